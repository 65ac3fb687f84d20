"""Tests of skthermal.datasets: run-table validation, I/O, splitting, loaders."""

import decimal
import gzip
import json
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GroupKFold, cross_validate
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import FunctionTransformer

from skthermal.datasets import (
    changes_since_start,
    concat_runs,
    driver_columns,
    load_fl_thermal,
    read_runs,
    sensor_columns,
    split_runs,
    target_columns,
    validate_runs,
    write_runs,
)
from skthermal.utils import extract_runs


def make_runs(n_runs=3, n_rows=4, seed=0):
    """A small valid run table with drivers, two sensors, a strain and targets."""
    rng = np.random.default_rng(seed)
    n = n_runs * n_rows
    return pd.DataFrame(
        {
            "run": np.repeat([f"r{i}" for i in range(n_runs)], n_rows),
            "time_s": np.tile(np.arange(n_rows) * 60.0, n_runs),
            "spindle_rpm": np.full(n, 4000.0),
            "ambient_C": 20.0 + rng.normal(size=n),
            "T1_C": 20.0 + rng.normal(size=n),
            "operator": ["ann"] * n,
            "Tcarrier3_C": 21.0 + rng.normal(size=n),
            "Sram1_ue": rng.normal(size=n),
            "disp_y_um": rng.normal(size=n),
            "disp_z_um": rng.normal(size=n),
        }
    )


@pytest.fixture
def runs():
    return make_runs()


def with_value(df, column, row, value):
    out = df.copy()
    if not isinstance(value, float) or not pd.api.types.is_float_dtype(out[column]):
        out[column] = out[column].astype(object)
    out.loc[row, column] = value
    return out


# --- column roles ------------------------------------------------------------


def test_column_roles_in_table_order(runs):
    assert sensor_columns(runs) == ["T1_C", "Tcarrier3_C", "Sram1_ue"]
    assert target_columns(runs) == ["disp_y_um", "disp_z_um"]
    assert driver_columns(runs) == ["spindle_rpm", "ambient_C"]
    assert driver_columns(["feed_mm_min", "T1_C"]) == ["feed_mm_min"]


# --- validate_runs: valid tables ---------------------------------------------


def test_validate_returns_same_object(runs):
    assert validate_runs(runs, require_targets=True, require_drivers=True) is runs


def test_validate_accepts_int_labels_and_extra_columns():
    df = pd.DataFrame(
        {
            "run": [1, 1, 2, 2],
            "time_s": [0, 15, 0, 30],
            "T1_C": [20.0, 20.5, 21.0, 21.2],
            "Temp3_C": [1.0, 2.0, 3.0, 4.0],
            "Tspindle_front_C": [1.0, 2.0, 3.0, 4.0],
            "comment": ["x", None, "y", "z"],
            "tool_id": [7, 7, 8, 8],
            "Tags": ["a", "b", "c", "d"],
        }
    )
    assert validate_runs(df) is df
    assert sensor_columns(df) == ["T1_C", "Temp3_C", "Tspindle_front_C"]


def test_validate_does_not_modify(runs):
    before = runs.copy()
    validate_runs(runs)
    pd.testing.assert_frame_equal(runs, before)


# --- validate_runs: structural errors ----------------------------------------


@pytest.mark.parametrize("obj", [np.zeros((3, 3)), [1, 2], None])
def test_not_a_dataframe(obj):
    with pytest.raises(ValueError, match="must be a pandas DataFrame"):
        validate_runs(obj)


@pytest.mark.parametrize(
    "column, hint", [("run", "run_id"), ("time_s", "time")], ids=["run", "time"]
)
def test_missing_required_column(runs, column, hint):
    df = runs.rename(columns={column: hint})
    with pytest.raises(
        ValueError, match=rf"no '{column}' column.*might be it: \['{hint}'\]"
    ):
        validate_runs(df)


def test_no_temperature_column(runs):
    df = runs.drop(columns=["T1_C", "Tcarrier3_C"])
    with pytest.raises(ValueError, match="no temperature sensor column"):
        validate_runs(df)


def test_duplicated_columns(runs):
    df = pd.concat([runs, runs[["T1_C"]]], axis=1)
    with pytest.raises(ValueError, match=r"duplicated columns: \['T1_C'\]"):
        validate_runs(df)


@pytest.mark.parametrize(
    "function",
    [validate_runs, changes_since_start, split_runs],
    ids=lambda f: f.__name__,
)
def test_two_header_rows_are_named(runs, function):
    # pandas.read_csv(..., header=[0, 1]) on a file with a row of units:
    # "no temperature sensor column" (T1_C was there) and a TypeError from
    # inside pandas.
    df = runs.copy()
    df.columns = pd.MultiIndex.from_arrays([df.columns, ["unit"] * df.shape[1]])
    with pytest.raises(ValueError, match=r"columns of 2 levels .* df\.columns = "):
        function(df)


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda d: d.assign(time_s=pd.to_timedelta(d["time_s"], unit="s")),
            r"'time_s' holds timedelta64\S* values .*\.dt\.total_seconds\(\)",
        ),
        (
            lambda d: d.assign(
                time_s=pd.Timestamp("2024-03-01", tz="UTC")
                + pd.to_timedelta(d["time_s"], unit="s")
            ),
            r"'time_s' holds datetime64\S*, UTC\] values .*'first'\)\)",
        ),
        (
            lambda d: d.assign(T1_C=[decimal.Decimal(str(v)) for v in d["T1_C"]]),
            r"'T1_C' .* numbers stored as Python objects, e.g. Decimal\('\S+'\) "
            r"at run \S+, time_s 0\.0 \(row 0\); convert them, e.g. "
            r"df\['T1_C'\] = df\['T1_C'\]\.astype\(float\)",
        ),
        (
            lambda d: d.assign(T1_C=d["T1_C"] > 20.5),
            r"'T1_C' .* dtype bool: run \S+, time_s 0\.0 \(row 0\) holds (True|False);"
            r" a run table holds readings as numbers",
        ),
        (
            lambda d: d.assign(T1_C=d["T1_C"].astype(str)),
            r"'T1_C' .* numbers stored as text, e.g. '\S+' at run",
        ),
        (
            lambda d: d.assign(
                T1_C=pd.array([None, *(d["T1_C"] > 20.5)[1:]], dtype="boolean")
            ),
            r"'T1_C' .* dtype boolean: run \S+, time_s \S+ \(row 1\) holds",
        ),
    ],
    ids=["timedelta", "datetime", "decimal", "bool", "text", "nullable bool"],
)
def test_columns_of_other_kinds_are_named_with_the_conversion(runs, change, message):
    # "Column 'time_s' must be numeric but has dtype timedelta64[us]." said
    # neither a value nor what to do.
    with pytest.raises(ValueError, match=message):
        validate_runs(change(runs))


def test_runs_starting_late_are_told_apart_from_continued_runs(runs):
    # The advice "subtract each run's first time" alone restarted runs that
    # continue runs a model was fitted on (predictions 44 um apart).
    late = runs.assign(time_s=runs["time_s"] + 3000.0)
    with pytest.warns(UserWarning, match=r"do not start at 0") as record:
        validate_runs(late)
    text = str(record[0].message)
    assert "a clock's time? Then subtract each run's first time" in text
    assert "Rows that continue runs a model was fitted on keep their times" in text


def test_changes_since_start_names_a_column_given_twice(runs):
    # pandas' "Columns must be same length as key" came from inside.
    with pytest.raises(ValueError, match=r"columns names \['T1_C'\] more than once"):
        changes_since_start(runs, columns=["T1_C", "disp_z_um", "T1_C"])


def test_empty_table(runs):
    with pytest.raises(ValueError, match="no rows"):
        validate_runs(runs.iloc[:0])


@pytest.mark.parametrize(
    "bad, kind",
    [
        ("T05", "temperature"),
        ("t05_C", "temperature"),
        ("T05_K", "temperature"),
        ("T05_degC", "temperature"),
        ("T_C", "temperature"),
        ("T_spindle_C", "temperature"),
        ("T05_c", "temperature"),
        ("temp3", "temperature"),
        ("T 5_C", "temperature"),
        ("Sfoo_uE", "strain"),
        ("s1_ue", "strain"),
        ("strain_1", "strain"),
        ("disp_y", "displacement"),
        ("disp_y_mm", "displacement"),
        ("Disp_y_um", "displacement"),
        ("disp__y_um", "displacement"),
        ("Ambient_C", "the column 'ambient_C'"),
        ("SPINDLE_RPM", "the column 'spindle_rpm'"),
    ],
)
def test_naming_rule_errors_name_the_column(runs, bad, kind):
    df = runs.assign(**{bad: 1.0})
    with pytest.raises(ValueError, match=re.escape(f"'{bad}' looks like")) as info:
        validate_runs(df)
    message = str(info.value)
    assert kind in message
    if kind in ("temperature", "strain", "displacement"):
        # The message states the expected pattern.
        assert {"temperature": "T<name>_C", "strain": "S<name>_ue"}.get(
            kind, "disp_<axis>_um"
        ) in message


@pytest.mark.parametrize(
    "bad, hint",
    [
        ("disp_z_mm", "(in mm? multiply by 1000 for 'disp_z_um')"),
        ("disp_z_nm", "(in nm? divide by 1000 for 'disp_z_um')"),
        ("T05_F", "(in °F? convert with (F - 32) / 1.8 for 'T05_C')"),
        ("T05_K", "(in K? subtract 273.15 for 'T05_C')"),
        # Names that break the rule otherwise too: the name under the rule.
        ("Disp_Z_MM", "(in mm? multiply by 1000 for 'disp_Z_um')"),
        ("t5_degF", "(in °F? convert with (F - 32) / 1.8 for 'T5_C')"),
        ("T5_kelvin", "(in K? subtract 273.15 for 'T5_C')"),
        ("disp_mm", "(in mm? multiply by 1000)"),
    ],
)
def test_a_column_in_another_unit_is_told_the_conversion(runs, bad, hint):
    with pytest.raises(ValueError, match=re.escape(hint)):
        validate_runs(runs.assign(**{bad: 1.0}))


def test_naming_errors_list_every_bad_column(runs):
    df = runs.assign(T05=1.0, disp_x=2.0)
    with pytest.raises(ValueError, match=r"'T05' looks like.*'disp_x' looks like"):
        validate_runs(df)


