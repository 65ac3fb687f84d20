"""``skthermal gap`` and ``skthermal gap-check``: the sim-to-real gap diagnosis."""

import logging
import sys
from pathlib import Path

import pandas as pd

from skthermal._cli._common import (
    UserError,
    check_out_path,
    machine_from_args,
    machine_label,
    parse_effects,
    read_table,
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


def _show(report, columns, folder):
    """Print the verdict's ranking table and save the report to ``folder``."""
    with pd.option_context("display.width", 140, "display.precision", 3):
        print(report.ranking[columns].to_string(index=False))
    if folder:
        report.save(folder)
        print(f"Report: {folder}")
    return 0


def cmd_gap_external(args):
    """``skthermal gap --simulated sim.csv --runs real.csv``: the gap between
    an external simulation's run table and the measured runs."""
    from skthermal.gap import diagnose_runs

    log_progress(args.quiet)
    for option in ("preset", "machine", "effects"):
        if getattr(args, option, None):
            raise UserError(
                f"--{option} is not used with --simulated: the simulation is the "
                "run table given there."
            )
    check_out_path(args.report, "--report", folder=True)
    simulated = read_table(args.simulated, what="--simulated")
    measured = read_table(args.runs)
    candidates = parse_effects(args.candidates, "--candidates")
    if candidates == []:
        raise UserError("--candidates: give at least one effect.")
    print(
        f"Diagnosing {args.runs} ({measured['run'].nunique()} run(s)) against the "
        f"simulation {args.simulated} ...",
        flush=True,
    )
    try:
        report = diagnose_runs(simulated, measured, candidates=candidates)
    except ValueError as exc:
        raise UserError(f"--simulated/--runs: {exc}") from exc
    print(report.verdict())
    shown = [
        "effect",
        "gap_before",
        "gap_after",
        "shrink",
        "share_of_explainable",
        "p_value",
        "lr_p_value",
        "explains",
    ]
    return _show(report, shown, args.report)


def cmd_gap(args):
    from skthermal.gap import diagnose

    if getattr(args, "simulated", None):
        return cmd_gap_external(args)
    log_progress(args.quiet)
    check_out_path(args.report, "--report", folder=True)
    df = read_table(args.runs)
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
    report = diagnose(machine, df, candidates=candidates)
    print(report.verdict())
    shown = [
        c
        for c in ("effect", "gap_before", "gap_after", "shrink", "p_value", "explains")
        if c in report.ranking.columns
    ]
    return _show(report, shown, args.report)


def cmd_gap_check(args):
    from skthermal.gap import validate

    log_progress(args.quiet)
    if args.seeds < 1:
        raise UserError(f"--seeds must be at least 1, got {args.seeds}.")
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
            f"  {key}: {value:.2f}" if isinstance(value, float) else f"  {key}: {value}"
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
