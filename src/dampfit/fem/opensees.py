"""OpenSees model of the identified system: one OpenSeesPy script, exported and run.

:func:`script` writes the model as a standalone OpenSeesPy script (``dampfit export --format
opensees``); :func:`run_script` runs such a script text in an isolated child process and
reads its output, which is how ``dampfit verify`` (:mod:`dampfit.fem.verify`) and
:func:`free_decay` run OpenSees: the model exists once, as that script.

Model: a 1-D model (``-ndm 1 -ndf 1``), node 1 fixed, node 2 with the mass, one
``zeroLength`` element in direction 1 carrying two uniaxial materials in parallel —
``Elastic`` (k) and ``Viscous`` (c, α = 1: force = c·velocity). u is positive up; gravity, if
any, is a constant load −m·g on node 2, so the static equilibrium is at −s = −m·g/k.

Initial state: by default released at rest from ``−s + u0`` (u0 above static equilibrium);
the options ``--u-start``/``--v-start`` give another state (verify starts from the fitted
model's state at the window start). Set with ``setNodeDisp``/``setNodeVel`` and — necessary —
the consistent initial acceleration ``a(0) = (F − k·u(0) − c·v(0))/m`` with ``setNodeAccel``:
OpenSees' Newmark integrator takes the committed acceleration as a(0) and does not solve for
it, and a wrong a(0) leaves a first-order error (ΔtΔa/2 in the velocity) that no later step
removes.

Integration: Newmark average acceleration (γ = 1/2, β = 1/4), unconditionally stable, no
numerical damping, period elongation (ωΔt/2)/atan(ωΔt/2) − 1 ≈ (ωΔt)²/12
(:func:`dampfit.fem.timestep.newmark_period_error`).

Output: a CSV with the header ``time,u,v,a`` and one row per output step, every number
written with ``repr`` (it reads back as exactly the float64 OpenSees returned).
"""

from __future__ import annotations

import ctypes.util
import functools
import importlib
import importlib.util
import math
import os
import re
import subprocess
import tempfile
from collections.abc import Sequence
from typing import Any

import numpy as np

from dampfit._child import command
from dampfit.errors import InputError
from dampfit.fem.sanitize import python_comment, python_literal
from dampfit.fem.sdof import Sdof
from dampfit.fem.timestep import newmark_period_error
from dampfit.fem.units import UnitSystem, factor
from dampfit.fem.units import get as get_units

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
    of :func:`run_script` an isolated Python that imports nothing from the working folder,
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


#: The default file name of the exported script (``dampfit export --format opensees``).
SCRIPT_NAME = "sdof_opensees.py"
#: First line of the CSV the script writes.
CSV_HEADER = "time,u,v,a"
#: Longest CSV row the script writes [bytes]: four ``repr`` floats (≤ 24 characters each),
#: three commas and a newline — the bound on the output :func:`run_script` reads.
MAX_ROW_BYTES = 4 * 24 + 3 + 1

#: The transient analysis both runs of a script set up (linear Newmark, average acceleration:
#: unconditionally stable and without numerical damping).
_TRANSIENT = """\
ops.constraints("Plain")
ops.numberer("Plain")
ops.system("BandGeneral")
ops.test("NormDispIncr", 1e-12, 10)
ops.algorithm("Linear")
ops.integrator("Newmark", 0.5, 0.25)
ops.analysis("Transient")
"""


def _indent(text: str) -> str:
    return "".join(f"    {line}\n" for line in text.splitlines())


