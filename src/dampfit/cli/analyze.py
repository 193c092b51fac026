"""``dampfit analyze FILE…`` and ``dampfit demo``: recordings (read, or simulated) into a result folder.

Both write the same folder (:mod:`dampfit.cli.staging`): summary.json, posterior.nc,
signals.npz, the figures unless ``--no-figures``, and with ``--report`` report.html/.md; then
print the summary table (``--json``: summary.json itself).

Several files (``dampfit analyze FILE FILE… [--mass KG [--mass-sd KG] | --added-mass KG KG…
[--added-mass-sd KG]] --out DIR``) are several recordings of one damper, analysed jointly by
:func:`dampfit.campaign.analyze_campaign` (a campaign: repeated tests pooled by a hierarchical
model, or the added-mass method when ``--added-mass`` gives each recording's known added mass
[kg], 0 for the bare system). The folder (marker kind ``campaign``) holds summary.json
(``"kind": "campaign"``), posterior.nc, ``forest.png`` and, with ``--added-mass``,
``added_mass.png`` (:mod:`dampfit.output.campaign`); no signals.npz; the table it prints is
:mod:`dampfit.output.text_campaign`. Default ``--out``: the first FILE's name +
``.campaign.dampfit`` in the current folder. Every input file is protected like the one input
of a single analysis (``--out`` may not be or hold the folder of any of them).
Refused before any work, one line, exit 2, nothing written: ``--added-mass`` with a count other
than the number of files, ``--added-mass`` together with ``--mass`` (the added-mass method
estimates the effective mass m₀ itself), ``--added-mass-sd`` without ``--added-mass``, a file
given twice, ``--model``/``--amplitude``/``--mode-of-mass`` (single-recording options); a
file that cannot be read is named in its one error line. ``--window``/``--band``/``--axis``
apply to every file; the campaign pools the mode the band isolates, and ``--max-modes N``
(N > 1) lists every test's other modes (:mod:`dampfit.campaign.modes`).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import sys
from pathlib import Path

from dampfit.cli.options import progress_reporting, real_arg, seed_arg
from dampfit.physics import MAX_MASS
from dampfit.cli.options import add_analysis_options, add_reading_options, analysis_options
from dampfit.cli.staging import old_demo_folder, result_folder
from dampfit.files.folder import Free
from dampfit.errors import InputError

DEMO_MASS_SD = 0.02  # [kg] mass uncertainty used by the demo (a kitchen scale)
#: The demo's last line: the next command, on the user's own recording.
NEXT_STEP = 'next: dampfit analyze YOUR.csv --mass KG --report   (README: "Your own recording")'


def add_arguments(a: argparse.ArgumentParser) -> None:
    """Options of ``dampfit analyze``."""
    a.add_argument("file", metavar="FILE",
                   help="recording: phyphox CSV/ZIP/XLSX, Sensor Logger CSV, CSV/TXT, NPY/NPZ, "
                        "LabVIEW .lvm, NI .tdms, UFF 58 .uff/.unv, "
                        "MATLAB .mat")
    a.add_argument("more_files", nargs="*", metavar="FILE",
                   help="further recordings of the same damper: all FILEs are analysed jointly "
                        "(a campaign; give the FILEs before the options)")
    add_analysis_options(a)
    a.add_argument("--out", metavar="DIR",
                   help="output directory (default: FILE's name + '.dampfit'; several files: "
                        "the first FILE's name + '.campaign.dampfit')")
    a.add_argument("--force", action="store_true",
                   help="replace an existing output directory that dampfit wrote")
    c = a.add_argument_group("several recordings of one damper (campaign)")
    c.add_argument("--added-mass", nargs="+", type=real_arg("an added mass in kg, 0 to 1e6",
                                                         lambda v: 0 <= v <= MAX_MASS),
                   metavar="KG", help="added-mass method: the known mass added in each recording "
                                      "[kg], one per FILE in order (0 for the bare system); the "
                                      "effective mass m0 and k are estimated (not with --mass)")
    c.add_argument("--added-mass-sd", type=real_arg("a standard deviation ≥ 0 kg", lambda v: v >= 0),
                   metavar="KG", default=None,
                   help="standard deviation of each added mass [kg] (default 0; a 0 "
                   "for the bare system is exact)")
    add_reading_options(a)


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


def print_result(an, out: Path, as_json: bool) -> None:
    """The summary table (or summary.json) on stdout; a non-converged result warns on stderr."""
    from dampfit.output import text as render

    def written() -> str:
        extras = "".join(f", {name}" for name, there in (
            ("figures", (out / "fit.png").exists()), ("report.html", (out / "report.html").exists()))
            if there)
        return f"\n  written to {out}/ (summary.json, posterior.nc, signals.npz{extras})"

    s = an.summary()
    _show(s, as_json, render.text, written, an.converged)
    modal = (s.get("modes_evidence") or {}).get("sampling") or {}
    if modal.get("converged") is False:
        print(f"dampfit: WARNING: the modal posterior did NOT converge ({modal.get('stop_reason')}"
              f"; {modal.get('n_steps')} steps): the modes' intervals are not reliable (each "
              "mode's least_squares is); see modes_evidence.sampling in summary.json",
              file=sys.stderr)


def read_options(args) -> dict:
    """Options of :func:`dampfit.io.readers.read` given on the command line (the reading
    options, and the analysis window: rows with empty cells outside it are dropped)."""
    from dampfit.io.readers import READ_OPTIONS

    opts = {k: getattr(args, k) for k in READ_OPTIONS if getattr(args, k, None) is not None}
    if getattr(args, "window", None) is not None:
        opts["window"] = tuple(args.window)
    return opts


def figure_process(args):
    """The figure-drawing process (:mod:`dampfit.output.figure_process`), started now so that
    its imports overlap this process's; with ``--no-figures`` a handle that starts nothing.
    Use it as a context, and ``contextlib.closing`` it inside the result folder's context:
    it is then stopped before a failed folder's staging folder is removed."""
    from dampfit.output.figure_process import FigureProcess

    return FigureProcess(None) if args.no_figures else FigureProcess.start()


