"""The report of the Machine B study: tables as text and Markdown, figures."""

import json

import numpy as np
import pandas as pd

from skthermal._markdown import markdown_table
from skthermal.models import MODELS
from skthermal.study._constants import PAPER, PAPER_SENSORS, TARGET, TEST_RUNS


def _fmt(value, spec=".2f", prefix=""):
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "—"
    if isinstance(value, int | np.integer):
        return f"{prefix}{value}"
    return f"{prefix}{value:{spec}}"


def format_results(results):
    """The long result table in the form of 001 Tables 5-7/5-8 (strings)."""
    rows = []
    for r in results.to_dict("records"):
        rows.append(
            {
                "Test": r["test"],
                "Model": r["label"],
                "Rules": _fmt(r["rules"] if pd.notna(r["rules"]) else None),
                "R": _fmt(r["R"]),
                "RMSE µm": _fmt(r["RMSE_um"]),
                "NSE": _fmt(r["NSE"]),
                "Residual": _fmt(r["residual_um"], ".1f", "±"),
                "Improv. %": _fmt(r["improvement_pct"], ".0f"),
                "Paper R": _fmt(r["paper_R"]),
                "Paper RMSE": _fmt(r["paper_RMSE_um"]),
                "× paper": _fmt(r["RMSE_vs_paper"], ".1f"),
                "Paper NSE": _fmt(r["paper_NSE"]),
                "Paper resid.": _fmt(r["paper_residual_um"], ".0f", "±"),
            }
        )
    return pd.DataFrame(rows)


def format_summary(summary):
    rows = []
    for r in summary.to_dict("records"):
        rows.append(
            {
                "Model": r["label"],
                "Rules": _fmt(r["rules"] if pd.notna(r["rules"]) else None),
                "Train RMSE (IV) µm": _fmt(r["train_RMSE_um"]),
                "Mean RMSE µm": _fmt(r["RMSE_um"]),
                "Paper mean RMSE": _fmt(r["paper_RMSE_um"]),
                "Max residual µm": _fmt(r["residual_um"], ".1f", "±"),
                "Mean R": _fmt(r["R"]),
                "Mean NSE": _fmt(r["NSE"]),
                "Fit s": _fmt(r["fit_s"], ".1f"),
            }
        )
    return pd.DataFrame(rows)


def text_table(frame):
    """Left-aligned first columns, right-aligned numbers, for the terminal."""
    cols = list(frame.columns)
    widths = [max(len(str(c)), *(len(str(v)) for v in frame[c])) for c in cols]
    left = {"Test", "Model", "Sensor", "Location", "Description"}

    def line(values):
        cells = []
        for c, w, v in zip(cols, widths, values, strict=True):
            cells.append(str(v).ljust(w) if c in left else str(v).rjust(w))
        return "  ".join(cells).rstrip()

    out = [line(cols)]
    out += [line(row) for row in frame.itertuples(index=False, name=None)]
    return "\n".join(out)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if value is None or isinstance(value, str | int | float | bool):
        return value
    return repr(value)


def _write_tables(out, result, figure_files, figure_note):
    files = []
    result.results.to_csv(out / "results.csv", index=False)
    result.summary.to_csv(out / "summary.csv", index=False)
    result.sensors.to_csv(out / "sensors.csv", index=False)
    result.campaign.to_csv(out / "campaign.csv", index=False)
    result.predictions.to_csv(out / "predictions.csv.gz", index=False)
    files += [
        "results.csv",
        "summary.csv",
        "sensors.csv",
        "campaign.csv",
        "predictions.csv.gz",
    ]
    with open(out / "settings.json", "w", encoding="utf-8") as fh:
        json.dump(_jsonable(result.settings), fh, indent=2, ensure_ascii=False)
        fh.write("\n")
    files.append("settings.json")
    (out / "report.md").write_text(
        report_markdown(result, figure_files, figure_note), encoding="utf-8"
    )
    files.append("report.md")
    return files


