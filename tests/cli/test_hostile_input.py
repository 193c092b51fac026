"""Hostile and faulty input files: refused quickly with one line, or analysed correctly.

Every case is generated in ``tmp_path`` (no data files are committed) and run through the CLI
(:mod:`tests._support.hostile`): exit code, one ``dampfit: error:`` line and no traceback on failure,
nothing outside the output folder changed. Covers special files (FIFO, device links,
directories), size limits (zip / npz / xlsx bombs, absurd .npy headers, giant lines), encodings
and line endings, corrupt time stamps (gaps → the continuous part is analysed, with a warning;
memory bounded by the samples, not the time span) and unit mix-ups, and odd recordings
(reversed time, a million identical time stamps, a constant or zero signal, a pure Nyquist-rate
alternation, .xlsx formulas without cached values or with 1000 sheets, a ZIP whose member names
climb out of the folder).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pickle
import signal
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit.io import bounded as dio
from dampfit.signal import prepare as preprocess
from dampfit.errors import InputError
from dampfit.io.recording import time_segments

from tests._support.requirements import REAL
from tests._support.hostile import F_TRUE, assert_one_line_error, assert_unchanged, run, snapshot
from tests._support.hostile import decay as _decay
from tests._support.hostile import decay_csv as _decay_csv

MASS = 5.3  # [kg]; k = m (2π f)² ≈ 5231 N/m
FAST = ["--no-figures", "--quiet", "--model", "viscous"]


# -- helpers --------------------------------------------------------------------------------


def _csv_text(t, a, header: str = "Time (s)", newline: str = "\n") -> str:
    rows = [f'"{header}","acc z (m/s^2)"'] + [f"{ti:.6f},{ai:.6f}" for ti, ai in zip(t, a)]
    return newline.join(rows) + newline


def _write(path: Path, text: str, newline: str = "\n") -> Path:
    path.write_bytes(text.replace("\n", newline).encode())
    return path


@contextlib.contextmanager
def _deadline(seconds: int):
    """Fail (instead of hanging the suite) if the block blocks longer than ``seconds``."""
    def _alarm(signum, frame):
        raise TimeoutError(f"blocked for more than {seconds} s")

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _refused(tmp_path, capsys, path, match: str, *extra, seconds: float = 10.0) -> str:
    """Run ``analyze`` on ``path``: exit 2, one line containing ``match``, within ``seconds``,
    nothing in ``tmp_path`` changed (no output folder left behind either)."""
    before = snapshot(tmp_path)
    start = time.monotonic()
    with _deadline(int(seconds) + 20):
        code, _, err = run(["analyze", path, "--out", tmp_path / "out", *FAST, *extra], capsys)
    elapsed = time.monotonic() - start
    line = assert_one_line_error(code, err, 2, match)
    assert elapsed < seconds, f"took {elapsed:.1f} s"
    assert_unchanged(before, snapshot(tmp_path))
    return line


def _analysed(tmp_path, capsys, path, *extra) -> dict:
    """Run ``analyze`` with the mass: exit 0, input unchanged; the summary.json."""
    out = tmp_path / "out"
    before = snapshot(tmp_path, exclude=[out])
    code, _, err = run(["analyze", path, "--mass", MASS, "--out", out, *FAST, *extra], capsys)
    assert code == 0, err
    assert "Traceback" not in err
    assert_unchanged(before, snapshot(tmp_path, exclude=[out]))
    return json.loads((out / "summary.json").read_text())


def _zip_bytes(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def _npy_bytes(header: dict, data: bytes = b"") -> bytes:
    """An .npy file: magic and ``header`` (``descr``, ``fortran_order``, ``shape``), then ``data``."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, header)
    assert buf.getvalue().startswith(b"\x93NUMPY")
    return buf.getvalue() + data


# -- special files: refused before opening, never blocking ---------------------------------


def test_fifo_is_refused_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "rec.csv"
    os.mkfifo(fifo)
    _refused(tmp_path, capsys, fifo, "named pipe", seconds=5)


def test_link_to_dev_zero_is_refused(tmp_path, capsys):
    link = tmp_path / "zero.csv"
    link.symlink_to("/dev/zero")
    _refused(tmp_path, capsys, link, "character device", seconds=5)


