"""The report of a single-recording result folder: the blocks of each section.

:func:`build_single` turns what :func:`dampfit.output.report.build.load` read into the
report's title and blocks (rendered by :mod:`dampfit.output.document`). What a reader relies
on:

* every warning appears once, in the red box at the top (the model check's warning, which
  the analysis also lists among the diagnostics, is not repeated);
* numbers with a 90 % interval get their digits from the interval's width
  (:mod:`dampfit.output.format`, through :mod:`dampfit.output.report.values`), so q05, median
  and q95 are distinct as printed; least squares take the posterior's digits and a baseline
  those of its own expected spread — as in the text table;
* the noise level is defined once, in "Noise model": σ [m/s²], the residual sd per fitted
  sample at the fit rate, and the density at f₀ [m/s²/√Hz] that the Cramér–Rao bound
  assumes, each with its definition; the bound refers to it;
* the model checks (:mod:`dampfit.output.report.checks`) open with the verdict in plain words;
* every key shown has a human label; the reproduce command names absolute, quoted paths
  (:mod:`dampfit.output.report.reproduce`).
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import shlex
from pathlib import Path
from typing import Any

from dampfit.files.folder import DEMO_MARKER
from dampfit.output import damper as damper_rows
from dampfit.output.document import Block
from dampfit.output.report.checks import amplitude, model_checks
from dampfit.output.report.modes import modes_blocks
from dampfit.output.report.reproduce import is_demo, not_computed, reproduce_blocks
from dampfit.output.report.values import (DERIVED, MAIN, NAMES, UNITS, baseline_value, bracket,
                                          estimate, figure, finite, generic, get, isnum,
                                          label_of, median, more_warnings, number, spec)
from dampfit.result.files import MAX_SIDE_BYTES, read_optional
from dampfit.result.schema import parse_json, unique_warnings

#: The seed paper's baselines by summary key, as the methods table names them.
BASELINES = {"log_decrement": "logarithmic decrement, seed paper baseline (paper eqs 9, 13, 15)",
             "envelope_pipeline": "envelope pipeline, seed paper baseline (paper eqs 3, 4; "
                                  "Fig. 20)"}


def build_single(data: dict[str, Any], directory: Path, now: str) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of a single-recording folder (:func:`dampfit.output.
    report.build.load`'s ``data``): the recommended damper, status box, headline, result
    table, methods, provenance, figures, noise model, diagnostics, model checks, amplitude dependence, verification,
    how to reproduce and cite; with several modes, the modes after the methods."""
    s = data["summary"]
    path = get(s, "input", "path")
    title = f"dampfit damping report — {Path(path).name if isinstance(path, str) else directory.name}"
    b: list[Block] = [("h1", title)]
    b += _damper_box(s) + _status(s) + _headline(s)

    crlb = s.get("crlb")
    b += [("h2", f"Result: {damper_rows.other_label(s)} of c, k, u₀, ζ, f_n")]
    b += _parameter_table(s, MAIN)
    b.append(("p", ["Median and 90 % equal-tailed interval of the posterior draws, with the "
                    "digits the interval's width supports; sd the posterior standard deviation; "
                    "R-hat (rank-normalised) and bulk ESS from arviz."]))
    if isinstance(crlb, dict):
        b += _crlb_blocks(crlb)
    else:
        b += [("h4", "Cramér–Rao lower bound")] + not_computed("crlb", s, directory)
    b += [("h3", "Methods compared")] + _methods(s, directory)
    b += modes_blocks(s)  # several modes only: nothing for one

    b += [("h2", "Inputs and provenance")] + _provenance(s, directory, now)
    b += [("h2", "Recorded signal"), figure("signal")]
    b += [("h2", "Spectrum, pass band and filter response"), figure("spectrum")]
    b += _fit_and_posterior(s)
    b += [("h2", "Noise model")] + _noise(s)
    b += [("h2", "Diagnostics")] + _diagnostics(s)
    b += [("h2", "Model checks")] + model_checks(s, directory)
    b += [("h2", "Amplitude dependence")] + amplitude(s, directory)
    b += [("h2", "Verification in OpenSees")] + _verification(data, directory)

    here = shlex.quote(os.path.abspath(directory))
    b += [("h2", "How to reproduce and cite")] + reproduce_blocks(s, directory)
    b.append(("p", [f"Cite as: dampfit {number(s.get('dampfit_version'))} (Bayesian free-decay fit of "
                    "m·ü + c·u̇ + k·u = 0 to the acceleration), with the baselines of Flis, Szwoch & "
                    "Krawczyk (2025), “Determining a damping coefficient by using a MEMS accelerometer "
                    "for FEM simulation purposes on a discrete damper example”. Rendered from "
                    "summary.json by ", ("code", f"dampfit report {here}"), f" on {now}."]))
    return title, b


