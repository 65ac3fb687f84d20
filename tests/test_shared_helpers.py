"""The package-private helpers shared across skthermal's subpackages."""

import sys

import numpy as np
import pandas as pd
import pytest

from skthermal._markdown import markdown_table
from skthermal._optional import import_optional, missing_dependency
from skthermal._run_changes import changes_since_first_row
from skthermal._versions import package_versions
from skthermal.utils import changes_since_start, run_slices


def test_import_optional_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    with pytest.raises(
        ImportError, match=r'Thing requires matplotlib\. .*"skthermal\[plot\]"'
    ):
        import_optional("matplotlib.pyplot", extra="plot", caller="Thing")
    err = missing_dependency("zstandard", caller="Reading x.zst")
    assert str(err).endswith("pip install zstandard.")
    assert import_optional("json", caller="x") is sys.modules["json"]


def test_changes_since_first_row_matches_contiguous_runs():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(7, 2))
    groups = np.array(["a", "b", "a", "b", "b", "a", "c"])
    got = changes_since_first_row(X, groups)
    for g in np.unique(groups):
        rows = groups == g
        np.testing.assert_array_equal(got[rows], X[rows] - X[rows][0])
    # Sorted into blocks, it is the array helper of the estimators.
    order = np.argsort(groups, kind="stable")
    slices, _ = run_slices(groups[order])
    np.testing.assert_array_equal(got[order], changes_since_start(X[order], slices))
    np.testing.assert_array_equal(changes_since_first_row(X, None), X - X[0])
    with pytest.raises(ValueError, match="one run label per row"):
        changes_since_first_row(X, groups[:3])
    with pytest.raises(ValueError, match="missing run labels"):
        changes_since_first_row(X[:2], np.array(["a", None], dtype=object))


def test_markdown_table_and_versions():
    frame = pd.DataFrame({"a": [1.5, 2.0], "b": ["x", "y"]})
    table = markdown_table(frame, cell=lambda v: f"<{v}>")
    assert table.splitlines() == [
        "| a | b |",
        "|---|---|",
        "| <1.5> | <x> |",
        "| <2.0> | <y> |",
    ]
    assert markdown_table(frame.iloc[:0], empty="(none)") == "(none)"
    versions = package_versions(["numpy", "no-such-distribution-xyz"])
    assert versions["numpy"] == np.__version__
    assert versions["no-such-distribution-xyz"] is None
    assert versions["python"] == ".".join(map(str, sys.version_info[:3]))


def test_table_changes_since_start_interleaved_runs():
    from skthermal.datasets import changes_since_start as table_changes

    df = pd.DataFrame(
        {
            "run": ["a", "b", "a", "b", "a"],
            "time_s": [0.0, 0.0, 1.0, 1.0, 2.0],
            "T1_C": [20.0, 30.0, 21.0, 29.0, 23.5],
        }
    )
    out = table_changes(df)
    assert out["T1_C"].tolist() == [0.0, 0.0, 1.0, -1.0, 3.5]
    assert out["run"].tolist() == df["run"].tolist()


def _imported_modules(package):
    """Every skthermal module imported (anywhere) by the files of ``package``."""
    import ast
    from pathlib import Path

    root = Path(__file__).parents[1] / "skthermal" / package
    out = set()
    for path in root.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                out.add(node.module)
            elif isinstance(node, ast.Import):
                out.update(alias.name for alias in node.names)
    return {m for m in out if m.startswith("skthermal")}


def test_sensors_and_datasets_import_layers():
    """The sensors do not use the data sets, nor the data sets the models."""
    assert not any(
        m.startswith("skthermal.datasets") for m in _imported_modules("sensors")
    )
    assert not any(
        m.startswith("skthermal.linear_model") for m in _imported_modules("datasets")
    )


