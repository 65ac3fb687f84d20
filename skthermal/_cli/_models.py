"""``skthermal fit``, ``predict``, ``evaluate`` and ``search``: named models.

Models come from :func:`skthermal.models.make_model`; model files are
bundles (a dict with the fitted model, its input sensors and target) saved
with :func:`skthermal.io.save` (``.skops``) or joblib (any other name).
"""

import json
import re
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.exceptions import ConvergenceWarning

from skthermal._cli._common import (
    UserError,
    check_out_path,
    check_out_table,
    check_used_sensors,
    features_of,
    label_text,
    pick_target,
    read_sensor_list,
    read_table,
    require,
    run_mask,
    sensor_file_target,
    write_table,
)
from skthermal._naming import compact
from skthermal.utils._runs import MAX_MAGNITUDE

MODEL_FORMAT = "skthermal-model"


def _is_skops(path):
    return Path(path).suffix.lower() == ".skops"


def save_model(bundle, path):
    """Write a model bundle (dict) to ``path``.

    ``*.skops``: the safe format of :mod:`skthermal.io` (skops, loads without
    running code from the file); anything else: joblib.
    """
    path = Path(path)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    if _is_skops(path):
        from skthermal.io import save

        try:
            save(bundle, path)
        except ImportError as exc:  # skops missing: the message names the extra
            raise UserError(str(exc)) from exc
        return
    import joblib

    joblib.dump(bundle, path)


def _not_a_model(path):
    """What ``path`` is when it is plainly not a model file (a run table or
    another text file), else None. Model files are binary: pickles (raw or
    compressed, as joblib writes them) or zip archives (skops)."""
    with open(path, "rb") as f:
        head = f.read(4096)
    if not head:
        return "an empty file"
    if head.startswith(b"SQLite format 3\0"):
        return "an SQLite database (a search's study?)"
    name = path.name.lower()
    if name.endswith((".csv", ".csv.gz", ".parquet", ".pq")):
        return "a run table"
    if b"\0" not in head:
        try:
            head.decode("utf-8")
        except UnicodeDecodeError:
            return None
        return "a text file"
    return None


def load_model(path):
    """Read a model bundle written by :func:`save_model`.

    joblib runs code from the file while loading it: load only ``.joblib``
    files you trust (yours). ``.skops`` files are loaded by
    :func:`skthermal.io.load`, which runs no code from the file.
    """
    path = Path(path)
    if not path.is_file():
        raise UserError(f"--model: no such file: {path}")
    kind = _not_a_model(path)
    if kind:
        raise UserError(
            f"--model {path}: {kind}, not a model file; write one with "
            "'skthermal fit --runs RUNS --out model.joblib' (or .skops)."
        )
    # A skops archive loads as one whatever its name (a .skops file renamed
    # .joblib met the unpickler: "persistent IDs in protocol 0 ...").
    safe = _is_skops(path) or zipfile.is_zipfile(path)
    try:
        if safe:
            from skthermal.io import load

            bundle = load(path)
        else:
            import joblib

            bundle = joblib.load(path)
    except UserError:
        raise
    except Exception as exc:  # a corrupt or foreign file fails in many ways
        raise UserError(
            f"--model {path}: not a readable model file ({type(exc).__name__}: {exc})"
        ) from exc
    if not isinstance(bundle, dict) or bundle.get("format") != MODEL_FORMAT:
        raise UserError(f"--model {path}: not a model file written by 'skthermal fit'.")
    if not safe:  # skthermal.io.load checked a skops file's versions
        from skthermal import __version__
        from skthermal.io import SkthermalVersionWarning

        written = bundle.get("skthermal_version")
        if written is not None and written != __version__:
            warnings.warn(
                f"The model file {path} was written with skthermal {written} "
                f"(installed: {__version__}). It may not load or predict as it "
                "did; refit it with the installed version, or check its "
                "predictions on known data before use.",
                SkthermalVersionWarning,
                stacklevel=2,
            )
    return bundle


def _parse_value(text):
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def _parse_params(items):
    params = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UserError(f"--set expects KEY=VALUE, got {item!r}.")
        params[key.strip()] = _parse_value(value.strip())
    return params


def _resolve_params(model, params):
    """``--set`` names -> ``set_params`` keys of the wrapped model.

    A name may be the inner model's parameter (``epochs``), a full nested key
    (``transformedtargetregressor__regressor__alpha``) or any unambiguous
    last part of one (``max_iter`` for the MLP).
    """
    valid = [k.removeprefix("estimator__") for k in model.get_params(deep=True)]
    valid = [k for k in valid if k != "estimator"]
    out = {}
    for key, value in params.items():
        if key in valid:
            out[f"estimator__{key}"] = value
            continue
        matches = [k for k in valid if k.endswith("__" + key)]
        if len(matches) != 1:
            short = sorted({k.rsplit("__", 1)[-1] for k in valid})
            what = "is ambiguous" if matches else "is not a parameter of the model"
            raise UserError(f"--set {key}: {what}; parameters: {', '.join(short)}.")
        out[f"estimator__{matches[0]}"] = value
    return out


