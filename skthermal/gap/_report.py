"""The gap report: tables, verdict, plots and files."""

import functools
import json
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal._markdown import markdown_table
from skthermal._naming import percent, removes
from skthermal.gap._scores import BANDS_H, GAP_UNIT, beyond_noise, excess_shrink


def _largest_jumps(jumps, table, file, limit=20):
    """The markdown ``table`` of the ``limit`` largest jumps (``size``), in
    the order of the table (model, run, time), with a note of the rows left
    out and the ``file`` that holds them all."""
    shown = jumps
    if len(jumps) > limit:
        keep = jumps["size"].sort_values(ascending=False, kind="stable").index[:limit]
        shown = jumps.loc[sorted(keep)]
    out = [table(shown)]
    if len(shown) < len(jumps):
        out.append(f"\n(The {limit} largest of {len(jumps)} jumps; all in `{file}`.)")
    return out


# A runner-up within this share of the held-out gap of the named effect
# (screening calibration) is said in the verdict: 0.47 beside 0.50 read as
# a clear-cut verdict (an independent check's lathe).
CLOSE_SHRINK = 0.1

# Least error, in multiples of its noise, of a channel that save() draws
# beside the displacements: one at its noise level misses nothing.
_FIGURE_NOISE = 2.0


def _for_noise(channels):
    """Each row's RMSE in multiples of its channel's noise (inf where the
    noise is 0): the channels' errors, comparable across µm and °C."""
    noise = channels["noise"].where(channels["noise"] > 0)
    return (channels["rmse"] / noise).fillna(np.inf)


def _largest_per_model(channels, table, file, limit=10):
    """The markdown ``table`` of each model's ``limit`` channels of largest
    error for their noise (displacements and temperatures alike), the
    models in their order, with a note of the rows left out."""
    relative = _for_noise(channels)
    ordered = channels.loc[relative.sort_values(ascending=False, kind="stable").index]
    models = list(dict.fromkeys(channels["model"]))
    shown = pd.concat(
        [ordered[ordered["model"] == m].head(limit) for m in models],
        ignore_index=True,
    )
    out = [table(shown)]
    if len(shown) < len(channels):
        out.append(
            f"\n(The {limit} channels of largest error for their noise per model, "
            f"{len(shown)} of {len(channels)} rows; all in `{file}`.)"
        )
    return out


def _units(problem, R):
    """Residuals back in channel units (µm, °C)."""
    return R / np.sqrt(problem.weight) * problem.scale


def _smallest_step(A):
    """Each column's smallest change between consecutive rows, above the
    rounding of its values (0 where it never changes): one reading step of
    a channel logged in steps."""
    D = np.abs(np.diff(A, axis=0))
    tiny = 1e-9 * np.maximum(np.abs(A).max(axis=0), 1e-300)
    steps = np.where(D > tiny, D, np.inf).min(axis=0)
    return np.where(np.isfinite(steps), steps, 0.0)


def _where_tables(problem, Rs, regimes, label):
    runs, chans, regs, bands, jumps = [], [], [], [], []
    all_units = []
    for run, R, lab in zip(problem.runs, Rs, regimes, strict=True):
        U = _units(problem, R)
        all_units.append(U)
        runs.append(
            {
                "model": label,
                "run": run.name,
                "samples": R.shape[0],
                "gap": float(np.sqrt(np.mean(np.sum(R * R, axis=1)))),
            }
        )
        for j, ch in enumerate(problem.channels):
            chans.append(
                {
                    "model": label,
                    "run": run.name,
                    "channel": ch,
                    "rmse": float(np.sqrt(np.mean(U[:, j] ** 2))),
                    "bias": float(np.mean(U[:, j])),
                    "max_abs": float(np.max(np.abs(U[:, j]))),
                }
            )
        e = np.sum(R * R, axis=1)
        regs.append(pd.DataFrame({"regime": lab["regime"].to_numpy(), "e": e}))
        # Frequency bands of the residual, from its spectrum: each channel's
        # power, summed (a sum of the signed residuals would let channels
        # of opposite sign cancel). Per sample, the power of all bands
        # sums to the squared gap about each channel's mean (Parseval).
        m = R.shape[0]
        t = run.time_s[run.rows]
        if m > 4:
            dt_h = float(np.median(np.diff(t))) / 3600.0
            F = np.fft.rfft(R - R.mean(axis=0), axis=0)
            weight = np.full(F.shape[0], 2.0)  # one-sided: both halves
            weight[0] = 1.0
            if m % 2 == 0:
                weight[-1] = 1.0
            spec = weight * np.sum(np.abs(F) ** 2, axis=1) / m**2
            freq = np.fft.rfftfreq(m, d=dt_h)
            period = np.divide(
                1.0, freq, out=np.full_like(freq, np.inf), where=freq > 0
            )
            for name, lo, hi in BANDS_H:
                sel = (period > lo) & (period <= hi) & (freq > 0)
                bands.append({"band": name, "power": float(spec[sel].sum())})
        # Where the gap jumps: outliers of each channel's first difference
        # (channel by channel: a sum over channels would let jumps of
        # opposite sign cancel), the channel that jumps most at each time.
        D = np.diff(R, axis=0)
        if D.shape[0] > 2:
            dev = np.abs(D - np.median(D, axis=0))
            mad = np.median(dev, axis=0) / 0.6745
            # Quantised readings change in steps, mostly not at all: their
            # median deviation is 0, and a single reading step must not count
            # as a jump. The smallest step taken is the floor of the spread:
            # the residual's own, and the reading step of the measured and
            # the simulated channel (a smooth simulation less readings
            # logged in steps of 0.1 °C has no step of its own, and every
            # reading step stood out as a jump). Half a step: jumps of 3
            # reading steps or more are found (at a full step, a 0.4 °C jump
            # of a channel logged in 0.1 °C steps never was).
            measured = run.y * (np.sqrt(problem.weight) / problem.scale)
            floor = 0.5 * np.maximum.reduce(
                [
                    _smallest_step(R),
                    _smallest_step(measured),
                    _smallest_step(R + measured),
                ]
            )
            mad = np.maximum(mad, floor)
            ratio = np.abs(D) / np.maximum(mad, 1e-12)
            big = np.flatnonzero(ratio.max(axis=1) > 6)
            # The 10 largest of a run, in time order.
            big = np.sort(big[np.argsort(-ratio[big].max(axis=1))[:10]])
            for k in big:
                j = int(np.argmax(ratio[k]))
                jumps.append(
                    {
                        "model": label,
                        "run": run.name,
                        "time_s": float(t[k + 1]),
                        "channel": problem.channels[j],
                        # In the channel's unit, simulated minus measured.
                        "jump": float(U[k + 1, j] - U[k, j]),
                        "size": float(ratio[k, j]),
                    }
                )
    reg = pd.concat(regs, ignore_index=True)
    total = reg["e"].sum()
    reg_table = reg.groupby("regime").agg(samples=("e", "size"), sq=("e", "sum"))
    reg_table["share_time"] = reg_table["samples"] / reg_table["samples"].sum()
    reg_table["share_sq_error"] = reg_table["sq"] / total if total > 0 else 0.0
    reg_table["gap"] = np.sqrt(reg_table["sq"] / reg_table["samples"])
    reg_table = reg_table.drop(columns="sq").reset_index()
    reg_table.insert(0, "model", label)
    U = np.vstack(all_units)
    chan_all = pd.DataFrame(
        {
            "model": label,
            "channel": problem.channels,
            "rmse": np.sqrt(np.mean(U**2, axis=0)),
            "bias": U.mean(axis=0),
            "max_abs": np.abs(U).max(axis=0),
            "noise": problem.noise,
        }
    )
    band_table = pd.DataFrame(bands)
    if len(band_table):
        band_table = band_table.groupby("band", sort=False)["power"].sum().reset_index()
        band_table["share"] = band_table["power"] / band_table["power"].sum()
        band_table.insert(0, "model", label)
    return {
        "runs": pd.DataFrame(runs),
        "regimes": reg_table,
        "channels": chan_all,
        "channels_by_run": pd.DataFrame(chans),
        "bands": band_table,
        "jumps": pd.DataFrame(
            jumps, columns=["model", "run", "time_s", "channel", "jump", "size"]
        ),
    }


