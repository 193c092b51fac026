"""The parts of ``dampfit record`` without a network: URL check, answer parsers, sample
cleaning, the release/end-of-decay detector, the live line, the shipped phyphox experiment
(its XML, its export columns read back by dampfit, its QR payload, the wheel)."""

from __future__ import annotations

import io
import shutil
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit.errors import InputError
from dampfit.record import live as L
from dampfit.record import phyphox as P
from dampfit.record.experiment import EXPERIMENT, experiment_bytes, qr_payloads, write_experiment
from dampfit.record.session import _Samples, quantisation_note
from tests._support.fake_phyphox import java_number

ROOT = Path(__file__).resolve().parents[2]
ACCEL = P.AccelInput("linear_acceleration", "t", "ax", "ay", "az")


# ----------------------------------------------------------------------------- URL
@pytest.mark.parametrize("url,expected", [
    ("http://192.168.1.20:8080", "http://192.168.1.20:8080"),
    ("HTTP://192.168.1.20:8080/", "http://192.168.1.20:8080"),
    ("http://phone.local", "http://phone.local:80"),
    ("http://[fe80::1]:8080", "http://[fe80::1]:8080"),
])
def test_check_url_accepts_phyphox_addresses(url, expected):
    assert P.check_url(url) == expected


@pytest.mark.parametrize("url,match", [
    ("https://192.168.1.20:8080", "plain HTTP, not HTTPS"),
    ("file:///etc/passwd", "only http:// URLs"),
    ("ftp://192.168.1.20/x", "only http:// URLs"),
    ("192.168.1.20:8080", "does not start with http://"),
    ("localhost:8080", "only http:// URLs"),
    ("http://user:pw@192.168.1.20:8080", "user name or password"),
    ("http://192.168.1.20:99999", "port must be a number"),
    ("http://192.168.1.20:0", "port must be a number"),
    ("http://192.168.1.20:8080/get?t=full", "without a path, query"),
    ("http://", "no host"),
    ("http://192.168.1.20 :8080", "spaces or control characters"),
    ("http://192.168.1.20:8080\n", "spaces or control characters"),
])
def test_check_url_refuses_everything_else(url, match):
    with pytest.raises(InputError, match=match):
        P.check_url(url)


# --------------------------------------------------------------------------- answers
def _config(inputs, buffers=("t", "ax", "ay", "az", "gt", "gx", "gy", "gz")):
    return {"crc32": "1", "title": "T", "buffers": [{"name": b, "size": 0} for b in buffers],
            "inputs": inputs, "export": []}


def _outputs(t, x, y, z):
    return [{"x": x}, {"y": y}, {"z": z}, {"t": t}]


def test_parse_config_finds_the_accelerometer_from_the_inputs():
    with_g = {"source": "accelerometer", "outputs": _outputs("gt", "gx", "gy", "gz")}
    without_g = {"source": "linear_acceleration", "outputs": _outputs("t", "ax", "ay", "az")}
    gyro = {"source": "gyroscope", "outputs": _outputs("t", "ax", "ay", "az")}
    assert P.parse_config(_config([gyro, with_g])).accel == P.AccelInput(
        "accelerometer", "gt", "gx", "gy", "gz")
    # both: the one without g (what dampfit's experiment uses)
    cfg = P.parse_config(_config([with_g, without_g]))
    assert cfg.accel.buffers == ("t", "ax", "ay", "az") and cfg.accel.gravity_removed


@pytest.mark.parametrize("obj,err,match", [
    (_config([{"source": "gyroscope", "outputs": _outputs("t", "ax", "ay", "az")}]), InputError,
     "has no accelerometer"),
    (_config([{"source": "accelerometer", "outputs": [{"x": "ax"}, {"t": "t"}]}]), InputError,
     "has no accelerometer"),
    (_config([{"source": "accelerometer", "outputs": _outputs("t", "ax", "ay", "nope")}]),
     InputError, "has no accelerometer"),
    ([1, 2], P.NotPhyphox, "did not answer like phyphox"),
    ({"inputs": "x", "buffers": []}, P.NotPhyphox, "did not answer like phyphox"),
    (_config([{"source": "accelerometer", "outputs": _outputs("t", "a\nx", "ay", "az")}]),
     P.NotPhyphox, "not a usable buffer name"),
])
def test_parse_config_refusals(obj, err, match):
    with pytest.raises(err, match=match):
        P.parse_config(obj)


