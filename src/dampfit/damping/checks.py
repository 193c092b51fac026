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
Whittle factor r (:mod:`dampfit.inference.noise`) of each law's residuals is reported beside it.

**Adequacy verdict** (:func:`adequacy`): one decision from all the evidence the analysis
computes. Inputs: the windowed slope s = d ln p/d ln a (:func:`~dampfit.damping.curve.slope`)
with its standard error and the amplitude span a_max/a_min of the windows; the windowed
frequency trend (:func:`~dampfit.damping.curve.frequency_trend`); P(viscous | data) and the
best non-viscous law (:mod:`~dampfit.damping.evidence`); for the viscous fit and for the
best-fitting law: the Ljung–Box p at f₀, r_raw/r_white and the residual rms relative to the
fitted decay and to the sensor noise (:func:`dampfit.inference.noise.misfit_check`). Criteria:

* *slope decisive*: the 99 % interval of s excludes 0 (|s| > t₀.₉₉₅,ν·sd) **and** the implied
  change of ζ over the recorded amplitudes, (a_max/a_min)^|s|, is ≥ :data:`ZETA_RATIO_MATTERS`;
* *law decisive*: P(viscous | data) < :data:`~dampfit.damping.evidence.P_VISCOUS_MAX`, unless
  the windows contradict it: the whole 90 % interval of s implies a change of ζ below
  :data:`ZETA_RATIO_MATTERS` (*slope null*) — then the law evidence only comes from
  something else in the waveform;
* *fit misfit* (for the viscous fit, and for the best law): the absolute rule of
  :func:`dampfit.inference.noise.misfit_check` (r_raw/r_white > 3, or residual > 5 % of the signal and
  > 3× the sensor noise) holds **and** the residual is structured at f₀ (Ljung–Box
  p < :data:`P_WHITE`) — or the residual is > 5 % of the signal and > 3× the sensor noise,
  whatever the Ljung–Box p (a large residual is misfit even if it is not at f₀). The same rule is applied to the constant-frequency viscous least squares whose c
  :func:`dampfit.analyze` reports (*pipeline misfit*);
* *frequency drift*: the 99 % interval of g = d ln ω_d/d ln a excludes 0 and the frequency
  changes by more than :data:`FREQ_DRIFT_MATTERS` over the recorded amplitudes; or *phase
  drift*: the constant-frequency fit is a misfit and leaves more than :data:`PHASE_RATIO`
  times the residual of the viscous fit with frequency-drift phase terms (amplitude-dependent
  damping leaves ≈ 1×, a drifting frequency 10–60×).

The verdict, first match wins:

1. **misfit** — the best-fitting law is itself a misfit, or the frequency drifts with
   amplitude or along the decay (a stiffness nonlinearity no damping law describes; named as
   the cause), or the viscous (or pipeline) fit is a misfit and neither the slope nor the law
   evidence is decisive. No damping law is named.
2. **inconclusive** — fewer than :data:`MIN_CYCLES` cycles or fewer than 4 independent windows
   (no slope), and no decisive criterion.
3. **amplitude-dependent** — slope decisive or law decisive; the best non-viscous law is
   named, with the slope evidence.
4. **inconclusive** — weak evidence either way: P(viscous) < :data:`P_VISCOUS_ADEQUATE`, or
   the 90 % interval of s excludes 0 with a change of ζ ≥ :data:`ZETA_RATIO_MATTERS`, or law
   evidence contradicted by the slope.
5. **adequate** — one viscous c describes the decay.

So "adequate" is never returned while any single criterion is decisive against it, and a law
is never named as the explanation of a misfit. Thresholds were calibrated by simulation
(``tests/test_adequacy.py``).

**Warning text.** :func:`warning_text` states, when amplitude dependence is detected, how
much ζ changes over the recorded amplitudes, which law fits and what to put in the FEM model.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

__all__ = ["ljung_box", "envelope_whiteness", "warning_text", "adequacy", "verdict_warning",
           "FEM_HINT", "VERDICTS"]

#: The four verdicts of :func:`adequacy`.
VERDICTS = ("adequate", "amplitude-dependent", "misfit", "inconclusive")
#: Fewest oscillation cycles for a verdict other than "inconclusive" (Ljung–Box needs 10).
MIN_CYCLES = 10
#: Change of ζ over the recorded amplitudes that matters [1].
ZETA_RATIO_MATTERS = 1.25
#: Relative change of the damped frequency over the recorded amplitudes that matters [1].
FREQ_DRIFT_MATTERS = 0.005
#: A constant-frequency viscous residual this many times that of the viscous fit with
#: frequency-drift phase terms: the frequency drifts along the decay.
PHASE_RATIO = 5.0
#: Ljung–Box p-value below which the residuals are structured at f₀.
P_WHITE = 1e-3
#: P(viscous | data) below this, without decisive evidence, leaves the verdict inconclusive.
P_VISCOUS_ADEQUATE = 0.5
#: Two-sided level of the "decisive" intervals of the slopes.
DECISIVE_LEVEL = 0.99

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


