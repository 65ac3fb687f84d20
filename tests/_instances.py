"""One place listing every public estimator with fast constructor arguments.

``tests/test_common.py`` runs scikit-learn's estimator checks over these
instances (the pattern of imbalanced-learn's ``instance_generator.py``). A new
public estimator is added here, with settings that keep the checks quick.
"""

from skthermal import (
    ANFISRegressor,
    FCMClusterPicker,
    GNNMCIRegressor,
    GRASelector,
    GreyInfluenceSelector,
    GreyPSORegressor,
)

INSTANCES = [
    GreyInfluenceSelector(),
    GreyInfluenceSelector(method="gm0n", alpha=1e-3),
    GRASelector(),
    GRASelector(method="absolute"),
    GRASelector(method="deng", normalize="std"),
    # The checks use X with as few as 3 sensors: 2 groups fit.
    FCMClusterPicker(n_clusters=2, n_init=2, random_state=0),
    FCMClusterPicker(n_clusters=2, scorer="pearson", features="scores", random_state=0),
    ANFISRegressor(epochs=5),
    ANFISRegressor(init="grid", mf="gbell", epochs=5),
    ANFISRegressor(learning="backprop", validation_fraction=0.2, epochs=5),
    GreyPSORegressor(n_particles=10, epochs=5, random_state=0),
    GreyPSORegressor(calibration="ls"),
    GreyPSORegressor(n_particles=10, epochs=5, delay=2, init="random", random_state=0),
    GNNMCIRegressor(n_particles=10, epochs=5, random_state=0),
]

_SEQUENCE = (
    "sequence model: a row's prediction depends on the earlier rows of its run "
    "(the grey accumulation restarts at each run), so predicting a subset or a "
    "reordering of the rows of a plain array, which is one run, changes it"
)

# Checks that cannot apply, with the reason, keyed by estimator class name.
EXPECTED_FAILED_CHECKS: dict[str, dict[str, str]] = {
    "GreyPSORegressor": {
        "check_methods_subset_invariance": _SEQUENCE,
        "check_methods_sample_order_invariance": _SEQUENCE,
    },
    "GNNMCIRegressor": {
        "check_methods_subset_invariance": _SEQUENCE,
        "check_methods_sample_order_invariance": _SEQUENCE,
    },
}
