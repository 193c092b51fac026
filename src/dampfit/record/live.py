"""While recording: the release and the end of a free decay from streamed samples, and the live line.

:class:`Detector` is fed the samples as they arrive (time [s], acceleration [m/s²] of x, y, z)
and cuts them into blocks of :attr:`Detector.block_s`. For each block b:

* the **baseline** β is the mean acceleration of the last ``baseline_blocks`` blocks (gravity,
  bias and slow drift; the oscillation averages out over several periods);
* the **noise** σ_b² = Σ_axes mean(Δ²a)²/6 from second differences Δ²a_i = a_{i+1} − 2a_i +
  a_{i−1}, whose variance is 6σ² for white noise of variance σ² while a smooth oscillation of
  amplitude A at f ≪ fs contributes only A·(2πf/fs)²; the **noise floor** σ² is the 20th
  percentile of σ_b² over the blocks so far, and at least 3·LSB²/12 when the sensor
  resolution (LSB [m/s²]) is known (uniform quantisation noise, three axes);
* the **amplitude** A_b = √(2·max(ms_b − σ², 0)) [m/s²] from the mean square deviation ms_b
  about the baseline (a sinusoid of amplitude A has mean square A²/2 on top of the noise).

States (:data:`WAITING` → :data:`DECAYING` → :data:`DONE`):

* **release**: the amplitude has peaked at ≥ ``release_snr``·σ and fallen to ≤
  ``confirm_drop`` × the peak at least two blocks later (the hand let go: the envelope
  peaks, then decays); the release time is the start of the peak block. A later block above
  ``1.2`` × the peak is a new release (the mass was pulled again).
* **end of the decay**: the amplitude stays ≤ ``floor_snr``·σ (at the noise floor) for
  ``hold_periods`` oscillation periods and at least ``hold_min_s`` seconds. The period comes
  from the zero crossings (with a hysteresis of 2σ) of the axis that moved most at the
  release.

Everything here is pure NumPy and bounded in memory (a few numbers per block, the last
:data:`MAX_BLOCKS` blocks). :class:`LiveLine` writes one throttled, overwritten status line
(elapsed time, amplitude, state) to a terminal, and only the final line when the stream is not
a terminal; nothing with ``enabled=False`` (``--quiet``).
"""

from __future__ import annotations

import collections
import math
import time

import numpy as np

WAITING = "waiting for the release"
DECAYING = "decaying"
DONE = "done"
#: Blocks remembered for the noise floor (20 min of 0.5 s blocks).
MAX_BLOCKS = 2400
#: Fewest samples a block needs; a shorter one is merged into the next.
MIN_BLOCK_SAMPLES = 4
#: A step of the phone's clock [s] longer than this between two samples is a gap (counted in
#: :attr:`Detector.gaps`): samples stopped coming, or the clock jumped.
GAP_S = 1.0
#: Smallest noise floor [m/s²] (a recording of exact zeros has no noise to measure).
_TINY = 1e-6


