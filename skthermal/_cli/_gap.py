"""``skthermal gap`` and ``skthermal gap-check``: the sim-to-real gap diagnosis."""

import contextlib
import inspect
import json
import logging
import re
import sys
import warnings
from pathlib import Path

import pandas as pd

from skthermal._cli._common import (
    UserError,
    check_out_path,
    machine_from_args,
    machine_label,
    parse_effects,
    read_table,
    split_list,
)


def log_progress(quiet=False, stream=None):
    """Print INFO records of the ``skthermal`` loggers on stderr (or ``stream``).

    The gap diagnosis reports its steps and candidates through
    :mod:`logging` (logger ``skthermal.gap``); this shows them as
    ``12:03:04 message`` lines. ``quiet`` shows warnings only. The handler
    is installed once on the ``skthermal`` logger and replaced on each call.
    """
    logger = logging.getLogger("skthermal")
    for handler in list(logger.handlers):
        if getattr(handler, "_skthermal_cli", False):
            logger.removeHandler(handler)
    handler = logging.StreamHandler(sys.stderr if stream is None else stream)
    handler.setFormatter(logging.Formatter("%(asctime)s %(message)s", "%H:%M:%S"))
    handler._skthermal_cli = True
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.INFO)
    return handler


# The Python keyword arguments that library messages advise, and the options
# of 'skthermal gap' that do the same.
_PYTHON_WORDS = (
    ("mapping={'measured': 'simulated'}", "--mapping MEASURED=SIMULATED"),
    ("block_hours=", "--block-hours "),
    ("max_samples=", "--max-samples "),
)
_PYTHON_BARE = re.compile(r"(?<![\w-])(block_hours|max_samples)\b")
_PYTHON_NAMES = re.compile(r"(?<![\w-])(channels|mapping)=(?=[\s.,;)]|$)")


def cli_words(message):
    """``message`` with the Python arguments it advises (``mapping={...}``,
    ``channels=``, ``block_hours=``) named as the command's options."""
    text = str(message)
    for python, option in _PYTHON_WORDS:
        text = text.replace(python, option)
    text = _PYTHON_NAMES.sub(lambda m: f"--{m.group(1)}", text)
    return _PYTHON_BARE.sub(lambda m: "--" + m.group(1).replace("_", "-"), text)


@contextlib.contextmanager
def _option_words():
    """Warnings raised inside are shown with :func:`cli_words` applied."""
    with warnings.catch_warnings():
        show = warnings.showwarning

        def rewrite(message, category, *args, **kwargs):
            return show(cli_words(message), category, *args, **kwargs)

        warnings.showwarning = rewrite
        yield


def _list_effects():
    from skthermal._cli._data import effects_text
    from skthermal.simulate import describe_effects

    print(effects_text(describe_effects()))
    return 0


# Columns the diagnosis simulates (or aligns) each run from.
_GAP_DRIVERS = ("run", "time_s", "spindle_rpm", "ambient_C")


