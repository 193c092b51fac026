"""The plain-data summary of a live campaign (:func:`summarise`; kind "campaign",
schema_version 1): the population, each test's own and pooled values, the checks (computed
by :mod:`dampfit.campaign.verdict` before, only rendered here), the added-mass line and the
sampler's diagnostics. :meth:`dampfit.campaign.result.CampaignAnalysis.summary` caches it.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from dampfit import physics
from dampfit._json import jsonable
from dampfit._meta import __version__

#: What every section reads: a :class:`dampfit.campaign.result.CampaignAnalysis`. Not imported,
#: not even for type checkers: result.py imports this module, and the two stay one-way.
Campaign = Any

#: Draws [1] of each test's own (Laplace) estimate.
OWN_DRAWS = 4000
#: Population quantities reported under "parameters" and their units.
POPULATION_UNITS = {"c": "N s/m", "k": "N/m", "zeta": "1", "f_n": "Hz", "p": "1/s",
                    "c_crit": "N s/m", "m0": "kg"}
#: The names of each test's own and pooled values.
TEST_QUANTITIES = ("c", "zeta", "f_n", "p")


def quantiles(x, unit: str | None = None) -> dict[str, Any]:
    """5 %, 50 %, 95 % quantiles and sd of the finite values of ``x`` (None without any),
    with ``unit`` when given."""
    x = np.asarray(x, float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"q05": None, "q50": None, "q95": None, "sd": None,
                **({"unit": unit} if unit else {})}
    out = {"q05": float(np.quantile(x, 0.05)), "q50": float(np.median(x)),
           "q95": float(np.quantile(x, 0.95)), "sd": float(x.std(ddof=1))}
    if unit:
        out["unit"] = unit
    return out


def _interval(x, unit: str) -> dict[str, Any]:
    """:func:`quantiles` without the sd."""
    return {k: v for k, v in quantiles(x, unit).items() if k != "sd"}


def _parameters(a: Campaign) -> dict[str, Any]:
    """The population quantities (:data:`POPULATION_UNITS`; m0 of the added-mass design only)
    with their diagnostics."""
    from dampfit.damping.quantities import summarise as summarise_draws

    post, diag = a.posterior.posterior, a.sampling.diagnostics
    added = a.added_mass is not None
    return {n: (summarise_draws(np.asarray(post[n]), u, diag.get(n, {})) if n in post else None)
            for n, u in POPULATION_UNITS.items() if n != "m0" or added}


def _mass(a: Campaign) -> dict[str, Any]:
    """The mass: given (hierarchical) or the posterior m₀ (added-mass design) [kg]."""
    if a.added_mass is not None:
        m0 = np.asarray(a.posterior.posterior["m0"]).ravel()
        return {"value": float(np.median(m0)), "sd": float(m0.std(ddof=1)), "unit": "kg"}
    return {"value": a.mass, "sd": a.mass_sd if a.mass is not None else None, "unit": "kg"}


def _population(a: Campaign) -> dict[str, Any]:
    """The between-test spreads (τ_p, τ_ω with P(τ_ω = 0), eq. C7), the predictive damper of
    a new test and whether the tests agree (:mod:`dampfit.campaign.verdict`)."""
    post = a.posterior.posterior
    spread = {"p": _interval(post["tau_p"], "1"),
              "omega": {**_interval(post["tau_omega"], "1"),
                        "p_zero": float(a.sampling.p_shared_frequency)}}
    predictive = {}
    for name in ("c", "zeta", "f_n", "k"):
        key = f"predictive_{name}"
        predictive[name] = (_interval(post[key], POPULATION_UNITS[name]) if key in post
                            else None)
    return {"spread": spread, "predictive": predictive,
            "spread_consistent_with_zero": a.checks.spread_consistent_with_zero}


def _tests(a: Campaign, m0_draws: np.ndarray | None) -> list[dict[str, Any]]:
    """Each test: its input, window, band, frequency, added mass, amplitude, noise ratio,
    damping-law verdict, its **own** values (:data:`OWN_DRAWS` draws of its Laplace
    expansion; mass the given one, or the posterior m₀ + Δm_i), its **pooled** values from
    the joint posterior, and whether it is an outlier."""
    from dampfit.inference import posterior as post_mod

    post = a.posterior.posterior
    added = a.added_mass is not None
    rng = np.random.default_rng(a.seed + 1)
    if added:
        m0_own = rng.choice(m0_draws, OWN_DRAWS)
    else:
        m_own = post_mod.mass_draws(a.mass, a.mass_sd, OWN_DRAWS, rng)
    outliers = set(a.checks.outliers)
    out = []
    for t in a.tests:
        z = rng.multivariate_normal(t.psi_hat, t.sigma_psi, OWN_DRAWS)
        p, wn = np.exp(z[:, 0]), np.exp(z[:, 1])
        q = physics.quantities(p, mass=(m0_own + t.added_mass_kg) if added else m_own,
                               omega_n=wn)
        own = {name: (quantiles(q[name]) if name in q else None) for name in TEST_QUANTITIES}
        pooled = {name: (quantiles(np.asarray(post[f"{name}_test"])[..., t.index])
                         if f"{name}_test" in post else None) for name in TEST_QUANTITIES}
        rec, prep = t.recording, t.prepared
        out.append({
            "index": t.index + 1,
            "input": {"path": os.path.abspath(rec.path) if rec.path else rec.path,
                      "sha256": rec.sha256, "n_samples": rec.n_samples,
                      "sample_rate_hz": prep.fs, "duration_s": rec.duration,
                      "decimated": prep.decimation},
            "window": {"start_s": prep.window[0], "end_s": prep.window[1]},
            "band": {"low_hz": prep.band[0], "high_hz": prep.band[1]},
            "dominant_frequency_hz": prep.f0,
            "added_mass_kg": t.added_mass_kg,
            "amplitude_m": t.amplitude_m,
            "noise_psd_ratio": t.noise.psd_ratio,
            "damping_verdict": t.damping_verdict,
            "own": own, "pooled": pooled, "outlier": t.index in outliers})
        if t.modes is not None:  # max_modes > 1 (dampfit.campaign.modes)
            out[-1]["modes"] = t.modes
    return out


def _added_mass(a: Campaign, params: dict[str, Any]) -> dict[str, Any] | None:
    """The added-mass design's m₀, k, each test's ω_n² [rad²/s²] with its sd against its
    added mass [kg], and the line 1/ω_n² = (m₀ + Δm)/k (intercept [s²], slope [s²/kg])."""
    if a.added_mass is None:
        return None
    post = a.posterior.posterior
    k = np.asarray(post["k"]).ravel()
    m0 = np.asarray(post["m0"]).ravel()
    points = []
    for t in a.tests:
        w2 = float(np.exp(2 * t.psi_hat[1]))
        points.append({"added_mass_kg": t.added_mass_kg, "omega_n2": w2,
                       "omega_n2_sd": float(2 * w2 * np.sqrt(t.sigma_psi[1, 1]))})
    return {"m0": params["m0"], "k": params["k"], "points": points,
            "line": {"intercept": float(np.median(m0 / k)), "slope": float(np.median(1.0 / k)),
                     "unit_intercept": "s^2", "unit_slope": "s^2/kg"}}


def _diagnostics(a: Campaign) -> dict[str, Any]:
    """Convergence (worst R-hat, least bulk ESS of the reported quantities) and the
    sampler's facts."""
    s = a.sampling  # max_r_hat, min_ess_bulk: of sampling.REPORTED (SamplerRun.finish)
    return {"converged": a.converged, "max_r_hat": s.max_r_hat, "min_ess_bulk": s.min_ess_bulk,
            "n_steps": s.n_steps, "burn_in": s.burn_in, "thin": s.thin,
            "acceptance_fraction": s.acceptance,
            "importance_ess_fraction": s.importance_ess_fraction,
            "log_bayes_factor_shared_frequency": s.log_bayes_factor_shared,
            "seconds": s.seconds, "warnings": list(s.warnings)}


