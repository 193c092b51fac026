"""A hostile phone (``dampfit record``): a server that drips its answer a byte at a time, a
jump of the phone's clock, a ``/get`` answer as dense as JSON allows, ``/meta`` values out of
range, SIGTERM and kill -9 while recording, ``--experiment --force`` on a file dampfit did not
write. Each ends within its deadline, with exit 2 and one line or the correct behaviour, and
keeps every sample that arrived. The phone is :class:`tests._support.fake_phyphox.FakePhone`
(127.0.0.1 only; a drip stops by itself after ``DRIP_MAX_S``)."""

from __future__ import annotations

import json
import signal
import threading
import time
import tracemalloc

import numpy as np
import pytest

from dampfit.io.readers import read
from dampfit.record import live as L
from dampfit.record.phyphox import NotPhyphox, PhyphoxClient, parse_meta
from dampfit.record.session import DEFAULT_DURATION, MAX_RATE_HZ
from tests._support.fake_phyphox import FakePhone, Quirks, stop_after
from tests._support.hostile import assert_one_line_error, record_child, run

FAST = ["--quiet", "--no-analyze"]


def _timed(argv, capsys) -> tuple[int, str, float]:
    t0 = time.monotonic()
    code, _, err = run(argv, capsys)
    return code, err, time.monotonic() - t0


# ---------------------------------------------------------------------- the slow drip
@pytest.mark.heavy
def test_headers_dripped_a_byte_at_a_time_end_at_the_deadline(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(drip="headers", drip_path="/config", drip_s=0.5)) as phone:
        code, err, took = _timed(["record", phone.url, "--out", out, *FAST, "--timeout", "1"],
                                 capsys)
    # deadline of /config: 3 × 1 s + 1 s per MB of its 4 MB limit = 7 s, not retried
    assert_one_line_error(code, err, match="/config did not answer within 7 s")
    assert took < 20, took
    assert not out.exists()


@pytest.mark.heavy
def test_a_body_dripped_during_the_recording_keeps_the_samples(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, drip="body", drip_at=5.0, drip_s=0.5)) as phone:
        code, err, took = _timed(["record", phone.url, "--out", out, *FAST, "--timeout", "1",
                                  "--duration", "20"], capsys)
    line = assert_one_line_error(code, err, match="/get did not answer within")
    assert "kept in" in line and took < 30, (line, took)
    rec = read(out / "recording.csv")
    assert rec.time[-1] >= 2.0  # what arrived before the drip (4 polls a second, 10× speed)
    meta = json.loads((out / "recording.json").read_text())
    assert meta["stopped_by"] == "connection lost"


# ---------------------------------------------------------------------- the clock jump
@pytest.mark.parametrize("jump", [1e9, 1e17])
def test_the_detector_treats_a_clock_jump_as_one_gap(jump):
    d = L.Detector()
    t = np.concatenate([np.arange(0, 2, 0.002), [0.002 + jump], jump + np.arange(1, 5) * 0.002])
    done = threading.Event()
    worker = threading.Thread(target=lambda: (d.feed(t, np.zeros((t.size, 3))), done.set()),
                              daemon=True)
    worker.start()
    assert done.wait(30), "Detector.feed hung on a clock jump"
    assert d.gaps == 1 and d.largest_gap == pytest.approx(jump, rel=1e-6)
    assert d.elapsed == t[-1]


def test_a_clock_jump_ends_the_recording_with_the_samples_before_it(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, jump_at=5.0, jump_by=1e9)) as phone:
        code, err, took = _timed(["record", phone.url, "--out", out, *FAST, "--timeout", "2",
                                  "--duration", "30"], capsys)
    line = assert_one_line_error(code, err, match="the phone's clock jumped by 1e+09 s")
    assert "kept in" in line and took < 30
    rec = read(out / "recording.csv")
    assert 4.0 <= rec.time[-1] <= 5.0 + 1e-6
    meta = json.loads((out / "recording.json").read_text())
    assert meta["stopped_by"] == "clock jump" and meta["clock_gaps"]["count"] >= 1


