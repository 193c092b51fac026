"""Figures of an :class:`~dampfit.analysis.Analysis` (PNG files for the report).

Every figure has its own function returning a :class:`matplotlib.figure.Figure` built with
the object API (no pyplot, no global state), so a report can reuse it; :func:`save_figures`
writes them all:

* ``signal`` — :func:`signal_figure`: raw axes, selected signal, window, masked samples;
* ``spectrum`` — :func:`spectrum_figure`: amplitude spectrum (linear and dB), band, f₀, |H|²
  and the spectrum after the band-pass (the seed paper's Figs 15–17, 19);
* ``fit`` — :func:`fit_figure`: fitted samples, least-squares model, zooms, residuals;
* ``displacement`` — :func:`displacement_figure`: the paper's envelope pipeline (its Fig. 20)
  against the least-squares envelope;
* ``posterior`` — :func:`posterior_figure`: corner plot of (c, k, u₀), or (ζ, f_n, u₀)
  without a mass;
* ``trace`` — :func:`trace_figure`: walker traces and marginal densities.
* ``amplitude`` — :func:`amplitude_figure`: ζ(A) (windowed ζ with its 90 % band and each
  damping law's ζ_eq(a)) and the f(A) backbone (windowed damped frequency with its 90 %
  band), written when the analysis assessed the damping laws (always with
  :func:`dampfit.analyze`).

matplotlib is imported inside the functions only: the numeric core never needs it.

Drawing is the larger part of ``dampfit analyze --report`` after the analysis, so the figures
are drawn cheaply with the same content: fixed layouts computed from the measured labels (no
layout engine), tick labels without mathtext, posterior densities evaluated by binning
(:func:`_contours`, :func:`_density`), long lines reduced to a few points per pixel column, one
Agg draw per figure written as an RGB PNG (:func:`write_png`), and :func:`save_figures` /
:func:`render` run inside :func:`drawing` (garbage collector paused, BLAS on one thread).
``paper/figure_benchmark.py`` times them.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any
from collections.abc import Callable

import numpy as np

from dampfit import physics
from dampfit.files.atomic import atomic_write

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from dampfit.analysis import Analysis

__all__ = [
    "save_figures",
    "amplitude_figure",
    "signal_figure",
    "spectrum_figure",
    "fit_figure",
    "displacement_figure",
    "posterior_figure",
    "trace_figure",
    "FIGURES",
]

#: Most points drawn per line (longer lines are reduced by min/max per bucket): 2 000 buckets,
#: more than the pixel columns of the widest axes (10.5 in) at the default 110 dpi.
MAX_LINE_POINTS = 4_000
#: Most samples drawn as dots (same reduction) and most points of the model curve's grid.
MAX_DOTS = 20_000
#: Most points drawn in one scatter (random subsample).
MAX_SCATTER_POINTS = 4_000
#: Cycles shown in each zoom panel of the fit figure.
ZOOM_CYCLES = 5.0

#: Symbol and unit (:data:`dampfit.physics.UNITS`, "N s/m" drawn as "N·s/m") of each quantity.
_LABELS = {
    name: (sym, physics.UNITS[name].replace(" ", "·"))
    for name, sym in (("c", "c"), ("k", "k"), ("u0", "u₀"), ("zeta", "ζ"), ("f_n", "f_n"),
                      ("p", "p"), ("f_d", "f_d"), ("delta", "δ"), ("mass", "m"),
                      ("omega_d", "ω_d"))
}
_AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown")


# ----------------------------------------------------------------------------- layout
# Every figure has a fixed layout: the margins and gaps [in] are computed from what occupies
# them (the suptitle, axes titles, legends drawn above an axes, tick labels, axis labels; tick
# labels measured from the formatted strings) and set as gridspec parameters before drawing.
# matplotlib's constrained layout would find them by measuring every artist of every axes in
# two extra passes per savefig, about half of the figure stage's time. Titles sit at a fixed
# height (``y=1``: matplotlib's automatic title placement measures the y axis once more per
# titled axes and draw) and are lifted where a y-axis offset text (×10ⁿ) takes their place.

_PT = 1.0 / 72.0  # [in] per typographic point
_EDGE = 5 * _PT  # free border of the figure [in]
_TICK = 7 * _PT  # tick length + tick-label pad [in] (matplotlib's 3.5 + 3.5 pt)
_LABEL_PAD = 4 * _PT  # axis label pad [in] (rcParams["axes.labelpad"])
_TITLE_PAD = 6.0  # title above the axes [pt] (rcParams["axes.titlepad"])
_SIZE = 10.0  # tick labels, axis labels and titles [pt] unless set
_SUPTITLE = 12.0  # suptitle [pt] ("large")


def _new_figure(width: float, height: float) -> "Figure":
    """An empty ``width`` × ``height`` [in] figure without a layout engine (see above)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def _line(size: float = _SIZE) -> float:
    """Height [in] of one line of text of ``size`` [pt]."""
    return 1.25 * size * _PT


