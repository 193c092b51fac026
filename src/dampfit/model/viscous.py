r"""Forward model of the viscous free decay, as pure ``jax.numpy`` functions.

Physics
-------
For ``m·ü + c·u̇ + k·u = 0`` (seed paper eq. 22 with F = 0) and ζ < 1 the displacement is
``u(τ) = Re[U·e^{sτ}]`` with the complex pole ``s = −p + iω_d`` (p = c/2m, ω_d = √(k/m − p²)),
τ = t − t₀ measured from the start of the analysed window. Differentiating twice,

    a(τ) = ü(τ) = Re[s²·U·e^{sτ}] = e^{−pτ}·(A·cos ω_dτ + B·sin ω_dτ),      (M1)

with acceleration quadratures ``A − iB = s²·U``. Because ``|s|² = p² + ω_d² = ω_n²``, the
displacement envelope amplitude at τ = 0 is

    u₀ = |U| = √(A² + B²) / ω_n²   [m].                                     (M2)

The quadratures enter (M1) linearly, so they are solved for (or marginalised) exactly given
the two nonlinear parameters θ = (ln p, ln ω_d); the solver and the sampler only see θ.

Nuisance
--------
Phone and MEMS accelerometers add a constant bias (or gravity) and a slow bias drift. They
enter as a Legendre polynomial basis ``P_0..P_d(2τ/T − 1)`` (orthonormalised on the sample
times) whose coefficients are also linear. With ``d ≪ f·T`` the basis is nearly orthogonal
to the oscillation.

The profile and marginal likelihood are those of :mod:`dampfit.model.profile` (one algebra
for every law) with the (M1) columns, :data:`M1` = :class:`dampfit.model.laws.ViscousM1`; the
functions here keep the viscous call signatures.

Every function here is pure and shape-static, so callers jit/vmap them once; nothing here
touches global JAX configuration (callers enable float64 where they enter, see
:func:`dampfit.inference.least_squares.least_squares`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from dampfit.model import profile as _profile
from dampfit.model.laws import ViscousM1


def acceleration(tau, p, omega_d, a_cos, a_sin, xp=jnp):
    """Acceleration (M1) [m/s²] at times ``tau`` [s] after the window start.

    ``p`` decay rate [1/s], ``omega_d`` damped angular frequency [rad/s],
    ``a_cos``, ``a_sin`` acceleration quadratures at τ = 0 [m/s²]; ``xp`` jax.numpy (traceable)
    or numpy (plain evaluation, no JAX dispatch).
    """
    ph = omega_d * tau
    return xp.exp(-p * tau) * (a_cos * xp.cos(ph) + a_sin * xp.sin(ph))


def _complex_amplitude(p, omega_d, a_cos, a_sin, power):
    # a = Re[C e^{sτ}] with C = A − iB; the n-th antiderivative is Re[C s^{-n} e^{sτ}].
    s = -p + 1j * omega_d
    return (a_cos - 1j * a_sin) / s**power, s


def velocity(tau, p, omega_d, a_cos, a_sin, xp=jnp):
    """Velocity [m/s] of the free decay whose acceleration is (M1) (``xp`` as above)."""
    cc, s = _complex_amplitude(p, omega_d, a_cos, a_sin, 1)
    return xp.real(cc * xp.exp(s * tau))


def displacement(tau, p, omega_d, a_cos, a_sin, xp=jnp):
    """Displacement [m] of the free decay whose acceleration is (M1) (``xp`` as above)."""
    cc, s = _complex_amplitude(p, omega_d, a_cos, a_sin, 2)
    return xp.real(cc * xp.exp(s * tau))


def drift_basis(tau: np.ndarray, degree: int, at: np.ndarray | None = None) -> np.ndarray:
    """Orthonormal drift basis on the window, shape (n, degree + 1) [1].

    The Legendre polynomials ``P_0..P_degree`` of x = 2τ/T − 1 ∈ [−1, 1] (``tau`` [s] from the
    window start), orthonormalised on the actual sample times by a QR decomposition V = QR, so
    that ``QᵀQ = I`` exactly even for irregular times. With ``at`` [s], the *same* basis
    functions V(at)·R⁻¹ are evaluated at other times (e.g. a dense grid for plotting), so
    coefficients fitted on ``tau`` apply there unchanged.
    """
    tau = np.asarray(tau, dtype=float)
    span = max(float(tau[-1] - tau[0]), 1e-12)

    def vander(t):
        return np.polynomial.legendre.legvander(2.0 * (t - tau[0]) / span - 1.0, degree)

    q, r = np.linalg.qr(vander(tau))
    if at is None:
        return q
    return np.linalg.solve(r.T, vander(np.asarray(at, dtype=float)).T).T


#: The viscous law with the (M1) columns; the pipeline's least squares and posterior use it.
M1 = ViscousM1()


def oscillation_columns(theta, tau):
    """``[e^{−pτ}cos ω_dτ, e^{−pτ}sin ω_dτ]`` for θ = (ln p, ln ω_d), shape (n, 2)."""
    return M1.columns(theta, tau)


def design_matrix(theta, tau, drift):
    """Full design matrix ``[oscillation columns, drift…]`` for θ = (ln p, ln ω_d)."""
    return jnp.concatenate([oscillation_columns(theta, tau), drift], axis=1)


def profile(theta, tau, y, drift, mask=None):
    r"""Linear least squares of ``y`` [m/s²] on the design matrix at fixed θ = (ln p, ln ω_d).

    :func:`dampfit.model.profile.profile` with the (M1) columns: the drift is projected out
    (Schur complement, det QᵀQ = 1) and the 2×2 system solved from Gram products. Returns
    ``(beta, rss, logdet, (chol, scale))``: all coefficients (A, B, drift in Q coordinates),
    the RSS [(m/s²)²], ``log det XᵀX``, and the Cholesky factor of the column-scaled 2×2
    ``X⊥ᵀX⊥`` with its column scales (the conditional covariance of (A, B) is
    ``s²·diag(1/scale)·(LLᵀ)⁻¹·diag(1/scale)``). ``mask`` [1] switches padded rows off
    (:class:`dampfit.signal.prepare.Padded`).
    """
    pr = _profile.profile(M1, theta, tau, y, drift, mask)
    return pr.beta, pr.rss, pr.logdet, (pr.chol, pr.scale)


def log_marginal_likelihood(theta, tau, y, drift, temper, mask=None, n=None, q=None):
    r"""Log likelihood of θ with the linear coefficients and the noise level marginalised.

    With Gaussian noise of unknown σ, flat priors on the q linear coefficients and a
    Jeffreys prior 1/σ, integrating them out gives (up to a constant; eq. P3 of
    :mod:`dampfit.model.profile`)

        ln L(θ) = −½·ln det(XᵀX) − ½·(n − q)·ln RSS(θ).

    ``temper`` = 1/r divides the information by the ratio r of the noise power spectral
    density at the oscillation frequency to its mean (r = 1 for white noise; see
    :mod:`dampfit.inference.noise`), which keeps the posterior calibrated for coloured noise and for
    filtered, decimated samples. With padded inputs give ``mask`` and the real sample count
    ``n`` and coefficient count ``q``.
    """
    return marginal_and_amplitudes(theta, tau, y, drift, temper, mask, n, q)[0]


def marginal_and_amplitudes(theta, tau, y, drift, temper, mask=None, n=None, q=None):
    r""":func:`log_marginal_likelihood` and, from the same profile, the conditional posterior
    of the acceleration quadratures (A, B) [m/s²] given θ (drift marginalised):

        (A, B) | θ, y ~ N(β̂_osc, s²/temper · (X⊥ᵀX⊥)⁻¹),   s² = RSS/(n − q)

    (the σ-marginal is a Student-t with n − q degrees of freedom and this scale; with
    n − q ≫ 1 — hundreds of samples — the Gaussian is indistinguishable from it).
    Returns ``(ln L, moments)`` with moments = [Â, B̂, Σ_AA, Σ_AB, Σ_BB] — what the sampler
    stores per draw, so that the amplitudes need no second pass over the data.
    """
    n = y.shape[0] if n is None else n
    q = drift.shape[1] + 2 if q is None else q
    mask = jnp.ones_like(y) if mask is None else mask
    samples = _profile.Samples(tau, y, drift, mask, n, q - 2)
    ll, beta, cov = _profile.marginal_and_amplitudes(M1, theta, samples, temper)
    return ll, jnp.stack([beta[0], beta[1], cov[0, 0], cov[0, 1], cov[1, 1]])
