"""Tests of skthermal.plotting: artists, labels, shading, ax reuse, errors."""

import ast
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("matplotlib")
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from sklearn.linear_model import LinearRegression  # noqa: E402

from skthermal import ANFISRegressor, FCMClusterPicker, GreyInfluenceSelector  # noqa: E402
from skthermal.datasets import make_sensor_groups, split_runs  # noqa: E402
from skthermal.metrics import nash_sutcliffe, residual_band, rmse  # noqa: E402
from skthermal.plotting import (  # noqa: E402
    GapOverlayDisplay,
    GapTimelineDisplay,
    MembershipFunctionDisplay,
    PredictionDisplay,
    SensorScoreDisplay,
)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def run_data():
    """Three runs indexed by (run, time_s), a fitted linear model."""
    rng = np.random.default_rng(0)
    frames = []
    for k, run in enumerate(["a", "b", "c"]):
        t = np.arange(0.0, 3600.0 * (k + 1), 60.0)
        heat = 1 - np.exp(-t / 1500.0)
        frames.append(
            pd.DataFrame(
                {
                    "run": run,
                    "time_s": t,
                    "T1_C": 20 + 5 * heat + rng.normal(0, 0.05, t.size),
                    "T2_C": 20 + 2 * heat**2 + rng.normal(0, 0.05, t.size),
                    "disp_y_um": 10 * heat + rng.normal(0, 0.2, t.size),
                }
            )
        )
    df = pd.concat(frames, ignore_index=True)
    X, y, groups = split_runs(df)
    model = LinearRegression().fit(X, y)
    return X, y, groups, model


# ----------------------------------------------------------- PredictionDisplay


def test_prediction_from_estimator_one_run(run_data):
    X, y, groups, model = run_data
    disp = PredictionDisplay.from_estimator(model, X, y, run="b")
    assert disp.axes_.shape == (2, 1)
    assert disp.ax_ is disp.axes_[0, 0] and disp.ax_residual_ is disp.axes_[1, 0]
    assert disp.figure_ is disp.ax_.figure
    mask = groups == "b"
    t_min = y.index.get_level_values("time_s")[mask] / 60
    np.testing.assert_allclose(disp.line_measured_.get_xdata(), t_min)
    np.testing.assert_allclose(disp.line_measured_.get_ydata(), y[mask])
    np.testing.assert_allclose(disp.line_predicted_.get_ydata(), model.predict(X)[mask])
    np.testing.assert_allclose(
        disp.line_residual_.get_ydata(), y[mask] - model.predict(X)[mask]
    )
    assert disp.line_predicted_.get_label() == "LinearRegression"
    assert disp.ax_.get_ylabel() == "Y displacement (µm)"
    assert disp.ax_residual_.get_xlabel() == "time (min)"
    assert list(disp.metrics_.index) == ["b"]
    band = residual_band(y[mask], model.predict(X)[mask])
    assert disp.metrics_.loc["b", "band"] == pytest.approx(band)
    assert disp.metrics_.loc["b", "rmse"] == pytest.approx(
        rmse(y[mask], model.predict(X)[mask])
    )
    title = disp.ax_.get_title()
    assert "run b" in title and "RMSE" in title and "NSE" in title
    assert f"±{band:.3g}" in title
    assert len(disp.bands_) == 1
    lo, hi = (
        disp.bands_[0]
        .get_path()
        .get_extents(disp.bands_[0].get_transform() - disp.ax_residual_.transData)
        .intervaly
    )
    assert lo == pytest.approx(-band) and hi == pytest.approx(band)


