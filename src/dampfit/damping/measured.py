r"""The measured damper: a force–velocity curve fitted to the measured envelope itself, for a
deck whose decay follows the recording where a two-coefficient law cannot (issue 32).

**The curve** (:class:`Table`, the default): F(v) = sgn(v)·Σ_j s_j·r_j(|v|), piecewise linear
in |v| with F(0) = 0, knots 0 = v_0 < v_1 < … < v_{J−1} and ramps
r_j(u) = clip(u − v_j, 0, v_{j+1} − v_j) (the last one unbounded, r_{J−1}(u) = max(u −
v_{J−1}, 0): beyond the top knot the last slope continues). The slopes s_j ≥ 0 [N·s/m] make
F odd, monotone and passive (F·v ≥ 0) at every velocity, and allow plateaus. The knots are
data: v_1 … v_{J−1} are the 0, 1/(J−1), …, (J−2)/(J−1) quantiles of the trend's velocity
amplitudes ω·A at the peaks (:func:`table_knots`; J − 1 = n/:data:`PEAKS_PER_SEGMENT` slopes
above the lowest for n peaks, at least :data:`SEGMENTS` and at most :data:`MAX_SEGMENTS`),
so each slope has as many peaks as the next; below the slowest measured velocity the curve is
one linear slope s_0 (a linear dashpot), above the top knot the last slope continued. It is
an LS-DYNA ``*DEFINE_CURVE`` for ``*MAT_DAMPER_NONLINEAR_VISCOUS`` and an OpenSees ``Damper``
material (the strain rate as the strain) wrapping an ``ElasticMultiLinear`` of the same points
(which extrapolates its last segment), exactly. :class:`Powers` is the former family
F = Σ_j b_j·|v|^{α_j}·sgn v, b_j ≥ 0 (kept to compare with; not exported).

**Its decay.** First-order averaging (harmonic balance; Jacobsen 1930; (K2) of
:mod:`dampfit.model.laws`): over a cycle x = A·cos θ, v = −V·sin θ, V = ω·A, the energy of a
force F(|v|)·sgn v is E = ∮F dx = (4V/ω)·∫₀^{π/2} F(V sin θ)·sin θ dθ, and the equivalent
linear c dissipating it, E = π·c_eq·ω·A², is c_eq(V) = (4/(π·V))·∫₀^{π/2} F(V sin θ) sin θ dθ.
For the unbounded ramp max(u − a, 0), with r = a/V < 1, θ₀ = arcsin r,

    ∫_{θ₀}^{π/2} (V sin θ − a) sin θ dθ = V·h(r),   h(r) = π/4 − arcsin(r)/2 − r·√(1 − r²)/2

(h(0) = π/4, h ≥ 0, h = 0 for r ≥ 1), so per unit slope each ramp contributes
w_j(V) = (4/π)·[h(v_j/V) − h(v_{j+1}/V)] (the last: (4/π)·h(v_{J−1}/V)), c_eq(V) = Σ_j s_j·w_j(V):
a weighted mean of the slopes below V (Σ_j w_j = 1, weighted towards V). A power term gives
w_j = V^{α_j−1}·λ(α_j)/π. Either way the rate ρ(A) = c_eq(ω·A)/(2m) [1/s] is linear in the
coefficients, and the averaged envelope obeys d ln A/dt = −ρ(A); its solution is found by
quadrature, t(ln A) = ∫_{ln A}^{ln A₀} du/ρ(eᵘ) (:func:`envelope`), exact for the averaged
equation.

**The fit** (:func:`fit`) is to the measured half-period peaks ln P_i at t_i (the envelope
verify compares, :func:`dampfit.fem.response.envelope`):

1. a start by non-negative least squares (``scipy.optimize.nnls``) of the integrated form
   ln P_i = ln A₀ − Σ_j s_j·G_j(t_i), G_j(t) = ∫_{t_0}^{t} ρ_j(A_s)/s_j ds with A_s the measured
   trend (Savitzky–Golay, as verify's), the free ln A₀ projected out by centring;
2. the least squares of the averaged solution itself, ln A(t_i; s, ln A₀) − ln P_i, with
   s ≥ 0 (``scipy.optimize.least_squares``, trust-region reflective) — the error verify
   measures, no longer the trend's — from ln A₀ = the trend at the first peak, the start
   state verify runs every deck from (:func:`dampfit.fem.verify_damper.start_state`), not a
   free ln A₀: a free one traded a start offset for the curve (phone spring: 0.08 % above
   the trend, so the OpenSees run from the measured start stayed 0.08 % off the fit). With at least :data:`PEAKS_PER_SEGMENT` peaks a slope
   (and ≥ 2·:data:`BLOCK` peaks) the problem is well posed, each slope fixed by the peaks at
   its velocities; a roughness penalty on neighbouring slopes (first or second differences,
   weights 3·10⁻⁴ … 10⁻² of the peaks' rms) was tried and only biased the curves (simulated
   power, quadratic and sigmoid decays), so there is none. More segments follow a long
   recording closer (phone spring, 383 peaks: rms against the trend 0.28 % with 6 slopes,
   0.08 % with 16, 0.07 % with 24; its scatter 0.08 %).

**Its uncertainty.** The peaks scatter about the averaged envelope by e_i, stationary and
weakly dependent (sensor noise, the beat of neighbouring peaks). A moving-block bootstrap
of the residuals (Künsch 1989; circular blocks of :data:`BLOCK` peaks, the trend's span, so
the dependence within ~7 periods is kept) refits the curve :data:`N_BOOT` times from ŷ + e*
(same knots); the coefficients scale with the mass (ρ ∝ s/m), so each refit is multiplied by
a mass draw m*/m, m* ~ N(m, sd). c_eq(A) and ζ_eq(A) = ρ(A)/ω are given as the 5/50/95 %
quantiles of those refits. They do not cover the choice of knots (a structural choice) nor
the first-order averaging (O(ζ)).

**What the power family cannot follow.** ln c_eq(A) = ln Σ_j β_j·A^{α_j−1} with β_j ≥ 0 is a
convex function of ln A (a sum of log-convex functions is log-convex): a ζ(A) that rises and
then levels off or falls (as on the phone spring) is beyond it; the table follows it (a
plateau is a run of small slopes after steep ones). The fit's rms and the measurement's
scatter are given, so the outputs say whether the curve follows the recording.

**Range.** Fitted over the measured amplitudes [A_lo, A_hi] (velocities ω·A); outside it the
curve is extrapolated as stated above. Numeric only: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Exponents α_j of the power family's terms (0.5: strongly softening … 3: stiffening).
EXPONENTS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
#: Slopes of a table above the lowest one (segments between the velocity quantiles): at least
#: SEGMENTS, at most MAX_SEGMENTS, one per PEAKS_PER_SEGMENT peaks.
SEGMENTS, MAX_SEGMENTS, PEAKS_PER_SEGMENT = 6, 24, 16
#: Bootstrap refits and block length [peaks] (the verify trend's span).
N_BOOT, BLOCK = 100, 15
#: Points of the quadrature grid in ln A; residual evaluations of a bootstrap refit.
_GRID, _BOOT_EVALS = 800, 40


def _h(r):
    """h(r) = π/4 − arcsin(r)/2 − r·√(1 − r²)/2 for 0 ≤ r < 1, 0 beyond (module docstring)."""
    r = np.clip(np.asarray(r, float), 0.0, 1.0)
    return np.pi / 4 - np.arcsin(r) / 2 - r * np.sqrt(1.0 - r * r) / 2


@dataclass(frozen=True)
class Table:
    """Piecewise-linear F(|v|) of slopes s_j ≥ 0 from the knots ``knots`` = (0, v_1, …,
    v_{J−1}) [m/s] (the last slope unbounded); ``top`` [m/s] the fastest measured velocity,
    the last point of :meth:`points`."""

    knots: tuple[float, ...]
    top: float

    def weights(self, velocity) -> np.ndarray:
        """c_eq per unit slope of each segment at velocity amplitudes ``velocity`` [m/s]:
        w_j(V) of the module docstring, shape (len(V), J)."""
        V = np.maximum(np.asarray(velocity, float), 1e-300)[:, None]
        lo = _h(np.asarray(self.knots)[None, :] / V)
        hi = np.concatenate([lo[:, 1:], np.zeros((V.shape[0], 1))], axis=1)
        return 4.0 / np.pi * (lo - hi)

    def points(self, s) -> tuple[np.ndarray, np.ndarray]:
        """(v, F): the knots above 0 and ``top`` [m/s], the force there [N] (F(0) = 0)."""
        v = np.append(np.asarray(self.knots, float), max(self.top, self.knots[-1] * (1 + 1e-9)))
        F = np.concatenate([[0.0], np.cumsum(np.asarray(s, float) * np.diff(v))])
        return v[1:], F[1:]


@dataclass(frozen=True)
class Powers:
    """F = Σ_j b_j·|v|^{α_j}·sgn v over ``exponents`` (the power family, module docstring)."""

    exponents: tuple[float, ...] = EXPONENTS

    def weights(self, velocity) -> np.ndarray:
        """c_eq per unit b_j at velocity amplitudes ``velocity`` [m/s]: V^{α−1}·λ(α)/π."""
        from dampfit.model.laws import lam

        al = np.asarray(self.exponents, float)
        return np.asarray(velocity, float)[:, None] ** (al - 1.0) * lam(al) / np.pi


def table_knots(velocities, segments: int = SEGMENTS) -> Table:
    """The table of velocity amplitudes ``velocities`` [m/s] (the trend's at the peaks): knots
    0 and the 0, 1/segments, …, (segments − 1)/segments quantiles (module docstring)."""
    v = np.asarray(velocities, float)
    q = np.unique(np.quantile(v, np.arange(segments) / segments))
    return Table(tuple(float(x) for x in np.concatenate([[0.0], q[q > 0]])), float(v.max()))


def slopes(v, F) -> np.ndarray:
    """Slopes [N·s/m] of the points (v, F) of a table from (0, 0): one a segment."""
    v, F = np.concatenate([[0.0], v]), np.concatenate([[0.0], F])
    return np.diff(F) / np.diff(v)


def table_force(velocity, v, F):
    """F [N] of the table through (0, 0) and the points (``v`` [m/s] increasing, ``F`` [N])
    at ``velocity`` [m/s] (odd; beyond the last point its last slope continues)."""
    u = np.abs(np.asarray(velocity, float))
    vv, FF = np.concatenate([[0.0], v]), np.concatenate([[0.0], F])
    out = np.interp(u, vv, FF) + np.where(u > vv[-1], (u - vv[-1]) * slopes(v, F)[-1], 0.0)
    return np.sign(velocity) * out


def table_c_eq(velocity, v, F) -> np.ndarray:
    """c_eq [N·s/m] of the table of the points (v, F) at velocity amplitudes ``velocity``."""
    tab = Table(tuple(np.concatenate([[0.0], np.asarray(v, float)[:-1]])), float(v[-1]))
    return tab.weights(np.atleast_1d(velocity)) @ slopes(v, F)


@dataclass(frozen=True)
class MeasuredCurve:
    """The fitted curve: ``basis`` (:class:`Table` or :class:`Powers`), ``b`` (J,) its
    coefficients (slopes [N·s/m] or b_j [N·(s/m)^α]) point estimate, ``boot`` (B, J) their
    bootstrap refits (mass draws included), ``omega`` [rad/s], ``mass`` [kg], ``ln_a0`` of
    the averaged envelope at ``t0`` [s], ``rms`` [1] of ln P − ln A(t) over the peaks,
    ``amplitude_range`` [m] and ``velocity_range`` [m/s] of the fit (ω·A)."""

    basis: Table | Powers
    b: np.ndarray
    boot: np.ndarray
    omega: float
    mass: float
    t0: float
    ln_a0: float
    rms: float
    amplitude_range: tuple[float, float]
    velocity_range: tuple[float, float]

    def c_eq(self, amplitude, b=None):
        """c_eq(A) = 2·m·ρ(A) [N·s/m] at displacement amplitudes ``amplitude`` [m] (of ``b``,
        default the point estimate; b of shape (B, J) gives (B, len(A)))."""
        b = self.b if b is None else np.asarray(b, float)
        return b @ self.basis.weights(self.omega * np.atleast_1d(amplitude)).T

    def interval(self, amplitude: float) -> dict[str, float]:
        """c_eq and ζ_eq at ``amplitude`` [m]: point value and the bootstrap's q05/q50/q95."""
        draws = self.c_eq(amplitude, self.boot)[:, 0]
        q05, q50, q95 = (float(x) for x in np.quantile(draws, [0.05, 0.5, 0.95]))
        crit = 2.0 * self.mass * self.omega
        return {"c": float(self.c_eq(amplitude)[0]), "q05": q05, "q50": q50, "q95": q95,
                "zeta": float(self.c_eq(amplitude)[0]) / crit, "zeta_q05": q05 / crit,
                "zeta_q95": q95 / crit}


def term_rates(amplitude: np.ndarray, omega: float, mass: float, basis) -> np.ndarray:
    """ρ_j(A) per unit coefficient [1/s per unit] of each term of ``basis`` at the amplitudes
    ``amplitude`` [m] (module docstring); shape (len(A), J)."""
    return basis.weights(omega * np.asarray(amplitude, float)) / (2.0 * mass)


def envelope(b, ln_a0: float, t: np.ndarray, omega: float, mass: float, basis,
             ln_floor: float) -> np.ndarray:
    """ln A(t) [ln m] of the averaged equation d ln A/dt = −ρ(A) from ln A₀ at t = 0, by the
    quadrature of the module docstring on ``_GRID`` points down to ``ln_floor``; past the grid
    the last rate continues."""
    u = np.linspace(ln_a0, min(ln_floor, ln_a0 - 1e-6), _GRID)
    rho = term_rates(np.exp(u), omega, mass, basis) @ np.asarray(b, float)
    inv = 1.0 / np.maximum(rho, 1e-300)
    tg = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * -np.diff(u))])
    t = np.asarray(t, float)
    out = np.interp(t, tg, u)
    late = t > tg[-1]
    out[late] = u[-1] - rho[-1] * (t[late] - tg[-1])
    return out


