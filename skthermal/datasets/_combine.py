"""Joining run tables while keeping the metadata of their runs.

The simulator and the campaign generators put one metadata record per run in
``runs.attrs["metadata"]``; :func:`pandas.concat` drops ``attrs`` that differ
between its inputs, so joining simulated runs with it loses their metadata.
"""

import pandas as pd

from skthermal._naming import plain
from skthermal.datasets._loaders import _meta_records
from skthermal.datasets._runtable import RUN, validate_runs
from skthermal.utils._runs import check_frame


def _check_frames(frames):
    if isinstance(frames, pd.DataFrame):
        raise ValueError(
            "concat_runs takes a list of run tables, got a single DataFrame."
        )
    frames = list(frames)
    if not frames:
        raise ValueError("concat_runs needs at least one run table, got none.")
    for i, frame in enumerate(frames):
        check_frame(frame, f"Run table {i}")
        if RUN not in frame.columns:
            raise ValueError(
                f"Run table {i} has no 'run' column; every table needs the run "
                "label of its rows."
            )
    columns = list(frames[0].columns)
    for i, frame in enumerate(frames[1:], start=1):
        if set(frame.columns) != set(columns):
            missing = [c for c in columns if c not in frame.columns]
            extra = [c for c in frame.columns if c not in columns]
            raise ValueError(
                f"The columns of run table {i} differ from those of table 0: "
                f"missing {missing}, extra {extra}. Select or add columns so that "
                "every table has the same ones."
            )
    return frames, columns


def _check_labels(frames):
    """Raise naming a run label found in more than one table."""
    owner = {}
    for i, frame in enumerate(frames):
        for run in pd.unique(frame[RUN]):
            if run in owner:
                raise ValueError(
                    f"Run {plain(run)!r} is in run table {owner[run]} and in run "
                    f"table {i}; run labels must be unique across the tables "
                    "(simulate them with distinct run=... labels, or relabel one)."
                )
            owner[run] = i


def _as_records(meta):
    """Metadata in any accepted form as a list of dicts, checked by run."""
    frame = _meta_records(meta)  # raises on a missing 'run' key or a repeated run
    if isinstance(meta, pd.DataFrame | dict):
        return frame.to_dict("records")
    return [dict(record) for record in meta]


def _records(frames, metadata):
    """Metadata records of the joined table, or None when there are none."""
    if metadata is not None:
        return _as_records(metadata)
    have = [f for f in frames if "metadata" in f.attrs]
    if not have:
        return None
    # Each table's records of its own runs: a table filtered from a campaign
    # with pandas keeps the records of every run of it in attrs.
    own = []
    for frame in have:
        runs = set(pd.unique(frame[RUN]))
        own += [r for r in _as_records(frame.attrs["metadata"]) if r[RUN] in runs]
    return _as_records(own)


def concat_runs(frames, *, metadata=None, validate=True):
    """Join run tables into one, keeping the metadata of their runs.

    Unlike :func:`pandas.concat`, this keeps the per-run metadata that the
    simulator and the campaign generators attach as ``attrs["metadata"]``
    (one record per run), and refuses tables that would mix up: a run label
    used in two tables, or tables with different columns.

    Parameters
    ----------
    frames : sequence of DataFrame
        Run tables, each with a ``run`` column and the same set of columns.
    metadata : DataFrame, dict or list of dict, optional
        Metadata of the joined runs, in any form that
        :func:`~skthermal.datasets.write_runs` accepts; it replaces the
        records of the tables. Default: the records in the tables'
        ``attrs["metadata"]`` of the runs each table holds, in table order
        (a table filtered from a campaign with pandas keeps the records of
        all its runs).
    validate : bool, default=True
        Check the joined table with :func:`validate_runs`.

    Returns
    -------
    runs : DataFrame
        The rows of every table in order, with a fresh index and the columns
        in the order of the first table. ``runs.attrs`` holds only
        ``"metadata"``: a list with one record (dict) per run, ready for
        ``write_runs(runs, path, metadata=runs.attrs["metadata"])``; it is
        absent when no table carries metadata and none is given.

    Raises
    ------
    ValueError
        If a run label is in more than one table (the message names it and
        the two tables), the columns differ (it names them), the metadata
        lists a run twice, or the joined table is not a valid run table.

    See Also
    --------
    validate_runs, write_runs

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.datasets import concat_runs
    >>> a = pd.DataFrame({"run": ["a", "a"], "time_s": [0.0, 60.0],
    ...                   "T1_C": [20.0, 21.0]})
    >>> a.attrs["metadata"] = [{"run": "a", "machine": "B"}]
    >>> b = a.assign(run="b")
    >>> b.attrs["metadata"] = [{"run": "b", "machine": "C"}]
    >>> runs = concat_runs([a, b])
    >>> runs["run"].tolist()
    ['a', 'a', 'b', 'b']
    >>> runs.attrs["metadata"]
    [{'run': 'a', 'machine': 'B'}, {'run': 'b', 'machine': 'C'}]
    >>> concat_runs([a, a])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: Run 'a' is in run table 0 and in run table 1; run labels must be ...
    """
    frames, columns = _check_frames(frames)
    _check_labels(frames)
    records = _records(frames, metadata)
    if records is not None:
        runs = {run for frame in frames for run in pd.unique(frame[RUN])}
        unknown = [r[RUN] for r in records if r[RUN] not in runs]
        if unknown:
            raise ValueError(
                f"The metadata describes run(s) {[plain(r) for r in unknown]} "
                "that are in none of the tables."
            )
    parts = []
    for frame in frames:
        # pandas compares the inputs' attrs, which fails on a DataFrame there
        # (read_runs(..., metadata=True) gives one); the records are above.
        part = frame[columns]
        part.attrs = {}
        parts.append(part)
    joined = pd.concat(parts, ignore_index=True)
    joined.attrs = {} if records is None else {"metadata": records}
    if validate:
        validate_runs(joined)
    return joined
