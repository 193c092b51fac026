"""Command-line interface: ``dampfit analyze | batch | record | simulate | demo | report | export | verify | study``.

This package is a thin layer over the library: one module per command (:mod:`.analyze` with
``demo``, :mod:`.batch`, :mod:`.record`, :mod:`.simulate`, :mod:`.report`, :mod:`.export`,
:mod:`.verify`, :mod:`.study`),
each with ``add_arguments(parser)`` and ``command(args) -> exit code``; option converters in
:mod:`.options`, result-folder staging in :mod:`.staging`. This module builds the parser,
dispatches, and owns exit codes, the one-line error contract and signal handling. No library
module imports this package.

Exit codes: 0 success (including a flagged, non-converged posterior), 2 bad input or usage
(one line on stderr, no traceback, nothing written), 1 unexpected internal error, 130/143
interrupted (Ctrl-C / SIGTERM; nothing half-written is left behind).

Every option is checked before any work: numbers must be finite and physically sensible (a
positive mass of at most 10⁶ kg, a seed in [0, 2³²), ``--window START END`` with START < END,
``--band LO HI`` with 0 < LO < HI, …).

Result folders (``analyze``, ``demo``, ``record``) are handled by
:class:`dampfit.files.folder.ResultFolder` (``record`` publishes its recording before its analysis,
see :mod:`.record`):

* each holds a marker file ``.dampfit-result`` (JSON: kind, dampfit version);
* ``--force`` replaces an existing ``--out`` only if it is a real directory (not a symbolic
  link) with that marker, and never the current folder, one of its parents, or the input
  file's folder or one of its parents; anything else is refused (exit 2) and left untouched;
* a lock file ``.NAME.dampfit-lock`` beside the folder keeps a second dampfit process writing
  the same ``--out`` away (it fails at once, exit 2);
* before the analysis the parent folder is checked for write permission and free space; the
  result is written into a staging folder ``.NAME.dampfit-stage-PID-XXXX`` beside the target
  and moved into place only when complete, so an old result is never half-overwritten; a
  failed write (full disk, read-only folder) is one line, exit 2, with the old result intact.
  Staging folders of killed dampfit processes are removed by the next run to the same target.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import threading
import traceback
import warnings
from pathlib import Path
from collections.abc import Sequence

from dampfit.cli import analyze as _analyze
from dampfit.cli import batch as _batch
from dampfit.cli import export as _export
from dampfit.cli import record as _record
from dampfit.cli import report as _report
from dampfit.cli import simulate as _simulate
from dampfit.cli import study as _study
from dampfit.cli import verify as _verify
from dampfit.cli import warm_up as _warm_up
from dampfit.cli import messages
from dampfit.cli.options import Parser as _Parser
from dampfit.errors import DampfitError, InputError

#: (command, help, add_arguments, command) of every sub-command, in the order of ``--help``.
COMMANDS = (
    ("analyze", "analyse a recording: summary.json, posterior.nc, figures",
     _analyze.add_arguments, _analyze.command),
    ("record", "record a free decay from a phone running phyphox (remote access), then analyse it",
     _record.add_arguments, _record.command),
    ("simulate", "write a synthetic phyphox CSV with known truth",
     _simulate.add_arguments, _simulate.command),
    ("demo", "simulate the paper's set-up and analyse it (the main job)",
     _analyze.add_demo_arguments, _analyze.demo),
    ("report", "write report.html and report.md for a result folder",
     _report.add_arguments, _report.command),
    ("export", "write an FEM deck (LS-DYNA, OpenSees, CalculiX) of the identified system",
     _export.add_arguments, _export.command),
    ("verify", "run the identified system in OpenSeesPy and compare with the measurement",
     _verify.add_arguments, _verify.command),
    ("batch", "analyse many recordings into one results table (Dask, resumable)",
     _batch.add_arguments, _batch.command),
    ("study", "simulation study comparing damping estimators (Dask, resumable)",
     _study.add_arguments, _study.command),
    ("warm-up", "compile the analysis kernels once per machine (a first analysis then loads them)",
     _warm_up.add_arguments, _warm_up.command),
)


#: Commands that run on Dask; the others run with Dask hidden (:func:`dampfit._arviz.dask_absent`).
DASK_COMMANDS = ("batch", "study")


def get_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``dampfit`` command (the command modules import nothing
    heavy at the top, so building it stays fast)."""
    p = _Parser(prog="dampfit", description=(
        "Damping coefficient c [N s/m], stiffness k [N/m] and initial amplitude u0 [m] "
        "from a free-decay accelerometer recording, with a Bayesian posterior."))
    from dampfit._meta import __version__

    p.add_argument("--version", action="version", version=f"dampfit {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, help_, add_arguments, _ in COMMANDS:
        add_arguments(sub.add_parser(name, help=help_))
    return p


#: The user's switch of the compiled-kernel store (:data:`dampfit.inference.executables.SWITCH`).
CACHE_ENV = "DAMPFIT_JAX_CACHE"


def _make_private(path: Path) -> list[Path]:
    """Create ``path`` and its missing parents, each 0700, after checking every folder above
    them (:func:`dampfit.files.private.open_store`); return the folders created."""
    from dampfit.files.private import open_store

    opened = open_store(path)
    opened.close()
    return opened.created


def _unsafe_cache(path: Path, created: Sequence[Path] = ()) -> str | None:
    """Why the cache folder ``path`` must not be used (others could plant code in it), or None
    (the checks of :mod:`dampfit.files.private`; ``created`` is no longer needed)."""
    from dampfit.files.private import UnsafeFolder, open_store

    try:
        open_store(path, create=False).close()
    except UnsafeFolder as exc:
        return str(exc)
    except OSError as exc:
        return f"cannot be checked ({exc.strerror or exc})"
    return None


def _compile_cache() -> Path | None:
    """Switch on dampfit's store of compiled kernels for this run and its child processes.

    A fresh process otherwise traces, lowers and compiles every kernel again (least squares,
    damping-law profiles, CRLB, sampler: ≈ 6 s of a 60 s recording's CLI run); with the store a
    second run loads them, compiled, in milliseconds (:mod:`dampfit.inference.executables`).
    Location: ``$DAMPFIT_JAX_CACHE``, else ``$XDG_CACHE_HOME/dampfit/jax`` (``~/.cache/…``);
    ``DAMPFIT_JAX_CACHE=off`` switches it off, and a ``JAX_COMPILATION_CACHE_DIR`` the user
    set is left alone (JAX's own cache then serves, and dampfit stores nothing). Executables
    loaded from the folder run as code, so it is used only if it is private all the way down
    (:mod:`dampfit.files.private`): every folder from ``/`` to it owned by the user or root
    and not writable by group or others (unless sticky, like ``/tmp``), the folder itself the
    user's own (created 0700 with its missing parents); each entry a 0600 file of the user,
    authenticated with an HMAC under a key kept in the folder. Otherwise one warning line on
    stderr after the command, and the run continues without the cache; a folder that cannot
    be created (a read-only home) silently means no cache. Passed on through the environment
    variable :data:`dampfit.inference.executables.ENV` so that Dask workers of ``dampfit
    study`` use it too (they check it again); a value of that variable set from outside is
    replaced. Size: ≈ 1 MB per kernel and shape bucket of recordings
    (:class:`dampfit.signal.prepare.Padded`); entries of other JAX or dampfit versions, another
    processor or an edited source are never read again, so deleting the folder is safe.
    """
    from dampfit.files.private import UnsafeFolder
    from dampfit.inference.executables import ENV, chosen_folder, open_checked

    os.environ.pop(ENV, None)  # only a folder checked here is passed on
    path = chosen_folder()
    if path is None:
        return None
    try:
        opened = open_checked(str(path))
    except UnsafeFolder as problem:
        messages.defer(f"dampfit: warning: JAX compilation cache {path} not used: {problem}; "
                       "cache off")
        os.environ[ENV] = ""  # and not re-checked (and warned about) by the library
        return None
    except OSError:
        os.environ[ENV] = ""
        return None  # read-only home etc.: run without the cache, only slower
    os.environ[ENV] = str(path)
    return opened.path


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that every cleanup (staging folders) runs."""


def _on_sigterm(signum, frame):
    raise _Terminated()


def _redeliver_swallowed(unraisable) -> None:
    """``sys.unraisablehook`` while the CLI runs: a SIGTERM whose exception landed inside a
    callback that cannot propagate it (JAX's gc callback, a ``__del__``) is sent again, so the
    handler runs at a point where raising works; anything else goes to the usual hook."""
    if isinstance(unraisable.exc_value, _Terminated):
        # sent from a thread a moment later: sent from here, the handler would run inside
        # this hook, where raising is swallowed again
        threading.Timer(0.01, os.kill, (os.getpid(), signal.SIGTERM)).start()
        return
    sys.__unraisablehook__(unraisable)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    installed = False
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
        previous_hook, sys.unraisablehook = sys.unraisablehook, _redeliver_swallowed
        installed = True
    try:
        return _main(argv)
    finally:
        if installed:
            signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)
            sys.unraisablehook = previous_hook


def _main(argv: Sequence[str] | None) -> int:
    messages.clear()
    with warnings.catch_warnings():
        # library warnings (NumPy overflow, emcee, JAX) are not dampfit's messages: what matters
        # reaches summary.json's warnings; DAMPFIT_DEBUG=1 shows them
        if not os.environ.get("DAMPFIT_DEBUG"):
            warnings.simplefilter("ignore")
        code = _dispatch(argv)
    if code == 0:
        messages.flush(sys.stderr)
    return code


def _dispatch(argv: Sequence[str] | None) -> int:
    try:
        _compile_cache()
        args = get_parser().parse_args(argv)
        if args.command is None:
            raise InputError("no command given; use analyze, batch, record, simulate, demo, report, "
                             "export, verify or study (see 'dampfit --help')")
        command = {name: command for name, _, _, command in COMMANDS}[args.command]
        if args.command in DASK_COMMANDS:
            return command(args)
        from dampfit._arviz import dask_absent

        with dask_absent():  # xarray's probes for Dask cost 0.3 s where none is used
            return command(args)
    except DampfitError as exc:
        print(f"dampfit: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(interrupt_line(exc), file=sys.stderr)
        return 143 if isinstance(exc, _Terminated) else 130
    except Exception as exc:  # noqa: BLE001 - the last line of defence
        if os.environ.get("DAMPFIT_DEBUG"):
            traceback.print_exc()
        print(f"dampfit: internal error: {type(exc).__name__}: {_one_line(exc)} "
              "(please report it; set DAMPFIT_DEBUG=1 for the traceback)", file=sys.stderr)
        return 1


def interrupt_line(exc: KeyboardInterrupt) -> str:
    """The line after Ctrl-C (``interrupted``) or SIGTERM (``terminated``): what a command
    kept when it set ``exc.dampfit_kept`` (``dampfit record``: the recording; ``dampfit
    batch``: the finished rows), else that nothing partial was left behind."""
    what = "terminated" if isinstance(exc, _Terminated) else "interrupted"
    kept = getattr(exc, "dampfit_kept", None)
    return _one_line(f"dampfit: {what}; {kept or 'no partial output was left behind'}")


def _one_line(exc: BaseException) -> str:
    """The message of ``exc`` on one line: a path or value holding newlines or control
    characters (a hostile folder name) cannot add lines to the one-line error contract."""
    return "".join(ch if ch.isprintable() else " " for ch in " ".join(str(exc).split()))


def run() -> None:
    """Console-script entry point.

    After an interrupt (exit 130/143) the cleanup has run inside :func:`main`; the process then
    ends at once: finalising the interpreter while XLA's threads are still mid-computation can
    crash (a segmentation fault instead of the promised exit code).
    """
    code = main()
    if code in (130, 143):
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
