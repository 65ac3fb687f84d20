"""ModularRegressor: modules trained on single-source tests, superposed."""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.pipeline import make_pipeline

from skthermal import GNNMCIRegressor, GreyPSORegressor
from skthermal.datasets import changes_since_start, split_runs
from skthermal.ensemble import ModularRegressor
from skthermal.linear_model import TransferFunctionRegressor
from skthermal.preprocessing import LagFeatures, LagRidgeCV
from skthermal.simulate import DutyCycle, ThermalMachine


def _two_tests(n=40):
    heat = np.linspace(0.0, 4.0, n)
    quiet = np.zeros(n)
    X = np.r_[np.c_[heat, quiet, 10 + heat], np.c_[quiet, heat, 10 + quiet]]
    y = np.r_[3.0 * heat, -2.0 * heat]
    return X, y, np.repeat(["spindle", "axis"], n)


def test_sum_of_modules_by_hand():
    X, y, source = _two_tests()
    model = ModularRegressor(
        [("spindle", LinearRegression(), [0]), ("axis", LinearRegression(), [1])],
        relative=False,
    ).fit(X, y, source=source)
    Xq = np.array([[1.0, 2.0, 0.0], [0.5, 0.0, 0.0]])
    np.testing.assert_allclose(model.predict(Xq), [3.0 - 4.0, 1.5], atol=1e-10)
    parts = model.predict_modules(Xq)
    np.testing.assert_allclose(parts, [[3.0, -4.0], [1.5, 0.0]], atol=1e-10)
    assert model.n_iter_ == 0
    np.testing.assert_allclose(model.named_estimators_["spindle"].coef_, [3.0])
    assert [c.tolist() for c in model.module_columns_] == [[0], [1]]


def test_relative_works_on_changes_since_each_run_start():
    X, y, source = _two_tests()
    offset = np.r_[np.full(40, 20.0), np.full(40, 23.0)]
    Xa = X + offset[:, None]
    ya = y + 5.0
    groups = source  # one run per test
    model = ModularRegressor(
        [("spindle", LinearRegression(), [0]), ("axis", LinearRegression(), [1])]
    ).fit(Xa, ya, source=source, groups=groups)
    combined = np.c_[np.linspace(0, 2, 5), np.linspace(0, 1, 5), np.zeros(5)] + 21.0
    # Fitted on labelled runs, given rows without labels: one run, with a word.
    with pytest.warns(UserWarning, match="carry no run labels"):
        pred = model.predict(combined)
    np.testing.assert_allclose(pred, model.predict(combined, groups=np.zeros(5)))
    np.testing.assert_allclose(
        pred, 3.0 * np.linspace(0, 2, 5) - 2.0 * np.linspace(0, 1, 5), atol=1e-9
    )
    # A run column of a DataFrame splits the runs at predict time too.
    frame = pd.DataFrame(np.r_[combined, combined + 1.0], columns=["a", "b", "c"])
    frame.insert(0, "run", ["p"] * 5 + ["q"] * 5)
    model.fit(
        pd.DataFrame(Xa, columns=["a", "b", "c"]), ya, source=source, groups=groups
    )
    out = model.predict(frame)
    np.testing.assert_allclose(out[:5], out[5:], atol=1e-9)


def test_backfitting_recovers_an_additive_truth(rng):
    X = rng.normal(size=(300, 4))
    y = 2.0 * X[:, 0] - X[:, 1] + 0.5 * X[:, 2] + 3.0
    model = ModularRegressor(
        [("a", LinearRegression(), [0, 1]), ("b", LinearRegression(), [2, 3])],
        relative=False,
    ).fit(X, y)
    np.testing.assert_allclose(model.predict(X), y, atol=1e-6)
    assert 1 <= model.n_iter_ <= 20
    np.testing.assert_allclose(model.named_estimators_["a"].coef_, [2.0, -1.0])
    np.testing.assert_allclose(
        model.named_estimators_["b"].coef_, [0.5, 0.0], atol=1e-9
    )


