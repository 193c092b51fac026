"""Command-line interface: ``dampfit analyze | simulate | demo``.

Exit codes: 0 success (including a flagged, non-converged posterior), 2 bad input or usage
(one line on stderr, no traceback, nothing written), 1 unexpected internal error. Outputs are
written into a staging directory next to the target and moved into place only when complete,
so an existing result is never half-overwritten; it is replaced only with ``--force``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import shutil
import sys
import tempfile
import traceback
import warnings
from pathlib import Path
from collections.abc import Sequence

from ._files import publish
from .errors import DampfitError, InputError

__all__ = ["main", "run", "get_parser"]

DEMO_MASS_SD = 0.02  # [kg] mass uncertainty used by the demo (a kitchen scale)
DEMO_MARKER = "paper-preset.truth.json"  # file that identifies a demo's own output folder


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(f"{message} (see '{self.prog} --help')")


def _number(kind):
    def conv(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        return v

    return conv


#: argparse type for a float option with a one-line error (shared by the sub-command modules).
float_arg = _number(float)


def get_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``dampfit`` command."""
    p = _Parser(prog="dampfit", description=(
        "Damping coefficient c [N s/m], stiffness k [N/m] and initial amplitude u0 [m] "
        "from a free-decay accelerometer recording, with a Bayesian posterior."))
    from . import __version__

    p.add_argument("--version", action="version", version=f"dampfit {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    a = sub.add_parser("analyze", help="analyse a recording: summary.json, posterior.nc, figures")
    a.add_argument("file", help="recording: phyphox CSV/ZIP/XLSX, Sensor Logger CSV, CSV/TXT, NPY/NPZ")
    _analysis_options(a)
    a.add_argument("--out", metavar="DIR", help="output directory (default: FILE's name + '.dampfit')")
    a.add_argument("--force", action="store_true", help="replace an existing output directory")
    g = a.add_argument_group("reading (generic CSV/NPY)")
    g.add_argument("--time-column", metavar="COL", help="time column name or 0-based index")
    g.add_argument("--accel-columns", metavar="COL", nargs="+", help="acceleration column(s)")
    g.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column")
    g.add_argument("--accel-unit", choices=["m/s2", "g"], help="unit of the acceleration")
    g.add_argument("--sheet", help="Excel sheet name")

    s = sub.add_parser("simulate", help="write a synthetic phyphox CSV with known truth")
    s.add_argument("--preset", default="paper", help="starting configuration: paper | phone")
    s.add_argument("--mass", type=_number(float), metavar="KG")
    s.add_argument("--f-n", type=_number(float), metavar="HZ", help="natural frequency [Hz]")
    s.add_argument("--zeta", type=_number(float), metavar="Z", help="damping ratio [1]")
    s.add_argument("--u0", type=_number(float), metavar="M", help="initial displacement [m]")
    s.add_argument("--duration", type=_number(float), metavar="S")
    s.add_argument("--sample-rate", type=_number(float), metavar="HZ")
    s.add_argument("--jitter", type=_number(float), metavar="CV")
    s.add_argument("--noise-density", type=_number(float), metavar="UG", help="µg/√Hz")
    s.add_argument("--drift", type=_number(float), metavar="MS2", help="bias drift rms [m/s²]")
    s.add_argument("--tilt", type=_number(float), metavar="DEG")
    s.add_argument("--handheld", type=_number(float), metavar="S")
    s.add_argument("--gravity", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--catch", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--dialect", default="comma", choices=["comma", "tab", "semicolon"])
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--out", required=True, metavar="FILE.csv")
    s.add_argument("--force", action="store_true", help="overwrite existing files")

    d = sub.add_parser("demo", help="simulate the paper's set-up and analyse it (the main job)")
    d.add_argument("--out", default="dampfit-demo", metavar="DIR")
    d.add_argument("--force", action="store_true")
    d.add_argument("--seed", type=int, default=0)
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
    ("report", "write report.html and report.md for a result folder", "report"),
    ("export", "write an FEM deck (LS-DYNA, OpenSees, CalculiX) of the identified system", "fem.export"),
    ("verify", "run the identified system in OpenSeesPy and compare with the measurement", "fem.verify"),
    ("study", "simulation study comparing damping estimators (Dask, resumable)", "study"),
)


def _load(module: str):
    import importlib

    return importlib.import_module(f"dampfit.{module}")


