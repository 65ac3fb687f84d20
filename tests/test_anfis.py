"""Tests of ANFISRegressor, its array-level core and the membership functions."""

import pickle
import re
import warnings

import joblib
import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from sklearn.base import clone
from sklearn.metrics import r2_score
from sklearn.model_selection import GroupKFold, cross_validate
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal.fuzzy import ANFISRegressor
from skthermal.fuzzy._anfis_core import (
    StepSizeRule,
    _forward,
    _normalised_firing,
    _premise_gradient,
    _rule_matrix,
    _rule_outputs,
    _rule_selectors,
    _with_ones,
    anfis_predict,
    fcm_mf_params,
    grid_mf_params,
    grid_rules,
    solve_consequents,
)
from skthermal.fuzzy._membership import (
    gaussian_mf,
    gbell_mf,
    log_gaussian_mf,
    log_gbell_mf,
    log_membership,
    log_membership_grad,
)

# Jang (1993) example 4, Table VI: bell MFs (a, b, c), two per input.
JANG_MFS = np.array(
    [
        (0.1790, 2.0456, 0.4798),
        (0.1584, 2.0103, 1.4975),
        (0.2410, 1.9533, 0.2960),
        (0.2923, 1.9178, 1.7824),
        (0.3798, 2.1490, 0.6599),
        (0.4884, 1.8967, 1.6465),
        (0.2815, 2.0170, 0.3341),
        (0.1616, 2.0165, 1.4727),
    ]
).reshape(4, 2, 3)
JANG_INITIAL = np.array([[[0.444045, 2.0, 0.425606], [0.444045, 2.0, 1.313696]]] * 4)


def _mackey_glass(shared_data):
    folder = shared_data / "mackey_glass"
    for name in ("ex4.trn", "ex4.chk", "jang_consequents.csv"):
        if not (folder / name).exists():
            pytest.skip(f"reference data file {folder / name} is absent")
    trn = np.loadtxt(folder / "ex4.trn")
    chk = np.loadtxt(folder / "ex4.chk")
    cons = np.loadtxt(folder / "jang_consequents.csv", delimiter=",", skiprows=1)
    return trn, chk, cons


def _rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


@pytest.fixture
def regression_data(rng):
    X = rng.uniform(-1, 1, size=(240, 3))
    y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2 - 0.5 * X[:, 2]
    return X, y


def _runs_table(rng, n_runs=4):
    """Heat-up runs of different length; error linear in the temperature rises."""
    frames = []
    for r in range(n_runs):
        n = 40 + 10 * r
        t = np.arange(n)
        t1 = (3 + r) * (1 - np.exp(-t / (10 + 4 * r))) + rng.normal(0, 0.02, n)
        t2 = (1 + r) * (1 - np.exp(-t / (20 + 4 * r))) + rng.normal(0, 0.02, n)
        err = 4 * t1 + 2 * t2 + rng.normal(0, 0.05, n)
        frames.append(pd.DataFrame({"run": f"r{r}", "T1": t1, "T2": t2, "err": err}))
    return pd.concat(frames, ignore_index=True)


# ---------------------------------------------------------------- membership


def test_membership_values():
    assert_allclose(gaussian_mf([0.0, 1.0, -2.0], 1.0, 0.0), np.exp([0, -0.5, -2]))
    x = np.array([-3.0, 0.5, 1.0, 2.0])
    assert_allclose(gbell_mf(x, 1.5, 2.0, 0.5), 1 / (1 + np.abs((x - 0.5) / 1.5) ** 4))
    # Log forms stay finite where the plain memberships underflow to zero.
    assert np.isfinite(log_gbell_mf(1e200, 0.1, 2.0, 0.0))
    assert np.isfinite(log_gaussian_mf(1e100, 1.0, 0.0))
    assert gbell_mf(1e200, 0.1, 2.0, 0.0) == 0.0


@pytest.mark.parametrize(
    "mf, params",
    [("gaussian", [0.7, 0.3]), ("gbell", [0.6, 1.7, 0.3]), ("gbell", [0.4, 0.8, -1])],
)
def test_log_membership_grad_matches_finite_differences(mf, params):
    x = np.array([-2.0, -0.4, 0.1, 0.3, 0.31, 1.2, 5.0])
    params = np.asarray(params, dtype=float)
    grad = log_membership_grad(x, params, mf)
    h = 1e-6
    for k in range(params.size):
        up, down = params.copy(), params.copy()
        up[k] += h
        down[k] -= h
        num = (log_membership(x, up, mf) - log_membership(x, down, mf)) / (2 * h)
        assert_allclose(grad[:, k], num, rtol=1e-5, atol=1e-6)
    # At the centre the bell derivatives are their (zero) limits, not NaN.
    at_centre = log_membership_grad(params[-1], params, mf)
    assert np.all(np.isfinite(at_centre))


# ---------------------------------------------------------------------- core


def test_grid_rules_first_input_slowest():
    assert_array_equal(
        grid_rules(2, 3)[:4], [[0, 0, 0], [0, 0, 1], [0, 1, 0], [0, 1, 1]]
    )
    assert grid_rules(3, 5).shape == (243, 5)