def test_default_is_one_linear_model_and_multioutput(rng):
    X = rng.normal(size=(50, 3))
    Y = np.c_[X @ [1.0, 2.0, 3.0], X @ [-1.0, 0.0, 1.0]]
    model = ModularRegressor(relative=False).fit(X, Y)
    np.testing.assert_allclose(model.predict(X), Y, atol=1e-9)
    assert model.predict_modules(X).shape == (50, 1, 2)


def test_named_columns_and_nested_params():
    X, y, source = _two_tests()
    df = pd.DataFrame(X, columns=["Tboss_C", "Tnut_C", "Tother_C"])
    model = ModularRegressor(
        [("spindle", Ridge(alpha=1.0), ["Tboss_C"]), ("axis", Ridge(), "Tnut_C")],
        relative=False,
    )
    params = model.get_params()
    assert params["spindle__alpha"] == 1.0 and "axis" in params
    model.set_params(spindle__alpha=1e-9, axis=LinearRegression())
    assert model.modules[0][1].alpha == 1e-9
    assert isinstance(model.modules[1][1], LinearRegression)
    assert model.modules[1][2] == "Tnut_C"
    model.fit(df, y, source=source)
    np.testing.assert_allclose(model.predict(df.iloc[:3]), y[:3], atol=1e-6)
    # The given modules are not fitted in place.
    assert not hasattr(model.modules[1][1], "coef_")
    clone(model)


def test_fit_modules_from_tables_and_pairs():
    X, y, _ = _two_tests()
    pairs = {"spindle": (X[:40], y[:40]), "axis": (X[40:], y[40:])}
    model = ModularRegressor(
        [("spindle", LinearRegression(), [0]), ("axis", LinearRegression(), [1])]
    ).fit_modules(pairs)
    np.testing.assert_allclose(
        model.predict([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]), [0.0, 1.0], atol=1e-9
    )
    tables = {
        name: pd.DataFrame(
            {
                "run": name,
                "time_s": np.arange(40.0),
                "T1_C": Xi[:, 0],
                "T2_C": Xi[:, 1],
                "disp_y_um": yi,
            }
        )
        for name, (Xi, yi) in pairs.items()
    }
    model = ModularRegressor(
        [
            ("spindle", LinearRegression(), ["T1_C"]),
            ("axis", LinearRegression(), ["T2_C"]),
        ]
    ).fit_modules(tables)
    np.testing.assert_allclose(model.named_estimators_["axis"].coef_, [-2.0])
    with pytest.raises(ValueError, match="several targets"):
        model.fit_modules({k: v.assign(disp_z_um=0.0) for k, v in tables.items()})
    with pytest.raises(ValueError, match="differ"):
        model.fit_modules(
            {"spindle": tables["spindle"], "axis": tables["axis"].assign(T3_C=1.0)}
        )
    with pytest.raises(ValueError, match="non-empty dict"):
        model.fit_modules({})
    # Inputs in the tables' order (drivers were put after the temperatures):
    # a test of the same layout is predicted without its displacements.
    tables = {
        k: v.assign(spindle_rpm=0.0)[
            ["run", "time_s", "spindle_rpm", "T1_C", "T2_C", "disp_y_um"]
        ]
        for k, v in tables.items()
    }
    model.fit_modules(tables)
    assert list(model.feature_names_in_) == ["spindle_rpm", "T1_C", "T2_C"]
    test = tables["axis"].drop(columns="disp_y_um")
    np.testing.assert_allclose(
        model.predict(test),
        model.predict(test.to_numpy()[:, 2:].astype(float), groups=test["run"]),
    )


@pytest.mark.parametrize(
    "modules, message",
    [
        ([], "empty"),
        ([("a", LinearRegression())], "tuple"),
        (
            [("a", LinearRegression(), [0]), ("a", LinearRegression(), [1])],
            "Two modules",
        ),
        ([("a__b", LinearRegression(), [0])], "without '__'"),
        ([("tol", LinearRegression(), [0])], "clashes"),
        ([("a", "estimator", [0])], "not a regressor"),
        ([("a", LinearRegression(), [5])], "out of range"),
        ([("a", LinearRegression(), ["T1_C"])], "no column names"),
        ([("a", LinearRegression(), [0, 0])], "twice"),
        ([("a", LinearRegression(), [])], "reads no column"),
        ([("a", LinearRegression(), [0.5])], "integer positions"),
    ],
)
def test_module_errors(modules, message):
    X, y, _ = _two_tests()
    with pytest.raises(ValueError, match=message):
        ModularRegressor(modules).fit(X, y)