@pytest.mark.parametrize("routing", [False, True])
def test_prediction_gives_groups_to_a_pipeline(run_data, routing):
    # A Pipeline takes groups through metadata routing, or as the rows' run
    # index: the plotted predictions are its predictions run by run.
    import sklearn
    from sklearn.pipeline import make_pipeline

    from skthermal import GreyPSORegressor

    X, y, groups, _ = run_data
    with sklearn.config_context(enable_metadata_routing=routing):
        grey = GreyPSORegressor(calibration="ls")
        if routing:
            grey.set_fit_request(groups=True).set_predict_request(groups=True)
        Xn = X.to_numpy()
        if routing:
            pipe = make_pipeline(grey).fit(Xn, y.to_numpy(), groups=groups)
            reference = pipe.predict(Xn, groups=groups)
        else:  # the runs in the index, columns unnamed as in Xn
            Xi = pd.DataFrame(Xn, index=X.index)
            pipe = make_pipeline(grey).fit(Xi, y)
            reference = pipe.predict(Xi)
        disp = PredictionDisplay.from_estimator(pipe, Xn, y.to_numpy(), groups=groups)
    np.testing.assert_allclose(disp.y_pred, reference, rtol=1e-10)


def test_prediction_facets_per_run(run_data):
    X, y, groups, model = run_data
    disp = PredictionDisplay.from_estimator(model, X, y)
    assert disp.axes_.shape == (2, 3)
    assert len(disp.lines_measured_) == 3 and len(disp.bands_) == 3
    assert list(disp.metrics_.index) == ["a", "b", "c"]
    # Run "c" lasts 3 h: the auto unit is hours only beyond 3 h, so minutes.
    assert disp.axes_[1, 2].get_xlabel() == "time (min)"
    sub = PredictionDisplay.from_estimator(model, X, y, run=["a", "c"])
    assert sub.axes_.shape == (2, 2)
    # Runs and times come from X's index when y is a plain array.
    plain = PredictionDisplay.from_estimator(model, X, y.to_numpy(), run="c")
    assert list(plain.metrics_.index) == ["c"]
    assert plain.line_measured_.get_xdata()[-1] == pytest.approx(
        y.index.get_level_values("time_s")[-1] / 60
    )


def test_prediction_from_predictions_plain_arrays():
    y = np.linspace(0, 10, 50)
    pred = y + 0.1
    disp = PredictionDisplay.from_predictions(
        y, pred, band=False, show_metrics=False, estimator_name="model"
    )
    assert disp.bands_ == []
    assert disp.ax_.get_title() == ""
    assert disp.ax_residual_.get_xlabel() == "sample"
    assert disp.line_predicted_.get_label() == "model"
    assert disp.metrics_["nse"].iloc[0] == pytest.approx(nash_sutcliffe(y, pred))
    np.testing.assert_allclose(disp.line_residual_.get_ydata(), -0.1)


def test_prediction_reuses_axes(run_data):
    X, y, groups, model = run_data
    fig, axes = plt.subplots(2, 1)
    disp = PredictionDisplay.from_estimator(
        model, X, y, run="a", ax=axes, time_unit="h"
    )
    assert disp.figure_ is fig
    assert disp.ax_ is axes[0] and disp.ax_residual_ is axes[1]
    assert disp.ax_residual_.get_xlabel() == "time (h)"
    # Drawing again on other Axes keeps the data.
    fig2, axes2 = plt.subplots(2, 1)
    disp.plot(ax=axes2)
    assert disp.figure_ is fig2 and len(axes2[0].lines) == 2


def test_prediction_errors(run_data):
    X, y, groups, model = run_data
    with pytest.raises(ValueError, match=r"Run\(s\) \['z'\] not found"):
        PredictionDisplay.from_estimator(model, X, y, run="z")
    with pytest.raises(ValueError, match="no run labels"):
        PredictionDisplay.from_predictions(np.ones(3), np.ones(3), run="a")
    with pytest.raises(ValueError, match="3 samples but y_pred has 4"):
        PredictionDisplay.from_predictions(np.ones(3), np.ones(4))
    with pytest.raises(ValueError, match="one-dimensional"):
        PredictionDisplay.from_predictions(np.ones((3, 2)), np.ones((3, 2)))
    with pytest.raises(ValueError, match="needs 2 Axes"):
        _, ax = plt.subplots()
        PredictionDisplay.from_predictions(np.ones(3), np.ones(3), ax=ax)
    with pytest.raises(ValueError, match="time_unit"):
        PredictionDisplay.from_predictions(
            np.ones(3), np.ones(3), time=[0, 1, 2], time_unit="days"
        )
    with pytest.raises(ValueError, match="time must hold one value"):
        PredictionDisplay.from_predictions(np.ones(3), np.ones(3), time=[0, 1])


