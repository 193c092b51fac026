"""The client of phyphox's remote-access HTTP API: a few GET requests, each bounded in time and size.

phyphox (RWTH Aachen; Android and iOS) serves a running experiment over plain HTTP on the local
network when the user switches on "Allow remote access"; the phone shows the address, e.g.
``http://192.168.1.20:8080`` (Android's default port 8080, iOS's 80). The facts this module
relies on, and where they were read:

* **Sources.** The API specification ``docs/remote-interface/openapi.yaml`` (API 1.1.0) of the
  phyphox-docs repository (github.com/phyphox/phyphox-docs), derived there from both apps'
  servers and checked against devices; the Android server itself,
  ``app/src/main/java/de/rwth_aachen/phyphox/RemoteServer.java`` and ``Metadata.java`` of
  github.com/phyphox/phyphox-android; the wiki page "Remote-interface communication"
  (phyphox.org/wiki/index.php/Remote-interface_communication); and, for the no-keep-alive
  quirk, a public client (gist pgaskin/85402391313e868c66618439cbc70e8d) whose author notes
  that keep-alive connections break phyphox.
* **Endpoints** (all GET, no authentication): ``/config`` — the experiment: ``crc32``,
  ``title``, ``buffers`` [{name, size}], ``inputs`` [{source, outputs: [{x: BUFFER}, {y: …},
  {z: …}, {t: …}, …]}] with ``source`` the sensor name of the file format
  (``linear_acceleration`` = acceleration without g, ``accelerometer`` = with g), and
  ``export`` sets; ``/meta`` — device strings (``version``, ``build``, ``deviceModel``,
  ``deviceBrand``, ``deviceManufacturer``, ``deviceRelease``, …) and, on Android only,
  ``sensors`` {sensor name: {Name, Vendor, Range, Resolution, MinDelay, …}} with every value a
  string or null (Android omits a value it cannot supply, iOS sends null; the key set is open);
  ``/time`` — a list of {event: START|PAUSE, experimentTime [s], systemTime [s since 1970]};
  ``/control?cmd=start|stop|clear`` → ``{"result": true|false}`` (start answers false when the
  experiment refuses to start; clear also stops a running measurement); ``/get`` — one query
  parameter per buffer: ``name=full`` (the whole buffer, ``updateMode`` "full"),
  ``name=T`` (the values after the first one above T, "partial") or ``name=T|ref`` (the
  values at the indices where buffer ``ref`` is above T; the ``|`` percent-encoded as %7C),
  answered by ``{"buffer": {name: {size, updateMode, buffer: [...]}}, "status": {session,
  measuring, timedRun, countDown}}``; an unknown buffer name is skipped, not reported.
* **Quirks handled here and in** :mod:`dampfit.record.session`: numbers carry about 8
  significant digits (Java ``DecimalFormat("0.#######E0")``, e.g. ``1.2345678E1``; the server
  nudges a threshold up by one unit in the 8th digit so a value is not sent twice); NaN and
  ±infinity arrive as ``null`` (lossy, and kept in place so buffers still pair by index);
  buffers read in one answer may differ in length (each is copied as filled when the answer is
  built); ``status.session`` changes when the user opens another experiment (data of two
  sessions must not be mixed); ``status.measuring`` turns false when the user presses stop on
  the phone; the server is single-threaded and slow (clients should serialise requests, as the
  bundled web page does) and must not be kept alive: every request here opens its own
  connection and sends ``Connection: close``.

Every request has a timeout (connect and each read) and an overall deadline; an answer larger
than its limit is refused before it is read whole; a connection that fails (refused, reset,
closed without an answer, timed out, HTTP 5xx) is retried with exponential backoff and then
reported as :class:`ConnectionLost`. Only ``http://`` URLs are accepted (:func:`check_url`):
phyphox serves nothing else. A server that is not phyphox, or answers garbage, is a
:class:`NotPhyphox` error naming the endpoint. All errors are one-line
:class:`~dampfit.errors.InputError` s.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import math
import re
import socket
import threading
import time
from dataclasses import dataclass
from urllib.parse import quote, urlsplit

import numpy as np

from dampfit.errors import InputError

#: Sensor names of the file format that are accelerometers, in order of preference: the
#: shipped experiment uses the one without g.
ACCEL_SOURCES = ("linear_acceleration", "accelerometer")
#: Largest answer [bytes] of /config, /meta, /time and /control.
SMALL_ANSWER = 4 * 2**20
#: Longest string [characters] kept from the phone (names, titles, device strings).
MAX_TEXT = 200


class NotPhyphox(InputError):
    """The server does not answer like phyphox's remote access (or answers garbage)."""


