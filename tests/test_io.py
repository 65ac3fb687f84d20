"""Tests of skthermal.io: safe deployment files (skops) and version warnings."""

import functools
import json
import pickle
import re
import warnings
import zipfile
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_array_equal
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

pytest.importorskip("skops")

from skthermal import (  # noqa: E402
    ANFISRegressor,
    FCMClusterPicker,
    FuzzyEquivalenceSelector,
    GNNMCIRegressor,
    GRASelector,
    GreyInfluenceSelector,
    GreyPSORegressor,
    GuardedRegressor,
    LagFeatures,
    LagRidgeCV,
    ModularRegressor,
    StableTSPSelector,
    TransferFunctionRegressor,
    UpdateRegressor,
)
from skthermal.datasets import make_sensor_groups, split_runs  # noqa: E402
from skthermal.io import (  # noqa: E402
    SkthermalVersionWarning,
    UntrustedTypesError,
    load,
    read_metadata,
    save,
)

ESTIMATORS = [
    ANFISRegressor(n_clusters=2, epochs=5, random_state=0),
    ANFISRegressor(init="grid", mf="gbell", epochs=3, grey=True),
    GNNMCIRegressor(n_particles=6, epochs=3, random_state=0),
    GreyPSORegressor(n_particles=6, epochs=3, random_state=0),
    GreyInfluenceSelector(n_features_to_select=2),
    GRASelector(n_features_to_select=2),
    FCMClusterPicker(n_clusters=2, n_init=2, random_state=0),
    StableTSPSelector(),
    FuzzyEquivalenceSelector(n_groups=2),
    UpdateRegressor(),
    TransferFunctionRegressor(n_grid=3, max_iter=2),
    ModularRegressor(),
    GuardedRegressor(GreyPSORegressor(n_particles=6, epochs=3), mode="clip"),
    LagRidgeCV(time_constant_sets=[(), (2.0, 5.0)], alphas=[0.1, 10.0], dt=1.0),
    make_pipeline(
        LagFeatures(time_constants=(3.0,), dt=1.0), StandardScaler(), Ridge()
    ),
    make_pipeline(
        GreyInfluenceSelector(n_features_to_select=2),
        StandardScaler(),
        ANFISRegressor(n_clusters=2, epochs=5, random_state=0),
    ),
]


def _name(est):
    steps = getattr(est, "steps", None)
    if steps:
        return "Pipeline(" + "+".join(type(s).__name__ for _, s in steps) + ")"
    return type(est).__name__


@pytest.fixture(scope="module")
def runs_data():
    runs, _ = make_sensor_groups(
        n_groups=2,
        sensors_per_group=2,
        n_noise=1,
        n_runs=3,
        n_samples=40,
        random_state=0,
    )
    X, y, _ = split_runs(runs)
    return X, y


def _output(model, X):
    return model.predict(X) if hasattr(model, "predict") else model.transform(X)


@pytest.fixture(scope="module")
def fitted(runs_data):
    X, y = runs_data
    return [clone(est).fit(X, y) for est in ESTIMATORS]


@pytest.mark.parametrize("index", range(len(ESTIMATORS)), ids=map(_name, ESTIMATORS))
def test_save_load_round_trip(index, fitted, runs_data, tmp_path):
    X, _ = runs_data
    model = fitted[index]
    path = save(model, tmp_path / "model.skops")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # same versions: no warning at all
        loaded = load(path)
    assert type(loaded) is type(model)
    assert_array_equal(_output(loaded, X), _output(model, X))
    assert loaded.get_params(deep=False).keys() == model.get_params(deep=False).keys()


@pytest.mark.parametrize("index", range(len(ESTIMATORS)), ids=map(_name, ESTIMATORS))
def test_joblib_round_trip(index, fitted, runs_data, tmp_path):
    X, _ = runs_data
    model = fitted[index]
    joblib.dump(model, tmp_path / "model.joblib")
    assert_array_equal(
        _output(joblib.load(tmp_path / "model.joblib"), X), _output(model, X)
    )


def test_metadata_records_versions(fitted, tmp_path):
    import sklearn

    import skthermal

    path = save(fitted[0], tmp_path / "model.skops")
    versions = read_metadata(path)["versions"]
    assert versions["skthermal"] == skthermal.__version__
    assert versions["scikit-learn"] == sklearn.__version__