def test_source_errors():
    X, y, source = _two_tests()
    model = ModularRegressor(
        [("spindle", LinearRegression(), [0]), ("axis", LinearRegression(), [1])]
    )
    with pytest.raises(ValueError, match="not modules"):
        model.fit(X, y, source=np.where(source == "axis", "feed", source))
    with pytest.raises(ValueError, match="no training rows"):
        model.fit(X, y, source=np.full(80, "spindle"))
    with pytest.raises(ValueError, match="one module name per row"):
        model.fit(X, y, source=source[:3])
    df = pd.DataFrame(X, columns=["a", "b", "c"])
    with pytest.raises(ValueError, match=r"\['zz'\] are not in X"):
        ModularRegressor([("m", LinearRegression(), ["zz"])]).fit(df, y)


def test_simulated_spindle_and_feed_tests_predict_the_combined_test():
    """001 §5.4.1.3 on simulated runs: modules beat a model of one test."""
    machine = ThermalMachine.from_preset(
        "vmc-b", params={"feed_heating.W_per_m_min": 15.0}
    )
    kw = {"sample_period_s": 120}
    spindle = machine.simulate(
        DutyCycle.heat_cool(8000, heat_h=2, cool_h=2),
        20.0,
        run="spindle",
        random_state=0,
        **kw,
    )
    feed = machine.simulate(
        DutyCycle.heat_cool(0, heat_h=2, cool_h=2, feed_mm_min=10000),
        20.0,
        run="feed",
        random_state=1,
        **kw,
    )
    both = machine.simulate(
        DutyCycle([(3 * 3600, 6000, 8000), (3600, 0, 0)]),
        20.5,
        run="combined",
        random_state=2,
        **kw,
    )
    head = ["T63_C", "T12_C", "T40_C", "T25_C"]
    axis = ["T68_C", "T69_C", "T74_C"]
    model = ModularRegressor(
        [("spindle", LinearRegression(), head), ("axis", LinearRegression(), axis)]
    ).fit_modules({"spindle": spindle, "axis": feed}, target="disp_y_um")
    truth = changes_since_start(both, "disp_y_um")["disp_y_um"].to_numpy()
    modular = model.predict(both[["run", *model.feature_names_in_]])
    rmse = np.sqrt(np.mean((modular - truth) ** 2))
    one = changes_since_start(spindle, head + axis + ["disp_y_um"])
    single = LinearRegression().fit(one[head + axis], one["disp_y_um"])
    rel = changes_since_start(both, head + axis)
    rmse_single = np.sqrt(np.mean((single.predict(rel[head + axis]) - truth) ** 2))
    assert rmse < 0.05 * np.abs(truth).max()
    assert rmse < 0.5 * rmse_single


# --- sequence modules get the run table's structure ---------------------------


@pytest.fixture(scope="module")
def machine_b_runs():
    """Two training runs and a test run of the simulated Machine B."""
    machine = ThermalMachine.from_preset("vmc-b")
    kw = {"sample_period_s": 120}
    train = pd.concat(
        [
            machine.simulate(
                DutyCycle.heat_cool(8000, heat_h=2, cool_h=2),
                20.0,
                run="a",
                random_state=0,
                **kw,
            ),
            machine.simulate(
                DutyCycle.heat_cool(4000, heat_h=3, cool_h=1),
                20.5,
                run="b",
                random_state=1,
                **kw,
            ),
        ],
        ignore_index=True,
    )
    test = machine.simulate(
        DutyCycle([(3 * 3600, 6000, 0), (3600, 0, 0)]),
        20.5,
        run="c",
        random_state=2,
        **kw,
    )
    return train, test