def with_recorded_warnings(diagnosis):
    """Decorate a diagnosis returning a :class:`GapReport`: the warnings it
    raised are said as before and recorded in ``report.settings
    ["warnings"]``, so a saved report keeps them (a unit slip warned about
    on the console left no trace in report.md)."""

    @functools.wraps(diagnosis)
    def wrapper(*args, **kwargs):
        with warnings.catch_warnings(record=True) as caught:
            report = diagnosis(*args, **kwargs)
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        report.settings["warnings"] = [
            f"{w.category.__name__}: {w.message}" for w in caught
        ]
        return report

    return wrapper


@dataclass
class GapReport:
    """Result of :func:`skthermal.gap.diagnose`.

    Attributes
    ----------
    ranking : DataFrame
        One row per candidate: ``effect``, ``gap_before``, ``gap_after`` (held
        out, normalised), ``shrink`` (share of the gap above the noise floor
        removed), ``shrink_raw``, ``p_value`` (paired test over held-out
        runs), ``runs_improved``, ``extra_params``, ``xcorr_before`` /
        ``xcorr_after`` (largest residual-driver correlation), ``explains``
        and the ``fitted`` parameter value (in the run-table mode a dict of
        the term's parameters; for ``sensor_drift``, which has none, the
        rates' root mean square ``rate_C_per_h``). Best first.
    best_effect : str or None
        The effect that explains the gap, or None when no candidate explains
        it beyond noise.
    where : dict of DataFrame
        ``runs``, ``regimes``, ``channels``, ``channels_by_run``, ``bands``,
        ``jumps``: the gap of the simulation as given and after calibrating
        its base parameters (column ``model``).
    regime_shrink : DataFrame
        Shrink of the held-out gap per regime (rows) and candidate (columns).
    how_far : DataFrame
        Held-out gap per regime and overall (columns ``effect``, ``regime``,
        ``gap_before``, ``gap_after``, ``shrink`` above the noise floor and
        ``shrink_raw``) before and after the best effect, or the best
        candidate when none explains the gap, both with the fine
        calibration.
    how_far_evidence : dict
        The overall evidence of that comparison (the ranking's columns, and
        ``calibration``: ``"fine"`` or ``"screening"``).
    steps : DataFrame
        Effects added greedily, with the held-out gap after each.
    noise_floor : float
        The gap that measurement noise alone would leave.
    machines : dict
        The simulation with the network parameters calibrated on all runs
        (the capacity, convection and air-exchange multipliers, and an
        identified effect's parameter), without and (when an effect
        explains the gap) with the identified effects, for
        :func:`skthermal.gap.downstream_error`. The calibration's
        per-channel gains of the air, bearing, drive and feed
        parts are not part of these machines (a network has no such
        parameter), so they do not reproduce the "calibrated" fit of the
        where-table; to get a machine that does, fit it with
        :meth:`ThermalMachine.calibrate` on the heat inputs and displacement
        coefficients.
    not_applicable : dict
        Candidates that were not scored because they cannot change the
        compared channels on these runs, with the reason: ``{effect:
        reason}``.
    explainable : dict
        The flexible discrepancy model of the drivers (holding every
        candidate's signal): held-out ``gap_before`` (the base's) and
        ``gap_after``, ``share`` (share of the base's held-out gap above the
        noise floor it removes: an estimate of what any added term could
        close; not clipped, negative when it makes the held-out gap worse)
        and its whiteness. ``share_of_explainable`` in the ranking is each
        shrink divided by that share (above 1 when a term removes more; NaN
        when the share is not positive). Empty when no candidate was scored.
    drift_rates : dict
        ``{temperature channel: rate}``: the drift rate fitted for every
        compared temperature channel, in °C per hour of its readings (median
        over the folds), by the machine's own base when it has
        ``sensor_drift`` on, else by the ``sensor_drift`` candidate; a
        sensor whose rate stands out is the one that drifts. The ranking's
        ``fitted`` for ``sensor_drift`` is their root mean square (as the
        simulator's ``sensor_drift.rate_C_per_h``, a spread over sensors).
        In the run-table mode (:func:`diagnose_runs`), the ``sensor_drift``
        term's gain per channel. Empty when no calibration modelled drift.
    initial_states : DataFrame or None
        Every run's initial node temperatures above its first air reading
        (K; rows: runs, columns: the machine's nodes), as the diagnosis
        simulated them: zero with ``initial="ambient"``, estimated from the
        first readings with ``initial="measured"``; None in the run-table
        mode.

    The ranking also holds, per candidate, the evidence grey-box
    identification selects structure by: the likelihood-ratio test of the
    calibration with the candidate against the base, in sample
    (``lr_statistic``, ``lr_p_value``, ``delta_aic``, ``delta_bic``), and
    the whiteness of the held-out residual before and after
    (``whiteness_before``, ``whiteness_after``: largest deviation of the
    cumulated periodogram from the diagonal; ``white_band``, the 95%
    Kolmogorov-Smirnov band; ``white_after``).
    """

    # The where-tables' model that where_summary and save's extra figure
    # read by default (not a field): a preset as given is off everywhere,
    # so the ThermalMachine mode answers after its base calibration.
    where_model = "base calibrated"

    ranking: pd.DataFrame
    best_effect: str | None
    where: dict
    regime_shrink: pd.DataFrame
    how_far: pd.DataFrame
    steps: pd.DataFrame
    noise_floor: float
    how_far_evidence: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    timelines: dict = field(default_factory=dict, repr=False)
    machines: dict = field(default_factory=dict, repr=False)
    not_applicable: dict = field(default_factory=dict)
    explainable: dict = field(default_factory=dict)
    drift_rates: dict = field(default_factory=dict)
    initial_states: pd.DataFrame = field(default=None, repr=False)

    @classmethod
    def _build(
        cls,
        *,
        problem,
        machine,
        candidates,
        ranking,
        regime_shrink,
        best_effect,
        steps,
        base_R,
        best_R,
        fine_row,
        fine_regimes,
        fine_before_R,
        fine_after_R,
        as_given,
        calibrated,
        regimes,
        floor2,
        settings,
    ):
        where_a = _where_tables(problem, as_given, regimes, "as given")
        where_c = _where_tables(problem, calibrated, regimes, "base calibrated")
        where = {
            k: pd.concat([where_a[k], where_c[k]], ignore_index=True) for k in where_a
        }
        if fine_row is not None:
            before, after = fine_regimes
            how_far = pd.DataFrame({"gap_before": before, "gap_after": after})
            how_far.loc["overall"] = [fine_row["gap_before"], fine_row["gap_after"]]
            how_far["shrink"] = [
                excess_shrink(gb, ga, floor2)
                for gb, ga in zip(
                    how_far["gap_before"], how_far["gap_after"], strict=True
                )
            ]
            how_far["shrink_raw"] = 1 - how_far["gap_after"] / how_far["gap_before"]
            how_far.index.name = "regime"
            how_far = how_far.reset_index()
            how_far.insert(0, "effect", fine_row["effect"])
        else:
            how_far = pd.DataFrame(
                columns=[
                    "effect",
                    "regime",
                    "gap_before",
                    "gap_after",
                    "shrink",
                    "shrink_raw",
                ]
            )
        if best_R is not None and fine_row is not None:
            # The timelines show the how-far comparison.
            base_R, best_R = fine_before_R, fine_after_R
        timelines = {}
        for i, run in enumerate(problem.runs):
            cols = {
                "time_s": run.time_s[run.rows],
                "regime": regimes[i]["regime"].to_numpy(),
            }
            Ub = _units(problem, base_R[i])
            Ua = _units(problem, best_R[i]) if best_R is not None else None
            for j, ch in enumerate(problem.channels):
                cols[f"measured:{ch}"] = run.y[:, j]
                cols[f"residual_before:{ch}"] = Ub[:, j]
                if Ua is not None:
                    cols[f"residual_after:{ch}"] = Ua[:, j]
            timelines[run.name] = pd.DataFrame(cols)
        settings = dict(
            settings,
            machine=machine.name,
            candidates=list(candidates),
            channels=list(problem.channels),
        )
        return cls(
            ranking=ranking,
            best_effect=best_effect,
            where=where,
            regime_shrink=regime_shrink,
            how_far=how_far,
            steps=pd.DataFrame(
                steps, columns=["added", "gap", "shrink", "calibration"]
            ),
            noise_floor=float(np.sqrt(floor2)),
            how_far_evidence=dict(fine_row or {}),
            settings=settings,
            timelines=timelines,
        )

    # --- text ------------------------------------------------------------------

    def verdict(self):
        """One sentence: which effect explains the gap, or that none does."""
        if not self.not_applicable:
            return self._verdict()
        return f"{self._verdict()} {self._not_applicable_text()}"

    def _not_applicable_text(self, name="{}"):
        """The candidates not scored, as a sentence; ``name`` formats each
        effect's name (e.g. ``"`{}`"`` in Markdown)."""
        return (
            "Not applicable on these runs (not scored): "
            + "; ".join(
                f"{name.format(e)}: {why}" for e, why in self.not_applicable.items()
            )
            + "."
        )

    def _verdict(self):
        fine = self.how_far_evidence
        if not fine:
            return "No candidate effect was tested."
        how = (
            "once the spindle head is calibrated finely"
            if fine.get("calibration") == "fine"
            else "with the screening calibration"
        )
        table = (
            "table 'How far', overall"
            if fine.get("calibration") == "fine"
            else ("table 'Which effect'")
        )
        evidence = (
            f"held-out gap {fine['gap_before']:.3g} -> {fine['gap_after']:.3g} "
            f"({table}), "
            f"{fine['runs_improved']}/{fine['n_runs']} held-out runs better, "
            f"p = {fine['p_value']:.2g}"
        )
        if self.best_effect is None:
            text = (
                f"{self._none_opening(fine)} ({self._best_candidate_text(fine, how)}"
                f": {evidence}{self._flexible_text(fine)})."
            )
            return text + self._unnamed_tail(fine)
        text = (
            f"{self.best_effect!r} explains the gap: adding it removes "
            f"{percent(fine['shrink'])} of the held-out gap above the noise floor "
            f"{how} ({evidence}{self._flexible_text(fine)})"
        )
        if fine.get("calibration") == "fine":
            row = self.ranking.set_index("effect").loc[fine["effect"]]
            text += (
                f"; with the screening calibration (table 'Which effect') "
                f"{row['gap_before']:.3g} -> {row['gap_after']:.3g}, "
                f"{percent(row['shrink'])}"
            )
        return text + "." + self._bound_text(fine) + self._named_tail()

    def _named_tail(self):
        """What a verdict naming an effect ends with, in both modes: the
        effects the greedy steps added after it, and the other candidates
        that pass the test alone (table 'Which effect') and are not among
        the steps: the runs then do not single out the named effect."""
        text = ""
        if len(self.steps) > 1:
            text += " Then also: " + ", ".join(self.steps["added"].iloc[1:]) + "."
        ranking = self.ranking
        if "explains" not in ranking or "effect" not in ranking:
            return text
        added = set(self.steps["added"]) if "added" in self.steps else set()
        added.add(self.best_effect)
        rows = ranking[
            ranking["explains"].astype(bool) & ~ranking["effect"].isin(added)
        ]
        if not len(rows):
            return text + self._close_runner_up(added)
        said = ", ".join(
            f"{e!r} ({percent(s)})"
            for e, s in zip(rows["effect"], rows["shrink"], strict=True)
        )
        return text + (
            f" Alone, {said} also pass(es) the test (table 'Which effect'): the "
            "runs do not single out one effect; weigh the ranking and the fitted "
            "parameters (one on its bound fits something else)."
        )

    def _close_runner_up(self, added):
        """`` Runner-up 'y' removes 47% ...`` when the best candidate not
        among the named effects (``added``) comes within :data:`CLOSE_SHRINK`
        of the named effect's share with the screening calibration (table
        'Which effect'), without passing the test: a reader of the verdict
        alone would take the named effect as clear-cut."""
        ranking = self.ranking.set_index("effect")
        if self.best_effect not in ranking.index or "shrink" not in ranking:
            return ""
        named = float(ranking.loc[self.best_effect, "shrink"])
        others = ranking.loc[~ranking.index.isin(added), "shrink"].astype(float)
        if not len(others):
            return ""
        effect, share = others.idxmax(), float(others.max())
        if not (share > 0 and named - share <= CLOSE_SHRINK):
            return ""
        return (
            f" Runner-up {effect!r} removes {percent(share)} with the screening "
            f"calibration (table 'Which effect'), close to {self.best_effect!r}'s "
            f"{percent(named)}: the runs barely tell the two apart; weigh their "
            "fitted parameters."
        )

    def _best_candidate_text(self, row, how=""):
        """``best candidate 'x' removes 46% of the excess held-out gap {how},
        short of the 50% that names an effect`` for a verdict that names
        none: its share never rounded up to ``min_shrink``."""
        least = self.settings.get("min_shrink")
        short = (
            f", short of the {least * 100:g}% that names an effect"
            if least is not None and 0 < row["shrink"] < least
            else ""
        )
        how = f" {how}" if how else ""
        return (
            f"best candidate {row['effect']!r} {removes(row['shrink'], least)} "
            f"the excess held-out gap{how}{short}"
        )

    def _none_opening(self, row):
        """The verdict's opening when no effect is named: "beyond noise"
        only when the base's held-out gap is near the noise floor; a gap far
        above it is said to be so (something the vocabulary does not
        describe, or the base, misses it)."""
        gap, floor = row.get("gap_before", np.nan), self.noise_floor
        if np.isfinite(gap) and floor > 0 and beyond_noise(gap, floor**2):
            return (
                "No candidate effect explains the gap: held out it is "
                f"{gap / floor:.1f} times the noise floor"
            )
        return "No candidate effect explains the gap beyond noise"

    def _flexible_text(self, row):
        """``"; a flexible model of the drivers removes ..."`` for the
        verdict's evidence (``""`` without that estimate)."""
        share = self.explainable.get("share", np.nan) if self.explainable else np.nan
        if not np.isfinite(share):
            return ""
        if round(share * 100) < 0:  # worse by at least half a percent
            return (
                "; a flexible model of the drivers makes the held-out gap worse "
                f"(excess above noise {percent(-share)} larger)"
            )
        text = f"; a flexible model of the drivers removes {percent(share)}"
        significant = row.get("p_value", np.nan) < self.settings.get("alpha", 0.05)
        if row["shrink"] > share and significant:
            # The flexible model is an estimate, fitted on few runs: here it
            # falls short of a term, so it bounds nothing.
            text += (
                f", less than {row['effect']!r}: the gap explainable at "
                "all is at least what the term removes"
            )
        return text

    def _within_noise_text(self, row):
        """A sentence when the base's held-out gap in ``row`` is within
        :data:`~skthermal.gap._scores.MIN_EXCESS` of the noise floor (no
        effect is named then)."""
        gap, floor = row.get("gap_before", np.nan), self.noise_floor
        if not (np.isfinite(gap) and floor > 0) or beyond_noise(gap, floor**2):
            return ""
        return (
            f" The held-out gap ({gap:.3g}) is within the noise (floor "
            f"{floor:.3g}, {gap / floor:.2f} times it): the simulation matches "
            "the measurement as far as the noise tells."
        )

    # What a candidate whose parameter sits on its range's end may be.
    _STAND_IN = (
        "it may stand in for something else, such as the same physics "
        "elsewhere or on another time scale"
    )

    @classmethod
    def _bound_text(cls, row):
        """The verdict's sentence on a named effect whose fitted parameter
        sits on an end of its range that physics reaches (``""`` when none
        does; on any other end it is not named)."""
        if not row.get("on_bound"):
            return ""
        return (
            f" Its fitted {row['on_bound']} sits on its range's end: "
            f"{cls._STAND_IN}; weigh the other candidates that pass."
        )

    def _unnamed_tail(self, row):
        """What a verdict that names no effect says after its opening, in
        both modes: why its best candidate ``row`` is not named (overruled by
        the finer calibration, ruled out, stopped by its range) and whether
        the gap is within the noise."""
        return (
            self._overruled_text(row)
            + self._ruled_out_text(row)
            + self._stopped_text(row)
            + self._within_noise_text(row)
        )

    def _overruled_text(self, fine):
        """The verdict's sentence when the screening passed the best
        candidate (its row of table 'Which effect' says it explains the gap)
        and the fine calibration of the how-far step did not bear it out
        (``""`` otherwise): the tables and the verdict then disagree."""
        if fine.get("calibration") != "fine" or "explains" not in self.ranking:
            return ""
        rows = self.ranking[self.ranking["effect"] == fine["effect"]]
        if not len(rows) or not bool(rows["explains"].iloc[0]):
            return ""
        return (
            f" The screening (table 'Which effect') passed {fine['effect']!r} "
            f"({percent(rows['shrink'].iloc[0])}); the finer calibration, which "
            "decides, does not bear it out."
        )

    def _passes_alone(self, row):
        """Whether the candidate ``row`` removes ``min_shrink`` of the gap,
        significantly: only then is what else keeps it from being named
        worth a sentence (a candidate that removes nothing needs none)."""
        least = self.settings.get("min_shrink", 0.0)
        alpha = self.settings.get("alpha", 0.05)
        return bool(
            row.get("shrink", -np.inf) >= least and row.get("p_value", 1) < alpha
        )

    def _stopped_text(self, row):
        """The verdict's sentence on the best candidate whose fitted
        parameter the range stopped, which keeps it from being named
        (``""`` when none did, or when it would not be named anyway)."""
        if not row.get("stopped") or not self._passes_alone(row):
            return ""
        return (
            f" The fitted {row['stopped']} of {row['effect']!r} sits on its "
            f"range's end, where the range stopped it, not the runs: "
            f"{self._STAND_IN}, or a load the candidates do not describe, and a "
            "candidate so stopped is not named."
        )

    def _ruled_out_text(self, row):
        """The verdict's sentence on why the best candidate is ruled out by
        its fitted value (``""`` when it is not, or when it would not be
        named anyway)."""
        if not row.get("ruled_out") or not self._passes_alone(row):
            return ""
        return f" {row['effect']!r} is ruled out: {row['ruled_out']}."

    def __repr__(self):
        return f"GapReport(best_effect={self.best_effect!r}): {self.verdict()}"

    def to_dict(self):
        """Plain-Python content (tables as lists of records): numbers as
        Python floats at full precision, a missing or infinite value as
        None, so that :meth:`to_json` writes strict JSON."""

        def records(df):
            return jsonable(df.to_dict(orient="records"))

        return {
            "verdict": self.verdict(),
            "best_effect": self.best_effect,
            "noise_floor": jsonable(self.noise_floor),
            "how_far_evidence": jsonable(self.how_far_evidence),
            "settings": jsonable(self.settings),
            "not_applicable": jsonable(self.not_applicable),
            "explainable": jsonable(self.explainable),
            "drift_rates": jsonable(self.drift_rates),
            "initial_states": None
            if self.initial_states is None
            else jsonable(self.initial_states.to_dict(orient="index")),
            "ranking": records(self.ranking),
            "how_far": records(self.how_far),
            "steps": records(self.steps),
            "regime_shrink": jsonable(self.regime_shrink.to_dict(orient="index")),
            "where": {k: records(v) for k, v in self.where.items()},
        }

    def to_json(self, path=None, **kwargs):
        """The report as strict JSON (written to ``path`` when given): a
        missing value is ``null``, never ``NaN``."""
        kwargs.setdefault("indent", 2)
        text = json.dumps(self.to_dict(), allow_nan=False, **kwargs)
        if path is not None:
            Path(path).write_text(text)
        return text

    def where_summary(self, model=None):
        """Where the simulation misses most, in a few lines of text.

        From :attr:`where`, for ``model`` (``"as given"`` or ``"base
        calibrated"``): the run of largest gap, the channel of largest error
        for its noise, the regime whose share of the squared gap most
        exceeds its share of time, and the largest jumps. The tables hold
        the rest.

        Parameters
        ----------
        model : str, optional
            Default: ``"base calibrated"`` in the ThermalMachine mode
            (:func:`diagnose`; a preset as given is off everywhere),
            ``"as given"`` in the run-table mode (:func:`diagnose_runs`;
            the user's own simulation). The figure :meth:`save` adds reads
            the same model.

        Returns
        -------
        str
        """
        model = self.where_model if model is None else model
        where = {k: v[v["model"] == model] for k, v in self.where.items()}
        if not len(where["runs"]):
            models = sorted(set(self.where["runs"]["model"]))
            raise ValueError(f"Unknown model {model!r}; the report has {models}.")
        lines = []
        runs = where["runs"]
        top = runs.loc[runs["gap"].idxmax()]
        lines.append(
            f"run {_label(top['run'])}: gap {top['gap']:.3g} [norm.] (median of the "
            f"{len(runs)} runs {runs['gap'].median():.3g})"
        )
        chans = where["channels"]
        relative = _for_noise(chans)
        c = chans.loc[relative.idxmax()]
        lines.append(
            f"channel {c['channel']}: rmse {c['rmse']:.3g} {_unit(c['channel'])}, "
            f"{relative.max():.3g} x its noise, bias {c['bias']:+.3g}"
            f" {_unit(c['channel'])}".rstrip()
        )
        regs = where["regimes"]
        regs = regs[regs["share_time"] > 0]
        if len(regs):
            r = regs.loc[(regs["share_sq_error"] / regs["share_time"]).idxmax()]
            lines.append(
                f"regime {r['regime']}: {percent(r['share_sq_error'])} of the "
                f"squared gap in {percent(r['share_time'])} of the time"
            )
        jumps = where["jumps"]
        if len(jumps):
            largest = jumps.sort_values("size", ascending=False, kind="stable")
            shown = [
                f"run {_label(j['run'])} at {_time_text(j['time_s'])} s in "
                f"{j['channel']} "
                f"({j['jump']:+.3g} {_unit(j['channel'])})"
                for _, j in largest.head(3).iterrows()
            ]
            lines.append(f"{len(jumps)} jump(s), largest: " + "; ".join(shown))
        else:
            lines.append("no jumps")
        return f"Where ({model}):\n" + "\n".join(f"  {line}" for line in lines)

    def to_markdown(self):
        """The report as Markdown."""

        table = gap_table

        where = self.where
        ranking = self.ranking
        ruled_out = (
            [
                f"- `{effect}` is ruled out: {why}."
                for effect, why in zip(
                    ranking["effect"], ranking["ruled_out"], strict=True
                )
                if why
            ]
            if "ruled_out" in ranking
            else []
        )
        ruled_out += [
            f"- `{effect}`: its fitted {which} sits on its range's end"
            + (" (stopped there by the range: not named)." if stopped else ".")
            for effect, which, stopped in zip(
                ranking["effect"],
                ranking.get("on_bound", [""] * len(ranking)),
                ranking.get("stopped", [""] * len(ranking)),
                strict=True,
            )
            if which
        ]
        ruled_out += [""] if ruled_out else []
        said = self.settings.get("warnings", [])
        parts = [
            "# Sim-to-real gap report",
            "",
            f"**Verdict.** {self.verdict()}",
            "",
            *(
                [
                    f"**Warnings during the diagnosis** ({len(said)}; they may "
                    "bear on the verdict):",
                    "",
                    *[f"- {w}" for w in said],
                    "",
                ]
                if said
                else []
            ),
            "Channels compared: "
            + ", ".join(f"`{c}`" for c in self.settings.get("channels", []))
            + ".",
            "",
            f"Machine `{self.settings.get('machine')}`, candidates "
            f"{', '.join(self.settings.get('candidates', []))}; noise floor "
            f"{self.noise_floor:.3g}. Gap figures [norm.] are {GAP_UNIT}: the "
            "weighted RMS residual, each channel divided by the spread of its "
            "group's measurements (µm for displacements, °C for temperatures); "
            "errors per channel are in the channel's unit.",
            "",
            "## Which effect",
            table(self.ranking[[c for c in RANKING_SHOWN if c in self.ranking]]),
            "",
            "Every column (the likelihood-ratio test, information criteria, "
            "whiteness and cross-correlations before and after): `ranking.csv`, "
            "`report.ranking`.",
            "",
            *ruled_out,
            *([self._not_applicable_text("`{}`"), ""] if self.not_applicable else []),
            "## How far",
            table(self.how_far),
            "",
            *(
                [
                    "Effects added one after another (greedy), with the held-out "
                    "gap after each:",
                    "",
                    table(self.steps),
                    "",
                ]
                if len(self.steps)
                else []
            ),
            "## Where: runs",
            table(where["runs"]),
            "",
            "## Where: regimes",
            table(where["regimes"]),
            "",
            "## Where: channels",
            *_largest_per_model(where["channels"], table, "where_channels.csv"),
            "",
            "## Where: frequency bands",
            table(where["bands"]),
            "",
            "## Where: jumps",
            *_largest_jumps(where["jumps"], table, "where_jumps.csv"),
        ]
        if self.explainable:
            parts += [
                "",
                "## How much any added term could close",
                table(pd.DataFrame([self.explainable])),
            ]
        if self.initial_states is not None and self.settings.get("initial") == (
            "measured"
        ):
            parts += [
                "",
                "## Initial states from the first readings (K above the air)",
                table(self.initial_states.round(3).reset_index()),
            ]
        if self.drift_rates:
            rates = pd.Series(self.drift_rates, name="rate_C_per_h")
            parts += [
                "",
                "## Fitted sensor drift (°C per hour, largest first)",
                table(
                    rates.reindex(rates.abs().sort_values(ascending=False).index)
                    .rename_axis("channel")
                    .reset_index()
                    .head(20)
                ),
            ]
        return "\n".join(parts) + "\n"

    def to_html(self):
        """The report as a self-contained HTML page."""
        import html

        body = [
            f"<h1>Sim-to-real gap report</h1><p><b>Verdict.</b> "
            f"{html.escape(self.verdict())}</p>"
        ]
        for title, df in [
            ("Which effect", self.ranking),
            ("How far", self.how_far),
            ("Steps", self.steps),
        ] + [(f"Where: {k}", v) for k, v in self.where.items()]:
            body.append(f"<h2>{html.escape(title)}</h2>")
            body.append(
                _with_units(df).to_html(
                    index=False,
                    float_format=lambda x: f"{x + 0.0:.3g}",
                    na_rep=_NO_VALUE,
                )
            )
        return (
            "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Gap report"
            "</title></head><body>" + "\n".join(body) + "</body></html>"
        )

    # --- plots -----------------------------------------------------------------

    def _default_channel(self, frame):
        """The displacement channel with the largest residual (else any)."""
        channels = self.settings["channels"]
        disp = [c for c in channels if c.startswith("disp_")] or channels
        return max(
            disp, key=lambda c: float(np.mean(frame[f"residual_before:{c}"] ** 2))
        )

    def _timeline(self, run, channel):
        """The run label, its timeline and the channel to plot (defaults
        filled in); a ValueError names the valid runs or channels."""
        runs = list(self.timelines)
        if run is None:
            run = runs[0]
        elif run not in self.timelines:
            raise ValueError(f"Unknown run {run!r}; the report's runs are {runs}.")
        frame = self.timelines[run]
        channels = self.settings["channels"]
        if channel is None:
            channel = self._default_channel(frame)
        elif channel not in channels:
            raise ValueError(
                f"Unknown channel {channel!r}; the compared channels are {channels}."
            )
        return run, frame, channel

    def plot_timeline(self, run=None, channel=None, ax=None):
        """Residual timeline of a run shaded by regime, before (and after) the
        best effect.

        A :class:`skthermal.plotting.GapTimelineDisplay` of the residual
        before, with the residual after the best effect drawn on top.

        Parameters
        ----------
        run : run label, optional
            Default: the first run.
        channel : str, optional
            Default: the displacement channel with the largest gap.
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib Axes
        """
        from skthermal.plotting import GapTimelineDisplay

        run, frame, channel = self._timeline(run, channel)
        display = GapTimelineDisplay.from_arrays(
            frame["time_s"].to_numpy(),
            frame[f"residual_before:{channel}"].to_numpy(),
            frame["regime"].to_numpy(),
            residual_name="before",
            ax=ax,
            time_unit="h",
            line_kwargs={"color": "C3"},
        )
        ax = display.ax_
        col = f"residual_after:{channel}"
        if col in frame:
            ax.plot(
                frame["time_s"].to_numpy() / 3600.0,
                frame[col],
                color="C0",
                label=f"with {self.best_effect}",
            )
            ax.legend(fontsize="small", ncol=3)
        ax.set_ylabel(f"residual {channel}")
        ax.set_title(f"Run {run}: simulated - measured")
        return ax

    def plot_overlay(self, run=None, channel=None, ax=None):
        """Measured and simulated channel, before and after the best effect.

        A :class:`skthermal.plotting.GapOverlayDisplay` of the run.

        Parameters
        ----------
        run : run label, optional
            Default: the first run.
        channel : str, optional
            Default: the displacement channel with the largest gap.
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib Axes
        """
        run, frame, channel = self._timeline(run, channel)
        # Imported here: plotting is optional (and imports nothing of gap).
        from skthermal.plotting import GapOverlayDisplay

        measured = frame[f"measured:{channel}"].to_numpy()
        col = f"residual_after:{channel}"
        display = GapOverlayDisplay.from_arrays(
            frame["time_s"].to_numpy(),
            measured,
            measured + frame[f"residual_before:{channel}"].to_numpy(),
            simulated_after=measured + frame[col].to_numpy() if col in frame else None,
            channel_name=channel,
            after_name=f"simulated + {self.best_effect}",
            ax=ax,
            time_unit="h",
            legend_kwargs={"fontsize": 7},
        )
        return display.ax_

    def save(self, folder):
        """Write report.md, report.html, report.json, the tables as CSV (with
        drift_rates.csv when drift was fitted, and initial_states.csv: every
        run's initial node temperatures, in K above its first air reading,
        a column ``<node>_K_above_air`` each) and, with matplotlib, timeline
        figures into ``folder``. An earlier report's timelines, drift rates
        and initial states in ``folder`` are removed first."""
        folder = Path(folder)
        if folder.exists() and not folder.is_dir():
            raise ValueError(
                f"Cannot save the report into {str(folder)!r}: a file of that "
                "name exists; save() writes a folder of files."
            )
        folder.mkdir(parents=True, exist_ok=True)
        # A folder reused for another report: the files this one may not
        # write (a run's timeline, drift rates, initial states) would stay
        # beside it, stale, as if this report had drawn them.
        for stale in (
            *folder.glob("timeline_*.png"),
            folder / "drift_rates.csv",
            folder / "initial_states.csv",
        ):
            if stale.is_file():
                stale.unlink()
        self.to_json(folder / "report.json")
        # Fitted parameters (dicts) as JSON text, which any reader parses.
        self.ranking.map(
            lambda v: json.dumps(jsonable(v)) if isinstance(v, dict) else v
        ).to_csv(folder / "ranking.csv", index=False)
        self.how_far.to_csv(folder / "how_far.csv", index=False)
        for name, df in self.where.items():
            df.to_csv(folder / f"where_{name}.csv", index=False)
        if self.drift_rates:
            pd.Series(self.drift_rates, name="rate_C_per_h").rename_axis(
                "channel"
            ).reset_index().to_csv(folder / "drift_rates.csv", index=False)
        if self.initial_states is not None:
            self.initial_states.add_suffix("_K_above_air").to_csv(
                folder / "initial_states.csv"
            )
        self._write_pages(folder, self._save_figures(folder))
        return folder

    def _save_figures(self, folder):
        """The timeline figures of :meth:`save`, as (caption, file) pairs;
        none without matplotlib."""
        try:
            plt = _pyplot()
        except ImportError:
            return []

        def draw(run, channel, file):
            fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
            self.plot_overlay(run, channel, ax=axes[0])
            self.plot_timeline(run, channel, ax=axes[1])
            fig.tight_layout()
            fig.savefig(folder / file, dpi=90)
            plt.close(fig)

        runs = list(self.timelines)
        names = _file_names(runs)
        figures = []
        for run, name in zip(runs, names, strict=True):
            draw(run, None, f"timeline_{name}.png")
            figures.append((f"run {_label(run)}", f"timeline_{name}.png"))
        # The figures show a displacement; where another channel misses most
        # for its noise (a temperature, say), its worst run too.
        extra = self._worst_other_channel()
        if extra is not None:
            run, channel = extra
            file = f"timeline_{names[runs.index(run)]}_{_file_names([channel])[0]}.png"
            draw(run, channel, file)
            figures.append((f"run {_label(run)}, {channel}", file))
        return figures

    def _write_pages(self, folder, figures):
        """report.md and report.html, with the ``figures`` (caption, file)
        that :meth:`save` drew, shown at the end."""
        import html

        md, page = self.to_markdown(), self.to_html()
        if figures:
            md += "\n\n## Figures\n\n" + "\n\n".join(
                f"![{caption}]({file})" for caption, file in figures
            )
            shown = "".join(
                f"<figure><img src='{html.escape(file)}' alt='"
                f"{html.escape(caption)}'><figcaption>{html.escape(caption)}"
                "</figcaption></figure>"
                for caption, file in figures
            )
            page = page.replace("</body>", f"<h2>Figures</h2>{shown}</body>")
        (folder / "report.md").write_text(md)
        (folder / "report.html").write_text(page)

    def _worst_other_channel(self):
        """``(run, channel)`` of the channel of largest error for its noise
        in the tables :meth:`where_summary` reads by default, and its run of
        largest error, when that channel is not what the figures show by
        default and misses by more than :data:`_FIGURE_NOISE` times its
        noise; else None."""
        chans = self.where["channels"]
        by_run = self.where["channels_by_run"]
        models = list(dict.fromkeys(chans["model"]))
        model = self.where_model if self.where_model in models else models[0]
        chans = chans[chans["model"] == model]
        relative = _for_noise(chans)
        if not relative.max() > _FIGURE_NOISE:
            return None
        channel = chans.loc[relative.idxmax(), "channel"]
        rows = by_run[(by_run["model"] == model) & (by_run["channel"] == channel)]
        rows = rows[rows["run"].isin(list(self.timelines))]
        if not len(rows):
            return None
        run = rows.loc[rows["rmse"].idxmax(), "run"]
        if channel == self._default_channel(self.timelines[run]):
            return None
        return run, channel


