"""``dampfit record`` end to end against the fake phyphox phone (:mod:`tests._support.fake_phyphox`).

The phone replays a decay simulated by dampfit in accelerated time; each quirk of the real
server is switched on in turn. Every failure must be one line, exit 2, with the samples
already recorded kept in DIR/recording.csv (or nothing written when nothing was recorded).
"""

from __future__ import annotations

import io
import json
import re
import shlex
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit.files.folder import MARKER
from dampfit.io.readers import read
from tests._support.fake_phyphox import FakePhone, Quirks, stop_after
from tests._support.hostile import assert_one_line_error, record_child, run

FAST = ["--quiet", "--no-analyze", "--timeout", "2"]


def record(phone, out, capsys, *extra) -> tuple[int, str, str]:
    return run(["record", phone.url, "--out", out, *extra], capsys)


def recording(out: Path) -> tuple:
    """The recording in ``out``: (Recording read back by dampfit, recording.json)."""
    return read(out / "recording.csv"), json.loads((out / "recording.json").read_text())


def assert_matches_phone(rec, phone) -> None:
    """Every sample kept is a sample of the simulated decay, to phyphox's 8 digits."""
    i = np.searchsorted(phone.t, rec.time - 1e-6)
    np.testing.assert_allclose(rec.time, phone.t[i], rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(rec.accel, phone.a[i], rtol=1e-7, atol=1e-12)


def no_staging_left(out: Path) -> None:
    assert not [p for p in out.parent.iterdir() if ".dampfit-" in p.name], \
        list(out.parent.iterdir())


# ------------------------------------------------------------------------ done when
@pytest.mark.heavy
def test_record_then_analyse_recovers_c(tmp_path, capsys):
    out = tmp_path / "decay"
    with FakePhone(Quirks(speed=20.0)) as phone:
        code, stdout, err = record(phone, out, capsys, "--mass", "5.3", "--duration", "40",
                                   "--no-figures", "--quiet")
        assert code == 0, err
        assert {c for _, c in phone.requests} == {"close"}, "phyphox must not be kept alive"
    rec, meta = recording(out)
    assert rec.format == "phyphox-csv" and rec.duration == pytest.approx(40.0, abs=0.05)
    assert_matches_phone(rec, phone)
    summary = json.loads((out / "summary.json").read_text())
    c = summary["parameters"]["c"]
    assert c["q05"] <= phone.truth["c"] <= c["q95"]
    assert summary["input"]["path"] == str((out / "recording.csv").resolve())
    assert any("sensor resolution 0.0012 m/s²" in n for n in summary["input"]["notes"])
    assert {"summary.json", "posterior.nc", "signals.npz", "recording.csv", "recording.json",
            MARKER} <= {p.name for p in out.iterdir()}
    assert meta["url"] == phone.url and meta["phone"]["model"] == "Pixel Fake"
    assert meta["sensor"]["type"] == "linear_acceleration"
    assert meta["sensor"]["resolution"] == 0.0012 and meta["sensor"]["range"] == 78.45346
    assert meta["sample_rate_hz"] == pytest.approx(500, rel=0.01)
    assert meta["stopped_by"] == "duration" and meta["dampfit_version"]
    assert meta["start_time"].startswith(time.strftime("%Y", time.gmtime()))
    assert abs(meta["release_time_s"] - phone.truth["t_release"]) <= 1.0
    assert "c      [N s/m]" in stdout
    no_staging_left(out)
    # and dampfit analyze reads the recording as it is
    assert run(["analyze", out / "recording.csv", "--mass", "5.3", "--out", tmp_path / "again",
                "--quiet", "--no-figures", "--max-steps", "200"], capsys)[0] == 0


# ------------------------------------------------------------------------- quirks
def test_unequal_lengths_nulls_and_8_digits_lose_nothing_else(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=40.0, unequal=True, nulls=0.01)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "20")
    assert code == 0, err
    rec, meta = recording(out)
    assert_matches_phone(rec, phone)
    expected = int(np.searchsorted(phone.t, 20.0, side="right"))
    # rows with a null are dropped (≈ 4 % of rows: 1 % per column), nothing else
    assert 0.93 * expected <= rec.n_samples <= expected
    assert meta["dropped"]["missing_values"] > 0 and meta["dropped"]["time_not_increasing"] == 0
    assert meta["data"] == "full buffers fetched after the stop"