_TEMPLATE = '''\
"""OpenSeesPy model of an identified spring-damper-mass system (written by dampfit {version}).

{provenance}
The exact source folder and dampfit version are SOURCE_FOLDER and DAMPFIT_VERSION below.

Units: length {L}, time {T}, mass {M}, force {F} (k in {K}, c in {C}).
{damper_doc}Model: node 1 fixed, node 2 carries the mass m; a zeroLength element holds an Elastic (k)
and {damper_model} in parallel. u is positive up; with gravity the weight
-m*g is a constant load and the static equilibrium is at -m*g/k. Released at rest from u0
above static equilibrium, with the consistent initial acceleration (OpenSees' Newmark does
not compute it). Newmark average acceleration (gamma = 1/2, beta = 1/4) with a fixed step:
{steps_per_period:.0f} steps per period, period error {period_error:.2e}.

Run:  python {name}  [OUT.csv]   -> time, u, v, a of node 2 (default: next to this script)
Output: CSV, the header line {header}, then one row per output step: time [{T}], u [{L}]
(absolute: with gravity it includes the static sag), v [{L}/{T}], a [{A}], every number
written with repr (the exact float64). Options replace the defaults below:
  --u-start U --v-start V  initial displacement [{L}] and velocity [{L}/{T}] of node 2
                           (default: static equilibrium + u0, at rest)
  --dt DT --steps N        time step [{T}] and number of steps (default: dt, duration/dt)
  --every K                steps per output row (default: output_every)
(dampfit verify runs this exact script with these options: see verification.json.)
{modal_doc}"""
import argparse
import math
import os
import sys

SOURCE_FOLDER = {source_literal}  # result folder the system was read from
DAMPFIT_VERSION = {version_literal}  # dampfit version that wrote its summary.json
m = {m!r}  # mass [{M}]
k = {k!r}  # stiffness [{K}]
c = {c!r}  # {c_comment} [{C}]
{damper_values}u0 = {u0!r}  # release displacement above static equilibrium [{L}]
g = {g!r}  # gravity [{A}] (0: none)
duration = {duration!r}  # [{T}]
dt = {dt!r}  # time step [{T}]
output_every = {every}  # steps between output rows
{modal_values}
cli = argparse.ArgumentParser(description="Free decay of the mass; writes time,u,v,a as CSV.")
cli.add_argument("out", nargs="?", metavar="OUT.csv",
                 default=os.path.splitext(os.path.abspath(__file__))[0] + ".csv")
cli.add_argument("--u-start", type=float, default=-m * g / k + u0)  # static equilibrium + u0
cli.add_argument("--v-start", type=float, default=0.0)
cli.add_argument("--dt", type=float, default=dt)
cli.add_argument("--steps", type=int)
cli.add_argument("--every", type=int, default=output_every)
{modal_option}args = cli.parse_args()
finite = all(map(math.isfinite, (args.u_start, args.v_start, args.dt)))
if not (finite and args.dt > 0 and args.every >= 1):
    cli.error("--dt must be positive, --every at least 1, all numbers finite")
if args.steps is None:
    n_rows = int(round(duration / (args.dt * args.every)))
elif args.steps >= 0 and args.steps % args.every == 0:
    n_rows = args.steps // args.every
else:
    cli.error("--steps must be a non-negative multiple of --every")

import openseespy.opensees as ops  # after the options: --help and their errors need no OpenSees
{force_def}
{modal_run}ops.wipe()
ops.model("basic", "-ndm", 1, "-ndf", 1)
ops.node(1, 0.0)  # anchor
ops.node(2, 0.0)  # mass
ops.fix(1, 1)
ops.mass(2, m)
ops.uniaxialMaterial("Elastic", 1, k)
{damper_materials}ops.element("zeroLength", 1, 1, 2, "-mat", 1, 2, "-dir", 1, 1)  # spring || damper
weight = -m * g
if g > 0:
    ops.timeSeries("Constant", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(2, weight)
ops.setNodeDisp(2, 1, args.u_start, "-commit")
ops.setNodeVel(2, 1, args.v_start, "-commit")
ops.setNodeAccel(2, 1, (weight - k * args.u_start - {force_at_start}) / m, "-commit")
{transient}
with open(args.out, "w") as fh:
    fh.write("{header}\\n")
    fh.write(f"0.0,{{ops.nodeDisp(2, 1)!r}},{{ops.nodeVel(2, 1)!r}},{{ops.nodeAccel(2, 1)!r}}\\n")
    for i in range(1, n_rows + 1):
        if ops.analyze(args.every, args.dt) != 0:
            sys.exit(f"OpenSees failed before t = {{i * args.every * args.dt}}")
        fh.write(f"{{ops.getTime()!r}},{{ops.nodeDisp(2, 1)!r}},{{ops.nodeVel(2, 1)!r}},"
                 f"{{ops.nodeAccel(2, 1)!r}}\\n")
ops.wipe()
print(f"wrote {{n_rows + 1}} rows to {{args.out}}; omega_n = {{math.sqrt(k / m):.6g}} rad/{T}")
'''