_HEAD = ["T63_C", "T12_C", "T40_C", "spindle_rpm"]
_SEQUENCE_MODULES = [
    make_pipeline(LagFeatures(), Ridge(alpha=1.0)),  # drivers="auto": by name
    LagRidgeCV(),
    TransferFunctionRegressor(),
    GreyPSORegressor(n_particles=10, epochs=5, random_state=0),
    GNNMCIRegressor(n_particles=10, epochs=5, random_state=0),
]


@pytest.mark.parametrize("module", _SEQUENCE_MODULES, ids=lambda m: type(m).__name__)
def test_sequence_module_predicts_as_when_fitted_alone(machine_b_runs, module):
    # Given plain arrays, a module lost the runs, the times and the driver
    # names: TransferFunctionRegressor was 3.7 um off on the test run.
    train, test = machine_b_runs
    X, y, _ = split_runs(train, sensors=[*_HEAD, "T25_C"], targets="disp_y_um")
    X_test, _, _ = split_runs(test, sensors=[*_HEAD, "T25_C"], targets="disp_y_um")
    alone = clone(module).fit(X[_HEAD], y)
    model = ModularRegressor([("head", clone(module), _HEAD)], relative=False)
    model.fit(X, y)
    for data in (X_test, X):
        np.testing.assert_allclose(
            model.predict(data), alone.predict(data[_HEAD]), rtol=0, atol=1e-9
        )
    # The run table itself (run and time_s columns) works the same.
    table = test[["run", "time_s", *model.feature_names_in_]]
    np.testing.assert_allclose(
        model.predict(table), alone.predict(X_test[_HEAD]), rtol=0, atol=1e-9
    )


def test_sequence_module_on_changes_since_the_run_start(machine_b_runs):
    # relative=True: the module sees the changes, with the runs and times.
    train, test = machine_b_runs
    columns = [*_HEAD, "disp_y_um"]
    X, y, _ = split_runs(train, sensors=_HEAD, targets="disp_y_um")
    X_test, _, _ = split_runs(test, sensors=_HEAD, targets="disp_y_um")
    rel = changes_since_start(train, columns).set_index(["run", "time_s"])
    rel_test = changes_since_start(test, _HEAD).set_index(["run", "time_s"])
    alone = TransferFunctionRegressor().fit(rel[_HEAD], rel["disp_y_um"])
    model = ModularRegressor([("head", TransferFunctionRegressor(), _HEAD)])
    np.testing.assert_allclose(
        model.fit(X, y).predict(X_test),
        alone.predict(rel_test[_HEAD]),
        rtol=0,
        atol=1e-9,
    )


def test_fit_modules_keeps_the_tests_runs_and_times(machine_b_runs):
    train, test = machine_b_runs
    spindle = train[train["run"] == "a"]
    other = train[train["run"] == "b"]
    model = ModularRegressor(
        [
            ("head", TransferFunctionRegressor(), _HEAD),
            ("rest", LinearRegression(), ["T25_C"]),
        ]
    ).fit_modules({"head": spindle, "rest": other}, target="disp_y_um")
    rel = changes_since_start(spindle, [*_HEAD, "disp_y_um"])
    alone = TransferFunctionRegressor().fit(
        rel.set_index(["run", "time_s"])[_HEAD], rel["disp_y_um"]
    )
    rel_test = changes_since_start(test, _HEAD).set_index(["run", "time_s"])
    np.testing.assert_allclose(
        model.predict_modules(test[["run", "time_s", *model.feature_names_in_]])[:, 0],
        alone.predict(rel_test[_HEAD]),
        rtol=0,
        atol=1e-9,
    )


