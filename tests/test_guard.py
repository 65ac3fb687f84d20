"""Tests of the deployment guard (skthermal.compose.GuardedRegressor)."""

import subprocess
import sys
import warnings

import joblib
import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.compose import ColumnTransformer
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.model_selection import GridSearchCV, GroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import InvalidParameterError

from skthermal.compose import (
    GuardedRegressor,
    GuardWarning,
    PredictionRangeWarning,
    SensorFaultWarning,
    SensorRangeWarning,
)
from skthermal.compose._guard import RunStartWarning
from skthermal.fuzzy import ANFISRegressor
from skthermal.grey import GreyPSORegressor
from skthermal.preprocessing import LagFeatures

SENSORS = ["T1_C", "T2_C", "T3_C", "T4_C"]
GAINS = np.array([4.0, 2.5, 1.0, 0.5])  # temperature rise per unit of heat
COEF = np.array([3.0, -1.0, 2.0, 0.5])  # displacement per degree


def make_runs(amplitudes, *, seed=0, n=120, period=30.0):
    """A run table: heating runs of 4 noisy sensors and a linear displacement."""
    rng = np.random.default_rng(seed)
    frames = []
    for r, amp in enumerate(amplitudes):
        t = np.arange(n) * period
        heat = amp * (1.0 - np.exp(-t / 1200.0))
        T = 20.0 + heat[:, None] * GAINS + rng.normal(0, 0.02, (n, 4))
        index = pd.MultiIndex.from_arrays(
            [np.full(n, f"r{r}"), t], names=["run", "time_s"]
        )
        frame = pd.DataFrame(T, index=index, columns=SENSORS)
        frame["disp_y_um"] = (T - 20.0) @ COEF + rng.normal(0, 0.05, n)
        frames.append(frame)
    data = pd.concat(frames)
    return data[SENSORS], data["disp_y_um"]


@pytest.fixture(scope="module")
def train():
    return make_runs([1.0, 2.0, 3.0], seed=0)


@pytest.fixture(scope="module")
def new_run():
    """A run inside the training conditions, different noise."""
    return make_runs([2.5], seed=1)


def _caught(fn, *args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kwargs)
    return out, caught


def _messages(caught, category):
    return [str(w.message) for w in caught if issubclass(w.category, category)]


@pytest.mark.parametrize("column", ["run", "time_s"])
def test_a_run_column_beside_the_run_index_is_taken_once(train, column):
    # X indexed by (run, time_s) with the level joined back as a column:
    # pandas' "The name run occurs multiple times" from inside the guard,
    # while every other estimator took the column.
    X, y = train
    plain = GuardedRegressor(LinearRegression()).fit(X, y)
    both = X.assign(**{column: X.index.get_level_values(column)})
    guard = GuardedRegressor(LinearRegression()).fit(both, y)
    np.testing.assert_allclose(guard.predict(both), plain.predict(X))


# --- no false alarms --------------------------------------------------------


def test_in_range_data_gives_no_warning_and_unchanged_predictions(train, new_run):
    X, y = train
    X_new, _ = new_run
    for mode in ("warn", "clip", "hold"):
        guard = GuardedRegressor(LinearRegression(), mode=mode).fit(X, y)
        checked, caught = _caught(guard.predict_checked, X_new)
        assert not [w for w in caught if issubclass(w.category, GuardWarning)]
        plain = LinearRegression().fit(X, y).predict(X_new)
        np.testing.assert_allclose(checked["prediction"], plain)
        assert checked["ok"].all()
        assert (checked["reason"] == "").all() and (checked["action"] == "").all()
        assert checked.index.equals(X_new.index)


