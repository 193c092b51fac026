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
from typing import Any

import numpy as np

# the envelope, its error and the free run of a damper law are the damping layer's (analyze
# checks the recommended law with them too); verify and export read them from here as well
from dampfit.damping.decay_run import (EDGE_PERIODS, RUN_STEPS_PER_PERIOD,  # noqa: F401
                                       TREND_PEAKS, envelope, extrema, free_run,
                                       log_envelope_error, released_amplitude)


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


def peak_decay_rate(t: np.ndarray, y: np.ndarray, start: float | None = None,
                    stop: float | None = None) -> dict[str, float | int | None]:
    """Decay rate ``p`` [1/s] of oscillation ``y`` (sampled at ``t`` [s]) from its extrema.

    Uses extrema of both signs, optionally only those with ``start ≤ t ≤ stop``; ``p`` is
    ``None`` with fewer than 4 extrema. Also returns the number of extrema and the rms
    scatter of ln|y_peak| about the line [1].
    """
    tp, yp = envelope(t, y, start, stop)
    if tp.size < 4:
        return {"p": None, "n_peaks": int(tp.size), "scatter": None}
    coef = np.polyfit(tp, np.log(np.abs(yp)), 1)
    resid = np.log(np.abs(yp)) - np.polyval(coef, tp)
    return {"p": float(-coef[0]), "n_peaks": int(tp.size), "scatter": float(np.sqrt(np.mean(resid**2)))}


def zeta_of_amplitude(t: np.ndarray, y: np.ndarray, omega_n: float,
                      smooth: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """ζ(A) of a simulated free decay: (amplitudes [m], ζ [1]), amplitude decreasing.

    The local decay rate ρ = −d ln A/dt of the envelope (:func:`envelope`) is the slope of a
    straight line through ``smooth`` successive peaks (half periods), and ζ = ρ/ω_n at the
    mean amplitude of those peaks (light damping: ρ = ζ·ω_n, paper eq. 3)."""
    tp, ap = envelope(t, y)
    if tp.size < smooth + 1:
        return np.empty(0), np.empty(0)
    la = np.log(ap)
    amps, zetas = [], []
    for i in range(0, tp.size - smooth + 1):
        sl = slice(i, i + smooth)
        slope = np.polyfit(tp[sl], la[sl], 1)[0]
        amps.append(float(np.exp(np.mean(la[sl]))))
        zetas.append(float(-slope / omega_n))
    return np.array(amps), np.array(zetas)


def zeta_in_bands(windows: list[dict[str, Any]], amps: np.ndarray, zetas: np.ndarray,
                  z: float = 1.645) -> dict[str, Any]:
    """The simulated ζ(A) (``amps`` decreasing, ``zetas``) at the amplitudes of the measured
    windows ``windows`` (``amplitude_m``, ``zeta``, ``zeta_sd`` of summary.json's
    ``amplitude_curve``): each window's simulated ζ, its band ζ ± ``z``·sd (90 %) and whether
    it lies inside; windows outside the simulated amplitude range are left out."""
    rows = []
    if amps.size >= 2:
        order = np.argsort(amps)
        a, zs = amps[order], zetas[order]
        for w in windows:
            A, zm, sd = w["amplitude_m"], w["zeta"], w["zeta_sd"]
            if not (a[0] <= A <= a[-1]):
                continue
            zf = float(np.interp(A, a, zs))
            rows.append({"amplitude_m": A, "zeta_measured": zm, "band": [zm - z * sd, zm + z * sd],
                         "zeta_fem": zf, "inside": bool(abs(zf - zm) <= z * sd)})
    inside = sum(r["inside"] for r in rows)
    return {"windows": rows, "n_inside": inside, "n": len(rows),
            "fraction_inside": inside / len(rows) if rows else None}
