"""Building and writing the report of a result folder.

:func:`load` reads the folder through the one reader of result folders
(:func:`dampfit.result.schema.read_summary`, bounded: :mod:`dampfit.result.files`) plus the
optional verification.json; :func:`build` chooses the single-recording
(:mod:`~dampfit.output.report.single`) or the campaign report
(:mod:`~dampfit.output.report.campaign`); :func:`write_report` renders both files
(:mod:`dampfit.output.document`) and writes them atomically — replacing a report dampfit
wrote (told by its marker, :func:`dampfit.result.files.written_by_dampfit`), any other file of
those names only with ``force``.
"""

from __future__ import annotations

import datetime as _dt
import os
from pathlib import Path
from typing import Any

from dampfit.files.atomic import atomic_write_text
from dampfit.errors import InputError
from dampfit.output.document import Block, render_html, render_markdown
from dampfit.output.report.campaign import build_campaign
from dampfit.output.report.single import build_single
from dampfit.result.files import (MAX_VERIFICATION_BYTES, REPORT_MARKERS, read_optional,
                                  written_by_dampfit)
from dampfit.result.schema import folder_of, parse_json, read_summary


def load(directory: str | os.PathLike | Any) -> dict[str, Any]:
    """Read ``DIR/summary.json`` (required; by the one reader of result folders,
    :func:`dampfit.result.schema.read_summary`) and ``DIR/verification.json`` (optional).

    ``directory`` may also be an analysis :func:`dampfit.load` read from a folder. Returns
    ``{"summary": dict, "verification": dict | None, "verification_error": str | None}``.
    """
    checked = read_summary(directory)
    summary, d = checked.data, checked.folder
    ver = summary.get("verification")
    data, err = read_optional(d / "verification.json", MAX_VERIFICATION_BYTES,
                              "'dampfit verify' writes a few kB")
    if data is not None:
        try:
            ver = parse_json(data)
        except ValueError as exc:
            ver, err = None, f"verification.json could not be read ({exc})"
    elif err is not None:
        ver, err = None, f"verification.json could not be read: {err}"
    return {"summary": summary, "verification": ver, "verification_error": err}


def build(data: dict[str, Any], directory: str | os.PathLike, now: str | None = None
          ) -> tuple[str, list[Block]]:
    """(title, blocks) of the report of ``data`` (from :func:`load`) for the folder ``directory``.

    Every warning appears once, in the box at the top; the noise level is defined once, in
    "Noise model", and the Cramér–Rao bound refers to it; every key shown has a human label.
    A campaign folder (``"kind": "campaign"``) gets the campaign report. ``now`` is the time
    the report states it was rendered (default: now, UTC)."""
    directory = Path(directory)
    now = now or _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    if data["summary"].get("kind") == "campaign":
        return build_campaign(data, directory, now)
    return build_single(data, directory, now)


def write_report(directory: str | os.PathLike | Any, *, force: bool = False) -> dict[str, Path]:
    """Write ``report.html`` and ``report.md`` into the result folder ``directory`` (or the
    folder an analysis :func:`dampfit.load` read was loaded from).

    Reads ``summary.json`` (required), ``verification.json`` and the PNG figures found there.
    A report that dampfit wrote earlier is replaced; any other file of those names only with
    ``force``. Each file is written atomically. Returns ``{"html": path, "md": path}``.
    Call it on the final folder: the commands printed in the report name it.
    """
    d = folder_of(directory)
    data = load(d)
    title, blocks = build(data, d.resolve())
    texts = {"html": render_html(title, blocks, d), "md": render_markdown(title, blocks, d)}
    paths = {"html": d / "report.html", "md": d / "report.md"}
    for key, path in paths.items():
        if os.path.lexists(path) and not force and not written_by_dampfit(
                path, REPORT_MARKERS[path.name]):
            raise InputError(f"{path} exists and was not written by dampfit; "
                             "use --force to replace it")
    try:
        for key, path in paths.items():
            atomic_write_text(path, texts[key])
    except OSError as exc:
        raise InputError(f"cannot write the report into {d}: {exc.strerror or exc}") from None
    return paths
