"""Shared checks of the hostile-input corpus (``tests/cli/test_hostile_*.py``) and of the CLI tests.

Every hostile case asserts what the CLI promises a careless or hostile user:

* the exit code (2 for bad input, 0 for a correct or clearly flagged result);
* on failure exactly one line on stderr, starting ``dampfit: error:``, and no traceback;
* nothing outside the output path changed: :func:`snapshot` the folder before and after and
  compare with :func:`assert_unchanged`.

:func:`one_error_line` reads the one error line from ``capsys`` after an in-process ``main``;
:func:`no_compile_cache` (import it into a module as ``_no_compile_cache``: an autouse fixture)
keeps in-process runs off the user's JAX compilation cache.

Cases run in-process through :func:`run` (fast: the CLI's ``main``) or in a subprocess through
:func:`run_subprocess` when they need a real process (kills, locks, blocking files).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dampfit.cli import main

__all__ = ["ctrl_c_default", "run", "run_subprocess", "snapshot", "assert_unchanged", "assert_one_line_error",
           "one_error_line", "no_compile_cache", "fails", "decay", "decay_csv", "F_TRUE", "LONG"]

F_TRUE = 5.0  # [Hz] natural frequency of the simulated decay (ζ ≈ 0.01: f_d ≈ f_n)
LONG = "x" * 300  # longer than NAME_MAX (255 bytes) of every common file system


def run(argv, capsys) -> tuple[int, str, str]:
    """``dampfit ARGV`` in this process: (exit code, stdout, stderr)."""
    capsys.readouterr()
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def run_subprocess(argv, cwd=None, timeout: float = 120, env=None, stdin=None) -> tuple[int, str, str]:
    """``python -m dampfit ARGV`` in a fresh process: (exit code, stdout, stderr)."""
    full_env = {**os.environ, "MPLBACKEND": "Agg", **(env or {})}
    proc = subprocess.run([sys.executable, "-m", "dampfit", *[str(a) for a in argv]],
                          cwd=cwd, capture_output=True, text=True, timeout=timeout, env=full_env,
                          stdin=subprocess.DEVNULL if stdin is None else stdin)
    return proc.returncode, proc.stdout, proc.stderr


def assert_one_line_error(code: int, err: str, expected_code: int = 2, match: str | None = None) -> str:
    """The failure contract: exit code, one ``dampfit: error:`` line, no traceback."""
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == expected_code, f"exit {code}, stderr: {err!r}"
    assert len(lines) == 1, f"expected one stderr line, got {lines!r}"
    assert lines[0].startswith("dampfit: error:"), lines[0]
    if match is not None:
        assert match.lower() in lines[0].lower(), f"{match!r} not in {lines[0]!r}"
    return lines[0]


def snapshot(root, exclude=()) -> dict[str, tuple]:
    """Every file, folder and link under ``root`` (not following links): path -> fingerprint.

    The fingerprint of a file is (size, SHA-256), of a link its target, of a folder its mode;
    paths under any of ``exclude`` (e.g. the output folder) are left out.
    """
    root = Path(root)
    skip = [Path(e).absolute() for e in exclude]
    out: dict[str, tuple] = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        here = Path(dirpath)
        for name in [*dirnames, *filenames]:
            p = here / name
            if any(p == s or s in p.parents for s in skip):
                continue
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                out[rel] = ("dir", p.stat().st_mode)
            elif p.is_file():
                out[rel] = ("file", p.stat().st_size, hashlib.sha256(p.read_bytes()).hexdigest())
            else:
                out[rel] = ("special", p.stat().st_mode)
    return out


def assert_unchanged(before: dict, after: dict) -> None:
    """Nothing added, removed or changed between two :func:`snapshot` s."""
    added = sorted(set(after) - set(before))
    removed = sorted(set(before) - set(after))
    changed = sorted(k for k in before.keys() & after.keys() if before[k] != after[k])
    assert not (added or removed or changed), f"added {added}, removed {removed}, changed {changed}"


def one_error_line(capsys) -> str:
    """The one stderr line (``dampfit: error: …``) of the ``main`` call just made."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("dampfit: error:")
    return err[0]


@pytest.fixture(autouse=True)
def no_compile_cache(monkeypatch):
    """In-process runs leave the user's JAX cache alone (the cache test sets its own)."""
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", "off")


def fails(tmp_path, capsys, argv, match, exclude=()):
    """``dampfit ARGV``: exit 2, one line containing ``match``, nothing under tmp_path changed."""
    before = snapshot(tmp_path, exclude=exclude)
    code, out, err = run(argv, capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path, exclude=exclude))
    return line


def decay(n_sec: float = 10.0, fs: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    """Time [s] and a 5 Hz free decay [m/s²] with a little noise (a 10 s, 100 Hz
    recording by default)."""
    t = np.arange(int(n_sec * fs)) / fs
    a = 3.0 * np.exp(-0.3 * t) * np.cos(2 * np.pi * F_TRUE * t)
    return t, a + 0.01 * np.random.default_rng(0).standard_normal(t.size)


def decay_csv(path: Path, t: np.ndarray, a: np.ndarray) -> Path:
    """``t`` [s], ``a`` [m/s²] as a two-column CSV, every number in full (``repr``)."""
    rows = "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in zip(t, a))
    path.write_text('"Time (s)","acc z (m/s^2)"\n' + rows)
    return path


def ctrl_c_default() -> None:
    """``preexec_fn`` of a child that a test sends Ctrl-C: SIGINT at its default and SIGINT,
    SIGTERM unblocked, whatever this test process has (a child inherits an ignored SIGINT and
    the signal mask; see ``tests/conftest.py``)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})


def record_child(url: str, out: Path) -> subprocess.Popen:
    """``dampfit record URL --out OUT --no-analyze --duration 60`` in a child process of this
    checkout's source, ready to be sent Ctrl-C, SIGTERM or SIGKILL (:func:`ctrl_c_default`)."""
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root / "src"), str(root),
                                                        os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen([sys.executable, "-m", "dampfit", "record", url, "--out", str(out),
                             "--no-analyze", "--duration", "60"], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=ctrl_c_default)