def test_prediction_gaps_order_lengths_and_one_time_unit(run_data):
    X, y, groups, model = run_data
    pred = pd.Series(model.predict(X), index=y.index, name="p")
    # A NaN (a model's warm-up) is a gap, left out of the metrics; the
    # warning names the row of the whole input and its run. It stopped the
    # plot, naming the row within its run.
    holes = pred.copy()
    holes.iloc[70] = np.nan
    with pytest.warns(UserWarning, match=r"1 row\(s\).* first at row 70 \(run 'b'\)"):
        disp = PredictionDisplay.from_predictions(y, holes)
    whole = PredictionDisplay.from_predictions(y, pred)
    b = y.index.get_level_values("run") == "b"
    keep = b & ~np.isnan(holes.to_numpy())
    expected = np.sqrt(np.mean((y[keep] - pred[keep]) ** 2))
    assert disp.metrics_.loc["b", "rmse"] == pytest.approx(expected)
    assert disp.metrics_.loc["a", "rmse"] == whole.metrics_.loc["a", "rmse"]
    # A prediction in another row order is paired by its labels.
    shuffled = pred.sample(frac=1.0, random_state=0)
    again = PredictionDisplay.from_predictions(y, shuffled)
    pd.testing.assert_frame_equal(again.metrics_, whole.metrics_)
    other = pred.rename(index={"a": "z"}, level="run")
    with pytest.raises(ValueError, match="indexed by other \\(run, time_s\\) labels"):
        PredictionDisplay.from_predictions(y, other)
    # Lengths are checked before a run is picked.
    with pytest.raises(ValueError, match=r"groups must hold one value per row .*\(3"):
        PredictionDisplay.from_predictions(
            y.to_numpy(), pred.to_numpy(), groups=groups[:-3], run="a"
        )
    with pytest.raises(ValueError, match=r"time must hold one value per row"):
        PredictionDisplay.from_predictions(y, pred, time=np.arange(10), run="a")
    # Runs of 2, 4 and 6 h side by side share one time unit (the 2 h run
    # was drawn in minutes beside the others in hours).
    twice = 2 * np.asarray(y.index.get_level_values("time_s"))
    slow = PredictionDisplay.from_predictions(y, pred, time=twice)
    assert {ax.get_xlabel() for ax in slow.axes_[1]} == {"time (h)"}
    plt.close("all")


def test_an_estimator_of_several_outputs_plots_the_one_asked_for(run_data):
    X, y, _, _ = run_data
    Y = np.c_[y, 2 * y]
    model = LinearRegression().fit(X, Y)
    with pytest.raises(ValueError, match=r"predicts 2 outputs.*output=j"):
        PredictionDisplay.from_estimator(model, X, y)
    disp = PredictionDisplay.from_estimator(model, X, 2 * y, output=1)
    by_hand = PredictionDisplay.from_predictions(2 * y, model.predict(X)[:, 1])
    pd.testing.assert_frame_equal(disp.metrics_, by_hand.metrics_)
    with pytest.raises(ValueError, match=r"output must be an int in \[0, 1\]"):
        PredictionDisplay.from_estimator(model, X, y, output=2)
    plt.close("all")


# ---------------------------------------------------- MembershipFunctionDisplay


@pytest.fixture(scope="module")
def anfis():
    rng = np.random.default_rng(0)
    X = pd.DataFrame(rng.uniform(-1, 1, size=(120, 3)), columns=["T1", "T2", "T3"])
    y = X["T1"] - X["T2"] ** 2 + 0.5 * X["T3"]
    return ANFISRegressor(n_clusters=2, epochs=5, random_state=0).fit(X, y)


