"""scikit-learn's estimator checks over every public skthermal estimator."""

import numpy as np
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
    # A few checks draw from numpy's global generator (e.g. the permutation
    # of check_methods_sample_order_invariance): seeded, a check's outcome
    # does not depend on which tests ran before it in the same worker.
    np.random.seed(0)
    check(estimator)


def test_every_public_estimator_is_checked():
    checked = {type(e).__name__ for e in INSTANCES}
    missing = public_estimator_names() - checked
    assert not missing, f"add {sorted(missing)} to tests/_instances.py"


def _run_table_data():
    from skthermal.datasets import make_sensor_groups, split_runs

    runs, _ = make_sensor_groups(
        n_groups=2,
        sensors_per_group=3,
        n_noise=2,
        n_runs=3,
        n_samples=40,
        random_state=0,
    )
    return split_runs(runs, targets="disp_y_um")[:2]


def _one_per_class():
    seen, out = set(), []
    for est in INSTANCES:
        if type(est).__name__ not in seen:
            seen.add(type(est).__name__)
            out.append(est)
    return out


@pytest.mark.filterwarnings("ignore::UserWarning", "ignore::RuntimeWarning")
@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("estimator", _one_per_class(), ids=lambda e: type(e).__name__)
def test_same_results_under_global_pandas_output(estimator):
    # docs/run_tables.md recommends set_config(transform_output="pandas"):
    # the estimators' inner transformers must not change with it.
    import sklearn
    from sklearn.base import clone

    X, y = _run_table_data()

    def fit_out():
        est = clone(estimator)
        if "random_state" in est.get_params():
            est.set_params(random_state=0)
        est.fit(X, y)
        out = est.predict(X) if hasattr(est, "predict") else est.transform(X)
        return np.asarray(out, dtype=float)

    ref = fit_out()
    with sklearn.config_context(transform_output="pandas"):
        got = fit_out()
    np.testing.assert_allclose(got, ref)
