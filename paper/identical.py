"""Results byte-identical before and after a refactor (issue 37, "Done when"): run
``dampfit analyze`` of a base commit's sources and of the working tree on the same recordings
and compare their summary.json with timestamps, durations and paths removed.

Usage (from the worktree root; the base sources from ``git worktree add /tmp/base ed0b9b5``)::

    nice -n 10 /work/venv/bin/python paper/identical.py --base /tmp/base --new . \
        --work /tmp/identical [--simulated] [--real PATH ...] [--out paper/results/identical.md]

* ``--simulated`` makes six recordings with dampfit's own simulator (the *new* tree's, written
  once and read by both sides): two one-mode decays (``dampfit simulate --preset paper`` and
  ``--preset phone``), two two-mode ones (:func:`dampfit.simulate.structure.two_modes`, a mode at
  2 f1, and :func:`~dampfit.simulate.structure.modulated`) and two nonlinear ones
  (:func:`~dampfit.simulate.structure.nonlinear`: Coulomb friction and quadratic drag);
* ``--real PATH`` adds a real recording (e.g. under ../shared/data/real; never copied);
* each side runs ``python -m dampfit analyze FILE --out DIR --seed 0 --no-figures --quiet``
  with ``PYTHONPATH`` = that side's ``src`` (a side's output is reused when its summary.json
  exists already, so the base side can be run once);
* the comparison drops the keys named in :data:`VOLATILE` (when and where the result was
  written, a stage's wall time, the files' digests: posterior.nc records its creation time)
  and compares the rest as canonical JSON text (sorted keys): ``identical`` or the first
  differing keys. A wall time inside a text ("the viscous sampler took 3.1 s",
  :data:`TOOK`) is replaced by "took … s". The keys dropped are listed under the table.

Prints one line per recording and writes a Markdown table (``--out``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

PY = sys.executable
#: Key names (exact) whose values differ between runs or trees by nature: when the result
#: was written, where, and how long a stage took on this machine's clock.
VOLATILE = ("date", "path", "seconds", "wall_time_s", "files")


def _simulated(work: Path, new_src: Path) -> list[tuple[str, Path]]:
    """The six simulated recordings (written once under ``work/sim``)."""
    sim = work / "sim"
    sim.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(new_src))
    out = []
    for name, preset, seed in (("one_mode_paper", "paper", 1), ("one_mode_phone", "phone", 2)):
        path = sim / f"{name}.csv"
        if not path.exists():
            subprocess.run([PY, "-m", "dampfit", "simulate", "--preset", preset, "--seed",
                            str(seed), "--out", str(path)], env=env, check=True,
                           stdout=subprocess.DEVNULL)
        out.append((name, path))
    script = (
        "import sys, numpy as np\n"
        "from dampfit.simulate import structure as s\n"
        "cases = {'two_mode_2f': lambda: s.two_modes(seed=3),\n"
        "         'two_mode_modulated': lambda: s.modulated(seed=4),\n"
        "         'nonlinear_coulomb': lambda: s.nonlinear(F_c=0.002, seed=5),\n"
        "         'nonlinear_drag': lambda: s.nonlinear(c2=0.05, seed=6)}\n"
        "for name, make in cases.items():\n"
        "    rec, _ = make()\n"
        "    path = sys.argv[1] + '/' + name + '.csv'\n"
        "    np.savetxt(path, np.column_stack([rec.time, rec.accel[:, 0]]), delimiter=',',\n"
        "               fmt='%.17g', header='time (s),z (m/s^2)', comments='')\n")
    names = ("two_mode_2f", "two_mode_modulated", "nonlinear_coulomb", "nonlinear_drag")
    if not all((sim / f"{n}.csv").exists() for n in names):
        subprocess.run([PY, "-c", script, str(sim)], env=env, check=True)
    out += [(n, sim / f"{n}.csv") for n in names]
    return out


def _analyze(src: Path, path: Path, out: Path, extra: list[str]) -> tuple[dict | None, str, float]:
    """summary.json of ``dampfit analyze`` under ``src`` (reused when present), its error
    line, and the seconds it took (0 when reused)."""
    summary = out / "summary.json"
    started = time.monotonic()
    if not summary.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, PYTHONPATH=str(src))
        run = subprocess.run([PY, "-m", "dampfit", "analyze", str(path), "--out", str(out),
                              "--force", "--seed", "0", "--no-figures", "--quiet", *extra],
                             env=env, capture_output=True, text=True)
        if run.returncode != 0 or not summary.exists():
            return None, (run.stderr.strip().splitlines() or ["exit %d" % run.returncode])[-1], \
                time.monotonic() - started
    return json.loads(summary.read_text()), "", time.monotonic() - started


DROPPED: set[str] = set()
#: A wall time written into a text ("the viscous sampler took 3.1 s"): replaced by "took … s".
TOOK = re.compile(r"took [0-9.eE+-]+ s\b")


def _clean(value):
    """``value`` without the volatile keys (:data:`VOLATILE`), recursively (the names
    dropped are collected in :data:`DROPPED`)."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if k in VOLATILE:
                DROPPED.add(k)
            else:
                out[k] = _clean(v)
        return out
    if isinstance(value, list):
        return [_clean(v) for v in value]
    if isinstance(value, str):
        return TOOK.sub("took … s", value)
    return value