@pytest.mark.parametrize("mf", ["gaussian", "gbell"])
@pytest.mark.parametrize("grid", [True, False])
def test_premise_gradient_matches_finite_differences(rng, mf, grid):
    n, d, n_out = 30, 3, 2
    X = rng.uniform(-1, 1, size=(n, d))
    Y = rng.normal(size=(n, n_out))
    if grid:
        rules = grid_rules(2, d)
        centres = np.tile([-0.5, 0.6], (d, 1))
    else:
        rules = np.tile(np.arange(4)[:, None], (1, d))
        centres = rng.uniform(-1, 1, size=(d, 4))
    widths = rng.uniform(0.4, 0.9, size=centres.shape)
    if mf == "gaussian":
        params = np.stack([widths, centres], axis=-1)
    else:
        slopes = rng.uniform(1.5, 2.5, size=centres.shape)
        params = np.stack([widths, slopes, centres], axis=-1)
    cons = rng.normal(size=(rules.shape[0], d + 1, n_out))

    def loss(p):
        return 0.5 * np.sum((anfis_predict(X, p, rules, cons, mf) - Y) ** 2)

    wbar = _normalised_firing(X, params, rules, mf)
    f = _rule_outputs(_with_ones(X), cons)
    yhat = np.einsum("nr,nro->no", wbar, f)
    S = _rule_selectors(rules, params.shape[1])
    grad = _premise_gradient(X, params, mf, S, wbar, f, yhat, yhat - Y)
    num = np.zeros_like(params)
    h = 1e-6
    for idx in np.ndindex(params.shape):
        up, down = params.copy(), params.copy()
        up[idx] += h
        down[idx] -= h
        num[idx] = (loss(up) - loss(down)) / (2 * h)
    assert_allclose(grad, num, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("offset", [0.0, 20.0])
@pytest.mark.parametrize("shared", [False, True])
def test_gaussian_rule_forms_equal_the_log_memberships(rng, offset, shared):
    # Fuzzy c-means rule bases train on quadratic forms of the inputs; they
    # give the firing strengths and premise gradient of the log-membership
    # path (rules with functions of their own, or sharing some).
    from skthermal.fuzzy._anfis_core import _GaussianRuleForms, _softmax_gradient

    n, d, n_out = 200, 5, 2
    X = offset + rng.uniform(-1, 1, size=(n, d)) * rng.uniform(0.5, 3, d)
    if shared:
        rules = grid_rules(2, d)[[0, 3, 9, 17, 30]]
        centres = offset + rng.uniform(-1, 1, size=(d, 2))
    else:
        rules = np.tile(np.arange(4)[:, None], (1, d))
        centres = offset + rng.uniform(-1, 1, size=(d, 4))
    params = np.stack([rng.uniform(0.4, 2.0, size=centres.shape), centres], -1)
    cons = rng.normal(size=(rules.shape[0], d + 1, n_out))
    Y = rng.normal(size=(n, n_out))
    wbar = _normalised_firing(X, params, rules, "gaussian")
    forms = _GaussianRuleForms(np.ascontiguousarray(X.T), rules)
    assert_allclose(forms.firing(params), wbar.T, rtol=1e-10, atol=1e-14)
    f = _rule_outputs(_with_ones(X), cons)
    yhat = np.einsum("nr,nro->no", wbar, f)
    S = _rule_selectors(rules, params.shape[1])
    expected = _premise_gradient(X, params, "gaussian", S, wbar, f, yhat, yhat - Y)
    g = _softmax_gradient(wbar.T, f.transpose(1, 2, 0), yhat.T, (yhat - Y).T)
    assert_allclose(forms.gradient(g, params), expected, rtol=1e-9, atol=1e-10)


def test_step_size_rule():
    rule = StepSizeRule(0.5, 1.2, 0.9)
    errors = [5.0, 4.0, 3.0, 2.0]
    assert rule.update(errors) == 0.5  # four errors are only three decreases
    errors.append(1.0)
    assert rule.update(errors) == pytest.approx(0.6)  # four decreases
    errors.append(0.9)
    assert rule.update(errors) == pytest.approx(0.6)  # waits four epochs
    # Two up/down combinations shrink the step, in either phase.
    rule = StepSizeRule(0.5, 1.2, 0.9)
    assert rule.update([1.0, 2.0, 1.0, 2.0, 1.0]) == pytest.approx(0.45)
    rule = StepSizeRule(0.5, 1.2, 0.9)
    assert rule.update([2.0, 1.0, 2.0, 1.0, 2.0]) == pytest.approx(0.45)
    # One oscillation is not enough.
    rule = StepSizeRule(0.5, 1.2, 0.9)
    assert rule.update([3.0, 2.0, 1.0, 2.0, 1.0]) == 0.5


# ---------------------------------------------------- Jang's Mackey-Glass model


def test_jang_published_model_reproduces_paper_rmse(shared_data):
    trn, chk, cons = _mackey_glass(shared_data)
    model = ANFISRegressor.from_parameters(
        mf="gbell", mf_params=JANG_MFS, consequents=cons
    )
    assert model.n_rules_ == 16
    assert_array_equal(model.rules_[1], [0, 0, 0, 1])
    assert abs(_rmse(model.predict(trn[:, :4]), trn[:, 4]) - 0.00148) < 1e-4
    assert abs(_rmse(model.predict(chk[:, :4]), chk[:, 4]) - 0.00163) < 1e-4


def test_grid_initialisation_is_jangs(shared_data):
    trn, chk, _ = _mackey_glass(shared_data)
    # Jang's initial MFs span the range of all 1000 rows.
    model = ANFISRegressor(init="grid", mf="gbell", epochs=1)
    model.fit(np.r_[trn, chk][:, :4], np.r_[trn, chk][:, 4])
    assert_allclose(model.initial_mf_params_, JANG_INITIAL, atol=1e-9)
    assert model.n_rules_ == 16


def test_jang_training_from_scratch(shared_data):
    trn, chk, _ = _mackey_glass(shared_data)
    # Jang's initial MFs; 100 hybrid epochs (Jang ran 500; see
    # benchmarks/bench_anfis.py). No checking data: the least-training-error
    # epoch is kept, then scored on the checking rows.
    model = ANFISRegressor(init=JANG_INITIAL, mf="gbell", epochs=100, step_size=0.1)
    model.fit(trn[:, :4], trn[:, 4])
    assert _rmse(model.predict(trn[:, :4]), trn[:, 4]) < 0.00148
    assert _rmse(model.predict(chk[:, :4]), chk[:, 4]) <= 0.0016
    hist = model.history_
    assert hist["train_rmse"][-1] < hist["train_rmse"][0] / 2
    assert hist["step_size"][0] == 0.1 and len(np.unique(hist["step_size"])) > 2


def test_checking_set_keeps_best_epoch(shared_data):
    trn, chk, _ = _mackey_glass(shared_data)
    model = ANFISRegressor(init=JANG_INITIAL, mf="gbell", epochs=30, step_size=0.1)
    model.fit(trn[:, :4], trn[:, 4], X_val=chk[:, :4], y_val=chk[:, 4])
    val = model.history_["val_rmse"]
    assert model.best_epoch_ == int(np.argmin(val)) + 1
    assert _rmse(model.predict(chk[:, :4]), chk[:, 4]) == pytest.approx(val.min())


# ------------------------------------------------------------------ estimator


@pytest.mark.parametrize("mf", ["gaussian", "gbell"])
@pytest.mark.parametrize("init", ["fcm", "grid"])
@pytest.mark.parametrize("learning", ["hybrid", "backprop"])
def test_fits_nonlinear_function(regression_data, mf, init, learning):
    X, y = regression_data
    model = ANFISRegressor(
        init=init, mf=mf, learning=learning, n_clusters=4, epochs=40, random_state=0
    ).fit(X, y)
    assert model.score(X, y) > (0.99 if learning == "hybrid" else 0.9)
    assert model.n_rules_ == (4 if init == "fcm" else 8)
    assert model.consequents_.shape == (model.n_rules_, 4)
    k = 2 if mf == "gaussian" else 3
    assert model.mf_params_.shape[::2] == (3, k)
    hist = model.history_
    assert len(hist["train_rmse"]) == model.n_iter_ == 40
    assert hist["train_rmse"][model.best_epoch_ - 1] == hist["train_rmse"].min()


def test_out_of_range_inputs_stay_finite(regression_data):
    X, y = regression_data
    far = np.array([[1e6, -1e6, 1e6], [-1e6, 0.0, 0.0], [0.0, 1e6, 0.0]])
    for mf in ("gbell", "gaussian"):
        model = ANFISRegressor(mf=mf, epochs=10, random_state=0).fit(X, y)
        pred = model.predict(far)
        assert np.all(np.isfinite(pred))
        # The output is a convex combination of the rules' linear models (with
        # Gaussians far away, the widest rule alone), not 0/0.
        rule_out = far @ model.consequents_[:, :3].T + model.consequents_[:, 3]
        tol = 1e-9 * np.abs(rule_out).max(axis=1)
        assert np.all(pred >= rule_out.min(axis=1) - tol)
        assert np.all(pred <= rule_out.max(axis=1) + tol)
    # With Gaussians, products of plain memberships underflow to zero there,
    # and the plain normalisation would be 0/0.
    mu = [np.exp(log_membership(far[0, j], model.mf_params_[j], mf)) for j in range(3)]
    w = np.prod([m[model.rules_[:, j]] for j, m in enumerate(mu)], axis=0)
    assert np.all(w == 0.0)


def test_multi_output(regression_data):
    X, y = regression_data
    Y = np.c_[y, -2 * y + 1]
    model = ANFISRegressor(epochs=20, random_state=0).fit(X, Y)
    pred = model.predict(X)
    assert pred.shape == (X.shape[0], 2)
    assert model.consequents_.shape == (3, 4, 2)
    assert model.n_outputs_ == 2
    assert model.score(X, Y) > 0.95
    single = ANFISRegressor(epochs=20, random_state=0).fit(X, y)
    assert single.predict(X).shape == (X.shape[0],)


def test_random_state_reproducible_and_matters(regression_data):
    X, y = regression_data
    a = ANFISRegressor(epochs=5, random_state=1).fit(X, y).predict(X)
    b = ANFISRegressor(epochs=5, random_state=1).fit(X, y).predict(X)
    assert_array_equal(a, b)


def test_validation_fraction_holds_out_the_tail(regression_data):
    X, y = regression_data
    model = ANFISRegressor(epochs=15, validation_fraction=0.25, random_state=0)
    model.fit(X, y)
    val = model.history_["val_rmse"]
    assert model.best_epoch_ == int(np.argmin(val)) + 1
    tail = slice(180, None)
    assert _rmse(model.predict(X[tail]), y[tail]) == pytest.approx(val.min())
    # Held out per run when there are runs.
    groups = np.repeat([0, 1], 120)
    model.fit(X, y, groups=groups)
    assert model.history_["val_rmse"].shape == (15,)


def test_early_stopping(regression_data):
    X, y = regression_data
    model = ANFISRegressor(
        epochs=200, tol=1e9, n_iter_no_change=3, validation_fraction=0.2
    ).fit(X, y)
    assert model.n_iter_ == 4  # the first epoch, then three without improvement


def test_verbose(regression_data, capsys):
    X, y = regression_data
    ANFISRegressor(epochs=20, verbose=1, random_state=0).fit(X, y)
    out = capsys.readouterr().out
    assert out.count("Epoch") == 10 and "train RMSE" in out
    ANFISRegressor(epochs=3, verbose=2, random_state=0).fit(X, y)
    assert capsys.readouterr().out.count("Epoch") == 3


def test_describe_rules_uses_feature_names(regression_data):
    X, y = regression_data
    df = pd.DataFrame(X, columns=["T18", "T55", "T63"])
    model = ANFISRegressor(n_clusters=2, epochs=5, random_state=0).fit(df, y)
    text = model.describe_rules()
    lines = text.splitlines()
    assert len(lines) == 2
    assert re.match(
        r"Rule 1: IF T18 is in1mf1 \(sigma=\S+, c=\S+\) AND T55 is in2mf1 .* "
        r"THEN y = \S+\*T18 [+-] \S+\*T55 [+-] \S+\*T63 [+-] \S+$",
        lines[0],
    )
    assert_array_equal(model.feature_names_in_, ["T18", "T55", "T63"])


def test_plot_membership_functions(regression_data):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    X, y = regression_data
    model = ANFISRegressor(init="grid", mf="gbell", epochs=5).fit(X, y)
    axes = model.plot_membership_functions(which="both")
    assert len(axes) == 3
    assert len(axes[0].lines) == 4  # 2 trained + 2 initial
    _, ax = plt.subplots(1, 3)
    assert model.plot_membership_functions(ax=ax)[2] is ax[2]
    with pytest.raises(ValueError, match="which"):
        model.plot_membership_functions(which="final")
    plt.close("all")


def test_plot_without_matplotlib_names_the_extra(regression_data, monkeypatch):
    import sys

    X, y = regression_data
    model = ANFISRegressor(epochs=2).fit(X, y)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(ImportError, match=re.escape('pip install "skthermal[plot]"')):
        model.plot_membership_functions()


# ---------------------------------------------------------------- grey ANFIS


def test_grey_runs_predicted_independently(rng):
    df = _runs_table(rng)
    X, y = df[["run", "T1", "T2"]], df["err"]
    model = ANFISRegressor(grey=True, n_clusters=2, epochs=30, random_state=0)
    model.fit(X, y)
    assert_array_equal(model.feature_names_in_, ["T1", "T2"])
    pred = model.predict(X)
    assert _rmse(pred, y) < 0.2 * y.std()
    for run in ("r0", "r2"):
        rows = (df["run"] == run).to_numpy()
        assert_array_equal(model.predict(X[rows]), pred[rows])
    # Same with explicit groups, and with a run index level.
    arr = X[["T1", "T2"]].to_numpy()
    model_arr = ANFISRegressor(grey=True, n_clusters=2, epochs=30, random_state=0)
    model_arr.fit(arr, y.to_numpy(), groups=df["run"].to_numpy())
    assert_allclose(model_arr.predict(arr, groups=df["run"]), pred)
    indexed = X.set_index("run", append=True)
    assert_allclose(model.predict(indexed), pred)
    # Without run labels everything is one run: a different prediction.
    assert not np.allclose(model.predict(X[["T1", "T2"]]), pred)


def test_grey_checking_data(rng):
    df = _runs_table(rng)
    X, y = df[["run", "T1", "T2"]], df["err"]
    last = (df["run"] == "r3").to_numpy()
    model = ANFISRegressor(grey=True, n_clusters=2, epochs=10, random_state=0)
    model.fit(X[~last], y[~last], X_val=X[last], y_val=y[last])
    val = model.history_["val_rmse"]
    assert _rmse(model.predict(X[last]), y[last]) == pytest.approx(val.min())
    model.set_params(validation_fraction=0.2).fit(X, y)
    assert np.all(np.isfinite(model.history_["val_rmse"]))


# --------------------------------------------------------------- ecosystem


def test_clone_set_params_pickle_joblib(regression_data, tmp_path):
    X, y = regression_data
    model = ANFISRegressor(epochs=10, random_state=0)
    model.set_params(mf="gbell", n_clusters=2)
    fitted = clone(model).fit(X, y)
    assert fitted.n_rules_ == 2 and fitted.mf == "gbell"
    pred = fitted.predict(X)
    assert_array_equal(pickle.loads(pickle.dumps(fitted)).predict(X), pred)
    path = tmp_path / "anfis.joblib"
    joblib.dump(fitted, path)
    assert_array_equal(joblib.load(path).predict(X), pred)
    assert not hasattr(clone(fitted), "mf_params_")
    with_array = clone(ANFISRegressor(init=JANG_INITIAL.copy(), mf="gbell"))
    assert_array_equal(with_array.init, JANG_INITIAL)


def _stop_after_two(epoch, train_rmse, check_rmse):
    return epoch >= 2


def test_epoch_callback_goes_with_a_model_still_to_be_trained(regression_data):
    # The hook was dropped in every pickle, so the copies that loky sends to
    # worker processes trained all 60 epochs with n_jobs=2, 2 with n_jobs=1.
    X, y = regression_data
    model = ANFISRegressor(epochs=60, random_state=0, epoch_callback=_stop_after_two)
    assert pickle.loads(pickle.dumps(model)).epoch_callback is _stop_after_two
    fitted = clone(model).fit(X, y)
    assert len(fitted.history_["train_rmse"]) == 2
    assert pickle.loads(pickle.dumps(fitted)).epoch_callback is None
    groups = np.repeat(np.arange(6), 40)
    runs = [
        cross_validate(
            model,
            X,
            y,
            groups=groups,
            cv=GroupKFold(3),
            n_jobs=n,
            return_estimator=True,
        )
        for n in (1, 2)
    ]
    assert_array_equal(runs[0]["test_score"], runs[1]["test_score"])
    assert [len(m.history_["train_rmse"]) for m in runs[1]["estimator"]] == [2] * 3


def test_pipeline_and_grouped_cross_validation(regression_data):
    X, y = regression_data
    groups = np.repeat(np.arange(6), 40)
    pipe = make_pipeline(
        StandardScaler(), ANFISRegressor(n_clusters=3, epochs=15, random_state=0)
    )
    res = cross_validate(pipe, X, y, groups=groups, cv=GroupKFold(n_splits=3))
    assert res["test_score"].shape == (3,)
    assert np.all(res["test_score"] > 0.8)


def test_optuna_study(regression_data):
    optuna = pytest.importorskip("optuna")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    X, y = regression_data
    Xtr, Xte, ytr, yte = X[:160], X[160:], y[:160], y[160:]

    def objective(trial):
        init = trial.suggest_categorical("init", ["fcm", "grid"])
        model = ANFISRegressor(
            init=init,
            n_clusters=trial.suggest_int("n_clusters", 2, 4),
            n_mfs=trial.suggest_int("n_mfs", 2, 3),
            mf=trial.suggest_categorical("mf", ["gaussian", "gbell"]),
            epochs=trial.suggest_int("epochs", 5, 15),
            random_state=0,
        )
        return model.fit(Xtr, ytr).score(Xte, yte)

    study = optuna.create_study(
        direction="maximize", sampler=optuna.samplers.TPESampler(seed=0)
    )
    study.optimize(objective, n_trials=3)
    assert len(study.trials) == 3
    assert study.best_value > 0.5


def test_from_parameters_roundtrip(regression_data):
    X, y = regression_data
    model = ANFISRegressor(init="grid", epochs=10).fit(X, y)
    copy = ANFISRegressor.from_parameters(
        mf=model.mf, mf_params=model.mf_params_, consequents=model.consequents_
    )
    assert_allclose(copy.predict(X), model.predict(X))
    fcm = ANFISRegressor(n_clusters=4, epochs=5, random_state=0).fit(X, y)
    copy = ANFISRegressor.from_parameters(
        mf=fcm.mf, mf_params=fcm.mf_params_, consequents=fcm.consequents_
    )
    assert_array_equal(copy.rules_, fcm.rules_)
    assert_allclose(copy.predict(X), fcm.predict(X))
    with pytest.raises(ValueError, match="neither a grid"):
        ANFISRegressor.from_parameters(
            mf="gaussian", mf_params=np.ones((2, 3, 2)), consequents=np.ones((5, 3))
        )


# ------------------------------------------------------------------- errors


def test_grid_too_large_raises_before_allocation():
    X = np.zeros((5, 13))
    X[0] = 1.0
    with pytest.raises(ValueError, match=r"n_mfs=2 .* 13 inputs .* 8192 rules"):
        ANFISRegressor(init="grid").fit(X, np.zeros(5))
    X20 = np.random.default_rng(0).random((5, 40))
    with pytest.raises(ValueError, match=r"max_rules=4096"):
        ANFISRegressor(init="grid", n_mfs=3).fit(X20, np.zeros(5))


@pytest.mark.parametrize(
    "params, match",
    [
        ({"mf": "triangle"}, "'mf' parameter"),
        ({"init": "kmeans"}, "'init' parameter"),
        ({"learning": "lm"}, "'learning' parameter"),
        ({"step_decrease": 1.5}, "'step_decrease' parameter"),
        ({"validation_fraction": 1.0}, "'validation_fraction' parameter"),
    ],
)
def test_invalid_parameters(regression_data, params, match):
    X, y = regression_data
    with pytest.raises(ValueError, match=match):
        ANFISRegressor(**params).fit(X, y)


def test_input_errors(regression_data):
    X, y = regression_data
    Xn = X.copy()
    Xn[3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        ANFISRegressor(epochs=2).fit(Xn, y)
    model = ANFISRegressor(epochs=2).fit(X, y)
    with pytest.raises(ValueError, match="NaN"):
        model.predict(Xn)
    with pytest.raises(ValueError, match="n_clusters=3 needs at least 3"):
        ANFISRegressor().fit(X[:2], y[:2])
    with pytest.raises(ValueError, match="either validation_fraction or X_val"):
        ANFISRegressor(validation_fraction=0.2).fit(X, y, X_val=X, y_val=y)
    with pytest.raises(ValueError, match="both X_val and y_val"):
        ANFISRegressor().fit(X, y, X_val=X)
    with pytest.raises(ValueError, match="init array"):
        ANFISRegressor(init=np.ones((3, 2, 3))).fit(X, y)  # gbell params, gaussian
    with pytest.raises(ValueError, match="not contiguous"):
        ANFISRegressor(grey=True).fit(X, y, groups=np.tile([0, 1], 120))


def test_solve_consequents_primal_and_dual_agree(rng):
    A = rng.normal(size=(30, 12))
    Y = rng.normal(size=(30, 2))
    ridge = 1e-3
    lam = ridge * np.sum(A * A) / 12
    expected = np.linalg.solve(A.T @ A + lam * np.eye(12), A.T @ Y)
    assert_allclose(solve_consequents(A, Y, ridge), expected, rtol=1e-10)
    wide = A[:8]  # more columns than rows: the dual form
    lam = ridge * np.sum(wide * wide) / 12
    expected = np.linalg.solve(wide.T @ wide + lam * np.eye(12), wide.T @ Y[:8])
    assert_allclose(solve_consequents(wide, Y[:8], ridge), expected, rtol=1e-8)
    exact = np.linalg.lstsq(A, Y, rcond=None)[0]
    assert_allclose(solve_consequents(A, Y, 0.0), exact, rtol=1e-10)


def test_solve_consequents_leaves_free_columns_unshrunk(rng):
    """Free columns get the stabilising ridge only, in the primal and the
    dual form alike."""
    from skthermal.fuzzy._anfis_lsq import FREE_RIDGE

    A = rng.normal(size=(30, 12)) + 3.0
    Y = rng.normal(size=(30, 2)) + 10.0
    free = np.zeros(12, dtype=bool)
    free[-3:] = True
    ridge = 0.5
    for rows in (A, A[:8]):  # primal, then dual (more columns than rows)
        lam = ridge * np.sum(rows * rows) / 12
        D = np.where(free, lam * FREE_RIDGE / ridge, lam)
        expected = np.linalg.solve(rows.T @ rows + np.diag(D), rows.T @ Y[: len(rows)])
        got = solve_consequents(rows, Y[: len(rows)], ridge, free)
        assert_allclose(got, expected, rtol=1e-7, atol=1e-9)
        shrunk = solve_consequents(rows, Y[: len(rows)], ridge)
        assert not np.allclose(got, shrunk)


def test_one_rule_with_free_intercept_is_a_ridge_regression(rng):
    """One rule, slopes-only ridge: scikit-learn's Ridge with the same
    penalty; with the intercept shrunk too, the mean is pulled to zero."""
    from sklearn.linear_model import Ridge

    X = rng.normal(size=(200, 4))
    y = X @ [1.0, 2.0, 0.0, -1.0] + 50.0 + rng.normal(size=200)
    ridge = 0.3
    # Scale-free: the mean diagonal of the normal equations; with free
    # constant terms, of the inputs centred on their mean.
    lam = ridge * (np.sum((X - X.mean(axis=0)) ** 2) + 200) / 5
    reference = Ridge(alpha=lam).fit(X, y).predict(X)
    free = ANFISRegressor(n_clusters=1, ridge=ridge, penalize_intercepts=False)
    assert_allclose(free.fit(X, y).predict(X), reference, atol=1e-5)
    shrunk = ANFISRegressor(n_clusters=1, ridge=ridge).fit(X, y).predict(X)
    assert abs(shrunk.mean() - y.mean()) > 5.0
    assert abs(reference.mean() - y.mean()) < 1e-6


def test_free_intercepts_do_not_depend_on_an_input_offset(rng):
    # Temperatures in kelvin or far from zero: with free constant terms the
    # stabilising ridge acts on the centred inputs, so a shift changes only
    # the constant terms.
    x = np.linspace(-1, 1, 100)[:, None]
    y = 2 * x[:, 0] + 5
    free = {"penalize_intercepts": False}
    model = ANFISRegressor(n_clusters=1, epochs=1, **free).fit(x + 300, y)
    assert_allclose(model.consequents_.ravel(), [2.0, -595.0], rtol=1e-6)
    X = rng.uniform(-1, 1, (300, 2))
    y = np.sin(3 * X[:, 0]) + X[:, 1] ** 2
    near = ANFISRegressor(n_clusters=3, epochs=20, random_state=0, **free).fit(X, y)
    far = ANFISRegressor(n_clusters=3, epochs=20, random_state=0, **free)
    far.fit(X + 293, y)
    assert_allclose(far.predict(X + 293), near.predict(X), atol=1e-6)


@pytest.mark.parametrize("init", ["fcm", "grid"])
def test_free_intercepts_agree_between_the_solve_routes(rng, init):
    """The normal equations without the design matrix and the syrk route
    leave the same columns free."""
    from skthermal.fuzzy._anfis_core import _forward, _rule_matrix, _solve_transposed
    from skthermal.fuzzy._anfis_lsq import NormalEquations

    X = rng.uniform(-1, 1, size=(300, 3))
    Y = rng.normal(size=(300, 1)) + 5.0
    params = np.stack([np.full((3, 2), 0.6), np.tile([-0.5, 0.5], (3, 1))], -1)
    grid = init == "grid"
    rules = grid_rules(2, 3) if grid else grid_rules(2, 3)[:3]
    XT = np.ascontiguousarray(X.T)
    _, nu, wT = _forward(XT, params, "gaussian", _rule_matrix(rules, 2), grid)
    X1T = _with_ones(X).T
    n_rules = rules.shape[0]
    free = np.zeros(4 * n_rules, dtype=bool)
    free[3 * n_rules :] = True
    AT = (X1T[:, None, :] * wT[None]).reshape(-1, 300)
    expected = _solve_transposed(AT, Y.T, 0.1, free)
    normal = NormalEquations(X1T, np.ascontiguousarray(Y.T), rules, 2, grid)
    got = normal.solve(wT, nu, 0.1, free)
    assert_allclose(got, expected, rtol=1e-8, atol=1e-10)
    shrunk = _solve_transposed(AT, Y.T, 0.1)
    assert not np.allclose(got, shrunk)


def test_fcm_rules_beat_a_243_rule_grid_on_simulated_machine_b():
    """000's finding on the simulated campaign: trained on Test IV, ANFIS-FCM
    with 3 rules predicts the held-out Tests I, II, III, V, VI better than
    ANFIS-Grid with 3 MFs on 5 inputs (243 rules)."""
    from skthermal import FCMClusterPicker
    from skthermal.datasets import make_machine_b_tests, split_runs

    runs = make_machine_b_tests(sample_period_s=60.0, random_state=0)
    X, y, groups = split_runs(runs, targets="disp_y_um")
    train = groups == "IV"
    picker = FCMClusterPicker(n_clusters=5, random_state=0).fit(X[train], y[train])
    Xs = picker.transform(X)
    fcm = ANFISRegressor(init="fcm", n_clusters=3, epochs=30, random_state=0)
    grid = ANFISRegressor(init="grid", n_mfs=3, mf="gbell", epochs=10)
    scores = {}
    for name, est in (("fcm", fcm), ("grid", grid)):
        est.fit(Xs[train], y[train])
        errors = []
        for run in ("I", "II", "III", "V", "VI"):
            held = groups == run
            z, p = y[held].to_numpy(), est.predict(Xs[held])
            errors.append(np.sqrt(np.mean(((z - z[0]) - (p - p[0])) ** 2)))
        scores[name] = np.mean(errors)
    assert grid.n_rules_ == 243 and fcm.n_rules_ == 3
    assert scores["fcm"] < 5.0
    assert scores["fcm"] < scores["grid"]


# ------------------------------------------------- fast path, ridge, runs


def test_normal_equations_match_the_design_matrix(rng):
    """The training loop's transposed Gram (syrk) solves the same system as
    the plain design matrix."""
    from skthermal.fuzzy._anfis_core import _design, _solve_transposed

    X = rng.uniform(-1, 1, size=(200, 3))
    Y = rng.normal(size=(200, 2))
    params = np.stack([np.full((3, 2), 0.6), np.tile([-0.5, 0.5], (3, 1))], -1)
    rules = grid_rules(2, 3)
    wbar = _normalised_firing(X, params, rules, "gaussian")
    A = _design(wbar, _with_ones(X))  # columns (rule, input)
    expected = solve_consequents(A, Y, 1e-6)
    AT = (_with_ones(X).T[:, None, :] * wbar.T[None]).reshape(-1, 200)
    theta = _solve_transposed(AT, Y.T, 1e-6)  # columns (input, rule)
    got = theta.reshape(4, 8, 2).transpose(1, 0, 2).reshape(32, 2)
    assert_allclose(got, expected, rtol=1e-8, atol=1e-10)


def test_ridge_auto_picks_from_the_grid_by_time_ordered_checking(rng):
    X = rng.normal(size=(300, 6))
    X[:, 1:] = X[:, :1] + 0.01 * rng.normal(size=(300, 5))  # collinear inputs
    y = X[:, 0] + 0.3 * rng.normal(size=300)
    grid = (1e-8, 1e-2, 1.0)
    model = ANFISRegressor(ridge="auto", ridge_grid=grid, epochs=5, random_state=0)
    model.fit(X, y)
    assert set(model.ridge_scores_) == set(grid)
    assert model.ridge_ == min(model.ridge_scores_, key=model.ridge_scores_.get)
    # The final model is the refit with the chosen ridge on all rows.
    same = ANFISRegressor(ridge=model.ridge_, epochs=5, random_state=0).fit(X, y)
    assert_allclose(model.predict(X), same.predict(X))
    # With a checking set, the chosen candidate's fit is kept as it is.
    checked = ANFISRegressor(ridge="auto", ridge_grid=grid, epochs=5, random_state=0)
    checked.fit(X[:200], y[:200], X_val=X[200:], y_val=y[200:])
    assert checked.ridge_ in grid
    assert checked.history_["val_rmse"].min() == pytest.approx(
        checked.ridge_scores_[checked.ridge_]
    )
    with pytest.raises(ValueError, match="ridge_grid"):
        ANFISRegressor(ridge="auto", ridge_grid=[-1.0]).fit(X, y)
    with pytest.raises(ValueError, match="ridge='auto'"):
        ANFISRegressor(ridge="auto", n_clusters=1).fit(X[:2], y[:2])


def test_a_larger_ridge_shrinks_the_consequents(rng):
    X = rng.normal(size=(200, 5))
    X[:, 1:] = X[:, :1] + 1e-3 * rng.normal(size=(200, 4))
    y = X[:, 0] + 0.1 * rng.normal(size=200)
    norms = [
        np.abs(
            ANFISRegressor(ridge=r, epochs=3, random_state=0).fit(X, y).consequents_
        ).max()
        for r in (1e-10, 1e-2, 1.0)
    ]
    assert norms[0] > norms[1] > norms[2]


def _timed_runs(rng):
    table = _runs_table(rng, n_runs=2)
    table["time_s"] = table.groupby("run").cumcount() * 10.0
    table = table.set_index(["run", "time_s"])
    return table[["T1", "T2"]], table["err"]


def test_time_going_backwards_within_a_run_raises(rng):
    X, y = _timed_runs(rng)
    index = X.index.to_frame(index=False)
    index.loc[5, "time_s"] = 20.0  # row 5 after time 40
    bad = X.set_axis(pd.MultiIndex.from_frame(index))
    with pytest.raises(ValueError, match=r"time_s must increase.*run 'r0'.*row 5"):
        ANFISRegressor(grey=True, epochs=2).fit(bad, y)
    with pytest.raises(ValueError, match="time_s must increase"):
        ANFISRegressor(validation_fraction=0.2, epochs=2).fit(bad, y)
    model = ANFISRegressor(grey=True, epochs=2, random_state=0).fit(X, y)
    with pytest.raises(ValueError, match="time_s must increase"):
        model.predict(bad)
    # A static model reads rows independently: no order is needed.
    ANFISRegressor(epochs=2, random_state=0).fit(bad, y)


def test_grey_model_warns_when_predict_gets_no_run_labels(rng):
    X, y = _timed_runs(rng)
    model = ANFISRegressor(grey=True, epochs=2, random_state=0).fit(X, y)
    with pytest.warns(UserWarning, match="fitted on 2 labelled run"):
        model.predict(X.to_numpy())
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(X)
        ANFISRegressor(grey=True, epochs=2).fit(X.to_numpy(), y).predict(X.to_numpy())


@pytest.mark.parametrize("mf", ["gaussian", "gbell"])
@pytest.mark.parametrize("init", ["fcm", "grid"])
def test_far_inputs_give_finite_convex_outputs(regression_data, mf, init):
    """One sensor at 1e6, 1e100, 1e150 or 1e300: the firing strengths stay a
    convex combination (no 0/0), and the output (up to the largest magnitude
    a reading may have, 1e100; beyond it predict refuses the reading) that
    of the rules' linear models at that input (ANFIS extrapolates linearly;
    it does not clip)."""
    X, y = regression_data
    model = ANFISRegressor(init=init, mf=mf, epochs=5, random_state=0).fit(X, y)
    for value in (1e6, -1e6, 1e100, -1e100, 1e150, 1e300):
        far = X[:4].copy()
        far[:, 1] = value
        if abs(value) > 1e100:
            with pytest.raises(ValueError, match="Column 1 of X is 1e"):
                model.predict(far)
            predicted = False
        else:
            pred = model.predict(far)
            predicted = True
        rule_out = far @ model.consequents_[:, :3].T + model.consequents_[:, 3]
        if predicted and np.all(np.isfinite(rule_out)):
            assert np.all(np.isfinite(pred))
            tol = 1e-9 * np.abs(rule_out).max(axis=1)
            assert np.all(pred >= rule_out.min(axis=1) - tol)
            assert np.all(pred <= rule_out.max(axis=1) + tol)
        wbar = _normalised_firing(far, model.mf_params_, model.rules_, mf)
        assert np.all(np.isfinite(wbar))
        assert_allclose(wbar.sum(axis=1), 1.0)


def test_from_parameters_and_auto_ridge_name_bad_input(rng):
    kw = {
        "mf": "gaussian",
        "mf_params": [[[1.0, 0.0], [1.0, 1.0]]],
        "rules": [[0], [1]],
    }
    with pytest.raises(ValueError, match="consequents must be finite"):
        ANFISRegressor.from_parameters(consequents=[[np.nan, 0], [0, 1]], **kw)
    with pytest.raises(ValueError, match="'epochs' parameter"):
        ANFISRegressor.from_parameters(consequents=[[0.0, 0], [0, 1]], epochs=-3, **kw)
    X = rng.normal(size=(3, 2))
    with pytest.raises(ValueError, match="3 samples leave only 1 there"):
        ANFISRegressor(ridge="auto").fit(X, X.sum(axis=1))


def test_backprop_does_not_depend_on_an_offset_of_the_inputs():
    # Readings around 20 °C or in kelvin: the consequents' steps are taken on
    # centred inputs, so the fit is the one of the centred data (it was the
    # initial constant model, its error rising every epoch).
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 2))
    y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2
    fits = [
        ANFISRegressor(learning="backprop", epochs=30, random_state=0).fit(X + off, y)
        for off in (0.0, 20.0, 300.0)
    ]
    base = fits[0].predict(X)
    assert fits[0].score(X, y) > 0.95
    for off, model in zip((20.0, 300.0), fits[1:], strict=True):
        np.testing.assert_allclose(model.predict(X + off), base, atol=1e-6)


