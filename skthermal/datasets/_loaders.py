"""Reading and writing run tables (CSV, compressed CSV, Parquet) and loaders.

On disk a run table is a CSV file (compressed when its name ends in ``.gz``,
``.bz2``, ``.zip``, ``.xz`` or ``.zst``) or a Parquet file (``.parquet``,
``.pq``). Metadata about the runs travels in a JSON *sidecar* named after the
whole file name plus ``.json``: ``runs.csv.gz`` -> ``runs.csv.gz.json``.
"""

import bz2
import csv
import gzip
import io
import json
import lzma
import math
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal._optional import import_optional, missing_dependency
from skthermal.datasets._runtable import RUN, validate_runs

_PARQUET_SUFFIXES = (".parquet", ".pq")
FL_THERMAL_FILE = "fl_thermal_spindle.csv.gz"
# pandas < 3 parses floats with a fast but inexact parser unless asked for
# "round_trip"; pandas 3 round-trips by default and deprecates the argument.
_CSV_OPTIONS = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)


def _is_parquet(path):
    return path.suffix.lower() in _PARQUET_SUFFIXES


_COMPRESSION_SUFFIXES = (".gz", ".bz2", ".zip", ".xz", ".zst")
_TEXT_SUFFIXES = (".csv", ".txt")


def check_table_name(path, what="The run table file"):
    """Raise a ValueError unless ``path`` names a file a run table is written
    as: CSV (``.csv`` or ``.txt``, optionally compressed) or Parquet."""
    path = Path(path)
    if _is_parquet(path):
        return
    suffixes = [x.lower() for x in path.suffixes]
    if suffixes and suffixes[-1] in _COMPRESSION_SUFFIXES:
        suffixes = suffixes[:-1]
    if not suffixes or suffixes[-1] not in _TEXT_SUFFIXES:
        raise ValueError(
            f"{what} {str(path)!r} is neither CSV nor Parquet: name it .csv "
            f"(optionally {', '.join(_COMPRESSION_SUFFIXES)}) or .parquet."
        )


def _sidecar_path(path):
    return path.with_name(path.name + ".json")


def _parquet_error(exc):
    return missing_dependency(
        "pyarrow", extra="parquet", caller="Reading or writing Parquet"
    ).with_traceback(exc.__traceback__)


def _unzip(path):
    with zipfile.ZipFile(path) as archive:
        names = [n for n in archive.namelist() if not n.endswith("/")]
        if len(names) != 1:
            raise ValueError(
                f"{path}: a zipped run table must hold exactly one file, found "
                f"{len(names)}: {names[:5]}."
            )
        return archive.read(names[0])


def _unzstd(path):
    zstandard = import_optional(
        "zstandard", caller=f"Reading {path} (Zstandard-compressed)"
    )
    with zstandard.open(path, "rb") as fh:
        return fh.read()


def _read_with(opener):
    def read(path):
        with opener(path, "rb") as fh:
            return fh.read()

    return read


_DECOMPRESS = {
    ".gz": _read_with(gzip.open),
    ".bz2": _read_with(bz2.open),
    ".xz": _read_with(lzma.open),
    ".zip": _unzip,
    ".zst": _unzstd,
}
# What a cut or damaged compressed file raises while being decompressed.
_DAMAGED = (EOFError, zlib.error, gzip.BadGzipFile, lzma.LZMAError, zipfile.BadZipFile)


def _raw_bytes(path):
    """The CSV bytes of ``path``, decompressed, with plain errors."""
    decompress = _DECOMPRESS.get(path.suffix.lower())
    if decompress is None:
        return path.read_bytes()
    try:
        return decompress(path)
    except EOFError as exc:
        raise ValueError(
            f"{path}: the file is cut off: its compressed data end without the "
            "end-of-stream marker. It was probably not written or copied "
            "completely; write or copy it again."
        ) from exc
    except (*_DAMAGED, OSError) as exc:
        raise ValueError(
            f"{path}: the file is cut off or damaged: it is not valid "
            f"{path.suffix.lower()[1:]}-compressed data ({exc}). Write or copy it "
            "again, or rename it if it is not compressed."
        ) from exc


def _csv_fields(line):
    return next(csv.reader([line]), [])


