"""A long recording (issue 33, "memory bounded"): reading a CSV costs a bounded number of
bytes of memory per byte of file, and a table of more values than
:data:`dampfit.io.bounded.MAX_CELLS` is refused in one line before it is parsed. The
10-million-sample measurement itself is ``paper/bench_memory.py`` (not a timed test)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dampfit.errors import InputError
from dampfit.io import bounded
from dampfit.io.readers import read
from tests._support.hostile import assert_one_line_error, run

ROOT = Path(__file__).resolve().parents[2]


def _csv(path: Path, rows: int, axes: int = 3) -> Path:
    t = np.arange(rows) / 500.0
    a = np.sin(2 * np.pi * 2 * t)[:, None] * np.exp(-0.01 * t)[:, None] * np.ones(axes)
    a += 0.01 * np.random.default_rng(0).standard_normal((rows, axes))
    with open(path, "w") as fh:
        fh.write("time," + ",".join(f"a{i}" for i in range(axes)) + "\n")
        np.savetxt(fh, np.column_stack([t, a]), fmt=["%.10g"] + ["%.7g"] * axes, delimiter=",")
    return path


def _peak_kib(path: Path) -> int:
    """Peak resident memory [KiB] of a fresh process that reads ``path``."""
    code = ("import resource; from dampfit.io.readers import read; read(%r); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)" % str(path))
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=300, check=True)
    return int(out.stdout.split()[-1])


def test_reading_a_csv_costs_a_bounded_memory_per_byte(tmp_path):
    """Memory beyond the imports grows linearly, at under 9 bytes per byte of file (time and
    three axes; paper/bench_memory.py measures 6.3 at 10 M rows of time and one axis)."""
    small, large = _csv(tmp_path / "s.csv", 100_000), _csv(tmp_path / "l.csv", 500_000)
    grown = (_peak_kib(large) - _peak_kib(small)) * 1024
    per_byte = grown / (large.stat().st_size - small.stat().st_size)
    print(f"{per_byte:.2f} bytes of memory per byte of file")
    assert per_byte < 9, f"{per_byte:.1f} bytes of memory per byte of file"


def test_a_table_of_too_many_values_is_refused_before_parsing(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(bounded, "MAX_CELLS", 1000)
    wide = _csv(tmp_path / "wide.csv", 300, axes=3)  # 300 rows × 4 columns
    with pytest.raises(InputError, match="has 300 rows of 4 column.s., 1200 values, more than "
                                         "the limit of 1000"):
        read(wide)
    narrow = _csv(tmp_path / "narrow.csv", 300, axes=1)  # 600 values
    assert read(narrow).time.size == 300
    code, _, err = run(["analyze", wide, "--out", tmp_path / "o"], capsys)
    assert_one_line_error(code, err, match="values, more than the limit")
    assert not (tmp_path / "o").exists()