def _analysis_options(a: argparse.ArgumentParser) -> None:
    a.add_argument("--mass", type=_number(float), metavar="KG", help="oscillating mass [kg]")
    a.add_argument("--mass-sd", type=_number(float), metavar="KG", default=None,
                   help="standard deviation of the mass [kg]")
    a.add_argument("--axis", default="auto", help="x, y, z, another column name, or auto")
    a.add_argument("--window", nargs=2, type=_number(float), metavar=("START", "END"),
                   help="free-decay window [s] in the recording's time base")
    a.add_argument("--band", nargs=2, type=_number(float), metavar=("LO", "HI"),
                   help="pass band [Hz] around the oscillation")
    a.add_argument("--seed", type=int, default=0, help="random seed of the sampler")
    a.add_argument("--max-steps", type=int, default=20000, help="sampler step limit")
    a.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    a.add_argument("--json", action="store_true", help="print summary.json instead of the table")
    a.add_argument("--quiet", action="store_true", help="no progress bar")
    a.add_argument("--report", action="store_true", help="also write report.html and report.md")
    a.add_argument("--model", default="auto",
                   choices=["auto", "viscous", "coulomb", "quadratic", "power"],
                   help="damping law reported as c_equivalent (auto: the one the evidence "
                        "prefers); all are compared in model_checks either way")
    a.add_argument("--amplitude", type=_number(float), metavar="M",
                   help="displacement amplitude [m] at which a non-viscous law's equivalent "
                        "viscous c is reported (the amplitude your FEM model will see)")


# ----------------------------------------------------------------------- outputs
def _check_target(target: Path, force: bool) -> None:
    """Refuse an output directory that exists (without --force) or cannot be made; before any work."""
    target = target.resolve()
    if target.exists() and not force:
        raise InputError(f"{target} exists; use --force to replace it")
    if target.exists() and not target.is_dir():
        raise InputError(f"{target} exists and is not a directory")
    if not target.parent.is_dir():
        raise InputError(f"output folder {target.parent} does not exist")