class ConnectionLost(InputError):
    """No answer from the phone after the retries."""


def text(value, limit: int = MAX_TEXT) -> str | None:
    """A string from the phone made safe to store and print: printable characters only,
    at most ``limit`` long; None for a missing or non-string value."""
    if not isinstance(value, str):
        return None
    clean = "".join(ch if ch.isprintable() else " " for ch in value).strip()
    return clean[:limit] if clean else None


def check_url(url: str) -> str:
    """The base URL ``http://HOST[:PORT]`` of phyphox's remote access, or a one-line
    :class:`InputError`: only ``http://`` (phyphox serves plain HTTP; https, file, ftp and an
    address without a scheme are refused), no user name or password, no path beyond ``/``,
    no query or fragment, a valid port."""
    shown = text(url, 300) or repr(url)
    if not isinstance(url, str) or any(not ch.isprintable() or ch.isspace() for ch in url):
        raise InputError(f"URL {shown!r}: contains spaces or control characters; give the "
                         "address phyphox shows, e.g. http://192.168.1.20:8080")
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme != "http":
        why = ("phyphox's remote access is plain HTTP, not HTTPS" if scheme == "https" else
               f"the scheme {parts.scheme!r} is not http" if scheme and parts.netloc else
               "it does not start with http://")
        raise InputError(f"URL {shown!r}: only http:// URLs are accepted ({why}); give the "
                         "address phyphox shows, e.g. http://192.168.1.20:8080")
    if "@" in parts.netloc:
        raise InputError(f"URL {shown!r}: a user name or password is not accepted "
                         "(phyphox's remote access has no login)")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        raise InputError(f"URL {shown!r}: the port must be a number from 1 to 65535") from None
    if not host:
        raise InputError(f"URL {shown!r}: no host; give the address phyphox shows, "
                         "e.g. http://192.168.1.20:8080")
    if port == 0:
        raise InputError(f"URL {shown!r}: the port must be a number from 1 to 65535")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise InputError(f"URL {shown!r}: give only the address phyphox shows (http://HOST:PORT), "
                         "without a path, query or fragment")
    netloc = f"[{host}]" if ":" in host else host
    return f"http://{netloc}:{port or 80}"


# ----------------------------------------------------------------------------- answers
@dataclass(frozen=True)
class AccelInput:
    """The accelerometer of the experiment: its sensor name and the buffers it writes."""

    sensor: str  # "linear_acceleration" or "accelerometer"
    t: str
    x: str
    y: str
    z: str

    @property
    def buffers(self) -> tuple[str, str, str, str]:
        """Buffer names of time [s] and x, y, z acceleration [m/s²]."""
        return self.t, self.x, self.y, self.z

    @property
    def gravity_removed(self) -> bool:
        """True for the sensor without g."""
        return self.sensor == "linear_acceleration"


@dataclass(frozen=True)
class Config:
    """What ``/config`` says: the experiment and its accelerometer buffers."""

    title: str | None
    crc32: str | None
    accel: AccelInput


@dataclass(frozen=True)
class Status:
    """``status`` of a ``/get`` answer."""

    session: str
    measuring: bool
    countdown_ms: float  # [ms] until a timed run starts or stops; 0 without one


