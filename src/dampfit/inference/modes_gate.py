r"""A cheap screen before the several-modes analysis: is there anything beside the one mode?

The order selection (:mod:`dampfit.inference.modes_select`) fits K = 1 … K_max modes by
Levenberg–Marquardt and costs several times the whole one-mode analysis. On a recording with
one mode all of that only confirms K = 1. The screen decides, from the one-mode least
squares alone, whether a second mode could pass the selection; only then is it run.

Statistic
---------
The window is resampled as the order selection sees it (the modal band (MS1) and window of
:func:`dampfit.inference.modes.modal_band` / :func:`~dampfit.inference.modes.modal_window`,
:func:`dampfit.signal.subspace.uniform_window`), and the one-mode decay at the least-squares
rate p₁ [1/s] and damped frequency ω₁ [rad/s] is removed by linear least squares together with
a Legendre drift (its amplitude and phase refitted: the filter gains differ from the one-mode
path's). In the residual e(τ), for every frequency f of the band (FFT, zero-padded ×4) and
every decay rate p of a grid (0 and 1/T·3^j up to 0.2·2π·f_hi), the matched statistic of one
damped mode

    z²(f, p) = 2·|Σ_τ e(τ)·e^{−pτ}·e^{−2πifτ}|² / (S(f)·Σ_τ e^{−2pτ})                    (G1)

is, for white noise of level S, a χ² variable with 2 degrees of freedom — the z² of a new
mode's amplitude in (MS4) without the other columns. The local noise level S(f) is the running
median (over ±¼f) of the residual's plain periodogram divided by ln 2 (the median of an
exponential variable), so coloured noise raises the bar where it is strong; for a rate p > 0
the denominator is S smeared by that rate's spectral window, S ⊛ |W_p|² (the null mean of the
numerator), not S·Σe^{−2pτ}: a fast-decaying weight is wide in frequency and near the band
edges, beyond which the low-pass cuts the noise, S changes within its width.

Decision
--------
A second mode is looked for (``passed``) when the largest z² more than one resolution cell
1/T from f₁ reaches the (MS4) threshold for N_cells·N_rates tries, 2·ln(N_cells·N_rates/α)
with α = :data:`~dampfit.inference.modes_select.AMPLITUDE_ALPHA`. Otherwise the recording is
reported as one mode, with the reason. (The one-mode Whittle factor near f₀ is not used: on
phone recordings it is 5–8 from coloured noise alone, and the local level S handles that.)

*False negatives.* The selection keeps a mode only when its evidence pays the prior volume,
which in practice needs z ≈ 8–9 (z² ≳ 64; paper/modes.md), while the screen already passes at
z² ≈ 20. (G1) loses against the selection's z² at most ≈ 10 % from the rate and frequency
grids, plus what the mode shares with the first mode and the drift (small more than one
resolution cell away) — a margin of about three in power. Missed are: a mode within one
resolution cell of f₁ (the selection refuses such a pair anyway), a mode decaying faster than 0.2·ω_hi (outside
the selection's prior too), and a weak mode hidden where the noise level is estimated high
because strong modes crowd the ±¼f median (several strong modes close together). The screen
errs towards running the selection: a spurious peak costs time, not a wrong answer.

Pure NumPy/SciPy; no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre
from scipy import ndimage

from dampfit.inference.modes import modal_band, modal_window
from dampfit.inference.modes_select import AMPLITUDE_ALPHA
from dampfit.model import modes as mm
from dampfit.signal import subspace
from dampfit.signal.prepare import MAX_DRIFT_DEGREE, Prepared

#: Zero padding of the FFT [1].
ZERO_PAD = 4
#: Searched part of the modal band: from EDGE[0]·f_lo to EDGE[1]·f_hi (at the edges the
#: low-pass, the drift basis and sub-band motion make the noise level change too fast for
#: the local median, and one-mode recordings show spurious peaks there).
EDGE = (1.25, 0.9)
#: Fastest decay screened at frequency f: p ≤ MAX_ZETA·2πf [1/s] (the modes a structure rings
#: in; faster "modes" are what a release transient leaves at the window start).
MAX_ZETA = 0.05
#: Smallest screening threshold z² [1] (z ≈ 5.7; the selection keeps a mode at z ≈ 8–9).
MIN_Z2 = 32.0


@dataclass(frozen=True)
class Screen:
    """The screen's decision (module docstring): ``passed`` (look for more modes),
    ``z2`` [1] the largest (G1) away from f₁ at ``f_hz`` [Hz] and rate ``p`` [1/s],
    ``threshold`` [1], ``band`` [Hz], ``span`` T [s], ``fs`` [Hz] of the screened samples,
    ``reason`` one line."""

    passed: bool
    z2: float
    f_hz: float
    p: float
    threshold: float
    band: tuple[float, float]
    span: float
    fs: float
    reason: str

    def summary(self) -> dict:
        """Plain data for summary.json's ``modes_evidence``."""
        return {"passed": self.passed, "max_z2": _num(self.z2), "at_hz": _num(self.f_hz),
                "rate_per_s": _num(self.p), "threshold_z2": _num(self.threshold),
                "reason": self.reason}


