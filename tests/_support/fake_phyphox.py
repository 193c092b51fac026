"""A fake phone running phyphox with remote access, for the tests of ``dampfit record``.

:class:`FakePhone` serves phyphox's remote-access API (``/config``, ``/meta``, ``/time``,
``/control``, ``/get``; shapes as in phyphox-docs ``openapi.yaml`` and the Android
``RemoteServer.java``, see :mod:`dampfit.record.phyphox`) with the standard library's
``http.server`` on 127.0.0.1, port 0, in a daemon thread. Its experiment is dampfit's shipped
``dampfit-decay.phyphox`` (buffers, sensor and export read from the XML), or one with other
buffer names; its data is a decay simulated by :mod:`dampfit.simulate`, replayed in
accelerated time: while measuring, the phone clock runs ``speed`` times faster than the wall
clock and ``/get`` sees the simulated samples up to it.

Every quirk of the real server can be switched on through :class:`Quirks`: numbers in 8
significant digits (Java ``0.#######E0``; always on), the threshold nudge, NaN as null,
buffers of unequal length, measuring switching to false (stop pressed on the phone), a
changed session id, connections dropped (closed without an answer) or refused, flaky
connections that recover, hanging answers, a server that is not phyphox or answers garbage,
start refused, already measuring, iOS-like ``/meta`` without sensors; and hostile ones: an
answer dripped a byte at a time (headers or body; it stops by itself after
:data:`DRIP_MAX_S`), a jump of the phone's clock, a ``/get`` answer as dense as JSON allows,
``/meta`` values out of range. It listens on 127.0.0.1 only. Every request's path and
``Connection`` header are logged (phyphox must not be kept alive).

Run it by hand: ``python tests/_support/fake_phyphox.py [SPEED]`` serves until Ctrl-C.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
import xml.etree.ElementTree as ET
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

import numpy as np

from dampfit import simulate as sim
from dampfit.record.experiment import experiment_bytes


@dataclasses.dataclass
class Quirks:
    """Switches of the fake phone; times [s] are phone (experiment) time."""

    speed: float = 10.0            # phone seconds per wall second
    unequal: bool = False          # buffers of one /get answer differ in length
    nulls: float = 0.0             # fraction of values sent as null
    stop_at: float | None = None   # the user presses stop on the phone
    session_change_at: float | None = None  # the experiment is restarted (new session id)
    drop_at: float | None = None   # from then on connections close without an answer
    refuse_at: float | None = None  # from then on the server stops listening
    flaky_at: float | None = None  # from then on the next `flaky` requests are dropped
    flaky: int = 0
    hang_at: float | None = None   # from then on /get answers only after `hang` wall seconds
    hang: float = 0.0
    garbage: str | None = None     # "html", "404", "get-text", "get-shape", "no-accel"
    garbage_at: float = 0.0        # phone time from which /get answers garbage
    start_refused: bool = False
    measuring_at_connect: bool = False
    ios: bool = False              # /meta without sensors, nulls for missing values
    resolution: float | None = 0.0012  # [m/s²] reported in /meta
    names: tuple[str, str, str, str] | None = None  # other buffer names (t, x, y, z)
    seed: int = 0
    # hostile servers (tests/cli/test_hostile_record.py)
    drip: str | None = None        # "headers" or "body": the answer sent a byte at a time
    drip_path: str = "/get"        # the endpoint that drips
    drip_at: float = 0.0           # phone time from which it drips
    drip_s: float = 0.25           # wall seconds per byte; a drip ends by itself after DRIP_MAX_S
    jump_at: float | None = None   # the phone's clock jumps by `jump_by` after this time [s]
    jump_by: float = 1e9
    dense: int = 0                 # /get answers this many values per buffer, as dense as JSON allows
    meta_values: dict | None = None  # /meta sensor entries replaced (e.g. {"Resolution": "1e308"})


def java_number(v: float) -> str:
    """``v`` as phyphox writes it: Java ``DecimalFormat("0.#######E0")``, 8 significant digits."""
    if v == 0:
        return "0E0"
    mant, exp = f"{v:.7E}".split("E")
    mant = mant.rstrip("0").rstrip(".")
    return f"{mant}E{int(exp)}"


def experiment_layout(names=None) -> dict:
    """Sensor, buffers and export set of the shipped experiment (optionally renamed)."""
    root = ET.fromstring(experiment_bytes())
    sensor = root.find("input/sensor")
    outputs = {o.get("component"): o.text for o in sensor.findall("output")}
    containers = [c.text for c in root.findall("data-containers/container")]
    export = [{"set": s.get("name"), "sources": [{"label": d.get("name"), "buffer": d.text}
                                                 for d in s.findall("data")]}
              for s in root.findall("export/set")]
    if names is not None:
        rename = dict(zip((outputs["t"], outputs["x"], outputs["y"], outputs["z"]), names))
        outputs = {k: rename.get(v, v) for k, v in outputs.items()}
        containers = [rename.get(c, c) for c in containers]
        for s in export:
            for src in s["sources"]:
                src["buffer"] = rename.get(src["buffer"], src["buffer"])
    return {"sensor": sensor.get("type"), "outputs": outputs, "containers": containers,
            "export": export, "title": root.findtext("title")}


#: Longest drip [wall s]: a dripping answer stops by itself (the fake server is bounded).
DRIP_MAX_S = 30.0


class FakePhone:
    """The fake phone; use as a context manager (``with FakePhone(...) as phone: phone.url``)."""

    def __init__(self, quirks: Quirks | None = None, config: sim.SimulationConfig | None = None):
        self.q = quirks or Quirks()
        self.cfg = config or sim.preset("paper", duration=45.0, seed=11)
        rec, self.truth = sim.recording(self.cfg)
        self.t, self.a = rec.time, rec.accel
        self.t_sent = self.t.copy()  # the phone's time stamps as served (a clock jump)
        if self.q.jump_at is not None:
            self.t_sent[self.t > self.q.jump_at] += self.q.jump_by
        self.layout = experiment_layout(self.q.names)
        if self.cfg.gravity:
            self.layout["sensor"] = "accelerometer"
        self.lock = threading.Lock()
        self.rng = np.random.default_rng(self.q.seed)
        self.requests: list[tuple[str, str | None]] = []
        self.measuring = self.q.measuring_at_connect
        self.session = "a1b2c3"
        self.offset = 0.0          # phone time accumulated before the current run [s]
        self.wall0 = time.monotonic()
        self.start_wall_epoch: float | None = time.time() if self.measuring else None
        self.flaky_left = self.q.flaky
        self.server: ThreadingHTTPServer | None = None

    # ------------------------------------------------------------- clock
    def phone_time(self) -> float:
        """The phone's experiment time [s] (stop and session quirks applied)."""
        with self.lock:
            return self._phone_time()

    def _phone_time(self) -> float:
        te = self.offset + ((time.monotonic() - self.wall0) * self.q.speed if self.measuring else 0.0)
        if self.q.stop_at is not None and self.measuring and te >= self.q.stop_at:
            self.measuring, self.offset = False, self.q.stop_at
            te = self.offset
        if self.q.session_change_at is not None and te >= self.q.session_change_at \
                and self.session == "a1b2c3":
            self.session = "d4e5f6"  # restarted: a new session, measuring again from 0
            self.offset, self.wall0 = 0.0, time.monotonic()
            te = 0.0
        return min(te, float(self.t[-1]) + 1.0)

    def buffers(self) -> dict[str, np.ndarray]:
        """The buffers as they are now (the samples up to the phone time)."""
        te = self._phone_time()
        n = int(np.searchsorted(self.t, te, side="right")) if self.start_wall_epoch else 0
        o = self.layout["outputs"]
        return {o["t"]: self.t_sent[:n], o["x"]: self.a[:n, 0], o["y"]: self.a[:n, 1],
                o["z"]: self.a[:n, 2]}

    # ------------------------------------------------------------ server
    def __enter__(self) -> "FakePhone":
        phone = self

        class Handler(_Handler):
            pass

        Handler.phone = phone
        self.server = _Server(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.server is not None:
            self.server.shutdown()
            self.server.server_close()
            self.server = None

    def count(self, endpoint: str) -> int:
        """How many requests went to ``endpoint`` (e.g. "/get")."""
        with self.lock:
            return sum(1 for path, _ in self.requests if path.split("?")[0] == endpoint)

    # ---------------------------------------------------------- answers
    def config(self) -> dict:
        lay = self.layout
        outputs = [{c: lay["outputs"][c]} for c in ("x", "y", "z", "t") if c in lay["outputs"]]
        source = "gyroscope" if self.q.garbage == "no-accel" else lay["sensor"]
        return {"crc32": "1f2e3d4c", "title": lay["title"], "localTitle": lay["title"],
                "category": "dampfit", "localCategory": "dampfit",
                "buffers": [{"name": c, "size": 0} for c in lay["containers"]],
                "inputs": [{"source": source, "outputs": outputs}], "export": lay["export"]}

    def meta(self) -> dict:
        device = {"version": "1.2.1", "build": "1020102", "fileFormat": "1.20",
                  "deviceModel": "Pixel Fake", "deviceBrand": "google",
                  "deviceManufacturer": "Google", "deviceRelease": "14"}
        if self.q.ios:
            device.update(deviceBoard=None, deviceBaseOS=None)
            return device
        res = None if self.q.resolution is None else repr(self.q.resolution)
        sensor = {"Name": "Fake LSM6DSO", "Vendor": "ST", "Range": "78.45346",
                  "Resolution": res, "MinDelay": "2000", "MaxDelay": "1000000",
                  "Power": "0.17", "Version": "1"}
        sensor.update(self.q.meta_values or {})
        device["sensors"] = {self.layout["sensor"]: {k: v for k, v in sensor.items() if v}}
        return device

    def get(self, pairs) -> tuple[int, dict]:
        bufs = self.buffers()
        out = {}
        ragged = self.q.unequal and self.measuring
        for name, value in pairs:
            if name not in bufs:
                continue
            data = bufs[name]
            if value == "":
                vals, mode = data[-1:], "single"
            elif value == "full":
                vals, mode = data, "full"
            else:
                thr, _, ref = value.partition("|")
                try:
                    thr = float(thr)
                except ValueError:
                    return 400, {"error": "Invalid threshold."}
                ref = ref or name
                if ref not in bufs:
                    return 400, {"error": "Unknown reference buffer."}
                if thr != 0 and math.isfinite(thr):  # phyphox's nudge in the 8th digit
                    thr += 10.0 ** math.floor(math.log10(abs(thr) / 1e7))
                keep = ~(bufs[ref] <= thr)
                vals, mode = data[keep[:data.size]], "partial"
            if ragged and mode != "single" and vals.size and self.rng.random() < 0.5:
                vals = vals[:max(vals.size - int(self.rng.integers(1, 4)), 0)]
            out[name] = {"size": 0, "updateMode": mode, "buffer": self._encode(vals)}
        status = {"session": self.session, "measuring": self.measuring, "timedRun": False,
                  "countDown": 0}
        return 200, {"buffer": out, "status": status}

    def dense_answer(self) -> bytes:
        """A /get answer of ``dense`` values per buffer, each ``1e0`` (4 bytes with its comma:
        as dense as a JSON float gets), times increasing in 8 digits."""
        if getattr(self, "_dense", None) is not None:
            return self._dense
        n, o = self.q.dense, self.layout["outputs"]
        ones = b",".join([b"1e0"] * n)
        times = b",".join(java_number(0.001 * (i + 1)).encode() for i in range(n))
        parts = [b'"%s":{"size":0,"updateMode":"partial","buffer":[%s]}'
                 % (o[c].encode(), times if c == "t" else ones) for c in ("t", "x", "y", "z")]
        status = json.dumps({"session": self.session, "measuring": self.measuring,
                             "timedRun": False, "countDown": 0}).encode()
        self._dense = b'{"buffer":{' + b",".join(parts) + b'},"status":' + status + b"}"
        return self._dense

    def _encode(self, vals: np.ndarray) -> list:
        enc = [java_number(float(v)) for v in vals]
        if self.q.nulls > 0 and enc:
            for i in np.flatnonzero(self.rng.random(len(enc)) < self.q.nulls):
                enc[i] = None
        return enc

    def control(self, cmd: str) -> dict:
        if cmd == "start":
            if self.q.start_refused:
                return {"result": False}
            if not self.measuring:
                self.measuring, self.wall0 = True, time.monotonic()
                self.start_wall_epoch = time.time()
            return {"result": True}
        if cmd == "stop":
            self.offset = self._phone_time()
            self.measuring = False
            return {"result": True}
        if cmd == "clear":
            self.measuring, self.offset, self.start_wall_epoch = False, 0.0, None
            return {"result": True}
        return {"result": False}


class _Server(ThreadingHTTPServer):
    def handle_error(self, request, client_address) -> None:
        pass  # a client that timed out and left: not the test's business


class _Handler(BaseHTTPRequestHandler):
    """Routes requests to the :class:`FakePhone` of its class."""

    phone: FakePhone
    protocol_version = "HTTP/1.1"

    def log_message(self, *args) -> None:  # quiet
        pass

    drip: str | None = None  # set per request by do_GET

    def _send(self, status: int, body: bytes, ctype: str = "application/json") -> None:
        head = (f"HTTP/1.1 {status} OK\r\nContent-Type: {ctype}\r\nContent-Length: {len(body)}"
                "\r\nAccess-Control-Allow-Origin: *\r\n\r\n").encode()
        if self.drip is None:
            self.wfile.write(head + body)
            return
        fast, slow = (b"", head + body) if self.drip == "headers" else (head, body)
        self.wfile.write(fast)
        self.wfile.flush()
        until = time.monotonic() + DRIP_MAX_S
        for i in range(len(slow)):  # a byte at a time, until the client leaves or time is up
            if time.monotonic() > until:
                break
            try:
                self.wfile.write(slow[i:i + 1])
                self.wfile.flush()
            except OSError:
                break
            time.sleep(self.phone.q.drip_s)
        self.close_connection = True

    def _json(self, obj, status: int = 200) -> None:
        # JSON whose numbers are phyphox's strings (8 significant digits), nulls as null
        text = json.dumps(obj)
        self._send(status, _unquote_numbers(text).encode())

    def do_GET(self) -> None:  # noqa: N802 - http.server API
        phone, q = self.phone, self.phone.q
        parts = urlsplit(self.path)
        with phone.lock:
            phone.requests.append((self.path, self.headers.get("Connection")))
            te = phone._phone_time()
            if q.refuse_at is not None and te >= q.refuse_at:
                threading.Thread(target=phone.close, daemon=True).start()
                self.close_connection = True
                return
            if q.drop_at is not None and te >= q.drop_at:
                self.close_connection = True
                return
            if q.flaky_at is not None and te >= q.flaky_at and phone.flaky_left > 0 \
                    and parts.path == "/get":
                phone.flaky_left -= 1
                self.close_connection = True
                return
            hang = q.hang if q.hang_at is not None and te >= q.hang_at and parts.path == "/get" else 0
            self.drip = q.drip if q.drip and parts.path == q.drip_path and te >= q.drip_at else None
        if hang:
            time.sleep(hang)
        if q.garbage == "html":
            self._send(200, b"<html><body>My router</body></html>", "text/html")
            return
        if q.garbage == "404":
            self._send(404, b"not found", "text/plain")
            return
        pairs = parse_qsl(parts.query, keep_blank_values=True)
        with phone.lock:
            answer = self._answer(parts.path, dict(pairs), pairs, te)
        if answer is None:
            self._send(404, b'{"error": "not found"}')
        elif isinstance(answer, bytes):
            self._send(200, answer, "application/json" if answer.startswith(b"{") else "text/plain")
        else:
            self._json(answer[1], answer[0])

    def _answer(self, path, params, pairs, te):
        phone, q = self.phone, self.phone.q
        if path == "/config":
            return 200, phone.config()
        if path == "/meta":
            return 200, phone.meta()
        if path == "/time":
            if phone.start_wall_epoch is None:
                return 200, []
            return 200, [{"event": "START", "experimentTime": 0.0,
                          "systemTime": phone.start_wall_epoch}]
        if path == "/control":
            return 200, phone.control(params.get("cmd", ""))
        if path == "/get":
            if q.garbage == "get-text" and te >= q.garbage_at:
                return b"this is not JSON"
            if q.garbage == "get-shape" and te >= q.garbage_at:
                return 200, {"buffer": 5, "status": "fine"}
            if q.dense and phone.measuring:
                return phone.dense_answer()
            return phone.get(pairs)
        return None


def _unquote_numbers(text: str) -> str:
    """Turn the quoted Java-style numbers json.dumps wrote back into JSON numbers."""
    import re

    return re.sub(r'"(-?\d(?:\.\d+)?E-?\d+)"', r"\1", text)


if __name__ == "__main__":  # pragma: no cover - manual use
    import sys

    speed = float(sys.argv[1]) if len(sys.argv) > 1 else 1.0
    with FakePhone(Quirks(speed=speed)) as phone:
        print(f"fake phyphox at {phone.url} (speed {speed:g}); Ctrl-C to stop", flush=True)
        try:
            threading.Event().wait()
        except KeyboardInterrupt:
            pass


def stop_after(phone, proc, sig, *, at: float = 10.0, gets: int = 3,
               settle_s: float = 0.0) -> tuple[float, str]:
    """Send ``sig`` to the ``dampfit record`` child ``proc`` once ``phone``'s clock has passed
    ``at`` [s] and it has answered ``gets`` /get requests (then ``settle_s`` [s] more); the
    phone time at the signal and the child's stderr. The child is killed if anything fails."""
    try:
        deadline = time.monotonic() + 60
        while phone.phone_time() < at or phone.count("/get") < gets:
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "the recording did not start"
            time.sleep(0.05)
        time.sleep(settle_s)
        when = phone.phone_time()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    return when, err
