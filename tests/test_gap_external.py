"""Tests of the gap diagnosis between two run tables (skthermal.gap.diagnose_runs),
its discrepancy terms and its structure-selection evidence."""

import dataclasses
import json
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from skthermal.gap import ExternalGapReport, diagnose_runs
from skthermal.gap._evidence import (
    cumulated_periodogram,
    effective_samples,
    explainable_gap,
    likelihood_ratio,
    whiteness,
)
from skthermal.gap._terms import TERMS, RunSignals, Signals, ToolGrowth


def _lowpass(x, tau, dt=60.0):
    a = np.exp(-dt / tau)
    x = np.asarray(x, dtype=float)
    return lfilter([1 - a], [1, -a], x, axis=0, zi=a * x[:1])[0]


def _tables(rng, truth="null", n_runs=4, hours=6.0, noise=0.01):
    """A plain-numpy simulation (two temperatures, one displacement) and its
    'measurement' with ``truth`` added."""
    sims, meas = [], []
    for r in range(n_runs):
        t = np.arange(0, hours * 3600, 60.0)
        # Random on/off blocks of 30-90 min at random speeds.
        edges = np.cumsum(rng.uniform(1800, 5400, 20))
        block = np.searchsorted(edges, t)
        speeds = rng.choice([2000.0, 4000.0, 6000.0, 8000.0], 20)
        rpm = np.where(block % 2 == r % 2, speeds[block], 0.0)
        air = (
            20
            + 0.5 * np.sin(2 * np.pi * t / 86400 + r)
            + 0.05 * np.cumsum(rng.standard_normal(t.size)) / np.sqrt(t.size)
        )
        heat = _lowpass((rpm / 1000) ** 1.3, 2400.0)
        T1 = air + 0.8 * heat
        T2 = air + 0.3 * _lowpass(heat, 3600.0)
        dz = 4.0 * heat + 2.0 * _lowpass(heat, 7200.0)
        sim = np.column_stack([T1, T2, dz])
        true = 1.1 * sim + np.array([0.3, -0.2, 5.0])
        if truth in ("tool_growth", "slow_tool_growth"):
            rise = dz - dz[0]
            tau = 600.0 if truth == "tool_growth" else 4800.0
            true[:, 2] -= 0.3 * _lowpass(np.sqrt(rpm / 1000) * rise, tau)
        elif truth == "steep_speed_convection":
            # Convection growing as n^3: beyond the term's exponents.
            rise = sim - sim[0]
            true -= 0.03 * _lowpass((rpm / 1000)[:, None] ** 3 * rise, 3600.0)
        elif truth == "sensor_lag":
            true[:, :2] = _lowpass(true[:, :2], 900.0)
        y = true + noise * rng.standard_normal(true.shape) * [1, 1, 10]
        base = {"run": f"r{r}", "time_s": t, "spindle_rpm": rpm, "ambient_C": air}
        cols = ["T1_C", "T2_C", "disp_z_um"]
        sims.append(pd.DataFrame({**base, **dict(zip(cols, sim.T))}))
        meas.append(pd.DataFrame({**base, **dict(zip(cols, y.T))}))
    return pd.concat(sims, ignore_index=True), pd.concat(meas, ignore_index=True)


# --- evidence ---------------------------------------------------------------


def test_whiteness_flags_ar1_and_passes_white_noise(rng):
    e = rng.standard_normal(2000)
    ar = lfilter([1.0], [1.0, -0.7], e)
    assert whiteness(e)["white"]
    w = whiteness(ar)
    assert not w["white"] and w["max_deviation"] > 3 * w["band"]
    assert w["lag1"] > 0.6
    # Pooled over runs of different amplitude, white stays white.
    assert whiteness([e[:700], 50 * e[700:]])["white"]


def test_cumulated_periodogram_ends_at_one_and_rises(rng):
    f, c = cumulated_periodogram([rng.standard_normal(100), rng.standard_normal(51)])
    assert f.size == 50 + 25 and np.all(np.diff(c) >= 0) and c[-1] == 1.0
    assert np.all((f > 0) & (f <= 1))
    with pytest.raises(ValueError, match="non-constant"):
        cumulated_periodogram(np.ones(10))


def test_effective_samples_shrinks_with_autocorrelation(rng):
    e = rng.standard_normal(5000)
    assert effective_samples(e) == pytest.approx(5000, rel=0.1)
    slow = lfilter([1.0], [1.0, -0.95], e)
    assert effective_samples(slow) == pytest.approx(5000 * 0.05 / 1.95, rel=0.3)
    per = effective_samples(np.column_stack([e, slow]), per_channel=True)
    assert per.shape == (2,) and per[0] > 10 * per[1]


def test_likelihood_ratio_p_value_behaviour():
    strong = likelihood_ratio(10.0, 5.0, n=200, extra_params=1)
    weak = likelihood_ratio(10.0, 9.9, n=200, extra_params=1)
    assert strong.p_value < 1e-10 < 0.05 < weak.p_value
    assert strong.statistic == pytest.approx(200 * np.log(2))
    # More extra parameters for the same gain: a larger p-value.
    assert (
        likelihood_ratio(10.0, 9.0, 200, 10).p_value
        > likelihood_ratio(10.0, 9.0, 200, 1).p_value
    )
    # Fewer effective samples: less evidence.
    assert (
        likelihood_ratio(10.0, 9.0, 20, 1).p_value
        > likelihood_ratio(10.0, 9.0, 200, 1).p_value
    )
    # No gain: p = 1, AIC and BIC prefer the smaller model.
    none = likelihood_ratio(10.0, 10.0, 200, 2)
    assert none.p_value == 1.0 and none.delta_aic > 0 and none.delta_bic > 0
    with pytest.raises(ValueError, match="positive"):
        likelihood_ratio(0.0, 1.0, 10, 1)
    with pytest.raises(ValueError, match="extra_params"):
        likelihood_ratio(2.0, 1.0, 10, 0)


def test_explainable_gap_is_a_share_above_noise():
    assert explainable_gap(1.0, 0.6, 0.0) == pytest.approx(0.4)
    # A flexible model that makes the held-out gap worse is not clipped to 0.
    assert explainable_gap(1.0, 1.2, 0.0) == pytest.approx(-0.2)
    # Against the noise floor: closing down to noise is everything.
    assert explainable_gap(0.5, 0.3, 0.09) == pytest.approx(1.0)


# --- terms ------------------------------------------------------------------


def test_terms_cover_the_vocabulary():
    from skthermal.simulate import EFFECTS

    assert set(TERMS) == set(EFFECTS)


