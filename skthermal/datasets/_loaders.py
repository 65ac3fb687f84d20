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
import re
import warnings
import zipfile
import zlib
from numbers import Integral, Real
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal._naming import plain
from skthermal._optional import import_optional, missing_dependency
from skthermal.datasets._runtable import (
    RUN,
    SKIP_VALIDATION,
    TIME,
    check_label_kinds,
    check_run_table,
    validate_runs,
)
from skthermal.utils._runs import check_frame

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
        if "[Content_Types].xml" in names or "content.xml" in names:
            raise ValueError(_WORKBOOK.format(path=path))
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


# What a file's first bytes say it is, when that is not CSV text.
_MAGIC = (
    (b"\x1f\x8b", "gzip-compressed data", ".gz"),
    (b"BZh", "bzip2-compressed data", ".bz2"),
    (b"PK\x03\x04", "a zip archive", ".zip"),
    (b"\xfd7zXZ\x00", "xz-compressed data", ".xz"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed data", ".zst"),
)


_WORKBOOK = (
    "{path}: the file is a spreadsheet workbook, not CSV text; run tables are "
    "read from CSV or Parquet. Save the sheet as CSV (UTF-8) from the "
    "spreadsheet, or read it with pandas.read_excel and pass the frame to "
    "skthermal.datasets.validate_runs."
)
# An OLE2 compound file: an Excel 97-2003 workbook (.xls).
_OLE_MAGIC = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"


def _is_workbook(data):
    """Whether ``data`` is a zip archive of an Office or OpenDocument
    workbook (an .xlsx or .ods file, whatever its name)."""
    if not data.startswith(b"PK\x03\x04"):
        return False
    head = data[:4096]
    return b"xl/" in head or b"[Content_Types].xml" in head or b"spreadsheet" in head


def _check_not_binary(path, data):
    """Raise naming what ``data`` (the CSV bytes of ``path``, decompressed
    as its name says) is, when its first bytes show a compressed stream or
    a Parquet file: read as text, they gave a misleading message (a '|'
    separator, a stray carriage return)."""
    if data[:4] == b"PAR1":
        raise ValueError(
            f"{path}: the file is a Parquet file, not CSV text; name it "
            f"{path.stem}.parquet to read it as Parquet."
        )
    excel = path.suffix.lower() in (".xlsx", ".xlsm", ".xls", ".ods")
    if excel or data.startswith(_OLE_MAGIC) or _is_workbook(data):
        # Named .zip it failed again ("must hold exactly one file, found 4").
        raise ValueError(_WORKBOOK.format(path=path))
    for magic, what, suffix in _MAGIC:
        if not data.startswith(magic):
            continue
        if path.suffix.lower() in _DECOMPRESS:
            raise ValueError(
                f"{path}: the file was compressed twice: decompressed, it holds "
                f"{what}, not CSV text. Write it compressed once."
            )
        raise ValueError(
            f"{path}: the file holds {what}, not CSV text; name it "
            f"{path.name}{suffix} to read it."
        )


def _csv_fields(line, path):
    try:
        return next(csv.reader([line]), [])
    except csv.Error as exc:
        raise ValueError(
            f"{path}: a CSV line cannot be read ({exc}): a line break or a stray "
            "carriage return inside a field; the line starts "
            f"{line[:60]!r}."
        ) from None


def _named_fields(fields):
    """How many of a header's ``fields`` come up to its last named one (the
    empty ones after it are trailing separators)."""
    return next((i + 1 for i in range(len(fields) - 1, -1, -1) if fields[i].strip()), 0)


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
    fields = _csv_fields(header, path)
    # Empty names at the header's end are trailing separators, not columns
    # the rows must fill.
    n_header = _named_fields(fields)
    n_last = len(_csv_fields(last, path))
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


def _first_line(data):
    """The first line of the CSV bytes ``data`` that is not blank (the header
    line as pandas finds it), as text without the byte-order mark."""
    start = 0
    while True:
        end = data.find(b"\n", start)
        line = data[start : len(data) if end < 0 else end]
        if line.strip() or end < 0:
            break
        start = end + 1
    return line.decode("utf-8", errors="replace").lstrip("\ufeff").rstrip("\r")


# Separators of spreadsheet exports that are not a comma (e.g. Excel in locales
# with a decimal comma writes ';').
_OTHER_SEPARATORS = {";": "';'", "\t": "a tab", "|": "'|'"}
_DECIMAL_COMMA = re.compile(r"(?:^|[;\t|])\s*[-+]?[0-9]+,[0-9]+\s*(?:$|[;\t|])")


def _check_header(path, data):
    """Raise on a header a run table cannot have: one field holding another
    separator (a ';'-separated spreadsheet export), or repeated names (which
    pandas would rename silently to ``name.1``). Returns the header fields."""
    header = _first_line(data)
    fields = _csv_fields(header, path)
    if len(fields) == 1:
        for sep, name in _OTHER_SEPARATORS.items():
            if sep in fields[0]:
                head = data[: 1 << 16]
                try:
                    sample, encoding = head.decode("utf-8"), ""
                except UnicodeDecodeError:
                    # A spreadsheet of Windows (°: 0xb0); the recipe said
                    # nothing of it, and pandas then failed on the byte.
                    sample, encoding = head.decode("cp1252", errors="replace"), "cp1252"
                every = sample.splitlines()[:_PREAMBLE_LINES]
                # The header: the first line with as many fields as most
                # lines (the rows; a logger's preamble lines hold fewer).
                counts = [len(line.split(sep)) for line in every]
                filled = [c for c, line in zip(counts, every, strict=True) if line]
                rows = max(set(filled), key=filled.count) if filled else 1
                skip = next((i for i, c in enumerate(counts) if c == rows), 0)
                lines = every[skip + 1 : skip + 6]
                decimal = any(_DECIMAL_COMMA.search(line) for line in lines)
                header = every[skip] if every else header
                shown = header if len(header) <= 60 else header[:57] + "..."
                convert = (
                    f"sep={sep!r}"
                    + (", decimal=','" if decimal else "")
                    + (f", skiprows={skip}" if skip else "")
                    + (f", encoding={encoding!r}" if encoding else "")
                )
                raise ValueError(
                    f"{path}: the header line {shown!r} is a single column: the "
                    f"file seems to use {name} as the separator"
                    + (" and decimal commas" if decimal else "")
                    + " (as spreadsheet programs write CSV in some locales). A "
                    "run table is comma-separated, with decimal points: export it "
                    "as comma-separated CSV, or convert it with "
                    f"pandas.read_csv(path, {convert}) and write_runs."
                )
    seen = {}
    for position, name in enumerate(fields, start=1):
        if name.strip():
            seen.setdefault(name, []).append(position)
    repeated = {name: cols for name, cols in seen.items() if len(cols) > 1}
    if repeated:
        listing = "; ".join(
            f"{name!r} (columns {', '.join(map(str, cols))})"
            for name, cols in repeated.items()
        )
        raise ValueError(
            f"{path}: the header names the same column more than once: {listing}. "
            "Every column needs its own name; rename or delete the duplicates."
        )
    return fields


# Lines searched for a run table's header below a preamble.
_PREAMBLE_LINES = 50


def _check_preamble(path, data, fields):
    """Raise when the first line is not the header and a later line is (a
    logger's preamble or a comment above it): pandas would read the
    preamble as the header and fail on the first row, or worse."""
    if {RUN, TIME} <= {f.strip() for f in fields}:
        return
    text = data[: 1 << 16].decode("utf-8", errors="replace").lstrip("\ufeff")
    reader = csv.reader(io.StringIO(text, newline=""))
    for row in reader:
        if reader.line_num > _PREAMBLE_LINES:
            return
        if reader.line_num > 1 and {RUN, TIME} <= {f.strip() for f in row}:
            k = reader.line_num - 1
            first = _first_line(data)
            first = first if len(first) <= 60 else first[:57] + "..."
            raise ValueError(
                f"{path}: the run table's header (the line naming 'run' and "
                f"'time_s') is line {k + 1}; the {k} line(s) above it, from "
                f"{first!r}, are a preamble or comment, not part of a run table. "
                "Delete them (keep their information in the run metadata, "
                f"write_runs(..., metadata=...)), or read the file with "
                f"pandas.read_csv(path, skiprows={k}) and write it again with "
                "write_runs."
            )


def _long_line_error(path, data, n_header, warning):
    """The error for rows with more fields than the header (pandas would drop
    the extra fields or shift every column), naming the first such line."""
    text = data.decode("utf-8", errors="replace").lstrip("\ufeff")
    reader = csv.reader(io.StringIO(text, newline=""))
    for row in reader:
        if len(row) > n_header and reader.line_num > 1:
            extra = row[n_header:]
            trailing = (
                " (empty fields at its end: trailing separators; remove them)"
                if not any(field.strip() for field in extra)
                else ""
            )
            shown = ",".join(row)
            shown = shown if len(shown) <= 60 else shown[:57] + "..."
            return ValueError(
                f"{path}: line {reader.line_num} has {len(row)} fields but the "
                f"header has {n_header}{trailing}: {shown!r}. Every row needs "
                "one field per header name."
            )
    return ValueError(f"{path}: not a well-formed CSV file: {warning}")


# A whole number as CSV writes one, so that it reads back as the same text.
_CANONICAL_INT = re.compile(r"-?(?:0|[1-9][0-9]{0,17})")


def _csv_run_labels(data, labels):
    """The ``run`` column of the CSV bytes ``data``, read as the text written.

    Labels are text: ``"01"``, ``"NA"`` and ``"None"`` stay what they are (an
    empty field is a missing label). They are read as integers when every
    label is a whole number written plainly (``1``, ``-2``, not ``01``),
    unless ``labels`` is ``"str"`` (the sidecar says they are strings).
    """
    text = pd.read_csv(
        io.BytesIO(data),
        usecols=[RUN],
        dtype=str,
        keep_default_na=False,
        index_col=False,
    )[RUN]
    values = text.to_numpy(dtype=object)
    if labels != "str" and all(
        _CANONICAL_INT.fullmatch(v) is not None for v in pd.unique(values)
    ):
        return text.astype("int64")
    return text.where(text != "")


def _without_trailing_empty(df, header):
    """``df`` without the columns of trailing separators: a header that ends
    with empty names (``run,time_s,T1_C,``) over columns without a value,
    which pandas would read as an ``Unnamed: 3`` column of NaN."""
    k = len(header) - _named_fields(header)
    if k == 0 or k > df.shape[1]:
        return df
    tail = df[df.columns[-k:]]
    # Empty, or blank (a separator written as ", ").
    blank = tail.isna() | tail.astype(str).apply(lambda c: c.str.strip() == "")
    if blank.all().all():
        return df.drop(columns=tail.columns)
    return df


def _check_utf16(path, data):
    """Refuse UTF-16 text (a byte-order mark ``FF FE``/``FE FF``, or ASCII
    text with every other byte zero, as spreadsheet "Unicode text" exports
    write it), which would read as lines of stray zero bytes."""
    head = data[:4096]
    bom = head[:2] in (b"\xff\xfe", b"\xfe\xff")
    even, odd = head[0::2], head[1::2]
    n = min(len(even), len(odd))
    # ASCII text in UTF-16: one byte of every pair zero, the other not (a
    # file padded with zero bytes has both zero).
    little = odd.count(0) >= 0.9 * n > 0 and even.count(0) <= 0.1 * n
    big = even.count(0) >= 0.9 * n > 0 and odd.count(0) <= 0.1 * n
    if bom or little or big:
        encoding = "utf-16" if bom else "utf-16-le" if little else "utf-16-be"
        raise ValueError(
            f"{path}: UTF-16 text, not UTF-8: run tables are UTF-8 CSV files. "
            "Save it as 'CSV UTF-8', or convert it: pandas.read_csv(path, "
            f"encoding={encoding!r}) and skthermal.datasets.write_runs."
        )


def _check_comments(path, data):
    """Raise naming the first comment line (``# ...``) below a CSV header: a
    logger's "# end of log" was read as a row cut short ("the file is cut
    off"), a "# pause" inside a run as a run split in two ("sort the
    table"). A comment is a record whose one field starts with ``#``: a row
    whose run label or text starts with it ("#1") is a row. Comments above
    the header are a preamble (:func:`_check_preamble`)."""
    if b"#" not in data:
        return
    text = data.decode("utf-8", errors="replace")
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except (StopIteration, csv.Error):
        return
    if not header or header[0].lstrip().startswith("#") or len(header) < 2:
        return
    try:
        for fields in reader:
            filled = [f for f in fields if f.strip()]
            if len(filled) == 1 and filled[0].lstrip().startswith("#"):
                raise ValueError(
                    f"{path}: line {reader.line_num} is a comment "
                    f"({filled[0].strip()[:60]!r}), not a row: a run table holds "
                    "rows only. Delete such lines."
                )
    except csv.Error:
        return  # _csv_fields names a malformed line


def _read_csv(path, labels=None):
    data = _raw_bytes(path)
    if not data.strip():
        raise ValueError(
            f"{path}: empty file: it holds no run table (expected a CSV header "
            "line and rows)."
        )
    _check_not_binary(path, data)
    _check_utf16(path, data)
    _check_comments(path, data)
    _check_complete(path, data)
    try:
        header = _check_header(path, data)
        _check_preamble(path, data, header)
        with warnings.catch_warnings():
            # A row with more fields than the header: pandas drops the extra
            # fields (index_col=False) and says so with this warning.
            warnings.simplefilter("error", pd.errors.ParserWarning)
            try:
                df = pd.read_csv(io.BytesIO(data), index_col=False, **_CSV_OPTIONS)
            except pd.errors.ParserWarning as exc:
                raise _long_line_error(path, data, len(header), exc) from None
        df = _without_trailing_empty(df, header)
        if RUN in df.columns:
            df[RUN] = _csv_run_labels(data, labels)
        return df
    except UnicodeDecodeError as exc:
        if b"\x00" not in data[: 1 << 16]:  # text in another encoding
            try:
                data.decode("utf-8")
                at = exc.start
            except UnicodeDecodeError as whole:
                at = whole.start
            byte = data[at : at + 1]
            line = data.count(b"\n", 0, at) + 1
            raise ValueError(
                f"{path}: a text file, but not UTF-8: line {line} holds the byte "
                f"0x{byte.hex()} ({byte.decode('cp1252', errors='replace')!r} in "
                "Windows-1252/Latin-1). Run tables are UTF-8 text: save the file "
                "as UTF-8 (e.g. pandas.read_csv(path, encoding='cp1252') and "
                "write_runs)."
            ) from exc
        raise ValueError(
            f"{path}: not a UTF-8 text CSV run table ({exc}); use .csv, .csv.gz "
            "or .parquet."
        ) from exc
    except pd.errors.ParserError as exc:
        if re.search(r"Expected \d+ fields in line \d+", str(exc)):
            n_header = _named_fields(_csv_fields(_first_line(data), path))
            raise _long_line_error(path, data, n_header, exc) from None
        raise ValueError(f"{path}: not a well-formed CSV file: {exc}") from exc


def _read_table(path, labels=None):
    """Read the run table at ``path``, naming the file in every error.

    ``labels="str"`` reads the run labels of a CSV file as strings even when
    they are all whole numbers."""
    if not path.is_file():
        what = "a folder, not a file" if path.is_dir() else "no such file"
        raise FileNotFoundError(f"No run table file at {path} ({what}).")
    if path.stat().st_size == 0:
        raise ValueError(f"{path}: empty file (0 bytes): it holds no run table.")
    if not _is_parquet(path):
        return _read_csv(path, labels)
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
    """Metadata as a DataFrame with a ``run`` column, from the accepted forms.

    Metadata without records (an empty DataFrame, dict or list) is a frame
    with a ``run`` column and no rows."""
    if isinstance(meta, pd.DataFrame):
        frame = meta
        if RUN not in frame.columns and RUN in frame.index.names:
            frame = frame.reset_index()
    elif isinstance(meta, dict):
        flat = [run for run, fields in meta.items() if not isinstance(fields, dict)]
        if flat:
            raise ValueError(
                "Run metadata as a dict maps every run to its fields, "
                "{run: {field: value}}; got "
                f"{flat[0]!r}: {meta[flat[0]]!r}. For the same fields on every "
                "run write {run: {...} for run in runs}."
            )
        frame = pd.DataFrame.from_records(
            [{RUN: run, **dict(fields)} for run, fields in meta.items()]
        )
    else:
        frame = pd.DataFrame.from_records(list(meta))
    if RUN not in frame.columns and len(frame) == 0:
        frame = frame.reindex(columns=[RUN, *frame.columns])
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


# The sidecar field that says the run labels of a CSV table are strings
# although every one is a whole number (which CSV would read back as ints).
_LABELS_FIELD = "run_labels"


def _sidecar_document(meta, df):
    """The sidecar of ``df`` with the metadata ``meta`` as a JSON-ready dict,
    or None when there is nothing to write (no records, no top-level
    fields). Raises, before anything is written, unless every run the
    metadata describes is in ``df``."""
    frame = _meta_records(meta)
    if len(frame):
        if RUN not in df.columns:
            raise ValueError("Run metadata needs a 'run' column in the table.")
        unknown = sorted(set(frame[RUN]) - set(df[RUN]), key=str)
        if unknown:
            raise ValueError(
                f"Run metadata describes run(s) {[plain(r) for r in unknown]} "
                "that are not in the table."
            )
    document = {
        str(k): _jsonable(v)
        for k, v in frame.attrs.items()
        if k not in ("runs", _LABELS_FIELD)
    }
    if not len(frame) and not document:
        return None
    columns = [RUN, *(c for c in frame.columns if c != RUN)]
    document["runs"] = [
        {str(k): _jsonable(v) for k, v in zip(columns, row, strict=True)}
        for row in frame[columns].itertuples(index=False, name=None)
    ]
    return document


def _check_label_types(labels, kinds, where, hint=""):
    """Raise unless every run label is an instance of ``kinds`` (and not a
    bool); return the distinct labels. ``where`` and ``hint`` word the
    message for the file format."""
    unique = pd.unique(labels.to_numpy(dtype=object))
    for value in unique:
        if isinstance(value, bool | np.bool_) or not isinstance(value, kinds):
            raise ValueError(
                f"Run label {plain(value)!r} ({type(value).__name__}) cannot be "
                f"written {where}: run labels are strings or integers "
                "(DATA_FORMAT). Convert them, e.g. "
                f"df['run'] = df['run'].astype(str){hint}."
            )
    return unique


def _check_csv_labels(labels):
    """Raise unless the run labels read back from CSV as written; return True
    when they are strings that would read back as integers (all whole
    numbers), which the sidecar must then record."""
    unique = _check_label_types(
        labels, str | Integral, "to CSV and read back as it is", ", or write Parquet"
    )
    for value in unique:
        if isinstance(value, str) and value == "":
            raise ValueError(
                "Run label '' (an empty string) cannot be written to CSV: an "
                "empty field reads back as a missing label. Name the run."
            )
        if isinstance(value, Integral) and abs(int(value)) >= 10**18:
            raise ValueError(
                f"Run label {int(value)} cannot be written to CSV and read back "
                "as it is: a whole number of more than 18 digits reads back as "
                "text. "
                "Convert the labels, e.g. df['run'] = df['run'].astype(str), "
                "or write Parquet."
            )
    return all(
        isinstance(v, str) and _CANONICAL_INT.fullmatch(v) is not None for v in unique
    )


def _write_document(path, document):
    with open(_sidecar_path(path), "w", encoding="utf-8") as fh:
        json.dump(document, fh, indent=2, ensure_ascii=False)
        fh.write("\n")


def _read_sidecar(path):
    """The metadata of the sidecar of ``path`` (an empty frame without one)
    and how it says the run labels are written: ``"str"`` when it records
    that they are strings, or when it describes runs and all by strings;
    else None."""
    sidecar = _sidecar_path(path)
    if not sidecar.exists():
        return pd.DataFrame({RUN: []}), None
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
    labels = attrs.pop(_LABELS_FIELD, None)
    if labels not in (None, "str"):
        raise ValueError(
            f"Metadata sidecar {sidecar}: {_LABELS_FIELD!r} must be 'str' (the "
            f"run labels are strings), got {labels!r}."
        )
    try:
        frame = _meta_records(document)
    except ValueError as exc:
        raise ValueError(f"Metadata sidecar {sidecar}: {exc}") from exc
    frame = frame[[RUN, *(c for c in frame.columns if c != RUN)]]
    frame.attrs.update(attrs)
    if labels is None and len(frame) and all(isinstance(r, str) for r in frame[RUN]):
        labels = "str"
    return frame, labels


def read_runs(path, *, validate=True, metadata=False, allow_missing_sensors=False):
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
    allow_missing_sensors : bool, default=False
        With ``validate``: sensor columns may have missing values, as in
        :func:`validate_runs` (e.g. for a model that reads only some of
        them, or holds over a dropout).

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
        rules (see :func:`validate_runs`); or, with ``metadata=True``, if the
        sidecar is malformed. Every message starts with the file's path (or
        the sidecar's). A CSV whose header uses another separator (``;``),
        names a column twice, or with rows holding more fields than the
        header is refused with a message naming the problem.

    See Also
    --------
    write_runs, validate_runs

    Notes
    -----
    The sidecar is a JSON object ``{"runs": [{"run": ..., "machine": ...},
    ...], ...}`` (a bare list of records is accepted too); run labels keep
    their JSON type, so label the runs the same way in the table and in the
    sidecar.

    CSV keeps no types, so the run labels of a CSV file are read as the text
    written: ``"01"``, ``"NA"`` or ``"None"`` are labels like any other (an
    empty field is a missing label). When every label is a whole number
    written plainly (``1``, ``2``, not ``01``) they are read as integers,
    unless the sidecar says they are strings: its field ``"run_labels":
    "str"`` (written by :func:`write_runs` for such string labels) or run
    records labelled by strings.

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
    # The sidecar also says how the run labels of a CSV file are typed; its
    # own problems are raised only when the metadata is asked for.
    try:
        meta, labels = _read_sidecar(path)
        problem = None
    except (ValueError, OSError) as exc:
        meta, labels, problem = None, None, exc
    df = _read_table(path, labels)
    if validate:
        try:
            check_run_table(
                df,
                allow_missing_sensors=allow_missing_sensors,
                missing_hint=SKIP_VALIDATION,
            )
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from exc
    if metadata:
        if problem is not None:
            raise problem
        return df, meta
    return df


def write_runs(df, path, *, metadata=None, validate=True, allow_missing_sensors=False):
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
        ``run`` key. Every run it names must be in ``df``; this is checked
        before any file is written. Metadata without records (and without
        ``attrs``), as :func:`read_runs` returns for a file without sidecar,
        writes no sidecar. Without metadata, a sidecar left by an earlier file
        at ``path`` is removed so that stale metadata never describes new
        data.
    validate : bool, default=True
        Check ``df`` with :func:`validate_runs` before writing.
    allow_missing_sensors : bool, default=False
        With ``validate``: sensor columns may have missing values (written
        as empty fields), as in :func:`validate_runs`.

    Raises
    ------
    ValueError
        If ``df`` is not a valid run table or the metadata is not keyed by
        runs of ``df``; if run labels are missing or of mixed kinds (``1``
        and ``"1"`` are the same text in CSV and Parquet alike), also with
        ``validate=False``; for CSV, if a run label would not read back as
        written: an empty string, a label that is neither a string nor an
        integer (a float, a bool). Nothing is written then.

    See Also
    --------
    read_runs

    Notes
    -----
    CSV run labels are read back as text, or as integers when all are whole
    numbers (see :func:`read_runs`). String labels that are all whole numbers
    (``"1"``, ``"2"``) are therefore recorded in the sidecar as strings
    (``"run_labels": "str"``), which writes a sidecar even without metadata,
    so that they read back as strings.

    Examples
    --------
    See :func:`read_runs`.
    """
    if validate:
        check_run_table(
            df,
            allow_missing_sensors=allow_missing_sensors,
            missing_hint=SKIP_VALIDATION,
        )
    else:
        check_frame(df)
    path = Path(path)
    check_table_name(path)
    # Check the metadata and the labels before touching any file.
    document = None if metadata is None else _sidecar_document(metadata, df)
    if RUN in df.columns:  # missing labels or mixed kinds, for every format
        check_label_kinds(df[RUN])
    if not _is_parquet(path) and RUN in df.columns and _check_csv_labels(df[RUN]):
        document = {_LABELS_FIELD: "str"} | (document or {"runs": []})
    if _is_parquet(path):
        if RUN in df.columns:  # numbers and text; not tuples (pyarrow's error)
            _check_label_types(df[RUN], str | Real, "to Parquet")
        try:
            df.to_parquet(path, index=False)
        except ImportError as exc:
            raise _parquet_error(exc) from exc
    else:
        df.to_csv(path, index=False)
    if document is not None:
        _write_document(path, document)
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
