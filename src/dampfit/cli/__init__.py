"""Command-line interface: ``dampfit analyze | simulate | demo``.

Exit codes: 0 success (including a flagged, non-converged posterior), 2 bad input or usage
(one line on stderr, no traceback, nothing written), 1 unexpected internal error, 130/143
interrupted (Ctrl-C / SIGTERM; nothing half-written is left behind).

Every option is checked before any work: numbers must be finite and physically sensible (a
positive mass of at most 10⁶ kg, a seed in [0, 2³²), ``--window START END`` with START < END,
``--band LO HI`` with 0 < LO < HI, …).

Result folders (``analyze``, ``demo``) are handled by :class:`dampfit._files.ResultFolder`:

* each holds a marker file ``.dampfit-result`` (JSON: kind, dampfit version);
* ``--force`` replaces an existing ``--out`` only if it is a real directory (not a symbolic
  link) with that marker, and never the current folder, one of its parents, or the input
  file's folder or one of its parents; anything else is refused (exit 2) and left untouched;
* a lock file ``.NAME.dampfit-lock`` beside the folder keeps a second dampfit process writing
  the same ``--out`` away (it fails at once, exit 2);
* before the analysis the parent folder is checked for write permission and free space; the
  result is written into a staging folder ``.NAME.dampfit-stage-PID-XXXX`` beside the target
  and moved into place only when complete, so an old result is never half-overwritten; a
  failed write (full disk, read-only folder) is one line, exit 2, with the old result intact.
  Staging folders of killed dampfit processes are removed by the next run to the same target.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import os
import signal
import stat
import sys
import threading
import traceback
import warnings
from pathlib import Path
from collections.abc import Sequence

from dampfit._files import MIN_FREE, ResultFolder
from dampfit.errors import DampfitError, InputError

__all__ = ["main", "run", "get_parser"]

DEMO_MASS_SD = 0.02  # [kg] mass uncertainty used by the demo (a kitchen scale)
DEMO_MARKER = "paper-preset.truth.json"  # file of a demo folder (one without .dampfit-result)

#: Largest mass [kg] accepted: far above any spring–mass test, far below overflow.
MAX_MASS = 1e6
#: Largest seed + 1 (numpy and the sampler take 32-bit seeds).
SEED_LIMIT = 2**32
#: Largest --max-steps: the stored chain grows with it (10⁶ steps × 64 walkers ≈ 2 GB).
MAX_STEPS = 10**6
#: Largest simulated recording [samples] (duration × sample rate): ≈ 2 GB of arrays.
MAX_SIM_SAMPLES = 5e7


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(f"{message} (see '{self.prog} --help')")


def _real(what: str = "a finite number", ok=None):
    """argparse type: a finite float for which ``ok(value)`` holds, else 'must be WHAT'."""

    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(v) or (ok is not None and not ok(v)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return v

    return conv


def _integer(lo: int, hi: int, what: str | None = None):
    """argparse type: an integer in [lo, hi]."""

    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(
                f"must be {what or f'an integer from {lo} to {hi}'}, got {v}")
        return v

    return conv


#: argparse type for a float option with a one-line error (shared by the sub-command modules):
#: a finite number (NaN and ±inf are refused).
float_arg = _real()
#: argparse type of every ``--seed``: an integer in [0, 2³²).
seed_arg = _integer(0, SEED_LIMIT - 1, f"an integer from 0 to {SEED_LIMIT - 1}")

_positive = _real("a positive finite number", lambda v: v > 0)
_non_negative = _real("a finite number ≥ 0", lambda v: v >= 0)
_mass = _real("a positive mass in kg (at most 1e6)", lambda v: 0 < v <= MAX_MASS)


def get_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``dampfit`` command."""
    p = _Parser(prog="dampfit", description=(
        "Damping coefficient c [N s/m], stiffness k [N/m] and initial amplitude u0 [m] "
        "from a free-decay accelerometer recording, with a Bayesian posterior."))
    from dampfit import __version__

    p.add_argument("--version", action="version", version=f"dampfit {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    a = sub.add_parser("analyze", help="analyse a recording: summary.json, posterior.nc, figures")
    a.add_argument("file", help="recording: phyphox CSV/ZIP/XLSX, Sensor Logger CSV, CSV/TXT, NPY/NPZ, MATLAB .mat")
    _analysis_options(a)
    a.add_argument("--out", metavar="DIR", help="output directory (default: FILE's name + '.dampfit')")
    a.add_argument("--force", action="store_true",
                   help="replace an existing output directory that dampfit wrote")
    g = a.add_argument_group("reading (generic CSV/NPY, MATLAB)")
    g.add_argument("--time-column", metavar="COL", help="time column name or 0-based index")
    g.add_argument("--accel-columns", metavar="COL", nargs="+", help="acceleration column(s)")
    g.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column")
    g.add_argument("--accel-unit", choices=["m/s2", "g"], help="unit of the acceleration")
    g.add_argument("--sheet", help="Excel sheet name")
    g.add_argument("--variable", metavar="PATH",
                   help="MATLAB .mat: the array to read, e.g. Fe.Out.Acc (default: detected)")
    g.add_argument("--row", type=_integer(0, 1023), metavar="N",
                   help="MATLAB .mat: 0-based row of that array holding the acceleration")

    s = sub.add_parser("simulate", help="write a synthetic phyphox CSV with known truth")
    s.add_argument("--preset", default="paper", help="starting configuration: paper | phone")
    s.add_argument("--mass", type=_mass, metavar="KG", help="oscillating mass [kg]")
    s.add_argument("--f-n", type=_positive, metavar="HZ", help="natural frequency [Hz]")
    s.add_argument("--zeta", type=_real("a damping ratio in [0, 1)", lambda v: 0 <= v < 1),
                   metavar="Z", help="damping ratio [1], 0 ≤ ZETA < 1")
    s.add_argument("--u0", type=_real("a displacement in [0, 100] m", lambda v: 0 <= v <= 100),
                   metavar="M", help="initial displacement [m]")
    s.add_argument("--duration", type=_positive, metavar="S", help="record length [s]")
    s.add_argument("--sample-rate", type=_positive, metavar="HZ",
                   help=f"sample rate [Hz]; duration × sample rate ≤ {MAX_SIM_SAMPLES:g} samples")
    s.add_argument("--jitter", type=_real("a coefficient of variation in [0, 1]",
                                          lambda v: 0 <= v <= 1), metavar="CV")
    s.add_argument("--noise-density", type=_non_negative, metavar="UG", help="µg/√Hz")
    s.add_argument("--drift", type=_non_negative, metavar="MS2", help="bias drift rms [m/s²]")
    s.add_argument("--tilt", type=_real("an angle in [-90, 90] degrees", lambda v: abs(v) <= 90),
                   metavar="DEG")
    s.add_argument("--handheld", type=_non_negative, metavar="S")
    s.add_argument("--gravity", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--catch", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--dialect", default="comma", choices=["comma", "tab", "semicolon"])
    s.add_argument("--seed", type=seed_arg, default=0)
    s.add_argument("--out", required=True, metavar="FILE.csv")
    s.add_argument("--force", action="store_true",
                   help="overwrite existing files FILE.csv and FILE.truth.json")

    d = sub.add_parser("demo", help="simulate the paper's set-up and analyse it (the main job)")
    d.add_argument("--out", default="dampfit-demo", metavar="DIR",
                   help="output directory (a previous demo's folder is regenerated)")
    d.add_argument("--force", action="store_true",
                   help="replace an existing output directory that dampfit wrote")
    d.add_argument("--seed", type=seed_arg, default=0)
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.add_argument("--no-figures", action="store_true")
    d.add_argument("--report", action="store_true", help="also write report.html and report.md")

    # commands implemented in their own modules: each provides add_arguments(parser) and
    # command(args) -> exit code; those modules keep heavy imports (jax, dask, openseespy)
    # inside functions so that building the parser stays fast
    for name, help_, module in _EXTERNAL:
        sp = sub.add_parser(name, help=help_)
        _load(module).add_arguments(sp)
    return p


#: (command, help, module) of the commands that live outside this file.
_EXTERNAL = (
    ("report", "write report.html and report.md for a result folder", "output.report"),
    ("export", "write an FEM deck (LS-DYNA, OpenSees, CalculiX) of the identified system", "fem.export"),
    ("verify", "run the identified system in OpenSeesPy and compare with the measurement", "fem.verify"),
    ("study", "simulation study comparing damping estimators (Dask, resumable)", "study"),
)


def _load(module: str):
    import importlib

    return importlib.import_module(f"dampfit.{module}")


def _analysis_options(a: argparse.ArgumentParser) -> None:
    a.add_argument("--mass", type=_mass, metavar="KG", help="oscillating mass [kg]")
    a.add_argument("--mass-sd", type=_real("a standard deviation ≥ 0 kg", lambda v: v >= 0),
                   metavar="KG", default=None, help="standard deviation of the mass [kg]")
    a.add_argument("--axis", default="auto", help="x, y, z, another column name, or auto")
    a.add_argument("--window", nargs=2, type=_real("a finite time [s]"), metavar=("START", "END"),
                   help="free-decay window [s] in the recording's time base, START < END")
    a.add_argument("--band", nargs=2, type=_real("a positive frequency [Hz]", lambda v: v > 0),
                   metavar=("LO", "HI"), help="pass band [Hz] around the oscillation, 0 < LO < HI")
    a.add_argument("--seed", type=seed_arg, default=0,
                   help=f"random seed of the sampler, 0 to {SEED_LIMIT - 1}")
    a.add_argument("--max-steps", type=_integer(1, MAX_STEPS), default=20000,
                   help=f"sampler step limit, 1 to {MAX_STEPS}")
    a.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    a.add_argument("--json", action="store_true", help="print summary.json instead of the table")
    a.add_argument("--quiet", action="store_true", help="no progress bar")
    a.add_argument("--report", action="store_true", help="also write report.html and report.md")
    a.add_argument("--model", default="auto",
                   choices=["auto", "viscous", "coulomb", "quadratic", "power"],
                   help="damping law reported as c_equivalent (auto: the one the evidence "
                        "prefers); all are compared in model_checks either way")
    a.add_argument("--amplitude", type=_real("a positive displacement amplitude in metres",
                                             lambda v: v > 0), metavar="M",
                   help="displacement amplitude [m] at which a non-viscous law's equivalent "
                        "viscous c is reported (the amplitude your FEM model will see)")


# ----------------------------------------------------------------------- outputs
#: Every file an old demo folder (written before the .dampfit-result marker) can hold.
_DEMO_FILES = frozenset({
    DEMO_MARKER, "paper-preset.csv", "summary.json", "posterior.nc", "signals.npz",
    "report.html", "report.md",
    *(f"{n}.png" for n in ("signal", "spectrum", "fit", "displacement", "posterior", "trace",
                           "amplitude"))})


def _old_demo_folder(folder: Path) -> bool:
    """An old demo's folder: only regular files, all of names a demo writes, its truth file among them."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return False
    names = set()
    for entry in entries:
        if not entry.is_file(follow_symlinks=False):
            return False
        names.add(entry.name)
    return DEMO_MARKER in names and names <= _DEMO_FILES


def _result_folder(out: Path, kind: str, force: bool, inputs=(), **kw) -> ResultFolder:
    """The :class:`~dampfit._files.ResultFolder` of a result written to ``out``."""
    from dampfit import __version__

    need = MIN_FREE
    for path in inputs:  # results are a few times the size of the recording (2.9 MB per 0.7 MB)
        try:
            need += 5 * os.stat(path).st_size
        except OSError:
            pass  # reading reports a missing input
    return ResultFolder(out, kind=kind, force=force, protect=inputs, need_bytes=need,
                        version=__version__, **kw)


def _write_outputs(an, folder: ResultFolder, figures: bool) -> None:
    """summary.json, posterior.nc, signals.npz and the figures into the staging folder."""
    stage = folder.stage
    with folder.writing():
        an.to_json(stage / "summary.json")
        an.to_netcdf(stage / "posterior.nc")
        an.to_signals(stage / "signals.npz")
        if figures:
            from dampfit.output.figures import save_figures

            save_figures(an, stage)


def _write_report(out: Path) -> None:
    """report.html + report.md in the finished folder (the report names the folder's commands)."""
    from dampfit.output.report import write_report

    write_report(out)


def _report(an, out: Path, as_json: bool) -> None:
    from dampfit.output import text as render

    s = an.summary()
    if as_json:
        import json

        print(json.dumps(s, indent=2))
    else:
        print(render.text(s))
        extras = "".join(f", {name}" for name, there in (
            ("figures", (out / "fit.png").exists()), ("report.html", (out / "report.html").exists()))
            if there)
        print(f"\n  written to {out}/ (summary.json, posterior.nc, signals.npz{extras})")
    if not an.converged:
        print("dampfit: WARNING: the result did NOT converge; see diagnostics.warnings in "
              "summary.json before using these numbers", file=sys.stderr)


# ----------------------------------------------------------------------- commands
def _check_analysis_options(args) -> None:
    """Relations between options, before any work (single values are checked by the parser)."""
    if args.window is not None and not args.window[0] < args.window[1]:
        raise InputError(f"argument --window: END must come after its start, got "
                         f"{args.window[0]:g} {args.window[1]:g}")
    if args.band is not None and not args.band[0] < args.band[1]:
        raise InputError(f"argument --band: the pass band needs LO < HI, got "
                         f"{args.band[0]:g} {args.band[1]:g}")


def _cmd_analyze(args) -> int:
    from dampfit.pipeline import analyze
    from dampfit.io.readers import read

    _check_analysis_options(args)
    out = Path(args.out) if args.out else Path(Path(args.file).name + ".dampfit")
    opts = {k: getattr(args, k) for k in ("time_column", "accel_columns", "time_unit",
                                           "accel_unit", "sheet", "variable", "row")
            if getattr(args, k) is not None}
    with _result_folder(out, "analyze", args.force, inputs=[args.file]) as folder:
        rec = read(args.file, **opts)
        an = analyze(rec, mass=args.mass, mass_sd=args.mass_sd, axis=args.axis,
                     window=tuple(args.window) if args.window else None,
                     band=tuple(args.band) if args.band else None, seed=args.seed,
                     progress=not args.quiet and sys.stderr.isatty(), max_steps=args.max_steps,
                     model=args.model, amplitude=args.amplitude)
        _write_outputs(an, folder, not args.no_figures)
        folder.publish()
        if args.report:
            _write_report(out)
    _report(an, out, args.json)
    return 0


_SIM_FIELDS = {"mass": "mass", "u0": "u0", "duration": "duration", "sample_rate": "sample_rate",
               "jitter": "jitter", "noise_density": "noise_density", "drift": "drift",
               "tilt": "tilt_deg", "handheld": "handheld", "gravity": "gravity", "catch": "catch"}


def _sim_config(args):
    from dampfit import simulate as sim

    over = {field: getattr(args, name) for name, field in _SIM_FIELDS.items()
            if getattr(args, name) is not None}
    cfg = sim.preset(args.preset, seed=args.seed, **over)
    if args.f_n is not None or args.zeta is not None:
        from dampfit.physics import critical_damping

        f_n = args.f_n if args.f_n is not None else (cfg.k / cfg.mass) ** 0.5 / (2 * 3.141592653589793)
        zeta = args.zeta if args.zeta is not None else cfg.c / float(critical_damping(cfg.k, cfg.mass))
        fields = {k: getattr(cfg, k) for k in cfg.__dataclass_fields__ if k not in ("k", "c", "mass")}
        cfg = sim.from_modal(cfg.mass, f_n, zeta, **fields)
    n = cfg.duration * cfg.sample_rate
    if n > MAX_SIM_SAMPLES:
        raise InputError(f"--duration {cfg.duration:g} s at --sample-rate {cfg.sample_rate:g} Hz "
                         f"would be {n:.3g} samples; at most {MAX_SIM_SAMPLES:g} are simulated")
    f_n = (cfg.k / cfg.mass) ** 0.5 / (2 * math.pi)
    if not f_n < cfg.sample_rate / 2:
        raise InputError(f"natural frequency {f_n:g} Hz is not below the Nyquist frequency "
                         f"{cfg.sample_rate / 2:g} Hz of --sample-rate {cfg.sample_rate:g} Hz")
    return cfg


def _cmd_simulate(args) -> int:
    """``dampfit simulate``: FILE.csv and FILE.truth.json, both or neither.

    Before any work: both names are checked (:func:`dampfit._files.check_output_file`: an
    existing file or link only with --force, never a directory; a name too long or a missing
    folder is one line) and the configuration against :func:`dampfit.simulate.check_limits`.
    Both files are written into a private staging folder beside them and renamed into place,
    so a failed write (full disk, read-only folder) leaves nothing behind. Every file-system
    failure is an :class:`InputError` (exit 2, one line).
    """
    import shutil
    import tempfile

    from dampfit import simulate as sim
    from dampfit._files import _reason, check_output_file

    out = Path(args.out)
    if not out.name or out.name in (".", ".."):
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv")
    try:
        truth_path = out.with_suffix(".truth.json")
    except ValueError:
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv") from None
    for f in (out, truth_path):
        check_output_file(f, args.force)
    if not os.access(out.parent, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into {os.path.abspath(out.parent)}: permission denied")
    cfg = _sim_config(args)
    sim.check_limits(cfg)
    rec, truth = sim.simulate(cfg)
    try:
        stage = Path(tempfile.mkdtemp(prefix=".dampfit-simulate-", dir=out.parent))
    except OSError as exc:
        raise InputError(f"cannot write {out}: {_reason(exc)}; nothing was written") from None
    existed = os.path.lexists(out)
    try:
        sim.write_phyphox_csv(rec, stage / out.name, dialect=args.dialect)
        sim.write_truth(truth, stage / truth_path.name)
        os.replace(stage / out.name, out)
        try:
            os.replace(stage / truth_path.name, truth_path)
        except OSError:
            if not existed:  # both or neither
                out.unlink(missing_ok=True)
            raise
    except OSError as exc:
        raise InputError(f"cannot write {out}: {_reason(exc)}; nothing was written") from None
    except InputError as exc:  # a failed write in the staging folder
        cause = exc.__cause__
        reason = _reason(cause) if isinstance(cause, OSError) else str(exc)
        raise InputError(f"cannot write {out}: {reason}; nothing was written") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    print(f"wrote {out} ({rec.n_samples} samples, {rec.duration:.4g} s) and {truth_path}: "
          f"c = {truth['c']:.6g} N s/m, k = {truth['k']:.6g} N/m, m = {truth['mass']:.6g} kg, "
          f"f_n = {truth['f_n']:.6g} Hz, zeta = {truth['zeta']:.4g}")
    return 0


def _cmd_demo(args) -> int:
    from dampfit import simulate as sim
    from dampfit.pipeline import analyze
    from dampfit.io.readers import read

    out = Path(args.out)
    cfg = sim.preset("paper", seed=args.seed)
    # a previous demo's own folder (marker of kind "demo", or an old one recognised by its
    # files) is regenerated freely; an analyze result only with --force; anything else never
    with _result_folder(out, "demo", args.force, free_kinds=("demo",),
                        legacy=_old_demo_folder) as folder:
        print(f"dampfit demo: simulating the seed paper's set-up (m = {cfg.mass} kg, "
              f"k = {cfg.k:.1f} N/m, c = {cfg.c} N s/m, {cfg.duration:g} s at "
              f"{cfg.sample_rate:g} Hz) as a phyphox CSV, then analysing it\n")
        stage = folder.stage
        rec, truth = sim.simulate(cfg)
        csv = stage / "paper-preset.csv"
        with folder.writing():
            sim.write_phyphox_csv(rec, csv)
            sim.write_truth(truth, csv.with_suffix(".truth.json"))
        # the recording is read from the staging folder but lives at its final path
        rec = dataclasses.replace(read(csv), path=str(folder.target / csv.name))
        an = analyze(rec, mass=cfg.mass, mass_sd=DEMO_MASS_SD, seed=args.seed,
                     progress=not args.quiet and sys.stderr.isatty())
        _write_outputs(an, folder, not args.no_figures)
        folder.publish()
        if args.report:
            _write_report(out)
    _report(an, out, False)
    c = an.summary()["parameters"]["c"]
    inside = c["q05"] <= truth["c"] <= c["q95"]
    print(f"\n  truth c = {truth['c']:g} N s/m is {'inside' if inside else 'OUTSIDE'} the 90 % "
          f"interval [{c['q05']:.5g}, {c['q95']:.5g}]")
    return 0


#: Where compiled JAX kernels are kept between CLI runs (see :func:`_compile_cache`).
CACHE_ENV = "DAMPFIT_JAX_CACHE"


def _make_private(path: Path) -> list[Path]:
    """Create ``path`` and its missing parents, each 0700; return the folders created."""
    missing = [p for p in (path, *path.parents) if not os.path.lexists(p)]
    created = []
    for p in reversed(missing):
        try:
            os.mkdir(p, 0o700)
        except FileExistsError:
            continue
        created.append(p)
    return created


def _unsafe_cache(path: Path, created: Sequence[Path]) -> str | None:
    """Why the cache folder ``path`` must not be used (others could plant code in it), or None."""
    uid = os.geteuid()
    try:
        for p in {path, *created}:
            st = os.stat(p)
            if not stat.S_ISDIR(st.st_mode):
                return f"{p} is not a directory"
            if st.st_uid != uid:
                return f"{p} belongs to another user (uid {st.st_uid})"
            if st.st_mode & 0o022:
                return f"{p} is writable by group or others (mode {stat.S_IMODE(st.st_mode):o})"
        for p in path.resolve().parents:  # a parent others may rename things in
            st = os.stat(p)
            if st.st_mode & 0o002 and not st.st_mode & stat.S_ISVTX:
                return f"its parent {p} is writable by everyone"
    except OSError as exc:
        return f"cannot be checked ({exc.strerror or exc})"
    return None


def _compile_cache() -> Path | None:
    """Switch on JAX's persistent compilation cache for this run and its child processes.

    A fresh process otherwise compiles every kernel again (least squares, CRLB, sampler: ≈ 6 s
    of a 60 s recording's ≈ 16 s CLI run); with the cache a second run loads them from disk.
    Location: ``$DAMPFIT_JAX_CACHE``, else ``$XDG_CACHE_HOME/dampfit/jax`` (``~/.cache/…``);
    ``DAMPFIT_JAX_CACHE=off`` switches it off, and a ``JAX_COMPILATION_CACHE_DIR`` the user
    set is left alone. The directory (and every parent created for it) is private (0700): JAX
    trusts what it loads from it, so a cache folder that is writable by group or others, is
    not owned by the user, or lies under a folder everyone may rename things in (no sticky
    bit) is not used: one warning line on stderr, and the run continues without the cache.
    Set through environment variables so that Dask workers of ``dampfit study`` inherit it;
    it takes effect only if nothing was compiled yet in this process (as in a CLI run).
    Size: ≈ 1 MB per shape bucket of recordings (:class:`dampfit.signal.prepare.Padded`); entries
    of other JAX or dampfit versions are never read again, so deleting the folder is safe.
    """
    choice = os.environ.get(CACHE_ENV, "")
    if choice.lower() in ("off", "0", "no", "false") or os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return None
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    path = Path(os.path.abspath(Path(choice) if choice else base / "dampfit" / "jax"))
    try:
        created = _make_private(path)
    except OSError:
        return None  # read-only home etc.: run without the cache, only slower
    problem = _unsafe_cache(path, created)
    if problem is not None:
        _DEFERRED.append(f"dampfit: warning: JAX compilation cache {path} not used: {problem}; "
                         "cache off")
        return None
    settings = {"JAX_COMPILATION_CACHE_DIR": str(path),
                "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",  # many small kernels add up
                "JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES": "-1"}
    os.environ.update(settings)
    if "jax" in sys.modules:  # imported with the package: configure it directly as well
        import jax

        for key, value in settings.items():
            jax.config.update(key.lower(), int(value) if key.endswith("_BYTES")
                              else float(value) if key.endswith("_SECS") else value)
    return path


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that every cleanup (staging folders) runs."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    installed = False
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
        installed = True
    try:
        return _main(argv)
    finally:
        if installed:
            signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)


#: Warning lines printed after a command succeeds; a failing command prints its one error
#: line only (the one-line contract), so a side issue never adds a second line to it.
_DEFERRED: list[str] = []


def _main(argv: Sequence[str] | None) -> int:
    _DEFERRED.clear()
    with warnings.catch_warnings():
        # library warnings (NumPy overflow, emcee, JAX) are not dampfit's messages: what matters
        # reaches summary.json's warnings; DAMPFIT_DEBUG=1 shows them
        if not os.environ.get("DAMPFIT_DEBUG"):
            warnings.simplefilter("ignore")
        code = _dispatch(argv)
    if code == 0:
        for line in _DEFERRED:
            print(line, file=sys.stderr)
    return code


def _dispatch(argv: Sequence[str] | None) -> int:
    try:
        _compile_cache()
        args = get_parser().parse_args(argv)
        if args.command is None:
            raise InputError("no command given; use analyze, simulate, demo, report, export, verify "
                             "or study (see 'dampfit --help')")
        builtin = {"analyze": _cmd_analyze, "simulate": _cmd_simulate, "demo": _cmd_demo}
        if args.command in builtin:
            return builtin[args.command](args)
        module = {name: mod for name, _, mod in _EXTERNAL}[args.command]
        return _load(module).command(args)
    except DampfitError as exc:
        print(f"dampfit: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        what = "terminated" if isinstance(exc, _Terminated) else "interrupted"
        print(f"dampfit: {what}; no partial output was left behind", file=sys.stderr)
        return 143 if isinstance(exc, _Terminated) else 130
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        if os.environ.get("DAMPFIT_DEBUG"):
            traceback.print_exc()
        print(f"dampfit: internal error: {type(exc).__name__}: {_one_line(exc)} "
              "(please report it; set DAMPFIT_DEBUG=1 for the traceback)", file=sys.stderr)
        return 1


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line: a path or value holding newlines or control
    characters (a hostile folder name) cannot add lines to the one-line error contract."""
    return "".join(ch if ch.isprintable() else " " for ch in " ".join(str(exc).split()))


def run() -> None:
    """Console-script entry point.

    After an interrupt (exit 130/143) the cleanup has run inside :func:`main`; the process then
    ends at once: finalising the interpreter while XLA's threads are still mid-computation can
    crash (a segmentation fault instead of the promised exit code).
    """
    code = main()
    if code in (130, 143):
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
