"""The damper a deck carries: the recommended law of summary.json's ``damper`` section, read,
checked and turned into each engine's elements (issue 32).

Laws (SI; v [m/s] the elongation rate of the damper, F [N] its force, positive in tension):

==========  ==========================  =====================================================
law         F(v)                        coefficients
==========  ==========================  =====================================================
viscous     c·v                         c [N·s/m]
coulomb     c·v + F_c·sgn(v)            c [N·s/m], F_c [N]
quadratic   c·v + c₂·v·|v|              c [N·s/m], c₂ [N·s²/m²]
power       c_α·|v|^α·sgn(v)            c_α [N·(s/m)^α], α [1]
==========  ==========================  =====================================================

Which damper is written (:func:`choose`):

* the ``damper`` section's law at its coefficients' medians (status "recommended" or
  "viscous-stands"; a viscous law at the ``--quantile`` of ``parameters.c``, as before);
* ``--law viscous``: a linear dashpot. Under a non-viscous verdict its c is ``c_linear`` — the
  energy-equivalent linear c of the recommended law at the design amplitude (Jacobsen 1930,
  c_eq = 2·m·ρ(A), :mod:`dampfit.model.laws` K2) — not the viscous posterior c: it is the
  linear dashpot that dissipates what the measured damper dissipates per cycle at that
  amplitude. The deck and stderr say that it is not the measured law;
* ``--force-law LAW``: LAW whatever the verdict (required under "none", a misfit), its
  coefficients' medians from ``damping_models.models.LAW.parameters``;
* a summary without a ``damper`` section (written before issue 32): the viscous posterior c,
  as before, with a note in the deck that no recommendation was read.

A nonlinear law's coefficients are medians: the quantiles of correlated coefficients taken one
by one are no damper (``--draws N`` carries the joint uncertainty), so ``--quantile`` other
than 0.5 is refused for them.

Every number reaches a deck only after :func:`dampfit.result.schema.number` (finite, in range);
every text only through :mod:`dampfit.fem.sanitize` by the writer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import InputError, shown
from dampfit.result.schema import brief, number

#: Coefficients of each law the decks write, with their SI units.
COEFFICIENTS: dict[str, dict[str, str]] = {
    "viscous": {"c": "N s/m"},
    "coulomb": {"c": "N s/m", "F_c": "N"},
    "quadratic": {"c": "N s/m", "c2": "N s^2/m^2"},
    "power": {"c_alpha": "N (s/m)^alpha", "alpha": "1"},
}
#: The force laws in plain ASCII (deck comments).
FORCE_TEXT = {"viscous": "F = c*v", "coulomb": "F = c*v + F_c*sgn(v)",
              "quadratic": "F = c*v + c2*v*|v|", "power": "F = c_alpha*|v|^alpha*sgn(v)",
              "measured": "F = sgn(v)*T(|v|), T piecewise linear through (0, 0) and the points "
                          "(v_j, F_j), its last slope continued"}
#: ``--law measured``: the curve fitted to the measured envelope (:mod:`dampfit.fem.measured`);
#: its coefficients are its points ``v_j`` [m/s], ``F_j`` [N] (j = 1, 2, …), checked by
#: :func:`points` (increasing v > 0, non-decreasing F ≥ 0: a monotone, passive damper).
MEASURED = "measured"
#: Allowed range of each coefficient (``number`` rules); α ∈ (0, 3] as the law's prior.
_RULES = {"c": {"nonnegative": True}, "F_c": {"nonnegative": True}, "c2": {"nonnegative": True},
          "c_alpha": {"positive": True}, "alpha": {"positive": True}}
STATUSES = ("recommended", "viscous-stands", "none")


@dataclass(frozen=True)
class Damper:
    """The damper a deck writes: ``law`` and its ``coefficients`` (SI medians), where it comes
    from and what the deck must say about it.

    ``status``/``verdict``/``recommended`` are the summary's (``None`` for a summary without a
    damper section); ``velocity_range`` and ``displacement_range`` [m/s, m] the measured
    amplitudes, ``design`` the design amplitude entry, ``c_linear`` the equivalent linear c
    entry (q05/q50/q95), ``k`` [N/m] the stiffness of the law's own posterior (the section's
    ``k.q50``; the deck's spring whenever the deck carries the law or its c_linear, so the
    deck, the damper section and the report give one k), ``notes`` the sentences every deck carries (warnings included) and
    ``warnings`` those also printed on stderr.
    """

    law: str
    coefficients: dict[str, float]
    status: str | None = None
    verdict: str | None = None
    recommended: str | None = None
    velocity_range: tuple[float, float] | None = None
    displacement_range: tuple[float, float] | None = None
    design: dict[str, Any] | None = None
    c_linear: dict[str, float] | None = None
    k: float | None = None
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = field(default=())

    @property
    def nonlinear(self) -> bool:
        """Whether the force is not proportional to the velocity."""
        return self.law != "viscous"

    def force(self, v):
        """F(v) [N] at velocity ``v`` [m/s] (NumPy, broadcasts)."""
        return force(self.law, self.coefficients, v)


def points(coeffs: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(v [m/s], F [N]) of a measured curve's ``coeffs`` (``v_1``, ``F_1``, …); InputError
    unless finite, v increasing from above 0 and F non-decreasing from 0 (monotone, passive)."""
    n = len(coeffs) // 2
    try:
        v = np.array([float(coeffs[f"v_{j}"]) for j in range(1, n + 1)])
        F = np.array([float(coeffs[f"F_{j}"]) for j in range(1, n + 1)])
    except (KeyError, TypeError, ValueError):
        raise InputError("the measured curve's points must be v_1, F_1, ..., v_n, F_n") from None
    ok = (n >= 1 and 2 * n == len(coeffs) and np.all(np.isfinite(v) & np.isfinite(F))
          and v[0] > 0 and np.all(np.diff(v) > 0) and F[0] >= 0 and np.all(np.diff(F) >= 0))
    if not ok:
        raise InputError("the measured curve's points are not a monotone, passive damper "
                         "(v increasing from above 0, F non-decreasing from 0, all finite)")
    return v, F


