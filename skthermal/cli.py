"""The ``skthermal`` command.

Subcommands:

``demo``
    An end-to-end run on generated data: synthetic heating tests with groups
    of collinear sensors, fuzzy c-means sensor selection, a compensation model
    trained on some runs and evaluated on held-out runs, and a table of the
    papers' metrics.

User errors print one line and exit with status 2, never a traceback.
"""

import argparse
import sys
from pathlib import Path

import pandas as pd


class UserError(Exception):
    """An error in the user's input: reported as one line, exit status 2."""


def _demo(args):
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


def build_parser():
    parser = argparse.ArgumentParser(
        prog="skthermal",
        description="Thermal-error modelling of CNC machine tools.",
    )
    from skthermal import __version__

    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser(
        "demo",
        help="end-to-end demo on generated data",
        description=(
            "Generate heating tests with groups of collinear sensors, select one "
            "sensor per group with fuzzy c-means, and score compensation models "
            "on held-out runs."
        ),
    )
    demo.add_argument("--runs", type=int, default=4, help="test runs (default 4)")
    demo.add_argument(
        "--groups", type=int, default=3, help="heat-driven sensor groups (default 3)"
    )
    demo.add_argument("--sensors-per-group", type=int, default=10, help="default 10")
    demo.add_argument("--noise-sensors", type=int, default=10, help="default 10")
    demo.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    demo.add_argument(
        "--out", metavar="DIR", help="also write the runs and scores here"
    )
    demo.set_defaults(func=_demo)
    return parser


def main(argv=None):
    """Entry point of the ``skthermal`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return args.func(args)
    except (UserError, ValueError, FileNotFoundError) as exc:
        print(f"skthermal {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
