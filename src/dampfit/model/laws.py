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
Accuracy against a DOP853 solution of the equation of motion (``tests/analytic/test_damping_models.py``),
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

Each law is one small frozen dataclass (:class:`Viscous`, :class:`Coulomb`, :class:`Quadratic`,
:class:`Power`, all :class:`Law`) holding its parameter names, units and priors, the envelope
(K3), the columns, the local rate (K2) and the physical coefficients; :data:`LAWS` maps the names
above to instances, and the string functions below (:func:`envelope`, :func:`columns`, …) are thin
wrappers that dispatch through it. Laws are hashable, so jitted functions take them as static
arguments. The methods are pure and shape-static and run on ``jax.numpy`` (jit/vmap/grad) or on
NumPy (``xp=numpy``); θ may carry leading batch axes. The likelihood built on the columns (one
variable-projection profile for every law, sums of laws and several recordings) is in
:mod:`dampfit.model.profile`.

**A new law is one class.** Besides the numerics (:meth:`Law.envelope`, :meth:`Law.local_rate`,
:meth:`Law._coefficients`, :meth:`Law.force`) a law carries everything the rest of dampfit
reads about it: ``prior_weight`` (the evidence's model prior,
:func:`dampfit.model.registry.prior_weights`),
``coefficients`` (:class:`Coefficient`: name, SI unit, symbol, whether it needs the mass —
summary.json's ``damper`` and the report print them), ``force_text``, ``fem_hint`` (the
damping-law warning) and ``colour`` (the amplitude figure).
:func:`dampfit.model.registry.register` adds an instance to :data:`LAWS` (``--model`` then
offers it, the assessment fits, samples and compares it); ``unregister`` removes it. The
FEM writers dispatch on ``Law.name`` and can tabulate any law's force–velocity curve with
:meth:`Law.force`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from dampfit._lazy import LazyModule

#: ``jax.numpy``, imported on first use (:class:`dampfit._lazy.LazyModule`): the laws'
#: descriptions (names, coefficients, force laws, FEM hints, plot styles) are read by the
#: command line and the outputs, which should not pay JAX's import (≈ 2 s) for them.
jnp = LazyModule("jax.numpy")

#: Envelope level treated as "stopped" [1]; local decay rates are also capped at ω
#: (ζ_local ≤ 1), beyond which averaging has no meaning.
_SMALL = 1e-9
#: Width of the log-uniform prior on p₀: [10⁻⁶·ω, ω].
P_RANGE = 1e-6


def lam(alpha):
    """λ(α) = 2^{2+α}·Γ²(1 + α/2)/Γ(2 + α) [1] of (K2) (FEMA 274; NumPy, broadcasts)."""
    from scipy.special import gammaln  # on first use: the laws' descriptions do not need it

    alpha = np.asarray(alpha, dtype=float)
    return np.exp((2 + alpha) * np.log(2.0) + 2 * gammaln(1 + alpha / 2) - gammaln(2 + alpha))


def _safe(x, xp, small=1e-8):
    return xp.where(xp.abs(x) < small, small, x)


# Legendre P_j (j = 2, 3, 4) and their first and second derivatives in x
_LEG = (
    (lambda x: 1.5 * x * x - 0.5, lambda x: 3.0 * x, lambda x: 3.0 + 0.0 * x),
    (lambda x: 2.5 * x**3 - 1.5 * x, lambda x: 7.5 * x * x - 1.5, lambda x: 15.0 * x),
    (lambda x: (35 * x**4 - 30 * x * x + 3) / 8, lambda x: 17.5 * x**3 - 7.5 * x,
     lambda x: 52.5 * x * x - 7.5),
)
#: Most frequency-drift phase coefficients (Legendre degrees 2..4).
MAX_PHASE = len(_LEG)