def _target_changes(y, groups):
    """The target as the change since the first row of each run: what the
    named models predict (they are :class:`~skthermal.models.RunStartRegressor`
    wrappers)."""
    from skthermal._run_changes import changes_since_first_row

    return pd.Series(changes_since_first_row(y, groups), index=y.index, name=y.name)


def _note_turning_starts(df, mask):
    """A note when most training runs start with the spindle turning: the
    named models' zero at each run's first row carries their miss there
    through the run (docs/command_line.md)."""
    if "spindle_rpm" not in df.columns:
        return
    first = df[mask].groupby("run", sort=False)["spindle_rpm"].first()
    turning = int((first > 0).sum())
    if turning and 2 * turning >= len(first):
        print(
            f"Note: {turning} of the {len(first)} training run(s) start with the "
            "spindle turning. The model predicts the change since each run's "
            "start from a zero at its first row, so what it misses there is "
            "carried through the run; on such runs make_lag_pipeline() fitted "
            "in Python and applied as it is missed 1.3 to 9 times less in "
            "independent checks (docs/command_line.md)."
        )


# Training rows from which `fit` says what it fits before it starts.
_LONG_FIT_ROWS = 20_000


def cmd_fit(args):
    from skthermal import __version__
    from skthermal._run_changes import changes_since_first_row
    from skthermal.datasets import sensor_columns, split_runs
    from skthermal.models import MODELS, make_model, make_selector
    from skthermal.study import score_runs

    if args.model not in MODELS:
        raise UserError(
            f"--model: unknown model {args.model!r}; choose one of {', '.join(MODELS)}."
        )
    if args.sensors and args.selector:
        raise UserError("Give either --sensors or --selector, not both.")
    check_out_path(args.out, "--out")
    # With --sensors, other sensors may miss readings (a channel a run lacks).
    df = read_table(args.runs, allow_missing_sensors=bool(args.sensors))
    target = pick_target(df, sensor_file_target(args.sensors, args.target), args.runs)
    mask = run_mask(df, args.train_runs)
    if args.sensors:
        sensors = read_sensor_list(args.sensors, df)
        check_used_sensors(df, sensors, args.runs)
    elif args.selector:
        X, y, _ = split_runs(df, targets=target)
        if not 1 <= args.n_sensors <= X.shape[1]:
            raise UserError(
                f"--n-sensors must be between 1 and {X.shape[1]}, got {args.n_sensors}."
            )
        selector = make_selector(args.selector, args.n_sensors, random_state=args.seed)
        selector.fit(X[mask], y[mask])
        sensors = list(selector.get_feature_names_out())
        print(f"{args.selector} selected {', '.join(sensors)}")
    else:
        sensors = sensor_columns(df)
    model = make_model(args.model, random_state=args.seed, quick=args.quick)
    drivers = MODELS[args.model].drivers
    if drivers:
        have = [d for d in drivers if d in df.columns]
        sensors = [s for s in sensors if s not in have] + have
        if not have:
            print(
                f"Note: the run table has none of {', '.join(drivers)}; "
                f"{MODELS[args.model].label} uses the sensors only."
            )
    X, y, groups = split_runs(df, sensors=sensors, targets=target)
    _note_turning_starts(df, mask)
    # The models read changes since each run's start: a run's first row is
    # its zero, and a sensor whose changes are all zero tells them nothing.
    changes = changes_since_first_row(X[mask].to_numpy(dtype=float), groups[mask])
    n_runs = len(pd.unique(groups[mask]))
    n_rows = int(mask.sum()) - n_runs
    measured = set(sensor_columns(df))  # drivers may rest (no feed)
    still = [
        s
        for s, moved in zip(sensors, np.abs(changes).max(axis=0) > 0, strict=True)
        if s in measured and n_rows > 0 and not moved
    ]
    if still:
        warnings.warn(
            f"Sensor(s) {still} do not change within any training run (stuck "
            "or disconnected?): the model learns nothing from them, and any "
            "later change of theirs is an extrapolation. Check them, or leave "
            "them out (--sensors).",
            UserWarning,
            stacklevel=2,
        )
    if n_rows <= len(sensors):
        warnings.warn(
            f"{n_rows} training sample(s) after the runs' first rows (the "
            f"zero of their changes) for {len(sensors)} input(s): the model "
            "can fit them exactly whatever the inputs mean, so its training RMSE "
            "says nothing. Train on more samples (longer or more runs), or on "
            "fewer sensors (--sensors or --selector).",
            UserWarning,
            stacklevel=2,
        )
    params = _resolve_params(model, _parse_params(args.set))
    if params:
        model.set_params(**params)
    if args.guard:
        from skthermal.compose import GuardedRegressor

        model = GuardedRegressor(model, mode=args.guard)
    if int(mask.sum()) >= _LONG_FIT_ROWS:
        # A campaign logged every second fits for minutes: say so first.
        print(
            f"Fitting {MODELS[args.model].label} on {int(mask.sum()):,} rows of "
            f"{n_runs} run(s), {len(sensors)} input(s)...",
            flush=True,
        )
    with warnings.catch_warnings():
        warnings.simplefilter("always", ConvergenceWarning)
        # On the changes the model predicts, so that a guard's output band
        # is a band of changes too.
        model.fit(X[mask], _target_changes(y, groups)[mask])
        fitted = model.predict(X[mask])
    scores = score_runs(y[mask], fitted, groups[mask])
    bundle = {
        "format": MODEL_FORMAT,
        "version": 1,
        "model": args.model,
        "estimator": model,
        "sensors": sensors,
        "target": target,
        "train_runs": [str(r) for r in pd.unique(groups[mask])],
        "train_spans": _run_spans(df[mask]),
        "skthermal_version": __version__,
    }
    save_model(bundle, args.out)
    rmse = ", ".join(
        f"{r}: {compact(v)}"
        for r, v in zip(scores["run"], scores["RMSE_um"], strict=True)
    )
    used = [s for s in sensors if s not in measured]  # the drivers
    inputs = f"{len(sensors) - len(used)} sensor(s)" + (
        f" and {', '.join(used)}" if used else ""
    )
    print(
        f"Fitted {MODELS[args.model].label} on {inputs} -> {target}, "
        f"runs {', '.join(bundle['train_runs'])}; training RMSE (µm) {rmse}."
    )
    print(f"Wrote {args.out}")
    return 0