#: Docstring lines of a script with several modes (before its closing quotes).
_MODAL_DOC = """
Several modes were measured: {n} modes, each with its own damping. --modal runs them instead
of the model above: {n} uncoupled oscillators (node i+1, unit mass, k_i = (2*pi*f_i)^2, a
zeroLength element with -doRayleigh 1) damped by Rayleigh damping alone,
ops.rayleigh(alphaM, betaK, 0, 0), each released at rest from u = 1 {L}; output: time, u1..u{n}.
Each mode then decays at p_i = alphaM/2 + betaK*(2*pi*f_i)^2/2 [1/{T}].
  --modal --modal-dt DT --modal-every K   step of the modal run and steps per output row
                           (default: modal_dt, the highest mode's T/200, and modal_every)
Per-mode damping instead of Rayleigh (OpenSees applies it to the residual only, so it needs
an iterating algorithm such as Newton, not Linear): ops.eigen({n}); ops.modalDamping(*modal_zeta)
{described}
"""
#: Constants of a script with several modes (after output_every).
_MODAL_VALUES = """modal_f = {f!r}  # natural frequencies of the measured modes [1/{T}]
modal_zeta = {zeta!r}  # their damping ratios (posterior medians) [1]
alphaM = {alpha!r}  # Rayleigh mass-proportional coefficient [1/{T}]
betaK = {beta!r}  # Rayleigh stiffness-proportional coefficient [{T}]
modal_dt = {modal_dt!r}  # time step of the --modal run [{T}]
modal_every = {modal_every}  # steps between output rows of the --modal run
"""
_MODAL_OPTION = """cli.add_argument("--modal", action="store_true",
                 help="run the measured modes with Rayleigh damping instead (see the docstring)")
cli.add_argument("--modal-dt", type=float, default=modal_dt)
cli.add_argument("--modal-every", type=int, default=modal_every)
"""
_MODAL_RUN = """if args.modal:  # the measured modes: uncoupled oscillators damped by Rayleigh alone
    every = args.modal_every
    if not (math.isfinite(args.modal_dt) and args.modal_dt > 0 and every >= 1):
        cli.error("--modal-dt must be a positive finite number, --modal-every at least 1")
    if args.steps is None:
        n_rows = int(round(duration / (args.modal_dt * every)))
    elif args.steps % every == 0:
        n_rows = args.steps // every
    else:
        cli.error("--steps must be a non-negative multiple of --modal-every")
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(1, 0.0)  # anchor of every oscillator
    ops.fix(1, 1)
    for i, f in enumerate(modal_f, start=1):
        k_i = (2.0 * math.pi * f) ** 2  # unit mass
        ops.node(1 + i, 0.0)
        ops.mass(1 + i, 1.0)
        ops.uniaxialMaterial("Elastic", i, k_i)
        ops.element("zeroLength", i, 1, 1 + i, "-mat", i, "-dir", 1, "-doRayleigh", 1)
        ops.setNodeDisp(1 + i, 1, 1.0, "-commit")
        ops.setNodeAccel(1 + i, 1, -k_i, "-commit")  # at rest: no damping force
    ops.rayleigh(alphaM, betaK, 0.0, 0.0)
""" + _indent(_TRANSIENT) + """    nodes = range(2, len(modal_f) + 2)
    with open(args.out, "w") as fh:
        fh.write("time," + ",".join(f"u{i}" for i in range(1, len(modal_f) + 1)) + "\\n")
        fh.write("0.0," + ",".join(repr(ops.nodeDisp(n, 1)) for n in nodes) + "\\n")
        for i in range(1, n_rows + 1):
            if ops.analyze(every, args.modal_dt) != 0:
                sys.exit(f"OpenSees failed before t = {i * every * args.modal_dt}")
            fh.write(repr(ops.getTime()) + "," + ",".join(repr(ops.nodeDisp(n, 1))
                                                           for n in nodes) + "\\n")
    ops.wipe()
    print(f"wrote {n_rows + 1} rows of {len(modal_f)} modes to {args.out}")
    sys.exit(0)

"""


