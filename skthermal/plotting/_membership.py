"""MembershipFunctionDisplay: an ANFIS model's membership functions.

One panel per input with the membership functions before training (dashed)
and after it (solid), as 001 Fig. 6-6 and Jang (1993) Fig. 13.
"""

import numpy as np
from sklearn.feature_selection import SelectorMixin
from sklearn.utils.validation import check_is_fitted

from skthermal.plotting._base import _new_figure_or_axes, check_matplotlib_support

_WHICH = ("trained", "initial", "both")
# The public methods of a fitted ANFISRegressor this display draws from: it
# reads the model through them and its fitted attributes, never through
# skthermal.fuzzy's internals (so skthermal.fuzzy can import this module).
_METHODS = ("get_input_range", "membership_degrees")


class MembershipFunctionDisplay:
    """Membership functions of a fitted ANFIS model, one panel per input.

    Create it with :meth:`from_estimator`; the constructor only stores the
    curves.

    Parameters
    ----------
    x : list of ndarray
        ``x[j]`` are the points at which the functions of input j are
        evaluated.
    initial : list of ndarray of shape (n_points, n_mfs_j), default=None
        Membership degrees of the initial functions of every input.
    trained : list of ndarray of shape (n_points, n_mfs_j), default=None
        Membership degrees of the trained functions of every input.
    input_names : list of str
        Name of every input (the x-axis labels).
    mf_labels : list of list of str, default=None
        Legend label of every function of every input; default
        ``in{j}mf{m}``.

    Attributes
    ----------
    axes_ : ndarray of matplotlib Axes of shape (n_inputs,)
        One panel per input.
    ax_ : matplotlib Axes
        The first panel.
    figure_ : matplotlib Figure
        Figure holding the panels.
    lines_initial_, lines_trained_ : list of list of Line2D
        ``lines_trained_[j][m]`` is the curve of function m of input j; empty
        lists for the set not drawn.

    See Also
    --------
    skthermal.fuzzy.ANFISRegressor.plot_membership_functions : Same plot as a
        method of the estimator.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import numpy as np
    >>> from skthermal.fuzzy import ANFISRegressor
    >>> from skthermal.plotting import MembershipFunctionDisplay
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(100, 2))
    >>> model = ANFISRegressor(n_clusters=3, epochs=5, random_state=0)
    >>> model = model.fit(X, X[:, 0] - X[:, 1] ** 2)
    >>> disp = MembershipFunctionDisplay.from_estimator(model, which="both")
    >>> len(disp.axes_), len(disp.lines_trained_[0]), len(disp.lines_initial_[0])
    (2, 3, 3)
    """

    def __init__(self, *, x, initial=None, trained=None, input_names, mf_labels=None):
        self.x = x
        self.initial = initial
        self.trained = trained
        self.input_names = input_names
        self.mf_labels = mf_labels

    def plot(self, ax=None, *, ncols=4, initial_kwargs=None, trained_kwargs=None):
        """Draw one panel per input.

        Parameters
        ----------
        ax : matplotlib Axes or array-like of Axes, default=None
            One Axes per input; None creates a figure with up to ``ncols``
            panels per row.
        ncols : int, default=4
            Panels per row of a new figure.
        initial_kwargs, trained_kwargs : dict, default=None
            Keyword arguments of ``Axes.plot`` for the initial (default
            dashed) and trained (default solid) curves.

        Returns
        -------
        display : MembershipFunctionDisplay
            The display, with the drawn artists as attributes.
        """
        plt = check_matplotlib_support(f"{type(self).__name__}.plot")
        if self.initial is None and self.trained is None:
            raise ValueError("Nothing to plot: both initial and trained are None.")
        d = len(self.x)
        if len(self.input_names) != d:
            raise ValueError(f"input_names must hold {d} names.")
        if ax is None:
            cols = max(1, min(d, ncols))
            rows = -(-d // cols)
            fig, grid = _new_figure_or_axes(
                plt,
                None,
                (rows, cols),
                type(self).__name__,
                figsize=(3.2 * cols, 2.6 * rows),
            )
            for extra in grid.ravel()[d:]:
                extra.set_visible(False)
            axes = grid.ravel()[:d]
        else:
            fig, grid = _new_figure_or_axes(plt, ax, (d,), type(self).__name__)
            axes = grid.ravel()
        sets = [
            ("initial", self.initial, {"linestyle": "--"} | (initial_kwargs or {})),
            ("trained", self.trained, {"linestyle": "-"} | (trained_kwargs or {})),
        ]
        self.lines_initial_ = [[] for _ in range(d)]
        self.lines_trained_ = [[] for _ in range(d)]
        store = {"initial": self.lines_initial_, "trained": self.lines_trained_}
        for j, axis in enumerate(axes):
            for name, curves, kwargs in sets:
                if curves is None:
                    continue
                mu = np.asarray(curves[j], dtype=float)
                for m in range(mu.shape[1]):
                    label = (
                        self.mf_labels[j][m]
                        if self.mf_labels is not None
                        else f"in{j + 1}mf{m + 1}"
                    )
                    (line,) = axis.plot(
                        self.x[j],
                        mu[:, m],
                        **{"color": f"C{m % 10}", "label": f"{label} ({name})"}
                        | kwargs,
                    )
                    store[name][j].append(line)
            axis.set_xlabel(self.input_names[j])
            axis.set_ylim(-0.02, 1.05)
        axes[0].set_ylabel("membership")
        axes[0].legend(fontsize="x-small")
        self.axes_ = np.asarray(axes, dtype=object)
        self.ax_ = axes[0]
        self.figure_ = fig
        return self

    @classmethod
    def from_estimator(
        cls, estimator, *, which="both", n_points=201, ax=None, **plot_kwargs
    ):
        """Plot the membership functions of a fitted ANFISRegressor.

        Only the functions used by some rule are drawn (a grid partition uses
        all of them, an FCM rule base one per rule and input).

        Parameters
        ----------
        estimator : ANFISRegressor
            Fitted model (or any estimator with ``mf``, ``mf_params_``,
            ``initial_mf_params_``, ``rules_`` and ANFISRegressor's
            ``get_input_range()`` and ``membership_degrees(X, which=...)``),
            or a fitted pipeline or wrapper ending in one (the last step of a
            pipeline, the ``estimator_`` of a wrapper such as
            ``make_model("anfis-fcm")``). The curves span the training range
            of every input plus 5 % on either side.
        which : {"both", "trained", "initial"}, default="both"
            Which functions to draw: trained (solid), initial (dashed), or
            both.
        n_points : int, default=201
            Points per curve.
        ax : matplotlib Axes or array-like of Axes, default=None
            One Axes per input; see :meth:`plot`.
        **plot_kwargs
            Further keyword arguments of :meth:`plot`.

        Returns
        -------
        display : MembershipFunctionDisplay
            The display, with the drawn artists as attributes.
        """
        check_matplotlib_support(f"{cls.__name__}.from_estimator")
        if which not in _WHICH:
            raise ValueError(
                f"which must be 'trained', 'initial' or 'both', got {which!r}."
            )
        given = estimator
        estimator, outer_names, changed = _final_model(estimator)
        if not hasattr(estimator, "mf"):
            what = type(given).__name__
            if estimator is not given:
                what += f" ending in {type(estimator).__name__}"
            raise TypeError(
                f"{cls.__name__} needs a fitted ANFISRegressor (or a pipeline or "
                f"wrapper ending in one), got {what}."
            )
        check_is_fitted(estimator, "mf_params_")
        for attr in ("initial_mf_params_", "rules_", "mf", *_METHODS):
            if not hasattr(estimator, attr):
                raise TypeError(
                    f"{type(estimator).__name__} has no {attr}; "
                    f"{cls.__name__} needs a fitted ANFISRegressor."
                )
        rules = np.asarray(estimator.rules_)
        d = np.shape(estimator.mf_params_)[0]
        names = getattr(estimator, "feature_names_in_", None)
        if names is None and outer_names is not None and len(outer_names) == d:
            names = outer_names
        names = (
            [str(s) for s in names]
            if names is not None
            else [f"x{j + 1}" for j in range(d)]
        )
        if changed:
            # The functions live in the units the steps before make.
            names = [f"{n} (after {', '.join(changed)})" for n in names]
        # One column of evaluation points per input: its range plus 5 %.
        grid = np.empty((n_points, d))
        for j, (lo, hi) in enumerate(np.asarray(estimator.get_input_range())):
            lo, hi = float(lo), float(hi)
            pad = 0.05 * (hi - lo) if hi > lo else 1.0
            grid[:, j] = np.linspace(lo - pad, hi + pad, n_points)
        # The model evaluates its own functions (layer 1 of ANFIS).
        degrees = {
            kind: np.asarray(estimator.membership_degrees(grid, which=kind))
            for kind in ("initial", "trained")
            if which in (kind, "both")
        }
        x, labels = [], []
        curves = {kind: [] for kind in degrees}
        for j in range(d):
            used = np.unique(rules[:, j])
            x.append(grid[:, j].copy())
            labels.append([f"in{j + 1}mf{m + 1}" for m in used])
            for kind, mu in degrees.items():
                curves[kind].append(mu[:, j, used])
        display = cls(
            x=x,
            initial=curves.get("initial"),
            trained=curves.get("trained"),
            input_names=names,
            mf_labels=labels,
        )
        return display.plot(ax=ax, **plot_kwargs)


def _final_model(estimator):
    """The model that does the work inside ``estimator`` (the last step of a
    pipeline, the fitted ``estimator_`` of a wrapper such as
    :class:`~skthermal.models.RunStartRegressor`), and the names of its
    inputs as the outer layers know them (None when unknown), and the names
    of the pipeline steps before it that change the inputs' values (a
    scaler: its functions are then in the scaled units; a sensor selector
    changes none)."""
    names, changed = None, []
    for _ in range(16):  # nesting depth; a loop guard, not a limit in practice
        own = getattr(estimator, "feature_names_in_", None)
        if own is not None:
            names = list(own)
        steps = getattr(estimator, "steps", None)
        if steps:
            try:
                names = list(estimator[:-1].get_feature_names_out(names))
            except Exception:  # unfitted, or a step without names
                names = None if len(steps) > 1 else names
            changed += [
                name
                for name, step in steps[:-1]
                if step not in (None, "passthrough")
                and not isinstance(step, SelectorMixin)
            ]
            estimator = steps[-1][1]
        elif not hasattr(estimator, "mf") and hasattr(estimator, "estimator_"):
            estimator = estimator.estimator_
        else:
            if not hasattr(estimator, "mf") and hasattr(estimator, "estimator"):
                check_is_fitted(estimator)  # an unfitted wrapper: say so
            break
    return estimator, names, changed
