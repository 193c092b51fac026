"""The study folder: :class:`Store`, the resumable store of finished runs
(:class:`dampfit.files.runlog.RunStore`) whose runs are (scenario, replicate) records of
:func:`dampfit.study.task.run_task`, configured by a
:class:`~dampfit.study.config.StudyConfig`; ``study.json`` and ``runs.jsonl`` in ``DIR``.
"""

from __future__ import annotations

from typing import Any

from dampfit.files.runlog import MAX_RECORD_BYTES, RunStore

#: Files the study writes (and ``--force`` removes); nothing else in DIR is touched.
OUTPUTS = ("study.json", "runs.jsonl", "runs.csv", "runs.parquet", "aggregate.csv",
           "ranking.csv", "summary.md", "ranking.png", "coverage.png")


def check_record(rec: Any) -> str | None:
    """Why ``rec`` (a parsed line of runs.jsonl) is not a record of
    :func:`dampfit.study.task.run_task`, or None: an object with a string ``scenario``, an
    integer ``replicate`` ≥ 0, an integer ``seed`` (if present) and ``rows`` a list of objects
    whose ``estimator`` (if present) is a string and whose values are JSON scalars. (A record
    that passes but does not match a run of the configuration — another seed or estimators —
    is not used: its run is done again.)"""
    if not isinstance(rec, dict):
        return "not a JSON object"
    if not isinstance(rec.get("scenario"), str):
        return "'scenario' must be a string"
    for key in ("replicate", "seed"):
        v = rec.get(key, 0)
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            return f"'{key}' must be a non-negative integer"
    rows = rec.get("rows")
    if not isinstance(rows, list):
        return "'rows' must be a list"
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            return f"rows[{i}] must be an object"
        if not isinstance(row.get("estimator", ""), str):
            return f"rows[{i}].estimator must be a string"
        if any(isinstance(v, (dict, list)) for v in row.values()):
            return f"rows[{i}] holds a nested value"
    return None


class Store(RunStore):
    """Finished runs of one study in folder ``root`` (:class:`~dampfit.files.runlog.RunStore`)."""

    KIND = "study"
    META = "study.json"
    LOG = "runs.jsonl"
    OUTPUTS = OUTPUTS

    def check(self, rec: Any) -> str | None:
        return check_record(rec)

    def key(self, rec: dict[str, Any]) -> tuple[str, int]:
        return (rec["scenario"], rec["replicate"])