@dataclass(frozen=True)
class Coefficient:
    """One physical coefficient of a law: its name (a key of :meth:`Law.physical` with a
    mass and of summary.json's ``damper.coefficients``), SI unit, printed symbol, and
    ``per_mass`` (True: the recording identifies it per unit mass only, so it needs the mass;
    False: mass-free, like α)."""

    name: str
    unit: str
    symbol: str
    per_mass: bool = True


@dataclass(frozen=True)
class Law:
    r"""One damping law: θ = (the law's own parameters, ln ω, c₂ … c_{J+1}).

    Subclasses set the class attributes ``name``, ``own`` (names of the parameters before ln ω),
    ``own_units`` and ``shape_prior`` (uniform support of θ[1], None for viscous) and implement
    :meth:`envelope`, :meth:`local_rate` and :meth:`_coefficients`. ``n_phase`` = J (K4) fixes
    :attr:`n_params` and :attr:`names` (what compositions split θ by); the array methods
    themselves read J from the length of θ, so one law object serves every J.

    Methods take θ of shape (..., k) and times ``tau`` [s] of shape (n,); ``xp`` is the array
    module (``jax.numpy`` by default, or ``numpy``).
    """

    n_phase: int = 0

    name: ClassVar[str] = ""
    own: ClassVar[tuple[str, ...]] = ()
    own_units: ClassVar[tuple[str, ...]] = ()
    shape_prior: ClassVar[tuple[float, float] | None] = None
    #: Linear amplitudes per law: the two quadratures (A, B) of the oscillation columns.
    n_columns: ClassVar[int] = 2
    # ---- what the rest of dampfit reads about a law (one place: see "A new law" above)
    #: Prior weight in the evidence comparison (normalised over the registered laws:
    #: :func:`dampfit.model.registry.prior_weights`); viscous 1/2 and the three others 1/6
    #: each is 1 : 1 between
    #: "one viscous c" and "amplitude-dependent".
    prior_weight: ClassVar[float] = 1 / 6
    #: The law's own physical coefficients, in the order they are printed.
    coefficients: ClassVar[tuple["Coefficient", ...]] = ()
    #: The force law in plain text (units implied by the coefficients).
    force_text: ClassVar[str] = ""
    #: What to enter in an FEM code for this law (the hint of the damping-law warning).
    fem_hint: ClassVar[str] = ""
    #: Plot style of the law in the figures (a matplotlib colour).
    colour: ClassVar[str] = "tab:purple"

    # ------------------------------------------------------------------ parameters
    @property
    def omega_index(self) -> int:
        """Position of ln ω in θ (the law's own parameters come first, phase terms after)."""
        return len(self.own)

    @property
    def n_params(self) -> int:
        """k = own parameters + ln ω + J phase terms."""
        return self.omega_index + 1 + self.n_phase

    @property
    def names(self) -> tuple[str, ...]:
        """Names of θ's entries (as in ``summary.json``: ``ln_p0``, the shape, ``ln_omega``,
        ``phase_P2_rad`` …)."""
        return self.own + ("ln_omega",) + tuple(f"phase_P{j + 2}_rad" for j in range(self.n_phase))

    @property
    def units(self) -> tuple[str, ...]:
        """Units of θ's entries (ln of a rate: ln(1/s); ln ω: ln(rad/s); phase terms: rad)."""
        return self.own_units + ("ln(rad/s)",) + ("rad",) * self.n_phase

    @property
    def shape_name(self) -> str | None:
        """Name of the shape parameter θ[1] (None for viscous)."""
        return self.own[1] if len(self.own) > 1 else None

    def with_phase(self, n_phase: int) -> "Law":
        """The same law with J = ``n_phase`` frequency-drift terms."""
        return replace(self, n_phase=int(n_phase))

    def phase_count(self, theta) -> int:
        """Number J of frequency-drift phase coefficients carried by θ (K4)."""
        return int(np.shape(theta)[-1]) - self.omega_index - 1

    def log_prior(self, theta, band: tuple[float, float], xp=np):
        """Log prior density of θ (shape (..., k)); −inf outside the support. ``band`` [Hz].

        ln p₀ log-uniform on [ln 10⁻⁶·ω, ln ω], ln ω uniform over the pass band, the shape
        parameter uniform on :attr:`shape_prior`; phase terms flat (a constant common to every
        law, so it cancels in comparisons).
        """
        lw_lo, lw_hi = np.log(2 * np.pi * band[0]), np.log(2 * np.pi * band[1])
        return self.log_prior_ln(theta, lw_lo, lw_hi, xp)

    def log_prior_ln(self, theta, lw_lo, lw_hi, xp=np):
        """:meth:`log_prior` with the pass band as ln ω bounds [ln(rad/s)], which may be JAX
        values (the posterior kernel passes them as arguments: one compilation for every
        band)."""
        th = theta if xp is not np else np.asarray(theta, dtype=float)
        lnw, lnp = th[..., self.omega_index], th[..., 0]
        inside = (lnw > lw_lo) & (lnw < lw_hi) & (lnp < lnw) & (lnp > lnw + np.log(P_RANGE))
        lp = -xp.log(lw_hi - lw_lo) - np.log(-np.log(P_RANGE)) + xp.zeros_like(lnw)
        if self.shape_prior is not None:
            lo, hi = self.shape_prior
            inside = inside & (th[..., 1] >= lo) & (th[..., 1] <= hi)
            lp = lp - np.log(hi - lo)
        return xp.where(inside, lp, -xp.inf)

    # ------------------------------------------------------------------ model
    def rates(self, theta, xp=jnp):
        """(p₀ or p [1/s], shape parameter, ω [rad/s]) from θ, each with a trailing axis for τ."""
        p0 = xp.exp(theta[..., 0])[..., None]
        w = xp.exp(theta[..., self.omega_index])[..., None]
        s = theta[..., 1][..., None] if self.shape_prior is not None else None
        return p0, s, w

    def envelope(self, theta, tau, xp=jnp):
        """Envelope shape e = a/a₀ [1], rate R = ρ·e [1/s] and R' = dR/de [1/s] (K3)."""
        raise NotImplementedError

    def phase(self, theta, tau, xp=jnp):
        """Phase ψ [rad], instantaneous frequency Ω = ψ' [rad/s] and ψ'' [rad/s²] of (K4)."""
        iw = self.omega_index
        w = xp.exp(theta[..., iw])[..., None]
        psi, dpsi, ddpsi = w * tau, w + 0.0 * tau, 0.0 * tau
        j_max = self.phase_count(theta)
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

    def columns(self, theta, tau, xp=jnp):
        """Acceleration columns [Re, Im] of (Ω/ω)²·h(τ)·e^{iψ}, shape (..., n, 2) [1] (module
        docstring); the linear quadratures (A, B) on them have |(A, B)| = ω²·a₀ [m/s²]."""
        _, _, w = self.rates(theta, xp)
        e, r, dr = self.envelope(theta, tau, xp)
        psi, big_w, ddpsi = self.phase(theta, tau, xp)
        rho = xp.clip(r / xp.maximum(e, _SMALL), -big_w, big_w)  # local rate, |ζ_local| ≤ 1
        scale = e * (big_w / w) ** 2
        re_h = scale * (1.0 - dr * rho / (big_w * big_w))
        im_h = scale * (2.0 * rho / big_w - ddpsi / (big_w * big_w))
        c, s = xp.cos(psi), xp.sin(psi)
        return xp.stack([re_h * c - im_h * s, re_h * s + im_h * c], axis=-1)

    # ------------------------------------------------------------------ physics (NumPy)
    def local_rate(self, theta, ratio):
        """Local decay rate ρ [1/s] at the amplitude ``ratio`` = a/a₀ [1] (K2); NumPy,
        broadcasts."""
        raise NotImplementedError

    def c_equivalent(self, theta, a0, amplitude, mass):
        """Energy-equivalent viscous c_eq = 2·m·ρ(a) [N·s/m] at displacement ``amplitude`` [m];
        ``a0`` [m] the amplitude at the window start, ``mass`` [kg] (Jacobsen 1930)."""
        ratio = np.asarray(amplitude) / np.asarray(a0)
        return 2.0 * np.asarray(mass) * self.local_rate(theta, ratio)

    def _coefficients(self, p0, s, w, a0) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def force(self, velocity, coefficients: dict[str, float]) -> np.ndarray:
        """The damping force f_d [N] at ``velocity`` [m/s] (NumPy, broadcasts) for the
        coefficient values ``coefficients`` (names of :attr:`coefficients`, SI units): the
        force–velocity curve an FEM deck tabulates."""
        raise NotImplementedError

    def physical(self, theta, a0, mass=None) -> dict[str, np.ndarray]:
        """The law's coefficients from θ and the start amplitude ``a0`` [m]; NumPy, broadcasts.

        Per unit mass (always): ``p_viscous`` = c/(2m) [1/s]; coulomb ``mu_c`` = F_c/m [m/s²];
        quadratic ``beta`` = c₂/m [1/m]; power ``gamma`` = c_α/m [(m/s)^{1−α}/s] and ``alpha``
        [1]. With ``mass`` [kg] also ``c`` [N·s/m], ``F_c`` [N], ``c2`` [N·s²/m²], ``c_alpha``
        [N·(s/m)^α]. ω [rad/s] = exp(θ[ln ω]). Inverts (K2)–(K3). A law added with
        :func:`dampfit.model.registry.register` returns each coefficient NAME that needs the
        mass per unit mass as ``"NAME/m"`` from :meth:`_coefficients`; with a mass
        NAME = m·(NAME/m) is added.
        """
        th = np.asarray(theta, dtype=float)
        p0, w = np.exp(th[..., 0]), np.exp(th[..., self.omega_index])
        s = th[..., 1] if self.shape_prior is not None else None
        out = self._coefficients(p0, s, w, np.asarray(a0, dtype=float))
        if mass is not None:
            m = np.asarray(mass, dtype=float)
            if "p_viscous" in out:
                out["c"] = 2.0 * m * out["p_viscous"]
            for src, dst in (("mu_c", "F_c"), ("beta", "c2"), ("gamma", "c_alpha")):
                if src in out:
                    out[dst] = m * out[src]
            for c in self.coefficients:  # a new law's per-unit-mass "NAME/m" → NAME
                if c.per_mass and c.name not in out and f"{c.name}/m" in out:
                    out[c.name] = m * out[f"{c.name}/m"]
        return out


