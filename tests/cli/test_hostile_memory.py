"""A long recording (issue 33, "memory bounded"): reading a CSV costs a bounded number of
bytes of memory per byte of file, a table of more values than
:data:`dampfit.io.bounded.MAX_CELLS` is refused in one line before it is parsed, a recording
of more than :data:`dampfit.signal.decimate.DECIMATE_ABOVE` samples is decimated to the rate
its band needs (said, recorded, and c still right), and the whole ``dampfit analyze`` of a
10-million-sample CSV peaks under 2 GB (slow; ``paper/bench_memory.py`` measures it too)."""

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
from dampfit.io.recording import Recording
from dampfit.signal import decimate
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


@pytest.mark.heavy
def test_reading_a_csv_costs_a_bounded_memory_per_byte(tmp_path):
    """Memory beyond the imports grows linearly, at under 6 bytes per byte of file (time and
    three axes: 2.2 measured; the whole process reading 10 M rows of time and one axis peaks
    at 4.9× the file, paper/bench_memory.py, and at 6.3× before the text reached pandas as
    bytes and was sniffed line by line)."""
    small, large = _csv(tmp_path / "s.csv", 300_000), _csv(tmp_path / "l.csv", 1_500_000)
    grown = (_peak_kib(large) - _peak_kib(small)) * 1024
    per_byte = grown / (large.stat().st_size - small.stat().st_size)
    print(f"{per_byte:.2f} bytes of memory per byte of file")
    assert per_byte < 6, f"{per_byte:.1f} bytes of memory per byte of file"


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


def _decay(fs: float, duration: float, zeta: float = 0.01, f: float = 2.0, mass: float = 1.0):
    """A viscous free decay at ``fs`` [Hz] (f_n ``f`` [Hz], ``zeta``, mass [kg], 3 m/s² at
    release, noise 0.01 m/s²): (time [s], acceleration [m/s²], true c [N·s/m])."""
    t = np.arange(int(duration * fs)) / fs
    wn = 2 * np.pi * f
    wd = wn * np.sqrt(1 - zeta**2)
    a = 3.0 * np.exp(-zeta * wn * t) * np.sin(wd * t)
    a += 0.01 * np.random.default_rng(1).standard_normal(t.size)
    return t, a, 2 * mass * zeta * wn


def test_a_long_recording_is_decimated_said_and_still_right(tmp_path, monkeypatch, capsys):
    """Above the threshold (lowered here to keep the test short; 1 M samples by default) the
    recording is decimated by ⌊f_s / (16·band top)⌋ before the analysis: one warning line
    names both rates, ``input.decimated`` records them, and c's interval holds the truth."""
    import json

    monkeypatch.setattr(decimate, "DECIMATE_ABOVE", 20_000)
    t, a, c_true = _decay(500.0, 60.0)  # 30 000 samples
    path = tmp_path / "long.csv"
    np.savetxt(path, np.column_stack([t, a]), fmt=["%.10g", "%.7g"], delimiter=",",
               header="time,accel", comments="")
    code, out, err = run(["analyze", path, "--out", tmp_path / "o", "--mass", "1",
                          "--max-modes", "1", "--no-figures"], capsys)
    assert code == 0, err
    said = [line for line in (out + err).splitlines() if "was decimated" in line]
    assert len(said) == 1 and "30000 samples at 500 Hz" in said[0] and "by 10 to 50 Hz" in said[0]
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    dec = s["input"]["decimated"]
    assert dec["factor"] == 10 and dec["from_hz"] == pytest.approx(500.0)
    assert dec["to_hz"] == pytest.approx(50.0) and dec["n_samples_read"] == 30000
    assert s["input"]["n_samples"] == 30000 and s["input"]["sample_rate_hz"] == pytest.approx(50.0)
    assert any("was decimated" in w for w in s["diagnostics"]["warnings"])
    c = s["parameters"]["c"]
    assert c["q05"] <= c_true <= c["q95"], (c, c_true)


def test_a_recording_under_the_threshold_is_analysed_as_read():
    t, a, _ = _decay(500.0, 60.0)
    rec = Recording(t, a[:, None], ("z",))
    same, what = decimate.reduce(rec)
    assert same is rec and what is None  # 30 000 ≤ DECIMATE_ABOVE


def test_decimation_drops_clipped_reach_and_follows_irregular_stamps(monkeypatch):
    """Irregular stamps go onto the median-rate grid first; decimated samples within the
    anti-aliasing filter's reach of a clipped sample are dropped; the decay's frequency and
    amplitude survive."""
    monkeypatch.setattr(decimate, "DECIMATE_ABOVE", 20_000)
    t, a, _ = _decay(500.0, 60.0)
    t = t + np.random.default_rng(2).uniform(-2e-4, 2e-4, t.size)  # jitter, still increasing
    a = np.clip(a, -2.2, 2.2)  # the first cycles saturate at ±2.2 m/s²
    rec = Recording(t, a[:, None], ("z",))
    out, what = decimate.reduce(rec)
    assert what.factor == 10 and what.n_clipped_dropped > 0
    assert out.time[0] > 0.2  # the first clipped run (and the filter's reach) is gone
    assert np.all(np.diff(out.time) > 0)
    wn = 2 * np.pi * 2.0
    truth = 3.0 * np.exp(-0.01 * wn * out.time) * np.sin(wn * np.sqrt(1 - 1e-4) * out.time)
    keep = (out.time > 5.0) & (out.time < 55.0)
    assert np.max(np.abs(out.accel[keep, 0] - truth[keep])) < 0.02  # noise 0.01 m/s², filtered


def test_a_recording_that_cannot_be_reduced_enough_is_refused(monkeypatch):
    monkeypatch.setattr(decimate, "DECIMATE_ABOVE", 20_000)
    monkeypatch.setattr(decimate, "MAX_ANALYSED", 2_000)
    t, a, _ = _decay(500.0, 60.0)
    with pytest.raises(InputError, match=r"3000 samples at 50 Hz are more than the 2000 that can "
                                         r"be analysed in about 2 GB"):
        decimate.reduce(Recording(t, a[:, None], ("z",)))


@pytest.mark.slow
def test_the_10M_sample_csv_analysis_peaks_under_2GB(tmp_path):
    """Issue 33's memory clause, end to end: ``dampfit analyze`` (read, prepare, fit, sample,
    CRLB, laws, figures, outputs) of a 10-million-row CSV, its peak resident memory measured
    in the child that runs it (and the figure process it starts): under 2 GB."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_memory", ROOT / "paper" / "bench_memory.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    csv = tmp_path / "long.csv"
    bench.write_csv(csv, 10_000_000)
    peak, _ = bench.peak_of(bench.analyze_code(csv, tmp_path / "out", figures=True))
    print(f"peak {peak / 2**30:.2f} GiB")
    assert peak < 2e9, f"peak {peak / 2**30:.2f} GiB"
    summary = (tmp_path / "out" / "summary.json").read_text()
    assert '"decimated": {' in summary
