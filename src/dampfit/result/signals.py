"""What ``signals.npz`` of a result folder holds, how it is checked when read, and how it is written.

Every array is float64 in SI units (:meth:`dampfit.analysis.Analysis.signals`).

Required (:data:`SIGNAL_KEYS`; ``dampfit verify`` and ``export`` read them), on the analysis
window:

* ``t`` [s] — at least 16 finite, increasing times (the window of the uniform grid);
* ``accel``, ``accel_model`` [m/s²] — band-passed measured and least-squares acceleration,
  finite; ``displacement``, ``displacement_model`` [m] — the paper's displacement (NaN when
  its pipeline failed) and the model's; all as long as ``t``;
* scalars ``p`` ≥ 0 [1/s], ``omega_d`` > 0 [rad/s], ``t0`` [s] (window start); optional ``fs``
  [Hz].

Optional: the figure arrays (:func:`dampfit.stages.figure_signals`), in groups
(:data:`FIGURE_GROUPS`) that are present whole or not at all; a folder written before they
existed simply cannot redraw those figures (:mod:`dampfit.output.figures`):

* ``signal`` — the whole recording reduced for display: ``rec_axes_t`` [s] and ``rec_axes_y``
  [m/s²] every axis on the grid, concatenated, ``rec_axes_n`` points per axis (at most
  :data:`MAX_AXES` axes); ``rec_signal_t``/``_y`` the selected signal; ``rec_envelope_t``/``_y``
  its band-pass envelope; ``rec_masked_t``/``_y`` masked samples (clipped or in spikes);
  ``rec_masked_runs`` (r, 2) their runs (start, end) [s]; ``rec_ylim`` (2, 2) y limits of the
  axes and of the signal [m/s²] (NaN: none);
* ``spectrum`` — ``spectrum_f`` [Hz], ``spectrum_amp`` [m/s²] single-sided amplitude spectrum;
* ``fit`` — ``fit_t`` [s], ``fit_y`` [m/s²], ``fit_residual`` [m/s²] the fitted samples;
  ``fit_model_t``/``_y`` the least-squares model on a fine grid; ``fit_raw_t``/``_y`` the
  recorded signal in the first and last cycles of the fitted span, the fit figure's zooms
  (empty when the raw samples are fitted);
* ``displacement`` — on ``t``: ``disp_envelope`` [m] Hilbert envelope, ``disp_envelope_fit``
  [m] its fit, ``disp_fit_mask`` 1/0 samples used; scalars ``disp_p`` [1/s], ``disp_c``
  [N·s/m] and ``disp_zeta`` [1] (NaN: none);
* ``log_decrement`` — ``logdec_peak_t`` [s], ``logdec_peak_a`` [m/s²], scalar ``logdec_p``.

Bounds: reduced lines hold at most :data:`MAX_LINE` points, masked samples and model grids
at most :data:`MAX_DOTS`, masked runs at most :data:`~dampfit.signal.display.MAX_RUNS` + 1;
the other arrays at most twice as many points as ``t`` or :data:`MAX_DOTS`, whichever is
larger. So signals.npz of a long recording grows only with its
analysed window (16 bytes a sample for each window-long array; ≈ 3.5 MB for 55 s at 500 Hz).
Arrays other than these keys are ignored. :func:`check_signals` refuses (one-line
:class:`~dampfit.errors.InputError`) anything else: a wrong shape or dtype, infinities, NaN
where a value is required, a group in part.
"""

from __future__ import annotations

import math
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.files.atomic import atomic_write
from dampfit.errors import InputError
from dampfit.errors import shown
from dampfit.signal.display import MAX_DOTS as _DISPLAY_DOTS
from dampfit.signal.display import MAX_LINE_POINTS, MAX_RUNS

#: Arrays and scalars ``signals.npz`` must hold.
SIGNAL_KEYS = ("t", "accel", "accel_model", "displacement", "displacement_model", "p",
               "omega_d", "t0")
