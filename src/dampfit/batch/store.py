"""The batch folder: :class:`BatchStore`, the resumable store of finished rows
(:class:`dampfit.files.runlog.RunStore`): ``batch.json`` (the options, their fingerprint, the
dampfit version) and ``rows.jsonl`` (one row per finished recording, appended durably as it
arrives) in ``DIR``, beside ``results.csv``, ``summary.md``, ``comparison.png`` and ``runs/``.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from typing import Any

from dampfit.batch.task import DAMPER_COLUMNS, QUANTITIES, STATUSES
from dampfit.errors import shown
from dampfit.files.runlog import RunStore

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


_HEX64 = re.compile(r"^[0-9a-f]{64}$")
#: A run folder's name as :func:`dampfit.batch.inputs.run_name` makes it.
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,95}$")
#: Longest text cell of a row [characters] (a file path, a message).
_MAX_TEXT = 8192


def _text(v: Any) -> bool:
    return isinstance(v, str) and len(v) <= _MAX_TEXT


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: Every column of a row and the values it may hold (a row of an older dampfit may lack
#: the optional ones; a column not listed is refused).
_COLUMNS: dict[str, Any] = {
    "key": lambda v: isinstance(v, str) and bool(_HEX64.match(v)),
    "file": lambda v: _text(v) and bool(v),
    "name": lambda v: isinstance(v, str) and bool(_NAME.match(v)),
    "sha256": lambda v: isinstance(v, str) and bool(_HEX64.match(v)),
    "status": lambda v: v in STATUSES,
    "message": _text,
    "mass_kg": lambda v: v is None or (_number(v) and v > 0),
    **{f"{q}_{lv}": (lambda v: v is None or _number(v))
       for q in QUANTITIES for lv in ("q05", "q50", "q95")},
    "verdict": lambda v: v is None or (_text(v) and len(v) <= 64),
    "converged": lambda v: v is None or isinstance(v, bool),
    "n_modes": lambda v: v is None or (isinstance(v, int) and not isinstance(v, bool) and v >= 0),
    "modes_f_n_hz": lambda v: v is None or _text(v),
    "seconds": lambda v: v is None or (_number(v) and v >= 0),
    "folder": None,  # None, or runs/NAME of the row's own name (checked below)
    "damper_status": lambda v: v is None or v in ("recommended", "viscous-stands", "none"),
    "damper_law": lambda v: v is None or v in ("viscous", "coulomb", "quadratic", "power"),
    **{c: (lambda v: v is None or _number(v)) for c in DAMPER_COLUMNS[2:]},
}
_REQUIRED = ("key", "file", "name", "sha256", "status", "message")


def check_row(rec: Any) -> str | None:
    """Why ``rec`` (a parsed line of rows.jsonl) is not a row :func:`~dampfit.batch.task.run_job`
    writes, or None — validated column by column as :func:`dampfit.result.schema.read_summary`
    validates a summary: an object with a 64-digit hex ``key`` and ``sha256``, a ``file``, a
    run folder ``name`` as :func:`~dampfit.batch.inputs.run_name` makes it, a known
    ``status``, a ``message``; every other column of :data:`_COLUMNS` empty or of its type
    (finite numbers, booleans, short text); ``folder`` empty or ``runs/NAME`` of its own
    name (a tampered ``../../etc`` is refused); no other column."""
    if not isinstance(rec, dict):
        return "not a JSON object"
    for k in _REQUIRED:
        if k not in rec:
            return f"no '{k}'"
    for k, v in rec.items():
        if k not in _COLUMNS:
            return f"unknown column {shown(k, 40)!r}"
        ok = _COLUMNS[k]
        if ok is not None and not ok(v):
            return f"'{k}' holds {shown(v, 60)!r}, not a value dampfit writes there"
    folder = rec.get("folder")
    if folder is not None and folder != f"runs/{rec['name']}":
        return f"'folder' must be runs/{rec['name']} or empty, not {shown(folder, 60)!r}"
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
