"""The damping report of a result folder: ``report.html`` (self-contained) and ``report.md``.

``dampfit report DIR`` (:mod:`dampfit.cli.report`) or :func:`write_report` reads
``DIR/summary.json`` (through the one reader of result folders,
:func:`dampfit.result.schema.read_summary`) — plus the optional ``DIR/verification.json`` and
the PNG figures already in ``DIR`` — and renders them; nothing is recomputed, so the report states exactly the numbers of ``summary.json``. This module imports
only the standard library: no JAX, no matplotlib.

* ``report.html`` embeds every figure as a base64 ``data:`` URI with inline CSS and a
  Content-Security-Policy that forbids any other resource: it opens offline and prints.
* ``report.md`` refers to the figures as relative PNG files in ``DIR``.

Both are built from one list of blocks (:func:`build`), so they always say the same thing.
A campaign folder (several recordings of one damper, ``"kind": "campaign"``) gets its own
report: design and input files, the population table with the predictive interval for a new
test and the between-test spread, the verdict, the per-test table (alone and pooled) with the
forest plot, and in added-mass mode m₀, k and the 1/ω_n²–Δm figure.
Optional summary entries (``crlb``, ``model_checks``, ``amplitude_curve``, verification) are
shown when present and otherwise say "not computed" with the command that computes them;
entries whose layout this module does not know are rendered as generic tables.

What a reader relies on:

* every warning appears once, in the red box at the top (the model check's warning, which
  the analysis also lists among the diagnostics, is not repeated);
* numbers with a 90 % interval get their digits from the interval's width
  (:func:`dampfit.output.text.interval`), so q05, median and q95 are distinct as printed; least
  squares take the posterior's digits and a baseline those of its own expected spread;
* the noise level is defined once, in "Noise model": σ [m/s²], the residual sd per fitted
  sample at the fit rate, and the density at f₀ [m/s²/√Hz] that the Cramér–Rao bound
  assumes, each with its definition; the bound refers to it;
* the model checks open with the verdict in plain words and its reasons, then one short table
  of the damping laws (weight, parameters with units, ζ_eq) and one of the fit checks; the
  amplitude dependence is the ζ(A) and f(A) figure (``amplitude.png``, :mod:`dampfit.output.figures`);
* every key shown has a human label; the reproduce command names absolute, quoted paths.

Regenerating a report is harmless (it is a pure rendering of the folder), so an existing
report written by dampfit is replaced without ``--force``; ``--force`` is needed only to
replace a ``report.html``/``report.md`` that dampfit did not write.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import shlex
from pathlib import Path
from typing import Any

from dampfit import physics
from dampfit.output.document import _MARK_HTML, _MARK_MD, Block, _png
from dampfit.output.document import GENERATOR as GENERATOR
from dampfit.output.document import PNG_MAGIC as PNG_MAGIC
from dampfit.output.document import render_html as render_html
from dampfit.output.document import render_markdown as render_markdown
from dampfit._files import DEMO_MARKER, atomic_write_text
from dampfit.errors import InputError
from dampfit.result.schema import folder_of, read_summary
from dampfit.output.campaign import FIGURES as CAMPAIGN_FIGURES
from dampfit.output.campaign import labels as campaign_labels
from dampfit.output.text import _own_spread
from dampfit.output.text import interval as _honest

__all__ = ["write_report", "load", "build", "render_html", "render_markdown", "GENERATOR",
           "PNG_MAGIC"]


MAIN = ("c", "k", "u0", "zeta", "f_n")
DERIVED = ("p", "f_d", "delta", "Q", "c_crit")
#: Units of the reported quantities: :data:`dampfit.physics.UNITS`, the one table.
UNITS = physics.UNITS
NAMES = {"c": "c, damping coefficient", "k": "k, stiffness", "u0": "u₀, initial amplitude",
         "zeta": "ζ, damping ratio", "f_n": "f_n, natural frequency", "p": "p = c/(2m), decay rate",
         "f_d": "f_d, damped frequency", "delta": "δ, logarithmic decrement",
         "Q": "Q = 1/(2ζ), quality factor", "c_crit": "c_crit = 2√(km), critical damping"}
LABELS = {"mae": "MAE", "mse": "MSE", "nmse": "NMSE", "rmse": "RMSE", "r_hat": "R-hat",
          "ess_bulk": "bulk ESS", "max_r_hat": "max R-hat", "min_ess_bulk": "min bulk ESS",
          "autocorr_time_steps": "integrated autocorrelation time", "n_steps": "steps",
          "psd_ratio_at_f0": "Whittle factor r (PSD ratio at f₀)",
          "psd_ratio_at_f0_unclipped": "r as measured (plain Welch ratio), before its calibration (noise.estimate)",
          "residual_lag1_autocorrelation": "residual lag-1 autocorrelation", "sigma": "σ",
          "converged": "converged (least squares and posterior)",
          "posterior_converged": "posterior converged", "burn_in": "burn-in",
          "thin": "thinning", "n_walkers": "walkers", "acceptance_fraction": "acceptance fraction",
          "n_samples": "samples", "drift_degree": "drift polynomial degree", "method": "method"}
_SUFFIX_UNITS = (("_hz", "Hz"), ("_per_s", "1/s"), ("_s", "s"), ("_kg", "kg"), ("_m", "m"),
                 ("_steps", "steps"))
_KEY_UNITS = {"n_steps": "steps", "burn_in": "steps", "thin": "steps", "mass_sd": "kg",
              "noise_sigma": "m/s^2", "omega_d": "rad/s",
              "psd_ratio_at_f0": "1", "psd_ratio_at_f0_unclipped": "1",
              "residual_lag1_autocorrelation": "1", "acceptance_fraction": "1"}
BASELINES = {"log_decrement": "logarithmic decrement (paper eqs 9, 13, 15)",
             "envelope_pipeline": "envelope pipeline (paper eqs 3, 4; Fig. 20)"}
FIGURES = {
    "signal": "Recorded axes and the selected signal over the whole recording; the analysed "
              "window is shaded green, masked (clipped or spike) samples magenta.",
    "spectrum": "Amplitude spectrum of the selected signal on a linear scale (paper Fig. 15) and "
                "in dB (Fig. 16), the zero-phase band-pass gain |H|² (Fig. 17) and the spectrum "
                "after filtering (Fig. 19); pass band shaded, f₀ dotted.",
    "fit": "Fitted samples and the least-squares model over the analysed window, the first and "
           "last cycles, and the residuals [m/s²] with ±2σ.",
    "displacement": "Displacement [m] from the paper's envelope pipeline with its Hilbert "
                    "envelope and envelope fit (paper Fig. 20) against the least-squares envelope.",
    "posterior": "Posterior corner plot: pairs and marginals with median and 90 % interval; "
                 "least squares marked red.",
    "trace": "Walker traces after burn-in and marginal densities (convergence check).",
    "amplitude": "Top, ζ(A): windowed damping ratio against displacement amplitude with its 90 % "
                 "band, each damping law's ζ_eq(a) and the chosen law's 90 % posterior band. "
                 "Bottom, f(A): the backbone curve, windowed damped frequency against amplitude "
                 "with its 90 % band and the constant frequency the fit assumes.",
    "verify": "OpenSees verification: simulated response of the identified system against the "
              "measurement.",
    **CAMPAIGN_FIGURES,
}



# ----------------------------------------------------------------------------- formatting
def _isnum(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _num(x: Any, digits: int = 6) -> str:
    """Any summary value as short text: numbers to ``digits`` significant digits, None → —."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    if isinstance(x, str):
        return x
    if isinstance(x, dict):
        return ", ".join(f"{_label(k)} = {_num(v, 4)}" for k, v in x.items()) or "—"
    if isinstance(x, (list, tuple)):
        if len(x) > 8 and all(_isnum(v) for v in x):
            return f"{len(x)} values, {_num(x[0], 4)} … {_num(x[-1], 4)}"
        return ", ".join(_num(v, 4) for v in x) or "—"
    return str(x)


