"""One recording from a phone running phyphox: handshake, polling loop, final fetch, files.

:func:`record` runs the session against a :class:`~dampfit.record.phyphox.PhyphoxClient`:

1. ``/config`` (the accelerometer buffers of the open experiment), ``/meta`` (phone, sensor
   name, range [m/s²], resolution [m/s²]) and ``/time``; a phone that is already measuring is
   refused (another ``dampfit record``, or the user, is using it: nothing is cleared);
2. ``/control?cmd=clear`` and ``cmd=start`` (start refused → one line);
3. every :data:`POLL_S` seconds ``/get`` of only the new samples (``t=T&x=T|t…``), fed to the
   :class:`~dampfit.record.live.Detector` and shown on the :class:`~dampfit.record.live.LiveLine`;
4. it stops at the end of the decay (:data:`~dampfit.record.live.DONE`), at ``duration``
   seconds of phone time, when the user presses stop on the phone (``measuring`` false), at
   Ctrl-C or SIGTERM, or when the memory bound (``duration`` × :data:`MAX_RATE_HZ` samples) is
   reached;
5. ``/control?cmd=stop`` and one ``/get`` of the full buffers, merged with what was polled
   (a phone whose buffers are bounded keeps only the newest samples: the polled ones before
   them are kept too).

A failure after samples arrived — the connection lost after the retries, garbage, a changed
session id (the experiment was restarted or another opened: the two are never mixed, and the
new session is not touched), no new samples for :data:`STALL_S` seconds — ends the loop with
:attr:`Recorded.error` set: the samples so far are written all the same, and the caller
reports the error afterwards (one line, exit 2). A failure before any sample (not phyphox, no
accelerometer, start refused) is raised at once and nothing is written.

Samples are cleaned as they arrive: buffers of unequal length in one answer are cut to the
common length (the rest comes with the next poll, which asks for times after the last kept
one); rows holding a null (NaN) are dropped; rows whose time does not increase are dropped.
:func:`write_recording` writes ``recording.csv`` (phyphox's "Raw Data" CSV, which
``dampfit analyze`` reads) and ``recording.json`` (phone, sensor, range, resolution, rate,
start time, URL, dampfit version, why it stopped, what was dropped) atomically.
"""

from __future__ import annotations

import datetime
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dampfit.files.atomic import atomic_write_text
from dampfit.errors import InputError
from dampfit.record.live import DONE, GAP_S, Detector, LiveLine
from dampfit.record.phyphox import Chunk, ConnectionLost, NotPhyphox, PhyphoxClient

#: File names in the result folder.
CSV, JSON = "recording.csv", "recording.json"
#: Default and largest ``--duration`` [s] of phone time.
DEFAULT_DURATION = 600.0
MAX_DURATION = 1800.0
#: Highest sample rate [Hz] the memory bound allows for (phones deliver ≤ ~1 kHz).
MAX_RATE_HZ = 2000.0
#: Pause between polls [s] (phyphox's server is single-threaded: no request in parallel).
POLL_S = 0.25
#: Wall time [s] without a new sample, while measuring, after which the recording stops.
STALL_S = 15.0
#: Wall time [s] the measurement may take to begin after cmd=start (plus a timed-run countdown).
START_WAIT_S = 10.0
#: Samples per second [1/s] a phone formats for the final full /get at least (its timeout).
FULL_FETCH_RATE = 5000.0
#: Bytes per value in a /get answer at most: phyphox's 8 significant digits, sign, point,
#: exponent and separator (``-1.2345678E-1,`` is 14). Only the honest answer's size: the
#: memory of a parsed answer is bounded by the number of values (4 per row), counted from
#: the bytes received (:func:`dampfit.record.phyphox.values_in`).
_BYTES_PER_VALUE = 16


@dataclass
class Recorded:
    """What :func:`record` got: the cleaned samples and everything for recording.json."""

    time: np.ndarray  # [s], phone experiment time, strictly increasing
    accel: np.ndarray  # [m/s²], shape (n, 3): x, y, z
    gravity_removed: bool
    info: dict
    stopped_by: str
    error: InputError | None = None
    interrupt: BaseException | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.time[-1] - self.time[0]) if self.time.size else 0.0


