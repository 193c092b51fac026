"""Benchmark: dampfit's phyphox CSV writer and reader against pandas on the same 30,000 rows.

The seed paper's set-up simulated (:func:`dampfit.simulate.preset` ``"paper"``: 60 s at
500 Hz, 30,000 rows of time [s], three acceleration axes and the absolute value [m/s²]) is

1. **written** by :func:`dampfit.files.writers.write_phyphox_csv` (phyphox's comma dialect,
   ten significant digits) and, as the reference, by ``pandas.DataFrame.to_csv`` with the same
   columns and ``float_format="%.9E"`` (the same digits);
2. **read** back by :func:`dampfit.read` (dialect sniffing, header parsing and every check of the
   time base included) and, as the reference, by ``pandas.read_csv`` of the same file.

Each timing is the median of ``--repeat`` runs; the ratios dampfit / pandas are measured in the
same process, so they transfer between machines (the absolute seconds are this machine's).
It replaces the wall-clock assertion the unit tests once had (``test_csv_writer_is_fast``:
"< 1.5 s for 30k rows"); the project keeps performance in benchmark scripts, not in tests.

Usage: ``python paper/bench_csv.py [--repeat 5] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path


def _median_time(fn, repeat: int) -> float:
    """Median wall time [s] of ``repeat`` calls of ``fn``."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run(repeat: int) -> dict:
    """Median times [s] of writing and reading the paper recording, dampfit and pandas."""
    import numpy as np
    import pandas as pd

    import dampfit
    from dampfit.files.writers import write_phyphox_csv
    from dampfit.simulate import preset, recording

    rec, _ = recording(preset("paper"))
    columns = ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)",
               "Acceleration z (m/s^2)", "Absolute acceleration (m/s^2)"]
    frame = pd.DataFrame(np.column_stack([rec.time, rec.accel, np.linalg.norm(rec.accel, axis=1)]),
                         columns=columns)
    with tempfile.TemporaryDirectory() as tmp:
        ours, theirs = Path(tmp) / "dampfit.csv", Path(tmp) / "pandas.csv"
        t_write = _median_time(lambda: write_phyphox_csv(rec, ours), repeat)
        t_write_ref = _median_time(lambda: frame.to_csv(theirs, index=False, float_format="%.9E"),
                                   repeat)
        t_read = _median_time(lambda: dampfit.read(ours), repeat)
        t_read_ref = _median_time(lambda: pd.read_csv(ours), repeat)
        assert dampfit.read(ours).n_samples == rec.n_samples == len(pd.read_csv(theirs))
    return {"rows": int(rec.n_samples), "repeat": repeat,
            "write_s": t_write, "write_pandas_s": t_write_ref, "write_ratio": t_write / t_write_ref,
            "read_s": t_read, "read_pandas_s": t_read_ref, "read_ratio": t_read / t_read_ref}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs per timing (median)")
    parser.add_argument("--json", type=Path, help="also write the numbers to this file")
    args = parser.parse_args(argv)
    r = run(max(1, args.repeat))
    print(f"{r['rows']} rows, median of {r['repeat']}:")
    print(f"  write: dampfit {r['write_s']:.3f} s, pandas.to_csv {r['write_pandas_s']:.3f} s, "
          f"ratio {r['write_ratio']:.2f}")
    print(f"  read:  dampfit {r['read_s']:.3f} s, pandas.read_csv {r['read_pandas_s']:.3f} s, "
          f"ratio {r['read_ratio']:.2f}")
    if args.json:
        args.json.write_text(json.dumps(r, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
