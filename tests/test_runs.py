"""Tests of the run helpers shared by the run-aware estimators."""

import re
import warnings

import numpy as np
import pandas as pd
import pytest

from skthermal.utils._runs import (
    RunMemory,
    check_numeric_columns,
    check_positive_numbers,
    check_time_order,
    continued_runs,
    extract_runs,
    fitted_sample_periods,
    run_key,
    run_memory,
    run_slices,
    run_times,
)


def table(times, runs, values=None):
    n = len(times)
    values = np.arange(2.0 * n).reshape(n, 2) if values is None else values
    index = pd.MultiIndex.from_arrays([runs, times], names=["run", "time_s"])
    return pd.DataFrame(values, columns=["T1", "T2"], index=index)


def test_string_column_named_with_its_value():
    df = pd.DataFrame({"T1": [20.0, 21.0, 22.0], "T2": ["20.5", "hot", "21"]})
    with pytest.raises(ValueError, match=r"Column 'T2' is not numeric.*row 1.*'hot'"):
        extract_runs(df)
    # Datetimes and durations would convert to nanoseconds.
    stamps = pd.date_range("2024-01-01", periods=3, freq="min")
    for values in (stamps, stamps - stamps[0]):
        with pytest.raises(ValueError, match=r"Column 'T2' holds \w+64"):
            check_numeric_columns(df.assign(T2=values))


def test_complex_columns_are_named():
    df = pd.DataFrame({"a": [1.0, 2.0], "b": np.array([1, 2], dtype=complex)})
    with pytest.raises(ValueError, match=r"Column 'b' holds complex numbers"):
        extract_runs(df)


def test_targets_that_are_not_numbers_are_named():
    # scikit-learn said "could not convert string to float: '0,5'", naming
    # no column or row; a timedelta target was taken as nanoseconds.
    X = pd.DataFrame({"run": ["a"] * 3, "time_s": [0.0, 60.0, 120.0], "T1_C": 1.0})
    comma = pd.Series(["0.0", "0,5", "1.0"], name="disp_y_um")
    with pytest.raises(
        ValueError,
        match=r"target 'disp_y_um' is not numeric: row 1, run 'a', time_s=60 "
        r"holds '0,5', a number with a decimal comma",
    ):
        extract_runs(X, y=comma)
    clock = pd.Series(pd.to_timedelta([0, 1, 2], unit="s"), name="disp_y_um")
    with pytest.raises(
        ValueError, match=r"'disp_y_um' holds timedelta64.* not numbers"
    ):
        extract_runs(X, y=clock)
    extract_runs(X, y=pd.Series(["0.0", "0.5", "1.0"]))  # numbers as text pass


def test_numeric_boolean_and_numeric_object_columns_pass():
    df = pd.DataFrame(
        {
            "a": [1.0, 2.0],
            "b": [True, False],
            "c": np.array([1, 2], dtype=object),
            "run": ["r", "r"],  # labels may be strings
        }
    )
    X, groups = extract_runs(df)
    assert list(X.columns) == ["a", "b", "c"] and groups.tolist() == ["r", "r"]
    # Plain arrays: numbers held as text pass; text is named with its row
    # and column (a run table's values with its run labels, say), and other
    # objects are left to numpy.
    check_numeric_columns(np.array([["1.5", 2.0]], dtype=object))
    with pytest.raises(
        ValueError,
        match=r"plain array holding text: column 1, row "
        r"0 holds 'x'.*run labels go in groups=",
    ):
        check_numeric_columns(np.array([[1.0, "x"]], dtype=object))
    check_numeric_columns(np.array([[{"a": 1}]], dtype=object))


@pytest.mark.parametrize(
    "labels, message",
    [
        # Sorted by time, runs interleaved: string labels are named like
        # numbers.
        (["a", "b", "a", "b"], r"rows of run 'a' are not contiguous"),
        ([0, 1, 0, 1], r"rows of run 0 are not contiguous"),
        (np.array(["a", None, "a", "a"], dtype=object), r"Row 1 has no run label"),
        (np.array(["a", "a", np.nan, np.nan], dtype=object), r"Row 2 has no run"),
        ([1.0, 1.0, np.nan, 2.0], r"Row 2 has no run label"),
        (
            np.array(["R0", "R0", 1, 1], dtype=object),
            r"Run labels mix kinds: row 0 has 'R0' \(string\), row 2 has 1",
        ),
    ],
)
def test_bad_run_labels_are_named(labels, message):
    with pytest.raises(ValueError, match=message):
        run_slices(labels)


def test_datetime_times_are_an_error_not_nanoseconds():
    t = pd.Timestamp("2024-01-01") + pd.to_timedelta([0, 60, 120], unit="s")
    df = pd.DataFrame({"run": "r", "time_s": t, "T1": [20.0, 20.5, 21.0]})
    with pytest.raises(ValueError, match=r"'time_s' holds datetime64.*seconds"):
        extract_runs(df)
    with pytest.raises(ValueError, match=r"'time_s' holds timedelta64"):
        extract_runs(df.assign(time_s=t - t[0]))


def test_time_going_backwards_is_an_error():
    df = table([0.0, 15.0, 10.0], ["a", "a", "a"])
    X, groups = extract_runs(df)
    with pytest.raises(ValueError, match=r"run 'a' row 2 has time_s=10 after 15"):
        check_time_order(X, groups)


def memory_and_plan(fit_df, pred_df):
    Xf, gf = extract_runs(fit_df)
    sl, lab = run_slices(gf, len(Xf))
    memory = run_memory(Xf.to_numpy(), sl, lab, Xf)
    Xp, gp = extract_runs(pred_df)
    sl, lab = run_slices(gp, len(Xp))
    return continued_runs("Model", Xp.to_numpy(), sl, lab, run_times(Xp, sl), memory)


def test_seen_label_continues_unless_it_restarts():
    fit = table([0.0, 15.0, 30.0], ["a"] * 3)
    assert memory_and_plan(fit, table([45.0, 60.0], ["a"] * 2)) == ["a"]
    assert memory_and_plan(fit, table([0.0, 15.0], ["a"] * 2)) == [None]
    with pytest.raises(
        ValueError, match=r"Run .a. starts at time_s=15, inside the span 0-30"
    ):
        memory_and_plan(fit, table([15.0, 30.0], ["a"] * 2))


