"""Hostile output paths and options: ``--force`` deletes nothing dampfit did not write, two runs
never write the same folder, a failed write leaves the old result and no debris, every bad
number is one line and exit 2, and an unsafe JAX compilation cache is not used. Odd output
names: too long for the lock file or the file system, a link as ``simulate --out`` (``--force``
replaces the link, not its target), a preset name that is a path; ``simulate`` writes both its
files or neither.

Cases that must write a result share one analysis (the session's ``analysed`` fixture):
``dampfit.pipeline.analyze`` is replaced by a function returning it, so reading, the output
checks, staging, writing and publishing are the real ones.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from dampfit import cli
from dampfit import simulate as sim
from dampfit.cli import messages
from dampfit.cli import staging as cli_staging
from dampfit.errors import InputError
from dampfit.files.atomic import WriteError, atomic_write_text
from dampfit.files.folder import MARKER

from tests._support.hostile import assert_one_line_error, assert_unchanged, run, snapshot
from tests._support.hostile import LONG, decay, decay_csv, fails
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401 (autouse)


@pytest.fixture(scope="module")
def rec_bytes():
    """A 20 s simulated phyphox CSV (bytes) of the paper's set-up."""
    rec, _ = sim.recording(sim.preset("paper", duration=20.0, seed=5))
    d = Path(os.environ.get("TMPDIR", "/tmp"))
    path = d / f"dampfit-hostile-{os.getpid()}.csv"
    sim.write_phyphox_csv(rec, path)
    try:
        return path.read_bytes()
    finally:
        path.unlink()


@pytest.fixture
def work(tmp_path, rec_bytes):
    """A user's folder: the recording, notes and a sub-folder with other work."""
    (tmp_path / "rec.csv").write_bytes(rec_bytes)
    (tmp_path / "notes.txt").write_text("do not delete\n")
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "thesis.tex").write_text("\\section{Results}\n")
    return tmp_path


@pytest.fixture
def fast(monkeypatch, analysed):
    """``analyze`` returns the session's analysis at once (the writing path stays real)."""
    an, _ = analysed
    calls = []

    def fake(*args, **kwargs):
        calls.append(kwargs)
        return an

    monkeypatch.setattr("dampfit.pipeline.analyze", fake)
    return calls


def no_analysis(monkeypatch):
    """Fail the test if the expensive analysis is reached."""
    def boom(*a, **k):
        raise AssertionError("the analysis ran although the case must fail before it")

    monkeypatch.setattr("dampfit.pipeline.analyze", boom)


def analyze_argv(work, out, *extra):
    return ["analyze", work / "rec.csv", "--mass", "5.3", "--out", out, "--quiet",
            "--no-figures", *extra]


def make_result(work, name, capsys, fast) -> Path:
    """A genuine result folder written by ``dampfit analyze`` (plus a file to see it go)."""
    out = work / name
    code, _, err = run(analyze_argv(work, out), capsys)
    assert code == 0, err
    (out / "old-only.txt").write_text("from the previous run\n")
    return out


def helpers_left(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".dampfit-" in p.name)


# ----------------------------------------------------------- --force deletes nothing foreign
def test_force_out_dot_in_work_folder_deletes_nothing(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    monkeypatch.chdir(work)
    before = snapshot(work)
    code, _, err = run(["analyze", "rec.csv", "--mass", "5.3", "--out", ".", "--force", "--quiet"],
                       capsys)
    assert_one_line_error(code, err, match="current folder")
    assert_unchanged(before, snapshot(work))


def test_force_out_parent_of_cwd_refused(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    monkeypatch.chdir(work / "other")
    before = snapshot(work)
    code, _, err = run(["analyze", "../rec.csv", "--mass", "5.3", "--out", "..", "--force"], capsys)
    assert_one_line_error(code, err, match="current folder")
    assert_unchanged(before, snapshot(work))


def test_force_out_input_folder_refused(work, tmp_path_factory, monkeypatch, capsys):
    no_analysis(monkeypatch)
    monkeypatch.chdir(tmp_path_factory.mktemp("elsewhere"))
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work, "--force"), capsys)
    assert_one_line_error(code, err, match="holds the input")
    assert_unchanged(before, snapshot(work))


