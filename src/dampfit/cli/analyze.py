"""``dampfit analyze FILE`` and ``dampfit demo``: a recording (read, or simulated) into a result folder.

Both write the same folder (:mod:`dampfit.cli.staging`): summary.json, posterior.nc,
signals.npz, the figures unless ``--no-figures``, and with ``--report`` report.html/.md; then
print the summary table (``--json``: summary.json itself).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from dampfit.cli.options import MAX_STEPS, SEED_LIMIT, _integer, _mass, _real, seed_arg
from dampfit.cli.staging import old_demo_folder, result_folder, write_outputs, write_report
from dampfit.errors import InputError

__all__ = ["DEMO_MASS_SD", "add_arguments", "add_demo_arguments", "command", "demo"]

DEMO_MASS_SD = 0.02  # [kg] mass uncertainty used by the demo (a kitchen scale)


def add_arguments(a: argparse.ArgumentParser) -> None:
    """Options of ``dampfit analyze``."""
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


def add_demo_arguments(d: argparse.ArgumentParser) -> None:
    """Options of ``dampfit demo``."""
    d.add_argument("--out", default="dampfit-demo", metavar="DIR",
                   help="output directory (a previous demo's folder is regenerated)")
    d.add_argument("--force", action="store_true",
                   help="replace an existing output directory that dampfit wrote")
    d.add_argument("--seed", type=seed_arg, default=0)
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.add_argument("--no-figures", action="store_true")
    d.add_argument("--report", action="store_true", help="also write report.html and report.md")


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


def _check_analysis_options(args) -> None:
    """Relations between options, before any work (single values are checked by the parser)."""
    if args.window is not None and not args.window[0] < args.window[1]:
        raise InputError(f"argument --window: END must come after its start, got "
                         f"{args.window[0]:g} {args.window[1]:g}")
    if args.band is not None and not args.band[0] < args.band[1]:
        raise InputError(f"argument --band: the pass band needs LO < HI, got "
                         f"{args.band[0]:g} {args.band[1]:g}")


def _print_result(an, out: Path, as_json: bool) -> None:
    """The summary table (or summary.json) on stdout; a non-converged result warns on stderr."""
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


def command(args) -> int:
    """``dampfit analyze FILE …``: read, analyse, write the result folder; exit code 0."""
    from dampfit.pipeline import analyze
    from dampfit.io.readers import read

    _check_analysis_options(args)
    out = Path(args.out) if args.out else Path(Path(args.file).name + ".dampfit")
    opts = {k: getattr(args, k) for k in ("time_column", "accel_columns", "time_unit",
                                           "accel_unit", "sheet", "variable", "row")
            if getattr(args, k) is not None}
    with result_folder(out, "analyze", args.force, inputs=[args.file]) as folder:
        rec = read(args.file, **opts)
        an = analyze(rec, mass=args.mass, mass_sd=args.mass_sd, axis=args.axis,
                     window=tuple(args.window) if args.window else None,
                     band=tuple(args.band) if args.band else None, seed=args.seed,
                     progress=not args.quiet and sys.stderr.isatty(), max_steps=args.max_steps,
                     model=args.model, amplitude=args.amplitude)
        write_outputs(an, folder, not args.no_figures)
        folder.publish()
        if args.report:
            write_report(out)
    _print_result(an, out, args.json)
    return 0


def demo(args) -> int:
    """``dampfit demo``: simulate the seed paper's set-up, analyse it; exit code 0."""
    from dampfit import simulate as sim
    from dampfit.pipeline import analyze
    from dampfit.io.readers import read

    out = Path(args.out)
    cfg = sim.preset("paper", seed=args.seed)
    # a previous demo's own folder (marker of kind "demo", or an old one recognised by its
    # files) is regenerated freely; an analyze result only with --force; anything else never
    with result_folder(out, "demo", args.force, free_kinds=("demo",),
                       legacy=old_demo_folder) as folder:
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
        write_outputs(an, folder, not args.no_figures)
        folder.publish()
        if args.report:
            write_report(out)
    _print_result(an, out, False)
    c = an.summary()["parameters"]["c"]
    inside = c["q05"] <= truth["c"] <= c["q95"]
    print(f"\n  truth c = {truth['c']:g} N s/m is {'inside' if inside else 'OUTSIDE'} the 90 % "
          f"interval [{c['q05']:.5g}, {c['q95']:.5g}]")
    return 0