def unit(law: str, name: str) -> str:
    """The SI unit of coefficient ``name`` of ``law``."""
    if law == MEASURED:
        return "m/s" if name.startswith("v_") else "N"
    return COEFFICIENTS[law][name]


def force(law: str, coeffs: dict[str, float], v):
    """The damping force [N] of ``law`` with ``coeffs`` (SI) at velocity ``v`` [m/s]."""
    v = np.asarray(v, dtype=float)
    if law == MEASURED:
        from dampfit.damping.measured import table_force

        return table_force(v, *points(coeffs))
    if law == "viscous":
        return coeffs["c"] * v
    if law == "coulomb":
        return coeffs["c"] * v + coeffs["F_c"] * np.sign(v)
    if law == "quadratic":
        return coeffs["c"] * v + coeffs["c2"] * v * np.abs(v)
    if law == "power":
        return coeffs["c_alpha"] * np.abs(v) ** coeffs["alpha"] * np.sign(v)
    raise ValueError(f"unknown law {law!r}")


def scalar_force(law: str, coeffs: dict[str, float]):
    """:func:`force` as a function of one Python float [m/s] → [N], ~20× faster than the NumPy
    one on a scalar: the force of a step-by-step run (:func:`dampfit.damping.decay_run.free_run`):
    the measured curve's table here, a law's :func:`dampfit.damping.decay_run.scalar_force`.
    The same law term for term (a test compares the two on a grid of velocities)."""
    if law == MEASURED:
        import bisect

        v, F = points(coeffs)
        vv, FF = [0.0] + [float(x) for x in v], [0.0] + [float(x) for x in F]
        last = (FF[-1] - FF[-2]) / (vv[-1] - vv[-2])

        def table(x: float) -> float:
            u = abs(x)
            j = bisect.bisect_right(vv, u)
            f = (FF[-1] + (u - vv[-1]) * last if j >= len(vv)
                 else FF[j - 1] + (u - vv[j - 1]) * (FF[j] - FF[j - 1]) / (vv[j] - vv[j - 1]))
            return math.copysign(f, x) if x else 0.0

        return table
    from dampfit.damping.decay_run import scalar_force as law_force

    return law_force(law, coeffs)


