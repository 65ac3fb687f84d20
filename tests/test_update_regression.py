"""Ridge and update regression, adaptive compensation, the batch campaign and
the three-level RMSE."""

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.utils._param_validation import InvalidParameterError

from skthermal.datasets import changes_since_start
from skthermal.linear_model import (
    UpdateRegressor,
    adaptive_compensation,
    first_stable_update,
    make_batch_campaign,
    ridge_coef,
    update_coef,
    update_is_stable,
    update_path,
)
from skthermal.metrics._levels import cross_batch_rmse, rmse_levels
from skthermal.selection._stable import StableTSPSelector


@pytest.fixture
def data(rng):
    X = rng.uniform(0, 5, size=(40, 3))
    y = 1.5 + X @ [4.0, -2.0, 0.5] + rng.normal(0, 0.1, 40)
    return X, y


# --- array functions -------------------------------------------------------


def test_ridge_coef_hand_and_sklearn(data):
    X, y = data
    A = np.c_[np.ones(len(X)), X]
    hand = np.linalg.solve(A.T @ A + 25 * np.eye(4), A.T @ y)
    np.testing.assert_allclose(ridge_coef(X, y), hand)
    # Penalised intercept = sklearn's Ridge on [1, X] without its own intercept.
    sk = Ridge(alpha=25.0, fit_intercept=False).fit(A, y).coef_
    np.testing.assert_allclose(ridge_coef(X, y), sk, rtol=1e-8)
    # Free intercept = the usual ridge.
    free = ridge_coef(X, y, alpha=25.0, penalize_intercept=False)
    sk = Ridge(alpha=25.0).fit(X, y)
    np.testing.assert_allclose(free, np.r_[sk.intercept_, sk.coef_], rtol=1e-8)
    ols = LinearRegression().fit(X, y)
    np.testing.assert_allclose(
        ridge_coef(X, y, alpha=0.0), np.r_[ols.intercept_, ols.coef_], rtol=1e-8
    )


def test_update_coef_is_the_minimiser(data, rng):
    X, y = data
    X, y = X[:6], y[:6]
    old = rng.normal(size=4)
    eta = 0.1
    beta = update_coef(X, y, old, eta=eta)
    A = np.c_[np.ones(6), X]
    hand = np.linalg.solve(
        eta * A.T @ A + (1 - eta) * np.eye(4), eta * A.T @ y + (1 - eta) * old
    )
    np.testing.assert_allclose(beta, hand)
    # Gradient of eta ||E - A b||^2 + (1 - eta) ||b - b_old||^2 vanishes.
    grad = -2 * eta * A.T @ (y - A @ beta) + 2 * (1 - eta) * (beta - old)
    np.testing.assert_allclose(grad, 0, atol=1e-9)
    # beta_old = 0: ridge with p = (1 - eta) / eta (004 §3.2).
    np.testing.assert_allclose(
        update_coef(X, y, np.zeros(4), eta=0.2), ridge_coef(X, y, alpha=0.8 / 0.2)
    )
    # A free intercept is not pulled towards the old one.
    free = update_coef(X, y, old, eta=eta, penalize_intercept=False)
    d = np.r_[0.0, np.full(3, 1 - eta)]
    hand = np.linalg.solve(eta * A.T @ A + np.diag(d), eta * A.T @ y + d * old)
    np.testing.assert_allclose(free, hand)


def test_update_path_matches_loop(data, rng):
    X, y = data
    Y = np.c_[y, 2 * y]
    old = rng.normal(size=(4, 2))
    path = update_path(X[:8], Y[:8], old)
    assert path.shape == (8, 4, 2)
    for n in range(1, 9):
        np.testing.assert_allclose(path[n - 1], update_coef(X[:n], Y[:n], old))