def test_plain_arrays_with_groups_give_the_modules_their_runs(machine_b_runs):
    train, test = machine_b_runs
    X, y, groups = split_runs(train, sensors=_HEAD, targets="disp_y_um")
    X_test, _, groups_test = split_runs(test, sensors=_HEAD, targets="disp_y_um")
    A, A_test = X.to_numpy(), X_test.to_numpy()
    alone = TransferFunctionRegressor(dt=120).fit(A, y.to_numpy(), groups=groups)
    model = ModularRegressor(
        [("head", TransferFunctionRegressor(dt=120), None)], relative=False
    ).fit(A, y.to_numpy(), groups=groups)
    np.testing.assert_allclose(
        model.predict(A_test, groups=groups_test),
        alone.predict(A_test, groups=groups_test),
        rtol=0,
        atol=1e-9,
    )


class _Probe(RegressorMixin, BaseEstimator):
    """Records what it is given; predicts zeros."""

    def fit(self, X, y):
        self.fit_input_ = X
        return self

    def predict(self, X):
        self.predict_input_ = X
        return np.zeros(len(X))


def test_modules_get_sub_tables_of_a_run_table_and_arrays_of_arrays():
    X, y, source = _two_tests()
    frame = pd.DataFrame(X, columns=["T1_C", "T2_C", "T3_C"])
    frame.insert(0, "time_s", np.tile(np.arange(40.0) * 60, 2))
    frame.insert(0, "run", np.repeat(["r1", "r2"], 40))
    by_source = {"source": np.where(source == "spindle", "a", "b")}
    for kwargs, n_fit in (({}, 80), (by_source, 40)):
        model = ModularRegressor(
            [("a", _Probe(), ["T2_C", "T1_C"]), ("b", _Probe(), "T3_C")],
            relative=False,
        ).fit(frame, y, **kwargs)
        model.predict(frame.iloc[40:])
        seen = model.named_estimators_["a"]
        for got, rows in ((seen.fit_input_, n_fit), (seen.predict_input_, 40)):
            assert isinstance(got, pd.DataFrame)
            assert list(got.columns) == ["T2_C", "T1_C"]
            assert list(got.index.names) == ["run", "time_s"]
            assert len(got) == rows
        np.testing.assert_array_equal(seen.fit_input_.to_numpy(), X[:n_fit, [1, 0]])
        np.testing.assert_array_equal(
            seen.predict_input_.index.get_level_values("time_s"),
            np.arange(40.0) * 60,
        )
        np.testing.assert_array_equal(seen.predict_input_.to_numpy(), X[40:, [1, 0]])
    # groups win over the table's own runs.
    model.fit(frame, y, groups=np.repeat(["g1", "g2"], 40))
    seen = model.named_estimators_["a"].fit_input_
    assert set(seen.index.get_level_values("run")) == {"g1", "g2"}
    # Plain arrays without runs: plain arrays, as before.
    model = ModularRegressor([("a", _Probe(), [1, 0])], relative=False).fit(X, y)
    model.predict(X[:5])
    seen = model.named_estimators_["a"]
    assert isinstance(seen.fit_input_, np.ndarray)
    assert isinstance(seen.predict_input_, np.ndarray)
    np.testing.assert_array_equal(seen.predict_input_, X[:5, [1, 0]])