@pytest.mark.parametrize("init", ["fcm", "grid"])
def test_an_input_constant_in_training_moves_no_prediction(init):
    # A sensor stuck throughout training: taken as given it was a second
    # constant term, and the consequents' least squares gave it a slope the
    # data never set (the stuck sensor reading 1 K more moved a grid ANFIS
    # by -34 um on a target spanning 0-59 um).
    rng = np.random.default_rng(0)
    X = np.c_[rng.uniform(0, 5, (300, 2)), np.full(300, 20.0)]
    y = 4.0 * X[:, 0] + np.sin(X[:, 1])
    model = ANFISRegressor(init=init, n_clusters=3, epochs=10, random_state=0)
    model.fit(X, y)
    assert model.score(X, y) > 0.9
    moved = X.copy()
    moved[:, 2] += 1.0
    np.testing.assert_allclose(model.predict(moved), model.predict(X), atol=1e-6)


def test_backprop_does_not_depend_on_the_target_unit():
    # A target in nanometres instead of micrometres (or a larger machine):
    # the normalised step moved the consequents in the target's units, so
    # a target spread over 1000 learned almost nothing (training RMSE 13.4
    # and 14.1 um against 1.3 on a target of std 14), without a warning.
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 2))
    y = 15.0 * (np.sin(2 * X[:, 0]) + X[:, 1] ** 2)
    fits = {
        s: ANFISRegressor(learning="backprop", epochs=30, random_state=0).fit(X, y * s)
        for s in (1.0, 1e-3, 1e3)
    }
    base = fits[1.0].predict(X)
    assert fits[1.0].score(X, y) > 0.95
    for s in (1e-3, 1e3):
        np.testing.assert_allclose(fits[s].predict(X) / s, base, rtol=1e-6, atol=1e-6)


