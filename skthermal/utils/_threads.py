"""Thread control for loops of many small BLAS calls."""

import functools

from threadpoolctl import ThreadpoolController

_CONTROLLER = None


def single_threaded_blas():
    """Context manager limiting BLAS to one thread, as scikit-learn's KMeans does.

    Loops of small matrix products (fuzzy c-means iterations, modal
    simulation) spend more time waking and synchronising BLAS threads than
    computing; on a busy machine a multi-threaded BLAS can be tens of times
    slower.
    """
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


def with_single_threaded_blas(func):
    """Decorator: ``func`` runs under :func:`single_threaded_blas`.

    For whole computations made of small arrays (a gap diagnosis, a
    calibration): their worker processes already get one BLAS thread each
    from joblib, and in the calling process more threads only wait on each
    other (4-5 times slower serial diagnoses on a loaded 2-core machine).
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with single_threaded_blas():
            return func(*args, **kwargs)

    return wrapper