def theta(law: str, coeffs: dict[str, float], mass: float, omega: float, a0: float) -> np.ndarray:
    """θ of :mod:`dampfit.model.laws` (ln p₀, shape, ln ω) for ``law`` with the SI ``coeffs``,
    ``mass`` [kg], ``omega`` [rad/s] and start amplitude ``a0`` [m]: the inverse of the laws'
    ``physical`` (K2: p_v = c/2m, p_c = 2F_c/(π·m·ω·a₀), p_q = 4c₂·ω·a₀/(3π·m),
    power p₀ = c_α·(ω·a₀)^(α−1)·λ(α)/(2π·m))."""
    from dampfit.model.laws import lam

    if law == "power":
        a = coeffs["alpha"]
        p0 = coeffs["c_alpha"] * (omega * a0) ** (a - 1.0) * float(lam(a)) / (2 * math.pi * mass)
        return np.array([math.log(p0), a, math.log(omega)])
    pv = coeffs["c"] / (2 * mass)
    if law == "viscous":
        return np.array([math.log(pv), math.log(omega)])
    extra = (2 * coeffs["F_c"] / (math.pi * mass * omega * a0) if law == "coulomb"
             else 4 * coeffs["c2"] * omega * a0 / (3 * math.pi * mass))
    p0 = pv + extra
    return np.array([math.log(p0), extra / p0, math.log(omega)])


def c_equivalent(law: str, coeffs: dict[str, float], omega: float, amplitude: float) -> float:
    """Energy-equivalent linear c [N·s/m] of the law at displacement ``amplitude`` [m] and
    ``omega`` [rad/s]: c_eq = 2·m·ρ(A) of (K2), which needs no mass (ρ·2m is the force's
    first harmonic over ω·A)."""
    from dampfit.model.laws import lam

    v = omega * amplitude
    if law == MEASURED:
        from dampfit.damping.measured import table_c_eq

        return float(table_c_eq(v, *points(coeffs))[0])
    if law == "viscous":
        return coeffs["c"]
    if law == "coulomb":
        return coeffs["c"] + 4 * coeffs["F_c"] / (math.pi * v)
    if law == "quadratic":
        return coeffs["c"] + 8 * coeffs["c2"] * v / (3 * math.pi)
    a = coeffs["alpha"]
    return coeffs["c_alpha"] * v ** (a - 1.0) * float(lam(a)) / math.pi


def zero_slope_velocity(dmp: Damper, v_lo: float, slope_max: float) -> float:
    """The smallest velocity [m/s] ≥ ``v_lo``/100 (doubling) at which the secant F(v)/v of the
    damper is at most ``slope_max`` [N·s/m]: the first point of a tabulated curve, so that the
    curve's steepest segment (through 0) stays a damping an explicit step can carry."""
    v = v_lo / 100.0
    for _ in range(200):
        if float(dmp.force(v)) / v <= slope_max:
            return v
        v *= 2.0
    raise InputError(f"the {dmp.law} damper is too stiff near zero velocity for the time step")


def _entry(value: Any, name: str, path: Path, **rules) -> dict[str, float]:
    """{q05, q50, q95} (q50 required) of a summary quantity, each checked."""
    if not isinstance(value, dict):
        raise InputError(f"{shown(path)}: {name} must be an object with q50, got {brief(value)}")
    out = {"q50": number(value.get("q50"), f"{name}.q50", path, **rules)}
    for q in ("q05", "q95"):
        if value.get(q) is not None:
            out[q] = number(value[q], f"{name}.{q}", path, **rules)
    return out