def test_backprop_learns_from_inputs_of_a_wide_spread():
    # Scaled by the target's spread alone, the slopes of inputs spread over
    # 100 (grey=True's accumulated readings, readings in other units)
    # overshot: a grey backprop fit of 20 epochs kept its initial model
    # (training RMSE 101.6 um, target std 13.6 um).
    from sklearn.exceptions import ConvergenceWarning

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (300, 2))
    y = 15.0 * (np.sin(2 * X[:, 0]) + X[:, 1] ** 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        wide = ANFISRegressor(learning="backprop", epochs=20, random_state=0)
        wide.fit(100.0 * X, y)
    assert wide.best_epoch_ > 10
    assert wide.score(100.0 * X, y) > 0.8


def test_backprop_that_never_improves_warns():
    from sklearn.exceptions import ConvergenceWarning

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 2))  # steps of 50 on inputs spanning 2
    y = np.sin(2 * X[:, 0])
    with pytest.warns(ConvergenceWarning, match="never improved on its initial"):
        model = ANFISRegressor(learning="backprop", epochs=10, step_size=50.0)
        model.fit(X, y)


def test_a_least_squares_of_gigabytes_warns(monkeypatch):
    # 4096 rules on 6 inputs passed max_rules and took 52 s and 5.7 GB per
    # epoch on 10,000 rows without a word; the threshold is lowered here to
    # keep the test small (16 rules x 3 consequents on 300 rows).
    import skthermal.fuzzy._anfis as anfis

    monkeypatch.setattr(anfis, "_LARGE_PROBLEM", 10_000)
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (300, 2))
    with pytest.warns(UserWarning, match=r"16 rules x 3 consequents = 48 unknowns"):
        ANFISRegressor(init="grid", n_mfs=4, epochs=1).fit(X, X.sum(axis=1))


