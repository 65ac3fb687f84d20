"""Tests of skthermal.model_selection: search spaces, run_search, storages and
searches shared by several worker processes (SQLite, journal file and, when
SKTHERMAL_TEST_POSTGRES_URL is set, PostgreSQL)."""

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
import uuid
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.base import clone
from sklearn.metrics import make_scorer, mean_squared_error
from sklearn.model_selection import GroupKFold
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import InvalidParameterError, StrOptions

optuna = pytest.importorskip("optuna")

from skthermal import (  # noqa: E402
    ANFISRegressor,
    FCMClusterPicker,
    GNNMCIRegressor,
    GreyPSORegressor,
)
from skthermal.datasets import make_sensor_groups, split_runs  # noqa: E402
from skthermal.model_selection import (  # noqa: E402
    SearchResult,
    combine_spaces,
    fail_stale_trials,
    make_storage,
    run_search,
    search_space,
    search_space_names,
)

WORKER = Path(__file__).with_name("_search_worker.py")
POSTGRES_URL = os.environ.get("SKTHERMAL_TEST_POSTGRES_URL")
COMPLETE = optuna.trial.TrialState.COMPLETE
FAIL = optuna.trial.TrialState.FAIL
PRUNED = optuna.trial.TrialState.PRUNED


@pytest.fixture(autouse=True)
def _quiet_optuna():
    level = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    yield
    optuna.logging.set_verbosity(level)


@pytest.fixture(scope="module")
def runs_data():
    runs, _ = make_sensor_groups(
        n_groups=2,
        sensors_per_group=2,
        n_noise=1,
        n_runs=3,
        n_samples=50,
        random_state=0,
    )
    return split_runs(runs)


def _small_anfis_space(**overrides):
    ranges = {"init": "fcm", "n_clusters": (2, 3), "epochs": (3, 6), **overrides}
    return search_space("anfis", **ranges)


# --------------------------------------------------------------- spaces


def test_search_space_names_and_errors():
    assert search_space_names() == ["anfis", "fcm_picker", "gnnmci", "grey_pso"]
    with pytest.raises(ValueError, match="Unknown search space 'svm'"):
        search_space("svm")
    with pytest.raises(ValueError, match=r"no parameter\(s\) \['depth'\]"):
        search_space("anfis", depth=(1, 2))
    with pytest.raises(ValueError, match="numeric"):
        search_space("anfis", epochs=[10, 20])
    with pytest.raises(ValueError, match="low must not exceed high"):
        search_space("anfis", epochs=(20, 10))
    # The other rule base's size did nothing, silently.
    with pytest.raises(ValueError, match=r"init='grid' draws n_mfs, not n_clusters"):
        search_space("anfis", init="grid", n_clusters=(2, 4))
    with pytest.raises(ValueError, match=r"init='fcm' draws n_clusters, not n_mfs"):
        search_space("anfis", init="fcm", n_mfs=3)
    search_space("anfis", init=["fcm", "grid"], n_clusters=(2, 4), n_mfs=2)
    # A whole-number parameter's range with a fractional bound drew values
    # outside it ((2.5, 4) drew 2), silently; whole floats are whole.
    with pytest.raises(ValueError, match=r"n_clusters is a whole number.*\(2\.5, 4\)"):
        search_space("anfis", n_clusters=(2.5, 4))
    search_space("anfis", n_clusters=(2.0, 4))
    with pytest.raises(ValueError, match="prefix"):
        search_space("anfis", prefix="")


@pytest.mark.parametrize(
    "name, estimator",
    [
        ("anfis", ANFISRegressor()),
        ("grey_pso", GreyPSORegressor()),
        ("gnnmci", GNNMCIRegressor()),
        ("fcm_picker", FCMClusterPicker()),
    ],
)
def test_builtin_spaces_draw_valid_parameters(name, estimator):
    space = search_space(name)
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for _ in range(20):
        trial = study.ask()
        params = space(trial)
        est = clone(estimator).set_params(**params)
        est._validate_params()  # every draw satisfies the constraints
        # Replaying the trial's Optuna parameters gives the same estimator params.
        assert space(optuna.trial.FixedTrial(trial.params)) == params
        study.tell(trial, 0.0)


def test_space_conditional_and_fixed_parameters():
    grid = search_space("anfis", init="grid")(
        optuna.trial.FixedTrial(
            {"mf": "gbell", "n_mfs": 3, "epochs": 12, "step_size": 0.1}
        )
    )
    assert grid == {
        "init": "grid",
        "mf": "gbell",
        "n_mfs": 3,
        "epochs": 12,
        "step_size": 0.1,
    }
    ls = search_space("grey_pso")(
        optuna.trial.FixedTrial({"calibration": "ls", "alpha": 0.1, "delay": 1})
    )
    assert ls == {"calibration": "ls", "alpha": 0.1, "delay": 1}
    # A swarm is searched only when asked for, and then not from the
    # variable-projection optimum, where its settings would change nothing.
    pso = search_space("grey_pso", calibration="pso", n_particles=20, delay=0)(
        optuna.trial.FixedTrial(
            {
                "alpha": 1.0,
                "init": "random",
                "epochs": 50,
                "c1": 1.0,
                "c2": 2.0,
                "inertia_start": 0.9,
                "inertia_end": 0.4,
            }
        )
    )
    assert pso["inertia"] == (0.9, 0.4) and pso["n_particles"] == 20
    assert pso["init"] == "random" and pso["delay"] == 0


def test_prefixed_and_combined_spaces():
    space = combine_spaces(
        search_space("fcm_picker", prefix="fcmclusterpicker", scorer="pearson"),
        search_space("anfis", prefix="anfisregressor", init="fcm"),
    )
    params = space(optuna.create_study().ask())
    assert set(params) == {
        "fcmclusterpicker__n_clusters",
        "fcmclusterpicker__scorer",
        "anfisregressor__init",
        "anfisregressor__mf",
        "anfisregressor__n_clusters",
        "anfisregressor__epochs",
        "anfisregressor__step_size",
    }
    make_pipeline(FCMClusterPicker(), ANFISRegressor()).set_params(**params)
    clash = combine_spaces(search_space("anfis"), search_space("anfis"))
    with pytest.raises(ValueError, match="clash"):
        clash(optuna.create_study().ask())


@pytest.mark.parametrize("given", ["dict", "inferred"])
def test_steps_that_name_a_parameter_alike_draw_it_apart(given):
    # A space per step (a dict, or inferred for space=None) asked Optuna for
    # the picker's and ANFIS's "n_clusters" under one name, so both always
    # got the same value (99 of 99 draws in an independent check).
    from skthermal.model_selection._search import _resolve_space

    pipe = make_pipeline(FCMClusterPicker(), ANFISRegressor())
    space = _resolve_space(
        {"fcmclusterpicker": "fcm_picker", "anfisregressor": "anfis"}
        if given == "dict"
        else None,
        pipe,
    )
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    pairs = []
    for _ in range(40):
        trial = study.ask()
        params = space(trial)
        study.tell(trial, 0.0)
        if "anfisregressor__n_clusters" in params:
            pairs.append(
                (
                    params["fcmclusterpicker__n_clusters"],
                    params["anfisregressor__n_clusters"],
                )
            )
        assert set(trial.params) == set(params)  # named as the steps
    assert len(pairs) > 10 and sum(a != b for a, b in pairs) > len(pairs) / 2


def test_a_log_range_from_zero_is_refused_early():
    with pytest.raises(ValueError, match="alpha is searched on a log scale"):
        search_space("grey_pso", alpha=(0, 100))


# ------------------------------------------------- ANFIS epoch callback


@pytest.mark.parametrize(
    "params",
    [{}, {"validation_fraction": 0.25}, {"grey": True}, {"learning": "backprop"}],
)
def test_anfis_epoch_callback(params):
    import pickle

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(120, 2))
    y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2
    plain = ANFISRegressor(epochs=12, random_state=0, **params).fit(X, y)
    calls = []
    watched = ANFISRegressor(
        epochs=12, random_state=0, epoch_callback=lambda *a: calls.append(a), **params
    ).fit(X, y)
    # A callback that never stops changes nothing.
    assert np.array_equal(watched.predict(X), plain.predict(X))
    assert watched.best_epoch_ == plain.best_epoch_
    assert watched.history_.keys() == plain.history_.keys()
    assert [c[0] for c in calls] == list(range(1, 13))
    assert_allclose([c[1] for c in calls], plain.history_["train_rmse"], rtol=1e-10)
    checks = [c[2] for c in calls]
    if "val_rmse" in plain.history_:
        assert_allclose(checks, plain.history_["val_rmse"], rtol=1e-10)
    else:
        assert checks == [None] * 12
    # Returning True stops after that epoch, keeping the best epoch so far.
    stopped = ANFISRegressor(
        epochs=12, random_state=0, epoch_callback=lambda e, t, c: e == 5, **params
    ).fit(X, y)
    assert stopped.n_iter_ == 5
    for key, values in stopped.history_.items():
        assert_allclose(values, plain.history_[key][:5], rtol=1e-10)
    monitored = plain.history_.get("val_rmse", plain.history_["train_rmse"])[:5]
    assert stopped.best_epoch_ == 1 + int(np.argmin(monitored))
    # clone keeps the callback; pickling drops it.
    assert clone(watched).epoch_callback is watched.epoch_callback
    restored = pickle.loads(pickle.dumps(watched))
    assert restored.epoch_callback is None
    assert np.array_equal(restored.predict(X), watched.predict(X))