def _coefficients(law: str, entries: Any, where: str, path: Path) -> dict[str, float]:
    """The medians of ``law``'s coefficients from ``entries`` (a dict NAME → stats)."""
    if not isinstance(entries, dict):
        raise InputError(f"{shown(path)}: {where} must be an object, got {brief(entries)}")
    out = {}
    for name in COEFFICIENTS[law]:
        if entries.get(name) is None:
            raise InputError(f"{shown(path)}: {where} has no {name!r} for the {law} law")
        out[name] = _entry(entries[name], f"{where}.{name}", path, **_RULES[name])["q50"]
    if law == "power" and not out["alpha"] <= 3.0:
        raise InputError(f"{shown(path)}: {where}.alpha = {out['alpha']:g} is outside (0, 3]")
    return out


def _pair(value: Any, name: str, path: Path) -> tuple[float, float]:
    if not (isinstance(value, (list, tuple)) and len(value) == 2):
        raise InputError(f"{shown(path)}: {name} must be [low, high], got {brief(value)}")
    lo, hi = (number(x, name, path, positive=True) for x in value)
    if not hi >= lo:
        raise InputError(f"{shown(path)}: {name} = [{lo:g}, {hi:g}] is not [low, high]")
    return lo, hi


def _law_name(law: str | None, option: str) -> str | None:
    if law is not None and law not in COEFFICIENTS:
        raise InputError(f"{option} {law!r}: choose one of {', '.join(COEFFICIENTS)}")
    return law


def choose(summary: dict[str, Any], path: str | Path, law: str | None = None,
           force_law: str | None = None, viscous_c: float | None = None) -> Damper:
    """The damper the deck of ``summary`` (read from ``path``) writes (module docstring).

    ``law``: ``--law`` (``"viscous"`` forces a linear dashpot; the recommended law's name is
    the default itself); ``force_law``: ``--force-law``; ``viscous_c`` [N·s/m]: the viscous
    posterior c at the export's quantile (the linear dashpot of a viscous verdict and of an
    old summary). :class:`InputError` (one line) for a misfit without ``force_law``, a bad
    section or a law without coefficients.
    """
    path = Path(path)
    law, force_law = _law_name(law, "--law"), _law_name(force_law, "--force-law")
    if law is not None and force_law is not None:
        raise InputError("give --law or --force-law, not both")
    sec = summary.get("damper")
    if sec is None:
        return _legacy(summary, path, law, force_law, viscous_c)
    if not isinstance(sec, dict):
        raise InputError(f"{shown(path)}: damper must be an object, got {brief(sec)}")
    status = sec.get("status")
    if status not in STATUSES:
        raise InputError(f"{shown(path)}: damper.status must be one of {', '.join(STATUSES)}, "
                         f"got {brief(status)}")
    verdict = str(sec.get("verdict") or "unknown")
    rec = sec.get("law")
    if status != "none" and rec not in COEFFICIENTS:
        raise InputError(f"{shown(path)}: damper.law must be one of {', '.join(COEFFICIENTS)}, "
                         f"got {brief(rec)}")
    common = {"status": status, "verdict": verdict, "recommended": rec if status != "none"
              else None, **_ranges(sec, path, status)}
    if status == "none" and force_law is None:
        reason = " ".join(str(sec.get("reason") or "the damping laws do not fit").split())
        raise InputError(f"{shown(path)}: no damper is recommended (verdict {verdict}: "
                         f"{reason[:200]}); nothing exported; give --force-law LAW to write one "
                         "anyway")
    if force_law is not None:
        return _forced(summary, sec, path, force_law, viscous_c, common)
    if law is not None and law not in ("viscous", rec):
        raise InputError(f"--law {law}: the recommended damper is {rec}; --law viscous writes a "
                         f"linear dashpot, --force-law {law} writes the {law} law anyway")
    if rec == "viscous":
        c = viscous_c if viscous_c is not None else _coefficients(
            "viscous", sec.get("coefficients"), "damper.coefficients", path)["c"]
        notes = [f"Recommended damper: linear viscous (verdict {verdict}, status {status})."]
        if status == "viscous-stands" and sec.get("not_ruled_out"):
            notes.append("The recording could not rule out: "
                         + " ".join(str(sec["not_ruled_out"]).split())[:300])
        return Damper("viscous", {"c": c}, notes=tuple(notes), **common)
    if law == "viscous":
        if common["c_linear"] is None:
            raise InputError(f"{shown(path)}: damper.c_linear is missing; --law viscous needs it")
        c = common["c_linear"]["q50"]
        warn = (f"--law viscous: a linear dashpot c = {c:.6g} N*s/m, the equivalent linear c of "
                f"the measured {rec} law at the design amplitude only; the verdict is {verdict} "
                f"and the recording supports the {rec} law, not this dashpot.")
        return Damper("viscous", {"c": c}, notes=(warn,), warnings=(warn,), **common)
    coeffs = _coefficients(rec, sec.get("coefficients"), "damper.coefficients", path)
    note = f"Recommended damper: the {rec} law {FORCE_TEXT[rec]} (verdict {verdict})."
    return Damper(rec, coeffs, notes=(note,), **common)


