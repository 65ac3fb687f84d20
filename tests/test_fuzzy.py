"""Tests of fuzzy c-means (skthermal.fuzzy)."""

import numpy as np
import pytest
from sklearn.datasets import make_blobs
from sklearn.metrics import adjusted_rand_score

from skthermal.fuzzy import fuzzy_cmeans, fuzzy_memberships
from skthermal.fuzzy._cmeans import memberships_from_distances


def _reference_fcm(X, u0, m, n_iter):
    """Textbook fuzzy c-means, one sample at a time (for cross-checking)."""
    u = u0.copy()
    for _ in range(n_iter):
        um = u**m
        centers = (um.T @ X) / um.sum(axis=0)[:, None]
        for j in range(X.shape[0]):
            d = np.linalg.norm(X[j] - centers, axis=1)
            for i in range(centers.shape[0]):
                u[j, i] = 1.0 / np.sum((d[i] / d) ** (2 / (m - 1)))
    return centers, u


@pytest.mark.parametrize("m", [2.0, 1.5, 3.0])
def test_matches_textbook_iteration(m):
    X, _ = make_blobs(60, centers=3, random_state=0)
    rng = np.random.default_rng(0)
    u0 = rng.random((60, 3))
    u0 /= u0.sum(axis=1, keepdims=True)
    res = fuzzy_cmeans(X, 3, m=m, init=u0, max_iter=7, tol=0)
    centers, u = _reference_fcm(X, u0, m, 7)
    # The library returns the memberships computed from the last centres.
    np.testing.assert_allclose(res.centers, centers, rtol=1e-10)
    np.testing.assert_allclose(res.memberships, u, rtol=1e-9)
    assert res.n_iter == 7


def test_zero_tol_stops_at_a_fixed_point():
    # tol=0 ("no membership changes by more than 0") ran every one of
    # max_iter iterations after the memberships had stopped changing.
    # Exactly unchanged memberships are rare: their last bits cycle, so the
    # fixed point is reached within rounding (of most data sets, as these).
    cases = [(60 + 40 * seed, 3 + seed % 3, 3, 2.0, seed) for seed in range(6)]
    cases.append((500, 10, 10, 3.0, 0))  # cycling at 1e-14 to 1e-13
    for n, centers, c, m, seed in cases:
        X, _ = make_blobs(n, centers=centers, random_state=seed)
        res = fuzzy_cmeans(X, c, m=m, tol=0, max_iter=20_000, random_state=0)
        assert res.n_iter < 2_000, seed
        again = fuzzy_cmeans(X, c, m=m, tol=0, init=res.memberships, max_iter=20_000)
        assert again.n_iter <= 10, seed


def test_recovers_blobs_and_objective_decreases():
    X, truth = make_blobs(300, centers=4, cluster_std=0.5, random_state=1)
    res = fuzzy_cmeans(X, 4, n_init=3, random_state=0)
    assert adjusted_rand_score(truth, res.labels) == 1.0
    np.testing.assert_allclose(res.memberships.sum(axis=1), 1.0)
    assert np.all(np.diff(res.objective_history) <= 1e-9 * res.objective_history[0])


def test_seeded_results_are_identical():
    X, _ = make_blobs(200, centers=3, random_state=2)
    a = fuzzy_cmeans(X, 3, n_init=4, init="random", random_state=7)
    b = fuzzy_cmeans(X, 3, n_init=4, init="random", random_state=7)
    np.testing.assert_array_equal(a.memberships, b.memberships)


def test_point_on_a_centre_gets_full_membership():
    d2 = np.array([[0.0, 4.0, 9.0], [1.0, 1.0, 4.0], [0.0, 0.0, 1.0]])
    u = memberships_from_distances(d2, 2.0)
    np.testing.assert_allclose(u[0], [1, 0, 0])
    np.testing.assert_allclose(u[1], [4 / 9, 4 / 9, 1 / 9])
    np.testing.assert_allclose(u[2], [0.5, 0.5, 0])


def test_far_away_points_stay_finite():
    centers = np.array([[0.0, 0.0], [1.0, 1.0]])
    u = fuzzy_memberships(np.array([[1e150, 1e150], [1e-160, 0.0]]), centers)
    assert np.all(np.isfinite(u))
    np.testing.assert_allclose(u.sum(axis=1), 1.0)


def test_sample_weight_moves_centres():
    X = np.array([[0.0], [1.0], [10.0]])
    res = fuzzy_cmeans(X, 1, sample_weight=[1.0, 0.0, 0.0], random_state=0)
    assert res.centers[0, 0] == pytest.approx(0.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n_clusters": 0}, "n_clusters must be between 1"),
        ({"n_clusters": 11}, "n_clusters must be between 1"),
        ({"n_clusters": 2, "m": 1.0}, "fuzzifier m must be greater than 1"),
        ({"n_clusters": 2, "init": "nope"}, "init must be"),
        ({"n_clusters": 2, "sample_weight": [-1.0] * 10}, "sample_weight"),
    ],
)
def test_errors(kwargs, match):
    X = np.arange(20.0).reshape(10, 2)
    n_clusters = kwargs.pop("n_clusters")
    with pytest.raises(ValueError, match=match):
        fuzzy_cmeans(X, n_clusters, **kwargs)


