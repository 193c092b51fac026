"""Benchmark of the figure stage of ``dampfit analyze FILE --report`` (issue 11, "fast CLI").

In one process:

1. simulates the recording of ``paper/benchmark.py`` (the seed paper's set-up: 60 s at 500 Hz,
   ``simulate.preset("paper", seed=0)``), writes it as a phyphox CSV and reads it back, as the
   CLI does;
2. runs :func:`dampfit.analyze` once with the CLI's defaults and ``--mass 5.3`` (timed, not part
   of the figure numbers);
3. times :func:`dampfit.output.figures.save_figures` — what the CLI's ``write_outputs`` calls
   to draw the seven analysis figures (``signal``, ``spectrum``, ``fit``, ``displacement``,
   ``posterior``, ``trace``, ``amplitude``) before ``--report`` embeds them — into a fresh
   temporary folder: the first call (the one a CLI run makes, paying matplotlib's first-use
   costs) reported apart as the warm-up, then the median [s] of ``--repeats`` calls;
4. times each figure alone the same way (``--repeats`` times, median), split into building
   the figure (the figure function) and drawing and writing the PNG (``save_png``: layout,
   Agg drawing, PNG encoding, atomic write).

Usage: ``python paper/figure_benchmark.py [--repeats 5] [--dpi 110] [--module FILE]
[--baseline FILE] [--fresh N] [--keep DIR]``. ``--module`` times another version of the figures
module instead of the installed one; ``--baseline`` times a second version as well (e.g. the one
before a change, ``git show HEAD:src/dampfit/output/figures.py > /tmp/old.py``), interleaved
with the first on the same analysis so that a busy machine slows both alike, and prints the
speed-up; ``--fresh N`` times the first call in N fresh processes per module as well (each
imports what a CLI run has imported by its figure stage and loads the analysis pickled): the
figure stage of one CLI run; ``--keep`` leaves the PNGs of the last call in ``DIR`` to look at.
Wall times are the measure (the process CPU time of ``save_figures`` is printed beside them).
Only the project's own dependencies are used.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

MASS = 5.3  # [kg], as in paper/benchmark.py


def _figures_module(path: str | None):
    """``dampfit.output.figures``, or the module file ``path`` loaded in its place."""
    if path is None:
        from dampfit.output import figures

        return figures
    spec = importlib.util.spec_from_file_location("dampfit_figures_under_test", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _analysis():
    """The paper recording (via a phyphox CSV, as the CLI reads it) and its analysis."""
    import dampfit
    from dampfit import simulate as sim
    from dampfit.io.readers import read

    rec, _ = sim.recording(sim.preset("paper", seed=0))
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "paper.csv"
        sim.write_phyphox_csv(rec, csv)
        rec = read(csv)
    t0 = time.perf_counter()
    an = dampfit.analyze(rec, mass=MASS)
    return an, time.perf_counter() - t0


def _one_figure(figs, an, name: str, outdir: Path, dpi: int) -> tuple[float, float]:
    """(build, write) wall times [s] of figure ``name`` into ``outdir`` (in the module's drawing
    context, as :func:`~dampfit.output.figures.save_figures` draws them, where it has one)."""
    with getattr(figs, "drawing", contextlib.nullcontext)():
        return _one_figure_timed(figs, an, name, outdir, dpi)


def _one_figure_timed(figs, an, name: str, outdir: Path, dpi: int) -> tuple[float, float]:
    t0 = time.perf_counter()
    fig = figs.FIGURES[name](an)
    t1 = time.perf_counter()
    if fig is not None:
        figs.save_png(fig, outdir / f"{name}.png", dpi)
    return t1 - t0, time.perf_counter() - t1


def _first_call(figs, an, tmp: Path, label: str, dpi: int) -> dict:
    """Wall time [s] of the first ``save_figures`` call of ``figs`` (``first``), written into
    ``tmp``; the later timings are appended to the returned dict's lists."""
    t0 = time.perf_counter()
    written = figs.save_figures(an, tmp / f"{label}-first", dpi=dpi)
    return {"first": time.perf_counter() - t0, "wall": [], "cpu": [], "per": {},
            "missing": sorted(set(figs.FIGURES) - set(written))}