@pytest.mark.parametrize(
    "which, n_initial, n_trained",
    [("both", 2, 2), ("initial", 2, 0), ("trained", 0, 2)],
)
def test_membership_functions(anfis, which, n_initial, n_trained):
    disp = MembershipFunctionDisplay.from_estimator(anfis, which=which)
    assert disp.axes_.shape == (3,)
    assert [a.get_xlabel() for a in disp.axes_] == ["T1", "T2", "T3"]
    assert disp.ax_.get_ylabel() == "membership"
    assert all(len(lines) == n_initial for lines in disp.lines_initial_)
    assert all(len(lines) == n_trained for lines in disp.lines_trained_)
    if n_trained:
        line = disp.lines_trained_[1][0]
        assert line.get_linestyle() == "-"
        assert line.get_label() == "in2mf1 (trained)"
        assert 0 <= line.get_ydata().min() and line.get_ydata().max() <= 1
    if n_initial:
        assert disp.lines_initial_[0][0].get_linestyle() == "--"


def test_membership_trained_differs_from_initial(anfis):
    disp = MembershipFunctionDisplay.from_estimator(anfis)
    y0 = disp.lines_initial_[0][0].get_ydata()
    y1 = disp.lines_trained_[0][0].get_ydata()
    assert not np.allclose(y0, y1)


def test_membership_axes_reuse_and_errors(anfis):
    fig, axes = plt.subplots(1, 3)
    disp = MembershipFunctionDisplay.from_estimator(anfis, ax=axes)
    assert disp.figure_ is fig and disp.ax_ is axes[0]
    with pytest.raises(ValueError, match="needs 3 Axes"):
        MembershipFunctionDisplay.from_estimator(anfis, ax=axes[:2])
    with pytest.raises(ValueError, match="which must be"):
        MembershipFunctionDisplay.from_estimator(anfis, which="before")
    with pytest.raises(TypeError, match="needs a fitted ANFISRegressor"):
        lr = LinearRegression().fit([[0.0], [1.0]], [0.0, 1.0])
        lr.mf_params_ = np.ones((1, 1, 2))
        MembershipFunctionDisplay.from_estimator(lr)
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        MembershipFunctionDisplay.from_estimator(ANFISRegressor())


def test_membership_grid_many_inputs_hides_spare_axes():
    rng = np.random.default_rng(1)
    X = rng.uniform(size=(60, 5))
    model = ANFISRegressor(init="grid", n_mfs=2, epochs=2).fit(X, X.sum(axis=1))
    disp = MembershipFunctionDisplay.from_estimator(model, which="trained")
    assert disp.axes_.shape == (5,)
    visible = [a for a in disp.figure_.axes if a.get_visible()]
    assert len(visible) == 5 and len(disp.figure_.axes) == 8
    assert disp.lines_trained_[4][1].get_label() == "in5mf2 (trained)"


# ----------------------------------------------------------- SensorScoreDisplay


@pytest.fixture(scope="module")
def sensor_data():
    runs, truth = make_sensor_groups(n_groups=3, random_state=0)
    return runs[truth.index], runs["disp_y_um"], runs["run"], truth


def test_sensor_scores_fcm_groups(sensor_data):
    X, y, groups, _ = sensor_data
    picker = FCMClusterPicker(n_clusters=3, random_state=0).fit(X, y, groups=groups)
    disp = SensorScoreDisplay.from_estimator(picker)
    n = X.shape[1]
    assert len(disp.bars_) == n
    np.testing.assert_allclose([b.get_height() for b in disp.bars_], picker.scores_)
    labels = [t.get_text() for t in disp.ax_.get_xticklabels()]
    assert labels == list(X.columns)
    kept = picker.get_support()
    alphas = np.array([b.get_facecolor()[3] for b in disp.bars_])
    np.testing.assert_allclose(alphas[kept], 1.0)
    np.testing.assert_allclose(alphas[~kept], 0.35)
    # Bars of one group share a colour, groups differ.
    rgb = [tuple(b.get_facecolor()[:3]) for b in disp.bars_]
    for g in np.unique(picker.labels_):
        assert len({rgb[j] for j in np.flatnonzero(picker.labels_ == g)}) == 1
    assert len(set(rgb)) == 3
    texts = [t.get_text() for t in disp.legend_.get_texts()]
    assert texts == ["group 0", "group 1", "group 2", "kept", "dropped"]
    assert disp.ax_.get_ylabel() == "score (FCMClusterPicker)"