def test_make_sensor_groups_rejects_too_few_samples():
    from sklearn.utils._param_validation import InvalidParameterError

    from skthermal.datasets import make_sensor_groups

    # Fewer than 12 samples per run used to loop forever on empty duty blocks.
    with pytest.raises(InvalidParameterError, match="n_samples"):
        make_sensor_groups(n_samples=3, random_state=0)
    runs, truth = make_sensor_groups(
        n_groups=1,
        sensors_per_group=1,
        n_noise=0,
        n_runs=1,
        n_samples=12,
        random_state=0,
    )
    assert runs.shape == (12, 4) and truth.tolist() == [0]


def test_find_spikes_takes_glitches_only():
    from skthermal.utils._faults import find_spikes, flat_columns, repair_spikes

    rng = np.random.default_rng(0)
    t = np.arange(600.0)
    smooth = 5.0 * (1.0 - np.exp(-t / 150.0)) + rng.normal(0, 0.02, t.size)
    y = np.column_stack([smooth] * 8)
    y[300, 0] += 3.0  # a glitch
    y[300:, 1] += 3.0  # a step that stays
    y[300:, 2] += 0.5 * (t[300:] - 300.0)  # a change of slope
    y[:, 3] = np.round(y[:, 3] / 0.1) * 0.1  # quantised readings: flicker
    y[0, 4] += 3.0  # the first sample
    y[300, 5] += 3.0  # two in a row, of either sign
    y[301, 5] -= 3.0
    y[::20, 6] += 3.0  # a periodic excursion: the channel's own
    y[450, 7] -= 3.0  # at a driver's change: a real event
    drivers = np.where(t < 450, 0.0, 2000.0)
    found = find_spikes(y, drivers)
    assert list(zip(*np.nonzero(found), strict=True)) == [
        (0, 4),
        (300, 0),
        (300, 5),
        (301, 5),
    ]
    assert find_spikes(y)[450, 7]  # without the drivers, a glitch
    # A run that starts running rises fastest at its first sample.
    assert not find_spikes(y, drivers, running=drivers > -1)[0].any()
    # Next to a driver's change, a reading stored as 0 is still a glitch;
    # a quantised air's flicker is no change.
    zero = 22.0 + 2.0 * smooth  # a sensor at 22-32 °C
    zero[450] = 0.0
    assert np.flatnonzero(find_spikes(zero, drivers)).tolist() == [450]
    air = np.where(t < 200, 21.0, 21.1)
    zero[200] = 0.0
    assert 200 in np.flatnonzero(find_spikes(zero, air=air))
    # A quantised reading's rare flicker is none; on a reading that never
    # changes, a glitch is not told by its size, and the channel is dead.
    flat = np.full(50, 20.0)
    flat[20] = 20.125
    assert not find_spikes(flat).any()
    assert not flat_columns(flat[:, None])  # a flicker is a change
    flat[20] = 70.0
    assert flat_columns(flat[:, None]) and not flat_columns(y[:, :1])
    assert not find_spikes(np.zeros((2, 3))).any()
    # A spindle start: the probe's instant centrifugal step, then growth of
    # the other sign. Its samples around the step do not agree.
    u = (t >= 300).astype(float)
    growth = 3.0 * (1.0 - np.exp(-np.clip(t - 300.0, 0, None) / 20.0))
    assert not find_spikes(-2.0 * u + growth).any()
    with pytest.warns(UserWarning, match=r"T1_C = 7\.\d+ at time_s 300 \(\+3\.0"):
        fixed = repair_spikes(y, ["T1_C", *"bcdefgh"], t, "r1", spindle_rpm=drivers)
    # On a straight line between the samples around them.
    assert fixed[300, 0] == pytest.approx(0.5 * (y[299, 0] + y[301, 0]))
    np.testing.assert_allclose(
        fixed[300:302, 5], y[299, 5] + (y[302, 5] - y[299, 5]) * np.r_[1, 2] / 3
    )
    assert fixed[0, 4] == pytest.approx(2 * y[1, 4] - y[2, 4])  # the line on
    keep = np.ones(600, dtype=bool)
    keep[[0, 300, 301]] = False
    assert np.array_equal(fixed[keep], y[keep])
