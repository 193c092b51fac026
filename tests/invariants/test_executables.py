"""Compiled kernels kept on disk between processes (dampfit.inference.executables).

A second process must load what the first compiled (no tracing, same numbers), including a
kernel that calls LAPACK (a loaded executable once crashed the process there); a damaged or
foreign entry must be recompiled, never trusted; without the store nothing is written; a
copy of an executable that JAX itself loaded from its own cache (which serialises without its
fused code) must never be stored.

The store is trusted only when it must be (dampfit.files.private): a folder others could
change on the way down, an entry of another owner or mode, a symbolic link, a flipped bit or
a lost or replaced key all mean "compile", and the process survives with the same result.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SCRIPT = textwrap.dedent("""
    import json, os, sys
    import jax, jax.numpy as jnp, numpy as np
    jax.config.update("jax_enable_x64", True)
    from dampfit.inference.executables import Kernel

    def solve(a, b):
        c = jnp.linalg.cholesky(a @ a.T + 4.0 * jnp.eye(a.shape[0]))
        return jax.scipy.linalg.cho_solve((c, True), b), jnp.sum(b)

    def as_dict(x):
        return {"twice": 2 * x}

    k, d = Kernel(solve), Kernel(as_dict)
    a = np.arange(16.0).reshape(4, 4) / 7.0
    x, s = k(a, np.ones(4))
    y = d(np.ones(3))["twice"]
    print(json.dumps({"x": np.asarray(x).tolist(), "s": float(s), "y": np.asarray(y).tolist(),
                      "loaded": k.loaded, "compiled": k.compiled,
                      "dict_loaded": d.loaded, "dict_compiled": d.compiled}))
""")


def _run(tmp_path: Path, cache: Path | None, **settings: str) -> dict:
    """Run the kernel script in a fresh process with ``cache`` as the checked folder
    (``DAMPFIT_EXECUTABLE_CACHE``; None: unset, so ``settings`` — the user's switch
    ``DAMPFIT_JAX_CACHE``, ``XDG_CACHE_HOME`` — decide, as in a script)."""
    env = dict(os.environ)
    for name in ("JAX_COMPILATION_CACHE_DIR", "DAMPFIT_EXECUTABLE_CACHE", "DAMPFIT_JAX_CACHE"):
        env.pop(name, None)
    env.update(settings)
    if cache is not None:
        env["DAMPFIT_EXECUTABLE_CACHE"] = str(cache)
    script = tmp_path / "kernel_script.py"
    script.write_text(SCRIPT)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return {**json.loads(out.stdout.strip().splitlines()[-1]), "stderr": out.stderr}


def _entries(cache: Path) -> list[Path]:
    return sorted(cache.glob("*.exe")) if cache.exists() else []


def _resign(cache: Path, entry: Path, edit) -> None:
    """Rewrite ``entry`` with its metadata changed by ``edit`` and a valid tag (as a dampfit of
    another environment with this folder's key would have written it)."""
    from dampfit.files.private import open_store
    from dampfit.inference import executables

    store = open_store(cache)
    meta, payload = executables._unpack(store.read(entry.name))
    edit(meta)
    store.write(entry.name, executables._pack(meta, payload))
    store.close()


def test_second_process_loads_what_the_first_compiled(tmp_path):
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    assert (first["compiled"], first["loaded"]) == (1, 0)
    assert len(_entries(cache)) == 1  # the dict-valued kernel is not stored
    second = _run(tmp_path, cache)
    assert (second["compiled"], second["loaded"]) == (0, 1)
    assert second["x"] == pytest.approx(first["x"], rel=0, abs=0)
    assert second["s"] == first["s"] == 4.0
    assert (second["dict_compiled"], second["dict_loaded"]) == (1, 0)
    assert second["y"] == [2.0, 2.0, 2.0]


@pytest.mark.heavy
def test_damaged_or_foreign_entry_is_recompiled(tmp_path):
    cache = tmp_path / "cache"
    good = _run(tmp_path, cache)
    (entry,) = _entries(cache)
    entry.write_bytes(b"\x00" * 64)  # damaged entry: its tag no longer matches
    again = _run(tmp_path, cache)
    assert (again["compiled"], again["loaded"]) == (1, 0)
    assert again["x"] == good["x"]

    def other_machine(meta):
        meta["environment"] = meta["environment"].replace("cpu", "gpu")

    _resign(cache, entry, other_machine)  # authentic, but another machine's entry
    third = _run(tmp_path, cache)
    assert (third["compiled"], third["loaded"]) == (1, 0)
    fourth = _run(tmp_path, cache)  # rewritten by the third run
    assert (fourth["compiled"], fourth["loaded"]) == (0, 1)


def test_switched_off_nothing_is_written(tmp_path):
    out = _run(tmp_path, None, DAMPFIT_JAX_CACHE="off", XDG_CACHE_HOME=str(tmp_path / "xdg"))
    assert (out["compiled"], out["loaded"]) == (0, 0)  # plain jax.jit
    assert not list(tmp_path.rglob("*.exe")) and not list(tmp_path.rglob("*.bin"))
    assert not (tmp_path / "xdg").exists()


@pytest.mark.heavy
def test_a_script_gets_the_store_by_default(tmp_path):
    """Issue 23: a script (no CLI, nothing set) stores its kernels in the default private
    folder ``$XDG_CACHE_HOME/dampfit/jax`` and the next script loads them instead of compiling;
    ``DAMPFIT_JAX_CACHE=FOLDER`` moves it, and an unsafe folder is one warning, no store."""
    import stat

    xdg = tmp_path / "xdg"
    first = _run(tmp_path, None, XDG_CACHE_HOME=str(xdg))
    second = _run(tmp_path, None, XDG_CACHE_HOME=str(xdg))
    assert (first["compiled"], first["loaded"]) == (1, 0)
    assert (second["compiled"], second["loaded"]) == (0, 1)
    assert second["x"] == first["x"]
    folder = xdg / "dampfit" / "jax"
    assert len(_entries(folder)) == 1 and stat.S_IMODE(folder.stat().st_mode) == 0o700
    moved = _run(tmp_path, None, DAMPFIT_JAX_CACHE=str(tmp_path / "mine"),
                 XDG_CACHE_HOME=str(xdg))
    assert (moved["compiled"], moved["loaded"]) == (1, 0) and _entries(tmp_path / "mine")
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)  # anyone could plant an executable here
    unsafe = _run(tmp_path, None, DAMPFIT_JAX_CACHE=str(shared))
    assert (unsafe["compiled"], unsafe["loaded"]) == (0, 0) and not any(shared.iterdir())
    assert unsafe["stderr"].count("not used") == 1


