r"""The measured damper: a force–velocity curve fitted to the measured envelope itself, for a
deck whose decay follows the recording where a two-coefficient law cannot (issue 32).

**The curve.** F(v) = Σ_j b_j·|v|^{α_j}·sgn(v) over the fixed exponents α_j of
:data:`EXPONENTS`, with b_j ≥ 0 [N·(s/m)^{α_j}]. Each term is passive and F is non-decreasing
for every b ≥ 0, so the curve is a damper at any velocity, inside or outside the measured
range; it is a sum of OpenSees ``Viscous b_j α_j`` materials exactly, and an LS-DYNA
``*DEFINE_CURVE`` table of F(v) for ``*MAT_DAMPER_NONLINEAR_VISCOUS``.

**Its decay.** First-order averaging (harmonic balance; Jacobsen 1930; (K2) of
:mod:`dampfit.model.laws`) gives each term's energy-equivalent rate at displacement amplitude
A and angular frequency ω:

    ρ_j(A) = b_j·(ω·A)^{α_j − 1}·λ(α_j) / (2π·m)   [1/s],   λ(α) of :func:`dampfit.model.laws.lam`

(λ(1) = π: ρ = c/2m), so c_eq(A) = 2·m·Σ_j ρ_j(A) and the averaged envelope obeys
d ln A/dt = −ρ(A), linear in b. Its solution is found by quadrature, t(ln A) =
∫_{ln A}^{ln A₀} du/ρ(eᵘ) (:func:`envelope`), exact for the averaged equation.

**The fit** (:func:`fit`) is to the measured half-period peaks ln P_i at t_i (the envelope
verify compares, :func:`dampfit.fem.response.envelope`):

1. a start by non-negative least squares (``scipy.optimize.nnls``) of the integrated form
   ln P_i = ln A₀ − Σ_j b_j·G_j(t_i), G_j(t) = ∫_{t_0}^{t} ρ_j(A_s)/b_j ds with A_s the measured
   trend (Savitzky–Golay, as verify's), the free ln A₀ projected out by centring;
2. the least squares of the averaged solution itself, ln A(t_i; b, ln A₀) − ln P_i, with
   b ≥ 0 (``scipy.optimize.least_squares``, trust-region reflective) — the error verify
   measures, no longer the trend's.

**Its uncertainty.** The peaks scatter about the averaged envelope by e_i, stationary and
weakly dependent (sensor noise, the beat of neighbouring peaks). A moving-block bootstrap
of the residuals (Künsch 1989; circular blocks of :data:`BLOCK` peaks, the trend's span, so
the dependence within ~7 periods is kept) refits the curve :data:`N_BOOT` times from ŷ + e*;
b scales with the mass (ρ ∝ b/m), so each refit is multiplied by a mass draw m*/m,
m* ~ N(m, sd). c_eq(A) and ζ_eq(A) = ρ(A)/ω are given as the 5/50/95 % quantiles of those
refits. They do not cover the choice of exponents (a structural choice) nor the
first-order averaging (O(ζ)).

**What it cannot follow.** ln c_eq(A) = ln Σ_j β_j·A^{α_j−1} with β_j ≥ 0 is a convex
function of ln A (a sum of log-convex functions is log-convex). A measured ζ(A) that rises
and then flattens or falls (a sigmoid in ln A, as on the phone spring) is followed only by
a passive F(v) outside this family (a tabulated curve with a plateau), which OpenSees has
no uniaxial material for. The fit's rms and the measurement's scatter are given, so the
outputs say whether the curve follows the recording.

**Range.** Fitted over the measured amplitudes [A_lo, A_hi] (velocities ω·A); outside it
the curve is the extrapolation of the same terms. Numeric only: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Exponents α_j of the terms (0.5: strongly softening … 3: stiffening).
EXPONENTS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
#: Bootstrap refits and block length [peaks] (the verify trend's span).
N_BOOT, BLOCK = 100, 15
#: Points of the quadrature grid in ln A; residual evaluations of a bootstrap refit.
_GRID, _BOOT_EVALS = 800, 40


@dataclass(frozen=True)
class MeasuredCurve:
    """The fitted curve: ``exponents`` (J,), ``b`` (J,) [N·(s/m)^α] point estimate, ``boot``
    (B, J) its bootstrap refits (mass draws included), ``omega`` [rad/s], ``mass`` [kg],
    ``ln_a0`` of the averaged envelope at ``t0`` [s], ``rms`` [1] of ln P − ln A(t) over the
    peaks, ``amplitude_range`` [m] and ``velocity_range`` [m/s] of the fit (ω·A)."""

    exponents: np.ndarray
    b: np.ndarray
    boot: np.ndarray
    omega: float
    mass: float
    t0: float
    ln_a0: float
    rms: float
    amplitude_range: tuple[float, float]
    velocity_range: tuple[float, float]

    def c_eq(self, amplitude, b=None):
        """c_eq(A) = 2·m·ρ(A) [N·s/m] at displacement amplitudes ``amplitude`` [m] (of ``b``,
        default the point estimate; b of shape (B, J) gives (B, len(A)))."""
        b = self.b if b is None else np.asarray(b, float)
        rates = term_rates(np.atleast_1d(amplitude), self.omega, self.mass, self.exponents)
        return 2.0 * self.mass * (b @ rates.T)

    def interval(self, amplitude: float) -> dict[str, float]:
        """c_eq and ζ_eq at ``amplitude`` [m]: point value and the bootstrap's q05/q50/q95."""
        draws = self.c_eq(amplitude, self.boot)[:, 0]
        q05, q50, q95 = (float(x) for x in np.quantile(draws, [0.05, 0.5, 0.95]))
        crit = 2.0 * self.mass * self.omega
        return {"c": float(self.c_eq(amplitude)[0]), "q05": q05, "q50": q50, "q95": q95,
                "zeta": float(self.c_eq(amplitude)[0]) / crit, "zeta_q05": q05 / crit,
                "zeta_q95": q95 / crit}


