"""Tests of :mod:`dampfit.io.readers`: every format and dialect, the real recordings, every bad input."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dampfit.errors import InputError
from dampfit.io.readers import detect_format, read
from dampfit.io.recording import STANDARD_GRAVITY
from tests._support.requirements import REAL

G = STANDARD_GRAVITY
N = 200


# -- synthetic signals and writers --------------------------------------------------------


def _signal(n: int = N, rate: float = 100.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Jittered time [s] and a damped 3-axis oscillation [m/s²]."""
    rng = np.random.default_rng(seed)
    t = 0.0123 + np.arange(n) / rate + rng.uniform(0, 0.2 / rate, n)
    env = 5.0 * np.exp(-0.5 * t) * np.sin(2 * np.pi * 2.0 * t)
    accel = np.column_stack([0.3 * env, env, 0.1 * env + 0.05])
    return t, accel


def _phyphox_number(value: float, decimal: str = ".") -> str:
    """phyphox's number style, e.g. ``8.152291659E-3``."""
    mantissa, exponent = f"{value:.9E}".split("E")
    return f"{mantissa}E{int(exponent)}".replace(".", decimal)


def _phyphox_csv(
    path: Path,
    t: np.ndarray,
    accel: np.ndarray,
    *,
    sep: str = ",",
    decimal: str = ".",
    unit: str = "m/s^2",
    linear: bool = False,
    absolute: bool = True,
) -> Path:
    prefix = "Linear Acceleration" if linear else "Acceleration"
    names = ["Time (s)"] + [f"{prefix} {a} ({unit})" for a in "xyz"]
    rows = np.column_stack([t, accel])
    if absolute:
        names.append(f"Absolute acceleration ({unit})")
        rows = np.column_stack([rows, np.linalg.norm(accel, axis=1)])
    lines = [sep.join(f'"{n}"' for n in names)]
    lines += [sep.join(_phyphox_number(v, decimal) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _write(path: Path, text: str, encoding: str = "utf-8") -> Path:
    path.write_text(text, encoding=encoding)
    return path


def _table_text(header: str | None, columns: list[np.ndarray], sep: str = ",", fmt: str = "{}") -> str:
    lines = [header] if header is not None else []
    lines += [sep.join(fmt.format(v) for v in row) for row in zip(*columns)]
    return "\n".join(lines) + "\n"


def _zip(path: Path, members: dict[str, str | bytes]) -> Path:
    with zipfile.ZipFile(path, "w") as zf:
        for name, content in members.items():
            zf.writestr(name, content)
    return path


META = {"meta/device.csv": '"property","value"\n"deviceModel","Pixel"\n', "meta/time.csv": '"event","experiment time"\n"START",0\n'}


# -- phyphox CSV --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("sep", "decimal"), [(",", "."), ("\t", "."), (";", ",")], ids=["comma", "tab", "semicolon-decimal-comma"]
)
@pytest.mark.parametrize("unit", ["m/s^2", "m/s²"])
@pytest.mark.parametrize("linear", [True, False], ids=["linear", "with-g"])
def test_phyphox_csv_dialects(tmp_path, sep, decimal, unit, linear):
    t, accel = _signal()
    name = "Linear Acceleration.csv" if linear else "Accelerometer.csv"
    path = _phyphox_csv(tmp_path / name, t, accel, sep=sep, decimal=decimal, unit=unit, linear=linear)
    rec = read(path)
    assert rec.format == "phyphox-csv" == detect_format(path)
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.time, t, rtol=1e-9)
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-8, atol=1e-12)
    assert rec.gravity_removed is linear
    assert any("Absolute acceleration" in n for n in rec.notes)
    assert any("Spring" in n for n in rec.notes) is not linear
    assert rec.path == str(path) and len(rec.sha256) == 64


def test_phyphox_spring_raw_data_without_absolute_column(tmp_path):
    t, accel = _signal()
    rec = read(_phyphox_csv(tmp_path / "Raw Data.csv", t, accel, absolute=False))
    assert rec.format == "phyphox-csv" and rec.gravity_removed is False
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-8, atol=1e-12)


def test_phyphox_renamed_header(tmp_path):
    t, accel = _signal()
    header = '"time","linear_acceleration_x","linear_acceleration_y","linear_acceleration_z","absolute_acceleration"'
    cols = [t, *accel.T, np.linalg.norm(accel, axis=1)]
    rec = read(_write(tmp_path / "raw_data.csv", _table_text(header, cols, fmt="{:.9E}")))
    assert rec.format == "phyphox-csv" and rec.gravity_removed is True
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-8, atol=1e-12)


# -- phyphox ZIP and xlsx -----------------------------------------------------------------


def test_phyphox_zip_with_meta(tmp_path):
    t, accel = _signal()
    raw = _phyphox_csv(tmp_path / "r.csv", t, accel, absolute=False).read_text()
    members = {
        "Raw Data.csv": raw,
        "Autocorrelation.csv": '"Time (s)","Autocorrelation"\n0,1\n',
        "Resonance.csv": '"Frequency (Hz)","Amplitude"\n1,2\n',
        **META,
    }
    path = _zip(tmp_path / "Spring 2024-01-01.zip", members)
    rec = read(path)
    assert rec.format == "phyphox-zip" == detect_format(path)
    assert any("Raw Data.csv" in n for n in rec.notes)
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-8, atol=1e-12)


