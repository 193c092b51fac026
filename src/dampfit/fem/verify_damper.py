"""The damper's part of ``dampfit verify`` (issue 32; :mod:`dampfit.fem.verify`): the start
state of a nonlinear damper, the linear dashpot run beside the exported deck, the envelope and
ζ(A) comparisons with the measurement, the draws' band, and their lines in the table.
"""

from __future__ import annotations

import hashlib
import shlex
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import InputError
from dampfit.fem import response


def damper_runs(source, script, run, measured, exported, omega_n, interior,
                draws) -> tuple[dict[str, Any], dict[str, Any]]:
    """The damper's part of :func:`dampfit.fem.verify.run`, the entries it adds to the
    report and the arrays: the linear dashpot's run beside a nonlinear export,
    :func:`damper_check` and the draws' band. ``source`` = (folder, summary), ``run`` =
    (start state, dt [s], n_steps), ``measured`` and ``exported`` = (t [s], |a|/ω_n² [m]),
    ``interior`` (start, end) [s], ``draws`` = (N or None, seed).

    The envelopes compared are displacement amplitudes from the accelerations, |a|/ω_n²
    (``measured`` and ``exported`` are handed in so): the measured acceleration is what the
    sensor measured, while its double integral carries the baseline wander of the
    integration (on the phone spring its peaks scatter by tens of percent near the end); for
    a lightly damped oscillation the displacement amplitude is |a|/ω² to O(ζ²), for the
    simulated runs alike."""
    from dampfit.fem import opensees

    (folder, summary), (start, dt, n_steps) = source, run
    (t, u_meas), (t_fem, _), (n_draws, seed) = measured, exported, draws
    report: dict[str, Any] = {}
    arrays: dict[str, Any] = {}
    runs = {"exported": exported}
    exported_law, rec = script["damper"]["law"], script["damper"].get("recommended")
    if exported_law != "viscous":
        # the linear dashpot, and the measured curve — or, when the export wrote the curve
        # because the recommended law misses the decay, that law
        other = (("recommended_law", rec) if exported_law == "measured" and rec
                 not in (None, "viscous", "measured") else ("measured", "measured"))
        for key, law in (("linear", "viscous"), other):
            try:
                side_text, side = linear_script(folder, script, law)
            except InputError as exc:  # too few peaks for a curve: verify the rest
                if key == "linear":
                    raise
                report[f"{key}_script"] = {"law": law, "error": str(exc)}
                continue
            res = opensees.run_steps(side_text, start["u"], start["v"], dt, n_steps,
                                     name=side["name"])
            side["run_options"] = res["options"]
            runs[key] = (t_fem, res["a"] / omega_n ** 2)
            arrays[f"u_{key}"] = np.interp(t, t_fem, res["u"], left=np.nan)
            report[f"{key}_script"] = side
    report["damper"] = damper_check(summary, folder, t, u_meas, runs, omega_n, interior,
                                    script["damper"])
    if n_draws:
        from dampfit.fem import draws as draws_mod
        from dampfit.fem.export import Deck, build

        def one_deck(name=None, variant=None):
            return build(folder, "opensees", Deck(duration=n_steps * dt), name=name,
                         variant=variant)

        band = draws_mod.verify_band(one_deck, folder, (n_draws, seed), run, measured,
                                     interior, omega_n)
        report["draws"], arrays["band"] = band["report"], band["arrays"]
    return report, arrays


#: Periods of the measured acceleration a nonlinear damper's start state is fitted to (they
#: begin response.EDGE_PERIODS after the window start, verify's interior edge).
START_PERIODS = 3.0
EDGE_PERIODS = response.EDGE_PERIODS