def _fit_and_posterior(s: dict) -> list[Block]:
    """The analysed window and fit, the displacement, the posterior figures and the derived
    quantities."""
    fit = s.get("fit") if isinstance(s.get("fit"), dict) else {}
    b: list[Block] = [
        ("h2", "Analysed window, fit and residuals"),
        ("p", [f"Window {number(get(s, 'window', 'start_s'), 6)} – {number(get(s, 'window', 'end_s'), 6)} s; "
               f"{number(fit.get('n_samples'))} fitted samples ({number(fit.get('path'))} path) at "
               f"{number(fit.get('sample_rate_hz'), 4)} Hz, drift polynomial degree "
               f"{number(fit.get('drift_degree'))}, {number(fit.get('n_excluded'))} samples excluded."]),
        figure("fit")]
    no_env = isinstance(s.get("baselines"), dict) and "envelope_pipeline" in s["baselines"] \
        and s["baselines"]["envelope_pipeline"] is None
    b += [("h2", "Displacement and envelope (paper Fig. 20)"),
          figure("displacement",
                 "not drawn: the envelope-pipeline baseline was not computed" if no_env else None)]
    return b + [("h2", "Posterior"), figure("posterior"), figure("trace"),
                ("h3", "Derived quantities")] + _parameter_table(s, DERIVED)


def _verification(data: dict[str, Any], directory: Path) -> list[Block]:
    """verification.json as tables with its figure, why it is not shown, or how to compute it."""
    b: list[Block] = []
    ver = data.get("verification")
    if data.get("verification_error"):
        b.append(("box", "bad", "Verification not shown", [[data["verification_error"]]]))
    if ver is not None:
        b += generic(ver) + [figure("verify")]
    elif not data.get("verification_error"):
        b += not_computed("verification", data["summary"], directory)
    return b


def _warnings(s: dict) -> list[str]:
    """Every warning of the analysis, each once (diagnostics first, then the model check's
    unless a diagnostics warning already says it), at most
    :data:`~dampfit.result.schema.MAX_WARNINGS_SHOWN` and a count of the rest; linear in the
    number of warnings (:func:`~dampfit.result.schema.unique_warnings`)."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    out, more = unique_warnings(d.get("warnings"), text=number)
    mc_warn = number(get(s, "model_checks", "warning")).strip()
    if mc_warn and mc_warn != "—" and not any(mc_warn in o for o in out):
        out.append(mc_warn)
    return out + more_warnings(more)



def _status(s: dict) -> list[Block]:
    """The red box (not converged, warnings) or the green one, at the top of the report.

    This is the one place the warnings appear; the sections below refer to it."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    warns = _warnings(s)
    converged = d.get("converged")
    facts = (f"max R-hat {spec(d.get('max_r_hat'), '.4f')}, min bulk ESS "
             f"{spec(d.get('min_ess_bulk'), '.0f')}, {number(d.get('n_steps'))} steps × "
             f"{number(d.get('n_walkers'))} walkers")
    if not d:
        return [("box", "bad", "No diagnostics in summary.json: convergence is unknown",
                 [["Re-run the analysis before using these numbers."]]
                 + [[("b", "Warning: "), w] for w in warns])]
    if converged is not True or warns:
        title = ("NOT CONVERGED — read the diagnostics before using these numbers"
                 if converged is not True else "Converged, with warnings")
        items = ([[f"least squares converged: {number(get(s, 'least_squares', 'converged'))}; "
                   f"posterior converged: {number(d.get('posterior_converged'))} ({facts})"]]
                 if converged is not True else [[f"Diagnostics: {facts}."]])
        return [("box", "bad", title, items + [[("b", "Warning: "), w] for w in warns])]
    return [("box", "ok", "Converged, no warnings", [[f"Diagnostics: {facts}."]])]


