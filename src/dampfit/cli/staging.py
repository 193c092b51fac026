"""Result folders of ``analyze`` (one recording or a campaign of several) and ``demo``: staged,
locked, then published whole.

The folder itself is :class:`dampfit._files.ResultFolder` (marker, lock, staging, free space);
this module sizes it for the input, writes the analysis into its staging folder and
recognises a demo folder written before the marker existed.
"""

from __future__ import annotations

import os
from pathlib import Path

from dampfit._files import DEMO_MARKER, MIN_FREE, ResultFolder

__all__ = ["old_demo_folder", "result_folder", "write_campaign_outputs", "write_outputs",
           "write_report"]

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
    """The :class:`~dampfit._files.ResultFolder` of a result written to ``out``."""
    from dampfit import __version__

    need = MIN_FREE
    for path in inputs:  # results are a few times the size of the recording (2.9 MB per 0.7 MB)
        try:
            need += 5 * os.stat(path).st_size
        except OSError:
            pass  # reading reports a missing input
    return ResultFolder(out, kind=kind, force=force, protect=inputs, need_bytes=need,
                        version=__version__, note=_note, **kw)


def _note(text: str) -> None:
    """A note of the result folder (a previous result restored after a kill): printed on
    stderr after the command succeeds (a failing command prints its one error line only)."""
    from dampfit.cli import _DEFERRED

    _DEFERRED.append(f"dampfit: note: {text}")


def write_outputs(an, folder: ResultFolder, figures: bool, figure_process=None) -> None:
    """summary.json, posterior.nc, signals.npz and the figures into the staging folder; the
    figures by ``figure_process`` (:class:`dampfit.output.figure_process.FigureProcess`, which
    has drawn the early ones during the analysis) when given, else here."""
    stage = folder.stage
    with folder.writing():
        an.to_json(stage / "summary.json")
        an.to_netcdf(stage / "posterior.nc")
        an.to_signals(stage / "signals.npz")
        if figures and figure_process is not None:
            figure_process.finish(an, stage)
        elif figures:
            from dampfit.output.figures import save_figures

            save_figures(an, stage)


def write_campaign_outputs(an, folder: ResultFolder, figures: bool) -> None:
    """summary.json, posterior.nc and the campaign figures (``forest.png``, and
    ``added_mass.png`` of the added-mass design; :mod:`dampfit.output.campaign`, drawn from the
    summary) of a :class:`dampfit.campaign.analysis.CampaignAnalysis` into the staging folder."""
    stage = folder.stage
    with folder.writing():
        an.to_json(stage / "summary.json")
        an.to_netcdf(stage / "posterior.nc")
        if figures:
            from dampfit.output.campaign import save_figures

            save_figures(an.summary(), stage)


def write_report(out: Path) -> None:
    """report.html + report.md in the finished folder (the report names the folder's commands)."""
    from dampfit.output.report import write_report as write

    write(out)


# the names the CLI module used before it was split (tests and scripts refer to them)
_old_demo_folder = old_demo_folder
_result_folder = result_folder
_write_outputs = write_outputs