@dataclass(frozen=True)
class Viscous(Law):
    """f_d = c·u̇: θ = (ln p, ln ω, phase…), e = exp(−pτ), p = c/(2m) [1/s]."""

    name: ClassVar[str] = "viscous"
    own: ClassVar[tuple[str, ...]] = ("ln_p0",)
    own_units: ClassVar[tuple[str, ...]] = ("ln(1/s)",)
    prior_weight: ClassVar[float] = 1 / 2
    coefficients: ClassVar[tuple[Coefficient, ...]] = (Coefficient("c", "N s/m", "c"),)
    force_text: ClassVar[str] = "F = c·v"
    fem_hint: ClassVar[str] = ("a linear dashpot c (LS-DYNA *MAT_DAMPER_VISCOUS, DC = c; "
                               "OpenSees uniaxialMaterial Viscous with alpha = 1)")
    colour: ClassVar[str] = "0.45"

    def force(self, velocity, coefficients):
        return coefficients["c"] * np.asarray(velocity, dtype=float)

    def envelope(self, theta, tau, xp=jnp):
        p0, _, _ = self.rates(theta, xp)
        e = xp.exp(-p0 * tau)
        return e, p0 * e, p0 * xp.ones_like(e)

    def local_rate(self, theta, ratio):
        th = np.asarray(theta, dtype=float)
        return np.exp(th[..., 0]) * np.ones_like(np.asarray(ratio, dtype=float))

    def _coefficients(self, p0, s, w, a0):
        return {"p_viscous": p0}


