"""Optuna structure searches of skthermal models, scored by run-wise CV.

:func:`run_search` draws parameters from a search space, scores each draw by
cross-validation over whole runs (``GroupKFold`` on the run labels) and lets
Optuna steer the draws. The study can live in memory, in a SQLite file, in a
journal file shared by processes on one machine, or in any database that
SQLAlchemy reaches (PostgreSQL, MySQL) shared by workers on many machines:
every worker runs the same call against the same storage and study name.
"""

import ast
import contextlib
import hashlib
import json
import math
import numbers
import os
import re
import socket
import threading
import time
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.base import clone
from sklearn.model_selection import GroupKFold
from sklearn.pipeline import Pipeline
from sklearn.utils._param_validation import (
    HasMethods,
    Interval,
    StrOptions,
    validate_params,
)

from skthermal._naming import listed, plain, qualified_name, suggest
from skthermal._optional import import_optional
from skthermal._versions import package_versions
from skthermal.metrics import get_scorer
from skthermal.model_selection._spaces import (
    PrefixedSpace,
    _default_space_name,
    combine_spaces,
    describe_space,
    refusal,
    search_space,
    space_names,
    space_ranges,
    space_values,
)
from skthermal.utils._runs import with_run_index
from skthermal.utils._warnings import user_stacklevel, without_figures
from skthermal.utils._wrappers import transform_output

_SQLITE_SUFFIXES = (".db", ".sqlite", ".sqlite3")
_JOURNAL_SUFFIXES = (".log", ".journal", ".jsonl")
_DEFAULT_HEARTBEAT = 60  # seconds; a dead worker's trial fails after 2 minutes
_CREATE_ATTEMPTS = 5

# Trial user attributes identifying the worker process that ran the trial.
ATTR_HOST = "worker_host"
ATTR_PID = "worker_pid"
ATTR_START = "worker_start"
# The estimator parameters a trial was scored with, as drawn by the space
# (``{name: text}``, :func:`_setting_text`; and their reprs, to read them
# back), so that a space function changed since cannot replay it into other
# settings than were scored.
ATTR_PARAMS = "skthermal_params"
ATTR_PARAMS_REPR = "skthermal_params_repr"
# The seeds (``random_state``, ints or None) a trial's models were fitted
# with: free to differ between workers, so the refit of the best trial takes
# them from the trial, not from the refitting call.
ATTR_SEEDS = "skthermal_seeds"


def _import_optuna():
    return import_optional(
        "optuna", extra="optuna", caller="skthermal.model_selection searches"
    )


@contextlib.contextmanager
def _no_experimental_warning():
    """Hide Optuna's ExperimentalWarning (its heartbeat API is experimental)."""
    optuna = _import_optuna()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        yield


# --------------------------------------------------------------------------
# Storage
# --------------------------------------------------------------------------


# The schemes of the database URLs a study is stored under (SQLAlchemy's,
# with an optional driver): a storage starting so without "://" is a typo
# of a URL, not a file path (a Windows drive letter is one letter).
_DATABASE_SCHEME = r"(sqlite|postgres(ql)?|mysql|mariadb|oracle|mssql)(\+\w+)?:"

# How a refusal to join a stored study says the way out (the command line
# puts its option names in its place).
OTHER_STUDY = "another study_name (or storage)"


@validate_params(
    {
        "spec": "no_validation",
        "heartbeat_interval": [
            Interval(numbers.Integral, 1, None, closed="left"),
            StrOptions({"auto"}),
            None,
        ],
        "grace_period": [Interval(numbers.Integral, 1, None, closed="left"), None],
        "max_retry": [Interval(numbers.Integral, 0, None, closed="left"), None],
    },
    prefer_skip_nested_validation=True,
)
def make_storage(spec, *, heartbeat_interval="auto", grace_period=None, max_retry=None):
    """An Optuna storage from a path or URL.

    Parameters
    ----------
    spec : None, str, path-like or optuna storage
        ``None``: in memory (one process). A path ending in ``.db``,
        ``.sqlite`` or ``.sqlite3``, or a ``sqlite:///`` URL: a SQLite file
        (processes on one machine, local disk). A path ending in ``.log``,
        ``.journal`` or ``.jsonl``: an Optuna journal file
        (``JournalStorage`` with a ``JournalFileBackend``; processes on one
        machine, also on file systems where SQLite locking is unreliable).
        Any other URL, e.g. ``postgresql://user:password@host/db``: that
        database through SQLAlchemy (workers on several machines; needs the
        database driver, e.g. ``psycopg2``). An Optuna storage object is
        returned unchanged.
    heartbeat_interval : int, "auto" or None, default="auto"
        Database storages only: seconds between the heartbeats a running
        trial records. A trial whose heartbeat is older than ``grace_period``
        (its worker was killed or lost) is marked failed by the next worker
        that starts a trial. ``"auto"``: 60 s. None disables heartbeats.
    grace_period : int, optional
        Seconds without heartbeat before a trial counts as stale; default
        twice ``heartbeat_interval``.
    max_retry : int, optional
        With heartbeats, re-queue a stale trial's parameters up to this many
        times (Optuna's ``RetryHeartbeatStaleTrialCallback``).

    Returns
    -------
    optuna.storages.BaseStorage or None

    Notes
    -----
    The journal storage has no heartbeat; :func:`fail_stale_trials` fails
    its trials whose worker process on this machine has died instead, and
    :func:`run_search` calls it before searching.

    Examples
    --------
    >>> import os, tempfile
    >>> from skthermal.model_selection import make_storage
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     sqlite = make_storage(os.path.join(folder, "study.db"))
    ...     journal = make_storage(os.path.join(folder, "study.log"))
    >>> type(sqlite).__name__, sqlite.heartbeat_interval
    ('RDBStorage', 60)
    >>> type(journal).__name__
    'JournalStorage'
    >>> make_storage(None) is None
    True
    """
    optuna = _import_optuna()
    if spec is None:
        _check_no_heartbeat_options(
            "a study in memory has no heartbeats",
            grace_period,
            max_retry,
            heartbeat_interval,
        )
        return spec
    if isinstance(spec, optuna.storages.BaseStorage):
        return spec
    if not isinstance(spec, str | os.PathLike):
        raise TypeError(
            f"storage must be None, a path, a URL or an Optuna storage, got "
            f"{type(spec).__name__}."
        )
    text = os.fspath(spec)
    lower = text.lower()
    if "://" not in text and re.match(_DATABASE_SCHEME, lower):
        # "sqlite:/study.db" was taken for a path in a folder "sqlite:".
        scheme = text.split(":", 1)[0]
        raise ValueError(
            f"storage {text!r}: a database URL takes '://' after its scheme, "
            f"e.g. {scheme}:///study.db (SQLite: three slashes before a "
            "relative path, four before an absolute one)."
        )
    if "://" not in text:
        folder = os.path.dirname(os.path.abspath(text))
        if not os.path.isdir(folder):
            raise ValueError(
                f"storage {text!r}: the folder {folder!r} does not exist; create "
                "it first (the study file is made in it)."
            )
        if lower.endswith(_JOURNAL_SUFFIXES):
            _check_no_heartbeat_options(
                "a journal file has no heartbeats",
                grace_period,
                max_retry,
                heartbeat_interval,
            )
            _check_journal_file(text)
            return _journal_storage(optuna, text)
        if not lower.endswith(_SQLITE_SUFFIXES):
            raise ValueError(
                f"Cannot tell the storage kind of {text!r}: use a path ending in "
                f"{' / '.join(_SQLITE_SUFFIXES)} (SQLite) or "
                f"{' / '.join(_JOURNAL_SUFFIXES)} (journal file), or a database "
                "URL such as sqlite:///study.db or postgresql://user@host/db."
            )
        _check_sqlite_file(text)
        text = "sqlite:///" + os.path.abspath(text)
    return _rdb_storage(optuna, text, heartbeat_interval, grace_period, max_retry)


