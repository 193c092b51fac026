r"""Noise model of the fitted samples: level, whiteness, and the calibration factor r.

A Gaussian likelihood with independent samples is exact for white noise. Two things break
that in practice: the samples may be low-pass filtered and decimated (their noise spectrum is
then not flat up to Nyquist), and phone noise is not quite white. For a narrow-band signal at
f₀ the information about the decay rate and frequency comes from frequencies near f₀, and the
Whittle approximation gives the Fisher information as ∝ 1/S(f₀), where S is the noise power
spectral density. An iid likelihood uses the *mean* level σ²/(f_s/2) instead, so it is off by

    r = S(f₀) / (σ² / (f_s/2)),

and dividing the log likelihood by r (a "tempered" likelihood) restores calibrated intervals
(r = 1 for white noise; r ≈ 1.3 for our low-pass-then-decimate path; r > 1 for red noise near
f₀, or for model misfit at f₀, which is where it belongs; r < 1 when the residual variance is
dominated by power far from f₀ — bias drift the polynomial basis does not fully absorb, 1/f
noise, harmonics, masked spikes — which inflates the iid σ² but carries no information about
the decay). r is estimated from the least-squares residuals with Welch's method, averaging
≈ 2·halfwidth·T independent bins (relative error ≈ 1/√(that)).

**Floor: r ≥ r_white.** r_white (:func:`white_ratio`) is the r that white noise of the *same
total residual variance* σ² leaves on the same path (1 on the raw path, ≈ (f_fit/2)/f_cut after
low-pass and decimation). Tempering with r < r_white would make the likelihood sharper than it
would be if every bit of residual power were white sensor noise — it credits the fit with
precision because the misfit sits away from f₀ (a distorted waveform, harmonics, spikes, a
strongly red residual with lag-1 autocorrelation near 1). That power is usually misfit whose
effect on p is not the stationary-noise effect the Whittle argument prices, and the Welch
estimate of S(f₀) is itself noisy, so dampfit never takes that credit: r is floored at r_white,
i.e. r/r_white ≥ 1 (the floor is on r itself, since r_white is what r *is* for white noise, not
1). Intervals therefore only widen under misfit or coloured noise, never narrow. The price is
over-coverage when slow drift inflates σ² (the calibration runs of ``paper/calibration.py``
gave 97 % for nominal 90 % intervals with a floor at 1 under drift); the former floor at 0.2
let a distorted real phone recording (residual lag-1 autocorrelation 0.87) be fitted 5×
sharper than the iid likelihood. ``psd_ratio_raw`` keeps the unfloored value; ``R_FLOOR``
remains as an absolute guard.

**Misfit on an absolute scale** (:func:`misfit_check`): r_raw/r_white > ``R_WARN`` (= 3), or
residual rms above ``RESID_FRACTION`` (5 %) of the fitted signal rms while the sensor noise
predicts less than a third of it — the sensor level is the residuals' own density away from
f₀ and its harmonics (:func:`sensor_density`), taken through the same path
(:func:`expected_sigma`); the same rule in code, docstring and paper/method.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate, signal

__all__ = ["NoiseModel", "estimate", "white_ratio", "sensor_density", "expected_sigma",
           "misfit_check", "R_FLOOR", "R_WARN", "RESID_FRACTION", "NOISE_EXCESS"]

#: Smallest calibration factor used (a guard; r below ≈ 0.3 is not seen on real or simulated data).
R_FLOOR = 0.2
#: r_raw/r_white above this signals structure at f₀ (misfit, a second mode or red noise).
R_WARN = 3.0
#: Residual rms / fitted signal rms [1] above which the residual is "large" …
RESID_FRACTION = 0.05
#: … when it is also more than this many times what the sensor noise alone predicts [1].
NOISE_EXCESS = 3.0


@dataclass(frozen=True)
class NoiseModel:
    """Noise of the fitted samples.

    ``sigma`` [m/s²] residual standard deviation per sample; ``psd_ratio`` r [1] (see module
    docstring); ``lag1`` [1] lag-one autocorrelation of the residuals; ``fs`` [Hz] rate of the
    fitted samples; ``kind`` a short description.
    """

    sigma: float
    psd_ratio: float
    psd_ratio_raw: float
    lag1: float
    fs: float
    kind: str
    white: float = 1.0  # r that white sensor noise alone would give on this path [1]

    def summary(self) -> dict:
        """JSON-safe description for ``summary.json``."""
        return {
            "kind": self.kind,
            "sigma": float(self.sigma),
            "sigma_unit": "m/s^2",
            "psd_ratio_at_f0": float(self.psd_ratio),
            "psd_ratio_at_f0_unclipped": float(self.psd_ratio_raw),
            "residual_lag1_autocorrelation": float(self.lag1),
            "sample_rate_hz": float(self.fs),
            "psd_ratio_expected_for_white_noise": float(self.white),
        }

    @property
    def excess(self) -> float:
        """Unfloored r relative to what white noise would give on this path [1] (≈ 1 when the
        residuals are sensor noise; ≫ 1 for misfit, a second mode or red noise at f₀)."""
        return float(self.psd_ratio_raw / self.white) if self.white > 0 else float("nan")


def white_ratio(sos: np.ndarray | None, fs_filter: float, fs_fit: float, f0: float) -> float:
    """r that white noise would give after the zero-phase low-pass ``sos`` (at ``fs_filter``
    [Hz]) and decimation to ``fs_fit`` [Hz]; 1 without a filter.

    filtfilt applies H twice, so white noise of density N₀ leaves with N₀·|H(f)|⁴. Decimation
    keeps the total power and folds it onto [0, f_fit/2]: the mean level there is
    ∫₀^{f_filter/2} N₀|H|⁴ df / (f_fit/2), and the level at f₀ is N₀·Σ_k |H(f_k)|⁴ over f₀ and
    its aliases f_k = |k·f_fit ± f₀|. r_white is their ratio (≈ (f_fit/2)/f_cut, e.g. ≈ 4 when
    a 20 s window keeps 400 samples of a 2.6 Hz band).
    """
    if sos is None:
        return 1.0
    f = np.linspace(0.0, fs_filter / 2, 40001)
    _, h = signal.sosfreqz(sos, worN=f, fs=fs_filter)
    power = np.abs(h) ** 4
    mean_level = integrate.trapezoid(power, f) / (fs_fit / 2)
    k = np.arange(0, int(np.ceil(fs_filter / fs_fit)) + 2)
    aliases = np.concatenate([k * fs_fit + f0, k[1:] * fs_fit - f0])
    aliases = aliases[aliases <= fs_filter / 2]
    at_f0 = float(np.sum(np.interp(aliases, f, power)))
    return at_f0 / mean_level if mean_level > 0 else 1.0


def estimate(resid: np.ndarray, fs: float, f0: float, halfwidth: float, n_params: int,
             white: float = 1.0) -> NoiseModel:
    """Noise model from least-squares residuals ``resid`` [m/s²] sampled at ``fs`` [Hz].

    ``f0`` [Hz] oscillation frequency, ``halfwidth`` [Hz] half-width of the frequency range
    around f₀ over which S(f₀) is averaged, ``n_params`` number of fitted parameters,
    ``white`` r_white [1] of the path (:func:`white_ratio`; 1 on the raw path): r is floored
    there (module docstring).
    """
    resid = np.asarray(resid, dtype=float)
    n = resid.size
    sigma2 = float(np.sum(resid**2) / max(n - n_params, 1))
    # segments long enough to resolve the half-width, short enough to average ≥ 8 of them
    nper = int(np.clip(4.0 * fs / max(halfwidth, 1e-9), 32, max(32, n // 4)))
    nper = min(nper, n)
    f, pxx = signal.welch(resid, fs=fs, nperseg=nper, detrend=False)
    near = np.abs(f - f0) <= max(halfwidth, 1.5 * (f[1] - f[0]))
    mean_level = np.mean(resid**2) / (fs / 2.0)
    r_raw = float(np.mean(pxx[near]) / mean_level) if near.any() and mean_level > 0 else 1.0
    lag1 = float(np.corrcoef(resid[:-1], resid[1:])[0, 1]) if n > 3 else 0.0
    return NoiseModel(
        sigma=float(np.sqrt(sigma2)),
        psd_ratio=max(R_FLOOR, float(white), r_raw),
        psd_ratio_raw=r_raw,
        lag1=lag1,
        fs=float(fs),
        kind="gaussian, spectrum-calibrated at f0 (Whittle factor r, floored at its white-noise "
             "value), unknown sigma marginalised",
        white=float(white),
    )


def sensor_density(resid: np.ndarray, fs: float, f0: float, f_max: float) -> float:
    """One-sided noise density [(m/s²)/√Hz] of the residuals ``resid`` [m/s²] (rate ``fs``
    [Hz]) *away from the oscillation*: the median Welch level over 0.5·f₀ … ``f_max`` [Hz]
    outside ±0.25·f₀ of f₀ and its harmonics. Misfit of the decay (envelope, frequency drift,
    harmonics) sits at or near k·f₀ and is excluded, so this is the sensor's own level (slightly
    low, ≈ 5 %, as a median; NaN when fewer than 3 bins qualify)."""
    resid = np.asarray(resid, dtype=float)
    n = resid.size
    nper = int(np.clip(16.0 * fs / f0, 32, max(32, n // 2)))
    nper = min(nper, n)
    f, pxx = signal.welch(resid, fs=fs, nperseg=nper, detrend="linear")
    k = np.maximum(np.round(f / f0), 1.0)
    away = (f >= 0.5 * f0) & (f <= f_max) & (np.abs(f - k * f0) > 0.25 * f0)
    if away.sum() < 3:
        return float("nan")
    return float(np.sqrt(np.median(pxx[away])))


def expected_sigma(noise_density: float, fs_fit: float, white: float) -> float:
    """Residual rms [m/s²] that white sensor noise of one-sided density ``noise_density``
    [(m/s²)/√Hz] leaves on the fit path (rate ``fs_fit`` [Hz], r_white ``white``).

    The density at f₀ passes unchanged (|H(f₀)| ≈ 1 in the band), and r_white is by definition
    S(f₀)/(σ²/(f_fit/2)), so σ² = noise_density²·(f_fit/2)/r_white.
    """
    if not (np.isfinite(noise_density) and noise_density > 0 and white > 0):
        return float("nan")
    return float(noise_density * np.sqrt(0.5 * fs_fit / white))


def misfit_check(psd_ratio_raw: float, white: float, resid_rms: float, signal_rms: float,
                 sigma_expected: float) -> dict:
    """The absolute misfit rule of the module docstring.

    ``psd_ratio_raw`` unfloored r [1], ``white`` r_white [1], ``resid_rms`` and ``signal_rms``
    [m/s²] (residual and fitted decay over the window), ``sigma_expected`` [m/s²]
    (:func:`expected_sigma`; NaN if unknown, then only the r rule applies). Returns
    ``{"r_excess", "resid_fraction", "noise_excess", "misfit", "reasons"}``: ``misfit`` when
    r_excess > R_WARN, or resid_fraction > RESID_FRACTION and noise_excess > NOISE_EXCESS.
    """
    r_ex = float(psd_ratio_raw / white) if white > 0 else float("nan")
    frac = float(resid_rms / signal_rms) if signal_rms > 0 else float("nan")
    nex = (float(resid_rms / sigma_expected)
           if np.isfinite(sigma_expected) and sigma_expected > 0 else float("nan"))
    reasons = []
    if r_ex > R_WARN:
        reasons.append(f"r/r_white = {r_ex:.3g} > {R_WARN:g} (residual power at f0)")
    if frac > RESID_FRACTION and nex > NOISE_EXCESS:
        reasons.append(f"residual rms = {100 * frac:.3g} % of the signal > "
                       f"{100 * RESID_FRACTION:g} %, {nex:.3g}x the sensor noise")
    return {"r_excess": r_ex, "resid_fraction": frac, "noise_excess": nex,
            "misfit": bool(reasons), "reasons": reasons}