@pytest.mark.parametrize(
    "bad, driver",
    [
        ("ambient_F", "ambient_C"),
        ("ambient_K", "ambient_C"),
        ("ambient_temp", "ambient_C"),
        ("spindle_rps", "spindle_rpm"),
        ("spindle_speed", "spindle_rpm"),
        ("feed_mm_s", "feed_mm_min"),
        ("feed_mm_min_", "feed_mm_min"),
        ("feedrate", "feed_mm_min"),
        ("feed_ipm", "feed_mm_min"),
        ("ambient_T_C", "ambient_C"),
        ("spindle_rev_min", "spindle_rpm"),
        ("spindle_rpm_act", "spindle_rpm"),
        # A logger's speed column by its unit alone: kept as an unrelated
        # extra, and the CLI fitted a model without any heat input.
        ("rpm", "spindle_rpm"),
        ("n [rpm]", "spindle_rpm"),
        # The workshop air by another name passed as an unrelated extra.
        ("air_C", "ambient_C"),
        ("room_temp_C", "ambient_C"),
        # A logger's unit in brackets, the T in front: passed silently.
        ("ambient [K]", "ambient_C"),
        ("ambient (C)", "ambient_C"),
        ("T_ambient", "ambient_C"),
        ("spindle speed [rpm]", "spindle_rpm"),
        ("Workshop_air_F", "ambient_C"),
    ],
)
def test_a_driver_in_another_unit_is_named(runs, bad, driver):
    # It was kept as an extra column without a word: the models and the
    # simulator then had no such driver.
    df = runs.drop(columns=driver, errors="ignore").assign(**{bad: 1.0})
    with pytest.raises(
        ValueError, match=re.escape(f"'{bad}' looks like the driver '{driver}'")
    ):
        validate_runs(df)
    # Beside the driver itself, it is another unit's copy: an extra.
    validate_runs(runs.assign(**{driver: 0.0, bad: 1.0}))


@pytest.mark.parametrize(
    "name",
    [
        "S1_ue",
        "Sram1_ue",
        "disp_ch1_um",
        "TC2_C",
        "spindle_load_pct",
        "feed_override_pct",
        "ambient_humidity_pct",
        "spindle_speed_cmd",
        "feed_mm_rev",
        "spindle2_rpm",
    ],
)
def test_valid_names_pass(runs, name):
    validate_runs(runs.assign(**{name: 1.0}))


def test_require_drivers(runs):
    validate_runs(runs.drop(columns="ambient_C"))
    with pytest.raises(ValueError, match=r"driver column\(s\) \['ambient_C'\]"):
        validate_runs(runs.drop(columns="ambient_C"), require_drivers=True)


def test_require_targets(runs):
    df = runs.drop(columns=["disp_y_um", "disp_z_um"]).assign(dy_um=1.0)
    validate_runs(df)
    with pytest.raises(ValueError, match=r"no displacement.*might be meant: \['dy_um'"):
        validate_runs(df, require_targets=True)


# --- validate_runs: values ---------------------------------------------------


@pytest.mark.parametrize("column", ["T1_C", "disp_y_um", "spindle_rpm", "time_s"])
def test_non_numeric_column_names_column_and_row(runs, column):
    df = with_value(runs, column, 5, "abc")
    with pytest.raises(
        ValueError,
        match=rf"Column '{column}' must be numeric.*run 'r1'.*\(row 5\) holds 'abc'",
    ):
        validate_runs(df)


def test_complex_column_is_refused(runs):
    # It passed with numpy's ComplexWarning alone, and write_runs then wrote
    # "(20+0j)", which read_runs could not read back.
    df = runs.assign(T1_C=runs["T1_C"].astype(complex))
    with pytest.raises(ValueError, match=r"'T1_C' holds complex numbers .* run 'r0'"):
        validate_runs(df)


def test_a_duplicated_run_column_is_named_everywhere(runs, tmp_path):
    # concat_runs and write_runs(validate=False) failed inside pandas.
    twice = pd.concat([runs, runs[["run"]]], axis=1)
    with pytest.raises(
        ValueError, match=r"Run table 0 has duplicated columns: \['run'\]"
    ):
        concat_runs([twice])
    with pytest.raises(ValueError, match=r"duplicated columns: \['run'\]"):
        write_runs(twice, tmp_path / "twice.csv", validate=False)


def test_changes_since_start_names_an_infinite_value(runs):
    df = with_value(runs, "T1_C", 4, np.inf)
    with pytest.raises(
        ValueError, match=r"'T1_C' has 1 infinite value\(s\), the first at run 'r1'"
    ):
        changes_since_start(df)


def test_bool_column_is_not_numeric(runs):
    with pytest.raises(ValueError, match="'Sram1_ue' must be numeric.*bool"):
        validate_runs(runs.assign(Sram1_ue=True))


def test_time_not_increasing_names_run_row_and_times(runs):
    df = with_value(runs, "time_s", 6, 60.0)  # run r1: 0, 60, 60, 180
    with pytest.raises(
        ValueError,
        match=r"in run 'r1', row 6 has time_s 60.0 after time_s 60.0 at row 5",
    ):
        validate_runs(df)


def test_time_decreasing(runs):
    df = with_value(runs, "time_s", 9, -5.0)
    with pytest.raises(ValueError, match=r"run 'r2', row 9 has time_s -5.0"):
        validate_runs(df)


def test_time_may_restart_between_runs(runs):
    # time_s restarts at 0 in every run of ``runs``; only within-run order counts
    assert (np.diff(runs["time_s"]) < 0).any()
    validate_runs(runs)


def test_missing_time(runs):
    df = with_value(runs, "time_s", 2, np.nan)
    with pytest.raises(ValueError, match=r"'time_s' has 1 missing.*run 'r0'.*row 2"):
        validate_runs(df)


def test_runs_not_contiguous(runs):
    df = runs.iloc[[0, 1, 4, 5, 2, 3, 6, 7, 8, 9, 10, 11]].reset_index(drop=True)
    with pytest.raises(
        ValueError, match=r"run 'r0' are not contiguous \(rows 0-1, rows 4-5\)"
    ):
        validate_runs(df)


def test_single_row_run(runs):
    df = runs.iloc[:9]  # r2 keeps one row, at position 8
    with pytest.raises(ValueError, match=r"Run 'r2' has a single row \(row 8\)"):
        validate_runs(df)


def test_missing_run_label(runs):
    df = with_value(runs, "run", 3, None)
    with pytest.raises(ValueError, match=r"'run' has 1 missing label.*row 3"):
        validate_runs(df)


@pytest.mark.parametrize("column", ["disp_z_um", "spindle_rpm", "ambient_C"])
def test_missing_driver_or_target_names_run_and_time(runs, column):
    df = with_value(runs, column, 7, np.nan)
    with pytest.raises(
        ValueError,
        match=rf"column '{column}' has 1 missing value\(s\), the first at run "
        r"'r1', time_s 180.0 \(row 7\)",
    ):
        validate_runs(df, allow_missing_sensors=True)


def test_missing_sensor(runs):
    df = with_value(runs, "Tcarrier3_C", 4, np.nan)
    df = with_value(df, "Tcarrier3_C", 10, np.nan)
    with pytest.raises(
        ValueError,
        match=r"column 'Tcarrier3_C' has 2 missing value\(s\), the first at run "
        r"'r1', time_s 0.0 \(row 4\).*allow_missing_sensors",
    ):
        validate_runs(df)
    assert validate_runs(df, allow_missing_sensors=True) is df


def test_missing_sensor_hint_fits_the_function_called(runs, tmp_path):
    """Each function's way out of missing sensor values is one of its own
    arguments."""
    df = with_value(runs, "Tcarrier3_C", 4, np.nan)
    way_out = r"or pass validate=False and impute them in the pipeline"
    for call in (
        lambda: split_runs(df),
        lambda: write_runs(df, tmp_path / "runs.csv"),
    ):
        with pytest.raises(ValueError, match=way_out) as info:
            call()
        assert "allow_missing_sensors" not in str(info.value)
    X, _, _ = split_runs(df, validate=False)
    assert X["Tcarrier3_C"].isna().sum() == 1
    write_runs(df, tmp_path / "runs.csv", validate=False)
    with pytest.raises(ValueError, match=way_out):
        read_runs(tmp_path / "runs.csv")


def test_nullable_missing_sensor(runs):
    df = runs.astype({"T1_C": "Float64"})
    df.loc[1, "T1_C"] = pd.NA
    with pytest.raises(ValueError, match=r"'T1_C' has 1 missing.*\(row 1\)"):
        validate_runs(df)


@pytest.mark.parametrize("column", ["T1_C", "disp_y_um", "ambient_C", "time_s"])
def test_infinite_values(runs, column):
    df = with_value(runs, column, 3, np.inf)
    with pytest.raises(ValueError, match=rf"'{column}' has 1 .*infinite.*\(row 3\)"):
        validate_runs(df, allow_missing_sensors=True)


def test_negative_spindle_speed_names_column_run_row_and_value(runs):
    df = with_value(runs, "spindle_rpm", 5, -500.0)
    df = with_value(df, "spindle_rpm", 9, -1.0)
    with pytest.raises(
        ValueError,
        match=r"Column 'spindle_rpm' must hold a spindle speed in rpm, 0 or more: "
        r"run 'r1', time_s 60.0 \(row 5\) holds -500 \(2 such rows in all\)",
    ):
        validate_runs(df)


def test_zero_speed_and_negative_feed_are_valid(runs):
    df = runs.assign(spindle_rpm=0.0, feed_mm_min=-1500.0)
    assert validate_runs(df, require_drivers=True) is df


@pytest.mark.parametrize("column", ["ambient_C", "Tcarrier3_C"])
def test_temperature_below_absolute_zero(runs, column):
    df = with_value(runs, column, 10, -999.0)
    with pytest.raises(
        ValueError,
        match=rf"Column '{column}' must hold a temperature in °C, above -273.15: "
        r"run 'r2', time_s 120.0 \(row 10\) holds -999\.",
    ):
        validate_runs(df)


def test_valid_drivers_can_be_simulated(runs):
    """A table whose drivers validate is accepted by the simulator."""
    from skthermal.simulate import ThermalMachine

    df = runs.assign(spindle_rpm=np.tile([0.0, 0.0, 4000.0, 4000.0], 3))
    validate_runs(df, require_drivers=True)
    machine = ThermalMachine.from_preset("vmc-b")
    for _, run in df.groupby("run", sort=False):
        sim = machine.simulate_drivers(
            run["time_s"], run["spindle_rpm"], run["ambient_C"], noise=False
        )
        assert np.isfinite(sim[target_columns(sim)].to_numpy()).all()


# --- split_runs --------------------------------------------------------------


def test_split_runs_defaults(runs):
    X, y, groups = split_runs(runs)
    assert list(X.columns) == ["T1_C", "Tcarrier3_C", "Sram1_ue"]
    assert list(y.columns) == ["disp_y_um", "disp_z_um"]
    assert X.index.names == ["run", "time_s"]
    assert y.index.equals(X.index)
    assert groups.tolist() == runs["run"].tolist()
    np.testing.assert_array_equal(X.to_numpy(), runs[list(X.columns)].to_numpy())
    assert X.index.get_level_values("time_s").tolist() == runs["time_s"].tolist()


