"""Compile once per machine: :func:`warm_up` fills the compiled-kernel store for every sample
bucket a recording can fall in, so that a user's first real analysis loads its kernels.

Why
---
The kernels of an analysis (the least squares, each damping law's profile, the CRLB, the
samplers' log-probabilities) are compiled for the *shape* of the fitted samples, padded to a
bucket of the series 256·{1, 1.5}·2^k (:func:`dampfit.signal.prepare.padded_length`), and kept
on disk (:mod:`dampfit.inference.executables`, and JAX's own cache for the sampler kernels).
A new recording in a bucket already seen compiles nothing; one in a new bucket pays the whole
compilation again (``paper/results/compile_inventory.md``: ≈ a dozen XLA compilations, tens of
seconds of CPU).

How
---
For each bucket up to ``max_samples`` fitted samples, a simulated free decay
(:func:`dampfit.simulate.from_modal`) is sized so that its fitted samples fall in that bucket
(its sample rate is low enough for the raw path, so the fitted samples are the window's own;
the record length is found by a few prepare-only passes) and analysed with the default
options, its posterior run short (``max_steps``: the sampler's kernels depend on the shape,
not on the number of steps). Nothing is written but the store's entries. Progress: one stage
``warm-up`` over the buckets (:mod:`dampfit._progress`); the analyses inside it are silent.

Then the several-mode kernels: a one-mode simulated recording compiles the modal stage's
kernels for K = 1 and its own modal shapes only, while a real recording in which a second mode
is found needs K = 2 … 4 as well, for *its* modal sample bucket and drift-column bucket. A
second stage ``warm-up: several-mode kernels`` compiles the modal kernels of K = 1 …
:data:`~dampfit.inference.modes.DEFAULT_MAX_MODES` directly
(:func:`dampfit.inference.modes_warm.warm_modal`) for every (sample bucket, drift bucket) pair
a modal fit of up to ``max_samples`` samples falls in on the decimated path
(:func:`dampfit.inference.modes_warm.modal_pairs`: 20 pairs up to 12 288, ≈ 45 s of CPU each).
``modes=False`` skips it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from dampfit import _progress
from dampfit.errors import InputError

#: Default most fitted samples warmed: 12 288 (a raw record of 20 min at 10 Hz, or the
#: decimated fit of ≈ 30 min of a 2.5 Hz mode); larger buckets are compiled on first use.
DEFAULT_MAX_SAMPLES = 12288
#: The simulated oscillator [kg], [Hz] and its sample rate [Hz] (≤ 7.5 f: the raw path).
_MASS, _F_N, _RATE = 1.0, 1.5, 10.0
#: Short posteriors [steps]: enough to compile every sampler kernel.
_STEPS = 200


@dataclass(frozen=True)
class WarmUp:
    """What :func:`warm_up` did: the buckets [samples] it analysed a recording of, and the
    kernels compiled meanwhile (:class:`~dampfit.inference.executables.Kernel` compiles)."""

    buckets: tuple[int, ...]
    compiled: int


def sample_buckets(max_samples: int, min_samples: int = 1) -> tuple[int, ...]:
    """The padded sample buckets of fitted-sample counts ``min_samples`` … ``max_samples``."""
    from dampfit.signal.prepare import padded_length

    out, n = [], max(1, int(min_samples))
    while n <= max_samples:
        b = padded_length(n)
        out.append(b)
        n = b + 1
    return tuple(out)


def _fit_samples(rec) -> int:
    from dampfit.signal import prepare

    return int(prepare.fit_data(prepare.prepare(rec)).tau.size)


def recording_in_bucket(bucket: int, seed: int = 0):
    """A simulated free decay whose fitted samples fall in ``bucket`` (module docstring):
    (recording, fitted samples)."""
    from dampfit import simulate as sim
    from dampfit.signal.prepare import padded_length

    target = 0.85 * bucket  # above the bucket below (at most 3/4 of this one)
    duration = max(target / _RATE * 1.3, 30.0)
    for _ in range(8):
        zeta = min(0.02, 1.0 / (2 * math.pi * _F_N * duration))  # the decay spans the record
        cfg = sim.from_modal(_MASS, _F_N, zeta, duration=duration, sample_rate=_RATE, seed=seed)
        rec, _ = sim.recording(cfg)
        n = _fit_samples(rec)
        if padded_length(n) == bucket:
            return rec, n
        duration *= target / max(n, 1)
    raise InputError(f"warm-up: no simulated recording falls in the bucket of {bucket} samples")


def _warm_modes(max_samples: int) -> None:
    """The second stage of the module docstring: the modal kernels of K = 1 … 4."""
    from dampfit.inference.modes import DEFAULT_MAX_MODES
    from dampfit.inference.modes_warm import modal_pairs, warm_modal

    pairs = modal_pairs(max_samples)
    with _progress.stage_bar(len(pairs), "warm-up: several-mode kernels", unit="shape") as bar:
        for bucket, drift in pairs:
            warm_modal(bucket, drift, range(1, DEFAULT_MAX_MODES + 1))
            bar.update(1)


def warm_up(max_samples: int = DEFAULT_MAX_SAMPLES, *, seed: int = 0,
            modes: bool = True) -> WarmUp:
    """Analyse one simulated recording per sample bucket up to ``max_samples`` fitted samples
    and (``modes``) compile the several-mode kernels of the modal shapes up to it (module
    docstring), filling the compiled-kernel store; returns what was done."""
    from dampfit.inference.executables import compiled_count, store
    from dampfit.pipeline import analyze

    if not (isinstance(max_samples, int) and 256 <= max_samples):
        raise InputError(f"warm-up: max_samples must be an integer ≥ 256, got {max_samples!r}")
    if store() is None:
        raise InputError("warm-up: the compiled-kernel store is switched off or unusable "
                         "(DAMPFIT_JAX_CACHE); nothing would be kept")
    buckets = sample_buckets(max_samples, min_samples=256)
    before = compiled_count()
    with _progress.stage_bar(len(buckets), "warm-up: sample buckets", unit="bucket") as bar:
        for b in buckets:
            rec, _ = recording_in_bucket(b, seed)
            with _progress.silenced():
                analyze(rec, mass=_MASS, seed=seed, max_steps=_STEPS)
            bar.update(1)
    if modes:
        _warm_modes(max_samples)
    return WarmUp(buckets=buckets, compiled=compiled_count() - before)