def test_polled_samples_with_unequal_lengths_are_complete(tmp_path, capsys):
    """Without the final full fetch (the connection drops after the stop), the polled
    samples alone are the recording: unequal answers were cut and fetched again."""
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=20.0, unequal=True, drop_at=12.0)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "30")
    line = assert_one_line_error(code, err, match="no answer from phyphox")
    assert "kept in" in line and "recording.csv" in line
    rec, meta = recording(out)
    assert meta["dropped"]["unequal_lengths"] > 0 and meta["data"] == "polled samples"
    n = int(np.searchsorted(phone.t, rec.time[-1] + 1e-6))  # the time has 8 digits
    assert rec.n_samples == n, "no sample between the first and the last is missing"
    assert_matches_phone(rec, phone)


def test_stop_pressed_on_the_phone_ends_the_recording(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=40.0, stop_at=12.0)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "40")
    assert code == 0, err
    rec, meta = recording(out)
    assert meta["stopped_by"] == "stopped on the phone"
    assert rec.time[-1] == pytest.approx(12.0, abs=0.01)


def test_a_changed_session_is_refused_and_the_first_kept(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=20.0, session_change_at=10.0)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "40")
        controls = [p for p, _ in phone.requests if p.startswith("/control")]
    line = assert_one_line_error(code, err, match="session changed")
    assert "refusing to mix" in line and "kept in" in line
    rec, meta = recording(out)
    assert meta["stopped_by"] == "session changed" and rec.time[-1] <= 10.0
    assert_matches_phone(rec, phone)
    assert controls == ["/control?cmd=clear", "/control?cmd=start"], "the new session is not touched"


@pytest.mark.heavy
@pytest.mark.parametrize("quirk,match", [
    ({"drop_at": 8.0}, "the connection was closed without an answer"),
    ({"refuse_at": 8.0}, "connection refused"),
])
def test_a_dropped_connection_is_retried_then_stops_keeping_the_data(tmp_path, capsys, quirk,
                                                                     match):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, **quirk)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "30")
        gets_after = phone.count("/get")
    line = assert_one_line_error(code, err, match=match)
    assert "5 attempts" in line and "analyse them with: dampfit analyze" in line
    rec, meta = recording(out)
    # the last poll before the drop came at most one poll (0.25 s wall = 2.5 s here) earlier
    assert 5.0 <= rec.time[-1] <= 8.0 and meta["stopped_by"] == "connection lost"
    assert gets_after >= 5


def test_a_flaky_connection_is_retried_and_recovers(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, flaky_at=5.0, flaky=3)) as phone:
        # the answer after the outage carries the ~17 s of phone time missed (the fake phone
        # formats it slowly): a timeout long enough for it
        code, _, err = record(phone, out, capsys, "--quiet", "--no-analyze", "--timeout", "3",
                              "--duration", "15")
    assert code == 0, err
    rec, meta = recording(out)
    assert meta["stopped_by"] == "duration" and rec.duration == pytest.approx(15.0, abs=0.05)
    assert_matches_phone(rec, phone)


def test_a_hanging_phone_times_out(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, hang_at=8.0, hang=3.0)) as phone:
        code, _, err = record(phone, out, capsys, "--quiet", "--no-analyze", "--timeout", "0.2",
                              "--duration", "30")
    assert_one_line_error(code, err, match="timed out, 5 attempts")
    assert recording(out)[0].time[-1] >= 2.0


