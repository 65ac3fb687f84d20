"""Tests of the transfer-function thermal-error model."""

import warnings

import numpy as np
import pandas as pd
import pytest

from skthermal.linear_model import TransferFunctionRegressor, first_order_lags
from skthermal.linear_model._transfer import (
    _direct_changes,
    _fit_lags,
    _grid_moments,
    _orthonormal_basis,
    _ridge_column_changes,
    _ridge_residual,
    _standardise,
    _triangular_factor,
)
from skthermal.preprocessing import exponential_filter


def _heating_runs(taus=(300.0, 1200.0), gains=(2.0, -0.5), speed_gain=0.003):
    """Two runs, 10 s sampling, built from known first-order lags.

    T1 follows the spindle's heat, T2 the room (independent of the spindle).
    """
    frames = []
    for run, (on, n) in enumerate([(1800, 720), (2400, 600)]):
        t = np.arange(n) * 10.0
        speed = np.where(t < on, 4000.0, 0.0)
        slices = [slice(0, n)]
        heat = first_order_lags(
            speed[:, None] / 1000.0, np.array([400.0]), np.array([10.0]), slices
        )[:, 0]
        t1 = 21.0 + 3.0 * heat
        room = np.sin(2 * np.pi * t / (3000.0 + 1000.0 * run))
        t2 = (
            20.0
            + first_order_lags(
                room[:, None], np.array([900.0]), np.array([10.0]), slices
            )[:, 0]
        )
        U = np.c_[t1 - t1[0], t2 - t2[0], speed]
        Z = first_order_lags(U, np.array([*taus, 500.0]), np.array([10.0]), slices)
        err = Z @ np.array([*gains, speed_gain]) + 1.5
        frames.append(
            pd.DataFrame(
                {
                    "run": f"r{run}",
                    "time_s": t,
                    "T1_C": t1,
                    "T2_C": t2,
                    "spindle_rpm": speed,
                    "disp_z_um": err,
                }
            )
        )
    df = pd.concat(frames).set_index(["run", "time_s"])
    return df[["T1_C", "T2_C", "spindle_rpm"]], df["disp_z_um"]


def test_first_order_lags_step_response_and_restart():
    U = np.ones((6, 1))
    z = first_order_lags(
        U, np.array([2.0]), np.array([1.0, 1.0]), [slice(0, 3), slice(3, 6)]
    )[:, 0]
    expected = 1 - np.exp(-np.arange(1, 4) / 2.0)
    np.testing.assert_allclose(z, np.r_[expected, expected])


def test_recovers_known_time_constants_and_gains():
    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm", max_iter=60)
    model.fit(X, y)
    np.testing.assert_allclose(model.time_constants_[:, 0], [300, 1200, 500], rtol=0.02)
    np.testing.assert_allclose(model.lag_coef_[:, 0], [2.0, -0.5, 0.003], rtol=0.02)
    assert model.intercept_ == pytest.approx(1.5, abs=1e-3)
    assert np.max(np.abs(model.predict(X) - y.to_numpy())) < 1e-3


@pytest.mark.parametrize("unit", [1e-6, 1e-3, 1e3, 1e60])
def test_the_unit_of_the_output_changes_no_time_constant(unit):
    # The same displacements in metres (or nanometres): the same time
    # constants, the predictions in that unit, and no warning from inside
    # the optimiser. The refinement's stopping rules are absolute, and in
    # metres it stopped at its start (the time constants were off by 2.5x).
    X, y = _heating_runs(taus=(800.0, 2000.0))
    ref = TransferFunctionRegressor(speed_column="spindle_rpm", max_iter=20).fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        model = TransferFunctionRegressor(speed_column="spindle_rpm", max_iter=20)
        model.fit(X, y * unit)
        pred = model.predict(X) / unit
    np.testing.assert_allclose(model.time_constants_, ref.time_constants_, rtol=1e-6)
    np.testing.assert_allclose(pred, ref.predict(X), rtol=1e-7, atol=1e-9)


def test_a_time_constant_at_the_upper_bound_warns():
    # A lag far slower than the runs: the data cannot fix it, it ends at the
    # longest run, and its gain extrapolates; the input is named.
    X, y = _heating_runs(taus=(300.0, 1e6), gains=(2.0, -400.0))
    with pytest.warns(UserWarning, match=r"time constant of 'T2_C' ends at the upper"):
        TransferFunctionRegressor(speed_column="spindle_rpm", max_iter=20).fit(X, y)
    X, y = _heating_runs()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        TransferFunctionRegressor(speed_column="spindle_rpm", max_iter=20).fit(X, y)


def _duty_runs(n_runs=6, hours=4.0, dt=10.0, seed=1):
    """Runs of random spindle duty with first-order lags and noise: the error
    follows T1 (1200 s), the speed (600 s) and T2 (300 s)."""
    rng = np.random.default_rng(seed)
    frames = []
    for r in range(n_runs):
        t = np.arange(0.0, hours * 3600.0, dt)
        one = [slice(0, t.size)]
        edges = np.cumsum(rng.uniform(1800.0, 5400.0, 20))
        block = np.searchsorted(edges, t)
        speeds = rng.choice([2000.0, 4000.0, 6000.0, 8000.0], 20)
        rpm = np.where(block % 2 == r % 2, speeds[block], 0.0)

        def lag(u, tau, t=t, one=one):
            return first_order_lags(u[:, None], np.array([tau]), [dt], one)[:, 0]

        t1 = 21.0 + 0.8 * lag(rpm / 1000.0, 900.0)
        t1 += 0.01 * rng.standard_normal(t.size)
        t2 = 20.0 + 0.5 * np.sin(2 * np.pi * t / 20000.0 + r)
        t2 += 0.01 * rng.standard_normal(t.size)
        err = (
            3.0 * lag(t1 - t1[0], 1200.0)
            + 0.4 * lag(rpm / 1000.0, 600.0)
            - lag(t2 - t2[0], 300.0)
            + 0.02 * rng.standard_normal(t.size)
        )
        frames.append(
            pd.DataFrame(
                {"run": f"r{r}", "time_s": t, "T1_C": t1, "T2_C": t2},
            ).assign(spindle_rpm=rpm, err=err)
        )
    df = pd.concat(frames).set_index(["run", "time_s"])
    return df.drop(columns="err"), df["err"]