def command(args) -> int:
    """``dampfit analyze FILE …``: read, analyse, write the result folder; exit code 0."""
    import gc

    files = [args.file, *(getattr(args, "more_files", None) or [])]
    options = analysis_options(args)  # built once, before any work
    if len(files) > 1:
        import dampfit.pipeline  # noqa: F401 - the stack, then out of the collector's reach

        gc.freeze()
        return campaign_command(args, files, options)
    for option in ("added_mass", "added_mass_sd"):
        if getattr(args, option, None) is not None:
            raise InputError(f"argument --{option.replace('_', '-')}: the added-mass method needs "
                             "several recordings (one FILE per added mass), got one FILE")
    path = files[0]
    out = Path(args.out) if args.out else Path(Path(path).name + ".dampfit")
    with figure_process(args) as figs:  # before the scientific stack is imported
        with result_folder(out, "analyze", args.force, inputs=[path]) as folder, \
                contextlib.closing(figs):
            an = analyse_into(args, folder, figs, path, options=options)
            folder.publish()
            if args.report:
                _write_report(out)
    print_result(an, out, args.json)
    return 0


def analyse_into(args, folder, figs, path, *, options, shown_path: Path | None = None,
                 notes: tuple[str, ...] = ()):
    """Read ``path``, analyse it with the analysis ``options`` (of ``args``:
    :func:`~dampfit.cli.options.analysis_options`) and write the outputs into
    ``folder.stage`` (not yet published); return the analysis.

    The one code path of ``dampfit analyze FILE`` (one recording), shared with ``dampfit
    record`` (which analyses its own recording): ``figs`` is the figure process
    (:func:`figure_process`, started before this imports the scientific stack);
    ``shown_path`` is the path the recording is reported under when it is read from
    elsewhere (a staging folder); ``notes`` are added to the recording's notes.
    """
    import gc

    from dampfit.io.readers import read
    from dampfit.pipeline import analyze

    # the imported stack (JAX, SciPy, …) is hundreds of thousands of long-lived objects
    # that every full garbage collection would walk again: move them out of its reach
    gc.freeze()
    figs.target(folder.stage)
    rec = read(path, **read_options(args))
    if shown_path is not None or notes:
        rec = dataclasses.replace(rec, path=str(shown_path) if shown_path else rec.path,
                                  notes=(*rec.notes, *notes))
    with progress_reporting(args):
        an = analyze(rec, mass=args.mass, mass_sd=args.mass_sd, options=options,
                     on_stage=figs.send)
        gc.freeze()  # and the analysis' own objects, before figures, NetCDF and report
        save_with_progress(an, folder, figures=not args.no_figures, figure_process=figs)
    return an