def test_sensor_scores_sorted_mapping_and_no_groups(sensor_data):
    X, y, groups, truth = sensor_data
    sel = GreyInfluenceSelector(n_features_to_select=3).fit(X, y, groups=groups)
    disp = SensorScoreDisplay.from_estimator(sel, sort=True)
    heights = [b.get_height() for b in disp.bars_]
    assert heights == sorted(heights, reverse=True)
    np.testing.assert_array_equal(disp.order_, np.argsort(-sel.scores_, kind="stable"))
    assert [t.get_text() for t in disp.legend_.get_texts()] == ["kept", "dropped"]
    mapping = {name: f"g{g}" for name, g in truth.items() if g != 0}
    disp = SensorScoreDisplay.from_estimator(sel, groups=mapping)
    texts = [t.get_text() for t in disp.legend_.get_texts()]
    assert "group ungrouped" in texts and "group g1" in texts
    _, ax = plt.subplots()
    disp = SensorScoreDisplay.from_estimator(sel, groups=None, ax=ax)
    assert disp.ax_ is ax and disp.figure_ is ax.figure


def test_sensor_scores_errors(sensor_data):
    with pytest.raises(TypeError, match="has no scores_"):
        SensorScoreDisplay.from_estimator(LinearRegression().fit([[0], [1]], [0, 1]))
    with pytest.raises(ValueError, match="groups must be 'auto'"):
        X, y, groups, _ = sensor_data
        sel = GreyInfluenceSelector().fit(X, y, groups=groups)
        SensorScoreDisplay.from_estimator(sel, groups="fcm")
    with pytest.raises(ValueError, match="boolean mask"):
        SensorScoreDisplay(scores=[1.0, 2.0], support=[1, 0]).plot()
    with pytest.raises(ValueError, match="feature_names must hold 2"):
        SensorScoreDisplay(scores=[1.0, 2.0], feature_names=["a"]).plot()
    with pytest.raises(ValueError, match="non-empty 1-D"):
        SensorScoreDisplay(scores=[]).plot()


# ----------------------------------------------------------- GapTimelineDisplay


def test_gap_timeline_spans_per_regime():
    t = np.arange(12) * 600.0
    regimes = ["heating"] * 3 + ["after stop"] * 2 + ["heating"] * 2
    regimes += ["dwell", "ambient event", "ambient event", None, "dwell"]
    residual = np.linspace(-1, 1, 12)
    disp = GapTimelineDisplay.from_arrays(t, residual, regimes)
    counts = {k: len(v) for k, v in disp.spans_.items()}
    assert counts == {"heating": 2, "after stop": 1, "dwell": 2, "ambient event": 1}
    assert disp.colors_["heating"] == "tab:red"
    assert disp.colors_["ambient event"] == "tab:purple"
    texts = [t.get_text() for t in disp.legend_.get_texts()]
    assert texts == ["heating", "after stop", "dwell", "ambient event", "residual"]
    # A span reaches the first sample of the next block (times in minutes).
    x = disp.spans_["after stop"][0].get_x()
    assert x == pytest.approx(30.0)
    assert disp.spans_["after stop"][0].get_width() == pytest.approx(20.0)
    np.testing.assert_allclose(disp.line_.get_ydata(), residual)
    assert disp.ax_.get_xlabel() == "time (min)"


def test_gap_timeline_colors_other_regimes_and_ax():
    t = np.arange(6.0)
    regimes = np.array(["warm-up", "warm-up", "heating", "cut", "cut", np.nan], object)
    _, ax = plt.subplots()
    disp = GapTimelineDisplay.from_arrays(
        t,
        np.zeros(6),
        regimes,
        ax=ax,
        time_unit=None,
        colors={"heating": "k"},
        residual_name="gap (µm)",
    )
    assert disp.ax_ is ax
    assert disp.colors_["heating"] == "k"
    assert disp.colors_["warm-up"] != disp.colors_["cut"]
    assert set(disp.spans_) == {"warm-up", "heating", "cut"}
    assert disp.ax_.get_ylabel() == "gap (µm)" and disp.ax_.get_xlabel() == "time"