def test_update_is_stable_by_hand():
    assert update_is_stable([[10.0, 5.0], [10.9, 5.4], [10.2, 5.1]])
    assert not update_is_stable([[10.0, 5.0], [11.2, 5.4], [10.2, 5.1]])
    # Intercept near zero needs atol.
    coefs = [[0.01, 5.0], [0.03, 5.1], [0.02, 5.05]]
    assert not update_is_stable(coefs)
    assert update_is_stable(coefs, atol=0.05)
    with pytest.raises(ValueError, match="at least two"):
        update_is_stable([[1.0, 2.0]])
    with pytest.raises(ValueError, match="NaN"):
        update_is_stable([[1.0, np.nan], [1.0, 2.0]])
    path = np.array([[0, 1], [1, 2], [1.9, 4], [2, 4.1], [2.05, 4.2]], dtype=float)
    assert first_stable_update(path) == 3
    assert first_stable_update(path[:4]) is None
    assert first_stable_update(path[:2]) is None


# --- the estimator ---------------------------------------------------------


def test_regressor_fit_partial_fit(data):
    X, y = data
    model = UpdateRegressor().fit(X[:30], y[:30])
    beta = ridge_coef(X[:30], y[:30])
    assert model.intercept_ == pytest.approx(beta[0])
    np.testing.assert_allclose(model.coef_, beta[1:])
    np.testing.assert_allclose(model.predict(X), np.c_[np.ones(40), X] @ beta)
    path = model.update_path(X[30:], y[30:])
    assert path.shape == (10, 4)
    model.partial_fit(X[30:36], y[30:36])
    new = update_coef(X[30:36], y[30:36], beta)
    np.testing.assert_allclose(np.r_[model.intercept_, model.coef_], new)
    np.testing.assert_allclose(path[5], new)
    assert model.n_updates_ == 1
    model.fit(X, y)
    assert model.n_updates_ == 0


def test_regressor_partial_fit_from_scratch_is_ridge(data):
    X, y = data
    model = UpdateRegressor(eta=0.5).partial_fit(X, y)
    np.testing.assert_allclose(
        np.r_[model.intercept_, model.coef_], ridge_coef(X, y, alpha=1.0)
    )
    assert model.n_updates_ == 1


def test_regressor_multi_output(data):
    X, y = data
    Y = np.c_[y, -y + 3]
    model = UpdateRegressor(alpha=1.0).fit(X, Y)
    assert model.coef_.shape == (2, 3)
    assert model.intercept_.shape == (2,)
    assert model.predict(X).shape == (40, 2)
    single = UpdateRegressor(alpha=1.0).fit(X, Y[:, 1])
    np.testing.assert_allclose(model.coef_[1], single.coef_)
    model.partial_fit(X[:5], Y[:5])
    assert model.update_path(X[:5], Y[:5]).shape == (5, 2, 4)
    with pytest.raises(ValueError, match="1 target"):
        model.partial_fit(X[:5], y[:5])
    # Named targets in another order would swap the axes silently.
    frame = pd.DataFrame(Y, columns=["disp_x_um", "disp_y_um"])
    named = UpdateRegressor(alpha=1.0).fit(X, frame)
    with pytest.raises(ValueError, match=r"\['disp_y_um', 'disp_x_um'\], but the"):
        named.partial_fit(X[:5], frame[["disp_y_um", "disp_x_um"]].iloc[:5])
    named.partial_fit(X[:5], frame.iloc[:5])
    named.partial_fit(X[:5], Y[:5])  # an array: no names to check


def test_regressor_errors(data):
    X, y = data
    with pytest.raises(InvalidParameterError):
        UpdateRegressor(alpha=-1).fit(X, y)
    with pytest.raises(InvalidParameterError):
        UpdateRegressor(eta=0.0).fit(X, y)
    model = UpdateRegressor().fit(X, y)
    with pytest.raises(ValueError, match="features"):
        model.partial_fit(X[:, :2], y)
    with pytest.raises(ValueError, match="NaN"):
        model.partial_fit(np.full((2, 3), np.nan), y[:2])


