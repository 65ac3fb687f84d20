"""Synthetic run tables with a known sensor structure, for tests and demos.

These generators are deliberately simple statistical models (independent heat
sources driving groups of collinear sensors), not the physics-based simulator:
they exist so that a selector's answer can be checked against the truth.
"""

from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, validate_params


def _first_order_response(power, dt, tau):
    """Exact zero-order-hold response of ``tau dT/dt = P - T`` (vectorised).

    ``power`` has shape (n_samples, n_sources); ``tau`` one time constant per
    source. Uses the closed-form discretisation ``T[k] = a T[k-1] + (1-a) P[k-1]``
    evaluated with ``scipy.signal.lfilter`` over the time axis of every source.
    """
    from scipy.signal import lfilter

    out = np.empty_like(power)
    a = np.exp(-dt / np.asarray(tau, dtype=float))
    for j, aj in enumerate(a):  # one filter per heat source (a handful)
        out[:, j] = lfilter([0.0, 1.0 - aj], [1.0, -aj], power[:, j])
    return out


_NONNEGATIVE = Interval(Real, 0, np.inf, closed="left")


@validate_params(
    {
        "n_groups": [Interval(Integral, 1, None, closed="left")],
        "sensors_per_group": [Interval(Integral, 1, None, closed="left")],
        "n_noise": [Interval(Integral, 0, None, closed="left")],
        "n_runs": [Interval(Integral, 1, None, closed="left")],
        # The duty-cycle blocks are n_samples // 12 to n_samples // 4 long.
        "n_samples": [Interval(Integral, 12, None, closed="left")],
        "sample_period_s": [Interval(Real, 0, np.inf, closed="neither")],
        "sensor_noise": [_NONNEGATIVE],
        "noise_sensor_std": [_NONNEGATIVE],
        "displacement_noise": [_NONNEGATIVE],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def make_sensor_groups(
    n_groups=3,
    sensors_per_group=10,
    n_noise=10,
    *,
    n_runs=2,
    n_samples=360,
    sample_period_s=60.0,
    sensor_noise=0.02,
    noise_sensor_std=0.3,
    displacement_noise=0.3,
    random_state=None,
):
    """Run table with groups of collinear heat-driven sensors and noise sensors.

    Each group follows its own heat source: a random on/off duty cycle with a
    random power level, passed through a first-order thermal lag whose time
    constant differs per group. Every sensor of a group reads
    ``gain * rise + offset + noise``, so the sensors of a group are collinear.
    Noise sensors read an unrelated slowly wandering temperature. The
    displacement ``disp_y_um`` is a positive combination of the group rises
    plus measurement noise.

    Parameters
    ----------
    n_groups : int, default=3
        Independent heat-driven groups.
    sensors_per_group : int, default=10
    n_noise : int, default=10
        Sensors unrelated to the displacement.
    n_runs : int, default=2
        Independent test runs (each starts from a cold machine).
    n_samples : int, default=360
        Samples per run, at least 12.
    sample_period_s : float, default=60.0
    sensor_noise : float, default=0.02
        Standard deviation (°C) of the independent noise on group sensors.
    noise_sensor_std : float, default=0.3
        Standard deviation (°C) of the wandering noise sensors.
    displacement_noise : float, default=0.3
        Standard deviation (µm) of the displacement noise.
    random_state : int, RandomState instance or None

    Returns
    -------
    runs : DataFrame
        A run table: ``run``, ``time_s``, ``T01_C`` .. (group sensors first, in
        group order, then the noise sensors) and ``disp_y_um``.
    sensor_group : Series
        Index = sensor column, value = group number (0 .. n_groups-1) or -1
        for a noise sensor.

    Examples
    --------
    >>> from skthermal.datasets import make_sensor_groups
    >>> runs, truth = make_sensor_groups(random_state=0)
    >>> runs.shape
    (720, 43)
    >>> truth.value_counts().sort_index().tolist()
    [10, 10, 10, 10]
    """
    rng = check_random_state(random_state)
    n_sensors = n_groups * sensors_per_group + n_noise
    width = max(2, len(str(n_sensors)))
    names = [f"T{i + 1:0{width}d}_C" for i in range(n_sensors)]
    group_of = np.r_[
        np.repeat(np.arange(n_groups), sensors_per_group), -np.ones(n_noise, dtype=int)
    ]
    tau = rng.uniform(15.0, 60.0, n_groups) * 60.0  # s
    gains = rng.uniform(0.5, 1.5, (n_groups, sensors_per_group))
    offsets = rng.uniform(18.0, 24.0, n_sensors)
    effect = rng.uniform(2.0, 5.0, n_groups)  # µm per °C of group rise

    frames = []
    t = np.arange(n_samples) * sample_period_s
    for r in range(n_runs):
        # Duty cycle: on/off blocks of random length with a random power level.
        power = np.zeros((n_samples, n_groups))
        for g in range(n_groups):
            k = 0
            on = bool(rng.randint(2))
            while k < n_samples:
                length = rng.randint(n_samples // 12, n_samples // 4 + 1)
                power[k : k + length, g] = rng.uniform(3.0, 8.0) if on else 0.0
                on = not on
                k += length
        rise = _first_order_response(power, sample_period_s, tau)
        temps = np.empty((n_samples, n_sensors))
        n_grouped = n_groups * sensors_per_group
        temps[:, :n_grouped] = (
            rise[:, np.repeat(np.arange(n_groups), sensors_per_group)] * gains.ravel()
        )
        temps[:, :n_grouped] += rng.normal(0, sensor_noise, (n_samples, n_grouped))
        walk = np.cumsum(rng.normal(0, 1, (n_samples, n_noise)), axis=0)
        walk -= walk.mean(axis=0)
        walk *= noise_sensor_std / np.maximum(walk.std(axis=0), 1e-12)
        temps[:, n_grouped:] = walk
        temps += offsets
        disp = rise @ effect + rng.normal(0, displacement_noise, n_samples)
        frame = pd.DataFrame(temps, columns=names)
        frame.insert(0, "time_s", t)
        frame.insert(0, "run", f"run{r + 1}")
        frame["disp_y_um"] = disp
        frames.append(frame)
    runs = pd.concat(frames, ignore_index=True)
    sensor_group = pd.Series(group_of, index=names, name="group")
    return runs, sensor_group