def _time_call(figs, an, tmp: Path, label: str, r: int, dpi: int, res: dict) -> None:
    """Wall and process-CPU time [s] of one ``save_figures`` call appended to ``res``."""
    w0, c0 = time.perf_counter(), time.process_time()
    figs.save_figures(an, tmp / f"{label}-total{r}", dpi=dpi)
    res["wall"].append(time.perf_counter() - w0)
    res["cpu"].append(time.process_time() - c0)


def _time_figures(figs, an, tmp: Path, label: str, r: int, dpi: int, per: dict) -> None:
    """One (build, write) timing of every figure of ``figs`` appended to ``per``."""
    out = tmp / f"{label}-each{r}"
    out.mkdir()
    for name in figs.FIGURES:
        build, write = _one_figure(figs, an, name, out, dpi)
        per.setdefault(name, ([], []))[0].append(build)
        per[name][1].append(write)


def _report(label: str, res: dict, repeats: int) -> None:
    med = statistics.median
    print(f"\n== {label}")
    print(f"save_figures, first call in this process: {res['first']:.3f} s")
    print(f"save_figures, median of {repeats} later calls: {med(res['wall']):.3f} s wall "
          f"(min {min(res['wall']):.3f}, max {max(res['wall']):.3f}), "
          f"{med(res['cpu']):.3f} s CPU"
          + (f"; not written: {res['missing']}" if res["missing"] else ""))
    print(f"{'figure':14s}{'build [s]':>11s}{'draw+write [s]':>16s}{'total [s]':>11s}")
    s_b = s_w = 0.0
    for name, (builds, writes) in res["per"].items():
        b, w = med(builds), med(writes)
        s_b, s_w = s_b + b, s_w + w
        print(f"{name:14s}{b:11.3f}{w:16.3f}{b + w:11.3f}")
    print(f"{'sum':14s}{s_b:11.3f}{s_w:16.3f}{s_b + s_w:11.3f}")


def _fresh_first_calls(an, mods: dict, runs: int, dpi: int, tmp: Path) -> dict[str, list]:
    """Wall time [s] of the first ``save_figures`` call in ``runs`` fresh processes per module,
    the modules alternating: each process imports what this one has imported by now (the
    analysis' libraries, as in a CLI run at its figure stage), loads the analysis (pickled),
    then times one call."""
    import pickle
    import subprocess

    state = tmp / "state.pkl"
    skip = ("__main__", "figure_benchmark", "dampfit_figures_under_test")
    with open(state, "wb") as fh:
        pickle.dump({"an": an, "modules": sorted(m for m in sys.modules if m not in skip)}, fh)
    out: dict[str, list] = {label: [] for label in mods}
    for r in range(runs):
        for label, path in mods.items():
            cmd = [sys.executable, __file__, "--child", str(state), "--dpi", str(dpi),
                   "--keep", str(tmp / f"fresh-{label}-{r}")]
            if path:
                cmd += ["--module", path]
            res = subprocess.run(cmd, check=True, capture_output=True, text=True)
            out[label].append(float(res.stdout.split()[-1]))
    return out


