"""RunStream: block-by-block prediction equals whole-run prediction."""

import pickle
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline

from skthermal.compose import (
    GuardedRegressor,
    GuardWarning,
    RunStartWarning,
    RunStream,
    SensorFaultWarning,
    SensorRangeWarning,
)
from skthermal.linear_model import TransferFunctionRegressor
from skthermal.preprocessing import LagFeatures, LagRidgeCV


def _run(label, hours=6.0, period=60.0, seed=0):
    """A run table of one run: a speed step and its rest, two sensors, a
    displacement lagging them."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600, period)
    rpm = np.where((t > 600) & (t < hours * 1800), 2000.0 + 1000 * seed, 0.0)
    heat = np.cumsum(rpm) * period / 3e6
    t1 = 20 + heat * np.exp(-t / 7200) + 0.01 * rng.standard_normal(t.size)
    t2 = 20 + 0.5 * heat * np.exp(-t / 5000) + 0.01 * rng.standard_normal(t.size)
    disp = 3 * (t1 - 20) + 2 * (t2 - 20) + 0.001 * rpm
    return pd.DataFrame(
        {
            "run": label,
            "time_s": t,
            "spindle_rpm": rpm,
            "T1_C": t1,
            "T2_C": t2,
            "disp_z_um": disp,
        }
    )


@pytest.fixture(scope="module")
def data():
    train = pd.concat([_run("a", seed=0), _run("b", seed=1)], ignore_index=True)
    X = train.drop(columns="disp_z_um")
    lag = LagRidgeCV(time_constant_sets=[(), (900.0, 3600.0)]).fit(
        X, train["disp_z_um"]
    )
    new = pd.concat([_run("c", seed=2), _run("d", seed=3)], ignore_index=True)
    return X, train["disp_z_um"], lag, new.drop(columns="disp_z_um")


def _blocks(table, sizes):
    """Consecutive blocks of ``table``'s rows, of the sizes given in turn."""
    out, start, k = [], 0, 0
    while start < len(table):
        size = sizes[k % len(sizes)]
        out.append(table.iloc[start : start + size])
        start += size
        k += 1
    return out


@pytest.mark.parametrize("sizes", [[1], [7], [30, 1, 12]])
def test_blocks_of_a_new_run_equal_the_whole_run(data, sizes):
    # A controller passing each new block once had every block taken as a
    # run of its own (tens of µm off), or had to pass the run so far.
    _, _, model, new = data
    run = new[new["run"] == "c"]
    whole = model.predict(run)
    stream = RunStream(model)
    assert stream.mode_ == "incremental"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no late-start warning per block
        parts = [stream.predict(b) for b in _blocks(run, sizes)]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)
    # Each block alone, as before, restarts the run: far off.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = np.concatenate([model.predict(b) for b in _blocks(run, [30])])
    assert np.max(np.abs(alone - whole)) > 1.0


def test_a_logger_that_switches_period_is_no_pause_at_every_row(data):
    # Logged at 20 s, then at 120 s: row by row every later row was warned
    # about as a pause (with a period creeping from 20 s), a new message each
    # time, hundreds in a run; the predictions were right.
    _, _, model, _ = data
    fast = _run("e", hours=1.0, period=20.0, seed=2)
    slow = _run("e", hours=3.0, period=120.0, seed=2)
    run = pd.concat([fast, slow[slow["time_s"] >= 3600]], ignore_index=True)
    run = run.drop(columns="disp_z_um")
    stream = RunStream(model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parts = [stream.predict(b) for b in _blocks(run, [1])]
    pauses = [
        w for w in caught if "continues 120 s after its last row" in str(w.message)
    ]
    assert 1 <= len(pauses) <= 10
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        np.testing.assert_allclose(np.concatenate(parts), model.predict(run), atol=1e-9)
    # A guard is given the run so far: its inner model's gap warning grew
    # its count at every row ("1 gap(s)", "2 gap(s)", ...), each said anew.
    # (A model with filters: a static one says nothing of gaps.)
    X, y, _, _ = data
    lagged = LagRidgeCV(time_constant_sets=[(900.0, 3600.0)])
    guarded = RunStream(GuardedRegressor(lagged).fit(X, y))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for b in _blocks(run, [5]):
            guarded.predict(b)
    assert sum("gap(s) in time_s" in str(w.message) for w in caught) == 1


@pytest.mark.parametrize("kind", ["lag", "transfer"])
def test_a_run_logged_more_slowly_than_training_streams_as_whole(data, kind):
    # Trained at 60 s, a run logged every 180 s: block by block every step
    # was taken as a gap against the training period (filtered as a ramp),
    # whole as regular steps: up to 0.5 µm apart, without a word.
    X, y, lag, _ = data
    model = (
        lag
        if kind == "lag"
        else TransferFunctionRegressor(speed_column="spindle_rpm").fit(X, y)
    )
    slow = _run("s", hours=6.0, period=180.0, seed=2).drop(columns="disp_z_um")
    whole = model.predict(slow)
    stream = RunStream(model)
    parts = [stream.predict(b) for b in _blocks(slow, [7])]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)


