"""Running a batch: every recording analysed independently (:func:`dampfit.batch.task.run_job`),
here or on Dask, rows stored as they finish — :func:`run_batch` (with a folder: resumable) and
:func:`analyze_many` (the Python face).

With a folder ``DIR`` (:class:`~dampfit.batch.store.BatchStore`) each finished row is appended
to ``rows.jsonl`` at once, so an interrupt (Ctrl-C, SIGTERM, a kill) loses at most the
recordings in flight; rerunning the same command skips every recording whose row is stored
with the same key (its bytes' SHA-256, mass, reading and analysis options:
:meth:`~dampfit.batch.inputs.Job.key`) unless that row ``failed`` (a bug or a dead worker,
tried again). A second batch writing the same ``DIR`` stops at once (the store's lock).

Where it runs: in this process (``workers=1``, no scheduler: the process that reads the
recordings analyses them one after the other), on a local Dask cluster of ``workers`` isolated
worker processes (:func:`dampfit.cluster.client`), on an existing cluster (``scheduler``), or
on a ``distributed.Client`` the caller passes. A Dask worker keeps its imports and compiled
kernels across recordings, and its kernels come from the compiled-kernel store
(:mod:`dampfit.inference.executables`). Workers on other machines must see ``DIR`` at the
same path (a shared file system) and run the same dampfit version (checked).
"""

from __future__ import annotations

import signal
import sys
import threading
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, NamedTuple, Sequence, TextIO

from dampfit._options import (DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, DEFAULT_SEED, AnalysisOptions,
                              SamplerSettings)
from dampfit.batch.inputs import Job, jobs as make_jobs
from dampfit.batch.store import BatchConfig, BatchStore
from dampfit.batch.table import frame, write_outputs
from dampfit.batch.task import run_job

#: Options of :func:`dampfit.pipeline.analyze` a batch passes to every recording.
ANALYSIS_OPTIONS = ("axis", "window", "band", "seed", "max_steps", "min_ess", "model",
                    "amplitude", "max_modes", "mode_of_mass")


def _dead_row(job: Job, key: str, exc: BaseException) -> dict[str, Any]:
    from dampfit.batch.task import row_of
    from dampfit.errors import shown

    return {"key": key, "file": job.file, "name": job.name, "sha256": job.sha256,
            "mass_kg": job.mass, "status": "failed", "folder": None, "seconds": None,
            "message": shown(f"{type(exc).__name__}: {exc}", 500), **row_of({})}


def execute(todo: Sequence[tuple[Job, str]], options: dict[str, Any], outputs: dict[str, bool],
            runs: Path | None, on_row: Callable[[dict[str, Any]], None], client=None) -> None:
    """Analyse every (job, key) of ``todo``, here (``client`` None) or on the Dask
    ``client``, calling ``on_row`` with each row as it finishes (any order)."""
    where = None if runs is None else str(runs)
    if client is None:
        for job, key in todo:
            on_row(run_job(job, key, options, outputs, where))
        return
    from distributed import as_completed

    tag = uuid.uuid4().hex[:8]
    futures = {client.submit(run_job, job, key, options, outputs, where, pure=False,
                             key=f"dampfit-batch-{i}-{tag}"): (job, key)
               for i, (job, key) in enumerate(todo)}
    for fut in as_completed(list(futures)):
        job, key = futures[fut]
        try:
            row = fut.result()
        except Exception as exc:  # noqa: BLE001 - a killed worker: a failed row, go on
            row = _dead_row(job, key, exc)
        fut.release()
        on_row(row)


class Workers(NamedTuple):
    """Where a batch runs: this process (``count`` 1, no ``scheduler``, no ``client``), a
    local cluster of ``count`` worker processes, the Dask ``scheduler`` at that address, or
    the given Dask ``client``."""

    count: int = 1
    scheduler: str | None = None
    client: Any = None