def test_split_runs_single_target_is_series(runs):
    X, y, _ = split_runs(runs, sensors="T1_C", targets="disp_z_um")
    assert isinstance(y, pd.Series) and y.name == "disp_z_um"
    assert list(X.columns) == ["T1_C"]
    _, y, _ = split_runs(runs.drop(columns="disp_z_um"))
    assert isinstance(y, pd.Series) and y.name == "disp_y_um"
    _, y, _ = split_runs(runs, targets=["disp_z_um"])
    assert isinstance(y, pd.DataFrame)


def test_split_runs_accepts_driver_as_feature(runs):
    X, _, _ = split_runs(runs, sensors=["ambient_C", "T1_C"])
    assert list(X.columns) == ["ambient_C", "T1_C"]


def test_split_runs_unknown_columns(runs):
    with pytest.raises(
        ValueError, match=r"Sensor column 'T9_C' is not in the table.*'Tcarrier3_C'"
    ):
        split_runs(runs, sensors=["T1_C", "T9_C"])
    with pytest.raises(ValueError, match=r"'disp_y_um' is not a sensor or driver"):
        split_runs(runs, sensors=["disp_y_um"])
    with pytest.raises(
        ValueError, match=r"Target column 'disp_x_um' is not in the table.*disp_y_um"
    ):
        split_runs(runs, targets="disp_x_um")


def test_split_runs_missing_values_only_in_selected_sensors(runs):
    df = with_value(runs, "Sram1_ue", 2, np.nan)
    X, _, _ = split_runs(df, sensors=["T1_C"])
    assert list(X.columns) == ["T1_C"]
    with pytest.raises(ValueError, match="'Sram1_ue' has 1 missing"):
        split_runs(df)


def test_split_runs_requires_targets(runs):
    with pytest.raises(ValueError, match="no displacement"):
        split_runs(runs.drop(columns=["disp_y_um", "disp_z_um"]))


def test_split_runs_cross_validate_group_kfold():
    df = make_runs(n_runs=6, n_rows=20)
    X, y, groups = split_runs(df, targets="disp_y_um")
    cv = cross_validate(
        LinearRegression(), X, y, groups=groups, cv=GroupKFold(3), return_indices=True
    )
    assert cv["test_score"].shape == (3,)
    for test in cv["indices"]["test"]:
        # Whole runs in every test fold: the fold's runs have all their rows.
        test_runs = set(groups[test])
        assert len(test) == 20 * len(test_runs)


# --- changes_since_start -----------------------------------------------------


def test_changes_since_start_hand_values():
    df = pd.DataFrame(
        {
            "run": ["a", "a", "a", "b", "b"],
            "time_s": [0.0, 1.0, 2.0, 0.0, 1.0],
            "T1_C": [20.0, 21.0, 23.5, 30.0, 29.0],
            "spindle_rpm": [100.0, 200.0, 300.0, 0.0, 0.0],
            "disp_y_um": [5.0, 7.0, 4.0, -1.0, 1.0],
        }
    )
    out = changes_since_start(df)
    assert out["T1_C"].tolist() == [0.0, 1.0, 3.5, 0.0, -1.0]
    assert out["disp_y_um"].tolist() == [0.0, 2.0, -1.0, 0.0, 2.0]
    assert out["spindle_rpm"].tolist() == df["spindle_rpm"].tolist()
    assert df["T1_C"].tolist()[0] == 20.0  # the input is not modified
    only = changes_since_start(df, columns="spindle_rpm")
    assert only["spindle_rpm"].tolist() == [0.0, 100.0, 200.0, 0.0, 0.0]
    assert only["T1_C"].tolist() == df["T1_C"].tolist()


def test_changes_since_start_int_columns_and_errors(runs):
    df = runs.assign(T1_C=np.arange(len(runs)))  # int64 column
    out = changes_since_start(df, columns=["T1_C"])
    assert out["T1_C"].tolist() == [0.0, 1.0, 2.0, 3.0] * 3
    with pytest.raises(ValueError, match=r"\['T9_C'\] are not in the table"):
        changes_since_start(runs, columns=["T9_C"])
    with pytest.raises(ValueError, match="no 'run' column"):
        changes_since_start(runs.drop(columns="run"))


# --- read_runs / write_runs --------------------------------------------------


@pytest.mark.parametrize("name", ["runs.csv", "runs.csv.gz", "runs.parquet", "r.pq"])
def test_round_trip(tmp_path, runs, name):
    path = tmp_path / name
    write_runs(runs, path)
    back = read_runs(path)
    pd.testing.assert_frame_equal(back, runs)
    assert not (tmp_path / f"{name}.json").exists()


@pytest.mark.parametrize("name", ["runs.xlsx", "runs", "runs.json", "runs.gz"])
def test_a_name_that_is_neither_csv_nor_parquet_is_refused(tmp_path, runs, name):
    with pytest.raises(ValueError, match="neither CSV nor Parquet"):
        write_runs(runs, tmp_path / name)
    assert not (tmp_path / name).exists()


def test_csv_gz_is_compressed(tmp_path, runs):
    write_runs(runs, tmp_path / "runs.csv.gz")
    assert (tmp_path / "runs.csv.gz").read_bytes()[:2] == b"\x1f\x8b"


def test_round_trip_with_metadata(tmp_path, runs):
    meta = pd.DataFrame(
        {
            "run": ["r0", "r2"],
            "machine": ["B", "B"],
            "max_rpm": [4000, 8000],
            "note": ["door opened", None],
        }
    )
    meta.attrs["source"] = "test bench"
    path = tmp_path / "runs.csv.gz"
    write_runs(runs, path, metadata=meta)
    sidecar = json.loads((tmp_path / "runs.csv.gz.json").read_text())
    assert sidecar["source"] == "test bench"
    assert sidecar["runs"][1] == {
        "run": "r2",
        "machine": "B",
        "max_rpm": 8000,
        "note": None,
    }
    df, back = read_runs(path, metadata=True)
    pd.testing.assert_frame_equal(df, runs)
    assert back["run"].tolist() == ["r0", "r2"]
    assert back["max_rpm"].tolist() == [4000, 8000]
    assert back["note"].iloc[0] == "door opened" and pd.isna(back["note"].iloc[1])
    assert back.attrs == {"source": "test bench"}


def test_metadata_forms(tmp_path, runs):
    path = tmp_path / "runs.parquet"
    write_runs(runs, path, metadata={"r1": {"date": "2024-05-01"}})
    _, meta = read_runs(path, metadata=True)
    assert meta.to_dict("records") == [{"run": "r1", "date": "2024-05-01"}]
    frame = pd.DataFrame({"machine": ["A"]}, index=pd.Index(["r0"], name="run"))
    write_runs(runs, path, metadata=frame)
    _, meta = read_runs(path, metadata=True)
    assert meta.to_dict("records") == [{"run": "r0", "machine": "A"}]


def test_no_sidecar_gives_empty_metadata(tmp_path, runs):
    path = tmp_path / "runs.csv"
    write_runs(runs, path)
    df, meta = read_runs(path, metadata=True)
    assert list(meta.columns) == ["run"] and len(meta) == 0
    assert isinstance(read_runs(path), pd.DataFrame)


def test_write_without_metadata_removes_stale_sidecar(tmp_path, runs):
    path = tmp_path / "runs.csv"
    write_runs(runs, path, metadata={"r0": {"machine": "A"}})
    write_runs(runs, path)
    assert not (tmp_path / "runs.csv.json").exists()


def test_metadata_errors(tmp_path, runs):
    path = tmp_path / "runs.csv"
    with pytest.raises(ValueError, match=r"run\(s\) \['r7'\] that are not in"):
        write_runs(runs, path, metadata={"r7": {"machine": "A"}})
    with pytest.raises(ValueError, match=r"keyed by run"):
        write_runs(runs, path, metadata=pd.DataFrame({"machine": ["A"]}))
    with pytest.raises(ValueError, match=r"\['r0'\] more than once"):
        write_runs(runs, path, metadata=[{"run": "r0"}, {"run": "r0"}])
    with pytest.raises(ValueError, match=r"maps every run to its fields.*'machine'"):
        write_runs(runs, path, metadata={"machine": "x"})
    write_runs(runs, path)
    (tmp_path / "runs.csv.json").write_text('{"machine": "A"}')
    with pytest.raises(ValueError, match=r"runs.csv.json has no 'runs' list"):
        read_runs(path, metadata=True)
    (tmp_path / "runs.csv.json").write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_runs(path, metadata=True)
    # A bare list of records is accepted.
    (tmp_path / "runs.csv.json").write_text('[{"run": "r1", "x": 1}]')
    assert read_runs(path, metadata=True)[1]["x"].tolist() == [1]


def test_read_validates(tmp_path, runs):
    path = tmp_path / "runs.csv"
    runs.rename(columns={"T1_C": "T1_K"}).to_csv(path, index=False)
    with pytest.raises(ValueError, match="'T1_K' looks like a temperature sensor"):
        read_runs(path)
    assert "T1_K" in read_runs(path, validate=False).columns


@pytest.mark.parametrize(
    "names, hint",
    [
        (["T_sp_front_C"], "('T_sp_front_C' -> 'Tsp_front_C'?)"),
        (["t1_c", "t2_c"], "('t1_c' -> 'T1_C', 't2_c' -> 'T2_C'?)"),
        (["Disp_Z_um"], "('Disp_Z_um' -> 'disp_Z_um'?)"),
        (
            ["DISP_Z_UM", "disp-x-um"],
            "('DISP_Z_UM' -> 'disp_z_um', 'disp-x-um' -> 'disp_x_um'?)",
        ),
        (["T-1-C"], "('T-1-C' -> 'T1_C'?)"),
        (["s_ram_ue"], "('s_ram_ue' -> 'Sram_ue'?)"),
        (["S05"], "e.g. 'Sram1_ue'"),  # dropped from the sensors before
        # another unit: no rename, the conversion
        (["disp_x_mm"], "e.g. 'disp_y_um' (in mm? multiply by 1000 for 'disp_x_um')"),
    ],
)
def test_a_name_off_by_its_separators_gets_its_rename(runs, names, hint):
    # 'T_sp_front_C' was refused with the rule alone.
    table = runs.drop(columns=["T1_C"]).assign(**dict.fromkeys(names, 20.0))
    with pytest.raises(ValueError) as info:
        validate_runs(table)
    assert str(info.value).endswith(hint + "."), str(info.value)