def test_a_guard_streamed_says_every_new_fault(data):
    # Said once per kind without its figures, a second spike of a sensor in
    # the run (another time) raised no warning in the default mode "warn".
    X, y, model, new = data
    run = new[new["run"] == "c"].copy()
    step = run["T1_C"].diff().abs().max()
    run.iloc[[60, 200], run.columns.get_loc("T1_C")] += 50 * step
    stream = RunStream(GuardedRegressor(model).fit(X, y))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for b in _blocks(run, [10]):
            stream.predict(b)
    jumps = [w for w in caught if "Sensor jump" in str(w.message)]
    assert len(jumps) >= 2


def test_a_record_logged_twice_streams_for_a_guarded_static_model(data):
    # The guard lets a record logged twice pass; streamed row by row it was
    # "a block given twice or out of order" (no compensation).
    X, y, _, new = data
    run = new[new["run"] == "c"].iloc[:40]
    twice = pd.concat([run.iloc[:20], run.iloc[19:]])
    stream = RunStream(GuardedRegressor(LinearRegression()).fit(X, y))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        parts = [stream.predict(b) for b in _blocks(twice, [1])]
    assert len(np.concatenate(parts)) == len(twice)
    lag = RunStream(data[2])  # a sequence model keeping the run's state
    lag.predict(run.iloc[:20])
    with pytest.raises(ValueError, match=r"a block given twice or out of order"):
        lag.predict(run.iloc[19:20])


def test_blocks_holding_several_runs(data):
    _, _, model, new = data
    whole = model.predict(new)
    c, d = new[new["run"] == "c"], new[new["run"] == "d"]
    stream = RunStream(model)
    got = {"c": [], "d": []}
    for start in range(0, len(c), 25):
        block = pd.concat([c.iloc[start : start + 25], d.iloc[start : start + 25]])
        y = stream.predict(block)
        n = len(c.iloc[start : start + 25])
        got["c"].append(y[:n])
        got["d"].append(y[n:])
    np.testing.assert_allclose(np.concatenate(got["c"] + got["d"]), whole, atol=1e-9)
    assert stream.runs_ == ["c", "d"]


def test_the_model_given_is_left_as_it_was(data):
    _, _, model, new = data
    known = set(model.lag_features_.run_states_)
    RunStream(model).predict(new.iloc[:10])
    assert set(model.lag_features_.run_states_) == known


def test_a_training_run_continued_in_blocks(data):
    # The later rows of a run seen in fit continue it, block by block.
    X, y, _, _ = data
    a = X[X["run"] == "a"]
    cut = len(a) // 2
    model = LagRidgeCV(time_constant_sets=[(900.0, 3600.0)]).fit(
        a.iloc[:cut], y[: len(a)].iloc[:cut]
    )
    whole = model.predict(a)[cut:]
    stream = RunStream(model)
    parts = [stream.predict(b) for b in _blocks(a.iloc[cut:], [11])]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)


def test_lag_features_remember_runs(data):
    X, _, _, new = data
    lf = LagFeatures(time_constants=(600.0, 3600.0)).fit(X)
    run = new[new["run"] == "d"]
    whole = np.asarray(lf.transform(run))
    parts = []
    for block in _blocks(run, [13]):
        parts.append(np.asarray(lf.transform(block)))
        lf.remember_runs(block)
    np.testing.assert_allclose(np.vstack(parts), whole, atol=1e-9)


def test_transfer_function_remembers_runs(data):
    X, y, _, new = data
    model = TransferFunctionRegressor().fit(X, y)
    run = new[new["run"] == "c"]
    whole = model.predict(run)
    stream = RunStream(model)
    assert stream.mode_ == "incremental"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parts = [stream.predict(b) for b in _blocks(run, [1, 17])]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)
    # And a training run's later rows, block by block.
    a = X[X["run"] == "a"]
    cut = len(a) // 2
    part = TransferFunctionRegressor().fit(a.iloc[:cut], y.iloc[:cut])
    whole = part.predict(a)[cut:]
    stream = RunStream(part)
    got = np.concatenate([stream.predict(b) for b in _blocks(a.iloc[cut:], [9])])
    np.testing.assert_allclose(got, whole, atol=1e-9)


