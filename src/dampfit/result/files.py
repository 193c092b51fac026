"""Opening the files of a result folder: regular files only, bounded, never blocking.

Everything ``report``, ``export``, ``verify`` and :func:`dampfit.load` read from a result folder
(summary.json, posterior.nc, signals.npz, verification.json, the PNG figures, the report a
refresh would replace, the demo's truth file) is opened here, and only the folder's own files
are read:

* opened with ``O_NOFOLLOW | O_NONBLOCK``, then checked with ``fstat`` on the open
  descriptor: a FIFO never blocks the process, a device (``/dev/zero``) or socket is refused,
  and a file swapped in after a check is the file checked;
* **no symbolic links**: dampfit never writes a link into a result folder, so a link there was
  put by someone else and may point anywhere (``/dev/zero``, a private file that a report
  would embed); it is refused like any other non-regular file. (The folder itself may be
  reached through a link: that is the user's choice of path.)
* a size limit per kind of file, checked from ``fstat`` before anything is read, and the read
  itself stops at the limit (a file growing meanwhile).

Whether a file there is one dampfit wrote (a report a refresh may replace) is decided here
too, read-only: :func:`written_by_dampfit` with the markers of :data:`REPORT_MARKERS`.

This module imports only the standard library.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Callable
from pathlib import Path

from dampfit.errors import InputError
from dampfit.errors import shown

__all__ = ["MAX_FIGURE_BYTES", "MAX_SIDE_BYTES", "MAX_VERIFICATION_BYTES", "REPORT_GENERATOR",
           "REPORT_MARKERS", "Unusable", "open_regular", "read_optional", "read_regular",
           "written_by_dampfit"]

#: Largest verification.json read [bytes]; ``dampfit verify`` writes a few kB.
MAX_VERIFICATION_BYTES = 16 * 2**20
#: Largest PNG figure embedded in a report [bytes]; dampfit's figures are below 1 MB.
MAX_FIGURE_BYTES = 32 * 2**20
#: Largest small side file read (the demo's truth file, the head of a report) [bytes].
MAX_SIDE_BYTES = 2**20

_FLAGS = (os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0)
          | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory, not a file"
    if stat.S_ISLNK(mode):
        return ("a symbolic link, not a regular file (dampfit writes no links into a result "
                "folder)")
    return "not a regular file (a FIFO, socket or device)"


class Unusable(InputError):
    """A file of a result folder that is there but is not a usable regular file: the message
    is ``PATH is REASON``; ``reason`` alone (e.g. "a directory, not a file") for callers that
    phrase it themselves."""

    def __init__(self, path: Path, reason: str):
        super().__init__(f"{shown(path)} is {reason}")
        self.reason = reason


def open_regular(path: Path, limit: int, *, missing: Exception,
                 refuse: Callable[[str], Exception] | None = None,
                 what: str = "not a file dampfit writes") -> int:
    """A read-only descriptor of the regular file ``path`` (not a link) of at most ``limit``
    bytes. ``missing`` is raised if there is none; otherwise :class:`Unusable` (or
    ``refuse(its message)`` when given) for a link, FIFO, socket, device, directory or a file
    too large, and an InputError (or ``refuse``) for a file that cannot be opened."""
    def fail(exc: InputError) -> Exception:
        return exc if refuse is None else refuse(str(exc))

    try:
        fd = os.open(path, _FLAGS)
    except FileNotFoundError:
        raise missing from None
    except OSError as exc:
        try:
            mode = os.lstat(path).st_mode
        except OSError:
            mode = None
        if mode is not None and (exc.errno in (errno.ELOOP, errno.ENXIO, errno.EMLINK)
                                 or not stat.S_ISREG(mode)):
            raise fail(Unusable(path, _kind(mode))) from None
        raise fail(InputError(f"cannot read {shown(path)}: "
                              f"{exc.strerror or type(exc).__name__}")) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise fail(Unusable(path, _kind(st.st_mode)))
        if st.st_size > limit:
            raise fail(Unusable(path, f"{_size(st.st_size)}, larger than {_size(limit)}; {what}"))
    except BaseException:
        os.close(fd)
        raise
    return fd


def _size(n: int) -> str:
    return f"{n / 2**20:.0f} MB" if n >= 2**20 else f"{n / 1024:.0f} kB"


def _read_fd(fd: int, limit: int) -> bytes:
    """At most ``limit + 1`` bytes of ``fd`` from its start."""
    chunks, size = [], 0
    while size <= limit:
        chunk = os.pread(fd, min(1 << 20, limit + 1 - size), size)
        if not chunk:
            break
        chunks.append(chunk)
        size += len(chunk)
    return b"".join(chunks)


def read_regular(path: Path, limit: int, missing: Exception | str,
                 refuse: Callable[[str], Exception] | None = None,
                 what: str = "a dampfit summary.json is a few kB") -> bytes:
    """The bytes of the regular file ``path`` (:func:`open_regular`), at most ``limit``."""
    refuse = refuse or InputError
    if not isinstance(missing, Exception):
        missing = InputError(missing)
    fd = open_regular(path, limit, missing=missing, refuse=refuse, what=what)
    try:
        data = _read_fd(fd, limit)
    except OSError as exc:
        raise refuse(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    finally:
        os.close(fd)
    if len(data) > limit:  # it grew since fstat
        raise refuse(f"{shown(path)} is larger than {_size(limit)}; {what}")
    return data


class _Missing(Exception):
    pass


def read_optional(path: Path, limit: int, what: str = "not a file dampfit writes"
                  ) -> tuple[bytes | None, str | None]:
    """(bytes, None) of an optional file of a result folder, (None, None) if there is none,
    (None, why) if it is there but unusable (a link, FIFO, device, too large, unreadable)."""
    try:
        return read_regular(path, limit, _Missing(), what=what), None
    except _Missing:
        return None, None
    except InputError as exc:
        return None, str(exc)


#: The generator a dampfit report names (:data:`dampfit.output.document.GENERATOR`).
REPORT_GENERATOR = "dampfit report"
#: What the first 4 kB of each report file dampfit writes hold, by file name: the one
#: definition, which :mod:`dampfit.output.document` writes into the report and
#: :func:`written_by_dampfit` looks for — how a refresh tells its own report from a file of the
#: same name that someone else put there.
REPORT_MARKERS = {"report.html": f'<meta name="generator" content="{REPORT_GENERATOR}">',
                  "report.md": f"<!-- generated by {REPORT_GENERATOR}"}


def written_by_dampfit(path: str | os.PathLike, marker: str) -> bool:
    """Whether ``path`` is a file dampfit wrote: a regular file (a link, FIFO or device is not,
    and is never opened in a way that could block) whose first 4 kB hold ``marker`` (e.g. a
    value of :data:`REPORT_MARKERS`). Read-only; any failure to read it means "not ours"."""
    try:
        fd = open_regular(Path(path), 1 << 62, missing=FileNotFoundError())
    except (InputError, OSError):
        return False
    try:
        head = os.pread(fd, 4096, 0)
    except OSError:
        return False
    finally:
        os.close(fd)
    return marker in head.decode("utf-8", "replace")
