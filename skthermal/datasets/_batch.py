"""A simulated campaign of machining batches in changing states (004 §4.1).

The stream :func:`skthermal.linear_model.adaptive_compensation` replays: 20
batches of machining cycles on the Machine-B-like preset of
:mod:`skthermal.simulate`, one after another on one timeline.
"""

from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import HasMethods, Interval, validate_params

from skthermal.utils._runs import RUN_COLUMN, TIME_COLUMN

_POSITIVE = Interval(Real, 0, np.inf, closed="neither")
_NONNEGATIVE = Interval(Real, 0, np.inf, closed="left")


@validate_params(
    {
        "n_batches": [Interval(Integral, 1, None, closed="left")],
        "machine": [HasMethods(["simulate", "run_metadata"]), None],
        "batch_h": [_POSITIVE],
        "cycle_min": [_POSITIVE],
        "speeds_rpm": ["array-like"],
        "feeds_mm_min": ["array-like"],
        "cut_fraction": ["array-like"],
        "rest_h": ["array-like"],
        "day_amplitude_C": [_NONNEGATIVE],
        "noise": ["boolean"],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def make_batch_campaign(
    n_batches=20,
    *,
    machine=None,
    batch_h=4.0,
    cycle_min=4.0,
    speeds_rpm=(3000, 4000, 5000, 6000, 7000, 8000),
    feeds_mm_min=(500, 1000, 2000, 3000),
    cut_fraction=(0.5, 0.9),
    rest_h=(0.5, 14.0),
    day_amplitude_C=2.0,
    noise=True,
    random_state=None,
):
    """A long campaign of machining batches in changing states, simulated.

    Like the 20 batches of Liu et al. (004 §4.1): each batch is ``batch_h``
    hours of machining cycles of ``cycle_min`` minutes, cutting for part of
    each cycle at a spindle speed and feed drawn per batch, and a
    measurement (one sample) at the end of every cycle. Batches follow one
    another on one timeline, separated by rests of random length, so a batch
    may start on a machine still warm from the last one, at any hour of the
    workshop's day/night cycle. The Machine-B-like ``"vmc-b"`` preset is
    simulated continuously and the samples of each batch are cut out.

    Parameters
    ----------
    n_batches : int, default=20
    machine : ThermalMachine, optional
        Default: ``ThermalMachine.from_preset("vmc-b")``.
    batch_h : float, default=4.0
        Length of a batch (hours).
    cycle_min : float, default=4.0
        Cutting-and-measuring cycle (minutes); also the sample period.
    speeds_rpm : sequence of float, default=(3000, ..., 8000)
        Spindle speeds a batch may use.
    feeds_mm_min : sequence of float, default=(500, 1000, 2000, 3000)
        Axis feeds a batch may use.
    cut_fraction : (float, float), default=(0.5, 0.9)
        Range of the cutting share of a cycle (drawn per batch, rounded to
        eighths of the cycle).
    rest_h : (float, float), default=(0.5, 14.0)
        Range of the rest before each batch after the first (the first
        starts after 12 h at rest).
    day_amplitude_C : float, default=2.0
        Half the workshop's day/night swing (mean 20 °C).
    noise : bool, default=True
        Sensor and displacement noise.
    random_state : int, RandomState instance or None

    Returns
    -------
    runs : DataFrame
        Run table with runs ``"B1"`` .. ``"B<n>"``, each ``batch_h * 60 /
        cycle_min + 1`` samples with ``time_s`` from 0, drivers, 77
        temperatures ``T01_C`` .. ``T77_C`` and ``disp_x_um``,
        ``disp_y_um``, ``disp_z_um`` (raw values: take changes since the
        start of each batch for modelling). ``runs.attrs["metadata"]`` has
        one record per batch (speed, feed, cutting share, rest before it,
        start hour on the campaign timeline).

    See Also
    --------
    skthermal.linear_model.adaptive_compensation, make_machine_b_tests

    Notes
    -----
    The batches' parameters are drawn, not the paper's Table 1 (not in the
    extracted text). Y is the simulated machine's largest error; 004
    modelled Z, the largest on its machine.

    Examples
    --------
    >>> from skthermal.datasets import make_batch_campaign
    >>> runs = make_batch_campaign(n_batches=3, random_state=0)
    >>> runs.groupby("run", sort=False).size().to_dict()
    {'B1': 61, 'B2': 61, 'B3': 61}
    """
    from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine

    for name, pair, low in (("cut_fraction", cut_fraction, 0.0), ("rest_h", rest_h, 0)):
        if len(pair) != 2 or not (low <= pair[0] <= pair[1]):
            raise ValueError(f"{name} must be a (low, high) pair, got {pair!r}.")
    if cut_fraction[1] > 1:
        raise ValueError(f"cut_fraction must lie in [0, 1], got {cut_fraction!r}.")
    speeds = np.asarray(speeds_rpm, dtype=float)
    feeds = np.asarray(feeds_mm_min, dtype=float)
    if speeds.size == 0 or feeds.size == 0 or np.any(speeds < 0):
        raise ValueError("speeds_rpm and feeds_mm_min must be non-empty; speeds >= 0.")
    cycle_s = 60.0 * cycle_min
    n_cycles = int(round(batch_h * 60.0 / cycle_min))
    if n_cycles < 2:
        raise ValueError(
            f"A batch of {batch_h} h holds fewer than two {cycle_min}-minute cycles."
        )
    machine = ThermalMachine.from_preset("vmc-b") if machine is None else machine
    rng = check_random_state(random_state)
    sub = 8  # integration steps per cycle
    step_s = cycle_s / sub
    segments, starts, metas = [], [], []
    cursor = 0  # in integration steps
    for b in range(n_batches):
        rest_cycles = (
            int(round(12.0 * 3600 / cycle_s))
            if b == 0
            else max(1, int(round(rng.uniform(*rest_h) * 3600 / cycle_s)))
        )
        segments.append((rest_cycles * cycle_s, 0.0, 0.0))
        cursor += rest_cycles * sub
        rpm = float(rng.choice(speeds))
        feed = float(rng.choice(feeds))
        cut = int(np.clip(round(rng.uniform(*cut_fraction) * sub), 1, sub))
        for _ in range(n_cycles):
            segments.append((cut * step_s, rpm, feed))
            if cut < sub:
                segments.append(((sub - cut) * step_s, 0.0, 0.0))
        starts.append(cursor)
        name = f"B{b + 1}"
        metas.append(
            {
                "run": name,
                "spindle_rpm": rpm,
                "feed_mm_min": feed,
                "cut_fraction": cut / sub,
                "rest_before_h": rest_cycles * cycle_s / 3600.0,
                "start_h": cursor * step_s / 3600.0,
                "description": (
                    f"{batch_h:g} h of {cycle_min:g}-minute cycles, cutting "
                    f"{cut / sub:.0%} of each at {rpm:.0f} rpm, feed {feed:.0f} mm/min"
                ),
            }
        )
        cursor += n_cycles * sub
    ambient = AmbientProfile(
        mean_C=20.0,
        day_amplitude_C=day_amplitude_C,
        start_hour=6.0,
        noise_C=0.1,
        noise_tau_min=60.0,
    )
    whole = machine.simulate(
        DutyCycle(segments),
        ambient,
        sample_period_s=step_s,
        run="campaign",
        noise=noise,
        random_state=rng,
    )
    frames = []
    for start, meta in zip(starts, metas, strict=True):
        rows = start + sub * np.arange(n_cycles + 1)
        frame = whole.iloc[rows].copy()
        frame[RUN_COLUMN] = meta["run"]
        frame[TIME_COLUMN] = frame[TIME_COLUMN] - frame[TIME_COLUMN].iloc[0]
        frames.append(frame)
    runs = pd.concat(frames, ignore_index=True)
    runs.attrs.clear()
    base = machine.run_metadata("campaign")
    runs.attrs["metadata"] = [{**base, **meta} for meta in metas]
    return runs
