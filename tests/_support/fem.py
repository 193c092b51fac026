"""Hand-made result folders for the FEM hand-off (``export``, ``verify``) and the hostile cases
that read a result folder: a ``summary.json`` alone, or a whole result with ``signals.npz``."""

from __future__ import annotations

import json
import math

import numpy as np

from dampfit.physics import to_decay
from dampfit.simulate import free_decay

M, K, C, U0 = 5.3, 619.0, 0.2, 0.04  # the seed paper's set-up (SI)
T_RELEASE, T0, SPAN, FS = 0.5, 2.0, 20.0, 200.0


def write_summary(folder, mass=M, k=K, c=C, u0=U0, spread=0.01, window=(2.0, 12.0)):
    """A minimal summary.json with q05/q50/q95 = value·(1 ∓ spread, 1, 1 ± spread)."""
    def entry(unit, v):
        return None if v is None else {"unit": unit, "mean": v, "sd": spread * v,
                                       "q05": v * (1 - spread), "q50": v, "q95": v * (1 + spread)}
    p = None if mass is None else c / (2 * mass)
    summary = {
        "dampfit_version": "test",
        "input": {"sample_rate_hz": 500.0, "sha256": "0" * 64},
        "window": {"start_s": window[0], "end_s": window[1]},
        "mass": {"value": mass, "sd": 0.02 if mass else None, "unit": "kg"},
        "parameters": {"c": entry("N s/m", c if mass else None), "k": entry("N/m", k if mass else None),
                       "u0": entry("m", u0), "p": entry("1/s", p if p else 0.0189)},
    }
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


def write_result(folder, noise=0.0, mass=M, drop=()):
    """A result folder for the clean free decay released at T_RELEASE, window [T0, T0 + SPAN]:
    summary.json (posterior medians = truth) and signals.npz with the keys analysis writes."""
    p, wd = (float(x) for x in to_decay(C, K, M))
    t = T0 + np.arange(int(SPAN * FS) + 1) / FS
    u, _, a = free_decay(t - T_RELEASE, M, C, K, U0)
    rng = np.random.default_rng(1)
    sig = {"t": t, "accel": a + noise * rng.standard_normal(t.size), "accel_model": a,
           "displacement": u, "displacement_model": u, "fs": np.float64(FS),
           "p": np.float64(p), "omega_d": np.float64(wd), "t0": np.float64(T0)}
    folder.mkdir(parents=True, exist_ok=True)
    np.savez(folder / "signals.npz", **{k: v for k, v in sig.items() if k not in drop})
    entry = lambda unit, v: {"unit": unit, "mean": v, "sd": 0.0, "q05": v, "q50": v, "q95": v}
    summary = {"dampfit_version": "test", "window": {"start_s": T0, "end_s": T0 + SPAN},
               "input": {"sample_rate_hz": FS}, "mass": {"value": mass, "sd": 0.0, "unit": "kg"},
               "parameters": {"c": entry("N s/m", C if mass else None), "k": entry("N/m", K if mass else None),
                              "u0": entry("m", U0), "p": entry("1/s", p)}}
    if mass is None:
        summary["parameters"]["c"] = summary["parameters"]["k"] = None
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


#: Two measured modes (f_n [Hz], ζ [1]) of a modal summary; the first is the damper's mode.
MODES = ((math.sqrt(K / M) / (2 * math.pi), C / (2 * math.sqrt(K * M))), (10.0, 0.004))


def modal_entries(modes=MODES, spread=0.02, n=4000, seed=0):
    """(modes list, Rayleigh entry) as the modes stage writes them (mean/sd/q05/q50/q95 per
    quantity; Rayleigh from :func:`dampfit.physics_modal.rayleigh_summary` of draws with a
    relative spread ``spread`` around each mode's (f_n, ζ))."""
    from dampfit.physics_modal import rayleigh_summary

    rng = np.random.default_rng(seed)
    f = np.array([m[0] for m in modes]) * (1 + 0.1 * spread * rng.standard_normal((n, len(modes))))
    z = np.array([m[1] for m in modes]) * (1 + spread * rng.standard_normal((n, len(modes))))

    def stats(x, unit):
        q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
        return {"mean": float(x.mean()), "sd": float(x.std(ddof=1)), "q05": float(q05),
                "q50": float(q50), "q95": float(q95), "unit": unit}

    rows = [{"index": i + 1, "mass_mode": i == 0, "f_n": stats(f[:, i], "Hz"),
             "zeta": stats(z[:, i], "1")} for i in range(len(modes))]
    ray = rayleigh_summary(2 * np.pi * f, z) if len(modes) >= 2 else None
    return rows, ray


