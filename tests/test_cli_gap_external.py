"""Command line: ``skthermal gap --simulated sim.csv --runs real.csv``."""

import numpy as np
import pytest

from skthermal.cli import main
from tests.test_gap_external import _tables


@pytest.fixture
def tables(tmp_path):
    sim, meas = _tables(np.random.default_rng(3), "tool_growth", n_runs=3, hours=4.0)
    sim_path, meas_path = tmp_path / "sim.csv", tmp_path / "real.csv"
    sim.to_csv(sim_path, index=False)
    meas.to_csv(meas_path, index=False)
    return sim_path, meas_path


def test_gap_simulated_names_the_effect(tables, capsys):
    sim, meas = tables
    status = main(
        [
            "gap",
            "--simulated",
            str(sim),
            "--runs",
            str(meas),
            "--candidates",
            "tool_growth,feed_heating,sensor_drift",
            "--quiet",
        ]
    )
    assert status == 0
    text = capsys.readouterr().out
    assert "'tool_growth' explains the gap" in text
    assert "share_of_explainable" in text and "lr_p_value" in text


def test_gap_simulated_errors_are_one_line(tables, tmp_path, capsys):
    sim, meas = tables
    missing = tmp_path / "nope.csv"
    assert main(["gap", "--simulated", str(missing), "--runs", str(meas)]) == 2
    err = capsys.readouterr().err
    assert "--simulated: no such file" in err and len(err.strip().splitlines()) == 1
    import pandas as pd

    frame = pd.read_csv(sim)
    frame.loc[frame["run"] == "r1", "spindle_rpm"] += 100.0
    bad = tmp_path / "bad.csv"
    frame.to_csv(bad, index=False)
    assert main(["gap", "--simulated", str(bad), "--runs", str(meas), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "spindle_rpm in run 'r1'" in err and len(err.strip().splitlines()) == 1
    args = ["gap", "--simulated", str(sim), "--runs", str(meas), "--effects", "x"]
    assert main(args) == 2
    assert "--effects is not used with --simulated" in capsys.readouterr().err


def test_gap_without_candidates_is_one_line(tables, capsys):
    # Both modes: an empty --candidates is an error, not a traceback.
    sim, meas = tables
    for extra in (["--preset", "spindle-rig"], ["--simulated", str(sim)]):
        args = ["gap", "--runs", str(meas), *extra, "--candidates", "", "--quiet"]
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "give at least one" in err.lower() and len(err.strip().splitlines()) == 1
