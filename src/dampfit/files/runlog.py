"""A resumable, append-only store of finished runs in one folder: :class:`RunStore`.

Used by ``dampfit study`` (:class:`dampfit.study.store.Store`: one run is a simulated
scenario and replicate) and ``dampfit batch`` (:class:`dampfit.batch.store.BatchStore`: one
run is a recording). Layout of ``DIR`` (names from the subclass; a study's shown):

* ``study.json`` (:attr:`RunStore.META`) — the configuration, its fingerprint and the dampfit
  version (written atomically before any run starts);
* ``runs.jsonl`` (:attr:`RunStore.LOG`) — one line per finished run, appended by the client
  as each run completes with a single ``write`` followed by ``fsync``. A kill can only tear
  the last line; :meth:`RunStore.start` cuts such a partial line off, and the reader skips
  lines that do not parse, so at most the runs in flight are lost;
* the tables and figures (written at the end, each atomically);
* ``.lock`` — held (``flock``) while a run goes on, so two processes never append to the same
  folder (the second stops at once); removed at the end by the process that created it.

Only a new or empty folder, or one holding a store of the same kind that dampfit wrote (its
meta file), is written to; ``--force`` discards the files in :attr:`RunStore.OUTPUTS` of a
store of another configuration and nothing else. Every check comes before anything is
created. The configuration object needs ``name``, ``fingerprint()``, ``as_dict()`` and
``source``.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any

from dampfit.files.atomic import atomic_write_text, error_text, publish
from dampfit.files.folder import read_marker
from dampfit.files.lock import FileLock
from dampfit.errors import InputError

#: Largest study.json [bytes] read (the configuration and its TOML source: a few KiB).
MAX_META_BYTES = 16 * 2**20


#: Longest line of runs.jsonl [bytes]: one run's record is a few KiB.
MAX_RECORD_BYTES = 4 * 2**20


class RunStore:
    """Finished runs of one configuration in folder ``root`` (see the module docstring).
    Subclasses name the kind, the files and what a record is."""

    #: What the folder holds, in messages and in a result marker ("study", "batch").
    KIND = "study"
    #: The configuration file and the append-only log of finished runs.
    META = "study.json"
    LOG = "runs.jsonl"
    #: Files the store writes (and ``--force`` removes); nothing else in DIR is touched.
    OUTPUTS: tuple[str, ...] = ()

    def check(self, rec: Any) -> str | None:
        """Why ``rec`` (a parsed line of the log) is not a record this store writes, or None."""
        raise NotImplementedError

    def key(self, rec: dict[str, Any]) -> Any:
        """The run a record belongs to (a later record of the same run wins)."""
        raise NotImplementedError

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.runs_path = self.root / self.LOG
        self.meta_path = self.root / self.META
        self.lock_path = self.root / ".lock"
        self._lock_file = FileLock(self.lock_path, keep_foreign=True, busy=lambda pid: (
            f"another dampfit {self.KIND} is running in {self.root} (pid {pid}); wait for it "
            "or choose another --out"))
        self._created_root = False
        self._started = False
        self._discard = False
        self._cfg = None
        self._version = ""

    # -- opening ------------------------------------------------------------------------
    def open(self, cfg, *, force: bool, version: str, start: bool = True) -> None:
        """Check, then create and lock the folder for ``cfg``; with ``start`` also :meth:`start`.

        Refused (:class:`InputError`, nothing created or changed): ``root`` is not a
        directory; it holds a ``study.json`` that is not a study dampfit wrote; it holds other
        files but no study (``--force`` does not change that: it never writes into a folder
        that is not a dampfit study); it holds a study with another fingerprint and ``force``
        is not set; another process holds its lock. With ``start=False`` nothing is written
        until :meth:`start` (the runner calls it once the workers are ready), so a refusal
        later (an unreachable scheduler) leaves no trace: :meth:`close` removes the lock file
        and the folder this store created.
        """
        self._check(cfg, force)  # read-only, before anything is created
        if not os.path.lexists(self.root):
            try:
                self.root.mkdir()
                publish(self.root)
            except OSError as exc:
                raise InputError(f"cannot create {self.root}: {error_text(exc)}") from None
            self._created_root = True
        try:
            self._lock()
            self._check(cfg, force)  # again under the lock: nobody changed it meanwhile
            self._cfg, self._version, self._discard = cfg, version, force
            if start:
                self.start()
        except BaseException:
            self.close()
            raise

    @property
    def started(self) -> bool:
        """Whether :meth:`start` has written the folder (runs may be appended)."""
        return self._started

    def start(self) -> None:
        """Write the study: with ``force`` remove the study's own files of a previous
        configuration, else cut a torn last line; then write ``study.json``. Idempotent."""
        if self._started or self._cfg is None:
            return
        try:
            if self._discard:
                for name in self.OUTPUTS:
                    (self.root / name).unlink(missing_ok=True)
            else:
                self._repair_tail()
        except OSError as exc:
            raise InputError(f"cannot write into {self.root}: {error_text(exc)}") from None
        self.write_meta(self._cfg, self._version)
        self._started = True
        self._discard = False

    def _check(self, cfg, force: bool) -> None:
        """Refuse a folder this study must not write to (read-only; see :meth:`open`)."""
        try:
            st = os.stat(self.root)
        except FileNotFoundError:
            if os.path.islink(self.root):
                raise InputError(f"{self.root} is a dangling symbolic link; choose another --out") from None
            try:
                parent_ok = self.root.parent.is_dir()
            except OSError as exc:
                raise InputError(f"cannot use {self.root}: {error_text(exc)}") from None
            if not parent_ok:
                raise InputError(f"output folder {self.root.parent} does not exist")
            return
        except OSError as exc:  # a name too long, no permission, a link loop
            raise InputError(f"cannot use {self.root}: {error_text(exc)}") from None
        if not stat.S_ISDIR(st.st_mode):
            raise InputError(f"{self.root} exists and is not a directory")
        meta = self._read_meta()
        try:
            runs = os.lstat(self.runs_path)
        except FileNotFoundError:
            runs = None
        except OSError as exc:
            raise InputError(f"cannot read {self.runs_path}: {error_text(exc)}") from None
        if runs is not None and not stat.S_ISREG(runs.st_mode) and not (force and meta is not None):
            raise InputError(f"{self.runs_path} is not a regular file (a link, FIFO, socket or "
                             f"device); a {self.KIND} stores its runs only in a file it wrote: "
                             "remove it, or choose another --out")
        if meta is None:
            try:
                other = [p.name for p in self.root.iterdir() if p.name != ".lock"]
            except OSError as exc:
                raise InputError(f"cannot read {self.root}: {error_text(exc)}") from None
            marked = (read_marker(self.root) or {}).get("kind") == self.KIND
            if other and not marked:
                raise InputError(f"{self.root} exists and holds no dampfit {self.KIND} (no "
                                 f"{self.META}); dampfit writes a {self.KIND} only into a new "
                                 "or empty folder or one it wrote (even with --force): choose "
                                 "another --out")
            return
        if meta.get("fingerprint") != cfg.fingerprint():
            if not force:
                raise InputError(f"{self.root} holds a {self.KIND} with a different "
                                 f"configuration ({meta.get('name', '?')!r}); use --force to "
                                 "discard it and restart, or choose another --out")
            for name in self.OUTPUTS:  # --force removes these: only files or links, never a folder
                path = self.root / name
                if os.path.lexists(path) and not (path.is_symlink() or path.is_file()):
                    raise InputError(f"refusing to replace {path}: it is not a regular file")

    def _lock(self) -> None:
        self._lock_file.acquire()

    def close(self) -> None:
        """Release the lock; remove the lock file and an unused folder this store created."""
        self._lock_file.release()
        if self._created_root and not self._started:
            try:
                os.rmdir(self.root)  # only if still empty
            except OSError:
                pass
            self._created_root = False

    def _read_meta(self) -> dict | None:
        """The meta file as dampfit wrote it; None if there is none; refused if it is not ours."""
        from dampfit.io.bounded import read_regular

        class Absent(Exception):
            pass

        why = f"it is not a {self.KIND} file dampfit wrote"
        try:  # the one bounded guard: a regular file (no link, FIFO, device), at most the limit
            meta = json.loads(read_regular(self.meta_path, MAX_META_BYTES, missing=Absent(),
                                           describe=lambda mode: None if stat.S_ISREG(mode)
                                           else "not a regular file").decode("utf-8"))
        except Absent:
            return None
        except InputError as exc:
            why, meta = str(exc).replace(f"{self.meta_path} is ", "it is "), None
        except (ValueError, RecursionError):
            meta = None
        if isinstance(meta, dict) and isinstance(meta.get("fingerprint"), str) \
                and isinstance(meta.get("config"), dict):
            return meta
        raise InputError(f"{self.meta_path} is unusable ({why}); choose another --out or "
                         "remove it yourself")

    def write_meta(self, cfg, version: str) -> None:
        meta = {"name": cfg.name, "fingerprint": cfg.fingerprint(), "dampfit_version": version,
                "config": cfg.as_dict(), "source": cfg.source}
        atomic_write_text(self.meta_path, json.dumps(meta, indent=2) + "\n")

    def _repair_tail(self) -> None:
        """Cut a torn last line (a kill during a write) so the next append starts a fresh line."""
        if not self.runs_path.is_file():
            return
        with open(self.runs_path, "r+b") as fh:  # only the tail is read: memory stays small
            end = fh.seek(0, os.SEEK_END)
            pos = end
            while pos > 0:
                step = min(pos, 1 << 16)
                fh.seek(pos - step)
                chunk = fh.read(step)
                if pos == end and chunk.endswith(b"\n"):
                    return  # not torn
                cut = chunk.rfind(b"\n")
                if cut >= 0:
                    fh.truncate(pos - step + cut + 1)
                    return
                pos -= step
            if end:
                fh.truncate(0)  # a single torn line

    # -- runs ---------------------------------------------------------------------------
    def records(self) -> list[dict[str, Any]]:
        """Every complete record in the log (a later record of the same run wins).

        A line that does not parse is a write torn by a kill and is skipped (its run is done
        again); a line that parses but is not a record dampfit writes (:meth:`check`)
        or is longer than :data:`MAX_RECORD_BYTES` means the file was edited: refused, one
        line naming it, before anything is run or written."""
        if self._discard or not self.runs_path.is_file():  # --force: not yet removed, not used
            return []
        out: dict[Any, dict] = {}
        with open(self.runs_path, "rb") as fh:
            for number, line in enumerate(iter(lambda: fh.readline(MAX_RECORD_BYTES + 1), b""), 1):
                if len(line) > MAX_RECORD_BYTES:
                    raise self._tampered(number, f"longer than {MAX_RECORD_BYTES // 2**20} MiB")
                try:
                    rec = json.loads(line.decode("utf-8", "replace"))
                except (ValueError, RecursionError):
                    continue  # a torn line
                why = self.check(rec)
                if why is not None:
                    raise self._tampered(number, why)
                out[self.key(rec)] = rec
        return list(out.values())

    def _tampered(self, number: int, why: str) -> InputError:
        return InputError(f"{self.runs_path} line {number} is not a run record dampfit wrote "
                          f"({why}); remove that line (its run is then repeated) or restart "
                          f"the {self.KIND} with --force")

    def append(self, record: dict[str, Any]) -> None:
        """Append one record durably (one write, flush, fsync)."""
        line = (json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n").encode()
        try:
            fd = os.open(self.runs_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW,
                         0o666)
            try:
                view = memoryview(line)
                while view:
                    view = view[os.write(fd, view):]
                os.fsync(fd)
            finally:
                os.close(fd)
        except OSError as exc:  # a full disk: the runs stored so far are kept
            raise InputError(f"cannot append to {self.runs_path}: {error_text(exc)}; the runs stored "
                             "so far are kept: run the same command again to resume") from None