def test_a_superfluous_slow_lag_with_no_gain_does_not_warn():
    # First-order data fitted with order=2: an input's second lag has
    # nothing to fit and ends at the upper bound with a gain near zero; it
    # changes nothing, so it is not worth a word.
    X, y = _duty_runs()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model = TransferFunctionRegressor(speed_column="spindle_rpm", order=2).fit(X, y)
    at_bound = model.time_constants_ >= 0.99 * 4 * 3600.0
    assert at_bound.any()
    assert np.all(np.abs(model.lag_coef_[at_bound]) < 0.05)


def test_time_from_index_matches_dt():
    X, y = _heating_runs()
    a = TransferFunctionRegressor(speed_column=2, max_iter=5).fit(X, y)
    b = TransferFunctionRegressor(speed_column=2, max_iter=5, dt=10.0).fit(
        X.to_numpy(), y.to_numpy(), groups=X.index.get_level_values("run")
    )
    np.testing.assert_allclose(a.time_constants_, b.time_constants_)
    np.testing.assert_allclose(
        a.predict(X), b.predict(X.to_numpy(), groups=X.index.get_level_values(0))
    )


def test_refinement_beats_grid_search():
    X, y = _heating_runs()
    grid = TransferFunctionRegressor(speed_column=2, max_iter=0).fit(X, y)
    refined = TransferFunctionRegressor(speed_column=2, max_iter=30).fit(X, y)
    err = [np.mean((m.predict(X) - y.to_numpy()) ** 2) for m in (grid, refined)]
    assert err[1] < 0.1 * err[0]


def test_second_order_and_multi_output():
    X, y = _heating_runs()
    Y = np.c_[y, -2.0 * y]
    model = TransferFunctionRegressor(
        speed_column=2, order=2, n_grid=5, max_iter=10
    ).fit(X, Y)
    assert model.time_constants_.shape == (2, 3, 2)
    assert model.lag_coef_.shape == (2, 3, 2)
    assert model.coef_.shape == (2, 3)
    pred = model.predict(X)
    assert pred.shape == Y.shape
    assert np.sqrt(np.mean((pred - Y) ** 2)) < 0.05 * Y.std()


def test_speed_column_errors():
    X, y = _heating_runs()
    with pytest.raises(ValueError, match="'rpm' is not a column of X"):
        TransferFunctionRegressor(speed_column="rpm").fit(X, y)
    with pytest.raises(ValueError, match="X has no column names"):
        TransferFunctionRegressor(speed_column="spindle_rpm").fit(X.to_numpy(), y)
    with pytest.raises(ValueError, match="speed_column 5 is out of range"):
        TransferFunctionRegressor(speed_column=5).fit(X.to_numpy(), y)


def test_a_period_that_changes_is_no_hole():
    # A logger switching from 10 s to 5 s was told that rows were missing.
    X, y = _heating_runs()
    run = X.loc[["r0"]]
    t = run.index.get_level_values("time_s").to_numpy().copy()
    t[300:] = t[300] + (t[300:] - t[300]) / 2.0
    run.index = pd.MultiIndex.from_arrays(
        [run.index.get_level_values("run"), t], names=["run", "time_s"]
    )
    with pytest.raises(ValueError, match="constant sampling") as err:
        TransferFunctionRegressor(speed_column=2, max_iter=0).fit(run, y.loc[["r0"]])
    assert "Rows are missing" not in str(err.value)
    # dt= was the remedy named: it takes every step as dt, a period that
    # changes too, without a word.
    assert str(err.value).endswith(
        "resample the run onto a regular time grid (dt=... takes every step as "
        "dt, gaps and changes of the period too)"
    )
    period = float(np.median(np.diff(t[:300])))
    with pytest.warns(
        UserWarning,
        match=rf"dt={period:g} is given, but the time_s steps of run 'r0' range "
        rf"from {period / 2:g} to {period:g} s \(\d+ step\(s\) more than 10% off",
    ):
        TransferFunctionRegressor(speed_column=2, max_iter=0, dt=period).fit(
            run, y.loc[["r0"]]
        )


def test_a_jittering_logger_clock_is_accepted():
    # Timestamps jittering by 3% of the period were refused (1% tolerated).
    X, y = _heating_runs()
    t = X.index.get_level_values("time_s").to_numpy()
    period = float(np.median(np.diff(t[t < t[1] * 10])))
    jitter = np.random.default_rng(0).uniform(-0.015, 0.015, t.size) * period
    X.index = pd.MultiIndex.from_arrays(
        [X.index.get_level_values("run"), t + jitter], names=["run", "time_s"]
    )
    model = TransferFunctionRegressor(speed_column=2, max_iter=0).fit(X, y)
    assert model.score(X, y) > 0.9
    # Beyond 5%, the error names dt as the remedy for clock jitter.
    wide = np.random.default_rng(1).uniform(-0.04, 0.04, t.size) * period
    X.index = pd.MultiIndex.from_arrays(
        [X.index.get_level_values("run"), t + wide], names=["run", "time_s"]
    )
    with pytest.raises(
        ValueError, match=rf"clock jitter of up to \d+%: pass dt={period:g}"
    ):
        TransferFunctionRegressor(speed_column=2, max_iter=0).fit(X, y)