#: Optional groups of figure arrays: group → keys (all or none).
FIGURE_GROUPS: dict[str, tuple[str, ...]] = {
    "signal": ("rec_axes_t", "rec_axes_y", "rec_axes_n", "rec_signal_t", "rec_signal_y",
               "rec_envelope_t", "rec_envelope_y", "rec_masked_t", "rec_masked_y",
               "rec_masked_runs", "rec_ylim"),
    "spectrum": ("spectrum_f", "spectrum_amp"),
    "fit": ("fit_t", "fit_y", "fit_residual", "fit_model_t", "fit_model_y", "fit_raw_t",
            "fit_raw_y"),
    "displacement": ("disp_envelope", "disp_envelope_fit", "disp_fit_mask", "disp_p",
                     "disp_c", "disp_zeta"),
    "log_decrement": ("logdec_peak_t", "logdec_peak_a", "logdec_p"),
}
#: Every key read from signals.npz.
KNOWN_KEYS = (*SIGNAL_KEYS, "fs", *(k for keys in FIGURE_GROUPS.values() for k in keys))
#: Most axes of a recording drawn.
MAX_AXES = 16
#: Most points of a reduced line (:func:`dampfit.signal.display.keep_extremes`).
MAX_LINE = MAX_LINE_POINTS + 2
#: Most masked samples, runs and model-grid points.
MAX_DOTS = _DISPLAY_DOTS + 2
#: Scalars (NaN allowed where marked).
_SCALARS = {"fs": False, "disp_p": False, "disp_c": True, "disp_zeta": True, "logdec_p": True}
#: 1-D pairs of equal length and their bound ("line", "dots", or "window": at most max(t, dots)).
_PAIRS = (("rec_signal_t", "rec_signal_y", "line"), ("rec_envelope_t", "rec_envelope_y", "line"),
          ("rec_masked_t", "rec_masked_y", "dots"), ("spectrum_f", "spectrum_amp", "line"),
          ("fit_model_t", "fit_model_y", "dots"), ("fit_raw_t", "fit_raw_y", "window"),
          ("logdec_peak_t", "logdec_peak_a", "window"))


def group_of(key: str) -> str | None:
    """The figure group of ``key``, or None for a required key."""
    return next((g for g, keys in FIGURE_GROUPS.items() if key in keys), None)


def check_signals(sig: dict[str, np.ndarray], path: Path) -> dict[str, np.ndarray]:
    """The known arrays of ``sig`` (float arrays read from ``path``) after the checks of the
    module docstring; unknown keys dropped. :class:`InputError` (one line) otherwise."""
    where = shown(path)
    missing = [k for k in SIGNAL_KEYS if k not in sig]
    if missing:
        raise InputError(f"{where} lacks {', '.join(missing)}; re-run 'dampfit analyze'")
    out = {k: v for k, v in sig.items() if k in KNOWN_KEYS}
    t = out["t"]
    n = t.size
    if t.ndim != 1 or n < 16 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError(f"{where}: 't' must be at least 16 finite, increasing times")
    for key in ("accel", "accel_model", "displacement", "displacement_model"):
        if out[key].shape != (n,):
            raise InputError(f"{where}: '{key}' has shape {out[key].shape}, expected ({n},)")
    if not (np.all(np.isfinite(out["accel"])) and np.all(np.isfinite(out["accel_model"]))):
        raise InputError(f"{where}: 'accel' and 'accel_model' must be finite")
    if np.any(np.isinf(out["displacement"])) or np.any(np.isinf(out["displacement_model"])):
        raise InputError(f"{where}: 'displacement' and 'displacement_model' must not be infinite")
    for key in ("p", "omega_d", "t0"):
        if out[key].size != 1:
            raise InputError(f"{where}: '{key}' must be one number, got shape {out[key].shape}")
    p, w, t0 = (float(out[k].reshape(())) for k in ("p", "omega_d", "t0"))
    if not (math.isfinite(p) and p >= 0 and math.isfinite(w) and w > 0 and math.isfinite(t0)):
        raise InputError(f"{where}: p, omega_d and t0 must be finite (p >= 0, omega_d > 0)")
    for group, keys in FIGURE_GROUPS.items():
        have = [k for k in keys if k in out]
        if have and len(have) < len(keys):
            lack = [k for k in keys if k not in out]
            raise InputError(f"{where}: the {group} figure arrays are incomplete (no "
                             f"{', '.join(lack[:3])}); re-run 'dampfit analyze'")
    _check_figure_arrays(out, n, where)
    return out


