"""The rules of the analysis and reading options, once: the command line's argparse types
(:mod:`dampfit.cli.options`) and the Python face's checks (:func:`check_analysis`, used by
:func:`dampfit.batch.runner.analyze_many`) refuse the same values with the same reasons.

A rule (:data:`RULES`) is the kind of number (``int`` or ``real``), what it must be (the
message's words) and the test; :func:`convert` applies one to a value or a command-line text
(``ValueError`` with "not an integer: 'x'", "not a number: 'x'" or "must be WHAT, got V");
:func:`check_relations` checks the options against each other (window and band order,
``mode_of_mass`` ≤ ``max_modes``), with the messages of ``dampfit analyze``.
"""

from __future__ import annotations

import math
import operator
from typing import Any, Callable, NamedTuple

from dampfit.errors import InputError

__all__ = ["ANALYSIS_MAX_MODES", "DEFAULT_MAX_MODES", "MAX_MODES_LIMIT", "MAX_STEPS", "MODELS",
           "RULES", "Rule", "SEED_LIMIT", "check_analysis", "check_relations", "convert"]

#: Largest seed + 1 (numpy and the sampler take 32-bit seeds).
SEED_LIMIT = 2**32
#: Largest max_steps: the stored chain grows with it (10⁶ steps × 64 walkers ≈ 2 GB).
MAX_STEPS = 10**6
#: Default and largest max_modes: :data:`dampfit.inference.modes.DEFAULT_MAX_MODES` and
#: :data:`~dampfit.inference.modes.MAX_MODES_LIMIT` (not imported: that module imports JAX,
#: and the parser is built before the scientific stack; a test checks they agree).
DEFAULT_MAX_MODES, MAX_MODES_LIMIT = 4, 8
#: max_modes when not given, for one recording (paper/modes.md).
ANALYSIS_MAX_MODES = DEFAULT_MAX_MODES
#: The damping laws ``model`` may name.
MODELS = ("auto", "viscous", "coulomb", "quadratic", "power")


class Rule(NamedTuple):
    """One option's values: ``kind`` "int" or "real" (finite), ``what`` it must be, ``ok``."""

    kind: str
    what: str
    ok: Callable[[float], bool] | None = None


RULES: dict[str, Rule] = {
    "seed": Rule("int", f"an integer from 0 to {SEED_LIMIT - 1}", lambda v: 0 <= v < SEED_LIMIT),
    "max_steps": Rule("int", f"an integer from 1 to {MAX_STEPS}", lambda v: 1 <= v <= MAX_STEPS),
    "max_modes": Rule("int", f"an integer from 1 to {MAX_MODES_LIMIT}",
                      lambda v: 1 <= v <= MAX_MODES_LIMIT),
    "mode_of_mass": Rule("int", f"an integer from 1 to {MAX_MODES_LIMIT}",
                         lambda v: 1 <= v <= MAX_MODES_LIMIT),
    "row": Rule("int", "an integer from 0 to 1023", lambda v: 0 <= v <= 1023),
    "rate": Rule("real", "a sample rate in Hz, above 0 and at most 1e7", lambda v: 0 < v <= 1e7),
    "window": Rule("real", "a finite time [s]"),
    "band": Rule("real", "a positive frequency [Hz]", lambda v: v > 0),
    "amplitude": Rule("real", "a positive displacement amplitude in metres", lambda v: v > 0),
}


def convert(name: str, value: Any) -> int | float:
    """``value`` (a number, or the text given on the command line) under the rule of
    option ``name``; ``ValueError`` with the reason otherwise."""
    rule = RULES[name]
    text = value if isinstance(value, str) else repr(value)
    if rule.kind == "int":
        try:
            v = int(value, 10) if isinstance(value, str) else operator.index(value)
            if isinstance(value, bool):
                raise TypeError
        except (TypeError, ValueError):
            raise ValueError(f"not an integer: {text!r}") from None
        if not rule.ok(v):
            raise ValueError(f"must be {rule.what}, got {v}")
        return v
    try:
        if isinstance(value, bool):
            raise TypeError
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or (rule.ok is not None and not rule.ok(v)):
        raise ValueError(f"must be {rule.what}, got {value if isinstance(value, str) else f'{v:g}'}")
    return v


def check_relations(window, band, max_modes: int | None, mode_of_mass: int | None) -> None:
    """The options against each other (each already under its rule): START < END, LO < HI,
    ``mode_of_mass`` at most ``max_modes`` (default :data:`ANALYSIS_MAX_MODES`)."""
    if window is not None and not window[0] < window[1]:
        raise InputError(f"argument --window: END must come after its start, got "
                         f"{window[0]:g} {window[1]:g}")
    if mode_of_mass is not None and mode_of_mass > (max_modes or ANALYSIS_MAX_MODES):
        raise InputError(f"argument --mode-of-mass: mode {mode_of_mass} is beyond "
                         f"--max-modes {max_modes or ANALYSIS_MAX_MODES}")
    if band is not None and not band[0] < band[1]:
        raise InputError(f"argument --band: the pass band needs LO < HI, got "
                         f"{band[0]:g} {band[1]:g}")


def _pair(name: str, value) -> tuple[float, float]:
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != 2:
        raise InputError(f"argument --{name}: expected two numbers, got {value!r}")
    return tuple(_one(name, v) for v in items)


def _one(name: str, value):
    try:
        return convert(name, value)
    except ValueError as exc:
        raise InputError(f"argument --{name.replace('_', '-')}: {exc}") from None


def check_analysis(options: dict[str, Any]) -> dict[str, Any]:
    """The analysis options of :func:`dampfit.pipeline.analyze` given from Python (axis,
    window, band, seed, max_steps, model, amplitude, max_modes, mode_of_mass), checked as
    ``dampfit analyze`` checks them on the command line (the rules above, then
    :func:`check_relations`); returned with tuples for window and band. One-line
    :class:`InputError` naming the option as the command line does."""
    out = dict(options)
    for name in ("seed", "max_steps", "max_modes", "mode_of_mass", "amplitude"):
        if out.get(name) is not None:
            out[name] = _one(name, out[name])
    for name in ("window", "band"):
        if out.get(name) is not None:
            out[name] = _pair(name, out[name])
    if "model" in out and out["model"] not in MODELS:
        raise InputError(f"argument --model: invalid choice: {out['model']!r} (choose from "
                         f"{', '.join(MODELS)})")
    if "axis" in out and not (isinstance(out["axis"], str) and out["axis"].strip()):
        raise InputError(f"argument --axis: must be x, y, z, a column name or auto, got "
                         f"{out['axis']!r}")
    check_relations(out.get("window"), out.get("band"), out.get("max_modes"),
                    out.get("mode_of_mass"))
    return out
