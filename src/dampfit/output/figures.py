"""Figures of an :class:`~dampfit.pipeline.Analysis` (PNG files for the report).

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
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any
from collections.abc import Callable

import numpy as np

from dampfit import physics
from dampfit._files import atomic_write

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from dampfit.pipeline import Analysis

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

#: Most points drawn per line (longer lines are reduced by min/max per bucket).
MAX_LINE_POINTS = 20_000
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


# ----------------------------------------------------------------------------- helpers
def _new_figure(width: float, height: float) -> "Figure":
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


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
    """Least-squares physical values (:func:`dampfit.pipeline.ls_quantities`, i.e.
    :func:`dampfit.physics.quantities`; c, k and the mass only with a mass)."""
    from dampfit.pipeline import ls_quantities

    out = {name: float(v) for name, v in ls_quantities(an.least_squares, an.mass).items()}
    if an.mass is not None:
        out["mass"] = float(an.mass)
    return out


def _model_curve(an: "Analysis", n: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares model on a fine grid over the fitted span: (t [s], a [m/s²])
    (:func:`dampfit.pipeline.fitted_curve`)."""
    from dampfit.pipeline import fitted_curve

    return fitted_curve(an.fit_data, an.least_squares, n)


def _variables(an: "Analysis") -> list[str]:
    post = an.posterior.posterior
    names = ["c", "k", "u0"] if ("c" in post and "k" in post) else ["zeta", "f_n", "u0"]
    return [v for v in names if v in post]


def _recording_name(an: "Analysis") -> str:
    path = an.recording.path
    return Path(path).name if path else f"{an.recording.format} recording"


def _compact_ticks(ax, which: str = "both", n: int = 4) -> None:
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    axes = {"x": [ax.xaxis], "y": [ax.yaxis], "both": [ax.xaxis, ax.yaxis]}[which]
    for axis in axes:
        axis.set_major_locator(MaxNLocator(n))
        fmt = ScalarFormatter(useOffset=True, useMathText=True)
        fmt.set_powerlimits((-3, 4))
        axis.set_major_formatter(fmt)


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


def _legend_above(ax, ncols: int, **kw) -> None:
    """Legend in the strip above the axes (right-aligned), so it never hides data."""
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=ncols, fontsize=8,
              frameon=False, borderaxespad=0.2, **kw)


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
    ax_raw.set_title("Recorded axes (offset removed, uniform grid)", fontsize=10, loc="left")
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
    ax_sel.set_title("Selected / projected signal", fontsize=10, loc="left")
    for ax, lim in ((ax_raw, lim_raw), (ax_sel, lim_sel)):
        ax.axvspan(w0, w1, color="tab:green", alpha=0.10, lw=0,
                   label=f"analysed window {w0:.2f}–{w1:.2f} s" if ax is ax_sel else None)
        ax.grid(alpha=0.3)
        ax.set_xlim(prep.grid[0], prep.grid[-1])
        if lim is not None:
            ax.set_ylim(lim)
    _legend_above(ax_raw, min(4, prep.grid_raw.shape[1]))
    _legend_above(ax_sel, 4)
    fig.suptitle(f"Signal: {_recording_name(an)} — {prep.fs:.4g} Hz, "
                 f"{an.recording.duration:.4g} s, f₀ = {prep.f0:.4g} Hz")
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
    ax_lin.set_title("Linear scale (paper Figs 15 and 17)", fontsize=10)
    ax_db.set_title("Decibels, 20·log₁₀ of amplitude re spectral peak (paper Figs 16 and 19)",
                    fontsize=10)
    fig.suptitle(f"Spectrum of the selected signal — f₀ = {prep.f0:.4g} Hz, "
                 f"band {lo:.3g}–{hi:.3g} Hz ({'auto' if prep.band_auto else 'given'})")
    return fig