def _row(table, i):
    """``run 'I', time_s 1500.0``: where row ``i`` of a run table is."""
    from skthermal._naming import plain

    return (
        f"run {plain(table['run'].iloc[i])!r}, time_s {plain(table['time_s'].iloc[i])}"
    )


def _first_non_finite(values, table, nan="NaN", rows=None):
    """Row and value (``nan`` for NaN, else inf or -inf) of the first
    missing or infinite value of ``values`` (one or more per row of
    ``table``), with the number of such rows; None when all are finite.
    ``rows``: a mask of the rows to look at (default: all)."""
    values = np.asarray(values, dtype=float).reshape(len(table), -1)
    bad = ~np.isfinite(values).all(axis=1)
    if rows is not None:
        bad &= rows
    if not bad.any():
        return None
    i = int(np.flatnonzero(bad)[0])
    value = values[i][~np.isfinite(values[i])][0]
    return i, nan if np.isnan(value) else f"{value}", int(bad.sum())


def _largest_reading(X, row=None):
    """``'T18_C' = 1e+308 at run 'I', time_s 1500.0``: the input reading of
    largest magnitude in the run of ``row`` up to it (a sequence model
    carries a reading on to later rows), or in all of ``X`` (None)."""
    values = X.to_numpy(dtype=float)
    rows = np.arange(len(X))
    if row is not None:
        runs = np.asarray(X.index.get_level_values("run"))
        rows = rows[: row + 1][runs[: row + 1] == runs[row]]
    size = np.abs(values[rows])
    r, c = np.unravel_index(int(np.argmax(size)), size.shape)
    i = int(rows[r])
    where = "that row" if i == row else _row(X.index.to_frame(index=False), i)
    return f"{X.columns[c]!r} = {values[i, c]:.4g} at {where}"


def _is_float_error(caught):
    """Whether a caught warning is numpy's floating-point error report
    ("overflow encountered in matmul")."""
    return issubclass(caught.category, RuntimeWarning) and (
        " encountered in " in str(caught.message)
    )