def test_other_models_get_the_run_so_far(data):
    X, y, _, new = data
    model = make_pipeline(LagFeatures(time_constants=(900.0,)), LinearRegression()).fit(
        X, y
    )
    run = new[new["run"] == "c"]
    whole = model.predict(run)
    stream = RunStream(model)
    assert stream.mode_ == "history"
    parts = [stream.predict(b) for b in _blocks(run, [40])]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)


def test_a_guard_warns_once_per_fault(data):
    # Given the run so far, the guard sees a fault of an earlier block again
    # in every later call: it is said once, and a new fault is said.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    run = new[new["run"] == "c"].copy()
    run.iloc[50, run.columns.get_loc("T1_C")] += 30.0  # a spike in block 2
    run.iloc[250, run.columns.get_loc("T2_C")] += 30.0  # and in block 6
    stream = RunStream(guard)
    faults = []
    for block in _blocks(run, [40]):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            stream.predict(block)
        faults.append(sum(issubclass(w.category, SensorFaultWarning) for w in caught))
    assert faults[1] >= 1 and faults[6] >= 1
    assert sum(faults[2:6]) == 0 and sum(faults[7:]) == 0


def test_a_lasting_finding_is_said_once(data):
    # A reading out of range from the run's start on: its finding's row
    # count grew with every block ("3 rows", "4 rows", ...), and it was said
    # again at every one-row block, 60 warnings for one finding.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    run = new[new["run"] == "c"].copy()
    run["T2_C"] += 50.0  # out of range at every row
    run.iloc[30:, run.columns.get_loc("T1_C")] += 50.0  # and from row 30 on
    stream = RunStream(guard)
    said = []
    for block in _blocks(run.iloc[:60], [1]):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            stream.predict(block)
        said.append([str(w.message) for w in caught])
    # New findings only: T2_C at row 0, the speed (4000 rpm, above training)
    # at row 11, T1_C at row 30 (out of range, and its step a jump).
    assert [i for i, s in enumerate(said) if s] == [0, 11, 30]
    assert "'spindle_rpm'" in said[11][0] and "'T1_C'" in said[30][0]


@pytest.mark.parametrize("mode", ["warn", "clip", "hold"])
def test_a_guard_around_a_static_model_streams_from_a_bounded_tail(data, mode):
    # The guard was given the whole run so far at every block: one more row
    # after 128,000 took 2.9-5.6 s. It keeps the rows its checks read now,
    # and the checked predictions equal those of the whole run.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode=mode).fit(X, y)
    run = new[new["run"] == "c"].copy()
    col = run.columns.get_loc
    run.iloc[50, col("T1_C")] += 30.0  # a spike
    run.iloc[120:150, col("T2_C")] = run.iloc[120, col("T2_C")]  # stuck
    run.iloc[200:204, col("T1_C")] += 40.0  # out of range for a while
    if mode == "hold":
        run.iloc[260:263, col("T2_C")] = np.nan  # a dropout
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = guard.predict_checked(run)
        stream = RunStream(guard)
        assert stream.mode_ == "incremental"
        parts = [stream.predict_checked(b) for b in _blocks(run, [1, 3, 7, 2])]
    got = pd.concat(parts)
    np.testing.assert_allclose(got["prediction"], whole["prediction"], atol=1e-12)
    for column in ("ok", "action", "reason"):
        assert got[column].tolist() == whole[column].tolist()
    # What is kept of the run: its last rows, not the run.
    assert len(stream.model_.stream_runs_["c"]["rows"]) == 3
    stream.forget("c")
    assert "c" not in stream.model_.stream_runs_