def _ranges(sec: dict[str, Any], path: Path, status: str) -> dict[str, Any]:
    """Measured ranges, design amplitude and c_linear of the section (None where absent)."""
    out: dict[str, Any] = {"velocity_range": None, "displacement_range": None, "design": None,
                           "c_linear": None, "k": None}
    mr = sec.get("measured_range")
    if isinstance(mr, dict):
        if mr.get("velocity_m_s") is not None:
            out["velocity_range"] = _pair(mr["velocity_m_s"], "damper.measured_range."
                                          "velocity_m_s", path)
        if mr.get("displacement_m") is not None:
            out["displacement_range"] = _pair(mr["displacement_m"], "damper.measured_range."
                                              "displacement_m", path)
    d = sec.get("design_amplitude")
    if isinstance(d, dict) and d.get("displacement_m") is not None:
        out["design"] = {"displacement_m": number(d["displacement_m"], "damper.design_amplitude."
                                                  "displacement_m", path, positive=True),
                         "source": " ".join(str(d.get("source") or "?").split())[:80]}
    if sec.get("c_linear") is not None:
        out["c_linear"] = _entry(sec["c_linear"], "damper.c_linear", path, nonnegative=True)
    if sec.get("k") is not None:
        out["k"] = _entry(sec["k"], "damper.k", path, positive=True)["q50"]
    return out


def _forced(summary, sec, path, law, viscous_c, common) -> Damper:
    """``--force-law LAW``: the coefficients of LAW, whatever the verdict."""
    rec = common["recommended"]
    if law == rec:
        coeffs = (_coefficients(law, sec.get("coefficients"), "damper.coefficients", path)
                  if law != "viscous" or viscous_c is None else {"c": viscous_c})
    elif law == "viscous" and viscous_c is not None:
        coeffs = {"c": viscous_c}
        common = {**common, "k": None}  # the viscous posterior's c with its own k
    else:
        models = (summary.get("damping_models") or {}).get("models") or {}
        if not isinstance(models, dict) or not isinstance(models.get(law), dict):
            raise InputError(f"{shown(path)} has no fitted {law} law (damping_models.models."
                             f"{law}); --force-law {law} cannot write it")
        coeffs = _coefficients(law, models[law].get("parameters"),
                               f"damping_models.models.{law}.parameters", path)
        k = (models[law].get("parameters") or {}).get("k")  # that law's own k, not the section's
        common = {**common, "k": None if k is None else _entry(
            k, f"damping_models.models.{law}.parameters.k", path, positive=True)["q50"]}
    warn = (f"--force-law {law}: the {law} law is written although the verdict is "
            f"{common['verdict']}" + (f" and the recommended damper is {rec}" if rec else
                                      " and no damper is recommended") + ".")
    notes = (warn,) if law != rec else (f"--force-law {law}: the recommended law.",)
    return Damper(law, coeffs, notes=notes, warnings=notes if law != rec else (), **common)


def _legacy(summary, path, law, force_law, viscous_c) -> Damper:
    """A summary without a damper section: the viscous posterior c, with a note."""
    if (force_law or law or "viscous") != "viscous":
        raise InputError(f"{shown(path)} has no damper section (written before dampfit "
                         "recommended a damper); re-run 'dampfit analyze' to export another law")
    if viscous_c is None:
        raise InputError(f"{shown(path)} has no damper section and no viscous c")
    if summary.get("kind") == "campaign":
        note = ("A campaign recommends no damping law: the population's viscous c is written "
                "(check each test's verdict before using a linear dashpot).")
    else:
        note = ("summary.json has no damper section (written before dampfit recommended a "
                "damper): the viscous posterior c is written, with no check of the damping "
                "law; re-run 'dampfit analyze' for the recommended damper.")
    return Damper("viscous", {"c": viscous_c}, verdict=_verdict(summary), notes=(note,))


