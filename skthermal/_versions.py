"""Versions of Python and of installed distributions, for saved metadata."""

import importlib.metadata
import platform


def package_versions(distributions, *, with_platform=False):
    """Installed version of each distribution (None when not installed).

    Parameters
    ----------
    distributions : iterable of str
        Distribution names as pip knows them, e.g. ``"scikit-learn"``.
    with_platform : bool, default=False
        Also record ``platform.platform()`` under ``"platform"``.

    Returns
    -------
    dict
        ``{"python": "3.x.y", ["platform": ...,] name: version or None}``.
    """
    out = {"python": platform.python_version()}
    if with_platform:
        out["platform"] = platform.platform()
    for name in distributions:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out