def _start(t, ln_p, trend, omega, mass, basis) -> tuple[np.ndarray, float]:
    """Step 1 of the fit: NNLS of the integrated form (module docstring)."""
    from scipy.optimize import nnls

    g = term_rates(np.exp(trend), omega, mass, basis)
    G = np.zeros_like(g)
    G[1:] = np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t)[:, None], axis=0)
    Gc, yc = G - G.mean(axis=0), ln_p - ln_p.mean()
    scale = np.linalg.norm(Gc, axis=0)
    scale[scale == 0] = 1.0
    x, _ = nnls(-Gc / scale, yc)
    b = x / scale
    return b, float(ln_p.mean() + G.mean(axis=0) @ b)


def _refine(t, ln_p, b0, a0, system, floor, evals=None) -> np.ndarray:
    """Step 2: bounded least squares of the averaged envelope from the fixed start ln A₀ =
    ``a0`` (``system`` = (ω, m, basis); at most ``evals`` residual evaluations: a bootstrap
    refit starts at the optimum); returns (b…, ln A₀)."""
    from scipy.optimize import least_squares

    scale = np.where(b0 > 0, b0, max(float(b0.max()), 1e-12) * 1e-2)

    def resid(x):
        return envelope(x * scale, a0, t, *system, floor) - ln_p

    res = least_squares(resid, b0 / scale, bounds=(np.zeros(b0.size), np.inf), method="trf",
                        x_scale=1.0, max_nfev=evals)
    return np.concatenate([res.x * scale, [a0]])


