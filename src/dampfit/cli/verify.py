"""``dampfit verify DIR``: run the identified system in OpenSeesPy and compare with the
measurement (:func:`dampfit.fem.verify.verify`)."""

from __future__ import annotations

import argparse

from dampfit.cli.options import float_arg, progress_reporting


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``dampfit verify``."""
    parser.add_argument("folder", metavar="DIR", help="dampfit result folder (summary.json, signals.npz)")
    parser.add_argument("--dt", type=float_arg, metavar="S",
                        help="time step [s] (default: from the period and the window)")
    parser.add_argument("--out", metavar="FIG",
                        help="figure file, .png/.pdf/.svg/… (default: DIR/verify.png)")
    parser.add_argument("--draws", type=int, metavar="N",
                        help="also run N posterior draws of the damper (1 <= N <= 1000) and "
                             "draw the band of their envelopes")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the choice of draws (default 0; as export --draws)")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing --out file (a link is replaced, not its target)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress lines (the runs of --draws, a measured curve's fit)")


def command(args: argparse.Namespace) -> int:
    """Verify, print the table and what was written; exit code 0."""
    from dampfit.fem.verify import table, verify

    with progress_reporting(args):
        res = verify(args.folder, args.dt, args.out, getattr(args, "force", False),
                     draws=getattr(args, "draws", None), seed=getattr(args, "seed", 0))
    print(table(res["report"]))
    print(f"\n  written {res['json']}, {res['figure']}")
    refresh = res["report_refresh"]
    if res["report_error"]:  # the verification itself is written: say so, exit 0
        print(f"  report not updated: {res['report_error']}")
    elif refresh is True:
        print(f"  report updated: {res['json'].parent / 'report.html'}")
    elif refresh:
        print(f"  report not updated: {refresh}")
    return 0
