"""From a raw :class:`~dampfit.io.recording.Recording` to the samples the decay model is fitted to.

Steps (each one reported in :class:`Prepared` so the user can see what was done):

1. **Stale samples** — a sensor polled faster than its output data rate repeats the previous
   value (e.g. an ADXL345 at 400 Hz read at 533 Hz). If more than 10 % of consecutive samples
   repeat exactly on every axis, the repeats are dropped: their true sample time is unknown.
2. **Offset / gravity** — the per-axis median is subtracted (gravity or bias); the slow drift
   that remains is modelled later as nuisance terms (:func:`dampfit.model.viscous.drift_basis`).
3. **Continuous part and uniform grid** — a time step far larger than the typical one
   (``Recording.segments``, :func:`dampfit.io.recording.time_segments`: > 50× the median step and > 1 s; a long dropout,
   clock jump or corrupt time stamp) splits the record; the longest continuous part is analysed
   (with ``window``: the part holding it; a window across such a gap is an error), with a
   warning. Irregular phone timestamps within it are interpolated (cubic) onto a uniform grid at
   the median rate, for the spectrum, filters and window detection only; the grid never has
   more than ``GRID_FACTOR`` × the samples (memory follows the samples, not the time span).
   The model itself is fitted at the *recorded* sample times when no decimation is needed.
   Stamps that scatter around a steady sample clock while the signal follows the clock (a
   phone stamping samples on arrival) are detected and the samples placed on that clock
   (:mod:`dampfit.signal.clock`); stamps that are right are kept.
4. **Axis** — ``x|y|z`` picks a column; ``auto`` projects the axes on the first principal
   direction of the band-passed signal (the oscillation direction, whatever the tilt).
5. **Clipping and impact spikes** — samples at a saturated level and isolated spikes
   (> 8 robust σ above a running median) are masked, never fitted.
6. **Spectrum and dominant frequency** — peak of the power summed over axes (Tukey-windowed
   periodogram, flat over 90 % of the record) refined by parabolic interpolation
   (:mod:`dampfit.signal.spectrum`). Gross spikes (more than
   :data:`~dampfit.signal.masks.GROSS_SPIKE` times the signal's own local scale on both
   sides, :func:`~dampfit.signal.masks.gross_spikes`; they need no f₀ to be found) are left
   out of this spectrum, so that a train of glitches cannot pose as the oscillation, and are
   masked with the spikes of step 5 (which that test misses at the ends
   of the record and with fewer than 12 samples per period).
7. **Band** — default ``[f₀/1.5, 1.5·f₀]`` [Hz] (capped below Nyquist), overridable.
8. **Free-decay window** — from the Hilbert envelope of the band-passed signal: from just after
   the envelope maximum (the release) to where the envelope reaches 3× the in-band noise floor
   or rises again (a catch), before an impact spike 10× the oscillation, or before an abrupt
   envelope drop (a catch, rattle or contact: :func:`~dampfit.signal.window.envelope_drops`),
   overridable (:mod:`dampfit.signal.window`); a
   user's window that contains such a drop is kept, with a warning.
9. **Fit samples** — if the rate is far above what the band needs, a zero-phase low-pass at the
   band's upper edge and decimation to ≈2.5× that edge (near-white samples); otherwise the raw
   samples in the window — also when masked runs (a train of spikes) would exclude more than
   half of the decimated samples, whose filter support they touch.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from scipy import interpolate, signal

from dampfit.signal import clock, decimate, filters, masks
from dampfit.model import viscous
from dampfit.errors import InputError
from dampfit.io.recording import MIN_SAMPLES, Recording, gap_summary
from dampfit.signal.spectrum import auto_band, axis_share_warning, dominant_frequency
from dampfit.signal.window import (
    DROP_PERIODS, RAYLEIGH_MEAN, detect_window, envelope_drops, impacts, later_decay, noise_floor,
)

#: Fewest oscillation cycles a free-decay window must hold.
MIN_CYCLES = 3.0
#: Drift basis: one Legendre degree per this many oscillation cycles in the window, up to a
#: maximum. Legendre polynomials up to degree N follow a sinusoid of up to ≈ N/π cycles over
#: the window, so one degree per 2.5 cycles absorbs bias drift up to ≈ f₀/(2.5π) ≈ f₀/8, still
#: far from the oscillation. (One per 4 cycles, capped at 24, absorbed only up to f₀/12.6, f₀/15
#: on a 36 s, 3.3 Hz window: the drift left between that and f₀/10 leaked into the estimates of
#: ω_d and p through the window's edges — 0.5–0.8 posterior sd on the simulator's phone preset,
#: 90 % intervals of ω_d covering 82 % — while it inflated the residual variance, which the
#: noise calibration rightly does not count as information about the decay.)
DRIFT_CYCLES_PER_DEGREE, MAX_DRIFT_DEGREE = 2.5, 48
#: Settling time of the decimation low-pass, in periods of its cut-off frequency.
SETTLE_PERIODS = 3.0
#: A masked run bridged over more than this fraction of a period is excluded from the
#: decimated fit (a cubic bridge of 0.1 period errs by < 4e-4 of the amplitude).
LONG_GAP = 0.1
#: Samples the decimated path aims to keep at least (fewer only if the raw window has fewer).
TARGET_DECIMATED = 400
#: The uniform grid may have at most this many points per recorded sample (plus a few): more
#: means the time stamps are far sparser than their median step (a gap or a unit error).
GRID_FACTOR = 4


@dataclass(frozen=True)
class Prepared:
    """A recording prepared for analysis. Times [s] are in the recording's time base."""

    time: np.ndarray  # raw sample times [s] (stale samples removed)
    signal: np.ndarray  # selected axis, offset removed [m/s²]
    usable: np.ndarray  # bool, False for clipped / spike samples
    axis: str  # requested axis ("x", "y", "z", "auto", …)
    direction: dict[str, float]  # weight of each recording axis in the signal
    fs: float  # median sample rate [Hz]
    jitter: float  # coefficient of variation of the sample interval [1]
    grid: np.ndarray  # uniform time grid [s]
    grid_signal: np.ndarray  # selected signal on the grid [m/s²]
    grid_raw: np.ndarray  # all axes on the grid, offsets removed, shape (n, n_axes) [m/s²]
    bandpassed: np.ndarray  # band-passed grid signal [m/s²]
    envelope: np.ndarray  # Hilbert envelope of the band-passed signal [m/s²]
    freqs: np.ndarray  # spectrum frequencies [Hz]
    amplitude: np.ndarray  # single-sided amplitude spectrum [m/s²]
    f0: float  # dominant frequency [Hz]
    band: tuple[float, float]  # pass band [Hz]
    band_auto: bool
    window: tuple[float, float]  # free-decay window [s]
    window_auto: bool
    noise_density: float  # white-noise level near the band, one-sided [(m/s²)/√Hz]
    noise_floor: float  # envelope level of in-band noise [m/s²]
    n_stale: int
    n_clipped: int
    n_spikes: int
    notes: tuple[str, ...] = field(default_factory=tuple)
    warnings: tuple[str, ...] = field(default_factory=tuple)
    #: Why the window ends where it does (:data:`dampfit.signal.window.END_REASONS`, with the
    #: time of a drop or impact; "given" for a window the user gave).
    window_end_reason: str = "given"
    #: the sample-clock test (:meth:`dampfit.signal.clock.ClockCheck.summary`); ``time`` holds
    #: the clock's times when ``moved``
    timing: dict = field(default_factory=dict)
    #: a recording of more than :data:`dampfit.signal.decimate.DECIMATE_ABOVE` samples:
    #: what was decimated (:meth:`dampfit.signal.decimate.Decimation.summary`), else None
    decimation: dict | None = None

    @property
    def grid_in_window(self) -> np.ndarray:
        """The points of ``grid`` inside the free-decay ``window`` (ends included)."""
        return (self.grid >= self.window[0]) & (self.grid <= self.window[1])

    @property
    def time_in_window(self) -> np.ndarray:
        """The raw samples (``time``) inside the free-decay ``window`` (ends included)."""
        return (self.time >= self.window[0]) & (self.time <= self.window[1])


