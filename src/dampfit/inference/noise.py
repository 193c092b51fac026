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

**The calibrated r** (``estimate(..., jacobian=J)``, the pipeline's viscous posterior). Three
things bias the plain ratio above, each measured on ``paper/calibration.py``'s scenarios:

* *The fit's own projection.* The least squares removes the residual's component along every
  column of the model's Jacobian J (amplitudes, decay, frequency: all at f₀; drift: at low
  frequency), so the residual spectrum near f₀ is depleted: by 3 % on a 36 s window, by 30 %
  on a 1.7 s one (a 3 s record: plain r 0.64 for white noise). For white noise the expected
  Welch estimate of the residual is the noise level times d(f) = 1 − tr((JᵀJ)⁻¹·JᵀA_fJ)/tr(A_f)
  (A_f the Welch quadratic form at f: E[(Pε)ᵀA_f(Pε)] = σ²·tr(A_f·P), P the residual
  projector); the residual spectrum is divided by d(f). The level is s² = RSS/(n − q)
  (unbiased), not the mean square.
* *Power away from f₀* — bias drift the polynomial basis does not absorb, 1/f wander — inflates
  σ² but carries no information about the decay. It enters neither estimate below, while the
  former floor at r_white (white noise of the *whole* residual variance) priced it as if it
  were at f₀: 97–98 % coverage of nominal 90 % intervals under drift and 1/f noise.
* *Few bins near f₀.* On a short record the local estimate rests on a handful of Welch bins
  (relative sd 34 % on 1.7 s) and undercovers.

So r = max(r_local, r_sensor, :data:`R_FLOOR`) with