def test_source_edit_changes_the_key(monkeypatch):
    from dampfit.inference import executables

    executables._environment.cache_clear()
    before = executables._environment()
    monkeypatch.setattr(executables, "source_digest", lambda: "edited")
    executables._environment.cache_clear()
    try:
        assert executables._environment() != before
    finally:
        monkeypatch.undo()
        executables._environment.cache_clear()


@pytest.mark.heavy
def test_copy_of_a_jax_cache_hit_is_not_stored(tmp_path):
    """Under a user's own JAX persistent cache, a kernel JAX loaded from it serialises without
    its fused code; the check before storing must refuse it, and the kernel still works."""
    env = dict(os.environ)
    env.pop("DAMPFIT_EXECUTABLE_CACHE", None)
    env.update(JAX_COMPILATION_CACHE_DIR=str(tmp_path / "jax"),
               JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0",
               JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES="-1")
    script = tmp_path / "kernel_script.py"
    script.write_text(SCRIPT)
    outs = []
    for i in range(3):  # 1: JAX cache filled; 2: cache hit, its copy refused; 3: still works
        env["DAMPFIT_EXECUTABLE_CACHE"] = str(tmp_path / f"store{i}")
        run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                             env=env, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        outs.append(json.loads(run.stdout.strip().splitlines()[-1]))
    assert len(_entries(tmp_path / "store0")) == 1
    assert _entries(tmp_path / "store1") == []
    assert outs[1]["x"] == outs[0]["x"] and outs[2]["x"] == outs[0]["x"]


# ------------------------------------------------------------------ a store that is not trusted
def _warnings(out: dict) -> list[str]:
    return [line for line in out["stderr"].splitlines() if "compiled-kernel cache" in line]


@pytest.mark.heavy
def test_an_ancestor_others_may_write_in_means_no_cache(tmp_path):
    """A group- or world-writable folder above the cache (without the sticky bit) lets
    others swap the cache folder: not used (plain jax.jit), one warning, same result; with the
    sticky bit (as /tmp) it is used."""
    shared = tmp_path / "shared"
    shared.mkdir()
    cache = shared / "dampfit" / "cache"
    good = _run(tmp_path, None)
    for mode, who in ((0o775, "its group"), (0o757, "everyone")):
        shared.chmod(mode)
        out = _run(tmp_path, cache)
        assert (out["compiled"], out["loaded"]) == (0, 0) and out["x"] == good["x"]
        assert not cache.exists()  # nothing created below the unsafe folder
        (line,) = _warnings(out)
        assert "not used" in line and f"{shared} is writable by {who}" in line
    shared.chmod(0o1777)
    first, second = _run(tmp_path, cache), _run(tmp_path, cache)
    assert (second["compiled"], second["loaded"]) == (0, 1) and not _warnings(second)
    assert second["x"] == first["x"] == good["x"]


