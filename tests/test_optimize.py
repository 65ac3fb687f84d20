"""Tests of skthermal.optimize: the vectorised particle swarm."""

import numpy as np
import pytest
from scipy.optimize import Bounds

from skthermal.optimize import particle_swarm


def sphere(P):
    return np.sum((P - 0.5) ** 2, axis=1)


def rosenbrock(P):
    return np.sum(
        100.0 * (P[:, 1:] - P[:, :-1] ** 2) ** 2 + (1.0 - P[:, :-1]) ** 2, axis=1
    )


# Constant inertia with Clerc's constriction values: the usual setting for
# converging tightly on a narrow valley.
CLERC = {"inertia": 0.729, "c1": 1.49445, "c2": 1.49445}


class Recorder:
    """An objective that remembers every swarm it was called with."""

    def __init__(self, fun):
        self.fun = fun
        self.calls = []

    def __call__(self, P):
        self.calls.append(P.copy())
        return self.fun(P)


@pytest.mark.parametrize("d", [2, 3, 5])
def test_sphere_converges_with_defaults(d, seed):
    res = particle_swarm(sphere, [(-5.0, 5.0)] * d, epochs=100, random_state=seed)
    assert res.fun < 1e-6
    np.testing.assert_allclose(res.x, 0.5, atol=1e-3)
    assert res.success


@pytest.mark.parametrize(
    ("d", "n_particles", "epochs", "target"),
    [(2, 40, 300, 1e-8), (3, 60, 600, 1e-4), (5, 90, 1500, 1e-2)],
)
def test_rosenbrock_converges(d, n_particles, epochs, target, seed):
    res = particle_swarm(
        rosenbrock,
        [(-2.0, 2.0)] * d,
        n_particles=n_particles,
        epochs=epochs,
        random_state=seed,
        **CLERC,
    )
    assert res.fun < target
    np.testing.assert_allclose(res.x, 1.0, atol=0.1)


def test_deterministic_under_random_state(seed):
    kw = {"n_particles": 20, "epochs": 30}
    a = particle_swarm(rosenbrock, [(-2, 2)] * 3, random_state=seed, **kw)
    b = particle_swarm(rosenbrock, [(-2, 2)] * 3, random_state=seed, **kw)
    c = particle_swarm(rosenbrock, [(-2, 2)] * 3, random_state=seed + 1, **kw)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.history, b.history)
    assert not np.array_equal(a.x, c.x)
    rs = np.random.RandomState(seed)
    d = particle_swarm(rosenbrock, [(-2, 2)] * 3, random_state=rs, **kw)
    np.testing.assert_array_equal(a.x, d.x)


def test_one_call_per_epoch_with_the_whole_swarm():
    fun = Recorder(sphere)
    res = particle_swarm(fun, [(-1, 1)] * 4, n_particles=13, epochs=7, random_state=0)
    assert len(fun.calls) == 8  # initial swarm + one per epoch
    assert all(P.shape == (13, 4) for P in fun.calls)
    assert res.nit == 7
    assert res.nfev == 13 * 8
    assert res.history.shape == (8,)
    assert np.all(np.diff(res.history) <= 0)
    assert res.history[-1] == res.fun == sphere(res.x[None])[0]


def test_positions_stay_inside_the_bounds():
    fun = Recorder(lambda P: np.sum(P, axis=1))  # optimum on the lower wall
    lo, hi = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.5, 2.0])
    res = particle_swarm(fun, np.c_[lo, hi], n_particles=10, epochs=20, random_state=0)
    P = np.concatenate(fun.calls)
    assert np.all(P >= lo) and np.all(P <= hi)
    np.testing.assert_allclose(res.x, [-1.0, 0.0, 2.0])  # found on the wall


def test_scipy_bounds_accepted():
    res = particle_swarm(
        sphere, Bounds([-1, -1], [1, 1]), n_particles=10, epochs=50, random_state=0
    )
    assert res.fun < 1e-6


def test_velocity_clamp_limits_every_step():
    fun = Recorder(sphere)
    particle_swarm(
        fun,
        [(-10, 10)] * 2,
        n_particles=10,
        epochs=10,
        velocity_clamp=0.25,
        random_state=0,
    )
    steps = np.abs(np.diff(np.stack(fun.calls), axis=0))
    assert steps.max() <= 0.25 + 1e-12


def test_constant_inertia_and_zero_epochs():
    res = particle_swarm(sphere, [(-1, 1)] * 2, epochs=0, inertia=0.5, random_state=0)
    assert res.nit == 0 and res.history.shape == (1,)


def test_init_is_never_worse_than_the_start():
    start = np.full(3, 0.5)  # the optimum itself
    res = particle_swarm(
        sphere, [(-5, 5)] * 3, n_particles=5, epochs=3, init=start, random_state=0
    )
    assert res.fun == 0.0
    np.testing.assert_array_equal(res.x, start)
    starts = np.array([[0.5, 0.5, 0.5], [1.0, 1.0, 1.0]])
    res = particle_swarm(
        sphere, [(-5, 5)] * 3, n_particles=5, epochs=0, init=starts, random_state=0
    )
    assert res.fun == 0.0