def test_no_false_alarm_on_held_out_part_of_machine_b():
    from skthermal.datasets import make_machine_b_tests, split_runs

    runs = make_machine_b_tests(["I", "II", "III"], random_state=0)
    X, y, groups = split_runs(runs, targets="disp_y_um")
    position = X.groupby(level="run", sort=False).cumcount().to_numpy()
    held = (position // 20) % 5 == 2  # every fifth block of 20 samples
    guard = GuardedRegressor(Ridge()).fit(X[~held], y[~held])
    blocks = [f"{r}/{b}" for r, b in zip(groups[held], position[held] // 20)]
    checked, caught = _caught(guard.predict_checked, X[held], groups=blocks)
    assert not [str(w.message) for w in caught if issubclass(w.category, GuardWarning)]
    assert checked["ok"].all() and held.sum() == len(checked) > 100


# --- a broken sensor spike --------------------------------------------------


@pytest.fixture(scope="module")
def spiked(new_run):
    X_new, _ = new_run
    X_bad = X_new.copy()
    X_bad.iloc[60, 1] = 1e6  # T2_C breaks at time_s=1800 of run r0
    return X_bad


def test_spike_warns_naming_sensor_run_and_time(train, spiked):
    X, y = train
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    pred, caught = _caught(guard.predict, spiked)
    (msg,) = _messages(caught, SensorRangeWarning)
    assert "'T2_C' in run 'r0' at time_s=1800" in msg
    assert "1e+06" in msg and "1 of 4" in msg
    # clip and hold are the remedy for a faulty sensor, not for a machine or
    # room truly beyond the training range (an independent check: a colder
    # room clipped or held erred 1.2 and 2.2 times as much as warned).
    assert "A faulty sensor (stuck, jumping or cut): mode='clip' or 'hold'" in msg
    assert "clipping or holding errs too; refit on runs that cover it." in msg
    (jump,) = [m for m in _messages(caught, SensorFaultWarning) if "jump" in m]
    # The step back to normal is judged from the last good reading, not
    # from the spike (out of range): the spike's row alone.
    assert "'T2_C' in run 'r0' at time_s=1800" in jump and "1 row)" in jump
    assert _messages(caught, PredictionRangeWarning)
    # warn mode never changes the predictions
    np.testing.assert_array_equal(pred, guard.estimator_.predict(spiked))
    assert abs(pred[60]) > 1e5


def test_a_flat_run_table_names_the_time_too(train, spiked):
    # The run table as stored (run and time_s columns, which the wrapped
    # model gets as given: one of skthermal's, which reads them) is named
    # alike.
    from skthermal.linear_model import UpdateRegressor

    X, y = train
    guard = GuardedRegressor(UpdateRegressor()).fit(X.reset_index(), y)
    _, caught = _caught(guard.predict, spiked.reset_index())
    (msg,) = _messages(caught, SensorRangeWarning)
    assert "'T2_C' in run 'r0' at time_s=1800" in msg


def test_runs_in_the_index_and_times_in_a_column(train, new_run):
    # The wrapped model got the times moved into the index in place of the
    # runs (every run's times then one sequence: "time_s must increase
    # strictly") where the same model alone read both.
    from skthermal.preprocessing import make_lag_pipeline

    X, y = train
    mixed = X.reset_index("time_s")
    mixed_new = new_run[0].reset_index("time_s")
    assert list(mixed.index.names) == ["run"] and "time_s" in mixed.columns
    guard = GuardedRegressor(make_lag_pipeline(drivers=None)).fit(mixed, y)
    alone = make_lag_pipeline(drivers=None).fit(mixed, y)
    np.testing.assert_allclose(
        guard.predict(mixed_new), alone.predict(mixed_new), rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        guard.predict(mixed_new), guard.predict(new_run[0]), rtol=0, atol=1e-9
    )


@pytest.mark.parametrize("mode", ["clip", "hold"])
def test_spike_is_bounded_in_safe_mode(train, spiked, mode):
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode=mode).fit(X, y)
    checked, caught = _caught(guard.predict_checked, spiked)
    pred = checked["prediction"].to_numpy()
    low = y.min() - 0.25 * (y.max() - y.min())
    high = y.max() + 0.25 * (y.max() - y.min())
    assert np.isfinite(pred).all()
    assert (pred >= low - 1e-9).all() and (pred <= high + 1e-9).all()
    assert not checked["ok"].iloc[60]
    assert checked["reason"].iloc[60] == "out of range: T2_C; jump: T2_C"
    assert checked["ok"].drop(checked.index[60]).all()
    if mode == "hold":
        assert checked["action"].iloc[60] == "held"
        assert pred[60] == pred[59]
        # the rows after the fault are predicted from the sensor again, the
        # first one too: its step is judged from the last good reading
        good = guard.estimator_.predict(spiked.iloc[61:])
        np.testing.assert_allclose(pred[61:], good)
    else:
        assert checked["action"].iloc[60] == "clipped"
    assert _messages(caught, SensorRangeWarning)


def test_every_sensor_at_1e6(train, new_run):
    X, y = train
    X_bad = new_run[0].copy()
    X_bad.iloc[50:] = 1e6
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    _, caught = _caught(guard.predict, X_bad)
    (msg,) = _messages(caught, SensorRangeWarning)
    assert "4 of 4" in msg and "at time_s=1500" in msg
    for name in SENSORS:
        assert f"'{name}' in run 'r0' at time_s=1500" in msg
    for mode in ("clip", "hold"):
        guard.set_params(mode=mode)
        checked, _ = _caught(guard.predict_checked, X_bad)
        pred = checked["prediction"].to_numpy()
        assert np.isfinite(pred).all()
        low, high = y.min() - 0.25 * np.ptp(y), y.max() + 0.25 * np.ptp(y)
        assert (pred >= low - 1e-9).all() and (pred <= high + 1e-9).all()
        assert not checked["ok"].iloc[50:].any() and checked["ok"].iloc[:50].all()
        if mode == "hold":
            assert (pred[50:] == pred[49]).all()


@pytest.mark.parametrize(
    "inner",
    [ANFISRegressor(n_clusters=2, epochs=5, random_state=0), GreyPSORegressor()],
    ids=["anfis", "grey"],
)
def test_nonlinear_and_sequence_models_are_bounded(train, spiked, inner):
    X, y = train
    guard = GuardedRegressor(inner, mode="clip").fit(X, y)
    X_bad = spiked.copy()
    X_bad.iloc[80:] = 1e6
    raw = guard.estimator_.predict(X_bad)
    pred, caught = _caught(guard.predict, X_bad)
    assert np.abs(raw).max() > 10 * np.abs(y).max()  # unguarded: absurd
    low, high = y.min() - 0.25 * np.ptp(y), y.max() + 0.25 * np.ptp(y)
    assert np.isfinite(pred).all() and (pred >= low).all() and (pred <= high).all()
    assert "4 of 4" in _messages(caught, SensorRangeWarning)[0]


# --- a stuck sensor ---------------------------------------------------------


def test_stuck_sensor_is_flagged_after_the_window(train, new_run):
    X, y = train
    X_bad = new_run[0].copy()
    X_bad.iloc[40:, 2] = X_bad.iloc[40, 2]  # T3_C stuck from time_s=1200
    guard = GuardedRegressor(LinearRegression(), flat=20).fit(X, y)
    checked, caught = _caught(guard.predict_checked, X_bad)
    (msg,) = _messages(caught, SensorFaultWarning)
    # 20 equal readings, rows 40..59: flagged from row 59 (time_s=1770)
    assert "flat-lined" in msg and "'T3_C' in run 'r0' at time_s=1770" in msg
    assert not _messages(caught, SensorRangeWarning)
    flagged = ~checked["ok"].to_numpy()
    assert not flagged[:59].any() and flagged[59:].all()
    assert (checked["reason"].iloc[59:] == "flat-line: T3_C").all()


def test_flat_auto_uses_training_stretches(train):
    X, y = train
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    assert (guard.input_max_unchanged_ == 1).all()  # noisy: never repeats
    X_bad = X.iloc[:120].copy()
    X_bad.iloc[30:, 0] = X_bad.iloc[30, 0]
    checked, caught = _caught(guard.predict_checked, X_bad)
    # auto window: max(3 * 1, 10) = 10 equal readings -> flagged from row 39
    flagged = checked["reason"].str.contains("flat-line: T1_C").to_numpy()
    assert not flagged[:39].any() and flagged[39:].all()
    # a sensor constant in training is never "flat-lined"
    X_const = X.assign(T4_C=21.0)
    guard = GuardedRegressor(LinearRegression()).fit(X_const, y)
    _, caught = _caught(guard.predict, X_const)
    assert not [w for w in caught if issubclass(w.category, GuardWarning)]


# --- logging gaps and other sampling periods ---------------------------------


def _resampled(X, keep):
    """``X`` with only the rows ``keep`` (a boolean mask) of its runs."""
    return X[np.asarray(keep)]


def test_a_logging_gap_in_training_does_not_widen_the_jump_limit(train, new_run):
    # The step across one 30-min gap of one training run became the sensor's
    # largest step: spikes up to 1-2 °C then passed as ok.
    X, y = train
    t = X.index.get_level_values("time_s").to_numpy()
    run = X.index.get_level_values("run").to_numpy()
    gap = (run == "r1") & (t > 1200) & (t <= 3000)  # 30 min of r1 not logged
    clean = GuardedRegressor(LinearRegression()).fit(X, y)
    gapped = GuardedRegressor(LinearRegression()).fit(X[~gap], y[~gap])
    assert gapped.sample_period_ == 30.0
    np.testing.assert_allclose(gapped.input_max_step_, clean.input_max_step_, rtol=0.5)
    X_new = new_run[0].copy()
    X_new.iloc[60, 2] += 8 * clean.input_max_step_[2]  # a spike of T3_C
    for guard in (clean, gapped):
        checked, _ = _caught(guard.predict_checked, X_new)
        assert checked["reason"].iloc[60] == "jump: T3_C"


def test_the_first_reading_after_a_logging_gap_is_no_jump(train, new_run):
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    X_new = new_run[0]
    t = X_new.index.get_level_values("time_s").to_numpy()
    paused = _resampled(X_new, (t < 600) | (t > 2400))  # 30 min not logged
    checked, caught = _caught(guard.predict_checked, paused)
    assert checked["ok"].all(), checked["reason"][~checked["ok"]]
    # A sensor back far off after the gap is still flagged (the range takes
    # over where the time allows a sensor to move that far).
    broken = paused.copy()
    row = int(np.flatnonzero(paused.index.get_level_values("time_s") > 2400)[0])
    broken.iloc[row, 0] += 100 * guard.input_max_step_[0]
    checked, _ = _caught(guard.predict_checked, broken)
    assert "T1_C" in checked["reason"].iloc[row]


def test_records_logged_twice_do_not_switch_the_flat_line_check_off(train, new_run):
    # Every record logged twice: half the steps 0, the run taken for one
    # logged infinitely fast, and a stuck sensor never flagged.
    X, y = train
    guard = GuardedRegressor(LinearRegression(), flat=20).fit(X, y)
    stuck = new_run[0].copy()
    stuck.iloc[40:, 2] = stuck.iloc[40, 2]
    twice = stuck.iloc[np.repeat(np.arange(len(stuck)), 2)]
    checked, _ = _caught(guard.predict_checked, twice)
    assert checked["reason"].str.contains("flat-line: T3_C").any()


def test_logging_faster_than_in_training_flat_lines_as_late_in_time(train):
    # The window counted samples of training: a run logged three times as
    # fast flat-lined after a third of the time, and hold froze the
    # compensation for hours.
    X, y = train
    guard = GuardedRegressor(LinearRegression(), flat=20).fit(X, y)
    fast, _ = make_runs([2.0], seed=4, n=360, period=10.0)
    fast.iloc[120:, 2] = fast.iloc[120, 2]  # T3_C stuck from time_s=1200
    checked, _ = _caught(guard.predict_checked, fast)
    flagged = checked["reason"].str.contains("flat-line: T3_C").to_numpy()
    # 20 samples of 30 s = 600 s = 60 samples of 10 s: rows 120..179
    assert not flagged[:179].any() and flagged[179:].all()


def test_update_samples_taken_sparsely_are_no_spike(train):
    from skthermal.linear_model import UpdateRegressor

    X, y = train
    guard = GuardedRegressor(UpdateRegressor(alpha=1.0)).fit(X, y)
    sparse, y_sparse = make_runs([2.0], seed=5, n=12, period=600.0)
    guard.partial_fit(sparse, y_sparse)  # every 10 min: no spike
    spike = sparse.copy()
    spike.iloc[6, 1] += 50.0
    with pytest.raises(ValueError, match=r"sensor spike \(1 of 4: 'T2_C'"):
        guard.partial_fit(spike, y_sparse)


def test_rows_out_of_time_order_are_an_error_not_sensor_faults(train, new_run):
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    shuffled = new_run[0].sample(frac=1.0, random_state=0)
    with pytest.raises(ValueError, match=r"time_s must not go back within a run"):
        guard.predict_checked(shuffled)
    with pytest.raises(ValueError, match=r"time_s must not go back within a run"):
        GuardedRegressor(LinearRegression()).fit(X.iloc[::-1], y.iloc[::-1])
    # A record logged twice (the same time) is no fault: the static model
    # predicts it, and so does its guard (it raised, leaving no
    # compensation for the whole call).
    twice = pd.concat([new_run[0].iloc[:50], new_run[0].iloc[49:]])
    checked, caught = _caught(guard.predict_checked, twice)
    assert checked["ok"].all() and len(checked) == len(twice)


def test_a_commanded_speed_steps_alike_at_any_logging_period():
    # Trained on runs logged at 10 s (small speed steps) and at 60 s (large
    # ones), the speed's steps were taken per 10 s: the large ones divided
    # by 6, and every speed change of a new 10 s run was held as a jump.
    rng = np.random.default_rng(0)
    frames, ys = [], []
    for r, (period, rpm) in enumerate([(10.0, 800.0), (10.0, 800.0), (60.0, 6000.0)]):
        t = np.arange(0.0, 4 * 3600, period)
        speed = np.where((t // 3600) % 2 == 1, rpm, 0.0)
        T = 20 + np.cumsum(speed) * period / 4e6 + rng.normal(0, 0.01, t.size)
        frames.append(
            pd.DataFrame(
                {"spindle_rpm": speed, "T1_C": T},
                index=pd.MultiIndex.from_arrays(
                    [np.full(t.size, f"r{r}"), t], names=["run", "time_s"]
                ),
            )
        )
        ys.append(T - 20)
    guard = GuardedRegressor(Ridge(), mode="hold").fit(
        pd.concat(frames), np.concatenate(ys)
    )
    assert guard.sample_period_ == 10.0
    t = np.arange(0.0, 4 * 3600, 10.0)
    speed = np.where((t // 3600) % 2 == 1, 6000.0, 0.0)
    new = pd.DataFrame(
        {"spindle_rpm": speed, "T1_C": 20 + np.cumsum(speed) * 10 / 4e6},
        index=pd.MultiIndex.from_arrays(
            [np.full(t.size, "n"), t], names=["run", "time_s"]
        ),
    )
    checked, _ = _caught(guard.predict_checked, new)
    assert not checked["reason"].str.contains("jump").any()
    # A second spindle's speed is commanded too.
    renamed = GuardedRegressor(Ridge(), mode="hold").fit(
        pd.concat(frames).rename(columns={"spindle_rpm": "spindle2_rpm"}),
        np.concatenate(ys),
    )
    checked, _ = _caught(
        renamed.predict_checked, new.rename(columns={"spindle_rpm": "spindle2_rpm"})
    )
    assert not checked["reason"].str.contains("jump").any()


# --- a slow drift -----------------------------------------------------------


def test_slow_drift_flagged_when_it_leaves_the_range(train, new_run):
    X, y = train
    X_new = new_run[0]
    X_bad = X_new.copy()
    X_bad["T1_C"] += np.linspace(0.0, 10.0, len(X_bad))  # slow drift
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    checked, caught = _caught(guard.predict_checked, X_bad)
    # the allowed range computed here independently of the guard
    high = X["T1_C"].max() + 0.25 * (X["T1_C"].max() - X["T1_C"].min())
    first = int(np.argmax(X_bad["T1_C"].to_numpy() > high))
    assert 0 < first < len(X_bad) - 1
    t_first = X_bad.index.get_level_values("time_s")[first]
    (msg,) = _messages(caught, SensorRangeWarning)
    assert f"'T1_C' in run 'r0' at time_s={t_first:g}" in msg
    assert not _messages(caught, SensorFaultWarning)  # a drift is no jump
    out = checked["reason"].str.contains("out of range: T1_C").to_numpy()
    assert not out[:first].any() and out[first:].all()


def test_the_allowed_range_stops_where_an_input_physically_ends(train, new_run):
    """Widened by span, a spindle speed's range would reach below 0 rpm: the
    allowed range stops at 0, and a speed above it is still flagged."""
    X, y = train
    rpm = np.tile(np.r_[np.zeros(60), np.full(60, 6000.0)], 3)
    X = X.assign(spindle_rpm=rpm)
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    X_new = new_run[0].assign(spindle_rpm=np.r_[np.zeros(60), np.full(60, 9000.0)])
    _, caught = _caught(guard.predict_checked, X_new)
    (msg,) = _messages(caught, SensorRangeWarning)
    assert "'spindle_rpm'" in msg and "allowed 0 to 7500" in msg


# --- non-finite readings ----------------------------------------------------


def test_nan_is_an_error_naming_sensor_unless_hold(train, new_run):
    X, y = train
    X_bad = new_run[0].copy()
    X_bad.iloc[10, 3] = np.nan
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    with pytest.raises(ValueError, match=r"'T4_C' reads nan .*run 'r0' at time_s=300"):
        guard.predict(X_bad)
    guard.set_params(mode="hold")
    checked, caught = _caught(guard.predict_checked, X_bad)
    assert checked["reason"].iloc[10] == "missing: T4_C"
    assert checked["prediction"].iloc[10] == checked["prediction"].iloc[9]
    assert np.isfinite(checked["prediction"]).all()
    assert any("missing" in m for m in _messages(caught, SensorFaultWarning))


def test_hold_makes_up_no_reading_of_a_sensor_dead_for_a_whole_run(train, new_run):
    # A sensor unplugged for the whole run (or every sensor) was filled with
    # the middle of its allowed range and the compensation computed from it
    # reported as "clipped".
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    X_dead = new_run[0].copy()
    X_dead["T2_C"] = np.nan
    with (
        warnings.catch_warnings(record=True) as caught,
        pytest.raises(
            ValueError,
            match=r"sensor 'T2_C' reads no finite value in run 'r0' at time_s=0, nor "
            r"in any other row of that run given to this call \(120 row\(s\)\)",
        ),
    ):
        warnings.simplefilter("always")
        guard.predict(X_dead)
    # No warning first saying that a value was held.
    assert not _messages(caught, SensorFaultWarning)
    with pytest.raises(ValueError, match=r"more sensor\(s\) alike"):
        guard.predict(X_dead * np.nan)
    # Dead from a later row on: held at its last good reading, as before.
    X_late = new_run[0].copy()
    X_late.iloc[30:, 1] = np.nan
    checked, _ = _caught(guard.predict_checked, X_late)
    assert (checked["action"].iloc[30:] == "held").all()
    assert np.isfinite(checked["prediction"]).all()
    # An input the model ignores (not among `inputs`) still gets a value.
    ignoring = GuardedRegressor(LinearRegression(), mode="hold", inputs=["T1_C"])
    ignoring.fit(X, y)
    assert np.isfinite(_caught(ignoring.predict, X_dead)[0]).all()


def test_a_run_with_a_dead_sensor_is_unavailable_in_a_batch(train):
    # One run of a batch with a dead sensor made predict_checked raise for
    # the whole batch: the good runs got no compensation either.
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    batch, _ = make_runs([1.5, 2.5, 2.0], seed=3)
    dead = batch.copy()
    dead.loc["r1", "T2_C"] = np.nan
    with pytest.raises(ValueError, match=r"'T2_C' reads no finite value in run 'r1'"):
        guard.predict(dead)  # predict has no way to say "no value"
    checked, caught = _caught(guard.predict_checked, dead)
    in_r1 = checked.index.get_level_values("run") == "r1"
    assert checked["prediction"][in_r1].isna().all()
    assert (checked["action"][in_r1] == "unavailable").all()
    assert (checked["reason"][in_r1] == "no reading: T2_C").all()
    assert not checked["ok"][in_r1].any()
    # The other runs as if given alone.
    alone = guard.predict_checked(batch.loc[["r0", "r2"]])
    pd.testing.assert_frame_equal(checked[~in_r1], alone)
    (message,) = _messages(caught, SensorFaultWarning)
    assert "'T2_C' reads no finite value in run 'r1'" in message
    assert "in run 'r1' at time_s=0, nor in any other row of that run" in message
    assert "(120 row(s))" in message
    assert "the 120 row(s) of the 1 run(s) with such a sensor" in message
    assert "the other 2 run(s) are predicted" in message
    # Every run dead: every row unavailable, and said so.
    with pytest.warns(SensorFaultWarning, match="no run of the call can be"):
        everything = guard.predict_checked(batch * np.nan)
    assert (everything["action"] == "unavailable").all()


def test_a_one_column_target_keeps_its_column_when_a_sensor_dies(train):
    # An independent check: fitted on a one-column frame, predict_checked's
    # column was 'prediction_disp_y_um', and 'prediction' whenever a run of
    # the batch had a dead sensor (a script reading it by name failed then).
    X, y = train
    frame = pd.DataFrame({"disp_y_um": np.asarray(y)}, index=X.index)
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, frame)
    batch, _ = make_runs([1.5, 2.5], seed=3)
    dead = batch.copy()
    dead.loc["r1", "T2_C"] = np.nan
    good = guard.predict_checked(batch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        checked = guard.predict_checked(dead)
    assert list(checked.columns) == list(good.columns)
    assert list(good.columns)[0] == "prediction_disp_y_um"


def _relative_hold_guard(train, new_run):
    """A guard in hold mode around a model of changes since the run start,
    and its predictions of the clean new run."""
    from skthermal.ensemble import ModularRegressor

    guard = GuardedRegressor(ModularRegressor(relative=True), mode="hold")
    guard.fit(*train)
    return guard, guard.predict(new_run[0])


def test_dropout_at_a_run_start_does_not_offset_the_run(train, new_run):
    # The first row is the run's reference for changes since the start: a
    # made-up value there shifts every later compensation of the run.
    X, y = train
    guard, good = _relative_hold_guard(train, new_run)
    X_bad = new_run[0].copy()
    X_bad.iloc[0, 1] = np.nan
    checked, _ = _caught(guard.predict_checked, X_bad)
    assert checked["reason"].iloc[0] == "missing: T2_C"
    shift = np.abs(checked["prediction"].to_numpy()[1:] - good[1:]).max()
    # Row 0 takes row 1's reading (one sample's change away), not the middle
    # of the training range.
    middle = X_bad.copy()
    middle.iloc[0, 1] = (X["T2_C"].min() + X["T2_C"].max()) / 2
    far = np.abs(guard.estimator_.predict(middle)[1:] - good[1:]).max()
    assert shift < 0.05 * far


def test_a_glitch_in_the_first_reading_is_flagged_and_held(train, new_run):
    # The first reading is the reference of changes since the run start: a
    # glitch there, inside the range, shifts every later compensation while
    # those rows look good. It is the jump, not the step back to normal.
    guard, good = _relative_hold_guard(train, new_run)
    X_bad = new_run[0].copy()
    X_bad.iloc[0, 0] += 1.5  # five largest training steps, within the range
    checked, caught = _caught(guard.predict_checked, X_bad)
    assert checked["reason"].tolist()[:3] == ["jump: T1_C", "", ""]
    assert "at time_s=0" in _messages(caught, SensorFaultWarning)[0]
    unguarded = guard.estimator_.predict(X_bad)
    assert np.abs(unguarded[1:] - good[1:]).min() > 4.0
    # Held at the second reading: one sample's change away.
    assert np.abs(checked["prediction"].to_numpy()[1:] - good[1:]).max() < 1.0


@pytest.mark.parametrize("fault", [1e6, np.nan])
def test_run_so_far_after_a_faulty_first_reading_equals_the_whole_run(
    train, new_run, fault
):
    # A controller passes the run so far. With a first reading out of range
    # or missing, the second call saw the step back as a jump too, had no
    # good reading to stand in for the first and clipped a made-up value
    # (documented: 159 µm against 2.4 µm for the whole run). The step is now
    # judged from the last good reading, so from the second row on the
    # streamed compensation is the whole run's.
    guard, _ = _relative_hold_guard(train, new_run)
    X_bad = new_run[0].copy()
    X_bad.iloc[0, 1] = fault
    whole = _caught(guard.predict_checked, X_bad)[0]
    assert whole["reason"].iloc[0] in ("out of range: T2_C", "missing: T2_C")
    assert whole["ok"].iloc[1:].all()
    streamed = [
        _caught(guard.predict_checked, X_bad.iloc[:k])[0]["prediction"].iloc[-1]
        for k in range(2, 8)
    ]
    np.testing.assert_allclose(streamed, whole["prediction"].iloc[1:7], rtol=1e-12)


def test_a_jump_after_the_first_reading_is_the_second_reading(train, new_run):
    # The step from the first reading is a jump and so is the next: the
    # second reading is the odd one out (a spike and its step back).
    X, y = train
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    X_bad = new_run[0].copy()
    X_bad.iloc[1, 0] += 1.5
    checked, _ = _caught(guard.predict_checked, X_bad)
    assert checked["reason"].tolist()[:4] == ["", "jump: T1_C", "jump: T1_C", ""]


class _NaNModel(RegressorMixin, BaseEstimator):
    def fit(self, X, y):
        self.n_features_in_ = np.asarray(X).shape[1]
        return self

    def predict(self, X):
        return np.full(np.asarray(X).shape[0], np.nan)


@pytest.mark.parametrize("mode", ["clip", "hold"])
def test_safe_modes_never_pass_on_a_nan_compensation(train, new_run, mode):
    X, y = train
    guard = GuardedRegressor(_NaNModel(), mode=mode).fit(X, y)
    with pytest.raises(ValueError, match=r"predicted \[nan\] in run 'r0' at time_s=0"):
        guard.predict(new_run[0])


def test_fit_names_a_missing_reading_or_target(train):
    X, y = train
    X_bad = X.copy()
    X_bad.iloc[5, 2] = np.nan
    with pytest.raises(ValueError, match=r"'T3_C' is missing \(NaN\) at row 5, run"):
        GuardedRegressor(LinearRegression()).fit(X_bad, y)
    y_bad = y.copy()
    y_bad.iloc[7] = np.nan
    with pytest.raises(ValueError, match=r"target 'disp_y_um' is missing .* row 7"):
        GuardedRegressor(LinearRegression()).fit(X, y_bad)


def test_partial_fit_updates_the_model_and_widens_the_ranges(train):
    from skthermal.linear_model import UpdateRegressor

    X, y = train
    guard = GuardedRegressor(UpdateRegressor(alpha=1.0)).fit(X, y)
    assert not hasattr(GuardedRegressor(LinearRegression()), "partial_fit")
    # A changed machine: hotter readings, another slope.
    hot, y_hot = make_runs([40.0], seed=3, n=8)
    _, caught = _caught(guard.predict, hot)
    assert _messages(caught, SensorRangeWarning)
    guard.partial_fit(hot, 1.2 * y_hot)
    direct = UpdateRegressor(alpha=1.0).fit(X, y).partial_fit(hot, 1.2 * y_hot)
    np.testing.assert_allclose(guard.estimator_.coef_, direct.coef_)
    assert np.all(guard.input_max_ >= hot.max().to_numpy())
    _, caught = _caught(guard.predict, hot)
    assert not _messages(caught, SensorRangeWarning)
    bad = hot.copy()
    bad.iloc[2, 0] = np.nan
    with pytest.raises(ValueError, match=r"'T1_C' is missing \(NaN\) at row 2"):
        guard.partial_fit(bad, y_hot)
    # A spike in the update rows is refused: learnt, it bent the model and
    # widened the checks so that the same spike later passed as ok.
    spike = hot.copy()
    spike.iloc[3, 0] = 1e6
    before = guard.estimator_.coef_.copy()
    with pytest.raises(
        ValueError, match=r"partial_fit: the new samples hold a sensor spike"
    ):
        guard.partial_fit(spike, y_hot)
    np.testing.assert_array_equal(guard.estimator_.coef_, before)
    assert guard.input_max_[0] < 1e3


def test_plain_arrays_are_named_by_row_and_x_index(train):
    X, y = train
    A = X.to_numpy()
    guard = GuardedRegressor(LinearRegression()).fit(A, y.to_numpy())
    A_bad = A[:50].copy()
    A_bad[20, 0] = -500.0
    _, caught = _caught(guard.predict, A_bad)
    (msg,) = _messages(caught, SensorRangeWarning)
    assert "'x0' at row 20" in msg
    groups = np.repeat(["a", "b"], 25)
    _, caught = _caught(guard.predict, A_bad, groups=groups)
    assert "'x0' in run 'a' at row 20" in _messages(caught, SensorRangeWarning)[0]


def test_string_column_is_named(train):
    X, y = train
    guard = GuardedRegressor(LinearRegression())
    with pytest.raises(ValueError, match=r"'T2_C'.*not numeric"):
        guard.fit(X.assign(T2_C="hot"), y)


def test_bad_mode_is_rejected(train):
    with pytest.raises(InvalidParameterError, match="mode"):
        GuardedRegressor(LinearRegression(), mode="stop").fit(*train)


def test_only_the_named_inputs_are_checked(train, spiked):
    X, y = train
    # T2_C (spiked) is not read by the model, so it must not hold or clip it
    model = make_pipeline(
        ColumnTransformer([("used", "passthrough", ["T1_C", "T3_C"])]), Ridge()
    )
    for mode in ("clip", "hold"):
        guard = GuardedRegressor(model, inputs=["T1_C", "T3_C"], mode=mode)
        checked, caught = _caught(guard.fit(X, y).predict_checked, spiked)
        assert checked["ok"].all()
        np.testing.assert_allclose(
            checked["prediction"], guard.estimator_.predict(spiked)
        )
        assert not [w for w in caught if issubclass(w.category, GuardWarning)]
    guard = GuardedRegressor(model, inputs=[1], mode="hold").fit(X, y)
    assert guard.checked_inputs_.tolist() == [False, True, False, False]
    checked, _ = _caught(guard.predict_checked, spiked)
    assert checked["action"].iloc[60] == "held"
    with pytest.raises(ValueError, match="inputs names 'T9_C', which is not an"):
        GuardedRegressor(model, inputs=["T9_C"]).fit(X, y)


# --- run-aware inner models -------------------------------------------------


def test_sequence_model_sees_the_runs(train, new_run):
    X, y = train
    inner = GreyPSORegressor(calibration="ls")
    guard = GuardedRegressor(inner).fit(X, y)
    plain = clone(inner).fit(X, y)
    X_new = new_run[0]
    pred, caught = _caught(guard.predict, X_new)
    np.testing.assert_allclose(pred, plain.predict(X_new))
    # groups given separately reach the inner model's fit and predict
    groups = X.index.get_level_values("run").to_numpy()
    guard2 = GuardedRegressor(inner).fit(X.to_numpy(), y.to_numpy(), groups=groups)
    np.testing.assert_allclose(guard2.estimator_.coef_, plain.coef_)
    two = np.r_[X_new.to_numpy(), X_new.to_numpy()]
    pred2, _ = _caught(guard2.predict, two, groups=np.repeat(["a", "b"], len(X_new)))
    np.testing.assert_allclose(pred2, np.r_[pred, pred])


@pytest.mark.parametrize("routing", [False, True])
def test_groups_reach_the_steps_of_a_wrapped_pipeline(train, new_run, routing):
    # A Pipeline takes no groups= of its own: without metadata routing the
    # guard gives them as the rows' run index, with routing as routed
    # metadata. Before, they were dropped and every row was one run.
    import sklearn

    from skthermal.selection import GRASelector

    X, y = train
    groups = X.index.get_level_values("run").to_numpy()
    X_new = new_run[0]
    two = pd.concat([X_new, X_new]).to_numpy()
    new_groups = np.repeat(["a", "b"], len(X_new))
    with sklearn.config_context(enable_metadata_routing=routing):
        select, grey = GRASelector(n_features_to_select=2), GreyPSORegressor()
        if routing:
            select.set_fit_request(groups=True)
            grey.set_fit_request(groups=True).set_predict_request(groups=True)
        pipe = make_pipeline(select, grey.set_params(calibration="ls"))
        reference = clone(pipe).fit(X, y).predict(X_new)
        guard = GuardedRegressor(pipe)
        if routing:
            guard.set_fit_request(groups=True).set_predict_request(groups=True)
        guard.fit(X.to_numpy(), y.to_numpy(), groups=groups)
        pred, caught = _caught(guard.predict, two, groups=new_groups)
    assert not [w for w in caught if "carry no run labels" in str(w.message)]
    np.testing.assert_allclose(pred, np.r_[reference, reference], rtol=1e-10)


@pytest.mark.parametrize("labels", ["text", "int"])
def test_run_and_time_columns_are_not_inputs_of_the_wrapped_model(train, labels):
    # The run table as stored: run and time_s columns. A plain model took
    # them as inputs (integer labels) or failed on them (text labels).
    X, y = train
    stored = X.reset_index()
    if labels == "int":
        stored["run"] = stored["run"].str[1:].astype(int)
    guard = GuardedRegressor(LinearRegression()).fit(stored, y.to_numpy())
    assert list(guard.estimator_.feature_names_in_) == SENSORS
    reference = GuardedRegressor(LinearRegression()).fit(X, y)
    np.testing.assert_allclose(guard.predict(stored), reference.predict(X))


SEQUENCE_MODELS = pytest.mark.parametrize(
    "inner",
    [
        GreyPSORegressor(),
        make_pipeline(LagFeatures(time_constants=[600.0]), LinearRegression()),
    ],
    ids=["grey", "lag-pipeline"],
)


@SEQUENCE_MODELS
@pytest.mark.parametrize("mode", ["warn", "hold"])
def test_a_window_of_recent_rows_is_not_ok_for_a_sequence_model(
    train, new_run, inner, mode
):
    # The controller gives the last rows of a new run: a sequence model takes
    # them as a run that starts there (its compensation collapses to ~0),
    # which must not pass as ok.
    X, y = train
    window = new_run[0].rename(index={"r0": "new"}, level="run").iloc[-20:]
    guard = GuardedRegressor(inner, mode=mode).fit(X, y)
    checked, caught = _caught(guard.predict_checked, window)
    assert not checked["ok"].any()
    assert (
        checked["reason"]
        == "run starts at time_s=3000, not at its start: a sequence model needs "
        "the whole run or a continued run"
    ).all()
    (msg,) = _messages(caught, RunStartWarning)
    assert "run 'new' at time_s=3000 to time_s=3570" in msg
    assert "a window of recent rows suits only static models" in msg
    # said once: not again by the wrapped model in its own words
    assert not [m for m in _messages(caught, UserWarning) if "start(s) at" in m]
    assert _caught(guard.predict, window)[0].shape == (20,)
    # the whole run so far is fine
    whole, caught = _caught(guard.predict_checked, new_run[0].iloc[:70])
    assert whole["ok"].all() and not _messages(caught, GuardWarning)


def test_a_window_of_recent_rows_is_fine_for_a_static_model(train, new_run):
    X, y = train
    window = new_run[0].rename(index={"r0": "new"}, level="run").iloc[-20:]
    guard = GuardedRegressor(make_pipeline(StandardScaler(), Ridge())).fit(X, y)
    checked, caught = _caught(guard.predict_checked, window)
    assert checked["ok"].all() and not _messages(caught, GuardWarning)


@SEQUENCE_MODELS
def test_the_rows_after_a_training_run_continue_it(train, new_run, inner):
    X, y = train
    run = new_run[0].rename(index={"r0": "c"}, level="run")
    target = new_run[1].rename(index={"r0": "c"}, level="run")
    X_fit, y_fit = pd.concat([X, run.iloc[:60]]), pd.concat([y, target.iloc[:60]])
    guard = GuardedRegressor(inner).fit(X_fit, y_fit)
    later, caught = _caught(guard.predict_checked, run.iloc[60:])
    assert later["ok"].all() and not _messages(caught, GuardWarning)
    whole, _ = _caught(guard.predict_checked, run)
    np.testing.assert_allclose(later["prediction"], whole["prediction"].iloc[60:])


def test_hold_repairs_the_input_of_a_sequence_model(train, spiked):
    X, y = train
    guard = GuardedRegressor(GreyPSORegressor(calibration="ls"), mode="hold")
    guard.fit(X, y)
    pred, _ = _caught(guard.predict, spiked)
    # the grey model accumulates its input: unrepaired, the spike would
    # shift every later prediction of the run
    unguarded = guard.estimator_.predict(spiked)
    low, high = y.min() - 0.25 * np.ptp(y), y.max() + 0.25 * np.ptp(y)
    assert np.abs(unguarded[62:]).max() > 1e3
    assert np.isfinite(pred).all() and (pred >= low).all() and (pred <= high).all()


def test_multi_output_columns(train):
    X, y = train
    Y = pd.DataFrame({"disp_x_um": y, "disp_y_um": -2 * y})
    guard = GuardedRegressor(LinearRegression(), mode="clip").fit(X, Y)
    checked, _ = _caught(guard.predict_checked, X.iloc[:5])
    assert list(checked.columns) == [
        "prediction_disp_x_um",
        "prediction_disp_y_um",
        "ok",
        "action",
        "reason",
    ]
    assert guard.predict(X.iloc[:5]).shape == (5, 2)


def test_run_column_stays_with_the_rows(train):
    X, y = train
    flat = X.reset_index()
    X_run = flat.drop(columns="time_s")
    guard = GuardedRegressor(GreyPSORegressor(calibration="ls"), mode="clip")
    guard.fit(X_run, y.to_numpy())
    assert list(guard.feature_names_in_) == SENSORS
    pred, caught = _caught(guard.predict, X_run)
    np.testing.assert_allclose(pred, guard.estimator_.predict(X_run))


@pytest.mark.parametrize("mode", ["clip", "hold"])
def test_safe_modes_take_the_run_table_as_stored(train, spiked, mode):
    # run and time_s columns are handed on unchanged around the held or
    # clipped inputs: the same predictions as from the indexed table.
    from skthermal.linear_model import UpdateRegressor

    X, y = train
    bad = spiked.copy()
    bad.iloc[30, 0] = np.nan  # a dropout for the hold mode to bridge
    guard = GuardedRegressor(UpdateRegressor(), mode=mode).fit(X.reset_index(), y)
    flat = bad.reset_index()[["T1_C", "time_s", "T2_C", "run", "T3_C", "T4_C"]]
    if mode == "clip":
        flat = flat.dropna()
        bad = bad.dropna()
    pred, _ = _caught(guard.predict, flat)
    expected, _ = _caught(guard.predict, bad)
    np.testing.assert_allclose(pred, expected)


# --- composition and persistence --------------------------------------------


def test_pipeline_grid_search_clone(train):
    X, y = train
    groups = X.index.get_level_values("run")
    guard = GuardedRegressor(make_pipeline(StandardScaler(), Ridge()))
    search = GridSearchCV(
        guard,
        {"estimator__ridge__alpha": [0.1, 10.0], "span": [0.5]},
        cv=GroupKFold(n_splits=3),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GuardWarning)
        search.fit(X, y, groups=groups)
    assert search.best_params_["estimator__ridge__alpha"] in (0.1, 10.0)
    assert isinstance(search.best_estimator_, GuardedRegressor)
    assert clone(guard).get_params()["estimator__ridge__alpha"] == 1.0
    # the guard as the last step of a pipeline sees the scaled inputs
    pipe = make_pipeline(StandardScaler(), GuardedRegressor(Ridge())).fit(X, y)
    assert np.isfinite(pipe.predict(X)).all()


def test_joblib_and_skthermal_io_round_trip(tmp_path, train, spiked):
    pytest.importorskip("skops")
    from skthermal.io import load, save

    X, y = train
    guard = GuardedRegressor(
        make_pipeline(StandardScaler(), GreyPSORegressor(calibration="ls")),
        mode="hold",
    ).fit(X, y)
    expected, _ = _caught(guard.predict_checked, spiked)
    joblib.dump(guard, tmp_path / "guard.joblib")
    save(guard, tmp_path / "guard.skops")
    for loaded in (
        joblib.load(tmp_path / "guard.joblib"),
        load(tmp_path / "guard.skops"),
    ):
        got, caught = _caught(loaded.predict_checked, spiked)
        pd.testing.assert_frame_equal(got, expected)
        assert _messages(caught, SensorRangeWarning)


def test_warnings_share_a_base_class():
    classes = (
        SensorRangeWarning,
        SensorFaultWarning,
        PredictionRangeWarning,
        RunStartWarning,
    )
    for cls in classes:
        assert issubclass(cls, GuardWarning) and issubclass(cls, UserWarning)


def test_skthermal_io_loads_a_guard_in_a_fresh_interpreter(tmp_path, train):
    """On the controller PC only ``skthermal.io`` is imported before ``load``."""
    pytest.importorskip("skops")
    from skthermal.io import save

    X, y = train
    path = save(GuardedRegressor(Ridge()).fit(X, y), tmp_path / "guard.skops")
    code = (
        "import sys; from skthermal.io import load; "
        f"m = load({str(path)!r}); print(type(m).__name__, m.n_features_in_)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["GuardedRegressor", "4"]


def test_wrappers_route_metadata_to_their_model():
    # With metadata routing on, what the wrapped model requested reaches it
    # through a Pipeline and cross_validate, as through scikit-learn's own
    # meta-estimators; with it off, fit passes its keyword arguments on.
    import sklearn
    from sklearn.linear_model import LinearRegression
    from sklearn.model_selection import GroupKFold, cross_validate
    from sklearn.pipeline import make_pipeline

    from skthermal.models import RunStartRegressor

    rng = np.random.default_rng(0)
    X = pd.DataFrame(rng.normal(size=(60, 3)), columns=["T1_C", "T2_C", "T3_C"])
    y = X.to_numpy() @ [1.0, -2.0, 0.5] + rng.normal(size=60)
    w = rng.uniform(0.1, 3.0, size=60)
    groups = np.repeat(["a", "b", "c"], 20)
    weighted = LinearRegression().fit(X, y, sample_weight=w)
    unrouted = GuardedRegressor(LinearRegression()).fit(X, y, sample_weight=w)
    np.testing.assert_allclose(unrouted.estimator_.coef_, weighted.coef_)
    with sklearn.config_context(enable_metadata_routing=True):
        inner = LinearRegression().set_fit_request(sample_weight=True)
        for wrapper in (GuardedRegressor(inner), RunStartRegressor(inner)):
            pipe = make_pipeline(wrapper.set_fit_request(groups=True))
            pipe.fit(X, y, sample_weight=w, groups=groups)
            fitted = pipe[-1].estimator_
            reference = clone(wrapper).fit(X, y, groups=groups, sample_weight=w)
            np.testing.assert_allclose(fitted.coef_, reference.estimator_.coef_)
            if isinstance(wrapper, GuardedRegressor):
                np.testing.assert_allclose(fitted.coef_, weighted.coef_)
            scores = cross_validate(
                clone(wrapper).set_score_request(sample_weight=False),
                X,
                y,
                cv=GroupKFold(3),
                params={"sample_weight": w, "groups": groups},
            )
            assert np.all(np.isfinite(scores["test_score"]))


@pytest.mark.parametrize("missing", [2, 20])
def test_a_sensor_back_far_off_after_a_dropout_is_a_jump(train, new_run, missing):
    # The step is judged from the last good reading; the limit grows with the
    # samples in between only up to a few, so an offset after a long dropout
    # is still caught (an independent check: +8 °C after 5 or 20 missing
    # samples passed as ok).
    X, y = train
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    X_bad = new_run[0].copy()
    X_bad.iloc[40 : 40 + missing, 1] = np.nan
    X_bad.iloc[40 + missing :, 1] += 20 * guard.input_max_step_[1]
    checked, _ = _caught(guard.predict_checked, X_bad)
    assert checked["reason"].iloc[40 + missing] == "jump: T2_C"


def test_a_spindle_at_one_speed_for_hours_is_no_flat_line(train):
    # An independent check: spindle_rpm, a commanded value, was flat-line
    # checked like a sensor; any speed (or rest) held longer than its window
    # flagged the rows, and hold mode froze the compensation for hours
    # (1,971 of 5,041 rows of an 84 h run; 21 -> 52 µm).
    X, y = train
    speeds = np.tile(np.r_[np.zeros(40), np.full(40, 3000.0), np.zeros(40)], 3)
    fit_X = X.assign(spindle_rpm=speeds)
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(fit_X, y)
    new = fit_X.loc[["r1"]].copy()
    new["spindle_rpm"] = 3000.0  # held all run long, 3 times the window
    checked, caught = _caught(guard.predict_checked, new)
    assert not [m for m in _messages(caught, SensorFaultWarning) if "flat" in m]
    assert checked["ok"].all()
    # A temperature sensor stuck as long is still flagged.
    stuck = new.copy()
    stuck["T1_C"] = stuck["T1_C"].iloc[0]
    checked, caught = _caught(guard.predict_checked, stuck)
    assert any("'T1_C'" in m for m in _messages(caught, SensorFaultWarning))