def test_phyphox_zip_prefers_linear_acceleration(tmp_path):
    t, accel = _signal()
    with_g = _phyphox_csv(tmp_path / "a.csv", t, accel + [0, 0, G]).read_text()
    linear = _phyphox_csv(tmp_path / "b.csv", t, accel, linear=True).read_text()
    path = _zip(tmp_path / "x.zip", {"Accelerometer.csv": with_g, "Linear Acceleration.csv": linear, **META})
    rec = read(path)
    assert rec.gravity_removed is True
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-8, atol=1e-12)


def test_zip_falls_back_to_the_only_acceleration_csv(tmp_path):
    t, accel = _signal()
    data = _phyphox_csv(tmp_path / "a.csv", t, accel).read_text()
    path = _zip(tmp_path / "x.zip", {"My set.csv": data, "Resonance.csv": '"Frequency (Hz)","Amplitude"\n1,2\n', **META})
    assert read(path).format == "phyphox-zip"


@pytest.mark.parametrize("linear", [True, False])
def test_phyphox_xlsx(tmp_path, linear):
    t, accel = _signal()
    prefix = "Linear Acceleration" if linear else "Acceleration"
    frame = pd.DataFrame({"Time (s)": t, **{f"{prefix} {a} (m/s^2)": accel[:, i] for i, a in enumerate("xyz")}})
    frame["Absolute acceleration (m/s^2)"] = np.linalg.norm(accel, axis=1)
    path = tmp_path / "export.xlsx"
    with pd.ExcelWriter(path, engine="openpyxl") as writer:
        pd.DataFrame({"property": ["model"], "value": ["Pixel"]}).to_excel(writer, sheet_name="Metadata Device", index=False)
        frame.to_excel(writer, sheet_name="Raw Data", index=False)
    rec = read(path)
    assert rec.format == "phyphox-xlsx" == detect_format(path)
    assert rec.gravity_removed is linear and rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-12)
    assert read(path, sheet=1).format == "phyphox-xlsx" == read(path, sheet="1").format
    assert read(path, sheet="Raw Data").n_samples == N
    with pytest.raises(InputError, match=r"no sheet 'Nope'; sheets: 'Metadata Device', 'Raw Data'"):
        read(path, sheet="Nope")


# -- Sensor Logger ------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "gravity"), [("Accelerometer.csv", True), ("TotalAcceleration.csv", False)])
def test_sensor_logger(tmp_path, name, gravity):
    t, accel = _signal()
    epoch_ns = (1_700_000_000_000_000_000 + np.round((t - t[0]) * 1e9)).astype(np.int64)
    cols = [epoch_ns, t - t[0], accel[:, 2], accel[:, 1], accel[:, 0]]
    path = _write(tmp_path / name, _table_text("time,seconds_elapsed,z,y,x", cols))
    rec = read(path)
    assert rec.format == "sensor-logger" == detect_format(path)
    assert rec.axes == ("x", "y", "z") and rec.gravity_removed is gravity
    np.testing.assert_allclose(rec.time, t - t[0], atol=1e-12)
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-12)


# -- generic CSV / TXT --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("header", "unit", "factor"),
    [("time_ms", "ms", 1e3), ("t (us)", "us", 1e6), ("Time [ns]", "ns", 1e9), ("millis", "ms", 1e3), ("micros", "us", 1e6)],
)
def test_generic_time_units_from_header(tmp_path, header, unit, factor):
    t, accel = _signal()
    stamps = np.round(t * factor).astype(np.int64)
    path = _write(tmp_path / "log.csv", _table_text(f"{header},ax,ay,az", [stamps, *accel.T]))
    rec = read(path)
    assert rec.format == "generic-csv" == detect_format(path)
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.time, stamps / factor, rtol=1e-12)
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-12)
    assert any(f"converted from {'µs' if unit == 'us' else unit} to s" in n for n in rec.notes)


@pytest.mark.parametrize(("factor", "unit"), [(1.0, "s"), (1e3, "ms"), (1e6, "µs"), (1e9, "ns")])
def test_generic_time_unit_inferred_from_step(tmp_path, factor, unit):
    t, accel = _signal(rate=500.0)
    stamps = t * factor if unit == "s" else np.round(t * factor).astype(np.int64)
    if unit == "ms":  # millis() resolution is too coarse for 500 Hz: use 100 Hz instead
        t, accel = _signal(rate=100.0)
        stamps = np.round(t * 1e3).astype(np.int64)
    rec = read(_write(tmp_path / "log.txt", _table_text(None, [stamps, accel[:, 1]], sep="  ")))
    assert rec.axes == ("a",)
    assert rec.sample_rate == pytest.approx(500.0 if unit != "ms" else 100.0, rel=0.15)
    assert any(f"assumed {unit} from the median step" in n for n in rec.notes)


def test_generic_epoch_ns_keeps_time_base(tmp_path):
    t, accel = _signal()
    stamps = (1_700_000_000_000_000_000 + np.round(t * 1e9)).astype(np.int64)
    rec = read(_write(tmp_path / "log.csv", _table_text("timestamp_ns,acc_z", [stamps, accel[:, 1]])))
    assert rec.time[0] == pytest.approx(1.7e9, rel=1e-9)
    np.testing.assert_allclose(np.diff(rec.time), np.diff(t), atol=1e-6)
    assert rec.axes == ("z",)


