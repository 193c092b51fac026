"""The :class:`Recording`: one accelerometer recording, validated once at the boundary.

Every reader in :mod:`dampfit.io` and the simulator return a ``Recording``; every later
stage may rely on its invariants:

* ``time`` is float64 [s], finite and strictly increasing (irregular spacing is allowed:
  phone timestamps jitter and have gaps);
* ``accel`` is float64 [m/s²], finite, shape ``(n_samples, n_axes)``;
* at least :data:`MIN_SAMPLES` samples.

Anything else is an :class:`~dampfit.errors.InputError` with a one-line message.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

__all__ = ["Recording", "MIN_SAMPLES", "STANDARD_GRAVITY"]

#: Fewest samples a recording may have to be analysed at all.
MIN_SAMPLES = 16
#: Standard gravity [m/s²] (CGPM 1901), used to convert g to m/s².
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class Recording:
    """An accelerometer recording.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s] in the recording's own time base, strictly increasing.
    accel : ndarray, shape (n, n_axes)
        Acceleration [m/s²] per axis.
    axes : tuple of str
        Axis names, e.g. ``("x", "y", "z")`` or ``("z",)``.
    path : str or None
        File the recording was read from.
    format : str
        Detected format, e.g. ``"phyphox-csv"``, ``"sensor-logger"``, ``"generic-csv"``, ``"npy"``.
    gravity_removed : bool or None
        ``True`` for "linear acceleration" exports, ``False`` if gravity is present,
        ``None`` if unknown. Preprocessing removes a constant offset either way.
    notes : tuple of str
        What the reader did to the data (unit conversions, dropped columns, …).
    sha256 : str or None
        SHA-256 of the input file, for provenance.
    """

    time: np.ndarray
    accel: np.ndarray
    axes: tuple[str, ...] = ("x", "y", "z")
    path: str | None = None
    format: str = "array"
    gravity_removed: bool | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    sha256: str | None = None

    def __post_init__(self) -> None:
        t, a = _coerce(self.time, self.accel, len(self.axes))
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "accel", a)
        object.__setattr__(self, "axes", tuple(str(x) for x in self.axes))
        object.__setattr__(self, "notes", tuple(self.notes))

    # -- derived facts -------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.time.size)

    @property
    def duration(self) -> float:
        """Time from first to last sample [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def sample_rate(self) -> float:
        """Median sample rate [Hz] (robust to gaps and jitter)."""
        return float(1.0 / np.median(np.diff(self.time)))

    @property
    def jitter(self) -> float:
        """Coefficient of variation of the sample interval [1]."""
        dt = np.diff(self.time)
        return float(np.std(dt) / np.mean(dt))

    def axis(self, name: str) -> np.ndarray:
        """The acceleration [m/s²] of one axis by name."""
        try:
            return self.accel[:, self.axes.index(name)]
        except ValueError:
            raise InputError(
                f"axis {name!r} is not in this recording; it has {', '.join(self.axes)}"
            ) from None


def _coerce(time, accel, n_axes: int) -> tuple[np.ndarray, np.ndarray]:
    """Coerce and validate time [s] and acceleration [m/s²] arrays (see module docstring)."""
    try:
        t = np.asarray(time, dtype=np.float64)
        a = np.asarray(accel, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("time and acceleration must be numeric") from None
    if t.ndim != 1:
        raise InputError(f"time must be one-dimensional, got shape {t.shape}")
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != t.size:
        raise InputError(
            f"acceleration of shape {a.shape} does not match {t.size} time stamps"
        )
    if a.shape[1] != n_axes:
        raise InputError(f"acceleration has {a.shape[1]} columns but {n_axes} axis names")
    if t.size == 0:
        raise InputError("the recording has no samples")
    if t.size < MIN_SAMPLES:
        raise InputError(
            f"the recording has only {t.size} samples; at least {MIN_SAMPLES} are needed"
        )
    bad_t = ~np.isfinite(t)
    if bad_t.any():
        raise InputError(
            f"time has {int(bad_t.sum())} missing or non-finite values (first at sample {int(np.argmax(bad_t))})"
        )
    bad_a = ~np.isfinite(a)
    if bad_a.any():
        row = int(np.argmax(bad_a.any(axis=1)))
        raise InputError(
            f"acceleration has {int(bad_a.sum())} missing or non-finite values (first at sample {row})"
        )
    dt = np.diff(t)
    if (dt == 0).any():
        i = int(np.argmax(dt == 0))
        raise InputError(
            f"time is duplicated at sample {i + 1} (t = {t[i + 1]:g} s); time stamps must be distinct"
        )
    if (dt < 0).any():
        i = int(np.argmax(dt < 0))
        raise InputError(
            f"time goes backwards at sample {i + 1} (t = {t[i + 1]:g} s after {t[i]:g} s); "
            "time stamps must increase"
        )
    return t, a