def _modal_fields(modal: dict[str, Any] | None, units: UnitSystem, duration: float,
                  output_dt: float, label) -> dict[str, str]:
    """The four insertions of a script with several modes (empty strings for one mode, so
    its text stays what it was): docstring, constants, options and the ``--modal`` run."""
    if modal is None:
        return dict.fromkeys(("modal_doc", "modal_values", "modal_option", "modal_run"), "")
    from dampfit.fem import modal as modal_mod

    ff, ft = factor("frequency", units), factor("time", units)
    f = [float(r["f_n"]["q50"] * ff) for r in modal["modes"]]
    zeta = [float(r["zeta"]["q50"]) for r in modal["modes"]]
    alpha, beta = float(modal["alpha"]["q50"] * ff), float(modal["beta"]["q50"] * ft)
    w_max = 2 * math.pi * max(r["f_n"]["q50"] for r in modal["modes"])
    step = modal_step(w_max, output_dt)
    modal_dt, modal_every = float(step * ft), int(max(1, round(output_dt / step)))
    for key, v in (("alpha", alpha), ("beta", beta), ("modal_dt", modal_dt), *zip(
            ("f",) * len(f), f), *zip(("zeta",) * len(zeta), zeta)):
        if not math.isfinite(v):
            raise InputError(f"{key} = {v!r} in {units.name} units is not a finite number")
    described = "\n".join(python_comment(t, None) for t in modal_mod.describe(modal))
    return {"modal_doc": _MODAL_DOC.format(n=len(f), L=label("length"), T=label("time"),
                                           described=described),
            "modal_values": _MODAL_VALUES.format(f=f, zeta=zeta, alpha=alpha, beta=beta,
                                                 modal_dt=modal_dt, modal_every=modal_every,
                                                 T=label("time")),
            "modal_option": _MODAL_OPTION,
            "modal_run": _MODAL_RUN}


def modal_step(omega_max: float, output_dt: float) -> float:
    """Step [s] of the ``--modal`` run: T/200 of the highest mode ``omega_max`` [rad/s], made
    to divide ``output_dt`` [s] (:func:`dampfit.fem.timestep.choose` without a phase demand)."""
    from dampfit.fem.timestep import MIN_STEPS_PER_PERIOD

    dt_max = 2 * math.pi / omega_max / MIN_STEPS_PER_PERIOD
    return output_dt / math.ceil(output_dt / dt_max * (1.0 - 1e-12))


