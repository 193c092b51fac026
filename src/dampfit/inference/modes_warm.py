"""Compile the several-mode kernels for a shape without an analysis: :func:`warm_modal`.

Why
---
The modal stage (:mod:`dampfit.inference.modes_select`, :mod:`dampfit.inference.modes_posterior`)
runs four compiled kernels per number of modes K: the start-grid RSS (``_rss_batch``), the
vmapped Levenberg–Marquardt (``_fit_batch``), the optimum's details (``_details``) and, for the
K ≥ 2 that is sampled, the posterior's batched log-probability (``_batched_log_prob``, one
executable per batch size: the whole ensemble of max(64, 32 K) walkers at the start, a half or
a quarter of it per move). Their shapes are set by K, the modal fit's sample bucket
(:func:`dampfit.signal.prepare.padded_length`) and its drift-column bucket
(:func:`dampfit.inference.modes.drift_columns`), not by the recording's values. A one-mode
simulated recording (``dampfit warm-up``'s) compiles only K = 1 and only its own buckets, so a
real recording in which a second mode is found compiled ≈ 11 kernels on its first run
(``paper/results/first_run.md``: 50 cm cantilever, 42 s CPU first against 20 s warm).

How
---
Each kernel is called once with arguments of exactly the shapes, dtypes and static arguments the
analysis passes (float64 device arrays from :func:`dampfit.inference.modes.padded_arrays` of a
synthetic :class:`~dampfit.signal.prepare.FitData`; the LM step limit
:data:`dampfit.inference.modes.LM_STEPS`; the ensemble sizes of
:func:`dampfit.inference.modes_posterior.sample`), so the executables land in the compiled-kernel
store (:mod:`dampfit.inference.executables`) under the keys a real analysis looks up. The values
are a K-mode decay with modes spread over a factor 4 in frequency; they only need to be finite
(the store checks every executable by re-running it bit for bit).
"""

from __future__ import annotations

import math

import numpy as np

from dampfit.inference import modes as _modes
from dampfit.inference import modes_posterior as _mp
from dampfit.signal.prepare import FitData

_F0, _FS = 1.0, 10.0  # [Hz] the synthetic lowest mode and sample rate
#: Modal fit samples per drift degree on the decimated path [samples] (:func:`modal_pairs`).
_SAMPLES_PER_DEGREE = (640, 1280)


def drift_buckets(bucket: int) -> tuple[int, ...]:
    """The drift-column buckets (:func:`dampfit.inference.modes.drift_columns`) a modal fit of
    ``bucket`` padded samples falls in on the usual, decimated path (module docstring of
    :func:`modal_pairs`)."""
    prev = max((b for b in _sample_buckets_below(bucket)), default=0)
    lo = max(1, math.floor(prev / _SAMPLES_PER_DEGREE[1]))
    hi = max(1, min(math.ceil(bucket / _SAMPLES_PER_DEGREE[0]), _modes.MAX_DRIFT_DEGREE))
    cols = {_modes.drift_columns(d) for d in range(lo, hi + 1)}
    return tuple(sorted(cols))


def modal_pairs(max_samples: int) -> tuple[tuple[int, int], ...]:
    """(modal sample bucket, drift columns) pairs :func:`warm_modal` should cover for modal
    fits of up to ``max_samples`` samples.

    The modal fit (:func:`dampfit.inference.modes.modal_fit_data`) spans T [s] of the band
    f0/8 … 8 f0 (:data:`~dampfit.inference.modes.BAND_RATIO`), decimated to between 2.5 and
    5 times its upper edge: n ≈ T·(20 … 40)·f0 samples, with a drift of degree
    d = T·f0/32 (one degree per 4 cycles of the lower edge), so n/d ≈ 640 … 1280
    (:data:`_SAMPLES_PER_DEGREE`; the real recordings of ``../shared/data/real`` lie at
    600–850). A fit on the raw path or with the lower edge raised to 3 cycles of the window
    can have fewer samples per degree; its kernels compile on first use (announced).
    """
    from dampfit.signal.prepare import padded_length

    pairs, n = [], 1
    while n <= max_samples:
        b = padded_length(n)
        pairs += [(b, d) for d in drift_buckets(b)]
        n = b + 1
    return tuple(pairs)


def _sample_buckets_below(bucket: int) -> list[int]:
    from dampfit.signal.prepare import padded_length

    out, n = [], 1
    while True:
        b = padded_length(n)
        if b >= bucket:
            return out
        out.append(b)
        n = b + 1


def _fit_data(bucket: int, drift_columns: int) -> FitData:
    """A synthetic fit of padded length ``bucket`` whose drift falls in ``drift_columns``."""
    n = max(bucket * 3 // 4 + 1, 64) if bucket > 256 else 200
    tau = np.arange(n) / _FS
    y = sum(math.exp(-0.02 * i) * np.exp(-0.05 * tau) * np.cos(2 * math.pi * _F0 * (1 + i) * tau)
            for i in range(4))
    below = [b for b in _modes.drift_column_buckets() if b < drift_columns]
    degree = max(below[-1] if below else 1, 1)  # the smallest degree of that bucket
    return FitData(t0=0.0, tau=tau, y=np.asarray(y, float), drift_degree=degree, path="raw",
                   fs=_FS, lowpass_sos=None, fs_filter=_FS, n_excluded=0)


def _theta(k: int) -> np.ndarray:
    """θ = (ln p_i, ln ω_i) of ``k`` modes at f0·(1 … k), ζ = 1 %."""
    w = 2 * math.pi * _F0 * np.arange(1, k + 1)
    return np.column_stack([np.log(0.01 * w), np.log(w)]).reshape(-1).astype(np.float64)


def warm_modal(bucket: int, drift_columns: int, ks) -> None:
    """Compile (or load) the modal kernels of every K in ``ks`` for a modal fit of ``bucket``
    padded samples and ``drift_columns`` drift columns (module docstring)."""
    fd = _fit_data(bucket, drift_columns)
    band = (_F0 / _modes.BAND_RATIO, min(_modes.BAND_RATIO * _F0, 0.45 * _FS))
    for k in ks:
        if _modes.support(fd, k):
            continue
        _modes.warm_kernels(fd, _theta(k))
        if k >= 2:
            _mp.warm_log_prob(fd, _theta(k), band)