def _differences(a, b, where: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            out += _differences(a.get(k, "<absent>"), b.get(k, "<absent>"), f"{where}.{k}")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{where}[{i}]")]
    return [] if json.dumps(a) == json.dumps(b) else [where or "."]


def compare(base: Path, new: Path, work: Path, recordings, base_only=False) -> list[dict]:
    rows = []
    for name, path, extra in recordings:
        sides = {}
        for side, root in (("base", base), ("new", new))[:1 if base_only else 2]:
            sides[side] = _analyze(root / "src", path, work / side / name, extra)
        (a, err_a, t_a), (b, err_b, t_b) = sides["base"], sides.get("new", (None, "not run", 0))
        if a is None or b is None:
            verdict = f"not compared: base {err_a or 'ok'}; new {err_b or 'ok'}"
        else:
            ta = json.dumps(_clean(a), sort_keys=True)
            tb = json.dumps(_clean(b), sort_keys=True)
            diff = _differences(_clean(a), _clean(b))
            verdict = "identical" if ta == tb else "DIFFERENT: " + ", ".join(diff[:5])
        rows.append({"name": name, "path": str(path), "options": " ".join(extra),
                     "verdict": verdict, "base_s": t_a, "new_s": t_b,
                     "bytes": len(json.dumps(_clean(b), sort_keys=True)) if b else 0})
        print(f"{name}: {verdict} (base {t_a:.0f} s, new {t_b:.0f} s)", flush=True)
    return rows


def _markdown(rows: list[dict], base: Path, new: Path) -> str:
    lines = [f"| recording | options | summary.json compared [bytes] | result |",
             "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['name']} (`{r['path']}`) | {r['options'] or '—'} | {r['bytes']} | "
                     f"{r['verdict']} |")
    return "\n".join(lines) + "\n\nKeys dropped before the comparison (on both sides): " + \
        ", ".join(f"`{k}`" for k in sorted(DROPPED)) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", type=Path, required=True, help="the base commit's checkout")
    ap.add_argument("--new", type=Path, default=Path("."), help="the working tree")
    ap.add_argument("--work", type=Path, required=True, help="scratch folder for the outputs")
    ap.add_argument("--simulated", action="store_true", help="the six simulated recordings")
    ap.add_argument("--real", nargs="*", default=[], help="real recordings (PATH[::OPTIONS])")
    ap.add_argument("--out", type=Path, help="Markdown table to write")
    ap.add_argument("--base-only", action="store_true",
                    help="run the base side only (its outputs are reused later)")
    args = ap.parse_args(argv)
    recs = []
    if args.simulated:
        recs += [(n, p, []) for n, p in _simulated(args.work, args.new.resolve() / "src")]
    for item in args.real:
        path, _, opts = item.partition("::")
        recs.append((Path(path).parent.name + "/" + Path(path).stem, Path(path), opts.split()))
    rows = compare(args.base.resolve(), args.new.resolve(), args.work, recs, args.base_only)
    if args.out:
        args.out.write_text(_markdown(rows, args.base, args.new))
    return 0 if all(r["verdict"] == "identical" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