def test_parse_meta_android_ios_and_lenient_keys():
    android = {"deviceModel": "Pixel\x1b[2J 8", "version": "1.2.1",
               "sensors": {"linear_acceleration": {"Name": "LSM6", "Range": "78.4",
                                                   "Resolution": "0.0011901855",
                                                   "MinDelay": "2500"}}}
    phone, sensor = P.parse_meta(android, "linear_acceleration")
    assert phone["model"] == "Pixel [2J 8" and phone["phyphox_version"] == "1.2.1"
    assert sensor["resolution"] == pytest.approx(0.0011901855) and sensor["range"] == 78.4
    assert sensor["min_delay_us"] == 2500 and sensor["vendor"] is None
    lower = {"sensors": {"accelerometer": {"resolution": "0.002", "name": None}}}
    assert P.parse_meta(lower, "accelerometer")[1]["resolution"] == 0.002
    ios = {"deviceModel": "iPhone", "deviceBoard": None}
    assert P.parse_meta(ios, "accelerometer") == ({**dict.fromkeys(
        ("model", "brand", "manufacturer", "os_release", "phyphox_version", "phyphox_build")),
        "model": "iPhone"}, {})
    bad = {"sensors": {"accelerometer": {"Resolution": "-1", "Range": "NaN"}}}
    assert P.parse_meta(bad, "accelerometer")[1]["resolution"] is None
    with pytest.raises(P.NotPhyphox, match="/meta"):
        P.parse_meta("x", "accelerometer")


def test_parse_time_takes_the_last_start():
    events = [{"event": "START", "experimentTime": 0, "systemTime": 1.7e9},
              {"event": "PAUSE", "experimentTime": 3, "systemTime": 1.7e9 + 3},
              {"event": "START", "experimentTime": 3, "systemTime": 1.7e9 + 9}]
    assert P.parse_time(events) == 1.7e9 + 9
    assert P.parse_time([]) is None and P.parse_time([{"event": "START", "systemTime": "x"}]) is None
    with pytest.raises(P.NotPhyphox, match="/time"):
        P.parse_time({"event": "START"})


def _answer(t, x, y, z, session="s", measuring=True):
    return {"buffer": {n: {"size": 0, "updateMode": "partial", "buffer": v}
                       for n, v in zip(ACCEL.buffers, (t, x, y, z))},
            "status": {"session": session, "measuring": measuring, "timedRun": False,
                       "countDown": 0}}


def test_parse_get_reads_8_digit_numbers_and_nulls():
    body = ('{"buffer": {"t": {"size": 0, "updateMode": "partial", "buffer": [1.2345678E1, '
            '1.2347678E1, null]}, "ax": {"size": 0, "updateMode": "partial", "buffer": '
            '[-9.8066502E-3, null, 0E0]}, "ay": {"size": 0, "updateMode": "partial", "buffer": '
            '[1E0, 2E0, 3E0]}, "az": {"size": 0, "updateMode": "partial", "buffer": [1, 2, 3]}},'
            ' "status": {"session": "abc", "measuring": true, "timedRun": false, "countDown": 0}}')
    chunk = P.parse_get(P._parse_json(body.encode(), "/get"), ACCEL)
    assert chunk.t[:2].tolist() == [12.345678, 12.347678] and np.isnan(chunk.t[2])
    assert chunk.x[0] == -0.0098066502 and np.isnan(chunk.x[1])
    assert chunk.status.session == "abc" and chunk.status.measuring


@pytest.mark.parametrize("mutate,match", [
    (lambda a: a.update(status="fine"), "no buffer and status"),
    (lambda a: a["status"].pop("session"), "no session"),
    (lambda a: a["status"].update(measuring="yes"), "no session or measuring"),
    (lambda a: a["buffer"].pop("ay"), "'ay' is missing"),
    (lambda a: a["buffer"]["ax"].update(buffer=["1.5"]), "not a list of numbers"),
    (lambda a: a["buffer"]["ax"].update(buffer=[True]), "not a list of numbers"),
    (lambda a: a["buffer"]["ax"].update(buffer=[10**400]), "out of range"),
])
def test_parse_get_refuses_garbage(mutate, match):
    answer = _answer([1.0], [2.0], [3.0], [4.0])
    mutate(answer)
    with pytest.raises(P.NotPhyphox, match=match):
        P.parse_get(answer, ACCEL)