@pytest.mark.parametrize("header", ["t,acc_g", "time,a [g]", "Time (s),Acceleration (g)"])
def test_generic_accel_in_g_from_header(tmp_path, header):
    t, accel = _signal()
    rec = read(_write(tmp_path / "g.csv", _table_text(header, [t, accel[:, 1] / G])))
    np.testing.assert_allclose(rec.accel[:, 0], accel[:, 1], rtol=1e-12)
    assert any("converted from g to m/s²" in n for n in rec.notes)


def test_generic_accel_g_inferred_from_gravity_mean(tmp_path):
    t, accel = _signal()
    z_g = -0.92 + accel[:, 1] / G
    rec = read(_write(tmp_path / "g.csv", _table_text("time (s),Acceleration", [t, z_g])))
    np.testing.assert_allclose(rec.accel[:, 0], z_g * G, rtol=1e-12)
    assert rec.axes == ("Acceleration",)
    assert any("assumed g" in n for n in rec.notes)


def test_generic_three_axes_in_g_inferred_from_vector_magnitude(tmp_path):
    t, accel = _signal()
    acc_g = (accel + [0.0, 5.0, 8.5]) / G  # gravity split between y and z
    rec = read(_write(tmp_path / "g.csv", _table_text("t,x,y,z", [t, *acc_g.T])))
    np.testing.assert_allclose(rec.accel, acc_g * G, rtol=1e-12)


def test_generic_ambiguous_accel_assumes_si_and_notes_it(tmp_path):
    t, accel = _signal()
    rec = read(_write(tmp_path / "a.csv", _table_text("t,ax,ay,az", [t, *accel.T])))
    np.testing.assert_allclose(rec.accel, accel, rtol=1e-12)
    assert any("ambiguous" in n and "assumed m/s²" in n for n in rec.notes)


def test_generic_with_g_in_si_is_not_mistaken_for_g(tmp_path):
    t, accel = _signal()
    rec = read(_write(tmp_path / "a.csv", _table_text("t,ax,ay,az", [t, *(accel + [0, 0, G]).T])))
    np.testing.assert_allclose(rec.accel, accel + [0, 0, G], rtol=1e-12)


def test_generic_comments_semicolon_decimal_comma(tmp_path):
    t, accel = _signal()
    body = _table_text("Zeit (s);acc_x;acc_y;acc_z", [t, *accel.T], sep=";", fmt="{:.10f}").replace(".", ",")
    rec = read(_write(tmp_path / "messung.csv", "# logger v1\n# rate 100 Hz\n" + body))
    np.testing.assert_allclose(rec.time, t, atol=1e-10)
    np.testing.assert_allclose(rec.accel, accel, atol=1e-10)
    assert any("decimal comma" in n for n in rec.notes)


def test_generic_options_override(tmp_path):
    t, accel = _signal()
    stamps = np.round(t * 1e3).astype(np.int64)
    path = _write(tmp_path / "data.tsv", _table_text("idx\tfoo\tbar\tbaz", [np.arange(N), stamps, accel[:, 0] / G, accel[:, 1] / G], sep="\t"))
    rec = read(path, time_column="foo", accel_columns=["bar", 3], time_unit="ms", accel_unit="g")
    np.testing.assert_allclose(rec.time, stamps / 1e3)
    np.testing.assert_allclose(rec.accel, accel[:, :2], rtol=1e-12)
    assert rec.axes == ("bar", "baz")
    assert read(path, time_column=1, accel_columns="bar", time_unit="ms").axes == ("bar",)


def test_headerless_with_options_and_bom(tmp_path):
    t, accel = _signal()
    text = _table_text(None, [accel[:, 0], t, accel[:, 1]])
    path = tmp_path / "raw.csv"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    rec = read(path, time_column=1, accel_columns=[0, 2])
    np.testing.assert_allclose(rec.time, t)
    np.testing.assert_allclose(rec.accel, accel[:, :2], rtol=1e-12)


def test_irregular_time_and_repeated_values_are_kept(tmp_path):
    t, accel = _signal()
    t = t.copy()
    t[100:] += 0.5  # a gap
    a = accel[:, 1].copy()
    a[1::3] = a[0::3][: a[1::3].size]  # sensor polled faster than its output rate
    rec = read(_write(tmp_path / "a.csv", _table_text("time,acc", [t, a])))
    np.testing.assert_allclose(rec.time, t)
    np.testing.assert_allclose(rec.accel[:, 0], a)


def test_trailing_delimiters_do_not_shift_columns(tmp_path):
    t, accel = _signal()
    text = _table_text("time,acc", [t, accel[:, 1]]).replace("\n", ",\n")
    rec = read(_write(tmp_path / "trailing.csv", "time,acc\n" + text.split("\n", 1)[1]))
    np.testing.assert_allclose(rec.time, t)
    np.testing.assert_allclose(rec.accel[:, 0], accel[:, 1])


def test_whitespace_separated_with_header(tmp_path):
    t, accel = _signal()
    rec = read(_write(tmp_path / "log.dat", _table_text("time  ax  ay  az", [t, *accel.T], sep="   ")))
    assert rec.format == "generic-csv" and rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.accel, accel)


