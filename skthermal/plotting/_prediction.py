"""PredictionDisplay: measured and predicted thermal error over time.

The figure of every thermal-error paper (001 Figs. 5-11 to 5-15): the measured
and the predicted displacement of a test against time, the residual below it
with the residual band shaded, and the accuracy figures in the title.
"""

import numbers
import re
import warnings

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from skthermal._naming import plain
from skthermal.metrics import nash_sutcliffe, pearson_r, residual_band, rmse
from skthermal.plotting._base import (
    _as_1d,
    _index_level,
    _new_figure_or_axes,
    _time_scale,
    _time_unit,
    check_matplotlib_support,
)
from skthermal.utils._runs import (
    RUN_COLUMN,
    TIME_COLUMN,
    extract_runs,
    pass_runs,
    run_slices,
)
from skthermal.utils._warnings import user_stacklevel

_DISP = re.compile(r"^disp_(?P<axis>[a-z0-9]+)_um$", re.IGNORECASE)


def _target_label(name):
    """Axis label and unit of a target column, e.g. ``disp_y_um``."""
    if name is None:
        return "displacement", ""
    match = _DISP.match(str(name))
    if match:
        return f"{match['axis'].upper()} displacement (µm)", " µm"
    return str(name), ""


def _metrics(y_true, y_pred):
    """The title's metrics on the rows where both values are finite (NaN
    when there is none)."""
    ok = np.isfinite(y_true) & np.isfinite(y_pred)
    if not ok.any():
        return dict.fromkeys(("rmse", "r", "nse", "band"), np.nan)
    y_true, y_pred = y_true[ok], y_pred[ok]
    with np.errstate(all="ignore"):
        return {
            "rmse": rmse(y_true, y_pred),
            "r": pearson_r(y_true, y_pred),
            "nse": nash_sutcliffe(y_true, y_pred),
            "band": residual_band(y_true, y_pred),
        }


def _one_output(y_pred, output):
    """Column ``output`` of an estimator's prediction of several outputs."""
    arr = np.asarray(y_pred)
    k = arr.shape[1] if arr.ndim == 2 else 1
    if output is None:
        if k > 1:
            raise ValueError(
                f"The estimator predicts {k} outputs (one per target it was "
                "fitted on): pick one with output=j (its j-th target, 0-based), "
                "and pass that target as y."
            )
        return y_pred
    if not isinstance(output, numbers.Integral) or not 0 <= output < k:
        raise ValueError(
            f"output must be an int in [0, {k - 1}] (the estimator predicts "
            f"{k} output(s)), got {output!r}."
        )
    return arr[:, output] if arr.ndim == 2 else arr


def _aligned_prediction(y_true, y_pred):
    """``y_pred`` in the row order of ``y_true`` when both are pandas objects
    indexed by runs and times (a prediction sorted or grouped otherwise);
    taken as it is (by position) otherwise. Labels that differ are an
    error: the runs and times come from ``y_true``."""
    a, b = getattr(y_true, "index", None), getattr(y_pred, "index", None)
    if a is None or b is None or RUN_COLUMN not in (b.names or []):
        return y_pred
    if a.equals(b):
        return y_pred
    if (
        a.is_unique
        and b.is_unique
        and len(a) == len(b)
        and a.sort_values().equals(b.sort_values())
    ):
        return y_pred.reindex(a)
    raise ValueError(
        "y_pred is indexed by other (run, time_s) labels than y_true: the runs "
        "and times are read from y_true, so the rows would be paired wrongly. "
        "Predict the rows of y_true, or pass y_pred as an array in its row "
        "order."
    )


