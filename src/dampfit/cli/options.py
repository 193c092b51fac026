"""Option converters of the command line: every number is checked by the parser, one line each.

A converter raises :class:`argparse.ArgumentTypeError` with the reason (``must be WHAT, got
TEXT``); the parser (:class:`Parser`) turns it into one :class:`~dampfit.errors.InputError`
line, exit code 2. The limits are the library's (:data:`dampfit.simulate.MAX_MASS`,
:data:`dampfit.simulate.MAX_SIM_SAMPLES`), so the CLI and the library refuse the same values.
"""

from __future__ import annotations

import argparse
import math

from dampfit.errors import InputError
from dampfit.simulate import MAX_MASS as MAX_MASS
from dampfit.simulate import MAX_SIM_SAMPLES as MAX_SIM_SAMPLES

__all__ = ["MAX_MASS", "MAX_SIM_SAMPLES", "MAX_STEPS", "SEED_LIMIT", "Parser", "float_arg",
           "seed_arg"]

#: Largest seed + 1 (numpy and the sampler take 32-bit seeds).
SEED_LIMIT = 2**32
#: Largest --max-steps: the stored chain grows with it (10⁶ steps × 64 walkers ≈ 2 GB).
MAX_STEPS = 10**6


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(f"{message} (see '{self.prog} --help')")


def _real(what: str = "a finite number", ok=None):
    """argparse type: a finite float for which ``ok(value)`` holds, else 'must be WHAT'."""

    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(v) or (ok is not None and not ok(v)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return v

    return conv


def _integer(lo: int, hi: int, what: str | None = None):
    """argparse type: an integer in [lo, hi]."""

    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(
                f"must be {what or f'an integer from {lo} to {hi}'}, got {v}")
        return v

    return conv


#: argparse type for a float option with a one-line error: a finite number (NaN and ±inf are
#: refused).
float_arg = _real()
#: argparse type of every ``--seed``: an integer in [0, 2³²).
seed_arg = _integer(0, SEED_LIMIT - 1, f"an integer from 0 to {SEED_LIMIT - 1}")

_positive = _real("a positive finite number", lambda v: v > 0)
_non_negative = _real("a finite number ≥ 0", lambda v: v >= 0)
_mass = _real("a positive mass in kg (at most 1e6)", lambda v: 0 < v <= MAX_MASS)
