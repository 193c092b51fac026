"""Progress bars: the one place dampfit makes them (tqdm).

Every long loop — emcee blocks of the viscous posterior and of each damping law, the runs of
a study — shows the same kind of bar on stderr: off unless asked for (the CLI asks when
stderr is a terminal and ``--quiet`` is not given), cleared when done, width following the
terminal.
"""

from __future__ import annotations

from typing import Any, TextIO

__all__ = ["progress_bar"]


def progress_bar(total: int, desc: str, *, unit: str = "step", enabled: bool = True,
                 initial: int = 0, file: TextIO | None = None, leave: bool = False) -> Any:
    """A tqdm bar of ``total`` ``unit``s titled ``desc`` (a context manager with ``update``);
    ``enabled=False`` gives a bar that draws nothing."""
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, desc=desc, unit=unit, disable=not enabled,
                leave=leave, dynamic_ncols=True, file=file)
