"""Shared helpers of the Display objects: lazy matplotlib import, time axes.

matplotlib is an optional dependency (the ``plot`` extra): it is imported only
when something is drawn, with an error that says how to install it.
"""

import numpy as np

from skthermal._optional import import_optional

_TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}


def check_matplotlib_support(caller_name):
    """Import ``matplotlib.pyplot``, or raise an ImportError naming the extra.

    Parameters
    ----------
    caller_name : str
        Name of the function or class that needs matplotlib, used in the
        error message.

    Returns
    -------
    module
        ``matplotlib.pyplot``.

    Raises
    ------
    ImportError
        If matplotlib is not installed.
    """
    return import_optional("matplotlib.pyplot", extra="plot", caller=caller_name)


def _time_scale(time, time_unit):
    """Time converted from seconds to ``time_unit`` and the axis label.

    ``time_unit="auto"`` picks hours for spans over three hours, minutes for
    spans over three minutes, seconds otherwise. ``None`` leaves the values
    (and datetimes) untouched.
    """
    if time_unit is None:
        return time, "time"
    if time_unit != "auto" and time_unit not in _TIME_UNITS:
        raise ValueError(
            f"time_unit must be 'auto', 's', 'min', 'h' or None, got {time_unit!r}."
        )
    if not np.issubdtype(np.asarray(time).dtype, np.number):
        return time, "time"
    t = np.asarray(time, dtype=float)
    if time_unit == "auto":
        time_unit = _unit_of_span(float(np.nanmax(t) - np.nanmin(t)) if t.size else 0.0)
    return t / _TIME_UNITS[time_unit], f"time ({time_unit})"


def _unit_of_span(span):
    """The ``"auto"`` time unit of a span of seconds."""
    return "h" if span > 3 * 3600 else "min" if span > 180 else "s"


def _time_unit(time, slices):
    """The ``"auto"`` time unit shared by the runs (``slices``) drawn side
    by side: that of the longest run (None for times that are no numbers,
    which :func:`_time_scale` leaves as they are)."""
    if not np.issubdtype(np.asarray(time).dtype, np.number):
        return None
    t = np.asarray(time, dtype=float)
    spans = [
        float(np.nanmax(t[sl]) - np.nanmin(t[sl]))
        for sl in slices
        if sl.stop > sl.start
    ]
    return _unit_of_span(max(spans, default=0.0))


def _index_level(obj, name):
    """Values of index level ``name`` of a pandas object, or None."""
    index = getattr(obj, "index", None)
    names = getattr(index, "names", None)
    if names is None or name not in names:
        return None
    return np.asarray(index.get_level_values(name))


def _as_1d(values, name):
    """A 1-D float array; a single-column DataFrame or (n, 1) array is squeezed."""
    arr = _floats(values, name)
    if arr.ndim != 1:
        raise ValueError(
            f"{name} must be one-dimensional (one target), got shape {arr.shape}; "
            "select one column, e.g. y['disp_y_um']."
        )
    if arr.size == 0:
        raise ValueError(f"{name} is empty.")
    return arr


def _per_sample(lead_name, lead, *, text=(), **arrays):
    """``lead`` as a non-empty 1-D float array, and every other array (None
    left out) as one value per sample of it: ``time`` numbers or datetimes
    that increase strictly, the arrays named in ``text`` as objects (labels),
    the rest as floats (an ``(n, 1)`` column squeezed). A ValueError names
    the first that is not. Returns ``(lead, {name: array})``."""
    lead = _floats(lead, lead_name)
    if lead.ndim != 1 or lead.size == 0:
        raise ValueError(
            f"{lead_name} must be a non-empty 1-D array, got shape {lead.shape}."
        )
    n = lead.size
    out = {}
    for name, values in arrays.items():
        if values is None:
            continue
        if name == "time":
            arr = np.asarray(values)
            if not (
                np.issubdtype(arr.dtype, np.number)
                or np.issubdtype(arr.dtype, np.datetime64)
            ):
                raise ValueError(
                    f"time must hold numbers (seconds) or datetimes, got "
                    f"{arr.dtype} values."
                )
        elif name in text:
            arr = np.asarray(values, dtype=object)
        else:
            arr = _floats(values, name)
        if arr.shape != (n,):
            raise ValueError(
                f"{name} must hold one value per {lead_name} sample ({n}), got "
                f"shape {arr.shape}."
            )
        if name == "time" and n > 1 and not np.all(arr[1:] > arr[:-1]):
            bad = int(np.flatnonzero(~(arr[1:] > arr[:-1]))[0]) + 1
            raise ValueError(
                f"time must increase strictly; sample {bad} has time {arr[bad]} "
                f"after {arr[bad - 1]}."
            )
        out[name] = arr
    return lead, out


def _floats(values, name):
    """``values`` as floats (an ``(n, 1)`` column squeezed to ``(n,)``); text
    is an error naming ``name``."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from exc
    return arr[:, 0] if arr.ndim == 2 and arr.shape[1] == 1 else arr


def _new_figure_or_axes(plt, ax, shape, caller, **subplots_kw):
    """Axes of the requested shape: new ones, or ``ax`` checked and reshaped."""
    if ax is None:
        fig, axes = plt.subplots(*shape, squeeze=False, **subplots_kw)
        return fig, axes
    axes = np.asarray(ax, dtype=object)
    if axes.size != int(np.prod(shape)):
        raise ValueError(
            f"{caller} needs {int(np.prod(shape))} Axes (shape {shape}) for this "
            f"data, got {axes.size}."
        )
    axes = axes.reshape(shape)
    return axes.flat[0].figure, axes
