r"""Cramér–Rao lower bound (CRLB) of a free-decay recording design.

The data model is the acceleration (M1) of :mod:`dampfit.model.viscous` plus white Gaussian noise,

    y_i = e^{−pτ_i}·(A·cos ω_dτ_i + B·sin ω_dτ_i) + Σ_j c_j·Q_j(τ_i) + ε_i,   ε_i ~ N(0, σ_i²),

with φ = (p, ω_d, A, B, c_0…c_d) and Q the orthonormal Legendre drift basis of
:func:`dampfit.model.viscous.drift_basis` (degree d; ``drift_degree=None`` drops it). Its Fisher
information is F = Jᵀ·diag(1/σ²)·J with J = ∂y/∂φ (exact, in closed form; accumulated over
blocks of samples for a long design, :func:`_blocked_fisher`), and any
unbiased estimator has Cov φ̂ ⪰ F⁻¹. Derived quantities g(φ, m) — ζ = p/ω_n, f_n = ω_n/2π,
u₀ = √(A²+B²)/ω_n² (eq. M2), c = 2mp, k = m·ω_n² with ω_n² = p² + ω_d² — get
var ĝ ≥ ∇gᵀ·F⁻¹·∇g (delta method). A mass known only to ± s_m is independent prior
information and adds (∂g/∂m)²·s_m².

The closed form of Yao & Pandit (1995) for a single real damped sinusoid in white noise is
given for checking (:func:`yao_pandit_var_p`). Times ``τ`` [s] count from the instant at
which A, B and u₀ are defined (the analysed window's start).

Several modes (:func:`fisher_modes`, :func:`bound_modes`): the same Fisher information for the
K-mode model (MK1) of :mod:`dampfit.model.modes`, φ = (p_i, ω_i, A_i, B_i for every mode,
drift); each mode's bound comes from its 4×4 block of F⁻¹, so it carries the price of the
other modes (their overlap with it) — the bound of close modes grows as their separation
shrinks.

Reference: Y.-X. Yao and S. M. Pandit, "Cramér–Rao lower bounds for a damped sinusoidal
process", IEEE Trans. Signal Processing 43(4), 878–885, 1995.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from dampfit import physics
from dampfit.errors import InputError

__all__ = ["yao_pandit_var_p", "fisher", "bound", "fisher_modes", "bound_modes", "from_noise_density",
           "UNITS"]

#: A design of at most this many samples gets its Fisher information in one piece, exactly as
#: before blocks were introduced (the bound of every recording this size or smaller is
#: unchanged, bit for bit; the longest window of the real recordings has ≈ 1.2e5 samples).
ONE_PIECE = 1 << 17
#: Samples per block of a longer design (:func:`_blocked_fisher`): its memory is a few
#: BLOCK × (4K + d + 1) × 8 bytes (≈ 14 MB each at K = 1, d = 48) whatever its length, where
#: the whole Jacobian and QR of 10 M samples would take several GB.
BLOCK = 1 << 15

#: Unit of every quantity :func:`bound` reports.
UNITS = {name: physics.UNITS[name] for name in ("p", "omega_d", "zeta", "f_n", "u0", "c", "k")}


def from_noise_density(density: float, fs: float) -> float:
    """Per-sample noise sd σ [m/s²] of white noise of one-sided density ``density``
    [m/s²/√Hz] sampled at ``fs`` [Hz]: σ = density·√(fs/2) (the noise fills 0…fs/2)."""
    density, fs = float(density), float(fs)
    if not (math.isfinite(density) and density >= 0):
        raise InputError(f"noise density must be a non-negative number, got {density!r}")
    if not (math.isfinite(fs) and fs > 0):
        raise InputError(f"sample rate must be positive, got {fs!r} Hz")
    return density * math.sqrt(fs / 2.0)


def yao_pandit_var_p(A: float, sigma: float, dt: float, N: int, p: float) -> float:
    r"""CRLB of the decay rate, var p̂ [1/s²], of a real damped sinusoid (Yao & Pandit 1995).

    For ``N`` uniform samples τ_n = n·Δ (n = 0…N−1, Δ = ``dt`` [s]) of
    A·e^{−pτ}·cos(ω_dτ + φ) (``A`` [m/s²] amplitude at n = 0) in white noise of sd ``sigma``
    [m/s²], with q = e^{−2pΔ},

        var p̂ ≥ (2σ²/(A²Δ²))·(1−q)³(1−q^N) / {q·[(1−q^N)² − N²q^{N−1}(1−q)²]}.

    This equals (2σ²/(A²Δ²))·S₀/(S₀S₂ − S₁²) with S_k = Σ n^k q^n: the (p, amplitude) block
    of the Fisher matrix with cos² replaced by its mean ½. That is *exact* for the Fisher
    information in amplitude–phase coordinates (p, ω_d, A, φ) averaged over a uniformly
    random initial phase φ (the double-frequency terms cos(2ω_dτ + 2φ) average to zero and
    the (p, A) block decouples from (ω_d, φ)), and approximate for one given phase: the
    error is of the order of the double-frequency sums, ≈ 1 % with tens of cycles per decay
    time 1/p, several per cent with a few, and large when ω_d nears 0 or the Nyquist
    frequency (see the tests). No offset or drift is estimated. ``p`` [1/s] ≥ 0 (p → 0 gives the
    undamped limit 24σ²/(A²Δ²N(N²−1))).
    """
    A, sigma, dt, p = float(A), float(sigma), float(dt), float(p)
    if isinstance(N, bool) or int(N) != N or N < 3:
        raise InputError(f"N must be an integer ≥ 3, got {N!r}")
    N = int(N)
    for name, v in (("A", A), ("sigma", sigma), ("dt", dt)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} must be a positive number, got {v!r}")
    if not (math.isfinite(p) and p >= 0):
        raise InputError(f"p must be a non-negative decay rate [1/s], got {p!r}")
    x = 2.0 * p * dt
    if N * x > 1e-2:  # closed form; expm1 keeps 1 − q accurate for small pΔ
        one_q, one_qn = -math.expm1(-x), -math.expm1(-N * x)
        q = 1.0 - one_q
        den = q * (one_qn**2 - N**2 * math.exp(-(N - 1) * x) * one_q**2)
        ratio = one_q**3 * one_qn / den
    else:  # N(1 − q) ≪ 1: the closed form cancels catastrophically; sum directly
        n = np.arange(N, dtype=float)
        w = np.exp(-x * n)
        s0, s1, s2 = w.sum(), (n * w).sum(), (n * n * w).sum()
        ratio = s0 / (s0 * s2 - s1 * s1)
    return 2.0 * sigma**2 / (A**2 * dt**2) * ratio


def _check_design(times, sigma, p, omega_d, a_cos, a_sin, drift_degree):
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or t.size < 3:
        raise InputError("times must be a 1-D array of at least 3 sample times [s]")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError("times must be finite and strictly increasing")
    s = np.broadcast_to(np.asarray(sigma, dtype=float), t.shape) if np.ndim(sigma) == 0 else \
        np.asarray(sigma, dtype=float)
    if s.shape != t.shape:
        raise InputError(f"sigma must be a scalar or one value per sample ({t.size}), got shape {s.shape}")
    if not (np.all(np.isfinite(s)) and np.all(s > 0)):
        raise InputError("sigma must be positive and finite [m/s²]")
    vals = [float(v) for v in (p, omega_d, a_cos, a_sin)]
    if not all(math.isfinite(v) for v in vals):
        raise InputError("p, omega_d, a_cos and a_sin must be finite numbers")
    if vals[0] < 0 or vals[1] <= 0:
        raise InputError(f"need p ≥ 0 [1/s] and omega_d > 0 [rad/s], got p={vals[0]:g}, omega_d={vals[1]:g}")
    if vals[2] == 0 and vals[3] == 0:
        raise InputError("the amplitude is zero (a_cos = a_sin = 0): nothing to estimate")
    if drift_degree is not None:
        if isinstance(drift_degree, bool) or int(drift_degree) != drift_degree or drift_degree < 0:
            raise InputError(f"drift_degree must be None or an integer ≥ 0, got {drift_degree!r}")
        drift_degree = int(drift_degree)
    n_par = 4 + (0 if drift_degree is None else drift_degree + 1)
    if t.size <= n_par:
        raise InputError(f"{t.size} samples cannot identify {n_par} parameters; give more samples")
    return t, s, vals, drift_degree


def fisher(times, sigma, p, omega_d, a_cos, a_sin, drift_degree: int | None = 0) -> np.ndarray:
    """Fisher information matrix of φ = (p, ω_d, A, B[, drift coefficients]).

    ``times`` [s] sample times τ (any spacing: jitter and gaps are fine), counted from the
    instant where the quadratures are defined; ``sigma`` [m/s²] white-noise sd, scalar or one
    per sample; ``p`` [1/s], ``omega_d`` [rad/s], ``a_cos``, ``a_sin`` [m/s²] as in (M1).
    ``drift_degree`` d adds the d + 1 orthonormal Legendre drift columns of
    :func:`dampfit.model.viscous.drift_basis` (0 = a constant offset, which every analysis removes;
    ``None`` = no nuisance terms, the pure model of Yao & Pandit). Units of F are those of
    1/(φ_i·φ_j); shape (4 + d + 1,)*2.
    """
    from dampfit.model import viscous

    t, s, (p, wd, a, b), degree = _check_design(times, sigma, p, omega_d, a_cos, a_sin, drift_degree)
    # ∂y/∂φ of (M1) y = e^{−pτ}(A cos ω_dτ + B sin ω_dτ), in closed form:
    # ∂y/∂p = −τ·y, ∂y/∂ω_d = τ·e^{−pτ}(B cos ω_dτ − A sin ω_dτ), ∂y/∂A = e^{−pτ}cos ω_dτ,
    # ∂y/∂B = e^{−pτ}sin ω_dτ
    if t.size > ONE_PIECE:
        return _blocked_fisher(t, s, [(p, wd, a, b)], degree)
    jac = _mode_columns(t, p, wd, a, b)
    if degree is not None:
        jac = np.concatenate([jac, viscous.drift_basis(t, degree)], axis=1)
    jw = jac / s[:, None]
    return jw.T @ jw


def _mode_columns(t: np.ndarray, p: float, wd: float, a: float, b: float) -> np.ndarray:
    """∂y/∂(p, ω_d, A, B) of (M1) at times ``t`` [s], shape (n, 4)."""
    e = np.exp(-p * t)
    cos, sin = e * np.cos(wd * t), e * np.sin(wd * t)
    y = a * cos + b * sin
    return np.stack([-t * y, t * (b * cos - a * sin), cos, sin], axis=1)


def _blocked_fisher(t: np.ndarray, s: np.ndarray, modes: list[tuple[float, ...]],
                    degree: int | None) -> np.ndarray:
    r"""The Fisher information of :func:`fisher` / :func:`fisher_modes` accumulated over
    blocks of :data:`BLOCK` samples, in memory linear in n with a small constant (never the
    n × (4K + d + 1) Jacobian at once).

    With V the Legendre Vandermonde matrix of :func:`dampfit.model.viscous.drift_basis` and
    its QR factor V = QR, the drift basis is Q = V·R⁻¹, and RᵀR = VᵀV (R is the Cholesky
    factor of the Gram matrix, up to the signs of its rows, which flip the signs of drift
    coefficients only). So with G = Σ_blocks [J_osc, V]ᵀ·diag(1/σ²)·[J_osc, V] and
    T = blockdiag(I, R⁻¹), F = Tᵀ·G·T: the same matrix as from the whole Q, to rounding.
    """
    from scipy.linalg import cholesky, solve_triangular

    n_osc = 4 * len(modes)
    n_drift = 0 if degree is None else degree + 1
    gram = np.zeros((n_osc + n_drift, n_osc + n_drift))
    vtv = np.zeros((n_drift, n_drift))  # VᵀV, unweighted: Q is orthonormal in 1, not 1/σ²
    span = max(float(t[-1] - t[0]), 1e-12)
    for i in range(0, t.size, BLOCK):
        tb = t[i:i + BLOCK]
        cols = [_mode_columns(tb, *m) for m in modes]
        if degree is not None:
            v = np.polynomial.legendre.legvander(2.0 * (tb - t[0]) / span - 1.0, degree)
            vtv += v.T @ v
            cols.append(v)
        jw = np.concatenate(cols, axis=1) / s[i:i + BLOCK, None]
        gram += jw.T @ jw
    if degree is None:
        return gram
    transform = np.eye(n_osc + n_drift)
    transform[n_osc:, n_osc:] = solve_triangular(cholesky(vtv, lower=False), np.eye(n_drift),
                                                 lower=False)
    return transform.T @ gram @ transform


def _inverse(f: np.ndarray) -> np.ndarray:
    """F⁻¹ via the correlation form (columns scaled to unit diagonal) for conditioning."""
    d = np.sqrt(np.diag(f))
    if not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise InputError("the design carries no information on some parameter (zero Fisher diagonal)")
    r = f / np.outer(d, d)
    try:
        inv = np.linalg.inv(r)
    except np.linalg.LinAlgError:
        raise InputError("the Fisher matrix is singular: this design does not identify p and ω_d") from None
    if np.linalg.cond(r) > 1e14 or np.any(np.diag(inv) <= 0):
        raise InputError("the Fisher matrix is numerically singular: this design does not identify p and ω_d")
    return inv / np.outer(d, d)


#: Quantities with a CRLB; c and k only with a mass.
_DERIVED = ("p", "omega_d", "zeta", "f_n", "u0", "c", "k")


def _derived(x, m):
    """(g, ∂g/∂x, ∂g/∂m) at x = (p, ω_d, A, B), mass m for every quantity g of :data:`_DERIVED`,
    from :func:`dampfit.physics.quantities` (which takes JAX arrays)."""
    import jax
    import jax.numpy as jnp

    def g(x, m):
        q = physics.quantities(x[0], x[1], m, accel_amplitude=jnp.sqrt(x[2] ** 2 + x[3] ** 2))
        return jnp.stack([q[name] for name in _DERIVED])

    return (g(x, m), *jax.jacfwd(g, argnums=(0, 1))(x, m))


@functools.lru_cache(maxsize=1)
def _derived_jacobian():
    """:func:`_derived` as one compiled kernel: traced and compiled once per process, or loaded
    compiled from disk under the CLI (:mod:`dampfit.inference.executables`)."""
    from dampfit.inference.executables import Kernel

    return Kernel(_derived)


def bound(
    times,
    sigma,
    *,
    p: float,
    omega_d: float,
    a_cos: float,
    a_sin: float,
    mass: float | None = None,
    mass_sd: float = 0.0,
    drift_degree: int | None = 0,
) -> dict:
    """CRLB standard deviations of p, ω_d, ζ, f_n, u₀ and, with ``mass`` [kg], c and k.

    Arguments as for :func:`fisher`; ``mass_sd`` [kg] ≥ 0 the standard uncertainty of the
    mass (both checked by :func:`dampfit.physics.check_mass`: at most half the mass; or
    ``mass`` a :class:`dampfit.physics.Mass`, checked when it was made, with its sd). Values
    and gradients come from :func:`dampfit.physics.quantities`. Returns a plain dict: for each quantity ``{"value": g(φ), "sd": √(∇gᵀF⁻¹∇g)}``;
    ``c`` and ``k`` (only with mass) also carry ``"sd_with_mass"`` =
    √(sd² + (∂g/∂m)²·mass_sd²) (equal to ``sd`` when mass_sd = 0). ``"units"`` maps each
    quantity to its unit; ``"n_samples"``, ``"drift_degree"``, ``"mass"`` and ``"mass_sd"``
    record the design.
    """
    import jax

    checked = physics.as_mass(mass, mass_sd)  # a Mass was checked when it was made
    mass, mass_sd = checked.value, checked.sd
    f = fisher(times, sigma, p, omega_d, a_cos, a_sin, drift_degree)
    cov = _inverse(f)[:4, :4]
    out: dict = {}
    with jax.enable_x64(True):
        x = np.array([p, omega_d, a_cos, a_sin], dtype=np.float64)
        m = np.float64(mass if mass is not None else 1.0)
        values, grad_x, grad_m = (np.asarray(v) for v in _derived_jacobian()(x, m))
    for i, name in enumerate(_DERIVED):
        if name in ("c", "k") and mass is None:
            continue
        gx, gm = grad_x[i], float(grad_m[i])
        var = float(gx @ cov @ gx)
        entry = {"value": float(values[i]), "sd": math.sqrt(max(var, 0.0))}
        if name in ("c", "k"):
            entry["sd_with_mass"] = math.sqrt(max(var, 0.0) + (gm * mass_sd) ** 2)
        out[name] = entry
    out["units"] = {k: v for k, v in UNITS.items() if k in out}
    out["n_samples"] = int(np.size(times))
    out["drift_degree"] = drift_degree
    out["mass"] = mass
    out["mass_sd"] = mass_sd if mass is not None else None
    return out


# ----------------------------------------------------------------------------- several modes
def fisher_modes(times, sigma, modes, drift_degree: int | None = 0) -> np.ndarray:
    r"""Fisher information of K modes, φ = (p_1, ω_1, A_1, B_1, …, p_K, ω_K, A_K, B_K[, drift]).

    The data model is (MK1) of :mod:`dampfit.model.modes` — the sum of K (M1) decays — in
    white noise: J is the side-by-side stack of each mode's closed-form columns of
    :func:`fisher` (the modes share no parameter), so F = Jᵀ·diag(1/σ²)·J couples them only
    through the overlap of their columns, which is what makes close modes hard. ``modes`` is
    a sequence of (p [1/s], ω_d [rad/s], A, B [m/s²]); the other arguments as for
    :func:`fisher`. Shape (4K + d + 1,)*2.
    """
    from dampfit.model import viscous

    modes = [tuple(float(v) for v in m) for m in modes]
    if not modes or any(len(m) != 4 for m in modes):
        raise InputError("modes must be a non-empty list of (p, omega_d, a_cos, a_sin)")
    for m in modes:
        t, s, _, degree = _check_design(times, sigma, *m, drift_degree)
    n_par = 4 * len(modes) + (0 if degree is None else degree + 1)
    if t.size <= n_par:
        raise InputError(f"{t.size} samples cannot identify {n_par} parameters; give more samples")
    if t.size > ONE_PIECE:
        return _blocked_fisher(t, s, modes, degree)
    jac = np.concatenate([_mode_columns(t, *m) for m in modes], axis=1)
    if degree is not None:
        jac = np.concatenate([jac, viscous.drift_basis(t, degree)], axis=1)
    jw = jac / s[:, None]
    return jw.T @ jw


def bound_modes(times, sigma, modes, *, drift_degree: int | None = 0,
                mass: float | physics.Mass | None = None,
                mode_of_mass: int | None = None) -> list[dict]:
    """CRLB standard deviations of every mode's p, ω_d, ζ, f_n and u₀ (and, for the mode
    ``mode_of_mass`` (0-based) with ``mass`` [kg], c and k), from :func:`fisher_modes`.

    Returns one plain dict per mode, in the order given: ``{quantity: {"value", "sd"}}`` as
    :func:`bound` (without the mass uncertainty), plus ``"units"``.
    """
    import jax

    mass = physics.as_mass(mass).value  # a Mass was checked when it was made
    f = fisher_modes(times, sigma, modes, drift_degree)
    cov = _inverse(f)
    out = []
    with jax.enable_x64(True):
        for i, mode in enumerate(modes):
            x = np.asarray(mode, dtype=np.float64)
            m = np.float64(mass if mass is not None else 1.0)
            values, grad_x, _ = (np.asarray(v) for v in _derived_jacobian()(x, m))
            block = cov[4 * i:4 * i + 4, 4 * i:4 * i + 4]
            entry: dict = {}
            for j, name in enumerate(_DERIVED):
                if name in ("c", "k") and (mass is None or i != mode_of_mass):
                    continue
                var = float(grad_x[j] @ block @ grad_x[j])
                entry[name] = {"value": float(values[j]), "sd": math.sqrt(max(var, 0.0))}
            entry["units"] = {k: v for k, v in UNITS.items() if k in entry}
            out.append(entry)
    return out
