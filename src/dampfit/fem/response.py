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


#: Peaks of the Savitzky–Golay trend of the measured log envelope (quadratic) [1].
TREND_PEAKS = 15
#: Periods at each end of the window where the band-pass filters of the measured signal
#: settle: left out of the damper's comparisons and of the measured curve's fit.
EDGE_PERIODS = 3.0


def envelope(t: np.ndarray, y: np.ndarray, start: float | None = None,
             stop: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and absolute values of the extrema of ``y`` (both signs, parabola-refined)
    with ``start ≤ t ≤ stop``: the displacement envelope sampled twice a period."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    ok = np.isfinite(y)
    tp, yp = _extrema(t[ok], y[ok])
    keep = np.abs(yp) > 0
    if start is not None:
        keep &= tp >= start
    if stop is not None:
        keep &= tp <= stop
    return tp[keep], np.abs(yp[keep])


def log_envelope_error(t: np.ndarray, measured: np.ndarray, t_sim: np.ndarray,
                       simulated: np.ndarray, start: float, stop: float) -> dict[str, Any]:
    """How far a simulated displacement envelope lies from the measured one over
    [``start``, ``stop``] [s], on a log scale (a relative error [1]).

    The measured envelope: its extrema (|u| at each half period, :func:`envelope`) and their
    trend, a Savitzky–Golay smoothing of ln|u_peak| over :data:`TREND_PEAKS` peaks (quadratic;
    ``scipy.signal.savgol_filter``). The simulated one: ln|u| of its extrema interpolated at
    the measured peak times. Returned: ``rms_vs_peaks`` = rms(ln A_sim − ln A_meas),
    ``rms_vs_trend`` = rms(ln A_sim − trend), ``scatter`` = rms(ln A_meas − trend) — the
    measurement's own scatter about its trend, which no envelope can beat against the peaks —,
    ``within_scatter`` (rms_vs_trend ≤ scatter), ``max_abs_vs_trend`` and ``n_peaks``.
    For peaks with independent noise of rms σ the scatter is σ·√(1 − h) ≈ 0.92·σ (h = 0.151,
    the central weight of a 15-point quadratic Savitzky–Golay filter), while the true envelope
    lies σ·√h ≈ 0.39·σ from the trend: a run within the scatter is as close to the trend as
    one peak's noise, and the test is slightly strict, not lenient.
    ``None`` values with fewer than 8 measured peaks."""
    from scipy.signal import savgol_filter

    tm, am = envelope(t, measured, start, stop)
    ts, as_ = envelope(t_sim, simulated)
    if tm.size < 8 or ts.size < 2:
        return {"n_peaks": int(tm.size), "rms_vs_peaks": None, "rms_vs_trend": None,
                "scatter": None, "within_scatter": None, "max_abs_vs_trend": None}
    lm = np.log(am)
    window = min(TREND_PEAKS, tm.size - (1 - tm.size % 2))
    trend = savgol_filter(lm, window, 2)
    ls = np.interp(tm, ts, np.log(as_))
    d_trend = ls - trend
    scatter = float(np.sqrt(np.mean((lm - trend) ** 2)))
    rms_trend = float(np.sqrt(np.mean(d_trend ** 2)))
    return {"n_peaks": int(tm.size), "rms_vs_peaks": float(np.sqrt(np.mean((ls - lm) ** 2))),
            "rms_vs_trend": rms_trend, "scatter": scatter,
            "within_scatter": bool(rms_trend <= scatter),
            "max_abs_vs_trend": float(np.max(np.abs(d_trend)))}


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


#: Steps a natural period of :func:`free_run` (the decks' own resolution: timestep.choose
#: gives ≥ 200 steps a period).
RUN_STEPS_PER_PERIOD = 200


def free_run(force, k: float, mass: float, u0: float, duration: float,
             per_period: int = RUN_STEPS_PER_PERIOD) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] from 0 and accelerations [m/s²] of m·ü + F(u̇) + k·u = 0 released at rest at
    ``u0`` [m] for ``duration`` [s]: classical fourth-order Runge–Kutta at a fixed step of
    T_n/``per_period``, T_n = 2π·√(m/k). ``force(v)`` [N] is any damper force law of the
    velocity [m/s] (a Python float in and out).

    What an FEM deck of the damper would do, without the engine: a fixed step, so that the
    cost is the duration's (no step-size search at the jump of a Coulomb force, nor in the
    stick-slip chatter a wrong law may run into), and a = −(k·u + F(u̇))/m as the run's
    accelerometer would read it. The RK4 error per step is O((ω_n·h)⁵): ≈ 2.5·10⁻¹⁰ at 200
    steps a period, ≈ 2.6·10⁻⁷ at 50, far below any measured scatter either way."""
    h = 2 * math.pi * math.sqrt(mass / k) / per_period
    n = max(int(math.ceil(duration / h)), 1)
    h = duration / n
    a = np.empty(n + 1)
    u, v = float(u0), 0.0

    def acc(u_, v_):
        return -(k * u_ + force(v_)) / mass

    a[0] = acc(u, v)
    for i in range(1, n + 1):
        a1 = a[i - 1]
        u2, v2 = u + 0.5 * h * v, v + 0.5 * h * a1
        a2 = acc(u2, v2)
        u3, v3 = u + 0.5 * h * v2, v + 0.5 * h * a2
        a3 = acc(u3, v3)
        u4, v4 = u + h * v3, v + h * a3
        a4 = acc(u4, v4)
        u += h * (v + 2 * v2 + 2 * v3 + v4) / 6
        v += h * (a1 + 2 * a2 + 2 * a3 + a4) / 6
        a[i] = acc(u, v)
    return np.arange(n + 1) * h, a


def released_amplitude(force, k: float, mass: float, amplitude: float, trend_at,
                       per_period: int = RUN_STEPS_PER_PERIOD) -> float:
    """The displacement [m] at which a free decay of ``force`` (:func:`free_run`), released at
    rest, has its first peak of |a|/ω_n² on the measured trend: ``amplitude`` [m] (the trend
    at the release, a measured peak) scaled by ``trend_at(s)`` / that first peak, ``s`` [s]
    the peak's time after the release (``trend_at`` [s → m]). Where F(u̇) is steep at u̇ = 0
    (power α < 1, Coulomb) the release's acceleration k·u/m is followed by a peak of
    |k·u + F(u̇)|/m above the displacement's by the force's share, so the run would start off
    the trend by that share; for a viscous or measured curve the scale is 1 to O(ζ²). One
    and a half periods are run: the cost of a few hundred steps."""
    w = math.sqrt(k / mass)
    ts, acc = free_run(force, k, mass, amplitude, 3 * math.pi / w, per_period)
    tq, aq = envelope(ts, acc / w ** 2)
    if not tq.size or not aq[0] > 0:
        return float(amplitude)
    return float(amplitude) * float(trend_at(float(tq[0]))) / float(aq[0])
