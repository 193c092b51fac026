"""``dampfit report DIR [--force]``: report.html and report.md of a result folder
(:func:`dampfit.output.report.write_report`)."""

from __future__ import annotations

import argparse

__all__ = ["add_arguments", "command"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``dampfit report``."""
    parser.add_argument("dir", metavar="DIR",
                        help="result folder with summary.json (from 'dampfit analyze' or 'demo')")
    parser.add_argument("--force", action="store_true",
                        help="replace report.html/report.md even if dampfit did not write them "
                             "(a report dampfit wrote is always regenerated)")


def command(args) -> int:
    """Write the report; exit code 0."""
    from dampfit.output.report import write_report

    paths = write_report(args.dir, force=args.force)
    print(f"wrote {paths['html']} and {paths['md']}")
    return 0
