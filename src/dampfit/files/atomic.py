"""Atomic file output: a file is either complete or absent, never half-written.

Files are written to a temporary name in the target folder and renamed into place
(``os.replace`` is atomic on one file system). Temporary files are created private
(``mkstemp``); :func:`publish` gives them the mode the user's umask asks for.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from dampfit.errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask

def publish(path: str | os.PathLike) -> None:
    """Give a file (0o666) or folder (0o777) the permissions the process umask allows."""
    path = Path(path)
    os.chmod(path, (0o777 if path.is_dir() else 0o666) & ~_umask())

class WriteError(InputError):
    """A file could not be written (the OSError is the ``__cause__``); one line, exit 2."""

def _tmp_prefix(name: str) -> str:
    """Prefix of a temporary file beside ``name``: short enough that the temporary name fits
    whenever ``name`` itself does (a long ``name`` would otherwise fail in ``mkstemp``)."""
    return f".{name[:40]}."

def check_output_file(path: str | os.PathLike, force: bool, option: str = "--out") -> Path:
    """Refuse, before any work, to write the single file ``path``: its folder must exist; an
    existing entry (a file, or a symbolic link even if dangling) is replaced only with
    ``force`` (a link is then replaced itself, never its target); a directory or a special
    file never. A name the file system cannot hold (too long) is one line as well."""
    path = Path(path)
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):  # the folder check below names the problem
        st = None
    except OSError as exc:  # ENAMETOOLONG, EACCES, ELOOP
        raise InputError(f"cannot write {path}: {error_text(exc)}") from None
    try:
        parent_ok = path.parent.is_dir()
    except OSError as exc:
        raise InputError(f"cannot write {path}: {error_text(exc)}") from None
    if not parent_ok:
        raise InputError(f"cannot write {path}: directory {path.parent} does not exist")
    if st is None:
        return path
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"refusing to overwrite {path}: it is a directory, not a regular file; "
                         f"give a file name with {option}")
    if not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
        raise InputError(f"refusing to overwrite {path}: it is not a regular file")
    if not force:
        what = (" (it is a symbolic link: --force replaces the link, never its target)"
                if stat.S_ISLNK(st.st_mode) else "")
        raise InputError(f"{path} exists; use --force to replace it{what}")
    return path

def atomic_write(path: str | os.PathLike, write: Callable[[str], object], *,
                 suffix: str = ".tmp", shown: Callable[[object], str] = str) -> Path:
    """Write ``path`` atomically through ``write(tmp)``, which writes a temporary file ``tmp``
    in the same folder; it is then made readable like any file the user creates
    (:func:`publish`) and renamed over ``path`` (a symbolic link at ``path`` is replaced, not
    followed). Any failure — missing folder, a name too long, no permission, a full disk — is a
    :class:`WriteError` (an :class:`InputError`: one line, exit 2) and leaves ``path`` as it was
    and no temporary file behind. ``suffix`` keeps the format visible to writers that infer it
    from the name (``.png``, ``.nc``); ``shown`` renders paths in the message."""
    path = Path(path)
    try:
        if not path.parent.is_dir():
            raise WriteError(f"cannot write {shown(path)}: directory {shown(path.parent)} "
                             "does not exist")
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_tmp_prefix(path.name), suffix=suffix)
        os.close(fd)
    except OSError as exc:
        raise WriteError(f"cannot write {shown(path)}: {error_text(exc)}") from exc
    try:
        write(tmp)
        publish(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise WriteError(f"cannot write {shown(path)}: {error_text(exc)}") from exc
    finally:
        Path(tmp).unlink(missing_ok=True)
    return path

def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`)."""

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)

    return atomic_write(path, write)

def error_text(exc: BaseException) -> str:
    """One short line describing an I/O failure."""
    if isinstance(exc, OSError) and exc.strerror:
        text = exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    text = " ".join(text.split())
    return text if len(text) <= 200 else text[:197] + "..."

def os_error_in(exc: BaseException) -> OSError | None:
    """The OSError ``exc`` is or was caused by (h5py, matplotlib and PIL wrap them)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, OSError):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
