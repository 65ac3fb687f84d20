"""Stable TSP selection (uncertainty-correlation) and fuzzy-equivalence grouping."""

import numpy as np
import pandas as pd
import pytest
from sklearn.utils._param_validation import InvalidParameterError

from skthermal.selection._stable import (
    FuzzyEquivalenceSelector,
    StableTSPSelector,
    fuzzy_equivalence_closure,
    pearson_gradients,
    uncertainty_correlation,
)

# Most tests here fit one run given as a plain array, which the selectors
# (rightly) warn is taken as one run.
pytestmark = pytest.mark.filterwarnings("ignore:.*carry no run labels:UserWarning")


@pytest.fixture
def heating(rng):
    """A heating curve, three related sensors and one unrelated."""
    t = np.linspace(0, 4, 80)
    e = 20 * (1 - np.exp(-t)) + rng.normal(0, 0.2, t.size)
    X = np.c_[
        e / 5 + rng.normal(0, 0.6, t.size),  # correlated, noisy
        e / 4 + rng.normal(0, 0.05, t.size),  # correlated, clean
        -e / 6 + rng.normal(0, 0.1, t.size),  # anti-correlated, clean
        rng.normal(0, 1, t.size),  # unrelated
    ]
    return X, e


def test_pearson_gradients_match_finite_differences(rng):
    x = rng.normal(size=(15, 3)) + np.linspace(0, 3, 15)[:, None]
    e = np.linspace(0, 5, 15) + rng.normal(0, 0.5, 15)
    r, dr_dx, dr_de = pearson_gradients(x, e)
    np.testing.assert_allclose(r, [np.corrcoef(x[:, i], e)[0, 1] for i in range(3)])
    h = 1e-6
    for k in range(15):
        xp, xm = x.copy(), x.copy()
        xp[k] += h
        xm[k] -= h
        fd = (pearson_gradients(xp, e)[0] - pearson_gradients(xm, e)[0]) / (2 * h)
        np.testing.assert_allclose(dr_dx[k], fd, rtol=1e-5, atol=1e-8)
        ep, em = e.copy(), e.copy()
        ep[k] += h
        em[k] -= h
        fd = (pearson_gradients(x, ep)[0] - pearson_gradients(x, em)[0]) / (2 * h)
        np.testing.assert_allclose(dr_de[k], fd, rtol=1e-5, atol=1e-8)


def test_gradient_sums_reduce_to_closed_form(rng):
    x = rng.normal(size=(30, 4))
    e = x[:, 0] + rng.normal(size=30)
    r, dr_dx, dr_de = pearson_gradients(x, e)
    sxx = ((x - x.mean(0)) ** 2).sum(0)
    see = ((e - e.mean()) ** 2).sum()
    np.testing.assert_allclose((dr_dx**2).sum(0), (1 - r**2) / sxx)
    np.testing.assert_allclose((dr_de**2).sum(0), (1 - r**2) / see)


def test_uncertainty_correlation_by_hand():
    x = np.array([[0.0, 1.0], [1.0, 0.5], [3.0, 2.0], [4.0, 2.5]])
    e = np.array([0.0, 2.0, 5.0, 9.0])
    rho, u_rho, u_t, rho_u = uncertainty_correlation(x, e, displacement_uncertainty=2)
    for i in range(2):
        t = x[:, i]
        r = np.corrcoef(t, e)[0, 1]
        slope, icpt = np.polyfit(e, t, 1)
        ut = 3 * np.sqrt(np.sum((t - (icpt + slope * e)) ** 2) / 3)
        tc, ec = t - t.mean(), e - e.mean()
        sxx, see = tc @ tc, ec @ ec
        dx = ec / np.sqrt(sxx * see) - r * tc / sxx
        de = tc / np.sqrt(sxx * see) - r * ec / see
        u = np.sqrt(4 * np.sum(de**2) + ut**2 * np.sum(dx**2))
        assert rho[i] == pytest.approx(r)
        assert u_t[i] == pytest.approx(ut)
        assert u_rho[i] == pytest.approx(u)
        assert rho_u[i] == pytest.approx(r / (1 + u))


def test_selector_scores_and_sign(heating):
    X, e = heating
    sel = StableTSPSelector(n_features_to_select=2).fit(X, e)
    rho, u_rho, u_t, rho_u = uncertainty_correlation(X - X[0], e - e[0])
    np.testing.assert_allclose(sel.correlation_[0], rho)
    np.testing.assert_allclose(sel.uncertainty_[0], u_rho)
    np.testing.assert_allclose(sel.temperature_uncertainty_[0], u_t)
    np.testing.assert_allclose(sel.scores_, np.abs(rho_u))
    # The anti-correlated clean sensor is kept, its score signed negative.
    assert sel.get_support().tolist() == [False, True, True, False]
    assert sel.uncertainty_correlation_[0, 2] < 0
    assert sel.ranking_.tolist()[:3] == [3, 1, 2]