def test_irregular_sampling_names_the_run():
    X, y = _heating_runs()
    t = X.index.get_level_values("time_s").to_numpy().copy()
    t[800:] *= 1.5
    X.index = pd.MultiIndex.from_arrays(
        [X.index.get_level_values("run"), t], names=["run", "time_s"]
    )
    with pytest.raises(ValueError, match="constant sampling.*run 'r1'") as err:
        TransferFunctionRegressor(speed_column=2, max_iter=0).fit(X, y)
    assert str(err.value).endswith("gaps and changes of the period too)")


def test_a_controller_logging_every_second_is_no_unit_slip():
    # Trained on a 60 s log and given a controller's 1 s rows (60 times
    # faster), the model asked "is time_s in minutes or hours?".
    X, y = _heating_runs()
    slow = X.set_axis(
        pd.MultiIndex.from_arrays(
            [X.index.get_level_values(0), X.index.get_level_values(1) * 6.0],
            names=["run", "time_s"],
        )
    )
    model = TransferFunctionRegressor(speed_column=2, max_iter=0).fit(slow, y)
    new = X.loc[["r1"]]
    t = np.arange(len(new), dtype=float)

    def _index(times):
        return pd.MultiIndex.from_arrays(
            [["c"] * times.size, times], names=["run", "time_s"]
        )

    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        model.predict(new.set_axis(_index(t)))
    assert not any("minutes or hours" in str(w.message) for w in record)
    with pytest.warns(UserWarning, match=r"minutes or hours\?"):
        model.predict(new.set_axis(_index(t / 2)))


def test_training_runs_too_short_for_a_thermal_model_warn():
    # Fitted on runs of 3-10 samples (a few minutes), the model predicted up
    # to 140 mm on a whole run, without a word.
    from skthermal.grey import GreyPSORegressor

    X, y = _heating_runs()
    first = X.groupby(level="run").cumcount().to_numpy() < 10  # 90 s per run
    for model in (
        TransferFunctionRegressor(speed_column=2, max_iter=0),
        GreyPSORegressor(alpha=0.0),
    ):
        with pytest.warns(
            UserWarning, match=r"the longest run \('r\d'\) lasts 90 s of time_s"
        ):
            model.fit(X[first], y[first])
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        TransferFunctionRegressor(speed_column=2, max_iter=0).fit(X, y)


def test_bad_tau_bounds():
    X, y = _heating_runs()
    with pytest.raises(ValueError, match="tau_bounds"):
        TransferFunctionRegressor(tau_bounds=(10.0, 1.0)).fit(X, y)


def test_warns_when_run_labels_are_dropped():
    X, y = _heating_runs()
    runs = X.index.get_level_values("run")
    model = TransferFunctionRegressor(speed_column=2, dt=10.0, max_iter=0)
    model.fit(X.to_numpy(), y, groups=runs)
    with pytest.warns(UserWarning, match="labelled run"):
        model.predict(X.to_numpy())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(X.to_numpy(), groups=runs)


def test_the_fitted_sampling_period_serves_rows_without_times():
    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm").fit(X, y)
    assert model.sample_period_s_ == 10.0
    whole = model.predict(X)
    # The same rows without their times, or a new run's first row alone,
    # are predicted with the fitted period, not one second per row.
    bare = X.reset_index(level="time_s", drop=True)
    np.testing.assert_allclose(model.predict(bare), whole)
    new = X.loc[["r1"]].rename(index={"r1": "new"})
    first = model.predict(new.iloc[:1])
    np.testing.assert_allclose(first, model.predict(new)[:1])
    np.testing.assert_allclose(first, whole[720:721])
    with pytest.warns(UserWarning, match="no time_s.*counted in rows"):
        TransferFunctionRegressor().fit(X.to_numpy(), y.to_numpy())


def test_a_training_run_continued_after_a_hole():
    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm").fit(
        X.iloc[:300], y.iloc[:300]
    )
    whole = model.predict(X.loc[["r0"]])
    # Rows 300-399 missing: the lags decay over the 1000 s in between (the
    # pause named, as a gap within a run).
    with pytest.warns(UserWarning, match=r"run 'r0' continues 1010 s after"):
        tail = model.predict(X.loc[["r0"]].iloc[400:])
    assert np.abs(tail - whole[400:]).max() < 0.02 * np.ptp(whole)


def test_a_continued_run_beside_a_new_one():
    # One call with a training run's later rows and a new run from its
    # start used to fail inside numpy (the filters' start states, an array
    # for the continued run and None for the new one).
    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm").fit(
        X.iloc[:300], y.iloc[:300]
    )
    tail = X.loc[["r0"]].iloc[300:]
    new = X.loc[["r1"]]
    both = model.predict(pd.concat([tail, new]))
    np.testing.assert_allclose(
        both, np.r_[model.predict(tail), model.predict(new)], rtol=0, atol=1e-12
    )