def _warn_missing(finite, slices, labels):
    """Warn of the rows without a finite measured or predicted value
    (``~finite``: drawn as gaps, left out of the metrics), naming the first
    run."""
    bad = ~finite
    if not bad.any():
        return
    row = int(np.argmax(bad))
    run = next(
        lab for sl, lab in zip(slices, labels, strict=True) if sl.start <= row < sl.stop
    )
    where = f"row {row}" + ("" if run is None else f" (run {plain(run)!r})")
    warnings.warn(
        f"PredictionDisplay: {int(bad.sum())} row(s) hold a missing or infinite "
        f"measured or predicted value, the first at {where}: they are drawn "
        "as gaps and left out of the metrics.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


class PredictionDisplay:
    """Measured vs predicted thermal error over time, with the residual.

    The top panel shows the measured and the predicted displacement against
    time, the bottom panel the residual (measured minus predicted) with the
    residual band ``± max |z - p|`` shaded; the title gives RMSE, Pearson's R,
    the Nash-Sutcliffe efficiency and the residual band. Data of several runs
    are drawn side by side, one column of panels per run.

    Create it with :meth:`from_estimator` or :meth:`from_predictions`; the
    constructor only stores the data. Call :meth:`plot` to draw again, e.g. on
    other Axes.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        Measured values.
    y_pred : array-like of shape (n_samples,)
        Predicted values.
    time : array-like of shape (n_samples,), default=None
        Sample times in seconds; None plots against the sample number within
        each run.
    runs : array-like of shape (n_samples,), default=None
        Run label of every sample (each run one contiguous block); None means
        one run.
    target_name : str, default=None
        Name of the target, e.g. ``"disp_y_um"`` (labelled "Y displacement
        (µm)").
    estimator_name : str, default=None
        Legend label of the prediction; None labels it "predicted".

    Attributes
    ----------
    axes_ : ndarray of matplotlib Axes of shape (2, n_runs)
        Row 0 the displacement panels, row 1 the residual panels.
    ax_ : matplotlib Axes
        Displacement panel of the first run (``axes_[0, 0]``).
    ax_residual_ : matplotlib Axes
        Residual panel of the first run (``axes_[1, 0]``).
    figure_ : matplotlib Figure
        Figure holding the panels.
    lines_measured_, lines_predicted_, lines_residual_ : list of Line2D
        One line per run.
    bands_ : list of matplotlib artists
        The shaded residual band of every run (empty with ``band=False``).
    line_measured_, line_predicted_, line_residual_ : Line2D
        The lines of the first run.
    metrics_ : DataFrame
        ``rmse``, ``r``, ``nse`` and ``band`` of every run (index: run label).

    See Also
    --------
    sklearn.metrics.PredictionErrorDisplay : Measured vs predicted scatter.
    skthermal.metrics.residual_band : The band shaded in the residual panel.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skthermal.plotting import PredictionDisplay
    >>> t = np.arange(0, 7200, 60.0)
    >>> y = 20 * (1 - np.exp(-t / 2000))
    >>> disp = PredictionDisplay.from_predictions(
    ...     y, y + 0.5 * np.sin(t / 600), time=t, target_name="disp_y_um"
    ... )
    >>> disp.ax_.get_ylabel()
    'Y displacement (µm)'
    >>> round(float(disp.metrics_["band"].iloc[0]), 2)
    0.5
    """

    def __init__(
        self,
        *,
        y_true,
        y_pred,
        time=None,
        runs=None,
        target_name=None,
        estimator_name=None,
    ):
        self.y_true = y_true
        self.y_pred = y_pred
        self.time = time
        self.runs = runs
        self.target_name = target_name
        self.estimator_name = estimator_name

    def _validated(self):
        y_true = _as_1d(self.y_true, "y_true")
        y_pred = _as_1d(self.y_pred, "y_pred")
        n = y_true.shape[0]
        if y_pred.shape[0] != n:
            raise ValueError(
                f"y_true has {n} samples but y_pred has {y_pred.shape[0]}."
            )
        time = None
        if self.time is not None:
            time = np.asarray(self.time)
            if time.shape != (n,):
                raise ValueError(
                    f"time must hold one value per sample ({n}), got shape "
                    f"{time.shape}."
                )
        runs = None if self.runs is None else np.asarray(self.runs)
        slices, labels = run_slices(runs, n)
        return y_true, y_pred, time, slices, labels

    def plot(
        self,
        ax=None,
        *,
        time_unit="auto",
        band=True,
        show_metrics=True,
        measured_kwargs=None,
        predicted_kwargs=None,
        residual_kwargs=None,
        band_kwargs=None,
    ):
        """Draw the panels.

        Parameters
        ----------
        ax : array-like of matplotlib Axes of shape (2,) or (2, n_runs), \
default=None
            Displacement Axes in the first row, residual Axes in the second;
            None creates a figure.
        time_unit : {"auto", "s", "min", "h"} or None, default="auto"
            Unit of the time axis (``time`` is in seconds); ``"auto"`` picks
            one from the span, None plots ``time`` as given.
        band : bool, default=True
            Shade ``± max |residual|`` in the residual panel.
        show_metrics : bool, default=True
            Put RMSE, R, NSE and the residual band in the panel titles.
        measured_kwargs, predicted_kwargs, residual_kwargs : dict, default=None
            Keyword arguments of ``Axes.plot`` for the three lines.
        band_kwargs : dict, default=None
            Keyword arguments of ``Axes.axhspan`` for the band.

        Returns
        -------
        display : PredictionDisplay
            The display, with the artists stored as attributes.
        """
        plt = check_matplotlib_support(f"{type(self).__name__}.plot")
        y_true, y_pred, time, slices, labels = self._validated()
        n_runs = len(slices)
        fig, axes = _new_figure_or_axes(
            plt,
            ax,
            (2, n_runs),
            type(self).__name__,
            figsize=(min(4.5 * n_runs, 16), 4.8),
            sharex="col",
            height_ratios=[2, 1],
        )
        ylabel, unit = _target_label(self.target_name)
        pred_label = self.estimator_name or "predicted"
        finite = np.isfinite(y_true) & np.isfinite(y_pred)
        _warn_missing(finite, slices, labels)
        with np.errstate(invalid="ignore"):
            residual = np.where(finite, y_true - y_pred, np.nan)
        if time is not None and time_unit == "auto":
            # One unit for every run: the longest one's.
            time_unit = _time_unit(time, slices)
        self.lines_measured_, self.lines_predicted_ = [], []
        self.lines_residual_, self.bands_ = [], []
        rows = []
        for k, (sl, label) in enumerate(zip(slices, labels, strict=True)):
            top, bottom = axes[0, k], axes[1, k]
            if time is None:
                t, xlabel = np.arange(sl.stop - sl.start), "sample"
            else:
                t, xlabel = _time_scale(time[sl], time_unit)
            (measured,) = top.plot(
                t,
                y_true[sl],
                **{"color": "k", "label": "measured"} | (measured_kwargs or {}),
            )
            (predicted,) = top.plot(
                t,
                y_pred[sl],
                **{"color": "C3", "linestyle": "--", "label": pred_label}
                | (predicted_kwargs or {}),
            )
            (res,) = bottom.plot(
                t,
                residual[sl],
                **{"color": "C0", "label": "residual"} | (residual_kwargs or {}),
            )
            metrics = _metrics(y_true[sl], y_pred[sl])
            if band:
                b = metrics["band"]
                self.bands_.append(
                    bottom.axhspan(
                        -b,
                        b,
                        **{
                            "color": "C0",
                            "alpha": 0.15,
                            "label": f"±{b:.3g}{unit} band",
                        }
                        | (band_kwargs or {}),
                    )
                )
            bottom.axhline(0.0, color="0.5", linewidth=0.8)
            bottom.set_xlabel(xlabel)
            if k == 0:
                top.set_ylabel(ylabel)
                bottom.set_ylabel(f"residual{f' ({unit.strip()})' if unit else ''}")
                top.legend(loc="best", fontsize="small")
                bottom.legend(loc="best", fontsize="small")
            title = "" if label is None else f"run {label}"
            if show_metrics:
                numbers = (
                    f"RMSE {metrics['rmse']:.3g}{unit}, R {metrics['r']:.3f}, "
                    f"NSE {metrics['nse']:.3f}, band ±{metrics['band']:.3g}{unit}"
                )
                title = f"{title}\n{numbers}" if title else numbers
            top.set_title(title, fontsize="small")
            self.lines_measured_.append(measured)
            self.lines_predicted_.append(predicted)
            self.lines_residual_.append(res)
            rows.append(metrics)
        self.metrics_ = pd.DataFrame(rows, index=pd.Index(labels, name=RUN_COLUMN))
        self.axes_ = axes
        self.ax_, self.ax_residual_ = axes[0, 0], axes[1, 0]
        self.figure_ = fig
        self.line_measured_ = self.lines_measured_[0]
        self.line_predicted_ = self.lines_predicted_[0]
        self.line_residual_ = self.lines_residual_[0]
        return self

    @classmethod
    def from_predictions(
        cls,
        y_true,
        y_pred,
        *,
        time=None,
        groups=None,
        run=None,
        target_name=None,
        estimator_name=None,
        ax=None,
        **plot_kwargs,
    ):
        """Plot measured and predicted values over time.

        Parameters
        ----------
        y_true : array-like or Series of shape (n_samples,)
            Measured values. A pandas object indexed by ``(run, time_s)``, as
            returned by :func:`skthermal.datasets.split_runs`, supplies the
            run labels and the times.
        y_pred : array-like of shape (n_samples,)
            Predicted values, in the row order of ``y_true``.
        time : array-like of shape (n_samples,), default=None
            Sample times in seconds; default: the ``time_s`` index level of
            ``y_true``, else the sample number.
        groups : array-like of shape (n_samples,), default=None
            Run labels; default: the ``run`` index level of ``y_true``.
        run : label or list of labels, default=None
            The run(s) to plot; None plots every run, one column each.
        target_name : str, default=None
            Name of the target; default: the name of ``y_true``.
        estimator_name : str, default=None
            Legend label of the prediction.
        ax : array-like of matplotlib Axes, default=None
            See :meth:`plot`.
        **plot_kwargs
            Further keyword arguments of :meth:`plot`.

        Returns
        -------
        display : PredictionDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_predictions")
        if target_name is None:
            target_name = getattr(y_true, "name", None)
            columns = getattr(y_true, "columns", None)
            if columns is not None and len(columns) == 1:
                target_name = columns[0]
        if time is None:
            time = _index_level(y_true, TIME_COLUMN)
        if groups is None:
            groups = _index_level(y_true, RUN_COLUMN)
        y_pred = _aligned_prediction(y_true, y_pred)
        y_true = _as_1d(y_true, "y_true")
        y_pred = _as_1d(y_pred, "y_pred")
        n = y_true.shape[0]
        if y_pred.shape[0] != n:
            raise ValueError(
                f"y_true has {n} samples but y_pred has {y_pred.shape[0]}."
            )
        for name, values in (("groups", groups), ("time", time)):
            if values is not None and np.shape(values) != (n,):
                raise ValueError(
                    f"{name} must hold one value per row of y_true ({n}), got "
                    f"shape {np.shape(values)}."
                )
        if run is not None:
            if groups is None:
                raise ValueError(
                    f"run={run!r} was given but there are no run labels: pass "
                    "groups, or y indexed by (run, time_s)."
                )
            groups = np.asarray(groups)
            # One label, or several in any sequence (list, tuple, array, Index).
            several = not isinstance(run, str | bytes) and np.iterable(run)
            wanted = [plain(r) for r in run] if several else [plain(run)]
            known = list(dict.fromkeys(groups.tolist()))
            missing = [r for r in wanted if r not in known]
            if missing:
                raise ValueError(
                    f"Run(s) {missing} not found; the runs are {known[:20]}."
                )
            mask = np.isin(groups, wanted)
            y_true, y_pred, groups = y_true[mask], y_pred[mask], groups[mask]
            if time is not None:
                time = np.asarray(time)[mask]
        display = cls(
            y_true=y_true,
            y_pred=y_pred,
            time=time,
            runs=groups,
            target_name=target_name,
            estimator_name=estimator_name,
        )
        return display.plot(ax=ax, **plot_kwargs)

    @classmethod
    def from_estimator(
        cls,
        estimator,
        X,
        y,
        *,
        time=None,
        groups=None,
        run=None,
        output=None,
        target_name=None,
        estimator_name=None,
        ax=None,
        **plot_kwargs,
    ):
        """Predict ``X`` with a fitted estimator and plot against ``y``.

        The whole of ``X`` is predicted before ``run`` selects what is drawn,
        so models that accumulate along a run (grey models, Grey-ANFIS) see
        every run from its start.

        Parameters
        ----------
        estimator : estimator instance
            Fitted regressor (or pipeline) with a ``predict`` method.
        X : array-like or DataFrame of shape (n_samples, n_features)
            Inputs. A ``(run, time_s)`` index, as from
            :func:`skthermal.datasets.split_runs`, supplies run labels and
            times when ``y`` has none.
        y : array-like or Series of shape (n_samples,)
            Measured values.
        time : array-like of shape (n_samples,), default=None
            Sample times in seconds; default: the ``time_s`` index level of
            ``y``, else of ``X``, else the sample number.
        groups : array-like of shape (n_samples,), default=None
            Run labels; default: the ``run`` index level of ``y``, else the
            ``run`` column or index level of ``X``. Also passed to
            ``predict`` when the estimator's ``predict`` accepts ``groups``.
        run : label or list of labels, default=None
            The run(s) to plot; None plots every run, one column each.
        output : int, default=None
            For an estimator fitted on several targets (``disp_x_um``,
            ``disp_y_um``, ...): the column of its prediction to draw, in
            the order of its targets; ``y`` is then that target. Needed when
            the estimator predicts several outputs.
        target_name : str, default=None
            Name of the target; default: the name of ``y``.
        estimator_name : str, default=None
            Legend label of the prediction; default: the estimator's class
            name (of a pipeline: its final step's).
        ax : array-like of matplotlib Axes, default=None
            See :meth:`plot`.
        **plot_kwargs
            Further keyword arguments of :meth:`plot`.

        Returns
        -------
        display : PredictionDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_estimator")
        check_is_fitted(estimator)
        if groups is not None:
            X_in, kwargs = pass_runs(estimator.predict, X, groups, {})
            y_pred = estimator.predict(X_in, **kwargs)
        else:
            y_pred = estimator.predict(X)
        y_pred = _one_output(y_pred, output)
        if time is None:
            time = _index_level(y, TIME_COLUMN)
            if time is None:
                time = _index_level(X, TIME_COLUMN)
        if groups is None:
            groups = _index_level(y, RUN_COLUMN)
            if groups is None:  # a run column or index level, as estimators read it
                groups = extract_runs(X, finite=False)[1]
        if target_name is None:
            target_name = getattr(y, "name", None)
        if estimator_name is None:
            # A pipeline is named after its final step, the model.
            steps = getattr(estimator, "steps", None)
            final = steps[-1][1] if steps else estimator
            estimator_name = type(final).__name__
        return cls.from_predictions(
            y,
            y_pred,
            time=time,
            groups=groups,
            run=run,
            target_name=target_name,
            estimator_name=estimator_name,
            ax=ax,
            **plot_kwargs,
        )
