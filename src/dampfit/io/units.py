"""Units of the time and acceleration columns: names, unit inference and conversion.

Time is converted to seconds, acceleration to m/s². A column's unit is, in this order, the one
the user gave, the one written in its header (``Time (ms)``, ``acc [g]``, ``micros``), the one
the format implies (phyphox: s and m/s²), else inferred from the values:

* time (:func:`infer_time_unit`): the unit (s, ms, µs, ns) whose median step gives a plausible
  sample rate (1 Hz–100 kHz); non-integer stamps prefer s, integer stamps (``millis()``,
  ``micros()``, epoch ns) the unit nearest a few hundred Hz. Integer stamps are split into
  whole seconds and a remainder before the float conversion, so epoch nanoseconds stay exact.
* acceleration (:func:`infer_accel_unit`): g if the data clearly look like g (mean vector of
  three axes of magnitude ≈ 1, or a single axis with a static mean ≈ ±1, and peak |a| < 20 g);
  m/s² if they cannot be g (peak > 20 or |mean| > 2); otherwise the format's default.

Every conversion and assumption is returned as a note for ``Recording.notes``.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from dampfit.errors import InputError
from dampfit.io.recording import STANDARD_GRAVITY
from dampfit.io.text import Column, Table

#: Seconds per unit of time.
_TIME_FACTORS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Integer ticks per second, for exact conversion of integer stamps.
_TICKS: dict[str, int] = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}
#: Unit names as printed in notes.
_TIME_LABELS = {"s": "s", "ms": "ms", "us": "µs", "ns": "ns"}
#: Accepted spellings of each time unit (lower case).
TIME_ALIASES: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millis", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "usec", "micros", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanos", "nanosecond", "nanoseconds"), "ns"),
}
#: m/s² per unit of acceleration.
_ACCEL_FACTORS: dict[str, float] = {"m/s2": 1.0, "g": STANDARD_GRAVITY, "mg": STANDARD_GRAVITY / 1000}
#: Unit names as printed in notes.
_ACCEL_LABELS = {"m/s2": "m/s²", "g": "g", "mg": "mg"}
#: Accepted spellings of each acceleration unit (lower case).
ACCEL_ALIASES: dict[str, str] = {
    **dict.fromkeys(
        ("m/s2", "m/s^2", "m/s²", "m/s/s", "ms^-2", "ms-2", "m s^-2", "m*s^-2", "mps2", "ms2"),
        "m/s2",
    ),
    **dict.fromkeys(("g", "g0", "gee"), "g"),
    **dict.fromkeys(("mg", "milli-g"), "mg"),
}

#: Plausible sample rates [Hz] for time-unit inference, and the typical rate for ties.
_RATE_RANGE = (1.0, 1e5)
_TYPICAL_RATE = 300.0
#: Largest |a| that can still be g from a MEMS sensor (full scale ≤ ±16 g) [g].
_MAX_G = 20.0
#: A unit written in a column name: in brackets (``Time (ms)``) or as a suffix (``acc_g``).
_BRACKET_UNIT = re.compile(r"^(?P<base>.*?)\s*[(\[{]\s*(?P<unit>[^)\]}]*?)\s*[)\]}]\s*$")
_SUFFIX_UNIT = re.compile(r"^(?P<base>.+?)[\s_\-]+(?P<unit>[^\s_\-]+)$")


def canonical_unit(unit: str, aliases: dict[str, str], what: str) -> str:
    key = str(unit).strip().lower().replace("μ", "µ")
    if key in aliases:
        return aliases[key]
    allowed = "s, ms, us, µs, ns" if what == "time" else "m/s2, m/s^2, m/s², g, mg"
    raise InputError(f"unknown {what} unit {unit!r}; use one of {allowed}")


def split_name(name: Column) -> tuple[str, str | None]:
    """Column name → (base name, unit written in it or None): ``Time (ms)``, ``acc_g``…"""
    text = str(name).strip().strip('"').strip()
    match = _BRACKET_UNIT.match(text)
    if match:
        return match["base"], match["unit"]
    match = _SUFFIX_UNIT.match(text)
    if match:
        unit = match["unit"].lower().replace("μ", "µ")
        if unit in TIME_ALIASES or unit in ACCEL_ALIASES:
            return match["base"], match["unit"]
    return text, None


def name_words(base: str) -> list[str]:
    """The lower-case letter runs of a column name: ``"Linear Acceleration X"`` → linear, acceleration, x."""
    return re.findall(r"[a-z]+", base.lower())


def _header_unit(name: Column, aliases: dict[str, str]) -> str | None:
    """The unit (canonical) written in a column name, e.g. ``Time (ms)`` → ``ms``, ``micros`` → ``us``."""
    base, unit = split_name(name)
    if unit is not None:
        return aliases.get(unit.strip().lower().replace("μ", "µ"))
    if aliases is TIME_ALIASES:
        for word in name_words(base):
            if word in TIME_ALIASES and word != "s":
                return TIME_ALIASES[word]
    return None


def _values(table: Table, col: Column) -> np.ndarray:
    """A column as a numeric array (integers kept for exact time conversion)."""
    series = table.frame[col]
    if pd.api.types.is_numeric_dtype(series) and not pd.api.types.is_bool_dtype(series):
        return series.to_numpy()
    converted = pd.to_numeric(series, errors="coerce")
    text = series.astype("string").str.strip()
    bad = converted.isna() & series.notna() & (text != "")
    if bad.any():
        row = int(np.argmax(bad.to_numpy()))
        raise InputError(f"column {str(col)!r} has a non-numeric value {str(series.iloc[row])!r} in data row {row + 1}")
    return converted.to_numpy(dtype=np.float64, na_value=np.nan)


def infer_time_unit(raw: np.ndarray) -> tuple[str, str]:
    """(unit, note) from the median time step: a plausible sample rate (1 Hz–100 kHz)."""
    steps = np.diff(raw.astype(np.float64))
    steps = steps[steps > 0]
    if steps.size == 0:
        return "s", "time unit not given; assumed s"
    step = float(np.median(steps))
    rate = {u: 1.0 / (step * f) for u, f in _TIME_FACTORS.items()}
    plausible = [u for u in _TIME_FACTORS if _RATE_RANGE[0] <= rate[u] <= _RATE_RANGE[1]]
    if not plausible:
        raise InputError(
            f"cannot infer the time unit: a median step of {step:g} gives no sample rate between "
            "1 Hz and 100 kHz in s, ms, µs or ns; pass --time-unit"
        )
    integer = bool(np.all(raw == np.round(raw)))
    if "s" in plausible and not integer:
        unit = "s"
    else:
        unit = min(plausible, key=lambda u: abs(np.log10(rate[u] / _TYPICAL_RATE)))
    return unit, (
        f"time unit not given; assumed {_TIME_LABELS[unit]} from the median step {step:g} "
        f"({rate[unit]:.4g} Hz){'' if unit == 's' else ', converted to s'}; pass --time-unit to override"
    )


def _to_seconds(raw: np.ndarray, unit: str) -> np.ndarray:
    """Time [s]; integer stamps (epoch ns, micros()) are split exactly before the float conversion."""
    if raw.dtype.kind in "iu" and unit != "s":
        whole, rest = np.divmod(raw.astype(np.int64), _TICKS[unit])
        return whole.astype(np.float64) + rest.astype(np.float64) / _TICKS[unit]
    return raw.astype(np.float64) * _TIME_FACTORS[unit]


def infer_accel_unit(block: np.ndarray, default: str) -> tuple[str, str]:
    """(unit, note) for acceleration [n, k] without a written unit."""
    finite = block[np.isfinite(block).all(axis=1)]
    if finite.size == 0:
        return default, f"acceleration unit not given; assumed {_ACCEL_LABELS[default]}"
    mean = finite.mean(axis=0)
    peak = float(np.abs(finite).max())
    override = "; pass --accel-unit to override"
    if peak > _MAX_G or float(np.abs(mean).max()) > 2.0:
        return "m/s2", (
            f"acceleration unit not given; assumed m/s² (mean {float(np.abs(mean).max()):.3g}, "
            f"peak {peak:.3g}: too large for g){override}"
        )
    if finite.shape[1] >= 3 and 0.7 <= float(np.linalg.norm(mean)) <= 1.3:
        return "g", f"acceleration unit not given; assumed g (the mean vector has magnitude {np.linalg.norm(mean):.3g}, gravity in g){override}"
    if finite.shape[1] < 3 and np.any((np.abs(mean) >= 0.5) & (np.abs(mean) <= 1.5)):
        return "g", f"acceleration unit not given; assumed g (static mean {mean[np.argmax(np.abs(mean))]:.3g} ≈ ±1, gravity in g){override}"
    return default, (
        f"acceleration unit not given and ambiguous (mean {float(np.abs(mean).max()):.3g}, peak {peak:.3g}); "
        f"assumed {_ACCEL_LABELS[default]}{override}"
    )


def time_axis(table: Table, col: Column, given: str | None,
               format_units: dict[Column, str]) -> tuple[np.ndarray, list[str], str, str]:
    """Time [s] of column ``col``, notes on its unit, the unit and where it came from
    (``given``, ``header``, ``format`` or ``inferred``).

    ``given`` is the user's unit (canonical, or None); ``format_units`` the units the
    recognised layout implies (:attr:`dampfit.io.columns.Layout.units`)."""
    raw = _values(table, col)
    if given is not None:
        unit, source = given, "as given"
    elif (unit := _header_unit(col, TIME_ALIASES) if table.header else None) is not None:
        source = "from the header"
    elif col in format_units:
        unit, source = format_units[col], "format default"
    else:
        unit, note = infer_time_unit(raw[np.isfinite(raw)] if raw.dtype.kind == "f" else raw)
        return _to_seconds(raw, unit), [note], unit, "inferred"
    notes = [f"time converted from {_TIME_LABELS[unit]} to s ({source})"] if unit != "s" else []
    origin = {"as given": "given", "from the header": "header", "format default": "format"}[source]
    return _to_seconds(raw, unit), notes, unit, origin


def accel_block(table: Table, cols: list[Column], given: str | None,
                 format_units: dict[Column, str]) -> tuple[np.ndarray, list[str]]:
    """Acceleration [m/s²] of columns ``cols`` and notes on their units (``given`` and
    ``format_units`` as in :func:`time_axis`)."""
    block = np.column_stack([_values(table, c).astype(np.float64) for c in cols])
    units: list[tuple[str, str]] = []
    for col in cols:
        if given is not None:
            units.append((given, "as given"))
        elif table.header and (unit := _header_unit(col, ACCEL_ALIASES)) is not None:
            units.append((unit, "from the header"))
        elif col in format_units:
            units.append((format_units[col], "format default"))
        else:
            units.append(("", ""))
    notes = []
    unknown = [i for i, (u, _) in enumerate(units) if not u]
    if unknown:
        default = "g" if table.source in ("npy", "npz") else "m/s2"
        unit, note = infer_accel_unit(block[:, unknown], default)
        notes.append(note)
        for i in unknown:
            units[i] = (unit, "inferred")
    for unit, source in dict.fromkeys(units):
        if unit != "m/s2":
            which = [str(c) for c, u in zip(cols, units) if u == (unit, source)]
            scope = f" ({', '.join(which)})" if len(set(units)) > 1 else ""
            notes.append(
                f"acceleration{scope} converted from {_ACCEL_LABELS[unit]} to m/s² "
                f"(× {_ACCEL_FACTORS[unit]:g}, unit {source})"
            )
    factors = np.array([_ACCEL_FACTORS[u] for u, _ in units])
    return block * factors, notes