def read_gap_table(path, what, *, numeric=()):
    """Read a run table for the gap diagnosis.

    The diagnosis compares whatever channels the two sides share --
    displacements only, temperatures only, or columns with another tool's
    names given by ``--mapping`` -- so the run-table rule "at least one
    ``T<name>_C`` sensor" does not apply. The table is read without that
    validation; its drivers must be there and, like the columns named in
    ``numeric``, be numbers. Value checks (times, missing values) are the
    diagnosis's own, each a one-line error naming the run.
    """
    df = read_table(path, what=what, validate=False)
    missing = [c for c in _GAP_DRIVERS if c not in df.columns]
    if missing:
        from skthermal.datasets import sensor_columns, target_columns

        names = [str(c) for c in df.columns]
        groups = {"temperature": sensor_columns(df), "displacement": target_columns(df)}
        listed = [c for c in names if not any(c in g for g in groups.values())]
        for kind, cols in groups.items():
            if cols:
                span = cols[0] if len(cols) == 1 else f"{cols[0]} .. {cols[-1]}"
                listed.append(f"{len(cols)} {kind} column(s) ({span})")
        hint = (
            " (the workshop air's sensor, if one of the temperature columns, "
            "renamed ambient_C)"
            if "ambient_C" in missing and groups["temperature"]
            else ""
        )
        raise UserError(
            f"{what} {path}: no {', '.join(missing)} column(s); the diagnosis "
            "needs run, time_s, spindle_rpm and ambient_C (and feed_mm_min if "
            f"the axis moved){hint}; the table has {', '.join(listed)}."
        )
    if df.shape[0] == 0:
        raise UserError(f"{what} {path}: the run table has no rows.")
    for col in [*_GAP_DRIVERS[1:], "feed_mm_min", *numeric]:
        if col in df.columns and not pd.api.types.is_numeric_dtype(df[col]):
            values = pd.to_numeric(df[col], errors="coerce")
            bad = values.isna() & df[col].notna()
            if bad.any():
                row = int(bad.to_numpy().argmax())
                header = (
                    "; that row repeats the header line (files joined with "
                    "their headers?): keep one header"
                    if str(df[col].iloc[row]).strip() == str(col)
                    else ""
                )
                raise UserError(
                    f"{what} {path}: column {col!r} holds text "
                    f"({df[col].iloc[row]!r} in run {df['run'].iloc[row]!r}, "
                    f"row {row}); it must hold numbers{header}."
                )
    return df


def _channel_columns(df):
    from skthermal.gap._problem import is_channel

    return [c for c in df.columns if is_channel(c)]


def parse_mapping(value):
    """``"T1_C=sensor1,disp_x_um=dx"`` -> ``{"T1_C": "sensor1", ...}``.

    ``value``: one string or several (the option given again); each a JSON
    object, or comma-separated pairs. A comma inside a name (another tool's
    column, ``"Temp, front [C]=T1_C"``) is read as part of it in a value of
    one pair; between two pairs it could end one name or start the next,
    and is an error saying so."""
    if value is None:
        return None
    mapping = {}
    for item in _mapping_pairs([value] if isinstance(value, str) else value):
        measured, sep, simulated = item.partition("=")
        if not sep or not measured or not simulated or "=" in simulated:
            raise UserError(
                f"--mapping: {item!r} is not MEASURED=SIMULATED (e.g. "
                "--mapping T1_C=sensor1,disp_x_um=dx)."
            )
        if measured in mapping:
            raise UserError(f"--mapping: {measured!r} is mapped twice.")
        mapping[measured] = simulated
    if not mapping:
        raise UserError("--mapping: give at least one MEASURED=SIMULATED pair.")
    return mapping


def _mapping_pairs(values):
    """The ``MEASURED=SIMULATED`` items of the ``--mapping`` values (see
    :func:`parse_mapping`)."""
    items = []
    for value in values:
        if value.lstrip().startswith("{"):
            try:
                pairs = json.loads(value)
            except json.JSONDecodeError as exc:
                raise UserError(
                    f"--mapping: {value!r} is not a JSON object ({exc.msg})."
                ) from None
            if not isinstance(pairs, dict) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in pairs.items()
            ):
                raise UserError(
                    f"--mapping: {value!r} is not a JSON object of names "
                    '(e.g. \'{"Temp, front [C]": "T1_C"}\').'
                )
            items += [f"{k}={v}" for k, v in pairs.items()]
            continue
        pieces = [p for p in value.split(",") if p.strip()]
        pairs, held = [], []
        for piece in pieces:
            if "=" not in piece:
                held.append(piece)
                continue
            if held and pairs:
                raise UserError(
                    f"--mapping: in {value!r}, {','.join(held).strip()!r} may "
                    "end one name or start the next: give the pair of a name "
                    "holding a comma in its own --mapping (e.g. --mapping "
                    '"T1_C=Temp, front [C]"), or all pairs as a JSON object.'
                )
            pairs.append(",".join([*held, piece]).strip())
            held = []
        if held:
            if pairs:  # the end of the last pair's simulated name
                pairs[-1] = ",".join([pairs[-1], *held]).strip()
            else:
                pairs.append(",".join(held).strip())  # no pair: said below
        items += pairs
    return items