def _text_width(s: str, size: float = _SIZE) -> float:
    """Width [in] of ``s`` at ``size`` [pt] in the default font; mathtext is measured as its
    characters at full size (an upper bound: superscripts are smaller)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import text_to_path

    if "$" in s:
        for a, b in (("\\mathdefault", ""), ("\\times", "×"), ("\\cdot", "·"), ("$", ""),
                     ("{", ""), ("}", ""), ("^", ""), ("\\", "")):
            s = s.replace(a, b)
    if not s:
        return 0.0
    w, _, _ = text_to_path.get_text_width_height_descent(s, FontProperties(size=size), False)
    return w * _PT


def _tick_texts(axis, minor: bool = False, interval=None) -> tuple[list[str], str]:
    """The tick labels ``axis`` will draw in its current view (or ``interval``), and its offset
    text (×10ⁿ)."""
    lo, hi = sorted(axis.get_view_interval() if interval is None else interval)
    loc = axis.get_minor_locator() if minor else axis.get_major_locator()
    fmt = axis.get_minor_formatter() if minor else axis.get_major_formatter()
    tol = 1e-9 * (hi - lo) if hi > lo else 0.0
    locs = [v for v in loc.tick_values(lo, hi) if lo - tol <= v <= hi + tol]
    labels = fmt.format_ticks(locs) if locs else []
    offset = fmt.get_offset() if hasattr(fmt, "get_offset") and locs else ""
    return [t for t in labels if t], offset


def _ticks_width(axis, size: float = _SIZE) -> float:
    """Width [in] of the widest tick label of ``axis`` (major and, on a log axis, minor)."""
    texts = _tick_texts(axis)[0]
    if axis.get_scale() == "log":
        texts += _tick_texts(axis, minor=True)[0]
    return max((_text_width(t, size) for t in texts), default=0.0)


def _y_room(axes, size: float = _SIZE, label: bool = True, labels=()) -> float:
    """Room [in] beside the y axes ``axes`` for their tick labels (and ``labels``; ``size``
    [pt]) and an axis label."""
    width = max([_ticks_width(ax.yaxis, size) for ax in axes]
                + [_text_width(t, size) for t in labels] + [0.0])
    return _EDGE + _TICK + width + (_LABEL_PAD + _line() if label else 0.0)


def _x_room(size: float = _SIZE, label: bool = True) -> float:
    """Room [in] below an x axis for one line of tick labels (``size`` [pt]) and a label."""
    return _EDGE + _TICK + _line(size) + (_LABEL_PAD + _line() if label else 0.0)


def _offset(axis) -> str:
    """The offset text (×10ⁿ, +c) ``axis`` will draw, or ``""``."""
    return _tick_texts(axis)[1]


def _above(ax, title_size: float | None = _SIZE, legend_rows: int = 0, legend_size=8.0,
           offset_size: float = _SIZE) -> float:
    """Height [in] of the strip above ``ax``: its title (``title_size`` [pt], None: none), a
    legend of ``legend_rows`` rows placed above it (:func:`_legend_above`) and the y-axis offset
    text; a title is lifted over an offset text (:func:`_lift_titles`)."""
    title = _TITLE_PAD * _PT + _line(title_size) if title_size else 0.0
    off = _line(offset_size) + 3 * _PT if _offset(ax.yaxis) else 0.0
    if off and title:
        _lift_titles(ax, off, title_size)
    legend = (legend_rows * _line(legend_size) + (legend_rows - 1) * 0.5 * legend_size * _PT
              + 1.0 * legend_size * _PT) if legend_rows else 0.0
    return max(title + off, legend, off)


def _title(ax, text: str, loc: str = "center", size: float = _SIZE):
    """Axes title at a fixed height (no automatic placement; see the layout notes)."""
    return ax.set_title(text, loc=loc, fontsize=size, y=1.0, pad=_TITLE_PAD)


def _lift_titles(ax, lift: float, size: float = _SIZE) -> None:
    """Raise the titles of ``ax`` (set by :func:`_title` at ``size`` [pt]) by ``lift`` [in],
    over the y-axis offset text."""
    for loc in ("left", "center", "right"):
        text = ax.get_title(loc)
        if text:
            ax.set_title(text, loc=loc, fontsize=size, y=1.0, pad=_TITLE_PAD + lift / _PT)


def _suptitle(fig, text: str) -> None:
    """Figure title at the top edge (:data:`_EDGE`)."""
    fig.suptitle(text, y=1.0 - _EDGE / fig.get_figheight(), va="top", fontsize=_SUPTITLE)


def _top(extra: float = 0.0) -> float:
    """Top margin [in]: the suptitle and a strip of ``extra`` [in] above the first axes."""
    return _EDGE + _line(_SUPTITLE) + 3 * _PT + extra


def _place(gs, *, left: float, right: float, top: float, bottom: float, hgap: float = 0.0,
           wgap: float = 0.0) -> None:
    """Put gridspec ``gs`` at ``left``, ``right``, ``top``, ``bottom`` [in] from the figure's
    edges, with ``hgap`` [in] between rows and ``wgap`` [in] between columns."""
    width, height = gs.figure.get_size_inches()
    nrows, ncols = gs.get_geometry()
    w, h = width - left - right, height - top - bottom
    gs.update(left=left / width, right=1.0 - right / width, bottom=bottom / height,
              top=1.0 - top / height,
              hspace=hgap * nrows / max(h - hgap * (nrows - 1), 1e-6) if nrows > 1 else 0.0,
              wspace=wgap * ncols / max(w - wgap * (ncols - 1), 1e-6) if ncols > 1 else 0.0)
    fig = gs.figure  # GridSpec.update moves the axes of pyplot's figures only
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        if spec is not None and spec.get_topmost_subplotspec().get_gridspec() is gs:
            ax.set_position(spec.get_position(fig))


def _gridspec(ax):
    return ax.get_subplotspec().get_gridspec()


def _spans(size: float, start: float, end: float, ratios, gaps) -> list[tuple[float, float]]:
    """Margins (from the start, from the end) [in] of cells laid out along a figure side of
    ``size`` [in] inside margins ``start`` and ``end`` [in], with sizes in ``ratios`` and
    ``gaps`` [in] between consecutive cells (rows from the top, columns from the left)."""
    unit = (size - start - end - sum(gaps)) / sum(ratios)
    out, y = [], start
    for i, r in enumerate(ratios):
        out.append((y, size - y - r * unit))
        y += r * unit + (gaps[i] if i < len(gaps) else 0.0)
    return out


# ----------------------------------------------------------------------------- helpers


def _unit(name: str) -> str:
    """Unit of ``name`` as drawn (:data:`_LABELS`)."""
    return _LABELS[name][1]


def _label(name: str) -> str:
    sym, unit = _LABELS.get(name, (name, "1"))
    return f"{sym} [{unit}]"


def _reduce(t: np.ndarray, y: np.ndarray, max_points: int = MAX_LINE_POINTS):
    """``(t, y)`` with at most ~``max_points`` points, keeping each bucket's min and max.

    A min/max reduction keeps the visual envelope of a dense oscillation (plain striding
    would alias it).
    """
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


def _subsample(n: int, max_points: int, seed: int = 0) -> np.ndarray:
    if n <= max_points:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, max_points, replace=False))


def _fmt(x: float | None, digits: int = 4) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.{digits}g}"


def _fmt_interval(q05: float, q50: float, q95: float) -> str:
    """``median [q05, q95]`` with enough significant digits to resolve the interval."""
    width = abs(q95 - q05)
    scale = max(abs(q50), abs(q05), abs(q95))
    if not (np.isfinite(width) and np.isfinite(scale)) or width <= 0 or scale <= 0:
        return f"{_fmt(q50)}  [{_fmt(q05)}, {_fmt(q95)}]"
    d = int(np.clip(np.ceil(np.log10(scale / width)) + 1, 3, 12))

    def g(x: float) -> str:  # keep trailing zeros (1.72000), but not a bare point (619.)
        return f"{x:#.{d}g}".replace(".e", "e").rstrip(".")

    return f"{g(q50)}  [{g(q05)}, {g(q95)}]"


def _ls_values(an: "Analysis") -> dict[str, float]:
    """Least-squares physical values (:func:`dampfit.stages.ls_quantities`, i.e.
    :func:`dampfit.physics.quantities`; c, k and the mass only with a mass)."""
    from dampfit.stages import ls_quantities

    out = {name: float(v) for name, v in ls_quantities(an.least_squares, an.mass).items()}
    if an.mass is not None:
        out["mass"] = float(an.mass)
    return out


def _model_curve(an: "Analysis", n: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares model on a fine grid over the fitted span: (t [s], a [m/s²])
    (:func:`dampfit.stages.fitted_curve`)."""
    from dampfit.stages import fitted_curve

    return fitted_curve(an.fit_data, an.least_squares, n)


def _variables(an: "Analysis") -> list[str]:
    post = an.posterior.posterior
    names = ["c", "k", "u0"] if ("c" in post and "k" in post) else ["zeta", "f_n", "u0"]
    return [v for v in names if v in post]


def _recording_name(an: "Analysis") -> str:
    path = an.recording.path
    return Path(path).name if path else f"{an.recording.format} recording"


def _compact_ticks(ax, which: str = "both", n: int = 4) -> None:
    """At most ``n`` ticks; scientific notation with an offset (×10ⁿ + c) beyond 10⁻³–10⁴."""
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    axes = {"x": [ax.xaxis], "y": [ax.yaxis], "both": [ax.xaxis, ax.yaxis]}[which]
    for axis in axes:
        axis.set_major_locator(MaxNLocator(n))
        fmt = _unicode(ScalarFormatter)(useOffset=True, useMathText=True)
        fmt.set_powerlimits((-3, 4))
        axis.set_major_formatter(fmt)


def _log_ticks(axis) -> None:
    """Decade labels of a log ``axis`` (10⁻², 6×10⁻²) without mathtext (:func:`_unicode`)."""
    from matplotlib.ticker import LogFormatterSciNotation

    cls = _unicode(LogFormatterSciNotation)
    axis.set_major_formatter(cls(10.0))
    axis.set_minor_formatter(cls(10.0, labelOnlyBase=False))  # as matplotlib's log scale


_SUPERSCRIPT = str.maketrans("0123456789-−+", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁻⁺")


def _unmath(s: str) -> str:
    """Tick-label mathtext (``$\\mathdefault{6\\times10^{-2}}$``) as plain text with Unicode
    superscripts (``6×10⁻²``); anything else unchanged."""
    if "$" not in s:
        return s
    body = s.strip()
    if body.count("$") != 2 or body[0] != "$" or body[-1] != "$":
        return s
    body = body[1:-1].replace("\\mathdefault", "").replace("\\times", "×")
    body = re.sub(r"\^\{([0-9−+-]*)\}", lambda m: m.group(1).translate(_SUPERSCRIPT), body)
    body = body.replace("{", "").replace("}", "").replace(" × ", "×")
    return s if any(c in body for c in "\\^_$") else body


@functools.lru_cache(maxsize=None)
def _unicode(cls):
    """The matplotlib formatter class ``cls`` with its tick labels and offset text written
    without mathtext (:func:`_unmath`): the same text, but no mathtext parse per label (about
    10 ms each, and the parser's construction on first use)."""

    class Unicode(cls):
        def __call__(self, x, pos=None):
            return _unmath(super().__call__(x, pos))

        def get_offset(self):
            return _unmath(super().get_offset())

    Unicode.__name__ = Unicode.__qualname__ = f"Unicode{cls.__name__}"
    return Unicode


def _bins(n: int) -> int:
    """Histogram bins for ``n`` draws (Rice rule, 15–50)."""
    return int(np.clip(2.0 * max(n, 1) ** (1 / 3), 15, 50))


def _interval(x: np.ndarray) -> tuple[float, float, float]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return (np.nan, np.nan, np.nan)
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return float(q05), float(q50), float(q95)


# ----------------------------------------------------------------------------- figures
def _runs(t: np.ndarray, gap: float) -> list[tuple[float, float]]:
    """Contiguous runs (start, end) [s] of sorted times ``t`` split where a step exceeds ``gap``."""
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) > gap)
    starts = np.concatenate([[0], cut + 1])
    ends = np.concatenate([cut, [t.size - 1]])
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, ends)]


