"""The subcommands of the ``skthermal`` command (the parser is in ``cli.py``).

Every subcommand reads and writes run tables through
:mod:`skthermal.datasets` (``read_runs`` validates them) and turns problems
with the user's input -- a missing file, a bad column, an unknown name, an
out-of-range option -- into :class:`UserError`, which the command prints as
one line with exit status 2.
"""

import importlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.exceptions import ConvergenceWarning

MODEL_FORMAT = "skthermal-model"


class UserError(Exception):
    """An error in the user's input: reported as one line, exit status 2."""


# --------------------------------------------------------------------------
# Shared helpers
# --------------------------------------------------------------------------


def _split_list(value):
    """``"a,b c"`` or ``["a,b", "c"]`` -> ``["a", "b", "c"]``."""
    if value is None:
        return None
    items = [value] if isinstance(value, str) else list(value)
    out = []
    for item in items:
        out += [v for v in item.replace(",", " ").split() if v]
    return out


def read_table(path, what="--runs"):
    """Read and validate a run table, naming the option on failure."""
    from skthermal.datasets import read_runs

    if path is None:
        raise UserError(f"{what} FILE is required.")
    path = Path(path)
    if not path.exists():
        raise UserError(f"{what}: no such file: {path}")
    if path.is_dir():
        raise UserError(f"{what}: {path} is a folder, not a run table file.")
    try:
        return read_runs(path)
    except UnicodeDecodeError as exc:
        raise UserError(
            f"{what} {path}: not a text CSV run table (binary data; use .csv, "
            ".csv.gz or .parquet)."
        ) from exc
    except (ValueError, ImportError, pd.errors.ParserError) as exc:
        raise UserError(f"{what} {path}: {exc}") from exc


def write_table(df, path, *, metadata=None):
    from skthermal.datasets import write_runs

    path = Path(path)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_runs(df, path, metadata=metadata)
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
    labels = df["run"].astype(str)
    if not runs:
        return np.ones(len(df), dtype=bool)
    wanted = _split_list(runs)
    present = list(pd.unique(labels))
    unknown = [r for r in wanted if r not in present]
    if unknown:
        raise UserError(
            f"{option}: run(s) {unknown} are not in the table; runs: {present}."
        )
    return labels.isin(wanted).to_numpy()


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
            table = pd.read_csv(path)
            if "sensor" not in table.columns:
                raise UserError(f"--sensors {path}: no 'sensor' column.")
            if "selected" in table.columns:
                table = table[table["selected"].astype(bool)]
            names = table["sensor"].tolist()
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise UserError(
                f"--sensors {path}: expected a list of sensor names (as written by "
                "'skthermal select')."
            )
    else:
        names = _split_list(value)
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


def features_of(df, sensors):
    """``df[sensors]`` indexed by (run, time_s), as ``split_runs`` makes it."""
    missing = [s for s in sensors if s not in df.columns]
    if missing:
        raise UserError(f"The run table lacks the model's input column(s) {missing}.")
    index = pd.MultiIndex.from_arrays(
        [df["run"], df["time_s"]], names=["run", "time_s"]
    )
    return df[list(sensors)].set_axis(index, axis=0)


def _check_positive(value, option, *, integer=False, upper=None):
    if value is None:
        return
    if not np.isfinite(value) or value <= 0:
        raise UserError(f"{option} must be positive, got {value}.")
    if upper is not None and value > upper:
        raise UserError(f"{option} must be at most {upper}, got {value}.")


# --------------------------------------------------------------------------
# Model files: the one place to switch to skthermal.io (skops) later
# --------------------------------------------------------------------------


def _is_skops(path):
    return Path(path).suffix.lower() == ".skops"


def save_model(bundle, path):
    """Write a model bundle (dict) to ``path``.

    ``*.skops``: the safe format of :mod:`skthermal.io` (skops, loads without
    running code from the file); anything else: joblib. Making skops the
    default is a change of this function and :func:`load_model` only.
    """
    path = Path(path)
    if path.parent and not path.parent.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
    if _is_skops(path):
        save = _optional("skthermal.io", "save", "fit --out *.skops", "deploy")
        try:
            save(bundle, path)
        except ImportError as exc:
            raise UserError(str(exc)) from exc
        return
    import joblib

    joblib.dump(bundle, path)


