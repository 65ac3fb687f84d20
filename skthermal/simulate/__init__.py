"""Physics-based thermal simulation of machine tools.

A lumped-parameter thermal network with heat sources, a thermo-elastic map to
displacements, realistic sensors and a vocabulary of switchable physical
effects; presets for the papers' machines and their test campaigns.
"""

from skthermal.simulate._drivers import AmbientProfile, DoorEvent, DutyCycle, Segment
from skthermal.simulate._effects import EFFECTS, Effect, describe_effects
from skthermal.simulate._machine import (
    CalibrationResult,
    ImplausibleDriverWarning,
    ThermalMachine,
)
from skthermal.simulate._solver import ModalSystem, linear_recurrence
from skthermal.simulate._spec import MachineSpec, SensorSpec

__all__ = [
    "EFFECTS",
    "AmbientProfile",
    "CalibrationResult",
    "DoorEvent",
    "DutyCycle",
    "Effect",
    "ImplausibleDriverWarning",
    "MachineSpec",
    "ModalSystem",
    "Segment",
    "SensorSpec",
    "ThermalMachine",
    "describe_effects",
    "linear_recurrence",
]
