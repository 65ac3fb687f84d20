"""Tests of the sensor selectors (skthermal.selection)."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn import config_context
from sklearn.base import clone
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GroupKFold, cross_validate
from sklearn.pipeline import make_pipeline

from skthermal import FCMClusterPicker, GRASelector, GreyInfluenceSelector
from skthermal.datasets import split_runs
from skthermal.datasets._generators import make_sensor_groups
from skthermal.selection import FuzzyEquivalenceSelector, StableTSPSelector

SELECTORS = [
    GreyInfluenceSelector(n_features_to_select=3),
    GreyInfluenceSelector("gm0n", n_features_to_select=3),
    GRASelector(n_features_to_select=3),
    GRASelector("deng", n_features_to_select=3),
    FCMClusterPicker(n_clusters=3, random_state=0),
]

# Most tests here fit one run given as a plain array, which the selectors
# (rightly) warn is taken as one run.
pytestmark = pytest.mark.filterwarnings("ignore:.*carry no run labels:UserWarning")


def _indexed(runs, truth):
    """Sensors and target indexed by (run, time_s), as split_runs returns them."""
    frame = runs.set_index(["run", "time_s"])
    return frame[truth.index], frame["disp_y_um"]


@pytest.mark.parametrize("seed", range(10))
def test_fcm_picker_keeps_one_sensor_per_group_and_no_noise(seed):
    runs, truth = make_sensor_groups(
        n_groups=3, sensors_per_group=10, n_noise=10, random_state=seed
    )
    picker = FCMClusterPicker(n_clusters=3, random_state=seed)
    picker.fit(runs[truth.index], runs["disp_y_um"], groups=runs["run"])
    kept = truth[picker.get_feature_names_out()]
    assert sorted(kept.tolist()) == [0, 1, 2]
    # Every group sits in one cluster of its own.
    for g in range(3):
        assert len(set(picker.labels_[truth.to_numpy() == g])) == 1
    assert len(set(picker.labels_[truth.to_numpy() >= 0])) == 3
    np.testing.assert_allclose(picker.memberships_.sum(axis=1), 1.0)
    assert picker.memberships_.argmax(axis=1).tolist() == picker.labels_.tolist()


def test_fcm_picker_attributes_are_consistent():
    runs, truth = make_sensor_groups(random_state=1)
    picker = FCMClusterPicker(n_clusters=3, random_state=0).fit(
        runs[truth.index], runs["disp_y_um"], groups=runs["run"]
    )
    reps = picker.representatives_
    assert picker.support_.sum() == 3 and np.all(picker.support_[reps])
    # Groups are numbered by decreasing score of their representative.
    assert np.all(np.diff(picker.scores_[reps]) <= 0)
    assert picker.labels_[reps].tolist() == [0, 1, 2]
    for c, r in enumerate(reps):
        members = np.flatnonzero(picker.labels_ == c)
        assert picker.scores_[r] == picker.scores_[members].max()


@pytest.mark.parametrize("scorer", ["gm0n", "gra", GRASelector(method="deng")])
def test_fcm_picker_other_scorers(scorer):
    runs, truth = make_sensor_groups(random_state=3)
    picker = FCMClusterPicker(n_clusters=3, scorer=scorer, random_state=0)
    picker.fit(runs[truth.index], runs["disp_y_um"], groups=runs["run"])
    assert picker.get_support().sum() == 3
    assert len(set(truth[picker.get_feature_names_out()])) == 3


def test_fcm_picker_scorer_without_scores_is_an_error():
    from sklearn.cluster import KMeans

    runs, truth = make_sensor_groups(random_state=0)
    picker = FCMClusterPicker(n_clusters=3, scorer=KMeans(2, n_init=1))
    with pytest.raises(ValueError, match="has no scores_"):
        picker.fit(runs[truth.index], runs["disp_y_um"])


def test_fcm_picker_too_many_clusters():
    # It raised where the other selectors keep every sensor with a warning;
    # a search over 2-8 groups on 7 sensors lost those trials.
    X = np.random.default_rng(0).normal(size=(30, 3)).cumsum(axis=0)
    with pytest.warns(UserWarning, match=r"n_clusters=5, but X has only 3 sensor"):
        picker = FCMClusterPicker(n_clusters=5).fit(X, X.sum(axis=1), groups=[0] * 30)
    assert picker.get_support().all() and picker.memberships_.shape == (3, 3)
    assert sorted(picker.labels_) == [0, 1, 2]


@pytest.mark.parametrize("selector", SELECTORS, ids=repr)
def test_run_labels_from_groups_column_or_index_agree(selector):
    runs, truth = make_sensor_groups(random_state=5)
    X, y = runs[truth.index], runs["disp_y_um"]
    by_groups = clone(selector).fit(X, y, groups=runs["run"])
    by_column = clone(selector).fit(runs[["run", *truth.index]], y)
    Xi, yi = _indexed(runs, truth)
    by_index = clone(selector).fit(Xi, yi)
    np.testing.assert_allclose(by_column.scores_, by_groups.scores_)
    np.testing.assert_allclose(by_index.scores_, by_groups.scores_)
    assert by_column.feature_names_in_.tolist() == truth.index.tolist()
    # The run column is not a feature and is dropped at transform time too.
    out = by_column.set_output(transform="pandas").transform(
        runs[["run", *truth.index]]
    )
    assert "run" not in out.columns
    assert out.columns.tolist() == by_groups.get_feature_names_out().tolist()


@pytest.mark.parametrize("selector", SELECTORS[:4], ids=repr)
def test_scores_ignore_absolute_run_offsets(selector):
    """Runs are scored on changes since their start, restarting at each run."""
    runs, truth = make_sensor_groups(random_state=6)
    shifted = runs.copy()
    second = shifted["run"] == "run2"
    shifted.loc[second, truth.index] += 7.5
    shifted.loc[second, "disp_y_um"] -= 30.0
    a = clone(selector).fit(runs[truth.index], runs["disp_y_um"], groups=runs["run"])
    b = clone(selector).fit(
        shifted[truth.index], shifted["disp_y_um"], groups=shifted["run"]
    )
    np.testing.assert_allclose(a.scores_, b.scores_, rtol=1e-7, atol=1e-12)
    # Without run labels the jump at the boundary changes the scores.
    c = clone(selector).fit(shifted[truth.index], shifted["disp_y_um"])
    assert not np.allclose(a.scores_, c.scores_, rtol=1e-3)


def test_grey_influence_ranks_driving_sensors_first():
    rng = np.random.default_rng(0)
    t = np.arange(200.0)
    drivers = np.c_[1 - np.exp(-t / 30), 1 - np.exp(-t / 70)] * [4.0, 2.0]
    noise = rng.normal(0, 0.05, size=(200, 3))
    X = np.c_[noise[:, :1], drivers[:, 0], noise[:, 1:2], drivers[:, 1], noise[:, 2:]]
    y = drivers @ [5.0, 3.0]
    sel = GreyInfluenceSelector(n_features_to_select=2).fit(X, y)
    assert sel.get_support().tolist() == [False, True, False, True, False]
    assert sorted(sel.ranking_[[1, 3]].tolist()) == [1, 2]
    assert sel.coef_.shape == (1, 5) and np.isfinite(sel.development_coef_[0])


@pytest.mark.parametrize(
    "selector",
    [GreyInfluenceSelector(n_features_to_select=2), FCMClusterPicker(n_clusters=2)],
)
def test_a_gap_in_the_times_is_said_by_the_grey_selectors(selector):
    # The accumulation counts rows: one 30-min logging pause moved a sensor
    # to the top of the ranking, without a word (the grey regressors warn).
    rng = np.random.default_rng(0)
    t = np.arange(240) * 30.0
    drivers = np.c_[1 - np.exp(-t / 1800), 1 - np.exp(-t / 4000)] * [4.0, 2.0]
    X = np.c_[drivers, rng.normal(0, 0.05, (240, 2))]
    y = drivers @ [5.0, 3.0]
    keep = (t < 3000) | (t >= 4800)
    frame = pd.DataFrame(
        X[keep],
        columns=["T1_C", "T2_C", "T3_C", "T4_C"],
        index=pd.MultiIndex.from_arrays(
            [np.full(keep.sum(), "r1"), t[keep]], names=["run", "time_s"]
        ),
    )
    with pytest.warns(UserWarning, match=r"1 gap\(s\) in time_s.*counts rows"):
        clone(selector).fit(frame, y[keep])
    GRASelector(n_features_to_select=2).fit(frame, y[keep])  # compares rows


def test_selection_size_and_threshold():
    rng = np.random.default_rng(1)
    X = rng.normal(size=(50, 6)).cumsum(axis=0)
    y = X[:, 0] + 0.5 * X[:, 1]
    n = GRASelector().fit(X, y).get_support().sum()
    assert n == 3  # default: half of the sensors
    assert GRASelector(n_features_to_select=0.5).fit(X, y).get_support().sum() == 3
    assert GRASelector(n_features_to_select=2).fit(X, y).get_support().sum() == 2
    sel = GRASelector(threshold="median").fit(X, y)
    assert np.all(sel.scores_[sel.get_support()] >= np.median(sel.scores_))
    # Degrees are <= 1: nothing would be kept, and a pipeline would fail later
    # with "0 feature(s)"; the selector says why instead.
    with pytest.raises(ValueError, match=r"threshold=2.0 keeps no sensor: the scores"):
        GRASelector(threshold=2.0).fit(X, y)
    with pytest.raises(ValueError, match="threshold must be a finite score"):
        GRASelector(threshold=np.nan).fit(X, y)


def test_multi_output_target():
    runs, truth = make_sensor_groups(random_state=2)
    Y = np.c_[runs["disp_y_um"], 0.5 * runs["disp_y_um"] + 1.0]
    sel = GreyInfluenceSelector(n_features_to_select=4)
    sel.fit(runs[truth.index], Y, groups=runs["run"])
    single = clone(sel).fit(runs[truth.index], runs["disp_y_um"], groups=runs["run"])
    assert sel.coef_.shape == (2, truth.size)
    # A target and its affine image rank the sensors alike.
    assert sel.get_support().tolist() == single.get_support().tolist()


def test_pipeline_cross_validate_with_group_kfold_unchanged():
    runs, truth = make_sensor_groups(n_runs=4, random_state=4)
    X, y = _indexed(runs, truth)
    groups = runs["run"].to_numpy()
    pipe = make_pipeline(
        FCMClusterPicker(n_clusters=3, random_state=0), LinearRegression()
    )
    res = cross_validate(
        pipe, X, y, groups=groups, cv=GroupKFold(n_splits=4), return_estimator=True
    )
    assert np.all(np.isfinite(res["test_score"]))
    assert np.all(res["test_score"] > 0.9)
    for est in res["estimator"]:
        assert est[0].get_support().sum() == 3


def test_a_sequence_model_after_a_selector_sees_the_runs():
    # The selector's output keeps the (run, time_s) index of a run table, so
    # the sequence model after it restarts at every run.
    from skthermal import GNNMCIRegressor

    runs, _ = make_sensor_groups(
        n_groups=2, sensors_per_group=2, n_noise=1, n_runs=3, random_state=0
    )
    X, y, groups = split_runs(runs)
    pipe = make_pipeline(
        FCMClusterPicker(n_clusters=2, random_state=0), GNNMCIRegressor(epochs=2)
    ).fit(X, y)
    assert list(pipe[-1].run_states_) == list(dict.fromkeys(groups))
    out = pipe[0].transform(X)
    assert list(out.index.names) == ["run", "time_s"]
    assert list(out.columns) == list(pipe[0].get_feature_names_out())
    # A run column: the run labels become the index.
    table = X.reset_index()
    assert pipe[0].transform(table).index.names == ["run", "time_s"]
    assert isinstance(pipe[0].transform(X.to_numpy()), np.ndarray)


@pytest.mark.parametrize("selector", SELECTORS)
def test_drivers_among_the_sensors_warn_and_the_recipe_keeps_them(selector):
    # The speed was ranked as a temperature and dropped, and the lag model
    # behind lost its heat input (0.29 -> 0.4-1.7 µm), with no word.
    import warnings

    from sklearn.compose import ColumnTransformer

    from skthermal import LagFeatures

    runs, _ = make_sensor_groups(
        n_groups=2, sensors_per_group=2, n_noise=1, n_runs=3, random_state=0
    )
    X, y, _ = split_runs(runs)
    sensors = list(X.columns)
    X = X.assign(spindle_rpm=np.where(np.arange(len(X)) % 40 < 20, 3000.0, 0.0))
    with pytest.warns(UserWarning, match=r"X holds the drivers \['spindle_rpm'\]"):
        clone(selector).fit(X, y)
    kept = ColumnTransformer(
        [("sensors", clone(selector), sensors)],
        remainder="passthrough",
        verbose_feature_names_out=False,
    )
    pipe = make_pipeline(kept, LagFeatures(time_constants=[600.0]))
    pipe.set_output(transform="pandas")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = pipe.fit_transform(X, y)
    assert pipe[-1].driver_indices_.size == 1
    assert list(out.index.names) == ["run", "time_s"]


def test_metadata_routing_of_groups():
    runs, truth = make_sensor_groups(n_runs=3, random_state=8)
    X, y, groups = runs[truth.index], runs["disp_y_um"], runs["run"].to_numpy()
    with config_context(enable_metadata_routing=True):
        sel = GreyInfluenceSelector(n_features_to_select=5).set_fit_request(groups=True)
        pipe = make_pipeline(sel, LinearRegression())
        res = cross_validate(
            pipe,
            X,
            y,
            cv=GroupKFold(3),
            params={"groups": groups},
            return_estimator=True,
        )
    direct = GreyInfluenceSelector(n_features_to_select=5)
    train = groups != "run1"
    direct.fit(X[train], y[train], groups=groups[train])
    fitted = [e[0] for e in res["estimator"]]
    assert any(np.allclose(f.scores_, direct.scores_) for f in fitted)


def test_set_output_pandas_and_feature_names():
    runs, truth = make_sensor_groups(random_state=0)
    sel = GRASelector(n_features_to_select=4).set_output(transform="pandas")
    out = sel.fit(runs[truth.index], runs["disp_y_um"]).transform(runs[truth.index])
    assert isinstance(out, pd.DataFrame)
    assert out.columns.tolist() == sel.get_feature_names_out().tolist()
    assert set(out.columns) <= set(truth.index)


# --- errors that name the problem ---------------------------------------------


def _small():
    rng = np.random.default_rng(0)
    X = pd.DataFrame(
        rng.normal(size=(40, 4)).cumsum(axis=0),
        columns=["Ta_C", "Tb_C", "Tc_C", "Td_C"],
    )
    y = X["Ta_C"] * 2 + rng.normal(0, 0.1, 40)
    groups = np.repeat(["r1", "r2"], 20)
    return X, y, groups


@pytest.mark.parametrize("selector", SELECTORS[:3] + [FCMClusterPicker(2)], ids=repr)
def test_nan_names_sensor_and_run(selector):
    X, y, groups = _small()
    X.loc[25, "Tc_C"] = np.nan
    with pytest.raises(ValueError, match=r"NaN: sensor 'Tc_C' at row 25, run 'r2'"):
        clone(selector).fit(X, y, groups=groups)
    X.loc[25, "Tc_C"] = np.inf
    with pytest.raises(ValueError, match=r"contains inf: sensor 'Tc_C'"):
        clone(selector).fit(X, y, groups=groups)
    # The same names when a fitted selector transforms (a pipeline predicts).
    fitted = clone(selector).fit(X.assign(Tc_C=X["Tc_C"].where(X.index != 25, 0.3)), y)
    with pytest.raises(ValueError, match=r"contains inf: sensor 'Tc_C' at row 25"):
        fitted.transform(X.assign(run=groups))


@pytest.mark.parametrize("selector", SELECTORS[:3] + [FCMClusterPicker(2)], ids=repr)
def test_constant_target_is_named(selector):
    X, _, groups = _small()
    with pytest.raises(ValueError, match="Target 0 does not change within any run"):
        clone(selector).fit(X, np.ones(len(X)), groups=groups)
    # A named target by its name.
    y = pd.Series(np.ones(len(X)), name="disp_y_um")
    with pytest.raises(ValueError, match="Target 'disp_y_um' does not change"):
        clone(selector).fit(X, y, groups=groups)
    # Constant up to rounding: the selectors ranked the sensors on it.
    y = 5.0 + np.where(np.arange(len(X)) % 2, 1e-13, 0.0)
    with pytest.raises(ValueError, match="Target 0 does not change"):
        clone(selector).fit(X, y, groups=groups)
    # A small but real change is a thermal error, in any unit.
    clone(selector).fit(X, 1e-9 * np.asarray(_small()[1]), groups=groups)


@pytest.mark.parametrize("selector", SELECTORS[:3] + [FCMClusterPicker(2)], ids=repr)
def test_missing_target_names_row_and_run(selector):
    X, y, groups = _small()
    y = np.array(y, dtype=float)
    y[25] = np.nan
    with pytest.raises(
        ValueError, match=r"target is missing \(NaN\) at row 25, run 'r2'"
    ):
        clone(selector).fit(X, y, groups=groups)


def _said_constant(selector, X, y, groups):
    """Fit, expecting Tb_C said constant, unselected, last and scored NaN."""
    with pytest.warns(
        UserWarning, match=r"sensor 'Tb_C' is constant within every training run"
    ):
        fitted = clone(selector).fit(X, y, groups=groups)
    j = list(X.columns).index("Tb_C")
    assert not fitted.support_[j] and np.isnan(fitted.scores_[j])
    if hasattr(fitted, "ranking_"):
        assert fitted.ranking_[j] == fitted.ranking_.max()
    return fitted


def _not_said_constant(selector, X, y, groups):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        clone(selector).fit(X, y, groups=groups)
    assert not [w for w in caught if "constant within" in str(w.message)]


@pytest.mark.parametrize("selector", SELECTORS[:3] + [FCMClusterPicker(2)], ids=repr)
def test_constant_sensor_is_named(selector):
    X, y, groups = _small()
    X["Tb_C"] = 21.5
    _said_constant(selector, X, y, groups)
    X["Tb_C"] = 21.5 + np.where(np.arange(len(X)) % 3, 3e-15, 0.0)  # rounding
    _said_constant(selector, X, y, groups)
    # float32 readings rounded at their own precision (1 ulp at 21.5 is
    # 1.9e-6): constant too, where a real float32 change is kept.
    X["Tb_C"] = np.float32(21.5) + np.where(
        np.arange(len(X)) % 3, np.float32(1.9073486e-06), np.float32(0.0)
    ).astype(np.float32)
    assert X["Tb_C"].dtype == np.float32 and X["Tb_C"].nunique() == 2
    _said_constant(selector, X, y, groups)
    X["Tb_C"] = X["Tb_C"] + np.float32(0.01) * np.arange(len(X), dtype=np.float32)
    _not_said_constant(selector, X, y, groups)
    # A float64 sensor beside it keeps float64's allowance: a change of 1e-6
    # of its value is a change.
    X["Tc_C"] = 21.5 + np.where(np.arange(len(X)) % 3, 2e-5, 0.0)
    _not_said_constant(selector, X, y, groups)


def test_constant_within_each_run_is_constant():
    X, y, groups = _small()
    X["Tb_C"] = np.where(groups == "r1", 20.0, 25.0)
    _said_constant(GRASelector(), X, y, groups)
    # Every sensor constant: nothing to rank.
    flat = X.copy()
    flat[:] = 20.0
    with pytest.raises(ValueError, match=r"Every sensor is constant within every"):
        GRASelector().fit(flat, y, groups=groups)


@pytest.mark.parametrize(
    "selector",
    [*SELECTORS, StableTSPSelector(n_features_to_select=2), FuzzyEquivalenceSelector()],
    ids=repr,
)
def test_a_sensor_moving_in_one_run_only_does_not_fail_a_fold(selector):
    # An independent check: a sensor that moved only in one run was refused
    # in every fold that held that run out (a NaN score and a
    # FitFailedWarning in cross_validate, a stopped search).
    X, y, groups = _small()
    X["Tb_C"] = np.where(groups == "r2", np.linspace(20, 23, len(X)), 20.0)
    model = make_pipeline(clone(selector), LinearRegression())
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*constant within every")
        scores = cross_validate(
            model, X, y, groups=groups, cv=GroupKFold(n_splits=2), error_score="raise"
        )["test_score"]
    assert np.all(np.isfinite(scores))


def test_one_row_run_is_named():
    X, y, groups = _small()
    groups = groups.copy()
    groups[-1] = "r3"
    with pytest.raises(ValueError, match=r"Run .r3. has only 1 sample \(rows 39-39\)"):
        GRASelector().fit(X, y, groups=groups)


def test_too_few_samples_for_gm1n_says_how_many():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(8, 10)).cumsum(axis=0)
    with pytest.raises(ValueError, match="10 input series need at least 12 samples"):
        GreyInfluenceSelector().fit(X, X[:, 0])
    # The picker names the scorers without that limit (more image spots
    # than frames is common).
    with pytest.raises(ValueError, match=r"samples in 1 run\(s\)\. scorer='pearson'"):
        FCMClusterPicker(n_clusters=2).fit(X, X[:, 0], groups=np.zeros(8))


def test_non_increasing_time_is_named():
    runs, truth = make_sensor_groups(random_state=0)
    runs.loc[[400, 401], "time_s"] = [60.0, 60.0]
    X, y = _indexed(runs, truth)
    with pytest.raises(
        ValueError, match=r"in run 'run2' row 400 has time_s=60 after 2340"
    ):
        GRASelector().fit(X, y)


def test_non_contiguous_run_is_named():
    X, y, groups = _small()
    groups = np.array(["r1"] * 10 + ["r2"] * 10 + ["r1"] * 20)
    with pytest.raises(ValueError, match="run 'r1' are not contiguous"):
        GRASelector().fit(X, y, groups=groups)


def test_transform_with_missing_or_renamed_columns():
    X, y, groups = _small()
    sel = GRASelector(n_features_to_select=2).fit(X, y, groups=groups)
    with pytest.raises(ValueError, match="Tc_C"):
        sel.transform(X.drop(columns="Tc_C"))
    with pytest.raises(ValueError, match="T_renamed_C"):
        sel.transform(X.rename(columns={"Tc_C": "T_renamed_C"}))


def test_wrong_number_of_run_labels():
    X, y, _ = _small()
    with pytest.raises(ValueError, match="Got 3 run labels"):
        GRASelector().fit(X, y, groups=["a", "b", "c"])


# --- the real spindle test -----------------------------------------------------


def test_selectors_on_the_real_spindle_test(shared_data):
    from skthermal.datasets import load_fl_thermal, split_runs

    runs = load_fl_thermal(shared_data / "fl_thermal_spindle.csv.gz")
    X, y, groups = split_runs(runs, targets="disp_ch1_um")
    picker = FCMClusterPicker(n_clusters=5, random_state=0).fit(X, y)
    assert picker.get_support().sum() == 5
    assert len(set(picker.labels_[picker.representatives_])) == 5
    again = FCMClusterPicker(n_clusters=5, random_state=0).fit(X, y)
    assert again.get_feature_names_out().tolist() == (
        picker.get_feature_names_out().tolist()
    )
    for sel in (GreyInfluenceSelector(n_features_to_select=4), GRASelector()):
        sel.fit(X, y)
        assert np.all(np.isfinite(sel.scores_))
        assert sel.transform(X).shape == (X.shape[0], sel.get_support().sum())


@pytest.mark.parametrize("selector", SELECTORS, ids=repr)
def test_joblib_round_trip(selector, tmp_path):
    import joblib

    runs, truth = make_sensor_groups(random_state=9)
    X, y = _indexed(runs, truth)
    fitted = clone(selector).fit(X, y)
    joblib.dump(fitted, tmp_path / "sel.joblib")
    loaded = joblib.load(tmp_path / "sel.joblib")
    np.testing.assert_array_equal(loaded.transform(X), fitted.transform(X))
    assert loaded.get_feature_names_out().tolist() == (
        fitted.get_feature_names_out().tolist()
    )


def test_more_sensors_asked_than_given_warns_and_keeps_all():
    X, y, groups = _small()
    selector = GRASelector(n_features_to_select=10)
    with pytest.warns(UserWarning, match="only 4 sensor"):
        selector.fit(X, y, groups=groups)
    assert selector.get_support().all()


@pytest.mark.parametrize("value", [np.nan, 1e101])
def test_unreadable_values_name_the_time_as_the_estimators_do(value):
    # The selectors named the row and run, not the time_s X carries.
    X, y, groups = _small()
    X = X.assign(run=groups, time_s=np.tile(np.arange(20) * 60.0, 2))
    bad = X.copy()
    bad.loc[25, "Tc_C"] = value
    where = r"sensor 'Tc_C' at row 25, run 'r2', time_s=300"
    with pytest.raises(ValueError, match=where):
        GRASelector().fit(bad, y)
    fitted = GRASelector().fit(X, y)
    with pytest.raises(ValueError, match=where):
        fitted.transform(bad)


def test_fcm_picker_groups_readings_of_any_scale():
    # Standardising readings of 1e-300 underflowed their spread to 0 and
    # the clustering refused its own NaN.
    rng = np.random.default_rng(0)
    t = np.arange(20) * 60.0
    X = pd.DataFrame(
        {
            "run": "r0",
            "time_s": t,
            "T1_C": 1 - np.exp(-t / 300),
            "T2_C": 2 * (1 - np.exp(-t / 900)),
            "T3_C": rng.normal(size=20),
        }
    )
    y = 1 - np.exp(-t / 600)
    sensors = ["T1_C", "T2_C", "T3_C"]
    ref = FCMClusterPicker(n_clusters=2, random_state=0).fit(X, y)
    tiny = X.assign(**{c: X[c] * 1e-300 for c in sensors})
    got = FCMClusterPicker(n_clusters=2, random_state=0).fit(tiny, y * 1e-300)
    np.testing.assert_array_equal(got.get_support(), ref.get_support())


@pytest.mark.parametrize(
    "transformer",
    [
        GRASelector(n_features_to_select=2),
        FCMClusterPicker(n_clusters=2, random_state=0),
        "lags",
    ],
    ids=["GRASelector", "FCMClusterPicker", "LagFeatures"],
)
def test_column_transformer_over_run_table_columns_names_its_outputs(transformer):
    # A ColumnTransformer passing a run table's run and time_s columns (the
    # documented way to give runs) asked for the output names with all its
    # columns and got "input_features is not equal to feature_names_in_".
    from sklearn.compose import ColumnTransformer

    from skthermal import LagFeatures

    if transformer == "lags":
        transformer = LagFeatures(drivers=None, time_constants=(600.0,))
    rng = np.random.default_rng(0)
    table = pd.DataFrame(
        {
            "run": np.repeat(["A", "B"], 50),
            "time_s": np.tile(np.arange(50) * 60.0, 2),
            "T1_C": 20 + rng.random(100).cumsum() / 10,
            "T2_C": 20 + rng.random(100).cumsum() / 20,
            "T3_C": 20 + rng.random(100).cumsum() / 30,
        }
    )
    y = 2 * (table["T1_C"] - 20)
    columns = ["run", "time_s", "T1_C", "T2_C", "T3_C"]
    ct = ColumnTransformer([("s", transformer, columns)]).set_output(transform="pandas")
    out = ct.fit_transform(table, y)
    step = ct.named_transformers_["s"]
    names = [f"s__{c}" for c in step.get_feature_names_out()]
    assert list(out.columns) == names == list(ct.get_feature_names_out())
    assert not any(c.endswith(("__run", "__time_s")) for c in names)
    with pytest.raises(ValueError, match="input_features is not equal"):
        step.get_feature_names_out(["run", "time_s", "T3_C", "T2_C", "T1_C"])