def script(sdof: Sdof, units: UnitSystem, times: tuple[float, float, float], *,
           name: str = SCRIPT_NAME, modal: dict[str, Any] | None = None,
           damper: Any = None, header: Sequence[str] = ()) -> str:
    """Standalone OpenSeesPy script for ``sdof`` in ``units``; ``times`` = (duration, dt,
    output_dt) [s] are SI.

    ``modal`` (:func:`dampfit.fem.modal.modal_damping` of a summary with several modes) adds
    the ``--modal`` run of the measured modes with Rayleigh damping (:data:`_MODAL_RUN`);
    without it the text is exactly the one-mode script.
    ``damper`` (:class:`dampfit.fem.damper.Damper`) sets the damper material
    (:func:`dampfit.fem.damper.opensees_fields`; none: Viscous c, alpha = 1) and ``header``
    the sentences at the top of the docstring (sanitised).

    Text from outside (the source folder, the dampfit version of the summary, ``name``) is
    written into the docstring only through :func:`~dampfit.fem.sanitize.python_comment` and
    kept exactly as ``repr`` literals (SOURCE_FOLDER, DAMPFIT_VERSION): nothing a folder name
    or an edited summary.json holds can become code.
    """
    duration, dt, output_dt = times
    src = sdof.source
    folder = str(src.get("folder", "?"))
    version = src.get("dampfit_version") or ""
    nonlinear = damper is not None and damper.nonlinear
    cname = "c_eq (linear c at the design amplitude, not in the model)" if nonlinear else "c"
    prov = (f"Source: {python_comment(folder)} (summary.json sha256 "
            f"{python_comment(str(src.get('summary_sha256', '?'))[:16])}...), posterior quantile "
            f"q = {float(src.get('quantile', 0.5)):g}.\nIdentified (SI): m = {sdof.mass:.6g} kg, "
            f"k = {sdof.k:.6g} N/m, {cname} = {sdof.c:.6g} N*s/m, u0 = {sdof.u0:.6g} m, "
            f"zeta = {sdof.zeta:.6g}, f_n = {sdof.omega_n / (2 * math.pi):.6g} Hz.")
    T = factor("time", units)
    # unit names also land in an f-string of the script: no braces
    label = lambda q: python_comment(units.label(q), 40).replace("{", "(").replace("}", ")")  # noqa: E731
    fields: dict[str, Any] = {
        "version": python_comment(version, 80), "provenance": prov,
        "name": python_comment(name, 200), "header": CSV_HEADER,
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
    fields.update(_modal_fields(modal, units, duration, output_dt, label))
    from dampfit.fem.damper import opensees_fields

    fields.update(opensees_fields(damper, units, k=fields["k"]))
    if header:
        fields["damper_doc"] = "".join(python_comment(t, None) + "\n" for t in header) + "\n"
    for key in ("m", "k", "c", "u0", "g", "duration", "dt"):
        if not math.isfinite(fields[key]):
            raise InputError(f"{key} = {fields[key]!r} in {units.name} units is not a finite number")
    transient = _TRANSIENT if damper is None or not damper.nonlinear else _TRANSIENT.replace(
        'ops.test("NormDispIncr", 1e-12, 10)\nops.algorithm("Linear")',
        'ops.test("NormDispIncr", 1e-12 * max(math.hypot(args.u_start + m * g / k, '
        'args.v_start * math.sqrt(m / k)), 1e-300), 50)  # relative to the start amplitude\n'
        'ops.algorithm("Newton")  # the damper is nonlinear: iterate each step')
    return _TEMPLATE.format(transient=transient, **fields)


def run_script(text: str, options: Sequence[str], rows: int,
               name: str = SCRIPT_NAME) -> dict[str, np.ndarray]:
    """Run the script ``text`` (as :func:`script` wrote it) with the command-line ``options``
    and read the CSV it writes: ``t``, ``u``, ``v``, ``a`` of node 2 in the script's units,
    ``rows`` entries each (the initial state and one per output row).

    The text is written byte for byte (UTF-8, as ``dampfit export`` writes it) as ``name``
    into a private temporary folder and run there as ``python -I … name OUT.csv OPTIONS`` in
    an isolated child (:func:`dampfit._child.command`: nothing is imported from the working
    folder), which ends with ``os._exit`` so that OpenSees' "Process 0 Terminating" never
    reaches this process's standard error. Its standard output and error go to files of that
    folder; only the last 4 kB of the error are read (the message of a failure), and the CSV
    only if it is at most ``rows`` × :data:`MAX_ROW_BYTES` long. :class:`InputError` if
    OpenSeesPy is unusable; :class:`RuntimeError` if the run fails or its output is not what
    the script writes.
    """
    data = _execute(text, options, rows, name, CSV_HEADER, 4)
    return {"t": data[:, 0], "u": data[:, 1], "v": data[:, 2], "a": data[:, 3]}


def _execute(text: str, options: Sequence[str], rows: int, name: str, header: str,
             columns: int) -> np.ndarray:
    """Run the script ``text`` in an isolated child (see :func:`run_script`) and read the
    ``rows`` × ``columns`` numbers of the CSV it writes under ``header``."""
    reason = unavailable()
    if reason is not None:  # not installed, or its BLAS/LAPACK libraries are missing
        raise InputError(reason)
    if os.path.basename(name) != name or name in ("", ".", ".."):
        raise ValueError(f"the script name must be a plain file name, got {name!r}")
    with tempfile.TemporaryDirectory(prefix="dampfit-opensees-") as tmp:
        path, out = os.path.join(tmp, name), os.path.join(tmp, "response.csv")
        with open(path, "wb") as fh:
            fh.write(text.encode("utf-8"))
        err = os.path.join(tmp, "stderr.txt")
        with open(os.path.join(tmp, "stdout.txt"), "wb") as so, open(err, "wb") as se:
            proc = subprocess.run(command(_RUN_CODE) + [path, out, *options], cwd=tmp,
                                  stdin=subprocess.DEVNULL, stdout=so, stderr=se, check=False)
        if proc.returncode != 0:
            raise RuntimeError(f"OpenSees run failed (exit {proc.returncode}): {_last_line(err)}")
        return _read_response(out, rows, header, columns)


def run_modal(text: str, n_modes: int, modal_dt: float, n_steps: int, every: int = 1,
              name: str = SCRIPT_NAME) -> dict[str, np.ndarray]:
    """Run the ``--modal`` model of a script with several modes (:func:`script` with
    ``modal``) for ``n_steps`` steps of ``modal_dt`` (script units), a row every ``every``
    steps: ``t`` (``modal_dt``·steps) and ``u`` (rows × ``n_modes``, each oscillator released
    at rest from 1 length unit) and ``options`` (what it ran with)."""
    if n_steps % every:
        raise ValueError("n_steps must be a multiple of every")
    options = ["--modal", f"--modal-dt={float(modal_dt)!r}", f"--modal-every={int(every)}",
               f"--steps={int(n_steps)}", "--every=1"]
    header = "time," + ",".join(f"u{i}" for i in range(1, n_modes + 1))
    rows = int(n_steps) // int(every) + 1
    data = _execute(text, options, rows, name, header, n_modes + 1)
    t = float(modal_dt) * every * np.arange(rows)
    if not np.all(np.abs(data[:, 0] - t) <= 0.5 * modal_dt):
        raise RuntimeError("the OpenSees output rows are not the steps of the run")
    return {"t": t, "u": data[:, 1:], "options": options}


#: Child process of :func:`run_script`: ``sys.argv[1:]`` = the script's path, then its own
#: arguments; runs it as ``__main__`` and ends with ``os._exit`` (OpenSees then prints nothing).
_RUN_CODE = """\
import os, runpy, sys
sys.argv = sys.argv[1:]
code = 0
try:
    runpy.run_path(sys.argv[0], run_name="__main__")
except SystemExit as exc:
    if exc.code not in (None, 0):
        code = exc.code if isinstance(exc.code, int) else 1
        if not isinstance(exc.code, int):
            sys.stderr.write(f"{exc.code}\\n")
except BaseException as exc:
    sys.stderr.write(f"{type(exc).__name__}: {exc}\\n")
    code = 1
sys.stdout.flush()
sys.stderr.flush()
os._exit(code)
"""


def _last_line(path: str, limit: int = 4096) -> str:
    """The last non-blank line of the end (``limit`` bytes) of the text file ``path``."""
    with open(path, "rb") as fh:
        fh.seek(max(0, os.fstat(fh.fileno()).st_size - limit))
        lines = fh.read(limit).decode("utf-8", "replace").strip().splitlines() or ["no message"]
    return " ".join(lines[-1].split())[:200]


def _read_response(path: str, rows: int, header: str = CSV_HEADER,
                   columns: int = 4) -> np.ndarray:
    """The ``rows`` × ``columns`` numbers of the CSV the script wrote to ``path`` under the
    line ``header`` (size checked first: ``repr`` floats of at most 24 characters)."""
    limit = len(header) + 1 + rows * (columns * 25)
    try:
        size = os.stat(path).st_size
    except OSError:
        raise RuntimeError("the OpenSees script wrote no output") from None
    if size > limit:
        raise RuntimeError(f"the OpenSees script wrote {size} bytes, more than {rows} rows hold")
    with open(path, encoding="ascii", errors="replace") as fh:
        if fh.readline().strip() != header:
            raise RuntimeError(f"the OpenSees output does not start with {header!r}")
        data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=float)
    if data.shape != (rows, columns):
        raise RuntimeError(f"the OpenSees script wrote {data.shape[0]} rows of {data.shape[1]} "
                           f"numbers, not {rows} of {columns}")
    return data


