"""``dampfit record URL --out DIR``: record a free decay from phyphox's remote access, then analyse it.

URL is the address phyphox shows under "Allow remote access" (``http://HOST:PORT``; nothing
but ``http://`` is accepted). The recording (:func:`dampfit.record.record`) clears and starts
the measurement on the phone, shows a live line on stderr (elapsed time, amplitude, state:
waiting for the release / decaying / done; only on a terminal, nothing with ``--quiet``),
stops at the end of the decay, at ``--duration`` seconds, when stop is pressed on the phone or
at Ctrl-C, then fetches the full buffers.

The result folder DIR (:class:`dampfit.files.folder.ResultFolder`, marker kind ``record``) is locked
before the phone is touched (a second ``dampfit record`` or ``analyze`` to the same DIR fails
at once, exit 2; an existing DIR is replaced only with ``--force`` and only if dampfit wrote
it). From the first sample on, the samples stream into ``DIR/recording.partial.csv``
(:class:`dampfit.record.journal.Journal`: DIR is published with it, each poll appended and
synced at least every second), so even ``kill -9`` keeps them. Then it is written in two
steps, each staged and swapped in whole:

1. ``recording.csv`` (phyphox "Raw Data" CSV) and ``recording.json`` — published as soon as
   the recording ends, before any analysis, so the recording survives whatever follows;
2. the analysis, exactly as ``dampfit analyze`` writes it (:func:`dampfit.cli.analyze.
   analyse_into`: summary.json, posterior.nc, signals.npz, figures, ``--report``), beside
   copies of the two recording files; the sensor resolution phyphox reports becomes a note of
   the recording (summary.json ``input.notes``). If the analysis fails or is interrupted, DIR
   keeps the recording alone (the error line says so); ``--no-analyze`` stops after step 1.

Exit codes: 0 success (a recording stopped by Ctrl-C is a success: Ctrl-C is how to end it
early); 2 a failure, one line — before any sample nothing is written; after samples arrived
(connection lost after the retries, garbage, a changed session, no new samples) the samples
are written first and the line names the file; 130 a second Ctrl-C during the final fetch or
the analysis, 143 SIGTERM — the recording written so far stays in DIR, and the last line says
where (``dampfit: terminated; the recording so far is kept: …``).

``dampfit record --experiment FILE`` writes dampfit's phyphox experiment (and, with segno
installed, its QR code ``FILE.qr.svg``) and says how to open it on the phone.
"""

from __future__ import annotations

import argparse
import contextlib
import shutil
import sys
from pathlib import Path

from dampfit.cli.options import real_arg, add_analysis_options, analysis_options
from dampfit.errors import DampfitError, InputError

_DURATION_MAX = 1800.0  # = dampfit.record.session.MAX_DURATION (not imported: keeps --help light)


def add_arguments(a: argparse.ArgumentParser) -> None:
    """Options of ``dampfit record``."""
    a.add_argument("url", nargs="?", metavar="URL",
                   help="the address phyphox shows under 'Allow remote access', "
                        "e.g. http://192.168.1.20:8080 (http:// only)")
    a.add_argument("--out", metavar="DIR",
                   help="result folder: recording.csv, recording.json and the analysis")
    a.add_argument("--force", action="store_true",
                   help="replace an existing output folder (or --experiment file) that dampfit "
                        "wrote")
    a.add_argument("--duration", metavar="S", default=600.0,
                   type=real_arg(f"a positive duration in seconds, at most {_DURATION_MAX:g}",
                              lambda v: 0 < v <= _DURATION_MAX),
                   help="longest recording [s] of phone time (default 600; it also bounds "
                        "the memory used)")
    a.add_argument("--timeout", metavar="S", default=5.0,
                   type=real_arg("a timeout in seconds from 0.05 to 120", lambda v: 0.05 <= v <= 120),
                   help="timeout [s] of every request to the phone (connect and each read)")
    a.add_argument("--no-analyze", action="store_true",
                   help="only record (recording.csv, recording.json); no analysis")
    a.add_argument("--experiment", metavar="FILE",
                   help="write dampfit's phyphox experiment to FILE (and its QR code, with "
                        "segno installed) and exit")
    add_analysis_options(a, quiet_help="no live line and no progress bar (errors only)")


def _experiment(args) -> int:
    from dampfit.record.experiment import write_experiment

    path, _, qr = write_experiment(args.experiment, force=args.force)
    print(f"wrote {path}: open it on the phone (send it to the phone and open it with phyphox, "
          f"then save it to the collection); {qr}; then in phyphox's menu switch on "
          "'Allow remote access' and run: dampfit record URL --out DIR")
    return 0


