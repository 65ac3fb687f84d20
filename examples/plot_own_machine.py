"""
Model your own machine: a spindle rig calibrated to a real record
=================================================================

From a sketch of a machine to a calibrated model, on the public spindle test
CAIVIAC/FL_THERMAL (46 h, 15 s sampling, 16 temperatures, 5 displacement
channels of the spindle nose):

1. start from the ``spindle-rig`` preset, written as a TOML file to edit;
2. read the file back with :meth:`ThermalMachine.from_spec`;
3. calibrate its heat sources and thermo-elastic coefficients on the first
   60% of the record;
4. check it on the last 40%, against a linear regression on the 16
   temperatures.

The record has no air temperature: as in the gap example, the sensor least
correlated with low-passed spindle losses stands in for it.

Run: ``python examples/plot_own_machine.py [path/to/fl_thermal_spindle.csv.gz]``
(default: ``../shared/data/fl_thermal_spindle.csv.gz``; under ten seconds).
"""

# %%
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from sklearn.linear_model import LinearRegression

from skthermal.datasets import ambient_proxy, load_fl_thermal
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

# %%
# Ambient proxy: the sensor least correlated with low-passed spindle losses.
sensors = [c for c in runs.columns if c.startswith("T")]
proxy = ambient_proxy(runs)
runs["ambient_C"] = runs[proxy]
print(f"ambient proxy: {proxy}")

# %%
# The machine as a file: write the preset, edit it (here: as is), read it.
folder = Path(tempfile.mkdtemp())
ThermalMachine.from_preset("spindle-rig").spec.to_toml(folder / "my_rig.toml")
rig = ThermalMachine.from_spec(folder / "my_rig.toml", effects=[])
print(rig)

# %%
# Calibrate on the first 60% (at one sample a minute, to save time): the
# heat sources and every non-zero thermo-elastic coefficient, each between a
# tenth and ten times the sketch's value.
every = 4
split = int(0.6 * len(runs))
train = runs.iloc[:split:every]
targets = rig.targets
params = ["q.bearing_W", "q.motor_W_per_krpm", "q.belt_W_per_krpm"]
params += [k for k, v in rig.params.items() if k.startswith("k.") and v != 0]
t0 = time.perf_counter()
fitted, result = rig.calibrate(train, params, channels=targets)
print(f"calibrated {len(params)} parameters in {time.perf_counter() - t0:.0f} s")
print("train RMSE (µm) before:", result.rmse_before.round(1).to_dict())
print("train RMSE (µm) after: ", result.rmse_after.round(1).to_dict())

# %%
# Held out: the last 40%, simulated from the start of the record.
sampled = runs.iloc[::every]
y = sampled[targets].to_numpy() - sampled[targets].to_numpy()[0]
test = np.arange(len(sampled)) * every >= split
for name, machine in (("sketch", rig), ("calibrated", fitted)):
    sim = machine.simulate_drivers(
        sampled["time_s"], sampled["spindle_rpm"], sampled["ambient_C"], noise=False
    )
    err = sim[targets].to_numpy()[test] - y[test]
    print(f"{name:>10} test RMSE (µm):", np.sqrt((err**2).mean(axis=0)).round(1))
X = sampled[sensors].to_numpy()
linear = LinearRegression().fit(X[~test], y[~test])
err = linear.predict(X[test]) - y[test]
print("linear regression test RMSE (µm):", np.sqrt((err**2).mean(axis=0)).round(1))

# %%
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    sim = fitted.simulate_drivers(
        sampled["time_s"], sampled["spindle_rpm"], sampled["ambient_C"], noise=False
    )
    hours = sampled["time_s"].to_numpy() / 3600.0
    fig, axes = plt.subplots(len(targets), 1, figsize=(9, 9), sharex=True)
    for ax, (j, ch) in zip(axes, enumerate(targets), strict=True):
        ax.plot(hours, y[:, j], lw=1, label="measured")
        ax.plot(hours, sim[ch], lw=1, label="calibrated spindle rig")
        ax.axvline(hours[test][0], color="k", ls=":")
        ax.set_ylabel(f"{ch} (µm)")
    axes[0].legend(loc="upper left")
    axes[-1].set_xlabel("time (h)")
    fig.tight_layout()
    plt.show()