@pytest.mark.parametrize("mode", ["warn", "hold"])
@pytest.mark.parametrize("seed", range(4))
def test_a_guarded_static_model_streams_as_the_whole_run(data, seed, mode):
    # Faults that last across blocks (a sensor stuck past its flat-line
    # window, a dropout, readings out of range, predictions out of band),
    # spikes at block edges, a record logged twice and a logging gap: the
    # kept rows and what is carried apart give the whole run's checks.
    X, y, _, new = data
    rng = np.random.default_rng(seed)
    run = new[new["run"] == "d"].copy().reset_index(drop=True)
    col = run.columns.get_loc
    for _ in range(6):
        at = int(rng.integers(5, len(run) - 40))
        kind = rng.integers(5)
        c = col(str(rng.choice(["T1_C", "T2_C"])))
        if kind == 0:
            run.iloc[at, c] += 30.0
        elif kind == 1:
            run.iloc[at : at + 30, c] = run.iloc[at, c]
        elif kind == 2:
            run.iloc[at : at + 12, c] += 8.0
        elif kind == 3 and mode == "hold":  # other modes refuse a NaN
            run.iloc[at : at + 5, c] = np.nan
        else:
            run.iloc[at : at + 20, c] -= 3.0
    run = pd.concat([run.iloc[:100], run.iloc[99:]]).reset_index(drop=True)  # twice
    run = run.drop(index=range(200, 215)).reset_index(drop=True)  # a gap
    guard = GuardedRegressor(LinearRegression(), mode=mode, flat=8).fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = guard.predict_checked(run)
        stream = RunStream(guard)
        sizes = list(rng.integers(1, 9, 40))
        got = pd.concat([stream.predict_checked(b) for b in _blocks(run, sizes)])
    np.testing.assert_allclose(got["prediction"], whole["prediction"], atol=1e-12)
    for column in ("ok", "action", "reason"):
        assert got[column].tolist() == whole[column].tolist()


def test_a_guard_keeping_runs_saves_and_starts_a_run_again(data, tmp_path):
    # The kept rows are frames, which a skops file cannot hold: left out.
    from skthermal.io import load, save

    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    run = new[new["run"] == "c"]
    RunStream(guard, copy=False).predict(run.iloc[:50])
    assert "c" in guard.stream_runs_
    loaded = load(save(guard, tmp_path / "guard.skops"))
    assert not hasattr(loaded, "stream_runs_")
    np.testing.assert_allclose(
        loaded.predict(run.iloc[50:60]), guard.predict(run.iloc[50:60])
    )
    # The run given again from its start is not continued from its kept rows.
    fresh = GuardedRegressor(LinearRegression()).fit(X, y)
    np.testing.assert_allclose(
        guard.predict(run.iloc[:10]), fresh.predict(run.iloc[:10])
    )


def test_a_new_run_without_readings_leaves_a_continued_one_as_it_was(data):
    # Beside a new run whose sensor had read nothing yet, a continued run
    # lost its kept state (a stuck sensor went unflagged for 110 rows) and
    # the dead sensor was warned of at every block.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode="hold", flat=8).fit(X, y)
    a = new[new["run"] == "c"].iloc[:200].copy()
    b = new[new["run"] == "d"].iloc[:200].copy()
    a.iloc[100:150, a.columns.get_loc("T2_C")] = a.iloc[100, a.columns.get_loc("T2_C")]
    b.iloc[:60, b.columns.get_loc("T1_C")] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = guard.predict_checked(a)
    stream = RunStream(guard)
    stream.predict_checked(a.iloc[:95])
    got = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for i in range(0, 100, 5):
            block = pd.concat([a.iloc[95 + i : 100 + i], b.iloc[i : i + 5]])
            out = stream.predict_checked(block)
            got.append(out[block["run"].to_numpy() == "c"])
    got = pd.concat(got)
    np.testing.assert_allclose(got["prediction"], whole["prediction"].iloc[95:195])
    assert got["reason"].tolist() == whole["reason"].iloc[95:195].tolist()
    dead = [w for w in caught if "reads no finite value" in str(w.message)]
    assert len(dead) == 1


def test_a_sensor_dead_for_good_keeps_the_stream_bounded_and_refit_forgets(data):
    # In hold mode the rows back to a dead sensor's last reading were kept,
    # so the cost grew with the run again; a refit kept the old runs.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    run = pd.concat([new[new["run"] == "c"]] * 12, ignore_index=True)
    run["time_s"] = np.arange(len(run)) * 60.0
    run.iloc[10:, run.columns.get_loc("T2_C")] = np.nan
    stream = RunStream(guard, copy=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for block in _blocks(run, [500]):
            stream.predict(block)
    assert len(guard.stream_runs_["c"]["rows"]) <= 3600
    guard.fit(X, y)
    assert not hasattr(guard, "stream_runs_")


def test_a_finding_coming_back_often_is_said_every_ten_minutes(data):
    # A sensor hovering at the edge of its range was said at every return
    # (247 warnings in 100 minutes of one run).
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression()).fit(X, y)
    run = new[new["run"] == "c"].iloc[:100].copy()  # 99 min at 60 s
    col = run.columns.get_loc("T2_C")
    run.iloc[::3, col] += 30.0  # out of range at every third row
    stream = RunStream(guard)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for block in _blocks(run, [2]):
            stream.predict(block)
    said = [
        w
        for w in caught
        if issubclass(w.category, SensorRangeWarning) and "'T2_C'" in str(w.message)
    ]
    assert 2 <= len(said) <= 10


