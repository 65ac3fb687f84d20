"""One place listing every public estimator with fast constructor arguments.

``tests/test_common.py`` runs scikit-learn's estimator checks over these
instances (the pattern of imbalanced-learn's ``instance_generator.py``). A new
public estimator is added here, with settings that keep the checks quick.
"""

from sklearn.linear_model import LinearRegression, Ridge

from skthermal import (
    ANFISRegressor,
    FCMClusterPicker,
    FuzzyEquivalenceSelector,
    GNNMCIRegressor,
    GRASelector,
    GreyInfluenceSelector,
    GreyPSORegressor,
    LagFeatures,
    LagRidgeCV,
    ModularRegressor,
    StableTSPSelector,
    TransferFunctionRegressor,
    UpdateRegressor,
)
from skthermal.compose import GuardedRegressor
from skthermal.models import RunStartRegressor

INSTANCES = [
    GreyInfluenceSelector(),
    GreyInfluenceSelector(method="gm0n", alpha=1e-3),
    GRASelector(),
    GRASelector(method="absolute"),
    GRASelector(method="deng", normalize="std"),
    # The checks use X with as few as 3 sensors: 2 groups fit.
    FCMClusterPicker(n_clusters=2, n_init=2, random_state=0),
    FCMClusterPicker(n_clusters=2, scorer="pearson", features="scores", random_state=0),
    StableTSPSelector(),
    StableTSPSelector(
        n_features_to_select=None, threshold="median", temperature_uncertainty=0.1
    ),
    FuzzyEquivalenceSelector(),
    FuzzyEquivalenceSelector(n_groups=2),
    ANFISRegressor(epochs=5),
    ANFISRegressor(init="grid", mf="gbell", epochs=5, penalize_intercepts=False),
    ANFISRegressor(learning="backprop", validation_fraction=0.2, epochs=5),
    ANFISRegressor(grey=True, epochs=5),
    GreyPSORegressor(n_particles=10, epochs=5, random_state=0),
    GreyPSORegressor(calibration="ls"),
    GreyPSORegressor(
        calibration="pso",
        n_particles=10,
        epochs=5,
        delay=2,
        init="random",
        random_state=0,
    ),
    GreyPSORegressor(
        calibration="pso", alpha=0.0, n_particles=10, epochs=5, random_state=0
    ),
    GNNMCIRegressor(n_particles=10, epochs=5, random_state=0),
    GNNMCIRegressor(alpha=0.0, init="random", n_particles=10, epochs=5, random_state=0),
    UpdateRegressor(),
    UpdateRegressor(alpha=0.0, eta=0.5, penalize_intercept=False),
    ModularRegressor(relative=False),
    ModularRegressor(
        [("a", LinearRegression(), [0]), ("b", Ridge(), None)], relative=False
    ),
    ModularRegressor(),
    GuardedRegressor(LinearRegression()),
    GuardedRegressor(Ridge(), mode="clip", flat=3, jump=2.0),
    GuardedRegressor(LinearRegression(), mode="hold"),
    GuardedRegressor(ANFISRegressor(epochs=5, random_state=0), jump=None, flat=None),
    GuardedRegressor(UpdateRegressor()),  # with partial_fit
    GuardedRegressor(
        LagRidgeCV(time_constant_sets=[(2.0, 5.0)], alphas=[1.0], dt=1.0),
        jump=None,
        flat=None,
    ),
    TransferFunctionRegressor(n_grid=3, max_iter=2),
    TransferFunctionRegressor(order=2, alpha=1.0, n_grid=3, max_iter=0),
    LagFeatures(time_constants=(2.0, 5.0), dt=1.0),
    # One set with lags: CV cannot pick the static model, so the sequence
    # behaviour the checks below expect to fail is always there.
    LagRidgeCV(time_constant_sets=[(2.0, 5.0)], alphas=[0.1, 10.0], dt=1.0),
    RunStartRegressor(LinearRegression()),
    RunStartRegressor(LinearRegression(), drivers=[0]),
    RunStartRegressor(ANFISRegressor(epochs=5, random_state=0)),
]

_SEQUENCE = (
    "sequence model: a row's prediction depends on the earlier rows of its run "
    "(the grey accumulation or the lag filters restart at each run), so "
    "predicting a subset or a reordering of the rows of a plain array, which is "
    "one run, changes it"
)
_RELATIVE = (
    "the model predicts the change since the start of the run "
    "(a plain array is one run), so a subset or reordering changes the first row "
    "and the score against absolute targets does not apply"
)


def _is_sequence_model(estimator):
    """Whether a row's prediction depends on the earlier rows of its run."""
    name = type(estimator).__name__
    if name == "GuardedRegressor":
        return _is_sequence_model(estimator.estimator)
    if name == "ANFISRegressor":
        return estimator.grey
    return name in (
        "GreyPSORegressor",
        "GNNMCIRegressor",
        "TransferFunctionRegressor",
        "LagFeatures",
        "LagRidgeCV",
    )


def expected_failed_checks(estimator):
    """Checks that cannot apply to this instance, with the reason."""
    name = type(estimator).__name__
    if name == "GuardedRegressor" and estimator.mode == "hold":
        return {
            "check_estimators_nan_inf": (
                "mode='hold' treats a NaN or infinite reading as a sensor fault "
                "and holds the last good compensation instead of raising"
            )
        }
    if _is_sequence_model(estimator):
        return {
            "check_methods_subset_invariance": _SEQUENCE,
            "check_methods_sample_order_invariance": _SEQUENCE,
        }
    if name == "RunStartRegressor" or (
        name == "ModularRegressor" and estimator.relative
    ):
        return {
            "check_regressors_train": _RELATIVE,
            "check_methods_subset_invariance": _RELATIVE,
            "check_methods_sample_order_invariance": _RELATIVE,
        }
    return {}


def public_estimator_names():
    """Names of the estimator classes ``skthermal`` exports."""
    from sklearn.base import BaseEstimator

    import skthermal

    return {
        name
        for name in skthermal.__all__
        if isinstance(getattr(skthermal, name), type)
        and issubclass(getattr(skthermal, name), BaseEstimator)
    }