def _damper_box(s: dict) -> list[Block]:
    """The first box: the recommended damper (:mod:`dampfit.output.damper`) — what goes into
    the model — or why none is recommended and what to try."""
    d = s.get("damper")
    if not isinstance(d, dict):
        return []
    status = d.get("status") if isinstance(d.get("status"), str) else None  # may be edited
    cls = {"recommended": "ok", "viscous-stands": "note"}.get(status, "bad")
    items = [[("b", f"{label}: "), text] for label, text in damper_rows.rows(d)]
    return [("box", cls, damper_rows.title(d), items)]


def _headline(s: dict) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    d = s.get("damper") if isinstance(s.get("damper"), dict) else None
    bold = d is None or d.get("law") == "viscous"  # the headline only when it is the damper
    spans: list = [] if d is None else [f"{damper_rows.other_label(s)}: "]
    for name in MAIN:
        q = params.get(name)
        if isinstance(q, dict) and isnum(q.get("q50")):
            sym, unit = NAMES[name].split(",")[0], q.get("unit") or UNITS[name]
            spans += ["; "] if len(spans) > (d is not None) else []
            value = f"{sym} = {median(q)}" + (f" {unit}" if unit != "1" else "")
            spans += [("b", value) if bold else value, f" (90 % interval {bracket(q)})"]
    if not spans:
        return [("p", ["No posterior summary in summary.json."])]
    out: list[Block] = [("p", spans + ["."])]
    why = get(s, "missing", "c")
    if why:
        out.append(("p", [("b", "c and k not identified: "), number(why)]))
    return out


def _parameter_table(s: dict, names: tuple[str, ...]) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    crlb = s.get("crlb") if isinstance(s.get("crlb"), dict) else {}
    show_crlb = bool(crlb) or any(isnum(get(params, n, "crlb_sd")) for n in names)
    head = ["quantity", "unit", "median", "mean", "sd", "90 % interval"]
    head += ["CRLB sd", "sd / CRLB sd"] if show_crlb else []
    head += ["R-hat", "bulk ESS"]
    rows = []
    for name in names:
        q = params.get(name)
        if not isinstance(q, dict):
            why = get(s, "missing", name)
            rows.append([NAMES[name], UNITS[name], "not identified" if why else "—"]
                        + ["—"] * (len(head) - 3))
            continue
        shown = bracket(q)
        if q.get("reaches_zero") is True and finite(q.get("q05")) and not finite(q.get("q95")):
            shown = f"[{number(q['q05'], 3)}, ∞)"  # Q = 1/(2ζ) of a decay not told from 0
        row = [NAMES[name], q.get("unit") or UNITS[name], median(q), median(q, "mean"),
               number(q.get("sd"), 3), shown]
        if show_crlb:
            c = q.get("crlb_sd") if isnum(q.get("crlb_sd")) else crlb_sd(crlb, name)
            sd = q.get("sd")
            ratio = sd / c if isnum(c) and c > 0 and isnum(sd) else None
            row += [number(c, 3), spec(ratio, ".2f")]
        rows.append(row + [spec(q.get("r_hat"), ".4f"), spec(q.get("ess_bulk"), ".0f")])
    out: list[Block] = [("table", head, rows)]
    zero = [NAMES[n].split(",")[0].split(" =")[0] for n in names
            if isinstance(params.get(n), dict) and params[n].get("reaches_zero") is True]
    if zero:
        out.append(("p", [("b", "No decay measured: "), ", ".join(zero) + " cannot be told "
                          "from no decay (forced or self-sustained vibration?); their 90 % "
                          "intervals reach 0 (one-sided, under a prior uniform in p) and Q "
                          "has no upper bound."]))
    return out


def crlb_sd(crlb: dict, name: str) -> float | None:
    """The bound's sd of ``name``: a number, or ``{"sd_with_mass" | "sd": …}`` (mass sd included)."""
    v = crlb.get(name)
    if isinstance(v, dict):
        v = next((v[k] for k in ("sd_with_mass", "sd", "crlb_sd") if isnum(v.get(k))), None)
    return v if isnum(v) else None


#: Keys of ``crlb`` that describe its design (shown in one sentence, not as a table).
_CRLB_DESIGN = ("n_samples", "drift_degree", "mass", "mass_sd", "noise_sigma", "noise_density",
                "noise_density_unit", "units")
_CRLB_NAMES = {"p": "p, decay rate", "omega_d": "ω_d, damped angular frequency"}


