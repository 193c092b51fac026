"""The report of a campaign folder (several recordings of one damper, ``"kind": "campaign"``).

:func:`build_campaign` gives the title and blocks: the status box (every warning once), the
design and input files, the population table with the predictive interval for a new test and
the between-test spread, the verdict, the per-test table (alone and pooled) with the forest
plot, with several modes (``max_modes`` > 1) each test's modes in every damping convention
(the pooled one marked) and its Rayleigh α, β, and in added-mass mode m₀, k and the
1/ω_n²–Δm figure; then how to reproduce and cite.
The tests carry the names of the campaign table (:func:`dampfit.output.text_campaign.labels`)
and every number with an interval the digits of :mod:`dampfit.output.format`.
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path
from typing import Any

from dampfit.output.document import Block
from dampfit.output.report.modes import CONVENTIONS, inverse_q
from dampfit.output.report.reproduce import campaign_reproduce_command
from dampfit.output.report.values import (NAMES, UNITS, bracket, figure, finite, get, median,
                                          more_warnings, number, spec, with_interval)
from dampfit.output.text_campaign import labels
from dampfit.result.schema import unique_warnings

# A campaign folder (several recordings of one damper, summary "kind": "campaign";
# dampfit.campaign): design, population table with the predictive interval and the spread,
# per-test table, the verdict, the forest and added-mass figures.
#: Names and units of the quantities of a campaign (m₀ in added-mass mode).
CAMPAIGN_NAMES = {**NAMES, "m0": "m₀, effective mass"}
CAMPAIGN_UNITS = {**UNITS, "m0": "kg"}


def _status(s: dict) -> list[Block]:
    """The red or green box at the top of a campaign report (every warning once)."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    warns, more = unique_warnings(d.get("warnings"), s.get("warnings"), text=number)
    warns += more_warnings(more)
    facts = (f"max R-hat {spec(d.get('max_r_hat'), '.4f')}, min bulk ESS "
             f"{spec(d.get('min_ess_bulk'), '.0f')}, {number(d.get('n_steps'))} steps")
    if not d:
        return [("box", "bad", "No diagnostics in summary.json: convergence is unknown",
                 [["Re-run the analysis before using these numbers."]]
                 + [[("b", "Warning: "), w] for w in warns])]
    if d.get("converged") is not True or warns:
        title = ("NOT CONVERGED — read the diagnostics before using these numbers"
                 if d.get("converged") is not True else "Converged, with warnings")
        return [("box", "bad", title, [[f"Diagnostics: {facts}."]]
                 + [[("b", "Warning: "), w] for w in warns])]
    return [("box", "ok", "Converged, no warnings", [[f"Diagnostics: {facts}."]])]


def _design(s: dict) -> list[Block]:
    design = s.get("design") if isinstance(s.get("design"), dict) else {}
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    am = design.get("added_mass") if isinstance(design.get("added_mass"), dict) else None
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    rows = [["tests", number(design.get("n_tests", len(tests)))],
            ["model", number(design.get("model"))]]
    if am is not None:
        rows.append(["added masses", f"{number(am.get('values'))} kg, sd {number(am.get('sd'), 3)} kg"])
        rows.append(["mass used for c and k", f"effective mass m₀ (median {number(m.get('value'))} kg), "
                                              "estimated from the frequencies"])
    elif finite(m.get("value")):
        sd = f" ± {number(m['sd'], 3)}" if finite(m.get("sd")) and m["sd"] > 0 else " (sd not given)"
        rows.append(["mass", f"{number(m['value'])}{sd} kg"])
    else:
        rows.append(["mass", "not given (c and k cannot be identified)"])
    rows += [["dampfit version", number(s.get("dampfit_version"))],
             ["seed", number(get(s, "provenance", "seed"))]]
    out: list[Block] = [("table", ["item", "value"], rows)]
    irows = []
    for i, t in enumerate(tests):
        inp = t.get("input") if isinstance(t.get("input"), dict) else {}
        win = t.get("window") if isinstance(t.get("window"), dict) else {}
        irows.append([str(i + 1), number(inp.get("path")), str(number(inp.get("sha256")))[:16],
                      f"{number(inp.get('n_samples'))} at {number(inp.get('sample_rate_hz'), 5)} Hz",
                      f"{number(win.get('start_s'), 5)} – {number(win.get('end_s'), 5)}"])
    if irows:
        out += [("h3", "Input files"),
                ("table", ["test", "file", "sha256 (first 16)", "samples", "window [s]"], irows)]
    return out


