"""Optional dependencies: imported when needed, with an error naming the extra.

Plotting needs matplotlib (the ``plot`` extra), Parquet files pyarrow
(``parquet``), saving models skops (``deploy``), searches optuna (``optuna``).
A missing one is reported once, the same way everywhere: what needed it and
the command that installs it.
"""

import importlib


def missing_dependency(package, *, extra=None, caller):
    """The ImportError for a missing optional ``package``.

    Parameters
    ----------
    package : str
        Distribution to install, e.g. ``"matplotlib"``.
    extra : str or None, default=None
        skthermal's extra that installs it; None: install ``package`` itself.
    caller : str
        What needs it, e.g. ``"PredictionDisplay.plot"``.

    Returns
    -------
    ImportError
    """
    install = f'"skthermal[{extra}]"' if extra else package
    return ImportError(
        f"{caller} requires {package}. Install it with pip install {install}."
    )


def import_optional(module, *, extra=None, caller):
    """Import ``module``, or raise :func:`missing_dependency`'s ImportError.

    Parameters
    ----------
    module : str
        Module to import, e.g. ``"matplotlib.pyplot"``; its top-level package
        is named in the error.
    extra, caller
        As in :func:`missing_dependency`.

    Returns
    -------
    module
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        package = module.partition(".")[0]
        raise missing_dependency(package, extra=extra, caller=caller) from exc