def load_model(path):
    """Read a model bundle written by :func:`save_model`.

    joblib runs code from the file while loading it: load only ``.joblib``
    files you trust (yours). ``.skops`` files are loaded by
    :func:`skthermal.io.load`, which runs no code from the file.
    """
    path = Path(path)
    if not path.is_file():
        raise UserError(f"--model: no such file: {path}")
    try:
        if _is_skops(path):
            import skthermal._reproduce  # noqa: F401 - trusts RunStartRegressor

            load = _optional("skthermal.io", "load", "--model *.skops", "deploy")
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


def _note_warnings(caught, command):
    """Warnings of a fit as one line each on stderr (first line, no repeats)."""
    seen = set()
    for w in caught:
        first = str(w.message).strip().splitlines()[0] if str(w.message) else ""
        if first and first not in seen:
            seen.add(first)
            print(f"skthermal {command}: warning: {first}", file=sys.stderr)


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


# --------------------------------------------------------------------------
# reproduce
# --------------------------------------------------------------------------


def cmd_reproduce(args):
    from skthermal._reproduce import (
        MODELS,
        format_results,
        format_summary,
        reproduce,
        text_table,
    )

    _check_positive(args.sample_period, "--sample-period", upper=720.0)
    models = _split_list(args.models)
    if models:
        unknown = [m for m in models if m not in MODELS]
        if unknown:
            raise UserError(
                f"--models: unknown model(s) {unknown}; choose from "
                f"{', '.join(MODELS)}."
            )
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} exists and is not a folder.")
    result = reproduce(
        out,
        seed=args.seed,
        quick=args.quick,
        sample_period_s=args.sample_period,
        figures=not args.no_figures,
        models=models,
        command=getattr(args, "command_line", None),
    )
    s = result.settings
    print(
        f"Machine B, Tests I-VI simulated (preset vmc-b, {s['sample_period_s']:g} s "
        f"sampling, seed {s['seed']}{', quick budget' if s['quick'] else ''}); "
        f"trained on Test IV, Y displacement as change since each test's start."
    )
    print(
        "Sensors (GM(1,N) influence + fuzzy c-means on Test IV): "
        + ", ".join(s["selector"]["selected"])
        + " (paper: T18, T55, T63, T68, T71)"
    )
    print("\nPer test, as 001 Tables 5-7/5-8 (paper columns for the ANFIS models):")
    print(text_table(format_results(result.results)))
    print("\nMean over Tests I, II, III, V, VI:")
    print(text_table(format_summary(result.summary)))
    if result.finding:
        print("\n" + result.finding)
    print(
        f"\nReport: {out}/report.md ({len(result.files)} files, "
        f"{s['timings_s']['total_s']:.0f} s)"
        + (f"; {s['figures_note']}" if s.get("figures_note") else "")
    )
    return 0


# --------------------------------------------------------------------------
# simulate
# --------------------------------------------------------------------------

_HOURS = {"h": 1.0, "hr": 1.0, "min": 1 / 60, "m": 1 / 60, "s": 1 / 3600}


def parse_segments(specs):
    """``["4000:1h,0:30min", "6000:2:1500"]`` -> ``[(s, rpm, feed), ...]``."""
    segments = []
    for spec in _split_list(specs):
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
        if rpm < 0 or feed < 0 or not hours > 0:
            raise UserError(
                f"--segment {spec!r}: speed and feed must be >= 0 and the duration "
                "positive."
            )
        segments.append((hours * 3600.0, rpm, feed))
    return segments


def _effects(value):
    from skthermal.simulate import EFFECTS

    if value is None:
        return None
    names = _split_list(value)
    if names == ["none"]:
        return []
    if names == ["all"]:
        return list(EFFECTS)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise UserError(
            f"--effects: unknown effect(s) {unknown}; known: {', '.join(EFFECTS)} "
            "(or 'all', 'none'; see --list-effects)."
        )
    return names