def _check_no_heartbeat_options(why, grace_period, max_retry, interval="auto"):
    """Warn of heartbeat options a storage ignores, saying ``why`` (an
    ``interval`` other than the default "auto" or None is one)."""
    options = (
        ("heartbeat_interval", None if interval == "auto" else interval),
        ("grace_period", grace_period),
        ("max_retry", max_retry),
    )
    given = [name for name, value in options if value is not None]
    if given:
        warnings.warn(
            f"{' and '.join(given)} ignored: {why}. Stale trials are failed "
            "when a worker starts (fail_stale_trials); for retries use a "
            "database storage with heartbeat_interval.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


_NOT_A_STUDY = (
    "give a new file name (the study file is made there) or a study file "
    "of skthermal or Optuna; nothing was written to it"
)


def _check_journal_file(path):
    """Refuse an existing file at ``path`` that is not an Optuna journal
    (an application's log named .log), before anything is appended to it:
    Optuna wrote its record into it and then failed on the file's own lines
    ("Extra data: line 1 column 5"), naming neither."""
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        return
    with open(path, "rb") as f:
        first = f.readline(1 << 16)
    try:
        record = json.loads(first)
    except ValueError:
        record = None
    if not (isinstance(record, dict) and "op_code" in record):
        raise ValueError(
            f"storage {path!r}: the file exists and is not an Optuna journal "
            f"(its first line is no journal record): {_NOT_A_STUDY}."
        )


def _check_sqlite_file(path):
    """Refuse an existing file at ``path`` that is not an SQLite database
    of studies, before anything is written to it (SQLAlchemy's traceback
    named neither; another application's database got Optuna's tables)."""
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        return
    import sqlite3

    with open(path, "rb") as f:
        header = f.read(16)
    if header != b"SQLite format 3\x00":
        raise ValueError(
            f"storage {path!r}: the file exists and is not an SQLite database: "
            f"{_NOT_A_STUDY}."
        )
    query = "SELECT name FROM sqlite_master WHERE type='table'"
    try:
        uri = Path(os.path.abspath(path)).as_uri() + "?mode=ro"
        read_only = sqlite3.connect(uri, uri=True)
        with contextlib.closing(read_only) as db:
            tables = {row[0] for row in db.execute(query)}
    except sqlite3.Error as exc:
        raise ValueError(
            f"storage {path!r}: the SQLite database cannot be read ({exc}): "
            f"{_NOT_A_STUDY}."
        ) from None
    if tables and "studies" not in tables:
        raise ValueError(
            f"storage {path!r}: the SQLite database holds another application's "
            f"tables ({listed(sorted(tables), show=repr)}), no studies: "
            f"{_NOT_A_STUDY}."
        )


def _journal_storage(optuna, path):
    try:
        from optuna.storages.journal import JournalFileBackend as backend
    except ImportError:  # pragma: no cover - optuna < 4
        backend = optuna.storages.JournalFileStorage
    return optuna.storages.JournalStorage(backend(os.path.abspath(path)))


def _rdb_storage(optuna, url, heartbeat_interval, grace_period, max_retry):
    if heartbeat_interval == "auto":
        heartbeat_interval = _DEFAULT_HEARTBEAT
    if heartbeat_interval is None:
        _check_no_heartbeat_options(
            "heartbeat_interval=None switches heartbeats off", grace_period, max_retry
        )
    kwargs = {}
    if heartbeat_interval is not None:
        kwargs["heartbeat_interval"] = int(heartbeat_interval)
        if grace_period is not None:
            if grace_period <= heartbeat_interval:
                raise ValueError(
                    f"grace_period ({grace_period} s) must be longer than "
                    f"heartbeat_interval ({heartbeat_interval} s): a live worker "
                    "records a heartbeat only every heartbeat_interval, so another "
                    "worker would take its running trial for a dead one and fail "
                    "it. The default is twice heartbeat_interval."
                )
            kwargs["grace_period"] = int(grace_period)
        if max_retry is not None:
            retry = getattr(
                optuna.storages,
                "RetryHeartbeatStaleTrialCallback",
                optuna.storages.RetryFailedTrialCallback,
            )
            name = (
                "heartbeat_stale_trial_callback"
                if hasattr(optuna.storages, "RetryHeartbeatStaleTrialCallback")
                else "failed_trial_callback"
            )
            with _no_experimental_warning():
                kwargs[name] = retry(max_retry=max_retry)
    engine_kwargs = None
    if url.startswith("sqlite"):
        # Several processes share the file: wait for its lock rather than fail.
        engine_kwargs = {"connect_args": {"timeout": 60}}
    # Workers that start together on an empty database race to create Optuna's
    # tables; the losers see an integrity error and succeed on a retry.
    from sqlalchemy.exc import (
        ArgumentError,
        IntegrityError,
        NoSuchModuleError,
        OperationalError,
    )

    shown = safe_url(url)
    for attempt in range(_CREATE_ATTEMPTS):
        try:
            with _no_experimental_warning():
                return optuna.storages.RDBStorage(
                    url, engine_kwargs=engine_kwargs, **kwargs
                )
        except (NoSuchModuleError, ArgumentError) as exc:
            raise ValueError(
                f"storage {shown!r}: not a database URL SQLAlchemy knows "
                f"({exc}); write e.g. sqlite:///study.db, "
                "postgresql://user:password@host/db or mysql://user@host/db."
            ) from None
        except ValueError as exc:
            # SQLAlchemy's own parse error quotes part of the URL (of the
            # password, e.g. "invalid literal for int()" after an '@' in it).
            if not _raised_in(exc, "sqlalchemy"):
                raise
            raise ValueError(
                f"storage {shown!r}: SQLAlchemy cannot read this URL; write it as "
                "dialect://user:password@host:port/database, with any '@', ':', "
                "'/' or '%' in the user name or password percent-encoded "
                "(urllib.parse.quote_plus(password))."
            ) from None
        except ImportError as exc:
            scheme = shown.split(":", 1)[0]
            driver = _DB_DRIVERS.get(
                scheme, _DB_DRIVERS.get(scheme.split("+", 1)[0], "its database driver")
            )
            raise ValueError(
                f"storage {shown!r}: the database driver for {scheme!r} is not "
                f"installed; install {driver} in this environment ({exc})."
            ) from None
        except (IntegrityError, OperationalError) as exc:
            if attempt == _CREATE_ATTEMPTS - 1:
                raise ValueError(
                    f"storage {shown!r}: cannot open the database: "
                    f"{getattr(exc, 'orig', exc)}"
                ) from exc
            time.sleep(0.2 * (attempt + 1))


# The drivers SQLAlchemy needs for the usual database URLs.
_DB_DRIVERS = {
    "postgresql": "psycopg2-binary (or psycopg, with postgresql+psycopg://)",
    # A URL that names its driver needs that one.
    "postgresql+psycopg": "psycopg (pip install 'psycopg[binary]')",
    "postgresql+psycopg2": "psycopg2-binary",
    "mysql+pymysql": "pymysql",
    "mariadb+pymysql": "pymysql",
    "mysql": "pymysql (with mysql+pymysql://) or mysqlclient",
    "mariadb": "pymysql (with mariadb+pymysql://) or mysqlclient",
}


def _raised_in(exc, package):
    """Whether ``exc`` was raised inside ``package``'s code."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    name = "" if tb is None else tb.tb_frame.f_globals.get("__name__", "")
    return name == package or name.startswith(package + ".")


def safe_url(url):
    """``url`` without its password, for messages: everything between the
    user name's ``:`` and the last ``@`` (a password holding an unencoded
    ``@`` or ``:`` is hidden whole), and the value of a ``password`` (or
    ``sslpassword``) query parameter, which libpq and SQLAlchemy also
    read."""
    url = re.sub(r"^([A-Za-z0-9+.-]+://[^:/@]*):.*@", r"\1:***@", url)
    return re.sub(r"([?&](?:ssl)?password=)[^&#]*", r"\1***", url, flags=re.IGNORECASE)


# --------------------------------------------------------------------------
# Workers and stale trials
# --------------------------------------------------------------------------


def _process_start(pid):
    """(start time in clock ticks, state) of a process from /proc, or None."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return int(fields[19]), fields[0]


def _worker_identity():
    pid = os.getpid()
    start = _process_start(pid)
    return {
        ATTR_HOST: socket.gethostname(),
        ATTR_PID: pid,
        ATTR_START: None if start is None else start[0],
    }


def _is_alive(pid, start):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    except OSError:  # pragma: no cover - e.g. Windows without the process
        return False
    now = _process_start(pid)
    if now is None:
        return True  # no /proc: trust the signal test
    if now[1] == "Z":  # killed, waiting for its parent to collect it
        return False
    return start is None or now[0] == start


