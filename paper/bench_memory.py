"""Benchmark: peak memory of reading (and analysing) a long CSV recording (issue 33).

A free decay of ``--rows`` samples (default 10 million: 5.6 h at 500 Hz) is written as a
two-column CSV (time [s] ``%.10g``, acceleration [m/s²] ``%.7g``: about 20 bytes a row, 213 MB for 10 M
rows; the issue's file was 174 MB), then a child process runs ``dampfit.read`` of it (``--analyze``: the
whole ``dampfit analyze FILE``, ``--figures`` with its figures) and reports its peak resident
memory: the child's own ``ru_maxrss`` (the number ``/usr/bin/time -v`` prints as "Maximum
resident set size") or that of the figure process it started, whichever is larger. The child
is a fresh ``python`` with this source (or ``--src``) on its path, so the number is that of the
command, imports included.

The issue's bound: ≤ 2 GB at the row limit and about 20× the file size at most. Measured
(paper/results/bench_memory.json; 2 shared cores, peak RSS does not depend on the load):

* reading 10 M rows of time and one axis: 1.26 GiB before this work, 0.98 GiB after (the
  dialect sniffed line by line and pandas fed bytes, not ``io.StringIO``, whose 4-byte
  characters copied the text twice); reading costs about 50 bytes a value (60 before), hence
  :data:`dampfit.io.bounded.MAX_CELLS` = 30 M values;
* ``dampfit analyze`` of the 10 M rows: 3.39 GiB before (the preparation of 10 M samples:
  spectra zero-padded to 2^26 points, grid, filters, envelope), 1.17 GiB after (with the
  figures; 5.9× the file, reading is now its largest stage): more than
  :data:`dampfit.signal.decimate.DECIMATE_ABOVE` samples are decimated to 16× the band's top
  first (here 500 → 50 Hz, 1 M samples), and the Cramér–Rao bound accumulates its Fisher
  information in blocks (:data:`dampfit.inference.crlb.BLOCK`) where it formed the whole
  n × 53 Jacobian and a QR of its drift basis;
* ``dampfit analyze`` at the row limit (15 M rows of time and one axis, 323 MB): 1.63 GiB
  with the figures, 5.4× the file;
* ``dampfit analyze`` of 1 M rows (not decimated): 1.34 GiB before (the CRLB of the
  270 000-sample window), 0.83 GiB after (with the figures).

Usage: ``python paper/bench_memory.py [--rows N] [--analyze [--figures]] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def write_csv(path: Path, rows: int, fs: float = 500.0, block: int = 1_000_000) -> int:
    """A viscous free decay (f = 2 Hz, ζ = 0.001, noise 0.01 m/s²) of ``rows`` samples at
    ``fs`` [Hz], written in blocks; returns the file's size [bytes]."""
    import numpy as np

    rng = np.random.default_rng(0)
    with open(path, "w") as fh:
        fh.write("time,accel\n")
        for start in range(0, rows, block):
            t = np.arange(start, min(start + block, rows)) / fs
            a = 3.0 * np.exp(-0.001 * 2 * np.pi * 2 * t) * np.sin(2 * np.pi * 2 * t)
            a += 0.01 * rng.standard_normal(t.size)
            np.savetxt(fh, np.column_stack([t, a]), fmt=["%.10g", "%.7g"], delimiter=",")
    return path.stat().st_size


def analyze_code(csv: Path, out: Path, figures: bool = False) -> str:
    """Python code running ``dampfit analyze CSV --out OUT`` (``--no-figures`` unless
    ``figures``), failing unless it exits 0."""
    extra = "" if figures else ", '--no-figures'"
    return ("from dampfit.cli import main\n"
            f"rc = main(['analyze', {str(csv)!r}, '--out', {str(out)!r}, '--quiet'{extra}])\n"
            "assert rc == 0, rc")


def peak_of(code: str, src: Path = ROOT / "src") -> tuple[float, float]:
    """(peak resident memory [bytes], wall time [s]) of ``python -c code`` with the dampfit
    source ``src`` (another checkout's ``src`` to compare versions): the child's own
    ``ru_maxrss`` or that of a process it started (the figure process), whichever is larger,
    measured in the child (a caller's earlier children do not count)."""
    env = {**os.environ, "PYTHONPATH": str(src), "DAMPFIT_JAX_CACHE": "off"}
    probe = (f"{code}\nimport resource as _r\n"
             "print('PEAK_KIB', max(_r.getrusage(_r.RUSAGE_SELF).ru_maxrss, "
             "_r.getrusage(_r.RUSAGE_CHILDREN).ru_maxrss))")
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", probe], check=True, env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    kib = next(line.split()[1] for line in reversed(done.stdout.splitlines())
               if line.startswith("PEAK_KIB"))
    return float(kib) * 1024.0, wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=10_000_000)
    ap.add_argument("--analyze", action="store_true", help="the whole dampfit analyze")
    ap.add_argument("--figures", action="store_true", help="with --analyze: draw the figures too")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--src", type=Path, default=ROOT / "src",
                    help="the dampfit source measured (default this checkout's)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "long.csv"
        size = write_csv(csv, args.rows)
        if args.analyze:
            code = analyze_code(csv, Path(tmp) / "out", figures=args.figures)
        else:
            code = f"from dampfit.io.readers import read; read({str(csv)!r})"
        peak, wall = peak_of(code, args.src)
    result = {"src": str(args.src), "rows": args.rows, "file_bytes": size, "what": "analyze" if args.analyze else "read",
              "peak_rss_bytes": peak, "peak_over_file": peak / size, "wall_s": wall}
    print(f"{result['what']} of {args.rows} rows ({size / 1e6:.0f} MB): peak "
          f"{peak / 2**30:.2f} GiB = {peak / size:.1f}× the file, {wall:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