def _rewrite_metadata(path, change):
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    metadata = json.loads(members["skthermal_metadata.json"])
    change(metadata["versions"])
    members["skthermal_metadata.json"] = json.dumps(metadata).encode()
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def test_tampered_versions_warn(fitted, runs_data, tmp_path):
    import sklearn

    import skthermal

    X, _ = runs_data
    path = save(fitted[0], tmp_path / "model.skops")

    def older(versions):
        versions["skthermal"] = "0.0.1"
        versions["scikit-learn"] = "1.0"

    _rewrite_metadata(path, older)
    with pytest.warns(SkthermalVersionWarning) as record:
        loaded = load(path)
    message = str(record[0].message)
    assert "skthermal 0.0.1" in message
    assert f"installed: {skthermal.__version__}" in message
    assert "scikit-learn 1.0" in message
    assert f"installed: {sklearn.__version__}" in message
    assert_array_equal(loaded.predict(X), fitted[0].predict(X))


class _Custom(RegressorMixin, BaseEstimator):
    """A class skthermal does not know: not trusted by default."""

    def fit(self, X, y):
        self.mean_ = float(np.mean(y))
        return self

    def predict(self, X):
        return np.full(len(X), self.mean_)


RUN_LABELS = {
    "Timestamp": [pd.Timestamp(f"2024-05-0{d} 07:30") for d in (1, 2, 3)],
    "tuple": [("m1", 1), ("m1", 2), ("m2", 1)],
    "bool": [True, False, None],  # the rows of the third run left out
    "int": [3, 1, 2],
}


@pytest.mark.parametrize("kind", list(RUN_LABELS))
@pytest.mark.parametrize(
    "model",
    [
        LagRidgeCV(time_constant_sets=[(120.0, 600.0)], alphas=[0.1, 10.0]),
        make_pipeline(LagFeatures(time_constants=(120.0, 600.0)), Ridge()),
        TransferFunctionRegressor(n_grid=3, max_iter=2),
        GreyPSORegressor(calibration="ls"),
    ],
    ids=_name,
)
def test_sequence_models_of_any_run_label_round_trip(model, kind, runs_data, tmp_path):
    # The run memory of a model fitted on runs labelled by their start
    # (Timestamps) or by tuples could not be written (JSON keys); bool
    # labels came back as one key (True). The later rows of every training
    # run, continued from that memory, are predicted alike after loading.
    X, y = runs_data
    runs = X.index.get_level_values("run")
    labels = np.empty(len(X), dtype=object)
    labels[:] = [RUN_LABELS[kind][int(r[-1]) - 1] for r in runs]
    keep = np.array([lab is not None for lab in labels])
    table = X.reset_index(level="time_s").assign(run=labels)[keep]
    target = y.to_numpy()[keep]
    early = table["time_s"].to_numpy() < 25 * 60.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # few rows: no CV fold
        model = clone(model).fit(table[early], target[early])
    loaded = load(save(model, tmp_path / "model.skops"))
    later = model.predict(table[~early])
    assert_array_equal(loaded.predict(table[~early]), later)
    # Continued, not restarted: the same as the whole runs predicted.
    np.testing.assert_allclose(later, model.predict(table)[~early], atol=1e-9)


def test_a_dict_key_a_file_cannot_hold_is_named(runs_data, tmp_path):
    X, y = runs_data
    model = make_pipeline(LagFeatures(time_constants=(120.0,)), Ridge()).fit(X, y)
    # As a model fitted by an older skthermal kept its run memory.
    model[0].run_states_ = {pd.Timestamp("2024-05-01"): {}}
    with pytest.raises(
        TypeError,
        match=r"Pipeline.steps\[0\]\[1\].run_states_ is a dict with the key "
        r"Timestamp\('2024-05-01 00:00:00'\) of type Timestamp.*refit",
    ):
        save(model, tmp_path / "model.skops")
    model[0].run_states_ = {True: {}, False: {}}  # skops gave back one key
    with pytest.raises(TypeError, match="key True of type bool"):
        save(model, tmp_path / "model.skops")
    assert not (tmp_path / "model.skops").exists()


def test_a_function_a_file_cannot_give_back_is_named(runs_data, tmp_path):
    # A lambda (or a function of the running script) was saved, and the file
    # failed to load only on the controller, inside skops.
    from sklearn.preprocessing import FunctionTransformer

    X, y = runs_data

    def local(z):
        return z - 20.0

    for func, where, why in (
        (lambda z: z - 20.0, "", "is a lambda"),
        (local, "", "is the function .*local, local to another function"),
        (functools.partial(lambda z, a: z - a, a=20.0), ".func", "is a lambda"),
    ):
        model = make_pipeline(FunctionTransformer(func), Ridge()).fit(X, y)
        with pytest.raises(
            TypeError, match=r"Pipeline.steps\[0\]\[1\].func" + where + " " + why
        ):
            save(model, tmp_path / "f.skops")
    assert not (tmp_path / "f.skops").exists()

    # A function of the running script loads only where a script defines it:
    # saved, with a warning naming what load must trust.
    def shift(z):
        return z - 20.0

    shift.__module__, shift.__qualname__ = "__main__", "shift"
    model = make_pipeline(FunctionTransformer(shift), Ridge()).fit(X, y)
    with pytest.warns(UserWarning, match=r"trusted=\['__main__.shift'\]"):
        save(model, tmp_path / "f.skops")
    # A function of an importable module is saved, and loads.
    model = make_pipeline(FunctionTransformer(np.log1p), Ridge()).fit(X - X.min(), y)
    loaded = load(save(model, tmp_path / "f.skops"))
    assert_array_equal(loaded.predict(X - X.min()), model.predict(X - X.min()))
    with pytest.raises(IsADirectoryError, match="is a folder: give the file"):
        save(model, tmp_path)


