"""OpenSees model of the identified system: an exported OpenSeesPy script and an in-process run.

Model (both): a 1-D model (``-ndm 1 -ndf 1``), node 1 fixed, node 2 with the mass, one
``zeroLength`` element in direction 1 carrying two uniaxial materials in parallel —
``Elastic`` (k) and ``Viscous`` (c, α = 1: force = c·velocity). u is positive up; gravity, if
any, is a constant load −m·g on node 2, so the static equilibrium is at −s = −m·g/k.

Initial state: released at rest from ``−s + u0`` (u0 above static equilibrium), set with
``setNodeDisp``/``setNodeVel`` and — necessary — the consistent initial acceleration
``a(0) = (F − k·u(0) − c·v(0))/m`` with ``setNodeAccel``: OpenSees' Newmark integrator takes
the committed acceleration as a(0) and does not solve for it, and a wrong a(0) leaves a
first-order error (ΔtΔa/2 in the velocity) that no later step removes.

Integration: Newmark average acceleration (γ = 1/2, β = 1/4), unconditionally stable, no
numerical damping, period elongation (ωΔt/2)/atan(ωΔt/2) − 1 ≈ (ωΔt)²/12
(:func:`dampfit.fem.timestep.newmark_period_error`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import InputError

from .sdof import Sdof
from .timestep import newmark_period_error
from .units import UnitSystem, factor

__all__ = ["engine_version", "free_decay", "script"]


def engine_version() -> str:
    """Installed OpenSeesPy version (``"unknown"`` if it has no metadata)."""
    import importlib.metadata

    try:
        return importlib.metadata.version("openseespy")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def free_decay(mass: float, k: float, c: float, u_init: float, v_init: float, dt: float,
               n_steps: int, force: float = 0.0) -> dict[str, np.ndarray]:
    """Run the model in OpenSeesPy; every step's ``t`` [s], ``u`` [m], ``v`` [m/s], ``a`` [m/s²].

    ``mass`` [kg], ``k`` [N/m], ``c`` [N·s/m] (any consistent units work), initial
    displacement ``u_init`` and velocity ``v_init`` of node 2, fixed step ``dt``, ``n_steps``
    steps, constant external ``force`` on the mass (e.g. −m·g). Arrays have n_steps + 1 entries.
    """
    try:
        import openseespy.opensees as ops  # lazy: heavy, and global state
    except ImportError as exc:  # not installed, or its BLAS/LAPACK libraries are missing
        raise InputError(
            f"OpenSeesPy is not usable ({exc}); install it with 'pip install \"dampfit[fem]\"' "
            "(on Debian it also needs: apt-get install libblas3 liblapack3)"
        ) from None

    ops.wipe()
    try:
        ops.model("basic", "-ndm", 1, "-ndf", 1)
        ops.node(1, 0.0)
        ops.node(2, 0.0)
        ops.fix(1, 1)
        ops.mass(2, mass)
        ops.uniaxialMaterial("Elastic", 1, k)
        ops.uniaxialMaterial("Viscous", 2, c, 1.0)
        ops.element("zeroLength", 1, 1, 2, "-mat", 1, 2, "-dir", 1, 1)
        if force != 0.0:
            ops.timeSeries("Constant", 1)
            ops.pattern("Plain", 1, 1)
            ops.load(2, force)
        ops.setNodeDisp(2, 1, u_init, "-commit")
        ops.setNodeVel(2, 1, v_init, "-commit")
        ops.setNodeAccel(2, 1, (force - k * u_init - c * v_init) / mass, "-commit")
        ops.constraints("Plain")
        ops.numberer("Plain")
        ops.system("BandGeneral")
        ops.test("NormDispIncr", 1e-12, 10)
        ops.algorithm("Linear")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")
        u = np.empty(n_steps + 1)
        v = np.empty(n_steps + 1)
        a = np.empty(n_steps + 1)
        u[0], v[0], a[0] = ops.nodeDisp(2, 1), ops.nodeVel(2, 1), ops.nodeAccel(2, 1)
        for i in range(1, n_steps + 1):
            if ops.analyze(1, dt) != 0:
                raise RuntimeError(f"OpenSees failed at step {i}")
            u[i], v[i], a[i] = ops.nodeDisp(2, 1), ops.nodeVel(2, 1), ops.nodeAccel(2, 1)
    finally:
        ops.wipe()
    return {"t": dt * np.arange(n_steps + 1), "u": u, "v": v, "a": a}


_TEMPLATE = '''\
"""OpenSeesPy model of an identified spring-damper-mass system (written by dampfit {version}).

{provenance}