def _design(a: Campaign) -> dict[str, Any]:
    """The design: number of tests, model, mass or added masses [kg], and the priors."""
    from dampfit.campaign import model

    return {"n_tests": len(a.tests), "model": a.model,
            "mass": ({"value": a.mass, "sd": a.mass_sd, "unit": "kg"}
                     if a.mass is not None else None),
            "added_mass": ({"values": [float(x) for x in a.added_mass],
                            "sd": a.added_mass_sd, "unit": "kg"}
                           if a.added_mass is not None else None),
            "priors": {"tau_p": f"half-normal, scale {model.TAU_P_SCALE}",
                       "tau_omega": f"0 with probability {model.P_SHARED_FREQUENCY}, "
                                    f"else half-normal, scale {model.TAU_OMEGA_SCALE}",
                       "locations": f"normal, sd {model.LOCATION_SD} about the "
                                    "least-squares values (log scale)"}}


def summarise(a: Campaign) -> dict[str, Any]:
    """The JSON-safe summary of the live campaign ``a`` (its checks already made)."""
    from dampfit.result.schema import SCHEMA_VERSION

    params = _parameters(a)
    m0_draws = (np.asarray(a.posterior.posterior["m0"]).ravel()
                if a.added_mass is not None else None)
    return jsonable({
        "schema_version": SCHEMA_VERSION,
        "kind": "campaign",
        "dampfit_version": __version__,
        "design": _design(a),
        "parameters": params,
        "mass": _mass(a),
        "population": _population(a),
        "tests": _tests(a, m0_draws),
        "checks": a.checks.summary(),
        "added_mass": _added_mass(a, params),
        "diagnostics": _diagnostics(a),
        "warnings": list(a.warnings),
        "provenance": {"seed": a.seed, "options": a.options, "date": a.date},
    })
