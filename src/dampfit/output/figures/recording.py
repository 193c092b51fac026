"""Figures of the recording: the signal over the whole recording and its spectrum.

* :func:`signal_figure` (``signal.png``) — raw axes, selected signal, window, masked samples;
* :func:`spectrum_figure` (``spectrum.png``) — amplitude spectrum (linear and dB), band, f₀,
  |H|² and the spectrum after the band-pass (the seed paper's Figs 15–17, 19).

Drawn from the signals' ``signal`` and ``spectrum`` figure arrays and the summary's input,
window, band and preprocessing sections (:class:`~dampfit.output.figures.data.FigureData`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dampfit.output.figures import layout as L
from dampfit.output.figures.data import MissingData, as_data, plain

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

_AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown")


def _limits(row: np.ndarray) -> tuple[float, float] | None:
    lo, hi = (float(v) for v in row)
    return (lo, hi) if np.isfinite(lo) and np.isfinite(hi) else None


def signal_figure(an: Any) -> "Figure":
    """Raw axes and the selected signal over the whole recording; window and masked samples.

    The y range follows the usable samples; masked samples (clipped or impact spikes) outside
    it are drawn at the edge of the axes and their time spans are shaded. ``an``: an
    analysis or its :class:`~dampfit.output.figures.data.FigureData`.
    """
    d = as_data(an)
    a = d.arrays("signal", "signal")
    fs, w0, w1, f0, duration = d.require("signal", ("input", "sample_rate_hz"),
                                         ("window", "start_s"), ("window", "end_s"),
                                         ("dominant_frequency_hz", None),
                                         ("input", "duration_s"))
    fig = L.new_figure(11.0, 7.0)
    ax_raw, ax_sel = fig.subplots(2, 1, sharex=True)
    dt = 1.0 / fs
    direction = d.section("input").get("axis_direction")
    names = [n for n in direction if isinstance(n, str)] if isinstance(direction, dict) else []
    counts = a["rec_axes_n"].astype(int)
    bounds = np.concatenate([[0], np.cumsum(counts)])
    for j in range(counts.size):
        t, y = (a[k][bounds[j]:bounds[j + 1]] for k in ("rec_axes_t", "rec_axes_y"))
        name = names[j] if j < len(names) else f"axis {j}"
        weight = direction.get(name) if name in names else None
        weight = float(weight) if isinstance(weight, (int, float)) else float("nan")
        ax_raw.plot(t, y, lw=0.6, color=_AXIS_COLORS[j % len(_AXIS_COLORS)],
                    label=f"{plain(name)} (weight {weight:+.3f})")
    ax_raw.set_ylabel("acceleration [m/s²]")
    L.title(ax_raw, "Recorded axes (offset removed, uniform grid)", loc="left")
    lim_raw, lim_sel = _limits(a["rec_ylim"][0]), _limits(a["rec_ylim"][1])

    ax_sel.plot(a["rec_signal_t"], a["rec_signal_y"], lw=0.6, color="0.25",
                label=f"selected signal (axis {d.text('input', 'axis')})")
    te, ye = a["rec_envelope_t"], a["rec_envelope_y"]
    ax_sel.plot(te, ye, lw=0.9, color="tab:red", alpha=0.8, label="band-pass envelope")
    ax_sel.plot(te, -ye, lw=0.9, color="tab:red", alpha=0.8)
    t_bad = a["rec_masked_t"]
    if t_bad.size:
        yb = a["rec_masked_y"]
        if lim_sel is not None:
            yb = np.clip(yb, *lim_sel)
        n_clipped = d.number("preprocessing", "n_clipped", 0)
        n_spikes = d.number("preprocessing", "n_spikes", 0)
        ax_sel.plot(t_bad, yb, "x", color="magenta", ms=5, mew=1.2, clip_on=False,
                    label=f"masked: {n_clipped:.0f} clipped, {n_spikes:.0f} in spikes")
        for lo, hi in a["rec_masked_runs"]:
            for ax in (ax_raw, ax_sel):
                ax.axvspan(float(lo) - dt, float(hi) + dt, color="magenta", alpha=0.25, lw=0)
    ax_sel.set_ylabel("acceleration [m/s²]")
    ax_sel.set_xlabel("time [s]")
    L.title(ax_sel, "Selected / projected signal", loc="left")
    for ax, lim in ((ax_raw, lim_raw), (ax_sel, lim_sel)):
        ax.axvspan(w0, w1, color="tab:green", alpha=0.10, lw=0,
                   label=f"analysed window {w0:.2f}–{w1:.2f} s" if ax is ax_sel else None)
        ax.grid(alpha=0.3)
        ax.set_xlim(te[0], te[-1])
        if lim is not None:
            ax.set_ylim(lim)
    rows_raw = L.legend_above(ax_raw, min(4, counts.size))
    rows_sel = L.legend_above(ax_sel, 4)
    L.suptitle(fig, f"Signal: {d.recording_name()} — {fs:.4g} Hz, "
                    f"{duration:.4g} s, f₀ = {f0:.4g} Hz")
    L.place(L.gridspec(ax_raw), left=L.y_room([ax_raw, ax_sel]), right=0.2, bottom=L.x_room(),
            top=L.top(L.above(ax_raw, legend_rows=rows_raw)),
            hgap=L.above(ax_sel, legend_rows=rows_sel) + 4 * L.PT)
    return fig


def spectrum_figure(an: Any) -> "Figure":
    """Amplitude spectrum (linear and dB re peak) with the pass band, f₀ and the filter gain.

    The seed paper's Figs 15–17 and 19: the single-sided amplitude spectrum [m/s²] of the
    selected signal on a linear scale with the zero-phase band-pass gain |H|² [1] on a second
    axis; the same in dB re the spectral peak with |H|² [dB] and the spectrum after filtering
    (amplitude·|H|²); the pass band shaded and f₀ [Hz] marked in both panels.
    """
    from scipy import signal as sps

    from dampfit.signal.display import spectrum_limit
    from dampfit.signal.filters import bandpass_sos

    d = as_data(an)
    a = d.arrays("spectrum", "spectrum")
    fs, f0, lo, hi = d.require("spectrum", ("input", "sample_rate_hz"),
                               ("dominant_frequency_hz", None), ("band", "low_hz"),
                               ("band", "high_hz"))
    if not 0 < lo < hi < 0.5 * fs:
        raise MissingData(f"spectrum.png cannot be drawn: the band {lo:g}–{hi:g} Hz of "
                          f"{d.where} is not inside 0–{0.5 * fs:g} Hz")
    fmax = spectrum_limit(f0, hi, fs)
    f, amp = a["spectrum_f"], a["spectrum_amp"]  # reduced for display by the stage
    peak = float(np.max(amp)) if amp.size else 1.0
    db = 20 * np.log10(np.maximum(amp, 1e-12 * peak) / peak)

    sos = bandpass_sos((lo, hi), fs)
    fh = np.linspace(0, fmax, 2000)[1:]
    _, h = sps.sosfreqz(sos, worN=fh, fs=fs)
    gain = np.abs(h) ** 2  # zero-phase (forward–backward): |H|²
    # the spectrum after the zero-phase band-pass is the spectrum times |H|² (the paper's Fig. 19)
    _, hf = sps.sosfreqz(sos, worN=f, fs=fs) if f.size else (None, np.zeros(0))
    db_filt = 20 * np.log10(np.maximum(amp * np.abs(hf) ** 2, 1e-12 * peak) / peak)

    fig = L.new_figure(10.0, 7.0)
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
        ax.axvline(f0, color="tab:red", lw=0.9, ls=":",
                   label=f"f₀ = {f0:.4g} Hz" if ax is ax_db else None)
        ax.grid(alpha=0.3)
    ax_lin.set_xlim(0, fmax)
    lines = ax_lin.get_legend_handles_labels()
    lines_h = ax_h.get_legend_handles_labels()
    ax_lin.legend(lines[0] + lines_h[0], lines[1] + lines_h[1], loc="upper right", fontsize=8)
    ax_db.legend(loc="upper right", fontsize=8)
    L.title(ax_lin, "Linear scale (paper Figs 15 and 17)")
    L.title(ax_db, "Decibels, 20·log₁₀ of amplitude re spectral peak (paper Figs 16 and 19)")
    auto = {True: "auto", False: "given"}.get(d.flag("band", "auto"), "?")
    L.suptitle(fig, f"Spectrum of the selected signal — f₀ = {f0:.4g} Hz, "
                    f"band {lo:.3g}–{hi:.3g} Hz ({auto})")
    L.place(L.gridspec(ax_lin), left=L.y_room([ax_lin, ax_db]), right=L.y_room([ax_h]),
            bottom=L.x_room(), top=L.top(max(L.above(ax_lin), L.above(ax_h, None))),
            hgap=L.above(ax_db) + 4 * L.PT)
    return fig
