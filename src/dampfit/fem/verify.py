"""Run the identified system in OpenSeesPy and compare with the measurement (``dampfit verify DIR``,
:mod:`dampfit.cli.verify`; :func:`verify`).

What it does (the seed paper's Figs 21–26 and 24, made quantitative):

1. System: m = ``mass.value``, k and c = posterior medians of ``DIR/summary.json`` — exactly
   what ``dampfit export --quantile 0.5`` hands to a FEM code.
2. Start: the FEM run starts at the first sample of the analysis window in the state of the
   fitted model, (u, v) from ``accel_model`` of ``DIR/signals.npz``
   (:func:`dampfit.fem.response.initial_state`), so FEM and model share the phase; with the
   model's release-from-rest this is the same free decay the deck of ``export`` describes.
3. Run: OpenSeesPy, zeroLength with Elastic + Viscous (α = 1), Newmark average acceleration
   (γ = 1/2, β = 1/4) with a fixed step Δt that divides the sample interval, from
   :func:`dampfit.fem.timestep.choose` (≥ 200 steps per period and a phase error ≤ 1e-3 rad
   at the end) or ``--dt``; the period error (ωΔt/2)/atan(ωΔt/2) − 1 must be below 1e-4.
4. Compare on the sample times: FEM displacement vs the measured (band-passed, double
   integrated) displacement and FEM acceleration vs the measured band-passed acceleration —
   MAE, MSE, NMSE = MSE/var(measured), regression — and the same against the fitted model;
   the decay rate of the FEM displacement's extrema against the identified p (posterior median).
5. Write ``DIR/verification.json`` (all numbers with units, engine version, Δt) and the figure
   (default ``DIR/verify.png``) atomically; print a short table. An existing report.html/.md
   that dampfit wrote is refreshed; one it did not write is left alone (a note on stdout).

Refusals (exit 2, one line) all come before anything is written: OpenSeesPy unusable; a
``--out`` that exists (a symbolic link too, even a dangling one) without ``--force`` (with it a
link is replaced itself, never its target), is a directory, has a name the file system cannot
hold or a suffix matplotlib cannot write; a bad summary.json or signals.npz (its ZIP directory
and array headers are checked before loading, as :mod:`dampfit.io.readers` does for recordings, so
memory stays bounded by the file). OpenSees runs in a child process
(:func:`dampfit.fem.opensees.free_decay`), so its native exit message never reaches stderr.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from dampfit._files import atomic_write, atomic_write_text, check_output_file
from dampfit.errors import InputError
from dampfit.fem import timestep
from dampfit.fem import response as compare
from dampfit.fem import sdof as sdof_mod
from dampfit.errors import shown
from dampfit.result.schema import is_campaign
from dampfit.result.folder import SIGNAL_KEYS as SIGNAL_KEYS
from dampfit.result.folder import load_signals as load_signals
from dampfit.result.schema import folder_of

__all__ = ["SIGNAL_KEYS", "figure_format", "load_signals", "plot", "run", "table", "verify"]

#: Periods left out at each end for the "interior" error measures (filter settling).
EDGE_PERIODS = 3.0
#: Largest allowed Newmark period error [1].
MAX_PERIOD_ERROR = 1e-4


def run(folder: str | Path | Any, dt: float | None = None) -> dict[str, Any]:
    """Verification of result ``folder`` (or an analysis :func:`dampfit.load` read from one):
    plain-data ``report`` plus the arrays for :func:`plot`.

    ``dt`` [s] overrides the automatic step (it must keep the period error below 1e-4).
    """
    from dampfit.fem import opensees

    folder, summary = sdof_mod.read_summary(folder_of(folder))
    _refuse_campaign(folder, summary)
    ident = sdof_mod.load(folder, 0.5)
    p_id = sdof_mod.summary_quantile(summary, "p", 0.5, folder)  # checked before any work
    sig = load_signals(folder)
    t, tau = sig["t"], sig["t"] - sig["t0"]
    spacing = float(np.median(np.diff(t)))
    span = float(t[-1] - t[0])
    if dt is None:
        dt = timestep.choose(ident.omega_n, span, spacing)
    elif not (math.isfinite(dt) and dt > 0):
        raise InputError(f"--dt must be a positive number of seconds, got {dt!r}")
    period_error = timestep.newmark_period_error(ident.omega_n, dt)
    if period_error > MAX_PERIOD_ERROR:
        dt_max = ident.period / timestep.MIN_STEPS_PER_PERIOD
        raise InputError(f"--dt {dt:g} s gives a Newmark period error {period_error:.2g} > "
                         f"{MAX_PERIOD_ERROR:g}; use --dt {dt_max:.3g} or smaller")
    n_steps = math.ceil(span / dt - 1e-9)
    if n_steps > 2e7:
        raise InputError(f"{n_steps} steps of {dt:g} s are too many; give a larger --dt")
    start = compare.initial_state(tau, sig["accel_model"], sig["p"], sig["omega_d"], tau0=tau[0])
    fem = opensees.free_decay(ident.mass, ident.k, ident.c, start["u"], start["v"], dt, n_steps)
    t_fem = t[0] + fem["t"]
    u_fem = np.interp(t, t_fem, fem["u"])
    a_fem = np.interp(t, t_fem, fem["a"])
    decay = compare.peak_decay_rate(t_fem, fem["u"])
    measured_decay = compare.peak_decay_rate(t, sig["displacement"])
    rel = None if decay["p"] is None or p_id == 0 else decay["p"] / p_id - 1.0
    edge = EDGE_PERIODS * ident.period
    inner = (t >= t[0] + edge) & (t <= t[-1] - edge)
    report = {
        "dampfit_version": summary.get("dampfit_version"),
        "folder": str(folder.resolve()),
        "engine": {"name": "OpenSeesPy", "version": opensees.engine_version(),
                   "model": "zeroLength, uniaxialMaterial Elastic (k) + Viscous (c, alpha=1)",
                   "integrator": "Newmark average acceleration", "gamma": 0.5, "beta": 0.25,
                   "dt_s": dt, "n_steps": n_steps, "steps_per_period": ident.period / dt,
                   "period_error": period_error,
                   "period_error_formula": "(w*dt/2)/atan(w*dt/2) - 1 ~ (w*dt)^2/12",
                   "phase_error_at_end_rad": ident.omega_n * span * period_error,
                   "numerical_damping": 0.0},
        "system": {"quantile": 0.5, "mass": {"value": ident.mass, "unit": "kg"},
                   "k": {"value": ident.k, "unit": "N/m"}, "c": {"value": ident.c, "unit": "N s/m"},
                   "omega_n": {"value": ident.omega_n, "unit": "rad/s"},
                   "zeta": {"value": ident.zeta, "unit": "1"}, "p": {"value": ident.p, "unit": "1/s"}},
        "initial_state": {"t_s": float(t[0]), "u": {"value": start["u"], "unit": "m"},
                          "v": {"value": start["v"], "unit": "m/s"},
                          "accel_model_fit_rms": {"value": start["fit_rms"], "unit": "m/s^2"},
                          "method": "least-squares (A, B) of accel_model on exp(-p tau)cos/sin; "
                                    "u = Re[(A-iB)/s^2 e^(s tau)], v = Re[(A-iB)/s e^(s tau)]"},
        "window": {"t0_s": sig["t0"], "start_s": float(t[0]), "end_s": float(t[-1]),
                   "n_samples": int(t.size), "sample_interval_s": spacing},
        "displacement": {"unit": "m", "vs_measured": compare.errors(sig["displacement"], u_fem),
                         "vs_measured_interior": compare.errors(sig["displacement"][inner],
                                                                u_fem[inner]),
                         "vs_model": compare.errors(sig["displacement_model"], u_fem)},
        "acceleration": {"unit": "m/s^2", "vs_measured": compare.errors(sig["accel"], a_fem),
                         "vs_measured_interior": compare.errors(sig["accel"][inner], a_fem[inner]),
                         "vs_model": compare.errors(sig["accel_model"], a_fem)},
        "interior": {"start_s": float(t[0] + edge), "end_s": float(t[-1] - edge),
                     "why": "three periods at each end left out: the band-pass filters of the "
                            "measured signals settle there"},
        "decay_rate": {"unit": "1/s", "fem_peaks": decay["p"], "fem_n_peaks": decay["n_peaks"],
                       "identified_q50": p_id, "relative_difference": rel,
                       "measured_displacement_peaks": measured_decay["p"],
                       "model_least_squares": sig["p"]},
    }
    arrays = {"t": t, "u_fem": u_fem, "a_fem": a_fem, "u_meas": sig["displacement"],
              "a_meas": sig["accel"], "period": ident.period}
    return {"report": report, "arrays": arrays}


def plot(result: dict[str, Any], path: str | os.PathLike) -> Path:
    """Overlay of measured and FEM displacement and acceleration (full window, first and last
    three periods) as in the paper's Figs 21–26, saved atomically to ``path``."""
    from matplotlib.figure import Figure  # lazy; no pyplot, no global backend change

    a = result["arrays"]
    t, span = a["t"], 3.0 * a["period"]
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    grid = fig.add_gridspec(3, 2)
    full = fig.add_subplot(grid[0, :])
    panels = [(full, None, "u", 1e3, "displacement [mm]")]
    for col, (lo, hi) in enumerate(((t[0], t[0] + span), (t[-1] - span, t[-1]))):
        panels.append((fig.add_subplot(grid[1, col]), (lo, hi), "u", 1e3, "displacement [mm]"))
        panels.append((fig.add_subplot(grid[2, col]), (lo, hi), "a", 1.0, "acceleration [m/s²]"))
    for ax, lim, kind, scale, label in panels:
        sel = slice(None) if lim is None else (t >= lim[0]) & (t <= lim[1])
        ax.plot(t[sel], scale * a[f"{kind}_meas"][sel], color="0.35", lw=0.9, label="measured (MEMS)")
        ax.plot(t[sel], scale * a[f"{kind}_fem"][sel], color="tab:red", lw=0.9, ls="--",
                label="OpenSees FEM")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    full.legend(loc="upper right")
    rep = result["report"]
    s = rep["system"]
    full.set_title(f"FEM (m = {s['mass']['value']:.4g} kg, k = {s['k']['value']:.5g} N/m, "
                   f"c = {s['c']['value']:.4g} N s/m) vs measurement — displacement NMSE "
                   f"{_fmt(rep['displacement']['vs_measured']['nmse'])}, acceleration NMSE "
                   f"{_fmt(rep['acceleration']['vs_measured']['nmse'])}", fontsize=10)
    path = Path(path)
    fmt = figure_format(path)
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format=fmt), suffix=f".{fmt}",
                 shown=shown)
    return path