def save_with_progress(an, folder, **kw) -> None:
    """``an.save(folder, **kw)`` as the last stage of the progress: "writing results"."""
    from dampfit._progress import stage_bar

    with stage_bar(1, "writing results" + (" and figures" if kw.get("figures") else ""),
                   unit="folder") as bar:
        an.save(folder, **kw)
        bar.update(1)


def _check_campaign_options(args, files: list[str]) -> None:
    """Relations between the options of a campaign (several FILEs), before any work."""
    n = len(files)
    if args.added_mass is not None:
        if len(args.added_mass) != n:
            raise InputError(f"argument --added-mass: give one added mass per FILE, got "
                             f"{len(args.added_mass)} for {n} files")
        if args.mass is not None or args.mass_sd is not None:
            raise InputError("argument --mass: not with --added-mass (the added-mass method "
                             "estimates the effective mass m0 itself); give one of them")
    elif args.added_mass_sd is not None:
        raise InputError("argument --added-mass-sd: given without --added-mass")
    if args.mass_sd is not None and args.mass is None:
        raise InputError("argument --mass-sd: a mass standard deviation without --mass")
    single = [name for name, given in (("--model", args.model != "auto"),
                                       ("--amplitude", args.amplitude is not None),
                                       ("--mode-of-mass", args.mode_of_mass is not None))
              if given]
    if single:
        which = single[0]
        raise InputError(f"argument {which}: applies to one recording, not to a campaign of "
                         f"{n} files; analyse a file alone for its damping-law check")
    seen: dict[str, str] = {}
    for f in files:
        key = os.path.realpath(f)
        if key in seen:
            also = "" if seen[key] == f else f" (also as {seen[key]})"
            raise InputError(f"{f}: given twice{also}; give each recording once")
        seen[key] = f


def _read_named(read, path: str, opts: dict):
    """``read(path, **opts)``; a refusal that does not name the file gets its name in front."""
    try:
        return read(path, **opts)
    except InputError as exc:
        if str(path) in str(exc) or Path(path).name in str(exc):
            raise
        raise InputError(f"{path}: {exc}") from None


def _print_campaign(an, out: Path, as_json: bool) -> None:
    """The campaign table (or its summary.json) on stdout; not converged: a warning on stderr."""
    from dampfit.output import text_campaign

    def written() -> str:
        extras = "".join(f", {name}" for name in ("forest.png", "added_mass.png", "report.html")
                         if (out / name).exists())
        return f"\n  written to {out}/ (summary.json, posterior.nc{extras})"

    _show(an.summary(), as_json, text_campaign.text, written, an.converged)


def _show(s: dict, as_json: bool, table, written, converged: bool) -> None:
    """summary.json ``s`` as JSON, or ``table(s)`` and the ``written()`` line, on stdout; a
    warning on stderr when the result did not converge (one recording's or a campaign's)."""
    if as_json:
        import json

        print(json.dumps(s, indent=2))
    else:
        print(table(s))
        print(written())
    if not converged:
        print("dampfit: WARNING: the result did NOT converge; see diagnostics.warnings in "
              "summary.json before using these numbers", file=sys.stderr)


