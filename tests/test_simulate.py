"""Tests of the thermal simulator (skthermal.simulate) and the campaigns."""

import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from skthermal.datasets import (
    make_etve,
    make_machine_b_tests,
    make_multipart_test,
    validate_runs,
)
from skthermal.simulate import (
    EFFECTS,
    AmbientProfile,
    DoorEvent,
    DutyCycle,
    ImplausibleDriverWarning,
    ModalSystem,
    ThermalMachine,
    describe_effects,
    linear_recurrence,
)
from skthermal.simulate._solver import first_order_lag

# --- numerics -----------------------------------------------------------------


@pytest.mark.parametrize("n", [0, 1, 7, 64, 65, 1000, 5000])
def test_linear_recurrence_matches_loop(n, rng):
    lam = np.r_[rng.uniform(0, 1, 3), 0.0, 0.999999]
    g = rng.normal(size=(n, 5))
    x = linear_recurrence(lam, g, np.ones(5))
    ref = np.empty((n + 1, 5))
    ref[0] = 1.0
    for k in range(n):
        ref[k + 1] = lam * ref[k] + g[k]
    np.testing.assert_allclose(x, ref, rtol=1e-10, atol=1e-10)


def _random_chain(rng, n):
    """Capacities, ``L + H`` and convection of a random chain of ``n`` nodes."""
    C = rng.uniform(1e3, 1e5, n)
    G = np.zeros((n, n))
    for i in range(n - 1):
        G[i, i + 1] = G[i + 1, i] = rng.uniform(1, 20)
    h = rng.uniform(0.1, 2, n)
    return C, np.diag(G.sum(axis=1)) - G + np.diag(h), h


