r"""A damper law's free decay against a measured one: the numerics that decide whether the
recommended law's own decay follows the recording (``summary.json``'s ``damper.decay_check``,
and the deck ``dampfit export`` writes, :func:`dampfit.fem.measured.default_damper`).

* :func:`envelope` — the extrema of a decay (|u| twice a period, parabola-refined);
* :func:`free_run` — m·ü + F(u̇) + k·u = 0 released at rest, classical RK4 at a fixed step;
* :func:`released_amplitude` — where to release it so that its first peak is on the measured
  trend;
* :func:`log_envelope_error` — how far a run's envelope lies from the measured one, against
  the measurement's own scatter about its trend;
* :func:`check` — the three together: the law run from the first measured peak of the
  interior (the window without :data:`EDGE_PERIODS` periods at each end) and compared with
  the measured envelope, as verify compares the FEM run of the deck.

Numeric only (NumPy, SciPy): no I/O.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Peaks of the Savitzky–Golay trend of the measured log envelope (quadratic) [1].
TREND_PEAKS = 15
#: Periods at each end of the window where the band-pass filters of the measured signal
#: settle: left out of the damper's comparisons and of the measured curve's fit.
EDGE_PERIODS = 3.0


def extrema(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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



def envelope(t: np.ndarray, y: np.ndarray, start: float | None = None,
             stop: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and absolute values of the extrema of ``y`` (both signs, parabola-refined)
    with ``start ≤ t ≤ stop``: the displacement envelope sampled twice a period."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    ok = np.isfinite(y)
    tp, yp = extrema(t[ok], y[ok])
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


def scalar_force(law: str, coeffs: dict[str, float]):
    """The force [N] of damping law ``law`` (:mod:`dampfit.model.laws`) with the SI ``coeffs``
    as a function of one Python float velocity [m/s]: the force of :func:`free_run`, ~20×
    faster than the law's NumPy :meth:`~dampfit.model.laws.Law.force` on a scalar and the
    same law term for term (a test compares the two on a grid of velocities). A law without
    a fast form here (one added later) runs its own ``force``, only slower."""
    if law == "viscous":
        c = float(coeffs["c"])
        return lambda x: c * x
    if law == "coulomb":
        c, fc = float(coeffs["c"]), float(coeffs["F_c"])
        return lambda x: c * x + (math.copysign(fc, x) if x else 0.0)
    if law == "quadratic":
        c, c2 = float(coeffs["c"]), float(coeffs["c2"])
        return lambda x: c * x + c2 * x * abs(x)
    if law == "power":
        ca, al = float(coeffs["c_alpha"]), float(coeffs["alpha"])
        return lambda x: math.copysign(ca * abs(x) ** al, x) if x else 0.0
    from dampfit.model import laws

    model = laws.get(law)  # ValueError for an unknown law
    return lambda x: float(model.force(x, coeffs))


#: Largest number of RK4 steps of one :func:`check` run (the step per period is lowered to
#: stay within it; below :data:`MIN_STEPS_PER_PERIOD` the check is not run).
MAX_RUN_STEPS = 2_000_000
#: Fewest steps a period of a :func:`check` run (RK4 error ≈ 2.6·10⁻⁷ a step at 50).
MIN_STEPS_PER_PERIOD = 50
#: A law whose run lies within this rms of the measured trend [1] follows it, whatever the
#: scatter (a measurement cleaner than 0.1 % asks more than a two-coefficient law can give).
LAW_TOLERANCE = 0.001


def check(t: np.ndarray, y: np.ndarray, force, k: float, mass: float,
          max_steps: int = MAX_RUN_STEPS) -> dict[str, Any]:
    """How far the free decay of ``force`` (a float [m/s] → [N] law) on k [N/m], ``mass``
    [kg] lies from the measured displacement amplitude ``y`` = |a|/ω_n² [m] at ``t`` [s].

    The interior is the window without :data:`EDGE_PERIODS` periods at each end (the
    band-pass filters settle there). The run is released at rest at its first measured peak
    on the measured trend (:func:`released_amplitude`; quadratic Savitzky–Golay over
    :data:`TREND_PEAKS` peaks) and read as the sensor reads the structure, |a|/ω_n² at the
    extrema of a = −(k·u + F(u̇))/m; it is compared from the next peak on
    (:func:`log_envelope_error`). Returned: that function's numbers, with ``follows`` =
    rms_vs_trend ≤ max(scatter, :data:`LAW_TOLERANCE`). ValueError (the reason, a phrase)
    with fewer than 2·:data:`TREND_PEAKS` peaks or more cycles than ``max_steps`` can run at
    :data:`MIN_STEPS_PER_PERIOD` steps a period."""
    from scipy.signal import savgol_filter

    t, y = np.asarray(t, float), np.asarray(y, float)
    w = math.sqrt(k / mass)
    edge = EDGE_PERIODS * 2 * math.pi / w
    start, stop = float(t[0]) + edge, float(t[-1]) - edge
    tp, ap = envelope(t, y, start, stop)
    if tp.size < 2 * TREND_PEAKS:
        raise ValueError(f"{tp.size} peaks, fewer than {2 * TREND_PEAKS}")
    trend = savgol_filter(np.log(ap), TREND_PEAKS, 2)
    cycles = (stop - tp[0]) * w / (2 * math.pi)
    per_period = min(RUN_STEPS_PER_PERIOD, int(max_steps / max(cycles, 1.0)))
    if per_period < MIN_STEPS_PER_PERIOD:
        raise ValueError(f"{cycles:.0f} cycles are too many to run")
    u0 = released_amplitude(force, k, mass, float(np.exp(trend[0])),
                            lambda s: float(np.exp(np.interp(tp[0] + s, tp, trend))),
                            per_period)
    ts, acc = free_run(force, k, mass, u0, stop - tp[0], per_period)
    out = log_envelope_error(t, y, ts + tp[0], acc / w ** 2, tp[0] + 0.5 * math.pi / w, stop)
    out["follows"] = bool(out["rms_vs_trend"] is not None and out["rms_vs_trend"]
                          <= max(out["scatter"], LAW_TOLERANCE))
    return out