def cmd_simulate(args):
    from skthermal.datasets import make_machine_b_tests, read_runs
    from skthermal.simulate import (
        AmbientProfile,
        DutyCycle,
        ThermalMachine,
        describe_effects,
    )

    if args.list_effects:
        with pd.option_context("display.max_colwidth", 70, "display.width", 160):
            print(describe_effects().to_string(index=False))
        return 0
    _check_positive(args.sample_period, "--sample-period")
    if args.ambient_noise < 0:
        raise UserError(f"--ambient-noise must be >= 0, got {args.ambient_noise}.")
    machine = ThermalMachine.from_preset(args.preset, effects=_effects(args.effects))
    noise = not args.no_noise
    if args.tests:
        if args.segment:
            raise UserError("Give either --tests or --segment, not both.")
        tests = _split_list(args.tests)
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
        ambient = AmbientProfile(
            mean_C=args.ambient_mean,
            trend_C_per_h=args.ambient_trend,
            day_amplitude_C=args.day_amplitude,
            start_hour=args.start_hour,
            noise_C=args.ambient_noise,
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
        clash = sorted(set(old["run"].astype(str)) & set(runs["run"].astype(str)))
        if clash:
            raise UserError(
                f"--append: run(s) {clash} are already in {out}; name the new run "
                "with --run."
            )
        meta = old_meta.to_dict("records") + meta
        runs = pd.concat([old, runs], ignore_index=True)
    write_table(runs, out, metadata=meta or None)
    sizes = runs.groupby("run", sort=False).size()
    print(
        f"Wrote {out}: {len(sizes)} run(s) ({', '.join(map(str, sizes.index))}), "
        f"{len(runs)} rows, {runs.shape[1]} columns, preset {args.preset}."
    )
    return 0


# --------------------------------------------------------------------------
# select
# --------------------------------------------------------------------------


def cmd_select(args):
    from skthermal._reproduce import SELECTORS, make_selector
    from skthermal.datasets import split_runs

    if args.method not in SELECTORS:
        raise UserError(f"--method: choose one of {', '.join(SELECTORS)}.")
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
    out = Path(args.out)
    if out.parent and not out.parent.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".csv":
        table.to_csv(out, index=False)
    elif out.suffix.lower() == ".json":
        doc = {
            "method": args.method,
            "target": target,
            "train_runs": sorted(pd.unique(df["run"][mask].astype(str)).tolist()),
            "sensors": kept,
            "scores": dict(zip(names, map(float, scores), strict=True)),
        }
        if "group" in table:
            doc["groups"] = dict(zip(names, map(int, table["group"]), strict=True))
        out.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    else:
        raise UserError(f"--out {out}: write .json or .csv.")
    print(
        f"{args.method}: kept {len(kept)} of {len(names)} sensors for {target}: "
        + ", ".join(kept)
    )
    print(f"Wrote {out}")
    return 0


# --------------------------------------------------------------------------
# fit, predict, evaluate
# --------------------------------------------------------------------------


def cmd_fit(args):
    from skthermal import __version__
    from skthermal._reproduce import MODELS, make_model, make_selector, score_runs
    from skthermal.datasets import sensor_columns, split_runs

    if args.model not in MODELS:
        raise UserError(
            f"--model: unknown model {args.model!r}; choose one of {', '.join(MODELS)}."
        )
    if args.sensors and args.selector:
        raise UserError("Give either --sensors or --selector, not both.")
    df = read_table(args.runs)
    target = pick_target(df, args.target, args.runs)
    mask = run_mask(df, args.train_runs)
    if args.sensors:
        sensors = read_sensor_list(args.sensors, df)
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
    X, y, groups = split_runs(df, sensors=sensors, targets=target)
    model = make_model(args.model, random_state=args.seed, quick=args.quick)
    params = _resolve_params(model, _parse_params(args.set))
    if params:
        model.set_params(**params)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        model.fit(X[mask], y[mask])
    _note_warnings(caught, "fit")
    scores = score_runs(y[mask], model.predict(X[mask]), groups[mask])
    bundle = {
        "format": MODEL_FORMAT,
        "version": 1,
        "model": args.model,
        "estimator": model,
        "sensors": sensors,
        "target": target,
        "train_runs": [str(r) for r in pd.unique(groups[mask])],
        "skthermal_version": __version__,
    }
    save_model(bundle, args.out)
    rmse = ", ".join(
        f"{r}: {v:.2f}" for r, v in zip(scores["run"], scores["RMSE_um"], strict=True)
    )
    print(
        f"Fitted {MODELS[args.model].label} on {len(sensors)} sensor(s) -> {target}, "
        f"runs {', '.join(bundle['train_runs'])}; training RMSE (µm) {rmse}."
    )
    print(f"Wrote {args.out}")
    return 0


def _predict(bundle, df):
    X = features_of(df, bundle["sensors"])
    return bundle["estimator"].predict(X)


def cmd_predict(args):
    from skthermal.datasets import read_runs

    bundle = load_model(args.model)
    df = read_table(args.runs)
    pred = _predict(bundle, df)
    out = df.copy()
    out[f"pred_{bundle['target']}"] = pred
    try:
        _, meta = read_runs(args.runs, metadata=True, validate=False)
    except ValueError:
        meta = None
    write_table(
        out, args.out, metadata=meta if meta is not None and len(meta) else None
    )
    print(
        f"Predicted pred_{bundle['target']} (change since the start of each run) "
        f"for {df['run'].nunique()} run(s); wrote {args.out}"
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
        raise UserError(
            f"{where} has no prediction column pred_disp_<axis>_um; pass "
            "--predictions FILE or --model FILE."
        )
    if len(candidates) > 1:
        raise UserError(
            f"{where} has several prediction columns {candidates}; choose with "
            "--target."
        )
    return candidates[0][5:], candidates[0]


def cmd_evaluate(args):
    from skthermal._reproduce import METRIC_COLUMNS, markdown_table, score_runs

    if args.model and args.predictions:
        raise UserError("Give either --model or --predictions, not both.")
    df = read_table(args.runs)
    if args.model:
        bundle = load_model(args.model)
        target = args.target or bundle["target"]
        if target not in df.columns:
            raise UserError(f"{args.runs} has no measured {target!r} column.")
        pred = _predict(bundle, df)
        data = df
    else:
        if args.predictions:
            preds = read_table(args.predictions, "--predictions")
            target, col = _prediction_column(preds, args.target, args.predictions)
            data = df.merge(
                preds[["run", "time_s", col]], on=["run", "time_s"], how="inner"
            )
            if data.empty:
                raise UserError(
                    f"--predictions {args.predictions} shares no (run, time_s) rows "
                    f"with {args.runs}."
                )
        else:
            target, col = _prediction_column(df, args.target, args.runs)
            data = df
        if target not in data.columns:
            raise UserError(f"{args.runs} has no measured {target!r} column.")
        pred = data[col].to_numpy(dtype=float)
        if not np.all(np.isfinite(pred)):
            raise UserError(f"Column {col!r} has missing or infinite values.")
    table = score_runs(data[target], pred, data["run"].to_numpy())
    mean = {"run": "mean", "n_samples": int(table["n_samples"].sum())}
    mean.update(table[list(METRIC_COLUMNS)].mean().to_dict())
    mean["residual_um"] = table["residual_um"].max()
    table = pd.concat([table, pd.DataFrame([mean])], ignore_index=True)
    shown = table.copy()
    for c in METRIC_COLUMNS:
        shown[c] = [f"{v:.2f}" if np.isfinite(v) else "—" for v in table[c]]
    print(
        f"{target}: measured vs predicted change since the start of each run "
        "(residual: max |error|; mean row: residual is the max over runs)"
    )
    print(shown.to_string(index=False))
    if args.out:
        out = Path(args.out)
        if out.parent and not out.parent.exists():
            out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix.lower() == ".md":
            out.write_text(markdown_table(shown) + "\n", encoding="utf-8")
        elif out.suffix.lower() == ".csv":
            table.to_csv(out, index=False)
        else:
            raise UserError(f"--out {out}: write .csv or .md.")
        print(f"Wrote {out}")
    return 0


# --------------------------------------------------------------------------
# search, gap, gap-check: modules written in parallel, imported lazily
# --------------------------------------------------------------------------


def _optional(module, attribute, command, extra=None):
    """``module.attribute``, or a UserError that says what is missing."""
    try:
        mod = importlib.import_module(module)
    except ImportError as exc:
        missing = getattr(exc, "name", None)
        if missing and not missing.startswith("skthermal"):
            hint = f": pip install 'skthermal[{extra}]'" if extra else ""
            raise UserError(
                f"'skthermal {command}' needs the package {missing!r}{hint}."
            ) from exc
        raise UserError(
            f"'skthermal {command}' needs {module}, which this installation of "
            "skthermal does not have."
        ) from exc
    try:
        return getattr(mod, attribute)
    except AttributeError as exc:
        raise UserError(
            f"'skthermal {command}' needs {module}.{attribute}, which this "
            "installation of skthermal does not have."
        ) from exc


def _mlp_space(trial):
    """Search space of the MLP baseline (no built-in one exists)."""
    prefix = "estimator__transformedtargetregressor__regressor__"
    return {
        prefix + "hidden_layer_sizes": (trial.suggest_int("hidden", 2, 30),),
        prefix + "alpha": trial.suggest_float("alpha", 1e-6, 1e-1, log=True),
        prefix + "activation": trial.suggest_categorical(
            "activation", ["tanh", "relu"]
        ),
    }


def _search_space(model, n_inputs):
    from skthermal.model_selection import search_space

    if model == "anfis-fcm":
        return search_space("anfis", prefix="estimator", init="fcm")
    if model == "anfis-grid":
        return search_space("anfis", prefix="estimator", init="grid")
    if model == "gnnmci":
        return search_space("gnnmci", prefix="estimator")
    if model == "grey-pso":
        return search_space("grey_pso", prefix="estimator")
    return _mlp_space


def cmd_search(args):
    from skthermal._reproduce import MODELS, make_model
    from skthermal.datasets import split_runs

    if args.model not in MODELS:
        raise UserError(
            f"--model: unknown model {args.model!r}; choose one of {', '.join(MODELS)}."
        )
    if args.trials < 1:
        raise UserError(f"--trials must be at least 1, got {args.trials}.")
    run_search = _optional(
        "skthermal.model_selection", "run_search", "search", "optuna"
    )
    _optional("optuna", "create_study", "search", "optuna")
    import optuna

    df = read_table(args.runs)
    target = pick_target(df, args.target, args.runs)
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
            f"{args.runs} has {n_runs} run; the search cross-validates over runs "
            "and needs at least 2."
        )
    study_name = args.study_name
    if args.storage and not study_name:
        study_name = f"skthermal-{args.model}"
    model = make_model(args.model, random_state=args.seed)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    print(
        f"Searching {MODELS[args.model].label} on {len(sensors)} input(s) -> "
        f"{target}: {args.trials} trial(s), {min(5, n_runs)}-fold CV over "
        f"{n_runs} runs"
        + (f", study {study_name!r} in {args.storage}" if args.storage else "")
        + " ...",
        flush=True,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        result = run_search(
            model,
            X,
            y,
            groups,
            space=_search_space(args.model, len(sensors)),
            n_trials=args.trials,
            storage=args.storage,
            study_name=study_name,
            random_state=args.seed,
        )
    _note_warnings(caught, "search")
    trials = result.trials_dataframe()
    done = int((trials["state"] == "COMPLETE").sum()) if len(trials) else 0
    if result.best_params_ is None:
        raise UserError(
            f"No trial of {len(trials)} completed; see the trials' 'error' "
            "attribute in the study."
        )
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
            "storage": args.storage,
            "study_name": study_name,
        }
        Path(args.out).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
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
                "train_runs": [str(r) for r in pd.unique(groups)],
                "skthermal_version": __version__,
            },
            args.save_model,
        )
        print(f"Wrote {args.save_model} (best parameters, refitted on all runs)")
    return 0


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, tuple):
        return list(value)
    return value


