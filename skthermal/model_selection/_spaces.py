"""Optuna search spaces of the skthermal estimators.

A search space is a callable ``space(trial) -> dict`` of estimator parameters,
drawn with the ``trial.suggest_*`` methods (the define-by-run style of Optuna,
so a parameter can depend on another, e.g. ``n_clusters`` only for
``init="fcm"``). :func:`search_space` builds the built-in ones, with the ranges
of the thermal-error literature and optional overrides; :func:`combine_spaces`
joins spaces of several pipeline steps.
"""

import numbers

from skthermal._naming import qualified_name

_PREFIX_SEP = "__"


def _cat(trial, name, spec):
    if isinstance(spec, list | tuple):
        return trial.suggest_categorical(name, list(spec))
    return spec


def _int(trial, name, spec, log=False):
    if isinstance(spec, tuple):
        low, high = spec
        return trial.suggest_int(name, int(low), int(high), log=log)
    return spec


def _float(trial, name, spec, log=False):
    if isinstance(spec, tuple):
        low, high = spec
        return trial.suggest_float(name, float(low), float(high), log=log)
    return spec


def _anfis(trial, key, r):
    init = _cat(trial, key("init"), r["init"])
    params = {"init": init, "mf": _cat(trial, key("mf"), r["mf"])}
    if init == "fcm":
        params["n_clusters"] = _int(trial, key("n_clusters"), r["n_clusters"])
    else:
        params["n_mfs"] = _int(trial, key("n_mfs"), r["n_mfs"])
    params["epochs"] = _int(trial, key("epochs"), r["epochs"], log=True)
    params["step_size"] = _float(trial, key("step_size"), r["step_size"], log=True)
    return params


def _pso(trial, key, r):
    start = _float(trial, key("inertia_start"), r["inertia_start"])
    end = _float(trial, key("inertia_end"), r["inertia_end"])
    return {
        "n_particles": _int(trial, key("n_particles"), r["n_particles"], log=True),
        "epochs": _int(trial, key("epochs"), r["epochs"], log=True),
        "c1": _float(trial, key("c1"), r["c1"]),
        "c2": _float(trial, key("c2"), r["c2"]),
        "inertia": (start, end),
    }


def _grey_pso(trial, key, r):
    # What changes the held-out error: the calibration, the ridge on the
    # driving coefficients and the delay. A swarm started at the
    # variable-projection optimum ends there whatever its settings, so with
    # "pso" (only when asked for) it starts elsewhere and its settings are
    # searched.
    calibration = _cat(trial, key("calibration"), r["calibration"])
    params = {
        "calibration": calibration,
        "alpha": _float(trial, key("alpha"), r["alpha"], log=True),
        "delay": _int(trial, key("delay"), r["delay"]),
    }
    if calibration == "pso":
        params["init"] = _cat(trial, key("init"), r["init"])
        params.update(_pso(trial, key, r))
    return params


def _gnnmci(trial, key, r):
    params = _pso(trial, key, r)
    params["velocity_clamp"] = _float(
        trial, key("velocity_clamp"), r["velocity_clamp"], log=True
    )
    return params


def _fcm_picker(trial, key, r):
    return {
        "n_clusters": _int(trial, key("n_clusters"), r["n_clusters"]),
        "scorer": _cat(trial, key("scorer"), r["scorer"]),
    }


_PSO_RANGES = {
    "n_particles": (10, 100),
    "epochs": (10, 200),
    "c1": (0.5, 2.5),
    "c2": (0.5, 2.5),
    "inertia_start": (0.6, 1.0),
    "inertia_end": (0.1, 0.6),
}

