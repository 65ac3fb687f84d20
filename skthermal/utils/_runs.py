"""Run-aware helpers: where each run starts and ends inside a stacked array.

Rows of a run table are time-ordered samples of one or more *runs* (tests).
Everything that uses time -- AGO, grey models, "change since the start of the
run" -- must restart at every run boundary. These helpers turn run labels into
contiguous slices and find the labels a user supplied, whichever way they came:
explicitly as ``groups``, as a ``run`` column of a DataFrame, or as a ``run``
level of a DataFrame's index.
"""

import datetime
import inspect
import re
import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils._param_validation import InvalidParameterError

from skthermal._naming import TARGET_PATTERN, plain, shown
from skthermal.utils._noise import pooled_noise
from skthermal.utils._warnings import user_stacklevel
from skthermal.utils._wrappers import routed_params, routing_enabled

RUN_COLUMN = "run"
TIME_COLUMN = "time_s"
# The run table's heat-source drivers: set-points whose losses grow with
# their magnitude (not readings: a model takes them as they are, not as
# changes since the run start).
POWER_DRIVERS = ("spindle_rpm", "feed_mm_min")


def is_commanded(name):
    """Whether a column is a commanded driver: a spindle speed in rpm or a
    feed in mm/min (``spindle_rpm``, ``feed_mm_min``, a second spindle's
    ``spindle2_rpm``, a ColumnTransformer's ``num__feed_mm_min``). It steps
    in one sample and holds a level by command, unlike a reading."""
    return str(name).endswith(("rpm", "_mm_min"))


# A driver written with another unit or spelling (ambient_F, spindle_rps,
# feed_mm_s, feed_rate): every model and the simulator read the drivers by
# their names, in these units. Other columns of the same stem (a spindle's
# load in %, a feed override) are extras.
DRIVER_LOOKALIKES = {
    "ambient_C": re.compile(
        r"((t|temp|temperature)_?)?"
        r"(ambient|air|room|workshop|hall)(_?(air|temp|temperature|t))*"
        r"(_?(c|f|k|deg_?c|deg_?f|°c|°f|kelvin|celsius|fahrenheit))?_*"
    ),
    "spindle_rpm": re.compile(
        r"((spindle(_?(speed|n))?|speed)"
        r"(_?(rpm|rps|hz|rad_?s|1/min|min-1|min\^-1|u/min|rev_?min|r_?min|rev_?s))?"
        r"|(n_?)?rpm)"  # the unit alone: a logger's "rpm" or "n [rpm]"
        r"(_?(act|actual|meas|measured))?_*"
    ),
    "feed_mm_min": re.compile(
        r"feed(_?rate)?(_?(mm|m|in|inch)_?(per_?|/)?(min|s|sec)|_?ipm|_?mmpm)?"
        r"(_?(act|actual|meas|measured))?_*"
    ),
}
DRIVER_RULE = (
    "the drivers are named exactly 'spindle_rpm' (rpm), 'feed_mm_min' (mm/min) "
    "and 'ambient_C' (°C); convert its unit and rename it"
)


def driver_lookalike(name):
    """The driver a column name writes with another unit or spelling
    (``ambient_F``: ``"ambient_C"``), or None."""
    if not isinstance(name, str) or name in (*POWER_DRIVERS, "ambient_C"):
        return None
    # Units in brackets or after spaces, as loggers write them:
    # "ambient [K]", "ambient (C)" read as "ambient_k", "ambient_c".
    lower = re.sub(r"[^0-9a-z°/^\-]+", "_", name.lower()).strip("_")
    return next(
        (d for d, pattern in DRIVER_LOOKALIKES.items() if pattern.fullmatch(lower)),
        None,
    )


def driver_lookalike_hint(columns, missing):
    """Text to add to an error about the ``missing`` drivers: the columns
    that write one of them in another unit or spelling (``ambient_F``), and
    the naming rule; empty when there is none."""
    found = [
        f"{c!r} looks like {d!r}"
        for c in columns
        if (d := driver_lookalike(c)) is not None and d in missing
    ]
    if not found:
        return ""
    return f" ({'; '.join(found)}: {DRIVER_RULE})"


# The largest magnitude a feature or target value may have. No sensor reads
# 1e100 in any unit: such a value is a broken sensor or a corrupt file. The
# models square readings, multiply them and sum them over runs (least
# squares, the grey models' accumulation, variances, distances); from
# magnitudes of about 1e150 on, those overflow float64 (1.8e308) into inf
# and NaN. Up to this bound they stay finite with room to spare.
MAX_MAGNITUDE = 1e100
# A number written with a decimal comma ("20,5"), which pandas reads as text.
DECIMAL_COMMA = re.compile(r"\s*[-+]?[0-9]*,[0-9]+\s*")
# No temperature lies below it (°C).
ABSOLUTE_ZERO_C = -273.15


def check_flat_columns(columns, what="The run table", name="df"):
    """Raise a ValueError when ``columns`` has several levels (a MultiIndex,
    as ``pandas.read_csv(..., header=[0, 1])`` gives for a row of units),
    with the way to flatten them (``name``: the frame's name in the hint)."""
    if getattr(columns, "nlevels", 1) > 1:
        raise ValueError(
            f"{what} has columns of {columns.nlevels} levels (a MultiIndex, e.g. "
            f"{columns[0]!r}); a run table has one name per column. Flatten "
            f"them first, e.g. {name}.columns = ['_'.join(map(str, c)) for c in "
            f"{name}.columns]."
        )


def check_unique_columns(df, what="The run table"):
    """Raise a ValueError naming the columns ``df`` holds more than once."""
    duplicated = df.columns[df.columns.duplicated()].unique().tolist()
    if duplicated:
        raise ValueError(f"{what} has duplicated columns: {duplicated}.")


def rows_by_run(labels):
    """Every run's label and rows: ``(labels, rows)``, the runs in order of
    first appearance, ``rows[r]`` the row numbers of run ``r`` in order
    (the runs' rows need not be together). Found in one pass, not a mask
    per run, which costs runs x rows (16,000 runs took a minute).

    Examples
    --------
    >>> from skthermal.utils._runs import rows_by_run
    >>> labels, rows = rows_by_run(["a", "b", "a"])
    >>> list(labels), [r.tolist() for r in rows]
    (['a', 'b'], [[0, 2], [1]])
    """
    import pandas as pd

    codes, uniques = pd.factorize(
        np.asarray(labels, dtype=object), use_na_sentinel=False
    )
    order = np.argsort(codes, kind="stable")
    bounds = np.cumsum(np.bincount(codes, minlength=len(uniques)))[:-1]
    return uniques, np.split(order, bounds)


