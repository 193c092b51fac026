"""Pure numerics of the FEM verification: initial state from the fit, error measures, decay rate.

* :func:`initial_state` — the fitted model's acceleration is ``a(τ) = e^{−pτ}(A cos ω_dτ +
  B sin ω_dτ)`` (paper/method.md eq. M1) = Re[Z·e^{sτ}] with Z = A − iB and s = −p + iω_d. Its
  displacement and velocity are the antiderivatives Re[Z s⁻²e^{sτ}] and Re[Z s⁻¹e^{sτ}], so the
  state at τ₀ is ``u = Re[Z s⁻² e^{sτ₀}]``, ``v = Re[Z s⁻¹ e^{sτ₀}]``. (A, B) are found by
  linear least squares of the samples of ``accel_model`` on the two columns e^{−pτ}cos ω_dτ,
  e^{−pτ}sin ω_dτ — exact for a noise-free model signal, and it uses the whole window rather
  than the first samples only.
* :func:`errors` — the paper's MAE = (1/n)Σ|yᵢ − ŷᵢ| and MSE = (1/n)Σ(yᵢ − ŷᵢ)² (its Fig. 24),
  RMSE, NMSE = MSE/var(y) (0 = perfect, 1 = no better than the mean) and the regression
  ŷ = a·y + b with its r² (the paper's scatter of MEMS vs LS-DYNA).
* :func:`peak_decay_rate` — decay rate p [1/s] from successive extrema: for a viscous free
  decay u = U e^{−pt} cos(ω_d t − φ) the extrema lie exactly T_d/2 apart with
  |u_peak| ∝ e^{−p t_peak}, so a straight-line fit of ln|u_peak| against t_peak has slope −p
  (the paper's eq. 4 on the discrete envelope). Extrema are refined by a parabola through the
  three samples around each one.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["errors", "initial_state", "peak_decay_rate"]


def initial_state(tau: np.ndarray, accel_model: np.ndarray, p: float, omega_d: float,
                  tau0: float = 0.0) -> dict[str, float]:
    """Displacement ``u`` [m] and velocity ``v`` [m/s] of the fitted model at ``tau0`` [s].

    ``tau`` [s] sample times from the window start, ``accel_model`` [m/s²] the model's
    acceleration there, ``p`` [1/s], ``omega_d`` [rad/s]. Also returns the quadratures ``A``,
    ``B`` [m/s²] and the rms misfit of the two-column fit (≈ 0 for a pure model signal).
    """
    tau = np.asarray(tau, float)
    y = np.asarray(accel_model, float)
    env = np.exp(-p * tau)
    X = np.column_stack([env * np.cos(omega_d * tau), env * np.sin(omega_d * tau)])
    (a_cos, a_sin), *_ = np.linalg.lstsq(X, y, rcond=None)
    z = complex(a_cos, -a_sin)
    s = complex(-p, omega_d)
    e = np.exp(s * tau0)
    misfit = float(np.sqrt(np.mean((X @ np.array([a_cos, a_sin]) - y) ** 2)))
    return {"u": float((z / s**2 * e).real), "v": float((z / s * e).real),
            "A": float(a_cos), "B": float(a_sin), "fit_rms": misfit}


def errors(measured: np.ndarray, simulated: np.ndarray) -> dict[str, float | int | None]:
    """MAE, MSE, RMSE, NMSE = MSE/var(measured), regression slope/intercept/r² over finite pairs.

    Units: MAE and RMSE in the signals' unit, MSE in its square; NMSE, r² [1]. All ``None``
    if fewer than 3 finite pairs.
    """
    y = np.asarray(measured, float)
    f = np.asarray(simulated, float)
    ok = np.isfinite(y) & np.isfinite(f)
    n = int(ok.sum())
    if n < 3:
        return {"n": n, "mae": None, "mse": None, "rmse": None, "nmse": None,
                "slope": None, "intercept": None, "r2": None}
    y, f = y[ok], f[ok]
    d = f - y
    mse = float(np.mean(d**2))
    var = float(np.var(y))
    slope, intercept = np.polyfit(y, f, 1)
    r = np.corrcoef(y, f)[0, 1] if np.std(f) > 0 and var > 0 else math.nan
    return {"n": n, "mae": float(np.mean(np.abs(d))), "mse": mse, "rmse": math.sqrt(mse),
            "nmse": mse / var if var > 0 else None, "slope": float(slope),
            "intercept": float(intercept), "r2": float(r**2) if math.isfinite(r) else None}


def _extrema(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the interior local extrema of ``y``, parabola-refined."""
    d = np.diff(y)
    idx = np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0) + 1
    if idx.size == 0:
        return np.empty(0), np.empty(0)
    y0, y1, y2 = y[idx - 1], y[idx], y[idx + 1]
    denom = y0 - 2.0 * y1 + y2
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(denom != 0, 0.5 * (y0 - y2) / denom, 0.0)
    delta = np.clip(delta, -0.5, 0.5)
    h = np.interp(idx + delta, np.arange(t.size), t)
    return h, y1 - 0.25 * (y0 - y2) * delta


def peak_decay_rate(t: np.ndarray, y: np.ndarray, start: float | None = None,
                    stop: float | None = None) -> dict[str, float | int | None]:
    """Decay rate ``p`` [1/s] of oscillation ``y`` (sampled at ``t`` [s]) from its extrema.

    Uses extrema of both signs, optionally only those with ``start ≤ t ≤ stop``; ``p`` is
    ``None`` with fewer than 4 extrema. Also returns the number of extrema and the rms
    scatter of ln|y_peak| about the line [1].
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    ok = np.isfinite(y)
    tp, yp = _extrema(t[ok], y[ok])
    keep = (np.abs(yp) > 0)
    if start is not None:
        keep &= tp >= start
    if stop is not None:
        keep &= tp <= stop
    tp, yp = tp[keep], yp[keep]
    if tp.size < 4:
        return {"p": None, "n_peaks": int(tp.size), "scatter": None}
    coef = np.polyfit(tp, np.log(np.abs(yp)), 1)
    resid = np.log(np.abs(yp)) - np.polyval(coef, tp)
    return {"p": float(-coef[0]), "n_peaks": int(tp.size), "scatter": float(np.sqrt(np.mean(resid**2)))}