# name -> (function, default ranges, estimator "module.Class"). A tuple is a
# (low, high) range, a list the categorical choices, anything else a fixed
# value that is set but not searched.
_REGISTRY = {
    "anfis": (
        _anfis,
        {
            "init": ["fcm", "grid"],
            "mf": ["gaussian", "gbell"],
            "n_clusters": (2, 8),
            "n_mfs": (2, 3),
            "epochs": (10, 200),
            "step_size": (0.01, 1.0),
        },
        "skthermal.fuzzy.ANFISRegressor",
    ),
    "grey_pso": (
        _grey_pso,
        {
            "calibration": ["varpro", "ls"],
            "alpha": (1e-6, 1e2),
            "delay": (0, 3),
            "init": ["ls", "random"],
            **_PSO_RANGES,
        },
        "skthermal.grey.GreyPSORegressor",
    ),
    "gnnmci": (
        _gnnmci,
        {**_PSO_RANGES, "velocity_clamp": (0.1, 3.0)},
        "skthermal.grey.GNNMCIRegressor",
    ),
    "fcm_picker": (
        _fcm_picker,
        {"n_clusters": (2, 8), "scorer": ["gm1n", "gm0n", "gra", "pearson"]},
        "skthermal.selection.FCMClusterPicker",
    ),
}


def search_space_names():
    """Names of the built-in search spaces.

    Returns
    -------
    list of str

    Examples
    --------
    >>> from skthermal.model_selection import search_space_names
    >>> search_space_names()
    ['anfis', 'fcm_picker', 'gnnmci', 'grey_pso']
    """
    return sorted(_REGISTRY)


def _default_space_name(estimator):
    """The built-in space for an estimator's class, or None."""
    cls = type(estimator).__name__
    for name, (_, _, owner) in _REGISTRY.items():
        if owner.rpartition(".")[2] == cls:
            return name
    return None


def refusal(owner, key, value):
    """Why the estimator class ``owner`` refuses ``key=value`` (its
    parameter constraints' message), or None; None too for a key it has no
    constraint for (a setting drawn into another parameter, e.g. the PSO's
    inertia)."""
    from sklearn.utils._param_validation import (
        InvalidParameterError,
        validate_parameter_constraints,
    )

    constraints = getattr(owner, "_parameter_constraints", None) or {}
    if key not in constraints:
        return None
    try:
        validate_parameter_constraints(
            {key: constraints[key]}, {key: value}, owner.__name__
        )
    except InvalidParameterError as exc:
        return str(exc)
    return None


def _values_drawn(name, key, spec):
    """The values the space ``name`` can set for ``key`` under ``spec``: the
    choices, the fixed value, or the ends of the range, cast to int where the
    space draws ints (its default range is of ints, as :func:`_int` does)."""
    if isinstance(spec, list):
        return list(spec)
    if not isinstance(spec, tuple):
        return [spec]
    default = _REGISTRY[name][1][key]
    if isinstance(default, tuple) and all(isinstance(v, int) for v in default):
        return [int(v) for v in spec]
    return list(spec)


def _check_override(name, key, spec):
    """Refuse an override that the space's estimator would refuse in every
    trial (a fixed value or a choice it does not take, a range ending outside
    what it takes), naming the parameter: at once, not when a search runs."""
    from importlib import import_module

    module, _, cls = _REGISTRY[name][2].rpartition(".")
    owner = getattr(import_module(module), cls)
    for value in _values_drawn(name, key, spec):
        why = refusal(owner, key, value)
        if why is not None:
            raise ValueError(
                f"search_space({name!r}, {key}={spec!r}): {cls} refuses "
                f"{key}={value!r}. {why}"
            )


# Parameters the built-in spaces draw on a log scale: a range must start
# above 0.
_LOG_SCALED = frozenset(
    {"epochs", "step_size", "n_particles", "alpha", "velocity_clamp"}
)


def _check_spec(key, spec, default):
    if isinstance(default, list):
        if isinstance(spec, list | tuple) and len(spec) == 0:
            raise ValueError(f"{key}: give at least one choice.")
        return list(spec) if isinstance(spec, tuple) else spec
    if isinstance(spec, list):
        raise ValueError(
            f"{key} is numeric: give a (low, high) tuple or a fixed number, got "
            f"the list {spec!r}."
        )
    if isinstance(spec, tuple):
        if len(spec) != 2 or not all(isinstance(v, numbers.Real) for v in spec):
            raise ValueError(f"{key}: a range is a (low, high) tuple, got {spec!r}.")
        if spec[0] > spec[1]:
            raise ValueError(f"{key}: low must not exceed high, got {spec!r}.")
        whole = isinstance(default, tuple) and all(isinstance(v, int) for v in default)
        if whole and any(float(v) != int(v) for v in spec):
            # int() of a bound drew values outside the range asked for
            # ((2.5, 4) drew 2).
            raise ValueError(
                f"{key} is a whole number: its range takes whole bounds, got {spec!r}."
            )
        if key in _LOG_SCALED and spec[0] <= 0:
            raise ValueError(
                f"{key} is searched on a log scale: its range must start above "
                f"0, got {spec!r}."
            )
    return spec