def _verdict(summary: dict[str, Any]) -> str | None:
    mc = summary.get("model_checks")
    v = mc.get("verdict") if isinstance(mc, dict) else None
    return v if isinstance(v, str) else None


def describe(dmp: Damper, command: str | None = None) -> list[str]:
    """The header sentences of every deck (plain text; each writer sanitises them): the
    verdict, the law and its coefficients, the measured amplitude range, the notes and the
    command that wrote the deck."""
    coeffs = ", ".join(f"{k} = {v:.6g} {unit(dmp.law, k)}" for k, v in dmp.coefficients.items())
    what = ("fitted to the measured envelope" if dmp.law == MEASURED else "posterior medians")
    lines = [f"Damper: {dmp.law} law {FORCE_TEXT[dmp.law]}; {coeffs} (SI, {what}); "
             f"verdict {dmp.verdict or 'not recorded'}"
             + (f", recommended law {dmp.recommended}" if dmp.recommended else "") + "."]
    if dmp.displacement_range or dmp.velocity_range:
        parts = []
        if dmp.displacement_range:
            parts.append("displacement amplitude %.4g to %.4g m" % dmp.displacement_range)
        if dmp.velocity_range:
            parts.append("velocity amplitude %.4g to %.4g m/s" % dmp.velocity_range)
        lines.append("Measured over: " + ", ".join(parts) + "; outside it the law is "
                     "extrapolated.")
    if dmp.design and dmp.c_linear:
        lines.append(f"Equivalent linear c at the design amplitude {dmp.design['displacement_m']:.4g}"
                     f" m ({dmp.design['source']}): {dmp.c_linear['q50']:.6g} N*s/m.")
    lines += list(dmp.notes)
    lines.append(f"Written by: {command or 'dampfit.fem.export.export (Python)'}")
    return lines


#: How far a tabulated force–velocity curve reaches beyond the fastest measured velocity [1].
TABLE_REACH = 5.0
#: Points of a tabulated curve on each side of zero.
TABLE_POINTS = 48


def table(dmp: Damper, v_range: tuple[float, float], slope_max: float) -> dict[str, Any]:
    """The force–velocity table of ``dmp`` (SI) for a ``*DEFINE_CURVE``: symmetric, through
    (0, 0), from −``TABLE_REACH``·v_hi to +``TABLE_REACH``·v_hi with ``TABLE_POINTS`` points a
    side spaced geometrically from v₁ (:func:`zero_slope_velocity`: the secant F(v₁)/v₁ ≤
    ``slope_max`` [N·s/m], so the segment through zero, a linear ramp, is a damping the
    deck's time step carries; for Coulomb friction it is the regularised jump) and holding
    the measured ends v_lo, v_hi (and a measured curve's points) exactly.

    Returns ``{"v", "F"`` (arrays, increasing v), ``"v1"``, ``"v_top"``, ``"measured"``}``."""
    v_lo, v_hi = v_range
    v1 = zero_slope_velocity(dmp, v_lo, slope_max)
    top = TABLE_REACH * v_hi
    knots = list(points(dmp.coefficients)[0]) if dmp.law == MEASURED else []
    ends = [x for x in (v_lo, v_hi, *knots) if x > v1]
    pos = np.unique(np.concatenate([np.geomspace(v1, top, TABLE_POINTS - len(ends)), ends]))
    v = np.concatenate([-pos[::-1], [0.0], pos])
    return {"v": v, "F": dmp.force(v), "v1": float(v1), "v_top": float(top),
            "measured": (float(v_lo), float(v_hi))}