def _finite(x: Any) -> bool:
    return _isnum(x) and math.isfinite(x)


def _fixed(x: Any, fmt: str) -> str:
    return format(x, fmt) if _finite(x) else "—"


def _interval(q: dict) -> str:
    """``[q05, q95]`` with the digits of :func:`dampfit.output.text.interval` (from the width)."""
    lo, hi = q.get("q05"), q.get("q95")
    if not (_finite(lo) and _finite(hi)):
        return "—"
    return "[{1}, {2}]".format(*_honest(q.get("q50") if _finite(q.get("q50")) else lo, lo, hi))


def _median(q: dict, key: str = "q50") -> str:
    """``q[key]`` (median, mean) with the digits of the 90 % interval of ``q``."""
    x = q.get(key)
    if not _finite(x):
        return "—"
    if not (_finite(q.get("q05")) and _finite(q.get("q95"))):
        return _num(x)
    return _honest(x, q["q05"], q["q95"])[0]


def _point(s: dict, name: str, x: Any) -> str:
    """A point estimate of ``name`` (least squares) with the digits of its posterior interval."""
    q = _get(s, "parameters", name)
    if not (_finite(x) and isinstance(q, dict) and _finite(q.get("q05")) and _finite(q.get("q95"))):
        return _num(x)
    return _honest(x, q["q05"], q["q95"])[0]


def _baseline_value(b: dict, name: str) -> str:
    """A baseline's value with the digits of its own expected 90 % spread
    (:func:`dampfit.output.text._own_spread`), else six significant digits."""
    x, rel = b.get(name), b.get("expected_rel_sd")
    if not (_finite(x) and _finite(rel)):
        return _num(x)
    return _own_spread({name: float(x), "expected_rel_sd": float(rel)}, name)


def _with_interval(q: Any, unit: str = "") -> str:
    """``median [q05, q95] unit`` with honest digits, or — ."""
    if not isinstance(q, dict) or not _finite(q.get("q50")):
        return "—"
    unit = "" if unit in ("", "1") else f" {unit}"
    return f"{_median(q)} {_interval(q)}{unit}"


def _get(d: Any, *keys: str) -> Any:
    """``d[k1][k2]…`` or None where anything along the way is missing or not a dict."""
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def _label(key: Any) -> str:
    key = str(key)
    if key.lower() in LABELS or key in NAMES:
        return LABELS.get(key.lower(), NAMES.get(key, key))
    suffix = next((suf for suf, _ in _SUFFIX_UNITS if key.endswith(suf) and len(key) > len(suf)), "")
    return key[: len(key) - len(suffix)].replace("_", " ")


def _unit(key: Any, parent: dict) -> str:
    key = str(key)
    u = parent.get(f"{key}_unit")
    if isinstance(u, str):
        return u
    if key in UNITS or key in _KEY_UNITS:
        return UNITS.get(key) or _KEY_UNITS[key]
    return next((u for suf, u in _SUFFIX_UNITS if key.endswith(suf)), "")


def _scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


# ----------------------------------------------------------------------------- generic data
def _records(obj: Any) -> tuple[list[str], list[dict]] | None:
    """(column keys, rows) if ``obj`` is a list of dicts, a dict of dicts or equal-length columns."""
    if isinstance(obj, list) and obj and all(isinstance(r, dict) for r in obj):
        rows = obj
    elif isinstance(obj, dict) and len(obj) > 1 and all(isinstance(r, dict) for r in obj.values()):
        rows = [{"name": _label(k), **r} for k, r in obj.items()]
    elif isinstance(obj, dict):
        cols = {k: v for k, v in obj.items() if isinstance(v, list) and all(_scalar(x) for x in v)}
        lens = {len(v) for v in cols.values()}
        if len(cols) < 2 or len(lens) != 1 or 0 in lens:
            return None
        n = lens.pop()
        rows = [{k: v[i] for k, v in cols.items()} for i in range(n)]
    else:
        return None
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys and not str(k).endswith("_unit")]
    return keys, rows


def _records_table(keys: list[str], rows: list[dict], units: dict, max_rows: int = 40
                   ) -> list[Block]:
    head = [_label(k) + (f" [{_unit(k, units)}]" if _unit(k, units) else "") for k in keys]
    body = [[_num(r.get(k), 5) for k in keys] for r in rows[:max_rows]]
    out: list[Block] = [("table", head, body)]
    if len(rows) > max_rows:
        out.append(("p", [f"… and {len(rows) - max_rows} more rows in the JSON file."]))
    return out


def _generic(obj: Any, depth: int = 0) -> list[Block]:
    """Blocks for any JSON value: a key/value/unit table, sub-tables for nested entries."""
    rec = _records(obj)
    if rec is not None and isinstance(obj, dict) and not all(isinstance(v, dict) for v in obj.values()):
        rest = {k: v for k, v in obj.items() if k not in rec[0]}  # columns + other entries
        return (_generic(rest, depth) if rest else []) + _records_table(*rec, units=obj)
    if rec is not None:
        return _records_table(*rec, units={k: v for r in rec[1] for k, v in r.items()})
    if not isinstance(obj, dict):
        return [("p", [_num(obj)])]
    rows, subs = [], []
    for k, v in obj.items():
        if str(k).endswith("_unit") and str(k)[:-5] in obj:
            continue
        if isinstance(v, (dict, list)) and depth < 3 and (_records(v) or isinstance(v, dict)):
            subs += [("h4", _label(k))] + (_generic(v, depth + 1) if v else [("p", ["—"])])
        else:
            rows.append([_label(k), _num(v), _unit(k, obj)])
    return ([("table", ["item", "value", "unit"], rows)] if rows else []) + subs