def test_seen_label_starting_before_its_training_span_starts_there():
    # Fit had a later part of the run (a cut), predict an earlier one: it is
    # predicted from its own first row, as the run's start (the advice of
    # the error for a run inside its span, "pass the run from its start").
    # It says so: in cross-validation a splitter that cuts runs does this.
    fit = table([100.0, 115.0, 130.0], ["a"] * 3)
    with pytest.warns(
        UserWarning,
        match=r"starts before its rows seen in fit \(from time_s=100\).*from its "
        r"start\. .*GroupKFold",
    ):
        assert memory_and_plan(fit, table([0.0, 15.0], ["a"] * 2)) == [None]
    whole = table([0.0, 15.0, 100.0, 115.0, 130.0, 145.0], ["a"] * 6)
    with pytest.warns(UserWarning, match="from its start"):
        assert memory_and_plan(fit, whole) == [None]
    with pytest.warns(UserWarning, match=r"at time_s=50, not 0"):
        assert memory_and_plan(fit, table([50.0, 65.0], ["a"] * 2)) == [None]


def test_new_run_not_starting_at_zero_warns():
    fit = table([0.0, 15.0, 30.0], ["a"] * 3)
    with pytest.warns(UserWarning, match=r"Run 'b'.*time_s=45, not 0"):
        assert memory_and_plan(fit, table([45.0, 60.0], ["b"] * 2)) == [None]


def test_without_time_the_first_row_tells_restart_from_continuation():
    fit = pd.DataFrame({"T1": [1.0, 2.0, 3.0], "run": "a"})
    pred = pd.DataFrame({"T1": [4.0, 5.0], "run": "a"})
    assert memory_and_plan(fit, pred) == ["a"]
    assert memory_and_plan(fit, fit) == [None]