@pytest.mark.parametrize("garbage,match", [
    ("get-text", "/get answered something that is not JSON"),
    ("get-shape", "/get did not answer like phyphox"),
])
def test_garbage_during_the_recording_keeps_the_data(tmp_path, capsys, garbage, match):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0, garbage=garbage, garbage_at=8.0)) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "30")
    assert "kept in" in assert_one_line_error(code, err, match=match)
    rec, meta = recording(out)
    # what arrived before the garbage is kept (how much depends on the polling pace under load)
    assert meta["stopped_by"] == "garbage" and rec.time[-1] >= 2.0
    assert_matches_phone(rec, phone)


@pytest.mark.parametrize("quirks,match", [
    (Quirks(garbage="html"), "/config answered something that is not JSON"),
    (Quirks(garbage="404"), "/config answered HTTP 404"),
    (Quirks(garbage="no-accel"), "has no accelerometer"),
    (Quirks(start_refused=True), "refused to start the measurement"),
    (Quirks(measuring_at_connect=True), "already measuring; press stop on the phone"),
])
def test_refusals_before_any_sample_write_nothing(tmp_path, capsys, quirks, match):
    out = tmp_path / "r"
    with FakePhone(quirks) as phone:
        code, _, err = record(phone, out, capsys, *FAST)
        controls = [p for p, _ in phone.requests if p.startswith("/control")]
    assert_one_line_error(code, err, match=match)
    assert not out.exists()
    no_staging_left(out)
    if quirks.measuring_at_connect:
        assert controls == [], "a phone in use is not cleared"


@pytest.mark.parametrize("scheme", ["https://{}", "ftp://{}", "file:///{}", "{}"])
def test_a_url_that_is_not_http_is_refused_before_any_request(tmp_path, capsys, scheme):
    with FakePhone() as phone:
        url = scheme.format(phone.url.removeprefix("http://"))
        code, _, err = run(["record", url, "--out", tmp_path / "r"], capsys)
        assert phone.requests == []
    assert_one_line_error(code, err, match="only http:// URLs are accepted")
    assert not (tmp_path / "r").exists()


def test_ios_meta_and_other_buffer_names_with_g(tmp_path, capsys):
    """iOS serves no sensor metadata; an experiment with g and its own buffer names is found
    from /config."""
    cfg = sim.preset("phone", duration=30.0, catch=False, seed=2)
    q = Quirks(speed=40.0, ios=True, names=("acc_time", "accX", "accY", "accZ"))
    out = tmp_path / "r"
    with FakePhone(q, cfg) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "20")
    assert code == 0, err
    rec, meta = recording(out)
    assert rec.gravity_removed is False and meta["sensor"]["type"] == "accelerometer"
    assert meta["buffers"] == {"time": "acc_time", "x": "accX", "y": "accY", "z": "accZ"}
    assert meta["sensor"].get("resolution") is None
    assert not any("resolution" in n for n in meta["notes"])
    assert (out / "recording.csv").read_text().startswith('"Time (s)","Acceleration x (m/s^2)"')
    assert_matches_phone(rec, phone)


def test_the_end_of_the_decay_stops_the_recording(tmp_path, capsys):
    cfg = sim.from_modal(5.3, 1.72, 0.03, u0=0.04, duration=60.0, handheld=3.0, seed=2)
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=10.0), cfg) as phone:
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "60")
    assert code == 0, err
    rec, meta = recording(out)
    assert meta["stopped_by"] == "end of the decay" and rec.time[-1] < 50.0
    assert meta["decay_end_time_s"] is not None and meta["release_time_s"] == pytest.approx(
        3.0, abs=1.0)


