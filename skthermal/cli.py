"""The ``skthermal`` command.

Subcommands:

``reproduce``
    The papers' Machine B study on the simulator: Tests I-VI, sensor
    selection, ANFIS-FCM, ANFIS-Grid, GNNMCI, Grey-PSO and an MLP trained on
    Test IV and scored on the other tests, beside the papers' figures; writes
    a report folder.
``simulate``, ``select``, ``fit``, ``predict``, ``evaluate``
    The workflow on run tables: simulate tests, select sensors, fit a named
    model, predict, score.
``search``, ``gap``, ``gap-check``
    Optuna structure search and the sim-to-real gap diagnosis (optional
    modules, imported when used).
``demo``
    An end-to-end run on generated data: synthetic heating tests with groups
    of collinear sensors, fuzzy c-means sensor selection, a compensation model
    trained on some runs and evaluated on held-out runs, and a table of the
    papers' metrics.

The implementations live in the modules of :mod:`skthermal._cli`, imported
only when their subcommand runs (``skthermal --help`` imports none of them).
User errors print one line and exit with status 2, never a traceback;
warnings print one line each, ``skthermal COMMAND: warning: ...``.
"""

import argparse
import importlib
import os
import shutil
import sys
import textwrap

__all__ = ["build_parser", "main"]


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (and the hint to ask for --help), exit 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