def campaign_command(args, files: list[str], options) -> int:
    """``dampfit analyze FILE FILE…``: several recordings of one damper analysed jointly
    (:func:`dampfit.campaign.analyze_campaign`) under ``options`` (the run's
    :class:`~dampfit._options.AnalysisOptions`) into one result folder; exit code 0."""
    from dampfit.campaign import analyze_campaign
    from dampfit.io.readers import read

    _check_campaign_options(args, files)
    out = Path(args.out) if args.out else Path(Path(files[0]).name + ".campaign.dampfit")
    opts = read_options(args)
    with result_folder(out, "campaign", args.force, inputs=files) as folder:
        recs = [_read_named(read, f, opts) for f in files]
        kw = {"added_mass": list(args.added_mass), "added_mass_sd": args.added_mass_sd or 0.0} \
            if args.added_mass is not None else {}
        with progress_reporting(args):
            an = analyze_campaign(recs, mass=args.mass, mass_sd=args.mass_sd,
                                  options=options, **kw)
            save_with_progress(an, folder, figures=not args.no_figures)
        folder.publish()
        if args.report:
            _write_report(out)
    _print_campaign(an, out, args.json)
    return 0


def _write_report(out: Path) -> None:
    """report.html + report.md in the published folder (the report names the folder's commands)."""
    from dampfit.output.report import write_report

    write_report(out)


def demo(args) -> int:
    """``dampfit demo``: simulate the seed paper's set-up, analyse it; exit code 0."""
    from dampfit import simulate as sim
    from dampfit.pipeline import analyze
    from dampfit.io.readers import read

    out = Path(args.out)
    cfg = sim.preset("paper", seed=args.seed)
    # a previous demo's own folder (marker of kind "demo", or an old one recognised by its
    # files) is regenerated freely; an analyze result only with --force; anything else never
    with figure_process(args) as figs, \
            result_folder(out, "demo", args.force,
                          free=Free(("demo",), old_demo_folder)) as folder, \
            contextlib.closing(figs):
        figs.target(folder.stage)
        print(f"dampfit demo: simulating the seed paper's set-up (m = {cfg.mass} kg, "
              f"k = {cfg.k:.1f} N/m, c = {cfg.c} N s/m, {cfg.duration:g} s at "
              f"{cfg.sample_rate:g} Hz) as a phyphox CSV, then analysing it\n")
        stage = folder.stage
        rec, truth = sim.recording(cfg)
        csv = stage / "paper-preset.csv"
        with folder.writing():
            sim.write_phyphox_csv(rec, csv)
            sim.write_truth(truth, csv.with_suffix(".truth.json"))
        # the recording is read from the staging folder but lives at its final path
        rec = dataclasses.replace(read(csv), path=str(folder.target / csv.name))
        with progress_reporting(args):
            an = analyze(rec, mass=cfg.mass, mass_sd=DEMO_MASS_SD, seed=args.seed,
                         progress=not args.quiet, on_stage=figs.send)
            save_with_progress(an, folder, figures=not args.no_figures, figure_process=figs)
        folder.publish()
        if args.report:
            _write_report(out)
    print_result(an, out, False)
    c = an.summary()["parameters"]["c"]
    inside = c["q05"] <= truth["c"] <= c["q95"]
    print(f"\n  truth c = {truth['c']:g} N s/m is {'inside' if inside else 'OUTSIDE'} the 90 % "
          f"interval [{c['q05']:.5g}, {c['q95']:.5g}]")
    _suggest_warm_up()
    print(f"\n  {NEXT_STEP}")  # the last line
    return 0


def _suggest_warm_up() -> None:
    """After a demo that had to compile kernels (a new machine or dampfit version): say that
    ``dampfit warm-up`` compiles those of every other recording length once."""
    from dampfit.inference.executables import compiled_count

    if compiled_count():
        print(f"\n  this machine compiled {compiled_count()} kernels for the demo's recording "
              "length; `dampfit warm-up` compiles those of every other length once, so that "
              "a first analysis of your own recording starts at once")
