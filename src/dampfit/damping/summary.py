"""Plain-data summary of a :class:`~dampfit.damping.assessment.DampingAssessment` (summary.json).

Three keys, all JSON-safe (non-finite numbers become ``None``):

* ``model_checks`` — preferred law, amplitude dependence with its evidence, residual whiteness
  at f₀, whether one viscous c is adequate, and the warning text;
* ``damping_models`` — the comparison table and, per law, its parameters (posterior
  summaries), least-squares θ, method and FEM hint;
* ``amplitude_curve`` — the windowed ζ(amplitude) estimates, the slope of ln p against ln a,
  and each law's ζ_eq(a) (and c_eq(a) with a mass) on an amplitude grid, with a 90 % band for
  the chosen law — what :func:`dampfit.output.figures.amplitude_figure` draws.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dampfit._json import jsonable
from dampfit.damping import quantities
from dampfit.damping import evidence as compare
from dampfit.physics import damping_coefficient
from dampfit.model import laws as models

#: What every section reads: a :class:`dampfit.damping.assessment.DampingAssessment`. Not
#: imported, not even for type checkers: assessment.py imports this module, one way only.
Assessment = Any

#: Points of the amplitude grid of the model curves.
N_GRID = 60
#: Posterior draws used for the band of the chosen law.
N_BAND = 800


def _model_checks(a: Assessment) -> dict[str, Any]:
    q = a.quantities.get("power", {})
    s = None
    if "alpha" in q and len(q["alpha"]):
        s = quantities.summarise(q["alpha"] - 1.0, "1")
        s["source"] = "power-law fit: d ln p / d ln a = alpha - 1"
    pref = a.quantities.get(a.preferred, {})
    z = {k: quantities.summarise(pref[k], "1") for k in ("zeta_eq_start", "zeta_eq_end")
         if k in pref}
    warning = next((w for w in a.warnings if w.startswith("damping depends on amplitude")), None)
    return {
        "requested_model": a.requested,
        "preferred_model": a.preferred,
        "chosen_model": a.chosen,
        "single_viscous_c_adequate": a.verdict_name == "adequate",
        "amplitude_dependence": {
            "detected": a.amplitude_dependent,
            "criterion": f"P(viscous | data) < {compare.P_VISCOUS_MAX} (evidence, prior odds "
                         "1:1 viscous vs amplitude-dependent)",
            "p_viscous": a.verdict["p_viscous"],
            "ln_bayes_factor_nonlinear_vs_viscous": a.verdict["bayes_factor_ln"],
            "slope_ln_p_vs_ln_amplitude": s,
            "window_slope": a.slope,
            "amplitude_start_m": a.amplitudes["start"],
            "amplitude_end_m": a.amplitudes["end"],
            "zeta_at_start_and_end": z,
        },
        "residual_whiteness": {
            "psd_ratio_common": a.psd_ratio,
            "psd_ratio_by_model": a.psd_ratios,
            "psd_ratio_viscous_pipeline": a.pipeline_psd_ratio,
            "ljung_box_at_f0": a.whiteness,
            "note": "Ljung-Box on per-cycle residuals demodulated at f0; a small p-value "
                    "means the envelope (damping law) leaves structured misfit",
        },
        "warning": warning,
    }


def _model_entry(a: Assessment, name: str) -> dict[str, Any]:
    mf, post = a.fits[name], a.posteriors[name]
    q = a.quantities.get(name, {})
    names = [f"theta:{n}" for n in models.get(name, mf.theta).names]
    return {
        "parameters": {k: quantities.summarise(v, quantities.unit_of(name, k))
                       for k, v in q.items()},
        "least_squares": {"theta": dict(zip(names, mf.theta.tolist())), "rss": mf.rss,
                          "u0": mf.a0, "converged": mf.converged, "message": mf.message,
                          "theta_sd": (dict(zip(names, np.sqrt(np.diag(mf.cov)).tolist()))
                                       if mf.cov is not None else None)},
        "posterior": {"method": post.method, "converged": post.converged, "n_draws": len(post.a0),
                      "n_steps": post.n_steps, "max_r_hat": post.max_r_hat,
                      "min_ess_bulk": post.min_ess_bulk},
        "ln_evidence": mf.ln_evidence,
        "fem": models.get(name).fem_hint,
        "force": models.get(name).force_text,
        "coefficients": [{"name": c.name, "unit": c.unit, "symbol": c.symbol,
                          "needs_mass": c.per_mass} for c in models.get(name).coefficients],
        "style": {"colour": models.get(name).colour},
    }


def _curve(a: Assessment) -> dict[str, Any]:
    amps = [w.amplitude for w in a.windows if w.amplitude > 0]
    lo = min(amps + [a.amplitudes["end"]])
    hi = max(amps + [a.amplitudes["start"]])
    grid = np.geomspace(lo, hi, N_GRID) if lo > 0 and hi > lo else np.array([hi])
    curves = {}
    for name, mf in a.fits.items():
        if not mf.converged:
            continue
        zeta = models.local_rate(name, mf.theta, grid / mf.a0) / mf.omega
        entry = {"zeta_eq": zeta, "colour": models.get(name).colour}
        if a.mass is not None:
            entry["c_eq"] = damping_coefficient(a.mass, mf.omega * zeta)
        curves[name] = entry
    band = None
    post = a.posteriors.get(a.chosen)
    if post is not None and len(post.a0):
        idx = np.linspace(0, len(post.a0) - 1, min(N_BAND, len(post.a0))).astype(int)
        th, a0 = post.theta[idx], post.a0[idx]
        z = models.local_rate(a.chosen, th[:, None, :], grid[None, :] / a0[:, None]) \
            / np.exp(th[:, models.omega_index(a.chosen)])[:, None]
        band = {"model": a.chosen, "zeta_q05": np.quantile(z, 0.05, axis=0),
                "zeta_q50": np.quantile(z, 0.5, axis=0), "zeta_q95": np.quantile(z, 0.95, axis=0)}
    wins = [{"t_center_s": w.t_center + a.t0, "amplitude_m": w.amplitude,
             "accel_amplitude_m_s2": w.accel_amplitude, "p": w.p, "p_sd": w.p_sd,
             "zeta": w.zeta, "zeta_sd": w.zeta_sd, "f_d_hz": w.omega_d / (2 * np.pi),
             "f_d_sd_hz": w.omega_sd / (2 * np.pi),
             "c": damping_coefficient(a.mass, w.p) if a.mass is not None else None,
             "c_sd": damping_coefficient(a.mass, w.p_sd) if a.mass is not None else None,
             "n_samples": w.n}
            for w in a.windows]
    visc = a.fits.get("viscous")
    backbone = {
        "frequency_trend": (a.adequacy or {}).get("frequency_trend"),
        "phase_terms": models.n_phase("viscous", visc.theta) if visc is not None else 0,
        "note": "backbone: the windows' damped frequency f_d against displacement amplitude; "
                "frequency_trend: ln f_d = const + g ln a over non-overlapping windows, rel_change "
                "= (a_max/a_min)^g - 1 (< 0 softening, > 0 hardening); the viscous law of "
                "damping_models follows the drift with phase_terms Legendre phase coefficients "
                "(K4 in dampfit.model.laws), so its p, zeta and c are not biased by it",
    }
    return {
        "window_cycles": a.window_cycles, "windows": wins, "slope": a.slope, "backbone": backbone,
        "amplitude_grid_m": grid, "models": curves, "band": band,
        "preferred_model": a.preferred, "chosen_model": a.chosen, "mass_kg": a.mass,
        "reference_amplitude_m": a.amplitudes["ref"],
        "note": "windows: local viscous fits (50 % overlap, 1-sigma calibrated by r); models: "
                "zeta_eq(a) = rho(a)/omega of each law at its least-squares optimum",
    }


def _c_report(a: Assessment) -> dict[str, Any]:
    """:meth:`~dampfit.damping.assessment.DampingAssessment.c_report`, its numbers null with
    the reason (``"missing"``) where the equivalent c means nothing (``c_missing``)."""
    rep = a.c_report()
    why = a.c_missing()
    if why:
        rep.update(c=None, zeta=None, missing=why)
    return rep


def summary(a: Assessment) -> dict[str, Any]:
    """The plain-data view of ``a`` (module docstring)."""
    return jsonable({
        "model_checks": _model_checks(a),
        "damping_models": {
            "criterion": "log evidence (Laplace; a nonlinear law's shape parameter integrated "
                         "numerically); likelihood tempered by 1/r with one r (Whittle factor "
                         "of the best law's residuals) for every law",
            "model_prior": compare.model_prior(),
            "psd_ratio_common": a.psd_ratio,
            "comparison": a.table,
            "preferred_model": a.preferred,
            "chosen_model": a.chosen,
            "reference_amplitude_m": a.amplitudes["ref"],
            "c_report": _c_report(a),
            "models": {name: _model_entry(a, name) for name in a.fits},
        },
        "amplitude_curve": _curve(a),
    })
