"""The simulator fields a study's [grid] and [fixed] tables may set, and their values.

Allowed: ``f_n`` [Hz] and ``zeta`` [1] (both required; the simulator's k and c follow from them
and the mass, :func:`dampfit.simulate.from_modal`) and the
:class:`~dampfit.simulate.SimulationConfig` options except ``mass`` (set in ``[study]``),
``k``, ``c`` and ``seed`` (set per run). Values are normalised to their kind, so 2 and 2.0
give the same scenario id.

``modes`` (kind "modes") lists the structure's extra modes besides the mass's (f_n, zeta) one,
each ``[f_n [Hz], zeta [1], amplitude ratio [1], phase [rad]]`` (the simulator's ``modes``:
the ratio is to the mass's mode's acceleration envelope at release); at most
:data:`MAX_EXTRA_MODES`, normalised to floats and sorted, so their order does not change the
scenario id. In [grid] it is a list of such lists, e.g. ``modes = [[], [[8.91, 0.012, 0.25, 0.5]]]``.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit.errors import InputError

#: Simulator fields a study may set, with their kind: float, int, bool, str, bias or modes.
FIELDS: dict[str, str] = {
    "f_n": "float", "zeta": "float", "u0": "float", "duration": "float", "sample_rate": "float",
    "jitter": "float", "timestamp_jitter": "float", "gaps": "int", "noise_density": "float",
    "bias": "bias", "drift": "float", "quantization": "float", "tilt_deg": "float",
    "azimuth_deg": "float", "main_axis": "str", "gravity": "bool", "handheld": "float", "catch": "bool",
    "modes": "modes",
}
#: Most extra modes a scenario may have (with the mass's mode: the modes analysis' limit of 8).
MAX_EXTRA_MODES = 7
_SET_ELSEWHERE = {"mass": "set it as [study] mass", "k": "give f_n and the mass instead",
                  "c": "give zeta instead", "seed": "each run's seed is derived from [study] seed"}


def check_field(key: str, table: str) -> None:
    if key in _SET_ELSEWHERE:
        raise InputError(f"[{table}] {key} cannot be set here: {_SET_ELSEWHERE[key]}")
    if key not in FIELDS:
        raise InputError(f"unknown field [{table}] {key}; known: {', '.join(sorted(FIELDS))}")


def field_value(key: str, value: Any, table: str) -> Any:
    """A field value normalised to its kind (so 2 and 2.0 give the same scenario id)."""
    kind = FIELDS[key]
    where = f"[{table}] {key}"
    if kind == "bool":
        if not isinstance(value, bool):
            raise InputError(f"{where} must be true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise InputError(f"{where} must be a string, got {value!r}")
        return value
    if kind == "modes":
        return _modes(where, value)
    if kind == "bias" and isinstance(value, list):
        return [number(where, v) for v in value]
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{where} must be an integer, got {value!r}")
        return value
    return number(where, value)


def number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def _modes(where: str, value: Any) -> list[list[float]]:
    """Extra modes as a sorted list of [f_n, zeta, ratio, phase] floats (ranges are the
    simulator's to check)."""
    shape = "[f_n Hz, zeta, amplitude ratio, phase rad]"
    if not isinstance(value, list):
        raise InputError(f"{where} must be a list of modes, each {shape}, got {value!r}")
    if len(value) > MAX_EXTRA_MODES:
        raise InputError(f"{where} lists {len(value)} modes; at most {MAX_EXTRA_MODES} extra modes")
    out = []
    for i, mode in enumerate(value, start=1):
        if not isinstance(mode, list) or len(mode) != 4:
            raise InputError(f"{where}: mode {i} must be {shape}, got {mode!r}")
        out.append([number(f"{where}: mode {i}", v) for v in mode])
    return sorted(out)
