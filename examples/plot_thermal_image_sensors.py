"""
Virtual temperature sensors from thermal images
===============================================

The thermal-imaging workflow of 001 §4.4 on a simulated spindle carrier: a
camera records the carrier every 15 s while the spindle heats and cools;
hundreds of virtual sensors (spots of averaged pixels) are extracted from the
images; grey influence and fuzzy c-means pick four of them; a model on the four
spots predicts the Y displacement of an unseen run.

Run: ``python examples/plot_thermal_image_sensors.py`` (the plot needs the
``plot`` extra: ``pip install "skthermal[plot]"``).
"""

# %%
# Two simulated runs with their image stacks (60 x 80 pixels, one frame per
# 15 s; 001 §4.4 stored one every 10 s): a training run (8000 rpm, 2 h on,
# 1 h off) and an unseen test run (4000 then 8000 rpm, warmer, rising ambient).
import numpy as np
from sklearn.linear_model import LinearRegression

from skthermal import FCMClusterPicker
from skthermal.datasets import changes_since_start
from skthermal.metrics import residual_band, rmse
from skthermal.sensors import VirtualSensorExtractor, simulate_thermal_images
from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine

machine = ThermalMachine.from_preset("vmc-b")
train = simulate_thermal_images(
    machine,
    DutyCycle.heat_cool(8000, heat_h=2, cool_h=1),
    20.0,
    sample_period_s=15,
    random_state=0,
)
test = simulate_thermal_images(
    machine,
    DutyCycle([(3600, 4000), (3600, 8000), (3600, 0)]),
    AmbientProfile(mean_C=21.0, trend_C_per_h=0.3),
    sample_period_s=15,
    run="test",
    random_state=1,
)
print("frames:", train.frames.shape)

# %%
# Virtual sensors: a 15 x 35 grid of 3 x 3-pixel spots over the machine (spots
# on the background are dropped), plus two strips along the carrier. Frames
# are averaged in pairs (one sample every 30 s), the displacement with them.
# The grey models need more samples than spots: 294 spots, 360 samples.
extractor = VirtualSensorExtractor(
    grid=(15, 35),
    spot_size=3,
    strips={1: ((12, 20), (12, 76), 15), 2: ((30, 20), (30, 76), 15)},
    mask=train.mask,
    frame_average=2,
).fit(train.frames)
target = "disp_y_um"
a = extractor.transform(
    train.frames, train.time_s, run="train", extra=train.runs[[target]]
)
b = extractor.transform(test.frames, test.time_s, run="test", extra=test.runs[[target]])
spots = list(extractor.get_feature_names_out())
print(f"{len(spots)} virtual sensors, {len(a)} samples per run")

# %%
# GM(0,N) grey influence of every spot (as 001 §4.4 ranked its 525 spots),
# fuzzy groups of spots that behave alike, and
# the most influential spot of each group (001 §4.4, Table 4-3).
picker = FCMClusterPicker(n_clusters=4, scorer="gm0n", random_state=0)
picker.fit(a[spots], a[target], groups=a["run"])  # one run
picked = list(picker.get_feature_names_out())
print("picked:", extractor.spots_.loc[picked, ["row", "col", "kind"]], sep="\n")

# %%
# A model on the four spots, trained on one run, scored on the other.
ca, cb = changes_since_start(a), changes_since_start(b)
model = LinearRegression().fit(ca[picked], ca[target])
pred = model.predict(cb[picked])
print(
    f"test run: RMSE {rmse(cb[target], pred):.2f} µm, residual band "
    f"±{residual_band(cb[target], pred):.2f} µm, of {cb[target].abs().max():.1f} µm"
)

# %%
# The last frame, the spots, the grey influence and the test prediction.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.5))
    im = axes[0].imshow(train.frames[480], cmap="inferno")
    fig.colorbar(im, ax=axes[0], label="°C")
    axes[0].set_title("Frame after 2 h at 8000 rpm")
    influence = np.zeros(train.mask.shape)
    s = extractor.spots_
    influence[s["row"], s["col"]] = picker.scores_
    axes[1].imshow(np.where(train.mask, influence, np.nan), cmap="viridis")
    axes[1].plot(s.loc[picked, "col"], s.loc[picked, "row"], "r+", ms=12)
    axes[1].set_title("GM(0,N) influence of the spots (picked: +)")
    axes[2].plot(cb["time_s"] / 3600, cb[target], label="simulated")
    axes[2].plot(cb["time_s"] / 3600, pred, "--", label="4-spot model")
    axes[2].set_xlabel("h")
    axes[2].set_ylabel("Y displacement (µm)")
    axes[2].legend()
    fig.tight_layout()
    plt.show()