def test_parse_get_body_reads_what_parse_get_reads_without_a_float_per_value():
    """The raw answer cut into its number lists and parsed by NumPy gives the same chunk as
    json + :func:`parse_get`; a list holding anything but numbers and nulls is refused."""
    body = ('{"buffer": {"t": {"size": 0, "updateMode": "partial", "buffer": [1.2345678E1, '
            '1.2347678E1, null]}, "ax": {"size": 0, "updateMode": "partial", "buffer": '
            '[-9.8066502E-3, null, 0E0]}, "ay": {"size": 0, "updateMode": "partial", "buffer": '
            '[1E0,2E0,3E0]}, "az": {"size": 0, "updateMode": "partial", "buffer": [1, 2, 1e999]}},'
            ' "status": {"session": "abc", "measuring": true, "timedRun": false, "countDown": 0}}')
    fast = P.parse_get_body(body.encode(), ACCEL)
    slow = P.parse_get(P._parse_json(body.encode(), "/get"), ACCEL)
    for a, b in zip((fast.t, fast.x, fast.y, fast.z), (slow.t, slow.x, slow.y, slow.z)):
        np.testing.assert_array_equal(a, b)
    assert fast.status == slow.status and np.isnan(fast.z[2])
    assert P.values_in(body.encode()) >= 12
    empty = body.replace("[1E0,2E0,3E0]", "[]").encode()
    assert P.parse_get_body(empty, ACCEL).y.size == 0
    for bad in ('["1.5", 2]', "[true, 1]", "[1 2, 3]", "[1, , 2]", "[NaN, 1]", "[[1], 2]"):
        with pytest.raises(P.NotPhyphox, match="not a list of numbers|not JSON"):
            P.parse_get_body(body.replace("[1E0,2E0,3E0]", bad).encode(), ACCEL)


def test_meta_numbers_beyond_their_limits_are_dropped():
    raw = {"Name": "S", "Range": "1e308", "Resolution": "1e308", "MinDelay": "1e300",
           "MaxDelay": "-5"}
    _, info = P.parse_meta({"sensors": {"accelerometer": raw}}, "accelerometer")
    assert info["range"] is info["resolution"] is info["min_delay_us"] is None
    assert info["max_delay_us"] is None and info["name"] == "S"


def test_non_json_is_one_line_not_phyphox():
    with pytest.raises(P.NotPhyphox, match="not JSON \\('<html><body>hi </body></html>'"):
        P._parse_json(b"<html><body>hi\n</body></html>", "/config")
    with pytest.raises(P.NotPhyphox, match="not JSON"):
        P._parse_json(b"[" * 100000, "/get")


def test_java_number_has_8_significant_digits():
    assert java_number(12.3456789) == "1.2345679E1"
    assert java_number(-0.00980665) == "-9.80665E-3" and java_number(0.0) == "0E0"


# ------------------------------------------------------------------------ samples
def test_samples_cut_unequal_lengths_drop_nulls_and_repeats():
    s = _Samples(limit=100)
    nan = np.nan
    chunk = P.parse_get(_answer([0.0, 0.1, 0.2, 0.3], [1, 2, 3], [1, nan, 3, 4], [1, 2, 3, 4]), ACCEL)
    t, a = s.add(chunk)
    assert t.tolist() == [0.0, 0.2] and a[:, 0].tolist() == [1, 3]
    assert s.dropped == {"unequal_lengths": 3, "missing_values": 1, "time_not_increasing": 0}
    # the next answer repeats t = 0.2 and goes back in time once
    t, _ = s.add(P.parse_get(_answer([0.2, 0.3, 0.25, 0.4], *[[5.0] * 4] * 3), ACCEL))
    assert t.tolist() == [0.3, 0.4] and s.dropped["time_not_increasing"] == 2
    assert s.last == 0.4 and s.n == 4 and not s.full


def test_samples_stop_at_their_limit():
    s = _Samples(limit=5)
    t = np.arange(8.0)
    kept, _ = s.add(P.parse_get(_answer(t.tolist(), *[t.tolist()] * 3), ACCEL))
    assert kept.size == 5 and s.full and s.arrays()[0].size == 5


# ----------------------------------------------------------------------- detector
def _feed(rec, resolution=None, step=137):
    d = L.Detector(resolution)
    states = []
    for i in range(0, rec.n_samples, step):
        d.feed(rec.time[i:i + step], rec.accel[i:i + step])
        states.append((d.elapsed, d.state))
    return d, states


def test_detector_finds_release_and_end_of_a_damped_decay():
    cfg = sim.from_modal(5.3, 1.72, 0.03, u0=0.04, duration=40.0, handheld=3.0, seed=2,
                         quantization=0.0012)
    rec, truth = sim.recording(cfg)
    d, states = _feed(rec, cfg.quantization)
    assert d.state == L.DONE
    assert abs(d.release_time - truth["t_release"]) <= 1.0
    assert d.period == pytest.approx(1 / truth["f_d"], rel=0.05)
    # done only once the envelope is at the noise floor: below 3 sigma of the noise
    env = truth["envelope_amplitude"] * truth["omega_n"] ** 2  # acceleration amplitude [m/s²]
    floor_time = truth["t_release"] + np.log(env / (3 * truth["noise_sigma"])) / truth["p"]
    assert d.end_time > floor_time - 2.0
    first_done = next(e for e, s in states if s == L.DONE)
    assert first_done >= d.end_time + 5 * d.period
    assert [s for _, s in states][:3] == [L.WAITING] * 3


