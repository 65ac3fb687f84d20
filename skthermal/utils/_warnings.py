"""Where a warning points (the user's line, not the library's), and when
two warnings say the same."""

import os
import re
import sys
from pathlib import Path

import sklearn

# Frames in these folders are the library's or scikit-learn's (a Pipeline,
# a fit context), not the user's call.
_INSIDE = tuple(
    str(Path(module.__file__).parent) + os.sep
    for module in (sys.modules["skthermal"], sklearn)
)


def user_stacklevel():
    """The ``stacklevel`` that makes a ``warnings.warn`` in the calling
    function point at the first frame outside skthermal and scikit-learn:
    the line of the user's code that led there, however deep the call
    (``fit``, ``fit_transform``, a Pipeline, a fit context) and from any
    of the library's paths.

    Examples
    --------
    >>> import warnings
    >>> from skthermal.utils._warnings import user_stacklevel
    >>> def check():
    ...     warnings.warn("said where check() was called", stacklevel=user_stacklevel())
    """
    frame = sys._getframe(1)  # the function that calls warnings.warn
    level = 1
    while frame is not None:
        name = frame.f_code.co_filename
        # A dataclass's generated __init__ (calling __post_init__) has no file.
        generated = name == "<string>" and frame.f_code.co_name == "__init__"
        if not name.startswith(_INSIDE) and not generated:
            return level
        frame = frame.f_back
        level += 1
    return level


# Numbers in a warning's text, for telling the same warning with other
# figures from another one; not a run's label (run 2, or quoted: 'day 2').
_FIGURES = r"(?<![\w.])(?<!run )[-+]?\d+(\.\d+)?(e[-+]?\d+)?(?![\w])"


def without_figures(text):
    """A warning's ``text`` with its figures outside quotes as ``#``: equal
    for the same warning said with other counts or values ("1 gap(s)" and
    "2 gap(s)"), different for another sensor or run (quoted).

    Examples
    --------
    >>> from skthermal.utils._warnings import without_figures
    >>> without_figures("'T1_C' read 3.5 in run 2 (12 rows)")
    "'T1_C' read # in run 2 (# rows)"
    """
    parts = text.split("'")
    parts[::2] = [re.sub(_FIGURES, "#", p) for p in parts[::2]]
    return "'".join(parts)
