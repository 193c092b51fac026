"""Progress a person can trust (issue 36): the long stages of ``dampfit analyze`` report a
stage name, a percentage and an ETA on stderr — a tqdm bar on a terminal, a few lines a stage
anywhere else — and nothing with ``--quiet``. No timed assertions: the ETAs are checked for
their form, and the line progress is driven by a fake clock."""

from __future__ import annotations

import io
import re

import pytest

from dampfit import _progress
from dampfit import simulate as sim
from dampfit.cli import main

#: one line of a stage's progress: "viscous posterior: 50 %, ~12 s left"
ETA_LINE = re.compile(
    r"^(?P<stage>[^\n:]+(?::[^\n:%]+)?): (?P<pct>\d+) %, ~\d+(\.\d)? (s|min|h) left$", re.M)
FAST = ["--mass", "5.3", "--no-figures", "--max-modes", "1", "--model", "viscous"]


class FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_line_progress_says_each_quarter_with_its_eta_and_the_end():
    out, clock = io.StringIO(), FakeClock()
    with _progress.LineProgress(1000, "viscous posterior", out, clock=clock) as bar:
        for _ in range(10):
            clock.t += 2.0
            bar.update(100)
    lines = out.getvalue().splitlines()
    # a quarter is crossed at 300 done (6 s): 6 s × 0.7 / 0.3 = 14 s left; 800 at 16 s: 4 s
    assert lines == ["viscous posterior: 30 %, ~14 s left", "viscous posterior: 50 %, ~10 s left",
                     "viscous posterior: 80 %, ~4 s left", "viscous posterior: done in 20.0 s"]


def test_a_revised_total_moves_the_fraction_and_the_eta():
    """An adaptive sampler learns it needs 400 steps, not the 20000 allowed: the ETA follows."""
    out, clock = io.StringIO(), FakeClock()
    bar = _progress.LineProgress(20000, "modes: K = 2, posterior", out, clock=clock)
    clock.t = 10.0
    bar.update(100)
    clock.t = 12.0
    bar.total = 800  # 100 of 800 after 12 s: not a quarter yet
    bar.total = 300  # 100 of 300: a quarter crossed, ETA 12 s × 2 = 24 s
    clock.t = 20.0
    bar.update(100)  # 200 of 300: the half, 20 s × 0.33 / 0.67 = 10 s left
    bar.close()
    bar.close()  # once only
    assert out.getvalue().splitlines() == ["modes: K = 2, posterior: 33 %, ~24 s left",
                                           "modes: K = 2, posterior: 67 %, ~10 s left",
                                           "modes: K = 2, posterior: done in 20.0 s"]


def test_reporting_chooses_bars_on_a_terminal_and_lines_elsewhere():
    tty = _FakeTTY()
    with _progress.reporting(tty):
        with _progress.stage_bar(4, "modes: K = 1 … 4 by evidence", unit="K") as bar:
            bar.update(4)
    assert "modes: K = 1 … 4 by evidence:   0%|" in tty.getvalue()  # tqdm's bar
    log = io.StringIO()
    with _progress.reporting(log):
        with _progress.stage_bar(4, "modes: K = 1 … 4 by evidence", unit="K") as bar:
            assert isinstance(bar, _progress.LineProgress)
            bar.update(4)
    assert log.getvalue().startswith("modes: K = 1 … 4 by evidence: done in ")
    assert not _progress.active()
    silent = _progress.stage_bar(4, "nothing reported", unit="K")  # no reporting: shows nothing
    assert silent.disable
    silent.close()


def test_eta_is_rounded_as_a_person_reads_it():
    assert [_progress.eta_text(s) for s in (0.2, 25.4, 150, 7200)] == ["~1 s", "~25 s",
                                                                      "~2 min", "~2.0 h"]


class _FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    rec, _ = sim.recording(sim.preset("paper", duration=20.0, seed=5))
    path = d / "Raw Data.csv"
    sim.write_phyphox_csv(rec, path)
    return path


def test_a_log_gets_each_long_stage_as_lines_with_etas(recording, tmp_path, capsys):
    """stderr is not a terminal (captured): lines, never a bar's carriage returns."""
    assert main(["analyze", str(recording), "--out", str(tmp_path / "o"), *FAST]) == 0
    err = capsys.readouterr().err
    stages = {m["stage"] for m in ETA_LINE.finditer(err)}
    assert "viscous posterior" in stages, err
    assert "viscous posterior: done in" in err and "writing results: done in" in err
    assert "\r" not in err
    # a sensible rate: at most three ETA lines and one end line per stage
    for stage in stages:
        assert len(re.findall(rf"^{re.escape(stage)}: \d+ %", err, re.M)) <= 3


def test_quiet_prints_no_progress(recording, tmp_path, capsys):
    assert main(["analyze", str(recording), "--out", str(tmp_path / "o"), "--quiet",
                 *FAST]) == 0
    err = capsys.readouterr().err
    assert not ETA_LINE.search(err) and "done in" not in err and "compiling kernel" not in err


def test_a_terminal_gets_a_bar(recording, tmp_path, capsys, monkeypatch):
    tty = _FakeTTY()
    monkeypatch.setattr("sys.stderr", tty)
    assert main(["analyze", str(recording), "--out", str(tmp_path / "o"), *FAST]) == 0
    drawn = tty.getvalue()
    assert "viscous posterior:" in drawn and "\r" in drawn and "%|" in drawn, drawn
    assert not ETA_LINE.search(drawn)  # bars, not the lines of a log