def test_sensor_logger_zip(tmp_path):
    t, accel = _signal()
    acc = _table_text("time,seconds_elapsed,z,y,x", [np.arange(N) * 10**7, t, *accel.T[::-1]])
    gyro = _table_text("time,seconds_elapsed,z,y,x", [np.arange(N) * 10**7, t, *accel.T])
    rec = read(_zip(tmp_path / "sl.zip", {"Gyroscope.csv": gyro, "Accelerometer.csv": acc, "Metadata.csv": "a,b\n1,2\n"}))
    assert rec.format == "sensor-logger" and rec.gravity_removed is True
    np.testing.assert_allclose(rec.accel, accel)


def test_adxl345_like_micros_g_with_bom(tmp_path):
    stamps = 19202812 + np.cumsum(np.full(N, 1876) + np.arange(N) % 3)
    a_g = -0.92 + 0.5 * np.sin(np.arange(N) / 5)
    path = tmp_path / "Cantilever.csv"
    path.write_bytes(b"\xef\xbb\xbf" + _table_text("Time Stamp,Acceleration", [stamps, a_g]).replace("\n", "\r\n").encode())
    rec = read(path)
    np.testing.assert_allclose(rec.time, stamps / 1e6, rtol=1e-12)
    np.testing.assert_allclose(rec.accel[:, 0], a_g * G, rtol=1e-12)


# -- NumPy --------------------------------------------------------------------------------


@pytest.mark.parametrize("transpose", [False, True])
def test_npy_time_accel_in_g(tmp_path, transpose):
    t, accel = _signal(rate=4000.0)
    z_g = 0.045 + accel[:, 1] / G
    arr = np.vstack([t, z_g])
    path = tmp_path / "accelerometer_data.npy"
    np.save(path, arr.T if transpose else arr)
    rec = read(path)
    assert rec.format == "npy" == detect_format(path) and rec.axes == ("a",)
    np.testing.assert_allclose(rec.time, t)
    np.testing.assert_allclose(rec.accel[:, 0], z_g * G, rtol=1e-12)
    assert any("assumed g" in n for n in rec.notes)
    np.testing.assert_allclose(read(path, accel_unit="m/s2").accel[:, 0], z_g)


def test_npy_time_xyz(tmp_path):
    t, accel = _signal()
    path = tmp_path / "a.npy"
    np.save(path, np.column_stack([t * 1e3, accel]))
    rec = read(path, time_unit="ms", accel_unit="m/s^2")
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.time, t, rtol=1e-12)
    np.testing.assert_allclose(rec.accel, accel)


def test_npz_named_arrays(tmp_path):
    t, accel = _signal()
    path = tmp_path / "run.npz"
    np.savez(path, t=t, acc=accel, note_len=np.arange(3))
    rec = read(path, accel_unit="m/s²")
    assert rec.format == "npz" == detect_format(path)
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.accel, accel)


def test_npz_positional_arrays(tmp_path):
    t, accel = _signal()
    path = tmp_path / "run.npz"
    np.savez(path, t, accel[:, 1])
    rec = read(path, accel_unit="m/s2")
    np.testing.assert_allclose(rec.time, t)
    np.testing.assert_allclose(rec.accel[:, 0], accel[:, 1])


# -- bad input ----------------------------------------------------------------------------


def _raises(path, match: str, **options) -> InputError:
    with pytest.raises(InputError, match=match) as info:
        read(path, **options)
    message = str(info.value)
    assert "\n" not in message and str(path) in message
    return info.value


def test_missing_file(tmp_path):
    _raises(tmp_path / "nope.csv", "file not found")


def test_directory(tmp_path):
    _raises(tmp_path, "is a directory")


def test_empty_file(tmp_path):
    _raises(_write(tmp_path / "e.csv", ""), r"is empty \(0 bytes\)")


def test_header_only(tmp_path):
    _raises(_write(tmp_path / "h.csv", '"Time (s)","Acceleration x (m/s^2)"\n'), "header but no data rows")


def test_text_junk(tmp_path):
    _raises(_write(tmp_path / "j.txt", "hello there\nthis is not data\nat all, really\n"), "no numeric data rows")


def test_binary_junk(tmp_path):
    path = tmp_path / "b.csv"
    path.write_bytes(bytes(np.random.default_rng(1).integers(0, 256, 4096, dtype=np.uint8)))
    _raises(path, "is binary")


@pytest.mark.parametrize(
    ("cell", "match"),
    [("", "acceleration has 1 missing"), ("NaN", "acceleration has 1 missing"), ("abc", "non-numeric value 'abc' in data row 6")],
)
def test_missing_or_bad_cell(tmp_path, cell, match):
    t, accel = _signal()
    lines = _table_text("time,acc", [t, accel[:, 1]]).splitlines()
    lines[6] = f"{t[5]},{cell}"
    _raises(_write(tmp_path / "m.csv", "\n".join(lines)), match)


def test_missing_time_cell(tmp_path):
    t, accel = _signal()
    lines = _table_text("time,acc", [t, accel[:, 1]]).splitlines()
    lines[3] = f",{accel[2, 1]}"
    _raises(_write(tmp_path / "m.csv", "\n".join(lines)), "time has 1 missing")


def test_non_monotonic_time_keeps_the_longest_run(tmp_path):
    t, accel = _signal()
    t = t.copy()
    t[[10, 11]] = t[[11, 10]]
    rec = read(_write(tmp_path / "n.csv", _table_text("time,acc", [t, accel[:, 1]])))
    assert rec.n_samples == t.size - 11 and rec.time[0] == t[11]
    assert any(n.startswith("time goes backwards at sample 12") and "2 runs of time stamps" in n
               for n in rec.notes)


