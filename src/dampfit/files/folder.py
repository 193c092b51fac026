"""Whole result folders: :class:`ResultFolder` (``dampfit analyze``/``demo``/``record``, and
:meth:`dampfit.analysis.Analysis.save`): a marker file :data:`MARKER` identifies a folder dampfit
wrote (only such a folder is ever replaced), a lock file keeps two dampfit processes from
writing the same folder, write permission and free space are checked before the work starts,
and the folder is staged beside its target and swapped in only when complete
(:mod:`dampfit.files.swap`).
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import stat
import tempfile
from collections.abc import Callable, Sequence
from typing import NamedTuple
from pathlib import Path

from dampfit.errors import InputError
from dampfit.files import swap
from dampfit.files.atomic import WriteError, atomic_write_text, error_text, os_error_in, publish
from dampfit.files.lock import FileLock, pid_alive


#: File in every result folder dampfit writes (analyze, demo): JSON ``{"kind", "dampfit"}``.
#: ``--force`` replaces only a real directory holding it.
MARKER = ".dampfit-result"
#: File of a demo folder: the truth of the simulated recording (``dampfit demo`` writes it,
#: also into old demo folders written before :data:`MARKER` existed).
DEMO_MARKER = "paper-preset.truth.json"
#: Hidden helpers beside a target ``NAME``: ``.NAME.dampfit-stage-PID-XXXX`` (being written),
#: ``.NAME.dampfit-old-PID-XXXX`` (previous result while it is swapped out) and the lock file.
_HELPER = re.compile(r"^\.(?P<name>.+)\.dampfit-(?P<what>stage|old)-(?P<pid>\d+)-[A-Za-z0-9_]+$")
_LOCK_SUFFIX = ".dampfit-lock"
#: Free space [bytes] a result folder is assumed to need at least (posterior, signals, figures).
MIN_FREE = 50 * 2**20


def read_marker(folder: str | os.PathLike) -> dict | None:
    """The marker of a result folder dampfit wrote, or None (missing, a link, not ours):
    read by the one bounded guard (:func:`dampfit.io.bounded.read_regular`; never follows a
    link, never blocks on a FIFO)."""
    from dampfit.io.bounded import read_regular

    try:
        data = json.loads(read_regular(Path(folder) / MARKER, 4096, missing=FileNotFoundError())
                          .decode("utf-8"))
    except (OSError, InputError, ValueError, RecursionError):
        return None
    return data if isinstance(data, dict) and "kind" in data else None


class Free(NamedTuple):
    """What an existing ``out`` may be replaced without ``force``: a result whose marker's
    kind is in ``kinds``, or any folder ``legacy(out)`` says is dampfit's."""

    kinds: Sequence[str] = ()
    legacy: Callable[[Path], bool] | None = None