# ----------------------------------------------------------- run_search


def test_run_search_in_memory(runs_data):
    X, y, groups = runs_data
    result = run_search(
        ANFISRegressor(random_state=0),
        X,
        y,
        groups=groups,
        space=_small_anfis_space(),
        n_trials=4,
        cv=GroupKFold(n_splits=3),
        random_state=0,
    )
    assert isinstance(result, SearchResult)
    study = result.study
    assert [t.state for t in study.trials] == [COMPLETE] * 4
    best = result.best_trial_
    assert result.best_score_ == study.best_value == best.value
    assert result.best_params_["init"] == "fcm"
    assert (
        result.best_estimator_.get_params()["epochs"] == result.best_params_["epochs"]
    )
    assert len(best.user_attrs["fold_scores"]) == 3
    assert best.user_attrs["worker_pid"] == os.getpid()
    # A seeded search's result (its study and sampler too) pickles, and the
    # restored study draws on as the original would.
    import pickle

    restored = pickle.loads(pickle.dumps(result))
    assert restored.best_params_ == result.best_params_
    assert type(restored.study.sampler) is type(study.sampler)
    assert_allclose(np.mean(best.user_attrs["fold_scores"]), best.value)
    # The objective is the mean over run-wise folds of the scorer, as cross_validate.
    from sklearn.model_selection import cross_validate

    from skthermal.metrics import get_scorer

    est = ANFISRegressor(random_state=0).set_params(**result.best_params_)
    cv = cross_validate(
        est, X, y, groups=groups, cv=GroupKFold(3), scoring=get_scorer("neg_rmse")
    )
    assert_allclose(cv["test_score"].mean(), best.value)
    frame = result.trials_dataframe()
    assert len(frame) == 4 and "user_attrs_worker_pid" in frame
    assert "n_trials=4" in repr(result)


def test_more_folds_than_runs_is_refused_naming_both(runs_data):
    X, y, _ = runs_data  # 3 runs
    with pytest.raises(
        ValueError,
        match=r"cv=4 asks for more folds than there "
        r"are runs \(3\)",
    ):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            n_trials=1,
            cv=4,
        )


def test_a_splitter_that_ignores_runs_is_not_told_about_them(runs_data):
    from sklearn.model_selection import TimeSeriesSplit

    X, y, _ = runs_data  # the run labels are in X's index, not given
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            n_trials=1,
            cv=TimeSeriesSplit(2),
            refit=False,
        )


def test_run_search_groups_from_index_and_scorer_names(runs_data):
    X, y, _ = runs_data
    for scoring in ("nse", "r2"):
        result = run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            n_trials=2,
            scoring=scoring,
            refit=False,
            random_state=0,
        )
        assert result.best_estimator_ is None
        # groups from the run level of the index: 3 runs -> 3 folds
        assert len(result.best_trial_.user_attrs["fold_scores"]) == 3


def test_run_search_pipeline_spaces(runs_data):
    X, y, groups = runs_data
    pipe = make_pipeline(
        FCMClusterPicker(n_init=2, random_state=0), ANFISRegressor(random_state=0)
    )
    result = run_search(
        pipe,
        X,
        y,
        groups=groups,
        space={
            "fcmclusterpicker": search_space(
                "fcm_picker", n_clusters=(2, 3), scorer="pearson"
            ),
            "anfisregressor": _small_anfis_space(),
        },
        n_trials=2,
        random_state=0,
    )
    assert set(result.best_params_) == {
        "fcmclusterpicker__n_clusters",
        "fcmclusterpicker__scorer",
        "anfisregressor__init",
        "anfisregressor__mf",
        "anfisregressor__n_clusters",
        "anfisregressor__epochs",
        "anfisregressor__step_size",
    }
    fitted = result.best_estimator_.named_steps["fcmclusterpicker"]
    assert fitted.n_clusters == result.best_params_["fcmclusterpicker__n_clusters"]


def test_default_space_is_inferred_for_pipelines():
    from skthermal.model_selection._search import _resolve_space

    space = _resolve_space(None, make_pipeline(FCMClusterPicker(), ANFISRegressor()))
    params = space(optuna.create_study().ask())
    assert {k.split("__")[0] for k in params} == {"fcmclusterpicker", "anfisregressor"}
    from sklearn.linear_model import Ridge

    with pytest.raises(ValueError, match="No built-in search space for Ridge"):
        _resolve_space(None, Ridge())


class _PruneAfterStep:
    """Prunes every trial but the first as soon as it reports step ``step``."""

    def __init__(self, step):
        self.step = step

    def prune(self, study, trial):
        return trial.number > 0 and max(trial.intermediate_values) >= self.step


def _pruner(step):
    return type("P", (_PruneAfterStep, optuna.pruners.BasePruner), {})(step)


@pytest.mark.parametrize("validation_fraction", [None, 0.25])
def test_anfis_epoch_pruning(runs_data, validation_fraction):
    X, y, groups = runs_data
    est = make_pipeline(ANFISRegressor(random_state=0))
    est.set_params(anfisregressor__validation_fraction=validation_fraction)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_search(
            est,
            X,
            y,
            groups=groups,
            space={"anfisregressor": _small_anfis_space(epochs=5)},
            n_trials=3,
            pruner=_pruner(2),
            random_state=0,
        )
    # Pruned by the training error: said once per search.
    training = [w for w in caught if "by its training RMSE" in str(w.message)]
    assert len(training) == (validation_fraction is None)
    first, *others = result.study.trials
    assert first.state == COMPLETE
    assert sorted(first.intermediate_values) == [1, 2, 3, 4, 5]
    for trial in others:
        assert trial.state == PRUNED
        assert sorted(trial.intermediate_values) == [1, 2]
    # The reports are the negated monitored error of the first fold's model.
    train, _ = next(GroupKFold(n_splits=3).split(X, y, groups))
    model = clone(est).set_params(**result.best_params_)
    model.fit(X.iloc[train], y.iloc[train])
    history = model[-1].history_
    errors = history["train_rmse" if validation_fraction is None else "val_rmse"]
    reported = [first.intermediate_values[e] for e in range(1, 6)]
    assert_allclose(reported, -errors, rtol=1e-10)
    # The refitted model carries no callback.
    assert result.best_estimator_[-1].epoch_callback is None


def test_epoch_pruning_keeps_the_users_epoch_callback(runs_data):
    # The pruning callback is chained after the estimator's own in the first
    # fold; best_estimator_ keeps the user's callback, not the pruning one.
    X, y, groups = runs_data
    calls = []

    def user_callback(epoch, train_rmse, check_rmse):
        calls.append(epoch)

    result = run_search(
        ANFISRegressor(random_state=0, epoch_callback=user_callback),
        X,
        y,
        groups=groups,
        space=_small_anfis_space(epochs=3),
        n_trials=1,
        pruner=_pruner(10),  # reports every epoch, never prunes
        random_state=0,
    )
    assert sorted(result.study.trials[0].intermediate_values) == [1, 2, 3]
    assert calls == [1, 2, 3] * 4  # three folds, then the refit
    assert result.best_estimator_.epoch_callback is user_callback
    # A user's callback asking to stop still stops the first fold.
    result = run_search(
        ANFISRegressor(random_state=0, epoch_callback=lambda e, t, c: e == 2),
        X,
        y,
        groups=groups,
        space=_small_anfis_space(epochs=5),
        n_trials=1,
        pruner=_pruner(10),
        refit=False,
    )
    assert sorted(result.study.trials[0].intermediate_values) == [1, 2]


def test_fold_pruning_for_other_estimators(runs_data):
    X, y, groups = runs_data
    result = run_search(
        GreyPSORegressor(calibration="ls"),
        X,
        y,
        groups=groups,
        space=lambda trial: {"delay": trial.suggest_int("delay", 0, 2)},
        n_trials=3,
        pruner=_pruner(1),
        random_state=0,
    )
    states = [t.state for t in result.study.trials]
    assert states == [COMPLETE, PRUNED, PRUNED]
    assert sorted(result.study.trials[0].intermediate_values) == [1, 2, 3]
    assert sorted(result.study.trials[1].intermediate_values) == [1]
    with pytest.raises(ValueError, match="pruning='epochs' needs an ANFISRegressor"):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=lambda trial: {},
            n_trials=1,
            pruning="epochs",
            pruner=optuna.pruners.MedianPruner(),
        )


