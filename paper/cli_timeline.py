"""Where a warm ``dampfit analyze --report`` spends its wall time: the stages of one run of the
paper recording, as [start, end] seconds after the interpreter started (issue 23, item 7).

Runs the CLI in a fresh Python with timers wrapped around its stages (imports, reading, the fit,
the posterior and the first R-hat/ESS check — which imports arviz —, the damping-law
comparison, writing the folder, waiting for the figure process, the report); the
compiled-kernel store is filled by a first, untimed run in a child process.

Usage: ``python paper/cli_timeline.py [--out FILE.md]``; prints a table (and writes it).
"""

from __future__ import annotations

import time

T0 = time.perf_counter()  # before anything else is imported

import argparse  # noqa: E402
import functools  # noqa: E402
import importlib  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

MARKS: list[tuple[str, float, float]] = []

#: (module, attribute path, label) of the analysis stages timed, in the order they run: wrapped
#: once the CLI has imported the stack (their modules are the stack).
STACK_STAGES = (
    ("dampfit.io.readers", "read", "read the recording"),
    ("dampfit.pipeline", "analyze", "analysis (all stages)"),
    ("dampfit.stages", "fit_stages", "fit stages (baselines, least squares, noise)"),
    ("dampfit.inference.posterior", "run_adaptive", "posterior (emcee blocks)"),
    ("dampfit.inference.posterior", "diagnose", "R-hat/ESS check (first: imports arviz)"),
    ("dampfit.stages", "assess_damping", "damping-law comparison"),
    ("dampfit.pipeline", "modes_stage", "modes screen"),
    ("dampfit.analysis", "Analysis.save", "write the folder"),
    ("dampfit.analysis", "Analysis.to_netcdf", "posterior.nc"),
)
#: The CLI's own stages, wrapped before it runs (their modules import no stack).
CLI_STAGES = (
    ("dampfit.output.figure_process", "FigureProcess.finish", "last figures / wait"),
    ("dampfit.cli.analyze", "_write_report", "report"),
)


def _wrap(module: str, path: str, label: str) -> None:
    owner = importlib.import_module(module)
    *parents, name = path.split(".")
    for p in parents:
        owner = getattr(owner, p)
    inner = getattr(owner, name)

    @functools.wraps(inner)
    def timed(*args, **kwargs):
        start = time.perf_counter() - T0
        try:
            return inner(*args, **kwargs)
        finally:
            MARKS.append((label, start, time.perf_counter() - T0))

    setattr(owner, name, timed)


def child(argv_cli: list[str]) -> None:
    """The timed run (a fresh interpreter: nothing imported before the CLI imports it)."""
    import json

    import dampfit.cli.analyze as cli_analyze

    inner = cli_analyze.analyse_into

    def analyse_into(*args, **kwargs):  # the stack is imported here, as in the CLI
        started = time.perf_counter() - T0
        for module, path, label in STACK_STAGES:
            _wrap(module, path, label)
        MARKS.append(("imports (stack)", started, time.perf_counter() - T0))
        return inner(*args, **kwargs)

    cli_analyze.analyse_into = analyse_into
    for module, path, label in CLI_STAGES:
        _wrap(module, path, label)
    from dampfit.cli import main as cli_main

    if cli_main(argv_cli) != 0:
        raise SystemExit("the CLI run failed")
    MARKS.append(("whole run (from the interpreter's start)", 0.0, time.perf_counter() - T0))
    print(json.dumps(MARKS))


def main(argv=None) -> int:
    import json

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="also write the table to this Markdown file")
    a = ap.parse_args(argv)
    from dampfit import simulate as sim

    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "paper.csv"
        sim.write_phyphox_csv(sim.recording(sim.preset("paper", seed=0))[0], csv)
        env = dict(os.environ, DAMPFIT_JAX_CACHE=str(Path(tmp) / "cache"))
        argv_cli = ["analyze", str(csv), "--mass", "5.3", "--out", str(Path(tmp) / "out"),
                    "--force", "--quiet", "--report"]
        subprocess.run([sys.executable, "-m", "dampfit", *argv_cli], check=True,
                       stdout=subprocess.DEVNULL, env=env)  # fills the store
        out = subprocess.run([sys.executable, __file__, "--child", *argv_cli], check=True,
                             capture_output=True, text=True, env=env).stdout
    marks = json.loads(out.strip().splitlines()[-1])
    rows = ["| stage | start [s] | end [s] | wall [s] |", "|---|---|---|---|"]
    for label, s, e in sorted(marks, key=lambda m: (m[1], -m[2])):
        rows.append(f"| {label} | {s:.2f} | {e:.2f} | {e - s:.2f} |")
    text = "\n".join(rows)
    print(text)
    if a.out:
        Path(a.out).write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        child(sys.argv[2:])
        raise SystemExit(0)
    raise SystemExit(main())