def _excludes_zero(est: float, sd: float, dof: int, level: float) -> bool:
    if not (np.isfinite(est) and np.isfinite(sd) and sd > 0 and dof > 0):
        return False
    return abs(est) > float(stats.t.ppf(0.5 + level / 2, dof)) * sd


def _fit_misfit(name: str, fit: dict | None) -> list[str]:
    """Reasons why one fit is a misfit (module docstring), [] if it is not."""
    if not fit:
        return []
    p = fit.get("ljung_box_p")
    structured = p is not None and np.isfinite(p) and p < P_WHITE
    from dampfit.inference.noise import NOISE_EXCESS, RESID_FRACTION, R_WARN

    r_ex, frac, nex = fit["r_excess"], fit["resid_fraction"], fit["noise_excess"]
    big = frac > RESID_FRACTION and nex > NOISE_EXCESS
    out = []
    if big:
        out.append(f"{name} residual rms {100 * frac:.3g} % of the signal, {nex:.3g}x the "
                   "sensor noise")
    if structured and r_ex > R_WARN:
        out.append(f"{name} residual structured at f0 (Ljung-Box p = {p:.2g}, "
                   f"r/r_white = {r_ex:.3g})")
    return out


def adequacy(*, n_cycles: float, slope: dict | None, amplitude_span: float,
             freq: dict | None, p_viscous: float, best_nonlinear: str | None,
             viscous: dict | None, best: dict | None, best_model: str = "viscous",
             pipeline: dict | None = None) -> dict:
    """The adequacy verdict of the module docstring.

    ``n_cycles`` [cycles] in the window; ``slope`` the windowed d ln p/d ln a
    (:func:`~dampfit.damping.curve.slope`, None with < 4 windows); ``amplitude_span``
    a_max/a_min [1] of the windows; ``freq`` :func:`~dampfit.damping.curve.frequency_trend`;
    ``p_viscous`` P(viscous | data) [1]; ``best_nonlinear`` the most probable non-viscous law;
    ``viscous``, ``best`` per-fit checks ``{"ljung_box_p", "r_excess", "resid_fraction",
    "noise_excess"}`` of the viscous fit and of the best-fitting law ``best_model``;
    ``pipeline`` the same for the constant-frequency viscous least squares whose c
    :func:`dampfit.analyze` reports (None when not available).

    Returns ``{"verdict", "reasons", "law", "criteria"}``: ``verdict`` one of
    :data:`VERDICTS`, ``reasons`` short strings with the numbers, ``law`` the named damping
    law (amplitude-dependent only, else None), ``criteria`` the booleans behind it.
    """
    reasons: list[str] = []
    span = float(amplitude_span) if np.isfinite(amplitude_span) and amplitude_span > 1 else 1.0
    s_dec = s_weak = s_null = False
    if slope is not None:
        s, sd, dof = slope["s"], slope["s_sd"], int(slope["n_windows"]) - 2
        ratio = float(span ** abs(s))
        matters = ratio >= ZETA_RATIO_MATTERS
        s_dec = matters and _excludes_zero(s, sd, dof, DECISIVE_LEVEL)
        s_weak = matters and not s_dec and (slope["s_q05"] > 0 or slope["s_q95"] < 0)
        s_null = span ** max(abs(slope["s_q05"]), abs(slope["s_q95"])) < ZETA_RATIO_MATTERS
        reasons.append(f"windowed slope d ln p/d ln a = {s:.2g} [{slope['s_q05']:.2g}, "
                       f"{slope['s_q95']:.2g}] (90 %), zeta changes {ratio:.3g}x over "
                       f"{span:.3g}x in amplitude, chi2/dof = {slope['chi2_per_dof']:.3g}")
    law_ev = bool(best_nonlinear) and np.isfinite(p_viscous) and p_viscous < _p_decisive()
    law_dec = law_ev and not s_null  # the windows contradict a law that changes ζ
    reasons.append(f"P(one viscous c) = {p_viscous:.2g}"
                   + (f", best other law {best_nonlinear}" if best_nonlinear else "")
                   + (" (contradicted by the windowed slope)" if law_ev and s_null else ""))
    f_dec = False
    if freq is not None:
        f_dec = (abs(freq["rel_change"]) > FREQ_DRIFT_MATTERS
                 and _excludes_zero(freq["g"], freq["g_sd"], int(freq["n_windows"]) - 2,
                                    DECISIVE_LEVEL))
        if f_dec:
            reasons.insert(0, f"frequency drifts with amplitude: f_d changes "
                              f"{100 * freq['rel_change']:+.2g} % from the smallest to the "
                              f"largest amplitude (±{100 * freq['rel_change_sd']:.2g} %)")
    v_mis = _fit_misfit("viscous", viscous)
    b_mis = _fit_misfit(best_model, best) if best_model != "viscous" else v_mis
    p_mis = _fit_misfit("constant-frequency viscous", pipeline)
    phase = bool(p_mis and viscous and pipeline["resid_fraction"]
                 > PHASE_RATIO * viscous["resid_fraction"])
    if phase and not f_dec:
        reasons.insert(0, "frequency drifts along the decay: the constant-frequency fit leaves "
                          f"{pipeline['resid_fraction'] / viscous['resid_fraction']:.3g}x the "
                          "residual of the fit with frequency-drift terms")
    fits = ([("viscous", viscous)] + ([(best_model, best)] if best_model != "viscous" else [])
            + [("constant-frequency viscous", pipeline)])
    for name, fit in fits:
        if fit:
            p = fit.get("ljung_box_p")
            reasons.append(f"{name}: Ljung-Box p = {'n/a' if p is None else format(p, '.2g')}, "
                           f"r/r_white = {fit['r_excess']:.3g}, residual = "
                           f"{100 * fit['resid_fraction']:.3g} % of the signal "
                           f"({fit['noise_excess']:.3g}x sensor noise)")
    few = n_cycles < MIN_CYCLES or slope is None
    criteria = {"slope_decisive": s_dec, "slope_weak": s_weak, "slope_null": s_null,
                "law_evidence": law_ev, "law_decisive": law_dec,
                "frequency_drift": f_dec, "viscous_misfit": bool(v_mis),
                "best_law_misfit": bool(b_mis), "pipeline_misfit": bool(p_mis),
                "phase_drift": phase,
                "few_cycles": few}
    explained = law_dec or s_dec
    if b_mis or f_dec or phase or ((v_mis or p_mis) and not explained):
        why = list(dict.fromkeys(b_mis + p_mis)) or v_mis
        ordered = ([reasons[0]] + why + reasons[1:]) if (f_dec or phase) else (why + reasons)
        return {"verdict": "misfit", "reasons": ordered, "law": None, "criteria": criteria}
    if few and not explained:
        reasons.insert(0, f"{n_cycles:.3g} cycles" + (", fewer than 4 independent windows"
                                                      if slope is None else ""))
        return {"verdict": "inconclusive", "reasons": reasons, "law": None, "criteria": criteria}
    if s_dec or law_dec:
        return {"verdict": "amplitude-dependent", "reasons": reasons,
                "law": best_nonlinear or "power", "criteria": criteria}
    if s_weak or law_ev or (np.isfinite(p_viscous) and p_viscous < P_VISCOUS_ADEQUATE):
        return {"verdict": "inconclusive", "reasons": reasons, "law": None, "criteria": criteria}
    return {"verdict": "adequate", "reasons": reasons, "law": None, "criteria": criteria}


def _p_decisive() -> float:
    from dampfit.damping.evidence import P_VISCOUS_MAX

    return P_VISCOUS_MAX


def verdict_warning(result: dict, amplitude_text: str | None = None) -> str | None:
    """The one warning for a verdict of :func:`adequacy` (None when adequate).

    ``amplitude_text`` the :func:`warning_text` of an amplitude-dependent decay.
    """
    v, why = result["verdict"], "; ".join(result["reasons"][:3])
    if v == "adequate":
        return None
    if v == "amplitude-dependent":
        if amplitude_text:
            return f"{amplitude_text} (evidence: {why})"
        return (
            f"damping depends on amplitude: the {result['law']} law fits best, so a single "
            f"viscous c is not adequate ({why})")
    if v == "misfit":
        return ("model misfit: the free-decay model does not describe this waveform "
                f"({why}); no damping law explains it (harmonics, frequency drift, distortion, "
                "a second mode or catches?), so c and its interval are not trustworthy — check "
                "the window and the set-up")
    return ("inconclusive: the recording cannot tell whether one viscous c is adequate "
            f"({why}); treat c as an estimate for this amplitude range only")
