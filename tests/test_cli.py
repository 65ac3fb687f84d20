"""Tests of the ``skthermal`` command."""

import subprocess
import sys

import pandas as pd
import pytest

from skthermal.cli import main


def test_demo_runs_and_finds_one_sensor_per_group(capsys, tmp_path):
    assert main(["demo", "--seed", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "FCMClusterPicker kept 3 of 40 sensors" in out
    assert "NOISE" not in out
    scores = pd.read_csv(tmp_path / "scores.csv")
    assert set(scores["test run"]) == {"run1", "run2", "run3", "run4"}
    picker = scores[scores["model"].str.startswith("FCM picker")]
    assert picker["RMSE (µm)"].mean() < 1.0
    runs = pd.read_csv(tmp_path / "runs.csv")
    assert runs.shape == (4 * 360, 43)


def test_user_error_is_one_line_and_exit_2(capsys):
    assert main(["demo", "--runs", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--runs must be at least 2" in err


def test_module_entry_point_and_help():
    res = subprocess.run(
        [sys.executable, "-m", "skthermal", "demo", "--help"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert res.returncode == 0 and "--sensors-per-group" in res.stdout


def test_unknown_command_exits_nonzero(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["nope"])
    assert exc.value.code == 2
