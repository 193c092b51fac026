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
In every process — the CLI, a script, a notebook, a Dask worker of ``dampfit study`` or
``dampfit batch`` — unless switched off: the folder is :data:`ENV` when set (the CLI sets it
to the folder it checked, and child processes inherit it), else the user's choice in
:data:`SWITCH` (``DAMPFIT_JAX_CACHE=/some/folder``), else ``$XDG_CACHE_HOME/dampfit/jax``
(``~/.cache/dampfit/jax``): :func:`chosen_folder`. ``DAMPFIT_JAX_CACHE=off`` (or ``0``,
``no``, ``false``) switches it off, and so does a ``JAX_COMPILATION_CACHE_DIR`` the user set
(JAX's own cache then serves; see below). The folder is used only if it passes the checks of
:mod:`dampfit.files.private` in this process: every folder
from ``/`` down owned by the user or root and writable by nobody else (or sticky), the folder
itself the user's own. Otherwise a :class:`Kernel` is exactly ``jax.jit`` (one warning, once
per process, when the folder is unsafe: :func:`store`; a folder that cannot be created, as in
a read-only home, silently means no store).

An entry is one file: its metadata (JSON) and the serialised executable, authenticated with
an HMAC-SHA256 under a random key kept in the folder. It is read only if it is a regular file
of the user with mode 0600 (opened with ``O_NOFOLLOW``, checked with ``fstat``) and its tag
verifies; anything else — a symbolic link, another owner, a flipped bit, an entry from
another account or machine — is deleted and the kernel compiled, and the executable is never
deserialised (deserialising runs a pickle, and a damaged executable can crash the process).
Any other failure to read, write or load an entry (a stale file) also falls back to
compiling, and the entry is rewritten (atomically).

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
and jaxlib versions, the platform and device kind, the processor's model and instruction-set
flags (:func:`_cpu`: an executable compiled for another processor of a shared home folder
could use instructions this one lacks); and a digest of the *source of the whole
dampfit package* (:func:`source_digest`), so that editing any module (a law, the profile) can
never load an executable of the old code. Outputs must be arrays or (nested) tuples/lists of
arrays (their structure is stored as JSON, not pickled); a kernel with other outputs is
compiled and kept in memory only.

A compile is announced where progress is reported (:func:`dampfit._progress.announce`: the
CLI without ``--quiet``) with an estimate, this kernel's last compile time on this machine,
kept in the store's ``compile-times.json`` entry (authenticated as the others; an estimate
only, so a missing or damaged one just means "its first compile here").

