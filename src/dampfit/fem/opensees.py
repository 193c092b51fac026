"""OpenSees model of the identified system: an exported OpenSeesPy script and a run in a child process.

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

import ctypes.util
import functools
import importlib
import importlib.util
import json
import math
import re
import subprocess
from typing import Any

import numpy as np

from dampfit._child import command
from dampfit.errors import InputError
from dampfit.fem.sanitize import python_comment, python_literal
from dampfit.fem.sdof import Sdof
from dampfit.fem.timestep import newmark_period_error
from dampfit.fem.units import UnitSystem, factor

__all__ = ["BLAS_REASON", "NOT_INSTALLED_REASON", "engine_version", "free_decay", "script",
           "unavailable"]

#: Why OpenSeesPy cannot run when its binary misses the system BLAS/LAPACK (Debian packages).
BLAS_REASON = ("OpenSeesPy needs the system BLAS/LAPACK libraries: "
               "sudo apt-get install libblas3 liblapack3")
#: Why OpenSeesPy cannot run when it is not installed.
NOT_INSTALLED_REASON = "OpenSeesPy is not installed: pip install 'dampfit[fem]'"


def unavailable() -> str | None:
    """``None`` if OpenSeesPy can be imported, else a one-line reason with the remedy.

    The reasons: not installed (:data:`NOT_INSTALLED_REASON`); its binary cannot load
    ``libblas.so.3``/``liblapack.so.3`` (:data:`BLAS_REASON`; OpenSeesPy hides the loader's
    message behind "Failed to import openseespy on Linux", so the exception chain is searched,
    and ``ctypes.util.find_library`` decides if the chain says nothing); another shared library
    missing; any other import failure.

    The import is tried in a child process (:func:`_probe`, once per process; like the run
    of :func:`free_decay` an isolated Python that imports nothing from the working folder,
    :func:`dampfit._child.command`): OpenSees'
    native code prints "Process 0 Terminating" on the standard error at the exit of any
    process that imported it, which would break the CLI's one-line error contract.
    """
    try:
        found = importlib.util.find_spec("openseespy") is not None
    except (ImportError, ValueError):
        found = False
    if not found:
        return NOT_INSTALLED_REASON
    return _probe()


#: Child process of :func:`_probe`: exit 0 if OpenSeesPy imports, else print the reason, exit 3
#: (``os._exit``: no interpreter shutdown, so OpenSees prints nothing at exit).
_PROBE_CODE = """\
import os, sys
try:
    import openseespy.opensees
except Exception as exc:
    from dampfit.fem.opensees import _reason
    sys.stdout.write(_reason(exc)); sys.stdout.flush(); os._exit(3)
os._exit(0)
"""


@functools.lru_cache(maxsize=1)
def _probe() -> str | None:
    """Import OpenSeesPy in a child process: ``None`` if it works, else the one-line reason."""
    try:
        proc = subprocess.run(command(_PROBE_CODE), capture_output=True, text=True,
                              timeout=300, stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"OpenSeesPy could not be tried in a child process ({type(exc).__name__}: {exc})"
    if proc.returncode == 0:
        return None
    reason = " ".join(proc.stdout.split())
    if proc.returncode == 3 and reason:
        return reason
    last = " ".join((proc.stderr.strip().splitlines() or ["no message"])[-1].split())[:160]
    return (f"OpenSeesPy cannot be imported (exit {proc.returncode}: {last}); reinstall it: "
            "pip install --force-reinstall 'dampfit[fem]'")


def _reason(exc: BaseException) -> str:
    """One-line reason for an OpenSeesPy import failure ``exc`` (searching its chain)."""
    texts, seen, e = [], set(), exc
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        texts.append(f"{type(e).__name__}: {e}")
        e = e.__cause__ or e.__context__
    chain = " | ".join(texts)
    if re.search(r"lib(blas|lapack)\.so", chain):
        return BLAS_REASON
    lib = re.search(r"([\w.+-]+\.so[\w.]*): cannot open shared object file", chain)
    if lib:
        return (f"OpenSeesPy cannot load the system library {lib.group(1)}: install the "
                "package that provides it (Debian: apt-file search " + lib.group(1) + ")")
    if ctypes.util.find_library("blas") is None or ctypes.util.find_library("lapack") is None:
        return BLAS_REASON
    last = " ".join(texts[-1].split())[:160]
    return (f"OpenSeesPy cannot be imported ({last}); reinstall it: "
            "pip install --force-reinstall 'dampfit[fem]'")


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

    The analysis runs in a child process (:func:`_run_child`): OpenSees keeps global state and
    prints "Process 0 Terminating" on the standard error at the exit of a process that
    imported it; the child ends with ``os._exit`` and its standard error is captured. The
    arrays come back as raw float64 bytes on the child's standard output (3·(n_steps + 1)·8
    bytes, the size of the result itself).
    """
    reason = unavailable()
    if reason is not None:  # not installed, or its BLAS/LAPACK libraries are missing
        raise InputError(reason)
    params = {"mass": mass, "k": k, "c": c, "u_init": u_init, "v_init": v_init, "dt": dt,
              "n_steps": int(n_steps), "force": force}
    proc = subprocess.run(command(_RUN_CODE), input=json.dumps(params).encode(),
                          capture_output=True, check=False)
    n = int(n_steps) + 1
    if proc.returncode != 0 or len(proc.stdout) != 3 * n * 8:
        lines = proc.stderr.decode("utf-8", "replace").strip().splitlines() or ["no message"]
        raise RuntimeError(f"OpenSees run failed (exit {proc.returncode}): "
                           f"{' '.join(lines[-1].split())[:200]}")
    u, v, a = np.frombuffer(proc.stdout, dtype="<f8").reshape(3, n)
    return {"t": dt * np.arange(n), "u": u, "v": v, "a": a}


