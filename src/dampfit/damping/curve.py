r"""ζ(amplitude): windowed viscous fits along the decay, and the slope of ln p against ln a.

The decay is cut into windows of ``cycles`` oscillation cycles with 50 % overlap. In each
window the *viscous* model, with a local offset and slope for whatever drift is left after the
global drift fit is subtracted,

    y(τ') = e^{−p·τ'}·(A·cos ωτ' + B·sin ωτ') + d₀ + d₁·τ',   τ' = τ − τ_c (window centre),

is fitted by variable projection (scipy's Levenberg–Marquardt over (p, ω); A, B, d₀, d₁
linear). Centring τ' makes the amplitude √(A² + B²) the acceleration amplitude at τ_c [m/s²],
nearly uncorrelated with p; the displacement amplitude is that over ω_n²·|G| [m]. The 1-σ of p
comes from the Jacobian, s²·(JᵀJ)⁻¹, multiplied by the global Whittle factor r
(:mod:`dampfit.inference.noise`) so that the windows carry the same calibration as the global fits. p may come out negative in
a noisy window; it is kept (dropping it would bias the curve).

If the damping is viscous, p does not depend on the amplitude a. A power law
p(a) = p_ref·(a/a_ref)^s (s = α − 1 of the power-law damper, :mod:`~dampfit.model.laws`)
is fitted by weighted least squares to the *non-overlapping* windows (every second one), its
standard errors scaled by √max(1, χ²/ν) (overdispersion), and the 90 % interval of s uses
Student's t with ν = n_windows − 2. NumPy/SciPy only; no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from dampfit.errors import InputError

#: Fewest samples a window needs (6 parameters are fitted in it).
MIN_WINDOW_SAMPLES = 16
#: Windows aimed for along the decay when the length is automatic.
TARGET_WINDOWS = 16


@dataclass(frozen=True)
class Window:
    """One windowed viscous fit. Times [s] from the fit window start, as ``FitData.tau``."""

    t_start: float
    t_end: float
    t_center: float
    p: float  # decay rate [1/s]
    p_sd: float  # 1-σ [1/s], calibrated by r
    omega_d: float  # [rad/s]
    accel_amplitude: float  # acceleration amplitude at the centre [m/s²]
    amplitude: float  # displacement amplitude at the centre [m]
    n: int
    omega_sd: float = float("nan")  # 1-σ of omega_d [rad/s], calibrated by r

    @property
    def zeta(self) -> float:
        return self.p / float(np.hypot(self.p, self.omega_d))

    @property
    def zeta_sd(self) -> float:
        return self.p_sd / float(np.hypot(self.p, self.omega_d))


def auto_cycles(n_cycles_total: float, samples_per_cycle: float) -> float:
    """Window length [cycles]: ≥ 4 cycles, ≥ :data:`MIN_WINDOW_SAMPLES` samples, ≈ 16 windows."""
    need = MIN_WINDOW_SAMPLES / max(samples_per_cycle, 1e-9)
    return float(max(4.0, np.ceil(need), np.round(2.0 * n_cycles_total / (TARGET_WINDOWS + 1))))


def _fit_window(tau, y, p0, w0):
    tc = 0.5 * (tau[0] + tau[-1])
    tp = tau - tc

    def design(th):
        env = np.exp(-th[0] * tp)
        return np.stack([env * np.cos(th[1] * tp), env * np.sin(th[1] * tp),
                         np.ones_like(tp), tp], axis=1)

    def resid(th):
        x = design(th)
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        return y - x @ coef

    scale = [max(abs(p0), 1e-3 * w0), 1e-3 * w0]
    sol = optimize.least_squares(resid, np.array([p0, w0]), method="lm", x_scale=scale,
                                 xtol=1e-10, ftol=1e-10)
    p, w = sol.x
    x = design(sol.x)
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    r = y - x @ coef
    env = np.exp(-p * tp)
    a, b = coef[0], coef[1]
    osc = env * (a * np.cos(w * tp) + b * np.sin(w * tp))
    j = np.column_stack([-tp * osc, env * tp * (-a * np.sin(w * tp) + b * np.cos(w * tp)), x])
    s2 = float(r @ r) / max(y.size - 6, 1)
    try:
        cov = s2 * np.linalg.inv(j.T @ j)
    except np.linalg.LinAlgError:
        cov = np.full((6, 6), np.nan)
    return p, w, float(np.hypot(a, b)), cov, tc, bool(sol.success)


def windows(tau, y, omega: float, p_guess: float, *, cycles: float, psd_ratio: float = 1.0,
            gain: float = 1.0) -> list[Window]:
    """Windowed viscous fits of ``y`` [m/s²] at ``tau`` [s] (global drift already removed).

    ``omega`` [rad/s] and ``p_guess`` [1/s] start each fit; ``cycles`` window length [cycles];
    ``psd_ratio`` r [1] calibrates the intervals; ``gain`` |G| [1] of the decimation filter.
    """
    tau = np.asarray(tau, dtype=float)
    y = np.asarray(y, dtype=float)
    if not np.isfinite(cycles) or cycles < 2:
        raise InputError(f"amplitude windows must span at least 2 cycles, got {cycles!r}")
    length = cycles * 2 * np.pi / omega
    if tau[-1] - tau[0] < length:
        return []
    starts = np.arange(tau[0], tau[-1] - length + 1e-9 * length, 0.5 * length)
    out: list[Window] = []
    for t0 in starts:
        sel = (tau >= t0) & (tau <= t0 + length)
        if sel.sum() < MIN_WINDOW_SAMPLES:
            continue
        p, w, acc, cov, tc, ok = _fit_window(tau[sel], y[sel], p_guess, omega)
        if not (ok and np.isfinite(cov[0, 0]) and cov[0, 0] >= 0 and w > 0):
            continue
        out.append(Window(
            t_start=float(t0), t_end=float(t0 + length), t_center=float(tc), p=float(p),
            p_sd=float(np.sqrt(cov[0, 0] * max(psd_ratio, 1.0))), omega_d=float(w),
            accel_amplitude=acc, amplitude=acc / ((w * w + p * p) * gain), n=int(sel.sum()),
            omega_sd=float(np.sqrt(max(cov[1, 1], 0.0) * max(psd_ratio, 1.0))),
        ))
    return out


def slope(wins: list[Window], level: float = 0.90) -> dict | None:
    """Fit p = p_ref·(a/a_ref)^s to the non-overlapping windows; None with fewer than 4.

    Returns ``{"s", "s_sd", "s_q05", "s_q95", "p_ref" [1/s], "a_ref" [m], "n_windows",
    "chi2_per_dof"}``; s = d ln p/d ln a [1] (0 for viscous damping, α − 1 for a power law).
    """
    use = [w for i, w in enumerate(wins) if i % 2 == 0 and w.amplitude > 0 and w.p_sd > 0]
    if len(use) < 4:
        return None
    a = np.array([w.amplitude for w in use])
    p = np.array([w.p for w in use])
    sd = np.array([w.p_sd for w in use])
    a_ref = float(np.exp(np.mean(np.log(a))))
    x = np.log(a / a_ref)
    p_ref0 = float(np.sum(p / sd**2) / np.sum(1 / sd**2))

    def resid(th):
        return (p - th[0] * np.exp(th[1] * x)) / sd

    sol = optimize.least_squares(resid, np.array([p_ref0, 0.0]), method="lm")
    j = sol.jac
    dof = len(use) - 2
    chi2 = float(sol.fun @ sol.fun) / dof
    try:
        cov = np.linalg.inv(j.T @ j) * max(1.0, chi2)
    except np.linalg.LinAlgError:
        return None
    s, s_sd = float(sol.x[1]), float(np.sqrt(cov[1, 1]))
    tq = float(stats.t.ppf(0.5 + level / 2, dof))
    return {"s": s, "s_sd": s_sd, "s_q05": s - tq * s_sd, "s_q95": s + tq * s_sd,
            "p_ref": float(sol.x[0]), "a_ref": a_ref, "n_windows": len(use),
            "chi2_per_dof": chi2}


def frequency_trend(wins: list[Window], level: float = 0.90) -> dict | None:
    """Does the frequency drift with amplitude? ln ω_d = ln ω_ref + g·ln(a/a_ref) on the
    non-overlapping windows (weighted least squares, standard error scaled by √max(1, χ²/ν));
    None with fewer than 4 windows.

    Returns ``{"g", "g_sd", "g_q05", "g_q95", "rel_change", "rel_change_sd", "n_windows"}``:
    ``rel_change`` = (a_max/a_min)^g − 1 [1] is the relative change of the damped frequency
    from the smallest to the largest windowed amplitude (> 0: the frequency rises with
    amplitude, hardening; < 0 softening, like a pendulum).
    """
    use = [w for i, w in enumerate(wins) if i % 2 == 0 and w.amplitude > 0
           and np.isfinite(w.omega_sd) and w.omega_sd > 0]
    if len(use) < 4:
        return None
    a = np.array([w.amplitude for w in use])
    y = np.log([w.omega_d for w in use])
    sd = np.array([w.omega_sd / w.omega_d for w in use])
    x = np.log(a / np.exp(np.mean(np.log(a))))
    wts = 1.0 / sd**2
    xm = np.sum(wts * x) / np.sum(wts)
    sxx = float(np.sum(wts * (x - xm) ** 2))
    if sxx <= 0:
        return None
    g = float(np.sum(wts * (x - xm) * (y - np.sum(wts * y) / np.sum(wts))) / sxx)
    fit = np.sum(wts * y) / np.sum(wts) + g * (x - xm)
    dof = len(use) - 2
    chi2 = float(np.sum(wts * (y - fit) ** 2)) / dof
    g_sd = float(np.sqrt(max(1.0, chi2) / sxx))
    tq = float(stats.t.ppf(0.5 + level / 2, dof))
    span = float(np.log(a.max() / a.min()))
    return {"g": g, "g_sd": g_sd, "g_q05": g - tq * g_sd, "g_q95": g + tq * g_sd,
            "rel_change": float(np.expm1(g * span)), "rel_change_sd": float(g_sd * span),
            "n_windows": len(use), "chi2_per_dof": chi2}
