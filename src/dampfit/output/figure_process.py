"""The figures of ``dampfit analyze`` drawn in a second process while the analysis goes on.

Drawing the seven figures is the largest part of a warm ``dampfit analyze --report`` after
the analysis itself (≈ 1.2 s of ≈ 5 s on the 60 s / 500 Hz paper recording), and most of
them need only the early stages: every figure is drawn from plain data
(:class:`dampfit.output.figures.FigureData`), and the signal, spectrum, fit and displacement
figures need only what the fit stage delivers (the signals and the fit's summary sections),
the posterior and trace figures the posterior and the sampler's diagnostics, the amplitude
figure the summary (:data:`dampfit.output.figures.NEEDS`). While this process samples the
posterior — mostly one core — a second Python process draws what is ready on the other core:

1. :meth:`FigureProcess.start` starts a Python running :func:`main` before the analysis
   (isolated, with this process's import path minus the working folder:
   :func:`dampfit._child.command`); it imports matplotlib and the figure modules, overlapping
   this process's own imports, then waits on its standard input (not arviz: the posterior is
   sent as plain arrays, :class:`dampfit.output.figures.data.Draws`);
2. :meth:`FigureProcess.target` names the folder to write into (the result folder's staging
   folder), :meth:`FigureProcess.send` passes each stage's plain data as it appears
   (``dampfit.analyze(..., on_stage=…)``: ``signals`` and ``summary`` sections after the fit,
   ``posterior`` and the sampler's ``summary`` section after sampling), and the process draws
   every figure whose data have all arrived;
3. :meth:`FigureProcess.deliver` passes the finished :class:`~dampfit.analysis.Analysis`'s
   summary (and whatever was not sent before) before the result's files are written, and
   :meth:`FigureProcess.finish` draws, here and from the last figure backwards, the figures
   the process has not yet taken (each figure is drawn by whichever process first creates
   its claim file, :func:`dampfit.output.figures.claim_in`: the process is usually a figure
   or two behind when the analysis ends, and this one would otherwise only wait), then
   waits for the process and returns the files written.

Messages are pickles, each preceded by its length (8 bytes, big-endian), written to the
process's standard input; the process answers with one JSON line on its standard output and
exits. It is only an accelerator: the figures are those :func:`dampfit.output.figures.save_figures`
draws, and if the process cannot be started, dies, answers anything but success or does not
answer within :data:`TIMEOUT_S`, :meth:`finish` draws them all here instead (an error of the
drawing itself then surfaces here as it would without the process). It is not used with fewer
than two usable cores, or when ``DAMPFIT_FIGURE_PROCESS=0``. The pickles never leave the
pipe between this process and its own child.
"""

from __future__ import annotations

import json
import os
import pickle
import queue
import struct
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

#: Longest wait [s] for the process's answer after the finished analysis was sent; then it
#: is stopped and the figures are drawn here.
TIMEOUT_S = 120.0
#: Environment variable that switches the process off (``0``).
ENV = "DAMPFIT_FIGURE_PROCESS"
_HEADER = struct.Struct(">Q")
#: The process's program (run by :func:`dampfit._child.command`, which sets the path first).
_BOOT = "from dampfit.output.figure_process import main; raise SystemExit(main())"


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - platforms without affinity
        return os.cpu_count() or 1