#: Stick stiffness of the OpenSees friction element, a multiple of the spring's k [1].
STICK_FACTOR = 1000.0
#: Script constant names of the coefficients (``c`` stays the dashpot / the linear c).
_SCRIPT_NAME = {"c": "law_c", "F_c": "law_F_c", "c2": "law_c2", "c_alpha": "law_c_alpha",
                "alpha": "law_alpha"}


def deck_coefficients(dmp: Damper, units) -> dict[str, float]:
    """The coefficients of ``dmp`` in ``units`` (c [F·T/L], F_c [F], c₂ [F·(T/L)²],
    c_α [F·(T/L)^α], α [1]), each checked finite."""
    from dampfit.fem.units import factor

    F, V = factor("force", units), factor("velocity", units)
    alpha = dmp.coefficients.get("alpha", 1.0)
    conv = {"c": F / V, "F_c": F, "c2": F / V**2, "c_alpha": F / V**alpha, "alpha": 1.0}
    if dmp.law == MEASURED:
        conv = {name: V if name.startswith("v_") else F for name in dmp.coefficients}
    out = {k: float(v * conv[k]) for k, v in dmp.coefficients.items()}
    for k, v in out.items():
        if not math.isfinite(v):
            raise InputError(f"the damper's {k} = {v!r} in {units.name} units is not finite")
    return out


def opensees_fields(dmp: Damper | None, units, k: float) -> dict[str, str]:
    """The insertions of the OpenSees script (:func:`dampfit.fem.opensees.script`) for the
    damper ``dmp`` in ``units`` (``k`` the spring in those units):

    * viscous — ``uniaxialMaterial Viscous 2 c 1.0`` (force c·v);
    * power — ``Viscous 2 c_alpha alpha`` (OpenSees' ViscousMaterial: σ = C·|ε̇|^α·sgn ε̇,
      damping tangent α·C·|ε̇|^(α−1) floored at minVel = 1e-11);
    * quadratic — ``Parallel 2`` of ``Viscous 11 c 1`` and ``Viscous 12 c2 2``
      (σ = c·v + c₂·v·|v|);
    * coulomb — ``Parallel 2`` of ``Viscous 11 c 1`` and ``ElasticPP 12 k_s F_c/k_s −F_c/k_s
      u_start``: a rigid-plastic friction element approximated by a stick stiffness
      k_s = :data:`STICK_FACTOR`·k that slides at ±F_c. Its approximation: after each velocity
      reversal it sticks over 2·F_c/k_s (a 1/STICK_FACTOR fraction of the friction's
      amplitude loss 2·F_c/k per half cycle) and the stiffness there is k + k_s; it starts
      unstrained at the start displacement (ε₀ = u_start), i.e. with no friction at rest.

    A nonlinear law runs with Newton iterations (the test on the displacement increment
    relative to the start displacement)."""
    if dmp is None or not dmp.nonlinear:
        return {"damper_doc": "", "damper_model": "a Viscous (c, alpha = 1) material",
                "c_comment": "viscous damping", "damper_values": "",
                "damper_materials": 'ops.uniaxialMaterial("Viscous", 2, c, 1.0)  '
                                    '# force = c * velocity**1\n',
                "force_def": "", "force_at_start": "c * args.v_start"}
    vals = deck_coefficients(dmp, units)
    if dmp.law == MEASURED:
        return _measured_fields(dmp, vals)
    values = "".join(f"{_SCRIPT_NAME[n]} = {v!r}  # {n} of the {dmp.law} law\n"
                     for n, v in vals.items())
    sgn = "((v > 0) - (v < 0))"
    expr = {"coulomb": f"law_c * v + law_F_c * {sgn}",
            "quadratic": "law_c * v + law_c2 * v * abs(v)",
            "power": f"law_c_alpha * abs(v) ** law_alpha * {sgn}"}[dmp.law]
    if dmp.law == "power":
        mats = ('ops.uniaxialMaterial("Viscous", 2, law_c_alpha, law_alpha)  '
                '# force = c_alpha * |v|**alpha * sgn(v)\n')
        model = "a Viscous (c_alpha, alpha) material"
    elif dmp.law == "quadratic":
        mats = ('ops.uniaxialMaterial("Viscous", 11, law_c, 1.0)  # c * v\n'
                'ops.uniaxialMaterial("Viscous", 12, law_c2, 2.0)  # c2 * |v|**2 * sgn(v)\n'
                'ops.uniaxialMaterial("Parallel", 2, 11, 12)  # their sum\n')
        model = "a Parallel material (Viscous c, alpha = 1 and Viscous c2, alpha = 2)"
    else:
        values += f"k_stick = {STICK_FACTOR!r} * k  # stick stiffness of the friction element\n"
        mats = ('ops.uniaxialMaterial("Viscous", 11, law_c, 1.0)  # c * v\n'
                'ops.uniaxialMaterial("ElasticPP", 12, k_stick, law_F_c / k_stick, '
                '-law_F_c / k_stick, args.u_start)  # friction +-F_c, unstrained at the start\n'
                'ops.uniaxialMaterial("Parallel", 2, 11, 12)  # their sum\n')
        model = ("a Parallel material (Viscous c, alpha = 1 and an ElasticPP friction element: "
                 f"stick stiffness k_stick = {STICK_FACTOR:g}*k, sliding at +-F_c; it sticks over "
                 "2*F_c/k_stick after each reversal, an approximation of Coulomb friction)")
    return {"damper_doc": "", "damper_model": model,
            "c_comment": "equivalent linear c at the design amplitude (not in the model)",
            "damper_values": values, "damper_materials": mats,
            "force_at_start": "damper_force(args.v_start)",
            "force_def": (f"\n\ndef damper_force(v):\n    \"\"\"The damper's force at velocity v "
                          f"(script units): {FORCE_TEXT[dmp.law]}.\"\"\"\n    return {expr}\n\n")}


