r"""Compiled JAX kernels kept on disk between processes: :func:`kernel`.

Why
---
JAX's persistent compilation cache (switched on by the CLI, :mod:`dampfit.cli`) saves the
XLA *compilation* of a kernel, but a fresh process still traces the Python function and lowers
it to StableHLO before it can even look the executable up — for the least squares (an
optimistix Levenberg–Marquardt loop), the damping-law profiles and the CRLB that is ≈ 1 s of a
warm CLI run, more than the fits themselves. A :class:`Kernel` stores the *compiled*
executable (:mod:`jax.experimental.serialize_executable`) the first time it meets a signature
and later processes load it in a few milliseconds, with no tracing or lowering at all.

When it is used
---------------
Only where the environment variable :data:`ENV` names a folder (the CLI sets it after checking
that the folder is private, :mod:`dampfit.cli`); otherwise a :class:`Kernel` is exactly
``jax.jit``. Any failure to read, write or load an entry (a foreign, truncated or stale file)
falls back to compiling, and the entry is rewritten (atomically).

This store *replaces* JAX's own persistent compilation cache in CLI runs, it does not sit on
top of it: an executable that JAX loaded from its cache serialises without the code of its
fused functions (jaxlib 0.10 CPU; the copy fails with "Function …_fusion not found" when
called). Every executable is therefore checked before it is stored — loaded back and called on
the arguments it was compiled for, its outputs compared bit for bit — and stored only if it
passes; under a user's own ``JAX_COMPILATION_CACHE_DIR`` a kernel may then simply not be stored.

Keys
----
An entry is found by the SHA-256 of: the kernel's name; the static arguments' ``repr``; the
pytree structure, shapes, dtypes and weak types of the other arguments; the x64 flag; the JAX
and jaxlib versions, the platform and device kind; and a digest of the *source of the whole
dampfit package* (:func:`source_digest`), so that editing any module (a law, the profile) can
never load an executable of the old code. Outputs must be arrays or (nested) tuples/lists of
arrays (their structure is stored as JSON, not pickled); a kernel with other outputs is
compiled and kept in memory only.

Calls go through :class:`jax.stages.Compiled` (≈ 50 µs more per call than ``jax.jit``'s C++
path), so kernels called thousands of times per run (the sampler's log-probability) stay on
``jax.jit``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any, Callable

__all__ = ["Kernel", "kernel", "source_digest", "store_dir"]

#: Environment variable naming the folder of stored executables (set by the CLI; unset: off).
ENV = "DAMPFIT_EXECUTABLE_CACHE"


@functools.lru_cache(maxsize=1)
def source_digest() -> str:
    """SHA-256 [hex] of every ``.py`` file of the installed dampfit package (relative paths and
    contents, sorted): any edit of the code gives new keys."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def store_dir() -> Path | None:
    """The executables' folder (``$DAMPFIT_EXECUTABLE_CACHE``), or None when unset."""
    base = os.environ.get(ENV)
    return Path(base) if base else None


@functools.lru_cache(maxsize=1)
def _environment() -> str:
    import jax
    import jaxlib

    dev = jax.devices()[0]
    return json.dumps([jax.__version__, jaxlib.__version__, dev.platform,
                       getattr(dev, "device_kind", ""), source_digest()])


def _quick_aval(x) -> tuple:
    """(type, shape, dtype, weak type) of an argument, without JAX's abstraction machinery."""
    shape = getattr(x, "shape", None)
    if shape is None:  # a Python scalar: weakly typed, its type decides the dtype
        return (type(x),)
    return (type(x), shape, str(x.dtype), bool(getattr(x, "weak_type", False)))


def _skeleton(tree) -> Any:
    """A JSON form of an output structure made of tuples/lists and leaves (None if other)."""
    import jax

    template = jax.tree_util.tree_unflatten(tree, [0] * tree.num_leaves)

    def encode(x):
        if isinstance(x, (tuple, list)):
            return {"tuple" if isinstance(x, tuple) else "list": [encode(v) for v in x]}
        if isinstance(x, int) and x == 0:
            return 0
        raise TypeError

    try:
        return encode(template)
    except TypeError:
        return None


def _tree(skeleton):
    import jax

    def decode(x):
        if isinstance(x, dict):
            (kind, items), = x.items()
            values = [decode(v) for v in items]
            return tuple(values) if kind == "tuple" else values
        return 0

    return jax.tree_util.tree_structure(decode(skeleton))