def test_directory_is_refused(tmp_path, capsys):
    folder = tmp_path / "rec.csv"
    folder.mkdir()
    _refused(tmp_path, capsys, folder, "is a directory")


def test_broken_link_is_refused(tmp_path, capsys):
    link = tmp_path / "gone.csv"
    link.symlink_to(tmp_path / "missing.csv")
    _refused(tmp_path, capsys, link, "file not found")


def test_link_to_a_regular_file_is_followed(tmp_path):
    t, a = _decay()
    target = _write(tmp_path / "real.csv", _csv_text(t, a))
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    np.testing.assert_array_equal(dampfit.read(link).time, dampfit.read(target).time)


def test_empty_file(tmp_path, capsys):
    _refused(tmp_path, capsys, _write(tmp_path / "e.csv", ""), "empty")


def test_file_over_the_size_limit(tmp_path, capsys, monkeypatch):
    t, a = _decay()
    path = _write(tmp_path / "big.csv", _csv_text(t, a))
    monkeypatch.setattr(dio, "MAX_INPUT_BYTES", 1000)
    _refused(tmp_path, capsys, path, "larger than the limit")


# -- containers: bombs refused before decompressing ----------------------------------------


def test_zip_bomb_is_refused_by_ratio(tmp_path, capsys):
    path = tmp_path / "export.zip"
    path.write_bytes(_zip_bytes({"Accelerometer.csv": bytes(50 * 2**20)}))
    assert path.stat().st_size < 200_000
    _refused(tmp_path, capsys, path, "zip bomb", seconds=3)


def test_zip_over_the_unpacked_limit(tmp_path, capsys, monkeypatch):
    t, a = _decay()
    path = tmp_path / "export.zip"
    path.write_bytes(_zip_bytes({"Accelerometer.csv": _csv_text(t, a).encode()}))
    monkeypatch.setattr(dio, "MAX_UNPACKED_BYTES", 10_000)
    _refused(tmp_path, capsys, path, "would unpack")


def test_npz_bomb_is_refused(tmp_path, capsys):
    path = tmp_path / "rec.npz"
    path.write_bytes(_zip_bytes({"t.npy": _npy_bytes({"descr": "<f8", "fortran_order": False,
                                                      "shape": (6_000_000,)}, bytes(48_000_000)),
                                 "a.npy": _npy_bytes({"descr": "<f8", "fortran_order": False,
                                                      "shape": (2,)}, bytes(16))}))
    _refused(tmp_path, capsys, path, "zip bomb", seconds=3)


def test_npz_member_declaring_an_absurd_shape(tmp_path, capsys):
    path = tmp_path / "rec.npz"
    header = {"descr": "<f8", "fortran_order": False, "shape": (10**12, 4)}
    path.write_bytes(_zip_bytes({"t.npy": _npy_bytes(header, bytes(64)),
                                 "a.npy": _npy_bytes(header, bytes(64))}))
    _refused(tmp_path, capsys, path, "declares shape", seconds=3)


def test_npy_declaring_an_absurd_shape(tmp_path, capsys):
    path = tmp_path / "rec.npy"
    path.write_bytes(_npy_bytes({"descr": "<f8", "fortran_order": False, "shape": (4, 10**11)},
                                bytes(800)))
    _refused(tmp_path, capsys, path, "declares shape", seconds=3)


def test_truncated_npy(tmp_path, capsys):
    path = tmp_path / "rec.npy"
    path.write_bytes(_npy_bytes({"descr": "<f8", "fortran_order": False, "shape": (2, 1000)},
                                bytes(800)))
    _refused(tmp_path, capsys, path, "truncated")


def test_object_npy_is_never_unpickled(tmp_path, capsys):
    path = tmp_path / "rec.npy"
    np.save(path, np.array([{"a": 1}, None], dtype=object), allow_pickle=True)
    _refused(tmp_path, capsys, path, "Python objects")


def test_object_npz_member_is_never_unpickled(tmp_path, capsys):
    path = tmp_path / "rec.npz"
    np.savez(path, t=np.arange(100.0), a=np.array([object()] * 100, dtype=object))
    _refused(tmp_path, capsys, path, "Python objects")


def test_pickle_named_npy(tmp_path, capsys):
    path = tmp_path / "rec.npy"
    path.write_bytes(pickle.dumps({"t": [1, 2, 3]}))
    _refused(tmp_path, capsys, path, "not a valid .npy")


