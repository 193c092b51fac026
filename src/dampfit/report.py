"""The damping report of a result folder: ``report.html`` (self-contained) and ``report.md``.

``dampfit report DIR`` (or :func:`write_report`) reads ``DIR/summary.json`` — plus the optional
``DIR/verification.json`` and the PNG figures already in ``DIR`` — and renders them; nothing is
recomputed, so the report states exactly the numbers of ``summary.json``. This module imports
only the standard library: no JAX, no matplotlib.

* ``report.html`` embeds every figure as a base64 ``data:`` URI with inline CSS and a
  Content-Security-Policy that forbids any other resource: it opens offline and prints.
* ``report.md`` refers to the figures as relative PNG files in ``DIR``.

Both are built from one list of blocks (:func:`build`), so they always say the same thing.
Optional summary entries (``crlb``, ``model_checks``, ``amplitude_curve``, verification) are
shown when present and otherwise say "not computed" with the command that computes them;
entries whose layout this module does not know are rendered as generic tables.

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

from ._document import _MARK_HTML, _MARK_MD, Block, _png
from ._document import GENERATOR as GENERATOR
from ._document import PNG_MAGIC as PNG_MAGIC
from ._document import render_html as render_html
from ._document import render_markdown as render_markdown
from ._files import atomic_write_text
from .errors import InputError

__all__ = ["write_report", "load", "build", "render_html", "render_markdown", "GENERATOR",
           "PNG_MAGIC", "add_arguments", "command"]


MAIN = ("c", "k", "u0", "zeta", "f_n")
DERIVED = ("p", "f_d", "delta", "Q", "c_crit")
UNITS = {"c": "N s/m", "k": "N/m", "u0": "m", "zeta": "1", "f_n": "Hz", "p": "1/s",
         "f_d": "Hz", "delta": "1", "Q": "1", "c_crit": "N s/m", "mass": "kg"}
NAMES = {"c": "c, damping coefficient", "k": "k, stiffness", "u0": "u₀, initial amplitude",
         "zeta": "ζ, damping ratio", "f_n": "f_n, natural frequency", "p": "p = c/(2m), decay rate",
         "f_d": "f_d, damped frequency", "delta": "δ, logarithmic decrement",
         "Q": "Q = 1/(2ζ), quality factor", "c_crit": "c_crit = 2√(km), critical damping"}
LABELS = {"mae": "MAE", "mse": "MSE", "nmse": "NMSE", "rmse": "RMSE", "r_hat": "R-hat",
          "ess_bulk": "bulk ESS", "max_r_hat": "max R-hat", "min_ess_bulk": "min bulk ESS",
          "autocorr_time_steps": "integrated autocorrelation time", "n_steps": "steps",
          "psd_ratio_at_f0": "Whittle factor r (PSD ratio at f₀)",
          "psd_ratio_at_f0_unclipped": "r before the floor at its white-noise value (noise.estimate)",
          "residual_lag1_autocorrelation": "residual lag-1 autocorrelation", "sigma": "σ"}
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
    "amplitude": "Decay rate against amplitude (amplitude-dependent damping check).",
    "verify": "OpenSees verification: simulated response of the identified system against the "
              "measurement.",
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
        return ", ".join(f"{k} = {_num(v, 4)}" for k, v in x.items()) or "—"
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
    """``[q05, q95]`` with enough significant digits to resolve the interval's width."""
    lo, hi = q.get("q05"), q.get("q95")
    if not (_finite(lo) and _finite(hi)):
        return "—"
    width, scale = abs(hi - lo), max(abs(lo), abs(hi))
    d = 4 if width <= 0 or scale <= 0 else min(12, max(3, math.ceil(math.log10(scale / width)) + 2))

    def g(x: float) -> str:  # keep trailing zeros (1.720000), not a bare point (619.)
        return f"{x:#.{d}g}".replace(".e", "e").rstrip(".")

    return f"[{g(lo)}, {g(hi)}]"


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
        rows = [{"name": k, **r} for k, r in obj.items()]
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
def load(directory: str | os.PathLike) -> dict[str, Any]:
    """Read ``DIR/summary.json`` (required) and ``DIR/verification.json`` (optional).

    Returns ``{"summary": dict, "verification": dict | None, "verification_error": str | None}``.
    """
    d = Path(directory)
    if not d.is_dir():
        raise InputError(f"{d} is not a directory; give the result folder of 'dampfit analyze'")
    path = d / "summary.json"
    if not path.is_file():
        raise InputError(f"{d} has no summary.json; run 'dampfit analyze FILE --out {d}' first")
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read {path}: {exc}; re-run the analysis") from None
    if not isinstance(summary, dict):
        raise InputError(f"{path} is not a dampfit summary (expected a JSON object)")
    ver, err = summary.get("verification"), None
    vpath = d / "verification.json"
    if vpath.is_file():
        try:
            ver = json.loads(vpath.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            ver, err = None, f"verification.json could not be read ({exc})"
    return {"summary": summary, "verification": ver, "verification_error": err}


# ----------------------------------------------------------------------------- commands
def _is_demo(s: dict, directory: Path) -> bool:
    from .cli import DEMO_MARKER

    path = _get(s, "input", "path")
    return (directory / DEMO_MARKER).is_file() and isinstance(path, str) \
        and Path(path).name == DEMO_MARKER.replace(".truth.json", ".csv")


def reproduce_command(s: dict, directory: str | os.PathLike) -> str:
    """The shell command that re-creates the result folder ``directory`` from its input."""
    directory = Path(directory)
    q = shlex.quote
    seed = _get(s, "provenance", "seed")
    seed = seed if isinstance(seed, int) else 0
    if _is_demo(s, directory):
        return f"dampfit demo --seed {seed} --out {q(str(directory))}"
    opts = _get(s, "provenance", "options")
    opts = opts if isinstance(opts, dict) else {}
    path = _get(s, "input", "path")
    parts = ["dampfit", "analyze", q(path) if isinstance(path, str) else "FILE"]
    m = s.get("mass") if isinstance(s.get("mass"), dict) else {}
    if _finite(m.get("value")):
        parts += ["--mass", repr(float(m["value"]))]
        if _finite(m.get("sd")) and m["sd"] > 0:
            parts += ["--mass-sd", repr(float(m["sd"]))]
    if isinstance(opts.get("axis"), str) and opts["axis"] != "auto":
        parts += ["--axis", q(opts["axis"])]
    for key in ("window", "band"):
        v = opts.get(key)
        if isinstance(v, list) and len(v) == 2 and all(_finite(x) for x in v):
            parts += [f"--{key}", repr(float(v[0])), repr(float(v[1]))]
    if isinstance(opts.get("model"), str) and opts["model"] != "viscous":
        parts += ["--model", q(opts["model"])]
    if isinstance(opts.get("max_steps"), int) and opts["max_steps"] != 20000:
        parts += ["--max-steps", str(opts["max_steps"])]
    return " ".join(parts + ["--seed", str(seed), "--out", q(str(directory))])


def _hint(what: str, s: dict, directory: Path) -> str:
    """The command that computes an optional section that is absent."""
    if what == "verification":
        return f"dampfit verify {shlex.quote(str(directory))}"
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


def _status(s: dict) -> list[Block]:
    """The red box (not converged, warnings) or the green one, at the top of the report."""
    d = s.get("diagnostics") if isinstance(s.get("diagnostics"), dict) else {}
    warns = [w for w in (d.get("warnings") or []) if w] if isinstance(d.get("warnings"), list) else []
    mc_warn = _get(s, "model_checks", "warning")
    if mc_warn:
        warns.append(f"model checks: {_num(mc_warn)}")
    converged = d.get("converged")
    facts = (f"max R-hat {_fixed(d.get('max_r_hat'), '.4f')}, min bulk ESS "
             f"{_fixed(d.get('min_ess_bulk'), '.0f')}, {_num(d.get('n_steps'))} steps × "
             f"{_num(d.get('n_walkers'))} walkers")
    if not d:
        return [("box", "bad", "No diagnostics in summary.json: convergence is unknown",
                 [["Re-run the analysis before using these numbers."]])]
    if converged is not True or warns:
        title = ("NOT CONVERGED — read the diagnostics before using these numbers"
                 if converged is not True else "Converged, with warnings")
        items = ([[f"least squares converged: {_num(_get(s, 'least_squares', 'converged'))}; "
                   f"posterior converged: {_num(d.get('posterior_converged'))} ({facts})"]]
                 if converged is not True else [[f"Diagnostics: {facts}."]])
        return [("box", "bad", title, items + [[("b", "Warning: "), _num(w)] for w in warns])]
    return [("box", "ok", "Converged, no warnings", [[f"Diagnostics: {facts}."]])]


def _headline(s: dict) -> list[Block]:
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    spans: list = []
    for name in MAIN:
        q = params.get(name)
        if isinstance(q, dict) and _isnum(q.get("q50")):
            sym, unit = NAMES[name].split(",")[0], q.get("unit") or UNITS[name]
            spans += ["; "] if spans else []
            spans += [("b", f"{sym} = {_num(q['q50'])}" + (f" {unit}" if unit != "1" else "")),
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
        row = [NAMES[name], q.get("unit") or UNITS[name], _num(q.get("q50")), _num(q.get("mean")),
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


def _crlb_details(crlb: dict) -> list[Block]:
    """Bounds on other quantities (with their units) and the bound's design, as tables."""
    units = crlb.get("units") if isinstance(crlb.get("units"), dict) else {}
    others = {k: {**v, "unit": units.get(k, UNITS.get(k, ""))} for k, v in crlb.items()
              if isinstance(v, dict) and k not in MAIN and k != "units"}
    rest = {k: v for k, v in crlb.items() if k not in MAIN and k not in others and k != "units"}
    return (_generic(others) if others else []) + (_generic(rest) if rest else [])


def _methods(s: dict, directory: Path) -> list[Block]:
    """c, ζ, f_n, p per method: posterior, least squares, each baseline (and a demo's truth)."""
    params = s.get("parameters") if isinstance(s.get("parameters"), dict) else {}
    head = ["method", "c [N s/m]", "ζ [1]", "f_n [Hz]", "p [1/s]", "note"]
    rows = [["posterior median"] + [_num(_get(params, n, "q50")) for n in ("c", "zeta", "f_n", "p")]
            + ["90 % intervals in the table above"]]
    ls = s.get("least_squares")
    if isinstance(ls, dict):
        pm = lambda v, sd: _num(v) + (f" ± {_num(sd, 2)}" if _isnum(sd) and _isnum(v) else "")  # noqa: E731
        rows.append(["least squares", pm(ls.get("c"), ls.get("c_sd")),
                     pm(ls.get("zeta"), ls.get("zeta_sd")), _num(ls.get("f_n")), _num(ls.get("p")),
                     "± 1σ from the Jacobian" + ("" if ls.get("converged", True) else "; NOT converged")])
    bases = s.get("baselines") if isinstance(s.get("baselines"), dict) else {}
    for key, b in bases.items():
        label = BASELINES.get(key, _label(key))
        if not isinstance(b, dict):
            rows.append([label, "—", "—", "—", "—", "not computed (see the warnings)"])
            continue
        f_n, z = b.get("f_n"), b.get("zeta")
        if not _isnum(f_n) and _isnum(b.get("f_d")) and _isnum(z) and 0 <= z < 1:
            f_n = b["f_d"] / math.sqrt(1.0 - z * z)
        note = f"over {b['n_cycles']} cycles; " if _isnum(b.get("n_cycles")) else ""
        if b.get("supported") is False and _isnum(b.get("n_cycles_used")) and _isnum(b.get("n_cycles_window")):
            note += (f"only {b['n_cycles_used']:.3g} of {b['n_cycles_window']:.3g} cycles — not reliable"
                     f" ({b.get('support_reason') or 'too little support'}); ")
        if b.get("agrees_with_posterior") is False:
            note += str(b.get("note") or "disagrees with the posterior beyond its expected spread") + "; "
        rows.append([label, _num(b.get("c")), _num(z), _num(f_n), _num(b.get("p")),
                     note + "f_n = f_d/√(1−ζ²)" if not _isnum(b.get("f_n")) else note.rstrip("; ")])
    truth = _truth(s, directory)
    if truth:
        rows.append(["truth (simulated input)"] + [_num(truth.get(n)) for n in ("c", "zeta", "f_n", "p")]
                    + ["demo: the known values the recording was simulated with"])
    return [("table", head, rows)]


def _truth(s: dict, directory: Path) -> dict | None:
    if not _is_demo(s, directory):
        return None
    from .cli import DEMO_MARKER

    try:
        truth = json.loads((directory / DEMO_MARKER).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return truth if isinstance(truth, dict) else None


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
    mass = (f"{_num(m.get('value'))} ± {_num(m.get('sd'), 3)} kg" if _isnum(m.get("value"))
            else "not given (c and k cannot be identified)")
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
        ["options", _num(prov.get("options"))],
        ["dampfit version", _num(s.get("dampfit_version"))], ["seed", _num(prov.get("seed"))],
        ["Python", _num(prov.get("python"))],
        ["package versions", _num(prov.get("versions")).replace(" = ", " ")],
        ["analysis date", _num(date)], ["report generated", now],
    ]
    notes = [n for src in (inp.get("notes"), _get(s, "preprocessing", "notes"))
             if isinstance(src, list) for n in src if isinstance(n, str)]
    out: list[Block] = [("table", ["item", "value"], rows)]
    if notes:
        out += [("p", ["Reading and preprocessing notes:"]), ("ul", [[n] for n in notes])]
    return out


def build(data: dict[str, Any], directory: str | os.PathLike, now: str | None = None
          ) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of ``data`` (from :func:`load`) for the folder ``directory``."""
    directory = Path(directory)
    s = data["summary"]
    now = now or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    path = _get(s, "input", "path")
    title = f"dampfit damping report — {Path(path).name if isinstance(path, str) else directory.name}"
    b: list[Block] = [("h1", title)]
    b += _status(s) + _headline(s)

    crlb = s.get("crlb")
    b += [("h2", "Result: posterior of c, k, u₀, ζ, f_n")] + _parameter_table(s, MAIN)
    b.append(("p", ["Median and 90 % equal-tailed interval of the posterior draws; sd the posterior "
                    "standard deviation; R-hat (rank-normalised) and bulk ESS from arviz."]))
    if isinstance(crlb, dict):
        b.append(("p", ["CRLB sd: the Cramér–Rao lower bound on the standard deviation of an "
                        "unbiased estimator for this recording's design and noise (with the mass "
                        "uncertainty for c and k); sd / CRLB sd near 1 means the posterior is as "
                        "tight as the data allow."]))
        b += [("h4", "Cramér–Rao lower bound: other quantities and design")] + _crlb_details(crlb)
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

    nm = s.get("noise_model")
    b += [("h2", "Noise model")]
    b += _generic(nm) if isinstance(nm, dict) else [("p", ["Not in summary.json."])]
    b += [("p", ["r > 1 means the residuals near f₀ exceed the white-noise level; the likelihood "
                 "is tempered by 1/r, which widens the intervals accordingly."])]
    if isinstance(s.get("preprocessing"), dict):
        b += [("h3", "Preprocessing")] + _generic(
            {k: v for k, v in s["preprocessing"].items() if k != "notes"})

    b += [("h2", "Diagnostics")] + _status(s)
    diag = s.get("diagnostics")
    if isinstance(diag, dict):
        b += _generic({k: v for k, v in diag.items() if k != "warnings"})

    b += [("h2", "Model checks")] + _model_checks(s, directory)
    b += [("h2", "Amplitude dependence")]
    curve = s.get("amplitude_curve")
    if curve is not None:
        b += _generic(curve) + [_figure("amplitude")]
    elif _png(directory, "amplitude"):
        b.append(_figure("amplitude"))
    else:
        b += _not_computed("amplitude_curve", s, directory)

    b += [("h2", "Verification in OpenSees")]
    ver = data.get("verification")
    if data.get("verification_error"):
        b.append(("box", "bad", "Verification not shown", [[data["verification_error"]]]))
    if ver is not None:
        b += _generic(ver) + [_figure("verify")]
    elif not data.get("verification_error"):
        b += _not_computed("verification", s, directory)

    b += [("h2", "How to reproduce and cite"),
          ("p", ["Re-create this folder from the input file (sha256 above; add --force to "
                 "replace the folder):"]),
          ("code", reproduce_command(s, directory)),
          ("p", [f"Cite as: dampfit {_num(s.get('dampfit_version'))} (Bayesian free-decay fit of "
                 "m·ü + c·u̇ + k·u = 0 to the acceleration), with the baselines of Flis, Szwoch & "
                 "Krawczyk (2025), “Determining a damping coefficient by using a MEMS accelerometer "
                 "for FEM simulation purposes on a discrete damper example”. Rendered from "
                 "summary.json by ", ("code", f"dampfit report {directory}"), f" on {now}."])]
    return title, b


def _model_checks(s: dict, directory: Path) -> list[Block]:
    mc = s.get("model_checks")
    if not isinstance(mc, dict):
        return _not_computed("model_checks", s, directory)
    out: list[Block] = []
    if mc.get("warning"):
        out.append(("box", "bad", "Model check warning", [[_num(mc["warning"])]]))
    if mc.get("verdict") is not None:
        out.append(("p", [("b", "Verdict: "), _num(mc["verdict"])]))
    if mc.get("preferred_model") is not None:
        out.append(("p", ["Preferred damping model: ", ("b", _num(mc["preferred_model"]))]))
    for key, head in (("residual_whiteness", "Residual whiteness"),
                      ("amplitude_dependence", "Amplitude dependence of the decay rate"),
                      ("models", "Damping models compared")):
        if key in mc:
            out += [("h3", head)] + (_generic(mc[key]) if mc[key] is not None
                                      else [("p", ["not computed"])])
    rest = {k: v for k, v in mc.items() if k not in
            ("warning", "verdict", "preferred_model", "residual_whiteness",
             "amplitude_dependence", "models")}
    return out + (_generic(rest) if rest else [])


def _ours(path: Path, marker: str) -> bool:
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return marker in fh.read(4096)
    except OSError:
        return False


def write_report(directory: str | os.PathLike, *, force: bool = False) -> dict[str, Path]:
    """Write ``report.html`` and ``report.md`` into the result folder ``directory``.

    Reads ``summary.json`` (required), ``verification.json`` and the PNG figures found there.
    A report that dampfit wrote earlier is replaced; any other file of those names only with
    ``force``. Each file is written atomically. Returns ``{"html": path, "md": path}``.
    Call it on the final folder: the commands printed in the report name it.
    """
    d = Path(directory)
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


def add_arguments(parser) -> None:
    """Arguments of ``dampfit report``."""
    parser.add_argument("dir", metavar="DIR",
                        help="result folder with summary.json (from 'dampfit analyze' or 'demo')")
    parser.add_argument("--force", action="store_true",
                        help="replace report.html/report.md even if dampfit did not write them "
                             "(a report dampfit wrote is always regenerated)")


def command(args) -> int:
    """``dampfit report DIR [--force]``: write the report; exit code 0."""
    paths = write_report(args.dir, force=args.force)
    print(f"wrote {paths['html']} and {paths['md']}")
    return 0
