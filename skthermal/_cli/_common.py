"""What the subcommands share: user errors and reading the user's input.

Every subcommand reads and writes run tables through
:mod:`skthermal.datasets` (``read_runs`` validates them) and turns problems
with the user's input -- a missing file, a bad column, an unknown name, an
out-of-range option -- into :class:`UserError`, which the command prints as
one line with exit status 2.
"""

import contextlib
import importlib
import json
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd


class UserError(Exception):
    """An error in the user's input: reported as one line, exit status 2."""


def split_list(value, keep=()):
    """``"a, b"`` or ``["a,b", "c"]`` -> ``["a", "b", "c"]``: commas
    separate, spaces around the items are dropped (a run label may hold
    spaces: ``"test 1"``), unless an item with them is one of ``keep``. An
    item that is one of ``keep`` as a whole is not split (a run label with
    a comma: ``"A,1"``)."""
    if value is None:
        return None
    items = [value] if isinstance(value, str) else list(value)
    keep = set(keep)
    out = []
    for item in items:
        out += _split_item(item.split(","), keep)
    return out


def _split_item(pieces, keep):
    """The comma-separated ``pieces`` of one item as values: each a run of
    pieces that is one of ``keep`` as a whole (a label holding commas,
    ``"A,1"``), or one piece. Of all such readings, the one with the fewest
    values that are not in ``keep``, then the fewest values (the longest
    labels): with labels ``A``, ``A,B`` and ``B,C``, ``"A,B,C"`` reads
    ``A`` and ``B,C``, where taking the longest label first left ``C``."""
    n = len(pieces)
    # A label of k commas spans k + 1 pieces: no longer run can be one.
    widest = 1 + max((label.count(",") for label in keep), default=0)
    # best[i]: (values not in keep, values, the first value, where the next
    # starts) for pieces[i:].
    best = [None] * n + [(0, 0, None, n)]
    for i in range(n - 1, -1, -1):
        for j in range(min(n, i + widest), i, -1):  # longer first: win ties
            v = ",".join(pieces[i:j])
            if v not in keep:
                # A label after ", " (or with spaces around it as given).
                if v.strip() in keep or j == i + 1:
                    v = v.strip()
                else:
                    continue
            misses, count = best[j][:2]
            if v:
                misses, count = misses + (v not in keep), count + 1
            if best[i] is None or (misses, count) < best[i][:2]:
                best[i] = (misses, count, v, j)
    values, i = [], 0
    while i < n:
        _, _, v, i = best[i]
        if v:
            values.append(v)
    return values


def label_text(run):
    """Run labels (a Series) as the text the command line names them by:
    ``str`` of each, a whole number stored as a float (``1.0``, a Parquet
    file's float labels) as the integer (``1``), as the estimators take
    ``1.0`` and ``1`` for the same run. An ndarray of objects."""
    if pd.api.types.is_float_dtype(run.dtype):
        values = run.to_numpy(float)
        whole = np.isfinite(values) & (values == np.round(values))
        text = run.astype(str).to_numpy(object)
        text[whole] = [str(int(v)) for v in values[whole]]
        return text
    return run.astype(str).to_numpy(object)


def read_table(
    path, what="--runs", *, validate=True, allow_missing_sensors=False, unchecked=None
):
    """Read (and validate) a run table, naming the option on failure.
    ``allow_missing_sensors``: missing sensor readings pass the validation
    (for a model that holds over them); ``unchecked``: a function of the
    table's columns giving those the command does not read, left out of
    the validation (a measured displacement, or a driver, with empty fields
    on a table to predict)."""
    from skthermal.datasets import read_runs
    from skthermal.datasets._runtable import SKIP_VALIDATION, check_run_table

    if path is None:
        raise UserError(f"{what} FILE is required.")
    path = Path(path)
    if not path.exists():
        raise UserError(f"{what}: no such file: {path}")
    if path.is_dir():
        raise UserError(f"{what}: {path} is a folder, not a run table file.")
    try:
        if not unchecked or not validate:
            return read_runs(
                path, validate=validate, allow_missing_sensors=allow_missing_sensors
            )
        df = read_runs(path, validate=False)
        used = df.drop(columns=list(unchecked(df.columns)))
        check_run_table(
            used,
            allow_missing_sensors=allow_missing_sensors,
            missing_hint=SKIP_VALIDATION,
        )
        return df
    except UnicodeDecodeError as exc:
        raise UserError(
            f"{what} {path}: not a text CSV run table (binary data; use .csv, "
            ".csv.gz or .parquet)."
        ) from exc
    except (ValueError, ImportError, pd.errors.ParserError) as exc:
        message = str(exc)
        if SKIP_VALIDATION in message:
            # read_runs' way out is a Python argument; none here.
            message = message.replace(
                SKIP_VALIDATION, "impute them first or drop those rows"
            )
        if str(path) not in message:
            message = f"{path}: {message}"
        raise UserError(f"{what}: {message}") from exc


