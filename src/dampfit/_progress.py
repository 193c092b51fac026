"""Progress of the long stages: the one place dampfit makes progress bars (tqdm) and lines.

Every long loop — the emcee blocks of the viscous posterior, of each damping law and of the
several-mode posterior, K by evidence, the runs of a study, the kernels of ``dampfit
warm-up`` — reports through one interface: a stage name, a fraction done (steps of a total
that may be revised as the stage learns how much it needs) and the ETA that follows from them
(time so far × the fraction left / the fraction done). How it is shown is chosen once, by
whoever runs the work, with :func:`reporting`:

- on a terminal, a tqdm bar on stderr per stage (with its ETA), cleared when done, width
  following the terminal;
- anywhere else (a log file, a pipe, CI), :class:`LineProgress`: a line when a stage has done
  a quarter, a half and three quarters of its work, each with the ETA (``modes: K = 2,
  posterior: 50 %, ~12 s left``), and one line when it ends — at most four lines a stage,
  however many steps it takes;
- nothing under ``--quiet`` (no :func:`reporting` context), or for a bar made with
  ``enabled=False``.

A library call with ``progress=True`` and no :func:`reporting` context gets tqdm bars
(``tqdm.auto``: a widget in a notebook).
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import time
from dataclasses import dataclass
from typing import Any, Iterator, TextIO


@dataclass(frozen=True)
class Reporter:
    """Where progress goes: ``file`` (default: stderr when reported), as bars (``bars``
    True: a terminal) or as a few lines a stage (False)."""

    file: TextIO | None = None
    bars: bool = True

    @property
    def stream(self) -> TextIO:
        return self.file if self.file is not None else sys.stderr


_REPORTER: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar(
    "dampfit_progress", default=None)


@contextlib.contextmanager
def reporting(file: TextIO | None = None, *, bars: bool | None = None) -> Iterator[Reporter]:
    """Report the progress of every stage run inside this block to ``file`` (default
    stderr): as bars when ``bars`` (default: ``file`` is a terminal), else as lines."""
    stream = file if file is not None else sys.stderr
    if bars is None:
        isatty = getattr(stream, "isatty", None)
        bars = bool(isatty()) if callable(isatty) else False
    token = _REPORTER.set(Reporter(file, bars))
    try:
        yield _REPORTER.get()
    finally:
        _REPORTER.reset(token)


@contextlib.contextmanager
def silenced() -> Iterator[None]:
    """No progress inside this block (the analyses inside ``dampfit warm-up``'s own stage)."""
    token = _REPORTER.set(None)
    try:
        yield
    finally:
        _REPORTER.reset(token)


def active() -> bool:
    """Whether progress is being reported (inside :func:`reporting`)."""
    return _REPORTER.get() is not None


def announce(message: str) -> None:
    """One line of progress (``message``) where progress is reported; nothing elsewhere."""
    rep = _REPORTER.get()
    if rep is not None:
        _write_line(rep.stream, message)


def _write_line(stream: TextIO, text: str) -> None:
    try:
        from tqdm import tqdm

        tqdm.write(text, file=stream)  # above any bar being drawn
    except ImportError:  # pragma: no cover - tqdm is a dependency
        print(text, file=stream, flush=True)


def progress_bar(total: int, desc: str, *, unit: str = "step", enabled: bool = True,
                 initial: int = 0, file: TextIO | None = None, leave: bool = False) -> Any:
    """The progress of one stage: ``total`` ``unit``s titled ``desc`` (a context manager with
    ``update(n)``, a settable ``total`` and ``close()``). Inside :func:`reporting` it is shown
    as that context says; outside, a tqdm bar (``tqdm.auto``); ``enabled=False`` gives one
    that shows nothing."""
    rep = _REPORTER.get()
    if enabled and file is None and rep is not None and not rep.bars:
        return LineProgress(total, desc, rep.stream, initial=initial)
    from tqdm.auto import tqdm

    if file is None and rep is not None:
        file = rep.file
    return tqdm(total=total, initial=initial, desc=desc, unit=unit, disable=not enabled,
                leave=leave, dynamic_ncols=True, file=file)


def stage_bar(total: int, desc: str, *, unit: str = "step") -> Any:
    """:func:`progress_bar` of a stage that is not told whether to show progress: shown
    exactly when progress is being reported (:func:`active`)."""
    return progress_bar(total, desc, unit=unit, enabled=active())


def eta_text(seconds: float) -> str:
    """``~25 s`` / ``~3 min`` / ``~1.2 h``: an ETA [s] rounded as a person reads it."""
    if seconds < 90:
        return f"~{max(1, round(seconds))} s"
    if seconds < 5400:
        return f"~{round(seconds / 60)} min"
    return f"~{seconds / 3600:.1f} h"


class LineProgress:
    """A stage's progress as lines (no terminal): one at each quarter of the work crossed,
    with the percentage and the ETA, and one at the end with the time it took.

    ``total`` may be revised while the stage runs (an adaptive sampler learns how many steps
    its stopping rule needs); the fraction is then ``n / total`` of the new total.
    """

    QUARTERS = (0.25, 0.5, 0.75)

    def __init__(self, total: int, desc: str, file: TextIO, *, initial: int = 0,
                 clock=time.monotonic):
        self.desc, self.file, self.n = desc, file, initial
        self._clock = clock
        self._t0 = clock()
        self._next = 0  # index of the next quarter to announce
        self._closed = False
        self._total = total

    def __enter__(self) -> "LineProgress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def set_description(self, desc: str, refresh: bool = True) -> None:
        self.desc = desc

    def refresh(self) -> None:
        """Nothing to redraw (tqdm's interface)."""

    @property
    def total(self) -> int:
        return self._total

    @total.setter
    def total(self, value: int) -> None:
        self._total = value
        self._say()

    def update(self, n: int = 1) -> None:
        self.n += n
        self._say()

    def _say(self) -> None:
        """The line of a quarter just crossed (the last one crossed, if several were)."""
        if not self.total or self.total <= 0 or self._closed:
            return
        frac = min(self.n / self.total, 1.0)
        crossed = self._next
        while crossed < len(self.QUARTERS) and frac >= self.QUARTERS[crossed]:
            crossed += 1
        if crossed == self._next or frac >= 1.0:
            self._next = crossed
            return
        self._next = crossed
        elapsed = self._clock() - self._t0
        left = elapsed * (1.0 - frac) / frac
        _write_line(self.file, f"{self.desc}: {100 * frac:.0f} %, {eta_text(left)} left")

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        elapsed = self._clock() - self._t0
        _write_line(self.file, f"{self.desc}: done in {elapsed:.1f} s")