def figure_format(path: str | os.PathLike) -> str:
    """The figure format of ``path`` from its suffix (none: PNG); :class:`InputError` for a
    suffix matplotlib cannot write (checked before any work)."""
    from matplotlib.backend_bases import FigureCanvasBase

    suffix = Path(path).suffix.lower().lstrip(".")
    if not suffix:
        return "png"
    supported = FigureCanvasBase.get_supported_filetypes()
    if suffix not in supported:
        raise InputError(f"cannot write the figure {shown(path)}: unknown format .{suffix}; use "
                         f"one of {', '.join('.' + k for k in sorted(supported))}")
    return suffix


def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "n/a" if x is None else format(x, spec)


def table(rep: dict[str, Any]) -> str:
    """The short table ``dampfit verify`` prints of a verification ``rep``."""
    e, s, d = rep["engine"], rep["system"], rep["decay_rate"]
    lines = [
        f"dampfit verify — {rep['folder']}",
        f"  {e['name']} {e['version']}: {e['model']}",
        (f"  {e['integrator']} (gamma 1/2, beta 1/4), dt = {e['dt_s']:.4g} s = "
         f"T/{e['steps_per_period']:.0f}, period error {e['period_error']:.2g}, "
         f"phase error {e['phase_error_at_end_rad']:.2g} rad at the end"),
        (f"  system (posterior median): m = {s['mass']['value']:.6g} kg, "
         f"k = {s['k']['value']:.6g} N/m, c = {s['c']['value']:.6g} N s/m"),
        "",
        f"  FEM vs {'':13s}{'MAE':>11s}{'MSE':>11s}{'NMSE':>11s}{'interior':>11s}{'model':>11s}",
    ]
    for key, label in (("displacement", "displacement [m]"), ("acceleration", "accel. [m/s^2]")):
        m, mi, mm = (rep[key][x] for x in ("vs_measured", "vs_measured_interior", "vs_model"))
        lines.append(f"  {label:20s}{_fmt(m['mae']):>11s}{_fmt(m['mse']):>11s}"
                     f"{_fmt(m['nmse']):>11s}{_fmt(mi['nmse']):>11s}{_fmt(mm['nmse']):>11s}")
    lines.append("  (NMSE = MSE/var(measured); interior: without 3 periods at each end; model: "
                 "the fitted decay)")
    rel = d["relative_difference"]
    diff = "n/a" if rel is None else f"{100 * rel:+.3f} %"
    lines += ["", (f"  decay rate p [1/s]: FEM peaks {_fmt(d['fem_peaks'], '.6g')}, identified "
                   f"{_fmt(d['identified_q50'], '.6g')} (posterior median), difference {diff}")]
    return "\n".join(lines)


