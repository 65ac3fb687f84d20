"""Scorers for the thermal-error metrics, for ``cross_validate(scoring=...)``.

Errors are negated, as in scikit-learn, so that greater is always better:
``neg_rmse`` and ``neg_residual_band``; ``nse``, ``pearson_r`` and
``improvement`` are scores already.
"""

import copy

from sklearn.metrics import get_scorer as _sklearn_get_scorer
from sklearn.metrics import get_scorer_names as _sklearn_get_scorer_names
from sklearn.metrics import make_scorer

from skthermal.metrics._regression import (
    improvement,
    nash_sutcliffe,
    pearson_r,
    residual_band,
    rmse,
)

_SCORERS = {
    "neg_rmse": make_scorer(rmse, greater_is_better=False),
    "nse": make_scorer(nash_sutcliffe),
    "pearson_r": make_scorer(pearson_r),
    "neg_residual_band": make_scorer(residual_band, greater_is_better=False),
    "improvement": make_scorer(improvement),
}


def thermal_scorers():
    """All thermal-error scorers, by name.

    Returns
    -------
    dict of str to callable
        ``{"neg_rmse", "nse", "pearson_r", "neg_residual_band",
        "improvement"}`` mapped to scorer objects (fresh copies).

    Examples
    --------
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.model_selection import cross_validate
    >>> from skthermal.metrics import thermal_scorers
    >>> X = [[0.0], [1.0], [2.0], [3.0], [4.0], [5.0]]
    >>> y = [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    >>> cv = cross_validate(LinearRegression(), X, y, cv=2,
    ...                     scoring=thermal_scorers())
    >>> sorted(k for k in cv if k.startswith("test_"))
    ['test_improvement', 'test_neg_residual_band', 'test_neg_rmse', 'test_nse', \
'test_pearson_r']
    """
    return {name: copy.deepcopy(scorer) for name, scorer in _SCORERS.items()}


def get_scorer_names():
    """Names accepted by :func:`get_scorer`: the thermal ones, then sklearn's.

    Returns
    -------
    list of str
    """
    return [*_SCORERS, *_sklearn_get_scorer_names()]


def get_scorer(scoring):
    """A scorer from its name, thermal or scikit-learn.

    Parameters
    ----------
    scoring : str, callable or None
        One of ``"neg_rmse"``, ``"nse"``, ``"pearson_r"``,
        ``"neg_residual_band"``, ``"improvement"``, or any name known to
        :func:`sklearn.metrics.get_scorer`. Callables and None are returned
        as they are, as in scikit-learn.

    Returns
    -------
    callable
        A scorer ``scorer(estimator, X, y)``; greater is better.

    Raises
    ------
    ValueError
        If the name is unknown.

    Examples
    --------
    >>> from skthermal.metrics import get_scorer
    >>> get_scorer("neg_rmse")
    make_scorer(rmse, greater_is_better=False, response_method='predict')
    >>> get_scorer("r2")
    make_scorer(r2_score, response_method='predict')
    """
    if isinstance(scoring, str) and scoring in _SCORERS:
        return copy.deepcopy(_SCORERS[scoring])
    try:
        return _sklearn_get_scorer(scoring)
    except ValueError as exc:
        raise ValueError(
            f"{scoring!r} is not a valid scoring value: use one of the thermal "
            f"scorers {list(_SCORERS)} or a scikit-learn scorer name "
            "(skthermal.metrics.get_scorer_names())."
        ) from exc