def test_unlabelled_rows_warn_once_not_once_per_module(machine_b_runs):
    train, _ = machine_b_runs
    X, y, _ = split_runs(train, sensors=_HEAD, targets="disp_y_um")
    model = ModularRegressor(
        [
            ("a", TransferFunctionRegressor(), _HEAD[:2]),
            ("b", TransferFunctionRegressor(), _HEAD[2:]),
        ],
        max_iter=2,
    )
    # Two backfitting sweeps (for speed) do not converge, and fit says so.
    with pytest.warns(ConvergenceWarning, match=r"did not converge in max_iter=2"):
        model.fit(X, y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.predict(X.to_numpy()[:30])
    messages = [str(w.message) for w in caught if "labelled run" in str(w.message)]
    assert len(messages) == 1 and messages[0].startswith("ModularRegressor")


def test_a_numpy_step_in_front_warns_once_that_the_runs_become_one(machine_b_runs):
    # The changes since the start of the run need the runs: a step that
    # outputs numpy dropped them, and all training runs became one.
    from sklearn.preprocessing import StandardScaler

    train, _ = machine_b_runs
    X, y, _ = split_runs(train, sensors=_HEAD[:3], targets="disp_y_um")
    modules = [("grey", GreyPSORegressor(calibration="ls"), None)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        make_pipeline(StandardScaler(), ModularRegressor(modules)).fit(X, y)
    messages = [str(w.message) for w in caught if "no run labels" in str(w.message)]
    assert len(messages) == 1, messages  # not again by the grey module
    assert messages[0].startswith(f"ModularRegressor.fit got {len(X)} rows")
    assert "set_output(transform='pandas')" in messages[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        make_pipeline(StandardScaler(), ModularRegressor(modules)).set_output(
            transform="pandas"
        ).fit(X, y)
        # Without relative changes and with a module that reads no runs,
        # nothing to say.
        ModularRegressor(relative=False).fit(X.to_numpy(), y)
    # A sequence module says it itself, once, not once per backfitting sweep.
    two = [*modules, ("linear", LinearRegression(), [0])]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = ModularRegressor(two, relative=False, max_iter=5)
        model.fit(X.to_numpy(), y)
    messages = [str(w.message) for w in caught if "no run labels" in str(w.message)]
    assert model.n_iter_ > 1
    assert len(messages) == 1 and messages[0].startswith("GreyPSORegressor.fit")


def _weighted_case():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(60, 2))
    y = X @ [2.0, -1.0] + rng.normal(size=60)
    return X, y, rng.integers(1, 4, 60)


def test_sample_weight_equals_repeated_rows():
    # Weighted backfitting of linear modules fits the rows repeated by their
    # integer weights; with source, every module gets its own rows' weights.
    X, y, w = _weighted_case()
    modules = [("a", LinearRegression(), [0]), ("b", LinearRegression(), [1])]
    model = ModularRegressor(modules, relative=False)
    weighted = clone(model).fit(X, y, sample_weight=w).predict(X)
    repeated = clone(model).fit(np.repeat(X, w, 0), np.repeat(y, w)).predict(X)
    np.testing.assert_allclose(weighted, repeated, atol=1e-9)
    assert not np.allclose(weighted, clone(model).fit(X, y).predict(X))
    source = np.where(np.arange(60) < 30, "a", "b")
    by_source = clone(model).fit(X, y, source=source, sample_weight=w).predict(X)
    rep = clone(model).fit(
        np.repeat(X, w, 0), np.repeat(y, w), source=np.repeat(source, w)
    )
    np.testing.assert_allclose(by_source, rep.predict(X), atol=1e-9)


def test_metadata_routing_to_modules():
    import sklearn
    from sklearn.exceptions import UnsetMetadataPassedError
    from sklearn.model_selection import KFold, cross_validate

    X, y, w = _weighted_case()
    with sklearn.config_context(enable_metadata_routing=True):
        asked = ModularRegressor(
            [
                ("a", LinearRegression().set_fit_request(sample_weight=True), [0]),
                ("b", LinearRegression().set_fit_request(sample_weight=False), [1]),
            ],
            relative=False,
        )
        source = np.where(np.arange(60) < 30, "a", "b")
        routed = clone(asked).fit(X, y, source=source, sample_weight=w)
        # Only module "a" asked for the weights: its rows' weights.
        a = LinearRegression().fit(X[:30, :1], y[:30], sample_weight=w[:30])
        b = LinearRegression().fit(X[30:, 1:], y[30:])
        np.testing.assert_allclose(routed.named_estimators_["a"].coef_, a.coef_)
        np.testing.assert_allclose(routed.named_estimators_["b"].coef_, b.coef_)
        scores = cross_validate(
            asked.set_score_request(sample_weight=False),
            X,
            y,
            cv=KFold(3),
            params={"sample_weight": w},
        )["test_score"]
        assert np.all(np.isfinite(scores))
        unset = ModularRegressor([("a", LinearRegression(), [0])], relative=False)
        with pytest.raises(UnsetMetadataPassedError, match="sample_weight"):
            unset.fit(X, y, sample_weight=w)
