"""Linear thermal-error models: ridge and update regression, and adaptive
compensation of a stream of samples (METHODS §11, 004 §2.2, §3.2, §4.3)."""

from skthermal.linear_model._adaptive import (
    AdaptiveCompensationResult,
    adaptive_compensation,
    make_batch_campaign,
)
from skthermal.linear_model._transfer import (
    TransferFunctionRegressor,
    first_order_lags,
)
from skthermal.linear_model._update import (
    UpdateRegressor,
    first_stable_update,
    ridge_coef,
    update_coef,
    update_is_stable,
    update_path,
)

__all__ = [
    "AdaptiveCompensationResult",
    "TransferFunctionRegressor",
    "UpdateRegressor",
    "adaptive_compensation",
    "first_order_lags",
    "first_stable_update",
    "make_batch_campaign",
    "ridge_coef",
    "update_coef",
    "update_is_stable",
    "update_path",
]