def check_used_sensors(df, sensors, path, what="--runs"):
    """A UserError naming the first missing reading of the ``sensors`` the
    command uses (a table read with ``allow_missing_sensors``: the others may
    miss readings)."""
    from skthermal.datasets._runtable import check_missing_sensors

    try:
        check_missing_sensors(
            df,
            [s for s in sensors if s in df.columns],
            hint="impute them first or drop those rows, or leave the sensor out",
        )
    except ValueError as exc:
        raise UserError(f"{what}: {path}: {exc}") from exc


def check_out_table(path, what="--out"):
    """A UserError, before any work, unless ``path`` names a run table file
    (CSV or Parquet)."""
    from skthermal.datasets._loaders import check_table_name

    try:
        check_table_name(path, what)
    except ValueError as exc:
        raise UserError(str(exc)) from exc


def check_out_path(path, option, *, folder=False):
    """A UserError, before any work, unless ``path`` can be written: a file
    (or with ``folder=True`` a folder) where a folder (a file) of that name
    exists, or a parent folder that is a file, would fail after the work."""
    if path is None:
        return
    path = Path(path)
    if folder and path.exists() and not path.is_dir():
        raise UserError(f"{option} {path}: a file of that name exists; give a folder.")
    if not folder and path.is_dir():
        raise UserError(f"{option} {path} is a folder; give a file name.")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise UserError(f"{option} {path}: {parent} is a file, not a folder.")
            break


def write_table(df, path, *, metadata=None, allow_missing_sensors=False, validate=True):
    """Write a run table (validated unless ``validate=False``: a table read
    with columns left unchecked; ``allow_missing_sensors`` as in
    :func:`read_table`)."""
    from skthermal.datasets import write_runs

    check_out_table(path)
    path = Path(path)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_runs(
            df,
            path,
            metadata=metadata,
            validate=validate,
            allow_missing_sensors=allow_missing_sensors,
        )
    except ImportError as exc:  # Parquet without pyarrow
        raise UserError(f"{path}: {exc}") from exc


def pick_target(df, target, path="the run table"):
    """The displacement column to model: ``--target``, the only one, or Y."""
    from skthermal.datasets import target_columns

    targets = target_columns(df)
    if target is not None:
        if target not in targets:
            raise UserError(
                f"--target {target!r} is not a displacement column of {path}; "
                f"it has {targets or 'none'}."
            )
        return target
    if not targets:
        raise UserError(f"{path} has no displacement column (disp_<axis>_um) to model.")
    if len(targets) == 1:
        return targets[0]
    if "disp_y_um" in targets:
        return "disp_y_um"
    raise UserError(
        f"{path} has several displacement columns {targets}; choose one with --target."
    )


def run_mask(df, runs, option="--train-runs"):
    """Rows of the runs named in ``runs`` (all rows when None)."""
    labels = pd.Series(label_text(df["run"]))
    if not runs:
        return np.ones(len(df), dtype=bool)
    present = list(pd.unique(labels))
    wanted = split_list(runs, keep=present)
    if not wanted:
        raise UserError(
            f"{option} {runs!r} names no run (commas separate run labels); "
            f"runs: {present}."
        )
    unknown = [r for r in wanted if r not in present]
    if unknown:
        raise UserError(
            f"{option}: run(s) {unknown} are not in the table; runs: {present}."
        )
    return labels.isin(wanted).to_numpy()