def test_bad_draws_fail_trials_not_the_search(runs_data):
    X, y, groups = runs_data
    with pytest.warns(
        UserWarning,
        match=r"none of the study's 2 trial\(s\) completed \(2 fail\); a failed "
        "trial's user attribute 'error' holds its model's error",
    ):
        result = run_search(
            ANFISRegressor(),
            X,
            y,
            groups=groups,
            # more rules than the folds' training rows
            space=search_space("anfis", init="fcm", n_clusters=10_000, epochs=2),
            n_trials=2,
        )
    assert [t.state for t in result.study.trials] == [FAIL, FAIL]
    assert "n_clusters=10000" in result.study.trials[0].user_attrs["error"]
    assert result.best_params_ is None and result.best_estimator_ is None


def test_a_value_the_estimator_refuses_is_named_when_the_space_is_made():
    # A misspelt choice, a fixed value or a range end the estimator refuses
    # would fail every trial: the space refuses it at once, naming it.
    for kwargs, message in (
        ({"mf": ["gausian"], "epochs": 2}, "ANFISRegressor refuses mf='gausian'"),
        ({"init": "fcm", "n_clusters": (0, 5)}, "refuses n_clusters=0"),
        ({"init": "fcm", "step_size": -1.0}, "refuses step_size=-1.0"),
        ({"epochs": -5}, "search_space('anfis', epochs=-5)"),
        ({"step_size": "x"}, "step_size='x'"),
    ):
        with pytest.raises(ValueError, match=re.escape(message)):
            search_space("anfis", **kwargs)
    with pytest.raises(ValueError, match="FCMClusterPicker refuses scorer='pearsons'"):
        search_space("fcm_picker", scorer="pearsons")
    with pytest.raises(ValueError, match="GreyPSORegressor refuses calibration='lsq'"):
        search_space("grey_pso", calibration=["varpro", "lsq"])
    # Values the estimator takes are kept, a range given in floats included,
    # and settings drawn into another parameter (the swarm's inertia) too.
    assert search_space("anfis", epochs=(5.0, 20.0)).ranges["epochs"] == (5.0, 20.0)
    # ... and run_search, which checks what the space draws (ints), agrees:
    # it refused epochs=2.0.
    X = np.random.default_rng(0).normal(size=(40, 2))
    result = run_search(
        ANFISRegressor(),
        X,
        X.sum(axis=1),
        groups=np.repeat([0, 1], 20),
        space=search_space("anfis", init="fcm", epochs=(2.0, 3.0)),
        n_trials=1,
    )
    assert result.best_params_["epochs"] in (2, 3)
    assert search_space("gnnmci", inertia_start=0.9).ranges["inertia_start"] == 0.9
    # A log-scaled range from 0 is refused when the space is made.
    with pytest.raises(ValueError, match="epochs is searched on a log scale"):
        search_space("anfis", epochs=(0, 5))


def test_a_value_another_estimator_refuses_is_named_before_any_trial(runs_data):
    # A built-in space on a subclass that takes fewer values than the
    # space's own estimator: run_search names the value before any trial.
    X, y, groups = runs_data
    callback = _StopAfter(1)
    estimator = make_pipeline(StandardScaler(), _GaussianOnlyANFIS())
    space = {"_gaussianonlyanfis": search_space("anfis", init="fcm", mf="gbell")}
    with pytest.raises(ValueError, match=re.escape("_gaussianonlyanfis__mf='gbell'")):
        run_search(
            estimator,
            X,
            y,
            groups=groups,
            space=space,
            n_trials=1,
            callbacks=[callback],
        )
    assert callback.seen == 0


class _GaussianOnlyANFIS(ANFISRegressor):
    _parameter_constraints = {
        **ANFISRegressor._parameter_constraints,
        "mf": [StrOptions({"gaussian"})],
    }


class _StopAfter:
    """A callback failing the test once this call has run ``n`` trials (a
    search that should have stopped, or never started, loops otherwise)."""

    def __init__(self, n):
        self.n = n
        self.seen = 0
        self.study = None

    def __call__(self, study, trial):
        self.study = study
        self.seen += 1
        if self.seen >= self.n:
            raise AssertionError(f"the search ran {self.seen} trials")


def test_failing_trials_end_a_search_with_total_trials(runs_data):
    # The worker recipe (n_trials=None, total_trials=N): failed trials never
    # count towards N, so without a limit it would loop for ever.
    X, y, groups = runs_data
    watch = _StopAfter(50)
    with pytest.raises(ValueError, match="stopped: 4 trials in a row failed") as info:
        run_search(
            ANFISRegressor(),
            X,
            y,
            groups=groups,
            space=search_space("anfis", init="fcm", n_clusters=10_000, epochs=2),
            n_trials=None,
            total_trials=3,
            max_failed_trials=4,
            callbacks=[watch],
        )
    message = str(info.value)
    assert "The first of them, trial 0, failed in fold 0: ValueError:" in message
    assert "n_clusters=10000" in message and "raise max_failed_trials" in message
    assert isinstance(info.value.__cause__, ValueError)  # the trial's own error
    assert [t.state for t in watch.study.trials] == [FAIL] * 4


def test_only_failures_in_a_row_end_a_search(runs_data):
    # Two failures, then a complete trial, and again: never 3 in a row.
    X, y, groups = runs_data

    def space(trial):
        n_clusters = 2 if trial.number % 3 == 2 else 10_000
        return {"init": "fcm", "n_clusters": n_clusters, "epochs": 2}

    result = run_search(
        ANFISRegressor(random_state=0),
        X,
        y,
        groups=groups,
        space=space,
        n_trials=9,
        max_failed_trials=3,
        refit=False,
    )
    assert [t.state for t in result.study.trials] == [FAIL, FAIL, COMPLETE] * 3


def test_a_search_needs_a_stopping_criterion(runs_data):
    X, y, groups = runs_data
    with pytest.raises(ValueError, match=r"n_trials=None\) would never stop: pass"):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            n_trials=None,
            callbacks=[_StopAfter(1)],
        )


def test_no_trial_run_says_so(runs_data, tmp_path):
    X, y, groups = runs_data
    kwargs = {
        "space": lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
        "storage": tmp_path / "zero.db",
        "study_name": "zero",
    }
    est = GreyPSORegressor(calibration="ls")
    optuna = pytest.importorskip("optuna")
    # A study name the storage does not hold (a typo): an error, and no
    # empty study of that name is left behind.
    optuna.create_study(
        storage=f"sqlite:///{tmp_path / 'zero.db'}", study_name="zero-1"
    )
    with pytest.raises(
        ValueError,
        match=r"stored study 'zero' \(study_name\), but the storage .*zero\.db "
        r"holds 1 other study \('zero-1'\) \(did you mean 'zero-1'\?\); "
        r"nothing was stored",
    ):
        run_search(est, X, y, groups=groups, n_trials=0, **kwargs)
    assert optuna.study.get_all_study_names(f"sqlite:///{tmp_path / 'zero.db'}") == [
        "zero-1"
    ]
    with pytest.raises(ValueError, match="n_trials=0 runs no trial: .* needs storage"):
        run_search(est, X, y, groups=groups, n_trials=0, space=kwargs["space"])
    # A stored study without a trial: said as a warning.
    optuna.create_study(
        storage=f"sqlite:///{tmp_path / 'zero.db'}",
        study_name="zero",
        direction="maximize",
    )
    with pytest.warns(UserWarning, match="the study holds no trial") as record:
        result = run_search(est, X, y, groups=groups, n_trials=0, **kwargs)
    assert "error" not in str(record[0].message)
    assert result.best_params_ is None and result.study.trials == []
    # n_trials=0 on a stored study: its best trial, refitted.
    run_search(est, X, y, groups=groups, n_trials=2, refit=False, **kwargs)
    result = run_search(est, X, y, groups=groups, n_trials=0, **kwargs)
    assert len(result.study.trials) == 2
    assert result.best_estimator_.delay == result.best_params_["delay"]


def test_total_trials_counts_every_worker(runs_data, tmp_path):
    X, y, groups = runs_data
    kwargs = {
        "space": lambda trial: {"delay": trial.suggest_int("delay", 0, 2)},
        "storage": tmp_path / "total.db",
        "study_name": "total",
        "total_trials": 3,
        "refit": False,
    }
    est = GreyPSORegressor(calibration="ls")
    run_search(est, X, y, groups=groups, n_trials=2, **kwargs)
    result = run_search(est, X, y, groups=groups, n_trials=10, **kwargs)
    assert len(result.study.trials) == 3


