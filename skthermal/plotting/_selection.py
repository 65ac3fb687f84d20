"""SensorScoreDisplay: the sensor scores of a fitted selector as a bar chart.

Kept sensors are drawn solid with a dark edge, dropped ones faded; bars can be
coloured by sensor group (the fuzzy c-means clusters of
:class:`~skthermal.selection.FCMClusterPicker`, or any mapping).
"""

from collections.abc import Mapping

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from skthermal.plotting._base import _floats, check_matplotlib_support


class SensorScoreDisplay:
    """Bar chart of the sensor scores of a fitted selector.

    Create it with :meth:`from_estimator`, or with the constructor followed by
    :meth:`plot` for scores computed elsewhere.

    Parameters
    ----------
    scores : array-like of shape (n_sensors,)
        Score of every sensor (bigger = more relevant).
    support : array-like of bool of shape (n_sensors,), default=None
        Mask of the kept sensors; None draws every bar alike.
    feature_names : array-like of str of shape (n_sensors,), default=None
        Sensor names; default: the index of ``scores`` when it is a pandas
        Series indexed by name, else ``x0``, ``x1``, ...
    groups : array-like of shape (n_sensors,), default=None
        Group of every sensor (bars of a group share a colour); None colours
        by kept/dropped only.
    score_name : str, default="score"
        Label of the score axis.

    Attributes
    ----------
    bars_ : matplotlib BarContainer
        The bars, in drawing order.
    order_ : ndarray of shape (n_sensors,)
        Sensor index of every bar.
    ax_ : matplotlib Axes
        Axes with the chart.
    figure_ : matplotlib Figure
        Figure holding the Axes.
    legend_ : matplotlib Legend or None
        Legend of the groups and of kept/dropped.

    See Also
    --------
    skthermal.selection.GreyInfluenceSelector : Grey influence scores.
    skthermal.selection.FCMClusterPicker : Sensor groups and their best sensors.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from skthermal.plotting import SensorScoreDisplay
    >>> disp = SensorScoreDisplay(
    ...     scores=[0.9, 0.2, 0.6], support=[True, False, True],
    ...     feature_names=["T1_C", "T2_C", "T3_C"],
    ... ).plot(sort=True)
    >>> [t.get_text() for t in disp.ax_.get_xticklabels()]
    ['T1_C', 'T3_C', 'T2_C']
    """

    def __init__(
        self,
        *,
        scores,
        support=None,
        feature_names=None,
        groups=None,
        score_name="score",
    ):
        self.scores = scores
        self.support = support
        self.feature_names = feature_names
        self.groups = groups
        self.score_name = score_name

    def _validated(self):
        scores = _floats(self.scores, "scores")
        if scores.ndim != 1 or scores.size == 0:
            raise ValueError(
                f"scores must be a non-empty 1-D array, got shape {scores.shape}."
            )
        n = scores.size
        support = None
        if self.support is not None:
            support = np.asarray(self.support)
            if support.shape != (n,) or support.dtype != bool:
                raise ValueError(
                    f"support must be a boolean mask of shape ({n},), got "
                    f"{support.dtype} of shape {support.shape}."
                )
        given = self.feature_names
        if (
            given is None
            and isinstance(self.scores, pd.Series)
            and not isinstance(self.scores.index, pd.RangeIndex)
        ):
            given = self.scores.index  # scores named by sensor
        names = (
            [f"x{j}" for j in range(n)] if given is None else [str(s) for s in given]
        )
        if len(names) != n:
            raise ValueError(f"feature_names must hold {n} names, got {len(names)}.")
        groups = None
        if self.groups is not None:
            groups = np.asarray(self.groups, dtype=object)
            if groups.shape != (n,):
                raise ValueError(
                    f"groups must hold one group per sensor ({n}), got shape "
                    f"{groups.shape}."
                )
        return scores, support, names, groups

    def plot(
        self,
        ax=None,
        *,
        sort=False,
        kept_alpha=1.0,
        dropped_alpha=0.35,
        bar_kwargs=None,
    ):
        """Draw the bar chart.

        Parameters
        ----------
        ax : matplotlib Axes, default=None
            Axes to draw on; None creates a figure.
        sort : bool, default=False
            Order the bars by decreasing score instead of by column.
        kept_alpha, dropped_alpha : float, default=1.0 and 0.35
            Opacity of the bars of kept and dropped sensors.
        bar_kwargs : dict, default=None
            Keyword arguments of ``Axes.bar``.

        Returns
        -------
        display : SensorScoreDisplay
            The display, with the drawn artists as attributes.
        """
        plt = check_matplotlib_support(f"{type(self).__name__}.plot")
        from matplotlib.colors import to_rgba
        from matplotlib.patches import Patch

        scores, support, names, groups = self._validated()
        n = scores.size
        order = np.argsort(-scores, kind="stable") if sort else np.arange(n)
        if ax is None:
            # Constrained layout keeps the (rotated) sensor names inside the
            # figure, so a plain savefig shows them whole.
            fig, ax = plt.subplots(
                figsize=(max(4.0, min(0.35 * n + 2, 16)), 3.5), layout="constrained"
            )
        else:
            fig = ax.figure

        handles = []
        if groups is None:
            base = ["C0"] * n
        else:
            levels = list(dict.fromkeys(groups.tolist()))
            try:
                levels = sorted(levels)
            except TypeError:  # mixed label types: keep first appearance
                pass
            colour = {g: f"C{k % 10}" for k, g in enumerate(levels)}
            base = [colour[g] for g in groups]
            handles += [Patch(color=colour[g], label=f"group {g}") for g in levels]
        kept = np.ones(n, dtype=bool) if support is None else support
        colors, edges = [], []
        for j in order:
            colors.append(to_rgba(base[j], kept_alpha if kept[j] else dropped_alpha))
            edges.append("k" if (kept[j] and support is not None) else "none")
        bars = ax.bar(
            np.arange(n),
            scores[order],
            **{"color": colors, "edgecolor": edges, "linewidth": 1.2}
            | (bar_kwargs or {}),
        )
        ax.set_xticks(np.arange(n))
        # Upright while the names fit side by side (about 6 characters per
        # bar at this width), else rotated.
        upright = n <= 8 and max(len(name) for name in names) <= 6
        ax.set_xticklabels(
            [names[j] for j in order], rotation=0 if upright else 90, fontsize="small"
        )
        ax.set_ylabel(self.score_name)
        ax.set_xlabel("sensor")
        if support is not None:
            ref = "C0" if groups is None else "0.5"
            handles += [
                Patch(facecolor=to_rgba(ref, kept_alpha), edgecolor="k", label="kept"),
                Patch(facecolor=to_rgba(ref, dropped_alpha), label="dropped"),
            ]
        self.legend_ = ax.legend(handles=handles, fontsize="small") if handles else None
        self.bars_ = bars
        self.order_ = order
        self.ax_ = ax
        self.figure_ = fig
        return self

    @classmethod
    def from_estimator(cls, selector, *, groups="auto", ax=None, **plot_kwargs):
        """Plot the scores of a fitted sensor selector.

        Parameters
        ----------
        selector : fitted selector
            A selector with ``scores_`` (GreyInfluenceSelector, GRASelector,
            FCMClusterPicker, ...); the kept sensors come from
            ``get_support()``.
        groups : "auto", array-like, mapping or None, default="auto"
            Colour bars by group: ``"auto"`` uses the selector's ``labels_``
            (FCMClusterPicker's fuzzy c-means groups) when it has them; an
            array gives one group per sensor; a mapping maps sensor names to
            groups (sensors it omits are "ungrouped"); None does not colour by
            group.
        ax : matplotlib Axes, default=None
            Axes to draw on.
        **plot_kwargs
            Further keyword arguments of :meth:`plot`.

        Returns
        -------
        display : SensorScoreDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_estimator")
        check_is_fitted(selector)
        if not hasattr(selector, "scores_"):
            raise TypeError(
                f"{type(selector).__name__} has no scores_; {cls.__name__} needs "
                "a fitted selector that scores sensors."
            )
        scores = np.asarray(selector.scores_, dtype=float)
        n = scores.shape[0]
        names = getattr(selector, "feature_names_in_", None)
        names = (
            [str(s) for s in names]
            if names is not None
            else [f"x{j}" for j in range(n)]
        )
        support = (
            np.asarray(selector.get_support(), dtype=bool)
            if hasattr(selector, "get_support")
            else None
        )
        if isinstance(groups, str):
            if groups != "auto":
                raise ValueError(
                    f"groups must be 'auto', an array, a mapping or None, got "
                    f"{groups!r}."
                )
            groups = getattr(selector, "labels_", None)
        elif isinstance(groups, Mapping):
            groups = [groups.get(name, "ungrouped") for name in names]
        display = cls(
            scores=scores,
            support=support,
            feature_names=names,
            groups=groups,
            score_name=f"score ({type(selector).__name__})",
        )
        return display.plot(ax=ax, **plot_kwargs)