def _num(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _residual(x: np.ndarray, fs: float, p: float, omega: float, degree: int) -> np.ndarray:
    """``x`` minus its least-squares fit by e^{−pτ}(A cos ωτ + B sin ωτ) and a Legendre
    drift of ``degree``."""
    tau = np.arange(x.size) / fs
    env = np.exp(-p * tau)
    u = 2.0 * tau / max(tau[-1], 1e-12) - 1.0
    cols = np.column_stack([env * np.cos(omega * tau), env * np.sin(omega * tau),
                            legendre.legvander(u, degree)])
    coef, *_ = np.linalg.lstsq(cols, x, rcond=None)
    return x - cols @ coef


def _level(plain: np.ndarray, f: np.ndarray, band: tuple[float, float],
           span: float) -> np.ndarray:
    """Local noise level S(f) [(m/s²)²] of a periodogram ``plain`` on ``f`` [Hz]: the running
    median over ±f/4 (at least ±2 resolution cells) of the in-band bins only (mirrored at the
    band edges: beyond them the low-pass and the drift cut the noise), over ln 2; held
    constant outside the band."""
    df = f[1] - f[0]
    i0 = int(np.searchsorted(f, band[0]))
    i1 = max(i0 + 1, int(np.searchsorted(f, band[1], side="right")))
    seg = plain[i0:i1]
    out = np.empty_like(seg)
    for lo in range(0, seg.size, 64):  # piecewise: the ±f/4 width grows with f
        hi = min(seg.size, lo + 64)
        width = max(int(0.5 * f[i0 + (lo + hi) // 2] / df), int(4.0 / (span * df)), 3) | 1
        width = min(width, 2 * seg.size - 1)
        a, b = max(0, lo - width), min(seg.size, hi + width)
        out[lo:hi] = ndimage.median_filter(seg[a:b], size=width, mode="mirror")[lo - a:hi - a]
    level = np.concatenate([np.full(i0, out[0]), out, np.full(f.size - i1, out[-1])])
    return np.maximum(level / math.log(2.0), 1e-300)


def _rates(span: float, f_hi: float) -> np.ndarray:
    top = mm.P_MAX * 2 * np.pi * f_hi
    n = max(1, int(np.ceil(np.log(max(top * span, 1.0)) / np.log(3.0))) + 1)
    return np.concatenate([[0.0], np.minimum(3.0 ** np.arange(n) / span, top)])


def screen(prep: Prepared, p: float, omega_d: float,
           band: tuple[float, float] | None = None) -> Screen:
    """Screen ``prep`` for modes beside the one at rate ``p`` [1/s] and damped angular
    frequency ``omega_d`` [rad/s] (the one-mode least squares); ``band`` [Hz] overrides
    (MS1). See the module docstring."""
    band = modal_band(prep, band)
    window, _ = modal_window(prep, band)
    x, fs = subspace.uniform_window(prep.grid, prep.grid_signal, prep.fs, window, band)
    span = x.size / fs
    degree = int(np.clip(span * band[0] / 4.0, 1, MAX_DRIFT_DEGREE))
    f1 = omega_d / (2 * np.pi)
    if x.size < 16:
        return Screen(True, math.nan, math.nan, math.nan, math.nan, band, span, fs,
                      "too few samples to screen: every number of modes is tried")
    e = _residual(x, fs, p, omega_d, degree)
    tau = np.arange(e.size) / fs
    nfft = int(2 ** np.ceil(np.log2(ZERO_PAD * e.size)))
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    plain = np.abs(np.fft.rfft(e, nfft)) ** 2 / e.size
    level = _level(plain, f, band, span)
    inside = ((f >= EDGE[0] * band[0]) & (f <= EDGE[1] * band[1])
              & (np.abs(f - f1) * span >= 1.0))
    rates = _rates(span, band[1])
    # two-sided noise level, to be smeared by each rate's spectral window (the null mean of
    # |Σ e·w·e^{−iωτ}|² is S ⊛ |W|², not S·Σw², where S changes faster than |W| is wide:
    # at the band edges, beyond which the low-pass cuts the noise)
    two = np.concatenate([level, level[-2:0:-1]])
    spec_two = np.fft.fft(two)
    best = (-math.inf, math.nan, math.nan)
    for rate in rates:
        w = np.exp(-rate * tau)
        kern = np.abs(np.fft.fft(w, two.size)) ** 2 / two.size  # Σ_f |W(f)|² = Σ w²
        null = np.real(np.fft.ifft(spec_two * np.fft.fft(kern)))[:f.size]
        z2 = 2.0 * np.abs(np.fft.rfft(e * w, nfft)) ** 2 / np.maximum(null, 1e-300)
        z2 = np.where(inside & (rate <= MAX_ZETA * 2 * np.pi * f), z2, -np.inf)
        i = int(np.argmax(z2))
        if z2[i] > best[0]:
            best = (float(z2[i]), float(f[i]), float(rate))
    n_cells = max((band[1] - band[0]) * span, 1.0)
    threshold = max(2.0 * math.log(n_cells * rates.size / AMPLITUDE_ALPHA), MIN_Z2)
    z2, fz, pz = best
    if z2 >= threshold:
        return Screen(True, z2, fz, pz, threshold, band, span, fs,
                      f"a residual peak at {fz:.4g} Hz (z² = {z2:.3g} ≥ {threshold:.3g}) may "
                      "be another mode; more modes are tried")
    return Screen(False, z2, fz, pz, threshold, band, span, fs,
                  f"one mode: after the mode at {f1:.4g} Hz no peak in {band[0]:.3g}–"
                  f"{band[1]:.3g} Hz stands out of the noise (largest z² = {z2:.3g} at "
                  f"{fz:.4g} Hz, below {threshold:.3g}); no further mode was fitted")