def fit_figure(an: "Analysis") -> "Figure":
    """Fitted samples and the least-squares model: whole window, first/last cycles, residuals."""
    prep, fd, ls = an.prepared, an.fit_data, an.least_squares
    vals = _ls_values(an)
    t_fit = fd.t0 + fd.tau
    span = float(fd.tau[-1] - fd.tau[0])
    f0 = vals["f_d"]
    n_curve = int(np.clip(40 * f0 * span, 2000, MAX_LINE_POINTS))
    t_mod, y_mod = _model_curve(an, n_curve)

    fig = _new_figure(11.0, 8.5)
    gs = fig.add_gridspec(3, 2, height_ratios=[1.1, 1.0, 0.8])
    ax_all = fig.add_subplot(gs[0, :])
    ax_z0 = fig.add_subplot(gs[1, 0])
    ax_z1 = fig.add_subplot(gs[1, 1])
    ax_res = fig.add_subplot(gs[2, :], sharex=ax_all)

    many = t_fit.size > 3000
    # dense samples (raw path) would hide the model: draw them small and faint, model on top
    per_cycle = fd.fs / max(f0, 1e-12)
    dense = per_cycle > 25
    dot = dict(ls="none", marker=".", color="tab:blue", zorder=2,
               ms=1.5 if dense else 4.0, alpha=0.35 if dense else 1.0)
    line = dict(color="tab:red", zorder=3)
    tr, yr = _reduce(t_fit, fd.y) if many else (t_fit, fd.y)
    tm, ym = _reduce(t_mod, y_mod)
    ax_all.plot(tr, yr, **dot, label=f"fitted samples ({fd.path}, {fd.fs:.3g} Hz, n = {fd.y.size})")
    ax_all.plot(tm, ym, lw=0.7, **line, label="least-squares model")
    ax_all.set_ylabel("acceleration [m/s²]")
    ax_all.set_title("Whole analysed window", fontsize=10, loc="left")

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
        ax.set_title(f"{title} {ZOOM_CYCLES:g} cycles", fontsize=10)
        ax.grid(alpha=0.3)
    ax_z0.legend(loc="upper right", fontsize=7, framealpha=0.9)

    res = np.asarray(ls.residuals)
    rr_t, rr = _reduce(t_fit, res) if many else (t_fit, res)
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
    ax_res.set_title(f"Residuals (σ = {sig:.3g} m/s², lag-1 autocorrelation "
                     f"{an.noise.lag1:+.2f}, PSD ratio at f₀ r = {an.noise.psd_ratio:.2g})",
                     fontsize=10, loc="left")
    _legend_above(ax_res, 2)
    for ax in (ax_all, ax_res):
        ax.grid(alpha=0.3)
    ax_all.set_xlim(t_start, t_end)
    _legend_above(ax_all, 2)
    ax_all.tick_params(labelbottom=False)

    head = f"c = {_fmt(vals['c'])} {_unit('c')}, " if "c" in vals else ""
    status = "" if ls.converged else "  (NOT converged)"
    fig.suptitle(f"Least-squares fit: {head}ζ = {_fmt(vals['zeta'])}, "
                 f"f_n = {_fmt(vals['f_n'], 6)} {_unit('f_n')}, "
                 f"u₀ = {_fmt(vals['u0'])} {_unit('u0')}{status}")
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
    _legend_above(ax_lin, 2)
    # the log panel repeats the envelope lines: label only what is new there
    handles, labels = ax_log.get_legend_handles_labels()
    new = [(h, lab) for h, lab in zip(handles, labels)
           if lab.startswith(("not used", "log-decrement"))]
    if new:
        ax_log.legend(*zip(*new), loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2,
                      fontsize=8, frameon=False, borderaxespad=0.2)
    head = (f"c = {_fmt(base.c)} (envelope) vs {_fmt(vals.get('c'))} (LS) {_unit('c')}"
            if base.c is not None else
            f"ζ = {_fmt(base.zeta)} (envelope) vs {_fmt(vals['zeta'])} (LS)")
    fig.suptitle(f"Displacement from the paper's envelope pipeline and decay envelopes — {head}")
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
    axes = fig.subplots(n, n, squeeze=False)
    lims = {}
    for v in names:
        x = draws[v]
        if x.size:
            a, b = np.quantile(x, [0.001, 0.999])
            pad = 0.08 * (b - a) if b > a else 0.5 * abs(a) + 1e-12
            lims[v] = (a - pad, b + pad)
    for i, vy in enumerate(names):
        for j, vx in enumerate(names):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
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
                ax.set_title(f"{sym} = {_fmt_interval(q05, q50, q95)}", fontsize=9)
                if i == 0:
                    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
            else:
                y = draws[vy]
                ax.plot(x[idx], y[idx], ".", ms=1.5, color="tab:blue", alpha=0.35,
                        rasterized=True)
                try:
                    _contours(ax, x, y, lims.get(vx), lims.get(vy), seed=an.seed)
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
    fig.suptitle(f"Posterior ({ok.sum()} draws, median and 90 % interval){mass}")
    return fig


