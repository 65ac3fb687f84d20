"""scikit-learn's estimator checks over every public skthermal estimator."""

import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

from tests._instances import INSTANCES, expected_failed_checks, public_estimator_names


# scikit-learn's checks feed plain arrays by design: the sequence models'
# warnings that such rows are taken as one run, and that a plain array has
# no time_s, are the expected use there, not a finding.
@pytest.mark.filterwarnings(
    "ignore:.*carry no run labels:UserWarning",
    "ignore:.*has no time_s.*and no dt was given:UserWarning",
)
@parametrize_with_checks(INSTANCES, expected_failed_checks=expected_failed_checks)
def test_sklearn_compatible_estimator(estimator, check):
    check(estimator)


def test_every_public_estimator_is_checked():
    checked = {type(e).__name__ for e in INSTANCES}
    missing = public_estimator_names() - checked
    assert not missing, f"add {sorted(missing)} to tests/_instances.py"