@dataclass(frozen=True)
class ViscousM1(Viscous):
    """The viscous law with the columns of eq. (M1) of :mod:`dampfit.model.viscous`:
    ``[e^{−pτ}cos ψ, e^{−pτ}sin ψ]``, θ = (ln p, ln ω_d), so the linear coefficients are the
    acceleration quadratures (A, B) [m/s²] themselves (the pipeline's least squares and
    posterior). It spans the same space as :class:`Viscous` (a constant complex factor apart)."""

    def columns(self, theta, tau, xp=jnp):
        e = self.envelope(theta, tau, xp)[0]
        psi = self.phase(theta, tau, xp)[0]
        return xp.stack([e * xp.cos(psi), e * xp.sin(psi)], axis=-1)


@dataclass(frozen=True)
class Coulomb(Law):
    """f_d = c·u̇ + F_c·sgn(u̇): θ = (ln p₀, f, ln ω, phase…), f the friction fraction."""

    name: ClassVar[str] = "coulomb"
    own: ClassVar[tuple[str, ...]] = ("ln_p0", "friction_fraction")
    own_units: ClassVar[tuple[str, ...]] = ("ln(1/s)", "1")
    shape_prior: ClassVar[tuple[float, float]] = (0.0, 1.0)
    coefficients: ClassVar[tuple[Coefficient, ...]] = (
        Coefficient("c", "N s/m", "c"), Coefficient("F_c", "N", "F_c"))
    force_text: ClassVar[str] = "F = c·v + F_c·sgn(v)"
    fem_hint: ClassVar[str] = ("a dashpot c plus a friction force F_c (e.g. LS-DYNA "
                               "*MAT_DAMPER_NONLINEAR_VISCOUS with the force–velocity curve "
                               "F = c·v + F_c·sign(v), or a friction element)")
    colour: ClassVar[str] = "tab:orange"

    def force(self, velocity, coefficients):
        v = np.asarray(velocity, dtype=float)
        return coefficients["c"] * v + coefficients["F_c"] * np.sign(v)

    def envelope(self, theta, tau, xp=jnp):
        p0, s, _ = self.rates(theta, xp)
        pv, pc = (1 - s) * p0, s * p0
        x = pv * tau
        xs = _safe(x, xp)
        ex = xp.where(xp.abs(x) < 1e-8, 1 - 0.5 * x, -xp.expm1(-xs) / xs)
        e = xp.maximum(xp.exp(-x) - pc * tau * ex, 0.0)
        moving = e > 0
        return e, xp.where(moving, pv * e + pc, 0.0), xp.where(moving, pv, 0.0)

    def local_rate(self, theta, ratio):
        th = np.asarray(theta, dtype=float)
        p0, s = np.exp(th[..., 0]), th[..., 1]
        return (1 - s) * p0 + s * p0 / np.asarray(ratio, dtype=float)

    def _coefficients(self, p0, s, w, a0):
        return {"p_viscous": (1 - s) * p0, "mu_c": 0.5 * math.pi * w * a0 * s * p0}