# -------------------------------------------------------------- storages


def test_make_storage_kinds(tmp_path):
    from optuna.storages import JournalStorage, RDBStorage

    assert make_storage(None) is None
    db = make_storage(tmp_path / "a.sqlite")
    assert isinstance(db, RDBStorage) and db.heartbeat_interval == 60
    db = make_storage(f"sqlite:///{tmp_path / 'b.db'}", heartbeat_interval=None)
    assert db.heartbeat_interval is None
    db = make_storage(
        tmp_path / "c.db", heartbeat_interval=5, grace_period=7, max_retry=2
    )
    assert (db.heartbeat_interval, db.grace_period) == (5, 7)
    assert db.get_heartbeat_stale_trial_callback() is not None
    assert isinstance(make_storage(tmp_path / "d.journal"), JournalStorage)
    assert make_storage(db) is db
    with pytest.raises(ValueError, match="Cannot tell the storage kind"):
        make_storage(tmp_path / "study.txt")
    # A URL with one slash was a path in a folder 'sqlite:' ("does not
    # exist"), or made a file of that name.
    for typo in ("sqlite:/study.db", "sqlite:study.db"):
        with pytest.raises(ValueError, match=r"takes '://' after its scheme"):
            make_storage(typo)
    with pytest.raises(TypeError, match="storage must be"):
        make_storage(3)


def test_a_file_that_holds_no_study_is_refused_untouched(tmp_path):
    # An independent check: an application's log named .log got an Optuna
    # record appended, then "Extra data: line 1 column 5"; a file named .db
    # that is no database gave SQLAlchemy's traceback; another
    # application's database got Optuna's tables.
    import sqlite3

    log = tmp_path / "app.log"
    log.write_text("2026-11-29 08:00 spindle warm-up started\n")
    notdb = tmp_path / "notes.db"
    notdb.write_text("not a database\n")
    other = tmp_path / "other.db"
    with contextlib.closing(sqlite3.connect(other)) as db:
        db.execute("CREATE TABLE users (id INTEGER)")
        db.commit()
    real = tmp_path / "real.db"
    optuna.create_study(storage=make_storage(real), study_name="s")
    cut = tmp_path / "cut.db"
    cut.write_bytes(real.read_bytes()[:5000])
    cases = [
        (log, r"'.*app\.log': the file exists and is not an Optuna journal"),
        (notdb, r"'.*notes\.db': the file exists and is not an SQLite database"),
        (other, r"holds another application's tables \('users'\), no studies"),
        (cut, r"the SQLite database cannot be read \(database disk image"),
    ]
    for path, message in cases:
        before = path.read_bytes()
        with pytest.raises(ValueError, match=message + ".*nothing was written"):
            make_storage(path)
        assert path.read_bytes() == before
    # Study files, and empty files, are taken.
    make_storage(real)
    journal = tmp_path / "study.log"
    optuna.create_study(storage=make_storage(journal), study_name="s")
    make_storage(journal)
    (tmp_path / "empty.log").touch()
    make_storage(tmp_path / "empty.log")


def test_a_resumed_search_draws_new_points(runs_data, tmp_path):
    X, y, groups = runs_data
    kwargs = {
        "space": _small_anfis_space(),
        "storage": tmp_path / "resume.db",
        "study_name": "resume",
        "n_trials": 2,
        "random_state": 0,
        "refit": False,
    }
    run_search(ANFISRegressor(random_state=0), X, y, groups=groups, **kwargs)
    result = run_search(ANFISRegressor(random_state=0), X, y, groups=groups, **kwargs)
    params = [tuple(sorted(t.params.items())) for t in result.study.trials]
    assert len(params) == 4 and params[2:] != params[:2]


def test_the_library_s_wrappers_are_searched_inside(runs_data):
    # An independent check: run_search(make_model("anfis-fcm")) (the CLI's
    # model, a run-start wrapper) and a guarded ANFIS had "No built-in
    # search space", and pruning="epochs" was refused for them.
    from skthermal.compose import GuardedRegressor
    from skthermal.models import make_model

    X, y, groups = runs_data
    kwargs = {"groups": groups, "n_trials": 2, "random_state": 0}
    kwargs["pruner"] = optuna.pruners.MedianPruner()
    for model in (
        make_model("anfis-fcm", random_state=0, quick=True),
        GuardedRegressor(ANFISRegressor(epochs=3, random_state=0)),
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = run_search(model, X, y, pruning="epochs", **kwargs)
        assert "estimator__n_clusters" in result.best_params_ or (
            "estimator__n_mfs" in result.best_params_
        )
        assert type(result.best_estimator_) is type(model)


def test_a_study_not_to_join_is_said_in_run_search_s_words(runs_data, tmp_path):
    # Optuna's DuplicatedStudyError advised its command line's
    # --skip-if-exists.
    X, y, groups = runs_data
    kwargs = {"groups": groups, "n_trials": 1, "refit": False, "study_name": "s"}
    kwargs["storage"] = tmp_path / "s.db"
    est = GreyPSORegressor(calibration="ls")
    run_search(est, X, y, **kwargs)
    with pytest.raises(ValueError, match=r"already holds a study 's', and load_if"):
        run_search(est, X, y, load_if_exists=False, **kwargs)


def test_a_name_drawn_with_two_kinds_is_said_in_the_library_s_words(runs_data):
    # Optuna's "Cannot set different distribution kind to the same parameter
    # name." stopped the search from 14 frames deep, naming nothing.
    X, y, groups = runs_data

    def space(trial):
        if trial.suggest_categorical("kind", ["a", "b"]) == "a":
            return {"delay": trial.suggest_int("x", 0, 1)}
        return {"alpha": trial.suggest_float("x", 0.01, 0.5)}

    sampler = optuna.samplers.RandomSampler(seed=0)
    with pytest.raises(
        ValueError, match=r"drew one Optuna name with two kinds of distribution"
    ) as info:
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=space,
            n_trials=12,
            sampler=sampler,
            refit=False,
        )
    assert "Drawn before it in this trial: ['kind']" in str(info.value)


def test_a_target_with_holes_is_refused_once(runs_data):
    # An independent check: every trial failed on it, one by one, up to
    # max_failed_trials.
    X, y, groups = runs_data
    y = y.copy()
    y.iloc[[7, 9]] = np.nan
    with pytest.raises(
        ValueError, match=r"y has 2 missing or infinite value\(s\), the first at row 7"
    ):
        run_search(ANFISRegressor(random_state=0), X, y, groups=groups, n_trials=3)


def test_an_unseeded_estimator_is_said(runs_data):
    # An independent check: ANFIS with random_state=None searched with
    # run_search(random_state=0) twice gave other best scores, and the
    # refitted best model was not the one scored (-3.78 against -3.90 when
    # scored again), silently.
    X, y, groups = runs_data
    kwargs = {"groups": groups, "n_trials": 1, "refit": False, "random_state": 0}
    space = _small_anfis_space()
    with pytest.warns(UserWarning, match=r"'random_state' of ANFISRegressor is None"):
        run_search(ANFISRegressor(), X, y, space=space, **kwargs)
    pipe = make_pipeline(StandardScaler(), ANFISRegressor(epochs=3))

    def clusters(trial):
        return {"anfisregressor__n_clusters": trial.suggest_int("n", 2, 3)}

    with pytest.warns(UserWarning, match=r"'anfisregressor__random_state' of Pipe"):
        run_search(pipe, X, y, space=clusters, **kwargs)
    with pytest.warns(UserWarning, match=r"'random_state' of GreyPSORegressor"):
        grey = GreyPSORegressor(calibration="pso", epochs=3, n_particles=4)
        run_search(
            grey, X, y, space=lambda t: {"delay": t.suggest_int("d", 0, 1)}, **kwargs
        )

    def seeded(trial):  # the space sets the seed
        return {**space(trial), "random_state": trial.suggest_int("seed", 0, 9)}

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_search(ANFISRegressor(random_state=0), X, y, space=space, **kwargs)
        run_search(ANFISRegressor(), X, y, space=seeded, **kwargs)
        # Settings that draw no random numbers: nothing to seed.
        grid = {"init": "grid", "n_mfs": 2, "epochs": 3}
        run_search(ANFISRegressor(), X.iloc[:, :2], y, space=lambda t: grid, **kwargs)
        run_search(GreyPSORegressor(calibration="ls"), X, y, **kwargs)
    assert not [w for w in caught if "draws its own start" in str(w.message)]


