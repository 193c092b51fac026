"""The deck of the measured damper curve (issue 32): ``dampfit export DIR --law measured``, and
the plain export's deck where the recommended law misses the decay (:func:`default_damper`).

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



def _interior(folder: Path, summary: dict[str, Any], sdof):
    """(t [s], |a|/ω_n² [m], start [s], stop [s]) of result ``folder``'s ``signals.npz``:
    the displacement amplitude read from the measured acceleration, and the interior verify
    compares (without the :data:`EDGE_PERIODS` periods at each end where the band-pass
    filters settle). :class:`InputError` without usable signals."""
    from dampfit.result.folder import load_signals

    sig = load_signals(folder, summary=summary)
    w = sdof.omega_n
    edge = EDGE_PERIODS * 2 * math.pi / w
    return sig["t"], sig["accel"] / w ** 2, sig["t"][0] + edge, sig["t"][-1] - edge


def _peaks(folder: Path, summary: dict[str, Any], sdof) -> tuple[Any, Any]:
    """Times [s] and displacement amplitudes [m] of the measured peaks of the interior
    (:func:`_interior`)."""
    from dampfit.fem import response

    return response.envelope(*_interior(folder, summary, sdof))


def measured_damper(folder: Path, summary: dict[str, Any], base: damper_mod.Damper, sdof,
                    seed: int = 0, *, peaks=None,
                    why: str = "--law measured") -> damper_mod.Damper:
    """The measured curve of result ``folder`` as a deck's damper, beside the recommended
    ``base`` damper (its verdict, ranges and design amplitude) on the system ``sdof`` (the
    damper section's k, the weighed mass). ``peaks`` (:func:`_peaks`) when already at hand;
    ``why`` says in the deck why the curve was written.
    :class:`InputError` without usable signals or peaks."""
    if base.status is None:
        raise InputError(f"{shown(folder / 'summary.json')} has no damper section; re-run "
                         "'dampfit analyze' for --law measured")
    from dampfit.damping import measured

    tp, ap = peaks if peaks is not None else _peaks(folder, summary, sdof)
    try:
        curve = measured.fit(tp, ap, sdof.omega_n, sdof.mass,
                             float(sdof.source.get("mass_sd") or 0.0), seed=seed)
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
    note = (f"Measured damper curve ({why}), not the recommended {base.recommended} "
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


def default_damper(folder: Path, summary: dict[str, Any], base: damper_mod.Damper, sdof,
                   seed: int = 0) -> damper_mod.Damper:
    """The damper a plain ``dampfit export`` writes when a nonlinear law is recommended
    (``base``): the law, unless the recording shows that its two coefficients miss the
    measured decay — then the measured curve (:func:`measured_damper`), said in the deck and
    on stderr, with ``--law LAW`` to write the law instead.

    The test is verify's, run without an FEM engine (:func:`dampfit.damping.decay_run.check`):
    the law's free decay
    (:func:`dampfit.fem.response.free_run`, the deck's system: the damper section's k and the
    weighed mass) released at the first measured peak of the interior (:func:`_peaks`) at
    the measured trend's amplitude there, its |a|/ω_n² against the measured one by
    :func:`dampfit.fem.response.log_envelope_error` — rms of ln A_run − T about the trend T
    of the measured peaks (quadratic Savitzky–Golay over
    :data:`~dampfit.fem.response.TREND_PEAKS` peaks) against the measurement's own scatter
    rms(ln P − T). Within the scatter, or within
    :data:`~dampfit.damping.decay_run.LAW_TOLERANCE`, the law is written (no
    envelope can come closer than a peak's noise, response.py). Beyond it the measured curve
    is fitted to the same peaks and run likewise, and it is written only if it comes closer
    than the law. Every outcome leaves its numbers in the deck; without signals, or with too
    few peaks for a trend, the law is written and the note says it was not checked. Both
    runs are simulated the same way as the measurement is read (|a|/ω_n² at the extrema of
    a = −(k·u + F(u̇))/m), so the check has no error of its own beyond the step's: an
    averaged-envelope check instead (model/laws.py K2) called exact simulations of each law
    a miss (0.05–0.2 % against scatters of 0.003–0.1 %: the averaging and the peaks' offset
    by F/k that the curve, fitted to those peaks, absorbs)."""
    import dataclasses

    from dampfit.damping import decay_run

    law = base.law

    def with_note(dmp, text, warn=False):
        return dataclasses.replace(dmp, notes=dmp.notes + (text,),
                                   warnings=dmp.warnings + ((text,) if warn else ()))

    try:
        t, y, start, stop = _interior(folder, summary, sdof)
    except InputError as exc:
        return with_note(base, f"The {law} law was not checked against the measured envelope "
                               f"({exc}).")

    def judged(dmp):
        return decay_run.check(t, y, damper_mod.scalar_force(dmp.law, dmp.coefficients),
                               sdof.k, sdof.mass)

    try:
        law_env = judged(base)
    except ValueError as exc:
        return with_note(base, f"The {law} law was not checked against the measured envelope: "
                               f"{exc}.")
    scatter, law_rms = law_env["scatter"], law_env["rms_vs_trend"]
    facts = (f"{law_env['n_peaks']} peaks: the {law} law's run lies {100 * law_rms:.2g} % "
             f"(rms of ln|u|) from the measured trend, the measurement scatters "
             f"{100 * scatter:.2g} % about it")
    if law_env["follows"]:
        return with_note(base, f"The {law} law follows the measured envelope ({facts}).")
    try:
        dmp = measured_damper(folder, summary, base, sdof, seed,
                              peaks=decay_run.envelope(t, y, start, stop),
                              why="written by default: the recommended law misses the "
                                  "measured decay")
    except InputError as exc:
        return with_note(base, f"The {law} law misses the measured envelope ({facts}); no "
                               f"measured curve could replace it ({exc}).", warn=True)
    curve_rms = judged(dmp)["rms_vs_trend"]
    if curve_rms >= law_rms:
        return with_note(base, f"The {law} law misses the measured envelope ({facts}); the "
                               f"measured curve comes no closer ({100 * curve_rms:.2g} %).",
                         warn=True)
    text = (f"This deck is the measured damper curve, not the recommended {law} law: {facts}; "
            f"the curve's run lies {100 * curve_rms:.2g} % from it.{_c_eq_words(dmp, base)} "
            f"--law {law} writes the {law} law instead.")
    return with_note(dmp, text, warn=True)


def _c_eq_words(curve: damper_mod.Damper, law: damper_mod.Damper) -> str:
    """The two equivalent linear c at the design amplitude, the curve's and the law's (the
    analysis's headline), so that a reader of the deck sees how far the curve moved it."""
    a_c, a_l = ((d.design or {}).get("displacement_m") for d in (curve, law))
    if not (curve.c_linear and law.c_linear and a_c and a_l and math.isclose(a_c, a_l)):
        return ""
    return (f" At the design amplitude {a_c:.4g} m its equivalent linear c is "
            f"{curve.c_linear['q50']:.4g} N*s/m, the {law.law} law's (the analysis's "
            f"headline) {law.c_linear['q50']:.4g} N*s/m.")