#: Child process of :func:`free_decay`: parameters as JSON on stdin, u, v, a as float64 bytes
#: on stdout; ``os._exit`` so that OpenSees prints nothing at exit.
_RUN_CODE = """\
import json, os, sys
try:
    from dampfit.fem.opensees import _run_child
    res = _run_child(**json.loads(sys.stdin.buffer.read()))
    for key in ("u", "v", "a"):
        sys.stdout.buffer.write(res[key].astype("<f8").tobytes())
    sys.stdout.buffer.flush()
except BaseException as exc:
    sys.stderr.write(f"{type(exc).__name__}: {exc}\\n"); sys.stderr.flush(); os._exit(1)
os._exit(0)
"""


def _run_child(mass: float, k: float, c: float, u_init: float, v_init: float, dt: float,
               n_steps: int, force: float = 0.0) -> dict[str, np.ndarray]:
    """The OpenSees analysis of :func:`free_decay`, in this process (used by its child)."""
    import openseespy.opensees as ops  # lazy: heavy, and global state

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
The exact source folder and dampfit version are SOURCE_FOLDER and DAMPFIT_VERSION below.

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

SOURCE_FOLDER = {source_literal}  # result folder the system was read from
DAMPFIT_VERSION = {version_literal}  # dampfit version that wrote its summary.json
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
    """Standalone OpenSeesPy script for ``sdof`` in ``units``; times [s] are SI.

    Text from outside (the source folder, the dampfit version of the summary, ``name``) is
    written into the docstring only through :func:`~dampfit.fem.sanitize.python_comment` and
    kept exactly as ``repr`` literals (SOURCE_FOLDER, DAMPFIT_VERSION): nothing a folder name
    or an edited summary.json holds can become code.
    """
    src = sdof.source
    folder = str(src.get("folder", "?"))
    version = src.get("dampfit_version") or ""
    prov = (f"Source: {python_comment(folder)} (summary.json sha256 "
            f"{python_comment(str(src.get('summary_sha256', '?'))[:16])}...), posterior quantile "
            f"q = {float(src.get('quantile', 0.5)):g}.\nIdentified (SI): m = {sdof.mass:.6g} kg, "
            f"k = {sdof.k:.6g} N/m, c = {sdof.c:.6g} N*s/m, u0 = {sdof.u0:.6g} m, "
            f"zeta = {sdof.zeta:.6g}, f_n = {sdof.omega_n / (2 * math.pi):.6g} Hz.")
    T = factor("time", units)
    # unit names also land in an f-string of the script: no braces
    label = lambda q: python_comment(units.label(q), 40).replace("{", "(").replace("}", ")")  # noqa: E731
    fields: dict[str, Any] = {
        "version": python_comment(version, 80), "provenance": prov,
        "name": python_comment(name, 200),
        "source_literal": python_literal(folder), "version_literal": python_literal(version),
        "L": label("length"), "T": label("time"), "M": label("mass"),
        "F": label("force"), "K": label("stiffness"), "C": label("damping"),
        "A": label("acceleration"),
        "m": float(sdof.mass * factor("mass", units)), "k": float(sdof.k * factor("stiffness", units)),
        "c": float(sdof.c * factor("damping", units)), "u0": float(sdof.u0 * factor("length", units)),
        "g": float(sdof.g * factor("acceleration", units)), "duration": float(duration * T),
        "dt": float(dt * T), "every": int(max(1, round(output_dt / dt))),
        "steps_per_period": sdof.period / dt,
        "period_error": newmark_period_error(sdof.omega_n, dt),
    }
    for key in ("m", "k", "c", "u0", "g", "duration", "dt"):
        if not math.isfinite(fields[key]):
            raise InputError(f"{key} = {fields[key]!r} in {units.name} units is not a finite number")
    return _TEMPLATE.format(**fields)