def test_force_out_parent_of_input_refused_even_with_marker(work, rec_bytes, monkeypatch, capsys):
    """A folder above the input is never replaced, even if it carries dampfit's marker."""
    no_analysis(monkeypatch)
    deep = work / "a" / "b"
    deep.mkdir(parents=True)
    (deep / "rec.csv").write_bytes(rec_bytes)
    (work / "a" / MARKER).write_text(json.dumps({"kind": "analyze"}))
    before = snapshot(work)
    code, _, err = run(["analyze", deep / "rec.csv", "--mass", "5.3", "--out", work / "a",
                        "--force"], capsys)
    assert_one_line_error(code, err, match="holds the input")
    assert_unchanged(before, snapshot(work))


def test_force_out_symlink_keeps_link_and_target(work, capsys, fast, monkeypatch):
    """A link is refused, even to a genuine dampfit result: neither link nor target change."""
    result = make_result(work, "real-result", capsys, fast)
    (work / "link").symlink_to(result, target_is_directory=True)
    (work / "link2").symlink_to(work / "other", target_is_directory=True)
    before = snapshot(work)
    for link in ("link", "link2"):
        code, _, err = run(analyze_argv(work, work / link, "--force"), capsys)
        assert_one_line_error(code, err, match="symbolic link")
    assert_unchanged(before, snapshot(work))


@pytest.mark.parametrize("force", [True, False])
def test_folder_without_marker_is_refused(work, monkeypatch, capsys, force):
    no_analysis(monkeypatch)
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "other", *(["--force"] if force else [])), capsys)
    line = assert_one_line_error(code, err, match="not written by dampfit")
    assert MARKER in line and "remove it yourself" in line
    assert_unchanged(before, snapshot(work))


def test_out_existing_regular_file_refused(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "notes.txt", "--force"), capsys)
    assert_one_line_error(code, err, match="not a directory")
    assert_unchanged(before, snapshot(work))


def test_previous_result_needs_force_then_is_replaced(work, capsys, fast):
    out = make_result(work, "res", capsys, fast)
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, out), capsys)
    assert_one_line_error(code, err, match="exists; use --force")
    assert_unchanged(before, snapshot(work))

    code, out_text, err = run(analyze_argv(work, out, "--force"), capsys)
    assert code == 0, err
    assert not (out / "old-only.txt").exists(), "the old result was not replaced"
    assert json.loads((out / MARKER).read_text())["kind"] == "analyze"
    assert json.loads((out / "summary.json").read_text())["parameters"]["c"]["q50"] > 0
    assert helpers_left(work) == []
    assert_unchanged({k: v for k, v in before.items() if k.split(os.sep)[0] != "res"},
                     snapshot(work, exclude=[out]))


def _enospc(*a, **k):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), "posterior.nc")


def _h5py_like(*a, **k):  # h5py/h5netcdf wrap the system error in their own exceptions
    try:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    except OSError as exc:
        raise RuntimeError("Can't write data (file write failed:\n errno = 28)") from exc


@pytest.mark.parametrize("writer", [_enospc, _h5py_like], ids=["ENOSPC", "wrapped"])
def test_full_disk_while_writing_keeps_old_result(work, capsys, fast, monkeypatch, writer):
    out = make_result(work, "res", capsys, fast)
    before = snapshot(work)
    monkeypatch.setattr("dampfit.analysis.Analysis.to_netcdf", writer)
    code, _, err = run(analyze_argv(work, out, "--force"), capsys)
    line = assert_one_line_error(code, err, match="No space left on device")
    assert "previous result is unchanged" in line and str(out) in line
    assert_unchanged(before, snapshot(work))  # old result intact, no staging, no lock file


def test_full_disk_found_before_the_analysis(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    import shutil

    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage",
                        lambda p: real(p)._replace(free=3 * 2**20))
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "res"), capsys)
    assert_one_line_error(code, err, match="not enough free space")
    assert_unchanged(before, snapshot(work))