def test_more_consequents_than_rows_warns_unless_a_ridge_fixes_them():
    # 32 rules x 6 consequents on 160 rows: the data do not fix them, and
    # the same rows in another order gave predictions 0.1-0.2 apart on a
    # range of 20, without a word.
    rng = np.random.default_rng(0)
    X = rng.normal(size=(160, 5))
    y = X @ np.arange(1.0, 6.0)
    grid = ANFISRegressor(init="grid", n_mfs=2, epochs=2, random_state=0)
    with pytest.warns(UserWarning, match=r"192 unknowns on 160 training rows"):
        clone(grid).fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        clone(grid).set_params(ridge=1e-2).fit(X, y)
        clone(grid).fit(np.r_[X, X[:40] + 0.1], np.r_[y, y[:40]])  # 200 rows
    # ridge="auto" is judged by the ridge it picks.
    auto = clone(grid).set_params(ridge="auto", ridge_grid=(1e-8,))
    with pytest.warns(UserWarning, match=r"ridge='auto' picked 1e-08 from ridge_gr"):
        auto.fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        auto.set_params(ridge_grid=(1e-2,)).fit(X, y)


@pytest.mark.parametrize(
    "rules, message",
    [
        ([[0], [5]], r"rules\[1, 0\] is 5: every entry must be the index"),
        ([[0.0], [1.5]], r"rules\[1, 0\] is 1.5: every entry"),
        ([[0], [-1]], r"rules\[1, 0\] is -1: every entry"),
        ([[0, 1], [1, 0]], r"rules must have shape \(2, 1\).*got shape \(2, 2\)"),
    ],
)
def test_from_parameters_names_a_bad_rule_entry(rules, message):
    mfs = np.array([[[1.0, 0.0], [1.0, 1.0]]])
    cons = np.zeros((2, 2))
    with pytest.raises(ValueError, match=message):
        ANFISRegressor.from_parameters(
            mf="gaussian", mf_params=mfs, consequents=cons, rules=rules
        )