def test_a_kernel_compiled_on_a_cold_store_is_announced_with_an_estimate(tmp_path, monkeypatch):
    """The first run's compiles are said, each with this machine's last compile time of that
    kernel (none yet: said so); a kernel loaded from the store says nothing."""
    import numpy as np

    from dampfit.inference import executables

    monkeypatch.setenv(executables.ENV, str(tmp_path / "store"))

    def double(x):
        return 2.0 * x

    log = io.StringIO()
    with _progress.reporting(log):
        executables.Kernel(double)(np.ones(3))
        executables.Kernel(double)(np.ones(5))  # a new shape: compiled, estimated from the first
        executables.Kernel(double)(np.ones(3))  # a new process's view: loaded, nothing to say
    lines = log.getvalue().splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("compiling kernel double for shapes this machine has not compiled")
    assert "first compile here" in lines[0]
    assert "(input 3; " in lines[0], lines[0]  # the shape tells the two compiles apart
    assert re.search(r"\(input 5; kept for later runs; ~\d+ s: its last compile here took "
                     r"that\)$", lines[1]), lines[1]


def test_a_variants_estimate_is_its_own_and_a_kernel_that_is_not_stored_does_not_say_kept(
        tmp_path, monkeypatch):
    """The estimate of a variant is that variant's last compile (another variant's only when it
    has none, and said so); an executable that could not be stored is not announced as 'kept
    for later runs' the next time (issue 36)."""
    import numpy as np

    from dampfit.inference import executables

    monkeypatch.setenv(executables.ENV, str(tmp_path / "store"))

    def scaled(n, x):
        return n * x

    log = io.StringIO()
    with _progress.reporting(log):
        kernel = executables.Kernel(scaled, static_argnums=(0,))
        kernel(1, np.ones(3))
        kernel(2, np.ones(3))  # no compile of n=2 yet: n=1's time, said to be another's
        kernel(2, np.ones(4))  # n=2's own time now
    lines = log.getvalue().splitlines()
    assert "kept for later runs; its first compile here" in lines[0], lines
    assert "another variant of it took that here" in lines[1], lines
    assert "its last compile here took that" in lines[2], lines

    # a store that refuses every write (a full disk): compiled, not kept, and then said so
    monkeypatch.setattr(executables.PrivateStore, "write",
                        lambda self, name, body: (_ for _ in ()).throw(OSError("disk full")))
    store = executables.store()
    times = executables._compile_times(store)
    log = io.StringIO()
    with _progress.reporting(log):
        kernel = executables.Kernel(scaled, static_argnums=(0,))
        kernel(3, np.ones(3))  # first of n=3: not stored, and its time cannot be recorded
    assert "kept for later runs" in log.getvalue()  # nothing said otherwise yet
    assert executables._compile_times(store) == times

    monkeypatch.undo()
    monkeypatch.setenv(executables.ENV, str(tmp_path / "store"))
    monkeypatch.setattr(executables, "_loadable", lambda text: False)  # a host callback, say
    log = io.StringIO()
    with _progress.reporting(log):
        kernel = executables.Kernel(scaled, static_argnums=(0,))
        kernel(5, np.ones(3))  # compiled, not stored
        executables.Kernel(scaled, static_argnums=(0,))(5, np.ones(3))  # a new process: again
    lines = log.getvalue().splitlines()
    assert len(lines) == 2 and "kept for later runs" in lines[0], lines
    assert "not kept: its last compile here could not be stored" in lines[1], lines


def test_a_compile_with_no_usable_store_is_not_announced_as_kept(tmp_path, monkeypatch):
    """A store that turns unsafe while a kernel looks in it: the kernel is compiled and the
    announcement says it is not kept."""
    import numpy as np

    from dampfit.files.private import UnsafeFolder
    from dampfit.inference import executables

    monkeypatch.setenv(executables.ENV, str(tmp_path / "store"))

    def unsafe(self, name):
        raise UnsafeFolder("the folder became writable by others")

    monkeypatch.setattr(executables.PrivateStore, "read", unsafe)
    log = io.StringIO()
    with _progress.reporting(log), pytest.warns(RuntimeWarning):
        out = executables.Kernel(lambda x: 3.0 * x)(np.ones(2))
    assert np.allclose(out, 3.0)
    assert "(input 2; not kept: no usable store of compiled kernels)" in log.getvalue(), log.getvalue()


def test_a_kernel_compiled_once_per_variant_says_which_variant(tmp_path, monkeypatch):
    """A kernel with static arguments (a modal kernel: one executable per number of modes)
    names the variant it compiles, so the announcements of one run are not the same line
    repeated (issue 36)."""
    import numpy as np

    from dampfit.inference import executables

    monkeypatch.setenv(executables.ENV, str(tmp_path / "store"))

    def scaled(n, x):
        return n * x

    log = io.StringIO()
    with _progress.reporting(log):
        kernel = executables.Kernel(scaled, static_argnums=(0,))
        kernel(1, np.ones(3))
        kernel(2, np.ones(3))
    lines = log.getvalue().splitlines()
    assert [ln.split(" for ")[0] for ln in lines] == [
        "compiling kernel scaled (n=1)", "compiling kernel scaled (n=2)"], lines