def test_read_only_parent_found_before_the_analysis(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    target = work / "other"
    if os.geteuid() == 0:  # root ignores modes: pretend the folder refuses writes
        real = os.access
        monkeypatch.setattr(os, "access", lambda p, mode, **k: False if (
            Path(p).resolve() == target.resolve() and mode & os.W_OK) else real(p, mode, **k))
    else:
        target.chmod(0o555)
    try:
        before = snapshot(work)
        code, _, err = run(analyze_argv(work, target / "res"), capsys)
        assert_one_line_error(code, err, match="permission denied")
        assert_unchanged(before, snapshot(work))
    finally:
        target.chmod(0o755)


def test_read_only_folder_at_staging_is_one_line(work, monkeypatch, capsys):
    """A folder that says it is writable but refuses the staging folder (EROFS)."""
    no_analysis(monkeypatch)
    import tempfile

    def erofs(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(tempfile, "mkdtemp", erofs)
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "res"), capsys)
    assert_one_line_error(code, err, match="read-only file system")
    assert_unchanged(before, snapshot(work))


# ----------------------------------------------------------------- concurrency and debris
def test_concurrent_run_to_same_out_fails_at_once(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    lock = work / ".res.dampfit-lock"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        os.write(fd, b"4242\n")
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        before = snapshot(work)
        code, _, err = run(analyze_argv(work, work / "res"), capsys)
        assert_one_line_error(code, err, match="being written by another dampfit process (pid 4242)")
        assert_unchanged(before, snapshot(work))
    finally:
        os.close(fd)


@pytest.mark.parametrize("kind", ["fifo", "link-to-dev-zero"])
def test_a_lock_path_that_is_not_a_file_is_one_line(work, monkeypatch, capsys, kind):
    """A FIFO (or a link) planted under the lock's name: exit 2, one line, nothing written."""
    no_analysis(monkeypatch)
    lock = work / ".res.dampfit-lock"
    if kind == "fifo":
        os.mkfifo(lock)
    else:
        lock.symlink_to("/dev/zero")
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "res"), capsys)
    assert_one_line_error(code, err, match="lock file")
    assert_unchanged(before, snapshot(work))


def _dead_pid() -> int:
    proc = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    return int(proc.stdout)


def test_stale_staging_of_dead_process_cleaned_foreign_kept(work, capsys, fast):
    pid = _dead_pid()
    stale = work / f".res.dampfit-stage-{pid}-abc123"
    stale.mkdir()
    (stale / MARKER).write_text(json.dumps({"kind": "analyze"}))
    (stale / "posterior.nc.part").write_bytes(b"half")
    foreign = work / f".res.dampfit-stage-{pid}-zzz999"  # same pattern, not ours: no marker
    foreign.mkdir()
    (foreign / "mine.txt").write_text("user data\n")
    other = work / f".elsewhere.dampfit-stage-{pid}-abc123"  # another target's: not ours to judge
    other.mkdir()
    (other / MARKER).write_text(json.dumps({"kind": "analyze"}))
    code, _, err = run(analyze_argv(work, work / "res"), capsys)
    assert code == 0, err
    assert not stale.exists()
    assert (foreign / "mine.txt").read_text() == "user data\n"
    assert other.is_dir()
    assert helpers_left(work) == sorted([foreign.name, other.name])


def test_ctrl_c_while_writing_leaves_old_result_and_no_debris(work, capsys, fast, monkeypatch):
    out = make_result(work, "res", capsys, fast)
    before = snapshot(work)

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr("dampfit.analysis.Analysis.to_signals", interrupted)
    code, _, err = run(analyze_argv(work, out, "--force"), capsys)
    assert code == 130 and "Traceback" not in err
    assert err.strip().splitlines() == ["dampfit: interrupted; no partial output was left behind"]
    assert_unchanged(before, snapshot(work))


def test_sigterm_while_writing_leaves_no_debris(work, capsys, fast, monkeypatch):
    def killed(self, path):
        os.kill(os.getpid(), signal.SIGTERM)  # dampfit's handler turns it into an exception

    monkeypatch.setattr("dampfit.analysis.Analysis.to_signals", killed)
    before = snapshot(work)
    handler = signal.getsignal(signal.SIGTERM)
    code, _, err = run(analyze_argv(work, work / "res"), capsys)
    assert code == 143 and err.strip().splitlines() == [
        "dampfit: terminated; no partial output was left behind"]
    assert_unchanged(before, snapshot(work))
    assert signal.getsignal(signal.SIGTERM) == handler  # main restored the previous handler