@dataclass(frozen=True)
class Chunk:
    """The values of the accelerometer buffers in one ``/get`` answer: time [s] and x, y, z
    [m/s²] as delivered (NaN where phyphox sent null; the four may differ in length)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    status: Status


def _parse_json(body: bytes, what: str):
    try:
        return json.loads(body.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        start = text(" ".join(body[:40].decode("utf-8", "replace").split()), 40)
        shown = f"{start!r}…" if start else "nothing"
        raise NotPhyphox(f"{what} answered something that is not JSON ({shown}); "
                         "is this phyphox with remote access switched on?") from None


def _name(value, what: str) -> str:
    name = value if isinstance(value, str) else None
    if not name or len(name) > MAX_TEXT or any(not ch.isprintable() for ch in name):
        raise NotPhyphox(f"/config: {what} is not a usable buffer name")
    return name


def parse_config(obj) -> Config:
    """The accelerometer buffers from a ``/config`` answer (found from the experiment's inputs,
    not from fixed names); :class:`NotPhyphox` if it is not phyphox's shape or the experiment
    has no accelerometer with x, y, z and t buffers."""
    if not isinstance(obj, dict) or not isinstance(obj.get("inputs"), list) \
            or not isinstance(obj.get("buffers"), list):
        raise NotPhyphox("/config did not answer like phyphox (no inputs and buffers); is this "
                         "phyphox with remote access switched on?")
    known = {b.get("name") for b in obj["buffers"] if isinstance(b, dict)}
    found: dict[str, dict[str, str]] = {}
    for inp in obj["inputs"]:
        if not isinstance(inp, dict) or inp.get("source") not in ACCEL_SOURCES:
            continue
        outputs: dict[str, str] = {}
        for entry in inp.get("outputs") or []:
            if isinstance(entry, dict):
                for comp, buf in entry.items():
                    if comp in ("t", "x", "y", "z"):
                        outputs[comp] = _name(buf, f"the {comp} output of {inp['source']}")
        if len(outputs) == 4 and set(outputs.values()) <= known and inp["source"] not in found:
            found[inp["source"]] = outputs
    for source in ACCEL_SOURCES:
        if source in found:
            o = found[source]
            return Config(title=text(obj.get("title")), crc32=text(obj.get("crc32"), 16),
                          accel=AccelInput(source, o["t"], o["x"], o["y"], o["z"]))
    title = text(obj.get("title"))
    raise InputError(f"the experiment open in phyphox{f' ({title})' if title else ''} has no "
                     "accelerometer writing x, y, z and time buffers; open dampfit's experiment "
                     "('dampfit record --experiment FILE' writes it) or 'Acceleration (without g)'")


def _float_or_none(value) -> float | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        v = float(value)
    elif isinstance(value, str):
        try:
            v = float(value)
        except ValueError:
            return None
    else:
        return None
    return v if math.isfinite(v) else None


_DEVICE_KEYS = {"deviceModel": "model", "deviceBrand": "brand",
                "deviceManufacturer": "manufacturer", "deviceRelease": "os_release",
                "version": "phyphox_version", "build": "phyphox_build"}
#: Largest sensor value of /meta believed [its unit]: a phone's accelerometer range is at most
#: a few hundred m/s² (±32 g is 314 m/s²), its resolution far below its range, its delays
#: below a minute; a larger value (``"1e308"``) is a lie and is dropped (None).
SENSOR_LIMITS = {"range": 1e4, "resolution": 10.0, "min_delay_us": 6e7, "max_delay_us": 6e7}
_SENSOR_KEYS = {"name": "name", "vendor": "vendor", "range": "range", "resolution": "resolution",
                "mindelay": "min_delay_us", "maxdelay": "max_delay_us", "version": "version"}


def parse_meta(obj, sensor: str) -> tuple[dict, dict]:
    """(phone, sensor) from a ``/meta`` answer: device strings, and the metadata of ``sensor``
    (name, vendor, range [m/s²], resolution [m/s²], min_delay_us [µs], …; empty on iOS, which
    serves no sensor metadata). Keys may be absent or null; numbers come as strings; a number
    that is negative or beyond :data:`SENSOR_LIMITS` is dropped (None)."""
    if not isinstance(obj, dict):
        raise NotPhyphox("/meta did not answer like phyphox (not a JSON object)")
    phone = {ours: text(obj.get(theirs)) for theirs, ours in _DEVICE_KEYS.items()}
    sensors = obj.get("sensors")
    raw = sensors.get(sensor) if isinstance(sensors, dict) else None
    info: dict = {}
    if isinstance(raw, dict):
        folded = {str(k).lower(): v for k, v in raw.items()}  # documented capitalised; be lenient
        for theirs, ours in _SENSOR_KEYS.items():
            value = folded.get(theirs)
            if ours in ("range", "resolution", "min_delay_us", "max_delay_us"):
                number = _float_or_none(value)
                info[ours] = (number if number is not None and 0 <= number <= SENSOR_LIMITS[ours]
                              else None)
            else:
                info[ours] = text(value)
        if info.get("resolution") == 0:
            info["resolution"] = None
    return phone, info


def parse_time(obj) -> float | None:
    """The system time [s since 1970] of the last START event of a ``/time`` answer, or None."""
    if not isinstance(obj, list):
        raise NotPhyphox("/time did not answer like phyphox (not a JSON list)")
    starts = [_float_or_none(e.get("systemTime")) for e in obj
              if isinstance(e, dict) and e.get("event") == "START"]
    starts = [s for s in starts if s is not None and 0 < s < 1e11]
    return starts[-1] if starts else None


def _numbers(values, name: str) -> np.ndarray:
    if not isinstance(values, list) or not all(
            v is None or (type(v) in (int, float)) for v in values):
        raise NotPhyphox(f"/get: buffer {name!r} is not a list of numbers and nulls")
    try:
        out = np.array([np.nan if v is None else v for v in values], dtype=float)
    except OverflowError:  # an integer beyond any float
        raise NotPhyphox(f"/get: buffer {name!r} holds a number out of range") from None
    out[~np.isfinite(out)] = np.nan
    return out


def parse_get(obj, accel: AccelInput, parsed: dict[str, np.ndarray] | None = None) -> Chunk:
    """The accelerometer buffers and status of a ``/get`` answer (:class:`NotPhyphox` if
    its shape is wrong or a buffer is missing); ``parsed``: buffers already parsed
    (:func:`parse_get_body`)."""
    if not isinstance(obj, dict) or not isinstance(obj.get("buffer"), dict) \
            or not isinstance(obj.get("status"), dict):
        raise NotPhyphox("/get did not answer like phyphox (no buffer and status)")
    st = obj["status"]
    session, measuring = st.get("session"), st.get("measuring")
    if not isinstance(session, str) or not isinstance(measuring, bool):
        raise NotPhyphox("/get: the status has no session or measuring flag")
    countdown = _float_or_none(st.get("countDown")) or 0.0
    arrays = []
    for name in accel.buffers:
        entry = obj["buffer"].get(name)
        if not isinstance(entry, dict):
            raise NotPhyphox(f"/get: buffer {name!r} is missing from the answer (did the "
                             "experiment change on the phone?)")
        arrays.append(parsed[name] if parsed and name in parsed
                      else _numbers(entry.get("buffer"), name))
    status = Status(session=text(session, 64) or "", measuring=measuring,
                    countdown_ms=max(countdown, 0.0))
    return Chunk(*arrays, status=status)


#: One buffer's list of numbers in a /get answer: ``"buffer": [ … ]`` without nested lists.
_ARRAY = re.compile(rb'"buffer"\s*:\s*\[([^\[\]]*)\]')
#: Characters a list of JSON numbers and nulls is made of, "null" aside.
_NUMBER_BYTES = b"0123456789.eE+-, \t\r\n"


def _array(span: bytes, name: str) -> np.ndarray:
    """A buffer's values from the text of its JSON list (numbers and nulls, ``null`` → NaN)
    without a Python object per value: NumPy parses the text (8 bytes per value)."""
    import warnings

    if not span.strip():
        return np.empty(0)
    rest = span.translate(None, _NUMBER_BYTES)
    bare = span.translate(None, b" \t\r\n")  # an empty value (NumPy would read -1)
    if rest != b"null" * (len(rest) // 4) or b",," in bare or bare[:1] == b"," \
            or bare[-1:] == b",":
        raise NotPhyphox(f"/get: buffer {name!r} is not a list of numbers and nulls")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # older NumPy warns where the numbers stop
            out = np.fromstring(span.replace(b"null", b"nan"), dtype=float, sep=",")
    except ValueError:  # newer NumPy refuses text that is not all numbers
        out = None
    if out is None or out.size != span.count(b",") + 1:
        raise NotPhyphox(f"/get: buffer {name!r} is not a list of numbers and nulls")
    out[~np.isfinite(out)] = np.nan
    return out


def parse_get_body(body: bytes, accel: AccelInput) -> Chunk:
    """:func:`parse_get` of the raw ``/get`` answer, in memory bounded by the answer's bytes:
    every ``"buffer": [...]`` list is cut out and parsed by NumPy (8 bytes per value, where
    ``json.loads`` takes 32 per value, 8 times the 4 bytes of a dense ``1e0,``), the rest —
    structure and status — by ``json``."""
    pieces, arrays, at = [], [], 0
    for k, m in enumerate(_ARRAY.finditer(body)):
        pieces += [body[at:m.start(1)], b"%d" % k]
        arrays.append((m.start(1), m.end(1)))
        at = m.end(1)
    pieces.append(body[at:])
    obj = _parse_json(b"".join(pieces), "/get")
    buffers = obj.get("buffer") if isinstance(obj, dict) else None
    values: dict[str, np.ndarray] = {}
    if isinstance(buffers, dict):
        for name in accel.buffers:
            entry = buffers.get(name)
            ref = entry.get("buffer") if isinstance(entry, dict) else None
            if isinstance(ref, list) and len(ref) == 1 and type(ref[0]) is int \
                    and 0 <= ref[0] < len(arrays):
                start, end = arrays[ref[0]]
                values[name] = _array(body[start:end], name)
    return parse_get(obj, accel, values)


# ------------------------------------------------------------------------------ client
def _reason(exc: BaseException) -> str:
    if isinstance(exc, (socket.timeout, TimeoutError)):
        return "timed out"
    if isinstance(exc, ConnectionRefusedError):
        return "connection refused"
    if isinstance(exc, http.client.RemoteDisconnected):
        return "the connection was closed without an answer"
    if isinstance(exc, (ConnectionResetError, BrokenPipeError)):
        return "the connection was reset"
    if isinstance(exc, http.client.IncompleteRead):
        return "the answer was cut off"
    if isinstance(exc, _ServerError):
        return str(exc)
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return text(str(exc), 80) or type(exc).__name__


class _ServerError(Exception):
    """HTTP 5xx: the phone's server had a problem; retried like a dropped connection."""