class Detector:
    """Release and end-of-decay detector (see the module docstring).

    ``resolution`` [m/s²] is the sensor's LSB from phyphox's ``/meta`` (None if unknown).
    Attributes after each :meth:`feed`: ``state``, ``amplitude`` [m/s²] (of the last block),
    ``noise`` σ [m/s²], ``release_time`` and ``end_time`` [s] (None until detected),
    ``period`` [s] (None until measured), ``elapsed`` [s] (last time stamp), ``gaps`` (steps
    of the clock longer than :data:`GAP_S`) and ``largest_gap`` [s]. The work of a
    :meth:`feed` is bounded by its samples, not by the clock's values: a jump of the clock
    (0.002 → 1e9 s) is one gap, not 2·10⁹ empty blocks.
    """

    def __init__(self, resolution: float | None = None, *, block_s: float = 0.5,
                 baseline_blocks: int = 10, release_snr: float = 10.0, confirm_drop: float = 0.9,
                 floor_snr: float = 3.0, hold_periods: float = 5.0, hold_min_s: float = 2.0) -> None:
        self.block_s, self.release_snr, self.confirm_drop = block_s, release_snr, confirm_drop
        self.floor_snr, self.hold_periods, self.hold_min_s = floor_snr, hold_periods, hold_min_s
        lsb = resolution if resolution is not None and resolution > 0 else 0.0
        self._quant2 = 3 * lsb**2 / 12.0
        self._means: collections.deque = collections.deque(maxlen=baseline_blocks)
        self._noise2: collections.deque = collections.deque(maxlen=MAX_BLOCKS)
        self._t = np.empty(0)  # samples of the block not yet complete
        self._a = np.empty((0, 3))
        self._start: float | None = None
        self._last: float | None = None
        self.gaps, self.largest_gap = 0, 0.0
        self.state = WAITING
        self.amplitude = 0.0
        self.noise = 0.0
        self.elapsed = 0.0
        self.release_time: float | None = None
        self.end_time: float | None = None
        self.period: float | None = None
        self._peak, self._peak_t, self._since_peak = 0.0, None, 0
        self._peak_axis = 0
        self._below_since: float | None = None
        self._sign, self._crossings, self._cross_first, self._cross_last = 0, 0, None, None

    # ------------------------------------------------------------------ input
    def feed(self, t: np.ndarray, a: np.ndarray) -> None:
        """Add samples: time ``t`` [s] (increasing, after the previous ones) and acceleration
        ``a`` [m/s²] of shape (n, 3), all finite; closes every complete block (a block with
        fewer than :data:`MIN_BLOCK_SAMPLES` samples is lengthened; after a gap the next
        block starts at the next sample)."""
        t = np.asarray(t, dtype=float)
        a = np.asarray(a, dtype=float).reshape(-1, 3)
        if t.size == 0:
            return
        self.elapsed = float(t[-1])
        if self._start is None:
            self._start = float(t[0])
        tb = np.concatenate([self._t, t]) if self._t.size else t
        ab = np.concatenate([self._a, a]) if self._a.size else a
        gaps = np.diff(np.concatenate([[self._last], t])) if self._last is not None else np.diff(t)
        big = gaps[gaps > GAP_S]
        if big.size:
            self.gaps += int(big.size)
            self.largest_gap = max(self.largest_gap, float(big.max()))
        self._last = float(t[-1])
        while tb.size:  # every pass closes a block of ≥ MIN_BLOCK_SAMPLES samples, or stops
            end = self._start + self.block_s
            cut = int(np.searchsorted(tb, end, side="left"))
            if cut < MIN_BLOCK_SAMPLES and cut < tb.size:
                if tb.size < MIN_BLOCK_SAMPLES:
                    break
                # lengthened by whole blocks up to the MIN_BLOCK_SAMPLES-th sample, computed
                # from that sample (not stepped: a clock jump of 1e9 s is one step)
                last = float(tb[MIN_BLOCK_SAMPLES - 1])
                end = self._start + self.block_s * (math.floor((last - self._start)
                                                               / self.block_s) + 1)
                end = max(end, float(np.nextafter(last, math.inf)))
                cut = int(np.searchsorted(tb, end, side="left"))
            if cut == tb.size:  # not complete until a sample at or after its end arrives
                break
            self._block(self._start, end, ab[:cut])
            tb, ab = tb[cut:], ab[cut:]
            self._start = end if tb[0] < end + self.block_s else float(tb[0])
        self._t, self._a = tb, ab

    # ----------------------------------------------------------------- blocks
    def _block(self, t0: float, t1: float, a: np.ndarray) -> None:
        mean, var = a.mean(axis=0), a.var(axis=0)
        self._means.append(mean)
        base = np.mean(self._means, axis=0)
        dev2 = var + (mean - base) ** 2
        d2 = np.diff(a, n=2, axis=0)
        self._noise2.append(float(np.sum(np.mean(d2**2, axis=0))) / 6.0)
        floor2 = max(float(np.percentile(self._noise2, 20)), self._quant2, _TINY**2)
        self.noise = math.sqrt(floor2)
        self.amplitude = math.sqrt(2.0 * max(float(dev2.sum()) - floor2, 0.0))
        if self.state == WAITING:
            self._waiting(t0, dev2)
        elif self.state == DECAYING:
            self._crossings_in(a[:, self._peak_axis] - base[self._peak_axis], t0, t1, var)
            self._decaying(t0, t1, dev2)

    def _waiting(self, t0: float, dev2: np.ndarray) -> None:
        if self.amplitude > self._peak:
            self._peak, self._peak_t, self._since_peak = self.amplitude, t0, 0
            self._peak_axis = int(np.argmax(dev2))
            return
        self._since_peak += 1
        if (self._peak > self.release_snr * self.noise and self._since_peak >= 2
                and self.amplitude <= self.confirm_drop * self._peak):
            self.state, self.release_time = DECAYING, self._peak_t

    def _decaying(self, t0: float, t1: float, dev2: np.ndarray) -> None:
        if self.amplitude > 1.2 * self._peak:  # pulled again: a new release
            self._peak, self._peak_t = self.amplitude, t0
            self.release_time, self._peak_axis = t0, int(np.argmax(dev2))
            self._below_since, self.period = None, None
            self._sign, self._crossings, self._cross_first = 0, 0, None
            return
        if self.amplitude > self.floor_snr * self.noise:
            self._below_since = None
            return
        if self._below_since is None:
            self._below_since = t0
        hold = self.hold_min_s
        if self.period is not None:
            hold = max(hold, self.hold_periods * self.period)
        if t1 - self._below_since >= hold:
            self.state, self.end_time = DONE, self._below_since

    def _crossings_in(self, x: np.ndarray, t0: float, t1: float, var: np.ndarray) -> None:
        """Count zero crossings of the release axis (hysteresis 2σ) while above the floor."""
        if self.amplitude <= 5 * self.noise:
            return
        h = 2.0 * self.noise
        span = (t1 - t0) / max(x.size, 1)
        for i in np.flatnonzero(np.abs(x) > h):
            sign = 1 if x[i] > 0 else -1
            if sign != self._sign:
                if self._sign != 0:
                    when = t0 + i * span
                    self._crossings += 1
                    self._cross_first = when if self._cross_first is None else self._cross_first
                    self._cross_last = when
                self._sign = sign
        if self._crossings >= 4 and self._cross_last > self._cross_first:
            self.period = 2.0 * (self._cross_last - self._cross_first) / (self._crossings - 1)