def test_duplicated_time_splits_into_segments(tmp_path):
    t, accel = _signal()
    t = t.copy()
    t[11] = t[10]
    rec = read(_write(tmp_path / "d.csv", _table_text("time,acc", [t, accel[:, 1]])))
    assert rec.n_samples == t.size - 1 and rec.segments == ((0, 11), (11, t.size - 1))
    assert any("repeats (sample 12): 2 segments" in n for n in rec.notes)


def test_time_with_no_usable_run_is_still_refused(tmp_path):
    t, accel = _signal()
    _raises(_write(tmp_path / "r.csv", _table_text("time,acc", [t[::-1], accel[:, 1]])),
            "time goes backwards at sample 1")
    _raises(_write(tmp_path / "s.csv", _table_text("time,acc", [np.ones(t.size), accel[:, 1]])),
            "time is duplicated at sample 1")


def test_unknown_columns(tmp_path):
    t, accel = _signal()
    path = _write(tmp_path / "u.csv", _table_text("foo,bar", [t, accel[:, 1]]))
    _raises(path, r"no time or acceleration column recognised among columns 'foo', 'bar'.*--time-column/--accel-columns")
    assert read(path, time_column="foo", accel_columns="bar").n_samples == N


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"time_column": "when"}, r"column 'when' not found; available columns: 'time', 'acc'"),
        ({"accel_columns": ["acc", 5]}, r"column index 5 is out of range; available columns: 'time', 'acc'"),
        ({"time_column": "acc", "accel_columns": "acc"}, "cannot be both time and acceleration"),
    ],
)
def test_options_naming_missing_columns(tmp_path, options, match):
    t, accel = _signal()
    _raises(_write(tmp_path / "o.csv", _table_text("time,acc", [t, accel[:, 1]])), match, **options)


@pytest.mark.parametrize(("options", "match"), [({"time_unit": "h"}, "unknown time unit 'h'"), ({"accel_unit": "ft/s2"}, "unknown acceleration unit")])
def test_bad_unit_options(tmp_path, options, match):
    with pytest.raises(InputError, match=match):
        read(tmp_path / "any.csv", **options)


def test_unsupported_extension(tmp_path):
    _raises(_write(tmp_path / "data.json", "{}"), r"unsupported file type '.json'")


def test_corrupt_zip(tmp_path):
    t, accel = _signal()
    good = _zip(tmp_path / "g.zip", {"Raw Data.csv": _phyphox_csv(tmp_path / "r.csv", t, accel).read_text()})
    bad = tmp_path / "bad.zip"
    bad.write_bytes(good.read_bytes()[:200])
    _raises(bad, "not a valid .zip archive")
    _raises(_write(tmp_path / "text.zip", "not a zip at all\n"), "not a valid .zip file")


def test_zip_without_acceleration_csv(tmp_path):
    path = _zip(tmp_path / "x.zip", {"Resonance.csv": '"Frequency (Hz)","Amplitude"\n1,2\n3,4\n', **META})
    _raises(path, r"zip without an acceleration CSV \(found 'Resonance.csv'\)")
    _raises(_zip(tmp_path / "y.zip", META | {"readme.md": "hi"}), "zip without CSV files")


def test_zip_with_several_acceleration_csvs(tmp_path):
    t, accel = _signal()
    data = _phyphox_csv(tmp_path / "a.csv", t, accel).read_text()
    _raises(_zip(tmp_path / "x.zip", {"run 1.csv": data, "run 2.csv": data}), "several acceleration CSVs")


def test_too_few_samples(tmp_path):
    t, accel = _signal(n=5)
    _raises(_write(tmp_path / "s.csv", _table_text("time,acc", [t, accel[:, 1]])), "only 5 samples; at least 16")


def test_single_column(tmp_path):
    _raises(_write(tmp_path / "one.csv", "\n".join(str(i) for i in range(30))), "has only one column")


def test_time_unit_cannot_be_inferred(tmp_path):
    t = np.arange(N) * 1e-7  # 10 MHz even in s: no unit gives 1 Hz–100 kHz
    _raises(_write(tmp_path / "t.csv", _table_text("t,acc", [t, np.sin(t)])), "cannot infer the time unit")


def test_bad_npy(tmp_path):
    path = tmp_path / "a.npy"
    np.save(path, np.zeros((5, 100)))
    _raises(path, r"has shape \(5, 100\); expected \(2, N\)")
    np.save(path, np.array(["a", "b"]))
    _raises(path, "dtype <U1; expected numbers")
    _raises(_write(tmp_path / "b.npy", "1,2\n"), "not a valid .npy file")
    np.save(path, np.array([{"a": 1}], dtype=object))
    _raises(path, "not a readable .npy file")


def test_xls_needs_xlrd(tmp_path):
    path = tmp_path / "old.xls"
    path.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(512))
    _raises(path, "legacy .xls workbook.*export as .xlsx or CSV")


def test_corrupt_xlsx(tmp_path):
    _raises(_zip(tmp_path / "bad.xlsx", {"[Content_Types].xml": "<x/>", "xl/workbook.xml": "garbage"}), "not a readable xlsx workbook")


def test_detect_format_errors_name_the_file(tmp_path):
    with pytest.raises(InputError, match="nope.csv: file not found"):
        detect_format(tmp_path / "nope.csv")


# -- real recordings ----------------------------------------------------------------------