class Kernel:
    """``jax.jit(fn, static_argnums=…)`` whose compiled executables persist on disk (module
    docstring). Static arguments must have a ``repr`` that identifies them (the damping laws
    do)."""

    def __init__(self, fn: Callable, static_argnums: tuple[int, ...] = ()):
        import jax

        self._fn = fn
        self._static = tuple(static_argnums)
        self._jit = jax.jit(fn, static_argnums=self._static)
        self._name = f"{fn.__module__}.{fn.__qualname__}"
        self._memory: dict[str, Any] = {}
        #: how many executables this process loaded from disk and compiled (for tests)
        self.loaded = self.compiled = 0
        functools.update_wrapper(self, fn)

    def __call__(self, *args):
        folder = store_dir()
        if folder is None:
            return self._jit(*args)
        import jax
        from jax.api_util import shaped_abstractify

        static = tuple(args[i] for i in self._static)
        dynamic = tuple(a for i, a in enumerate(args) if i not in self._static)
        leaves, tree = jax.tree_util.tree_flatten(dynamic)
        x64 = bool(jax.config.jax_enable_x64)
        # the in-memory key: cheap to build on every call (a sampler calls thousands of times)
        quick = (static, tree, x64, tuple(_quick_aval(x) for x in leaves))
        exe = self._memory.get(quick)
        if exe is not None:
            return exe(*dynamic)
        avals = [str(shaped_abstractify(x)) for x in leaves]
        signature = json.dumps([self._name, [repr(a) for a in static], str(tree), avals, x64])
        exe, loaded = self._load_or_compile(folder, signature, args)
        if loaded:
            try:  # the first call of a loaded executable: a bad one raises here, not later
                out = exe(*dynamic)
            except Exception:  # noqa: BLE001 - fall back to compiling, never to a crash
                exe = self._jit.lower(*args).compile()
                self.compiled += 1
                out = exe(*dynamic)
        else:
            out = exe(*dynamic)
        self._memory[quick] = exe
        return out

    def _load_or_compile(self, folder: Path, signature: str, args):
        import jax
        from jax.experimental import serialize_executable

        digest = hashlib.sha256((signature + _environment()).encode()).hexdigest()
        stem = folder / f"{self._fn.__name__.strip('_')}-{digest[:40]}"
        dynamic = tuple(a for i, a in enumerate(args) if i not in self._static)
        in_tree = jax.tree_util.tree_structure((dynamic, {}))
        try:
            meta = json.loads(stem.with_suffix(".json").read_text())
            if meta.get("signature") == signature and meta.get("environment") == _environment():
                payload = stem.with_suffix(".bin").read_bytes()
                if hashlib.sha256(payload).hexdigest() == meta.get("payload_sha256"):
                    _prepare_lapack()
                    exe = serialize_executable.deserialize_and_load(
                        payload, in_tree, _tree(meta["out"]))
                    self.loaded += 1
                    return exe, True
        except Exception:  # noqa: BLE001 - missing, foreign or stale entry: compile instead
            pass
        lowered = self._jit.lower(*args)
        compiled = lowered.compile()
        self.compiled += 1
        try:
            payload, _, out_tree = serialize_executable.serialize(compiled)
            skeleton = _skeleton(out_tree)
            if (skeleton is not None and _loadable(lowered.as_text())
                    and _reloads(payload, in_tree, out_tree, compiled, dynamic)):
                meta = {"signature": signature, "environment": _environment(), "out": skeleton,
                        "payload_sha256": hashlib.sha256(payload).hexdigest()}
                folder.mkdir(mode=0o700, parents=True, exist_ok=True)
                _atomic(stem.with_suffix(".bin"), payload)
                _atomic(stem.with_suffix(".json"), json.dumps(meta).encode())
        except Exception:  # noqa: BLE001 - a cache that cannot be written only costs time
            pass
        return compiled, False


def _reloads(payload: bytes, in_tree, out_tree, compiled, dynamic) -> bool:
    """The serialised executable loads and computes exactly what ``compiled`` computes on the
    arguments ``dynamic`` (module docstring: a copy of a cache-loaded executable does not)."""
    import jax
    import numpy as np
    from jax.experimental import serialize_executable

    try:
        _prepare_lapack()
        copy = serialize_executable.deserialize_and_load(payload, in_tree, out_tree)
        got = jax.tree_util.tree_leaves(copy(*dynamic))
        want = jax.tree_util.tree_leaves(compiled(*dynamic))
    except Exception:  # noqa: BLE001
        return False
    return len(got) == len(want) and all(
        np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True) for a, b in zip(got, want))


#: Custom calls an executable may make and still be stored: jaxlib's LAPACK kernels, whose
#: function pointers :func:`_prepare_lapack` sets up before a load. Anything else (a host
#: callback, an FFT or GPU library) is compiled in every process instead: a loaded executable
#: calling an uninitialised target would crash the process.
_LOADABLE_CALLS = re.compile(r"lapack_[a-z]+_ffi")
_CUSTOM_CALL = re.compile(r"(?:stablehlo\.custom_call\s*@|custom_call_target\s*=\s*\")([\w.]+)")


def _loadable(hlo_text: str) -> bool:
    """The lowered module makes no custom call outside :data:`_LOADABLE_CALLS`."""
    if "callback" in hlo_text:
        return False
    return all(_LOADABLE_CALLS.fullmatch(name) for name in _CUSTOM_CALL.findall(hlo_text))


@functools.lru_cache(maxsize=1)
def _prepare_lapack() -> None:
    """Load jaxlib's LAPACK function pointers, which JAX otherwise sets up lazily while
    *lowering* a linear-algebra op — a loaded executable skips lowering (without this a call
    into LAPACK from a loaded executable dereferences a null pointer). The public route,
    lowering a 2×2 Cholesky factorisation, is the fallback if JAX's internal hook moves."""
    try:
        from jax._src.lax import linalg

        linalg.initialize_lapack()
    except Exception:  # noqa: BLE001
        import jax
        import jax.numpy as jnp
        import numpy as np

        jax.jit(jnp.linalg.cholesky).lower(np.eye(2))


def _atomic(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def kernel(fn: Callable | None = None, *, static_argnums: tuple[int, ...] = ()):
    """Decorator: ``@kernel`` or ``@kernel(static_argnums=(0,))`` makes a :class:`Kernel`."""
    if fn is None:
        return lambda f: Kernel(f, static_argnums)
    return Kernel(fn, static_argnums)