def _crlb_blocks(crlb: dict) -> list[Block]:
    """What the bound assumes (one sentence that refers to the noise level of "Noise model")
    and the bounds on the quantities not in the result table; any other entry generically."""
    units = crlb.get("units") if isinstance(crlb.get("units"), dict) else {}
    design = []
    if isnum(crlb.get("n_samples")):
        design.append(f"{crlb['n_samples']} usable samples of the window")
    if isnum(crlb.get("drift_degree")):
        design.append(f"a drift polynomial of degree {crlb['drift_degree']} as nuisance")
    if finite(crlb.get("mass")):
        msd = crlb.get("mass_sd")
        design.append(f"mass {number(crlb['mass'])} kg"
                      + (f" ± {number(msd, 3)} kg" if finite(msd) and msd > 0 else " (sd not given)"))
    out: list[Block] = [("p", [
        "CRLB sd: the Cramér–Rao lower bound on the standard deviation of an unbiased estimator "
        "for this recording's design (" + ("; ".join(design) or "design not recorded") + ") "
        "and white noise at the noise density at f₀ defined in the section “Noise model” "
        "(the level the residuals show near f₀); sd / CRLB sd near 1 means the posterior is as "
        "tight as the data allow."])]
    others = [(k, v) for k, v in crlb.items() if isinstance(v, dict) and k not in MAIN
              and k not in _CRLB_DESIGN]
    rows = [[_CRLB_NAMES.get(k, label_of(k)), number(v.get("value"), 6), number(crlb_sd(crlb, k), 3),
             number(units.get(k, v.get("unit", UNITS.get(k, ""))))] for k, v in others]
    if rows:
        out.append(("table", ["quantity", "least-squares value", "CRLB sd", "unit"], rows))
    rest = {k: v for k, v in crlb.items() if k not in MAIN and k not in _CRLB_DESIGN
            and not isinstance(v, dict)}
    return out + (generic(rest) if rest else [])


def _baseline_note(b: dict) -> str:
    """Support and agreement of a baseline, in words."""
    parts = []
    used, win = b.get("n_cycles_used"), b.get("n_cycles_window")
    if finite(used) and finite(win):
        parts.append(f"{used:.3g} of {win:.3g} cycles used")
    elif isnum(b.get("n_cycles")):
        parts.append(f"over {b['n_cycles']} cycles")
    if b.get("supported") is False:
        parts.append(f"not reliable: {b.get('support_reason') or 'too little support'}")
    elif b.get("supported") is True:
        parts.append("supported")
    if b.get("agrees_with_posterior") is False:
        parts.append(str(b.get("note") or "disagrees with the posterior beyond its expected spread"))
    elif b.get("agrees_with_posterior") is True:
        parts.append("agrees with the posterior within its expected spread")
        if b.get("note"):
            parts.append(str(b["note"]))
    return "; ".join(parts)


def _methods(s: dict, directory: Path) -> list[Block]:
    """c, ζ, f_n, p per method: posterior, least squares, each baseline (and a demo's truth)."""
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    head = (["method"] + [f"{sym} [{UNITS[n]}]" for sym, n in
                          (("c", "c"), ("ζ", "zeta"), ("f_n", "f_n"), ("p", "p"))] + ["note"])
    rows = [["viscous posterior median"] + [median(params[n]) if isinstance(params.get(n), dict) else "—"
                                    for n in ("c", "zeta", "f_n", "p")]
            + ["90 % intervals in the table above"]]
    ls = s.get("least_squares")
    if isinstance(ls, dict):
        def pm(name: str) -> str:
            v, sd = ls.get(name), ls.get(f"{name}_sd")
            return estimate(s, name, v) + (f" ± {number(sd, 2)}" if isnum(sd) and isnum(v) else "")

        rows.append(["least squares (viscous)", pm("c"), pm("zeta"), estimate(s, "f_n", ls.get("f_n")),
                     estimate(s, "p", ls.get("p")),
                     "± 1σ from the Jacobian" + ("" if ls.get("converged", True) else "; NOT converged")])
    bases = s.get("baselines") if isinstance(s.get("baselines"), dict) else {}
    for key, b in bases.items():
        label = BASELINES.get(key, label_of(key))
        if not isinstance(b, dict):
            rows.append([label, "—", "—", "—", "—", "not computed (see the warnings at the top)"])
            continue
        f_n, z = b.get("f_n"), b.get("zeta")
        note = _baseline_note(b)
        if not isnum(f_n) and isnum(b.get("f_d")) and isnum(z) and 0 <= z < 1:
            f_n = b["f_d"] / math.sqrt(1.0 - z * z)
            note += ("; " if note else "") + "f_n = f_d/√(1−ζ²)"
        rows.append([label, baseline_value(b, "c"), baseline_value(b, "zeta"),
                     estimate(s, "f_n", f_n), baseline_value(b, "p"), note or "—"])
    truth = _truth(s, directory)
    if truth:
        rows.append(["truth (simulated input)"] + [number(truth.get(n)) for n in ("c", "zeta", "f_n", "p")]
                    + ["demo: the known values the recording was simulated with"])
    return [("table", head, rows)]