def _distance_to(t_sorted: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Distance from each ``x`` to the nearest of the sorted times ``t_sorted`` (inf if none)."""
    if t_sorted.size == 0:
        return np.full(np.shape(x), np.inf)
    j = np.searchsorted(t_sorted, x)
    left = t_sorted[np.clip(j - 1, 0, t_sorted.size - 1)]
    right = t_sorted[np.clip(j, 0, t_sorted.size - 1)]
    return np.minimum(np.abs(x - left), np.abs(right - x))


def _robust_limits(y: np.ndarray, pad: float = 0.08) -> tuple[float, float] | None:
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return None
    lo, hi = float(y.min()), float(y.max())
    if hi <= lo:
        hi, lo = lo + 1.0, lo - 1.0
    d = pad * (hi - lo)
    return lo - d, hi + d


def _legend_above(ax, ncols: int, *args, **kw) -> int:
    """Legend in the strip above the axes (right-aligned), so it never hides data; returns its
    number of rows (for :func:`_above`)."""
    leg = ax.legend(*args, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=ncols,
                    fontsize=8, frameon=False, borderaxespad=0.2, **kw)
    return -(-len(leg.texts) // max(ncols, 1))


def signal_figure(an: "Analysis") -> "Figure":
    """Raw axes and the selected signal over the whole recording; window and masked samples.

    The y range follows the usable samples; masked samples (clipped or impact spikes) outside
    it are drawn at the edge of the axes and their time spans are shaded.
    """
    prep = an.prepared
    fig = _new_figure(11.0, 7.0)
    ax_raw, ax_sel = fig.subplots(2, 1, sharex=True)
    w0, w1 = prep.window
    bad = ~np.asarray(prep.usable, bool)
    t_bad = prep.time[bad]
    dt = 1.0 / prep.fs
    # grid samples next to a masked sample do not set the y range
    grid_ok = _distance_to(t_bad, prep.grid) > 1.5 * dt

    names = an.recording.axes
    for j in range(prep.grid_raw.shape[1]):
        t, y = _reduce(prep.grid, prep.grid_raw[:, j])
        name = names[j] if j < len(names) else f"axis {j}"
        ax_raw.plot(t, y, lw=0.6, color=_AXIS_COLORS[j % len(_AXIS_COLORS)],
                    label=f"{name} (weight {prep.direction.get(name, float('nan')):+.3f})")
    ax_raw.set_ylabel("acceleration [m/s²]")
    _title(ax_raw, "Recorded axes (offset removed, uniform grid)", loc="left")
    lim_raw = _robust_limits(prep.grid_raw[grid_ok] if grid_ok.any() else prep.grid_raw)

    t, y = _reduce(prep.time, prep.signal)
    ax_sel.plot(t, y, lw=0.6, color="0.25", label=f"selected signal (axis {prep.axis})")
    te, ye = _reduce(prep.grid, prep.envelope)
    ax_sel.plot(te, ye, lw=0.9, color="tab:red", alpha=0.8, label="band-pass envelope")
    ax_sel.plot(te, -ye, lw=0.9, color="tab:red", alpha=0.8)
    lim_sel = _robust_limits(prep.signal[~bad] if (~bad).any() else prep.signal)
    if bad.any():
        yb = prep.signal[bad]
        if lim_sel is not None:
            yb = np.clip(yb, *lim_sel)
        ax_sel.plot(t_bad, yb, "x", color="magenta", ms=5, mew=1.2, clip_on=False,
                    label=f"masked: {prep.n_clipped} clipped, {prep.n_spikes} in spikes")
        for a, b in _runs(t_bad, 5 * dt):
            for ax in (ax_raw, ax_sel):
                ax.axvspan(a - dt, b + dt, color="magenta", alpha=0.25, lw=0)
    ax_sel.set_ylabel("acceleration [m/s²]")
    ax_sel.set_xlabel("time [s]")
    _title(ax_sel, "Selected / projected signal", loc="left")
    for ax, lim in ((ax_raw, lim_raw), (ax_sel, lim_sel)):
        ax.axvspan(w0, w1, color="tab:green", alpha=0.10, lw=0,
                   label=f"analysed window {w0:.2f}–{w1:.2f} s" if ax is ax_sel else None)
        ax.grid(alpha=0.3)
        ax.set_xlim(prep.grid[0], prep.grid[-1])
        if lim is not None:
            ax.set_ylim(lim)
    rows_raw = _legend_above(ax_raw, min(4, prep.grid_raw.shape[1]))
    rows_sel = _legend_above(ax_sel, 4)
    _suptitle(fig, f"Signal: {_recording_name(an)} — {prep.fs:.4g} Hz, "
                   f"{an.recording.duration:.4g} s, f₀ = {prep.f0:.4g} Hz")
    _place(_gridspec(ax_raw), left=_y_room([ax_raw, ax_sel]), right=0.2, bottom=_x_room(),
           top=_top(_above(ax_raw, legend_rows=rows_raw)),
           hgap=_above(ax_sel, legend_rows=rows_sel) + 4 * _PT)
    return fig


def spectrum_figure(an: "Analysis") -> "Figure":
    """Amplitude spectrum (linear and dB re peak) with the pass band, f₀ and the filter gain.

    The seed paper's Figs 15–17 and 19: the single-sided amplitude spectrum [m/s²] of the
    selected signal on a linear scale with the zero-phase band-pass gain |H|² [1] on a second
    axis; the same in dB re the spectral peak with |H|² [dB] and the spectrum after filtering
    (amplitude·|H|²); the pass band shaded and f₀ [Hz] marked in both panels.
    """
    from scipy import signal as sps

    from dampfit.signal.filters import bandpass_sos

    prep = an.prepared
    lo, hi = prep.band
    nyq = 0.5 * prep.fs
    fmax = min(max(4.0 * prep.f0, 2.0 * hi), nyq)
    sel = (prep.freqs > 0) & (prep.freqs <= fmax)
    f, amp = prep.freqs[sel], prep.amplitude[sel]
    f, amp = _reduce(f, amp)
    peak = float(np.max(amp)) if amp.size else 1.0
    db = 20 * np.log10(np.maximum(amp, 1e-12 * peak) / peak)

    sos = bandpass_sos(prep.band, prep.fs)
    fh = np.linspace(0, fmax, 2000)[1:]
    _, h = sps.sosfreqz(sos, worN=fh, fs=prep.fs)
    gain = np.abs(h) ** 2  # zero-phase (forward–backward): |H|²
    # the spectrum after the zero-phase band-pass is the spectrum times |H|² (the paper's Fig. 19)
    _, hf = sps.sosfreqz(sos, worN=f, fs=prep.fs) if f.size else (None, np.zeros(0))
    db_filt = 20 * np.log10(np.maximum(amp * np.abs(hf) ** 2, 1e-12 * peak) / peak)

    fig = _new_figure(10.0, 7.0)
    ax_lin, ax_db = fig.subplots(2, 1, sharex=True)
    ax_lin.plot(f, amp, lw=0.9, color="tab:blue", label="amplitude spectrum")
    ax_lin.set_ylabel("amplitude [m/s²]")
    ax_h = ax_lin.twinx()
    ax_h.plot(fh, gain, lw=1.0, ls="--", color="tab:purple", label="band-pass |H|² (zero-phase)")
    ax_h.set_ylabel("filter gain |H|² [1]", color="tab:purple")
    ax_h.tick_params(axis="y", colors="tab:purple")
    ax_h.set_ylim(0, 1.6)

    ax_db.plot(f, db, lw=0.9, color="tab:blue", label="amplitude re peak")
    ax_db.plot(f, db_filt, lw=0.9, color="tab:orange", alpha=0.9,
               label="after band-pass (amplitude·|H|²)")
    gdb = 20 * np.log10(np.maximum(gain, 1e-12))
    ax_db.plot(fh, gdb, lw=1.0, ls="--", color="tab:purple", label="band-pass |H|² [dB]")
    floor = float(np.percentile(db, 1)) if db.size else -100.0
    ax_db.set_ylim(max(floor - 10.0, -160.0), 10.0)
    ax_db.set_ylabel("level re peak [dB]")
    ax_db.set_xlabel("frequency [Hz]")

    for ax in (ax_lin, ax_db):
        ax.axvspan(lo, hi, color="tab:green", alpha=0.12, lw=0,
                   label=f"pass band {lo:.3g}–{hi:.3g} Hz" if ax is ax_db else None)
        ax.axvline(prep.f0, color="tab:red", lw=0.9, ls=":",
                   label=f"f₀ = {prep.f0:.4g} Hz" if ax is ax_db else None)
        ax.grid(alpha=0.3)
    ax_lin.set_xlim(0, fmax)
    lines = ax_lin.get_legend_handles_labels()
    lines_h = ax_h.get_legend_handles_labels()
    ax_lin.legend(lines[0] + lines_h[0], lines[1] + lines_h[1], loc="upper right", fontsize=8)
    ax_db.legend(loc="upper right", fontsize=8)
    _title(ax_lin, "Linear scale (paper Figs 15 and 17)")
    _title(ax_db, "Decibels, 20·log₁₀ of amplitude re spectral peak (paper Figs 16 and 19)")
    _suptitle(fig, f"Spectrum of the selected signal — f₀ = {prep.f0:.4g} Hz, "
                   f"band {lo:.3g}–{hi:.3g} Hz ({'auto' if prep.band_auto else 'given'})")
    _place(_gridspec(ax_lin), left=_y_room([ax_lin, ax_db]), right=_y_room([ax_h]),
           bottom=_x_room(), top=_top(max(_above(ax_lin), _above(ax_h, None))),
           hgap=_above(ax_db) + 4 * _PT)
    return fig


def fit_figure(an: "Analysis") -> "Figure":
    """Fitted samples and the least-squares model: whole window, first/last cycles, residuals."""
    prep, fd, ls = an.prepared, an.fit_data, an.least_squares
    vals = _ls_values(an)
    t_fit = fd.t0 + fd.tau
    span = float(fd.tau[-1] - fd.tau[0])
    f0 = vals["f_d"]
    n_curve = int(np.clip(40 * f0 * span, 2000, MAX_DOTS))
    t_mod, y_mod = _model_curve(an, n_curve)

    fig = _new_figure(11.0, 8.5)
    gs_all, gs_zoom, gs_res = (fig.add_gridspec(1, n) for n in (1, 2, 1))
    ax_all = fig.add_subplot(gs_all[0])
    ax_z0 = fig.add_subplot(gs_zoom[0])
    ax_z1 = fig.add_subplot(gs_zoom[1])
    ax_res = fig.add_subplot(gs_res[0], sharex=ax_all)

    many = t_fit.size > 3000
    # dense samples (raw path) would hide the model: draw them small and faint, model on top
    per_cycle = fd.fs / max(f0, 1e-12)
    dense = per_cycle > 25
    dot = dict(ls="none", marker=".", color="tab:blue", zorder=2,
               ms=1.5 if dense else 4.0, alpha=0.35 if dense else 1.0)
    line = dict(color="tab:red", zorder=3)
    tr, yr = _reduce(t_fit, fd.y, MAX_DOTS) if many else (t_fit, fd.y)
    tm, ym = _reduce(t_mod, y_mod)
    ax_all.plot(tr, yr, **dot, label=f"fitted samples ({fd.path}, {fd.fs:.3g} Hz, n = {fd.y.size})")
    ax_all.plot(tm, ym, lw=0.7, **line, label="least-squares model")
    ax_all.set_ylabel("acceleration [m/s²]")
    _title(ax_all, "Whole analysed window", loc="left")

    zoom = ZOOM_CYCLES / max(f0, 1e-12)
    t_start, t_end = float(t_fit[0]), float(t_fit[-1])
    ranges = [(t_start, min(t_start + zoom, t_end)), (max(t_end - zoom, t_start), t_end)]
    in_win = (prep.time >= t_start) & (prep.time <= t_end)
    for ax, (a, b), title in zip((ax_z0, ax_z1), ranges, ("First", "Last")):
        if fd.path != "raw":  # the fitted samples are filtered: show the recording beside them
            raw = in_win & (prep.time >= a) & (prep.time <= b)
            tr_, yr_ = _reduce(prep.time[raw], prep.signal[raw])
            ax.plot(tr_, yr_, lw=0.6, color="0.6", zorder=1, label="recorded signal (raw)")
        s = (t_fit >= a) & (t_fit <= b)
        ax.plot(t_fit[s], fd.y[s], **{**dot, "ms": 3.0 if dense else 5.0}, label="fitted samples")
        m = (t_mod >= a) & (t_mod <= b)
        ax.plot(t_mod[m], y_mod[m], lw=1.3, **line, label="least-squares model")
        ax.set_xlim(a, b)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("acceleration [m/s²]")
        _title(ax, f"{title} {ZOOM_CYCLES:g} cycles")
        ax.grid(alpha=0.3)
    ax_z0.legend(loc="upper right", fontsize=7, framealpha=0.9)

    res = np.asarray(ls.residuals)
    rr_t, rr = _reduce(t_fit, res, MAX_DOTS) if many else (t_fit, res)
    ax_res.plot(rr_t, rr, **{**dot, "color": "0.3"})
    n_avg = int(round(per_cycle))
    if n_avg >= 3 and res.size > 3 * n_avg:
        from scipy import ndimage

        smooth = ndimage.uniform_filter1d(res, n_avg, mode="nearest")
        ts, ys = _reduce(t_fit, smooth)
        ax_res.plot(ts, ys, color="tab:orange", lw=1.2, zorder=3, label="one-period running mean")
    ax_res.axhline(0, color="tab:red", lw=0.8)
    sig = an.noise.sigma
    for sgn in (-2, 2):
        ax_res.axhline(sgn * sig, color="tab:red", lw=0.7, ls="--",
                       label="±2σ" if sgn > 0 else None)
    ax_res.set_xlabel("time [s]")
    ax_res.set_ylabel("residual [m/s²]")
    _title(ax_res, f"Residuals (σ = {sig:.3g} m/s², lag-1 autocorrelation "
                   f"{an.noise.lag1:+.2f}, PSD ratio at f₀ r = {an.noise.psd_ratio:.2g})",
           loc="left")
    rows_res = _legend_above(ax_res, 2)
    for ax in (ax_all, ax_res):
        ax.grid(alpha=0.3)
    ax_all.set_xlim(t_start, t_end)
    rows_all = _legend_above(ax_all, 2)
    ax_all.tick_params(labelbottom=False)

    head = f"c = {_fmt(vals['c'])} {_unit('c')}, " if "c" in vals else ""
    status = "" if ls.converged else "  (NOT converged)"
    _suptitle(fig, f"Least-squares fit: {head}ζ = {_fmt(vals['zeta'])}, "
                   f"f_n = {_fmt(vals['f_n'], 6)} {_unit('f_n')}, "
                   f"u₀ = {_fmt(vals['u0'])} {_unit('u0')}{status}")
    left = _y_room([ax_all, ax_z0, ax_res])
    rows = _spans(fig.get_figheight(), _top(_above(ax_all, legend_rows=rows_all)), _x_room(),
                  [1.1, 1.0, 0.8], [max(_above(ax_z0), _above(ax_z1)) + 4 * _PT,
                                    _x_room() - _EDGE + _above(ax_res, legend_rows=rows_res)])
    for gs, (top, bottom) in zip((gs_all, gs_zoom, gs_res), rows):
        _place(gs, left=left, right=0.2, top=top, bottom=bottom,
               wgap=_y_room([ax_z1]) + 0.15)
    return fig


def displacement_figure(an: "Analysis") -> "Figure | None":
    """The paper's Fig. 20 analogue: envelope-pipeline displacement with its envelope fits.

    Returns ``None`` when the envelope pipeline baseline was not computed.
    """
    base = an.baselines.get("envelope_pipeline")
    if base is None:
        return None
    prep = an.prepared
    det = base.details
    w0, w1 = prep.window
    sel = (prep.grid >= w0) & (prep.grid <= w1)
    t = prep.grid[sel]
    u = np.asarray(det.get("displacement", []), float)
    if u.size != t.size or t.size < 2:
        return None
    env = np.asarray(det["envelope"], float)
    env_fit = np.asarray(det["envelope_fit"], float)
    mask = np.asarray(det.get("fit_mask", np.ones(t.size, bool)), bool)
    vals = _ls_values(an)
    t0 = an.fit_data.t0
    ls_env = vals["u0"] * np.exp(-vals["p"] * (t - t0))

    fig = _new_figure(11.0, 7.5)
    ax_lin, ax_log = fig.subplots(2, 1, sharex=True, height_ratios=[1.2, 1.0])
    tt, uu = _reduce(t, u)
    ax_lin.plot(tt, uu, lw=0.6, color="tab:blue", label="displacement (band-pass, ∫∫, band-pass)")
    for ax in (ax_lin, ax_log):
        te, ee = _reduce(t, env)
        ax.plot(te, ee, lw=1.0, color="tab:orange", label="Hilbert envelope")
        ax.plot(t, np.where(mask, env_fit, np.nan), lw=1.6, color="black",
                label=f"envelope fit K·e^(−pt), p = {base.p:.4g} 1/s")
        ax.plot(t, np.where(mask, np.nan, env_fit), lw=1.0, ls=":", color="black")
        ax.plot(t, ls_env, lw=1.3, ls="--", color="tab:red",
                label=f"least squares u₀·e^(−p(t−t₀)), p = {vals['p']:.4g} 1/s")
    ax_lin.plot(t, -ls_env, lw=1.3, ls="--", color="tab:red")

    if mask.any():
        tm = t[mask]
        for ax in (ax_lin, ax_log):
            ax.axvspan(t[0], tm[0], color="0.5", alpha=0.12, lw=0)
            ax.axvspan(tm[-1], t[-1], color="0.5", alpha=0.12, lw=0,
                       label="not used by the envelope fit" if ax is ax_log else None)

    ld = an.baselines.get("log_decrement")
    if ld is not None and "peak_times" in ld.details:
        pk_t = np.asarray(ld.details["peak_times"], float)
        pk_a = physics.quantities(vals["p"], vals["omega_d"], accel_amplitude=np.asarray(
            ld.details["peak_amplitudes"], float))["u0"]  # displacement = acceleration / ω_n²
        ax_log.plot(pk_t, pk_a, "o", ms=3, mfc="none", color="tab:green",
                    label=f"log-decrement peaks ÷ ω_n² (p = {ld.p:.4g} 1/s)")

    ax_lin.set_ylabel("displacement [m]")
    ax_log.set_yscale("log")
    _log_ticks(ax_log.yaxis)
    pos = env[mask] if mask.any() else env
    pos = pos[pos > 0]
    if pos.size:
        lo_y = min(float(pos.min()), float(ls_env.min())) / 2
        hi_y = max(float(env.max()), float(ls_env.max())) * 2
        ax_log.set_ylim(lo_y, hi_y)
    ax_log.set_ylabel("envelope [m] (log scale)")
    ax_log.set_xlabel("time [s]")
    for ax in (ax_lin, ax_log):
        ax.grid(alpha=0.3, which="both" if ax is ax_log else "major")
        ax.set_xlim(t[0], t[-1])
    rows_lin = _legend_above(ax_lin, 2)
    # the log panel repeats the envelope lines: label only what is new there
    handles, labels = ax_log.get_legend_handles_labels()
    new = [(h, lab) for h, lab in zip(handles, labels)
           if lab.startswith(("not used", "log-decrement"))]
    rows_log = _legend_above(ax_log, 2, *zip(*new)) if new else 0
    head = (f"c = {_fmt(base.c)} (envelope) vs {_fmt(vals.get('c'))} (LS) {_unit('c')}"
            if base.c is not None else
            f"ζ = {_fmt(base.zeta)} (envelope) vs {_fmt(vals['zeta'])} (LS)")
    _suptitle(fig, f"Displacement from the paper's envelope pipeline and decay envelopes — {head}")
    _place(_gridspec(ax_lin), left=_y_room([ax_lin, ax_log]), right=0.2, bottom=_x_room(),
           top=_top(_above(ax_lin, None, legend_rows=rows_lin)),
           hgap=_above(ax_log, None, legend_rows=rows_log) + 4 * _PT)
    return fig


def posterior_figure(an: "Analysis") -> "Figure":
    """Corner plot of (c, k, u₀) with a mass, else (ζ, f_n, u₀): pairs and marginals."""
    names = _variables(an)
    post = an.posterior.posterior
    draws = {v: np.asarray(post[v]).ravel() for v in names}
    ok = np.all([np.isfinite(draws[v]) for v in names], axis=0)
    draws = {v: x[ok] for v, x in draws.items()}
    n = len(names)
    idx = _subsample(int(ok.sum()), MAX_SCATTER_POINTS, seed=an.seed)
    ls_vals = _ls_values(an)

    fig = _new_figure(3.0 * n + 1.0, 3.0 * n + 0.6)
    gs = fig.add_gridspec(n, n)
    axes = np.empty((n, n), dtype=object)  # lower triangle only: no hidden axes to build
    for i in range(n):
        for j in range(i + 1):
            axes[i, j] = fig.add_subplot(gs[i, j])
    lims = {}
    for v in names:
        x = draws[v]
        if x.size:
            a, b = np.quantile(x, [0.001, 0.999])
            pad = 0.08 * (b - a) if b > a else 0.5 * abs(a) + 1e-12
            lims[v] = (a - pad, b + pad)
    for i, vy in enumerate(names):
        for j, vx in enumerate(names):
            if j > i:
                continue
            ax = axes[i, j]
            x = draws[vx]
            if i == j:
                q05, q50, q95 = _interval(x)
                ax.hist(x, bins=_bins(x.size), range=lims.get(vx), histtype="step",
                        color="tab:blue", density=True, lw=1.2)
                ax.axvspan(q05, q95, color="tab:orange", alpha=0.15, lw=0,
                           label="90 % interval")
                ax.axvline(q50, color="tab:orange", lw=1.5, label="median")
                for q in (q05, q95):
                    ax.axvline(q, color="tab:orange", lw=0.8, ls="--")
                if vx in ls_vals:
                    ax.axvline(ls_vals[vx], color="tab:red", lw=1.0, ls=":",
                               label="least squares")
                ax.set_yticks([])
                sym, unit = _LABELS.get(vx, (vx, ""))
                _title(ax, f"{sym} = {_fmt_interval(q05, q50, q95)}", size=9)
                if i == 0:
                    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
            else:
                y = draws[vy]
                ax.plot(x[idx], y[idx], ".", ms=1.5, color="tab:blue", alpha=0.35,
                        rasterized=True)
                try:
                    _contours(ax, x, y, lims.get(vx), lims.get(vy))
                except (ValueError, np.linalg.LinAlgError):  # degenerate draws: scatter only
                    pass
                if vx in ls_vals and vy in ls_vals:
                    ax.plot(ls_vals[vx], ls_vals[vy], "+", color="tab:red", ms=10, mew=1.5)
                ax.set_ylim(lims.get(vy))
            ax.set_xlim(lims.get(vx))
            _compact_ticks(ax, "both" if i != j else "x", 4)
            ax.tick_params(labelsize=8)
            for lab in ax.get_xticklabels():
                lab.set_rotation(30)
                lab.set_ha("right")
            if i == n - 1:  # left-aligned: the tick offset text (×10⁻⁴ + …) sits on the right
                ax.set_xlabel(_label(vx), loc="left")
            else:
                ax.tick_params(labelbottom=False)
            if j == 0 and i != j:
                ax.set_ylabel(_label(vy))
            elif i != j:
                ax.tick_params(labelleft=False)
            ax.grid(alpha=0.25)
    mass = f", m = {an.mass:g} ± {an.mass_sd:g} kg" if an.mass is not None else \
        " (no mass: c and k not identifiable)"
    _suptitle(fig, f"Posterior ({ok.sum()} draws, median and 90 % interval){mass}")
    _place_corner(axes)
    return fig


def _place_corner(axes) -> None:
    """Layout of the corner plot: y tick labels [8 pt] in the first column, x tick labels
    (rotated 30°, right-aligned at their tick) in the last row — a column's gap on its left
    holds its first label where that reaches out of the axes — marginal titles [9 pt] and y
    offset texts between rows."""
    fig = axes[0, 0].figure
    n = axes.shape[0]
    sin, cos = np.sin(np.radians(30.0)), np.cos(np.radians(30.0))
    labels = [_tick_texts(ax.xaxis)[0] for ax in axes[-1]]
    rotated = max((_text_width(t, 8) * sin + _line(8) * cos for row in labels for t in row),
                  default=0.0)
    x_offset = _line(9) if any(_offset(ax.xaxis) for ax in axes[-1]) else 0.0
    bottom = _EDGE + _TICK + rotated + max(_LABEL_PAD + _line(), x_offset)
    left = _y_room(axes[1:, 0], 8) if n > 1 else _EDGE + _TICK
    right = 0.15
    gap = max([_above(axes[i, i], 9) for i in range(n)]
              + [_above(axes[i, 0], None, offset_size=9) for i in range(1, n)])
    width = (fig.get_figwidth() - left - right - 0.12 * (n - 1)) / n  # [in], about
    wgaps = []
    for j in range(1, n):
        ax = axes[-1, j]
        a, b = ax.get_xlim()
        first = min((v for v in ax.xaxis.get_major_locator().tick_values(a, b)
                     if min(a, b) <= v <= max(a, b)), default=None, key=lambda v: abs(v - a))
        reach = (_text_width(labels[j][0], 8) * cos + _line(8) * sin) if labels[j] else 0.0
        room = abs(first - a) / abs(b - a) * width if first is not None and b != a else 0.0
        wgaps.append(max(0.12, reach - room + 0.05))
    cols = _spans(fig.get_figwidth(), left, right, [1.0] * n, wgaps)
    rows = _spans(fig.get_figheight(), _top(_above(axes[0, 0], 9)), bottom, [1.0] * n,
                  [gap + 3 * _PT] * (n - 1))
    W, H = fig.get_size_inches()
    for i, (t, bot) in enumerate(rows):
        for j, (l, r) in enumerate(cols[:i + 1]):
            axes[i, j].set_position([l / W, bot / H, (W - l - r) / W, (H - t - bot) / H])


#: Draws that set the kernel bandwidth of the posterior densities (Scott's rule): emcee draws
#: are autocorrelated, so the effective sample is a few thousand whatever their number.
KDE_DRAWS = 2_000


def _contours(ax, x, y, xlim, ylim, n_grid: int = 64) -> None:
    """Highest-density-region (HDR) contours holding ≈ 50 % and 90 % of the draws.

    The density is a Gaussian kernel density estimate whose kernel has the draws' own
    covariance (as :class:`scipy.stats.gaussian_kde`; Scott's factor n^(−1/6) with
    n = min(draws, :data:`KDE_DRAWS`)), evaluated by binning: the draws are whitened,
    w = L⁻¹·(p − mean) with L the Cholesky factor of their covariance (so a strongly
    correlated pair such as c–k becomes round and keeps its narrow ridge; standardised first,
    so L is that of the correlation matrix whatever the parameters' scales), counted on an
    ``n_grid`` × ``n_grid`` histogram and smoothed with an isotropic Gaussian filter of that
    bandwidth (:func:`scipy.ndimage.gaussian_filter`). The level of the q-HDR contour is the
    density that a fraction q of the draws exceed (the density at each draw read off the grid),
    so the contour encloses ≈ q of the draws (q = 50 %, 90 %). The grid is mapped back to the
    parameters' units for drawing. ``xlim``/``ylim`` None (no draws) or fewer than 10 draws:
    nothing is drawn; degenerate draws raise :class:`numpy.linalg.LinAlgError`.
    """
    from scipy import ndimage

    if xlim is None or ylim is None or x.size < 10:
        return
    if np.ptp(x) <= 0 or np.ptp(y) <= 0:
        return
    mean, sd = np.array([x.mean(), y.mean()]), np.array([x.std(), y.std()])
    z = (np.vstack([x, y]) - mean[:, None]) / sd[:, None]  # standardised draws (2, n)
    chol = np.linalg.cholesky(np.corrcoef(z))
    w = np.linalg.solve(chol, z)  # whitened draws
    bw = min(x.size, KDE_DRAWS) ** (-1.0 / 6.0)  # kernel sd in whitened units
    lo = np.quantile(w, 0.0005, axis=1) - 3 * bw
    hi = np.quantile(w, 0.9995, axis=1) + 3 * bw
    counts, eu, ev = np.histogram2d(w[0], w[1], bins=n_grid, range=[(lo[0], hi[0]),
                                                                    (lo[1], hi[1])])
    du, dv = eu[1] - eu[0], ev[1] - ev[0]
    dens = ndimage.gaussian_filter(counts, (bw / du, bw / dv), mode="constant")
    # density at each draw (bilinear between bin centres); the HDR levels are its quantiles
    at = ndimage.map_coordinates(dens, [(w[0] - lo[0]) / du - 0.5, (w[1] - lo[1]) / dv - 0.5],
                                 order=1, mode="constant", cval=0.0)
    levels = sorted({float(np.quantile(at, 1.0 - q)) for q in (0.9, 0.5)})
    if dens.max() <= levels[0] or levels[0] <= 0:
        return
    cu, cv = np.meshgrid(0.5 * (eu[1:] + eu[:-1]), 0.5 * (ev[1:] + ev[:-1]), indexing="ij")
    gx = mean[0] + sd[0] * (chol[0, 0] * cu)
    gy = mean[1] + sd[1] * (chol[1, 0] * cu + chol[1, 1] * cv)
    ax.contour(gx, gy, dens, levels=levels, colors="navy", linewidths=0.9)


def trace_figure(an: "Analysis") -> "Figure":
    """Per-walker traces (thinned, after burn-in) and marginal densities of the corner variables."""
    from matplotlib.collections import LineCollection

    names = _variables(an)
    post = an.posterior.posterior
    s = an.sampling
    n = len(names)
    fig = _new_figure(11.0, 2.3 * n + 0.8)
    axes = fig.subplots(n, 2, squeeze=False, width_ratios=[2.6, 1.0])
    for i, v in enumerate(names):
        x = np.asarray(post[v])  # (walker, draw)
        n_walk, n_draw = x.shape
        step = s.burn_in + s.thin * np.arange(n_draw)
        stride = max(1, int(np.ceil(n_draw * n_walk / 40_000)))
        ax_t, ax_d = axes[i]
        # one LineCollection per panel instead of one Line2D per walker (64 artists)
        segs = np.stack(np.broadcast_arrays(step[::stride][None, :], x[:, ::stride]), axis=-1)
        ax_t.add_collection(LineCollection(segs, linewidths=0.4, alpha=0.5, rasterized=True,
                                           colors=[f"C{w % 10}" for w in range(n_walk)]))
        ax_t.autoscale_view()
        q05, q50, q95 = _interval(x.ravel())
        ax_t.axhline(q50, color="black", lw=0.9)
        ax_t.set_ylabel(_label(v))
        ax_t.set_xlim(step[0], step[-1] if n_draw > 1 else step[0] + 1)
        ax_t.grid(alpha=0.3)
        _compact_ticks(ax_t, "y", 4)

        flat = x.ravel()
        flat = flat[np.isfinite(flat)]
        lo, hi = np.quantile(flat, [0.001, 0.999]) if flat.size else (0.0, 1.0)
        pad = 0.1 * (hi - lo) if hi > lo else 1e-12 + 0.1 * abs(lo)
        grid = np.linspace(lo - pad, hi + pad, 300)
        ax_d.hist(flat, bins=_bins(flat.size), range=(grid[0], grid[-1]), density=True,
                  color="0.85", histtype="stepfilled")  # one polygon, not one bar per bin
        dens = _density(flat, grid)
        if dens is not None:
            ax_d.plot(grid, dens, color="tab:blue", lw=1.2, label="density (KDE)")
            inside = (grid >= q05) & (grid <= q95)
            ax_d.fill_between(grid[inside], dens[inside], color="tab:orange", alpha=0.3, lw=0,
                              label="90 % interval")
        ax_d.axvline(q50, color="tab:orange", lw=1.5, label="median")
        ax_d.set_ylim(bottom=0)
        if i == 0:
            ax_d.legend(loc="upper right", fontsize=7, framealpha=0.8)
        ax_d.set_xlim(grid[0], grid[-1])
        ax_d.set_yticks([])  # no x label: the trace's y label names it, and the tick
        _title(ax_d, _fmt_interval(q05, q50, q95), size=9)  # offset text needs the room
        _compact_ticks(ax_d, "x", 3)
        ax_d.tick_params(labelsize=8)
        if i < n - 1:
            ax_t.tick_params(labelbottom=False)
    axes[-1, 0].set_xlabel(f"emcee step [1] (after burn-in {s.burn_in}, thinned by {s.thin}; "
                           f"{post.sizes.get('chain', 0)} walkers)")
    conv = "converged" if s.converged else "NOT converged"
    _suptitle(fig, f"Posterior traces — {conv}: max R-hat {s.max_r_hat:.3f}, "
                   f"min bulk ESS {s.min_ess_bulk:.0f}, acceptance {s.acceptance:.2f}, "
                   f"{s.n_steps} steps")
    # between rows: the density's x tick labels [8 pt] and offset text, then the next row's
    # density title [9 pt] or trace offset text
    below_d = _TICK + _line(8) + max((_line(8) + 3 * _PT for ax in axes[:, 1]
                                      if _offset(ax.xaxis)), default=0.0)
    above = [max(_above(ax_d, 9), _above(ax_t, None)) for ax_t, ax_d in axes]
    _place(_gridspec(axes[0, 0]), left=_y_room(axes[:, 0]), right=0.2,
           bottom=max(_x_room(), _EDGE + below_d), top=_top(above[0]),
           hgap=below_d + max(above[1:], default=0.0) + 3 * _PT, wgap=0.2)
    return fig


def _density(x: np.ndarray, grid: np.ndarray) -> np.ndarray | None:
    """Gaussian kernel density [1/unit of x] of the draws ``x`` on the evenly spaced ``grid``.

    Scott's bandwidth h = sd · n^(−1/5), n = min(draws, :data:`MAX_SCATTER_POINTS`) (as
    :class:`scipy.stats.gaussian_kde`), evaluated by binning: the draws are counted in bins
    centred on the grid points and the counts smoothed with a Gaussian of sd h
    (:func:`scipy.ndimage.gaussian_filter1d`), normalised by all draws. None for fewer than
    3 draws or no spread.
    """
    from scipy import ndimage

    if x.size < 3 or np.ptp(x) <= 0 or grid.size < 2:
        return None
    dx = float(grid[1] - grid[0])
    counts, _ = np.histogram(x, bins=grid.size, range=(grid[0] - dx / 2, grid[-1] + dx / 2))
    h = float(np.std(x, ddof=1)) * min(x.size, MAX_SCATTER_POINTS) ** (-0.2)
    return ndimage.gaussian_filter1d(counts.astype(float), h / dx, mode="constant") / (x.size * dx)


#: name → figure function; the name is also the PNG file stem.
FIGURES: dict[str, Callable[["Analysis"], Any]] = {
    "signal": signal_figure,
    "spectrum": spectrum_figure,
    "fit": fit_figure,
    "displacement": displacement_figure,
    "posterior": posterior_figure,
    "trace": trace_figure,
}

#: The :class:`~dampfit.analysis.Analysis` fields each figure reads (``amplitude``: the one
#: :func:`save_figures` adds): a figure can be drawn as soon as its stage has produced them
#: (:mod:`dampfit.output.figure_process` draws the early ones while the posterior is sampled).
NEEDS: dict[str, frozenset[str]] = {
    "signal": frozenset({"recording", "prepared"}),
    "spectrum": frozenset({"prepared"}),
    "fit": frozenset({"prepared", "fit_data", "least_squares", "noise", "mass"}),
    "displacement": frozenset({"prepared", "fit_data", "least_squares", "baselines", "mass"}),
    "posterior": frozenset({"sampling", "least_squares", "mass", "mass_sd", "seed"}),
    "trace": frozenset({"sampling"}),
    "amplitude": frozenset({"damping", "least_squares", "mass"}),
}


def render(an: Any, names, outdir: str | os.PathLike, dpi: int = 110) -> dict[str, Path | None]:
    """Draw the figures ``names`` of :data:`FIGURES` and write each as ``<name>.png`` into
    ``outdir`` (atomically). Returns ``{name: path}``; ``None`` for a figure that does not apply
    (the displacement figure without the envelope-pipeline baseline), whose older file in
    ``outdir`` is removed."""
    outdir = Path(outdir)
    written: dict[str, Path | None] = {}
    with drawing():
        for name in names:
            fig = FIGURES[name](an)
            path = outdir / f"{name}.png"
            if fig is None:
                path.unlink(missing_ok=True)  # never leave a stale figure of an earlier run
                written[name] = None
                continue
            save_png(fig, path, dpi)
            written[name] = path
    return written


@contextlib.contextmanager
def drawing():
    """Settings for drawing figures: Python's cyclic garbage collector paused (the youngest
    generation, what the figures left, is collected at the end) and BLAS held to one thread.

    Drawing allocates about a million short-lived objects in reference cycles (artists,
    transforms, canvases); with the collector on, they trigger full collections that walk the
    whole heap — the analysis, JAX, arviz — about 0.2 s each, for garbage that one
    young-generation pass afterwards frees in a fraction of that. The figures' linear algebra
    is tiny (a 400 × 24 QR for the drift basis, 2 × 2 Cholesky factors), where waking BLAS
    threads costs a hundred times the work. Nested use changes nothing."""
    from threadpoolctl import threadpool_limits

    global _DRAWING
    if _DRAWING:  # nested: the outer call has set everything
        yield
        return
    pause = gc.isenabled()  # the caller may have switched it off: leave it so
    _DRAWING = True
    if pause:
        gc.disable()
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
    finally:
        _DRAWING = False
        if pause:
            gc.enable()
            gc.collect(0)


_DRAWING = False  # inside drawing()


#: zlib level of the PNG files: 1 encodes about twice as fast as Pillow's default 6; without
#: the alpha channel the seven figures are then no larger than matplotlib's RGBA files at 6.
PNG_COMPRESSION = 1


def save_png(fig: "Figure", path: str | os.PathLike, dpi: int = 110) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically (:func:`write_png`), then release its axes
    (detached from the figure; cheaper than :meth:`~matplotlib.figure.Figure.clear`, which
    rebuilds every axes it empties)."""
    try:
        return write_png(fig, path, dpi)
    finally:
        _release(fig)