def test_a_finding_that_ended_is_not_said_again(data):
    # An independent check: a sensor reading NaN for 3 rows, streamed row by
    # row through a guard around a sequence model (given the run so far),
    # was said again every 10 minutes until the run ended, hours after the
    # sensor read again (and its second row again, "1 row" -> "2 rows").
    X, y, _, new = data
    lag = LagRidgeCV(time_constant_sets=[(900.0, 3600.0)])
    guard = GuardedRegressor(lag, mode="hold").fit(X, y)
    run = new[new["run"] == "c"].iloc[:200].copy()
    run.iloc[100:103, run.columns.get_loc("T2_C")] = np.nan
    stream = RunStream(guard)
    # The guard keeps each run so far itself (remember_runs).
    assert stream.mode_ == "incremental"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for block in _blocks(run, [1]):
            stream.predict_checked(block)
    said = [w for w in caught if "reading missing" in str(w.message)]
    assert len(said) == 1, [str(w.message)[:120] for w in said]


def test_a_clock_reset_mid_run_is_told_from_a_new_run(data):
    # An independent check: a controller restarting mid-run numbered time_s
    # from 0 again under the same label, the machine warm; the stream said
    # only a UserWarning that a new run starts (not caught by a filter on
    # GuardWarning), and the lag model's compensation was 34 µm off.
    X, y, lag, new = data
    run = new[new["run"] == "c"]
    reset = run.copy()
    reset.loc[reset.index[150] :, "time_s"] -= reset["time_s"].iloc[150]
    for model in (lag, GuardedRegressor(lag, mode="hold").fit(X, y)):
        stream = RunStream(model)
        with pytest.warns(RunStartWarning, match=r"starts again") as caught:
            for block in _blocks(reset, [10]):
                stream.predict(block)
        said = [str(w.message) for w in caught if "starts again" in str(w.message)]
        assert len(said) == 1
        assert "go on from the earlier run's last ones" in said[0]
        assert "time_s going on from 8940" in said[0]
        # The same label given again from its start, the machine cold:
        # a new run, without the hint.
        stream = RunStream(model)
        for block in _blocks(run, [10]):
            stream.predict(block)
        with pytest.warns(RunStartWarning, match=r"starts again") as caught:
            stream.predict(run.iloc[:10])
        said = [str(w.message) for w in caught if "starts again" in str(w.message)]
        assert len(said) == 1 and "go on" not in said[0]


def test_a_fault_at_the_run_start_streams_as_the_whole_run(data):
    # An independent check: a guard in hold mode around a sequence model,
    # kept whole and replayed every block, held the sensor's latest good
    # reading over its faulty first rows (the whole run: its first good
    # one), moving the model's run start at every block: up to 8 µm off
    # for the rest of the run, ok=True.
    X, y, _, new = data
    run = new[new["run"] == "c"].iloc[:120].copy()
    col = run.columns.get_loc("T2_C")
    run.iloc[:10, col] = np.nan
    glitch = run.copy()
    glitch.iloc[0, glitch.columns.get_loc("T1_C")] += 0.5
    for model in (
        LagRidgeCV(time_constant_sets=[(900.0, 3600.0)]),
        TransferFunctionRegressor(speed_column="spindle_rpm"),
    ):
        guard = GuardedRegressor(model, mode="hold").fit(X, y)
        for table in (run, glitch):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                whole = guard.predict_checked(table)
                stream = RunStream(guard)
                got = pd.concat(
                    [stream.predict_checked(b) for b in _blocks(table, [1])]
                )
            # (Before the sensor's first reading the whole run holds the
            # next; the stream cannot: the rows after it are compared.)
            got, whole = got.iloc[10:], whole.iloc[10:]
            np.testing.assert_allclose(
                got["prediction"], whole["prediction"], atol=1e-9
            )
            assert got["ok"].tolist() == whole["ok"].tolist()


