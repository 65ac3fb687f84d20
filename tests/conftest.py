"""Shared fixtures: a fixed seed and the project's reference data folder."""

import os
from pathlib import Path

import numpy as np
import pytest


@pytest.fixture(scope="session", autouse=True)
def _one_blas_thread_per_worker():
    """With pytest-xdist, one BLAS thread per worker process.

    The workers already use every core; OpenBLAS threads on top of them
    oversubscribe the cores and slow the linear-algebra-heavy tests several
    fold (its threads busy-wait).
    """
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture
def seed():
    return 42


@pytest.fixture
def rng(seed):
    return np.random.default_rng(seed)


@pytest.fixture
def shared_data():
    """Folder of the real reference data (``../shared/data``), or skip."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"reference data folder {SHARED_DATA} is absent")
    return SHARED_DATA


def shared_file(*parts):
    """Path of a reference data file, skipping the test when it is absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"reference data file {path} is absent")
    return path
