r"""Physical quantities of each damping law from posterior draws, and their summaries.

For draws of θ and the start amplitude a₀ [m] (:mod:`dampfit.inference.law_sampler`) and, with a
mass, draws of m [kg] (normal, truncated at m > 0, independent of the data — the recording
identifies only rates per unit mass, exactly as in :mod:`dampfit.inference.posterior`), this module
evaluates the law's coefficients (:func:`dampfit.model.laws.physical`), the natural
frequency f_n = ω/2π [Hz] (first-order averaging: ω_n = ω), k = m·ω² [N/m], and the
equivalent viscous damping at chosen displacement amplitudes,

    ζ_eq(a) = ρ(a)/ω,   c_eq(a) = 2·m·ρ(a)   (Jacobsen 1930; (K2) of
    :mod:`~dampfit.model.laws`).

The arithmetic (k = m·ω², c = 2·m·ρ, ζ = p/ω_n) is :mod:`dampfit.physics`'s. Summaries are
plain JSON-safe dicts (unit, mean, sd, q05, q50, q95; :func:`summarise` is also the summariser
of the viscous posterior in :func:`dampfit.analyze`, there with R-hat and bulk ESS).
"""

from __future__ import annotations

import numpy as np

from dampfit import physics
from dampfit.model import laws as models

#: Unit of every reported quantity.
UNITS = {
    **{name: physics.UNITS[name] for name in ("p", "zeta", "f_n", "u0", "k", "c")},
    "p0": "1/s",
    "F_c": "N", "mu_c": "m/s^2", "friction_fraction": "1", "c2": "N s^2/m^2", "beta": "1/m",
    "drag_fraction": "1", "alpha": "1", "c_alpha": "N (s/m)^alpha", "gamma": "(m/s)^(1-alpha)/s",
    "zeta_eq_ref": "1", "zeta_eq_start": "1", "zeta_eq_end": "1",
    "c_eq_ref": "N s/m", "c_eq_start": "N s/m", "c_eq_end": "N s/m",
}


def unit_of(model: str, name: str) -> str:
    """Unit of the quantity ``name`` of law ``model``: :data:`UNITS`, else the law's own
    coefficient units (a law added with :func:`dampfit.model.registry.register`), else ""."""
    if name in UNITS:
        return UNITS[name]
    law = models.LAWS.get(model)
    units = {c.name: c.unit for c in law.coefficients} if law is not None else {}
    units.update({f"{n}/m": f"({u})/kg" for n, u in list(units.items())})
    return units.get(name, "")


def mass_draws(mass: float | None, mass_sd: float, size: int, rng) -> np.ndarray | None:
    """Mass draws [kg] (:func:`dampfit.inference.posterior.mass_draws`)."""
    from dampfit.inference.posterior import mass_draws as draws

    return draws(mass, mass_sd, size, rng)


def draws(model: str, theta: np.ndarray, a0: np.ndarray, m: np.ndarray | None,
          amplitudes: dict[str, float]) -> dict[str, np.ndarray]:
    """All reported quantities as arrays of draws.

    ``theta`` (N, k), ``a0`` (N,) [m], ``m`` (N,) [kg] or None, ``amplitudes`` maps the suffixes
    ``ref``, ``start``, ``end`` to displacement amplitudes [m] for ζ_eq and c_eq.
    """
    theta = np.asarray(theta, dtype=float)
    law = models.get(model)
    w = np.exp(theta[:, law.omega_index])
    out: dict[str, np.ndarray] = {"p0": np.exp(theta[:, 0]), "f_n": w / (2 * np.pi), "u0": a0}
    phys = law.physical(theta, a0, m)
    if isinstance(law, models.Viscous):  # one decay rate: it is p, and ζ = p/ω
        out["p"] = out["p0"]
        out["zeta"] = physics.quantities(out["p0"], w)["zeta"]
    elif law.shape_name not in phys:  # a shape parameter that is no coefficient (a fraction)
        out[law.shape_name] = theta[:, 1]
    # the law's coefficients (with a mass) and their per-unit-mass forms; p_viscous is p0's
    out.update({k_: v for k_, v in phys.items() if k_ != "p_viscous"})
    if m is not None:
        out["k"] = physics.stiffness(m, w)
    for name, a in amplitudes.items():
        if a is None or not np.isfinite(a) or a <= 0:
            continue
        rho = models.local_rate(model, theta, a / a0)
        out[f"zeta_eq_{name}"] = rho / w
        if m is not None:
            out[f"c_eq_{name}"] = physics.damping_coefficient(m, rho)
    return out


def summarise(x: np.ndarray, unit: str, diagnostics: dict[str, float] | None = None,
              weights: np.ndarray | None = None) -> dict:
    """``{"unit", "mean", "sd", "q05", "q50", "q95"}`` of draws ``x`` (NaN-free part).

    With ``diagnostics`` (the sampler's ``{"r_hat", "ess_bulk"}`` of this quantity, computed
    once by the posterior stage), ``r_hat`` [1] and ``ess_bulk`` [draws] are appended (NaN when
    absent); they are not recomputed here. ``weights`` (≥ 0, one per draw) makes every
    statistic an importance-weighted one (quantiles of the weighted empirical distribution).
    """
    x = np.asarray(x, dtype=float).ravel()
    w = np.ones_like(x) if weights is None else np.asarray(weights, dtype=float).ravel()
    keep = np.isfinite(x) & np.isfinite(w) & (w >= 0)
    x, w = x[keep], w[keep]
    if x.size == 0 or not w.sum() > 0:
        out = {"unit": unit, "mean": None, "sd": None, "q05": None, "q50": None, "q95": None}
    elif weights is None:
        q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
        sd = float(x.std(ddof=1)) if x.size > 1 else 0.0
        out = {"unit": unit, "mean": float(x.mean()), "sd": sd,
               "q05": float(q05), "q50": float(q50), "q95": float(q95)}
    else:
        order = np.argsort(x)
        xs, cw = x[order], np.cumsum(w[order]) / w.sum()
        q05, q50, q95 = (float(xs[min(np.searchsorted(cw, q), xs.size - 1)])
                         for q in (0.05, 0.5, 0.95))
        mean = float(np.sum(w * x) / w.sum())
        out = {"unit": unit, "mean": mean,
               "sd": float(np.sqrt(np.sum(w * (x - mean) ** 2) / w.sum())),
               "q05": q05, "q50": q50, "q95": q95}
    if diagnostics is not None:
        nan = float("nan")
        out["r_hat"] = float(diagnostics.get("r_hat", nan))
        out["ess_bulk"] = float(diagnostics.get("ess_bulk", nan))
    return out