def _check_complete(path, data):
    """Raise if the CSV bytes ``data`` end in a line that was cut short.

    A file cut mid-line ends with a row holding fewer fields than the header,
    which pandas would read as missing values.
    """
    body = data.rstrip(b"\r\n")
    first_end = body.find(b"\n")
    if first_end < 0:
        return  # a single line: nothing to compare with the header
    header = body[:first_end].decode("utf-8", errors="replace").lstrip("\ufeff")
    line_no = body.count(b"\n") + 1
    last = body[body.rfind(b"\n") + 1 :].decode("utf-8", errors="replace")
    n_header, n_last = len(_csv_fields(header)), len(_csv_fields(last))
    if not last.strip() or n_last >= n_header:
        return
    newline = "" if data.endswith(b"\n") else " and no line end"
    shown = last if len(last) <= 60 else last[:57] + "..."
    raise ValueError(
        f"{path}: the file is cut off: its last line (line {line_no}) has "
        f"{n_last} of the {n_header} fields of the header{newline}: {shown!r}. "
        "It was probably not written or copied completely; write or copy it "
        "again, or delete that line."
    )


def _read_csv(path):
    data = _raw_bytes(path)
    if not data.strip():
        raise ValueError(
            f"{path}: empty file: it holds no run table (expected a CSV header "
            "line and rows)."
        )
    _check_complete(path, data)
    try:
        return pd.read_csv(io.BytesIO(data), **_CSV_OPTIONS)
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{path}: not a UTF-8 text CSV run table ({exc}); use .csv, .csv.gz "
            "or .parquet."
        ) from exc
    except pd.errors.ParserError as exc:
        raise ValueError(f"{path}: not a well-formed CSV file: {exc}") from exc


def _read_table(path):
    """Read the run table at ``path``, naming the file in every error."""
    if not path.is_file():
        what = "a folder, not a file" if path.is_dir() else "no such file"
        raise FileNotFoundError(f"No run table file at {path} ({what}).")
    if path.stat().st_size == 0:
        raise ValueError(f"{path}: empty file (0 bytes): it holds no run table.")
    if not _is_parquet(path):
        return _read_csv(path)
    try:
        return pd.read_parquet(path)
    except ImportError as exc:
        raise _parquet_error(exc) from exc
    except (ValueError, OSError) as exc:  # pyarrow's ArrowInvalid is a ValueError
        raise ValueError(
            f"{path}: not a readable Parquet file: the file is cut off or damaged "
            f"({exc}). Write or copy it again."
        ) from exc


def _meta_records(meta):
    """Metadata as a DataFrame with a ``run`` column, from the accepted forms."""
    if isinstance(meta, pd.DataFrame):
        frame = meta
        if RUN not in frame.columns and RUN in frame.index.names:
            frame = frame.reset_index()
    elif isinstance(meta, dict):
        frame = pd.DataFrame.from_records(
            [{RUN: run, **dict(fields)} for run, fields in meta.items()]
        )
    else:
        frame = pd.DataFrame.from_records(list(meta))
    if RUN not in frame.columns:
        raise ValueError(
            "Run metadata must be keyed by run: a DataFrame with a 'run' column or "
            "index level, a dict {run: {field: value}} or a list of records with a "
            f"'run' key; got columns {list(frame.columns)}."
        )
    duplicated = frame[RUN][frame[RUN].duplicated()].unique().tolist()
    if duplicated:
        raise ValueError(f"Run metadata lists run(s) {duplicated} more than once.")
    return frame


def _jsonable(value):
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_jsonable(v) for v in value]
    if value is None or value is pd.NA or value is pd.NaT:
        return None
    if isinstance(value, str | int | float | bool):
        return value
    return str(value)


def _write_sidecar(path, meta, df):
    frame = _meta_records(meta)
    unknown = sorted(set(frame[RUN]) - set(df[RUN]), key=str)
    if unknown:
        raise ValueError(
            f"Run metadata describes run(s) {unknown} that are not in the table."
        )
    columns = [RUN, *(c for c in frame.columns if c != RUN)]
    runs = [
        {str(k): _jsonable(v) for k, v in zip(columns, row, strict=True)}
        for row in frame[columns].itertuples(index=False, name=None)
    ]
    document = {str(k): _jsonable(v) for k, v in frame.attrs.items() if k != "runs"}
    document["runs"] = runs
    with open(_sidecar_path(path), "w", encoding="utf-8") as fh:
        json.dump(document, fh, indent=2, ensure_ascii=False)
        fh.write("\n")