def test_uncertainty_demotes_noisy_sensor(rng):
    # Two sensors with the same relative noise at different scales.
    t = np.linspace(0, 1, 40)
    e = 10 * t
    X = np.c_[t + rng.normal(0, 0.03, 40), 100 * t + rng.normal(0, 3, 40)]
    sel = StableTSPSelector(n_features_to_select=1, displacement_uncertainty=0.0)
    sel.fit(X, e)
    # Same relative noise: the same correlation and the same U_T-term.
    assert sel.uncertainty_[0, 0] == pytest.approx(sel.uncertainty_[0, 1], rel=0.3)
    # Bigger U_E lowers every score.
    big = StableTSPSelector(displacement_uncertainty=5.0).fit(X, e)
    assert np.all(big.scores_ < sel.scores_)
    zero = StableTSPSelector(
        displacement_uncertainty=0.0, temperature_uncertainty=0.0
    ).fit(X, e)
    np.testing.assert_allclose(zero.scores_, np.abs(zero.correlation_[0]))


def test_selector_known_temperature_uncertainty(heating):
    X, e = heating
    sel = StableTSPSelector(temperature_uncertainty=0.25).fit(X, e)
    np.testing.assert_allclose(sel.temperature_uncertainty_, 0.25)


def test_selector_runs_use_changes_since_start(heating):
    X, e = heating
    df = pd.DataFrame(X, columns=["a", "b", "c", "d"])
    df["run"] = ["r1"] * 40 + ["r2"] * 40
    shifted = df.copy()
    shifted.loc[40:, ["a", "b", "c", "d"]] += 7.0  # a run starting warmer
    y2 = e.copy()
    y2[40:] += 3.0
    a = StableTSPSelector().fit(df, e)
    b = StableTSPSelector().fit(shifted, y2)
    np.testing.assert_allclose(a.scores_, b.scores_)
    Xc = np.r_[X[:40] - X[0], X[40:] - X[40]]
    ec = np.r_[e[:40] - e[0], e[40:] - e[40]]
    np.testing.assert_allclose(a.correlation_[0], uncertainty_correlation(Xc, ec)[0])
    assert list(a.get_feature_names_out()) == ["b", "c"]


def test_selector_multi_target(heating):
    X, e = heating
    sel = StableTSPSelector().fit(X, np.c_[e, 2 * e + 1])
    assert sel.correlation_.shape == (2, 4)
    np.testing.assert_allclose(sel.correlation_[0], sel.correlation_[1])


def test_selector_errors(heating):
    X, e = heating
    with pytest.raises(InvalidParameterError):
        StableTSPSelector(displacement_uncertainty=-1).fit(X, e)
    with pytest.raises(InvalidParameterError):
        StableTSPSelector(temperature_uncertainty="rmse").fit(X, e)
    with pytest.raises(ValueError, match="Target 0 does not change"):
        StableTSPSelector().fit(X, np.ones(len(e)))
    bad = pd.DataFrame(X, columns=list("abcd"))
    bad.iloc[5, 2] = np.nan
    with pytest.raises(ValueError, match="sensor 'c' at row 5"):
        StableTSPSelector().fit(bad, e)
    const = X.copy()
    const[:, 3] = 1.0
    with pytest.warns(UserWarning, match="feature 3 is constant within every"):
        fitted = StableTSPSelector().fit(const, e)
    assert not fitted.support_[3] and np.isnan(fitted.correlation_[0, 3])
    const[:] = 1.0
    with pytest.raises(ValueError, match="Every sensor is constant"):
        StableTSPSelector().fit(const, e)


def _closure_brute_force(R):
    R = R.copy()
    while True:
        n = len(R)
        R2 = np.array(
            [
                [max(min(R[i, k], R[k, j]) for k in range(n)) for j in range(n)]
                for i in range(n)
            ]
        )
        if np.array_equal(R2, R):
            return R
        R = R2


def test_closure_matches_brute_force_and_is_transitive(rng):
    A = rng.uniform(size=(7, 7))
    R = np.minimum(A, A.T)
    np.fill_diagonal(R, 1.0)
    closure, merges = fuzzy_equivalence_closure(R)
    np.testing.assert_array_equal(closure, _closure_brute_force(R))
    composed = np.minimum(closure[:, :, None], closure[None]).max(axis=1)
    np.testing.assert_array_equal(composed, closure)
    assert np.all(closure >= R)
    # The merge levels, highest first: the cut at each has one group fewer.
    assert merges.shape == (6,) and np.all(np.diff(merges) <= 0)
    for k, lam in enumerate(merges):
        cut = closure >= lam
        assert np.rint((1.0 / cut.sum(axis=1)).sum()) == 7 - (k + 1)


def test_closure_of_many_sensors_in_quadratic_memory(rng):
    # 004's iteration needs n^3 floats per squaring (2 GB at 600 sensors).
    import tracemalloc

    A = rng.uniform(size=(600, 600))
    R = np.minimum(A, A.T)
    np.fill_diagonal(R, 1.0)
    tracemalloc.start()
    closure, _ = fuzzy_equivalence_closure(R)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 40 * R.nbytes
    assert closure.shape == R.shape and np.all(closure >= R)