def _predict(bundle, df, then, where="The run table"):
    """The model's predictions for the rows of ``df``, every one finite, and
    for a model fitted with ``--guard`` its checks (``predict_checked``:
    ``ok``, ``action``, ``reason`` per row; else None).

    A non-finite prediction is a :class:`UserError` naming the column, the
    run and the time of the first one, ``then`` (what was not done) and
    the likely cause: the input reading of largest magnitude in the run up
    to there; so is a step of the model refusing a non-finite value (the
    readings themselves are finite). numpy's floating-point warnings
    ("overflow encountered in matmul"), which name neither, are replaced by
    that error, or by one warning naming the largest reading when the
    predictions are finite all the same.
    """
    X = features_of(df, bundle["sensors"], where)
    col = f"pred_{bundle['target']}"
    cause = "Likely cause: an input reading far outside any physical range; "
    fix = "Check or drop that reading and predict again."
    estimator = bundle["estimator"]
    checked = None
    with warnings.catch_warnings(record=True) as caught:
        try:
            if hasattr(estimator, "predict_checked"):  # --guard
                checked = estimator.predict_checked(X)
                pred = checked["prediction"].to_numpy(dtype=float)
            else:
                pred = np.asarray(estimator.predict(X), dtype=float)
        except AttributeError as exc:
            # A fitted attribute this skthermal reads and the file lacks.
            from skthermal import __version__

            raise UserError(
                f"The model cannot predict {col} with skthermal {__version__} "
                f"({exc}), so {then}. It was saved by another skthermal "
                "version: fit it again with 'skthermal fit'."
            ) from exc
        except ValueError as exc:
            # The readings are finite (read_table checked them): a step of
            # the model met a value its arithmetic overflowed to.
            if not re.search(r"contains (infinity|NaN)", str(exc)):
                raise
            raise UserError(
                f"The model could not predict {col} ({str(exc).rstrip('.')}), so "
                f"{then}. {cause}the largest input reading is "
                f"{_largest_reading(X)}. {fix}"
            ) from exc
    numeric = [w for w in caught if _is_float_error(w)]
    for w in caught:
        if not _is_float_error(w):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    # A guard in hold mode gives no prediction for a run in which a sensor
    # reads nothing (action "unavailable"), and says so: those rows stay
    # empty in the output.
    given = None if checked is None else checked["action"].to_numpy() != "unavailable"
    found = _first_non_finite(pred, df, rows=given)
    if found is not None:
        i, kind, count = found
        raise UserError(
            f"The model predicts {kind} for {col} at {_row(df, i)} ({count} of "
            f"{len(df)} rows without a finite prediction), so {then}. {cause}"
            f"the largest in the run up to there is {_largest_reading(X, i)}. {fix}"
        )
    if numeric:
        warnings.warn(
            f"{numeric[0].message} while predicting {col} (the predictions are "
            "finite); the largest input reading is "
            f"{_largest_reading(X)}: check it if it is far outside any "
            "physical range.",
            RuntimeWarning,
            stacklevel=2,
        )
    return pred, checked


def _check_model_sensors(df, bundle, path):
    """Refuse missing readings of the sensors the saved model reads (those
    of the others are fine), unless the model is a guard in ``"hold"``
    mode, which holds the compensation over them."""
    if getattr(bundle["estimator"], "mode", None) != "hold":
        check_used_sensors(df, bundle["sensors"], path)


def _unread_columns(columns, bundle):
    """The displacement and driver ``columns`` of a run table that the saved
    model does not read (``bundle["sensors"]``)."""
    from skthermal.datasets import driver_columns, target_columns

    read = set(bundle["sensors"])
    return [
        c for c in [*target_columns(columns), *driver_columns(columns)] if c not in read
    ]


_GUARD_COLUMNS = ("guard_ok", "guard_action", "guard_reason")


def _other_predictions(df, target):
    """The targets of the prediction columns of ``df`` other than ``target``'s."""
    return [
        c[len("pred_") :]
        for c in df.columns
        if isinstance(c, str) and c.startswith("pred_") and c != f"pred_{target}"
    ]


def _guard_columns(out, target, guarded):
    """``out`` (the table given to ``predict``) with the guard columns of an
    earlier ``predict`` named for their target, where this one would
    overwrite or orphan them (an independent check: the x model's checks
    replaced the z model's, which had flagged a spike; a model predicting
    the target again left the old checks beside its new prediction).

    Unnamed ones (``guard_ok`` ...) belong to the one other prediction in
    the table: renamed ``guard_ok_<target>``; those of ``target`` itself
    are dropped, being of the prediction this one replaces."""
    held = [c for c in _GUARD_COLUMNS if c in out.columns]
    stale = [c for c in out.columns if c in {f"{g}_{target}" for g in _GUARD_COLUMNS}]
    others = _other_predictions(out, target)
    if held:
        if not others:  # they check pred_<target>, which is replaced
            stale += held
        elif len(others) == 1:
            out = out.rename(columns={c: f"{c}_{others[0]}" for c in held})
        elif guarded:
            raise UserError(
                f"The run table holds guard columns ({', '.join(held)}) of an "
                f"earlier predict of one of {others}, which this model's checks "
                "would replace: predict each target from the table without "
                "them, or rename them."
            )
    if stale:
        warnings.warn(
            f"The run table's {', '.join(stale)} checked the earlier "
            f"pred_{target}, which this prediction replaces: dropped.",
            UserWarning,
            stacklevel=2,
        )
        out = out.drop(columns=stale)
    return out


