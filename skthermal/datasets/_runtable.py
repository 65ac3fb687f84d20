"""The run table: naming rules, validation, column roles and splitting.

A run table (``docs``: DATA_FORMAT) is a DataFrame with one row per sample time
of one *run*: a ``run`` label, ``time_s``, optional drivers (``spindle_rpm``,
``feed_mm_min``, ``ambient_C``), temperature sensors ``T<name>_C``, strain
sensors ``S<name>_ue`` and thermal displacements ``disp_<axis>_um``. Everything
in skthermal that reads or writes measurements goes through the checks here, so
a user's own table works everywhere or fails once, with a message that names
the column, the run and the row.
"""

import re
import warnings
from numbers import Real

import numpy as np
import pandas as pd

from skthermal._naming import (
    STRAIN_PATTERN,
    TARGET_PATTERN,
    TEMPERATURE_PATTERN,
    listed,
    plain,
    renamed,
)
from skthermal._run_changes import changes_since_first_row
from skthermal.utils._runs import (
    ABSOLUTE_ZERO_C,
    AIR_RANGE_C,
    DECIMAL_COMMA,
    DRIVER_RULE,
    MAX_MAGNITUDE,
    check_frame,
    check_labels,
    driver_lookalike,
    refuse_clock_values,
    unreadable,
    warn_air_unit,
    warn_odd_times,
)
from skthermal.utils._warnings import user_stacklevel

RUN = "run"
TIME = "time_s"
DRIVERS = ("spindle_rpm", "feed_mm_min", "ambient_C")
REQUIRED_DRIVERS = ("spindle_rpm", "ambient_C")


_RULES = {
    "temperature": (
        "temperature columns are named T<name>_C "
        f"(regex ^{TEMPERATURE_PATTERN.pattern}$), e.g. 'T05_C', 'Tcarrier3_C'"
    ),
    "strain": (
        "strain columns are named S<name>_ue "
        f"(regex ^{STRAIN_PATTERN.pattern}$), e.g. 'Sram1_ue'"
    ),
    "target": (
        "displacement columns are named disp_<axis>_um "
        f"(regex ^{TARGET_PATTERN.pattern}$), e.g. 'disp_y_um'"
    ),
}
_TEMPERATURE_UNITS = {"c", "degc", "°c", "celsius", "k", "kelvin", "f", "degf"}
_STRAIN_UNITS = {"ue", "µe", "μe", "με", "µε", "ustrain", "microstrain", "me"}
_KNOWN = (RUN, TIME, *DRIVERS)
_SPACES = (
    "its header name has spaces around it; remove them (a CSV header written "
    "with a space after each comma)"
)


def _is_temperature(name):
    return isinstance(name, str) and TEMPERATURE_PATTERN.fullmatch(name) is not None


def _is_strain(name):
    return isinstance(name, str) and STRAIN_PATTERN.fullmatch(name) is not None


def _is_target(name):
    return isinstance(name, str) and TARGET_PATTERN.fullmatch(name) is not None


def _columns(df):
    columns = getattr(df, "columns", df)
    return list(columns)


def sensor_columns(df):
    """Names of the sensor columns, in table order.

    Sensors are temperatures ``T<name>_C`` (°C) and strains ``S<name>_ue``
    (µε). Columns are recognised by name only; use :func:`validate_runs` to
    check the table.

    Parameters
    ----------
    df : DataFrame or iterable of str
        A run table, or its column names.

    Returns
    -------
    list of str

    See Also
    --------
    target_columns, driver_columns

    Examples
    --------
    >>> from skthermal.datasets import sensor_columns
    >>> sensor_columns(["run", "time_s", "T1_C", "disp_y_um", "Sram1_ue", "T2_C"])
    ['T1_C', 'Sram1_ue', 'T2_C']
    """
    return [c for c in _columns(df) if _is_temperature(c) or _is_strain(c)]


def target_columns(df):
    """Names of the thermal displacement columns ``disp_<axis>_um``, in order.

    Parameters
    ----------
    df : DataFrame or iterable of str
        A run table, or its column names.

    Returns
    -------
    list of str

    Examples
    --------
    >>> from skthermal.datasets import target_columns
    >>> target_columns(["run", "time_s", "T1_C", "disp_y_um", "disp_z_um"])
    ['disp_y_um', 'disp_z_um']
    """
    return [c for c in _columns(df) if _is_target(c)]


def driver_columns(df):
    """Names of the driver columns present, in table order.

    Drivers are the inputs that heat the machine: ``spindle_rpm``,
    ``feed_mm_min`` and ``ambient_C``.

    Parameters
    ----------
    df : DataFrame or iterable of str
        A run table, or its column names.

    Returns
    -------
    list of str

    Examples
    --------
    >>> from skthermal.datasets import driver_columns
    >>> driver_columns(["run", "time_s", "ambient_C", "spindle_rpm", "T1_C"])
    ['ambient_C', 'spindle_rpm']
    """
    return [c for c in _columns(df) if c in DRIVERS]


def _looks_like(name):
    """Which role a column that breaks the naming rules seems meant for.

    Returns ``None`` for a valid or clearly unrelated column (kept and
    ignored), otherwise ``(kind, expected)``.
    """
    if not isinstance(name, str) or name in _KNOWN:
        return None
    if _is_temperature(name) or _is_strain(name) or _is_target(name):
        return None
    bare = name.strip()
    if bare != name and (
        bare in _KNOWN or _is_temperature(bare) or _is_strain(bare) or _is_target(bare)
    ):
        return f"the column '{bare}'", _SPACES
    lower = name.lower()
    for known in _KNOWN:
        if lower == known.lower():
            return f"the column '{known}'", f"spell it exactly '{known}'"
    driver = driver_lookalike(name)
    if driver is not None:
        return f"the driver '{driver}'", DRIVER_RULE
    last = lower.rsplit("_", 1)[-1] if "_" in lower else ""
    if lower.startswith("disp"):
        return "a displacement", _RULES["target"]
    if (
        (lower[:1] == "t" and last in _TEMPERATURE_UNITS)
        or re.match(r"[Tt][^A-Za-z0-9]*[0-9]", name)
        or lower.startswith("temp")
    ):
        return "a temperature sensor", _RULES["temperature"]
    if (
        (lower[:1] == "s" and last in _STRAIN_UNITS)
        or lower.startswith("strain")
        or re.fullmatch(r"[Ss][0-9]+", name)
    ):
        return "a strain sensor", _RULES["strain"]
    return None


def _where(df, pos):
    """``run 'a', time_s 30.0 (row 2)`` for the row at position ``pos``."""
    parts = []
    if RUN in df.columns:
        parts.append(f"run {plain(df[RUN].iloc[pos])!r}")
    if TIME in df.columns:
        parts.append(f"time_s {plain(df[TIME].iloc[pos])}")
    return f"{', '.join(parts)} (row {pos})" if parts else f"row {pos}"


def _as_float(df, columns):
    """``df[columns]`` as a float array, missing values (also ``pd.NA``) as NaN."""
    return df[list(columns)].to_numpy(dtype=float, na_value=np.nan)


