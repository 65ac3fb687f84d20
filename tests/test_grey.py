"""Tests of the grey-system array functions (skthermal.grey)."""

import numpy as np
import pytest

from skthermal.grey import (
    ago,
    background,
    gm0n,
    gm1n,
    gm11,
    grey_relational_grade,
    iago,
)

X0 = [2.874, 3.278, 3.337, 3.390, 3.679]


def test_gm11_worked_example():
    model = gm11(X0)
    assert model.a == pytest.approx(-0.0372044, abs=5e-8)
    assert model.b == pytest.approx(3.0653633, abs=5e-8)
    np.testing.assert_allclose(
        model.predict(), [2.874, 3.23204, 3.35455, 3.48170, 3.61368], atol=5e-6
    )
    assert model.forecast(1)[0] == pytest.approx(3.75066, abs=5e-6)


def test_gm11_needs_three_samples():
    with pytest.raises(ValueError, match="at least 3 samples"):
        gm11([1.0, 2.0])


def test_ago_iago_roundtrip_within_runs(rng):
    x = rng.normal(size=(12, 3))
    groups = np.repeat(["a", "b", "c"], 4)
    x1 = ago(x, groups)
    # Accumulation restarts at every run: the first row of a run is unchanged.
    np.testing.assert_allclose(x1[[0, 4, 8]], x[[0, 4, 8]])
    np.testing.assert_allclose(x1[7], x[4:8].sum(axis=0))
    np.testing.assert_allclose(iago(x1, groups), x)
    np.testing.assert_allclose(iago(ago(x)), x)


def test_background_skips_run_starts():
    x1 = np.array([1.0, 3.0, 6.0, 10.0, 20.0])
    z, mask = background(x1, groups=[0, 0, 0, 1, 1])
    np.testing.assert_allclose(z, [2.0, 4.5, 15.0])
    assert mask.tolist() == [False, True, True, False, True]


def test_non_contiguous_runs_are_rejected():
    with pytest.raises(ValueError, match="run 'a' are not contiguous"):
        ago(np.ones(4), groups=["a", "b", "a", "b"])


def _gm1n_series(a, b, n=40, seed=0):
    """Inputs and a target that satisfy the GM(1,N) equation exactly."""
    rng = np.random.default_rng(seed)
    X = np.cumsum(rng.uniform(0.1, 1.0, size=(n, len(b))), axis=0)
    X -= X[0]
    X1 = np.cumsum(X, axis=0)
    # x1(k) + a z1(k) = b.X1(k), with z1(k) = (y1(k-1) + y1(k)) / 2 and
    # y1(k) = y1(k-1) + x1(k)  ->  x1(k) (1 + a/2) = b.X1(k) - a y1(k-1)
    y = np.zeros(n)
    y1 = 0.0
    for k in range(1, n):
        y[k] = (X1[k] @ b - a * y1) / (1 + a / 2)
        y1 += y[k]
    return X, y


def test_gm1n_recovers_exact_coefficients():
    a, b = 0.3, np.array([0.5, -0.2, 0.05])
    X, y = _gm1n_series(a, b)
    a_hat, b_hat = gm1n(y, X)
    assert a_hat == pytest.approx(a, rel=1e-8)
    np.testing.assert_allclose(b_hat, b, rtol=1e-8)


def test_gm1n_stacks_runs_without_crossing_boundaries():
    a, b = 0.3, np.array([0.5, -0.2])
    X1, y1 = _gm1n_series(a, b, n=30, seed=1)
    X2, y2 = _gm1n_series(a, b, n=25, seed=2)
    # An offset in the second run's absolute readings must not matter.
    X = np.r_[X1, X2 + 20.0]
    y = np.r_[y1, y2 + 5.0]
    groups = np.r_[np.zeros(30), np.ones(25)]
    a_hat, b_hat = gm1n(y, X, groups=groups)
    assert a_hat == pytest.approx(a, rel=1e-8)
    np.testing.assert_allclose(b_hat, b, rtol=1e-8)
    # Treated as one run, the boundary breaks the model.
    a_bad, _ = gm1n(y, X)
    assert abs(a_bad - a) > 1e-3


def test_gm1n_sample_count_error_says_how_many():
    X = np.random.default_rng(0).normal(size=(5, 6))
    with pytest.raises(ValueError, match=r"6 input series need at least 8 samples"):
        gm1n(np.arange(5.0), X)


def test_gm1n_collinear_sensors_do_not_break(rng):
    t = np.arange(100.0)
    base = 1 - np.exp(-t / 20)
    X = np.c_[base, 2 * base, base + 1e-9 * rng.normal(size=100)]
    y = 3 * base
    a, b = gm1n(y, X)
    assert np.all(np.isfinite(b)) and np.isfinite(a)
    a_r, b_r = gm1n(y, X, alpha=1e-3)
    assert np.all(np.isfinite(b_r))