def test_xlsx_bomb_is_refused(tmp_path, capsys):
    path = tmp_path / "book.xlsx"
    path.write_bytes(_zip_bytes({"[Content_Types].xml": b"<Types/>",
                                 "xl/workbook.xml": b"<workbook/>",
                                 "xl/worksheets/sheet1.xml": b" " * (40 * 2**20)}))
    _refused(tmp_path, capsys, path, "zip bomb", seconds=3)


# -- text: size of lines and rows checked before parsing; endings and encodings ------------


def test_eight_megabyte_single_line_is_refused_fast(tmp_path, capsys):
    path = tmp_path / "line.csv"
    path.write_bytes(b"0.1," * (2 * 2**20))
    _refused(tmp_path, capsys, path, "no line breaks", seconds=3)


def test_header_with_a_million_commas(tmp_path, capsys):
    path = tmp_path / "wide.csv"
    path.write_bytes(b"time" + b"," * 10**6 + b"\n")
    _refused(tmp_path, capsys, path, "64 KiB", seconds=3)


def test_one_giant_line_in_a_normal_file(tmp_path, capsys):
    t, a = _decay()
    lines = _csv_text(t, a).splitlines()
    lines[500] = "1" * 100_000
    _refused(tmp_path, capsys, _write(tmp_path / "g.csv", "\n".join(lines)), "64 KiB")


def test_too_many_columns(tmp_path, capsys):
    row = ",".join(["1.0"] * 2000)
    _refused(tmp_path, capsys, _write(tmp_path / "c.csv", "\n".join([row] * 20)), "2000 columns")


def test_too_many_rows(tmp_path, capsys, monkeypatch):
    t, a = _decay()
    monkeypatch.setattr(dio, "MAX_ROWS", 500)
    _refused(tmp_path, capsys, _write(tmp_path / "long.csv", _csv_text(t, a)), "more than the limit of 500")


def test_binary_junk(tmp_path, capsys):
    path = tmp_path / "junk.csv"
    path.write_bytes(np.random.default_rng(3).integers(0, 256, 100_000, dtype=np.uint8).tobytes())
    _refused(tmp_path, capsys, path, "binary")


@pytest.mark.parametrize("newline", ["\r\n", "\r"], ids=["crlf", "cr-only"])
def test_line_endings_read_like_lf(tmp_path, newline):
    t, a = _decay()
    lf = dampfit.read(_write(tmp_path / "lf.csv", _csv_text(t, a)))
    other = dampfit.read(_write(tmp_path / "x.csv", _csv_text(t, a), newline))
    np.testing.assert_array_equal(other.time, lf.time)
    np.testing.assert_array_equal(other.accel, lf.accel)
    assert other.n_samples == t.size


def test_cr_only_file_is_analysed(tmp_path, capsys):
    t, a = _decay()
    s = _analysed(tmp_path, capsys, _write(tmp_path / "mac.csv", _csv_text(t, a), "\r"))
    assert abs(s["parameters"]["f_n"]["q50"] / F_TRUE - 1) < 0.01


def test_utf16_text_is_decoded(tmp_path):
    t, a = _decay()
    path = tmp_path / "u16.txt"
    path.write_bytes(_csv_text(t, a).replace(",", "\t").encode("utf-16"))
    rec = dampfit.read(path)
    np.testing.assert_allclose(rec.time, np.round(t, 6))
    np.testing.assert_allclose(rec.accel[:, 0], np.round(a, 6))


def test_utf16_without_bom_is_refused(tmp_path, capsys):
    t, a = _decay()
    path = tmp_path / "u16.csv"
    path.write_bytes(_csv_text(t, a).encode("utf-16-le"))
    _refused(tmp_path, capsys, path, "binary")


def test_nan_row(tmp_path, capsys):
    t, a = _decay()
    lines = _csv_text(t, a).splitlines()
    lines[300] = f"{t[299]:.6f},NaN"
    _refused(tmp_path, capsys, _write(tmp_path / "nan.csv", "\n".join(lines)), "missing or non-finite")


def test_absurd_acceleration(tmp_path, capsys):
    t, a = _decay()
    a = a.copy()
    a[400] = 1e300
    _refused(tmp_path, capsys, _write(tmp_path / "huge.csv", _csv_text(t, a).replace(
        f"{1e300:.6f}", "1e300")), "not physical")