def fail_stale_trials(study, *, heartbeat=True, local_processes=True, storage=None):
    """Mark failed the running trials whose worker is gone.

    Parameters
    ----------
    study : optuna.Study
    heartbeat : bool, default=True
        Fail the trials whose heartbeat is older than the grace period
        (database storages made with a ``heartbeat_interval``; Optuna's own
        ``optuna.storages.fail_stale_trials``, which every worker also runs
        before each trial).
    local_processes : bool, default=True
        Fail the trials that a worker process on this machine started (as
        recorded by :func:`run_search` in the trial's user attributes
        ``worker_host``, ``worker_pid``, ``worker_start``) and that process
        no longer exists. This covers storages without heartbeat, such as
        the journal file. A restarted process that reused the id is told
        apart by its start time on Linux.
    storage : optuna storage, optional
        The study's storage (as :func:`make_storage` made it): a trial
        failed for its dead process is then handed to the storage's stale
        trial callback, so that ``max_retry`` re-queues its parameters as it
        does for a trial failed for its heartbeat. :func:`run_search` passes
        its own.

    Returns
    -------
    list of int
        Numbers of the trials marked failed by this call.
    """
    optuna = _import_optuna()
    running = (optuna.trial.TrialState.RUNNING,)
    before = {t.number for t in study.get_trials(deepcopy=False, states=running)}
    if heartbeat and before:
        with _no_experimental_warning():
            optuna.storages.fail_stale_trials(study)
    if local_processes and before:
        host = socket.gethostname()
        for trial in study.get_trials(deepcopy=False, states=running):
            attrs = trial.user_attrs
            if attrs.get(ATTR_HOST) != host or ATTR_PID not in attrs:
                continue
            if attrs[ATTR_PID] == os.getpid() or _is_alive(
                attrs[ATTR_PID], attrs.get(ATTR_START)
            ):
                continue
            if storage is not None:
                # Why it failed, for trials_dataframe's readers (a finished
                # trial takes no attributes: before it is told).
                study_id = storage.get_study_id_from_name(study.study_name)
                storage.set_trial_user_attr(
                    storage.get_trial_id_from_study_id_trial_number(
                        study_id, trial.number
                    ),
                    "error",
                    f"its worker (process {attrs[ATTR_PID]} on {host}) stopped "
                    "while it ran",
                )
            study.tell(
                trial.number, state=optuna.trial.TrialState.FAIL, skip_if_finished=True
            )
            retry = getattr(storage, "get_heartbeat_stale_trial_callback", None)
            callback = retry() if retry is not None else None
            if callback is not None:
                failed = study.get_trials(deepcopy=True)[trial.number]
                if failed.state == optuna.trial.TrialState.FAIL:
                    callback(study, failed)
    after = {t.number for t in study.get_trials(deepcopy=False, states=running)}
    failed = {
        t.number
        for t in study.get_trials(
            deepcopy=False, states=(optuna.trial.TrialState.FAIL,)
        )
    }
    return sorted((before - after) & failed)


# --------------------------------------------------------------------------
# The search
# --------------------------------------------------------------------------


def _wrapped(estimator):
    """The estimator a wrapper holds in its ``estimator`` parameter (the
    library's run-start and guard wrappers, scikit-learn's convention), or
    None."""
    if isinstance(estimator, Pipeline) or not hasattr(estimator, "get_params"):
        return None
    inner = estimator.get_params(deep=False).get("estimator")
    return inner if hasattr(inner, "fit") else None


def _final_step(estimator, prefix=""):
    """The last estimator of (nested) pipelines, inside wrappers
    (:func:`_wrapped`), and its parameter prefix."""
    if isinstance(estimator, Pipeline):
        name, step = estimator.steps[-1]
        return _final_step(step, f"{prefix}{name}__")
    inner = _wrapped(estimator)
    if inner is not None:
        return _final_step(inner, f"{prefix}estimator__")
    return estimator, prefix


def _infer_space(estimator):
    """The built-in spaces of an estimator, of the steps of a pipeline, or
    of the estimator a wrapper holds."""
    if isinstance(estimator, Pipeline):
        spaces = []
        for name, step in estimator.steps:
            inner = _infer_space(step)
            if inner is not None:
                spaces.append(PrefixedSpace(name, inner))
        return combine_spaces(*spaces) if spaces else None
    name = _default_space_name(estimator)
    wrapped = _wrapped(estimator) if name is None else None
    if wrapped is not None:
        inner = _infer_space(wrapped)
        return None if inner is None else PrefixedSpace("estimator", inner)
    return None if name is None else search_space(name)


def _check_target_finite(y):
    """Refuse a target with missing or infinite values once, naming the
    first (every trial failed on it one by one, up to max_failed_trials)."""
    try:
        values = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        return  # the estimator says what it makes of it
    bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
    if not bad.any():
        return
    row = int(np.flatnonzero(bad)[0])
    index = getattr(y, "index", None)
    where = f"row {row}"
    if index is not None:
        label = index[row]
        names = [n for n in (index.names or []) if n is not None]
        if names and isinstance(label, tuple):
            where += (
                " ("
                + ", ".join(
                    f"{n} {plain(v)!r}" for n, v in zip(names, label, strict=False)
                )
                + ")"
            )
    raise ValueError(
        f"y has {int(bad.sum())} missing or infinite value(s), the first at "
        f"{where}: no trial could score it. Drop those rows (X, y and groups "
        "alike) or fill them before searching."
    )


def _resolve_space(space, estimator):
    if callable(space):
        return space
    if space is None:
        inferred = _infer_space(estimator)
        if inferred is None:
            raise ValueError(
                f"No built-in search space for {type(estimator).__name__}; pass "
                "space= (a name, a callable space(trial) -> dict, or a dict "
                "mapping pipeline step names to those)."
            )
        return inferred
    if isinstance(space, str):
        return search_space(space)
    if isinstance(space, dict):
        parts = []
        for prefix, inner in space.items():
            inner = search_space(inner) if isinstance(inner, str) else inner
            if not callable(inner):
                raise TypeError(f"space[{prefix!r}] must be a name or a callable.")
            parts.append(PrefixedSpace(prefix, inner))
        return combine_spaces(*parts)
    raise TypeError(
        "space must be None, a built-in name, a callable space(trial) -> dict or a "
        f"dict of those by pipeline step, got {type(space).__name__}."
    )


def _check_space_values(space, estimator):
    """Refuse a value the built-in parts of ``space`` set that the estimator
    rejects (a choice misspelt, a fixed value out of range), before any
    trial: each trial would fail on it."""
    params = estimator.get_params(deep=True)
    for key, values in space_values(space).items():
        owner_key, _, name = key.rpartition("__")
        owner = params.get(owner_key) if owner_key else estimator
        for value in values:
            exc = refusal(type(owner), name, value)
            if exc is not None:
                own = _default_space_name(owner)
                hint = (
                    f" Is the space meant for another estimator? The built-in "
                    f"space of {type(owner).__name__} is {own!r}."
                    if own is not None and own not in space_names(space)
                    else " Give a value it accepts for this override."
                )
                raise ValueError(
                    f"The search space sets {key}={value!r}, which "
                    f"{type(owner).__name__} refuses: {exc}{hint}"
                ) from None


def _take(data, rows):
    return data.iloc[rows] if hasattr(data, "iloc") else np.asarray(data)[rows]


def _run_groups(X, groups):
    if groups is not None:
        groups = np.asarray(groups)
        n = len(X)
        if groups.ndim != 1 or groups.shape[0] != n:
            raise ValueError(
                f"groups holds {groups.shape[0] if groups.ndim else 1} run "
                f"label(s) of shape {groups.shape} for the {n} rows of X; give "
                "one label per row."
            )
        return groups
    if "run" in list(getattr(X, "columns", [])):
        return np.asarray(X["run"])
    names = getattr(getattr(X, "index", None), "names", None) or []
    if "run" in names:
        return np.asarray(X.index.get_level_values("run"))
    return None


def _resolve_cv(cv, groups):
    if cv is None or isinstance(cv, numbers.Integral):
        if groups is None:
            raise ValueError(
                "Run-wise cross-validation needs the run labels: pass groups, or X "
                "with a 'run' index level (skthermal.datasets.split_runs), or an "
                "explicit cv."
            )
        n_runs = len(np.unique(groups))
        n_splits = min(5, n_runs) if cv is None else int(cv)
        if n_splits > n_runs:
            raise ValueError(
                f"cv={n_splits} asks for more folds than there are runs "
                f"({n_runs}); each fold leaves out whole runs."
            )
        if n_splits < 2:
            raise ValueError(
                f"GroupKFold needs at least 2 runs to score on unseen runs, got "
                f"{n_runs}."
            )
        return GroupKFold(n_splits=n_splits)
    if groups is None and hasattr(cv, "split") and "Group" in type(cv).__name__:
        raise ValueError(
            f"cv={type(cv).__name__}(...) leaves out groups of rows, and there "
            "are no run labels: pass groups, or X with a 'run' column or index "
            "level (skthermal.datasets.split_runs)."
        )
    return cv