def _child(state: str, module: str | None, outdir: str, dpi: int) -> int:
    """``--child``: import the parent's modules, load the analysis, time one first call."""
    import importlib
    import pickle

    with open(state, "rb") as fh:
        names = pickle.load(fh)["modules"]  # the analysis' classes need their modules first
    for name in names:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 — a module that cannot be re-imported is skipped
            pass
    with open(state, "rb") as fh:
        an = pickle.load(fh)["an"]
    figs = _figures_module(module)
    t0 = time.perf_counter()
    figs.save_figures(an, Path(outdir), dpi=dpi)
    print(f"{time.perf_counter() - t0:.4f}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="time the analysis figures of dampfit --report")
    ap.add_argument("--repeats", type=int, default=5, help="timed calls (median; at least 3)")
    ap.add_argument("--dpi", type=int, default=110, help="PNG resolution (the CLI's: 110)")
    ap.add_argument("--module", help="time this figures module file instead of dampfit's")
    ap.add_argument("--baseline", metavar="FILE",
                    help="also time this figures module file, interleaved with the other on "
                         "the same analysis, and print the speed-up")
    ap.add_argument("--keep", help="write the PNGs of the last call into this folder")
    ap.add_argument("--fresh", type=int, default=0, metavar="N",
                    help="also time the first call in N fresh processes per module (what one "
                         "CLI run pays)")
    ap.add_argument("--child", help=argparse.SUPPRESS)  # one fresh process of --fresh
    a = ap.parse_args(argv)
    if a.child:
        return _child(a.child, a.module, a.keep, a.dpi)
    repeats = max(3, a.repeats)

    import matplotlib
    import matplotlib.backends.backend_agg  # noqa: F401  (imports are the import floor's part,
    import matplotlib.figure  # noqa: F401  # not the figures': paper/benchmark.py STACK)

    mods = {"figures": _figures_module(a.module)}
    if a.baseline:
        mods["baseline"] = _figures_module(a.baseline)
    an, t_an = _analysis()
    print(f"dampfit.analyze (60 s at 500 Hz, mass {MASS} kg): {t_an:.2f} s (not counted); "
          f"matplotlib {matplotlib.__version__}; load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} CPUs")
    for label, figs in mods.items():
        print(f"{label}: {a.module if label == 'figures' and a.module else figs.__file__}")

    with tempfile.TemporaryDirectory() as tmp:
        # the module timed first pays matplotlib's first-use costs (fonts, caches) in its first
        # call: that is the new one, so the comparison of first calls is conservative
        res = {label: _first_call(figs, an, Path(tmp), label, a.dpi)
               for label, figs in mods.items()}
        for r in range(repeats):  # the modules interleaved
            for label, figs in mods.items():
                _time_call(figs, an, Path(tmp), label, r, a.dpi, res[label])
        for r in range(repeats):
            for label, figs in mods.items():
                _time_figures(figs, an, Path(tmp), label, r, a.dpi, res[label]["per"])
        if a.keep:
            mods["figures"].save_figures(an, Path(a.keep), dpi=a.dpi)
            print(f"PNGs in {a.keep}")
        paths = {"figures": a.module, "baseline": a.baseline}
        fresh = _fresh_first_calls(an, {label: paths[label] for label in mods}, a.fresh,
                                   a.dpi, Path(tmp)) if a.fresh > 0 else {}

    for label in mods:
        _report(label, res[label], repeats)
        if fresh:
            print(f"first call in {a.fresh} fresh processes: median "
                  f"{statistics.median(fresh[label]):.3f} s "
                  f"({', '.join(f'{t:.3f}' for t in fresh[label])})")
    if a.baseline:
        med = statistics.median
        new, old = res["figures"], res["baseline"]
        print(f"\nspeed-up of save_figures (baseline / figures): "
              f"{med(old['wall']) / med(new['wall']):.2f}x wall, "
              f"{med(old['cpu']) / med(new['cpu']):.2f}x CPU, first call "
              f"{old['first'] / new['first']:.2f}x")
        if fresh:
            ratio = statistics.median(fresh["baseline"]) / statistics.median(fresh["figures"])
            print(f"first call in a fresh process: {ratio:.2f}x")
        print("per figure (wall, build + draw + write): " + ", ".join(
            f"{name} {sum(map(med, old['per'][name])) / sum(map(med, new['per'][name])):.1f}x"
            for name in new["per"] if name in old["per"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
