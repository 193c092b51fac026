r"""Least-squares fit of the decay model (:mod:`dampfit.model.viscous`) with optimistix.

The profile is the one of :mod:`dampfit.model.profile` (eq. P2) with the viscous (M1) columns.

Variable projection: for the two nonlinear parameters θ = (ln p, ln ω_d) the linear
coefficients β = (A, B, drift…) are the exact linear least-squares solution, so the
Levenberg–Marquardt solver (``optimistix.LevenbergMarquardt``) minimises the projected
residual ``y − X(θ)·β̂(θ)`` over θ alone. This removes the amplitude–phase valley of the
direct problem and converges from the baseline guess in a few steps. A coarse grid over ω_d
(±3 Fourier bins of the window) first puts the start inside the basin of the global
minimum.

The covariance of all parameters φ = (θ, β) comes from the Jacobian J of the full model at
the optimum: ``Cov φ ≈ s²·r·(JᵀJ)⁻¹`` with ``s² = RSS/(n − dim φ)`` and the noise
calibration factor r of :mod:`dampfit.inference.noise`. Failure to converge is data
(``converged=False`` and a message), never an exception.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from dampfit.inference.executables import kernel
from dampfit.model import profile
from dampfit.model.viscous import M1 as _M1
from dampfit.signal.filters import filtfilt_gain
from dampfit.signal.prepare import FitData


@dataclass(frozen=True)
class LeastSquaresResult:
    """Least-squares optimum.

    ``theta`` = (ln p, ln ω_d); ``beta`` = (A [m/s²], B [m/s²], drift coefficients [m/s²]);
    ``cov`` covariance of (θ, β) *before* the calibration factor r; ``rss`` [(m/s²)²];
    ``residuals`` [m/s²]; ``gain`` complex gain of the pre-decimation filter on the decay;
    ``jacobian`` (n, 2 + q) of the full model in (θ, β) at the optimum [m/s² per unit], the
    design whose projection the noise calibration corrects for
    (:func:`dampfit.inference.noise.estimate`).
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
    jacobian: np.ndarray | None = None

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

    def true_quadratures(self) -> tuple[float, float]:
        """Acceleration quadratures (A, B) [m/s²] at τ = 0 with the decimation filter's complex
        gain G divided out: the fitted data carry Re[G·C·e^{sτ}] with C = A − iB (eq. M1), so
        C_true = C_fit / G."""
        cc = complex(self.beta[0], -self.beta[1]) / complex(self.gain)
        return cc.real, -cc.imag

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


# One kernel on padded inputs (FitData.padded) does the whole fit: coarse grid, Levenberg–
# Marquardt, profile, residuals and Jacobian. It compiles once per shape bucket and is reused by
# every later fit of that bucket (a study compiles a handful of times); under the CLI its
# executable is kept on disk (dampfit.inference.executables), so a fresh process neither traces
# nor lowers the optimistix loop. All goes through the one profile of dampfit.model.profile with
# the (M1) columns.
def _projected_residual(theta, args):
    tau, y, drift, mask = args
    return profile.profile(_M1, theta, tau, y, drift, mask).residual


#: Solver tolerances (relative, absolute) of the Levenberg–Marquardt loop.
TOLERANCES = (1e-10, 1e-12)


@kernel(static_argnums=(0,))
def _fit(max_steps, grid, tau, y, drift, mask):
    """(θ̂, β̂ (padded), RSS, residuals (padded), Jacobian (padded rows, all columns), solver
    result code, steps) of the fit started at the best point of ``grid`` (rows θ)."""
    import optimistix as optx  # here, not at the top: a process that loads the compiled
    # kernel (dampfit.inference.executables) never traces this and never imports optimistix

    arrays = (tau, y, drift, mask)
    rss = jax.vmap(lambda th: profile.profile(_M1, th, tau, y, drift, mask).rss)(grid)
    theta0 = grid[jnp.nanargmin(rss)]
    solver = optx.LevenbergMarquardt(rtol=TOLERANCES[0], atol=TOLERANCES[1])
    sol = optx.least_squares(_projected_residual, solver, theta0, args=arrays,
                             max_steps=max_steps, throw=False)
    pr = profile.profile(_M1, sol.value, tau, y, drift, mask)
    phi = jnp.concatenate([sol.value, pr.beta])
    resid = y - profile.predict(_M1, phi, tau, drift, mask)
    jac = jax.jacfwd(lambda ph: profile.predict(_M1, ph, tau, drift, mask))(phi)
    steps = sol.stats.get("num_steps", jnp.asarray(-1))
    return sol.value, pr.beta, pr.rss, resid, jac, sol.result._value, steps


def _solver_message(code: int) -> str:
    """optimistix's text for a result code (its RESULTS table)."""
    import optimistix as optx

    try:
        return optx.RESULTS._index_to_message[code].split("\n")[0]
    except (AttributeError, IndexError, TypeError):
        return f"result code {code}"


def least_squares(fd: FitData, p0: float, f0: float, *, max_steps: int = 200) -> LeastSquaresResult:
    """Fit the decay model to ``fd`` from a decay rate guess ``p0`` [1/s] and frequency ``f0`` [Hz]."""
    pad = fd.padded
    n, nq = pad.n, pad.q  # real samples; real linear coefficients (A, B, drift)
    with jax.enable_x64(True):
        arrays = tuple(np.asarray(a, dtype=np.float64) for a in (pad.tau, pad.y, pad.drift))
        arrays += (np.asarray(pad.mask),)
        span = float(fd.tau[-1] - fd.tau[0])
        w0 = 2 * np.pi * f0
        p0 = float(np.clip(p0, 1e-6 * w0, 0.5 * w0)) if np.isfinite(p0) and p0 > 0 else 1e-3 * w0
        # coarse start: ω_d over ±3 Fourier bins, p over a factor of 10 (fixed 5 × 49 grid)
        ws = w0 + 2 * np.pi / span * np.linspace(-3, 3, 49)
        ws = np.where(ws > 0, ws, w0)
        ps = p0 * np.array([0.2, 0.5, 1.0, 2.0, 5.0])
        grid = np.log(np.array([[pp, ww] for pp in ps for ww in ws]))
        out = [np.asarray(v) for v in _fit(int(max_steps), grid, *arrays)]
        theta, beta_pad, rss_v, resid_pad, jac_pad, code, steps = out
        code = int(code)
        ok = code == 0
        resid = resid_pad[:n]
        # Jacobian of the real rows and the real columns (θ, A, B, drift_0..drift_degree)
        jac = jac_pad[:n, : 2 + nq]
        beta = beta_pad[:nq]
        k = 2 + nq
        s2 = float(rss_v) / max(n - k, 1)
        try:
            cov = s2 * np.linalg.inv(jac.T @ jac)
        except np.linalg.LinAlgError:
            cov = np.full((k, k), np.nan)
            ok = False
        finite = np.all(np.isfinite(theta)) and np.all(np.isfinite(cov))
        message = "converged" if ok else f"optimistix: {_solver_message(code)}"
        if ok and not finite:
            ok, message = False, "singular Jacobian at the optimum"
        steps = int(steps)
        p, wd = float(np.exp(theta[0])), float(np.exp(theta[1]))
        y, drift = fd.y, fd.drift
        return LeastSquaresResult(
            theta=theta, beta=beta, cov=cov, rss=float(rss_v), n=n,
            residuals=resid, converged=ok and finite, message=message, n_steps=steps,
            gain=amplitude_gain(fd, p, wd),
            rss_drift=float(np.sum((y - drift @ (drift.T @ y)) ** 2)),
            jacobian=np.asarray(jac, dtype=float),
        )