def _population(s: dict) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    pop = s.get("population") if isinstance(s.get("population"), dict) else {}
    pred = pop.get("predictive") if isinstance(pop.get("predictive"), dict) else {}
    rows = []
    for name in ("c", "k", "zeta", "f_n", "m0", "p"):
        q = params.get(name)
        if not isinstance(q, dict) or not finite(q.get("q50")):
            continue
        pq = pred.get(name) if isinstance(pred.get(name), dict) else {}
        rows.append([CAMPAIGN_NAMES.get(name, name), CAMPAIGN_UNITS.get(name, ""), median(q),
                     bracket(q), median(pq) if pq else "—", bracket(pq) if pq else "—",
                     spec(q.get("r_hat"), ".4f"), spec(q.get("ess_bulk"), ".0f")])
    out: list[Block] = []
    if rows:
        out.append(("table", ["quantity", "unit", "population median", "90 % interval",
                              "new test: median", "90 % predictive interval", "R-hat",
                              "bulk ESS"], rows))
    else:
        out.append(("p", ["No population summary in summary.json."]))
    out.append(("p", ["The population values describe “this damper”: the centre of the "
                      "distribution the tests are drawn from. The predictive interval is where "
                      "the value of one new test is expected (90 %): it adds the between-test "
                      "spread to the uncertainty of the centre, and it is the interval an FEM "
                      "model of this damper should carry."]))
    spread = pop.get("spread") if isinstance(pop.get("spread"), dict) else {}
    srows = [[label, median(spread[key]), bracket(spread[key])]
             for key, label in (("p", "τ of ln p (decay rate)"), ("omega", "τ of ln ω_n (frequency)"))
             if isinstance(spread.get(key), dict)]
    if srows:
        out += [("h3", "Between-test spread"),
                ("table", ["spread (relative sd between tests)", "median", "90 % interval"], srows)]
    zero = pop.get("spread_consistent_with_zero")
    if zero is not None:
        out.append(("p", [("b", "Spread consistent with zero: " if zero else
                           "Spread not consistent with zero: "),
                          "the tests agree within their own uncertainty." if zero else
                          "the tests differ by more than their own uncertainty explains."]))
    return out


def _tests(s: dict) -> list[Block]:
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    has_c = tests and all(isinstance(get(t, "own", "c"), dict) for t in tests)
    names = ("c", "zeta", "f_n") if has_c else ("zeta", "f_n")
    head = ["test", "file", "Δm [kg]", "amplitude [m]"]
    for n in names:
        unit = CAMPAIGN_UNITS[n]
        sym = CAMPAIGN_NAMES[n].split(",")[0]
        head += [f"{sym} alone" + (f" [{unit}]" if unit != "1" else ""), f"{sym} pooled"]
    head.append("outlier")
    rows = []
    for i, (t, name) in enumerate(zip(tests, labels(tests))):
        row = [str(i + 1), name,
               number(t.get("added_mass_kg"), 4), number(t.get("amplitude_m"), 3)]
        for n in names:
            row += [with_interval(get(t, "own", n)), with_interval(get(t, "pooled", n))]
        row.append("OUTLIER" if t.get("outlier") is True else "no")
        rows.append(row)
    if not rows:
        return [("p", ["No tests in summary.json."])]
    return [("table", head, rows),
            ("p", ["“alone”: the test's own posterior (median [90 % interval]); “pooled”: its "
                   "estimate within the hierarchical model, pulled towards the population by as "
                   "much as the spread between the tests allows."])]


def _test_modes(s: dict) -> list[Block]:
    """Each test's modes (``tests[i].modes``, :mod:`dampfit.campaign.modes`): f_n and every
    damping convention with 90 % intervals, the pooled mode marked, the test's Rayleigh α, β;
    [] for a one-mode campaign."""
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    entries = [(i, name, t["modes"]) for i, (t, name) in enumerate(zip(tests, labels(tests)))
               if isinstance(t.get("modes"), dict)]
    if not entries:
        return []
    head = ["test", "mode", "f_n, natural frequency [Hz]"] + [h for _, h in CONVENTIONS]
    rows, rayleigh = [], []
    for i, name, m in entries:
        modes = [r for r in m.get("modes") or [] if isinstance(r, dict)] \
            if isinstance(m.get("modes"), list) else []
        if not modes:
            one = m.get("n_modes") == 1 and not isinstance(m.get("n_modes"), bool)
            ev = m.get("modes_evidence") if isinstance(m.get("modes_evidence"), dict) else {}
            why = (f"one mode (the pooled one): {number(ev.get('reason'))}" if one else
                   f"not analysed: {number(m.get('reason'))}")
            rows.append([f"{i + 1} {name}", "—", why] + ["—"] * len(CONVENTIONS))
        for j, r in enumerate(modes):
            qs = {k: r.get(k) for k, _ in CONVENTIONS}
            qs["Q_inv"] = inverse_q(r.get("Q"))
            mark = " (pooled)" if r.get("pooled") is True else ""
            rows.append([f"{i + 1} {name}" if j == 0 else "", f"{j + 1}{mark}",
                         with_interval(r.get("f_n"))]
                        + [with_interval(qs[k]) for k, _ in CONVENTIONS])
        ray = m.get("rayleigh")
        if isinstance(ray, dict) and isinstance(ray.get("alpha"), dict):
            rayleigh.append([f"{i + 1} {name}", with_interval(ray.get("alpha"), "1/s"),
                             with_interval(ray.get("beta"), "s"), number(ray.get("statement"))])
    out: list[Block] = [
        ("h2", "Modes of each test"),
        ("p", ["The campaign pools the mode each test's band isolates (marked “pooled”); "
               "every test was also analysed for several modes on its own (posterior median "
               "and 90 % interval; η = 2ζ, Λ = 2πζ/√(1−ζ²), Q⁻¹ = 2ζ). The other modes "
               "report ζ and f_n only: no modal mass is invented for them."]),
        ("table", head, rows)]
    if rayleigh:
        out.append(("table", ["test", "Rayleigh α [1/s]", "Rayleigh β [s]", "fit"], rayleigh))
    return out


