"""Causal lag features for dynamic thermal-error compensation.

The thermal error of a machine tool lags its temperatures: the structure heats
and cools with its own time constants. A static regression on the current
temperatures cannot represent that lag; first-order low-pass filters of the
temperature changes (and of the spindle speed, the heat source) can.
"""

from numbers import Integral, Real

import numpy as np
from scipy.signal import lfilter
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from ..utils._runs import (
    TIME_COLUMN,
    check_time_order,
    extract_runs,
    run_slices,
)

DEFAULT_DRIVER_NAMES = ("spindle_rpm",)


def exponential_filter(U, time_constant, dt, slices=None):
    """First-order exponential (low-pass) filter, restarting at every run.

    ``z[k] = a z[k-1] + (1 - a) u[k]`` with ``a = exp(-dt / time_constant)``.
    Each run's filter starts in steady state at the run's first value, so a
    constant input gives a constant output.

    Parameters
    ----------
    U : array-like of shape (n_samples,) or (n_samples, n_features)
        Input signals, rows in time order.
    time_constant : float
        Time constant in the unit of ``dt`` (seconds), > 0.
    dt : float or array-like of shape (n_runs,)
        Sampling period of every run (one value for all runs, or one per run).
    slices : list of slice, optional
        Runs as returned by :func:`skthermal.utils._runs.run_slices`
        (default: all rows are one run).

    Returns
    -------
    Z : ndarray of the same shape as ``U``

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import exponential_filter
    >>> z = exponential_filter(np.r_[0.0, 1.0, 1.0, 1.0], 1.0, 1.0)
    >>> np.round(z, 3).tolist()
    [0.0, 0.632, 0.865, 0.95]
    """
    U = np.asarray(U, dtype=float)
    if not time_constant > 0:
        raise ValueError(f"time_constant must be > 0, got {time_constant!r}.")
    if slices is None:
        slices = [slice(0, U.shape[0])]
    dts = np.broadcast_to(np.asarray(dt, dtype=float), (len(slices),))
    Z = np.empty_like(U)
    for sl, step in zip(slices, dts, strict=True):
        if sl.stop <= sl.start:
            continue
        a = float(np.exp(-step / time_constant))
        u = U[sl]
        zi = a * u[:1]
        Z[sl] = lfilter([1.0 - a], [1.0, -a], u, axis=0, zi=zi)[0]
    return Z


def _run_spacing(X, groups, slices, default):
    """Sampling period of every run: from a ``time_s`` index level, else dt."""
    index = getattr(X, "index", None)
    names = getattr(index, "names", None)
    if names is None or TIME_COLUMN not in names:
        return np.full(len(slices), float(default))
    check_time_order(X, groups)
    t = np.asarray(index.get_level_values(TIME_COLUMN), dtype=float)
    out = np.full(len(slices), float(default))
    for i, sl in enumerate(slices):
        if sl.stop - sl.start > 1:
            out[i] = float(np.median(np.diff(t[sl])))
    return out