def _release(fig: "Figure") -> None:
    """Detach every axes of ``fig`` (its artists are freed with the axes)."""
    for ax in list(fig.axes):
        fig.delaxes(ax)


def write_png(fig: "Figure", path: str | os.PathLike, dpi: int = 110) -> Path:
    """Draw ``fig`` once on an Agg canvas at ``dpi`` [pixels per inch] and write it to ``path``
    atomically (:func:`dampfit.files.folder.atomic_write`) as an 8-bit RGB PNG with its resolution
    and matplotlib's software tag (what ``savefig`` writes, less the alpha channel: every
    figure here is opaque, and the channel costs a quarter more to compress)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin

    old_dpi = fig.dpi
    try:
        fig.set_dpi(dpi)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        size = canvas.get_width_height()
        image = Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        image = image.convert("RGB")
    finally:
        fig.set_dpi(old_dpi)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, "
                              "https://matplotlib.org/")
    return atomic_write(path, lambda tmp: image.save(tmp, format="png", dpi=(dpi, dpi),
                                                     pnginfo=info,
                                                     compress_level=PNG_COMPRESSION),
                        suffix=".png")


def save_figures(an: "Analysis", outdir: str | os.PathLike, *, dpi: int = 110,
                 skip=()) -> dict[str, Path]:
    """Write every figure of :data:`FIGURES` (but ``skip``) and the amplitude figure as
    ``<name>.png`` into ``outdir``.

    Returns ``{name: path}`` of the files written. A figure that does not apply (the
    displacement figure without the envelope-pipeline baseline; the amplitude figure without a
    damping assessment) is skipped, and an older file of that name in ``outdir`` is removed.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    with drawing():
        done = render(an, [name for name in FIGURES if name not in skip], outdir, dpi)
        written = {name: path for name, path in done.items() if path is not None}
        path = outdir / "amplitude.png"
        if getattr(an, "damping", None) is not None:  # ζ(A) and f(A) of dampfit.damping
            fig = amplitude_figure(_amplitude_curve(an), path, dpi=dpi,
                                   f_d_hz=_ls_values(an)["f_d"],
                                   frequency_trend=(an.damping.adequacy or {})
                                   .get("frequency_trend"))
            _release(fig)
            written["amplitude"] = path
        else:
            path.unlink(missing_ok=True)  # never leave a stale figure of an earlier run
    return written


