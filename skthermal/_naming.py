"""Column-naming patterns of the run table (DATA_FORMAT), and the names
and values that error messages show.

The patterns sit below every package, so that :mod:`skthermal.sensors` (which
the simulator uses) can name the channels it adds without importing
:mod:`skthermal.datasets` (which holds campaigns simulated with the
simulator). :mod:`skthermal.datasets` builds its checks and messages on them.
"""

import difflib
import re

import numpy as np

# <name> of a sensor or an axis: ASCII letters and digits, inner underscores.
NAME = r"[A-Za-z0-9]+(?:_[A-Za-z0-9]+)*"
TEMPERATURE_PATTERN = re.compile(rf"T{NAME}_C")
STRAIN_PATTERN = re.compile(rf"S{NAME}_ue")
TARGET_PATTERN = re.compile(rf"disp_{NAME}_um")


# A column that breaks a naming rule only in its separators or case:
# (kind, its start to drop, its end to drop, the rule's start and end, rule).
_RENAMES = (
    ("a temperature sensor", "t", "_c", "T", "_C", TEMPERATURE_PATTERN),
    ("a strain sensor", "s", "_ue", "S", "_ue", STRAIN_PATTERN),
    ("a displacement", "disp", "_um", "disp_", "_um", TARGET_PATTERN),
)


def renamed(name, kind):
    """The name ``name`` (meant for ``kind``: ``"a temperature sensor"``,
    ``"a strain sensor"`` or ``"a displacement"``) has under its naming
    rule when only its separators or the case of its marks are off
    (``T_sp_front_C``: ``Tsp_front_C``), else None.

    >>> renamed("T_fb_C", "a temperature sensor")
    'Tfb_C'
    """
    norm = re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")
    lower = norm.lower()
    for meant, head, tail, start, end, rule in _RENAMES:
        if kind != meant or not (lower.startswith(head) and lower.endswith(tail)):
            continue
        core = norm[len(head) : len(norm) - len(tail)].strip("_")
        if norm.isupper():  # DISP_Z_UM: disp_z_um
            core = core.lower()
        candidate = f"{start}{core}{end}"
        return candidate if core and rule.fullmatch(candidate) else None
    return None


def closest(name, choices):
    """The one of ``choices`` closest to a mistyped ``name`` (as text), or
    None when none is close."""
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=1)
    return close[0] if close else None


def suggest(name, choices):
    """`` (did you mean 'x'?)`` for the closest of ``choices`` to a mistyped
    ``name``, or an empty string when none is close."""
    near = closest(name, choices)
    return f" (did you mean {near!r}?)" if near is not None else ""


def listed(items, most=3, *, sep=", ", show=str, more_sep=" "):
    """The first ``most`` of ``items`` (each through ``show``) joined by
    ``sep``, and how many more there are, for messages that name a few of
    many.

    >>> listed(["a", "b", "c", "d", "e"], show=repr)
    "'a', 'b', 'c' and 2 more"
    >>> listed(["x", "y"], 1, sep="; ", more_sep="; ")
    'x; and 1 more'
    """
    items = list(items)
    extra = len(items) - most
    text = sep.join(show(i) for i in items[:most])
    return text + (f"{more_sep}and {extra} more" if extra > 0 else "")


def plain(value):
    """A numpy scalar as the Python value, for messages: ``'r2'`` and ``3``,
    not ``np.str_('r2')`` and ``np.int64(3)``."""
    return value.item() if isinstance(value, np.generic) else value


def shown(value):
    """``repr`` of :func:`plain` ``value`` for messages, shortened for a huge
    integer (``10**400`` has 401 digits): its first digits and its size."""
    value = plain(value)
    text = repr(value)
    if isinstance(value, int) and not isinstance(value, bool) and len(text) > 40:
        digits = len(str(abs(value)))
        return f"{text[:12]}... (an integer of {digits} digits, about 1e{digits - 1})"
    return text


def compact(value):
    """A figure for report tables: two decimals, but three significant
    digits below 0.1 (a table in mm under a ``_um`` header read 0.00
    everywhere) and beyond a million; a missing figure ``—``.

    >>> compact(3.456), compact(0.001234), compact(0.0), compact(2e7)
    ('3.46', '0.00123', '0.00', '2e+07')
    """
    value = float(value)
    if not np.isfinite(value):
        return "—"
    if value == 0 or 0.1 <= abs(value) < 1e6:
        return f"{value:.2f}"
    return f"{value:.3g}"


def percent(share, below=None):
    """A share as a whole percentage for reports: ``-0.004`` reads ``0%``
    (not ``-0%``), ``0.516`` reads ``52%``; a missing share ``n/a``. A share
    under a threshold ``below`` that whole percents would round up to it
    gets a decimal, rounded down: ``percent(0.4996, below=0.5)`` reads
    ``49.9%``, not the ``50%`` a report then says falls short of 50%.

    >>> percent(0.516), percent(0.4956, below=0.5), percent(0.4956)
    ('52%', '49.5%', '50%')
    >>> percent(0.5051, below=0.5055)  # the threshold reads 50.55%
    '50.5%'
    """
    share = float(share)
    if not np.isfinite(share):
        return "n/a"
    if below is not None and share < below and round(share * 100) >= below * 100:
        for digits in (1, 2, 3):
            shown = np.floor(share * 100 * 10**digits) / 10**digits
            if shown < below * 100:
                return f"{shown:.{digits}f}%"
    return f"{round(share * 100)}%"


def removes(share, below=None):
    """``removes 52% of`` for a share of a gap taken away, ``adds 8% to``
    for one made larger (a negative share), for report sentences; ``below``
    as in :func:`percent`.

    >>> removes(0.516), removes(-0.08), removes(-0.004)
    ('removes 52% of', 'adds 8% to', 'removes 0% of')
    """
    if np.isfinite(float(share)) and round(float(share) * 100) < 0:
        return f"adds {percent(-float(share))} to"
    return f"removes {percent(share, below)} of"


def qualified_name(obj):
    """``module.qualname`` of a function or of an object's class: the same in
    every process (a default repr holds a memory address)."""
    name = getattr(obj, "__qualname__", None) or type(obj).__qualname__
    module = getattr(obj, "__module__", None) or type(obj).__module__
    return f"{module}.{name}"