@dataclass(frozen=True)
class Quadratic(Law):
    """f_d = c·u̇ + c₂·u̇|u̇|: θ = (ln p₀, f, ln ω, phase…), f the drag fraction."""

    name: ClassVar[str] = "quadratic"
    own: ClassVar[tuple[str, ...]] = ("ln_p0", "drag_fraction")
    own_units: ClassVar[tuple[str, ...]] = ("ln(1/s)", "1")
    shape_prior: ClassVar[tuple[float, float]] = (0.0, 1.0)
    coefficients: ClassVar[tuple[Coefficient, ...]] = (
        Coefficient("c", "N s/m", "c"), Coefficient("c2", "N s^2/m^2", "c₂"))
    force_text: ClassVar[str] = "F = c·v + c2·v·|v|"
    fem_hint: ClassVar[str] = ("a dashpot with F = c·v + c2·v·|v| (LS-DYNA "
                               "*MAT_DAMPER_NONLINEAR_VISCOUS with that force–velocity curve)")
    colour: ClassVar[str] = "tab:green"

    def force(self, velocity, coefficients):
        v = np.asarray(velocity, dtype=float)
        return coefficients["c"] * v + coefficients["c2"] * v * np.abs(v)

    def envelope(self, theta, tau, xp=jnp):
        p0, s, _ = self.rates(theta, xp)
        pv, pq = (1 - s) * p0, s * p0
        x = pv * tau
        xs = _safe(x, xp)
        fx = xp.where(xp.abs(x) < 1e-8, 1 + 0.5 * x, xp.expm1(xs) / xs)
        z = xp.maximum(xp.exp(x) + pq * tau * fx, 1e-6)  # 1/e; > 0 unless p_q < 0
        e = 1.0 / z
        return e, pv * e + pq * e * e, pv + 2 * pq * e

    def local_rate(self, theta, ratio):
        th = np.asarray(theta, dtype=float)
        p0, s = np.exp(th[..., 0]), th[..., 1]
        return (1 - s) * p0 + s * p0 * np.asarray(ratio, dtype=float)

    def _coefficients(self, p0, s, w, a0):
        return {"p_viscous": (1 - s) * p0, "beta": 3.0 * math.pi * s * p0 / (4.0 * w * a0)}