class ResultFolder:
    """Write a result folder so that nothing is deleted by mistake and nothing is half-written.

    Use as a context manager::

        with ResultFolder(out, kind="analyze", force=args.force, protect=[input_file]) as rf:
            ...                         # expensive work; rf.stage is the staging folder
            with rf.writing():
                write files into rf.stage
            rf.publish()                # rf.stage becomes ``out``; a previous result is removed
            ...                         # e.g. a report written into ``out``

    On entry, before any work: the parent folder must exist and be writable; ``out`` must not
    be the current folder or one of its parents, nor the folder of (or a folder above) any
    path in ``protect`` (the input); an existing ``out`` is replaced only if it is a real
    directory (not a symbolic link) holding dampfit's :data:`MARKER` and ``force`` is set (or
    it is ``free``: its marker's kind is in ``free.kinds``, or ``free.legacy(out)`` is true). A non-blocking
    exclusive lock (``.NAME.dampfit-lock`` beside ``out``) keeps a second dampfit process
    writing the same ``out`` away until this one is finished; what dead processes left is dealt
    with (:meth:`_recover`: a previous result a kill left hidden is restored, dampfit's other
    left-overs removed, ``note`` tells); the staging folder ``.NAME.dampfit-stage-PID-XXXX`` is created
    (with the marker) and the free space is checked against ``need_bytes``. Every refusal is
    an :class:`~dampfit.errors.InputError` with one line. On any exception (including
    KeyboardInterrupt) the staging folder is removed and an existing result stays untouched.
    """

    def __init__(self, target: str | os.PathLike, *, kind: str, force: bool = False,
                 protect: Sequence[str | os.PathLike] = (), need_bytes: int = MIN_FREE,
                 free: Free = Free(), version: str = "unknown",
                 note: Callable[[str], object] | None = None) -> None:
        try:
            absolute = Path(os.path.abspath(target))
            Path.cwd()
        except OSError:  # the current folder was deleted under us
            raise InputError("the current folder no longer exists; cd into an existing "
                             "folder first") from None
        if not absolute.name:
            raise InputError(f"refusing to write the output to {absolute}; choose another --out")
        if not absolute.parent.is_dir():
            raise InputError(f"output folder {absolute.parent} does not exist")
        self.parent = absolute.parent.resolve()
        self.target = self.parent / absolute.name
        self.kind, self.force, self.version = kind, force, version
        self.protect = [Path(p) for p in protect]
        self.need_bytes = int(need_bytes)
        self.free_kinds, self.legacy = tuple(free.kinds), free.legacy
        self.note = note if note is not None else (lambda text: None)
        self.stage: Path | None = None
        self.published = False
        self.replaced = False
        self._lock_path = self.parent / f".{absolute.name}{_LOCK_SUFFIX}"
        self._lock_file = FileLock(self._lock_path, busy=lambda pid: (
            f"{self.target} is being written by another dampfit process (pid {pid}); wait for "
            "it or choose another --out"))

    # ---------------------------------------------------------------- checks
    def _refuse(self, why: str) -> InputError:
        return InputError(f"refusing to replace {self.target}: {why}; choose another --out "
                          "or remove it yourself")

    def _check_protected(self) -> None:
        real = self.target.resolve()
        cwd = Path.cwd().resolve()  # exists: checked in __init__
        if real == cwd or real in cwd.parents:
            raise self._refuse("it is the current folder or contains it")
        for p in self.protect:
            p = Path(os.path.abspath(p))
            for candidate in {p, p.resolve()}:
                if real == candidate or real in candidate.parents:
                    raise self._refuse(f"it is or holds the input {p}")

    def _check_existing(self) -> bool:
        """True if ``target`` exists (and may be replaced); raise if it must not be."""
        try:
            st = os.lstat(self.target)
        except FileNotFoundError:
            return False
        except OSError as exc:
            raise InputError(f"cannot inspect {self.target}: {error_text(exc)}") from None
        if stat.S_ISLNK(st.st_mode):
            raise self._refuse("it is a symbolic link (dampfit never replaces a link or its target)")
        if not stat.S_ISDIR(st.st_mode):
            raise self._refuse("it exists and is not a directory")
        marker = read_marker(self.target)
        if marker is None and not (self.legacy is not None and self.legacy(self.target)):
            raise self._refuse(f"it was not written by dampfit (no {MARKER} marker)")
        # here the folder is dampfit's: marked, or an old folder ``legacy`` recognises
        free = marker is None or marker.get("kind") in self.free_kinds
        if not self.force and not free:
            raise InputError(f"{self.target} exists; use --force to replace it")
        return True

    # ------------------------------------------------------------------ lock
    def _lock(self) -> None:
        self._lock_file.acquire()

    def _unlock(self) -> None:
        self._lock_file.release()

    # --------------------------------------------------------------- helpers
    def _ours(self, path: Path) -> bool:
        """A real folder (not a link) holding dampfit's marker, or an old folder ``legacy``
        recognises: only such a folder is ever restored or removed."""
        try:
            if not stat.S_ISDIR(os.lstat(path).st_mode):
                return False
        except OSError:
            return False
        return read_marker(path) is not None or bool(self.legacy and self.legacy(path))

    def _recover(self) -> None:
        """Deal with what dampfit processes that died left beside the target (under the lock,
        so no live dampfit process is writing it): restore the previous result a kill left
        under ``.NAME.dampfit-old-…`` when the target is missing (the kill fell between the
        two renames of a swap without ``renameat2``), remove the other old and staging
        folders that are dampfit's; report (``note``) what was restored or left alone."""
        try:
            entries = list(os.scandir(self.parent))
        except OSError:
            return
        helpers = []
        for entry in entries:
            m = _HELPER.match(entry.name)
            if m and m["name"] == self.target.name and not pid_alive(int(m["pid"])):
                helpers.append((m["what"], int(m["pid"]), Path(entry.path)))
        olds = [(pid, path) for what, pid, path in helpers if what == "old" and self._ours(path)]
        restored = None
        if olds and not os.path.lexists(self.target):
            if len(olds) == 1:
                pid, path = olds[0]
                try:
                    swap.rename_noreplace(path, self.target)
                    restored = path
                    self.note(f"restored the previous result {self.target} from {path.name}, "
                              f"left by a dampfit process (pid {pid}) killed while replacing it")
                except OSError as exc:
                    self.note(f"could not restore the previous result {self.target} from "
                              f"{path.name}: {error_text(exc)}; rename it yourself")
            else:
                names = ", ".join(sorted(path.name for _, path in olds))
                self.note(f"{self.target} is missing and {len(olds)} earlier results of it were "
                          f"left by killed dampfit processes ({names}); none was restored: "
                          "rename the one to keep yourself")
                return
        for what, pid, path in helpers:
            if path == restored or not os.path.lexists(path):
                continue
            if self._ours(path):
                swap.remove_result(path, MARKER)
            elif what == "old":
                self.note(f"{path.name} (left by a killed dampfit process) holds no dampfit "
                          "marker: left alone; remove it yourself")

    def _make_stage(self) -> None:
        name = self.target.name
        try:
            self.stage = Path(tempfile.mkdtemp(
                prefix=f".{name}.dampfit-stage-{os.getpid()}-", dir=self.parent))
            marker = json.dumps({"kind": self.kind, "dampfit": self.version}) + "\n"
            atomic_write_text(self.stage / MARKER, marker)
            publish(self.stage)
        except OSError as exc:
            raise InputError(f"cannot write into {self.parent}: {error_text(exc)}") from None
        try:
            free = shutil.disk_usage(self.parent).free
        except OSError:  # pragma: no cover - statvfs unsupported
            return
        if free < self.need_bytes:
            raise InputError(f"not enough free space in {self.parent}: {free / 2**20:.1f} MB "
                             f"free, about {self.need_bytes / 2**20:.0f} MB needed")

    def _discard_stage(self) -> None:
        if self.stage is not None and os.path.lexists(self.stage):
            swap.remove_result(self.stage, MARKER)

    # --------------------------------------------------------------- protocol
    def __enter__(self) -> "ResultFolder":
        if not os.access(self.parent, os.W_OK | os.X_OK):
            raise InputError(f"cannot write into {self.parent}: permission denied")
        self._check_protected()
        self._lock()
        try:
            self._recover()
            self._check_existing()
            self._make_stage()
        except BaseException:
            self._discard_stage()
            self._unlock()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if not self.published:
                self._discard_stage()
        finally:
            self._unlock()

    @contextlib.contextmanager
    def writing(self):
        """Turn an I/O failure while writing into the staging folder into one InputError."""
        try:
            yield self.stage
        except InputError as exc:
            if not isinstance(exc, WriteError) or os_error_in(exc) is None:
                raise
            fate = ("the previous result is unchanged" if os.path.lexists(self.target)
                    else "nothing was written")
            raise InputError(f"cannot write {self.target}: {error_text(os_error_in(exc))}; "
                             f"{fate}") from None
        except Exception as exc:  # noqa: BLE001 - h5py/matplotlib wrap their OSErrors
            os_error = os_error_in(exc)
            if os_error is None:
                try:
                    full = shutil.disk_usage(self.parent).free < 2**20
                except OSError:
                    full = False
                if not full:
                    raise
                reason = "no space left on the device"
            else:
                reason = error_text(os_error)
            fate = ("the previous result is unchanged" if os.path.lexists(self.target)
                    else "nothing was written")
            raise InputError(f"cannot write {self.target}: {reason}; {fate}") from None

    def publish(self) -> Path:
        """Move the staging folder onto the target (replacing a previous result); return it.

        With ``renameat2(RENAME_EXCHANGE)`` (Linux) the old and new folders are swapped in one
        system call; elsewhere two renames run with the signals held back
        (:func:`dampfit.swap.signals_deferred`), and a kill between them leaves the previous
        result under ``.NAME.dampfit-old-…``, which the next run restores (:meth:`_recover`).
        The previous result is then removed, marker last, if it is still the folder checked;
        a signal that arrives meanwhile acts once both are done."""
        if self.stage is None:
            raise RuntimeError("ResultFolder.publish outside its with-block")
        existed = self._check_existing()  # nobody swapped in something foreign meanwhile
        try:
            checked = os.lstat(self.target) if existed else None
        except OSError:
            checked, existed = None, False
        old = None
        try:
            with swap.signals_deferred():  # a signal meanwhile acts once all is done
                try:
                    old = self._move_into_place(existed)
                    self.published = True
                    self.replaced = existed
                finally:
                    if old is not None:
                        self._remove_previous(old, checked)
        except OSError as exc:
            raise InputError(f"cannot move the result into place at {self.target}: "
                             f"{error_text(exc)}; the previous result is unchanged") from None
        return self.target

    def restage(self) -> Path:
        """After :meth:`publish`: a fresh staging folder for a second, fuller version of the
        same target, still under this process's lock (no other dampfit process can step in
        between). :meth:`publish` swaps it in without ``force`` (the target is the version this
        folder published); if the work fails, it is discarded and the published version stays.
        ``dampfit record`` publishes the recording first and the analysis beside it second, so
        that a failed or killed analysis never loses the recording."""
        if not self.published or self.stage is None:
            raise RuntimeError("ResultFolder.restage before publish")
        if self.kind not in self.free_kinds:
            self.free_kinds = (*self.free_kinds, self.kind)
        self.published = False
        self.stage = None
        try:
            self._make_stage()
        except BaseException:
            self._discard_stage()
            raise
        return self.stage

    def _remove_previous(self, old: Path, checked: os.stat_result | None) -> None:
        """Remove the previous result swapped out to ``old`` if it is still the folder that
        was checked and dampfit's; else leave it and say where it is."""
        try:
            same = checked is not None and os.path.samestat(checked, os.lstat(old))
        except OSError:
            same = False
        if same and self._ours(old):
            swap.remove_result(old, MARKER)
        else:  # replaced between the check and the swap: never delete what is not ours
            self.note(f"the folder that was at {self.target} was moved to {old} and left "
                      "there: it changed while the result was being written")

    def _move_into_place(self, existed: bool) -> Path | None:
        """Put the staging folder at the target; return where the previous result went."""
        if not existed:
            swap.rename_noreplace(self.stage, self.target)
            return None
        if swap.exchange(self.stage, self.target):
            return self.stage  # the staging name now holds the previous result
        old = self.parent / (f".{self.target.name}.dampfit-old-{os.getpid()}-"
                             f"{secrets.token_hex(4)}")
        os.rename(self.target, old)
        try:
            os.rename(self.stage, self.target)
        except OSError:
            os.rename(old, self.target)
            raise
        return old


def result_folder(out: str | os.PathLike, kind: str, force: bool = False, inputs=(),
                  **kw) -> ResultFolder:
    """The :class:`ResultFolder` of a result written to ``out``, sized for its ``inputs``
    (results are a few times the size of the recording: 2.9 MB per 0.7 MB) and protecting
    them (``out`` may not be or hold the folder of an input)."""
    from dampfit._meta import __version__

    need = MIN_FREE
    for path in inputs:
        try:
            need += 5 * os.stat(path).st_size
        except OSError:
            pass  # reading reports a missing input
    return ResultFolder(out, kind=kind, force=force, protect=inputs, need_bytes=need,
                        version=__version__, **kw)


