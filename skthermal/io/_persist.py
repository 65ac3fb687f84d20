"""Safe deployment files: fitted models saved with skops, loaded without pickle.

A pickle (or joblib) file runs whatever code it names when it is loaded, so it
must only be opened when its origin is trusted. :func:`save` writes the model
with :mod:`skops.io` instead, whose loader rebuilds objects from a schema and
refuses every type it was not told to trust. :func:`load` trusts exactly the
skops defaults (builtins, numpy, scipy, scikit-learn) plus the classes that
skthermal itself defines, so skthermal models load without listing their
types; anything else in the file has to be named by the caller. The file also
records the versions it was written with, and :func:`load` warns when they
differ from the installed ones.
"""

import copy
import functools
import importlib
import importlib.util
import json
import os
import sys
import types
import warnings
import zipfile
import zlib

import numpy as np

from skthermal._naming import qualified_name
from skthermal._optional import import_optional
from skthermal._versions import package_versions
from skthermal.utils._runs import sequence_models
from skthermal.utils._wrappers import own_transform_output, transform_output

_METADATA_NAME = "skthermal_metadata.json"
_FORMAT = 1


class SkthermalVersionWarning(UserWarning):
    """A model file was written by other skthermal or scikit-learn versions.

    The model may still load and predict identically, but nothing guarantees
    it: refit it with the installed versions, or compare its predictions on
    known data before using it.
    """


class UntrustedTypesError(ValueError):
    """A model file holds types that :func:`load` does not trust by default.

    Attributes
    ----------
    types : list of str
        The fully qualified names of the untrusted types.
    """

    def __init__(self, message, types):
        super().__init__(message)
        self.types = list(types)


def _skops_io():
    return import_optional("skops.io", caller="skthermal.io")


def _versions():
    import skthermal

    versions = package_versions(["scikit-learn", "numpy", "scipy", "skops"])
    # The running package, not the installed distribution's metadata: a source
    # checkout may not match what pip recorded.
    return {"skthermal": skthermal.__version__, **versions}


def _type_name(t):
    if isinstance(t, str):
        return t
    if isinstance(t, type):
        return qualified_name(t)
    raise TypeError(
        f"trusted must hold type names (str) or classes, got {type(t).__name__}."
    )


# Plain containers from scikit-learn that skops does not list by default but
# that run no code of their own (``Bunch`` is a dict with attribute access,
# used by composite estimators such as ModularRegressor).
_ALSO_TRUSTED = ("sklearn.utils._bunch.Bunch",)


def _is_skthermal_class(name):
    """Whether ``name`` is a class defined in one of skthermal's subpackages.

    ``import skthermal`` is lazy, so the subpackage named by ``name`` is
    imported here. Only subpackages (folders of the installed package) are
    imported, never a top-level module named by a file: ``skthermal.__main__``
    would run the command line.
    """
    module, _, attr = name.rpartition(".")
    parts = module.split(".")
    if parts[0] != "skthermal" or len(parts) < 2:
        return False
    package = f"skthermal.{parts[1]}"
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return False
    if spec is None or spec.submodule_search_locations is None:
        return False
    importlib.import_module(package)
    mod = sys.modules.get(module)
    obj = getattr(mod, attr, None) if mod is not None else None
    return isinstance(obj, type) and obj.__module__ == module


_EXPECTED = "expected a .skops file written by skthermal.io.save (a zip archive)"
_PICKLE_HINT = (
    "loading a pickle or joblib file runs any code it names: only if you trust "
    "where it comes from, load it with joblib.load (or pickle.load) and save it "
    "again with skthermal.io.save."
)
# Leading bytes of the compressed streams joblib writes with compress=...:
# zlib (four header variants), gzip, xz and lzma; bz2 is checked apart.
_COMPRESSED = (
    b"\x78\x01",
    b"\x78\x5e",
    b"\x78\x9c",
    b"\x78\xda",
    b"\x1f\x8b",
    b"\xfd7zXZ\x00",
    b"\x5d\x00\x00",
)


def _is_compressed(head):
    is_bz2 = head.startswith(b"BZh") and head[4:10] == b"1AY&SY"
    return is_bz2 or head.startswith(_COMPRESSED)


_DAMAGED = " Write or copy it again."


def _not_skops(path, what, hint=""):
    return ValueError(f"{path} is not a skops model file: {what}; {_EXPECTED}.{hint}")


