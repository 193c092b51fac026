r"""Is each component a mode? The checks a component passes before it is reported as one
(issue 34).

The screen and the evidence (:mod:`~dampfit.inference.modes_select`) find *components*: damped
sinusoids that lower the residual. A sum of viscous modes also fits what is not a mode — the
harmonics of a nonlinear oscillation, the sidebands of two modes that modulate each other, the
pieces of one mode whose damping or frequency changes over the record, and broad components
the data cannot pin down. Each component of the modal posterior is therefore checked, in this
order, and the first check it fails is its ``kind``:

``harmonic``
    at a whole multiple m = 2…5 of a stronger component's damped frequency f_j (within
    :data:`~dampfit.inference.modes_select.HARMONIC_CELLS` resolution cells 1/T) **and**
    decaying at p ≥ :data:`~dampfit.inference.modes_select.HARMONIC_DECAY` × m·p_j: the m-th
    harmonic of a mode whose amplitude A ∝ e^{−p_j t} enters as A^m or a higher power, so it
    decays at m·p_j or faster. A component at the multiple that decays slower is a mode.
``sideband``
    at f_j ± n·f_k (n = 1, 2) of two other components j, k, weaker than both, within the same
    cells, decaying at p ≥ HARMONIC_DECAY × (p_j + n·p_k): the product of two modes (an
    amplitude modulation between them, a nonlinear coupling) has exactly that frequency and
    decay.
``split``
    a partner of the fundamental closer than
    :data:`~dampfit.inference.modes_close.SPLIT_HALF_POWER` half-power bandwidths while the
    one-mode damping verdict is amplitude-dependent or misfit: the fundamental split by its
    changing damping or frequency — or two modes closer than the record resolves; either way
    no mode of its own can be reported.
``not converged``
    R-hat of its f_n or ζ above :data:`R_HAT_MAX`.
``basin``
    its f_n 90 % interval wider than :data:`BASIN_SHARE` of its basin (the part of the modal
    band it may occupy, :func:`~dampfit.inference.modes_posterior.basins`): the data do not
    locate it.
``zeta``
    its ζ 90 % interval reaching 0 (q95/q05 > :data:`ZETA_SPAN`: the decay is not measured)
    or the prior's upper edge (q95 > :data:`ZETA_EDGE_SHARE` × the largest ζ the prior allows).

The component at the one-mode frequency (the fundamental the recording was released in) is
never dropped when the one-mode analysis is given: the one-mode posterior identified it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from dampfit.inference.modes_select import HARMONIC_CELLS, HARMONIC_DECAY
from dampfit.model.modes import P_MAX

#: An f_n 90 % interval wider than this share of the component's basin [1] fills it.
BASIN_SHARE = 0.25
#: A ζ 90 % interval with q95/q05 above this [1] reaches 0 (the decay is not measured).
ZETA_SPAN = 10.0
#: The largest ζ the modal prior allows (p ≤ P_MAX·ω_d, :mod:`dampfit.model.modes` MK3:
#: ζ = P_MAX/√(1 + P_MAX²) ≈ 0.196) [1] …
ZETA_PRIOR_MAX = P_MAX / math.sqrt(1.0 + P_MAX**2)
#: … and the share of it [1] a ζ interval's q95 may not exceed.
ZETA_EDGE_SHARE = 0.9
#: Largest per-mode R-hat [1] of f_n and ζ for a converged component.
R_HAT_MAX = 1.05


def check_components(rows: Sequence[dict], *, f_d: Sequence[float], p: Sequence[float],
                     amplitudes: Sequence[float], span: float, basins_hz: np.ndarray,
                     keep: int | None = None, split: Sequence[int] = ()) -> dict[int, tuple]:
    """{0-based component: (kind, reason)} of every component that is not a mode (module
    docstring). ``rows`` the per-mode posterior summaries (``f_n``, ``zeta`` with
    ``q05``/``q50``/``q95`` and ``r_hat``); ``f_d`` [Hz], ``p`` [1/s] and ``amplitudes``
    [m/s²] the components' least-squares values (the structural checks use them, as the
    selection's); ``span`` T [s] the window; ``basins_hz`` (2, K) each basin's edges [Hz];
    ``keep`` the component never dropped (the fundamental), ``split`` the split partners."""
    f, rate, amp = (np.asarray(x, dtype=float) for x in (f_d, p, amplitudes))
    cell = 1.0 / span if span and span > 0 else 0.0
    out: dict[int, tuple] = {}
    for i, row in enumerate(rows):
        if i == keep:
            continue
        found = (_harmonic(i, f, rate, amp, cell) or _sideband(i, f, rate, amp, cell)
                 or (("split", _split_reason(f, i, keep)) if i in split else None)
                 or _identified(row, basins_hz[:, i]))
        if found:
            out[i] = found
    return out


def _harmonic(i, f, rate, amp, cell):
    for j in range(f.size):
        m = round(f[i] / f[j]) if f[j] > 0 else 0
        if j == i or not 2 <= m <= 5 or amp[j] <= amp[i] or abs(f[i] - m * f[j]) > \
                max(HARMONIC_CELLS * cell, 1e-9 * f[i]):
            continue
        if rate[i] >= HARMONIC_DECAY * m * rate[j]:
            return "harmonic", (f"{f[i]:.5g} Hz = {m} x {f[j]:.5g} Hz within a resolution "
                                f"cell, decaying at {rate[i]:.3g} 1/s >= "
                                f"{HARMONIC_DECAY:g} x {m} x {rate[j]:.3g} 1/s: the {m}th "
                                "harmonic of a nonlinear oscillation, not a mode")
    return None


def _sideband(i, f, rate, amp, cell):
    for j in range(f.size):
        for k in range(f.size):
            if len({i, j, k}) < 3 or min(amp[j], amp[k]) <= amp[i]:
                continue
            for n in (1, 2):
                for sign in (1, -1):
                    target = f[j] + sign * n * f[k]
                    if target > 0 and abs(f[i] - target) <= HARMONIC_CELLS * cell and \
                            rate[i] >= HARMONIC_DECAY * (rate[j] + n * rate[k]):
                        op = "+" if sign > 0 else "-"
                        return "sideband", (
                            f"{f[i]:.5g} Hz = {f[j]:.5g} Hz {op} {n} x {f[k]:.5g} Hz within a "
                            f"resolution cell, decaying at {rate[i]:.3g} 1/s (>= "
                            f"{HARMONIC_DECAY:g} x the {rate[j] + n * rate[k]:.3g} 1/s of a "
                            "product of the two): a sideband of their modulation, not a mode")
    return None


def _split_reason(f, i, keep) -> str:
    at = "" if keep is None else f" beside the fundamental at {f[keep]:.5g} Hz"
    return (f"{f[i]:.5g} Hz{at}: the fundamental split by its amplitude-dependent damping or "
            "drifting frequency, or two modes closer than the record resolves (an unresolved "
            "pair); not reported as a mode of its own")


def _identified(row: dict, basin) -> tuple | None:
    """(kind, reason) when the component's posterior does not identify a mode, else None."""
    fn, z = row.get("f_n") or {}, row.get("zeta") or {}
    worst = max((_num(d.get("r_hat")) for d in (fn, z)), default=math.nan)
    if not math.isfinite(worst) or worst > R_HAT_MAX:
        return "not converged", (f"its posterior did not converge (R-hat {worst:.3g} > "
                                 f"{R_HAT_MAX:g})")
    width, room = _num(fn.get("q95")) - _num(fn.get("q05")), float(basin[1] - basin[0])
    if not width <= BASIN_SHARE * room:
        return "basin", (f"its f_n interval [{_num(fn.get('q05')):.4g}, "
                         f"{_num(fn.get('q95')):.4g}] Hz spans {width / room:.0%} of its "
                         f"basin {basin[0]:.4g}–{basin[1]:.4g} Hz: the data do not locate it")
    lo, hi = _num(z.get("q05")), _num(z.get("q95"))
    if not (lo > 0 and hi / lo <= ZETA_SPAN):
        return "zeta", (f"its zeta interval [{lo:.2g}, {hi:.2g}] reaches 0: its decay is "
                        "not measured")
    if hi > ZETA_EDGE_SHARE * ZETA_PRIOR_MAX:
        return "zeta", (f"its zeta interval [{lo:.2g}, {hi:.2g}] reaches the prior's edge "
                        f"{ZETA_PRIOR_MAX:.3g}")
    return None


