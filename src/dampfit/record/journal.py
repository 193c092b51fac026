"""``recording.partial.csv``: the samples of ``dampfit record`` on disk as they arrive.

:class:`Journal` is the ``sink`` of :func:`dampfit.record.session.record`: it is called with
every poll's kept samples (time [s], x, y, z [m/s²]). The first call creates
``recording.partial.csv`` (phyphox's "Raw Data" CSV: :func:`dampfit.files.writers.
phyphox_csv_text`, which ``dampfit analyze`` reads) in the result folder's staging folder and
publishes that folder at once (``publish``), so from the first sample on ``DIR`` exists and
holds the file; every later call appends its lines with one ``write`` (signals held back: a
line is whole or absent) and ``fsync``s at most every ``sync_s`` seconds. A ``kill -9`` thus
keeps every sample polled up to a second before it. When the recording ends normally
``recording.csv`` and ``recording.json`` replace the folder (the partial file goes with the
previous version). A write that fails (disk full) stops the journal, not the recording:
:attr:`Journal.error` says why.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Callable

import numpy as np

#: The file the samples stream into.
PARTIAL = "recording.partial.csv"


class Journal:
    """Append-only ``recording.partial.csv`` (module docstring): ``stage()`` is the folder
    to create it in, ``publish()`` makes that folder the result folder."""

    def __init__(self, stage: Callable[[], Path], publish: Callable[[], object], *,
                 sync_s: float = 1.0, clock=time.monotonic) -> None:
        self.stage, self.publish, self.sync_s, self.clock = stage, publish, sync_s, clock
        self.fd: int | None = None
        self.published = False
        self.rows = 0
        self.error: str | None = None
        self._synced = -float("inf")

    def __call__(self, t: np.ndarray, a: np.ndarray, gravity_removed: bool) -> None:
        from dampfit.files.swap import signals_deferred
        from dampfit.files.writers import phyphox_csv_text

        if self.error is not None or not len(t):
            return
        text = phyphox_csv_text(t, a, gravity_removed, header=self.fd is None)
        try:
            with signals_deferred():
                if self.fd is None:
                    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) \
                        | getattr(os, "O_CLOEXEC", 0)
                    self.fd = os.open(self.stage() / PARTIAL, flags, 0o644)
                self._write(text.encode())
                self.rows += len(t)
                now = self.clock()
                if not self.published or now - self._synced >= self.sync_s:
                    os.fsync(self.fd)
                    self._synced = now
                if not self.published:
                    self.publish()
                    self.published = True
        except OSError as exc:
            self.error = exc.strerror or type(exc).__name__
            self.close()

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view):]

    def close(self) -> None:
        """Close the file (it stays where it is)."""
        if self.fd is not None:
            fd, self.fd = self.fd, None
            try:
                os.close(fd)
            except OSError:
                pass