def _refuse_campaign(folder: Path, summary: dict) -> None:
    """One line for a campaign folder: verify compares one recording with its FEM model."""
    if is_campaign(summary):
        n = len(summary.get("tests") or [])
        raise InputError(f"{shown(folder)} is a campaign of {n} tests: verify compares one "
                         "recording with its FEM model; verify a single-recording result "
                         "('dampfit analyze FILE --mass KG --out DIR', then 'dampfit verify DIR')")


def verify(result: str | Path | Any, dt: float | None = None, out: str | Path | None = None,
           force: bool = False) -> dict[str, Any]:
    """Verify ``result`` (a result folder, or an analysis :func:`dampfit.load` read from one):
    write ``FOLDER/verification.json`` and the figure ``out`` (default ``FOLDER/verify.png``),
    and refresh a report dampfit wrote in the folder.

    First of all OpenSeesPy must be usable (:func:`dampfit.fem.opensees.unavailable`): if not,
    one error line says why and how to fix it, before any file is read or written. Everything
    that can refuse is checked before anything is written. Returns ``{"report": the
    verification, "json": path, "figure": path, "report_refresh": True | False | why not,
    "report_error": message or None}`` (``report_refresh`` True: report.html/.md rewritten).
    """
    from dampfit.fem import opensees

    reason = opensees.unavailable()
    if reason is not None:
        raise InputError(reason)
    folder = folder_of(result)
    _refuse_campaign(*sdof_mod.read_summary(folder))
    if out:
        fig = check_output_file(out, force)
    else:
        fig = folder / "verify.png"  # verify's own file in the result folder: refreshed
    figure_format(fig)
    refresh = _report_refresh(folder)
    result = run(folder, dt)  # reads and checks every input; nothing written yet
    for own in {fig, folder / "verification.json"}:  # verify's own files: never a folder
        if own.is_dir() and not own.is_symlink():
            raise InputError(f"refusing to overwrite {shown(own)}: it is a directory")
    rep = result["report"]
    rep["figure"] = str(fig)
    text = json.dumps(rep, indent=2, allow_nan=False) + "\n"
    plot(result, fig)
    atomic_write_text(folder / "verification.json", text)
    error = None
    if refresh is True:  # keep an existing report complete
        from dampfit.output.report import write_report

        try:
            write_report(folder)
        except InputError as exc:  # the verification itself is written
            refresh, error = False, " ".join(str(exc).split())
    return {"report": rep, "json": folder / "verification.json", "figure": fig,
            "report_refresh": refresh, "report_error": error}


def _report_refresh(folder: Path) -> bool | str:
    """Whether verify refreshes the folder's report: False (there is none), True (dampfit
    wrote it), or why not (a report.html/report.md that dampfit did not write is left alone;
    decided read-only with the report module's own ownership test)."""
    html = folder / "report.html"
    if not os.path.lexists(html):
        return False
    from dampfit.output import report

    for name, marker in (("report.html", report._MARK_HTML), ("report.md", report._MARK_MD)):
        path = folder / name
        if os.path.islink(path) or (os.path.lexists(path) and not report._ours(path, marker)):
            return f"{shown(path)} was not written by dampfit (use 'dampfit report --force')"
    return True
