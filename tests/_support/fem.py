"""Hand-made result folders for the FEM hand-off (``export``, ``verify``) and the hostile cases
that read a result folder: a ``summary.json`` alone, or a whole result with ``signals.npz``."""

from __future__ import annotations

import json

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