def test_a_gap_inside_predicted_rows_is_bridged_as_a_pause_is():
    # A pause between fit and predict was bridged (with a warning) while the
    # same hole inside the predicted rows was an error; both are bridged now.
    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm").fit(X, y)
    run = X.loc[["r0"]]
    whole = model.predict(run)
    holed = run.iloc[np.r_[0:300, 400 : len(run)]]
    with pytest.warns(UserWarning, match=r"1 gap\(s\) in time_s.*lasts 1010 s"):
        pred = model.predict(holed)
    np.testing.assert_allclose(pred[:300], whole[:300], rtol=0, atol=1e-12)
    assert np.abs(pred[300:] - whole[400:]).max() < 0.02 * np.ptp(whole)
    # Fit names the hole as rows missing from the middle of the run (a block
    # held out by a splitter over rows), not as jittered sampling.
    with pytest.raises(
        ValueError,
        match=r"constant sampling.*run 'r0'.*1 gap\(s\) in a run otherwise sampled "
        r"every 10 s, the first from time_s=2990 to 4000\. Rows are missing.*KFold",
    ):
        TransferFunctionRegressor(speed_column=2, max_iter=0).fit(
            holed, y.loc[["r0"]].iloc[np.r_[0:300, 400 : len(run)]]
        )


@pytest.mark.parametrize(
    "tau_bounds, message",
    [
        ((1.0, np.inf), r"'tau_bounds'.*Got inf at position 1"),
        ((np.nan, 10.0), r"'tau_bounds'.*Got nan at position 0"),
        (("1", "10"), r"'tau_bounds'.*Got '1' at position 0"),
        ((-1.0, 10.0), r"'tau_bounds'.*Got -1.0 at position 0"),
        ((1.0, 10.0, 100.0), r"'tau_bounds'.*2 finite numbers > 0.*Got 3 entries"),
        ([[1.0, 10.0]], r"'tau_bounds'.*flat sequence"),
        ((10.0, 10.0), r"'tau_bounds'.*low < high"),
    ],
)
def test_tau_bounds_are_checked_before_fitting(tau_bounds, message):
    X, y = _heating_runs()
    with pytest.raises(ValueError, match=message):
        TransferFunctionRegressor(tau_bounds=tau_bounds).fit(X, y)


def test_one_row_runs_do_not_pull_the_fitted_sampling_period():
    # Two runs sampled every 10 s and two runs of one row: the period is
    # 10 s (it was the median of 10, 10, 1 and 1 s: 5.5 s), and the one-row
    # runs are filtered over 10 s, so the time constants are found as
    # without them (they were 300.6, 1188.8 and 497.3 s).
    X, y = _heating_runs()
    first = X.index.get_level_values("time_s") == 0
    ones = X[first].rename(index={"r0": "o0", "r1": "o1"}, level="run")
    data = pd.concat([X, ones])
    target = pd.concat([y, y[first]]).to_numpy()
    model = TransferFunctionRegressor(speed_column=2).fit(data, target)
    assert model.sample_period_s_ == 10.0
    np.testing.assert_allclose(model.time_constants_[:, 0], [300, 1200, 500], rtol=1e-3)
    with pytest.raises(ValueError, match=r"no run has two rows.*dt="):
        TransferFunctionRegressor().fit(ones, y[first])


def _two_lag_runs(taus, noise=0.01):
    """Three runs of a spindle heating the structure through two lags in
    series (time constants ``taus``, s), 10 s sampling, with noise."""
    rng = np.random.default_rng(0)
    frames = []
    for run, (on, n) in enumerate([(1800, 720), (2400, 600), (1200, 500)]):
        t = np.arange(n) * 10.0
        speed = np.where(t < on, 4000.0, 0.0)
        z = speed[:, None] / 1000.0
        for tau in taus:
            z = first_order_lags(z, np.array([tau]), np.array([10.0]), [slice(0, n)])
        err = 3.0 * z[:, 0] + noise * rng.normal(size=n)
        frames.append(
            pd.DataFrame(
                {"run": f"r{run}", "time_s": t, "spindle_rpm": speed, "e": err}
            )
        )
    df = pd.concat(frames).set_index(["run", "time_s"])
    return df[["spindle_rpm"]], df["e"]


@pytest.mark.parametrize("taus", [(100.0, 3000.0), (600.0, 600.0)])
def test_second_order_keeps_its_two_time_constants_apart(taus):
    # Merged time constants with huge gains of opposite signs (the
    # difference of two nearly equal lags, a derivative) was the optimum
    # found: at (100, 3000) s, 5804 and 5812 s with gains +-2.2 (rpm^-1),
    # barely better than order 1; at (600, 600) s, gains +-38.
    X, y = _two_lag_runs(taus)
    rmse = []
    for order in (1, 2):
        model = TransferFunctionRegressor(speed_column=0, order=order).fit(X, y)
        rmse.append(np.sqrt(np.mean((model.predict(X) - y.to_numpy()) ** 2)))
    low, high = model.time_constants_[0]
    assert high >= 2.0 * low * (1 - 1e-9)
    # Gains of the size of the steady-state gain, 3 per 1000 rpm.
    assert np.abs(model.lag_coef_).max() < 0.01
    assert rmse[1] <= rmse[0]
    if taus[0] != taus[1]:  # two distinct lags: found, to the noise
        assert rmse[1] < 0.011
        np.testing.assert_allclose(model.time_constants_[0], taus, rtol=0.02)
    else:  # a repeated lag, matched closely by a pair twice apart
        assert rmse[1] < 0.1 * rmse[0]