def test_a_fault_of_a_run_given_again_under_its_label_is_said(data):
    # An independent check: a finding was said again 600 s of time_s after
    # it was last said; a run label given again from 0 (or after forget)
    # took the time back, and a fault of the new run was never said.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    run = new[new["run"] == "c"].iloc[:240].copy()
    col = run.columns.get_loc("T2_C")
    late, early = run.copy(), run.copy()
    late.iloc[200, col] = 1e6
    early.iloc[50, col] = 1e6
    for restart in ("forget", "again"):
        stream = RunStream(guard)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for block in _blocks(late, [1]):
                stream.predict_checked(block)
            if restart == "forget":
                stream.forget("c")
            for block in _blocks(early, [1]):
                stream.predict_checked(block)
        spikes = [
            str(w.message)
            for w in caught
            if "value 1e+06" in str(w.message) and "training range" in str(w.message)
        ]
        t1, t2 = run["time_s"].iloc[200], run["time_s"].iloc[50]
        assert len(spikes) == 2, (restart, spikes)
        assert f"time_s={t1:g} " in spikes[0] and f"time_s={t2:g} " in spikes[1]


def _guarded_lag_stream(data, rows):
    """A stream of a guard around a lag model that has been given the first
    ``rows`` rows of the new run 'c', and that run."""
    X, y, _, new = data
    guard = GuardedRegressor(LagRidgeCV(time_constant_sets=[(900.0,)])).fit(X, y)
    run = new[new["run"] == "c"]
    stream = RunStream(guard)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stream.predict(run.iloc[:rows])
    return stream, run


def test_rows_out_of_order_in_a_block_are_named_in_the_block(data):
    # An independent check: the guard kept the run so far and named the
    # row by its place behind those ("row 101" of a 3-row block).
    stream, run = _guarded_lag_stream(data, 100)
    block = run.iloc[100:103].iloc[[0, 2, 1]]
    with pytest.raises(ValueError, match=r"in run 'c' row 2 has time_s=6060 after"):
        stream.predict(block)


def test_a_second_fault_is_said_with_its_own_time(data):
    # An independent check: two spikes on one sensor 100 minutes apart,
    # streamed row by row through a guard around a sequence model: the
    # second was said "at time_s=<the first's time> (...; 2 rows in 2
    # stretches)", the guard describing the run so far, not the new row.
    X, y, _, new = data
    lag = LagRidgeCV(time_constant_sets=[(900.0, 3600.0)])
    guard = GuardedRegressor(lag, mode="hold").fit(X, y)
    run = new[new["run"] == "c"].iloc[:240].copy()
    col = run.columns.get_loc("T2_C")
    run.iloc[[60, 160], col] = 1e6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = guard.predict_checked(run)
    stream = RunStream(guard)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = pd.concat([stream.predict_checked(b) for b in _blocks(run, [1])])
    said = [str(w.message) for w in caught if issubclass(w.category, GuardWarning)]
    t1, t2 = run["time_s"].iloc[60], run["time_s"].iloc[160]
    range_said = [m for m in said if "training range" in m and "value 1e+06" in m]
    assert len(range_said) == 2, range_said
    assert f"at time_s={t1:g} " in range_said[0]
    assert f"at time_s={t2:g} " in range_said[1]
    assert "2 rows" not in range_said[1]
    # The checked predictions are those of the whole run.
    assert got["ok"].tolist() == whole["ok"].tolist()
    np.testing.assert_allclose(got["prediction"], whole["prediction"], atol=1e-12)


def test_a_guard_inside_a_pipeline_streams_the_run_so_far(data):
    # Streamed as a static model, its jump and flat-line checks saw one
    # block at a time: a stuck sensor and a spike were missed.
    from sklearn.preprocessing import StandardScaler

    X, y, _, new = data
    pipe = make_pipeline(
        StandardScaler(), GuardedRegressor(LinearRegression(), mode="hold", flat=8)
    ).set_output(transform="pandas")
    pipe.fit(X.set_index(["run", "time_s"]), y.to_numpy())
    run = new[new["run"] == "c"].set_index(["run", "time_s"])
    col = run.columns.get_loc("T1_C")
    run.iloc[40:70, col] = run.iloc[40, col]  # stuck
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = pipe.predict(run)
        stream = RunStream(pipe)
        assert stream.mode_ == "history"
        got = np.concatenate([stream.predict(b) for b in _blocks(run, [1])])
    np.testing.assert_allclose(got, whole, atol=1e-12)