def _check_file(path):
    """Raise a plain error naming ``path`` unless it is a skops zip archive.

    Tells an empty, cut-off or foreign file (a pickle, a joblib dump, text)
    apart from a model file before any zip or skops code sees it.
    """
    if not os.path.isfile(path):
        what = "a folder" if os.path.isdir(path) else "no such file"
        raise FileNotFoundError(f"No model file at {path} ({what}); {_EXPECTED}.")
    if os.path.getsize(path) == 0:
        raise _not_skops(path, "empty file (0 bytes)")
    with open(path, "rb") as fh:
        head = fh.read(512)
    if zipfile.is_zipfile(path):
        try:
            with zipfile.ZipFile(path) as archive:
                names = archive.namelist()
                # Every member read and its checksum compared: a damaged
                # copy is told here, not by a decompressor deep in skops.
                bad = archive.testzip()
        except (zipfile.BadZipFile, OSError, zlib.error, EOFError) as exc:
            raise _not_skops(
                path, f"it is a damaged zip archive ({exc})", _DAMAGED
            ) from exc
        if bad is not None:
            raise _not_skops(
                path, f"it is a damaged zip archive (member {bad!r})", _DAMAGED
            )
        if "schema.json" not in names:
            raise _not_skops(path, "it is a zip archive without skops' schema.json")
        return
    if head.startswith(b"PK\x03\x04"):
        what = "the file is cut off (a zip archive whose end is missing)"
        hint = " Write or copy it again."
    elif head[:1] == b"\x80" and head[1:2] in (b"\x02", b"\x03", b"\x04", b"\x05"):
        what, hint = "it is a pickle (or joblib) file", " Note: " + _PICKLE_HINT
    elif _is_compressed(head):
        what = "it holds compressed data, such as a compressed joblib file"
        hint = " If it is a joblib file, note: " + _PICKLE_HINT
    elif b"\x00" not in head:
        text = head.decode("utf-8", errors="replace").strip()
        shown = text if len(text) <= 40 else text[:37] + "..."
        what, hint = f"it is a text file starting with {shown!r}", ""
    else:
        what, hint = "it is not a zip archive", ""
    raise _not_skops(path, what, hint)


# The dict keys a skops file gives back as they were: skops writes the keys
# as JSON text and rebuilds each with its type from that text, which only
# these types (and numpy's) survive; a bool comes back True.
_KEY_TYPES = (str, int, float)


def _walk(obj, where, seen):
    """``(where, value)`` for ``obj`` and everything inside it that a skops
    file holds: its attributes (skthermal and scikit-learn objects, as they
    pickle), lists, tuples and dicts, recursively, each object once."""
    if id(obj) in seen:
        return
    seen.add(id(obj))
    yield where, obj
    if isinstance(obj, dict):
        children = ((f"[{k!r}]", v) for k, v in obj.items())
    elif isinstance(obj, list | tuple):
        children = ((f"[{i}]", v) for i, v in enumerate(obj))
    elif isinstance(obj, functools.partial):
        children = [(".func", obj.func), (".args", obj.args)]
        children += [(".keywords", obj.keywords)]
    elif type(obj).__module__.split(".")[0] in ("skthermal", "sklearn"):
        # What pickling (and so skops) stores: an ANFISRegressor leaves out
        # its epoch_callback.
        state = obj.__getstate__() if hasattr(obj, "__getstate__") else None
        if not isinstance(state, dict):
            state = getattr(obj, "__dict__", {})
        children = ((f".{k}", v) for k, v in state.items())
    else:
        return
    for name, value in children:
        yield from _walk(value, where + name, seen)


def _bad_dict_key(model):
    """``(where, key)`` of the first dict key inside ``model`` that a skops
    file cannot hold, or None."""
    for where, obj in _walk(model, type(model).__name__, set()):
        if not isinstance(obj, dict):
            continue
        for key in obj:
            # skops writes a numpy scalar key as its Python value.
            value = key.item() if isinstance(key, np.generic) else key
            if type(value) not in _KEY_TYPES:
                return where, key
    return None


# Attributes a skops file does not hold: scikit-learn's metadata requests
# (they hold the estimator itself, a cycle skops recurses into without end)
# and a guard's kept rows of streamed runs (pandas frames, which skops cannot
# hold; a stream reloaded from the file starts its runs anew).
_NOT_SAVED = ("_metadata_request", "stream_runs_")