def write_modal_summary(folder, modes=MODES, layout="list", **kw):
    """:func:`write_summary` plus several modes: ``layout`` "list" (top-level ``modes`` list,
    ``n_modes`` and ``modes_rayleigh``), "rayleigh" (the list with ``rayleigh`` beside it) or
    "stage" (``modes`` = the whole modes-stage object with ``modes`` and ``rayleigh``)."""
    write_summary(folder, **kw)
    path = folder / "summary.json"
    summary = json.loads(path.read_text())
    rows, ray = modal_entries(modes)
    if layout == "stage":
        summary["modes"] = {"n_modes": len(rows), "modes": rows, "rayleigh": ray}
    else:
        summary.update({"n_modes": len(rows), "modes": rows,
                        ("modes_rayleigh" if layout == "list" else "rayleigh"): ray})
    path.write_text(json.dumps(summary))
    return folder


# -- the damper section (issue 32; notes/damper_spec.md) -------------------------------------

#: Known nonlinear dampers on the seed paper's system (SI): ζ_eq ≈ 0.005–0.01 at U0.
LAW_CASES = {
    "power": {"c_alpha": 0.53, "alpha": 0.5},
    "coulomb": {"c": 0.2, "F_c": 0.06},
    "quadratic": {"c": 0.2, "c2": 1.6},
    "viscous": {"c": C},
}
_UNITS = {"c": "N s/m", "F_c": "N", "c2": "N s^2/m^2", "c_alpha": "N (s/m)^alpha", "alpha": "1"}


def stats(value, unit, spread=0.02):
    """An interval entry (mean, sd, q05, q50, q95) around ``value`` with a relative ``spread``."""
    v = float(value)
    return {"unit": unit, "mean": v, "sd": spread * abs(v), "q05": v - 1.645 * spread * abs(v),
            "q50": v, "q95": v + 1.645 * spread * abs(v)}


def damper_section(law, coeffs, mass=M, k=K, amplitude=(0.3 * U0, U0), status=None,
                   verdict=None, design=None, spread=0.02):
    """summary["damper"] per the contract for ``law`` with the known ``coeffs`` (SI): measured
    displacement range ``amplitude`` [m] (v = ω·A), design amplitude its middle, c_linear the
    law's c_eq there (K2)."""
    from dampfit.fem.damper import c_equivalent

    w = math.sqrt(k / mass)
    lo, hi = amplitude
    a_d = design if design is not None else 0.5 * (lo + hi)
    status = status or "recommended"
    if law is None or status == "none":
        c_lin = None
    else:
        c_lin = c_equivalent(law, coeffs, w, a_d)
    crit = 2 * math.sqrt(k * mass)
    return {
        "status": status,
        "verdict": verdict or ("adequate" if law == "viscous" else "amplitude-dependent"),
        "law": None if status == "none" else law,
        "force": "test",
        "coefficients": {} if status == "none" else {
            n: {**stats(v, _UNITS[n], spread), "symbol": n} for n, v in coeffs.items()},
        "mass": {"value": mass, "sd": 0.0, "unit": "kg"},
        "k": stats(k, "N/m", 0.002), "f_n": stats(w / (2 * math.pi), "Hz", 0.001),
        "measured_range": {"displacement_m": [lo, hi], "velocity_m_s": [w * lo, w * hi]},
        "design_amplitude": {"displacement_m": a_d, "velocity_m_s": w * a_d,
                             "source": "middle of the measured range"},
        "c_linear": None if c_lin is None else stats(c_lin, "N s/m", spread),
        "zeta_linear": None if c_lin is None else stats(c_lin / crit, "1", spread),
        "linear_within_10pct_m": None,
        "reason": "test damper",
        "not_ruled_out": None, "try": None if status != "none" else "a longer recording",
        "draws": None,
    }


def write_damper_summary(folder, law, coeffs=None, status=None, **kw):
    """:func:`write_summary` (viscous parameters c = C) plus the damper section of ``law``."""
    write_summary(folder)
    path = folder / "summary.json"
    summary = json.loads(path.read_text())
    summary["damper"] = damper_section(law, LAW_CASES.get(law, {}) if coeffs is None
                                       else coeffs, status=status, **kw)
    summary["model_checks"] = {"verdict": summary["damper"]["verdict"]}
    path.write_text(json.dumps(summary))
    return folder