def run_batch(jobs: Sequence[Job], out: str | Path, *, options: dict[str, Any],
              outputs: dict[str, bool], workers: Workers = Workers(), force: bool = False,
              quiet: bool = False, stderr: TextIO | None = None):
    """Run (or resume) the batch of ``jobs`` into folder ``out`` on ``workers``
    (:class:`Workers`); return the results table (one row per job, in order). Raises :class:`~dampfit.errors.InputError` for a folder
    holding something else, another batch's options (unless ``force``) or a busy lock;
    ``KeyboardInterrupt`` passes through after the finished rows' tables are written."""
    from dampfit._meta import __version__
    from dampfit._progress import progress_bar

    err = stderr or sys.stderr
    cfg = BatchConfig(options, outputs)
    store = BatchStore(out)
    store.open(cfg, force=force, version=__version__, start=False)
    try:
        keys = [j.key(cfg.as_dict()) for j in jobs]
        stored = {r["key"]: r for r in store.records() if r["status"] != "failed"}
        todo = [(j, k) for j, k in zip(jobs, keys) if k not in stored]
        count, scheduler, client = workers
        if not quiet:
            where = ("this process" if client is None and scheduler is None and count <= 1
                     else scheduler or ("the given Dask client" if client is not None else
                                        f"a local cluster of {count} worker process(es)"))
            print(f"dampfit batch: {len(jobs)} recording(s), {len(jobs) - len(todo)} already "
                  f"done in {store.root}; {len(todo)} to analyse in {where}", file=err)
        rows = dict(stored)
        runs = store.root / "runs"

        def ready() -> None:  # the first write, once the workers are there (a refusal
            store.start()     # before it leaves no folder behind)
            runs.mkdir(exist_ok=True)

        with progress_bar(len(jobs), "batch", unit="recording", initial=len(jobs) - len(todo),
                          file=err, enabled=not quiet and err.isatty(), leave=True) as bar:
            def on_row(row):
                with _signals_held():  # the row is in rows.jsonl and in the table, or neither
                    rows[row["key"]] = row
                    store.append(row)
                bar.update(1)

            try:
                _run(todo, cfg, runs, on_row, ready, workers, err)
            finally:  # also on an interrupt: the tables of what is done
                if store.started:
                    done = [rows[k] for k in keys if k in rows]
                    table = write_outputs(done, store.root, version=__version__)
            if not todo:
                ready()
                table = write_outputs([rows[k] for k in keys], store.root, version=__version__)
    finally:
        store.close()
    return table


@contextmanager
def _signals_held():
    """Ctrl-C and SIGTERM wait until the block is done (delivered right after it): a row
    appended to rows.jsonl is then also in the tables written on the interrupt. Without it a
    signal between the append (an fsync) and the in-memory update left results.csv one row
    short of rows.jsonl. POSIX only; elsewhere the block runs as is."""
    mask = getattr(signal, "pthread_sigmask", None)
    if mask is None or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = mask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        mask(signal.SIG_SETMASK, old)


def _run(todo, cfg: BatchConfig, runs: Path, on_row, ready, workers: Workers,
         err: TextIO) -> None:
    """Analyse ``todo`` on ``workers`` (:func:`run_batch`); ``ready()`` before the first row."""
    if not todo:
        return
    count, scheduler, client = workers
    if client is None and scheduler is None and count <= 1:
        ready()
        execute(todo, cfg.options, cfg.outputs, runs, on_row)
        return
    if client is not None:
        ready()
        execute(todo, cfg.options, cfg.outputs, runs, on_row, client)
        return
    from dampfit._meta import __version__
    from dampfit.cluster import check_workers, client as dask_client

    with dask_client(max(1, min(count, len(todo))), scheduler) as c:
        check_workers(c, scheduler, __version__, err)
        ready()
        execute(todo, cfg.options, cfg.outputs, runs, on_row, c)


