r"""Model checks for ``summary.json``: residual whiteness at f₀, amplitude dependence, warning.

**Residual whiteness at f₀.** A wrong envelope leaves a slowly varying misfit *at the
oscillation frequency*; broadband noise colour does not matter for it. The residuals are
demodulated at ω and averaged over each cycle, z_j = mean over cycle j of res·e^{−iωτ}
(one complex number per cycle, ≈ independent for noise that is smooth across 0…2f₀), and the
Ljung–Box statistic (Ljung & Box 1978)

    Q = B·(B + 2)·Σ_{h=1}^{H} ρ̂_h²/(B − h),

of the real and of the imaginary parts (summed: χ² with 2H degrees of freedom under
whiteness) tests them, with H = min(10, B/5) lags over B cycles. A small p-value with the
viscous law and a large one with the preferred law says the envelope was the misfit. The
Whittle factor r (:mod:`dampfit.noise`) of each law's residuals is reported beside it.

**Warning text.** :func:`warning_text` states, when amplitude dependence is detected, how
much ζ changes over the recorded amplitudes, which law fits and what to put in the FEM model.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = ["ljung_box", "envelope_whiteness", "warning_text", "FEM_HINT"]

#: What to enter in an FEM code for each law (LS-DYNA discrete dampers, OpenSees materials).
FEM_HINT = {
    "viscous": "a linear dashpot c (LS-DYNA *MAT_DAMPER_VISCOUS, DC = c; OpenSees "
               "uniaxialMaterial Viscous with alpha = 1)",
    "coulomb": "a dashpot c plus a friction force F_c (e.g. LS-DYNA *MAT_DAMPER_NONLINEAR_VISCOUS "
               "with the force–velocity curve F = c·v + F_c·sign(v), or a friction element)",
    "quadratic": "a dashpot with F = c·v + c2·v·|v| (LS-DYNA *MAT_DAMPER_NONLINEAR_VISCOUS with "
                 "that force–velocity curve)",
    "power": "a nonlinear viscous damper F = c_alpha·|v|^alpha·sign(v) (OpenSees uniaxialMaterial "
             "Viscous C alpha; LS-DYNA *MAT_DAMPER_NONLINEAR_VISCOUS with that curve)",
}


def ljung_box(x: np.ndarray, lags: int) -> tuple[float, float]:
    """Ljung–Box Q [1] and its χ²(``lags``) p-value for the series ``x``."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    b = x.size
    den = float(x @ x)
    if b <= lags + 1 or den <= 0:
        return float("nan"), float("nan")
    rho = np.array([float(x[:-h] @ x[h:]) / den for h in range(1, lags + 1)])
    q = float(b * (b + 2) * np.sum(rho**2 / (b - np.arange(1, lags + 1))))
    return q, float(stats.chi2.sf(q, lags))


def envelope_whiteness(tau: np.ndarray, resid: np.ndarray, omega: float) -> dict:
    """Ljung–Box test of the per-cycle demodulated residuals (module docstring).

    ``tau`` [s], ``resid`` [m/s²], ``omega`` [rad/s]. Returns ``{"q", "p_value", "lags",
    "n_cycles"}`` (NaN where there are fewer than 10 cycles).
    """
    tau = np.asarray(tau, dtype=float)
    blocks = np.floor((tau - tau[0]) * omega / (2 * np.pi)).astype(int)
    nb = int(blocks.max()) + 1
    cnt = np.bincount(blocks, minlength=nb)
    z = resid * np.exp(-1j * omega * tau)
    zr = np.bincount(blocks, weights=z.real, minlength=nb)
    zi = np.bincount(blocks, weights=z.imag, minlength=nb)
    keep = cnt > 0
    zr, zi = zr[keep] / cnt[keep], zi[keep] / cnt[keep]
    b = zr.size
    if b < 10:
        return {"q": None, "p_value": None, "lags": 0, "n_cycles": b}
    h = int(min(10, b // 5))
    q1, _ = ljung_box(zr, h)
    q2, _ = ljung_box(zi, h)
    q = q1 + q2
    return {"q": q, "p_value": float(stats.chi2.sf(q, 2 * h)), "lags": h, "n_cycles": b}


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def warning_text(preferred: str, p_viscous: float, zeta_hi: float, zeta_lo: float,
                 a_hi: float, a_lo: float, c_ref: float | None, a_ref: float,
                 source: str = "windowed fits") -> str:
    """The warning a user sees when one viscous c does not describe the decay.

    ζ [1] at the largest and smallest displacement amplitude ``a_hi``, ``a_lo`` [m] (from
    ``source``); ``c_ref`` [N·s/m] (None without mass) the preferred law's equivalent viscous
    c at ``a_ref`` [m].
    """
    at = (f"c_eq = {_fmt(c_ref)} N·s/m at {_fmt(a_ref)} m amplitude" if c_ref is not None
          else f"ζ_eq is given at {_fmt(a_ref)} m amplitude (no mass: no c)")
    verb = "falls" if zeta_lo < zeta_hi else "rises"
    return (
        f"damping depends on amplitude: ζ {verb} from {_fmt(zeta_hi)} at {_fmt(a_hi)} m to "
        f"{_fmt(zeta_lo)} at {_fmt(a_lo)} m ({source}; P(one viscous c) = {p_viscous:.2g}); "
        f"the {preferred} law fits best, so a single viscous c is not adequate — {at}; "
        f"for FEM use {FEM_HINT[preferred]}"
    )