class LiveLine:
    """One status line on ``stream`` (stderr): overwritten in place and at most every
    ``interval`` seconds on a terminal (``tty``, default ``stream.isatty()``); elsewhere only
    the final line; nothing when not ``enabled``."""

    def __init__(self, stream, *, enabled: bool = True, tty: bool | None = None,
                 interval: float = 0.25, clock=time.monotonic) -> None:
        self.stream, self.enabled = stream, enabled
        if tty is None:
            try:
                tty = bool(stream.isatty())
            except (AttributeError, ValueError, OSError):
                tty = False
        self.tty, self.interval, self.clock = tty, interval, clock
        self._last = -math.inf
        self._width = 0

    @staticmethod
    def render(elapsed: float, amplitude: float, state: str) -> str:
        """The line: elapsed time [s], current amplitude [m/s²], state."""
        return f"recording {elapsed:7.1f} s   amplitude {amplitude:8.3g} m/s²   {state}"

    def _write(self, text: str, end: str) -> None:
        try:
            self.stream.write(text + end)
            self.stream.flush()
        except (OSError, ValueError):  # a closed or broken stderr must not stop the recording
            self.enabled = False

    def show(self, elapsed: float, amplitude: float, state: str, force: bool = False) -> bool:
        """Redraw the line if on a terminal and ``interval`` has passed (or ``force``); whether
        it was drawn."""
        if not (self.enabled and self.tty):
            return False
        now = self.clock()
        if not force and now - self._last < self.interval:
            return False
        self._last = now
        line = self.render(elapsed, amplitude, state)
        self._write("\r" + line.ljust(self._width), "")
        self._width = len(line)
        return True

    def status(self, text: str) -> None:
        """Replace the live line by ``text`` (on a terminal only; no newline): what happens
        next, until :meth:`finish` or :meth:`finish_quietly`."""
        if self.enabled and self.tty:
            self._write("\r" + text.ljust(self._width), "")
            self._width = len(text)

    def finish_quietly(self) -> None:
        """Erase the live line (on a terminal) and write nothing: an error line follows."""
        if self.enabled and self.tty and self._width:
            self._write("\r" + " " * self._width + "\r", "")
            self._width = 0

    def finish(self, text: str) -> None:
        """End the live line (on a terminal) and write ``text`` as a line of its own."""
        if not self.enabled:
            return
        if self.tty and self._width:
            self._write("\r" + " " * self._width + "\r", "")
            self._width = 0
        self._write(text, "\n")