def free_decay(mass: float, k: float, c: float, u_init: float, v_init: float, dt: float,
               n_steps: int, force: float = 0.0) -> dict[str, np.ndarray]:
    """Run the model in OpenSeesPy; every step's ``t`` [s], ``u`` [m], ``v`` [m/s], ``a`` [m/s²].

    ``mass`` [kg], ``k`` [N/m], ``c`` [N·s/m] (any consistent units work), initial
    displacement ``u_init`` and velocity ``v_init`` of node 2, fixed step ``dt``, ``n_steps``
    steps, constant external ``force`` ≤ 0 on the mass (a weight −m·g). Arrays have
    n_steps + 1 entries.

    It runs the script :func:`script` writes for this system (SI, gravity g = −force/m)
    through :func:`run_steps`: OpenSees keeps global state and prints "Process 0 Terminating"
    at the exit of a process that imported it, so it never runs in this one.
    """
    if not (math.isfinite(force) and force <= 0):
        raise InputError(f"force must be a finite weight <= 0 [N], got {force!r}")
    n_steps = int(n_steps)
    sdof = Sdof(mass=mass, k=k, c=c, u0=u_init - force / k, g=-force / mass if force else 0.0)
    text = script(sdof, get_units("SI"), (n_steps * dt, dt, dt))
    res = run_steps(text, u_init, v_init, dt, n_steps)
    return {key: res[key] for key in ("t", "u", "v", "a")}


