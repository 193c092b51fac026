"""What compiles on a new recording (issue 36, item 1): an inventory, not a benchmark.

Runs ``dampfit analyze`` three times in fresh processes on an empty compiled-kernel store of
its own (``DAMPFIT_JAX_CACHE`` = a temporary folder), with JAX's compilation logging on
(``JAX_LOG_COMPILES=1``): recording A cold, A again (warm), then a second, new recording B
of another length and rate. Counts the XLA compilations of each run per kernel, with the
compile time JAX logs for each (one run, on whatever load the machine has: an indication,
not a measurement to compare), the fit-sample count and shape bucket of each recording, and
the number of sample buckets a recording up to the limits can fall in. Writes
``paper/results/compile_inventory.md``.

    PYTHONPATH=src python paper/compile_inventory.py
"""

from __future__ import annotations

import collections
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "paper" / "results" / "compile_inventory.md"
COMPILE = re.compile(r"Finished XLA compilation of jit\((?P<name>[^)]+)\) in (?P<s>[\d.e+-]+) sec")
RECORDINGS = {"A": dict(duration=10.0, sample_rate=100.0, seed=0),
              "B": dict(duration=23.0, sample_rate=50.0, seed=3)}


def _simulate(folder: Path) -> dict[str, Path]:
    from dampfit import simulate as sim

    paths = {}
    for name, kw in RECORDINGS.items():
        rec, _ = sim.recording(sim.preset("paper", **kw))
        paths[name] = folder / f"{name}.csv"
        sim.write_phyphox_csv(rec, paths[name])
    return paths


def _bucket(path: Path) -> tuple[int, int]:
    from dampfit.io.readers import read
    from dampfit.signal import prepare

    fd = prepare.fit_data(prepare.prepare(read(path)))
    return fd.tau.size, prepare.padded_length(fd.tau.size)


def _run(path: Path, out: Path, env: dict) -> tuple[list[tuple[str, float]], list[str]]:
    cmd = [sys.executable, "-m", "dampfit", "analyze", str(path), "--mass", "5.3",
           "--no-figures", "--out", str(out), "--force"]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    compiles = [(m["name"], float(m["s"])) for m in COMPILE.finditer(proc.stderr)]
    said = [ln for ln in proc.stderr.splitlines() if ln.startswith("compiling kernel")]
    return compiles, said


def _buckets_up_to(n_max: int) -> int:
    from dampfit.signal.prepare import padded_length

    sizes, n = set(), 1
    while n <= n_max:
        b = padded_length(n)
        sizes.add(b)
        n = b + 1
    return len(sizes)


def main() -> int:
    from dampfit.simulate.config import MAX_SIM_SAMPLES as MAX_SAMPLES  # duration × rate [samples]

    with tempfile.TemporaryDirectory(prefix="dampfit-inventory-") as tmp:
        tmp = Path(tmp)
        cache = tmp / "cache"
        cache.mkdir(mode=0o700)
        env = {k: v for k, v in os.environ.items()
               if k not in ("JAX_COMPILATION_CACHE_DIR", "DAMPFIT_EXECUTABLE_CACHE")}
        env.update(DAMPFIT_JAX_CACHE=str(cache), JAX_LOG_COMPILES="1",
                   PYTHONPATH=str(ROOT / "src"))
        paths = _simulate(tmp)
        buckets = {name: _bucket(p) for name, p in paths.items()}
        runs = {}
        for label, name in (("A, empty store", "A"), ("A again", "A"),
                            ("B, a new recording", "B")):
            runs[label] = _run(paths[name], tmp / f"{label[0]}.out", env)
    lines = ["# What compiles on a new recording", "",
             "Made by `PYTHONPATH=src python paper/compile_inventory.py` (one run each, fresh "
             "processes, an empty compiled-kernel store of its own; compile times as JAX logs "
             "them, on a shared, loaded machine: an indication only).", "",
             "| recording | simulated | fit samples | sample bucket |", "|---|---|---:|---:|"]
    for name, kw in RECORDINGS.items():
        n, b = buckets[name]
        lines.append(f"| {name} | paper preset, {kw['duration']:g} s at {kw['sample_rate']:g} Hz "
                     f"| {n} | {b} |")
    lines += ["", "| run | XLA compilations | compile time [s] | announced by dampfit |",
              "|---|---:|---:|---:|"]
    for label, (compiles, said) in runs.items():
        lines.append(f"| {label} | {len(compiles)} | {sum(s for _, s in compiles):.1f} | "
                     f"{len(said)} |")
    lines += ["", "Per kernel, first run (A, empty store):", "",
              "| kernel (jit name) | compilations | compile time [s] |", "|---|---:|---:|"]
    per = collections.defaultdict(list)
    for name, s in runs["A, empty store"][0]:
        per[name].append(s)
    for name, ss in sorted(per.items(), key=lambda kv: -sum(kv[1])):
        lines.append(f"| `{name}` | {len(ss)} | {sum(ss):.1f} |")
    lines += ["", f"A recording up to the limits ({MAX_SAMPLES:.0e} samples) can fall in "
              f"{_buckets_up_to(int(MAX_SAMPLES))} sample buckets (256·{{1, 1.5}}·2^k, "
              "`dampfit.signal.prepare.padded_length`), each compiled separately.", ""]
    OUT.write_text("\n".join(lines))
    print(OUT.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