def cmd_gap(args):
    diagnose = _optional("skthermal.gap", "diagnose", "gap")
    from skthermal.simulate import ThermalMachine

    df = read_table(args.runs)
    machine = ThermalMachine.from_preset(
        args.preset, effects=_effects(args.effects) or []
    )
    candidates = _effects(args.candidates)
    print(
        f"Diagnosing {args.runs} ({df['run'].nunique()} run(s)) against preset "
        f"{args.preset} (effects on: {', '.join(machine.effects) or 'none'}) ...",
        flush=True,
    )
    report = diagnose(machine, df, candidates=candidates)
    print(report.verdict())
    shown = [
        c
        for c in ("effect", "gap_before", "gap_after", "shrink", "p_value", "explains")
        if c in report.ranking.columns
    ]
    with pd.option_context("display.width", 120, "display.precision", 3):
        print(report.ranking[shown].to_string(index=False))
    if args.report:
        report.save(args.report)
        print(f"Report: {args.report}")
    return 0


def cmd_gap_check(args):
    validate = _optional("skthermal.gap", "validate", "gap-check")
    if args.seeds < 1:
        raise UserError(f"--seeds must be at least 1, got {args.seeds}.")
    effects = _effects(args.effects)
    print(
        f"Checking the gap diagnosis: {args.seeds} seed(s) per case, preset "
        f"{args.preset} ...",
        flush=True,
    )
    result = validate(
        effects,
        seeds=args.seeds,
        preset=args.preset,
        random_state=args.seed,
        n_jobs=args.n_jobs,
    )
    for key, value in result.rates.items():
        print(
            f"  {key}: {value:.2f}" if isinstance(value, float) else f"  {key}: {value}"
        )
    for key, met in result.targets.items():
        print(f"  target {key}: {'met' if met else 'NOT met'}")
    if args.report:
        folder = Path(args.report)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "validation.md").write_text(result.to_markdown(), encoding="utf-8")
        result.cases.to_csv(folder / "cases.csv", index=False)
        result.confusion.to_csv(folder / "confusion.csv")
        print(f"Report: {folder}")
    return 0 if result.meets_targets() else 1