# -- corrupt time stamps: the continuous part is analysed, memory follows the samples -------


@pytest.mark.parametrize("bad_time", [1e4, 1e5, 1e7])
def test_one_corrupt_timestamp_at_the_end(tmp_path, capsys, bad_time):
    t, a = _decay()
    text = _csv_text(t, a) + f"{bad_time:.1f},0.01\n"
    path = _write(tmp_path / "rec.csv", text)
    start = time.monotonic()
    s = _analysed(tmp_path, capsys, path)
    assert time.monotonic() - start < 60
    assert abs(s["parameters"]["f_n"]["q50"] / F_TRUE - 1) < 0.01
    assert abs(s["parameters"]["k"]["q50"] / (MASS * (2 * np.pi * F_TRUE) ** 2) - 1) < 0.02
    gap = [w for w in s["diagnostics"]["warnings"] if "time stamps jump" in w]
    assert gap and "continuous part 0–9.99 s (1000 of 1001 samples)" in gap[0]
    assert any("time stamps jump" in n for n in s["preprocessing"]["notes"])
    assert any("time stamps jump" in n for n in s["input"]["notes"])


def test_grid_is_bounded_by_the_samples_not_the_time_span(tmp_path):
    t, a = _decay()
    rec = dampfit.read(_write(tmp_path / "rec.csv", _csv_text(t, a) + "1e9,0.01\n"))
    prep = preprocess.prepare(rec)
    assert prep.grid.size <= rec.n_samples
    assert abs(prep.f0 / F_TRUE - 1) < 0.01


def test_clock_jump_in_the_middle_uses_the_longer_part(tmp_path):
    t, a = _decay(n_sec=20.0)
    t = t.copy()
    t[1200:] += 5e4  # the clock jumps after 12 s: the first 12 s are the longer part
    rec = dampfit.read(_write(tmp_path / "rec.csv", _csv_text(t, a)))
    prep = preprocess.prepare(rec)
    assert prep.time.size == 1200 and prep.time[-1] < 12
    assert abs(prep.f0 / F_TRUE - 1) < 0.01
    assert any("5e+04 s after t = 11.99 s" in w for w in prep.warnings)
    # the later part with --window, a window across the jump is refused
    later = preprocess.prepare(rec, window=(5e4 + 12.5, 5e4 + 19.5))
    assert later.time[0] >= 5e4 + 12
    with pytest.raises(InputError, match="not inside one continuous part"):
        preprocess.prepare(rec, window=(5.0, 5e4 + 15))


def test_window_across_a_gap_is_refused(tmp_path, capsys):
    t, a = _decay()
    path = _write(tmp_path / "rec.csv", _csv_text(t, a) + "100000.0,0.01\n")
    _refused(tmp_path, capsys, path, "not inside one continuous part", "--window", "1", "100000")


def test_corrupt_timestamp_in_the_middle_keeps_the_longest_run(tmp_path, capsys):
    t, a = _decay()
    t = t.copy()
    t[500] = 1e5  # one corrupt stamp: time then goes backwards; the longer run is analysed
    s = _analysed(tmp_path, capsys, _write(tmp_path / "rec.csv", _csv_text(t, a)))
    assert any(n.startswith("time goes backwards at sample 502") for n in s["input"]["notes"])
    assert s["window"]["end_s"] < 5.0
    assert abs(s["parameters"]["f_n"]["q50"] / F_TRUE - 1) < 0.01


def test_sparse_bursts_are_refused_not_gridded(tmp_path, capsys):
    # 50 bursts of 10 samples at 100 Hz every 0.99 s: no gap over 1 s, but a uniform grid at
    # the median rate would hold ~10x the samples
    t = np.concatenate([k * 0.99 + np.arange(10) / 100 for k in range(50)])
    a = np.cos(2 * np.pi * 0.3 * t)
    _refused(tmp_path, capsys, _write(tmp_path / "burst.csv", _csv_text(t, a)), "too sparse")


# -- unit mix-ups: named, never a silent wrong answer --------------------------------------


def test_milliseconds_under_a_seconds_header(tmp_path, capsys):
    t, a = _decay()
    path = _write(tmp_path / "ms.csv", _csv_text(t * 1000, a))
    line = _refused(tmp_path, capsys, path, "milliseconds under a '(s)' header")
    assert "--time-unit ms" in line