def _check(args):
    """The phyphox URL and the run's AnalysisOptions, both checked before recording."""
    from dampfit.record.phyphox import check_url

    if args.url is None:
        raise InputError("no URL given: give the address phyphox shows under 'Allow remote "
                         "access', e.g. dampfit record http://192.168.1.20:8080 --out DIR")
    if args.out is None:
        raise InputError("argument --out is required: the folder for the recording and its "
                         "analysis")
    url = check_url(args.url)
    return url, analysis_options(args)  # checked before recording, carried to the analysis


def command(args) -> int:
    """``dampfit record``: record, publish the recording, analyse it; the exit code."""
    if args.experiment is not None:
        if args.url is not None:
            raise InputError("give either URL (record) or --experiment FILE (write the "
                             "experiment), not both")
        return _experiment(args)
    url, options = _check(args)
    from dampfit.files.swap import signals_deferred
    from dampfit.cli.staging import result_folder
    from dampfit.record.live import LiveLine
    from dampfit.record.journal import PARTIAL, Journal
    from dampfit.record.phyphox import PhyphoxClient
    from dampfit.record.session import CSV, JSON, record, write_recording

    out = Path(args.out)
    live = LiveLine(sys.stderr, enabled=not args.quiet)
    with result_folder(out, "record", args.force) as folder:
        journal = Journal(lambda: folder.stage, lambda: _publish(folder))
        try:
            rec = record(PhyphoxClient(url, timeout=args.timeout), duration=args.duration,
                         live=live, sink=journal)
        except BaseException as exc:
            journal.close()
            if journal.published:  # kept: the samples streamed before the failure
                _kept(exc, f"the samples so far are kept in {out / PARTIAL}")
            raise
        with signals_deferred(), folder.writing():  # Ctrl-C cannot drop the recording now
            if journal.published:
                folder.restage()
            try:
                write_recording(rec, folder.stage)
            except InputError as exc:
                if journal.published:
                    raise InputError(f"{exc}; the samples are in {out / PARTIAL}") from None
                raise
            folder.publish()
            journal.close()
        kept = f"{rec.duration:.1f} s ({rec.time.size} samples) kept in {out / CSV} and {out / JSON}"
        if rec.error is not None:
            live.finish_quietly()
            raise InputError(f"{rec.error}; the {kept} (analyse them with: dampfit analyze "
                             f"{out / CSV} --out OTHER_DIR)")
        if rec.interrupt is not None and rec.stopped_by != "interrupted":
            live.finish_quietly()
            # SIGTERM or a second Ctrl-C: exit 143/130, the recording stays
            raise _kept(rec.interrupt, f"the recording so far is kept: {kept}")
        how = "Ctrl-C" if rec.stopped_by == "interrupted" else rec.stopped_by
        final = f"dampfit record: stopped ({how}); {kept}"
        if args.no_analyze:
            live.finish(final)
            return 0
        # the line is written once everything succeeded: a failure stays one line
        live.status(f"{final}; analysing (Ctrl-C aborts the analysis, the recording stays)")
        try:
            an = _analyse(args, options, folder, out, rec.notes, (CSV, JSON))
        except BaseException as exc:
            live.finish_quietly()
            _kept(exc, f"the analysis was stopped; the recording stays: {kept} (analyse it "
                       f"with: dampfit analyze {out / CSV} --out OTHER_DIR)")
            raise
    from dampfit.cli.analyze import print_result

    live.finish(final)
    print_result(an, out, args.json)
    return 0


def _publish(folder) -> None:
    """Publish the staging folder (the first streamed samples: ``recording.partial.csv``)."""
    from dampfit.files.swap import signals_deferred

    with signals_deferred(), folder.writing():
        folder.publish()


def _kept(exc: BaseException, what: str) -> BaseException:
    """``exc`` (an interrupt) with what stays on disk: the CLI's line after
    "dampfit: terminated" / "interrupted" says it instead of "no partial output was left
    behind" (:func:`dampfit.cli.interrupt_line`)."""
    if isinstance(exc, KeyboardInterrupt):
        exc.dampfit_kept = what
    return exc


def _analyse(args, options, folder, out: Path, notes, names):
    """Step 2: the analysis (under ``options``, the run's
    :class:`~dampfit._options.AnalysisOptions`) into a new staging folder beside copies of the
    recording files."""
    from dampfit.cli.analyze import figure_process, analyse_into
    from dampfit.output.report import write_report

    stage = folder.restage()
    with folder.writing():
        for name in names:
            shutil.copyfile(folder.target / name, stage / name)
    try:
        with figure_process(args) as figs, contextlib.closing(figs):
            an = analyse_into(args, folder, figs, stage / names[0],
                              options=options,
                              shown_path=folder.target / names[0], notes=tuple(notes))
            folder.publish()
    except DampfitError as exc:
        raise InputError(f"{exc} (the analysis failed; the recording is kept in "
                         f"{out / names[0]})") from None
    if args.report:
        write_report(out)
    return an