def test_write_validates(tmp_path, runs):
    path = tmp_path / "runs.csv"
    with pytest.raises(ValueError, match="'disp_y' looks like a displacement"):
        write_runs(runs.rename(columns={"disp_y_um": "disp_y"}), path)
    assert not path.exists()


def test_read_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        read_runs(tmp_path / "nope.csv")


# --- read_runs: empty, cut and damaged files ----------------------------------


@pytest.mark.parametrize("name", ["runs.csv", "runs.csv.gz", "runs.parquet"])
def test_read_empty_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"")
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: empty file"):
        read_runs(path)


def test_read_compressed_empty_table(tmp_path):
    path = tmp_path / "runs.csv.gz"
    with gzip.open(path, "wb") as fh:
        fh.write(b"\n")
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: empty file"):
        read_runs(path)


@pytest.mark.parametrize("keep", [0.5, 0.9, 20])
def test_read_truncated_csv_gz(tmp_path, runs, keep):
    path = tmp_path / "runs.csv.gz"
    write_runs(runs, path)
    data = path.read_bytes()
    path.write_bytes(data[: int(keep * len(data)) if keep < 1 else keep])
    with pytest.raises(
        ValueError, match=rf"{re.escape(str(path))}: the file is cut off"
    ):
        read_runs(path)


def test_read_not_gzip(tmp_path, runs):
    path = tmp_path / "runs.csv.gz"
    runs.to_csv(path, index=False, compression=None)
    with pytest.raises(
        ValueError, match=rf"{re.escape(str(path))}: the file is cut off or damaged"
    ):
        read_runs(path)


def test_read_names_a_file_whose_name_hides_its_kind(tmp_path, runs):
    # Read as text, gzip data was "a '|' separator" and a Parquet file a
    # stray carriage return.
    text = runs.to_csv(index=False).encode()
    (tmp_path / "plain.csv").write_bytes(gzip.compress(text))
    with pytest.raises(
        ValueError, match=r"holds gzip-compressed data, .*plain\.csv\.gz"
    ):
        read_runs(tmp_path / "plain.csv")
    (tmp_path / "twice.csv.gz").write_bytes(gzip.compress(gzip.compress(text)))
    with pytest.raises(ValueError, match=r"compressed twice: .* compressed once"):
        read_runs(tmp_path / "twice.csv.gz")
    pytest.importorskip("pyarrow")
    runs.to_parquet(tmp_path / "table.csv")
    with pytest.raises(ValueError, match=r"a Parquet file, .* table\.parquet"):
        read_runs(tmp_path / "table.csv")


@pytest.mark.parametrize("newline", [True, False])
def test_read_csv_cut_mid_line(tmp_path, runs, newline):
    path = tmp_path / "runs.csv"
    text = runs.to_csv(index=False)
    cut = text[: text.rstrip("\n").rfind(",")]  # last row loses its last field
    path.write_text(cut + ("\n" if newline else ""))
    end = "" if newline else " and no line end"
    with pytest.raises(
        ValueError,
        match=rf"{re.escape(str(path))}: the file is cut off: its last line "
        rf"\(line 13\) has 9 of the 10 fields of the header{end}",
    ):
        read_runs(path)
    # Also without validation: the cut is not read as a missing value.
    with pytest.raises(ValueError, match="the file is cut off"):
        read_runs(path, validate=False)


def test_read_csv_cut_in_compressed_file(tmp_path, runs):
    path = tmp_path / "runs.csv.gz"
    text = runs.to_csv(index=False)
    with gzip.open(path, "wt") as fh:
        fh.write(text[: text.rfind(",", 0, -30)])
    with pytest.raises(ValueError, match="runs.csv.gz: the file is cut off"):
        read_runs(path)


def test_read_csv_empty_trailing_field_is_not_a_cut(tmp_path, runs):
    path = tmp_path / "runs.csv"
    runs.assign(note="").to_csv(path, index=False)  # every row ends with ","
    assert path.read_text().splitlines()[-1].endswith(",")
    assert len(read_runs(path)) == len(runs)
    path.write_text(path.read_text().rstrip("\n"))  # nor without a line end
    assert len(read_runs(path)) == len(runs)
    # A last value left empty, without a line end, is read as missing: the
    # bytes cannot tell it from a file cut right after the separator.
    path.write_text(runs.to_csv(index=False).rstrip("\n")[:-1].rsplit(",", 1)[0] + ",")
    assert read_runs(path, validate=False).iloc[-1].isna().sum() == 1


def test_read_damaged_parquet(tmp_path, runs):
    pytest.importorskip("pyarrow")
    path = tmp_path / "runs.parquet"
    write_runs(runs, path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(
        ValueError,
        match=rf"{re.escape(str(path))}: not a readable Parquet file: the file is "
        "cut off or damaged",
    ):
        read_runs(path)


def test_read_binary_csv(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_bytes(b"run,time_s\n\xff\xfe\x00\x01,0\n")
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}: not a UTF-8"):
        read_runs(path)


def test_read_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="a folder, not a file"):
        read_runs(tmp_path)


def test_read_validation_error_names_file(tmp_path, runs):
    path = tmp_path / "runs.csv"
    with_value(runs, "spindle_rpm", 2, -10.0).to_csv(path, index=False)
    with pytest.raises(
        ValueError, match=rf"^{re.escape(str(path))}: Column 'spindle_rpm' must"
    ):
        read_runs(path)