def check_read_options(read_options: dict[str, Any] | None) -> dict[str, Any]:
    """The reading options of :func:`analyze_many`: only names of
    :data:`dampfit.io.readers.READ_OPTIONS` (anything else is refused, not ignored), ``row``
    under the command line's rule (the reader checks the others' values as for one file)."""
    from dampfit._options import convert
    from dampfit.errors import InputError, shown
    from dampfit.io.readers import READ_OPTIONS

    if read_options is None:
        return {}
    if not isinstance(read_options, dict):
        raise InputError(f"read_options must be a dict, got {type(read_options).__name__}")
    unknown = [k for k in read_options if k not in READ_OPTIONS]
    if unknown:
        raise InputError(f"read_options: unknown option {shown(unknown[0])!r} (known: "
                         f"{', '.join(READ_OPTIONS)})")
    out = {k: v for k, v in read_options.items() if v is not None}
    if "row" in out:
        try:
            out["row"] = convert("row", out["row"])
        except ValueError as exc:
            raise InputError(f"read_options: row {exc}") from None
    return out


def _check_flags(flags: dict[str, Any]) -> None:
    from dampfit.errors import InputError

    for name, value in flags.items():
        if not isinstance(value, bool):
            raise InputError(f"{name} must be True or False, got {value!r}")


def analyze_many(paths: str | Sequence[str], mass: float | None = None,
                 mass_sd: float | None = None, *, masses: str | None = None,
                 out: str | Path | None = None, client=None, progress: bool = False,
                 figures: bool = False, report: bool = False, summaries_only: bool = False,
                 force: bool = False, read_options: dict[str, Any] | None = None,
                 axis: str = "auto", window=None, band=None, seed: int = DEFAULT_SEED,
                 max_steps: int = DEFAULT_MAX_STEPS, min_ess: float = DEFAULT_MIN_ESS,
                 model: str = "auto", amplitude: float | None = None,
                 max_modes: int | None = None, mode_of_mass: int | None = None):
    """Analyse many independent recordings; return the results table (a ``pandas.DataFrame``,
    one row per recording: :mod:`dampfit.batch.table`).

    ``paths``: recordings and folders of recordings (:mod:`dampfit.batch.inputs`); ``mass``
    [kg] and ``mass_sd`` [kg] for all, or ``masses`` a masses.csv; ``read_options`` as for
    :func:`dampfit.read`; the analysis options as for :func:`dampfit.analyze` (every recording
    gets the same ``seed``, so a row equals ``dampfit analyze FILE --seed SEED``). Runs in
    this process, or on the Dask ``client`` given. Without ``out`` nothing is written; with
    ``out`` it is ``dampfit batch … --out OUT`` (result folders, results.csv, resumable);
    ``figures`` draws each recording's figures into its folder (by default not: ``dampfit
    report OUT/runs/NAME`` draws them later from the saved files). Every option is checked
    as the command line checks it (one :class:`~dampfit._options.AnalysisOptions`,
    :func:`check_read_options`): a bad one is one :class:`~dampfit.errors.InputError`
    before any work, not a failed row.
    """
    if isinstance(paths, (str, Path)):
        paths = [paths]
    options = AnalysisOptions(
        axis=axis, window=window, band=band, model=model, amplitude=amplitude,
        max_modes=max_modes, mode_of_mass=mode_of_mass,
        sampler=SamplerSettings(seed=seed, max_steps=max_steps, min_ess=min_ess)).to_keywords()
    outputs = {"figures": figures, "report": report, "summaries_only": summaries_only}
    _check_flags({**outputs, "force": force, "progress": progress})
    jobs = make_jobs([str(p) for p in paths], mass=mass, mass_sd=mass_sd, masses=masses,
                     read_options=check_read_options(read_options))
    if out is not None:
        return run_batch(jobs, out, options=options, outputs=outputs,
                         workers=Workers(client=client), force=force, quiet=not progress)
    from dampfit._progress import progress_bar

    rows: dict[str, dict] = {}
    keys = [j.key({"options": options, "outputs": outputs}) for j in jobs]
    with progress_bar(len(jobs), "batch", unit="recording", enabled=progress) as bar:
        def on_row(row):
            rows[row["key"]] = row
            bar.update(1)

        execute(list(zip(jobs, keys)), options, outputs, None, on_row, client)
    return frame([rows[k] for k in keys])
