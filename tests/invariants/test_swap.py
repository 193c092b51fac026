"""The swap of a new result onto the previous one loses nothing (issue 19, item 8).

A child process publishes a result folder over a previous one (:class:`dampfit.files.folder.ResultFolder`,
the path ``analyze``/``demo`` take) and stops at a named step of the swap: it prints the step
and waits for a byte on stdin. The test then sends SIGINT or SIGKILL, so every case hits
exactly the step it names — no sleeps. Both swap methods are run: the one-call exchange
(``renameat2(RENAME_EXCHANGE)``) and the two renames used where it is unavailable. While the
child waits, its main thread blocks SIGINT and a second thread is alive, so the kernel
delivers a Ctrl-C to that other thread (the case where blocking signals in the main thread
only did not help). What a user relies on:

* SIGINT at any step: the target is the complete previous or the complete new result, and no
  ``.NAME.dampfit-*`` folder is left;
* SIGKILL at any step: the next run for the same target finds the previous (or new) result
  complete — a previous result left as ``.NAME.dampfit-old-…`` is restored — and leaves no
  helper folder behind; ``dampfit report`` on the missing folder names the left-over folder.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from dampfit.files.folder import MARKER, ResultFolder

from tests._support.hostile import assert_one_line_error, ctrl_c_default, run

CHILD = r"""
import os, signal, sys, threading
from pathlib import Path
from dampfit.files import swap
from dampfit.files.folder import ResultFolder

target, mode = Path(sys.argv[1]), sys.argv[2]
threading.Thread(target=threading.Event().wait, daemon=True).start()  # another thread

def pause(step):
    print(step, flush=True)
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})  # Ctrl-C → other thread
    try:
        os.read(0, 1)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)

def paused(fn, before, after):
    def wrapper(*args, **kw):
        pause(before)
        out = fn(*args, **kw)
        pause(after)
        return out
    return wrapper

real_exchange, real_rename, real_remove = swap.exchange, os.rename, swap.remove_result
if mode == "exchange":
    swap.exchange = paused(real_exchange, "before-exchange", "after-exchange")
else:
    swap.exchange = lambda a, b: False
    renames = iter(["between-renames", "after-renames"])
    def rename(src, dst):
        real_rename(src, dst)
        pause(next(renames, "other-rename"))
    os.rename = rename

def remove(path, marker):
    first = next(iter(sorted(p for p in path.iterdir() if p.name != marker)), None)
    if first is not None:
        first.unlink()
        pause("mid-remove")
    real_remove(path, marker)
swap.remove_result = remove

