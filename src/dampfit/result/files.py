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

Every file is opened by the one guard, :func:`dampfit.io.bounded.open_regular`; this module
holds the result folder's policy (no links, the limits, the markers).
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from dampfit.errors import InputError, shown
from dampfit.io import bounded

#: Largest verification.json read [bytes]; ``dampfit verify`` writes a few kB.
MAX_VERIFICATION_BYTES = 16 * 2**20
#: Largest PNG figure embedded in a report [bytes]; dampfit's figures are below 1 MB.
MAX_FIGURE_BYTES = 32 * 2**20
#: Largest small side file read (the demo's truth file, the head of a report) [bytes].
MAX_SIDE_BYTES = 2**20


def _kind(mode: int) -> str | None:
    """How a result folder's file that is not a regular file is named (None: regular)."""
    if stat.S_ISREG(mode):
        return None
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
    """A read-only descriptor of the regular file ``path`` of a result folder (not a link) of
    at most ``limit`` bytes (:func:`dampfit.io.bounded.open_regular`, the one guard). ``missing``
    is raised if there is none; otherwise :class:`Unusable` (or ``refuse(its message)`` when
    given) for a link, FIFO, socket, device, directory or a file too large, and an InputError
    (or ``refuse``) for a file that cannot be opened."""
    prefix = f"{shown(path)} is "

    def unusable(message: str) -> Exception:
        exc = (Unusable(path, message[len(prefix):]) if message.startswith(prefix)
               else InputError(message))
        return exc if refuse is None else refuse(str(exc))

    return bounded.open_regular(path, limit, missing=missing,
                                refusal=bounded.Refusal(unusable, _kind, what))


def read_regular(path: Path, limit: int, missing: Exception | str,
                 refuse: Callable[[str], Exception] | None = None,
                 what: str = "a dampfit summary.json is a few kB") -> bytes:
    """The bytes of the regular file ``path`` (:func:`open_regular`), at most ``limit``."""
    if not isinstance(missing, Exception):
        missing = InputError(missing)
    fd = open_regular(path, limit, missing=missing, refuse=refuse, what=what)
    try:
        data = bounded.read_fd(fd, limit)
    except OSError as exc:
        raise (refuse or InputError)(
            f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    finally:
        os.close(fd)
    if len(data) > limit:  # it grew since fstat
        raise (refuse or InputError)(f"{shown(path)} is larger than "
                                     f"{bounded.size_text(limit)}; {what}")
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


# --------------------------------------------------------------- which summary a file is of
#: The files of a result folder whose SHA-256 summary.json records (``files``), so a
#: posterior.nc or signals.npz swapped in from another analysis is refused, not redrawn.
DIGESTED = ("posterior.nc", "signals.npz")


def digest_fd(fd: int) -> dict[str, object]:
    """``{"sha256": hex, "bytes": size}`` of the open file ``fd`` (read with ``pread``: the
    descriptor's offset is left as it is)."""
    import hashlib

    h, offset = hashlib.sha256(), 0
    while True:
        block = os.pread(fd, 1 << 20, offset)
        if not block:
            break
        h.update(block)
        offset += len(block)
    return {"sha256": h.hexdigest(), "bytes": offset}


def file_digests(folder: Path, names=DIGESTED) -> dict[str, dict[str, object]]:
    """The ``files`` section of summary.json: each file's :func:`digest_fd` (files dampfit
    has just written into ``folder``, opened without following links)."""
    out = {}
    for name in names:
        fd = bounded.open_regular(folder / name, 2**40, missing=InputError(
            f"{shown(folder / name)} was not written"),
            refusal=bounded.Refusal(what="a result file"))
        try:
            out[name] = digest_fd(fd)
        finally:
            os.close(fd)
    return out


class ForeignFile(InputError):
    """A result file that is not the one its summary.json records (another analysis's)."""


def check_digest(fd: int, path: Path, summary: dict | None) -> None:
    """Refuse the open ``fd`` of ``path`` (posterior.nc or signals.npz) when ``summary``
    (the folder's summary.json) records another SHA-256 for it: the file is of another
    analysis. A summary without ``files`` (written before dampfit recorded them) or without
    this file's entry is not checked."""
    files = summary.get("files") if isinstance(summary, dict) else None
    entry = files.get(path.name) if isinstance(files, dict) else None
    expected = entry.get("sha256") if isinstance(entry, dict) else None
    if not isinstance(expected, str):
        return
    if digest_fd(fd)["sha256"] != expected:
        raise ForeignFile(f"{shown(path)} does not belong to {shown(path.parent / 'summary.json')}: "
                         f"its SHA-256 is not the one recorded there (files.{path.name}); it was "
                         "replaced or swapped in from another analysis. Re-run 'dampfit "
                         "analyze', or put back the file written with this summary")
