"""The figures drawn in a second process while the analysis runs (dampfit.output.figure_process).

The process is only an accelerator: what it writes must be byte for byte what
:func:`dampfit.output.figures.save_figures` writes here, and any failure of it must end in
the same figures drawn here, or, when the analysis itself fails, in nothing written at all.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from dampfit import simulate as sim
from dampfit.cli import main
from dampfit.output import figure_process as fp
from dampfit.output.figures import NEEDS, save_figures
from dampfit.analysis import Analysis
from dampfit.pipeline import analyze
from tests._support.figures import pngs as _pngs

#: The figures of a one-mode result (``modes`` needs several modes).
ONE_MODE = set(NEEDS) - {"modes"}

CORES = fp._usable_cores()
needs_two_cores = pytest.mark.skipif(CORES < 2, reason=f"the figure process needs 2 usable "
                                     f"cores; this machine offers {CORES}")


@pytest.fixture(scope="module")
def rec():
    return sim.recording(sim.preset("paper", duration=20.0, sample_rate=100.0, seed=4))[0]


def test_needs_name_every_figure_and_only_data_keys():
    """Every figure is drawn from plain data (issue 20): NEEDS names the data keys a stage
    delivers — the signals, the posterior and summary sections — never an Analysis field."""
    import dataclasses

    from dampfit.output.figures import FIGURES
    from dampfit.output.figures.data import DATA_KEYS

    fields = {f.name for f in dataclasses.fields(Analysis) if f.init}
    assert set(NEEDS) == {*FIGURES, "amplitude"}
    for name, need in NEEDS.items():
        assert need <= DATA_KEYS, (name, need - DATA_KEYS)
        assert not need & fields, (name, need & fields)


@pytest.mark.heavy
@needs_two_cores
def test_process_draws_the_same_files_as_here_while_the_analysis_runs(rec, tmp_path,
                                                                      monkeypatch):
    monkeypatch.delenv(fp.ENV, raising=False)
    there, here = tmp_path / "process", tmp_path / "here"
    there.mkdir()
    stages = []
    with fp.FigureProcess.start() as figs:
        figs.target(there)

        def on_stage(name, fields):
            stages.append(name)
            figs.send(name, fields)

        an = analyze(rec, mass=5.3, max_steps=2000, on_stage=on_stage)
        written = figs.finish(an, there)
        assert figs.drawn_by == "process"
    assert stages == ["fit", "posterior"]
    expected = save_figures(an, here)
    assert set(written) == set(expected)
    assert _pngs(there) == _pngs(here)
    assert sorted(p.name for p in there.iterdir()) == sorted(p.name for p in here.iterdir())


@pytest.mark.heavy
@needs_two_cores
def test_a_dead_process_means_the_figures_are_drawn_here(rec, tmp_path, monkeypatch):
    monkeypatch.delenv(fp.ENV, raising=False)
    an = analyze(rec, mass=5.3, max_steps=2000)
    with fp.FigureProcess.start() as figs:
        figs.target(tmp_path)
        figs._proc.kill()
        figs._proc.wait()
        written = figs.finish(an, tmp_path)
        assert figs.drawn_by == "here"
    assert set(written) == ONE_MODE
    assert all((tmp_path / f"{n}.png").stat().st_size > 0 for n in written)


@pytest.mark.heavy
@needs_two_cores
def test_a_process_answering_nonsense_is_not_believed(rec, tmp_path, monkeypatch):
    """A process that exits 0 with an answer that is not its success line is distrusted."""
    monkeypatch.delenv(fp.ENV, raising=False)
    an = analyze(rec, mass=5.3, max_steps=2000)
    liar = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.buffer.read(); "
                             "print('{\"ok\": true, \"written\": 7}')"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    with fp.FigureProcess(liar) as figs:
        figs.finish(an, tmp_path)
        assert figs.drawn_by == "here"
    assert set(p.stem for p in tmp_path.glob("*.png")) == ONE_MODE


@pytest.mark.heavy
def test_switched_off_by_the_environment(monkeypatch, tmp_path, rec):
    monkeypatch.setenv(fp.ENV, "0")
    with fp.FigureProcess.start() as figs:
        assert figs._proc is None
        figs.target(tmp_path)
        figs.send("fit", {"mass": 1.0})  # ignored
        an = analyze(rec, mass=5.3, max_steps=2000)
        figs.finish(an, tmp_path)
        assert figs.drawn_by == "here"
    assert set(p.stem for p in tmp_path.glob("*.png")) == ONE_MODE


def test_the_process_imports_neither_arviz_nor_pandas():
    """The process shares the cores with the analysis while both import: it is sent the
    posterior as plain arrays (``Draws``), so it needs neither arviz/xarray nor pandas (≈ 1.2 s
    of imports); the figures it draws equal those drawn here (the first test)."""
    code = ("import sys; from dampfit.output.figure_process import main; main(); "
            "print(sorted(m for m in ('arviz', 'xarray', 'pandas', 'jax') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], input=b"", capture_output=True,
                          timeout=120, env=dict(os.environ))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.decode().strip() == "[]"


def test_the_process_exits_quietly_when_its_parent_gives_up():
    """Input closed before the finished analysis arrived (the analysis failed): exit 0,
    nothing reported, nothing drawn."""
    env = dict(os.environ)
    proc = subprocess.run([sys.executable, "-m", "dampfit.output.figure_process"], input=b"",
                          capture_output=True, timeout=120, env=env)
    assert proc.returncode == 0 and proc.stdout == b""


@needs_two_cores
def test_cli_failure_after_the_process_started_leaves_nothing(tmp_path, capsys, monkeypatch):
    """An analysis refused after the figure process has started and received the folder: one
    line, exit 2, no result folder, no staging folder, no process left behind."""
    monkeypatch.delenv(fp.ENV, raising=False)
    started = []
    real = fp.FigureProcess.start.__func__

    def spy(cls, *a, **kw):
        figs = real(cls, *a, **kw)
        started.append(figs)
        return figs

    monkeypatch.setattr(fp.FigureProcess, "start", classmethod(spy))
    csv = tmp_path / "quiet.csv"  # read inside the result folder: refused there
    csv.write_text("time,acc\n0,1\n0.01,x\n")
    out = tmp_path / "out"
    assert main(["analyze", str(csv), "--mass", "5.3", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dampfit: error:")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["quiet.csv"]
    assert len(started) == 1 and started[0]._proc is None  # closed, and so stopped


@pytest.mark.heavy
@needs_two_cores
def test_cli_figures_by_the_process_equal_those_drawn_here(tmp_path, monkeypatch):
    csv = tmp_path / "rec.csv"
    sim.write_phyphox_csv(
        sim.recording(sim.preset("paper", duration=20.0, sample_rate=100.0, seed=2))[0], csv)
    monkeypatch.delenv(fp.ENV, raising=False)
    args = ["analyze", str(csv), "--mass", "5.3", "--max-steps", "2000", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    monkeypatch.setenv(fp.ENV, "0")
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    a, b = _pngs(tmp_path / "a"), _pngs(tmp_path / "b")
    assert len(a) == len(ONE_MODE) and a == b
