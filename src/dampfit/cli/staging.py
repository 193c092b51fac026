"""Result folders of ``analyze`` (one recording or a campaign of several) and ``demo``: staged,
locked, then published whole.

The folder itself is :class:`dampfit.files.folder.ResultFolder` (marker, lock, staging, free space);
the result writes itself into it (``Analysis.save``, ``CampaignAnalysis.save``). This module
routes the folder's notes to the CLI's deferred messages and recognises a demo folder written
before the marker existed.
"""

from __future__ import annotations

import os
from pathlib import Path

from dampfit.files.folder import DEMO_MARKER, ResultFolder
from dampfit.files.folder import result_folder as files_result_folder

#: Every file an old demo folder (written before the .dampfit-result marker) can hold.
_DEMO_FILES = frozenset({
    DEMO_MARKER, "paper-preset.csv", "summary.json", "posterior.nc", "signals.npz",
    "report.html", "report.md",
    *(f"{n}.png" for n in ("signal", "spectrum", "fit", "displacement", "posterior", "trace",
                           "amplitude"))})


def old_demo_folder(folder: Path) -> bool:
    """An old demo's folder: only regular files, all of names a demo writes, its truth file among them."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return False
    names = set()
    for entry in entries:
        if not entry.is_file(follow_symlinks=False):
            return False
        names.add(entry.name)
    return DEMO_MARKER in names and names <= _DEMO_FILES


def result_folder(out: Path, kind: str, force: bool, inputs=(), **kw) -> ResultFolder:
    """The :class:`~dampfit.files.folder.ResultFolder` of a result written to ``out``
    (:func:`dampfit.files.folder.result_folder`), its notes printed after the command succeeds."""
    return files_result_folder(out, kind, force, inputs=inputs, note=_note, **kw)


def _note(text: str) -> None:
    """A note of the result folder (a previous result restored after a kill): printed on
    stderr after the command succeeds (a failing command prints its one error line only)."""
    from dampfit.cli import messages

    messages.defer(f"dampfit: note: {text}")
