"""Honest digits: the one formatter of a number with its uncertainty, for every output.

A value printed with its 90 % interval gets its digits from the interval's width: enough
decimals that the width shows two significant digits (:func:`decimals`), so a narrow interval
is never printed as ``1.72 [1.72, 1.72]`` and a wide one does not pretend to six digits. The
text table (:mod:`dampfit.output.text`, :mod:`dampfit.output.text_campaign`) and both reports
(:mod:`dampfit.output.report`) print every such number through this module, so one number is
printed with the same digits wherever it appears:

* :func:`interval` — median and both ends of a 90 % interval;
* :func:`point` — another estimate of the same quantity (least squares) with the digits of
  that interval;
* :func:`own_spread` — a value with the digits of its own expected 90 % spread (a baseline);
* :func:`with_interval` — ``median [q05, q95]`` of a summary's quantile dict;
* :func:`estimate` — a least-squares value of a summary with the digits of its posterior
  interval; :func:`baseline` — a baseline's value with the digits of its own spread;
* :func:`formatted` — a plain number in a given format (R-hat, ESS, a frequency), ``—`` when missing;
* :func:`decimals` and :func:`fixed` — the two steps every one of them takes.

Standard library only.
"""

from __future__ import annotations

import math
from typing import Any

#: z-value of the two-sided 90 % interval of a normal distribution: a spread ± 1.645·sd.
Z90 = 1.645


def _significant(x: float, digits: int) -> str:
    return f"{x:.{digits}g}"


def real(x: Any) -> bool:
    """A finite number (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


_real = real


def formatted(x: Any, spec: str, *, finite_only: bool = False) -> str:
    """``x`` in the format ``spec`` (``.4f``: R-hat 1.0099 must not print as "1.01" next to a
    "< 1.01" rule; ``.5g``), or ``—`` for None — and, with ``finite_only``, for anything
    that is not a finite number."""
    if x is None or (finite_only and not real(x)):
        return "—"
    return format(x, spec)


def decimals(lo: Any, hi: Any) -> int | None:
    """Decimals that show the width |hi − lo| with two significant digits (None: no width;
    negative: the last significant digit lies left of the point)."""
    try:
        width = abs(float(hi) - float(lo))
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(width) and width > 0):
        return None
    return 1 - math.floor(math.log10(width))  # negative for widths ≥ 100


def fixed(x: Any, dec: int | None, scale: float | None = None) -> str:
    """``x`` with ``dec`` decimals (``—`` for None; six significant digits without ``dec`` or
    for a value that is not finite); in scientific notation with the same absolute precision
    when ``scale`` (the largest magnitude printed alongside, default |x|) is below 10⁻⁴ or
    above 10⁹, where fixed point gets unwieldy.

    In scientific notation every number has its own exponent (a normalised mantissa), with
    as many mantissa digits as the absolute precision 10^−dec allows and at least one: 4·10⁻⁶
    beside an upper bound of 2·10⁻⁵ prints as ``4e-06``, never ``0.4e-05``."""
    if x is None:
        return "—"
    x = float(x)
    if dec is None or not math.isfinite(x):
        return _significant(x, 6)
    scale = abs(x) if scale is None else scale
    if scale >= 1e9 or 0 < scale < 1e-4:
        if x == 0:
            return "0"
        digits = max(0, math.floor(math.log10(abs(x))) + dec)
        return f"{x:.{digits}e}"
    return f"{x:.{max(0, dec)}f}"


def interval(q50: Any, q05: Any, q95: Any) -> tuple[str, str, str]:
    """(median, q05, q95) as strings with digits chosen from the interval width (module
    docstring): ``interval(1.72031, 1.71992, 1.72068)`` → ``("1.72031", "1.71992", "1.72068")``;
    ``interval(0.062, 0.019, 0.28)`` → ``("0.06", "0.02", "0.28")``. Without a width (missing
    or zero) six significant digits; a missing value is ``—``."""
    dec = decimals(q05, q95)
    vals = [abs(float(v)) for v in (q50, q05, q95) if _real(v)]
    scale = max(vals) if vals else None
    return fixed(q50, dec, scale), fixed(q05, dec, scale), fixed(q95, dec, scale)


def point(x: Any, q05: Any, q95: Any) -> str:
    """``x``, another estimate of a quantity whose 90 % interval is [q05, q95] (e.g. its least
    squares beside its posterior), with the digits that interval gives its median: exactly
    the median's text of :func:`interval` when ``x`` is the median."""
    return interval(x, q05, q95)[0]


def with_interval(q: dict) -> str:
    """``median [q05, q95]`` of a summary's quantile dict ``q`` with the digits of
    :func:`interval` (a missing value as ``—``)."""
    m, lo, hi = interval(q.get("q50"), q.get("q05"), q.get("q95"))
    return f"{m} [{lo}, {hi}]"


def estimate(s: dict, name: str, x: Any) -> str:
    """A point estimate ``x`` of ``name`` (its least squares) with the digits of the 90 %
    interval of ``name`` in the summary ``s``'s ``parameters`` (:func:`point`; six significant
    digits without one)."""
    q = lookup(s, "parameters", name) or {}
    return point(x, q.get("q05"), q.get("q95"))


def baseline(b: dict, name: str) -> str:
    """A baseline's value ``b[name]`` with the digits of its own expected 90 % spread
    (:func:`own_spread` of its ``expected_rel_sd``)."""
    return own_spread(b.get(name), b.get("expected_rel_sd"))


def own_spread(x: Any, rel_sd: Any) -> str:
    """``x`` with the digits of its own expected 90 % spread ± 1.645·rel_sd·|x| (a baseline's
    expected relative sd ``rel_sd`` [1]), so it shows no more precision than it has; six
    significant digits without a finite ``rel_sd``, ``—`` without ``x``."""
    if x is None:
        return "—"
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return str(x)
    if not (_real(x) and _real(rel_sd)):
        return fixed(x, None)
    return fixed(x, decimals(0.0, 2 * Z90 * rel_sd * abs(float(x))))


def lookup(d: Any, *keys: str) -> Any:
    """``d[k1][k2]…`` of a summary's nested dicts, or None where a level is missing or not a
    dict (an edited summary may hold anything)."""
    for key in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(key)
    return d


def quantiles(q: Any) -> tuple[float, float, float] | None:
    """(q50, q05, q95) of a summary's quantile dict when all three are finite numbers, else
    None (an edited summary may hold anything)."""
    if not isinstance(q, dict) or not all(_real(q.get(k)) for k in ("q50", "q05", "q95")):
        return None
    return q["q50"], q["q05"], q["q95"]
