"""The named models of the papers: ``make_model("anfis-fcm")`` and friends.

The models of the Machine B study (001 §5.3) and of the ``skthermal fit`` and
``skthermal search`` commands, by short name, with the papers' settings; the
named sensor selectors; and :class:`RunStartRegressor`, which fits and
predicts any regressor on changes since the start of each run.
"""

from skthermal.models._registry import (
    MODELS,
    SELECTORS,
    ModelSpec,
    make_model,
    make_selector,
    model_search_space,
    n_rules,
)
from skthermal.models._run_start import RunStartRegressor

__all__ = [
    "MODELS",
    "SELECTORS",
    "ModelSpec",
    "RunStartRegressor",
    "make_model",
    "make_selector",
    "model_search_space",
    "n_rules",
]