def test_untrusted_type_refused(runs_data, tmp_path):
    X, y = runs_data
    model = make_pipeline(GRASelector(n_features_to_select=2), _Custom()).fit(X, y)
    path = save(model, tmp_path / "custom.skops")
    name = f"{__name__}._Custom"
    with pytest.raises(UntrustedTypesError, match="not trusted by default") as info:
        load(path)
    assert info.value.types == [name]
    assert name in str(info.value) and "trusted=" in str(info.value)
    # Trusting it explicitly, by name or class, loads it.
    assert_array_equal(load(path, trusted=[name]).predict(X), model.predict(X))
    assert_array_equal(load(path, trusted=[_Custom]).predict(X), model.predict(X))


def test_skthermal_trust_needs_a_real_class(tmp_path):
    from skthermal.io._persist import _is_skthermal_class

    assert _is_skthermal_class("skthermal.fuzzy._anfis.ANFISRegressor")
    # Re-exported names, functions and modules are not classes defined there.
    assert not _is_skthermal_class("skthermal.fuzzy.ANFISRegressor")
    assert not _is_skthermal_class("skthermal.fuzzy._anfis.np")
    assert not _is_skthermal_class("skthermal.grey._ago.ago")
    # Modules are never imported on behalf of a file.
    assert not _is_skthermal_class("skthermal.__main__.Anything")
    assert not _is_skthermal_class("skthermalx.Evil")


def test_epoch_callback_is_not_saved(runs_data, tmp_path):
    X, y = runs_data
    seen = []
    model = ANFISRegressor(
        n_clusters=2, epochs=3, epoch_callback=lambda *a: seen.append(a)
    ).fit(X, y)
    assert len(seen) == 3
    loaded = load(save(model, tmp_path / "cb.skops"))
    assert loaded.epoch_callback is None
    assert model.epoch_callback is not None
    assert_array_equal(loaded.predict(X), model.predict(X))


def test_a_global_output_setting_is_said_on_save(runs_data, tmp_path):
    # Fitted under sklearn.set_config(transform_output="pandas"), a pipeline
    # loaded elsewhere output numpy between its steps and its grey model
    # took six runs as one (11 µm off), with no word at saving.
    import sklearn

    from skthermal import GreyPSORegressor

    X, y = runs_data
    pipe = make_pipeline(StandardScaler(), GreyPSORegressor(random_state=0))
    with sklearn.config_context(transform_output="pandas"):
        pipe.fit(X, y)
        with pytest.warns(UserWarning, match=r"set_output\(transform='pandas'\)"):
            save(pipe, tmp_path / "global.skops")
        pipe.set_output(transform="pandas")
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            save(pipe, tmp_path / "own.skops")
    assert_array_equal(load(tmp_path / "own.skops").predict(X), pipe.predict(X))


def test_a_pipeline_with_metadata_requests_saves(runs_data, tmp_path):
    # scikit-learn keeps the estimator inside its own metadata requests, a
    # cycle skops recursed into without end. The requests are not saved.
    import sklearn
    from sklearn.pipeline import make_pipeline

    from skthermal import GRASelector, GreyPSORegressor

    X, y = runs_data
    with sklearn.config_context(enable_metadata_routing=True):
        pipe = make_pipeline(
            GRASelector(n_features_to_select=2).set_fit_request(groups=True),
            GreyPSORegressor(calibration="ls").set_fit_request(groups=True),
        ).fit(X, y)
        loaded = load(save(pipe, tmp_path / "routed.skops"))
    assert_array_equal(loaded.predict(X), pipe.predict(X))
    assert pipe[-1].get_metadata_routing().fit.requests["groups"] is True
    assert "_metadata_request" not in vars(loaded[-1])


def test_missing_skops_says_how_to_install_it(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "skops.io", None)
    monkeypatch.setitem(sys.modules, "skops", None)
    with pytest.raises(ImportError, match=r"requires skops.*pip install skops"):
        save(ANFISRegressor(), "unused.skops")