class _Once(argparse.Action):
    """An option given at most once: ``--target x --target z`` kept z alone,
    fitting one model of the last target, silently."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, self.dest, None) is not None:
            parser.error(
                f"{option_string} given twice ({getattr(namespace, self.dest)!r} "
                f"and {values!r}): a model predicts one displacement column; "
                "fit one per target"
            )
        setattr(namespace, self.dest, values)


def _integer(text):
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def _seed(text):
    """A random seed as numpy takes it: an integer from 0 to 2**32 - 1."""
    value = _integer(text)
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(
            f"must be an integer from 0 to {2**32 - 1}, got {value}"
        )
    return value


def _nonnegative(text):
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be 0 or more, got {value}")
    return value


_FORMATTER = argparse.RawDescriptionHelpFormatter


def _wrap(text):
    """``text`` filled to the terminal width (argparse keeps raw text as is)."""
    width = min(shutil.get_terminal_size((80, 24)).columns, 100) - 2
    return textwrap.fill(text, width=max(width, 40), break_on_hyphens=False)


def _sub(sub, name, help, description, epilog):
    return sub.add_parser(
        name,
        help=help,
        description=_wrap(description),
        epilog="examples:\n" + epilog,
        formatter_class=_FORMATTER,
    )


def _add_demo(sub):
    demo = _sub(
        sub,
        "demo",
        "end-to-end demo on generated data",
        "Generate heating tests with groups of collinear sensors, select one "
        "sensor per group with fuzzy c-means, and score compensation models "
        "on held-out runs.",
        "  skthermal demo\n  skthermal demo --groups 4 --runs 5 --out demo/\n",
    )
    demo.add_argument("--runs", type=int, default=4, help="test runs (default 4)")
    demo.add_argument(
        "--groups", type=int, default=3, help="heat-driven sensor groups (default 3)"
    )
    demo.add_argument("--sensors-per-group", type=int, default=10, help="default 10")
    demo.add_argument(
        "--noise-sensors", type=_nonnegative, default=10, help="default 10"
    )
    demo.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    demo.add_argument(
        "--out", metavar="DIR", help="also write the runs and scores here"
    )
    demo.set_defaults(func="_study:cmd_demo")


def _add_reproduce(sub):
    p = _sub(
        sub,
        "reproduce",
        "replicate the papers' Machine B study on the simulator",
        "Simulate Machine B's Tests I-VI (001 §5.3), select 5 of the 77 "
        "temperature sensors on Test IV (GM(1,N) influence + fuzzy c-means), "
        "train ANFIS-FCM (3 rules), ANFIS-Grid (243 rules), GNNMCI, Grey-PSO and "
        "an MLP (10 hidden) on Test IV, score them on Tests I, II, III, V and VI "
        "(R, RMSE, NSE, residual band, improvement, rules) beside the papers' "
        "figures (001 Tables 5-7/5-8), and write a report folder: report.md, "
        "tables as CSV, figures as PNG (cf. 001 Figs. 5-11..5-15), the run "
        "table and settings.json (settings, versions, seed, timings). Progress "
        "goes to stderr. Default settings (10 s sampling, as the thesis) take "
        "about half a minute on two cores.",
        "  skthermal reproduce\n"
        "  skthermal reproduce --out report/ --seed 3\n"
        "  skthermal reproduce --quick --no-figures          # a few seconds\n"
        "  skthermal reproduce --sample-period 30 --models anfis-fcm,anfis-grid\n",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        default="skthermal-report",
        help="report folder (default skthermal-report/; files in it are replaced)",
    )
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.add_argument(
        "--quick",
        action="store_true",
        help="tiny budget: 120 s sampling, few epochs (for tests and smoke runs)",
    )
    p.add_argument(
        "--sample-period",
        type=float,
        metavar="SECONDS",
        help="sampling of the simulated tests (default 10, as the thesis; 120 "
        "with --quick)",
    )
    p.add_argument(
        "--models",
        metavar="LIST",
        help="comma-separated subset of anfis-fcm, anfis-grid, gnnmci, grey-pso, "
        "mlp (default: these, the papers' models), ridge, lag-ridge",
    )
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.set_defaults(func="_study:cmd_reproduce")


def _add_simulate(sub):
    p = _sub(
        sub,
        "simulate",
        "simulate test runs of a preset machine or your own as a run table",
        "Simulate a test programme on a preset machine (--preset) or on your "
        "own (--machine FILE.toml; thermal network, sensors, displacements) "
        "and write it as a run table. Either a duty cycle of --segment steps "
        "and an ambient profile (one run), or Machine B's Tests I-VI with "
        "--tests. Speeds above 100000 rpm, feeds above 200000 mm/min and air "
        "outside -50..100 °C are refused as typos.",
        "  skthermal simulate --segment 4000:1h --segment 0:1h --out runs.csv\n"
        "  skthermal simulate --segment 6000:2h:1500,0:90min --ambient-mean 22 \\\n"
        "      --ambient-trend 0.3 --run hot --append --out runs.csv\n"
        "  skthermal simulate --tests I,IV,V --sample-period 60 --out tests.csv.gz\n"
        "  skthermal simulate --effects sensor_lag,tool_growth --out runs.csv\n"
        "  skthermal simulate --list-effects\n"
        "  skthermal simulate --machine my-rig.toml --out runs.csv\n",
    )
    p.add_argument(
        "--preset",
        choices=["vmc-b", "vmc-a", "spindle-rig"],
        help="machine: vmc-b (Machine B, 77 sensors), vmc-a (26) or spindle-rig "
        "(16 sensors, 5 spindle-nose channels); default vmc-b",
    )
    p.add_argument(
        "--machine",
        metavar="FILE.toml",
        help="your own machine description (see docs/own_machine.md) instead "
        "of a preset; not together with --preset",
    )
    p.add_argument(
        "--segment",
        action="append",
        metavar="RPM:DURATION[:FEED]",
        help="a duty-cycle step, repeatable or comma-separated; RPM at most "
        "100000, DURATION in hours (at most 48 without a unit) or with a unit "
        "(1h, 90min, 600s), FEED in mm/min, at most 200000 (default: 4000:1h "
        "0:1h)",
    )
    p.add_argument(
        "--tests",
        metavar="LIST",
        help="simulate Machine B's tests instead, e.g. I,IV,V (of I..VI)",
    )
    # Defaults None: skthermal._cli._data.AMBIENT_DEFAULTS fills them in, so
    # that an option given with --tests can be named.
    g = p.add_argument_group("ambient air (not with --tests)")
    g.add_argument("--ambient-mean", type=float, help="°C (default 20)")
    g.add_argument("--ambient-trend", type=float, help="°C per hour (default 0)")
    g.add_argument(
        "--day-amplitude", type=float, help="daily swing amplitude, °C (default 0)"
    )
    g.add_argument("--start-hour", type=float, help="hour of day at start (8)")
    g.add_argument("--ambient-noise", type=float, help="°C (default 0.05)")
    p.add_argument(
        "--effects",
        metavar="LIST",
        help="physical effects to switch on (comma list, 'all' or 'none'; "
        "default: the machine's); see --list-effects",
    )
    p.add_argument(
        "--list-effects", action="store_true", help="print the effects and exit"
    )
    p.add_argument(
        "--sample-period",
        type=float,
        default=30.0,
        metavar="SECONDS",
        help="default 30",
    )
    p.add_argument("--run", default="run1", help="run label (default run1)")
    p.add_argument(
        "--no-noise", action="store_true", help="noiseless sensors and displacements"
    )
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.add_argument(
        "--append",
        action="store_true",
        help="add the run(s) to an existing --out table instead of replacing it",
    )
    p.add_argument(
        "--out",
        metavar="FILE",
        default="runs.csv",
        help="run table to write: .csv, .csv.gz, .parquet (default runs.csv)",
    )
    p.set_defaults(func="_data:cmd_simulate")


def _add_select(sub):
    p = _sub(
        sub,
        "select",
        "select temperature sensors from a run table",
        "Fit a sensor selector on the runs and write the kept sensors. fcm: "
        "GM(1,N) grey influence + fuzzy c-means grouping, the most influential "
        "sensor of each group (000 §4.2); grey: the top sensors by GM(1,N) "
        "influence; gra: the top sensors by grey relational similitude degree.",
        "  skthermal select --runs runs.csv --out sensors.json\n"
        "  skthermal select --runs tests.csv --method grey --n-sensors 4 \\\n"
        "      --train-runs IV --out sensors.csv\n",
    )
    p.add_argument("--runs", metavar="FILE", required=True, help="run table")
    p.add_argument(
        "--method",
        choices=["fcm", "grey", "gra"],
        default="fcm",
        help="selector (default fcm)",
    )
    p.add_argument(
        "--n-sensors", type=int, default=5, help="sensors to keep (default 5)"
    )
    p.add_argument(
        "--target",
        action=_Once,
        help="displacement column (default: the only one, or disp_y_um)",
    )
    p.add_argument("--train-runs", metavar="LIST", help="runs to fit on (default all)")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.add_argument(
        "--out",
        metavar="FILE",
        default="sensors.json",
        help="sensor list: .json (names, scores) or .csv (one row per sensor); "
        "default sensors.json",
    )
    p.set_defaults(func="_data:cmd_select")


def _add_fit(sub):
    p = _sub(
        sub,
        "fit",
        "fit a named model on a run table and save it",
        "Fit a named model on the runs: anfis-fcm (3 rules), anfis-grid (3 MFs per "
        "input), gnnmci, grey-pso or mlp (10 hidden), the papers' models; or "
        "the baselines ridge (the tuned linear baseline) and lag-ridge (the "
        "recommended dynamic model: lag features of the temperatures, the "
        "spindle speed and the feed, settings by time-ordered CV; it also reads "
        "spindle_rpm and feed_mm_min when the table has them). Inputs and "
        "target are "
        "taken as changes since the start of each run; the model predicts the "
        "change of the displacement since the run started. Inputs: --sensors "
        "(names or a file from 'skthermal select'), a --selector, or every "
        "sensor. A .skops model file (skthermal.io) loads without "
        "running code from the file; any other name is a joblib pickle: load "
        "only joblib files you trust.",
        "  skthermal fit --runs runs.csv --model anfis-fcm --sensors sensors.json\n"
        "  skthermal fit --runs tests.csv --train-runs IV --model gnnmci \\\n"
        "      --selector fcm --n-sensors 5 --out gnnmci.joblib\n"
        "  skthermal fit --runs runs.csv --model anfis-grid --sensors T05_C,T40_C \\\n"
        "      --set epochs=30 --set n_mfs=2\n"
        "  skthermal fit --runs spindle.csv --model lag-ridge --out lag.joblib\n"
        "  skthermal fit --runs spindle.csv --model lag-ridge --guard hold \\\n"
        "      --out lag.skops\n",
    )
    p.add_argument("--runs", metavar="FILE", required=True, help="run table")
    p.add_argument(
        "--model",
        required=True,
        metavar="NAME",
        help="anfis-fcm, anfis-grid, gnnmci, grey-pso, mlp, ridge or lag-ridge",
    )
    p.add_argument(
        "--target",
        action=_Once,
        help="displacement column (default: the only one, or disp_y_um)",
    )
    p.add_argument(
        "--sensors",
        metavar="LIST|FILE",
        help="input sensors: comma list, or a .json/.csv from 'skthermal select'",
    )
    p.add_argument(
        "--selector",
        choices=["fcm", "grey", "gra"],
        help="select the inputs first with this selector",
    )
    p.add_argument(
        "--n-sensors", type=int, default=5, help="with --selector (default 5)"
    )
    p.add_argument("--train-runs", metavar="LIST", help="runs to fit on (default all)")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="a model parameter, e.g. epochs=50 (repeatable; JSON values)",
    )
    p.add_argument("--quick", action="store_true", help="a small training budget")
    p.add_argument(
        "--guard",
        choices=["warn", "clip", "hold"],
        help="wrap the model in a GuardedRegressor of this mode: 'skthermal "
        "predict' then checks every reading against the training data (range, "
        "jumps, flat-lines), bounds the prediction (clip, hold) and writes "
        "guard_ok, guard_action and guard_reason columns",
    )
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.add_argument(
        "--out",
        metavar="FILE",
        default="model.joblib",
        help="model file: *.skops (safe) or joblib (default model.joblib)",
    )
    p.set_defaults(func="_models:cmd_fit")


def _add_predict(sub):
    p = _sub(
        sub,
        "predict",
        "predict with a saved model",
        "Predict a run table with a model from 'skthermal fit' and write the "
        "table with a pred_<target> column: the predicted change of the "
        "displacement since the start of each run (zero on its first row; rows "
        "that continue a run given to 'skthermal fit' go on from where it "
        "left off).",
        "  skthermal predict --model model.joblib --runs new.csv --out pred.csv\n",
    )
    p.add_argument("--model", metavar="FILE", required=True, help="model file")
    p.add_argument("--runs", metavar="FILE", required=True, help="run table")
    p.add_argument(
        "--out",
        metavar="FILE",
        default="predictions.csv",
        help="default predictions.csv",
    )
    p.set_defaults(func="_models:cmd_predict")


def _add_evaluate(sub):
    p = _sub(
        sub,
        "evaluate",
        "score predictions against measurements, per run",
        "Score predictions per run with the papers' metrics: R, RMSE, NSE, "
        "residual band max|error| and improvement 1 - max|error| / max|measured| "
        "(001 §3.8). Measured and predicted displacements are compared as "
        "changes since the start of each run. Predictions come from --model, "
        "from a --predictions table (joined on run and time_s), or from a "
        "pred_<target> column of --runs itself.",
        "  skthermal evaluate --runs pred.csv\n"
        "  skthermal evaluate --runs test.csv --predictions pred.csv --out s.md\n"
        "  skthermal evaluate --runs test.csv --model model.joblib --out s.csv\n",
    )
    p.add_argument("--runs", metavar="FILE", required=True, help="measured runs")
    p.add_argument("--predictions", metavar="FILE", help="table with pred_<target>")
    p.add_argument("--model", metavar="FILE", help="predict with this model")
    p.add_argument("--target", action=_Once, help="displacement column")
    p.add_argument("--out", metavar="FILE", help="write the table (.csv or .md)")
    p.set_defaults(func="_models:cmd_evaluate")


def _add_search(sub):
    p = _sub(
        sub,
        "search",
        "Optuna search of a model's structure (needs optuna)",
        "Search a named model's structure and training settings with Optuna "
        "(skthermal.model_selection.run_search), scored by cross-validation "
        "over whole runs (GroupKFold, up to 5 folds), with the built-in search "
        "spaces (ANFIS: rules/MFs, MF shape, epochs, step size; grey-pso: "
        "calibration by variable projection or least squares, ridge, delay; "
        "gnnmci: PSO settings; MLP: hidden neurons, alpha, activation). A "
        "--storage "
        "keeps the study: run the same command in several processes or "
        "machines to share the trials, or later to resume.",
        "  skthermal search --runs tests.csv --model anfis-fcm --trials 50 \\\n"
        "      --sensors sensors.json\n"
        "  skthermal search --runs tests.csv --model mlp --storage study.db \\\n"
        "      --study-name mlp-b --out best.json --save-model best.joblib\n",
    )
    p.add_argument("--runs", metavar="FILE", required=True, help="run table")
    p.add_argument(
        "--train-runs",
        metavar="LIST",
        help="runs to search and refit on (default all): the others stay held out",
    )
    p.add_argument(
        "--model",
        required=True,
        metavar="NAME",
        help="anfis-fcm, anfis-grid, gnnmci, grey-pso or mlp (ridge and "
        "lag-ridge tune themselves in fit)",
    )
    p.add_argument(
        "--trials",
        type=int,
        default=20,
        help="default 20; 0 with --storage: no new trial, the stored study's "
        "best so far (with --out/--save-model)",
    )
    p.add_argument(
        "--storage",
        metavar="URL|PATH",
        help="Optuna storage: a .db/.sqlite or .log/.journal path, or a URL",
    )
    p.add_argument(
        "--study-name",
        help="name of the study in the storage (default skthermal-<model>)",
    )
    p.add_argument(
        "--target",
        action=_Once,
        help="displacement column (default: the only one, or disp_y_um)",
    )
    p.add_argument(
        "--sensors",
        metavar="LIST|FILE",
        help="input sensors: comma list or a file from 'skthermal select' "
        "(default all)",
    )
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.add_argument("--out", metavar="FILE", help="write the best parameters (JSON)")
    p.add_argument(
        "--save-model",
        metavar="FILE",
        help="save the best model, refitted on all (--train-runs) runs (as "
        "'skthermal fit')",
    )
    p.set_defaults(func="_models:cmd_search")


def _add_gap(sub):
    p = _sub(
        sub,
        "gap",
        "diagnose the gap between real runs and the simulator",
        "Compare real runs with the preset machine driven by the same drivers "
        "(skthermal.gap): where and in which regime the simulation misses, and "
        "which candidate physical effects close the gap.",
        "  skthermal gap --runs real.csv --preset vmc-b\n"
        "  skthermal gap --runs real.csv --preset vmc-a --report gap/ \\\n"
        "      --candidates tool_growth,ambient_transient\n"
        "  skthermal gap --simulated sim.csv --runs real.csv --report gap/\n"
        "  skthermal gap --runs record.csv --preset spindle-rig --block-hours 8\n"
        "  skthermal gap --simulated sim.csv --runs real.csv \\\n"
        "      --mapping T1_C=sensor1,T2_C=sensor2\n"
        "  skthermal gap --list-effects\n",
    )
    p.add_argument(
        "--runs",
        metavar="FILE",
        help="real run table (required, but for --list-effects): run, time_s, "
        "spindle_rpm, ambient_C (feed_mm_min) and the measured channels -- "
        "temperatures T*_C and/or "
        "displacements disp_*_um",
    )
    p.add_argument(
        "--simulated",
        metavar="FILE",
        help="run table of your own simulation of the same runs (same drivers; "
        "at the measured times, or at its own step, then interpolated onto "
        "them); not together with --preset or --machine (see "
        "docs/gap_external.md)",
    )
    p.add_argument(
        "--preset",
        choices=["vmc-b", "vmc-a", "spindle-rig"],
        help="default vmc-b",
    )
    p.add_argument(
        "--machine",
        metavar="FILE.toml",
        help="your own machine description (see docs/own_machine.md) instead "
        "of a preset; not together with --preset",
    )
    p.add_argument(
        "--effects",
        metavar="LIST",
        help="effects the simulation already has (comma list; default: those "
        "a --machine file records as on, else none)",
    )
    p.add_argument(
        "--candidates",
        metavar="LIST",
        help="candidate effects to test (comma list; default every other "
        "effect); see --list-effects",
    )
    p.add_argument(
        "--channels",
        metavar="LIST",
        help="measured columns to compare (comma list; default every measured "
        "T*_C / disp_*_um column the simulation also has, or that --mapping "
        "names)",
    )
    p.add_argument(
        "--mapping",
        metavar="MEASURED=SIMULATED,...",
        action="append",
        help="compare measured columns with simulated ones of other names, "
        "e.g. T1_C=sensor1,disp_x_um=dx (with --preset/--machine: the "
        "machine's channel names); may be given again: give the pair of a "
        'name holding a comma in its own --mapping ("T1_C=Temp, front '
        '[C]"), or all pairs as a JSON object '
        '(\'{"T1_C": "Temp, front [C]"}\')',
    )
    p.add_argument(
        "--block-hours",
        type=float,
        metavar="H",
        help="cut every run longer than 1.5 x H hours into blocks of about H "
        "hours that count as runs for the held-out scoring: diagnoses one long "
        "record (with --simulated only where skthermal.gap.diagnose_runs "
        "accepts block_hours)",
    )
    p.add_argument(
        "--initial",
        choices=["auto", "ambient", "measured"],
        help="the machine's state at the start of every run (with --preset/"
        "--machine): 'measured' (estimated from the run's first temperature "
        "readings, for runs that start warm from earlier work), 'ambient' "
        "(soaked at the first air reading) or 'auto' (default: 'measured' "
        "when the runs hold any of the machine's sensors)",
    )
    p.add_argument(
        "--driver-initial",
        choices=["rest", "steady"],
        help="with --simulated: the drivers' heat before every run, for the "
        "terms that filter the drivers (feed_heating): 'rest' (default: the "
        "runs start soaked) or 'steady' (as the first row's drivers give it "
        "in steady state, for runs that start where the machine had been "
        "working)",
    )
    p.add_argument(
        "--max-samples",
        type=int,
        metavar="N",
        help="compare at most N samples per run (or block), thinned evenly "
        "(default 600; fewer is faster)",
    )
    p.add_argument(
        "--report",
        metavar="DIR",
        help="write report.md, report.html, report.json, tables and figures",
    )
    p.add_argument(
        "--list-effects",
        action="store_true",
        help="print the candidate effects and exit",
    )
    p.add_argument(
        "--n-jobs",
        type=int,
        help="calibrations in parallel (joblib; default 1, -1 every core)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(func="_gap:cmd_gap")

    p = _sub(
        sub,
        "gap-check",
        "check that the gap diagnosis finds known, planted effects",
        "Self-check of the gap diagnosis (skthermal.gap.validate): simulate "
        "'real' runs with a known effect switched on (and null and "
        "out-of-vocabulary cases), diagnose them against the simulation "
        "lacking it, and report the detection rates against their targets. "
        "Exit status 1 when a target is not met. Slow: every case is a full "
        "diagnosis (tens of seconds each).",
        "  skthermal gap-check\n  skthermal gap-check --seeds 5 --report check/\n",
    )
    p.add_argument(
        "--seeds", type=int, default=5, help="campaigns per case (default 5)"
    )
    p.add_argument(
        "--preset", choices=["vmc-b", "vmc-a"], default="vmc-b", help="default vmc-b"
    )
    p.add_argument(
        "--effects",
        metavar="LIST",
        help="effects to plant (default every effect); see --list-effects",
    )
    p.add_argument(
        "--list-effects", action="store_true", help="print the effects and exit"
    )
    p.add_argument(
        "--report",
        metavar="DIR",
        help="write validation.md, cases.csv and confusion.csv here",
    )
    p.add_argument("--n-jobs", type=int, help="parallel cases (joblib; default 1)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    p.set_defaults(func="_gap:cmd_gap_check")


def build_parser():
    parser = _Parser(
        prog="skthermal",
        description="Thermal-error modelling of CNC machine tools.",
        epilog="examples:\n"
        "  skthermal reproduce                  # the papers' study, about 30 s\n"
        "  skthermal simulate --tests I,IV,V --out tests.csv\n"
        "  skthermal select --runs tests.csv --train-runs IV --out sensors.json\n"
        "  skthermal fit --runs tests.csv --train-runs IV --model anfis-fcm \\\n"
        "      --sensors sensors.json --out model.joblib\n"
        "  skthermal predict --model model.joblib --runs tests.csv --out pred.csv\n"
        "  skthermal evaluate --runs pred.csv\n"
        "\n'skthermal COMMAND --help' describes a command.",
        formatter_class=_FORMATTER,
    )
    from skthermal import __version__  # the package only, no estimators

    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_reproduce(sub)
    _add_simulate(sub)
    _add_select(sub)
    _add_fit(sub)
    _add_predict(sub)
    _add_evaluate(sub)
    _add_search(sub)
    _add_gap(sub)
    _add_demo(sub)
    # The command parsers, so that main can report an unknown option in the
    # command's own words.
    parser.commands = sub.choices
    return parser


def main(argv=None):
    """Entry point of the ``skthermal`` command; returns the exit status."""
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        # An option the command does not take: its own usage error (and the
        # hint to its --help), not the top-level one.
        where = parser.commands.get(args.command, parser)
        where.error(f"unrecognized arguments: {' '.join(unknown)}")
    if args.command is None:
        parser.print_help()
        return 0
    args.command_line = " ".join(["skthermal", *argv])
    module, _, name = args.func.partition(":")
    command = getattr(importlib.import_module(f"skthermal._cli.{module}"), name)
    from skthermal._cli._common import UserError, warning_lines

    try:
        with warning_lines(args.command):
            return command(args)
    except BrokenPipeError:
        # The reader of the output went away (skthermal gap | head): not an
        # error of the command. Python's recipe: send the rest of the output
        # to devnull so that flushing it at exit does not fail again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # as a shell reports a pipe closed early (128 + SIGPIPE)
    except (UserError, ValueError, OSError) as exc:
        # OSError: a file that cannot be read or written (missing, a folder,
        # no permission, a parent that is a file).
        print(f"skthermal {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"skthermal {args.command}: interrupted", file=sys.stderr)
        return 130


def _one_line(exc):
    return " ".join(str(exc).split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
