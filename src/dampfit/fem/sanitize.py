"""Text that reaches a generated deck or script: one small sanitiser per format.

Values such as the result folder's path, the ``dampfit_version`` of a summary.json (which a
user may have edited) or an output file name are *data*. Written raw into a generated file
they could become code or input cards: a folder whose name holds three double quotes, a
newline and ``import os…`` would close the docstring of the OpenSees script and run Python; a
newline followed by ``*INCLUDE`` in an LS-DYNA or CalculiX comment would start a new keyword
card. Every such value goes through the function of its format:

* :func:`python_comment` — text for a docstring or ``#`` comment of a Python script: one line
  of printable ASCII without quotes or backslashes. The exact value, if the script keeps it,
  is embedded with :func:`python_literal` (``repr``), which is always one valid string literal;
* :func:`lsdyna_comment` — ``$`` comment lines (≤ 80 columns) of an LS-DYNA keyword deck;
  :func:`lsdyna_title` — the data line of ``*TITLE`` (≤ 80 columns, cannot start with ``*``
  or ``$``);
* :func:`calculix_comment` — ``**`` comment lines (≤ 80 columns, CalculiX reads at most 132)
  of a CalculiX deck;
(A value inside a one-line error message goes through :func:`dampfit.errors.shown`.)

The deck sanitisers reduce text to printable ASCII (letters with accents lose the accent,
``Dämpfer`` → ``Dampfer``; the symbols dampfit's own texts use are spelled out, ``ζ`` →
``zeta``, ``·`` → ``*``, ``≤`` → ``<=`` (:data:`SPELLED`); other characters become ``?``), turn
every line break and control character into a blank and shorten text beyond ``limit``
characters with ``...``.
"""

from __future__ import annotations

import textwrap
import unicodedata

#: Longest text kept from one value in a comment [characters].
COMMENT_LIMIT = 500

#: ASCII spellings of the symbols in dampfit's own verdicts and notes (Greek letters of the
#: quantities, operators, dashes), so a deck's comment reads "zeta changes" rather than "? changes".
SPELLED = {
    "ζ": "zeta", "α": "alpha", "β": "beta", "γ": "gamma", "δ": "delta", "η": "eta", "λ": "lambda",
    "Λ": "Lambda", "μ": "mu", "ν": "nu", "ρ": "rho", "σ": "sigma", "τ": "tau", "φ": "phi",
    "ψ": "psi", "ω": "omega", "Ω": "Omega", "θ": "theta", "χ": "chi", "Δ": "Delta",
    "·": "*", "×": "x", "±": "+/-", "≤": "<=", "≥": ">=", "≈": "~", "≠": "!=", "−": "-",
    "–": "-", "—": "-", "→": "->", "²": "^2", "³": "^3", "√": "sqrt", "∞": "inf", "°": " deg",
    "µ": "u", "…": "...", "‘": "'", "’": "'", "“": "'", "”": "'",
}


def _shorten(text: str, limit: int | None) -> str:
    if limit is not None and len(text) > limit:
        return text[:max(0, limit - 3)] + "..."
    return text


def ascii_line(text: object, limit: int | None = COMMENT_LIMIT) -> str:
    """``text`` as one line of printable ASCII (0x20–0x7E), blanks collapsed, at most ``limit``
    characters. Accents are dropped (NFKD), other non-ASCII characters become ``?``, line
    breaks, tabs and every other control or format character a blank; the symbols of
    :data:`SPELLED` are spelled out first."""
    out = []
    for ch in unicodedata.normalize("NFKD", "".join(SPELLED.get(c, c) for c in str(text))):
        if " " <= ch <= "~":
            out.append(ch)
        elif unicodedata.category(ch) == "Mn":  # combining accent of a decomposed letter
            continue
        elif ch.isspace() or unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp"):
            out.append(" ")
        else:
            out.append("?")
    return _shorten(" ".join("".join(out).split()), limit)


def python_comment(text: object, limit: int | None = COMMENT_LIMIT) -> str:
    """Text safe inside a ``\"\"\"`` docstring or after ``#`` in Python: :func:`ascii_line`
    with ``"`` → ``'`` and ``\\`` → ``/`` (no quote can close the string, no escape starts)."""
    return ascii_line(text, limit).replace("\\", "/").replace('"', "'")


def python_literal(text: object) -> str:
    """``text`` as a Python string literal (``repr``): one line, every quote, backslash and
    non-printable character escaped, so it evaluates to exactly ``str(text)``."""
    return repr(str(text))


def _comment_lines(prefix: str, text: object, width: int, limit: int | None) -> list[str]:
    line = ascii_line(text, limit)
    body = textwrap.wrap(line, width - len(prefix), break_long_words=True,
                         break_on_hyphens=False)
    return [prefix + part for part in body] or [prefix.rstrip()]


def lsdyna_comment(text: object, limit: int | None = COMMENT_LIMIT) -> list[str]:
    """``$ …`` comment lines of at most 80 columns holding ``text`` (see :func:`ascii_line`)."""
    return _comment_lines("$ ", text, 80, limit)


def lsdyna_title(text: object) -> str:
    """The ``*TITLE`` data line: :func:`ascii_line` of at most 80 columns that does not start
    with ``*`` (a keyword) or ``$`` (a comment); ``untitled`` if nothing is left."""
    return ascii_line(text, None).lstrip("*$ ")[:80].rstrip() or "untitled"


def calculix_comment(text: object, limit: int | None = COMMENT_LIMIT) -> list[str]:
    """``** …`` comment lines of at most 80 columns holding ``text`` (see :func:`ascii_line`)."""
    return _comment_lines("** ", text, 80, limit)

