"""The study folder: resumable, append-only storage of finished runs.

Layout of ``DIR``:

* ``study.json`` — the configuration, its fingerprint and the dampfit version (written
  atomically before any run starts);
* ``runs.jsonl`` — one line per finished run (the record of
  :func:`dampfit.study.task.run_task`), appended by the client as each run completes with a
  single ``write`` followed by ``flush`` and ``fsync``. A kill can only tear the last line;
  :meth:`Store.open` cuts such a partial line off, and the reader skips lines that do not
  parse, so at most the runs in flight are lost;
* the tables and figures (written at the end, each atomically);
* ``.lock`` — held (``flock``) while a study runs, so two processes never append to the
  same folder.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from .._files import atomic_write_text, publish
from ..errors import InputError
from .config import StudyConfig

__all__ = ["OUTPUTS", "Store"]

#: Files the study writes (and ``--force`` removes); nothing else in DIR is touched.
OUTPUTS = ("study.json", "runs.jsonl", "runs.csv", "runs.parquet", "aggregate.csv",
           "ranking.csv", "summary.md", "ranking.png", "coverage.png")


class Store:
    """Finished runs of one study in folder ``root`` (see the module docstring)."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.runs_path = self.root / "runs.jsonl"
        self.meta_path = self.root / "study.json"
        self._lock_fd: int | None = None

    # -- opening ------------------------------------------------------------------------
    def open(self, cfg: StudyConfig, *, force: bool, version: str) -> None:
        """Create or reopen the folder for ``cfg``; lock it.

        An existing study with another fingerprint is an :class:`InputError` unless ``force``,
        which deletes the study's own files (and nothing else) and starts clean. A folder
        with other content but no ``study.json`` is refused unless ``force``.
        """
        if self.root.exists() and not self.root.is_dir():
            raise InputError(f"{self.root} exists and is not a directory")
        if not self.root.exists():
            if not self.root.parent.is_dir():
                raise InputError(f"output folder {self.root.parent} does not exist")
            self.root.mkdir()
            publish(self.root)
        self._lock()
        try:
            self._prepare(cfg, force, version)
        except BaseException:
            self.close()
            raise

    def _prepare(self, cfg: StudyConfig, force: bool, version: str) -> None:
        try:
            meta = self._read_meta()
        except InputError:
            if not force:
                raise
            meta = {}
        if meta is None and any(p for p in self.root.iterdir() if p.name != ".lock") and not force:
            raise InputError(f"{self.root} exists and holds no dampfit study; choose another --out "
                             "or use --force to write the study there")
        if meta is not None and meta.get("fingerprint") != cfg.fingerprint() and not force:
            raise InputError(f"{self.root} holds a study with a different configuration "
                             f"({meta.get('name', '?')!r}); use --force to discard it and restart, "
                             "or choose another --out")
        if force:
            for name in OUTPUTS:
                (self.root / name).unlink(missing_ok=True)
        elif meta is not None:
            self._repair_tail()
        self.write_meta(cfg, version)

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX: no locking
            return
        fd = os.open(self.root / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise InputError(f"another dampfit study is running in {self.root}; wait for it "
                             "or choose another --out") from None
        self._lock_fd = fd

    def close(self) -> None:
        """Release the lock."""
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None

    def _read_meta(self) -> dict | None:
        if not self.meta_path.is_file():
            return None
        try:
            return json.loads(self.meta_path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            raise InputError(f"{self.meta_path} is unreadable; use --force to restart the study") from None

    def write_meta(self, cfg: StudyConfig, version: str) -> None:
        meta = {"name": cfg.name, "fingerprint": cfg.fingerprint(), "dampfit_version": version,
                "config": cfg.as_dict(), "source": cfg.source}
        atomic_write_text(self.meta_path, json.dumps(meta, indent=2) + "\n")

    def _repair_tail(self) -> None:
        """Cut a torn last line (a kill during a write) so the next append starts a fresh line."""
        if not self.runs_path.is_file():
            return
        data = self.runs_path.read_bytes()
        if data and not data.endswith(b"\n"):
            with open(self.runs_path, "r+b") as fh:
                fh.truncate(data.rfind(b"\n") + 1)

    # -- runs ---------------------------------------------------------------------------
    def records(self) -> list[dict[str, Any]]:
        """Every complete record in ``runs.jsonl`` (a later record of the same run wins)."""
        if not self.runs_path.is_file():
            return []
        out: dict[tuple[str, int], dict] = {}
        with open(self.runs_path, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                try:
                    rec = json.loads(line)
                    key = (str(rec["scenario"]), int(rec["replicate"]))
                except (ValueError, KeyError, TypeError):
                    continue  # a torn line
                if isinstance(rec.get("rows"), list):
                    out[key] = rec
        return list(out.values())

    def append(self, record: dict[str, Any]) -> None:
        """Append one record durably (one write, flush, fsync)."""
        line = (json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n").encode()
        fd = os.open(self.runs_path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            view = memoryview(line)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        finally:
            os.close(fd)
