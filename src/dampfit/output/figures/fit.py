"""Figures of the least-squares fit: the fit itself and the paper's displacement pipeline.

* :func:`fit_figure` (``fit.png``) — fitted samples, least-squares model, zooms, residuals;
* :func:`displacement_figure` (``displacement.png``) — the paper's envelope pipeline (its
  Fig. 20) against the least-squares envelope.

Drawn from the signals' ``fit``, ``displacement`` and ``log_decrement`` figure arrays and the
summary's ``least_squares``, ``noise_model`` and ``fit`` sections
(:class:`~dampfit.output.figures.data.FigureData`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dampfit import physics
from dampfit.output.figures import layout as L
from dampfit.output.figures.data import as_data, fmt, unit
from dampfit.signal.display import MAX_DOTS, ZOOM_CYCLES, keep_extremes, zoom_ranges

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure


def fit_figure(an: Any) -> "Figure":
    """Fitted samples and the least-squares model: whole window, first/last cycles, residuals.
    ``an``: an analysis or its :class:`~dampfit.output.figures.data.FigureData`."""
    d = as_data(an)
    a = d.arrays("fit", "fit")
    vals = d.ls_values()
    fs_fit, sigma = d.require("fit", ("fit", "sample_rate_hz"), ("noise_model", "sigma"))
    f0 = vals["f_d"]  # from omega_d, which signals.npz always holds
    t_fit, y_fit = a["fit_t"], a["fit_y"]
    t_mod, y_mod = a["fit_model_t"], a["fit_model_y"]
    path = d.text("fit", "path", "?")

    fig = L.new_figure(11.0, 8.5)
    gs_all, gs_zoom, gs_res = (fig.add_gridspec(1, n) for n in (1, 2, 1))
    ax_all = fig.add_subplot(gs_all[0])
    ax_z0 = fig.add_subplot(gs_zoom[0])
    ax_z1 = fig.add_subplot(gs_zoom[1])
    ax_res = fig.add_subplot(gs_res[0], sharex=ax_all)

    many = t_fit.size > 3000
    # dense samples (raw path) would hide the model: draw them small and faint, model on top
    per_cycle = fs_fit / max(f0, 1e-12)
    dense = per_cycle > 25
    dot = dict(ls="none", marker=".", color="tab:blue", zorder=2,
               ms=1.5 if dense else 4.0, alpha=0.35 if dense else 1.0)
    line = dict(color="tab:red", zorder=3)
    tr, yr = keep_extremes(t_fit, y_fit, MAX_DOTS) if many else (t_fit, y_fit)
    tm, ym = keep_extremes(t_mod, y_mod)
    ax_all.plot(tr, yr, **dot,
                label=f"fitted samples ({path}, {fs_fit:.3g} Hz, n = {y_fit.size})")
    ax_all.plot(tm, ym, lw=0.7, **line, label="least-squares model")
    ax_all.set_ylabel("acceleration [m/s²]")
    L.title(ax_all, "Whole analysed window", loc="left")

    t_start, t_end = float(t_fit[0]), float(t_fit[-1])
    ranges = zoom_ranges(t_start, t_end, f0)
    t_raw, y_raw = a["fit_raw_t"], a["fit_raw_y"]  # the recording in those ranges
    for ax, (lo, hi), name in zip((ax_z0, ax_z1), ranges, ("First", "Last")):
        if path != "raw":  # the fitted samples are filtered: show the recording beside them
            raw = (t_raw >= lo) & (t_raw <= hi)
            tr_, yr_ = keep_extremes(t_raw[raw], y_raw[raw])
            ax.plot(tr_, yr_, lw=0.6, color="0.6", zorder=1, label="recorded signal (raw)")
        s = (t_fit >= lo) & (t_fit <= hi)
        ax.plot(t_fit[s], y_fit[s], **{**dot, "ms": 3.0 if dense else 5.0},
                label="fitted samples")
        m = (t_mod >= lo) & (t_mod <= hi)
        ax.plot(t_mod[m], y_mod[m], lw=1.3, **line, label="least-squares model")
        ax.set_xlim(lo, hi)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("acceleration [m/s²]")
        L.title(ax, f"{name} {ZOOM_CYCLES:g} cycles")
        ax.grid(alpha=0.3)
        _phase_comment(ax, t_fit[s], y_fit[s], t_mod, y_mod, f0)
    ax_z0.legend(loc="upper right", fontsize=7, framealpha=0.9)

    rows_res = _residuals(ax_res, t_fit, a["fit_residual"], dot, per_cycle, many, sigma, d)
    for ax in (ax_all, ax_res):
        ax.grid(alpha=0.3)
    ax_all.set_xlim(t_start, t_end)
    rows_all = L.legend_above(ax_all, 2)
    ax_all.tick_params(labelbottom=False)

    head = f"c = {fmt(vals['c'])} {unit('c')}, " if "c" in vals else ""
    status = "" if d.flag("least_squares", "converged") is not False else "  (NOT converged)"
    L.suptitle(fig, f"Least-squares fit: {head}ζ = {fmt(vals.get('zeta'))}, "
                    f"f_n = {fmt(vals.get('f_n'), 6)} {unit('f_n')}, "
                    f"u₀ = {fmt(vals.get('u0'))} {unit('u0')}{status}")
    left = L.y_room([ax_all, ax_z0, ax_res])
    rows = L.spans(fig.get_figheight(), L.top(L.above(ax_all, legend_rows=rows_all)),
                   L.x_room(), [1.1, 1.0, 0.8],
                   [max(L.above(ax_z0), L.above(ax_z1)) + 4 * L.PT,
                    L.x_room() - L.EDGE + L.above(ax_res, legend_rows=rows_res)])
    for gs, (top, bottom) in zip((gs_all, gs_zoom, gs_res), rows):
        L.place(gs, left=left, right=0.2, top=top, bottom=bottom,
                wgap=L.y_room([ax_z1]) + 0.15)
    return fig


#: |phase| [deg] between the data and the model in a zoom panel from which it is commented.
PHASE_COMMENT_DEG = 30.0


def phase_offset(t: np.ndarray, y: np.ndarray, t_mod: np.ndarray, y_mod: np.ndarray,
                 f0: float) -> float:
    """Phase [deg] of the data ``y`` relative to the model over the samples ``t`` [s]: ``y ≈
    A·m + B·q`` by least squares, with m the model interpolated at ``t`` and q its quadrature
    (dm/dt)/(2π·f0), φ = atan2(B, A) (> 0: the data lead). NaN with too few samples."""
    if t.size < 8 or t_mod.size < 2 or not f0 > 0:
        return float("nan")
    m = np.interp(t, t_mod, y_mod)
    q = np.gradient(m, t) / (2 * np.pi * f0)
    coef, *_ = np.linalg.lstsq(np.column_stack([m, q]), y, rcond=None)
    return float(np.degrees(np.arctan2(coef[1], coef[0])))


def _phase_comment(ax, t, y, t_mod, y_mod, f0) -> None:
    """A note in a zoom panel whose model is out of phase with the data (|φ| >
    :data:`PHASE_COMMENT_DEG`): the frequency drifts, or the model is wrong there."""
    phi = phase_offset(t, y, t_mod, y_mod, f0)
    if np.isfinite(phi) and abs(phi) > PHASE_COMMENT_DEG:
        ax.text(0.02, 0.04, f"model {abs(phi):.0f}° {'behind' if phi > 0 else 'ahead of'} the "
                "data here:\nthe frequency drifts over the decay\n(see f(A) in amplitude.png)",
                transform=ax.transAxes, fontsize=7, color="tab:red", va="bottom",
                bbox=dict(boxstyle="round", fc="white", ec="tab:red", alpha=0.85), zorder=5)


def _residuals(ax, t_fit, res, dot, per_cycle, many, sigma, d) -> int:
    """The residual panel: residuals, their one-period running mean, ±2σ (σ [m/s²] of the
    noise model); returns the rows of its legend."""
    rr_t, rr = keep_extremes(t_fit, res, MAX_DOTS) if many else (t_fit, res)
    ax.plot(rr_t, rr, **{**dot, "color": "0.3"})
    n_avg = int(round(per_cycle))
    if n_avg >= 3 and res.size > 3 * n_avg:
        from scipy import ndimage

        smooth = ndimage.uniform_filter1d(res, n_avg, mode="nearest")
        ts, ys = keep_extremes(t_fit, smooth)
        ax.plot(ts, ys, color="tab:orange", lw=1.2, zorder=3, label="one-period running mean")
    ax.axhline(0, color="tab:red", lw=0.8)
    for sgn in (-2, 2):
        ax.axhline(sgn * sigma, color="tab:red", lw=0.7, ls="--",
                   label="±2σ" if sgn > 0 else None)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("residual [m/s²]")
    lag1 = d.number("noise_model", "residual_lag1_autocorrelation")
    r = d.number("noise_model", "psd_ratio_at_f0")
    L.title(ax, f"Residuals (σ = {sigma:.3g} m/s², lag-1 autocorrelation "
                f"{lag1:+.2f}, PSD ratio at f₀ r = {r:.2g})", loc="left")
    return L.legend_above(ax, 2)


def displacement_figure(an: Any) -> "Figure | None":
    """The paper's Fig. 20 analogue: envelope-pipeline displacement with its envelope fits.

    Returns ``None`` when the envelope pipeline baseline was not computed (its figure arrays
    are absent; so are those of a folder written before they existed: see
    :meth:`~dampfit.output.figures.data.FigureData.arrays`).
    """
    d = as_data(an)
    a = d.arrays("displacement", "displacement", optional=True)
    if a is None:
        return None
    sig = d.signals
    t, u = sig["t"], sig["displacement"]
    env, env_fit = a["disp_envelope"], a["disp_envelope_fit"]
    mask = a["disp_fit_mask"] != 0
    vals = d.ls_values()
    p_ls, u0 = d.require("displacement", ("least_squares", "p"), ("least_squares", "u0"))
    t0 = d.scalar("t0")
    ls_env = u0 * np.exp(-p_ls * (t - t0))
    base_p, base_c, base_zeta = (d.scalar(k) for k in ("disp_p", "disp_c", "disp_zeta"))

    fig = L.new_figure(11.0, 7.5)
    ax_lin, ax_log = fig.subplots(2, 1, sharex=True, height_ratios=[1.2, 1.0])
    tt, uu = keep_extremes(t, u)
    ax_lin.plot(tt, uu, lw=0.6, color="tab:blue", label="displacement (band-pass, ∫∫, band-pass)")
    for ax in (ax_lin, ax_log):
        te, ee = keep_extremes(t, env)
        ax.plot(te, ee, lw=1.0, color="tab:orange", label="Hilbert envelope")
        ax.plot(t, np.where(mask, env_fit, np.nan), lw=1.6, color="black",
                label=f"envelope fit K·e^(−pt), p = {base_p:.4g} 1/s")
        ax.plot(t, np.where(mask, np.nan, env_fit), lw=1.0, ls=":", color="black")
        ax.plot(t, ls_env, lw=1.3, ls="--", color="tab:red",
                label=f"least squares u₀·e^(−p(t−t₀)), p = {p_ls:.4g} 1/s")
    ax_lin.plot(t, -ls_env, lw=1.3, ls="--", color="tab:red")

    if mask.any():
        tm = t[mask]
        for ax in (ax_lin, ax_log):
            ax.axvspan(t[0], tm[0], color="0.5", alpha=0.12, lw=0)
            ax.axvspan(tm[-1], t[-1], color="0.5", alpha=0.12, lw=0,
                       label="not used by the envelope fit" if ax is ax_log else None)

    ld = d.arrays("displacement", "log_decrement", optional=True)
    if ld is not None and "omega_d" in vals:
        pk_a = physics.quantities(p_ls, vals["omega_d"], accel_amplitude=ld["logdec_peak_a"])[
            "u0"]  # displacement = acceleration / ω_n²
        ax_log.plot(ld["logdec_peak_t"], pk_a, "o", ms=3, mfc="none", color="tab:green",
                    label=f"log-decrement peaks ÷ ω_n² (p = {d.scalar('logdec_p'):.4g} 1/s)")

    ax_lin.set_ylabel("displacement [m]")
    ax_log.set_yscale("log")
    L.log_ticks(ax_log.yaxis)
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
    rows_lin = L.legend_above(ax_lin, 2)
    # the log panel repeats the envelope lines: label only what is new there
    handles, labels = ax_log.get_legend_handles_labels()
    new = [(h, lab) for h, lab in zip(handles, labels)
           if lab.startswith(("not used", "log-decrement"))]
    rows_log = L.legend_above(ax_log, 2, *zip(*new)) if new else 0
    head = (f"c = {fmt(base_c)} (envelope) vs {fmt(vals.get('c'))} (LS) {unit('c')}"
            if np.isfinite(base_c) else
            f"ζ = {fmt(base_zeta)} (envelope) vs {fmt(vals.get('zeta'))} (LS)")
    L.suptitle(fig, f"Displacement from the paper's envelope pipeline and decay envelopes — {head}")
    L.place(L.gridspec(ax_lin), left=L.y_room([ax_lin, ax_log]), right=0.2, bottom=L.x_room(),
            top=L.top(L.above(ax_lin, None, legend_rows=rows_lin)),
            hgap=L.above(ax_log, None, legend_rows=rows_log) + 4 * L.PT)
    return fig
