r"""Subspace (matrix pencil) estimate of several damped modes, its model order, spectrum peaks.

Matrix pencil
-------------
Uniform samples x_n = x(n·Δ) (n = 0 … N−1, Δ = 1/f_s [s]) of K real damped modes are a sum of
M = 2K complex exponentials plus noise,

    x_n = Σ_{m=1}^{M} c_m·z_m^n + e_n,   z_m = exp((−p_m ± iω_m)·Δ).                         (S1)

The Hankel matrix Y (N − L) × (L + 1), Y_{jk} = x_{j+k}, with pencil parameter L = N/3 (capped
at :data:`MAX_PENCIL`), has rank M without noise. Its SVD Y = UΣVᴴ gives the signal subspace
V_M (the M leading right singular vectors); the poles are the eigenvalues of V₁⁺V₂, V₁ and V₂
being V_M without its last and its first row (the total-least-squares matrix pencil, Hua &
Sarkar, IEEE Trans. ASSP 38(5), 814–824, 1990; with this truncation it coincides in form with
TLS-ESPRIT, Roy & Kailath 1989). s_m = f_s·ln z_m = −p_m + iω_m [1/s]; the complex amplitudes
c_m follow from the Vandermonde least squares of (S1).

Model order
-----------
Two rules on the singular values σ_1 ≥ … ≥ σ_P (P = L + 1), reported side by side:

* **MDL** (Wax & Kailath, IEEE Trans. ASSP 33(2), 387–392, 1985) with λ_i = σ_i² and
  N' = N − L snapshots:

      MDL(k) = −N'·(P − k)·ln(g_k/a_k) + ½·k·(2P − k)·ln N',                               (S2)

  g_k and a_k the geometric and arithmetic means of λ_{k+1} … λ_P; the order minimises it.
  The Hankel rows overlap (they are not independent snapshots), so MDL tends to
  over-estimate; here it only sets how many candidate poles are kept;
* **SVD gap**: the k ≤ k_max with the largest ratio σ_k/σ_{k+1};
* **noise floor**: the number of σ_k above :data:`FLOOR_FACTOR` × the median of the lower
  half of the singular values (the noise level; white noise gives a flat tail) — robust to
  modes of unequal strength, where the largest gap separates the strongest mode only.

Both count complex exponentials; a real mode is a conjugate pair (two). The number of modes
itself is chosen by the evidence (:mod:`dampfit.inference.modes`); the poles are starting
values.

Spectrum peaks
--------------
:func:`spectrum_peaks` lists the local maxima of a Hann-windowed, 4× zero-padded periodogram in
a band [Hz], strongest first, refined by parabolic interpolation of the log power
(:func:`dampfit.signal.spectrum.parabolic_peak`), each at least one resolution cell 1/T from a
stronger one.

All functions are plain NumPy/SciPy, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from dampfit.errors import InputError
from dampfit.signal import filters
from dampfit.signal.spectrum import parabolic_peak

#: Largest pencil parameter L (the SVD costs O(N·L²)).
MAX_PENCIL = 200
#: Most samples decomposed (the start of the window: every mode is strongest there).
MAX_SAMPLES = 4000
#: Noise-floor order rule: singular values this many times the floor count as signal.
FLOOR_FACTOR = 3.0


@dataclass(frozen=True)
class Pole:
    """One oscillating pole: decay rate ``p`` [1/s] (negative: growing), damped angular
    frequency ``omega_d`` [rad/s], acceleration envelope amplitude at the first sample
    ``amplitude`` [m/s²] (2|c| of S1) and ``energy`` Σ_n (amplitude·e^{−pτ_n})²/2 [(m/s²)²]
    (how much of the record it explains)."""

    p: float
    omega_d: float
    amplitude: float
    energy: float

    @property
    def f_d(self) -> float:
        """Damped frequency [Hz]."""
        return self.omega_d / (2 * np.pi)


@dataclass(frozen=True)
class PencilResult:
    """Matrix pencil result: oscillating ``poles`` (strongest first), the orders of (S2), of
    the SVD gap and of the noise floor [complex exponentials], the ``singular_values`` of the
    Hankel matrix, the rate ``fs`` [Hz] and number of samples ``n`` decomposed."""

    poles: tuple[Pole, ...]
    order_mdl: int
    order_gap: int
    order_floor: int
    singular_values: np.ndarray
    fs: float
    n: int


def mdl_order(sv: np.ndarray, n_snapshots: int, k_max: int | None = None) -> int:
    """Order minimising MDL (S2) from singular values ``sv`` (descending) of a Hankel matrix
    with ``n_snapshots`` rows; searched over 0 … ``k_max`` (default P − 1)."""
    lam = np.asarray(sv, dtype=float) ** 2
    lam = np.maximum(lam, lam[0] * 1e-300 if lam.size else 1e-300)
    p = lam.size
    k_max = p - 1 if k_max is None else min(int(k_max), p - 1)
    n = float(n_snapshots)
    best, best_k = np.inf, 0
    for k in range(k_max + 1):
        tail = lam[k:]
        ln_g = float(np.mean(np.log(tail)))
        ln_a = float(np.log(np.mean(tail)))
        mdl = -n * (p - k) * (ln_g - ln_a) + 0.5 * k * (2 * p - k) * np.log(n)
        if mdl < best:
            best, best_k = mdl, k
    return best_k


def gap_order(sv: np.ndarray, k_max: int) -> int:
    """The k ∈ [1, ``k_max``] with the largest σ_k/σ_{k+1} (the SVD gap)."""
    s = np.asarray(sv, dtype=float)
    k_max = max(1, min(int(k_max), s.size - 1))
    ratio = s[:k_max] / np.maximum(s[1:k_max + 1], 1e-300)
    return int(np.argmax(ratio)) + 1


def floor_order(sv: np.ndarray, factor: float = FLOOR_FACTOR) -> int:
    """Number of singular values ``sv`` (descending) above ``factor`` × the median of their
    lower half (the noise floor)."""
    s = np.asarray(sv, dtype=float)
    floor = float(np.median(s[s.size // 2:])) if s.size > 1 else 0.0
    return int(np.sum(s > factor * floor))


def matrix_pencil(x, fs: float, *, max_order: int, band: tuple[float, float] | None = None,
                  order: int | None = None) -> PencilResult:
    """Poles of uniform samples ``x`` [m/s²] at ``fs`` [Hz] by the TLS matrix pencil (S1).

    The signal subspace has ``order`` complex exponentials, by default the MDL order (S2)
    clipped to [2, ``max_order``]; poles with ω_d ≤ 0 (the conjugates) are dropped and, with
    ``band`` [Hz], those outside it. Returns the oscillating poles, strongest (``energy``)
    first. Raises :class:`InputError` when there are fewer than 3·``max_order`` samples.
    """
    x = np.asarray(x, dtype=float)[:MAX_SAMPLES]
    n = x.size
    max_order = int(max_order)
    if n < 3 * max_order or max_order < 2:
        raise InputError(f"{n} samples cannot hold a pencil of order {max_order}")
    ell = int(min(n // 3, MAX_PENCIL))
    hank = np.lib.stride_tricks.sliding_window_view(x, ell + 1)  # (n − L) × (L + 1)
    # right singular vectors and values from the (L + 1)² Gram matrix (cheaper than the SVD)
    lam, vec = np.linalg.eigh(hank.T @ hank)
    lam, vec = lam[::-1], vec[:, ::-1]
    sv, vh = np.sqrt(np.maximum(lam, 0.0)), vec.T
    k_mdl = mdl_order(sv, n - ell, k_max=min(ell, 4 * max_order))
    k_gap = gap_order(sv, max_order)
    m = int(np.clip(k_mdl if order is None else order, 2, max_order))
    v = vh[:m].conj().T
    z = np.linalg.eigvals(np.linalg.pinv(v[:-1]) @ v[1:]).astype(complex)
    z = z[np.abs(z) > 0]
    s = np.log(z) * fs
    # complex amplitudes from the Vandermonde least squares of (S1)
    k = np.arange(n)[:, None]
    vand = np.exp(np.clip(np.log(z)[None, :] * k, -700, 700))
    c = np.linalg.lstsq(vand, x.astype(complex), rcond=None)[0]
    poles = []
    for sm, cm in zip(s, c):
        w, p = float(sm.imag), float(-sm.real)
        if w <= 0 or (band is not None and not band[0] <= w / (2 * np.pi) <= band[1]):
            continue
        amp = 2.0 * abs(cm)
        decay = np.exp(-2.0 * p * np.arange(n) / fs)
        poles.append(Pole(p=p, omega_d=w, amplitude=float(amp),
                          energy=float(0.5 * amp**2 * np.sum(decay))))
    poles.sort(key=lambda q: -q.energy)
    return PencilResult(poles=tuple(poles), order_mdl=int(k_mdl), order_gap=int(k_gap),
                        order_floor=floor_order(sv), singular_values=sv, fs=float(fs), n=int(n))


def uniform_window(grid, values, fs: float, window: tuple[float, float],
                   band: tuple[float, float]) -> tuple[np.ndarray, float]:
    """Uniform samples [m/s²] of the window ``window`` [s] of a signal on a uniform ``grid``
    [s] at ``fs`` [Hz], linear trend removed, low-passed (zero-phase Butterworth) at the
    upper band edge and decimated to ≥ 2.5× it; returns (samples, their rate [Hz])."""
    grid, values = np.asarray(grid, dtype=float), np.asarray(values, dtype=float)
    sel = (grid >= window[0]) & (grid <= window[1])
    y = signal.detrend(values[sel])
    hi = float(band[1])
    q = max(1, int(np.floor(fs / (2.5 * hi))))
    if q > 1:
        y = filters.lowpass(y, fs, hi)
    return y[::q], fs / q


def spectrum_peaks(x, fs: float, band: tuple[float, float], n_peaks: int = 6,
                   ) -> list[tuple[float, float]]:
    """The ``n_peaks`` strongest local maxima of the periodogram of uniform samples ``x``
    [m/s²] at ``fs`` [Hz] inside ``band`` [Hz]: ``[(frequency [Hz], amplitude [m/s²]), …]``,
    strongest first, each at least 1/T [Hz] (T = the record length) from a stronger one."""
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 8:
        return []
    win = signal.windows.hann(n)
    nfft = int(2 ** np.ceil(np.log2(4 * n)))
    spec = np.abs(np.fft.rfft((x - x.mean()) * win, nfft)) * 2.0 / win.sum()
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    inside = (f >= band[0]) & (f <= band[1])
    logp = np.log(spec**2 + 1e-300)
    cand = np.flatnonzero(inside[1:-1] & (spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
    cand = cand[np.argsort(-spec[cand])]
    cell = fs / n
    out: list[tuple[float, float]] = []
    for i in cand:
        fi = float(f[i] + parabolic_peak(logp, int(i)) * (f[1] - f[0]))
        if all(abs(fi - g) >= cell for g, _ in out):
            out.append((fi, float(spec[i])))
        if len(out) >= n_peaks:
            break
    return out