def _truth(s: dict, directory: Path) -> dict | None:
    if not is_demo(s, directory):
        return None
    data, _ = read_optional(directory / DEMO_MARKER, MAX_SIDE_BYTES)
    try:
        truth = parse_json(data) if data is not None else None
    except ValueError:
        return None
    return truth if isinstance(truth, dict) else None


def _options(opts: Any) -> str:
    """The analysis options as command-line flags (``--max-steps N``); unset ones omitted."""
    if not isinstance(opts, dict):
        return number(opts)
    out = []
    for k, v in opts.items():
        if v is None:
            continue
        flag = "--" + str(k).replace("_", "-")
        out.append(f"{flag} {' '.join(number(x, 6) for x in v) if isinstance(v, list) else number(v)}")
    return ", ".join(out) or "defaults"


def _provenance(s: dict, directory: Path, now: str) -> list[Block]:
    inp = s.get("input") if isinstance(s.get("input"), dict) else {}
    win = s.get("window") if isinstance(s.get("window"), dict) else {}
    band = s.get("band") if isinstance(s.get("band"), dict) else {}
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    prov = s.get("provenance") if isinstance(s.get("provenance"), dict) else {}
    auto = lambda v: "auto" if v else ("given" if v is False else "—")  # noqa: E731
    date = next((prov[k] for k in ("date", "created", "timestamp", "analysed_at") if prov.get(k)), None)
    if date is None:
        try:
            mtime = (directory / "summary.json").stat().st_mtime
            date = _dt.datetime.fromtimestamp(mtime, _dt.timezone.utc).isoformat(timespec="seconds") \
                + " (file time of summary.json)"
        except OSError:
            date = None
    if not isnum(m.get("value")):
        mass = "not given (c and k cannot be identified)"
    elif finite(m.get("sd")) and m["sd"] > 0:
        mass = f"{number(m['value'])} ± {number(m['sd'], 3)} kg"
    else:
        mass = f"{number(m['value'])} kg (sd not given)"
    rows = [
        ["input file", number(inp.get("path"))], ["format", number(inp.get("format"))],
        ["sha256", number(inp.get("sha256"))],
        ["samples", f"{number(inp.get('n_samples'))} at {number(inp.get('sample_rate_hz'), 5)} Hz, "
                    f"{number(inp.get('duration_s'), 5)} s, timing jitter (CV) "
                    f"{number(inp.get('timing_jitter'), 2)}"],
        ["axis", f"{number(inp.get('axis'))} (direction {number(inp.get('axis_direction'))})"],
        ["gravity removed", number(inp.get("gravity_removed"))],
        ["mass", mass],
        ["analysed window", f"{number(win.get('start_s'), 6)} – {number(win.get('end_s'), 6)} s, "
                            f"{number(win.get('n_cycles'), 4)} cycles ({auto(win.get('auto'))})"],
        ["pass band", f"{number(band.get('low_hz'), 4)} – {number(band.get('high_hz'), 4)} Hz "
                      f"({auto(band.get('auto'))}); dominant frequency f₀ = "
                      f"{number(s.get('dominant_frequency_hz'), 6)} Hz"],
        ["options", _options(prov.get("options"))],
        ["dampfit version", number(s.get("dampfit_version"))], ["seed", number(prov.get("seed"))],
        ["Python", number(prov.get("python"))],
        ["package versions", number(prov.get("versions")).replace(" = ", " ")],
        ["analysis date", number(date)], ["report generated", now],
    ]
    notes = [n for src in (inp.get("notes"), get(s, "preprocessing", "notes"))
             if isinstance(src, list) for n in src if isinstance(n, str)]
    out: list[Block] = [("table", ["item", "value"], rows)]
    pre = s.get("preprocessing") if isinstance(s.get("preprocessing"), dict) else {}
    counts = [f"{number(pre[k])} {what}" for k, what in (
        ("n_stale_dropped", "stale (repeated) samples dropped"),
        ("n_clipped", "clipped samples masked"), ("n_spikes", "samples in impact spikes masked"))
        if isnum(pre.get(k))]
    if counts:
        out.append(("p", ["Preprocessing: " + ", ".join(counts) + "."]))
    rest = {k: v for k, v in pre.items() if k not in (
        "notes", "n_stale_dropped", "n_clipped", "n_spikes", "noise_density", "noise_density_unit")}
    if rest:
        out += generic(rest)
    if notes:
        out += [("p", ["Reading and preprocessing notes:"]), ("ul", [[n] for n in notes])]
    return out


