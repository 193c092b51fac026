"""A new user's first analysis against a warm one (issue 36, "Done when" 1): CPU seconds.

What a new user does on a fresh machine: install, run ``dampfit demo`` and the
``dampfit warm-up`` the demo suggests, then ``dampfit analyze`` their own recording. This
script does exactly that in child processes, on an EMPTY compiled-kernel store of its own
(``DAMPFIT_JAX_CACHE`` = a new private temporary folder: the user's ``~/.cache/dampfit/jax``
is never read or written; a ``JAX_COMPILATION_CACHE_DIR`` of the caller is dropped), then
analyses each recording twice: the *first* analysis of that file (it may compile the kernels
of a shape the preparation did not meet) and a second, *warm* one. Per run it measures the CPU
seconds of the child and all its descendants (user + system, the ``resource.getrusage(
RUSAGE_CHILDREN)`` delta around the run; CPU, not wall time, so that the ratio does not
depend much on the other load of a shared machine), the wall time, and, from JAX's
compilation log (``JAX_LOG_COMPILES=1``), the XLA compilations and their logged compile time
per kernel. The ratio first/warm per file, its median and its maximum are the figures of
merit (goal: median ≤ 1.5, none above 2). It also checks that the two runs' summary.json
numbers are identical (same seed, same numbers, cold or warm store).

Recordings: a few short real ones read in place from ``../shared/data/real`` (never copied;
one of them finds a second mode, so the several-mode kernels are exercised) and simulated
ones (``dampfit.simulate`` paper preset) of several lengths and sample rates. Figures are off
(``--no-figures``) in every analysis: drawing them costs the same cold or warm, so leaving
them in would only flatter the ratio.

Usage (from the checkout root; ≈ 15–25 min of CPU on two cores)::

    PYTHONPATH=src nice -n 10 python paper/first_run.py --max-samples 4096   # writes paper/results/first_run.{md,json}
    PYTHONPATH=src python paper/first_run.py --only sim-10s-30Hz   # one recording (a check)

The children run a copy of ``src/dampfit`` taken at the start (the store is keyed by the
package's source digest: an edit of the checkout during the run would otherwise make the warm
store cold). No timed unit test: this is a benchmark script, its numbers depend on the machine.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT.parent / "shared" / "data" / "real"
OUT = ROOT / "paper" / "results" / "first_run.md"
COMPILE = re.compile(r"Finished XLA compilation of jit\((?P<name>[^)]+)\) in (?P<s>[\d.e+-]+) sec")
#: Real recordings (path under REAL, mass [kg] from SOURCES.md or None): short ones, < 15 s warm.
_ADXL = "cantilever-adxl357-demirkaya/"
REAL_FILES = {
    "ruler cantilever (533 Hz, 6 s)": ("cantilever-adxl345-rayjada/Cantilever-Data.csv", None),
    "pendulum 15° (100 Hz, 45 s)": ("phone-pendulum-harinlee83/l2LongTheta15.csv", None),
    "LSM 50 cm box (6 kHz, 20 s)": (_ADXL + "LSM_accelerometer/emptybox5cm/08-05_14-36-57_50cm_"
                                    "acc_7cm_ID2cm/accelerometer_data.npy", 0.037),
    "50 cm cantilever, 2 modes (4 kHz, 20 s)": (_ADXL + "tests_for_comparing_1st_nfreq/50cm_adxl/"
                                                "08-12_11-47-32_adxl6cmfromtip2cmID/"
                                                "accelerometer_data.npy", 0.037),
}
#: Simulated recordings: (duration [s], sample rate [Hz], seed) of the paper preset.
SIMULATED = {"sim-10s-30Hz": (10.0, 30.0, 1), "sim-23s-50Hz": (23.0, 50.0, 2),
             "sim-120s-1kHz": (120.0, 1000.0, 3)}
_PAPER_MASS = 5.3  # [kg] the paper preset's mass


def _cpu_children() -> float:
    """CPU seconds [s] (user + system) of every child process waited for so far."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _run(cmd: list[str], env: dict) -> dict:
    """Run one dampfit command in a child process: CPU [s], wall [s], XLA compilations."""
    cpu0, t0 = _cpu_children(), time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "dampfit", *cmd], env=env,
                          capture_output=True, text=True, check=False)
    wall, cpu = time.perf_counter() - t0, _cpu_children() - cpu0
    if proc.returncode != 0:
        raise SystemExit(f"dampfit {' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    compiles = [(m["name"], float(m["s"])) for m in COMPILE.finditer(proc.stderr)]
    said = [ln.strip() for ln in proc.stderr.splitlines() if "compiling kernel" in ln]
    return {"cpu_s": round(cpu, 2), "wall_s": round(wall, 2), "xla_compiles": len(compiles),
            "compile_s": round(sum(s for _, s in compiles), 2),
            "compiled": dict(collections.Counter(n for n, _ in compiles)), "announced": said}


def _simulate(folder: Path, names) -> dict[str, tuple[Path, float | None]]:
    from dampfit import simulate as sim

    paths = {}
    for name in names:
        d, r, seed = SIMULATED[name]
        rec, _ = sim.recording(sim.preset("paper", duration=d, sample_rate=r, seed=seed))
        paths[name] = (folder / f"{name}.csv", _PAPER_MASS)
        sim.write_phyphox_csv(rec, paths[name][0])
    return paths


#: summary.json paths that differ between two runs of one command by nature: the date, wall
#: times [s] (a law budget's basis quotes the viscous sampler's), and the digest of posterior.nc
#: (which records its creation time).
CLOCK = re.compile(r"^/(provenance/date|files/.*|timing.*|.*/seconds|.*wall_time_s|.*/budget/basis)$")


def _numbers(folder: Path) -> dict:
    """summary.json of the result folder ``folder``."""
    return json.loads((folder / "summary.json").read_text())


def _differ(a, b, where: str = "") -> list[str]:
    """The summary.json paths at which ``a`` and ``b`` differ (at most 20)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{where}/{k}" for k in a.keys() ^ b.keys()]
        for k in a.keys() & b.keys():
            out += _differ(a[k], b[k], f"{where}/{k}")
        return out[:20]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (u, v) in enumerate(zip(a, b))
                for d in _differ(u, v, f"{where}[{i}]")][:20]
    nan = isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)
    return [] if a == b or nan else [where or "/"]


def _analyze(name: str, path: Path, mass, tmp: Path, env: dict) -> dict:
    cmd = ["analyze", str(path), "--no-figures", "--force"] + \
          (["--mass", str(mass)] if mass is not None else [])
    row = {"recording": name}
    for label in ("first", "warm"):
        out = tmp / f"{re.sub(r'[^A-Za-z0-9]+', '_', name)}.{label}"
        row[label] = _run(cmd + ["--out", str(out)], env)
        row[f"{label}_numbers"] = _numbers(out)
    row["ratio"] = round(row["first"]["cpu_s"] / row["warm"]["cpu_s"], 2)
    row["differ"] = [d for d in _differ(row.pop("first_numbers"), row.pop("warm_numbers"))
                     if not CLOCK.match(d)]
    row["identical"] = not row["differ"]
    print(f"{name}: first {row['first']['cpu_s']} s CPU ({row['first']['xla_compiles']} XLA "
          f"compilations), warm {row['warm']['cpu_s']} s, ratio {row['ratio']}, "
          f"same numbers: {row['identical']}", flush=True)
    return row


def _markdown(prep: dict, rows: list[dict], ratios: list[float], warm_args: str) -> str:
    lines = ["# A new user's first analysis: CPU seconds, empty kernel store", "",
             "<!-- written by paper/first_run.py -->", "",
             ("Child processes, an empty compiled-kernel store of their own; CPU seconds of "
              "each command and its descendants (`getrusage(RUSAGE_CHILDREN)` deltas); "
              "`--no-figures`; XLA compilations counted from `JAX_LOG_COMPILES=1`."), "",
             "| preparation | CPU [s] | wall [s] | XLA compilations |", "|---|---:|---:|---:|"]
    for label, r in prep.items():
        lines.append(f"| `dampfit {label}{warm_args if label == 'warm-up' else ''}` | {r['cpu_s']} | {r['wall_s']} | {r['xla_compiles']} |")
    lines += ["", ("| recording | first CPU [s] | warm CPU [s] | first / warm | XLA compilations "
                   "(first) | compiled kernels (first) | same numbers |"),
              "|---|---:|---:|---:|---:|---|---|"]
    for r in rows:
        kernels = ", ".join(f"`{k}`×{v}" for k, v in sorted(r["first"]["compiled"].items()))
        lines.append(f"| {r['recording']} | {r['first']['cpu_s']} | {r['warm']['cpu_s']} | "
                     f"{r['ratio']} | {r['first']['xla_compiles']} | {kernels or '–'} | "
                     f"{'yes' if r['identical'] else 'NO'} |")
    lines += ["", (f"Median first/warm {statistics.median(ratios):.2f}, max {max(ratios):.2f} "
                   f"(goal: median ≤ 1.5, none above 2) over {len(ratios)} recordings."), ""]
    return "\n".join(lines)


def _rewrite(source: Path, out: Path, max_samples: int | None) -> int:
    """The Markdown of a saved run (``--from-json``), the clock paths (:data:`CLOCK`) left out
    of the comparison."""
    saved = json.loads(source.read_text())
    for row in saved["runs"]:
        row["differ"] = [d for d in row.get("differ", []) if not CLOCK.match(d)]
        row["identical"] = not row["differ"]
    warm_args = "" if max_samples is None else f" --max-samples {max_samples}"
    out.write_text(_markdown(saved["preparation"], saved["runs"],
                             [r["ratio"] for r in saved["runs"]], warm_args))
    print(out.read_text())
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=OUT, help="Markdown to write (and .json beside it)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="only these recordings")
    ap.add_argument("--max-samples", type=int, default=None, metavar="N",
                    help="pass --max-samples N to `dampfit warm-up` (default: its own default)")
    ap.add_argument("--no-warm-up", action="store_true",
                    help="prepare with `dampfit demo` alone (no `dampfit warm-up`)")
    ap.add_argument("--from-json", type=Path, metavar="JSON",
                    help="only rewrite the Markdown from a JSON this script wrote")
    args = ap.parse_args(argv)
    if args.from_json:
        return _rewrite(args.from_json, args.out, args.max_samples)
    real = {k: v for k, v in REAL_FILES.items() if not args.only or k in args.only}
    sims = [k for k in SIMULATED if not args.only or k in args.only]
    if real and not REAL.is_dir():
        raise SystemExit(f"no real recordings at {REAL}")
    with tempfile.TemporaryDirectory(prefix="dampfit-first-run-") as tmp:
        tmp = Path(tmp)
        cache = tmp / "cache"
        cache.mkdir(mode=0o700)
        env = {k: v for k, v in os.environ.items()
               if k != "JAX_COMPILATION_CACHE_DIR" and not k.startswith("DAMPFIT_")}
        # a snapshot of the source: the store is keyed by the package's source digest, so an
        # edit of the checkout during the run must not invalidate what the warm-up compiled
        shutil.copytree(ROOT / "src" / "dampfit", tmp / "src" / "dampfit",
                        ignore=shutil.ignore_patterns("__pycache__"))
        env.update(DAMPFIT_JAX_CACHE=str(cache), JAX_LOG_COMPILES="1", MPLBACKEND="Agg",
                   PYTHONPATH=os.pathsep.join([str(tmp / "src"), env.get("PYTHONPATH", "")]))
        files = {k: (REAL / p, m) for k, (p, m) in real.items()} | _simulate(tmp, sims)
        prep = {"demo": _run(["demo", "--out", str(tmp / "demo"), "--no-figures"], env)}
        if not args.no_warm_up:
            prep["warm-up"] = _run(["warm-up"] + ([] if args.max_samples is None else
                                                  ["--max-samples", str(args.max_samples)]), env)
        for label, r in prep.items():
            print(f"dampfit {label}: {r['cpu_s']} s CPU, {r['xla_compiles']} XLA compilations",
                  flush=True)
        rows = [_analyze(name, p, m, tmp, env) for name, (p, m) in files.items()]
    ratios = [r["ratio"] for r in rows]
    warm_args = "" if args.max_samples is None else f" --max-samples {args.max_samples}"
    args.out.write_text(_markdown(prep, rows, ratios, warm_args))
    args.out.with_suffix(".json").write_text(json.dumps({"preparation": prep, "runs": rows},
                                                        indent=1, ensure_ascii=False) + "\n")
    print(args.out.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