def start_state(tau: np.ndarray, sig: dict[str, Any], period: float, law: str,
                omega_n: float | None = None) -> dict:
    """The start state (:func:`dampfit.fem.response.initial_state`): of a viscous damper from
    the fitted model over the window (its model is that decay); of a nonlinear one from the
    measured acceleration over the first :data:`START_PERIODS` periods — the viscous model's
    amplitude at the window start is a compromise over the whole nonlinear decay (6 % low on
    the phone spring), while over three periods the decay is a constant rate to O(ζ·ω·3T).
    Those periods are the first :data:`EDGE_PERIODS` after the window start, where
    verify's comparison begins (before them the band-pass filters of the measured signal
    settle: on the ADXL357 cantilevers the first peaks lie ~1.5 % below the decay that
    follows), and the runs start there (``offset_s`` after the window start; the viscous
    run starts at the window start, its state from the fitted model, not from the samples).
    The state's amplitude is the measured envelope's trend there (the 15-peak trend of the
    interior's peaks verify compares every run with, :func:`_trend_amplitude`, so one noisy
    span of three periods cannot offset all runs; the same start for each run), its phase
    the fit's. That rate is the local one of those periods' peaks
    (:func:`response.peak_decay_rate`, ``p_local``), not the viscous p of the whole window: the amplitude fitted over the span is
    carried back 1.5 periods to its start at that rate, and with the window's p instead it
    came out ~1 % low on the ADXL357 cantilevers, an offset every nonlinear run then kept.
    The trend and the state's amplitude use ``omega_n``, the deck's ω_n (the damper
    section's k, which every nonlinear deck and the measured curve's fit use), so that a run's
    acceleration amplitude ω_n²·|u| starts on the measured acceleration's trend; with the
    viscous fit's ω_d instead the start sat 2·ln(ω_n/ω_d) ≈ 0.05–0.1 % above it on the real
    recordings."""
    if law == "viscous":
        return response.initial_state(tau, sig["accel_model"], sig["p"], sig["omega_d"],
                                      tau0=tau[0])
    begin = tau[0] + EDGE_PERIODS * period
    sel = (tau >= begin) & (tau <= begin + START_PERIODS * period)
    local = response.peak_decay_rate(tau[sel], sig["accel"][sel])["p"]
    p = local if local is not None and local > 0 else sig["p"]
    out = response.initial_state(tau[sel], sig["accel"][sel], p, sig["omega_d"], tau0=begin)
    out.update({"p_local": float(p), "offset_s": float(begin - tau[0])})
    w = float(omega_n or sig["omega_d"])  # the ω of the envelopes compared, |a|/ω_n²
    trend = _trend_amplitude(tau, sig["accel"] / w ** 2, begin, tau[-1] - EDGE_PERIODS * period)
    if trend is not None:  # the amplitude of the measured trend there, the phase of the fit
        scale = trend / float(np.hypot(out["u"], out["v"] / w))
        out.update({"u": out["u"] * scale, "v": out["v"] * scale, "amplitude_scale": scale})
    return out


def _trend_amplitude(tau: np.ndarray, disp: np.ndarray, at: float,
                     stop: float) -> float | None:
    """The measured envelope's trend at ``at`` [s]: the very trend
    :func:`response.log_envelope_error` compares every run with (Savitzky–Golay of ln|peak|
    over :data:`response.TREND_PEAKS` peaks of the interior [``at``, ``stop``]), carried from
    its first peak back to ``at`` along its own slope there; None with too few peaks. (A trend
    of the whole window's peaks, as before, put the start 0.3–0.5 % above the interior's on the
    four real amplitude-dependent recordings: its edge is shaped by the unsettled peaks.)"""
    from scipy.signal import savgol_filter

    tp, ap = response.envelope(tau, disp, at, stop)
    if tp.size < 2 * response.TREND_PEAKS:
        return None
    trend = savgol_filter(np.log(ap), response.TREND_PEAKS, 2)
    slope = (trend[1] - trend[0]) / (tp[1] - tp[0])
    return float(np.exp(trend[0] + slope * (at - tp[0])))


def damper_check(summary: dict[str, Any], folder: Path, t: np.ndarray, u_meas: np.ndarray,
                 runs: dict[str, tuple[np.ndarray, np.ndarray]], omega_n: float,
                 interior: tuple[float, float], damper: dict[str, Any]) -> dict[str, Any]:
    """The damper verified (issue 32): for each run (``exported``: the deck export writes,
    ``linear``: its linear dashpot at the design amplitude, when the exported law is not
    viscous; ``measured``: the measured curve beside an exported law, or ``recommended_law``:
    the recommended law beside an exported measured curve; ``recommended`` names that law)
    the displacement envelope against the measured one over the interior
    (:func:`dampfit.fem.response.log_envelope_error`: log-envelope rms against the peaks and
    against their trend, and the measured scatter) and ζ(A) of the run at the amplitudes of
    summary.json's ``amplitude_curve`` windows against their 90 % bands
    (:func:`dampfit.fem.response.zeta_in_bands`)."""
    windows = _amplitude_windows(summary, folder / "summary.json")
    out: dict[str, Any] = {"law": damper["law"], "coefficients": damper["coefficients"],
                           "verdict": damper["verdict"],
                           "recommended": damper.get("recommended"),
                           "unit": "1 (difference of ln |u|)",
                           "interior_s": [float(interior[0]), float(interior[1])]}
    for name, (ts, us) in runs.items():
        env = response.log_envelope_error(t, u_meas, ts, us, *interior)
        amps, zetas = response.zeta_of_amplitude(ts, us, omega_n)
        out[name] = {"envelope": env, "zeta_amplitude": response.zeta_in_bands(windows, amps,
                                                                              zetas)}
    if "linear" in runs:
        a, b = (out[k]["envelope"]["rms_vs_trend"] for k in ("exported", "linear"))
        out["exported_beats_linear"] = None if a is None or b is None else bool(a < b)
    for key in ("measured", "recommended_law"):
        if key in runs and "linear" in runs:
            a, b = (out[k]["envelope"]["rms_vs_trend"] for k in (key, "linear"))
            out[f"{key}_beats_linear"] = None if a is None or b is None else bool(a < b)
    return out

