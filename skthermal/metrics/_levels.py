"""Three-level RMSE of a family of batch models (004 eq. 16, METHODS §11).

Liu et al. build one model per batch (M1..M20 from B1..B20) with every method
and judge the method by three nested means: the RMSE of model ``i`` on batch
``j``; the mean of those over the batches, per model; and the mean over the
models, per method. :func:`rmse_levels` computes the three tables from
predictions; :func:`cross_batch_rmse` first fits one model per batch.
"""

import warnings
from collections import namedtuple
from collections.abc import Mapping

import numpy as np
import pandas as pd
from sklearn.base import clone

from skthermal._naming import plain
from skthermal.utils._runs import check_labels, run_slices
from skthermal.utils._warnings import user_stacklevel

RMSELevels = namedtuple("RMSELevels", ["per_batch", "per_model", "per_method"])
RMSELevels.__doc__ = """The three levels of 004 eq. 16.

per_batch : DataFrame
    Level 1, ``RMSE_{Mi,Bj}``: index (method, model), one column per batch.
per_model : DataFrame
    Level 2, ``RMSE_{Mi}``: index method, one column per model, the mean over
    batches.
per_method : DataFrame
    Level 3, ``RMSE_A``: index method, column ``rmse``, the mean over models.
"""


def _as_vector(a, name, n=None):
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}.")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name} has {a.shape[0]} values, expected {n} (one per row).")
    bad = ~np.isfinite(a)
    if bad.any():
        raise ValueError(
            f"{name} has {int(bad.sum())} NaN or infinite value(s), the first at "
            f"row {int(np.flatnonzero(bad)[0])}."
        )
    return a


def _batch_labels(groups, n):
    """``groups`` as an array of one batch label per row, checked."""
    groups = np.asarray(groups)
    if groups.ndim != 1 or groups.shape[0] != n:
        raise ValueError(
            f"groups must hold one batch label per row ({n}), got shape {groups.shape}."
        )
    check_labels(groups, label="batch", whole="batch")  # missing or mixed kinds
    return groups


def _method_predictions(method, preds, n):
    if isinstance(preds, pd.DataFrame):
        preds = {c: preds[c] for c in preds.columns}
    if not isinstance(preds, Mapping) or not preds:
        raise TypeError(
            f"predictions[{method!r}] must be a non-empty mapping of model label to "
            "predicted values (or a DataFrame with one column per model), got "
            f"{type(preds).__name__}."
        )
    labels = list(preds)
    P = np.stack(
        [_as_vector(preds[m], f"predictions[{method!r}][{m!r}]", n) for m in labels]
    )
    return labels, P


def rmse_levels(y_true, predictions, groups, *, include_self=True):
    """RMSE of every model on every batch, per model and per method.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        Measured thermal error of all batches, stacked.
    predictions : mapping
        ``{method: {model: y_pred}}``, ``y_pred`` of shape (n_samples,): the
        predictions of every model of every method for all rows. A
        DataFrame with one column per model may stand for the inner mapping.
    groups : array-like of shape (n_samples,)
        Batch label of every row.
    include_self : bool, default=True
        Count a model's own batch (a model labelled like a batch) in its
        mean, as 004 does. ``False`` averages over the other batches only.

    Returns
    -------
    RMSELevels
        Named tuple ``(per_batch, per_model, per_method)`` of DataFrames.

    Notes
    -----
    004 eq. 16: ``RMSE_{Mi,Bj} = sqrt(sum_k (e_k - e^_k)^2 / N)``,
    ``RMSE_{Mi} = mean_j RMSE_{Mi,Bj}``, ``RMSE_A = mean_i RMSE_{Mi}``.
    Methods may have different numbers of models; level 2 is then NaN where
    a method has no such model.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.metrics import rmse_levels
    >>> y = np.array([1.0, 1.0, 2.0, 2.0])
    >>> batches = ["B1", "B1", "B2", "B2"]
    >>> preds = {"ridge": {"B1": [1.0, 1.0, 1.0, 1.0], "B2": [2.0, 2.0, 2.0, 2.0]}}
    >>> levels = rmse_levels(y, preds, batches)
    >>> levels.per_batch.index.tolist(), levels.per_batch.to_numpy().tolist()
    ([('ridge', 'B1'), ('ridge', 'B2')], [[0.0, 1.0], [1.0, 0.0]])
    >>> levels.per_model.loc["ridge"].to_dict()
    {'B1': 0.5, 'B2': 0.5}
    >>> levels.per_method["rmse"].to_dict()
    {'ridge': 0.5}
    >>> rmse_levels(y, preds, batches, include_self=False).per_method["rmse"].to_dict()
    {'ridge': 1.0}
    """
    y = _as_vector(y_true, "y_true")
    n = y.shape[0]
    if n == 0:
        raise ValueError("y_true is empty.")
    groups = _batch_labels(groups, n)
    if not isinstance(predictions, Mapping) or not predictions:
        raise TypeError(
            "predictions must be a non-empty mapping {method: {model: y_pred}}, "
            f"got {type(predictions).__name__}."
        )
    batches = pd.unique(groups)
    frames = []
    for method, preds in predictions.items():
        labels, P = _method_predictions(method, preds, n)
        sq = pd.DataFrame(np.square(P - y).T, columns=labels)
        per = np.sqrt(sq.groupby(groups, sort=False).mean()).T
        per.index = pd.MultiIndex.from_product(
            [[method], labels], names=["method", "model"]
        )
        frames.append(per[list(batches)])
    level1 = pd.concat(frames)
    level1.columns.name = "batch"
    masked = level1
    if not include_self:
        models = level1.index.get_level_values("model").to_numpy()
        own = models[:, None] == np.asarray(batches, dtype=object)[None, :]
        if not own.any():
            _no_own_batch(models, batches)
        masked = level1.mask(own)
    level2 = masked.mean(axis=1).unstack("model")
    level2 = level2.reindex(index=list(predictions))
    level2.columns.name = "model"
    level3 = level2.mean(axis=1).to_frame("rmse")
    level3.index.name = "method"
    return RMSELevels(level1, level2, level3)