def test_a_jittering_logger_streams_as_the_whole_run(data):
    # The flat-line window followed each call's median period: a logger
    # jittering by 5% moved it by a sample, and 4-33 rows differed.
    X, y, _, new = data
    guard = GuardedRegressor(LinearRegression(), mode="hold", flat=18).fit(X, y)
    rng = np.random.default_rng(6)
    run = new[new["run"] == "c"].copy()
    run["time_s"] = np.r_[0.0, np.cumsum(60 * (1 + 0.05 * rng.uniform(-1, 1, 359)))]
    col = run.columns.get_loc("T2_C")
    for at, n in ((40, 18), (120, 19), (200, 20), (280, 21)):
        run.iloc[at : at + n, col] = run.iloc[at, col]  # stuck about the window
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = guard.predict_checked(run)
        stream = RunStream(guard)
        got = pd.concat([stream.predict_checked(b) for b in _blocks(run, [5])])
    assert got["ok"].tolist() == whole["ok"].tolist()
    np.testing.assert_allclose(got["prediction"], whole["prediction"], atol=1e-12)


def test_a_stream_pickles_mid_run(data):
    # A controller restarting reloads the stream and goes on with the run.
    _, _, model, new = data
    run = new[new["run"] == "c"]
    whole = model.predict(run)
    stream = RunStream(model)
    first = stream.predict(run.iloc[:100])
    again = pickle.loads(pickle.dumps(stream))
    rest = again.predict(run.iloc[100:])
    np.testing.assert_allclose(np.r_[first, rest], whole, atol=1e-9)


def test_blocks_need_run_labels_and_times(data):
    # Without times a block given twice was taken as more of the run: the
    # compensation was off by 1.6 µm for hundreds of rows, silently.
    _, _, model, new = data
    stream = RunStream(model)
    with pytest.raises(ValueError, match="RunStream needs the blocks as run tables"):
        stream.predict(new.drop(columns=["run"]).to_numpy(), groups=new["run"])
    with pytest.raises(ValueError, match="RunStream needs every row's run label"):
        stream.predict(new.drop(columns=["run"]))
    with pytest.raises(ValueError, match="RunStream needs every row's time_s"):
        stream.predict(new.drop(columns=["time_s"]))
    with pytest.raises(ValueError, match="The block given to RunStream holds no rows"):
        stream.predict(new.iloc[:0])


@pytest.mark.parametrize("how", ["sequence", "guard", "history"])
def test_a_block_given_twice_or_out_of_order_is_refused(data, how):
    X, y, lag, new = data
    model = {
        "sequence": lambda: lag,
        "guard": lambda: GuardedRegressor(lag).fit(X, y),
        "history": lambda: make_pipeline(GuardedRegressor(lag)).fit(X, y),
    }[how]()
    run = new[new["run"] == "c"]
    whole = model.predict(run)
    stream = RunStream(model)
    assert stream.mode_ == ("history" if how == "history" else "incremental")
    blocks = _blocks(run, [20])
    got = [stream.predict(blocks[0]), stream.predict(blocks[1])]
    # (The first block again would start the run anew: see below.)
    for bad in (blocks[1], blocks[1].iloc[5:], blocks[0].iloc[3:]):
        with pytest.raises(ValueError, match=r"Run 'c': the block starts at time_s="):
            stream.predict(bad)
    got += [stream.predict(b) for b in blocks[2:]]  # the stream goes on
    np.testing.assert_allclose(np.concatenate(got), whole, atol=1e-9)
    # The label again from its start: a new run, as the whole run alone.
    blocks = _blocks(run, [33])
    with pytest.warns(UserWarning, match=r"Run 'c' starts again at time_s=0"):
        again = [stream.predict(blocks[0])]
    again += [stream.predict(b) for b in blocks[1:]]
    np.testing.assert_allclose(np.concatenate(again), whole, atol=1e-9)


def test_a_label_of_another_type_is_said(data):
    # Run 1 given on as "1" restarted the run, said only as a late start.
    _, _, lag, new = data
    run = new[new["run"] == "c"].assign(run=1)
    stream = RunStream(lag)
    stream.predict(run.iloc[:10])
    with pytest.warns(UserWarning, match=r"Run '1' \(str\) is new to the stream, "):
        stream.predict(run.iloc[10:20].assign(run="1"))
    assert stream.runs_ == [1, "1"]
    stream = RunStream(lag)
    stream.predict(run.iloc[:10].assign(run=1.0))
    with pytest.warns(UserWarning, match=r"Run '1' \(str\) .* holds run 1\.0 \("):
        stream.predict(run.iloc[10:20].assign(run="1"))
    stream = RunStream(lag)
    stream.predict(run.iloc[:10])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        stream.predict(run.iloc[10:20].assign(run=1.0))  # equal to 1: run 1
    assert stream.runs_ == [1]


