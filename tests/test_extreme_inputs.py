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


def _run_table():
    import pandas as pd

    rng = np.random.RandomState(0)
    X = pd.DataFrame(rng.normal(20, 1, (40, 3)), columns=["T1", "T2", "T3"])
    X["run"] = np.repeat(["a", "b"], 20)
    X["time_s"] = np.tile(np.arange(20) * 60.0, 2)
    y = pd.Series(X["T1"] * 2 + rng.normal(0, 0.1, 40), name="disp_z_um")
    return X, y


def test_integer_column_and_target_names_are_shown_plainly():
    # Integer column names printed as np.int64(20) and np.int64(5).
    import pandas as pd

    from skthermal import UpdateRegressor

    X, y = _run_table()
    A = pd.DataFrame(X[["T1", "T2", "T3"]].to_numpy(), columns=pd.Index([10, 20, 30]))
    A.loc[3, 20] = 1e101
    with pytest.raises(ValueError) as info:
        UpdateRegressor().fit(A, y.to_numpy())
    assert str(info.value).startswith("Column 20 is 1e+101")
    Y = pd.DataFrame({5: y.to_numpy()})
    Y.iloc[3, 0] = 1e101
    with pytest.raises(ValueError) as info:
        UpdateRegressor().fit(X, Y)
    assert str(info.value).startswith("The target 5 is 1e+101")
    B = X.astype({"T2": object})
    B.columns = [10, 20, 30, "run", "time_s"]
    B[20] = B[20].astype(str)
    B.loc[3, 20] = "hot"
    with pytest.raises(ValueError) as info:
        UpdateRegressor().fit(B.astype({10: np.int64}), y)
    assert "Column 20 is not numeric" in str(info.value)
    assert "np." not in str(info.value)


def test_an_integer_beyond_a_float_names_x_or_y_and_the_row():
    # 10**400 in an object array or a list raised numpy's bare
    # "OverflowError: int too large to convert to float".
    from skthermal import GRASelector, UpdateRegressor

    X, y = _run_table()
    A = X[["T1", "T2", "T3"]].to_numpy().astype(object)
    A[3, 1] = 10**400
    too_large = "too large for a float"
    for fit in (UpdateRegressor().fit, GRASelector().fit):
        with pytest.raises(
            ValueError, match=rf"^Column 1 of X holds .* at row 3: {too_large}"
        ):
            fit(A, y.to_numpy())
        with pytest.raises(
            ValueError, match=rf"^Column 1 of X holds .* at row 3: {too_large}"
        ):
            fit(A.tolist(), y.to_numpy())
    B = X.astype({"T2": object})
    B.loc[3, "T2"] = 10**400
    with pytest.raises(
        ValueError,
        match=rf"^Column 'T2' of X holds .* at row 3, run 'a', time_s=180: {too_large}",
    ):
        UpdateRegressor().fit(B, y)
    Y = y.to_numpy().astype(object)
    Y[3] = 10**400
    for target in (Y, list(Y)):
        with pytest.raises(
            ValueError, match=rf"^y holds .*401 digits.* at row 3: {too_large}"
        ):
            UpdateRegressor().fit(X[["T1", "T2", "T3"]].to_numpy(), target)
    with pytest.raises(
        ValueError, match=rf"^y holds .* at row 3, run 'a', time_s=180: {too_large}"
    ):
        UpdateRegressor().fit(X, Y)


def test_a_value_just_beyond_the_bound_is_not_shown_as_the_bound():
    # describe_unreadable printed 1e100's next float as "1e+100, beyond the
    # largest magnitude a reading may have (1e+100)".
    from skthermal.utils._runs import describe_unreadable

    value = np.nextafter(1e100, np.inf)
    assert describe_unreadable(value).startswith("1.0000000000000002e+100, beyond")
    assert describe_unreadable(1e307).startswith("1e+307, beyond")
    assert describe_unreadable(np.nan) == "missing (NaN)"


def test_the_missing_reading_advice_says_what_hold_also_holds():
    # The advice to bridge dropouts with GuardedRegressor(mode='hold') led an
    # independent check into a frozen compensation: 'hold' also holds while a
    # reading is beyond its training range by more than span (29% of the
    # held-out rows of a chronological split).
    import pandas as pd

    from skthermal.preprocessing import make_lag_pipeline

    t = np.arange(50) * 60.0
    X = pd.DataFrame(
        {"run": "a", "time_s": t, "T1_C": 20 + t / 1000, "spindle_rpm": 1e3}
    )
    X = X.set_index(["run", "time_s"])
    X.iloc[5, 0] = np.nan
    with pytest.raises(ValueError, match=r"mode='hold'\) bridges .* span=0.25"):
        make_lag_pipeline().fit(X, np.arange(50.0))
