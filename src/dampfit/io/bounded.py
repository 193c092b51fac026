"""Bounded reading of an input file: limits on hostile input, file-kind checks, decoding —
and the one guard every file dampfit reads goes through (:func:`open_regular`,
:func:`read_regular`: a regular file under a size limit, opened so that nothing can block).

:func:`read_bytes` returns a file's bytes only if it is a regular file (symlinks resolved) of a
supported type, not empty and at most :data:`MAX_INPUT_BYTES` long; FIFOs, devices, sockets and
directories are refused before they are opened, so a ``/dev/zero`` link or a named pipe can
neither block nor read forever. :func:`decode` turns the bytes of a text table into ``str``
(UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1; ``\r\n`` and lone ``\r`` read as
``\n``) after refusing binary junk, lines over :data:`MAX_LINE_BYTES` [bytes] and more than
:data:`MAX_ROWS` lines; :func:`dampfit.io.text.text_table` refuses more than
:data:`MAX_CELLS` values before parsing (the memory of a parse grows with the values).

All limits on hostile input live here (sizes in bytes); the other readers look them up through
this module at call time, so one ``monkeypatch.setattr(bounded, "MAX_…", …)`` lowers a limit
everywhere.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from dampfit.errors import InputError, shown

#: Largest input file [bytes] read at all (1 GiB: ~25 million rows of phone CSV).
MAX_INPUT_BYTES = 1 << 30
#: Largest total decompressed size [bytes] of the ZIP members read (ZIP, xlsx, npz) and of an
#: array declared in an .npy header.
MAX_UNPACKED_BYTES = 1 << 30
#: Largest compression ratio (uncompressed / compressed) of a ZIP member over 1 MiB; text and
#: float arrays compress ≤ 20:1, a zip bomb of zeros ≈ 1000:1.
MAX_ZIP_RATIO = 200.0
#: Smallest member [bytes] whose compression ratio is checked.
RATIO_MIN_BYTES = 1 << 20
#: Longest line [bytes] of a text table (a real row is < 1 KiB).
MAX_LINE_BYTES = 64 * 1024
#: Most columns of a text table.
MAX_COLUMNS = 1000
#: Most lines of a text table (11 hours at 500 Hz); bounds the parsed table's memory.
MAX_ROWS = 20_000_000
#: Most values (rows × columns) of a text table: reading one peaks at about 60 bytes a value
#: (the file's bytes, its text, the parsed columns and the recording;
#: ``paper/bench_memory.py``), so 30 M values stay under 2 GB — 15 M rows of time and one
#: axis, 7.5 M rows of time and three axes, 6 M rows of phyphox's five columns.
MAX_CELLS = 30_000_000
#: Bytes scanned at a time when looking for the longest line.
_LINE_CHUNK = 1 << 24

#: File extensions read as text tables ("" = no extension), and all extensions read.
TEXT_EXTS = {".csv", ".txt", ".tsv", ".dat", ""}
_SUPPORTED_EXTS = TEXT_EXTS | {".zip", ".xlsx", ".xlsm", ".xls", ".npy", ".npz", ".mat", ".lvm",
                                ".tdms", ".uff", ".unv"}


def file_kind(mode: int) -> str | None:
    """What a non-regular file is, e.g. ``"a named pipe (FIFO)"``; None for a regular file."""
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symbolic link")):
        if test(mode):
            return name
    return None if stat.S_ISREG(mode) else "not a regular file"


# ------------------------------------------------------------------ the one guard
_BASE_FLAGS = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
               | getattr(os, "O_CLOEXEC", 0))


def size_text(n: int) -> str:
    """A size [bytes] for a message: ``12 MB``, ``3 kB``."""
    return f"{n / 2**20:.0f} MB" if n >= 2**20 else f"{n / 1024:.0f} kB"


class Refusal(NamedTuple):
    """How :func:`open_regular` words a refusal: ``error(message)`` makes the exception,
    ``describe(mode)`` names a file that is not a regular one (None: regular), ``what`` says
    why the size limit."""

    error: Callable[[str], Exception] = InputError
    describe: Callable[[int], str | None] = file_kind
    what: str = ""


def open_regular(path: str | os.PathLike, limit: int, *, missing: Exception,
                 follow_links: bool = False, refusal: Refusal = Refusal(),
                 check: Callable[[os.stat_result], None] | None = None,
                 dir_fd: int | None = None) -> int:
    """A read-only descriptor of the regular file ``path`` of at most ``limit`` bytes — the one
    guard every file dampfit reads passes.

    Opened non-blocking (a FIFO or device never blocks the process), without following a
    symbolic link unless ``follow_links`` (a recording the user names may be a link; a file of
    a result folder may not), then checked with ``fstat`` on the open descriptor, so the file
    checked is the file read. ``missing`` is raised when there is no such file; a link (when
    not followed), FIFO, socket, device, directory or a file larger than ``limit`` raises
    ``refusal.error("PATH is WHAT")`` (``refusal.describe(mode)`` names the kind,
    ``refusal.what`` says why the limit; :class:`Refusal`); ``check(stat)`` may refuse more
    (owner, mode). ``dir_fd`` opens ``path`` relative to an open folder."""
    refuse, describe, what = refusal
    flags = _BASE_FLAGS | (0 if follow_links else os.O_NOFOLLOW)
    try:
        fd = os.open(path, flags, dir_fd=dir_fd)
    except FileNotFoundError:
        raise missing from None
    except OSError as exc:
        try:
            mode = os.stat(path, dir_fd=dir_fd, follow_symlinks=follow_links).st_mode
        except OSError:
            mode = None
        if mode is not None and describe(mode) is not None:
            raise refuse(f"{shown(path)} is {describe(mode)}") from None
        raise refuse(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    try:
        st = os.fstat(fd)
        kind = describe(st.st_mode)
        if kind is not None:
            raise refuse(f"{shown(path)} is {kind}")
        if st.st_size > limit:
            raise refuse(f"{shown(path)} is {size_text(st.st_size)}, larger than {size_text(limit)}"
                         + (f"; {what}" if what else ""))
        if check is not None:
            check(st)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_fd(fd: int, limit: int) -> bytes:
    """At most ``limit + 1`` bytes of the open file ``fd`` from its start (one more than the
    limit: a file that grew since it was checked is seen)."""
    chunks, size = [], 0
    while size <= limit:
        chunk = os.pread(fd, min(1 << 20, limit + 1 - size), size)
        if not chunk:
            break
        chunks.append(chunk)
        size += len(chunk)
    return b"".join(chunks)


def read_regular(path: str | os.PathLike, limit: int, *, missing: Exception,
                 refuse: Callable[[str], Exception] = InputError, what: str = "",
                 describe: Callable[[int], str | None] = file_kind, **kw) -> bytes:
    """The bytes of the regular file ``path`` (:func:`open_regular`, same options), at most
    ``limit``; a file that grew past the limit while it was read is refused too."""
    fd = open_regular(path, limit, missing=missing, refusal=Refusal(refuse, describe, what),
                      **kw)
    try:
        data = read_fd(fd, limit)
    except OSError as exc:
        raise refuse(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    finally:
        os.close(fd)
    if len(data) > limit:
        raise refuse(f"{shown(path)} is larger than {size_text(limit)}" + (f"; {what}" if what else ""))
    return data


def read_bytes(path: Path) -> bytes:
    """The file's bytes, after checking it exists, is a regular file (links resolved), has a
    supported type, is not empty and not larger than :data:`MAX_INPUT_BYTES`.

    The type is checked with ``stat`` before opening, and again on the open descriptor (opened
    non-blocking, so a FIFO swapped in between cannot block), and at most
    ``MAX_INPUT_BYTES + 1`` bytes are ever read.
    """
    try:
        info = os.stat(path)  # follows symlinks: the target is what would be read
    except FileNotFoundError:
        raise InputError("file not found" + (" (broken link)" if path.is_symlink() else "")) from None
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror or exc})") from None
    kind = file_kind(info.st_mode)
    if kind == "a directory":
        raise InputError("is a directory, not a recording file")
    if kind is not None:
        via = " (via a symbolic link)" if path.is_symlink() else ""
        raise InputError(f"is {kind}{via}, not a regular file; only regular files are read")
    ext = path.suffix.lower()
    if ext not in _SUPPORTED_EXTS:
        supported = " ".join(sorted(e for e in _SUPPORTED_EXTS if e))
        raise InputError(f"unsupported file type {ext!r}; supported: {supported}")
    if info.st_size > MAX_INPUT_BYTES:
        raise InputError(f"is {info.st_size / 2**20:.0f} MiB, larger than the limit of "
                         f"{MAX_INPUT_BYTES / 2**20:.0f} MiB; split or decimate the recording")

    def refuse(message: str) -> InputError:  # replaced since the stat above, or it grew
        if "larger than" in message:
            return InputError(f"is larger than the limit of {MAX_INPUT_BYTES / 2**20:.0f} MiB; "
                              "split or decimate the recording")
        if message.startswith("cannot read"):
            return InputError(f"cannot be read ({message.rpartition(': ')[2]})")
        return InputError("is not a regular file; only regular files are read")

    data = read_regular(path, MAX_INPUT_BYTES, missing=InputError("file not found"),
                        follow_links=True, refuse=refuse)
    if not data:
        raise InputError("is empty (0 bytes)")
    return data


def _longest_line(data: bytes) -> int:
    """Length [bytes] of the longest line (``\n`` or ``\r`` ends a line), scanned in chunks;
    stops early once a line exceeds :data:`MAX_LINE_BYTES`."""
    longest, run = 0, 0  # run: the open line carried over from the previous chunk
    for start in range(0, len(data), _LINE_CHUNK):
        chunk = np.frombuffer(data, np.uint8, count=min(_LINE_CHUNK, len(data) - start), offset=start)
        ends = np.flatnonzero((chunk == 10) | (chunk == 13))
        if ends.size == 0:
            run += chunk.size
        else:
            inner = int(np.diff(ends).max()) - 1 if ends.size > 1 else 0
            longest = max(longest, run + int(ends[0]), inner)
            run = chunk.size - int(ends[-1]) - 1
        longest = max(longest, run)
        if longest > MAX_LINE_BYTES:
            break
    return longest


def decode(data: bytes) -> str:
    """Bytes → text (UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1) with ``\n`` line
    endings; reject binary junk and lines longer than :data:`MAX_LINE_BYTES` before parsing."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            data = data.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError:
            raise InputError("is neither valid UTF-16 text (despite its byte-order mark) nor a table") from None
    if b"\x00" in data[:65536]:
        raise InputError("is binary, not a text table of time and acceleration")
    longest = _longest_line(data)
    if longest > MAX_LINE_BYTES:
        what = "has no line breaks" if len(data) == longest else "has a line"
        raise InputError(
            f"{what} over {MAX_LINE_BYTES // 1024} KiB long ({len(data) / 2**20:.3g} MiB file); "
            "a table of time and acceleration has one short row per sample"
        )
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    head = text[:65536]
    control = sum(1 for ch in head if (ch < " " and ch not in "\t\r\n") or "\x7f" <= ch <= "\x9f")
    if control > 0.01 * len(head):
        raise InputError("is binary, not a text table of time and acceleration")
    if "\r" in text:  # Windows \r\n and old-Mac lone \r line endings
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    rows = text.count("\n")
    if rows > MAX_ROWS:
        raise InputError(f"has {rows} lines, more than the limit of {MAX_ROWS}; split or decimate "
                         "the recording")
    return text