def run_slices(groups, n_samples=None):
    """Contiguous slices, one per run, in order of appearance.

    Parameters
    ----------
    groups : array-like of shape (n_samples,) or None
        Run label of every row. ``None`` means all rows form one run.
    n_samples : int, optional
        Number of rows; required when ``groups`` is None.

    Returns
    -------
    slices : list of slice
        ``slices[r]`` selects the rows of the r-th run.
    labels : list
        The run label of each slice.

    Raises
    ------
    ValueError
        If the rows of a run are not contiguous, or if ``groups`` does not have
        one label per row.
    """
    if groups is None:
        if n_samples is None:
            raise ValueError("n_samples is required when groups is None.")
        return [slice(0, int(n_samples))], [None]
    groups = label_array(groups)
    if groups.ndim != 1:
        raise ValueError(
            f"Run labels (groups) must be one-dimensional, got shape {groups.shape}."
        )
    if n_samples is not None and groups.shape[0] != n_samples:
        raise ValueError(
            f"Got {groups.shape[0]} run labels (groups) for {n_samples} rows; "
            "every row needs exactly one run label."
        )
    if groups.shape[0] == 0:
        return [], []
    check_labels(groups)
    change = np.flatnonzero(groups[1:] != groups[:-1]) + 1
    starts = np.concatenate(([0], change))
    stops = np.concatenate((change, [groups.shape[0]]))
    if groups.dtype.kind in "mM":
        import pandas as pd

        # Timestamps (durations), as the run column held them: numpy's
        # tolist would give datetimes, or nanoseconds as plain ints.
        labels = pd.Index(groups[starts]).tolist()
    else:
        labels = groups[starts].tolist()
    # A label that starts more than one block means the run is split up.
    seen, bad = set(), None
    for lab in labels:
        if lab in seen:
            bad = lab
            break
        seen.add(lab)
    if bad is not None:
        blocks = [
            f"rows {a}-{b - 1}"
            for a, b, lab in zip(starts, stops, labels, strict=True)
            if lab == bad
        ]
        raise ValueError(
            f"The rows of run {bad!r} are not contiguous ({', '.join(blocks[:3])}); "
            "sort the table by run and time so that each run is one block. "
            "(A tool that shuffles columns, such as permutation_importance, "
            "shuffles a 'run' column too: give the runs as the index, e.g. "
            "X from split_runs, or as groups. A tool that draws rows at "
            "random, such as HalvingGridSearchCV with its default "
            "resource='n_samples', breaks the runs up: give it another "
            "resource, e.g. resource='epochs' for ANFIS.)"
        )
    slices = [slice(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]
    return slices, labels


def label_array(groups, **kwargs):
    """Labels as an ndarray, refusing a sequence that mixes kinds.

    ``np.asarray([1, 1, "1", "1"])`` turns every label into text, so two
    runs (or parts) would merge into one; such a sequence is checked as given
    (:func:`check_labels`, with ``kwargs``) before it is converted.
    """
    arr = np.asarray(groups)
    if arr.dtype.kind in "US" and not isinstance(groups, np.ndarray):
        as_given = np.asarray(groups, dtype=object)
        if as_given.ndim == 1 and as_given.size:
            check_labels(as_given, **kwargs)
    return arr


def check_labels(groups, *, item="row", label="run", whole="run (test)"):
    """Raise a ValueError naming the first ``item`` (row) whose ``label`` (run
    label) is missing (None, NaN) or of another kind than the first one's (a
    number among strings). ``groups`` is an ndarray; ``whole`` names what a
    label stands for."""
    import pandas as pd

    missing = pd.isna(groups)
    if missing.any():
        i = int(np.flatnonzero(missing)[0])
        raise ValueError(
            f"{item.capitalize()} {i} has no {label} label (it is missing: None "
            f"or NaN); every {item} needs the label of the {whole} it belongs to."
        )
    if groups.dtype != object or pd.api.types.infer_dtype(groups) not in (
        "mixed",
        "mixed-integer",
    ):
        return

    def kind(v):
        return "string" if isinstance(v, str) else type(v).__name__

    first = kind(groups[0])
    # "mixed" also covers labels of one kind that pandas does not name
    # (tuples): those are fine.
    i = next((i for i, v in enumerate(groups.tolist()) if kind(v) != first), None)
    if i is None:
        return
    raise ValueError(
        f"{label.capitalize()} labels mix kinds: {item} 0 has {groups[0]!r} "
        f"({first}), {item} {i} has {groups[i]!r} ({kind(groups[i])}); give every "
        f"{whole.split(' ')[0]} the same kind of label (e.g. all strings)."
    )


def check_run_label(run, name="run"):
    """Raise a ValueError unless ``run`` is one run label: a string or a
    number, not missing (None, NaN) and not a sequence."""
    import pandas as pd

    if (
        isinstance(run, (bool, np.bool_))
        or not isinstance(run, (str, Integral, Real))
        or pd.isna(run)
    ):
        raise ValueError(
            f"{name} must be one run label (a string or a number) for the "
            f"whole run, got {run!r}."
        )


def run_first_rows(groups, n_samples):
    """The first row of the run of every row.

    Parameters
    ----------
    groups : array-like of shape (n_samples,) or None
        Run label of every row; ``None``: all rows form one run.
    n_samples : int
        Number of rows.

    Returns
    -------
    first : ndarray of int, shape (n_samples,)
        ``first[i]`` is the index of the first row of row ``i``'s run;
        ``first == np.arange(n_samples)`` marks the rows that start a run.

    Examples
    --------
    >>> from skthermal.utils._runs import run_first_rows
    >>> run_first_rows(["a", "a", "b", "b", "b"], 5)
    array([0, 0, 2, 2, 2])
    """
    slices, _ = run_slices(groups, n_samples)
    return np.repeat(
        np.array([s.start for s in slices], dtype=int),
        [s.stop - s.start for s in slices],
    )


def frame_run_labels(frame):
    """The run label of every row of a DataFrame: its ``run`` column, else
    the ``run`` level of its index, else None (all rows are one run).

    For helpers that need a run table's runs but not its features (a table
    of channels to add to, say); :func:`extract_runs` is the reader of a
    model's input.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.utils._runs import frame_run_labels
    >>> index = pd.MultiIndex.from_tuples([("a", 0.0), ("a", 60.0), ("b", 0.0)],
    ...                                   names=["run", "time_s"])
    >>> frame_run_labels(pd.DataFrame({"T1_C": [1.0, 2.0, 3.0]}, index=index))
    array(['a', 'a', 'b'], dtype=object)
    """
    if RUN_COLUMN in frame.columns:
        labels = frame[RUN_COLUMN].to_numpy()
    elif RUN_COLUMN in (frame.index.names or ()):
        labels = frame.index.get_level_values(RUN_COLUMN).to_numpy()
    else:
        return None
    check_labels(labels)
    return labels


def as_pandas(data):
    """A polars (or other) DataFrame or Series as a pandas one, else ``data``.

    Run tables are read through pandas' columns and index; a frame of another
    library that converts itself (``to_pandas()``, as polars and pyarrow do)
    is converted, so its ``run`` and ``time_s`` columns are found like a
    pandas frame's. Such frames have no index: the run labels and times
    travel as columns.
    """
    module = type(data).__module__.partition(".")[0]
    if module in ("pandas", "numpy", "builtins") or not hasattr(data, "to_pandas"):
        return data
    return data.to_pandas()


def check_frame(df, what="A run table"):
    """Raise a ValueError unless ``df`` is a pandas DataFrame with each column
    once; a frame of another library (polars, pyarrow) is named with the
    conversion."""
    import pandas as pd

    if isinstance(df, pd.DataFrame):
        check_flat_columns(df.columns, what)
        check_unique_columns(df, what)
        return
    kind = type(df).__name__
    module = type(df).__module__.partition(".")[0]
    if module not in ("builtins", "numpy", "pandas"):
        kind = f"{module} {kind}"
    hint = (
        "; convert it with .to_pandas()"
        if callable(getattr(df, "to_pandas", None))
        else ""
    )
    raise ValueError(f"{what} must be a pandas DataFrame, got {kind}{hint}.")


def extract_runs(X, groups=None, *, finite=True, y=None):
    """Separate run labels (and times) from the features of ``X``.

    The labels are taken, in this order, from ``groups``, from a ``run`` column
    of a DataFrame (which is then removed from the features), or from a ``run``
    level of a DataFrame's index. Without any of them, all rows are one run.

    A ``time_s`` column (the run table's time since the run start) is not a
    feature either: it is removed from the features and becomes the
    ``time_s`` level of the index (with the run labels as a ``run`` level),
    which is where the time-aware estimators read it, as from
    :func:`skthermal.datasets.split_runs`.

    Parameters
    ----------
    X : array-like or DataFrame
    groups : array-like of shape (n_samples,), optional
    finite : bool, default=True
        Whether the feature values must be readings (:func:`unreadable`): a
        NaN, a missing value, inf, or a value of a magnitude beyond
        :data:`MAX_MAGNITUDE` (1e100) is then an error naming the column,
        the row, its run and its time (:func:`check_finite_columns`; NaN and
        inf in a plain array are left to
        :func:`sklearn.utils.validation.validate_data`). Estimators that
        handle missing readings themselves pass False and test their values
        with :func:`unreadable`.
    y : array-like of shape (n_samples,) or (n_samples, n_targets), optional
        The target of a fit. A ``y`` with row labels (a Series or DataFrame)
        must label its rows as ``X`` does (:func:`check_target_rows`); with
        ``finite``, a missing or infinite target value is an error naming
        the row, its run and its time.

    Returns
    -------
    X : array-like
        ``X`` without a ``run`` or ``time_s`` column.
    groups : ndarray of shape (n_samples,) or None

    Raises
    ------
    ValueError
        If a feature column of a DataFrame is not numeric, or ``time_s`` (a
        column or an index level) holds something other than numbers (naming
        the column and an offending value), or a DataFrame has no feature
        column left, or ``y``'s row labels are not ``X``'s, or (``finite``)
        a feature or target value is not finite or is beyond
        :data:`MAX_MAGNITUDE` in magnitude.

    Notes
    -----
    A DataFrame of run labels alone (no feature column, no ``time_s``, no
    ``y``) is not an error: it asks for the labels. With a ``time_s`` or a
    ``y`` it is a model's input without features, an error.
    """
    import scipy.sparse

    if scipy.sparse.issparse(X):
        # scikit-learn's words, as validate_data says them without groups.
        raise TypeError(
            "Sparse data was passed for X, but dense data is required. Use "
            "'.toarray()' to convert to a dense numpy array."
        )
    X, y = as_pandas(X), as_pandas(y)
    columns = getattr(X, "columns", None)
    check_flat_columns(columns, "X", "X")
    given_index = getattr(X, "index", None)
    if columns is not None and not columns.is_unique:
        duplicated = list(dict.fromkeys(columns[columns.duplicated()]))
        raise ValueError(
            f"X has duplicate column name(s) {duplicated}; every sensor needs a "
            "column of its own name."
        )
    has_column = columns is not None and RUN_COLUMN in list(columns)
    given = groups
    if has_column:
        run_col = X[RUN_COLUMN]
        X = X.drop(columns=RUN_COLUMN)
        if groups is None:
            groups = run_col.to_numpy()
        else:
            _warn_other_runs(groups, run_col.to_numpy(), "column")
    index = getattr(X, "index", None)
    names = getattr(index, "names", None)
    if groups is None:  # the labels given otherwise, a level is not needed
        _check_run_level(index)
    if names is not None and RUN_COLUMN in names:
        if groups is None:
            groups = index.get_level_values(RUN_COLUMN).to_numpy()
        elif given is not None:
            _warn_other_runs(
                groups, index.get_level_values(RUN_COLUMN).to_numpy(), "index level"
            )
    if groups is not None:
        n_rows = getattr(X, "shape", (len(X),))[0]
        shape = np.shape(groups)
        if len(shape) != 1 or shape[0] != n_rows:
            got = f"{shape[0]} run labels" if len(shape) == 1 else "run labels"
            raise ValueError(
                f"Got {got} (groups) of shape {shape} for {n_rows} rows; give "
                "one label per row."
            )
    if columns is not None and TIME_COLUMN in list(columns):
        times = _time_seconds(X[TIME_COLUMN], f"Column {TIME_COLUMN!r}")
        X = X.drop(columns=TIME_COLUMN)
        X = X.set_axis(run_table_index(groups, times), axis=0)
    _check_feature_columns(X, columns, y)
    if groups is not None:
        groups = label_array(groups)
    check_numeric_columns(X, groups)
    _check_finite_times(X, groups)
    if finite:
        check_finite_columns(X, groups)
    elif columns is None and getattr(getattr(X, "dtype", None), "kind", "O") == "O":
        _plain_values(X, groups)  # a ValueError for 10**400 (object or list)
    if y is not None:
        check = check_finite_target if finite else check_target_rows
        check(y, X, groups, given_index=given_index)
        warn_target_columns(X, y)
    return X, groups


def warn_time_unit(X, groups):
    """For the fit of a model that reads times: :func:`warn_odd_times`'s
    milliseconds check of a ``time_s`` index level (not its late-start or
    minutes checks: a fit may take the later part of a run, or a window of
    it; :func:`warn_short_runs` judges short runs)."""
    import pandas as pd

    t = row_times(X)
    if t is None or t.size < 2:
        return
    codes = (
        np.zeros(t.size, dtype=int)
        if groups is None
        else pd.factorize(pd.Series(np.asarray(groups, dtype=object)))[0]
    )
    order = np.argsort(codes, kind="stable")
    warn_odd_times(codes[order], t[order], late_start=False, minutes=False)


# Thermal tests last hours to weeks and are logged every second to hours: a
# run longer than this, or logged more slowly, has time_s in milliseconds
# (a run of 1.5 h in ms lasts 62 days) ...
_MAX_RUN_S = 60 * 86400.0
_MAX_STEP_S = 6 * 3600.0
# ... and runs all shorter than this, logged faster than every second, have
# it in minutes (runs of up to 20 h).
_SHORT_RUNS_S = 1200.0
_FAST_STEP_S = 1.0


# Workshop air outside this range (°C) is most likely in another unit.
AIR_RANGE_C = (-40.0, 60.0)


def air_unit_guess(value):
    """What an air temperature outside :data:`AIR_RANGE_C` most likely is,
    as the end of a warning ("in kelvin?")."""
    if value > 200:
        return "in kelvin?"
    if value > AIR_RANGE_C[1]:
        return "in Fahrenheit?"
    return "another unit, or a faulty sensor?"


def warn_air_unit(air, used_by="simulation, gap diagnosis", where=None):
    """Warn when the workshop air readings ``air`` (``ambient_C``, any
    shape) lie outside what workshop air (or a climate chamber) reads in °C
    (Fahrenheit reads 60-90, kelvin about 293): ``used_by`` takes them as
    °C. ``where``: a function of a position in the flattened ``air`` that
    says where that reading is (``"run 'a', time_s 30 (row 2)"``)."""
    air = np.asarray(air, dtype=float).ravel()
    finite = np.flatnonzero(np.isfinite(air))
    if not finite.size:
        return
    low, high = AIR_RANGE_C
    values = air[finite]
    if values.min() >= low and values.max() <= high:
        return
    k = int(np.argmax(np.abs(values - np.clip(values, low, high))))
    at = "" if where is None else f" at {where(int(finite[k]))}"
    warnings.warn(
        f"Column 'ambient_C' reads {values[k]:g}{at} (range {values.min():g} to "
        f"{values.max():g}), outside the {low:g} to {high:g} °C of workshop air "
        f"and climate chambers: {air_unit_guess(values[k])} It is read as °C "
        f"({used_by}).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def warn_odd_times(codes, times, late_start=True, minutes=True):
    """Warn when ``time_s`` (sorted by run ``codes``) looks like a clock's
    time (most runs start after 0) or like another unit than seconds: every
    model reads it as seconds since the run's start, so the filters' time
    constants and a drift rate would be off by 60 or 1000 without a word.
    ``minutes=False`` leaves out the minutes check (a fit may take a window
    of a run, which says nothing of how long the runs are)."""
    if not len(times):
        return
    starts = np.r_[True, codes[1:] != codes[:-1]]
    first = times[starts]
    last = times[np.r_[starts[1:], True]]
    length = last - first
    steps = np.diff(times)[~starts[1:]]
    step = float(np.median(steps)) if steps.size else 0.0
    # A run whose first sample is one period in (at 15 s, not 0) is fine;
    # one that starts before 0 by more than rounding is not (a run from -60 s
    # at 30 s passed).
    late = first[first > 2 * step]
    early = first[first < -0.5 * step]
    if late_start and early.size:
        warnings.warn(
            f"Column 'time_s' is the time since each run's start, but "
            f"{early.size} of the {first.size} runs start before 0 (at "
            f"{early.min():g} to {early.max():g} s): subtract each run's first "
            "time. Models of runs read the times as seconds since the start.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    elif late_start and late.size > 1 and 2 * late.size >= first.size:
        warnings.warn(
            f"Column 'time_s' is the time since each run's start, but "
            f"{late.size} of the {first.size} runs do not start at 0 (they start "
            f"at {late.min():g} to {late.max():g} s): a clock's time? Then "
            "subtract each run's first time. Rows that continue runs a model was "
            "fitted on keep their times: the model goes on from where the run "
            "left off (with the times restarted it would start the runs anew). "
            "Models of runs read any other run that does not start at 0 as the "
            "later part of a run and say so when they predict it.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    if not steps.size:
        return
    longest = float(length.max())
    if longest > _MAX_RUN_S or step > _MAX_STEP_S:
        unit = "milliseconds"
    elif minutes and longest < _SHORT_RUNS_S and step < _FAST_STEP_S:
        # A run of hours logged every few seconds: in hours, a few "s" long
        # and logged every thousandths; in minutes, some hundreds long.
        unit = "hours (or minutes)" if longest < _SHORT_RUNS_S / 60 else "minutes"
    else:
        return
    warnings.warn(
        "time_s is read as seconds since each run's start: the runs "
        f"last up to {longest:.4g} s ({longest / 3600:.3g} h), logged every "
        f"{step:.4g} s (median step). Thermal tests last hours to weeks and are "
        f"logged every second to hours: is time_s in {unit}? Convert it to seconds "
        "(every time-aware model and the gap diagnosis read it so); if the "
        "times are right, ignore this warning.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def warn_target_columns(X, y):
    """Warn when the features ``X`` (a DataFrame, ``run`` and ``time_s``
    already taken out) hold the target ``y`` itself or a displacement column
    of the run table (``disp_<axis>_um``): a stored run table passed whole
    as ``X`` keeps its targets as features, and a model fitted so predicts
    the target from itself (a selector picks it as the best "sensor", a
    cross-validation scores it perfect), silently."""
    columns = getattr(X, "columns", None)
    if columns is None or y is None or X.shape[0] == 0:
        return
    targets = [c for c in columns if isinstance(c, str) and TARGET_PATTERN.fullmatch(c)]
    values = np.asarray(y)
    values = values.reshape(len(values), -1) if values.ndim else values
    same = []
    if values.ndim == 2 and values.shape[0] == X.shape[0]:
        try:
            wanted = values.astype(float)
            # A constant target says nothing of which column it is.
            wanted = wanted[:, np.ptp(wanted, axis=0) > 0] if wanted.size else None
        except (TypeError, ValueError):
            wanted = None
        for c in columns:
            if wanted is None or X[c].dtype.kind not in "biuf":
                continue
            column = X[c].to_numpy(dtype=float)
            if any(np.array_equal(column, w, equal_nan=True) for w in wanted.T):
                same.append(c)
    if not targets and not same:
        return
    parts = []
    if same:
        parts.append(f"X's column(s) {shown(same)} equal the target y")
    rest = [c for c in targets if c not in same]
    if rest:
        parts.append(
            f"X holds the displacement column(s) {shown(rest)} (targets of the "
            "run table, not sensors)"
        )
    warnings.warn(
        "; ".join(parts) + ": they are features of this fit, so the model "
        "predicts the target from a target. Drop them from X, e.g. "
        "split_runs(runs, targets=...) or runs.drop(columns=[...]), and pass "
        "the target as y.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_other_runs(groups, labels, where):
    """Warn when ``groups`` cut the rows into other runs than the ``run``
    ``labels`` of X (its ``where``: column or index level); ``groups`` win.
    Labels that differ only in name (codes for the same runs) agree."""
    import pandas as pd

    if np.shape(groups) != np.shape(labels):
        return  # the length check that follows names the problem
    codes = pd.factorize(pd.Series(np.asarray(groups, dtype=object)))[0]
    other = pd.factorize(pd.Series(np.asarray(labels, dtype=object)))[0]
    if np.array_equal(codes, other):
        return
    k = int(np.flatnonzero(codes != other)[0])
    warnings.warn(
        f"groups cut the rows into {codes.max() + 1} run(s), X's {RUN_COLUMN!r} "
        f"{where} into {other.max() + 1}, and they first disagree at row {k} "
        f"(groups {plain(np.asarray(groups)[k])!r}, X {plain(labels[k])!r}); "
        "groups are used. Give one of them, or the same runs in both.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _check_feature_columns(X, columns, y):
    """Raise a ValueError when a DataFrame ``X`` (after :func:`extract_runs`
    took its ``run`` and ``time_s`` out; ``columns``: those it was given
    with) has no feature column left, unless it holds run labels alone (no
    ``time_s``, no ``y``): scikit-learn would fail on it with numpy's "at
    least one array or dtype is required"."""
    if columns is None or X.shape[1] != 0:
        return
    if y is None and not has_time_index(X):
        return  # run labels alone, asked for as such
    given = [str(c) for c in columns]
    held = f"only {given}" if given else "no column at all"
    raise ValueError(
        f"X has no feature columns (run and time_s are the index, not "
        f"features): it holds {held}. Give the model at least one sensor or "
        "driver column, e.g. runs[['run', 'time_s', 'T05_C']]."
    )


def refuse_clock_values(
    value, what, hint="t.dt.total_seconds() or (t - t[0]) / pd.Timedelta(seconds=1)"
):
    """Raise a ValueError naming ``what`` when ``value`` (an array, a
    Series or a scalar) holds datetimes or durations (numpy, pandas,
    pyarrow or :mod:`datetime`): converted to numbers they become integer
    ticks (nanoseconds, microseconds), with no error. ``hint``: how to get
    seconds."""
    import datetime

    import pandas as pd

    kind = getattr(value, "dtype", None)
    if kind is None:
        clock = datetime.timedelta | datetime.datetime | np.timedelta64 | np.datetime64
        if isinstance(value, clock):
            kind = type(value).__name__
        elif isinstance(value, list | tuple) and value:
            return refuse_clock_values(pd.Series(list(value)), what, hint)
    elif not is_clock_dtype(kind):
        kind = None
    if kind is not None:
        raise ValueError(
            f"{what} holds {kind} values (time stamps or durations), which as "
            f"numbers would be integer ticks; give seconds as numbers, e.g. {hint}."
        )


def _time_seconds(values, what):
    """``time_s`` values (a column or index level, named by ``what``) as
    float seconds; a ValueError names what it holds when that is not
    numbers: datetimes or durations (converting would give nanoseconds or
    microseconds, with no error) or text."""
    import pandas as pd

    refuse_clock_values(
        values,
        what,
        "the seconds since the start of each run, "
        "(t - t.groupby(run).transform('first')).dt.total_seconds()",
    )
    kind = values.dtype
    if pd.api.types.is_numeric_dtype(kind):
        return np.asarray(values, dtype=float)
    raw = np.asarray(values, dtype=object)
    converted = pd.to_numeric(pd.Series(raw), errors="coerce").to_numpy(dtype=float)
    bad = np.isnan(converted) & ~pd.isna(raw)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{what} is not numeric: row {i} holds {plain(raw[i])!r}; it must "
            "hold the seconds since the start of each run as numbers."
        )
    return converted


def target_names(y):
    """The names of the targets of a Series (its name) or DataFrame (its
    columns), as strings; None for arrays and unnamed Series."""
    if hasattr(y, "columns"):
        return [str(c) for c in y.columns]
    name = getattr(y, "name", None)
    return None if name is None else [str(name)]


def run_table_index(groups, times):
    """The ``(run, time_s)`` MultiIndex of run-table rows, where the
    time-aware estimators read them; a level whose values are None is left
    out."""
    import pandas as pd

    arrays, names = [], []
    if groups is not None:
        # A pandas index keeps its dtype (categorical labels stay so).
        arrays.append(groups if isinstance(groups, pd.Index) else np.asarray(groups))
        names.append(RUN_COLUMN)
    if times is not None:
        arrays.append(np.asarray(times, dtype=float))
        names.append(TIME_COLUMN)
    return pd.MultiIndex.from_arrays(arrays, names=names)


def accepts_groups(method):
    """Whether ``method`` (a bound ``fit``, ``predict``, ...) takes a
    ``groups`` argument: by name, or, with scikit-learn's metadata routing
    enabled, through ``**params`` (a Pipeline routes it to the steps that
    request it)."""
    from sklearn import get_config

    try:
        params = inspect.signature(method).parameters
    except (TypeError, ValueError):  # builtins, C methods
        return False
    if "groups" in params:
        return True
    var_keyword = any(p.kind is p.VAR_KEYWORD for p in params.values())
    return var_keyword and bool(get_config().get("enable_metadata_routing"))


def run_frame_index(original, X, groups):
    """The ``(run[, time_s])`` index of a run table's rows, or None when
    ``original`` (a transformer's input) is not a DataFrame carrying runs or
    times (``X`` and ``groups`` as :func:`extract_runs` returns them). The
    run-aware transformers return their output indexed by it, so that a
    sequence model after them in a Pipeline still sees every run's start and
    each row's time."""
    times = row_times(X)
    if not hasattr(original, "columns") or (groups is None and times is None):
        return None
    return run_table_index(_as_given(original, groups), times)


def _as_given(original, groups):
    """The run labels ``groups`` as ``original`` holds them (its ``run``
    column or index level, as a pandas index: categorical labels stay
    categorical), when they are those labels; else ``groups``."""
    import pandas as pd

    if groups is None:
        return None
    if RUN_COLUMN in original.columns:
        given = pd.Index(original[RUN_COLUMN])
    elif RUN_COLUMN in (original.index.names or []):
        given = original.index.get_level_values(RUN_COLUMN)
    else:
        return groups
    labels = np.asarray(groups, dtype=object)
    if len(given) != len(labels) or not np.array_equal(
        np.asarray(given, dtype=object), labels
    ):
        return groups
    return given


def with_run_index(X, groups=None):
    """``X`` with its runs (and times) in the index, for a model that reads
    them from its input rather than from a ``groups`` argument: a Pipeline,
    a wrapper's inner model, every fit and predict of a search. ``run`` and
    ``time_s`` columns move into the index (a plain model would take them as
    inputs); ``groups``, when ``X`` carries no run labels, become its
    ``run`` level (with the times as ``time_s``)."""
    import pandas as pd

    columns = list(getattr(X, "columns", []))
    if groups is not None or RUN_COLUMN in columns or TIME_COLUMN in columns:
        X = as_pandas(X)  # a polars frame's run and times: into an index
    if isinstance(X, pd.DataFrame):
        moved = [c for c in (RUN_COLUMN, TIME_COLUMN) if c in X.columns]
        # A column and an index level of one name: the column, as
        # extract_runs takes it (the level would be there twice).
        twice = [n for n in X.index.names if n in moved]
        if twice:
            X = (
                X.droplevel(twice)
                if X.index.nlevels > len(twice)
                else X.reset_index(drop=True)
            )
        kept = [
            n
            for n in X.index.names
            if n in (RUN_COLUMN, TIME_COLUMN) and n not in moved
        ]
        if moved and kept:
            # The runs in the index and the times in a column (or the other
            # way round): both into the index, in the run table's order.
            X = X.set_index(moved, append=True)
            other = [
                i
                for i, n in enumerate(X.index.names)
                if n not in (RUN_COLUMN, TIME_COLUMN)
            ]
            if other:
                X = X.droplevel(other)
            X = X.reorder_levels([RUN_COLUMN, TIME_COLUMN])
        elif moved:
            X = X.set_index(moved)
    if groups is None:
        return X
    columns = list(getattr(X, "columns", []))
    index = getattr(X, "index", None)
    names = [n for n in (getattr(index, "names", None) or []) if n is not None]
    if RUN_COLUMN in columns or RUN_COLUMN in names:
        return X
    frame = X if isinstance(X, pd.DataFrame) else pd.DataFrame(np.asarray(X))
    if len(groups) != len(frame):
        raise ValueError(
            f"groups has {len(groups)} run labels for {len(frame)} rows of X; "
            "give one label per row."
        )
    times = row_times(frame)
    return frame.set_axis(run_table_index(groups, times))


def pass_runs(method, X, groups, kwargs):
    """``X`` and the keyword arguments that give the runs to ``method`` (a
    wrapped model's ``fit``, ``predict``, ...): ``run`` and ``time_s``
    columns of ``X`` as its index (a plain model would take them as inputs),
    ``groups`` as ``groups=`` when the method takes that argument
    (:func:`accepts_groups`), else as a ``run`` index level (a Pipeline,
    whose steps read it there)."""
    if groups is not None and accepts_groups(method):
        return with_run_index(X), {**kwargs, "groups": groups}
    return with_run_index(X, groups), kwargs


def routed_runs(owner, method, inner_method, X, groups, params):
    """:func:`pass_runs` for a wrapper ``owner`` whose ``method`` (``"fit"``,
    ``"partial_fit"``) calls the same method of its wrapped model
    (``inner_method``), under scikit-learn's metadata routing when it is
    enabled: the wrapped model then gets what it requested
    (``set_fit_request``), ``groups`` included; runs it does not take as
    ``groups=`` travel in ``X``'s index. See
    :func:`~skthermal.utils._wrappers.wrapper_router`."""
    if not routing_enabled():
        return pass_runs(inner_method, X, groups, params)
    given = dict(params)
    if groups is not None:
        given["groups"] = groups
    routed = routed_params(owner, method, given)
    if "groups" in routed:
        return with_run_index(X), routed
    return with_run_index(X, groups), routed


def describe_row(row, X, groups):
    """``"row 3, run 'a', time_s=120"``: a row of a run table, with its run
    and time when known (``X`` and ``groups`` as :func:`extract_runs`
    returns them), for messages."""
    where = [f"row {row}"]
    if groups is not None:
        where.append(f"run {plain(groups[row])!r}")
    t = row_times(X)
    if t is not None:
        where.append(f"time_s={t[row]:g}")
    return ", ".join(where)


def _check_finite_times(X, groups):
    """Raise a ValueError naming the first row whose ``time_s`` is missing or
    infinite (a time-aware model would filter with a NaN step)."""
    t = row_times(X)
    if t is None or np.all(np.isfinite(t)):
        return
    row = int(np.flatnonzero(~np.isfinite(t))[0])
    run = "" if groups is None else f", run {plain(groups[row])!r}"
    raise ValueError(
        f"{TIME_COLUMN} is {t[row]} at row {row}{run} "
        f"({int(np.sum(~np.isfinite(t)))} non-finite time(s)); every row needs "
        "its time since the start of the run."
    )


def _label(value):
    """A row label for messages: numpy scalars (also inside a tuple) as
    Python values."""
    if isinstance(value, tuple):
        return tuple(plain(v) for v in value)
    return plain(value)


def _same_index(y_index, X, given_index):
    """Whether ``y_index`` is the index of ``X`` or the one ``X`` was given
    with (before :func:`extract_runs` made a ``time_s`` column its index)."""
    import pandas as pd

    return any(
        isinstance(idx, pd.Index) and y_index.equals(idx)
        for idx in (getattr(X, "index", None), given_index)
    )


def check_one_target(name, y, example):
    """Raise naming the estimator ``name`` and the targets of ``y`` when it
    holds several columns: an estimator of one target says so, and how to
    fit one per target (``example``: the estimator as a user writes it,
    e.g. ``"GreyPSORegressor()"``), not scikit-learn's "y should be a 1d
    array"."""
    shape = getattr(y, "shape", None) or np.asarray(y).shape
    if len(shape) == 2 and shape[1] > 1:
        names = getattr(y, "columns", None)
        which = "" if names is None else f" ({[str(c) for c in names]})"
        raise ValueError(
            f"{name} fits one target, got {shape[1]}{which}: fit one model per "
            f"target, e.g. sklearn.multioutput.MultiOutputRegressor({example})."
        )


def check_target_rows(y, X, groups, *, given_index=None):
    """Raise a ValueError when ``y`` holds the rows of ``X`` in another order.

    scikit-learn pairs ``X`` and ``y`` by position. A ``y`` with row labels
    (a Series or DataFrame) that are ``X``'s in another order (sorted
    otherwise after a merge) would be paired with the wrong rows without a
    word, so it is an error naming the first row that differs, when:

    - ``y``'s index has a ``run`` or ``time_s`` level, ``X`` carries the same
      (``groups``; the ``time_s`` index level, as :func:`extract_runs`
      returns ``X``), and ``y``'s (run, time) labels are ``X``'s in another
      order;
    - or, without such levels, ``y``'s row labels are those of ``X`` (its
      index, or ``given_index``: the one ``X`` was given with) in another
      order.

    Other row labels than ``X``'s (a ``RangeIndex`` after a filter, times
    or runs changed in ``X`` only) pair by position, as in scikit-learn. A
    ``y`` of another length is left to scikit-learn.
    """
    import pandas as pd

    y_index = getattr(y, "index", None)
    n = getattr(X, "shape", (None,))[0]
    if not isinstance(y_index, pd.Index) or len(y_index) != n or n == 0:
        return
    if _same_index(y_index, X, given_index):
        return
    names, x_levels, y_levels = [], [], []
    if RUN_COLUMN in y_index.names and groups is not None:
        names.append(RUN_COLUMN)
        x_levels.append(np.asarray(groups))
        y_levels.append(y_index.get_level_values(RUN_COLUMN))
    times = row_times(X)
    if TIME_COLUMN in y_index.names and times is not None:
        names.append(TIME_COLUMN)
        x_levels.append(times)
        y_levels.append(
            _time_seconds(
                y_index.get_level_values(TIME_COLUMN),
                f"y's {TIME_COLUMN!r} index level",
            )
        )
    if names:
        x_rows = pd.MultiIndex.from_arrays(x_levels, names=names)
        y_rows = pd.MultiIndex.from_arrays(y_levels, names=names)
    else:
        x_rows = next(
            (
                idx
                for idx in (getattr(X, "index", None), given_index)
                if isinstance(idx, pd.Index)
                and idx.nlevels == y_index.nlevels
                and y_index.isin(idx).all()
            ),
            None,
        )
        y_rows = y_index
        if x_rows is None:
            return
    differ = np.asarray(x_rows != y_rows, dtype=bool)
    if not differ.any() or not (
        y_rows.isin(x_rows).all() and x_rows.isin(y_rows).all()
    ):
        return  # the same rows, or others: paired by position

    def at(rows, row):
        if not names:
            return f"labelled {_label(rows[row])!r}"
        values = rows[row] if isinstance(rows[row], tuple) else (rows[row],)
        return "at " + ", ".join(
            f"time_s={v:g}" if name == TIME_COLUMN else f"run {plain(v)!r}"
            for name, v in zip(names, values, strict=True)
        )

    row = int(np.flatnonzero(differ)[0])
    raise ValueError(
        f"y holds the rows of X in another order: row {row} of X is "
        f"{at(x_rows, row)}, but row {row} of y is {at(y_rows, row)} "
        f"({int(differ.sum())} of {n} rows differ). scikit-learn pairs X and y "
        "by position: reorder y to X's rows (e.g. y.loc[X.index] when both "
        "carry the same index)."
    )


def check_finite_target(y, X, groups, *, given_index=None):
    """Raise a ValueError naming the first missing, infinite or absurdly large
    (:func:`unreadable`) target value
    (row, its run and time from ``X`` and ``groups`` as returned by
    :func:`extract_runs`, and ``y``'s own row label when it has other ones
    than ``X``); first, a ``y`` whose row labels are not ``X``'s is an error
    (:func:`check_target_rows`). Non-numeric targets and a length that
    differs from ``X`` are left to scikit-learn."""
    check_target_rows(y, X, groups, given_index=given_index)
    try:
        values = np.asarray(y)
        if values.dtype.kind == "c":
            return  # scikit-learn names complex data
        _check_target_numbers(y, values, X, groups)
        values = values.astype(float, copy=False)
    except OverflowError:
        raise _too_large_error(y, "y", X, groups) from None
    except _TargetNotNumeric:
        raise
    except (TypeError, ValueError):
        return
    if (
        values.ndim == 0
        or values.size == 0
        or values.shape[0] != getattr(X, "shape", (None,))[0]
    ):
        return  # no rows, or a length mismatch: reported by validate_data
    flat = values.reshape(values.shape[0], -1)
    bad = unreadable(flat)
    if not bad.any():
        return
    row, col = (int(i) for i in np.argwhere(bad)[0])
    kind = describe_unreadable(flat[row, col])
    target = _target_name(y, col)
    note = _bad_values_note(bad, flat, "y")
    y_index = getattr(y, "index", None)
    if y_index is not None and not _same_index(y_index, X, given_index):
        # y's rows have labels of their own: name that too.
        note = f"y's row label {_label(y_index[row])!r}; {note}"
    raise ValueError(
        f"{target} is {kind} at {describe_row(row, X, groups)} ({note}). Drop the "
        "rows without a measured target value before fitting."
    )


def _target_name(y, column=0):
    """``"The target 'disp_y_um'"`` (its Series or column name) or ``"The
    target"``."""
    name = getattr(y, "name", None)
    if name is None and np.ndim(y) == 2 and hasattr(y, "columns"):
        name = y.columns[column]
    return "The target" if name is None else f"The target {plain(name)!r}"


class _TargetNotNumeric(ValueError):
    """A target that holds text or clock values (:func:`_check_target_numbers`)."""


def _check_target_numbers(y, values, X, groups):
    """Raise a ValueError naming a target of clock values, or its first
    value that is text and not a number (row, run, time), before
    scikit-learn's "could not convert string to float" names none."""
    import pandas as pd

    if values.dtype.kind in "mM":
        raise _TargetNotNumeric(
            f"{_target_name(y)} holds {values.dtype} values, not numbers: a "
            "target is a displacement (µm) or another measured number."
        )
    if values.dtype.kind not in "OUS" or values.size == 0:
        return
    flat = values.reshape(values.shape[0], -1)
    for col in range(flat.shape[1]):
        raw = pd.Series(flat[:, col])
        bad = pd.to_numeric(raw, errors="coerce").isna() & raw.notna()
        if not bad.any():
            continue
        row = int(np.flatnonzero(bad.to_numpy())[0])
        value = plain(raw.iloc[row])
        hint = ""
        if isinstance(value, str) and DECIMAL_COMMA.fullmatch(value):
            hint = ", a number with a decimal comma; write numbers with a decimal point"
        raise _TargetNotNumeric(
            f"{_target_name(y, col)} is not numeric: "
            f"{describe_row(row, X, groups)} holds {value!r}{hint}."
        )


def unreadable(values):
    """Boolean mask of the values that are no reading: missing (NaN),
    infinite, or of a magnitude beyond :data:`MAX_MAGNITUDE` (which the
    models' arithmetic would turn into inf or NaN)."""
    with np.errstate(invalid="ignore"):
        return ~(np.abs(np.asarray(values, dtype=float)) <= MAX_MAGNITUDE)


def describe_unreadable(value):
    """What an :func:`unreadable` value is, for messages: ``"missing
    (NaN)"``, ``"inf"``, or the value and the bound it exceeds."""
    value = float(value)
    if np.isnan(value):
        return "missing (NaN)"
    if np.isinf(value):
        return f"{value}"
    return (
        f"{value!r}, beyond the largest magnitude a reading may have "
        f"({MAX_MAGNITUDE:g})"
    )


def _bad_values_note(bad, values, name):
    """``"2 non-finite value(s) in X"``, ``"1 value(s) in X beyond 1e+100 in
    magnitude"``, or both: how many values of ``values`` (``name``) the mask
    ``bad`` marks, and what they are."""
    finite = np.isfinite(values[bad])
    n_large, n_other = int(finite.sum()), int((~finite).sum())
    large = f"beyond {MAX_MAGNITUDE:g} in magnitude"
    if not n_large:
        return f"{n_other} non-finite value(s) in {name}"
    if not n_other:
        return f"{n_large} value(s) in {name} {large}"
    return f"{n_other} non-finite value(s) in {name} and {n_large} {large}"


def check_finite_columns(X, groups=None, *, what="X", hint=None):
    """Raise a ValueError naming the first missing, infinite or absurdly large
    (:func:`unreadable`) value of the feature columns: the column, the row,
    and the run and time of that row when known. ``what`` names the table
    and ``hint`` says what to do (default: a model's advice).

    Missing and infinite values of a plain array are left to scikit-learn
    (its usual message); a finite value beyond :data:`MAX_MAGNITUDE` is an
    error here for a plain array too (column ``j`` by position). Sparse and
    non-numeric input is left to scikit-learn.
    """
    columns = getattr(X, "columns", None)
    if columns is not None:
        if X.shape[1] == 0:
            return
        # The columns are numeric (check_numeric_columns runs first).
        values = X.to_numpy(dtype=float, na_value=np.nan)
        bad = unreadable(values)
    else:
        values = _plain_values(X, groups)
        if values is None:
            return
        bad = np.isfinite(values) & unreadable(values)
    if not bad.any():
        return
    row, col = (int(i) for i in np.argwhere(bad)[0])
    name = repr(plain(columns[col])) if columns is not None else f"{col} of X"
    if hint is None:
        hint = (
            "The model needs every reading: impute or drop those rows first "
            "(skthermal.compose.GuardedRegressor(mode='hold') bridges sensor "
            "dropouts in service; it also holds the compensation while any "
            "reading is beyond its training range by more than span=0.25 of "
            "it, so widen span, or list the checked inputs, for service beyond "
            "the training conditions)."
        )
    raise ValueError(
        f"Column {name} is {describe_unreadable(values[row, col])} at "
        f"{describe_row(row, X, groups)} ({_bad_values_note(bad, values, what)}). "
        + hint
    )


def _plain_values(X, groups=None):
    """A plain 2-D array-like's values as floats, or None when it is not one
    (sparse, of another dimension, complex, not numeric): scikit-learn
    reports those."""
    import scipy.sparse

    if scipy.sparse.issparse(X):
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values = np.asarray(X)
            if values.dtype.kind not in "biufO":
                return None
            values = values.astype(float, copy=False)
    except OverflowError:
        if np.ndim(X) != 2:
            return None
        raise _too_large_error(X, "X", X, groups) from None
    except (TypeError, ValueError):
        return None
    return values if values.ndim == 2 else None


def _too_large_error(values, name, X, groups):
    """The ValueError for ``values`` (``name``: "X" or "y") holding a number
    too large for a float (``10**400``, which numpy refuses with a bare
    OverflowError), naming the first one: its column and row, with the run
    and time of the row when known."""
    raw = np.asarray(values, dtype=object)
    flat = raw.reshape(raw.shape[0], -1) if raw.ndim else raw.reshape(1, 1)
    for (row, col), v in np.ndenumerate(flat):
        try:
            float(v)
        except OverflowError:
            break
        except (TypeError, ValueError):
            continue
    else:  # pragma: no cover - the conversion overflowed somewhere
        return ValueError(
            f"{name} holds a number too large for a float (a float reaches "
            "about 1.8e308); give readings of a physical size."
        )
    text = shown(v)
    columns = getattr(values, "columns", None)
    label = f"{col}" if columns is None else repr(plain(columns[col]))
    if name == "X":
        what = f"Column {label} of X"
    else:
        what = "y" + (f" (column {label})" if flat.shape[1] > 1 else "")
    return ValueError(
        f"{what} holds {text} at {describe_row(row, X, groups)}: too large "
        "for a float (a float reaches about 1.8e308). Give readings of a "
        "physical size: a number this large is a corrupt value."
    )


def has_time_index(X):
    """Whether ``X`` carries times: a ``time_s`` index level (after
    :func:`extract_runs`, also what was a ``time_s`` column)."""
    names = getattr(getattr(X, "index", None), "names", None)
    return names is not None and TIME_COLUMN in names


def row_times(X):
    """The ``time_s`` index level of ``X`` as floats (seconds), or None when
    ``X`` carries no times.

    Raises
    ------
    ValueError
        If the level holds datetimes or durations (which would be read as
        integer ticks) or text, as for a ``time_s`` column
        (:func:`extract_runs`).
    """
    if not has_time_index(X):
        return None
    return _time_seconds(
        X.index.get_level_values(TIME_COLUMN), f"The {TIME_COLUMN!r} index level"
    )


def changes_since_start(X, slices, bases=None):
    """Subtract the first sample of each run from every sample of that run.

    Parameters
    ----------
    X : ndarray of shape (n_samples,) or (n_samples, n_features)
    slices : list of slice
        Runs as returned by :func:`run_slices`.
    bases : sequence, optional
        Per run, the start to subtract instead of its first sample (the
        first sample of a training run this run continues), or None.

    Returns
    -------
    ndarray of the same shape, zero on the first row of every run that has
    no base.
    """
    X = np.asarray(X, dtype=float)
    out = np.empty_like(X)
    for sl, base in zip(slices, bases or [None] * len(slices), strict=True):
        out[sl] = X[sl] - (X[sl.start] if base is None else base)
    return out


def check_time_order(X, groups, strict=True):
    """Check that a ``time_s`` index level increases strictly within each run
    (``strict=False``: never decreases, a record logged twice passes).

    Does nothing when ``X`` has no such index level (plain arrays carry no
    time; rows are then taken to be in time order).

    Raises
    ------
    ValueError
        Naming the run, the row and the two times.
    """
    t = row_times(X)
    if t is None:
        return
    _check_increasing(t, groups, _unread_run_names(X), strict)


# Names of run labels in another spelling: "Run", "run_id", "Run ID",
# "test_no", "Test" (compared in lower case).
_RUN_SPELLINGS = (
    r"(test[ _]?)?run([ _]?(id|no|nr|number|name|label))?"
    r"|test([ _]?(id|no|nr|number|name|label))?"
)
_TIME_SPELLINGS = r"time(_?s(ec(ond)?s?)?)?|t_?s|elapsed(_?s)?"


def _check_run_level(index):
    """Raise when an index level looks like the run table's ``run`` but is
    spelt otherwise (``Run``, ``run_id``) and no run labels are given
    otherwise: its labels would not be read, and the rows taken as one run,
    silently."""
    names = list(getattr(index, "names", None) or [])
    if RUN_COLUMN in names:
        return
    found = _run_like(names)
    if not found:
        return
    fixed = [RUN_COLUMN if n == found[0] else n for n in names]
    raise ValueError(
        f"X's index has the level {found[0]!r}: run labels are read only from a "
        f"level (or column) named exactly {RUN_COLUMN!r} (or from groups=), so the "
        "rows would be taken as one run. Rename it: X.index = "
        f"X.index.set_names({fixed!r})."
    )


def misnamed_time_level(X):
    """The first index level of ``X`` spelt like ``time_s`` but otherwise
    (``Time_s``, ``time``), holding numbers, or None: times a model that
    reads them does not find."""
    index = getattr(X, "index", None)
    names = list(getattr(index, "names", None) or [])
    if TIME_COLUMN in names:
        return None
    for n in names:
        if isinstance(n, str) and re.fullmatch(_TIME_SPELLINGS, n.lower()):
            if index.get_level_values(n).dtype.kind in "iuf":
                return n
    return None


def warn_misnamed_time(name, X, period, stacklevel=4):
    """Warn in ``predict`` when ``X`` has no ``time_s`` but an index level
    spelt like it (:func:`misnamed_time_level`): the model takes its rows
    ``period`` s apart (its training period), so a gap in them is one
    step."""
    level = misnamed_time_level(X)
    if level is None or has_time_index(X):
        return
    warnings.warn(
        f"{name}: X has no time_s; its index level {level!r} is not read as "
        f"the times, so the rows are taken {period:g} s apart (the training "
        "period) and a gap in them as one step. If it holds seconds since each "
        "run's start, name it 'time_s'.",
        UserWarning,
        stacklevel=stacklevel,
    )


def _unread_run_names(X):
    """Index levels and columns of ``X`` named ``run`` in another case or
    spelling (``Run``, ``RUN``, ``run_id``): run labels that are not read."""
    names = list(getattr(getattr(X, "index", None), "names", None) or [])
    return _run_like(names + list(getattr(X, "columns", [])))


def _run_like(names):
    """The ``names`` that spell ``run`` otherwise (:data:`_RUN_SPELLINGS`)."""
    return [
        n
        for n in names
        if isinstance(n, str)
        and n != RUN_COLUMN
        and re.fullmatch(_RUN_SPELLINGS, n.lower())
    ]


def check_table_times(frame, groups):
    """Check a run table's ``time_s`` column, when it has one: seconds (not
    clock times or text), increasing strictly within each run (``groups``:
    its run labels, :func:`frame_run_labels`).

    Raises
    ------
    ValueError
        Naming the column, or the run, the row and the two times.
    """
    if TIME_COLUMN not in frame.columns:
        return
    t = _time_seconds(frame[TIME_COLUMN], f"The {TIME_COLUMN!r} column")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(
            f"The {TIME_COLUMN!r} column is missing or infinite at "
            f"{describe_row(int(bad[0]), frame, groups)}."
        )
    _check_increasing(t, groups)


def _check_increasing(t, groups, unread=(), strict=True):
    slices, labels = run_slices(groups, t.shape[0])
    for sl, lab in zip(slices, labels, strict=True):
        step = np.diff(t[sl])
        bad = np.flatnonzero(step <= 0 if strict else step < 0)
        if bad.size:
            row = sl.start + int(bad[0]) + 1
            where = "" if lab is None else f" in run {lab!r}"
            hint = ""
            if groups is None:
                hint = (
                    " No run labels were found (a 'run' column or index level, "
                    "or groups), so all rows are one run"
                    + (
                        f"; {shown(unread[0])} is not read as them: name it 'run'"
                        if unread
                        else ""
                    )
                    + "."
                )
            must = "increase strictly" if strict else "not go back"
            raise ValueError(
                f"time_s must {must} within a run, but{where} row {row} "
                f"has time_s={t[row]:g} after {t[row - 1]:g}.{hint}"
            )


def run_sample_periods(
    X, groups, slices, default, *, labels=None, regular=None, rtol=0.01
):
    """Sampling period of every run: the median spacing of its times.

    Parameters
    ----------
    X : array-like or DataFrame
        Rows; times come from a ``time_s`` index level (checked to increase
        within each run).
    groups, slices
        Run labels of the rows, and the runs' slices (:func:`run_slices`).
    default : float
        Period of runs without times (a run of one row, or ``X`` without a
        ``time_s`` level).
    labels : list, optional
        The runs' labels, for the error message.
    regular : str, optional
        The method that needs a constant period within each run: a run whose
        steps differ from its median by more than ``rtol`` is then an error
        naming the run and the method.

    Returns
    -------
    ndarray of shape (n_runs,)
    """
    t = row_times(X)
    if t is None:
        return np.full(len(slices), float(default))
    check_time_order(X, groups)
    periods = _median_periods(t, slices)
    if regular is not None:
        labels = [None] * len(slices) if labels is None else labels
        for sl, lab, step in zip(slices, labels, periods, strict=True):
            steps = np.diff(t[sl])
            if steps.size and np.max(np.abs(steps - step)) > rtol * step:
                where = "the run" if lab is None else f"run {lab!r}"
                raise ValueError(
                    f"{regular} needs a constant sampling interval within each "
                    f"run, but the time_s steps of {where} range from "
                    f"{steps.min():g} to {steps.max():g}"
                    + _hole_hint(t[sl], steps, step, rtol)
                )
    return np.where(np.isfinite(periods), periods, float(default))


def _hole_hint(t, steps, step, rtol):
    """The end of the irregular-sampling error: rows missing from the middle
    of a regularly sampled run (a block held out of it, e.g. by a
    cross-validation splitter over rows) are named as such; other jitter
    gets the general remedy."""
    long = steps > (1 + rtol) * step
    regular = np.abs(steps[~long] - step) <= rtol * step
    # A few gaps of several periods in a regular run are rows missing (a
    # period that changes, a single dropped sample are not).
    few = long.sum() <= max(1, 0.05 * steps.size)
    if (steps[long] > 2.5 * step).all() and long.any() and few and regular.all():
        k = int(np.flatnonzero(long)[0])
        return (
            f": {int(long.sum())} gap(s) in a run otherwise sampled every "
            f"{step:g} s, the first from time_s={t[k]:g} to {t[k + 1]:g}. "
            "Rows are missing from the middle of the run: a block held out of "
            "it (a cross-validation splitter over rows, such as KFold, does "
            "this) or a logging pause. Give the parts on either side of a gap "
            "their own run labels, or split over whole runs (GroupKFold with "
            "groups=runs); or resample the run."
        )
    if np.all(np.abs(steps - step) <= 0.1 * step):
        return (
            f"; a clock jitter of up to {np.max(np.abs(steps / step - 1)):.0%}: "
            f"pass dt={step:g} to take the steps as equal, or resample the run "
            "onto a regular time grid"
        )
    return (
        "; resample the run onto a regular time grid (dt=... takes every step "
        "as dt, gaps and changes of the period too)"
    )


def warn_dt_against_times(name, X, slices, labels, dt, rtol=0.1, overrides=True):
    """Warn, naming the run, when a model given ``dt`` fits rows whose
    ``time_s`` steps differ from it by more than ``rtol``. With
    ``overrides`` the model takes every step as ``dt``, so a gap, a change
    of the logging period or times in another unit go through as regular
    steps; else it reads the times and leaves ``dt`` unused (times in
    minutes then go through as seconds)."""
    t = row_times(X)
    if t is None or not len(slices):
        return
    steps, run, _, _ = within_run_steps(t, slices, medians=False)
    off = np.abs(steps - dt) > rtol * dt
    if not off.any():
        return
    k = int(np.flatnonzero(off)[0])
    lab = labels[run[k]] if labels is not None else None
    where = "a run" if lab is None else f"run {lab!r}"
    mine = steps[run == run[k]]
    effect = (
        "the model takes every step as dt, so gaps, a change of the logging "
        "period or times in another unit go through as regular steps. Resample "
        "the runs onto a grid of dt, or leave dt=None to read the times."
        if overrides
        else "the model reads the times and does not use dt (it is for rows "
        "without times): is time_s in seconds?"
    )
    warnings.warn(
        f"{name}: dt={dt:g} is given, but the time_s steps of {where} range "
        f"from {mine.min():g} to {mine.max():g} s ({int(off.sum())} step(s) "
        f"more than {rtol:.0%} off dt in all the runs): {effect}",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def fitted_sample_periods(X, groups, slices, dt, name, **kwargs):
    """Sampling period of every run in ``fit``, and the model's period.

    With times, a run's period is the median step of its times
    (:func:`run_sample_periods`, which takes ``labels``, ``regular`` and
    ``rtol`` from ``kwargs``) and the model's period is the median of those
    of the runs of two rows or more. A run of one row has no step to
    measure: it takes the model's period (that of the other runs) and does
    not pull it. Without times, ``dt`` (one second when None) for every run.

    Parameters
    ----------
    X, groups, slices
        As for :func:`run_sample_periods`.
    dt : float or None
        The estimator's ``dt``: the period without times, or when no run
        has two rows.
    name : str
        The estimator's class name, for the error.

    Returns
    -------
    dts : ndarray of shape (n_runs,)
    period : float

    Raises
    ------
    ValueError
        If ``X`` has times, no run has two rows (so the times tell no
        period) and ``dt`` is None.
    """
    dts = run_sample_periods(X, groups, slices, np.nan, **kwargs)
    measured = np.isfinite(dts)
    if measured.any():
        period = float(np.median(dts[measured]))
    elif dt is not None or not has_time_index(X):
        period = 1.0 if dt is None else float(dt)
    else:
        raise ValueError(
            f"{name}: no run has two rows, so time_s tells no sampling period "
            f"({len(slices)} run(s) of one row). Pass dt=<sampling period in "
            "s>, or runs of at least two rows."
        )
    dts[~measured] = period
    return dts, period


def check_run_lengths(slices, labels, what, min_samples=2):
    """Raise a ValueError naming the first run shorter than ``min_samples``.

    ``what`` names the method that needs the samples, e.g. ``"GM(1,N)"``.
    """
    for sl, lab in zip(slices, labels, strict=True):
        n = sl.stop - sl.start
        if n < min_samples:
            run = "A run" if lab is None else f"Run {lab!r}"
            got = f"{n} sample" + ("" if n == 1 else "s")
            raise ValueError(
                f"{run} has only {got} (rows {sl.start}-{sl.stop - 1}); {what} "
                f"needs at least {min_samples} samples per run."
            )


# The warnings of warn_unlabelled_runs, for a model that says it once for
# its inner models (warnings.filterwarnings(message=...)).
UNLABELLED_WARNING = (
    r".*(was fitted on \d+ labelled run|got \d+ rows that carry no run)"
)


def warn_unlabelled_runs(
    name, n_fitted_runs, groups, n_samples, *, X=None, stacklevel=3
):
    """Warn when a sequence model gets rows without run labels.

    A sequence model (its prediction for a row depends on the earlier rows of
    the run) fitted on a ``split_runs`` DataFrame knows where each run starts;
    given the same rows as a plain array it would treat them all as one run
    starting at the first row, and predict something different without a word.
    The same happens in ``fit`` when a scikit-learn step in front of the model
    outputs numpy: the run index is gone and all training runs become one.

    Parameters
    ----------
    name : str
        The estimator's class name, for the message.
    n_fitted_runs : int or None
        In ``predict``: the number of labelled runs seen in ``fit``; ``None``
        when ``fit`` got no run labels (then nothing is checked). None in
        ``fit``.
    groups : array-like or None
        The run labels found for the rows.
    n_samples : int
        Number of rows.
    X : array-like or DataFrame, optional
        In ``fit``: the rows as :func:`extract_runs` returns them. A warning
        then says that rows of two or more with neither run labels nor
        ``time_s`` (a plain array) are taken as one run. Rows with a
        ``time_s`` but no run labels are one run (several runs would restart
        their times, an error).
    stacklevel : int or None, default=3
        Of the warning: 3 points at the caller of the method that calls this
        function; None, at the first frame outside skthermal and
        scikit-learn (the user's line, however deep the call).
    """
    if stacklevel is None:
        stacklevel = user_stacklevel()
    if groups is not None:
        return
    if X is not None:
        if n_samples < 2 or has_time_index(X):
            return
        head = (
            f"{name}.fit got {n_samples} rows that carry no run labels (and no time_s)"
        )
        one = (
            " Rows that are one run: pass them with their time_s (a run table), "
            "or their run label as groups."
        )
        loaded = ""
    elif n_fitted_runs is None:
        return
    else:
        head = (
            f"{name} was fitted on {n_fitted_runs} labelled run(s), but the "
            f"{n_samples} rows given now carry no run labels"
        )
        one = ""
        loaded = (
            " In a pipeline fitted under sklearn.set_config(transform_output="
            "'pandas'), which is not saved with it, call "
            "pipeline.set_output(transform='pandas') after loading (and before "
            "saving)."
        )
    warnings.warn(
        f"{head}, so they are taken as ONE run that starts at the first row. "
        "Pass the run labels: groups=..., a 'run' column, or the (run, time_s) "
        "index that skthermal.datasets.split_runs makes; a scikit-learn step "
        "in front of the model must keep that index: "
        f"set_output(transform='pandas').{one}{loaded}",
        UserWarning,
        stacklevel=stacklevel,
    )


def warn_no_time(name, X, dt, time_constants=None):
    """Warn that ``X`` has no times and no ``dt`` was given: the time
    constants (seconds; None: the model's own, identified) are then counted
    in rows. Call from a ``fit`` wrapped by scikit-learn's ``_fit_context``
    (the warning points at the user's call)."""
    if dt is not None or has_time_index(X):
        return
    if time_constants is not None and len(time_constants) == 0:
        return
    counted = (
        "its time constants are counted in rows"
        if time_constants is None
        else "the time constants "
        f"({', '.join(f'{t:g}' for t in time_constants)} s) as that many rows"
    )
    level = misnamed_time_level(X)
    hint = (
        f" X's index level {level!r} is not read as the times: if it holds "
        "seconds since each run's start, name it 'time_s'."
        if level is not None
        else ""
    )
    warnings.warn(
        f"{name}: X has no time_s (no time_s column or index level) and no "
        f"dt was given, so rows are taken as 1 s apart and {counted}. Pass "
        "dt=<sample period in s>, or a run table with its time_s "
        "column (or the (run, time_s) index of skthermal.datasets.split_runs)." + hint,
        UserWarning,
        stacklevel=4,
    )


# A step longer than this many times its run's median step is a gap.
GAP_STEPS = 1.5


# The shortest longest run of a thermal test, in seconds: machine tools take
# hours to warm up, so runs that all last less suggest ``time_s`` was given in
# hours or minutes.
THERMAL_SPAN_S = 600.0


def warn_short_runs(who, spans, stacklevel=3):
    """Warn when every run spans less than :data:`THERMAL_SPAN_S` seconds:
    ``spans`` maps run labels (None: the rows without one) to the span of
    their ``time_s``."""
    if not spans:
        return
    label, longest = max(spans.items(), key=lambda item: item[1])
    if longest >= THERMAL_SPAN_S:
        return
    name = "unlabelled" if label is None else repr(label)
    warnings.warn(
        f"{who}: the longest run ({name}) lasts {longest:g} s of time_s. "
        "Thermal drift builds up over hours: runs this short do not determine "
        "a thermal model (fitted on them, it extrapolates on longer runs), or "
        "time_s is not in seconds (a run logged in hours or minutes reads as "
        "a few seconds).",
        UserWarning,
        stacklevel=stacklevel,
    )


def gap_steps(steps):
    """Which of a run's time steps are gaps (missing samples): longer than
    ``GAP_STEPS`` times the run's median step."""
    steps = np.asarray(steps, dtype=float)
    return steps > GAP_STEPS * np.median(steps)


def warn_gaps(name, X, slices, labels, bridged, stacklevel=4):
    """Warn about gaps in the runs' times: steps longer than ``GAP_STEPS``
    times the run's median step (missing samples). ``bridged`` says what
    the model does across them, e.g. ``"takes the inputs to change
    linearly across them"``. Names the run with the longest gap."""
    t = row_times(X)
    if t is None:
        return
    steps, run, first, medians = within_run_steps(t, slices)
    n_steps = np.bincount(run, minlength=len(slices))
    # A gap is longer than GAP_STEPS times its run's median step
    # (gap_steps), in runs of at least two steps.
    long = (steps > GAP_STEPS * medians[run]) & (n_steps[run] >= 2)
    if not long.any():
        return
    count = int(long.sum())
    # The longest gap; of equal ones, the first run's (in the runs' order).
    candidates = np.flatnonzero(long)
    size = steps[candidates].max()
    at = candidates[steps[candidates] == size]
    k = at[np.argmin(run[at])]
    lab, period = labels[run[k]], float(medians[run[k]])
    size, t0, t1 = float(size), t[first[k]], t[first[k] + 1]
    where = "" if lab is None else f" (run {lab!r})"
    warnings.warn(
        f"{name}: {count} gap(s) in time_s, steps longer than {GAP_STEPS:g} "
        f"sampling periods; the longest{where} lasts {size:g} s, from "
        f"time_s={t0:g} to {t1:g}, at a sampling period of {period:g} s. The "
        f"model {bridged}; what happened inside a gap (a spindle start, a "
        "door opened) is not seen.",
        UserWarning,
        stacklevel=stacklevel,
    )


# What a model that counts rows (a grey model's accumulation, a network of
# lagged samples) does across a gap in the times (for the warnings).
ROWS_BRIDGE = (
    "counts rows, not seconds, so it reads each gap as one sampling period; "
    "resample the runs onto a regular time grid first"
)
# What a model that filters in seconds (lag features, transfer functions)
# does across a gap in the times, and across a pause before a continued run.
GAP_BRIDGE = (
    "filters across them exactly, taking the inputs to change linearly over each gap"
)
PAUSE_BRIDGE = (
    "filters across the pause exactly, taking the inputs to change linearly "
    "over it, so what happened in it (a spindle start, a door opened) is not "
    "seen; give the rows of the pause too"
)
# Relative difference of sampling periods a model that counts rows lets
# pass between its training runs and the runs it predicts.
PERIOD_RTOL = 0.1


def warn_pauses(name, X, slices, cont, memory, bridged, stacklevel=5):
    """Warn about a predicted run that continues a training run (``cont``
    from :func:`continued_runs`, ``memory`` from :func:`run_memory`) more
    than ``GAP_STEPS`` sampling periods after its last training row: a gap
    between ``fit`` and ``predict``, which the model ``bridged``."""
    t = row_times(X)
    if cont is None or t is None:
        return
    pauses = continued_steps(np.zeros(len(slices)), slices, t, cont, memory)
    for lab, pause in zip(cont, pauses, strict=True):
        if lab is None:
            continue
        t1 = memory[lab]["t_last"]
        period = memory[lab].get("recent_period", memory_period(memory[lab]))
        if not np.isfinite(period):
            continue
        if pause > GAP_STEPS * period:
            warnings.warn(
                f"{name}: run {lab!r} continues {pause:g} s after its last "
                f"row the model knows (time_s={t1:g}; from fit, or remembered "
                f"from an earlier block), at a sampling period of "
                f"{period:g} s. The model {bridged}, or predict the run "
                "from its start.",
                UserWarning,
                stacklevel=stacklevel,
            )


def within_run_steps(t, slices, *, medians=True):
    """Every run's time steps at once: ``(steps, run, first, medians)``, the
    steps within runs (in row order), the run (index into ``slices``) of
    each, the row before each step, and every run's median step (NaN for a
    run of one row; None with ``medians=False``). ``slices`` tile the rows.
    One pass for all runs: with many short runs a loop per run was the cost."""
    n = t.shape[0]
    starts = np.array([sl.start for sl in slices], dtype=int)
    lengths = np.array([sl.stop - sl.start for sl in slices], dtype=int)
    order = np.argsort(starts, kind="stable")
    run_of_row = np.repeat(order, lengths[order])  # the runs tile the rows
    inner = run_of_row[:-1] == run_of_row[1:] if n > 1 else np.zeros(0, bool)
    first = np.flatnonzero(inner)
    steps = t[first + 1] - t[first]
    run = run_of_row[first]
    if not medians:
        return steps, run, first, None
    count = np.bincount(run, minlength=len(slices))
    middle = np.full(len(slices), np.nan)
    if steps.size:
        sort = np.lexsort((steps, run))
        ordered = steps[sort]
        offset = np.r_[0, np.cumsum(count)[:-1]]
        has = count > 0
        lo = offset[has] + (count[has] - 1) // 2
        hi = offset[has] + count[has] // 2
        middle[has] = (ordered[lo] + ordered[hi]) / 2
    return steps, run, first, middle


def _median_periods(t, slices):
    """Median time step of every run of at least two rows (NaN otherwise)."""
    return within_run_steps(t, slices)[3]


def _worst_run(score, labels, limit):
    """``(index, name for messages)`` of the run with the largest ``score``
    (non-finite scores count as 0), or None when none exceeds ``limit``."""
    score = np.where(np.isfinite(score), score, 0.0)
    off = int((score > limit).sum())
    if not off:
        return None
    r = int(np.argmax(score))
    where = "the unlabelled run" if labels[r] is None else f"run {labels[r]!r}"
    if off > 1:
        where += f" (and {off - 1} more run{'s' if off > 2 else ''} alike)"
    return r, where


def _period_of_most_rows(periods, steps):
    """The median of the runs' sampling ``periods`` weighted by their numbers
    of time ``steps``: the period most rows have (NaN when no run tells
    one). ``fit`` and ``predict`` of a model that counts rows compare runs
    with it alike (``predict`` compared with the median over the training
    runs, which named another period than ``fit`` for the same runs)."""
    periods = np.asarray(periods, dtype=float)
    steps = np.asarray(steps, dtype=float)
    ok = np.isfinite(periods) & (steps > 0)
    if not ok.any():
        return np.nan
    order = np.argsort(periods[ok])
    cum = np.cumsum(steps[ok][order])
    return float(periods[ok][order][np.searchsorted(cum, 0.5 * cum[-1])])


def warn_row_periods(name, X, slices, labels, memory=None, stacklevel=5):
    """Warn when runs are sampled at different periods, for a model that
    counts rows (its dynamics are per sample, so a run logged every 60 s
    is read as four times slower than one logged every 15 s).

    In ``fit`` (``memory`` None) the runs are compared with the period of
    most of their rows; in ``predict`` with the training runs' periods (from
    ``memory``, the :func:`run_memory` of the training runs; nothing to
    compare without labelled training runs). Names the run that differs
    most.
    """
    t = row_times(X)
    if t is None:
        return
    periods = _median_periods(t, slices)
    if memory is None:
        steps = [sl.stop - sl.start - 1 for sl in slices]
        ref = _period_of_most_rows(periods, steps)
        against = "the period of most of the runs' rows"
    else:
        ref = _period_of_most_rows(
            [memory_period(m) for m in memory.values()],
            [m["n"] - 1 for m in memory.values()],
        )
        against = "the period of most of the training runs' rows"
    if not (np.isfinite(ref) and ref > 0):
        return
    worst = _worst_run(np.abs(periods / ref - 1.0), labels, PERIOD_RTOL)
    if worst is None:
        return
    r, where = worst
    warnings.warn(
        f"{name}: {where} is sampled every {periods[r]:g} s, {against} is "
        f"{ref:g} s. The model counts rows, not seconds, so its dynamics "
        f"run {max(ref / periods[r], periods[r] / ref):.3g} times too "
        f"{'slow' if periods[r] > ref else 'fast'} on that run; resample "
        f"the runs onto one time grid ({ref:g} s) first.",
        UserWarning,
        stacklevel=stacklevel,
    )


# A run sampled this many times more slowly than the training runs is taken
# for a unit slip of its time_s (milliseconds read as seconds).
SLOW_PERIOD_FACTOR = 20.0


def warn_slow_periods(name, X, slices, labels, period, stacklevel=5):
    """Warn, naming the run, when a run given to a model whose time
    constants are in seconds is sampled over :data:`SLOW_PERIOD_FACTOR`
    times more slowly than its training runs (``period``, s): most likely
    ``time_s`` logged in milliseconds, which the filters read as a thousand
    times slower dynamics; or as many times faster and faster than one
    sample a second: minutes or hours (a faster run is filtered as given,
    every row's step used; a controller logging every second is no unit
    slip)."""
    t = row_times(X)
    if t is None or period is None or not (np.isfinite(period) and period > 0):
        return
    ratio = _median_periods(t, slices) / period
    worst = _worst_run(ratio, labels, SLOW_PERIOD_FACTOR)
    if worst is None:
        # Faster than a second and 20 times the training runs: minutes or
        # hours (a controller logging every second is fine).
        sub_second = np.where(ratio * period < 1.0, 1.0 / ratio, 0.0)
        fast = _worst_run(sub_second, labels, SLOW_PERIOD_FACTOR)
        if fast is not None:
            r, where = fast
            warnings.warn(
                f"{name}: {where} is sampled every {ratio[r] * period:g} s, the "
                f"training runs every {period:g} s ({1 / ratio[r]:.3g} times "
                "faster). The time constants are in seconds: is its time_s in "
                "minutes or hours? A run really sampled this fast is filtered "
                "as given.",
                UserWarning,
                stacklevel=stacklevel,
            )
        return
    r, where = worst
    warnings.warn(
        f"{name}: {where} is sampled every {ratio[r] * period:g} s, the "
        f"training runs every {period:g} s ({ratio[r]:.3g} times more "
        "slowly). The time constants are in seconds: is its time_s in "
        "seconds (not milliseconds)? A run really sampled this slowly is "
        "filtered as given.",
        UserWarning,
        stacklevel=stacklevel,
    )


def warn_row_gaps(name, X, slices, labels, cont=None, memory=None, stacklevel=5):
    """Warnings of a model that counts rows: gaps inside the runs
    (:func:`warn_gaps`), runs sampled at another period than the others
    (in ``fit``) or than the training runs (in ``predict``, with
    ``memory``; :func:`warn_row_periods`), and, in ``predict``, a run that
    continues a training run (``cont`` from :func:`continued_runs`) later
    than one sampling period after its last training row
    (:func:`warn_pauses`)."""
    warn_gaps(name, X, slices, labels, ROWS_BRIDGE, stacklevel=stacklevel)
    warn_row_periods(name, X, slices, labels, memory, stacklevel=stacklevel)
    warn_pauses(name, X, slices, cont, memory, ROWS_BRIDGE, stacklevel=stacklevel)


def continued_values(cont, memory, key):
    """Per predicted run, ``memory[label][key]`` of the training run it
    continues (``cont`` from :func:`continued_runs`), or None."""
    return [None if lab is None else memory[lab][key] for lab in cont]


def gap_periods(dts, cont, fitted, memory=None):
    """The period against which each predicted run's steps are gaps: for a
    run that continues a remembered one (a block of a few rows cannot tell
    it), that run's remembered period (``memory``: a training run's median
    step, a streamed run's latest steps), else the fitted sampling period;
    for any other run its own period ``dts``. So a run logged more slowly
    than the training runs is filtered alike whole and block by block."""
    periods = np.array(dts, dtype=float)
    for r, lab in enumerate(cont):
        if lab is None:
            continue
        own = np.nan if memory is None else memory_period(memory[lab])
        periods[r] = own if np.isfinite(own) else fitted
    return periods


def continued_steps(dts, slices, times, cont, memory):
    """The step before each predicted run's first row: the run's sampling
    period (``dts``), or for a run that continues a training run (``cont``
    from :func:`continued_runs`) the time since that run's last training
    row, however long ago that was. Without ``times``, ``dts`` as given."""
    dts = np.array(dts, dtype=float)
    if times is None:
        return dts
    lasts = continued_values(cont, memory, "t_last")
    for r, (sl, last) in enumerate(zip(slices, lasts, strict=True)):
        if last is not None and np.isfinite(last):
            dts[r] = times[sl.start] - last
    return dts


def driver_positions(drivers, names, n_features):
    """Positions of the driver columns, sorted.

    ``drivers``: None (none), ``"auto"`` (the run table's
    :data:`POWER_DRIVERS` among ``names``), or names and positions, each of
    which must be a column of ``X`` (a ValueError names the one that is
    not).
    """
    if drivers is None:
        return np.zeros(0, dtype=int)
    if isinstance(drivers, str):  # "auto"
        found = (
            []
            if names is None
            else [i for i, c in enumerate(names) if str(c) in POWER_DRIVERS]
        )
        return np.array(found, dtype=int)
    names = None if names is None else [str(c) for c in names]
    out = []
    for d in drivers:
        if isinstance(d, Integral | np.integer) and 0 <= int(d) < n_features:
            out.append(int(d))
        elif names is not None and str(d) in names:
            out.append(names.index(str(d)))
        elif names is None and isinstance(d, str):
            raise ValueError(
                f"drivers: {d!r} is a column name, but X has no column names "
                f"({n_features} unnamed feature(s), e.g. a numpy array or a "
                "step that outputs numpy): pass a DataFrame or a column position."
            )
        else:
            known = "" if names is None else f"; columns: {names}"
            raise ValueError(
                f"drivers: {d!r} is not a column of X ({n_features} feature(s){known})."
            )
    return np.array(sorted(set(out)), dtype=int)


def _run_starts(Y, slices):
    """The target ``Y`` (2-D) at every run's first row, and its changes since
    that row, all runs' rows stacked."""
    first = np.array([Y[sl.start] for sl in slices])
    return first, np.concatenate([Y[sl] - Y[sl.start] for sl in slices])


# The target's root mean square at the runs' first rows, against its
# changes within them, beyond which a model of changes since the run start
# is warned about being scored on the target as given: beyond it, the
# offset is most of what a score measures.
_START_OFFSET = 1.0


def warn_absolute_target(name, y, slices):
    """Warn when a model that predicts the change of the target since each
    run's start is fitted on a target far from zero at the runs' starts
    (beyond its changes within them, root mean squares): its predictions are
    then compared with ``y`` as given by ``score`` and by scorers, which
    measure that offset more than the model's error (an independent check:
    offsets 1.8 times the changes, below the ten times warned about before,
    scored a grey model at 9.6 times linear regression's error)."""
    Y = np.asarray(y, dtype=float).reshape(len(y), -1)
    if not slices or not np.all(np.isfinite(Y)):
        return
    first, change = _run_starts(Y, slices)
    offset = float(np.sqrt(np.mean(first**2)))
    spread = float(np.sqrt(np.mean(change**2)))
    if offset <= _START_OFFSET * max(spread, 1e-12):
        return
    warnings.warn(
        f"{name} predicts the change of the target since each run's start "
        f"(0 at its first row), and y is far from 0 there (root mean square "
        f"{offset:.4g} at the runs' first rows, against changes of {spread:.4g} "
        "within them): score(X, y) and scorers compare the predictions with y "
        "as given and measure that offset. Fit and score on the changes "
        "(skthermal.datasets.changes_since_start) to compare like with like.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


# How far a run's first target value may lie from the runs' median first
# value before a model that starts every run at rest is warned about it: a
# share of the target's changes within the runs (root mean square), and a
# multiple of its noise (from the second differences within the runs),
# whichever is larger.
_START_SHARE = 0.25
_START_NOISES = 5.0


def warn_start_offsets(name, y, slices, names=None, labels=None):
    """Warn when a model that starts every run at rest (its prediction at the
    first row the same for all runs) is fitted on a target whose first rows
    differ between runs beyond its noise and :data:`_START_SHARE` of its
    changes within the runs: runs that start warm, or a probe zeroed anew
    for some runs. The model cannot predict those offsets, and its slow lags
    take them up as gains (an independent check: 37-61 µm held out where
    the same model fitted on the changes since each run's start erred by
    3-6). One run off is enough; first rows that differ by the probe's noise
    alone are not (fitted on changes, that noise becomes an offset of every
    row). ``names``: the target columns' names, ``labels``: the runs'."""
    Y = np.asarray(y, dtype=float).reshape(len(y), -1)
    if len(slices) < 2 or not np.all(np.isfinite(Y)):
        return
    first, change = _run_starts(Y, slices)
    within = np.sqrt(np.mean(change**2, axis=0))
    # The noise of one reading, from the second differences within the runs
    # (the median step read zero on quantised readings, most of whose steps
    # are exactly zero, and a first row one quantum off then warned).
    noise = pooled_noise([Y[sl] for sl in slices])
    off = np.abs(first - np.median(first, axis=0))
    limit = np.maximum(_START_SHARE * within, _START_NOISES * noise)
    excess = off / np.maximum(limit, 1e-12)
    r, k = np.unravel_index(int(np.argmax(excess)), excess.shape)
    if excess[r, k] <= 1.0:
        return
    runs = int(np.sum(excess[:, k] > 1.0))
    run = (
        f"run {labels[r]!r}"
        if labels is not None and labels[r] is not None
        else f"run {r}"
    )
    more = (
        f" (and {runs - 1} more run{'s' if runs > 2 else ''} alike)" if runs > 1 else ""
    )
    column = f"y ({names[k]!r})" if names is not None else "y"
    warnings.warn(
        f"{name} starts every run at rest (the same prediction at every run's "
        f"first row), and {column} starts {run}{more} at {first[r, k]:.4g}, "
        f"the runs' median first value being {np.median(first[:, k]):.4g}: "
        f"{off[r, k]:.3g} off, against changes of {within[k]:.3g} within the runs "
        f"and a noise of {noise[k]:.2g}. A run that starts warm, or a target "
        "zeroed anew: the fit takes the offsets up as gains. Fit on the change "
        "since each run's start (skthermal.datasets.changes_since_start), or use "
        "a model of the readings (make_lag_pipeline(relative=False)).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def warn_centred_drivers(name, X, indices, names):
    """Warn when a driver whose magnitude a model takes as heat (a speed,
    a feed) is standardised: a mean of 0 and a standard deviation of 1 over
    the training rows, what a ``StandardScaler`` in front of the model makes
    of it. A
    stopped spindle then reads a negative number whose magnitude counts as
    more heat than a slow one (-1.1 against 0.12 for 2000 rpm), and the
    errors grow several times, silently. ``X`` is the validated array,
    ``indices`` the driver columns, ``names`` the feature names or None."""
    for j in np.asarray(indices, dtype=int):
        u = X[:, j]
        u = u[np.isfinite(u)]
        if u.size < 2:
            continue
        spread = float(np.std(u))
        # A mean of 0 and a spread of 1 to rounding: standardised (a feed
        # moving back and forth in mm/min may average 0, not with unit spread).
        standard = abs(spread - 1.0) <= 1e-6 and abs(float(np.mean(u))) <= 1e-6
        if standard and u.min() < 0:
            label = f"column {j}" if names is None else repr(str(names[j]))
            warnings.warn(
                f"{name}.fit: the driver {label} has a mean of 0 over the "
                f"training rows and negative values (down to {u.min():.3g}): "
                "centred by a scaler in front of the model? Its magnitude is "
                "taken as heat, so a stop would count as more heat than a slow "
                "speed. Give the drivers as logged: scale after the lag "
                "features (make_lag_pipeline does), or keep the drivers out of "
                "the scaler (a ColumnTransformer).",
                UserWarning,
                stacklevel=user_stacklevel(),
            )


def warn_unnamed_drivers(name, drivers, names, groups):
    """Warn when ``drivers="auto"`` finds no driver: ``X``'s column
    ``names`` hold none (the sensor columns alone, as ``split_runs`` gives
    them), or ``X`` has lost its column names and its run labels (``names``
    and ``groups`` None: a scikit-learn step in front that outputs numpy),
    so that every column is taken as a temperature. Plain arrays given with
    their run labels are taken as meant. With ``drivers=None``, a column
    named as a driver is named: it is taken as a temperature."""
    if drivers is None and names is not None:
        found = [str(c) for c in names if str(c) in POWER_DRIVERS]
        if found:
            warnings.warn(
                f"{name}.fit: drivers=None takes every column as a temperature, "
                f"{found} too: their changes and filters enter as a "
                "temperature's, not as heat. Give them as drivers "
                "(drivers='auto'), or leave them out of X.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        return
    if not isinstance(drivers, str):
        return
    if names is not None:
        if not any(str(c) in POWER_DRIVERS for c in names):
            hint = driver_lookalike_hint([str(c) for c in names], POWER_DRIVERS)
            alike = [str(c) for c in names if driver_lookalike(str(c)) in POWER_DRIVERS]
            # A driver under another name is not left out: it goes in as a
            # temperature ("temperatures only" read as if it were dropped).
            held = (
                f"every column is taken as a temperature, {alike} too (their "
                "changes and filters enter as a temperature's, not as heat)"
                if alike
                else "the features hold temperatures only, no heat input"
            )
            warnings.warn(
                f"{name}.fit: drivers='auto' found none of the drivers "
                f"({', '.join(POWER_DRIVERS)}) among the columns of X{hint}, so "
                f"{held}. split_runs "
                "keeps the sensor columns alone unless told: "
                "split_runs(runs, sensors=[*sensor_columns(runs), "
                "*driver_columns(runs)]). drivers=None says there are none (and "
                "silences this).",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        return
    if groups is not None:
        return
    warnings.warn(
        f"{name}.fit: drivers='auto' finds the drivers ({', '.join(POWER_DRIVERS)}) "
        "by column name, and X has no column names: every column is taken as a "
        "temperature. Keep the names (set_output(transform='pandas') on the "
        "steps in front) or give the drivers by position (drivers=[...]; "
        "drivers=None when there are none).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def check_positive_numbers(
    values,
    name,
    owner,
    *,
    size=None,
    empty=True,
    distinct=False,
    why="",
    allow_zero=False,
):
    """The array-like parameter ``name`` of the estimator ``owner`` as a 1-D
    float array of finite numbers > 0 (>= 0 with ``allow_zero``).

    ``"array-like"`` in ``_parameter_constraints`` lets through strings,
    bools, NaN, infinities and negative numbers inside the sequence; this
    checks the entries, at the start of ``fit``.

    Parameters
    ----------
    values : array-like
        The parameter's value.
    name, owner : str
        The parameter's name (e.g. ``"alphas"`` or
        ``"time_constant_sets[1]"``) and the estimator's class name.
    size : int, optional
        The number of entries required (any when None).
    empty : bool, default=True
        Whether no entry at all is allowed.
    distinct : bool, default=False
        Whether an entry may not repeat (it would repeat a feature).
    why : str, optional
        Appended to the message: why the entries must be so.
    allow_zero : bool, default=False
        Whether an entry may be 0.

    Raises
    ------
    sklearn.utils._param_validation.InvalidParameterError
        (a ValueError) naming the parameter, the first offending entry and
        its position, and what was expected.
    """
    least = ">= 0" if allow_zero else "> 0"
    want = f"finite numbers {least}"
    if size is not None:
        want = f"{size} {want}"
    elif not empty:
        want = f"at least one finite number {least}"
    msg = f"The {name!r} parameter of {owner} must be a flat sequence of {want}"
    why = f" ({why})" if why else ""
    try:
        arr = np.asarray(values, dtype=object)
    except ValueError:  # ragged nesting
        arr = np.empty(0)
    if arr.ndim != 1:
        raise InvalidParameterError(f"{msg}{why}. Got {values!r} instead.")
    number = np.array(
        [isinstance(v, Real) and not isinstance(v, bool | np.bool_) for v in arr],
        dtype=bool,
    )
    num = np.full(arr.shape, np.nan)
    num[number] = arr[number].astype(float)
    allowed = (num >= 0) if allow_zero else (num > 0)
    bad = np.flatnonzero(~(np.isfinite(num) & allowed))
    if bad.size:
        i = int(bad[0])
        raise InvalidParameterError(
            f"{msg}{why}. Got {plain(arr[i])!r} at position {i} of {values!r} instead."
        )
    if (size is not None and num.size != size) or (not empty and num.size == 0):
        raise InvalidParameterError(
            f"{msg}{why}. Got {num.size} entries ({values!r}) instead."
        )
    ordered = np.sort(num)
    repeated = ordered[1:][np.diff(ordered) == 0]
    if distinct and repeated.size:
        raise InvalidParameterError(
            f"{msg}, each once{why}. Got {values!r}, which repeats "
            f"{repeated[0]:g}, instead."
        )
    return num


def is_clock_dtype(dtype):
    """Whether ``dtype`` holds datetimes or durations (numpy or pandas), which
    converting to numbers would read as nanoseconds."""
    import pandas as pd

    return bool(
        pd.api.types.is_datetime64_any_dtype(dtype)
        or pd.api.types.is_timedelta64_dtype(dtype)
        # pyarrow durations (pd.ArrowDtype(pa.duration(...))), which the
        # checks above do not take for timedeltas
        or getattr(dtype, "kind", None) in ("m", "M")
    )


def _check_text_in_array(X):
    """Raise a ValueError naming the first entry of a plain 2-D array of
    text or objects that is not a number (numpy's message names neither
    its row nor its column): typically a run table's ``run`` column passed
    as values."""
    import pandas as pd

    if not isinstance(X, np.ndarray) or X.ndim != 2 or X.dtype.kind not in "OUS":
        return
    flat = pd.Series(X.ravel(order="F"), dtype=object)
    text = flat.map(lambda v: isinstance(v, str)).to_numpy(dtype=bool)
    if not text.any():
        return  # other objects: numpy and scikit-learn say what they are
    # "nan" and "inf" are numbers to numpy (missing values are named later).
    texts = flat.where(text)
    named = texts.str.strip().str.lower().str.lstrip("+-")
    numeric = named.isin(["nan", "inf", "infinity"]).to_numpy(dtype=bool)
    coerced = pd.to_numeric(texts, errors="coerce").isna().to_numpy()
    bad = text & coerced & ~numeric
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    row, col = k % X.shape[0], k // X.shape[0]
    raise ValueError(
        f"X is a plain array holding text: column {col}, row {row} holds "
        f"{plain(X[row, col])!r}. Every feature must be a number; run labels go "
        "in groups= (or pass the run table as a DataFrame, whose 'run' and "
        "'time_s' columns are taken as the run and its time)."
    )


def check_numeric_columns(X, groups=None):
    """Raise a ValueError naming the first non-numeric column of a DataFrame.

    Numeric and boolean columns pass, as do object columns whose every value
    converts to a number; anything else (a sensor column holding ``"hot"``) is
    reported with its column name, the row and the offending value, before
    numpy would fail with a message that names neither. Plain arrays are left
    to :func:`sklearn.utils.validation.validate_data`.
    """
    columns = getattr(X, "columns", None)
    dtypes = getattr(X, "dtypes", None)
    import pandas as pd

    if columns is None or dtypes is None:
        _check_text_in_array(X)
        return
    for name, dtype in zip(columns, dtypes, strict=True):
        if pd.api.types.is_complex_dtype(dtype):
            raise ValueError(
                f"Column {plain(name)!r} holds complex numbers (dtype {dtype}). "
                "Every feature column must hold real numbers; keep the real part "
                "or the magnitude (np.real, np.abs) before fitting or predicting."
            )
        if pd.api.types.is_bool_dtype(dtype) or pd.api.types.is_numeric_dtype(dtype):
            continue
        if is_clock_dtype(dtype):
            # to_numeric would turn them into nanoseconds.
            raise ValueError(
                f"Column {plain(name)!r} holds {dtype} values, not numbers. Every "
                "feature column must hold numbers; convert (e.g. to seconds) or "
                "drop this column before fitting or predicting."
            )
        col = X[name]
        try:
            converted = pd.to_numeric(col, errors="coerce")
        except OverflowError:  # 10**400: numpy's bare "int too large"
            raise _too_large_error(X, "X", X, groups) from None
        bad = converted.isna().to_numpy() & col.notna().to_numpy()
        if not bad.any():
            continue
        i = int(np.flatnonzero(bad)[0])
        value = plain(col.iloc[i])
        comma = isinstance(value, str) and DECIMAL_COMMA.fullmatch(value)
        raise ValueError(
            f"Column {plain(name)!r} is not numeric: row {i} (index "
            f"{_label(col.index[i])!r}) holds {value!r}"
            + (", a number with a decimal comma" if comma else "")
            + ". Every feature column must hold numbers"
            + (" written with a decimal point" if comma else "")
            + "; convert or drop this column before fitting or predicting."
            + _prefixed_run_hint(name)
        )


def _prefixed_run_hint(name):
    """A hint for a ``run`` or ``time_s`` column renamed by a
    ``ColumnTransformer`` (``remainder__run``), which is then a feature."""
    text = str(name)
    for column in (RUN_COLUMN, TIME_COLUMN):
        if text.endswith(f"__{column}"):
            return (
                f" It looks like the run table's {column!r} column renamed by a "
                "ColumnTransformer: set verbose_feature_names_out=False on it so "
                f"that {column!r} keeps its name and is read as the run index."
            )
    return ""


def run_times(X, slices):
    """First and last ``time_s`` of each run, or None without a time index level.

    Returns
    -------
    ndarray of shape (n_runs, 2) or None
    """
    t = row_times(X)
    if t is None:
        return None
    return np.array([[t[sl.start], t[sl.stop - 1]] for sl in slices]).reshape(-1, 2)


def run_feature_names_in(estimator, input_features):
    """The input names for ``get_feature_names_out``: scikit-learn's rule,
    and also the columns of the run table the estimator was fitted on.

    A run-aware estimator takes a table's ``run`` and ``time_s`` columns as
    run information, not as inputs, so they are not in ``feature_names_in_``;
    a ``ColumnTransformer`` that passed them in asks for the output names with
    all the columns it gave. Those two are dropped when what is left are the
    names seen in fit.
    """
    from sklearn.utils.validation import _check_feature_names_in

    fitted = getattr(estimator, "feature_names_in_", None)
    if input_features is not None and fitted is not None:
        names = np.asarray(input_features, dtype=object)
        inputs = names[~np.isin(names, [RUN_COLUMN, TIME_COLUMN])]
        if inputs.size < names.size and np.array_equal(inputs, fitted):
            input_features = inputs
    return _check_feature_names_in(estimator, input_features)


def run_key(label):
    """The key of a run label in a :class:`RunMemory`: one that a model file
    can hold (skops writes the keys of a dict as JSON and rebuilds them from
    their type and text).

    ``str``, ``int`` and ``float`` labels (also as numpy scalars) are their
    own key. Any other label, such as a ``pandas.Timestamp`` (a run named by
    its start), a tuple or a bool, is keyed by its ``repr``, datetimes and
    durations as ``pandas.Timestamp`` and ``pandas.Timedelta`` whatever form
    they came in.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.utils._runs import run_key
    >>> run_key("r1"), run_key(3), run_key(("a", 1))
    ('r1', 3, "('a', 1)")
    >>> run_key(pd.Timestamp("2024-05-02 07:30"))
    "Timestamp('2024-05-02 07:30:00')"
    """
    import pandas as pd

    if isinstance(label, datetime.timedelta | np.timedelta64):
        label = pd.Timedelta(label)
    elif isinstance(label, datetime.datetime | np.datetime64):
        label = pd.Timestamp(label)
    elif isinstance(label, np.generic):
        label = label.item()
    if type(label) in (str, int, float):
        return label
    return repr(label)


class RunMemory(dict):
    """What a sequence model keeps of its labelled training runs, by run label.

    A dict whose keys are :func:`run_key` of the run labels, so that a model
    keeping it can be saved to a skops file whatever its labels are
    (``skthermal.io.save``). Items are read and set by the labels as given:
    ``memory[label]``, ``label in memory`` and ``memory.get(label)``
    convert the label first.
    """

    def __getitem__(self, label):
        return super().__getitem__(run_key(label))

    def __setitem__(self, label, value):
        super().__setitem__(run_key(label), value)

    def __delitem__(self, label):
        super().__delitem__(run_key(label))

    def __contains__(self, label):
        return super().__contains__(run_key(label))

    def get(self, label, default=None):
        return super().get(run_key(label), default)


def run_memory(X, slices, labels, frame):
    """What a sequence model keeps of each labelled training run, to continue it.

    Returns a :class:`RunMemory` ``label -> {"n", "x_first", "x_last",
    "t_first", "t_last", "period"}`` for every labelled run (rows without
    labels are one anonymous run, never continued): the number of rows, the
    first and last rows of inputs (``X``, the validated array), and from the
    times of ``frame`` (the input as :func:`extract_runs` returns it) the
    first and last ``time_s`` and the sampling period, the median time step
    (NaN without a time index). A model adds its own end state.
    """
    times = run_times(frame, slices)
    t = row_times(frame)
    periods = np.full(len(slices), np.nan) if t is None else _median_periods(t, slices)
    columns = getattr(frame, "columns", None)
    names = None
    if columns is not None and len(columns) == np.shape(X)[1]:
        names = [str(c) for c in columns]
    memory = RunMemory()
    for r, (sl, lab) in enumerate(zip(slices, labels, strict=True)):
        if lab is None:
            continue
        t0, t1 = (np.nan, np.nan) if times is None else times[r]
        run = np.asarray(X[sl], dtype=float)
        memory[lab] = {
            "n": sl.stop - sl.start,
            "x_first": run[0].copy(),
            "x_last": run[-1].copy(),
            "max_step": _smooth_max_step(run),
            "t_first": float(t0),
            "t_last": float(t1),
            "period": float(periods[r]),
        }
        if names is not None:
            memory[lab]["names"] = names
    return memory


def extend_memory(memory, X, slices, labels, frame, cont):
    """Add the rows of a later call to a sequence model's run memory.

    ``memory`` (a :class:`RunMemory` from :func:`run_memory`) is updated in
    place: a run that continues a remembered one (``cont`` from
    :func:`continued_runs`) keeps its first row, first time and period and
    takes the new last row and time, its row count and largest step grown;
    any other labelled run is remembered as :func:`run_memory` remembers a
    training run (replacing what an earlier run of that label left). Rows
    without labels are never remembered; the model adds each run's end
    state.
    """
    new = run_memory(X, slices, labels, frame)
    t = row_times(frame)
    for sl, lab, old_lab in zip(slices, labels, cont, strict=True):
        if lab is None:
            continue
        entry = new[lab]
        if old_lab is not None:
            old = memory[old_lab]
            merged = {
                **old,
                "n": old["n"] + entry["n"],
                "x_last": entry["x_last"],
                "t_last": entry["t_last"],
            }
            if t is not None:
                merged.update(_recent_period(old, t[sl]))
            if "max_step" in old and entry["n"] < 3:
                # A block of one or two rows shows no step of its own.
                merged["max_step"] = old["max_step"]
            elif "max_step" in old:
                merged["max_step"] = np.maximum(old["max_step"], entry["max_step"])
            entry = merged
        memory[lab] = entry


# Time steps a continued run's remembered sampling period is the median of:
# the run's latest, so that a logger that switches to another period is
# taken at its new period after a few blocks instead of warned about as a
# pause at every row.
_RECENT_STEPS = 15


def _recent_period(state, times):
    """``{"recent_steps", "recent_period", "period"}`` of a remembered run
    (``state``) continued by rows at ``times``: the latest
    :data:`_RECENT_STEPS` time steps, the step from the remembered last row
    included, and their median, which the pause warnings compare with. The
    run's ``period``, against which the filters judge a step a gap, stays
    what it was (a training run's median step), so that the run filters
    alike whole and block by block; a run whose first block told none (one
    row) takes its first steps'."""
    recent = state.get("recent_steps")
    if recent is None:
        period = memory_period(state)
        recent = np.array([period]) if np.isfinite(period) else np.zeros(0)
    steps = np.diff(np.r_[state["t_last"], times])
    steps = steps[np.isfinite(steps)]
    recent = np.r_[recent, steps][-_RECENT_STEPS:]
    out = {
        "recent_steps": recent,
        "recent_period": float(np.median(recent)) if recent.size else np.nan,
    }
    if not np.isfinite(state.get("period", np.nan)) and steps.size:
        out["period"] = float(np.median(steps))
    return out


def _estimators_in(value):
    """The estimators an attribute holds: itself, or the items (or the
    estimators in tuples such as pipeline steps) of a list, tuple or dict."""
    if isinstance(value, BaseEstimator):
        yield value
    elif isinstance(value, list | tuple) or (
        isinstance(value, dict) and not isinstance(value, RunMemory)
    ):
        for item in value.values() if isinstance(value, dict) else value:
            if isinstance(item, BaseEstimator):
                yield item
            elif isinstance(item, tuple):
                yield from (v for v in item if isinstance(v, BaseEstimator))


def sequence_models(estimator):
    """``(class name, run memory)`` of every fitted sequence model inside
    ``estimator`` (itself, pipeline steps, modules, ...), outermost first.

    A sequence model reads the rows of a run in order from its start (grey
    accumulation, lag filters, changes since the run start) and keeps what
    continuing its labelled training runs needs in ``run_states_``, a
    :class:`RunMemory`; static models keep none.
    """
    found, seen, todo = [], set(), [estimator]
    while todo:
        est = todo.pop(0)
        if id(est) in seen:
            continue
        seen.add(id(est))
        memory = getattr(est, "run_states_", None)
        if isinstance(memory, RunMemory):
            found.append((type(est).__name__, memory))
        for value in vars(est).values():
            todo.extend(_estimators_in(value))
    return found


class ForgetRunsMixin:
    """``forget_runs`` for a sequence model that keeps its runs' end states
    in ``run_states_`` (:func:`run_memory`, :func:`extend_memory`)."""

    def forget_runs(self, labels):
        """Forget the runs of ``labels`` (their end states, kept by ``fit``
        or ``remember_runs``): a later block under such a label is then a
        run of its own. Labels not remembered are ignored. Returns self."""
        memory = getattr(self, "run_states_", {})
        for lab in labels:
            if lab in memory:
                del memory[lab]
        return self


# A run continued by its label alone (no times) whose first row steps from
# the training run's last row by more than this many times the largest step
# within that run is most likely a new run under a reused label (the factor
# of GuardedRegressor's default jump check).
CONTINUATION_JUMP = 4.0


# An input whose largest step is this share of its span or more moves in
# steps (a spindle speed, a feed): a step at a run's continuation is normal.
_STEPPED_SHARE = 0.2


def _smooth_max_step(run):
    """Largest step of every input of a run's rows, inf for inputs that move
    in steps (:data:`_STEPPED_SHARE`) or have fewer than three rows, which
    the continuation check then leaves alone."""
    if run.shape[0] < 3:
        return np.full(run.shape[1], np.inf)
    step = np.abs(np.diff(run, axis=0)).max(axis=0)
    stepped = step >= _STEPPED_SHARE * np.ptp(run, axis=0)
    return np.where(stepped & (step > 0), np.inf, step)


def _input_name(state, j):
    """Input ``j`` of a remembered run, by name when fit had names."""
    names = state.get("names")
    return f"input {j}" if names is None else repr(names[j])


def _far_from_last(X_first, state):
    """The input (index) whose step from the remembered run's last row is the
    largest multiple of the run's largest step, and that multiple, when it
    exceeds :data:`CONTINUATION_JUMP`; else None."""
    step = state.get("max_step")
    if step is None:  # a memory kept before steps were
        return None
    jump = np.abs(np.asarray(X_first, dtype=float) - state["x_last"])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(step > 0, jump / step, 0.0)  # inf steps: 0
    if not ratio.size or ratio.max() <= CONTINUATION_JUMP:
        return None
    j = int(np.argmax(ratio))
    return j, float(ratio[j]), float(jump[j]), float(step[j])


def memory_period(state):
    """The sampling period of a remembered training run: its median time
    step, else its mean one (a memory kept before periods were)."""
    period = state.get("period", np.nan)
    if np.isfinite(period):
        return float(period)
    n, t0, t1 = state["n"], state["t_first"], state["t_last"]
    if n < 2 or not (np.isfinite(t0) and np.isfinite(t1)):
        return np.nan
    return (t1 - t0) / (n - 1)


# The two warnings of continued_runs, for a model that has said them for
# its inner models (warnings.filterwarnings(message=...)): a run that starts
# late, and a run under a training run's label that jumps from its end.
LATE_START_WARNING = r"(Run .*|The rows) given to .* start\(s\) at"
# The warning of warn_target_columns, for a wrapper that has said it for its
# inner model.
TARGET_COLUMNS_WARNING = (
    r"X's column\(s\) .* equal the target y|X holds the displacement"
)
REUSED_LABEL_WARNING = r"Run .* given to .* has the label of a training run"
# The warning of continued_runs for a run given from before its rows seen in
# fit, for a wrapper that has said it for its inner model.
EARLIER_PART_WARNING = r"Run .* given to .* starts before its rows seen in fit"
# The unit warning of warn_odd_times, for a model that has said it for X as
# given and fits inner models on the same times.
TIME_UNIT_WARNING = r"time_s is read as seconds since each run's start"


def continued_runs(
    name, X, slices, labels, times, memory, *, method="predict", stacklevel=3
):
    """Which predicted runs continue a training run: its label, else None.

    The rules, shared by the sequence models (documented in their
    docstrings):

    - a run whose label was seen in ``fit`` continues that run, so its rows
      are predicted as the samples after the last training row, unless it
      starts where the training run started (same first ``time_s``, or,
      without a time index, the same first row of inputs): then the run is
      predicted again from its start;
    - a labelled run whose first ``time_s`` is before the first one seen
      in ``fit`` (fit had a later part of the run) starts at its own first
      row, as a run's start;
    - a labelled run whose first ``time_s`` is inside its training span
      (after the first, up to the last) is an error: neither reading is
      right;
    - a run that is not continued starts at its first row; if its ``time_s``
      does not start at 0, a warning says so (the later part of a run given
      without its start is otherwise predicted as a run of its own).

    Parameters
    ----------
    name : str
        The class name of the estimator the user called, for the messages.
    X : ndarray of shape (n_samples, n_features)
        The validated inputs.
    slices, labels
        The predicted runs, as from :func:`run_slices`.
    times : ndarray of shape (n_runs, 2) or None
        From :func:`run_times`.
    memory : dict
        From :func:`run_memory` at fit time.
    method : str or None, default="predict"
        The method the user called, for the messages (``name.method``);
        None names the class alone, for a step that a pipeline may call.
    stacklevel : int, default=3
        Of the warning: 3 points at the caller of the method that calls
        this function.

    Returns
    -------
    list of the label to continue (or None) per predicted run.
    """
    who = name if method is None else f"{name}.{method}"
    out = []
    for r, (sl, lab) in enumerate(zip(slices, labels, strict=True)):
        state = memory.get(lab) if lab is not None else None
        t0 = None if times is None else float(times[r, 0])
        if (
            state is not None
            and t0 is not None
            and np.isfinite(state["t_first"])
            and t0 < state["t_first"]
        ):
            # Fit had a later part of this run (a cut), this call an earlier
            # one: nothing to continue, so it is predicted from its own first
            # row, as the start of the run.
            earlier = state["t_first"]
            state = None
        else:
            earlier = None
        if state is not None:
            if t0 is not None and np.isfinite(state["t_first"]):
                if t0 == state["t_first"]:
                    out.append(None)
                    continue
                if t0 <= state["t_last"]:
                    span = f"{state['t_first']:g}-{state['t_last']:g}"
                    where = f"inside the span {span} of it seen in fit"
                    raise ValueError(
                        f"Run {lab!r} starts at time_s={t0:g}, {where}. {who} "
                        "takes a run either from its start or after the end of "
                        "its training rows: pass the run from its start, or "
                        "only its rows after the training ones. A new run "
                        "under a training run's label needs a label of its "
                        "own; times that do not count from each run's start "
                        "(a clock's time, an offset) need each run's first "
                        "time subtracted. In cross-validation, a splitter "
                        "that cuts runs into pieces (KFold, ShuffleSplit, "
                        "train_test_split on rows) puts parts of one run in "
                        "both training and test; split by run (GroupKFold "
                        "with the run labels as groups) or in time order "
                        "(TimeSeriesSplit)."
                    )
                out.append(lab)
                continue
            same_start = np.array_equal(X[sl.start], state["x_first"])
            out.append(None if same_start else lab)
            far = None if same_start else _far_from_last(X[sl.start], state)
            if far is not None:
                j, ratio, jump, step = far
                warnings.warn(
                    f"Run {lab!r} given to {who} has the label of a training "
                    "run and no times, so it is taken as that run's "
                    "continuation, the samples after its last training row. "
                    f"But its first row steps from that last row by {jump:.4g} "
                    f"in {_input_name(state, j)} ({ratio:.3g} times the largest "
                    f"step within the training run, {step:.4g}): most likely a new run "
                    "under a reused label, or rows from inside the training "
                    "run. Give a new run a label not seen in fit (or its "
                    "time_s, from 0), a continuation the rows right after the "
                    "training ones, and rows with their time_s to have them "
                    "checked against the training span.",
                    UserWarning,
                    stacklevel=stacklevel,
                )
            continue
        out.append(None)
        if earlier is not None:
            start = (
                "from its start"
                if t0 == 0
                else f"at time_s={t0:g}, not 0 (pass it from time_s=0 to "
                "predict it from there)"
            )
            warnings.warn(
                f"Run {lab!r} given to {who} starts before its rows seen in fit "
                f"(from time_s={earlier:g}): fit had a later part of this run, "
                f"so it is predicted as a run that starts at its first row, "
                f"{start}. In cross-validation, a splitter that cuts runs into "
                "pieces (KFold, ShuffleSplit, train_test_split on rows) trains "
                "on later parts of a test run; split by run (GroupKFold with "
                "the run labels as groups) or in time order (TimeSeriesSplit).",
                UserWarning,
                stacklevel=stacklevel,
            )
        elif t0 is not None and t0 != 0:
            run = "The rows" if lab is None else f"Run {lab!r}"
            warnings.warn(
                f"{run} given to {who} start(s) at time_s={t0:g}, not "
                "0, and continue(s) no run seen in fit, so they are taken as a "
                "run that starts at their first row. To continue the later "
                "part of a training run, keep its run label (the model "
                "continues it); otherwise pass the run from its start.",
                UserWarning,
                stacklevel=stacklevel,
            )
    return out
