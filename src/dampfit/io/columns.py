"""Which column holds what: column roles, recognised layouts and the user's selection.

:func:`identify` recognises a :class:`Layout` from a table's header: the phyphox export
(``Time (s)``, ``Acceleration x (m/s^2)``…, or the renamed ``time``,
``linear_acceleration_x``…; units s and m/s²), Sensor Logger (``seconds_elapsed`` [s], ``x``,
``y``, ``z`` [m/s²]; its ``time`` column is epoch ns and ignored) or any other header, judged
per column name (:func:`role`: time-like, acceleration-like or a magnitude to drop). A table
without a header is read by position: column 0 time, the rest acceleration. Gravity
(``gravity_removed``) is taken from the header where it tells (``Linear Acceleration``, the
Sensor Logger sensor). :func:`select` applies the user's ``time_column``/``accel_columns``
(by name or 0-based position) on top. Units are handled in :mod:`dampfit.io.units`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dampfit.errors import InputError
from dampfit.io.text import Column, Table
from dampfit.io.units import name_words, split_name

#: phyphox headers: original with units, and the renamed form without.
_PHYPHOX_TIME = re.compile(r"^time \(s\)$", re.I)
_PHYPHOX_ACCEL = re.compile(r"^(linear )?acceleration ([xyz]) \((?:m/s\^2|m/s²)\)$", re.I)
_PHYPHOX_ABS = re.compile(r"^absolute acceleration \((?:m/s\^2|m/s²)\)$", re.I)
_RENAMED_ACCEL = re.compile(r"^(linear_)?acceleration_([xyz])$", re.I)
#: Words and prefixes of time, magnitude and acceleration column names.
_TIME_WORDS = {"time", "timestamp", "timestamps", "t", "seconds", "sec", "secs", "elapsed",
               "millis", "micros", "nanos", "ms", "us", "ns", "zeit"}
_MAGNITUDE_WORDS = {"abs", "absolute", "norm", "magnitude", "mag", "resultant", "total"}
_ACCEL_NAMES = {"a", "ax", "ay", "az", "x", "y", "z"}
_ACCEL_PREFIXES = ("acc", "linearacc", "linacc", "useracc")
#: Names and units of position and velocity columns (lab exports, motion detectors): never
#: acceleration, whatever else the name says.
_POSITION_WORDS = {"position", "displacement", "distance", "pos", "disp", "dist", "height",
                   "elongation", "extension", "deflection"}
_VELOCITY_WORDS = {"velocity", "speed", "vel"}
_LENGTH_UNITS = {"m", "cm", "mm", "µm", "um", "km", "in", "ft"}
_VELOCITY_UNITS = {f"{u}/s" for u in _LENGTH_UNITS} | {f"{u} s^-1" for u in _LENGTH_UNITS}


@dataclass
class Layout:
    """Which columns hold what, as recognised from the header (before user options)."""

    kind: str  # "phyphox", "sensor-logger" or "generic"
    time_col: Column | None
    accel_cols: list[Column]
    units: dict[Column, str] = field(default_factory=dict)  # units implied by the format
    gravity_removed: bool | None = None
    notes: list[str] = field(default_factory=list)


def role(name: Column) -> str | None:
    """``"time"``, ``"accel"``, ``"magnitude"``, ``"position"``, ``"velocity"`` or None,
    judged from a column name and the unit written in it (``Position (m)``, ``v (m/s)``)."""
    base, unit = split_name(name)
    words = name_words(base)
    joined = "".join(words)
    if not words:
        return None
    if _TIME_WORDS.intersection(words) or "time" in joined:
        return "time"
    unit = (unit or "").strip().lower().replace("μ", "µ")
    if unit in _LENGTH_UNITS or _POSITION_WORDS.intersection(words):
        return "position"
    if unit in _VELOCITY_UNITS or _VELOCITY_WORDS.intersection(words):
        return "velocity"
    is_accel = joined in _ACCEL_NAMES or joined.startswith(_ACCEL_PREFIXES) or "acceleration" in joined
    if not is_accel:
        return None
    return "magnitude" if _MAGNITUDE_WORDS.intersection(words) else "accel"


def _axis_from_name(name: Column) -> str | None:
    """``x``/``y``/``z`` if the column name says so (``Acceleration x``, ``ax``, ``accY``…)."""
    words = name_words(split_name(name)[0])
    if words and words[-1] in ("x", "y", "z"):
        return words[-1]
    if len(words) >= 2 and words[0] in ("x", "y", "z") and words[1:] in (["axis", "acceleration"],
                                                                          ["acceleration"]):
        return words[0]  # Vernier's "X-axis acceleration"
    match = re.fullmatch(r"(?:a|acc|accel|acceleration|linearacceleration)([xyz])", "".join(words))
    return match.group(1) if match else None


def identify(table: Table) -> Layout:
    """Recognise the layout from the header (or positions when there is none)."""
    if table.layout is not None:  # fixed by the reader (a DAQ file's metadata)
        return table.layout
    cols = list(table.frame.columns)
    if not table.header:
        n_acc = len(cols) - 1
        note = "no header: column 0 read as time" + (f", columns 1–{n_acc} as acceleration" if n_acc > 1 else ", column 1 as acceleration" if n_acc == 1 else "")
        return Layout("generic", cols[0] if cols else None, cols[1:], notes=[note])
    return _phyphox_layout(cols) or _sensor_logger_layout(cols, table.name) or _generic_layout(cols, table)


def _phyphox_layout(cols: list) -> Layout | None:
    """phyphox header, original (``Time (s)``, ``Acceleration x (m/s^2)``) or renamed (``time``, ``linear_acceleration_x``)."""
    notes: list[str] = []
    units: dict[Column, str] = {}
    time = [c for c in cols if _PHYPHOX_TIME.match(str(c))]
    accel = {c: m for c in cols if (m := _PHYPHOX_ACCEL.match(str(c)))}
    magnitude = [c for c in cols if _PHYPHOX_ABS.match(str(c))]
    if not (time and accel):
        time = [c for c in cols if str(c).lower() == "time"]
        accel = {c: m for c in cols if (m := _RENAMED_ACCEL.match(str(c)))}
        magnitude = [c for c in cols if str(c).lower() == "absolute_acceleration"]
        if not (time and accel):
            return None
        units = {time[0]: "s", **dict.fromkeys(accel, "m/s2")}
        notes.append("renamed phyphox header without units; read as s and m/s² like phyphox exports")
    linear = [bool(m.group(1)) for m in accel.values()]
    gravity = True if all(linear) else False if not any(linear) else None
    if gravity is False:
        notes.append(
            "gravity_removed=False presumed from the header 'Acceleration' (with g); "
            "phyphox's Spring experiment labels linear acceleration the same way"
        )
    if magnitude:
        notes.append(f"dropped column {magnitude[0]!r} (magnitude, not an axis)")
    return Layout("phyphox", time[0], list(accel), units, gravity, notes)


def _sensor_logger_layout(cols: list, name: str) -> Layout | None:
    """Sensor Logger CSV: ``time`` [ns], ``seconds_elapsed`` [s], ``z``, ``y``, ``x`` [m/s²]."""
    lower = {str(c).strip().lower(): c for c in cols}
    if "seconds_elapsed" not in lower or not {"x", "y", "z"} <= lower.keys():
        return None
    time = lower["seconds_elapsed"]
    accel = [lower[a] for a in ("x", "y", "z")]
    notes = ["time from 'seconds_elapsed' (the epoch 'time' column is ignored)"]
    sensor = Path(name).stem.lower().replace(" ", "")
    if sensor.startswith("totalacceleration") or sensor.startswith("accelerometeruncalibrated"):
        gravity = False
    elif sensor.startswith("accelerometer"):
        gravity = True
        notes.append("Sensor Logger's Accelerometer is without gravity (gravity_removed=True)")
    elif sensor.startswith("gravity"):
        gravity = False
        notes.append("this is Sensor Logger's gravity estimate, not the motion; use Accelerometer.csv")
    else:
        gravity = None
        notes.append(f"Sensor Logger sensor unknown from the name {name!r}; gravity_removed unknown")
    return Layout("sensor-logger", time, accel, {time: "s", **dict.fromkeys(accel, "m/s2")}, gravity, notes)


def _generic_layout(cols: list, table: Table) -> Layout:
    """Any header: time- and acceleration-like names; npz falls back to positions."""
    roles = {c: role(c) for c in cols}
    times = [c for c in cols if roles[c] == "time"]
    time = next((c for c in times if "elapsed" in str(c).lower()), times[0] if times else None)
    accel = [c for c in cols if roles[c] == "accel"]
    notes = []
    if (time is None or not accel) and table.positional_fallback and len(cols) >= 2:
        time, accel = cols[0], cols[1:]
        notes.append(f"array names not recognised; {time!r} read as time, the rest as acceleration")
    magnitude = [c for c in cols if roles[c] == "magnitude" and c not in accel]
    if magnitude:
        notes.append(f"dropped {', '.join(repr(c) for c in magnitude)} (magnitude, not an axis)")
    ignored = [c for c in cols if c != time and c not in accel and c not in magnitude]
    if ignored and time is not None and accel:
        notes.append(f"ignored columns {', '.join(repr(str(c)) for c in ignored)}")
    gravity = True if accel and all("linear" in str(c).lower() for c in accel) else None
    return Layout("generic", time, accel, gravity_removed=gravity, notes=notes)


def looks_like_acceleration(table: Table) -> bool:
    """True if a table has a time and acceleration columns named as such (not just x/y/z)."""
    layout = identify(table)
    if layout.time_col is None or not layout.accel_cols:
        return False
    if layout.kind == "phyphox":
        return True
    return "acc" in table.name.lower() or any("acc" in str(c).lower() for c in layout.accel_cols)


def _column_listing(table: Table) -> str:
    cols = list(table.frame.columns)
    if not table.header:
        return f"0–{len(cols) - 1} (by position; the file has no header)"
    return ", ".join(repr(str(c)) for c in cols)


def _lookup(table: Table, key: Column) -> Column:
    """A column by name (exact, then case-insensitive) or 0-based position."""
    cols = list(table.frame.columns)
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if 0 <= key < len(cols):
            return cols[int(key)]
        raise InputError(f"column index {key} is out of range; available columns: {_column_listing(table)}")
    wanted = str(key).strip()
    for match in (lambda c: str(c).strip() == wanted, lambda c: str(c).strip().lower() == wanted.lower()):
        found = [c for c in cols if match(c)]
        if found:
            return found[0]
    if wanted.isdigit():
        return _lookup(table, int(wanted))
    raise InputError(f"column {str(key)!r} not found; available columns: {_column_listing(table)}")


def lookup(table: Table, key: Column) -> Column:
    """A column of ``table`` by name (exact, then case-insensitive) or 0-based position; an
    unknown one is an :class:`InputError` listing the columns."""
    return _lookup(table, key)


def select(table: Table, layout: Layout, time_column: Column | None,
            accel_columns: tuple[Column, ...] | None) -> tuple[Column, list[Column]]:
    """Time and acceleration columns: the user's ``time_column``/``accel_columns`` (names or
    0-based positions, None: not given), else the recognised layout."""
    time = _lookup(table, time_column) if time_column is not None else layout.time_col
    if accel_columns is not None:
        accel = [_lookup(table, c) for c in accel_columns]
    elif time_column is not None and layout.kind == "generic" and not table.header:
        accel = [c for c in table.frame.columns if c != time]
    else:
        accel = [c for c in layout.accel_cols if c != time]
    if len(table.frame.columns) < 2:
        raise InputError("has only one column; need a time column and at least one acceleration column")
    if not accel and table.header:
        _refuse_motion_only(table)
    if time is None or not accel:
        missing = " or ".join(w for w, bad in (("time", time is None), ("acceleration", not accel)) if bad)
        raise InputError(
            f"no {missing} column recognised among columns {_column_listing(table)}; "
            "name them with --time-column/--accel-columns"
            + (" (or give the sample rate with --rate HZ)" if time is None else "")
        )
    if time in accel:
        raise InputError(f"column {str(time)!r} cannot be both time and acceleration")
    if accel_columns is not None and table.header:
        for c in accel:
            if (kind := role(c)) in ("position", "velocity"):
                raise InputError(f"column {str(c)!r} holds {kind}, not acceleration; dampfit "
                                 "analyses acceleration: name an acceleration column")
    return time, accel


def _refuse_motion_only(table: Table) -> None:
    """A table with position or velocity columns but no acceleration: say so (a motion
    detector's or video-tracking export), without suggesting to read the position as one."""
    motion = {c: role(c) for c in table.frame.columns}
    found = [c for c, r in motion.items() if r in ("position", "velocity")]
    if not found:
        return
    kinds = "/".join(dict.fromkeys("position/displacement" if motion[c] == "position"
                                   else "velocity" for c in found))
    names = ", ".join(repr(str(c)) for c in found[:4])
    raise InputError(f"this file has {kinds} ({names}) but no acceleration column; dampfit "
                     "analyses acceleration: record or export the acceleration (an accelerometer, "
                     "or the software's acceleration column)")


def axis_names(table: Table, accel: list[Column]) -> list[str]:
    """``x``/``y``/``z`` where the columns say so, else the column names (``a`` for one unnamed)."""
    if not table.header:
        return ["a"] if len(accel) == 1 else ["x", "y", "z"] if len(accel) == 3 else [f"a{i + 1}" for i in range(len(accel))]
    names = [_axis_from_name(c) or str(c).strip() for c in accel]
    if len(set(names)) < len(names):
        names = [str(c).strip() for c in accel]
    return names
