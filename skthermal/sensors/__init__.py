"""Sensors beyond the thermocouple: virtual temperature sensors from thermal
images and fibre Bragg grating (FBG) strain sensors."""

from skthermal.sensors._fbg import (
    FBG_SENSITIVITY_UE_PER_C,
    FBGGauge,
    add_strain_channels,
    correct_fbg_strain,
    correct_strain_channels,
)
from skthermal.sensors._thermal_image import (
    ThermalImageRun,
    VirtualSensorExtractor,
    carrier_field_weights,
    simulate_thermal_images,
)

__all__ = [
    "FBG_SENSITIVITY_UE_PER_C",
    "FBGGauge",
    "ThermalImageRun",
    "VirtualSensorExtractor",
    "add_strain_channels",
    "carrier_field_weights",
    "correct_fbg_strain",
    "correct_strain_channels",
    "simulate_thermal_images",
]