* r_local — the depletion-corrected residual spectrum averaged over ±halfwidth of f₀ (bins at
  ≥ f₀/2 only: the drift's dip at 0 Hz is no noise level), over s²/(f_s/2);
* r_sensor — the floor: the level that white noise would have at f₀ if it carried *all* the
  residual power from f₀/2 up to Nyquist (depletion-corrected, and divided by the path's power
  gain: the zero-phase low-pass |H|⁴ with its aliases, :func:`path_gain`). Many bins, so it is
  steady; misfit at the harmonics raises it, as the former floor did; drift and wander below
  f₀/2 do not. r is thus never below what white sensor noise of the residual's own
  high-frequency power would give, and only that — never below r_white·(share of the residual
  variance above f₀/2).

Measured (least-squares Laplace intervals, 150–400 replicates a scenario): 90 % coverage of
ln p and ln ω_d 0.905/0.915 (white), 0.88/0.87 (drift; the unabsorbed drift itself adds ≈ 5 %
variance to the estimates), 0.88/0.93 (1/f), 0.92/0.89 (3 s record), against 0.91/0.92,
0.97/0.98, 0.95/0.96, 0.92/0.90 with the floor at r_white.

Without a Jacobian (the damping-law fits of :mod:`dampfit.damping`) r is the plain ratio
floored at r_white, ``max(R_FLOOR, r_white, r_raw)``: their evidence and the misfit rule were
calibrated that way (``tests/recovery/test_adequacy.py``). ``psd_ratio_raw`` is always the plain ratio.

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

#: Smallest calibration factor used [1], a numerical guard (temper ≤ 100). In the calibrated
#: mode r falls below 1 when slow drift below f₀/2 carries much of the residual variance
#: (0.53 on paper/calibration.py's drift scenario; 0.07 with a drift 14× the noise power);
#: the plain mode never goes below r_white ≥ 1.
R_FLOOR = 0.01
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
    #: the calibrated mode's two estimates (module docstring): local at f₀ and the sensor
    #: floor [1]; NaN in the plain mode
    local: float = float("nan")
    sensor: float = float("nan")

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


def path_gain(sos: np.ndarray | None, fs_filter: float, fs_fit: float, f: np.ndarray) -> np.ndarray:
    """Power gain [1] of the fit path at frequencies ``f`` [Hz] of the fitted samples (rate
    ``fs_fit`` [Hz]): Σ_k |H(f_k)|⁴ over f and its aliases f_k = |k·f_fit ± f| below
    ``fs_filter``/2 [Hz] for the zero-phase low-pass ``sos`` (filtfilt applies H twice), or 1
    without a filter."""
    f = np.atleast_1d(np.asarray(f, dtype=float))
    if sos is None:
        return np.ones_like(f)
    grid = np.linspace(0.0, fs_filter / 2, 40001)
    _, h = signal.sosfreqz(sos, worN=grid, fs=fs_filter)
    power = np.abs(h) ** 4
    out = np.zeros_like(f)
    for k in range(0, int(np.ceil(fs_filter / fs_fit)) + 2):
        for alias in (k * fs_fit + f, (k + 1) * fs_fit - f):
            out += np.where(alias <= fs_filter / 2, np.interp(alias, grid, power), 0.0)
    return out


def white_ratio(sos: np.ndarray | None, fs_filter: float, fs_fit: float, f0: float) -> float:
    """r that white noise would give after the zero-phase low-pass ``sos`` (at ``fs_filter``
    [Hz]) and decimation to ``fs_fit`` [Hz]; 1 without a filter.

    filtfilt applies H twice, so white noise of density N₀ leaves with N₀·|H(f)|⁴. Decimation
    keeps the total power and folds it onto [0, f_fit/2]: the mean level there is
    ∫₀^{f_filter/2} N₀|H|⁴ df / (f_fit/2), and the level at f₀ is N₀·Σ_k |H(f_k)|⁴ over f₀ and
    its aliases f_k = |k·f_fit ± f₀| (:func:`path_gain`). r_white is their ratio
    (≈ (f_fit/2)/f_cut, e.g. ≈ 4 when a 20 s window keeps 400 samples of a 2.6 Hz band).
    """
    if sos is None:
        return 1.0
    f = np.linspace(0.0, fs_filter / 2, 40001)
    _, h = signal.sosfreqz(sos, worN=f, fs=fs_filter)
    mean_level = integrate.trapezoid(np.abs(h) ** 4, f) / (fs_fit / 2)
    at_f0 = float(path_gain(sos, fs_filter, fs_fit, np.array([f0]))[0])
    return at_f0 / mean_level if mean_level > 0 else 1.0


def _welch_segments(n: int, nper: int) -> np.ndarray:
    """Start indices of scipy's Welch segments (half overlap, the incomplete tail dropped)."""
    return np.arange(0, n - nper + 1, nper - nper // 2)


def projection_depletion(jacobian: np.ndarray, nper: int) -> np.ndarray:
    """d(f) [1] per one-sided Welch bin (Hann, ``nper`` samples, half overlap): the expected
    Welch spectrum of least-squares residuals over that of white noise, 1 − tr((JᵀJ)⁻¹JᵀA_fJ)/
    tr(A_f) for the design ``jacobian`` J (n, k) (module docstring), clipped to [0.05, 1]."""
    jac = np.asarray(jacobian, dtype=float)
    n = jac.shape[0]
    win = signal.get_window("hann", nper)
    starts = _welch_segments(n, nper)
    seg = jac[starts[:, None] + np.arange(nper)[None, :]] * win[None, :, None]  # (K, nper, k)
    spec = np.fft.rfft(seg, axis=1)  # (K, bins, k)
    scale = np.sqrt(np.sum(jac**2, axis=0))  # column scaling: the quadratic form is invariant
    scale = np.where(scale > 0, scale, 1.0)
    chol = np.linalg.cholesky((jac / scale).T @ (jac / scale))
    white = np.linalg.solve(chol, np.moveaxis(spec / scale, -1, 0).reshape(jac.shape[1], -1))
    quad = np.sum(np.abs(white) ** 2, axis=0).reshape(spec.shape[:2]).mean(axis=0)
    return np.clip(1.0 - quad / np.sum(win**2), 0.05, 1.0)


def _calibrated(resid: np.ndarray, jacobian: np.ndarray, fs: float, f0: float,
                halfwidth: float, nper: int, gain) -> tuple[float, float]:
    """(r_local, r_sensor) of the module docstring."""
    n, k = jacobian.shape
    f, pxx = signal.welch(resid, fs=fs, nperseg=nper, detrend=False)
    spec = pxx / projection_depletion(jacobian, nper)
    level = float(np.sum(resid**2)) / max(n - k, 1) / (fs / 2.0)
    if not level > 0:
        return 1.0, 1.0
    inner = (f > 0) & (f < fs / 2) & (f >= 0.5 * f0)
    near = inner & (np.abs(f - f0) <= max(halfwidth, 1.5 * (f[1] - f[0])))
    if not near.any():  # bins wider than the band: the one nearest f₀
        near = inner & (np.abs(f - f0) == np.min(np.abs(f[inner] - f0)))
    local = float(np.mean(spec[near])) / level
    g = gain(f[inner])
    at_f0 = float(gain(np.array([f0]))[0])
    sensor = float(np.sum(spec[inner]) / np.sum(g)) * at_f0 / level if np.sum(g) > 0 else 0.0
    return local, sensor


def estimate(resid: np.ndarray, fs: float, f0: float, halfwidth: float, n_params: int,
             white: float = 1.0, *, jacobian: np.ndarray | None = None,
             lowpass: tuple | None = None) -> NoiseModel:
    """Noise model from least-squares residuals ``resid`` [m/s²] sampled at ``fs`` [Hz].

    ``f0`` [Hz] oscillation frequency, ``halfwidth`` [Hz] half-width of the frequency range
    around f₀ over which S(f₀) is averaged, ``n_params`` number of fitted parameters,
    ``white`` r_white [1] of the path (:func:`white_ratio`; 1 on the raw path). With the fit's
    ``jacobian`` (n, n_params) [m/s² per unit] r is the calibrated one of the module
    docstring (``lowpass`` = (sos, fs_filter [Hz]): the path's low-pass, None on the raw path);
    without it the plain ratio floored at ``white``.
    """
    sos, fs_filter = lowpass if lowpass is not None else (None, None)
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
    if jacobian is None or np.shape(jacobian)[0] != n:
        r, local, sensor = max(R_FLOOR, float(white), r_raw), float("nan"), float("nan")
        kind = ("gaussian, spectrum-calibrated at f0 (Whittle factor r, floored at its "
                "white-noise value), unknown sigma marginalised")
    else:
        local, sensor = _calibrated(
            resid, np.asarray(jacobian, dtype=float), fs, f0, halfwidth, nper,
            lambda ff: path_gain(sos, fs_filter or fs, fs, ff))
        r = max(R_FLOOR, local, sensor)
        kind = ("gaussian, spectrum-calibrated at f0 (Whittle factor r corrected for the fit's "
                "projection, floored at the white level of the residual above f0/2), unknown "
                "sigma marginalised")
    return NoiseModel(
        sigma=float(np.sqrt(sigma2)),
        psd_ratio=float(r),
        psd_ratio_raw=r_raw,
        lag1=lag1,
        fs=float(fs),
        kind=kind,
        white=float(white),
        local=float(local),
        sensor=float(sensor),
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