def _real(sub: str) -> Path:
    if not REAL.is_dir():
        pytest.skip(f"real recordings not available at {REAL}")
    return REAL / sub


def test_real_phone_spring():
    rec = read(_real("phone-spring-metalcupcake5/raw_data.csv"))
    assert rec.format == "phyphox-csv" and rec.gravity_removed is True
    assert rec.axes == ("x", "y", "z") and rec.n_samples == 17_600
    assert rec.sample_rate == pytest.approx(59.0, rel=0.02)
    assert rec.duration == pytest.approx(298.5, abs=0.5)
    assert 5 < np.abs(rec.axis("y")).max() < 25


@pytest.mark.parametrize("theta", [5, 15, 25, 45, 60])
def test_real_phone_pendulum(theta):
    rec = read(_real(f"phone-pendulum-harinlee83/l2LongTheta{theta}.csv"))
    assert rec.format == "phyphox-csv" and rec.gravity_removed is True
    assert rec.axes == ("x", "y", "z")
    assert rec.sample_rate == pytest.approx(100.3, rel=0.01)
    assert 40 < rec.duration < 50
    assert abs(rec.accel.mean(axis=0)).max() < 5  # gravity removed


def _real_npys() -> list[Path]:
    return sorted(REAL.glob("cantilever-adxl357-demirkaya/**/accelerometer_data.npy")) if REAL.is_dir() else []


@pytest.mark.parametrize("path", _real_npys() or [None], ids=lambda p: p.parent.name if p else "missing")
def test_real_cantilever_adxl357_npy(path):
    if path is None:
        pytest.skip("real recordings not available")
    rec = read(path)
    assert rec.format == "npy" and rec.axes == ("a",)
    rate = 6100.0 if "LSM" in str(path) else 3995.0
    assert rec.sample_rate == pytest.approx(rate, rel=0.03)
    assert rec.duration == pytest.approx(20.0, abs=0.3)
    raw_peak = np.abs(np.load(path)[1]).max()
    assert np.abs(rec.accel).max() == pytest.approx(raw_peak * G)  # read as g
    assert 5 < np.abs(rec.accel).max() < 100  # m/s²
    assert any("assumed g" in n for n in rec.notes)


def test_real_cantilever_adxl345_csv():
    rec = read(_real("cantilever-adxl345-rayjada/Cantilever-Data.csv"))
    assert rec.format == "generic-csv" and rec.n_samples == 3347
    assert rec.sample_rate == pytest.approx(533.0, rel=0.01)
    assert rec.duration == pytest.approx(6.28, abs=0.05)
    assert rec.time[0] == pytest.approx(19.202812)  # micros() → s, own time base kept
    assert rec.accel.mean() == pytest.approx(-0.92 * G, rel=0.1)  # g → m/s²
    assert np.abs(rec.accel).max() == pytest.approx(15.97 * G, rel=0.01)
    assert np.mean(np.diff(rec.accel[:, 0]) == 0) > 0.2  # repeated samples kept


# -- lab exports (issue 19): Vernier Logger Pro / Graphical Analysis, PASCO Capstone -----------
# Synthetic files written the way these programs write them (generated here, no copies).


def _lab_decay(n: int = 1500, rate: float = 50.0, scale: float = 1.0):
    """Time [s] from 0 at ``rate`` [Hz] and a 2.5 Hz decay [m/s²] (a Vernier/PASCO cart)."""
    t = np.arange(n) / rate
    return t, scale * 4.0 * np.exp(-0.2 * t) * np.cos(2 * np.pi * 2.5 * t)


def _logger_pro(path: Path, runs: list[tuple[np.ndarray, np.ndarray]], *, decimal: str = ".",
                sets: str = "per column", position: bool = False, newline: str = "\r\n",
                encoding: str = "latin-1") -> Path:
    """A Logger Pro "Export As ▸ Text" file: format line, file name and date, data set
    name(s), long names, short names, units, a blank line, tab-separated data; shorter runs
    end in empty cells."""
    longs, shorts, units, names = [], [], [], []
    for k, _ in enumerate(runs):
        cols = (["Time", "Position", "Acceleration"], ["t", "x", "a"], ["s", "m", "m/s²"]) if position \
            else (["Time", "Acceleration"], ["t", "a"], ["s", "m/s²"])
        longs += cols[0]
        shorts += cols[1]
        units += cols[2]
        names += [f"Run {k + 1}"] * len(cols[0])
    head = ["Vernier Format 2", "Untitled.cmbl 3/14/2026 10:21:05 ."]
    head += ["\t".join(names)] if sets == "per column" else [names[0]]
    head += ["\t".join(longs), "\t".join(shorts), "\t".join(units), ""]
    fmt = lambda v: f"{v:.5g}".replace(".", decimal)  # noqa: E731
    rows = []
    for i in range(max(t.size for t, _ in runs)):
        cells = []
        for t, a in runs:
            if i >= t.size:
                cells += [""] * (3 if position else 2)
                continue
            vals = [t[i], -a[i] / (2 * np.pi * 2.5) ** 2, a[i]] if position else [t[i], a[i]]
            cells += [fmt(v) for v in vals]
        rows.append("\t".join(cells))
    path.write_bytes(newline.join(head + rows).encode(encoding) + newline.encode())
    return path