def test_default_penalty_warns_on_inputs_far_from_degrees(data):
    # alpha=25 (004) is an absolute penalty set for temperature changes in °C:
    # on millidegrees it regularised 1e6 times less, on kilodegrees 1e6 times
    # more, without a word. The default is kept (results in °C are 004's);
    # fit says what scale it saw and what to do.
    import warnings

    X, y = data  # changes of 0-5 °C
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        degrees = UpdateRegressor().fit(X, y)
        UpdateRegressor().partial_fit(X, y)
        UpdateRegressor(alpha=25e6).fit(1000 * X, y)  # alpha set for the units
        UpdateRegressor(eta=1e-7).partial_fit(1000 * X, y)
        UpdateRegressor().fit(np.zeros_like(X), y)  # no scale to speak of
    np.testing.assert_allclose(
        np.r_[degrees.intercept_, degrees.coef_], ridge_coef(X, y)
    )  # unchanged
    with pytest.warns(
        UserWarning,
        match=r"X has a root-mean-square of 2\.\d+e\+03, far from the temperature "
        r"changes in °C \(about 0\.01 to 100\) for which the default alpha=25\.0 "
        r".*regularises far less .*millidegrees / 1000\) or standardise it, or "
        r"set alpha for these units",
    ):
        milli = UpdateRegressor().fit(1000 * X, y)
    np.testing.assert_allclose(  # a warning only: the published ridge
        np.r_[milli.intercept_, milli.coef_], ridge_coef(1000 * X, y)
    )
    with pytest.warns(UserWarning, match=r"regularises far more"):
        UpdateRegressor().fit(X / 1000, y)
    # Absolute readings (around 20 °C, root-mean-square inside 0.01-100)
    # with the intercept penalised: 5.6 times the held-out error of changes
    # in an independent check, without a word.
    with pytest.warns(
        UserWarning, match=r"X's columns sit far from zero .* penalize_intercept"
    ):
        UpdateRegressor().fit(X + 20.0, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        UpdateRegressor(penalize_intercept=False).fit(X + 20.0, y)
        # Changes since the start of long batches: zero at each start, yet
        # their mean lies several spreads from zero (+5 °C, std 1.6, in a
        # 4 h batch); the warning told to give changes, as was done.
        # 4 h batches, and one 8 h run whose sensors warm within 20 min
        # (6 of its 960 rows within a spread of zero).
        # A 24 h run whose sensors warm within 5 min at 30 s: one row (the
        # first) within a spread of zero, which still warned.
        for hours, tau in ((4.0, 3600.0), (8.0, 1200.0), (24.0, 300.0)):
            t = np.arange(0.0, hours * 3600.0, 30.0)
            rise = 1.0 - np.exp(-t / tau)
            changes = np.c_[5.5 * rise, 4.0 * rise]
            UpdateRegressor().fit(changes, changes @ [1.0, 2.0])
    # ... while one drop-out row of zeros among readings does not hide them.
    dropout = X + 20.0
    dropout[5] = 0.0
    with pytest.warns(UserWarning, match=r"X's columns sit far from zero"):
        UpdateRegressor().fit(dropout, y)
    # One column beyond the range (a driver in rpm among temperatures) is
    # named; every column beyond it names none.
    frame = pd.DataFrame(X, columns=[f"T{j}_C" for j in range(X.shape[1])])
    frame["spindle_rpm"] = 3000.0 + 100.0 * (np.arange(len(frame)) % 7)
    with pytest.warns(
        UserWarning,
        match=r"of \S+ \(from the column\(s\) 'spindle_rpm' \(3\.\d+e\+03\)\)",
    ):
        UpdateRegressor().fit(frame, y)
    with pytest.warns(UserWarning, match=r"of 2\.\d+e\+03, far from") as rec:
        UpdateRegressor().fit(1000 * frame.drop(columns="spindle_rpm"), y)
    assert "from the column" not in str(rec[0].message)
    with pytest.warns(UserWarning, match=r"default eta=0\.1 .* \(1 - eta\) / eta"):
        UpdateRegressor().partial_fit(1000 * X, y)  # from scratch: a ridge
    # The remedy the message gives: alpha times the unit ratio squared is the
    # °C model (exactly, with a free intercept).
    free = UpdateRegressor(penalize_intercept=False).fit(X, y)
    scaled = UpdateRegressor(alpha=25e6, penalize_intercept=False).fit(1000 * X, y)
    np.testing.assert_allclose(1000 * scaled.coef_, free.coef_, rtol=1e-8)
    np.testing.assert_allclose(scaled.intercept_, free.intercept_, rtol=1e-8)


# --- adaptive compensation --------------------------------------------------


def _drift_table():
    # One sensor; the error's gain changes from 2 to 3 at row 20.
    T = np.arange(60, dtype=float) / 10
    E = np.where(np.arange(60) < 20, 2 * T, 3 * T - 2.0)
    return pd.DataFrame(
        {"run": "a", "time_s": 60.0 * np.arange(60), "T1_C": T, "disp_y_um": E}
    )


def test_adaptive_compensation_by_hand():
    runs = _drift_table()
    model = UpdateRegressor(alpha=0.0, penalize_intercept=False)
    model.fit(runs[["T1_C"]][:20], runs["disp_y_um"][:20])
    res = adaptive_compensation(model, runs, threshold_um=0.5, n_update=4)
    r = runs["disp_y_um"] - 2 * runs["T1_C"]  # residual of the initial model
    first = int(np.argmax(np.abs(r.to_numpy()) > 0.5))
    assert res.updates["row"].iloc[0] == first
    assert res.updates["n_samples"].iloc[0] == 4
    assert res.measuring.iloc[first + 1 : first + 5].all()
    assert not res.measuring.iloc[: first + 1].any()
    np.testing.assert_allclose(
        res.residual.iloc[: first + 5], r.iloc[: first + 5], atol=1e-9
    )
    assert res.samples_used == res.updates["n_samples"].sum()
    assert res.sample_period_s == 60.0
    assert res.downtime_s == 60.0 * res.samples_used
    assert res.downtime_fraction == pytest.approx(res.samples_used / 60)
    assert res.max_residual_um < np.abs(r).max()
    # The input model is untouched.
    assert model.n_updates_ == 0
    base = adaptive_compensation(model, runs, threshold_um=0.5, update=False)
    assert base.n_updates == 0
    np.testing.assert_allclose(base.residual, r, atol=1e-9)
    # A target in mm or nm under a *_um header: never an update, or one at
    # nearly every sample (85% downtime), without a word.
    for factor, unit in ((1e-4, "millimetres"), (1e3, "nanometres")):
        other = runs.assign(disp_y_um=runs["disp_y_um"] * factor)
        with pytest.warns(UserWarning, match=rf"spans .* Is it in {unit}\?"):
            adaptive_compensation(model, other, threshold_um=0.5, update=False)


def test_adaptive_compensation_auto(data):
    runs = _drift_table()
    model = UpdateRegressor().fit(runs[["T1_C"]][:20], runs["disp_y_um"][:20])
    res = adaptive_compensation(model, runs, threshold_um=0.5, n_update="auto")
    assert res.n_updates >= 1
    assert res.updates["n_samples"].between(1, 12).all()
    assert set(res.summary()) >= {"n_updates", "samples_used", "max_residual_um"}


def test_adaptive_compensation_errors():
    runs = _drift_table()
    model = UpdateRegressor().fit(runs[["T1_C"]], runs["disp_y_um"])
    with pytest.raises(ValueError, match="not in the run table"):
        adaptive_compensation(model, runs, target="disp_z_um")
    with pytest.raises(ValueError, match="threshold_um"):
        adaptive_compensation(model, runs, threshold_um=-1.0)
    with pytest.raises(ValueError, match="n_update"):
        adaptive_compensation(model, runs, n_update="some")
    with pytest.raises(TypeError, match="run table"):
        adaptive_compensation(model, runs.to_numpy())
    bad = runs.copy()
    bad.loc[3, "T1_C"] = np.nan
    with pytest.raises(ValueError, match="'T1_C'.*row 3"):
        adaptive_compensation(model, bad)
    unnamed = UpdateRegressor().fit(runs[["T1_C"]].to_numpy(), runs["disp_y_um"])
    with pytest.raises(ValueError, match="sensors="):
        adaptive_compensation(unnamed, runs)
    res = adaptive_compensation(unnamed, runs, sensors=["T1_C"], update=False)
    assert res.n_updates == 0
    # A two-axis model died inside numpy (shapes (50,) and (100,)).
    both = runs.assign(disp_z_um=2.0 * runs["disp_y_um"])
    two = UpdateRegressor().fit(both[["T1_C"]], both[["disp_y_um", "disp_z_um"]])
    with pytest.raises(ValueError, match=r"predicts 2 outputs; .* one model per ax"):
        adaptive_compensation(two, both)


@pytest.fixture(scope="module")
def campaign():
    return make_batch_campaign(n_batches=20, random_state=0)


def test_campaign_shape_and_metadata(campaign):
    sizes = campaign.groupby("run", sort=False).size()
    assert list(sizes.index) == [f"B{i}" for i in range(1, 21)]
    assert (sizes == 61).all()
    meta = pd.DataFrame(campaign.attrs["metadata"])
    assert len(meta) == 20
    assert meta["spindle_rpm"].nunique() > 1
    assert (meta["rest_before_h"] > 0).all()
    assert (campaign.groupby("run")["time_s"].first() == 0).all()
    with pytest.raises(ValueError, match="n_batches"):
        make_batch_campaign(n_batches=0)
    with pytest.raises(ValueError, match="cut_fraction"):
        make_batch_campaign(n_batches=1, cut_fraction=(0.5, 1.5))


def test_adaptive_campaign_keeps_residual_bounded(campaign):
    # 004 §4.3.1: model from B1, stream B2..B20 (76 h), update above 7 µm with
    # six new samples; goal 10 µm.
    first = changes_since_start(campaign[campaign["run"] == "B1"])
    sensors = [c for c in campaign if c.startswith("T")]
    sel = StableTSPSelector(n_features_to_select=2).fit(
        first[sensors], first["disp_y_um"], groups=first["run"]
    )
    tsp = list(sel.get_feature_names_out())
    model = UpdateRegressor().fit(first[tsp], first["disp_y_um"])
    rest = campaign[campaign["run"] != "B1"]
    adaptive = adaptive_compensation(model, rest, threshold_um=7.0, n_update=6)
    fixed = adaptive_compensation(model, rest, update=False)
    # Measured with random_state=0: 12 updates, 72 samples (6.2 % of the
    # time), 8.3 µm with updates against 15.8 µm without.
    assert adaptive.max_residual_um < 10.0
    assert 1 <= adaptive.n_updates <= 20
    assert adaptive.downtime_fraction < 0.1
    assert fixed.max_residual_um > 1.5 * adaptive.max_residual_um
    assert adaptive.rmse_um < fixed.rmse_um


# --- three-level RMSE ---------------------------------------------------------


def test_rmse_levels_by_hand():
    y = np.array([1.0, 2.0, 3.0, 5.0])
    groups = np.array(["B1", "B1", "B2", "B2"])
    preds = {
        "a": {"B1": [1.0, 2.0, 4.0, 4.0], "B2": [2.0, 2.0, 3.0, 5.0]},
        "b": pd.DataFrame({"B1": [0.0, 0.0, 0.0, 0.0]}),
    }
    lv = rmse_levels(y, preds, groups)
    r_a1 = [0.0, 1.0]
    r_a2 = [np.sqrt(0.5), 0.0]
    r_b1 = [np.sqrt((1 + 4) / 2), np.sqrt((9 + 25) / 2)]
    np.testing.assert_allclose(lv.per_batch.to_numpy(), [r_a1, r_a2, r_b1])
    assert lv.per_model.loc["a", "B1"] == pytest.approx(0.5)
    assert np.isnan(lv.per_model.loc["b", "B2"])
    assert lv.per_method.loc["a", "rmse"] == pytest.approx((0.5 + np.sqrt(0.5) / 2) / 2)
    assert lv.per_method.loc["b", "rmse"] == pytest.approx(np.mean(r_b1))
    no_self = rmse_levels(y, preds, groups, include_self=False)
    assert no_self.per_model.loc["a", "B1"] == pytest.approx(1.0)
    assert no_self.per_model.loc["a", "B2"] == pytest.approx(np.sqrt(0.5))


def test_rmse_levels_errors():
    y = np.arange(4.0)
    g = ["a", "a", "b", "b"]
    with pytest.raises(ValueError, match="expected 4"):
        rmse_levels(y, {"m": {"a": [1.0, 2.0]}}, g)
    with pytest.raises(TypeError, match="non-empty mapping"):
        rmse_levels(y, {}, g)
    with pytest.raises(ValueError, match="one batch label per row"):
        rmse_levels(y, {"m": {"a": y}}, ["a"])
    with pytest.raises(ValueError, match="NaN"):
        rmse_levels(y, {"m": {"a": [np.nan, 1, 1, 1]}}, g)
    # Models keyed "1", "2" for batches 1, 2 (or the other way round): no
    # model's own batch was left out, silently.
    with pytest.raises(
        ValueError, match=r"model '1' \(str\) is labelled like batch 1 \(int\)"
    ):
        rmse_levels(y, {"m": {"1": y, "2": y}}, [1, 1, 2, 2], include_self=False)
    with pytest.warns(UserWarning, match=r"no model is labelled like a batch"):
        rmse_levels(y, {"m": {"x": y}}, g, include_self=False)


def test_cross_batch_rmse(data):
    X, y = data
    groups = np.repeat(["B1", "B2"], 20)
    lv = cross_batch_rmse({"ridge": UpdateRegressor(alpha=1.0)}, X, y, groups)
    m1 = UpdateRegressor(alpha=1.0).fit(X[:20], y[:20])
    r12 = np.sqrt(np.mean((m1.predict(X[20:]) - y[20:]) ** 2))
    assert lv.per_batch.loc[("ridge", "B1"), "B2"] == pytest.approx(r12)
    assert lv.per_method.shape == (1, 1)


def test_takes_the_run_table_as_stored():
    # run and time_s are the table's labels and clock, not features.
    rng = np.random.default_rng(0)
    T = rng.normal(size=(20, 2))
    y = T @ [1.0, -2.0] + 0.5
    table = pd.DataFrame(
        {
            "run": ["a"] * 10 + ["b"] * 10,
            "time_s": np.r_[np.arange(10), np.arange(10)] * 60.0,
            "T1_C": T[:, 0],
            "T2_C": T[:, 1],
        }
    )
    model = UpdateRegressor(alpha=1e-6).fit(table, y)
    assert model.n_features_in_ == 2
    assert list(model.feature_names_in_) == ["T1_C", "T2_C"]
    plain = UpdateRegressor(alpha=1e-6).fit(table[["T1_C", "T2_C"]], y)
    np.testing.assert_allclose(
        model.predict(table), plain.predict(table[["T1_C", "T2_C"]])
    )
    model.partial_fit(table.iloc[:5], y[:5])
    bad = table.assign(T2_C=table["T2_C"].astype(object))
    bad.loc[4, "T2_C"] = "open"
    with pytest.raises(ValueError, match="'T2_C'.*'open'"):
        UpdateRegressor().fit(bad, y)


def test_groups_are_taken_like_every_run_aware_regressor():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 3))
    y = X @ np.array([1.0, -2.0, 0.5])
    groups = np.repeat(["a", "b"], 6)
    model = UpdateRegressor(alpha=1.0).fit(X, y, groups=groups)
    np.testing.assert_allclose(
        model.predict(X, groups=groups), UpdateRegressor(alpha=1.0).fit(X, y).predict(X)
    )
    with pytest.raises(ValueError, match="3 run labels"):
        model.fit(X, y, groups=groups[:3])
    model.partial_fit(X[:4], y[:4], groups=groups[:4])  # the same call in service
    with pytest.raises(ValueError, match="3 run labels"):
        model.partial_fit(X[:4], y[:4], groups=groups[:3])


