"""The damper's part of ``dampfit verify`` (issue 32; :mod:`dampfit.fem.verify`): the start
state of a nonlinear damper, the linear dashpot run beside the exported deck, the envelope and
ζ(A) comparisons with the measurement, the draws' band, and their lines in the table.
"""

from __future__ import annotations

import hashlib
import math
import shlex
from pathlib import Path
from typing import Any

import numpy as np

from dampfit._progress import announce
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
            side_start = run_start(start, law, side["coefficients"], script["k"],
                                   script["mass"])
            announce(f"verify: running the {'linear dashpot' if key == 'linear' else law} "
                     f"beside it ({n_steps} steps)")
            res = opensees.run_steps(side_text, side_start["u"], side_start["v"], dt, n_steps,
                                     name=side["name"])
            side["start_u"] = side_start["u"]
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


EDGE_PERIODS = response.EDGE_PERIODS


def start_state(tau: np.ndarray, sig: dict[str, Any], period: float, law: str,
                omega_n: float | None = None) -> dict:
    """The start state of verify's runs. A viscous damper's is the fitted model's state at
    the window start (:func:`dampfit.fem.response.initial_state`: its model is that decay).
    A nonlinear one is released at rest at the first peak of the interior (the measured
    |a|/ω_n², ``omega_n`` the deck's: the damper section's k), after the :data:`EDGE_PERIODS`
    periods where the band-pass filters of the measured signal settle, at the amplitude of
    the measured envelope's trend there — the trend every run is compared with
    (:func:`dampfit.fem.response.log_envelope_error`: Savitzky–Golay of ln|peak| over
    :data:`~dampfit.fem.response.TREND_PEAKS` peaks), so one noisy peak cannot offset all
    runs — with the sign of the measured acceleration there (u = −a/ω_n²). Each run's
    displacement is then scaled so that its own first peak lies on the trend
    (:func:`run_start`; a Coulomb or power α < 1 force lifts that peak by its share), and
    the comparison begins a quarter period after the release (:func:`compare_from`): the
    run has no sample before it. This is the start export's own check runs each law from
    (:func:`dampfit.fem.measured.default_damper`), so the two agree. (Before, the state was
    fitted over three periods of the measured acceleration at their local decay rate and
    scaled to the trend: its phase and amplitude carried the fit's error of those periods —
    the measured curve of the phone spring ran 0.10 % from the trend there, 0.076 % from
    the release at the peak, against a scatter of 0.08 %.) With fewer peaks than a trend
    needs (2·TREND_PEAKS) the release is at the first interior peak's own amplitude."""
    if law == "viscous":
        return response.initial_state(tau, sig["accel_model"], sig["p"], sig["omega_d"],
                                      tau0=tau[0])
    from scipy.signal import savgol_filter

    w = float(omega_n or sig["omega_d"])  # the ω of the envelopes compared, |a|/ω_n²
    accel = np.asarray(sig["accel"], float)
    tp, ap = response.envelope(tau, accel / w ** 2, tau[0] + EDGE_PERIODS * period,
                               tau[-1] - EDGE_PERIODS * period)
    if tp.size == 0:
        raise InputError("the measured signal has no peak in the interior of the window to "
                         "start the runs from")
    trend = (savgol_filter(np.log(ap), response.TREND_PEAKS, 2)
             if tp.size >= 2 * response.TREND_PEAKS else np.log(ap))
    sign = -1.0 if accel[int(np.argmin(np.abs(tau - tp[0])))] > 0 else 1.0
    head = slice(0, 6)  # the trend over the first peaks: where each run's first peak lies
    return {"u": float(sign * np.exp(trend[0])), "v": 0.0, "fit_rms": None,
            "offset_s": float(tp[0] - tau[0]), "omega_n": w,
            "amplitude_trend": float(np.exp(trend[0])),
            "trend_t_s": [float(x - tp[0]) for x in tp[head]],
            "trend_m": [float(np.exp(x)) for x in trend[head]]}


def run_start(start: dict[str, Any], law: str, coefficients: dict[str, float], k: float,
              mass: float) -> dict[str, Any]:
    """``start`` (:func:`start_state`) for the run of one damper (``law``, its
    ``coefficients``) on k [N/m] and m [kg]: released at the displacement at which the run's
    first peak of |a|/ω_n² is on the measured trend
    (:func:`dampfit.fem.response.released_amplitude`); a viscous start is the fitted state."""
    if "trend_m" not in start:
        return start
    from dampfit.fem.damper import scalar_force

    ts, tr = np.asarray(start["trend_t_s"]), np.log(start["trend_m"])
    u = response.released_amplitude(scalar_force(law, coefficients), k, mass,
                                    start["amplitude_trend"],
                                    lambda s: float(np.exp(np.interp(s, ts, tr))))
    return {**start, "u": float(np.copysign(u, start["u"])), "scale": u / start[
        "amplitude_trend"]}


def compare_from(t0: float, start: dict[str, Any], interior_start: float) -> float:
    """Where the envelope comparison of runs from ``start`` begins [s] (``t0`` the window's
    first sample time): the interior's start, or for a release at a peak a quarter period
    after it (the next peak is the first a run has both sides of)."""
    if "trend_m" not in start:
        return interior_start
    return max(interior_start, t0 + start["offset_s"] + 0.5 * math.pi / start["omega_n"])


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
        inside = band.get("fraction_trend_inside")
        where = ("n/a (too few peaks)" if inside is None
                 else f"{100 * inside:.0f} % of the peaks")
        lines.append(f"    {band['n']} posterior draws of the {band.get('law', '?')} law: "
                     f"measured envelope trend inside their 5-95 % band at {where}")
    return lines


def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "n/a" if x is None else format(x, spec)
