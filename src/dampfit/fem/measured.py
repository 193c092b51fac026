"""``dampfit export DIR --law measured``: the deck of the measured damper curve (issue 32).

The recommended law (summary.json's ``damper``: the headline, with its coefficients'
posterior) has two coefficients; where the recording's ζ(A) has more shape than that, its
deck's envelope misses the measured one by more than the measurement's scatter (verify says
by how much). ``--law measured`` writes instead the force–velocity curve fitted to the
measured envelope of the result folder's ``signals.npz`` (its peaks without the three
periods at each end where the band-pass filters settle, the interior verify compares) (:mod:`dampfit.damping.measured`:
F(v) = Σ b_j·|v|^a_j·sgn v, b_j ≥ 0, the averaged decay least squares against the peaks of
|a|/ω_n², the envelope verify compares): LS-DYNA its ``*DEFINE_CURVE`` table, OpenSees a
``Parallel`` of ``Viscous b_j a_j``, CalculiX its equivalent linear c at the design
amplitude. The deck states that it is the measured curve, not the recommended law, its fit
over the measured range (extrapolated outside it), the fit's rms against the peaks and the
equivalent linear c at the design amplitude with the bootstrap's 90 % interval.

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

#: A term is written when it carries at least this part of c_eq at an end of the range [1]
#: (the bounded least squares leaves vanishing ones, ~1e-12 of the others, inside its bounds).
MIN_SHARE = 1e-4


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
    import numpy as np

    share = measured.term_rates(np.array(curve.amplitude_range), w, sdof.mass,
                                curve.exponents) * curve.b  # each term's part of ρ at lo, hi
    keep = np.max(share / share.sum(axis=1, keepdims=True), axis=0) >= MIN_SHARE
    coeffs = {f"c_{a:g}": float(b) for a, b, k in zip(curve.exponents, curve.b, keep) if k}
    if not coeffs:
        raise InputError("--law measured: the fit left no damping term (the envelope does not "
                         "decay)")
    a_d = (base.design or {}).get("displacement_m") or math.sqrt(
        curve.amplitude_range[0] * curve.amplitude_range[1])
    ci = curve.interval(a_d)
    lo, hi = curve.amplitude_range
    note = (f"Measured damper curve (--law measured), not the recommended {base.recommended} "
            f"law: F(v) = sum of {len(coeffs)} terms c_a*|v|^a*sgn(v), b >= 0, fitted to the "
            f"measured envelope (averaged decay, {tp.size} peaks; rms {100 * curve.rms:.3g} % "
            f"of ln|u| against the peaks) over displacement amplitudes {lo:.4g} to {hi:.4g} m "
            f"(velocities {curve.velocity_range[0]:.4g} to {curve.velocity_range[1]:.4g} m/s); "
            "outside it the curve is extrapolated. Equivalent linear c at the design "
            f"amplitude {a_d:.4g} m: {ci['q50']:.6g} N*s/m, 90 % [{ci['q05']:.6g}, "
            f"{ci['q95']:.6g}] (moving-block bootstrap of the peaks' residuals and the mass).")
    return dataclasses.replace(
        base, law=damper_mod.MEASURED, coefficients=coeffs,
        velocity_range=curve.velocity_range, displacement_range=curve.amplitude_range,
        design={"displacement_m": a_d, "source": (base.design or {}).get(
            "source", "middle of the measured range")},
        c_linear={"q05": ci["q05"], "q50": ci["q50"], "q95": ci["q95"]},
        notes=(note,), warnings=())
