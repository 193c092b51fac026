"""``dampfit report DIR [--force] [--no-redraw]``: report.html and report.md of a result folder
(:func:`dampfit.output.report.write_report`).

Figures the folder lacks (deleted, or never drawn: ``analyze --no-figures``, a folder saved
from Python without figures) are first redrawn from the folder's own summary.json, signals.npz
and posterior.nc (:func:`dampfit.output.figures.redraw_missing`), so the report shows them; a
figure whose data the folder lacks is named in one note line. Only a folder dampfit wrote (its
marker) is drawn into; a figure file that exists is never replaced.
"""

from __future__ import annotations

import argparse
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``dampfit report``."""
    parser.add_argument("dir", metavar="DIR",
                        help="result folder with summary.json (from 'dampfit analyze' or 'demo')")
    parser.add_argument("--force", action="store_true",
                        help="replace report.html/report.md even if dampfit did not write them "
                             "(a report dampfit wrote is always regenerated)")
    parser.add_argument("--no-redraw", action="store_true",
                        help="do not redraw figures missing from DIR before writing the report")


def command(args) -> int:
    """Redraw missing figures, write the report; exit code 0."""
    from dampfit.files.folder import read_marker
    from dampfit.output.report import write_report
    from dampfit.result.schema import folder_of

    folder = folder_of(args.dir)
    from dampfit.result.folder import check_files

    check_files(folder)  # a posterior.nc or signals.npz of another analysis: refused
    if not args.no_redraw and read_marker(folder) is not None:
        from dampfit.output.figures import redraw_missing

        done = redraw_missing(folder)
        if done.drawn:
            print(f"redrew {len(done.drawn)} missing figure(s): "
                  + ", ".join(f"{name}.png" for name in done.drawn))
        for note in done.notes:
            print(f"dampfit: note: {note}", file=sys.stderr)
    paths = write_report(folder, force=args.force)
    print(f"wrote {paths['html']} and {paths['md']}")
    return 0
