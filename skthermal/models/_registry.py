"""The named models and sensor selectors of the papers' study and the command line.

One place maps a short name (``"anfis-fcm"``, ``"gnnmci"``, ...) to a model
with the papers' settings, wrapped in :class:`RunStartRegressor`, and to the
Optuna search space of that model, so that ``skthermal reproduce``,
``skthermal fit`` and ``skthermal search`` build the same thing.
"""

from dataclasses import dataclass
from numbers import Integral

from sklearn.utils._param_validation import Interval, StrOptions, validate_params

from skthermal.models._run_start import RunStartRegressor

N_SENSORS = 5


@dataclass(frozen=True)
class ModelSpec:
    """A named model: its label in tables and a one-line description.

    ``paper``: one of the papers' models (the Machine B study runs these by
    default); ``drivers``: driver columns the model reads besides the
    sensors (``skthermal fit`` adds them when the run table has them).
    """

    label: str
    description: str
    paper: bool = True
    drivers: tuple = ()


MODELS = {
    "anfis-fcm": ModelSpec(
        "ANFIS-FCM", "ANFIS, one rule per fuzzy c-means cluster (3 rules)"
    ),
    "anfis-grid": ModelSpec(
        "ANFIS-Grid", "ANFIS, grid partition, 3 MFs per input (243 rules on 5)"
    ),
    "gnnmci": ModelSpec("GNNMCI", "grey neural network GNNMCI(1,N), PSO-trained"),
    "grey-pso": ModelSpec("Grey-PSO", "grey model GMC(1,N) calibrated by PSO"),
    "mlp": ModelSpec("MLP", "neural network, 10 hidden neurons (001 §6.3)"),
    "ridge": ModelSpec(
        "Ridge",
        "the tuned linear baseline: standardised ridge regression, its "
        "penalty chosen by time-ordered CV",
        paper=False,
    ),
    "lag-ridge": ModelSpec(
        "Lag-ridge",
        "the recommended dynamic model (make_lag_pipeline, the drivers' "
        "filters from rest at each run's start): ridge on lag features of the "
        "temperatures, the spindle speed and the feed, time constants and "
        "penalty chosen by time-ordered CV",
        paper=False,
        drivers=("spindle_rpm", "feed_mm_min"),
    ),
}

SELECTORS = {
    "fcm": "grey influence GM(1,N) + fuzzy c-means, one sensor per group",
    "grey": "top sensors by grey influence GM(1,N)",
    "gra": "top sensors by grey relational (similitude) degree",
}


def _anfis(init, quick, random_state):
    from skthermal.fuzzy import ANFISRegressor

    # Gaussian MFs and a checking set cut from the training runs, as in 000
    # §4.3: the epoch of least checking error is kept, and training stops when
    # it has not improved for 20 epochs ("until the errors converge"). The
    # checking set, which the papers use against over-fitting, also picks the
    # ridge of the consequents' least-squares solve: the 243 grid rules on 5
    # collinear temperatures otherwise get slopes of hundreds of µm/°C that
    # blow up beyond the training range (docs/replication.md).
    common = {
        "mf": "gaussian",
        "validation_fraction": 0.2,
        "n_iter_no_change": 20,
        "ridge": "auto",
    }
    if init == "fcm":
        return ANFISRegressor(
            init="fcm",
            n_clusters=3,
            epochs=20 if quick else 100,
            random_state=random_state,
            **common,
        )
    return ANFISRegressor(
        init="grid",
        n_mfs=3,
        epochs=10 if quick else 100,
        random_state=random_state,
        **common,
    )


def _mlp(quick, random_state):
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.neural_network import MLPRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    # MATLAB's fitnet of the thesis: tanh hidden layer, scaled inputs and
    # target, a batch second-order trainer (L-BFGS here for Levenberg-Marquardt).
    net = MLPRegressor(
        hidden_layer_sizes=(10,),
        activation="tanh",
        solver="lbfgs",
        max_iter=200 if quick else 1000,
        random_state=random_state,
    )
    return make_pipeline(
        StandardScaler(),
        TransformedTargetRegressor(regressor=net, transformer=StandardScaler()),
    )