def _check_figure_arrays(sig: dict[str, np.ndarray], n: int, where: str) -> None:
    """Shapes, bounds and finiteness of the optional figure arrays present in ``sig``."""
    def fail(key: str, what: str) -> InputError:
        return InputError(f"{where}: '{key}' {what}; re-run 'dampfit analyze'")

    limit = {"line": MAX_LINE, "dots": MAX_DOTS, "window": max(2 * n, MAX_DOTS)}
    for key, nan_ok in _SCALARS.items():
        if key in sig:
            x = sig[key]
            if x.size != 1 or np.isinf(x).any() or (np.isnan(x).any() and not nan_ok):
                raise fail(key, "must be one finite number")
    for a, b, bound in _PAIRS:
        if a in sig:
            if sig[a].ndim != 1 or sig[b].shape != sig[a].shape:
                raise fail(b, f"must be one line as long as '{a}'")
            if sig[a].size > limit[bound]:
                raise fail(a, f"holds {sig[a].size} points, more than {limit[bound]}")
    for key in ("disp_envelope", "disp_envelope_fit", "disp_fit_mask"):
        if key in sig and sig[key].shape != (n,):
            raise fail(key, f"has shape {sig[key].shape}, expected ({n},) like 't'")
    if "fit_t" in sig:
        m = sig["fit_t"].size
        if sig["fit_t"].ndim != 1 or m < 2 or m > limit["window"] or any(
                sig[k].shape != (m,) for k in ("fit_y", "fit_residual")):
            raise fail("fit_t", "and 'fit_y', 'fit_residual' must be one line of 2 or more "
                                "points, at most as long as 't'")
        if sig["fit_model_t"].size < 2:
            raise fail("fit_model_t", "must hold 2 or more points")
    if "rec_axes_t" in sig:
        _check_axes(sig, fail)
    if "spectrum_f" in sig and sig["spectrum_f"].size < 1:
        raise fail("spectrum_f", "must hold at least one frequency")
    for key, keys in FIGURE_GROUPS.items():
        for k in keys:
            if k in sig and k not in _SCALARS and k != "rec_ylim" and not np.all(
                    np.isfinite(sig[k])):
                raise fail(k, "must be finite")
    if "rec_ylim" in sig and (sig["rec_ylim"].shape != (2, 2) or np.isinf(sig["rec_ylim"]).any()):
        raise fail("rec_ylim", "must be two (low, high) limits")


def _check_axes(sig: dict[str, np.ndarray], fail) -> None:
    counts, t = sig["rec_axes_n"], sig["rec_axes_t"]
    if counts.ndim != 1 or not 1 <= counts.size <= MAX_AXES:
        raise fail("rec_axes_n", f"must count the points of 1 to {MAX_AXES} axes")
    if not (np.all(np.isfinite(counts)) and np.all(counts >= 1) and np.all(counts <= MAX_LINE)
            and np.all(counts == np.round(counts))):
        raise fail("rec_axes_n", f"must be whole numbers from 1 to {MAX_LINE}")
    if t.ndim != 1 or sig["rec_axes_y"].shape != t.shape or t.size != int(counts.sum()):
        raise fail("rec_axes_t", "and 'rec_axes_y' must hold exactly the points 'rec_axes_n' "
                                 "counts")
    runs = sig["rec_masked_runs"]
    if runs.ndim != 2 or runs.shape[1:] != (2,) or runs.shape[0] > MAX_RUNS + 1:
        raise fail("rec_masked_runs", f"must be at most {MAX_RUNS + 1} (start, end) pairs")


#: zlib level of signals.npz: 1 compresses float64 samples about as well as NumPy's default
#: (6), several times faster.
NPZ_COMPRESSION = 1


def write_npz(path: str | os.PathLike, arrays: dict[str, Any]) -> Path:
    """Write ``arrays`` to the ``.npz`` file ``path`` atomically (what ``numpy.savez_compressed``
    writes, at zlib level :data:`NPZ_COMPRESSION`; read back by :func:`numpy.load`)."""
    def write(tmp: str) -> None:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED,
                             compresslevel=NPZ_COMPRESSION, allowZip64=True) as zf:
            for key, value in arrays.items():
                with zf.open(f"{key}.npy", "w", force_zip64=True) as fh:
                    np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=False)

    return atomic_write(path, write, suffix=".npz")
