"""Baseline estimators of the seed paper (Flis et al. 2025) for comparison with dampfit's fit.

Both work on one uniformly sampled analysis window of offset-removed acceleration and return
a :class:`BaselineResult` with decay rate ``p`` [1/s], damping ratio ζ [1], logarithmic
decrement δ [1], damped frequency ``f_d`` [Hz] and, if the mass ``m`` [kg] is given, the
damping coefficient ``c`` [N·s/m] and stiffness ``k`` [N/m].

* :func:`envelope_pipeline` — the paper's "Python algorithm" (Fig. 18): band-pass the
  acceleration, integrate twice to displacement with a band-pass after every step (this removes
  the integration constants and the drift of Figs. 10–11), take the Hilbert envelope, fit
  ``ln u(t) = ln K − p·t`` by least squares (eq. 4, the logarithm of eq. 2's envelope
  ``K·e^{−pt}``) and convert with ``c = 2·m·p`` (eq. 3).
* :func:`log_decrement` — the paper's verification (eqs. 5–15): from the positive peaks
  ``u_a0`` and ``u_an`` n cycles apart, ``δ = (1/n)·ln(u_a0/u_an)`` (eq. 9),
  ``γ = ζ = δ/√(4π² + δ²)`` (eq. 13) and ``c = γ·2√(k·m)`` (eq. 15). The peaks are taken on
  the band-passed *acceleration*: for a damped sinusoid ``ü = −ω_n²·u − 2p·u̇`` is again a
  damped sinusoid with the same ``e^{−pt}`` envelope, so peak ratios (and δ) are unchanged.
  Here ``c`` is computed as ``2·m·p`` with ``p = δ·f_d``, which equals eq. 15 identically.

Where these implementations add to what the paper prints (each needed for the estimators to
recover a known ``p`` from clean synthetic data; see the tests):

* edge guard — the zero-phase band-pass has start/stop transients lasting roughly its impulse
  response (≈ 5 s for a 1.2 Hz wide band at 1.7 Hz). Peaks and envelope samples closer to a
  window end than that settling time (at most 25 % of the window) are not used. Without the
  guard the last, half-formed peak alone biased δ by tens of percent;
* envelope dynamic range — the Hilbert envelope of a record that starts abruptly carries a
  leakage decaying only like 1/t, so the fit stops where the envelope first falls below 1 % of
  its maximum, and is by default weighted by env² (``weighted=False`` gives the unweighted fit).

Support and expected spread (every result carries them, see :class:`BaselineResult`):

* ``n_cycles_used`` of ``n_cycles_window`` — the cycles the estimate rests on (log decrement:
  the n of eq. 9; envelope pipeline: the span of the fit region × f_d) out of the cycles in the
  window (duration × f_d);
* ``expected_rel_sd`` — the expected relative spread of p (and of ζ, c): log decrement
  sd(δ) = √((σ_a/a_0)² + (σ_a/a_n)²)/n (≈ √2·σ_a/(n·a)), with σ_a the scatter of the smaller
  half of the peak heights about their exponential fit; envelope pipeline sd(p) = σ_ln·√(12/N)/T for a
  log-linear fit over T seconds with N = T·(band width) independent envelope samples and σ_ln
  the weighted scatter of ln env about the fit. Neither is taken below
  :data:`REL_SD_FLOOR` (both recover p within 2 % on clean synthetic decays, not better);
* ``supported`` is False, with ``support_reason``, when the estimate rests on fewer than
  :data:`MIN_CYCLES` cycles, or on less than :data:`MIN_CYCLE_FRACTION` of the window's
  cycles, or when the decay it measures is within the noise (ln(a_0/a_n), or p·T, below
  :data:`MIN_DECAY_SD` expected sd), or when the end of what it fits (the log decrement's
  peak a_n, the envelope fit's last value) is below :data:`MIN_PEAK_SNR` × its noise (σ_a; the
  envelope's scatter about the fit over its lower half) — such an estimate is printed, but marked not reliable.

:func:`agreement` compares a baseline with the posterior median of p: it disagrees when the
difference exceeds :data:`DISAGREE_SD` combined expected sd (its own and the posterior's).

All conversions go through :mod:`dampfit.physics`; filtering through
:func:`dampfit.signal.filters.bandpass` (zero-phase Butterworth). Pure NumPy/SciPy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import integrate, signal

from dampfit.errors import InputError
from dampfit.estimators import features
from dampfit.estimators.features import FILTER_ORDER
from dampfit.signal.filters import bandpass
from dampfit.physics import Mass, as_mass, quantities, zeta_from_log_decrement

#: Relative tolerance on the time grid's uniformity and on its agreement with 1/fs.
UNIFORM_TOLERANCE = 1e-3
#: Fewest samples a window may have.
MIN_WINDOW_SAMPLES = 16
#: A baseline resting on fewer cycles than this is not supported (not reliable).
MIN_CYCLES = 5
#: ... nor one resting on less than this fraction of the window's cycles.
MIN_CYCLE_FRACTION = 0.25
#: ... nor one whose measured decay (ln(a_0/a_n), p·T) is below this many expected sd.
MIN_DECAY_SD = 3.0
#: ... nor a log decrement whose end peak a_n is below this many times the peak-height noise
#: σ_a (noise peaks are biased upwards: δ would measure the noise floor, not the decay).
MIN_PEAK_SNR = 3.0
#: Smallest expected relative spread of a baseline's p [1] (method accuracy on clean data).
REL_SD_FLOOR = 0.02
#: A baseline disagrees with the posterior beyond this many combined expected sd.
DISAGREE_SD = 3.0


@dataclass(frozen=True)
class BaselineResult:
    """Result of a baseline estimator.

    Attributes
    ----------
    method : str
        ``"log_decrement"`` or ``"envelope_pipeline"``.
    p : float
        Decay rate [1/s].
    zeta : float
        Damping ratio ζ (the paper's γ) [1].
    delta : float
        Logarithmic decrement δ = p·T_d [1].
    f_d : float
        Damped frequency used [Hz].
    c : float or None
        Damping coefficient ``2·m·p`` [N·s/m]; ``None`` without mass.
    k : float or None
        Stiffness ``m·ω_n²`` [N/m]; ``None`` without mass.
    n_cycles : int or None
        Cycles spanned by the two peaks (log decrement); ``None`` for the envelope pipeline.
    n_cycles_used : float or None
        Cycles the estimate rests on (log decrement: n; envelope: fit span × f_d) [cycles].
    n_cycles_window : float or None
        Cycles in the analysed window (duration × f_d) [cycles].
    supported : bool
        False when the estimate rests on too little (module docstring); then
        ``support_reason`` says why.
    support_reason : str or None
    expected_rel_sd : float or None
        Expected relative spread (1 sd) of p, ζ and c [1].
    details : dict
        Intermediate arrays and diagnostics for plotting (not JSON-safe).
    """

    method: str
    p: float
    zeta: float
    delta: float
    f_d: float
    c: float | None
    k: float | None
    n_cycles: int | None
    details: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    n_cycles_used: float | None = None
    n_cycles_window: float | None = None
    supported: bool = True
    support_reason: str | None = None
    expected_rel_sd: float | None = None

    def summary(self) -> dict[str, Any]:
        """JSON-safe scalars: method, p, zeta, delta, f_d, c, k, n_cycles, n_cycles_used,
        n_cycles_window, supported, support_reason, expected_rel_sd (plain floats/ints/None)."""
        return {
            "method": str(self.method),
            "p": _opt_float(self.p),
            "zeta": _opt_float(self.zeta),
            "delta": _opt_float(self.delta),
            "f_d": _opt_float(self.f_d),
            "c": _opt_float(self.c),
            "k": _opt_float(self.k),
            "n_cycles": None if self.n_cycles is None else int(self.n_cycles),
            "n_cycles_used": _opt_float(self.n_cycles_used),
            "n_cycles_window": _opt_float(self.n_cycles_window),
            "supported": bool(self.supported),
            "support_reason": self.support_reason,
            "expected_rel_sd": _opt_float(self.expected_rel_sd),
        }


# -- public estimators ----------------------------------------------------------------------


def log_decrement(
    time: np.ndarray,
    accel: np.ndarray,
    fs: float,
    band: tuple[float, float],
    *,
    mass: float | Mass | None = None,
    n_cycles: int | None = None,
) -> BaselineResult:
    """Logarithmic-decrement estimate from the acceleration peaks (paper eqs. 5–15).

    Parameters
    ----------
    time : array, shape (n,)
        Uniform sample times [s].
    accel : array, shape (n,)
        Offset-removed acceleration [m/s²], not yet band-passed.
    fs : float
        Sample rate [Hz].
    band : (float, float)
        Pass band (lo, hi) [Hz] around the dominant frequency.
    mass : float or dampfit.physics.Mass, optional
        Oscillating mass [kg]; without it ``c`` and ``k`` are ``None``.
    n_cycles : int, optional
        Cycles n between the two peaks of eq. 9 (1 ≤ n ≤ available); default: first to last peak.

    Returns
    -------
    BaselineResult
        ``p = δ·f_d`` [1/s] with ``δ = (1/n)·ln(a_0/a_n)`` (eq. 9) and ``f_d = n/(t_n − t_0)``
        [Hz]; ζ from eq. 13; with mass, ``c = 2·m·p`` and ``k = m·ω_n²``,
        ``ω_n = 2π·f_d/√(1−ζ²)``. Peak 0 is the first positive peak after the edge guard
        (filter settling time), peak n the n-th after it. ``details`` holds ``accel_filtered``
        [m/s²], ``peak_index``, ``peak_times`` [s], ``peak_amplitudes`` [m/s²] (peaks used, after
        the guard), ``n_available``, ``edge_guard`` [s] (< ``edge_settle`` [s] when capped at
        25 % of a short window: then the end peaks still carry filter transients), ``ln_fit``
        (intercept, slope [1/s]) and the regression variant over all peaks: ``p_regression``
        [1/s] (minus the slope of ln(peak) vs time), ``f_d_regression`` [Hz],
        ``zeta_regression`` and ``delta_regression``.
    """
    t, a, fs, band, mass = _validate(time, accel, fs, band, mass)
    y = bandpass(a, fs, band, FILTER_ORDER)
    idx, t_pk, a_pk, guard, settle = _inner_peaks(y, fs, band, t)
    n_avail = len(t_pk) - 1
    n = _cycles_between(n_cycles, n_avail)
    delta = math.log(a_pk[0] / a_pk[n]) / n  # eq. 9
    f_d = n / (t_pk[n] - t_pk[0])
    zeta = float(zeta_from_log_decrement(delta))  # eq. 13
    p = delta * f_d  # δ = p·T_d (eq. 11)
    phys = quantities(p, 2.0 * np.pi * f_d, mass)

    slope, intercept = np.polyfit(t_pk, np.log(a_pk), 1)
    sigma_a, support = _peak_support(t_pk, a_pk, n, (t[-1] - t[0]) * f_d, delta,
                                     intercept + slope * t_pk)
    p_reg = -float(slope)
    f_reg = n_avail / (t_pk[-1] - t_pk[0])
    phys_reg = quantities(p_reg, 2.0 * np.pi * f_reg)
    details = {
        "accel_filtered": y,
        "peak_index": idx,
        "peak_times": t_pk,
        "peak_amplitudes": a_pk,
        "n_available": n_avail,
        "edge_guard": float(guard),
        "edge_settle": float(settle),
        "ln_fit": (float(intercept), float(slope)),
        "p_regression": p_reg,
        "zeta_regression": float(phys_reg["zeta"]),
        "delta_regression": float(phys_reg["delta"]),
        "f_d_regression": float(f_reg),
        "peak_sigma": sigma_a,
    }
    return _result("log_decrement", p, zeta, delta, f_d, phys, details, n_cycles=n, **support)


def _inner_peaks(y: np.ndarray, fs: float, band: tuple[float, float], t: np.ndarray):
    """The positive peaks of the band-passed ``y`` away from the filter's edge transients:
    (indices, times [s], heights, guard [s], settle [s]); fewer than 3 is an :class:`InputError`."""
    guard, settle = features.edge_guard(fs, band, t[-1] - t[0])
    idx, t_pk, a_pk = features.positive_peaks(y, fs, band, t)
    inner = (t_pk >= t[0] + guard) & (t_pk <= t[-1] - guard)
    idx, t_pk, a_pk = idx[inner], t_pk[inner], a_pk[inner]
    n_avail = len(t_pk) - 1
    if n_avail < 2:
        raise InputError(
            f"only {len(t_pk)} positive peak(s) away from the filter's edge transients "
            f"({guard:.3g} s at each end); the log decrement needs at least 3 (2 cycles) — "
            "use a longer window or a wider pass band"
        )
    return idx, t_pk, a_pk, guard, settle


def _cycles_between(n_cycles: int | None, n_avail: int) -> int:
    """Cycles n of eq. 9: ``n_cycles`` checked against the ``n_avail`` the window has, or all."""
    if n_cycles is None:
        return n_avail
    if isinstance(n_cycles, bool) or int(n_cycles) != n_cycles:
        raise InputError(f"n_cycles must be an integer, got {n_cycles!r}")
    n = int(n_cycles)
    if not 1 <= n <= n_avail:
        raise InputError(f"n_cycles={n} is out of range: this window has 1 to {n_avail} cycles")
    return n


def _peak_support(t_pk: np.ndarray, a_pk: np.ndarray, n: int, n_window: float, delta: float,
                  ln_fit: np.ndarray) -> tuple[float, dict[str, Any]]:
    """The peak-height noise σ_a [m/s²] and whether the log decrement over peaks 0…n is
    supported (:func:`_support`), ``ln_fit`` the exponential fit ln a(t_pk) of the peaks.

    Expected spread: scatter σ_a of the smaller half of the peak heights about their
    exponential fit (additive noise shows there; proportional errors of the large peaks are
    what REL_SD_FLOOR covers), with the fit's two degrees of freedom allowed for."""
    resid = a_pk - np.exp(ln_fit)
    small = a_pk <= np.median(a_pk)
    sigma_a = float(np.sqrt(np.mean(resid[small] ** 2) * len(a_pk) / max(len(a_pk) - 2, 1)))
    sd_ln_ratio = math.hypot(sigma_a / a_pk[0], sigma_a / a_pk[n])
    low = ([f"the end peak a_n = {a_pk[n]:.3g} m/s^2 is within {MIN_PEAK_SNR:g}x the noise of "
            f"the peak heights ({sigma_a:.2g} m/s^2)"] if a_pk[n] < MIN_PEAK_SNR * sigma_a else [])
    return sigma_a, _support(n, n_window, delta * n, sd_ln_ratio, "ln(a_0/a_n)", low)


def envelope_pipeline(
    time: np.ndarray,
    accel: np.ndarray,
    fs: float,
    band: tuple[float, float],
    *,
    mass: float | Mass | None = None,
    weighted: bool = True,
) -> BaselineResult:
    """The paper's filter → double integration → envelope → log-linear fit pipeline (eqs. 2–4).

    Parameters
    ----------
    time, accel, fs, band, mass
        As for :func:`log_decrement`: uniform times [s], acceleration [m/s²], rate [Hz],
        pass band [Hz], optional mass [kg].
    weighted : bool
        ``True`` (default): weighted least squares of eq. 4 with weights ``env²``
        (var(ln env) ≈ σ²/env² for additive noise σ), so the low-amplitude tail does not dominate.
        ``False``: the unweighted fit exactly as printed. Both slopes are in ``details``.

    Returns
    -------
    BaselineResult
        ``p`` [1/s] from the fit ``ln|H(u)| = ln K − p·t`` over the fit region: the window
        without max(10 %, two periods, filter settling time) at each end, cut further where the
        envelope first falls below :data:`~dampfit.estimators.features.ENVELOPE_FLOOR` of its maximum; ``f_d`` [Hz] from the
        displacement's upward zero crossings in the fit region; ``c = 2·m·p`` (eq. 3);
        ζ = p/ω_n. ``details`` holds ``accel_filtered`` [m/s²], ``velocity`` [m/s],
        ``displacement`` [m], ``envelope`` [m], ``fit_mask`` (samples used), ``envelope_fit``
        [m] (``K·e^{−p(t−t_0)}`` on every sample), ``K`` [m], ``trim`` [s] per end,
        ``edge_settle`` [s] (settling time of the three band-passes; > ``trim`` means capped),
        ``weighted``, ``p_weighted`` and ``p_unweighted`` [1/s].
    """
    t, a, fs, band, mass = _validate(time, accel, fs, band, mass)
    a_f, v, u, env = _displacement(a, fs, band)

    mask, trim, settle = features.envelope_fit_region(t, u, env, fs, band)
    f_d = features.zero_crossing_frequency(t[mask], u[mask])
    if f_d is None:
        raise InputError(
            "fewer than 2 oscillation cycles remain for the envelope fit; use a longer window"
        )

    tm = t[mask]
    t_ref = tm[0]  # fit about the first kept sample for conditioning; K refers to time[0]
    ln_env = np.log(env[mask])
    slope_u, icpt_u = np.polyfit(tm - t_ref, ln_env, 1)  # eq. 4 as printed
    slope_w, icpt_w = np.polyfit(tm - t_ref, ln_env, 1, w=env[mask])  # polyfit squares w
    slope, icpt = (float(slope_w), float(icpt_w)) if weighted else (float(slope_u), float(icpt_u))
    p = -slope
    K = float(np.exp(icpt + slope * (t[0] - t_ref)))
    support = _envelope_support(tm, env[mask], icpt + slope * (tm - t_ref), weighted, band, p,
                                f_d, (t[-1] - t[0]) * f_d)
    phys = quantities(p, 2.0 * np.pi * f_d, mass)
    details = {
        "accel_filtered": a_f,
        "velocity": v,
        "displacement": u,
        "envelope": env,
        "fit_mask": mask,
        "envelope_fit": K * np.exp(-p * (t - t[0])),
        "K": K,
        "trim": float(trim),
        "edge_settle": settle,
        "weighted": bool(weighted),
        "p_weighted": -float(slope_w),
        "p_unweighted": -float(slope_u),
    }
    return _result(
        "envelope_pipeline", p, float(phys["zeta"]), float(phys["delta"]), f_d, phys, details,
        n_cycles=None, **support,
    )


def _displacement(a: np.ndarray, fs: float, band: tuple[float, float]):
    """Eq. 2: the band-passed acceleration [m/s²], velocity [m/s], displacement [m] and the
    displacement's Hilbert envelope [m]; a band-pass after each integration removes the
    integration constants and the drift."""
    dt = 1.0 / fs
    a_f = bandpass(a, fs, band, FILTER_ORDER)
    v = bandpass(integrate.cumulative_trapezoid(a_f, dx=dt, initial=0.0), fs, band, FILTER_ORDER)
    u = bandpass(integrate.cumulative_trapezoid(v, dx=dt, initial=0.0), fs, band, FILTER_ORDER)
    return a_f, v, u, np.abs(signal.hilbert(u))


def _envelope_support(tm: np.ndarray, env_m: np.ndarray, fit_ln: np.ndarray, weighted: bool,
                      band: tuple[float, float], p: float, f_d: float,
                      n_window: float) -> dict[str, Any]:
    """Whether the envelope fit (envelope ``env_m`` [m] at the fitted times ``tm`` [s], the
    fitted ln envelope ``fit_ln``) is supported (:func:`_support`).

    Expected spread of p: log-linear fit over ``span`` s with N ≈ span·bandwidth independent
    envelope samples (the envelope decorrelates over ≈ 1/bandwidth), scatter σ_ln about the
    fit; and the fit must end above the noise: envelope scatter about the fit on its lower
    half."""
    span = float(tm[-1] - tm[0])
    w2 = env_m ** 2 if weighted else np.ones(tm.size)
    sigma_ln = float(np.sqrt(np.sum(w2 * (np.log(env_m) - fit_ln) ** 2) / np.sum(w2)))
    n_indep = max(span * (band[1] - band[0]), 3.0)
    sd_p = sigma_ln * math.sqrt(12.0 / n_indep) / span if span > 0 else math.inf
    fit_env = np.exp(fit_ln)
    small = env_m <= np.median(env_m)
    sigma_env = float(np.sqrt(np.mean((env_m[small] - fit_env[small]) ** 2)))
    low = ([f"the fitted envelope ends at {fit_env[-1]:.3g} m, within {MIN_PEAK_SNR:g}x its "
            f"scatter ({sigma_env:.2g} m): the fit reaches the noise floor"]
           if fit_env[-1] < MIN_PEAK_SNR * sigma_env else [])
    return _support(span * f_d, n_window, p * span, sd_p * span, "p·T", low)


def agreement(summary: dict[str, Any], p_median: float | None, p_sd: float | None) -> dict[str, Any]:
    """Does a baseline (its :meth:`BaselineResult.summary`) agree with the posterior of p?

    ``p_median``, ``p_sd`` [1/s]: the posterior median and sd of the decay rate. Returns
    ``{"agrees_with_posterior": bool or None, "note": str or None}``: False (with a note) when
    |p_baseline − p_median| exceeds :data:`DISAGREE_SD` × √((rel_sd·p_baseline)² + p_sd²);
    None when either side is missing.
    """
    p_b, rel = summary.get("p"), summary.get("expected_rel_sd")
    vals = (p_b, rel, p_median, p_sd)
    if any(v is None or not math.isfinite(v) for v in vals) or p_median <= 0:
        return {"agrees_with_posterior": None, "note": None}
    spread = math.hypot(rel * p_b, p_sd)
    z = abs(p_b - p_median) / spread if spread > 0 else math.inf
    if z <= DISAGREE_SD:
        return {"agrees_with_posterior": True, "note": None}
    name = str(summary.get("method", "baseline")).replace("_", " ")
    return {
        "agrees_with_posterior": False,
        "note": (f"{name} gives p = {p_b:.3g} 1/s, {p_b / p_median:.2g}x the posterior median "
                 f"{p_median:.3g} 1/s: {z:.1f} expected sd apart (its own spread "
                 f"{100 * rel:.2g} %, the posterior's sd {p_sd:.2g} 1/s); beyond "
                 f"{DISAGREE_SD:g} sd it is not the same estimate"),
    }


# -- helpers --------------------------------------------------------------------------------


def _opt_float(x: Any) -> float | None:
    return None if x is None else float(x)


def _support(n_used: float, n_window: float, decay: float, sd_decay: float,
             what: str, extra: list[str] | None = None) -> dict[str, Any]:
    """Support fields of a result (module docstring): ``n_used`` of ``n_window`` cycles and
    the measured decay ``decay`` [1] (ln(a_0/a_n) or p·T) with its expected sd ``sd_decay``;
    ``extra`` further reasons against it."""
    reasons = []
    if n_used < MIN_CYCLES:
        reasons.append(f"rests on only {_cycles(n_used)} cycles (fewer than {MIN_CYCLES})")
    elif n_used < MIN_CYCLE_FRACTION * n_window:
        reasons.append(f"rests on only {_cycles(n_used)} of the window's {_cycles(n_window)} "
                       f"cycles (less than {100 * MIN_CYCLE_FRACTION:.0f} %)")
    if not (decay > MIN_DECAY_SD * sd_decay):
        reasons.append(f"the measured decay {what} = {decay:.3g} is within {MIN_DECAY_SD:g} "
                       f"expected sd ({sd_decay:.2g}) of the noise")
    reasons += extra or []
    rel = sd_decay / decay if decay > 0 and math.isfinite(sd_decay) else math.inf
    return {"n_cycles_used": float(n_used), "n_cycles_window": float(n_window),
            "supported": not reasons, "support_reason": "; ".join(reasons) or None,
            "expected_rel_sd": math.hypot(rel, REL_SD_FLOOR)}


def _cycles(n: float) -> str:
    return f"{n:.0f}" if abs(n - round(n)) < 1e-9 or n >= 10 else f"{n:.1f}"


def _result(
    method: str,
    p: float,
    zeta: float,
    delta: float,
    f_d: float,
    phys: dict[str, np.ndarray],
    details: dict[str, Any],
    **support: Any,
) -> BaselineResult:
    """The :class:`BaselineResult` of ``method``; c and k where ``phys``
    (:func:`dampfit.physics.quantities`) has them (a mass was given); ``support`` the
    result's other fields (``n_cycles`` …)."""
    c = float(phys["c"]) if "c" in phys else None
    k = float(phys["k"]) if "k" in phys else None
    return BaselineResult(
        method=method,
        p=float(p),
        zeta=float(zeta),
        delta=float(delta),
        f_d=float(f_d),
        c=c,
        k=k,
        details=details,
        **support,
    )


def _validate(
    time: np.ndarray, accel: np.ndarray, fs: float, band: tuple[float, float],
    mass: float | Mass | None,
) -> tuple[np.ndarray, np.ndarray, float, tuple[float, float], float | None]:
    """Coerce and check the window and the mass (a :class:`~dampfit.physics.Mass` was checked
    when it was made, so only a plain number is checked here); raise :class:`InputError` with
    a one-line message. Returns the window, ``fs``, the band and the mass [kg] or None."""
    t = np.asarray(time, dtype=float)
    a = np.asarray(accel, dtype=float)
    if t.ndim != 1 or a.ndim != 1:
        raise InputError(f"time and accel must be 1-D arrays, got shapes {t.shape} and {a.shape}")
    if t.size == 0 or a.size == 0:
        raise InputError("time and accel are empty")
    if t.size != a.size:
        raise InputError(f"time and accel have mismatched lengths {t.size} and {a.size}")
    if t.size < MIN_WINDOW_SAMPLES:
        raise InputError(
            f"the window has only {t.size} samples; at least {MIN_WINDOW_SAMPLES} are needed"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise InputError("time or accel contains NaN or infinite values")
    fs = float(fs)
    if not (math.isfinite(fs) and fs > 0.0):
        raise InputError(f"sample rate fs must be positive, got {fs!r}")
    dts = np.diff(t)
    if np.any(dts <= 0.0):
        raise InputError("time is not strictly increasing")
    step = float(np.median(dts))
    if np.max(np.abs(dts - step)) > UNIFORM_TOLERANCE * step:
        raise InputError(
            f"time is not a uniform grid (steps {dts.min():.6g}–{dts.max():.6g} s); "
            "resample the window first"
        )
    if abs(step * fs - 1.0) > UNIFORM_TOLERANCE:
        raise InputError(f"time step {step:.6g} s does not match the sample rate fs = {fs:g} Hz")
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError):
        raise InputError(f"band must be a pair (low, high) in Hz, got {band!r}") from None
    return t, a, fs, (lo, hi), as_mass(mass).value