def _no_own_batch(models, batches):
    """``include_self=False`` with no model labelled like a batch: an error
    when the labels match as text (1 against "1": the key types differ),
    else a warning that nothing is left out."""
    text = {str(plain(b)): plain(b) for b in batches}
    like = [(plain(m), text[str(plain(m))]) for m in models if str(plain(m)) in text]
    if like:
        m, b = like[0]
        raise ValueError(
            f"include_self=False: model {m!r} ({type(m).__name__}) is labelled "
            f"like batch {b!r} ({type(b).__name__}) only as text, so no model's "
            "own batch would be left out. Label the models with the batch "
            "labels themselves."
        )
    warnings.warn(
        f"include_self=False, but no model is labelled like a batch (models "
        f"{list(models[:3])!r}..., batches {list(batches[:3])!r}...): nothing is "
        "left out of the means.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def cross_batch_rmse(estimators, X, y, groups, *, include_self=True):
    """Fit one model per batch with every method and score it on every batch.

    For every method and every batch ``i``, a clone of the estimator is fitted
    on batch ``i`` alone (model ``Mi``) and predicts all rows; the
    predictions go to :func:`rmse_levels`.

    Parameters
    ----------
    estimators : mapping of str to estimator
        The methods, e.g. ``{"stable + ridge": make_pipeline(...)}``.
    X : {array-like, DataFrame} of shape (n_samples, n_features)
        Inputs of all batches, stacked (usually changes since the start of
        each batch).
    y : array-like of shape (n_samples,)
        Thermal error.
    groups : array-like of shape (n_samples,)
        Batch label of every row.
    include_self : bool, default=True
        As in :func:`rmse_levels`.

    Returns
    -------
    RMSELevels

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from skthermal.metrics import cross_batch_rmse
    >>> X = np.arange(8.0)[:, None]
    >>> y = np.r_[2 * X[:4, 0], 3 * X[4:, 0]]
    >>> levels = cross_batch_rmse({"ols": LinearRegression()}, X, y, [1] * 4 + [2] * 4)
    >>> levels.per_batch.round(2).to_numpy().tolist()  # row: model, column: batch
    [[0.0, 5.61], [1.87, 0.0]]
    >>> levels.per_method["rmse"].round(3).to_dict()
    {'ols': 1.871}
    """
    if not isinstance(estimators, Mapping) or not estimators:
        raise TypeError(
            "estimators must be a non-empty mapping {method name: estimator}, got "
            f"{type(estimators).__name__}."
        )
    y = _as_vector(y, "y")
    groups = _batch_labels(groups, y.shape[0])
    # Every batch model is fitted on one contiguous batch (a sequence model
    # would join the pieces of a scattered one).
    run_slices(groups)
    if not hasattr(X, "shape"):  # a list of rows
        X = np.asarray(X)
    if X.ndim != 2:
        raise ValueError(f"X must be 2-D (n_samples, n_features), got shape {X.shape}.")
    if X.shape[0] != y.shape[0]:
        raise ValueError(f"X has {X.shape[0]} rows but y has {y.shape[0]}.")
    take = X.iloc if hasattr(X, "iloc") else np.asarray(X)
    predictions = {}
    for method, est in estimators.items():
        preds = {}
        for batch in pd.unique(groups):
            rows = np.flatnonzero(groups == batch)
            with warnings.catch_warnings():
                # One batch: one run by construction, labels or not.
                warnings.filterwarnings("ignore", message=r".* carry no run labels")
                model = clone(est).fit(take[rows], y[rows])
            preds[batch] = np.asarray(model.predict(X), dtype=float).reshape(-1)
        predictions[method] = preds
    return rmse_levels(y, predictions, groups, include_self=include_self)