def _read_sidecar(path):
    sidecar = _sidecar_path(path)
    if not sidecar.exists():
        return pd.DataFrame({RUN: []})
    data = sidecar.read_bytes()
    if not data.strip():
        raise ValueError(
            f"Metadata sidecar {sidecar}: empty file; expected a JSON object "
            '{"runs": [{"run": ..., ...}, ...]} (delete the file if the runs have '
            "no metadata)."
        )
    try:
        document = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"Metadata sidecar {sidecar} is not UTF-8 JSON text ({exc})."
        ) from exc
    except json.JSONDecodeError as exc:
        # A document that ends inside a string or before its closing brackets
        # was cut off rather than mistyped.
        ends_early = exc.pos >= len(exc.doc.rstrip()) or exc.msg.startswith(
            "Unterminated string"
        )
        cut = " (the file is cut off)" if ends_early and exc.pos > 0 else ""
        raise ValueError(
            f"Metadata sidecar {sidecar} is not valid JSON{cut}: {exc}."
        ) from exc
    attrs = {}
    if isinstance(document, dict):
        if "runs" not in document:
            raise ValueError(
                f"Metadata sidecar {sidecar} has no 'runs' list of records."
            )
        attrs = {k: v for k, v in document.items() if k != "runs"}
        document = document["runs"]
    if not isinstance(document, list) or not all(isinstance(r, dict) for r in document):
        raise ValueError(
            f"Metadata sidecar {sidecar}: 'runs' must be a list of records."
        )
    try:
        frame = _meta_records(document)
    except ValueError as exc:
        raise ValueError(f"Metadata sidecar {sidecar}: {exc}") from exc
    frame = frame[[RUN, *(c for c in frame.columns if c != RUN)]]
    frame.attrs.update(attrs)
    return frame


def read_runs(path, *, validate=True, metadata=False):
    """Read a run table from CSV, compressed CSV or Parquet.

    Parameters
    ----------
    path : str or path-like
        The file. Names ending in ``.parquet`` or ``.pq`` are read as Parquet
        (needs pyarrow, the ``parquet`` extra); anything else as CSV, with the
        compression inferred from the name (``.gz``, ``.bz2``, ``.zip``,
        ``.xz``, ``.zst``).
    validate : bool, default=True
        Check the table with :func:`validate_runs` (default options).
    metadata : bool, default=False
        Also return the run metadata from the JSON sidecar.

    Returns
    -------
    df : DataFrame
        The run table, values as stored.
    meta : DataFrame
        Only when ``metadata=True``: one row per run, a ``run`` column first,
        from the sidecar ``<file name>.json`` beside the file (for
        ``runs.csv.gz``: ``runs.csv.gz.json``). Top-level fields of the sidecar
        other than ``runs`` are in ``meta.attrs``. Without a sidecar, an empty
        frame with a ``run`` column.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist or is a folder.
    ValueError
        If the file cannot be read as a run table: an empty file, a file that
        is cut off (a compressed stream that ends early, a last CSV line with
        fewer fields than the header, a damaged Parquet file), a CSV that is
        not UTF-8 text or not well formed; if the table breaks the run-table
        rules (see :func:`validate_runs`); or if the sidecar is malformed.
        Every message starts with the file's path.

    See Also
    --------
    write_runs, validate_runs

    Notes
    -----
    The sidecar is a JSON object ``{"runs": [{"run": ..., "machine": ...},
    ...], ...}`` (a bare list of records is accepted too); run labels keep
    their JSON type, so label the runs the same way in the table and in the
    sidecar.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import pandas as pd
    >>> from skthermal.datasets import read_runs, write_runs
    >>> df = pd.DataFrame({"run": ["a", "a"], "time_s": [0.0, 60.0],
    ...                    "T1_C": [20.0, 21.5], "disp_y_um": [0.0, 3.2]})
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "runs.csv.gz"
    ...     write_runs(df, path, metadata={"a": {"machine": "B"}})
    ...     back, meta = read_runs(path, metadata=True)
    ...     sorted(p.name for p in path.parent.iterdir())
    ['runs.csv.gz', 'runs.csv.gz.json']
    >>> back.equals(df)
    True
    >>> meta
      run machine
    0   a       B
    """
    path = Path(path)
    df = _read_table(path)
    if validate:
        try:
            validate_runs(df)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from exc
    if metadata:
        return df, _read_sidecar(path)
    return df


