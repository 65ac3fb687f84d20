"""What drives a simulated machine: duty cycles and ambient air profiles.

A :class:`DutyCycle` is a sequence of segments of constant spindle speed and
axis feed; an :class:`AmbientProfile` is the workshop air around the machine
(a mean, a trend, the day/night cycle, door events and fluctuations). Both are
sampled on the simulation grid.
"""

import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from sklearn.utils import check_random_state

from skthermal._naming import shown
from skthermal.utils._runs import AIR_RANGE_C, air_unit_guess, refuse_clock_values
from skthermal.utils._warnings import user_stacklevel


def _check_number(value, name, *, positive=False, nonnegative=False):
    try:
        value = float(value)
    except OverflowError:
        # An integer beyond the largest float (about 1.8e308), e.g. 10**400
        # in a TOML file, which reads integers exactly.
        raise ValueError(
            f"{name} must be a finite number (a float reaches about 1.8e308), "
            f"got {shown(value)}."
        ) from None
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {shown(value)}.") from None
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}.")
    if positive and value <= 0:
        raise ValueError(f"{name} must be positive, got {value}.")
    if nonnegative and value < 0:
        raise ValueError(f"{name} must not be negative, got {value}.")
    return value


def _hours(value, name, *, positive=True):
    """A duration in hours as seconds; a ValueError naming ``name`` when it
    is not a finite number (``10**400`` hours overflowed into a bare
    OverflowError) or its seconds exceed the largest float."""
    hours = _check_number(value, name, positive=positive, nonnegative=not positive)
    seconds = hours * 3600.0
    if not np.isfinite(seconds):
        raise ValueError(
            f"{name} must be a finite number of hours (its seconds must stay "
            f"below about 1.8e308), got {shown(value)}."
        )
    return seconds


def _float_array(value, name):
    """``value`` as a float array; a ValueError naming ``name`` for an
    integer beyond the largest float (``np.asarray`` raises OverflowError)
    or for time stamps and durations (read as ticks otherwise)."""
    refuse_clock_values(value, name)
    try:
        return np.asarray(value, dtype=float)
    except OverflowError:
        raise ValueError(
            f"{name} holds an integer too large for a float (a float reaches "
            "about 1.8e308); give finite values."
        ) from None


@dataclass(frozen=True)
class Segment:
    """A stretch of constant spindle speed and axis feed.

    Attributes
    ----------
    duration_s : float
        Length of the segment (s), positive.
    spindle_rpm : float
        Spindle speed (rpm), not negative.
    feed_mm_min : float
        Axis feed (mm/min); its magnitude heats the ball screw.
    """

    duration_s: float
    spindle_rpm: float = 0.0
    feed_mm_min: float = 0.0

    def __post_init__(self):
        _check_number(self.duration_s, "Segment duration_s", positive=True)
        _check_number(self.spindle_rpm, "Segment spindle_rpm", nonnegative=True)
        _check_number(self.feed_mm_min, "Segment feed_mm_min")