def _without_unsaved(model):
    """``model``, or a copy without the attributes of :data:`_NOT_SAVED`."""
    if not any(
        any(name in getattr(obj, "__dict__", {}) for name in _NOT_SAVED)
        for _, obj in _walk(model, "", set())
    ):
        return model
    model = copy.deepcopy(model)
    for _, obj in list(_walk(model, "", set())):
        for name in _NOT_SAVED:
            getattr(obj, "__dict__", {}).pop(name, None)
    return model


def _check_dict_keys(model):
    """Raise a TypeError naming the first dict key that a skops file cannot
    hold (skops would fail on it deep inside, or give back another key)."""
    found = _bad_dict_key(model)
    if found is None:
        return
    where, key = found
    raise TypeError(
        f"Cannot save {type(model).__name__}: {where} is a dict with the key "
        f"{key!r} of type {type(key).__name__}, which a skops file cannot hold "
        "(it stores dict keys as JSON text: only str, int and float come back "
        "as they were). If it is a run_states_ of a model fitted by an older "
        "skthermal (runs labelled by pandas.Timestamp, tuples or bools), "
        "refit the model with this version, which keys it by str, int or "
        "float; otherwise use str or int keys."
    )


def _code_of(obj):
    """The function or class that a skops file stores ``obj`` by (its module
    and name, imported when it loads): ``obj`` itself, a method's function,
    or the class of an instance defined in the running script; else None."""
    if isinstance(obj, types.MethodType):
        return obj.__func__
    if isinstance(obj, types.FunctionType | type):
        return obj
    if type(obj).__module__ == "__main__":
        return type(obj)
    return None


def _check_code(model):
    """Raise a TypeError naming the first lambda or local function (or
    class) inside ``model``, which a skops file stores but cannot give back;
    warn for one of the running script or notebook (``__main__``), which
    loads only where a script defines it under the same name."""
    main = None
    for where, obj in _walk(model, type(model).__name__, set()):
        target = _code_of(obj)
        if target is None:
            continue
        name = getattr(target, "__qualname__", repr(target))
        what = "class" if isinstance(target, type) else "function"
        why = (
            "a lambda"
            if "<lambda>" in name
            else f"the {what} {name}, local to another function"
            if "<locals>" in name
            else None
        )
        if why is not None:
            raise TypeError(
                f"Cannot save {type(model).__name__}: {where} is {why}, which a "
                "skops file cannot give back (it stores a function or class by "
                "its module and name, and loading imports them). Define it in a "
                "module of your own that the machine loading the file can import "
                "(e.g. my_transforms.py, installed beside skthermal), or use a "
                "scikit-learn or skthermal transformer instead."
            )
        if main is None and getattr(target, "__module__", None) == "__main__":
            main = where, f"__main__.{name}"
    if main is not None:
        where, name = main
        warnings.warn(
            f"{where} is {name}, defined in the running script or notebook: the "
            "file loads only in a script that defines it under the same name, "
            f"with load(path, trusted=[{name!r}]). For a file that loads "
            "anywhere, define it in a module of your own that the loading "
            "machine can import.",
            UserWarning,
            stacklevel=3,
        )


def _check_output_config(model):
    """Warn when scikit-learn's global ``transform_output`` is set and a
    transformer inside ``model`` carries no output setting of its own: the
    global one is not saved, so the loaded model's steps output numpy."""
    import sklearn

    output = sklearn.get_config().get("transform_output", "default")
    if output == "default":
        return
    for where, obj in _walk(model, type(model).__name__, set()):
        if transform_output(obj) is None or own_transform_output(obj) is not None:
            continue
        warnings.warn(
            f"sklearn.set_config(transform_output={output!r}) is on, but "
            f"{where} ({type(obj).__name__}) has no output setting of its own: "
            "the global setting is not saved, so where the file is loaded its "
            "steps output numpy, and a sequence model behind them loses the "
            "runs' (run, time_s) index. Call model.set_output(transform="
            f"{output!r}) before saving; that is saved with the model.",
            UserWarning,
            stacklevel=3,
        )
        return