def step_options(u_start: float, v_start: float, dt: float, n_steps: int) -> list[str]:
    """The options that make the script run ``n_steps`` steps of ``dt`` from the state
    (``u_start``, ``v_start``) with a row per step (values in the script's units, written
    with ``repr``: the script reads back exactly these float64 numbers)."""
    return [f"--u-start={float(u_start)!r}", f"--v-start={float(v_start)!r}",
            f"--dt={float(dt)!r}", f"--steps={int(n_steps)}", "--every=1"]


def run_steps(text: str, u_start: float, v_start: float, dt: float, n_steps: int,
              name: str = SCRIPT_NAME) -> dict[str, Any]:
    """Run the script ``text`` for ``n_steps`` steps of ``dt`` from (``u_start``,
    ``v_start``), a row per step (:func:`step_options`, :func:`run_script`; the script's
    units): ``t``, ``u``, ``v``, ``a`` (n_steps + 1 entries) and ``options`` (what it ran with).

    ``t`` is ``dt·i`` at step i: the state of row i is the state after i steps of ``dt``,
    while the script's time column is OpenSees' running sum of ``dt`` (it drifts by about
    i·ε·t); that column is only checked to lie within ``dt``/2 of ``dt·i``.
    """
    options = step_options(u_start, v_start, dt, n_steps)
    res = run_script(text, options, int(n_steps) + 1, name)
    steps = float(dt) * np.arange(int(n_steps) + 1)
    if not np.all(np.abs(res["t"] - steps) <= 0.5 * dt):
        raise RuntimeError("the OpenSees output rows are not the steps of the run")
    return {**res, "t": steps, "options": options}