def cmd_predict(args):
    from skthermal.datasets import read_runs

    check_out_table(args.out)
    check_out_path(args.out, "--out")
    bundle = load_model(args.model)
    # Sensors the model does not read may miss readings; a guard in "hold"
    # mode holds the compensation over those of its own. Nor are the
    # measured displacements, or drivers it does not read, checked (a
    # production run's probe is absent or drops out).
    df = read_table(
        args.runs,
        allow_missing_sensors=True,
        unchecked=lambda columns: _unread_columns(columns, bundle),
    )
    unread = _unread_columns(df.columns, bundle)
    _check_model_sensors(df, bundle, args.runs)
    pred, checked = _predict(
        bundle, df, f"nothing was written to {args.out}", f"--runs {args.runs}"
    )
    out = _guard_columns(df.copy(), bundle["target"], checked is not None)
    out[f"pred_{bundle['target']}"] = pred
    if checked is not None:  # a model fitted with --guard
        suffix = (
            ""
            if "guard_ok" not in df.columns
            and not _other_predictions(df, bundle["target"])
            else f"_{bundle['target']}"
        )
        for column in ("ok", "action", "reason"):
            out[f"guard_{column}{suffix}"] = checked[column].to_numpy()
    try:
        _, meta = read_runs(args.runs, metadata=True, validate=False)
    except ValueError:
        meta = None
    write_table(
        out,
        args.out,
        metadata=meta if meta is not None and len(meta) else None,
        allow_missing_sensors=True,
        validate=not unread,  # its columns as read, with the predictions
    )
    lost = ""
    if checked is not None and (checked["action"] == "unavailable").any():
        runs = df.loc[(checked["action"] == "unavailable").to_numpy(), "run"]
        lost = (
            f" ({runs.nunique()} of them without a prediction, action "
            "'unavailable': a sensor reads nothing there)"
        )
    print(
        f"Predicted pred_{bundle['target']} (change since the start of each run) "
        f"for {df['run'].nunique()} run(s){lost}; wrote {args.out}"
    )
    return 0


def _prediction_column(df, target, where):
    from skthermal.datasets import target_columns

    preds = [c for c in df.columns if isinstance(c, str) and c.startswith("pred_")]
    if target is not None:
        name = f"pred_{target}"
        if name not in df.columns:
            raise UserError(
                f"{where} has no {name!r} column; it has {preds or 'none'}."
            )
        return target, name
    candidates = [f"pred_{t}" for t in target_columns([c[5:] for c in preds])]
    if not candidates:
        found = f" (it has {preds})" if preds else ""
        raise UserError(
            f"{where} has no prediction column pred_disp_<axis>_um{found}; "
            "name it so (predictions in µm), or pass --model FILE to predict."
        )
    if len(candidates) > 1:
        raise UserError(
            f"{where} has several prediction columns {candidates}; choose with "
            "--target."
        )
    return candidates[0][5:], candidates[0]


def _join_keys(table, time_dtype=np.float64):
    """(run, time_s) of every row as join keys: the run label as text (as
    --train-runs matches it; a whole number stored as a float, ``1.0``, as
    ``1``), the time as a float of ``time_dtype``."""
    return pd.DataFrame(
        {
            "run": label_text(table["run"]),
            "time_s": pd.to_numeric(table["time_s"], errors="coerce")
            .to_numpy(float)
            .astype(time_dtype),
        }
    )


def _time_dtype(*tables):
    """The coarsest float type of the tables' ``time_s``: times stored as
    float32 (a Parquet file made smaller) match their float64 text in a CSV
    file only at float32's precision."""
    coarse = [
        np.dtype(getattr(t["time_s"].dtype, "numpy_dtype", t["time_s"].dtype))
        for t in tables
        if pd.api.types.is_float_dtype(t["time_s"].dtype)
    ]
    return min(coarse, key=lambda d: d.itemsize, default=np.dtype(np.float64))


def _join_predictions(df, preds, col, runs_path, preds_path):
    """The rows of ``df`` with the ``col`` of ``preds`` on the same (run,
    time_s). Refuses predictions that repeat a (run, time_s) and runs that
    are scored with rows missing (a missing first row would move the start
    the changes are measured from); runs without any prediction are left
    out with a note."""
    from skthermal._naming import plain

    time_dtype = _time_dtype(df, preds)
    keys = _join_keys(preds, time_dtype)
    repeated = np.flatnonzero(keys.duplicated().to_numpy())
    if repeated.size:
        i = repeated[0]
        raise UserError(
            f"--predictions {preds_path}: {repeated.size} row(s) repeat a (run, "
            f"time_s) pair, the first run {plain(preds['run'].iloc[i])!r}, time_s "
            f"{plain(preds['time_s'].iloc[i])} (row {i}); every measured row needs "
            "exactly one prediction."
        )
    right = keys.assign(**{"_pred": preds[col].to_numpy()})
    joined = _join_keys(df, time_dtype).merge(
        right, on=["run", "time_s"], how="left", indicator=True
    )
    have = (joined["_merge"] == "both").to_numpy()
    if not have.any():
        raise UserError(
            f"--predictions {preds_path} shares no (run, time_s) rows with {runs_path}."
        )
    labels = df["run"].to_numpy()
    scored = pd.Series(have).groupby(labels, sort=False).any()
    partial = np.flatnonzero(~have & scored.reindex(labels).to_numpy())
    if partial.size:
        i = partial[0]
        run = labels[i]
        first = int(np.flatnonzero(labels == run)[0]) == i
        start = (
            " (the first row of the run, from which its changes are measured)"
            if first
            else ""
        )
        runs = list(dict.fromkeys(plain(r) for r in labels[partial]))
        raise UserError(
            f"--predictions {preds_path} has no prediction for {partial.size} "
            f"row(s) of {runs_path} in run(s) {runs}, the first run "
            f"{plain(run)!r}, time_s {plain(df['time_s'].iloc[i])}{start}; predict "
            "every row of a run to score it."
        )
    unscored = [plain(r) for r, any_ in scored.items() if not any_]
    if unscored:
        print(
            f"Note: run(s) {unscored} of {runs_path} have no predictions in "
            f"{preds_path}; they are not scored."
        )
    data = df.drop(columns=[col], errors="ignore").loc[have].copy()
    data[col] = joined["_pred"].to_numpy()[have]
    return data


