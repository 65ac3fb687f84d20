"""``skthermal simulate`` and ``skthermal select``: make and reduce run tables."""

import json
import shutil
import textwrap
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal._cli._common import (
    UserError,
    check_machine_sensors,
    check_out_path,
    check_out_table,
    check_positive,
    label_text,
    machine_from_args,
    machine_label,
    parse_effects,
    pick_target,
    read_table,
    run_mask,
    split_list,
    write_table,
)
from skthermal.simulate._machine import PLAUSIBLE_FEED_MM_MIN, PLAUSIBLE_RPM

_HOURS = {"h": 1.0, "hr": 1.0, "min": 1 / 60, "m": 1 / 60, "s": 1 / 3600}
# Longest duration accepted as a bare number (hours); longer needs a unit.
BARE_HOURS_LIMIT = 48.0
# Air the simulate command accepts (wider than the run tables' plausible
# workshop air, utils._runs.AIR_RANGE_C, which only warns).
ACCEPTED_AIR_C = (-50.0, 100.0)


def parse_segments(specs):
    """``["4000:1h,0:30min", "6000:2:1500"]`` -> ``[(s, rpm, feed), ...]``."""
    segments = []
    for spec in split_list(specs):
        parts = spec.split(":")
        if len(parts) not in (2, 3):
            raise UserError(
                f"--segment {spec!r}: expected RPM:DURATION[:FEED], e.g. 4000:1h, "
                "0:30min or 6000:2h:1500."
            )
        try:
            rpm = float(parts[0])
            dur = parts[1].strip().lower()
            unit = next((u for u in _HOURS if dur.endswith(u)), None)
            hours = float(dur[: -len(unit)] if unit else dur) * _HOURS.get(unit, 1.0)
            feed = float(parts[2]) if len(parts) == 3 else 0.0
        except ValueError as exc:
            raise UserError(
                f"--segment {spec!r}: RPM, DURATION (hours, or with h/min/s) and "
                "FEED must be numbers."
            ) from exc
        if not (np.isfinite(rpm) and np.isfinite(feed) and np.isfinite(hours)):
            raise UserError(f"--segment {spec!r}: every value must be finite.")
        if rpm < 0 or feed < 0 or not hours > 0:
            raise UserError(
                f"--segment {spec!r}: speed and feed must be >= 0 and the duration "
                "positive."
            )
        # The simulator's plausibility limits (beyond them a value is a typo
        # or a unit slip; it warns): the command refuses them.
        for value, name, unit_name, limit in (
            (rpm, "spindle speed", "rpm", PLAUSIBLE_RPM),
            (feed, "feed", "mm/min", PLAUSIBLE_FEED_MM_MIN),
        ):
            if value > limit:
                raise UserError(
                    f"--segment {spec!r}: {name} {value:g} {unit_name} is above "
                    f"the limit of {limit:g} {unit_name} this command accepts."
                )
        if unit is None and hours > BARE_HOURS_LIMIT:
            # A bare number is hours: 3600 would be 150 days, surely seconds.
            raise UserError(
                f"--segment {spec!r}: a DURATION without a unit is in hours, so "
                f"{dur} would be {hours / 24:.0f} days; write the unit "
                f"({dur}s, {dur}min or {dur}h)."
            )
        segments.append((hours * 3600.0, rpm, feed))
    return segments


def check_air(ambient, duration_s):
    """A UserError if the air of ``ambient`` (without its noise) leaves
    :data:`ACCEPTED_AIR_C` during the first ``duration_s`` seconds."""
    low, high = ACCEPTED_AIR_C
    time_s = np.linspace(0.0, duration_s, 2001)
    air = replace(ambient, noise_C=0.0).sample(time_s)
    worst = int(np.argmax(np.maximum(air - high, low - air)))
    if not low <= air[worst] <= high:
        raise UserError(
            "--ambient-mean/--ambient-trend/--day-amplitude: the air reaches "
            f"{air[worst]:.4g} °C at {time_s[worst] / 3600:.3g} h, outside the "
            f"{low:g}..{high:g} °C this command accepts."
        )