def test_nan_is_rejected():
    X = np.ones((4, 2))
    X[1, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        fuzzy_cmeans(X, 2)


def test_gram_path_for_wide_data_matches_direct_path():
    """More features than samples switches to Gram-matrix distances: same result."""
    rng = np.random.default_rng(0)
    wide = rng.normal(size=(30, 200)) + np.repeat(rng.normal(size=(3, 200)), 10, 0)
    u0 = rng.random((30, 3))
    u0 /= u0.sum(axis=1, keepdims=True)
    res = fuzzy_cmeans(wide, 3, init=u0, max_iter=5, tol=0)
    centers, u = _reference_fcm(wide, u0, 2.0, 5)
    np.testing.assert_allclose(res.centers, centers, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(res.memberships, u, rtol=1e-8)


def test_cmeans_keeps_its_precision_far_from_zero():
    rng = np.random.default_rng(0)
    X = np.r_[rng.normal(0, 0.1, (20, 2)), rng.normal(1, 0.1, (20, 2))]
    near = fuzzy_cmeans(X, 2, random_state=0)
    far = fuzzy_cmeans(X + 1e8, 2, random_state=0)
    np.testing.assert_allclose(far.centers - 1e8, near.centers, atol=1e-6)
    np.testing.assert_allclose(
        fuzzy_memberships(X + 1e8, far.centers),
        fuzzy_memberships(X, near.centers),
        atol=1e-6,
    )


def test_cmeans_names_bad_arguments():
    X = np.random.default_rng(0).normal(size=(10, 2))
    cases = [
        ({"max_iter": 0}, "max_iter must be an integer >= 1"),
        ({"n_init": 0}, "n_init must be an integer >= 1"),
        ({"sample_weight": np.zeros(10)}, "zero everywhere"),
        ({"init": np.zeros((10, 2))}, "sample 0 are all zero"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            fuzzy_cmeans(X, 2, **kwargs)
    with pytest.raises(ValueError, match="same number of features"):
        fuzzy_memberships(X[:, :1], np.ones((2, 2)))
    with pytest.raises(ValueError, match="greater than 1"):
        fuzzy_memberships(X, np.ones((2, 2)), m=1.0)
    with pytest.raises(ValueError, match="must be finite"):
        fuzzy_memberships(np.where(X > 1, np.nan, X), np.ones((2, 2)))


# ------------------------------------- ANFIS membership functions, as plotted


def test_anfis_membership_degrees_are_the_membership_functions():
    from skthermal.fuzzy import ANFISRegressor, gaussian_mf, gbell_mf

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(80, 2))
    y = X[:, 0] - X[:, 1] ** 2
    points = np.c_[np.linspace(-1.5, 1.5, 7), np.linspace(2.0, -2.0, 7)]
    for mf, func in (("gaussian", gaussian_mf), ("gbell", gbell_mf)):
        model = ANFISRegressor(init="grid", n_mfs=3, mf=mf, epochs=3).fit(X, y)
        for which, params in (
            ("trained", model.mf_params_),
            ("initial", model.initial_mf_params_),
        ):
            mu = model.membership_degrees(points, which=which)
            assert mu.shape == (7, 2, 3)
            for j in range(2):
                for m in range(3):
                    expected = func(points[:, j], *params[j, m])
                    np.testing.assert_allclose(mu[:, j, m], expected, rtol=1e-12)
        assert not np.allclose(
            model.membership_degrees(points),
            model.membership_degrees(points, which="initial"),
        )
    np.testing.assert_array_equal(
        model.get_input_range(), np.c_[X.min(axis=0), X.max(axis=0)]
    )


def test_anfis_membership_degrees_errors():
    from sklearn.exceptions import NotFittedError

    from skthermal.fuzzy import ANFISRegressor

    with pytest.raises(NotFittedError):
        ANFISRegressor().membership_degrees([[0.0]])
    with pytest.raises(NotFittedError):
        ANFISRegressor().get_input_range()
    model = ANFISRegressor.from_parameters(
        mf="gbell", mf_params=[[[1.0, 2.0, 0.0]]], consequents=[[1.0, 0.0]]
    )
    with pytest.raises(ValueError, match="which must be 'trained' or 'initial'"):
        model.membership_degrees([[0.0]], which="both")
    with pytest.raises(ValueError, match="X has 2 features, but ANFISRegressor has 1"):
        model.membership_degrees([[0.0, 1.0]])
    # A model from parameters: the span of its functions (centre +- 2 a).
    np.testing.assert_allclose(model.get_input_range(), [[-2.0, 2.0]])