@pytest.mark.parametrize("ext", ["db", "log"])
def test_two_searches_started_together_do_not_both_join(
    runs_data, tmp_path, monkeypatch, ext
):
    # An independent check: two workers started at the same moment on a
    # new study name, on 3 and on 2 sensors, both found no setup to check
    # and both recorded theirs (3 of 4 tries with a journal file): their
    # trials were ranked together. The first here records its setup late.
    import threading

    from skthermal.model_selection import _search

    X, y, groups = runs_data
    record = _search._record_setup
    made = threading.Event()

    def late_record(study, setup, missing):
        if threading.current_thread().name == "first":
            made.set()
            time.sleep(1.0)
        record(study, setup, missing)

    monkeypatch.setattr(_search, "_record_setup", late_record)
    kwargs = {
        "groups": groups,
        "space": _small_anfis_space(),
        "n_trials": 1,
        "storage": tmp_path / f"race.{ext}",
        "study_name": "race",
        "refit": False,
    }
    out = {}

    def first():
        out["first"] = run_search(ANFISRegressor(random_state=0), X, y, **kwargs)

    thread = threading.Thread(target=first, name="first")
    thread.start()
    assert made.wait(30)
    with pytest.raises(ValueError, match=r"made by another search \(features"):
        run_search(ANFISRegressor(random_state=0), X.iloc[:, :2], y, **kwargs)
    thread.join()
    assert len(out["first"].study.trials) == 1


def test_a_study_of_another_search_is_refused(runs_data, tmp_path):
    X, y, groups = runs_data
    kwargs = {"storage": tmp_path / "clash.db", "study_name": "s", "refit": False}
    run_search(
        ANFISRegressor(random_state=0),
        X,
        y,
        groups=groups,
        space=_small_anfis_space(),
        n_trials=1,
        **kwargs,
    )
    with pytest.raises(ValueError, match=r"made by another search \(scoring"):
        run_search(
            ANFISRegressor(random_state=1),  # another seed joins: same search
            X,
            y,
            groups=groups,
            space=_small_anfis_space(),
            n_trials=1,
            scoring="nse",
            **kwargs,
        )
    with pytest.raises(ValueError, match=r"estimator 'ANFISRegressor' there"):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 2)},
            n_trials=1,
            **kwargs,
        )


def test_a_study_of_another_output_setting_is_refused(runs_data, tmp_path):
    # A pipeline without pandas output (its grey model sees the training
    # rows as one run) joined a study made with it, and its session's best
    # model was not the one that scored best_score_.
    import sklearn

    X, y, groups = runs_data

    def search(model):
        return run_search(
            model,
            X,
            y,
            groups=groups,
            space=lambda t: {"greypsoregressor__delay": t.suggest_int("d", 0, 1)},
            n_trials=1,
            storage=tmp_path / "output.db",
            study_name="s",
            refit=False,
        )

    def pipe():
        return make_pipeline(StandardScaler(), GreyPSORegressor(calibration="ls"))

    search(pipe().set_output(transform="pandas"))
    with sklearn.config_context(transform_output="pandas"):
        search(pipe())  # the same output, set for the process
    with pytest.raises(ValueError, match=r"standardscaler.transform_output"):
        search(pipe())


