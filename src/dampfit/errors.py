"""Exceptions raised at dampfit's user-facing boundary.

The numeric core reports numerical failure as data (``converged=False`` plus a
reason); only input problems a user can fix are raised, as :class:`InputError`.
The CLI turns an :class:`InputError` into one line on stderr and exit code 2.
"""

from __future__ import annotations

__all__ = ["DampfitError", "InputError", "shown"]


class DampfitError(Exception):
    """Base class of every exception dampfit raises on purpose."""


class InputError(DampfitError, ValueError):
    """A recording, option or file the user gave cannot be used.

    The message is one line, says what is wrong and, where there is one, the remedy.
    """


def shown(text: object, limit: int = 200) -> str:
    """``text`` for a one-line message: unchanged if printable, else with ``repr``-style
    escapes (``\\n``, ``\\x1b``…); shortened beyond ``limit`` characters (``...``)."""
    text = str(text)
    if not text.isprintable():
        text = repr(text)[1:-1]
    if limit is not None and len(text) > limit:
        return text[:max(0, limit - 3)] + "..."
    return text