def test_forget_frees_a_run(data):
    X, y, _, new = data
    guard = GuardedRegressor(TransferFunctionRegressor()).fit(X, y)
    run = new[new["run"] == "c"]
    stream = RunStream(guard)
    stream.predict(run.iloc[:50])
    assert stream.runs_ == ["c"]
    stream.forget("c")
    assert stream.runs_ == []
    with pytest.raises(KeyError, match="The stream holds no run 'c'"):
        stream.forget("c")
    # Forgotten, its next block is a run that starts late.
    with pytest.warns(UserWarning, match="start"):
        stream.predict(run.iloc[50:60])
    lag = RunStream(data[2])
    lag.predict(run.iloc[:50])
    lag.forget()
    assert "c" not in lag.model_.lag_features_.run_states_


def test_interleaved_rows_of_two_runs(data):
    _, _, model, new = data
    whole = model.predict(new)
    stream = RunStream(model)
    # Rows of c and d alternating, in time order: the predictions come back
    # in the block's order.
    mixed = new.sort_values(["time_s", "run"], kind="stable")
    got = np.concatenate([stream.predict(b) for b in _blocks(mixed, [40])])
    np.testing.assert_allclose(got, whole[mixed.index.to_numpy()], atol=1e-9)


def test_static_models_get_the_new_rows_alone(data):
    X, y, _, new = data
    static = LinearRegression().fit(X.set_index(["run", "time_s"]), y)
    table = new.set_index(["run", "time_s"])
    stream = RunStream(static)
    assert stream.mode_ == "static"
    got = np.concatenate([stream.predict(b) for b in _blocks(table, [25])])
    np.testing.assert_allclose(got, static.predict(table), atol=1e-9)
    assert not stream._history


def test_checked_predictions_of_a_guard_and_a_late_start_said_once(data):
    X, y, lag, new = data
    # (mode="hold" would differ at the start: a reading faulty from a run's
    # first row takes the next good one, which a later block holds.)
    guard = GuardedRegressor(lag, mode="clip").fit(X, y)
    late = new[new["run"] == "c"].iloc[60:]  # a run given from 1 h on
    whole = guard.predict_checked(late)
    stream = RunStream(guard)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parts = [stream.predict_checked(b) for b in _blocks(late, [30])]
    checked = pd.concat(parts)
    pd.testing.assert_frame_equal(checked, whole)
    starts = [w for w in caught if "start" in str(w.message)]
    assert len(starts) == 1, [str(w.message) for w in starts]
    with pytest.raises(AttributeError, match="has no predict_checked"):
        RunStream(lag).predict_checked(late)


def test_a_stream_given_the_runs_so_far_is_not_saved_to_skops(data, tmp_path):
    # skops stores no pandas tables: its error ("no default __reduce__ due to
    # non-trivial __cinit__") named nothing of the model.
    from skthermal.io import save

    X, y, _, new = data
    guard = GuardedRegressor(LagRidgeCV(time_constant_sets=[(900.0,)])).fit(X, y)
    static = GuardedRegressor(LinearRegression()).fit(X, y)
    streams = {}
    for name, model in [
        ("guard", guard),
        ("pipeline", make_pipeline(guard)),
        ("static", static),
    ]:
        streams[name] = RunStream(model)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            streams[name].predict(new[new["run"] == "c"].iloc[:10])
    # Any stream that has seen a block: after a warning, skops' own error
    # named an internal key of the findings said and advised a refit (an
    # independent check).
    for name in ("guard", "pipeline", "static"):
        with pytest.raises(
            TypeError, match=r"RunStream keeps the runs it streams .* joblib"
        ):
            save(streams[name], tmp_path / "stream.skops")
    # Nor the guard itself: restarted mid-run, its sequence model would be
    # wrong from there on.
    with pytest.raises(
        TypeError, match=r"GuardedRegressor keeps the runs it streams .* joblib"
    ):
        save(streams["guard"].model_, tmp_path / "guard.skops")
    # A guard around a static model restarts its checks only (documented).
    save(streams["static"].model_, tmp_path / "static.skops")
    save(RunStream(static), tmp_path / "fresh.skops")  # no block yet


def test_a_row_at_the_last_time_is_refused_by_a_stream_of_the_runs_so_far(data):
    # The model given the run so far refused it itself, naming "row 20" of
    # the stream's run so far, which the controller never gave.
    X, y, _, _ = data
    stream, run = _guarded_lag_stream(data, 20)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(
            ValueError, match=r"Run 'c': the block starts at time_s=1140, not after"
        ):
            stream.predict(run.iloc[19:20])
        # A guard around a static model takes it (a record logged twice).
        static = RunStream(GuardedRegressor(LinearRegression()).fit(X, y))
        static.predict(run.iloc[:20])
        static.predict(run.iloc[19:20])