def test_gm0n_recovers_static_relation():
    rng = np.random.default_rng(3)
    X = np.cumsum(rng.uniform(0.1, 1, size=(50, 3)), axis=0)
    X -= X[0]
    theta = np.array([0.7, 0.0, -0.3])
    # z1(k) = X1(k) . theta for k >= 2, which fixes y recursively.
    X1 = np.cumsum(X, axis=0)
    y = np.zeros(50)
    y1_prev = 0.0
    for k in range(1, 50):
        # z1(k) = y1(k-1) + y(k)/2 = X1(k).theta
        y[k] = 2 * (X1[k] @ theta - y1_prev)
        y1_prev += y[k]
    np.testing.assert_allclose(gm0n(y, X), theta, atol=1e-9)


def test_similitude_degree_by_hand():
    y = np.array([0.0, 1.0, 2.0, 4.0])
    X = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 2.0], [3.0, 2.0]])
    # s0 = 1 + 2 + 0.5*4 = 5; s1 = 1 + 2 + 1.5 = 4.5; s2 = 2 + 2 + 1 = 5
    deg = grey_relational_grade(y, X, normalize=None)
    np.testing.assert_allclose(deg, [1 / 1.5, 1.0])
    absd = grey_relational_grade(y, X, method="absolute", normalize=None)
    np.testing.assert_allclose(absd, [10.5 / 11.0, 1.0])


def test_deng_grade_by_hand():
    y = np.array([0.0, 1.0, 2.0])
    X = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 1.0]])
    # d1 = [0, 0, 0], d2 = [0, 1, 1]; dmin = 0, dmax = 1, rho = 0.5
    deg = grey_relational_grade(y, X, method="deng", normalize=None)
    np.testing.assert_allclose(deg, [1.0, (1 + 1 / 3 + 1 / 3) / 3])


def test_gra_prefers_the_matching_curve_and_is_unit_free():
    t = np.linspace(0, 1, 80)
    y = 1000 * (1 - np.exp(-3 * t))  # µm-like scale
    X = np.c_[np.sin(5 * t), 2 * (1 - np.exp(-3 * t)), t**4]
    for method in ("similitude", "absolute", "deng"):
        assert grey_relational_grade(y, X, method=method).argmax() == 1


def test_gra_rejects_bad_options():
    with pytest.raises(ValueError, match="method must be one of"):
        grey_relational_grade([0, 1.0], [[0], [1.0]], method="nope")
    with pytest.raises(ValueError, match="rho must be in"):
        grey_relational_grade([0, 1.0], [[0], [1.0]], rho=0)


def test_gm11_restores_a_constant_series():
    # The development coefficient is ~1e-17 there: no cancellation.
    from skthermal.grey import gm11

    np.testing.assert_allclose(gm11([1.0, 1.0, 1.0, 1.0]).predict(), [1, 1, 1, 1])
    np.testing.assert_allclose(gm11([10.0, 10.0, 10.0]).predict(), [10, 10, 10])


def test_grey_functions_name_bad_arguments():
    from skthermal.grey import (
        gm0n,
        gm1n,
        gmc1n,
        gmc1n_predict,
        gmc1n_varpro,
        gnnmci_predict,
        grey_relational_grade,
    )

    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 2)).cumsum(axis=0)
    y = X @ [0.5, -0.3]
    cases = [
        (lambda: gm1n(y, X, alpha=-1.0), "alpha must be a finite number >= 0"),
        (lambda: gm0n(y, X, alpha=np.nan), "alpha must be a finite number >= 0"),
        (lambda: gmc1n(y, X, delay=-2), "delay must be an integer >= 0"),
        (lambda: gmc1n(y, X, delay=1.7), "delay must be an integer >= 0"),
        (lambda: gmc1n_predict(X, 0.1, [1.0], 0.0), "one driving coefficient"),
        (lambda: gmc1n_predict(X, -50, [1, 1], 0), "b1 must be finite and >= 0"),
        (lambda: gnnmci_predict(X, [0.1, 1.0]), "weights must hold 4 finite"),
        (lambda: gmc1n_varpro(y, X, b1_bounds=(-5, -1)), "b1_bounds must be"),
        (lambda: gmc1n_varpro(y, X, b1_bounds=(1, 0)), "b1_bounds must be"),
        (lambda: gmc1n_varpro(y, X, alpha="bogus"), 'or "auto"'),
        (
            lambda: grey_relational_grade(y, np.where(X > 0, np.nan, X)),
            "NaN or infinite values",
        ),
    ]
    for call, message in cases:
        with pytest.raises(ValueError, match=message):
            call()
