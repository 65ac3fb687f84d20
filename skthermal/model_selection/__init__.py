"""Model selection: Optuna searches of model structure, scored by
cross-validation over whole runs, with search spaces of the skthermal
estimators and storages for searches spread over processes and machines.

Optuna is optional (``pip install "skthermal[optuna]"``); it is imported when
a search or storage is made.
"""

from skthermal.model_selection._search import (
    SearchResult,
    fail_stale_trials,
    make_storage,
    run_search,
)
from skthermal.model_selection._spaces import (
    SearchSpace,
    combine_spaces,
    search_space,
    search_space_names,
)

__all__ = [
    "SearchResult",
    "SearchSpace",
    "combine_spaces",
    "fail_stale_trials",
    "make_storage",
    "run_search",
    "search_space",
    "search_space_names",
]