def test_nan_costs_are_infeasible():
    def fun(P):
        c = sphere(P)
        c[P[:, 0] > 0] = np.nan  # half the box cannot be evaluated
        return c

    res = particle_swarm(fun, [(-1, 1)] * 2, n_particles=20, epochs=50, random_state=0)
    assert np.isfinite(res.fun)
    assert res.x[0] <= 0


@pytest.mark.parametrize(
    ("bounds", "match"),
    [
        ([(1.0, 0.0)], "low > high"),
        ([(0.0, np.inf)], "finite"),
        ([0.0, 1.0], "shape"),
        ([], "shape"),
        ([(0, 1, 2)], "shape"),
        # Finite but too wide: the steps overflowed, and the run ended in
        # "every position had a non-finite cost", blaming the objective.
        ([(-1e308, 1e308)], r"dimension 0 \(-1e\+308, 1e\+308\) are wider"),
        ([(0.0, 1.0), (-1e301, 0.0)], "dimension 1"),
    ],
)
def test_bad_bounds(bounds, match):
    with pytest.raises(ValueError, match=match):
        particle_swarm(sphere, bounds)


def test_bad_objective_output():
    with pytest.raises(ValueError, match="one cost per particle"):
        particle_swarm(lambda P: sphere(P)[:-1], [(-1, 1)], n_particles=5)
    with pytest.raises(ValueError, match="one cost per particle"):
        particle_swarm(lambda P: sphere(P)[:, None], [(-1, 1)], n_particles=5)
    with pytest.raises(ValueError, match="-inf"):
        particle_swarm(lambda P: -np.inf * np.ones(len(P)), [(-1, 1)], n_particles=5)
    with pytest.raises(ValueError, match="non-finite"):
        particle_swarm(lambda P: np.full(len(P), np.nan), [(-1, 1)], epochs=2)
    # The imaginary part was dropped with a numpy ComplexWarning.
    with pytest.raises(ValueError, match="complex costs"):
        particle_swarm(lambda P: np.sqrt(P[:, 0] - 2 + 0j), [(-1, 1)], epochs=2)
    with pytest.raises(ValueError, match="real numbers"):
        particle_swarm(lambda P: np.array(["a"] * len(P)), [(-1, 1)], epochs=2)
    # Text that reads as a number is still text, and None is no cost (it
    # became NaN, blamed on the bounds as a non-finite cost).
    with pytest.raises(ValueError, match=r"real numbers.*got text \(<U"):
        particle_swarm(lambda P: [str(v) for v in P[:, 0]], [(-1, 1)])
    with pytest.raises(ValueError, match=r"real numbers.*got NoneType"):
        particle_swarm(lambda P: np.array([None] * len(P)), [(-1, 1)], epochs=2)
    with pytest.raises(ValueError, match=r"real numbers.*got str"):
        particle_swarm(lambda P: np.array([0.0, "1"] * 10, dtype=object), [(-1, 1)])
    # Numbers of any kind in an object array are costs: numpy bools, 0-d
    # arrays, Decimal.
    from decimal import Decimal

    makers = (
        lambda v: np.bool_(v > 0.5),
        lambda v: np.asarray(abs(v)),
        lambda v: Decimal(str(abs(v))),
    )
    for make in makers:
        res = particle_swarm(
            lambda P, make=make: np.array([make(v) for v in P[:, 0]], dtype=object),
            [(-1, 1)],
            epochs=3,
        )
        assert np.isfinite(res.fun)
    res = particle_swarm(
        lambda P: np.array(list(np.abs(P[:, 0])), dtype=object), [(-1, 1)]
    )
    assert res.fun < 0.1


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"n_particles": 0}, ValueError),
        ({"n_particles": 2.5}, TypeError),
        ({"epochs": -1}, ValueError),
        ({"c1": -1.0}, ValueError),
        ({"inertia": (0.9,)}, ValueError),
        ({"inertia": np.nan}, ValueError),
        ({"inertia": (np.nan, 0.4)}, ValueError),
        ({"velocity_clamp": 0.0}, ValueError),
        ({"init": np.zeros((2, 5))}, ValueError),
        ({"init": np.zeros(3)}, ValueError),
        ({"tol": -1.0}, ValueError),
    ],
)
def test_bad_parameters(kwargs, error):
    with pytest.raises(error):
        particle_swarm(sphere, [(-1, 1)] * 2, **{"n_particles": 4, **kwargs})


def test_velocity_clamp_of_the_wrong_length_is_named():
    with pytest.raises(
        ValueError, match=r"one value per dimension of the search \(2\)"
    ):
        particle_swarm(sphere, [(-1, 1)] * 2, n_particles=4, velocity_clamp=[1.0] * 3)


def test_tol_stops_early():
    res = particle_swarm(
        sphere, [(-1, 1)] * 2, epochs=1000, tol=1e-3, patience=5, random_state=0
    )
    assert res.nit < 1000
    assert "tol" in res.message
    assert res.history.shape == (res.nit + 1,)