def parse_channels(value):
    if value is None:
        return None
    names = split_list(value)
    if not names:
        raise UserError("--channels: give at least one column name.")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise UserError(f"--channels: {twice} named more than once.")
    return names


def _options(args):
    """The keyword arguments of the diagnosis from the command's options."""
    if args.max_samples is not None and args.max_samples < 3:
        raise UserError(f"--max-samples must be at least 3, got {args.max_samples}.")
    if args.block_hours is not None and not (
        pd.notna(args.block_hours) and 0 < args.block_hours < float("inf")
    ):
        raise UserError(f"--block-hours must be positive, got {args.block_hours}.")
    _check_n_jobs(args.n_jobs)
    given = {
        "channels": parse_channels(args.channels),
        "mapping": parse_mapping(args.mapping),
        "max_samples": args.max_samples,
        "block_hours": args.block_hours,
        "n_jobs": args.n_jobs,
    }
    # Only the options given: the library's defaults stay its own.
    return {k: v for k, v in given.items() if v is not None}


def _check_n_jobs(n_jobs):
    if n_jobs == 0:
        raise UserError(
            "--n-jobs must be 1 or more (or -1 for all cores, -2 for all but "
            "one, ...), got 0."
        )


def _used_columns(kwargs):
    """Columns of the measured and of the simulated table the options name."""
    mapping = kwargs.get("mapping") or {}
    measured = [*(kwargs.get("channels") or []), *mapping]
    return measured, [*mapping.values()]


def _library_error(exc, *, prefix=""):
    """A UserError of the diagnosis's ValueError, in the options' words."""
    return UserError(prefix + cli_words(exc))


def _show(report, columns, folder, *, rename=None):
    """Print the verdict's ranking table and save the report to ``folder``."""
    with pd.option_context("display.width", 140, "display.precision", 3):
        print(
            report.ranking[columns].rename(columns=rename or {}).to_string(index=False)
        )
    if folder:
        report.save(folder)
        print(f"Report: {folder}")
    return 0


def _how_far_overall(report):
    """The overall row of the table 'How far' (fine calibration) as text, or
    None when the fine step did not run."""
    evidence = getattr(report, "how_far_evidence", None) or {}
    how_far = getattr(report, "how_far", None)
    if evidence.get("calibration") != "fine" or how_far is None or how_far.empty:
        return None
    rows = how_far[how_far["regime"] == "overall"]
    if rows.empty:
        return None
    row = rows.iloc[0]
    table = pd.DataFrame(
        [
            {
                "effect": row["effect"],
                "gap_before": row["gap_before"],
                "gap_after": row["gap_after"],
                "shrink": row["shrink"],
                "runs_better": (
                    f"{evidence.get('runs_improved')}/{evidence.get('n_runs')}"
                ),
                "p_value": evidence.get("p_value"),
                "explains": report.best_effect == row["effect"],
            }
        ]
    )
    with pd.option_context("display.width", 140, "display.precision", 3):
        return table.to_string(index=False)


def _accepts(function, name):
    try:
        return name in inspect.signature(function).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins only
        return False


def cmd_gap_external(args):
    """``skthermal gap --simulated sim.csv --runs real.csv``: the gap between
    an external simulation's run table and the measured runs."""
    from skthermal.gap import diagnose_runs
    from skthermal.gap._report import RANKING_DETAIL, RANKING_SHOWN

    log_progress(args.quiet)
    for option in ("preset", "machine", "effects", "initial"):
        if getattr(args, option, None):
            raise UserError(
                f"--{option} is not used with --simulated: the simulation is the "
                "run table given there."
            )
    kwargs = _options(args)
    if getattr(args, "driver_initial", None):
        kwargs["driver_initial"] = args.driver_initial
    blocks = _accepts(diagnose_runs, "block_hours")
    if "block_hours" in kwargs and not blocks:
        raise UserError(
            "--block-hours is not available with --simulated: cut the long "
            "record into runs (a new run label per block) in both tables."
        )
    check_out_path(args.report, "--report", folder=True)
    measured_cols, simulated_cols = _used_columns(kwargs)
    simulated = read_gap_table(args.simulated, "--simulated", numeric=simulated_cols)
    measured = read_gap_table(args.runs, "--runs", numeric=measured_cols)
    candidates = parse_effects(args.candidates, "--candidates")
    if candidates == []:
        raise UserError("--candidates: give at least one effect.")
    print(
        f"Diagnosing {args.runs} ({measured['run'].nunique()} run(s)) against the "
        f"simulation {args.simulated} ...",
        flush=True,
    )
    try:
        with _option_words():
            report = diagnose_runs(simulated, measured, candidates=candidates, **kwargs)
    except ValueError as exc:
        raise _library_error(exc, prefix="--simulated/--runs: ") from exc
    print(report.verdict())
    print(report.where_summary())
    shown = [
        c
        for c in RANKING_SHOWN
        if c not in RANKING_DETAIL and c in report.ranking.columns
    ]
    return _show(report, shown, args.report)


