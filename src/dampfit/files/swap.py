"""The swap of a finished result folder onto its target, so that no signal or kill loses one.

:class:`dampfit.files.folder.ResultFolder` publishes a staging folder with the primitives here:

* :func:`exchange` swaps two folders in one system call (Linux ``renameat2`` with
  ``RENAME_EXCHANGE``): at every instant the target is either the old or the new result, so
  even ``kill -9`` cannot leave it missing. Where the call or the flag is not available
  (another OS, an old kernel, a file system without it) it returns False and the caller falls
  back to two renames;
* :func:`rename_noreplace` moves a folder onto a name that must not exist (``RENAME_NOREPLACE``
  where available, so a folder created there meanwhile is never replaced);
* :func:`signals_deferred` holds SIGINT, SIGTERM and SIGHUP back during those renames. Python
  runs signal handlers in the main thread whichever thread the kernel delivered the signal
  to, so blocking the signals in one thread (``pthread_sigmask``) does not stop a Ctrl-C that
  lands in another thread (JAX's, the figure helper's reader) from raising
  ``KeyboardInterrupt`` between two renames. Here the Python-level handlers themselves are
  replaced by one that only records the signal; the previous handlers are restored and a
  recorded signal is raised again once the renames are done, so it acts at once after them;
* :func:`remove_result` deletes a result folder with its marker file last, so a deletion cut
  short by a kill leaves a folder that is still recognisably dampfit's and is removed by the
  next run.

A kill between the two renames of the fallback leaves the previous result under its hidden
name ``.NAME.dampfit-old-PID-XXXX``; the next run for the same target restores it
(:meth:`dampfit.files.folder.ResultFolder._recover`).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import signal
import sys
import threading
from pathlib import Path

_AT_FDCWD = -100
_RENAME_NOREPLACE = 1
_RENAME_EXCHANGE = 2
#: errno values meaning "this system or file system cannot do it": fall back to rename(2).
_UNSUPPORTED = {errno.ENOSYS, errno.EINVAL, getattr(errno, "ENOTSUP", -1),
                getattr(errno, "EOPNOTSUPP", -1)}
_renameat2 = None


def _libc_renameat2():
    """libc's ``renameat2`` (glibc ≥ 2.28, musl ≥ 1.2.3) or None."""
    global _renameat2
    if _renameat2 is None:
        fn = False
        if sys.platform.startswith("linux"):
            try:
                fn = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", False)
            except (OSError, AttributeError):  # pragma: no cover - no usable libc
                fn = False
            if fn:
                fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                               ctypes.c_uint]
                fn.restype = ctypes.c_int
        _renameat2 = fn
    return _renameat2 or None


def _rename2(src: os.PathLike | str, dst: os.PathLike | str, flags: int) -> bool:
    """``renameat2(src, dst, flags)``: True if done, False if unsupported; OSError otherwise."""
    fn = _libc_renameat2()
    if fn is None:
        return False
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) == 0:
        return True
    err = ctypes.get_errno()
    if err in _UNSUPPORTED:
        return False
    raise OSError(err, os.strerror(err), str(src), None, str(dst))


def exchange(a: os.PathLike | str, b: os.PathLike | str) -> bool:
    """Swap the folders ``a`` and ``b`` atomically; False if this system cannot (nothing done)."""
    return _rename2(a, b, _RENAME_EXCHANGE)


def rename_noreplace(src: os.PathLike | str, dst: os.PathLike | str) -> None:
    """Rename ``src`` to ``dst``, which must not exist (``FileExistsError`` if it does)."""
    if _rename2(src, dst, _RENAME_NOREPLACE):
        return
    if os.path.lexists(dst):
        raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(dst))
    os.rename(src, dst)  # an empty folder created at dst since the check would be replaced


#: Signals whose Python-level handling is deferred during a swap (each ends the process or
#: raises in the main thread when it is not held back).
_DEFERRED_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                          if hasattr(signal, n))


@contextlib.contextmanager
def signals_deferred():
    """Hold SIGINT/SIGTERM/SIGHUP back in every thread for a few system calls (see the module).

    Outside the main thread nothing is needed (Python raises signal exceptions only in the
    main thread) and nothing is done. A signal that arrived meanwhile is raised again at the
    end, under the handler that was in place before."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []

    def record(signum, frame):
        caught.append(signum)

    previous = {}
    try:
        for sig in _DEFERRED_SIGNALS:
            old = signal.getsignal(sig)
            if old is signal.SIG_IGN or old is None:  # ignored (or set outside Python): keep
                continue
            previous[sig] = old
            signal.signal(sig, record)
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        for sig in dict.fromkeys(caught):
            signal.raise_signal(sig)


def remove_result(path: Path, marker: str) -> None:
    """Remove the result folder ``path`` (not following links), its ``marker`` file last."""
    try:
        entries = list(os.scandir(path))
    except OSError:
        return
    for entry in entries:
        if entry.name == marker:
            continue
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path, ignore_errors=True)
            else:
                os.unlink(entry.path)
        except OSError:
            pass
    with contextlib.suppress(OSError):
        os.unlink(os.path.join(path, marker))
    with contextlib.suppress(OSError):
        os.rmdir(path)
