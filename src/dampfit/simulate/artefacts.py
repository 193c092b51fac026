"""What a simulation leaves behind besides the samples: the truth of a recording
(:func:`recording_truth`, JSON-safe), the envelope it implies (:func:`envelope_at`), and the
writers of the CSV and truth files (:func:`write_phyphox_csv`, :func:`write_truth`, from
:mod:`dampfit.files.writers`, re-exported here).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from dampfit._meta import __version__
from dampfit.files.writers import DIALECTS, write_phyphox_csv, write_truth  # re-exported
from dampfit.physics import quantities, to_decay
from dampfit.simulate.config import SimulationConfig, noise_sigma


def recording_truth(cfg: SimulationConfig, t_catch: float | None, direction: np.ndarray) -> dict[str, Any]:
    """JSON-safe truth of ``cfg`` (the catch at ``t_catch`` [s] or None, the unit motion
    ``direction`` in the phone frame): what :func:`dampfit.simulate.recording` returns."""
    p, omega_d = to_decay(cfg.c, cfg.k, cfg.mass)
    with np.errstate(divide="ignore"):  # Q = 1/(2ζ) is infinite for c = 0; it is not reported
        derived = {name: float(v) for name, v in quantities(p, omega_d, cfg.mass).items()}
    config = {k: v.item() if isinstance(v, np.generic) else v for k, v in dataclasses.asdict(cfg).items()}
    config["bias"] = list(cfg.bias)
    extra = {}
    if cfg.modes:  # the one-mode truth stays as it was
        config["modes"] = [list(m) for m in cfg.modes]
        extra["modes"] = modes_truth(cfg, derived, float(omega_d))
    else:
        config.pop("modes")
    return {
        "mass": float(cfg.mass),
        "c": float(cfg.c),
        "k": float(cfg.k),
        "u0": float(cfg.u0),
        "zeta": derived["zeta"],
        "f_n": derived["f_n"],
        "f_d": derived["f_d"],
        "p": derived["p"],
        "omega_n": derived["omega_n"],
        "omega_d": float(omega_d),
        "delta": derived["delta"],
        "envelope_amplitude": float(cfg.u0 * derived["omega_n"] / omega_d),
        "phase": float(math.atan2(derived["p"], omega_d)),
        "t_release": float(cfg.handheld),
        "t_catch": t_catch,
        "direction": [float(x) for x in direction],
        "noise_sigma": noise_sigma(cfg),
        "config": config,
        "dampfit_version": __version__,
    } | extra


def modes_truth(cfg: SimulationConfig, primary: dict[str, float], omega_d: float) -> list[dict[str, Any]]:
    """Truth of every mode of ``cfg``, the primary (m, k, c) one first: f_n, f_d [Hz], ζ [1],
    p [1/s], ω_n, ω_d [rad/s], acceleration envelope amplitude at release [m/s²], phase [rad]
    (None for the primary, whose phase follows from the release at rest)."""
    a1 = cfg.u0 * primary["omega_n"] ** 3 / omega_d
    out = [{"f_n": primary["f_n"], "f_d": primary["f_d"], "zeta": primary["zeta"],
            "p": primary["p"], "omega_n": primary["omega_n"], "omega_d": omega_d,
            "accel_amplitude": a1, "phase": None, "primary": True}]
    for f_n, zeta, ratio, phase in cfg.modes:
        wn = 2.0 * math.pi * f_n
        wd = wn * math.sqrt(1.0 - zeta**2)
        out.append({"f_n": f_n, "f_d": wd / (2.0 * math.pi), "zeta": zeta, "p": zeta * wn,
                    "omega_n": wn, "omega_d": wd, "accel_amplitude": ratio * a1,
                    "phase": phase, "primary": False})
    return out


def envelope_at(truth: dict[str, Any], t) -> float | np.ndarray:
    """Displacement envelope ``U·e^{−p(t − t_release)}`` [m] at time ``t`` [s] (valid between release and catch)."""
    elapsed = np.asarray(t, dtype=float) - truth["t_release"]
    env = truth["envelope_amplitude"] * np.exp(-truth["p"] * elapsed)
    return float(env) if np.ndim(env) == 0 else env