# How a sensors.csv file edited by hand (or by a spreadsheet) says whether
# a sensor is selected; anything else is an error, not "selected" (any
# non-empty text, 'FALSCH' or 'no', was True).
_SELECTED = {
    **dict.fromkeys(("true", "1", "1.0", "yes"), True),
    **dict.fromkeys(("false", "0", "0.0", "no"), False),
}


def _selected_flags(column, path):
    """The ``selected`` column of a sensors file as booleans."""
    text = column.str.strip().str.lower()
    known = text.isin(list(_SELECTED))
    if not known.all():
        i = int(np.flatnonzero(~known.to_numpy())[0])
        raise UserError(
            f"--sensors {path}: row {i + 1} has selected = {column.iloc[i]!r}; "
            "write True or False (also 1/0, yes/no) in the 'selected' column, "
            "or leave the column out to take every sensor listed."
        )
    return text.map(_SELECTED).astype(bool).to_numpy()


def sensor_file_target(value, target):
    """The target of a run: ``target`` (``--target``), else the one a
    ``skthermal select`` JSON file given as ``--sensors`` records; a
    UserError when they differ (the file's target was ignored: a model of
    disp_y_um fitted on the sensors selected for disp_x_um)."""
    path = Path(value) if value else None
    if path is None or path.suffix.lower() != ".json" or not path.is_file():
        return target
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError:
        return target  # read_sensor_list names it
    recorded = doc.get("target") if isinstance(doc, dict) else None
    if not isinstance(recorded, str):
        return target
    if target is not None and target != recorded:
        raise UserError(
            f"--target {target}: the sensors of {path} were selected for "
            f"{recorded!r}; give --target {recorded}, or select sensors for "
            f"{target} ('skthermal select --target {target}')."
        )
    return recorded


def read_sensor_list(value, df):
    """Sensor names from ``--sensors``: a comma list or a select output file."""
    from skthermal.datasets import driver_columns, sensor_columns

    path = Path(value)
    if path.suffix.lower() in (".json", ".csv") or path.is_file():
        if not path.is_file():
            raise UserError(f"--sensors: no such file: {path}")
        if path.suffix.lower() == ".json":
            try:
                doc = json.loads(path.read_text(encoding="utf-8"))
            except json.JSONDecodeError as exc:
                raise UserError(f"--sensors {path}: not valid JSON ({exc})") from exc
            names = doc.get("sensors") if isinstance(doc, dict) else doc
        else:
            table = pd.read_csv(path, keep_default_na=False, dtype=str)
            if "sensor" not in table.columns:
                hint = (
                    f" (its header {table.columns[0]!r} holds ';': separate the "
                    "columns with commas, as 'skthermal select' writes them)"
                    if len(table.columns) == 1 and ";" in table.columns[0]
                    else ""
                )
                raise UserError(f"--sensors {path}: no 'sensor' column{hint}.")
            if "selected" in table.columns:
                table = table[_selected_flags(table["selected"], path)]
            names = table["sensor"].tolist()
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise UserError(
                f"--sensors {path}: expected a list of sensor names (as written by "
                "'skthermal select')."
            )
    else:
        names = split_list(value)
    if not names:
        raise UserError("--sensors: no sensor names given.")
    allowed = sensor_columns(df) + driver_columns(df)
    missing = [n for n in names if n not in allowed]
    if missing:
        raise UserError(
            f"--sensors: {missing} are not sensor columns of the table "
            f"(it has {len(sensor_columns(df))} sensors, e.g. "
            f"{sensor_columns(df)[:5]})."
        )
    return names


def features_of(df, sensors, where="The run table"):
    """``df[sensors]`` indexed by (run, time_s), as ``split_runs`` makes it;
    ``where`` names the table in an error."""
    missing = [s for s in sensors if s not in df.columns]
    if missing:
        raise UserError(f"{where} lacks the model's input column(s) {missing}.")
    index = pd.MultiIndex.from_arrays(
        [df["run"], df["time_s"]], names=["run", "time_s"]
    )
    return df[list(sensors)].set_axis(index, axis=0)


def check_positive(value, option, *, upper=None):
    if value is None:
        return
    if not np.isfinite(value) or value <= 0:
        raise UserError(f"{option} must be positive, got {value}.")
    if upper is not None and value > upper:
        raise UserError(f"{option} must be at most {upper}, got {value}.")