def effects_text(table, width=None):
    """The effects table as text blocks wrapped to the terminal width.

    One block per effect: its name, then its parameters and its summary
    indented below, each wrapped to ``width`` columns (default: the
    terminal's, at most 100).
    """
    if width is None:
        width = min(shutil.get_terminal_size((80, 24)).columns, 100)
    width = max(int(width), 40)
    blocks = []
    for row in table.to_dict("records"):
        lines = [str(row["effect"])]
        for label, text in (("parameters: ", row["parameters"]), ("", row["summary"])):
            lines += textwrap.wrap(
                label + str(text),
                width=width,
                initial_indent="    ",
                subsequent_indent="    ",
                break_on_hyphens=False,
            )
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def _relabel(runs, convert):
    """``runs`` and the records of its ``attrs["metadata"]`` with every run
    label passed through ``convert``."""
    out = runs.assign(run=runs["run"].map(convert))
    out.attrs["metadata"] = [
        {**record, "run": convert(record["run"])}
        for record in runs.attrs.get("metadata", [])
    ]
    return out


def _same_label_kind(old, new):
    """The old table and the new runs with run labels of one kind.

    A table read with integer labels (1, 2) gets new runs labelled by
    ``--run`` (text): they become integers when they are whole numbers
    (``--run 3``), else every label becomes text (``"1"``, ``"2"``,
    ``"hot"``), so that the table never mixes kinds, which CSV cannot keep
    apart.
    """
    integer = pd.api.types.is_integer_dtype
    if not integer(old["run"]) or integer(new["run"]):
        return old, new
    text = new["run"].astype(str)
    if text.str.fullmatch(r"-?(?:0|[1-9][0-9]{0,17})").all():
        return old, _relabel(new, int)
    return _relabel(old, str), _relabel(new, str)


# The ambient-air options of ``simulate`` and their defaults (the parser's
# are None, so that an option given with --tests can be named).
AMBIENT_DEFAULTS = {
    "ambient_mean": 20.0,
    "ambient_trend": 0.0,
    "day_amplitude": 0.0,
    "start_hour": 8.0,
    "ambient_noise": 0.05,
}


