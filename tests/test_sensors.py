"""Virtual sensors from thermal images, FBG strain correction and strain channels."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from skthermal.datasets import changes_since_start, validate_runs
from skthermal.selection import FCMClusterPicker
from skthermal.sensors import (
    FBGGauge,
    VirtualSensorExtractor,
    add_strain_channels,
    carrier_field_weights,
    correct_fbg_strain,
    correct_strain_channels,
    simulate_thermal_images,
)
from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine


@pytest.fixture(scope="module")
def machine():
    return ThermalMachine.from_preset("vmc-b")


@pytest.fixture
def stack(rng):
    return rng.normal(20.0, 1.0, size=(7, 12, 16))


# --------------------------------------------------------------- extractor


def test_spot_is_mean_of_pixel_group_and_frames(stack):
    ext = VirtualSensorExtractor(
        spot_size=3, centres={"a": (5, 7)}, frame_average=3
    ).fit(stack)
    out = ext.transform(stack)
    # 7 frames, blocks of 3: the last incomplete block is dropped.
    assert out.shape == (2, 1)
    expected = [stack[3 * b : 3 * b + 3, 4:7, 6:9].mean() for b in range(2)]
    np.testing.assert_allclose(out["Ta_C"], expected)
    assert ext.spots_.loc["Ta_C", ["row0", "row1", "col0", "col1"]].tolist() == [
        4,
        7,
        6,
        9,
    ]


def test_even_spot_size_and_image_edge(stack):
    ext = VirtualSensorExtractor(spot_size=2, centres=[[0, 0], [5, 5]]).fit(stack)
    out = ext.transform(stack)
    assert list(out.columns) == ["Tspot001_C", "Tspot002_C"]
    np.testing.assert_allclose(out["Tspot001_C"], stack[:, 0:2, 0:2].mean(axis=(1, 2)))
    # At the far corner only one pixel of the 2x2 group lies in the image.
    with pytest.raises(ValueError, match="covers 25% valid pixels"):
        VirtualSensorExtractor(spot_size=2, centres=[[11, 15]], min_coverage=0.5).fit(
            stack
        )
    low = VirtualSensorExtractor(spot_size=2, centres=[[11, 15]], min_coverage=0.25)
    np.testing.assert_allclose(
        low.fit(stack).transform(stack).iloc[:, 0], stack[:, 11, 15]
    )


def test_mask_limits_pixels_and_grid(stack):
    mask = np.zeros(stack.shape[1:], dtype=bool)
    mask[2:10, 4:12] = True
    stack = stack.copy()
    stack[:, ~mask] = np.nan  # pixels off the object may be anything
    ext = VirtualSensorExtractor(spot_size=3, grid=(2, 4), mask=mask).fit(stack)
    assert ext.n_sensors_ == 8
    # Cells of 4 rows x 2 columns over the mask's bounding box.
    assert ext.spots_["row"].tolist() == [4] * 4 + [8] * 4
    assert ext.spots_["col"].tolist() == [5, 7, 9, 11] * 2
    out = ext.transform(stack)
    # Spot at (4, 11) covers cols 10-12; col 12 is off the mask.
    np.testing.assert_allclose(
        out["Tspot004_C"], stack[:, 3:6, 10:12].mean(axis=(1, 2))
    )
    assert ext.spots_.loc["Tspot004_C", "n_pixels"] == 6
    labels = ext.spot_labels()
    assert labels.shape == mask.shape and labels[~mask].max() == 0


def test_strips_and_run_table_output(stack):
    ext = VirtualSensorExtractor(
        spot_size=1, strips={1: ((0, 0), (0, 10), 11), "b": ((2, 3), (8, 3), 3)}
    )
    time_s = np.arange(7) * 10.0
    out = ext.fit_transform(stack, time_s, run="R", extra={"disp_y_um": np.arange(7.0)})
    names = [f"Tstrip1_{k:02d}_C" for k in range(1, 12)] + [
        "Tstripb_01_C",
        "Tstripb_02_C",
        "Tstripb_03_C",
    ]
    assert list(out.columns) == ["run", "time_s", *names, "disp_y_um"]
    np.testing.assert_allclose(out["Tstrip1_03_C"], stack[:, 0, 2])
    np.testing.assert_allclose(out["Tstripb_02_C"], stack[:, 5, 3])
    validate_runs(out)
    assert ext.spots_.loc["Tstripb_03_C", "strip"] == "b"


def test_frame_average_keeps_extra_aligned(stack):
    ext = VirtualSensorExtractor(spot_size=1, centres=[[0, 0]], frame_average=2)
    out = ext.fit_transform(stack, np.arange(7.0), extra={"x": np.arange(7.0)})
    assert out["time_s"].tolist() == [0.5, 2.5, 4.5]
    assert out["x"].tolist() == [0.5, 2.5, 4.5]


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({}, "Place some spots"),
        ({"grid": (0, 3)}, "grid must be"),
        ({"centres": {"bad-name": (1, 1)}}, "letters and digits"),
        ({"strips": {"s_1": ((0, 0), (1, 1), 2)}}, "letters and digits"),
        ({"strips": {"s": ((0, 0), 2)}}, "must be"),
        ({"strips": {}}, "strips is empty"),
        ({"centres": [[1, 1]], "mask": np.ones((3, 3), bool)}, "mask has shape"),
        ({"centres": [[1, 1]], "spot_size": 0}, "spot_size"),
        ({"centres": [[1, 1]], "min_coverage": 0}, "min_coverage"),
        ({"centres": [[50, 1]]}, "covers 0%"),
        (
            {
                "centres": {"a": (1, 1)},
                "strips": {"x": ((1, 1), (2, 2), 2)},
                "grid": (1, 1),
            },
            None,
        ),
    ],
)
def test_layout_errors(stack, kwargs, message):
    ext = VirtualSensorExtractor(**kwargs)
    if message is None:
        assert ext.fit(stack).n_sensors_ == 4
    else:
        with pytest.raises(ValueError, match=message):
            ext.fit(stack)


def test_given_centres_at_one_pixel_are_refused(stack):
    # Two given spots at one pixel: two copies of one column, silently.
    for centres in ([[5, 5], [5, 5]], {"a": (5, 5), "b": (5, 5)}):
        with pytest.raises(ValueError, match=r"share the centre \(row 5, col 5\)"):
            VirtualSensorExtractor(centres=centres).fit(stack)


def test_images_below_absolute_zero_or_in_kelvin_are_named(stack):
    ext = VirtualSensorExtractor(centres=[[5, 5]]).fit(stack)
    cold = stack.copy()
    cold[3, 5, 5] = -400.0
    with pytest.raises(ValueError, match=r"frame 3, pixel \(row 5, col 5\): below"):
        ext.transform(cold)
    with pytest.warns(UserWarning, match=r"like kelvin"):
        ext.transform(stack + 273.15)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ext.transform(stack)
        ext.transform(stack + 60.0)  # a hot spindle nose: still °C


def test_transform_errors(stack):
    ext = VirtualSensorExtractor(centres=[[5, 5]], frame_average=2)
    with pytest.raises(ValueError, match="not fitted"):
        ext.transform(stack)
    ext.fit(stack)
    with pytest.raises(ValueError, match="fitted on 12x16"):
        ext.transform(stack[:, :10])
    # A flattened stack was taken as one image and time_s blamed.
    with pytest.raises(
        ValueError,
        match=r"is one image, but time_s holds 7 .*"
        r"stack\.reshape\(-1, 12, 16\)",
    ):
        ext.transform(stack[0], time_s=np.arange(7.0))
    with pytest.raises(ValueError, match="fewer than frame_average"):
        ext.transform(stack[:1])
    with pytest.raises(ValueError, match="increase strictly"):
        ext.transform(stack, [0, 1, 2, 2, 3, 4, 5])
    with pytest.raises(ValueError, match="one value per frame"):
        ext.transform(stack, extra={"x": [1.0, 2.0]})
    with pytest.raises(ValueError, match="extra is a Series; give a DataFrame"):
        ext.transform(stack, extra=pd.Series(np.zeros(stack.shape[0]), name="rpm"))
    bad = stack.copy()
    bad[3, 5, 6] = np.nan
    with pytest.raises(ValueError, match=r"frame 3, pixel \(row 5, col 6\)"):
        ext.transform(bad)
    with pytest.raises(ValueError, match="shape"):
        ext.fit(np.zeros(5))
    # Datetimes would otherwise be read as nanoseconds.
    times = pd.date_range("2024-01-01 08:00", periods=stack.shape[0], freq="10s")
    for t in (times, times - times[0]):
        with pytest.raises(ValueError, match="time_s holds .*64"):
            ext.transform(stack, t)
    with pytest.raises(ValueError, match=r"time_s must hold numbers"):
        ext.transform(stack, ["a"] * stack.shape[0])


def test_simulated_images_check_their_arguments(machine):
    from skthermal.simulate import DutyCycle

    duty = DutyCycle.heat_cool(8000, heat_h=0.2, cool_h=0.2)
    for blur in (-3.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="'blur_px' parameter"):
            simulate_thermal_images(machine, duty, blur_px=blur)
    with pytest.raises(ValueError, match="machine must be a ThermalMachine"):
        simulate_thermal_images(None, duty)
    with pytest.raises(ValueError, match="emissivity must be a number"):
        simulate_thermal_images(machine, duty, emissivity="x")


def test_layout_is_fixed_at_fit(stack):
    mask = np.ones(stack.shape[1:], dtype=bool)
    ext = VirtualSensorExtractor(grid=(2, 2), mask=mask).fit(stack)
    before = ext.transform(stack)
    mask[:6] = False  # the user's array changes after fit
    pd.testing.assert_frame_equal(ext.transform(stack), before)
    # A grid finer than the valid pixels would give spots the same centre.
    mask[:] = False
    mask[2:5, 4:12] = True
    with pytest.raises(ValueError, match=r"grid=\(4, 2\) is finer .* \(3 rows"):
        VirtualSensorExtractor(grid=(4, 2), mask=mask).fit(stack)


# ---------------------------------------------------------- simulated images


def test_field_weights_are_means_of_nodes(machine):
    w, regions = carrier_field_weights(machine.spec.nodes, (40, 60), blur_px=1.0)
    np.testing.assert_allclose(w.sum(axis=0), 1.0)
    assert set(np.unique(regions)) == {0, 1, 2, 3}
    with pytest.raises(ValueError, match="missing"):
        carrier_field_weights(["a", "b"], (40, 60))
    with pytest.raises(ValueError, match="shape"):
        carrier_field_weights(machine.spec.nodes, (10, 60))


def test_noiseless_frames_show_node_temperatures(machine):
    sim = simulate_thermal_images(
        machine,
        DutyCycle.heat_cool(8000, heat_h=1, cool_h=0.5),
        20.0,
        shape=(40, 60),
        sample_period_s=120,
        emissivity=1.0,
        blur_px=0.0,
        noise_C=0.0,
        fixed_pattern_C=0.0,
        random_state=0,
    )
    assert sim.frames.shape == (46, 40, 60) and len(sim.runs) == 46
    boss = sim.frames[:, sim.regions == 2]
    np.testing.assert_allclose(
        boss, np.repeat(sim.states[["boss"]].to_numpy(), boss.shape[1], 1)
    )
    tool = sim.frames[:, sim.regions == 3].mean(axis=1)
    np.testing.assert_allclose(tool, sim.states["tool"])
    # Far end of the carrier: between the carrier5 and carrier6 nodes, nearer 6.
    r, c = np.argwhere(sim.regions == 1).max(axis=0)
    c5, c6 = sim.states["carrier5"].to_numpy(), sim.states["carrier6"].to_numpy()
    share = (sim.frames[1:, r, c] - c5[1:]) / (c6[1:] - c5[1:])
    assert np.all((share > 0.9) & (share <= 1.0))
    assert sim.mask.sum() == (sim.regions > 0).sum()


def test_emissivity_pulls_towards_surroundings(machine):
    kw = {
        "shape": (30, 40),
        "sample_period_s": 300,
        "noise_C": 0.0,
        "fixed_pattern_C": 0.0,
    }
    duty = DutyCycle([(3600, 8000)])
    hi = simulate_thermal_images(machine, duty, 20.0, emissivity=1.0, **kw)
    lo = simulate_thermal_images(machine, duty, 20.0, emissivity=0.5, **kw)
    rise_hi = (
        hi.frames[-1, hi.regions == 2].mean() - hi.frames[0, hi.regions == 2].mean()
    )
    rise_lo = (
        lo.frames[-1, lo.regions == 2].mean() - lo.frames[0, lo.regions == 2].mean()
    )
    assert 0.45 < rise_lo / rise_hi < 0.55
    with pytest.raises(ValueError, match="emissivity"):
        simulate_thermal_images(machine, duty, emissivity=1.5, **kw)
    with pytest.raises(ValueError, match="noise_C"):
        simulate_thermal_images(machine, duty, noise_C=-1, shape=(30, 40))


def test_image_workflow_end_to_end(machine):
    """Hundreds of spots -> GM(0,N) + fuzzy clusters -> 4 spots -> a model."""
    train = simulate_thermal_images(
        machine, DutyCycle.heat_cool(8000, heat_h=2, cool_h=1), 20.0, random_state=0
    )
    test = simulate_thermal_images(
        machine,
        DutyCycle([(3600, 4000), (3600, 8000), (3600, 0)]),
        AmbientProfile(mean_C=21.0, trend_C_per_h=0.3),
        run="test",
        random_state=1,
    )
    ext = VirtualSensorExtractor(grid=(15, 35), spot_size=3, mask=train.mask)
    ext.fit(train.frames)
    assert ext.n_sensors_ > 200
    target = "disp_y_um"
    a = ext.transform(
        train.frames, train.time_s, run="train", extra=train.runs[[target]]
    )
    b = ext.transform(test.frames, test.time_s, run="test", extra=test.runs[[target]])
    spots = list(ext.get_feature_names_out())
    picker = FCMClusterPicker(n_clusters=4, scorer="gm1n", random_state=0)
    picker.fit(a[spots], a[target], groups=np.zeros(len(a)))  # one run
    picked = list(picker.get_feature_names_out())
    assert len(picked) == 4
    a, b = changes_since_start(a), changes_since_start(b)
    model = LinearRegression().fit(a[picked], a[target])
    rmse = np.sqrt(np.mean((model.predict(b[picked]) - b[target]) ** 2))
    assert rmse < 0.05 * b[target].abs().max()


# ------------------------------------------------------------------- FBG


def test_correct_fbg_strain_hand_computation():
    raw = np.array([[0.0, 1.0], [20.0, 9.64], [40.0, 18.28]])
    temp = np.array([[20.0, 25.0], [21.0, 26.0], [22.0, 27.0]])
    np.testing.assert_allclose(
        correct_fbg_strain(raw, temp), [[0.0, 1.0], [11.36, 1.0], [22.72, 1.0]]
    )
    # One temperature series for both gratings, a fixed reference.
    np.testing.assert_allclose(
        correct_fbg_strain(raw, temp[:, 0], reference_C=19.0),
        raw - 8.64 * (temp[:, [0]] - 19.0),
    )
    # Every run referred to its own start.
    out = correct_fbg_strain(
        [0.0, 10.0, 5.0, 5.0], [20.0, 21.0, 30.0, 30.5], groups=["a", "a", "b", "b"]
    )
    np.testing.assert_allclose(out, [0.0, 1.36, 5.0, 0.68])
    np.testing.assert_allclose(
        correct_fbg_strain([0.0, 10.0], [20.0, 21.0], sensitivity_ue_per_C=10.0),
        [0.0, 0.0],
    )


@pytest.mark.parametrize(
    "raw, temp, kwargs, message",
    [
        ([0.0, np.nan], [20.0, 21.0], {}, "raw_ue is NaN"),
        ([0.0, 1.0], [20.0, 21.0, 22.0], {}, "does not match"),
        ([[0.0, 1.0]], [[20.0, 21.0, 3.0]], {}, "does not match"),
        ([0.0, 1.0], [20.0, 21.0], {"groups": ["a"]}, "one run label per row"),
        ([0.0, 1.0], [20.0, 21.0], {"sensitivity_ue_per_C": "x"}, "finite number"),
        (np.zeros((2, 2, 2)), [20.0, 21.0], {}, "shape"),
    ],
)
def test_correct_fbg_strain_errors(raw, temp, kwargs, message):
    with pytest.raises(ValueError, match=message):
        correct_fbg_strain(raw, temp, **kwargs)


@pytest.fixture(scope="module")
def simulated(machine):
    runs, states = machine.simulate(
        DutyCycle.heat_cool(8000, heat_h=1, cool_h=1),
        20.0,
        sample_period_s=120,
        random_state=0,
        return_states=True,
    )
    return runs, states


def test_strain_channels_follow_the_stated_model(simulated):
    runs, states = simulated
    gauges = {
        "carrier": FBGGauge({"carrier2": 0.5, "carrier3": 0.5}, sensor="T15_C"),
        "Scol_ue": {
            "nodes": {"column_surface": 1.0},
            "expansion_ue_per_C": 10.0,
            "gradient": ("column_surface", "column_core"),
            "bending_ue_per_C": 3.0,
        },
    }
    out = add_strain_channels(runs, states, gauges, noise_ue=0.0)
    dT = states - states.iloc[0]
    np.testing.assert_allclose(
        out["Scarrier_ue"], 19.64 * dT[["carrier2", "carrier3"]].mean(axis=1)
    )
    np.testing.assert_allclose(
        out["Scol_ue"],
        18.64 * dT["column_surface"] + 3.0 * (dT["column_surface"] - dT["column_core"]),
    )
    validate_runs(out)
    assert list(out.columns[: runs.shape[1]]) == list(runs.columns)
    # The correction removes the grating's own 8.64 µε/°C, given its temperature.
    exact = runs.assign(Tg_C=states[["carrier2", "carrier3"]].mean(axis=1).to_numpy())
    exact = add_strain_channels(
        exact, states, {"carrier": gauges["carrier"]}, noise_ue=0.0
    )
    fixed = correct_strain_channels(exact, {"Scarrier_ue": "Tg_C"})
    np.testing.assert_allclose(
        fixed["Scarrier_ue"],
        11.0 * dT[["carrier2", "carrier3"]].mean(axis=1),
        atol=1e-9,
    )
    # Without a mapping, the recorded co-located sensors are used.
    auto = correct_strain_channels(out)
    manual = correct_strain_channels(out, {"Scarrier_ue": "T15_C"})
    np.testing.assert_allclose(auto["Scarrier_ue"], manual["Scarrier_ue"])


def test_strain_channels_restart_every_run(machine):
    parts = [
        machine.simulate(
            DutyCycle.heat_cool(rpm, heat_h=0.5, cool_h=0.5),
            ambient,
            sample_period_s=300,
            run=name,
            return_states=True,
            random_state=0,
        )
        for name, rpm, ambient in (("a", 4000, 20.0), ("b", 8000, 23.0))
    ]
    runs = pd.concat([p[0] for p in parts], ignore_index=True)
    states = pd.concat([p[1] for p in parts], ignore_index=True)
    out = add_strain_channels(
        runs, states, {"b": FBGGauge({"boss": 1.0})}, noise_ue=0.0
    )
    starts = out.groupby("run")["Sb_ue"].first()
    np.testing.assert_allclose(starts, 0.0)
    # A run table whose runs are the index (as split_runs gives X) is read
    # the same way: its run level, not one run for all rows.
    indexed = runs.set_index(["run", "time_s"])
    temp = next(c for c in runs.columns if c.startswith("T") and c.endswith("_C"))
    by_index = add_strain_channels(
        indexed, states, {"b": FBGGauge({"boss": 1.0})}, noise_ue=0.0
    )
    np.testing.assert_allclose(by_index["Sb_ue"].to_numpy(), out["Sb_ue"].to_numpy())
    back = correct_strain_channels(by_index, {"Sb_ue": temp})
    np.testing.assert_allclose(
        back["Sb_ue"].to_numpy(),
        correct_strain_channels(out, {"Sb_ue": temp})["Sb_ue"].to_numpy(),
    )


@pytest.mark.parametrize(
    "gauges, message",
    [
        ({}, "empty"),
        ([FBGGauge({"boss": 1.0})], "must be a dict"),
        ({"g": FBGGauge({"nope": 1.0})}, "unknown node"),
        ({"g": FBGGauge({"boss": 0.5})}, "sum to 0.5"),
        ({"g": FBGGauge({})}, "names no node"),
        ({"g-1": FBGGauge({"boss": 1.0})}, "does not make a strain column"),
        ({"g": {"nodes": {"boss": 1.0}, "colour": 1}}, "Gauge 'g'"),
        ({"g": FBGGauge({"boss": 1.0}, sensor="boss")}, "not a temperature column"),
        ({"g": FBGGauge(["boss"])}, r"nodes must be a dict \{node: weight\}"),
    ],
)
def test_strain_channel_errors(simulated, gauges, message):
    runs, states = simulated
    with pytest.raises(ValueError, match=message):
        add_strain_channels(runs, states, gauges)


def test_strain_channel_table_errors(simulated):
    runs, states = simulated
    g = {"g": FBGGauge({"boss": 1.0})}
    with pytest.raises(ValueError, match="rows"):
        add_strain_channels(runs, states.iloc[:-1], g)
    with pytest.raises(ValueError, match="noise_ue"):
        add_strain_channels(runs, states, g, noise_ue=-1.0)
    with pytest.raises(ValueError, match="already has"):
        add_strain_channels(add_strain_channels(runs, states, g), states, g)
    with pytest.raises(ValueError, match="not in the table"):
        correct_strain_channels(runs, {"Sg_ue": "T01_C"})
    with pytest.raises(ValueError, match="records no uncorrected gauge"):
        correct_strain_channels(runs)
    with pytest.raises(
        ValueError, match=r"states has duplicate column\(s\) \['boss'\]"
    ):
        add_strain_channels(runs, pd.concat([states, states[["boss"]]], axis=1), g)
    with pytest.raises(ValueError, match="Column 'extra' is not numeric"):
        add_strain_channels(runs, states.assign(extra="x"), g)


def test_strain_channels_accumulate_and_are_corrected_once(simulated):
    runs, states = simulated
    first = add_strain_channels(
        runs, states, {"a": FBGGauge({"boss": 1.0}, sensor="T63_C")}, random_state=0
    )
    both = add_strain_channels(
        first, states, {"b": FBGGauge({"boss": 1.0}, sensor="T15_C")}, random_state=1
    )
    # The gauges of both calls are recorded, so both get corrected.
    assert list(both.attrs["fbg_gauges"]) == ["Sa_ue", "Sb_ue"]
    once = correct_strain_channels(both)
    assert once.attrs["fbg_corrected"] == ["Sa_ue", "Sb_ue"]
    for col, sensor in (("Sa_ue", "T63_C"), ("Sb_ue", "T15_C")):
        expected = correct_strain_channels(both, {col: sensor})[col]
        np.testing.assert_allclose(once[col], expected)
    # A second correction would subtract the sensitivity twice.
    with pytest.raises(ValueError, match="already corrected"):
        correct_strain_channels(once)
    with pytest.raises(ValueError, match=r"\['Sa_ue'\] are already temperature"):
        correct_strain_channels(once, {"Sa_ue": "T63_C"})


def test_fused_temperature_and_strain_beat_temperatures_alone(machine):
    """001 §5.4: strain added to a few temperatures improves the Y prediction."""
    gauges = {
        "carrier": FBGGauge({"carrier2": 0.5, "carrier3": 0.5}, sensor="T15_C"),
        "column": FBGGauge(
            {"column_surface": 0.5, "column_core": 0.5},
            gradient=("column_surface", "column_core"),
            bending_ue_per_C=3.0,
            sensor="T04_C",
        ),
        "boss": FBGGauge({"boss": 1.0}, sensor="T63_C"),
    }

    def run(duty, ambient, name, seed):
        r, s = machine.simulate(
            duty,
            ambient,
            sample_period_s=60,
            run=name,
            random_state=seed,
            return_states=True,
        )
        r = add_strain_channels(r, s, gauges, random_state=seed)
        return changes_since_start(correct_strain_channels(r))

    train = run(
        DutyCycle.from_hours([(2, 4000), (1, 0), (2, 4000), (3, 0)]),
        AmbientProfile(mean_C=20.0, day_amplitude_C=0.4, start_hour=8.0),
        "IV",
        0,
    )
    tests = [
        run(
            DutyCycle.heat_cool(4000, heat_h=1, cool_h=1),
            AmbientProfile(mean_C=20.5, trend_C_per_h=0.2),
            "I",
            1,
        ),
        run(
            DutyCycle.heat_cool(4000, heat_h=3, cool_h=2),
            AmbientProfile(mean_C=21.5, trend_C_per_h=0.15),
            "III",
            2,
        ),
        run(
            DutyCycle.heat_cool(8000, heat_h=1, cool_h=1),
            AmbientProfile(mean_C=20.0, trend_C_per_h=-0.1),
            "V",
            3,
        ),
    ]
    temps = ["T15_C", "T04_C", "T63_C"]
    fused = temps + ["Scarrier_ue", "Scolumn_ue", "Sboss_ue"]

    def mean_rmse(cols):
        model = LinearRegression().fit(train[cols], train["disp_y_um"])
        return np.mean(
            [
                np.sqrt(np.mean((model.predict(t[cols]) - t["disp_y_um"]) ** 2))
                for t in tests
            ]
        )

    assert mean_rmse(fused) < 0.9 * mean_rmse(temps)


def test_missing_extra_values_are_named(stack):
    ext = VirtualSensorExtractor(spot_size=3, centres={"a": (5, 7)}).fit(stack)
    disp = np.r_[np.nan, np.arange(6.0)]
    with pytest.raises(ValueError, match=r"'disp_y_um' is missing .* at frame 0"):
        ext.transform(stack, extra={"disp_y_um": disp})


def test_strain_functions_name_bad_input():
    runs = pd.DataFrame(
        {
            "run": ["a", "a", "a", "b", "b", "b"],
            "time_s": [0.0, 60.0, 120.0, 0.0, 60.0, 120.0],
            "T1_C": [20.0, 21.0, 22.0, 25.0, 26.0, 27.0],
            "Sram_ue": [0.0, 20.0, 40.0, 0.0, 20.0, 40.0],
        }
    )
    text = runs.astype({"Sram_ue": object})
    text.loc[2, "Sram_ue"] = "n/a"
    with pytest.raises(ValueError, match=r"Column 'Sram_ue' is not numeric: row 2"):
        correct_strain_channels(text, {"Sram_ue": "T1_C"})
    gap = runs.copy()
    gap.loc[4, "T1_C"] = np.nan
    with pytest.raises(ValueError, match=r"Column 'T1_C' is missing .* run 'b'"):
        correct_strain_channels(gap, {"Sram_ue": "T1_C"})
    with pytest.raises(ValueError, match="runs is empty"):
        correct_strain_channels(runs.iloc[:0], {"Sram_ue": "T1_C"})
    # A run out of time order would be referred to the wrong first row.
    swapped = runs.iloc[[1, 0, 2, 3, 4, 5]]
    with pytest.raises(ValueError, match=r"in run 'a' row 1 has time_s=0 after 60"):
        correct_strain_channels(swapped, {"Sram_ue": "T1_C"})
    states = pd.DataFrame({"carrier2": np.linspace(20.0, 21.0, 6)})
    gauges = {"c": FBGGauge({"carrier2": 1.0})}
    with pytest.raises(ValueError, match=r"in run 'a' row 1 has time_s=0"):
        add_strain_channels(swapped, states, gauges)
    # One temperature for many readings corrects nothing: refused.
    for temperature in (20.0, [20.0], np.full((1, 2), 20.0)):
        with pytest.raises(ValueError, match="one co-located temperature per"):
            correct_fbg_strain(np.zeros((5, 2)), temperature)


def test_extractor_run_label_and_strip_spots():
    frames = 20 + np.random.default_rng(0).normal(0, 0.1, (6, 10, 12))
    extractor = VirtualSensorExtractor(grid=(2, 2)).fit(frames)
    for run in (np.nan, ["A", "B"]):
        with pytest.raises(ValueError, match="run must be one run label"):
            extractor.transform(frames, np.arange(6) * 10.0, run=run)
    assert extractor.transform(frames, run="A")["run"].eq("A").all()
    with pytest.raises(ValueError, match="5 spots over 2 pixel.*at most 2"):
        VirtualSensorExtractor(strips={1: ((2, 2), (2, 3), 5)}).fit(frames)
    strip = VirtualSensorExtractor(strips={1: ((2, 2), (2, 3), 2)}).fit(frames)
    assert len(strip.spots_) == 2


def test_correct_fbg_strain_refuses_series_in_another_order():
    # A temperature log sorted otherwise than the strain file was paired by
    # position: [0, 38.64, 112.48] instead of [0, 12.72, 17.44].
    raw = pd.Series([0.0, 30.0, 52.0])
    temp = pd.Series([20.0, 22.0, 24.0])
    with pytest.raises(ValueError, match="raw_ue and temperature_C are pandas obj"):
        correct_fbg_strain(raw, temp.iloc[::-1])
    got = correct_fbg_strain(raw, temp)
    np.testing.assert_allclose(got, [0.0, 12.72, 17.44])


def test_fbg_groups_with_a_reference_temperature_warn():
    # They were ignored without a word.
    with pytest.warns(UserWarning, match="groups are not used with a reference_C"):
        out = correct_fbg_strain(
            [0.0, 10.0, 0.0, 10.0],
            [20.0, 21.0, 22.0, 23.0],
            reference_C=20.0,
            groups=["a", "a", "b", "b"],
        )
    np.testing.assert_allclose(out, [0.0, 10.0 - 8.64, -2 * 8.64, 10.0 - 3 * 8.64])
