"""The signal features the seed paper's baselines (:mod:`dampfit.estimators.baselines`) read:
how long a band-pass's edge transient lasts (:func:`settle_time`, :func:`edge_guard`), one
positive peak per cycle (:func:`positive_peaks`), a rough dominant frequency, the region of
the envelope fit (:func:`envelope_fit_region`) and the frequency of the zero crossings.
NumPy/SciPy only, no I/O.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from dampfit.errors import InputError
from dampfit.signal.filters import bandpass_sos

#: Butterworth order of every band-pass used here (zero-phase, so the effective order doubles).
FILTER_ORDER = 4
#: Minimum peak distance as a fraction of the oscillation period (one positive peak per cycle).
PEAK_DISTANCE_FRACTION = 0.7
#: Fraction of the window dropped at each end of the envelope fit (filter / Hilbert end effects).
ENVELOPE_TRIM_FRACTION = 0.10
#: ... but at least this many periods at each end.
ENVELOPE_TRIM_MIN_PERIODS = 2.0
#: Envelope fit stops where the envelope first falls below this fraction of its maximum (40 dB).
ENVELOPE_FLOOR = 1e-2
#: Edge guard: samples closer to a window end than the time the band-pass impulse response needs
#: to fall below this fraction of its peak are distorted by the filter's start/stop transient.
EDGE_SETTLE_TOLERANCE = 5e-3
#: ... but the guard never exceeds this fraction of the window at each end.
EDGE_GUARD_MAX_FRACTION = 0.25


def settle_time(fs: float, band: tuple[float, float], n_filters: int = 1) -> float:
    """Time [s] after which the impulse response of ``n_filters`` cascaded band-passes stays
    below :data:`EDGE_SETTLE_TOLERANCE` of its peak (how long an edge transient lasts)."""
    sos = np.vstack([bandpass_sos(band, fs, FILTER_ORDER)] * n_filters)
    n = int(math.ceil(fs * 20.0 * (n_filters + 1) / (band[1] - band[0]))) + 1
    impulse = np.zeros(n)
    impulse[0] = 1.0
    h = np.abs(signal.sosfilt(sos, impulse))
    return float(np.flatnonzero(h > EDGE_SETTLE_TOLERANCE * h.max())[-1] / fs)


def edge_guard(
    fs: float, band: tuple[float, float], duration: float, n_filters: int = 1
) -> tuple[float, float]:
    """(guard, settle) [s]: the time at each window end where the band-passed output is not yet
    trustworthy — the settling time of the filter cascade, but at most
    :data:`EDGE_GUARD_MAX_FRACTION` of the window — and the uncapped settling time."""
    settle = settle_time(fs, band, n_filters)
    return min(settle, EDGE_GUARD_MAX_FRACTION * duration), settle


def parabolic(y: np.ndarray, i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """3-point parabolic refinement at interior indices ``i``: (fractional offset [samples], height)."""
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    denom = y0 - 2.0 * y1 + y2
    safe = np.where(denom != 0.0, denom, 1.0)
    d = np.where(denom != 0.0, 0.5 * (y0 - y2) / safe, 0.0)
    return d, y1 - 0.25 * (y0 - y2) * d


def positive_peaks(
    y: np.ndarray, fs: float, band: tuple[float, float], t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One positive peak per cycle: (indices, refined times [s], refined heights)."""
    # First pass: distance from the upper band edge (shortest possible period), so no true
    # peak is skipped; then repeat with the median spacing of what was found.
    dist = max(1, int(PEAK_DISTANCE_FRACTION * fs / band[1]))
    idx, _ = signal.find_peaks(y, height=0.0, distance=dist)
    if idx.size >= 3:
        period = float(np.median(np.diff(idx)))
        idx, _ = signal.find_peaks(y, height=0.0, distance=max(1, int(PEAK_DISTANCE_FRACTION * period)))
    d, h = parabolic(y, idx)
    return idx, t[idx] + d / fs, h


def rough_frequency(u: np.ndarray, fs: float, band: tuple[float, float]) -> float:
    """Dominant frequency [Hz]: FFT peak with parabolic refinement, falling back to the band centre."""
    spec = np.abs(np.fft.rfft(u * np.hanning(u.size)))
    freqs = np.fft.rfftfreq(u.size, 1.0 / fs)
    inband = (freqs >= band[0]) & (freqs <= band[1])
    if not np.any(inband):
        return math.sqrt(band[0] * band[1])
    i = int(np.flatnonzero(inband)[np.argmax(spec[inband])])
    if 0 < i < spec.size - 1:
        d, _ = parabolic(spec, np.array([i]))
        return float((i + d[0]) * fs / u.size)
    return float(freqs[i])


def envelope_fit_region(
    t: np.ndarray, u: np.ndarray, env: np.ndarray, fs: float, band: tuple[float, float]
) -> tuple[np.ndarray, float, float]:
    """Boolean mask of the samples the envelope fit may use, the end trim [s] and the filter
    cascade's uncapped settling time [s].

    Drops max(10 %, two periods, settling time of the three band-passes) at each end, then —
    because the Hilbert envelope of a record that starts abruptly carries an algebraically
    decaying leakage (≈1e-3 of the initial amplitude) while the true envelope decays
    exponentially — keeps only the part before the envelope first drops below
    :data:`ENVELOPE_FLOOR` of its maximum.
    """
    duration = t[-1] - t[0]
    f_rough = rough_frequency(u, fs, band)
    guard, settle = edge_guard(fs, band, duration, n_filters=3)
    trim = max(ENVELOPE_TRIM_FRACTION * duration, ENVELOPE_TRIM_MIN_PERIODS / f_rough, guard)
    if (duration - 2.0 * trim) * f_rough < 2.0:
        raise InputError(
            f"the window ({duration:.3g} s) is too short for the envelope pipeline: after trimming "
            f"{trim:.3g} s at each end fewer than 2 cycles of {f_rough:.3g} Hz remain"
        )
    mask = (t >= t[0] + trim) & (t <= t[-1] - trim)
    keep = np.flatnonzero(mask)
    peak = env[keep].max()
    if not peak > 0.0:
        raise InputError("the displacement envelope is zero; check the pass band and the data")
    below = np.flatnonzero(env[keep] < ENVELOPE_FLOOR * peak)
    if below.size:
        mask[keep[below[0]] :] = False
    return mask, float(trim), float(settle)


def zero_crossing_frequency(t: np.ndarray, u: np.ndarray) -> float | None:
    """Frequency [Hz] from linearly interpolated upward zero crossings; ``None`` if < 2 cycles."""
    i = np.flatnonzero((u[:-1] < 0.0) & (u[1:] >= 0.0))
    if i.size < 3:
        return None
    tc = t[i] - u[i] * (t[i + 1] - t[i]) / (u[i + 1] - u[i])
    return float((tc.size - 1) / (tc[-1] - tc[0]))
