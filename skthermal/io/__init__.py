"""Deployment files: save fitted models with skops and load them without
running code from the file, with a warning on version changes."""

from skthermal.io._persist import (
    SkthermalVersionWarning,
    UntrustedTypesError,
    load,
    read_metadata,
    save,
)

__all__ = [
    "SkthermalVersionWarning",
    "UntrustedTypesError",
    "load",
    "read_metadata",
    "save",
]
