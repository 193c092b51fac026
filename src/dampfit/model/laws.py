r"""Damping laws beyond one viscous c: averaged free-decay envelopes and equivalent viscous c.

Equation of motion (single degree of freedom, k = m·ω²)

    m·ü + f_d(u̇) + k·u = 0,

with the damping force f_d [N] of one of four laws (the names used everywhere in dampfit):

==========  ==================================  =========================================
name        f_d(u̇)                              FEM element
==========  ==================================  =========================================
viscous     c·u̇                                 LS-DYNA *MAT_DAMPER_VISCOUS (DC = c)
coulomb     c·u̇ + F_c·sgn(u̇)                    viscous damper + friction element
quadratic   c·u̇ + c₂·u̇·|u̇|                      *MAT_DAMPER_NONLINEAR_VISCOUS (F–v curve)
power       c_α·|u̇|^α·sgn(u̇)                    OpenSees ``uniaxialMaterial Viscous C α``
==========  ==================================  =========================================

**Averaged envelope** (first-order Krylov–Bogoliubov averaging; Nayfeh & Mook, *Nonlinear
Oscillations*, 1979, §4.1). With u = a·cos ψ, u̇ = −a·ω·sin ψ, ψ = ω·t + φ and light damping,

    da/dt = −(1/(2π·m·ω))·∮ f_d(a·ω·sin ψ)·sin ψ dψ ≡ −ρ(a)·a,      dψ/dt = ω,         (K1)

where ρ(a) [1/s] is the local decay rate. The integrals ∮|sin ψ| = 4, ∮|sin ψ|³ = 8/3 and
∮|sin ψ|^{α+1} = 2√π·Γ(α/2 + 1)/Γ(α/2 + 3/2) give

    viscous    ρ = c/(2m)
    coulomb    ρ = c/(2m) + 2·F_c/(π·m·ω·a)
    quadratic  ρ = c/(2m) + 4·c₂·ω·a/(3π·m)
    power      ρ = c_α·(ω·a)^{α−1}·λ(α)/(2π·m),   λ(α) = 2^{2+α}·Γ²(1 + α/2)/Γ(2 + α).   (K2)

The energy-equivalent viscous coefficient (Jacobsen 1930: the c that dissipates the same
energy per cycle, W_d = π·c_eq·ω·a²) is c_eq(a) = 2·m·ρ(a); for the power law this is the
λ of FEMA 274 (1997) §9 / Symans & Constantinou (1998): c_eq = λ·c_α·(ω·a)^{α−1}/π. λ(1) = π,
λ(0) = 4, λ(2) = 8/3 recover the three other laws.

**Shape parameters.** The envelope *shape* e(τ) = a(τ)/a₀ depends on the law's coefficients
only through rates at the window start (amplitude a₀), so the amplitude itself stays a linear
parameter (the acceleration quadratures of :mod:`dampfit.model.viscous`):

    viscous    θ = (ln p, ln ω)              e = exp(−pτ)
    coulomb    θ = (ln p₀, f, ln ω)          p_v = (1−f)·p₀, p_c = f·p₀ = 2F_c/(π·m·ω·a₀)
               e = exp(−p_vτ) − p_c·τ·E(p_vτ),  E(x) = (1 − e^{−x})/x;  e = 0 after it stops
    quadratic  θ = (ln p₀, f, ln ω)          p_v = (1−f)·p₀, p_q = f·p₀ = 4c₂·ω·a₀/(3π·m)
               1/e = exp(p_vτ) + p_q·τ·F(p_vτ),  F(x) = (e^{x} − 1)/x
    power      θ = (ln p₀, α, ln ω)          p₀ = ρ(a₀);  e^{1−α} = 1 − (1−α)·p₀·τ   (K3)

p₀ [1/s] is the total decay rate at the window start and f [1] the fraction of it due to the
nonlinear term (f = 0 or α = 1 is the viscous model). These are the closed-form solutions of
(K1) with (K2), so no ODE solver is needed.

**Acceleration.** The averaged displacement u = Re[Z·e(τ)·e^{iωτ}] is differentiated exactly:
ü = Re[−ω²·Z·h(τ)·e^{iωτ}] with h = e·(1 + 2iρ/ω − R'ρ/ω²), R(e) = ρ·e the envelope's rate
function and R' = dR/de. The two columns Re, Im of h·e^{iωτ} span the acceleration with the
linear quadratures (A, B); |(A, B)| = ω²·a₀. For viscous damping this is *exactly* the model
(M1) of :mod:`dampfit.model.viscous` with ω = ω_d (h = s²/(−ω_d²), s = −p + iω_d), so the models nest.
Accuracy against a DOP853 solution of the equation of motion (``tests/test_damping_models.py``),
ζ_eq from 10⁻³ to 0.1, decay to 30 % of the initial amplitude, quadratures and ω fitted: the
in-band (0.5–1.5 f) acceleration error is ≈ 0.05–0.08·ζ_eq of the amplitude for coulomb,
0.003–0.013·ζ_eq for quadratic and 0.02–0.035·ζ_eq for power (α = 0.5); the fitted ω is
ω_n·(1 − O(ζ²)). The friction and drag forces also put odd harmonics (3ω, 5ω, …) into the
acceleration (rms ≈ 0.37·ζ_eq, 0.07·ζ_eq and 0.2·ζ_eq of the amplitude for those cases);
they are out of band and not modelled.

**Frequency drift** (a nuisance shared by all laws). Real oscillators also change frequency
along a decay (amplitude-dependent stiffness, temperature): 0.4 % over 200 cycles is 2.5 rad
of phase, far more misfit than the damping law leaves. θ may therefore carry
J ≤ :data:`MAX_PHASE` extra phase coefficients c_j [rad] after ln ω,

    ψ(τ) = ω·τ + Σ_{j=2}^{J+1} c_j·P_j(x),   x = 2(τ − τ₀)/(τ₁ − τ₀) − 1,                 (K4)

(Legendre P_j; P_0 and P_1 are the phase and ω already), and h uses the instantaneous
frequency Ω = dψ/dτ: ü = Re[−Ω²·Z·e·(1 + 2iρ/Ω − R'ρ/Ω² − iψ''/Ω²)·e^{iψ}].

All functions are pure and shape-static; the law is a static Python string. :func:`envelope`
and :func:`columns` run on ``jax.numpy`` (jit/vmap/grad) or on NumPy (``xp=numpy``), where
the fits of :mod:`dampfit.inference.law_fit` call them: a handful of nonlinear parameters on a few
thousand samples needs no compiled kernel (and XLA compiles these graphs in seconds, which a
per-recording fit of four laws cannot afford).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
from scipy.special import gammaln

__all__ = [
    "MODELS", "SHAPE", "PRIOR_SHAPE", "MAX_PHASE", "lam", "envelope", "phase", "columns",
    "local_rate", "c_equivalent", "physical", "omega_index", "n_phase",
]

#: Damping laws, viscous first (the null model).
MODELS = ("viscous", "coulomb", "quadratic", "power")
#: Name of the law's shape parameter θ[1] (viscous has none).
SHAPE = {"coulomb": "friction_fraction", "quadratic": "drag_fraction", "power": "alpha"}
#: Uniform prior support of the shape parameter: f ∈ [0, 1]; α ∈ [0, 3] (friction 0 …
#: viscous 1 … drag 2, with room above).
PRIOR_SHAPE = {"coulomb": (0.0, 1.0), "quadratic": (0.0, 1.0), "power": (0.0, 3.0)}
#: Envelope level treated as "stopped" [1]; local decay rates are also capped at ω
#: (ζ_local ≤ 1), beyond which averaging has no meaning.
_SMALL = 1e-9


def lam(alpha):
    """λ(α) = 2^{2+α}·Γ²(1 + α/2)/Γ(2 + α) [1] of (K2) (FEMA 274; NumPy, broadcasts)."""
    alpha = np.asarray(alpha, dtype=float)
    return np.exp((2 + alpha) * np.log(2.0) + 2 * gammaln(1 + alpha / 2) - gammaln(2 + alpha))


def _safe(x, xp, small=1e-8):
    return xp.where(xp.abs(x) < small, small, x)


def omega_index(model: str) -> int:
    """Position of ln ω in θ (the law's own parameters come first, phase terms after)."""
    return 1 if model == "viscous" else 2


def n_phase(model: str, theta) -> int:
    """Number J of frequency-drift phase coefficients carried by θ (K4)."""
    return int(np.shape(theta)[-1]) - omega_index(model) - 1


def _rates(model: str, theta, xp):
    """(p₀ or p [1/s], shape parameter, ω [rad/s]) from θ, each with a trailing axis for τ."""
    iw = omega_index(model)
    p0, w = xp.exp(theta[..., 0])[..., None], xp.exp(theta[..., iw])[..., None]
    return p0, (None if model == "viscous" else theta[..., 1][..., None]), w


# Legendre P_j (j = 2, 3, 4) and their first and second derivatives in x
_LEG = (
    (lambda x: 1.5 * x * x - 0.5, lambda x: 3.0 * x, lambda x: 3.0 + 0.0 * x),
    (lambda x: 2.5 * x**3 - 1.5 * x, lambda x: 7.5 * x * x - 1.5, lambda x: 15.0 * x),
    (lambda x: (35 * x**4 - 30 * x * x + 3) / 8, lambda x: 17.5 * x**3 - 7.5 * x,
     lambda x: 52.5 * x * x - 7.5),
)
#: Most frequency-drift phase coefficients (Legendre degrees 2..4).
MAX_PHASE = len(_LEG)


def phase(model: str, theta, tau, xp=jnp):
    """Phase ψ [rad], instantaneous frequency Ω = ψ' [rad/s] and ψ'' [rad/s²] of (K4)."""
    iw = omega_index(model)
    w = xp.exp(theta[..., iw])[..., None]
    psi, dpsi, ddpsi = w * tau, w + 0.0 * tau, 0.0 * tau
    j_max = n_phase(model, theta)
    if j_max:
        span = tau[-1] - tau[0]
        x, dx = 2.0 * (tau - tau[0]) / span - 1.0, 2.0 / span
        for j in range(j_max):
            c = theta[..., iw + 1 + j][..., None]
            f, d1, d2 = _LEG[j]
            psi = psi + c * f(x)
            dpsi = dpsi + c * d1(x) * dx
            ddpsi = ddpsi + c * d2(x) * dx * dx
    return psi, dpsi, ddpsi


def envelope(model: str, theta, tau, xp=jnp):
    """Envelope shape e = a/a₀ [1], rate R = ρ·e [1/s] and R' = dR/de [1/s] at ``tau`` [s] (K3).

    ``theta`` has shape (..., k); the outputs have shape (..., n) for ``tau`` of shape (n,).
    ``xp`` is the array module: ``jax.numpy`` (default; jit/vmap/grad-safe) or ``numpy``.
    """
    p0, s, w = _rates(model, theta, xp)
    if model == "viscous":
        e = xp.exp(-p0 * tau)
        return e, p0 * e, p0 * xp.ones_like(e)
    if model == "coulomb":
        pv, pc = (1 - s) * p0, s * p0
        x = pv * tau
        xs = _safe(x, xp)
        ex = xp.where(xp.abs(x) < 1e-8, 1 - 0.5 * x, -xp.expm1(-xs) / xs)
        e = xp.maximum(xp.exp(-x) - pc * tau * ex, 0.0)
        moving = e > 0
        return e, xp.where(moving, pv * e + pc, 0.0), xp.where(moving, pv, 0.0)
    if model == "quadratic":
        pv, pq = (1 - s) * p0, s * p0
        x = pv * tau
        xs = _safe(x, xp)
        fx = xp.where(xp.abs(x) < 1e-8, 1 + 0.5 * x, xp.expm1(xs) / xs)
        z = xp.maximum(xp.exp(x) + pq * tau * fx, 1e-6)  # 1/e; > 0 unless p_q < 0
        e = 1.0 / z
        return e, pv * e + pq * e * e, pv + 2 * pq * e
    if model == "power":
        d = 1.0 - s  # 1 − α
        x = p0 * tau
        arg = 1.0 - d * x
        ok = arg > _SMALL
        ds = _safe(d, xp, 1e-6)
        log_e = xp.where(xp.abs(d) < 1e-6, -x - 0.5 * d * x * x,
                         xp.log(xp.where(ok, arg, 1.0)) / ds)
        e = xp.where(ok | (d <= 0), xp.exp(log_e), 0.0)
        rho = p0 * xp.exp(-d * log_e)  # ρ = p₀·e^{α−1}, capped by the caller as e → 0
        moving = e > 0
        return e, xp.where(moving, rho * e, 0.0), xp.where(moving, s * rho, 0.0)
    raise ValueError(f"unknown damping model {model!r}")


def columns(model: str, theta, tau, xp=jnp):
    """Acceleration columns [Re, Im] of (Ω/ω)²·h(τ)·e^{iψ}, shape (..., n, 2) [1] (docstring)."""
    _, _, w = _rates(model, theta, xp)
    e, r, dr = envelope(model, theta, tau, xp)
    psi, big_w, ddpsi = phase(model, theta, tau, xp)
    rho = xp.clip(r / xp.maximum(e, _SMALL), -big_w, big_w)  # local rate, |ζ_local| ≤ 1
    scale = e * (big_w / w) ** 2
    re_h = scale * (1.0 - dr * rho / (big_w * big_w))
    im_h = scale * (2.0 * rho / big_w - ddpsi / (big_w * big_w))
    c, s = xp.cos(psi), xp.sin(psi)
    return xp.stack([re_h * c - im_h * s, re_h * s + im_h * c], axis=-1)


def local_rate(model: str, theta, ratio):
    """Local decay rate ρ [1/s] at the amplitude ``ratio`` = a/a₀ [1] (K2); NumPy, broadcasts.

    ``theta`` may be an array of shape (..., k) of draws.
    """
    th = np.asarray(theta, dtype=float)
    ratio = np.asarray(ratio, dtype=float)
    p0 = np.exp(th[..., 0])
    if model == "viscous":
        return p0 * np.ones_like(ratio)
    s = th[..., 1]
    if model == "coulomb":
        return (1 - s) * p0 + s * p0 / ratio
    if model == "quadratic":
        return (1 - s) * p0 + s * p0 * ratio
    if model == "power":
        return p0 * ratio ** (s - 1.0)
    raise ValueError(f"unknown damping model {model!r}")


def c_equivalent(model: str, theta, a0, amplitude, mass):
    """Energy-equivalent viscous c_eq = 2·m·ρ(a) [N·s/m] at displacement ``amplitude`` [m].

    ``a0`` [m] is the displacement amplitude at the window start, ``mass`` [kg] (Jacobsen 1930).
    """
    return 2.0 * np.asarray(mass) * local_rate(model, theta, np.asarray(amplitude) / np.asarray(a0))


def physical(model: str, theta, a0, mass=None) -> dict[str, np.ndarray]:
    """The law's coefficients from θ and the start amplitude ``a0`` [m]; NumPy, broadcasts.

    Per unit mass (always): ``p_viscous`` = c/(2m) [1/s]; coulomb ``mu_c`` = F_c/m [m/s²];
    quadratic ``beta`` = c₂/m [1/m]; power ``gamma`` = c_α/m [(m/s)^{1−α}/s] and ``alpha`` [1].
    With ``mass`` [kg] also ``c`` [N·s/m], ``F_c`` [N], ``c2`` [N·s²/m²], ``c_alpha``
    [N·(s/m)^α]. ω [rad/s] = exp(θ[ln ω]). Inverts (K2)–(K3).
    """
    th = np.asarray(theta, dtype=float)
    a0 = np.asarray(a0, dtype=float)
    p0, w = np.exp(th[..., 0]), np.exp(th[..., omega_index(model)])
    out: dict[str, np.ndarray] = {}
    if model == "viscous":
        out["p_viscous"] = p0
    elif model in ("coulomb", "quadratic"):
        f = th[..., 1]
        out["p_viscous"] = (1 - f) * p0
        if model == "coulomb":
            out["mu_c"] = 0.5 * math.pi * w * a0 * f * p0
        else:
            out["beta"] = 3.0 * math.pi * f * p0 / (4.0 * w * a0)
    elif model == "power":
        alpha = th[..., 1]
        out["alpha"] = alpha
        out["gamma"] = 2.0 * math.pi * p0 * (w * a0) ** (1.0 - alpha) / lam(alpha)
    else:
        raise ValueError(f"unknown damping model {model!r}")
    if mass is not None:
        m = np.asarray(mass, dtype=float)
        if "p_viscous" in out:
            out["c"] = 2.0 * m * out["p_viscous"]
        for src, dst in (("mu_c", "F_c"), ("beta", "c2"), ("gamma", "c_alpha")):
            if src in out:
                out[dst] = m * out[src]
    return out