def test_seconds_under_a_milliseconds_header_is_flagged(tmp_path, capsys):
    t, a = _decay()
    s = _analysed(tmp_path, capsys, _write(tmp_path / "s.csv", _csv_text(t, a, header="Time (ms)")))
    warnings = " | ".join(s["diagnostics"]["warnings"])
    assert "seconds under a '(ms)' header" in warnings and "--time-unit s" in warnings
    assert "implied stiffness" in warnings
    # the fix the warning names gives the right answer
    rec = dampfit.read(tmp_path / "s.csv", time_unit="s")
    assert rec.time_unit_verdict is None


def test_plausible_time_units_give_no_hint(tmp_path):
    t, a = _decay()
    assert dampfit.read(_write(tmp_path / "ok.csv", _csv_text(t, a))).time_unit_verdict is None
    ms = dampfit.read(_write(tmp_path / "ms.csv", _csv_text(t * 1000, a, header="Time (ms)")))
    assert ms.time_unit_verdict is None
    np.testing.assert_allclose(ms.time, np.round(t, 6), atol=1e-9)


REAL_FILES = sorted(p for p in REAL.rglob("*") if p.suffix in {".csv", ".npy"}) if REAL.is_dir() else []


@pytest.mark.skipif(not REAL_FILES, reason="../shared/data/real is not present")
def test_real_recordings_are_continuous_and_plausible():
    """Ordinary phone and logger dropouts are no gaps and no unit warnings."""
    for path in REAL_FILES:
        rec = dampfit.read(path)
        assert len(time_segments(rec.time)) == 1, path
        assert rec.time_unit_verdict is None, path


# ----------------------------------------------------------- found by a second hostile probe
@pytest.mark.parametrize("case, scale, offset, match", [
    ("noise-free decay", 1.0, 0.0, "free of noise"),       # an FEM output: exact to rounding
    ("time step 1e-302 s", 1e-302, 0.0, "time looks wrong"),
    ("time stamps near 1e300 s", 1e300, 1e300, "time looks wrong"),
])
def test_numerically_extreme_recordings_are_one_line(tmp_path, capsys, case, scale, offset, match):
    n = np.arange(1000)
    a = 3.0 * np.exp(-0.3 * n / 100.0) * np.cos(2 * np.pi * 5.0 * n / 100.0)
    path = _decay_csv(tmp_path / "rec.csv", n / 100.0 * scale + offset, a)
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", path, "--mass", "5.3", "--out", tmp_path / "o", "--quiet",
                        "--no-figures"], capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(tmp_path))


def test_a_decay_quantised_at_a_micro_unit_is_not_noise_free(tmp_path, capsys):
    n = np.arange(1000)
    a = np.round(3.0 * np.exp(-0.3 * n / 100.0) * np.cos(2 * np.pi * 5.0 * n / 100.0), 6)
    path = _decay_csv(tmp_path / "rec.csv", n / 100.0, a)
    code, _, err = run(["analyze", path, "--mass", "5.3", "--out", tmp_path / "o", "--quiet",
                        "--no-figures", "--json"], capsys)
    assert code == 0 and err == "", err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["parameters"]["f_n"]["q50"] == pytest.approx(5.0, rel=1e-4)


def test_an_unsafe_cache_never_adds_a_line_to_an_error(tmp_path, capsys, monkeypatch):
    """The cache warning is printed after a command that succeeds, never beside an error."""
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", str(shared))
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    code, _, err = run(["analyze", tmp_path / "missing.csv", "--out", tmp_path / "o"], capsys)
    assert_one_line_error(code, err, match="not found")
    code, _, err = run(["simulate", "--duration", "5", "--handheld", "0", "--out",
                        tmp_path / "s.csv"], capsys)
    assert code == 0 and "cache off" in err and len(err.strip().splitlines()) == 1


# -- lab exports, empty cells and motion-only files (issue 19) -------------------------------