class FigureProcess:
    """Handle of the drawing process (module docstring). Use as a context manager, or call
    :meth:`close`: a process still running is stopped."""

    def __init__(self, proc: subprocess.Popen | None, dpi: int = 110):
        self._proc = proc
        self._dpi = dpi
        self._broken = proc is None
        # messages are written by a thread: the process reads its input only once its own
        # imports are done, and a pipe holds 64 KiB, so writing here would block the analysis
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._writer: threading.Thread | None = None
        if proc is not None:
            self._writer = threading.Thread(target=self._write_loop, name="dampfit-figures",
                                            daemon=True)
            self._writer.start()
        #: Where the figures of the last :meth:`finish` came from: "process" (shared with
        #: this one: :attr:`drawn_here`) or "here" (the process failed or was not used).
        self.drawn_by: str | None = None
        self.drawn_here: list[str] = []
        self._sent: set[str] = set()  # "signals", "posterior" once a stage has sent them
        self._delivered = False  # the finished analysis was sent (deliver)

    # ------------------------------------------------------------------ life cycle
    @classmethod
    def start(cls, dpi: int = 110) -> "FigureProcess":
        """Start the drawing process (a handle that draws here when it cannot be used)."""
        if os.environ.get(ENV, "1").strip() == "0" or _usable_cores() < 2:
            return cls(None, dpi)
        # the process imports from this process's sys.path: this very dampfit and its
        # libraries, whatever put them there (an editable install, a script's path edits),
        # but never from the working folder (dampfit._child)
        from dampfit._child import command

        try:
            proc = subprocess.Popen(command(_BOOT),
                                    stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, close_fds=True)
        except OSError:
            proc = None
        return cls(proc, dpi)

    def __enter__(self) -> "FigureProcess":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the process if it still runs (an analysis that failed: nothing more is drawn)."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        self._broken = True
        self._queue.put(None)
        if proc.poll() is None:
            proc.kill()  # first: a write blocked on the full pipe then fails and lets go
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - a process that ignores SIGKILL
            pass
        if self._writer is not None:
            self._writer.join(10)
        for stream in (proc.stdin, proc.stdout):
            try:
                stream.close()
            except (OSError, ValueError):
                pass

    # ------------------------------------------------------------------ messages
    def _write(self, message: dict[str, Any]) -> None:
        """Queue ``message`` pickled now (the objects may change later) for the writer."""
        if self._broken or self._proc is None:
            return
        try:
            data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:  # noqa: BLE001 - any failure: draw here at the end
            self._broken = True
            return
        self._queue.put(_HEADER.pack(len(data)) + data)

    def _write_loop(self) -> None:
        stdin = self._proc.stdin
        while True:
            data = self._queue.get()
            if data is None:
                return
            try:
                stdin.write(data)
                stdin.flush()
            except Exception:  # noqa: BLE001 - the process is gone: draw here at the end
                self._broken = True
                return

    def _drain(self, timeout: float) -> bool:
        """Let the writer pass every queued message on; False if it could not."""
        if self._writer is None:
            return False
        self._queue.put(None)
        self._writer.join(timeout)
        return not self._writer.is_alive() and not self._broken

    def target(self, outdir: str | os.PathLike) -> None:
        """The folder the figures are written into."""
        self._write({"outdir": str(outdir), "dpi": self._dpi})

    def send(self, stage: str, data: dict[str, Any]) -> None:
        """The plain data the stage ``stage`` produced (the ``on_stage`` callback of
        :func:`dampfit.analyze`): ``signals``, ``posterior`` and ``summary`` sections."""
        self._sent.update(k for k in ("signals", "posterior") if data.get(k) is not None)
        self._write({"data": _plain(data)})

    def deliver(self, an, outdir: str | os.PathLike) -> None:
        """The finished analysis ``an``: send its summary (and its signals and posterior when
        no stage sent them) and the folder ``outdir``, without waiting — the process draws
        the last figures while this process writes the result's other files."""
        if self._delivered or self._broken or self._proc is None:
            return
        data = {"summary": an.summary()}
        if "signals" not in self._sent:
            data["signals"] = an.signals()
        if "posterior" not in self._sent:
            data["posterior"] = an.posterior
        self._write({"outdir": str(outdir), "dpi": self._dpi, "data": _plain(data),
                     "end": True})
        self._delivered = True

    def finish(self, an, outdir: str | os.PathLike) -> dict[str, Path]:
        """The finished analysis ``an`` (:meth:`deliver`, unless done): draw here, from the
        last figure backwards, every figure the process has not yet taken, while it draws
        from the first forwards — each figure goes to the process that first claims it
        (:func:`dampfit.output.figures.claim_in`) — then wait for the process's answer (or
        draw the rest here, module docstring); ``{name: path}`` written. The analysis process
        is otherwise idle here, and the process is often a figure or two behind."""
        from dampfit.output import figures

        self.deliver(an, outdir)
        try:
            mine: dict[str, Path | None] = {}
            if not self._broken and self._proc is not None:
                mine = figures.render(an, list(reversed(figures.FIGURES)), outdir, self._dpi,
                                      claim=figures.claim_in(outdir))
                written = self._answer() if self._drain(TIMEOUT_S) else None
                if written is not None:
                    self.drawn_by = "process"
                    self.drawn_here = sorted(n for n, p in mine.items() if p is not None)
                    names = set(written) | set(self.drawn_here)
                    return {name: Path(outdir) / f"{name}.png" for name in names}
            self.close()
            self.drawn_by, self.drawn_here = "here", list(figures.FIGURES)
            done = {n: p for n, p in mine.items() if p is not None}
            return {**done, **figures.save_figures(an, outdir, dpi=self._dpi, skip=tuple(mine))}
        finally:
            figures.release_claims(outdir)

    def _answer(self) -> list[str] | None:
        proc = self._proc
        try:
            out, _ = proc.communicate(timeout=TIMEOUT_S)  # closes its input: the last message
        except (OSError, ValueError, subprocess.TimeoutExpired):
            return None
        finally:
            self.close()
        try:
            answer = json.loads(out.decode("utf-8").strip().splitlines()[-1])
        except (ValueError, IndexError, UnicodeDecodeError):
            return None
        if proc.returncode != 0 or not isinstance(answer, dict) or answer.get("ok") is not True:
            return None
        written = answer.get("written")
        if not isinstance(written, list) or not all(isinstance(n, str) for n in written):
            return None
        return written


