"""The simulator fields a study's [grid] and [fixed] tables may set, and their values.

Allowed: ``f_n`` [Hz] and ``zeta`` [1] (both required; the simulator's k and c follow from them
and the mass, :func:`dampfit.simulate.from_modal`) and the
:class:`~dampfit.simulate.SimulationConfig` options except ``mass`` (set in ``[study]``),
``k``, ``c`` and ``seed`` (set per run). Values are normalised to their kind, so 2 and 2.0
give the same scenario id.
"""

from __future__ import annotations

import math
from typing import Any

from dampfit.errors import InputError

__all__ = ["FIELDS", "check_field", "field_value", "number"]

#: Simulator fields a study may set, with their kind: float, int, bool, str or bias.
FIELDS: dict[str, str] = {
    "f_n": "float", "zeta": "float", "u0": "float", "duration": "float", "sample_rate": "float",
    "jitter": "float", "timestamp_jitter": "float", "gaps": "int", "noise_density": "float",
    "bias": "bias", "drift": "float", "quantization": "float", "tilt_deg": "float",
    "azimuth_deg": "float", "main_axis": "str", "gravity": "bool", "handheld": "float", "catch": "bool",
}
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
