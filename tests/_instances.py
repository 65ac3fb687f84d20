"""One place listing every public estimator with fast constructor arguments.

``tests/test_common.py`` runs scikit-learn's estimator checks over these
instances (the pattern of imbalanced-learn's ``instance_generator.py``). A new
public estimator is added here, with settings that keep the checks quick.
"""

from skthermal import FCMClusterPicker, GRASelector, GreyInfluenceSelector

INSTANCES = [
    GreyInfluenceSelector(),
    GreyInfluenceSelector(method="gm0n", alpha=1e-3),
    GRASelector(),
    GRASelector(method="absolute"),
    GRASelector(method="deng", normalize="std"),
    # The checks use X with as few as 3 sensors: 2 groups fit.
    FCMClusterPicker(n_clusters=2, n_init=2, random_state=0),
    FCMClusterPicker(n_clusters=2, scorer="pearson", features="scores", random_state=0),
]

# Checks that cannot apply, with the reason, keyed by estimator class name.
# Every entry must say why; none is needed today.
EXPECTED_FAILED_CHECKS: dict[str, dict[str, str]] = {}
