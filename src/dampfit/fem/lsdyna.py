"""LS-DYNA keyword deck (.k) of the identified spring–damper–mass system, and its reader.

The model is the seed paper's (its Fig. 22 and text): a mass on a discrete spring and a
discrete damper in parallel — *ELEMENT_DISCRETE with *SECTION_DISCRETE (DRO = 0,
translational), *MAT_SPRING_ELASTIC (K) and *MAT_DAMPER_VISCOUS (DC), the mass as
*ELEMENT_MASS, optional gravity as *LOAD_BODY_Y. Node 1 is the fixed anchor
(*BOUNDARY_SPC_NODE), node 2 carries the mass and hangs below it (global y up); node 2 may
move along y only.

**Initial displacement.** The paper prescribes u0 = 4 cm at t = 0. LS-DYNA has no
initial-displacement card (*INITIAL_VELOCITY only sets velocities), and a discrete spring
measures its elongation from the node positions at t = 0. So node 2 is placed at its released
position and the spring gets the elongation it has there through the OFFSET field of
*ELEMENT_DISCRETE ("initial offset … at time zero; a positive offset leads to a tensile
force"): OFFSET = s − u0 with s = m·g/k the static sag (0 without gravity). At t = 0 the spring
force is k·(s − u0) upwards, the weight m·g downwards, the net force −k·u0: the mass is at u0
above its static equilibrium, at rest (*INITIAL_VELOCITY_NODE = 0), exactly the free decay
identified. The nodout Y-displacement is d(t) = u(t) − u0.

**Gravity** (``g > 0``): *LOAD_BODY_Y with a constant curve of value g. LS-DYNA's body load
is a base acceleration: a positive value gives inertial forces along −y, i.e. weight
downwards. The start from static equilibrium + u0 needs no dynamic relaxation (the paper
notes that LS-DYNA handles the preload itself; the OFFSET makes the start exact).

**Time step.** The explicit central-difference step LS-DYNA would choose for a discrete
spring is a sizeable fraction of the period; the deck caps it with a constant curve on LCTM
of *CONTROL_TIMESTEP (see :mod:`dampfit.fem.timestep` for the period error). The anchor node
also gets a mass (it is fixed, so the mass carries no load): LS-DYNA computes the time step of
a discrete element from its nodal masses and rejects massless nodes.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit.fem import keyword as kw
from dampfit.fem.sanitize import ascii_line, lsdyna_comment, lsdyna_title
from dampfit.fem.sdof import Sdof
from dampfit.fem.timestep import central_difference_period_error
from dampfit.fem.units import UnitSystem

_NODE_W = [8, 16, 16, 16, 8, 8]
_EMASS_W = [8, 8, 16, 8]
_EDISC_W = [8, 8, 8, 8, 8, 16, 8, 16]
_CURVE_POINT_W = [20, 20]
#: Curve ids: time-step cap, gravity, the nonlinear damper's force–velocity table.
LC_DT, LC_GRAVITY, LC_DAMPER = 1, 2, 3


def reference_length(sdof: Sdof) -> float:
    """Unstretched distance [m] between anchor and mass: 1 m or 10× the largest motion."""
    return max(1.0, 10.0 * (abs(sdof.u0) + sdof.sag))


def _comment(text: str) -> list[str]:
    """``$`` comment lines (≤ 80 columns, printable ASCII) holding ``text``."""
    return lsdyna_comment(text, limit=None)


def deck(sdof: Sdof, units: UnitSystem, times: tuple[float, float, float], *,
         title: str = "dampfit SDOF free decay", damper: Any = None,
         header: tuple[str, ...] | list[str] = ()) -> str:
    """The .k deck text for ``sdof`` in ``units``; ``times`` = (duration, dt, output_dt) [s]
    (SI).

    ``damper`` (:class:`dampfit.fem.damper.Damper`) with a nonlinear law replaces
    *MAT_DAMPER_VISCOUS by *MAT_DAMPER_NONLINEAR_VISCOUS (MID, LCDR) and its force–velocity
    curve :data:`LC_DAMPER` (:func:`damper_curve`); ``header`` (the damper's sentences) goes
    into ``$`` comments right after *KEYWORD.

    Outside text (source folder, dampfit version, ``title``) is sanitised
    (:mod:`dampfit.fem.sanitize`): it can only appear inside ``$`` comments or as the
    ``*TITLE`` line, never start a card.
    """
    duration, dt, output_dt = times
    from dampfit.fem.units import factor

    L, T, M = (factor(q, units) for q in ("length", "time", "mass"))
    K, C, A = (factor(q, units) for q in ("stiffness", "damping", "acceleration"))
    m, k, c, g = sdof.mass * M, sdof.k * K, sdof.c * C, sdof.g * A
    ref = reference_length(sdof)
    y2 = (-ref - sdof.sag + sdof.u0) * L  # released position of the mass node
    offset = (sdof.sag - sdof.u0) * L     # spring elongation at t = 0 (positive = tension)
    end, step, out = duration * T, dt * T, output_dt * T
    lines = ["*KEYWORD"] + [x for text in header for x in _comment(text)]
    lines += _comments(sdof, units, L, dt, step, damper is not None and damper.nonlinear)
    lines += ["*TITLE", lsdyna_title(title)]
    lines += ["*CONTROL_TERMINATION", kw.header(["endtim", "endcyc", "dtmin", "endeng", "endmas"]),
              kw.card([end, 0, 0.0, 0.0, 0.0])]
    lines += ["*CONTROL_TIMESTEP",
              kw.header(["dtinit", "tssfac", "isdo", "tslimt", "dt2ms", "lctm", "erode", "ms1st"]),
              kw.card([step, 0.9, 0, 0.0, 0.0, LC_DT, 0, 0])]
    lines += _constant_curve(LC_DT, "maximum time step", step, end)
    lines += ["*DATABASE_NODOUT", kw.header(["dt", "binary", "lcur", "ioopt"]),
              kw.card([out, 3, 0, 1])]
    lines += ["*DATABASE_HISTORY_NODE", kw.header(["id1"]), kw.card([2])]
    lines += ["*NODE", kw.header(["nid", "x", "y", "z", "tc", "rc"], _NODE_W),
              kw.card([1, 0.0, 0.0, 0.0, 0, 0], _NODE_W),
              kw.card([2, 0.0, y2, 0.0, 0, 0], _NODE_W)]
    lines += ["*BOUNDARY_SPC_NODE",
              kw.header(["nid", "cid", "dofx", "dofy", "dofz", "dofrx", "dofry", "dofrz"]),
              kw.card([1, 0, 1, 1, 1, 1, 1, 1]), kw.card([2, 0, 1, 0, 1, 1, 1, 1])]
    lines += ["*INITIAL_VELOCITY_NODE",
              kw.header(["nid", "vx", "vy", "vz", "vxr", "vyr", "vzr", "icid"]),
              kw.card([2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0])]
    lines += ["*PART", "spring", kw.header(["pid", "secid", "mid", "eosid", "hgid", "grav"]),
              kw.card([1, 1, 1, 0, 0, 0]),
              "*PART", "damper", kw.header(["pid", "secid", "mid", "eosid", "hgid", "grav"]),
              kw.card([2, 1, 2, 0, 0, 0])]
    lines += ["*SECTION_DISCRETE", kw.header(["secid", "dro", "kd", "v0", "cl", "fd"]),
              kw.card([1, 0, 0.0, 0.0, 0.0, 0.0]), kw.header(["cdl", "tdl"]), kw.card([0.0, 0.0])]
    lines += ["*MAT_SPRING_ELASTIC", kw.header(["mid", "k"]), kw.card([1, k])]
    if damper is not None and damper.nonlinear:
        lines += ["*MAT_DAMPER_NONLINEAR_VISCOUS", kw.header(["mid", "lcdr"]),
                  kw.card([2, LC_DAMPER])]
        lines += damper_curve(damper, sdof, units, dt)
    else:
        lines += ["*MAT_DAMPER_VISCOUS", kw.header(["mid", "dc"]), kw.card([2, c])]
    lines += ["*ELEMENT_DISCRETE",
              kw.header(["eid", "pid", "n1", "n2", "vid", "s", "pf", "offset"], _EDISC_W),
              kw.card([1, 1, 1, 2, 0, 1.0, 0, offset], _EDISC_W),
              kw.card([2, 2, 1, 2, 0, 1.0, 0, 0.0], _EDISC_W)]
    for eid, nid in ((3, 2), (4, 1)):  # one block each: some readers take one card per block
        lines += ["*ELEMENT_MASS", kw.header(["eid", "nid", "mass", "pid"], _EMASS_W),
                  kw.card([eid, nid, m, 0], _EMASS_W)]
    if sdof.g > 0:
        lines += ["*LOAD_BODY_Y", kw.header(["lcid", "sf", "lciddr", "xc", "yc", "zc", "cid"]),
                  kw.card([LC_GRAVITY, 1.0, 0, 0.0, 0.0, 0.0, 0])]
        lines += _constant_curve(LC_GRAVITY, "gravity (constant)", g, end)
    lines.append("*END")
    return "\n".join(lines) + "\n"


def _comments(sdof: Sdof, units: UnitSystem, L: float, dt: float, step: float,
              nonlinear: bool = False) -> list[str]:
    """The deck's ``$`` comments: where it comes from, the identified system (SI), the units,
    the model, the initial displacement and the time step (``dt`` [s], ``step`` in the deck's
    time unit, ``L`` the deck's length per metre)."""
    lab = units.label
    period_err = central_difference_period_error(sdof.omega_n, dt)
    src = sdof.source
    lines: list[str] = []
    lines += _comment(f"Written by dampfit {ascii_line(src.get('dampfit_version') or '', 80)} from "
                      f"{ascii_line(src.get('folder', '?'), 300)} (summary.json sha256 "
                      f"{ascii_line(str(src.get('summary_sha256', '?'))[:16])}...), posterior "
                      f"quantile q = {float(src.get('quantile', 0.5)):g}.")
    cname = "c_eq (linear c at the design amplitude, not written)" if nonlinear else "c"
    card = "*MAT_DAMPER_NONLINEAR_VISCOUS" if nonlinear else "*MAT_DAMPER_VISCOUS"
    lines += _comment(f"Identified (SI): m = {sdof.mass:.6g} kg, k = {sdof.k:.6g} N/m, "
                      f"{cname} = {sdof.c:.6g} N*s/m, u0 = {sdof.u0:.6g} m, zeta = {sdof.zeta:.6g}, "
                      f"f_n = {sdof.omega_n / (2 * math.pi):.6g} Hz.")
    lines += _comment(f"Units of this deck: length {lab('length')}, time {lab('time')}, mass "
                      f"{lab('mass')}, force {lab('force')}; k in {lab('stiffness')}, c in "
                      f"{lab('damping')}.")
    lines += _comment("Node 1 is the fixed anchor; node 2 carries the mass and hangs below it "
                      f"(y up) on a *MAT_SPRING_ELASTIC spring and a {card} damper "
                      "in parallel (two *ELEMENT_DISCRETE).")
    lines += _comment("Initial displacement: node 2 sits at its released position, u0 above "
                      "static equilibrium, at rest; the spring's OFFSET (initial elongation, "
                      "positive = tension) = s - u0 carries the force of that displacement "
                      f"(s = m*g/k = {sdof.sag * L:.6g} {lab('length')} static sag). "
                      "nodout Y-displacement d(t) = u(t) - u0.")
    lines += _comment(f"Time step capped at {step:.6g} {lab('time')} by curve {LC_DT} (LCTM): "
                      f"{sdof.period / dt:.0f} steps per period, central-difference period error "
                      f"{period_err:.2e}.")
    return lines


def damper_curve(damper: Any, sdof: Sdof, units: UnitSystem, dt: float) -> list[str]:
    """Comments and ``*DEFINE_CURVE_TITLE`` :data:`LC_DAMPER` of the damper's force against
    elongation rate, in the deck's units (velocity, force): the table of
    :func:`dampfit.fem.damper.table` over the measured velocity range (else ω·u0/10 … ω·u0)
    with its steepest segment (through 0) a damping of at most m/Δt, half the explicit
    stability limit 2m/Δt of a damper on the mass."""
    from dampfit.fem.damper import TABLE_REACH, table
    from dampfit.fem.units import factor

    vr = damper.velocity_range or (0.1 * sdof.omega_n * abs(sdof.u0), sdof.omega_n * abs(sdof.u0))
    tab = table(damper, vr, sdof.mass / dt)
    V, F = factor("velocity", units), factor("force", units)
    lv, lf = units.label("velocity"), units.label("force")
    out = _comment(f"Curve {LC_DAMPER}: damper force [{lf}] against elongation rate [{lv}], "
                   f"symmetric through (0, 0). Measured |v| {tab['measured'][0] * V:.4g} to "
                   f"{tab['measured'][1] * V:.4g} {lv}; below and above that the law is "
                   f"extrapolated (not measured), up to {TABLE_REACH:g}x the fastest measured "
                   f"velocity ({tab['v_top'] * V:.4g} {lv}), beyond which LS-DYNA extrapolates "
                   f"the last segment. Between -{tab['v1'] * V:.4g} and {tab['v1'] * V:.4g} "
                   f"{lv} the curve is a straight line through 0 (its slope <= m/dt, so the "
                   "explicit step stays stable; for friction this regularises the jump).")
    out += ["*DEFINE_CURVE_TITLE", "damper force - velocity",
            kw.header(["lcid", "sidr", "sfa", "sfo", "offa", "offo", "dattyp"]),
            kw.card([LC_DAMPER, 0, 1.0, 1.0, 0.0, 0.0, 0]), kw.header(["a1", "o1"], _CURVE_POINT_W)]
    out += [kw.card([float(v * V), float(f * F)], _CURVE_POINT_W) for v, f in zip(tab["v"], tab["F"])]
    return out


def _constant_curve(lcid: int, title: str, value: float, end: float) -> list[str]:
    """``*DEFINE_CURVE_TITLE`` ``lcid``: the constant ``value`` from t = 0 to 2·``end``."""
    return ["*DEFINE_CURVE_TITLE", title,
            kw.header(["lcid", "sidr", "sfa", "sfo", "offa", "offo", "dattyp"]),
            kw.card([lcid, 0, 1.0, 1.0, 0.0, 0.0, 0]),
            kw.header(["a1", "o1"], _CURVE_POINT_W),
            kw.card([0.0, value], _CURVE_POINT_W), kw.card([2.0 * end, value], _CURVE_POINT_W)]


def _curves(blocks) -> dict[int, tuple[float, list[tuple[float, float]]]]:
    out = {}
    for name, data in blocks:
        if name.startswith("DEFINE_CURVE"):
            rows = data[1:] if name.endswith("_TITLE") else data
            f = kw.split_fields(rows[0], 10, 8)
            sfo = kw.read_real(f[3], 1.0) or 1.0
            pts = [tuple(kw.read_real(x) for x in kw.split_fields(r, _CURVE_POINT_W)) for r in rows[1:]]
            out[kw.read_int(f[0])] = (sfo, pts)
    return out


def _materials(blocks: list[list[str]]) -> dict[int, float]:
    """``{mid: value}`` of one-value material cards (``*MAT_SPRING_ELASTIC`` k,
    ``*MAT_DAMPER_VISCOUS`` dc)."""
    fields = [kw.split_fields(data[0], 10, 2) for data in blocks]
    return {kw.read_int(f[0]): kw.read_real(f[1]) for f in fields}


def read_deck(text: str) -> dict[str, Any]:
    """Read a deck written by :func:`deck` back, in the deck's own units.

    Returns mass, k, c, offset, node positions, duration, dt, output_dt, g and the physics
    they imply with LS-DYNA's conventions: the static equilibrium of node 2 and ``u0``, its
    position relative to that equilibrium at t = 0 (along y, positive up), and ``v0``.
    """
    blocks = kw.parse_deck(text)
    get = {}
    for name, data in blocks:
        get.setdefault(name, []).append(data)
    nodes = {}
    for row in get["NODE"][0]:
        f = kw.split_fields(row, _NODE_W)
        nodes[kw.read_int(f[0])] = tuple(kw.read_real(x, 0.0) for x in f[1:4])
    masses = {}
    for row in (r for data in get["ELEMENT_MASS"] for r in data):
        f = kw.split_fields(row, _EMASS_W)
        masses[kw.read_int(f[1])] = masses.get(kw.read_int(f[1]), 0.0) + kw.read_real(f[2])
    parts = {}
    for data in get["PART"]:
        f = kw.split_fields(data[1], 10, 3)
        parts[kw.read_int(f[0])] = kw.read_int(f[2])
    springs, dampers = (_materials(get.get(name, [])) for name in ("MAT_SPRING_ELASTIC",
                                                                    "MAT_DAMPER_VISCOUS"))
    nonlinear = {mid: int(lc) for mid, lc in _materials(get.get("MAT_DAMPER_NONLINEAR_VISCOUS",
                                                                 [])).items()}
    k = c = offset = 0.0
    for row in get["ELEMENT_DISCRETE"][0]:
        f = kw.split_fields(row, _EDISC_W)
        mid, scale = parts[kw.read_int(f[1])], kw.read_real(f[5], 1.0) or 1.0
        if mid in springs:
            k += scale * springs[mid]
            offset = kw.read_real(f[7], 0.0)
            anchor, free = kw.read_int(f[2]), kw.read_int(f[3])
        elif mid in dampers:
            c += scale * dampers[mid]
    curves = _curves(blocks)
    damper_curve_pts = None
    for mid, lc in nonlinear.items():
        sfo_d, pts_d = curves[lc]
        damper_curve_pts = [(v, sfo_d * f) for v, f in pts_d]
    f = kw.split_fields(get["CONTROL_TIMESTEP"][0][0], 10, 8)
    sfo, pts = curves[kw.read_int(f[5])]
    g = 0.0
    if "LOAD_BODY_Y" in get:
        lf = kw.split_fields(get["LOAD_BODY_Y"][0][0], 10, 2)
        gsfo, gpts = curves[kw.read_int(lf[0])]
        g = kw.read_real(lf[1], 1.0) * gsfo * gpts[0][1]
    v0 = 0.0
    for row in get.get("INITIAL_VELOCITY_NODE", [[]])[0]:
        vf = kw.split_fields(row, 10, 3)
        if kw.read_int(vf[0]) == free:
            v0 = kw.read_real(vf[2], 0.0)
    m = masses[free]
    x1, x2 = nodes[anchor], nodes[free]
    length = math.dist(x1, x2)
    ey = (x2[1] - x1[1]) / length  # the element axis, anchor → mass, must be along y
    # y-displacement d of node 2 from its t = 0 position elongates the spring by d·ey; the
    # spring force on node 2 is −k·(offset + d·ey)·ey and the weight −m·g (along y):
    d_eq = -m * g / k - offset * ey
    return {
        "mass": m, "k": k, "c": c, "offset": offset, "g": g, "damper_curve": damper_curve_pts,
        "anchor": x1, "node": x2, "axis_y": ey,
        "duration": kw.read_real(kw.split_fields(get["CONTROL_TERMINATION"][0][0], 10, 1)[0]),
        "dt": sfo * pts[0][1], "dtinit": kw.read_real(f[0], 0.0),
        "output_dt": kw.read_real(kw.split_fields(get["DATABASE_NODOUT"][0][0], 10, 1)[0]),
        "equilibrium_y": x2[1] + d_eq, "u0": -d_eq, "v0": v0,
        "spc": {kw.read_int(r[:10]): [kw.read_int(x, 0) for x in kw.split_fields(r, 10, 8)[2:]]
                for r in get["BOUNDARY_SPC_NODE"][0]},
    }