def _plain(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with its posterior (InferenceData) as plain arrays
    (:class:`dampfit.output.figures.data.Draws`): the process then needs neither arviz nor
    xarray to unpickle it."""
    if data.get("posterior") is None:
        return dict(data)
    from dampfit.output.figures.data import Draws

    return {**data, "posterior": Draws.of(data["posterior"])}


# ---------------------------------------------------------------------- the process itself
def _read(stream) -> dict[str, Any] | None:
    """The next message, or None at the end of the input (the parent closed it or died)."""
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return None
    (size,) = _HEADER.unpack(head)
    data = stream.read(size)
    if len(data) < size:
        return None
    return pickle.loads(data)  # noqa: S301 - written by our own parent over a private pipe


def main() -> int:
    """The drawing process: import, then draw each figure once its data have arrived."""
    import gc

    import matplotlib

    matplotlib.use("Agg")
    from dampfit.output import figures
    from dampfit.output.figures import layout

    layout.text_width("0")  # font cache and text measurement: first-use costs paid now
    import scipy.ndimage  # noqa: F401 - the spectrum, fit and posterior figures' (≈ 1 s of
    import scipy.signal  # noqa: F401 - imports), paid while the analysis imports its stack
    gc.freeze()
    stdin = sys.stdin.buffer
    data = figures.FigureData()
    outdir, dpi, done, claim = None, 110, {}, None
    try:
        while True:
            msg = _read(stdin)
            if msg is None:
                return 0  # the parent gave up: nothing to report
            if msg.get("outdir", outdir) != outdir:
                outdir = msg["outdir"]
                claim = figures.claim_in(outdir)  # the parent draws the last ones too
            dpi = msg.get("dpi", dpi)
            data.add(msg.get("data", {}))
            if outdir is None:
                continue
            if msg.get("end"):
                rest = [n for n in figures.FIGURES if n not in done]
                written = figures.render(data, rest, outdir, dpi, claim=claim)
                names = sorted(n for n, p in {**done, **written}.items() if p is not None)
                sys.stdout.write(json.dumps({"ok": True, "written": names}) + "\n")
                sys.stdout.flush()
                return 0
            ready = [n for n in figures.FIGURES
                     if n not in done and figures.NEEDS[n] <= data.keys()]
            if ready:
                done.update(figures.render(data, ready, outdir, dpi, claim=claim))
    except Exception as exc:  # noqa: BLE001 - reported; the parent draws the figures itself
        text = " ".join(f"{type(exc).__name__}: {exc}".split())[:500]
        sys.stdout.write(json.dumps({"ok": False, "error": text}) + "\n")
        sys.stdout.flush()
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