def _verdict(s: dict) -> list[Block]:
    checks = s.get("checks") if isinstance(s.get("checks"), dict) else {}
    if not checks:
        return [("p", ["No checks in summary.json."])]
    out: list[Block] = [("p", [("b", f"{number(checks.get('verdict'))}: "), number(checks.get("text"))])]
    rows = [["between-test spread / typical own sd", number(checks.get("tau_over_within"), 3)]]
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    rows.append(["outliers (test numbers)", ", ".join(
        str(i + 1) for i, t in enumerate(tests) if t.get("outlier") is True) or "none"])
    amp = checks.get("amplitude") if isinstance(checks.get("amplitude"), dict) else {}
    if amp:
        y = "ln c" if isinstance(s.get("added_mass"), dict) else "ln p"
        rows.append([f"slope of each test's {y} against its ln amplitude",
                     f"{number(amp.get('slope'), 3)} (90 % interval [{number(amp.get('q05'), 3)}, "
                     f"{number(amp.get('q95'), 3)}])"])
        rows.append(["amplitude explains the scatter", number(amp.get("explains_scatter"))])
    out.append(("table", ["check", "value"], rows))
    return out


def _added_mass(s: dict) -> list[Block]:
    am = s.get("added_mass")
    if not isinstance(am, dict):
        return []
    out: list[Block] = [("h2", "Added-mass method"),
                        ("p", ["The natural frequencies fall with the added mass as "
                               "ω_n² = k/(m₀ + Δm), so 1/ω_n² is a straight line in Δm with slope "
                               "1/k that crosses zero at Δm = −m₀: ",
                               ("b", f"m₀ = {with_interval(am.get('m0'), 'kg')}"), ", ",
                               ("b", f"k = {with_interval(am.get('k'), 'N/m')}"), "."])]
    pts = [p for p in (am.get("points") or []) if isinstance(p, dict)]
    if pts:
        out.append(("table", ["Δm [kg]", "ω_n² [rad²/s²]", "sd [rad²/s²]"],
                    [[number(p.get("added_mass_kg"), 4), number(p.get("omega_n2"), 6),
                      number(p.get("omega_n2_sd"), 3)] for p in pts]))
    out.append(figure("added_mass"))
    return out


def build_campaign(data: dict[str, Any], directory: Path, now: str) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of a campaign folder (several recordings of one damper)."""
    s = data["summary"]
    n = get(s, "design", "n_tests")
    title = f"dampfit damping report — campaign of {number(n)} tests ({directory.name})"
    b: list[Block] = [("h1", title)] + _status(s)
    for name, sym in (("c", "c"), ("zeta", "ζ")):  # ζ when no mass identifies c
        x = get(s, "parameters", name)
        px = get(s, "population", "predictive", name)
        if isinstance(x, dict) and finite(x.get("q50")):
            unit = CAMPAIGN_UNITS[name]
            b.append(("p", [("b", f"Population {sym} = {with_interval(x, unit)}"),
                            "; a new test: " + (with_interval(px, unit) if isinstance(px, dict)
                                                else "—") + " (90 % intervals)."]))
            break
    b += [("h2", "Design")] + _design(s)
    b += [("h2", "Population: the damper")] + _population(s)
    b += [("h2", "Verdict")] + _verdict(s)
    b += [("h2", "Each test")] + _tests(s) + [figure("forest")]
    b += _test_modes(s)
    b += _added_mass(s)
    here = shlex.quote(os.path.abspath(directory))
    b += [("h2", "How to reproduce and cite"),
          ("p", ["Re-create this folder from the input files (add --force to replace it):"]),
          ("code", campaign_reproduce_command(s, directory)),
          ("p", [f"Cite as: dampfit {number(s.get('dampfit_version'))} (hierarchical Bayesian "
                 "analysis of repeated free-decay tests of m·ü + c·u̇ + k·u = 0). Rendered from "
                 "summary.json by ", ("code", f"dampfit report {here}"), f" on {now}."])]
    return title, b
