"""Spectra of a uniformly sampled signal: dominant frequency, default band, noise density.

* :func:`dominant_frequency` — peak [Hz] of the Tukey(0.1)-windowed, 4× zero-padded
  periodogram (power summed over axes), refined by parabolic interpolation of the log power
  between bins (:func:`parabolic_peak`), and the single-sided amplitude spectrum [m/s²];
* :func:`auto_band` — the default pass band ``[f₀/1.5, 1.5·f₀]`` [Hz], capped at 0.45·fs;
* :func:`noise_density` — white-noise density [(m/s²)/√Hz] near the band, from the median
  Welch power spectral density off the peak;
* :func:`axis_share_warning` — a chosen axis that carries little of the oscillation's
  energy at f₀ is said, with the axis that does.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from dampfit.errors import InputError
from dampfit.signal import filters

#: Band edges relative to the dominant frequency for the automatic band.
BAND_FACTOR = 1.5


def parabolic_peak(y: np.ndarray, i: int) -> float:
    """Sub-bin offset [bins] of a peak at index ``i`` of ``y`` from the parabola through
    ``y[i-1]``, ``y[i]``, ``y[i+1]``: δ = ½·(a − c)/(a − 2b + c); 0 at an end."""
    if i <= 0 or i >= len(y) - 1:
        return 0.0
    a, b, c = y[i - 1], y[i], y[i + 1]
    den = a - 2 * b + c
    return 0.0 if den == 0 else float(0.5 * (a - c) / den)


def dominant_frequency(
    y: np.ndarray, fs: float, fmin: float, fmax: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """Dominant frequency [Hz] of uniformly sampled ``y`` (n,) or (n, axes) in [fmin, fmax] [Hz].

    Returns ``(f0, freqs, amplitude)``: the Tukey(0.1)-windowed, 4× zero-padded periodogram peak
    refined by parabolic interpolation of the log power, and the single-sided amplitude
    spectrum [m/s²] of the unpadded signal for display.
    """
    n = len(y)
    win = signal.windows.tukey(n, 0.1)  # flat over 90 %: a decay near an end keeps its weight
    nfft = int(2 ** np.ceil(np.log2(4 * n)))
    yy = (y - y.mean(axis=0)).reshape(n, -1)
    # power summed over axes (one axis: its own power)
    spec = np.sqrt(np.sum(np.abs(np.fft.rfft(yy * win[:, None], nfft, axis=0)) ** 2, axis=1))
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    sel = np.flatnonzero((f >= fmin) & (f <= fmax))
    if sel.size < 3:
        raise InputError(f"no frequency range to search between {fmin:.3g} and {fmax:.3g} Hz")
    i = sel[np.argmax(spec[sel])]
    if i in (sel[0], sel[-1]):
        # a maximum at the edge of the searched range is leakage, not a resolved oscillation
        raise InputError(
            f"no resolvable oscillation between {fmin:.3g} and {fmax:.3g} Hz: the spectrum peaks "
            f"at the edge of that range (recording {n / fs:.3g} s long; too short, or give --band)"
        )
    logp = np.log(spec**2 + 1e-300)
    f0 = f[i] + parabolic_peak(logp, i) * (f[1] - f[0])
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    amp = 2.0 * np.sqrt(np.sum(np.abs(np.fft.rfft(yy, axis=0)) ** 2, axis=1)) / n
    return float(f0), freqs, amp


def auto_band(f0: float, fs: float) -> tuple[float, float]:
    """Default pass band [Hz]: ``[f₀/1.5, 1.5·f₀]``, upper edge capped at 0.45·fs."""
    hi = min(BAND_FACTOR * f0, 0.45 * fs)
    lo = f0 / BAND_FACTOR
    if hi <= f0 * 1.02:
        raise InputError(
            f"the dominant frequency {f0:.4g} Hz is too close to the Nyquist frequency "
            f"{fs / 2:.4g} Hz of this recording; record at a higher sample rate"
        )
    return float(lo), float(hi)


def noise_density(y: np.ndarray, fs: float, f0: float, band: tuple[float, float]) -> float:
    """White-noise density [(m/s²)/√Hz] near the band, from the median Welch PSD off the peak."""
    nper = int(min(len(y), max(256, 8 * fs / band[0])))
    f, pxx = signal.welch(y, fs=fs, nperseg=nper)
    lo, hi = band
    off_peak = np.abs(f - f0) > 0.25 * f0
    near = off_peak & (f >= lo / 2) & (f <= min(4 * hi, 0.9 * fs / 2))
    if near.sum() < 5:
        near = off_peak & (f > 0)
    return float(np.sqrt(np.median(pxx[near]))) if near.any() else 0.0


#: A chosen axis carrying less than this share [1] of the oscillation's energy at f₀ is
#: said to be the wrong one (issue 34: a phone pendulum analysed on a cross axis).
AXIS_SHARE_MIN = 0.2


def axis_share_warning(axes, graw_f: np.ndarray, fs: float, fmin: float, fmax: float,
                       axis: str) -> list[str]:
    """[a warning] when the chosen ``axis`` carries less than :data:`AXIS_SHARE_MIN` of the
    oscillation's energy at f₀ ([] for ``auto``, one axis or a fair share). f₀ [Hz] is the
    peak of the power summed over the axes; each axis's share is its band-passed power
    (f₀ × [1/√2, √2]) over the sum of all axes' (the trace of the band's covariance, which
    does not depend on the axes' orientation); the warning names the axis with the largest
    share and suggests ``--axis auto`` (the principal direction of the band)."""
    if axis == "auto" or graw_f.shape[1] < 2 or axis not in axes:
        return []
    detr = signal.detrend(graw_f, axis=0)
    try:
        f0 = dominant_frequency(detr, fs, fmin, fmax)[0]
    except InputError:
        return []
    lo, hi = f0 / math.sqrt(2.0), min(f0 * math.sqrt(2.0), 0.45 * fs)
    if not lo < hi:
        return []
    power = np.mean(filters.bandpass(detr, fs, (lo, hi)) ** 2, axis=0)
    total = float(np.sum(power))
    if not total > 0:
        return []
    share = power / total
    i, best = list(axes).index(axis), int(np.argmax(share))
    if share[i] >= AXIS_SHARE_MIN:
        return []
    return [f"axis {axis} carries only {share[i]:.0%} of the oscillation's energy at "
            f"{f0:.4g} Hz; axis {axes[best]} carries {share[best]:.0%}: the chosen axis is "
            "probably the wrong one (try --axis auto, the oscillation's direction)"]