def _contours(ax, x, y, xlim, ylim, seed: int = 0, n_grid: int = 80) -> None:
    """Highest-density contours holding ≈ 50 % and 90 % of the draws.

    A Gaussian KDE (bandwidth from the draws' own covariance, so strongly correlated pairs
    such as c–k keep their narrow ridge) on at most 2 000 draws; the contour levels are the
    density quantiles at the draws themselves.
    """
    from scipy import stats

    if xlim is None or ylim is None or x.size < 10:
        return
    sub = _subsample(x.size, 2000, seed=seed + 1)
    xs, ys = x[sub], y[sub]
    if np.ptp(xs) <= 0 or np.ptp(ys) <= 0:
        return
    # standardise first: the KDE works in well-scaled units whatever the parameters' size
    mx, sx, my, sy = xs.mean(), xs.std(), ys.mean(), ys.std()
    kde = stats.gaussian_kde(np.vstack([(xs - mx) / sx, (ys - my) / sy]))
    dens_pts = kde(kde.dataset)
    levels = sorted({float(np.quantile(dens_pts, 1.0 - q)) for q in (0.9, 0.5)})
    gx = np.linspace(*xlim, n_grid)
    gy = np.linspace(*ylim, n_grid)
    xx, yy = np.meshgrid(gx, gy)
    zz = kde(np.vstack([(xx.ravel() - mx) / sx, (yy.ravel() - my) / sy])).reshape(xx.shape)
    if zz.max() <= levels[0]:
        return
    ax.contour(gx, gy, zz, levels=levels, colors="navy", linewidths=0.9)


def trace_figure(an: "Analysis") -> "Figure":
    """Per-walker traces (thinned, after burn-in) and marginal densities of the corner variables."""
    from matplotlib.collections import LineCollection
    from scipy import stats

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
                  color="0.85")
        sub = flat[_subsample(flat.size, MAX_SCATTER_POINTS, seed=an.seed)]
        if sub.size > 2 and np.ptp(sub) > 0:
            dens = stats.gaussian_kde(sub)(grid)
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
        ax_d.set_title(_fmt_interval(q05, q50, q95), fontsize=9)  # offset text needs the room
        _compact_ticks(ax_d, "x", 3)
        ax_d.tick_params(labelsize=8)
        if i < n - 1:
            ax_t.tick_params(labelbottom=False)
    axes[-1, 0].set_xlabel(f"emcee step [1] (after burn-in {s.burn_in}, thinned by {s.thin}; "
                           f"{post.sizes.get('chain', 0)} walkers)")
    conv = "converged" if s.converged else "NOT converged"
    fig.suptitle(f"Posterior traces — {conv}: max R-hat {s.max_r_hat:.3f}, "
                 f"min bulk ESS {s.min_ess_bulk:.0f}, acceptance {s.acceptance:.2f}, "
                 f"{s.n_steps} steps")
    return fig


#: name → figure function; the name is also the PNG file stem.
FIGURES: dict[str, Callable[["Analysis"], Any]] = {
    "signal": signal_figure,
    "spectrum": spectrum_figure,
    "fit": fit_figure,
    "displacement": displacement_figure,
    "posterior": posterior_figure,
    "trace": trace_figure,
}


def render(an: Any, names, outdir: str | os.PathLike, dpi: int = 110) -> dict[str, Path | None]:
    """Draw the figures ``names`` of :data:`FIGURES` and write each as ``<name>.png`` into
    ``outdir`` (atomically). Returns ``{name: path}``; ``None`` for a figure that does not apply
    (the displacement figure without the envelope-pipeline baseline), whose older file in
    ``outdir`` is removed."""
    outdir = Path(outdir)
    written: dict[str, Path | None] = {}
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


def save_png(fig: "Figure", path: str | os.PathLike, dpi: int = 110) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically (:func:`dampfit._files.atomic_write`), then
    release its artists."""
    try:
        return atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format="png"),
                            suffix=".png")
    finally:
        fig.clear()


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
    done = render(an, [name for name in FIGURES if name not in skip], outdir, dpi)
    written = {name: path for name, path in done.items() if path is not None}
    path = outdir / "amplitude.png"
    if getattr(an, "damping", None) is not None:  # ζ(A) and f(A) of dampfit.damping
        fig = amplitude_figure(_amplitude_curve(an), path, dpi=dpi, f_d_hz=_ls_values(an)["f_d"],
                               frequency_trend=(an.damping.adequacy or {}).get("frequency_trend"))
        fig.clear()
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
        from matplotlib.ticker import FuncFormatter

        plain = FuncFormatter(lambda v, _: f"{v:.3g}")  # not 2.2×10⁻¹ on a short log span
        span = np.concatenate([a[a > 0], grid[grid > 0]])
        if span.size and span.max() < 10 * span.min():
            ax_f.xaxis.set_major_formatter(plain)
            ax_f.xaxis.set_minor_formatter(plain)
    ax.set_ylabel("damping ratio ζ [1]")
    mass = curve.get("mass_kg")
    fd = np.array([w.get("f_d_hz", np.nan) for w in wins], dtype=float)
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
    ax.set_title(title, fontsize=10, loc="left")
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
    ax_f.set_title(ftitle, fontsize=10, loc="left")
    if ax_f.get_legend_handles_labels()[0]:
        ax_f.legend(fontsize=8, loc="best")
    fig.suptitle("Amplitude dependence: damping ζ(A) and frequency f(A)")
    if path is not None:
        atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format="png"), suffix=".png")
    return fig