@dataclass(frozen=True)
class Power(Law):
    """f_d = c_α·|u̇|^α·sgn(u̇): θ = (ln p₀, α, ln ω, phase…); α ∈ [0, 3] (friction 0 …
    viscous 1 … drag 2, with room above)."""

    name: ClassVar[str] = "power"
    own: ClassVar[tuple[str, ...]] = ("ln_p0", "alpha")
    own_units: ClassVar[tuple[str, ...]] = ("ln(1/s)", "1")
    shape_prior: ClassVar[tuple[float, float]] = (0.0, 3.0)
    coefficients: ClassVar[tuple[Coefficient, ...]] = (
        Coefficient("c_alpha", "N (s/m)^alpha", "c_α"),
        Coefficient("alpha", "1", "α", per_mass=False))
    force_text: ClassVar[str] = "F = c_alpha·|v|^alpha·sgn(v)"
    fem_hint: ClassVar[str] = ("a nonlinear viscous damper F = c_alpha·|v|^alpha·sign(v) "
                               "(OpenSees uniaxialMaterial Viscous C alpha; LS-DYNA "
                               "*MAT_DAMPER_NONLINEAR_VISCOUS with that curve)")
    colour: ClassVar[str] = "tab:blue"

    def force(self, velocity, coefficients):
        v = np.asarray(velocity, dtype=float)
        return coefficients["c_alpha"] * np.abs(v) ** coefficients["alpha"] * np.sign(v)

    def envelope(self, theta, tau, xp=jnp):
        p0, s, _ = self.rates(theta, xp)
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

    def local_rate(self, theta, ratio):
        th = np.asarray(theta, dtype=float)
        p0, s = np.exp(th[..., 0]), th[..., 1]
        return p0 * np.asarray(ratio, dtype=float) ** (s - 1.0)

    def _coefficients(self, p0, s, w, a0):
        return {"alpha": s, "gamma": 2.0 * math.pi * p0 * (w * a0) ** (1.0 - s) / lam(s)}


