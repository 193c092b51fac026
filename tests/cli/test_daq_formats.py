"""The lab DAQ formats and the newcomer's awkward tables, through the CLI.

LabVIEW LVM, NI TDMS and UFF 58 files made here (npTDMS's and pyuff's own writers; LVM per NI's
text specification), a CONTEC-style logger CSV (a 14-line preamble, 9 channels of raw counts,
no time column: ``--rate``, ``--channel``) and a spliced phyphox export (a repeated time stamp
where the phone was re-excited) are analysed; hostile variants of each format (truncated, huge
declared sizes, NaN, a wrong or no channel) are refused with one line, nothing written.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from tests._support.daq import F1, FS, cantilever, write_logger_csv, write_lvm, write_tdms, write_uff
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, snapshot

pytest.importorskip("lvm_read")
pytest.importorskip("nptdms")
pytest.importorskip("pyuff")

FAST = ["--no-figures", "--quiet", "--model", "viscous", "--max-modes", "1", "--mass", "0.1"]


def _analysed(tmp_path, capsys, path, *extra) -> dict:
    out = tmp_path / f"out-{path.name}"
    code, stdout, err = run(["analyze", path, *FAST, "--out", out, *extra], capsys)
    assert code == 0, err
    return json.loads((out / "summary.json").read_text()), stdout


def _fails(tmp_path, capsys, path, match, *extra) -> str:
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", path, *FAST, "--out", tmp_path / "failed", *extra], capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))
    return line


def _zeta_near(s: dict, truth: float = 0.01) -> None:
    assert abs(s["parameters"]["zeta"]["q50"] / truth - 1) < 0.05
    assert abs(s["parameters"]["f_n"]["q50"] / F1 - 1) < 0.01


# -- the three DAQ formats analysed ---------------------------------------------------------------

@pytest.mark.heavy
def test_lvm_hammer_test_is_analysed(tmp_path, capsys):
    t, a = cantilever()
    path = write_lvm(tmp_path / "hammer.lvm", t, {"Force": 50 * a, "Accel": a},
                     {"Force": "N", "Accel": "g"})
    s, _ = _analysed(tmp_path, capsys, path)
    assert s["input"]["format"] == "lvm"
    _zeta_near(s)


def test_tdms_channel_of_a_group_is_analysed(tmp_path, capsys):
    t, a = cantilever()
    path = write_tdms(tmp_path / "rig.tdms", {"ai0": a, "ai1": 0.5 * a}, units={"ai0": "g"},
                      more_groups={"Other": {"temp": np.full(t.size, 21.0)}})
    s, _ = _analysed(tmp_path, capsys, path, "--group", "Accel", "--channel", "ai1",
                     "--accel-unit", "g")
    assert s["input"]["format"] == "tdms"
    _zeta_near(s)


def test_uff58_record_chosen_like_row_is_analysed(tmp_path, capsys):
    t, a = cantilever()
    path = write_uff(tmp_path / "test.uff", [{"t": t, "a": 0 * a + 1.0, "func_type": 4},
                                             {"t": t, "a": a, "name": "tip accel"}])
    s, _ = _analysed(tmp_path, capsys, path, "--row", "1")
    assert s["input"]["format"] == "uff58"
    _zeta_near(s)


@pytest.mark.heavy
def test_logger_csv_with_preamble_and_no_time_is_analysed_with_rate(tmp_path, capsys):
    t, a = cantilever()
    rng = np.random.default_rng(3)
    counts = np.round(32768 + rng.normal(0, 20, (t.size, 9)))
    counts[:, 2] += np.round(3000 * a)
    path = write_logger_csv(tmp_path / "logger.csv", counts, FS)
    line = _fails(tmp_path, capsys, path, "--rate HZ")  # no time column: the way out is named
    assert "'CH1'" in line
    _fails(tmp_path, capsys, path, "--channel NAME", "--rate", str(FS))  # 9 anonymous channels
    s, _ = _analysed(tmp_path, capsys, path, "--rate", str(FS), "--channel", "CH3")
    assert list(s["input"]["axis_direction"]) == ["CH3"]
    assert any("14-line header" in n for n in s["input"]["notes"])
    _zeta_near(s)
    from dampfit.output.report.reproduce import reproduce_command

    cmd = reproduce_command(s, tmp_path / "out-logger.csv")  # the report's command repeats them
    assert "--rate 1653.0" in cmd and "--channel CH3" in cmd


def test_spliced_phyphox_export_analyses_the_longest_segment(tmp_path, capsys):
    fs = 100.0
    t1 = np.arange(0, 8, 1 / fs)
    t2 = np.arange(t1[-1], 30, 1 / fs)  # the phone re-excited: one time stamp repeats
    t = np.concatenate([t1, t2])
    a = np.concatenate([3 * np.exp(-0.3 * t1) * np.cos(2 * np.pi * 5 * t1),
                        4 * np.exp(-0.3 * (t2 - t2[0])) * np.cos(2 * np.pi * 5 * (t2 - t2[0]))])
    a = a + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    head = '"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)",' \
           '"Linear Acceleration z (m/s^2)"\n'
    path = tmp_path / "Raw Data.csv"
    path.write_text(head + "".join(f"{x:.4f},0.001,0.002,{y:.6f}\n" for x, y in zip(t, a)))
    s, stdout = _analysed(tmp_path, capsys, path)
    assert s["window"]["start_s"] >= 8.0 and s["window"]["end_s"] > 20  # the later, longer decay
    assert any("2 segments, 0–7.99 s (800 samples), 8–29.99 s (2200 samples)" in n
               for n in s["input"]["notes"])
    assert "a time stamp repeats at t = 8 s" in stdout


def test_time_going_backwards_keeps_the_longest_run(tmp_path, capsys):
    t = np.arange(0, 20, 0.01)
    a = 3 * np.exp(-0.3 * t) * np.cos(2 * np.pi * 5 * t)
    t = np.concatenate([t[:300], t[300:] - t[300] + 0.005])  # the clock reset after 3 s
    path = tmp_path / "reset.csv"
    path.write_text('"Time (s)","acc z (m/s^2)"\n'
                    + "".join(f"{x:.4f},{y:.6f}\n" for x, y in zip(t, a)))
    s, _ = _analysed(tmp_path, capsys, path)
    assert any("only the longest, samples 301–2000" in n for n in s["input"]["notes"])


# -- hostile variants -------------------------------------------------------------------------------

def _lvm(tmp_path, **kw):
    t, a = cantilever(1.0)
    return write_lvm(tmp_path / "h.lvm", t, {"Accel": a, "Force": a}, {"Accel": "g", "Force": "N"},
                     **kw)


def _tdms(tmp_path, name="h.tdms", **kw):
    t, a = cantilever(1.0)
    return write_tdms(tmp_path / name, {"ai0": a}, units={"ai0": "g"}, **kw)


def _uff(tmp_path, records=None):
    t, a = cantilever(1.0)
    return write_uff(tmp_path / "h.uff", records or [{"t": t, "a": a}])


@pytest.mark.heavy
def test_lvm_hostile(tmp_path, capsys):
    path = _lvm(tmp_path)
    text = path.read_text()
    _fails(tmp_path, capsys, path, "has no channel 'nope'", "--channel", "nope")
    _fails(tmp_path, capsys, path, "is in N, not an acceleration", "--channel", "Force")
    cut = tmp_path / "cut.lvm"
    cut.write_text(text[:text.index("***End_of_Header***", 200)])  # header only: no data
    _fails(tmp_path, capsys, cut, "no data segment")
    nan = tmp_path / "nan.lvm"
    lines = text.splitlines()
    lines[-300] = lines[-300].split("\t")[0] + "\tNaN\t0.1"
    nan.write_text("\n".join(lines) + "\n")
    _fails(tmp_path, capsys, nan, "missing or non-finite value")
    huge = _lvm(tmp_path, declared=10**15)  # a declared sample count is never allocated
    s, _ = _analysed(tmp_path, capsys, huge, "--channel", "Accel")
    assert s["input"]["n_samples"] == 1653


@pytest.mark.heavy
def test_tdms_hostile(tmp_path, capsys, monkeypatch):
    t, a = cantilever(1.0)
    path = _tdms(tmp_path)
    data = path.read_bytes()
    _fails(tmp_path, capsys, path, "has no channel 'ai9'", "--channel", "ai9")
    _fails(tmp_path, capsys, path, "has no TDMS group 'Nope'", "--group", "Nope")
    two = write_tdms(tmp_path / "two.tdms", {"ai0": a}, more_groups={"B": {"x": a}})
    _fails(tmp_path, capsys, two, "choose one with --group NAME")
    trunc = tmp_path / "trunc.tdms"
    trunc.write_bytes(data[:40])
    _fails(tmp_path, capsys, trunc, "tdms")
    huge = bytearray(data)
    i = huge.find(struct.pack("<Q", t.size))
    huge[i:i + 8] = struct.pack("<Q", 10**15)  # the channel declares 10^15 values
    (tmp_path / "huge.tdms").write_bytes(bytes(huge))
    monkeypatch.setattr("dampfit.io.bounded.MAX_INPUT_BYTES", 1 << 30)
    s, _ = _analysed(tmp_path, capsys, tmp_path / "huge.tdms")  # what is there is read, once
    assert s["input"]["n_samples"] == t.size
    assert any("npTDMS:" in n for n in s["input"]["notes"])
    nan = write_tdms(tmp_path / "nan.tdms", {"ai0": np.where(np.arange(t.size) == 800, np.nan, a)})
    _fails(tmp_path, capsys, nan, "missing or non-finite value", "--accel-unit", "g")
    notime = write_tdms(tmp_path / "notime.tdms", {"ai0": a}, dt=None)
    _fails(tmp_path, capsys, notime, "--rate HZ")
    empty = write_tdms(tmp_path / "empty.tdms", {})
    _fails(tmp_path, capsys, empty, "without channels")


def test_uff_hostile(tmp_path, capsys):
    t, a = cantilever(1.0)
    path = _uff(tmp_path)
    text = path.read_text()
    _fails(tmp_path, capsys, path, "no UFF data set 58 numbered 7", "--row", "7")
    _fails(tmp_path, capsys, path, "--rate is for tables without a time base", "--rate", "100")
    cut = tmp_path / "cut.uff"
    cut.write_text(text[:len(text) // 3])  # no closing '    -1': no data set at all
    _fails(tmp_path, capsys, cut, "uff")
    nan = tmp_path / "nan.uff"
    rows = text.splitlines()
    rows[400] = f"{'NaN':>20}" + rows[400][20:]  # one value of the '4E20.12' block
    nan.write_text("\n".join(rows) + "\n")
    _fails(tmp_path, capsys, nan, "non-finite")
    two = write_uff(tmp_path / "two.uff", [{"t": t, "a": a}, {"t": t, "a": a, "name": "b"}])
    _fails(tmp_path, capsys, two, "choose one with --row N")
    spectrum = write_uff(tmp_path / "fr.uff", [{"t": t, "a": a, "func_type": 4}])
    _fails(tmp_path, capsys, spectrum, "no time-response record")
    huge = tmp_path / "huge.uff"  # a declared point count of 10^10 - 1: refused from the header
    huge.write_text(text.replace(f"{t.size:10d}", f"{10**10 - 1:10d}", 1))
    _fails(tmp_path, capsys, huge, "declares 9999999999 values")


def test_missing_library_names_the_extra(tmp_path, capsys, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_nptdms(name, *args, **kw):
        if name == "nptdms":
            raise ImportError(name)
        return real(name, *args, **kw)

    path = _tdms(tmp_path)
    monkeypatch.setattr(builtins, "__import__", no_nptdms)
    _fails(tmp_path, capsys, path, "pip install 'dampfit[tdms]'")