def test_a_warning_of_every_fit_is_said_once_per_search(runs_data):
    # A scaler outputting numpy in front of a grey model: every trial and
    # fold warned that the runs became one, 31 warnings for 6 trials.
    X, y, groups = runs_data
    pipe = make_pipeline(StandardScaler(), GreyPSORegressor(calibration="ls"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_search(
            pipe,
            X,
            y,
            groups=groups,
            space=lambda t: {"greypsoregressor__delay": t.suggest_int("d", 0, 1)},
            n_trials=3,
            refit=False,
        )
    said = [w for w in caught if "taken as ONE run" in str(w.message)]
    assert len(said) == 1


def test_a_warning_made_an_error_fails_its_trial_not_the_search(runs_data):
    # Re-said after the fit, outside the trial's try, such a warning
    # stopped the whole search.
    X, y, groups = runs_data
    pipe = make_pipeline(StandardScaler(), GreyPSORegressor(calibration="ls"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warnings.filterwarnings("error", message=".*taken as ONE run")
        result = run_search(
            pipe,
            X,
            y,
            groups=groups,
            space=lambda t: {"greypsoregressor__delay": t.suggest_int("d", 0, 1)},
            n_trials=2,
            refit=False,
        )
    states = [t.state.name for t in result.study.trials]
    assert states == ["FAIL", "FAIL"]
    assert "taken as ONE run" in result.study.trials[1].user_attrs["error"]


def _grey_search(X, y, groups, storage, **kwargs):
    return run_search(
        GreyPSORegressor(calibration="ls"),
        X,
        y,
        groups=groups,
        **{
            "space": lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            "n_trials": 1,
            "storage": storage,
            "study_name": "s",
            "refit": False,
            **kwargs,
        },
    )


def test_a_study_on_other_inputs_rows_or_folds_is_refused(runs_data, tmp_path):
    # Scores on other sensors, rows or folds, or optimised the other way, are
    # not comparable: joining such a study would report the other search's
    # best trial as this one's.
    X, y, groups = runs_data
    storage = tmp_path / "other.db"
    _grey_search(X.iloc[:, :3], y, groups, storage)
    first, second, third, fourth = X.columns[:4]
    refused = {
        rf"features: only there \['{first}'\], only here \['{fourth}'\]": {
            "X": X.iloc[:, 1:4]
        },
        rf"features in the order \['{first}', '{second}', '{third}'\] there": {
            "X": X[[third, second, first]]
        },
        r"features \[.*\] there, '3 unnamed columns' here": {
            "X": X.iloc[:, :3].to_numpy()
        },
        r"\(cv 'GroupKFold, 3 folds' there, 'GroupKFold, 2 folds' here; data": {
            "cv": 2
        },
        r"; data '150 rows, 3 runs, run labels and folds \w+' there, '100 rows, "
        r"2 runs, run labels and folds \w+' here\)": {"rows": slice(0, 100)},
        # (a scoring callable: with a scorer name, minimize is refused anyway)
        r"made to maximize, this search gives direction='minimize'": {
            "direction": "minimize",
            "scoring": make_scorer(mean_squared_error),
        },
    }
    for message, change in refused.items():
        rows = change.pop("rows", slice(None))
        data = change.pop("X", X.iloc[:, :3])
        data, y_rows = (
            v.iloc[rows] if hasattr(v, "iloc") else v[rows] for v in (data, y)
        )
        with pytest.raises(ValueError, match=message):
            _grey_search(data, y_rows, groups[rows], storage, **change)
    # The same search, seeded otherwise, joins.
    result = _grey_search(X.iloc[:, :3], y, groups, storage, random_state=1)
    assert len(result.study.trials) == 2
    assert result.study.user_attrs["skthermal_features"] == [first, second, third]


def test_a_study_of_another_model_names_the_models_only(runs_data, tmp_path):
    # Another model's settings and search space differ with it: every one
    # of them was listed (about 2,000 characters from the command line).
    X, y, groups = runs_data
    storage = tmp_path / "model.db"
    _grey_search(X.iloc[:, :3], y, groups, storage)
    with pytest.raises(ValueError) as info:
        run_search(
            ANFISRegressor(epochs=2),
            X.iloc[:, :3],
            y,
            groups=groups,
            space=_small_anfis_space(),
            n_trials=1,
            storage=storage,
            study_name="s",
        )
    message = str(info.value)
    assert message.startswith(
        "Study 's' was made by another search (estimator 'GreyPSORegressor' "
        "there, 'ANFISRegressor' here): its trials cannot be compared"
    )
    assert len(message) < 300


def test_many_differing_settings_are_counted_not_all_listed():
    from skthermal.model_selection._search import _describe_difference

    there = {f"p{i}": i for i in range(10)}
    text = _describe_difference("skthermal_settings", there, {})
    assert text == (
        "estimator settings: p0 0 there, unset here; p1 1 there, unset here; "
        "p2 2 there, unset here; p3 3 there, unset here; and 6 more"
    )


def test_a_study_of_another_space_is_refused_before_any_trial(runs_data, tmp_path):
    # Resuming with a value fixed that the study searched would replay its
    # best trial through the new space (the fixed value winning), so the best
    # parameters and refitted model would not be the ones scored; another
    # built-in space of the same estimator would add its trials to the study.
    X, y, groups = runs_data
    storage = tmp_path / "space.db"

    def search(space):
        return run_search(
            ANFISRegressor(random_state=0),
            X.iloc[:, :2],
            y,
            groups=groups,
            space=space,
            n_trials=1,
            storage=storage,
            study_name="s",
            refit=False,
            random_state=0,
        )

    search(search_space("anfis", init="fcm", n_clusters=2, epochs=(3, 5)))
    for other in (
        search_space("anfis", init="fcm", n_clusters=2, epochs=9),
        search_space("anfis", init="grid", n_mfs=2, epochs=(3, 5)),
    ):
        with pytest.raises(ValueError, match=r"\(search space ranges: ranges\.(ep|in)"):
            search(other)
    study = optuna.load_study(study_name="s", storage=make_storage(storage))
    assert len(study.trials) == 1
    same = search(search_space("anfis", init="fcm", n_clusters=2, epochs=(3, 5)))
    assert len(same.study.trials) == 2


def test_a_changed_space_callable_is_refused_before_any_trial(runs_data, tmp_path):
    # Same module and name, other draws: only replaying the best trial shows
    # it, and that happens before this search adds its trials.
    X, y, groups = runs_data
    storage = tmp_path / "callable.db"

    def make(name):
        def space(trial):
            return {"delay": trial.suggest_int(name, 0, 1)}

        return space

    _grey_search(X, y, groups, storage, space=make("delay"))
    with pytest.raises(ValueError, match="this search space cannot replay"):
        _grey_search(X, y, groups, storage, space=make("lag"))
    study = optuna.load_study(study_name="s", storage=make_storage(storage))
    assert len(study.trials) == 1


def test_a_study_records_every_range_and_the_version(runs_data, tmp_path, monkeypatch):
    # The space's text lists only what differs from the installed defaults:
    # a later version with other default ranges joined a study of the old
    # ones silently, and refused one whose explicit ranges are its defaults.
    from skthermal.model_selection import _spaces

    X, y, groups = runs_data
    storage = tmp_path / "ranges.db"

    def search(**ranges):
        return _grey_search(
            X, y, groups, storage, space=search_space("grey_pso", **ranges)
        )

    first = search(calibration="ls")
    attrs = first.study.user_attrs
    assert attrs["skthermal_space_ranges"]["ranges"]["alpha"] == [1e-6, 100.0]
    assert attrs["skthermal_version"]
    defaults = dict(_spaces._REGISTRY["grey_pso"][1], alpha=(1e-3, 1e4))
    registry = dict(
        _spaces._REGISTRY,
        grey_pso=(
            _spaces._REGISTRY["grey_pso"][0],
            defaults,
            _spaces._REGISTRY["grey_pso"][2],
        ),
    )
    monkeypatch.setattr(_spaces, "_REGISTRY", registry)
    with pytest.raises(ValueError, match=r"search space ranges: ranges.alpha \[1e-06"):
        search(calibration="ls")
    # The old ranges given explicitly are the study's.
    assert len(search(calibration="ls", alpha=(1e-6, 100.0)).study.trials) == 2


def test_a_study_of_another_space_is_refused_in_plain_words(runs_data, tmp_path):
    # A study searched outside run_search with other parameter names: the
    # refusal ended on Optuna's advice about its FixedTrial, and the refused
    # search had already written its records into the study.
    X, y, groups = runs_data
    storage = tmp_path / "foreign.db"
    study = optuna.create_study(
        study_name="s", storage=make_storage(storage), direction="maximize"
    )
    study.optimize(lambda t: -t.suggest_float("ridge", 0.1, 1.0), n_trials=1)
    with (
        pytest.warns(UserWarning, match="does not record"),
        pytest.raises(ValueError, match=r"searched with another space") as info,
    ):
        _grey_search(X, y, groups, storage)
    assert "FixedTrial" not in str(info.value)
    stored = optuna.load_study(study_name="s", storage=make_storage(storage))
    assert not [k for k in stored.user_attrs if k.startswith("skthermal_")]


def test_groups_that_cut_the_runs_of_x_warn(runs_data):
    # groups= splitting a run of X's own run index: folds over the groups
    # trained and scored on one run without a word.
    from sklearn.linear_model import Ridge

    X, y, groups = runs_data
    cut = np.where(
        (groups == groups[0]) & (np.arange(len(groups)) % 50 >= 25),
        "cut",
        groups.astype(object),
    )
    with pytest.warns(UserWarning, match=r"groups cuts run .* into 2 groups"):
        run_search(
            Ridge(),
            X,
            y,
            groups=cut,
            space=lambda t: {"alpha": t.suggest_float("alpha", 0.1, 1.0)},
            n_trials=1,
            refit=False,
        )


def test_heartbeat_interval_without_heartbeats_warns(tmp_path):
    with pytest.warns(UserWarning, match="heartbeat_interval ignored: a journal"):
        make_storage(tmp_path / "s.log", heartbeat_interval=5)
    with pytest.warns(UserWarning, match="heartbeat_interval ignored: a study in"):
        make_storage(None, heartbeat_interval=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        make_storage(tmp_path / "t.log")
        make_storage(None)


def test_a_space_of_another_estimator_is_named():
    with pytest.raises(ValueError, match=r"built-in space of GreyPSORegressor is 'gr"):
        run_search(
            GreyPSORegressor(),
            np.zeros((4, 2)),
            np.zeros(4),
            groups=[0, 0, 1, 1],
            space="anfis",
            n_trials=1,
        )
    # Its own built-in space with a bad override: no "another estimator?".
    with pytest.raises(ValueError, match="mf='gbell'") as err:
        run_search(
            _GaussianOnlyANFIS(),
            np.zeros((4, 2)),
            np.zeros(4),
            groups=[0, 0, 1, 1],
            space=search_space("anfis", init="fcm", mf="gbell"),
            n_trials=1,
        )
    assert "another estimator" not in str(err.value)
    assert "Give a value it accepts" in str(err.value)


def test_a_space_shows_its_overrides():
    assert repr(search_space("anfis", init="fcm", epochs=(5, 8))) == (
        "search_space('anfis', init='fcm', epochs=(5, 8))"
    )
    assert (
        repr(search_space("gnnmci", prefix="g")) == "search_space('gnnmci', prefix='g')"
    )


def test_a_study_of_an_older_skthermal_is_joined_with_a_warning(runs_data, tmp_path):
    # Made before the features, cv and data were recorded: no way to check
    # them; the search warns, records its own, and later searches are checked.
    X, y, groups = runs_data
    storage = tmp_path / "old.db"
    study = optuna.create_study(
        study_name="s", storage=make_storage(storage), direction="maximize"
    )
    for key, value in {
        "skthermal_estimator": "GreyPSORegressor",
        "skthermal_scoring": "neg_rmse",
        "skthermal_target": str(y.name),
    }.items():
        study.set_user_attr(key, value)
    study.enqueue_trial({"delay": 0})
    study.optimize(lambda trial: -float(trial.suggest_int("delay", 0, 1)), n_trials=1)
    with pytest.warns(
        UserWarning,
        match="does not record their settings, space, space_ranges, features, cv, d",
    ):
        result = _grey_search(X, y, groups, storage)
    assert len(result.study.trials) == 2
    assert result.study.user_attrs["skthermal_features"] == list(X.columns)
    with pytest.raises(ValueError, match="features: only there"):
        _grey_search(X.iloc[:, :2], y, groups, storage)


def test_groups_given_apart_reach_every_fit(runs_data):
    # Run labels passed as groups= with a plain array: the folds' fits and the
    # refit see the runs, as fit(X, y, groups=groups) would.
    X, y, groups = runs_data
    result = run_search(
        GreyPSORegressor(calibration="ls"),
        X.to_numpy(),
        y.to_numpy(),
        groups=groups,
        space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
        n_trials=2,
        random_state=0,
    )
    best = result.best_estimator_
    direct = GreyPSORegressor(calibration="ls", **result.best_params_).fit(
        X.to_numpy(), y.to_numpy(), groups=groups
    )
    assert (
        list(best.run_states_)
        == list(direct.run_states_)
        == list(dict.fromkeys(groups))
    )
    assert_allclose(best.coef_, direct.coef_)
    with pytest.raises(ValueError, match=r"groups holds 3 run label\(s\) .* for the"):
        run_search(GreyPSORegressor(), X.to_numpy(), y.to_numpy(), groups=groups[:3])


def _scorer_for_a_shared_study(estimator, X, y):
    return -float(np.sqrt(np.mean((estimator.predict(X) - y) ** 2)))


def test_a_function_scorer_joins_its_own_study_again(runs_data, tmp_path):
    # Its repr holds a memory address: another process (or a second call)
    # must still see the same search.
    X, y, groups = runs_data
    kwargs = {"storage": tmp_path / "fn.db", "study_name": "s", "refit": False}
    for seed in (0, 1):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            n_trials=1,
            scoring=_scorer_for_a_shared_study,
            random_state=seed,
            **kwargs,
        )
    stored = optuna.load_study(
        study_name="s", storage=f"sqlite:///{tmp_path / 'fn.db'}"
    )
    assert stored.user_attrs["skthermal_scoring"].endswith("_scorer_for_a_shared_study")
    assert len(stored.trials) == 2


def test_storage_options_are_checked(tmp_path):
    # A negative retry count was accepted, a text heartbeat failed inside
    # int(), and options the storage ignores were dropped silently.
    from sklearn.utils._param_validation import InvalidParameterError

    db, log = tmp_path / "s.db", tmp_path / "s.log"
    with pytest.raises(InvalidParameterError, match="'max_retry' parameter"):
        make_storage(db, max_retry=-1)
    with pytest.raises(InvalidParameterError, match="'heartbeat_interval'"):
        make_storage(db, heartbeat_interval="abc")
    with pytest.warns(UserWarning, match="max_retry ignored: a journal"):
        make_storage(log, max_retry=1)
    with pytest.warns(UserWarning, match="grace_period ignored: heartbeat_int"):
        make_storage(db, heartbeat_interval=None, grace_period=5)
    assert make_storage(db, heartbeat_interval=2, grace_period=5, max_retry=1)


def test_storage_in_a_missing_folder(runs_data, tmp_path):
    with pytest.raises(ValueError, match="does not exist; create it first"):
        make_storage(tmp_path / "nowhere" / "study.db")


def test_storage_needs_a_study_name(runs_data, tmp_path):
    X, y, groups = runs_data
    with pytest.raises(ValueError, match="study_name"):
        run_search(
            ANFISRegressor(),
            X,
            y,
            groups=groups,
            space="anfis",
            storage=tmp_path / "x.db",
        )


def test_missing_optuna_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "optuna", None)
    with pytest.raises(ImportError, match=r"skthermal\[optuna\]"):
        make_storage("study.db")


# ------------------------------------------------- distributed workers


def _storages(tmp_path):
    return {
        "sqlite": str(tmp_path / "study.db"),
        "journal": str(tmp_path / "study.log"),
        "postgres": POSTGRES_URL,
    }


_KINDS = [
    "sqlite",
    "journal",
    pytest.param(
        "postgres",
        marks=pytest.mark.skipif(
            POSTGRES_URL is None, reason="SKTHERMAL_TEST_POSTGRES_URL is not set"
        ),
    ),
]


def _worker(storage, study, *args):
    return subprocess.Popen(
        [sys.executable, str(WORKER), storage, study, *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(proc, timeout=60):
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, f"worker failed:\n{err}"
    return out


@pytest.mark.parametrize("kind", _KINDS)
def test_two_workers_share_one_study(kind, tmp_path):
    storage = _storages(tmp_path)[kind]
    study_name = f"shared-{uuid.uuid4().hex[:8]}"
    workers = [_worker(storage, study_name, "--n-trials", 3) for _ in range(2)]
    for proc in workers:
        _finish(proc)
    study = optuna.load_study(study_name=study_name, storage=make_storage(storage))
    trials = study.trials
    assert len(trials) == 6
    assert all(t.state == COMPLETE for t in trials)
    pids = {t.user_attrs["worker_pid"] for t in trials}
    assert pids == {proc.pid for proc in workers}
    assert sorted(t.number for t in trials) == list(range(6))


def test_workers_started_together_with_one_seed_draw_different_points(tmp_path):
    # Each trial's draws are seeded by the seed and the trial's number, so
    # two workers that join the study at the same moment with the same
    # random_state do not repeat each other's trials (a continuous
    # step_size never comes out twice), and the study is reproducible.
    storage = str(tmp_path / "seeded.db")
    start = tmp_path / "start"
    studies = []
    for attempt in range(2):
        name = f"seeded-{attempt}"
        workers = [
            _worker(storage, name, "--n-trials", 3, "--random-state", 0,
                    "--start-at", start.with_suffix(f".{attempt}"))
            for _ in range(2)
        ]  # fmt: skip
        for proc in workers:
            ready = start.with_suffix(f".{attempt}.{proc.pid}")
            _wait_for(ready, proc)
        start.with_suffix(f".{attempt}").write_text("go")
        for proc in workers:
            _finish(proc)
        study = optuna.load_study(study_name=name, storage=make_storage(storage))
        steps = {t.number: t.params["step_size"] for t in study.trials}
        assert len(steps) == 6 and len(set(steps.values())) == 6
        studies.append(steps)
    # Trial k draws the same in both studies whichever worker ran it (the
    # first ten draws of TPE are random, seeded by the trial alone).
    assert studies[0] == studies[1]


def _wait_for(path, proc, timeout=45):
    deadline = time.monotonic() + timeout
    while not path.exists():
        if proc.poll() is not None:
            raise AssertionError(f"worker exited early:\n{proc.stderr.read()}")
        if time.monotonic() > deadline:
            proc.kill()
            raise AssertionError("the worker never started a trial")
        time.sleep(0.1)


@pytest.mark.parametrize("kind", _KINDS)
def test_killed_worker_leaves_a_consistent_study(kind, tmp_path):
    storage = _storages(tmp_path)[kind]
    study_name = f"killed-{uuid.uuid4().hex[:8]}"
    beat = ("--heartbeat", 1, "--grace", 2)
    marker = tmp_path / "started"
    sleeper = _worker(
        storage, study_name, "--n-trials", 1, "--sleep", 120, "--marker", marker, *beat
    )
    _wait_for(marker, sleeper)
    sleeper.send_signal(signal.SIGKILL)
    sleeper.communicate(timeout=30)
    assert sleeper.returncode == -signal.SIGKILL

    store = make_storage(storage, heartbeat_interval=1, grace_period=2)
    study = optuna.load_study(study_name=study_name, storage=store)
    (dead,) = study.trials
    assert dead.state == optuna.trial.TrialState.RUNNING
    assert dead.user_attrs["worker_pid"] == sleeper.pid
    if kind != "journal":
        # Database storages: the heartbeat alone finds the stale trial, once
        # the grace period after its last heartbeat has passed.
        deadline = time.monotonic() + 15
        failed = []
        while not failed and time.monotonic() < deadline:
            time.sleep(0.25)
            failed = fail_stale_trials(study, local_processes=False)
        assert failed == [dead.number]
    # The journal has no heartbeat: the next worker fails the trial of the
    # dead local process itself; with a database there is nothing left to do.
    _finish(_worker(storage, study_name, "--n-trials", 2, *beat))

    study = optuna.load_study(study_name=study_name, storage=make_storage(storage))
    states = [t.state for t in study.trials]
    assert states == [FAIL, COMPLETE, COMPLETE]
    assert study.best_trial.number in (1, 2)
    assert fail_stale_trials(study) == []


def test_run_search_validates_its_parameters(runs_data):
    X, y, groups = runs_data
    est = ANFISRegressor(epochs=2, random_state=0)
    with pytest.raises(InvalidParameterError, match="direction"):
        run_search(est, X, y, groups=groups, direction="up", n_trials=1)
    # Minimizing the default "neg_rmse" returned the worst trial, silently.
    with pytest.raises(ValueError, match=r"scoring='neg_rmse' is greater-is-better"):
        run_search(est, X, y, groups=groups, direction="minimize", n_trials=1)
    with pytest.raises(InvalidParameterError, match="n_trials"):
        run_search(est, X, y, groups=groups, n_trials=-1)
    with pytest.raises(TypeError, match="positional"):
        run_search(est, X, y, groups, n_trials=1)


def test_a_study_of_other_estimator_settings_is_refused(runs_data, tmp_path):
    # Only the estimator's classes were recorded: a session with another
    # fixed ridge joined the study and reported the other session's best.
    X, y, groups = runs_data
    space = lambda trial: {"delay": trial.suggest_int("delay", 0, 1)}  # noqa: E731
    kwargs = {
        "space": space,
        "storage": tmp_path / "settings.db",
        "study_name": "s",
        "n_trials": 1,
        "refit": False,
    }
    run_search(
        GreyPSORegressor(calibration="ls", random_state=0),
        X,
        y,
        groups=groups,
        **kwargs,
    )
    with pytest.raises(
        ValueError, match=r'estimator settings: alpha "auto" there, 1000.0 here'
    ):
        run_search(
            GreyPSORegressor(calibration="ls", alpha=1000.0),
            X,
            y,
            groups=groups,
            **kwargs,
        )
    # Another seed, or another fixed value of a searched parameter, joins.
    run_search(
        GreyPSORegressor(calibration="ls", delay=1, random_state=5),
        X,
        y,
        groups=groups,
        **kwargs,
    )


def test_an_edited_space_function_does_not_change_the_best_params(runs_data, tmp_path):
    # The best trial was replayed through the space function as it is now:
    # edited since, best_params_ and the refit held settings never scored.
    X, y, groups = runs_data
    est = GreyPSORegressor(calibration="ls", random_state=0)
    kwargs = {"storage": tmp_path / "edited.db", "study_name": "s", "refit": False}

    def space(trial):
        return {"delay": trial.suggest_int("delay", 0, 1), "alpha": 0.0}

    first = run_search(est, X, y, groups=groups, space=space, n_trials=2, **kwargs)

    def space(trial):  # noqa: F811 - the same cell, edited
        return {"delay": trial.suggest_int("delay", 0, 1), "alpha": 50.0}

    with pytest.warns(UserWarning, match=r"alpha 0.0 scored, 50.0 now"):
        again = run_search(est, X, y, groups=groups, space=space, n_trials=0, **kwargs)
    assert again.best_params_ == first.best_params_


def test_search_input_errors_say_what_is_wrong(runs_data, tmp_path):
    X, y, groups = runs_data
    est = GreyPSORegressor(calibration="ls")
    with pytest.raises(TypeError, match="search space returned NoneType, not a dict"):
        run_search(est, X, y, groups=groups, space=lambda trial: None, n_trials=1)
    plain = X.to_numpy()
    with pytest.raises(ValueError, match=r"cv=GroupKFold\(...\) leaves out groups"):
        run_search(est, plain, y, cv=GroupKFold(3), space=lambda t: {}, n_trials=1)
    with pytest.raises(ValueError, match=r"grace_period \(5 s\) must be longer"):
        make_storage(tmp_path / "g.db", heartbeat_interval=10, grace_period=5)
    with pytest.raises(ValueError, match=r"'postgresq://u@h/db': not a database URL"):
        make_storage("postgresq://u@h/db")
    # An unencoded '@' and ':' in the password: hidden whole, and said.
    with pytest.raises(
        ValueError, match=r"'postgresql://alice:\*\*\*@localhost/db'.*"
    ) as info:
        make_storage("postgresql://alice:p@ss:w0rd@localhost/db")
    assert "ss" not in str(info.value).split("localhost")[0].replace("postgresql", "")


def test_a_url_that_names_its_driver_gets_that_driver_s_advice():
    import importlib.util

    if importlib.util.find_spec("psycopg") is not None:
        pytest.skip("psycopg is installed: the URL's driver is found")
    # It said "install psycopg2-binary (or psycopg, ...)" for a URL that
    # needs psycopg.
    with pytest.raises(ValueError, match=r"install psycopg \(pip install") as info:
        make_storage("postgresql+psycopg://u:secret@localhost/db")
    assert "psycopg2" not in str(info.value) and "secret" not in str(info.value)


def test_a_dead_local_worker_s_trial_is_retried(tmp_path):
    # max_retry re-queued a trial failed for its heartbeat, not one failed
    # at once for its dead process (a worker resumed a second after kill -9).
    import socket

    store = make_storage(tmp_path / "retry.db", heartbeat_interval=60, max_retry=1)
    study = optuna.create_study(storage=store, study_name="r")
    trial = study.ask()
    trial.suggest_int("a", 0, 9)
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    trial.set_user_attr("worker_host", socket.gethostname())
    trial.set_user_attr("worker_pid", gone.pid)
    assert fail_stale_trials(study, heartbeat=False, storage=store) == [trial.number]
    states = [t.state for t in study.get_trials()]
    assert states == [FAIL, optuna.trial.TrialState.WAITING]
    # The failed trial says why, as a trial whose model failed does.
    error = study.get_trials()[0].user_attrs["error"]
    assert f"its worker (process {gone.pid} on" in error and "stopped" in error
    assert study.get_trials()[1].params == study.get_trials()[0].params


def test_recorded_settings_are_the_same_in_every_process():
    # Function-valued settings were recorded by repr (a memory address that
    # differs per process), and settings inside a Pipeline's steps came back
    # through the steps' repr: seeds, n_jobs and drawn values included.
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.feature_selection import SelectKBest, f_regression
    from sklearn.linear_model import Ridge
    from sklearn.pipeline import Pipeline

    from skthermal.model_selection._search import _estimator_settings, _param_text

    def pipe(**ridge):
        return Pipeline(
            [("sel", SelectKBest(f_regression, k=2)), ("ridge", Ridge(**ridge))]
        )

    settings = _estimator_settings(pipe())
    assert "steps" not in settings and not any("0x" in v for v in settings.values())
    function = f"{f_regression.__module__}.{f_regression.__qualname__}"
    assert json.loads(settings["sel__score_func"]) == {"callable": function}
    assert settings == _estimator_settings(pipe(random_state=3))
    assert _estimator_settings(pipe(alpha=np.float64(0.5))) == _estimator_settings(
        pipe(alpha=0.5)
    )
    anfis = ANFISRegressor(epochs=5)
    with_callback = ANFISRegressor(epochs=5, epoch_callback=lambda *a: None)
    assert _estimator_settings(anfis) == _estimator_settings(with_callback)
    assert _param_text({"a": (1, 2)}) == _param_text({"a": [1, 2]})
    # Another function is another model.
    assert _estimator_settings(
        TransformedTargetRegressor(func=np.arcsinh, inverse_func=np.sinh)
    ) != _estimator_settings(
        TransformedTargetRegressor(func=np.cbrt, inverse_func=np.sinh)
    )


def test_folds_that_cut_runs_and_empty_spaces_are_named(runs_data):
    from sklearn.model_selection import KFold

    X, y, groups = runs_data
    est = GreyPSORegressor(calibration="ls")
    space = lambda trial: {"delay": trial.suggest_int("delay", 0, 1)}  # noqa: E731
    with pytest.warns(
        UserWarning, match=r"The folds cut runs: fold 0 scores rows of run"
    ):
        run_search(est, X, y, groups=groups, cv=KFold(4), space=space, n_trials=1)
    with pytest.warns(
        UserWarning, match="draws no parameter: every trial fits the same"
    ):
        run_search(est, X, y, groups=groups, space=lambda t: {}, n_trials=2)


def test_an_interrupted_trial_records_why(runs_data, tmp_path):
    # Ctrl-C during a trial: Optuna stores it as failed and stops; the record
    # said "no error recorded", as for a worker killed outright.
    X, y, groups = runs_data
    optuna = pytest.importorskip("optuna")

    def interrupted(model, X, y):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_search(
            GreyPSORegressor(calibration="ls"),
            X,
            y,
            groups=groups,
            space=lambda trial: {"delay": trial.suggest_int("delay", 0, 1)},
            scoring=interrupted,
            n_trials=2,
            storage=tmp_path / "stop.db",
            study_name="stop",
        )
    study = optuna.load_study(
        study_name="stop", storage=f"sqlite:///{tmp_path}/stop.db"
    )
    (trial,) = study.trials
    assert trial.state.name == "FAIL"
    assert trial.user_attrs["error"] == "interrupted (KeyboardInterrupt) in fold 0"


def test_a_searched_setting_may_differ_before_the_first_trial(runs_data, tmp_path):
    # A worker joining a study whose first trial has not started yet: the
    # fixed value of a parameter the space draws does not count.
    X, y, groups = runs_data
    space = lambda trial: {"alpha": trial.suggest_float("alpha", 0.1, 10.0)}  # noqa: E731
    kwargs = {"space": space, "storage": tmp_path / "early.db", "study_name": "s"}
    optuna = pytest.importorskip("optuna")
    optuna.create_study(
        storage=f"sqlite:///{tmp_path / 'early.db'}",
        study_name="s",
        direction="maximize",
    )
    with pytest.warns(UserWarning, match="No best trial"):
        run_search(
            GreyPSORegressor(calibration="ls", alpha=1.0),
            X,
            y,
            groups=groups,
            n_trials=0,
            **kwargs,
        )
    result = run_search(
        GreyPSORegressor(calibration="ls", alpha=5.0),
        X,
        y,
        groups=groups,
        n_trials=1,
        refit=False,
        **kwargs,
    )
    assert len(result.study.trials) == 1


def test_the_best_trial_is_refitted_with_the_seed_it_was_scored_with(
    runs_data, tmp_path
):
    # Workers may run with other seeds; a later call refitting the stored
    # best trial (n_trials=0) refitted it with its own seed: another model
    # than the one scored, silently.
    X, y, groups = runs_data
    storage = tmp_path / "seeds.db"
    space = search_space("gnnmci", epochs=3, n_particles=(5, 8))

    def search(seed, n_trials):
        return run_search(
            GNNMCIRegressor(random_state=seed),
            X,
            y,
            groups=groups,
            space=space,
            n_trials=n_trials,
            storage=storage,
            study_name="s",
            random_state=0,
        )

    first = search(1, 2)
    assert first.best_trial_.user_attrs["skthermal_seeds"] == {"random_state": 1}
    with pytest.warns(
        UserWarning, match=r"scored with random_state=1 \(this search: 2\)"
    ):
        again = search(2, 0)
    assert again.best_estimator_.random_state == 1
    assert_allclose(again.best_estimator_.predict(X), first.best_estimator_.predict(X))
    # The same seed: no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        assert search(1, 0).best_estimator_.random_state == 1