def _without_unavailable(table, path):
    """``table`` without the runs that ``skthermal predict`` gave no
    prediction (``guard_action`` "unavailable": a guard in hold mode with a
    sensor that reads nothing in the run), with a note naming them."""
    from skthermal._naming import plain

    if "guard_action" not in table.columns:
        return table
    lost = (table["guard_action"] == "unavailable").to_numpy()
    if not lost.any():
        return table
    runs = pd.unique(table.loc[lost, "run"])
    print(
        f"Note: run(s) {[plain(r) for r in runs]} of {path} have no prediction "
        "(guard_action 'unavailable': a sensor reads nothing there); they are "
        "not scored."
    )
    keep = ~table["run"].isin(runs).to_numpy()
    if not keep.any():
        raise UserError(
            f"No run of {path} has a prediction (every one 'unavailable'): "
            "nothing to score."
        )
    return table.loc[keep]


def _run_spans(df):
    """Per run of ``df`` (its label as ``str``): its rows and first and last
    ``time_s``, what tells a model's training run from another run under the
    same label (``evaluate --model``)."""
    times = pd.to_numeric(df["time_s"], errors="coerce")
    grouped = times.groupby(df["run"].astype(str).to_numpy(), sort=False)
    return {
        str(label): [int(t.size), float(t.iloc[0]), float(t.iloc[-1])]
        for label, t in grouped
    }


def _fitted_runs(bundle, df, labels):
    """Which runs ``labels`` of ``df`` a model's bundle was fitted on: the
    label, and (bundles that keep them) the rows and times of the run."""
    spans = bundle.get("train_spans")
    given = _run_spans(df) if spans is not None else {}
    return np.array(
        [
            str(r) in bundle["train_runs"]
            and (spans is None or spans.get(str(r)) == given.get(str(r)))
            for r in labels
        ],
        dtype=bool,
    )


