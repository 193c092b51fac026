"""Which samples of a recording are not measurements of the motion (:mod:`dampfit.signal.prepare`
steps 1, 5 and 6): stale repeats of a sensor polled faster than its output rate
(:func:`stale_mask`), samples held at a saturated level (:func:`clipped`), impact spikes
against a local cubic (:func:`spikes`, needs f₀) and gross spikes against the signal's own
scale on both sides (:func:`gross_spikes`, needs no f₀). Pure NumPy/SciPy, no I/O.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, signal

from dampfit.signal.window import running_median

#: Fraction of exactly repeated samples above which repeats are treated as stale reads.
STALE_FRACTION = 0.10
#: Robust z-score above which a sample deviating from its running median is a spike.
SPIKE_SIGMA = 8.0
#: A sample more than this many times the signal's robust local scale on both sides away from
#: its running median is a gross spike, whatever the frequency (an oscillation's samples stay
#: within ≈ 1 scale).
GROSS_SPIKE = 20.0
#: A candidate gross spike after which the signal's scale stays this many times the scale
#: before it is the onset of an oscillation (a release), not a spike.
ONSET_RATIO = 4.0
#: A gross spike is isolated: at most this many such samples among the 2·GROSS_RUN² + 1
#: around it.
GROSS_RUN = 3


def stale_mask(accel: np.ndarray) -> np.ndarray:
    """True for samples identical on every axis to the previous one."""
    rep = np.zeros(len(accel), dtype=bool)
    rep[1:] = np.all(accel[1:] == accel[:-1], axis=1)
    return rep


def clipped(a: np.ndarray) -> np.ndarray:
    """True for samples stuck at the extreme value of their axis (saturation)."""
    out = np.zeros(a.shape[0], dtype=bool)
    for col in a.T:
        for level in (col.max(), col.min()):
            at = np.isclose(col, level, rtol=0, atol=1e-9 * max(1.0, abs(level)))
            # saturation: the extreme value held on consecutive samples, in two or more runs
            held = at[1:] & at[:-1]
            n_runs = int(np.sum(held[1:] & ~held[:-1]) + held[0]) if held.size else 0
            if n_runs >= 2:
                out |= at
    return out


def spikes(y: np.ndarray, fs: float, f0: float) -> np.ndarray:
    """True for impact spikes: deviations > SPIKE_SIGMA local robust σ from a local cubic.

    The local cubic (Savitzky–Golay over ~1/6 period) follows a well-sampled oscillation;
    the robust scale (MAD of the deviations over two periods) follows its amplitude, so
    only isolated outliers stand out. With fewer than 12 samples per period the test
    would flag the oscillation itself and is skipped.
    """
    per = fs / f0
    if per < 12 or len(y) < 4 * per:
        return np.zeros(len(y), dtype=bool)
    k = max(5, int(per / 6) | 1)
    r = y - signal.savgol_filter(y, k, 3)
    local = 1.4826 * ndimage.median_filter(np.abs(r), size=int(2 * per) | 1, mode="nearest")
    scale = np.maximum(local, 1e-3 * np.max(local) + 1e-15)
    hit = np.abs(r) > SPIKE_SIGMA * scale
    return ndimage.binary_dilation(hit, iterations=2)


def gross_spikes(a: np.ndarray, span: int) -> np.ndarray:
    """True for isolated samples of ``a`` (n, n_axes) [m/s²] that stand more than
    :data:`GROSS_SPIKE` × the signal's robust scale away from its running median, the scale
    taken over ``span`` samples on *both* sides (the larger): an isolated spike is an outlier
    against both, the onset of an oscillation only against the quiet side before it, and a
    short ring in a quiet record has many such samples (:data:`GROSS_RUN`). Needs no
    frequency: ``span`` is at least a period of the lowest frequency searched."""
    out = np.zeros(a.shape[0], dtype=bool)
    h = max(1, span // 2)
    if a.shape[0] < 4 * h:
        return out
    for col in np.asarray(a, float).T:
        med = running_median(col, 2 * h + 1, "mirror")
        dev = np.abs(col - med)
        scale = 1.4826 * running_median(dev, 2 * h + 1, "mirror")  # centred: [i − h, i + h]
        left = np.concatenate([np.full(h, scale[0]), scale[:-h]])  # ends at i
        right = np.concatenate([scale[h:], np.full(h, scale[-1])])  # starts at i
        both = np.maximum(np.maximum(left, right), 1e-12 * max(float(dev.max()), 1e-300))
        far = dev > GROSS_SPIKE * both
        # isolated: at most GROSS_RUN such samples among the 2·GROSS_RUN² + 1 around it (a
        # short ring in a quiet record also stands far above both medians, but for many samples)
        near = ndimage.uniform_filter1d(far.astype(float), 2 * GROSS_RUN**2 + 1, mode="constant")
        isolated = far & (near * (2 * GROSS_RUN**2 + 1) <= GROSS_RUN + 0.5)
        out |= isolated & ~_onsets(isolated, far, dev, left)
    return out


def _onsets(candidates: np.ndarray, far: np.ndarray, dev: np.ndarray,
            left: np.ndarray) -> np.ndarray:
    """True for the candidate gross spikes after which the signal stays in a louder regime:
    the robust scale of the next GROSS_RUN² samples (other far samples left out) is more than
    :data:`ONSET_RATIO` × the scale before the sample. A glitch returns at once to the scale
    around it; the release of a fast, heavily damped oscillation (20 Hz, ζ = 0.08 at 60 Hz:
    three samples a period, so its first peak alone clears the threshold) does not."""
    out = np.zeros(dev.size, dtype=bool)
    run = GROSS_RUN**2
    for i in np.flatnonzero(candidates):
        after = dev[i + 1:i + 1 + run][~far[i + 1:i + 1 + run]]
        out[i] = after.size > 0 and 1.4826 * np.median(after) > ONSET_RATIO * left[i]
    return out
