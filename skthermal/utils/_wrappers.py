"""What a wrapper of models (``owner.estimator``, or the named modules of a
composition) takes from them: their tags, and the metadata scikit-learn's
routing passes to them."""

import sklearn
from sklearn.utils import get_tags
from sklearn.utils.metadata_routing import (
    MetadataRouter,
    MethodMapping,
    process_routing,
)


def routing_enabled():
    """Whether scikit-learn's metadata routing is on
    (``sklearn.set_config(enable_metadata_routing=True)``)."""
    return bool(sklearn.get_config().get("enable_metadata_routing", False))


def transform_output(step):
    """The output container of ``step``'s ``transform`` (``"pandas"``,
    ``"default"``, ...): its own ``set_output``
    (:func:`own_transform_output`), else scikit-learn's global
    ``transform_output``. None for a step that transforms nothing."""
    if not (hasattr(step, "set_output") and hasattr(step, "transform")):
        return None
    own = own_transform_output(step)
    if own is None:
        return sklearn.get_config().get("transform_output", "default")
    return own


def own_transform_output(step):
    """``step``'s own ``set_output(transform=...)``, which is saved with it
    (the global setting is not), or None."""
    # scikit-learn keeps an estimator's own set_output in this attribute.
    return getattr(step, "_sklearn_output_config", {}).get("transform")


def routed_params(owner, method, params):
    """The keyword arguments of the wrapped model's ``method``: under metadata
    routing what it requested of ``params``, else ``params`` as given."""
    return routed_by_name(owner, method, params, ["estimator"])["estimator"]


def routed_by_name(owner, method, params, names):
    """``{name: keyword arguments of that wrapped model's method}`` for the
    wrapped models ``names`` of ``owner`` (see :func:`wrapper_router`): under
    metadata routing what each requested of ``params``, else ``params`` as
    given to every one."""
    if not routing_enabled():
        return {name: dict(params) for name in names}
    bunch = process_routing(owner, method, **params)
    return {name: dict(getattr(bunch[name], method)) for name in names}


def wrapper_router(owner, methods, children=None):
    """The metadata router of a wrapper ``owner``: its own requests
    (``groups``) and those of the wrapped models (``children``, ``{name:
    estimator}``; default ``owner.estimator`` as ``"estimator"``), each of
    ``methods`` routed to the same method. A Pipeline, ``cross_validate`` or
    a search then passes on what a wrapped model requested
    (``sample_weight``)."""
    if children is None:
        children = {"estimator": owner.estimator}
    router = MetadataRouter(owner=owner).add_self_request(owner)
    for name, estimator in children.items():
        mapping = MethodMapping()
        for method in methods:
            mapping.add(caller=method, callee=method)
        router.add(**{name: estimator}, method_mapping=mapping)
    return router


def wrapped_tags(tags, estimator):
    """``tags`` of a wrapper with the target kinds and determinism of the
    wrapped ``estimator``; returns the wrapped model's tags."""
    inner = get_tags(estimator)
    tags.target_tags.multi_output = inner.target_tags.multi_output
    tags.target_tags.single_output = inner.target_tags.single_output
    tags.non_deterministic = inner.non_deterministic
    return inner
