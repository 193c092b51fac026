r"""The K-mode free-decay model: several viscous modes in one recording (JAX).

Model
-----
A structure released from rest rings in K modes; each is a viscous free decay (eq. M1 of
:mod:`dampfit.model.viscous`) with its own decay rate p_i [1/s] and damped angular frequency
ω_i [rad/s], so the acceleration samples y [m/s²] at times τ [s] from the window start are

    y(τ) = Σ_{i=1}^{K} e^{−p_iτ}·(A_i·cos ω_iτ + B_i·sin ω_iτ) + Σ_j d_j·Q_j(τ) + ε,        (MK1)

with the acceleration quadratures (A_i, B_i) [m/s²] linear, Q the orthonormal drift basis
(:func:`dampfit.model.viscous.drift_basis`) and ε the noise. It is
``Sum(ViscousM1(), …, ViscousM1())`` of :mod:`dampfit.model.profile` (K components): the 2K
nonlinear parameters

    θ = (ln p_1, ln ω_1, ln p_2, ln ω_2, …, ln p_K, ln ω_K)                                  (MK2)

are concatenated in mode order, the 2K columns side by side, and (A_i, B_i, d) are projected
out exactly (P2 of :mod:`dampfit.model.profile`) — one profile and one σ-marginal likelihood
(P3) for every K; K = 1 *is* the one-mode viscous model (M1). Each mode's natural frequency is
ω_n,i = √(p_i² + ω_i²), ζ_i = p_i/ω_n,i and its displacement amplitude √(A_i² + B_i²)/ω_n,i²
(eq. M2 per mode).

Ordering and prior
------------------
The likelihood is symmetric under relabelling the modes, so the K! copies of every optimum
would make a sampler switch labels. The prior is put on the *ordered* region

    ω_lo < ω_1 < ω_2 < … < ω_K < ω_hi,   ln p_i ∈ (ln(10⁻⁶·ω_i), ln(0.2·ω_i)),               (MK3)

each ln ω_i uniform over the pass band [ω_lo, ω_hi] and each ln p_i uniform over its range,
so its density there is

    π_K(θ) = K! / (Δ_ω·Δ_p)^K,   Δ_ω = ln(ω_hi/ω_lo),   Δ_p = ln(0.2/10⁻⁶),                    (MK4)

and zero outside: modes are numbered by frequency everywhere (least squares, posterior,
output). The rate range is the one-mode prior's (:meth:`dampfit.model.laws.Law.log_prior`)
cut at p = 0.2·ω (ζ ≈ 0.2, :data:`P_MAX`): a component that loses 70 % of its amplitude per
cycle is a transient (a pluck, a sensor settling), not a mode that rings — without the cut
such transients right after a release were fitted as "modes" with ζ ≈ 0.7. The K! is the ordered region's share of the unordered cube; the prior volume
(Δ_ω·Δ_p)^K/K! is what a K-mode model pays in its evidence for every mode
(:mod:`dampfit.inference.modes`).

Functions are pure; :func:`model` returns the hashable model object (a static argument of
jitted kernels), :func:`log_prior` works on NumPy or ``jax.numpy`` (``xp``) and broadcasts
over leading axes of θ.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from dampfit.model.laws import P_RANGE, ViscousM1
from dampfit.model.profile import Sum

#: Nonlinear parameters per mode: (ln p, ln ω_d).
PARAMS_PER_MODE = 2
#: Largest decay rate of a mode relative to its frequency, p/ω_d (ζ ≈ 0.2; MK3).
P_MAX = 0.2


#: Width Δ_p of the ln p prior [1] (MK4).
_D_P = math.log(P_MAX / P_RANGE)


@functools.lru_cache(maxsize=None)
def model(n: int) -> Sum:
    """The K = ``n`` mode model (MK1): ``Sum`` of ``n`` viscous (M1) components."""
    n = int(n)
    if n < 1:
        raise ValueError(f"a modal model needs at least one mode, got {n}")
    return Sum(*([ViscousM1()] * n))


def n_modes(theta) -> int:
    """K from the length 2K of θ (MK2)."""
    return int(np.shape(theta)[-1]) // PARAMS_PER_MODE


def rates(theta) -> tuple[np.ndarray, np.ndarray]:
    """(p [1/s], ω_d [rad/s]) of every mode, each of shape (..., K) (NumPy)."""
    th = np.asarray(theta, dtype=float)
    return np.exp(th[..., 0::2]), np.exp(th[..., 1::2])


def to_theta(p, omega_d) -> np.ndarray:
    """θ (MK2) from per-mode decay rates ``p`` [1/s] and damped frequencies ``omega_d``
    [rad/s] (sequences of length K, or arrays (..., K))."""
    p, w = np.asarray(p, dtype=float), np.asarray(omega_d, dtype=float)
    out = np.empty(p.shape[:-1] + (2 * p.shape[-1],))
    out[..., 0::2], out[..., 1::2] = np.log(p), np.log(w)
    return out


def order(theta) -> np.ndarray:
    """θ with its modes sorted by frequency (the labelling of MK3); also the permutation:
    returns ``(theta_sorted, perm)`` with mode i of the result = mode ``perm[i]`` of θ."""
    th = np.asarray(theta, dtype=float)
    perm = np.argsort(th[..., 1::2], axis=-1, kind="stable")
    idx = np.stack([2 * perm, 2 * perm + 1], axis=-1).reshape(perm.shape[:-1] + (-1,))
    return np.take_along_axis(th, idx, axis=-1), perm


def log_prior_volume(n: int, band: tuple[float, float]) -> float:
    """ln of the ordered prior volume (Δ_ω·Δ_p)^K/K! of (MK4) [1]; ``band`` [Hz]."""
    d_w = math.log(band[1] / band[0])
    return n * (math.log(d_w) + math.log(_D_P)) - math.lgamma(n + 1)


def log_prior(theta, lw_lo, lw_hi, xp=np):
    """ln π_K(θ) of (MK4) for θ (..., 2K); −inf outside the ordered support (MK3).

    ``lw_lo``, ``lw_hi`` are the band edges as ln ω [ln(rad/s)] (they may be JAX values), or
    one pair per mode (K,): each mode's own interval of ln ω (the posterior's basins,
    :func:`dampfit.inference.modes_posterior.basins`), uniform over each.
    """
    th = theta if xp is not np else np.asarray(theta, dtype=float)
    k = th.shape[-1] // PARAMS_PER_MODE
    lnp, lnw = th[..., 0::2], th[..., 1::2]
    inside = xp.all((lnw > lw_lo) & (lnw < lw_hi) & (lnp < lnw + math.log(P_MAX))
                    & (lnp > lnw + math.log(P_RANGE)), axis=-1)
    if k > 1:
        inside = inside & xp.all(lnw[..., 1:] > lnw[..., :-1], axis=-1)
    width = xp.sum(xp.log(xp.broadcast_to(xp.asarray(lw_hi) - xp.asarray(lw_lo), (k,))))
    dens = math.lgamma(k + 1) - k * math.log(_D_P) - width + xp.zeros_like(lnw[..., 0])
    return xp.where(inside, dens, -xp.inf)
