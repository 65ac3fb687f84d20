"""Run tables: reading, writing, validation, column roles and loaders.

The run table is skthermal's data contract (see DATA_FORMAT): one row per
sample time of one run, with ``run``, ``time_s``, drivers, sensors
``T<name>_C`` / ``S<name>_ue`` and displacements ``disp_<axis>_um``. Also
synthetic generators with a known sensor structure, for tests and demos, and
the papers' test campaigns simulated with :mod:`skthermal.simulate`.
"""

from skthermal.datasets._batch import make_batch_campaign
from skthermal.datasets._campaigns import (
    make_etve,
    make_machine_b_tests,
    make_multipart_test,
)
from skthermal.datasets._combine import concat_runs
from skthermal.datasets._generators import make_sensor_groups
from skthermal.datasets._loaders import load_fl_thermal, read_runs, write_runs
from skthermal.datasets._proxy import ambient_proxy
from skthermal.datasets._runtable import (
    changes_since_start,
    driver_columns,
    sensor_columns,
    split_runs,
    target_columns,
    validate_runs,
)

__all__ = [
    "ambient_proxy",
    "changes_since_start",
    "concat_runs",
    "driver_columns",
    "load_fl_thermal",
    "make_batch_campaign",
    "make_etve",
    "make_machine_b_tests",
    "make_multipart_test",
    "make_sensor_groups",
    "read_runs",
    "sensor_columns",
    "split_runs",
    "target_columns",
    "validate_runs",
    "write_runs",
]