@validate_params(
    {
        "name": [StrOptions(set(MODELS))],
        "random_state": ["random_state"],
        "quick": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def make_model(name, *, random_state=None, quick=False):
    """A named model, wrapped in :class:`RunStartRegressor`.

    The papers' models, and two baselines a compensation model must beat on
    real records: ``"ridge"`` (the tuned linear baseline) and
    ``"lag-ridge"`` (the recommended dynamic model,
    :func:`skthermal.preprocessing.make_lag_pipeline` with its drivers'
    filters starting from rest at each run's start, the reference of the
    changes; it also reads the spindle speed, passed through as it is, not
    as a change).

    Parameters
    ----------
    name : {"anfis-fcm", "anfis-grid", "gnnmci", "grey-pso", "mlp", \
            "ridge", "lag-ridge"}
        The model (:data:`MODELS` describes each).
    random_state : int, RandomState instance or None, default=None
        Seeds the model.
    quick : bool, default=False
        A small training budget (for tests and smoke runs).

    Returns
    -------
    RunStartRegressor
        Parameters of the inner model are reachable as ``estimator__<name>``
        (``estimator__epochs``, ...).

    See Also
    --------
    model_search_space : the Optuna search space of a named model.

    Examples
    --------
    >>> from skthermal.models import make_model
    >>> model = make_model("anfis-fcm", random_state=0)
    >>> type(model.estimator).__name__, model.estimator.n_clusters
    ('ANFISRegressor', 3)
    """
    if name == "anfis-fcm":
        inner = _anfis("fcm", quick, random_state)
    elif name == "anfis-grid":
        inner = _anfis("grid", quick, random_state)
    elif name == "gnnmci":
        from skthermal.grey import GNNMCIRegressor

        # The papers' objective: no ridge term on the driving coefficients.
        inner = GNNMCIRegressor(alpha=0.0, random_state=random_state)
    elif name == "grey-pso":
        from skthermal.grey import GreyPSORegressor

        # The papers' set-up: the swarm on the unpenalised objective (it starts
        # from the exact variable-projection solution, so it cannot end worse).
        inner = GreyPSORegressor(
            calibration="pso", alpha=0.0, random_state=random_state
        )
    elif name == "mlp":
        inner = _mlp(quick, random_state)
    else:
        from skthermal.preprocessing import LagRidgeCV, make_lag_pipeline

        if name == "ridge":
            # No lags, no drivers: standardised ridge on the temperatures,
            # its penalty by the same time-ordered CV.
            inner = LagRidgeCV(time_constant_sets=[()], drivers=None)
        else:
            # Changes since the run start take the start as the reference
            # state, and so do the drivers' filters: the heat of a spindle
            # turning at the first row builds up from there. Started in
            # steady state, the filters read the first row as a warm machine,
            # and its predicted error, subtracted from the whole run, shifted
            # runs that start turning (on independent multi-run campaigns
            # worse than the ridge in 31 of 54 cases, 23 from rest).
            inner = make_lag_pipeline(driver_initial="rest")
    return RunStartRegressor(inner, drivers="auto" if MODELS[name].drivers else None)


class _MLPSpace:
    """Search space of the MLP baseline (hidden neurons, alpha, activation)."""

    _prefix = "estimator__transformedtargetregressor__regressor__"

    def __call__(self, trial):
        p = self._prefix
        return {
            p + "hidden_layer_sizes": (trial.suggest_int("hidden", 2, 30),),
            p + "alpha": trial.suggest_float("alpha", 1e-6, 1e-1, log=True),
            p + "activation": trial.suggest_categorical("activation", ["tanh", "relu"]),
        }

    def __repr__(self):
        return "model_search_space('mlp')"


@validate_params(
    {"name": [StrOptions(set(MODELS))]},
    prefer_skip_nested_validation=True,
)
def model_search_space(name):
    """The Optuna search space of a named model of :func:`make_model`.

    ANFIS: rules or MFs per input, MF shape, epochs and step size (with the
    model's partition fixed); grey-pso: the calibration (variable projection
    or least squares, not the swarm), the ridge and the delay; gnnmci: the
    PSO settings; MLP: hidden
    neurons, L2 penalty and activation. Keys are ``set_params`` names of the
    wrapped model (``estimator__...``). ``"ridge"`` and ``"lag-ridge"``
    choose their settings by their own time-ordered CV and have no search
    space (a ValueError says so).

    Parameters
    ----------
    name : {"anfis-fcm", "anfis-grid", "gnnmci", "grey-pso", "mlp", \
            "ridge", "lag-ridge"}

    Returns
    -------
    callable
        ``space(trial) -> dict`` of parameters, for
        :func:`skthermal.model_selection.run_search`.

    Examples
    --------
    >>> from skthermal.models import model_search_space
    >>> model_search_space("anfis-fcm")
    search_space('anfis', prefix='estimator', init='fcm')
    """
    from skthermal.model_selection import search_space

    if name == "anfis-fcm":
        return search_space("anfis", prefix="estimator", init="fcm")
    if name == "anfis-grid":
        return search_space("anfis", prefix="estimator", init="grid")
    if name == "gnnmci":
        return search_space("gnnmci", prefix="estimator")
    if name == "grey-pso":
        return search_space("grey_pso", prefix="estimator")
    if name == "mlp":
        return _MLPSpace()
    raise ValueError(
        f"{name!r} has no search space: it chooses its settings (penalty, "
        "time constants) by its own time-ordered cross-validation in fit."
    )


@validate_params(
    {
        "name": [StrOptions(set(SELECTORS))],
        "n_sensors": [Interval(Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def make_selector(name, n_sensors=N_SENSORS, *, random_state=None):
    """A named sensor selector keeping ``n_sensors`` sensors.

    Parameters
    ----------
    name : {"fcm", "grey", "gra"}
        ``"fcm"``: GM(1,N) influence + fuzzy c-means, the most influential
        sensor of each group (000 §4.2); ``"grey"``: the top sensors by
        GM(1,N) influence; ``"gra"``: the top sensors by grey relational
        degree.
    n_sensors : int, default=5
        Sensors to keep.
    random_state : int, RandomState instance or None, default=None
        Seeds the clustering of ``"fcm"``.

    Returns
    -------
    selector
        A :class:`~skthermal.selection.FCMClusterPicker`,
        :class:`~skthermal.selection.GreyInfluenceSelector` or
        :class:`~skthermal.selection.GRASelector`.

    Examples
    --------
    >>> from skthermal.models import make_selector
    >>> make_selector("grey", 3)
    GreyInfluenceSelector(n_features_to_select=3)
    """
    from skthermal.selection import (
        FCMClusterPicker,
        GRASelector,
        GreyInfluenceSelector,
    )

    if name == "fcm":
        return FCMClusterPicker(n_clusters=n_sensors, random_state=random_state)
    if name == "grey":
        return GreyInfluenceSelector(n_features_to_select=n_sensors)
    return GRASelector(n_features_to_select=n_sensors)


def n_rules(model):
    """Rules of a fitted (wrapped) ANFIS model, else None.

    Parameters
    ----------
    model : estimator
        A fitted model, bare or wrapped in :class:`RunStartRegressor`.

    Returns
    -------
    int or None

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from skthermal.models import n_rules
    >>> n_rules(LinearRegression()) is None
    True
    """
    inner = getattr(model, "estimator_", model)
    value = getattr(inner, "n_rules_", None)
    return None if value is None else int(value)