Calls go through :class:`jax.stages.Compiled` (≈ 50 µs more per call than ``jax.jit``'s C++
path), so kernels called thousands of times per run (the sampler's log-probability) stay on
``jax.jit``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import platform
import re
import struct
import threading
import time
import warnings
from pathlib import Path
from typing import Any, Callable

from dampfit._progress import announce
from dampfit.files.private import PrivateStore, UnsafeFolder, open_store

#: Environment variable naming the checked folder of stored executables (set by the CLI for
#: itself and its child processes; unset: :data:`SWITCH` or the default folder decides).
ENV = "DAMPFIT_EXECUTABLE_CACHE"
#: The user's switch: a folder to use, or ``off`` (``0``, ``no``, ``false``); unset: the default.
SWITCH = "DAMPFIT_JAX_CACHE"
_OFF = ("off", "0", "no", "false")
#: First bytes of an entry (format version 2: one authenticated file).
_MAGIC = b"dampfit-executable\x02"
_LENGTH = struct.Struct(">Q")


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


_STORES: dict[str, PrivateStore | None] = {}
_STORES_LOCK = threading.Lock()


def open_checked(folder: str) -> PrivateStore:
    """The store in ``folder`` for this process (opened and checked once; created 0700 if
    missing). Raises :class:`~dampfit.files.private.UnsafeFolder` (with the reason) or
    :class:`OSError` (cannot be created or read) when it must not or cannot be used."""
    with _STORES_LOCK:
        if _STORES.get(folder) is not None:
            return _STORES[folder]
        opened = open_store(folder)
        _STORES[folder] = opened
        return opened


def chosen_folder() -> Path | None:
    """The folder the user's settings choose for stored executables (not yet checked), or
    None when switched off: :data:`SWITCH` is ``off`` (``0``, ``no``, ``false``), or the user
    set ``JAX_COMPILATION_CACHE_DIR`` (module docstring); else :data:`SWITCH`'s folder, else
    ``$XDG_CACHE_HOME/dampfit/jax`` (``~/.cache/dampfit/jax``). :data:`ENV` is not read here."""
    env = os.environ
    return _chosen(env.get(SWITCH, ""), env.get("JAX_COMPILATION_CACHE_DIR", ""),
                   env.get("XDG_CACHE_HOME", ""), env.get("HOME", ""))


@functools.lru_cache(maxsize=8)
def _chosen(choice: str, jax_cache: str, xdg: str, home: str) -> Path | None:
    """:func:`chosen_folder` of these settings (cached: the kernels ask on every call)."""
    choice = choice.strip()
    if choice.lower() in _OFF or jax_cache:
        return None
    if choice:
        return Path(os.path.abspath(choice))
    base = xdg or os.path.join(home or os.path.expanduser("~"), ".cache")
    return Path(os.path.abspath(os.path.join(base, "dampfit", "jax")))


def store() -> PrivateStore | None:
    """The checked store of this process (:data:`ENV`, else :func:`chosen_folder`; an empty
    :data:`ENV` means off), or None:
    switched off, unusable (a read-only home: silently), or unsafe (then one
    :class:`RuntimeWarning`, once per process and folder)."""
    base = os.environ.get(ENV)
    if base == "":  # a parent process (the CLI) found its folder unusable and said so
        return None
    if base is None:
        chosen = chosen_folder()
        if chosen is None:
            return None
        base = str(chosen)
    if base in _STORES:
        return _STORES[base]
    try:
        return open_checked(base)
    except (UnsafeFolder, OSError) as exc:
        with _STORES_LOCK:
            _STORES[base] = None
        if isinstance(exc, UnsafeFolder):
            warnings.warn(f"dampfit: compiled-kernel cache {base} not used: {exc}",
                          RuntimeWarning, stacklevel=3)
        return None


def store_dir() -> Path | None:
    """The real path of the executables' folder in use (:func:`store`), or None."""
    opened = store()
    return None if opened is None else opened.path


def _disable(opened: PrivateStore, exc: Exception) -> None:
    """The folder stopped being private while in use: stop using it (one warning)."""
    with _STORES_LOCK:
        for key, value in list(_STORES.items()):
            if value is opened:
                _STORES[key] = None
    warnings.warn(f"dampfit: compiled-kernel cache {opened.path} no longer used: {exc}",
                  RuntimeWarning, stacklevel=3)


@functools.lru_cache(maxsize=1)
def _cpu() -> str:
    """The processor's model and instruction-set flags (Linux ``/proc/cpuinfo``, first
    processor), else what :mod:`platform` knows."""
    lines = []
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if not line.strip():
                    break  # the first processor's block is enough
                key = line.split(":", 1)[0].strip()
                if key in ("vendor_id", "model name", "flags", "Features", "CPU implementer",
                           "CPU part", "isa"):
                    lines.append(line.strip())
    except OSError:
        pass
    return hashlib.sha256("\n".join(lines or [platform.machine(), platform.processor()])
                          .encode()).hexdigest()


@functools.lru_cache(maxsize=1)
def _environment() -> str:
    import jax
    import jaxlib

    dev = jax.devices()[0]
    return json.dumps([jax.__version__, jaxlib.__version__, dev.platform,
                       getattr(dev, "device_kind", ""), _cpu(), source_digest()])


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
        folder = store()
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

    def _variant(self, args) -> str:
        """`` (n=2, max_steps=40)``: the static arguments that make this executable one of
        several of the same kernel (a modal kernel compiles once per number of modes), by
        the kernel's own parameter names; "" without static arguments."""
        import inspect

        if not self._static:
            return ""
        try:
            names = list(inspect.signature(self._fn).parameters)
        except (TypeError, ValueError):
            names = []
        said = [f"{names[i] if i < len(names) else i}={args[i]!r}"[:40] for i in self._static]
        return " (" + ", ".join(said) + ")"

    def _load_or_compile(self, folder: PrivateStore, signature: str, args):
        import jax
        from jax.experimental import serialize_executable

        digest = hashlib.sha256((signature + _environment()).encode()).hexdigest()
        stem = re.sub(r"[^A-Za-z0-9_]", "_", self._fn.__name__).strip("_")[:60] or "kernel"
        name = f"{stem}-{digest[:40]}.exe"
        dynamic = tuple(a for i, a in enumerate(args) if i not in self._static)
        in_tree = jax.tree_util.tree_structure((dynamic, {}))
        try:
            entry = _unpack(folder.read(name))  # None unless authenticated (module docstring)
            if (entry is not None and entry[0].get("signature") == signature
                    and entry[0].get("environment") == _environment()):
                _prepare_lapack()
                exe = serialize_executable.deserialize_and_load(
                    entry[1], in_tree, _tree(entry[0]["out"]))
                self.loaded += 1
                return exe, True
        except UnsafeFolder as exc:
            _disable(folder, exc)
            folder = None
        except Exception:  # noqa: BLE001 - missing or stale entry: compile instead
            pass
        variant = self._variant(args)
        announce(f"compiling kernel {stem}{variant} for shapes this machine has not compiled "
                 f"yet ({_input_words(dynamic)}{_estimate(folder, stem, variant)})")
        t0 = time.monotonic()
        lowered = self._jit.lower(*args)
        compiled = lowered.compile()
        self.compiled += 1
        _COMPILED[0] += 1
        seconds = time.monotonic() - t0
        kept = False
        try:
            payload, _, out_tree = serialize_executable.serialize(compiled)
            skeleton = _skeleton(out_tree)
            if (folder is not None and skeleton is not None and _loadable(lowered.as_text())
                    and _reloads(payload, in_tree, out_tree, compiled, dynamic)):
                meta = {"signature": signature, "environment": _environment(), "out": skeleton}
                folder.write(name, _pack(meta, payload))
                kept = True
        except UnsafeFolder as exc:
            _disable(folder, exc)
            folder = None
        except Exception:  # noqa: BLE001 - a cache that cannot be written only costs time
            pass
        _record_time(folder, stem + variant, seconds, kept)
        return compiled, False


def _input_words(dynamic) -> str:
    """``input 64×3; ``: the shape of a kernel's first array argument, so that the
    compiles of one kernel for several shapes in one run (a sampler's whole ensemble and its
    halves) are told apart; "" for a scalar or no array."""
    import jax

    for leaf in jax.tree_util.tree_leaves(dynamic):
        shape = getattr(leaf, "shape", None)
        if shape:
            return "input " + "×".join(str(int(d)) for d in shape) + "; "
    return ""


#: Kernels compiled in this process because the store lacked them (:func:`compiled_count`).
_COMPILED = [0]


def compiled_count() -> int:
    """How many kernels this process compiled because the store lacked them (a warm store:
    none; the count ``dampfit warm-up`` reports)."""
    return _COMPILED[0]


#: The store's entry of the last compile time [s] of each kernel on this machine (the
#: estimate announced before the next compile of it: :func:`_estimate`).
_TIMES = "compile-times.json"


def _compile_times(folder: PrivateStore | None) -> dict[str, dict]:
    """``{kernel and variant: {"seconds": s, "kept": bool}}`` as recorded by
    :func:`_record_time` (an entry someone edited into another shape is ignored)."""
    try:
        entry = _unpack(folder.read(_TIMES)) if folder is not None else None
    except Exception:  # noqa: BLE001 - an estimate only
        entry = None
    times = entry[0].get("kernels") if entry is not None else None
    if not isinstance(times, dict):
        return {}
    return {k: v for k, v in times.items() if isinstance(k, str) and isinstance(v, dict)
            and isinstance(v.get("seconds"), (int, float)) and math.isfinite(v["seconds"])
            and v["seconds"] >= 0 and isinstance(v.get("kept"), bool)}


def _estimate(folder: PrivateStore | None, stem: str, variant: str = "") -> str:
    """What the announcement of a compile says beside it: whether the executable will be kept
    for later runs, and ``~N s`` from this machine's last compile of this kernel and variant
    (else of another variant of the same kernel, and said so), or that it is the first.

    Whether it will be kept is known only after the compile (:meth:`Kernel._load_or_compile`
    stores only executables that reload bit-identically and call nothing unloadable); the
    announcement says "kept for later runs" only when the store is in use and this kernel's
    last compile here was kept (or it has none yet, the usual case), and says it is not when the
    last one was not."""
    from dampfit._progress import eta_text

    if folder is None:
        return "not kept: no usable store of compiled kernels"
    times = _compile_times(folder)
    own = times.get(stem + variant)
    siblings = [v for k, v in times.items() if k == stem or k.startswith(stem + " (")]
    last = own or (max(siblings, key=lambda v: v["seconds"]) if siblings else None)
    if last is not None and not last["kept"]:
        keeping = "not kept: its last compile here could not be stored"
    else:
        keeping = "kept for later runs"
    if own is not None:
        return f"{keeping}; {eta_text(own['seconds'])}: its last compile here took that"
    if last is not None:
        return f"{keeping}; {eta_text(last['seconds'])}: another variant of it took that here"
    return f"{keeping}; its first compile here: seconds to a minute"


def _record_time(folder: PrivateStore | None, key: str, seconds: float, kept: bool) -> None:
    if folder is None:
        return
    times = _compile_times(folder)
    times[key] = {"seconds": round(float(seconds), 3), "kept": bool(kept)}
    try:
        folder.write(_TIMES, _pack({"kernels": times}, b""))
    except Exception:  # noqa: BLE001 - an estimate only
        pass


def _pack(meta: dict, payload: bytes) -> bytes:
    head = json.dumps(meta).encode()
    return _MAGIC + _LENGTH.pack(len(head)) + head + payload


def _unpack(body: bytes | None) -> tuple[dict, bytes] | None:
    """(metadata, serialised executable) of an authenticated entry's body, or None."""
    if body is None or not body.startswith(_MAGIC):
        return None
    start = len(_MAGIC) + _LENGTH.size
    (size,) = _LENGTH.unpack_from(body, len(_MAGIC))
    meta = json.loads(body[start:start + size])
    return (meta, body[start + size:]) if isinstance(meta, dict) else None


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


def kernel(fn: Callable | None = None, *, static_argnums: tuple[int, ...] = ()):
    """Decorator: ``@kernel`` or ``@kernel(static_argnums=(0,))`` makes a :class:`Kernel`."""
    if fn is None:
        return lambda f: Kernel(f, static_argnums)
    return Kernel(fn, static_argnums)