def test_empty_or_cut_sidecar(tmp_path, runs):
    path = tmp_path / "runs.csv"
    write_runs(runs, path, metadata={"r0": {"machine": "B"}})
    sidecar = tmp_path / "runs.csv.json"
    text = sidecar.read_text()
    sidecar.write_text(text[: len(text) // 2])
    with pytest.raises(
        ValueError,
        match=rf"{re.escape(str(sidecar))} is not valid JSON \(the file is cut off\)",
    ):
        read_runs(path, metadata=True)
    sidecar.write_text('{"runs": [{"run": "r0"}}')  # mistyped, not cut
    with pytest.raises(ValueError, match="not valid JSON: ") as info:
        read_runs(path, metadata=True)
    assert "cut off" not in str(info.value)
    sidecar.write_text("")
    with pytest.raises(ValueError, match=rf"{re.escape(str(sidecar))}: empty file"):
        read_runs(path, metadata=True)


def test_load_fl_thermal_cut_file(tmp_path):
    path = tmp_path / "fl_thermal_spindle.csv.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("time_s,spindle_rpm,T1_C\n0,0,20.0\n15,0")
    with pytest.raises(ValueError, match="fl_thermal_spindle.csv.gz: the file is cut"):
        load_fl_thermal(tmp_path)


# --- concat_runs --------------------------------------------------------------


def _simulated(run, rpm):
    from skthermal.simulate import ThermalMachine

    machine = ThermalMachine.from_preset("vmc-b")
    return machine.simulate([(300, rpm)], run=run, sample_period_s=60, noise=False)


def test_concat_runs_keeps_simulated_metadata(tmp_path):
    a, b = _simulated("a", 2000), _simulated("b", 0)
    assert "metadata" not in pd.concat([a, b]).attrs  # what pandas does
    runs = concat_runs([a, b])
    pd.testing.assert_frame_equal(runs, pd.concat([a, b], ignore_index=True))
    assert runs.attrs["metadata"] == a.attrs["metadata"] + b.attrs["metadata"]
    assert [m["run"] for m in runs.attrs["metadata"]] == ["a", "b"]
    # The inputs keep their own metadata.
    assert [m["run"] for m in a.attrs["metadata"]] == ["a"]
    path = tmp_path / "runs.csv"
    write_runs(runs, path, metadata=runs.attrs["metadata"])
    assert read_runs(path, metadata=True)[1]["run"].tolist() == ["a", "b"]


def test_concat_runs_duplicate_run(runs):
    with pytest.raises(
        ValueError, match=r"Run 'r1' is in run table 0 and in run table 1"
    ):
        concat_runs([runs, runs[runs["run"] == "r1"]])


def test_concat_runs_columns_differ(runs):
    other = runs.assign(run=runs["run"] + "b").drop(columns="T1_C").assign(x=1)
    with pytest.raises(
        ValueError,
        match=r"columns of run table 1 differ .*missing \['T1_C'\], extra \['x'\]",
    ):
        concat_runs([runs, other])


def test_concat_runs_metadata_argument_and_errors(runs):
    a, b = runs.iloc[:4], runs.iloc[4:]
    out = concat_runs([a, b], metadata={"r0": {"m": 1}, "r2": {"m": 2}})
    assert out.attrs["metadata"] == [{"run": "r0", "m": 1}, {"run": "r2", "m": 2}]
    assert "metadata" not in concat_runs([a, b]).attrs
    with pytest.raises(ValueError, match=r"run\(s\) \['r9'\] that are in none"):
        concat_runs([a, b], metadata={"r9": {"m": 1}})
    with pytest.raises(ValueError, match="a list of run tables"):
        concat_runs(runs)
    with pytest.raises(ValueError, match="Run table 1 has no 'run' column"):
        concat_runs([a, b.drop(columns="run")])
    with pytest.raises(ValueError, match="at least one"):
        concat_runs([])
    bad = b.copy()
    bad.loc[5, "spindle_rpm"] = -1.0
    with pytest.raises(ValueError, match="'spindle_rpm' must hold"):
        concat_runs([a, bad])


def test_concat_runs_of_pieces_filtered_from_one_campaign():
    # pandas filtering keeps attrs: each piece carries the records of all
    # six tests; the joined table keeps those of its own runs.
    from skthermal.datasets import make_machine_b_tests

    campaign = make_machine_b_tests(sample_period_s=1200, random_state=0)
    heating = campaign[campaign["run"].isin(["I", "II"])]
    cooling = campaign[campaign["run"].isin(["V"])]
    assert len(heating.attrs["metadata"]) == 6
    joined = concat_runs([heating, cooling])
    assert [r["run"] for r in joined.attrs["metadata"]] == ["I", "II", "V"]


# --- load_fl_thermal ---------------------------------------------------------


def test_load_fl_thermal(shared_data):
    df = load_fl_thermal(shared_data / "fl_thermal_spindle.csv.gz")
    assert df.shape == (11115, 24)
    assert df.columns[0] == "run" and (df["run"] == "fl_thermal").all()
    assert sensor_columns(df) == [f"T{i}_C" for i in range(1, 17)]
    assert target_columns(df) == [f"disp_ch{i}_um" for i in range(1, 6)]
    assert driver_columns(df) == ["spindle_rpm"]
    assert validate_runs(df, require_targets=True) is df
    assert np.all(np.diff(df["time_s"]) == 15)
    # Values unchanged: first row as in the file.
    assert df["time_s"].iloc[0] == 0 and df["disp_ch1_um"].iloc[0] == 0.377452788
    assert df["T1_C"].iloc[0] == 26.1908623380691
    # Duty cycle: 1250 rpm for the first 4 h (hour 1-3).
    assert set(df.loc[df["time_s"].between(3600, 3 * 3600), "spindle_rpm"]) == {1250}
    X, y, groups = split_runs(df)
    assert X.shape == (11115, 16) and y.shape == (11115, 5)
    assert set(groups) == {"fl_thermal"}


def test_load_fl_thermal_from_folder(shared_data):
    df = load_fl_thermal(shared_data)
    assert len(df) == 11115


def test_load_fl_thermal_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="fl_thermal_spindle.csv.gz"):
        load_fl_thermal(tmp_path)
    with pytest.raises(FileNotFoundError, match="not found"):
        load_fl_thermal(tmp_path / "other.csv")
    path = tmp_path / "fl_thermal_spindle.csv.gz"
    pd.DataFrame({"time_s": [0, 15], "T1_C": [1.0, 2.0]}).to_csv(path, index=False)
    with pytest.raises(ValueError, match="does not look like.*'spindle_rpm'"):
        load_fl_thermal(tmp_path)


def test_split_runs_index_carries_runs_through_cross_validate():
    seen = []

    def record_runs(X):
        seen.append(extract_runs(X)[1])
        return X

    df = make_runs(n_runs=6, n_rows=5)
    X, y, groups = split_runs(df, targets="disp_y_um")
    pipe = make_pipeline(FunctionTransformer(record_runs), LinearRegression())
    cross_validate(pipe, X, y, groups=groups, cv=GroupKFold(3), error_score="raise")
    assert len(seen) > 0
    for labels in seen:
        assert labels is not None and len(labels) in (10, 20)
        assert set(labels) <= set(groups)


def test_ambient_proxy_picks_the_sensor_the_spindle_does_not_heat():
    from skthermal.datasets import ambient_proxy

    rng = np.random.RandomState(0)
    t = np.arange(0, 6 * 3600, 60.0)
    rpm = np.where((t // 3600) % 2 == 0, 5000.0, 0.0)
    warm = np.cumsum(rpm) / 5e5
    frames = []
    for run in ("a", "b"):
        air = 20 + 0.5 * np.sin(t / 9000 + (run == "b")) + rng.normal(0, 0.02, t.size)
        frames.append(
            pd.DataFrame(
                {
                    "run": run,
                    "time_s": t,
                    "spindle_rpm": rpm,
                    "T1_C": air + warm,
                    "T2_C": air,
                    "T3_C": air + 0.3 * warm,
                }
            )
        )
    runs = pd.concat(frames, ignore_index=True)
    name, scores = ambient_proxy(runs, return_scores=True)
    assert name == "T2_C" and scores.idxmax() == "T1_C"
    with pytest.raises(ValueError, match="needs a 'spindle_rpm' column"):
        ambient_proxy(runs.drop(columns="spindle_rpm"))
    with pytest.raises(ValueError, match="never turns"):
        ambient_proxy(runs.assign(spindle_rpm=0.0))
    with pytest.raises(ValueError, match="temperature sensors"):
        ambient_proxy(runs[["run", "time_s", "spindle_rpm"]])
    # A column twice: named (a pandas TypeError or a 2-D run label before).
    for col in ("T1_C", "run"):
        with pytest.raises(ValueError, match=rf"duplicated columns: \['{col}'\]"):
            ambient_proxy(pd.concat([runs, runs[[col]]], axis=1))


# --- CSV run labels, metadata and malformed CSV files -------------------------


def _labelled(labels, n_rows=2):
    return pd.DataFrame(
        {
            "run": np.repeat(np.asarray(labels, dtype=object), n_rows).tolist(),
            "time_s": np.tile(np.arange(n_rows) * 60.0, len(labels)),
            "T1_C": np.linspace(20.0, 22.0, n_rows * len(labels)),
            "disp_y_um": np.linspace(0.0, 3.0, n_rows * len(labels)),
        }
    )


@pytest.mark.parametrize(
    "labels", [["01", "02"], ["NA", "None"], ["1", "2"], [1, 2], ["a", "2"]]
)
@pytest.mark.parametrize("name", ["runs.csv", "runs.csv.gz"])
def test_csv_run_labels_survive_the_round_trip(tmp_path, labels, name):
    df = _labelled(labels)
    path = tmp_path / name
    write_runs(df, path, metadata={labels[0]: {"machine": "B"}})
    back, meta = read_runs(path, metadata=True)
    assert back["run"].tolist() == df["run"].tolist()
    assert meta["run"].tolist() == [labels[0]]
    # The same without metadata.
    write_runs(df, path)
    assert read_runs(path)["run"].tolist() == df["run"].tolist()


def test_csv_string_labels_that_look_like_numbers_are_recorded(tmp_path):
    path = tmp_path / "runs.csv"
    write_runs(_labelled(["1", "2"]), path)
    assert json.loads((tmp_path / "runs.csv.json").read_text()) == {
        "run_labels": "str",
        "runs": [],
    }
    _, meta = read_runs(path, metadata=True)
    assert len(meta) == 0 and meta.attrs == {}
    # Integer labels need no sidecar; whole numbers without one read as ints.
    write_runs(_labelled([1, 2]), path)
    assert not (tmp_path / "runs.csv.json").exists()
    assert read_runs(path)["run"].tolist() == [1, 1, 2, 2]


def test_csv_labels_typed_by_the_sidecar_records(tmp_path):
    # A file written before the labels were recorded: string labels in the
    # sidecar say the table's labels are strings.
    path = tmp_path / "runs.csv"
    _labelled([1, 2]).to_csv(path, index=False)
    (tmp_path / "runs.csv.json").write_text('{"runs": [{"run": "1", "m": "x"}]}')
    back, meta = read_runs(path, metadata=True)
    assert back["run"].tolist() == ["1", "1", "2", "2"]
    assert set(meta["run"]) <= set(back["run"])
    (tmp_path / "runs.csv.json").write_text('{"run_labels": "int", "runs": []}')
    with pytest.raises(ValueError, match="'run_labels' must be 'str'"):
        read_runs(path, metadata=True)


@pytest.mark.parametrize(
    "labels, message",
    [
        (["", "a"], r"Run label '' \(an empty string\) cannot be written to CSV"),
        ([1, "1"], r"Run labels mix kinds: row 0 has 1 \(int\), row 2 has '1'"),
        ([1.5, 2.0], r"Run label 1.5 \(float\) cannot be written to CSV"),
        ([True, False], r"Run label True \(bool\) cannot be written to CSV"),
    ],
)
def test_csv_refuses_labels_it_cannot_read_back(tmp_path, labels, message):
    path = tmp_path / "runs.csv"
    with pytest.raises(ValueError, match=message):
        write_runs(_labelled(labels), path, validate=False)
    assert not path.exists()


def test_csv_refuses_integer_labels_of_over_18_digits(tmp_path):
    # uint64 test ids above 2**63 - 1 read back as text: a model that had
    # remembered those runs took the re-read ones as new runs.
    df = _labelled([2**64 - 2, 2**64 - 1]).astype({"run": "uint64"})
    with pytest.raises(ValueError, match=r"Run label 18446744073709551614 .* text"):
        write_runs(df, tmp_path / "runs.csv")
    assert not (tmp_path / "runs.csv").exists()
    small = _labelled([10**18 - 2, 10**18 - 1]).astype({"run": "uint64"})
    write_runs(small, tmp_path / "runs.csv")
    assert read_runs(tmp_path / "runs.csv")["run"].tolist() == small["run"].tolist()


@pytest.mark.parametrize(
    "labels, shown",
    [
        (
            pd.to_datetime(["2024-03-01 08:00", "2024-03-02 08:00"]),
            r"Timestamp\('2024-03-01 08:00:00'\) \(Timestamp\).* "
            r"df\['run'\]\.dt\.strftime",
        ),
        ([b"a", b"b"], r"b'a' \(bytes\).* df\['run'\]\.astype\(str\)"),
        ([(1, 2), (3, 4)], r"\(1, 2\) \(tuple\)"),
        ([decimal.Decimal("1"), decimal.Decimal("2")], r"Decimal\('1'\) \(Decimal\)"),
        ([np.inf, 1.0], r"inf \(float\)"),
        (["", "a"], r"'' \(an empty string\)"),
    ],
    ids=["dates", "bytes", "tuples", "decimal", "inf", "empty"],
)
def test_run_labels_no_file_stores_are_refused(tmp_path, labels, shown):
    # Dates as run labels passed read_runs, fit and evaluate, and then
    # skthermal predict could write them neither to CSV nor to Parquet.
    df = _labelled(["a", "b"])
    repeated = [label for label in labels for _ in range(2)]
    df["run"] = (
        pd.to_datetime(repeated)
        if isinstance(labels, pd.DatetimeIndex)
        else pd.Series(repeated, dtype=object)
    )
    with pytest.raises(
        ValueError, match=r"Column 'run': row 0 has the run label " + shown
    ):
        validate_runs(df)


@pytest.mark.parametrize("name", ["runs.parquet", "runs.csv"])
@pytest.mark.parametrize(
    "labels, message",
    [
        ([1, "b"], r"row 0 has 1 \(int\), row 2 has 'b' \(string\)"),
        (["a", 2.5], r"row 0 has 'a' \(string\), row 2 has 2.5 \(float\)"),
    ],
)
def test_run_labels_of_mixed_kinds_are_refused_by_name(tmp_path, name, labels, message):
    # Parquet gave pyarrow's own error ("Could not convert 'b' with type
    # str: tried to convert to int64"), which names no fix.
    df = _labelled(labels)
    full = (
        r"Column 'run': Run labels mix kinds: " + message + r".*all strings.*"
        r"df\['run'\] = df\['run'\]\.astype\(str\)"
    )
    with pytest.raises(ValueError, match=full):
        validate_runs(df)
    with pytest.raises(ValueError, match=full):
        write_runs(df, tmp_path / name)
    # Also unvalidated: the labels are checked for every format.
    with pytest.raises(ValueError, match=full):
        write_runs(df, tmp_path / name, validate=False)
    assert not (tmp_path / name).exists()
    # As the message says: strings write and read back.
    fixed = df.assign(run=df["run"].astype(str))
    write_runs(fixed, tmp_path / name)
    assert read_runs(tmp_path / name)["run"].tolist() == fixed["run"].tolist()


def test_empty_metadata_is_accepted(tmp_path, runs):
    path = tmp_path / "runs.csv"
    write_runs(runs, path)
    back, meta = read_runs(path, metadata=True)
    copy = tmp_path / "copy.csv"
    write_runs(back, copy, metadata=meta)
    assert not (tmp_path / "copy.csv.json").exists()
    for empty in ([], {}, pd.DataFrame()):
        write_runs(runs, copy, metadata=empty)
        assert not (tmp_path / "copy.csv.json").exists()
    # A sidecar without records (as written before) reads as no metadata.
    (tmp_path / "copy.csv.json").write_text('{"runs": []}')
    _, meta = read_runs(copy, metadata=True)
    assert list(meta.columns) == ["run"] and len(meta) == 0
    # Top-level fields without records are kept.
    meta = pd.DataFrame({"run": []})
    meta.attrs["campaign"] = "spring"
    write_runs(runs, copy, metadata=meta)
    assert read_runs(copy, metadata=True)[1].attrs == {"campaign": "spring"}


def test_failed_write_leaves_the_old_files(tmp_path, runs):
    path = tmp_path / "runs.csv"
    write_runs(runs, path, metadata={"r0": {"machine": "old"}})
    before = path.read_bytes(), (tmp_path / "runs.csv.json").read_bytes()
    new = runs.assign(run=runs["run"] + "x")
    with pytest.raises(ValueError, match=r"run\(s\) \['r0'\] that are not in"):
        write_runs(new, path, metadata={"r0": {"machine": "new"}})
    assert (path.read_bytes(), (tmp_path / "runs.csv.json").read_bytes()) == before


def test_csv_trailing_separators_are_ignored(tmp_path, runs):
    path = tmp_path / "runs.csv"
    text = runs.to_csv(index=False).replace("\n", ",\n")
    path.write_text(text.replace(",\n", "\n", 1))  # not on the header line
    pd.testing.assert_frame_equal(read_runs(path), runs)
    # On the header line too: no "Unnamed: 9" column of NaN; and on the
    # header line alone (it was "the file is cut off").
    path.write_text(text)
    pd.testing.assert_frame_equal(read_runs(path), runs)
    path.write_text(text.replace(",\n", "\n").replace("\n", ",\n", 1))
    pd.testing.assert_frame_equal(read_runs(path), runs)
    # A separator written as ", " (a blank field) on every line.
    path.write_text(text.replace(",\n", ", \n"))
    pd.testing.assert_frame_equal(read_runs(path), runs)
    # An unnamed column that holds values is the table's, not a separator's.
    path.write_text(text.replace(",\n", ",1\n").replace(",1\n", ",\n", 1))
    assert read_runs(path).shape[1] == runs.shape[1] + 1


def test_csv_row_with_an_extra_field_names_the_line(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_text("run,time_s,T1_C\nr1,1,0,20\nr1,1,60,21\n")
    with pytest.raises(ValueError, match=r"line 2 has 4 fields but the header has 3"):
        read_runs(path)
    path.write_text("run,time_s,T1_C\nr1,0,20,,\nr1,60,21,,\n")
    with pytest.raises(ValueError, match=r"line 2 .*trailing separators"):
        read_runs(path)
    # A later line with an extra field: pandas' own parser error, "Expected
    # 3 fields in line 11, saw 4", said without the remedy.
    rows = "".join(f"r1,{60 * i},20\n" for i in range(9))
    path.write_text("run,time_s,T1_C\n" + rows + "r1,540,20,7\nr1,600,21\n")
    with pytest.raises(
        ValueError, match=r"line 11 has 4 fields but the header has 3.*one field per"
    ):
        read_runs(path)


def test_csv_duplicated_header_names(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_text("run,time_s,T1_C,T1_C\na,0,20,1\na,60,21,2\n")
    with pytest.raises(ValueError, match=r"more than once: 'T1_C' \(columns 3, 4\)"):
        read_runs(path)


def test_spreadsheet_csv_files_are_named(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_bytes(
        "\ufeffrun;time_s;T1_C\r\na;0;20,5\r\na;60;21,25\r\n".encode("utf-8")
    )
    with pytest.raises(
        ValueError, match=r"seems to use ';' as the separator and decimal commas"
    ):
        read_runs(path)
    path.write_text('run,time_s,T1_C\na,0,"20,5"\na,60,"21,5"\n')
    with pytest.raises(ValueError, match=r"holds '20,5', a number with a decimal"):
        read_runs(path)


def test_header_names_with_spaces_are_named(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_text("run, time_s, T1_C\na, 0, 20\na, 60, 21\n")
    with pytest.raises(ValueError, match=r"has ' time_s': its header name has spaces"):
        read_runs(path)
    df = _labelled(["a"]).rename(columns={"T1_C": " T1_C"}).assign(T2_C=20.0)
    with pytest.raises(ValueError, match=r"' T1_C' looks like the column 'T1_C'"):
        validate_runs(df)


def test_concat_runs_with_a_metadata_frame_in_attrs(tmp_path):
    a, b = _labelled(["a"]), _labelled(["b"])
    write_runs(a, tmp_path / "a.csv", metadata={"a": {"machine": "B"}})
    a, meta = read_runs(tmp_path / "a.csv", metadata=True)
    a.attrs["metadata"] = meta
    b.attrs["metadata"] = [{"run": "b", "machine": "C"}]
    runs = concat_runs([a, b])
    assert runs.attrs["metadata"] == [
        {"run": "a", "machine": "B"},
        {"run": "b", "machine": "C"},
    ]
    assert isinstance(a.attrs["metadata"], pd.DataFrame)  # input untouched


def test_machine_b_tests_single_string_is_one_test():
    from skthermal.datasets import make_machine_b_tests

    runs = make_machine_b_tests("IV", sample_period_s=1200, random_state=0)
    assert pd.unique(runs["run"]).tolist() == ["IV"]


def test_ambient_proxy_refuses_missing_readings_and_unsorted_time():
    from skthermal.datasets import ambient_proxy

    runs = pd.DataFrame(
        {
            "run": ["a"] * 4,
            "time_s": [0.0, 60.0, 120.0, 180.0],
            "spindle_rpm": [0.0, 1000.0, 1000.0, 0.0],
            "T1_C": [20.0, np.nan, 21.0, 22.0],
            "T2_C": [20.0, 20.1, 20.2, 20.3],
        }
    )
    with pytest.raises(
        ValueError, match=r"column 'T1_C' has 1 missing .* run 'a', time_s 60"
    ):
        ambient_proxy(runs)
    unsorted = runs.assign(T1_C=[20.0, 21.0, 21.5, 22.0], time_s=[0, 120, 60, 180])
    with pytest.raises(
        ValueError, match=r"strictly increasing within a run: in run 'a', row 2"
    ):
        ambient_proxy(unsorted)


@pytest.mark.parametrize("column", ["T1_C", "disp_y_um"])
def test_validate_runs_names_absurd_readings(column):
    # Finite but beyond any reading (1e100): a corrupt value that every
    # model refuses, so the table is refused where it is read.
    df = pd.DataFrame(
        {
            "run": ["a"] * 3,
            "time_s": [0.0, 60.0, 120.0],
            "T1_C": [20.0, 20.5, 21.0],
            "disp_y_um": [0.0, 1.0, 2.0],
        }
    )
    df.loc[1, column] = -1e200
    with pytest.raises(
        ValueError,
        match=rf"column '{column}' has 1 absurd \(beyond 1e\+100 in magnitude\) "
        r"value\(s\), the first at run 'a', time_s 60.0 \(row 1\)",
    ):
        validate_runs(df)
    df.loc[1, column] = 1e100  # the bound itself is accepted
    validate_runs(df)


def test_changes_since_start_refuses_runs_out_of_time_order_and_repeated_columns():
    from skthermal.datasets import changes_since_start

    df = pd.DataFrame(
        {
            "run": ["a", "b", "a", "b"],
            "time_s": [120.0, 0.0, 0.0, 60.0],
            "T1_C": [23.0, 20.0, 20.0, 21.0],
        }
    )
    with pytest.raises(ValueError, match=r"in run 'a', row 2 has time_s 0.0"):
        changes_since_start(df)
    # Interleaved runs in time order are fine.
    ok = changes_since_start(df.assign(time_s=[0.0, 0.0, 120.0, 60.0]))
    assert ok["T1_C"].tolist() == [0.0, 0.0, -3.0, 1.0]
    with pytest.raises(ValueError, match=r"duplicated columns: \['T1_C'\]"):
        changes_since_start(pd.concat([df, df[["T1_C"]]], axis=1))


def test_run_files_name_stray_carriage_returns_and_unwritable_labels(tmp_path):
    from skthermal.datasets import read_runs, write_runs

    path = tmp_path / "cr.csv"
    path.write_bytes(b"run,time_s,T1_C\na\r,0,20\n")
    with pytest.raises(ValueError, match=r"cr\.csv: a CSV line cannot be read"):
        read_runs(path)
    df = pd.DataFrame(
        {"run": [(1, "a")] * 2, "time_s": [0.0, 60.0], "T1_C": [20.0, 21.0]}
    )
    with pytest.raises(ValueError, match=r"cannot be written to Parquet"):
        write_runs(df, tmp_path / "t.parquet", validate=False)


def _minimal_table(times, runs):
    return pd.DataFrame(
        {
            "run": runs,
            "time_s": times,
            "T1_C": np.linspace(20.0, 22.0, len(times)),
            "disp_y_um": np.linspace(0.0, 5.0, len(times)),
        }
    )


@pytest.mark.parametrize(
    "scale, unit",
    [
        (1000.0, "milliseconds"),
        (1 / 60.0, "minutes"),
        # "minutes?" before: converted as minutes, still 60 times off
        (1 / 3600.0, r"hours \(or minutes\)"),
    ],
)
def test_time_in_another_unit_than_seconds_warns(scale, unit):
    # A logger's milliseconds or minutes under the time_s header went through
    # every command: time constants and drift rates off by 1000 or 60.
    t = np.tile(np.arange(0.0, 10 * 3600.0, 15.0), 2)  # two 10 h runs, 15 s
    runs = np.repeat(["A", "B"], t.size // 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(_minimal_table(t, runs))
    with pytest.warns(UserWarning, match=rf"is time_s in {unit}\?"):
        validate_runs(_minimal_table(t * scale, runs))


def test_sensors_in_kelvin_warn():
    # Only ambient_C was checked: kelvin in T*_C passed, and an ANFIS with
    # shrunk intercepts trained worse on it without a word.
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3)
    table["T1_C"] += 273.15
    table["T2_C"] = table["T1_C"] - 273.15
    with pytest.warns(
        UserWarning, match=r"column\(s\) 'T1_C' never read below 200 \('T1_C': 293.15"
    ):
        validate_runs(table)
    table["T1_C"] -= 273.15  # a structure at 20-22 °C
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(table)


def test_run_and_time_in_the_index_are_named_with_the_remedy():
    # "The run table has no 'run' column" while it was there, as an index
    # level (what split_runs returns, what the estimators take).
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3).set_index(["run", "time_s"])
    for func in (validate_runs, changes_since_start, split_runs):
        with pytest.raises(ValueError, match=r"it is an index level.*reset_index"):
            func(table)


def test_one_run_in_kelvin_warns_naming_the_run():
    # The kelvin check took whole columns: a logger set to kelvin for one
    # test put that run 273 above the others without a word (an ANFIS then
    # missed it by 500 µm), and workshop air in kelvin named no run.
    table = pd.concat(
        [
            _minimal_table([0.0, 15.0, 30.0], [run] * 3).assign(
                T1_C=lambda t, run=run: t["T1_C"] + (273.15 if run == "B" else 0.0)
            )
            for run in ("A", "B", "C")
        ],
        ignore_index=True,
    )
    with pytest.warns(
        UserWarning,
        match=r"'T1_C' never read below 200 in run\(s\) 'B', and below it in the "
        r"other runs \('T1_C': 293.15 to .* there, 20 to .* elsewhere\): those "
        r"runs logged in kelvin\?",
    ):
        validate_runs(table)
    # A cutting-zone sensor at 230-270 °C in one hot test is no kelvin.
    hot = table.assign(
        T1_C=np.where(table["run"] == "B", 250.0, np.tile([25.0, 90.0, 175.0], 3))
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(hot)
    air = table.assign(ambient_C=np.where(table["run"] == "C", 294.0, 21.0))
    air["T1_C"] = np.tile(np.linspace(20.0, 22.0, 3), 3)
    with pytest.warns(
        UserWarning, match=r"'ambient_C' reads 294 at run 'C', time_s 0.0 \(row 6\)"
    ):
        validate_runs(air)


def test_sensors_in_fahrenheit_warn():
    # Fahrenheit in T*_C passed without a word (68-72 read as °C), though no
    # machine has every part 50 °C or more above freezing at every sample.
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3)
    table["T2_C"] = table["T1_C"] + 30.0
    celsius = table.copy()
    for col in ("T1_C", "T2_C"):
        table[col] = table[col] * 1.8 + 32.0
    with pytest.warns(
        UserWarning,
        match=r"No temperature sensor \('T1_C', 'T2_C'\) ever reads below 50 "
        r"\(the coldest, 'T1_C', from 68\): .* In Fahrenheit\?",
    ):
        validate_runs(table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(celsius)  # one hot part (50-52 °C) beside a cool one


def test_readings_no_machine_gives_warn():
    # One 1e6 °C reading passed without a word, and an unguarded model's
    # prediction at that row was a correction of 1.4 m.
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(table)
    hot = table.assign(T2_C=table["T1_C"])
    hot.loc[1, "T1_C"] = 1e6
    hot.loc[2, "T2_C"] = 900.0
    with pytest.warns(
        UserWarning,
        match=r"Column 'T1_C' holds 1e\+06 at run 'A', time_s 15.0 \(row 1\), and "
        r"so do 'T2_C': no machine tool reads a temperature above 500 °C",
    ):
        validate_runs(hot)
    far = table.copy()
    far["disp_y_um"] = [0.0, 1.0, 2e4]
    far = pd.concat([far, far], ignore_index=True).assign(run=["A"] * 3 + ["B"] * 3)
    with pytest.warns(
        UserWarning,
        match=r"'disp_y_um' holds 20000 at run 'A', time_s 30.0 \(row 2\) \(2 "
        r"such rows in all\): .* further from its run's median than 10000 µm",
    ):
        validate_runs(far)
    # A probe read with an offset of 10 mm is no fault, nor one mounted anew
    # with another offset in one run (it was taken for nanometres).
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(table.assign(disp_y_um=table["disp_y_um"] + 10_500.0))
        remounted = pd.concat([table, table.assign(run="B"), table.assign(run="C")])
        remounted["disp_y_um"] += np.repeat([2000.0, 3000.0, 27_000.0], 3)
        validate_runs(remounted.reset_index(drop=True))
    # One run logged in nm among runs in µm is named, whatever its level.
    ten = np.arange(0.0, 600.0, 60.0)
    runs = pd.concat([_minimal_table(ten, [r] * 10) for r in "ABC"])
    runs.loc[runs["run"] == "B", "disp_y_um"] *= 1000.0
    with pytest.warns(
        UserWarning, match=r"'disp_y_um' moves 5000 within run 'B', 1e\+03 times"
    ):
        validate_runs(runs.reset_index(drop=True))
    # A logger's error code repeated in a run is named as such, not as nm.
    coded = runs.reset_index(drop=True).assign(disp_y_um=lambda d: d["disp_y_um"] / 1e3)
    coded.loc[10:13, "disp_y_um"] = -99999.0
    with pytest.warns(
        UserWarning, match=r"holds -99999 in 4 of the 10 rows of run 'B'"
    ):
        validate_runs(coded)
    # Nanometres under a *_um header: the warning named the run's first
    # reading (0, the likeliest value) a glitch, with no word of the unit.
    t = np.arange(0.0, 3600.0, 60.0)
    nm = _minimal_table(t, ["A"] * t.size)
    nm["disp_y_um"] = -30_000.0 * (1 - np.exp(-t / 900.0)) + 5000.0 * np.sin(t / 600)
    with pytest.warns(
        UserWarning,
        # (It quotes the largest reading, not the run's zero start: an
        # independent check read "holds 0" as the fault.)
        match=r"'disp_y_um' holds -1\d{4}\.?\d* at .*: .* In another unit\? "
        r"Columns \*_um are read as µm \(nanometres: divide by 1000\)",
    ) as caught:
        validate_runs(nm)
    assert not any("glitch" in str(w.message) for w in caught)


def test_runs_that_start_before_zero_warn():
    # A run from -5000 s passed silently; one from +3600 s was warned about.
    t = np.arange(0.0, 4 * 3600.0, 60.0)
    table = _minimal_table(np.r_[t - 5000.0, t], np.repeat(["A", "B"], t.size))
    with pytest.warns(UserWarning, match=r"1 of the 2 runs start before 0 \(at -5000"):
        validate_runs(table)
    one_step = _minimal_table(np.r_[t - 60.0, t], np.repeat(["A", "B"], t.size))
    with pytest.warns(UserWarning, match=r"1 of the 2 runs start before 0 \(at -60"):
        validate_runs(one_step)


def test_changes_of_an_empty_table_are_an_empty_table():
    empty = _minimal_table([0.0, 15.0], ["A", "A"]).iloc[:0]
    assert changes_since_start(empty).empty


def test_thousands_separators_are_not_called_decimal_commas():
    # "1,250" rpm was called a decimal comma: following the advice gave 1.25.
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3)
    table["spindle_rpm"] = ["1,250", "2,500", "12,500.5"]
    with pytest.raises(ValueError, match=r"holds '1,250', a number with thousands"):
        validate_runs(table)
    table["spindle_rpm"] = ["1,25", "2,5", "3,75"]
    with pytest.raises(
        ValueError, match=r"holds '1,25', a number with a decimal comma"
    ):
        validate_runs(table)


_HEADER = "run,time_s,T1_C,disp_y_um\n"
_ROWS = "A,0,20.0,0.0\nA,15,20.5,1.0\nA,30,21.0,2.0\n"


@pytest.mark.parametrize(
    "text, message",
    [
        # a comment line, and a logger's preamble, above the header
        (
            "# Logger export, 2024\n" + _HEADER + _ROWS,
            r"header .* is line 2.*skiprows=1",
        ),
        (
            "Device,XY\nSerial,1\nStart,x\n\n" + _HEADER + _ROWS,
            r"is line 5.*skiprows=4",
        ),
        # a row of units under the header
        (_HEADER + ",s,degC,um\n" + _ROWS, r"holds 's'.*a row of units\? Delete it"),
        # every temperature column in Fahrenheit: the rule said once
        (
            "run,time_s,T1_F,T2_F,T3_F,disp_y_um\nA,0,68,68,68,0\n",
            r"'T1_F', 'T2_F', 'T3_F' \(3 columns\) look like temperature sensors",
        ),
    ],
)
def test_logger_exports_get_a_hint(tmp_path, text, message):
    path = tmp_path / "runs.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        read_runs(path)


def test_a_latin1_file_is_told_to_be_saved_as_utf8(tmp_path):
    path = tmp_path / "runs.csv"
    path.write_bytes(
        (_HEADER + "A,0,20.0,0.0\nA,15,20.5,1.0 \u00b0\n").encode("cp1252")
    )
    with pytest.raises(
        ValueError, match=r"not UTF-8: line 3 holds the byte 0xb0 \('°'"
    ):
        read_runs(path)


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_a_utf16_file_is_told_to_be_saved_as_utf8(tmp_path, encoding):
    # A spreadsheet's "Unicode text" export: it was called cut off, its last
    # line quoted as a stray zero byte.
    path = tmp_path / "runs.csv"
    path.write_bytes((_HEADER + "A,0,20.0,0.0\nA,15,20.5,1.0\n").encode(encoding))
    with pytest.raises(
        ValueError, match=rf"UTF-16 text, not UTF-8.*encoding='{encoding}'"
    ):
        read_runs(path)
    # A logger's file padded with zero bytes (a power loss) is no UTF-16.
    path.write_bytes((_HEADER + "A,0,20.0,0.0\nA,15,20.5,1.0\n").encode() + bytes(8192))
    with pytest.raises(ValueError) as err:
        read_runs(path)
    assert "UTF-16" not in str(err.value)


@pytest.mark.parametrize("air, guess", [(80.0, "Fahrenheit"), (293.0, "kelvin")])
def test_workshop_air_in_another_unit_warns(air, guess):
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3).assign(ambient_C=air)
    with pytest.warns(UserWarning, match=rf"'ambient_C' reads {air:g}.*in {guess}\?"):
        validate_runs(table)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        validate_runs(table.assign(ambient_C=21.0))


def test_a_timestamp_column_gets_the_conversion_to_time_s():
    table = _minimal_table([0.0, 15.0, 30.0], ["A"] * 3).drop(columns="time_s")
    table["timestamp"] = ["2024-03-04T08:00:00", "2024-03-04T08:00:15", "x"]
    with pytest.raises(
        ValueError, match=r"might be it: \['timestamp'\]\. It holds clock times"
    ):
        validate_runs(table)
    table["timestamp"] = [0.0, 15.0, 30.0]  # numbers: a rename, no conversion
    with pytest.raises(ValueError, match=r"might be it: \['timestamp'\]\.$"):
        validate_runs(table)


def test_plausible_times_do_not_warn():
    # From an independent check of the warnings: runs whose first sample is
    # one period in, a 30 min test logged every 0.5 s, a 35-day soak logged
    # every 10 min, an arctic chamber.
    cases = [
        (np.tile(np.arange(15.0, 3600.0, 15.0), 3), 3),
        (np.arange(0.0, 1800.0, 0.5), 1),
        (np.arange(0.0, 35 * 86400.0, 600.0), 1),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for t, n_runs in cases:
            runs = np.repeat([f"r{k}" for k in range(n_runs)], t.size // n_runs)
            validate_runs(_minimal_table(t, runs))
        validate_runs(_minimal_table([0.0, 15.0], ["A"] * 2).assign(ambient_C=-30.0))


def test_warn_implausible_reads_interleaved_runs():
    # The gap diagnosis reads its tables without validate_runs; it calls this.
    from skthermal.datasets._runtable import warn_implausible

    t = np.arange(0.0, 8 * 3600.0, 30.0) * 1000.0  # 8 h in milliseconds
    table = _minimal_table(np.r_[t, t], np.repeat(["a", "b"], t.size))
    table = table.iloc[np.argsort(np.r_[t, t], kind="stable")]  # interleaved
    with pytest.warns(UserWarning, match=r"is time_s in milliseconds\?"):
        warn_implausible(table)


def _three_runs(n=30):
    """Three runs A, B, C of ``n`` rows at 60 s: two sensors warming by
    3 K, a displacement moving by 8 µm."""
    t = np.arange(n) * 60.0
    parts = []
    for k, run in enumerate("ABC"):
        rise = 3.0 * (1 - np.exp(-t / 600.0))
        parts.append(
            pd.DataFrame(
                {
                    "run": run,
                    "time_s": t,
                    "T1_C": 20.0 + k * 0.3 + rise,
                    "T2_C": 21.0 + rise / 2,
                    "disp_y_um": 8.0 * rise / 3.0,
                }
            )
        )
    return pd.concat(parts, ignore_index=True)


def _said(table):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        validate_runs(table)
    return [str(w.message) for w in caught]


def test_units_and_labels_that_passed_in_silence_are_said():
    # An independent check of logger exports: each of these passed
    # validate_runs and the CLI without a word, the models taking it as
    # data (training errors of 2-11 µm where the clean table's was 1e-4).
    assert _said(_three_runs()) == []
    # One test logged under two labels that differ in a space or in case.
    table = _three_runs()
    table.loc[table.index[15:30], "run"] = "A "
    assert any("Run labels 'A' and 'A ' differ only in spaces or case" in m
               for m in _said(table))  # fmt: skip
    table = _three_runs()
    table.loc[table["run"] == "C", "run"] = "a"
    assert any("'A' and 'a' differ only" in m for m in _said(table))
    # A logger set to Fahrenheit for one run.
    table = _three_runs()
    b = table["run"] == "B"
    table.loc[b, ["T1_C", "T2_C"]] = table.loc[b, ["T1_C", "T2_C"]] * 1.8 + 32
    said = _said(table)
    assert any("in run(s) 'B'" in m and "Fahrenheit" in m for m in said), said
    # A displacement in mm: the whole table, or one run.
    table = _three_runs()
    table["disp_y_um"] /= 1000.0
    said = _said(table)
    assert any("moves at most 0.00756 within a run" in m and "millimetres" in m
               for m in said), said  # fmt: skip
    table = _three_runs()
    table.loc[b, "disp_y_um"] /= 1000.0
    said = _said(table)
    assert any("within run(s) 'B'" in m and "millimetres" in m for m in said), said
    # A logger's 0 for no reading.
    table = _three_runs()
    table.loc[[5, 6, 40], "T1_C"] = 0.0
    said = _said(table)
    assert any("'T1_C' reads exactly 0 at run 'A', time_s 300.0 (row 5) (3 such"
               in m for m in said), said  # fmt: skip
    # Spindle speeds in krpm, or "2.000" read as 2 (a thousands dot).
    table = _three_runs().assign(spindle_rpm=2.0)
    said = _said(table)
    assert any("'spindle_rpm' never exceeds 2 (rpm)" in m for m in said), said
    assert not _said(_three_runs().assign(spindle_rpm=2000.0))
    assert not _said(_three_runs().assign(spindle_rpm=0.0))  # at rest
    # Readings near 0 °C (a cold room) are readings.
    cold = _three_runs()
    cold[["T1_C", "T2_C"]] -= 21.0
    assert not any("exactly 0" in m for m in _said(cold))


def test_a_spreadsheet_workbook_is_named_as_one(tmp_path):
    # An independent check: an .xlsx was told to be renamed .zip, which then
    # failed with "must hold exactly one file, found 4"; an .xls got a
    # UTF-8 decoding message. Neither said to save the sheet as CSV.
    import zipfile

    xlsx = tmp_path / "runs.xlsx"
    with zipfile.ZipFile(xlsx, "w") as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        z.writestr("xl/workbook.xml", "<workbook/>")
    renamed = tmp_path / "runs.xlsx.zip"
    renamed.write_bytes(xlsx.read_bytes())
    xls = tmp_path / "runs.xls"
    xls.write_bytes(bytes.fromhex("D0CF11E0A1B11AE1") + b"\0" * 504)
    for path in (xlsx, renamed, xls):
        with pytest.raises(
            ValueError, match=r"is a spreadsheet workbook, not CSV text.*as CSV"
        ):
            read_runs(path)


def test_a_sensor_empty_in_every_row_is_told_to_be_dropped():
    # It was told to "impute them first": no row to impute or drop.
    table = _three_runs().assign(T9_C=np.nan)
    with pytest.raises(
        ValueError,
        match=r"^column 'T9_C' is empty in every row \(a sensor that was not "
        r"connected\? drop the column\)\.$",
    ):
        validate_runs(table)


@pytest.mark.parametrize("column", ["time_s", "Time"])
def test_clock_and_elapsed_times_get_a_recipe_that_works(column):
    # An independent check: the recipe pandas.to_datetime failed on elapsed
    # times past 24 h and on stamps across a daylight-saving change, and a
    # time_s of "00:01:30" text got none.
    cases = {
        "elapsed": ["00:00:00", "12:00:00", "24:01:00"],
        "dst": [
            "2026-03-29T01:59:00+01:00",
            "2026-03-29T03:00:00+02:00",
            "2026-03-29T03:01:00+02:00",
        ],
    }
    for times in cases.values():
        df = pd.DataFrame(
            {"run": "a", column: times, "T1_C": [20.0, 21, 22], "disp_y_um": 0.0}
        )
        with pytest.raises(ValueError, match=r"they become time_s as") as info:
            validate_runs(df)
        recipe = re.search(r"e\.g\. (t = .*)\.$", str(info.value)).group(1)
        exec(recipe.replace("; ", "\n"), {"pandas": pd, "df": df})
        validate_runs(df.drop(columns=[c for c in [column] if c != "time_s"]))


def test_comments_empty_rows_and_repeated_headers_are_named(tmp_path):
    # An independent check: a logger's "# end of log" was read as a file
    # cut off, a "# pause" inside a run as a run split in two ("sort the
    # table"), a spreadsheet's empty trailing rows as missing labels, and
    # files joined with their headers as text in time_s.
    table = _three_runs()
    text = table.to_csv(index=False)
    lines = text.splitlines()
    cases = {
        "end.csv": (
            "\n".join([*lines, "# end of log"]),
            r"line 92 is a comment \('# end of log'\), not a row",
        ),
        "pause.csv": (
            "\n".join([*lines[:11], "# pause", *lines[11:]]),
            r"line 12 is a comment \('# pause'\)",
        ),
        "excel.csv": (
            "\n".join([*lines, ",,,,", ",,,,"]),
            r"rows 90-91 are empty \(a spreadsheet's trailing rows\?\); delete them",
        ),
        "joined.csv": (
            "\n".join([*lines[:31], *lines]),
            r"holds 'time_s', its own name: the header line again",
        ),
    }
    for name, (content, message) in cases.items():
        path = tmp_path / name
        path.write_text(content + "\n", encoding="utf-8")
        with pytest.raises(ValueError, match=message):
            read_runs(path)


def test_the_new_checks_leave_legitimate_tables_alone(tmp_path):
    # An independent hunt for false positives of the checks above: labels
    # "#1" (every data line starting with '#') refused as comments; an idle
    # run among heating ones taken for millimetres; a warm start (air in
    # °C) taken for Fahrenheit; changes since the start (0 at each run's
    # first row) taken for a logger's 0; a stiff axis beside a moving one.
    from skthermal.datasets import changes_since_start, write_runs

    table = _three_runs().assign(run=lambda t: "#" + t["run"])
    path = tmp_path / "hash.csv"
    write_runs(table, path)
    assert read_runs(path)["run"].tolist() == table["run"].tolist()
    idle = _three_runs()
    still = idle["run"] == "C"
    idle.loc[still, ["T1_C", "T2_C"]] = 21.0
    idle.loc[still, "disp_y_um"] = 0.01 * np.tile([0.0, 1.0, 2.0], 10)
    assert _said(idle) == []
    warm = _three_runs().assign(ambient_C=21.0)
    b = warm["run"] == "B"
    warm.loc[b, ["T1_C", "T2_C"]] += 40.0
    assert not any("Fahrenheit" in m for m in _said(warm))
    fast = _three_runs()
    fast.loc[fast.index % 30 != 0, "T1_C"] += 10.0  # 10 K in the first step
    assert not any("exactly 0" in m for m in _said(changes_since_start(fast)))
    stiff = _three_runs().assign(disp_x_um=lambda t: 0.0005 * t["T1_C"])
    assert not any("millimetres" in m for m in _said(stiff))


def test_a_semicolon_export_gets_a_recipe_that_reads_it(tmp_path):
    # An independent check: with a logger's preamble or a Windows-1252 °
    # in the header, the recipe pandas.read_csv(path, sep=';', decimal=',')
    # failed inside pandas (a parser error, a decoding error).
    body = _three_runs().to_csv(sep=";", decimal=",", index=False)
    cases = {
        "preamble.csv": ("Logger;HBM QuantumX\nMachine;VMC-B\n\n" + body, "utf-8"),
        "windows.csv": (body.replace("T1_C", "T1_°C", 1), "cp1252"),
    }
    for name, (text, encoding) in cases.items():
        path = tmp_path / name
        path.write_text(text, encoding=encoding)
        with pytest.raises(ValueError, match=r"pandas\.read_csv\(path, ") as info:
            read_runs(path)
        recipe = re.search(r"pandas\.read_csv\(path, (.*?)\) and", str(info.value))
        frame = eval(f"pd.read_csv(path, {recipe.group(1)})")  # noqa: S307
        assert frame.shape == (90, 5) and frame["time_s"].dtype.kind == "f"