def _split_record(n=90, cut=55):
    """One labelled run with times, cut chronologically."""
    t = np.arange(n) * 60.0
    rpm = np.where((t // 900) % 2 == 0, 4000.0, 0.0)
    heat = np.cumsum(rpm) / 5e4
    table = pd.DataFrame(
        {
            "run": "rec",
            "time_s": t,
            "T1_C": 20 + heat + 0.3 * np.sin(t / 500.0),
            "T2_C": 21 + 0.6 * heat,
            "spindle_rpm": rpm,
        }
    )
    y = 2.0 * table["T1_C"].to_numpy() - 1.5 * table["T2_C"].to_numpy() + heat**0.5
    return table, y, cut


def _sequence_models():
    from sklearn.linear_model import LinearRegression

    from skthermal.ensemble import ModularRegressor
    from skthermal.fuzzy import ANFISRegressor
    from skthermal.linear_model import TransferFunctionRegressor
    from skthermal.models import RunStartRegressor, make_model

    return {
        "TransferFunctionRegressor": TransferFunctionRegressor(
            speed_column="spindle_rpm", n_grid=4, max_iter=3
        ),
        "ModularRegressor": ModularRegressor(),
        "RunStartRegressor": RunStartRegressor(LinearRegression()),
        "lag-ridge": make_model("lag-ridge"),
        "Grey-ANFIS": ANFISRegressor(grey=True, n_clusters=2, epochs=3, random_state=0),
    }


@pytest.mark.parametrize("name", list(_sequence_models()))
def test_sequence_models_continue_a_training_run(name):
    # After a chronological split, the later rows predicted alone are what
    # predicting the whole run gives on them.
    import warnings

    model = _sequence_models()[name]
    table, y, cut = _split_record()
    model.fit(table.iloc[:cut], y[:cut])
    whole = model.predict(table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tail = model.predict(table.iloc[cut:])
    np.testing.assert_allclose(tail, whole[cut:], rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="inside the span"):
        model.predict(table.iloc[10:])
    with pytest.warns(UserWarning, match="not 0"):
        model.predict(table.iloc[cut:].assign(run="new"))


@pytest.mark.parametrize("pause", [3, 12, 25])
def test_lag_models_continue_a_training_run_after_a_pause(pause):
    # Rows of a training run given alone after a pause are predicted as in
    # the whole run with that pause: the inputs ramp across it in both.
    from skthermal.preprocessing import LagFeatures, make_lag_pipeline

    table, y, cut = _split_record()
    later = table.iloc[cut + pause :]
    record = pd.concat([table.iloc[:cut], later])
    for model in (
        make_lag_pipeline(time_constant_sets=[(300.0, 1800.0)]),
        LagFeatures(time_constants=[300.0, 1800.0], drivers=["spindle_rpm"]),
    ):
        model.fit(table.iloc[:cut], y[:cut])
        use = model.transform if hasattr(model, "transform") else model.predict
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the gap is named: known here
            whole = use(record)[cut:]
            alone = use(later)
        np.testing.assert_allclose(alone, whole, rtol=1e-9, atol=1e-9)


def test_one_row_after_a_pause_is_predicted_as_in_a_longer_block():
    # A controller predicts one new sample at a time: a block of one or two
    # rows after a pause is judged against the fitted sampling period.
    from skthermal.linear_model import TransferFunctionRegressor
    from skthermal.preprocessing import make_lag_pipeline

    table, y, cut = _split_record()
    start = cut + 10  # a pause of 10 samples
    for model in (
        make_lag_pipeline(time_constant_sets=[(300.0, 1800.0)]),
        TransferFunctionRegressor(speed_column="spindle_rpm", n_grid=4, max_iter=3),
    ):
        model.fit(table.iloc[:cut], y[:cut])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            one = model.predict(table.iloc[start : start + 1])[0]
            more = model.predict(table.iloc[start : start + 4])[0]
        assert one == pytest.approx(more, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("name", list(_sequence_models()))
def test_sequence_models_refuse_rows_out_of_time_order(name):
    # Rows of a run shuffled: the run start would be a random row.
    model = _sequence_models()[name]
    table, y, cut = _split_record()
    order = np.r_[1, 0, 2:cut]
    with pytest.raises(ValueError, match="time_s must increase"):
        model.fit(table.iloc[order], y[order])
    model.fit(table.iloc[:cut], y[:cut])
    with pytest.raises(ValueError, match="time_s must increase"):
        model.predict(table.iloc[order].assign(run="new"))


@pytest.mark.parametrize("dtype", ["float64", "Float64"])
def test_missing_reading_is_named_with_its_run_and_time(dtype):
    df = pd.DataFrame(
        {
            "run": ["a"] * 3 + ["b"] * 3,
            "time_s": [0.0, 60.0, 120.0] * 2,
            "T1_C": [20.0, 20.5, 21.0, 20.0, 20.2, 20.4],
            "T2_C": [19.0, 19.1, 19.2, 19.0, 19.1, 19.2],
        }
    ).astype({"T2_C": dtype})
    df.loc[4, "T2_C"] = np.nan if dtype == "float64" else pd.NA
    with pytest.raises(
        ValueError, match=r"'T2_C' is missing \(NaN\) at row 4, run 'b', time_s=60"
    ):
        extract_runs(df)
    df.loc[4, "T2_C"] = np.inf
    with pytest.raises(ValueError, match=r"'T2_C' is inf at row 4"):
        extract_runs(df)
    X, _ = extract_runs(df, finite=False)  # models that bridge dropouts
    assert X.shape == (6, 2)


def test_run_labels_of_the_wrong_shape_are_named():
    table, y, cut = _split_record()
    for groups in (["a"] * (len(table) - 1), np.zeros((len(table), 2))):
        with pytest.raises(ValueError, match="run labels \\(groups\\) of shape"):
            extract_runs(table, groups)


def test_missing_time_duplicate_columns_and_no_rows_are_named():
    table, y, _ = _split_record()
    bad = table.copy()
    bad.loc[50, "time_s"] = np.nan
    with pytest.raises(ValueError, match=r"time_s is nan at row 50, run 'rec'"):
        extract_runs(bad)
    with pytest.raises(ValueError, match=r"duplicate column name\(s\) \['T1_C'\]"):
        extract_runs(pd.concat([table, table[["T1_C"]]], axis=1))
    for name, model in _regressors().items():
        with pytest.raises(ValueError, match="time_s is nan at row 50"):
            model.fit(bad, y)
        with pytest.raises(ValueError, match="0 sample"):
            model.fit(table.iloc[:0], y[:0])


def _regressors():
    from skthermal import (
        ANFISRegressor,
        GNNMCIRegressor,
        GreyPSORegressor,
        LagRidgeCV,
        ModularRegressor,
        TransferFunctionRegressor,
        UpdateRegressor,
    )

    return {
        "ANFISRegressor": ANFISRegressor(n_clusters=2, epochs=2),
        "GNNMCIRegressor": GNNMCIRegressor(),
        "GreyPSORegressor": GreyPSORegressor(),
        "LagRidgeCV": LagRidgeCV(),
        "ModularRegressor": ModularRegressor(),
        "TransferFunctionRegressor": TransferFunctionRegressor(),
        "UpdateRegressor": UpdateRegressor(),
    }


@pytest.mark.parametrize("name", list(_regressors()))
def test_missing_target_is_named_with_its_run_and_time(name):
    table, y, cut = _split_record()
    y = pd.Series(y, name="disp_ch1_um")
    y.iloc[7] = np.nan
    with pytest.raises(
        ValueError,
        match=r"target 'disp_ch1_um' is missing \(NaN\) at row 7, run .*time_s=",
    ):
        _regressors()[name].fit(table, y)


def _row_counting_models():
    """The models whose dynamics count rows, not seconds."""
    from skthermal.fuzzy import ANFISRegressor
    from skthermal.grey import GreyPSORegressor

    return {
        "GreyPSORegressor": GreyPSORegressor(calibration="ls"),
        "Grey-ANFIS": ANFISRegressor(grey=True, n_clusters=2, epochs=3, random_state=0),
    }


@pytest.mark.parametrize("name", ["GreyPSORegressor", "Grey-ANFIS"])
def test_models_counting_rows_warn_about_gaps(name):
    model = _row_counting_models()[name]
    table, y, cut = _split_record()
    keep = np.r_[0:20, 30:cut]  # 10 samples missing
    with pytest.warns(UserWarning, match=r"1 gap\(s\).*lasts 660 s.*counts rows"):
        model.fit(table.iloc[keep], y[keep])
    with pytest.warns(
        UserWarning, match=r"continues 1860 s after its last row the model knows"
    ):
        model.predict(table.iloc[cut + 30 :])
    # The gap in the training run does not make its sampling period look
    # longer (its median step, not its mean one).
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(table.iloc[cut:])


def test_lag_and_transfer_models_warn_about_a_pause_before_a_continued_run():
    # Rows of a training run given after a pause are predicted across it,
    # as a gap inside a run: named, as the models counting rows do.
    from skthermal.linear_model import TransferFunctionRegressor
    from skthermal.preprocessing import LagFeatures, make_lag_pipeline

    table, y, cut = _split_record()
    for model in (
        make_lag_pipeline(time_constant_sets=[(300.0, 1800.0)]),
        LagFeatures(time_constants=[300.0, 1800.0], drivers=["spindle_rpm"]),
        TransferFunctionRegressor(speed_column="spindle_rpm", n_grid=4, max_iter=3),
    ):
        model.fit(table.iloc[:cut], y[:cut])
        use = model.transform if hasattr(model, "transform") else model.predict
        name = type(model[-1] if hasattr(model, "steps") else model).__name__
        with pytest.warns(UserWarning) as record:
            use(table.iloc[cut + 30 :])
        messages = [str(w.message) for w in record]
        assert any(
            m.startswith(f"{name}: run ")
            and "continues 1860 s after its last" in m
            and "filters across the pause" in m
            for m in messages
        ), messages
        # Each warning once, under the name of the estimator called.
        assert sum("continues 1860 s" in m for m in messages) == 1
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            use(table.iloc[cut:])  # no pause: no warning


@pytest.mark.parametrize("name", ["GreyPSORegressor", "Grey-ANFIS"])
def test_models_counting_rows_warn_about_another_sampling_period(name):
    model = _row_counting_models()[name]
    table, y, cut = _split_record()
    model.fit(table.iloc[:cut], y[:cut])
    sparse = table.iloc[::4].assign(run="every 4th row")
    with pytest.warns(
        UserWarning,
        match=r"run 'every 4th row' is sampled every 240 s, the period of most "
        r"of the training runs' rows is 60 s\. The model counts rows.*4 times too "
        r"slow",
    ):
        model.predict(sparse)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(table.assign(run="same period"))
    # Several runs off: the warning named one of them only.
    two = pd.concat([sparse, table.iloc[1::3].assign(run="every 3rd row")])
    with pytest.warns(UserWarning, match=r"every 4th row' \(and 1 more run alike\)"):
        model.predict(two)
    # In fit, runs logged at other periods than the others.
    both = pd.concat([table.iloc[:cut], sparse])
    y_both = np.r_[y[:cut], y[::4]]
    with pytest.warns(
        UserWarning,
        match=r"sampled every 240 s, the period of most of the runs' rows is 60 s",
    ):
        model.fit(both, y_both)
    # predict compares with the same period as fit: that of most training
    # rows (it took the median over the runs, 240 s with two sparse runs,
    # and advised resampling to it where fit had advised 60 s).
    more = pd.concat([both, table.iloc[2::4].assign(run="another 4th row")])
    with pytest.warns(UserWarning, match="the period of most of the runs' rows"):
        model.fit(more, np.r_[y_both, y[2::4]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(table.assign(run="same period"))


def _object_array(values):
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def test_tuple_and_timestamp_run_labels_are_runs():
    # Tuples: one kind of label, not "mixed" ones (was a bare StopIteration).
    slices, labels = run_slices(_object_array([("a", 1), ("a", 1), ("b", 2)]))
    assert labels == [("a", 1), ("b", 2)] and slices[1] == slice(2, 3)
    with pytest.raises(ValueError, match=r"mix kinds: row 0 has \('a', 1\) \(tuple"):
        run_slices(_object_array([("a", 1), "b"]))
    # Timestamps, whatever the resolution: Timestamps, not datetimes or
    # nanoseconds as plain ints.
    for stamps in (
        pd.to_datetime(["2024-05-02", "2024-05-02", "2024-05-03"]),
        pd.to_datetime(["2024-05-02"] * 2 + ["2024-05-03"]).as_unit("ns")
        + pd.to_timedelta([0, 0, 1], unit="ns"),
    ):
        _, labels = run_slices(stamps.to_numpy())
        assert all(type(lab) is pd.Timestamp for lab in labels)
        assert labels == [stamps[0], stamps[2]]


def test_run_memory_keys_any_label_as_a_model_file_holds():
    import json
    import pickle

    day = pd.Timestamp("2024-05-02 07:30")
    memory = RunMemory()
    for label in (day, ("a", 1), True, False, "r1", 3, 2.5):
        memory[label] = {"n": 1}
    # JSON-able keys that JSON gives back with their type (skops rebuilds
    # a key as type(key)(text)): a bool would come back True.
    assert {type(k) for k in memory} == {str, int, float}
    assert len(memory) == 7 and json.loads(json.dumps(list(memory)))
    # Found by the labels as given, in any form of the same instant.
    for label in (day, day.to_pydatetime(), day.to_datetime64(), np.int64(3)):
        assert label in memory and memory.get(label) == {"n": 1}
    assert memory[("a", 1)] == {"n": 1} and memory.get(("b", 2)) is None
    assert run_key(np.str_("r1")) == "r1" and run_key(False) == "False"
    copy = pickle.loads(pickle.dumps(memory))
    assert type(copy) is RunMemory and copy[day] == {"n": 1} and copy == memory
    # run_memory builds one.
    X = np.arange(6.0).reshape(3, 2)
    mem = run_memory(X, [slice(0, 2), slice(2, 3)], [day, None], None)
    assert type(mem) is RunMemory and list(mem) == [run_key(day)]


@pytest.mark.parametrize("kind", ["Timestamp", "tuple"])
@pytest.mark.parametrize("name", list(_sequence_models()))
def test_sequence_models_continue_runs_of_any_label(name, kind):
    model = _sequence_models()[name]
    table, y, cut = _split_record()
    label = pd.Timestamp("2024-05-02 07:30") if kind == "Timestamp" else ("m1", 2)
    table["run"] = _object_array([label] * len(table))
    model.fit(table.iloc[:cut], y[:cut])
    whole = model.predict(table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tail = model.predict(table.iloc[cut:])
    np.testing.assert_allclose(tail, whole[cut:], rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match=rf"Run {re.escape(repr(label))} starts"):
        model.predict(table.iloc[10:])


def test_one_row_runs_do_not_pull_the_fitted_period():
    # Runs a (60 s), b and c (one row each), d (30 s, uneven in fit order).
    df = table(
        [0.0, 60.0, 120.0, 0.0, 0.0, 0.0, 30.0, 60.0, 90.0],
        ["a"] * 3 + ["b", "c"] + ["d"] * 4,
    )
    X, groups = extract_runs(df)
    slices, labels = run_slices(groups, len(X))
    dts, period = fitted_sample_periods(X, groups, slices, None, "Model")
    assert period == 45.0  # the median of 60 and 30, not of 60, 1, 1, 30
    np.testing.assert_allclose(dts, [60.0, 45.0, 45.0, 30.0])
    # dt does not override the times.
    assert fitted_sample_periods(X, groups, slices, 5.0, "Model")[1] == 45.0
    # No run of two rows: dt, or an error naming the fix.
    ones = table([0.0, 0.0], ["b", "c"])
    X, groups = extract_runs(ones)
    slices, _ = run_slices(groups, 2)
    assert fitted_sample_periods(X, groups, slices, 5.0, "Model")[1] == 5.0
    with pytest.raises(ValueError, match=r"Model: no run has two rows.*dt="):
        fitted_sample_periods(X, groups, slices, None, "Model")
    # Without times: dt, else one second.
    bare = np.zeros((4, 1))
    dts, period = fitted_sample_periods(bare, None, [slice(0, 4)], None, "Model")
    assert period == 1.0 and dts.tolist() == [1.0]


@pytest.mark.parametrize(
    "values, kwargs, message",
    [
        ([1.0, -1.0], {}, r"finite numbers > 0.*Got -1.0 at position 1"),
        ([0.0], {}, r"Got 0.0 at position 0"),
        ([1.0, np.nan], {}, r"Got nan at position 1"),
        ([1.0, np.inf], {}, r"Got inf at position 1"),
        ([1.0, "2"], {}, r"Got '2' at position 1"),
        ([True], {}, r"Got True at position 0"),
        ([[1.0, 2.0]], {}, r"flat sequence"),
        ([], {"empty": False}, r"sequence of at least one finite number > 0"),
        ([1.0], {"size": 2}, r"must be a flat sequence of 2 finite.*Got 1 entries"),
        ([2.0, 1.0, 2.0], {"distinct": True}, r"each once.*repeats 2"),
    ],
)
def test_check_positive_numbers_names_the_entry(values, kwargs, message):
    with pytest.raises(ValueError, match=r"The 'p' parameter of Model must be"):
        check_positive_numbers(values, "p", "Model", **kwargs)
    with pytest.raises(ValueError, match=message):
        check_positive_numbers(values, "p", "Model", **kwargs)


def test_check_positive_numbers_returns_floats():
    out = check_positive_numbers((1, np.float32(2.5), 3), "p", "Model", size=3)
    assert out.dtype == float and out.tolist() == [1.0, 2.5, 3.0]


def test_continued_run_messages_name_the_method_called():
    fit = table([0.0, 15.0, 30.0], ["a"] * 3)
    Xf, gf = extract_runs(fit)
    sl, lab = run_slices(gf, 3)
    memory = run_memory(Xf.to_numpy(), sl, lab, Xf)
    late = table([45.0, 60.0], ["b"] * 2)
    Xp, gp = extract_runs(late)
    sl, lab = run_slices(gp, 2)
    args = (Xp.to_numpy(), sl, lab, run_times(Xp, sl), memory)
    with pytest.warns(UserWarning, match=r"Run 'b' given to Model\.predict start"):
        continued_runs("Model", *args)
    with pytest.warns(UserWarning, match=r"Run 'b' given to Step start") as record:
        continued_runs("Step", *args, method=None, stacklevel=2)
    assert record[0].filename == __file__


def test_a_reused_label_without_times_that_jumps_warns():
    # Numpy rows of a new run under a training run's label (labels numbered
    # from 0 again in a test set) are taken as that run's continuation; an
    # independent check got 4.5 µm instead of 0.7 without a word. A first row
    # far from the training run's last one says so; a real continuation
    # does not warn.
    t = np.linspace(0.0, 1.0, 50)
    X = np.c_[20 + 3 * t, 20 + 2 * t]
    groups = np.zeros(50, dtype=int)
    sl, lab = run_slices(groups, 50)
    memory = run_memory(X, sl, lab, X)
    new = X[:10] + 0.01  # another run, cold again
    sl, lab = run_slices(groups[:10], 10)
    message = (
        r"Run 0 given to M\.predict has the label.*by 2.99 in input 0 \(48.8 times"
    )
    with pytest.warns(UserWarning, match=message):
        assert continued_runs("M", new, sl, lab, None, memory) == [0]
    later = X[-1] + np.c_[3 * t, 2 * t][1:11] / 49
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert continued_runs("M", later, sl, lab, None, memory) == [0]
        # the training run again from its start: predicted anew, no warning
        assert continued_runs("M", X[:10], sl, lab, None, memory) == [None]


def _clock_indexed(table, kind):
    """``table`` (a run table) with its (run, time_s) as the index, the times
    as durations or time stamps, or as text."""
    frame = table.set_index(["run", "time_s"])
    t = frame.index.get_level_values("time_s")
    t = {
        "timedelta": pd.to_timedelta(t, unit="s"),
        "datetime": pd.Timestamp("2024-05-02") + pd.to_timedelta(t, unit="s"),
        "text": t.astype(str).astype(object).where(t != 120.0, "2 min"),
        # what read_parquet(dtype_backend="pyarrow") gives for a duration
        "arrow duration": pd.Series(pd.to_timedelta(t, unit="s")).astype(
            "duration[us][pyarrow]"
        ),
    }[kind]
    return frame.set_axis(
        pd.MultiIndex.from_arrays(
            [frame.index.get_level_values("run"), t], names=["run", "time_s"]
        )
    )


@pytest.mark.parametrize(
    "kind, message",
    [
        ("timedelta", r"'time_s' index level holds timedelta64\[\w+\] values.*seconds"),
        ("datetime", r"'time_s' index level holds datetime64\[\w+\] values.*seconds"),
        ("text", r"'time_s' index level is not numeric: row 2 holds '2 min'"),
        (
            "arrow duration",
            r"'time_s' index level holds duration\[us\]\[pyarrow\] values.*seconds",
        ),
    ],
)
def test_clock_times_in_the_index_are_an_error_as_in_a_column(kind, message):
    # Read as floats, durations and time stamps became integer ticks: a
    # sampling period of 6e7 "s" and predictions changed, without a word.
    table, y, _ = _split_record()
    X = _clock_indexed(table.drop(columns="spindle_rpm"), kind)
    with pytest.raises(ValueError, match=message):
        extract_runs(X)
    with pytest.raises(ValueError, match=message):
        run_times(X, [slice(0, len(X))])
    for name, model in _regressors().items():
        with pytest.raises(ValueError, match=message):
            model.fit(X, y)
    # The same values as a column: the same words.
    column = X.reset_index()
    as_column = message.replace("'time_s' index level", "Column 'time_s'")
    with pytest.raises(ValueError, match=as_column):
        extract_runs(column)


def _two_runs():
    table, y, _ = _split_record(n=30)
    other = table.assign(run="rec2", T1_C=table["T1_C"] + 1.0)
    table = pd.concat([table, other], ignore_index=True)
    y = pd.Series(np.r_[y, y + 3.0], name="disp_y_um")
    return table, y


@pytest.mark.parametrize("name", list(_regressors()))
def test_y_in_another_row_order_is_an_error(name):
    # X and y both labelled, y sorted otherwise (after a merge): paired by
    # position, they were accepted and the model learnt from the wrong rows.
    table, y = _two_runs()
    X = table.set_index(["run", "time_s"])
    y = y.set_axis(X.index)
    shuffled = y.sort_index(level="run", ascending=False)
    model = _regressors()[name]
    with pytest.raises(
        ValueError,
        match=r"y holds the rows of X in another order: row 0 of X is at run "
        r"'rec', time_s=0, but row 0 of y is at run 'rec2', time_s=1740 \(60 of 60 "
        r"rows differ\).*y\.loc\[X\.index\]",
    ):
        model.fit(X, shuffled)
    # The run table as stored, with y indexed by (run, time_s): the same.
    with pytest.raises(ValueError, match=r"row 0 of y is at run 'rec2'"):
        model.fit(table, shuffled)
    # y's plain index, another order: named by its labels.
    with pytest.raises(
        ValueError, match=r"row 0 of X is labelled 0, but row 0 of y is labelled 59"
    ):
        model.fit(table, y.reset_index(drop=True).iloc[::-1])


def test_y_in_x_order_or_with_other_labels_pairs_by_position():
    table, y = _two_runs()
    X = table.set_index(["run", "time_s"])
    y = y.set_axis(X.index)
    shuffled = y.sort_index(level="run", ascending=False)
    for target in (
        y,
        shuffled.loc[X.index],  # the fix the message gives
        y.to_numpy(),
        y.reset_index(drop=True),  # the table's own rows
        y.set_axis(pd.RangeIndex(100, 160)),  # other labels: by position
    ):
        for features in (X, table):
            extract_runs(features, y=target)
    # Times changed in X alone (resampled, shifted): by position too.
    later = X.set_axis(
        pd.MultiIndex.from_arrays(
            [X.index.get_level_values("run"), X.index.get_level_values(1) + 30.0],
            names=["run", "time_s"],
        )
    )
    extract_runs(later, y=y)


def test_missing_target_names_the_row_label_of_y():
    table, y = _two_runs()
    X = table.set_index(["run", "time_s"])
    target = y.set_axis(pd.RangeIndex(100, 160))
    target.iloc[35] = np.nan
    with pytest.raises(
        ValueError,
        match=r"'disp_y_um' is missing \(NaN\) at row 35, run 'rec2', time_s=300 "
        r"\(y's row label 135; 1 non-finite",
    ):
        extract_runs(X, y=target)
    with pytest.raises(ValueError, match=r"at row 35, run 'rec2', time_s=300 \(1 "):
        extract_runs(X, y=target.set_axis(X.index))


@pytest.mark.parametrize("name", list(_regressors()))
def test_no_feature_columns_is_named(name):
    table, y, _ = _split_record()
    model = _regressors()[name]
    message = r"X has no feature columns \(run and time_s are the index"
    with pytest.raises(ValueError, match=message + r".*only \['run', 'time_s'\]"):
        model.fit(table[["run", "time_s"]], y)
    X = table.set_index(["run", "time_s"])
    with pytest.raises(ValueError, match=message + ".*no column at all"):
        model.fit(X[[]], y)
    model.fit(X[["T1_C", "T2_C"]], y)
    with pytest.raises(ValueError, match=message):
        model.predict(X[[]])


def test_run_labels_alone_are_not_an_error():
    # Asking extract_runs for the labels of a table (a frame of its run
    # column) is no model input.
    table, _, _ = _split_record()
    X, groups = extract_runs(table[["run"]])
    assert X.shape == (len(table), 0) and set(groups) == {"rec"}
    assert extract_runs(table[[]])[1] is None
    with pytest.raises(ValueError, match="X has no feature columns"):
        extract_runs(table[["run", "time_s"]])
    with pytest.raises(ValueError, match="X has no feature columns"):
        extract_runs(table[["run"]], y=np.zeros(len(table)))


def test_fit_without_run_labels_or_times_warns_once():
    from skthermal.utils._runs import UNLABELLED_WARNING, warn_unlabelled_runs

    def caught(*args, **kwargs):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            warn_unlabelled_runs(*args, **kwargs)
        return [str(x.message) for x in w]

    table, _, _ = _split_record()
    X, groups = extract_runs(table)
    plain = np.zeros((5, 2))
    [message] = caught("Model", None, None, 5, X=plain)
    assert message.startswith("Model.fit got 5 rows that carry no run labels")
    assert "set_output(transform='pandas')" in message
    assert message.endswith(
        "pass them with their time_s (a run table), or their run label as groups."
    )
    assert re.match(UNLABELLED_WARNING, message)
    assert not caught("Model", None, groups, len(X), X=X)  # labelled
    assert not caught("Model", None, None, len(X), X=X.droplevel("run"))  # times
    assert not caught("Model", None, None, 1, X=plain[:1])  # one row
    [message] = caught("Model", 2, None, 5)  # predict
    assert re.match(UNLABELLED_WARNING, message) and "set_output" in message
    assert not caught("Model", None, None, 5)


def test_selectors_warn_when_the_runs_are_lost_in_front_of_them():
    # A scaler with numpy output drops the (run, time_s) index: the
    # selector then accumulates across run boundaries, so it says so.
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from skthermal.selection import FCMClusterPicker, GreyInfluenceSelector

    table, y, cut = _split_record()
    X = table.set_index(["run", "time_s"])[["T1_C", "T2_C", "spindle_rpm"]]
    for selector in (
        GreyInfluenceSelector(n_features_to_select=2),
        FCMClusterPicker(n_clusters=2, random_state=0),
    ):
        name = type(selector).__name__
        with pytest.warns(UserWarning, match=rf"{name}.fit got 90 rows that carry no"):
            make_pipeline(StandardScaler(), selector).fit(X, y)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            # The speed among the sensors is said too (test_selection.py).
            warnings.filterwarnings("ignore", message=".*X holds the drivers")
            make_pipeline(StandardScaler(), selector).set_output(
                transform="pandas"
            ).fit(X, y)


def test_a_late_start_is_named_once_by_the_model_called():
    from skthermal.models import make_model

    table, y, cut = _split_record()
    model = make_model("lag-ridge").fit(table.iloc[:cut], y[:cut])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.predict(table.iloc[cut:].assign(run="new"))
    late = [str(w.message) for w in caught if "not 0" in str(w.message)]
    assert len(late) == 1 and "RunStartRegressor.predict" in late[0], late


def test_groups_that_cut_other_runs_than_the_index_warn():
    X = table(np.r_[np.arange(4), np.arange(4)] * 30.0, ["a"] * 4 + ["b"] * 4)
    # The same runs under other names (codes, as a CV splitter may pass):
    # nothing to say.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, groups = extract_runs(X, np.repeat([7, 9], 4))
    assert groups.tolist() == [7] * 4 + [9] * 4
    with pytest.warns(
        UserWarning,
        match=r"groups cut the rows into 4 run\(s\), X's 'run' index level into "
        r"2, and they first disagree at row 2 \(groups 1, X 'a'\); groups are used",
    ):
        _, groups = extract_runs(X, np.repeat([0, 1, 2, 3], 2))
    assert groups.tolist() == [0, 0, 1, 1, 2, 2, 3, 3]
    frame = X.reset_index(level="run")  # the labels as a column
    with pytest.warns(UserWarning, match=r"X's 'run' column into 2"):
        extract_runs(frame, np.repeat([0, 1, 2, 3], 2))


class _ForeignFrame:
    """A data frame of another library (as polars): columns, no index, and a
    ``to_pandas()`` that converts it."""

    def __init__(self, frame):
        self._frame = frame.reset_index(drop=True)
        self.columns = list(self._frame.columns)
        self.shape = self._frame.shape

    def __len__(self):
        return len(self._frame)

    def __array__(self, dtype=None, copy=None):
        return self._frame.to_numpy(dtype=dtype)

    def to_pandas(self):
        return self._frame.copy()


@pytest.mark.parametrize("name", [*_sequence_models(), "GuardedRegressor"])
def test_frames_of_other_libraries_are_read_by_their_run_columns(name):
    # A polars run table has its run and time_s as columns (no index): read
    # like a pandas table with those columns, not as inputs.
    from sklearn.base import clone
    from sklearn.linear_model import LinearRegression

    from skthermal.compose import GuardedRegressor

    model = (
        GuardedRegressor(LinearRegression())
        if name == "GuardedRegressor"
        else _sequence_models()[name]
    )
    table, y, cut = _split_record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = clone(model).fit(table, y).predict(table)
        got = clone(model).fit(_ForeignFrame(table), y).predict(_ForeignFrame(table))
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)


def test_run_table_functions_name_the_conversion_of_other_frames():
    from skthermal.datasets import split_runs, validate_runs

    table, _, _ = _split_record()
    for call in (validate_runs, split_runs):
        with pytest.raises(ValueError, match=r"convert it with \.to_pandas\(\)"):
            call(_ForeignFrame(table))


def test_multiindex_columns_are_named():
    from skthermal.utils._runs import extract_runs

    X = pd.DataFrame(
        np.ones((3, 2)),
        columns=pd.MultiIndex.from_tuples([("a", "T1_C"), ("a", "T2_C")]),
    )
    with pytest.raises(ValueError, match="columns of 2 levels"):
        extract_runs(X)


def test_sparse_input_with_run_labels_says_dense_is_required():
    # Without groups scikit-learn's validation said it; with them scipy's
    # "sparse array length is ambiguous" came first.
    import scipy.sparse

    X = scipy.sparse.csr_matrix(np.ones((4, 2)))
    with pytest.raises(TypeError, match="Sparse data was passed for X, but dense"):
        extract_runs(X, [0, 0, 1, 1])


def test_labels_of_two_kinds_in_a_list_are_not_merged():
    # np.asarray([1, 1, "1", "1"]) makes every label "1": two runs became one.
    with pytest.raises(ValueError, match=r"Run labels mix kinds: row 0 has 1 \(int\)"):
        run_slices([1, 1, "1", "1"], 4)
    with pytest.raises(ValueError, match=r"Run labels mix kinds"):
        extract_runs(np.ones((4, 2)), [1, 1, "1", "1"])
    assert run_slices(["a", "a", "b"], 3)[1] == ["a", "b"]


def _leaky_models():
    from sklearn.linear_model import LinearRegression

    from skthermal.compose import GuardedRegressor
    from skthermal.linear_model import UpdateRegressor
    from skthermal.models import RunStartRegressor
    from skthermal.preprocessing import LagFeatures, LagRidgeCV
    from skthermal.selection import GreyInfluenceSelector

    def lag():
        return LagRidgeCV(time_constant_sets=[(600.0,)], alphas=[1.0])

    return {
        "selector": GreyInfluenceSelector(n_features_to_select=1),
        "LagFeatures": LagFeatures(time_constants=(600.0,)),
        "UpdateRegressor": UpdateRegressor(),
        "RunStartRegressor": RunStartRegressor(LinearRegression()),
        # Wrappers say it once, not again for their inner model.
        "RunStartRegressor(LagRidgeCV)": RunStartRegressor(lag()),
        "GuardedRegressor(LagRidgeCV)": GuardedRegressor(lag()),
    }


@pytest.mark.parametrize("name", list(_leaky_models()))
def test_a_stored_table_whose_targets_are_features_warns(name):
    # The run table passed whole as X keeps its displacement columns: a model
    # fitted on it with y = one of them predicts the target from itself.
    table, y, _ = _split_record()
    table = table.assign(disp_y_um=y, disp_z_um=0.5 * y + 1.0)
    model = _leaky_models()[name]
    with pytest.warns(UserWarning, match=r"\['disp_y_um'\] equal the target y") as rec:
        model.fit(table, table["disp_y_um"])
    said = [str(w.message) for w in rec if "equal the target" in str(w.message)]
    assert len(said) == 1  # once per fit
    assert "['disp_z_um'] (targets of the run table" in said[0]
    # Without them, no such warning.
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        model.fit(table.drop(columns=["disp_y_um", "disp_z_um"]), y)
    assert not [w for w in rec if "equal the target" in str(w.message)]


def test_permutation_importance_needs_the_runs_out_of_the_columns():
    # permutation_importance shuffles every column of X, a 'run' column too:
    # the error says so; with the runs as the index it works.
    from sklearn.inspection import permutation_importance

    from skthermal.datasets import make_sensor_groups, split_runs
    from skthermal.grey import GreyPSORegressor

    runs, _ = make_sensor_groups(
        n_groups=2, sensors_per_group=2, n_runs=3, n_samples=40, random_state=0
    )
    y = runs.pop("disp_y_um")
    model = GreyPSORegressor(calibration="ls").fit(runs, y)
    with pytest.raises(ValueError, match="shuffles a 'run' column too"):
        permutation_importance(model, runs, y, n_repeats=2, random_state=0)
    X, y2, _ = split_runs(runs.assign(disp_y_um=y), targets="disp_y_um")
    model = GreyPSORegressor(calibration="ls").fit(X, y2)
    result = permutation_importance(model, X, y2, n_repeats=2, random_state=0)
    assert result.importances_mean.shape == (X.shape[1],)


def test_a_run_column_renamed_by_a_column_transformer_is_named():
    X = pd.DataFrame({"remainder__run": ["a", "a", "b"], "T1_C": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="verbose_feature_names_out=False"):
        extract_runs(X)
    X = pd.DataFrame({"sensor": ["hot", "a", "b"], "T1_C": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="is not numeric") as err:
        extract_runs(X)
    assert "ColumnTransformer" not in str(err.value)


def test_misnamed_run_and_time_levels_are_named():
    # Levels named as a logger exports them were not read: the rows were
    # one run 1 s apart, and a lag pipeline's predictions 8 µm off.
    from skthermal.preprocessing import LagFeatures, make_lag_pipeline

    index = pd.MultiIndex.from_arrays(
        [np.repeat(["a", "b"], 30), np.tile(np.arange(30) * 60.0, 2)],
        names=["Run", "Time_s"],
    )
    X = pd.DataFrame({"T1_C": np.linspace(20, 25, 60)}, index=index)
    with pytest.raises(
        ValueError,
        match=r"index has the level 'Run': .*taken as one run\. Rename it: "
        r"X\.index = X\.index\.set_names\(\['run', 'Time_s'\]\)",
    ):
        make_lag_pipeline().fit(X, np.arange(60.0))
    for name in ("Run ID", "test_no", "Test"):
        renamed = X.rename_axis(index=[name, "time_s"])
        with pytest.raises(ValueError, match=rf"index has the level '{name}'"):
            extract_runs(renamed)
    # Labels given as groups: the level is not needed, no error.
    assert extract_runs(X, groups=X.index.get_level_values(0))[1][0] == "a"
    # A misspelt time level: a model that reads times says so where it says
    # that it found none.
    X.index = X.index.set_names(["run", "Time_s"])
    with pytest.warns(UserWarning, match=r"index level 'Time_s' is not read as the"):
        LagFeatures(drivers=None).fit(X)
    # Fitted with times and given the misspelt level in predict: the rows
    # were taken at the training period, a gap as one step, silently.
    from skthermal.linear_model import TransferFunctionRegressor

    fitted = LagFeatures(drivers=None).fit(X.rename_axis(index=["run", "time_s"]))
    for model in (fitted, TransferFunctionRegressor(max_iter=0)):
        if model is not fitted:
            model.fit(X.rename_axis(index=["run", "time_s"]), np.arange(60.0))
        with pytest.warns(
            UserWarning, match=r"X has no time_s; its index level 'Time_s' is not"
        ):
            (model.transform if model is fitted else model.predict)(X)
    with warnings.catch_warnings():  # a static use of X: nothing to say
        warnings.simplefilter("error")
        extract_runs(X, y=np.arange(60.0))
    X.index = X.index.set_names(["run", "time_s"])
    assert extract_runs(X)[1].tolist() == ["a"] * 30 + ["b"] * 30
    # Other names are not run labels or times: left alone.
    X.index = X.index.set_names(["batch", "step"])
    assert extract_runs(X)[1] is None


def test_time_restarting_without_run_labels_points_at_a_misnamed_run_level():
    X = pd.DataFrame(
        {"T1_C": [1.0, 2.0, 3.0, 4.0]},
        index=pd.MultiIndex.from_arrays(
            [["a", "a", "b", "b"], [0.0, 60.0, 0.0, 60.0]], names=["Run", "time_s"]
        ),
    )
    # Models read X through extract_runs, which names the level at once.
    with pytest.raises(
        ValueError,
        match=r"index has the level 'Run': .*taken as one run\. "
        r"Rename it: X\.index = X\.index\.set_names\(\['run', 'time_s'\]\)",
    ):
        extract_runs(X)
    with pytest.raises(
        ValueError, match=r"No run labels were found .*'Run' is not read as them"
    ):
        check_time_order(X, None)
    labelled = X.reset_index(level="Run", drop=True)
    with pytest.raises(ValueError, match="No run labels were found") as err:
        check_time_order(labelled, None)
    assert "not read" not in str(err.value)
    with pytest.raises(ValueError, match=r"in run 'a'") as err:
        check_time_order(labelled, np.array(["a", "a", "a", "a"]))
    assert "No run labels" not in str(err.value)


def test_a_fit_on_times_in_milliseconds_warns():
    # read_runs and validate_runs warned; the fit of a model that reads times
    # on X with its own (run, time_s) index did not, and a lag pipeline's
    # predictions moved by 8 µm.
    from skthermal.preprocessing import LagFeatures

    t = np.arange(0.0, 4 * 3600.0, 120.0)
    runs = np.repeat(["a", "b"], t.size)
    index = pd.MultiIndex.from_arrays([runs, np.tile(t, 2)], names=["run", "time_s"])
    X = pd.DataFrame({"T1_C": np.linspace(20, 25, 2 * t.size)}, index=index)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LagFeatures(drivers=None).fit(X)
        # A window of a run (an update, a later part) is no unit question.
        LagFeatures(drivers=None).fit(X.iloc[10:20])
    X.index = pd.MultiIndex.from_arrays(
        [runs, np.tile(t * 1000.0, 2)], names=["run", "time_s"]
    )
    with pytest.warns(UserWarning, match=r"^time_s is read as seconds.*milliseconds\?"):
        LagFeatures(drivers=None).fit(X)


def test_a_wrapper_says_the_time_unit_warning_once():
    # LagRidgeCV said it once per candidate fit (five times on the gas
    # furnace series).
    from skthermal.preprocessing import LagRidgeCV

    t = np.arange(0.0, 4 * 3600.0, 120.0) * 1000.0  # 4 h in milliseconds
    index = pd.MultiIndex.from_arrays(
        [np.repeat(["a", "b"], t.size), np.tile(t, 2)], names=["run", "time_s"]
    )
    X = pd.DataFrame({"T1_C": np.sin(np.arange(2 * t.size) / 9.0)}, index=index)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        LagRidgeCV(drivers=None).fit(X, np.cos(np.arange(2 * t.size) / 9.0))
    said = [w for w in caught if "time_s is read as seconds" in str(w.message)]
    assert len(said) == 1
    # Behind a guard, which fits it once: said once, not silenced.
    from skthermal.compose import GuardedRegressor

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        GuardedRegressor(LagRidgeCV(drivers=None)).fit(
            X, np.cos(np.arange(2 * t.size) / 9.0)
        )
    said = [w for w in caught if "time_s is read as seconds" in str(w.message)]
    assert len(said) == 1


def test_transformers_keep_categorical_run_labels():
    # A run column of dtype category came back as a level of str labels
    # (joining the output back onto the input then failed on the dtype).
    from skthermal.preprocessing import LagFeatures
    from skthermal.selection import GRASelector

    rng = np.random.default_rng(0)
    n = 40
    frame = pd.DataFrame(
        {
            "run": pd.Categorical(np.repeat(["a", "b"], n)),
            "time_s": np.tile(np.arange(n) * 60.0, 2),
            "T1_C": rng.random(2 * n),
            "T2_C": rng.random(2 * n),
        }
    )
    y = rng.random(2 * n)
    for table in (frame, frame.set_index(["run", "time_s"])):
        for step in (
            LagFeatures(time_constants=[600.0]),
            GRASelector(n_features_to_select=1),
        ):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                out = step.fit(table, y).transform(table)
            level = out.index.get_level_values("run")
            assert isinstance(level.dtype, pd.CategoricalDtype), type(step)
            assert level.tolist() == frame["run"].tolist()
    # Labels given apart from X (groups) are taken as given.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        out = LagFeatures(time_constants=[600.0]).fit_transform(
            frame, groups=np.repeat(["c", "d"], n)
        )
    assert out.index.get_level_values("run").tolist() == ["c"] * n + ["d"] * n