def simulate_law(law, coeffs, t, mass=M, k=K, u0=U0, force_fn=None):
    """Free decay m·ü + F(u̇) + k·u = 0 from rest at ``u0`` (DOP853, rtol 1e-10) at times
    ``t`` [s] from 0: (u [m], v [m/s], a [m/s²]); the damper force of :mod:`dampfit.fem.damper`
    (or ``force_fn(v)`` [N], a law defined by a test)."""
    from scipy.integrate import solve_ivp

    from dampfit.fem.damper import force as law_force

    def force(_law, _coeffs, v):
        return law_force(law, coeffs, v) if force_fn is None else force_fn(np.asarray(v, float))

    def rhs(_, y):
        return [y[1], -(k * y[0] + float(force(law, coeffs, y[1]))) / mass]

    sol = solve_ivp(rhs, (0.0, float(t[-1])), [u0, 0.0], t_eval=t, method="DOP853",
                    rtol=1e-10, atol=1e-13, max_step=0.01)
    u, v = sol.y
    a = -(k * u + force(law, coeffs, v)) / mass
    return u, v, a


def c_eq_of(force_fn, omega, amplitude):
    """Energy-equivalent linear c [N·s/m] of the force law ``force_fn(v)`` [N] at displacement
    ``amplitude`` [m]: (4/(π·V))·∫₀^{π/2} F(V sin θ) sin θ dθ, V = ω·A, by quadrature."""
    th = np.linspace(0.0, math.pi / 2, 4001)
    V = omega * amplitude
    return 4 / (math.pi * V) * float(np.trapezoid(force_fn(V * np.sin(th)) * np.sin(th), th))


def write_damper_result(folder, law, span=20.0, fs=200.0, coeffs=None, noise=0.0,
                        force_fn=None):
    """A result folder of a free decay damped by ``law`` (released at rest at U0 at the window
    start T0): signals.npz of the true motion, summary.json with the viscous fit of the start
    rate, the damper section and an amplitude_curve of the law's ζ(A) (sd 3 %). With
    ``force_fn(v)`` [N] the decay, its start rate and ζ(A) are that force's (the damper
    section still names ``law``: the headline a recording of it got)."""
    from dampfit.fem.damper import c_equivalent, theta
    from dampfit.model.laws import get

    coeffs = LAW_CASES[law] if coeffs is None else coeffs
    tau = np.arange(int(span * fs) + 1) / fs
    u, _, a = simulate_law(law, coeffs, tau, force_fn=force_fn)
    w = math.sqrt(K / M)
    p0 = float(np.exp(theta(law, coeffs, M, w, U0)[0]))
    if force_fn is not None:
        c_equivalent = lambda _l, _c, om, A: c_eq_of(force_fn, om, A)  # noqa: E731
        p0 = c_equivalent(law, coeffs, w, U0) / (2 * M)
    rng = np.random.default_rng(2)
    sig = {"t": T0 + tau, "accel": a + noise * rng.standard_normal(tau.size), "accel_model": a,
           "displacement": u, "displacement_model": u, "fs": np.float64(fs),
           "p": np.float64(p0), "omega_d": np.float64(w), "t0": np.float64(T0)}
    folder.mkdir(parents=True, exist_ok=True)
    np.savez(folder / "signals.npz", **sig)
    e_end = float(get(law).envelope(theta(law, coeffs, M, w, U0), np.array([span]), xp=np)[0][0])
    if force_fn is not None:  # the simulated decay's own amplitude over its last period
        e_end = float(np.max(np.abs(u[tau > span - 2 * math.pi / w]))) / U0
    entry = lambda unit, v: stats(v, unit, 0.0)  # noqa: E731
    c_start = c_equivalent(law, coeffs, w, U0)
    crit = 2 * math.sqrt(K * M)
    amps = np.geomspace(U0 * e_end * 1.05, U0 * 0.95, 8)
    windows = [{"amplitude_m": float(A), "zeta": c_equivalent(law, coeffs, w, A) / crit,
                "zeta_sd": 0.03 * c_equivalent(law, coeffs, w, A) / crit} for A in amps]
    summary = {"dampfit_version": "test", "window": {"start_s": T0, "end_s": T0 + span},
               "input": {"sample_rate_hz": fs}, "mass": {"value": M, "sd": 0.0, "unit": "kg"},
               "parameters": {"c": entry("N s/m", c_start), "k": entry("N/m", K),
                              "u0": entry("m", U0), "p": entry("1/s", p0)},
               "amplitude_curve": {"windows": windows},
               "damper": damper_section(law, coeffs, amplitude=(U0 * e_end, U0))}
    summary["model_checks"] = {"verdict": summary["damper"]["verdict"]}
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