@pytest.mark.parametrize("grid", [False, True])
def test_training_firing_strengths_hold_no_subnormal_numbers(grid):
    # Many inputs, each rule far from most samples: products of firing
    # strengths in the normal equations were subnormal, and the Cholesky
    # factorisation ran 50 times slower on them (300 sensors: 62 s -> 8 s).
    rng = np.random.default_rng(0)
    d = 6 if grid else 60
    X = rng.normal(size=(200, d))
    if grid:
        mf_params = grid_mf_params(X, 2, "gaussian")
        mf_params[..., 0] /= 20.0  # narrow functions: tiny memberships
        rules = grid_rules(2, d)
    else:
        mf_params, rules = fcm_mf_params(X, 3, "gaussian", random_state=0)
    E = _rule_matrix(rules, mf_params.shape[1])
    _, nu, wT = _forward(np.ascontiguousarray(X.T), mf_params, "gaussian", E, grid)
    for a in (wT,) if nu is None else (wT, nu):
        assert not np.any((a > 0) & (a < 1e-100))
    np.testing.assert_allclose(wT.sum(axis=0), 1.0)


def test_a_step_far_beyond_an_inputs_span_warns():
    # The premise step is in the inputs' units: on inputs spanning 1e-5 the
    # membership functions jumped off the data (train R^2 0.99 -> 0.79).
    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 2))
    y = np.sin(X[:, 0]) + X[:, 1]
    with pytest.warns(
        UserWarning, match=r"input 'x1' spans only 2.93e-05.*StandardScaler"
    ):
        ANFISRegressor(epochs=2, random_state=0).fit(X * 5e-6, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ANFISRegressor(epochs=2, random_state=0).fit(X, y)


def test_a_function_collapsed_among_others_is_reported():
    # One function collapsed while the others went on: its rules fired
    # nowhere from then on, without a word (half of the collapses of 290
    # fits of real and simulated records; the warning came only when one
    # rule was left).
    from sklearn.exceptions import ConvergenceWarning

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 3))
    y = np.sin(3 * X[:, 0]) * X[:, 1] + X[:, 2] ** 2 + rng.normal(0, 0.05, 200)
    model = ANFISRegressor(n_clusters=4, epochs=40, random_state=0)
    with pytest.warns(ConvergenceWarning) as record:
        model.fit(X, y)
    said = [str(w.message) for w in record if "collapsed" in str(w.message)]
    assert len(said) == 1, said
    assert re.search(
        r"the premise step of epoch 19 collapsed a membership function .* the "
        r"rules it takes part in fire nowhere from then on, and the (model|"
        r"parameters) kept \(best epoch \d+\)",
        said[0],
    )
    assert record[0].filename == __file__  # the user's line
    floor = 1e-6 * np.ptp(X, axis=0)
    collapsed_kept = np.any(model.mf_params_[..., 0] <= floor[:, None])
    assert collapsed_kept == ("fewer working rules" in said[0])


