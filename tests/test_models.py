"""Tests of the named models and of RunStartRegressor."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.utils._param_validation import InvalidParameterError

from skthermal.cli import main
from skthermal.models import (
    MODELS,
    RunStartRegressor,
    make_model,
    make_selector,
    model_search_space,
)


def _two_runs(n=30):
    t = np.linspace(0.0, 1.0, n)
    X = np.c_[np.r_[20 + 3 * t, 22 + 4 * t], np.r_[18 + t**2, 19 + 2 * t**2]]
    y = np.r_[5 + 2 * X[:n, 0] - X[:n, 1], -3 + 2 * X[n:, 0] - X[n:, 1]]
    return X, y, np.repeat(["a", "b"], n)


def test_run_start_regressor_validates_its_estimator():
    X, y, groups = _two_runs()
    with pytest.raises(InvalidParameterError, match="estimator"):
        RunStartRegressor("ridge").fit(X, y, groups=groups)


def test_run_start_regressor_needs_contiguous_runs():
    X, y, groups = _two_runs()
    mixed = groups[np.r_[0:20, 40:60, 20:40]]
    with pytest.raises(ValueError, match="not contiguous"):
        RunStartRegressor(LinearRegression()).fit(X, y, groups=mixed)


def test_run_start_regressor_hands_runs_and_names_to_the_inner_model():
    X, y, groups = _two_runs()
    frame = pd.DataFrame(X, columns=["T1_C", "T2_C"]).assign(run=groups)
    model = RunStartRegressor(LinearRegression()).fit(frame, y)
    assert list(model.feature_names_in_) == ["T1_C", "T2_C"]
    assert list(model.estimator_.feature_names_in_) == ["T1_C", "T2_C"]
    pred = model.predict(frame)
    assert pred[0] == 0 and pred[30] == 0
    z = np.r_[y[:30] - y[0], y[30:] - y[30]]
    np.testing.assert_allclose(pred, z, atol=1e-9)
    with pytest.raises(ValueError, match="T2_C"):
        model.predict(frame[["T1_C", "run"]])


def test_run_start_regressor_keeps_drivers_and_times():
    X, y, groups = _two_runs()
    t = np.r_[np.arange(30), np.arange(30)] * 60.0
    rpm = np.r_[np.full(30, 2000.0), np.full(30, 3000.0)]
    frame = pd.DataFrame(
        {"run": groups, "time_s": t, "T1_C": X[:, 0], "spindle_rpm": rpm}
    )

    class Spy(LinearRegression):
        def fit(self, X, y):
            self.seen_ = X.copy()
            return super().fit(X, y)

    model = RunStartRegressor(Spy(), drivers=["spindle_rpm"]).fit(frame, y)
    seen = model.estimator_.seen_
    # Temperatures as changes, the driver as it is, indexed by run and time.
    np.testing.assert_allclose(seen["T1_C"].iloc[[0, 30]], 0.0)
    np.testing.assert_allclose(seen["spindle_rpm"], rpm)
    assert seen.index.names == ["run", "time_s"]
    np.testing.assert_allclose(seen.index.get_level_values("time_s"), t)
    # A time-aware inner model reads the sampling period from those times.
    from skthermal.preprocessing import LagRidgeCV

    lag = RunStartRegressor(
        LagRidgeCV(time_constant_sets=[(600.0,)], alphas=[1.0]),
        drivers=["spindle_rpm"],
    )
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "no time_s" warning
        # (y starts far from 0 in both runs, which is said.)
        warnings.filterwarnings("ignore", message=".*predicts the change of the")
        lag.fit(frame, y)
    assert lag.estimator_.lag_features_.sample_period_s_ == pytest.approx(60.0)
    with pytest.raises(ValueError, match="drivers: 'rpm' is not a column"):
        RunStartRegressor(LinearRegression(), drivers=["rpm"]).fit(frame, y)
    # A name with a plain array: the cause is that X has no names.
    plain = frame.drop(columns=["run", "time_s"], errors="ignore").to_numpy()
    with pytest.raises(
        ValueError, match="'spindle_rpm' is a column name, but X has no"
    ):
        RunStartRegressor(LinearRegression(), drivers=["spindle_rpm"]).fit(plain, y)
    # "auto": the run table's drivers present among the columns.
    auto = RunStartRegressor(Spy(), drivers="auto").fit(frame, y)
    pd.testing.assert_frame_equal(auto.estimator_.seen_, seen)
    alone = RunStartRegressor(Spy(), drivers="auto").fit(
        frame.drop(columns="spindle_rpm"), y
    )
    np.testing.assert_allclose(alone.estimator_.seen_["T1_C"], seen["T1_C"])


def test_run_start_regressor_warns_when_runs_lose_their_labels():
    X, y, groups = _two_runs()
    model = RunStartRegressor(LinearRegression()).fit(X, y, groups=groups)
    with pytest.warns(UserWarning, match="fitted on 2 labelled run.*ONE run"):
        model.predict(X)
    # A plain array in fit is one run, as the other sequence models say.
    with pytest.warns(UserWarning, match="carry no run labels"):
        unlabelled = RunStartRegressor(LinearRegression()).fit(X[:30], y[:30])
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        unlabelled.predict(X[:30])


def test_every_named_model_is_wrapped_and_has_a_search_space():
    for name in MODELS:
        model = make_model(name, random_state=0, quick=True)
        assert isinstance(model, RunStartRegressor)
        if MODELS[name].paper:
            assert callable(model_search_space(name))
        else:  # the baselines tune themselves; asking for a space says so
            with pytest.raises(ValueError, match="own time-ordered"):
                model_search_space(name)
    with pytest.raises(InvalidParameterError, match="name"):
        make_model("svm")
    with pytest.raises(InvalidParameterError, match="n_sensors"):
        make_selector("fcm", 0)


def test_mlp_search_space_keys_are_model_parameters():
    optuna = pytest.importorskip("optuna")
    model = make_model("mlp")
    trial = optuna.trial.FixedTrial({"hidden": 4, "alpha": 1e-3, "activation": "relu"})
    params = model_search_space("mlp")(trial)
    model.set_params(**params)
    inner = model.estimator.steps[-1][1].regressor
    assert inner.hidden_layer_sizes == (4,) and inner.activation == "relu"


@pytest.fixture(scope="module")
def small_runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    path = folder / "runs.csv"
    rng = np.random.default_rng(0)
    frames = []
    for r in range(3):
        t = np.arange(60) * 60.0
        heat = (1 - np.exp(-t / 1500.0)) * (4 + r)
        frames.append(
            pd.DataFrame(
                {
                    "run": f"r{r}",
                    "time_s": t,
                    "T01_C": 20 + heat + rng.normal(0, 0.02, t.size),
                    "T02_C": 20 + 0.5 * heat + rng.normal(0, 0.02, t.size),
                    "disp_y_um": 3 * heat + rng.normal(0, 0.1, t.size),
                }
            )
        )
    pd.concat(frames).to_csv(path, index=False)
    return path


@pytest.mark.parametrize("name", list(MODELS))
def test_every_cli_model_loads_back_with_skthermal_io_in_a_fresh_process(
    name, small_runs, tmp_path, capsys
):
    pytest.importorskip("skops")
    out = tmp_path / f"{name}.skops"
    argv = ["fit", "--runs", str(small_runs), "--model", name, "--quick"]
    argv += ["--sensors", "T01_C,T02_C", "--set", "epochs=3"] if "anfis" in name else []
    argv += ["--set", "n_particles=5", "--set", "epochs=3"] if "g" == name[0] else []
    assert main([*argv, "--out", str(out)]) == 0, capsys.readouterr().err
    code = (
        "import sys, pandas as pd; from skthermal.io import load; "
        "b = load(sys.argv[1]); df = pd.read_csv(sys.argv[2]); "
        "X = df.set_index(['run', 'time_s'])[b['sensors']]; "
        "p = b['estimator'].predict(X); "
        "print(type(b['estimator']).__module__, len(p), bool((p == p).all()))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(out), str(small_runs)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["skthermal.models._run_start", "180", "True"]


def test_wrappers_take_several_targets_when_their_models_do():
    from sklearn.linear_model import LinearRegression
    from sklearn.utils import get_tags

    from skthermal import GreyPSORegressor, ModularRegressor
    from skthermal.models import RunStartRegressor

    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3)).cumsum(axis=0)
    Y = np.c_[X @ [1.0, 2.0, 0.0], X @ [0.0, -1.0, 3.0]]
    groups = np.repeat(["a", "b"], 20)
    model = RunStartRegressor(LinearRegression()).fit(X, Y, groups=groups)
    assert model.predict(X, groups=groups).shape == (40, 2)
    assert get_tags(model).target_tags.multi_output
    assert not get_tags(RunStartRegressor(GreyPSORegressor())).target_tags.multi_output
    grey = ModularRegressor([("grey", GreyPSORegressor(), None)])
    assert not get_tags(grey).target_tags.multi_output
    assert get_tags(ModularRegressor()).target_tags.multi_output


def _cold_runs_that_start_turning(n_runs=6):
    """Runs from a cold machine whose spindle turns from the first row: the
    error and the temperatures are lags of the bearing heat from rest."""
    from scipy.signal import lfilter

    def lag(x, tau):
        a = np.exp(-60.0 / tau)
        return lfilter([1 - a], [1, -a], x)

    rng = np.random.default_rng(0)
    frames = []
    for r in range(n_runs):
        t = np.arange(0, 5 * 3600, 60.0)
        speeds = rng.choice([2000.0, 4000.0, 6000.0], 5)
        hour = (t // 3600).astype(int)
        rpm = np.where(hour % 2 == 0, speeds[hour], 0.0)
        heat = (rpm / 1000) ** 1.3
        noise = rng.standard_normal((3, t.size))
        frames.append(
            pd.DataFrame(
                {
                    "run": f"r{r}",
                    "time_s": t,
                    "spindle_rpm": rpm,
                    "T1_C": 20 + 0.5 * lag(heat, 1200) + 0.02 * noise[0],
                    "T2_C": 20 + 0.2 * lag(heat, 3600) + 0.02 * noise[1],
                    "disp_z_um": 3 * lag(heat, 900)
                    + 1.5 * lag(heat, 5400)
                    + 0.2 * noise[2],
                }
            )
        )
    return pd.concat(frames, ignore_index=True).set_index(["run", "time_s"])


def test_lag_ridge_starts_the_drivers_filters_at_the_run_start():
    # The named lag model predicts changes since each run's start, which is
    # its reference state: its drivers' filters start from rest there. In
    # steady state, a run that starts turning read as a warm machine at its
    # first row, and that row's predicted error, subtracted from the whole
    # run, shifted it.
    import warnings

    from skthermal.preprocessing import make_lag_pipeline

    runs = _cold_runs_that_start_turning()
    train = runs.loc[["r0", "r1", "r2", "r3"]]
    test = runs.loc[["r4", "r5"]]
    X = ["T1_C", "T2_C", "spindle_rpm"]
    model = make_model("lag-ridge")
    assert model.estimator.driver_initial == "rest"
    steady = RunStartRegressor(make_lag_pipeline(), drivers="auto")

    def rmse(m, cols):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m.fit(train[cols], train["disp_z_um"].to_numpy())
            p = m.predict(test[cols])
        return float(np.sqrt(np.mean((p - test["disp_z_um"].to_numpy()) ** 2)))

    ours, before = rmse(model, X), rmse(steady, X)
    assert ours < 0.9 * before
    assert ours < rmse(make_model("ridge"), X[:2])