def _warn_groups_cut_runs(X, groups):
    """Warn when the ``groups`` given cut a run of X's own run labels (its
    ``run`` column or index level) in two or more: folds over ``groups``
    may then train and score on one run, and a sequence model, which reads
    X's runs, fails on every fold."""
    own = _run_groups(X, None)
    if own is None or groups is None:
        return
    pairs = pd.DataFrame({"run": own, "group": np.asarray(groups)})
    counts = pairs.groupby("run", sort=False)["group"].nunique()
    cut = counts[counts > 1]
    if not len(cut):
        return
    run = cut.index[0]
    labels = list(dict.fromkeys(pairs.loc[pairs["run"] == run, "group"]))
    warnings.warn(
        f"groups cuts run {plain(run)!r} of X's run labels into "
        f"{len(labels)} groups ({', '.join(repr(plain(g)) for g in labels[:4])}"
        f"{', ...' if len(labels) > 4 else ''}; {len(cut)} run(s) cut in all): "
        "folds over these groups may train and score on one run, which "
        "scores optimistically, and a sequence model, which reads X's runs, "
        "fails. Give one group per run, or leave groups out (X's run labels "
        "are used).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_cut_runs(splits, groups):
    """Warn when a fold scores rows of a run it also trains on, with several
    runs at hand (a row-wise KFold): the score then says how a run goes on,
    not how a new run is predicted."""
    if groups is None or len(np.unique(groups)) < 2:
        return
    groups = np.asarray(groups)
    for k, (train, test) in enumerate(splits):
        shared = np.intersect1d(groups[np.asarray(train)], groups[np.asarray(test)])
        if shared.size:
            warnings.warn(
                f"The folds cut runs: fold {k} scores rows of run "
                f"{plain(shared[0])!r} that it also trains on ({shared.size} "
                "such run(s)). The score then says how a run goes on, not how a "
                "new run is predicted, and comes out optimistic (four times "
                "in an independent check); GroupKFold over the runs (the "
                "default cv) scores whole runs left out.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
            return


class _PruningCallback:
    """ANFIS ``epoch_callback`` reporting the monitored error to the trial,
    after calling the estimator's own ``epoch_callback`` (``user``), if any:
    training stops when either asks."""

    def __init__(self, trial, sign, user=None):
        self.trial = trial
        self.sign = sign
        self.user = user
        self.pruned_at = None

    def __call__(self, epoch, train_rmse, check_rmse):
        stop = False
        if self.user is not None:
            stop = bool(self.user(epoch, train_rmse, check_rmse))
        error = train_rmse if check_rmse is None else check_rmse
        if not math.isfinite(error):
            return stop
        self.trial.report(self.sign * error, epoch)
        if self.trial.should_prune():
            self.pruned_at = epoch
            return True
        return stop


class _FailureGuard:
    """Optuna callback stopping the study once ``limit`` trials of this call
    failed in a row (a complete or pruned trial resets the count); the
    objective hands it each failure's exception (``record``)."""

    def __init__(self, limit):
        self.limit = limit
        self.lock = threading.Lock()
        self.errors = {}  # trial number -> exception, until its callback
        self.in_a_row = 0
        self.first = None  # (frozen trial, exception) opening the failures
        self.tripped = None  # ``first`` when the limit was reached

    def record(self, number, exc):
        with self.lock:
            self.errors[number] = exc

    def __call__(self, study, trial):
        optuna = _import_optuna()
        with self.lock:
            exc = self.errors.pop(trial.number, None)
            if trial.state == optuna.trial.TrialState.FAIL:
                if self.in_a_row == 0:
                    self.first = (trial, exc)
                self.in_a_row += 1
                if self.in_a_row >= self.limit and self.tripped is None:
                    self.tripped = self.first
                    study.stop()
            else:
                self.in_a_row = 0
                self.first = None

    def raise_if_tripped(self):
        if self.tripped is None:
            return
        trial, exc = self.tripped
        error = trial.user_attrs.get("error")
        if error is None:
            what = "recorded no error (Optuna failed it, e.g. for a NaN value)"
        else:
            fold = trial.user_attrs.get("error_fold")
            what = f"failed in fold {fold}: {error.rstrip('.')}"
        raise ValueError(
            f"The search stopped: {self.limit} trials in a row failed in this call "
            f"(max_failed_trials={self.limit}). The first of them, trial "
            f"{trial.number}, {what}. Fix the estimator, the data or the search "
            "space (every failed trial keeps its error in the user attribute "
            "'error'), or raise max_failed_trials."
        ) from exc


class _Objective:
    def __init__(self, estimator, space, X, y, splits, scorer, pruning, sign, guard):
        self.estimator = estimator
        self.space = space
        self.X = X
        self.y = y
        self.splits = splits
        self.scorer = scorer
        self.pruning = pruning
        self.sign = sign
        self.guard = guard
        self.warned = False
        self.warned_empty = False
        # What the fits warned, said once per search (without its figures):
        # None with threads (n_jobs > 1), where recording warnings is not
        # safe; they then pass as they come.
        self.said = set()

    def _recording(self):
        """A context recording the warnings of a fold's fit and scoring
        (for :meth:`_say_once`), or none with threads."""
        if self.said is None:
            return contextlib.nullcontext([])
        # The filters stay as set: a warning the user made an error fails
        # its trial there, as without recording.
        return warnings.catch_warnings(record=True)

    def _say_once(self, caught, quiet=False):
        """Say each warning of ``caught`` not said in an earlier fold or
        trial (the same text with other figures is the same warning: a
        count of rows, a loss ratio), so a search of many trials does not
        repeat one warning per trial and fold. A warning the filters make
        an error raises it (inside the trial's ``try``: the trial fails);
        with ``quiet`` (the trial ends anyway) it is dropped."""
        for w in caught:
            key = (w.category, without_figures(str(w.message)))
            if key not in self.said:
                self.said.add(key)
                try:
                    warnings.warn_explicit(
                        w.message, w.category, w.filename, w.lineno, source=w.source
                    )
                except Warning:
                    if not quiet:
                        raise

    def _warn_training_error(self, validation_fraction):
        """Once per search: pruning ANFIS by its training error."""
        if self.warned or validation_fraction:
            return
        self.warned = True
        warnings.warn(
            "The pruner judges each ANFIS epoch by its training RMSE: the "
            "ANFISRegressor has no validation_fraction. The training error "
            "keeps falling where the held-out error does not, so trials that "
            "would generalise better can be pruned. Set validation_fraction "
            "(e.g. 0.2) so that the pruner sees held-out rows of the training "
            "runs.",
            UserWarning,
            stacklevel=2,
        )

    def __call__(self, trial):
        optuna = _import_optuna()
        for key, value in _worker_identity().items():
            trial.set_user_attr(key, value)
        try:
            params = self.space(trial)
        except ValueError as exc:
            if not (_raised_in(exc, "optuna") and "distribution" in str(exc)):
                raise
            # Optuna's message names no parameter, and came from 14 frames
            # deep (an independent check).
            drawn = sorted(trial.params)
            raise ValueError(
                f"The search space drew one Optuna name with two kinds of "
                f"distribution in trial {trial.number} (Optuna: {exc}): a name "
                "must keep its kind and range in every trial. Give each kind "
                "of draw its own name (e.g. 'x_int', 'x_float'). Drawn before "
                f"it in this trial: {drawn or 'nothing'}."
            ) from None
        if not isinstance(params, Mapping):
            raise TypeError(
                f"The search space returned {type(params).__name__}, not a dict "
                "of estimator parameters: a space function returns {name: value} "
                "drawn from the trial (e.g. {'n_clusters': "
                "trial.suggest_int('n_clusters', 2, 6)})."
            )
        trial.set_user_attr(ATTR_PARAMS, _param_text(params))
        trial.set_user_attr(
            ATTR_PARAMS_REPR, {str(k): repr(v) for k, v in params.items()}
        )
        trial.set_user_attr(ATTR_SEEDS, _seeds(self.estimator))
        if not params and not self.warned_empty:
            self.warned_empty = True
            warnings.warn(
                "The search space draws no parameter: every trial fits the same "
                "model. Give the space the parameters to search.",
                UserWarning,
                stacklevel=2,
            )
        try:
            base = clone(self.estimator).set_params(**params)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"The search space drew parameters the estimator does not take: {exc}"
            ) from exc
        scores = []
        for fold, (train, test) in enumerate(self.splits):
            model = clone(base)
            hook = None
            if self.pruning == "epochs" and fold == 0:
                _, prefix = _final_step(model)
                params = model.get_params()
                self._warn_training_error(params[f"{prefix}validation_fraction"])
                key = f"{prefix}epoch_callback"
                hook = _PruningCallback(trial, self.sign, params[key])
                model.set_params(**{key: hook})
            caught = []
            try:
                with self._recording() as caught:
                    model.fit(_take(self.X, train), _take(self.y, train))
                    if hook is not None and hook.pruned_at is not None:
                        raise optuna.TrialPruned(
                            f"pruned at epoch {hook.pruned_at} of the first fold"
                        )
                    score = float(
                        self.scorer(model, _take(self.X, test), _take(self.y, test))
                    )
                self._say_once(caught or [])
            except optuna.TrialPruned:
                self._say_once(caught or [], quiet=True)
                raise
            except KeyboardInterrupt:
                # Optuna stores the trial as failed, and stops the study: the
                # record says why (a killed worker leaves none).
                trial.set_user_attr(
                    "error", f"interrupted (KeyboardInterrupt) in fold {fold}"
                )
                trial.set_user_attr("error_fold", fold)
                raise
            except Exception as exc:  # a bad draw fails the trial, not the study
                trial.set_user_attr("error", f"{type(exc).__name__}: {exc}")
                trial.set_user_attr("error_fold", fold)
                self.guard.record(trial.number, exc)
                # Raised as the cause of the failure, which Optuna logs and
                # records (the study's optimize catches it).
                self._say_once(caught or [], quiet=True)
                raise _TrialFailed(f"fold {fold}: {type(exc).__name__}: {exc}") from exc
            scores.append(score)
            if self.pruning == "folds":
                trial.report(float(np.mean(scores)), fold + 1)
                if trial.should_prune():
                    raise optuna.TrialPruned(f"pruned after fold {fold + 1}")
        trial.set_user_attr("fold_scores", scores)
        return float(np.mean(scores))


class _TrialFailed(Exception):
    """A trial's model failed to fit or score (the trial fails, not the
    study)."""


# What a stored study records of the search that made it, so that another
# search does not join it by a clash of names: scores are comparable only for
# the same model, scoring, target, inputs, folds and rows.
_SETUP_KEYS = (
    "skthermal_estimator",
    "skthermal_settings",
    "skthermal_space",
    "skthermal_space_ranges",
    "skthermal_scoring",
    "skthermal_target",
    "skthermal_features",
    "skthermal_cv",
    "skthermal_data",
)


def _estimator_kind(estimator):
    """The classes of an estimator and of the estimators inside it (not
    their settings: workers may seed them differently)."""
    inner = sorted(
        {
            type(v).__name__
            for v in estimator.get_params(deep=True).values()
            if hasattr(v, "fit")
        }
    )
    return type(estimator).__name__ + (f"({', '.join(inner)})" if inner else "")


# Settings that do not change a trial's score (or differ per process): not
# recorded.
_FREE_SETTINGS = ("random_state", "n_jobs", "verbose")


def _seeds(estimator):
    """The estimator's seeds that a trial can record, ``{name: int or
    None}`` (a ``RandomState`` instance cannot be recorded and is left
    out)."""
    out = {}
    for name, value in estimator.get_params(deep=True).items():
        if name.rsplit("__", 1)[-1] != "random_state":
            continue
        if value is None or isinstance(value, numbers.Integral):
            out[name] = None if value is None else int(value)
    return out


def _warn_unseeded(estimator, searched):
    """Warn when a seed of ``estimator`` is None and the space does not set
    it (``searched``): every fit then draws its own start, so the trials'
    scores are not reproducible and the refitted best model is not the one
    scored (an independent check: best score -3.78, the same parameters
    -3.90 to -3.93 when scored again)."""
    params = {**estimator.get_params(deep=True), **searched}
    unseeded = [
        name
        for name, value in _seeds(estimator).items()
        if value is None and name not in searched and _draws(params, name)
    ]
    if unseeded:
        warnings.warn(
            f"{listed(unseeded, show=repr)} of {type(estimator).__name__} "
            f"{'is' if len(unseeded) == 1 else 'are'} None: every fit draws its "
            "own start, so the trials' scores cannot be reproduced and the "
            "refitted best estimator is not the model that was scored "
            "(random_state= of run_search seeds the sampler only). Give the "
            f"estimator a seed, e.g. set_params({unseeded[0]}=0).",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


# Settings under which the library's estimators draw no random numbers,
# whatever their random_state: {parameter: values}.
_DETERMINISTIC = {"calibration": ("varpro", "ls"), "init": ("grid",)}


def _draws(params, seed):
    """Whether the estimator owning the parameter ``seed`` (``a__random_state``)
    may draw random numbers with the settings ``params``: not a grey model
    calibrated by variable projection or least squares, nor an ANFIS with a
    grid rule base (given as "grid" or as membership functions)."""
    prefix = seed[: -len("random_state")]
    for name, values in _DETERMINISTIC.items():
        value = params.get(prefix + name)
        if isinstance(value, str) and value in values:
            return False
        if name == "init" and value is not None and not isinstance(value, str):
            return False  # initial grid membership functions given
    return True


def _seeds_of(trial, estimator):
    """The seeds ``trial`` was scored with where they differ from the
    ``estimator``'s, with a warning naming them; {} when they agree or the
    trial recorded none (made by an older skthermal)."""
    recorded = trial.user_attrs.get(ATTR_SEEDS)
    if not isinstance(recorded, Mapping):
        return {}
    now = _seeds(estimator)
    differ = {k: v for k, v in recorded.items() if k in now and now[k] != v}
    if differ:
        said = ", ".join(
            f"{k}={v!r} (this search: {now[k]!r})" for k, v in differ.items()
        )
        warnings.warn(
            f"The best trial (number {trial.number}) was scored with {said}: "
            "another seed (another worker's, or an earlier session's). The best "
            "estimator is refitted with the trial's seed, so that it is the "
            "model that was scored.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    return differ


def _canonical(value):
    """``value`` as plain JSON data that is the same in every process:
    numpy scalars and arrays as numbers and lists, tuples as lists, dicts
    with sorted keys, functions by module and qualified name, other objects
    by their repr without memory addresses."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, np.ndarray):
        return _canonical(value.tolist())
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in sorted(value.items(), key=str)}
    if callable(value) and hasattr(value, "__qualname__"):
        return {"callable": qualified_name(value)}
    return {"repr": re.sub(r" at 0x[0-9a-fA-F]+", "", repr(value))}


def _setting_text(value):
    """A parameter's value as text, equal for equal values in any process
    (:func:`_canonical`): ``np.float64(0.1)`` and ``0.1``, ``(1, 2)`` and
    ``[1, 2]``, a function in two processes."""
    return json.dumps(_canonical(value), sort_keys=True)


def _holds_estimator(value):
    """Whether ``value`` is an estimator or a list/tuple holding one (a
    Pipeline's ``steps``): its settings are recorded one by one."""
    if hasattr(value, "fit"):
        return True
    if isinstance(value, list | tuple):
        return any(_holds_estimator(v) for v in value)
    return False


def _estimator_settings(estimator):
    """The estimator's settings as text, ``{name: text}`` (nested ones by
    their ``step__name``; :func:`_setting_text`), but for those free to
    differ between workers (seeds, parallelism, verbosity, callbacks) and
    estimators (in :func:`_estimator_kind`; their settings are listed by
    name)."""
    out = {}
    params = estimator.get_params(deep=True)
    for name, value in params.items():
        last = name.rsplit("__", 1)[-1]
        if last in _FREE_SETTINGS or "callback" in last:
            continue
        if _holds_estimator(value):
            continue
        out[name] = _setting_text(value)
    # A step's output container (set_output, or the process's global
    # transform_output) decides whether the run index reaches a sequence
    # model behind it, so the scores: recorded unless the default.
    steps = [("", estimator)] + [(n, v) for n, v in params.items() if hasattr(v, "fit")]
    for name, step in steps:
        output = transform_output(step)
        if output not in (None, "default"):
            out[f"{name}.transform_output" if name else "transform_output"] = (
                _setting_text(output)
            )
    return out


def _scoring_name(scoring):
    """The scoring as the same in every process: a name, or a callable's
    module and qualified name (its repr holds a memory address)."""
    if scoring is None or isinstance(scoring, str):
        return str(scoring)
    if hasattr(scoring, "_score_func"):  # make_scorer: its repr has no address
        return repr(scoring)
    return qualified_name(scoring)


def _target_name(y):
    name = getattr(y, "name", None)
    if name is None and hasattr(y, "columns"):
        name = ",".join(map(str, y.columns))
    return "" if name is None else str(name)


def _feature_names(X):
    """X's column names when they are all strings (scikit-learn's rule for
    ``feature_names_in_``), else the number of unnamed columns."""
    columns = getattr(X, "columns", None)
    if (
        columns is not None
        and len(columns)
        and all(isinstance(c, str) for c in columns)
    ):
        return [str(c) for c in columns]
    shape = np.shape(X)
    return f"{shape[1] if len(shape) > 1 else 1} unnamed columns"


def _cv_kind(cv, splits):
    kind = type(cv).__name__ if hasattr(cv, "split") else "given folds"
    return f"{kind}, {len(splits)} folds"


def _data_fingerprint(X, groups, splits):
    """Rows, runs and a hash of the run labels (in row order) and of the
    folds' rows: equal for the same runs split the same way."""
    digest = hashlib.sha256()
    if groups is not None:
        digest.update("\x1f".join(map(str, groups)).encode())
    for train, test in splits:
        digest.update(b"\x1e" + np.asarray(train, dtype="<i8").tobytes())
        digest.update(b"\x1d" + np.asarray(test, dtype="<i8").tobytes())
    runs = "" if groups is None else f", {len(dict.fromkeys(groups))} runs"
    return f"{len(X)} rows{runs}, run labels and folds {digest.hexdigest()[:16]}"


def _search_setup(estimator, space, scoring, X, y, groups, cv, splits):
    """What :func:`run_search` records in a study (``_SETUP_KEYS``); ``X``
    as the caller gave it (its column names)."""
    values = (
        _estimator_kind(estimator),
        _estimator_settings(estimator),
        describe_space(space),
        _canonical(space_ranges(space)),
        _scoring_name(scoring),
        _target_name(y),
        _feature_names(X),
        _cv_kind(cv, splits),
        _data_fingerprint(X, groups, splits),
    )
    return dict(zip(_SETUP_KEYS, values, strict=True))


def _skthermal_version():
    return package_versions(("skthermal",))["skthermal"]


def _flat(value, path=""):
    """Plain JSON data as ``{path: leaf}``: dicts by key, lists of dicts by
    position (a list of values is one leaf)."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            out.update(_flat(v, f"{path}.{k}" if path else str(k)))
        return out
    if isinstance(value, list) and any(isinstance(v, dict) for v in value):
        out = {}
        for i, v in enumerate(value):
            out.update(_flat(v, f"{path}[{i}]"))
        return out
    return {path: value}


def _describe_difference(key, there, here):
    what = key.removeprefix("skthermal_")
    if key == "skthermal_space_ranges":
        a, b = _flat(there), _flat(here)
        parts = [
            f"{k} {a.get(k, 'unset')} there, {b.get(k, 'unset')} here"
            for k in sorted(set(a) | set(b))
            if a.get(k) != b.get(k)
        ]
        return "search space ranges: " + listed(parts, 4, sep="; ", more_sep="; ")
    if (
        key == "skthermal_features"
        and isinstance(there, list)
        and isinstance(here, list)
    ):
        only_there = [c for c in there if c not in here]
        only_here = [c for c in here if c not in there]
        if only_there or only_here:
            return f"features: only there {only_there}, only here {only_here}"
        return f"features in the order {there} there, {here} here"
    if key == "skthermal_settings":
        names = sorted(set(there) | set(here))
        parts = [
            f"{n} {there.get(n, 'unset')} there, {here.get(n, 'unset')} here"
            for n in names
            if there.get(n) != here.get(n)
        ]
        return "estimator settings: " + listed(parts, 4, sep="; ", more_sep="; ")
    return f"{what} {there!r} there, {here!r} here"


def _searched_names(study, space):
    """The estimator parameters the search space sets: those a stored trial
    recorded, else those of one draw of the space on a scratch study (a
    worker joining a study whose first trial has not started yet)."""
    optuna = _import_optuna()
    for trial in study.get_trials(deepcopy=False):
        recorded = trial.user_attrs.get(ATTR_PARAMS)
        if recorded is not None:
            return set(recorded)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            optuna.logging.disable_default_handler()
            try:
                draw = space(optuna.create_study().ask())
            finally:
                optuna.logging.enable_default_handler()
        return set(draw) if isinstance(draw, Mapping) else set()
    except Exception:  # noqa: BLE001 - the search itself names a bad space
        return set()


def _check_study_setup(study, setup, direction, space=None):
    """Record the search's setup (``_search_setup``) in a new study; refuse
    to join a study that another search made, naming what differs. A study
    holding trials but not (all of) the keys, made by an older skthermal or
    outside :func:`run_search`, is joined with a warning and the missing
    keys are recorded."""
    directions = [d.name.lower() for d in study.directions]
    if directions != [direction]:
        raise ValueError(
            f"Study {study.study_name!r} was made to {' and '.join(directions)}, "
            f"this search gives direction={direction!r}: give the study's "
            f"direction, or {OTHER_STUDY}."
        )
    # Trials first: a search records its keys before its first trial, so a
    # trial seen here means that its keys are visible below.
    n_trials = len(study.get_trials(deepcopy=False))
    stored = dict(study.user_attrs)
    key = "skthermal_settings"
    if key in stored and stored[key] != setup[key] and space is not None:
        # What the space sets is drawn per trial: its fixed value may differ.
        searched = _searched_names(study, space)
        there = {k: v for k, v in stored[key].items() if k not in searched}
        here = {k: v for k, v in setup[key].items() if k not in searched}
        stored[key], setup = there, {**setup, key: here}
    compared = dict(setup)
    if "skthermal_space_ranges" in stored:
        # The ranges in full decide: the space's text lists only what
        # differs from the defaults of the version that wrote it.
        compared.pop("skthermal_space")
    if (
        stored.get("skthermal_estimator", setup["skthermal_estimator"])
        != setup["skthermal_estimator"]
    ):
        # Another model: its settings and search space differ with it.
        for follows in (
            "skthermal_settings",
            "skthermal_space",
            "skthermal_space_ranges",
        ):
            compared.pop(follows, None)
    differ = [
        _describe_difference(key, stored[key], value)
        for key, value in compared.items()
        if key in stored and stored[key] != value
    ]
    if differ:
        raise ValueError(
            f"Study {study.study_name!r} was made by another search ("
            + "; ".join(differ)
            + f"): its trials cannot be compared with this one's. Give {OTHER_STUDY}."
        )
    missing = [key for key in setup if key not in stored]
    if missing and n_trials:
        names = ", ".join(key.removeprefix("skthermal_") for key in missing)
        warnings.warn(
            f"Study {study.study_name!r} holds {n_trials} trial(s) but does not "
            f"record their {names} (made by an older skthermal or outside "
            "run_search): cannot check that its trials are comparable with this "
            "search's. This search records its own; later searches are checked "
            "against them.",
            UserWarning,
            stacklevel=4,
        )
    return missing


# How long a search joining a study without a recorded setup or trials
# waits for the search that made it to record its setup (s): that one
# records it within milliseconds of making the study, before its first
# trial; a study made outside run_search (optuna create-study) costs a
# joining worker this wait once.
SETUP_WAIT_S = 2.0


def _open_study(optuna, store, name, load_if_exists, **kwargs):
    """The study ``name`` of ``store``, made by this search or joined.

    Two searches started together on a new name both found no setup to
    check and both recorded theirs, mixing incomparable trials (an
    independent check: 3 of 4 tries with a journal file). Making the study
    is atomic in the storage (one of them gets ``DuplicatedStudyError``),
    so the search that made it records its setup, and one that joins a
    study without a recorded setup or trials waits up to
    :data:`SETUP_WAIT_S` for it before checking against it."""
    if store is None or not load_if_exists:
        try:
            return optuna.create_study(
                storage=store, study_name=name, load_if_exists=load_if_exists, **kwargs
            )
        except optuna.exceptions.DuplicatedStudyError:
            # Optuna's text advises its own command line's --skip-if-exists.
            raise ValueError(
                f"The storage already holds a study {name!r}, and "
                "load_if_exists=False does not join one: give another "
                "study_name, or load_if_exists=True to add trials to it."
            ) from None
    try:
        return optuna.create_study(
            storage=store, study_name=name, load_if_exists=False, **kwargs
        )
    except optuna.exceptions.DuplicatedStudyError:
        study = optuna.create_study(
            storage=store, study_name=name, load_if_exists=True, **kwargs
        )
    deadline = time.monotonic() + SETUP_WAIT_S
    while (
        "skthermal_version" not in study.user_attrs
        and not study.get_trials(deepcopy=False)
        and time.monotonic() < deadline
    ):
        time.sleep(0.05)
    return study


def _record_setup(study, setup, missing):
    """Record the ``missing`` keys of the search's setup in the study, and
    the skthermal version that made it (not compared: a new version may
    join a study of an older one with the same setup)."""
    for key in missing:
        study.set_user_attr(key, setup[key])
    if "skthermal_version" not in study.user_attrs:
        study.set_user_attr("skthermal_version", _skthermal_version())


def _param_text(params):
    """``{name: text}`` (:func:`_setting_text`): estimator parameters as a
    trial records them."""
    return {str(k): _setting_text(v) for k, v in params.items()}


def _replay(space, trial, *, warn=True):
    """The estimator parameters of a stored trial, drawn again by ``space``;
    they must be those the trial was scored with (else those, read back from
    the trial, with a warning when ``warn``)."""
    optuna = _import_optuna()
    try:
        params = space(optuna.trial.FixedTrial(trial.params))
    except Exception as exc:  # e.g. a shared study searched another space
        # Optuna's own advice ("set it at the construction of the FixedTrial
        # object") is about its internals, not the user's study.
        why = str(exc).split(" Please set it at the construction")[0]
        raise ValueError(
            f"The best trial (number {trial.number}) has parameters "
            f"{trial.params} that this search space cannot replay ({why}): "
            "the study was searched with another space (made outside "
            f"run_search, or by another version of this space). Give {OTHER_STUDY}."
        ) from exc
    scored = trial.user_attrs.get(ATTR_PARAMS)
    if scored is None or not isinstance(params, Mapping):
        return params
    now = _param_text(params)
    if now == scored:
        return params
    differ = "; ".join(
        f"{k} {scored.get(k, 'unset')} scored, {now.get(k, 'unset')} now"
        for k in sorted(set(scored) | set(now))
        if scored.get(k) != now.get(k)
    )
    try:
        reprs = trial.user_attrs[ATTR_PARAMS_REPR]
        params = {k: ast.literal_eval(v) for k, v in reprs.items()}
    except (KeyError, ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        raise ValueError(
            f"The best trial (number {trial.number}) was scored with other "
            f"estimator parameters than this search space draws from its values "
            f"({differ}): the space function changed since. Restore it, or give "
            f"{OTHER_STUDY}."
        ) from None
    if not warn:
        return params
    warnings.warn(
        f"The best trial (number {trial.number}) was scored with other estimator "
        f"parameters than this search space draws from its values ({differ}): "
        "the space function changed since, or it does not draw every setting "
        "from the trial. The parameters it was scored with are used.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return params


class SearchResult:
    """Outcome of :func:`run_search`.

    Attributes
    ----------
    study : optuna.Study
        The study (all trials, of every worker).
    best_params_ : dict or None
        Estimator parameters of the best trial, ready for ``set_params``
        (replayed through the search space, so e.g. tuples come back as
        tuples); None if no trial completed.
    best_score_ : float or None
        Its mean cross-validation score.
    best_trial_ : optuna.trial.FrozenTrial or None
    best_estimator_ : estimator or None
        The estimator with ``best_params_`` refitted on all the data
        (``refit=True``).
    scoring : str or callable
        The scoring used.
    """

    def __init__(self, study, best_params, best_trial, best_estimator, scoring):
        self.study = study
        self.best_params_ = best_params
        self.best_trial_ = best_trial
        self.best_score_ = None if best_trial is None else best_trial.value
        self.best_estimator_ = best_estimator
        self.scoring = scoring

    def trials_dataframe(self, **kwargs):
        """All trials as a DataFrame (``optuna.Study.trials_dataframe``).

        Returns
        -------
        pandas.DataFrame
        """
        return self.study.trials_dataframe(**kwargs)

    def __repr__(self):
        n = len(self.study.trials)
        return (
            f"SearchResult(study={self.study.study_name!r}, n_trials={n}, "
            f"best_score_={self.best_score_!r}, best_params_={self.best_params_!r})"
        )


def check_stored_study(
    store, study_name, storage, said=("n_trials=0", "study_name", "storage")
):
    """Refitting a stored study's best trial (``n_trials=0``) reads a stored
    study: one that is not there (a typo of its name) is an error, before an
    empty study of that name is stored. ``store``: the Optuna storage made
    from ``storage`` (None without one); ``said``: how the caller names the
    trial count, the study name and the storage (the command line's
    options)."""
    optuna = _import_optuna()
    trials, name_option, storage_option = said
    if store is None:
        raise ValueError(
            f"{trials} runs no trial: it refits the best trial of a stored "
            f"study, so it needs {storage_option} and the {name_option} of a "
            "study there."
        )
    names = optuna.study.get_all_study_names(storage=store)
    if study_name in names:
        return
    where = (
        safe_url(os.fspath(storage))
        if isinstance(storage, (str, os.PathLike))
        else repr(storage)
    )
    held = (
        "holds no study"
        if not names
        else f"holds {len(names)} other stud{'y' if len(names) == 1 else 'ies'} ("
        + ", ".join(repr(n) for n in sorted(names)[:5])
        + (", ..." if len(names) > 5 else "")
        + ")"
    )
    raise ValueError(
        f"{trials} refits the best trial of the stored study {study_name!r} "
        f"({name_option}), but the {storage_option} {where} {held}"
        f"{suggest(study_name, names)}; nothing was stored."
    )


def no_best_trial(study):
    """Why a study has no best trial, by the states of its trials."""
    trials = study.get_trials(deepcopy=False)
    if not trials:
        return (
            "No best trial: the study holds no trial (this call ran none, and "
            "none were stored before)."
        )
    counts = {}
    for trial in trials:
        state = trial.state.name.lower()
        counts[state] = counts.get(state, 0) + 1
    states = ", ".join(f"{n} {state}" for state, n in counts.items())
    hint = (
        "; a failed trial's user attribute 'error' holds its model's error when "
        "it raised one (none when the score was NaN, or its worker died)"
        if "fail" in counts
        else ""
    )
    return (
        f"No best trial: none of the study's {len(trials)} trial(s) completed "
        f"({states}){hint}."
    )


def _resolve_pruning(pruning, study, estimator):
    optuna = _import_optuna()
    last, _ = _final_step(estimator)
    is_anfis = type(last).__name__ == "ANFISRegressor" and hasattr(
        last, "epoch_callback"
    )
    if pruning == "auto":
        if isinstance(study.pruner, optuna.pruners.NopPruner):
            return None
        return "epochs" if is_anfis else "folds"
    if pruning in (None, False):
        return None
    if pruning == "epochs" and not is_anfis:
        raise ValueError(
            "pruning='epochs' needs an ANFISRegressor as the estimator or the "
            f"last pipeline step, got {type(last).__name__}."
        )
    if pruning not in ("epochs", "folds"):
        raise ValueError(
            f"pruning must be 'auto', 'epochs', 'folds' or None, got {pruning!r}."
        )
    return pruning


@validate_params(
    {
        "estimator": [HasMethods(["fit"])],
        "X": ["array-like"],
        "y": ["array-like"],
        "groups": ["array-like", None],
        "space": [None, str, callable, dict],
        "n_trials": [Interval(numbers.Integral, 0, None, closed="left"), None],
        "cv": ["cv_object"],
        "scoring": [str, callable],
        "storage": "no_validation",
        "study_name": [str, None],
        "direction": [StrOptions({"maximize", "minimize"})],
        "sampler": "no_validation",
        "pruner": "no_validation",
        "pruning": [StrOptions({"auto", "epochs", "folds"}), None],
        "timeout": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "total_trials": [Interval(numbers.Integral, 1, None, closed="left"), None],
        "max_failed_trials": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_jobs": [numbers.Integral],
        "random_state": [Interval(numbers.Integral, 0, None, closed="left"), None],
        "load_if_exists": ["boolean"],
        "heartbeat_interval": "no_validation",
        "grace_period": "no_validation",
        "max_retry": "no_validation",
        "fail_stale": ["boolean"],
        "refit": ["boolean"],
        "callbacks": [list, None],
    },
    prefer_skip_nested_validation=False,
)
def run_search(
    estimator,
    X,
    y,
    *,
    groups=None,
    space=None,
    n_trials=20,
    cv=None,
    scoring="neg_rmse",
    storage=None,
    study_name=None,
    direction="maximize",
    sampler=None,
    pruner=None,
    pruning="auto",
    timeout=None,
    total_trials=None,
    max_failed_trials=20,
    n_jobs=1,
    random_state=None,
    load_if_exists=True,
    heartbeat_interval="auto",
    grace_period=None,
    max_retry=None,
    fail_stale=True,
    refit=True,
    callbacks=None,
):
    """Search the structure of a model with Optuna, scoring by run-wise CV.

    Every trial draws parameters from ``space``, sets them on a clone of
    ``estimator`` and scores it by cross-validation over whole runs; the
    objective is the mean test score. Several processes or machines can run
    the same call against one ``storage`` and ``study_name``: they share the
    trials and each adds ``n_trials``.

    Parameters
    ----------
    estimator : estimator
        A skthermal estimator or a pipeline. Run-aware estimators read the run
        boundaries from a ``run`` level of X's index, so pass X as returned by
        :func:`skthermal.datasets.split_runs`.
    X : DataFrame or array-like of shape (n_samples, n_features)
    y : Series, DataFrame or array-like
    groups : array-like of shape (n_samples,), optional
        Run labels for the splitter; default: the ``run`` level of X's index.
    space : None, str, callable or dict, default=None
        The parameters to search: a callable ``space(trial) -> dict`` of
        ``set_params`` keywords; a built-in name (:func:`search_space`); a
        dict mapping pipeline step names to names or callables (e.g.
        ``{"fcmclusterpicker": "fcm_picker", "anfisregressor": "anfis"}``);
        or None for the built-in spaces of the estimator or of every pipeline
        step that has one.
    n_trials : int or None, default=20
        Trials run by this call (this worker). None: until ``timeout`` or
        ``total_trials``, one of which is then required. 0 runs none: the
        result (and refit) of the trials already in a stored study.
    cv : int, cross-validation generator or iterable, optional
        Default ``GroupKFold(n_splits=min(5, n_runs))`` over the runs; an int
        sets the number of folds. The folds must be the same for every
        trial (and every worker), so do not shuffle without a fixed seed.
    scoring : str or callable, default="neg_rmse"
        A :func:`skthermal.metrics.get_scorer` name (thermal or scikit-learn)
        or a scorer ``scorer(estimator, X, y)``; greater is better.
    storage : None, str, path-like or optuna storage, optional
        Where the study lives, see :func:`make_storage`: None (memory), a
        ``.db``/``.sqlite`` path or ``sqlite:///`` URL, a ``.log``/``.journal``
        journal file, or a database URL (``postgresql://...``).
    study_name : str, optional
        Required with a storage: the name every worker uses.
    direction : {"maximize", "minimize"}, default="maximize"
        "maximize" suits every scorer name (errors are negated), and with a
        scorer name "minimize" is an error (it would pick the worst trial);
        "minimize" is for a scoring callable whose smaller values are
        better. Joining a stored study, it must be the study's direction.
    sampler : optuna sampler, optional
        Default: Optuna's ``TPESampler``, with ``random_state`` seeded anew
        for every trial from the seed and the trial's number (unique in a
        study): a search in one process draws the same points at every run,
        several workers started together with the same seed draw different
        points, and a resumed study draws new ones. A sampler given here
        is used as it is (several workers with one seeded sampler draw the
        same first trials).
    pruner : optuna pruner, optional
        Default: no pruning. E.g. ``optuna.pruners.MedianPruner()``.
    pruning : {"auto", "epochs", "folds"} or None, default="auto"
        What is reported to the pruner. ``"epochs"``: per training epoch of
        the first fold, the ANFIS monitored error (checking RMSE with
        ``validation_fraction``, else training RMSE), negated when
        maximizing; ``"folds"``: after each fold, the mean test score so far.
        ``"auto"``: ``"epochs"`` when the estimator or the last pipeline step
        is an :class:`~skthermal.fuzzy.ANFISRegressor`, else ``"folds"``;
        nothing when there is no pruner.
    timeout : float, optional
        Stop starting trials after this many seconds.
    total_trials : int, optional
        Stop when the study holds this many complete or pruned trials (over
        all workers), Optuna's ``MaxTrialsCallback``. Failed trials do not
        count; ``max_failed_trials`` ends a search whose trials keep failing.
    max_failed_trials : int, default=20
        Raise a ValueError naming the first of them when this many trials of
        this call (this worker; ``n_jobs`` threads together) fail in a row. A
        complete or pruned trial of this call resets the count; other
        workers' trials do not count.
    n_jobs : int, default=1
        Trials run in parallel threads of this process (Optuna's
        ``n_jobs``); for more throughput start more processes instead.
    random_state : int or None, default=None
        Seed of the default sampler (not of the estimator: an estimator
        whose ``random_state`` is None, and not set by the space, warns).
    load_if_exists : bool, default=True
        Join the study if it exists (how workers share it).
    heartbeat_interval, grace_period, max_retry
        Passed to :func:`make_storage` (which validates them) when
        ``storage`` is a path or URL.
    fail_stale : bool, default=True
        Before searching, mark failed the trials left running by dead workers
        (:func:`fail_stale_trials`).
    refit : bool, default=True
        Refit the best parameters on all of X, y (``best_estimator_``). The
        refitted estimator keeps an ``epoch_callback`` of ``estimator``, never
        the pruning one.
    callbacks : list of callable, optional
        Passed to ``Study.optimize``.

    Returns
    -------
    SearchResult
        ``study``, ``best_params_``, ``best_score_``, ``best_trial_``,
        ``best_estimator_`` and ``trials_dataframe()``.

    See Also
    --------
    search_space : The built-in spaces.
    make_storage : Storages from paths and URLs.

    Notes
    -----
    A draw the estimator rejects (e.g. more clusters than sensors) fails its
    trial, with the error in the trial's user attribute ``"error"``; the
    search goes on, until ``max_failed_trials`` trials fail in a row. Every
    trial records the worker's host name and process id (user attributes
    ``worker_host``, ``worker_pid``) and its fold scores (``fold_scores``).

    Per-epoch pruning only watches the first fold: the pruner compares the
    trials at equal epochs of the same training data, which is sound, while
    reports from later folds would mix folds of different difficulty at one
    step. The other folds run in full once the first survives. An
    ``epoch_callback`` of the estimator is kept: it is called before the
    pruning callback in the first fold, and either can stop training.

    A stored study records the estimator's classes, the search space (a
    built-in space with its overrides, or a callable's module and name), the
    scoring, the target, the feature names (or their number), the kind and
    number of folds, and the rows (their number, the runs, and a hash of the
    run labels and of the folds' rows); joining it with a search that
    differs in any of them, or in ``direction``, raises a ValueError naming
    what differs: the best trial of another space cannot be replayed or
    compared.

    Examples
    --------
    >>> import optuna
    >>> from skthermal.datasets import make_sensor_groups, split_runs
    >>> from skthermal.fuzzy import ANFISRegressor
    >>> from skthermal.model_selection import run_search, search_space
    >>> optuna.logging.set_verbosity(optuna.logging.WARNING)
    >>> runs, _ = make_sensor_groups(n_groups=2, sensors_per_group=2, n_noise=1,
    ...                              n_runs=3, n_samples=60, random_state=0)
    >>> X, y, groups = split_runs(runs)
    >>> space = search_space("anfis", init="fcm", n_clusters=(2, 3), epochs=(3, 6))
    >>> result = run_search(ANFISRegressor(random_state=0), X, y, groups=groups,
    ...                     space=space, n_trials=3, random_state=0)
    >>> len(result.study.trials), sorted(result.best_params_)
    (3, ['epochs', 'init', 'mf', 'n_clusters', 'step_size'])
    >>> bool(result.best_score_ < 0)  # negated RMSE
    True
    """
    optuna = _import_optuna()
    if n_trials is None and total_trials is None and timeout is None:
        raise ValueError(
            "run_search(n_trials=None) would never stop: pass total_trials (the "
            "trials of the study over all workers), timeout (seconds), or an "
            "int n_trials."
        )
    if isinstance(scoring, str) and direction == "minimize":
        # A named scorer is greater-is-better (errors come negated): its
        # minimum is the worst trial.
        raise ValueError(
            f"scoring={scoring!r} is greater-is-better (scikit-learn negates "
            "errors, as in 'neg_rmse'), so direction='minimize' would pick the "
            "worst trial; use direction='maximize' (the default), or a scoring "
            "callable whose smaller values are better."
        )
    _check_target_finite(y)
    space = _resolve_space(space, estimator)
    _check_space_values(space, estimator)
    said = groups is not None  # run labels the user gave explicitly
    groups = _run_groups(X, groups)
    if said:
        _warn_groups_cut_runs(X, groups)
    given_X = X
    X = with_run_index(X, groups)
    cv = _resolve_cv(cv, groups)
    with warnings.catch_warnings():
        # The run labels (from X's index) go to every splitter; one that does
        # not use them (TimeSeriesSplit) need not say so to a user who gave
        # none.
        if not said:
            warnings.filterwarnings("ignore", message="The groups parameter is ignored")
        splits = list(
            cv.split(X, y, groups) if hasattr(cv, "split") else cv  # iterable of folds
        )
    _warn_cut_runs(splits, groups)
    scorer = get_scorer(scoring)
    setup = _search_setup(estimator, space, scoring, given_X, y, groups, cv, splits)

    store = make_storage(
        storage,
        heartbeat_interval=heartbeat_interval,
        grace_period=grace_period,
        max_retry=max_retry,
    )
    if store is not None and study_name is None:
        raise ValueError(
            "Give study_name with a storage: it is how other workers, and later "
            "sessions, find the study."
        )
    if n_trials == 0 and (store is None or load_if_exists):
        check_stored_study(store, study_name, storage)
    if pruner is None:
        pruner = optuna.pruners.NopPruner()
    study = _open_study(
        optuna,
        store,
        study_name,
        load_if_exists,
        direction=direction,
        sampler=sampler,
        pruner=pruner,
    )
    missing = _check_study_setup(study, setup, direction, space)
    complete = (optuna.trial.TrialState.COMPLETE,)
    if study.get_trials(deepcopy=False, states=complete):
        # A space that cannot replay the study's best trial (a callable
        # changed between sessions, a study searched with another space)
        # fails now, before adding trials or records.
        _replay(space, study.best_trial, warn=False)
    _record_setup(study, setup, missing)
    if fail_stale and store is not None:
        fail_stale_trials(study, storage=store)
    if sampler is None:
        # Seeded per trial: workers started together with one seed, and a
        # later session resuming the study, draw new points.
        if random_state is None:
            study.sampler = optuna.samplers.TPESampler()
        else:
            from skthermal.model_selection._sampler import TrialSeededSampler

            study.sampler = TrialSeededSampler(random_state)

    mode = _resolve_pruning(pruning, study, estimator)
    sign = -1.0 if direction == "maximize" else 1.0
    guard = _FailureGuard(max_failed_trials)
    objective = _Objective(estimator, space, X, y, splits, scorer, mode, sign, guard)
    if n_jobs != 1:
        objective.said = None
    all_callbacks = [*(callbacks or []), guard]
    if total_trials is not None:
        counted = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
        all_callbacks.append(
            optuna.study.MaxTrialsCallback(total_trials, states=counted)
        )
        if len(study.get_trials(deepcopy=False, states=counted)) >= total_trials:
            n_trials = 0
    if n_trials is None or n_trials > 0:
        study.optimize(
            objective,
            n_trials=n_trials,
            timeout=timeout,
            n_jobs=n_jobs,
            callbacks=all_callbacks,
            catch=(_TrialFailed,),
        )
        guard.raise_if_tripped()

    best_trial = best_params = best_estimator = None
    try:
        best_trial = study.best_trial
    except ValueError:
        warnings.warn(no_best_trial(study), UserWarning, stacklevel=3)
    if best_trial is not None:
        best_params = _replay(space, best_trial)
        _warn_unseeded(estimator, best_params)
        if refit:
            seeds = _seeds_of(best_trial, estimator)
            best_estimator = clone(estimator).set_params(**{**seeds, **best_params})
            best_estimator.fit(X, y)
    return SearchResult(study, best_params, best_trial, best_estimator, scoring)
