"""The independent truth machine of benchmarks/truth (used by the gap benchmark)."""

import numpy as np
import pytest

from benchmarks.truth import CASES, EFFECTS, Block, TruthMachine, make_truth_campaign
from benchmarks.truth.campaign import random_room
from skthermal.datasets import validate_runs

VMC_B_COLUMNS = [
    "run",
    "time_s",
    "spindle_rpm",
    "feed_mm_min",
    "ambient_C",
    *[f"T{n:02d}_C" for n in range(1, 78)],
    "disp_x_um",
    "disp_y_um",
    "disp_z_um",
]

BLOCKS = [
    Block(2400, 7000, 3000, coolant=True, stroke=(0.4, 0.2)),
    Block(1800, 0),
    Block(1800, 4000, 0, coolant=False),
]


def test_campaign_is_a_valid_run_table_with_vmc_b_columns():
    runs, truth = make_truth_campaign(
        "feed_heating", n_runs=2, hours=(1.0, 1.5), random_state=0
    )
    validate_runs(runs, require_targets=True, require_drivers=True)
    assert list(runs.columns) == VMC_B_COLUMNS
    assert runs["run"].nunique() == 2
    assert np.isfinite(runs.drop(columns="run").to_numpy(float)).all()
    assert truth.effects[0].name == "feed_heating"


def test_constant_power_gives_bounded_monotone_rise_to_steady_state():
    truth = TruthMachine(random_state=1)
    block = Block(400 * 3600, 6000)
    t = np.arange(0.0, 400 * 3600 + 1, 600.0)
    T = truth.node_temperatures([block], t, {"room": np.full(t.size, 20.0)})
    steady = truth.steady_state(block, 20.0)
    assert (np.diff(T, axis=0) >= -1e-9).all()
    assert (T <= steady + 1e-6).all()
    np.testing.assert_allclose(T[-1], steady, atol=0.05)
    rise = steady - 20.0
    assert 3.0 < rise.max() < 40.0
    # Energy balance at equilibrium: the heat put in leaves to the room.
    net = truth.block_net(block)
    K, b, q = truth._assemble(net)
    assert q.sum() == pytest.approx(b["room"] @ rise, rel=1e-9)


def test_displacements_and_rises_are_realistic():
    truth = TruthMachine(random_state=2)
    df = truth.run_table([Block(4 * 3600, 6000), Block(4 * 3600, 0)], 20.0, noise=False)
    temps = df.filter(regex=r"^T\d+_C$")
    rise = (temps - temps.iloc[0]).max()
    assert 3.0 < rise.max() < 20.0
    disp = df.filter(like="disp_").abs().max()
    assert 10.0 < disp[["disp_y_um", "disp_z_um"]].min()
    assert disp.max() < 150.0


@pytest.mark.parametrize("name", list(EFFECTS))
def test_each_effect_changes_the_output(name):
    room = random_room(np.random.default_rng(0), 1)
    base = TruthMachine(random_state=3)
    with_effect = TruthMachine([EFFECTS[name](4)], random_state=3)
    a = base.run_table(BLOCKS, room, noise=False, random_state=5)
    b = with_effect.run_table(BLOCKS, room, noise=False, random_state=5)
    channels = [c for c in a.columns if c.startswith(("T", "disp_"))]
    assert a[["spindle_rpm", "feed_mm_min", "ambient_C"]].equals(
        b[["spindle_rpm", "feed_mm_min", "ambient_C"]]
    )
    assert np.abs(a[channels].to_numpy() - b[channels].to_numpy()).max() > 0.1


def test_cases_cover_the_vocabulary_null_and_out_of_vocabulary():
    assert {
        "sensor_lag",
        "speed_convection",
        "tool_growth",
        "ambient_transient",
        "feed_heating",
        "sensor_drift",
        "null",
        "coolant",
    } == set(CASES)
    assert not EFFECTS["coolant"].in_vocabulary