def write_runs(df, path, *, metadata=None, validate=True):
    """Write a run table to CSV, compressed CSV or Parquet, with its metadata.

    Parameters
    ----------
    df : DataFrame
        The run table. Its index is not written.
    path : str or path-like
        The file; the format follows the name as in :func:`read_runs`.
    metadata : DataFrame, dict or list of dict, optional
        Run metadata, written to the sidecar ``<file name>.json``: a DataFrame
        with a ``run`` column (or index level; its ``attrs`` become top-level
        fields), a dict ``{run: {field: value}}`` or a list of records with a
        ``run`` key. Every run it names must be in ``df``. Without metadata, a
        sidecar left by an earlier file at ``path`` is removed so that stale
        metadata never describes new data.
    validate : bool, default=True
        Check ``df`` with :func:`validate_runs` before writing.

    Raises
    ------
    ValueError
        If ``df`` is not a valid run table or the metadata is not keyed by
        runs of ``df``.

    See Also
    --------
    read_runs

    Examples
    --------
    See :func:`read_runs`.
    """
    if validate:
        validate_runs(df)
    elif not isinstance(df, pd.DataFrame):
        raise ValueError(
            f"A run table must be a pandas DataFrame, got {type(df).__name__}."
        )
    path = Path(path)
    check_table_name(path)
    if metadata is not None:
        # Check the metadata before touching any file.
        _meta_records(metadata)
        if RUN not in df.columns:
            raise ValueError("Run metadata needs a 'run' column in the table.")
    if _is_parquet(path):
        try:
            df.to_parquet(path, index=False)
        except ImportError as exc:
            raise _parquet_error(exc) from exc
    else:
        df.to_csv(path, index=False)
    if metadata is not None:
        _write_sidecar(path, metadata, df)
    else:
        _sidecar_path(path).unlink(missing_ok=True)


def load_fl_thermal(path):
    """Load the FL_THERMAL spindle thermal-error test as a run table.

    A real test of a machine-tool spindle: 11,115 rows sampled every 15 s
    (about 46.3 h) in one continuous run, with the spindle speed, five
    displacement channels ``disp_ch1_um`` .. ``disp_ch5_um`` (µm; the source
    does not say which axis each one measures) and sixteen temperature
    sensors ``T1_C`` .. ``T16_C`` (°C; locations not documented).

    Duty cycle: spindle-speed steps of 4 h alternating with 4 h at rest (1250,
    0, 2500, 0, 3750, 0, 5000, 0, 3500, 0 rpm), then 500 and 1500 rpm for 2 h
    each, then 2500 and 4500 rpm for 1 h each.

    Parameters
    ----------
    path : str or path-like
        The file ``fl_thermal_spindle.csv.gz`` or the folder that holds it.
        The data are not shipped with skthermal.

    Returns
    -------
    DataFrame
        A valid run table: a ``run`` column equal to ``"fl_thermal"`` first,
        then the columns of the file with their values unchanged (absolute
        readings).

    Raises
    ------
    FileNotFoundError
        If the file cannot be found.
    ValueError
        If the file does not have the expected columns.

    See Also
    --------
    split_runs : Turn the table into ``X``, ``y`` and ``groups``.

    Notes
    -----
    Source: GitHub repository CAIVIAC/FL_THERMAL, file ``data/data.xlsx``,
    MIT licence, Copyright (c) 2024 CAIVIAC; converted to CSV with column
    names translated and values unchanged. A plain linear regression on all
    sixteen temperatures trained on the first 60% of the run has a test RMSE
    of about 8.3 / 6.7 / 11.0 / 11.0 / 7.9 µm on the last 40% (channels 1-5):
    a hard extrapolation problem.

    Examples
    --------
    >>> from skthermal.datasets import load_fl_thermal, split_runs
    >>> df = load_fl_thermal("../shared/data")  # doctest: +SKIP
    >>> X, y, groups = split_runs(df)  # doctest: +SKIP
    >>> X.shape, y.shape  # doctest: +SKIP
    ((11115, 16), (11115, 5))
    """
    path = Path(path)
    file = path / FL_THERMAL_FILE if path.is_dir() else path
    if not file.is_file():
        raise FileNotFoundError(
            f"FL_THERMAL spindle data not found at {file}: pass the file "
            f"{FL_THERMAL_FILE} or the folder holding it (skthermal does not ship "
            "it; it comes from GitHub CAIVIAC/FL_THERMAL, converted to CSV)."
        )
    df = _read_table(file)
    expected = [
        "time_s",
        "spindle_rpm",
        *(f"disp_ch{i}_um" for i in range(1, 6)),
        *(f"T{i}_C" for i in range(1, 17)),
    ]
    absent = [c for c in expected if c not in df.columns]
    if absent or RUN in df.columns:
        raise ValueError(
            f"{file} does not look like {FL_THERMAL_FILE}: expected the columns "
            f"{expected} (and no 'run'), missing {absent}."
        )
    df.insert(0, RUN, "fl_thermal")
    return validate_runs(df, require_targets=True)