@dataclass(frozen=True)
class DutyCycle:
    """A test programme: segments of spindle speed and feed, one after another.

    Parameters
    ----------
    segments : sequence of Segment or (duration_s, spindle_rpm[, feed_mm_min])

    Examples
    --------
    >>> from skthermal.simulate import DutyCycle
    >>> duty = DutyCycle.heat_cool(4000, heat_h=1, cool_h=1)
    >>> duty.duration_s, [s.spindle_rpm for s in duty.segments]
    (7200.0, [4000.0, 0.0])
    >>> DutyCycle([(600, 2000), (600, 0, 1500)]).duration_s
    1200.0
    """

    segments: tuple = field(default_factory=tuple)

    def __init__(self, segments):
        if isinstance(segments, str | bytes) or not isinstance(segments, Iterable):
            raise ValueError(
                "A duty cycle is a sequence of segments (duration_s, spindle_rpm"
                f"[, feed_mm_min]), e.g. [(3600, 3000), (1800, 0)]; got {segments!r}."
            )
        segs = []
        for i, seg in enumerate(segments):
            if not isinstance(seg, Segment):
                try:
                    seg = Segment(*[float(v) for v in seg])
                except OverflowError:
                    raise ValueError(
                        f"Duty-cycle segment {i}: every value must be a finite "
                        "number (a float reaches about 1.8e308), got "
                        f"({', '.join(map(shown, seg))})."
                    ) from None
                except ValueError as exc:
                    raise ValueError(f"Duty-cycle segment {i}: {exc}") from None
                except TypeError:
                    raise ValueError(
                        f"Duty-cycle segment {i} must be (duration_s, spindle_rpm"
                        f"[, feed_mm_min]), got {seg!r}."
                    ) from None
            segs.append(seg)
        if not segs:
            raise ValueError("A duty cycle needs at least one segment.")
        object.__setattr__(self, "segments", tuple(segs))

    @property
    def duration_s(self):
        """Total length (s)."""
        return float(sum(s.duration_s for s in self.segments))

    @classmethod
    def heat_cool(cls, spindle_rpm, *, heat_h, cool_h, feed_mm_min=0.0):
        """Run the spindle for ``heat_h`` hours, then stop it for ``cool_h``."""
        return cls(
            [
                (_hours(heat_h, "heat_cool heat_h"), spindle_rpm, feed_mm_min),
                (_hours(cool_h, "heat_cool cool_h"), 0.0, 0.0),
            ]
        )

    @classmethod
    def from_hours(cls, steps):
        """Segments given as ``(hours, spindle_rpm[, feed_mm_min])``."""
        segments = []
        for i, step in enumerate(steps):
            try:
                h, *rest = step
            except TypeError:
                raise ValueError(
                    f"from_hours step {i} must be (hours, spindle_rpm"
                    f"[, feed_mm_min]), got {step!r}."
                ) from None
            segments.append((_hours(h, f"from_hours step {i}: hours"), *rest))
        return cls(segments)

    @classmethod
    def speed_spectrum(cls, speeds, *, step_h, rest_h=0.0):
        """ISO 230-3-style speed spectrum: each speed for ``step_h`` hours,
        optionally separated by ``rest_h`` hours at rest."""
        _hours(step_h, "speed_spectrum step_h")
        _hours(rest_h, "speed_spectrum rest_h", positive=False)
        steps = []
        for n in speeds:
            steps.append((step_h, n))
            if rest_h:
                steps.append((rest_h, 0.0))
        return cls.from_hours(steps)

    def __add__(self, other):
        return DutyCycle(self.segments + other.segments)

    def sample(self, time_s):
        """Speed and feed in force at each time (s) from the cycle's start.

        A time past the end takes the last segment's values.
        """
        ends = np.cumsum([s.duration_s for s in self.segments])
        idx = np.searchsorted(ends, np.asarray(time_s, dtype=float), side="right")
        idx = np.minimum(idx, len(self.segments) - 1)
        speed = np.array([s.spindle_rpm for s in self.segments])[idx]
        feed = np.array([s.feed_mm_min for s in self.segments])[idx]
        return speed, feed


@dataclass(frozen=True)
class DoorEvent:
    """A workshop door left open: the local air drops fast, then recovers.

    Attributes
    ----------
    start_h : float
        When the door opens (hours from the start of the run).
    drop_C : float, default=9.0
        How far the air near the machine falls (°C).
    duration_min : float, default=30.0
        How long the door stays open; the air approaches the drop with a
        time constant of a tenth of this.
    recovery_min : float, default=45.0
        Time constant of the recovery after the door closes.
    """

    start_h: float
    drop_C: float = 9.0
    duration_min: float = 30.0
    recovery_min: float = 45.0

    def __post_init__(self):
        _check_number(self.start_h, "DoorEvent start_h", nonnegative=True)
        _check_number(self.drop_C, "DoorEvent drop_C")
        _check_number(self.duration_min, "DoorEvent duration_min", positive=True)
        _check_number(self.recovery_min, "DoorEvent recovery_min", positive=True)

    def offset(self, time_s):
        """Air temperature change (°C, negative for a drop) at each time."""
        t = (np.asarray(time_s, dtype=float) - self.start_h * 3600.0) / 60.0
        tau_in = self.duration_min / 10.0
        during = -self.drop_C * -np.expm1(-np.clip(t, 0, None) / tau_in)
        at_close = -self.drop_C * -np.expm1(-self.duration_min / tau_in)
        after = at_close * np.exp(
            -np.clip(t - self.duration_min, 0, None) / self.recovery_min
        )
        return np.where(t < 0, 0.0, np.where(t < self.duration_min, during, after))