@dataclass(frozen=True, eq=False)
class FitData:
    """Samples the decay model is fitted to.

    ``tau`` [s] counts from the window start ``t0`` [s]; ``y`` [m/s²]. ``lowpass_sos`` is the
    zero-phase low-pass applied before decimation (None on the raw path) at rate ``fs_filter``;
    its complex gain on the decay is divided out of the amplitude.
    """

    t0: float
    tau: np.ndarray
    y: np.ndarray
    drift_degree: int
    path: str  # "raw" or "decimated"
    fs: float  # rate of the fitted samples [Hz] (median for raw)
    lowpass_sos: np.ndarray | None
    fs_filter: float
    n_excluded: int

    @functools.cached_property
    def drift(self) -> np.ndarray:
        """Orthonormal drift basis on ``tau`` (:func:`dampfit.model.viscous.drift_basis`), built once."""
        return viscous.drift_basis(self.tau, self.drift_degree)

    @functools.cached_property
    def padded(self) -> "Padded":
        """The same samples padded to a fixed bucket of shapes, so that jitted functions
        compile once per bucket instead of once per recording (see :class:`Padded`)."""
        n = self.tau.size
        n_pad = padded_length(n)
        tau = np.full(n_pad, self.tau[-1])
        tau[:n] = self.tau
        y = np.zeros(n_pad)
        y[:n] = self.y
        drift = np.zeros((n_pad, MAX_DRIFT_DEGREE + 1))
        drift[:n, : self.drift_degree + 1] = self.drift
        mask = np.zeros(n_pad)
        mask[:n] = 1.0
        return Padded(tau=tau, y=y, drift=drift, mask=mask, n=n, q=self.drift_degree + 3)


