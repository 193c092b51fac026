"""Child processes import nothing from the working folder (dampfit._child).

The figure process of ``analyze``, the OpenSees child of ``verify`` and the Dask workers of
``study`` once imported a ``json.py`` (``threading.py``, …) lying in the folder the user ran
dampfit from. Here such modules are planted in the working folder; each writes a marker file
and exits loudly if imported. The CLI is started the way its console script is (a script in
another folder, no ``-P``), so that only the children could import them.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dampfit import _child
from dampfit.output import figure_process as fp

PLANTED = ("json", "numpy", "matplotlib", "pickle", "threading")
CORES = fp._usable_cores()


def _plant(folder: Path, markers: Path) -> Path:
    folder.mkdir()
    markers.mkdir()
    for name in PLANTED:
        (folder / f"{name}.py").write_text(
            "import os, sys\n"
            f"open(os.path.join({str(markers)!r}, '{name}-%d' % os.getpid()), 'w')"
            ".write(repr(sys.argv))\n"
            f"raise SystemExit('planted {name}.py was imported')\n")
    return folder


@pytest.fixture
def hostile(tmp_path):
    """(working folder with the planted modules, marker folder, command that runs the CLI as
    the console script does: a script in its own folder; this checkout through PYTHONPATH)."""
    markers = tmp_path / "markers"
    cwd = _plant(tmp_path / "work", markers)
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    script = bin_ / "dampfit_cli.py"
    script.write_text("from dampfit.cli import run\nrun()\n")
    return cwd, markers, [sys.executable, str(script)]


def _env(**extra) -> dict:
    src = str(Path(_child.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": src, "DAMPFIT_JAX_CACHE": "off", "MPLBACKEND": "Agg"}
    env.pop("DAMPFIT_FIGURE_PROCESS", None)
    return {**env, **extra}


def _cli(cmd, args, cwd, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([*cmd, *map(str, args)], cwd=cwd, env=_env(), capture_output=True,
                          text=True, timeout=timeout, stdin=subprocess.DEVNULL)


# ----------------------------------------------------------------------------- the path
def test_import_path_drops_the_working_folder_relative_entries_and_the_script_folder(
        tmp_path, monkeypatch):
    work, lib, script_dir = tmp_path / "work", tmp_path / "lib", tmp_path / "bin"
    for d in (work, lib, script_dir):
        d.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setattr(_child, "_script_folder", lambda: str(script_dir))
    path = ["", ".", "src", str(work), str(work) + "/", str(script_dir), str(lib),
            str(work / "sub"), str(lib)]
    assert _child.import_path(path) == [str(lib), str(work / "sub")]


def test_the_script_folder_is_what_python_put_first(tmp_path):
    """A script run as ``python DIR/script.py`` has DIR first on its path; its children not."""
    (tmp_path / "bin").mkdir()
    script = tmp_path / "bin" / "s.py"
    script.write_text("import sys, json; from dampfit._child import import_path\n"
                      "print(json.dumps([sys.path[0], import_path()]))\n")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         env=_env(), cwd=tmp_path, check=True, timeout=120)
    first, child = json.loads(out.stdout)
    assert first == str(tmp_path / "bin") and first not in child
    assert str(Path(_child.__file__).resolve().parents[1]) in child  # PYTHONPATH's entry kept


def test_a_child_ignores_the_working_folder_and_pythonpath_injection(tmp_path, monkeypatch):
    markers = tmp_path / "markers"
    work = _plant(tmp_path / "work", markers)
    monkeypatch.chdir(work)
    # entries that point into the working folder, as PYTHONPATH=. or a relative entry would
    monkeypatch.setattr(sys, "path", ["", ".", str(work), *sys.path])
    code = "import json, os, sys; print(json.dumps([sys.path, sys.flags.isolated]))"
    out = subprocess.run(_child.command(code), capture_output=True, text=True, cwd=work,
                         env=_env(PYTHONPATH=str(work), PYTHONSTARTUP=str(work / "json.py")),
                         timeout=120)
    assert out.returncode == 0, out.stderr
    path, isolated = json.loads(out.stdout)
    assert isolated == 1
    assert str(work) not in path and "" not in path and "." not in path
    assert not any(markers.iterdir())


# ----------------------------------------------------------------------------- the children
@pytest.mark.heavy
@pytest.mark.skipif(CORES < 2, reason=f"the figure process needs 2 usable cores; {CORES} here")
def test_the_figure_process_started_from_a_hostile_folder_draws(tmp_path, monkeypatch):
    from dampfit import simulate as sim
    from dampfit.pipeline import analyze

    markers = tmp_path / "markers"
    monkeypatch.chdir(_plant(tmp_path / "work", markers))
    monkeypatch.delenv(fp.ENV, raising=False)
    rec = sim.recording(sim.preset("paper", duration=10.0, sample_rate=100.0, seed=3))[0]
    out = tmp_path / "figs"
    out.mkdir()
    with fp.FigureProcess.start() as figs:
        an = analyze(rec, mass=5.3, max_steps=1000, on_stage=figs.send)
        written = figs.finish(an, out)
        assert figs.drawn_by == "process"  # it ran, and imported the real modules
    assert written and not any(markers.iterdir())


@pytest.mark.heavy
@pytest.mark.skipif(CORES < 2, reason=f"the figure process needs 2 usable cores; {CORES} here")
def test_analyze_and_verify_from_a_hostile_folder_run_nothing_of_it(hostile, tmp_path,
                                                                   requires_opensees):
    from dampfit import simulate as sim

    cwd, markers, cmd = hostile
    csv = tmp_path / "rec.csv"
    sim.write_phyphox_csv(sim.recording(sim.preset("paper", duration=10.0, sample_rate=100.0,
                                                   seed=5))[0], csv)
    out = tmp_path / "result"
    run = _cli(cmd, ["analyze", csv, "--mass", "5.3", "--max-steps", "1000", "--quiet",
                     "--out", out], cwd)
    assert run.returncode == 0, run.stderr
    assert (out / "fit.png").is_file()
    run = _cli(cmd, ["verify", out], cwd)
    assert run.returncode == 0, run.stderr
    assert (out / "verification.json").is_file()
    assert sorted(p.name for p in markers.iterdir()) == []


TINY = """
[study]
name = "hostile"
replicates = 2
seed = 3
estimators = ["log_decrement"]
mass = 0.5

