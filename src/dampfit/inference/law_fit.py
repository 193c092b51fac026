r"""Least squares, tempered likelihood and Laplace evidence for each damping law.

The data and noise model are those of the viscous fit (:mod:`dampfit.inference.least_squares`, :mod:`dampfit.inference.noise`):
the acceleration is ``y = X(θ)·(A, B) + Q·d + noise`` with the law's two oscillation columns
(:func:`dampfit.model.laws.columns`), the orthonormal drift basis Q of
:func:`dampfit.model.viscous.drift_basis`, and Gaussian noise of unknown σ. The linear coefficients
(A, B, d) are solved exactly at every θ (variable projection, drift projected out once — the
Schur complement of :func:`dampfit.model.profile.profile`), so Levenberg–Marquardt sees only the
nonlinear parameters θ (two to six: the law's, ln ω and the frequency-drift terms). With flat
priors on (A, B, d) and a Jeffreys prior on σ, the marginal log likelihood is (P3 of
:mod:`dampfit.model.profile`)

    ℓ(θ) = −½·ln det(X⊥ᵀX⊥) − ½·(n − q)·ln RSS(θ),                                     (L1)

used tempered, ℓ/r, with the Whittle factor r (:mod:`dampfit.inference.noise`). **Evidence** with the
priors of :func:`log_prior` (ln p₀ uniform on [ln 10⁻⁶ω, ln ω], ln ω uniform over the pass band,
the shape parameter s — friction or drag fraction, or exponent α — uniform on its support
:data:`~dampfit.model.laws.PRIOR_SHAPE`):

* viscous: Laplace, ln Z ≈ ℓ(θ̂)/r + ln π(θ̂) + (k/2)·ln 2π − ½·ln det H,  H = −∇²ℓ/r;  (L2)
* nonlinear laws: the shape s is integrated *numerically* over its support and only
  (ln p₀, ln ω) by Laplace at each s (a nested Laplace approximation):

    Z = ∫ π(s)·exp[ℓ(s, φ̂_s)/r]·π(φ̂_s)·(2π)^{m/2}·det H_s^{−½} ds,  φ = (ln p₀, ln ω, c_j), (L3)

  on a grid of s that resolves the peak (nodes every 2σ_s/3 within ±6σ_s of the optimum,
  plus a uniform grid over the support, each side's march stopped once the integrand has
  fallen e^−50 below its peak: :data:`TAIL_DROP`), trapezoidal rule. This stays accurate when the
  likelihood in s is skewed or peaks outside the support (a negative friction fraction on
  viscous data), where a Gaussian in s would not. H = Gauss–Newton information (below).
  The frequency-drift coefficients c_j (K4 of :mod:`~dampfit.model.laws`) get a flat
  prior common to every law, so ln Z is defined up to a constant that cancels in comparisons.

The profile is the one of :mod:`dampfit.model.profile` (P2, P3) with the law's columns, run as
a jitted JAX kernel (float64) on the padded samples (the shape buckets of
:func:`dampfit.signal.prepare.padded_length`) and on fixed blocks of :data:`BATCH` θ rows, θ
padded with zero phase terms (identical columns): each law compiles once per sample bucket and
process (≈ 0.5–1 s), and every later recording of the same bucket reuses the compiled code. The
optimiser is scipy's MINPACK Levenberg–Marquardt; its central-difference Jacobian comes from
the same kernel call as the residual (:class:`_Residual`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import jax
import numpy as np
from scipy import optimize

from dampfit.inference.executables import kernel
from dampfit.inference.least_squares import amplitude_gain
from dampfit.model import laws
from dampfit.model import profile as _profile
from dampfit.model.laws import P_RANGE
from dampfit.signal.prepare import MAX_DRIFT_DEGREE, FitData, padded_length

#: Central-difference step in θ [1] (ln-rates, fraction or exponent, ln ω).
STEP = 1e-6


@dataclass(frozen=True, eq=False)
class Data:
    """Fit samples: ``tau`` [s], ``y`` [m/s²], orthonormal ``drift`` basis (n, d) [1]."""

    tau: np.ndarray
    y: np.ndarray
    drift: np.ndarray

    @classmethod
    def from_fit_data(cls, fd: FitData) -> "Data":
        return cls(np.asarray(fd.tau, float), np.asarray(fd.y, float), np.asarray(fd.drift, float))

    @property
    def n(self) -> int:
        return int(self.y.size)

    @property
    def q(self) -> int:
        """Number of linear coefficients (A, B and the drift terms)."""
        return int(self.drift.shape[1] + 2)

    @functools.cached_property
    def samples(self) -> _profile.Samples:
        """The samples padded to the shape bucket of :func:`dampfit.signal.prepare.padded_length`
        (JAX float64 arrays, built once)."""
        with jax.enable_x64(True):
            return _profile.Samples.from_arrays(
                self.tau, self.y, self.drift, pad_to=padded_length(self.n),
                drift_columns=max(MAX_DRIFT_DEGREE + 1, self.drift.shape[1]))


#: θ rows per kernel call: smaller batches are padded, larger ones run in chunks, and θ is
#: padded with zero phase terms to J = MAX_PHASE (exactly the same columns), so each law
#: compiles once per padded sample bucket — a few seconds per process in all.
BATCH = 8


@kernel(static_argnums=(0,))
def _profile_kernel(law, thetas, samples):
    def one(th):
        pr = _profile.profile(law, th, samples.tau, samples.y, samples.drift, samples.mask)
        return (pr.beta, pr.rss, pr.logdet, _profile.conditional_covariance(pr),
                samples.y - pr.residual)

    return jax.vmap(one)(thetas)


def _run_kernel(model: str, theta, data: Data):
    """The kernel on θ (..., k) in chunks of :data:`BATCH`: NumPy outputs with rows (b, …)."""
    law = laws.get(model)
    theta = np.asarray(theta, dtype=float)
    rows = theta.reshape(-1, theta.shape[-1])
    b, k = rows.shape
    full = np.zeros((max(-(-b // BATCH), 1) * BATCH, law.omega_index + 1 + laws.MAX_PHASE))
    full[:b, :k], full[b:, :k] = rows, (rows[-1] if b else 0.0)
    outs = []
    with jax.enable_x64(True):
        for i in range(0, full.shape[0], BATCH):
            outs.append([np.asarray(x) for x in
                         _profile_kernel(law, full[i:i + BATCH], data.samples)])
    return [np.concatenate(col)[:b] for col in zip(*outs)], theta.shape[:-1]


def profile(model: str, theta, data: Data):
    """Variable projection (P2 of :mod:`dampfit.model.profile`) at θ (shape (..., k)).

    Returns NumPy ``(beta (..., q), rss (...), logdet (...), minv (..., 2, 2),
    fitted (..., n))``: β = (A, B, drift…), the RSS [(m/s²)²], ln det X⊥ᵀX⊥, M⁻¹ = (X⊥ᵀX⊥)⁻¹
    (the conditional covariance of (A, B) is s²·M⁻¹) and the fitted values [m/s²].
    """
    (beta, rss, logdet, minv, fitted), batch = _run_kernel(model, theta, data)
    n, q = data.n, data.q
    return (beta[:, :q].reshape(batch + (q,)), rss.reshape(batch), logdet.reshape(batch),
            minv.reshape(batch + (2, 2)), fitted[:, :n].reshape(batch + (n,)))


def loglik_batch(model: str, thetas, data: Data) -> np.ndarray:
    """Untempered ℓ(θ) of (L1) for θ of shape (..., k), NumPy; −inf where undefined (the
    emcee sampler of :mod:`dampfit.inference.law_sampler` evaluates it ~10⁴ times)."""
    (_, rss, logdet, _, _), batch = _run_kernel(model, thetas, data)
    with np.errstate(all="ignore"):
        ll = -0.5 * logdet - 0.5 * (data.n - data.q) * np.log(rss)
    return np.where(np.isfinite(ll), ll, -np.inf).reshape(batch)


class _Residual:
    """Projected residual y − fitted(θ(x)) [m/s²] and its central-difference Jacobian from one
    evaluation of [x, x + h·e_i, x − h·e_i] (2k + 1 rows: one or two :data:`BATCH` blocks);
    the Jacobian is kept for MINPACK's ``jac(x)``, which follows ``fun(x)`` at every accepted
    step, so each Levenberg–Marquardt iteration costs one kernel evaluation.
    ``to_theta`` maps the optimised x (..., k') to θ."""

    def __init__(self, model: str, data: Data, to_theta=None):
        self.model, self.data = model, data
        self.to_theta = to_theta or (lambda x: x)
        self.key, self.jacobian = None, None

    def _eval(self, x):
        x = np.asarray(x, dtype=float)
        d = STEP * np.eye(x.size)
        pts = self.to_theta(np.concatenate([x[None], x + d, x - d]))
        with np.errstate(all="ignore"):
            r = self.data.y - profile(self.model, pts, self.data)[4]
        self.key = x.tobytes()
        self.jacobian = ((r[1:x.size + 1] - r[x.size + 1:]) / (2 * STEP)).T
        return r[0]

    def fun(self, x):
        return self._eval(x)

    def jac(self, x):
        if np.asarray(x, dtype=float).tobytes() != self.key:
            self._eval(x)
        return self.jacobian


@dataclass(frozen=True)
class ModelFit:
    """Least-squares optimum of one law (and, after :func:`laplace`, its Laplace evidence).

    ``theta`` (see :mod:`~dampfit.model.laws`); ``beta`` = (A, B [m/s²], drift…);
    ``rss`` [(m/s²)²]; ``loglik`` untempered ℓ(θ̂) of (L1); ``residuals``, ``fitted`` [m/s²];
    ``a0`` [m] displacement amplitude at the window start; ``gain`` |G| [1] of the decimation
    filter on the decay. ``cov`` = Σ, ``ln_evidence`` of (L2) and ``temper`` = 1/r are set by
    :func:`laplace`, and for a nonlinear law the ``grid`` of (L3).
    """

    model: str
    theta: np.ndarray
    beta: np.ndarray
    rss: float
    loglik: float
    residuals: np.ndarray
    fitted: np.ndarray
    a0: float
    gain: float
    converged: bool
    message: str
    cov: np.ndarray | None = None
    ln_evidence: float = float("nan")
    temper: float = float("nan")
    grid: "ShapeGrid | None" = None

    @property
    def k(self) -> int:
        """Number of nonlinear parameters."""
        return int(self.theta.size)

    @property
    def omega(self) -> float:
        """Carrier angular frequency ω [rad/s] (ω_d of the viscous model)."""
        return float(np.exp(self.theta[laws.omega_index(self.model)]))

    @property
    def p0(self) -> float:
        """Total decay rate at the window start [1/s]."""
        return float(np.exp(self.theta[0]))


def _start_grid(model: str, p_visc: float, w: float, span: float, phase0) -> np.ndarray:
    ph = list(phase0)
    law = laws.get(model)
    if law.shape_prior is None:  # ω over ±3 Fourier bins of the window, as least_squares does
        ws = w + 2 * np.pi / span * np.linspace(-3, 3, 25)
        return np.array([[np.log(p_visc * x), np.log(ww)] + ph
                         for x in (0.3, 0.5, 0.7, 1.0, 1.4, 2.0, 3.0) for ww in ws if ww > 0])
    lo, hi = law.shape_prior
    shapes = np.linspace(lo - 0.1 * (hi - lo), hi, 14)
    rates = p_visc * np.array([0.5, 0.7, 1.0, 1.4, 2.0, 3.0])
    return np.array([[np.log(r), s, np.log(w)] + ph for r in rates for s in shapes])


def jacobian(fun, theta: np.ndarray) -> np.ndarray:
    """Central-difference Jacobian (n, k) of ``fun``, which takes a batch of θ (b, k) → (b, n)."""
    d = STEP * np.eye(theta.size)
    vals = fun(np.concatenate([theta + d, theta - d]))
    return ((vals[:theta.size] - vals[theta.size:]) / (2 * STEP)).T


def fit_model(model: str, fd: FitData, data: Data, p_visc: float, omega: float, *,
              phase0=(), max_nfev: int = 600) -> ModelFit:
    """Least-squares fit of one law from the viscous rate ``p_visc`` [1/s] and ``omega`` [rad/s].

    ``phase0`` [rad] starts the frequency-drift coefficients (K4); their number is the J of
    the fit. A coarse grid over (p₀, shape) at ω (viscous: over p and ω ± 3 Fourier bins)
    picks the start; MINPACK's Levenberg–Marquardt then minimises the projected residual.
    Failure is data (``converged=False``), never raised.
    """
    p_visc = p_visc if np.isfinite(p_visc) and p_visc > 0 else 1e-3 * omega
    grid = _start_grid(model, p_visc, omega, float(data.tau[-1] - data.tau[0]), phase0)
    with np.errstate(all="ignore"):
        rss = profile(model, grid, data)[1]
    theta0 = grid[int(np.nanargmin(np.where(np.isfinite(rss), rss, np.inf)))]

    res = _Residual(model, data)
    try:
        sol = optimize.least_squares(res.fun, theta0, jac=res.jac,
                                     method="lm", xtol=1e-12, ftol=1e-12, max_nfev=max_nfev)
        theta, ok, message = sol.x, bool(sol.success), str(sol.message)
    except (ValueError, np.linalg.LinAlgError) as exc:  # non-finite residuals at the start
        theta, ok, message = theta0, False, f"least squares failed: {exc}"
    with np.errstate(all="ignore"):
        beta, rss_v, logdet, _, fitted = profile(model, theta, data)
    ll = float(-0.5 * logdet - 0.5 * (data.n - data.q) * np.log(rss_v))
    finite = bool(np.all(np.isfinite(theta)) and np.isfinite(ll))
    w = float(np.exp(theta[laws.omega_index(model)]))
    if finite:
        gain = abs(amplitude_gain(fd, float(laws.local_rate(model, theta, 1.0)), w))
        a0 = float(np.hypot(beta[0], beta[1]) / (w * w * gain))
    else:
        gain = a0 = float("nan")
    return ModelFit(
        model=model, theta=np.asarray(theta, float), beta=beta, rss=float(rss_v), loglik=ll,
        residuals=data.y - fitted, fitted=fitted, a0=a0, gain=gain, converged=ok and finite,
        message="converged" if ok and finite else message,
    )


def log_prior(model: str, theta, band: tuple[float, float]) -> np.ndarray:
    """Log prior density of θ (shape (..., k)); −inf outside the support. ``band`` [Hz]
    (:meth:`dampfit.model.laws.Law.log_prior`)."""
    return laws.log_prior(model, theta, band)


def information(model: str, theta, beta, rss: float, data: Data, idx=None) -> np.ndarray:
    r"""Gauss–Newton −∇²ℓ of (L1) in the coordinates ``idx`` of θ (all by default), untempered.

    J_θ⊥ᵀ·J_θ⊥/s² [1/θ²]: J_θ⊥ is the θ-Jacobian of the model at fixed (A, B) = ``beta[:2]``
    with the linear columns (X, Q) projected out, s² = RSS/(n − q − k) — the inverse of the
    θ-block of s²·(JᵀJ)⁻¹ for the full Jacobian J = [∂f/∂θ, X, Q], the covariance
    :mod:`dampfit.inference.least_squares` uses (Golub & Pereyra 2003).
    """
    theta = np.asarray(theta, dtype=float)
    idx = list(range(theta.size)) if idx is None else list(idx)
    ab = np.asarray(beta)[:2]

    def f(subs):
        th = np.repeat(theta[None, :], len(subs), axis=0)
        th[:, idx] = subs
        return laws.columns(model, th, data.tau, xp=np) @ ab

    q_ = data.drift  # orthonormal: project it out directly, then the two columns X⊥
    jt = jacobian(f, theta[idx])
    jt = jt - q_ @ (q_.T @ jt)
    xo = laws.columns(model, theta, data.tau, xp=np)
    xo = xo - q_ @ (q_.T @ xo)
    jp = jt - xo @ np.linalg.solve(xo.T @ xo, xo.T @ jt)
    s2 = rss / max(data.n - data.q - theta.size, 1)
    return jp.T @ jp / s2


@dataclass(frozen=True)
class ShapeGrid:
    """The integrand of (L3) on a grid of the shape parameter ``s``.

    ``log_density`` [1] (ln of the integrand without π(s)), ``phi`` (m, k − 1) the profile
    optimum of the other parameters (ln p₀, ln ω, phase terms) at each node and ``phi_cov``
    (m, k − 1, k − 1) its Laplace covariance (tempered).
    """

    s: np.ndarray
    log_density: np.ndarray
    phi: np.ndarray
    phi_cov: np.ndarray
    loglik: np.ndarray  # untempered profile ℓ(s, φ̂_s) [1]


#: A node of the (L3) grid whose integrand lies this far [nats] below the largest so far, and
#: below its inner neighbour, ends the march in its direction: the nodes beyond would add less
#: than e^−TAIL_DROP of Z (nothing, in double precision) unless the integrand rose again by as
#: much — a second optimum the least-squares start did not find, which a grid of nine uniform
#: nodes would not resolve either. Typically the first uniform node outside the ±6σ_s core
#: already lies 400–900 nats down; the 5–7 nodes beyond it cost ≈ 40 % of the grid's fits.
TAIL_DROP = 50.0


def _beyond_tail(log_density: np.ndarray, i: int, i0: int) -> bool:
    """Whether node ``i`` lies beyond the tail cut-off of :data:`TAIL_DROP` (its inner
    neighbour, towards the start node ``i0``, already past the drop and falling)."""
    step = 1 if i > i0 else -1
    prev, prev2 = i - step, i - 2 * step
    if not (0 <= prev2 < log_density.size) or (prev2 - i0) * step < 0:
        return False
    top = float(np.max(log_density))
    a, b = float(log_density[prev]), float(log_density[prev2])
    return bool(np.isfinite(a) and np.isfinite(b) and a < b and a < top - TAIL_DROP)


def _with_shape(phi: np.ndarray, s: float) -> np.ndarray:
    """θ from the other parameters ``phi`` (..., k − 1) and the shape ``s``."""
    phi = np.asarray(phi, dtype=float)
    return np.concatenate([phi[..., :1], np.full(phi.shape[:-1] + (1,), s), phi[..., 1:]], axis=-1)


def _fit_at_shape(mf: ModelFit, data: Data, s: float, phi0: np.ndarray):
    res = _Residual(mf.model, data, lambda phi: _with_shape(phi, s))
    sol = optimize.least_squares(res.fun, phi0, jac=res.jac, method="lm",
                                 xtol=1e-10, ftol=1e-12, max_nfev=100)
    th = _with_shape(sol.x, s)
    beta, rss, logdet, _, _ = profile(mf.model, th, data)
    return th, beta, float(rss), float(-0.5 * logdet - 0.5 * (data.n - data.q) * np.log(rss))


def shape_grid(mf: ModelFit, data: Data, temper: float, band, sd: float) -> ShapeGrid:
    """Evaluate the integrand of (L3) around the optimum ``mf.theta`` (``sd`` ≈ σ of s)."""
    lo, hi = laws.get(mf.model).shape_prior
    centre = float(np.clip(mf.theta[1], lo, hi))
    sd = float(np.clip(sd, 1e-4 * (hi - lo), hi - lo)) if np.isfinite(sd) else 0.1 * (hi - lo)
    nodes = np.concatenate([np.linspace(lo, hi, 9), centre + sd * np.linspace(-6, 6, 19)])
    nodes = np.unique(np.clip(nodes, lo, hi))
    out = np.full(nodes.size, -np.inf)
    rest = [i for i in range(mf.k) if i != 1]
    phis = np.full((nodes.size, len(rest)), np.nan)
    covs = np.full((nodes.size, len(rest), len(rest)), np.nan)
    lls = np.full(nodes.size, -np.inf)
    i0 = int(np.argmin(np.abs(nodes - centre)))
    # march outwards from the optimum, warm-starting each node from its neighbour, until the
    # integrand has fallen below e^−TAIL_DROP of its peak while still falling
    for order in (range(i0, nodes.size), range(i0 - 1, -1, -1)):
        phi = mf.theta[rest].copy()
        for i in order:
            if _beyond_tail(out, i, i0):
                break
            th, beta, rss, ll = _fit_at_shape(mf, data, float(nodes[i]), phi)
            if not np.isfinite(ll):
                continue
            h = temper * information(mf.model, th, beta, rss, data, idx=rest)
            ev = np.linalg.eigvalsh(h)
            if not (np.all(np.isfinite(ev)) and ev.min() > 0):
                continue
            phi = th[rest]
            lp = float(log_prior("viscous", phi, band))  # (ln p₀, ln ω, …) as the viscous law
            out[i] = (temper * ll + lp + 0.5 * len(rest) * np.log(2 * np.pi)
                      - 0.5 * float(np.sum(np.log(ev))))
            phis[i], covs[i], lls[i] = phi, np.linalg.inv(h), ll
    return ShapeGrid(s=nodes, log_density=out, phi=phis, phi_cov=covs, loglik=lls)


def laplace(mf: ModelFit, data: Data, temper: float, band: tuple[float, float]) -> ModelFit:
    """Add the covariance Σ at θ̂ and ln Z of (L2)/(L3) for the likelihood ℓ·``temper`` (= ℓ/r)."""
    k = mf.k
    cov, ln_z, grid = np.full((k, k), np.nan), float("nan"), None
    if mf.converged:
        h = temper * information(mf.model, mf.theta, mf.beta, mf.rss, data)
        ev = np.linalg.eigvalsh(h)
        if np.all(np.isfinite(h)) and ev.min() > 0:
            cov = np.linalg.inv(h)
        if laws.get(mf.model).shape_prior is None:  # no shape parameter: plain Laplace
            if np.all(np.isfinite(cov)):
                lp = float(log_prior("viscous", mf.theta, band))
                ln_z = (temper * mf.loglik + lp + 0.5 * k * np.log(2 * np.pi)
                        - 0.5 * float(np.sum(np.log(ev))))
        else:
            grid = shape_grid(mf, data, temper, band, float(np.sqrt(cov[1, 1])))
            ok = np.isfinite(grid.log_density)
            if ok.sum() >= 3:
                lo, hi = laws.get(mf.model).shape_prior
                x, y = grid.s[ok], grid.log_density[ok]
                top = float(y.max())
                dens = np.exp(y - top)
                area = float(np.sum(0.5 * (dens[1:] + dens[:-1]) * np.diff(x)))
                ln_z = top + np.log(area) - np.log(hi - lo)
    out = replace(mf, cov=cov, ln_evidence=float(ln_z), temper=float(temper), grid=grid)
    return _constrain(out, data) if grid is not None else out


def _constrain(mf: ModelFit, data: Data) -> ModelFit:
    """Move an optimum whose shape parameter lies outside the prior support onto the support.

    The best node of the evidence grid (a boundary, since ℓ is unimodal in s there) replaces θ̂,
    with β, residuals, a₀ and the covariance recomputed; ln Z and the grid are unchanged.
    """
    law = laws.get(mf.model)
    lo, hi = law.shape_prior
    g = mf.grid
    if lo <= mf.theta[1] <= hi or not np.any(np.isfinite(g.loglik)):
        return mf
    i = int(np.argmax(g.loglik))
    theta = _with_shape(g.phi[i], g.s[i])
    beta, rss, logdet, _, fitted = profile(mf.model, theta, data)
    w = float(np.exp(theta[laws.omega_index(mf.model)]))
    h = mf.temper * information(mf.model, theta, beta, float(rss), data)
    try:
        cov = np.linalg.inv(h)
    except np.linalg.LinAlgError:
        cov = np.full((mf.k, mf.k), np.nan)
    return replace(
        mf, theta=theta, beta=beta, rss=float(rss), loglik=float(g.loglik[i]), fitted=fitted,
        residuals=data.y - fitted, a0=float(np.hypot(beta[0], beta[1]) / (w * w * mf.gain)),
        cov=cov, message=f"optimum on the prior boundary {law.shape_name} = {g.s[i]:g}",
    )




#: Signed root of the likelihood ratio against no decay above which the decay is measured:
#: the one-sided 95 % point of N(0, 1), i.e. the 90 % interval of p excludes 0.
Z_DECAY = float(1.6448536269514722)
#: Decay rate, as a fraction of ω, that stands for "no decay" (p·T ≈ 2π·10⁻¹²·cycles).
P_ZERO = 1e-12


def decay_test(mf: ModelFit, data: Data, temper: float) -> dict:
    r"""Can the decay of the viscous fit ``mf`` be told from no decay at all?

    Likelihood ratio of p = 0 (:data:`P_ZERO`·ω, any recording's p·T below 10⁻⁸) against the
    optimum, with ω (and the phase terms held) re-optimised at p = 0, tempered like the
    evidence (``temper`` = 1/r):

        Λ = temper·(ℓ(θ̂) − max_ω ℓ(p = 0, ω)),   z = √(2Λ),                      (D1)

    z is the signed root of the likelihood ratio, ≈ N(0, 1) under p = 0 (one-sided: p ≥ 0 is
    on the boundary); the decay is *resolved* when z > :data:`Z_DECAY` — the 90 % interval
    of p then excludes 0. A steady sine (forced or self-sustained vibration) gives z ≈ 0–1.6.

    Returns ``{"z", "ln_lr", "resolved", "p_hat" [1/s]}`` (``resolved`` None when ℓ cannot
    be evaluated).
    """
    theta = np.asarray(mf.theta, dtype=float)
    iw = laws.omega_index(mf.model)
    ll_hat = float(mf.loglik)
    if not (np.all(np.isfinite(theta)) and np.isfinite(ll_hat) and temper > 0):
        return {"z": None, "ln_lr": None, "resolved": None, "p_hat": None}
    sd = float(np.sqrt(mf.cov[iw, iw])) if mf.cov is not None and np.isfinite(
        mf.cov[iw, iw]) and mf.cov[iw, iw] > 0 else 1e-4
    best_w, best_ll = theta[iw], -np.inf
    for half in (6.0 * sd, 0.5 * sd):  # a coarse grid in ln ω, then a fine one about its best
        lnw = best_w + np.linspace(-half, half, 33)
        th = np.repeat(theta[None, :], lnw.size, axis=0)
        th[:, iw] = lnw
        th[:, 0] = lnw + np.log(P_ZERO)
        ll = loglik_batch(mf.model, th, data)
        i = int(np.argmax(ll))
        if ll[i] > best_ll:
            best_w, best_ll = float(lnw[i]), float(ll[i])
    if not np.isfinite(best_ll):
        return {"z": None, "ln_lr": None, "resolved": None, "p_hat": float(np.exp(theta[0]))}
    lam = max(temper * (ll_hat - best_ll), 0.0)
    z = float(np.sqrt(2.0 * lam))
    return {"z": z, "ln_lr": float(lam), "resolved": bool(z > Z_DECAY),
            "p_hat": float(np.exp(theta[0]))}