class SearchSpace:
    """A built-in search space; call it with an Optuna trial.

    Create it with :func:`search_space`. Calling ``space(trial)`` draws the
    parameters and returns them keyed for ``set_params`` (with the prefix,
    e.g. ``"anfisregressor__epochs"``); the Optuna parameter names carry the
    same prefix, so several steps of a pipeline can be searched together.

    Parameters
    ----------
    name : str
        Built-in space name (:func:`search_space_names`).
    prefix : str or None
        Pipeline step name; None for a bare estimator.
    ranges : dict
        Ranges per searched parameter, after overrides.
    """

    def __init__(self, name, prefix, ranges):
        self.name = name
        self.prefix = prefix
        self.ranges = ranges

    def _key(self, param):
        return param if not self.prefix else f"{self.prefix}{_PREFIX_SEP}{param}"

    def __call__(self, trial):
        function = _REGISTRY[self.name][0]
        params = function(trial, self._key, self.ranges)
        return {self._key(k): v for k, v in params.items()}

    def __repr__(self):
        prefix = f", prefix={self.prefix!r}" if self.prefix else ""
        defaults = _REGISTRY[self.name][1]
        overrides = "".join(
            f", {k}={v!r}" for k, v in self.ranges.items() if v != defaults[k]
        )
        return f"search_space({self.name!r}{prefix}{overrides})"


