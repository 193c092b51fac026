"""Dask for ``dampfit study`` and ``dampfit batch``: a client of an existing cluster, checked
before use (:func:`check_scheduler`, :func:`check_workers`), or of a local cluster whose worker
processes import nothing from the working folder (:func:`local_cluster`): :func:`client`.

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
import contextlib
import json
import logging
import os
import signal
import socket
import subprocess
import time
from typing import Any, TextIO

from dampfit._child import command
from dampfit.errors import InputError

#: Longest wait [s] for the local workers to connect to the scheduler.
START_TIMEOUT_S = 120.0

#: Program of a worker's Nanny process (``sys.argv[1:]``: scheduler address, JSON spec).
_BOOT = "from dampfit.cluster import nanny_main; nanny_main(sys.argv[1], sys.argv[2])"


def nanny_main(scheduler: str, spec: str) -> None:
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

        def __init__(self, scheduler: str, name=None, env=None, **options):
            super().__init__(scheduler=scheduler, name=name)
            self.scheduler = scheduler
            self.name = name
            self.env = dict(env or {})
            self.options = {**options, "name": name}
            self.process: asyncio.subprocess.Process | None = None

        async def start(self) -> None:
            spec = json.dumps({"cls": "distributed.Nanny", "opts": self.options})
            quiet = None if os.environ.get("DAMPFIT_DEBUG") else subprocess.DEVNULL
            self.process = await asyncio.create_subprocess_exec(
                *command(_BOOT), self.scheduler, spec, stdin=subprocess.DEVNULL,
                stdout=quiet, stderr=quiet, env={**os.environ, **self.env})
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
    worker = {"cls": _worker_class(), "options": {**options, "env": worker_env(workers)}}
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


#: XLA settings of a worker process that shares the processors with other workers: one
#: compute thread (XLA's thread pool otherwise spins on every core for kernels of a few
#: microseconds, and N workers each waking N threads made the small kernels of a study 10–30×
#: slower on two cores).
ONE_THREAD_XLA = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"


#: glibc's memory thresholds [bytes] of a local worker process (``MALLOC_MMAP_THRESHOLD_``,
#: ``MALLOC_TRIM_THRESHOLD_``). Dask starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536``
#: (``distributed.nanny.pre-spawn-environ``, to hand unused memory back to the system), and an
#: explicit trim threshold also switches off glibc's adaptive mmap threshold, which then stays
#: at 128 KiB: every array above that — a recording's signals, the kernels' buffers, a
#: figure's canvas — is mapped and unmapped at each use, and the heap's top is trimmed at every
#: 64 KiB. Measured on one core (the paper recording with its figures): 3.4–3.6 s of CPU per
#: analysis against 2.8–2.9 s without Dask's setting, whose resident size however crept from
#: 460 to 620 MiB over 40 recordings; with arrays up to 32 MiB from the heap and trimming above
#: 1 MiB, 2.9–3.0 s and a flat 495 MiB. Batch of 20, 2 workers, ``--summaries-only``: 20.0–20.7 s
#: (Dask's setting: 28 s). A user's own value of either variable is left as it is.
MALLOC_THRESHOLDS = {"MALLOC_MMAP_THRESHOLD_": "33554432", "MALLOC_TRIM_THRESHOLD_": "1048576"}


def worker_env(workers: int) -> dict[str, str]:
    """Environment added to each of ``workers`` local worker processes: with several workers
    and no ``XLA_FLAGS`` of the user's, :data:`ONE_THREAD_XLA` (the workers are the
    parallelism); :data:`MALLOC_THRESHOLDS` but those the user set (a Nanny takes Dask's
    ``MALLOC_TRIM_THRESHOLD_`` only where its own environment has none)."""
    env = {k: v for k, v in MALLOC_THRESHOLDS.items() if k not in os.environ}
    if workers >= 2 and "XLA_FLAGS" not in os.environ:
        env["XLA_FLAGS"] = ONE_THREAD_XLA
    return env


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


#: How long to wait for a worker to connect to an external scheduler [s].
WORKER_WAIT_S = 120.0


#: How long the scheduler has to answer a first request before it is called unreachable [s].
SCHEDULER_WAIT_S = 15.0
#: Address schemes ``--scheduler`` accepts: plain TCP, and TLS when Dask's configuration
#: holds the certificates (``distributed.comm.tls.*``).
SCHEMES = ("tcp", "tls")


def _unreachable(scheduler: str, why: str) -> InputError:
    return InputError(f"cannot reach the Dask scheduler at {scheduler} ({why}); start it with "
                      "'dask scheduler' or drop --scheduler")


def check_scheduler(scheduler: str, wait_s: float | None = None) -> dict:
    """Refuse an unusable ``--scheduler`` address before a ``Client`` exists (a failed Client
    lingers, and one connected to a server that accepts but never answers waits forever):
    the scheme must be one of :data:`SCHEMES` (``tls://`` only with Dask's TLS settings), and
    a Dask scheduler must answer an identity request within ``wait_s`` [s] (default
    :data:`SCHEDULER_WAIT_S`). Returns the connection arguments; one-line InputError else."""
    from distributed.comm.addressing import parse_address
    from distributed.security import Security

    wait_s = SCHEDULER_WAIT_S if wait_s is None else wait_s
    try:
        scheme = parse_address(scheduler)[0]
    except ValueError as exc:
        raise _unreachable(scheduler, str(exc)) from None
    if scheme not in SCHEMES:
        raise _unreachable(scheduler, f"the {scheme}:// transport is not supported by dampfit"
                                      ": give a tcp:// address, or tls:// with Dask's TLS "
                                      "settings")
    try:
        args = Security().get_connection_args("client")
    except Exception as exc:  # noqa: BLE001 - a broken TLS configuration (missing files)
        raise _unreachable(scheduler, f"Dask's TLS settings are unusable: {exc}") from None
    if scheme == "tls" and args.get("ssl_context") is None:
        raise _unreachable(scheduler, "tls:// needs Dask's TLS settings "
                                      "(distributed.comm.tls.ca-file and a client certificate); "
                                      "none are set")
    identity = _ask_identity(scheduler, args, wait_s)
    if not (isinstance(identity, dict) and identity.get("type") == "Scheduler"):
        raise _unreachable(scheduler, "the server there is not a Dask scheduler")
    return args


def _ask_identity(address: str, args: dict, wait_s: float):
    """The scheduler's answer to ``identity``, within ``wait_s`` [s] in all (connection,
    handshake and answer), asked from a thread of its own (an event loop may be running in
    this one); InputError when nothing usable arrives in time."""
    import asyncio
    import concurrent.futures

    from distributed.comm import connect

    async def ask():
        comm = await connect(address, timeout=wait_s, **args)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def run():
        return asyncio.run(asyncio.wait_for(ask(), wait_s))

    pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="dampfit-probe")
    try:
        return pool.submit(run).result(timeout=wait_s + 5)
    except (TimeoutError, asyncio.TimeoutError, concurrent.futures.TimeoutError):
        raise _unreachable(address, f"no answer within {wait_s:g} s") from None
    except Exception as exc:  # noqa: BLE001 - refused, reset, a handshake that is not Dask's
        raise _unreachable(address, f"{type(exc).__name__}: {exc}") from None
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


@contextlib.contextmanager
def client(workers: int, scheduler: str | None):
    """A Dask client of the cluster at ``scheduler`` (checked first: :func:`check_scheduler`),
    or of a new local cluster of ``workers`` isolated worker processes (:func:`local_cluster`);
    closed, and the local cluster stopped, on leaving."""
    import dask
    from distributed import Client

    if scheduler:
        check_scheduler(scheduler)
        try:
            dask_client = Client(scheduler, timeout=f"{SCHEDULER_WAIT_S:g}s")
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            # a failed Client has already made itself dask's global scheduler: undo that, or
            # every later dask computation in this process (xarray/arviz loads) tries to reach it
            dask.config.config.pop("scheduler", None)
            dask.config.config.pop("shuffle", None)
            raise _unreachable(scheduler, str(exc)) from None
        cluster = None
    else:
        cluster = local_cluster(workers)  # workers import nothing from the working folder
        try:
            dask_client = Client(cluster)
        except BaseException:
            cluster.close()
            raise
    try:
        yield dask_client
    finally:
        dask_client.close()
        if cluster is not None:
            cluster.close()


def check_workers(dask_client, scheduler: str | None, version: str, err: TextIO) -> None:
    """Refuse workers that cannot import dampfit or run another version; wait for one to join
    (an external scheduler without workers: a line on ``err``, at most :data:`WORKER_WAIT_S`)."""
    if scheduler and not dask_client.scheduler_info().get("workers"):
        print(f"dampfit: waiting for a Dask worker to connect to {scheduler} …", file=err)
        try:
            dask_client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except TimeoutError:
            raise InputError(f"no Dask worker connected to {scheduler} within {WORKER_WAIT_S:g} s; "
                             "start one with 'dask worker ADDRESS'") from None
    try:
        infos = dask_client.run(worker_info)
    except Exception as exc:  # noqa: BLE001 - any failure here means the workers are unusable
        raise InputError(f"the Dask workers cannot run dampfit ({type(exc).__name__}: {exc}); "
                         "install dampfit in the workers' environment") from None
    other = {a: i["dampfit"] for a, i in infos.items() if i["dampfit"] != version}
    if other:
        addr, v = next(iter(other.items()))
        raise InputError(f"worker {addr} runs dampfit {v}, this client {version}; install the "
                         "same version everywhere so that runs are reproducible")
    if scheduler and any(i.get("mmap_threshold") is None and i.get("trim_threshold")
                         for i in infos.values()):
        setting = " ".join(f"{k}={v}" for k, v in MALLOC_THRESHOLDS.items())
        print("dampfit: note: the Dask workers trim memory (MALLOC_TRIM_THRESHOLD_, Dask's "
              "default) with glibc's mmap threshold left at 128 KiB, which makes each analysis "
              f"1.2-1.5x slower; start them with {setting} in their environment", file=err)


def worker_info() -> dict[str, Any]:
    """Identity of the process this runs in (checked by the client before submitting)."""
    from dampfit._meta import __version__

    return {"dampfit": __version__, "pid": os.getpid(), "host": socket.gethostname(),
            "trim_threshold": os.environ.get("MALLOC_TRIM_THRESHOLD_"),
            "mmap_threshold": os.environ.get("MALLOC_MMAP_THRESHOLD_")}