# A column named in another unit than its rule's: its unit token (the
# name's last) -> (the kind it is, the rule's unit, the unit as said, the
# conversion).
_DISPLACEMENT, _TEMPERATURE = "a displacement", "a temperature sensor"
_FAHRENHEIT = (_TEMPERATURE, "C", "°F", "convert with (F - 32) / 1.8")
_KELVIN = (_TEMPERATURE, "C", "K", "subtract 273.15")
_CONVERSIONS = {
    "mm": (_DISPLACEMENT, "um", "mm", "multiply by 1000"),
    "nm": (_DISPLACEMENT, "um", "nm", "divide by 1000"),
    "m": (_DISPLACEMENT, "um", "m", "multiply by 1e6"),
    "f": _FAHRENHEIT,
    "degf": _FAHRENHEIT,
    "k": _KELVIN,
    "kelvin": _KELVIN,
}


def _unit_hint(name, kind):
    """`` (in mm? multiply by 1000 for 'disp_z_um')`` for a column meant for
    ``kind`` but named in another unit than the rule's (a displacement in
    mm, nm or m, a temperature in °F or K), the name under the rule as
    :func:`_renamed` gives it (none when there is none); else ``""``."""
    norm = re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")
    head, _, unit = norm.rpartition("_")
    conversion = _CONVERSIONS.get(unit.lower())
    if not head or conversion is None or conversion[0] != kind:
        return ""
    _, end, said, how = conversion
    meant = f"{head}_{end}"
    if not (_is_target(meant) or _is_temperature(meant)):
        meant = renamed(meant, kind)
    return f" (in {said}? {how}" + (f" for {meant!r})" if meant else ")")


def check_column_names(columns, *, table="Run table", exempt=()):
    """Raise a ValueError naming every column of ``columns`` that looks like
    a sensor, a displacement or a known column while breaking its naming
    rule (``disp_x_mm``, ``T1``, ``Time_s``), with the rule; ``exempt``
    columns (e.g. mapped explicitly by the caller) are not checked."""
    # Columns that break one rule alike are named together, the rule once.
    broken = {}
    columns = list(columns)
    for name in columns:
        hit = None if name in exempt else _looks_like(name)
        if (
            hit is not None
            and hit[1] == DRIVER_RULE
            and driver_lookalike(name) in columns
        ):
            hit = None  # the driver is there: this one is another unit's extra
        if hit is not None:
            broken.setdefault(hit, []).append(name)
    problems = []
    for (kind, expected), names in broken.items():
        renames = {n: renamed(n, kind) for n in names[:4]}
        renames = {n: r for n, r in renames.items() if r is not None}
        hint = ""
        if renames:
            hint = " (" + ", ".join(f"{n!r} -> {r!r}" for n, r in renames.items())
            hint += "?)"
        hint += _unit_hint(names[0], kind)
        if len(names) == 1:
            problems.append(f"{names[0]!r} looks like {kind} but {expected}{hint}")
            continue
        shown = ", ".join(repr(n) for n in names[:4])
        more = f" and {len(names) - 4} more" if len(names) > 4 else ""
        kinds = kind[2:] + "s" if kind.startswith("a ") else kind
        problems.append(
            f"{shown}{more} ({len(names)} columns) look like {kinds} but "
            f"{expected}{hint}"
        )
    if problems:
        raise ValueError(
            f"{table} columns break the naming rule (rename or drop them): "
            + "; ".join(problems)
            + "."
        )


def _missing_column(name, meaning, candidates, df=None):
    if df is not None and name in (df.index.names or []):
        return ValueError(
            f"The run table has no {name!r} column ({meaning}): it is an index "
            "level. Run-table functions take run and time_s as columns "
            "(df.reset_index()); the estimators take either."
        )
    spaced = [c for c in candidates if isinstance(c, str) and c.strip() == name]
    if spaced:
        return ValueError(
            f"The run table has no {name!r} column ({meaning}), but has "
            f"{spaced[0]!r}: {_SPACES}."
        )
    hint = f"; columns that might be it: {candidates}" if candidates else ""
    return ValueError(f"The run table has no {name!r} column ({meaning}){hint}.")


# 1,250 or 12,500,000.5: digits in groups of three after the first comma.
_THOUSANDS = re.compile(r"\s*[-+]?[0-9]{1,3}(,[0-9]{3})+(\.[0-9]*)?\s*")


# Elapsed time written as [d days] h:mm:ss(.f), which no date parser takes
# past 24 h.
_DURATION = re.compile(r"\s*(\d+\s+days?,?\s+)?\d+:\d{2}(:\d{2}(\.\d*)?)?\s*")


# Text that reads as a time or a date: digits on both sides of ':', '-',
# '/' or '.' ("00:01:30", "2026-03-29"), not a unit ("s").
_CLOCKLIKE = re.compile(r"\d[-/.:]\d")


def _time_recipe(col, column):
    """How a column of clock times, dates or elapsed times (``col``, named
    ``column``) becomes ``time_s``, the seconds since each run's first row:
    `` becomes time_s as ...`` for the kind of its first values."""
    text = col.dropna().astype(str).head(20)
    if len(text) and text.str.fullmatch(_DURATION).all():
        t = f"pandas.to_timedelta(df[{column!r}])"
        kind = "elapsed times (h:mm:ss)"
    else:
        # utc=True: stamps with offsets across a daylight-saving change
        # ("Mixed timezones detected" without it).
        t = f"pandas.to_datetime(df[{column!r}], utc=True)"
        kind = "clock times or dates"
    return (
        f" holds {kind}: they become time_s as the seconds since each run's "
        f"first row, e.g. t = {t}; df['time_s'] = (t - t.groupby(df['run'])"
        ".transform('first')).dt.total_seconds()"
    )


def _check_numeric(df, columns):
    for name in columns:
        col = df[name]
        if pd.api.types.is_complex_dtype(col):
            raise ValueError(
                f"Column {name!r} holds complex numbers (dtype {col.dtype}), "
                f"e.g. {plain(col.iloc[0])!r} at {_where(df, 0)}: a run table "
                "holds real numbers; keep the real part or the magnitude "
                "(np.real, np.abs)."
            )
        if pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col):
            continue
        refuse_clock_values(
            col,
            f"Column {name!r}",
            "the seconds since each run's first row, t = df['time_s']; "
            "df['time_s'] = (t - t.groupby(df['run']).transform('first'))"
            ".dt.total_seconds()"
            if name == TIME
            else f"for durations df[{name!r}].dt.total_seconds(); a column "
            "of clock times is not a reading",
        )
        where = ""
        given = np.flatnonzero(col.notna().to_numpy())
        i = int(given[0]) if given.size else 0  # the first value given
        if pd.api.types.is_bool_dtype(col):
            where = (
                f": {_where(df, i)} holds {plain(col.iloc[i])!r}; a run table "
                "holds readings as numbers (a flag is not a sensor, a driver or "
                f"a displacement): give numbers, e.g. df[{name!r}].astype(float), "
                "or name the column otherwise"
            )
        else:
            coerced = pd.to_numeric(col, errors="coerce")
            bad = np.flatnonzero(coerced.isna().to_numpy() & col.notna().to_numpy())
            if bad.size:
                value = plain(col.iloc[bad[0]])
                where = f": {_where(df, bad[0])} holds {value!r}"
                text = col.iloc[bad].astype(str)
                if isinstance(value, str) and text.str.fullmatch(_THOUSANDS).all():
                    where += (
                        ", a number with thousands separators (or decimal "
                        "commas: 1,250 reads either way); write numbers without "
                        "separators and with a decimal point, e.g. "
                        "pandas.read_csv(..., thousands=',') for separators"
                    )
                elif isinstance(value, str) and DECIMAL_COMMA.fullmatch(value):
                    where += (
                        ", a number with a decimal comma; write numbers with a "
                        "decimal point"
                    )
                elif value == name:
                    where += (
                        ", its own name: the header line again (files joined "
                        "one after the other?); delete the repeated header lines"
                    )
                elif (
                    name == TIME and isinstance(value, str) and _CLOCKLIKE.search(value)
                ):
                    where += "; the column" + _time_recipe(col, TIME)
                elif bad.size == 1 and bad[0] == 0 and len(df) > 1:
                    where += (
                        ", the only text in the column, on the line under the "
                        "header: a row of units? Delete it; a run table's units "
                        "are in its column names (time_s, T<name>_C, "
                        "disp_<axis>_um)"
                    )
            elif given.size:
                # Numbers stored as text, or as Python objects: Decimal (a
                # database's or Spark's Parquet), floats in an object column.
                kind = "text" if isinstance(col.iloc[i], str) else "Python objects"
                where = (
                    f": numbers stored as {kind}, e.g. "
                    f"{col.iloc[i]!r} at {_where(df, i)}; convert them, e.g. "
                    f"df[{name!r}] = df[{name!r}].astype(float)"
                )
        raise ValueError(
            f"Column {name!r} must be numeric but has dtype {col.dtype}{where}."
        )