def test_second_order_needs_room_for_two_time_constants():
    X, y = _heating_runs()
    with pytest.raises(ValueError, match=r"order=2.*factor 2 apart.*tau_bounds"):
        TransferFunctionRegressor(order=2, tau_bounds=(100.0, 150.0)).fit(X, y)


def _dependent_lags():
    """Five inputs of four lags each, nearly dependent rows as many sensors
    give (without penalty their Gram matrix has a condition of 4e8), in
    two runs: the inputs, lags, time constants and a target."""
    rng = np.random.default_rng(0)
    slices = [slice(0, 150), slice(150, 300)]
    dt = np.array([10.0, 10.0])
    U = np.repeat(np.cumsum(rng.normal(size=(300, 5)), axis=0), 4, axis=1)
    taus = np.tile(np.geomspace(30.0, 3000.0, 4), 5) * rng.uniform(0.8, 1.2, 20)
    Phi = first_order_lags(U, taus, dt, slices)
    y = Phi @ rng.normal(size=20) + 0.01 * rng.normal(size=300)
    return U, taus, dt, slices, Phi, y


@pytest.mark.parametrize("alpha", [0.0, 0.5])
def test_column_changes_match_a_direct_solve(alpha):
    # The Jacobian's ridge with one or two lags replaced, from one
    # factorisation of the whole design, against a solve from scratch. On
    # the nearly dependent lags without penalty, the reference is an
    # orthogonal factorisation of each design (the direct Cholesky solve
    # is itself off by 5e-5 there).
    U, taus, dt, slices, Phi, y = _dependent_lags()
    A = Phi.T.copy()
    _standardise(A)
    yc = y - y.mean()
    gram, w, r0 = _ridge_residual(A, yc, alpha)

    def orthogonal(A):
        Q = np.linalg.qr(A.T)[0]
        return yc - Q @ (Q.T @ yc)

    groups = [np.array([0]), np.array([9]), np.array([18, 19]), np.array([], int)]
    h = 1e-3
    new = first_order_lags(
        U[:, [0, 9, 18, 19]], taus[[0, 9, 18, 19]] * np.exp(h), dt, slices
    ).T.copy()
    _standardise(new)
    changes = (
        np.hstack(_ridge_column_changes(A, yc, alpha, gram, groups, new.copy())) / h
    )
    np.testing.assert_array_equal(changes[3], 0.0)
    start = 0
    for cols, fast in zip(groups[:3], changes, strict=False):
        trial = A.copy()
        trial[cols] = new[start : start + cols.size]
        start += cols.size
        if alpha > 0:
            ref = (_ridge_residual(trial, yc, alpha)[2] - r0) / h
        else:
            ref = (orthogonal(trial) - orthogonal(A)) / h
            np.testing.assert_array_equal(fast[y.size :], 0.0)
            fast = fast[: y.size]
        np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    if alpha > 0:
        # The direct solves (for singular designs) agree where both apply.
        direct = np.hstack(_direct_changes(A, yc, alpha, gram, w, groups, new)) / h
        np.testing.assert_allclose(
            direct, changes, rtol=0, atol=1e-6 * np.abs(changes).max()
        )
    else:
        # A singular design (a sensor that never changes, no penalty), or a
        # singular replacement: solved directly.
        still = np.vstack([A, np.zeros(300)])
        assert (
            _ridge_column_changes(
                still, yc, 0.0, still @ still.T, groups[:1], new[:1].copy()
            )
            is None
        )
        again = _ridge_column_changes(A, yc, 0.0, gram, [np.array([1])], A[[0]])
        assert all(np.isnan(part).all() for part in again)
        # A replacement that changes nothing changes the direct solve by
        # exactly nothing (the refinement then sees a Jacobian of exact
        # rank, as refitting from scratch gave it).
        gram, w, _ = _ridge_residual(still, yc, 0.0)
        direct = _direct_changes(still, yc, 0.0, gram, w, [np.array([20])], still[[20]])
        assert all(np.all(part == 0.0) for part in direct)


