"""Compiled kernels kept on disk between processes (dampfit.inference.executables).

A second process must load what the first compiled (no tracing, same numbers), including a
kernel that calls LAPACK (a loaded executable once crashed the process there); a damaged or
foreign entry must be recompiled, never trusted; without the store nothing is written; a
copy of an executable that JAX itself loaded from its own cache (which serialises without its
fused code) must never be stored.
"""

from __future__ import annotations

import json
import os
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


def _run(tmp_path: Path, cache: Path | None) -> dict:
    env = dict(os.environ)
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    env.pop("DAMPFIT_EXECUTABLE_CACHE", None)
    if cache is not None:
        env["DAMPFIT_EXECUTABLE_CACHE"] = str(cache)
    script = tmp_path / "kernel_script.py"
    script.write_text(SCRIPT)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _entries(cache: Path) -> list[Path]:
    return sorted(cache.glob("*.bin")) if cache.exists() else []


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


def test_damaged_or_foreign_entry_is_recompiled(tmp_path):
    cache = tmp_path / "cache"
    good = _run(tmp_path, cache)
    (entry,) = _entries(cache)
    entry.write_bytes(b"\x00" * 64)  # damaged payload: its checksum no longer matches
    again = _run(tmp_path, cache)
    assert (again["compiled"], again["loaded"]) == (1, 0)
    assert again["x"] == good["x"]
    meta = entry.with_suffix(".json")
    data = json.loads(meta.read_text())
    data["environment"] = data["environment"].replace("cpu", "gpu")  # another machine's entry
    meta.write_text(json.dumps(data))
    third = _run(tmp_path, cache)
    assert (third["compiled"], third["loaded"]) == (1, 0)
    fourth = _run(tmp_path, cache)  # rewritten by the third run
    assert (fourth["compiled"], fourth["loaded"]) == (0, 1)


def test_without_the_store_nothing_is_written(tmp_path):
    out = _run(tmp_path, None)
    assert (out["compiled"], out["loaded"]) == (0, 0)  # plain jax.jit
    assert not list(tmp_path.rglob("*.bin"))


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