def jsonable(value):
    """``value`` as plain Python for JSON: dicts (keys as strings), lists,
    Python numbers at full precision, and None for a missing or infinite
    number."""
    if isinstance(value, dict):
        return {
            k if isinstance(k, str) else str(k): jsonable(v) for k, v in value.items()
        }
    if isinstance(value, list | tuple | np.ndarray | pd.Series):
        return [jsonable(v) for v in value]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value) if np.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    if value is pd.NA or value is pd.NaT:
        return None
    return str(value)


def _file_names(labels):
    """Safe, unique file-name stems for run ``labels``: characters other than
    letters, digits, ``.``, ``-`` and ``_`` become ``_``, no leading dot (so
    no ``..`` and no path), and a repeated stem (case-insensitively) gets
    ``-2``, ``-3``, ..."""
    out, seen = [], set()
    for label in labels:
        stem = re.sub(r"[^A-Za-z0-9._-]", "_", str(label)).lstrip(".") or "run"
        name, k = stem, 1
        while name.lower() in seen:
            k += 1
            name = f"{stem}-{k}"
        seen.add(name.lower())
        out.append(name)
    return out


_DISPLAY_UNITS = {
    "gap": "gap [norm.]",
    "gap_before": "gap_before [norm.]",
    "gap_after": "gap_after [norm.]",
    "rmse": "rmse [µm or °C]",
    "bias": "bias [µm or °C]",
    "max_abs": "max_abs [µm or °C]",
    "noise": "noise [µm or °C]",
    "jump": "jump [µm or °C]",
    "size": "size [x spread]",
    "time_s": "time [s]",
}