# Numbers in a warning (a trial's values, a row): masked to tell warnings
# that differ only in them apart from new ones.
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@contextlib.contextmanager
def warning_lines(command):
    """Show the warnings raised inside as one line each on stderr,
    ``skthermal CMD: warning: ...`` (the message with its lines joined).
    A warning that differs from one shown only in its numbers is counted,
    not shown again; the counts are said at the end."""
    seen = {}

    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        if not text:
            return
        key = _NUMBER.sub("#", text)
        if key in seen:
            seen[key].add(text)  # the same one again: not counted
            return
        seen[key] = {text}
        print(f"skthermal {command}: warning: {text}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.showwarning = show
            yield
    finally:
        for texts in seen.values():
            if len(texts) > 1:
                text = min(texts, key=len)
                shown = text if len(text) <= 70 else text[:67] + "..."
                print(
                    f"skthermal {command}: warning: {len(texts) - 1} more like "
                    f"{shown!r} (other numbers)",
                    file=sys.stderr,
                )


def parse_effects(value, option="--effects"):
    """Effect names from the comma list of ``option`` (None: not given)."""
    from skthermal.simulate import EFFECTS

    if value is None:
        return None
    names = split_list(value)
    if names == ["none"]:
        return []
    if names == ["all"]:
        return list(EFFECTS)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise UserError(
            f"{option}: unknown effect(s) {unknown}; known: {', '.join(EFFECTS)} "
            "(or 'all', 'none'; see --list-effects)."
        )
    return names


# The machine of a command with neither --preset nor --machine.
DEFAULT_PRESET = "vmc-b"


def machine_from_args(args, *, effects=None):
    """The machine of ``--machine FILE`` (if given) or of ``--preset``.

    ``effects=None`` keeps the machine's default effects. Both options at
    once, a machine file that is missing or a folder, or one that does not
    describe a valid machine is a :class:`UserError` naming the file (and,
    where the loader names it, the offending entry).
    """
    from skthermal.simulate import ThermalMachine

    path = getattr(args, "machine", None)
    preset = getattr(args, "preset", None)
    if path is None:
        return ThermalMachine.from_preset(preset or DEFAULT_PRESET, effects=effects)
    if preset is not None:
        raise UserError(
            f"give --preset or --machine, not both (--preset {preset}, "
            f"--machine {path})."
        )
    path = Path(path)
    if path.is_dir():
        raise UserError(
            f"--machine: {path} is a folder (a directory), not a machine file; "
            "give a FILE.toml."
        )
    if not path.exists():
        raise UserError(f"--machine: no such file: {path}")
    try:
        return ThermalMachine.from_spec(path, effects=effects)
    except (TypeError, KeyError, AttributeError, IndexError) as exc:
        # Not a message written for the user: a wrong type the loader did
        # not check. Say which file, and what Python said.
        raise UserError(
            f"--machine: could not read machine file {path}: "
            f"{type(exc).__name__}: {exc} (check the types of its entries "
            "against docs/own_machine.md)."
        ) from exc
    except (ValueError, OSError) as exc:
        message = str(exc)
        if str(path) not in message:
            message = f"{path}: {message}"
        raise UserError(f"--machine: {message}") from exc


def machine_label(args):
    """How a command names the machine it used: the file or the preset."""
    path = getattr(args, "machine", None)
    if path is not None:
        return f"machine {path}"
    return f"preset {getattr(args, 'preset', None) or DEFAULT_PRESET}"


def check_machine_sensors(machine, args):
    """A UserError unless ``machine`` has a temperature sensor: a run table
    needs at least one ``T<name>_C`` column (DATA_FORMAT)."""
    if machine.sensors:
        return
    path = getattr(args, "machine", None)
    where = f"the machine in {path}" if path is not None else machine_label(args)
    raise UserError(
        f"{where} has no [sensors]: a run table needs at least one temperature "
        'sensor (add e.g. [sensors.T1_C] node = "<node>"; see docs/own_machine.md).'
    )


def require(package, *, extra, command):
    """Import the third-party ``package``, or a UserError naming the extra."""
    try:
        return importlib.import_module(package)
    except ImportError as exc:
        raise UserError(
            f"'skthermal {command}' needs the package {package!r}: "
            f"pip install 'skthermal[{extra}]'."
        ) from exc
