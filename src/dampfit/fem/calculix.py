"""CalculiX (ccx) input deck (.inp) of the identified system, and its reader.

Model: node 1 fixed, node 2 with a MASS element, hanging below node 1 (global y up) on a
SPRINGA (linear, k) and a DASHPOTA (c) element in parallel between the two nodes; node 2 may
move along y only. The axial elements act along the node-to-node line, so their forces are
exact for this 1-D motion in the geometrically nonlinear *DYNAMIC step too.

Steps:

1. *STATIC — pre-displace: node 2 is prescribed to ``−s + u0`` (s = m·g/k, the static sag
   under gravity, 0 without) from the unstretched position, i.e. u0 above static equilibrium;
   gravity is a *CLOAD of −m·g on node 2 (the same weight as a *DLOAD GRAV on a point mass).
2. *DYNAMIC, DIRECT, ALPHA=0 — release: *BOUNDARY, OP=NEW drops the prescribed displacement
   (keeping the supports), the mass starts at rest from where step 1 left it. α = 0 makes
   CalculiX's HHT integrator the Newmark average-acceleration rule (γ = 1/2, β = 1/4, no
   numerical damping); DIRECT keeps the fixed increment. *NODE PRINT writes U of node 2 to
   the .dat file every output interval.

CalculiX is not installed here: the deck is checked by reading it back (:func:`read_deck`),
not by running ccx. Reals are written with a decimal point or exponent, since CalculiX tells
the optional first line of *SPRING/*DASHPOT (integers) from the constants (reals) by that.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit.fem.lsdyna import reference_length
from dampfit.fem.sanitize import ascii_line, calculix_comment
from dampfit.fem.sdof import Sdof
from dampfit.fem.timestep import newmark_period_error
from dampfit.fem.units import UnitSystem, factor


def real(x: float) -> str:
    """Shortest exact text of ``x`` that contains a decimal point (``1e-05`` → ``1.0e-05``)."""
    text = repr(float(x))
    if "." not in text and "e" in text:
        mant, exp = text.split("e")
        text = f"{mant}.0e{exp}"
    elif "." not in text and "inf" not in text and "nan" not in text:
        text += ".0"
    return text


def deck(sdof: Sdof, units: UnitSystem, times: tuple[float, float, float], *,
         damper: Any = None, header: tuple[str, ...] | list[str] = ()) -> str:
    """The .inp text for ``sdof`` in ``units``; ``times`` = (duration, dt, output_dt) [s]
    (SI).

    CalculiX's *DASHPOT is linear: its constant may depend on the frequency (steady-state
    dynamics) and the temperature, never on the velocity (ccx ``dashpots.f``). A nonlinear
    ``damper`` (:class:`dampfit.fem.damper.Damper`) is therefore written as the linear c of
    ``sdof`` — the equivalent linear c at the design amplitude — with that limitation stated
    in the comments; ``header`` (the damper's sentences) opens the deck.

    Outside text (source folder, dampfit version) is sanitised (:mod:`dampfit.fem.sanitize`):
    it only appears inside ``**`` comment lines, never starts a keyword card.
    """
    duration, dt, output_dt = times
    L, T = factor("length", units), factor("time", units)
    m = sdof.mass * factor("mass", units)
    k = sdof.k * factor("stiffness", units)
    c = sdof.c * factor("damping", units)
    weight = -sdof.mass * sdof.g * factor("force", units)
    ref = reference_length(sdof) * L
    start = (-sdof.sag + sdof.u0) * L
    n_steps = round(duration / dt)
    every = max(1, round(output_dt / dt))
    lab = units.label
    src = sdof.source
    head = [
        (f"Written by dampfit {ascii_line(src.get('dampfit_version') or '', 80)} from "
         f"{ascii_line(src.get('folder', '?'), 300)} (summary.json sha256 "
         f"{ascii_line(str(src.get('summary_sha256', '?'))[:16])}...), posterior quantile "
         f"q = {float(src.get('quantile', 0.5)):g}."),
        (f"Identified (SI): m = {sdof.mass:.6g} kg, k = {sdof.k:.6g} N/m, c = {sdof.c:.6g} N*s/m, "
         f"u0 = {sdof.u0:.6g} m, zeta = {sdof.zeta:.6g}, f_n = {sdof.omega_n / (2 * math.pi):.6g} Hz."),
        (f"Units: length {lab('length')}, time {lab('time')}, mass {lab('mass')}, force "
         f"{lab('force')}; k in {lab('stiffness')}, c in {lab('damping')}."),
        ("Step 1 (static) prescribes node 2 at u0 above static equilibrium (static sag "
         f"s = m*g/k = {sdof.sag * L!r} {lab('length')}); step 2 releases it at rest: Newmark "
         f"average acceleration (ALPHA=0), fixed increment {dt * T!r} {lab('time')} = T/"
         f"{sdof.period / dt:.0f}, period error {newmark_period_error(sdof.omega_n, dt):.2e}."),
    ]
    if damper is not None and damper.nonlinear:
        head[1] = head[1].replace("c = ", "c (equivalent linear c at the design amplitude) = ", 1)
        head.append(f"LIMITATION: CalculiX has no nonlinear dashpot (*DASHPOT is linear in the "
                    f"velocity), so this deck carries the equivalent linear c at the design "
                    f"amplitude, not the measured {damper.law} law; it dissipates the measured "
                    "energy per cycle at that amplitude only (more or less elsewhere).")
    head = list(header) + head
    out = [line for text in head for line in calculix_comment(text, limit=None)]
    out += [
        "*HEADING",
        "dampfit SDOF free decay",
        "*NODE, NSET=NALL",
        "1, 0.0, 0.0, 0.0",
        f"2, 0.0, {real(-ref)}, 0.0",
        "*NSET, NSET=NFIX", "1",
        "*NSET, NSET=NMASS", "2",
        "*ELEMENT, TYPE=SPRINGA, ELSET=ESPRING", "1, 1, 2",
        "*ELEMENT, TYPE=DASHPOTA, ELSET=EDASHPOT", "2, 1, 2",
        "*ELEMENT, TYPE=MASS, ELSET=EMASS", "3, 2",
        "*SPRING, ELSET=ESPRING", "", real(k),
        "*DASHPOT, ELSET=EDASHPOT", "", real(c),
        "*MASS, ELSET=EMASS", real(m),
        "*BOUNDARY", "NFIX, 1, 3", "NMASS, 1, 1", "NMASS, 3, 3",
        "*STEP",
        "*STATIC",
        "*BOUNDARY", f"NMASS, 2, 2, {real(start)}",
    ]
    if sdof.g > 0:
        out += ["*CLOAD", f"NMASS, 2, {real(weight)}"]
    out += [
        "*END STEP",
        f"*STEP, INC={n_steps + 10}",
        "*DYNAMIC, DIRECT, ALPHA=0.0",
        f"{real(dt * T)}, {real(n_steps * dt * T)}",
        "*BOUNDARY, OP=NEW", "NFIX, 1, 3", "NMASS, 1, 1", "NMASS, 3, 3",
        f"*NODE PRINT, NSET=NMASS, FREQUENCY={every}", "U",
        "*END STEP",
    ]
    return "\n".join(out) + "\n"


def _keyword(line: str) -> tuple[str, dict[str, str]]:
    parts = [p.strip() for p in line[1:].split(",")]
    params = {}
    for p in parts[1:]:
        key, _, value = p.partition("=")
        params[key.strip().upper()] = value.strip()
    return parts[0].upper(), params


def read_deck(text: str) -> dict[str, Any]:
    """Read a deck written by :func:`deck` back, in its own units, with the physics it implies.

    ``u0`` is node 2's position at the release relative to its static equilibrium under the
    spring, the *CLOAD and nothing else (positive up); also mass, k, c, g-load, dt, duration.
    """
    blocks: list[tuple[str, dict[str, str], list[str]]] = []
    for raw in text.splitlines():
        line = raw.strip()
        if line.startswith("**"):
            continue
        if line.startswith("*"):
            blocks.append((*_keyword(line), []))
        elif line and blocks:  # CalculiX drops blank lines
            blocks[-1][2].append(line)
    values: dict[str, Any] = {"cload": 0.0}
    step = 0
    for name, params, data in blocks:
        if name == "STEP":
            step += 1
        elif name == "NODE":
            values["nodes"] = {int(r.split(",")[0]): tuple(float(x) for x in r.split(",")[1:4])
                               for r in data}
        elif name in ("SPRING", "DASHPOT", "MASS"):
            values[{"SPRING": "k", "DASHPOT": "c", "MASS": "mass"}[name]] = float(data[-1])
        elif name == "BOUNDARY" and step == 1:
            f = [x.strip() for x in data[0].split(",")]
            values["prescribed"] = float(f[3])
        elif name == "CLOAD":
            values["cload"] = float(data[0].split(",")[2])
        elif name == "DYNAMIC":
            dt, period = (float(x) for x in data[0].split(",")[:2])
            values.update(dt=dt, duration=period, alpha=float(params.get("ALPHA", "-0.05")),
                          direct="DIRECT" in params)
        elif name == "NODE PRINT":
            values["output_every"] = int(params.get("FREQUENCY", "1"))
    x1, x2 = values["nodes"][1], values["nodes"][2]
    ey = (x2[1] - x1[1]) / math.dist(x1, x2)
    # displacement d (along y) of node 2 elongates the spring by d·ey; the spring force on
    # node 2 is −k·d·ey·ey = −k·d, so the static equilibrium under the load F is d = F/k
    d_eq = values["cload"] / values["k"]
    values.update(axis_y=ey, u0=values["prescribed"] - d_eq, equilibrium=d_eq)
    return values