def _runs_csv(path: Path, lengths=(1000, 600)) -> Path:
    """A Capstone-style CSV: "Time (s) Run #k", "Acceleration (m/s²) Run #k", shorter runs
    ending in empty cells."""
    t, a = _decay()
    header = ",".join(f'"{n} Run #{k + 1}"' for k in range(len(lengths))
                      for n in ("Time (s)", "Acceleration (m/s²)"))
    rows = [",".join(f"{t[i]:.4f},{a[i]:.5f}" if i < n else "," for n in lengths)
            for i in range(max(lengths))]
    return _write(path, header + "\n" + "\n".join(rows) + "\n")


def _motion_txt(path: Path) -> Path:
    t, a = _decay()
    x = -a / (2 * np.pi * F_TRUE) ** 2
    lines = ["Vernier Format 2", "Untitled.cmbl 3/14/2026 10:21:05 .", "Latest",
             "Time\tPosition", "t\tx", "s\tm", ""] + [f"{ti:.3f}\t{xi:.7f}" for ti, xi in zip(t, x)]
    return _write(path, "\n".join(lines) + "\n")


def _gap_csv(path: Path) -> Path:
    t, a = _decay()
    rows = [f"{ti:.4f},{ai:.5f}" for ti, ai in zip(t, a)]
    rows[800] = f"{t[800]:.4f},"
    return _write(path, '"Time (s)","acc z (m/s^2)"\n' + "\n".join(rows) + "\n")


@pytest.mark.parametrize("case,extra,match", [  # match: a plain substring of the line
    ("motion", [], "position/displacement ('Position (m)') but no acceleration column; "
                   "dampfit analyses acceleration"),
    ("gap", [], "acceleration has 1 missing or non-finite value inside the data (first at data "
                "row 801, after t = 7.99 s); fill or delete those rows, or give --window START "
                "END that leaves them out"),
    ("gap", ["--window", "1", "9"], "inside the data"),
    ("runs", ["--run", "3"], "has no run '3'; runs: 'Run #1', 'Run #2'"),
    ("plain", ["--run", "2"], "--run: this file has no runs"),
    ("cmbl", [], "is a Logger Pro file; export the data as text (File ▸ Export As ▸ Text)"),
    ("mat-run", ["--run", "1"], "--run applies to lab exports"),
], ids=["motion-only", "gap-inside", "gap-inside-window", "unknown-run", "run-without-runs",
        "native-cmbl", "run-on-mat"])
def test_lab_exports_and_empty_cells_refused_with_the_reason(tmp_path, capsys, case, extra, match):
    import scipy.io as sio

    t, a = _decay()
    if case == "motion":
        path = _motion_txt(tmp_path / "motion.txt")
    elif case == "gap":
        path = _gap_csv(tmp_path / "gap.csv")
    elif case == "runs":
        path = _runs_csv(tmp_path / "runs.csv")
    elif case == "plain":
        path = _write(tmp_path / "plain.csv", _csv_text(t, a))
    elif case == "cmbl":
        path = _write(tmp_path / "lab.cmbl", "<Document/>")
    else:
        path = tmp_path / "r.mat"
        sio.savemat(path, {"acc": np.vstack([t, a])})
    line = _refused(tmp_path, capsys, path, match, *extra)
    if case == "motion":
        assert "--accel-columns" not in line


@pytest.mark.heavy
def test_empty_cells_outside_the_window_and_a_shorter_run_are_analysed(tmp_path, capsys):
    """The window is applied before the empty-cell check: the gap at 8 s lies outside
    --window 0.5 7.5; and run #2 of a Capstone file, shorter than run #1, reads without a
    complaint about its empty cells. Both record their reading options."""
    s = _analysed(tmp_path, capsys, _gap_csv(tmp_path / "gap.csv"), "--window", "0.5", "7.5")
    assert "dropped 1 row with empty cells outside the window 0.5–7.5 s" in s["input"]["notes"]
    assert s["parameters"]["f_n"]["q50"] == pytest.approx(F_TRUE, rel=2e-3)
    s = _analysed(tmp_path, capsys, _runs_csv(tmp_path / "runs.csv"), "--run", "Run #2", "--force")
    assert s["input"]["format"] == "capstone-csv" and s["input"]["n_samples"] == 600
    assert s["provenance"]["options"]["run"] == "Run #2"
    assert s["parameters"]["f_n"]["q50"] == pytest.approx(F_TRUE, rel=2e-3)


# -- odd recordings (from the hostile review) -----------------------------------------------


