"""What both reports are made of: summary values as text, labels and units, generic tables.

Every value of ``summary.json`` that a report shows passes through here: :func:`number` (any
value, short), :func:`median` / :func:`bracket` / :func:`with_interval` (a value with its 90 %
interval), :func:`estimate` (least squares, with the posterior's digits) and
:func:`baseline_value` (with the digits of its own spread) — the digits from the one
formatter of every output, :mod:`dampfit.output.format`, so the report prints each number as
the text table does. :func:`label_of` and :func:`unit_of` give every key a human label and a
unit; :func:`generic` renders any entry whose layout the report does not know as tables.
An edited summary.json may hold anything: nothing here assumes a type.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit import physics
from dampfit.output.campaign import FIGURES as CAMPAIGN_FIGURES
from dampfit.output.document import Block
from dampfit.output.format import (baseline, formatted, interval, lookup, point, quantiles,
                                   real)
from dampfit.output.format import estimate as estimate_text
from dampfit.output.format import with_interval as interval_text

#: The headline quantities (the result table) and the derived ones.
MAIN = ("c", "k", "u0", "zeta", "f_n")
DERIVED = ("p", "f_d", "delta", "Q", "c_crit")
#: Units of the reported quantities: :data:`dampfit.physics.UNITS`, the one table.
UNITS = physics.UNITS
#: Human name of each quantity.
NAMES = {"c": "c, damping coefficient", "k": "k, stiffness", "u0": "u₀, initial amplitude",
         "zeta": "ζ, damping ratio", "f_n": "f_n, natural frequency", "p": "p = c/(2m), decay rate",
         "f_d": "f_d, damped frequency", "delta": "δ, logarithmic decrement",
         "Q": "Q = 1/(2ζ), quality factor", "c_crit": "c_crit = 2√(km), critical damping"}
#: Human label of a summary key (else the key with "_" as spaces, its unit suffix cut).
LABELS = {"mae": "MAE", "mse": "MSE", "nmse": "NMSE", "rmse": "RMSE", "r_hat": "R-hat",
          "ess_bulk": "bulk ESS", "max_r_hat": "max R-hat", "min_ess_bulk": "min bulk ESS",
          "autocorr_time_steps": "integrated autocorrelation time", "n_steps": "steps",
          "psd_ratio_at_f0": "Whittle factor r (PSD ratio at f₀)",
          "psd_ratio_at_f0_unclipped": "r as measured (plain Welch ratio), before its calibration "
                                       "(noise.estimate)",
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
#: Caption of each figure a report shows, by file stem (the campaign's from
#: :data:`dampfit.output.campaign.FIGURES`).
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
    "modes": "Amplitude spectrum of the selected signal in dB re its peak with each identified "
             "mode marked: f_n at its posterior median (dashed) and its 90 % interval (band), "
             "labelled with f_n and ζ (median [90 % interval]).",
    "verify": "OpenSees verification: simulated response of the identified system against the "
              "measurement.",
    **CAMPAIGN_FIGURES,
}


def isnum(x: Any) -> bool:
    """A number (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def number(x: Any, digits: int = 6) -> str:
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
        return ", ".join(f"{label_of(k)} = {number(v, 4)}" for k, v in x.items()) or "—"
    if isinstance(x, (list, tuple)):
        if len(x) > 8 and all(isnum(v) for v in x):
            return f"{len(x)} values, {number(x[0], 4)} … {number(x[-1], 4)}"
        return ", ".join(number(v, 4) for v in x) or "—"
    return str(x)


#: A finite number (not a bool): :func:`dampfit.output.format.real`.
finite = real


def spec(x: Any, fmt: str) -> str:
    """``x`` in the format ``fmt`` (:func:`dampfit.output.format.formatted`), or — when it is
    not a finite number."""
    return formatted(x, fmt, finite_only=True)


def bracket(q: dict) -> str:
    """``[q05, q95]`` with the digits of :func:`dampfit.output.format.interval` (from the width)."""
    lo, hi = q.get("q05"), q.get("q95")
    if not (finite(lo) and finite(hi)):
        return "—"
    return "[{1}, {2}]".format(*interval(q.get("q50") if finite(q.get("q50")) else lo, lo, hi))


def median(q: dict, key: str = "q50") -> str:
    """``q[key]`` (median, mean) with the digits of the 90 % interval of ``q``."""
    x = q.get(key)
    if not finite(x):
        return "—"
    if not (finite(q.get("q05")) and finite(q.get("q95"))):
        return number(x)
    return point(x, q["q05"], q["q95"])


def estimate(s: dict, name: str, x: Any) -> str:
    """A point estimate of ``name`` (least squares) with the digits of its posterior interval
    (:func:`dampfit.output.format.point`, as the text table prints it)."""
    q = get(s, "parameters", name)
    if not (finite(x) and isinstance(q, dict) and finite(q.get("q05")) and finite(q.get("q95"))):
        return number(x)
    return estimate_text(s, name, x)


def baseline_value(b: dict, name: str) -> str:
    """A baseline's value with the digits of its own expected 90 % spread
    (:func:`dampfit.output.format.own_spread`, as the text table prints it), else six
    significant digits."""
    if not (finite(b.get(name)) and finite(b.get("expected_rel_sd"))):
        return number(b.get(name))
    return baseline(b, name)


def with_interval(q: Any, unit: str = "") -> str:
    """``median [q05, q95] unit`` with honest digits, or — ."""
    if not isinstance(q, dict) or not finite(q.get("q50")):
        return "—"
    unit = "" if unit in ("", "1") else f" {unit}"
    if quantiles(q) is not None:
        return f"{interval_text(q)}{unit}"
    return f"{median(q)} {bracket(q)}{unit}"


#: ``d[k1][k2]…`` or None where anything along the way is missing or not a dict
#: (:func:`dampfit.output.format.lookup`).
get = lookup


def label_of(key: Any) -> str:
    """The human label of a summary key (:data:`LABELS`, :data:`NAMES`, else the key itself
    with its unit suffix cut and spaces for "_")."""
    key = str(key)
    if key.lower() in LABELS or key in NAMES:
        return LABELS.get(key.lower(), NAMES.get(key, key))
    suffix = next((suf for suf, _ in _SUFFIX_UNITS if key.endswith(suf) and len(key) > len(suf)), "")
    return key[: len(key) - len(suffix)].replace("_", " ")


def unit_of(key: Any, parent: dict) -> str:
    """The unit of ``parent[key]``: its ``KEY_unit`` entry, the units table, else the key's
    suffix (``_hz`` → Hz, …)."""
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
        rows = [{"name": label_of(k), **r} for k, r in obj.items()]
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
    head = [label_of(k) + (f" [{unit_of(k, units)}]" if unit_of(k, units) else "") for k in keys]
    body = [[number(r.get(k), 5) for k in keys] for r in rows[:max_rows]]
    out: list[Block] = [("table", head, body)]
    if len(rows) > max_rows:
        out.append(("p", [f"… and {len(rows) - max_rows} more rows in the JSON file."]))
    return out


def generic(obj: Any, depth: int = 0) -> list[Block]:
    """Blocks for any JSON value: a key/value/unit table, sub-tables for nested entries."""
    rec = _records(obj)
    if rec is not None and isinstance(obj, dict) and not all(isinstance(v, dict) for v in obj.values()):
        rest = {k: v for k, v in obj.items() if k not in rec[0]}  # columns + other entries
        return (generic(rest, depth) if rest else []) + _records_table(*rec, units=obj)
    if rec is not None:
        return _records_table(*rec, units={k: v for r in rec[1] for k, v in r.items()})
    if not isinstance(obj, dict):
        return [("p", [number(obj)])]
    rows, subs = [], []
    for k, v in obj.items():
        if str(k).endswith("_unit") and str(k)[:-5] in obj:
            continue
        if isinstance(v, (dict, list)) and depth < 3 and (_records(v) or isinstance(v, dict)):
            subs += [("h4", label_of(k))] + (generic(v, depth + 1) if v else [("p", ["—"])])
        else:
            rows.append([label_of(k), number(v), unit_of(k, obj)])
    return ([("table", ["item", "value", "unit"], rows)] if rows else []) + subs


def figure(name: str, why_missing: str | None = None) -> Block:
    """The block of figure ``DIR/name.png`` with its caption (:data:`FIGURES`); ``why_missing``
    replaces it by a note."""
    return ("figure", name, FIGURES.get(name, name), why_missing)


def more_warnings(more: int) -> list[str]:
    """The line that counts the distinct warnings not shown (none when there are none)."""
    return [f"… and {more} more distinct warnings (see summary.json)"] if more else []