def test_gap_timeline_errors():
    with pytest.raises(ValueError, match="regimes must hold one value"):
        GapTimelineDisplay.from_arrays([0, 1, 2], [0, 0, 0], ["a", "b"])
    with pytest.raises(ValueError, match="time must increase strictly"):
        GapTimelineDisplay.from_arrays([0, 2, 1], [0, 0, 0], ["a"] * 3)
    with pytest.raises(ValueError, match="non-empty 1-D"):
        GapTimelineDisplay.from_arrays([], [], [])


# ------------------------------------------------------ missing matplotlib


@pytest.mark.parametrize(
    "call",
    [
        lambda: PredictionDisplay.from_predictions([1.0, 2.0], [1.0, 2.0]),
        lambda: GapTimelineDisplay.from_arrays([0, 1], [0, 0], ["a", "a"]),
        lambda: SensorScoreDisplay(scores=[1.0]).plot(),
        lambda: MembershipFunctionDisplay(x=[], input_names=[]).plot(),
    ],
)
def test_import_error_names_the_extra(monkeypatch, call):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r'pip install "skthermal\[plot\]"'):
        call()


def test_package_imports_without_matplotlib(monkeypatch):
    for name in list(sys.modules):
        if name == "matplotlib" or name.startswith(("matplotlib.", "skthermal.plot")):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    import skthermal.plotting as plotting

    assert "PredictionDisplay" in plotting.__all__


def test_prediction_run_as_an_array_of_labels(run_data):
    X, y, _, model = run_data
    disp = PredictionDisplay.from_estimator(model, X, y, run=np.array(["a", "c"]))
    assert disp.metrics_.index.tolist() == ["a", "c"]
    disp = PredictionDisplay.from_estimator(model, X, y, run=pd.Index(["b"]))
    assert disp.metrics_.index.tolist() == ["b"]
    with pytest.raises(ValueError, match=r"Run\(s\) \['z'\] not found"):
        PredictionDisplay.from_estimator(model, X, y, run=np.array(["a", "z"]))


def test_membership_of_a_pipeline_or_a_wrapped_model(run_data):
    from sklearn.exceptions import NotFittedError
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from skthermal.models import make_model

    X, y, _, _ = run_data
    anfis = ANFISRegressor(n_clusters=2, epochs=3, random_state=0)
    pipe = make_pipeline(StandardScaler(), anfis).fit(X, y)
    disp = MembershipFunctionDisplay.from_estimator(pipe)
    # The functions live in the scaler's units: said on the axes (they were
    # labelled as if in °C).
    scaled = ["T1_C (after standardscaler)", "T2_C (after standardscaler)"]
    assert [ax.get_xlabel() for ax in disp.axes_] == scaled
    wrapped = make_model("anfis-fcm", random_state=0, quick=True).fit(X, y)
    disp = MembershipFunctionDisplay.from_estimator(wrapped)
    assert [ax.get_xlabel() for ax in disp.axes_] == ["T1_C", "T2_C"]
    with pytest.raises(NotFittedError, match="RunStartRegressor"):
        MembershipFunctionDisplay.from_estimator(make_model("anfis-fcm"))
    other = make_pipeline(StandardScaler(), LinearRegression()).fit(X, y)
    with pytest.raises(TypeError, match="got Pipeline ending in LinearRegression"):
        MembershipFunctionDisplay.from_estimator(other)


# ------------------------------------------------------------ GapOverlayDisplay


def test_gap_overlay_lines_and_labels():
    t = np.arange(0.0, 4 * 3600, 600.0)
    measured = np.sqrt(t)
    disp = GapOverlayDisplay.from_arrays(
        t,
        measured,
        0.5 * measured,
        simulated_after=0.9 * measured,
        channel_name="disp_z_um",
        after_name="simulated + tool_growth",
        time_unit="h",
    )
    assert [line.get_label() for line in disp.ax_.get_lines()] == [
        "measured",
        "simulated",
        "simulated + tool_growth",
    ]
    assert [disp.lines_[k].get_color() for k in ("measured", "simulated", "after")] == [
        "k",
        "C3",
        "C0",
    ]
    np.testing.assert_allclose(disp.lines_["after"].get_xdata(), t / 3600.0)
    np.testing.assert_allclose(disp.lines_["simulated"].get_ydata(), 0.5 * measured)
    assert disp.ax_.get_xlabel() == "time (h)"
    assert disp.ax_.get_ylabel() == "disp_z_um"
    assert tuple(disp.figure_.get_size_inches()) == (9.0, 3.0)


