"""Modal damping of several measured modes for the FEM decks (issue 21): Rayleigh α, β and
per-mode ζ, read from a summary and written into each format.

A recording with K ≥ 2 modes (``dampfit analyze --max-modes``) gives every mode's natural
frequency f_i [Hz] and damping ratio ζ_i [1], and the Rayleigh coefficients that reproduce
them, ζ(ω) = α/(2ω) + β·ω/2 with α [1/s] (mass-proportional) and β [s]
(stiffness-proportional; Chopra, *Dynamics of Structures*, eq. 11.4.3;
:mod:`dampfit.physics_modal`). :func:`modal_damping` reads them from a summary;
``dampfit export`` writes them next to the deck's spring–damper of the damper's mode:

* OpenSees — the script keeps its one-mode model and gains ``--modal``: K uncoupled
  oscillators (unit masses, k_i = ω_i²) damped only by ``ops.rayleigh(alphaM, betaK, 0, 0)``
  (zeroLength elements with ``-doRayleigh 1``), whose free decay ``dampfit verify`` runs and
  compares with the rates α/2 + β·ω_i²/2 (:func:`decay_rates`); ``modalDamping`` (per-mode ζ)
  is given as a comment (it needs iterations: OpenSees applies it to the residual only);
* LS-DYNA — ``*DAMPING_PART_MASS`` (damping force D·m·v with D = SF × curve = α) and
  ``*DAMPING_PART_STIFFNESS`` with COEF = −β (a negative COEF is the classical Rayleigh β
  in units of time; a positive one is LS-DYNA's non-classical explicit coefficient);
  ``*DAMPING_GLOBAL`` would carry the mass-proportional part only;
* CalculiX — ``*MODAL DAMPING, RAYLEIGH`` (data line ``,,α,β``) and the per-mode form
  ``*MODAL DAMPING`` (``first mode, last mode, ζ``); both are step cards of a
  ``*MODAL DYNAMIC`` step (the deck's direct-integration ``*DYNAMIC`` step has no Rayleigh
  damping).

In the LS-DYNA and CalculiX decks the cards are a block of comment lines, each starting with
:data:`LSDYNA_PREFIX` / :data:`CALCULIX_PREFIX` and followed by the card exactly as it is to
be pasted into the user's structural model (PID to be replaced; comma-separated free format):
applied to the deck's own spring–damper they would damp the damper's mode twice, since its
dashpot already carries that mode's damping. Every number written is a finite float checked
here; text (the misfit statement) reaches a deck only through :mod:`dampfit.fem.sanitize`.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

from dampfit.errors import InputError, shown
from dampfit.fem.sanitize import ascii_line
from dampfit.fem.units import UnitSystem, factor
from dampfit.result.schema import brief, number

#: Start of an LS-DYNA comment line that holds a card to paste (remove the prefix).
LSDYNA_PREFIX = "$> "
#: Start of a CalculiX comment line that holds a card to paste (remove the prefix).
CALCULIX_PREFIX = "**> "
#: Load-curve id of the constant curve in the LS-DYNA block (*DAMPING_PART_MASS needs one).
LC_MASS_DAMPING = 90
_STATS = ("q05", "q50", "q95")


def _entry(value: Any, field: str, where: Path, **rules) -> dict[str, float]:
    """{q05, q50, q95} of a summary quantity (q50 required, the others if present)."""
    if not isinstance(value, dict):
        raise InputError(f"{shown(where)}: {field} must be an object with q50, got {brief(value)}")
    out = {"q50": number(value.get("q50"), f"{field}.q50", where, **rules)}
    for q in ("q05", "q95", "sd"):
        if value.get(q) is not None:
            out[q] = number(value[q], f"{field}.{q}", where, **({} if q != "sd" else
                                                               {"nonnegative": True}))
    return out


def _source(summary: dict[str, Any]) -> tuple[list | None, Any]:
    """(modes list, Rayleigh dict) wherever the summary keeps them: a ``modes`` list with
    ``modes_rayleigh``/``rayleigh`` beside it, or a ``modes`` object (the whole modes stage
    summary) holding ``modes`` and ``rayleigh``."""
    modes = summary.get("modes")
    if isinstance(modes, dict):
        return modes.get("modes"), modes.get("rayleigh")
    ray = summary.get("modes_rayleigh", summary.get("rayleigh"))
    return modes, ray


def modal_damping(summary: dict[str, Any], where: str | Path = "summary.json") -> dict | None:
    """The measured modes and their Rayleigh damping as checked plain data, or ``None`` for a
    summary of one mode (or none: a summary written before issue 21).

    Returns ``{"n_modes", "modes": [{"index", "f_n", "zeta"} (each {q50[, q05, q95, sd]},
    f_n [Hz] > 0, ζ [1] ≥ 0), …] by frequency, "mass_mode" (1-based or None),
    "alpha", "beta"`` ({q50[, q05, q95, sd]}, [1/s] and [s])``, "statement", "p_value",
    "dof", "max_relative_misfit", "zeta_fitted"`` (ζ(ω_i) of the exported α, β at the
    median f_i), ``"computed"`` (True if the summary had no Rayleigh entry and α, β were
    solved here from the modes' medians, without interval)``}``. Every number is checked
    (:func:`dampfit.result.schema.number`); :class:`InputError` names the bad field.
    """
    where = Path(where)
    modes, ray = _source(summary)
    if modes is None:
        return None
    if not isinstance(modes, list) or not all(isinstance(m, dict) for m in modes):
        raise InputError(f"{shown(where)}: modes must be a list of objects, got {brief(modes)}")
    declared = summary.get("n_modes")
    if isinstance(summary.get("modes"), dict):
        declared = summary["modes"].get("n_modes", declared)
    if declared is not None and (isinstance(declared, bool) or declared != len(modes)):
        raise InputError(f"{shown(where)}: n_modes = {brief(declared)} but modes lists "
                         f"{len(modes)}")
    if len(modes) < 2:
        return None
    seen = _seen_frequencies(summary)
    identified = [(i, m) for i, m in enumerate(modes) if _identified(m, seen)]
    new_layout = "modes_seen" in summary or any("identified" in m for m in modes)
    if len(identified) < 2 or (new_layout and ray is None):
        return None  # one identified mode, or no Rayleigh fit: no modal block (modal_note)
    rows, mass_mode = [], None
    for i, m in identified:
        row = {"index": len(rows) + 1,
               "f_n": _entry(m.get("f_n"), f"modes[{i}].f_n", where, positive=True),
               "zeta": _entry(m.get("zeta"), f"modes[{i}].zeta", where, nonnegative=True)}
        if row["zeta"]["q50"] >= 1.0:
            raise InputError(f"{shown(where)}: modes[{i}].zeta.q50 = {row['zeta']['q50']:g} is "
                             "not below 1: the mode does not oscillate")
        if m.get("mass_mode") is True:
            mass_mode = len(rows) + 1
        rows.append(row)
    f = [r["f_n"]["q50"] for r in rows]
    if any(b <= a for a, b in itertools.pairwise(f)):
        raise InputError(f"{shown(where)}: the modes' f_n.q50 must increase strictly (by "
                         f"frequency), got {', '.join(f'{x:g}' for x in f)}")
    out = {"n_modes": len(rows), "modes": rows, "mass_mode": mass_mode}
    out.update(_rayleigh(ray, rows, where))
    return out


def _identified(mode: dict[str, Any], seen: set[float]) -> bool:
    """Whether a ``modes`` entry may reach a deck: not ``"identified": false`` and not the
    frequency of a ``modes_seen`` component (a reader of an old summary, without the flag,
    takes its modes as identified)."""
    if mode.get("identified") is False:
        return False
    f = mode.get("f_n")
    q50 = f.get("q50") if isinstance(f, dict) else None
    return not (isinstance(q50, (int, float)) and float(q50) in seen)


def _seen_frequencies(summary: dict[str, Any]) -> set[float]:
    """f_n medians [Hz] of ``modes_seen`` (components seen but not identified as modes)."""
    out = set()
    for entry in summary.get("modes_seen") or []:
        f = entry.get("f_n") if isinstance(entry, dict) else None
        q50 = f.get("q50") if isinstance(f, dict) else None
        if isinstance(q50, (int, float)) and not isinstance(q50, bool) and math.isfinite(q50):
            out.add(float(q50))
    return out


def modal_note(summary: dict[str, Any]) -> str | None:
    """One sentence for a deck whose summary lists modes that are left out: the components
    ``modes_seen`` (or flagged ``"identified": false``) and, when no Rayleigh fit was made
    (``rayleigh`` null: fewer than two identified modes), that the deck has no Rayleigh
    damping. ``None`` when nothing was left out."""
    modes, ray = _source(summary)
    modes = modes if isinstance(modes, list) else []
    seen = _seen_frequencies(summary)
    left = [m for m in modes if isinstance(m, dict) and not _identified(m, seen)]
    parts = []
    for entry in list(summary.get("modes_seen") or []) + left:
        if not isinstance(entry, dict):
            continue
        f = entry.get("f_n") if isinstance(entry.get("f_n"), dict) else {}
        q50 = f.get("q50")
        where = f"{q50:.4g} Hz" if isinstance(q50, (int, float)) and not isinstance(
            q50, bool) and math.isfinite(q50) else "unknown frequency"
        kind = ascii_line(entry.get("kind") or entry.get("reason") or "not identified", 80)
        parts.append(f"{where} ({kind})")
    if not parts:
        return None
    n_id = sum(1 for m in modes if isinstance(m, dict) and _identified(m, seen))
    note = ("Seen, not identified as modes, and left out of this deck and of any Rayleigh fit: "
            + "; ".join(parts[:10]) + ".")
    if ray is None or n_id < 2:
        note += (f" No Rayleigh damping: {n_id} identified mode"
                 f"{'' if n_id == 1 else 's'} (a Rayleigh fit needs two).")
    return note


def _rayleigh(ray: Any, rows: list[dict], where: Path) -> dict[str, Any]:
    """α, β and the misfit of the summary's Rayleigh entry (checked), or solved here."""
    from dampfit import physics_modal

    omega = [2 * math.pi * r["f_n"]["q50"] for r in rows]
    zeta = [r["zeta"]["q50"] for r in rows]
    if ray is None:
        fit = physics_modal.rayleigh(omega, zeta)
        out = {"alpha": {"q50": fit["alpha"]}, "beta": {"q50": fit["beta"]},
               "p_value": fit["p_value"], "dof": fit["dof"],
               "max_relative_misfit": fit["max_relative_misfit"], "computed": True,
               "statement": ("computed by export from the modes' medians (equal weights, no "
                             "interval): the summary has no Rayleigh entry")}
    elif not isinstance(ray, dict):
        raise InputError(f"{shown(where)}: the Rayleigh entry must be an object, got {brief(ray)}")
    else:
        out = {"alpha": _entry(ray.get("alpha"), "rayleigh.alpha", where),
               "beta": _entry(ray.get("beta"), "rayleigh.beta", where), "computed": False,
               "statement": str(ray.get("statement") or "")}
        for key, rules in (("p_value", {"nonnegative": True}), ("max_relative_misfit",
                           {"nonnegative": True}), ("chi2", {"nonnegative": True})):
            if ray.get(key) is not None:
                out[key] = number(ray[key], f"rayleigh.{key}", where, **rules)
        dof = ray.get("dof")
        out["dof"] = dof if isinstance(dof, int) and not isinstance(dof, bool) and dof >= 0 \
            else len(rows) - 2
    a, b = out["alpha"]["q50"], out["beta"]["q50"]
    out["zeta_fitted"] = [zeta_of(a, b, w) for w in omega]
    if not all(z > 0 for z in out["zeta_fitted"]):
        raise InputError(f"{shown(where)}: Rayleigh alpha = {a:g} 1/s, beta = {b:g} s give a "
                         "damping ratio <= 0 at a measured mode: not usable in a FEM model; "
                         "use per-mode (modal) damping")
    return out


def zeta_of(alpha: float, beta: float, omega: float) -> float:
    """ζ(ω) = α/(2ω) + β·ω/2 [1] of Rayleigh damping (α [1/s], β [s], ω [rad/s])."""
    return alpha / (2.0 * omega) + beta * omega / 2.0


def decay_rates(md: dict[str, Any]) -> list[float]:
    """Decay rate p_i = ζ(ω_i)·ω_i = α/2 + β·ω_i²/2 [1/s] of each mode of ``md`` under the
    exported α, β (posterior medians): the envelope of mode i falls as e^(−p_i·t)."""
    a, b = md["alpha"]["q50"], md["beta"]["q50"]
    return [a / 2.0 + b * (2 * math.pi * r["f_n"]["q50"]) ** 2 / 2.0 for r in md["modes"]]


def _interval(e: dict[str, float], fmt: str = ".4g") -> str:
    if "q05" in e and "q95" in e:
        return f"{e['q50']:{fmt}} [{e['q05']:{fmt}}, {e['q95']:{fmt}}]"
    return f"{e['q50']:{fmt}} (no interval)"


def describe(md: dict[str, Any]) -> list[str]:
    """Plain sentences (SI) for the comment lines of every format: the modes with their 90 %
    intervals, α, β with theirs and the misfit statement (sanitised by each writer)."""
    lines = [f"Modal damping of the {md['n_modes']} measured modes (posterior median [90 % "
             "interval]; the deck's spring-damper above is the damper's mode"
             + (f", mode {md['mass_mode']}" if md.get("mass_mode") else "") + "):"]
    for r, zf in zip(md["modes"], md["zeta_fitted"]):
        lines.append(f"mode {r['index']}: f_n = {_interval(r['f_n'], '.6g')} Hz, zeta = "
                     f"{_interval(r['zeta'])}; Rayleigh zeta at f_n = {zf:.4g}")
    lines.append(f"Rayleigh C = alpha*M + beta*K (zeta = alpha/(2w) + beta*w/2): alpha = "
                 f"{_interval(md['alpha'])} 1/s, beta = {_interval(md['beta'])} s "
                 "(the medians are written).")
    if md.get("statement"):
        lines.append(f"Misfit: {ascii_line(_greek(md['statement']), 300)}.")
    return lines


#: Greek letters of the statements, spelled out (a deck holds ASCII only).
_GREEK = str.maketrans({"α": "alpha", "β": "beta", "ζ": "zeta", "ω": "w", "χ": "chi", "²": "2",
                        "Λ": "Lambda", "η": "eta"})


def _greek(text: str) -> str:
    return str(text).translate(_GREEK)


def _deck_values(md: dict[str, Any], units: UnitSystem) -> tuple[float, float, list[float]]:
    """(α [1/time], β [time], f_i [1/time]) in the deck's units, each checked finite."""
    ff, ft = factor("frequency", units), factor("time", units)
    vals = (md["alpha"]["q50"] * ff, md["beta"]["q50"] * ft,
            [r["f_n"]["q50"] * ff for r in md["modes"]])
    if not all(math.isfinite(x) for x in (vals[0], vals[1], *vals[2])):
        raise InputError(f"Rayleigh alpha, beta or a frequency is not finite in {units.name} units")
    return vals


def lsdyna_lines(md: dict[str, Any], units: UnitSystem) -> list[str]:
    """``$`` comment lines of the LS-DYNA deck: :func:`describe`, then the cards to paste
    (prefixed :data:`LSDYNA_PREFIX`): a constant curve of 1.0, ``*DAMPING_PART_MASS`` with
    SF = α and ``*DAMPING_PART_STIFFNESS`` with COEF = −β, in the deck's units."""
    from dampfit.fem.sanitize import lsdyna_comment

    alpha, beta, _ = _deck_values(md, units)
    T = units.label("time")
    out = [line for text in describe(md) for line in lsdyna_comment(text, limit=None)]
    out += lsdyna_comment(
        f"Cards for a structural model (replace PID by its part id; not applied here): "
        f"*DAMPING_PART_MASS damps with force D*m*v, D = SF * curve {LC_MASS_DAMPING} = alpha "
        f"[1/{T}]; *DAMPING_PART_STIFFNESS with COEF = -beta [{T}] (COEF < 0 is the classical "
        "Rayleigh beta). *DAMPING_GLOBAL carries the mass-proportional part only.", limit=None)
    p = LSDYNA_PREFIX
    out += [f"{p}*DEFINE_CURVE", f"{p}{LC_MASS_DAMPING},0,1.0,1.0,0.0,0.0",
            f"{p}0.0,1.0", f"{p}1.0e+20,1.0",
            f"{p}*DAMPING_PART_MASS", f"{p}PID,{LC_MASS_DAMPING},{alpha!r},0",
            f"{p}*DAMPING_PART_STIFFNESS", f"{p}PID,{-beta!r}"]
    return out


def calculix_lines(md: dict[str, Any], units: UnitSystem) -> list[str]:
    """``**`` comment lines of the CalculiX deck: :func:`describe`, then the cards to paste
    (prefixed :data:`CALCULIX_PREFIX`): ``*MODAL DAMPING, RAYLEIGH`` with ``,,α,β`` and the
    per-mode ``*MODAL DAMPING`` (``i,i,ζ_i``), in the deck's units."""
    from dampfit.fem.calculix import real
    from dampfit.fem.sanitize import calculix_comment

    alpha, beta, _ = _deck_values(md, units)
    out = [line for text in describe(md) for line in calculix_comment(text, limit=None)]
    out += calculix_comment(
        "Cards for the *MODAL DYNAMIC step of a structural model (this deck integrates "
        "directly and has none): Rayleigh, or per mode (mode numbers as measured: map them to "
        "the model's eigenmodes).", limit=None)
    p = CALCULIX_PREFIX
    out += [f"{p}*MODAL DAMPING, RAYLEIGH", f"{p},,{real(alpha)},{real(beta)}",
            f"{p}*MODAL DAMPING, MODAL=DIRECT"]
    out += [f"{p}{r['index']},{r['index']},{real(r['zeta']['q50'])}" for r in md["modes"]]
    return out


def _pasted(text: str, prefix: str) -> list[str]:
    return [line[len(prefix):] for line in text.splitlines() if line.startswith(prefix)]


def read_lsdyna(text: str) -> dict[str, Any] | None:
    """The modal cards of an LS-DYNA deck written with :func:`lsdyna_lines`, read back as
    LS-DYNA would read them once pasted: ``{"alpha", "beta", "curve"}`` (deck units; α =
    SF × the curve's value, β = −COEF), or ``None`` if the deck has none."""
    cards: dict[str, list[list[str]]] = {}
    name = None
    for line in _pasted(text, LSDYNA_PREFIX):
        if line.startswith("*"):
            name = line[1:].strip().upper()
            cards[name] = []
        elif name is not None:
            cards[name].append([x.strip() for x in line.split(",")])
    if not cards:
        return None
    curve = cards["DEFINE_CURVE"]
    sfo = float(curve[0][3])
    values = {float(row[1]) * sfo for row in curve[1:]}
    mass = cards["DAMPING_PART_MASS"][0]
    if int(mass[1]) != int(curve[0][0]) or len(values) != 1:
        raise ValueError("the mass-damping card does not use one constant curve")
    coef = float(cards["DAMPING_PART_STIFFNESS"][0][1])
    return {"alpha": float(mass[2]) * values.pop(), "beta": -coef, "coef": coef,
            "curve": int(curve[0][0])}


def read_calculix(text: str) -> dict[str, Any] | None:
    """The ``*MODAL DAMPING`` cards of a CalculiX deck written with :func:`calculix_lines`:
    ``{"alpha", "beta", "zeta": {mode: ζ}}`` (deck units), or ``None`` if it has none."""
    lines = _pasted(text, CALCULIX_PREFIX)
    if not lines:
        return None
    out: dict[str, Any] = {"zeta": {}}
    kind = None
    for line in lines:
        if line.startswith("*"):
            kind = "rayleigh" if "RAYLEIGH" in line.upper() else "direct"
            continue
        f = [x.strip() for x in line.split(",")]
        if kind == "rayleigh":
            out["alpha"], out["beta"] = float(f[2]), float(f[3])
        else:
            for mode in range(int(f[0]), int(f[1]) + 1):
                out["zeta"][mode] = float(f[2])
    return out
