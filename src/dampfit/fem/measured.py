"""``dampfit export DIR --law measured``: the deck of the measured damper curve (issue 32).

The recommended law (summary.json's ``damper``: the headline, with its coefficients'
posterior) has two coefficients; where the recording's ζ(A) has more shape than that, its
deck's envelope misses the measured one by more than the measurement's scatter (verify says
by how much). ``--law measured`` writes instead the force–velocity curve fitted to the
measured envelope of the result folder's ``signals.npz`` (its peaks of |a|/ω_n² without the
three periods at each end where the band-pass filters settle: the interior verify compares)
— :mod:`dampfit.damping.measured`'s table: F(v) piecewise linear in |v| through (0, 0) with
non-negative slopes on knots at the quantiles of the measured velocity amplitudes, below the
slowest one a linear slope and above the fastest knot the last slope continued (monotone and
passive at every velocity). LS-DYNA gets its ``*DEFINE_CURVE`` table, OpenSees a ``Damper``
material wrapping an ``ElasticMultiLinear`` of its points, CalculiX its equivalent linear c
at the design amplitude. The deck states that it is the measured curve, not the recommended
law, its fit over the measured range (and how it is extrapolated outside it), the fit's rms
against the peaks and the equivalent linear c at the design amplitude with the bootstrap's
90 % interval.

ω_n is the damper section's (its k and the weighed mass), the same as the deck's spring.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from dampfit.errors import InputError, shown
from dampfit.fem import damper as damper_mod
from dampfit.fem.response import EDGE_PERIODS


def measured_damper(folder: Path, summary: dict[str, Any], base: damper_mod.Damper, sdof,
                    seed: int = 0) -> damper_mod.Damper:
    """The measured curve of result ``folder`` as a deck's damper, beside the recommended
    ``base`` damper (its verdict, ranges and design amplitude) on the system ``sdof`` (the
    damper section's k, the weighed mass). :class:`InputError` without usable signals or
    peaks."""
    from dampfit.damping import measured
    from dampfit.fem import response
    from dampfit.result.folder import load_signals

    if base.status is None:
        raise InputError(f"{shown(folder / 'summary.json')} has no damper section; re-run "
                         "'dampfit analyze' for --law measured")
    sig = load_signals(folder, summary=summary)
    w = sdof.omega_n
    edge = EDGE_PERIODS * 2 * math.pi / w  # the interior verify compares (filters settled)
    tp, ap = response.envelope(sig["t"], sig["accel"] / w ** 2, sig["t"][0] + edge,
                               sig["t"][-1] - edge)
    try:
        curve = measured.fit(tp, ap, w, sdof.mass, float(sdof.source.get("mass_sd") or 0.0),
                             seed=seed)
    except ValueError as exc:
        raise InputError(f"--law measured: {exc}") from None
    v, F = curve.basis.points(curve.b)
    if not F[-1] > 0:
        raise InputError("--law measured: the fit left no damping (the envelope does not "
                         "decay)")
    coeffs = {}
    for j, (vj, fj) in enumerate(zip(v, F), start=1):
        coeffs[f"v_{j}"], coeffs[f"F_{j}"] = float(vj), float(fj)
    damper_mod.points(coeffs)  # monotone and passive by construction: checked all the same
    a_d = (base.design or {}).get("displacement_m") or math.sqrt(
        curve.amplitude_range[0] * curve.amplitude_range[1])
    ci = curve.interval(a_d)
    lo, hi = curve.amplitude_range
    note = (f"Measured damper curve (--law measured), not the recommended {base.recommended} "
            f"law: F(v) piecewise linear in |v| through (0, 0) and {len(v)} points, slopes "
            f">= 0 (monotone, passive), fitted to the measured envelope (averaged decay, "
            f"{tp.size} peaks; rms {100 * curve.rms:.3g} % of ln|u| against the peaks) over "
            f"displacement amplitudes {lo:.4g} to {hi:.4g} m (velocities "
            f"{curve.velocity_range[0]:.4g} to {curve.velocity_range[1]:.4g} m/s); below "
            f"{v[0]:.4g} m/s it is one linear slope, above {v[-1]:.4g} m/s its last slope "
            "continued (extrapolated, not measured). Equivalent linear c at the design "
            f"amplitude {a_d:.4g} m: {ci['q50']:.6g} N*s/m, 90 % [{ci['q05']:.6g}, "
            f"{ci['q95']:.6g}] (moving-block bootstrap of the peaks' residuals and the mass).")
    return dataclasses.replace(
        base, law=damper_mod.MEASURED, coefficients=coeffs,
        velocity_range=curve.velocity_range, displacement_range=curve.amplitude_range,
        design={"displacement_m": a_d, "source": (base.design or {}).get(
            "source", "middle of the measured range")},
        c_linear={"q05": ci["q05"], "q50": ci["q50"], "q95": ci["q95"]},
        notes=(note,), warnings=())