def test_modal_step_matches_an_ode_solver(rng):
    """Exact discretisation: ZOH heat, linearly varying air, any step length."""
    n = 6
    C, K, h = _random_chain(rng, n)
    modal = ModalSystem.from_network(C, K)
    dt, steps = 60.0, 120
    Q = np.zeros((steps, n))
    Q[:50, 0] = 80.0
    Q[30:90, 3] = 25.0
    air = 20 + 3 * np.sin(np.arange(steps + 1) * dt / 2000)
    T = modal.step(np.full(n, 20.0), Q, h, air, dt)

    def f(t, T):
        k = min(int(t // dt), steps - 1)
        a = air[k] + (air[k + 1] - air[k]) * (t / dt - k)
        return (-K @ T + h * a + Q[k]) / C

    ref = solve_ivp(
        f,
        (0, steps * dt),
        np.full(n, 20.0),
        t_eval=np.arange(steps + 1) * dt,
        rtol=1e-10,
        atol=1e-10,
        max_step=dt / 8,
    )
    np.testing.assert_allclose(T, ref.y.T, atol=1e-6)


def test_modal_step_advances_several_responses_together(rng):
    """Parts stacked on a leading axis give each part's own response."""
    n = 5
    C, K, h = _random_chain(rng, n)
    modal = ModalSystem.from_network(C, K)
    steps = 90
    T0 = rng.normal(20.0, 2.0, (3, n))
    heat = rng.uniform(0.0, 50.0, (3, steps, 2))
    air = rng.normal(20.0, 1.0, (3, steps + 1))
    T = modal.step(T0, heat, h, air, 30.0, [1, 3])
    assert T.shape == (steps + 1, 3, n)
    for k in range(3):
        alone = modal.step(T0[k], heat[k], h, air[k], 30.0, [1, 3])
        np.testing.assert_allclose(T[:, k], alone, rtol=1e-12, atol=1e-10)


def test_first_order_lag_settles_and_starts_at_input():
    x = np.r_[np.zeros(10), np.ones(400)][:, None] * [1.0, 2.0]
    y = first_order_lag(x, tau=60.0, dt=10.0)
    np.testing.assert_allclose(y[0], x[0])
    np.testing.assert_allclose(y[-1], [1.0, 2.0], rtol=1e-6)
    # After one time constant past the step, 1 - 1/e of the way (FOH ramp).
    assert 0.5 < y[16, 0] < 0.7


# --- the machine ----------------------------------------------------------------


@pytest.fixture(scope="module")
def vmc_b():
    return ThermalMachine.from_preset("vmc-b")


def test_vmc_b_layout(vmc_b):
    assert vmc_b.sensors == [f"T{i:02d}_C" for i in range(1, 78)]
    assert vmc_b.targets == ["disp_x_um", "disp_y_um", "disp_z_um"]
    groups = vmc_b.spec.groups
    assert groups["carrier strip 1"][0] == "T08_C"
    assert groups["carrier strip 1"][-1] == "T33_C"
    assert len(groups["carrier strip 2"]) == 29
    assert groups["spindle boss"] == ["T63_C", "T64_C", "T65_C"]


def test_vmc_a_layout():
    machine = ThermalMachine.from_preset("vmc-a")
    assert machine.sensors == [f"T{i:02d}_C" for i in range(1, 27)]
    assert machine.spec.feed_axis == "x"


def test_simulated_run_is_a_valid_run_table(vmc_b):
    run = vmc_b.simulate(
        DutyCycle.heat_cool(4000, heat_h=1, cool_h=0.5),
        AmbientProfile(noise_C=0.05),
        run="A",
        random_state=0,
    )
    validate_runs(run, require_targets=True, require_drivers=True)
    assert run["time_s"].iloc[-1] == 5400.0
    meta = run.attrs["metadata"][0]
    assert meta["machine"] == "vmc-b" and meta["run"] == "A"
    assert meta["effect_sensor_lag"] and not meta["effect_sensor_drift"]
    # Quantised temperatures.
    assert np.allclose(run["T10_C"] / 0.125, np.round(run["T10_C"] / 0.125))


def test_seeded_simulation_is_reproducible(vmc_b):
    duty = DutyCycle.heat_cool(8000, heat_h=0.5, cool_h=0.5)
    a = vmc_b.simulate(duty, AmbientProfile(noise_C=0.1), random_state=3)
    b = vmc_b.simulate(duty, AmbientProfile(noise_C=0.1), random_state=3)
    c = vmc_b.simulate(duty, AmbientProfile(noise_C=0.1), random_state=4)
    pd.testing.assert_frame_equal(a, b)
    assert not a["disp_y_um"].equals(c["disp_y_um"])


def test_heating_raises_spindle_first_and_column_core_last(vmc_b):
    _, states = vmc_b.simulate(
        DutyCycle([(7200, 6000)]), noise=False, return_states=True
    )
    rise = states.iloc[-1] - states.iloc[0]
    assert rise["bearings"] > rise["carrier3"] > rise["column_core"] > 0
    # Response times (63% of the rise): minutes, tens of minutes, hours.
    minutes = vmc_b.response_times(6000, hours=48)
    assert 2 <= minutes["bearings"] <= 20
    carrier = minutes[[f"carrier{i}" for i in range(1, 7)]]
    assert carrier.min() >= 10 and carrier.median() <= 100
    assert minutes["column_core"] >= 180


def test_faster_spindle_heats_more_like_n_to_the_alpha(vmc_b):
    slow = vmc_b.simulate(DutyCycle([(3600, 4000)]), noise=False, return_states=True)
    fast = vmc_b.simulate(DutyCycle([(3600, 8000)]), noise=False, return_states=True)
    rise_slow = slow[1]["bearings"].iloc[-1] - 20.0
    rise_fast = fast[1]["bearings"].iloc[-1] - 20.0
    # Losses grow like n^1.65; stronger convection at speed takes some back.
    assert 1.8 < rise_fast / rise_slow < 3.2


def test_steady_initial_state_stays_put(vmc_b):
    run = vmc_b.simulate(DutyCycle([(7200, 3000)]), 21.0, initial="steady", noise=False)
    assert np.ptp(run["disp_y_um"]) < 1e-6
    assert np.ptp(run["T40_C"]) < 1e-6


# --- effects --------------------------------------------------------------------


def test_effect_vocabulary_is_documented():
    table = describe_effects()
    expected = {
        "sensor_lag",
        "speed_convection",
        "tool_growth",
        "ambient_transient",
        "feed_heating",
        "sensor_drift",
    }
    assert expected <= set(table["effect"])
    assert table["summary"].str.len().min() > 80
    assert set(EFFECTS) == set(table["effect"])


def test_effects_are_switchable_and_reported(vmc_b):
    bare = vmc_b.with_effects([])
    assert bare.effects == ()
    assert not any(bare.effect_status().values())
    both = bare.with_effects(add=["tool_growth", "sensor_lag"])
    assert both.effects == ("sensor_lag", "tool_growth")
    assert both.with_effects(remove="sensor_lag").effects == ("tool_growth",)
    with pytest.raises(ValueError, match="Unknown effect"):
        vmc_b.with_effects(add=["magic"])
    with pytest.raises(ValueError, match="did you mean 'sensor_lag'"):
        vmc_b.with_effects(add=["sensor_lagg"])


def test_tool_keeps_growing_after_the_spindle_stops(vmc_b):
    duty = DutyCycle.heat_cool(8000, heat_h=1, cool_h=1)
    on = vmc_b.simulate(duty, noise=False, return_states=True)[1]["tool"]
    stop = 120  # samples of 30 s: the spindle stops at 1 h
    # The tool's temperature rises for a while after the stop ...
    assert on.iloc[stop + 10] > on.iloc[stop] + 0.05
    off = vmc_b.with_effects(remove="tool_growth")
    still = off.simulate(duty, noise=False, return_states=True)[1]["tool"]
    # ... so Z grows more after the stop with the effect than without, and
    # the tool runs cooler while turning (the churned air cools it).
    z_on = vmc_b.simulate(duty, noise=False)["disp_z_um"]
    z_off = off.simulate(duty, noise=False)["disp_z_um"]
    rise_on = z_on.iloc[stop + 20] - z_on.iloc[stop]
    rise_off = z_off.iloc[stop + 20] - z_off.iloc[stop]
    assert rise_on > rise_off + 0.5
    assert on.iloc[stop] < still.iloc[stop]


def test_sensor_lag_gives_hysteresis(vmc_b):
    duty = DutyCycle.heat_cool(4000, heat_h=1, cool_h=1)
    lagged = vmc_b.simulate(duty, noise=False)
    direct = vmc_b.with_effects(remove="sensor_lag").simulate(duty, noise=False)
    # During heating the lagged boss sensor reads lower, during cooling higher.
    assert lagged["T63_C"].iloc[30] < direct["T63_C"].iloc[30] - 1.0
    assert lagged["T63_C"].iloc[140] > direct["T63_C"].iloc[140] + 0.5
    # Air sensors do not lag; displacements are the same.
    np.testing.assert_allclose(lagged["T76_C"], direct["T76_C"])
    np.testing.assert_allclose(lagged["disp_y_um"], direct["disp_y_um"])


def test_speed_convection_cools_a_running_spindle(vmc_b):
    duty = DutyCycle([(3600, 8000)])
    on = vmc_b.simulate(duty, noise=False)["T64_C"].iloc[-1]
    off = vmc_b.with_effects(remove="speed_convection").simulate(duty, noise=False)
    assert on < off["T64_C"].iloc[-1] - 0.5


def test_ambient_transient_lets_a_door_event_reach_the_structure():
    machine = ThermalMachine.from_preset("vmc-a")
    air = AmbientProfile(door_events=[DoorEvent(start_h=1.0)])
    duty = DutyCycle([(4 * 3600, 0)])
    with_ = machine.simulate(duty, air, noise=False)
    without = machine.with_effects(remove="ambient_transient").simulate(
        duty, air, noise=False
    )
    # 30 minutes after the door opens the exposed structure has moved Z
    # several times more than the enclosure-shielded one.
    k = 180  # 1.5 h at 30 s
    assert abs(with_["disp_z_um"].iloc[k]) > 3 * abs(without["disp_z_um"].iloc[k])
    assert np.ptp(with_["disp_z_um"]) > 2 * np.ptp(without["disp_z_um"])


def test_feed_heating_warms_the_screw_and_moves_the_feed_axis():
    machine = ThermalMachine.from_preset("vmc-a")
    duty = DutyCycle([(3 * 3600, 0, 4000)])
    on = machine.simulate(duty, noise=False)
    off = machine.with_effects(remove="feed_heating").simulate(duty, noise=False)
    assert on["T25_C"].iloc[-1] > off["T25_C"].iloc[-1] + 1.0  # X bearing cap
    assert abs(on["disp_x_um"].iloc[-1]) > 5 * abs(off["disp_x_um"].iloc[-1]) + 1
    # Position-dependent: measured nearer the fixed end, the screw moves it less.
    near = machine.with_params({"feed_heating.measure_at": 0.1}).simulate(
        duty, noise=False
    )
    assert abs(near["disp_x_um"].iloc[-1]) < 0.5 * abs(on["disp_x_um"].iloc[-1])


def test_sensor_drift_moves_readings_slowly(vmc_b):
    duty = DutyCycle([(48 * 3600, 0)])
    drift = vmc_b.with_effects(add="sensor_drift").with_params(
        {"sensor_drift.rate_C_per_h": 0.05}
    )
    a = drift.simulate(duty, 20.0, sample_period_s=600, random_state=0)
    b = vmc_b.simulate(duty, 20.0, sample_period_s=600, random_state=0)
    sensors = vmc_b.sensors
    spread_a = (a[sensors].iloc[-1] - a[sensors].iloc[0]).abs().mean()
    spread_b = (b[sensors].iloc[-1] - b[sensors].iloc[0]).abs().mean()
    assert spread_a > 5 * spread_b


def test_sensor_drift_rate_belongs_to_the_sensor(vmc_b):
    # Ageing is a property of the sensor: the same rate in every run (every
    # random_state); only the random walk is new in every run.
    machine = vmc_b.with_effects(add="sensor_drift").with_params(
        {"sensor_drift.rate_C_per_h": 0.05, "sensor_drift.walk_C_per_sqrt_h": 0.0}
    )
    t = np.arange(0.0, 36001.0, 600.0)
    x = np.zeros((t.size, len(machine.spec.sensors)))
    effect = EFFECTS["sensor_drift"]
    runs = [
        effect.noise(machine, machine.params, x, t, 600.0, np.random.default_rng(s))
        for s in (0, 1)
    ]
    np.testing.assert_allclose(runs[0], runs[1])
    rate = runs[0][-1] / 10.0
    np.testing.assert_allclose(runs[0], np.outer(t / 3600.0, rate), atol=1e-12)
    assert 0.02 < rate.std() < 0.08  # spread over the sensors: the rate's std


# --- campaigns and realism ------------------------------------------------------


@pytest.fixture(scope="module")
def machine_b_tests():
    return make_machine_b_tests(random_state=0)


def test_machine_b_tests_match_the_papers_magnitudes(machine_b_tests):
    runs = machine_b_tests
    assert runs["run"].unique().tolist() == ["I", "II", "III", "IV", "V", "VI"]
    peak = runs.groupby("run", sort=False)[["disp_x_um", "disp_y_um", "disp_z_um"]]
    peak = peak.agg(lambda s: s.abs().max())
    paper = {"I": 25, "II": 35, "III": 40, "IV": 39, "V": 64, "VI": 79}
    for run, y in paper.items():
        assert 0.8 * y <= peak.loc[run, "disp_y_um"] <= 1.2 * y, run
    for run in ("V", "VI"):
        assert 0.8 * 22 <= peak.loc[run, "disp_z_um"] <= 1.2 * 22
    assert peak["disp_x_um"].max() <= 3.0
    meta = pd.DataFrame(runs.attrs["metadata"])
    assert meta["paper_max_disp_y_um"].tolist() == [25, 35, 40, 39, 64, 79]
    hours = runs.groupby("run", sort=False)["time_s"].max() / 3600
    assert hours.round(2).tolist() == [2, 5, 5, 8, 2, 2]
    validate_runs(runs, require_targets=True, require_drivers=True)


def test_etve_door_event_magnitudes():
    runs = make_etve(hours=48, random_state=0)
    t = runs["time_s"] / 3600
    window = (t >= 0.3) & (t < 3.0)  # the door opens at 0.5 h
    dz = np.ptp(runs.loc[window, "disp_z_um"])
    dy = np.ptp(runs.loc[window, "disp_y_um"])
    assert 0.75 * 35 <= dz <= 1.25 * 35
    assert 0.75 * 25 <= dy <= 1.25 * 25
    air = runs["ambient_C"]
    assert np.ptp(air[window]) > 7  # about 9 °C drop
    assert runs["spindle_rpm"].eq(0).all()
    assert (runs["time_s"].diff().dropna() == 60).all()


def test_multipart_test_moves_all_three_axes():
    runs = make_multipart_test(random_state=0)
    peak = runs[["disp_x_um", "disp_y_um", "disp_z_um"]].abs().max()
    assert (peak > 10).all()
    assert runs["feed_mm_min"].gt(0).any() and runs["spindle_rpm"].nunique() > 3


# --- calibration ----------------------------------------------------------------


def test_calibration_recovers_hidden_parameters():
    truth = ThermalMachine.from_preset(
        "vmc-b", params={"q.bearing_W": 13.0, "k.y.carrier3": 2.4}
    )
    runs = pd.concat(
        [
            truth.simulate(
                DutyCycle.heat_cool(4000, heat_h=1, cool_h=1), run="a", noise=False
            ),
            truth.simulate(
                DutyCycle.heat_cool(7000, heat_h=1, cool_h=1), run="b", noise=False
            ),
        ],
        ignore_index=True,
    )
    model = ThermalMachine.from_preset("vmc-b")
    fitted, result = model.calibrate(runs, ["q.bearing_W", "k.y.carrier3"])
    assert result.success
    np.testing.assert_allclose(result.params, [13.0, 2.4], rtol=1e-4)
    assert (result.rmse_after < 1e-3).all()
    assert (result.rmse_before > 0.5).any()
    assert fitted.params["q.bearing_W"] == pytest.approx(13.0, rel=1e-4)
    assert model.params["q.bearing_W"] == 10.0  # the original is unchanged


def test_calibration_errors():
    machine = ThermalMachine.from_preset("vmc-b")
    runs = machine.simulate(DutyCycle([(600, 1000)]), noise=False)
    with pytest.raises(ValueError, match="Unknown parameter"):
        machine.calibrate(runs, ["q.nothing"])
    with pytest.raises(ValueError, match="are 0: give bounds"):
        machine.calibrate(runs, ["k.x.base"])
    with pytest.raises(ValueError, match="no 'ambient_C' column"):
        machine.calibrate(runs.drop(columns="ambient_C"), ["q.bearing_W"])
    with pytest.raises(
        ValueError, match=r"bounds of 'q.bearing_W' must be a \(low, high\) pair"
    ):
        machine.calibrate(runs, ["q.bearing_W"], bounds=[(1, 5, 3)])
    with pytest.raises(ValueError, match=r"'q.bearing_W': low must be below high"):
        machine.calibrate(runs, ["q.bearing_W"], bounds={"q.bearing_W": (5, 1)})
    with pytest.raises(ValueError, match=r"'q.bearing_W': high must be a number"):
        machine.calibrate(runs, ["q.bearing_W"], bounds=[(1, "ten")])
    # Channels asked for are fitted or named, never dropped silently.
    with pytest.raises(ValueError, match=r"\['disp_zz_um'\] are not columns"):
        machine.calibrate(runs, ["q.bearing_W"], channels=["disp_z_um", "disp_zz_um"])
    _, result = machine.calibrate(runs, ["q.bearing_W"], channels="disp_z_um")
    assert list(result.rmse_after.index) == ["disp_z_um"]  # a name, not letters
    with pytest.raises(ValueError, match=r"\['q.bearing_W'\] more than once"):
        machine.calibrate(runs, ["q.bearing_W", "q.bearing_W"])
    with pytest.raises(ValueError, match="empty"):
        machine.calibrate(runs.iloc[:0], ["q.bearing_W"])


def test_calibration_is_not_bent_by_sensor_offsets():
    # Temperatures are compared as changes since the start, as displacements.
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    truth = rig.with_params(
        {
            "q.bearing_W": 1.4 * rig.params["q.bearing_W"],
            "sensor.offset_C": 0.5,
            "sensor.noise_C": 0.0,
            "sensor.quantization_C": 0.0,
        }
    )
    runs = truth.simulate(
        DutyCycle([(3600, 4000, 0), (3600, 0, 0)]), sample_period_s=60, random_state=0
    )
    _, result = rig.calibrate(runs, ["q.bearing_W"], channels=rig.sensors)
    assert result.params.iloc[0] == pytest.approx(truth.params["q.bearing_W"], rel=1e-6)


def _warm(machine, rpm=4000.0, air=20.0):
    """Node temperatures after running at ``rpm`` for a long time."""
    t = np.array([0.0, 1e7])  # modal integration: exact for constant drivers
    return machine.response(t, np.full(2, rpm), np.full(2, air))[-1]


def test_initial_state_from_the_first_readings():
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    warm = _warm(rig)
    readings = rig.read(warm[None], [20.0], rig.sensors, sample_period_s=60)[0]
    # The rig's sensors read every node: the state comes back (to the
    # readings' uncertainty, their 0.1 K calibration offsets).
    T0 = rig.initial_from_readings(dict(zip(rig.sensors, readings)), 20.0)
    np.testing.assert_allclose(T0, warm, atol=0.05)  # 0.7-5.8 K above the air
    soaked = rig.initial_from_readings(dict.fromkeys(rig.sensors, 21.5), 21.5)
    np.testing.assert_allclose(soaked, 21.5, atol=1e-9)
    # Two sensors only: the others' nodes take the temperatures the
    # machine's warm states give them beside the ones read.
    few = rig.initial_from_readings(
        {s: readings[rig.sensors.index(s)] for s in ("T1_C", "T9_C")}, 20.0
    )
    assert np.abs(few - warm).max() < 0.1 * (warm.max() - 20.0)
    # First samples are read at the first one's time (a straight line).
    times = np.arange(5) * 60.0
    drifting = {"T1_C": 25.0 - 0.01 * times}
    a = rig.initial_from_readings(drifting, np.full(5, 20.0), time_s=times)
    b = rig.initial_from_readings({"T1_C": 25.0}, 20.0)
    np.testing.assert_allclose(a, b)
    # The spindle started at the first sample: the heating over the samples
    # (a bearing sensor warms fast) is taken out before the line is drawn.
    rpm = np.full(5, 8000.0)
    T = rig.response(times, rpm, np.full(5, 20.0))
    heating = rig.read(T, np.full(5, 20.0), rig.sensors, sample_period_s=60.0)
    first = dict(zip(rig.sensors, heating.T))
    tilted = rig.initial_from_readings(first, 20.0, time_s=times)
    assert tilted.max() > 20.5  # read as a warm machine
    straight = rig.initial_from_readings(first, 20.0, time_s=times, spindle_rpm=rpm)
    np.testing.assert_allclose(straight, 20.0, atol=1e-6)
    with pytest.raises(ValueError, match=r"293.15 K from the air .* give temperatures"):
        rig.initial_from_readings({"T1_C": 313.15}, 20.0)
    with pytest.raises(ValueError, match="readings is empty"):
        rig.initial_from_readings({}, 20.0)
    with pytest.raises(ValueError, match=r"\['T1C'\] are not sensors.*'T1_C'"):
        rig.initial_from_readings({"T1C": 25.0}, 20.0)
    with pytest.raises(ValueError, match="readings\\['T1_C'\\] must be"):
        rig.initial_from_readings({"T1_C": [25.0, np.nan]}, 20.0)
    with pytest.raises(ValueError, match="initial='measured' is an option of"):
        rig.simulate_drivers(times, np.zeros(5), np.full(5, 20.0), initial="measured")


def _rest_run_rest(truth, speeds, random_state=0, **kwargs):
    """Runs of 1 h at rest, 1 h at each speed, 1 h at rest, every 60 s (the
    i-th run's noise seeded i, with ``random_state=None``)."""
    return pd.concat(
        [
            truth.simulate(
                DutyCycle([(3600, 0, 0), (3600, rpm, 0), (3600, 0, 0)]),
                20.0,
                sample_period_s=60,
                run=f"r{i}",
                random_state=i if random_state is None else random_state,
                **kwargs,
            )
            for i, rpm in enumerate(speeds)
        ],
        ignore_index=True,
    )


def test_auto_starts_soaked_runs_at_the_air():
    # "auto" read the sensors' calibration offsets of soaked runs as warmth:
    # the bearing loss came out 26% low (within 1% from the air).
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    machine = rig.with_params({"sensor.offset_C": 0.5})
    truth = machine.with_params({"q.bearing_W": 1.4 * rig.params["q.bearing_W"]})
    runs = _rest_run_rest(truth, [2500, 5000, 4000], random_state=None)
    true = truth.params["q.bearing_W"]
    fits = {
        initial: machine.calibrate(
            runs, ["q.bearing_W"], initial=initial, channels=rig.targets
        )[1].params.iloc[0]
        / true
        - 1
        for initial in ("ambient", "measured", "auto")
    }
    assert abs(fits["ambient"]) < 0.02 and abs(fits["auto"]) < 0.02
    assert fits["measured"] < -0.15
    # The estimate itself: readings within the offsets of the air stay at
    # the air; a warm start is read as before.
    rng = np.random.default_rng(0)
    near = {s: 20.0 + 0.5 * rng.standard_normal() for s in machine.sensors}
    soaked = machine.initial_from_readings(near, 20.0, p_soaked=0.5)
    assert np.abs(soaked - 20.0).max() < 0.05
    assert np.abs(machine.initial_from_readings(near, 20.0) - 20.0).max() > 0.3
    warm = dict(zip(machine.sensors, 20.0 + 3.0 * rng.random(len(machine.sensors))))
    np.testing.assert_allclose(
        machine.initial_from_readings(warm, 20.0, p_soaked=0.5),
        machine.initial_from_readings(warm, 20.0),
        atol=1e-6,
    )
    with pytest.raises(ValueError, match=r"p_soaked must be in \[0, 1\)"):
        machine.initial_from_readings(near, 20.0, p_soaked=1.0)
    # The probability of a warm start, judged once, gives the same estimate.
    w = machine.warm_probability(near, 20.0)
    assert 0 <= w < 0.5 and machine.warm_probability(warm, 20.0) > 0.99
    np.testing.assert_allclose(
        machine.initial_from_readings(near, 20.0, warm=w),
        machine.initial_from_readings(near, 20.0, p_soaked=0.5),
    )
    with pytest.raises(ValueError, match=r"warm must be in \[0, 1\]"):
        machine.initial_from_readings(near, 20.0, warm=1.5)


def test_calibration_of_runs_that_start_warm():
    # Every run starts warm from earlier running; simulated from the air,
    # the calibration has to bend the bearing loss to its bound.
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    truth = rig.with_params({"q.bearing_W": 1.4 * rig.params["q.bearing_W"]})
    runs = _rest_run_rest(truth, [2500, 5000], noise=False, initial=_warm(truth))
    true = truth.params["q.bearing_W"]
    _, soaked = rig.calibrate(runs, ["q.bearing_W"])
    # (No feed column: the axis never moved.)
    _, measured = rig.calibrate(
        runs.drop(columns="feed_mm_min"), ["q.bearing_W"], initial="measured"
    )
    assert abs(soaked.params.iloc[0] / true - 1) > 0.5
    assert measured.params.iloc[0] == pytest.approx(true, rel=0.03)
    assert (measured.rmse_after < 0.1 * soaked.rmse_after).all()
    # "auto": from the first readings, as the runs hold the rig's sensors.
    _, auto = rig.calibrate(runs, ["q.bearing_W"], initial="auto")
    assert auto.params.iloc[0] == measured.params.iloc[0]
    with pytest.raises(ValueError, match="table holds none of the sensors that read"):
        rig.calibrate(
            runs.drop(columns=rig.sensors), ["q.bearing_W"], initial="measured"
        )
    # The air alone cannot tell a warm machine: refused, not run.
    air_only = runs.drop(columns=[s for s in rig.sensors if s != "T6_C"])
    with pytest.raises(ValueError, match=r"the air alone, \['T6_C'\], cannot tell"):
        rig.calibrate(air_only, ["q.bearing_W"], initial="measured")
    _, from_air = rig.calibrate(air_only, ["q.bearing_W"], initial="auto")
    assert from_air.params.iloc[0] == soaked.params.iloc[0]
    # Errors of a run's first readings name the run.
    kelvin = runs.copy()
    kelvin.loc[kelvin["run"] == "r1", "T1_C"] += 273.15
    with pytest.raises(ValueError, match=r"Run 'r1': readings\['T1_C'\] is 29"):
        rig.calibrate(kelvin, ["q.bearing_W"], initial="measured")
    swapped = runs.copy()
    rows = swapped.index[swapped["run"] == "r1"][:2]
    swapped.loc[rows, "time_s"] = swapped.loc[rows[::-1], "time_s"].to_numpy()
    with pytest.raises(ValueError, match=r"Run 'r1': time_s must increase"):
        rig.calibrate(swapped, ["q.bearing_W"], initial="measured")


def test_first_readings_and_their_estimate_name_bad_input():
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = pd.concat(
        [
            rig.simulate(
                DutyCycle([(1800, 3000, 0)]),
                air,
                sample_period_s=60,
                run=name,
                noise=False,
            )
            for name, air in (("r0", 20.0), ("r1", 23.0))
        ],
        ignore_index=True,
    )
    # run= picks the run (its first samples, not the table's).
    first = rig.first_readings(runs, run="r1")
    np.testing.assert_allclose(
        first["T1_C"], runs.loc[runs["run"] == "r1", "T1_C"].to_numpy()[:5]
    )
    with pytest.raises(ValueError, match=r"run 'r9' is not in the table.*'r0'"):
        rig.first_readings(runs, run="r9")
    with pytest.raises(ValueError, match="holds 2 runs.*give run="):
        rig.first_readings(runs)
    with pytest.raises(ValueError, match="the table has no rows"):
        rig.first_readings(runs.iloc[:0])
    with pytest.raises(ValueError, match=r"'T1_C' is mapped to column 'Tfront_C'"):
        rig.first_readings(runs, run="r0", columns={"T1_C": "Tfront_C"})
    with pytest.raises(ValueError, match=r"\['T99_C'\] are not sensors"):
        rig.first_readings(runs, run="r0", columns={"T99_C": "T1_C"})
    with pytest.raises(TypeError, match="must be a run table"):
        rig.first_readings(runs.to_numpy())
    # The estimate's inputs.
    t = np.arange(5) * 60.0
    ok = {"T1_C": np.full(5, 25.0)}
    with pytest.raises(ValueError, match=r"Run 'x': time_s is NaN or infinite"):
        rig.initial_from_readings(ok, 20.0, time_s=[0, 60, np.nan, 180, 240], run="x")
    with pytest.raises(ValueError, match=r"spindle_rpm must be .* shape \(5,\)"):
        rig.initial_from_readings(ok, 20.0, time_s=t, spindle_rpm=np.zeros(3))
    # A spindle far too fast is named, not the readings' unit.
    with pytest.warns(ImplausibleDriverWarning, match="spindle_rpm is 1e"):
        with pytest.raises(ValueError, match=r"after taking out what spindle_rpm"):
            rig.initial_from_readings(ok, 20.0, time_s=t, spindle_rpm=np.full(5, 1e7))
    with pytest.warns(ImplausibleDriverWarning, match=r"^max_rpm is 1e\+07"):
        rig.initial_from_readings(ok, 20.0, max_rpm=1e7)
    # Readings in fahrenheit against the air in °C, or far below the air:
    # warned of.
    with pytest.warns(UserWarning, match=r"median \+52.*same unit"):
        rig.initial_from_readings(dict.fromkeys(["T1_C", "T2_C"], 72.0), 20.0)
    with pytest.warns(UserWarning, match=r"'T1_C'\] is -60 K from the air"):
        rig.initial_from_readings({"T1_C": -40.0}, 20.0)
    for odd in (True, "24.0", [24.0, "24.1"]):
        with pytest.raises(ValueError, match=r"readings\['T1_C'\] must be numbers"):
            rig.initial_from_readings({"T1_C": odd}, 20.0)


def test_duty_segments_between_samples_heat_for_their_own_length():
    """A segment that starts between two samples heats for its own length,
    not until the next sample: sampled every 60 s, 90 s on / 90 s off gives
    the node temperatures of the same cycle sampled every 10 s."""
    machine = ThermalMachine.from_preset("spindle-rig", effects=[])
    duty = DutyCycle([(90, 6000), (90, 0)] * 20)
    fine, fine_T = machine.simulate(
        duty, 20.0, sample_period_s=10.0, noise=False, return_states=True
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        coarse, coarse_T = machine.simulate(
            duty, 20.0, sample_period_s=60.0, noise=False, return_states=True
        )
    np.testing.assert_allclose(coarse_T.to_numpy(), fine_T.to_numpy()[::6], atol=1e-9)
    disp = [c for c in coarse.columns if c.startswith("disp_")]
    np.testing.assert_allclose(
        coarse[disp].to_numpy(), fine[disp].to_numpy()[::6], atol=1e-9
    )
    # The table logs the speed in force at each sample time.
    np.testing.assert_array_equal(
        coarse["spindle_rpm"].to_numpy(), duty.sample(coarse["time_s"].to_numpy())[0]
    )
    # Segments on the samples: one step per sample, as before.
    aligned = DutyCycle([(120, 6000), (60, 0)] * 10)
    a = machine.simulate(aligned, 20.0, sample_period_s=60.0, noise=False)
    b = machine.simulate_drivers(
        a["time_s"], a["spindle_rpm"], a["ambient_C"], noise=False
    )
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())


def test_duty_segment_starts_anywhere_between_samples():
    """A start at any time between samples (90.5 s, or 1e-4 s after a
    sample) is integrated from there: the same node temperatures as a
    sampling that holds it, and a continuous response to the shift."""
    machine = ThermalMachine.from_preset("vmc-b", effects=["speed_convection"])
    duty = DutyCycle([(90.5, 6000, 2000), (3000, 3000), (1500, 0)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, coarse = machine.simulate(
            duty, 20.0, sample_period_s=60.0, noise=False, return_states=True
        )
    _, fine = machine.simulate(
        duty, 20.0, sample_period_s=0.5, noise=False, return_states=True
    )
    fine = fine.to_numpy()[::120]
    np.testing.assert_allclose(coarse.to_numpy()[: len(fine)], fine, atol=1e-9)
    shifted = DutyCycle([(60 + 1e-4, 6000, 2000), (3000, 3000), (1500, 0)])
    on_sample = DutyCycle([(60, 6000, 2000), (3000, 3000), (1500, 0)])
    a, b = (
        machine.simulate(d, 20.0, sample_period_s=60.0, noise=False)
        for d in (shifted, on_sample)
    )
    disp = [c for c in a.columns if c.startswith("disp_")]
    gap = np.abs(a[disp].to_numpy() - b[disp].to_numpy()).max()
    assert 0 < gap < 1e-3


def test_read_checks_the_sample_period():
    machine = ThermalMachine.from_preset("vmc-b", effects=["sensor_lag"])
    T = np.full((5, len(machine.spec.nodes)), 20.5)
    for period in (0.0, -60.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="sample_period_s must be"):
            machine.read(T, np.full(5, 20.0), sample_period_s=period)


def test_calibration_flags_parameters_the_channels_do_not_see():
    machine = ThermalMachine.from_preset("spindle-rig")
    truth = machine.with_params({"q.bearing_W": 1.3 * machine.params["q.bearing_W"]})
    runs = truth.simulate(DutyCycle([(3600, 3000), (1800, 0)]), noise=False)
    # A displacement coefficient does not move a temperature channel.
    with pytest.warns(UserWarning, match=r"\['k.ch1.spindle'\] have no influence"):
        _, result = machine.calibrate(
            runs, ["k.ch1.spindle", "q.bearing_W"], channels=["T2_C"]
        )
    assert np.isinf(result.std_error["k.ch1.spindle"])
    assert np.isfinite(result.std_error["q.bearing_W"])
    # The parameter of an effect that is off has no influence at all.
    with pytest.raises(
        ValueError, match=r"'sensor_lag.tau_s': effect 'sensor_lag' is off"
    ):
        machine.with_effects(remove=["sensor_lag"]).calibrate(
            runs, ["sensor_lag.tau_s"], channels=["T2_C"]
        )


def test_calibration_warns_when_a_parameter_ends_on_its_bound():
    """A speed logged in krpm drives a tenth of the heat: the bearing loss
    runs to ten times its sketch, the top of its default range, and the
    warning names it with the likely causes; a good fit says nothing."""
    machine = ThermalMachine.from_preset("spindle-rig")
    runs = machine.simulate(DutyCycle([(3600, 3000), (1800, 0)]), noise=False)
    slipped = runs.assign(spindle_rpm=runs["spindle_rpm"] / 1000.0)
    high = 10 * machine.params["q.bearing_W"]
    with pytest.warns(
        UserWarning,
        match=rf"q.bearing_W = {high:.4g} \(high bound\) ended on the bound .*"
        r"speed in rpm",
    ):
        _, result = machine.calibrate(slipped, ["q.bearing_W"], channels=["T2_C"])
    assert result.params["q.bearing_W"] == pytest.approx(high)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        machine.calibrate(runs, ["q.bearing_W"], channels=["T2_C"])


def test_a_bound_reached_by_collinear_coefficients_is_said_so():
    # Coefficients that shape a channel alike push each other to the bounds;
    # the warning led with "check the units", which an independent check
    # followed in vain (the heat inputs came back within 5% of the truth).
    from skthermal.simulate._machine import _alike_text

    params = ["k.z.nose", "k.z.tool", "q.bearing_W"]
    on_bound = np.array([True, False, False])  # k.z.nose at its low bound
    corr = np.array([[1.0, -0.99, 0.1], [-0.99, 1.0, 0.0], [0.1, 0.0, 1.0]])
    text = _alike_text(params, on_bound, corr)
    assert "(k.z.nose with k.z.tool (r = -0.99))" in text
    assert text.endswith("fit fewer parameters; else")
    corr[0, 1] = corr[1, 0] = -0.5  # not alike: the old advice alone
    assert _alike_text(params, on_bound, corr) == ""


# --- bad input ------------------------------------------------------------------


@pytest.mark.parametrize(
    "segments, match",
    [
        ([(600, -100)], "spindle_rpm must not be negative"),
        ([(600, float("nan"))], "spindle_rpm must be finite"),
        ([(0, 1000)], "duration_s must be positive"),
        ([], "at least one segment"),
        ([(600,)], None),
    ],
)
def test_bad_duty_cycles(segments, match):
    if match is None:  # a bare duration is a stopped spindle
        assert DutyCycle(segments).segments[0].spindle_rpm == 0
        return
    with pytest.raises(ValueError, match=match):
        DutyCycle(segments)


def test_bad_drivers_name_the_problem(vmc_b):
    t = np.arange(5) * 30.0
    ok = np.full(5, 20.0)
    # Durations were read as ticks: a 2 h run became 7e9 s, silently.
    for clock in (
        pd.to_timedelta(t, unit="s"),
        pd.Series(pd.to_timedelta(t, unit="s")).astype("duration[ns][pyarrow]"),
    ):
        with pytest.raises(ValueError, match=r"time_s holds .* \(time stamps or"):
            vmc_b.simulate_drivers(clock, np.zeros(5), ok)
    with pytest.raises(ValueError, match=r"negative: -5 in run 'x' at row 2"):
        vmc_b.simulate_drivers(t, [0, 0, -5, 0, 0], ok, run="x")
    with pytest.raises(ValueError, match=r"ambient_C is NaN or infinite in run 'x'"):
        vmc_b.simulate_drivers(t, np.zeros(5), [20, np.nan, 20, 20, 20], run="x")
    with pytest.raises(
        ValueError, match=r"time_s must increase strictly: run 'x', row 3"
    ):
        vmc_b.simulate_drivers([0, 30, 60, 60, 90], np.zeros(5), ok, run="x")
    with pytest.raises(ValueError, match="not regularly sampled") as err:
        vmc_b.simulate_drivers([0, 30, 60, 100, 130], np.zeros(5), ok)
    assert "round time_s" not in str(err.value)  # a gap, not jitter
    # A jittering clock: the suggested period (the logger's, not the median
    # of the jittered steps) makes the run regular.
    rng = np.random.default_rng(0)
    t = np.arange(200) * 60.0
    t[1:] += rng.uniform(-2.0, 2.0, t.size - 1)
    with pytest.raises(ValueError, match=r"round\(time_s / 60\) \* 60,") as err:
        vmc_b.simulate_drivers(t, np.zeros(t.size), np.full(t.size, 20.0))
    fixed = np.round(t / 60.0) * 60.0
    vmc_b.simulate_drivers(fixed, np.zeros(t.size), np.full(t.size, 20.0))


def test_bad_presets_and_parameters():
    with pytest.raises(ValueError, match="Unknown preset 'vmc-z'"):
        ThermalMachine.from_preset("vmc-z")
    with pytest.raises(ValueError, match="'C.boss' is a heat capacity and must be pos"):
        ThermalMachine.from_preset("vmc-b", params={"C.boss": -5.0})
    with pytest.raises(ValueError, match="'G.bearings-boss'.*must not be negative"):
        ThermalMachine.from_preset("vmc-b", params={"G.bearings-boss": -1.0})
    with pytest.raises(ValueError, match="q.alpha"):
        ThermalMachine.from_preset("vmc-b", params={"q.alpha": 5.0})
    with pytest.raises(ValueError, match="Unknown parameter"):
        ThermalMachine.from_preset("vmc-b").with_params({"C.nowhere": 1.0})
    with pytest.raises(ValueError, match="sensor_lag.tau_s"):
        ThermalMachine.from_preset("vmc-b", params={"sensor_lag.tau_s": 0.0})


def test_long_run_memory_is_linear_and_fast_enough(vmc_b):
    """A week at one-minute sampling: one array per quantity, no blow-up."""
    duty = DutyCycle.from_hours([(4, 4000), (4, 0)] * 21)
    run = vmc_b.simulate(duty, AmbientProfile(day_amplitude_C=2.5), sample_period_s=60)
    assert run.shape == (168 * 60 + 1, 85)
    assert run.memory_usage(deep=False).sum() < 200 * run.shape[0] * 8


def test_simulated_runs_can_carry_fbg_strain_channels(vmc_b):
    from skthermal.datasets import validate_runs
    from skthermal.sensors import FBGGauge, correct_strain_channels

    gauges = {"carrier": FBGGauge({"carrier2": 0.5, "carrier3": 0.5}, sensor="T15_C")}
    run = vmc_b.simulate(
        DutyCycle.heat_cool(6000, heat_h=1, cool_h=0.5),
        strain_gauges=gauges,
        random_state=0,
    )
    assert "Scarrier_ue" in run.columns
    validate_runs(run)
    # The raw reading includes the grating's 8.64 µε/°C; corrected, it is the
    # member's mechanical strain, smaller for a heating carrier.
    corrected = correct_strain_channels(run)  # gauges recorded in run.attrs
    assert abs(corrected["Scarrier_ue"].iloc[120]) < abs(run["Scarrier_ue"].iloc[120])


# --- audit fixes: calibration bounds and inputs, read, response times -----------


def test_default_bounds_stay_inside_the_valid_range():
    # The truth at the edge of the valid range (alpha 3): the default bounds
    # (a tenth to ten times, here [0.15, 15]) are cut to [0.5, 3], so neither
    # the optimiser nor its finite-difference steps leave it.
    from skthermal.simulate._machine import _default_bounds

    lo, hi = _default_bounds(
        np.array([1.5, 0.5, 6000.0]), ["q.alpha", "feed_heating.measure_at", "C.x"]
    )
    np.testing.assert_array_equal(lo, [0.5, 0.05, 600.0])
    np.testing.assert_array_equal(hi, [3.0, 1.0, 60000.0])
    truth = ThermalMachine.from_preset(
        "spindle-rig", effects=[], params={"q.alpha": 3.0}
    )
    runs = truth.simulate(
        DutyCycle([(3600, 8000), (1800, 0)]), sample_period_s=300, noise=False
    )
    runs[truth.targets] *= 1.5  # the best fit lies beyond the range
    model = ThermalMachine.from_preset("spindle-rig", effects=[])
    _, result = model.calibrate(runs, ["q.alpha"], max_nfev=20)
    assert 0.5 <= result.params["q.alpha"] <= 3.0
    assert result.params["q.alpha"] == pytest.approx(3.0, abs=1e-6)


def test_feed_heating_fraction_is_fitted_inside_zero_to_one():
    truth = ThermalMachine.from_preset("vmc-a", params={"feed_heating.measure_at": 1.0})
    runs = truth.simulate(
        DutyCycle([(3600, 3000, 3000), (1800, 0, 0)]), sample_period_s=300, noise=False
    )
    runs["disp_x_um"] += 3 * np.linspace(0, 1, len(runs))
    model = ThermalMachine.from_preset("vmc-a")
    _, result = model.calibrate(
        runs, ["feed_heating.measure_at"], channels=["disp_x_um"], max_nfev=20
    )
    assert 0.0 <= result.params.iloc[0] <= 1.0


@pytest.mark.parametrize(
    "key, bounds, valid",
    [
        ("q.alpha", (-2.0, 5.0), r"\[0.5, 3\]"),
        ("q.bearing_W", (-10.0, 10.0), r"\[0, inf\)"),
        ("C.spindle", (-5000.0, 5000.0), r"\(0, inf\)"),
        ("C.spindle", (0.0, 5000.0), r"\(0, inf\)"),
    ],
)
def test_bounds_outside_the_valid_range_are_refused_before_any_work(
    key, bounds, valid, monkeypatch
):
    model = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = model.simulate(DutyCycle([(600, 3000)]), sample_period_s=60, noise=False)

    def no_simulation(*args, **kwargs):  # pragma: no cover - must not run
        raise AssertionError("calibrate simulated before checking its bounds")

    monkeypatch.setattr(ThermalMachine, "simulate_drivers", no_simulation)
    with pytest.raises(
        ValueError,
        match=rf"bounds of '{key}': .* reach outside its valid range {valid}",
    ):
        model.calibrate(runs, [key], bounds=[bounds])


def test_calibration_input_gaps_are_named():
    machine = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = machine.simulate(DutyCycle([(1200, 4000)]), sample_period_s=300, noise=False)
    with pytest.warns(UserWarning, match=r"no column \['disp_ch3_um'\], which the"):
        _, result = machine.calibrate(
            runs.drop(columns="disp_ch3_um"), ["q.bearing_W"], max_nfev=2
        )
    assert "disp_ch3_um" not in result.rmse_after.index
    with pytest.raises(ValueError, match=r"channels names \['disp_ch1_um'\] more"):
        machine.calibrate(runs, ["q.bearing_W"], channels=["disp_ch1_um"] * 2)
    with pytest.raises(
        TypeError, match=r"keyword argument 'max_nfevs' \(did you mean 'max_nfev'"
    ):
        machine.calibrate(runs, ["q.bearing_W"], max_nfevs=2)
    with pytest.raises(ValueError, match=r"bounds names \['q.bearng_W'\], not"):
        machine.calibrate(
            runs,
            ["q.bearing_W"],
            bounds={"q.bearing_W": (1, 50), "q.bearng_W": (0, 1)},
        )
    with pytest.raises(
        ValueError, match=r"\['q.bearng_W'\].*did you mean 'q.bearing_W'"
    ):
        machine.calibrate(runs, ["q.bearing_W"], bounds={"q.bearng_W": (1, 50)})
    with pytest.raises(TypeError, match="runs must be a run table .* got dict"):
        machine.calibrate(runs.to_dict("list"), ["q.bearing_W"])


def test_calibration_names_bad_values_by_column_run_and_row():
    machine = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = machine.simulate(DutyCycle([(1200, 4000)]), sample_period_s=300, noise=False)
    bad = runs.copy()
    bad.loc[2, "disp_ch1_um"] = np.nan
    with pytest.raises(
        ValueError, match=r"Column 'disp_ch1_um' is missing \(NaN\) at row 2, run"
    ) as info:
        machine.calibrate(bad, ["q.bearing_W"])
    # The calibration's advice, not a deployed model's.
    assert "in the runs). The calibration compares every sample" in str(info.value)
    assert "GuardedRegressor" not in str(info.value)
    text = runs.astype({"spindle_rpm": object})
    text.loc[3, "spindle_rpm"] = "fast"
    with pytest.raises(
        ValueError, match=r"Column 'spindle_rpm' is not numeric: row 3 .* 'fast'"
    ):
        machine.calibrate(text, ["q.bearing_W"])
    # Rows without a run label used to be left out of every run.
    other = runs.assign(run="b", spindle_rpm=2 * runs["spindle_rpm"])
    both = pd.concat([runs, other], ignore_index=True)
    unlabelled = both.assign(run=both["run"].where(both["run"] != "b"))
    with pytest.raises(ValueError, match=f"Row {len(runs)} has no run label"):
        machine.calibrate(unlabelled, ["q.bearing_W"])
    # An air below absolute zero is not simulated.
    cold = runs.copy()
    cold.loc[3, "ambient_C"] = -300.0
    with pytest.raises(ValueError, match=r"ambient_C must be a temperature .* -300"):
        machine.calibrate(cold, ["q.bearing_W"])
    twice = pd.concat([runs, runs[["T1_C"]]], axis=1)
    with pytest.raises(ValueError, match=r"duplicated columns: \['T1_C'\]"):
        machine.calibrate(twice, ["q.bearing_W"], channels=["T1_C"])


def test_calibration_flags_time_in_hours():
    machine = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = machine.simulate(DutyCycle([(7200, 4000)]), sample_period_s=300, noise=False)
    with pytest.warns(
        UserWarning, match=r"calibrate: the longest run .* lasts 2 s of time_s"
    ):
        machine.calibrate(runs.assign(time_s=runs["time_s"] / 3600), ["q.bearing_W"])


def test_calibration_repairs_a_glitch_and_flags_air_in_fahrenheit():
    # One 1e6 µm sample drove the bearing loss to its bound without a word;
    # air in Fahrenheit passed as °C.
    truth = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = truth.simulate(DutyCycle([(7200, 4000)]), sample_period_s=120, noise=False)
    broken = runs.copy()
    broken.loc[20, "disp_ch1_um"] = 1e6
    model = truth.with_params({"q.bearing_W": 0.7 * truth.params["q.bearing_W"]})
    kw = {"channels": ["disp_ch1_um"], "initial": "ambient"}
    _, clean = model.calibrate(runs, ["q.bearing_W"], **kw)
    with pytest.warns(UserWarning, match=r"disp_ch1_um = 1e\+06 at time_s 2400"):
        _, result = model.calibrate(broken, ["q.bearing_W"], **kw)
    np.testing.assert_allclose(result.params, clean.params, rtol=1e-3)
    # A first reading 30 K off, read for the run's initial state.
    first = runs.copy()
    first.loc[0, "T1_C"] += 30.0
    with pytest.warns(UserWarning, match=r"T1_C = .* at time_s 0 "):
        _, result = model.calibrate(
            first, ["q.bearing_W"], channels=["disp_ch1_um"], initial="measured"
        )
    _, clean = model.calibrate(
        runs, ["q.bearing_W"], channels=["disp_ch1_um"], initial="measured"
    )
    np.testing.assert_allclose(result.params, clean.params, rtol=0.01)
    # Not read at all (initial="ambient", T1_C not fitted): not said.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.calibrate(first, ["q.bearing_W"], **kw)
    fahrenheit = runs.assign(ambient_C=runs["ambient_C"] * 1.8 + 32)
    with pytest.warns(UserWarning, match=r"ambient_C' reads .* in Fahrenheit\?"):
        model.calibrate(fahrenheit, ["q.bearing_W"], **kw)


def test_calibration_names_a_dead_channel_and_an_index_of_runs():
    # A dead probe calibrated silently; run labels in the index were called
    # missing.
    rig = ThermalMachine.from_preset("spindle-rig", effects=[])
    runs = rig.simulate(DutyCycle([(3600, 4000)]), sample_period_s=120, noise=False)
    with pytest.warns(UserWarning, match=r"\['disp_ch1_um'\] are constant on every"):
        _, dead = rig.calibrate(
            runs.assign(disp_ch1_um=0.0),
            ["q.bearing_W"],
            channels=["disp_ch1_um", "disp_ch2_um"],
        )
    # A glitch on the dead probe (which tells nothing of its size) is left out.
    glitch = runs.assign(disp_ch1_um=0.0)
    glitch.loc[10, "disp_ch1_um"] = 25.0
    with pytest.warns(UserWarning, match=r"\['disp_ch1_um'\] are constant on every"):
        _, result = rig.calibrate(
            glitch, ["q.bearing_W"], channels=["disp_ch1_um", "disp_ch2_um"]
        )
    np.testing.assert_allclose(result.params, dead.params, rtol=1e-6)
    with pytest.raises(
        ValueError, match=r"\['run', 'time_s'\] are levels of its index: runs.re"
    ):
        rig.calibrate(runs.set_index(["run", "time_s"]), ["q.bearing_W"])


def test_a_channel_that_barely_moves_does_not_bend_the_calibration():
    # disp_x of this test is noise around zero (0.4 µm against 19 and 4.5
    # µm): scaled by its own spread, it weighed as much as disp_y and the fit
    # chased its noise (k 0.33 for 1.8, disp_z's error up from 0.3 to 2 µm).
    machine = ThermalMachine.from_preset("vmc-b")
    duty = DutyCycle.heat_cool(8000, heat_h=1, cool_h=1)
    air = AmbientProfile(
        mean_C=20, day_amplitude_C=2.5, door_events=[DoorEvent(start_h=1.5)]
    )
    run = machine.simulate(duty, air, sample_period_s=30, run="V", random_state=2)
    _, result = machine.calibrate(run, ["q.bearing_W", "k.y.carrier3"])
    np.testing.assert_allclose(result.params, [10.0, 1.8], rtol=0.06)
    assert (result.rmse_after <= 1.05 * result.rmse_before).all()


def test_response_names_a_driver_of_the_wrong_shape():
    machine = ThermalMachine.from_preset("spindle-rig", effects=[])
    t = np.arange(0, 3600, 60.0)
    rpm = np.full(t.size, 3000.0)
    with pytest.raises(ValueError, match=r"ambient_C must be a flat .* got shape \(\)"):
        machine.response(t, rpm, 20.0)
    with pytest.raises(ValueError, match=r"spindle_rpm .* shape \(60,\).*\(60, 1\)"):
        machine.response(t, rpm[:, None], np.full(t.size, 20.0))


def test_read_takes_a_dataframe_by_column_name():
    m = ThermalMachine.from_preset("spindle-rig", effects=[])
    _, states = m.simulate(
        DutyCycle.heat_cool(6000, heat_h=1, cool_h=1), noise=False, return_states=True
    )
    air = np.full(len(states), 20.0)
    channels = ["T1_C", "disp_ch1_um"]
    good = m.read(states.to_numpy(), air, channels, sample_period_s=30)
    shuffled = states[sorted(states.columns)]
    np.testing.assert_array_equal(
        m.read(shuffled, air, channels, sample_period_s=30), good
    )
    with pytest.raises(ValueError, match=r"no column for node\(s\) \['air'\]"):
        m.read(states.drop(columns="air"), air, channels, sample_period_s=30)
    # One channel by name, not its letters; a reference per node.
    np.testing.assert_array_equal(
        m.read(states, air, "T1_C", sample_period_s=30), good[:, :1]
    )
    with pytest.raises(ValueError, match="reference must be 9 node temperatures"):
        m.read(states, air, channels, sample_period_s=30, reference=[20, 20])
    with pytest.raises(ValueError, match="with n >= 1"):
        m.read(np.empty((0, 9)), np.empty(0), sample_period_s=30)


def test_response_times_are_nan_for_nodes_that_do_not_heat():
    m = ThermalMachine.from_preset("spindle-rig", effects=[])
    assert m.response_times(0, hours=4).isna().all()
    minutes = m.response_times(4000, hours=4)
    assert minutes.notna().all() and (minutes > 0).all()


def test_tool_growth_effect_leaves_the_displacement_map_as_documented():
    for name in ("vmc-b", "spindle-rig"):
        on = ThermalMachine.from_preset(name, effects=["tool_growth"])
        off = ThermalMachine.from_preset(name, effects=[])
        pd.testing.assert_frame_equal(
            on.displacement_matrix(), off.displacement_matrix()
        )
        assert on.displacement_matrix()[on.spec.tool].abs().sum() > 0
    doc = " ".join(ThermalMachine.displacement_matrix.__doc__.split())
    assert "counts only with" not in doc
    assert "on or off the ``tool_growth`` effect" in doc


def test_implausible_drivers_warn_naming_the_value():
    # A spindle beyond 1e5 rpm or a feed beyond 2e5 mm/min is a typo or a
    # unit slip: the simulation warns, naming the value, run and row.
    from skthermal.simulate import ImplausibleDriverWarning

    m = ThermalMachine.from_preset("vmc-b", effects=[])
    t = np.arange(5) * 60.0
    rpm = np.array([3000.0, 3000.0, 4e5, 4e5, 0.0])
    with pytest.warns(
        ImplausibleDriverWarning,
        match=r"spindle_rpm is 400000 rpm in run 'r2' at row 2 \(2 such row\(s\)\)",
    ):
        m.simulate_drivers(t, rpm, np.full(5, 20.0), run="r2", noise=False)
    with pytest.warns(ImplausibleDriverWarning, match=r"feed_mm_min is 3e\+06 mm/min"):
        m.simulate_drivers(
            t, np.zeros(5), np.full(5, 20.0), np.full(5, -3e6), noise=False
        )
    with warnings.catch_warnings():
        # 30000 rpm is a plausible speed (this machine's bearings get far too
        # hot at it, which another warning says).
        warnings.simplefilter("error", ImplausibleDriverWarning)
        warnings.filterwarnings("ignore", message="ThermalMachine: .* rises")
        m.simulate_drivers(t, np.full(5, 30000.0), np.full(5, 20.0), noise=False)


@pytest.mark.filterwarnings("ignore::skthermal.simulate.ImplausibleDriverWarning")
def test_absurd_drivers_and_stiff_parameters_are_named_not_nan():
    m = ThermalMachine.from_preset("spindle-rig")
    t = np.arange(5) * 60.0
    with pytest.raises(
        ValueError, match=r"heat input is not finite .*spindle_rpm 1e\+308"
    ):
        m.response(t, np.full(5, 1e308), np.full(5, 20.0))
    with pytest.raises(ValueError, match=r"not finite: .*speed 1e\+200 rpm"):
        m.response(t, np.full(5, 1e200), np.full(5, 20.0))
    for where, value, named in (
        ("capacity", 1e-300, r"smallest capacity C.spindle = 1e-300"),
        ("conductance", 1e300, r"largest conductance G.spindle-housing = 1e\+300"),
    ):
        data = {
            "name": "mini",
            "axes": ["z"],
            "roles": {"enclosure": "air", "tool": "spindle"},
            "nodes": {
                "spindle": {"capacity_J_per_K": 2000.0, "convection_W_per_K": 0.5},
                "housing": {"capacity_J_per_K": 20000.0, "convection_W_per_K": 3.0},
                "air": {"capacity_J_per_K": 50000.0, "convection_W_per_K": 40.0},
            },
            "links": [{"between": ["spindle", "housing"], "conductance_W_per_K": 5.0}],
            "heat": {"bearing": {"node": "spindle", "W_at_1000_rpm": 4.0}},
            "displacement": {"z": {"spindle": 2.0}},
        }
        if where == "capacity":
            data["nodes"]["spindle"]["capacity_J_per_K"] = value
        else:
            data["links"][0]["conductance_W_per_K"] = value
        stiff = ThermalMachine.from_spec(data, effects=[])
        with pytest.raises(ValueError, match=named):
            stiff.simulate(
                DutyCycle([(3600, 6000)]), 20.0, sample_period_s=60, noise=False
            )


def test_a_run_label_is_one_label(vmc_b):
    t = np.arange(5) * 30.0
    for run in (None, np.nan, ["a", "b"], True):
        with pytest.raises(ValueError, match="run must be one run label"):
            vmc_b.simulate_drivers(t, np.zeros(5), np.full(5, 20.0), run=run)


def test_a_duty_cycle_too_long_to_hold_or_not_a_sequence_is_named():
    # A duration in the wrong unit asked numpy for 124 GiB (a MemoryError
    # traceback, on the command line too); None failed inside iteration.
    machine = ThermalMachine.from_preset("spindle-rig")
    with pytest.raises(
        ValueError, match=r"lasts 1e\+12 s .*more than skthermal simulates in one run"
    ):
        machine.simulate([(1e12, 4000)], sample_period_s=60)
    for duty in (None, "3600,4000", 5.0):
        with pytest.raises(ValueError, match="A duty cycle is a sequence of segments"):
            DutyCycle(duty)
    # A test typed in milliseconds (8 h as 2.9e7 s) fits, but is warned about.
    with pytest.warns(UserWarning, match=r"lasts 333.3 days.*in milliseconds\?"):
        long = machine.simulate(
            [(4 * 3600e3, 3000), (4 * 3600e3, 0)], sample_period_s=3600, noise=False
        )
    assert len(long) == 8 * 1000 + 1
    with warnings.catch_warnings():  # four weeks: a long soak, not a unit slip
        warnings.simplefilter("error")
        machine.simulate([(28 * 86400, 0)], sample_period_s=3600, noise=False)


def test_workshop_air_in_another_unit_warns_where_it_is_made():
    # AmbientProfile(mean_C=293) simulated silently; validate_runs warned
    # for the same value in a table.
    with pytest.warns(UserWarning, match=r"mean_C=293 lies outside .*in kelvin\?") as w:
        AmbientProfile(mean_C=293.0)
    assert w[0].filename == __file__  # the user's line, not the dataclass's
    with pytest.warns(UserWarning, match=r"mean_C=80 .*in Fahrenheit\?"):
        AmbientProfile(mean_C=80.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        AmbientProfile(mean_C=22.0)