def test_gap_overlay_without_correction_on_given_axes():
    _, ax = plt.subplots()
    disp = GapOverlayDisplay.from_arrays(
        [0, 1, 2], [1.0, 2.0, 3.0], [1.0, 1.5, 2.0], ax=ax, time_unit=None
    )
    assert disp.ax_ is ax and set(disp.lines_) == {"measured", "simulated"}
    assert disp.ax_.get_xlabel() == "time" and disp.ax_.get_ylabel() == "value"
    assert disp.legend_.get_texts()[0].get_fontsize() == pytest.approx(
        matplotlib.font_manager.FontProperties(size="small").get_size_in_points()
    )


def test_gap_overlay_errors():
    with pytest.raises(ValueError, match="simulated must hold one value"):
        GapOverlayDisplay.from_arrays([0, 1, 2], [0, 0, 0], [0, 0])
    with pytest.raises(ValueError, match="simulated_after must hold one value"):
        GapOverlayDisplay.from_arrays([0, 1], [0, 0], [0, 0], simulated_after=[0])
    with pytest.raises(ValueError, match="time must hold one value"):
        GapOverlayDisplay.from_arrays([0], [0, 0], [0, 0])
    with pytest.raises(ValueError, match="non-empty 1-D"):
        GapOverlayDisplay.from_arrays([], [], [])
    # The same checks as the timeline's: time goes forward, text is named,
    # a one-column simulation is a column.
    with pytest.raises(ValueError, match="time must increase strictly; sample 1"):
        GapOverlayDisplay.from_arrays([1, 0, 2], [0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError, match="time must hold numbers .* or datetimes"):
        GapOverlayDisplay.from_arrays(["a", "b"], [0, 0], [0, 0])
    with pytest.raises(ValueError, match="simulated must be numeric"):
        GapOverlayDisplay.from_arrays([0, 1], [0, 0], ["a", "b"])
    disp = GapOverlayDisplay.from_arrays([0, 1], [0, 1], np.array([[0.0], [1.0]]))
    assert disp.ax_ is not None
    plt.close("all")


def test_sensor_scores_named_by_their_index():
    disp = SensorScoreDisplay(scores=pd.Series([0.3, 0.9], index=["T1_C", "T2_C"]))
    disp.plot()
    labels = sorted(t.get_text() for t in disp.ax_.get_xticklabels())
    assert labels == ["T1_C", "T2_C"]
    with pytest.raises(ValueError, match="scores must be numeric"):
        SensorScoreDisplay(scores=["a", "b"]).plot()
    plt.close("all")


def test_gap_overlay_import_error_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=r'pip install "skthermal\[plot\]"'):
        GapOverlayDisplay.from_arrays([0, 1], [0, 0], [0, 0])


# ------------------------------------------- package structure: no import cycle

PACKAGE = Path(__import__("skthermal").__file__).parent
# The estimator packages that have plots drawn by skthermal.plotting.
ESTIMATOR_PACKAGES = ("fuzzy", "gap", "selection")