def test_detector_keeps_a_light_decay_decaying_and_noise_waiting():
    rec, truth = sim.recording(sim.preset("paper", duration=30.0, seed=4))
    d, _ = _feed(rec)
    assert d.state == L.DECAYING and abs(d.release_time - truth["t_release"]) <= 1.0
    assert d.amplitude == pytest.approx(truth["envelope_amplitude"] * truth["omega_n"] ** 2
                                        * np.exp(-truth["p"] * (d.elapsed - 3.0)), rel=0.15)
    rng = np.random.default_rng(0)
    t = np.arange(0, 20, 0.002)
    noise = L.Detector()
    noise.feed(t, 0.02 * rng.standard_normal((t.size, 3)))
    assert noise.state == L.WAITING and noise.noise == pytest.approx(0.02 * np.sqrt(3), rel=0.1)


def test_detector_handles_slow_rates_and_gaps():
    d = L.Detector()
    t = np.concatenate([np.arange(0, 5, 0.2), np.arange(30, 31, 0.2)])  # 5 Hz, then a 25 s gap
    d.feed(t, np.zeros((t.size, 3)))
    assert d.elapsed == pytest.approx(30.8) and d.state == L.WAITING and d.amplitude == 0.0


# ------------------------------------------------------------------------ live line
class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_live_line_is_throttled_overwritten_and_only_on_a_terminal():
    clock, out = _Clock(), io.StringIO()
    line = L.LiveLine(out, tty=True, interval=0.5, clock=clock)
    assert line.show(1.0, 0.5, L.WAITING)
    assert not line.show(1.2, 0.6, L.WAITING)  # too soon
    clock.now = 0.6
    assert line.show(2.0, 4.2, L.DECAYING)
    line.status("recorded; analysing")
    line.finish("done: 40 s")
    text = out.getvalue()
    assert "\rrecorded; analysing" in text
    assert text.count("\r") >= 3 and "waiting for the release" in text and "4.2 m/s²" in text
    assert text.endswith("done: 40 s\n") and "\n" not in text[:-1]
    plain = io.StringIO()
    quiet = io.StringIO()
    for stream, kw in ((plain, {"tty": False}), (quiet, {"tty": True, "enabled": False})):
        ll = L.LiveLine(stream, clock=clock, **kw)
        assert not ll.show(1.0, 1.0, L.DECAYING, force=True)
        ll.status("analysing")
        ll.finish_quietly()
        ll.finish("final")
    assert plain.getvalue() == "final\n" and quiet.getvalue() == ""


def test_quantisation_note_says_whether_it_matters():
    assert quantisation_note(None, 0.01, "accelerometer") is None
    small = quantisation_note(0.0012, 0.04, "linear_acceleration")
    assert "LSB/√12 = 0.00035 m/s²" in small and "negligible" in small
    big = quantisation_note(0.02, 0.01, "accelerometer")
    assert "set by the resolution" in big


# ------------------------------------------------------------------------ experiment
def test_shipped_experiment_follows_the_file_format():
    root = ET.fromstring(experiment_bytes())
    assert root.tag == "phyphox" and tuple(map(int, root.get("version").split("."))) >= (1, 14)
    containers = {c.text: c.get("size") for c in root.findall("data-containers/container")}
    assert set(containers.values()) == {"0"}  # unbounded: the whole decay is kept
    sensors = root.findall("input/sensor")
    assert len(sensors) == 1 and sensors[0].get("type") == "linear_acceleration"
    assert sensors[0].get("rate") == "0"
    assert sensors[0].get("rateStrategy") in ("auto", "request", "generate", "limit")
    outputs = {o.get("component"): o.text for o in sensors[0].findall("output")}
    assert set(outputs) == {"t", "x", "y", "z"}
    used = set(outputs.values()) | {i.text for i in root.iter("input") if i.text and i.text.strip()}
    used |= {d.text for d in root.findall("export/set/data")}
    assert used <= set(containers), "every buffer used is declared"
    allowed = {"title", "category", "icon", "description", "data-containers", "input", "views",
               "export"}
    assert {child.tag for child in root} <= allowed
    assert len(root.findtext("icon")) <= 3
    graphs = root.findall("views/view/graph")
    assert graphs and all(i.get("axis") in ("x", "y") for g in graphs for i in g.findall("input"))