def _amplitude_curve(an: "Analysis") -> dict:
    """``amplitude_curve`` of the damping summary, each window with its frequency sd
    ``f_d_sd_hz`` [Hz] (from the window fit's ω_d sd when the summary does not carry it)."""
    curve = dict(an.damping.summary()["amplitude_curve"])
    wins = [dict(w) for w in (curve.get("windows") or [])]
    fits = list(getattr(an.damping, "windows", None) or [])
    if len(fits) == len(wins):
        for w, fit in zip(wins, fits):
            if "f_d_sd_hz" not in w:
                w["f_d_sd_hz"] = float(getattr(fit, "omega_sd", float("nan"))) / (2 * np.pi)
    curve["windows"] = wins
    return curve


def _window_f_sd(w: dict) -> float:
    """1-σ [Hz] of a window's damped frequency (``f_d_sd_hz``, or ``omega_sd`` [rad/s]); NaN."""
    for key, scale in (("f_d_sd_hz", 1.0), ("omega_sd", 1.0 / (2 * np.pi))):
        v = w.get(key)
        if isinstance(v, (int, float)) and np.isfinite(v) and v > 0:
            return float(v) * scale
    return float("nan")


def amplitude_figure(curve: dict, path: str | os.PathLike | None = None, *, dpi: int = 110,
                     f_d_hz: float | None = None, frequency_trend: dict | None = None) -> "Figure":
    """ζ(A) and the f(A) backbone against displacement amplitude, in two panels.

    ``curve`` is ``summary()["amplitude_curve"]`` of :func:`dampfit.damping.assess`.

    * Top (``fig.axes[0]``), ζ(A): window estimates ζ ± 1.645·sd (90 %) [1] at their
      amplitude [m] (log axis), every law's ζ_eq(a) = ρ(a)/ω from its least-squares fit, the
      90 % posterior band of the chosen law and the reference amplitude of c_eq. With a mass,
      a second axis gives c_eq [N·s/m] = 2·m·ω·ζ (ω from the windows).
    * Bottom, f(A) backbone: each window's damped frequency f_d [Hz] ± 1.645·sd (90 %; sd
      from ``f_d_sd_hz`` [Hz] or ``omega_sd`` [rad/s] of the window, error bars omitted when
      absent) against the same amplitude axis, with the constant frequency ``f_d_hz`` [Hz] the
      free-decay model assumes (dashed, when given); ``frequency_trend``
      (:func:`dampfit.damping.curve.frequency_trend`; default ``curve["backbone"]
      ["frequency_trend"]``) adds its relative change to the title.

    With ``path``, the PNG is written atomically as well.
    """
    fig = _new_figure(8.0, 7.5)
    ax, ax_f = fig.subplots(2, 1, sharex=True, height_ratios=[1.5, 1.0])
    wins = [w for w in (curve.get("windows") or []) if isinstance(w, dict)]
    a = np.array([w.get("amplitude_m", np.nan) for w in wins], dtype=float)
    z = np.array([w.get("zeta", np.nan) for w in wins], dtype=float)
    zs = np.array([w.get("zeta_sd", np.nan) for w in wins], dtype=float)
    cyc = curve.get("window_cycles") or 0
    if a.size:
        ax.errorbar(a, z, yerr=1.645 * np.nan_to_num(zs), fmt="o", ms=4, color="0.25",
                    ecolor="0.6", capsize=2,
                    label=f"windowed viscous fits ({cyc:.0f} cycles, 90 %)")
    grid = np.asarray(curve.get("amplitude_grid_m") or [], dtype=float)
    band = curve.get("band")
    if band and grid.size > 1:
        ax.fill_between(grid, band["zeta_q05"], band["zeta_q95"], color="tab:blue", alpha=0.18,
                        lw=0, label=f"{band['model']}: 90 % posterior band")
    colors = {"viscous": "0.45", "coulomb": "tab:orange", "quadratic": "tab:green",
              "power": "tab:blue"}
    chosen = curve.get("chosen_model")
    for name, entry in (curve.get("models") or {}).items():
        if grid.size > 1 and isinstance(entry, dict) and entry.get("zeta_eq") is not None:
            ax.plot(grid, entry["zeta_eq"], color=colors.get(name, "k"),
                    lw=2.0 if name == chosen else 1.0, ls="-" if name == chosen else "--",
                    label=f"{name}{' (chosen)' if name == chosen else ''}: ζ_eq(a)")
    ref = curve.get("reference_amplitude_m")
    for axis in (ax, ax_f):
        if ref:
            axis.axvline(ref, color="tab:red", lw=0.9, ls=":",
                         label=f"reference amplitude {ref:.3g} m" if axis is ax else None)
        axis.grid(alpha=0.3, which="both")
    if (a > 0).any() or grid.size > 1:
        ax.set_xscale("log")
        _log_ticks(ax.xaxis)
        from matplotlib.ticker import FuncFormatter

        plain = FuncFormatter(lambda v, _: f"{v:.3g}")  # not 2.2×10⁻¹ on a short log span
        span = np.concatenate([a[a > 0], grid[grid > 0]])
        if span.size and span.max() < 10 * span.min():
            ax_f.xaxis.set_major_formatter(plain)
            ax_f.xaxis.set_minor_formatter(plain)
    ax.set_ylabel("damping ratio ζ [1]")
    mass = curve.get("mass_kg")
    fd = np.array([w.get("f_d_hz", np.nan) for w in wins], dtype=float)
    sec = None
    if mass and np.isfinite(fd).any():
        w = float(2 * np.pi * np.nanmedian(fd))
        c_per_zeta = float(physics.damping_coefficient(mass, w))  # c = 2·m·ω·ζ [N·s/m]
        sec = ax.secondary_yaxis("right", functions=(lambda zz: c_per_zeta * zz,
                                                     lambda cc: cc / c_per_zeta))
        sec.set_ylabel(f"c_eq [{_unit('c')}]")
    slope = curve.get("slope")
    title = "ζ(A)"
    if slope:
        title += (f": d ln p/d ln a = {slope['s']:.2f} [{slope['s_q05']:.2f}, "
                  f"{slope['s_q95']:.2f}] (0 for one viscous c)")
    _title(ax, title, loc="left")
    if not a.size and grid.size < 2:
        ax.text(0.5, 0.5, "no amplitude windows (too few cycles)", ha="center", va="center",
                transform=ax.transAxes, color="0.4")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="best", ncols=2, framealpha=0.7)

    # f(A): the backbone curve
    fs = np.array([_window_f_sd(w) for w in wins], dtype=float)
    ok = np.isfinite(a) & np.isfinite(fd)
    if ok.any():
        has_sd = np.isfinite(fs[ok]).all()
        ax_f.errorbar(a[ok], fd[ok], yerr=1.645 * fs[ok] if has_sd else None, fmt="s", ms=4,
                      color="tab:purple", ecolor="plum", capsize=2,
                      label="windowed damped frequency" + (" (90 %)" if has_sd else
                                                           " (sd not in the summary)"))
    else:
        ax_f.text(0.5, 0.5, "no windowed frequencies", ha="center", va="center",
                  transform=ax_f.transAxes, color="0.4")
    if f_d_hz is not None and np.isfinite(f_d_hz):
        ax_f.axhline(f_d_hz, color="0.3", lw=1.0, ls="--",
                     label=f"constant f_d of the fit = {f_d_hz:.6g} Hz")
    ax_f.set_ylabel("damped frequency f_d [Hz]")
    ax_f.set_xlabel("displacement amplitude a [m]")
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    ax_f.yaxis.set_major_locator(MaxNLocator(4))
    ax_f.yaxis.set_major_formatter(ScalarFormatter(useOffset=False))  # 1.72008, not ×10⁻⁴+1.72
    if frequency_trend is None and isinstance(curve.get("backbone"), dict):
        frequency_trend = curve["backbone"].get("frequency_trend")
    ftitle = "f(A) backbone"
    if frequency_trend and all(isinstance(frequency_trend.get(k), (int, float))
                               for k in ("rel_change", "rel_change_sd")):
        ftitle += (f": f_d changes {100 * frequency_trend['rel_change']:+.2g} % "
                   f"(± {100 * frequency_trend['rel_change_sd']:.2g} %) over the amplitudes "
                   "(0 if linear)")
    _title(ax_f, ftitle, loc="left")
    if ax_f.get_legend_handles_labels()[0]:
        ax_f.legend(fontsize=8, loc="best")
    _suptitle(fig, "Amplitude dependence: damping ζ(A) and frequency f(A)")
    right = 0.2
    if sec is not None:  # c_eq axis: its ticks follow ζ's limits through c = c_per_zeta·ζ
        labels = _tick_texts(sec.yaxis, interval=[c_per_zeta * v for v in ax.get_ylim()])[0]
        right = _y_room([], labels=labels)
    _place(_gridspec(ax), left=_y_room([ax, ax_f]), right=right, bottom=_x_room(),
           top=_top(_above(ax)), hgap=_above(ax_f) + 4 * _PT)
    if path is not None:
        write_png(fig, path, dpi)
    return fig
