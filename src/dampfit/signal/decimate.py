r"""Long recordings reduced to the rate the analysis can use, before anything else sees them.

A recording of more than :data:`DECIMATE_ABOVE` samples (the longest real recording in the
project's test data has 1.2e5; 10 M samples is 5.6 h at 500 Hz) costs far more memory in the
preparation (spectra zero-padded 4×, the grid, filters, envelope: ≈ 340 bytes a sample,
3.4 GiB at 10 M) than its samples carry information about a decay: the damped oscillation
lives in a band [f₀/1.5, 1.5·f₀] (:func:`dampfit.signal.spectrum.auto_band`) and a rate of
:data:`RATE_FACTOR` × the band's top keeps it, its harmonics up to ≈ 10·f₀ and ≥ 20 samples
a period for the spike and window detectors, with nothing in the band lost (Nyquist–Shannon;
the model's parameters are carried by the band, the Whittle argument of
:mod:`dampfit.inference.noise`).

So :func:`reduce`:

1. finds the dominant frequency f̂ from a Welch spectrum summed over the axes, computed over
   chunks of :data:`CHUNK` samples (memory bounded by the chunk), searched from 4 cycles in
   the record (≥ 0.1 Hz) to 0.45·f_s as :func:`dampfit.signal.prepare.prepare` does; with a
   ``band`` its top is used instead of 1.5·f̂;
2. chooses the integer factor q = ⌊f_s / (RATE_FACTOR · f_top)⌋ (nothing is done for q < 2);
3. per continuous segment (:attr:`~dampfit.io.recording.Recording.segments`): drops stale
   repeats (as prepare's step 1 would: their time is unknown), places irregular stamps on a
   uniform grid at the median rate (cubic spline, chunk by chunk), and decimates with
   :func:`scipy.signal.resample_poly` (polyphase FIR anti-aliasing, Kaiser window, linear
   phase: the sample at index i·q of the input is at the input's time i·q); decimated
   samples within the filter's reach of a clipped input sample are dropped (a saturated
   run is not the signal; prepare could not find it after the low-pass).

Impact spikes are left to prepare's detectors on the decimated samples (the low-pass spreads
a one-sample spike over ≈ 20 output samples, which are masked as one event). A recording
whose useful rate still leaves more than :data:`MAX_ANALYSED` samples cannot be analysed in
≈ 2 GB: that is a one-line :class:`~dampfit.errors.InputError`. The original recording
(its path, digest, sample count) is what the summary's ``input`` reports, with
``input.decimated`` saying what was done and a warning line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import interpolate, ndimage, signal

from dampfit.errors import InputError
from dampfit.io.recording import Recording
from dampfit.signal import masks

#: A recording of at most this many samples is analysed as read (every result up to this
#: size is the same as before decimation existed).
DECIMATE_ABOVE = 1_000_000
#: The rate kept, as a multiple of the top of the band [1] (24 × f₀ for the automatic band).
RATE_FACTOR = 16.0
#: Most samples analysed after the reduction: ≈ 1.6 GB at the measured ≈ 340 bytes a sample
#: of the preparation plus the ≈ 0.5 GB of the libraries (paper/results/bench_memory.json).
MAX_ANALYSED = 3_000_000
#: Samples per chunk of the Welch spectrum and of the spline onto the uniform grid.
CHUNK = 1 << 20
#: Welch segment length [samples]: a resolution of f_s / 65536.
NPERSEG = 1 << 16
#: Stamps regular to this relative step deviation are taken as the uniform grid itself.
REGULAR = 1e-6


@dataclass(frozen=True)
class Decimation:
    """What :func:`reduce` did: rates [Hz], the factor, sample counts and the frequency
    [Hz] that set the rate."""

    factor: int
    from_hz: float
    to_hz: float
    n_read: int
    n_analysed: int
    top_hz: float
    n_clipped_dropped: int
    n_stale_dropped: int

    def summary(self) -> dict:
        """summary.json's ``input.decimated`` (:mod:`dampfit.result.schema`)."""
        return {"factor": self.factor, "from_hz": self.from_hz, "to_hz": self.to_hz,
                "n_samples_read": self.n_read, "n_samples_analysed": self.n_analysed,
                "band_top_hz": self.top_hz, "n_clipped_dropped": self.n_clipped_dropped,
                "n_stale_dropped": self.n_stale_dropped, "method": "scipy.signal.resample_poly"}

    def warning(self) -> str:
        """The one warning line of the summary and the report."""
        return (f"the recording ({self.n_read} samples at {self.from_hz:.6g} Hz) was decimated "
                f"by {self.factor} to {self.to_hz:.6g} Hz ({self.n_analysed} samples) before the "
                f"analysis: {RATE_FACTOR:g}x the band's top ({self.top_hz:.4g} Hz) keeps the decay; "
                f"recordings of more than {DECIMATE_ABOVE} samples are decimated")