@contextlib.contextmanager
def _staged_dir(target: Path, force: bool):
    """Yield a fresh staging directory; move it onto ``target`` only if the block succeeds."""
    _check_target(target, force)
    target = target.resolve()
    parent = target.parent
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=parent))
    publish(stage)
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    old = None
    if target.exists():
        old = parent / f".{target.name}.old-{os.getpid()}"
        os.replace(target, old)
    os.replace(stage, target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _write_outputs(an, out: Path, force: bool, figures: bool) -> Path:
    with _staged_dir(out, force) as stage:
        an.to_json(stage / "summary.json")
        an.to_netcdf(stage / "posterior.nc")
        an.to_signals(stage / "signals.npz")
        if figures:
            from .plots import save_figures

            save_figures(an, stage)
    return out


def _write_report(out: Path) -> None:
    """report.html + report.md in the finished folder (the report names the folder's commands)."""
    from .report import write_report

    write_report(out)


def _report(an, out: Path, as_json: bool) -> None:
    from . import render

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
def _cmd_analyze(args) -> int:
    from .analysis import analyze
    from .io import read

    out = Path(args.out) if args.out else Path(Path(args.file).name + ".dampfit")
    _check_target(out, args.force)
    opts = {k: getattr(args, k) for k in ("time_column", "accel_columns", "time_unit",
                                           "accel_unit", "sheet") if getattr(args, k)}
    rec = read(args.file, **opts)
    an = analyze(rec, mass=args.mass, mass_sd=args.mass_sd, axis=args.axis,
                 window=tuple(args.window) if args.window else None,
                 band=tuple(args.band) if args.band else None, seed=args.seed,
                 progress=not args.quiet and sys.stderr.isatty(), max_steps=args.max_steps,
                 model=args.model, amplitude=args.amplitude)
    _write_outputs(an, out, args.force, not args.no_figures)
    if args.report:
        _write_report(out)
    _report(an, out, args.json)
    return 0


_SIM_FIELDS = {"mass": "mass", "u0": "u0", "duration": "duration", "sample_rate": "sample_rate",
               "jitter": "jitter", "noise_density": "noise_density", "drift": "drift",
               "tilt": "tilt_deg", "handheld": "handheld", "gravity": "gravity", "catch": "catch"}


def _sim_config(args):
    from . import simulate as sim

    over = {field: getattr(args, name) for name, field in _SIM_FIELDS.items()
            if getattr(args, name) is not None}
    cfg = sim.preset(args.preset, seed=args.seed, **over)
    if args.f_n is not None or args.zeta is not None:
        from .physics import critical_damping

        f_n = args.f_n if args.f_n is not None else (cfg.k / cfg.mass) ** 0.5 / (2 * 3.141592653589793)
        zeta = args.zeta if args.zeta is not None else cfg.c / float(critical_damping(cfg.k, cfg.mass))
        fields = {k: getattr(cfg, k) for k in cfg.__dataclass_fields__ if k not in ("k", "c", "mass")}
        cfg = sim.from_modal(cfg.mass, f_n, zeta, **fields)
    return cfg


def _cmd_simulate(args) -> int:
    from . import simulate as sim

    out = Path(args.out)
    truth_path = out.with_suffix(".truth.json")
    for f in (out, truth_path):
        if f.exists() and not args.force:
            raise InputError(f"{f} exists; use --force to overwrite it")
    if not out.parent.resolve().is_dir():
        raise InputError(f"output folder {out.parent} does not exist")
    rec, truth = sim.simulate(_sim_config(args))
    sim.write_phyphox_csv(rec, out, dialect=args.dialect)
    sim.write_truth(truth, truth_path)
    print(f"wrote {out} ({rec.n_samples} samples, {rec.duration:.4g} s) and {truth_path}: "
          f"c = {truth['c']:.6g} N s/m, k = {truth['k']:.6g} N/m, m = {truth['mass']:.6g} kg, "
          f"f_n = {truth['f_n']:.6g} Hz, zeta = {truth['zeta']:.4g}")
    return 0


def _cmd_demo(args) -> int:
    from . import simulate as sim
    from .analysis import analyze
    from .io import read

    out = Path(args.out)
    # a previous demo's own output (recognised by its truth file) is regenerated freely
    force = args.force or (out / DEMO_MARKER).is_file()
    _check_target(out, force)
    cfg = sim.preset("paper", seed=args.seed)
    print(f"dampfit demo: simulating the seed paper's set-up (m = {cfg.mass} kg, "
          f"k = {cfg.k:.1f} N/m, c = {cfg.c} N s/m, {cfg.duration:g} s at {cfg.sample_rate:g} Hz) "
          "as a phyphox CSV, then analysing it\n")
    with _staged_dir(out, force) as stage:
        rec, truth = sim.simulate(cfg)
        csv = stage / "paper-preset.csv"
        sim.write_phyphox_csv(rec, csv)
        sim.write_truth(truth, csv.with_suffix(".truth.json"))
        # the recording is read from the staging folder but lives at its final path
        rec = dataclasses.replace(read(csv), path=str(out.resolve() / csv.name))
        an = analyze(rec, mass=cfg.mass, mass_sd=DEMO_MASS_SD, seed=args.seed,
                     progress=not args.quiet and sys.stderr.isatty())
        an.to_json(stage / "summary.json")
        an.to_netcdf(stage / "posterior.nc")
        an.to_signals(stage / "signals.npz")
        if not args.no_figures:
            from .plots import save_figures

            save_figures(an, stage)
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


def _compile_cache() -> Path | None:
    """Switch on JAX's persistent compilation cache for this run and its child processes.

    A fresh process otherwise compiles every kernel again (least squares, CRLB, sampler: ≈ 6 s
    of a 60 s recording's ≈ 16 s CLI run); with the cache a second run loads them from disk.
    Location: ``$DAMPFIT_JAX_CACHE``, else ``$XDG_CACHE_HOME/dampfit/jax`` (``~/.cache/…``);
    ``DAMPFIT_JAX_CACHE=off`` switches it off, and a ``JAX_COMPILATION_CACHE_DIR`` the user
    set is left alone. The directory is private (0700): JAX trusts what it loads from it.
    Set through environment variables so that Dask workers of ``dampfit study`` inherit it;
    it takes effect only if nothing was compiled yet in this process (as in a CLI run).
    Size: ≈ 1 MB per shape bucket of recordings (:class:`dampfit.preprocess.Padded`); entries
    of other JAX or dampfit versions are never read again, so deleting the folder is safe.
    """
    choice = os.environ.get(CACHE_ENV, "")
    if choice.lower() in ("off", "0", "no", "false") or os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return None
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    path = Path(choice) if choice else base / "dampfit" / "jax"
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError:
        return None  # read-only home etc.: run without the cache, only slower
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


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    warnings.filterwarnings("ignore", category=FutureWarning)
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
    except InputError as exc:
        print(f"dampfit: error: {exc}", file=sys.stderr)
        return 2
    except DampfitError as exc:
        print(f"dampfit: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("dampfit: interrupted; nothing was written", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        if os.environ.get("DAMPFIT_DEBUG"):
            traceback.print_exc()
        print(f"dampfit: internal error: {type(exc).__name__}: {exc} "
              "(please report it; set DAMPFIT_DEBUG=1 for the traceback)", file=sys.stderr)
        return 1


def run() -> None:
    """Console-script entry point."""
    sys.exit(main())


if __name__ == "__main__":
    run()