def _noise(s: dict) -> list[Block]:
    """The noise level, defined once: the residual σ per fitted sample and the density at f₀
    the Cramér–Rao bound uses, each with its definition and unit (plus the sensor floor)."""
    nm = s.get("noise_model")
    if not isinstance(nm, dict):
        return [("p", ["Not in summary.json."])]
    crlb = s.get("crlb") if isinstance(s.get("crlb"), dict) else {}
    sig, r, fs = nm.get("sigma"), nm.get("psd_ratio_at_f0"), nm.get("sample_rate_hz")
    rows = []
    if isnum(sig):
        rows.append(["σ, residual noise level", number(sig, 3), number(nm.get("sigma_unit") or "m/s^2"),
                     f"standard deviation of the fit residuals per fitted sample, at the fit rate "
                     f"{number(fs, 4)} Hz: the noise level of the likelihood"])
    if isnum(r):
        rows.append(["r, Whittle factor at f₀", number(r), "1",
                     "residual power near f₀ relative to white noise of level σ; the likelihood "
                     "is tempered by 1/r, which widens the intervals accordingly"])
    raw = nm.get("psd_ratio_at_f0_unclipped")
    if isnum(raw) and isnum(r) and abs(raw - r) > 1e-9 * abs(r):
        rows.append(["r as measured", number(raw, 3), "1",
                     "the plain Welch ratio, before the correction for what the fit itself "
                     "removes near f₀ and the floor at the residual's white level above f₀/2"])
    if isnum(nm.get("psd_ratio_expected_for_white_noise")):
        rows.append(["r for white noise", number(nm["psd_ratio_expected_for_white_noise"], 3), "1",
                     "the r that white sensor noise alone would give on this signal path"])
    if isnum(nm.get("residual_lag1_autocorrelation")):
        rows.append(["residual lag-1 autocorrelation", number(nm["residual_lag1_autocorrelation"], 3),
                     "1", "correlation of successive residuals (0 for white noise)"])
    dens = crlb.get("noise_density")
    if not finite(dens) and finite(sig) and finite(r) and finite(fs) and fs > 0:
        dens = math.sqrt(2.0 * r * sig * sig / fs)
    if finite(dens):
        rows.append(["noise density at f₀", number(dens, 3),
                     number(crlb.get("noise_density_unit") or "m/s^2/sqrt(Hz)"),
                     "one-sided density √(2·r·σ²/f_fit) of the residuals near f₀ (f_fit the fit "
                     "rate): the noise level the Cramér–Rao bound assumes"])
    floor = get(s, "preprocessing", "noise_density")
    if finite(floor):
        rows.append(["sensor noise floor", number(floor, 3),
                     number(get(s, "preprocessing", "noise_density_unit") or "m/s^2/sqrt(Hz)"),
                     "white-noise level of the raw spectrum near the pass band, away from f₀: "
                     "where the window ends, and the “× sensor noise” of the model checks; not "
                     "used by the fit"])
    out: list[Block] = []
    if nm.get("kind"):
        out.append(("p", ["Likelihood: ", number(nm["kind"]), "."]))
    out.append(("table", ["quantity", "value", "unit", "definition"], rows))
    rest = {k: v for k, v in nm.items() if k not in (
        "kind", "sigma", "sigma_unit", "psd_ratio_at_f0", "psd_ratio_at_f0_unclipped",
        "residual_lag1_autocorrelation", "sample_rate_hz", "psd_ratio_expected_for_white_noise")}
    return out + (generic(rest) if rest else [])


def _diagnostics(s: dict) -> list[Block]:
    d = s.get("diagnostics")
    if not isinstance(d, dict):
        return [("p", ["Not in summary.json."])]
    out: list[Block] = [("p", ["Convergence and any warnings are stated in the box at the top."])]
    return out + generic({k: v for k, v in d.items() if k != "warnings"})