def test_every_public_estimator_has_a_round_trip():
    from tests._instances import public_estimator_names

    covered = {type(e).__name__ for e in ESTIMATORS}
    for est in ESTIMATORS:
        covered |= {type(s).__name__ for _, s in getattr(est, "steps", [])}
    missing = public_estimator_names() - covered
    assert not missing, f"add {sorted(missing)} to ESTIMATORS"


# --- files that are not skops files -------------------------------------------


@pytest.fixture
def small_model():
    from sklearn.linear_model import LinearRegression

    X = np.arange(6.0).reshape(-1, 1)
    return LinearRegression().fit(X, 2 * X[:, 0])


def _write_foreign(kind, path, model):
    if kind == "empty":
        path.write_bytes(b"")
    elif kind == "text":  # starts with "x", the first byte of a zlib stream
        path.write_text("xrun,time_s,T1_C\na,0,20\n")
    elif kind == "pickle":
        path.write_bytes(pickle.dumps(model))
    elif kind == "joblib":
        joblib.dump(model, path)
    elif kind == "joblib-compressed":
        joblib.dump(model, path, compress=3)
    elif kind == "truncated":
        save(model, path)
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif kind == "other-zip":
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("notes.txt", "hello")


FOREIGN = {
    "empty": "empty file \\(0 bytes\\)",
    "text": "a text file starting with 'xrun,time_s",
    "pickle": "a pickle \\(or joblib\\) file",
    "joblib": "a pickle \\(or joblib\\) file",
    "joblib-compressed": "compressed data, such as a compressed joblib file",
    "truncated": "the file is cut off",
    "other-zip": "a zip archive without skops' schema.json",
}


@pytest.mark.parametrize("reader", [load, read_metadata])
@pytest.mark.parametrize("kind", list(FOREIGN))
def test_not_a_skops_file(kind, reader, small_model, tmp_path):
    path = tmp_path / "model.skops"
    _write_foreign(kind, path, small_model)
    with pytest.raises(ValueError) as info:
        reader(path)
    message = str(info.value)
    assert message.startswith(f"{path} is not a skops model file: ")
    assert re.search(FOREIGN[kind], message), message
    assert "expected a .skops file written by skthermal.io.save" in message
    trusted_hint = "only if you trust where it comes from, load it with joblib.load"
    assert (trusted_hint in message) == kind.startswith(("pickle", "joblib"))


@pytest.mark.parametrize("reader", [load, read_metadata])
def test_missing_model_file(reader, tmp_path):
    path = tmp_path / "nope.skops"
    with pytest.raises(FileNotFoundError, match=re.escape(f"No model file at {path}")):
        reader(path)
    with pytest.raises(FileNotFoundError, match="a folder"):
        reader(tmp_path)


def test_skops_file_without_metadata_still_loads(small_model, tmp_path):
    import skops.io as sio

    path = tmp_path / "plain.skops"
    sio.dump(small_model, path)
    assert read_metadata(path) is None
    assert_array_equal(load(path).coef_, small_model.coef_)


def _rewrite_member(path, name, data):
    with zipfile.ZipFile(path) as archive:
        members = {n: archive.read(n) for n in archive.namelist()}
    members[name] = data
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for n, d in members.items():
            archive.writestr(n, d)


@pytest.mark.parametrize("reader", [load, read_metadata])
def test_damaged_files_are_named_as_damaged(reader, small_model, tmp_path):
    path = save(small_model, tmp_path / "meta.skops")
    _rewrite_member(path, "skthermal_metadata.json", b"{not json")
    with pytest.raises(ValueError, match=r"meta.skops.*not readable JSON.*again"):
        reader(path)
    path = save(small_model, tmp_path / "format.skops")
    _rewrite_member(path, "skthermal_metadata.json", b'{"format": 99}')
    with pytest.raises(ValueError, match="format 99, which this skthermal"):
        reader(path)
    path = save(small_model, tmp_path / "flip.skops")
    data = bytearray(Path(path).read_bytes())
    data[len(data) // 3 : len(data) // 3 + 50] = bytes(50)
    Path(path).write_bytes(bytes(data))
    with pytest.raises(
        ValueError, match=r"flip.skops.*damaged.*Write or copy it again"
    ):
        reader(path)


def test_metadata_without_versions_warns_with_unknown(small_model, tmp_path):
    path = save(small_model, tmp_path / "bare.skops")
    _rewrite_member(path, "skthermal_metadata.json", b'{"format": 1}')
    with pytest.warns(SkthermalVersionWarning, match="skthermal unknown"):
        load(path)
