"""``dampfit study CONFIG.toml``: a resumable simulation study comparing damping estimators,
or calibrating the joint analysis of test campaigns (:func:`dampfit.study.run_study`)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``dampfit study``."""
    from dampfit.cli.options import add_cluster_options

    parser.description = (
        "Simulate every scenario of CONFIG.toml's grid, run the chosen estimators on each "
        "recording and compare them with the truth and the Cramér–Rao bound. Runs execute on "
        "Dask (local worker processes, or an existing cluster with --scheduler; workers need the "
        "same dampfit installed) and are stored as they finish: rerunning the same command "
        "resumes an interrupted study. With a [campaign] table each run simulates a campaign "
        "of several recordings of one damper and analyses it jointly; the tables then give "
        "the coverage of its intervals. See examples/study_ranking.toml and "
        "examples/study_campaign.toml.")
    parser.add_argument("config", metavar="CONFIG.toml", help="study configuration (TOML)")
    parser.add_argument("--out", metavar="DIR",
                        help="study folder (default: CONFIG's name + '.study'); reused to resume")
    add_cluster_options(parser, workers_note="never more than the runs still to do",
                        force_help="discard stored runs in DIR (even of another configuration) "
                                   "and restart")
    parser.add_argument("--quiet", action="store_true", help="no progress bar or status lines")
    parser.add_argument("--no-figures", action="store_true",
                        help="skip ranking.png and coverage.png (a campaign study: coverage.png)")


def command(args) -> int:
    """Run the study; exit code 0 done, 1 runs missing, 130 interrupted."""
    import sys

    from dampfit.study import load, run_study
    from dampfit.study.runner import StudyIncomplete

    cfg = load(args.config)
    out = Path(args.out) if args.out else Path(Path(args.config).stem + ".study")
    workers = args.workers or os.cpu_count() or 1
    try:
        run_study(cfg, out, workers=workers, scheduler=args.scheduler, force=args.force,
                  quiet=args.quiet, figures=not args.no_figures)
    except StudyIncomplete as exc:
        print(f"dampfit: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"dampfit: interrupted; finished runs are kept in {out}/runs.jsonl; run the same "
              "command again to resume", file=sys.stderr)
        return 130
    return 0