# ------------------------------------------------------------------------- bad numbers
@pytest.mark.parametrize("extra,match", [
    (["--seed", "-1"], "--seed"),
    (["--seed", str(2**32)], "--seed"),
    (["--max-steps", "0"], "--max-steps"),
    (["--mass", "nan"], "positive mass"),
    (["--mass", "inf"], "positive mass"),
    (["--mass", "-1"], "positive mass"),
    (["--mass", "0"], "positive mass"),
    (["--mass", "1e308"], "positive mass"),
    (["--mass-sd", "-1"], "standard deviation"),
    (["--mass-sd", "nan"], "standard deviation"),
    (["--window", "5", "2"], "after its start"),
    (["--window", "0", "inf"], "finite time"),
    (["--band", "3", "1"], "LO < HI"),
    (["--band", "0", "2"], "positive frequency"),
    (["--band", "1", "nan"], "positive frequency"),
    (["--amplitude", "-1"], "positive displacement amplitude"),
    (["--amplitude", "inf"], "positive displacement amplitude"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_bad_analyze_numbers_exit_2_before_any_work(work, monkeypatch, capsys, extra, match):
    no_analysis(monkeypatch)
    monkeypatch.chdir(work)
    before = snapshot(work)
    code, _, err = run(analyze_argv(work, work / "res", *extra), capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(work))


@pytest.mark.parametrize("extra,match", [
    (["--duration", "1e9"], "samples"),
    (["--duration", "1e5", "--sample-rate", "1e5"], "samples"),
    (["--zeta", "2"], "damping ratio"),
    (["--zeta", "-0.1"], "damping ratio"),
    (["--mass", "nan"], "positive mass"),
    (["--mass", "1e308"], "positive mass"),
    (["--sample-rate", "0"], "positive"),
    (["--duration", "inf"], "positive"),
    (["--u0", "1e300"], "displacement"),
    (["--f-n", "400"], "Nyquist"),
    (["--jitter", "-1"], "coefficient of variation"),
    (["--noise-density", "-3"], "≥ 0"),
    (["--seed", "-1"], "--seed"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_bad_simulate_numbers_exit_2(work, monkeypatch, capsys, extra, match):
    monkeypatch.setattr(sim, "recording", lambda *a, **k: pytest.fail("simulated anyway"))
    before = snapshot(work)
    code, _, err = run(["simulate", "--out", work / "sim.csv", *extra], capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(work))


@pytest.mark.parametrize("out,match", [(".", "names no file"), ("other", "not a regular file")])
def test_simulate_out_must_be_a_file(work, monkeypatch, capsys, out, match):
    monkeypatch.chdir(work)
    before = snapshot(work)
    code, _, err = run(["simulate", "--out", out, "--force"], capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(work))


@pytest.mark.parametrize("argv,match", [
    (["export", "res", "--quantile", "nan"], "finite"),
    (["verify", "res", "--dt", "inf"], "finite"),
    (["study", "x.toml", "--workers", "100000"], "at most 256"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_other_commands_refuse_non_finite_and_absurd_numbers(work, monkeypatch, capsys, argv,
                                                             match):
    monkeypatch.chdir(work)
    before = snapshot(work)
    code, _, err = run(argv, capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(work))


def test_deleted_current_folder_is_one_line(tmp_path, monkeypatch, capsys, rec_bytes):
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    code, _, err = run(["analyze", "../x.csv", "--mass", "5", "--out", "res"], capsys)
    assert_one_line_error(code, err, match="current folder no longer exists")


def test_sigterm_to_a_real_run_exits_143_and_leaves_nothing(work):
    """A real process killed with SIGTERM mid-analysis: exit 143 (not a crash), one line,
    no staging folder, no lock file, nothing else changed."""
    import time

    before = snapshot(work)
    env = {**os.environ, "DAMPFIT_JAX_CACHE": "off", "MPLBACKEND": "Agg"}
    proc = subprocess.Popen([sys.executable, "-m", "dampfit", "analyze", "rec.csv", "--mass", "5.3",
                             "--out", "res", "--quiet"], cwd=work, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not list(work.glob(".res.dampfit-stage-*")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)  # inside the analysis (JAX busy)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert err.strip().splitlines() == ["dampfit: terminated; no partial output was left behind"]
    assert_unchanged(before, snapshot(work))


# ------------------------------------------------------------------------------- demo
def test_demo_bad_seed_and_foreign_out(work, monkeypatch, capsys):
    no_analysis(monkeypatch)
    monkeypatch.chdir(work)
    before = snapshot(work)
    code, _, err = run(["demo", "--seed", "-1", "--quiet"], capsys)
    assert_one_line_error(code, err, match="--seed")
    for out in (".", "other"):
        code, _, err = run(["demo", "--out", out, "--force", "--quiet"], capsys)
        assert_one_line_error(code, err, match="refusing to replace")
    assert_unchanged(before, snapshot(work))


def test_demo_regenerates_its_own_folder_but_not_an_analyze_result(work, monkeypatch, capsys, fast):
    real_preset = sim.preset
    monkeypatch.setattr(sim, "preset", lambda name, **kw: real_preset(name, **{"duration": 10.0,
                                                                              **kw}))
    monkeypatch.chdir(work)
    demo = work / "dampfit-demo"
    code, _, err = run(["demo", "--quiet", "--no-figures"], capsys)
    assert code == 0, err
    assert json.loads((demo / MARKER).read_text())["kind"] == "demo"
    (demo / "old-only.txt").write_text("x")
    code, _, err = run(["demo", "--quiet", "--no-figures"], capsys)  # no --force needed
    assert code == 0, err
    assert not (demo / "old-only.txt").exists()

    result = make_result(work, "res", capsys, fast)
    before = snapshot(work)
    code, _, err = run(["demo", "--out", result, "--quiet", "--no-figures"], capsys)
    assert_one_line_error(code, err, match="exists; use --force")
    assert_unchanged(before, snapshot(work))


def test_old_demo_folder_recognised_only_by_its_own_files(tmp_path):
    folder = tmp_path / "dampfit-demo"
    folder.mkdir()
    for name in ("paper-preset.csv", "paper-preset.truth.json", "summary.json", "fit.png"):
        (folder / name).write_text("x")
    assert cli_staging.old_demo_folder(folder)
    (folder / "thesis.tex").write_text("mine")
    assert not cli_staging.old_demo_folder(folder)
    (folder / "thesis.tex").unlink()
    (folder / "sub").mkdir()
    assert not cli_staging.old_demo_folder(folder)


# ------------------------------------------------------------------------ compile cache
def _cache_env(monkeypatch, path):
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", str(path))


def test_world_writable_cache_is_not_used(tmp_path, monkeypatch, capsys):
    cache = tmp_path / "jax"
    cache.mkdir()
    cache.chmod(0o777)
    _cache_env(monkeypatch, cache)
    capsys.readouterr()
    messages.clear()
    assert cli._compile_cache() is None
    assert len(messages.pending()) == 1
    line = messages.pending()[0]
    assert line.startswith("dampfit: warning:") and line.endswith("cache off")
    assert "writable by group or others" in line
    assert "JAX_COMPILATION_CACHE_DIR" not in os.environ
    # the CLI keeps working without it: a usage error is still the only error line (the
    # warning is printed only after a command that succeeds)
    code, _, err = run(["simulate", "--zeta", "2", "--out", tmp_path / "x.csv"], capsys)
    assert_one_line_error(code, err)


def test_cache_under_everyone_writable_parent_or_foreign_owner_is_not_used(tmp_path, monkeypatch,
                                                                           capsys):
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)  # no sticky bit: anyone may swap the cache folder
    _cache_env(monkeypatch, shared / "dampfit" / "jax")
    messages.clear()
    assert cli._compile_cache() is None
    assert "writable by everyone" in " ".join(messages.pending())
    if os.geteuid() == 0:  # only root can give a folder away
        mine = tmp_path / "foreign"
        mine.mkdir(mode=0o700)
        os.chown(mine, 4321, -1)
        _cache_env(monkeypatch, mine)
        messages.clear()
        assert cli._compile_cache() is None
        assert "another user" in " ".join(messages.pending())


def test_private_cache_folders_created_0700_throughout(tmp_path):
    """Every folder made for the cache is private even under a permissive umask (umask 0)."""
    path = tmp_path / "new" / "dampfit" / "jax"
    old = os.umask(0)
    try:
        created = cli._make_private(path)
    finally:
        os.umask(old)
    assert created == [path.parent.parent, path.parent, path]
    for p in created:
        assert stat.S_IMODE(p.stat().st_mode) == 0o700, p
    assert cli._unsafe_cache(path, created) is None


def test_an_error_naming_a_path_with_newlines_stays_one_line(tmp_path, capsys):
    """A missing input whose name holds a newline and a fake second error line."""
    from tests._support.hostile import assert_one_line_error, run

    name = tmp_path / "rec\ndampfit: error: forged\r.csv"
    code, _, err = run(["analyze", name, "--mass", "1", "--out", tmp_path / "o"], capsys)
    assert_one_line_error(code, err, match="not found")


def test_a_sigterm_swallowed_by_a_callback_is_delivered_again(tmp_path):
    """SIGTERM whose exception lands in a callback that cannot raise (JAX's gc callback, a
    ``__del__``) still ends the command with 143: the CLI sends it again instead of running on
    and publishing a result after being told to stop."""
    code = (
        "import os, signal, time\n"
        "import dampfit.cli as cli\n"
        "class Swallower:\n"
        "    def __del__(self):\n"
        "        os.kill(os.getpid(), signal.SIGTERM)\n"
        "        for _ in range(1000): pass\n"
        "def command(args):\n"
        "    Swallower()\n"
        "    time.sleep(5)\n"
        "    return 0\n"
        "cli.COMMANDS = [(name, h, o, command) for name, h, o, _ in cli.COMMANDS]\n"
        "raise SystemExit(cli.main(['demo']))\n")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 143, proc.stderr


# -- odd output names: lock file, links, a preset path, names too long, full disk -----------


FAST = ["--no-figures", "--quiet", "--model", "viscous", "--mass", "5.3"]

def test_out_name_too_long_for_the_lock_file_is_one_line(tmp_path, capsys, monkeypatch):
    t, a = decay()
    decay_csv(tmp_path / "rec.csv", t, a)
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", "rec.csv", *FAST, "--out", "y" * 250], capsys)
    assert_one_line_error(code, err, 2, "lock file")
    assert_unchanged(before, snapshot(tmp_path))

def test_simulate_force_over_links_keeps_their_targets(tmp_path, capsys):
    (tmp_path / "mine.txt").write_text("precious")
    (tmp_path / "sim.csv").symlink_to(tmp_path / "mine.txt")
    (tmp_path / "sim.truth.json").symlink_to(tmp_path / "mine.txt")
    code, _, err = run(["simulate", "--duration", "2", "--handheld", "0",
                        "--out", tmp_path / "sim.csv", "--force"], capsys)
    assert code == 0, err
    assert (tmp_path / "mine.txt").read_text() == "precious"
    assert not (tmp_path / "sim.csv").is_symlink() and not (tmp_path / "sim.truth.json").is_symlink()

def test_simulate_unknown_preset_path_is_one_line(tmp_path, capsys):
    before = snapshot(tmp_path)
    code, _, err = run(["simulate", "--preset", "../../etc/passwd", "--out", tmp_path / "x.csv"], capsys)
    assert_one_line_error(code, err, 2, "unknown preset")
    assert_unchanged(before, snapshot(tmp_path))


def test_simulate_refuses_a_file_name_too_long_before_simulating(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sim, "recording", lambda *a, **k: pytest.fail("simulated anyway"))
    fails(tmp_path, capsys, ["simulate", "--out", tmp_path / f"{LONG}.csv"], "File name too long")
    # the CSV name fits, the truth file's (longer) name does not: refused before either is written
    fails(tmp_path, capsys, ["simulate", "--out", tmp_path / ("y" * 245 + ".csv")],
          "File name too long")

def test_simulate_writes_both_files_or_neither(tmp_path, capsys, monkeypatch):
    def full_disk(truth, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(sim, "write_truth", full_disk)
    line = fails(tmp_path, capsys, ["simulate", "--out", tmp_path / "rec.csv", "--duration", "5"],
                 "No space left on device")
    assert "nothing was written" in line
    assert not list(tmp_path.iterdir())  # no staging debris either

def test_atomic_write_text_fits_long_names_and_turns_os_errors_into_one_line(tmp_path):
    name = "z" * 250  # fits, but ".NAME.XXXXXXXX.tmp" would not
    atomic_write_text(tmp_path / name, "ok")
    assert (tmp_path / name).read_text() == "ok"
    with pytest.raises(WriteError, match="File name too long"):
        atomic_write_text(tmp_path / LONG, "no")
    assert isinstance(WriteError("x"), InputError)
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]