[grid]
zeta = [0.02]

[fixed]
f_n = 3.0
duration = 6
sample_rate = 60
"""


@pytest.mark.heavy
def test_study_workers_started_from_a_hostile_folder_run_nothing_of_it(hostile, tmp_path):
    pytest.importorskip("distributed")
    cwd, markers, cmd = hostile
    cfg = tmp_path / "tiny.toml"
    cfg.write_text(TINY)
    out = tmp_path / "study"
    proc = subprocess.Popen([*cmd, "study", str(cfg), "--out", str(out), "--workers", "1",
                             "--quiet"], cwd=cwd, env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    pids = {json.loads(line)["pid"] for line in (out / "runs.jsonl").read_text().splitlines()}
    assert len(pids) == 1 and proc.pid not in pids  # the runs ran in a worker process
    assert sorted(p.name for p in markers.iterdir()) == []


@pytest.mark.heavy
def test_study_workers_stop_when_the_study_is_killed(tmp_path):
    """``kill -9`` of ``dampfit study`` (its process only): the worker processes it started
    (in their own isolated Pythons) notice and end; nothing is left running."""
    pytest.importorskip("distributed")
    cfg = tmp_path / "tiny.toml"
    cfg.write_text(TINY.replace("replicates = 2", "replicates = 400"))
    out = tmp_path / "study"
    runs = out / "runs.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "dampfit", "study", str(cfg), "--out",
                             str(out), "--workers", "1", "--quiet"], env=_env(),
                            start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while proc.poll() is None and time.monotonic() < deadline:
            if runs.is_file() and runs.read_bytes().count(b"\n") >= 1:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the study ended before it could be killed"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 60
        while _alive_in_group(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _alive_in_group(proc.pid) == [], "worker processes outlived the killed study"
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _alive_in_group(pgid: int) -> list[int]:
    """Processes of the process group ``pgid`` that have not ended (zombies count as ended:
    a container's first process may not reap orphans)."""
    import psutil

    alive = []
    for p in psutil.process_iter():
        try:
            if os.getpgid(p.pid) == pgid and p.status() != psutil.STATUS_ZOMBIE:
                alive.append(p.pid)
        except (psutil.Error, ProcessLookupError):
            continue
    return alive
