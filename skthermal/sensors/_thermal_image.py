"""Virtual temperature sensors from thermal-image stacks, and simulated stacks.

A thermal imaging camera records a sequence of temperature fields across a
machine structure; every pixel is a possible measuring point (001 §4.4). The
:class:`VirtualSensorExtractor` turns an image stack into a handful to hundreds
of *virtual sensors*: it averages consecutive frames (temporal noise), averages
square pixel groups into *spots* (pixel noise, and the footprint of a real
sensor), places spots on a grid, at given centres or along lines (*strips*),
and returns run-table columns ``T<name>_C``. :func:`simulate_thermal_images`
renders a stack of the spindle carrier of a simulated machine, frame by frame
in step with a simulated run, so the whole workflow (hundreds of spots -> grey
influence and fuzzy clustering -> a few sensors -> a model) can be tried
without a camera.
"""

import re
import warnings
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state, check_scalar
from sklearn.utils._param_validation import Interval, validate_params

from skthermal._naming import TEMPERATURE_PATTERN
from skthermal.utils._runs import ABSOLUTE_ZERO_C, check_run_label, is_clock_dtype
from skthermal.utils._warnings import user_stacklevel

_NAME = re.compile(r"[A-Za-z0-9]+")
# Frames processed at once: bounds the memory of the integral images.
_CHUNK_PIXELS = 1 << 23


# Median image reading that looks like kelvin rather than °C: a machine in
# a workshop reads 250-400 K; in °C no machine part is that warm.
_KELVIN_LIKE = (250.0, 400.0)


def _as_stack(stack, what="stack"):
    try:
        arr = np.asarray(stack, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"The {what} must be a numeric array of frames (n_frames, height, width)."
        ) from None
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or 0 in arr.shape:
        raise ValueError(
            f"The {what} must have shape (n_frames, height, width) or (height, "
            f"width), got shape {np.shape(stack)}."
        )
    return arr