class _Samples:
    """Cleaned samples, appended chunk by chunk, at most ``limit`` rows."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.t: list[np.ndarray] = []
        self.a: list[np.ndarray] = []
        self.n = 0
        self.last = -math.inf
        self.full = False
        self.dropped = {"unequal_lengths": 0, "missing_values": 0, "time_not_increasing": 0}

    def add(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        """Clean and keep the rows of ``chunk``; return the kept (time [s], accel [m/s²])."""
        cols = (chunk.t, chunk.x, chunk.y, chunk.z)
        n = min(c.size for c in cols)
        self.dropped["unequal_lengths"] += sum(c.size - n for c in cols)
        t = chunk.t[:n]
        a = np.column_stack([chunk.x[:n], chunk.y[:n], chunk.z[:n]])
        ok = np.isfinite(t) & np.isfinite(a).all(axis=1)
        self.dropped["missing_values"] += int((~ok).sum())
        t, a = t[ok], a[ok]
        before = np.maximum.accumulate(np.concatenate([[self.last], t]))[:-1]
        rising = t > before
        self.dropped["time_not_increasing"] += int((~rising).sum())
        t, a = t[rising], a[rising]
        room = self.limit - self.n
        if t.size >= room:
            self.full = True
            t, a = t[:room], a[:room]
        if t.size:
            self.t.append(t)
            self.a.append(a)
            self.n += t.size
            self.last = float(t[-1])
        return t, a

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.t:
            return np.empty(0), np.empty((0, 3))
        return np.concatenate(self.t), np.concatenate(self.a)


def _merge(polled: _Samples, full: _Samples) -> tuple[np.ndarray, np.ndarray]:
    """The full fetch, preceded by the polled samples older than its first one."""
    tp, ap = polled.arrays()
    tf, af = full.arrays()
    if tf.size == 0:
        return tp, ap
    older = tp < tf[0]
    return np.concatenate([tp[older], tf]), np.concatenate([ap[older], af])


def quantisation_note(resolution: float | None, noise: float | None, sensor: str) -> str | None:
    """The sensor resolution (LSB [m/s²]) as a note for the noise model: the uniform
    quantisation noise LSB/√12 [m/s² rms per axis] and whether it matters beside the measured
    noise σ [m/s², three axes together] (there is no quantisation term in dampfit's noise
    model: it is part of the σ the analysis measures)."""
    if resolution is None:
        return None
    q = resolution / math.sqrt(12.0)
    text = (f"sensor resolution {resolution:.3g} m/s² ({sensor}, phyphox /meta): quantisation "
            f"noise LSB/√12 = {q:.2g} m/s² rms per axis")
    if noise is not None and noise > 0:
        share = 3 * q**2 / noise**2
        if share >= 0.25:
            text += (f", {min(share, 1.0):.0%} of the noise variance while recording: the noise "
                     "floor is set by the resolution; amplitudes near it are step-like, and "
                     "the fitted σ includes it")
        else:
            text += f", {share:.0%} of the noise variance while recording: negligible"
    return text


def _handshake(client: PhyphoxClient) -> tuple:
    """/config, /meta, /time and a status check; raises if the phone is already measuring."""
    config = client.config()
    accel = config.accel
    phone, sensor = client.meta(accel.sensor)
    client.start_time()
    status = client.get(accel, since=1e300, limit=1 << 16).status
    if status.measuring:
        raise InputError(f"phyphox at {client.url} is already measuring; press stop on the "
                         "phone first (dampfit record clears and starts the measurement itself)")
    return config, phone, sensor


def record(client: PhyphoxClient, *, duration: float = DEFAULT_DURATION,
           live: LiveLine | None = None, clock=time.monotonic, sleep=time.sleep,
           sink=None) -> Recorded:
    """Record one free decay from phyphox (see the module docstring); ``duration`` [s] of
    phone time at most. Raises before any sample arrived; after that a failure is returned
    in :attr:`Recorded.error`, Ctrl-C/SIGTERM in :attr:`Recorded.interrupt`. ``sink``
    (optional) is called with each poll's kept samples as they arrive: (time [s], accel
    [m/s²] (n, 3), gravity removed) — :class:`dampfit.record.journal.Journal` streams them
    to disk."""
    if not 0 < duration <= MAX_DURATION:
        raise InputError(f"duration must be in (0, {MAX_DURATION:g}] s, got {duration:g}")
    return _Session(client, duration, live or LiveLine(None, enabled=False), clock, sleep,
                    sink).run()


class _Session:
    """The state of one :func:`record` call."""

    def __init__(self, client, duration, live, clock, sleep, sink=None) -> None:
        self.client, self.duration, self.live = client, duration, live
        self.clock, self.sleep, self.sink = clock, sleep, sink
        self.rows = int(duration * MAX_RATE_HZ) + 1000
        self.limit_bytes = 4 * self.rows * _BYTES_PER_VALUE + (1 << 16)
        self.limit_values = 4 * self.rows + 64
        self.samples = _Samples(self.rows)
        self.stopped_by: str | None = None
        self.error: InputError | None = None
        self.interrupt: BaseException | None = None

    def run(self) -> Recorded:
        client = self.client
        self.config, self.phone, self.sensor = _handshake(client)
        self.accel = self.config.accel
        self.detector = Detector(self.sensor.get("resolution"))
        client.control("clear")
        if not client.control("start"):
            raise InputError(f"phyphox at {client.url} refused to start the measurement (is a "
                             "sensor of the experiment missing, or a Bluetooth device not "
                             "connected?)")
        self.started_wall, self.start_time = self.clock(), None
        try:
            self.start_time = client.start_time()
            self._loop()
        except KeyboardInterrupt as exc:
            self.interrupt = exc
            self.stopped_by = "interrupted" if type(exc) is KeyboardInterrupt else "terminated"
        except (ConnectionLost, NotPhyphox) as exc:
            if self.samples.n == 0:
                raise
            self.error = exc
            self.stopped_by = "connection lost" if isinstance(exc, ConnectionLost) else "garbage"
        t, a, final = self._finish()
        keep = t <= t[0] + self.duration if t.size else slice(None)  # the full fetch runs on
        t, a = t[keep], a[keep]
        if t.size == 0:
            raise self.error or InputError(f"phyphox sent no samples before the recording "
                                           f"stopped ({self.stopped_by})")
        info = _info(self, client, t, final)
        notes = [f"recorded from phyphox at {client.url} with dampfit record ({self.stopped_by})"]
        note = quantisation_note(self.sensor.get("resolution"), self.detector.noise or None,
                                 self.accel.sensor)
        if note:
            notes.append(note)
        if self.detector.gaps:
            notes.append(f"{self.detector.gaps} gap(s) in the phone's time stamps longer than "
                         f"{GAP_S:g} s (the largest {self.detector.largest_gap:.3g} s) while "
                         "recording")
        info["notes"] = notes
        return Recorded(time=t, accel=a, gravity_removed=self.accel.gravity_removed, info=info,
                        stopped_by=self.stopped_by, error=self.error, interrupt=self.interrupt,
                        notes=notes)

    def _loop(self) -> None:
        """Poll until a stop condition holds (sets ``stopped_by``, maybe ``error``)."""
        samples, detector = self.samples, self.detector
        session, measuring_seen, last_new, countdown = None, False, self.clock(), 0.0
        while self.stopped_by is None:
            chunk = self.client.get(self.accel, samples.last if samples.n else None,
                                    self.limit_bytes, values=self.limit_values)
            st = chunk.status
            session = st.session if session is None else session
            if st.session != session:
                self.error = InputError(
                    f"phyphox's session changed from {session} to {st.session} (the experiment "
                    "was restarted or another one opened); refusing to mix the two recordings")
                self.stopped_by = "session changed"
                return
            t_new, a_new = samples.add(chunk)
            now = self.clock()
            if t_new.size:
                last_new = now
                detector.feed(t_new, a_new)
                if self.sink is not None:
                    self.sink(t_new, a_new, self.accel.gravity_removed)
            self.live.show(detector.elapsed, detector.amplitude, detector.state)
            countdown = max(countdown, st.countdown_ms / 1000.0)
            measuring_seen = measuring_seen or st.measuring
            if detector.largest_gap > self.duration:
                self.error = InputError(
                    f"the phone's clock jumped by {detector.largest_gap:.3g} s, more than the "
                    f"{self.duration:g} s recording (a gap in the time stamps); the samples "
                    "before it are kept")
                self.stopped_by = "clock jump"
            elif detector.state == DONE:
                self.stopped_by = "end of the decay"
            elif samples.n and samples.last - samples.t[0][0] >= self.duration:
                self.stopped_by = "duration"
            elif samples.full:
                self.stopped_by = "sample limit"
            elif measuring_seen and not st.measuring:
                self.stopped_by = "stopped on the phone"
            elif not measuring_seen and now - self.started_wall > START_WAIT_S + countdown:
                raise InputError(f"phyphox at {self.client.url} did not start measuring within "
                                 f"{START_WAIT_S + countdown:g} s")
            elif now - self.started_wall > self.duration + 60.0:
                self.stopped_by = "duration (this computer's clock)"
            elif measuring_seen and now - last_new > STALL_S:
                self.error = InputError(f"phyphox sent no new samples for {STALL_S:g} s")
                self.stopped_by = "no new samples"
            else:
                self.sleep(POLL_S)

    def _finish(self) -> tuple[np.ndarray, np.ndarray, str]:
        """Stop the measurement and fetch the full buffers, unless the session failed or was
        terminated; the merged samples and where they came from."""
        t, a = self.samples.arrays()
        if self.error is not None or self.stopped_by == "terminated":
            return t, a, "polled samples"
        try:
            self.client.control("stop")
            full = _Samples(self.rows)
            # the phone formats the whole buffers first (slowly): allow for it
            wait = 2 * self.client.timeout + self.samples.n / FULL_FETCH_RATE
            # twice the values of a poll: the phone measures on until cmd=stop arrives (the
            # samples beyond ``duration`` are dropped afterwards)
            full.add(self.client.get(self.accel, None, 2 * self.limit_bytes, timeout=wait,
                                     values=2 * self.limit_values))
        except KeyboardInterrupt as exc:  # a second Ctrl-C: keep what was polled
            self.interrupt, self.stopped_by = exc, "interrupted twice"
            return t, a, "polled samples"
        except (ConnectionLost, NotPhyphox) as exc:
            self.error = exc
            return t, a, "polled samples"
        for k, v in full.dropped.items():
            self.samples.dropped[k] = max(self.samples.dropped[k], v)
        t, a = _merge(self.samples, full)
        return t, a, "full buffers fetched after the stop"


def _info(session: _Session, client, t, final) -> dict:
    """The content of recording.json (JSON-safe; strings from the phone cleaned) of the
    ``session`` that recorded the times ``t`` [s] from ``client`` (``final``: how the last
    data were fetched)."""
    from dampfit._meta import __version__

    config, phone, sensor, detector = session.config, session.phone, session.sensor, \
        session.detector
    start_time, clock, duration = session.start_time, session.clock, session.duration

    rate = float(1.0 / np.median(np.diff(t))) if t.size > 1 else None
    if start_time is None:  # no START event: this computer's clock at cmd=start
        start_time = time.time() - (clock() - session.started_wall)
        source = "this computer's clock when dampfit sent cmd=start"
    else:
        source = "phyphox /time (the phone's clock at the start)"
    when = datetime.datetime.fromtimestamp(start_time, datetime.timezone.utc)
    return {
        "url": client.url,
        "dampfit_version": __version__,
        "phone": phone,
        "experiment": {"title": config.title, "crc32": config.crc32},
        "sensor": {"type": config.accel.sensor, "gravity_removed": config.accel.gravity_removed,
                   **sensor, "units": {"range": "m/s²", "resolution": "m/s²",
                                       "min_delay_us": "µs", "max_delay_us": "µs"}},
        "buffers": dict(zip(("time", "x", "y", "z"), config.accel.buffers)),
        "sample_rate_hz": rate,
        "n_samples": int(t.size),
        "first_time_s": float(t[0]),
        "duration_s": float(t[-1] - t[0]),
        "max_duration_s": duration,
        "start_time": when.isoformat(timespec="milliseconds"),
        "start_time_source": source,
        "stopped_by": session.stopped_by,
        "release_time_s": detector.release_time,
        "decay_end_time_s": detector.end_time,
        "noise_floor_m_s2": detector.noise or None,
        "clock_gaps": {"count": detector.gaps, "largest_s": detector.largest_gap or None,
                       "longer_than_s": GAP_S},
        "data": final,
        "dropped": dict(session.samples.dropped),
    }


def write_recording(rec: Recorded, folder: str | Path) -> list[Path]:
    """``recording.csv`` (phyphox "Raw Data" CSV) and ``recording.json`` into ``folder``,
    atomically; a recording :class:`~dampfit.io.recording.Recording` refuses (too few samples,
    …) is one :class:`InputError` and nothing is written."""
    from dampfit.io.recording import Recording
    from dampfit.files.writers import write_phyphox_csv

    folder = Path(folder)
    try:
        r = Recording(time=rec.time, accel=rec.accel, axes=("x", "y", "z"), format="phyphox",
                      gravity_removed=rec.gravity_removed)
    except InputError as exc:
        why = f"{rec.error}; " if rec.error else ""
        raise InputError(f"{why}the {rec.time.size} samples recorded cannot be kept: {exc}") from None
    csv = write_phyphox_csv(r, folder / CSV)
    meta = atomic_write_text(folder / JSON, json.dumps(rec.info, indent=2, allow_nan=False,
                                                       ensure_ascii=False) + "\n")
    return [csv, meta]