def test_a_collapsed_membership_function_is_reported():
    """A premise step that collapses a width onto its floor leaves no
    gradient: training says so, and keeps the best epoch's parameters."""
    from sklearn.exceptions import ConvergenceWarning

    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (200, 2))
    y = np.sin(3 * X[:, 0]) * X[:, 1] + rng.normal(0, 0.05, 200)
    model = ANFISRegressor(n_clusters=2, epochs=20, random_state=0)
    with pytest.warns(
        ConvergenceWarning, match=r"premise training stopped after epoch 3 of 20"
    ) as record:
        model.fit(X, y)
    assert record[0].filename == __file__  # the user's line
    rmse = model.history_["train_rmse"]
    assert np.all(rmse[3:] == rmse[2])  # the epochs after the collapse repeat
    assert model.best_epoch_ == 2 and rmse[1] < rmse[2]
    # With a smaller step the widths survive, and nothing is said; nor with
    # one rule, whose premise has no gradient at all.
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        model.set_params(step_size=0.1).fit(X, y)
        ANFISRegressor(n_clusters=1, epochs=5).fit(X, y)
        ANFISRegressor(init="grid", n_mfs=1, epochs=5).fit(X, y)


def test_inputs_of_very_different_spans_warn():
    rng = np.random.default_rng(0)
    X = np.c_[rng.uniform(0, 5000, 200), rng.uniform(20, 23, 200)]
    y = X[:, 1] + X[:, 0] / 1000
    model = ANFISRegressor(n_clusters=2, epochs=3, random_state=0)
    with pytest.warns(UserWarning, match=r"spans differ by a factor of 1.\d+e\+03"):
        model.fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.fit(X / [1000.0, 1.0], y)  # speed in krpm: comparable spans