try:
    with ResultFolder(target, kind="analyze", force=True) as rf:
        for i in range(3):
            (rf.stage / f"new-{i}.txt").write_text("new\n")
        rf.publish()
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
print("done", flush=True)
"""

EXCHANGE_STEPS = ["before-exchange", "after-exchange", "mid-remove"]
RENAME_STEPS = ["between-renames", "after-renames", "mid-remove"]
CASES = [("exchange", s) for s in EXCHANGE_STEPS] + [("rename", s) for s in RENAME_STEPS]


def _previous(target: Path) -> None:
    """A previous result dampfit wrote at ``target``: marker and three files."""
    target.mkdir()
    (target / MARKER).write_text(json.dumps({"kind": "analyze", "dampfit": "test"}))
    for i in range(3):
        (target / f"old-{i}.txt").write_text("old\n")


def _content(folder: Path) -> str:
    """"old" or "new" if ``folder`` is that complete result, else what it holds."""
    names = sorted(p.name for p in folder.iterdir())
    for which in ("old", "new"):
        if names == sorted([MARKER] + [f"{which}-{i}.txt" for i in range(3)]):
            return which
    return f"incomplete: {names}"


def _helpers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if ".dampfit-" in p.name)


def _run_child(target: Path, mode: str, stop: str, sig: int) -> tuple[int, str]:
    """Run the child until it pauses at ``stop`` (earlier pauses are released), send ``sig``,
    release it and return (exit code, its stdout)."""
    if mode == "exchange":
        from dampfit.files import swap

        if swap._libc_renameat2() is None:
            pytest.skip("renameat2 is not available here: only the two-rename swap is used")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(target), mode], env=env,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=ctrl_c_default)
    lines = []
    try:
        while True:
            line = proc.stdout.readline().decode().strip()
            lines.append(line)
            if line == stop:
                proc.send_signal(sig)
                if sig != signal.SIGKILL:
                    proc.stdin.write(b"x")
                    proc.stdin.flush()
                break
            if not line or line in ("done", "interrupted"):
                pytest.fail(f"the child never reached {stop!r}: {lines}, "
                            f"{proc.stderr.read().decode()[-2000:]}")
            proc.stdin.write(b"x")  # an earlier pause: go on
            proc.stdin.flush()
        # release any further pauses until the child ends
        out, err = proc.communicate(input=b"x" * 16, timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, "\n".join(lines) + out.decode() + err.decode()


@pytest.mark.parametrize("mode,step", CASES, ids=[f"{m}-{s}" for m, s in CASES])
def test_sigint_at_any_step_of_the_swap_leaves_one_complete_result(tmp_path, mode, step):
    target = tmp_path / "res"
    _previous(target)
    code, out = _run_child(target, mode, step, signal.SIGINT)
    # the Ctrl-C acts once the swap is done: the new result is in place, nothing left over
    assert code == 130 and "interrupted" in out, out
    assert _content(target) == "new", out
    assert _helpers(tmp_path) == [], out


@pytest.mark.parametrize("mode,step", CASES, ids=[f"{m}-{s}" for m, s in CASES])
def test_sigkill_at_any_step_of_the_swap_is_repaired_by_the_next_run(tmp_path, mode, step):
    target = tmp_path / "res"
    _previous(target)
    code, out = _run_child(target, mode, step, signal.SIGKILL)
    assert code == -signal.SIGKILL, out
    # whatever the step: one complete result exists, under the target or the hidden old name
    left = [tmp_path / n for n in _helpers(tmp_path)]
    complete = [p for p in [target, *left] if p.is_dir() and _content(p) in ("old", "new")]
    assert complete, (out, _helpers(tmp_path))
    expected = _content(target) if target.exists() else "old"
    # the next run: it restores a previous result a kill left hidden, then replaces it
    notes: list[str] = []
    with ResultFolder(target, kind="analyze", force=True, note=notes.append) as rf:
        assert _content(target) == expected  # restored (or kept) before any work
        assert [n for n in _helpers(tmp_path) if "-old-" in n] == []
        (rf.stage / "third.txt").write_text("third\n")
        rf.publish()
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "third.txt"]
    assert _helpers(tmp_path) == []
    if step == "between-renames":
        assert len(notes) == 1 and "restored the previous result" in notes[0], notes


def test_a_killed_swap_is_reported_then_restored_through_the_cli(tmp_path, capsys):
    """``dampfit report`` on the folder a kill left missing names the hidden previous result;
    the next ``analyze --out`` restores it (printing a note) before it starts."""
    target = tmp_path / "res"
    _previous(target)
    code, out = _run_child(target, "rename", "between-renames", signal.SIGKILL)
    assert code == -signal.SIGKILL and not target.exists(), out
    code, _, err = run(["report", target], capsys)
    line = assert_one_line_error(code, err, 2, "is not a dampfit result folder")
    assert ".res.dampfit-old-" in line and "restores it" in line
    # the restoring step of the next run, as the CLI sets it up (note printed on success)
    from dampfit.cli import staging

    with staging.result_folder(target, "analyze", True) as rf:
        assert _content(target) == "old"
        (rf.stage / "x.txt").write_text("x")
        rf.publish()
    from dampfit.cli import messages

    assert any("restored the previous result" in line for line in messages.pending())
    messages.clear()


def test_a_hidden_previous_result_without_marker_is_never_restored_or_removed(tmp_path):
    """Only what dampfit wrote (its marker) is restored or removed; a look-alike is reported."""
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    fake = tmp_path / f".res.dampfit-old-{dead}-abcd1234"
    fake.mkdir()
    (fake / "mine.txt").write_text("user data\n")
    notes: list[str] = []
    with ResultFolder(tmp_path / "res", kind="analyze", note=notes.append) as rf:
        (rf.stage / "x.txt").write_text("x")
        rf.publish()
    assert (fake / "mine.txt").read_text() == "user data\n"
    assert any("holds no dampfit marker" in n for n in notes), notes


def test_two_hidden_previous_results_are_reported_not_guessed(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    olds = []
    for tag in ("aaaa1111", "bbbb2222"):
        _previous(tmp_path / f".res.dampfit-old-{dead}-{tag}")
        olds.append(tmp_path / f".res.dampfit-old-{dead}-{tag}")
    notes: list[str] = []
    with ResultFolder(tmp_path / "res", kind="analyze", note=notes.append) as rf:
        (rf.stage / "x.txt").write_text("x")
        rf.publish()
    assert all(_content(p) == "old" for p in olds)
    assert any("none was restored" in n for n in notes), notes
