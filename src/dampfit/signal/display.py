"""Long signals reduced for display: the bounded arrays a figure of a whole recording needs.

A figure cannot show more points than its pixel columns, and the figure arrays kept in a result
folder's ``signals.npz`` (:func:`dampfit.stages.figure_signals`) must stay small whatever the
recording's length, so long lines are reduced here, keeping what the eye sees:

* :func:`keep_extremes` — at most ~``max_points`` points of a line, each bucket's minimum and
  maximum kept (the visual envelope of a dense oscillation; plain striding would alias it);
* :func:`robust_limits` — y limits [unit of y] of the finite values with a margin;
* :func:`runs`, :func:`bounded_runs` — contiguous runs (start, end) [s] of sorted times, e.g.
  of masked samples (at most :data:`MAX_RUNS` + 1 of them);
* :func:`distance_to` — distance [s] from each time to the nearest of a set of times;
* :func:`spectrum_limit` — the highest frequency [Hz] a spectrum figure shows;
* :func:`zoom_ranges` — the first and last few cycles of a span, the zooms of a fit figure.

Pure NumPy: no plotting here.
"""

from __future__ import annotations

import numpy as np

#: Most points drawn per line (longer lines are reduced by min/max per bucket): 2 000 buckets,
#: more than the pixel columns of the widest axes (10.5 in) at the default 110 dpi.
MAX_LINE_POINTS = 4_000
#: Most samples drawn as dots (same reduction) and most points of the model curve's grid.
MAX_DOTS = 20_000
#: Most shaded runs of masked samples kept for a figure (closer runs are merged beyond it).
MAX_RUNS = 2_000
#: Cycles shown in each zoom panel of a fit (:func:`zoom_ranges`).
ZOOM_CYCLES = 5.0


def keep_extremes(t: np.ndarray, y: np.ndarray,
                  max_points: int = MAX_LINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)`` as float arrays with at most ``2·(max_points // 2) + 2`` points: the samples
    split into ``max_points // 2`` buckets of consecutive samples, each bucket's minimum and
    maximum of ``y`` kept (and the first and last sample), in their order. Shorter lines are
    returned whole. The global extremes of ``y`` are always kept."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    n = t.size
    if n <= max_points:
        return t, y
    n_buckets = max(1, max_points // 2)
    edges = np.linspace(0, n, n_buckets + 1).astype(int)
    starts = edges[:-1]
    lens = np.diff(edges)
    m = int(lens.max())
    idx = np.minimum(starts[:, None] + np.arange(m)[None, :], n - 1)
    valid = np.arange(m)[None, :] < lens[:, None]
    block = np.where(valid, y[idx], np.nan)
    i_min = starts + np.nanargmin(block, axis=1)
    i_max = starts + np.nanargmax(block, axis=1)
    keep = np.unique(np.concatenate([i_min, i_max, [0, n - 1]]))
    return t[keep], y[keep]


def robust_limits(y: np.ndarray, pad: float = 0.08) -> tuple[float, float] | None:
    """(low, high) of the finite values of ``y`` widened by ``pad`` of their range on each side
    (± 1 around a constant); None when none is finite."""
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return None
    lo, hi = float(y.min()), float(y.max())
    if hi <= lo:
        hi, lo = lo + 1.0, lo - 1.0
    d = pad * (hi - lo)
    return lo - d, hi + d


def runs(t: np.ndarray, gap: float) -> list[tuple[float, float]]:
    """Contiguous runs (start, end) [s] of sorted times ``t`` split where a step exceeds
    ``gap`` [s]."""
    t = np.asarray(t, float)
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) > gap)
    starts = np.concatenate([[0], cut + 1])
    ends = np.concatenate([cut, [t.size - 1]])
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, ends)]


def bounded_runs(t: np.ndarray, gap: float, max_runs: int = MAX_RUNS) -> list[tuple[float, float]]:
    """:func:`runs` of ``t`` split at steps over ``gap`` [s]; when that gives more than
    ``max_runs`` runs, split only at steps over span/``max_runs`` instead (at most
    ``max_runs + 1`` runs: every split step is longer than that)."""
    out = runs(t, gap)
    if len(out) > max_runs:
        t = np.asarray(t, float)
        out = runs(t, max(gap, float(t[-1] - t[0]) / max_runs))
    return out


def zoom_ranges(t_start: float, t_end: float, f0: float,
                cycles: float = ZOOM_CYCLES) -> list[tuple[float, float]]:
    """The first and the last ``cycles`` cycles of frequency ``f0`` [Hz] in the span
    ``t_start``–``t_end`` [s]: two (start, end) ranges [s], each at most the span."""
    zoom = cycles / max(f0, 1e-12)
    return [(t_start, min(t_start + zoom, t_end)), (max(t_end - zoom, t_start), t_end)]


def spectrum_limit(f0: float, high: float, fs: float) -> float:
    """Highest frequency [Hz] a spectrum figure shows: max(4·f₀, 2·``high``) for the dominant
    frequency ``f0`` [Hz] and the band's upper edge ``high`` [Hz], at most fs/2 (``fs``
    [Hz] the sample rate)."""
    return min(max(4.0 * f0, 2.0 * high), 0.5 * fs)


def distance_to(t_sorted: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Distance from each ``x`` to the nearest of the sorted times ``t_sorted`` (inf if none)."""
    if t_sorted.size == 0:
        return np.full(np.shape(x), np.inf)
    j = np.searchsorted(t_sorted, x)
    left = t_sorted[np.clip(j - 1, 0, t_sorted.size - 1)]
    right = t_sorted[np.clip(j, 0, t_sorted.size - 1)]
    return np.minimum(np.abs(x - left), np.abs(right - x))
