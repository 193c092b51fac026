r"""Rayleigh damping from measured modes: the α, β that reproduce each mode's ζ at its ω.

Rayleigh (proportional) damping C = α·M + β·K gives mode i, with natural angular frequency
ω_i [rad/s], the damping ratio (Chopra, *Dynamics of Structures*, eq. 11.4.3)

    ζ(ω) = α/(2ω) + β·ω/2,     α [1/s] (mass-proportional), β [s] (stiffness-proportional).   (R1)

From K ≥ 2 measured modes (ω_i, ζ_i) the coefficients solve the linear system
G·(α, β)ᵀ = ζ with rows G_i = (1/(2ω_i), ω_i/2):

* K = 2: exactly, (α, β) = G⁻¹ζ — (R1) then passes through both measured ζ;
* K ≥ 3: by weighted least squares, weights w_i = 1/sd(ζ_i)² (the posterior spread of each
  ζ_i), (α, β) = (GᵀWG)⁻¹GᵀWζ, and the **misfit** says whether two coefficients can carry
  K damping ratios: χ² = Σ w_i·(ζ_i − ζ(ω_i))² on K − 2 degrees of freedom, its p-value, and
  the largest relative misfit |ζ(ω_i)/ζ_i − 1|. A small p-value means the measured ζ(ω) is
  not of the form (R1): give the FEM model per-mode (modal) damping instead.

**Intervals** come from the posterior draws: every joint draw of (ω_i, ζ_i) of all modes is
mapped to its own (α, β) with the same weights, so the interval carries the measurement
uncertainty and the correlation between modes (not the misfit of R1 itself for K ≥ 3).
A negative α or β (ζ falling faster than 1/ω, or rising faster than ω) is reported as such:
most FEM codes do not accept it.

Pure NumPy/SciPy functions of arrays; no I/O. Units: ω [rad/s], ζ [1], α [1/s], β [s].
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from dampfit.errors import InputError


def rayleigh_zeta(alpha, beta, omega):
    """ζ(ω) of (R1) [1] for α [1/s], β [s] at ω [rad/s] (broadcasts)."""
    omega = np.asarray(omega, dtype=float)
    return np.asarray(alpha, dtype=float) / (2 * omega) + np.asarray(beta, dtype=float) * omega / 2


def _check(omega, zeta):
    w, z = np.asarray(omega, dtype=float), np.asarray(zeta, dtype=float)
    if w.shape != z.shape or w.ndim < 1:
        raise InputError(f"omega and zeta must have the same shape, got {w.shape} and {z.shape}")
    if w.shape[-1] < 2:
        raise InputError("Rayleigh damping needs at least two modes (α and β are two unknowns)")
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(z)) and np.all(w > 0)):
        raise InputError("omega must be positive and zeta finite for every mode")
    if np.any(np.min(np.abs(np.diff(np.sort(w, axis=-1), axis=-1)), axis=-1) <= 0):
        raise InputError("two modes have the same frequency: Rayleigh α, β are not determined")
    return w, z


def _weights(weights, k):
    if weights is None:
        return np.ones(k)
    w = np.asarray(weights, dtype=float)
    if w.shape != (k,) or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise InputError(f"weights must be {k} positive finite numbers")
    return w


def _solve(omega, zeta, w):
    """Weighted least squares of (R1) for rows (..., K): (α, β) of shape (..., 2)."""
    g = np.stack([0.5 / omega, 0.5 * omega], axis=-1)  # (..., K, 2)
    gw = g * w[:, None]
    a = np.einsum("...ki,...kj->...ij", gw, g)
    b = np.einsum("...ki,...k->...i", gw, zeta)
    return np.linalg.solve(a, b[..., None])[..., 0]


def rayleigh(omega, zeta, weights=None) -> dict:
    """α [1/s], β [s] of (R1) from ω_i [rad/s] and ζ_i [1] (K ≥ 2 modes), with the misfit.

    ``weights`` (K,) positive (default equal). Returns ``{"alpha", "beta", "zeta_fitted"
    (K,), "chi2", "dof", "p_value", "max_relative_misfit"}`` (χ² uses the weights as
    inverse variances; dof = K − 2, and for K = 2 χ² = 0, p = 1)."""
    w, z = _check(omega, zeta)
    wt = _weights(weights, w.shape[-1])
    alpha, beta = _solve(w, z, wt)
    fitted = alpha / (2 * w) + beta * w / 2
    chi2 = float(np.sum(wt * (z - fitted) ** 2))
    dof = w.size - 2
    p = 1.0 if dof == 0 else float(stats.chi2.sf(chi2, dof))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = float(np.max(np.abs(fitted / z - 1.0)))
    return {"alpha": float(alpha), "beta": float(beta), "zeta_fitted": fitted.tolist(),
            "chi2": chi2, "dof": dof, "p_value": p, "max_relative_misfit": rel}


def rayleigh_draws(omega, zeta, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """(α draws [1/s], β draws [s]) from joint draws ``omega`` [rad/s], ``zeta`` [1] of shape
    (n, K), each draw solved with the same ``weights`` (K,)."""
    w, z = _check(omega, zeta)
    if w.ndim != 2:
        raise InputError("omega and zeta draws must have shape (draws, modes)")
    ab = _solve(w, z, _weights(weights, w.shape[-1]))
    return ab[:, 0], ab[:, 1]


def _stats(x) -> dict:
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
            "q50": float(q50), "q95": float(q95)}


def rayleigh_summary(omega, zeta) -> dict:
    """Rayleigh α, β from posterior draws ``omega`` [rad/s] and ``zeta`` [1] of shape (n, K):
    weights 1/var(ζ_i) over the draws, the point fit and misfit at the posterior medians
    (:func:`rayleigh`), intervals from every draw (:func:`rayleigh_draws`), ζ(ω_i) of (R1)
    per mode, and a one-line ``statement``. Plain data: ``{"alpha", "beta"`` (each mean/sd/
    q05/q50/q95 and ``unit``)``, "zeta_fitted", "zeta_measured", "chi2", "dof", "p_value",
    "max_relative_misfit", "statement", "warnings"}``."""
    w, z = _check(omega, zeta)
    if w.ndim != 2 or w.shape[0] < 2:
        raise InputError("omega and zeta draws must have shape (draws ≥ 2, modes)")
    sd = np.std(z, axis=0, ddof=1)
    wt = 1.0 / np.maximum(sd, 1e-12 * np.abs(np.median(z, axis=0)) + 1e-300) ** 2
    point = rayleigh(np.median(w, axis=0), np.median(z, axis=0), wt / wt.max())
    point_chi2 = float(np.sum(wt * (np.median(z, axis=0) - np.asarray(point["zeta_fitted"]))**2))
    dof = point["dof"]
    p_value = 1.0 if dof == 0 else float(stats.chi2.sf(point_chi2, dof))
    a, b = rayleigh_draws(w, z, wt / wt.max())
    fitted = a[:, None] / (2 * w) + b[:, None] * w / 2
    out = {"alpha": dict(_stats(a), unit="1/s"), "beta": dict(_stats(b), unit="s"),
           "zeta_fitted": [_stats(fitted[:, i]) for i in range(w.shape[1])],
           "zeta_measured": [_stats(z[:, i]) for i in range(w.shape[1])],
           "chi2": point_chi2, "dof": dof, "p_value": p_value,
           "max_relative_misfit": point["max_relative_misfit"]}
    if dof == 0:
        out["statement"] = "exact: two modes determine α and β"
    elif p_value >= 0.05:
        out["statement"] = (f"Rayleigh damping reproduces all {w.shape[1]} measured ζ within "
                            f"their uncertainty (χ² = {point_chi2:.3g} on {dof} dof, "
                            f"p = {p_value:.2g})")
    else:
        out["statement"] = (f"Rayleigh damping does NOT reproduce the measured ζ (χ² = "
                            f"{point_chi2:.3g} on {dof} dof, p = {p_value:.2g}; worst mode off "
                            f"by {100 * point['max_relative_misfit']:.2g} %): use per-mode "
                            "(modal) damping in the FEM model")
    warns = []
    for name, x in (("alpha", a), ("beta", b)):
        if np.median(x) < 0:
            warns.append(f"Rayleigh {name} is negative ({np.median(x):.3g}): most FEM codes "
                         "reject it; use per-mode (modal) damping")
    out["warnings"] = warns
    return out