def _num(x) -> float:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) else math.nan


#: Resolution cells 1/T [1] within which a partner of the fundamental is tested as a drift
#: split whatever the damping verdict (a drift of Δf over the record splits the mode into
#: components ≈ Δf apart, which may be many half-power bandwidths at a small ζ).
DRIFT_CELLS = 3.0


def drift_split(tau, y, drift, p, omega_d, i: int, j: int) -> dict | None:
    r"""Do components ``i`` and ``j`` (0-based) fit as well as one mode whose frequency drifts?

    The pair's four columns e^{−p_kτ}(cos, sin)(ω_kτ) are replaced by the two of one viscous
    decay with a linear chirp, phase φ(τ) = ω τ + ½ κ τ² (κ [rad/s²]: a frequency drifting
    by κ/2π Hz/s, a clamp settling or the temperature changing), the other components and
    the drift basis kept at their least-squares (p, ω) with their amplitudes re-solved
    (variable projection). (ln p, ω, κ) are fitted by scipy's least squares from κ = 0 and
    ±1, ±2 × 2π|f_i − f_j|/T. The pair has 3 more free parameters (2 nonlinear, 2 linear
    against κ); by the Bayesian information criterion (Schwarz 1978) the chirp explains it
    when n ln(RSS_chirp/RSS_pair) ≤ 3 ln n. A beating pair of real modes has an envelope no
    single exponential follows, so its RSS_chirp is far larger.

    ``tau`` [s], ``y`` [m/s²] the modal fit samples, ``drift`` their drift basis (n, d),
    ``p`` [1/s] and ``omega_d`` [rad/s] every component's least-squares values. Returns
    {"chirp_hz_per_s", "f_start_hz", "f_end_hz", "delta_bic"} when the chirp explains the
    pair, else None.
    """
    from scipy.optimize import least_squares

    tau, y = np.asarray(tau, float), np.asarray(y, float)
    p, w = np.asarray(p, float), np.asarray(omega_d, float)
    others = [k for k in range(p.size) if k not in (i, j)]

    def cols(rate, omega, phase=None):
        ph = omega * tau if phase is None else phase
        e = np.exp(-rate * tau)
        return [e * np.cos(ph), e * np.sin(ph)]

    fixed = [c for k in others for c in cols(p[k], w[k])] + list(np.asarray(drift).T)

    def rss(columns) -> float:
        x = np.column_stack(columns)
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        return float(np.sum((y - x @ coef) ** 2))

    def resid(th):
        x = np.column_stack(cols(math.exp(min(max(th[0], -30.0), 5.0)), 0.0,
                                 th[1] * tau + 0.5 * th[2] * tau**2)
                            + fixed)
        coef, *_ = np.linalg.lstsq(x, y, rcond=None)
        return y - x @ coef

    pair = rss(cols(p[i], w[i]) + cols(p[j], w[j]) + fixed)
    span = float(tau[-1] - tau[0])
    k0 = abs(w[i] - w[j]) / span
    best = None
    for kappa in (0.0, k0, -k0, 2 * k0, -2 * k0):  # the mean frequency at mid-window
        th0 = [math.log(max(min(p[i], p[j]), 1e-6)), 0.5 * (w[i] + w[j] - kappa * span), kappa]
        sol = least_squares(resid, th0, method="lm", max_nfev=200)
        val = float(np.sum(sol.fun**2))
        if best is None or val < best[0]:
            best = (val, sol.x)
    n = tau.size
    delta = n * math.log(best[0] / pair) - 3 * math.log(n)
    if not delta <= 0:
        return None
    omega, kappa = float(best[1][1]), float(best[1][2])
    return {"chirp_hz_per_s": kappa / (2 * math.pi), "f_start_hz": omega / (2 * math.pi),
            "f_end_hz": (omega + kappa * span) / (2 * math.pi), "delta_bic": delta}


