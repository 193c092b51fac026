"""``dampfit batch FILE|FOLDER… --out DIR``: many independent recordings, one results table
(:mod:`dampfit.batch`).

Each recording is analysed as ``dampfit analyze FILE`` would (same options, same seed) into
``DIR/runs/NAME`` (its figures only with ``--figures``: ``dampfit report DIR/runs/NAME``
draws them later from the saved files); ``DIR/results.csv`` (and ``.parquet`` with pyarrow)
has one row per recording, ``DIR/summary.md`` and ``DIR/comparison.png`` compare them
(always written). A row's status is ``ok`` only when a damper was recommended; else
``inconclusive`` or ``misfit`` with the verdict's reason, ``refused`` or ``failed``. Runs on a local Dask
cluster (``--workers N``, default the number of CPUs; 1: in this process) or an existing one
(``--scheduler ADDRESS``). Rerunning the same command resumes; Ctrl-C keeps every finished row.

Exit codes: 0 every recording has a row (analysed or refused by the analysis, with its
reason), 1 some failed unexpectedly (tried again by the next run), 2 bad input or usage (one
line, nothing written), 130/143 interrupted (finished rows kept).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from dampfit.cli.options import add_analysis_options, add_reading_options, analysis_options

#: Rows printed on the terminal; the rest are in results.csv.
SHOWN_ROWS = 25


def add_arguments(a: argparse.ArgumentParser) -> None:
    """Options of ``dampfit batch``."""
    from dampfit.cli.options import add_cluster_options

    a.description = ("Analyse many independent recordings (each as 'dampfit analyze' would, "
                     "same options and seed) into one folder with one results table. "
                     "Resumable: rerun the same command after an interruption.")
    a.add_argument("paths", nargs="*", metavar="FILE|FOLDER",
                   help="recordings, or folders whose recordings (by suffix, not recursive) "
                        "are all analysed")
    a.add_argument("--out", required=True, metavar="DIR",
                   help="batch folder: results.csv, summary.md, comparison.png, runs/NAME/")
    a.add_argument("--list", metavar="FILE", dest="list_file",
                   help="a text file with one recording path per line (relative to its folder)")
    a.add_argument("--masses", metavar="CSV",
                   help="per-recording masses: columns file, mass [kg], optional mass_sd [kg] "
                        "and reading options (time_column, accel_columns, …); --mass is then "
                        "the default for recordings without a row")
    add_analysis_options(a, quiet_help="no progress bar or status line")
    add_reading_options(a)
    a.add_argument("--figures", action="store_true",
                   help="also draw each recording's figures into DIR/runs/NAME (by default "
                        "not: 'dampfit report DIR/runs/NAME' draws them later from the saved "
                        "files); the batch's comparison.png and tables are always written")
    a.add_argument("--summaries-only", action="store_true",
                   help="write summary.json alone in each run folder (no posterior, signals, "
                        "figures)")
    add_cluster_options(a, workers_note="1: in this process",
                        force_help="discard the rows stored in DIR by a batch with other "
                                   "options")


def _options(args, analysis) -> tuple[dict, dict, dict]:
    """The batch's analysis keywords (of ``analysis``, the run's
    :class:`~dampfit._options.AnalysisOptions`), outputs and reading options."""
    from dampfit.cli.analyze import read_options

    options = analysis.to_keywords()
    outputs = {"figures": args.figures and not args.summaries_only,
               "report": args.report and not args.summaries_only,
               "summaries_only": args.summaries_only}
    reading = {k: v for k, v in read_options(args).items() if k != "window"}
    return options, outputs, reading


def _print(table, out: Path, as_json: bool) -> None:
    from dampfit.output.format import interval

    if as_json:
        print(table.to_json(orient="records", indent=2))
        return
    from dampfit.batch.table import ANALYSED

    q = "c" if table["c_q50"].notna().any() else "zeta"
    for _, r in table.head(SHOWN_ROWS).iterrows():
        name = str(r["name"])[:40]
        if r["status"] in ANALYSED and r[f"{q}_q50"] == r[f"{q}_q50"]:  # not NaN
            med, lo, hi = interval(r[f"{q}_q50"], r[f"{q}_q05"], r[f"{q}_q95"])
            why = "" if r["status"] == "ok" else f"  {r['status']}: {str(r['message'])[:80]}"
            print(f"  {name:40s} {q} = {med} [{lo}, {hi}]  {r['verdict'] or ''}{why}")
        else:
            print(f"  {name:40s} {r['status']}: {str(r['message'])[:100]}")
    if len(table) > SHOWN_ROWS:
        print(f"  … {len(table) - SHOWN_ROWS} more in results.csv")
    counts = table["status"].value_counts()
    n = {k: int(counts.get(k, 0)) for k in (*ANALYSED, "refused", "failed")}
    print(f"\n  {len(table)} recordings: {sum(n[k] for k in ANALYSED)} analysed ({n['ok']} "
          f"with a damper recommended, {n['inconclusive']} inconclusive, {n['misfit']} misfit), "
          f"{n['refused']} refused, {n['failed']} failed; "
          f"written to {out}/ (results.csv, summary.md, comparison.png, runs/)")


def command(args) -> int:
    """Run the batch; exit code module docstring."""
    from dampfit.batch.inputs import jobs
    from dampfit.errors import InputError

    analysis = analysis_options(args)  # built (and checked) once, before any work
    if args.figures and args.no_figures:
        raise InputError("give either --figures or --no-figures, not both (a batch draws no "
                         "per-recording figures unless --figures)")
    if args.masses is None and args.mass_sd is not None and args.mass is None:
        raise InputError("argument --mass-sd: needs --mass")
    if args.scheduler is None and (args.workers or os.cpu_count() or 1) > 1:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise InputError("dampfit batch on several workers runs on Dask: install it with "
                             "pip install 'dask[distributed]', or give --workers 1")
    options, outputs, reading = _options(args, analysis)
    todo = jobs(args.paths, list_file=args.list_file, mass=args.mass, mass_sd=args.mass_sd,
                masses=args.masses, read_options=reading)
    out = Path(args.out)
    from dampfit.batch.runner import Workers, run_batch

    try:
        table = run_batch(todo, out, options=options, outputs=outputs,
                          workers=Workers(args.workers or os.cpu_count() or 1, args.scheduler),
                          force=args.force, quiet=args.quiet)
    except KeyboardInterrupt as exc:  # the CLI's one line says what is kept
        exc.dampfit_kept = (f"finished rows are kept in {out}/rows.jsonl and {out}/results.csv; "
                            "run the same command again to resume")
        raise
    _print(table, out, args.json)
    return 1 if (table["status"] == "failed").any() else 0