def _check_image_temperatures(valid, mask):
    """Refuse images below absolute zero, and warn of images that read like
    kelvin (a camera export of about 293 for a room at 20 °C): the virtual
    sensors are ``T<name>_C`` columns, in °C. ``valid``: the frames' pixels
    where ``mask`` holds, ``(n_frames, n_pixels)``."""
    cold = valid <= ABSOLUTE_ZERO_C
    if cold.any():
        f, p = np.argwhere(cold)[0]
        r, c = np.argwhere(mask)[p]
        raise ValueError(
            f"The stack reads {valid[f, p]:g} at frame {f}, pixel (row {r}, col "
            f"{c}): below absolute zero ({ABSOLUTE_ZERO_C:g} °C). The images "
            "must be temperatures in °C."
        )
    median = float(np.median(valid))
    if _KELVIN_LIKE[0] <= median <= _KELVIN_LIKE[1]:
        warnings.warn(
            f"The images read a median of {median:.4g}: like kelvin, not °C (a "
            "room at 20 °C is 293 K). The virtual sensors are °C columns; "
            "subtract 273.15 from a kelvin export.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


def _seconds(time_s):
    """``time_s`` as float seconds; datetimes, durations and text are errors
    (``np.asarray(..., float)`` would read datetimes as nanoseconds)."""
    kind = getattr(time_s, "dtype", None)
    arr = np.asarray(time_s)
    if (kind is not None and is_clock_dtype(kind)) or is_clock_dtype(arr.dtype):
        raise ValueError(
            f"time_s holds {arr.dtype} values; it must hold the seconds since the "
            "start of the run as numbers, e.g. (t - t[0]).total_seconds()."
        )
    try:
        return np.asarray(arr, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"time_s must hold numbers (seconds), got values such as {arr.ravel()[:1]}."
        ) from None


def _block_mean(a, k):
    """Means of ``k`` consecutive rows (axis 0); an incomplete last block is
    dropped."""
    n = (a.shape[0] // k) * k
    return a[:n].reshape(n // k, k, *a.shape[1:]).mean(axis=1)


def _integral(a):
    """Summed-area table with a zero first row and column (last two axes)."""
    out = np.zeros((*a.shape[:-2], a.shape[-2] + 1, a.shape[-1] + 1))
    np.cumsum(a, axis=-2, out=out[..., 1:, 1:])
    np.cumsum(out[..., 1:, 1:], axis=-1, out=out[..., 1:, 1:])
    return out


def _box_sums(S, r0, r1, c0, c1):
    """Sums over the boxes ``[r0, r1) x [c0, c1)`` from a summed-area table."""
    return S[..., r1, c1] - S[..., r0, c1] - S[..., r1, c0] + S[..., r0, c0]


class VirtualSensorExtractor:
    """Spot and strip temperatures from a thermal-image stack.

    The "virtual sensors" of 001 §4.4: frames are averaged in blocks of
    ``frame_average`` consecutive frames, and the pixels of square groups of
    ``spot_size`` x ``spot_size`` pixels are averaged into one reading per
    spot. Spots are placed on a regular grid over the object (``grid``; 525
    spots covered the spindle carrier of 001 Fig. 4-10), at given pixel
    centres (``centres``), or along lines (``strips``: evenly spaced spots
    from one point to another, the "strips" of 001 Table 4-4).

    This is a plain class, not a scikit-learn transformer, on purpose: its
    input is a 3-D image stack, not a 2-D feature matrix; frame averaging
    changes the number of rows, which a Pipeline step must not do (the
    targets would no longer line up); and nothing is learned from data, the
    layout is geometry. Its output is a run table, the input of the
    scikit-learn part of the workflow (selectors, regressors).

    Parameters
    ----------
    spot_size : int, default=3
        Side of the square pixel group averaged into a spot. A spot centred
        on pixel ``(r, c)`` covers rows ``r - (spot_size - 1) // 2`` onwards
        (for an even size the extra row and column lie after the centre).
    grid : (int, int) or None, default=None
        ``(n_rows, n_cols)`` spots evenly spread over the bounding box of
        ``mask`` (of the whole image without a mask), each in the middle of
        its cell; spots covering less than ``min_coverage`` of valid pixels
        are left out. Named ``Tspot001_C``, ``Tspot002_C``, ... row by row.
    centres : array-like of shape (n_spots, 2), dict or None, default=None
        Spot centres as ``(row, col)`` pixel coordinates: an array (numbered
        after the grid spots, ``Tspot<k>_C``) or a dict ``{name: (row, col)}``
        (columns ``T<name>_C``). A spot is centred on a pixel: fractional
        coordinates are rounded to the nearest one (halves to the even one,
        as ``numpy.rint``).
    strips : dict or None, default=None
        ``{name: ((row0, col0), (row1, col1), n_spots)}``: ``n_spots`` spots
        evenly spaced on the line from the first to the second pixel, both
        included, columns ``Tstrip<name>_<k>_C`` (``k`` from 01).
    mask : array-like of bool of shape (height, width) or None, default=None
        Valid pixels (the object; masking tape of known emissivity). A spot
        averages only its valid pixels. None: every pixel is valid.
    min_coverage : float in (0, 1], default=0.5
        Least fraction of a spot's pixel group that must be valid (inside the
        image and the mask). Grid spots below it are dropped; a centre or a
        strip spot below it is an error.
    frame_average : int, default=1
        Number of consecutive frames averaged into one sample (non-
        overlapping blocks; an incomplete last block is dropped).

    Attributes
    ----------
    image_shape_ : tuple of int
        ``(height, width)`` of the images seen in :meth:`fit`.
    spots_ : DataFrame
        One row per virtual sensor, indexed by its column name: ``row``,
        ``col`` (centre pixel), ``row0``, ``row1``, ``col0``, ``col1`` (the
        pixel group, end exclusive, clipped to the image), ``n_pixels``
        (valid pixels averaged), ``kind`` (``"grid"``, ``"centre"`` or
        ``"strip"``) and ``strip`` (its strip name, or empty).
    n_sensors_ : int
        Number of virtual sensors.

    See Also
    --------
    simulate_thermal_images : a simulated stack of a spindle carrier.
    skthermal.selection.FCMClusterPicker : picks a few of many spots.

    Notes
    -----
    001 §4.4 (frame averaging, pixel-group averaging, strips, 525 spots) and
    §4.4.1. Pixel groups are summed with a summed-area table (integral image),
    so the cost does not grow with ``spot_size``; frames are processed in
    chunks of a few million pixels.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.sensors import VirtualSensorExtractor
    >>> frames = np.arange(4 * 6 * 8, dtype=float).reshape(4, 6, 8)
    >>> ext = VirtualSensorExtractor(spot_size=2, centres={"a": (0, 0)},
    ...                              strips={1: ((4, 0), (4, 6), 3)},
    ...                              frame_average=2)
    >>> table = ext.fit(frames).transform(frames, time_s=[0, 10, 20, 30])
    >>> list(table.columns)
    ['time_s', 'Ta_C', 'Tstrip1_01_C', 'Tstrip1_02_C', 'Tstrip1_03_C']
    >>> table.round(2).to_numpy().tolist()[0]
    [5.0, 28.5, 60.5, 63.5, 66.5]
    """

    def __init__(
        self,
        *,
        spot_size=3,
        grid=None,
        centres=None,
        strips=None,
        mask=None,
        min_coverage=0.5,
        frame_average=1,
    ):
        self.spot_size = spot_size
        self.grid = grid
        self.centres = centres
        self.strips = strips
        self.mask = mask
        self.min_coverage = min_coverage
        self.frame_average = frame_average

    def __repr__(self):
        args = [f"spot_size={self.spot_size}"]
        for key in ("grid", "frame_average"):
            args.append(f"{key}={getattr(self, key)!r}")
        return f"VirtualSensorExtractor({', '.join(args)})"

    # ------------------------------------------------------------ layout

    def _check_params(self, shape):
        check_scalar(self.spot_size, "spot_size", Integral, min_val=1)
        check_scalar(self.frame_average, "frame_average", Integral, min_val=1)
        check_scalar(
            self.min_coverage,
            "min_coverage",
            Real,
            min_val=0,
            max_val=1,
            include_boundaries="right",
        )
        if self.grid is None and self.centres is None and self.strips is None:
            raise ValueError(
                "Place some spots: give grid=(n_rows, n_cols), centres or strips."
            )
        if self.mask is None:
            mask = np.ones(shape, dtype=bool)
        else:
            # A copy: the user's array may change after fit.
            mask = np.array(self.mask, copy=True)
            if mask.shape != shape:
                raise ValueError(
                    f"mask has shape {mask.shape} but the images are {shape}."
                )
            if mask.dtype != bool:
                if not np.isin(mask, (0, 1)).all():
                    raise ValueError("mask must be boolean (or 0/1).")
                mask = mask.astype(bool)
            if not mask.any():
                raise ValueError("mask has no valid pixel.")
        return mask

    def _grid_centres(self, mask):
        grid = self.grid
        if (
            not isinstance(grid, tuple | list)
            or len(grid) != 2
            or any(isinstance(g, bool) or not isinstance(g, Integral) for g in grid)
            or min(grid) < 1
        ):
            raise ValueError(
                f"grid must be (n_rows, n_cols), two integers >= 1, got {grid!r}."
            )
        rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(0))
        r_lo, r_hi, c_lo, c_hi = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        if grid[0] > r_hi - r_lo or grid[1] > c_hi - c_lo:
            raise ValueError(
                f"grid={tuple(grid)} is finer than the valid pixels span "
                f"({r_hi - r_lo} rows x {c_hi - c_lo} columns): spots would share "
                f"centres; use at most grid=({min(grid[0], r_hi - r_lo)}, "
                f"{min(grid[1], c_hi - c_lo)})."
            )
        rc = np.floor(r_lo + (np.arange(grid[0]) + 0.5) * (r_hi - r_lo) / grid[0])
        cc = np.floor(c_lo + (np.arange(grid[1]) + 0.5) * (c_hi - c_lo) / grid[1])
        R, C = np.meshgrid(rc.astype(int), cc.astype(int), indexing="ij")
        return np.column_stack([R.ravel(), C.ravel()])

    @staticmethod
    def _points(points, what):
        try:
            arr = np.asarray(points, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{what} must be (row, col) pixel coordinates.") from None
        if arr.ndim != 2 or arr.shape[1] != 2 or not np.all(np.isfinite(arr)):
            raise ValueError(
                f"{what} must be finite (row, col) pixel coordinates, an array "
                f"of shape (n, 2); got shape {np.shape(points)}."
            )
        return np.rint(arr).astype(int)

    def _strip_spots(self):
        if not isinstance(self.strips, dict):
            raise ValueError(
                "strips must be a dict {name: ((row0, col0), (row1, col1), n_spots)}."
            )
        if not self.strips:
            raise ValueError(
                "strips is empty: give {name: ((row0, col0), (row1, col1), "
                "n_spots)}, or None for no strip."
            )
        names, kinds, strip_of, pts = [], [], [], []
        for name, spec in self.strips.items():
            label = str(name)
            if not _NAME.fullmatch(label):
                raise ValueError(
                    f"Strip name {name!r} must be letters and digits only "
                    "(it becomes part of the column name Tstrip<name>_<k>_C)."
                )
            try:
                start, end, n = spec
            except (TypeError, ValueError):
                raise ValueError(
                    f"Strip {name!r} must be ((row0, col0), (row1, col1), n_spots), "
                    f"got {spec!r}."
                ) from None
            n = check_scalar(n, f"n_spots of strip {name!r}", Integral, min_val=1)
            ends = self._points([start, end], f"The ends of strip {name!r}")
            t = np.linspace(0.0, 1.0, n) if n > 1 else np.zeros(1)
            line = np.rint(ends[0] + t[:, None] * (ends[1] - ends[0])).astype(int)
            span = int(np.abs(ends[1] - ends[0]).max()) + 1
            if n > span:
                raise ValueError(
                    f"Strip {name!r} has {n} spots over {span} pixel(s) from "
                    f"{tuple(ends[0].tolist())} to {tuple(ends[1].tolist())}: "
                    f"spots would share centres; use at most {span} spots."
                )
            width = max(2, len(str(n)))
            names += [f"Tstrip{label}_{k + 1:0{width}d}_C" for k in range(n)]
            kinds += ["strip"] * n
            strip_of += [label] * n
            pts.append(line)
        return names, kinds, strip_of, pts

    def fit(self, stack):
        """Lay out the spots for images of the shape of ``stack``.

        Parameters
        ----------
        stack : array-like of shape (n_frames, height, width) or (height, width)
            An image stack or one image; only its shape is used.

        Returns
        -------
        self : VirtualSensorExtractor
        """
        shape = _as_stack(stack).shape[1:]
        mask = self._check_params(shape)
        names, kinds, strip_of, pts = [], [], [], []
        n_numbered = 0
        if self.grid is not None:
            grid_pts = self._grid_centres(mask)
            cover = self._coverage(grid_pts, mask, shape)
            grid_pts = grid_pts[cover >= self.min_coverage]
            if grid_pts.shape[0] == 0:
                raise ValueError(
                    f"No grid spot covers min_coverage={self.min_coverage} of "
                    "valid pixels; lower it or check the mask."
                )
            pts.append(grid_pts)
            n_numbered += grid_pts.shape[0]
            kinds += ["grid"] * grid_pts.shape[0]
        centres = self.centres
        given = []
        if centres is not None:
            if isinstance(centres, dict):
                for name in centres:
                    if not _NAME.fullmatch(str(name)):
                        raise ValueError(
                            f"Spot name {name!r} must be letters and digits only "
                            "(the column is T<name>_C)."
                        )
                arr = self._points(list(centres.values()), "centres")
                given = [f"T{name}_C" for name in centres]
            else:
                arr = self._points(centres, "centres")
                n_numbered += arr.shape[0]
            pts.append(arr)
            kinds += ["centre"] * arr.shape[0]
        width = max(3, len(str(n_numbered)))
        names = [f"Tspot{k + 1:0{width}d}_C" for k in range(n_numbered)]
        names += given
        strip_of = [""] * len(names)
        if self.strips is not None:
            s_names, s_kinds, s_of, s_pts = self._strip_spots()
            names += s_names
            kinds += s_kinds
            strip_of += s_of
            pts += s_pts
        P = np.concatenate(pts, axis=0)
        dup = pd.Index(names)[pd.Index(names).duplicated()]
        if len(dup):
            raise ValueError(f"Two virtual sensors share the column {dup[0]!r}.")
        bad = [n for n in names if not TEMPERATURE_PATTERN.fullmatch(n)]
        if bad:
            raise ValueError(f"Invalid temperature column name {bad[0]!r}.")
        # Given centres that coincide (the grid's and the strips' spots are
        # kept apart where they are made).
        given_at = [k for k, kind in enumerate(kinds) if kind == "centre"]
        seen = {}
        for k in given_at:
            j = seen.setdefault(tuple(P[k]), k)
            if j != k:
                raise ValueError(
                    f"Virtual sensors {names[j]!r} and {names[k]!r} share the "
                    f"centre (row {P[k, 0]}, col {P[k, 1]}): they would read the "
                    "same pixels, two copies of one column. Give distinct "
                    "centres."
                )
        inside = (P[:, 0] >= 0) & (P[:, 0] < shape[0]) & (P[:, 1] >= 0)
        inside &= P[:, 1] < shape[1]
        cover = self._coverage(P, mask, shape)
        explicit = np.array([k != "grid" for k in kinds])
        low = explicit & ((cover < self.min_coverage) | ~inside)
        if low.any():
            j = int(np.flatnonzero(low)[0])
            raise ValueError(
                f"Virtual sensor {names[j]!r} at pixel (row {P[j, 0]}, col "
                f"{P[j, 1]}) covers {cover[j]:.0%} valid pixels of its "
                f"{self.spot_size}x{self.spot_size} group, below min_coverage="
                f"{self.min_coverage} (images are {shape[0]}x{shape[1]})."
            )
        r0, r1, c0, c1 = self._boxes(P, shape)
        counts = _box_sums(_integral(mask.astype(float)), r0, r1, c0, c1)
        self.image_shape_ = tuple(int(s) for s in shape)
        self.spots_ = pd.DataFrame(
            {
                "row": P[:, 0],
                "col": P[:, 1],
                "row0": r0,
                "row1": r1,
                "col0": c0,
                "col1": c1,
                "n_pixels": counts.round().astype(int),
                "kind": kinds,
                "strip": strip_of,
            },
            index=pd.Index(names, name="sensor"),
        )
        self.n_sensors_ = len(names)
        self._mask = mask
        return self

    def _boxes(self, P, shape):
        lo = (self.spot_size - 1) // 2
        r0 = np.clip(P[:, 0] - lo, 0, shape[0])
        c0 = np.clip(P[:, 1] - lo, 0, shape[1])
        r1 = np.clip(P[:, 0] - lo + self.spot_size, 0, shape[0])
        c1 = np.clip(P[:, 1] - lo + self.spot_size, 0, shape[1])
        return r0, r1, c0, c1

    def _coverage(self, P, mask, shape):
        r0, r1, c0, c1 = self._boxes(P, shape)
        valid = _box_sums(_integral(mask.astype(float)), r0, r1, c0, c1)
        return valid / self.spot_size**2

    # --------------------------------------------------------- transform

    def _check_fitted(self):
        if not hasattr(self, "spots_"):
            raise ValueError(
                "This VirtualSensorExtractor is not fitted yet; call fit(stack) first."
            )

    def get_feature_names_out(self):
        """Column names of the virtual sensors, in output order."""
        self._check_fitted()
        return np.asarray(self.spots_.index, dtype=object)

    def spot_labels(self):
        """Image of spot numbers: pixel -> 1 + index of the spot covering it.

        0 where no spot lies; where spots overlap the later one wins. Handy
        for drawing the layout over a frame.
        """
        self._check_fitted()
        labels = np.zeros(self.image_shape_, dtype=int)
        s = self.spots_
        for k, (r0, r1, c0, c1) in enumerate(
            s[["row0", "row1", "col0", "col1"]].to_numpy()
        ):  # one slice per spot, not per pixel
            labels[r0:r1, c0:c1] = np.where(
                self._mask[r0:r1, c0:c1], k + 1, labels[r0:r1, c0:c1]
            )
        return labels

    def transform(self, stack, time_s=None, *, run=None, extra=None):
        """Virtual sensor readings, one row per block of averaged frames.

        Parameters
        ----------
        stack : array-like of shape (n_frames, height, width)
            Temperature images (°C), in time order.
        time_s : array-like of shape (n_frames,), optional
            Time of every frame; block means become the ``time_s`` column.
        run : label, optional
            Adds a ``run`` column with this label (first column).
        extra : DataFrame or dict of array-like of shape (n_frames,), optional
            Other per-frame series (a measured displacement, a driver) to
            average over the same blocks and append, so they stay aligned
            with the sensors.

        Returns
        -------
        DataFrame of shape (n_frames // frame_average, n_columns)
            ``run`` (if given), ``time_s`` (if given), one ``T<name>_C``
            column per virtual sensor, then the ``extra`` columns.
        """
        self._check_fitted()
        if np.ndim(stack) == 2 and time_s is not None and np.size(time_s) > 1:
            h, w = self.image_shape_
            raise ValueError(
                f"The stack of shape {np.shape(stack)} is one image, but time_s "
                f"holds {np.size(time_s)} times: give the frames as (n_frames, "
                f"height, width), e.g. a flattened (n_frames, n_pixels) stack as "
                f"stack.reshape(-1, {h}, {w})."
            )
        frames = _as_stack(stack)
        if frames.shape[1:] != self.image_shape_:
            raise ValueError(
                f"The images are {frames.shape[1]}x{frames.shape[2]} but the "
                f"extractor was fitted on {self.image_shape_[0]}x"
                f"{self.image_shape_[1]} images."
            )
        n, k = frames.shape[0], self.frame_average
        if n < k:
            raise ValueError(
                f"The stack has {n} frame(s), fewer than frame_average={k}."
            )
        valid = frames[:, self._mask]
        bad = ~np.isfinite(valid)
        if bad.any():
            f, p = np.argwhere(bad)[0]
            r, c = np.argwhere(self._mask)[p]
            raise ValueError(
                f"The stack is NaN or infinite at frame {f}, pixel (row {r}, "
                f"col {c}); repair or mask the pixel."
            )
        _check_image_temperatures(valid, self._mask)
        columns = {}
        if run is not None:
            check_run_label(run)
            columns["run"] = None
        if time_s is not None:
            t = _seconds(time_s)
            if t.shape != (n,) or not np.all(np.isfinite(t)):
                raise ValueError(
                    f"time_s must hold {n} finite times, one per frame, got shape "
                    f"{t.shape}."
                )
            if np.any(np.diff(t) <= 0):
                row = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
                raise ValueError(
                    f"time_s must increase strictly: frame {row} has time "
                    f"{t[row]:g} after {t[row - 1]:g}."
                )
            columns["time_s"] = _block_mean(t, k)
        values = self._readings(frames)
        columns.update(zip(self.spots_.index, values.T, strict=True))
        if extra is not None:
            if isinstance(extra, pd.Series):
                raise ValueError(
                    "extra is a Series; give a DataFrame or a dict {name: values} "
                    f"(e.g. extra={{{str(extra.name or 'name')!r}: series}})."
                )
            items = extra.items() if hasattr(extra, "items") else None
            if items is None:
                raise ValueError("extra must be a DataFrame or a dict of series.")
            for name, series in items:
                if name in columns:
                    raise ValueError(f"extra column {name!r} clashes with an output.")
                try:
                    arr = np.asarray(series, dtype=float)
                except (TypeError, ValueError):
                    raise ValueError(f"extra column {name!r} is not numeric.") from None
                if arr.shape != (n,):
                    raise ValueError(
                        f"extra column {name!r} has shape {arr.shape}; it needs one "
                        f"value per frame ({n})."
                    )
                bad = np.flatnonzero(~np.isfinite(arr))
                if bad.size:
                    raise ValueError(
                        f"extra column {name!r} is missing or infinite at frame "
                        f"{bad[0]} ({bad.size} frame(s)); a run table column "
                        "holds a number on every row."
                    )
                columns[name] = _block_mean(arr, k)
        n_out = n // k
        if run is not None:
            columns["run"] = np.full(n_out, run, dtype=object)
        return pd.DataFrame(columns)

    def fit_transform(self, stack, time_s=None, *, run=None, extra=None):
        """:meth:`fit` then :meth:`transform` on the same stack."""
        return self.fit(stack).transform(stack, time_s, run=run, extra=extra)

    def _readings(self, frames):
        k = self.frame_average
        s = self.spots_
        r0, r1, c0, c1 = (s[c].to_numpy() for c in ("row0", "row1", "col0", "col1"))
        count = s["n_pixels"].to_numpy(float)
        n_out = frames.shape[0] // k
        out = np.empty((n_out, len(s)))
        per_chunk = max(1, _CHUNK_PIXELS // (frames.shape[1] * frames.shape[2] * k))
        for a in range(0, n_out, per_chunk):  # chunks of frames bound the memory
            b = min(a + per_chunk, n_out)
            block = np.where(self._mask, _block_mean(frames[a * k : b * k], k), 0.0)
            out[a:b] = _box_sums(_integral(block), r0, r1, c0, c1) / count
        return out


# --------------------------------------------------------------------------
# Simulated thermal images of a spindle carrier
# --------------------------------------------------------------------------


@dataclass
class ThermalImageRun:
    """A simulated run with its thermal-image stack.

    Attributes
    ----------
    frames : ndarray of shape (n_frames, height, width)
        Apparent temperatures (°C), one frame per row of ``runs``.
    time_s : ndarray of shape (n_frames,)
    runs : DataFrame
        The simulated run table (drivers, the machine's sensors, displacements).
    states : DataFrame
        Node temperatures behind the frames.
    mask : ndarray of bool of shape (height, width)
        Pixels on the machine (carrier, spindle boss, tool).
    regions : ndarray of int of shape (height, width)
        0 background, 1 carrier, 2 spindle boss, 3 tool.
    """

    frames: np.ndarray
    time_s: np.ndarray
    runs: pd.DataFrame
    states: pd.DataFrame
    mask: np.ndarray
    regions: np.ndarray


REGIONS = ("background", "carrier", "spindle boss", "tool")


@validate_params(
    {
        "nodes": "no_validation",
        "shape": "no_validation",  # a pair, checked with its own message
        "blur_px": [Interval(Real, 0, None, closed="left")],
    },
    prefer_skip_nested_validation=True,
)
def carrier_field_weights(nodes, shape, *, blur_px=1.0):
    """Linear map from node temperatures to the pixels of a carrier image.

    The scene (rows top to bottom, columns spindle end to column):
    the carrier, a beam over ``[0.15, 0.55) H x [0.22, 0.97) W`` whose
    temperature is interpolated linearly along its length between the
    ``carrier1..carrierN`` nodes (``carrier1`` at the spindle end); the
    spindle boss ``[0.30, 0.75) H x [0.04, 0.22) W``; the tool (test bar)
    ``[0.75, 0.97) H x [0.10, 0.16) W``; the rest is background at the
    enclosure air. Two hot spots blend into the carrier: the spindle motor,
    a Gaussian of weight 0.6 centred a third along the top edge, and the
    boss, whose weight ``0.5 exp(-u / 0.06)`` fades along the first few
    percent of the carrier (``u`` = fraction of its length). A Gaussian blur
    of ``blur_px`` pixels (the camera's optics) smooths the edges; every
    pixel stays a weighted mean of node temperatures (weights sum to one).

    Parameters
    ----------
    nodes : sequence of str
        Node names of the machine; needs ``carrier1``.., ``boss``, ``motor``,
        ``tool`` and ``enclosure``.
    shape : (int, int)
        Image ``(height, width)``, at least 20 x 20.
    blur_px : float, default=1.0
        Standard deviation of the blur (pixels); 0 for none.

    Returns
    -------
    weights : ndarray of shape (n_nodes, height, width)
    regions : ndarray of int of shape (height, width)
        0 background, 1 carrier, 2 spindle boss, 3 tool (before the blur).
    """
    from scipy.ndimage import gaussian_filter

    nodes = list(nodes)
    carrier = sorted(
        (n for n in nodes if re.fullmatch(r"carrier\d+", n)),
        key=lambda n: int(n[7:]),
    )
    missing = [n for n in ("boss", "motor", "tool", "enclosure") if n not in nodes]
    if len(carrier) < 2 or missing:
        raise ValueError(
            "A carrier image needs nodes carrier1..carrierN (N >= 2), boss, motor, "
            f"tool and enclosure; missing {missing or ['carrier nodes']}."
        )
    if (
        not isinstance(shape, tuple | list)
        or len(shape) != 2
        or any(isinstance(s, bool) or not isinstance(s, Integral) for s in shape)
        or min(shape) < 20
    ):
        raise ValueError(f"shape must be (height, width), both >= 20, got {shape!r}.")
    H, W = int(shape[0]), int(shape[1])
    idx = {n: i for i, n in enumerate(nodes)}
    rows = (np.arange(H) + 0.5) / H
    cols = (np.arange(W) + 0.5) / W
    R, C = np.meshgrid(rows, cols, indexing="ij")

    def box(r0, r1, c0, c1):
        return (R >= r0) & (R < r1) & (C >= c0) & (C < c1)

    regions = np.zeros((H, W), dtype=int)
    regions[box(0.15, 0.55, 0.22, 0.97)] = 1
    regions[box(0.30, 0.75, 0.04, 0.22)] = 2
    regions[box(0.75, 0.97, 0.10, 0.16)] = 3
    weights = np.zeros((len(nodes), H, W))
    weights[idx["enclosure"]] = regions == 0

    on_carrier = regions == 1
    u = np.clip((C - 0.22) / (0.97 - 0.22), 0.0, 1.0)
    x = u * (len(carrier) - 1)
    lo = np.minimum(np.floor(x).astype(int), len(carrier) - 2)
    frac = x - lo
    motor = 0.6 * np.exp(-0.5 * (((u - 0.3) / 0.08) ** 2 + ((R - 0.2) / 0.06) ** 2))
    boss = 0.5 * np.exp(-u / 0.06)
    base = (1.0 - motor - boss) * on_carrier
    cidx = np.array([idx[c] for c in carrier])
    rr, cc = np.nonzero(on_carrier)
    np.add.at(weights, (cidx[lo[rr, cc]], rr, cc), base[rr, cc] * (1 - frac[rr, cc]))
    np.add.at(weights, (cidx[lo[rr, cc] + 1], rr, cc), base[rr, cc] * frac[rr, cc])
    weights[idx["motor"]] += motor * on_carrier
    weights[idx["boss"]] += boss * on_carrier + (regions == 2)
    weights[idx["tool"]] += regions == 3
    if blur_px > 0:
        weights = gaussian_filter(weights, sigma=(0, blur_px, blur_px), mode="nearest")
    return weights, regions


@validate_params(
    {
        "blur_px": [Interval(Real, 0, None, closed="left")],
        "noise_C": [Interval(Real, 0, None, closed="left")],
        "fixed_pattern_C": [Interval(Real, 0, None, closed="left")],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def simulate_thermal_images(
    machine,
    duty,
    ambient=None,
    *,
    shape=(60, 80),
    sample_period_s=30.0,
    run="run1",
    emissivity=0.95,
    blur_px=1.0,
    noise_C=0.1,
    fixed_pattern_C=0.05,
    random_state=None,
):
    """Simulate a run and a thermal-image stack of the spindle carrier.

    The machine is simulated with :meth:`ThermalMachine.simulate` (one frame
    per sample, as a camera storing an image every ``sample_period_s``; 001
    §4.4 used 10 s); every frame is the node temperatures mapped to pixels by
    :func:`carrier_field_weights`, seen through a linearised radiometric model
    and camera noise:

    ``T_app = eps T + (1 - eps) T_refl + o_pixel + e_frame,pixel``

    with ``eps`` the surface emissivity (machine pixels; the background is
    air), ``T_refl`` the reflected surroundings (the enclosure air), ``o`` a
    fixed-pattern offset per pixel (``N(0, fixed_pattern_C)``, the same in
    every frame) and ``e`` temporal noise (``N(0, noise_C)``, the camera's
    NETD). The linear emissivity model holds for the few kelvin between a
    machine and its surroundings.

    Parameters
    ----------
    machine : ThermalMachine
        A machine with carrier nodes, e.g. ``ThermalMachine.from_preset("vmc-b")``.
    duty : DutyCycle or sequence of (duration_s, spindle_rpm[, feed_mm_min])
    ambient : AmbientProfile, float or None
        As in :meth:`ThermalMachine.simulate`.
    shape : (int, int), default=(60, 80)
        Image ``(height, width)``.
    sample_period_s : float, default=30.0
        Time between frames (and rows of the run table).
    run : label, default="run1"
    emissivity : float in (0, 1] or array of shape ``shape``, default=0.95
        0.95: painted metal or masking tape (001 §4.4 taped the machine for a
        known emissivity); bare machined steel is nearer 0.1-0.3.
    blur_px : float, default=1.0
        Optical blur (pixels).
    noise_C : float, default=0.1
        Temporal noise per pixel and frame (°C).
    fixed_pattern_C : float, default=0.05
        Fixed-pattern offset per pixel (°C).
    random_state : int, RandomState instance or None
        Seeds the simulation noise and the camera noise.

    Returns
    -------
    ThermalImageRun
        ``frames``, ``time_s``, the run table ``runs``, the node ``states``,
        the machine ``mask`` and ``regions``.

    Examples
    --------
    >>> from skthermal.simulate import DutyCycle, ThermalMachine
    >>> from skthermal.sensors import simulate_thermal_images
    >>> sim = simulate_thermal_images(ThermalMachine.from_preset("vmc-b"),
    ...                               DutyCycle.heat_cool(8000, heat_h=1, cool_h=1),
    ...                               sample_period_s=60, random_state=0)
    >>> sim.frames.shape, len(sim.runs)
    ((121, 60, 80), 121)
    >>> hot = sim.frames[60] - sim.frames[0]
    >>> bool(hot[sim.regions == 2].mean() > hot[sim.regions == 1].mean() > 1.0)
    True
    """
    if not (hasattr(machine, "simulate") and hasattr(machine, "spec")):
        raise ValueError(
            "machine must be a ThermalMachine (e.g. ThermalMachine.from_preset("
            f"'vmc-b')), got {type(machine).__name__}."
        )
    weights, regions = carrier_field_weights(machine.spec.nodes, shape, blur_px=blur_px)
    H, W = regions.shape
    try:
        eps = np.asarray(emissivity, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"emissivity must be a number or an array of numbers, got {emissivity!r}."
        ) from None
    if eps.ndim == 0:
        eps = np.full((H, W), float(eps))
    if eps.shape != (H, W):
        raise ValueError(
            f"emissivity must be a number or an array of shape {(H, W)}, got shape "
            f"{np.shape(emissivity)}."
        )
    if not np.all((eps > 0) & (eps <= 1)):
        raise ValueError("emissivity must lie in (0, 1].")
    rng = check_random_state(random_state)
    runs, states = machine.simulate(
        duty,
        ambient,
        sample_period_s=sample_period_s,
        run=run,
        random_state=rng,
        return_states=True,
    )
    T = states.to_numpy()
    true = (T @ weights.reshape(len(machine.spec.nodes), -1)).reshape(-1, H, W)
    refl = T[:, list(machine.spec.nodes).index(machine.spec.enclosure)]
    mask = regions > 0
    e = np.where(mask, eps, 1.0)
    frames = e * true + (1.0 - e) * refl[:, None, None]
    frames += rng.normal(0.0, fixed_pattern_C, (H, W))
    frames += rng.normal(0.0, noise_C, frames.shape)
    return ThermalImageRun(
        frames=frames,
        time_s=runs["time_s"].to_numpy(),
        runs=runs,
        states=states,
        mask=mask,
        regions=regions,
    )