#: The least separation Δf·T [resolution cells] of an unresolved pair: below it the two
#: components' relative phase turns by less than 0.4π over the window, so they do not beat —
#: they are two exponentials at one frequency, i.e. a non-exponential envelope, which is
#: what an amplitude-dependent damping law describes (a Coulomb decay is fitted so, 0.05
#: cells apart; the 0.1 % pair of the false-mode study, 0.4 cells).
PAIR_MIN_CELLS = 0.2


def unresolved_pair(tau, y, drift, p: float, omega_d: float, law_rss: float,
                    law_k: int) -> dict | None:
    r"""Does a pair of viscous modes inside the fundamental's resolution cell fit better than
    the amplitude-dependent damping law the one-mode analysis preferred?

    Two modes Δf apart beat: the envelope e^{−pt}|a₁ + a₂e^{i2πΔf t}| is not exponential,
    and over less than a beat period (Δf·T ≲ 1, a pair the record does not resolve) a
    damping law whose ζ changes with amplitude fits it too — the verdict would then be
    "amplitude-dependent" for what is two modes. Two viscous components are fitted (scipy's
    least squares, variable projection, the same drift basis) from ω_d ∓ δ with
    δ = ½π/T and π/T and the one-mode p; the pair has 6 nonlinear parameters against the
    law's ``law_k`` (its p, ω and law parameters) and 2 more amplitudes, so by the Bayesian
    information criterion it is preferred when
    n ln(RSS_pair/RSS_law) + (6 − k_law) ln n < 0, and it is a pair only when the two are
    at least :data:`PAIR_MIN_CELLS` resolution cells apart (they beat). A law that is the
    truth (drag, friction) fits its envelope exactly with fewer parameters; a beat, only
    approximately.

    ``tau`` [s], ``y`` [m/s²], ``drift`` (n, d) the one-mode fit samples; ``p`` [1/s],
    ``omega_d`` [rad/s] the one-mode least squares; ``law_rss`` [(m/s²)²] and ``law_k`` the
    preferred law's fit on the same samples. Returns {"f_hz": [f₁, f₂], "separation_hz",
    "separation_cells", "delta_bic"} when the pair is preferred, else None."""
    got = pair_fit(tau, y, drift, p, omega_d, law_rss, law_k)
    if got is None:
        return None
    score, f = got
    span = float(np.asarray(tau, float)[-1] - np.asarray(tau, float)[0])
    if not (score < 0 and (f[1] - f[0]) * span >= PAIR_MIN_CELLS):
        return None
    return {"f_hz": f, "separation_hz": f[1] - f[0], "separation_cells": (f[1] - f[0]) * span,
            "delta_bic": score}