# -------------------------------------------------------------------- live line, signals
class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_live_line_on_a_terminal(tmp_path, capsys, monkeypatch):
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with FakePhone(Quirks(speed=4.0)) as phone:
        code = run(["record", phone.url, "--out", tmp_path / "r", "--no-analyze",
                    "--duration", "8"], capsys)[0]
    text = term.getvalue()
    monkeypatch.undo()
    assert code == 0, text
    updates = text.split("\r")
    assert len(updates) >= 4 and "waiting for the release" in text and "decaying" in text
    assert any("amplitude" in u and " s " in u for u in updates)
    assert text.endswith("\n") and "stopped (duration)" in text.splitlines()[-1]
    # not a terminal: only the final line; --quiet: nothing
    with FakePhone(Quirks(speed=40.0)) as phone:
        _, _, err = run(["record", phone.url, "--out", tmp_path / "p", "--no-analyze",
                         "--duration", "4"], capsys)
        _, _, quiet = run(["record", phone.url, "--out", tmp_path / "q", "--no-analyze",
                           "--duration", "4", "--quiet"], capsys)
    assert err.count("\n") == 1 and "\r" not in err and "kept in" in err
    assert quiet == ""




@pytest.mark.parametrize("sig,code,stopped", [(signal.SIGINT, 0, "interrupted"),
                                              (signal.SIGTERM, 143, "terminated")])
def test_ctrl_c_and_sigterm_keep_what_was_recorded(tmp_path, sig, code, stopped):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=4.0)) as phone:
        proc = record_child(phone.url, out)
        at, err = stop_after(phone, proc, sig)
    assert proc.returncode == code, err
    assert "Traceback" not in err
    rec, meta = recording(out)
    assert meta["stopped_by"] == stopped
    assert at - 1.5 <= rec.time[-1] <= at + 3.0
    no_staging_left(out)


# ------------------------------------------------------------------ the result folder
def test_result_folder_rules_before_the_phone_is_touched(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=40.0)) as phone:
        assert record(phone, out, capsys, *FAST, "--duration", "4")[0] == 0
        before = (out / "recording.csv").read_bytes()
        n = len(phone.requests)
        code, _, err = record(phone, out, capsys, *FAST, "--duration", "4")
        assert_one_line_error(code, err, match="exists; use --force")
        assert len(phone.requests) == n and (out / "recording.csv").read_bytes() == before
        foreign = tmp_path / "mine"
        foreign.mkdir()
        (foreign / "notes.txt").write_text("mine")
        code, _, err = record(phone, foreign, capsys, *FAST, "--force")
        assert_one_line_error(code, err, match="not written by dampfit")
        assert len(phone.requests) == n
        assert record(phone, out, capsys, *FAST, "--duration", "6", "--force")[0] == 0
    assert recording(out)[0].duration == pytest.approx(6.0, abs=0.05)
    no_staging_left(out)


def test_a_second_run_to_the_same_folder_fails_at_once(tmp_path, capsys):
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=2.0)) as slow, FakePhone(Quirks(speed=40.0)) as other:
        first = threading.Thread(target=lambda: run(
            ["record", slow.url, "--out", out, *FAST, "--duration", "6"], capsys))
        first.start()
        deadline = time.monotonic() + 30
        while slow.count("/get") < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        code, _, err = run(["record", other.url, "--out", out, *FAST, "--force"], capsys)
        first.join(60)
        assert other.requests == [], "the second run never touched its phone"
    assert_one_line_error(code, err, match="is being written by another dampfit process")
    assert recording(out)[0].duration == pytest.approx(6.0, abs=0.05)


def test_a_failed_analysis_keeps_the_recording(tmp_path, capsys, monkeypatch):
    import dampfit.cli.analyze as analyze_cli
    from dampfit.errors import InputError

    def fail(args, folder, figs, path, **kw):
        (folder.stage / "summary.json").write_text("{half")
        raise InputError("no oscillation found")

    monkeypatch.setattr(analyze_cli, "analyse_into", fail)
    out = tmp_path / "r"
    with FakePhone(Quirks(speed=40.0)) as phone:
        code, _, err = record(phone, out, capsys, "--no-figures", "--duration", "5")
    line = assert_one_line_error(code, err, match="no oscillation found")  # one line, not two
    assert "the recording is kept in" in line
    assert {p.name for p in out.iterdir()} == {MARKER, "recording.csv", "recording.json"}
    assert recording(out)[0].duration == pytest.approx(5.0, abs=0.05)
    no_staging_left(out)