def save(model, path, *, compress=True):
    """Save a fitted model to a skops file that loads without running code.

    Parameters
    ----------
    model : object
        Usually a fitted skthermal estimator or a pipeline holding them.
    path : str or path-like
        File to write (conventionally ``*.skops``); overwritten if present.
    compress : bool, default=True
        Deflate the archive members.

    Returns
    -------
    path : str
        The path written.

    Raises
    ------
    ImportError
        If skops (a dependency of skthermal) is missing from the environment.
    TypeError
        If the model holds a dict whose keys a skops file cannot hold (not
        str, int or float), or a function it cannot give back (a lambda, a
        function local to another); the message names where. A function or
        class of the running script or notebook (``__main__``) is saved with
        a warning: the file loads only where a script defines it.
        A warning too when ``sklearn.set_config(transform_output=...)`` is
        on and a step of the model has no ``set_output`` of its own: the
        global setting is not saved with the model.
    IsADirectoryError
        If ``path`` is a folder.

    See Also
    --------
    load : Read the file back.
    read_metadata : The versions a file was written with.

    Notes
    -----
    The file is a skops archive (readable by ``skops.io.load``) with one extra
    member, ``skthermal_metadata.json``, holding the versions of skthermal,
    scikit-learn, numpy, scipy, skops and Python that wrote it. An
    ``ANFISRegressor.epoch_callback`` is not saved, nor are metadata
    requests (``set_fit_request(groups=True)`` and the like, for
    scikit-learn's metadata routing): set them again after loading to route
    ``groups`` through a loaded pipeline. Nor are the rows a
    ``GuardedRegressor`` around a static model keeps of runs streamed
    through it (:meth:`~skthermal.compose.GuardedRegressor.remember_runs`):
    a loaded guard starts those runs anew. A ``RunStream`` that has seen a
    block, or a guard around a sequence model holding runs, is refused
    (``TypeError``): save them with ``joblib.dump``.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from skthermal.fuzzy import ANFISRegressor
    >>> from skthermal.io import load, save
    >>> X = np.linspace(0, 1, 40).reshape(-1, 1)
    >>> model = ANFISRegressor(n_clusters=2, epochs=5, random_state=0)
    >>> model = model.fit(X, 2 * X[:, 0])
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save(model, os.path.join(folder, "model.skops"))
    ...     reloaded = load(path)
    >>> bool(np.array_equal(reloaded.predict(X), model.predict(X)))
    True
    """
    sio = _skops_io()
    path = os.fspath(path)
    if os.path.isdir(path):
        raise IsADirectoryError(
            f"{path} is a folder: give the file to write, e.g. "
            f"{os.path.join(path, 'model.skops')}."
        )
    _check_dict_keys(model)
    _check_code(model)
    _check_output_config(model)
    if _holds_streamed_runs(model):
        # skops stores no pandas tables (its error, "no default __reduce__
        # due to non-trivial __cinit__", named nothing of the model), and a
        # sequence model restarted mid-run is wrong from there on.
        raise TypeError(
            f"{type(model).__name__} keeps the runs it streams (their rows or "
            "end states, and the findings it said), which a skops file cannot "
            "hold. Save it with joblib.dump (a pickle: it restarts mid-run "
            "exactly), or save its model with skthermal.io.save and give the "
            "loaded one each run again from its first row."
        )
    compression = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    sio.dump(_without_unsaved(model), path, compression=compression)
    metadata = {"format": _FORMAT, "versions": _versions()}
    with zipfile.ZipFile(path, "a", compression=compression) as archive:
        archive.writestr(_METADATA_NAME, json.dumps(metadata, indent=2))
    return path


def _holds_streamed_runs(model):
    """Whether ``model`` holds runs it streams that a skops file cannot keep:
    a :class:`~skthermal.compose.RunStream` that has seen a block (the runs'
    rows or end states, the findings said, keyed by tuples; after a warning
    skops' own error named an internal key and advised a refit), or a guard
    around a sequence model keeping the runs streamed through it (restarted
    mid-run, the model would be wrong from there on)."""
    if hasattr(model, "mode_") and getattr(model, "runs_", None):
        return True
    return bool(getattr(model, "stream_runs_", None)) and bool(sequence_models(model))