@pytest.mark.parametrize("alpha", [0.0, 0.5])
@pytest.mark.parametrize("condition", ["dependent", "degenerate"])
def test_orthonormal_basis(alpha, condition):
    # Cholesky QR twice, or (a design too ill-conditioned for it)
    # Householder QR: an orthonormal Q and Q R the design, to rounding.
    Phi = _dependent_lags()[4]
    A = Phi.T.copy()
    _standardise(A)
    if condition == "degenerate":  # a condition number of some 1e10
        A[1] = A[0] + 1e-10 * A[1]
    gram = A @ A.T + alpha * np.eye(20)
    Qn, Qp, R = _orthonormal_basis(A, alpha, gram)
    Q = np.hstack([Qn, Qp])
    np.testing.assert_allclose(Q @ Q.T, np.eye(20), rtol=0, atol=1e-13)
    design = np.hstack([A, np.sqrt(alpha) * np.eye(20)])
    np.testing.assert_allclose(R.T @ Q, design, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(R, np.triu(R))


def test_triangular_factor():
    # R'R is the Gram matrix of the rows, from a Cholesky factorisation, or
    # (a row of zeros: singular) a blocked QR factorisation.
    rng = np.random.default_rng(1)
    Kn, Kp = rng.normal(size=(6, 5000)), rng.normal(size=(6, 4))
    for zero in (False, True):
        if zero:
            Kn[3], Kp[3] = 0.0, 0.0
        R = _triangular_factor(Kn, Kp)
        np.testing.assert_allclose(
            R.T @ R, Kn @ Kn.T + Kp @ Kp.T, rtol=0, atol=1e-9 * 5000
        )
        np.testing.assert_array_equal(R, np.triu(R))
        assert np.all(np.diag(R) >= 0)
    # The first row alone on the first axis: the residual's coordinates.
    np.testing.assert_allclose(R[0, 0], np.sqrt(Kn[0] @ Kn[0] + Kp[0] @ Kp[0]))


def test_fit_lags_and_grid_moments_match_the_filter(monkeypatch):
    # The lags of the refinement, one row each, are those of
    # first_order_lags; the grid search's Gram matrix, formed a block of
    # rows at a time (here blocks smaller than a run, and spanning runs),
    # is that of all the lags at once.
    rng = np.random.default_rng(2)
    slices = [slice(0, 130), slice(130, 131), slice(131, 300)]
    dts = np.array([10.0, 10.0, 4.0])
    U = np.cumsum(rng.normal(size=(300, 3)), axis=0)
    Y = rng.normal(size=(300, 2))
    taus = np.array([30.0, 300.0, 50.0, 400.0, 20.0, 900.0])
    Z = _fit_lags(np.ascontiguousarray(U.T), taus, np.arange(6) // 2, dts, slices)
    ref = first_order_lags(np.repeat(U, 2, axis=1), taus, dts, slices)
    np.testing.assert_array_equal(Z.T, ref)
    grid = np.geomspace(5.0, 3000.0, 4)
    monkeypatch.setattr("skthermal.linear_model._transfer._GRID_BLOCK", 12 * 50)
    gram, cross = _grid_moments(np.ascontiguousarray(U.T), Y, dts, slices, grid)
    lags = np.stack(
        [exponential_filter(U, t, dts, slices, initial="rest") for t in grid], axis=2
    ).reshape(300, 12)
    lags -= lags.mean(axis=0)
    np.testing.assert_allclose(gram, lags.T @ lags, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(
        cross, lags.T @ (Y - Y.mean(axis=0)), rtol=1e-12, atol=1e-9
    )


@pytest.mark.parametrize("order", [1, 2])
def test_fit_matches_the_direct_jacobian(order, monkeypatch):
    # The Jacobian from one factorisation per evaluation gives the fit of
    # the Jacobian that re-solves the ridge for every time constant.
    X, y = _heating_runs()
    params = {
        "speed_column": 2,
        "order": order,
        "n_grid": 5,
        "max_iter": 10,
        "alpha": 0.0,
    }
    fast = TransferFunctionRegressor(**params).fit(X, y)
    monkeypatch.setattr(
        "skthermal.linear_model._transfer._ridge_column_changes",
        lambda *args: None,
    )
    slow = TransferFunctionRegressor(**params).fit(X, y)
    np.testing.assert_allclose(fast.predict(X), slow.predict(X), rtol=0, atol=1e-8)
    # Steady-state gains (a lag of negligible gain may move its time
    # constant a little with order=2).
    np.testing.assert_allclose(fast.coef_, slow.coef_, rtol=1e-6)


@pytest.mark.parametrize("kind", ["transfer", "lags"])
def test_a_run_logged_in_milliseconds_warns(kind):
    # time_s in milliseconds reads as a thousand times slower sampling; the
    # filters then ran a thousand times too fast, silently (an independent
    # check: RMSE 0.53 -> 29.5 µm). A faster run is fine.
    from skthermal.preprocessing import make_lag_pipeline

    X, y = _heating_runs()
    model = (
        TransferFunctionRegressor(speed_column="spindle_rpm")
        if kind == "transfer"
        else make_lag_pipeline()
    )
    model.fit(X, y)
    new = X.loc[["r1"]]

    def scaled(factor):
        """``new`` with its times multiplied by ``factor``."""
        return new.set_axis(
            pd.MultiIndex.from_arrays(
                [new.index.get_level_values(0), new.index.get_level_values(1) * factor],
                names=["run", "time_s"],
            )
        )

    ms = scaled(1000.0)
    with pytest.warns(
        UserWarning,
        match=r"run 'r1' is sampled every 10000 s, the "
        r"training runs every 10 s .*not milliseconds",
    ):
        model.predict(ms)
    fast = scaled(0.1)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        model.predict(fast)  # ten times faster: a faster logger, no warning
    assert not any("sampled every" in str(w.message) for w in record)
    # Minutes under time_s (60 times faster) went through silently: 11 µm off
    # on an independent check's run, 25 µm in hours.
    minutes = scaled(1 / 60.0)
    with pytest.warns(
        UserWarning,
        match=r"run 'r1' is sampled every 0.1\d* s, the training runs every 10 s "
        r"\(60 times faster\).*minutes or hours\?",
    ):
        model.predict(minutes)


def test_a_centred_speed_warns():
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    X, y = _duty_runs(n_runs=2, hours=2.0, dt=60.0)
    model = make_pipeline(
        StandardScaler(), TransferFunctionRegressor(speed_column="spindle_rpm")
    ).set_output(transform="pandas")
    with pytest.warns(UserWarning, match=r"driver 'spindle_rpm' has a mean of 0"):
        model.fit(X, y)


def _one_run(X, y, run):
    """The rows of run ``run`` relabelled as a new run, predicted from rest."""
    part = X.loc[[run]]
    index = pd.MultiIndex.from_arrays(
        [np.repeat("new", len(part)), part.index.get_level_values("time_s")],
        names=["run", "time_s"],
    )
    return part.set_axis(index), np.asarray(y.loc[[run]])


@pytest.mark.parametrize("runs", ["two", "one"])
def test_auto_alpha_is_the_time_ordered_cross_validation(runs):
    # alpha="auto" scores every candidate on the folds of LagRidgeCV's
    # cv="auto" (whole runs left out; on one run, expanding windows), each
    # validation stretch predicted from its run's start by a model
    # identified on the fold's training rows, and keeps the least error.
    from skthermal.utils._folds import forward_folds

    X, y = _heating_runs()
    if runs == "one":
        X, y = X.loc[["r0"]], y.loc[["r0"]]
    params = {"speed_column": 2, "n_grid": 5, "max_iter": 5, "tau_bounds": (5, 7200)}
    alphas = [0.0, 1.0, 100.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model = TransferFunctionRegressor(alphas=alphas, **params).fit(X, y)
        sse = np.zeros(len(alphas))
        if runs == "two":
            for out in ("r0", "r1"):
                keep = "r1" if out == "r0" else "r0"
                Xv, yv = _one_run(X, y, out)
                for i, a in enumerate(alphas):
                    fold = TransferFunctionRegressor(alpha=a, **params)
                    fold.fit(X.loc[[keep]], y.loc[[keep]])
                    sse[i] += np.sum((fold.predict(Xv) - yv) ** 2)
            n_scored = len(y)
        else:
            Xv, yv = _one_run(X, y, "r0")
            folds = forward_folds(len(y), 4, 0.4)
            for tr, va in folds:
                for i, a in enumerate(alphas):
                    fold = TransferFunctionRegressor(alpha=a, **params)
                    fold.fit(X.iloc[tr], y.iloc[tr])
                    pred = fold.predict(Xv.iloc[: va[-1] + 1])[va]
                    sse[i] += np.sum((pred - yv[va]) ** 2)
            n_scored = sum(va.size for _, va in folds)
    np.testing.assert_allclose(model.cv_results_["alpha"], alphas)
    np.testing.assert_allclose(
        model.cv_results_["rmse"], np.sqrt(sse / n_scored), rtol=1e-7
    )
    assert model.alpha_ == alphas[int(np.argmin(sse))]
    refit = TransferFunctionRegressor(alpha=model.alpha_, **params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        refit.fit(X, y)
    np.testing.assert_allclose(model.predict(X), refit.predict(X), rtol=1e-12)


def test_auto_alpha_per_output_and_its_checks():
    X, y = _heating_runs()
    Y = np.c_[y, -3.0 * y + 0.1 * np.sin(np.arange(len(y)))]
    model = TransferFunctionRegressor(speed_column=2, n_grid=5, max_iter=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model.fit(X, Y)
    assert model.alpha_.shape == (2,)
    assert model.cv_results_["rmse"].shape == (7, 2)
    np.testing.assert_array_equal(
        model.alpha_,
        model.cv_results_["alpha"][np.argmin(model.cv_results_["rmse"], axis=0)],
    )
    fixed = TransferFunctionRegressor(speed_column=2, alpha=2.5).fit(X, y)
    assert fixed.alpha_ == 2.5 and not hasattr(fixed, "cv_results_")
    # Refitted with a given alpha, no choice of the earlier fit stays.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model.set_params(alpha=2.5).fit(X, Y)
    assert not hasattr(model, "cv_results_")
    with pytest.raises(ValueError, match=r"'alphas' parameter .* >= 0.*-1"):
        TransferFunctionRegressor(speed_column=2, alphas=[1.0, -1.0]).fit(X, y)
    with pytest.warns(UserWarning, match="no cross-validation fold.*first candidate"):
        few = TransferFunctionRegressor(dt=1.0, n_grid=3)
        few.fit(np.ones((2, 1)), [0.0, 1.0])
    assert np.isnan(few.cv_results_["rmse"]).all()  # nothing validated, not 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        # cv_results_ shaped as alpha_, for a one-column y too.
        column = TransferFunctionRegressor(speed_column=2, n_grid=5, max_iter=3)
        column.fit(X, y.to_frame())
        assert column.alpha_.shape == (1,)
        assert column.cv_results_["rmse"].shape == (7, 1)
        # Tied candidates (a constant output): the largest penalty.
        flat = TransferFunctionRegressor(speed_column=2, n_grid=5, max_iter=3)
        assert flat.fit(X, np.zeros(len(y))).alpha_ == 1e4


def test_auto_alpha_keeps_collinear_lags_from_extrapolating(shared_data):
    # On the real FL_THERMAL record (16 collinear temperatures, one 46 h
    # run, chronological 60/40 split), the least-squares gains cancel one
    # another and extrapolate worse than linear regression; the penalty the
    # cross-validation chooses on the training part does not.
    from sklearn.linear_model import LinearRegression

    from skthermal.datasets import load_fl_thermal

    fl_thermal = load_fl_thermal(shared_data)
    temps = [f"T{i}_C" for i in range(1, 17)]
    X = fl_thermal.set_index(["run", "time_s"])[[*temps, "spindle_rpm"]]
    y = fl_thermal["disp_ch1_um"].to_numpy()
    k = int(round(0.6 * len(y)))

    def held_out(model):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            pred = model.fit(X.iloc[:k], y[:k]).predict(X)
        return np.sqrt(np.mean((pred[k:] - y[k:]) ** 2))

    linear = LinearRegression().fit(X[temps].iloc[:k], y[:k])
    r_linear = np.sqrt(np.mean((linear.predict(X[temps].iloc[k:]) - y[k:]) ** 2))
    least_squares = held_out(
        TransferFunctionRegressor(speed_column="spindle_rpm", alpha=0.0)
    )
    auto = held_out(TransferFunctionRegressor(speed_column="spindle_rpm"))
    assert least_squares > r_linear
    assert auto < 0.5 * r_linear


def test_runs_starting_at_different_targets_warn():
    # The model starts every run at rest, the same prediction at every
    # run's first row: a target whose runs start far apart (warm starts, a
    # probe zeroed anew) is taken up by the gains (an independent check:
    # 37-61 µm held out against 3-6 fitted on the changes), silently.
    X, y = _heating_runs()
    offsets = np.where(X.index.get_level_values("run") == "r1", 12.0, 0.0)
    with pytest.warns(
        UserWarning,
        match=r"y \('disp_z_um'\) starts run 'r0' \(and 1 more run alike\) at "
        r"1\.738, the runs' median first value being 7\.738: 6 off, against "
        r"changes of 17 within the runs and a noise of 0\.00091",
    ):
        TransferFunctionRegressor(speed_column=2, alpha=0.0).fit(X, y + offsets)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        TransferFunctionRegressor(speed_column=2, alpha=0.0).fit(X, y)
        # On the changes since each run's start, nothing to say.
        shifted = y + offsets
        first = shifted.groupby(level="run").transform("first")
        TransferFunctionRegressor(speed_column=2, alpha=0.0).fit(X, shifted - first)


def test_start_offsets_beyond_noise_in_one_run_warn_and_noise_alone_does_not():
    # An independent check: first rows that differ by the probe's noise
    # alone were warned about (fitted on changes as advised, that noise
    # became an offset of every row: 4 times the error), and one run zeroed
    # 10 µm off among six was not (the spread pooled over the runs).
    from skthermal.utils._runs import run_slices, warn_start_offsets

    rng = np.random.default_rng(0)
    n, runs = 200, 8
    drift = np.tile(np.linspace(0.0, 1.2, n), runs)
    y = drift + 0.5 * rng.normal(size=n * runs)
    groups = np.repeat([f"R{r}" for r in range(runs)], n)
    slices, labels = run_slices(groups)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_start_offsets("Model", y, slices, ["disp_x_um"], labels)
    y[groups == "R2"] += 10.0
    with pytest.warns(
        UserWarning, match=r"y \('disp_x_um'\) starts run 'R2' at 9\.\d+, the runs'"
    ):
        warn_start_offsets("Model", y, slices, ["disp_x_um"], labels)


def test_a_short_run_beside_long_ones_does_not_decide_the_penalty():
    # Leaving the long run out trained a fold on the short run alone; its
    # error on the long run decided the choice (the largest penalty, an
    # error of 12.5 where least squares erred by 0.0). Such a fold keeps
    # fewer than first_fraction of the rows and is skipped.
    from skthermal.utils._folds import run_folds

    X, y = _heating_runs()
    keep = np.r_[np.arange(720), 720 + np.arange(2)]
    slices = [slice(0, 720), slice(720, 722)]
    folds = run_folds("auto", slices, ["r0", "r1"], 722, 4, 0.4, "Model")
    assert [tr.size for tr, _ in folds] == [720]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model = TransferFunctionRegressor(speed_column=2).fit(
            X.iloc[keep], y.iloc[keep]
        )
    assert model.alpha_ == 0.0
    new = X.loc[["r1"]].rename(index={"r1": "other"}, level="run")
    error = model.predict(new) - y.loc[["r1"]].to_numpy()
    assert np.sqrt(np.mean(error**2)) < 0.01


def test_start_offsets_of_one_quantum_on_quantised_readings_do_not_warn():
    # An independent check: on a probe read to 1 µm with a noise of 0.2 µm,
    # most steps between rows are exactly zero, the noise taken from them
    # read 0, and first rows one quantum apart were warned about.
    from skthermal.utils._runs import run_slices, warn_start_offsets

    rng = np.random.default_rng(0)
    n, runs = 300, 6
    drift = np.tile(np.linspace(0.0, 1.5, n), runs)
    y = np.round(drift + 0.2 * rng.normal(size=n * runs) + 0.45)
    groups = np.repeat([f"R{r}" for r in range(runs)], n)
    slices, labels = run_slices(groups)
    first = y[[sl.start for sl in slices]]
    assert np.ptp(first) == 1.0  # one quantum apart
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_start_offsets("Model", y, slices, ["disp_x_um"], labels)
    y[groups == "R3"] += 10.0  # a run zeroed 10 quanta off still warns
    with pytest.warns(UserWarning, match=r"starts run 'R3' at 1\d\.?\d*, the runs'"):
        warn_start_offsets("Model", y, slices, ["disp_x_um"], labels)


def test_coef_has_one_weight_per_feature_for_feature_selection():
    # coef_ was (n_inputs, order): RFE dropped features by position, not
    # weight (the same ranking with the columns reversed), and
    # SelectFromModel raised an IndexError from numpy.
    from sklearn.feature_selection import SelectFromModel

    X, y = _heating_runs()
    model = TransferFunctionRegressor(speed_column="spindle_rpm", order=2).fit(X, y)
    assert model.coef_.shape == (X.shape[1],)
    np.testing.assert_allclose(model.coef_, model.lag_coef_.sum(axis=1))
    select = SelectFromModel(
        TransferFunctionRegressor(speed_column="spindle_rpm", alpha=0.0),
        threshold=-np.inf,
        max_features=2,
    ).fit(X, y)
    assert select.get_support().shape == (X.shape[1],)
    # The largest steady-state gains: T1 (2.0 per K) and T2 (-0.5 per K).
    assert list(select.get_feature_names_out()) == list(X.columns[:2])
