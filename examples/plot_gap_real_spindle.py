"""
Sim-to-real gap on a real spindle test
======================================

The public spindle thermal test CAIVIAC/FL_THERMAL (46 h, 15 s sampling,
speed steps alternating with rest, 16 temperatures, 5 displacement channels)
is compared with a ``spindle-rig`` machine calibrated on the first 60% of
the record (as in ``plot_own_machine.py``), without any effect, and the gap
is diagnosed.

The record has no air temperature. As an ambient proxy we take the sensor
least coupled to the spindle (:func:`skthermal.datasets.ambient_proxy`). The
sensor locations are not documented, so only the five displacement channels
are compared. The 46 h record is one run; it is held out in 8 h blocks, each
simulated from the start of the record.

Run: ``python examples/plot_gap_real_spindle.py [path/to/fl_thermal_spindle.csv.gz]``
(default: ``../shared/data/fl_thermal_spindle.csv.gz``; about half a minute).
"""

# %%
import sys
import time
from pathlib import Path

from skthermal.datasets import ambient_proxy, load_fl_thermal
from skthermal.gap import diagnose, diagnose_runs
from skthermal.simulate import ThermalMachine

try:
    HERE = Path(__file__).resolve().parent
except NameError:  # run by sphinx-gallery, from the examples folder
    HERE = Path.cwd()
default = HERE.parents[1] / "shared" / "data"
given = len(sys.argv) > 1 and not sys.argv[1].startswith("-")
path = Path(sys.argv[1]) if given else default / "fl_thermal_spindle.csv.gz"
if not path.exists():
    print(f"{path} not found: pass the path of fl_thermal_spindle.csv.gz")
    raise SystemExit(0)
runs = load_fl_thermal(path)
print(runs.shape, "columns:", list(runs.columns[:8]), "...")

# %%
# Ambient proxy: the sensor least correlated with low-passed spindle losses.
proxy, scores = ambient_proxy(runs, return_scores=True)
print("correlation with spindle heating:", scores.sort_values()[:4].round(2).to_dict())
print(f"ambient proxy: {proxy}")

channels = [c for c in runs.columns if c.startswith("disp_")]
measured = runs[["run", "time_s", "spindle_rpm", *channels]].copy()
measured["ambient_C"] = runs[proxy]

# %%
# The machine: the spindle-rig sketch, its heat sources and thermo-elastic
# coefficients calibrated on the first 60% of the record (one sample a
# minute).
rig = ThermalMachine.from_preset("spindle-rig", effects=[])
params = ["q.bearing_W", "q.motor_W_per_krpm", "q.belt_W_per_krpm"]
params += [k for k, v in rig.params.items() if k.startswith("k.") and v != 0]
train = measured.iloc[: int(0.6 * len(measured)) : 4]
t0 = time.perf_counter()
machine, _ = rig.calibrate(train, params, channels=channels)
print(f"calibrated {len(params)} parameters in {time.perf_counter() - t0:.0f} s")

# %%
t0 = time.perf_counter()
report = diagnose(
    machine,
    measured,
    channels=channels,
    block_hours=8.0,
    max_samples=400,
    n_jobs=2,
)
print(f"diagnosis in {time.perf_counter() - t0:.0f} s")
print(report.verdict())
cols = [
    "effect",
    "gap_before",
    "gap_after",
    "shrink",
    "p_value",
    "runs_improved",
    "explains",
    "fitted",
]
print(report.ranking[cols].round(3).to_string(index=False))
where = report.where["regimes"]
print(where[where["model"] == "base calibrated"].round(3).to_string(index=False))
print(report.how_far.round(3).to_string(index=False))

# %%
# The same question from the simulation's run table alone, as a user with
# another tool's simulation would ask it: export the calibrated rig's
# noise-free response, cut both tables into the same 8 h blocks, and let
# diagnose_runs test every effect as a discrepancy term.
simulated = machine.simulate_drivers(
    measured["time_s"].to_numpy(),
    measured["spindle_rpm"].to_numpy(),
    measured["ambient_C"].to_numpy(),
    noise=False,
)[["time_s", "spindle_rpm", "ambient_C", *channels]]
block = (measured["time_s"] // (8 * 3600)).astype(int).to_numpy()
# Each block is a run of its own: its time_s counts from its first row.
since = measured["time_s"] - measured.groupby(block)["time_s"].transform("first")
external = diagnose_runs(
    simulated.assign(run=block, time_s=since.to_numpy()),
    measured.assign(run=block, time_s=since.to_numpy()),
    channels=channels,
)
print(external.verdict())
print(
    external.ranking[
        [
            "effect",
            "gap_before",
            "gap_after",
            "share_of_explainable",
            "lr_p_value",
            "whiteness_before",
            "white_band",
        ]
    ]
    .round(3)
    .to_string(index=False)
)

# %%
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    run = list(report.timelines)[2]
    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    report.plot_overlay(run, channel=channels[0], ax=axes[0])
    report.plot_timeline(run, channel=channels[0], ax=axes[1])
    fig.tight_layout()
    plt.show()