def read_metadata(path):
    """The metadata that :func:`save` recorded in a model file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    dict or None
        ``{"format": 1, "versions": {"skthermal": ..., "scikit-learn": ...,
        ...}}``, or None for a skops file not written by :func:`save`.

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    ValueError
        If the file is not a skops file (empty, cut off, a pickle or joblib
        file, text, ...); the message names the path and what it expected.
    """
    path = os.fspath(path)
    _check_file(path)
    with zipfile.ZipFile(path) as archive:
        if _METADATA_NAME not in archive.namelist():
            return None
        raw = archive.read(_METADATA_NAME)
    try:
        metadata = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _not_skops(
            path, f"its {_METADATA_NAME} is not readable JSON ({exc})", _DAMAGED
        ) from exc
    if not isinstance(metadata, dict):
        raise _not_skops(path, f"its {_METADATA_NAME} is not a JSON object", _DAMAGED)
    fmt = metadata.get("format")
    if not isinstance(fmt, int) or fmt > _FORMAT:
        raise ValueError(
            f"{path} was written in skthermal model format {fmt!r}, which this "
            f"skthermal (format {_FORMAT}) cannot read: a newer skthermal wrote "
            "it, or the file is damaged. Install that version, or refit."
        )
    return metadata


def _check_versions(path, metadata):
    if metadata is None:
        return
    saved = metadata.get("versions")
    saved = saved if isinstance(saved, dict) else {}
    installed = _versions()
    differ = [
        f"{name} {saved.get(name, 'unknown')} (installed: {installed[name]})"
        for name in ("skthermal", "scikit-learn")
        if saved.get(name) != installed[name]
    ]
    if differ:
        warnings.warn(
            f"The model file {path} was written with {', '.join(differ)}. It may "
            "not load or predict as it did; refit it with the installed "
            "versions, or check its predictions on known data before use.",
            SkthermalVersionWarning,
            stacklevel=3,
        )


def load(path, *, trusted=None):
    """Load a model saved by :func:`save`, running no code from the file.

    Parameters
    ----------
    path : str or path-like
        A file written by :func:`save` (or any skops file).
    trusted : sequence of str or type, optional
        Further types to trust, by fully qualified name (as listed by the
        error) or as classes. Trusted by default: skops' own defaults
        (builtins, numpy, scipy and scikit-learn types) and the classes
        defined by skthermal.

    Returns
    -------
    object
        The model.

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    ValueError
        If the file is not a skops file: empty, cut off, a pickle or joblib
        file (the message says how to load one you trust), text, or another
        zip archive. The message names the path and what it expected.
    UntrustedTypesError
        If the file holds types outside the default set and ``trusted``;
        the error lists them (``.types``).
    ImportError
        If skops (a dependency of skthermal) is missing from the environment.

    Warns
    -----
    SkthermalVersionWarning
        When the file was written with another skthermal or scikit-learn
        version than the installed one; the message names both.

    See Also
    --------
    save : Write the file.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from sklearn.pipeline import make_pipeline
    >>> from sklearn.preprocessing import StandardScaler
    >>> from skthermal.fuzzy import ANFISRegressor
    >>> from skthermal.io import load, read_metadata, save
    >>> X = np.linspace(0, 1, 40).reshape(-1, 1)
    >>> pipe = make_pipeline(StandardScaler(), ANFISRegressor(epochs=5))
    >>> pipe = pipe.fit(X, X[:, 0] ** 2)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = save(pipe, os.path.join(folder, "pipe.skops"))
    ...     reloaded = load(path)
    ...     versions = read_metadata(path)["versions"]
    >>> reloaded.steps[-1][0]
    'anfisregressor'
    >>> sorted(versions)[:3]
    ['numpy', 'python', 'scikit-learn']
    """
    sio = _skops_io()
    path = os.fspath(path)
    metadata = read_metadata(path)  # checks that the file is a skops archive
    extra = {_type_name(t) for t in (trusted or ())} | set(_ALSO_TRUSTED)
    untrusted = sio.get_untrusted_types(file=path)
    ours = [t for t in untrusted if _is_skthermal_class(t)]
    refused = sorted(t for t in untrusted if t not in extra and t not in ours)
    if refused:
        raise UntrustedTypesError(
            f"The model file {path} contains types that are not trusted by "
            f"default: {refused}. Loading them could run their code. Only if "
            "you trust where the file comes from, pass them to load(..., "
            "trusted=[...]).",
            refused,
        )
    _check_versions(path, metadata)
    return sio.load(path, trusted=list(untrusted))
