"""GapTimelineDisplay: a residual over time, shaded by operating regime;
GapOverlayDisplay: the measured and the simulated channel over time.

For diagnosing the gap between a simulation (or model) and the measurement:
where in a test the residual grows -- while heating, after a stop, dwelling, during
an ambient event -- is the first clue to the missing physics.
"""

import pandas as pd

from skthermal.plotting._base import (
    _per_sample,
    _time_scale,
    check_matplotlib_support,
)

# Default colours of the common regimes; others cycle through the tab palette.
REGIME_COLORS = {
    "heating": "tab:red",
    "after stop": "tab:blue",
    "dwell": "tab:gray",
    "ambient event": "tab:purple",
}
_OTHER_COLORS = [
    "tab:orange",
    "tab:green",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "tab:cyan",
]


def _regime_spans(regimes):
    """``(regime, start, stop)`` of every block of equal labels (missing skipped)."""
    missing = pd.isna(regimes)
    spans, start = [], 0
    n = len(regimes)
    for i in range(1, n + 1):
        if (
            i == n
            or missing[i] != missing[start]
            or (not missing[i] and regimes[i] != regimes[start])
        ):
            if not missing[start]:
                spans.append((regimes[start], start, i))
            start = i
    return spans


class GapTimelineDisplay:
    """Residual (gap) timeline with the operating regimes shaded.

    Every block of consecutive samples with the same regime label is shaded
    in the regime's colour, from its first sample to the first sample of the
    next block; one legend entry per regime. Samples whose regime is missing
    (None or NaN) are left unshaded.

    Create it with :meth:`from_arrays`; the constructor only stores the data.

    Parameters
    ----------
    time : array-like of shape (n_samples,)
        Sample times, increasing, in seconds (or any unit with
        ``time_unit=None`` in :meth:`plot`; datetimes work with it too).
    residual : array-like of shape (n_samples,)
        The gap, e.g. simulated minus measured displacement (the sign of the
        gap reports' residuals).
    regimes : array-like of str of shape (n_samples,)
        Regime label of every sample, e.g. ``"heating"``, ``"after stop"``,
        ``"dwell"``, ``"ambient event"``.
    residual_name : str, default="residual"
        Legend label of the residual line and y-axis label.

    Attributes
    ----------
    line_ : matplotlib Line2D
        The residual.
    spans_ : dict of str to list of matplotlib artists
        The shaded spans of every regime, in order of first appearance.
    colors_ : dict of str to color
        The colour of every regime.
    ax_ : matplotlib Axes
        Axes with the timeline.
    figure_ : matplotlib Figure
        Figure holding the Axes.
    legend_ : matplotlib Legend
        One entry per regime and the residual.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skthermal.plotting import GapTimelineDisplay
    >>> t = np.arange(0, 6 * 3600, 300.0)
    >>> regimes = np.where(t < 3 * 3600, "heating", "after stop")
    >>> disp = GapTimelineDisplay.from_arrays(t, np.sin(t / 3600), regimes)
    >>> {k: len(v) for k, v in disp.spans_.items()}
    {'heating': 1, 'after stop': 1}
    """

    def __init__(self, *, time, residual, regimes, residual_name="residual"):
        self.time = time
        self.residual = residual
        self.regimes = regimes
        self.residual_name = residual_name

    def _validated(self):
        residual, arrays = _per_sample(
            "residual",
            self.residual,
            text=("regimes",),
            time=self.time,
            regimes=self.regimes,
        )
        return arrays["time"], residual, arrays["regimes"]

    def plot(
        self, ax=None, *, time_unit="auto", colors=None, alpha=0.2, line_kwargs=None
    ):
        """Draw the residual and shade the regimes.

        Parameters
        ----------
        ax : matplotlib Axes, default=None
            Axes to draw on; None creates a figure.
        time_unit : {"auto", "s", "min", "h"} or None, default="auto"
            Unit of the time axis (``time`` is in seconds); None plots
            ``time`` as given.
        colors : dict of str to color, default=None
            Colours of regimes, overriding the defaults (heating red, after stop
            blue, dwell grey, ambient event purple, others from the tab
            palette).
        alpha : float, default=0.2
            Opacity of the shading.
        line_kwargs : dict, default=None
            Keyword arguments of ``Axes.plot`` for the residual.

        Returns
        -------
        display : GapTimelineDisplay
            The display, with the drawn artists as attributes.
        """
        plt = check_matplotlib_support(f"{type(self).__name__}.plot")
        time, residual, regimes = self._validated()
        t, xlabel = _time_scale(time, time_unit)
        if ax is None:
            fig, ax = plt.subplots(figsize=(8, 3.2))
        else:
            fig = ax.figure
        spans = _regime_spans(regimes)
        palette = dict(REGIME_COLORS) | (colors or {})
        self.colors_, self.spans_ = {}, {}
        others = iter(_OTHER_COLORS * (len(spans) // len(_OTHER_COLORS) + 1))
        for regime, start, stop in spans:
            key = str(regime)
            if key not in self.colors_:
                self.colors_[key] = palette.get(key) or next(others)
                self.spans_[key] = []
            right = t[stop] if stop < len(t) else t[-1]
            self.spans_[key].append(
                ax.axvspan(
                    t[start],
                    right,
                    color=self.colors_[key],
                    alpha=alpha,
                    linewidth=0,
                    label=key if not self.spans_[key] else None,
                )
            )
        (self.line_,) = ax.plot(
            t,
            residual,
            **{"color": "k", "label": self.residual_name} | (line_kwargs or {}),
        )
        ax.axhline(0.0, color="0.5", linewidth=0.8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(self.residual_name)
        self.legend_ = ax.legend(fontsize="small", loc="best")
        self.ax_ = ax
        self.figure_ = fig
        return self

    @classmethod
    def from_arrays(
        cls,
        time,
        residual,
        regimes,
        *,
        residual_name="residual",
        ax=None,
        **plot_kwargs,
    ):
        """Plot a residual timeline shaded by regime.

        Parameters
        ----------
        time : array-like of shape (n_samples,)
            Sample times in seconds, increasing.
        residual : array-like of shape (n_samples,)
            The gap at every sample.
        regimes : array-like of str of shape (n_samples,)
            Regime label of every sample (None or NaN: unshaded).
        residual_name : str, default="residual"
            Label of the residual.
        ax : matplotlib Axes, default=None
            Axes to draw on.
        **plot_kwargs
            Further keyword arguments of :meth:`plot` (``time_unit``,
            ``colors``, ``alpha``, ``line_kwargs``).

        Returns
        -------
        display : GapTimelineDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_arrays")
        display = cls(
            time=time, residual=residual, regimes=regimes, residual_name=residual_name
        )
        return display.plot(ax=ax, **plot_kwargs)


class GapOverlayDisplay:
    """A measured channel and its simulation, before (and after) a correction.

    The measured values in black, the simulation in red and, when given, the
    corrected simulation (e.g. with the unmodelled effect a gap diagnosis
    found) in blue: the companion of :class:`GapTimelineDisplay`, which shows
    the difference of the first two.

    Create it with :meth:`from_arrays`; the constructor only stores the data.

    Parameters
    ----------
    time : array-like of shape (n_samples,)
        Sample times, increasing, in seconds (or any unit with
        ``time_unit=None`` in :meth:`plot`).
    measured : array-like of shape (n_samples,)
        The measured channel.
    simulated : array-like of shape (n_samples,)
        The simulated (or predicted) channel.
    simulated_after : array-like of shape (n_samples,), default=None
        The simulation after a correction; None draws no third line.
    channel_name : str, default="value"
        Label of the y axis, e.g. the channel ``"disp_z_um"``.
    after_name : str, default="simulated + correction"
        Legend label of ``simulated_after``.

    Attributes
    ----------
    lines_ : dict of str to matplotlib Line2D
        ``"measured"``, ``"simulated"`` and (when drawn) ``"after"``.
    ax_ : matplotlib Axes
        Axes with the lines.
    figure_ : matplotlib Figure
        Figure holding the Axes.
    legend_ : matplotlib Legend
        One entry per line.

    See Also
    --------
    GapTimelineDisplay : The residual, shaded by operating regime.
    skthermal.gap.GapReport.plot_overlay : This plot of a gap report's run.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skthermal.plotting import GapOverlayDisplay
    >>> t = np.arange(0, 6 * 3600, 300.0)
    >>> measured = 10 * (1 - np.exp(-t / 7200))
    >>> disp = GapOverlayDisplay.from_arrays(
    ...     t, measured, 0.8 * measured, simulated_after=0.97 * measured
    ... )
    >>> [line.get_label() for line in disp.ax_.get_lines()]
    ['measured', 'simulated', 'simulated + correction']
    """

    def __init__(
        self,
        *,
        time,
        measured,
        simulated,
        simulated_after=None,
        channel_name="value",
        after_name="simulated + correction",
    ):
        self.time = time
        self.measured = measured
        self.simulated = simulated
        self.simulated_after = simulated_after
        self.channel_name = channel_name
        self.after_name = after_name

    def _validated(self):
        measured, arrays = _per_sample(
            "measured",
            self.measured,
            time=self.time,
            simulated=self.simulated,
            simulated_after=self.simulated_after,
        )
        return (
            arrays["time"],
            measured,
            arrays["simulated"],
            arrays.get("simulated_after"),
        )

    def plot(self, ax=None, *, time_unit="auto", legend_kwargs=None):
        """Draw the measured, simulated and corrected lines.

        Parameters
        ----------
        ax : matplotlib Axes, default=None
            Axes to draw on; None creates a figure.
        time_unit : {"auto", "s", "min", "h"} or None, default="auto"
            Unit of the time axis (``time`` is in seconds); None plots
            ``time`` as given.
        legend_kwargs : dict, default=None
            Keyword arguments of ``Axes.legend`` (default
            ``fontsize="small"``).

        Returns
        -------
        display : GapOverlayDisplay
            The display, with the drawn artists as attributes.
        """
        plt = check_matplotlib_support(f"{type(self).__name__}.plot")
        time, measured, simulated, after = self._validated()
        t, xlabel = _time_scale(time, time_unit)
        if ax is None:
            fig, ax = plt.subplots(figsize=(9, 3))
        else:
            fig = ax.figure
        self.lines_ = {}
        (self.lines_["measured"],) = ax.plot(t, measured, color="k", label="measured")
        (self.lines_["simulated"],) = ax.plot(
            t, simulated, color="C3", label="simulated"
        )
        if after is not None:
            (self.lines_["after"],) = ax.plot(
                t, after, color="C0", label=self.after_name
            )
        ax.set_xlabel(xlabel)
        ax.set_ylabel(self.channel_name)
        self.legend_ = ax.legend(**{"fontsize": "small"} | (legend_kwargs or {}))
        self.ax_ = ax
        self.figure_ = fig
        return self

    @classmethod
    def from_arrays(
        cls,
        time,
        measured,
        simulated,
        *,
        simulated_after=None,
        channel_name="value",
        after_name="simulated + correction",
        ax=None,
        **plot_kwargs,
    ):
        """Plot a measured channel against its simulation.

        Parameters
        ----------
        time : array-like of shape (n_samples,)
            Sample times in seconds, increasing.
        measured, simulated : array-like of shape (n_samples,)
            The measured and the simulated channel.
        simulated_after : array-like of shape (n_samples,), default=None
            The simulation after a correction.
        channel_name : str, default="value"
            Label of the y axis.
        after_name : str, default="simulated + correction"
            Legend label of ``simulated_after``.
        ax : matplotlib Axes, default=None
            Axes to draw on.
        **plot_kwargs
            Further keyword arguments of :meth:`plot` (``time_unit``,
            ``legend_kwargs``).

        Returns
        -------
        display : GapOverlayDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_arrays")
        display = cls(
            time=time,
            measured=measured,
            simulated=simulated,
            simulated_after=simulated_after,
            channel_name=channel_name,
            after_name=after_name,
        )
        return display.plot(ax=ax, **plot_kwargs)