def test_the_variable_naming_an_unsafe_folder_is_not_used(tmp_path):
    cache = tmp_path / "open"
    cache.mkdir()
    cache.chmod(0o777)
    out = _run(tmp_path, cache)
    assert (out["compiled"], out["loaded"]) == (0, 0)  # plain jax.jit: compiled in memory
    assert _entries(cache) == [] and not (cache / "hmac.key").exists()
    (line,) = _warnings(out)
    assert "writable by group or others" in line


def _stored(tmp_path: Path) -> tuple[Path, Path, dict]:
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    (entry,) = _entries(cache)
    return cache, entry, first


def _recompiled(tmp_path: Path, cache: Path, first: dict) -> Path:
    """Run again: the entry is not loaded but compiled, with the same result, and stored anew
    as the user's own private file; returns it."""
    out = _run(tmp_path, cache)
    assert (out["compiled"], out["loaded"]) == (1, 0)
    assert out["x"] == first["x"] and out["s"] == first["s"]
    (entry,) = _entries(cache)
    st = entry.lstat()
    assert stat.S_ISREG(st.st_mode) and st.st_uid == os.geteuid()
    assert stat.S_IMODE(st.st_mode) == 0o600
    return entry


@pytest.mark.heavy
def test_an_entry_of_another_mode_or_a_link_is_not_loaded(tmp_path):
    cache, entry, first = _stored(tmp_path)
    for mode in (0o666, 0o644):
        entry.chmod(mode)
        entry = _recompiled(tmp_path, cache, first)
    elsewhere = tmp_path / "elsewhere.exe"
    entry.rename(elsewhere)
    entry.symlink_to(elsewhere)
    before = elsewhere.read_bytes()
    entry = _recompiled(tmp_path, cache, first)
    assert elsewhere.read_bytes() == before  # the link was replaced, not its target


@pytest.mark.heavy
def test_an_entry_of_another_user_is_not_loaded(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("only root can give a file to another user")
    cache, entry, first = _stored(tmp_path)
    os.chown(entry, 4321, -1)
    _recompiled(tmp_path, cache, first)


@pytest.mark.heavy
def test_bit_flipped_entries_are_recompiled_and_the_process_survives(tmp_path):
    cache, entry, first = _stored(tmp_path)
    for where in ("header", "payload", "tag"):
        data = bytearray(entry.read_bytes())
        at = {"header": 30, "payload": len(data) // 2, "tag": len(data) - 1}[where]
        data[at] ^= 0x10
        entry.write_bytes(bytes(data))
        entry = _recompiled(tmp_path, cache, first)


@pytest.mark.heavy
def test_entries_are_not_trusted_without_their_key(tmp_path):
    cache, entry, first = _stored(tmp_path)
    key = cache / "hmac.key"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600 and key.stat().st_size == 32
    planted = tmp_path / "planted.key"
    planted.write_bytes(b"k" * 32)
    for how in ("missing", "replaced", "symlink"):
        key.unlink()
        if how == "replaced":
            key.write_bytes(os.urandom(32))
            key.chmod(0o600)
        elif how == "symlink":
            key.symlink_to(planted)
        _recompiled(tmp_path, cache, first)
        assert not key.is_symlink() and key.stat().st_size == 32
    assert planted.read_bytes() == b"k" * 32


def test_the_cli_passes_on_only_a_folder_it_checked(tmp_path, monkeypatch):
    """DAMPFIT_EXECUTABLE_CACHE set from outside never reaches the kernels of a CLI run: the
    CLI replaces it with its own checked folder, or removes it."""
    from dampfit import cli
    from dampfit.inference import executables

    planted = tmp_path / "planted"
    planted.mkdir()
    planted.chmod(0o777)
    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.setenv(executables.ENV, str(planted))
    monkeypatch.setenv(cli.CACHE_ENV, "off")
    assert cli._compile_cache() is None and executables.ENV not in os.environ
    monkeypatch.setenv(executables.ENV, str(planted))
    monkeypatch.setenv(cli.CACHE_ENV, str(tmp_path / "ours"))
    assert cli._compile_cache() == tmp_path / "ours"
    assert os.environ[executables.ENV] == str(tmp_path / "ours")
    assert executables.store_dir() == tmp_path / "ours"
    assert not any(planted.iterdir())
