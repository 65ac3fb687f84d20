"""Random test campaigns for the truth machine.

Each run is 5-7 h of random duty: spindle blocks of 25-100 min at speeds
drawn uniformly in 1500-10000 rpm (steps of 250), rests of 15-70 min, feed
blocks while cutting (and some traverse exercise at rest), flood coolant in
some cutting blocks (hidden from the run table), a room air with a daily
swing, a slow wander and door events (drops of 1.5-4 K for 10-40 min).
"""

import numpy as np
import pandas as pd

from .effects import EFFECTS
from .vmc_truth import Block, TruthMachine

CASES = (*[k for k, v in EFFECTS.items() if v.in_vocabulary], "null", "coolant")


def random_blocks(rng, hours, sample_period_s=60.0):
    """Blocks of a random duty cycle of ``hours`` hours."""
    blocks, t, total = [], 0.0, hours * 3600
    on = bool(rng.integers(2))
    while t < total - 1:
        minutes = rng.uniform(25, 100) if on else rng.uniform(15, 70)
        d = min(
            max(
                sample_period_s, round(minutes * 60 / sample_period_s) * sample_period_s
            ),
            total - t,
        )
        rpm = float(np.round(rng.uniform(1500, 10000) / 250) * 250) if on else 0.0
        if on and rng.random() < 0.55:
            feed = float(np.round(rng.uniform(800, 5000), -2))
        elif not on and rng.random() < 0.15:
            feed = float(np.round(rng.uniform(2000, 6000), -2))
        else:
            feed = 0.0
        stroke = (rng.uniform(0.3, 0.7), rng.uniform(0.1, 0.3))
        coolant = bool(on and rng.random() < 0.5)
        blocks.append(Block(d, rpm, feed, coolant, stroke))
        t += d
        on = not on
    return blocks


def random_room(rng, n_doors):
    """Room air (°C) as a function of time, with ``n_doors`` door events."""
    base = rng.uniform(18, 24)
    amp = rng.uniform(0.5, 2.0)
    phase = rng.uniform(0, 24 * 3600)
    doors = [
        (rng.uniform(0.5, 5.0) * 3600, rng.uniform(1.5, 4.0), rng.uniform(600, 2400))
        for _ in range(n_doors)
    ]
    knots = rng.standard_normal(16).cumsum() * 0.08

    def room(t):
        t = np.asarray(t, dtype=float)
        T = base + amp * np.sin(2 * np.pi * (t + phase) / 86400)
        T = T + np.interp(t, np.linspace(0, 8 * 3600, knots.size), knots)
        for start, drop, length in doors:
            inside = (t >= start) & (t < start + length)
            after = t >= start + length
            T = T - drop * inside
            T = T - drop * after * np.exp(-(t - start - length) / 600.0)
        return T

    return room


def warm_run_table(machine, pre, blocks, room, **kwargs):
    """``machine.run_table(blocks, room, **kwargs)`` after the earlier work
    ``pre`` (blocks, possibly none).

    The machine runs ``pre`` and then ``blocks`` from soaked; the rows of
    ``pre`` are cut off and the clock restarts at the run's first sample.
    ``room`` is the run's air as a function of the run's clock (earlier
    times are negative).
    """
    if not pre:
        return machine.run_table(blocks, room, **kwargs)
    t_pre = sum(b.duration_s for b in pre)
    table = machine.run_table(
        list(pre) + list(blocks),
        lambda t: room(np.asarray(t) - t_pre),
        **kwargs,
    )
    table = table[table["time_s"] >= t_pre - 1e-6].reset_index(drop=True)
    table["time_s"] = table["time_s"] - t_pre
    return table


def make_truth_campaign(
    case,
    *,
    n_runs=4,
    hours=(5.0, 7.0),
    sample_period_s=60.0,
    prehistory_hours=0.0,
    random_state=None,
):
    """Noisy measured-like runs of a truth machine with one effect (or none).

    Parameters
    ----------
    case : str
        An effect of ``benchmarks.truth.effects.EFFECTS`` or ``"null"``.
    n_runs : int, default=4
    hours : (float, float), default=(5, 7)
        Range of the runs' lengths.
    sample_period_s : float, default=60.0
    prehistory_hours : float, default=0.0
        Random duty the machine runs before each run's first sample: with
        0 every run starts soaked at its first air reading; with more, it
        starts warm from earlier work (the state a real test usually starts
        in). The earlier work is simulated on the same machine, effects
        included, and cut off; the run's clock, displacements and duty start
        at its first sample. The other random draws do not change with it.
    random_state : int or None

    Returns
    -------
    runs : DataFrame
        The run table (vmc-b's columns).
    truth : TruthMachine
    """
    rng = np.random.default_rng(random_state)
    if case != "null" and case not in EFFECTS:
        raise ValueError(f"Unknown case {case!r}; expected one of {CASES}.")
    effects = [] if case == "null" else [EFFECTS[case](rng.integers(2**32))]
    truth = TruthMachine(effects, random_state=rng.integers(2**32))
    doors = rng.poisson(0.8, n_runs)
    if doors.sum() == 0:
        doors[0] = 1
    # Its own stream (spawning leaves ``rng``'s draws as they were).
    pre_rng = rng.spawn(1)[0] if prehistory_hours > 0 else None
    tables = []
    for i in range(n_runs):
        h = np.round(rng.uniform(*hours) * 60) / 60
        blocks = random_blocks(rng, h, sample_period_s)
        room = random_room(rng, doors[i])
        pre = (
            random_blocks(pre_rng, prehistory_hours, sample_period_s)
            if pre_rng is not None
            else []
        )
        tables.append(
            warm_run_table(
                truth,
                pre,
                blocks,
                room,
                sample_period_s=sample_period_s,
                run=f"run{i + 1}",
                random_state=rng.integers(2**32),
            )
        )
    return pd.concat(tables, ignore_index=True), truth
