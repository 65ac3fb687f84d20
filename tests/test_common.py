"""scikit-learn's estimator checks over every public skthermal estimator."""

from sklearn.utils.estimator_checks import parametrize_with_checks

from tests._instances import INSTANCES, expected_failed_checks


@parametrize_with_checks(INSTANCES, expected_failed_checks=expected_failed_checks)
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)


def test_every_public_estimator_is_checked():
    from sklearn.base import BaseEstimator

    import skthermal

    public = {
        name
        for name in skthermal.__all__
        if isinstance(getattr(skthermal, name), type)
        and issubclass(getattr(skthermal, name), BaseEstimator)
    }
    checked = {type(e).__name__ for e in INSTANCES}
    assert public <= checked, f"add {sorted(public - checked)} to tests/_instances.py"
