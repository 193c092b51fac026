"""The :class:`Recording`: one accelerometer recording, validated once at the boundary.

Every reader in :mod:`dampfit.io.readers` and the simulator return a ``Recording``; every later
stage may rely on its invariants:

* ``time`` is float64 [s], finite and strictly increasing (irregular spacing is allowed:
  phone timestamps jitter and have gaps);
* ``accel`` is float64 [m/s²], finite, shape ``(n_samples, n_axes)``;
* at least :data:`MIN_SAMPLES` samples;
* |acceleration| ≤ :data:`MAX_ACCEL` (a larger value is a wrong column, unit or a corrupt cell).

The time stamps may have gaps: :func:`time_segments` splits them where a gap is far larger than
the typical step (a dropout of many seconds, a clock jump or one corrupt time stamp), or where
a reader removed a repeated time stamp (``breaks``: a spliced export, a phone re-excited and
re-started; :func:`untangle` makes the time increasing first), and the
analysis uses one continuous segment (:func:`dampfit.signal.prepare.prepare`); the recording itself
keeps every sample. The time base is judged here, once: ``Recording.segments`` holds the
continuous segments and ``Recording.time_unit_verdict`` the sentence naming a likely time-unit
mix-up (None when the time looks plausible); every later stage reads them from the recording.

Anything else is an :class:`~dampfit.errors.InputError` with a one-line message.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from dampfit.errors import InputError

#: Fewest samples a recording may have to be analysed at all.
MIN_SAMPLES = 16
#: Standard gravity [m/s²] (CGPM 1901), used to convert g to m/s².
STANDARD_GRAVITY = 9.80665
#: Largest |acceleration| [m/s²] accepted (≈ 100 000 g, beyond any shock accelerometer).
MAX_ACCEL = 1e6
#: A time step larger than GAP_FACTOR × the median step *and* MIN_GAP_S [s] splits the record
#: into separate continuous segments. Ordinary phone dropouts (a few to a few hundred median
#: steps, well under a second) stay inside one segment and are bridged by interpolation.
GAP_FACTOR = 50.0
MIN_GAP_S = 1.0
#: Sample rates [Hz] a vibration recording plausibly has; outside them the time unit is suspect.
PLAUSIBLE_RATE_HZ = (1.0, 1e5)
_UNIT_SECONDS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_UNIT_WORDS = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
_UNIT_HEADER = {"s": "(s)", "ms": "(ms)", "us": "(µs)", "ns": "(ns)"}


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
    time_unit : str or None
        Unit the time column was read in (``s``, ``ms``, ``us``, ``ns``), None if not from a file.
    time_unit_source : str or None
        Where that unit came from: ``"given"`` (option), ``"header"``, ``"format"`` (the
        format's fixed unit) or ``"inferred"`` (from the step size).
    read_options : dict
        The reading options it was read with (:data:`dampfit.io.readers.READ_OPTIONS`, None
        where not given), JSON-safe; recorded in ``provenance.options`` so that the analysis
        can be reproduced. Empty when not read from a file.
    breaks : tuple of int
        Sample indices where a new segment starts although the time step there is ordinary:
        a repeated time stamp was removed before it (:func:`untangle`). Empty by default.
    segments : tuple of (int, int)
        Continuous segments ``(start, stop)`` of the sample indices (:func:`time_segments`),
        judged once when the recording is made.
    time_unit_verdict : str or None
        One sentence naming a likely time-unit mix-up, or None if the time looks plausible
        (:meth:`_judge_time_unit`), judged once when the recording is made.
    """

    time: np.ndarray
    accel: np.ndarray
    axes: tuple[str, ...] = ("x", "y", "z")
    path: str | None = None
    format: str = "array"
    gravity_removed: bool | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    sha256: str | None = None
    time_unit: str | None = None
    time_unit_source: str | None = None
    read_options: dict = field(default_factory=dict)
    breaks: tuple[int, ...] = ()
    segments: tuple[tuple[int, int], ...] = field(init=False, repr=False, compare=False)
    time_unit_verdict: str | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t, a = _coerce(self.time, self.accel, len(self.axes))
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "accel", a)
        object.__setattr__(self, "axes", tuple(str(x) for x in self.axes))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "breaks", tuple(int(b) for b in self.breaks if 0 < b < t.size))
        object.__setattr__(self, "segments", tuple(time_segments(t, self.breaks)))
        object.__setattr__(self, "time_unit_verdict", self._judge_time_unit())

    def with_notes(self, *notes: str) -> "Recording":
        """This recording with ``notes`` added (the data are not validated again)."""
        out = copy.copy(self)
        object.__setattr__(out, "notes", (*self.notes, *notes))
        return out

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

    def _judge_time_unit(self) -> str | None:
        """One sentence naming a likely time-unit mix-up, or None if the time looks plausible.

        Suspicious: a median sample rate outside :data:`PLAUSIBLE_RATE_HZ` (e.g. milliseconds
        read as seconds: a 100 Hz phone looks like 0.1 Hz), or ≥ 10 kHz from a unit other than
        seconds written in a header (seconds under a ``(ms)`` header). The hint names the unit
        that gives a rate nearest a typical 300 Hz and the ``--time-unit`` option to use.
        """
        steps = np.diff(self.time)
        step = float(np.median(steps))  # [s]
        rate = 1.0 / step
        unit = self.time_unit or "s"
        lo, hi = PLAUSIBLE_RATE_HZ
        too_fast_for_unit = (rate >= 1e4 and unit != "s"
                             and self.time_unit_source in ("header", "format"))
        if lo <= rate <= hi and not too_fast_for_unit:
            return None
        raw_step = step / _UNIT_SECONDS[unit]  # the median step in the file's own numbers
        options = {u: 1.0 / (raw_step * f) for u, f in _UNIT_SECONDS.items() if u != unit}
        plausible = {u: r for u, r in options.items() if lo <= r <= hi}
        if too_fast_for_unit:  # only a larger unit can fix a rate that is too high
            plausible = {u: r for u, r in plausible.items()
                         if _UNIT_SECONDS[u] > _UNIT_SECONDS[unit]}
        where = {"header": f"under a '{_UNIT_HEADER[unit]}' header",
                 "format": f"in a format whose time is in {_UNIT_WORDS[unit]}",
                 "given": f"with --time-unit {unit}",
                 "inferred": f"read as {_UNIT_WORDS[unit]}"}.get(self.time_unit_source or "",
                                                                   f"in {_UNIT_WORDS[unit]}")
        fact = f"median time step {raw_step:.3g} {unit} = {rate:.3g} Hz sample rate"
        if not plausible:
            return (f"the time looks wrong ({fact}, outside {lo:g} Hz–{hi / 1e3:g} kHz); "
                    "check the time column and unit")
        best = min(plausible, key=lambda u: abs(np.log10(plausible[u] / 300.0)))
        return (f"time looks like {_UNIT_WORDS[best]} {where} ({fact}; as {_UNIT_WORDS[best]} "
                f"{plausible[best]:.4g} Hz); use --time-unit {best}")

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
    big = np.abs(a) > MAX_ACCEL
    if big.any():
        row = int(np.argmax(big.any(axis=1)))
        raise InputError(
            f"acceleration of {float(np.abs(a).max()):.3g} m/s² (first at sample {row}) is not "
            f"physical (> {MAX_ACCEL:g} m/s²); check the acceleration column and unit"
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


def time_segments(time: np.ndarray, breaks=()) -> list[tuple[int, int]]:
    """Continuous parts of strictly increasing ``time`` [s]: ``[(start, stop), …]`` index ranges.

    A step larger than both ``GAP_FACTOR`` × the median step and ``MIN_GAP_S`` ends a segment
    (a long dropout, a clock jump or a corrupt time stamp), and so does each index of
    ``breaks`` (a removed repeated time stamp); one segment means neither.
    """
    t = np.asarray(time, dtype=np.float64)
    if t.size < 2:
        return [(0, int(t.size))]
    dt = np.diff(t)
    limit = _gap_limit(dt)
    cuts = sorted(set((np.flatnonzero(dt > limit) + 1).tolist()) | {int(b) for b in breaks})
    bounds = [0, *cuts, int(t.size)]
    return list(zip(bounds[:-1], bounds[1:]))


def _gap_limit(dt: np.ndarray) -> float:
    return max(GAP_FACTOR * float(np.median(dt)), MIN_GAP_S)


def gap_summary(time: np.ndarray, segments: list[tuple[int, int]]) -> str:
    """One sentence on the gaps and splices between ``segments`` of ``time`` [s] (see
    :func:`time_segments`)."""
    t = np.asarray(time, dtype=np.float64)
    step = float(np.median(np.diff(t)))
    limit = _gap_limit(np.diff(t))
    gaps = [(t[a - 1], t[a]) for a, _ in segments[1:] if t[a] - t[a - 1] > limit]
    splices = [t[a] for a, _ in segments[1:] if t[a] - t[a - 1] <= limit]
    parts = []
    if gaps:
        widest = max(gaps, key=lambda g: g[1] - g[0])
        more = f" and {len(gaps) - 1} more" if len(gaps) > 1 else ""
        parts.append(f"time stamps jump by {widest[1] - widest[0]:.4g} s after t = "
                     f"{widest[0]:.6g} s{more} (> {GAP_FACTOR:g}× the median step {step:.3g} s "
                     f"and > {MIN_GAP_S:g} s: a long dropout, clock jump or corrupt time stamp)")
    if splices:
        more = f" and {len(splices) - 1} more" if len(splices) > 1 else ""
        parts.append(f"a time stamp repeats at t = {splices[0]:.6g} s{more} (a spliced or "
                     "re-started recording)")
    return f"{'; '.join(parts)}; {len(segments)} continuous segments"


def untangle(time: np.ndarray) -> tuple[np.ndarray | None, tuple[int, ...], str | None]:
    """(samples to keep, ``breaks``, one-line note) for finite ``time`` [s] that repeats or
    goes backwards; ``(None, (), None)`` when it increases (or nothing usable would be left:
    :class:`Recording` then refuses it with the first bad sample).

    * Only repeats (a spliced export, a phone re-excited): the second sample of each repeated
      stamp is dropped and a segment starts after it (``breaks``); every other sample is kept
      in the one time base, so ``--window`` can reach each segment.
    * Time goes backwards (recordings appended, a clock reset): the runs of increasing time
      are separate time bases; the one with the most samples is kept.
    """
    t = np.asarray(time, dtype=np.float64)
    if t.size < 2 or not np.isfinite(t).all():
        return None, (), None
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size == 0:
        return None, (), None
    starts = [0, *(bad + 1).tolist()]
    runs = list(zip(starts, [*(bad + 1).tolist(), int(t.size)]))
    if not (dt < 0).any():
        keep = np.ones(t.size, dtype=bool)
        keep[bad + 1] = False
        position = np.cumsum(keep) - 1
        breaks = tuple(sorted({int(position[j]) for j in bad + 2 if j < t.size and keep[j]}))
        kept = t[keep]
        bounds = [0, *breaks, int(kept.size)]
        segs = list(zip(bounds[:-1], bounds[1:]))
        if max(b - a for a, b in segs) < MIN_SAMPLES:
            return None, (), None
        named = ", ".join(f"{kept[a]:.6g}–{kept[b - 1]:.6g} s ({b - a} samples)"
                          for a, b in segs[:4]) + (", …" if len(segs) > 4 else "")
        return keep, breaks, (
            f"time stamp t = {t[bad[0]]:.6g} s repeats (sample {bad[0] + 2}"
            f"{f' and {bad.size - 1} more' if bad.size > 1 else ''}): {len(segs)} segments, "
            f"{named}; the longest segment is analysed (give --window START END for another)")
    i, j = max(runs, key=lambda r: r[1] - r[0])
    if j - i < MIN_SAMPLES:
        return None, (), None
    back = int(bad[np.argmax(dt[bad] < 0)])
    named = ", ".join(f"samples {a + 1}–{b} ({t[a]:.6g}–{t[b - 1]:.6g} s)"
                      for a, b in runs[:4]) + (", …" if len(runs) > 4 else "")
    keep = np.zeros(t.size, dtype=bool)
    keep[i:j] = True
    return keep, (), (
        f"time goes backwards at sample {back + 2} (t = {t[back + 1]:.6g} s after "
        f"{t[back]:.6g} s): {len(runs)} runs of time stamps, {named}; only the longest, samples "
        f"{i + 1}–{j}, is read (cut the file to read another)")
