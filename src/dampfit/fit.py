r"""Least-squares fit of the decay model (:mod:`dampfit.model`) with optimistix.

Variable projection: for the two nonlinear parameters θ = (ln p, ln ω_d) the linear
coefficients β = (A, B, drift…) are the exact linear least-squares solution, so the
Levenberg–Marquardt solver (``optimistix.LevenbergMarquardt``) minimises the projected
residual ``y − X(θ)·β̂(θ)`` over θ alone. This removes the amplitude–phase valley of the
direct problem and converges from the baseline guess in a few steps. A coarse grid over ω_d
(±3 Fourier bins of the window) first puts the start inside the basin of the global
minimum.

The covariance of all parameters φ = (θ, β) comes from the Jacobian J of the full model at
the optimum: ``Cov φ ≈ s²·r·(JᵀJ)⁻¹`` with ``s² = RSS/(n − dim φ)`` and the noise
calibration factor r of :mod:`dampfit.noise`. Failure to converge is data
(``converged=False`` and a message), never an exception.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from . import model
from .filters import filtfilt_gain
from .preprocess import FitData

__all__ = ["LeastSquaresResult", "least_squares", "amplitude_gain"]


@dataclass(frozen=True)
class LeastSquaresResult:
    """Least-squares optimum.

    ``theta`` = (ln p, ln ω_d); ``beta`` = (A [m/s²], B [m/s²], drift coefficients [m/s²]);
    ``cov`` covariance of (θ, β) *before* the calibration factor r; ``rss`` [(m/s²)²];
    ``residuals`` [m/s²]; ``gain`` complex gain of the pre-decimation filter on the decay.
    """

    theta: np.ndarray
    beta: np.ndarray
    cov: np.ndarray
    rss: float
    n: int
    residuals: np.ndarray
    converged: bool
    message: str
    n_steps: int
    gain: complex
    rss_drift: float  # residual sum of squares of the drift terms alone [(m/s²)²]

    @property
    def explained(self) -> float:
        """Fraction of the window's variance beyond the drift that the damped oscillation explains."""
        return float(1.0 - self.rss / self.rss_drift) if self.rss_drift > 0 else 0.0

    @property
    def p(self) -> float:
        """Decay rate [1/s]."""
        return float(np.exp(self.theta[0]))

    @property
    def omega_d(self) -> float:
        """Damped angular frequency [rad/s]."""
        return float(np.exp(self.theta[1]))

    @property
    def n_params(self) -> int:
        return int(self.beta.size + 2)

    def u0(self, beta=None, p=None, omega_d=None) -> np.ndarray:
        """Displacement envelope amplitude at the window start, eq. (M2), [m]."""
        beta = self.beta if beta is None else beta
        p = self.p if p is None else p
        omega_d = self.omega_d if omega_d is None else omega_d
        beta = np.asarray(beta)
        return np.hypot(beta[..., 0], beta[..., 1]) / ((omega_d**2 + p**2) * abs(self.gain))


def amplitude_gain(fd: FitData, p: float, omega_d: float) -> complex:
    """Complex gain of the decimation low-pass on the decay (1 on the raw path)."""
    if fd.lowpass_sos is None:
        return 1.0 + 0j
    return filtfilt_gain(fd.lowpass_sos, fd.fs_filter, p, omega_d)


@jax.jit
def _projected_residual(theta, args):
    tau, y, drift = args
    beta, _, _, _ = model.profile(theta, tau, y, drift)
    return y - model.design_matrix(theta, tau, drift) @ beta


@jax.jit
def _grid_rss(thetas, tau, y, drift):
    return jax.vmap(lambda th: model.profile(th, tau, y, drift)[1])(thetas)


@jax.jit
def _full_model(phi, tau, drift):
    return model.design_matrix(phi[:2], tau, drift) @ phi[2:]


def least_squares(fd: FitData, p0: float, f0: float, *, max_steps: int = 200) -> LeastSquaresResult:
    """Fit the decay model to ``fd`` from a decay rate guess ``p0`` [1/s] and frequency ``f0`` [Hz]."""
    with jax.enable_x64(True):
        tau = jnp.asarray(fd.tau)
        y = jnp.asarray(fd.y)
        drift = jnp.asarray(fd.drift)
        span = float(fd.tau[-1] - fd.tau[0])
        w0 = 2 * np.pi * f0
        p0 = float(np.clip(p0, 1e-6 * w0, 0.5 * w0)) if np.isfinite(p0) and p0 > 0 else 1e-3 * w0
        # coarse start: ω_d over ±3 Fourier bins, p over a factor of 10
        ws = w0 + 2 * np.pi / span * np.linspace(-3, 3, 49)
        ps = p0 * np.array([0.2, 0.5, 1.0, 2.0, 5.0])
        grid = np.array([[np.log(pp), np.log(ww)] for pp in ps for ww in ws if ww > 0])
        rss = np.asarray(_grid_rss(jnp.asarray(grid), tau, y, drift))
        theta0 = jnp.asarray(grid[int(np.nanargmin(rss))])

        solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12)
        sol = optx.least_squares(
            _projected_residual, solver, theta0, args=(tau, y, drift),
            max_steps=max_steps, throw=False,
        )
        ok = bool(sol.result == optx.RESULTS.successful)
        theta = np.asarray(sol.value)
        beta, rss_v, _, _ = model.profile(sol.value, tau, y, drift)
        phi = jnp.concatenate([sol.value, beta])
        resid = np.asarray(y - _full_model(phi, tau, drift))
        jac = np.asarray(jax.jacfwd(_full_model)(phi, tau, drift))
        n, k = fd.y.size, phi.size
        s2 = float(rss_v) / max(n - k, 1)
        try:
            cov = s2 * np.linalg.inv(jac.T @ jac)
        except np.linalg.LinAlgError:
            cov = np.full((k, k), np.nan)
            ok = False
        finite = np.all(np.isfinite(theta)) and np.all(np.isfinite(cov))
        message = "converged" if ok else f"optimistix: {sol.result}"
        if ok and not finite:
            ok, message = False, "singular Jacobian at the optimum"
        steps = int(sol.stats.get("num_steps", -1)) if hasattr(sol, "stats") else -1
        p, wd = float(np.exp(theta[0])), float(np.exp(theta[1]))
        return LeastSquaresResult(
            theta=theta, beta=np.asarray(beta), cov=cov, rss=float(rss_v), n=n,
            residuals=resid, converged=ok and finite, message=message, n_steps=steps,
            gain=amplitude_gain(fd, p, wd),
            rss_drift=float(jnp.sum((y - drift @ (drift.T @ y)) ** 2)),
        )
