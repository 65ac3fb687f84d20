import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline

from skthermal.preprocessing import (
    LagFeatures,
    LagRidgeCV,
    exponential_filter,
    make_lag_pipeline,
)
from skthermal.preprocessing._lags import lowpass_steps, run_steps

DATA = Path(__file__).parents[1].parent / "shared" / "data"


def test_a_dt_the_times_disagree_with_is_said_once():
    # LagFeatures(dt=30) on times in minutes: the times overrode dt, the 900 s
    # filter 23 °C off, without a word.
    from skthermal.preprocessing import LagFeatures, LagRidgeCV

    t = np.arange(0.0, 3 * 3600, 30.0)
    X = pd.DataFrame(
        {
            "run": "a",
            "time_s": t / 60,
            "T1_C": 20 + np.sin(t / 3000),
            "spindle_rpm": 1e3,
        }
    )
    y = np.sin(t / 3000)
    for model in (
        LagFeatures(dt=30.0),
        LagRidgeCV(dt=30.0, time_constant_sets=[(600.0,)]),
    ):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model.fit(X, y)
        said = [
            w
            for w in caught
            if "dt=30 is given, but the time_s steps" in str(w.message)
        ]
        assert len(said) == 1 and "is time_s in seconds?" in str(said[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LagFeatures(dt=30.0).fit(X.assign(time_s=t))


def test_durations_as_times_or_dt_are_refused():
    # A timedelta times= or dt= was read as integer ticks, silently.
    U = np.ones((4, 1))
    t = pd.to_timedelta([0, 60, 120, 180], unit="s")
    with pytest.raises(ValueError, match=r"times holds timedelta64"):
        exponential_filter(U, 600.0, 60.0, times=t)
    with pytest.raises(ValueError, match=r"dt holds timedelta64\[ms\]"):
        exponential_filter(U, 600.0, np.timedelta64(60000, "ms"))


def test_filter_steady_state_and_restart():
    U = np.r_[np.full(5, 3.0), np.full(5, 7.0)]
    slices = [slice(0, 5), slice(5, 10)]
    Z = exponential_filter(U, 10.0, 1.0, slices)
    # constant input within each run: steady state from the first row
    np.testing.assert_allclose(Z, U)
    one_run = exponential_filter(U, 10.0, 1.0)
    assert one_run[5] < 7.0  # without the restart the step is smoothed


def test_filter_matches_recursion():
    rng = np.random.default_rng(0)
    u = rng.normal(size=50)
    a = np.exp(-2.0 / 7.0)
    z = np.empty_like(u)
    z[0] = u[0]
    for k in range(1, u.size):
        z[k] = a * z[k - 1] + (1 - a) * u[k]
    np.testing.assert_allclose(exponential_filter(u, 7.0, 2.0), z)


def test_bad_time_constant():
    with pytest.raises(ValueError, match="time_constant"):
        exponential_filter(np.ones(3), 0.0, 1.0)
    with pytest.raises(ValueError, match="time_constants"):
        LagFeatures(time_constants=[-1.0]).fit(np.ones((3, 1)))


# The lag transformer and the lag regressor, for the tests both must pass.
LAG_MODELS = pytest.mark.parametrize(
    "model",
    [
        LagFeatures(time_constants=[60.0]),
        LagRidgeCV(time_constant_sets=[(60.0,)], alphas=[1.0]),
    ],
    ids=["LagFeatures", "LagRidgeCV"],
)


def _frame():
    t = np.r_[np.arange(6) * 30.0, np.arange(4) * 30.0]
    idx = pd.MultiIndex.from_arrays([["a"] * 6 + ["b"] * 4, t], names=["run", "time_s"])
    return pd.DataFrame(
        {
            "T1_C": np.r_[np.linspace(20, 25, 6), np.linspace(30, 31, 4)],
            "spindle_rpm": np.r_[np.full(6, 2000.0), np.zeros(4)],
        },
        index=idx,
    )


def test_lag_feature_names_follow_scikit_learns_rule():
    lf = LagFeatures(time_constants=[60.0]).fit(_frame())
    assert list(lf.get_feature_names_out(["T1_C", "spindle_rpm"])) == list(
        lf.get_feature_names_out()
    )
    for names in (["a", "b"], ["T1_C"]):
        with pytest.raises(ValueError, match="input_features"):
            lf.get_feature_names_out(names)


def test_run_tables_keep_their_runs_through_lag_features():
    # As the selectors: a run table (runs as index levels or as columns) comes
    # out indexed by run and time_s, whatever the output config, so that a
    # sequence model after the step still sees the runs.
    X = _frame()
    as_columns = X.reset_index()
    for given in (X, as_columns):
        for output in ("default", "pandas"):
            lf = LagFeatures(time_constants=[60.0]).set_output(transform=output)
            F = lf.fit_transform(given)
            assert list(F.index.names) == ["run", "time_s"]
            assert F.index.equals(X.index)
            assert list(F.columns) == list(lf.get_feature_names_out())
    plain = LagFeatures(time_constants=[60.0]).fit_transform(
        X.to_numpy(), groups=X.index.get_level_values("run")
    )
    assert isinstance(plain, np.ndarray)


def test_lag_feature_names_tell_close_time_constants_apart():
    lf = LagFeatures(time_constants=[100000.0, 100000.4, 60.0]).fit(_frame())
    names = list(lf.get_feature_names_out())
    assert len(set(names)) == len(names)
    assert "d_T1_C_lp100000.4" in names and "d_T1_C_lp60" in names


def test_runs_restart_and_names_and_pandas_output():
    X = _frame()
    lf = LagFeatures(time_constants=[60.0]).set_output(transform="pandas")
    F = lf.fit_transform(X)
    assert list(F.columns) == [
        "d_T1_C",
        "d_T1_C_lp60",
        "spindle_rpm_pow1_lp60",
        "spindle_rpm_pow1.5_lp60",
        "spindle_rpm_pow1",
        "spindle_rpm_pow1.5",
    ]
    assert isinstance(F, pd.DataFrame)
    # the driver terms unfiltered: the speed at once, in thousands
    np.testing.assert_allclose(F["spindle_rpm_pow1"], X["spindle_rpm"] / 1000)
    # changes restart at the start of run b
    assert F["d_T1_C"].iloc[0] == 0 and F["d_T1_C"].iloc[6] == 0
    # driver filters start in steady state: constant within each run
    np.testing.assert_allclose(F["spindle_rpm_pow1_lp60"].iloc[:6], 2.0)
    np.testing.assert_allclose(F["spindle_rpm_pow1_lp60"].iloc[6:], 0.0)
    # spacing taken from time_s (30 s), not dt
    a = np.exp(-30.0 / 60.0)
    dT = F["d_T1_C"].to_numpy()
    assert F["d_T1_C_lp60"].iloc[1] == pytest.approx((1 - a) * dT[1])


@LAG_MODELS
def test_run_table_columns_give_runs_and_times(model):
    # The run table as it is stored (run and time_s as columns) is read as
    # the (run, time_s) index of split_runs: time_s is the time base, not a
    # feature.
    X = _frame()
    y = np.arange(len(X), dtype=float)
    flat = X.reset_index()
    use = "transform" if hasattr(model, "transform") else "predict"
    a = getattr(clone(model).fit(X, y), use)(X)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fitted = clone(model).fit(flat, y)
        b = getattr(fitted, use)(flat)
    np.testing.assert_allclose(b, a)
    assert fitted.n_features_in_ == 2  # T1_C and spindle_rpm
    # A bad time_s column is named.
    bad = flat.assign(time_s=flat["time_s"].astype(object))
    bad.loc[3, "time_s"] = "late"
    with pytest.raises(ValueError, match="'time_s'.*'late'"):
        clone(model).fit(bad, y)


@LAG_MODELS
def test_rows_without_times_warn_unless_dt_is_given(model):
    X = _frame()
    y = np.arange(len(X), dtype=float)
    bare = X.reset_index(drop=True)  # no run labels, no times
    with pytest.warns(UserWarning) as record:
        clone(model).fit(bare, y)
    # Each said once, not once per candidate: no times (give dt), and rows
    # without run labels taken as one run.
    messages = sorted(str(w.message) for w in record)
    assert len(messages) == 2
    assert re.search("ONE run", messages[0]) and re.search(
        "no time_s.*dt=", messages[1]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        explicit = (
            clone(model).set_params(dt=30.0).fit(bare, y, groups=np.zeros(len(y)))
        )
    # dt=30 on the bare rows is the same model as a 30 s time index.
    timed_rows = bare.set_axis(pd.Index(np.arange(len(X)) * 30.0, name="time_s"))
    timed = clone(model).fit(timed_rows, y)
    use = "transform" if hasattr(model, "transform") else "predict"
    expected = getattr(timed, use)(timed_rows)
    np.testing.assert_allclose(getattr(explicit, use)(bare), expected)
    # Fitted with times, rows without times are taken at the fitted period.
    lags = getattr(timed, "lag_features_", timed)
    assert lags.sample_period_s_ == pytest.approx(30.0)
    np.testing.assert_allclose(getattr(timed, use)(bare), expected)


def _long_run(n=80, run="r"):
    t = np.arange(n) * 30.0
    rpm = np.where((t // 600) % 2 == 0, 3000.0, 0.0)
    heat = np.cumsum(rpm) / 4e4
    return pd.DataFrame(
        {
            "run": run,
            "time_s": t,
            "T1_C": 20 + heat + np.sin(t / 400.0),
            "T2_C": 21 + 0.5 * heat,
            "spindle_rpm": rpm,
        }
    )


@pytest.mark.parametrize("kind", ["even", "uneven", "gap"])
def test_run_steps_and_lowpass_steps_filter_as_exponential_filter(kind, rng):
    """The kernel with a run's steps worked out once gives the filter of
    exponential_filter given the run's times."""
    t = np.arange(200) * 10.0
    if kind == "uneven":
        t = t + rng.uniform(-2.0, 2.0, t.size)
    elif kind == "gap":
        t[120:] += 300.0
    U = np.cumsum(rng.standard_normal((t.size, 3)), axis=0)
    plan = run_steps(t)
    assert (plan[1] is None) == (kind == "even")
    for tau in (5.0, 60.0, 3600.0):
        np.testing.assert_allclose(
            lowpass_steps(U, tau, *plan),
            exponential_filter(U, tau, float(np.median(np.diff(t))), times=t),
            rtol=1e-12,
            atol=1e-12,
        )


def test_exponential_filter_continues_from_a_state():
    u = np.random.default_rng(0).normal(size=(50, 2))
    whole = exponential_filter(u, 7.0, 2.0)
    head = exponential_filter(u[:20], 7.0, 2.0)
    tail = exponential_filter(u[20:], 7.0, 2.0, state=head[-1:])
    np.testing.assert_allclose(tail, whole[20:], rtol=1e-12)
    # A row of NaN starts that run afresh.
    fresh = exponential_filter(u[20:], 7.0, 2.0, state=np.full((1, 2), np.nan))
    np.testing.assert_allclose(fresh, exponential_filter(u[20:], 7.0, 2.0))


@LAG_MODELS
def test_the_later_rows_of_a_training_run_continue_it(model):
    table = _long_run()
    y = table["T1_C"].to_numpy() * 2.0 + table["spindle_rpm"].to_numpy() / 1e3
    cut = 50
    fitted = clone(model).fit(table.iloc[:cut], y[:cut])
    use = getattr(fitted, "transform" if hasattr(fitted, "transform") else "predict")
    whole = use(table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tail = use(table.iloc[cut:])
    np.testing.assert_allclose(tail, whole[cut:], rtol=1e-10, atol=1e-10)
    # The training rows again: predicted from the run's start.
    np.testing.assert_allclose(use(table.iloc[:cut]), whole[:cut])
    # Starting inside the training span is neither reading: an error.
    with pytest.raises(ValueError, match="inside the span"):
        use(table.iloc[20:])
    # A run not seen in fit that does not start at 0 is a run of its own,
    # with a warning.
    other = table.iloc[cut:].assign(run="other")
    with pytest.warns(UserWarning, match="not 0"):
        use(other)


def test_feed_is_a_driver_and_direction_does_not_matter():
    X = _frame().assign(feed_mm_min=np.r_[np.full(5, 2000.0), np.full(5, -2000.0)])
    lf = LagFeatures(time_constants=[60.0]).set_output(transform="pandas")
    F = lf.fit_transform(X)
    assert "feed_mm_min_pow1_lp60" in F.columns
    assert "d_feed_mm_min" not in F.columns  # a driver, not a temperature
    # Travelling back heats as travelling forward.
    np.testing.assert_allclose(F["feed_mm_min_pow1_lp60"].iloc[5:], 2.0)


def test_without_drivers_the_driver_columns_are_left_out():
    # A candidate "without the drivers" must not take the spindle speed as a
    # temperature (its change since the run start and its filters): it is
    # the model of the temperatures alone.
    X = _frame().assign(spindle_rpm=np.r_[np.zeros(5), np.full(5, 3000.0)])
    y = X["spindle_rpm"].to_numpy() / 1000.0 + X["T1_C"].to_numpy()
    n_temps = X.shape[1] - 1
    for taus in [(), (60.0,)]:
        model = LagRidgeCV(
            time_constant_sets=[taus],
            alphas=[0.01],
            relative=True,
            driver_initial="steady",
        )
        model.fit(X, y)
        assert model.cv_results_["use_drivers"] == [True, False]
        alone = clone(model).set_params(drivers=None)
        alone.fit(X.drop(columns="spindle_rpm"), y)
        np.testing.assert_allclose(
            model.cv_results_["sse"][1], alone.cv_results_["sse"][0]
        )
        assert alone.cv_results_["use_drivers"] == [False]
        # With the drivers: their filters and the terms unfiltered, two
        # powers each.
        assert model.use_drivers_
        assert model.n_lag_features_ == (1 + len(taus)) * (n_temps + 2)
        assert np.isfinite(model.predict(X)).all()


def test_the_drivers_initial_state_is_chosen_by_the_cv():
    # Runs logged from a cold start with the spindle turning: "steady" takes
    # the speed as turning for ever before, "rest" as just switched on. On
    # independent records with such runs in training too (so no warning),
    # "steady" alone left held-out errors 1.2-1.7 times linear regression's.
    rng = np.random.default_rng(0)
    frames = []
    for r in range(4):
        t = np.arange(0.0, 4 * 3600.0, 60.0)
        rpm = np.where((t // 2400) % 2 == 0, 3000.0 + 500 * r, 0.0)  # on at t=0
        heat = _lowpass_series(rpm / 1000.0, t, 1800.0)  # from rest
        frames.append(
            pd.DataFrame(
                {
                    "run": f"r{r}",
                    "time_s": t,
                    "T1_C": 20
                    + 0.5 * _lowpass_series(heat, t, 1200.0)
                    + rng.normal(0, 0.01, t.size),
                    "spindle_rpm": rpm,
                    "y": 3.0 * heat + rng.normal(0, 0.05, t.size),
                }
            )
        )
    data = pd.concat(frames).set_index(["run", "time_s"])
    X, y = data[["T1_C", "spindle_rpm"]], data["y"]
    model = LagRidgeCV(time_constant_sets=[(1800.0,)]).fit(X, y)
    assert model.driver_initial_ == "rest"
    assert set(model.cv_results_["driver_initial"]) == {"steady", "rest"}
    steady = LagRidgeCV(time_constant_sets=[(1800.0,)], driver_initial="steady")
    steady.fit(X, y)
    assert model.best_score_ < 0.5 * steady.best_score_
    # No run starting driven: one initial state, the same for both.
    off = data.copy()
    off["spindle_rpm"] = (
        off["spindle_rpm"].groupby(level="run").shift(40, fill_value=0.0)
    )
    quiet = LagRidgeCV(time_constant_sets=[(1800.0,)]).fit(
        off[["T1_C", "spindle_rpm"]], y
    )
    assert set(quiet.cv_results_["driver_initial"]) == {"steady"}


def _lowpass_series(u, t, tau):
    """First-order lag of ``u`` from rest (exact for piecewise-constant u)."""
    out = np.zeros_like(u)
    for k in range(1, u.size):
        a = np.exp(-(t[k] - t[k - 1]) / tau)
        out[k] = a * out[k - 1] + (1 - a) * u[k - 1]
    return out


def test_filter_with_uneven_times_and_gaps_matches_recursion():
    rng = np.random.default_rng(1)
    n = 400
    steps = np.where(rng.random(n - 1) < 0.05, rng.uniform(60, 3000, n - 1), 15.0)
    steps = steps * rng.uniform(0.95, 1.05, n - 1)  # jitter, no gap
    t = np.r_[0.0, np.cumsum(steps)]
    u = rng.normal(size=(n, 2)).cumsum(axis=0)
    period = np.median(steps)
    for tau in (2.0, 300.0, 1e5):
        z = np.empty_like(u)
        prev = u[0]
        for k in range(n):
            h = 15.0 if k == 0 else t[k] - t[k - 1]
            a, d = np.exp(-h / tau), h / tau
            if k and h > 1.5 * period:  # a gap: the input ramps across it
                c = (1 - a) * u[k - 1] + (u[k] - u[k - 1]) * (1 - (1 - a) / d)
            else:
                c = (1 - a) * u[k]
            prev = a * prev + c
            z[k] = prev
        np.testing.assert_allclose(
            exponential_filter(u, tau, 15.0, times=t), z, rtol=1e-9, atol=1e-9
        )
    # Regular times: the same as one step for the run.
    regular = np.arange(n) * 15.0
    np.testing.assert_array_equal(
        exponential_filter(u, 60.0, 15.0, times=regular),
        exponential_filter(u, 60.0, 15.0),
    )


def test_lag_features_bridge_missing_samples():
    # A smooth heating run sampled every 30 s; 50 minutes of it missing.
    t = np.arange(400) * 30.0
    T = 20.0 + 5.0 * (1.0 - np.exp(-t / 2400.0))
    index = pd.MultiIndex.from_arrays(
        [np.full(t.size, "a"), t], names=["run", "time_s"]
    )
    X = pd.DataFrame({"T1_C": T}, index=index)
    lf = LagFeatures(time_constants=[600.0])
    full = np.asarray(lf.fit_transform(X))
    keep = np.r_[0:100, 200:400]
    with pytest.warns(UserWarning, match=r"1 gap\(s\).*run 'a'.*lasts 3030 s"):
        holed = np.asarray(lf.transform(X.iloc[keep]))
    # Across the gap the filters see the time pass: the features after it
    # are close to those of the complete record (the input taken to ramp
    # across the gap), unlike a gap read as one sampling period.
    np.testing.assert_allclose(holed[100:], full[200:], atol=0.1)
    contiguous = X.iloc[keep].copy()
    contiguous.index = pd.MultiIndex.from_arrays(
        [np.full(300, "a"), np.arange(300) * 30.0], names=["run", "time_s"]
    )
    assert np.abs(np.asarray(lf.transform(contiguous))[100:] - full[200:]).max() > 0.5


def test_a_static_lag_ridge_says_nothing_of_filtering_across_gaps():
    # The command line's tuned ridge (no filter) said it "filters across
    # them exactly" of a logging gap; the filtering ones still say so.
    t = np.r_[np.arange(100), np.arange(200, 400)] * 30.0
    index = pd.MultiIndex.from_arrays(
        [np.full(t.size, "a"), t], names=["run", "time_s"]
    )
    X = pd.DataFrame({"T1_C": 20.0 + 5.0 * (1.0 - np.exp(-t / 2400.0))}, index=index)
    y = 3.0 * X["T1_C"].to_numpy()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        static = LagRidgeCV(time_constant_sets=[()], drivers=None).fit(X, y)
        static.predict(X)
    with pytest.warns(UserWarning, match=r"filters across them exactly"):
        LagRidgeCV(time_constant_sets=[(600.0,)], drivers=None).fit(X, y)


def test_lag_ridge_says_once_that_fit_had_a_later_part():
    # An independent check of the docs: predicting an earlier part of a run
    # that fit saw later said it twice, from LagRidgeCV and its LagFeatures.
    t = np.arange(400) * 30.0
    index = pd.MultiIndex.from_arrays(
        [np.full(t.size, "a"), t], names=["run", "time_s"]
    )
    X = pd.DataFrame({"T1_C": 20.0 + 5.0 * (1.0 - np.exp(-t / 2400.0))}, index=index)
    y = 3.0 * X["T1_C"].to_numpy()
    model = LagRidgeCV(time_constant_sets=[(600.0,)], drivers=None)
    model.fit(X.iloc[200:], y[200:])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.predict(X.iloc[:100])
    said = [
        str(w.message) for w in caught if "starts before its rows" in str(w.message)
    ]
    assert len(said) == 1 and "given to LagRidgeCV.predict" in said[0], said


def test_lag_ridge_names_a_repeated_time():
    X = _frame()
    t = X.index.get_level_values("time_s").to_numpy().copy()
    t[3] = t[2]
    X.index = pd.MultiIndex.from_arrays(
        [X.index.get_level_values("run"), t], names=["run", "time_s"]
    )
    y = np.arange(len(X), dtype=float)
    with pytest.raises(ValueError, match=r"time_s must increase.*row 3"):
        LagRidgeCV().fit(X, y)


def test_bad_driver_and_time_order():
    X = _frame()
    with pytest.raises(ValueError, match="'rpm'"):
        LagFeatures(drivers=["rpm"]).fit(X)
    bad = X.iloc[[1, 0, 2, 3, 4, 5, 6, 7, 8, 9]]
    with pytest.raises(ValueError, match="time_s must increase"):
        LagFeatures().fit(bad).transform(bad)


@LAG_MODELS
def test_rows_without_run_labels_warn_with_the_fix(model):
    X = _frame()
    y = np.arange(len(X), dtype=float)
    model.fit(X, y)
    assert model.n_fitted_runs_ == 2
    use = model.transform if hasattr(model, "transform") else model.predict
    bare = X.reset_index(drop=True)  # the same rows without their run labels
    with pytest.warns(UserWarning, match="ONE run.*groups=") as record:
        out = use(bare)
    assert len(record) == 1  # once, not again from the inner transformer
    np.testing.assert_allclose(out, use(bare, groups=np.zeros(len(X))))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        use(X)  # the run labels of the index: no warning
    # Plain rows in fit (a step in front that outputs numpy): the runs and
    # the drivers' names are lost, and fit says both.
    with pytest.warns(UserWarning) as record:
        model.set_params(dt=30.0).fit(X.to_numpy(), y)
    assert {w.filename for w in record} == {__file__}  # the user's line
    messages = sorted(str(w.message) for w in record)
    assert len(messages) == 2
    assert re.search(r"\.fit got 10 rows .* ONE run", messages[0])
    assert re.search(
        r"drivers='auto' finds the drivers .* no column names", messages[1]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        use(X.to_numpy())  # fitted without labels: nothing to warn about
        model.set_params(drivers=None).fit(X.to_numpy(), y, groups=np.zeros(len(y)))


@LAG_MODELS
def test_rows_without_labels_do_not_continue_a_run_labelled_zero(model):
    # With integer run labels, unlabelled rows are a new run, not run 0
    # continued.
    X = _frame()
    X.index = X.index.set_levels([0, 1], level="run")
    y = np.arange(len(X), dtype=float)
    model.fit(X, y)
    use = model.transform if hasattr(model, "transform") else model.predict
    tail = X.loc[[1]]
    with pytest.warns(UserWarning, match="ONE run"):
        bare = use(tail.to_numpy())
    np.testing.assert_allclose(bare, use(tail.rename(index={1: 99}, level="run")))


def test_filters_a_piece_of_columns_at_a_time_with_the_same_values(monkeypatch):
    # Long runs with many columns are filtered a few columns at a time (the
    # temporaries stay small); the values are those of one call per time
    # constant, bit for bit, on the regular path (runs of one length
    # together) and the per-run one (uneven times, a continued state).
    import skthermal.preprocessing._lags as lags

    rng = np.random.default_rng(3)
    U = rng.normal(size=(90, 7)).cumsum(0)
    slices = [slice(0, 30), slice(30, 60), slice(60, 90)]
    taus = [5.0, 5.0, 20.0, 5.0, 20.0, 60.0, 5.0]
    state = [None, rng.normal(size=7), None]
    state[1][5] = np.nan  # this time constant's columns start anew
    times = np.r_[np.arange(30.0), np.arange(30.0), np.arange(30.0) ** 1.1]
    calls = [
        {"dt": 1.0, "slices": slices, "state": state},
        {"dt": 1.0, "slices": slices, "initial": "rest"},
        {"dt": 1.0, "slices": slices, "times": times, "state": state},
    ]
    whole = [lags.exponential_filter(U, taus, **kw) for kw in calls]
    monkeypatch.setattr(lags, "_CHUNK_ELEMENTS", 40)  # one column at a time
    for kw, expected in zip(calls, whole, strict=True):
        np.testing.assert_array_equal(lags.exponential_filter(U, taus, **kw), expected)


def test_lag_ridge_cv_holds_one_fold_copy_at_a_time():
    # The CV standardises a copy of each fold's rows; the previous fold's
    # copy is gone before the next one is made, and no second copy is made
    # for the standard deviations.
    import tracemalloc

    from skthermal.preprocessing._lag_ridge import _ridge_path_sse
    from skthermal.utils._folds import forward_folds

    rng = np.random.default_rng(0)
    F = rng.normal(size=(20000, 40))
    y = F[:, 0] + rng.normal(size=20000)
    folds = forward_folds(20000, 4, 0.6)
    alphas = np.logspace(-2, 4, 7)
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        _ridge_path_sse(F, y, folds, alphas)
        extra = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    assert extra < 1.3 * F.nbytes


def test_cv_uses_training_rows_only():
    from sklearn.linear_model import Ridge
    from sklearn.preprocessing import StandardScaler

    from skthermal.preprocessing._lag_ridge import _ridge_path_sse
    from skthermal.utils._folds import forward_folds

    rng = np.random.default_rng(0)
    n = 300
    T = np.cumsum(rng.normal(size=(n, 2)), axis=0)
    y = T[:, 0] + 0.1 * rng.normal(size=n)
    lf = LagFeatures(time_constants=[5.0], dt=1.0).fit(T)
    F = lf.transform(T)
    # causal: features of a prefix equal the prefix of the features, so
    # slicing once-computed features per forward fold sees no later rows
    np.testing.assert_allclose(lf.transform(T[:120]), F[:120])
    # the SVD alpha path equals ridge refitted on each fold's training rows
    folds = forward_folds(n, 4, 0.4)
    alphas = np.array([0.1, 10.0])
    expected = np.zeros(2)
    for tr, va in folds:
        sc = StandardScaler().fit(F[tr])
        for j, a in enumerate(alphas):
            m = Ridge(alpha=a).fit(sc.transform(F[tr]), y[tr])
            expected[j] += np.sum((m.predict(sc.transform(F[va])) - y[va]) ** 2)
    np.testing.assert_allclose(_ridge_path_sse(F, y, folds, alphas), expected)
    # fit's CV scores come from the rows given to fit, in the same folds
    m1 = LagRidgeCV(time_constant_sets=[(), (5.0,)], alphas=alphas, dt=1.0).fit(T, y)
    # one entry per (candidate, penalty): a table, the candidates in order
    np.testing.assert_allclose(m1.cv_results_["sse"][2:], expected)
    table = pd.DataFrame(m1.cv_results_)
    assert table.shape[0] == 4
    np.testing.assert_array_equal(table["alpha"], np.tile(alphas, 2))
    assert list(table["time_constants"]) == [(), (), (5.0,), (5.0,)]
    n_scored = sum(va.size for _, va in folds)
    np.testing.assert_allclose(table["mse"], table["sse"] / n_scored)
    assert table["rank_sse"].min() == 1 and sorted(table["rank_sse"]) == [1, 2, 3, 4]
    assert m1.best_score_ == table["mse"][m1.best_index_] == table["mse"].min()
    m1 = LagRidgeCV(time_constant_sets=[(), (5.0,)], dt=1.0).fit(T[:200], y[:200])
    assert m1.cv_results_["sse"].shape == (2 * 15,)
    assert np.isfinite(m1.predict(T)).all()


def test_cv_folds_score_only_later_rows():
    from skthermal.utils._folds import forward_folds, group_folds

    for tr, va in forward_folds(100, 4, 0.4):
        assert tr.max() < va.min()
    folds = group_folds([slice(0, 3), slice(3, 7), slice(7, 9)], 4)
    assert len(folds) == 3
    for tr, va in folds:
        assert np.intersect1d(tr, va).size == 0


def test_absolute_readings_and_drivers_from_rest():
    X = _frame()
    lf = LagFeatures(
        time_constants=[60.0], relative=False, driver_initial="rest"
    ).set_output(transform="pandas")
    F = lf.fit_transform(X)
    assert list(F.columns)[:2] == ["T1_C", "T1_C_lp60"]
    np.testing.assert_allclose(F["T1_C"], X["T1_C"])
    # temperature filters start in steady state at the first reading
    assert F["T1_C_lp60"].iloc[6] == pytest.approx(30.0)
    # driver filters start at rest: the first row is (1 - a) u
    a = np.exp(-30.0 / 60.0)
    assert F["spindle_rpm_pow1_lp60"].iloc[0] == pytest.approx((1 - a) * 2.0)
    assert F["spindle_rpm_pow1_lp60"].iloc[1] > F["spindle_rpm_pow1_lp60"].iloc[0]


def test_a_flat_list_of_time_constants_is_named():
    X = _frame()
    y = np.arange(len(X), dtype=float)
    with pytest.raises(ValueError, match=r"for one set write \[\(900, 3600\)\]"):
        LagRidgeCV(time_constant_sets=[900, 3600]).fit(X, y)


def test_cv_schemes_and_the_one_standard_error_rule():
    from skthermal.utils._folds import block_folds

    folds = block_folds(10, 3)
    held = np.sort(np.concatenate([va for _, va in folds]))
    np.testing.assert_array_equal(held, np.arange(10))  # every row once
    for tr, va in folds:
        assert np.intersect1d(tr, va).size == 0 and tr.size + va.size == 10

    rng = np.random.default_rng(1)
    n = 240
    T = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    y = T @ [1.0, 0.5, 0.0] + rng.normal(size=n)
    alphas = np.logspace(-3, 3, 13)
    kw = {
        "time_constant_sets": [(), (5.0,)],
        "alphas": alphas,
        "cv": "blocks",
        "dt": 1.0,
        "drivers": None,
    }
    one_run = np.zeros(n)  # the rows are one run, said as such
    best = LagRidgeCV(**kw).fit(T, y, groups=one_run)
    simple = LagRidgeCV(**kw, selection="1se").fit(T, y, groups=one_run)
    # within one standard error of the best: a penalty at least as large
    assert simple.alpha_ >= best.alpha_
    mse = simple.cv_results_["sse"].min() / n
    assert simple.best_score_ >= mse - 1e-12
    # several runs: changes and absolute readings are both tried
    groups = np.repeat([0, 1, 2, 3], n // 4)
    m = LagRidgeCV(time_constant_sets=[(5.0,)], alphas=[1.0], dt=1.0, drivers=None).fit(
        T, y, groups=groups
    )
    assert set(m.cv_results_["relative"]) == {True, False}
    assert m.relative_ in (True, False)


@pytest.mark.skipif(
    not (DATA / "fl_thermal_spindle.csv.gz").exists(),
    reason="FL_THERMAL data not found in ../shared/data",
)
def test_fl_thermal_target():
    df = pd.read_csv(DATA / "fl_thermal_spindle.csv.gz")
    temps = [f"T{i}_C" for i in range(1, 17)]
    n = len(df)
    cut = int(0.6 * n)
    index = pd.MultiIndex.from_arrays(
        [np.zeros(n, int), df["time_s"].to_numpy()], names=["run", "time_s"]
    )
    X = df[temps + ["spindle_rpm"]].set_axis(index, axis=0)
    for ch in (1, 5):  # the best and the worst channel of the benchmark
        y = df[f"disp_ch{ch}_um"].to_numpy()
        lr = LinearRegression().fit(df[temps].iloc[:cut], y[:cut])
        base = np.sqrt(np.mean((lr.predict(df[temps].iloc[cut:]) - y[cut:]) ** 2))
        pred = make_lag_pipeline().fit(X.iloc[:cut], y[:cut]).predict(X)[cut:]
        assert np.sqrt(np.mean((pred - y[cut:]) ** 2)) <= 0.5 * base


def test_exponential_filter_names_bad_arguments():
    from skthermal.preprocessing import exponential_filter

    u = np.r_[0.0, 1.0, 1.0, 1.0]
    cases = [
        ({"dt": -1.0}, "dt must be finite and > 0"),
        ({"dt": np.nan}, "dt must be finite and > 0"),
        ({"dt": [1.0, 2.0]}, "dt must be a number or one per run"),
        ({"dt": 1.0, "times": [0, 1, 2, 1.5]}, "increase strictly"),
        ({"dt": 1.0, "times": [0, 1, np.nan, 3]}, "times must be finite"),
        ({"dt": 1.0, "slices": [slice(0, 3)]}, "cover every row"),
        ({"dt": 1.0, "state": [np.ones(3)]}, "one value per column"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            exponential_filter(u, 1.0, **kwargs)
    with pytest.raises(ValueError, match="single number"):
        exponential_filter(1.0, 1.0, 1.0)


def test_lag_ridge_on_too_few_rows_says_nothing_was_validated():
    X = _frame().iloc[:2]
    with pytest.warns(UserWarning, match="leave no cross-validation fold"):
        LagRidgeCV(time_constant_sets=[(60.0,)], alphas=[1.0, 10.0]).fit(
            X, np.arange(2.0)
        )


def test_lag_ridge_says_when_its_candidates_are_slow_for_the_runs():
    # A process that responds within a few samples, runs of 1,800 s and
    # candidates of 600 s and more: the CV falls back to the static model,
    # and says why, with what to do.
    rng = np.random.default_rng(0)
    n = 200
    u = rng.uniform(0, 5, n)
    y = np.convolve(u, np.exp(-np.arange(20) / 2.0), mode="full")[:n]
    y = y + 0.01 * rng.standard_normal(n)
    X = pd.DataFrame({"run": "a", "time_s": 9.0 * np.arange(n), "T1_C": u})
    slow = [(), (600.0, 1800.0)]
    with pytest.warns(
        UserWarning,
        match=r"chose no time constant .*600-1800 s.*"
        r"at most 1791 s \(sampled every 9 s\).*time_constant_sets",
    ):
        model = LagRidgeCV(time_constant_sets=slow, drivers=None).fit(X, y)
    assert model.time_constants_ == ()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fast = LagRidgeCV(time_constant_sets=[(), (9.0, 27.0)], drivers=None)
        assert fast.fit(X, y).time_constants_ == (9.0, 27.0)
    # A run that spans ten times the shortest candidate (here across a
    # logging pause of 11 h) is not short for them.
    paused = X.assign(time_s=np.r_[9.0 * np.arange(100), 40000 + 9.0 * np.arange(100)])
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        model = LagRidgeCV(time_constant_sets=slow, drivers=None).fit(paused, y)
    assert model.time_constants_ == ()
    assert not [w for w in rec if "chose no time constant" in str(w.message)]


@pytest.mark.parametrize(
    "params, message",
    [
        ({"driver_powers": (-1.0, 1.5)}, r"'driver_powers'.*Got -1.0 at position 0"),
        ({"driver_powers": (0.0,)}, r"'driver_powers'.*Got 0.0 at position 0"),
        ({"driver_powers": (1.0, np.nan)}, r"'driver_powers'.*Got nan at position 1"),
        ({"driver_powers": ("1",)}, r"'driver_powers'.*Got '1' at position 0"),
        ({"driver_powers": ()}, r"'driver_powers'.*at least one.*drivers=None"),
        ({"driver_powers": (1.0, 1.0)}, r"'driver_powers'.*repeats 1"),
        ({"time_constants": (60.0, np.inf)}, r"'time_constants'.*Got inf at"),
        ({"time_constants": ("60",)}, r"'time_constants'.*Got '60' at"),
        ({"time_constants": (60.0, 60.0)}, r"'time_constants'.*repeats 60"),
    ],
)
def test_lag_features_names_a_bad_power_or_time_constant(params, message):
    # Negative powers made infinite features at rest, NaN ones NaN features,
    # and 0 a constant one; repeated entries repeated a feature's name.
    X = _frame()
    with pytest.raises(ValueError, match=r"parameter of LagFeatures must be"):
        LagFeatures(**params).fit(X)
    with pytest.raises(ValueError, match=message):
        LagFeatures(**params).fit(X)


@pytest.mark.parametrize(
    "params, message",
    [
        ({"alphas": [1.0, np.nan]}, r"'alphas'.*Got nan at position 1"),
        ({"alphas": [np.inf]}, r"'alphas'.*Got inf at position 0"),
        ({"alphas": [0.0, 1.0]}, r"'alphas'.*Got 0.0 at position 0"),
        ({"alphas": ["1"]}, r"'alphas'.*Got '1' at position 0"),
        ({"alphas": []}, r"'alphas'.*at least one"),
        ({"time_constant_sets": [(), (60.0, np.nan)]}, r"'time_constant_sets\[1\]'"),
        ({"time_constant_sets": [("60",)]}, r"'time_constant_sets\[0\]'.*'60'"),
        ({"time_constant_sets": [(60.0, -5.0)]}, r"Got -5.0 at position 1"),
        ({"time_constant_sets": [None]}, r"'time_constant_sets\[0\]'.*Got None"),
        ({"time_constant_sets": []}, r"at least one candidate set"),
    ],
)
def test_lag_ridge_names_a_bad_grid_entry(params, message):
    X = _frame()
    y = np.arange(len(X), dtype=float)
    with pytest.raises(ValueError, match=message):
        LagRidgeCV(**params).fit(X, y)


def test_one_row_runs_do_not_pull_the_fitted_sampling_period():
    # Run a sampled every 30 s, runs c and d of one row each: the period is
    # 30 s (it was the median of 30, 1 and 1 s), which rows without times
    # and the one-row runs are then filtered with.
    X = _frame().loc[["a"]]
    ones = X.iloc[:2].set_axis(
        pd.MultiIndex.from_arrays([["c", "d"], [0.0, 0.0]], names=X.index.names)
    )
    data = pd.concat([X, ones])
    lf = LagFeatures(time_constants=[60.0], driver_initial="rest").fit(data)
    assert lf.sample_period_s_ == 30.0
    F = np.asarray(lf.transform(data))
    # A one-row run: its first row filtered from rest over one 30 s period.
    a = np.exp(-30.0 / 60.0)
    pow1_lp60 = list(lf.get_feature_names_out()).index("spindle_rpm_pow1_lp60")
    assert F[-1, pow1_lp60] == pytest.approx((1 - a) * X["spindle_rpm"].iloc[1] / 1e3)
    model = LagRidgeCV(time_constant_sets=[(60.0,)], alphas=[1.0])
    model.fit(data, np.arange(len(data), dtype=float))
    assert model.lag_features_.sample_period_s_ == 30.0
    # No run of two rows: dt, or an error that names the fix.
    assert LagFeatures(dt=15.0).fit(ones).sample_period_s_ == 15.0
    with pytest.raises(ValueError, match="LagFeatures: no run has two rows.*dt="):
        LagFeatures().fit(ones)


def test_late_start_messages_name_the_estimator_called():
    # LagRidgeCV.predict, not LagFeatures.predict; the warning points at
    # the caller's line.
    table = _long_run()
    y = table["T1_C"].to_numpy()
    cut = 50
    model = LagRidgeCV(time_constant_sets=[(300.0,)], alphas=[1.0])
    model.fit(table.iloc[:cut], y[:cut])
    other = table.iloc[cut:].assign(run="other")
    with pytest.warns(UserWarning, match=r"given to LagRidgeCV\.predict") as record:
        model.predict(other)
    assert len(record) == 1 and record[0].filename == __file__
    with pytest.raises(ValueError, match=r"LagRidgeCV\.predict takes a run"):
        model.predict(table.iloc[20:])
    # A LagFeatures step: named alone (a pipeline calls it), the warning
    # pointing at the caller of transform.
    lf = LagFeatures(time_constants=[300.0]).fit(table.iloc[:cut])
    with pytest.warns(UserWarning, match=r"'other' given to LagFeatures start") as rec:
        lf.transform(other)
    assert rec[0].filename == __file__
    with pytest.raises(ValueError, match=r"LagFeatures takes a run"):
        lf.transform(table.iloc[20:])
    # In a pipeline, the step is named, not a LagFeatures.predict.
    pipe = make_pipeline(LagFeatures(time_constants=[300.0]), LinearRegression())
    pipe.fit(table.iloc[:cut], y[:cut])
    with pytest.warns(UserWarning, match=r"'other' given to LagFeatures start"):
        pipe.predict(other)


def _five_runs(seed=0):
    rng = np.random.default_rng(seed)
    frames = []
    for r, label in enumerate(["r1", "r2", "r3", "r4", "r5"]):
        T = 20 + r + np.cumsum(rng.normal(scale=0.3, size=(40, 2)), axis=0)
        y = 3 * (T[:, 0] - T[0, 0]) + 0.5 * T[:, 1] + rng.normal(scale=0.5, size=40)
        frames.append(
            pd.DataFrame(
                {
                    "run": label,
                    "time_s": np.arange(40) * 60.0,
                    "T1_C": T[:, 0],
                    "T2_C": T[:, 1],
                    "y": y,
                }
            )
        )
    return pd.concat(frames, ignore_index=True)


def test_lag_ridge_is_the_same_model_whatever_the_order_of_the_runs():
    # The runs were dealt into the CV folds in table order: another order of
    # the same runs chose another penalty (here 10 or 0.1).
    table = _five_runs()
    inputs = ["run", "time_s", "T1_C", "T2_C"]
    kw = {
        "time_constant_sets": [(), (300.0,)],
        "alphas": [0.1, 10.0, 1000.0],
        "n_splits": 2,
    }
    base = LagRidgeCV(**kw).fit(table[inputs], table["y"])
    expected = base.predict(table[inputs])
    for order in (["r4", "r2", "r5", "r1", "r3"], ["r5", "r4", "r3", "r2", "r1"]):
        shuffled = pd.concat([table[table["run"] == r] for r in order])
        model = LagRidgeCV(**kw).fit(shuffled[inputs], shuffled["y"])
        assert (model.alpha_, model.relative_) == (base.alpha_, base.relative_)
        np.testing.assert_allclose(
            model.predict(table[inputs]), expected, rtol=0, atol=1e-9
        )


def test_run_folds_do_not_depend_on_the_order_of_unsortable_labels():
    from skthermal.utils._folds import group_folds

    # Tuples of a number and a string do not sort: their repr orders them.
    labels = [("a", 1), (1, "a"), ("b", 2), (2, "b")]

    def held_out(order):
        """The labels of the runs each fold leaves out, runs stacked in order."""
        labs = [labels[r] for r in order]
        slices = [slice(3 * i, 3 * i + 3) for i in range(len(labs))]
        folds = group_folds(slices, 2, labs)
        return sorted(sorted({repr(labs[int(i) // 3]) for i in va}) for _, va in folds)

    assert held_out([0, 1, 2, 3]) == held_out([3, 1, 0, 2]) == held_out([2, 0, 3, 1])


def test_two_targets_are_refused_naming_them_and_the_way_out():
    X = _frame()
    Y = pd.DataFrame(
        {"disp_x_um": np.arange(10.0), "disp_y_um": np.arange(10.0) ** 2},
        index=X.index,
    )
    with pytest.raises(
        ValueError,
        match=r"LagRidgeCV fits one target, got 2 \(\['disp_x_um', 'disp_y_um'\]\).*"
        r"MultiOutputRegressor",
    ):
        make_lag_pipeline().fit(X, Y)


def test_lag_ridge_takes_readings_as_they_are_for_a_run_cut_from_a_record():
    # One run from its start: changes since the start. One run cut from a
    # longer record (time_s starting after 0): no particular start state,
    # so the readings as they are.
    X = _frame().loc[["a"]]
    y = np.linspace(0.0, 3.0, len(X))
    model = LagRidgeCV(time_constant_sets=[(60.0,)], alphas=[1.0])
    assert model.fit(X, y).relative_ is True
    later = X.set_axis(
        X.index.set_levels(X.index.levels[1] + 600.0, level="time_s"), axis=0
    )
    assert model.fit(later, y).relative_ is False


def test_auto_drivers_found_nowhere_warn():
    X = _frame()
    with pytest.warns(UserWarning, match=r"found none of the drivers") as record:
        LagFeatures(time_constants=[60.0]).fit(X.drop(columns="spindle_rpm"))
    assert record[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LagFeatures(time_constants=[60.0], drivers=None).fit(
            X.drop(columns="spindle_rpm")
        )
        LagFeatures(time_constants=[60.0]).fit(X)
    # The speed under another name: the warning names it (it went in as a
    # temperature without a word about it).
    rps = X.rename(columns={"spindle_rpm": "spindle_rps"})
    with pytest.warns(
        UserWarning, match=r"'spindle_rps' looks like 'spindle_rpm'"
    ) as record:
        LagFeatures(time_constants=[60.0]).fit(rps)
    # ... and says it goes in as a temperature (not "temperatures only").
    message = str(record[0].message)
    assert "every column is taken as a temperature, ['spindle_rps'] too" in message
    assert "temperatures only" not in message
    # drivers=None with the speed in X: it goes in as a temperature, said.
    with pytest.warns(UserWarning, match=r"drivers=None .* \['spindle_rpm'\] too"):
        LagFeatures(time_constants=[60.0], drivers=None).fit(X)


def test_a_centred_driver_warns_once():
    # A StandardScaler in front made a stopped spindle -1.1 and 2000 rpm
    # 0.12: its magnitude counted a stop as more heat, and the cross-validated
    # errors of LagRidgeCV grew from 0.3 to 2-57 µm without a word.
    from sklearn.preprocessing import StandardScaler

    X = _frame()
    y = np.arange(len(X), dtype=float)
    scaled = make_pipeline(StandardScaler(), LagRidgeCV()).set_output(
        transform="pandas"
    )
    for model in (
        make_pipeline(StandardScaler(), LagFeatures()).set_output(transform="pandas"),
        scaled,
    ):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model.fit(X, y)
        said = [w for w in caught if "has a mean of 0" in str(w.message)]
        assert len(said) == 1 and "'spindle_rpm'" in str(said[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LagFeatures().fit(X)  # as logged
        make_pipeline(LagFeatures(), StandardScaler()).fit(X)


def test_lag_ridge_says_its_progress_when_asked(capsys):
    # A fit on a long campaign logged every second took minutes in silence.
    table = _five_runs()
    inputs = ["run", "time_s", "T1_C", "T2_C"]
    model = LagRidgeCV(time_constant_sets=[(), (300.0,)], verbose=1)
    model.fit(table[inputs], table["y"])
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 5 and lines[-1].startswith("[LagRidgeCV] refit on 200 rows")
    assert all(re.search(r"validation MSE .* s\)$", line) for line in lines[:-1])
    LagRidgeCV(time_constant_sets=[(), (300.0,)]).fit(table[inputs], table["y"])
    assert capsys.readouterr().out == ""


def test_a_run_starting_driven_when_no_training_run_did_warns():
    # Held out, runs that start cold with the spindle on were 46 µm off
    # (0.89 with driver_initial="rest"), without a word.
    X = _frame().iloc[:6]  # run 'a' starts turning
    rest = X.assign(spindle_rpm=np.r_[0.0, X["spindle_rpm"].to_numpy()[1:]])
    lf = LagFeatures(time_constants=[60.0]).fit(rest)
    assert not lf.runs_start_driven_
    with pytest.warns(UserWarning, match=r"run\(s\) \['a'\] start with spindle_rpm on"):
        lf.transform(X)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LagFeatures(time_constants=[60.0], driver_initial="rest").fit(rest).transform(X)
        LagFeatures(time_constants=[60.0]).fit(X).transform(X)  # trained so
    later = X.reset_index().assign(run="z", time_s=lambda d: d["time_s"] + 600)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lf.transform(later)  # cut from a longer record: driven before
    assert not any("start with spindle_rpm on" in str(w.message) for w in caught)


def test_exponential_filter_names_bad_rows_slices_state_and_periods():
    from skthermal.preprocessing import exponential_filter

    U = np.r_[0.0, 1.0, 1.0, 1.0]
    with pytest.raises(ValueError, match="missing or infinite value at row 1"):
        exponential_filter(np.r_[0.0, np.nan, 1.0, 1.0], 5.0, 1.0)
    assert exponential_filter(np.zeros((0, 2)), 5.0, 1.0).shape == (0, 2)
    with pytest.raises(ValueError, match="slice\\(start, stop\\) objects"):
        exponential_filter(U, 5.0, 1.0, slices=[(0, 2), (2, 4)])
    with pytest.raises(ValueError, match="slice\\(start, stop\\) objects"):
        exponential_filter(U, 5.0, 1.0, slices=[slice(0, 40)])
    with pytest.raises(ValueError, match="state must be a list"):
        exponential_filter(U, 5.0, 1.0, state=5.0)
    for periods in ([0.0], [-1.0], [1.0, 1.0]):
        with pytest.raises(ValueError, match="periods must hold one"):
            exponential_filter(U, 5.0, 1.0, times=[0, 1, 2, 3], periods=periods)


def test_lag_ridge_cv_by_runs_on_one_run_says_what_it_does():
    rng = np.random.default_rng(0)
    X = 20 + np.cumsum(rng.normal(0, 0.05, (120, 2)), axis=0)
    y = X[:, 0] - 20
    model = LagRidgeCV(cv="runs", time_constant_sets=[(5.0,)], dt=1.0)
    with pytest.warns(UserWarning, match=r"cv='runs'.*one run.*cv='forward'") as rec:
        model.fit(X, y, groups=np.zeros(120))
    assert any(w.filename == __file__ for w in rec)
    forward = LagRidgeCV(cv="forward", time_constant_sets=[(5.0,)], dt=1.0)
    forward.fit(X, y, groups=np.zeros(120))
    assert model.alpha_ == forward.alpha_


def test_runs_of_slightly_different_steps_keep_their_own():
    # The one-pass filter of runs at one common step took the first run's
    # step for every run whose step agreed within 1e-9: the last bits moved.
    from skthermal.preprocessing._lags import lowpass_steps

    rng = np.random.default_rng(0)
    U = rng.normal(size=(20, 2)).cumsum(0)
    slices = [slice(0, 10), slice(10, 20)]
    Z = exponential_filter(U, 30.0, dt=[1.0, 1.0 + 1e-12], slices=slices)
    for sl, step in zip(slices, [1.0, 1.0 + 1e-12], strict=True):
        np.testing.assert_array_equal(Z[sl], lowpass_steps(U[sl], 30.0, step))