def test_tool_growth_term_recovers_its_time_constant(rng):
    t = np.arange(0, 6 * 3600, 60.0)
    # Three speeds, each followed by a stop: at one speed the exponent and
    # the gain could not be told apart.
    speeds = np.array([2000.0, 0.0, 6000.0, 0.0, 4000.0, 0.0])
    rpm = speeds[(t // 3600).astype(int)]
    sim = np.column_stack([5 * _lowpass(rpm / 1000, 1800.0)])
    rise = sim - sim[0]
    y_full = 1.5 * sim - 0.2 * _lowpass(np.sqrt(rpm / 1000)[:, None] * rise, 900.0)
    rows = np.arange(t.size)
    y = y_full - y_full[:5].mean(axis=0)
    run = RunSignals("a", t, rpm, np.full(t.size, 20.0), 0 * t, sim, rows, y)
    term = ToolGrowth().fit(Signals([run], np.array([False]), np.ones(1)), [0])
    assert term.theta_["tau_s"] == pytest.approx(900.0, rel=0.1)
    assert 0.5 <= term.theta_["exponent"] <= 0.7
    assert term.gains_[0, 0] == pytest.approx(1.5, rel=0.01)
    assert term.gains_[0, 1] < 0
    assert term.cost_ < 1e-4 * float(np.sum(y**2))


def test_term_fits_share_grid_statistics_without_changing_them(rng):
    """The folds' fits share each run's statistics at the grid's points
    (``cache``): the fitted parameters and gains are those of separate
    fits, and the cost from the statistics is the sum of squared errors."""
    runs = []
    for r in range(4):
        t = np.arange(0, 4 * 3600, 60.0)
        rpm = np.where((t // 1800) % 2 == r % 2, 3000.0 + 500 * r, 0.0)
        sim = np.column_stack(
            [_lowpass(rpm / 1000, 1800.0), _lowpass(rpm / 1000, 600.0)]
        )
        y = sim + 0.3 * (_lowpass(sim, 700.0) - sim)
        y = y + 0.005 * rng.standard_normal(y.shape)
        rows = np.arange(0, t.size, 2)
        y = y[rows] - y[rows][:5].mean(axis=0)
        runs.append(RunSignals(r, t, rpm, np.full(t.size, 20.0), 0 * t, sim, rows, y))
    signals = Signals(runs, np.array([True, True]), np.array([1.0, 2.0]))
    cache = {}
    folds = [[0, 1, 2], [1, 2, 3], [0, 2, 3]]
    for train in folds:
        shared = TERMS["sensor_lag"]().fit(signals, train, cache)
        alone = TERMS["sensor_lag"]().fit(signals, train)
        assert shared.theta_ == alone.theta_
        np.testing.assert_array_equal(shared.gains_, alone.gains_)
        pred = shared.apply(signals, train)
        sse = sum(
            np.sum(((p - signals.runs[i].y) * signals.w) ** 2)
            for p, i in zip(pred, train)
        )
        assert shared.cost_ == pytest.approx(sse, rel=1e-9)
    assert shared.theta_["tau_s"] == pytest.approx(700.0, rel=0.1)
    # The grid's points of every run, once each.
    assert len(cache) == 4 * TERMS["sensor_lag"].grid


# --- diagnosis --------------------------------------------------------------


def test_post_stop_term_is_ranked_first_and_named(rng):
    sim, meas = _tables(rng, "tool_growth")
    report = diagnose_runs(sim, meas, greedy=False)
    assert isinstance(report, ExternalGapReport)
    assert report.ranking["effect"].iloc[0] == "tool_growth"
    assert report.best_effect == "tool_growth"
    top = report.ranking.iloc[0]
    assert top["shrink"] > 0.8 and top["p_value"] < 0.05
    assert top["lr_p_value"] < 0.05
    assert top["fitted"]["tau_s"] == pytest.approx(600.0, rel=0.3)
    # The truth's exponent, 0.5 (sqrt), is the range's lower end, which
    # physics reaches (laminar convection): named, the end said.
    assert top["on_bound"].startswith("exponent = 0.5 (the lower end")
    assert top["stopped"] == ""
    assert "Its fitted exponent = 0.5 (the lower end of 0.5-1) sits" in report.verdict()
    # How far: per regime, and the after-stop gap shrinks.
    hf = report.how_far.set_index("regime")
    assert hf.loc["overall", "gap_after"] < 0.5 * hf.loc["overall", "gap_before"]
    assert hf.loc["after stop", "shrink"] > 0.5
    assert "tool_growth" in report.verdict()
    assert 0 < report.explainable["share"] <= 1


def test_a_candidate_short_of_min_shrink_is_said_so(rng):
    # The verdict that names nothing says how far the best candidate falls
    # short, its share never rounded up to the threshold (an independent
    # check read "removes 50%" beside "No candidate effect explains" at the
    # default 50%).
    # (The rounding itself: the doctest of skthermal._naming.percent.)
    sim, meas = _tables(rng, "tool_growth", noise=0.1)
    report = diagnose_runs(
        sim, meas, greedy=False, min_shrink=0.99, candidates=["tool_growth"]
    )
    assert report.best_effect is None
    shrink = report.ranking.iloc[0]["shrink"]
    assert 0.8 < shrink < 0.99
    assert f"removes {round(shrink * 100)}% of" in report.verdict()
    assert "short of the 99% that names an effect" in report.verdict()


def test_a_candidate_that_removes_nothing_gets_no_stopped_sentence(pair):
    # An exact null case: the best candidate removes 0% and its time
    # constant sits on the range's end; why that end keeps it from being
    # named was a paragraph about a candidate nothing would name.
    sim, meas = pair
    report = diagnose_runs(sim, meas, greedy=False)
    top = report.ranking.iloc[0]
    assert top["shrink"] < 0.5 and top["stopped"]
    assert "stopped it" not in report.verdict()


def test_sensor_lag_is_named(rng):
    sim, meas = _tables(rng, "sensor_lag")
    report = diagnose_runs(
        sim,
        meas,
        candidates=["sensor_lag", "feed_heating", "sensor_drift"],
        greedy=False,
    )
    assert report.best_effect == "sensor_lag"
    assert report.ranking.iloc[0]["fitted"]["tau_s"] == pytest.approx(900, rel=0.3)
    assert "also pass" not in report.verdict()
    # A runner-up that passes the test alone is named beside the verdict (an
    # independent truth: 'speed_convection' named, 'tool_growth' passing too).
    ranking = report.ranking.copy()
    ranking.loc[ranking["effect"] == "sensor_drift", ["explains", "shrink"]] = [
        True,
        0.51,
    ]
    both = dataclasses.replace(report, ranking=ranking)
    assert both.verdict().startswith(report.verdict().split(" Not applicable")[0])
    assert "Alone, 'sensor_drift' (51%) also pass(es) the test" in both.verdict()
    assert "Runner-up" not in report.verdict()
    # One that comes close without passing is said too (an independent
    # check: 'tool_growth' at 47% beside the named effect's 50%, unsaid).
    named = float(ranking.loc[ranking["effect"] == "sensor_lag", "shrink"].iloc[0])
    ranking.loc[ranking["effect"] == "sensor_drift", ["explains", "shrink"]] = [
        False,
        named - 0.05,
    ]
    close = dataclasses.replace(report, ranking=ranking).verdict()
    assert f"Runner-up 'sensor_drift' removes {round(100 * (named - 0.05))}%" in close
    assert "barely tell the two apart" in close


def test_a_candidate_stopped_by_its_range_is_not_named(rng):
    # A fitted parameter stopped by its range fits something else: the
    # verdict said so but named it all the same (independent truths: a
    # hydraulic load named 'feed_heating' at its 4 h time constant, a
    # coolant load 'speed_convection' at its largest exponent). Here the
    # convection grows as n^3, beyond the term's exponents (0.5-1.5).
    sim, meas = _tables(rng, "sensor_lag")
    report = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    assert report.best_effect == "sensor_lag"
    assert report.ranking["on_bound"].iloc[0] == ""
    assert "range's end" not in report.verdict()
    sim, meas = _tables(np.random.default_rng(2), "steep_speed_convection")
    report = diagnose_runs(sim, meas, candidates=["speed_convection"], greedy=False)
    top = report.ranking.iloc[0]
    assert top["shrink"] > 0.5 and top["p_value"] < 0.05  # it would pass
    assert top["on_bound"].startswith("exponent = 1.5 (the upper end")
    assert report.best_effect is None and not top["explains"]
    assert (
        "The fitted exponent = 1.5 (the upper end of 0.5-1.5) of "
        "'speed_convection' sits on its range's end, where the range stopped it"
    ) in report.verdict()
    assert "a candidate so stopped is not named" in report.verdict()


def test_null_gain_and_offset_call_none(rng):
    sim, meas = _tables(rng, "null")
    report = diagnose_runs(sim, meas)
    assert report.best_effect is None
    assert "No candidate effect explains the gap beyond noise" in report.verdict()
    assert "The held-out gap (" in report.verdict()  # within the noise
    assert not report.ranking["explains"].any()
    # The base (gain per channel, offsets as change since start) closes the
    # gap down to the noise.
    where = report.where["runs"]
    calibrated = where[where["model"] == "base calibrated"]["gap"].mean()
    given = where[where["model"] == "as given"]["gap"].mean()
    assert calibrated < 0.5 * given
    text = report.to_markdown()
    assert "How much any added term could close" in text
    # No greedy steps: no bare "(none)" line that reads as an empty How far.
    assert len(report.steps) == 0 and "(greedy)" not in text
    assert "\n(none)\n" not in text.split("## How far")[1].split("## Where")[0]
    data = json.loads(report.to_json())
    assert data["explainable"]["share"] >= 0
    assert {"lr_p_value", "whiteness_after"} <= set(data["ranking"][0])


# --- errors -----------------------------------------------------------------


@pytest.fixture
def pair():
    return _tables(np.random.default_rng(0), "null", n_runs=3, hours=2.0)


def test_absurd_values_are_refused_by_name(pair):
    # One 1e300 reading used to overflow the squares: in the measured table
    # the verdict changed without a word, in the simulated one an error of
    # the evidence's internals.
    sim, meas = pair
    row = meas.index[10]
    for table, label in ((meas, "measured"), (sim, "simulated")):
        broken = table.copy()
        broken.loc[row, "T2_C"] = 1e300
        args = (sim, broken) if label == "measured" else (broken, meas)
        with pytest.raises(
            ValueError,
            match=rf"T2_C holds 1e\+300 in run 'r0' of the {label} table at row "
            r"10 of the run \(time_s 600\)",
        ):
            diagnose_runs(*args, candidates=["sensor_lag"])
    broken = meas.copy()
    broken.loc[row, "ambient_C"] = -1e200
    with pytest.raises(ValueError, match=r"ambient_C is absurd \(-1e\+200"):
        diagnose_runs(sim, broken, candidates=["sensor_lag"])


def test_two_measured_columns_onto_one_simulated_are_refused(pair):
    sim, meas = pair
    with pytest.raises(ValueError, match="'T1_C' and 'T2_C' would both be"):
        diagnose_runs(sim, meas, mapping={"T2_C": "T1_C"})


def test_different_drivers_are_named(pair):
    sim, meas = pair
    sim = sim.copy()
    sim.loc[sim.index[sim["run"] == "r1"][10], "spindle_rpm"] += 500
    with pytest.raises(ValueError, match=r"spindle_rpm in run 'r1' at row 10"):
        diagnose_runs(sim, meas)
    sim2 = pair[0].assign(feed_mm_min=1000.0)
    with pytest.raises(ValueError, match="feed_mm_min.*absent from one table"):
        diagnose_runs(sim2, meas)
    # Air off by its reading noise: the simulation was exported with noise.
    rng = np.random.default_rng(4)
    noisy = pair[0].assign(
        ambient_C=np.round(pair[0]["ambient_C"] + rng.normal(0, 0.08, len(pair[0])), 1)
    )
    with pytest.raises(ValueError, match=r"exported with its sensors' noise"):
        diagnose_runs(noisy, meas)
    # Off by a constant: another air probe (the noise hint pointed an
    # external tool's user at skthermal's simulator).
    offset = pair[0].assign(ambient_C=pair[0]["ambient_C"] + 0.3)
    with pytest.raises(
        ValueError, match=r"the simulated air is the measured one offset by \+0\.3 K"
    ):
        diagnose_runs(offset, meas)
    offset = pair[0].assign(ambient_C=pair[0]["ambient_C"] + 1.5)
    with pytest.raises(
        ValueError, match=r"the simulated air is the measured one offset by \+1\.5 K"
    ):
        diagnose_runs(offset, meas)
    # In another unit: said.
    fahrenheit = pair[0].assign(ambient_C=pair[0]["ambient_C"] * 1.8 + 32.0)
    with pytest.raises(ValueError, match=r"the simulated air in °F\?"):
        diagnose_runs(fahrenheit, meas)
    # The measured air noisy, the simulated one smooth: the simulation was
    # driven by another air series (the hint said to export it without noise,
    # which it was).
    rng = np.random.default_rng(3)
    logged = meas.assign(
        ambient_C=np.round(meas["ambient_C"] + rng.normal(0, 0.08, len(meas)), 1)
    )
    with pytest.raises(
        ValueError,
        match=r"the simulated air is smooth and the measured one noisy: .* drive "
        r"it with the measured ambient_C, e\.g\. ThermalMachine\.simulate_drivers",
    ):
        diagnose_runs(pair[0], logged)
    # Another air series altogether: no hint but to simulate the measured one.
    wave = 5.0 * np.cos(np.arange(len(pair[0])) / 7.0)
    other = pair[0].assign(ambient_C=pair[0]["ambient_C"] + wave)
    with pytest.raises(ValueError, match=r"simulated; simulate the measured") as info:
        diagnose_runs(other, meas)
    assert "noise" not in str(info.value) and "offset" not in str(info.value)
    # A simulated table that writes it otherwise: named (a measured one is
    # refused for it up front).
    sim3 = pair[0].assign(feed_mm_s=1000.0 / 60.0)
    with pytest.raises(
        ValueError, match=r"table: 0\) \('feed_mm_s' looks like 'feed_mm_min'"
    ):
        diagnose_runs(sim3, meas.assign(feed_mm_min=1000.0))


def test_missing_runs_and_columns_are_named(pair):
    sim, meas = pair
    with pytest.raises(ValueError, match=r"\['r2'\].*missing from the simulated"):
        diagnose_runs(sim[sim["run"] != "r2"], meas)
    numbered = {"r0": 0, "r1": 1, "r2": 2}
    with pytest.raises(ValueError, match="the labels differ only in type"):
        diagnose_runs(
            sim.assign(run=sim["run"].map(numbered).astype(str)),
            meas.assign(run=meas["run"].map(numbered)),
        )
    with pytest.raises(ValueError, match="no \\['ambient_C'\\] column"):
        diagnose_runs(sim.drop(columns="ambient_C"), meas)
    with pytest.raises(ValueError, match="No measured channel"):
        renamed = {"T1_C": "T1_K", "T2_C": "T2_K", "disp_z_um": "dz"}
        diagnose_runs(sim.rename(columns=renamed), meas)
    with pytest.raises(ValueError, match="Unknown effect"):
        diagnose_runs(sim, meas, candidates=["coolant"])


def test_a_simulation_at_other_times_is_interpolated(pair):
    # Another tool's export at its own time step is interpolated onto the
    # measured times; it must cover them, with the measured drivers.
    sim, meas = pair
    coarse = pd.concat(
        [f.iloc[np.r_[0 : len(f) - 1 : 3, len(f) - 1]] for _, f in sim.groupby("run")],
        ignore_index=True,
    )  # every third sample, and the last
    given = diagnose_runs(sim, meas, greedy=False).where["runs"]
    again = diagnose_runs(coarse, meas, greedy=False).where["runs"]
    np.testing.assert_allclose(again["gap"], given["gap"], rtol=0.1, atol=0.01)
    short = sim.drop(index=sim.index[sim["run"] == "r1"][-1])
    with pytest.raises(ValueError, match="Run 'r1': the simulated table covers"):
        diagnose_runs(short, meas)
    # The span is the simulation's whole span, not the part compared; a
    # measurement in a clock's time is told so.
    with pytest.raises(
        ValueError, match=r"covers time_s 0-7140 s, the measured one 36"
    ):
        diagnose_runs(sim, meas.assign(time_s=meas["time_s"] + 3600.0))
    with pytest.raises(ValueError, match=r"covers time_s 0-7140 s.*a clock's time"):
        diagnose_runs(sim, meas.assign(time_s=meas["time_s"] + 1.78e9))
    wrong = coarse.copy()
    wrong.loc[wrong.index[wrong["run"] == "r2"][4], "spindle_rpm"] += 500
    with pytest.raises(ValueError, match="spindle_rpm in run 'r2' at simulated row 4"):
        diagnose_runs(wrong, meas)
    back = sim.copy()
    back.loc[back.index[back["run"] == "r0"][7], "time_s"] -= 90.0
    with pytest.raises(ValueError, match="not strictly increasing in run 'r0' of the"):
        diagnose_runs(back, meas)
    # A table out of order is told to be sorted; a repeated time, to drop it.
    shuffled = meas.sample(frac=1.0, random_state=0)
    with pytest.raises(ValueError, match=r"out of order\? Sort the table"):
        diagnose_runs(sim, shuffled)
    twice = meas.copy()
    twice.loc[twice.index[5], "time_s"] = twice.loc[twice.index[4], "time_s"]
    with pytest.raises(ValueError, match="A repeated time: drop the duplicated row"):
        diagnose_runs(sim, twice)


def test_a_measurement_that_starts_late_reads_the_simulation_before_it(rng):
    # A logger started 30 min into the runs: the simulated rows before the
    # measured start were dropped, so the terms' filters started cold there,
    # and the planted 15 min sensor lag made the gap worse (named none).
    sim, meas = _tables(rng, "sensor_lag", n_runs=3, hours=6.0)
    late = meas[meas["time_s"] >= 1800.0]
    with warnings.catch_warnings():
        # Runs that start at 1800 s: no clock's time, the simulation
        # starts before them.
        warnings.filterwarnings("error", message=".*do not start at 0")
        report = diagnose_runs(sim, late, candidates=["sensor_lag", "sensor_drift"])
    assert report.best_effect == "sensor_lag"
    row = report.ranking.set_index("effect").loc["sensor_lag"]
    assert row["shrink"] > 0.5
    # Times in the where tables are the tables' own (from the run's start).
    assert sorted(set(report.where["runs"]["run"])) == ["r0", "r1", "r2"]
    jumps = report.where["jumps"]
    assert jumps.empty or jumps["time_s"].min() >= 1800.0


def test_a_gap_within_the_noise_names_no_effect(rng):
    # The measurement is the simulation plus white noise: a term fitted to
    # noise "removed 100% of the gap above noise" (the gap fell by 2%, at
    # p = 0.04) and was named. An effect is named only for a gap beyond
    # the noise.
    from skthermal.gap._scores import MIN_EXCESS, beyond_noise

    assert beyond_noise(1.3, 1.0) and not beyond_noise(1.2, 1.0)
    assert beyond_noise(np.sqrt(1 + MIN_EXCESS**2), 1.0)
    sim, _ = _tables(rng, "null", n_runs=4, hours=6.0)
    cols = ["T1_C", "T2_C", "disp_z_um"]
    meas = sim.copy()
    meas[cols] += 0.01 * rng.standard_normal((len(sim), 3)) * [1, 1, 10]
    report = diagnose_runs(sim, meas)
    assert report.best_effect is None
    assert not report.ranking["explains"].any()
    assert "is within the noise (floor" in report.verdict()


def test_a_glitch_does_not_swamp_the_noise_floor(pair):
    # One glitch of one sample in one channel took the noise floor, and with
    # it the verdict, from "3.1 times the noise floor" to "within the noise"
    # without a word; in the simulated table it added millions of percent.
    sim, meas = pair
    clean = diagnose_runs(sim, meas, candidates=["sensor_lag"])
    row = meas.index[meas["run"] == "r1"][30]
    for table, label in ((meas, "measured"), (sim, "simulated")):
        broken = table.copy()
        broken.loc[row, "T2_C"] += 1e6
        args = (sim, broken) if label == "measured" else (broken, meas)
        with pytest.warns(UserWarning) as caught:
            report = diagnose_runs(*args, candidates=["sensor_lag"])
        said = [str(w.message) for w in caught]
        assert any(
            re.search(rf"of run 'r1' of the {label} table .* T2_C = ", m) for m in said
        ), said
        if label == "measured":  # as read_runs says it
            assert any("no machine tool reads a temperature above" in m for m in said)
            # ... and what it does to a gap, not only to a model's prediction.
            assert any("the gap diagnosis to the gap it measures" in m for m in said)
        assert report.noise_floor == pytest.approx(clean.noise_floor, rel=0.01)
        np.testing.assert_allclose(
            report.ranking["gap_before"], clean.ranking["gap_before"], rtol=0.01
        )


@pytest.mark.parametrize("factor", [1e3, 1e-3, -1.0])
def test_a_unit_slip_taken_up_by_the_base_gain_is_said(pair, factor):
    # Displacements in nm under a *_um header (1000 times the simulation):
    # the base gain took the factor up and the verdict read "the simulation
    # matches the measurement as far as the noise tells", the factor nowhere.
    sim, meas = pair  # measured = 1.1 x simulated + offsets
    slipped = meas.assign(disp_z_um=meas["disp_z_um"] * factor)
    gain = re.escape(f"{1.1 * factor:.2g}")
    with pytest.warns(
        UserWarning,
        match=rf"fits the measurement only scaled \('disp_z_um' by {gain}: "
        r"the base gain .* a unit slip",
    ):
        diagnose_runs(sim, slipped, candidates=["sensor_lag"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        diagnose_runs(sim, meas, candidates=["sensor_lag"])  # gains of 1.1


def test_blocks_shorter_than_a_few_samples_are_refused(pair):
    # block_hours below a sampling period raised an AssertionError about
    # duplicate block labels; a little above it, "Run 'r0[0-0 s]' has 0
    # samples", a block that does not exist.
    sim, meas = pair
    one = meas["run"] == "r0"
    for hours in (0.001, 0.1):
        with pytest.raises(
            ValueError,
            match=r"block_hours=.* cuts run 'r0' \(120 samples, every 60 s\) "
            r"into \d+ blocks; a block needs at least 8 samples: give "
            r"block_hours of at least 0\.2\.",
        ):
            diagnose_runs(sim[sim["run"] == "r0"], meas[one], block_hours=hours)
    report = diagnose_runs(
        sim[sim["run"] == "r0"], meas[one], block_hours=0.2, candidates=["sensor_lag"]
    )
    assert report.ranking.shape[0] == 1


def test_empty_tables_and_missing_values(pair):
    sim, meas = pair
    with pytest.raises(ValueError, match="simulated run table is empty"):
        diagnose_runs(sim.iloc[:0], meas)
    with pytest.raises(ValueError, match="measured run table is empty"):
        diagnose_runs(sim, meas.iloc[:0])
    bad = meas.copy()
    bad.loc[bad.index[5], "T1_C"] = np.nan
    with pytest.raises(ValueError, match="T1_C is missing .* run 'r0' of the measured"):
        diagnose_runs(sim, bad)
    with pytest.raises(ValueError, match="at least 2 runs"):
        diagnose_runs(sim[sim["run"] == "r0"], meas[meas["run"] == "r0"])


# --- audit fixes --------------------------------------------------------------


def test_constant_channels(pair):
    sim, meas = pair
    # Constant in the simulation only: a channel it does not model, where no
    # missing effect can be judged (a term of the drivers alone would take
    # up its whole change), is left out with a warning...
    with pytest.warns(UserWarning, match=r"\['T2_C'\] are constant .* left out"):
        report = diagnose_runs(sim.assign(T2_C=21.0), meas, greedy=False)
    assert report.settings["channels"] == ["T1_C", "disp_z_um"]
    # ... and named in channels=, compared with a base gain of 0.
    with pytest.warns(UserWarning, match=r"simulated channel\(s\) \['T2_C'\] are"):
        report = diagnose_runs(
            sim.assign(T2_C=21.0), meas, channels=["T1_C", "T2_C"], greedy=False
        )
    assert "T2_C" in report.settings["channels"]
    assert report.machines["base calibrated"].gains_[1, 0] == 0.0
    with pytest.raises(ValueError, match="predicts no change on any compared"):
        diagnose_runs(sim.assign(T1_C=20.0, T2_C=21.0, disp_z_um=0.0), meas)
    # Constant in both tables: nothing to diagnose on it.
    flat_sim, flat_meas = sim.assign(T2_C=21.0), meas.assign(T2_C=21.0)
    with pytest.raises(ValueError, match=r"\['T2_C'\] are constant in both tables"):
        diagnose_runs(flat_sim, flat_meas, channels=["T2_C"])
    with pytest.warns(UserWarning, match=r"\['T2_C'\] are constant in both .* left"):
        report = diagnose_runs(flat_sim, flat_meas, greedy=False)
    assert report.settings["channels"] == ["T1_C", "disp_z_um"]


def test_ridge_is_well_posed_on_a_zero_unpenalised_feature(rng):
    from skthermal.gap._evidence import ridge_heldout

    feats = [rng.standard_normal((50, 2, 3)) for _ in range(3)]
    for f in feats:
        f[:, 1, 0] = 0.0  # the base feature of channel 1 is zero
    targets = [f[:, :, 1] + 0.1 * rng.standard_normal((50, 2)) for f in feats]
    folds = [([1, 2], [0]), ([0, 2], [1]), ([0, 1], [2])]
    out = ridge_heldout(targets, feats, folds, penalize=[False, True, True])
    assert all(np.all(np.isfinite(r)) for r in out)


def test_ridge_does_not_blow_up_a_feature_the_training_runs_barely_excite(rng):
    # A driver feature nearly constant on the training runs (a filtered speed
    # step long past) and large on the held-out run (the step itself): scaled
    # to its training variation it took a huge weight and the held-out
    # prediction blew up (a flexible model "worse by 1e12 %").
    from skthermal.gap._evidence import ridge_heldout

    feats = [rng.standard_normal((200, 1, 3)) for _ in range(4)]
    for i, f in enumerate(feats):
        f[:, 0, 2] = 1e-9 * rng.standard_normal(200) if i < 3 else 5.0
    targets = [f[:, :, 1] + 0.1 * rng.standard_normal((200, 1)) for f in feats]
    out = ridge_heldout(targets, feats, [([0, 1, 2], [3])])
    assert np.sqrt(np.mean(out[3] ** 2)) < 0.5


@pytest.mark.parametrize("name", sorted(TERMS))
def test_blocks_of_one_run_share_the_signals_of_the_longest(name, rng):
    # The blocks of one long run hold its first rows up to their ends; a
    # term's features worked out once on the longest block equal those of
    # every block on its own.
    t = np.arange(0, 6 * 3600.0, 60.0)
    rpm = np.where((t // 3600) % 2 == 0, 6000.0, 0.0)
    air = 20 + 0.5 * np.sin(t / 5000)
    feed = np.where((t // 1800) % 3 == 0, 2000.0, 0.0)
    sim = np.cumsum(rng.standard_normal((t.size, 3)), axis=0) * 0.01
    runs = []
    for a, b in [(0, 120), (120, 240), (240, 360)]:
        rows = np.arange(a, b)
        runs.append(
            RunSignals(
                f"r[{a}]",
                t[:b],
                rpm[:b],
                air[:b],
                feed[:b],
                sim[:b],
                rows,
                sim[rows] - sim[rows[0]],
                origin="r",
                period=60.0,
            )
        )
    signals = Signals(runs, np.array([True, True, False]), np.ones(3))
    term = TERMS[name]()
    theta = {k: float(np.sqrt(lo * hi)) for k, (lo, hi) in term.bounds.items()}
    if name == "ambient_transient":
        theta = {"tau_fast_s": 300.0, "tau_slow_s": 3000.0}
    shared = term.features_of(signals, [0, 1, 2], theta)
    for i, run in enumerate(runs):
        np.testing.assert_array_equal(shared[i], term.features(signals, run, theta))


def test_negative_speed_names_the_run_and_row(pair):
    sim, meas = pair
    sim, meas = sim.copy(), meas.copy()
    for frame in (sim, meas):
        frame.loc[frame.index[frame["run"] == "r1"][3], "spindle_rpm"] = -100.0
    with pytest.raises(
        ValueError,
        match=r"spindle_rpm is negative \(-100\) in run 'r1' of the measured table "
        r"at row 3",
    ):
        diagnose_runs(sim, meas)


def test_mapping_typos_and_uncompared_channels(pair):
    sim, meas = pair
    # A measured column that breaks the naming rule (a unit slip) was left
    # out of the comparison silently; named, as read_runs names it, unless
    # the mapping takes it.
    slip = meas.rename(columns={"disp_z_um": "disp_z_mm"})
    with pytest.raises(
        ValueError, match="'disp_z_mm' looks like a displacement"
    ) as info:
        diagnose_runs(sim, slip)
    # ... and that the mapping or channels= take it (the message said only
    # to rename or drop it).
    assert "channels=[...] or mapping={'measured': 'simulated'}" in str(info.value)
    mapped = diagnose_runs(sim, slip, mapping={"disp_z_mm": "disp_z_um"}, greedy=False)
    assert "disp_z_mm" in mapped.settings["channels"]
    with pytest.raises(
        ValueError,
        match=r"mapping value\(s\) \['disp_zz_um'\].*did you mean 'disp_z_um'",
    ):
        diagnose_runs(sim, meas, mapping={"disp_z_um": "disp_zz_um"})
    with pytest.raises(
        ValueError,
        match=r"mapping key\(s\) \['disp_zz_um'\].*did you mean 'disp_z_um'",
    ):
        diagnose_runs(sim, meas, mapping={"disp_zz_um": "disp_z_um"})
    with pytest.warns(UserWarning, match=r"\['T3_C'\] are not compared"):
        report = diagnose_runs(sim, meas.assign(T3_C=meas["T1_C"]), greedy=False)
    assert "T3_C" not in report.settings["channels"]
    # The same slip in the simulated table (another tool's export) leaves
    # the channel out: the warning names the near miss.
    with pytest.warns(
        UserWarning, match=r"for 'disp_z_um' the simulated table has 'disp_z_mm'"
    ) as record:
        diagnose_runs(
            sim.rename(columns={"disp_z_um": "disp_z_mm"}), meas, greedy=False
        )
    assert record[0].filename == __file__


def test_a_jittering_logger_clock_is_accepted(pair):
    # Measured times a few seconds off the simulation's grid (a logger's
    # clock): a speed step may fall on either side of a simulated row, and
    # the last sample may end beyond the simulation; a real shift is not.
    sim, meas = pair
    rng = np.random.default_rng(0)
    step = float(np.median(np.diff(meas["time_s"])))
    jitter = rng.uniform(-0.05, 0.05, len(meas)) * step
    jitter[meas.groupby("run").cumcount().to_numpy() == 0] = 0.0
    jittered = meas.assign(time_s=meas["time_s"] + jitter)
    report = diagnose_runs(sim, jittered, candidates=["sensor_lag"], greedy=False)
    assert np.isfinite(report.ranking["shrink"]).all()
    shifted = sim.assign(spindle_rpm=sim.groupby("run")["spindle_rpm"].shift(3).bfill())
    with pytest.raises(ValueError, match="The drivers differ: spindle_rpm"):
        diagnose_runs(shifted, jittered, candidates=["sensor_lag"])


def test_repeated_columns_are_named(pair):
    sim, meas = pair
    for side, column in (("simulated", "T1_C"), ("simulated", "spindle_rpm")):
        twice = pd.concat([sim, sim[[column]]], axis=1)
        with pytest.raises(ValueError, match=rf"{side} run table has .*'{column}'"):
            diagnose_runs(twice, meas)
    with pytest.raises(ValueError, match=r"measured run table has .*'T1_C'"):
        diagnose_runs(sim, pd.concat([meas, meas[["T1_C"]]], axis=1))


def test_another_tools_column_names_give_the_same_diagnosis(rng):
    # The kind of a channel comes from the measured (run-table) name, and a
    # mapping may start from a measured column of any name.
    sim, meas = _tables(rng, "tool_growth", n_runs=3, hours=3.0)
    kwargs = {"candidates": ["tool_growth", "sensor_lag"], "greedy": False}
    standard = diagnose_runs(sim, meas, **kwargs)
    renamed = sim.rename(columns={"disp_z_um": "uz", "T1_C": "temp1"})
    other = diagnose_runs(
        renamed, meas, mapping={"disp_z_um": "uz", "T1_C": "temp1"}, **kwargs
    )
    pd.testing.assert_frame_equal(
        other.ranking[["effect", "gap_before", "gap_after", "shrink"]],
        standard.ranking[["effect", "gap_before", "gap_after", "shrink"]],
    )
    custom = meas.rename(columns={"disp_z_um": "z_displacement"})
    mapped = diagnose_runs(
        sim, custom, mapping={"z_displacement": "disp_z_um"}, **kwargs
    )
    assert "z_displacement" in mapped.settings["channels"]
    both_odd = renamed.rename(columns={"uz": "z"})
    with pytest.raises(ValueError, match="temperature or a displacement"):
        diagnose_runs(both_odd, custom, mapping={"z_displacement": "z"}, **kwargs)


def test_report_dict_keeps_small_p_values(pair):
    sim, meas = pair
    report = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    row = report.to_dict()["ranking"][0]
    expected = report.ranking.iloc[0]
    for key in ("lr_p_value", "p_value", "shrink"):
        assert row[key] == pytest.approx(float(expected[key]), rel=1e-12, abs=1e-300)


def test_a_term_without_signal_is_not_scored(pair):
    sim, meas = pair  # no feed
    report = diagnose_runs(sim, meas, candidates=["feed_heating", "tool_growth"])
    assert list(report.ranking["effect"]) == ["tool_growth"]
    assert set(report.not_applicable) == {"feed_heating"}
    assert "Not applicable on these runs (not scored): feed_heating" in (
        report.verdict()
    )
    with pytest.raises(ValueError, match="sensor_lag: it acts on temperature"):
        diagnose_runs(sim, meas, candidates=["sensor_lag"], channels=["disp_z_um"])


def test_share_of_the_explainable_gap_is_not_clipped(pair):
    from skthermal.gap._evidence import share_of_explainable as _share

    assert _share(0.95, 0.84) == pytest.approx(0.95 / 0.84)  # above 1
    assert np.isnan(_share(0.3, -0.2))  # no share of a worse flexible model
    report = diagnose_runs(*pair, candidates=["tool_growth"])
    report.explainable["share"] = -0.25
    text = report.verdict()
    assert "makes the held-out gap worse (excess above noise 25% larger)" in text
    assert "drivers removes" not in text
    # A term that removes more than the flexible model: said so, when its
    # improvement is significant (else it bounds nothing either).
    report.how_far_evidence["shrink"] = 0.6
    report.how_far_evidence["p_value"] = 0.01
    report.explainable["share"] = 0.2
    text = report.verdict()
    assert "removes 20%, less than 'tool_growth': the gap explainable at" in text
    report.how_far_evidence["p_value"] = 0.3
    assert "less than" not in report.verdict()
    report.how_far_evidence["p_value"] = 0.01
    report.explainable["share"] = 0.7
    assert "less than" not in report.verdict()
    # The simulation as given, on the same rows, beside a worse base.
    given = report.how_far_evidence["gap_as_given"]
    assert np.isfinite(given) and given > 0
    report.how_far_evidence["gap_before"] = given * 1.5
    assert f"(the simulation as given: {given:.3g}, less than" in report.verdict()
    report.how_far_evidence["gap_before"] = given * 0.5
    assert "as given" not in report.verdict()


# --- audit 2 fixes ------------------------------------------------------------


def test_a_simulation_covering_more_than_the_measurement(pair):
    sim, meas = pair
    # Another tool's export: starts 30 s before the measurement with the
    # spindle in another state, ends later; only the measured span counts.
    before = sim.groupby("run", sort=False).head(1).copy()
    before["time_s"] -= 30.0
    before["spindle_rpm"] += 1000.0
    after = sim.groupby("run", sort=False).tail(1).copy()
    after["time_s"] += 30.0
    after["spindle_rpm"] += 1000.0
    longer = pd.concat([before, sim, after]).sort_values(
        ["run", "time_s"], kind="stable"
    )
    report = diagnose_runs(longer, meas, candidates=["sensor_lag"], max_samples=150)
    assert report.ranking["effect"].tolist() == ["sensor_lag"]
    # Rows out there are not checked either (they used to stop the diagnosis
    # on a missing value); the row just beyond serves the interpolation.
    spare = after.copy()
    spare["time_s"] += 30.0
    spare["T1_C"] = np.nan
    longer = pd.concat([longer, spare]).sort_values(["run", "time_s"], kind="stable")
    again = diagnose_runs(longer, meas, candidates=["sensor_lag"], max_samples=150)
    pd.testing.assert_frame_equal(again.ranking, report.ranking)


def test_irregular_sampling_is_filtered_with_each_step():
    sim, meas = _tables(np.random.default_rng(1), "sensor_lag", n_runs=3, hours=5)
    # A logging gap of an hour in every run (rows removed).
    keep = ~((meas["time_s"] > 2 * 3600) & (meas["time_s"] < 3 * 3600))
    report = diagnose_runs(
        sim[keep], meas[keep], candidates=["sensor_lag"], max_samples=150
    )
    row = report.ranking.iloc[0]
    # Filtered with one (median) step the gap skewed tau and the shrink.
    assert 700 < row["fitted"]["tau_s"] < 1150
    assert row["shrink"] > 0.8
    # The simulation complete, the measurement with its gap: the drivers in
    # the gap are not known, so a change there is not a mismatch (the last
    # logged value was compared, carried across the gap).
    inside = ~keep & (sim["time_s"] > 2.5 * 3600)
    moved = sim.assign(spindle_rpm=sim["spindle_rpm"].where(~inside, 9999.0))
    again = diagnose_runs(moved, meas[keep], candidates=["sensor_lag"], max_samples=150)
    assert again.ranking.iloc[0]["shrink"] > 0.8


def test_a_logging_gap_from_a_driver_step_is_not_compared():
    sim, meas = _tables(np.random.default_rng(1), "sensor_lag", n_runs=3, hours=5)
    # The measurement loses its rows from the first one at which the speed
    # changes (a dropout at the step, or that one row dropped): the
    # simulation, complete, has the new speed there.
    run0 = meas["run"] == "r0"
    rpm = meas.loc[run0, "spindle_rpm"].to_numpy()
    step = meas.loc[run0].index[1 + int(np.flatnonzero(np.diff(rpm))[0])]
    t_step = meas.loc[step, "time_s"]
    for dropped in (
        run0 & meas["time_s"].between(t_step, t_step + 600),
        run0 & (meas["time_s"] == t_step),
    ):
        report = diagnose_runs(
            sim, meas[~dropped], candidates=["sensor_lag"], max_samples=150
        )
        assert report.ranking.iloc[0]["shrink"] > 0.8
    # A driver that differs where both tables have rows is still an error.
    wrong = sim.assign(spindle_rpm=sim["spindle_rpm"].where(~run0, 1234.0))
    with pytest.raises(ValueError, match="The drivers differ: spindle_rpm in run 'r0'"):
        diagnose_runs(wrong, meas, candidates=["sensor_lag"], max_samples=150)


def _feed_tables(rng, start="rest", n_runs=4, hours=6.0):
    """Runs that start cutting at their first row; the measurement has the
    feed axis's friction heat (a lag of |feed|, from rest or from the steady
    state of the first row's feed), which the simulation lacks."""
    sims, meas = [], []
    for r in range(n_runs):
        t = np.arange(0, hours * 3600, 60.0)
        edges = np.cumsum(rng.uniform(1800, 5400, 20))
        block = np.searchsorted(edges, t)
        on = block % 2 == 0  # cutting from the first row
        rpm = np.where(on, rng.choice([2000.0, 4000.0, 6000.0], 20)[block], 0.0)
        feed = np.where(on, rng.choice([800.0, 1500.0, 2500.0], 20)[block], 0.0)
        heat = _lowpass((rpm / 1000) ** 1.3, 2400.0)
        sim = np.column_stack([20 + 0.8 * heat, 20 + 4.0 * heat])
        u = np.abs(feed) / 1000
        a = np.exp(-60.0 / 3000.0)
        z0 = u[:1] if start == "steady" else np.zeros(1)
        friction = lfilter([1 - a], [1, -a], u, zi=a * z0)[0]
        y = sim + np.outer(friction, [0.6, 3.0])
        y += 0.01 * rng.standard_normal(y.shape) * [1, 10]
        base = {"run": f"r{r}", "time_s": t, "spindle_rpm": rpm, "ambient_C": 20.0}
        base["feed_mm_min"] = feed
        cols = ["T1_C", "disp_z_um"]
        sims.append(pd.DataFrame({**base, **dict(zip(cols, sim.T))}))
        meas.append(pd.DataFrame({**base, **dict(zip(cols, y.T))}))
    return pd.concat(sims, ignore_index=True), pd.concat(meas, ignore_index=True)


def _prepend_rest(df):
    """Every run with one row of rest (no speed, no feed) before its first."""
    parts = []
    for _, run in df.groupby("run", sort=False):
        first = run.iloc[[0]].assign(spindle_rpm=0.0, feed_mm_min=0.0, time_s=0.0)
        parts += [first, run.assign(time_s=run["time_s"] + 60.0)]
    return pd.concat(parts, ignore_index=True)


def test_feed_heating_of_runs_that_start_cutting():
    # The heat of a run that starts cutting builds up from its first row.
    # Its filter used to start in steady state at the first row's feed, as if
    # the axis had been cutting for ever: the term's change since the start
    # then fell while the heat rose, and the withheld effect made the
    # held-out gap worse.
    sim, meas = _feed_tables(np.random.default_rng(3))
    report = diagnose_runs(sim, meas, candidates=["feed_heating", "sensor_lag"])
    first = report.ranking.iloc[0]
    assert first["effect"] == "feed_heating" and first["shrink"] > 0.8
    assert report.best_effect == "feed_heating"
    # One row of rest before every run is physically the same campaign.
    again = diagnose_runs(
        _prepend_rest(sim), _prepend_rest(meas), candidates=["feed_heating"]
    )
    assert abs(again.ranking.iloc[0]["shrink"] - first["shrink"]) < 0.05
    # Runs that start where the machine had been cutting as at their first
    # row: driver_initial="steady" says so.
    sim, meas = _feed_tables(np.random.default_rng(3), start="steady")
    rest = diagnose_runs(sim, meas, candidates=["feed_heating"])
    steady = diagnose_runs(
        sim, meas, candidates=["feed_heating"], driver_initial="steady"
    )
    assert steady.ranking.iloc[0]["shrink"] > 0.8
    assert steady.ranking.iloc[0]["shrink"] > rest.ranking.iloc[0]["shrink"] + 0.1
    with pytest.raises(ValueError, match="driver_initial"):
        diagnose_runs(sim, meas, driver_initial="warm")


def test_one_long_record_in_blocks():
    sim, meas = _tables(np.random.default_rng(2), "sensor_lag", n_runs=1, hours=6)
    with pytest.raises(ValueError, match=r"\(got 1\); to hold one long record"):
        diagnose_runs(sim, meas, candidates=["sensor_lag"], max_samples=150)
    report = diagnose_runs(
        sim, meas, candidates=["sensor_lag"], max_samples=150, block_hours=2
    )
    assert list(report.timelines) == ["r0[0-2 h]", "r0[2-4 h]", "r0[4-6 h]"]
    assert report.ranking.iloc[0]["n_runs"] == 3
    assert report.settings["block_hours"] == 2


def test_input_checks_name_what_is_wrong(pair):
    sim, meas = pair
    text = sim.assign(T1_C=sim["T1_C"].astype(object))
    text.loc[text.index[50], "T1_C"] = "n/a"
    with pytest.raises(ValueError, match=r"T1_C holds 'n/a', not a number, in run "):
        diagnose_runs(text, meas)
    with pytest.raises(ValueError, match=r"\['T1_C'\] are given more than once"):
        diagnose_runs(sim, meas, channels=["T1_C", "T1_C"])
    renamed = sim.rename(columns={"T1_C": "node_17"})
    with pytest.raises(
        ValueError, match=r"simulated channels: \['node_17', 'T2_C', 'disp_z_um'\]"
    ):
        diagnose_runs(renamed, meas, mapping={"T1_C": "node_1"})
    short = meas.groupby("run", sort=False).head(7)
    with pytest.raises(ValueError, match="has 7 samples; at least 8"):
        diagnose_runs(sim, short)
    # The run named as labelled (labels are case-sensitive).
    upper = {"run": lambda d: d["run"].str.upper()}
    with pytest.raises(ValueError, match="Run 'R0' of the measured table has 7"):
        diagnose_runs(sim.assign(**upper), short.assign(**upper))


def test_dead_probe_and_extra_simulated_run(pair):
    sim, meas = pair
    dead = meas.assign(disp_z_um=0.0)
    with pytest.raises(ValueError, match=r"\['disp_z_um'\] are constant on every"):
        diagnose_runs(sim, dead, channels=["T1_C", "disp_z_um"])
    extra = pd.concat([sim, sim[sim["run"] == "r0"].assign(run="r9")])
    with pytest.warns(UserWarning) as record:
        report = diagnose_runs(extra, dead, candidates=["sensor_lag"], max_samples=150)
    messages = " ".join(str(w.message) for w in record)
    assert "['disp_z_um'] are constant on every run" in messages
    assert "['r9'] of the simulated table are not in the measured" in messages
    assert report.settings["channels"] == ["T1_C", "T2_C"]
    assert (report.ranking["extra_params"] == report.ranking["lr_df"]).all()


def test_the_run_table_mode_reports_each_sensors_drift_rate(rng):
    sim, meas = _tables(rng, "null", n_runs=3, hours=4.0)
    hours = meas["time_s"] / 3600.0
    meas["T1_C"] += 0.4 * hours  # T1 drifts at 0.4 °C/h, T2 does not
    report = diagnose_runs(sim, meas, candidates=["sensor_drift", "sensor_lag"])
    rates = report.drift_rates
    assert set(rates) == {"T1_C", "T2_C"}
    assert rates["T1_C"] == pytest.approx(0.4, abs=0.05)
    assert abs(rates["T2_C"]) < 0.05
    assert "## Fitted sensor drift" in report.to_markdown()
    # The ranking's fitted value: the rates' root mean square, 0.4/sqrt(2).
    row = report.ranking.set_index("effect").loc["sensor_drift"]
    assert row["fitted"]["rate_C_per_h"] == pytest.approx(0.4 / np.sqrt(2), abs=0.04)
    reported = np.array(list(rates.values()))
    assert row["fitted"]["rate_C_per_h"] == pytest.approx(
        np.sqrt(np.mean(reported**2)), rel=1e-12
    )
    assert diagnose_runs(sim, meas, candidates=["sensor_lag"]).drift_rates == {}


def test_the_default_folds_do_not_depend_on_the_order_of_the_runs(rng):
    sim, meas = _tables(rng, "sensor_lag", n_runs=4, hours=4.0)
    report = diagnose_runs(sim, meas, candidates=["sensor_lag", "sensor_drift"])
    order = ["r3", "r1", "r0", "r2"]

    def reordered(table):
        return pd.concat([table[table["run"] == r] for r in order], ignore_index=True)

    again = diagnose_runs(
        reordered(sim), reordered(meas), candidates=["sensor_lag", "sensor_drift"]
    )
    columns = ["effect", "gap_before", "gap_after", "shrink", "p_value"]
    pd.testing.assert_frame_equal(
        report.ranking[columns].reset_index(drop=True),
        again.ranking[columns].reset_index(drop=True),
        rtol=1e-9,
    )


def test_time_in_hours_is_flagged(rng):
    sim, meas = _tables(rng, "null", n_runs=3, hours=4.0)
    hours = {"time_s": lambda d: d["time_s"] / 3600.0}
    with pytest.warns(UserWarning, match=r"longest run \('r\d'\) lasts 3\.98\d* s"):
        diagnose_runs(
            sim.assign(**hours), meas.assign(**hours), candidates=["sensor_lag"]
        )


def test_a_trend_too_fast_for_a_sensor_is_not_called_sensor_drift(rng):
    # 0.4 °C/h on one sensor (10 °C a day): a heat load the simulation
    # lacks, not a thermocouple's drift, so sensor_drift is ruled out.
    sim, meas = _tables(rng, "null", n_runs=3, hours=4.0)
    meas["T1_C"] += 0.4 * meas["time_s"] / 3600.0
    report = diagnose_runs(sim, meas, candidates=["sensor_drift", "sensor_lag"])
    row = report.ranking.set_index("effect").loc["sensor_drift"]
    assert row["shrink"] > 0.5 and row["p_value"] < 0.05  # it fits the trend
    assert "beyond a sensor's drift" in row["ruled_out"] and not row["explains"]
    assert report.best_effect is None
    assert (
        "'sensor_drift' is ruled out: drift rates of 0.283 °C/h (root mean square "
        "over the 2 temperature sensors; the fastest, 'T1_C', +0.4 °C/h)"
    ) in report.verdict()
    assert "- `sensor_drift` is ruled out" in report.to_markdown()
    # A gap far above the noise is not said to be noise.
    ratio = row["gap_before"] / report.noise_floor
    assert ratio > 2
    assert (
        f"No candidate effect explains the gap: held out it is {ratio:.1f} times "
        "the noise floor (best candidate 'sensor_drift'"
    ) in report.verdict()
    # A plausible drift (0.05 °C/h) is named.
    sim, meas = _tables(rng, "null", n_runs=3, hours=4.0, noise=0.002)
    meas["T1_C"] += 0.05 * meas["time_s"] / 3600.0
    report = diagnose_runs(sim, meas, candidates=["sensor_drift", "sensor_lag"])
    assert report.best_effect == "sensor_drift"


def test_a_lag_of_hours_is_not_called_sensor_lag(rng):
    # The measured temperatures follow the simulated ones through a 3 h lag:
    # the structure's slower response, not a sensor's own lag.
    sim, meas = _tables(rng, "null", n_runs=3, hours=6.0)
    for run, rows in meas.groupby("run").groups.items():
        for c in ("T1_C", "T2_C"):
            meas.loc[rows, c] = _lowpass(meas.loc[rows, c].to_numpy(), 3 * 3600.0)
    report = diagnose_runs(sim, meas, candidates=["sensor_lag", "sensor_drift"])
    row = report.ranking.set_index("effect").loc["sensor_lag"]
    assert row["fitted"]["tau_s"] > 3600
    assert "beyond a sensor's own" in row["ruled_out"] and not row["explains"]
    assert report.best_effect != "sensor_lag"
    # The 15 min lag of the sensor_lag case is one.
    sim, meas = _tables(rng, "sensor_lag", n_runs=3, hours=6.0)
    report = diagnose_runs(sim, meas, candidates=["sensor_lag", "sensor_drift"])
    assert report.best_effect == "sensor_lag"


def test_where_names_a_planted_jump_in_one_run_and_channel(rng):
    # A displacement sensor re-seated in one run (+4 µm from 4 h on) and a
    # temperature logged in steps of 0.1 °C: the jump is found, in the
    # channel's unit, and the reading steps are not jumps. The summary, the
    # Markdown and the CSV agree on it; times are written in full.
    sim, meas = _tables(rng, "null")
    meas["T2_C"] = meas["T2_C"].round(1)
    late = (meas["run"] == "r2") & (meas["time_s"] >= 14460)
    meas.loc[late, "disp_z_um"] += 4.0
    report = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    jumps = report.where["jumps"]
    given = jumps[jumps["model"] == "as given"]
    assert list(zip(given["run"], given["time_s"], given["channel"], strict=True)) == [
        ("r2", 14460.0, "disp_z_um")
    ]
    # Simulated minus measured, in µm.
    assert given["jump"].iloc[0] == pytest.approx(-4.0, abs=0.3)
    assert given["size"].iloc[0] > 6
    summary = report.where_summary()
    assert summary.startswith("Where (as given):")
    assert "run 'r2'" in summary
    assert "1 jump(s), largest: run 'r2' at 14460 s in disp_z_um (-4" in summary
    # The simulation's gain is off on every channel as given; calibrated,
    # the re-seated sensor is what is left.
    calibrated = report.where_summary("base calibrated")
    assert "run 'r2'" in calibrated and "channel disp_z_um" in calibrated
    text = report.to_markdown()
    assert "| as given | r2 | 14460 | disp_z_um |" in text
    assert "jump [µm or °C]" in text and "1.45e+04" not in text
    with pytest.raises(ValueError, match="Unknown model 'calibrated'"):
        report.where_summary("calibrated")


def test_save_draws_the_channel_the_summary_names(rng, tmp_path):
    # A temperature that rises 60% more than simulated: the summary (as
    # given, the run-table mode's default) names it, and save() draws that
    # channel, not the worst one after the base calibration (which absorbs
    # a gain, leaving a channel at its noise). Nothing missing beyond noise:
    # no extra figure.
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    sim, _ = _tables(rng, "null", n_runs=3, hours=4.0)
    cols = ["T1_C", "T2_C", "disp_z_um"]
    noise = 0.01 * rng.standard_normal((len(sim), 3)) * [1, 1, 10]
    meas = sim.copy()
    meas[cols] += noise
    null = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    assert null.where_model == "as given"
    null_figures = list(null.save(tmp_path / "null").glob("timeline_*"))
    assert len(null_figures) == 3, null_figures  # one per run
    # The fitted parameters as JSON text (a Python dict's repr was written).
    fitted = pd.read_csv(tmp_path / "null" / "ranking.csv")["fitted"]
    assert json.loads(fitted[0]) == null.ranking["fitted"][0]
    meas["T2_C"] += 0.6 * (sim["T2_C"] - sim["ambient_C"])
    report = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    assert "channel T2_C:" in report.where_summary()
    assert report.where_summary() == report.where_summary("as given")
    names = [p.name for p in report.save(tmp_path / "gain").glob("timeline_*")]
    extra = [n for n in names if n.count("_") > 1 and n.endswith("_T2_C.png")]
    assert len(names) == 4 and len(extra) == 1, names
    # The pages show every figure (they were only files beside them).
    md = (tmp_path / "gain" / "report.md").read_text()
    page = (tmp_path / "gain" / "report.html").read_text()
    for name in names:
        assert f"]({name})" in md and f"<img src='{name}'" in page
    md = (tmp_path / "null" / "report.md").read_text()
    assert all(f"]({n})" in md for n in (p.name for p in null_figures))


def test_report_text_rounds_as_it_says(rng):
    from skthermal.gap._report import _gap_cell, _time_text

    assert _time_text(16080.0) == "16080" and _time_text(9010.5) == "9010.5"
    assert _time_text(123456789.0) == "123456789"
    # A term's fitted parameters as the other figures are.
    assert _gap_cell({"tau_s": 0.0009228073853221015}) == "tau_s: 0.000923"


def test_a_driver_under_another_name_is_named(rng):
    sim, meas = _tables(rng, "null", n_runs=2, hours=2.0)
    fahrenheit = meas.rename(columns={"ambient_C": "ambient_F"})
    with pytest.raises(ValueError, match=r"'ambient_F' looks like 'ambient_C'"):
        diagnose_runs(sim, fahrenheit)


def test_a_simulation_in_milliseconds_is_refused(pair):
    # A simulation's time_s in ms against a measurement in s: its first two
    # rows spanned every measured run, which was compared with a straight
    # line between them, silently (an independent check: a feed-heating
    # case then read "no candidate effect explains the gap").
    sim, meas = pair
    in_ms = sim.assign(time_s=sim["time_s"] * 1000.0)
    with pytest.raises(ValueError, match=r"Run 'r0'.*60000 s apart.*milliseconds"):
        diagnose_runs(in_ms, meas, candidates=["sensor_lag"])
    # A coarse export of another tool (every 7 min of a 2 h run) is fine.
    coarse = sim[sim["time_s"] % 420 == 0]
    diagnose_runs(coarse, meas, candidates=["sensor_lag"], n_jobs=1)
    # A short measured run beside a coarse export is said, not refused.
    coarse = sim[sim["time_s"] % 600 == 0]
    short = meas[(meas["run"] != "r0") | (meas["time_s"] < 1500)]
    short = short[(short["run"] == "r0") | (short["time_s"] <= 6600)]
    with pytest.warns(UserWarning, match=r"Run 'r0'.*600 s apart.*lasts 1440 s"):
        diagnose_runs(coarse, short, candidates=["sensor_lag"], n_jobs=1)


@pytest.mark.parametrize("table", ["measured", "simulated"])
def test_sensors_in_fahrenheit_are_flagged(pair, table):
    # Temperatures in Fahrenheit under T*_C (the air in °C): a drift rate in
    # °F/h was then ruled out against the limit in °C/h, without a word.
    sim, meas = pair
    temps = ["T1_C", "T2_C"]
    frames = {"simulated": sim.copy(), "measured": meas.copy()}
    frames[table][temps] = frames[table][temps] * 1.8 + 32
    which = "The simulated table: " if table == "simulated" else "No temp"
    with pytest.warns(UserWarning, match=rf"^{which}.*ever reads below 50.*Fahr"):
        diagnose_runs(
            frames["simulated"], frames["measured"], candidates=["sensor_lag"]
        )


def _clock_text(meas):
    """``meas`` with its times as a logger's clock, written as text."""
    clock = pd.Timestamp("2026-11-01 08:00") + pd.to_timedelta(meas["time_s"], unit="s")
    return meas.assign(time_s=clock.astype(str))


@pytest.mark.parametrize(
    "slip, message",
    [
        (
            lambda m: m.rename(columns={"run": "Run", "time_s": "time_min"}),
            r"no \['run', 'time_s'\] column\(s\) \(columns that may be meant: "
            r"'Run' for 'run', 'time_min' for 'time_s'\)",
        ),
        (
            _clock_text,
            r"time_s is text \('2026-11-01 08:00:00'\) in run 'r0' of the measured "
            r"table at row 0 of the run: it must hold numbers \(a clock time",
        ),
    ],
)
def test_run_and_time_slips_are_named(pair, slip, message):
    sim, meas = pair
    with pytest.raises(ValueError, match=message):
        diagnose_runs(sim, slip(meas))


def test_a_signed_feed_against_its_magnitude_is_the_same_driver(rng):
    # The feed enters the terms as |feed|: a measured direction of travel
    # against a simulation's magnitude was refused as other drivers.
    sim, meas = _feed_tables(rng, n_runs=3, hours=3.0)
    signed = meas.assign(
        feed_mm_min=meas["feed_mm_min"] * np.where(np.arange(len(meas)) % 7 < 3, -1, 1)
    )
    kwargs = {"candidates": ["feed_heating", "sensor_lag"], "greedy": False}
    same = diagnose_runs(sim, signed, **kwargs)
    plain = diagnose_runs(sim, meas, **kwargs)
    pd.testing.assert_frame_equal(same.ranking, plain.ranking)
    with pytest.raises(ValueError, match="The drivers differ: feed_mm_min"):
        diagnose_runs(sim, meas.assign(feed_mm_min=meas["feed_mm_min"] * 2), **kwargs)


def _air_tables(rng, n_runs=4, hours=6.0, tau=(5000.0, 21600.0), gain=3.0):
    """A simulation whose displacement follows the workshop air (doors, heating)
    too slowly: the measurement adds a band-pass of the air, an exposed
    surface of time constant ``tau[0]`` against the bulk's ``tau[1]``."""
    sims, meas = [], []
    for r in range(n_runs):
        t = np.arange(0, hours * 3600, 60.0)
        air = np.full(t.size, 20.0)
        for _ in range(3):  # doors, heating: steps of the workshop air
            a, b = np.sort(rng.uniform(0, t[-1], 2))
            air += rng.uniform(-1.5, 1.5) * ((t >= a) & (t < b))
        air = _lowpass(air, 300.0)
        edges = np.cumsum(rng.uniform(1800, 5400, 20))
        block = np.searchsorted(edges, t)
        rpm = np.where(block % 2 == r % 2, rng.choice([2000.0, 6000.0], 20)[block], 0.0)
        heat = _lowpass((rpm / 1000) ** 1.3, 2400.0)
        T1 = _lowpass(air, 1800.0) + 0.8 * heat
        dz = 4.0 * heat + 1.0 * (_lowpass(air, 7200.0) - 20)
        sim = np.column_stack([T1, dz])
        y = sim.copy()
        y[:, 1] += gain * (_lowpass(air, tau[0]) - _lowpass(air, tau[1]))
        y += rng.standard_normal(y.shape) * [0.01, 0.1]
        base = {"run": f"r{r}", "time_s": t, "spindle_rpm": rpm, "ambient_C": air}
        cols = ["T1_C", "disp_z_um"]
        sims.append(pd.DataFrame({**base, **dict(zip(cols, sim.T))}))
        meas.append(pd.DataFrame({**base, **dict(zip(cols, y.T))}))
    return pd.concat(sims, ignore_index=True), pd.concat(meas, ignore_index=True)


def test_an_exposed_surface_slower_than_an_hour_is_named():
    # ambient_transient's fast time constant may reach 4 h: an exposed
    # surface of 3000 s ended on the old 1 h end, where a candidate the
    # range stopped is not named (an independent check: 92% of the held-out
    # gap removed, "no candidate effect explains the gap").
    sim, meas = _air_tables(np.random.default_rng(0))
    tried = ["ambient_transient", "sensor_lag", "speed_convection"]
    report = diagnose_runs(sim, meas, candidates=tried, greedy=False)
    assert report.best_effect == "ambient_transient"
    top = report.ranking.iloc[0]
    assert top["shrink"] > 0.9 and top["stopped"] == ""
    assert 3600 < top["fitted"]["tau_fast_s"] < 6000


def test_a_temperature_below_absolute_zero_is_refused(pair):
    # An independent check: a logger's -999 in four rows passed with a
    # warning that said "above 500 °C", and the verdict blamed an effect on
    # a 28 °C gap that the code made.
    sim, meas = pair
    meas = meas.copy()
    rows = meas.index[(meas["run"] == "r1").to_numpy()][5:9]
    meas.loc[rows, "T1_C"] = -999.0
    with pytest.raises(
        ValueError,
        match=r"T1_C holds -999 in run 'r1' of the measured table at row 5 of the "
        r"run \(time_s \d+\), and 4 such row\(s\) in all: a temperature in °C "
        r"lies above -273\.15 \(a logger's code",
    ):
        diagnose_runs(sim, meas)


def test_the_implausible_reading_warning_says_below_absolute_zero():
    from skthermal.datasets._runtable import warn_implausible

    table = pd.DataFrame(
        {
            "run": ["a"] * 6,
            "time_s": np.arange(6) * 60.0,
            "T1_C": [20.0, 20.1, -999.0, 20.2, 20.2, 20.3],
        }
    )
    with pytest.warns(
        UserWarning,
        match=r"holds -999 .*: no machine tool reads a "
        r"temperature below absolute zero \(-273\.15 °C\)\. A logger",
    ):
        warn_implausible(table)


def test_the_as_given_remark_needs_a_difference_the_figures_show():
    # "held-out gap 0.145 (the simulation as given: 0.145, less than the
    # base ...)" for 0.1452020 against 0.1452256.
    from skthermal.gap._external import _as_given_text

    assert _as_given_text(0.1452020, 0.1452256) == ""
    assert "as given: 0.13, less than" in _as_given_text(0.13, 0.145)
    assert _as_given_text(np.nan, 0.145) == ""


def test_another_tools_columns_are_hinted():
    # An independent check: 'Time [s]' and 'Air [degC]' were hinted, not
    # 'Speed [rpm]' nor 'Load case' (a finite-element tool's run label).
    from skthermal.datasets._runtable import meant_for
    from skthermal.utils._runs import driver_lookalike

    assert driver_lookalike("Speed [rpm]") == "spindle_rpm"
    assert driver_lookalike("speed_pct") is None
    assert meant_for(["Load case", "Time [s]", "T1_C"], "run") == ["Load case"]


def test_the_saved_report_keeps_the_warnings_and_the_channels(pair, tmp_path):
    # An independent check: a unit slip warned about on the console left no
    # trace in report.md, nor did the channels compared.
    sim, meas = pair
    with pytest.warns(UserWarning, match=r"\['T3_C'\] are not compared") as record:
        report = diagnose_runs(
            sim, meas.assign(T3_C=meas["T1_C"]), candidates=["sensor_lag"], greedy=False
        )
    said = [f"{w.category.__name__}: {w.message}" for w in record]
    assert report.settings["warnings"] == said
    text = report.to_markdown()
    assert "**Warnings during the diagnosis** (" in text
    assert "['T3_C'] are not compared" in text
    assert "Channels compared: `" in text
    report.save(tmp_path / "gap")
    saved = json.loads((tmp_path / "gap" / "report.json").read_text())
    assert saved["settings"]["warnings"] == said


def test_measured_runs_that_start_warm_beside_a_cold_simulation_warn(pair):
    # An independent check: runs starting warm against a simulation started
    # from the air left only a warning about a unit slip, and a planted lag
    # was lost. (Runs r0 and r2 start warm in both tables: no word of them.)
    sim, meas = pair
    warm = meas.copy()
    temps = [c for c in warm if c.startswith("T") and c.endswith("_C")]
    decay = 6.0 * np.exp(-warm["time_s"].to_numpy() / 3600.0)
    warm[temps] = warm[temps].to_numpy() + decay[:, None]
    with pytest.warns(
        UserWarning,
        match=r"Measured run 'r1' starts warm: its temperature sensors read "
        r"8\.\d K above the air at its first row on average, the simulation 0\.0 K",
    ):
        diagnose_runs(sim, warm, candidates=["sensor_lag"], greedy=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    assert not [w for w in caught if "starts warm" in str(w.message)]


def test_a_reused_report_folder_loses_the_earlier_reports_figures(pair, tmp_path):
    # An independent check: a stale timeline of an earlier run stayed in a
    # reused --report folder, read as part of the new report.
    sim, meas = pair
    report = diagnose_runs(sim, meas, candidates=["sensor_lag"], greedy=False)
    folder = tmp_path / "gap"
    folder.mkdir()
    (folder / "timeline_old-run.png").write_bytes(b"stale")
    (folder / "drift_rates.csv").write_text("stale")
    (folder / "notes.txt").write_text("the user's")
    report.save(folder)
    assert not (folder / "timeline_old-run.png").exists()
    assert not (folder / "drift_rates.csv").exists()
    assert (folder / "notes.txt").read_text() == "the user's"
    assert (folder / "report.md").exists()
