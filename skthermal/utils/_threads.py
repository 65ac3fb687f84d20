"""Thread control for loops of many small BLAS calls."""

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
