"""Command line: ``skthermal gap --simulated sim.csv --runs real.csv``."""

import numpy as np
import pandas as pd
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
    # Where, not only which: the run, channel, regime and jumps.
    assert "Where (as given):\n  run " in text and "\n  channel " in text
    assert "\n  regime " in text


def test_gap_n_jobs_gives_the_same_report(tables, capsys):
    sim, meas = tables
    argv = ["gap", "--simulated", str(sim), "--runs", str(meas), "--quiet"]
    argv += ["--candidates", "tool_growth,sensor_drift"]
    outputs = []
    for n_jobs in ("1", "2"):
        assert main([*argv, "--n-jobs", n_jobs]) == 0
        outputs.append(capsys.readouterr().out)
    assert outputs[0] == outputs[1] and "'tool_growth' explains the gap" in outputs[0]
    assert main([*argv, "--n-jobs", "0"]) == 2
    assert "--n-jobs must be 1 or more" in capsys.readouterr().err


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
    # Without the air's column: the table's columns summed up, not cut off
    # before its sensors.
    frame = pd.read_csv(meas).drop(columns="ambient_C")
    frame.to_csv(bad, index=False)
    assert main(["gap", "--simulated", str(sim), "--runs", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no ambient_C column" in err and "temperature column(s) (" in err, err


def test_gap_without_candidates_is_one_line(tables, capsys):
    # Both modes: an empty --candidates is an error, not a traceback.
    sim, meas = tables
    for extra in (["--preset", "spindle-rig"], ["--simulated", str(sim)]):
        args = ["gap", "--runs", str(meas), *extra, "--candidates", "", "--quiet"]
        assert main(args) == 2
        err = capsys.readouterr().err
        assert "give at least one" in err.lower() and len(err.strip().splitlines()) == 1


# --- run tables, options and messages of 'skthermal gap' ---------------------


def _write(frame, path):
    frame.to_csv(path, index=False)
    return str(path)


def test_gap_simulated_displacement_only_tables(tables, tmp_path, capsys):
    # No T*_C column on either side: the diagnosis compares the displacements
    # (the run-table rule "at least one sensor" does not apply here).
    import pandas as pd

    sim, meas = tables
    drop = ["T1_C", "T2_C"]
    sim_d = _write(pd.read_csv(sim).drop(columns=drop), tmp_path / "sim_d.csv")
    meas_d = _write(pd.read_csv(meas).drop(columns=drop), tmp_path / "real_d.csv")
    argv = ["gap", "--simulated", sim_d, "--runs", meas_d, "--quiet"]
    status = main([*argv, "--candidates", "tool_growth", "--max-samples", "120"])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert "temperature sensor" not in err and "tool_growth" in out


def test_gap_simulated_mapping_and_channels(tables, tmp_path, capsys):
    # The simulation names its channels its own way: --mapping pairs them.
    import pandas as pd

    sim, meas = tables
    renamed = pd.read_csv(sim).rename(
        columns={"T1_C": "sensor1", "T2_C": "sensor2", "disp_z_um": "dz"}
    )
    sim_r = _write(renamed, tmp_path / "sim_r.csv")
    base = ["gap", "--simulated", sim_r, "--runs", str(meas), "--quiet"]
    base += ["--candidates", "tool_growth", "--max-samples", "120"]
    assert main(base) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "--mapping" in err and "mapping=" not in err and "channels=" not in err
    status = main([*base, "--mapping", "T1_C=sensor1,disp_z_um=dz"])
    out, err = capsys.readouterr()
    assert status == 0, err
    # T2_C is left out: the warning names the options, not Python arguments.
    assert "T2_C" in err and "--mapping" in err and "mapping={" not in err
    assert "--channels" in err
    status = main([*base, "--mapping", "disp_z_um=dz", "--channels", "disp_z_um"])
    out, err = capsys.readouterr()
    assert status == 0 and "warning" not in err, err
    # Another tool's names holding commas (no way to give them before):
    # each such pair in its own --mapping, or a JSON object; between two
    # pairs of one value, a comma could belong to either name: an error.
    sim_c = _write(
        renamed.rename(columns={"sensor1": "Temp, front [C]", "sensor2": "T, rear"}),
        tmp_path / "sim_c.csv",
    )
    base[2] = sim_c
    assert main([*base, "--mapping", "T1_C=Temp, front [C],T2_C=T, rear"]) == 2
    err = capsys.readouterr().err
    assert "'front [C]' may end one name or start the next" in err, err
    for mapping in (
        ["--mapping", "T1_C=Temp, front [C]", "--mapping", "T2_C=T, rear"]
        + ["--mapping", "disp_z_um=dz"],
        ["--mapping", '{"T1_C": "Temp, front [C]", "T2_C": "T, rear"}']
        + ["--mapping", "disp_z_um=dz"],
    ):
        status = main([*base, *mapping])
        out, err = capsys.readouterr()
        assert status == 0 and "warning" not in err, (mapping, err)


@pytest.mark.parametrize(
    "extra, expected",
    [
        (["--mapping", "T1_C"], "is not MEASURED=SIMULATED"),
        (["--mapping", "T1_C=a,T1_C=b"], "mapped twice"),
        (["--mapping", "T1_C=a", "--mapping", "T1_C=b"], "mapped twice"),
        (["--mapping", '{"T1_C": 1}'], "not a JSON object of names"),
        (["--channels", "T1_C,T1_C"], "named more than once"),
        (["--max-samples", "2"], "--max-samples must be at least 3"),
        (["--block-hours", "0"], "--block-hours must be positive"),
    ],
)
def test_gap_option_errors_are_one_line(tables, capsys, extra, expected):
    sim, meas = tables
    for mode in (["--simulated", str(sim)], ["--preset", "vmc-b"]):
        assert main(["gap", "--runs", str(meas), *mode, *extra, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert expected in err and len(err.strip().splitlines()) == 1, err
        assert err.startswith("skthermal gap: error: ")


def test_gap_table_needs_drivers_and_numbers(tables, tmp_path, capsys):
    import pandas as pd

    sim, meas = tables
    frame = pd.read_csv(meas)
    no_air = _write(frame.drop(columns="ambient_C"), tmp_path / "no_air.csv")
    assert main(["gap", "--runs", no_air, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--runs" in err and "ambient_C" in err
    assert len(err.strip().splitlines()) == 1
    frame["spindle_rpm"] = frame["spindle_rpm"].astype(object)
    frame.loc[5, "spindle_rpm"] = "fast"
    text = _write(frame, tmp_path / "text.csv")
    assert main(["gap", "--simulated", str(sim), "--runs", text, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "'spindle_rpm' holds text" in err and "'fast'" in err
    assert len(err.strip().splitlines()) == 1
    # Per-run files joined with their headers: a header line inside.
    lines = open(meas).read().splitlines()
    joined = tmp_path / "joined.csv"
    joined.write_text("\n".join([*lines[:40], lines[0], *lines[40:]]) + "\n")
    assert main(["gap", "--simulated", str(sim), "--runs", str(joined)]) == 2
    err = capsys.readouterr().err
    assert "repeats the header line" in err
    assert len(err.strip().splitlines()) == 1


class _FakeReport:
    """A machine-mode report whose screening says True and whose fine step
    (the verdict) says no."""

    ranking = pd.DataFrame(
        {
            "effect": ["tool_growth"],
            "gap_before": [0.067],
            "gap_after": [0.028],
            "shrink": [0.63],
            "p_value": [0.039],
            "explains": [True],
        }
    )
    how_far = pd.DataFrame(
        {
            "effect": ["tool_growth"] * 2,
            "regime": ["heating", "overall"],
            "gap_before": [0.07, 0.0638],
            "gap_after": [0.02, 0.023],
            "shrink": [0.8, 0.70],
            "shrink_raw": [0.7, 0.64],
        }
    )
    how_far_evidence = {
        "effect": "tool_growth",
        "calibration": "fine",
        "p_value": 0.064,
        "runs_improved": 3,
        "n_runs": 3,
    }
    best_effect = None

    def verdict(self):
        return "No candidate effect explains the gap beyond noise (...)."

    def where_summary(self, model=None):
        return f"Where ({model or 'default'}):\n  run 'A': gap 0.1 [norm.]"


def test_gap_labels_the_screening_and_prints_how_far(tables, capsys, monkeypatch):
    import skthermal.gap as gap

    seen = {}

    def fake(machine, runs, candidates=None, **kwargs):
        seen.update(kwargs, columns=list(runs.columns))
        return _FakeReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    sim, meas = tables
    status = main(["gap", "--runs", str(meas), "--quiet"])
    out = capsys.readouterr().out
    assert status == 0
    assert "explains (screening)" in out and "Which effect (screening" in out
    how_far = out[out.index("How far") :].splitlines()
    assert "0.064" in how_far[2] and "False" in how_far[2] and "3/3" in how_far[2]
    assert seen.keys() == {"columns"}  # the library's defaults stay its own


def test_gap_machine_options_reach_diagnose(tables, tmp_path, capsys, monkeypatch):
    # A displacement-only table (no T*_C), one long record: --block-hours,
    # --channels, --mapping and --max-samples are passed on.
    import pandas as pd

    import skthermal.gap as gap

    seen = {}

    def fake(machine, runs, candidates=None, **kwargs):
        seen.update(kwargs, columns=list(runs.columns))
        return _FakeReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    sim, meas = tables
    frame = pd.read_csv(meas).drop(columns=["T1_C", "T2_C"])
    disp = _write(frame, tmp_path / "disp.csv")
    argv = ["gap", "--runs", disp, "--quiet", "--block-hours", "8"]
    argv += ["--channels", "disp_z_um", "--mapping", "disp_z_um=disp_y_um"]
    assert main([*argv, "--max-samples", "150"]) == 0, capsys.readouterr().err
    assert seen["block_hours"] == 8.0 and seen["max_samples"] == 150
    assert seen["channels"] == ["disp_z_um"]
    assert seen["mapping"] == {"disp_z_um": "disp_y_um"}
    assert "T1_C" not in seen["columns"]


def test_gap_one_record_points_to_block_hours(tables, tmp_path, capsys):
    import pandas as pd

    sim, meas = tables
    one = pd.read_csv(meas)
    one = _write(one[one["run"] == "r0"], tmp_path / "one.csv")
    argv = ["gap", "--runs", one, "--preset", "vmc-b", "--quiet"]
    argv += ["--channels", "disp_z_um", "--mapping", "disp_z_um=disp_y_um"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "at least 2 runs (got 1)" in err
    # One hint, sized to the record (it lasts 3.98 h).
    assert err.count("--block-hours") == 2 and "--block-hours 1.3 for 3" in err
    assert len(err.strip().splitlines()) == 1


def test_gap_block_hours_with_simulated(tables, capsys):
    import inspect

    from skthermal.gap import diagnose_runs

    sim, meas = tables
    argv = ["gap", "--simulated", str(sim), "--runs", str(meas), "--quiet"]
    argv += ["--candidates", "tool_growth", "--max-samples", "100"]
    status = main([*argv, "--block-hours", "2"])
    err = capsys.readouterr().err
    if "block_hours" in inspect.signature(diagnose_runs).parameters:
        assert status == 0, err
    else:
        assert status == 2 and "--block-hours is not available" in err


@pytest.mark.parametrize("command", [["gap"], ["gap-check"]])
def test_gap_list_effects(command, tables, capsys):
    assert main([*command, "--list-effects"]) == 0
    out = capsys.readouterr().out
    assert "tool_growth" in out and "sensor_drift" in out
    # The errors that point there name an option that exists.
    assert main(["gap", "--runs", str(tables[1]), "--candidates", "bogus"]) == 2
    assert "see --list-effects" in capsys.readouterr().err


def test_gap_needs_runs(capsys):
    assert main(["gap", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--runs FILE is required" in err and len(err.strip().splitlines()) == 1


def test_cli_words():
    from skthermal._cli._gap import cli_words

    text = cli_words(
        "Map them with mapping={'measured': 'simulated'}, or pass channels= to "
        "choose; pass channels= or mapping=. leave them out of channels=."
    )
    assert "mapping=" not in text and "channels=" not in text
    assert "--mapping MEASURED=SIMULATED" in text and text.count("--channels") == 3
    assert cli_words("give block_hours below 3 h") == "give --block-hours below 3 h"


def test_gap_driver_initial_reaches_diagnose_runs(tables, capsys, monkeypatch):
    import skthermal.gap as gap

    seen = {}

    def fake(simulated, measured, candidates=None, **kwargs):
        seen.update(kwargs)
        return _FakeReport()

    monkeypatch.setattr(gap, "diagnose_runs", fake)
    sim, meas = tables
    argv = ["gap", "--simulated", str(sim), "--runs", str(meas), "--quiet"]
    assert main(argv) == 0, capsys.readouterr().err
    assert "driver_initial" not in seen  # the library's default stays its own
    assert main([*argv, "--driver-initial", "steady"]) == 0
    assert seen["driver_initial"] == "steady"
    # With a machine, the simulator's --initial sets the start instead.
    argv = ["gap", "--preset", "vmc-b", "--runs", str(meas), "--quiet"]
    assert main([*argv, "--driver-initial", "rest"]) == 2
    err = capsys.readouterr().err
    assert "--driver-initial is used with --simulated" in err
    assert len(err.strip().splitlines()) == 1