def report_markdown(result, figure_files=(), figure_note=None):
    """The report as Markdown: tables beside the papers' figures, figures."""
    s = result.settings
    sel = result.sensors[result.sensors["selected"]]
    sensors = pd.DataFrame(
        {
            "Sensor": sel["sensor"],
            "Location": sel["location"],
            "Group": sel["group"],
            "GM(1,N) influence": [f"{v:.3g}" for v in sel["gm1n_influence"]],
        }
    )
    camp = result.campaign
    campaign = pd.DataFrame(
        {
            "Test": camp["test"],
            "Role": camp["role"],
            "Description": camp["description"],
            "Samples": camp["samples"],
            "Sim. max ΔY µm": [f"{v:.1f}" for v in camp["sim_max_dY_um"]],
            "Paper max Y µm": [_fmt(v, ".0f") for v in camp["paper_max_Y_um"]],
        }
    )
    lines = [
        "# Machine B study, replicated on the simulator",
        "",
        "Tests I-VI of Machine B (001 §5.3; 000) simulated with the `vmc-b` "
        f"preset, {s['sample_period_s']:g} s sampling, seed {s['seed']}"
        + (" (quick budget)" if s["quick"] else "")
        + ". Sensors selected and models trained on Test IV; scored on "
        "Tests I, II, III, V and VI. Measured and predicted Y displacement are "
        "compared as change since the start of each test, as a compensation "
        "applies them. Paper columns: 001 Tables 5-7 and 5-8 (ANFIS models "
        "only; — where the paper has no figure).",
        "",
        f"**{result.finding}**" if result.finding else "",
        "",
        "## Results per test (001 Tables 5-7, 5-8)",
        "",
        markdown_table(format_results(result.results)),
        "",
        "## Mean over the five tests",
        "",
        markdown_table(format_summary(result.summary)),
        "",
        "## Selected sensors (paper: " + ", ".join(PAPER_SENSORS) + ")",
        "",
        markdown_table(sensors),
        "",
        "## The simulated campaign",
        "",
        markdown_table(campaign),
        "",
        "## Figures (001 Figs. 5-11 to 5-15)",
        "",
    ]
    if figure_files:
        lines += [f"![{f}]({f})" for f in figure_files]
    else:
        lines.append(figure_note or "No figures.")
    lines += [
        "",
        "## Files",
        "",
        "`results.csv` (per test and model), `summary.csv` (means), "
        "`sensors.csv` (all 77 sensors: group, influence, selected), "
        "`campaign.csv`, `predictions.csv.gz` (changes since the start of each "
        "test, every model), `runs.csv.gz` (the simulated run table, metadata "
        "sidecar `runs.csv.gz.json`), `settings.json` (settings, versions, "
        "timings).",
        "",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------
# Figures (plain matplotlib, no pyplot state)
# --------------------------------------------------------------------------


def _draw_figures(out, result, models):
    from matplotlib.figure import Figure

    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    files = []
    pred = result.predictions
    # Paper layout: (a) ANFIS-Grid, (b) ANFIS-FCM; otherwise every model.
    panels = [m for m in ("anfis-grid", "anfis-fcm") if m in models] or models[:2]
    figure_no = {"I": "5-11", "II": "5-12", "III": "5-13", "V": "5-14", "VI": "5-15"}
    table = result.results.set_index(["test", "model"])
    for test in TEST_RUNS:
        part = pred[pred["run"] == test]
        hours = part["time_s"].to_numpy() / 3600.0
        z = part[TARGET].to_numpy()
        fig = Figure(figsize=(5.2 * len(panels), 5.2), layout="constrained")
        axes = fig.subplots(
            2, len(panels), sharex=True, squeeze=False, height_ratios=[2.2, 1]
        )
        for j, name in enumerate(panels):
            p = part[f"pred_{name}"].to_numpy()
            top, bottom = axes[0, j], axes[1, j]
            top.plot(hours, z, color="black", lw=1.6, label="measured")
            top.plot(hours, p, color="tab:red", lw=1.2, ls="--", label="predicted")
            row = table.loc[(test, name)]
            top.set_title(
                f"({chr(97 + j)}) {MODELS[name].label}: RMSE {row['RMSE_um']:.2f} µm",
                fontsize=10,
            )
            top.set_ylabel("Y change (µm)")
            top.legend(loc="best", fontsize=8)
            top.grid(alpha=0.3)
            bottom.plot(hours, z - p, color="tab:blue", lw=1.0)
            bottom.axhline(0.0, color="gray", lw=0.8)
            bottom.set_ylabel("residual (µm)")
            bottom.set_xlabel("time (h)")
            bottom.grid(alpha=0.3)
        fig.suptitle(
            f"Test {test} (cf. 001 Fig. {figure_no[test]}), trained on Test IV",
            fontsize=11,
        )
        name = f"figures/test_{test}.png"
        fig.savefig(out / name, dpi=110)
        files.append(name)

    fig = Figure(figsize=(8, 4.2), layout="constrained")
    ax = fig.subplots()
    width = 0.8 / max(len(models), 1)
    x = np.arange(len(TEST_RUNS))
    for k, name in enumerate(models):
        vals = [table.loc[(t, name), "RMSE_um"] for t in TEST_RUNS]
        ax.bar(
            x + (k - (len(models) - 1) / 2) * width,
            vals,
            width,
            label=MODELS[name].label,
        )
    for name, marker in (("anfis-fcm", "o"), ("anfis-grid", "s")):
        if name in models:
            k = models.index(name)
            paper = [PAPER[(t, name)][1] for t in TEST_RUNS]
            ax.plot(
                x + (k - (len(models) - 1) / 2) * width,
                paper,
                marker,
                color="black",
                mfc="white",
                label=f"paper {MODELS[name].label}",
            )
    ax.set_xticks(x, [f"Test {t}" for t in TEST_RUNS])
    ax.set_yscale("log")
    ax.set_ylabel("RMSE (µm, log scale)")
    ax.set_title("RMSE per test, models trained on Test IV")
    ax.grid(alpha=0.3, axis="y", which="both")
    ax.legend(fontsize=8, ncols=2)
    name = "figures/rmse_by_test.png"
    fig.savefig(out / name, dpi=110)
    files.append(name)
    return files