def _with_units(df):
    """``df`` with units in the headers of its gap and error columns, and its
    times written in full (16080 s, not 1.61e+04)."""
    if "time_s" in df:
        df = df.assign(time_s=df["time_s"].map(_time_text))
    return df.rename(columns=_DISPLAY_UNITS)


def _time_text(t):
    """A time in seconds as a table shows it: whole seconds as integers, else
    to the millisecond."""
    t = float(t)
    if not np.isfinite(t):
        return _NO_VALUE
    return f"{t:.0f}" if t == round(t) else f"{t:.3f}".rstrip("0")


# How a table shows a value that does not exist (a candidate without a
# fitted parameter, a regime without samples).
_NO_VALUE = "—"


def _gap_cell(v):
    if isinstance(v, float | np.floating):
        # + 0.0: a negative zero is written "0", not "-0".
        return _NO_VALUE if np.isnan(v) else f"{v + 0.0:.3g}"
    if isinstance(v, dict):
        if not v:
            return _NO_VALUE
        # A term's fitted parameters, each as the other figures are.
        return ", ".join(f"{k}: {_gap_cell(x)}" for k, x in v.items())
    return str(v).replace("|", "/")


# The columns of the ranking the Markdown report shows (the rest is in
# ranking.csv): the held-out evidence that decides, the in-sample test and
# the fitted value; a terminal shows them without RANKING_DETAIL.
RANKING_DETAIL = ("runs_improved", "n_runs", "white_after", "fitted")
RANKING_SHOWN = (
    "effect",
    "gap_before",
    "gap_after",
    "shrink",
    "share_of_explainable",
    "p_value",
    "runs_improved",
    "n_runs",
    "lr_p_value",
    "white_after",
    "fitted",
    "explains",
)


def gap_table(df):
    """A gap table as Markdown, with units in the headers, ``(none)`` when
    empty."""
    return markdown_table(_with_units(df), cell=_gap_cell, empty="(none)")


def _label(run):
    """A run label as text: quoted when it is text ('R2'), else as written."""
    return repr(run) if isinstance(run, str) else str(run)


def _unit(channel):
    """The unit of a channel by its name's suffix (``_um``, ``_C``), else
    empty."""
    name = str(channel)
    if name.endswith("_um"):
        return "µm"
    if name.endswith("_C"):
        return "°C"
    return ""


def _pyplot():
    """``matplotlib.pyplot`` for :meth:`GapReport.save`, or the ImportError
    naming the ``plot`` extra: skthermal's one optional-import helper, which
    the plotting package's displays use too."""
    from skthermal._optional import import_optional

    return import_optional("matplotlib.pyplot", extra="plot", caller="GapReport.save")