# ----------------------------------------------------------------------------- input
def load(directory: str | os.PathLike | Any) -> dict[str, Any]:
    """Read ``DIR/summary.json`` (required; by the one reader of result folders,
    :func:`dampfit.result.schema.read_summary`) and ``DIR/verification.json`` (optional).

    ``directory`` may also be an analysis :func:`dampfit.load` read from a folder. Returns
    ``{"summary": dict, "verification": dict | None, "verification_error": str | None}``.
    """
    checked = read_summary(directory)
    summary, d = checked.data, checked.folder
    ver, err = summary.get("verification"), None
    vpath = d / "verification.json"
    if vpath.is_file():
        try:
            ver = json.loads(vpath.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            ver, err = None, f"verification.json could not be read ({exc})"
    return {"summary": summary, "verification": ver, "verification_error": err}


# ----------------------------------------------------------------------------- reproduce
def _is_demo(s: dict, directory: Path) -> bool:
    path = _get(s, "input", "path")
    return (directory / DEMO_MARKER).is_file() and isinstance(path, str) \
        and Path(path).name == DEMO_MARKER.replace(".truth.json", ".csv")


def _mass_flags(m) -> list[str]:
    """``--mass KG [--mass-sd KG]`` of a summary's mass entry (nothing if there is no mass)."""
    if not (isinstance(m, dict) and _finite(m.get("value"))):
        return []
    parts = ["--mass", repr(float(m["value"]))]
    if _finite(m.get("sd")) and m["sd"] > 0:
        parts += ["--mass-sd", repr(float(m["sd"]))]
    return parts


def _signal_flags(opts: dict) -> list[str]:
    """``--axis``, ``--window`` and ``--band`` as the recorded options gave them."""
    parts = []
    if isinstance(opts.get("axis"), str) and opts["axis"] != "auto":
        parts += ["--axis", shlex.quote(opts["axis"])]
    for key in ("window", "band"):
        v = opts.get(key)
        if isinstance(v, list) and len(v) == 2 and all(_finite(x) for x in v):
            parts += [f"--{key}", repr(float(v[0])), repr(float(v[1]))]
    return parts


def reproduce_command(s: dict, directory: str | os.PathLike) -> str:
    """The shell command that re-creates the result folder ``directory`` from its input."""
    directory = Path(os.path.abspath(directory))
    q = shlex.quote
    seed = _get(s, "provenance", "seed")
    seed = seed if isinstance(seed, int) else 0
    if _is_demo(s, directory):
        return f"dampfit demo --seed {seed} --out {q(str(directory))}"
    opts = _get(s, "provenance", "options")
    opts = opts if isinstance(opts, dict) else {}
    path = _get(s, "input", "path")
    parts = ["dampfit", "analyze", q(path) if isinstance(path, str) else "FILE"]
    parts += _mass_flags(s.get("mass")) + _signal_flags(opts)
    if isinstance(opts.get("model"), str) and opts["model"] != "auto":
        parts += ["--model", q(opts["model"])]
    if _finite(opts.get("amplitude")):
        parts += ["--amplitude", repr(float(opts["amplitude"]))]
    if isinstance(opts.get("max_steps"), int) and opts["max_steps"] != 20000:
        parts += ["--max-steps", str(opts["max_steps"])]
    return " ".join(parts + ["--seed", str(seed), "--out", q(str(directory))])


def _hint(what: str, s: dict, directory: Path) -> str:
    """The command that computes an optional section that is absent."""
    if what == "verification":
        return f"dampfit verify {shlex.quote(os.path.abspath(directory))}"
    cmd = reproduce_command(s, directory)
    if what == "model_checks" and " --model " not in cmd and not cmd.startswith("dampfit demo"):
        cmd = cmd.replace(" --seed ", " --model auto --seed ", 1)
    return cmd + " --force"


def _not_computed(what: str, s: dict, directory: Path) -> list[Block]:
    return [("p", [f"Not computed ({what} is absent from this result folder). To compute it, run:"]),
            ("code", _hint(what, s, directory))]


# ----------------------------------------------------------------------------- the document
def _figure(name: str, why_missing: str | None = None) -> Block:
    return ("figure", name, FIGURES.get(name, name), why_missing)


def _warnings(s: dict) -> list[str]:
    """Every warning of the analysis, each once (diagnostics first, then the model check's)."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    raw = d.get("warnings") if isinstance(d.get("warnings"), list) else []
    mc_warn = _get(s, "model_checks", "warning")
    out: list[str] = []
    for w in raw + ([mc_warn] if mc_warn else []):
        text = _num(w).strip()
        if text and text not in out and not any(text in o for o in out):
            out.append(text)
    return out


def _status(s: dict) -> list[Block]:
    """The red box (not converged, warnings) or the green one, at the top of the report.

    This is the one place the warnings appear; the sections below refer to it."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    warns = _warnings(s)
    converged = d.get("converged")
    facts = (f"max R-hat {_fixed(d.get('max_r_hat'), '.4f')}, min bulk ESS "
             f"{_fixed(d.get('min_ess_bulk'), '.0f')}, {_num(d.get('n_steps'))} steps × "
             f"{_num(d.get('n_walkers'))} walkers")
    if not d:
        return [("box", "bad", "No diagnostics in summary.json: convergence is unknown",
                 [["Re-run the analysis before using these numbers."]]
                 + [[("b", "Warning: "), w] for w in warns])]
    if converged is not True or warns:
        title = ("NOT CONVERGED — read the diagnostics before using these numbers"
                 if converged is not True else "Converged, with warnings")
        items = ([[f"least squares converged: {_num(_get(s, 'least_squares', 'converged'))}; "
                   f"posterior converged: {_num(d.get('posterior_converged'))} ({facts})"]]
                 if converged is not True else [[f"Diagnostics: {facts}."]])
        return [("box", "bad", title, items + [[("b", "Warning: "), w] for w in warns])]
    return [("box", "ok", "Converged, no warnings", [[f"Diagnostics: {facts}."]])]


def _headline(s: dict) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    spans: list = []
    for name in MAIN:
        q = params.get(name)
        if isinstance(q, dict) and _isnum(q.get("q50")):
            sym, unit = NAMES[name].split(",")[0], q.get("unit") or UNITS[name]
            spans += ["; "] if spans else []
            spans += [("b", f"{sym} = {_median(q)}" + (f" {unit}" if unit != "1" else "")),
                      f" (90 % interval {_interval(q)})"]
    if not spans:
        return [("p", ["No posterior summary in summary.json."])]
    out: list[Block] = [("p", spans + ["."])]
    why = _get(s, "missing", "c")
    if why:
        out.append(("p", [("b", "c and k not identified: "), _num(why)]))
    return out


def _parameter_table(s: dict, names: tuple[str, ...]) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    crlb = s.get("crlb") if isinstance(s.get("crlb"), dict) else {}
    show_crlb = bool(crlb) or any(_isnum(_get(params, n, "crlb_sd")) for n in names)
    head = ["quantity", "unit", "median", "mean", "sd", "90 % interval"]
    head += ["CRLB sd", "sd / CRLB sd"] if show_crlb else []
    head += ["R-hat", "bulk ESS"]
    rows = []
    for name in names:
        q = params.get(name)
        if not isinstance(q, dict):
            why = _get(s, "missing", name)
            rows.append([NAMES[name], UNITS[name], "not identified" if why else "—"]
                        + ["—"] * (len(head) - 3))
            continue
        row = [NAMES[name], q.get("unit") or UNITS[name], _median(q), _median(q, "mean"),
               _num(q.get("sd"), 3), _interval(q)]
        if show_crlb:
            c = q.get("crlb_sd") if _isnum(q.get("crlb_sd")) else _crlb_sd(crlb, name)
            sd = q.get("sd")
            ratio = sd / c if _isnum(c) and c > 0 and _isnum(sd) else None
            row += [_num(c, 3), _fixed(ratio, ".2f")]
        rows.append(row + [_fixed(q.get("r_hat"), ".4f"), _fixed(q.get("ess_bulk"), ".0f")])
    return [("table", head, rows)]


def _crlb_sd(crlb: dict, name: str) -> float | None:
    """The bound's sd of ``name``: a number, or ``{"sd_with_mass" | "sd": …}`` (mass sd included)."""
    v = crlb.get(name)
    if isinstance(v, dict):
        v = next((v[k] for k in ("sd_with_mass", "sd", "crlb_sd") if _isnum(v.get(k))), None)
    return v if _isnum(v) else None


#: Keys of ``crlb`` that describe its design (shown in one sentence, not as a table).
_CRLB_DESIGN = ("n_samples", "drift_degree", "mass", "mass_sd", "noise_sigma", "noise_density",
                "noise_density_unit", "units")
_CRLB_NAMES = {"p": "p, decay rate", "omega_d": "ω_d, damped angular frequency"}


def _crlb_blocks(crlb: dict) -> list[Block]:
    """What the bound assumes (one sentence that refers to the noise level of "Noise model")
    and the bounds on the quantities not in the result table; any other entry generically."""
    units = crlb.get("units") if isinstance(crlb.get("units"), dict) else {}
    design = []
    if _isnum(crlb.get("n_samples")):
        design.append(f"{crlb['n_samples']} usable samples of the window")
    if _isnum(crlb.get("drift_degree")):
        design.append(f"a drift polynomial of degree {crlb['drift_degree']} as nuisance")
    if _finite(crlb.get("mass")):
        msd = crlb.get("mass_sd")
        design.append(f"mass {_num(crlb['mass'])} kg"
                      + (f" ± {_num(msd, 3)} kg" if _finite(msd) and msd > 0 else " (sd not given)"))
    out: list[Block] = [("p", [
        "CRLB sd: the Cramér–Rao lower bound on the standard deviation of an unbiased estimator "
        "for this recording's design (" + ("; ".join(design) or "design not recorded") + ") "
        "and white noise at the noise density at f₀ defined in the section “Noise model” "
        "(the level the residuals show near f₀); sd / CRLB sd near 1 means the posterior is as "
        "tight as the data allow."])]
    others = [(k, v) for k, v in crlb.items() if isinstance(v, dict) and k not in MAIN
              and k not in _CRLB_DESIGN]
    rows = [[_CRLB_NAMES.get(k, _label(k)), _num(v.get("value"), 6), _num(_crlb_sd(crlb, k), 3),
             _num(units.get(k, v.get("unit", UNITS.get(k, ""))))] for k, v in others]
    if rows:
        out.append(("table", ["quantity", "least-squares value", "CRLB sd", "unit"], rows))
    rest = {k: v for k, v in crlb.items() if k not in MAIN and k not in _CRLB_DESIGN
            and not isinstance(v, dict)}
    return out + (_generic(rest) if rest else [])


def _baseline_note(b: dict) -> str:
    """Support and agreement of a baseline, in words."""
    parts = []
    used, win = b.get("n_cycles_used"), b.get("n_cycles_window")
    if _finite(used) and _finite(win):
        parts.append(f"{used:.3g} of {win:.3g} cycles used")
    elif _isnum(b.get("n_cycles")):
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
    rows = [["posterior median"] + [_median(params[n]) if isinstance(params.get(n), dict) else "—"
                                    for n in ("c", "zeta", "f_n", "p")]
            + ["90 % intervals in the table above"]]
    ls = s.get("least_squares")
    if isinstance(ls, dict):
        def pm(name: str) -> str:
            v, sd = ls.get(name), ls.get(f"{name}_sd")
            return _point(s, name, v) + (f" ± {_num(sd, 2)}" if _isnum(sd) and _isnum(v) else "")

        rows.append(["least squares", pm("c"), pm("zeta"), _point(s, "f_n", ls.get("f_n")),
                     _point(s, "p", ls.get("p")),
                     "± 1σ from the Jacobian" + ("" if ls.get("converged", True) else "; NOT converged")])
    bases = s.get("baselines") if isinstance(s.get("baselines"), dict) else {}
    for key, b in bases.items():
        label = BASELINES.get(key, _label(key))
        if not isinstance(b, dict):
            rows.append([label, "—", "—", "—", "—", "not computed (see the warnings at the top)"])
            continue
        f_n, z = b.get("f_n"), b.get("zeta")
        note = _baseline_note(b)
        if not _isnum(f_n) and _isnum(b.get("f_d")) and _isnum(z) and 0 <= z < 1:
            f_n = b["f_d"] / math.sqrt(1.0 - z * z)
            note += ("; " if note else "") + "f_n = f_d/√(1−ζ²)"
        rows.append([label, _baseline_value(b, "c"), _baseline_value(b, "zeta"),
                     _point(s, "f_n", f_n), _baseline_value(b, "p"), note or "—"])
    truth = _truth(s, directory)
    if truth:
        rows.append(["truth (simulated input)"] + [_num(truth.get(n)) for n in ("c", "zeta", "f_n", "p")]
                    + ["demo: the known values the recording was simulated with"])
    return [("table", head, rows)]


def _truth(s: dict, directory: Path) -> dict | None:
    if not _is_demo(s, directory):
        return None
    try:
        truth = json.loads((directory / DEMO_MARKER).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return truth if isinstance(truth, dict) else None


def _options(opts: Any) -> str:
    """The analysis options as command-line flags (``--max-steps 20000``); unset ones omitted."""
    if not isinstance(opts, dict):
        return _num(opts)
    out = []
    for k, v in opts.items():
        if v is None:
            continue
        flag = "--" + str(k).replace("_", "-")
        out.append(f"{flag} {' '.join(_num(x, 6) for x in v) if isinstance(v, list) else _num(v)}")
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
    if not _isnum(m.get("value")):
        mass = "not given (c and k cannot be identified)"
    elif _finite(m.get("sd")) and m["sd"] > 0:
        mass = f"{_num(m['value'])} ± {_num(m['sd'], 3)} kg"
    else:
        mass = f"{_num(m['value'])} kg (sd not given)"
    rows = [
        ["input file", _num(inp.get("path"))], ["format", _num(inp.get("format"))],
        ["sha256", _num(inp.get("sha256"))],
        ["samples", f"{_num(inp.get('n_samples'))} at {_num(inp.get('sample_rate_hz'), 5)} Hz, "
                    f"{_num(inp.get('duration_s'), 5)} s, timing jitter (CV) "
                    f"{_num(inp.get('timing_jitter'), 2)}"],
        ["axis", f"{_num(inp.get('axis'))} (direction {_num(inp.get('axis_direction'))})"],
        ["gravity removed", _num(inp.get("gravity_removed"))],
        ["mass", mass],
        ["analysed window", f"{_num(win.get('start_s'), 6)} – {_num(win.get('end_s'), 6)} s, "
                            f"{_num(win.get('n_cycles'), 4)} cycles ({auto(win.get('auto'))})"],
        ["pass band", f"{_num(band.get('low_hz'), 4)} – {_num(band.get('high_hz'), 4)} Hz "
                      f"({auto(band.get('auto'))}); dominant frequency f₀ = "
                      f"{_num(s.get('dominant_frequency_hz'), 6)} Hz"],
        ["options", _options(prov.get("options"))],
        ["dampfit version", _num(s.get("dampfit_version"))], ["seed", _num(prov.get("seed"))],
        ["Python", _num(prov.get("python"))],
        ["package versions", _num(prov.get("versions")).replace(" = ", " ")],
        ["analysis date", _num(date)], ["report generated", now],
    ]
    notes = [n for src in (inp.get("notes"), _get(s, "preprocessing", "notes"))
             if isinstance(src, list) for n in src if isinstance(n, str)]
    out: list[Block] = [("table", ["item", "value"], rows)]
    pre = s.get("preprocessing") if isinstance(s.get("preprocessing"), dict) else {}
    counts = [f"{_num(pre[k])} {what}" for k, what in (
        ("n_stale_dropped", "stale (repeated) samples dropped"),
        ("n_clipped", "clipped samples masked"), ("n_spikes", "samples in impact spikes masked"))
        if _isnum(pre.get(k))]
    if counts:
        out.append(("p", ["Preprocessing: " + ", ".join(counts) + "."]))
    rest = {k: v for k, v in pre.items() if k not in (
        "notes", "n_stale_dropped", "n_clipped", "n_spikes", "noise_density", "noise_density_unit")}
    if rest:
        out += _generic(rest)
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
    if _isnum(sig):
        rows.append(["σ, residual noise level", _num(sig, 3), _num(nm.get("sigma_unit") or "m/s^2"),
                     f"standard deviation of the fit residuals per fitted sample, at the fit rate "
                     f"{_num(fs, 4)} Hz: the noise level of the likelihood"])
    if _isnum(r):
        rows.append(["r, Whittle factor at f₀", _num(r), "1",
                     "residual power near f₀ relative to white noise of level σ; the likelihood "
                     "is tempered by 1/r, which widens the intervals accordingly"])
    raw = nm.get("psd_ratio_at_f0_unclipped")
    if _isnum(raw) and _isnum(r) and abs(raw - r) > 1e-9 * abs(r):
        rows.append(["r as measured", _num(raw, 3), "1",
                     "the plain Welch ratio, before the correction for what the fit itself "
                     "removes near f₀ and the floor at the residual's white level above f₀/2"])
    if _isnum(nm.get("psd_ratio_expected_for_white_noise")):
        rows.append(["r for white noise", _num(nm["psd_ratio_expected_for_white_noise"], 3), "1",
                     "the r that white sensor noise alone would give on this signal path"])
    if _isnum(nm.get("residual_lag1_autocorrelation")):
        rows.append(["residual lag-1 autocorrelation", _num(nm["residual_lag1_autocorrelation"], 3),
                     "1", "correlation of successive residuals (0 for white noise)"])
    dens = crlb.get("noise_density")
    if not _finite(dens) and _finite(sig) and _finite(r) and _finite(fs) and fs > 0:
        dens = math.sqrt(2.0 * r * sig * sig / fs)
    if _finite(dens):
        rows.append(["noise density at f₀", _num(dens, 3),
                     _num(crlb.get("noise_density_unit") or "m/s^2/sqrt(Hz)"),
                     "one-sided density √(2·r·σ²/f_fit) of the residuals near f₀ (f_fit the fit "
                     "rate): the noise level the Cramér–Rao bound assumes"])
    floor = _get(s, "preprocessing", "noise_density")
    if _finite(floor):
        rows.append(["sensor noise floor", _num(floor, 3),
                     _num(_get(s, "preprocessing", "noise_density_unit") or "m/s^2/sqrt(Hz)"),
                     "white-noise level of the raw spectrum near the pass band, away from f₀: "
                     "where the window ends, and the “× sensor noise” of the model checks; not "
                     "used by the fit"])
    out: list[Block] = []
    if nm.get("kind"):
        out.append(("p", ["Likelihood: ", _num(nm["kind"]), "."]))
    out.append(("table", ["quantity", "value", "unit", "definition"], rows))
    rest = {k: v for k, v in nm.items() if k not in (
        "kind", "sigma", "sigma_unit", "psd_ratio_at_f0", "psd_ratio_at_f0_unclipped",
        "residual_lag1_autocorrelation", "sample_rate_hz", "psd_ratio_expected_for_white_noise")}
    return out + (_generic(rest) if rest else [])


def _diagnostics(s: dict) -> list[Block]:
    d = s.get("diagnostics")
    if not isinstance(d, dict):
        return [("p", ["Not in summary.json."])]
    out: list[Block] = [("p", ["Convergence and any warnings are stated in the box at the top."])]
    return out + _generic({k: v for k, v in d.items() if k != "warnings"})


#: The adequacy verdicts (:data:`dampfit.damping.checks.VERDICTS`) in plain words.
VERDICT_WORDS = {
    "adequate": "one viscous damping coefficient c describes the whole decay; no amplitude "
                "dependence was found.",
    "amplitude-dependent": "damping depends on amplitude; the {law} law describes it best. A "
                           "single viscous c holds at one amplitude only (the equivalent c below).",
    "misfit": "the free-decay model does not describe this waveform and no damping law explains "
              "it, so c and its interval are not trustworthy; check the window and the set-up.",
    "inconclusive": "the evidence is too weak to say whether damping depends on amplitude.",
}
#: The adequacy criteria (``model_checks.adequacy.criteria``) in plain words.
CRITERIA_WORDS = {
    "slope_decisive": "the windowed ζ(A) slope is decisive", "slope_weak": "the windowed slope is weak evidence",
    "slope_null": "the windowed slope rules out a change of ζ that matters",
    "law_evidence": "the evidence favours a non-viscous law",
    "law_decisive": "the evidence for a non-viscous law is decisive",
    "frequency_drift": "the frequency drifts with amplitude",
    "viscous_misfit": "the viscous fit is a misfit", "best_law_misfit": "the best law is a misfit",
    "pipeline_misfit": "the constant-frequency fit is a misfit",
    "phase_drift": "the frequency drifts along the decay", "few_cycles": "too few cycles",
}
#: Parameters shown per damping law in the laws table (first present set wins).
_LAW_PARAMS = ("c", "F_c", "mu_c", "c2", "beta", "c_alpha", "gamma", "alpha")
_MC_KNOWN = ("warning", "verdict", "verdict_reasons", "verdict_law", "preferred_model",
             "chosen_model", "requested_model", "single_viscous_c_adequate", "residual_whiteness",
             "amplitude_dependence", "adequacy")


def _laws(s: dict) -> list[Block]:
    """One short table of the damping laws: weight, parameters with units, ζ_eq at a_ref."""
    dm = s.get("damping_models")
    if not isinstance(dm, dict) or not isinstance(dm.get("models"), dict):
        return []
    comp = dm.get("comparison") if isinstance(dm.get("comparison"), list) else []
    weights = {r["model"]: r for r in comp if isinstance(r, dict) and isinstance(r.get("model"), str)}
    chosen, preferred = dm.get("chosen_model"), dm.get("preferred_model")
    aref = dm.get("reference_amplitude_m")
    rows = []
    for law, m in dm["models"].items():
        if not isinstance(m, dict):
            continue
        par = m.get("parameters") if isinstance(m.get("parameters"), dict) else {}
        shown = [(k, par[k]) for k in _LAW_PARAMS if isinstance(par.get(k), dict)]
        if "k" not in par:  # no mass: the viscous part is the decay rate p₀ (ζ for viscous)
            lead = "zeta" if law == "viscous" else "p0"
            shown = ([(lead, par[lead])] if isinstance(par.get(lead), dict) else []) + shown
        text = "; ".join(f"{_SYMBOL.get(k, k)} = {_with_interval(q, q.get('unit') or '')}"
                         for k, q in shown) or "—"
        w = _get(weights, law, "weight")
        post = m.get("posterior") if isinstance(m.get("posterior"), dict) else {}
        note = [x for x, on in (("chosen", law == chosen), ("preferred", law == preferred
                                                           and law != chosen)) if on]
        if post.get("ill_conditioned"):
            why = str(post.get("ill_conditioned_reason") or "")
            for k in par:  # the reason names parameters by their keys
                why = why.replace(k, _label(k)) if "_" in k else why
            note.append("ill-conditioned" + (f": {why}" if why else "")
                        + " (Laplace approximation, intervals approximate)")
        if post.get("converged") is False:
            note.append("posterior NOT converged")
        rows.append([law, _fixed(w, ".3g") if _finite(w) else "—", text,
                     _with_interval(par.get("zeta_eq_ref")), "; ".join(note) or "—"])
    if not rows:
        return []
    where = f" at the reference amplitude {_num(aref, 3)} m" if _finite(aref) else ""
    return [("h3", "Damping laws compared"),
            ("table", ["law", "weight [1]", "parameters (median [90 %])", f"ζ_eq{where} [1]",
                       "note"], rows),
            ("p", ["Weight: posterior probability of each law from its log evidence; parameters "
                   "with their units; ζ_eq the energy-equivalent viscous damping ratio."])]


_SYMBOL = {"p0": "p₀", "c": "c", "F_c": "F_c", "mu_c": "μ_c", "c2": "c₂", "beta": "β", "c_alpha": "c_α",
           "gamma": "γ", "alpha": "α", "zeta": "ζ"}


def _fit_checks(mc: dict) -> list[Block]:
    """Per law: Ljung–Box p at f₀, r, r / r_white, residual size — one table."""
    white = mc.get("residual_whiteness") if isinstance(mc.get("residual_whiteness"), dict) else {}
    lb = white.get("ljung_box_at_f0") if isinstance(white.get("ljung_box_at_f0"), dict) else {}
    fc = _get(mc, "adequacy", "fit_checks")
    fc = fc if isinstance(fc, dict) else {}
    names = list(dict.fromkeys(list(fc) + list(lb)))
    rows = []
    for law in names:
        f = fc.get(law) if isinstance(fc.get(law), dict) else {}
        b = lb.get(law) if isinstance(lb.get(law), dict) else {}
        p = f.get("ljung_box_p", b.get("p_value"))
        frac = f.get("resid_fraction")
        rows.append([_label(law).replace("viscous pipeline", "constant-frequency viscous"),
                     _num(p, 2), _num(b.get("n_cycles")), _num(f.get("r_raw"), 3),
                     _num(f.get("r_excess"), 3),
                     _num(100 * frac, 3) if _finite(frac) else "—", _num(f.get("noise_excess"), 3)])
    if not rows:
        return []
    return [("h3", "Fit checks per law"),
            ("table", ["fit", "Ljung–Box p at f₀", "cycles", "r", "r / r for white noise",
                       "residual [% of signal]", "residual / sensor noise"], rows),
            ("p", ["A small Ljung–Box p means the residual, demodulated at f₀ and averaged per "
                   "cycle, is structured: the envelope (damping law) leaves misfit. r is the "
                   "Whittle factor of that fit's residuals (see “Noise model”)."])]


def _amplitude_evidence(mc: dict) -> list[Block]:
    amp = mc.get("amplitude_dependence") if isinstance(mc.get("amplitude_dependence"), dict) else {}
    rows = []
    if _isnum(amp.get("p_viscous")):
        rows.append(["P(one viscous c | data)", _num(amp["p_viscous"], 2),
                     "posterior probability of the viscous law among all laws"])
    if _isnum(amp.get("ln_bayes_factor_nonlinear_vs_viscous")):
        rows.append(["ln Bayes factor, non-viscous vs viscous",
                     _num(amp["ln_bayes_factor_nonlinear_vs_viscous"], 3), "> 0 favours a non-viscous law"])
    ws = amp.get("window_slope")
    if isinstance(ws, dict) and _finite(ws.get("s")):
        lo, hi = ws.get("s_q05"), ws.get("s_q95")
        rows.append(["windowed slope d ln p / d ln a", f"{ws['s']:.2g} [{_num(lo, 2)}, {_num(hi, 2)}]",
                     f"from {_num(ws.get('n_windows'))} independent windows; 0 for one viscous c"])
    sl = amp.get("slope_ln_p_vs_ln_amplitude")
    if isinstance(sl, dict) and _finite(sl.get("q50")):
        rows.append(["law slope d ln p / d ln a", _with_interval(sl), _num(sl.get("source"))])
    if _finite(amp.get("amplitude_start_m")) and _finite(amp.get("amplitude_end_m")):
        rows.append(["displacement amplitude", f"{_num(amp['amplitude_start_m'], 3)} → "
                     f"{_num(amp['amplitude_end_m'], 3)} m", "start → end of the window"])
    za = amp.get("zeta_at_start_and_end")
    if isinstance(za, dict):
        for k, what in (("zeta_eq_start", "ζ_eq at the start"), ("zeta_eq_end", "ζ_eq at the end")):
            if isinstance(za.get(k), dict):
                rows.append([what, _with_interval(za[k]), "chosen law, posterior median [90 %]"])
    known = ("detected", "criterion", "p_viscous", "ln_bayes_factor_nonlinear_vs_viscous",
             "window_slope", "slope_ln_p_vs_ln_amplitude", "amplitude_start_m", "amplitude_end_m",
             "zeta_at_start_and_end", "evidence_detected")
    rest = {k: v for k, v in amp.items() if k not in known}
    out: list[Block] = []
    if rows or rest:
        out.append(("h3", "Amplitude dependence of the decay rate"))
    if rows:
        out.append(("table", ["evidence", "value", "meaning"], rows))
    return out + (_generic(rest) if rest else [])


def _c_equivalent(s: dict) -> list[Block]:
    ce = s.get("c_equivalent")
    if not isinstance(ce, dict):
        return []
    items = []
    for k, unit in (("c", UNITS["c"]), ("zeta", UNITS["zeta"])):
        if isinstance(ce.get(k), dict):
            items.append(f"{'c_eq' if k == 'c' else 'ζ_eq'} = "
                         f"{_with_interval(ce[k], ce[k].get('unit') or unit)}")
    if not items:
        return []
    where = f" at {_num(ce.get('amplitude_m'), 3)} m displacement amplitude" \
        if _finite(ce.get("amplitude_m")) else ""
    return [("p", [("b", "Equivalent viscous damping"),
                   f" of the {_num(ce.get('model'))} law{where}: " + ", ".join(items)
                   + " (median [90 %]); use it only near that amplitude."])]


def _model_checks(s: dict, directory: Path) -> list[Block]:
    mc = s.get("model_checks")
    if not isinstance(mc, dict):
        return _not_computed("model_checks", s, directory)
    out: list[Block] = []
    verdict = mc.get("verdict")
    if verdict is not None:
        law = mc.get("verdict_law") or mc.get("preferred_model") or "non-viscous"
        words = VERDICT_WORDS.get(verdict, "") if isinstance(verdict, str) else ""
        out.append(("p", [("b", f"Verdict: {_num(verdict)}")]
                    + ([" — " + words.format(law=_num(law))] if words else [])))
        reasons = mc.get("verdict_reasons")
        if isinstance(reasons, list) and reasons:
            out += [("p", ["Why:"]), ("ul", [[_num(r)] for r in reasons])]
    crit = _get(mc, "adequacy", "criteria")
    if isinstance(crit, dict):
        held = [CRITERIA_WORDS.get(k, _label(k)) for k, v in crit.items() if v is True]
        out.append(("p", ["Criteria that hold: " + ("; ".join(held) if held else "none") + "."]))
    if any(mc.get(k) is not None for k in ("requested_model", "preferred_model", "chosen_model")):
        parts = [f"{what}: {_num(mc[k])}" for k, what in (
            ("requested_model", "requested"), ("preferred_model", "preferred by the evidence"),
            ("chosen_model", "reported")) if mc.get(k) is not None]
        out.append(("p", ["Damping law — " + "; ".join(parts) + "."]))
    if mc.get("warning"):
        out.append(("p", ["The model-check warning is in the box at the top."]))
    out += _c_equivalent(s) + _laws(s) + _fit_checks(mc) + _amplitude_evidence(mc)
    white = mc.get("residual_whiteness")
    if isinstance(white, dict):
        rest = {k: v for k, v in white.items() if k not in (
            "psd_ratio_common", "psd_ratio_by_model", "psd_ratio_viscous_pipeline",
            "ljung_box_at_f0", "note")}
        if rest:
            out += [("h3", "Residual whiteness")] + _generic(rest)
    elif "residual_whiteness" in mc:
        out += [("h3", "Residual whiteness"), ("p", ["not computed"])]
    rest = {k: v for k, v in mc.items() if k not in _MC_KNOWN}
    return out + ([("h3", "Other model checks")] + _generic(rest) if rest else [])


def _amplitude(s: dict, directory: Path) -> list[Block]:
    curve = s.get("amplitude_curve")
    if not isinstance(curve, dict):
        if _png(directory, "amplitude"):
            return [_figure("amplitude")]
        return _not_computed("amplitude_curve", s, directory)
    wins = curve.get("windows") if isinstance(curve.get("windows"), list) else []
    text = []
    if wins:
        text.append(f"{len(wins)} windowed viscous fits of {_num(curve.get('window_cycles'), 3)} "
                    "cycles each (50 % overlap), each giving ζ and the damped frequency at its "
                    "displacement amplitude; the values are in summary.json (amplitude curve).")
    if _finite(curve.get("reference_amplitude_m")):
        text.append(f"Reference amplitude of the equivalent c: "
                    f"{_num(curve['reference_amplitude_m'], 3)} m.")
    bb = curve.get("backbone") if isinstance(curve.get("backbone"), dict) else {}
    ft = bb.get("frequency_trend") or _get(s, "model_checks", "adequacy", "frequency_trend")
    if isinstance(ft, dict) and _finite(ft.get("rel_change")) and _finite(ft.get("rel_change_sd")):
        text.append(f"Backbone f(A): the damped frequency changes {100 * ft['rel_change']:+.2g} % "
                    f"(± {100 * ft['rel_change_sd']:.2g} %) from the smallest to the largest "
                    "amplitude (0 for a linear oscillator; < 0 softening, > 0 hardening).")
    if _isnum(bb.get("phase_terms")) and bb["phase_terms"] > 0:
        text.append(f"The viscous law follows that drift with {bb['phase_terms']} Legendre phase "
                    "terms, so its p, ζ and c are not biased by it.")
    out: list[Block] = [("p", [" ".join(text)])] if text else []
    out.append(_figure("amplitude"))
    rest_bb = {k: v for k, v in bb.items() if k not in ("frequency_trend", "phase_terms", "note")}
    if rest_bb:
        out += [("h4", "Backbone")] + _generic(rest_bb)
    known = ("window_cycles", "windows", "slope", "amplitude_grid_m", "models", "band",
             "preferred_model", "chosen_model", "mass_kg", "reference_amplitude_m", "note",
             "backbone")
    rest = {k: v for k, v in curve.items() if k not in known}
    return out + (_generic(rest) if rest else [])


# ----------------------------------------------------------------------------- campaign
# A campaign folder (several recordings of one damper, summary "kind": "campaign";
# dampfit.campaign): design, population table with the predictive interval and the spread,
# per-test table, the verdict, the forest and added-mass figures.
CAMPAIGN_NAMES = {**NAMES, "m0": "m₀, effective mass"}
CAMPAIGN_UNITS = {**UNITS, "m0": "kg"}


def campaign_reproduce_command(s: dict, directory: str | os.PathLike) -> str:
    """The shell command that re-creates the campaign folder ``directory`` from its inputs."""
    directory = Path(os.path.abspath(directory))
    q = shlex.quote
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    paths = [_get(t, "input", "path") for t in tests]
    parts = ["dampfit", "analyze"] + [q(p) if isinstance(p, str) else "FILE" for p in paths]
    am = _get(s, "design", "added_mass")
    m = _get(s, "design", "mass")
    if isinstance(am, dict) and isinstance(am.get("values"), list):
        parts += ["--added-mass"] + [repr(float(v)) if _finite(v) else "KG" for v in am["values"]]
        if _finite(am.get("sd")) and am["sd"] > 0:
            parts += ["--added-mass-sd", repr(float(am["sd"]))]
    else:
        parts += _mass_flags(m)
    opts = _get(s, "provenance", "options")
    parts += _signal_flags(opts if isinstance(opts, dict) else {})
    seed = _get(s, "provenance", "seed")
    seed = seed if isinstance(seed, int) and not isinstance(seed, bool) else 0
    return " ".join(parts + ["--seed", str(seed), "--out", q(str(directory))])


def _campaign_status(s: dict) -> list[Block]:
    """The red or green box at the top of a campaign report (every warning once)."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    warns: list[str] = []
    for w in (d.get("warnings") if isinstance(d.get("warnings"), list) else []) + \
            (s.get("warnings") if isinstance(s.get("warnings"), list) else []):
        text = _num(w).strip()
        if text and text not in warns:
            warns.append(text)
    facts = (f"max R-hat {_fixed(d.get('max_r_hat'), '.4f')}, min bulk ESS "
             f"{_fixed(d.get('min_ess_bulk'), '.0f')}, {_num(d.get('n_steps'))} steps")
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


def _campaign_design(s: dict) -> list[Block]:
    design = s.get("design") if isinstance(s.get("design"), dict) else {}
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    am = design.get("added_mass") if isinstance(design.get("added_mass"), dict) else None
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    rows = [["tests", _num(design.get("n_tests", len(tests)))],
            ["model", _num(design.get("model"))]]
    if am is not None:
        rows.append(["added masses", f"{_num(am.get('values'))} kg, sd {_num(am.get('sd'), 3)} kg"])
        rows.append(["mass used for c and k", f"effective mass m₀ (median {_num(m.get('value'))} kg), "
                                              "estimated from the frequencies"])
    elif _finite(m.get("value")):
        sd = f" ± {_num(m['sd'], 3)}" if _finite(m.get("sd")) and m["sd"] > 0 else " (sd not given)"
        rows.append(["mass", f"{_num(m['value'])}{sd} kg"])
    else:
        rows.append(["mass", "not given (c and k cannot be identified)"])
    rows += [["dampfit version", _num(s.get("dampfit_version"))],
             ["seed", _num(_get(s, "provenance", "seed"))]]
    out: list[Block] = [("table", ["item", "value"], rows)]
    irows = []
    for i, t in enumerate(tests):
        inp = t.get("input") if isinstance(t.get("input"), dict) else {}
        win = t.get("window") if isinstance(t.get("window"), dict) else {}
        irows.append([str(i + 1), _num(inp.get("path")), str(_num(inp.get("sha256")))[:16],
                      f"{_num(inp.get('n_samples'))} at {_num(inp.get('sample_rate_hz'), 5)} Hz",
                      f"{_num(win.get('start_s'), 5)} – {_num(win.get('end_s'), 5)}"])
    if irows:
        out += [("h3", "Input files"),
                ("table", ["test", "file", "sha256 (first 16)", "samples", "window [s]"], irows)]
    return out


def _campaign_population(s: dict) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    pop = s.get("population") if isinstance(s.get("population"), dict) else {}
    pred = pop.get("predictive") if isinstance(pop.get("predictive"), dict) else {}
    rows = []
    for name in ("c", "k", "zeta", "f_n", "m0", "p"):
        q = params.get(name)
        if not isinstance(q, dict) or not _finite(q.get("q50")):
            continue
        pq = pred.get(name) if isinstance(pred.get(name), dict) else {}
        rows.append([CAMPAIGN_NAMES.get(name, name), CAMPAIGN_UNITS.get(name, ""), _median(q),
                     _interval(q), _median(pq) if pq else "—", _interval(pq) if pq else "—",
                     _fixed(q.get("r_hat"), ".4f"), _fixed(q.get("ess_bulk"), ".0f")])
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
    srows = [[label, _median(spread[key]), _interval(spread[key])]
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


def _campaign_tests(s: dict) -> list[Block]:
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    has_c = tests and all(isinstance(_get(t, "own", "c"), dict) for t in tests)
    names = ("c", "zeta", "f_n") if has_c else ("zeta", "f_n")
    head = ["test", "file", "Δm [kg]", "amplitude [m]"]
    for n in names:
        unit = CAMPAIGN_UNITS[n]
        sym = CAMPAIGN_NAMES[n].split(",")[0]
        head += [f"{sym} alone" + (f" [{unit}]" if unit != "1" else ""), f"{sym} pooled"]
    head.append("outlier")
    rows = []
    for i, (t, name) in enumerate(zip(tests, campaign_labels(tests))):
        row = [str(i + 1), name,
               _num(t.get("added_mass_kg"), 4), _num(t.get("amplitude_m"), 3)]
        for n in names:
            row += [_with_interval(_get(t, "own", n)), _with_interval(_get(t, "pooled", n))]
        row.append("OUTLIER" if t.get("outlier") is True else "no")
        rows.append(row)
    if not rows:
        return [("p", ["No tests in summary.json."])]
    return [("table", head, rows),
            ("p", ["“alone”: the test's own posterior (median [90 % interval]); “pooled”: its "
                   "estimate within the hierarchical model, pulled towards the population by as "
                   "much as the spread between the tests allows."])]


def _campaign_verdict(s: dict) -> list[Block]:
    checks = s.get("checks") if isinstance(s.get("checks"), dict) else {}
    if not checks:
        return [("p", ["No checks in summary.json."])]
    out: list[Block] = [("p", [("b", f"{_num(checks.get('verdict'))}: "), _num(checks.get("text"))])]
    rows = [["between-test spread / typical own sd", _num(checks.get("tau_over_within"), 3)]]
    tests = [t for t in (s.get("tests") or []) if isinstance(t, dict)]
    rows.append(["outliers (test numbers)", ", ".join(
        str(i + 1) for i, t in enumerate(tests) if t.get("outlier") is True) or "none"])
    amp = checks.get("amplitude") if isinstance(checks.get("amplitude"), dict) else {}
    if amp:
        y = "ln c" if isinstance(s.get("added_mass"), dict) else "ln p"
        rows.append([f"slope of each test's {y} against its ln amplitude",
                     f"{_num(amp.get('slope'), 3)} (90 % interval [{_num(amp.get('q05'), 3)}, "
                     f"{_num(amp.get('q95'), 3)}])"])
        rows.append(["amplitude explains the scatter", _num(amp.get("explains_scatter"))])
    out.append(("table", ["check", "value"], rows))
    return out


def _campaign_added_mass(s: dict) -> list[Block]:
    am = s.get("added_mass")
    if not isinstance(am, dict):
        return []
    out: list[Block] = [("h2", "Added-mass method"),
                        ("p", ["The natural frequencies fall with the added mass as "
                               "ω_n² = k/(m₀ + Δm), so 1/ω_n² is a straight line in Δm with slope "
                               "1/k that crosses zero at Δm = −m₀: ",
                               ("b", f"m₀ = {_with_interval(am.get('m0'), 'kg')}"), ", ",
                               ("b", f"k = {_with_interval(am.get('k'), 'N/m')}"), "."])]
    pts = [p for p in (am.get("points") or []) if isinstance(p, dict)]
    if pts:
        out.append(("table", ["Δm [kg]", "ω_n² [rad²/s²]", "sd [rad²/s²]"],
                    [[_num(p.get("added_mass_kg"), 4), _num(p.get("omega_n2"), 6),
                      _num(p.get("omega_n2_sd"), 3)] for p in pts]))
    out.append(_figure("added_mass"))
    return out


def _campaign_build(data: dict[str, Any], directory: Path, now: str) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of a campaign folder (several recordings of one damper)."""
    s = data["summary"]
    n = _get(s, "design", "n_tests")
    title = f"dampfit damping report — campaign of {_num(n)} tests ({directory.name})"
    b: list[Block] = [("h1", title)] + _campaign_status(s)
    for name, sym in (("c", "c"), ("zeta", "ζ")):  # ζ when no mass identifies c
        x = _get(s, "parameters", name)
        px = _get(s, "population", "predictive", name)
        if isinstance(x, dict) and _finite(x.get("q50")):
            unit = CAMPAIGN_UNITS[name]
            b.append(("p", [("b", f"Population {sym} = {_with_interval(x, unit)}"),
                            "; a new test: " + (_with_interval(px, unit) if isinstance(px, dict)
                                                else "—") + " (90 % intervals)."]))
            break
    b += [("h2", "Design")] + _campaign_design(s)
    b += [("h2", "Population: the damper")] + _campaign_population(s)
    b += [("h2", "Verdict")] + _campaign_verdict(s)
    b += [("h2", "Each test")] + _campaign_tests(s) + [_figure("forest")]
    b += _campaign_added_mass(s)
    here = shlex.quote(os.path.abspath(directory))
    b += [("h2", "How to reproduce and cite"),
          ("p", ["Re-create this folder from the input files (add --force to replace it):"]),
          ("code", campaign_reproduce_command(s, directory)),
          ("p", [f"Cite as: dampfit {_num(s.get('dampfit_version'))} (hierarchical Bayesian "
                 "analysis of repeated free-decay tests of m·ü + c·u̇ + k·u = 0). Rendered from "
                 "summary.json by ", ("code", f"dampfit report {here}"), f" on {now}."])]
    return title, b


def build(data: dict[str, Any], directory: str | os.PathLike, now: str | None = None
          ) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of ``data`` (from :func:`load`) for the folder ``directory``.

    Every warning appears once, in the box at the top; the noise level is defined once, in
    "Noise model", and the Cramér–Rao bound refers to it; every key shown has a human label.
    A campaign folder (``"kind": "campaign"``) gets the campaign report."""
    directory = Path(directory)
    s = data["summary"]
    now = now or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    if s.get("kind") == "campaign":
        return _campaign_build(data, directory, now)
    path = _get(s, "input", "path")
    title = f"dampfit damping report — {Path(path).name if isinstance(path, str) else directory.name}"
    b: list[Block] = [("h1", title)]
    b += _status(s) + _headline(s)

    crlb = s.get("crlb")
    b += [("h2", "Result: posterior of c, k, u₀, ζ, f_n")] + _parameter_table(s, MAIN)
    b.append(("p", ["Median and 90 % equal-tailed interval of the posterior draws, with the "
                    "digits the interval's width supports; sd the posterior standard deviation; "
                    "R-hat (rank-normalised) and bulk ESS from arviz."]))
    if isinstance(crlb, dict):
        b += _crlb_blocks(crlb)
    else:
        b += [("h4", "Cramér–Rao lower bound")] + _not_computed("crlb", s, directory)
    b += [("h3", "Methods compared")] + _methods(s, directory)

    b += [("h2", "Inputs and provenance")] + _provenance(s, directory, now)
    b += [("h2", "Recorded signal"), _figure("signal")]
    b += [("h2", "Spectrum, pass band and filter response"), _figure("spectrum")]
    fit = s.get("fit") if isinstance(s.get("fit"), dict) else {}
    b += [("h2", "Analysed window, fit and residuals"),
          ("p", [f"Window {_num(_get(s, 'window', 'start_s'), 6)} – {_num(_get(s, 'window', 'end_s'), 6)} s; "
                 f"{_num(fit.get('n_samples'))} fitted samples ({_num(fit.get('path'))} path) at "
                 f"{_num(fit.get('sample_rate_hz'), 4)} Hz, drift polynomial degree "
                 f"{_num(fit.get('drift_degree'))}, {_num(fit.get('n_excluded'))} samples excluded."]),
          _figure("fit")]
    no_env = isinstance(s.get("baselines"), dict) and "envelope_pipeline" in s["baselines"] \
        and s["baselines"]["envelope_pipeline"] is None
    b += [("h2", "Displacement and envelope (paper Fig. 20)"),
          _figure("displacement",
                  "not drawn: the envelope-pipeline baseline was not computed" if no_env else None)]
    b += [("h2", "Posterior"), _figure("posterior"), _figure("trace"),
          ("h3", "Derived quantities")] + _parameter_table(s, DERIVED)

    b += [("h2", "Noise model")] + _noise(s)
    b += [("h2", "Diagnostics")] + _diagnostics(s)
    b += [("h2", "Model checks")] + _model_checks(s, directory)
    b += [("h2", "Amplitude dependence")] + _amplitude(s, directory)

    b += [("h2", "Verification in OpenSees")]
    ver = data.get("verification")
    if data.get("verification_error"):
        b.append(("box", "bad", "Verification not shown", [[data["verification_error"]]]))
    if ver is not None:
        b += _generic(ver) + [_figure("verify")]
    elif not data.get("verification_error"):
        b += _not_computed("verification", s, directory)

    here = shlex.quote(os.path.abspath(directory))
    b += [("h2", "How to reproduce and cite"),
          ("p", ["Re-create this folder from the input file (sha256 above; add --force to "
                 "replace the folder):"]),
          ("code", reproduce_command(s, directory))]
    if isinstance(path, str) and not os.path.isabs(path):
        b.append(("p", [f"The input path {path} was recorded relative to the folder the analysis "
                        "ran in: run the command from there."]))
    b.append(("p", [f"Cite as: dampfit {_num(s.get('dampfit_version'))} (Bayesian free-decay fit of "
                    "m·ü + c·u̇ + k·u = 0 to the acceleration), with the baselines of Flis, Szwoch & "
                    "Krawczyk (2025), “Determining a damping coefficient by using a MEMS accelerometer "
                    "for FEM simulation purposes on a discrete damper example”. Rendered from "
                    "summary.json by ", ("code", f"dampfit report {here}"), f" on {now}."]))
    return title, b


def _ours(path: Path, marker: str) -> bool:
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return marker in fh.read(4096)
    except OSError:
        return False


def write_report(directory: str | os.PathLike | Any, *, force: bool = False) -> dict[str, Path]:
    """Write ``report.html`` and ``report.md`` into the result folder ``directory`` (or the
    folder an analysis :func:`dampfit.load` read was loaded from).

    Reads ``summary.json`` (required), ``verification.json`` and the PNG figures found there.
    A report that dampfit wrote earlier is replaced; any other file of those names only with
    ``force``. Each file is written atomically. Returns ``{"html": path, "md": path}``.
    Call it on the final folder: the commands printed in the report name it.
    """
    d = folder_of(directory)
    data = load(d)
    title, blocks = build(data, d.resolve())
    texts = {"html": render_html(title, blocks, d), "md": render_markdown(title, blocks, d)}
    paths = {"html": d / "report.html", "md": d / "report.md"}
    for key, marker in (("html", _MARK_HTML), ("md", _MARK_MD)):
        if paths[key].exists() and not force and not _ours(paths[key], marker):
            raise InputError(f"{paths[key]} exists and was not written by dampfit; "
                             "use --force to replace it")
    try:
        for key, path in paths.items():
            atomic_write_text(path, texts[key])
    except OSError as exc:
        raise InputError(f"cannot write the report into {d}: {exc.strerror or exc}") from None
    return paths
