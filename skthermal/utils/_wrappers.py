"""What a wrapper of one model (``owner.estimator``) takes from it: its
tags, and the metadata scikit-learn's routing passes to it."""

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


def routed_params(owner, method, params):
    """The keyword arguments of the wrapped model's ``method``: under metadata
    routing what it requested of ``params``, else ``params`` as given."""
    if not routing_enabled():
        return dict(params)
    return dict(getattr(process_routing(owner, method, **params).estimator, method))


def wrapper_router(owner, methods):
    """The metadata router of a wrapper ``owner`` of ``owner.estimator``: its
    own requests (``groups``) and the wrapped model's, each of ``methods``
    routed to the same method. A Pipeline, ``cross_validate`` or a search
    then passes on what the wrapped model requested (``sample_weight``)."""
    mapping = MethodMapping()
    for method in methods:
        mapping.add(caller=method, callee=method)
    return (
        MetadataRouter(owner=owner)
        .add_self_request(owner)
        .add(estimator=owner.estimator, method_mapping=mapping)
    )


def wrapped_tags(tags, estimator):
    """``tags`` of a wrapper with the target kinds and determinism of the
    wrapped ``estimator``; returns the wrapped model's tags."""
    inner = get_tags(estimator)
    tags.target_tags.multi_output = inner.target_tags.multi_output
    tags.target_tags.single_output = inner.target_tags.single_output
    tags.non_deterministic = inner.non_deterministic
    return inner