def _analyze_fails(tmp_path, capsys, path, match, *extra):
    """``analyze PATH``: exit 2, one line containing ``match``, nothing in tmp_path changed."""
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", path, *FAST, "--mass", "5.3", "--out", tmp_path / "out", *extra],
                       capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))
    return line

def test_time_column_in_descending_order(tmp_path, capsys):
    t, a = _decay()
    path = _decay_csv(tmp_path / "desc.csv", t[::-1], a[::-1])
    _analyze_fails(tmp_path, capsys, path, "time goes backwards at sample 1")

def test_a_million_identical_time_stamps(tmp_path, capsys):
    path = tmp_path / "same_t.csv"
    path.write_text('"Time (s)","acc z (m/s^2)"\n' + "1.0,0.5\n" * 1_000_000)
    _analyze_fails(tmp_path, capsys, path, "time is duplicated at sample 1")

@pytest.mark.parametrize("value", [9.81, 0.0], ids=["constant", "zero"])
def test_constant_signal(tmp_path, capsys, value):
    t, _ = _decay()
    path = _decay_csv(tmp_path / "flat.csv", t, np.full(t.size, value))
    _analyze_fails(tmp_path, capsys, path, "too few distinct samples")

def test_alternating_values_at_the_nyquist_frequency(tmp_path, capsys):
    t, _ = _decay()
    path = _decay_csv(tmp_path / "nyquist.csv", t, np.where(np.arange(t.size) % 2 == 0, 1e6, -1e6))
    _analyze_fails(tmp_path, capsys, path, "no resolvable oscillation")

def test_alternating_huge_and_tiny_values(tmp_path, capsys):
    t, _ = _decay()
    path = _decay_csv(tmp_path / "alt.csv", t, np.where(np.arange(t.size) % 2 == 0, 1e300, 1e-300))
    _analyze_fails(tmp_path, capsys, path, "is not physical")

@pytest.mark.parametrize("n", [2, 3])
def test_two_or_three_samples(tmp_path, capsys, n):
    t, a = _decay()
    path = _decay_csv(tmp_path / "short.csv", t[:n], a[:n])
    _analyze_fails(tmp_path, capsys, path, f"only {n} samples")

def _xlsx_header():
    return ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"]

def test_xlsx_with_formulas_and_no_cached_values(tmp_path, capsys):
    openpyxl = pytest.importorskip("openpyxl")
    t, _ = _decay()
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Accelerometer"
    ws.append(_xlsx_header())
    for i, x in enumerate(t):
        ws.append([float(x), 0.0, 0.0, f"=3*EXP(-0.3*A{i + 2})*COS(2*PI()*5*A{i + 2})"])
    wb.save(tmp_path / "formula.xlsx")
    _analyze_fails(tmp_path, capsys, tmp_path / "formula.xlsx", "missing or non-finite values")

@pytest.mark.heavy
def test_xlsx_with_a_thousand_sheets_and_a_bad_sheet_name(tmp_path, capsys):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    wb.active.title = "S0"
    wb.active.append(_xlsx_header())
    for k in range(1, 1000):
        wb.create_sheet(f"S{k}").append(_xlsx_header())
    wb.save(tmp_path / "many.xlsx")
    _analyze_fails(tmp_path, capsys, tmp_path / "many.xlsx", "has no single acceleration sheet")
    _analyze_fails(tmp_path, capsys, tmp_path / "many.xlsx", "has no sheet '../S5'", "--sheet", "../S5")

def test_zip_member_names_that_climb_out_are_only_read(tmp_path):
    """A phyphox ZIP whose members are named ``../../Accelerometer.csv`` and
    ``/tmp/…``: read from inside the archive, nothing is extracted anywhere."""
    t, a = _decay()
    body = ('"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)","Acceleration z (m/s^2)"\n'
            + "".join(f"{float(x)!r},0,0,{float(y)!r}\n" for x, y in zip(t, a)))
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    with zipfile.ZipFile(work / "trav.zip", "w") as z:
        z.writestr("../../Accelerometer.csv", body)
        z.writestr("meta/../../../etc/device.csv", "x\n")
    before = snapshot(tmp_path)
    rec = dampfit.read(work / "trav.zip")
    assert rec.n_samples == t.size
    assert np.allclose(rec.time, t)
    assert_unchanged(before, snapshot(tmp_path))