def write_damper_draws(folder, law, n=400, spread=0.05, seed=3):
    """posterior.nc with a ``damper`` group of ``n`` joint draws around the case's coefficients
    (lognormal, relative sd ``spread``; m fixed, k 0.2 %), c_linear and ζ_linear at the design
    amplitude from (K2); the summary's c_linear/zeta_linear become those draws' quantiles.
    Returns the ζ_linear draws."""
    import arviz as az
    import xarray as xr

    from dampfit.fem.damper import c_equivalent

    path = folder / "summary.json"
    summary = json.loads(path.read_text())
    sec = summary["damper"]
    rng = np.random.default_rng(seed)
    base = {k: v["q50"] for k, v in sec["coefficients"].items()}
    draws = {name: v * np.exp(spread * rng.standard_normal(n)) for name, v in base.items()}
    mass = np.full(n, M)
    k = K * (1 + 0.002 * rng.standard_normal(n))
    a_d = sec["design_amplitude"]["displacement_m"]
    c_lin = np.array([c_equivalent(law, {q: draws[q][i] for q in draws}, math.sqrt(k[i] / M), a_d)
                      for i in range(n)])
    zeta = c_lin / (2 * np.sqrt(k * mass))
    ds = xr.Dataset({name: ("draw", x) for name, x in {**draws, "mass": mass, "k": k,
                                                       "c_linear": c_lin,
                                                       "zeta_linear": zeta}.items()},
                    coords={"draw": np.arange(n)}, attrs={"law": law,
                                                          "design_amplitude_m": a_d})
    post = xr.Dataset({"c": (("chain", "draw"), rng.standard_normal((1, 10)))},
                      coords={"chain": [0], "draw": np.arange(10)})
    az.InferenceData(posterior=post, damper=ds).to_netcdf(str(folder / "posterior.nc"))
    for key, x in (("c_linear", c_lin), ("zeta_linear", zeta)):
        q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
        sec[key].update(q05=float(q05), q50=float(q50), q95=float(q95))
    sec["draws"] = {"group": "damper", "n": n}
    path.write_text(json.dumps(summary))
    return zeta


def damper_from_summary(summary, law=None):
    """A damper section (the contract's layout) built from a real summary written before it
    existed: the preferred law's ``damping_models.models.LAW.parameters`` (coefficients, k),
    ``c_equivalent`` (design amplitude, c_linear, ζ_linear, the recorded amplitude range) and
    the verdict — for developing export/verify on real recordings before the merge."""
    dm = summary["damping_models"]
    law = law or dm.get("chosen_model") or dm["preferred_model"]
    params = dm["models"][law]["parameters"]
    from dampfit.fem.damper import COEFFICIENTS

    ce = summary.get("c_equivalent") or {}
    mass = summary["mass"]["value"]
    k = params["k"]
    w = 2 * math.pi * params["f_n"]["q50"]
    lo, hi = ce.get("recorded_amplitude_range_m") or [params["u0"]["q50"] * 0.2,
                                                      params["u0"]["q50"]]
    verdict = summary["model_checks"]["verdict"]
    return {
        "status": "recommended" if verdict in ("adequate", "amplitude-dependent") else
        ("viscous-stands" if verdict == "inconclusive" else "none"),
        "verdict": verdict, "law": law, "force": "from damping_models",
        "coefficients": {n: {**params[n], "symbol": n} for n in COEFFICIENTS[law]},
        "mass": {"value": mass, "sd": summary["mass"].get("sd"), "unit": "kg"},
        "k": k, "f_n": params["f_n"],
        "measured_range": {"displacement_m": [lo, hi], "velocity_m_s": [w * lo, w * hi]},
        "design_amplitude": {"displacement_m": ce.get("amplitude_m", 0.5 * (lo + hi)),
                             "velocity_m_s": w * ce.get("amplitude_m", 0.5 * (lo + hi)),
                             "source": "middle of the measured range"},
        "c_linear": ce.get("c"), "zeta_linear": ce.get("zeta"),
        "linear_within_10pct_m": None, "reason": "test fixture from damping_models",
        "not_ruled_out": None, "try": None, "draws": None,
    }
