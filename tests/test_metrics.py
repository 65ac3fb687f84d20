"""Tests of skthermal.metrics: hand-computed values, input checks and scorers."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.exceptions import UndefinedMetricWarning
from sklearn.linear_model import LinearRegression
from sklearn.metrics import r2_score
from sklearn.model_selection import GroupKFold, cross_validate

from skthermal.metrics import (
    cross_batch_rmse,
    get_scorer,
    get_scorer_names,
    improvement,
    nash_sutcliffe,
    pearson_r,
    residual_band,
    rmse,
    rmse_levels,
    thermal_scorers,
)

METRICS = [rmse, nash_sutcliffe, pearson_r, residual_band, improvement]

# z = measured error, p = prediction; residuals z - p = [-1, 1, -1, 3]
Z = [2.0, 4.0, 6.0, 8.0]
P = [3.0, 3.0, 7.0, 5.0]


def test_hand_computed_values():
    # SSE = 1 + 1 + 1 + 9 = 12, mean z = 5, SST = 9 + 1 + 1 + 9 = 20
    assert rmse(Z, P) == pytest.approx(np.sqrt(12 / 4))
    assert nash_sutcliffe(Z, P) == pytest.approx(1 - 12 / 20)
    # z - 5 = [-3, -1, 1, 3], p - 4.5 = [-1.5, -1.5, 2.5, 0.5]
    # sum = 4.5 + 1.5 + 2.5 + 1.5 = 10; sqrt(20 * 11) = sqrt(220)
    assert pearson_r(Z, P) == pytest.approx(10 / np.sqrt(220))
    assert residual_band(Z, P) == 3.0
    assert improvement(Z, P) == pytest.approx(1 - 3 / 8)


def test_returns_python_float():
    for metric in METRICS:
        assert type(metric(Z, P)) is float


def test_perfect_prediction():
    assert rmse(Z, Z) == 0.0
    assert nash_sutcliffe(Z, Z) == 1.0
    assert pearson_r(Z, Z) == pytest.approx(1.0)
    assert residual_band(Z, Z) == 0.0
    assert improvement(Z, Z) == 1.0


def test_nse_equals_r2_and_mean_prediction_scores_zero(rng):
    y = rng.normal(size=(50, 3))
    p = y + rng.normal(scale=0.5, size=(50, 3))
    np.testing.assert_allclose(
        nash_sutcliffe(y, p, multioutput="raw_values"),
        r2_score(y, p, multioutput="raw_values"),
    )
    assert nash_sutcliffe(y[:, 0], np.full(50, y[:, 0].mean())) == pytest.approx(0.0)


def test_nse_falls_with_the_size_of_a_miss():
    # One prediction of 1e300 scored 0.0 (better than a miss of 1e100), one
    # of 1e160 -inf with numpy's overflow warning.
    y = np.linspace(0.0, 5.0, 61)
    scores = []
    for miss in (10.0, 1e10, 1e100, 1e160, 1e300):
        p = y.copy()
        p[5] = miss
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            scores.append(nash_sutcliffe(y, p))
    assert scores == sorted(scores, reverse=True) and scores[-2:] == [-np.inf] * 2
    assert scores[2] == pytest.approx(1 - 1e200 / np.sum((y - y.mean()) ** 2))
    # No error scores 1, however tiny the values or large an unweighted miss.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert nash_sutcliffe(1e-200 * y, 1e-200 * y) == 1.0
        miss = y + np.r_[1e200, np.zeros(60)]
        assert nash_sutcliffe(y, miss, sample_weight=np.r_[0, np.ones(60)]) == 1.0


def test_pearson_matches_numpy_and_sign(rng):
    y = rng.normal(size=40)
    p = 0.3 * y + rng.normal(size=40)
    assert pearson_r(y, p) == pytest.approx(np.corrcoef(y, p)[0, 1])
    assert pearson_r(y, -p) == pytest.approx(-np.corrcoef(y, p)[0, 1])
    # Invariant to a linear rescaling of the prediction, unlike RMSE.
    assert pearson_r(y, 5 * p + 2) == pytest.approx(pearson_r(y, p))


def test_improvement_uses_absolute_peak():
    # peak |z| = 10 comes from a negative value
    assert improvement([-10.0, 2.0], [-9.0, 0.0]) == pytest.approx(1 - 2 / 10)


def test_multioutput():
    y = np.column_stack([Z, [1.0, 1.0, 1.0, 5.0]])
    p = np.column_stack([P, [1.0, 2.0, 1.0, 3.0]])
    raw = rmse(y, p, multioutput="raw_values")
    np.testing.assert_allclose(raw, [np.sqrt(3.0), np.sqrt(5 / 4)])
    assert rmse(y, p) == pytest.approx(raw.mean())
    assert rmse(y, p, multioutput=[3.0, 1.0]) == pytest.approx(
        (3 * raw[0] + raw[1]) / 4
    )
    np.testing.assert_array_equal(residual_band(y, p, multioutput="raw_values"), [3, 2])
    np.testing.assert_allclose(
        improvement(y, p, multioutput="raw_values"), [1 - 3 / 8, 1 - 2 / 5]
    )
    # A 1-D target gives one raw value.
    assert rmse(Z, P, multioutput="raw_values").shape == (1,)


def test_accepts_pandas_and_column_vectors():
    assert rmse(pd.Series(Z), pd.DataFrame({"p": P})) == pytest.approx(np.sqrt(3))
    assert rmse(np.array(Z)[:, None], P) == pytest.approx(np.sqrt(3))


def test_constant_target_conventions():
    y = [2.0, 2.0, 2.0]
    assert nash_sutcliffe(y, y) == 1.0
    assert nash_sutcliffe(y, [2.0, 3.0, 2.0]) == 0.0
    assert np.isnan(nash_sutcliffe(y, y, force_finite=False))
    assert nash_sutcliffe(y, [2.0, 3.0, 2.0], force_finite=False) == -np.inf
    zero = [0.0, 0.0]
    assert improvement(zero, zero) == 1.0
    assert improvement(zero, [0.0, 1.0]) == 0.0
    assert improvement(zero, [0.0, 1.0], force_finite=False) == -np.inf
    with pytest.warns(UndefinedMetricWarning, match="y_true is constant"):
        assert np.isnan(pearson_r(y, [1.0, 2.0, 3.0]))
    with pytest.warns(UndefinedMetricWarning, match="y_pred is constant"):
        assert np.isnan(pearson_r([1.0, 2.0, 3.0], y))
        # Constant by value, whatever the rounding of its mean (it left 0.0).
        assert np.isnan(pearson_r([1.0, 2.0, 3.0], [0.1, 0.1, 0.1]))
    with pytest.warns(UndefinedMetricWarning, match="NaN for 1 of 2 output"):
        raw = pearson_r(
            np.column_stack([y, Z[:3]]),
            np.column_stack([Z[:3], Z[:3]]),
            multioutput="raw_values",
        )
    assert np.isnan(raw[0]) and raw[1] == pytest.approx(1.0)


@pytest.mark.parametrize("metric", METRICS)
def test_length_mismatch(metric):
    with pytest.raises(ValueError, match="y_true has 4 samples but y_pred has 3"):
        metric(Z, P[:3])


@pytest.mark.parametrize("metric", METRICS)
def test_output_mismatch(metric):
    with pytest.raises(ValueError, match="y_true has 2 outputs but y_pred has 3"):
        metric(np.ones((4, 2)), np.ones((4, 3)))


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_nan_and_inf(metric, bad):
    p = np.array(P)
    p[2] = bad
    with pytest.raises(ValueError, match=r"y_pred has 1 NaN or infinite.*row 2"):
        metric(Z, p)
    y = np.ones((4, 2))
    y[1, 1] = bad
    with pytest.raises(ValueError, match=r"y_true has 1 NaN .*row 1, output 1"):
        metric(y, np.ones((4, 2)))


def test_other_input_errors():
    with pytest.raises(ValueError, match="empty"):
        rmse([], [])
    with pytest.raises(ValueError, match="must be numeric"):
        rmse(["a", "b"], [1.0, 2.0])
    with pytest.raises(ValueError, match="1-D or 2-D"):
        rmse(np.ones((2, 2, 2)), np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match="multioutput must be one of"):
        rmse(Z, P, multioutput="variance_weighted")
    with pytest.raises(ValueError, match="one weight per output"):
        rmse(np.ones((4, 2)), np.ones((4, 2)), multioutput=[1.0])


# --- scorers -----------------------------------------------------------------


def test_scorer_names_and_signs(rng):
    X = rng.normal(size=(30, 2))
    y = X @ [1.0, -2.0] + rng.normal(size=30)
    model = LinearRegression().fit(X, y)
    p = model.predict(X)
    assert get_scorer("neg_rmse")(model, X, y) == pytest.approx(-rmse(y, p))
    assert get_scorer("neg_residual_band")(model, X, y) == pytest.approx(
        -residual_band(y, p)
    )
    assert get_scorer("nse")(model, X, y) == pytest.approx(nash_sutcliffe(y, p))
    assert get_scorer("pearson_r")(model, X, y) == pytest.approx(pearson_r(y, p))
    assert get_scorer("improvement")(model, X, y) == pytest.approx(improvement(y, p))


def test_get_scorer_falls_back_to_sklearn(rng):
    X = rng.normal(size=(20, 2))
    y = X[:, 0] + rng.normal(size=20)
    model = LinearRegression().fit(X, y)
    assert get_scorer("r2")(model, X, y) == pytest.approx(r2_score(y, model.predict(X)))
    assert get_scorer(None) is None
    scorer = get_scorer("nse")
    assert get_scorer(scorer) is scorer
    with pytest.raises(ValueError, match=r"'nope' is not a valid.*'neg_rmse'"):
        get_scorer("nope")


def test_get_scorer_names():
    names = get_scorer_names()
    assert names[:5] == list(thermal_scorers())
    assert "neg_root_mean_squared_error" in names


def test_thermal_scorers_are_fresh_copies():
    a, b = thermal_scorers(), thermal_scorers()
    assert set(a) == {
        "neg_rmse",
        "nse",
        "pearson_r",
        "neg_residual_band",
        "improvement",
    }
    assert a["nse"] is not b["nse"]


def test_cross_validate_with_thermal_scorers(rng):
    n_runs, n_rows = 6, 15
    groups = np.repeat(np.arange(n_runs), n_rows)
    X = rng.normal(size=(n_runs * n_rows, 3))
    y = X @ [2.0, 0.5, -1.0] + 0.3 * rng.normal(size=n_runs * n_rows)
    cv = cross_validate(
        LinearRegression(),
        X,
        y,
        groups=groups,
        cv=GroupKFold(3),
        scoring=thermal_scorers(),
        return_indices=True,
        error_score="raise",
    )
    for k, (train, test) in enumerate(
        zip(cv["indices"]["train"], cv["indices"]["test"], strict=True)
    ):
        assert not set(groups[train]) & set(groups[test])
        p = LinearRegression().fit(X[train], y[train]).predict(X[test])
        yt = y[test]
        res = yt - p
        assert cv["test_neg_rmse"][k] == pytest.approx(-np.sqrt(np.mean(res**2)))
        nse = 1 - np.sum(res**2) / np.sum((yt - yt.mean()) ** 2)
        assert cv["test_nse"][k] == pytest.approx(nse)
        assert cv["test_pearson_r"][k] == pytest.approx(np.corrcoef(yt, p)[0, 1])
        assert cv["test_neg_residual_band"][k] == pytest.approx(-np.abs(res).max())
        assert cv["test_improvement"][k] == pytest.approx(
            1 - np.abs(res).max() / np.abs(yt).max()
        )


def test_cross_validate_multioutput(rng):
    X = rng.normal(size=(60, 2))
    Y = np.column_stack([X @ [1.0, 2.0], X @ [-1.0, 0.5]]) + rng.normal(size=(60, 2))
    groups = np.repeat(np.arange(6), 10)
    cv = cross_validate(
        LinearRegression(),
        X,
        Y,
        groups=groups,
        cv=GroupKFold(3),
        scoring=thermal_scorers(),
        return_indices=True,
        error_score="raise",
    )
    test = cv["indices"]["test"][0]
    train = cv["indices"]["train"][0]
    p = LinearRegression().fit(X[train], Y[train]).predict(X[test])
    per_output = np.sqrt(np.mean((Y[test] - p) ** 2, axis=0))
    assert cv["test_neg_rmse"][0] == pytest.approx(-per_output.mean())


def test_rmse_levels_and_cross_batch_check_their_labels_and_inputs():
    with pytest.raises(ValueError, match="Row 1 has no batch label"):
        rmse_levels([1, 2, 3, 4], {"m": {"a": [1, 2, 3, 4]}}, ["a", None, "b", "b"])
    # X as a list of rows, as scikit-learn accepts it.
    X = [[0.0], [1.0], [2.0], [3.0]]
    levels = cross_batch_rmse(
        {"ols": LinearRegression()}, X, [0, 1, 2, 4], [1, 1, 2, 2]
    )
    arrays = cross_batch_rmse(
        {"ols": LinearRegression()}, np.asarray(X), [0, 1, 2, 4], [1, 1, 2, 2]
    )
    pd.testing.assert_frame_equal(levels.per_batch, arrays.per_batch)
    with pytest.raises(ValueError, match="X must be 2-D"):
        cross_batch_rmse({"ols": LinearRegression()}, [0.0, 1.0], [0, 1], [1, 1])


@pytest.mark.parametrize(
    "weights, message",
    [
        ([0, 0], "weights are all 0"),
        ([np.nan, 1], r"finite and 0 or more, got \[nan, 1.0\]"),
        ([-1, 2], r"finite and 0 or more, got \[-1.0, 2.0\]"),
        (["a", "b"], "weights must be numbers"),
    ],
)
def test_output_weights_are_checked(weights, message):
    y = np.array([[1.0, 2.0], [2.0, 3.0], [3.0, 5.0]])
    with pytest.raises(ValueError, match=message):
        rmse(y, y + 1, multioutput=weights)
    assert rmse(y, y + 1, multioutput=[0, 1]) == pytest.approx(1.0)


@pytest.mark.parametrize("scale", [1e160, 1e-170])
def test_metrics_do_not_overflow_or_underflow(scale):
    import warnings

    from skthermal.metrics import nash_sutcliffe, pearson_r, rmse

    y = np.array([1.0, 2.0, 3.0, 4.5])
    p = np.array([1.2, 1.9, 3.4, 4.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert rmse(y * scale, p * scale) == pytest.approx(rmse(y, p) * scale)
        assert nash_sutcliffe(y * scale, p * scale) == pytest.approx(
            nash_sutcliffe(y, p)
        )
        assert pearson_r(y * scale, p * scale) == pytest.approx(pearson_r(y, p))


def test_sample_weights(rng):
    from sklearn.metrics import mean_squared_error

    z = rng.normal(size=40)
    p = z + rng.normal(scale=0.3, size=40)
    w = rng.uniform(0.0, 3.0, size=40)
    w[:5] = 0.0
    assert rmse(z, p, sample_weight=w) == pytest.approx(
        np.sqrt(mean_squared_error(z, p, sample_weight=w))
    )
    assert nash_sutcliffe(z, p, sample_weight=w) == pytest.approx(
        r2_score(z, p, sample_weight=w)
    )
    cov = np.cov(z, p, aweights=w)
    assert pearson_r(z, p, sample_weight=w) == pytest.approx(
        cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])
    )
    # A largest residual is not weighted: weight 0 leaves a sample out.
    p_out = p.copy()
    p_out[0] += 100.0
    assert residual_band(z, p_out, sample_weight=w) == pytest.approx(
        np.abs(z - p)[5:].max()
    )
    assert improvement(z, p_out, sample_weight=w) == pytest.approx(
        1 - np.abs(z - p)[5:].max() / np.abs(z[5:]).max()
    )
    # Equal weights are no weights; whole-number weights repeat samples.
    for metric in METRICS:
        assert metric(z, p, sample_weight=np.full(40, 2.5)) == pytest.approx(
            metric(z, p)
        )
    counts = rng.integers(1, 4, size=40)
    rows = np.repeat(np.arange(40), counts)
    for metric in (rmse, nash_sutcliffe, pearson_r):
        assert metric(z, p, sample_weight=counts) == pytest.approx(
            metric(z[rows], p[rows])
        )


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize(
    "weights, message",
    [
        (np.ones(3), r"shape \(3,\), expected \(4,\)"),
        ([1.0, -1.0, 1.0, 1.0], "row 1 has -1.0"),
        ([1.0, np.nan, 1.0, 1.0], "row 1 has nan"),
        (np.zeros(4), "0 for every sample"),
        (["a", "b", "c", "d"], "must be numbers"),
    ],
)
def test_sample_weights_are_checked(metric, weights, message):
    with pytest.raises(ValueError, match=message):
        metric(Z, P, sample_weight=weights)


def test_scorers_pass_sample_weights_under_routing(rng):
    import sklearn

    n_runs, n_rows = 4, 15
    groups = np.repeat(np.arange(n_runs), n_rows)
    X = rng.normal(size=(n_runs * n_rows, 2))
    y = X @ [1.0, -2.0] + 0.3 * rng.normal(size=n_runs * n_rows)
    w = np.where(groups == 0, 5.0, 1.0)
    with sklearn.config_context(enable_metadata_routing=True):
        scorers = thermal_scorers()
        for scorer in scorers.values():
            scorer.set_score_request(sample_weight=True)
        cv = cross_validate(
            LinearRegression().set_fit_request(sample_weight=False),
            X,
            y,
            params={"groups": groups, "sample_weight": w},
            cv=GroupKFold(2),
            scoring=scorers,
            return_indices=True,
            error_score="raise",
        )
    for k, test in enumerate(cv["indices"]["test"]):
        train = cv["indices"]["train"][k]
        p = LinearRegression().fit(X[train], y[train]).predict(X[test])
        assert -cv["test_neg_rmse"][k] == pytest.approx(
            rmse(y[test], p, sample_weight=w[test])
        )