def _report_nonfinite(df, columns, mask, what, hint=""):
    """Raise naming every column with a ``mask`` entry set, and its first row."""
    bad_cols = np.flatnonzero(mask.any(axis=0))
    if not bad_cols.size:
        return
    parts, empty = [], 0
    for j in bad_cols:
        rows = np.flatnonzero(mask[:, j])
        if what == "missing" and rows.size == mask.shape[0] > 1:
            empty += 1
            # Dropping or filling rows is no way out: the sensor read nothing.
            parts.append(
                f"column {columns[j]!r} is empty in every row (a sensor that "
                "was not connected? drop the column)"
            )
            continue
        first = _where(df, rows[0])
        parts.append(
            f"column {columns[j]!r} has {rows.size} {what} value(s), "
            f"the first at {first}"
        )
    if empty == len(parts):
        hint = ""  # no row to impute or drop
    raise ValueError("; ".join(parts) + hint + ".")


def check_label_kinds(run):
    """Raise a ValueError, naming the ``run`` column, two rows and their
    kinds, when the run labels ``run`` (a Series) mix kinds (a number among
    strings): CSV and Parquet cannot store them as they are, and the
    estimators refuse them. Missing labels are checked before."""
    try:
        check_labels(run.to_numpy())
    except ValueError as exc:
        raise ValueError(
            f"Column 'run': {exc} Convert them, e.g. df['run'] = df['run'].astype(str)."
        ) from None


def _check_label_values(run, codes, uniques):
    """Raise a ValueError, naming the first row, unless every run label is a
    string or a finite real number (DATA_FORMAT: str or int): dates, times,
    bytes, tuples, ``Decimal`` or complex labels pass the estimators but no
    run table file stores them as they are, so ``skthermal predict`` and
    ``write_runs`` failed on tables ``read_runs`` and ``fit`` had taken."""
    values = np.asarray(uniques, dtype=object)
    for k, value in enumerate(values):
        real = isinstance(value, Real) and not isinstance(value, bool | np.bool_)
        if isinstance(value, str) and value != "":
            continue
        if real and np.isfinite(value):
            continue
        row = int(np.flatnonzero(codes == k)[0])
        what = "an empty string" if value == "" else type(value).__name__
        convert = (
            "df['run'].dt.strftime('%Y-%m-%d %H:%M')"
            if pd.api.types.is_datetime64_any_dtype(run.dtype)
            else "df['run'].astype(str)"
        )
        raise ValueError(
            f"Column 'run': row {row} has the run label {plain(value)!r} ({what}); "
            "run labels are strings or integers (DATA_FORMAT; Parquet files "
            "keep other real numbers too), which run table files store as they "
            f"are. Convert them, e.g. df['run'] = {convert}."
        )


def _check_runs(df):
    """Run labels present and of one kind, runs contiguous and longer than
    one row."""
    run = df[RUN]
    missing = np.flatnonzero(run.isna().to_numpy())
    if missing.size:
        empty = df.iloc[missing].isna().all(axis=1).to_numpy()
        why = (
            f": rows {missing[0]}-{missing[-1]} are empty (a spreadsheet's "
            "trailing rows?); delete them"
            if empty.all() and missing.size == missing[-1] - missing[0] + 1
            else "; every row needs a run label"
        )
        raise ValueError(
            f"Column 'run' has {missing.size} missing label(s), the first at row "
            f"{missing[0]}{why}."
        )
    check_label_kinds(run)
    codes, uniques = pd.factorize(run)
    _check_label_values(run, codes, uniques)
    n = codes.shape[0]
    starts = np.concatenate(([0], np.flatnonzero(codes[1:] != codes[:-1]) + 1))
    stops = np.concatenate((starts[1:], [n]))
    block_codes = codes[starts]
    n_blocks = np.bincount(block_codes)
    split = np.flatnonzero(n_blocks[block_codes] > 1)
    if split.size:
        code = block_codes[split[0]]
        blocks = np.flatnonzero(block_codes == code)
        spans = ", ".join(f"rows {starts[b]}-{stops[b] - 1}" for b in blocks[:3])
        more = f" and {blocks.size - 3} more blocks" if blocks.size > 3 else ""
        raise ValueError(
            f"The rows of run {plain(run.iloc[starts[split[0]]])!r} are not "
            f"contiguous ({spans}{more}); sort the table, e.g. "
            "df.sort_values(['run', 'time_s'], kind='stable'), so that each run "
            "is one block."
        )
    single = np.flatnonzero(stops - starts < 2)
    if single.size:
        pos = starts[single[0]]
        raise ValueError(
            f"Run {plain(run.iloc[pos])!r} has a single row (row {pos}); a run "
            "needs at least two samples."
        )
    _warn_labels_alike(uniques)
    return codes