def test_grey_anfis_is_told_to_scale_without_centring():
    # grey=True accumulates the inputs: a StandardScaler in front (the advice
    # for plain ANFIS) centres them, and centred readings accumulate into
    # drifting sums (an independent check: new-run RMSE 373 µm instead of
    # 34 unscaled; 7 with a MaxAbsScaler).
    rng = np.random.default_rng(0)
    X = np.c_[rng.uniform(0, 5000, 200), rng.uniform(20, 23, 200)]
    y = np.cumsum(X[:, 1] - 20 + X[:, 0] / 1000) / 50
    model = ANFISRegressor(n_clusters=2, epochs=3, grey=True, random_state=0)
    with pytest.warns(UserWarning, match=r"without centring them") as record:
        model.fit(X, y)
    assert not any("Standardise" in str(w.message) for w in record)


def test_grey_anfis_warns_of_centred_inputs():
    # Centred (standardised) readings accumulate into running sums that turn
    # back: an independent check got training R^2 -215 without a word, 1.0
    # on the same readings as changes since the run start.
    rng = np.random.default_rng(0)
    t = np.arange(200.0)
    T = np.c_[5 * (1 - np.exp(-t / 50)), 3 * (1 - np.exp(-t / 80))]
    T += rng.normal(0, 0.02, T.shape)
    y = 3 * T[:, 0] + T[:, 1]
    centred = (T - T.mean(axis=0)) / T.std(axis=0)
    model = ANFISRegressor(grey=True, epochs=10, random_state=0)
    with pytest.warns(
        UserWarning, match=r"input 'x1' \(and 1 more\) is centred on zero"
    ):
        model.fit(centred, y)
    assert model.score(centred, y) < 0  # what the warning is about
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.fit(T, y)  # changes since the run start: no warning
        assert model.score(T, y) > 0.99
        # one signed input among others (a feed's direction) is no cause
        feed = np.where((t // 20) % 2 == 0, 1.0, -1.0)
        model.fit(np.c_[T, T[:, :1], feed], y)


def test_grey_anfis_warns_of_readings_with_an_offset():
    # Absolute readings accumulate into a ramp in time: an independent check
    # got 54-77 µm held out with free intercepts on °C or kelvin readings (3
    # µm on changes since the run start, 16 for predicting zero) without a
    # word.
    t = np.tile(np.arange(100.0), 3)
    level = np.repeat([1.0, 0.6, 1.4], 100)[:, None]
    T = level * np.c_[5 * (1 - np.exp(-t / 30)), 3 * (1 - np.exp(-t / 50))]
    y = 3 * T[:, 0] + T[:, 1]
    groups = np.repeat([0, 1, 2], 100)
    model = ANFISRegressor(
        grey=True, epochs=10, penalize_intercepts=False, random_state=0
    )
    with pytest.warns(
        UserWarning,
        match=r"input 'x2' \(and 1 more\) starts its runs at 29\d \(median over "
        r"the runs\) and moves .* within a run: readings with an offset",
    ):
        model.fit(T + 293.15, y, groups=groups)
    kelvin = r2_score(y, model.predict(T + 293.15, groups=groups))
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.fit(T, y, groups=groups)  # changes since the run start
    assert r2_score(y, model.predict(T, groups=groups)) > max(kelvin, 0.9)
    # A speed beside a temperature change is a heat input, not an offset.
    X = pd.DataFrame({"spindle_rpm": 3.0, "T1_C": T[:, 0]})  # krpm
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.fit(X, y, groups=groups)


def test_a_step_far_too_small_for_the_inputs_warns():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (200, 2))
    y = np.sin(X[:, 0])
    model = ANFISRegressor(n_clusters=2, epochs=3, random_state=0)
    with pytest.warns(UserWarning, match=r"the membership functions will barely move"):
        model.fit(X * 1e6, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        model.fit(X * 1e3, y)  # a step of 0.5 in units of 1e3: still moves
