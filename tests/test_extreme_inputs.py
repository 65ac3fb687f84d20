"""Readings of an absurd but finite magnitude (a broken sensor, a corrupt
file): every estimator refuses them with an error naming the column and the
row, or gives finite output; never inf, NaN or a numpy overflow warning."""

import warnings

import numpy as np
import pytest
from sklearn.base import clone

from skthermal.compose import GuardedRegressor
from skthermal.datasets import make_sensor_groups, split_runs
from skthermal.utils._runs import MAX_MAGNITUDE, unreadable
from tests._instances import INSTANCES

# Every estimator is fitted on plain arrays too: the warning that such rows
# are taken as one run is the expected use here.
pytestmark = pytest.mark.filterwarnings("ignore:.*carry no run labels:UserWarning")

ROW, COLUMN = 100, 0  # row 100 is in the second run


@pytest.fixture(scope="module")
def data():
    df, _ = make_sensor_groups(
        n_groups=2,
        sensors_per_group=2,
        n_noise=1,
        n_runs=3,
        n_samples=60,
        random_state=0,
    )
    return split_runs(df)


def _with_reading(X, value, as_array):
    X = X.copy()
    X.iloc[ROW, COLUMN] = value
    return X.to_numpy() if as_array else X


def _output(est, X):
    method = est.predict if hasattr(est, "predict") else est.transform
    return np.asarray(method(X), dtype=float)


def _check(call, as_array, column):
    """``call()`` raises a ValueError naming the column and the row, or
    returns finite output; no RuntimeWarning (numpy overflow) either way."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            out = call()
        except ValueError as exc:
            message = str(exc)
            names = (
                [f"Column {COLUMN} of X", f"feature {COLUMN}", f"'x{COLUMN}'"]
                if as_array
                else [f"Column {column!r}", f"sensor {column!r}", repr(column)]
            )
            assert any(name in message for name in names), message
            # The row, or its run and time (GuardedRegressor).
            where = [f"row {ROW}", "run 'run2' at time_s=2400"]
            assert any(w in message for w in where), message
            assert "1e+307" in message, message
            return
    assert np.all(np.isfinite(out))


def _ids(est):
    return repr(est)[:60]


@pytest.mark.parametrize("as_array", [False, True], ids=["frame", "array"])
@pytest.mark.parametrize("estimator", INSTANCES, ids=_ids)
def test_extreme_reading_at_predict(estimator, as_array, data):
    X, y, _ = data
    est = clone(estimator).fit(X.to_numpy() if as_array else X, y)
    X_bad = _with_reading(X, 1e307, as_array)
    _check(lambda: _output(est, X_bad), as_array, X.columns[COLUMN])


@pytest.mark.parametrize("as_array", [False, True], ids=["frame", "array"])
@pytest.mark.parametrize("estimator", INSTANCES, ids=_ids)
def test_extreme_reading_at_fit(estimator, as_array, data):
    X, y, _ = data
    est = clone(estimator)
    X_bad = _with_reading(X, 1e307, as_array)
    _check(lambda: _output(est.fit(X_bad, y), X_bad), as_array, X.columns[COLUMN])


def test_frame_error_names_column_row_run_and_time(data):
    X, y, _ = data
    model = clone(INSTANCES[-3]).fit(X, y)  # RunStartRegressor(LinearRegression())
    with pytest.raises(
        ValueError,
        match=r"Column 'T01_C' is 1e\+307, beyond the largest magnitude a reading "
        r"may have \(1e\+100\) at row 100, run 'run2', time_s=2400 "
        r"\(1 value\(s\) in X beyond 1e\+100 in magnitude\)",
    ):
        model.predict(_with_reading(X, 1e307, as_array=False))


def test_extreme_target_is_refused(data):
    X, y, _ = data
    y = y.copy()
    y.iloc[ROW] = -1e200
    with pytest.raises(ValueError, match=r"target 'disp_y_um' is -1e\+200.*row 100"):
        clone(INSTANCES[-3]).fit(X, y)


@pytest.mark.parametrize("value", [1e100, -1e100, 1e6])
def test_readings_up_to_the_bound_are_accepted(value, data):
    X, y, _ = data
    for est in (INSTANCES[-3], INSTANCES[11], INSTANCES[15]):
        model = clone(est).fit(X, y)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            out = model.predict(_with_reading(X, value, as_array=False))
        assert np.all(np.isfinite(out))


def test_unreadable():
    values = np.array([0.0, -MAX_MAGNITUDE, MAX_MAGNITUDE, 1.01e100, -1e307, np.nan])
    assert unreadable(values).tolist() == [False, False, False, True, True, True]
    assert unreadable([np.inf, -np.inf]).all()


def test_hold_mode_holds_an_extreme_reading(data):
    X, y, _ = data
    model = GuardedRegressor(clone(INSTANCES[11]), mode="hold").fit(X, y)
    good = model.predict(X)
    with pytest.warns(UserWarning):
        held = model.predict(_with_reading(X, 1e307, as_array=False))
    assert np.all(np.isfinite(held))
    assert held[ROW] == good[ROW - 1]