def _measured_fields(dmp: Damper, vals: dict[str, float]) -> dict[str, str]:
    """:func:`opensees_fields` of a measured curve: ``uniaxialMaterial Damper 2 3`` wrapping
    ``ElasticMultiLinear 3`` of its points, mirrored through (0, 0) (OpenSees' DamperMaterial
    hands the strain rate to the wrapped material as its strain and uses its tangent as the
    damping tangent; ElasticMultiLinear interpolates its points and continues its end
    segments: the table's last slope, as in the fit)."""
    n = len(vals) // 2
    v = [vals[f"v_{j}"] for j in range(1, n + 1)]
    F = [vals[f"F_{j}"] for j in range(1, n + 1)]
    values = (f"law_v = {v!r}  # velocities of the measured curve's points\n"
              f"law_F = {F!r}  # its force at those velocities (through 0; last slope continued)\n")
    mats = ('ops.uniaxialMaterial("ElasticMultiLinear", 3, "-strain", '
            '*[-x for x in reversed(law_v)], 0.0, *law_v, "-stress", '
            '*[-f for f in reversed(law_F)], 0.0, *law_F)  # F(v): the table, mirrored\n'
            'ops.uniaxialMaterial("Damper", 2, 3)  # material 3 of the strain rate: a damper\n')
    body = ("    u, pv, pf = abs(v), [0.0] + law_v, [0.0] + law_F\n"
            "    j = 0\n"
            "    while j < len(pv) - 2 and u >= pv[j + 1]:  # the segment of u (the last beyond)\n"
            "        j += 1\n"
            "    f = pf[j] + (pf[j + 1] - pf[j]) / (pv[j + 1] - pv[j]) * (u - pv[j])\n"
            "    return f * ((v > 0) - (v < 0))\n")
    return {"damper_doc": "", "damper_values": values, "damper_materials": mats,
            "damper_model": f"a Damper material wrapping an ElasticMultiLinear of the {n} "
                            "points of the curve fitted to the measured envelope (mirrored)",
            "c_comment": "equivalent linear c at the design amplitude (not in the model)",
            "force_at_start": "damper_force(args.v_start)",
            "force_def": (f"\n\ndef damper_force(v):\n    \"\"\"The damper's force at velocity v "
                          f"(script units): {FORCE_TEXT[MEASURED]}.\"\"\"\n{body}\n")}