def cmd_evaluate(args):
    from skthermal._markdown import markdown_table
    from skthermal._run_changes import changes_since_first_row
    from skthermal.study import METRIC_COLUMNS, score_runs

    if args.model and args.predictions:
        raise UserError("Give either --model or --predictions, not both.")
    if args.out and Path(args.out).suffix.lower() not in (".csv", ".md"):
        raise UserError(f"--out {args.out}: write .csv or .md.")
    check_out_path(args.out, "--out")
    # Scoring reads the displacements and predictions, not the sensors: a
    # sensor missing readings (written so by predict with a hold guard) is
    # refused only where a model reads it, as in predict.
    df = read_table(args.runs, allow_missing_sensors=True)
    if args.model:
        bundle = load_model(args.model)
        _check_model_sensors(df, bundle, args.runs)
        target = bundle["target"]
        if args.target and args.target != target:
            raise UserError(
                f"--target {args.target}: the model {args.model} predicts "
                f"{target!r} (it was fitted on that column); leave out --target "
                f"or pass a model fitted on {args.target!r}."
            )
        if target not in df.columns:
            raise UserError(f"{args.runs} has no measured {target!r} column.")
        pred, checked = _predict(
            bundle, df, "nothing was scored", f"--runs {args.runs}"
        )
        if checked is not None and (checked["action"] == "unavailable").any():
            i = int(np.flatnonzero(checked["action"] == "unavailable")[0])
            raise UserError(
                f"The guard gives no prediction at {_row(df, i)} "
                f"({checked['reason'].iloc[i]}: a sensor reads nothing in that "
                "run), so nothing was scored; leave that run out of --runs."
            )
        data = df
    else:
        if args.predictions:
            # A predictions file needs only run, time_s and pred_* columns.
            preds = read_table(args.predictions, "--predictions", validate=False)
            missing = [c for c in ("run", "time_s") if c not in preds.columns]
            if missing:
                raise UserError(
                    f"--predictions {args.predictions} has no {missing} column(s): "
                    "its rows are joined to --runs on run and time_s."
                )
            target, col = _prediction_column(preds, args.target, args.predictions)
            preds = _without_unavailable(preds, args.predictions)
            data = _join_predictions(df, preds, col, args.runs, args.predictions)
        else:
            target, col = _prediction_column(df, args.target, args.runs)
            data = _without_unavailable(df, args.runs)
        if target not in data.columns:
            raise UserError(f"{args.runs} has no measured {target!r} column.")
        values = pd.to_numeric(data[col], errors="coerce")
        text = np.flatnonzero(values.isna().to_numpy() & data[col].notna().to_numpy())
        if text.size:
            raise UserError(
                f"Column {col!r} of {args.predictions or args.runs} holds "
                f"{data[col].iloc[text[0]]!r} at {_row(data, int(text[0]))} "
                f"({text.size} such row(s)): a prediction is a number in µm."
            )
        pred = values.to_numpy(dtype=float)
        found = _first_non_finite(pred, data, nan="missing (NaN)")
        if found is not None:
            i, kind, count = found
            raise UserError(
                f"Column {col!r} of {args.predictions or args.runs} is {kind} at "
                f"{_row(data, i)} ({count} of {len(data)} rows without a finite "
                "prediction); every scored row needs one: predict that run again "
                "or leave it out."
            )
        huge = np.flatnonzero(np.abs(pred) > MAX_MAGNITUDE)
        if huge.size:
            raise UserError(
                f"Column {col!r} of {args.predictions or args.runs} holds "
                f"{pred[huge[0]]:g} at {_row(data, int(huge[0]))} ({huge.size} "
                f"such row(s)): no thermal error comes near {MAX_MAGNITUDE:g} µm, "
                "a broken model or a corrupt file."
            )
    labels = data["run"].to_numpy()
    table = score_runs(data[target], pred, labels)
    # The model's own training runs score its fit, not its prediction: marked,
    # and left out of the mean and pooled rows while other runs remain.
    fitted = (
        _fitted_runs(bundle, data, table["run"])
        if args.model
        else np.zeros(len(table), dtype=bool)
    )
    summed = ~fitted if not fitted.all() else fitted
    rows = np.isin(labels, table["run"].to_numpy()[summed])
    mean = {"run": "mean", "n_samples": int(table["n_samples"][summed].sum())}
    mean.update(table[list(METRIC_COLUMNS)][summed].mean().to_dict())
    mean["residual_um"] = table["residual_um"][summed].max()
    # Every sample pooled: a run of a few samples weighs as little as it is
    # long (in the mean row it counts as much as a whole test).
    pooled = score_runs(
        changes_since_first_row(data[target].to_numpy(dtype=float)[rows], labels[rows]),
        changes_since_first_row(pred[rows], labels[rows]),
        np.zeros(int(rows.sum())),  # the changes, one series: its first value is 0
    ).assign(run="all")
    named = ", ".join(repr(str(r)) for r in table["run"][fitted])
    table = pd.concat([table, pd.DataFrame([mean]), pooled], ignore_index=True)
    if fitted.any():  # the mean and all rows are no run
        table.insert(1, "fitted", [*np.where(fitted, "yes", ""), "", ""])
    shown = table.copy()
    for c in METRIC_COLUMNS:
        shown[c] = [compact(v) for v in table[c]]
    caption = (
        f"{target}: measured vs predicted change since the start of each run "
        "(residual: max |error|; mean row: the mean over runs, each counting "
        "once, its residual the max over runs; all row: every sample pooled)"
    )
    if fitted.any():
        caption += (
            f". Run(s) {named} are the model's training runs (fitted: yes): "
            "their errors are its fit, not a prediction; "
            + (
                "the mean and all rows are over the other runs"
                if not fitted.all()
                else "every run here is one, so the mean and all rows are "
                "training errors too"
            )
        )
    print(caption)
    print(shown.to_string(index=False))
    if args.out:
        out = Path(args.out)
        if out.parent and not out.parent.exists():
            out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".md":
            out.write_text(f"{caption}\n\n{markdown_table(shown)}\n", encoding="utf-8")
        elif out.suffix.lower() == ".csv":
            table.to_csv(out, index=False)
        else:
            raise UserError(f"--out {out}: write .csv or .md.")
        print(f"Wrote {out}")
    return 0