def _amplitude_windows(summary: dict[str, Any], path: Path) -> list[dict[str, float]]:
    """The ζ(A) windows of summary.json's ``amplitude_curve`` (``amplitude_m``, ``zeta``,
    ``zeta_sd``, each checked); empty without a curve."""
    from dampfit.result.schema import number

    curve = summary.get("amplitude_curve")
    wins = curve.get("windows") if isinstance(curve, dict) else None
    if not isinstance(wins, list):
        return []
    out = []
    for i, w in enumerate(wins):
        if not isinstance(w, dict) or any(w.get(k) is None for k in ("amplitude_m", "zeta",
                                                                      "zeta_sd")):
            continue
        out.append({"amplitude_m": number(w["amplitude_m"], f"amplitude_curve.windows[{i}]."
                                          "amplitude_m", path, positive=True),
                    "zeta": number(w["zeta"], f"amplitude_curve.windows[{i}].zeta", path),
                    "zeta_sd": number(w["zeta_sd"], f"amplitude_curve.windows[{i}].zeta_sd",
                                      path, nonnegative=True)})
    return out

def linear_script(folder: Path, script: dict[str, Any],
                  law: str = "viscous") -> tuple[str, dict[str, Any]]:
    """A script run beside a nonlinear export, with the export's duration: ``dampfit export
    DIR --format opensees --law viscous`` (the linear dashpot: the equivalent linear c at the
    design amplitude, ``sdof_opensees_linear.py``) or ``--law measured`` (the curve fitted to
    the measured envelope, :mod:`dampfit.fem.measured`, ``sdof_opensees_measured.py``)."""
    from dampfit.fem import export as fem_export

    name = "sdof_opensees_linear.py" if law == "viscous" else f"sdof_opensees_{law}.py"
    text, info = fem_export.build(folder, "opensees",
                                  fem_export.Deck(duration=script["duration_s"], law=law),
                                  name=name)
    return text, {"name": name, "law": law, "c": info["sdof"].c,
                  "coefficients": info["damper"].coefficients,
                  "sha256": hashlib.sha256(text.encode("utf-8")).hexdigest(),
                  "export_command": f"dampfit export {shlex.quote(str(folder.resolve()))} "
                                    f"--format opensees --law {law} --duration "
                                    f"{script['duration_s']!r} --out {name}"}

#: The runs verify compares, in the order of its table: key (in ``damper``) and label.
RUN_LABELS = (("exported", "exported deck"), ("linear", "linear dashpot"),
              ("measured", "measured curve"), ("recommended_law", "recommended law"))


def envelope_words(rep: dict[str, Any]) -> str:
    """'log-envelope rms …' of the exported (and linear) run, for the title and the table."""
    d = rep.get("damper") or {}
    parts = []
    for key, label in RUN_LABELS:
        label = "exported" if key == "exported" else label
        env = (d.get(key) or {}).get("envelope") or {}
        if env.get("rms_vs_trend") is not None:
            parts.append(f"{label} {100 * env['rms_vs_trend']:.2g} %")
    env = ((d.get("exported") or {}).get("envelope") or {})
    if not parts:
        return "envelope: too few peaks"
    return ("log-envelope rms vs the measured trend: " + ", ".join(parts)
            + f" (measured scatter {100 * env['scatter']:.2g} %)")

def damper_lines(rep: dict[str, Any]) -> list[str]:
    """The table's block of the damper verified (envelope and ζ(A), linear beside)."""
    d = rep.get("damper")
    if not d:
        return []
    what = (f"the measured curve, not the recommended {d['recommended']} law"
            if d["law"] == "measured" and d.get("recommended") not in (None, "measured")
            else f"{d['law']} law")
    lines = ["", f"  damper: {what} (verdict {d['verdict'] or 'not recorded'}); "
             + envelope_words(rep)]
    for key, label in RUN_LABELS:
        if key not in d:
            continue
        z, env = d[key]["zeta_amplitude"], d[key]["envelope"]
        inside = "n/a" if not z["n"] else f"{z['n_inside']}/{z['n']}"
        lines.append(f"    {label:15s} envelope rms vs peaks {_fmt(env['rms_vs_peaks'])}, vs trend "
                     f"{_fmt(env['rms_vs_trend'])}; zeta(A) inside the measured 90 % bands: "
                     f"{inside}")
    if "recommended_law" in d:
        lines.append("    (the exported deck is the measured curve: the recommended law misses "
                     "the measured decay; dampfit export DIR --law LAW writes the law)")
    if "measured" in d:
        lines.append("    (measured curve: dampfit export DIR --law measured, the force-velocity "
                     "curve fitted to this envelope; the headline stays the "
                     f"{d['law']} law)")
    band = rep.get("draws")
    if band:
        lines.append(f"    {band['n']} posterior draws: measured envelope trend inside their "
                     f"5-95 % band at {100 * band['fraction_trend_inside']:.0f} % of the peaks")
    return lines

def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "n/a" if x is None else format(x, spec)