def test_old_coefficients_of_the_wrong_length_are_named():
    from skthermal.linear_model import update_coef, update_path

    X = np.arange(18.0).reshape(6, 3)
    y = X @ [1.0, 2.0, 0.5]
    for function in (update_coef, update_path):
        with pytest.raises(ValueError, match=r"coef_old must have shape \(4,\): the"):
            function(X, y, np.zeros(3))  # the intercept left out
    assert update_coef(X, y, np.zeros((4, 1))).shape == (4, 1)


def test_array_functions_check_their_input():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(10, 2))
    y = X @ [2.0, 1.0]
    holed = X.copy()
    holed[3, 0] = np.nan
    with pytest.raises(ValueError, match="Input X contains NaN"):
        ridge_coef(holed, y)
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        ridge_coef(X, y[:-1])
    with pytest.raises(ValueError, match="Expected 2D array"):
        ridge_coef(X[:, 0], y)
    with pytest.raises(InvalidParameterError, match="'alpha' parameter"):
        ridge_coef(X, y, alpha=-1000)
    for eta in (2.0, -1.0, 0.0):
        with pytest.raises(InvalidParameterError, match="'eta' parameter"):
            update_coef(X[:6], y[:6], np.zeros(3), eta=eta)
        with pytest.raises(InvalidParameterError, match="'eta' parameter"):
            update_path(X[:6], y[:6], np.zeros(3), eta=eta)
    with pytest.raises(ValueError, match="coef_old contains NaN"):
        update_coef(X[:6], y[:6], np.array([np.nan, 1.0, 1.0]))
    with pytest.raises(ValueError, match="Input y contains NaN"):
        update_path(X[:6], np.r_[np.nan, y[1:6]], np.zeros(3))
    with pytest.raises(ValueError, match="path contains NaN"):
        first_stable_update(np.full((5, 3), np.nan))
    with pytest.raises(InvalidParameterError, match="'rtol' parameter"):
        first_stable_update(np.ones((5, 3)), rtol=-1)
    with pytest.raises(ValueError, match="path must hold one coefficient vector"):
        first_stable_update(np.zeros((0, 3)))
    with pytest.raises(InvalidParameterError, match="'atol' parameter"):
        update_is_stable(np.ones((3, 2)), atol=-1.0)


