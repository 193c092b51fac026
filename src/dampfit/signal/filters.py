"""Zero-phase Butterworth filters (scipy.signal SOS) and their exact gain on a damped exponential.

All filters here are applied forward and backward (``sosfiltfilt``), so their phase is zero
and their magnitude is ``|H|²``. A key fact used by the estimator: a linear time-invariant
filter maps a damped complex exponential ``z^n`` (``z = exp((−p + iω_d)·Δ)``) onto itself times
the complex gain ``H(z)·H(1/z)`` — the decay rate p and frequency ω_d are *unchanged* away
from the record's ends; only amplitude and phase change. :func:`filtfilt_gain` evaluates that
gain so amplitudes can be corrected.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from dampfit.errors import InputError


def bandpass_sos(band: tuple[float, float], fs: float, order: int = 4) -> np.ndarray:
    """Second-order sections of a Butterworth band-pass ``band`` = (lo, hi) [Hz] at rate ``fs`` [Hz]."""
    lo, hi = float(band[0]), float(band[1])
    nyq = 0.5 * fs
    if not (0.0 < lo < hi):
        raise InputError(f"band {lo:g}–{hi:g} Hz is not a valid pass band (need 0 < low < high)")
    if hi >= nyq:
        raise InputError(
            f"band upper edge {hi:g} Hz is not below the Nyquist frequency {nyq:g} Hz of this recording"
        )
    return signal.butter(order, [lo, hi], btype="bandpass", fs=fs, output="sos")


def lowpass_sos(cutoff: float, fs: float, order: int = 8) -> np.ndarray:
    """Second-order sections of a Butterworth low-pass at ``cutoff`` [Hz], rate ``fs`` [Hz]."""
    return signal.butter(order, cutoff, btype="lowpass", fs=fs, output="sos")


def _padlen(sos: np.ndarray, n: int) -> int:
    # scipy's default pad (3 × number of taps) is too short for narrow bands; pad by the
    # filter's settling length but never more than the signal allows.
    return int(min(n - 1, max(3 * (2 * len(sos) + 1), 6 * len(sos) * 10)))


def bandpass(y: np.ndarray, fs: float, band: tuple[float, float], order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth band-pass of uniformly sampled ``y`` (rate ``fs`` [Hz], ``band`` [Hz])."""
    sos = bandpass_sos(band, fs, order)
    return signal.sosfiltfilt(sos, y, axis=0, padtype="odd", padlen=_padlen(sos, len(y)))


def lowpass(y: np.ndarray, fs: float, cutoff: float, order: int = 8) -> np.ndarray:
    """Zero-phase Butterworth low-pass of uniformly sampled ``y`` (rate ``fs``, ``cutoff`` [Hz])."""
    sos = lowpass_sos(cutoff, fs, order)
    return signal.sosfiltfilt(sos, y, axis=0, padtype="odd", padlen=_padlen(sos, len(y)))


def filtfilt_gain(sos: np.ndarray, fs: float, p: float, omega_d: float) -> complex:
    """Complex gain ``H(z)·H(1/z)`` of a forward–backward SOS filter on ``exp((−p + iω_d)t)``.

    ``p`` [1/s] decay rate, ``omega_d`` [rad/s] damped frequency, ``fs`` [Hz] sample rate.
    For p → 0 this is ``|H(e^{iω_dΔ})|²``, the usual filtfilt magnitude.
    """
    z = np.exp((-p + 1j * omega_d) / fs)

    def h(zz):
        out = 1.0 + 0j
        for b0, b1, b2, a0, a1, a2 in sos:
            zi = 1.0 / zz
            out *= (b0 + b1 * zi + b2 * zi**2) / (a0 + a1 * zi + a2 * zi**2)
        return out

    return complex(h(z) * h(1.0 / z))