def test_experiment_export_columns_are_what_the_reader_expects(tmp_path):
    from dampfit.io.readers import read

    root = ET.fromstring(experiment_bytes())
    sets = root.findall("export/set")
    assert [s.get("name") for s in sets] == ["Raw Data"]
    labels = [d.get("name") for d in sets[0].findall("data")]
    rec, _ = sim.recording(sim.preset("paper", duration=5.0, seed=3))
    # the CSV phyphox exports from this set: one column per <data>, its label as header
    path = tmp_path / "Raw Data.csv"
    rows = np.column_stack([rec.time, rec.accel])
    path.write_text(",".join(f'"{lab}"' for lab in labels) + "\n"
                    + "".join(",".join(f"{v:.9E}" for v in row) + "\n" for row in rows))
    back = read(path)
    assert back.format == "phyphox-csv" and back.axes == ("x", "y", "z")
    assert back.gravity_removed is True
    np.testing.assert_allclose(back.accel, rec.accel, rtol=1e-8)
    # and inside a phyphox ZIP export ("Raw Data.csv" is a member the reader picks)
    zpath = tmp_path / "export.zip"
    with zipfile.ZipFile(zpath, "w") as z:
        z.write(path, "Raw Data.csv")
    assert read(zpath).format == "phyphox-zip"


def _rebuild(payloads: list[bytes]) -> bytes:
    """Reassemble the QR payloads as phyphox does and read the experiment back with zipfile."""
    assert all(p[:7] == b"phyphox" and p[12] == len(payloads) for p in payloads)
    assert [p[11] for p in payloads] == list(range(len(payloads)))
    joined = b"".join(p[13:] for p in payloads)
    assert struct.unpack(">I", payloads[0][7:11])[0] == zlib.crc32(joined)
    body, desc = joined[:-16], joined[-16:]
    assert desc[:4] == b"PK\x07\x08"
    name = b"a.phyphox"
    lfh = b"PK\x03\x04" + struct.pack("<5H", 10, 0, 0, 0, 0) + desc[4:] + struct.pack(
        "<2H", len(name), 0) + name
    cd = b"PK\x01\x02" + struct.pack("<6H", 10, 10, 0, 0, 0, 0) + desc[4:] + struct.pack(
        "<5H2I", len(name), 0, 0, 0, 0, 0, 0) + name
    eocd = b"PK\x05\x06" + struct.pack("<4H2IH", 0, 0, 1, 1, len(cd), len(lfh) + len(body), 0)
    with zipfile.ZipFile(io.BytesIO(lfh + body + cd + eocd)) as z:
        return z.read("a.phyphox")


def test_qr_payloads_carry_the_file_byte_for_byte():
    data = experiment_bytes()
    one = qr_payloads(data)
    assert len(one) == 1, "the shipped experiment fits one QR code"
    assert _rebuild(one) == data
    split = qr_payloads(data, chunk=500)
    assert len(split) == 3 and _rebuild(split) == data


def test_write_experiment_with_and_without_segno(tmp_path, monkeypatch):
    pytest.importorskip("segno", reason="optional: segno (pip install 'dampfit[qr]')")
    path, qrs, line = write_experiment(tmp_path / EXPERIMENT)
    assert path.read_bytes() == experiment_bytes()
    assert [q.name for q in qrs] == ["dampfit-decay.qr.svg"] and "QR code" in line
    assert qrs[0].read_text().lstrip().startswith(("<?xml", "<svg"))
    with pytest.raises(InputError, match="exists; use --force"):
        write_experiment(path)
    monkeypatch.setitem(sys.modules, "segno", None)  # as if not installed
    path2, qrs2, line2 = write_experiment(tmp_path / "other.phyphox")
    assert qrs2 == [] and "segno is not installed" in line2 and "dampfit[qr]" in line2
    assert path2.read_bytes() == experiment_bytes()


@pytest.mark.heavy
def test_the_experiment_ships_in_the_wheel(tmp_path):
    if shutil.which("git") is None:
        pytest.skip("git is needed to copy the checkout")
    src = tmp_path / "src"
    shutil.copytree(ROOT / "src", src / "src", ignore=shutil.ignore_patterns(
        "__pycache__", "*.egg-info"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    out = tmp_path / "wheel"
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "-q",
                           "-w", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (wheel,) = out.glob("dampfit-*.whl")
    with zipfile.ZipFile(wheel) as z:
        assert z.read(f"dampfit/data/{EXPERIMENT}") == experiment_bytes()
        assert "dampfit/record/session.py" in z.namelist()