def cmd_search(args):
    from skthermal.datasets import split_runs
    from skthermal.model_selection import make_storage, run_search
    from skthermal.model_selection._search import (
        OTHER_STUDY,
        check_stored_study,
        no_best_trial,
        safe_url,
    )
    from skthermal.models import MODELS, make_model, model_search_space

    if args.model not in MODELS:
        raise UserError(
            f"--model: unknown model {args.model!r}; choose one of {', '.join(MODELS)}."
        )
    if not MODELS[args.model].paper:
        raise UserError(
            f"--model {args.model}: nothing to search; it chooses its settings "
            "by its own time-ordered cross-validation in 'skthermal fit'."
        )
    if args.trials < 0 or (args.trials == 0 and not args.storage):
        raise UserError(
            f"--trials must be at least 1, got {args.trials} (0 only with "
            "--storage: the stored study's best trial so far, refitted)."
        )
    check_out_path(args.out, "--out")
    check_out_path(args.save_model, "--save-model")
    optuna = require("optuna", extra="optuna", command="search")
    df = read_table(args.runs)
    target = pick_target(df, sensor_file_target(args.sensors, args.target), args.runs)
    df = df[run_mask(df, args.train_runs)]
    if args.sensors:
        sensors = read_sensor_list(args.sensors, df)
        X, y, groups = split_runs(df, sensors=sensors, targets=target)
    else:
        X, y, groups = split_runs(df, targets=target)
        sensors = list(X.columns)
    if args.model == "anfis-grid" and len(sensors) > 6:
        raise UserError(
            f"anfis-grid on {len(sensors)} inputs has at least 2**{len(sensors)} "
            "rules; choose at most 6 inputs with --sensors."
        )
    n_runs = len(pd.unique(groups))
    if n_runs < 2:
        raise UserError(
            f"{args.runs} has {n_runs} run"
            + (" among --train-runs" if args.train_runs else "")
            + "; the search cross-validates over runs and needs at least 2."
        )
    study_name = args.study_name
    if args.storage and not study_name:
        study_name = f"skthermal-{args.model}"
    if args.trials == 0:
        # Before the search stores an empty study under a mistyped name.
        check_stored_study(
            make_storage(args.storage),
            study_name,
            args.storage,
            said=("--trials 0", "--study-name", "--storage"),
        )
    model = make_model(args.model, random_state=args.seed)
    # Failed trials are summarised below, not logged with a traceback each.
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    print(
        f"Searching {MODELS[args.model].label} on {len(sensors)} input(s) -> "
        f"{target}: {args.trials} trial(s), {min(5, n_runs)}-fold CV over "
        f"{n_runs} runs"
        + (
            f", study {study_name!r} in {safe_url(args.storage)}"
            if args.storage
            else ""
        )
        + " ...",
        flush=True,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("always", ConvergenceWarning)
        # Said below as the command's error, not twice.
        warnings.filterwarnings("ignore", message="No best trial")
        try:
            result = run_search(
                model,
                X,
                # Scored as `fit` and `evaluate` score: the change since the start
                # of each held-out run, which is what the model predicts.
                _target_changes(y, groups),
                groups=groups,
                space=model_search_space(args.model),
                n_trials=args.trials,
                storage=args.storage,
                study_name=study_name,
                random_state=args.seed,
            )
        except ValueError as exc:
            # The library names its parameters; here they are options.
            raise UserError(
                str(exc).replace(OTHER_STUDY, "another --study-name (or --storage)")
            ) from None
    runs = [str(r) for r in pd.unique(groups)]
    trials = result.trials_dataframe()
    done = int((trials["state"] == "COMPLETE").sum()) if len(trials) else 0
    failed = [t for t in result.study.trials if t.state.name == "FAIL"]
    errors = [t.user_attrs["error"] for t in failed if "error" in t.user_attrs]
    if failed:
        first = errors[0] if errors else "no error recorded (its worker stopped)"
        print(f"{len(failed)} trial(s) failed; the first: {first}")
    if result.best_params_ is None:
        raise UserError(no_best_trial(result.study))
    best = {k.removeprefix("estimator__"): v for k, v in result.best_params_.items()}
    print(
        f"{done} of {len(trials)} trial(s) complete; best CV RMSE "
        f"{-result.best_score_:.3f} µm with:"
    )
    for key, value in best.items():
        print(f"  {key} = {value!r}")
    if args.out:
        doc = {
            "model": args.model,
            "target": target,
            "sensors": sensors,
            "best_rmse_um": -result.best_score_,
            "best_params": {k: _plain(v) for k, v in best.items()},
            "n_trials": len(trials),
            # The URL without its password: this file is shared.
            "train_runs": runs,
            "storage": None if args.storage is None else safe_url(args.storage),
            "study_name": study_name,
        }
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)  # as --save-model does
        out.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
        print(f"Wrote {args.out}")
    if args.save_model and result.best_estimator_ is not None:
        from skthermal import __version__

        save_model(
            {
                "format": MODEL_FORMAT,
                "version": 1,
                "model": args.model,
                "estimator": result.best_estimator_,
                "sensors": sensors,
                "target": target,
                "train_runs": runs,
                "train_spans": _run_spans(df),
                "skthermal_version": __version__,
            },
            args.save_model,
        )
        print(
            f"Wrote {args.save_model} (best parameters, refitted on "
            + ("all runs)" if not args.train_runs else f"runs {', '.join(runs)})")
        )
    return 0


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return value
