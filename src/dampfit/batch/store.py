"""The batch folder: :class:`BatchStore`, the resumable store of finished rows
(:class:`dampfit.files.runlog.RunStore`): ``batch.json`` (the options, their fingerprint, the
dampfit version) and ``rows.jsonl`` (one row per finished recording, appended durably as it
arrives) in ``DIR``, beside ``results.csv``, ``summary.md``, ``comparison.png`` and ``runs/``.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from dampfit.batch.task import STATUSES
from dampfit.files.runlog import RunStore

__all__ = ["BatchConfig", "BatchStore", "OUTPUTS", "check_row"]

#: Files the batch writes (and ``--force`` removes); the run folders in ``runs/`` are each
#: replaced only when their recording is analysed again.
OUTPUTS = ("batch.json", "rows.jsonl", "results.csv", "results.parquet", "summary.md",
           "comparison.png")


class BatchConfig:
    """The options every recording of a batch is analysed and written with: a batch folder
    holds one configuration (another needs ``--force``); the recordings may change between
    runs (new ones are added, finished ones kept)."""

    name = "batch"

    def __init__(self, options: dict[str, Any], outputs: dict[str, bool]):
        self.options = dict(options)
        self.outputs = dict(outputs)
        self.source = json.dumps(self.as_dict(), sort_keys=True, default=str)

    def as_dict(self) -> dict[str, Any]:
        return {"options": self.options, "outputs": self.outputs}

    def fingerprint(self) -> str:
        return hashlib.sha256(self.source.encode()).hexdigest()


def check_row(rec: Any) -> str | None:
    """Why ``rec`` (a parsed line of rows.jsonl) is not a row :func:`~dampfit.batch.task.run_job`
    writes, or None: an object with string ``key``, ``file``, ``name`` and a known ``status``,
    whose values are JSON scalars."""
    if not isinstance(rec, dict):
        return "not a JSON object"
    for k in ("key", "file", "name"):
        if not isinstance(rec.get(k), str):
            return f"'{k}' must be a string"
    if rec.get("status") not in STATUSES:
        return f"'status' must be one of {', '.join(STATUSES)}"
    if any(isinstance(v, (dict, list)) for v in rec.values()):
        return "a value is nested"
    return None


class BatchStore(RunStore):
    """Finished rows of one batch in folder ``root``."""

    KIND = "batch"
    META = "batch.json"
    LOG = "rows.jsonl"
    OUTPUTS = OUTPUTS

    def check(self, rec: Any) -> str | None:
        return check_row(rec)

    def key(self, rec: dict[str, Any]) -> str:
        return rec["key"]