def pair_fit(tau, y, drift, p: float, omega_d: float, law_rss: float,
             law_k: int) -> tuple[float, list[float]] | None:
    """The pair fit of :func:`unresolved_pair` before its two thresholds: (the BIC score
    n ln(RSS_pair/RSS_law) + (6 − k_law) ln n, the two frequencies [Hz] in order), or None
    when a residual sum is zero. Same arguments."""
    from scipy.optimize import least_squares

    tau, y = np.asarray(tau, float), np.asarray(y, float)
    fixed = list(np.asarray(drift).T)

    def resid(th):
        cols = []
        for k in range(2):
            e = np.exp(-math.exp(min(max(th[2 * k], -30.0), 5.0)) * tau)
            cols += [e * np.cos(th[2 * k + 1] * tau), e * np.sin(th[2 * k + 1] * tau)]
        x = np.column_stack(cols + fixed)
        return y - x @ np.linalg.lstsq(x, y, rcond=None)[0]

    span = float(tau[-1] - tau[0])
    best = None
    for delta in (0.5 * math.pi / span, math.pi / span):
        lp = math.log(max(p, 1e-6))
        sol = least_squares(resid, [lp, omega_d - delta, lp, omega_d + delta], method="lm",
                            max_nfev=400)
        val = float(np.sum(sol.fun**2))
        if best is None or val < best[0]:
            best = (val, sol.x)
    n = tau.size
    if not (best and best[0] > 0 and law_rss > 0):
        return None
    score = n * math.log(best[0] / law_rss) + (6 - int(law_k)) * math.log(n)
    return score, sorted(float(best[1][k]) / (2 * math.pi) for k in (1, 3))