def reduce(rec: Recording, band: tuple[float, float] | None = None
           ) -> tuple[Recording, Decimation | None]:
    """``rec`` at the rate the analysis can use (module docstring), and what was done (None
    when ``rec`` has at most :data:`DECIMATE_ABOVE` samples or cannot be decimated by 2)."""
    n = rec.n_samples
    if n <= DECIMATE_ABOVE:
        return rec, None
    fs = rec.sample_rate
    top = float(band[1]) if band is not None else 1.5 * _peak_frequency(rec, fs)
    q = math.floor(fs / (RATE_FACTOR * top))
    if q < 2:
        _refuse_above_max(n, fs, top, fs)
        return rec, None
    clipped = masks.clipped(rec.accel)
    stale = masks.stale_mask(rec.accel)
    drop_stale = stale.mean() > masks.STALE_FRACTION
    times, accels, starts, n_clip = [], [], [], 0
    for i, j in rec.segments:
        keep = ~stale[i:j] if drop_stale else np.ones(j - i, dtype=bool)
        if keep.sum() < 4 * q * 10 + 16:  # shorter than the filter's reach: left out
            continue
        t, a, bad = _decimated(rec.time[i:j][keep], rec.accel[i:j][keep], clipped[i:j][keep],
                               fs, q)
        n_clip += int(bad.sum())
        starts.append(sum(x.size for x in times))
        times.append(t[~bad])
        accels.append(a[~bad])
    if not times:
        return rec, None
    t, a = np.concatenate(times), np.concatenate(accels)
    _refuse_above_max(t.size, fs, top, fs / q)
    out = Recording(t, a, rec.axes, path=rec.path, format=rec.format,
                    gravity_removed=rec.gravity_removed, notes=rec.notes, sha256=rec.sha256,
                    time_unit=rec.time_unit, time_unit_source=rec.time_unit_source,
                    read_options=rec.read_options, breaks=tuple(starts[1:]))
    return out, Decimation(factor=q, from_hz=fs, to_hz=fs / q, n_read=n, n_analysed=t.size,
                           top_hz=top, n_clipped_dropped=n_clip,
                           n_stale_dropped=int(stale.sum()) if drop_stale else 0)


def _refuse_above_max(n: int, fs: float, top: float, rate: float) -> None:
    if n > MAX_ANALYSED:
        raise InputError(
            f"{n} samples at {rate:.6g} Hz are more than the {MAX_ANALYSED} that can be analysed "
            f"in about 2 GB, and the oscillation (band top {top:.4g} Hz, recorded at {fs:.6g} Hz) "
            "needs that rate; cut the recording to its free decay")


def _peak_frequency(rec: Recording, fs: float) -> float:
    """Step 1: the peak [Hz] of the Welch power summed over axes, accumulated chunk by chunk."""
    n = rec.n_samples
    nper = min(NPERSEG, n)
    total = None
    for i in range(0, n, CHUNK):
        block = rec.accel[i:i + CHUNK]
        if block.shape[0] < nper:
            break
        f, p = signal.welch(block, fs, nperseg=nper, detrend="linear", axis=0)
        p = p.sum(axis=1) * block.shape[0]
        total = p if total is None else total + p
    fmin = max(0.1, 4.0 / max(rec.duration, 1e-9), 2.0 * fs / nper)
    sel = np.flatnonzero((f >= fmin) & (f <= 0.45 * fs))
    if total is None or sel.size < 3:
        raise InputError("the recording is too short for its sample rate to find an oscillation")
    return float(f[sel[np.argmax(total[sel])]])


def _decimated(t: np.ndarray, a: np.ndarray, clipped: np.ndarray, fs: float, q: int):
    """Step 3 for one segment: (times [s], acceleration [m/s²] at fs/q, the decimated samples
    within the filter's reach of a clipped input sample)."""
    dt = np.diff(t)
    if np.max(np.abs(dt * fs - 1.0)) > REGULAR:  # irregular stamps: onto the uniform grid
        grid = t[0] + np.arange(math.floor((t[-1] - t[0]) * fs) + 1) / fs
        grid = grid[grid <= t[-1]]
        a = _spline_in_chunks(t, a, grid)
        clipped = np.interp(grid, t, clipped.astype(float)) > 0
        t = grid
    offset = np.median(a, axis=0)  # the filter's edges see a signal about zero
    y = signal.resample_poly(a - offset, 1, q, axis=0) + offset
    tq = t[::q][: y.shape[0]]
    reach = 10 * q + 1  # resample_poly's FIR half-length (10·max(up, down) taps)
    near = np.zeros(tq.size, dtype=bool)
    if clipped.any():
        near = ndimage.maximum_filter1d(clipped.astype(np.uint8), 2 * reach + 1)[::q][: tq.size] > 0
    return tq, y[: tq.size], near


def _spline_in_chunks(t: np.ndarray, a: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Cubic spline of ``a`` (n, axes) at times ``t`` [s] evaluated on ``grid`` [s], fitted
    chunk by chunk with 64 samples of overlap (memory of a chunk, not of the record)."""
    out = np.empty((grid.size, a.shape[1]))
    pad = 64
    for i in range(0, t.size, CHUNK):
        lo, hi = max(i - pad, 0), min(i + CHUNK + pad, t.size)
        g0 = np.searchsorted(grid, t[i])
        g1 = np.searchsorted(grid, t[min(i + CHUNK, t.size - 1)], side="right") \
            if i + CHUNK < t.size else grid.size
        spline = interpolate.make_interp_spline(t[lo:hi], a[lo:hi], k=3, axis=0)
        out[g0:g1] = spline(grid[g0:g1])
    return out