@dataclass(frozen=True, eq=False)
class Padded:
    """Fit samples padded with inert rows: ``mask`` [1] is 1 on the ``n`` real samples and 0 on
    the padding, where ``y`` and the drift basis are 0 and the oscillation columns are masked,
    so every projection, residual and determinant equals the unpadded one. The drift basis is
    padded with zero columns to ``MAX_DRIFT_DEGREE + 1`` (Q·Qᵀ is unchanged). ``q`` is the
    number of real linear coefficients (A, B and the drift terms)."""

    tau: np.ndarray
    y: np.ndarray
    drift: np.ndarray
    mask: np.ndarray
    n: int
    q: int


def padded_length(n: int) -> int:
    """Smallest bucket ≥ ``n`` of the series 256·{1, 1.5}·2^k (≤ 50 % padding)."""
    size = 256
    while True:
        for b in (size, size * 3 // 2):
            if b >= n:
                return b
        size *= 2


# ----------------------------------------------------------------------------- helpers
def _to_grid(
    t: np.ndarray, y: np.ndarray, fs: float, grid: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Cubic interpolation of ``y`` (n, …) at times ``t`` [s] onto a uniform grid at ``fs`` [Hz]."""
    if grid is None:
        n = int(np.floor((t[-1] - t[0]) * fs)) + 1
        if n > GRID_FACTOR * len(t) + 64:
            raise InputError(
                f"the time stamps are too sparse for their median step: {len(t)} samples over "
                f"{t[-1] - t[0]:.4g} s at {fs:.4g} Hz would need a grid of {n} points "
                f"(> {GRID_FACTOR}× the samples); check the time column and unit"
            )
        grid = t[0] + np.arange(n) / fs
        grid = grid[grid <= t[-1]]
    spline = interpolate.make_interp_spline(t, y, k=3, axis=0) if len(t) > 3 else None
    yg = spline(grid) if spline is not None else np.interp(grid, t, y)
    return grid, yg


def _unit_hint(rec: Recording) -> str:
    """``"; <hint>"`` naming a likely time-unit mix-up (``Recording.time_unit_verdict``), or ""."""
    hint = rec.time_unit_verdict
    return f"; {hint}" if hint else ""


def _continuous_part(
    rec: Recording, window: tuple[float, float] | None
) -> tuple[np.ndarray, np.ndarray, list[str], list[str]]:
    """Time [s], acceleration [m/s²], notes and warnings of the continuous part to analyse.

    The recording is split at gaps (``Recording.segments``, judged when it was read); the part with
    the most samples is used, or with ``window`` = (start, end) [s] the part holding it. A
    window reaching across a gap or into one is an :class:`InputError` (a fit across a gap of
    unknown length would be wrong, and silently cutting the user's window would hide it).
    """
    t, a = rec.time, rec.accel
    segments = list(rec.segments)
    if len(segments) == 1:
        return t, a, [], []
    spans = ", ".join(f"{t[i]:.6g}–{t[j - 1]:.6g} s" for i, j in segments[:6])
    spans += ", …" if len(segments) > 6 else ""
    if window is None:
        i, j = max(segments, key=lambda seg: seg[1] - seg[0])
    else:
        w0, w1 = float(window[0]), float(window[1])
        inside = [(i, j) for i, j in segments if t[i] <= w0 and w1 <= t[j - 1]]
        if not inside:
            raise InputError(
                f"window {w0:g}–{w1:g} s is not inside one continuous part of the recording: the "
                f"time stamps have gaps ({gap_summary(t, segments)}); continuous parts: {spans}"
            )
        i, j = inside[0]
    if j - i < MIN_SAMPLES:
        raise InputError(
            f"the longest continuous part of the recording has only {j - i} samples "
            f"({gap_summary(t, segments)}); check the time column"
        )
    used = (f"only the continuous part {t[i]:.6g}–{t[j - 1]:.6g} s ({j - i} of {t.size} samples) "
            "is analysed")
    note = f"{gap_summary(t, segments)}; {used}; continuous parts: {spans}"
    warning = f"{gap_summary(t, segments)}; {used}; give --window to analyse another part"
    return t[i:j], a[i:j], [note], [warning]


def _inpaint_on_grid(grid: np.ndarray, t: np.ndarray, y: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """``y`` on the grid from the usable samples only (cubic spline through them).

    A masked run of duration g is bridged with an error ≈ A·(ωg)⁴/384 for an oscillation of
    amplitude A (linear interpolation would give A·(ωg)²/8), so short masked spikes leave the
    filtered signal intact; long runs are excluded from the fit instead (:func:`fit_data`).
    """
    tu, yu = t[usable], y[usable]
    inside = (grid >= tu[0]) & (grid <= tu[-1])
    out = np.empty(grid.size)
    out[inside] = _to_grid(tu, yu, 1.0 / (grid[1] - grid[0]), grid=grid[inside])[1]
    out[grid < tu[0]], out[grid > tu[-1]] = yu[0], yu[-1]  # hold, never extrapolate
    return out


def _principal_direction(yb: np.ndarray) -> np.ndarray:
    """Unit vector of the largest variance of band-passed axes ``yb`` (n, n_axes)."""
    cov = yb.T @ yb
    w, v = np.linalg.eigh(cov)
    d = v[:, -1]
    return d if d[np.argmax(np.abs(d))] > 0 else -d


# ----------------------------------------------------------------------------- public
def prepare(
    rec: Recording,
    axis: str = "auto",
    window: tuple[float, float] | None = None,
    band: tuple[float, float] | None = None,
) -> Prepared:
    """Run steps 1–8 of the module docstring on ``rec``.

    ``axis`` is ``"auto"`` or an axis name of the recording; ``window`` = (start, end) [s] and
    ``band`` = (low, high) [Hz] override the automatic choices. A recording of more than
    :data:`~dampfit.signal.decimate.DECIMATE_ABOVE` samples is first decimated to the rate
    its band needs (:func:`dampfit.signal.decimate.reduce`; ``Prepared.decimation``, a warning).
    """
    rec, reduced = decimate.reduce(rec, band)  # a long recording: to the useful rate first
    t, a, clipped, n_stale, notes, warnings = _distinct_samples(rec, window)
    if reduced is not None:
        warnings.insert(0, reduced.warning())
    fs = float(1.0 / np.median(np.diff(t)))
    jitter = float(np.std(np.diff(t)) / np.mean(np.diff(t)))
    a = a - np.median(a, axis=0)
    if axis != "auto" and axis not in rec.axes:
        raise InputError(
            f"axis {axis!r} is not in this recording; it has {', '.join(rec.axes)} (or auto)"
        )
    grid, graw = _to_grid(t, a, fs)
    fmin, fmax = _search_range(rec, t, fs, band)
    # dominant frequency on the axis with the strongest peak, then the axis, then refine;
    # gross spikes (found without f0) stay out of this first spectrum
    gross = masks.gross_spikes(a, int(np.ceil(fs / fmin)))
    if gross.any() and (~gross).sum() >= 16:
        graw_f = _to_grid(t[~gross], a[~gross], fs, grid=grid)[1]
    else:
        graw_f = graw
    d, direction, f0, freqs, amp, bnd = _axis_and_frequency(rec, graw_f, fs, fmin, fmax, axis,
                                                             band, notes)
    warnings.extend(axis_share_warning(rec.axes, graw_f, fs, fmin, fmax, axis))
    y = a @ d
    usable, n_clipped, n_spikes = _usable(y, fs, f0, clipped, gross, notes, warnings)
    yg = graw @ d if usable.all() else _inpaint_on_grid(grid, t, y, usable)
    bp = filters.bandpass(yg, fs, bnd)
    env = np.abs(signal.hilbert(bp))

    floor = noise_floor(env, signal.detrend(yg), fs, f0, bnd)
    nd = floor / (RAYLEIGH_MEAN * np.sqrt(bnd[1] - bnd[0]))
    peak_env = float(np.percentile(env, 99))
    if peak_env < 8.0 * floor or peak_env <= 0:
        raise InputError(
            "no free-decay oscillation found: the strongest component "
            f"({f0:.3g} Hz) is not clearly above the noise; check the axis, band or file"
        )
    if window is None:
        w0, w1, end_reason = _detected_window(rec, t, y, usable, clipped,
                                              (grid, env, f0, floor), bnd, notes)
    else:
        w0, w1 = _given_window(window, t, grid, env, f0, floor, warnings)
        end_reason = "given"
    if (w1 - w0) * f0 < MIN_CYCLES:
        raise InputError(
            f"the free-decay window {w0:.3f}–{w1:.3f} s holds only {(w1 - w0) * f0:.1f} cycles "
            f"of {f0:.3g} Hz; at least {MIN_CYCLES:g} are needed (give --window START END?)"
        )
    # the free decay decides whether the samples follow their stamps or a steady clock
    timing = clock.check(t, y, usable & (t >= w0) & (t <= w1), grid, bp, f0)
    if timing.moved:  # on the clock: rebuild the grid and its filtered signals
        t = timing.time
        notes.append(timing.note())
        grid, graw = _to_grid(t, a, fs)
        yg = graw @ d if usable.all() else _inpaint_on_grid(grid, t, y, usable)
        bp = filters.bandpass(yg, fs, bnd)
        env = np.abs(signal.hilbert(bp))
    return Prepared(
        time=t, signal=y, usable=usable, axis=axis, direction=direction, fs=fs, jitter=jitter,
        grid=grid, grid_signal=yg, grid_raw=graw, bandpassed=bp, envelope=env, freqs=freqs,
        amplitude=amp, f0=f0, band=bnd, band_auto=band is None, window=(w0, w1),
        window_auto=window is None, noise_density=nd, noise_floor=floor, n_stale=n_stale,
        n_clipped=n_clipped, n_spikes=n_spikes, notes=tuple(notes), warnings=tuple(warnings),
        window_end_reason=end_reason,
        timing=timing.summary(), decimation=None if reduced is None else reduced.summary(),
    )


def _distinct_samples(rec: Recording, window: tuple[float, float] | None):
    """Steps 1 and 3's split: time [s], acceleration [m/s²], the clipped mask, the number of
    stale repeats dropped, notes and warnings of the continuous part to analyse."""
    t, a, notes, warnings = _continuous_part(rec, window)
    clipped = masks.clipped(a)  # before dropping repeats: a saturated run repeats exactly
    stale = masks.stale_mask(a)
    n_stale = 0
    if stale.mean() > masks.STALE_FRACTION:
        n_stale = int(stale.sum())
        t, a, clipped = t[~stale], a[~stale], clipped[~stale]
        notes.append(
            f"dropped {n_stale} repeated samples ({100 * stale.mean():.0f} %): the sensor was "
            "polled faster than its output rate"
        )
    if len(t) < 16:
        raise InputError("the recording has too few distinct samples to analyse")
    return t, a, clipped, n_stale, notes, warnings


def _search_range(rec: Recording, t: np.ndarray, fs: float,
                  band: tuple[float, float] | None) -> tuple[float, float]:
    """The frequencies [Hz] the dominant frequency is searched in: the given ``band``, else
    from 4 cycles in the record (at least 0.1 Hz) to 0.45·fs; a record too short for any
    is an :class:`InputError` (naming a likely time-unit mix-up)."""
    fmin = max(0.1, 4.0 / max(t[-1] - t[0], 1e-9))
    fmax = 0.45 * fs
    if band is not None:
        lo, hi = float(band[0]), float(band[1])
        filters.bandpass_sos((lo, hi), fs)  # validates the band against Nyquist
        fmin, fmax = lo, hi
    if fmin >= fmax:
        hint = rec.time_unit_verdict
        if hint:  # not too short: the time unit is wrong
            raise InputError(f"{hint}; as read, the recording ({t[-1] - t[0]:.3g} s at {fs:.3g} Hz) "
                             "cannot hold an oscillation")
        raise InputError(
            f"the recording ({t[-1] - t[0]:.3g} s at {fs:.3g} Hz) is too short to hold an oscillation"
        )
    return fmin, fmax


def _axis_and_frequency(rec: Recording, graw_f: np.ndarray, fs: float, fmin: float,
                        fmax: float, axis: str, band: tuple[float, float] | None,
                        notes: list[str]):
    """Steps 4, 6 and 7 on the grid signal ``graw_f`` (gross spikes left out): f₀ on the
    power summed over the axes, the axis (or the principal direction of the band-passed
    axes), f₀ refined on that signal, and the band. Returns the projection ``d``, the
    direction by axis name, f₀ [Hz], the spectrum's frequencies [Hz] and amplitudes, and the
    band (low, high) [Hz]."""
    detr = signal.detrend(graw_f, axis=0)
    try:
        f0 = dominant_frequency(detr, fs, fmin, fmax)[0]  # power summed over axes
    except InputError as exc:
        raise InputError(f"{exc}{_unit_hint(rec)}") from None
    bnd = (float(band[0]), float(band[1])) if band is not None else auto_band(f0, fs)
    if axis == "auto":
        if graw_f.shape[1] == 1:
            d = np.ones(1)
        else:
            d = _principal_direction(filters.bandpass(detr, fs, bnd))
    else:
        d = np.zeros(len(rec.axes))
        d[rec.axes.index(axis)] = 1.0
    direction = {name: float(w) for name, w in zip(rec.axes, d)}
    if axis == "auto" and len(d) > 1:
        notes.append(
            "axis auto: projected on the oscillation direction "
            + ", ".join(f"{k}={v:+.3f}" for k, v in direction.items())
        )
    # refine f0 on the selected signal, then fix the band
    f0, freqs, amp = dominant_frequency(signal.detrend(graw_f @ d), fs, *bnd)
    if band is None:
        bnd = auto_band(f0, fs)
    return d, direction, f0, freqs, amp, bnd


def _usable(y: np.ndarray, fs: float, f0: float, clipped: np.ndarray, gross: np.ndarray,
            notes: list[str], warnings: list[str]) -> tuple[np.ndarray, int, int]:
    """Step 5: the samples to fit (neither clipped nor in a spike), and the numbers of
    clipped and spike samples (reported in ``warnings`` and ``notes``)."""
    spikes = masks.spikes(y, fs, f0) | gross
    usable = ~(clipped | spikes)
    n_clipped, n_spikes = int(clipped.sum()), int((spikes & ~clipped).sum())
    if n_clipped:
        warnings.append(f"{n_clipped} samples are clipped (sensor saturation); they are not fitted")
    if n_spikes:
        notes.append(f"{n_spikes} samples in impact spikes are masked and not fitted")
    if usable.sum() < 16:
        raise InputError("almost every sample is clipped or a spike; nothing left to analyse")
    return usable, n_clipped, n_spikes


def _detected_window(rec, t, y, usable, clipped, envelope, bnd, notes):
    """Step 8, automatic: the free-decay window (start, end) [s] of the envelope
    ``envelope`` = (grid [s], env, f0 [Hz], noise floor)
    (:func:`~dampfit.signal.window.detect_window`), its start moved past the band-pass
    filter's settling, and why it ends; too few cycles left is an :class:`InputError`."""
    grid, env, f0, floor = envelope
    spikes = ~usable & ~clipped
    events = impacts(t, y, usable, spikes, f0)
    w0, w1, wnotes, end_reason = detect_window(grid, env, f0, floor, events)
    guard = max(0.5 / f0, 3.0 / bnd[1])
    if (w1 - min(w0 + guard, w1)) * f0 < MIN_CYCLES:
        later = later_decay(grid, env, f0, floor, events, w1, guard, MIN_CYCLES)
        if later is None:
            notes.extend(wnotes)
            raise InputError(_no_decay(rec, t, f0, w0, w1, wnotes))
        first, cut, why = w0, (w1 - w0) * f0, end_reason
        w0, w1, wnotes, end_reason = later
        by = f" by an {why}" if why and why.startswith("impact") else " (a handheld start?)"
        wnotes = [f"the first decay (from {first:.4g} s) was cut short after {cut:.1f} cycles"
                  f"{by}; the longest free decay after it, from {w0:.4g} s, is analysed",
                  *wnotes]
    notes.extend(wnotes)
    return min(w0 + guard, w1), w1, end_reason


def _given_window(window, t, grid, env, f0, floor, warnings) -> tuple[float, float]:
    """Step 8, given: the user's window (start, end) [s], checked against the recording, with
    a warning for every abrupt envelope drop inside it."""
    w0, w1 = float(window[0]), float(window[1])
    if not (w1 > w0):
        raise InputError(f"window end {w1:g} s must be after its start {w0:g} s")
    if w0 < t[0] - 1e-9 or w1 > t[-1] + 1e-9:
        raise InputError(
            f"window {w0:g}–{w1:g} s is outside the recording ({t[0]:g}–{t[-1]:g} s)"
        )
    i0, i1 = np.searchsorted(grid, [w0, w1])
    for tc, factor in envelope_drops(grid, env, f0, floor, int(i0), int(i1)):
        warnings.append(f"the window {w0:g}–{w1:g} s contains an abrupt envelope drop at "
                        f"{tc:.2f} s ({factor:.1f}x more loss than the decay trend within "
                        f"{DROP_PERIODS:g} cycles: a catch, rattle or contact); the damping "
                        "estimate mixes two regimes")
    return w0, w1


def _no_decay(rec: Recording, t: np.ndarray, f0: float, start: float, end: float,
              notes: list[str]) -> str:
    """Why the automatic window from the release at ``start`` [s] to ``end`` [s] holds fewer
    than :data:`MIN_CYCLES` cycles of ``f0`` [Hz]: the reason that ended it (the last window
    note: noise floor, a catch, an impact, an abrupt drop), or an envelope that is largest at
    the end of the recording (it grows: no free decay after it)."""
    cycles = max(end - start, 0.0) * f0
    reason = next((n for n in reversed(notes) if n.startswith("window ends")), None)
    if (t[-1] - t[0]) * f0 < 2 * MIN_CYCLES:
        what = (f"the {t[-1] - t[0]:.3g} s recording holds only {(t[-1] - t[0]) * f0:.1f} cycles "
                "of it (too short)")
    elif reason is not None:
        what = f"{reason}, {cycles:.1f} cycles after the release at {start:.4g} s"
    else:
        what = (f"its envelope is largest at {start:.4g} s, {t[-1] - start:.3g} s before the end "
                f"of the recording ({t[0]:.4g}–{t[-1]:.4g} s): the oscillation grows rather than "
                "decays (forced or self-sustained vibration, or a release at the very end?)")
    return (f"no free decay found: the strongest oscillation ({f0:.3g} Hz) is cut short, {what}; "
            f"at least {MIN_CYCLES:g} cycles are needed; give --window START END if a decay is "
            f"there{_unit_hint(rec)}")


def _long_masked_runs(t: np.ndarray, usable: np.ndarray, min_gap: float) -> np.ndarray:
    """Times [s] of masked samples in runs whose bridged gap exceeds ``min_gap`` [s]."""
    bad = ~usable
    if not bad.any():
        return np.empty(0)
    edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    out = []
    for a, b in zip(starts, stops):  # masked samples a..b-1, bridged from a-1 to b
        gap = t[min(b, t.size - 1)] - t[max(a - 1, 0)]
        if gap > min_gap:
            out.append(t[a:b])
    return np.concatenate(out) if out else np.empty(0)


def fit_data(prep: Prepared) -> FitData:
    """Step 9 of the module docstring: the samples to fit, on the raw or decimated path."""
    w0, w1 = prep.window
    lo, hi = prep.band
    span = (w1 - w0) * prep.f0
    degree = int(np.clip(span / DRIFT_CYCLES_PER_DEGREE, 1, MAX_DRIFT_DEGREE))
    # decimate to ≥ 2.5× the band edge (no in-band information is lost), but keep at least
    # TARGET_DECIMATED samples; below a factor of 3 fit the raw samples instead
    q_max = int(np.floor(prep.fs / (2.5 * hi)))
    q = min(q_max, int((w1 - w0) * prep.fs / TARGET_DECIMATED))
    if q >= 3:
        sos = filters.lowpass_sos(hi, prep.fs)
        yl = filters.lowpass(prep.grid_signal, prep.fs, hi)
        i0 = int(np.ceil((w0 - prep.grid[0]) * prep.fs))
        i1 = int(np.floor((w1 - prep.grid[0]) * prep.fs))
        idx = np.arange(i0, i1 + 1, q)
        # exclude samples whose filter support touched a long masked run or a record end
        reach = SETTLE_PERIODS / hi
        bad_t = np.concatenate([_long_masked_runs(prep.time, prep.usable, LONG_GAP / prep.f0),
                                prep.grid[[0, -1]]])
        bad_t.sort()
        keep = np.ones(idx.size, dtype=bool)
        if bad_t.size:
            tg = prep.grid[idx]
            j = np.searchsorted(bad_t, tg)
            near_l = np.abs(tg - bad_t[np.clip(j - 1, 0, bad_t.size - 1)]) < reach
            near_r = np.abs(bad_t[np.clip(j, 0, bad_t.size - 1)] - tg) < reach
            keep = ~(near_l | near_r)
        idx_k = idx[keep]
        tau = prep.grid[idx_k] - w0
        y = yl[idx_k]
        path, fs_fit, n_excl = "decimated", prep.fs / q, int((~keep).sum())
    if q < 3 or tau.size < max(keep.size / 2, 2 * (degree + 3) + 8):
        # the raw samples: too little decimation to gain, or masked runs (a train of
        # spikes) would exclude most decimated samples, whose filter support they touch
        sel = (prep.time >= w0) & (prep.time <= w1)
        keep = sel & prep.usable
        tau = prep.time[keep] - w0
        y = prep.signal[keep]
        sos, path, fs_fit, n_excl = None, "raw", prep.fs, int((sel & ~prep.usable).sum())
    if tau.size < 2 * (degree + 3) + 8:
        raise InputError("the free-decay window holds too few usable samples to fit")
    return FitData(
        t0=w0, tau=np.asarray(tau, float), y=np.asarray(y, float), drift_degree=degree,
        path=path, fs=fs_fit, lowpass_sos=sos, fs_filter=prep.fs, n_excluded=n_excl,
    )