class LagFeatures(TransformerMixin, BaseEstimator):
    """Causal lag features: temperature changes and their low-pass filters.

    For every run (restarting at each run start) the transformer returns the
    temperature changes since the run start ``dT``, ``dT`` through first-order
    exponential filters with the given time constants (each starting in steady
    state), and the same filters applied to the drivers (e.g. spindle speed)
    as ``(u / driver_scale) ** p`` for every power ``p``.

    Run labels are taken from ``groups``, a ``run`` column or a ``run`` index
    level; with a ``time_s`` index level the sampling period of each run is
    the median spacing of its times, otherwise ``dt``.

    Parameters
    ----------
    time_constants : sequence of float, default=(900.0, 3600.0, 14400.0)
        Filter time constants in seconds. May be empty.
    include_changes : bool, default=True
        Include the unfiltered changes ``dT`` themselves.
    drivers : "auto", None or sequence of str or int, default="auto"
        Driver columns (names or positions), filtered but not differenced.
        ``"auto"`` uses the columns named ``spindle_rpm`` when present.
        All other columns are temperatures.
    driver_powers : sequence of float, default=(1.0, 1.5)
        Powers applied to the scaled drivers (sign kept).
    driver_scale : float, default=1000.0
        Drivers are divided by this before the power.
    dt : float, default=1.0
        Seconds per row when there is no ``time_s`` index level.

    Attributes
    ----------
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when fitted on a DataFrame with string column names.
    driver_indices_ : ndarray of int
        Positions of the driver columns.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import LagFeatures
    >>> X = np.c_[np.linspace(20, 25, 6), np.linspace(21, 22, 6)]
    >>> LagFeatures(time_constants=[60.0], dt=30.0).fit_transform(X).shape
    (6, 4)
    """

    _parameter_constraints = {
        "time_constants": ["array-like"],
        "include_changes": ["boolean"],
        "drivers": [StrOptions({"auto"}), None, "array-like"],
        "driver_powers": ["array-like"],
        "driver_scale": [Interval(Real, 0, None, closed="neither")],
        "dt": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        time_constants=(900.0, 3600.0, 14400.0),
        *,
        include_changes=True,
        drivers="auto",
        driver_powers=(1.0, 1.5),
        driver_scale=1000.0,
        dt=1.0,
    ):
        self.time_constants = time_constants
        self.include_changes = include_changes
        self.drivers = drivers
        self.driver_powers = driver_powers
        self.driver_scale = driver_scale
        self.dt = dt

    def _taus(self):
        taus = np.asarray(self.time_constants, dtype=float).ravel()
        if np.any(~np.isfinite(taus)) or np.any(taus <= 0):
            raise ValueError(
                f"time_constants must be finite and > 0, got {list(taus)}."
            )
        return taus

    def _resolve_drivers(self, names, n_features):
        if self.drivers is None:
            return np.zeros(0, dtype=int)
        if isinstance(self.drivers, str):  # "auto"
            if names is None:
                return np.zeros(0, dtype=int)
            return np.array(
                [i for i, c in enumerate(names) if str(c) in DEFAULT_DRIVER_NAMES],
                dtype=int,
            )
        out = []
        for d in self.drivers:
            if isinstance(d, Integral | np.integer):
                if not 0 <= int(d) < n_features:
                    raise ValueError(
                        f"Driver column {d} is out of range for {n_features} features."
                    )
                out.append(int(d))
            else:
                if names is None or str(d) not in list(names):
                    raise ValueError(
                        f"Driver column {d!r} is not among the feature names "
                        f"{None if names is None else list(names)}."
                    )
                out.append(list(names).index(str(d)))
        return np.array(sorted(set(out)), dtype=int)

    def fit(self, X, y=None, groups=None):
        """Check the input and find the driver columns.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        y : ignored
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : LagFeatures
        """
        self._validate_params()
        X_raw, groups = extract_runs(X, groups)
        X_arr = validate_data(self, X_raw, dtype=np.float64)
        self._taus()
        names = getattr(self, "feature_names_in_", None)
        self.driver_indices_ = self._resolve_drivers(names, X_arr.shape[1])
        powers = np.asarray(self.driver_powers, dtype=float).ravel()
        n_temp = X_arr.shape[1] - self.driver_indices_.size
        n_out = n_temp * (int(self.include_changes) + self._taus().size)
        n_out += self.driver_indices_.size * powers.size * self._taus().size
        if n_out == 0:
            raise ValueError(
                "LagFeatures would produce no features: set include_changes=True "
                "or give time_constants (and drivers) to filter."
            )
        return self

    def transform(self, X, groups=None):
        """Compute the lag features, restarting at every run.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        F : ndarray of shape (n_samples, n_features_out)
        """
        check_is_fitted(self, "driver_indices_")
        X_raw, groups = extract_runs(X, groups)
        X_arr = validate_data(self, X_raw, dtype=np.float64, reset=False)
        slices, _ = run_slices(groups, X_arr.shape[0])
        dts = _run_spacing(X_raw, groups, slices, self.dt)
        taus = self._taus()
        temp = np.setdiff1d(np.arange(X_arr.shape[1]), self.driver_indices_)
        T = X_arr[:, temp]
        dT = np.empty_like(T)
        for sl in slices:
            dT[sl] = T[sl] - T[sl.start]
        blocks = [dT] if self.include_changes else []
        blocks += [exponential_filter(dT, tau, dts, slices) for tau in taus]
        if self.driver_indices_.size:
            D = X_arr[:, self.driver_indices_] / self.driver_scale
            for p in np.asarray(self.driver_powers, dtype=float).ravel():
                Dp = np.sign(D) * np.abs(D) ** p
                blocks += [exponential_filter(Dp, tau, dts, slices) for tau in taus]
        return np.hstack(blocks)

    def get_feature_names_out(self, input_features=None):
        """Names of the output features.

        Parameters
        ----------
        input_features : array-like of str, optional

        Returns
        -------
        ndarray of str
        """
        check_is_fitted(self, "driver_indices_")
        if input_features is None:
            input_features = getattr(self, "feature_names_in_", None)
        if input_features is None:
            input_features = [f"x{i}" for i in range(self.n_features_in_)]
        input_features = np.asarray(input_features, dtype=object)
        temp = np.setdiff1d(np.arange(self.n_features_in_), self.driver_indices_)
        tnames = [str(c) for c in input_features[temp]]
        out = [f"d_{c}" for c in tnames] if self.include_changes else []
        taus = self._taus()
        for tau in taus:
            out += [f"d_{c}_lp{tau:g}" for c in tnames]
        for p in np.asarray(self.driver_powers, dtype=float).ravel():
            for tau in taus:
                out += [
                    f"{input_features[i]}_pow{p:g}_lp{tau:g}"
                    for i in self.driver_indices_
                ]
        return np.asarray(out, dtype=object)
