"""scikit-learn's estimator checks over every public skthermal estimator."""

from sklearn.utils.estimator_checks import parametrize_with_checks

from tests._instances import EXPECTED_FAILED_CHECKS, INSTANCES


def _expected_failed_checks(estimator):
    return EXPECTED_FAILED_CHECKS.get(type(estimator).__name__, {})


@parametrize_with_checks(INSTANCES, expected_failed_checks=_expected_failed_checks)
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)
