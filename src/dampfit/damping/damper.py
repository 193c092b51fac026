r"""The one damper a recording supports: summary.json's ``damper`` section and its draws.

From what the analysis already decided — the adequacy verdict (:mod:`~dampfit.damping.checks`),
the law it names, that law's posterior draws (θ, a₀ and the mass) and the recorded amplitudes —
:func:`recommend` builds the recommendation every output leads with:

* **status** ``recommended`` (verdict "adequate": one viscous c; "amplitude-dependent": the law
  the verdict names), ``viscous-stands`` (verdict "inconclusive": the viscous c, with what the
  recording could not rule out) or ``none`` (verdict "misfit", an amplitude dependence no law
  describes, or a law without draws: why, and what to try);
* the law's **coefficients** (:attr:`dampfit.model.laws.Law.coefficients`, SI units) as
  median and 90 % interval of the law's own posterior draws, with the mass draws
  (:meth:`dampfit.model.laws.Law.physical` inverts (K2)–(K3));
* ``f_n`` and k = m·ω̄² from the mean frequency ω̄ over the window (:func:`mean_omega`: the
  law's ω corrected for its frequency-drift phase terms);
* the **measured range**: displacement amplitudes [lo, hi] of the analysed window and the
  velocity amplitudes ω̄·A (first-order averaging, u̇ = −a·ω·sin ψ);
* the **equivalent linear c** at the design amplitude A_d (``--amplitude``, else the middle of
  the measured range on a log scale, √(lo·hi)): c_lin = 2·m·ρ(A_d) per draw (Jacobsen 1930;
  (K2) of :mod:`dampfit.model.laws`), ζ_lin = ρ(A_d)/ω;
* where that c holds: the displacement amplitudes around A_d over which the law's posterior
  median c_eq(A) = 2·m·ρ(A) stays within ±10 % of c_lin's median, searched over
  [lo/10, 10·hi] (an end at the search bound means "at least that far"; a linear law holds
  over the whole search range). The ratio ρ(A)/ρ(A_d) is mass-free, so it is given without a
  mass too.

**Without a mass** the recording identifies rates per unit mass only: the coefficients that
need the mass (:attr:`~dampfit.model.laws.Coefficient.per_mass`) are given per kilogram under
``per_unit_mass`` (``c_per_kg`` [(N s/m)/kg] = 2·p …), ``coefficients`` keeps the mass-free
ones (α), ``mass``, ``k`` and ``c_linear`` are null and ``missing`` says why; ζ_lin, f_n and the
±10 % range are given. No FEM damper can be written from it.

Every summary is of all the law's draws (so the viscous c is printed with the interval of
``parameters.c``); a seeded, thinned subset of at most :data:`MAX_DRAWS` is kept for
posterior.nc's ``damper`` group. Numeric only: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dampfit.damping.checks import ZETA_RATIO_MATTERS
from dampfit.damping.quantities import summarise
from dampfit.model import laws

#: Most draws kept for posterior.nc's ``damper`` group.
MAX_DRAWS = 4000
#: Relative band of c_eq(A) around c_lin that "holds" [1].
WITHIN = 0.10
#: The ±10 % range is searched over [lo/SEARCH_FACTOR, SEARCH_FACTOR·hi] of the measured range.
SEARCH_FACTOR = 10.0
#: Points of the amplitude grid of that search (log-spaced) and draws used for its median.
_GRID, _CURVE_DRAWS = 481, 1000


@dataclass(frozen=True)
class LawDraws:
    """Posterior draws of one law: θ (N, k), start amplitude a₀ (N,) [m], mass (N,) [kg] or
    None; ``method`` ("emcee", "laplace"), ``converged``, ``note`` (why its intervals are
    approximate, "" when they are not); ``span_s`` [s] the window the phase terms of θ span
    (needed when θ carries frequency-drift terms, :func:`mean_omega`)."""

    law: str
    theta: np.ndarray
    a0: np.ndarray
    mass: np.ndarray | None
    method: str = "emcee"
    converged: bool = True
    note: str = ""
    span_s: float | None = None  # [s] the fitted window τ₁ − τ₀ (the phase terms' x scale)


@dataclass(frozen=True)
class Damper:
    """The ``damper`` section (plain, JSON-safe) and the draws of posterior.nc's group (name →
    array over ``draw``, SI units; None for status ``none``) with its attributes."""

    section: dict[str, Any]
    draws: dict[str, np.ndarray] | None
    attrs: dict[str, Any]


def _q(x: np.ndarray, unit: str, **extra) -> dict[str, Any]:
    out = summarise(x, unit)
    out.update(extra)
    return out


def _thin(n: int, seed: int) -> np.ndarray:
    """Indices of at most :data:`MAX_DRAWS` of ``n`` draws (seeded, in order)."""
    if n <= MAX_DRAWS:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, MAX_DRAWS, replace=False))


def _within(law: laws.Law, theta, a0, a_design: float, lo: float, hi: float) -> list | None:
    """[A_lo, A_hi] [m] around ``a_design`` where median ρ(A)/median ρ(A_d) is within ±WITHIN
    (module docstring), or None when not even A_d qualifies (no finite curve)."""
    idx = np.linspace(0, len(a0) - 1, min(_CURVE_DRAWS, len(a0))).astype(int)
    grid = np.geomspace(min(lo, a_design) / SEARCH_FACTOR, max(hi, a_design) * SEARCH_FACTOR,
                        _GRID)
    th, a = theta[idx], a0[idx]
    with np.errstate(all="ignore"):
        rho = law.local_rate(th[:, None, :], grid[None, :] / a[:, None])
        ref = np.nanmedian(law.local_rate(th, a_design / a))
        ratio = np.nanmedian(rho, axis=0) / ref
    ok = np.isfinite(ratio) & (np.abs(ratio - 1.0) <= WITHIN)
    i = int(np.argmin(np.abs(np.log(grid / a_design))))
    if not (np.isfinite(ref) and ref > 0 and ok[i]):
        return None
    j0, j1 = i, i
    while j0 > 0 and ok[j0 - 1]:
        j0 -= 1
    while j1 < grid.size - 1 and ok[j1 + 1]:
        j1 += 1
    return [float(grid[j0]), float(grid[j1])]


def _coefficients(law: laws.Law, d: LawDraws) -> tuple[dict, dict, dict]:
    """(coefficients in SI, per-kilogram ones without a mass, their draws)."""
    phys = law.physical(d.theta, d.a0, d.mass if d.mass is not None else None)
    per_kg = law.physical(d.theta, d.a0, 1.0) if d.mass is None else {}
    coef, per, draws = {}, {}, {}
    for c in law.coefficients:
        if d.mass is not None or not c.per_mass:
            x = np.asarray(phys[c.name], dtype=float)
            coef[c.name] = _q(x, c.unit, symbol=c.symbol)
            draws[c.name] = x
        else:
            x = np.asarray(per_kg[c.name], dtype=float)
            unit = f"({c.unit})/kg" if any(ch in c.unit for ch in " /^") else f"{c.unit}/kg"
            per[f"{c.name}_per_kg"] = _q(x, unit, symbol=f"{c.symbol}/m")
            draws[f"{c.name}_per_kg"] = x
    return coef, per, draws


def mean_omega(law: laws.Law, theta: np.ndarray, span_s: float | None) -> np.ndarray:
    """The mean angular frequency [rad/s] over the window of each θ draw: with the
    frequency-drift phase ψ = ω·τ + Σ c_j·P_j(x) of (K4), P_j(±1) = (±1)^j, the phase gained
    over the window T is ω·T + 2·Σ_{j odd} c_j, so ω̄ = ω + (2/T)·Σ_{j odd} c_j (ω alone is
    not the mean frequency when an odd-degree term is fitted)."""
    w = np.exp(theta[:, law.omega_index])
    if span_s and np.isfinite(span_s) and span_s > 0:
        for j in range(law.phase_count(theta)):
            if (j + 2) % 2:
                w = w + 2.0 * theta[:, law.omega_index + 1 + j] / span_s
    return w


def _numbers(name: str, d: LawDraws, measured: tuple[float, float], amplitude: float | None,
             mass: float | None, mass_sd: float) -> tuple[dict, dict]:
    """The numeric part of the section (law's coefficients, k, f_n, range, design amplitude,
    c_lin, ζ_lin, ±10 % range) and its draws."""
    law = laws.get(name, d.theta)
    theta, a0 = np.asarray(d.theta, float), np.asarray(d.a0, float)
    w = mean_omega(law, theta, d.span_s)
    w_med = float(np.median(w))
    lo, hi = measured
    a_d = float(amplitude) if amplitude is not None else float(np.sqrt(lo * hi))
    rho = law.local_rate(theta, a_d / a0)
    coef, per, draws = _coefficients(law, d)
    draws.update({"f_n": w / (2 * np.pi), "zeta_linear": rho / w})
    out: dict[str, Any] = {
        "force": law.force_text, "coefficients": coef,
        "mass": {"value": mass, "sd": mass_sd if mass is not None else None, "unit": "kg"},
        "k": None, "f_n": _q(draws["f_n"], "Hz"),
        "measured_range": {"displacement_m": [lo, hi],
                           "velocity_m_s": [w_med * lo, w_med * hi]},
        "design_amplitude": {"displacement_m": a_d, "velocity_m_s": w_med * a_d,
                             "source": "--amplitude" if amplitude is not None
                             else "middle of the measured range"},
        "c_linear": None, "zeta_linear": _q(draws["zeta_linear"], "1"),
        "linear_within_10pct_m": _within(law, theta, a0, a_d, lo, hi),
    }
    if per:
        out["per_unit_mass"] = per
    if d.mass is not None:
        m = np.asarray(d.mass, float)
        draws.update({"mass": m, "k": m * w * w, "c_linear": 2.0 * m * rho})
        out["k"] = _q(draws["k"], "N/m")
        out["c_linear"] = _q(draws["c_linear"], "N s/m")
    return out, draws


def _factor(x: float) -> str:
    return f"{100 * (x - 1):.2g} %" if x < 1.1 else f"{x:.3g}x"


def not_ruled_out(ctx: dict[str, Any], measured: tuple[float, float]) -> str:
    """What an "inconclusive" recording could not rule out, in one sentence from the evidence
    (``ctx``: ``no_decay``, ``bound`` = the largest change of ζ over the recorded amplitudes
    the slope's 90 % interval allows and ``bound_source``, ``white_at_f0`` with
    ``ljung_box_p``, ``best_nonlinear`` with ``best_weight``, ``p_viscous``)."""
    lo, hi = measured
    if ctx.get("no_decay"):
        return ("no damping at all: the decay rate cannot be told from 0, so the viscous c "
                "is an upper bound")
    parts, bounded = [], ""
    bound = ctx.get("bound")
    where = f"between {lo:.3g} and {hi:.3g} m displacement amplitude"
    source = ctx.get("bound_source") or "windowed slope"
    if isinstance(bound, (int, float)) and np.isfinite(bound) and bound >= ZETA_RATIO_MATTERS:
        parts.append(f"an amplitude-dependent damping with ζ changing by up to {_factor(bound)} "
                     f"{where} ({source}, 90 %)")
    elif isinstance(bound, (int, float)) and np.isfinite(bound):
        bounded = (f" (an amplitude dependence is bounded: ζ changes by at most "
                   f"{_factor(max(bound, 1.0))} {where}, {source}, 90 %)")
    else:
        parts.append(f"an amplitude-dependent damping of any size: the recorded amplitudes "
                     f"({lo:.3g}–{hi:.3g} m) give no slope of ζ against amplitude")
    best, weight = ctx.get("best_nonlinear"), ctx.get("best_weight")
    if best and isinstance(weight, (int, float)) and weight >= 0.05:
        parts.append(f"the {best} law (P = {weight:.2g})")
    if ctx.get("white_at_f0") is False:
        p = ctx.get("ljung_box_p")
        parts.append("structure at f0 that one viscous c leaves in the residual (Ljung-Box p = "
                     + ("n/a" if p is None else f"{p:.2g}") + ")")
    if not parts:
        parts.append("an amplitude dependence below what these data resolve")
    return "; ".join(parts) + " cannot be ruled out" + bounded


def misfit_advice(criteria: dict[str, Any]) -> str:
    """What to try after a misfit (or an amplitude dependence no law describes), from the
    adequacy criteria that fired."""
    tips = []
    if criteria.get("frequency_drift"):
        tips.append("the frequency changes with amplitude (a stiffness nonlinearity): analyse a "
                    "window of nearly constant amplitude (--window START END)")
    if criteria.get("phase_drift"):
        tips.append("the frequency drifts along the decay: check the set-up (temperature, a "
                    "loosening clamp) or analyse a shorter --window")
    if criteria.get("best_law_misfit") or criteria.get("viscous_misfit") \
            or criteria.get("pipeline_misfit"):
        tips.append("look at signal.png and spectrum.png for a second mode, harmonics, "
                    "clipping or catches; narrow the pass band (--band LO HI), shorten the "
                    "window (--window START END) or look for more modes (--max-modes 4)")
    if not tips:
        tips.append("record a longer, cleaner decay over a wider amplitude range; amplitude.png "
                    "shows the windows' zeta(A) meanwhile")
    tips.append("--force-law LAW on export writes a chosen law anyway, at your risk")
    return "; ".join(tips)


def _empty(verdict: str, reason: str, tip: str) -> Damper:
    keys = ("law", "force", "k", "f_n", "measured_range", "design_amplitude", "c_linear",
            "zeta_linear", "linear_within_10pct_m", "not_ruled_out", "draws", "mass",
            "missing", "posterior")
    section = {"status": "none", "verdict": verdict, **{k: None for k in keys},
               "coefficients": {}, "reason": reason, "try": tip}
    return Damper(section, None, {})


def recommend(*, verdict: str | None, reasons: list[str], law: str | None,
              draws: LawDraws | None, amplitudes: tuple[tuple[float, float], float | None],
              mass: tuple[float | None, float], context: dict[str, Any] | None = None,
              seed: int = 0) -> Damper:
    """The damper of the module docstring.

    ``verdict`` the adequacy verdict and ``reasons`` its reasons; ``law`` the law the verdict
    names (amplitude-dependent) — viscous is used for "adequate" and "inconclusive" whatever
    ``law`` is; ``draws`` that law's posterior draws (:class:`LawDraws`, None: none);
    ``amplitudes`` = (measured, amplitude): the (lo, hi) displacement amplitudes [m] of the
    analysed window and the user's design amplitude [m] or None; ``mass`` = (mass, sd) [kg]
    (as checked: :class:`dampfit.physics.Mass`); ``context`` the
    evidence :func:`not_ruled_out` and :func:`misfit_advice` read (``criteria`` …, ``weight``
    the law's posterior probability); ``seed`` thins the draws reproducibly.
    """
    (measured, amplitude), (mass, mass_sd) = amplitudes, mass
    ctx = context or {}
    first = reasons[0] if reasons else "no reason recorded"
    v = verdict or "none"
    if verdict in ("adequate", "inconclusive"):
        name = "viscous"
    elif verdict == "amplitude-dependent" and law:
        name = law
    elif verdict == "amplitude-dependent":
        return _empty(v, "damping depends on amplitude, but no damping law describes it "
                      f"reliably ({first})", misfit_advice({}))
    else:
        return _empty(v, first if verdict == "misfit" else
                      "no damping verdict could be made", misfit_advice(ctx.get("criteria")
                                                                       or {}))
    if draws is None or len(draws.a0) == 0:
        return _empty(v, f"the {name} law has no posterior draws", misfit_advice({}))
    lo, hi = measured
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
        return _empty(v, "no displacement amplitude was measured in the window",
                      misfit_advice({}))
    d = LawDraws(name, np.asarray(draws.theta, float), np.asarray(draws.a0, float),
                 None if draws.mass is None else np.asarray(draws.mass, float),
                 draws.method, draws.converged, draws.note, draws.span_s)
    numbers, arrays = _numbers(name, d, (float(lo), float(hi)), amplitude, mass, mass_sd)
    keep = _thin(len(d.a0), seed)  # the summaries are of every draw; the group keeps a subset
    arrays = {k: np.asarray(v)[keep] for k, v in arrays.items()}
    section: dict[str, Any] = {"status": "viscous-stands" if verdict == "inconclusive"
                               else "recommended", "verdict": v, "law": name, **numbers}
    section["reason"] = _reason(verdict, name, first, ctx, d)
    section["not_ruled_out"] = not_ruled_out(ctx, (lo, hi)) if verdict == "inconclusive" \
        else None
    section["try"] = None
    section["missing"] = None if mass is not None else (
        "no mass given: the coefficients in newtons, k and c_linear need it (--mass KG); the "
        "per-kilogram coefficients are under per_unit_mass")
    section["posterior"] = {"method": d.method, "converged": bool(d.converged),
                            "note": d.note or None}
    section["draws"] = {"group": "damper", "n": int(len(keep))}
    attrs = {"law": name, "design_amplitude_m": section["design_amplitude"]["displacement_m"]}
    return Damper(section, arrays, attrs)


#: What ``decay_check`` compares (summary.json's ``damper.decay_check.what``).
DECAY_CHECK_WHAT = ("the law's free decay at its coefficients' medians (RK4, the section's k "
                    "and mass, released at rest at the first peak after the filters settle, "
                    "on the measured trend) against the measured envelope: rms of ln|u| "
                    "about the measured trend, and the measurement's own scatter about it")


def decay_check(section: dict[str, Any], t: np.ndarray, accel: np.ndarray
                ) -> dict[str, Any] | None:
    """Whether a recommended nonlinear law's own free decay follows the recording: the
    check ``dampfit export`` makes before it writes the law
    (:func:`dampfit.damping.decay_run.check`, the section's k, mass and coefficients' medians,
    the measured ``accel`` [m/s²] at ``t`` [s] read as |a|/ω_n²), made when the recording is
    analysed so that the headline says what the deck will be. ``None`` for a viscous law, no
    recommendation or no mass (no deck). ``{"checked": False, "reason"}`` where it cannot
    run; else ``checked``, ``follows``, ``rms`` and ``scatter`` [1], ``n_peaks`` and
    ``what``. Where the law does not follow, export fits the measured force–velocity curve
    and writes it if it comes closer (:func:`dampfit.fem.measured.default_damper`)."""
    from dampfit.damping import decay_run

    name = section.get("law")
    mass = (section.get("mass") or {}).get("value")
    k = (section.get("k") or {}).get("q50")
    if section.get("status") != "recommended" or name in (None, "viscous") or not (
            mass and k):
        return None
    coeffs = {n: q["q50"] for n, q in (section.get("coefficients") or {}).items()}
    try:
        force = decay_run.scalar_force(name, coeffs)
        w2 = float(k) / float(mass)
        out = decay_run.check(t, np.asarray(accel, float) / w2, force, float(k), float(mass))
    except (ValueError, KeyError, ZeroDivisionError) as exc:
        return {"checked": False, "reason": str(exc) or type(exc).__name__}
    if out.get("rms_vs_trend") is None:
        return {"checked": False, "reason": f"{out.get('n_peaks')} peaks to compare"}
    return {"checked": True, "follows": out["follows"], "rms": out["rms_vs_trend"],
            "scatter": out["scatter"], "n_peaks": out["n_peaks"], "what": DECAY_CHECK_WHAT}


def _reason(verdict: str, name: str, first: str, ctx: dict[str, Any], d: LawDraws) -> str:
    approx = f" ({d.note})" if d.note else ""
    if verdict == "adequate":
        return f"one viscous c describes the whole decay: {first}{approx}"
    if verdict == "inconclusive":
        return (f"the recording cannot tell whether one viscous c is adequate: {first}; the "
                f"viscous c stands for the measured amplitude range only{approx}")
    w = ctx.get("weight")
    pw = f" (P = {w:.2g})" if isinstance(w, (int, float)) and np.isfinite(w) else ""
    return (f"damping depends on amplitude and the {name} law describes it best{pw}: "
            f"{first}{approx}")


def from_assessment(a: Any, viscous: LawDraws | None, *, amplitude: float | None,
                    seed: int = 0) -> Damper:
    """:func:`recommend` from a :class:`~dampfit.damping.assessment.DampingAssessment` ``a``
    (verdict, reasons, named law and its draws with the mass draws, recorded amplitudes,
    evidence). ``viscous`` the viscous draws to recommend under "adequate" or "inconclusive"
    (the pipeline's emcee posterior, whose c is ``parameters.c``; None: the assessment's own
    viscous draws)."""
    ad = a.adequacy or {}
    verdict = ad.get("verdict")
    law = ad.get("law")
    name = "viscous" if verdict in ("adequate", "inconclusive") else law
    draws = viscous if name == "viscous" else None
    if draws is None and name:
        post = a.posteriors.get(name)
        if post is not None:
            note = ""
            if post.ill_conditioned:
                note = "ill-conditioned: Laplace approximation, intervals approximate"
            elif post.method != "emcee":
                note = "Laplace approximation of the posterior, intervals approximate"
            elif not post.converged:
                note = f"posterior NOT converged ({post.stop_reason}), intervals approximate"
            draws = LawDraws(name, post.theta, post.a0, a.mass_draws.get(name), post.method,
                             bool(post.converged), note, getattr(a, "span_s", None))
    fc = (ad.get("fit_checks") or {}).get("viscous") or {}
    crit = ad.get("criteria") or {}
    bound = ad.get("bound") or {}
    best = a.verdict.get("best_nonlinear")
    weights = {r["model"]: r.get("weight") for r in a.table}
    ctx = {"criteria": crit, "no_decay": bool(crit.get("no_decay")),
           "bound": bound.get("factor"), "bound_source": bound.get("source"),
           "white_at_f0": crit.get("white_at_f0"), "ljung_box_p": fc.get("ljung_box_p"),
           "best_nonlinear": best, "best_weight": weights.get(best),
           "p_viscous": a.verdict.get("p_viscous"), "weight": weights.get(name)}
    return recommend(verdict=verdict, reasons=list(ad.get("reasons") or []), law=law,
                     draws=draws, amplitudes=(a.recorded_amplitudes, amplitude),
                     mass=(a.mass, float(getattr(a, "mass_sd", 0.0) or 0.0)),
                     context=ctx, seed=seed)
