"""``skthermal reproduce`` and ``skthermal demo``: the papers' study, a demo."""

from pathlib import Path

import pandas as pd

from skthermal._cli._common import (
    UserError,
    check_out_path,
    check_positive,
    split_list,
)


def cmd_reproduce(args):
    from skthermal.models import MODELS
    from skthermal.study import reproduce
    from skthermal.study._report import format_results, format_summary, text_table

    check_positive(args.sample_period, "--sample-period", upper=720.0)
    models = split_list(args.models)
    if models == []:
        raise UserError(
            f"--models names no model; choose from {', '.join(MODELS)} (or leave "
            "it out for the default models)."
        )
    if models:
        unknown = [m for m in models if m not in MODELS]
        if unknown:
            raise UserError(
                f"--models: unknown model(s) {unknown}; choose from "
                f"{', '.join(MODELS)}."
            )
    out = Path(args.out)
    check_out_path(out, "--out", folder=True)
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


def cmd_demo(args):
    from sklearn.linear_model import LinearRegression
    from sklearn.model_selection import GroupKFold
    from sklearn.pipeline import make_pipeline

    from skthermal import FCMClusterPicker, GreyInfluenceSelector
    from skthermal.datasets import make_sensor_groups, split_runs
    from skthermal.metrics import (
        improvement,
        nash_sutcliffe,
        pearson_r,
        residual_band,
        rmse,
    )

    if args.runs < 2:
        raise UserError(
            f"--runs must be at least 2 (one to train, one to test), got {args.runs}"
        )
    if args.groups < 1 or args.sensors_per_group < 1:
        raise UserError("--groups and --sensors-per-group must be at least 1")
    check_out_path(args.out, "--out", folder=True)
    runs, truth = make_sensor_groups(
        n_groups=args.groups,
        sensors_per_group=args.sensors_per_group,
        n_noise=args.noise_sensors,
        n_runs=args.runs,
        random_state=args.seed,
    )
    X, y, groups = split_runs(runs)
    n_sensors = X.shape[1]
    print(
        f"Generated {args.runs} runs x {runs.shape[0] // args.runs} samples: "
        f"{n_sensors} sensors ({args.groups} heat-driven groups of "
        f"{args.sensors_per_group} collinear sensors, {args.noise_sensors} noise "
        "sensors), target disp_y_um."
    )

    picker = FCMClusterPicker(n_clusters=args.groups, random_state=args.seed)
    picker.fit(X, y)
    kept = picker.get_feature_names_out()
    print(f"\nFCMClusterPicker kept {len(kept)} of {n_sensors} sensors:")
    scores = pd.Series(picker.scores_, index=X.columns)
    for name in kept:
        g = truth[name]
        what = f"group {g}" if g >= 0 else "NOISE"
        print(f"  {name}  (true {what}, GM(1,N) influence {scores[name]:.3g})")

    models = {
        f"FCM picker ({args.groups}) + linear": make_pipeline(
            FCMClusterPicker(n_clusters=args.groups, random_state=args.seed),
            LinearRegression(),
        ),
        f"grey top-{args.groups} + linear": make_pipeline(
            GreyInfluenceSelector(n_features_to_select=args.groups),
            LinearRegression(),
        ),
        f"all {n_sensors} sensors + linear": LinearRegression(),
    }
    rows = []
    cv = GroupKFold(n_splits=args.runs)
    for name, model in models.items():
        for train, test in cv.split(X, y, groups):
            model.fit(X.iloc[train], y.iloc[train])
            # Displacements are compared as change since the run start, as
            # a compensation would apply them.
            z = y.iloc[test].to_numpy()
            p = model.predict(X.iloc[test])
            p, z = p - p[0], z - z[0]
            rows.append(
                {
                    "model": name,
                    "test run": groups[test][0],
                    "R": pearson_r(z, p),
                    "RMSE (µm)": rmse(z, p),
                    "NSE": nash_sutcliffe(z, p),
                    "residual (±µm)": residual_band(z, p),
                    "improvement": improvement(z, p),
                }
            )
    table = pd.DataFrame(rows)
    summary = table.groupby("model", sort=False).mean(numeric_only=True)
    with pd.option_context(
        "display.float_format", "{:.3f}".format, "display.width", 120
    ):
        print(f"\nHeld-out runs (leave one run out, {args.runs} folds), mean:")
        print(summary.to_string())
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        runs.to_csv(out / "runs.csv", index=False)
        table.to_csv(out / "scores.csv", index=False)
        print(f"\nWrote {out / 'runs.csv'} and {out / 'scores.csv'}")
    return 0