#: The registered damping laws by name, viscous first (the null model): the four of this
#: module, and any added with :func:`dampfit.model.registry.register`.
LAWS: dict[str, Law] = {law.name: law for law in (Viscous(), Coulomb(), Quadratic(), Power())}
#: Their names, viscous first (kept equal to ``tuple(LAWS)`` by :func:`refresh`).
MODELS = tuple(LAWS)
#: Name of each law's shape parameter θ[1] (viscous has none).
SHAPE = {m: law.shape_name for m, law in LAWS.items() if law.shape_name}
#: Uniform prior support of the shape parameter: f ∈ [0, 1]; α ∈ [0, 3].
PRIOR_SHAPE = {m: law.shape_prior for m, law in LAWS.items() if law.shape_prior}


def refresh() -> None:
    """Bring :data:`MODELS`, :data:`SHAPE`, :data:`PRIOR_SHAPE` up to :data:`LAWS` (the dicts in
    place; :mod:`dampfit.model.registry` calls it)."""
    global MODELS
    MODELS = tuple(LAWS)
    SHAPE.clear()
    SHAPE.update({m: law.shape_name for m, law in LAWS.items() if law.shape_name})
    PRIOR_SHAPE.clear()
    PRIOR_SHAPE.update({m: law.shape_prior for m, law in LAWS.items() if law.shape_prior})


def names() -> tuple[str, ...]:
    """The registered laws' names, viscous first (what ``--model`` accepts besides auto)."""
    return tuple(LAWS)


def get(model: "str | Law", theta=None) -> Law:
    """The law called ``model`` (a law passes through); with ``theta`` its J matches θ."""
    if isinstance(model, Law):
        law = model
    else:
        try:
            law = LAWS[model]
        except (KeyError, TypeError):
            raise ValueError(f"unknown damping model {model!r}") from None
    return law if theta is None else law.with_phase(law.phase_count(theta))


# ------------------------------------------------------------ string API (dispatch by name)
def omega_index(model: str) -> int:
    """Position of ln ω in θ (the law's own parameters come first, phase terms after)."""
    return get(model).omega_index


def n_phase(model: str, theta) -> int:
    """Number J of frequency-drift phase coefficients carried by θ (K4)."""
    return get(model).phase_count(theta)


def phase(model: str, theta, tau, xp=jnp):
    """Phase ψ [rad], Ω = ψ' [rad/s], ψ'' [rad/s²] of (K4); see :meth:`Law.phase`."""
    return get(model).phase(theta, tau, xp)


def envelope(model: str, theta, tau, xp=jnp):
    """Envelope shape e = a/a₀ [1], rate R = ρ·e [1/s] and R' = dR/de [1/s] at ``tau`` [s]
    (K3): θ (..., k) → (..., n) for ``tau`` (n,); ``xp`` ``jax.numpy`` (default) or ``numpy``."""
    return get(model).envelope(theta, tau, xp)


def columns(model: str, theta, tau, xp=jnp):
    """Acceleration columns [Re, Im] of (Ω/ω)²·h(τ)·e^{iψ}, shape (..., n, 2) [1] (docstring)."""
    return get(model).columns(theta, tau, xp)


def local_rate(model: str, theta, ratio):
    """Local decay rate ρ [1/s] at the amplitude ``ratio`` = a/a₀ [1] (K2) of θ (..., k)
    draws; NumPy, broadcasts."""
    return get(model).local_rate(theta, ratio)


def c_equivalent(model: str, theta, a0, amplitude, mass):
    """Energy-equivalent viscous c_eq = 2·m·ρ(a) [N·s/m] at displacement ``amplitude`` [m];
    ``a0`` [m] the amplitude at the window start, ``mass`` [kg] (Jacobsen 1930)."""
    return get(model).c_equivalent(theta, a0, amplitude, mass)


def physical(model: str, theta, a0, mass=None) -> dict[str, np.ndarray]:
    """The law's coefficients from θ and ``a0`` [m]; see :meth:`Law.physical`."""
    return get(model).physical(theta, a0, mass)


def log_prior(model: str, theta, band: tuple[float, float], xp=np):
    """Log prior density of θ (shape (..., k)); −inf outside the support. ``band`` [Hz]."""
    return get(model).log_prior(theta, band, xp)