def search_space(name, *, prefix=None, **ranges):
    """A built-in Optuna search space of a skthermal estimator.

    Parameters
    ----------
    name : {"anfis", "grey_pso", "gnnmci", "fcm_picker"}
        ``"anfis"`` (:class:`~skthermal.fuzzy.ANFISRegressor`): ``init``
        in {"fcm", "grid"}; ``n_clusters`` 2-8 with FCM, ``n_mfs`` 2-3 with a
        grid; ``mf`` in {"gaussian", "gbell"}; ``epochs`` 10-200 (log);
        ``step_size`` 0.01-1 (log). A grid has ``n_mfs ** n_features``
        rules: with more than about four inputs fix ``init="fcm"``.
        ``"grey_pso"`` (:class:`~skthermal.grey.GreyPSORegressor`):
        ``calibration`` in {"varpro", "ls"}, the ridge ``alpha`` on the
        driving coefficients 1e-6-100 (log) and the ``delay`` 0-3 samples;
        with ``calibration="pso"`` among the choices (only when asked for,
        e.g. ``calibration=["varpro", "pso"]``), also ``init`` in {"ls",
        "random"}, ``n_particles`` 10-100, ``epochs`` 10-200, ``c1``, ``c2``
        0.5-2.5 and a linearly decreasing ``inertia`` from
        ``inertia_start`` (0.6-1.0) to ``inertia_end`` (0.1-0.6): a swarm
        started at the variable-projection optimum ends there.
        ``"gnnmci"`` (:class:`~skthermal.grey.GNNMCIRegressor`): the PSO
        settings and ``velocity_clamp`` 0.1-3 (log).
        ``"fcm_picker"`` (:class:`~skthermal.selection.FCMClusterPicker`):
        ``n_clusters`` 2-8 and ``scorer`` in {"gm1n", "gm0n", "gra",
        "pearson"}.
    prefix : str, optional
        Pipeline step name, e.g. ``"anfisregressor"``: the parameters come
        out as ``"anfisregressor__epochs"``.
    **ranges
        Overrides: a ``(low, high)`` tuple for a numeric range, a list of
        choices for a categorical one, or a single value to fix the parameter
        without searching it (e.g. ``epochs=20``, ``init="fcm"``).

    Returns
    -------
    SearchSpace
        A callable ``space(trial) -> dict`` of parameters.

    See Also
    --------
    combine_spaces : Join spaces of several pipeline steps.
    run_search : Run the search.

    Examples
    --------
    >>> import optuna
    >>> from skthermal.model_selection import search_space
    >>> space = search_space("anfis", init="fcm", epochs=(10, 50))
    >>> params = space(optuna.trial.FixedTrial(
    ...     {"mf": "gbell", "n_clusters": 3, "epochs": 20, "step_size": 0.1}))
    >>> params
    {'init': 'fcm', 'mf': 'gbell', 'n_clusters': 3, 'epochs': 20, 'step_size': 0.1}
    >>> search_space("fcm_picker", prefix="fcmclusterpicker", scorer="gm1n")(
    ...     optuna.trial.FixedTrial({"fcmclusterpicker__n_clusters": 4}))
    {'fcmclusterpicker__n_clusters': 4, 'fcmclusterpicker__scorer': 'gm1n'}
    """
    if name not in _REGISTRY:
        raise ValueError(
            f"Unknown search space {name!r}; use one of {search_space_names()} or "
            "pass your own callable space(trial) -> dict."
        )
    defaults = _REGISTRY[name][1]
    unknown = sorted(set(ranges) - set(defaults))
    if unknown:
        raise ValueError(
            f"Search space {name!r} has no parameter(s) {unknown}; it has "
            f"{sorted(defaults)}."
        )
    merged = dict(defaults)
    for key, spec in ranges.items():
        merged[key] = _check_spec(key, spec, defaults[key])
        _check_override(name, key, merged[key])
    if name == "anfis" and isinstance(merged["init"], str):
        # The other rule base's size is never drawn: an override of it did
        # nothing, silently.
        unused = {"grid": "n_clusters", "fcm": "n_mfs"}[merged["init"]]
        if unused in ranges:
            used = {"grid": "n_mfs", "fcm": "n_clusters"}[merged["init"]]
            raise ValueError(
                f"Search space 'anfis' with init={merged['init']!r} draws "
                f"{used}, not {unused}: give {used}=..., or init=['fcm', "
                "'grid'] to search both rule bases."
            )
    if prefix is not None and (not isinstance(prefix, str) or not prefix):
        raise ValueError(f"prefix must be a non-empty string, got {prefix!r}.")
    return SearchSpace(name, prefix, merged)


def combine_spaces(*spaces):
    """One space drawing from several (e.g. one per pipeline step).

    Parameters
    ----------
    *spaces : callable
        Each ``space(trial) -> dict``; their parameter names must not clash.

    Returns
    -------
    callable
        ``space(trial) -> dict``, the union of the dictionaries.

    Examples
    --------
    >>> import optuna
    >>> from skthermal.model_selection import combine_spaces, search_space
    >>> space = combine_spaces(
    ...     search_space("fcm_picker", prefix="fcmclusterpicker"),
    ...     search_space("anfis", prefix="anfisregressor", init="fcm"),
    ... )
    >>> study = optuna.create_study(direction="maximize")
    >>> sorted(space(study.ask()))
    ['anfisregressor__epochs', 'anfisregressor__init', 'anfisregressor__mf', \
'anfisregressor__n_clusters', 'anfisregressor__step_size', \
'fcmclusterpicker__n_clusters', 'fcmclusterpicker__scorer']
    """
    for space in spaces:
        if not callable(space):
            raise TypeError(f"Every space must be callable, got {space!r}.")
    return _CombinedSpace(spaces)


class _CombinedSpace:
    def __init__(self, spaces):
        self.spaces = tuple(spaces)

    def __call__(self, trial):
        params = {}
        for space in self.spaces:
            drawn = space(trial)
            clash = sorted(set(drawn) & set(params))
            if clash:
                raise ValueError(f"Search spaces clash on parameter(s) {clash}.")
            params.update(drawn)
        return params

    def __repr__(self):
        return f"combine_spaces({', '.join(map(describe_space, self.spaces))})"