def test_logger_pro_text_export(tmp_path):
    t, a = _lab_decay()
    path = _logger_pro(tmp_path / "cart.txt", [(t, a)], sets="one", position=True)
    rec = read(path)
    assert rec.format == "logger-pro-txt" == detect_format(path)
    assert rec.axes == ("Acceleration (m/s²)",) and rec.time_unit == "s"
    np.testing.assert_allclose(rec.accel[:, 0], a, atol=1e-4)
    np.testing.assert_allclose(rec.time, t)
    notes = " | ".join(rec.notes)
    assert "Vernier (Logger Pro) text export (Untitled.cmbl 3/14/2026" in notes
    assert "data set 'Run 1'" in notes and "ignored columns 'Position (m)'" in notes


def test_logger_pro_runs_side_by_side_and_decimal_comma(tmp_path):
    t, a = _lab_decay()
    t2, a2 = _lab_decay(900, scale=0.5)
    path = _logger_pro(tmp_path / "two.txt", [(t, a), (t2, a2)], decimal=",", newline="\n",
                       encoding="utf-8")
    rec = read(path)
    assert rec.n_samples == t.size and "read with decimal comma" in rec.notes
    np.testing.assert_allclose(rec.accel[:, 0], a, atol=1e-4)
    note = next(n for n in rec.notes if n.startswith("read run"))
    assert note == ("read run 'Run 1' (1500 rows, the first run); the file has 2 runs ('Run 1', "
                    "'Run 2'): choose another with --run")
    second = read(path, run=2)
    assert second.n_samples == 900 and not any("empty cells" in n for n in second.notes)
    np.testing.assert_allclose(second.accel[:, 0], a2, atol=1e-4)
    assert read(path, run="run 2").n_samples == 900
    assert second.read_options["run"] == 2
    _raises(path, r"has no run 'Run 3'; runs: 'Run 1', 'Run 2'", run="Run 3")


def test_vernier_format_2_from_an_arduino_sketch(tmp_path):
    """Vernier's Arduino sketches print the format line, a title, "Data Set", long names and
    units (no short names), with units spelled out."""
    t, a = _lab_decay()
    lines = ["Vernier Format 2", "Acceleration Readings taken using Arduino", "Data Set",
             "Time\tAcceleration", "seconds\tm/s/s"]
    lines += [f"{ti:.3f}\t{ai:.4f}" for ti, ai in zip(t, a)]
    rec = read(_write(tmp_path / "serial.txt", "\n".join(lines) + "\n"))
    assert rec.format == "logger-pro-txt" and rec.time_unit == "s"
    assert rec.axes == ("Acceleration (m/s/s)",)
    np.testing.assert_allclose(rec.accel[:, 0], a, atol=1e-4)


def test_graphical_analysis_csv_with_three_axes_and_a_latest_run(tmp_path):
    t, a = _lab_decay()
    axes = ["X-axis acceleration", "Y-axis acceleration", "Z-axis acceleration"]
    header = ",".join(f'"{run}: {name} (m/s²)"' for run in ("Latest",) for name in ["Time"] + axes)
    header = header.replace('"Latest: Time (m/s²)"', '"Latest: Time (s)"')
    header += "," + ",".join(f'"Run 1: {n}"' for n in ("Time (s)", "Y-axis acceleration (m/s²)"))
    rows = [header] + [f"{ti:.3f},{0.1 * ai:.4f},{ai:.4f},9.81,{ti:.3f},{-ai:.4f}"
                       for ti, ai in zip(t, a)]
    path = _write(tmp_path / "ga.csv", "\n".join(rows) + "\n")
    rec = read(path)
    assert rec.format == "graphical-analysis-csv" == detect_format(path)
    assert rec.axes == ("x", "y", "z")
    np.testing.assert_allclose(rec.axis("y"), a, atol=1e-4)
    assert any(n.startswith("read run 'Latest' (1500 rows, the first run)") for n in rec.notes)
    other = read(path, run=1)
    assert other.axes == ("y",) and other.accel[1, 0] == pytest.approx(-a[1], abs=1e-4)
    assert read(path, run="latest").axes == ("x", "y", "z")


def _capstone(path: Path, runs, sep: str = ",") -> Path:
    """A PASCO Capstone "Export Data" CSV: the run after each column name, shorter runs end
    in empty cells."""
    header = sep.join(f'"{name} Run #{k + 1}"' for k in range(len(runs))
                      for name in ("Time (s)", "Acceleration (m/s²)"))
    rows = [header]
    for i in range(max(t.size for t, _ in runs)):
        rows.append(sep.join(f"{v:.4f}" if i < t.size else "" for t, a in runs
                             for v in ((t[i], a[i]) if i < t.size else (0, 0))))
    return _write(path, "\n".join(rows) + "\n")


def test_capstone_csv_runs_of_different_lengths(tmp_path):
    t, a = _lab_decay()
    t2, a2 = _lab_decay(700, scale=2.0)
    path = _capstone(tmp_path / "capstone.csv", [(t2, a2), (t, a)])
    rec = read(path)
    assert rec.format == "capstone-csv" == detect_format(path)
    assert rec.n_samples == 700 and rec.axes == ("Acceleration (m/s²)",)
    np.testing.assert_allclose(rec.accel[:, 0], a2, atol=1e-4)
    assert any("read run 'Run #1' (700 rows, the first run); the file has 2 runs" in n
               for n in rec.notes)
    assert not any("empty cells" in n for n in rec.notes)  # a shorter run is not a defect
    for choice in ("Run #2", "2", 2, "run 2"):
        second = read(path, run=choice)
        assert second.n_samples == 1500
        assert any("as chosen with --run" in n for n in second.notes)
    np.testing.assert_allclose(read(path, run=2).accel[:, 0], a, atol=1e-4)
    _raises(path, "has no run '7'", run=7)