def cmd_gap(args):
    from skthermal.gap import diagnose

    if args.list_effects:
        return _list_effects()
    if getattr(args, "simulated", None):
        return cmd_gap_external(args)
    log_progress(args.quiet)
    kwargs = _options(args)
    if getattr(args, "driver_initial", None):
        raise UserError(
            "--driver-initial is used with --simulated; with --preset/--machine "
            "the simulator integrates the drivers from the state --initial gives."
        )
    if args.initial is not None:
        kwargs["initial"] = args.initial
    check_out_path(args.report, "--report", folder=True)
    df = read_gap_table(args.runs, "--runs", numeric=_used_columns(kwargs)[0])
    effects = parse_effects(args.effects)
    machine = machine_from_args(args, effects=[] if effects is None else effects)
    if effects is None and getattr(args, "machine", None) is not None:
        # A machine file that records its effect switches (a calibrated
        # machine written by to_spec) is diagnosed as written.
        recorded = machine.spec.effects
        if recorded:
            machine = machine.with_effects([e for e, on in recorded.items() if on])
    candidates = parse_effects(args.candidates, "--candidates")
    print(
        f"Diagnosing {args.runs} ({df['run'].nunique()} run(s)) against "
        f"{machine_label(args)} "
        f"(effects on: {', '.join(machine.effects) or 'none'}) ...",
        flush=True,
    )
    try:
        with _option_words():
            report = diagnose(machine, df, candidates=candidates, **kwargs)
    except ValueError as exc:
        raise _library_error(exc) from exc
    print(report.verdict())
    print(report.where_summary())
    overall = _how_far_overall(report)
    if overall is not None:
        print("How far (fine calibration of the spindle head), overall:")
        print(overall)
    print("Which effect (screening calibration):")
    shown = [
        c
        for c in ("effect", "gap_before", "gap_after", "shrink", "p_value", "explains")
        if c in report.ranking.columns
    ]
    return _show(
        report, shown, args.report, rename={"explains": "explains (screening)"}
    )


def cmd_gap_check(args):
    from skthermal.gap import validate

    if args.list_effects:
        return _list_effects()
    log_progress(args.quiet)
    if args.seeds < 1:
        raise UserError(f"--seeds must be at least 1, got {args.seeds}.")
    _check_n_jobs(args.n_jobs)
    check_out_path(args.report, "--report", folder=True)
    effects = parse_effects(args.effects)
    print(
        f"Checking the gap diagnosis: {args.seeds} seed(s) per case, preset "
        f"{args.preset} ...",
        flush=True,
    )
    result = validate(
        effects,
        seeds=args.seeds,
        preset=args.preset,
        random_state=args.seed,
        n_jobs=args.n_jobs,
    )
    for key, value in result.rates.items():
        print(
            f"  {key}: {value:.3f}" if isinstance(value, float) else f"  {key}: {value}"
        )
    for key, met in result.targets.items():
        print(f"  target {key}: {'met' if met else 'NOT met'}")
    if args.report:
        folder = Path(args.report)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "validation.md").write_text(result.to_markdown(), encoding="utf-8")
        result.cases.to_csv(folder / "cases.csv", index=False)
        result.confusion.to_csv(folder / "confusion.csv")
        print(f"Report: {folder}")
    return 0 if result.meets_targets() else 1