def term_rates(amplitude: np.ndarray, omega: float, mass: float, exponents) -> np.ndarray:
    """ρ_j(A)/b_j [1/s per N·(s/m)^α_j] of each term at the amplitudes (module docstring);
    shape (len(A), J)."""
    al = np.asarray(exponents, float)
    from dampfit.model.laws import lam

    a = np.asarray(amplitude, float)[:, None]
    return (omega * a) ** (al - 1.0) * lam(al) / (2.0 * math.pi * mass)


def envelope(b, ln_a0: float, t: np.ndarray, omega: float, mass: float, exponents,
             ln_floor: float) -> np.ndarray:
    """ln A(t) [ln m] of the averaged equation d ln A/dt = −ρ(A) from ln A₀ at t = 0, by the
    quadrature of the module docstring on ``_GRID`` points down to ``ln_floor``; past the grid
    the last rate continues."""
    u = np.linspace(ln_a0, min(ln_floor, ln_a0 - 1e-6), _GRID)
    rho = term_rates(np.exp(u), omega, mass, exponents) @ np.asarray(b, float)
    inv = 1.0 / np.maximum(rho, 1e-300)
    tg = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * -np.diff(u))])
    t = np.asarray(t, float)
    out = np.interp(t, tg, u)
    late = t > tg[-1]
    out[late] = u[-1] - rho[-1] * (t[late] - tg[-1])
    return out


def _start(t, ln_p, trend, omega, mass, exponents) -> tuple[np.ndarray, float]:
    """Step 1 of the fit: NNLS of the integrated form (module docstring)."""
    from scipy.optimize import nnls

    g = term_rates(np.exp(trend), omega, mass, exponents)
    G = np.zeros_like(g)
    G[1:] = np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t)[:, None], axis=0)
    Gc, yc = G - G.mean(axis=0), ln_p - ln_p.mean()
    scale = np.linalg.norm(Gc, axis=0)
    scale[scale == 0] = 1.0
    x, _ = nnls(-Gc / scale, yc)
    b = x / scale
    return b, float(ln_p.mean() + G.mean(axis=0) @ b)


def _refine(t, ln_p, b0, a0, system, floor, evals=None) -> np.ndarray:
    """Step 2: bounded least squares of the averaged envelope (``system`` = (ω, m,
    exponents); at most ``evals`` residual evaluations: a bootstrap refit starts at the
    optimum); returns (b…, ln A₀)."""
    from scipy.optimize import least_squares

    scale = np.where(b0 > 0, b0, max(float(b0.max()), 1e-12) * 1e-2)

    def resid(x):
        return envelope(x[:-1] * scale, x[-1], t, *system, floor) - ln_p

    x0 = np.concatenate([b0 / scale, [a0]])
    lo = np.concatenate([np.zeros(b0.size), [-np.inf]])
    res = least_squares(resid, x0, bounds=(lo, np.inf), method="trf", x_scale=1.0,
                        max_nfev=evals)
    return np.concatenate([res.x[:-1] * scale, res.x[-1:]])


def fit(t: np.ndarray, peaks: np.ndarray, omega: float, mass: float, mass_sd: float = 0.0,
        exponents=EXPONENTS, seed: int = 0) -> MeasuredCurve:
    """The measured curve of peaks ``peaks`` [m] (displacement amplitudes, half-period
    extrema) at times ``t`` [s], ``omega`` [rad/s], ``mass`` [kg] ± ``mass_sd`` (module
    docstring); ``seed`` makes the bootstrap reproducible. ValueError with fewer than
    2·:data:`BLOCK` peaks."""
    from scipy.signal import savgol_filter

    peaks = np.asarray(peaks, float)
    if not np.all(np.isfinite(peaks) & (peaks > 0)):
        raise ValueError("the peaks must be positive and finite")
    t, ln_p = np.asarray(t, float), np.log(peaks)
    if t.size < 2 * BLOCK:
        raise ValueError(f"{t.size} peaks: the measured curve needs at least {2 * BLOCK}")
    al = np.asarray(exponents, float)
    tau = t - t[0]
    floor = float(ln_p.min()) - 1.0
    trend = savgol_filter(ln_p, BLOCK, 2)
    b0, a0 = _start(tau, ln_p, trend, omega, mass, al)
    x = _refine(tau, ln_p, b0, a0, (omega, mass, al), floor)
    fitted = envelope(x[:-1], x[-1], tau, omega, mass, al, floor)
    resid = ln_p - fitted
    rng = np.random.default_rng(seed)
    n, boot = t.size, np.empty((N_BOOT, al.size))
    for i in range(N_BOOT):
        starts = rng.integers(0, n, size=-(-n // BLOCK))
        idx = (starts[:, None] + np.arange(BLOCK)[None, :]).ravel()[:n] % n
        xb = _refine(tau, fitted + resid[idx], x[:-1], x[-1], (omega, mass, al), floor,
                     evals=_BOOT_EVALS)
        m_star = mass + mass_sd * rng.standard_normal() if mass_sd > 0 else mass
        boot[i] = xb[:-1] * m_star / mass
    lo, hi = float(np.exp(trend.min())), float(np.exp(trend.max()))
    return MeasuredCurve(al, x[:-1], boot, float(omega), float(mass), float(t[0]),
                         float(x[-1]), float(np.sqrt(np.mean(resid ** 2))), (lo, hi),
                         (omega * lo, omega * hi))