class _TooSlow(Exception):
    """The answer did not arrive within the attempt's overall deadline (not retried)."""


def values_in(data: bytes) -> int:
    """An upper bound of the numbers ``data`` (a piece of a JSON answer) can complete: one
    per separator (``,`` or ``]``); a number needs at least one character and a separator,
    so the parsed answer's size follows from the bytes actually received, whatever their
    density (``0,`` is two bytes per value)."""
    return data.count(b",") + data.count(b"]")


class PhyphoxClient:
    """GET requests to phyphox's remote access at ``url`` (checked by :func:`check_url`).

    ``timeout`` [s] bounds the connect and every read; a whole answer must arrive within
    ``3·timeout`` plus 1 s per MB of its size limit. A failed connection is tried
    ``retries`` more times after ``backoff``·2^k s (k = 0, 1, …), then :class:`ConnectionLost`.
    ``log`` (optional) is called with each request path (tests count them).
    """

    def __init__(self, url: str, *, timeout: float = 5.0, retries: int = 4,
                 backoff: float = 0.25, log=None) -> None:
        self.url = check_url(url)
        parts = urlsplit(self.url)
        self.host, self.port = parts.hostname, parts.port
        self.timeout, self.retries, self.backoff = float(timeout), int(retries), float(backoff)
        self.log = log

    # -- transport -----------------------------------------------------------------
    def _once(self, path: str, limit: int, timeout: float, values: int | None) -> bytes:
        """One GET: the body, or an exception. A watchdog shuts the socket down when the
        attempt's overall deadline (:meth:`deadline`) passes, so a server that drips its
        headers or body (each byte within ``timeout``) cannot stretch it: :class:`_TooSlow`.
        ``values``: most numbers the answer may hold, counted from the bytes received (a
        separator per value; :func:`values_in`) — the memory of the parsed answer is bounded
        by it, whatever the bytes per value."""
        conn = http.client.HTTPConnection(self.host, self.port, timeout=timeout)
        expired = threading.Event()

        def expire() -> None:
            expired.set()
            sock = conn.sock
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)

        allowed = self.deadline(limit, timeout)
        watchdog = threading.Timer(allowed, expire)
        watchdog.daemon = True
        watchdog.start()
        slow = _TooSlow(f"{path.split('?')[0]} did not answer within {allowed:.3g} s (a "
                        "server that sends its answer too slowly)")
        try:
            body = self._exchange(conn, path, limit, values)
        except (OSError, http.client.HTTPException, NotPhyphox):
            if expired.is_set():
                raise slow from None
            raise
        else:  # a cut-off answer can look whole (no Content-Length): the watchdog decides
            if expired.is_set():
                raise slow
            return body
        finally:
            watchdog.cancel()
            conn.close()

    @staticmethod
    def deadline(limit: int, timeout: float) -> float:
        """The overall time [s] one attempt may take: ``3·timeout`` plus 1 s per MB of the
        answer's size limit ``limit`` [bytes]."""
        return 3 * timeout + limit / 2**20

    @staticmethod
    def _exchange(conn, path: str, limit: int, values: int | None) -> bytes:
        conn.request("GET", path, headers={"Connection": "close", "Accept": "application/json"})
        resp = conn.getresponse()
        endpoint = path.split("?")[0]
        if resp.status >= 500:
            raise _ServerError(f"HTTP {resp.status}")
        if resp.status != 200:
            raise NotPhyphox(f"{endpoint} answered HTTP {resp.status}; is this "
                             "phyphox with remote access switched on?")
        length = resp.getheader("Content-Length")
        if length is not None and length.isdigit() and int(length) > limit:
            raise NotPhyphox(f"{endpoint} answered {int(length)} bytes, more than "
                             f"the {limit} expected")
        chunks, size, count = [], 0, 0
        while True:
            chunk = resp.read(min(1 << 16, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
            if size > limit:
                raise NotPhyphox(f"{endpoint} answered more than the {limit} bytes expected")
            if values is not None:
                count += values_in(chunk)
                if count > values:
                    raise NotPhyphox(f"{endpoint} answered more than the {values} values "
                                     "expected")
        return b"".join(chunks)

    def request(self, path: str, limit: int = SMALL_ANSWER, timeout: float | None = None,
                values: int | None = None) -> bytes:
        """The body of ``GET path`` (at most ``limit`` bytes, at most ``values`` numbers),
        retried with backoff; ``timeout`` [s] replaces the client's for this request (a large
        answer). An answer too slow for its deadline is not retried (:class:`ConnectionLost`
        at once: a second attempt would wait as long again)."""
        if self.log is not None:
            self.log(path)
        for attempt in range(self.retries + 1):
            try:
                return self._once(path, limit, timeout or self.timeout, values)
            except _TooSlow as exc:
                raise ConnectionLost(f"phyphox at {self.url}: {exc}") from None
            except socket.gaierror as exc:
                raise ConnectionLost(f"cannot find the phone at {self.url}: "
                                     f"{exc.strerror or exc}") from None
            except (OSError, http.client.HTTPException, _ServerError) as exc:
                reason = _reason(exc)
            if attempt < self.retries:
                time.sleep(self.backoff * 2**attempt)
        raise ConnectionLost(f"no answer from phyphox at {self.url} ({reason}, "
                             f"{self.retries + 1} attempts)")

    def _json(self, path: str, limit: int = SMALL_ANSWER, timeout: float | None = None):
        return _parse_json(self.request(path, limit, timeout), path.split("?")[0])

    # -- endpoints -----------------------------------------------------------------
    def config(self) -> Config:
        """``/config``: the experiment and its accelerometer buffers."""
        return parse_config(self._json("/config"))

    def meta(self, sensor: str) -> tuple[dict, dict]:
        """``/meta``: (phone, sensor) strings and numbers (:func:`parse_meta`)."""
        return parse_meta(self._json("/meta"), sensor)

    def start_time(self) -> float | None:
        """``/time``: system time [s since 1970] of the last start, or None."""
        return parse_time(self._json("/time"))

    def control(self, cmd: str) -> bool:
        """``/control?cmd=CMD`` (start, stop, clear): whether phyphox accepted it."""
        obj = self._json(f"/control?cmd={quote(cmd)}")
        if not isinstance(obj, dict) or not isinstance(obj.get("result"), bool):
            raise NotPhyphox("/control did not answer like phyphox (no result)")
        return obj["result"]

    def get(self, accel: AccelInput, since: float | None, limit: int,
            timeout: float | None = None, values: int | None = None) -> Chunk:
        """``/get`` of the accelerometer buffers: all values (``since`` None) or those whose
        time [s] is above ``since`` (``t=T&x=T|t…``); at most ``limit`` bytes and ``values``
        numbers (None: ``limit``/2), parsed in memory bounded by them (:func:`parse_get_body`)."""
        if since is None:
            query = "&".join(f"{quote(b, safe='')}=full" for b in accel.buffers)
        else:
            mark, ref = quote(repr(float(since)), safe=""), quote(accel.t, safe="")
            query = "&".join([f"{ref}={mark}"] + [f"{quote(b, safe='')}={mark}%7C{ref}"
                                                  for b in accel.buffers[1:]])
        body = self.request(f"/get?{query}", limit, timeout,
                            values=limit // 2 if values is None else values)
        return parse_get_body(body, accel)