# ------------------------------------------------------------------ the dense /get
def test_a_dense_get_answer_stays_under_300_mb(tmp_path):
    """1.2 M values per buffer of ``1e0,`` (4 bytes a value; the default duration's limit):
    parsed without a Python float per value; more values than the limit are refused."""
    from dampfit.record.phyphox import AccelInput

    rows = int(DEFAULT_DURATION * MAX_RATE_HZ)
    with FakePhone(Quirks(dense=rows, measuring_at_connect=True)) as phone:
        lay = phone.layout["outputs"]
        accel = AccelInput("linear_acceleration", lay["t"], lay["x"], lay["y"], lay["z"])
        client = PhyphoxClient(phone.url, timeout=30, retries=0)
        body = phone.dense_answer()
        assert len(body) / (4 * rows) < 6  # bytes per value: 4 of x, y, z (the times are longer)
        tracemalloc.start()
        try:
            chunk = client.get(accel, None, 4 * rows * 16 + 2**16, values=4 * rows + 64)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert chunk.x.size == rows and np.all(chunk.x == 1.0)
        assert peak < 300 * 2**20, f"{peak / 2**20:.0f} MB"
        with pytest.raises(NotPhyphox, match="more than the 4000 values expected"):
            client.get(accel, None, 4 * rows * 16, values=4000)


# ----------------------------------------------------------------------- /meta values
@pytest.mark.parametrize("key,value", [("Resolution", "1e308"), ("Range", "1e308"),
                                       ("MinDelay", "1e300"), ("Resolution", "-1")])
def test_meta_values_out_of_range_are_dropped(key, value):
    sensor = {"Name": "S", "Range": "78.4", "Resolution": "0.0012", "MinDelay": "2000", key: value}
    _, info = parse_meta({"sensors": {"linear_acceleration": sensor}}, "linear_acceleration")
    ours = {"Resolution": "resolution", "Range": "range", "MinDelay": "min_delay_us"}[key]
    assert info[ours] is None


@pytest.mark.heavy
def test_a_resolution_of_1e308_records_and_analyses(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=40.0, meta_values={"Resolution": "1e308"})) as phone:
        code, _, err = run(["record", phone.url, "--out", out, "--quiet", "--duration", "30",
                            "--max-steps", "1500"], capsys)
    assert code == 0, err
    meta = json.loads((out / "recording.json").read_text())
    assert meta["sensor"]["resolution"] is None
    assert (out / "summary.json").is_file()


# ------------------------------------------------------------------ SIGTERM, kill -9


def test_sigterm_says_exactly_what_is_kept(tmp_path):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=4.0)) as phone:
        _, err = stop_after(phone, record_child(phone.url, out), signal.SIGTERM, gets=4,
                            settle_s=1.2)  # the journal syncs at least every second
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("dampfit: terminated; the recording so far "
                                                   "is kept:"), err
    assert "no partial output" not in err and str(out / "recording.csv") in lines[0]
    assert read(out / "recording.csv").time.size > 1000


def test_kill_9_keeps_the_samples_streamed_to_disk(tmp_path):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=4.0)) as phone:
        when, _ = stop_after(phone, record_child(phone.url, out), signal.SIGKILL, gets=4,
                             settle_s=1.2)
        truth_t, truth_a = phone.t, phone.a
    assert not (out / "recording.csv").exists()
    rec = read(out / "recording.partial.csv")
    assert rec.time[-1] >= when - 3.0
    i = np.searchsorted(truth_t, rec.time - 1e-6)
    np.testing.assert_allclose(rec.accel, truth_a[i], rtol=1e-7, atol=1e-12)
    assert np.all(np.diff(rec.time) > 0)


# -------------------------------------------------------------- --experiment --force
def test_experiment_force_replaces_only_what_dampfit_wrote(tmp_path, capsys):
    mine = tmp_path / "notes.phyphox"
    mine.write_text("my own notes, not an experiment")
    code, _, err = run(["record", "--experiment", mine, "--force"], capsys)
    assert_one_line_error(code, err, match="not a file dampfit's --experiment wrote")
    assert mine.read_text() == "my own notes, not an experiment"
    ours = tmp_path / "decay.phyphox"
    assert run(["record", "--experiment", ours], capsys)[0] == 0
    ours.write_bytes(ours.read_bytes().replace(b"1.14", b"1.13"))  # an older dampfit's file
    code, _, err = run(["record", "--experiment", ours, "--force"], capsys)
    assert code == 0, err
    from dampfit.record.experiment import experiment_bytes
    assert ours.read_bytes() == experiment_bytes()