def test_closure_by_hand():
    R = np.array([[1.0, 0.8, 0.1], [0.8, 1.0, 0.6], [0.1, 0.6, 1.0]])
    closure, _ = fuzzy_equivalence_closure(R)
    np.testing.assert_array_equal(
        closure, [[1.0, 0.8, 0.6], [0.8, 1.0, 0.6], [0.6, 0.6, 1.0]]
    )
    with pytest.raises(ValueError, match="square"):
        fuzzy_equivalence_closure(np.ones((2, 3)))


@pytest.fixture
def two_families(rng):
    t = np.linspace(0, 1, 60)
    e = 3 * t + np.sin(6 * t)
    X = np.c_[
        t + rng.normal(0, 0.01, 60),
        t + rng.normal(0, 0.05, 60),
        np.sin(6 * t) + rng.normal(0, 0.01, 60),
        np.sin(6 * t) + rng.normal(0, 0.2, 60),
        t**3,
    ]
    return X, e


def test_fuzzy_equivalence_groups_and_representatives(two_families):
    X, e = two_families
    sel = FuzzyEquivalenceSelector(threshold=0.97).fit(X, e)
    assert sel.labels_[0] == sel.labels_[1]
    assert sel.labels_[2] != sel.labels_[0]
    for g, rep in enumerate(sel.representatives_):
        members = np.flatnonzero(sel.labels_ == g)
        assert rep == members[np.argmax(sel.scores_[members])]
    assert sel.get_support().sum() == len(sel.representatives_)
    # Scores are |corr| with the error of changes since the start.
    Xc, ec = X - X[0], e - e[0]
    r = [abs(np.corrcoef(Xc[:, i], ec)[0, 1]) for i in range(5)]
    np.testing.assert_allclose(sel.scores_, r)
    # Lambda-cut of the closure is an equivalence relation (groups are cliques).
    same = sel.labels_[:, None] == sel.labels_[None, :]
    np.testing.assert_array_equal(same, sel.similarity_ >= 0.97)


def test_fuzzy_equivalence_extremes_and_n_groups(two_families):
    X, e = two_families
    assert FuzzyEquivalenceSelector(threshold=0.0).fit(X, e).labels_.max() == 0
    one_each = FuzzyEquivalenceSelector(threshold=1.0).fit(X, e)
    assert one_each.get_support().all()
    two = FuzzyEquivalenceSelector(n_groups=2).fit(X, e)
    assert len(two.representatives_) == 2
    # Lambda is the highest closure level with at most two groups.
    levels = np.unique(two.similarity_)
    assert two.threshold_ in levels
    higher = levels[levels > two.threshold_]
    assert all(np.unique(two.similarity_ >= v, axis=0).shape[0] > 2 for v in higher)
    with pytest.raises(InvalidParameterError):
        FuzzyEquivalenceSelector(threshold=1.5).fit(X, e)
    with pytest.raises(InvalidParameterError):
        FuzzyEquivalenceSelector(n_groups=0).fit(X, e)


def test_fuzzy_equivalence_pandas_output(two_families):
    X, e = two_families
    df = pd.DataFrame(X, columns=[f"T{i}_C" for i in range(5)])
    sel = FuzzyEquivalenceSelector(n_groups=2).set_output(transform="pandas")
    out = sel.fit(df, e).transform(df)
    assert list(out.columns) == list(sel.get_feature_names_out())


@pytest.mark.parametrize("scale", [1e80, 1e-90])
def test_scores_do_not_depend_on_the_units(scale):
    # Readings, error and its uncertainty in other (accepted) units: the
    # same scores. The product of the sums of squares overflowed (scores 0)
    # or underflowed (NaN) past 1e40 and 1e-40, and the selector still chose.
    import warnings

    from skthermal.datasets import make_sensor_groups
    from skthermal.selection import StableTSPSelector

    runs, _ = make_sensor_groups(
        n_groups=2,
        sensors_per_group=2,
        n_noise=1,
        n_runs=2,
        n_samples=60,
        random_state=0,
    )
    X, y = runs.drop(columns="disp_y_um"), runs["disp_y_um"]
    sensors = [c for c in X if c.startswith("T")]
    ref = StableTSPSelector(2).fit(X, y)
    Xs = X.copy()
    Xs[sensors] = Xs[sensors] * scale
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        sel = StableTSPSelector(2, displacement_uncertainty=scale).fit(Xs, y * scale)
    np.testing.assert_allclose(sel.scores_, ref.scores_, rtol=1e-9)
    assert list(sel.get_feature_names_out()) == list(ref.get_feature_names_out())
    # The uncertainty is in y's unit: left at 1 for an error of 1e-90, every
    # score is 0 and the choice arbitrary, which is said.
    if scale < 1:
        with pytest.warns(UserWarning, match=r"displacement_uncertainty=1 is larg"):
            StableTSPSelector(2).fit(Xs, y * scale)