def _imports(path):
    """``(line, module, names, at_module_level)`` of every import in a file,
    relative imports resolved; imports inside functions (lazy ones) included
    with ``at_module_level`` False."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = parts[:-1]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []

    def visit(node, in_function):
        if isinstance(node, ast.Import):
            for alias in node.names:
                found.append((node.lineno, alias.name, [], not in_function))
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join(base + ([module] if module else []))
            names = [alias.name for alias in node.names]
            found.append((node.lineno, module, names, not in_function))
        inside = in_function or isinstance(
            node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda
        )
        for child in ast.iter_child_nodes(node):
            visit(child, inside)

    visit(tree, False)
    return found


def _subpackage(module):
    """The skthermal subpackage a dotted name lies in, or None."""
    parts = module.split(".")
    if parts[0] != "skthermal" or len(parts) < 2:
        return None
    return parts[1] if (PACKAGE / parts[1] / "__init__.py").is_file() else None


def _import_graph():
    """Edges between skthermal subpackages: ``{(a, b): [import, ...]}`` where
    an import is ``(file:line, module, names, at_module_level)``."""
    edges = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        source = _subpackage(".".join(path.relative_to(PACKAGE.parent).parts[:2]))
        if source is None:  # skthermal/__init__.py, cli.py, ...: not a package
            continue
        for line, module, names, top in _imports(path):
            # "from skthermal import plotting" names a subpackage too.
            targets = {_subpackage(module)} | {
                _subpackage(f"{module}.{name}") for name in names
            }
            for target in targets - {None, source}:
                where = f"{path.relative_to(PACKAGE.parent)}:{line}"
                edges.setdefault((source, target), []).append(
                    (where, module, names, top)
                )
    return edges


def _path(edges, start, goal):
    """A chain of subpackages from ``start`` to ``goal``, or None."""
    graph = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
    paths, seen = [[start]], {start}
    while paths:
        path = paths.pop(0)
        for nxt in sorted(graph.get(path[-1], ())):
            if nxt == goal:
                return [*path, nxt]
            if nxt not in seen:
                seen.add(nxt)
                paths.append([*path, nxt])
    return None


def test_import_graph_sees_module_and_function_level_imports():
    edges = _import_graph()
    # Module level: the fuzzy c-means selector imports skthermal.fuzzy.
    assert any(top for *_, top in edges[("selection", "fuzzy")])
    # Function level: ANFISRegressor.plot_membership_functions and the gap
    # report's plots import their displays lazily; the graph includes them.
    for package in ("fuzzy", "gap"):
        lazy = edges[(package, "plotting")]
        assert lazy and not any(top for *_, top in lazy)


@pytest.mark.parametrize("package", ESTIMATOR_PACKAGES)
def test_no_import_cycle_between_plotting_and(package):
    edges = _import_graph()
    there = _path(edges, "plotting", package)
    back = _path(edges, package, "plotting")
    assert there is None or back is None, (
        f"import cycle: {' -> '.join(there)} and {' -> '.join(back)}; "
        f"plotting imports {edges.get(('plotting', there[1]))}, "
        f"{package} imports {edges.get((package, back[1]))}"
    )


def test_plotting_is_on_no_import_cycle():
    cycle = _path(_import_graph(), "plotting", "plotting")
    assert cycle is None, f"import cycle: {' -> '.join(cycle)}"


@pytest.mark.parametrize("package", ESTIMATOR_PACKAGES)
def test_plotting_and_estimator_packages_use_each_others_public_api(package):
    edges = _import_graph()
    for source, target in (("plotting", package), (package, "plotting")):
        for where, module, names, top in edges.get((source, target), []):
            private = [p for p in module.split(".") if p.startswith("_")]
            private += [n for n in names if n.startswith("_")]
            assert not private, f"{where}: {source} imports private {private}"
    # The estimator packages import plotting only inside their plot methods.
    eager = [w for w, *_, top in edges.get((package, "plotting"), []) if top]
    assert not eager, f"{package} imports skthermal.plotting at module level: {eager}"


@pytest.mark.parametrize(
    "names",
    [
        [f"Ts{k}a_C" for k in range(16)],
        ["Tcarrier3_C", "Tspindleboss_C", "Tcolumn_top_C", "Tambient_C"],
    ],
)
def test_sensor_names_are_whole_and_apart_in_the_figure(names):
    # Rotated names ran off the bottom of the figure (a savefig showed
    # '0a_C' for 'Ts0a_C'); four long upright names overlapped.
    n = len(names)
    disp = SensorScoreDisplay(
        scores=np.linspace(1, 0.1, n), support=np.arange(n) < 2, feature_names=names
    ).plot()
    fig = disp.figure_
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in disp.ax_.get_xticklabels()]
    assert all(b.y0 >= 0 and b.x0 >= 0 and b.x1 <= fig.bbox.x1 for b in boxes)
    assert all(a.x1 <= b.x0 for a, b in zip(boxes[:-1], boxes[1:]))
    plt.close(fig)
