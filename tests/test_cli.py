"""Tests of the ``skthermal`` command."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
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


def test_an_unknown_option_is_the_commands_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--quick"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err == (
        "skthermal demo: error: unrecognized arguments: --quick "
        "(see 'skthermal demo --help')\n"
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (["demo", "--seed", "-1"], "argument --seed: must be an integer from 0 to"),
        (["reproduce", "--seed", "x"], "argument --seed: must be an integer, got 'x'"),
        (["demo", "--noise-sensors", "-1"], "--noise-sensors: must be 0 or more"),
    ],
)
def test_options_are_checked_in_their_own_words(capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_reproduce_refuses_an_empty_model_list(capsys, tmp_path):
    assert main(["reproduce", "--models", " , ", "--out", str(tmp_path / "r")]) == 2
    assert "--models names no model" in capsys.readouterr().err


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


# --------------------------------------------------------------------------
# The workflow subcommands on small simulated data
# --------------------------------------------------------------------------

SUBCOMMANDS = [
    "reproduce",
    "simulate",
    "select",
    "fit",
    "predict",
    "evaluate",
    "search",
    "gap",
    "gap-check",
    "demo",
]


def _run(capsys, *argv):
    """``main(argv)``: (status, stdout, stderr)."""
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """Tests I, IV, V of Machine B (4-minute sampling) and one extra run."""
    folder = tmp_path_factory.mktemp("cli")
    runs = folder / "tests.csv"
    argv = ["simulate", "--tests", "I,IV,V", "--sample-period", "240"]
    assert main([*argv, "--out", str(runs)]) == 0
    extra = ["simulate", "--segment", "6000:1h:1500,0:30min", "--run", "extra"]
    extra += ["--ambient-trend", "0.5", "--sample-period", "240", "--append"]
    assert main([*extra, "--out", str(runs)]) == 0
    return folder


def test_run_labels_with_spaces_can_be_chosen(capsys, tmp_path):
    # Commas separate labels; a label may hold spaces.
    runs = tmp_path / "r.csv"
    for label in ("test 1", "test 2"):
        argv = ["simulate", "--segment", "6000:2h", "--sample-period", "240"]
        argv += ["--run", label, "--append", "--out", runs]
        assert _run(capsys, *argv)[0] == 0
    fit = ["fit", "--runs", runs, "--model", "ridge", "--sensors", "T05_C,T40_C"]
    fit += ["--out", tmp_path / "m.joblib", "--train-runs"]
    status, _, err = _run(capsys, *fit, "test 1, test 2")
    assert status == 0, err
    status, _, err = _run(capsys, *fit, "test 3")
    assert status == 2 and "run(s) ['test 3'] are not in the table" in err
    status, _, err = _run(capsys, *fit, " , ")  # a numpy error before
    assert status == 2 and "--train-runs ' , ' names no run" in err
    # A label the lists could not name is refused where it is made.
    argv = ["simulate", "--segment", "3000:20min", "--run", "a,b"]
    status, _, err = _run(capsys, *argv, "--out", tmp_path / "c.csv")
    assert status == 2 and "without commas" in err


def test_a_run_label_with_a_comma_is_chosen_whole(capsys, tmp_path):
    # Runs 'A,1', 'A' and '1' (a table made elsewhere): --train-runs "A,1"
    # trained on runs A and 1, without a word, and 'A,1' could not be named.
    from skthermal.datasets import concat_runs, read_runs, write_runs

    runs = tmp_path / "r.csv"
    argv = ["simulate", "--segment", "6000:1h,0:30min", "--sample-period", "240"]
    assert _run(capsys, *argv, "--out", runs)[0] == 0
    one = read_runs(runs)
    table = concat_runs([one.assign(run=label) for label in ("A,1", "A", "1")])
    write_runs(table, runs)
    fit = ["fit", "--runs", runs, "--model", "ridge", "--sensors", "T05_C,T40_C"]
    fit += ["--out", tmp_path / "m.joblib", "--train-runs"]
    status, text, err = _run(capsys, *fit, "A,1")
    assert status == 0, err
    assert "runs A,1;" in text and "runs A, 1" not in text
    status, text, err = _run(capsys, *fit, "A, 1")  # as separated labels
    assert status == 0 and "runs A, 1;" in text
    for given in ("A,1,B", "B,A,1"):  # with other runs: the longest label
        table = concat_runs([one.assign(run=label) for label in ("A,1", "B")])
        write_runs(table, runs)
        status, text, err = _run(capsys, *fit, given)
        assert status == 0, err
        assert "runs A,1, B;" in text


def test_run_lists_read_labels_with_commas_every_way_they_can():
    # Labels A, 'A,B' and 'B,C': taking the longest label first read
    # "A,B,C" as 'A,B' and an unknown 'C'.
    from skthermal._cli._common import split_list

    labels = ["A", "A,B", "B,C"]
    assert split_list("A,B,C", keep=labels) == ["A", "B,C"]
    assert split_list("A,B", keep=labels) == ["A,B"]
    assert split_list("B,C, A", keep=labels) == ["B,C", "A"]
    assert split_list("A,B,C,D", keep=labels) == ["A", "B,C", "D"]
    assert split_list(["A,B", " x "], keep=[]) == ["A", "B", "x"]
    # A label holding a comma after ", " or with spaces around it.
    assert split_list("B, A,1", keep={"A,1", "B"}) == ["B", "A,1"]
    assert split_list(" A,1 ", keep={"A,1"}) == ["A,1"]


def test_whole_float_run_labels_are_named_as_integers(capsys, tmp_path):
    # A Parquet table's float labels 1.0, 2.0: --train-runs 1,2 said they
    # were not in the table (runs ['1.0', '2.0']), while the estimators
    # take 1.0 and 1 for the same run.
    pytest.importorskip("pyarrow")
    from skthermal.datasets import concat_runs, read_runs

    csv = tmp_path / "r.csv"
    argv = ["simulate", "--segment", "6000:1h,0:30min", "--sample-period", "240"]
    assert _run(capsys, *argv, "--out", csv)[0] == 0
    one = read_runs(csv)
    table = concat_runs([one.assign(run=float(k)) for k in (1, 2, 3)])
    table.to_parquet(tmp_path / "r.parquet")
    fit = ["fit", "--runs", tmp_path / "r.parquet", "--model", "ridge", "--quick"]
    fit += ["--sensors", "T05_C,T40_C", "--out", tmp_path / "m.joblib"]
    status, text, err = _run(capsys, *fit, "--train-runs", "1,2")
    assert status == 0, err


@pytest.mark.parametrize(
    "true, false, chosen",
    [
        ("True", "False", 2),
        ("yes", "no", 2),
        ("1.0", "0.0", 2),
        ("WAHR", "FALSCH", "row 1 has selected = 'WAHR'"),
        ("x", "", "row 1 has selected = 'x'"),
    ],
)
def test_a_sensors_file_edited_by_hand_selects_what_it_says(
    capsys, workdir, tmp_path, true, false, chosen
):
    # 'selected' read with astype(bool): any non-empty text was True, so a
    # file saved by a German spreadsheet (WAHR/FALSCH) trained on every
    # sensor listed, silently.
    sensors = tmp_path / "sensors.csv"
    flags = [true, false, true, false]
    pd.DataFrame(
        {"sensor": ["T05_C", "T40_C", "T70_C", "T20_C"], "selected": flags}
    ).to_csv(sensors, index=False)
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "ridge", "--quick"]
    argv += ["--sensors", sensors, "--out", tmp_path / "m.joblib"]
    status, text, err = _run(capsys, *argv)
    if isinstance(chosen, int):
        assert status == 0, err
        assert f"on {chosen} sensor(s)" in text
    else:
        assert status == 2 and chosen in err and "True or False" in err


def test_simulate_refuses_a_segment_too_long_to_hold(capsys, tmp_path):
    # It printed numpy's MemoryError traceback (894 GiB).
    argv = ["simulate", "--preset", "spindle-rig", "--segment", "4000:1e9h"]
    status, _, err = _run(capsys, *argv, "--out", tmp_path / "s.csv")
    assert status == 2 and "more than skthermal simulates in one run" in err
    assert "Traceback" not in err and not (tmp_path / "s.csv").exists()


def test_simulate_writes_a_valid_run_table(workdir):
    from skthermal.datasets import read_runs

    runs, meta = read_runs(workdir / "tests.csv", metadata=True)
    assert list(pd.unique(runs["run"])) == ["I", "IV", "V", "extra"]
    assert meta["run"].tolist() == ["I", "IV", "V", "extra"]
    extra = runs[runs["run"] == "extra"]
    assert extra["feed_mm_min"].max() == 1500
    assert extra["spindle_rpm"].max() == 6000


def test_simulate_segments_effects_and_list(capsys, tmp_path):
    out = tmp_path / "one.csv.gz"
    status, text, _ = _run(
        capsys,
        "simulate",
        "--preset",
        "vmc-a",
        "--segment",
        "3000:20min",
        "--segment",
        "0:600s",
        "--effects",
        "none",
        "--no-noise",
        "--sample-period",
        "60",
        "--out",
        out,
    )
    assert status == 0 and "1 run(s) (run1), 31 rows" in text
    status, text, _ = _run(capsys, "simulate", "--list-effects")
    assert status == 0 and "tool_growth" in text


def _write_rig_file(tmp_path, **change):
    from skthermal.simulate import ThermalMachine

    data = ThermalMachine.from_preset("spindle-rig").spec.to_dict()
    data.update(change)
    from skthermal.simulate import MachineSpec

    path = tmp_path / "rig.toml"
    MachineSpec.from_dict(data).to_toml(path)
    return path


def test_simulate_and_gap_use_a_machine_file(capsys, tmp_path, monkeypatch):
    machine_file = _write_rig_file(tmp_path, name="my-rig")
    out = tmp_path / "rig.csv"
    status, text, _ = _run(
        capsys,
        "simulate",
        "--machine",
        machine_file,
        "--segment",
        "3000:20min",
        "--segment",
        "0:10min",
        "--sample-period",
        "60",
        "--out",
        out,
    )
    assert status == 0 and f"machine {machine_file}" in text
    runs = pd.read_csv(out)
    assert "T16_C" in runs.columns and "disp_ch5_um" in runs.columns
    assert "T1" not in runs.columns and "disp_y_um" not in runs.columns

    gap = pytest.importorskip("skthermal.gap")
    seen = {}

    def fake(machine, runs, candidates=None):
        seen.update(name=machine.spec.name, targets=list(machine.targets))
        return _FakeGapReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    status, text, _ = _run(capsys, "gap", "--runs", out, "--machine", machine_file)
    assert status == 0 and seen["name"] == "my-rig"
    assert "disp_ch1_um" in seen["targets"]
    assert "(effects on: none)" in text  # the file records no switches

    # A machine written with its switches (a calibrated one) is diagnosed as
    # written; --effects still overrides.
    from skthermal.simulate import ThermalMachine

    written = tmp_path / "calibrated.toml"
    ThermalMachine.from_spec(machine_file, effects=["sensor_lag"]).to_spec().to_toml(
        written
    )
    status, text, _ = _run(capsys, "gap", "--runs", out, "--machine", written)
    assert status == 0 and "(effects on: sensor_lag)" in text
    argv = ["gap", "--runs", out, "--machine", written, "--effects", "none"]
    status, text, _ = _run(capsys, *argv)
    assert status == 0 and "(effects on: none)" in text


def test_bad_machine_file_is_one_user_error(capsys, tmp_path):
    status, _, err = _run(
        capsys, "simulate", "--machine", tmp_path / "none.toml", "--out", "x.csv"
    )
    assert status == 2 and "--machine: no such file" in err
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'rig'\nnodes = 3\n")
    status, _, err = _run(capsys, "simulate", "--machine", bad, "--out", "x.csv")
    assert status == 2 and err.count("\n") == 1
    assert "bad.toml" in err and "nodes must be a table" in err


_MINI_MACHINE = """\
name = "mini"
axes = ["z"]
[roles]
enclosure = "air"
tool = {tool}
[nodes.spindle]
capacity_J_per_K = 2000.0
convection_W_per_K = 0.5
[nodes.air]
capacity_J_per_K = 50000.0
convection_W_per_K = 40.0
[[links]]
between = ["spindle", "air"]
conductance_W_per_K = 5.0
[heat.bearing]
node = "spindle"
W_at_1000_rpm = 4.0
[displacement.z]
spindle = 2.0
{sensors}"""


def _mini_machine(tmp_path, name="mini.toml", *, tool='"spindle"', sensors=True):
    path = tmp_path / name
    block = '[sensors.T1_C]\nnode = "spindle"\n' if sensors else ""
    path.write_text(_MINI_MACHINE.format(tool=tool, sensors=block))
    return path


def test_machine_file_of_wrong_types_names_the_file(capsys, tmp_path, monkeypatch):
    # A list where a node name belongs: whatever the loader says, the one
    # line names the file.
    bad = _mini_machine(tmp_path, "tool_list.toml", tool='["spindle"]')
    argv = ["simulate", "--machine", bad, "--out", tmp_path / "x.csv"]
    status, _, err = _run(capsys, *argv)
    assert status == 2 and err.count("\n") == 1
    assert err.startswith("skthermal simulate: error: --machine") and str(bad) in err
    # An unexpected TypeError or KeyError of the loader is not shown bare.
    from skthermal.simulate import ThermalMachine

    good = _mini_machine(tmp_path)
    for exc in (TypeError("unhashable type: 'list'"), KeyError("between")):

        def fail(*args, exc=exc, **kwargs):
            raise exc

        monkeypatch.setattr(ThermalMachine, "from_spec", fail)
        argv = ["simulate", "--machine", good, "--out", tmp_path / "x.csv"]
        status, _, err = _run(capsys, *argv)
        assert status == 2 and err.count("\n") == 1
        assert f"--machine: could not read machine file {good}: " in err
        assert type(exc).__name__ in err


def test_machine_without_sensors_is_named(capsys, tmp_path):
    path = _mini_machine(tmp_path, sensors=False)
    out = tmp_path / "x.csv"
    status, _, err = _run(capsys, "simulate", "--machine", path, "--out", out)
    assert status == 2 and err.count("\n") == 1
    assert (
        f"error: the machine in {path} has no [sensors]: a run table needs at "
        "least one temperature sensor" in err
    )
    assert not out.exists()
    status, text, _ = _run(
        capsys,
        "simulate",
        "--machine",
        _mini_machine(tmp_path),
        "--segment",
        "1000:10min",
        "--sample-period",
        "60",
        "--out",
        out,
    )
    assert status == 0 and "T1_C" in pd.read_csv(out).columns


def test_simulate_help_options_are_in_the_docs(capsys):
    """docs/command_line.md names every option of ``simulate --help``."""
    import re

    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    options = set(re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", capsys.readouterr().out))
    docs = Path(__file__).parents[1] / "docs" / "command_line.md"
    text = docs.read_text(encoding="utf-8")
    section = text[text.index("### `simulate`") :]
    section = section[: section.index("\n### ", 1)]
    assert "--machine" in options and "--help" in options
    missing = sorted(o for o in options - {"--help"} if o not in section)
    assert not missing, f"simulate options missing from the docs: {missing}"
    assert "spindle-rig" in section and "skthermal simulate --machine" in section


def test_the_target_of_a_sensors_file_is_the_fit_s(capsys, workdir):
    # An independent check: fit --sensors of a file selected for disp_x_um
    # fitted disp_y_um (the default) on those sensors, silently; --target
    # given twice kept the last.
    runs, sensors = workdir / "tests.csv", workdir / "sensors_x.json"
    argv = ["select", "--runs", runs, "--target", "disp_x_um", "--out", sensors]
    assert _run(capsys, *argv)[0] == 0
    assert json.loads(sensors.read_text())["target"] == "disp_x_um"
    fit = ["fit", "--runs", runs, "--model", "ridge", "--sensors", sensors]
    status, text, err = _run(capsys, *fit, "--out", workdir / "x.joblib")
    assert status == 0 and "-> disp_x_um" in text, err
    status, _, err = _run(
        capsys, *fit, "--target", "disp_z_um", "--out", workdir / "z.joblib"
    )
    assert status == 2 and "were selected for 'disp_x_um'" in err, err
    with pytest.raises(SystemExit) as exited:  # a usage error, as argparse's
        _run(capsys, *fit[:-2], "--target", "disp_x_um", "--target", "disp_z_um")
    err = capsys.readouterr().err
    assert exited.value.code == 2 and "--target given twice" in err, err


def test_chained_guarded_predictions_keep_each_target_s_checks(capsys, workdir):
    # An independent check: predicting a second target from the first's
    # table overwrote guard_ok/action/reason (a spike the first model had
    # flagged vanished); predicting a target again left its old checks
    # beside the new prediction.
    runs = workdir / "tests.csv"
    models = {}
    for target in ("disp_y_um", "disp_x_um"):
        models[target] = workdir / f"guard_{target}.joblib"
        argv = ["fit", "--runs", runs, "--model", "ridge", "--target", target]
        argv += ["--guard", "clip", "--sensors", "T05_C,T40_C"]
        assert _run(capsys, *argv, "--out", models[target])[0] == 0
    first, second = workdir / "chain_y.csv", workdir / "chain_yx.csv"
    argv = ["predict", "--model", models["disp_y_um"], "--runs", runs]
    assert _run(capsys, *argv, "--out", first)[0] == 0
    assert "guard_ok" in pd.read_csv(first).columns
    argv = ["predict", "--model", models["disp_x_um"], "--runs", first]
    assert _run(capsys, *argv, "--out", second)[0] == 0
    chained = pd.read_csv(second)
    for target in ("disp_y_um", "disp_x_um"):
        assert {f"guard_ok_{target}", f"guard_reason_{target}"} <= set(chained)
    assert "guard_ok" not in chained.columns
    yonly = pd.read_csv(first)
    assert chained["guard_ok_disp_y_um"].tolist() == yonly["guard_ok"].tolist()
    # The y target predicted again without a guard: its old checks go.
    plain = workdir / "plain_y.joblib"
    argv = ["fit", "--runs", runs, "--model", "ridge", "--target", "disp_y_um"]
    assert _run(capsys, *argv, "--sensors", "T05_C,T40_C", "--out", plain)[0] == 0
    argv = ["predict", "--model", plain, "--runs", second]
    status, _, err = _run(capsys, *argv, "--out", workdir / "again.csv")
    assert status == 0 and "checked the earlier pred_disp_y_um" in err, err
    again = pd.read_csv(workdir / "again.csv")
    assert "guard_ok_disp_y_um" not in again and "guard_ok_disp_x_um" in again


def test_select_fit_predict_evaluate_chain(capsys, workdir):
    runs, sensors = workdir / "tests.csv", workdir / "sensors.json"
    status, text, _ = _run(
        capsys, "select", "--runs", runs, "--train-runs", "IV", "--out", sensors
    )
    assert status == 0 and "fcm: kept 5 of 77 sensors for disp_y_um" in text
    doc = json.loads(sensors.read_text())
    assert len(doc["sensors"]) == 5 and doc["train_runs"] == ["IV"]

    model = workdir / "anfis.joblib"
    status, text, _ = _run(
        capsys,
        "fit",
        "--runs",
        runs,
        "--train-runs",
        "IV",
        "--model",
        "anfis-fcm",
        "--sensors",
        sensors,
        "--out",
        model,
    )
    assert status == 0 and "Fitted ANFIS-FCM on 5 sensor(s)" in text

    pred = workdir / "pred.csv"
    status, _, _ = _run(
        capsys, "predict", "--model", model, "--runs", runs, "--out", pred
    )
    assert status == 0
    table = pd.read_csv(pred)
    assert "pred_disp_y_um" in table.columns
    assert (table.groupby("run")["pred_disp_y_um"].first() == 0).all()

    status, text, _ = _run(
        capsys, "evaluate", "--runs", pred, "--out", workdir / "s.md"
    )
    assert status == 0 and "mean" in text
    caption, blank, header, *_ = (workdir / "s.md").read_text().splitlines()
    assert "its residual the max over runs; all row: every sample" in caption
    assert not blank
    assert header.startswith("| run | n_samples | R |")
    status, _, _ = _run(
        capsys,
        "evaluate",
        "--runs",
        runs,
        "--predictions",
        pred,
        "--out",
        workdir / "s.csv",
    )
    scores = pd.read_csv(workdir / "s.csv").set_index("run")
    assert status == 0 and list(scores.index) == [
        "I",
        "IV",
        "V",
        "extra",
        "mean",
        "all",
    ]
    # every sample pooled: the runs' squared errors weighted by their length
    runs_only = scores.drop(["mean", "all"])
    pooled = (runs_only["RMSE_um"] ** 2 * runs_only["n_samples"]).sum()
    pooled /= runs_only["n_samples"].sum()
    assert scores.loc["all", "RMSE_um"] == pytest.approx(np.sqrt(pooled), rel=1e-9)
    assert scores.loc["I", "RMSE_um"] < 5.0
    status, _, _ = _run(
        capsys,
        "evaluate",
        "--runs",
        runs,
        "--model",
        model,
        "--out",
        workdir / "s2.csv",
    )
    again = pd.read_csv(workdir / "s2.csv").set_index("run")
    # The same runs' scores; the model's training run marked, and the mean
    # and pooled rows over the other runs.
    each = ["I", "IV", "V", "extra"]
    assert (
        again["fitted"].eq("yes").tolist() == [False, True, False, False] + [False] * 2
    )
    pd.testing.assert_frame_equal(
        again.drop(columns="fitted").loc[each], scores.loc[each]
    )
    held_out = scores.loc[["I", "V", "extra"], "RMSE_um"]
    assert again.loc["mean", "RMSE_um"] == pytest.approx(held_out.mean())
    # A predictions file of run, time_s and the prediction only.
    bare = workdir / "bare.csv"
    table[["run", "time_s", "pred_disp_y_um"]].to_csv(bare, index=False)
    argv = ["evaluate", "--runs", runs, "--predictions", bare]
    status, _, _ = _run(capsys, *argv, "--out", workdir / "s3.csv")
    assert status == 0
    pd.testing.assert_frame_equal(
        pd.read_csv(workdir / "s3.csv").set_index("run"), scores
    )


@pytest.mark.parametrize("name", ["anfis-grid", "gnnmci", "grey-pso", "mlp"])
def test_fit_every_model_with_a_selector(capsys, workdir, name):
    out = workdir / f"{name}.joblib"
    status, text, err = _run(
        capsys,
        "fit",
        "--runs",
        workdir / "tests.csv",
        "--train-runs",
        "IV",
        "--model",
        name,
        "--selector",
        "grey",
        "--n-sensors",
        "3",
        "--quick",
        "--out",
        out,
    )
    assert status == 0, err
    assert "grey selected" in text and out.is_file()


def test_fit_notes_runs_that_start_turning(capsys, workdir, tmp_path):
    table = pd.read_csv(workdir / "tests.csv")
    first = ~table["run"].duplicated()
    for rpm, noted in ((3000.0, True), (0.0, False)):
        path = tmp_path / f"start_{int(rpm)}.csv"
        table.assign(spindle_rpm=table["spindle_rpm"].mask(first, rpm)).to_csv(
            path, index=False
        )
        argv = [
            "fit",
            "--runs",
            path,
            "--model",
            "ridge",
            "--out",
            tmp_path / "m.joblib",
        ]
        status, text, err = _run(capsys, *argv)
        assert status == 0, err
        assert ("start with the spindle turning" in text) == noted, text


def test_fit_the_baselines_and_predict(capsys, workdir):
    # The tuned linear baseline, and the recommended dynamic model, which
    # also reads the spindle speed from the table.
    import joblib

    for name in ("ridge", "lag-ridge"):
        out = workdir / f"{name}.joblib"
        argv = ["fit", "--runs", workdir / "tests.csv", "--train-runs", "IV"]
        status, text, err = _run(capsys, *argv, "--model", name, "--out", out)
        assert status == 0, err
        bundle = joblib.load(out)
        assert ("spindle_rpm" in bundle["sensors"]) == (name == "lag-ridge")
        # The drivers are inputs, not sensors.
        n = len(bundle["sensors"]) - (name == "lag-ridge") * 2
        drivers = " and spindle_rpm, feed_mm_min" if name == "lag-ridge" else ""
        assert f" on {n} sensor(s){drivers} -> " in text
        pred = workdir / f"{name}.csv"
        argv = ["predict", "--model", out, "--runs", workdir / "tests.csv"]
        status, _, err = _run(capsys, *argv, "--out", pred)
        assert status == 0, err
        assert np.isfinite(pd.read_csv(pred)["pred_disp_y_um"]).all()
    status, _, err = _run(
        capsys, "search", "--runs", workdir / "tests.csv", "--model", "ridge"
    )
    assert status != 0 and "nothing to search" in err
    # Empty fields in columns the model does not read (the measured
    # displacement, the air for a model on sensors alone) were refused,
    # while the table without those columns was predicted.
    table = pd.read_csv(workdir / "tests.csv")
    table.loc[table.index[5:8], ["disp_y_um", "ambient_C"]] = np.nan
    holes = workdir / "holes.csv"
    table.to_csv(holes, index=False)
    argv = ["predict", "--model", workdir / "ridge.joblib", "--runs", holes]
    status, _, err = _run(capsys, *argv, "--out", workdir / "holes_pred.csv")
    assert status == 0, err
    out = pd.read_csv(workdir / "holes_pred.csv")
    assert np.isfinite(out["pred_disp_y_um"]).all()
    assert out["disp_y_um"].isna().sum() == 3
    # A driver the model reads is still checked.
    argv = ["predict", "--model", workdir / "lag-ridge.joblib", "--runs", holes]
    table.loc[table.index[5], "spindle_rpm"] = np.nan
    table.to_csv(holes, index=False)
    status, _, err = _run(capsys, *argv, "--out", workdir / "holes_pred.csv")
    assert status == 2 and "'spindle_rpm'" in err, err


def test_predict_names_a_model_file_it_cannot_use(capsys, workdir, tmp_path):
    # A model saved by another skthermal lacks an attribute this one reads;
    # an empty file or a search's study is no model either. One line each.
    import joblib

    model = workdir / "lag-ridge.joblib"
    runs = workdir / "tests.csv"
    if not model.is_file():
        argv = ["fit", "--runs", workdir / "tests.csv", "--train-runs", "IV"]
        assert _run(capsys, *argv, "--model", "lag-ridge", "--out", model)[0] == 0
    bundle = joblib.load(model)
    inner = bundle["estimator"]
    inner = getattr(inner, "estimator_", inner)
    del inner.n_lag_features_
    stale = tmp_path / "stale.joblib"
    joblib.dump(bundle, stale)
    (tmp_path / "empty.joblib").write_bytes(b"")
    study = tmp_path / "study.db"
    import sqlite3

    sqlite3.connect(study).execute("create table t (x)").connection.commit()
    missing = tmp_path / "missing.csv"
    pd.read_csv(runs).drop(columns=bundle["sensors"][0]).to_csv(missing, index=False)
    argv = ["predict", "--model", model, "--runs", missing]
    status, _, err = _run(capsys, *argv, "--out", tmp_path / "p.csv")
    assert status == 2 and f"--runs {missing} lacks the model's input" in err
    for path, message in (
        (stale, "saved by another skthermal version: fit it again"),
        (tmp_path / "empty.joblib", "an empty file, not a model file"),
        (study, "an SQLite database (a search's study?), not a model file"),
    ):
        argv = ["predict", "--model", path, "--runs", runs]
        status, _, err = _run(capsys, *argv, "--out", tmp_path / "p.csv")
        assert status == 2 and message in err, err
        assert "Traceback" not in err


def test_predict_says_a_joblib_model_of_another_version(capsys, workdir, tmp_path):
    # A .skops file's versions were checked; a .joblib bundle's were not.
    import joblib

    model = workdir / "lag-ridge.joblib"
    if not model.is_file():
        argv = ["fit", "--runs", workdir / "tests.csv", "--train-runs", "IV"]
        assert _run(capsys, *argv, "--model", "lag-ridge", "--out", model)[0] == 0
    bundle = joblib.load(model)
    old = tmp_path / "old.joblib"
    joblib.dump({**bundle, "skthermal_version": "0.0.1"}, old)
    argv = ["predict", "--model", old, "--runs", workdir / "tests.csv"]
    status, _, err = _run(capsys, *argv, "--out", tmp_path / "p.csv")
    assert status == 0, err
    assert "written with skthermal 0.0.1" in err, err


def test_a_long_fit_says_what_it_fits_first(capsys, workdir, tmp_path, monkeypatch):
    monkeypatch.setattr("skthermal._cli._models._LONG_FIT_ROWS", 10)
    argv = ["fit", "--runs", workdir / "tests.csv", "--train-runs", "IV"]
    status, text, err = _run(
        capsys, *argv, "--model", "ridge", "--out", tmp_path / "m.joblib"
    )
    assert status == 0, err
    assert re.search(r"^Fitting .* on [\d,]+ rows of 1 run\(s\), \d+ input", text, re.M)


def test_a_run_with_a_dead_sensor_gets_no_prediction_the_others_do(
    capsys, workdir, tmp_path
):
    # One run of the file with a sensor unplugged throughout made predict
    # fail for every run of the file.
    model = tmp_path / "guarded.joblib"
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "ridge"]
    status, _, err = _run(capsys, *argv, "--guard", "hold", "--out", model)
    assert status == 0, err
    table = pd.read_csv(workdir / "tests.csv")
    dead_run = table["run"].iloc[0]
    table.loc[table["run"] == dead_run, "T05_C"] = np.nan
    runs = tmp_path / "dead.csv"
    table.to_csv(runs, index=False)
    out = tmp_path / "pred.csv"
    argv = ["predict", "--model", model, "--runs", runs, "--out", out]
    status, text, err = _run(capsys, *argv)
    assert status == 0, err
    assert "1 of them without a prediction, action 'unavailable'" in text
    assert f"'T05_C' reads no finite value in run '{dead_run}'" in err
    pred = pd.read_csv(out)
    mine = (pred["run"] == dead_run).to_numpy()
    assert pred.loc[mine, "pred_disp_y_um"].isna().all()
    assert (pred.loc[mine, "guard_action"] == "unavailable").all()
    assert pred.loc[~mine, "pred_disp_y_um"].notna().all()
    status, _, err = _run(capsys, "evaluate", "--runs", runs, "--model", model)
    assert status == 2 and "The guard gives no prediction at run" in err, err
    # What predict wrote is scored without that run (it failed to score at all).
    status, text, err = _run(capsys, "evaluate", "--runs", out)
    assert status == 0, err
    assert f"run(s) ['{dead_run}'] of {out} have no prediction" in text
    assert f"| {dead_run} " not in text and " all " in text


def test_a_guarded_model_holds_a_spike_and_says_so(capsys, workdir):
    # Without a guard a 1e6 reading went through the lag filters into a
    # correction of -50 mm, silently.
    model = workdir / "guarded.joblib"
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "lag-ridge"]
    argv += ["--guard", "hold", "--out", model]
    status, _, err = _run(capsys, *argv)
    assert status == 0, err
    table = pd.read_csv(workdir / "tests.csv")
    clean_runs = workdir / "clean.csv"
    table.to_csv(clean_runs, index=False)
    row = int(np.flatnonzero(table["run"] == "V")[30])
    table.loc[row, "T05_C"] = 1e6
    spiked = workdir / "spiked.csv"
    table.to_csv(spiked, index=False)
    outs = {}
    for name, runs in (("clean", clean_runs), ("spiked", spiked)):
        outs[name] = workdir / f"guarded_{name}.csv"
        argv = ["predict", "--model", model, "--runs", runs, "--out", outs[name]]
        status, _, err = _run(capsys, *argv)
        assert status == 0, err
    assert "Sensor jump" in err and "T05_C" in err
    clean, guarded = pd.read_csv(outs["clean"]), pd.read_csv(outs["spiked"])
    assert (
        not guarded.loc[row, "guard_ok"] and guarded.loc[row, "guard_action"] == "held"
    )
    assert "T05_C" in guarded.loc[row, "guard_reason"]
    # Held there, and the runs' other rows as without the spike.
    pred = guarded["pred_disp_y_um"]
    assert pred[row] == pred[row - 1]
    others = guarded["guard_ok"].to_numpy() & clean["guard_ok"].to_numpy()
    np.testing.assert_allclose(pred[others], clean["pred_disp_y_um"][others])
    # A sensor that drops out (empty fields) is held over too: the file was
    # refused when read, while the guard in Python held the same rows.
    table.loc[row, "T05_C"] = np.nan
    table.to_csv(spiked, index=False)
    argv = ["predict", "--model", model, "--runs", spiked, "--out", outs["spiked"]]
    status, _, err = _run(capsys, *argv)
    assert status == 0 and "Sensor reading missing" in err, err
    dropped = pd.read_csv(outs["spiked"])
    assert dropped.loc[row, "guard_action"] == "held"
    assert dropped.loc[row, "guard_reason"] == "missing: T05_C"
    assert np.isnan(dropped.loc[row, "T05_C"])
    # and what predict wrote is scored (evaluate reads no sensor)
    status, text, err = _run(capsys, "evaluate", "--runs", outs["spiked"])
    assert status == 0 and " all " in text, err
    status, _, err = _run(capsys, "evaluate", "--runs", spiked, "--model", model)
    assert status == 0, err


def test_fit_and_predict_with_a_safe_skops_file(capsys, workdir):
    pytest.importorskip("skops")
    model = workdir / "safe.skops"
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "grey-pso"]
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C", "--out", model)
    assert status == 0, err
    pred = workdir / "safe.csv"
    argv = ["predict", "--model", model, "--runs", workdir / "tests.csv"]
    status, _, err = _run(capsys, *argv, "--out", pred)
    assert status == 0, err
    assert "pred_disp_y_um" in pd.read_csv(pred).columns
    # The same file under another name loads as what it is (it met the
    # unpickler: "persistent IDs in protocol 0 must be ASCII strings").
    renamed = workdir / "safe_renamed.joblib"
    renamed.write_bytes(model.read_bytes())
    argv = ["predict", "--model", renamed, "--runs", workdir / "tests.csv"]
    status, _, err = _run(capsys, *argv, "--out", workdir / "safe_renamed.csv")
    assert status == 0, err
    pd.testing.assert_frame_equal(
        pd.read_csv(workdir / "safe_renamed.csv"), pd.read_csv(pred)
    )


def test_fit_set_parameters(capsys, workdir):
    status, _, _ = _run(
        capsys,
        "fit",
        "--runs",
        workdir / "tests.csv",
        "--model",
        "anfis-fcm",
        "--sensors",
        "T05_C,T40_C",
        "--set",
        "n_clusters=2",
        "--set",
        "epochs=5",
        "--out",
        workdir / "small.joblib",
    )
    assert status == 0
    import joblib

    bundle = joblib.load(workdir / "small.joblib")
    assert bundle["estimator"].estimator_.n_rules_ == 2
    assert bundle["sensors"] == ["T05_C", "T40_C"]


def test_search_runs_a_small_study(capsys, workdir):
    pytest.importorskip("optuna")
    best = workdir / "best.json"
    search = ["search", "--runs", workdir / "tests.csv", "--model", "grey-pso"]
    search += ["--sensors", "T05_C,T40_C,T70_C", "--storage", workdir / "study.db"]
    status, text, err = _run(capsys, *search, "--trials", "2", "--out", best)
    assert status == 0, err
    assert "2 of 2 trial(s) complete" in text
    doc = json.loads(best.read_text())
    assert doc["study_name"] == "skthermal-grey-pso" and doc["best_rmse_um"] > 0
    # --trials 0: the stored best so far, no new trial (into a new folder).
    again = workdir / "new" / "again.json"
    status, text, err = _run(capsys, *search, "--trials", "0", "--out", again)
    assert status == 0, err
    assert "2 of 2 trial(s) complete" in text
    assert json.loads(again.read_text())["best_params"] == doc["best_params"]
    # A study the storage does not hold (a mistyped --study-name): said in
    # the command's options, and no empty study is stored under that name.
    typo = ["--study-name", "skthermal-grey-psoo"]
    status, text, err = _run(capsys, *search, *typo, "--trials", "0")
    assert status == 2
    last = err.strip().splitlines()[-1]
    assert (
        "error: --trials 0 refits the best trial of the stored study "
        "'skthermal-grey-psoo' (--study-name), but the --storage "
    ) in last
    assert "holds 1 other study ('skthermal-grey-pso') (did you mean" in last
    optuna = pytest.importorskip("optuna")
    url = f"sqlite:///{workdir / 'study.db'}"
    assert optuna.study.get_all_study_names(url) == ["skthermal-grey-pso"]
    # Another model into that study: refused, in the command's words.
    other = [*search[:4], "anfis-fcm", *search[5:]]
    status, text, err = _run(
        capsys, *other, "--study-name", "skthermal-grey-pso", "--trials", "1"
    )
    assert status == 2
    last = err.strip().splitlines()[-1]
    assert "(estimator 'RunStartRegressor(GreyPSORegressor)' there, " in last
    assert last.endswith("Give another --study-name (or --storage).")
    # A stored study with no trial: the library's reason, said once.
    optuna.create_study(
        storage=f"sqlite:///{workdir / 'empty.db'}",
        study_name="skthermal-grey-pso",
        direction="maximize",
    )
    empty = ["--storage", workdir / "empty.db", "--trials", "0"]
    status, text, err = _run(capsys, *search[:-2], *empty)
    assert status == 2
    last = err.strip().splitlines()[-1]
    assert "error: No best trial: the study holds no trial" in last
    assert err.count("No best trial") == 1


def test_search_keeps_runs_out_with_train_runs(capsys, workdir, tmp_path):
    # Searching on some runs meant writing a second table.
    import joblib

    pytest.importorskip("optuna")
    model = tmp_path / "best.joblib"
    search = ["search", "--runs", workdir / "tests.csv", "--model", "grey-pso"]
    search += ["--sensors", "T05_C,T40_C", "--trials", "1", "--save-model", model]
    status, text, err = _run(capsys, *search, "--train-runs", "I,IV,extra")
    assert status == 0, err
    assert "3-fold CV over 3 runs" in text
    assert "refitted on runs I, IV, extra)" in text
    assert joblib.load(model)["train_runs"] == ["I", "IV", "extra"]
    status, _, err = _run(capsys, *search, "--train-runs", "V")
    assert status == 2 and "has 1 run among --train-runs; the search" in err, err
    status, _, err = _run(capsys, *search, "--train-runs", "VI")
    assert status == 2 and "run(s) ['VI'] are not in the table" in err, err


def test_search_shows_no_password(capsys, workdir):
    # The banner printed the URL as given while the error below hid it.
    pytest.importorskip("optuna")
    url = "postgresql://alice:S3cr3t@db.invalid/optuna"
    argv = ["search", "--runs", workdir / "tests.csv", "--model", "grey-pso"]
    status, text, err = _run(capsys, *argv, "--trials", "1", "--storage", url)
    assert status == 2
    assert "alice:***@db.invalid" in text + err
    assert "S3cr3t" not in text + err
    # A password given as a query parameter, as libpq reads it.
    url = "postgresql://alice@db.invalid/optuna?sslmode=off&password=S3cr3t&x=1"
    status, text, err = _run(capsys, *argv, "--trials", "1", "--storage", url)
    assert status == 2
    assert "password=***&x=1" in text + err
    assert "S3cr3t" not in text + err


def test_search_and_guard_ignore_each_runs_starting_offset(capsys, workdir, tmp_path):
    # The named models predict the change since each run's start. The search
    # scored those predictions against the absolute target, so each held-out
    # run's starting offset went into its RMSE, and `fit --guard` drew its
    # output band from the absolute target, holding healthy rows.
    pytest.importorskip("optuna")
    table = pd.read_csv(workdir / "tests.csv")
    shifted = table.copy()
    codes = pd.factorize(shifted["run"])[0]
    shifted["disp_y_um"] += np.array([0.0, 14.0, -9.0, 25.0])[codes]
    tables = {"as simulated": table, "offset per run": shifted}
    best, held = {}, {}
    for name, frame in tables.items():
        runs = tmp_path / f"{len(best)}.csv"
        frame.to_csv(runs, index=False)
        out = tmp_path / f"best{len(best)}.json"
        argv = ["search", "--runs", runs, "--model", "grey-pso", "--sensors"]
        argv += ["T05_C,T40_C", "--trials", "1", "--seed", "0", "--out", out]
        status, _, err = _run(capsys, *argv)
        assert status == 0, err
        best[name] = json.loads(out.read_text())["best_rmse_um"]
        model = tmp_path / f"guarded{len(held)}.joblib"
        argv = ["fit", "--runs", runs, "--model", "lag-ridge", "--guard", "hold"]
        status, _, err = _run(capsys, *argv, "--out", model)
        assert status == 0, err
        pred = tmp_path / f"pred{len(held)}.csv"
        argv = ["predict", "--model", model, "--runs", runs, "--out", pred]
        status, _, err = _run(capsys, *argv)
        assert status == 0, err
        held[name] = (pd.read_csv(pred)["guard_action"] == "held").mean()
    assert best["offset per run"] == pytest.approx(best["as simulated"], rel=1e-9)
    assert held["offset per run"] == held["as simulated"]


class _FakeGapReport:
    ranking = pd.DataFrame(
        {"effect": ["tool_growth"], "shrink": [0.9], "explains": [True]}
    )

    def verdict(self):
        return "tool_growth explains the gap"

    def where_summary(self, model=None):
        return f"Where ({model or 'default'}):\n  run 'A': gap 0.1 [norm.]"

    def save(self, folder):
        Path(folder).mkdir(parents=True, exist_ok=True)
        (Path(folder) / "report.md").write_text("# gap\n")


def test_gap_passes_runs_and_machine(capsys, workdir, monkeypatch, tmp_path):
    gap = pytest.importorskip("skthermal.gap")
    seen = {}

    def fake(machine, runs, candidates=None):
        seen.update(effects=list(machine.effects), runs=len(runs), cands=candidates)
        return _FakeGapReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    status, text, _ = _run(
        capsys,
        "gap",
        "--runs",
        workdir / "tests.csv",
        "--candidates",
        "tool_growth,sensor_lag",
        "--report",
        tmp_path / "gap",
    )
    assert status == 0 and "tool_growth explains the gap" in text
    assert seen["effects"] == [] and seen["cands"] == ["tool_growth", "sensor_lag"]
    assert (tmp_path / "gap" / "report.md").is_file()


def test_gap_initial_option(capsys, workdir, monkeypatch, tmp_path):
    gap = pytest.importorskip("skthermal.gap")
    seen = {}

    def fake(machine, runs, candidates=None, **kwargs):
        seen.update(kwargs)
        return _FakeGapReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    argv = ["gap", "--runs", workdir / "tests.csv"]
    status, _, _ = _run(capsys, *argv, "--initial", "measured")
    assert status == 0 and seen == {"initial": "measured"}
    seen.clear()
    status, _, _ = _run(capsys, *argv)
    assert status == 0 and "initial" not in seen  # the library's default
    status, _, err = _run(
        capsys, *argv, "--simulated", workdir / "tests.csv", "--initial", "measured"
    )
    assert status != 0 and "--initial is not used with --simulated" in err


def test_gap_check_exit_status_follows_targets(capsys, monkeypatch, tmp_path):
    gap = pytest.importorskip("skthermal.gap")

    class Fake:
        rates = {"detection": 1.0}
        targets = {"detection >= 90%": False}
        cases = pd.DataFrame({"case": [1]})
        confusion = pd.DataFrame({"none": [1]})

        def meets_targets(self):
            return False

        def to_markdown(self):
            return "# validation\n"

    monkeypatch.setattr(gap, "validate", lambda *a, **k: Fake())
    status, text, _ = _run(
        capsys, "gap-check", "--seeds", "1", "--report", tmp_path / "check"
    )
    assert status == 1 and "NOT met" in text
    assert (tmp_path / "check" / "validation.md").is_file()


def test_missing_optuna_names_the_extra(capsys, monkeypatch, workdir):
    monkeypatch.setitem(sys.modules, "optuna", None)
    argv = ["search", "--runs", workdir / "tests.csv", "--model", "mlp"]
    status, _, err = _run(capsys, *argv)
    assert status == 2 and err.count("\n") == 1
    assert "skthermal[optuna]" in err


def test_missing_skops_says_how_to_install_it(capsys, monkeypatch, workdir):
    monkeypatch.setitem(sys.modules, "skops", None)
    monkeypatch.setitem(sys.modules, "skops.io", None)
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "grey-pso"]
    out = workdir / "no-skops.skops"
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C", "--out", out)
    assert status == 2 and err.count("\n") == 1
    assert "pip install skops" in err
    assert not out.exists()


def test_help_does_not_import_the_estimators():
    code = (
        "import sys; from skthermal.cli import build_parser; build_parser(); "
        "print(sorted(m for m in ('sklearn', 'pandas', 'scipy', 'skthermal.fuzzy') "
        "if m in sys.modules))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "[]"


def test_lazy_package_attributes():
    import skthermal

    assert "ANFISRegressor" in dir(skthermal)
    assert skthermal.ANFISRegressor.__name__ == "ANFISRegressor"
    with pytest.raises(AttributeError, match="no attribute 'Nope'"):
        skthermal.Nope  # noqa: B018


def test_list_effects_is_wrapped_to_the_terminal(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "60")
    status, text, _ = _run(capsys, "simulate", "--list-effects")
    assert status == 0 and "tool_growth" in text
    assert max(len(line) for line in text.splitlines()) <= 60


def test_gap_progress_logging_and_quiet(capsys, workdir, monkeypatch):
    import logging

    gap = pytest.importorskip("skthermal.gap")

    def fake(machine, runs, candidates=None):
        logging.getLogger("skthermal.gap").info("screening candidate tool_growth")
        logging.getLogger("skthermal.gap").debug("not shown")
        return _FakeGapReport()

    monkeypatch.setattr(gap, "diagnose", fake)
    argv = ["gap", "--runs", workdir / "tests.csv"]
    status, _, err = _run(capsys, *argv)
    assert status == 0 and "screening candidate tool_growth" in err
    assert "not shown" not in err
    status, _, err = _run(capsys, *argv, "--quiet")
    assert status == 0 and "screening candidate" not in err


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_help_of_every_subcommand(capsys, command):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert f"usage: skthermal {command}" in text
    if command != "demo":
        assert "examples:" in text and f"skthermal {command}" in text


def test_top_level_help_lists_the_subcommands(capsys):
    assert main([]) == 0
    text = capsys.readouterr().out
    for command in SUBCOMMANDS:
        assert command in text


@pytest.mark.parametrize(
    "argv, message",
    [
        (["fit", "--runs", "{tmp}/nope.csv", "--model", "mlp"], "no such file"),
        (["fit", "--runs", "{runs}", "--model", "svm"], "unknown model 'svm'"),
        (["fit", "--runs", "{runs}", "--model", "mlp", "--sensors", "T99_C"], "T99_C"),
        (
            ["fit", "--runs", "{runs}", "--model", "mlp", "--set", "nope=1"],
            "--set nope",
        ),
        (["fit", "--runs", "{runs}", "--model", "anfis-grid"], "max_rules"),
        (["select", "--runs", "{runs}", "--target", "disp_q_um"], "disp_q_um"),
        (["select", "--runs", "{runs}", "--n-sensors", "0"], "--n-sensors"),
        (["select", "--runs", "{runs}", "--train-runs", "IX"], "'IX'"),
        (["select", "--runs", "{runs}", "--out", "{tmp}/s.txt"], ".json or .csv"),
        (["select", "--runs", "{bad}"], "'Temp3'"),
        (["simulate", "--segment", "4000:x", "--out", "{tmp}/r.csv"], "--segment"),
        (
            ["simulate", "--segment", "3000:3600", "--out", "{tmp}/r.csv"],
            "3600 would be 150 days; write the unit (3600s, 3600min or 3600h)",
        ),
        (["simulate", "--segment", "3000:inf", "--out", "{tmp}/r.csv"], "finite"),
        (
            ["simulate", "--segment", "100000000:1h", "--out", "{tmp}/r.csv"],
            "--segment '100000000:1h': spindle speed 1e+08 rpm is above the "
            "limit of 100000 rpm",
        ),
        (
            ["simulate", "--segment", "4000:1h:300000", "--out", "{tmp}/r.csv"],
            "feed 300000 mm/min is above the limit of 200000 mm/min",
        ),
        (
            ["simulate", "--ambient-mean", "500", "--out", "{tmp}/r.csv"],
            "the air reaches 500 °C at 0 h, outside the -50..100 °C",
        ),
        (
            ["simulate", "--ambient-trend", "10", "--segment", "0:10h"]
            + ["--out", "{tmp}/r.csv"],
            "the air reaches 120 °C at 10 h",
        ),
        (
            ["simulate", "--machine", "{tmp}", "--out", "{tmp}/r.csv"],
            "is a folder (a directory), not a machine file",
        ),
        (
            ["simulate", "--machine", "{tmp}/m.toml", "--preset", "vmc-a"]
            + ["--out", "{tmp}/r.csv"],
            "give --preset or --machine, not both",
        ),
        (
            ["gap", "--runs", "{runs}", "--machine", "{tmp}/m.toml"]
            + ["--preset", "vmc-b"],
            "give --preset or --machine, not both",
        ),
        (
            ["gap", "--runs", "{runs}", "--simulated", "{runs}"]
            + ["--preset", "vmc-b"],
            "--preset is not used with --simulated",
        ),
        (["simulate", "--effects", "magic", "--out", "{tmp}/r.csv"], "magic"),
        (["simulate", "--tests", "VII", "--out", "{tmp}/r.csv"], "VII"),
        (
            [
                "simulate",
                "--tests",
                "I",
                "--ambient-mean",
                "25",
                "--out",
                "{tmp}/r.csv",
            ],
            "own air; --ambient-mean would be ignored",
        ),
        (["reproduce", "--sample-period", "-5", "--out", "{tmp}/r"], "positive"),
        (["reproduce", "--models", "nope", "--out", "{tmp}/r"], "nope"),
        (
            ["predict", "--model", "{runs}", "--runs", "{runs}"],
            "a run table, not a model file",
        ),
        (
            ["predict", "--model", "{tmp}/notes.joblib", "--runs", "{runs}"],
            "a text file, not a model file",
        ),
        (["evaluate", "--runs", "{runs}"], "no prediction column"),
        (["search", "--runs", "{runs}", "--model", "svm"], "unknown model"),
        (["gap", "--runs", "{tmp}/nope.csv"], "no such file"),
        # Output names checked before the work.
        (
            [
                "predict",
                "--model",
                "{tmp}/m",
                "--runs",
                "{runs}",
                "--out",
                "{tmp}/p.xlsx",
            ],
            "neither CSV nor Parquet",
        ),
        (
            ["evaluate", "--runs", "{runs}", "--out", "{tmp}/s.xlsx"],
            "write .csv or .md",
        ),
    ],
)
def test_user_errors_are_one_line(capsys, workdir, tmp_path, argv, message):
    bad = tmp_path / "bad.csv"
    pd.DataFrame(
        {"run": ["a", "a"], "time_s": [0, 60], "T1_C": [20, 21], "Temp3": [1, 2]}
    ).to_csv(bad, index=False)
    (tmp_path / "notes.joblib").write_text("not a model\n")
    names = {"tmp": tmp_path, "runs": workdir / "tests.csv", "bad": bad}
    status, _, err = _run(capsys, *[a.format(**names) for a in argv])
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"skthermal {argv[0]}: error:")
    assert message in err


def test_bad_option_value_is_one_line(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["select", "--runs", "x.csv", "--seed", "abc"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--seed: must be an integer, got 'abc'" in err


def test_missing_sensor_values_get_advice_a_command_line_user_can_follow(
    capsys, tmp_path
):
    holed = tmp_path / "holed.csv"
    pd.DataFrame(
        {
            "run": ["a"] * 3,
            "time_s": [0, 60, 120],
            "T1_C": [20.0, None, 21.0],
            "disp_y_um": [0.0, 1.0, 2.0],
        }
    ).to_csv(holed, index=False)
    argv = ["fit", "--runs", holed, "--model", "ridge", "--out", tmp_path / "m"]
    status, _, err = _run(capsys, *argv)
    assert status == 2 and "'T1_C' has 1 missing value" in err
    assert "or drop those rows" in err and "allow_missing_sensors" not in err


# --------------------------------------------------------------------------
# Audit fixes: labels, output paths, evaluate joins, warnings
# --------------------------------------------------------------------------


def test_simulate_append_with_numeric_run_labels_to_csv(capsys, tmp_path):
    from skthermal.datasets import read_runs

    out = tmp_path / "e.csv"
    base = ["simulate", "--segment", "4000:20min", "--sample-period", "300"]
    assert _run(capsys, *base, "--run", "1", "--out", out)[0] == 0
    status, text, err = _run(capsys, *base, "--run", "2", "--append", "--out", out)
    assert status == 0, err
    assert "2 run(s) (1, 2)" in text
    runs, meta = read_runs(out, metadata=True)
    assert list(pd.unique(runs["run"])) == ["1", "2"]
    assert meta["run"].tolist() == ["1", "2"]


@pytest.fixture(scope="module")
def ridge_y(workdir):
    """A ridge model of disp_y_um on three sensors."""
    model = workdir / "ridge_y.joblib"
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "ridge"]
    argv += ["--sensors", "T01_C,T02_C,T03_C", "--out", model]
    assert main([str(a) for a in argv]) == 0
    return model


def test_evaluate_refuses_a_target_the_model_does_not_predict(capsys, workdir, ridge_y):
    argv = ["evaluate", "--runs", workdir / "tests.csv", "--model", ridge_y]
    status, _, err = _run(capsys, *argv, "--target", "disp_x_um")
    assert status == 2 and err.count("\n") == 1
    assert "--target disp_x_um: the model" in err and "predicts 'disp_y_um'" in err
    assert _run(capsys, *argv, "--target", "disp_y_um")[0] == 0


@pytest.fixture(scope="module")
def predictions(workdir, ridge_y):
    """The measured runs and a table of their predictions (run, time_s, pred)."""
    pred = workdir / "ridge_pred.csv"
    runs = workdir / "tests.csv"
    argv = ["predict", "--model", ridge_y, "--runs", runs, "--out", pred]
    assert main([str(a) for a in argv]) == 0
    table = pd.read_csv(pred)[["run", "time_s", "pred_disp_y_um"]]
    return runs, table


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda t: pd.concat([t, t.iloc[[5]]]),
            r"1 row\(s\) repeat a \(run, time_s\) pair, the first run 'I', time_s",
        ),
        (
            lambda t: t.drop(index=t.index[t["run"] == "IV"][0]),
            r"no prediction for 1 row\(s\) .* in run\(s\) \['IV'\], the first run "
            r"'IV', time_s 0.0 \(the first row of the run",
        ),
        (
            lambda t: t.iloc[::2],
            r"no prediction for \d+ row\(s\) .* in run\(s\) \['I', 'IV', 'V', "
            r"'extra'\]",
        ),
    ],
)
def test_evaluate_predictions_are_joined_row_for_row(
    capsys, tmp_path, predictions, change, message
):
    import re

    runs, table = predictions
    bad = tmp_path / "bad.csv"
    change(table).to_csv(bad, index=False)
    status, _, err = _run(capsys, "evaluate", "--runs", runs, "--predictions", bad)
    assert status == 2 and err.count("\n") == 1
    assert re.search(message, err), err


def test_evaluate_joins_float32_times_and_whole_float_labels(
    capsys, tmp_path, predictions
):
    # A Parquet file made smaller (float32 columns) and its predictions in a
    # CSV file (float64 text): 300.7 s is not the float32 300.70001220703125,
    # and every row was said to have no prediction. Run labels 1.0 and 1
    # are the same run to the estimators, and now here too.
    pytest.importorskip("pyarrow")
    runs, table = predictions
    measured, table = pd.read_csv(runs), table.copy()
    labels = {r: k for k, r in enumerate(measured["run"].unique(), start=1)}
    for t in (measured, table):
        t["time_s"] = t["time_s"] * 1.0117  # times float32 cannot hold
        t["run"] = t["run"].map(labels)
    small = measured.astype(
        {c: "float32" for c in measured.columns if c not in ("run", "time_s")}
    ).astype({"time_s": "float32", "run": "float64"})
    small.to_parquet(tmp_path / "small.parquet")
    table.to_csv(tmp_path / "pred.csv", index=False)
    measured.to_csv(tmp_path / "full.csv", index=False)
    scores = {}
    for name in ("small.parquet", "full.csv"):
        out = tmp_path / f"{name}.scores.csv"
        argv = ["evaluate", "--runs", tmp_path / name, "--predictions"]
        status, _, err = _run(capsys, *argv, tmp_path / "pred.csv", "--out", out)
        assert status == 0, err
        scores[name] = pd.read_csv(out)
    assert scores["small.parquet"]["n_samples"].iloc[-1] == len(measured)
    pd.testing.assert_frame_equal(
        scores["small.parquet"].drop(columns="run"),
        scores["full.csv"].drop(columns="run"),
        check_exact=False,
        rtol=1e-4,
    )


def test_evaluate_notes_runs_without_predictions(capsys, tmp_path, predictions):
    runs, table = predictions
    part = tmp_path / "part.csv"
    table[table["run"] != "V"].to_csv(part, index=False)
    out = tmp_path / "s.csv"
    argv = ["evaluate", "--runs", runs, "--predictions", part, "--out", out]
    status, text, _ = _run(capsys, *argv)
    assert status == 0 and "Note: run(s) ['V'] of" in text
    assert pd.read_csv(out)["run"].tolist() == ["I", "IV", "extra", "mean", "all"]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["select", "--runs", "{runs}", "--out", "{runs}/s.json"], "not a folder"),
        (["fit", "--runs", "{runs}", "--model", "ridge", "--out", "{runs}/m"], ""),
        (["evaluate", "--runs", "{runs}", "--out", "{runs}/s.md"], ""),
        (["search", "--runs", "{runs}", "--model", "mlp", "--out", "{runs}/b"], ""),
        (
            [
                "search",
                "--runs",
                "{runs}",
                "--model",
                "mlp",
                "--save-model",
                "{runs}/m",
            ],
            "",
        ),
        (["simulate", "--out", "{runs}/x.csv"], ""),
        (
            [
                "predict",
                "--model",
                "{tmp}/m",
                "--runs",
                "{runs}",
                "--out",
                "{runs}/p.csv",
            ],
            "",
        ),
        (
            ["gap", "--runs", "{runs}", "--report", "{runs}"],
            "a file of that name exists",
        ),
        (["gap-check", "--report", "{runs}"], "a file of that name exists"),
        (["demo", "--out", "{runs}"], "a file of that name exists"),
        (["reproduce", "--out", "{runs}"], "a file of that name exists"),
        (
            ["fit", "--runs", "{runs}", "--model", "ridge", "--out", "{tmp}"],
            "is a folder",
        ),
    ],
)
def test_output_paths_are_checked_before_the_work(
    capsys, workdir, tmp_path, argv, message
):
    names = {"tmp": tmp_path, "runs": workdir / "tests.csv"}
    argv = [a.format(**names) for a in argv]
    option = next(a for a in argv if a in ("--out", "--report", "--save-model"))
    status, text, err = _run(capsys, *argv)
    assert status == 2 and err.count("\n") == 1, err
    assert err.startswith(f"skthermal {argv[0]}: error: {option} ")
    assert message in err and text == ""


def test_gap_check_refuses_zero_jobs_before_the_work(capsys):
    status, text, err = _run(capsys, "gap-check", "--n-jobs", "0")
    assert status == 2 and "--n-jobs must be 1 or more" in err and text == ""


def test_os_errors_are_one_line(capsys, monkeypatch):
    from skthermal._cli import _data

    def fail(args):
        raise NotADirectoryError(20, "Not a directory", "tests.csv/s.json")

    monkeypatch.setattr(_data, "cmd_select", fail)
    status, _, err = _run(capsys, "select", "--runs", "x.csv")
    assert status == 2
    assert err == (
        "skthermal select: error: [Errno 20] Not a directory: 'tests.csv/s.json'\n"
    )


def test_gap_names_the_candidates_option(capsys, workdir):
    pytest.importorskip("skthermal.gap")
    argv = ["gap", "--runs", workdir / "tests.csv", "--candidates", "foo"]
    status, _, err = _run(capsys, *argv, "--quiet")
    assert status == 2 and "error: --candidates: unknown effect(s) ['foo']" in err


def test_warnings_are_one_line_each_and_shown_once(capsys, workdir, tmp_path):
    runs = pd.read_csv(workdir / "tests.csv")
    hole = (runs["run"] == "IV") & runs["time_s"].between(3000, 9000)
    gappy = tmp_path / "gappy.csv"
    runs[~hole].to_csv(gappy, index=False)
    model = tmp_path / "lag.joblib"
    argv = ["fit", "--runs", gappy, "--model", "lag-ridge", "--sensors", "T01_C"]
    status, _, err = _run(capsys, *argv, "--out", model)
    assert status == 0
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("skthermal fit: warning: ")
    assert "gap(s) in time_s" in lines[0] and "UserWarning" not in err
    argv = ["predict", "--model", model, "--runs", gappy]
    status, _, err = _run(capsys, *argv, "--out", tmp_path / "p.csv")
    assert status == 0
    assert err.startswith("skthermal predict: warning: ") and err.count("\n") == 1


@pytest.mark.parametrize(
    "label, labels", [("3", [1, 2, 3]), ("hot", ["1", "2", "hot"])]
)
def test_simulate_append_to_a_table_with_integer_labels(
    capsys, tmp_path, label, labels
):
    from skthermal.datasets import read_runs

    out = tmp_path / "e.csv"
    base = ["simulate", "--segment", "4000:20min", "--sample-period", "300"]
    for run in ("1", "2"):
        assert _run(capsys, *base, "--run", run, "--append", "--out", out)[0] == 0
    table = pd.read_csv(out)  # the user's own table: integer labels, no sidecar
    table.to_csv(out, index=False)
    (tmp_path / "e.csv.json").unlink()
    status, _, err = _run(capsys, *base, "--run", label, "--append", "--out", out)
    assert status == 0, err
    runs, meta = read_runs(out, metadata=True)
    assert list(pd.unique(runs["run"])) == labels
    assert meta["run"].tolist() == labels[-1:]


@pytest.fixture(scope="module")
def absurd_reading(workdir):
    """The measured runs with readings of 1e308 (finite, far outside any
    physical range): T02_C and T18_C of run 'I' at time_s 960."""
    runs = pd.read_csv(workdir / "tests.csv")
    at = (runs["run"] == "I") & (runs["time_s"] == 960.0)
    runs.loc[at, ["T02_C", "T18_C"]] = 1e308
    path = workdir / "absurd.csv"
    runs.to_csv(path, index=False)
    return path


def _refused_when_read(err, command, path):
    """The run table's absurd readings (1e308) are refused when it is read,
    naming the file, both columns, the run and the time, before any model
    runs (nothing overflows)."""
    assert err.count("\n") == 1
    assert err.startswith(f"skthermal {command}: error: --runs: {path}: ")
    assert "column 'T02_C' has 1 absurd (beyond 1e+100 in magnitude)" in err
    assert "column 'T18_C' has 1 absurd" in err
    assert "run 'I', time_s 960.0" in err
    assert "overflow" not in err and "RuntimeWarning" not in err


def test_predict_and_evaluate_refuse_absurd_readings_when_reading_the_runs(
    capsys, workdir, tmp_path, absurd_reading, ridge_y
):
    model = tmp_path / "mlp.joblib"
    argv = ["fit", "--runs", workdir / "tests.csv", "--model", "mlp", "--quick"]
    argv += ["--sensors", "T18_C,T46_C", "--train-runs", "IV", "--out", model]
    assert _run(capsys, *argv)[0] == 0
    out = tmp_path / "pred.csv"
    for fitted in (model, ridge_y):
        argv = ["predict", "--model", fitted, "--runs", absurd_reading, "--out", out]
        status, text, err = _run(capsys, *argv)
        assert status == 2 and not text and not out.exists()
        _refused_when_read(err, "predict", absurd_reading)
    argv = ["evaluate", "--runs", absurd_reading, "--model", model]
    status, text, err = _run(capsys, *argv)
    assert status == 2 and not text
    _refused_when_read(err, "evaluate", absurd_reading)


@pytest.mark.parametrize(
    "value, kind", [(np.inf, "inf"), (-np.inf, "-inf"), (np.nan, r"missing \(NaN\)")]
)
def test_evaluate_names_the_run_and_time_of_a_non_finite_prediction(
    capsys, tmp_path, predictions, value, kind
):
    import re

    runs, table = predictions
    table = table.copy()
    table.loc[(table["run"] == "V") & (table["time_s"] == 480.0), "pred_disp_y_um"] = (
        value
    )
    bad = tmp_path / "bad.csv"
    table.to_csv(bad, index=False)
    for argv in (["--runs", runs, "--predictions", bad], ["--runs", bad]):
        if argv[1] == bad:  # the predictions beside the measured columns
            full = pd.read_csv(runs)
            full["pred_disp_y_um"] = table["pred_disp_y_um"].to_numpy()
            full.to_csv(bad, index=False)
        status, _, err = _run(capsys, "evaluate", *argv)
        assert status == 2 and err.count("\n") == 1, err
        assert re.search(
            rf"Column 'pred_disp_y_um' of \S*bad.csv is {kind} at run 'V', "
            r"time_s 480.0 \(1 of \d+ rows without a finite prediction\)",
            err,
        ), err
        assert "Warning" not in err


def test_evaluate_refuses_an_absurd_prediction(capsys, tmp_path, predictions):
    # A prediction of 1e300 was scored: NSE 0.00 and 300-digit figures.
    runs, table = predictions
    table = table.copy()
    table.loc[(table["run"] == "V") & (table["time_s"] == 480.0), "pred_disp_y_um"] = (
        1e300
    )
    bad = tmp_path / "bad.csv"
    table.to_csv(bad, index=False)
    status, _, err = _run(capsys, "evaluate", "--runs", runs, "--predictions", bad)
    assert status == 2 and err.count("\n") == 1, err
    assert "holds 1e+300 at run 'V', time_s 480.0 (1 such row(s)): no " in err, err


def test_evaluate_names_a_prediction_that_is_not_a_number(
    capsys, tmp_path, predictions
):
    # It said only "could not convert string to float: 'oops'".
    runs, table = predictions
    full = pd.read_csv(runs)
    full["pred_disp_y_um"] = table["pred_disp_y_um"].to_numpy().astype(object)
    full.loc[(full["run"] == "V") & (full["time_s"] == 480.0), "pred_disp_y_um"] = (
        "oops"
    )
    bad = tmp_path / "bad.csv"
    full.to_csv(bad, index=False)
    status, _, err = _run(capsys, "evaluate", "--runs", bad)
    assert status == 2 and err.count("\n") == 1, err
    assert (
        "Column 'pred_disp_y_um' of " in err
        and "holds 'oops' at run 'V', time_s 480.0 (1 such row(s))" in err
    ), err


def test_a_reader_that_closes_the_pipe_is_not_an_error():
    # skthermal gap-check --list-effects | head -1: the reader goes away.
    code = (
        "import sys; from skthermal.cli import main; "
        "sys.exit(main(['gap-check', '--list-effects']))"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    proc.stdout.close()  # closed before anything is written
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    proc.stderr.close()
    assert proc.returncode == 141
    assert "Broken pipe" not in err and "Traceback" not in err


def test_fit_on_fewer_samples_than_inputs_warns(capsys, workdir, tmp_path):
    # Three samples of 77 sensors gave "training RMSE 0.00" without a word.
    table = pd.read_csv(workdir / "tests.csv")
    few = tmp_path / "few.csv"
    table[table["run"] == table["run"].iloc[0]].head(3).to_csv(few, index=False)
    argv = ["fit", "--runs", few, "--model", "ridge", "--out", tmp_path / "m.joblib"]
    status, _, err = _run(capsys, *argv)
    assert status == 0 and "2 training sample(s) after the runs' first" in err, err
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C")
    assert status == 0 and "training sample(s)" not in err, err


def test_a_sensor_not_used_may_miss_readings(capsys, workdir, tmp_path):
    # A channel one run lacks was refused even with --sensors leaving it out.
    table = pd.read_csv(workdir / "tests.csv")
    table.loc[table["run"] == table["run"].iloc[-1], "T77_C"] = np.nan
    runs = tmp_path / "gappy.csv"
    table.to_csv(runs, index=False)
    model = tmp_path / "m.joblib"
    argv = ["fit", "--runs", runs, "--model", "ridge", "--out", model]
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C,T12_C")
    assert status == 0, err
    argv = ["predict", "--model", model, "--runs", runs, "--out", tmp_path / "p.csv"]
    status, _, err = _run(capsys, *argv)
    assert status == 0, err
    argv = ["fit", "--runs", runs, "--model", "ridge", "--out", model]
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C,T77_C")
    assert status == 2 and "column 'T77_C' has" in err and "leave the sensor" in err


def test_warning_lines_join_lines_and_count_look_alikes(capsys):
    # A multi-line warning lost its advice after its first line; a search's
    # trials printed one line per trial for warnings differing in numbers.
    import warnings

    from skthermal._cli._common import warning_lines

    with warning_lines("search"):
        warnings.warn("lbfgs failed (status=1):\nSTOP.\n\nIncrease max_iter.")
        for k in range(5):
            warnings.warn(f"rule {k} collapsed at epoch {10 * k}")
        warnings.warn("rule 4 collapsed at epoch 40")  # the same again
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].endswith("lbfgs failed (status=1): STOP. Increase max_iter.")
    assert lines[1].endswith("rule 0 collapsed at epoch 0")
    assert lines[2].endswith(
        "4 more like 'rule 0 collapsed at epoch 0' (other numbers)"
    )
    assert len(lines) == 3


def test_fit_names_a_stuck_sensor(capsys, workdir, tmp_path):
    table = pd.read_csv(workdir / "tests.csv").assign(T07_C=21.5)
    runs = tmp_path / "stuck.csv"
    table.to_csv(runs, index=False)
    argv = ["fit", "--runs", runs, "--model", "ridge", "--out", tmp_path / "m.joblib"]
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C,T07_C")
    assert status == 0 and "Sensor(s) ['T07_C'] do not change" in err, err
    # stuck at another value in every run: its changes are all zero as well
    codes = pd.factorize(table["run"])[0]
    table.assign(T07_C=20.0 + codes).to_csv(runs, index=False)
    status, _, err = _run(capsys, *argv, "--sensors", "T05_C,T07_C")
    assert status == 0 and "Sensor(s) ['T07_C'] do not change" in err, err
    # a driver at rest (no feed in a spindle test) is not a stuck sensor
    status, _, err = _run(
        capsys, *argv[:4], "lag-ridge", *argv[5:], "--sensors", "T05_C"
    )
    assert status == 0 and "do not change" not in err, err


def test_evaluate_marks_the_models_training_runs(capsys, workdir, tmp_path):
    # A model's own training runs score its fit: marked, and out of the mean
    # and pooled rows (they were pooled in unmarked).
    model = tmp_path / "m.joblib"
    fit = ["fit", "--runs", workdir / "tests.csv", "--model", "ridge"]
    fit += ["--sensors", "T01_C,T02_C,T03_C", "--train-runs", "I,IV", "--out", model]
    assert _run(capsys, *fit)[0] == 0
    out = tmp_path / "scores.csv"
    argv = ["evaluate", "--runs", workdir / "tests.csv", "--model", model]
    status, text, err = _run(capsys, *argv, "--out", out)
    assert status == 0, err
    assert "Run(s) 'I', 'IV' are the model's training runs (fitted: yes)" in text
    table = pd.read_csv(out, keep_default_na=False).set_index("run")
    assert table.loc[["I", "IV"], "fitted"].tolist() == ["yes", "yes"]
    assert table.loc[["V", "extra", "mean", "all"], "fitted"].tolist() == [""] * 4
    held_out = table.loc[["V", "extra"], "RMSE_um"].astype(float)
    assert float(table.loc["mean", "RMSE_um"]) == pytest.approx(held_out.mean())
    n = table.loc[["V", "extra"], "n_samples"].astype(int).sum()
    assert int(table.loc["all", "n_samples"]) == n
    # Every run a training run: said so, the mean over them.
    only = tmp_path / "only.csv"
    runs = pd.read_csv(workdir / "tests.csv")
    runs[runs["run"].isin(["I", "IV"])].to_csv(only, index=False)
    status, text, err = _run(capsys, "evaluate", "--runs", only, "--model", model)
    assert status == 0, err
    assert "every run here is one, so the mean and all rows are training" in text
    # Another run under a training run's label (other rows and times) is
    # no training run.
    other = tmp_path / "other.csv"
    first = runs["run"] == "I"
    pd.concat([runs[first].iloc[::2], runs[~first]]).to_csv(other, index=False)
    argv = ["evaluate", "--runs", other, "--model", model, "--out", out]
    status, text, err = _run(capsys, *argv)
    assert status == 0, err
    table = pd.read_csv(out, keep_default_na=False).set_index("run")
    assert table.loc[["I", "IV"], "fitted"].tolist() == ["", "yes"]