def test_run_on_a_file_without_runs_is_refused(tmp_path):
    t, accel = _signal()
    path = _phyphox_csv(tmp_path / "p.csv", t, accel)
    _raises(path, r"--run: this file has no runs \(no 'Run 1:' or 'Run #1' column names\)", run=1)
    _raises(path, "run must be a run label", run=True)


def test_native_lab_files_are_refused_with_the_export_to_use(tmp_path):
    for ext, menu in ((".cmbl", r"Export As ▸ Text"), (".gambl", r"Export ▸ CSV"),
                      (".cap", r"File ▸ Export Data")):
        path = _write(tmp_path / f"run{ext}", "<xml/>")
        _raises(path, f"is a .* file; export the data as .*{menu}")
    _raises(tmp_path / "absent.cmbl", "file not found")  # the first reason still comes first


def test_position_only_files_say_so(tmp_path):
    """A motion detector's export (position, velocity) has no acceleration: the reason, not
    an invitation to name the position column as acceleration."""
    t, a = _lab_decay()
    x = -a / (2 * np.pi * 2.5) ** 2
    lines = ["Vernier Format 2", "Untitled.cmbl 3/14/2026 10:21:05 .", "Latest",
             "Time\tPosition\tVelocity", "t\tx\tv", "s\tm\tm/s", ""]
    lines += [f"{ti:.3f}\t{xi:.6f}\t{vi:.6f}" for ti, xi, vi in zip(t, x, np.gradient(x, t))]
    path = _write(tmp_path / "motion.txt", "\n".join(lines) + "\n")
    err = _raises(path, r"this file has position/displacement/velocity \('Position \(m\)', "
                        r"'Velocity \(m/s\)'\) but no acceleration column; dampfit analyses "
                        "acceleration")
    assert "--accel-columns" not in str(err) and "--time-column" not in str(err)
    for header in ("time,x (m)", "t,displacement", "Time (s),Distance (cm)"):
        err = _raises(_write(tmp_path / "d.csv", _table_text(header, [t, x])),
                      "position/displacement .* but no acceleration column")
        assert "--accel-columns" not in str(err)
    _raises(path, r"column 'Position \(m\)' holds position, not acceleration",
            accel_columns=["Position (m)"])


def _lines_with_empty_cells(t, a, empty: dict[int, str]) -> str:
    rows = [f"{ti:.4f},{ai:.5f}" for ti, ai in zip(t, a)]
    for i, row in empty.items():
        rows[i] = row
    return "time,acc\n" + "\n".join(rows) + "\n"


def test_empty_edge_rows_are_dropped_with_a_note(tmp_path):
    t, a = _lab_decay()
    text = _lines_with_empty_cells(t, a, {0: f"{t[0]:.4f},", 1: ",", len(t) - 1: f"{t[-1]:.4f},"})
    rec = read(_write(tmp_path / "edges.csv", text))
    assert rec.n_samples == t.size - 3 and rec.time[0] == pytest.approx(t[2])
    assert "dropped 2 leading rows and 1 trailing row with empty cells (at the edges of the table)" \
        in rec.notes


def test_empty_cells_inside_the_data_name_the_fix_unless_the_window_leaves_them_out(tmp_path):
    t, a = _lab_decay()
    path = _write(tmp_path / "gap.csv", _lines_with_empty_cells(
        t, a, {0: ",", 1000: f"{t[1000]:.4f},", 1001: f"{t[1001]:.4f},"}))
    _raises(path, r"acceleration has 2 missing or non-finite values inside the data \(first at "
                  r"data row 1001, after t = 19\.98 s\); fill or delete those rows, or give "
                  r"--window START END that leaves them out")
    rec = read(path, window=(2.0, 15.0))
    assert rec.n_samples == t.size - 3
    assert "dropped 2 rows with empty cells outside the window 2–15 s" in rec.notes
    assert rec.time[0] <= 2.0 and rec.time[-1] >= 15.0
    _raises(path, "inside the data", window=(2.0, 25.0))  # the window holds them
    time_gap = _write(tmp_path / "tgap.csv", _lines_with_empty_cells(t, a, {700: f",{a[700]:.5f}"}))
    _raises(time_gap, r"time has 1 missing or non-finite value inside the data \(first at data "
                      r"row 701")
    assert read(time_gap, window=(0.5, 10.0)).n_samples == t.size - 1
    _raises(path, "window must be two finite times", window=(3.0, 1.0))


def test_reading_options_are_recorded(tmp_path):
    t, accel = _signal()
    text = _table_text("stamp;acc_a;acc_b", [t * 1000, accel[:, 1] / G, accel[:, 0]], sep=";")
    rec = read(_write(tmp_path / "o.csv", text), time_column="stamp", accel_columns=["acc_a"],
               time_unit="ms", accel_unit="g")
    assert rec.read_options == {"time_column": "stamp", "accel_columns": ["acc_a"],
                                "time_unit": "ms", "accel_unit": "g", "sheet": None,
                                "variable": None, "row": None, "run": None, "rate": None,
                                "group": None, "channel": None}
