"""Messages printed after a command succeeds (a restored result, an unused cache).

A failing command prints its one error line only (the one-line contract), so a side issue
never adds a second line to it: such messages wait here until the command has succeeded.
"""

from __future__ import annotations

import sys
from typing import TextIO

_LINES: list[str] = []


def defer(line: str) -> None:
    """Print ``line`` on stderr once the command has succeeded."""
    _LINES.append(line)


def pending() -> list[str]:
    """The lines waiting to be printed (a copy)."""
    return list(_LINES)


def clear() -> None:
    """Forget the deferred lines (a new command starts)."""
    _LINES.clear()


def flush(stream: TextIO | None = None) -> None:
    """Print the deferred lines (the command succeeded) and forget them."""
    for line in _LINES:
        print(line, file=stream or sys.stderr)
    _LINES.clear()