def test_adaptive_compensation_checks_times_and_text():
    runs = make_batch_campaign(n_batches=3, random_state=0)
    first = changes_since_start(runs[runs["run"] == "B1"])
    model = UpdateRegressor().fit(first[["T09_C", "T35_C"]], first["disp_y_um"])
    rest = runs[runs["run"] != "B1"].reset_index(drop=True)
    clock = rest.assign(time_s=pd.to_datetime(rest["time_s"], unit="s"))
    with pytest.raises(ValueError, match="'time_s' column holds datetime64"):
        adaptive_compensation(model, clock)
    swapped = rest.iloc[[1, 0, *range(2, len(rest))]]
    with pytest.raises(ValueError, match="in run 'B2' row 1 has time_s=0"):
        adaptive_compensation(model, swapped)
    text = rest.astype({"disp_y_um": object})
    text.loc[5, "disp_y_um"] = "n/a"
    with pytest.raises(ValueError, match=r"Column 'disp_y_um' is not numeric: row 5"):
        adaptive_compensation(model, text)


def test_cross_batch_rmse_refuses_a_scattered_batch():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(9, 2))
    y = X @ [1.0, 2.0]
    with pytest.raises(ValueError, match="rows of run 'b1' are not contiguous"):
        cross_batch_rmse(
            {"ols": LinearRegression()}, X, y, ["b1"] * 3 + ["b2"] * 3 + ["b1"] * 3
        )


def test_fit_takes_lists_with_run_labels():
    # A list of rows with groups raised AttributeError ('list' has no shape).
    rng = np.random.default_rng(0)
    X, y = rng.random((20, 3)), rng.random(20)
    groups = [0] * 10 + [1] * 10
    from_lists = UpdateRegressor().fit(X.tolist(), y.tolist(), groups=groups)
    from_arrays = UpdateRegressor().fit(X, y, groups=groups)
    np.testing.assert_array_equal(from_lists.coef_, from_arrays.coef_)
