"""The one lock of dampfit: :class:`FileLock` (result folders, studies)."""

from __future__ import annotations

import fcntl
import os
import stat
from collections.abc import Callable
from pathlib import Path

from dampfit.errors import InputError
from dampfit.files.atomic import error_text


def check_lock_file(fd: int, path: Path) -> None:
    """Refuse (and close ``fd``) a lock file that is not a regular file: a FIFO, device or
    socket planted under the lock's name cannot be truncated or written like one."""
    try:
        mode = os.fstat(fd).st_mode
    except OSError as exc:
        os.close(fd)
        raise InputError(f"cannot use the lock file {path}: {error_text(exc)}") from None
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise InputError(f"the lock file {path} is not a regular file (a FIFO, socket or "
                         "device); remove it, or choose another --out")

def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` is alive (another user's counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    except OSError:
        return False
    return True

class FileLock:
    """An exclusive lock held through the lock file ``path`` (``flock``), the one lock of
    dampfit: result folders (:class:`ResultFolder`) and studies (:mod:`dampfit.files.runlog`).

    The lock file is opened without following a link and without blocking, refused if it is
    not a regular file (:func:`check_lock_file`), locked without waiting, and re-checked to be
    the file still at ``path`` (its previous holder may have removed it meanwhile); the
    holder's pid is written into it. A lock that another process holds raises
    ``InputError(busy(pid))``. :meth:`release` removes the lock file if it is still the one
    locked — unless ``keep_foreign`` and this process did not create it.
    """

    def __init__(self, path: str | os.PathLike, *, busy: Callable[[str], str],
                 keep_foreign: bool = False) -> None:
        self.path = Path(path)
        self.busy = busy
        self.keep_foreign = keep_foreign
        self.fd: int | None = None
        self.created = False

    def acquire(self) -> None:
        """Take the lock, or raise a one-line :class:`InputError`."""
        path = self.path
        flags = os.O_RDWR | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0)
        for _ in range(20):
            created = True
            try:
                fd = os.open(path, flags | os.O_CREAT | os.O_EXCL, 0o600)
            except FileExistsError:
                created = False
                try:
                    fd = os.open(path, flags)
                except FileNotFoundError:
                    continue  # removed by its holder meanwhile: try again
                except OSError as exc:
                    raise InputError(f"cannot open the lock file {path}: "
                                     f"{error_text(exc)}") from None
            except OSError as exc:
                raise InputError(f"cannot create the lock file {path}: {error_text(exc)}") from None
            check_lock_file(fd, path)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                try:
                    pid = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
                finally:
                    os.close(fd)
                raise InputError(self.busy(pid)) from None
            try:  # its holder may have removed the file before we locked it: lock the one there
                same = os.path.samestat(os.fstat(fd), os.lstat(path))
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
                self.fd, self.created = fd, created
                return
            os.close(fd)
        raise InputError(f"cannot lock {path}: it keeps changing")  # pragma: no cover

    def release(self) -> None:
        """Release the lock and remove the lock file if it is still the one locked."""
        if self.fd is None:
            return
        if self.created or not self.keep_foreign:
            try:
                if os.path.samestat(os.fstat(self.fd), os.lstat(self.path)):
                    os.unlink(self.path)
            except OSError:
                pass
        os.close(self.fd)
        self.fd = None

    @property
    def held(self) -> bool:
        """Whether this process holds the lock."""
        return self.fd is not None
