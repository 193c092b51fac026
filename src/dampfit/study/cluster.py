"""The local Dask cluster of ``dampfit study``: worker processes that import nothing from the
working folder.

``distributed.LocalCluster`` starts its workers with :mod:`multiprocessing` ("spawn"): a
``python -c …`` whose import path begins with the working folder and honours ``PYTHONPATH``,
and which is then handed the parent's own path (the working folder again, under
``python -m``). A ``pickle.py`` or ``numpy.py`` in the folder a user runs ``dampfit study``
from would run in every worker. Here the scheduler runs in this process (as in
``LocalCluster``) and each worker is a ``distributed.Nanny`` in its own isolated Python
(:func:`dampfit._child.command`: ``python -I``, this process's import path without the
working folder). The Nanny starts and watches its worker process as ``LocalCluster``'s
nannies do (a worker that dies is restarted; a task that kills workers repeatedly fails with
``KilledWorker``); that worker inherits the isolation (``-I``) and the Nanny's import path.
A Nanny whose parent died (``kill -9`` of ``dampfit study``) stops itself within a second.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import signal
import subprocess
import time

from dampfit._child import command
from dampfit.errors import InputError

__all__ = ["local_cluster"]

#: Longest wait [s] for the local workers to connect to the scheduler.
START_TIMEOUT_S = 120.0

#: Program of a worker's Nanny process (``sys.argv[1:]``: scheduler address, JSON spec).
_BOOT = "from dampfit.study.cluster import _nanny_main; _nanny_main(sys.argv[1], sys.argv[2])"


def _nanny_main(scheduler: str, spec: str) -> None:
    """Run ``dask spec SCHEDULER --spec SPEC`` here, and stop (SIGTERM to itself: the Nanny
    closes its worker) once the parent process is gone."""
    import threading

    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="dampfit-parent-watch", daemon=True).start()
    from distributed.cli.dask_spec import main

    main([scheduler, "--spec", spec], prog_name="dask spec")


def _worker_class():
    from distributed.deploy.spec import ProcessInterface

    class IsolatedNanny(ProcessInterface):
        """A ``distributed.Nanny`` in an isolated child process (module docstring)."""

        def __init__(self, scheduler: str, name=None, **options):
            super().__init__(scheduler=scheduler, name=name)
            self.scheduler = scheduler
            self.name = name
            self.options = {**options, "name": name}
            self.process: asyncio.subprocess.Process | None = None

        async def start(self) -> None:
            spec = json.dumps({"cls": "distributed.Nanny", "opts": self.options})
            quiet = None if os.environ.get("DAMPFIT_DEBUG") else subprocess.DEVNULL
            self.process = await asyncio.create_subprocess_exec(
                *command(_BOOT), self.scheduler, spec, stdin=subprocess.DEVNULL,
                stdout=quiet, stderr=quiet)
            await super().start()

        async def close(self) -> None:
            proc, self.process = self.process, None
            if proc is not None and proc.returncode is None:
                proc.terminate()  # the Nanny closes its worker process, then exits
                try:
                    await asyncio.wait_for(proc.wait(), 10)
                except asyncio.TimeoutError:
                    proc.kill()
                    await proc.wait()
            await super().close()

        def exited(self) -> int | None:
            """The process's exit code once it has ended, else None."""
            proc = self.process
            return None if proc is None else proc.returncode

    return IsolatedNanny


def local_cluster(workers: int):
    """A running cluster of ``workers`` isolated worker processes (one thread each) and a
    scheduler in this process on 127.0.0.1 (module docstring). Raises :class:`InputError`
    when the workers cannot start or connect within :data:`START_TIMEOUT_S`."""
    from distributed import Scheduler, SpecCluster
    from distributed.worker_memory import parse_memory_limit

    memory = parse_memory_limit("auto", 1, workers, logger=logging.getLogger(__name__))
    options = {"nthreads": 1, "memory_limit": memory, "host": "127.0.0.1",
               "dashboard": False, "dashboard_address": None,
               "silence_logs": logging.ERROR}
    worker = {"cls": _worker_class(), "options": options}
    scheduler = {"cls": Scheduler, "options": {"host": "127.0.0.1", "dashboard": False,
                                               "dashboard_address": None}}
    cluster = SpecCluster(workers={i: dict(worker) for i in range(workers)},
                          scheduler=scheduler, silence_logs=logging.ERROR, name="dampfit")
    try:
        _wait_for_workers(cluster, workers)
    except BaseException:
        cluster.close()
        raise
    return cluster


def _wait_for_workers(cluster, n: int) -> None:
    deadline = time.monotonic() + START_TIMEOUT_S
    while len(cluster.scheduler.workers) < n:  # the scheduler runs in this process
        codes = [w.exited() for w in cluster.workers.values()]
        if codes and all(c is not None for c in codes):
            raise InputError(f"the local Dask worker processes exited (code {codes[0]}) before "
                             "connecting; run with DAMPFIT_DEBUG=1 to see their messages")
        if time.monotonic() > deadline:
            raise InputError(f"the local Dask workers did not connect within "
                             f"{START_TIMEOUT_S:g} s; run with DAMPFIT_DEBUG=1 to see their "
                             "messages")
        time.sleep(0.05)