Units: length {L}, time {T}, mass {M}, force {F} (k in {K}, c in {C}).
Model: node 1 fixed, node 2 carries the mass m; a zeroLength element holds an Elastic (k)
and a Viscous (c, alpha = 1) material in parallel. u is positive up; with gravity the weight
-m*g is a constant load and the static equilibrium is at -m*g/k. Released at rest from u0
above static equilibrium, with the consistent initial acceleration (OpenSees' Newmark does
not compute it). Newmark average acceleration (gamma = 1/2, beta = 1/4) with a fixed step:
{steps_per_period:.0f} steps per period, period error {period_error:.2e}.

Run:  python {name}  [OUT.csv]   -> time, u, v, a of node 2 (default: next to this script)
"""
import math
import os
import sys

import openseespy.opensees as ops

m = {m!r}  # mass [{M}]
k = {k!r}  # stiffness [{K}]
c = {c!r}  # viscous damping [{C}]
u0 = {u0!r}  # release displacement above static equilibrium [{L}]
g = {g!r}  # gravity [{A}] (0: none)
duration = {duration!r}  # [{T}]
dt = {dt!r}  # time step [{T}]
output_every = {every}  # steps between output rows

ops.wipe()
ops.model("basic", "-ndm", 1, "-ndf", 1)
ops.node(1, 0.0)  # anchor
ops.node(2, 0.0)  # mass
ops.fix(1, 1)
ops.mass(2, m)
ops.uniaxialMaterial("Elastic", 1, k)
ops.uniaxialMaterial("Viscous", 2, c, 1.0)  # force = c * velocity**1
ops.element("zeroLength", 1, 1, 2, "-mat", 1, 2, "-dir", 1, 1)  # spring || damper
weight = -m * g
if g > 0:
    ops.timeSeries("Constant", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(2, weight)
u_start = -m * g / k + u0  # static equilibrium + u0
ops.setNodeDisp(2, 1, u_start, "-commit")
ops.setNodeVel(2, 1, 0.0, "-commit")
ops.setNodeAccel(2, 1, (weight - k * u_start) / m, "-commit")
ops.constraints("Plain")
ops.numberer("Plain")
ops.system("BandGeneral")
ops.test("NormDispIncr", 1e-12, 10)
ops.algorithm("Linear")
ops.integrator("Newmark", 0.5, 0.25)
ops.analysis("Transient")

out = sys.argv[1] if len(sys.argv) > 1 else os.path.splitext(os.path.abspath(__file__))[0] + ".csv"
n_rows = int(round(duration / (dt * output_every)))
with open(out, "w") as fh:
    fh.write("time,u,v,a\\n")
    fh.write(f"0.0,{{ops.nodeDisp(2, 1)!r}},{{ops.nodeVel(2, 1)!r}},{{ops.nodeAccel(2, 1)!r}}\\n")
    for i in range(1, n_rows + 1):
        if ops.analyze(output_every, dt) != 0:
            sys.exit(f"OpenSees failed before t = {{i * output_every * dt}}")
        fh.write(f"{{ops.getTime()!r}},{{ops.nodeDisp(2, 1)!r}},{{ops.nodeVel(2, 1)!r}},"
                 f"{{ops.nodeAccel(2, 1)!r}}\\n")
ops.wipe()
print(f"wrote {{n_rows + 1}} rows to {{out}}; omega_n = {{math.sqrt(k / m):.6g}} rad/{T}")
'''


def script(sdof: Sdof, units: UnitSystem, duration: float, dt: float, output_dt: float,
           name: str = "sdof_opensees.py") -> str:
    """Standalone OpenSeesPy script for ``sdof`` in ``units``; times [s] are SI."""
    src = sdof.source
    prov = (f"Source: {src.get('folder', '?')} (summary.json sha256 "
            f"{str(src.get('summary_sha256', '?'))[:16]}...), posterior quantile "
            f"q = {src.get('quantile', 0.5):g}.\nIdentified (SI): m = {sdof.mass:.6g} kg, "
            f"k = {sdof.k:.6g} N/m, c = {sdof.c:.6g} N*s/m, u0 = {sdof.u0:.6g} m, "
            f"zeta = {sdof.zeta:.6g}, f_n = {sdof.omega_n / (2 * math.pi):.6g} Hz.")
    T = factor("time", units)
    fields: dict[str, Any] = {
        "version": src.get("dampfit_version") or "", "provenance": prov, "name": name,
        "L": units.label("length"), "T": units.label("time"), "M": units.label("mass"),
        "F": units.label("force"), "K": units.label("stiffness"), "C": units.label("damping"),
        "A": units.label("acceleration"),
        "m": sdof.mass * factor("mass", units), "k": sdof.k * factor("stiffness", units),
        "c": sdof.c * factor("damping", units), "u0": sdof.u0 * factor("length", units),
        "g": sdof.g * factor("acceleration", units), "duration": duration * T, "dt": dt * T,
        "every": max(1, round(output_dt / dt)),
        "steps_per_period": sdof.period / dt,
        "period_error": newmark_period_error(sdof.omega_n, dt),
    }
    return _TEMPLATE.format(**fields)