class _PrefixedTrial:
    """An Optuna trial whose ``suggest_*`` names carry a pipeline step's
    prefix (``step__n_clusters``): two steps' spaces that name a parameter
    alike (a picker's and ANFIS's ``n_clusters``) then draw it apart, not
    as one Optuna parameter. Everything else is the trial's."""

    def __init__(self, trial, prefix):
        self._trial = trial
        self._prefix = prefix

    def __getattr__(self, attr):
        value = getattr(self._trial, attr)
        if not (attr.startswith("suggest_") and callable(value)):
            return value

        def suggest(name, *args, **kwargs):
            return value(f"{self._prefix}{_PREFIX_SEP}{name}", *args, **kwargs)

        return suggest


class PrefixedSpace:
    """A space whose parameters belong to the pipeline step ``prefix``; its
    Optuna parameters are named with the prefix too."""

    def __init__(self, prefix, space):
        self.prefix = prefix
        self.space = space

    def __call__(self, trial):
        params = self.space(_PrefixedTrial(trial, self.prefix))
        return {f"{self.prefix}{_PREFIX_SEP}{k}": v for k, v in params.items()}

    def __repr__(self):
        return f"{describe_space(self.space)} for step {self.prefix!r}"


def space_names(space):
    """The names of the built-in spaces that ``space`` is made of."""
    if isinstance(space, SearchSpace):
        return {space.name}
    if isinstance(space, PrefixedSpace):
        return space_names(space.space)
    if isinstance(space, _CombinedSpace):
        return set().union(*(space_names(part) for part in space.spaces))
    return set()


def space_values(space):
    """The values a space can set, by ``set_params`` key: every choice, every
    fixed value and the ends of every range of its built-in parts (a
    callable of the user's own gives none).

    Examples
    --------
    >>> from skthermal.model_selection._spaces import space_values
    >>> space_values(search_space("fcm_picker", prefix="p", scorer="gra"))
    {'p__n_clusters': [2, 8], 'p__scorer': ['gra']}
    """
    if isinstance(space, SearchSpace):
        return {
            space._key(k): _values_drawn(space.name, k, v)
            for k, v in space.ranges.items()
        }
    if isinstance(space, PrefixedSpace):
        inner = space_values(space.space)
        return {f"{space.prefix}{_PREFIX_SEP}{k}": v for k, v in inner.items()}
    if isinstance(space, _CombinedSpace):
        out = {}
        for part in space.spaces:
            out.update(space_values(part))
        return out
    return {}


def space_ranges(space):
    """Every range and choice of a space's built-in parts, defaults
    included, as plain data (a callable of the user's own by its module and
    qualified name): what a stored study records, so that a search whose
    defaults changed between versions does not join it unnoticed.

    Examples
    --------
    >>> from skthermal.model_selection._spaces import space_ranges
    >>> space_ranges(search_space("fcm_picker", n_clusters=(2, 4)))
    {'space': 'fcm_picker', 'prefix': None, 'ranges': {'n_clusters': (2, 4), \
'scorer': ['gm1n', 'gm0n', 'gra', 'pearson']}}
    """
    if isinstance(space, SearchSpace):
        return {"space": space.name, "prefix": space.prefix, "ranges": space.ranges}
    if isinstance(space, _CombinedSpace):
        return [space_ranges(s) for s in space.spaces]
    if isinstance(space, PrefixedSpace):
        return {"step": space.prefix, "space": space_ranges(space.space)}
    return qualified_name(space)


def describe_space(space):
    """What a search space is, the same in every process: a built-in space
    with its overrides, or a callable's module and qualified name.

    Examples
    --------
    >>> from skthermal.model_selection._spaces import describe_space
    >>> describe_space(search_space("anfis", init="fcm", epochs=(5, 8)))
    "search_space('anfis', init='fcm', epochs=(5, 8))"
    """
    if isinstance(space, SearchSpace | _CombinedSpace | PrefixedSpace):
        return repr(space)
    return qualified_name(space)