def _warn_labels_alike(uniques):
    """Warn when run labels differ only in spaces or case (``"R1"`` and
    ``"R1 "``): one test logged under two labels is two runs, the second
    starting anew (its changes since the start from zero, a group of its
    own in cross-validation), where an independent check found no word."""
    seen = {}
    for label in uniques:
        if not isinstance(label, str):
            continue
        key = " ".join(label.split()).casefold()
        if key in seen:
            warnings.warn(
                f"Run labels {seen[key]!r} and {label!r} differ only in spaces "
                "or case: two runs, the second starting anew. If they are one "
                "test, give its rows one label (e.g. df['run'] = df['run'].replace("
                f"{{{label!r}: {seen[key]!r}}})).",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
            return
        seen[key] = label


def _check_time(df, codes):
    """``time_s`` finite and strictly increasing within each run (``codes``:
    one per row) in table order, the runs contiguous or not (the first row
    of a run is its start)."""
    time = _as_float(df, [TIME])[:, 0]
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise ValueError(
            f"Column 'time_s' has {bad.size} missing or infinite value(s), the "
            f"first at {_where(df, bad[0])}."
        )
    order = np.argsort(codes, kind="stable")
    c, t = codes[order], time[order]
    bad = np.flatnonzero((c[1:] == c[:-1]) & ~(t[1:] > t[:-1]))
    if bad.size:
        i, j = int(order[bad[0]]), int(order[bad[0] + 1])
        raise ValueError(
            f"Column 'time_s' must be strictly increasing within a run: in run "
            f"{plain(df[RUN].iloc[j])!r}, row {j} has time_s {time[j]} after "
            f"time_s {time[i]} at row {i}."
        )
    warn_odd_times(c, t)


def validate_runs(
    df, *, require_targets=False, require_drivers=False, allow_missing_sensors=False
):
    """Check that a DataFrame is a valid run table and return it unchanged.

    The rules are those of DATA_FORMAT: a ``run`` label (of one kind: all
    strings or all numbers) and a ``time_s`` column, at least one
    temperature sensor ``T<name>_C``, numeric sensors, targets and drivers,
    runs that are contiguous blocks of at least two rows
    with strictly increasing ``time_s``, no missing or infinite values in
    drivers, targets and (unless allowed) sensors, no value beyond 1e100 in
    magnitude (which no sensor reads and the models refuse), and physical
    ranges: a
    ``spindle_rpm`` of 0 or more (as the simulator requires) and
    temperatures (``ambient_C``, ``T<name>_C``) above absolute zero. Extra
    columns are kept and ignored, but a column that looks like a sensor, a
    displacement or a required column while breaking its naming rule is an
    error.

    Parameters
    ----------
    df : DataFrame
        The run table.
    require_targets : bool, default=False
        Require at least one displacement column ``disp_<axis>_um`` (needed to
        train a model).
    require_drivers : bool, default=False
        Require the drivers ``spindle_rpm`` and ``ambient_C`` (needed to
        simulate).
    allow_missing_sensors : bool, default=False
        Accept missing (NaN) sensor values. The caller is then responsible for
        a documented imputation; infinite values are still an error.

    Returns
    -------
    df : DataFrame
        The same object, unchanged.

    Raises
    ------
    ValueError
        If any rule is broken. The message names the column and, for problems
        with values, the run, the ``time_s`` and the row (0-based position in
        the table) of the first offending row.

    See Also
    --------
    read_runs : Read and validate a run table from CSV or Parquet.

    Notes
    -----
    Regular sampling within a run is not checked here: a method that needs it
    (such as the simulator) checks it itself.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.datasets import validate_runs
    >>> df = pd.DataFrame({"run": ["a", "a", "b", "b"],
    ...                    "time_s": [0.0, 60.0, 0.0, 60.0],
    ...                    "T1_C": [20.0, 21.5, 20.1, 22.0],
    ...                    "disp_y_um": [0.0, 3.2, 0.0, 4.1]})
    >>> validate_runs(df, require_targets=True) is df
    True
    >>> validate_runs(df.iloc[:3])
    Traceback (most recent call last):
    ...
    ValueError: Run 'b' has a single row (row 2); a run needs at least two samples.
    """
    return check_run_table(
        df,
        require_targets=require_targets,
        require_drivers=require_drivers,
        allow_missing_sensors=allow_missing_sensors,
    )


# How a caller of validate_runs lets missing sensor values through, and how a
# caller of a function that takes ``validate=`` does.
ALLOW_MISSING = "impute them first (and say how) or pass allow_missing_sensors=True"
SKIP_VALIDATION = (
    "impute them first, or pass validate=False and impute them in the "
    "pipeline (e.g. sklearn.impute.SimpleImputer)"
)


def meant_for(columns, name):
    """The columns of ``columns`` that may be meant for the run table's
    ``run`` or ``time_s`` column ``name`` when it is absent (``Run``,
    ``test_id``, a simulation tool's ``Load case``; ``time_min``,
    ``Timestamp``, ``t``)."""
    starts = (
        ("run", "test", "case", "load case", "load_case", "loadcase", "job", "batch")
        if name == RUN
        else ("time", "t_", "date", "stamp")
    )
    return [
        c
        for c in columns
        if isinstance(c, str)
        and (
            c.strip().lower().startswith(starts) or (name == TIME and c.strip() == "t")
        )
    ]


def check_run_table(
    df,
    *,
    require_targets=False,
    require_drivers=False,
    allow_missing_sensors=False,
    missing_hint=ALLOW_MISSING,
):
    """:func:`validate_runs`, the way out of missing sensor values worded for
    the caller (``missing_hint``)."""
    check_frame(df)
    names = [c for c in df.columns if isinstance(c, str)]
    if RUN not in df.columns:
        candidates = meant_for(df.columns, RUN)
        raise _missing_column(RUN, "the label of the run of every row", candidates, df)
    if TIME not in df.columns:
        candidates = meant_for(df.columns, TIME)
        error = _missing_column(
            TIME, "time since the start of the run, in s", candidates, df
        )
        if candidates and not pd.api.types.is_numeric_dtype(df[candidates[0]]):
            column = candidates[0]
            error = ValueError(f"{error} It{_time_recipe(df[column], column)}.")
        raise error
    check_column_names(df.columns)
    sensors = sensor_columns(df)
    targets = target_columns(df)
    drivers = driver_columns(df)
    if not any(_is_temperature(c) for c in sensors):
        hint = [c for c in names if c.endswith(("_C", "_degC"))]
        raise ValueError(
            "The run table has no temperature sensor column: "
            f"{_RULES['temperature']}"
            + (f"; columns that might be meant: {hint}" if hint else "")
            + "."
        )
    if require_drivers:
        absent = [c for c in REQUIRED_DRIVERS if c not in df.columns]
        if absent:
            raise ValueError(
                f"The run table lacks the driver column(s) {absent}, required "
                "here (e.g. to simulate): 'spindle_rpm' in rpm and 'ambient_C' "
                "in °C."
            )
    if require_targets and not targets:
        hint = [c for c in names if c.lower().endswith("_um")]
        raise ValueError(
            "The run table has no displacement (target) column: "
            f"{_RULES['target']}"
            + (f"; columns that might be meant: {hint}" if hint else "")
            + "."
        )
    if len(df) == 0:
        raise ValueError("The run table has no rows.")
    _check_numeric(df, [TIME, *drivers, *sensors, *targets])
    codes = _check_runs(df)
    _check_time(df, codes)

    strict = [*drivers, *targets]
    values = _as_float(df, strict)
    _report_nonfinite(
        df,
        strict,
        np.isnan(values),
        "missing",
        "; drivers and targets may not have missing values",
    )
    everything = [*strict, *sensors]
    values = np.concatenate([values, _as_float(df, sensors)], axis=1)
    _report_nonfinite(df, everything, np.isinf(values), "infinite")
    _report_nonfinite(
        df,
        everything,
        np.isfinite(values) & unreadable(values),
        f"absurd (beyond {MAX_MAGNITUDE:g} in magnitude)",
        "; no sensor reads that: it is a corrupt value, which the models refuse",
    )
    _check_ranges(df, everything, values)
    _warn_air_unit(df)
    _warn_kelvin_sensors(df, everything, values, codes)
    _warn_impossible_readings(df, everything, values, codes)
    _warn_displacement_runs(df, everything, values, codes)
    _warn_zero_readings(df, everything, values, codes)
    _warn_speed_unit(df)
    if not allow_missing_sensors:
        check_missing_sensors(df, sensors, values[:, len(strict) :], missing_hint)
    return df


def _range_rules(columns):
    """``(column, lowest, strict, expected)`` for the columns with a range.

    The drivers' ranges are those the simulator enforces, so that a valid
    table can be simulated and diagnosed; no temperature lies below absolute
    zero. ``feed_mm_min`` may have either sign (the direction of travel).
    """
    rules = []
    for j, name in enumerate(columns):
        if name == "spindle_rpm":
            rules.append((j, 0.0, False, "a spindle speed in rpm, 0 or more"))
        elif name == "ambient_C" or _is_temperature(name):
            rules.append(
                (j, ABSOLUTE_ZERO_C, True, "a temperature in °C, above -273.15")
            )
    return rules


def physical_lows(columns):
    """The lowest value each of ``columns`` can physically hold (its run-table
    range; -inf for a column without one), as an array: 0 rpm for
    ``spindle_rpm``, -273.15 °C for a temperature."""
    lows = np.full(len(columns), -np.inf)
    for j, lowest, _, _ in _range_rules([str(c) for c in columns]):
        lows[j] = lowest
    return lows


def _check_ranges(df, columns, values):
    """Raise naming the first column, run and row outside its physical range."""
    for j, lowest, strict, expected in _range_rules(columns):
        col = values[:, j]
        bad = np.flatnonzero(col <= lowest if strict else col < lowest)
        if bad.size:
            raise ValueError(
                f"Column {columns[j]!r} must hold {expected}: "
                f"{_where(df, bad[0])} holds {col[bad[0]]:g}"
                + (f" ({bad.size} such rows in all)" if bad.size > 1 else "")
                + "."
            )


def warn_implausible(df, late_start=True, readings=False):
    """The plausibility warnings of a run table whose ``time_s`` is checked
    (finite, increasing within each run), for readers that skip the rest of
    :func:`validate_runs` (the gap diagnosis reads its own columns): a
    ``time_s`` like a clock's or in another unit (``late_start=False``:
    runs that start after 0 are not warned about, e.g. measured runs whose
    simulation starts before them), workshop air or temperature sensors in
    another unit (kelvin, Fahrenheit), readings no machine gives; with
    ``readings``, for a reader that simulates the machine from its readings,
    temperatures given as changes since the start."""
    codes = pd.factorize(df[RUN])[0]
    order = np.argsort(codes, kind="stable")
    times = _as_float(df, [TIME])[:, 0]
    warn_odd_times(codes[order], times[order], late_start)
    _warn_air_unit(df)
    read = [c for c in df.columns if _is_temperature(c) or _is_target(c)]
    values = df[read].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    _warn_kelvin_sensors(df, read, values, codes)
    _warn_impossible_readings(df, read, values, codes)
    if readings:
        _warn_changes_as_readings(read, values, codes)


def _warn_air_unit(df):
    """Warn when ``ambient_C`` is in another unit than °C
    (:func:`~skthermal.utils._runs.warn_air_unit`)."""
    if "ambient_C" in df.columns:
        warn_air_unit(
            _as_float(df, ["ambient_C"])[:, 0], where=lambda pos: _where(df, pos)
        )


# No machine-tool structure reads this much in °C at every sample (bearings
# run at 20-80 °C); kelvin reads from 250 up.
_KELVIN_FLOOR = 200.0
# A run logged in kelvin among runs in °C: nothing below this (-23 °C), and
# its lowest reading this far above the other runs' (273 K, give or take the
# runs' own differences).
_KELVIN_RUN_FLOOR = 250.0
_KELVIN_LIFT = (200.0, 350.0)
# Workshop air reads 50-85 in Fahrenheit, and a machine has parts near it:
# when every temperature sensor stays above this at every sample, the
# readings are most likely in Fahrenheit.
_FAHRENHEIT_FLOOR = 50.0


def _warn_kelvin_sensors(df, columns, values, codes):
    """Warn when temperature columns (``*_C``) never read below
    ``_KELVIN_FLOOR``: kelvin under a °C header. Models take changes or
    standardise, but not all: an ANFIS whose intercepts are shrunk, the
    simulator and the gap diagnosis read the level. A column that does so
    in some runs only (``codes``: every row's run) is warned about naming
    those runs: a logger set to kelvin for one test puts that run some 273
    above the others, which no model of levels can take."""
    hot, some = [], []
    for j, name in enumerate(columns):
        if name == "ambient_C" or not _is_temperature(name):
            continue
        col = values[:, j]
        finite = np.isfinite(col)
        if not finite.any():
            continue
        run_min = pd.Series(col[finite]).groupby(codes[finite]).min()
        if (run_min > _KELVIN_FLOOR).all():
            hot.append((name, col[finite].min(), col[finite].max()))
            continue
        # A run in kelvin reads some 273 above the others, and nothing in it
        # below the kelvin of a cold workshop (a cutting-zone sensor at
        # 230-270 °C in one hot test is no kelvin).
        cold = run_min[run_min <= _KELVIN_FLOOR]
        lift = run_min - (cold.median() if cold.size else np.nan)
        kelvin = (run_min > _KELVIN_RUN_FLOOR) & lift.between(*_KELVIN_LIFT)
        if kelvin.any():
            some.append((name, run_min.index[kelvin], col, finite))
    if some:
        _warn_kelvin_runs(df, codes, some)
    if not hot:
        if not some and not _warn_fahrenheit_sensors(columns, values):
            _warn_fahrenheit_runs(df, columns, values, codes)
        return
    name, low, high = hot[0]
    names = listed([h[0] for h in hot], show=repr)
    warnings.warn(
        f"Temperature column(s) {names} never read below "
        f"{_KELVIN_FLOOR:g} ({name!r}: {low:g} to {high:g}): no machine-tool "
        "structure is that hot at every sample. In kelvin? Columns *_C are read "
        "as °C: subtract 273.15.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _run_names(labels, codes, runs):
    """The labels of the runs numbered ``runs`` (their ``codes``; ``labels``:
    every row's), for a message: ``"'a', 'b' and 2 more"``."""
    return listed(
        [plain(labels[int(np.flatnonzero(codes == c)[0])]) for c in runs], show=repr
    )


def _warn_kelvin_runs(df, codes, some):
    """The warning of :func:`_warn_kelvin_sensors` for columns that read
    above the kelvin floor at every sample of some runs only: ``some`` holds
    ``(column, hot run codes, values, finite)``."""
    name, runs, col, finite = some[0]
    labels = df[RUN].to_numpy()
    named = _run_names(labels, codes, runs)
    inside = finite & np.isin(codes, runs)
    outside = finite & ~np.isin(codes, runs)
    names = listed([s[0] for s in some], show=repr)
    warnings.warn(
        f"Temperature column(s) {names} never read below "
        f"{_KELVIN_FLOOR:g} in run(s) {named}, and below it in the "
        f"other runs ({name!r}: {col[inside].min():g} to {col[inside].max():g} "
        f"there, {col[outside].min():g} to {col[outside].max():g} elsewhere): "
        "those runs logged in kelvin? Columns *_C are read as °C: subtract "
        "273.15 from those runs' readings.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


# Hotter than any machine-tool structure or its sensors (°C), and a larger
# thermal error than any machine tool shows (µm, away from its run's
# median: a probe may read with an offset): a glitch or a corrupt value.
_HOTTEST_C = 500.0
_LARGEST_ERROR_UM = 10_000.0
# Share of a column's readings beyond those limits above which they are
# taken for another unit rather than glitches.
_UNIT_SHARE = 0.05


def _warn_changes_as_readings(columns, values, codes):
    """Warn when every temperature sensor (``T<name>_C``) reads exactly 0 at
    the first row of every run: changes since the start, where a reader of
    the readings (the gap diagnosis: its base simulates the machine from
    the air) needs them as read; :func:`changes_since_start`'s tables, which
    the estimators take, are not warned about elsewhere."""
    temps = [j for j, name in enumerate(columns) if _is_temperature(name)]
    if not temps or len(codes) == 0:
        return
    first = np.r_[True, codes[1:] != codes[:-1]]
    block = values[np.ix_(first, temps)]
    if not (np.all(block == 0.0) and np.any(values[:, temps] != 0.0)):
        return
    names = listed([columns[j] for j in temps], show=repr)
    warnings.warn(
        f"Every temperature sensor ({names}) reads exactly 0 at the first "
        "row of every run: changes since the start? Columns T*_C hold the "
        "readings in °C (the library takes the changes where a method needs "
        "them; the simulator and the gap diagnosis need the readings).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_impossible_readings(df, columns, values, codes):
    """Warn naming the column, run and row of the first temperature above
    :data:`_HOTTEST_C` and the first displacement further than
    :data:`_LARGEST_ERROR_UM` from both its column's and its run's median
    (``codes``: every row's run): no machine reads that, and a model
    without a guard passes such a reading on to its correction."""
    for kind, limit, unit, test, other_unit in (
        (
            "temperature above",
            _HOTTEST_C,
            "°C",
            _is_temperature,
            "Columns *_C are read as °C (millidegrees: divide by 1000)",
        ),
        (
            "thermal displacement further from its run's median than",
            _LARGEST_ERROR_UM,
            "µm",
            _is_target,
            "Columns *_um are read as µm (nanometres: divide by 1000)",
        ),
    ):
        found = []
        for j, name in enumerate(columns):
            if not test(name):
                continue
            col = values[:, j]
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all NaN
                if test is _is_temperature:
                    level = np.zeros_like(col)
                    far = np.abs(col) > limit
                else:
                    # Far from the column's median and from its run's: a
                    # probe mounted anew with another offset in one run is
                    # no fault, nor are a few rows of a run's level.
                    level = pd.Series(col).groupby(codes).transform("median")
                    level = level.to_numpy()
                    far = (np.abs(col - np.nanmedian(col)) > limit) & (
                        np.abs(col - level) > limit
                    )
                bad = np.flatnonzero(far)
            if bad.size:
                found.append((name, col, bad, level))
        if not found:
            continue
        name, col, bad, level = found[0]
        # The largest in magnitude (of a table in nm, not a run's zero
        # start, which lies as far from the median).
        k = bad[np.argmax(np.abs(col[bad]))]
        others = [repr(f[0]) for f in found[1:]]
        # Beyond a few glitches: a whole stretch in another unit.
        many = bad.size > max(2, _UNIT_SHARE * np.isfinite(col).sum())
        cause = (
            f"In another unit? {other_unit}."
            if many
            else "A glitch or a corrupt value?"
        )
        said = f"a {kind} {limit:g} {unit}"
        if test is _is_temperature and col[k] < 0:
            # Beyond -500 °C: below absolute zero ("above 500" read wrong).
            said = f"a temperature below absolute zero ({ABSOLUTE_ZERO_C:g} °C)"
            cause = "A logger's code for no reading (-999)?"
        warnings.warn(
            f"Column {name!r} holds {col[k]:g} at {_where(df, k)}"
            + (f" ({bad.size} such rows in all)" if bad.size > 1 else "")
            + (f", and so do {', '.join(others)}" if others else "")
            + f": no machine tool reads {said}. {cause} A "
            "model without a guard (skthermal.compose.GuardedRegressor; "
            "skthermal fit --guard) passes it on to its prediction, and the gap "
            "diagnosis to the gap it measures: drop or fill such rows.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


# A run whose displacement moves this much (µm), and this many times as
# much as the other runs', is logged in another unit (nm).
_RUN_SPAN_UM = 1000.0
_RUN_SPAN_RATIO = 100.0


def _warn_displacement_runs(df, columns, values, codes):
    """Warn naming the run when a displacement column moves over
    :data:`_RUN_SPAN_UM` in one run and :data:`_RUN_SPAN_RATIO` times as
    much as in the others (their median): that run logged in nm; or, the
    other way, under :data:`_MM_SPAN_UM` in one run (or in all of them, the
    temperatures moving) and :data:`_RUN_SPAN_RATIO` times less than in the
    others: in mm. Judged per run, so a probe mounted anew with another
    offset is no finding."""
    temps = [j for j, name in enumerate(columns) if _is_temperature(name)]
    targets = [j for j, name in enumerate(columns) if _is_target(name)]
    spans = {}
    for j in targets:
        ok = np.isfinite(values[:, j])
        spans[j] = pd.Series(values[ok, j]).groupby(codes[ok]).agg(np.ptp)
    # How far the temperatures moved in every run (K).
    moved = _temperature_moves(values[:, temps], codes)
    for j in targets:
        name, col, span = columns[j], values[:, j], spans[j]
        # A column in mm beside others that move as µm probes do is more
        # likely a stiff axis (a capacitive probe reads nm).
        alone = all(not (spans[k] > 1.0).any() for k in targets if k != j)
        if _warn_mm(df, name, span, moved, codes, alone):
            return
        if span.size < 2:
            continue
        for code, value in span.items():
            others = float(span.drop(code).median())
            if value > _RUN_SPAN_UM and value > _RUN_SPAN_RATIO * max(others, 1e-9):
                rows = np.flatnonzero(codes == code)
                run = plain(df[RUN].to_numpy()[rows[0]])
                held, count = np.unique(col[rows], return_counts=True)
                if count.max() >= 3 and count.max() > 0.05 * rows.size:
                    warnings.warn(
                        f"Column {name!r} holds {held[np.argmax(count)]:g} in "
                        f"{count.max()} of the {rows.size} rows of run {run!r}, "
                        f"which moves {value:.4g} in all: an error code of the "
                        "logger? A model without a guard passes it on.",
                        UserWarning,
                        stacklevel=user_stacklevel(),
                    )
                    return
                warnings.warn(
                    f"Column {name!r} moves {value:.4g} within run {run!r}, "
                    f"{value / max(others, 1e-9):.3g} times as much as in the "
                    f"other runs (median {others:.4g}): that run logged in "
                    "nanometres? Columns *_um are read as µm: divide its "
                    "readings by 1000.",
                    UserWarning,
                    stacklevel=user_stacklevel(),
                )
                return


# No probe of a thermal error moves less than this (µm) over a run whose
# temperatures change by over _MM_TEMPERATURE_K: its noise alone is more.
_MM_SPAN_UM = 0.1
_MM_TEMPERATURE_K = 1.0


def _temperature_moves(temps, codes):
    """How far the temperatures ``temps`` (columns) moved in every run
    (``codes``), in K: the largest span of a column within the run, 0
    where none reads; a Series by run code."""
    if temps.shape[1] == 0:
        return pd.Series(0.0, index=np.unique(codes))
    frame = pd.DataFrame(temps)
    span = frame.groupby(codes).max() - frame.groupby(codes).min()
    return span.max(axis=1).fillna(0.0)


def _warn_mm(df, name, span, moved, codes, alone):
    """The millimetre half of :func:`_warn_displacement_runs` for column
    ``name`` (``span``: its movement per run code; ``moved``: the
    temperatures' per run, :func:`_temperature_moves`): warn and return
    True when it moves under :data:`_MM_SPAN_UM` (but moves) in every run
    while the temperatures move over :data:`_MM_TEMPERATURE_K`, and no
    other displacement column moves over 1 µm (``alone``); or in some
    runs whose temperatures move so, while it moves
    :data:`_RUN_SPAN_RATIO` times as much in the others (an idle run among
    heating ones is no finding). An independent check: a table in mm
    passed, the CLI printing an RMSE of 1e-7 "µm"."""
    if not span.size:
        return False
    small = span[(span > 0) & (span < _MM_SPAN_UM)]
    small = small[moved.reindex(small.index).fillna(0.0) > _MM_TEMPERATURE_K]
    if small.empty:
        return False
    labels = df[RUN].to_numpy()
    if small.size == span.size:
        if not alone:
            return False
        warnings.warn(
            f"Column {name!r} moves at most {span.max():.3g} within a run while "
            f"the temperatures move by up to {float(moved.max()):.3g} K: no "
            "probe of a thermal error in µm moves that little (a capacitive "
            "probe's nanometres aside). Logged in millimetres? Columns *_um are "
            "read as µm: multiply by 1000.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
        return True
    # Against the runs that move as a µm probe may (not one in nm, nor a
    # logger's error code).
    rest = span.drop(small.index)
    rest = rest[rest <= _RUN_SPAN_UM]
    if rest.empty:
        return False
    others = float(rest.median())
    tiny = small[others > _RUN_SPAN_RATIO * small]
    if tiny.empty:
        return False
    named = _run_names(labels, codes, tiny.index)
    warnings.warn(
        f"Column {name!r} moves at most {tiny.max():.3g} within run(s) {named}, "
        f"a hundredth or less of its movement in the other runs (median "
        f"{others:.4g}): those runs logged in millimetres? Columns *_um are "
        "read as µm: multiply their readings by 1000.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return True


def _warn_fahrenheit_sensors(columns, values):
    """Warn when no temperature sensor (``T<name>_C``) ever reads below
    :data:`_FAHRENHEIT_FLOOR`: a machine's structure holds parts near the
    workshop air, which in Fahrenheit reads 50-85. Returns whether it
    warned."""
    temps = [j for j, name in enumerate(columns) if _is_temperature(name)]
    if not temps:
        return False
    block = values[:, temps]
    finite = np.isfinite(block)
    if not finite.any() or block[finite].min() <= _FAHRENHEIT_FLOOR:
        return False
    names = [columns[j] for j in temps]
    coldest = int(np.argmin(np.where(finite, block, np.inf).min(axis=0)))
    shown = listed(names, show=repr)
    warnings.warn(
        f"No temperature sensor ({shown}) ever reads below "
        f"{_FAHRENHEIT_FLOOR:g} (the coldest, {names[coldest]!r}, from "
        f"{block[:, coldest][finite[:, coldest]].min():g}): a machine tool has "
        "parts near the workshop air. In Fahrenheit? Columns *_C are read as "
        "°C: convert with (F - 32) / 1.8. (A table of hot parts only, such as "
        "a motor's windings, may ignore this.)",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return True


def _warn_fahrenheit_runs(df, columns, values, codes):
    """Warn naming the runs in which no temperature sensor reads below
    :data:`_FAHRENHEIT_FLOOR` while every other run has one that does (a
    logger set to Fahrenheit for one test: some 40 above the other runs,
    which an independent check's models took as a 4-9 µm error)."""
    temps = [j for j, name in enumerate(columns) if _is_temperature(name)]
    if not temps:
        return
    # The coldest reading of every run (none where no sensor reads).
    run_min = pd.DataFrame(values[:, temps]).groupby(codes).min().min(axis=1).dropna()
    hot = run_min[run_min > _FAHRENHEIT_FLOOR]
    if "ambient_C" in df.columns:
        # The air of a run in Fahrenheit reads some 70 (warned about as
        # such); air in °C says the run is hot (a warm start with sensors
        # on the bearings and motor only, a climate chamber at 52 °C).
        air = pd.Series(_as_float(df, ["ambient_C"])[:, 0]).groupby(codes).median()
        hot = hot[air.reindex(hot.index) > AIR_RANGE_C[1]]
    if hot.empty or hot.size == run_min.size:
        return
    others = run_min.drop(hot.index)
    # Where the other runs' coldest readings would read in Fahrenheit (give
    # or take 20): a cutting-zone sensor at 250 °C in one hot test is none.
    hot = hot[hot <= 1.8 * others.max() + 32.0 + 20.0]
    if hot.empty:
        return
    labels = df[RUN].to_numpy()
    named = _run_names(labels, codes, hot.index)
    warnings.warn(
        f"No temperature sensor reads below {_FAHRENHEIT_FLOOR:g} in run(s) "
        f"{named} (the coldest from {hot.min():g}), while the other runs "
        f"have one from {others.max():g} down: those runs logged in "
        "Fahrenheit? Columns *_C are read as °C: convert those runs' readings "
        "with (F - 32) / 1.8.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


# The highest spindle speed of a thermal test (rpm) is above this: below it,
# the speeds are in another unit (krpm, rev/s) or a thousands dot ("6.000")
# was read as a decimal point.
_SLOWEST_TOP_RPM = 60.0


def _warn_speed_unit(df):
    """Warn when ``spindle_rpm`` turns but never reaches
    :data:`_SLOWEST_TOP_RPM`: no spindle of a machine tool heats a thermal
    test at that speed (an independent check: "2.000" rpm, a thousands dot,
    read as 2 in silence)."""
    if "spindle_rpm" not in df.columns:
        return
    rpm = _as_float(df, ["spindle_rpm"])[:, 0]
    top = np.nanmax(np.abs(rpm)) if np.isfinite(rpm).any() else 0.0
    if not 0 < top < _SLOWEST_TOP_RPM:
        return
    warnings.warn(
        f"Column 'spindle_rpm' never exceeds {top:g} (rpm), slow for the "
        "spindle of a thermal test. In another unit (thousands of rpm, "
        "revolutions per second: multiply by 1000 or 60), or with a thousands "
        'separator read as a decimal point ("6.000" as 6: read the file '
        "with pandas.read_csv(..., thousands='.'))? Columns spindle_rpm are "
        "read as rpm. (A slow spindle, a rotary table or a lathe's face "
        "plate may ignore this.)",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


# A logger's code for "no reading": a temperature of exactly 0 in a run
# whose readings otherwise sit this far from it (°C).
_ZERO_GAP_C = 5.0


def _warn_zero_readings(df, columns, values, codes):
    """Warn naming the column and the first row where a temperature sensor
    reads exactly 0 in a run whose other readings all lie over
    :data:`_ZERO_GAP_C` away (24 -> 0 -> 24 °C): a logger writing 0 for no
    reading, which models take as a reading (an independent check: a
    training error of 2 µm where the others' was 0.0001)."""
    for j, name in enumerate(columns):
        if not _is_temperature(name):
            continue
        col = values[:, j]
        # Not a run's first row: changes since the start are 0 there.
        zero = (col == 0.0) & np.r_[False, codes[1:] == codes[:-1]]
        if not zero.any():
            continue
        away = np.where(zero | ~np.isfinite(col), np.inf, np.abs(col))
        nearest = pd.Series(away).groupby(codes).transform("min").to_numpy()
        bad = np.flatnonzero(zero & (nearest > _ZERO_GAP_C) & np.isfinite(nearest))
        if bad.size:
            warnings.warn(
                f"Column {name!r} reads exactly 0 at {_where(df, bad[0])}"
                + (f" ({bad.size} such rows in all)" if bad.size > 1 else "")
                + f", where its run reads nothing within {_ZERO_GAP_C:g} °C of "
                "0 otherwise: a logger's 0 for no reading? Models take it as a "
                "reading: set those rows to NaN (missing), or drop them.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
            return


def check_missing_sensors(df, sensors, values=None, hint=ALLOW_MISSING):
    """Raise naming the first missing value (NaN) of the ``sensors`` columns:
    the column, run and row, and ``hint``, the way out."""
    if values is None:
        values = _as_float(df, sensors)
    _report_nonfinite(df, sensors, np.isnan(values), "missing", f"; {hint}")


def _as_list(columns):
    return [columns] if isinstance(columns, str) else list(columns)


def split_runs(df, *, sensors=None, targets=None, validate=True):
    """Split a run table into features, targets and run labels.

    Parameters
    ----------
    df : DataFrame
        A run table.
    sensors : str or list of str, optional
        Columns to use as features: sensor columns, optionally also drivers
        (e.g. ``ambient_C``). Default: every sensor column.
    targets : str or list of str, optional
        Displacement columns to predict. Default: every ``disp_<axis>_um``
        column.
    validate : bool, default=True
        Check ``df`` with :func:`validate_runs` (with ``require_targets=True``);
        missing values are then an error only in the selected sensors.

    Returns
    -------
    X : DataFrame of shape (n_samples, n_sensors)
        The selected sensor columns.
    y : Series or DataFrame
        A Series when ``targets`` is a string, or is None and the table has
        exactly one target column; otherwise (a list of names, or several
        target columns) a DataFrame.
    groups : ndarray of shape (n_samples,)
        The run label of every row, for ``GroupKFold`` and friends.

    Notes
    -----
    ``X`` and ``y`` are indexed by a MultiIndex with levels ``("run",
    "time_s")``. Run-aware skthermal estimators read the run boundaries from
    the ``run`` level, so they keep working inside ``cross_validate`` and
    pipelines, where ``groups`` is not passed on to ``fit``.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.datasets import split_runs
    >>> df = pd.DataFrame({"run": ["a", "a", "b", "b"],
    ...                    "time_s": [0.0, 60.0, 0.0, 60.0],
    ...                    "T1_C": [20.0, 21.5, 20.1, 22.0],
    ...                    "T2_C": [19.0, 19.5, 19.2, 19.9],
    ...                    "disp_y_um": [0.0, 3.2, 0.0, 4.1]})
    >>> X, y, groups = split_runs(df)
    >>> X  # doctest: +NORMALIZE_WHITESPACE
                T1_C  T2_C
    run time_s
    a   0.0     20.0  19.0
        60.0    21.5  19.5
    b   0.0     20.1  19.2
        60.0    22.0  19.9
    >>> y.name, groups.tolist()
    ('disp_y_um', ['a', 'a', 'b', 'b'])
    """
    if validate:
        validate_runs(df, require_targets=True, allow_missing_sensors=True)
    else:
        check_frame(df)
    for name in (RUN, TIME):
        if name not in df.columns:
            raise _missing_column(name, "required to split the table", [], df)
    available = sensor_columns(df)
    features = available if sensors is None else _as_list(sensors)
    allowed = available + driver_columns(df)
    for name in features:
        if name not in allowed:
            where = (
                "is not in the table"
                if name not in df.columns
                else ("is not a sensor or driver column")
            )
            raise ValueError(
                f"Sensor column {name!r} {where}; available sensor columns: "
                f"{available}, drivers: {driver_columns(df)}."
            )
    if not features:
        raise ValueError("No sensor columns selected.")
    available = target_columns(df)
    outputs = available if targets is None else _as_list(targets)
    for name in outputs:
        if name not in available:
            where = (
                "is not in the table"
                if name not in df.columns
                else ("is not a target column")
            )
            raise ValueError(
                f"Target column {name!r} {where}; available target columns: "
                f"{available}."
            )
    if not outputs:
        raise ValueError(f"The run table has no target column: {_RULES['target']}.")
    if validate:
        check_missing_sensors(df, features, hint=SKIP_VALIDATION)

    index = pd.MultiIndex.from_arrays([df[RUN], df[TIME]], names=[RUN, TIME])
    X = df.loc[:, features].set_axis(index, axis=0)
    if isinstance(targets, str) or (targets is None and len(outputs) == 1):
        y = df[outputs[0]].set_axis(index)
    else:
        y = df.loc[:, outputs].set_axis(index, axis=0)
    groups = df[RUN].to_numpy()
    return X, y, groups


def changes_since_start(df, columns=None):
    """Subtract the first value of every run from the chosen columns.

    Files keep absolute readings (DATA_FORMAT); methods that work on
    "temperature change" or "thermal drift since the start of the test" apply
    this transformation themselves. This is the run-table face of the array
    helper the estimators use (one implementation): it finds the runs from the
    ``run`` column, checks the columns, and returns a table.

    Parameters
    ----------
    df : DataFrame
        A run table; it needs a ``run`` column. Runs need not be contiguous.
    columns : str or list of str, optional
        Columns to transform. Default: every sensor and target column.

    Returns
    -------
    DataFrame
        A copy of ``df``; the chosen columns are zero on the first row of each
        run (NaN on every row of a run whose first value is missing). Other
        columns are unchanged.

    Raises
    ------
    ValueError
        Naming the column, run and row of an infinite value, a value that is
        not a number, or ``time_s`` that does not increase within a run.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.datasets import changes_since_start
    >>> df = pd.DataFrame({"run": ["a", "a", "b", "b"],
    ...                    "time_s": [0.0, 60.0, 0.0, 60.0],
    ...                    "T1_C": [20.0, 21.5, 20.1, 22.0],
    ...                    "disp_y_um": [1.0, 3.0, -1.0, 4.0]})
    >>> changes_since_start(df)
      run  time_s  T1_C  disp_y_um
    0   a     0.0   0.0        0.0
    1   a    60.0   1.5        2.0
    2   b     0.0   0.0        0.0
    3   b    60.0   1.9        5.0
    """
    check_frame(df)
    if RUN not in df.columns:
        raise _missing_column(RUN, "needed to find the start of every run", [], df)
    if TIME in df.columns:
        _check_numeric(df, [TIME])
        _check_time(df, pd.factorize(df[RUN], use_na_sentinel=False)[0])
    if columns is None:
        columns = sensor_columns(df) + target_columns(df)
    columns = _as_list(columns)
    absent = [c for c in columns if c not in df.columns]
    if absent:
        raise ValueError(f"Columns {absent} are not in the table.")
    named = pd.Index(columns)
    twice = named[named.duplicated()].unique().tolist()
    if twice:
        raise ValueError(f"columns names {twice} more than once; give each once.")
    _check_numeric(df, columns)
    out = df.copy()
    if not columns or len(df) == 0:
        return out
    values = _as_float(df, columns)
    # A missing value stays missing; an infinite one would turn its run's
    # changes into NaN and inf without a word.
    _report_nonfinite(df, columns, np.isinf(values), "infinite")
    changes = changes_since_first_row(values, df[RUN].to_numpy(), what="Column 'run'")
    out[columns] = pd.DataFrame(changes, index=df.index, columns=columns)
    return out