@pytest.mark.heavy
def test_the_report_of_a_record_folder_gives_a_command_that_works(tmp_path, capsys):
    """A record folder holds its own recording, so its report cannot say ``dampfit analyze
    DIR/recording.csv … --out DIR`` (analyze refuses an --out that holds its input, and
    replacing the folder would lose the recording): the command it prints re-analyses the
    recording into a folder beside it, and running it gives the same numbers."""
    out = tmp_path / "decay"
    with FakePhone(Quirks(speed=40.0)) as phone:
        code, _, err = record(phone, out, capsys, "--mass", "5.3", "--duration", "20",
                              "--max-steps", "300", "--model", "viscous", "--no-figures", "--quiet", "--report",
                              "--timeout", "2")
    assert code == 0, err
    md = (out / "report.md").read_text(encoding="utf-8")
    section = md.split("## How to reproduce and cite", 1)[1]
    assert "This folder holds its own recording (dampfit record wrote it)" in section
    args = shlex.split(re.search(r"```bash\n(dampfit analyze .*?)\n```", section).group(1))
    again = Path(args[args.index("--out") + 1])
    assert args[2] == str((out / "recording.csv").resolve())
    assert again == out.resolve().parent / "decay.reanalysed" and not again.exists()
    # what the report used to print is refused, and the record folder is kept whole
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    code, _, err = run(args[1:args.index("--out")] + ["--out", out, "--force"], capsys)
    assert_one_line_error(code, err, match="holds the input")
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    # the printed command runs as printed (no figures, to keep the test short)
    code, _, err = run(args[1:] + ["--no-figures"], capsys)
    assert code == 0, err
    first = json.loads((out / "summary.json").read_text())
    second = json.loads((again / "summary.json").read_text())
    assert second["input"]["sha256"] == first["input"]["sha256"]
    assert second["parameters"] == first["parameters"]
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    # the commands of the sections not computed go there too, never into the record folder
    for cmd in re.findall(r"```bash\n(dampfit analyze .*?)\n```", md):
        words = shlex.split(cmd)
        assert Path(words[words.index("--out") + 1]) == again, cmd


# ------------------------------------------------------------------------ options
def test_experiment_option_and_usage_errors(tmp_path, capsys):
    path = tmp_path / "dampfit-decay.phyphox"
    code, stdout, _ = run(["record", "--experiment", path], capsys)
    assert code == 0 and path.is_file()
    assert "open it on the phone" in stdout and "Allow remote access" in stdout
    for argv, match in [
        (["record", "--experiment", path], "exists; use --force"),
        (["record", "http://127.0.0.1:9", "--experiment", tmp_path / "x.phyphox"],
         "either URL"),
        (["record", "--out", tmp_path / "r"], "no URL given"),
        (["record", "http://127.0.0.1:9"], "--out is required"),
        (["record", "http://127.0.0.1:9", "--out", tmp_path / "r", "--duration", "0"],
         "--duration: must be a positive duration"),
        (["record", "http://127.0.0.1:9", "--out", tmp_path / "r", "--duration", "7200"],
         "at most 1800"),
        (["record", "http://127.0.0.1:9", "--out", tmp_path / "r", "--timeout", "nan"],
         "--timeout: must be a timeout"),
        (["record", "http://127.0.0.1:9", "--out", tmp_path / "r", "--window", "5", "1"],
         "--window: END must come after"),
    ]:
        code, _, err = run(argv, capsys)
        assert_one_line_error(code, err, match=match)
    assert not (tmp_path / "r").exists()