def fit(t: np.ndarray, peaks: np.ndarray, omega: float, mass: float, mass_sd: float = 0.0,
        basis=None, seed: int = 0) -> MeasuredCurve:
    """The measured curve of peaks ``peaks`` [m] (displacement amplitudes, half-period
    extrema) at times ``t`` [s], ``omega`` [rad/s], ``mass`` [kg] ± ``mass_sd`` (module
    docstring); ``basis`` a :class:`Table` or :class:`Powers` (default: the table of
    :func:`table_knots` of the trend's velocities); ``seed`` makes the bootstrap reproducible.
    ValueError with fewer than 2·:data:`BLOCK` peaks."""
    from scipy.signal import savgol_filter

    from dampfit._progress import stage_bar

    peaks = np.asarray(peaks, float)
    if not np.all(np.isfinite(peaks) & (peaks > 0)):
        raise ValueError("the peaks must be positive and finite")
    t, ln_p = np.asarray(t, float), np.log(peaks)
    if t.size < 2 * BLOCK:
        raise ValueError(f"{t.size} peaks: the measured curve needs at least {2 * BLOCK}")
    tau = t - t[0]
    floor = float(ln_p.min()) - 1.0
    trend = savgol_filter(ln_p, BLOCK, 2)
    if basis is None:
        segments = min(MAX_SEGMENTS, max(SEGMENTS, t.size // PEAKS_PER_SEGMENT))
        basis = table_knots(omega * np.exp(trend), segments)
    system = (omega, mass, basis)
    b0, _ = _start(tau, ln_p, trend, *system)
    x = _refine(tau, ln_p, b0, float(trend[0]), system, floor)
    fitted = envelope(x[:-1], x[-1], tau, *system, floor)
    resid = ln_p - fitted
    rng = np.random.default_rng(seed)
    n, boot = t.size, np.empty((N_BOOT, b0.size))
    with stage_bar(N_BOOT, "measured curve: bootstrap", unit="refit") as bar:
        for i in range(N_BOOT):
            starts = rng.integers(0, n, size=-(-n // BLOCK))
            idx = (starts[:, None] + np.arange(BLOCK)[None, :]).ravel()[:n] % n
            yb = fitted + resid[idx]
            xb = _refine(tau, yb, x[:-1], float(savgol_filter(yb, BLOCK, 2)[0]), system, floor,
                         evals=_BOOT_EVALS)
            m_star = mass + mass_sd * rng.standard_normal() if mass_sd > 0 else mass
            boot[i] = xb[:-1] * m_star / mass
            bar.update(1)
    lo, hi = float(np.exp(trend.min())), float(np.exp(trend.max()))
    return MeasuredCurve(basis, x[:-1], boot, float(omega), float(mass), float(t[0]),
                         float(x[-1]), float(np.sqrt(np.mean(resid ** 2))), (lo, hi),
                         (omega * lo, omega * hi))
