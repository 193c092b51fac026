"""Fixed-width LS-DYNA keyword cards: number formatting, card lines and a reader.

LS-DYNA's standard ("short") input format reads each data card in fixed columns: most cards
have 8 fields of 10 characters (80 columns); *NODE uses I8 + 3×E16 + 2×I8, the *ELEMENT
cards 8-character integers and 16-character reals, and the points of *DEFINE_CURVE 2×E20.
Lines starting with ``$`` are comments (``$#`` for field-name headers, as LS-PrePost
writes them). A real must fit its field: :func:`format_real` picks, among positional
(``619.0``, ``0.00021``) and scientific forms with a compact exponent (``2.12345E-4``), the
one closest to the value that fits the width, so a 10-character field keeps 6–9 significant
digits (``repr`` when it fits, which is exact).
"""

from __future__ import annotations

import math
from collections.abc import Sequence


def _compact_exponent(text: str) -> str:
    """``1.25E-05`` → ``1.25E-5``, ``2E+02`` → ``2.E2`` (valid Fortran reals, with a point)."""
    mant, exp = text.split("E")
    if "." not in mant:
        mant += "."
    return f"{mant}E{int(exp)}"


def _candidates(x: float) -> list[str]:
    r = repr(x)
    if "e" in r:
        mant, exp = r.split("e")
        r = _compact_exponent(f"{mant}E{exp}")
    out = [r]
    for d in range(17):
        pos = f"{x:.{d}f}"
        out.append(pos if "." in pos else pos + ".")
        out.append(_compact_exponent(f"{x:.{d}E}"))
    return out


def format_real(x: float, width: int = 10) -> str:
    """``x`` as a real that fits ``width`` columns (right-justified) with the best precision.

    Always contains a decimal point or an exponent, so a reader never takes it for an
    integer. Raises ``ValueError`` for non-finite values or if nothing fits.
    """
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"cannot write non-finite value {x!r} into a keyword card")
    if x == 0.0:
        return "0.0".rjust(width)
    best, best_err = None, math.inf
    for text in _candidates(x):
        if len(text) > width:
            continue
        err = abs(float(text) - x)
        if err < best_err:  # ties keep the earlier candidate: repr first
            best, best_err = text, err
    if best is None:
        raise ValueError(f"{x!r} does not fit in {width} characters")
    return best.rjust(width)


def format_int(n: int, width: int = 10) -> str:
    """Integer ``n`` right-justified in ``width`` columns."""
    text = str(int(n))
    if len(text) > width:
        raise ValueError(f"{n} does not fit in {width} characters")
    return text.rjust(width)


def card(values: Sequence[object], widths: Sequence[int] | int = 10) -> str:
    """One card line: ints with :func:`format_int`, floats with :func:`format_real`, None blank."""
    if isinstance(widths, int):
        widths = [widths] * len(values)
    parts = []
    for v, w in zip(values, widths, strict=True):
        if v is None:
            parts.append(" " * w)
        elif isinstance(v, bool):
            raise TypeError("booleans are not keyword values")
        elif isinstance(v, int):
            parts.append(format_int(v, w))
        elif isinstance(v, float):
            parts.append(format_real(v, w))
        else:
            text = str(v)
            if len(text) > w:
                raise ValueError(f"{text!r} does not fit in {w} characters")
            parts.append(text.rjust(w))
    return "".join(parts).rstrip()


def header(names: Sequence[str], widths: Sequence[int] | int = 10) -> str:
    """``$#`` comment line naming the fields of the card below, each right-aligned in its field."""
    if isinstance(widths, int):
        widths = [widths] * len(names)
    line = "".join(n.rjust(w) for n, w in zip(names, widths, strict=True))
    if len(names[0]) > widths[0] - 2:
        raise ValueError(f"field name {names[0]!r} leaves no room for '$#'")
    return "$#" + line[2:]


def parse_deck(text: str) -> list[tuple[str, list[str]]]:
    """Keyword blocks of a deck: ``[(keyword, data lines), …]`` in order, comments dropped.

    The keyword is upper case without the ``*`` and without anything after the first blank
    or comma; data lines keep their columns (not stripped on the left).
    """
    blocks: list[tuple[str, list[str]]] = []
    for raw in text.splitlines():
        line = raw.rstrip("\r\n")
        if line.startswith("$"):
            continue
        if line.startswith("*"):
            name = line[1:].replace(",", " ").split()
            blocks.append((name[0].upper() if name else "", []))
        elif blocks:
            blocks[-1][1].append(line)
    return blocks


def split_fields(line: str, widths: Sequence[int] | int = 10, count: int | None = None) -> list[str]:
    """Fields of a fixed-width ``line`` (stripped); ``count`` fields of equal ``widths`` if int."""
    if isinstance(widths, int):
        widths = [widths] * (count if count is not None else max(1, math.ceil(len(line) / widths)))
    out, pos = [], 0
    for w in widths:
        out.append(line[pos:pos + w].strip())
        pos += w
    return out


def _read(field_text: str, default, convert):
    """``convert`` of the stripped field, or ``default`` for a blank one (ValueError if None)."""
    text = field_text.strip()
    if not text:
        if default is None:
            raise ValueError("blank field without a default")
        return default
    return convert(text)


def read_real(field_text: str, default: float | None = None) -> float:
    """A real field as LS-DYNA reads it (blank → ``default``; Fortran ``D`` exponent accepted)."""
    return _read(field_text, default, lambda text: float(text.upper().replace("D", "E")))


def read_int(field_text: str, default: int | None = None) -> int:
    """An integer field (blank → ``default``)."""
    return _read(field_text, default, int)