def cmd_simulate(args):
    from skthermal.datasets import concat_runs, make_machine_b_tests, read_runs
    from skthermal.simulate import (
        AmbientProfile,
        DutyCycle,
        describe_effects,
    )

    if args.list_effects:
        print(effects_text(describe_effects()))
        return 0
    check_positive(args.sample_period, "--sample-period")
    check_out_table(args.out)
    check_out_path(args.out, "--out")
    machine = machine_from_args(args, effects=parse_effects(args.effects))
    check_machine_sensors(machine, args)
    noise = not args.no_noise
    given = [
        "--" + name.replace("_", "-")
        for name in AMBIENT_DEFAULTS
        if getattr(args, name) is not None
    ]
    if args.tests and given:
        them = "it" if len(given) == 1 else "them"
        raise UserError(
            "--tests simulates Machine B's tests with their own air; "
            f"{', '.join(given)} would be ignored: leave {them} out."
        )
    air = {
        k: AMBIENT_DEFAULTS[k] if getattr(args, k) is None else getattr(args, k)
        for k in AMBIENT_DEFAULTS
    }
    if air["ambient_noise"] < 0:
        raise UserError(f"--ambient-noise must be >= 0, got {air['ambient_noise']}.")
    if args.tests:
        if args.segment:
            raise UserError("Give either --tests or --segment, not both.")
        tests = split_list(args.tests)
        runs = make_machine_b_tests(
            tests,
            machine=machine,
            sample_period_s=args.sample_period,
            noise=noise,
            random_state=args.seed,
        )
    else:
        segments = parse_segments(args.segment or ["4000:1h", "0:1h"])
        duty = DutyCycle(segments)
        if duty.duration_s < 2 * args.sample_period:
            raise UserError(
                f"The duty cycle lasts {duty.duration_s:g} s, less than two samples "
                f"of --sample-period {args.sample_period:g} s."
            )
        with warnings.catch_warnings():
            # The table written says it (validate_runs), once; air the
            # command refuses (check_air) gets no warning first.
            warnings.filterwarnings("ignore", message="AmbientProfile mean_C=")
            ambient = AmbientProfile(
                mean_C=air["ambient_mean"],
                trend_C_per_h=air["ambient_trend"],
                day_amplitude_C=air["day_amplitude"],
                start_hour=air["start_hour"],
                noise_C=air["ambient_noise"],
            )
            check_air(ambient, duty.duration_s)
        if "," in args.run or args.run != args.run.strip() or not args.run:
            raise UserError(
                f"--run {args.run!r}: a run label without commas and without "
                "spaces at its ends (options such as --train-runs list labels "
                "separated by commas)."
            )
        runs = machine.simulate(
            duty,
            ambient,
            sample_period_s=args.sample_period,
            run=args.run,
            noise=noise,
            random_state=args.seed,
        )
    meta = list(runs.attrs.get("metadata", []))
    out = Path(args.out)
    if args.append and out.exists():
        try:
            old, old_meta = read_runs(out, metadata=True)
        except ValueError as exc:
            raise UserError(f"--append {out}: {exc}") from exc
        clash = sorted(set(label_text(old["run"])) & set(label_text(runs["run"])))
        if clash:
            raise UserError(
                f"--append: run(s) {clash} are already in {out}; name the new run "
                "with --run."
            )
        old.attrs["metadata"] = old_meta.to_dict("records")
        old, runs = _same_label_kind(old, runs)
        try:
            runs = concat_runs([old, runs])
        except ValueError as exc:
            raise UserError(f"--append {out}: {exc}") from exc
        meta = list(runs.attrs.get("metadata", []))
    write_table(runs, out, metadata=meta or None)
    sizes = runs.groupby("run", sort=False).size()
    print(
        f"Wrote {out}: {len(sizes)} run(s) ({', '.join(map(str, sizes.index))}), "
        f"{len(runs)} rows, {runs.shape[1]} columns, {machine_label(args)}."
    )
    return 0


# --------------------------------------------------------------------------
# select
# --------------------------------------------------------------------------


def cmd_select(args):
    from skthermal.datasets import split_runs
    from skthermal.models import SELECTORS, make_selector

    if args.method not in SELECTORS:
        raise UserError(f"--method: choose one of {', '.join(SELECTORS)}.")
    out = Path(args.out)
    if out.suffix.lower() not in (".csv", ".json"):
        raise UserError(f"--out {out}: write .json or .csv.")
    check_out_path(out, "--out")
    df = read_table(args.runs)
    target = pick_target(df, args.target, args.runs)
    X, y, _ = split_runs(df, targets=target)
    if not 1 <= args.n_sensors <= X.shape[1]:
        raise UserError(
            f"--n-sensors must be between 1 and the {X.shape[1]} sensors of the "
            f"table, got {args.n_sensors}."
        )
    mask = run_mask(df, args.train_runs)
    selector = make_selector(args.method, args.n_sensors, random_state=args.seed)
    selector.fit(X[mask], y[mask])
    names = list(X.columns)
    kept = list(selector.get_feature_names_out())
    scores = np.asarray(selector.scores_, dtype=float)
    table = pd.DataFrame({"sensor": names, "score": scores})
    table["selected"] = table["sensor"].isin(kept)
    if hasattr(selector, "labels_"):
        table["group"] = selector.labels_
    if out.parent and not out.parent.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".csv":
        table.to_csv(out, index=False)
    elif out.suffix.lower() == ".json":
        doc = {
            "method": args.method,
            "target": target,
            "train_runs": sorted(pd.unique(label_text(df["run"][mask])).tolist()),
            "sensors": kept,
            "scores": dict(zip(names, map(float, scores), strict=True)),
        }
        if "group" in table:
            doc["groups"] = dict(zip(names, map(int, table["group"]), strict=True))
        out.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    print(
        f"{args.method}: kept {len(kept)} of {len(names)} sensors for {target}: "
        + ", ".join(kept)
    )
    print(f"Wrote {out}")
    return 0