@dataclass(frozen=True)
class AmbientProfile:
    """Workshop air around the machine.

    ``T(t) = mean + trend t + day_amplitude sin(2 pi (t/24h - peak_h/24) + pi/2)
    + door events + fluctuation``, the fluctuation a smooth random process
    (first-order filtered noise with standard deviation ``noise_C`` and time
    constant ``noise_tau_min``).

    Parameters
    ----------
    mean_C : float, default=20.0
    trend_C_per_h : float, default=0.0
    day_amplitude_C : float, default=0.0
        Half the day/night swing (the papers' workshops: about 2.5 °C).
    peak_h : float, default=17.0
        Hour of the day of the warmest air.
    start_hour : float, default=8.0
        Hour of the day at which the run starts.
    door_events : sequence of DoorEvent or dict, default=()
    noise_C : float, default=0.0
    noise_tau_min : float, default=20.0

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.simulate import AmbientProfile, DoorEvent
    >>> air = AmbientProfile(mean_C=20, door_events=[DoorEvent(start_h=1.0)])
    >>> round(float(air.sample(np.array([0.0, 5400.0]))[1]), 2)
    11.0
    """

    mean_C: float = 20.0
    trend_C_per_h: float = 0.0
    day_amplitude_C: float = 0.0
    peak_h: float = 17.0
    start_hour: float = 8.0
    door_events: tuple = ()
    noise_C: float = 0.0
    noise_tau_min: float = 20.0

    def __post_init__(self):
        for name in (
            "mean_C",
            "trend_C_per_h",
            "day_amplitude_C",
            "peak_h",
            "start_hour",
        ):
            _check_number(getattr(self, name), f"AmbientProfile {name}")
        low, high = AIR_RANGE_C
        if not low <= self.mean_C <= high:
            warnings.warn(
                f"AmbientProfile mean_C={self.mean_C:g} lies outside the {low:g} "
                f"to {high:g} °C of workshop air and climate chambers: "
                f"{air_unit_guess(self.mean_C)} It is read as °C.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        _check_number(self.noise_C, "AmbientProfile noise_C", nonnegative=True)
        _check_number(self.noise_tau_min, "AmbientProfile noise_tau_min", positive=True)
        events = tuple(
            e if isinstance(e, DoorEvent) else DoorEvent(**e) for e in self.door_events
        )
        object.__setattr__(self, "door_events", events)

    def sample(self, time_s, random_state=None):
        """Air temperature (°C) at the given times (s from the run's start)."""
        t = np.asarray(time_s, dtype=float)
        hours = t / 3600.0
        T = self.mean_C + self.trend_C_per_h * hours
        if self.day_amplitude_C:
            phase = 2 * np.pi * (self.start_hour + hours - self.peak_h) / 24.0
            T = T + self.day_amplitude_C * np.cos(phase)
        for event in self.door_events:
            T = T + event.offset(t)
        if self.noise_C > 0 and t.size > 1:
            from skthermal.simulate._solver import linear_recurrence

            rng = check_random_state(random_state)
            dt = float(np.median(np.diff(t)))
            a = np.exp(-dt / (self.noise_tau_min * 60.0))
            w = rng.normal(0.0, self.noise_C * np.sqrt(1 - a * a), (t.size - 1, 1))
            x0 = rng.normal(0.0, self.noise_C, 1)
            T = T + linear_recurrence(np.array([a]), w, x0)[:, 0]
        return np.broadcast_to(T, t.shape).astype(float)
