r"""One variable-projection profile and marginal likelihood for every decay model (JAX).

Data model
----------
A recording's acceleration samples y [m/s²] at times τ [s] from the window start are

    y = X(θ)·β + Q·d + ε,     ε ~ N(0, σ²·I)·(coloured: see the Whittle factor below),     (P1)

with X(θ) the model's m oscillation columns (two per damping law, :mod:`dampfit.model.laws`),
β their linear amplitudes, Q the orthonormal drift basis
(:func:`dampfit.model.viscous.drift_basis`) with coefficients d. For fixed θ, (β, d) is the exact
linear least-squares solution; Q is projected out first (Schur complement):

    X⊥ᵀX⊥ = XᵀX − (QᵀX)ᵀ(QᵀX),   β̂ = (X⊥ᵀX⊥)⁻¹X⊥ᵀy⊥,   d̂ = Qᵀy − QᵀX·β̂,
    RSS(θ) = ‖y − Xβ̂ − Qd̂‖²,   ln det(XᵀX)_full = ln det X⊥ᵀX⊥   (QᵀQ = I).              (P2)

With flat priors on (β, d) and a Jeffreys prior 1/σ, integrating them out gives the profiled
(σ-marginal) log likelihood

    ℓ(θ) = −½·ln det X⊥ᵀX⊥ − ½·(n − q)·ln RSS(θ),   q = m + dim d,                          (P3)

used tempered, ℓ/r, with the Whittle factor r = PSD at the oscillation / mean PSD of the noise
(:mod:`dampfit.inference.noise`; ``temper`` = 1/r). This one function serves the pipeline's least
squares and posterior (:class:`~dampfit.model.laws.ViscousM1`) and the damping-law fits, evidence
and sampler (:data:`~dampfit.model.laws.LAWS`).

API
---
*Models* are hashable objects with ``n_params``, ``n_columns``, ``names`` and
``columns(theta, tau, xp=jnp) → (..., n, n_columns)``: each damping law
(:class:`~dampfit.model.laws.Law`), and compositions of them:

* ``Sum(law_a, law_b, …)`` — several modes in one recording: θ is the concatenation of the
  components' θ (each of its fixed ``n_params``; :meth:`Sum.split`), the columns are
  concatenated, β holds each component's (A, B) in order.
* ``Joint(model, n_recordings, shared=(i, …))`` — several recordings of one model with the
  entries ``shared`` of θ common to all and the others per recording. The global parameter
  vector is ``[shared…, rest of recording 0…, rest of recording 1…, …]``;
  :meth:`Joint.split` maps it to the per-recording θ (:meth:`Joint.index` is the map) and
  :func:`joint_log_marginal` sums (P3) over the recordings, each with its own β, d, σ and r.

*Samples* (:class:`Samples`) hold one recording's padded arrays (``tau``, ``y``, ``drift``,
``mask``) and its real sample and drift-column counts as float scalars, so a jitted function
compiles once per padded shape bucket (:class:`dampfit.signal.prepare.Padded`), not per
recording.

Functions (pure, shape-static; jit/vmap/grad; the caller enables float64):

* :func:`profile` ``(model, θ, tau, y, drift, mask)`` → :class:`Profile` (β, RSS, ln det, the
  scaled Cholesky factor of X⊥ᵀX⊥, the residual);
* :func:`predict` ``(model, φ = (θ, β, d), tau, drift, mask)`` → the model values (the full
  nonlinear model, for Jacobians);
* :func:`log_marginal` ``(model, θ, samples, temper)`` → (P3)·temper;
* :func:`marginal_and_amplitudes` → (P3)·temper and the conditional moments of β;
* :func:`joint_log_marginal` ``(joint, θ, [samples…], tempers)`` → Σ_r (P3)_r·temper_r.

A later hierarchical analysis puts priors over the per-recording entries of a :class:`Joint`
and samples its global θ with the same likelihood.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Sequence

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np


class Samples(NamedTuple):
    """One recording's (padded) fit samples: ``tau`` [s], ``y`` [m/s²], orthonormal ``drift``
    basis (n_pad, d_pad) [1] with zero rows/columns as padding, ``mask`` [1] (1 on real rows),
    ``n`` real samples and ``n_drift`` real drift columns (float scalars, so they are traced)."""

    tau: jnp.ndarray
    y: jnp.ndarray
    drift: jnp.ndarray
    mask: jnp.ndarray
    n: jnp.ndarray
    n_drift: jnp.ndarray

    @classmethod
    def from_padded(cls, pad) -> "Samples":
        """From :class:`dampfit.signal.prepare.Padded` (whose ``q`` counts A, B and the drift
        terms). Call inside ``jax.enable_x64(True)``."""
        return cls(*(jnp.asarray(a, dtype=jnp.float64) for a in (pad.tau, pad.y, pad.drift,
                                                                 pad.mask)),
                   jnp.float64(pad.n), jnp.float64(pad.q - 2))

    @classmethod
    def from_arrays(cls, tau, y, drift, pad_to: int | None = None,
                    drift_columns: int | None = None) -> "Samples":
        """From unpadded NumPy ``tau`` [s], ``y`` [m/s²], ``drift`` (n, d) [1], padded with inert
        rows to ``pad_to`` samples and zero columns to ``drift_columns``. Inside x64."""
        tau, y, drift = (np.asarray(a, dtype=float) for a in (tau, y, drift))
        n, d = drift.shape
        n_pad, d_pad = max(pad_to or n, n), max(drift_columns or d, d)
        tp = np.full(n_pad, tau[-1])
        tp[:n] = tau
        yp, qp, mp = np.zeros(n_pad), np.zeros((n_pad, d_pad)), np.zeros(n_pad)
        yp[:n], qp[:n, :d], mp[:n] = y, drift, 1.0
        # device_put, not jnp.asarray / jnp.float64 (each of those compiles an eager op)
        return cls(*jax.device_put((tp, yp, qp, mp, np.float64(n), np.float64(d))))


class Profile(NamedTuple):
    """Result of :func:`profile`: ``beta`` (β [m/s²] of the columns, then d in Q coordinates),
    ``rss`` [(m/s²)²], ``logdet`` = ln det X⊥ᵀX⊥, ``chol`` the Cholesky factor of the
    column-scaled X⊥ᵀX⊥ with the column ``scale``, ``residual`` y − Xβ̂ − Qd̂ [m/s²]."""

    beta: jnp.ndarray
    rss: jnp.ndarray
    logdet: jnp.ndarray
    chol: jnp.ndarray
    scale: jnp.ndarray
    residual: jnp.ndarray


# ----------------------------------------------------------------------------- compositions
@dataclass(frozen=True)
class Sum:
    """Several components (laws, or other sums) in one recording: columns concatenated, θ
    concatenated in component order (each component's fixed ``n_params``)."""

    components: tuple

    def __init__(self, *components):
        if len(components) == 1 and isinstance(components[0], (tuple, list)):
            components = tuple(components[0])
        object.__setattr__(self, "components", tuple(components))

    @property
    def n_params(self) -> int:
        return sum(c.n_params for c in self.components)

    @property
    def n_columns(self) -> int:
        return sum(c.n_columns for c in self.components)

    @property
    def names(self) -> tuple[str, ...]:
        """``"<i>.<name>"`` for component i's parameter."""
        return tuple(f"{i}.{n}" for i, c in enumerate(self.components) for n in c.names)

    def split(self, theta) -> list:
        """θ (..., k) → each component's θ (..., k_i)."""
        out, start = [], 0
        for c in self.components:
            out.append(theta[..., start:start + c.n_params])
            start += c.n_params
        return out

    def columns(self, theta, tau, xp=jnp):
        """The components' columns side by side, shape (..., n, n_columns) [1]."""
        parts = [c.columns(th, tau, xp) for c, th in zip(self.components, self.split(theta))]
        return xp.concatenate(parts, axis=-1)


@dataclass(frozen=True)
class Joint:
    """``model`` on ``n_recordings`` recordings; θ entries ``shared`` (indices into the model's
    θ) are common, the others per recording. Global θ = [shared…, recording 0's others…, …]."""

    model: object
    n_recordings: int
    shared: tuple[int, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "shared", tuple(int(i) for i in self.shared))
        k = self.model.n_params
        if len(set(self.shared)) != len(self.shared) or any(not 0 <= i < k for i in self.shared):
            raise ValueError(f"shared indices {self.shared} not distinct entries of θ (k = {k})")

    @property
    def own(self) -> tuple[int, ...]:
        """Indices of the model's θ that are per recording."""
        return tuple(i for i in range(self.model.n_params) if i not in self.shared)

    @property
    def n_params(self) -> int:
        return len(self.shared) + self.n_recordings * len(self.own)

    @property
    def names(self) -> tuple[str, ...]:
        base = self.model.names
        return (tuple(base[i] for i in self.shared)
                + tuple(f"{base[i]}[{r}]" for r in range(self.n_recordings) for i in self.own))

    def index(self) -> np.ndarray:
        """Map (n_recordings, k) [int]: recording r's θ[j] is global θ[index[r, j]]."""
        k, s, own = self.model.n_params, len(self.shared), self.own
        idx = np.zeros((self.n_recordings, k), dtype=int)
        for r in range(self.n_recordings):
            idx[r, list(self.shared)] = np.arange(s)
            idx[r, list(own)] = s + r * len(own) + np.arange(len(own))
        return idx

    def split(self, theta) -> list:
        """Global θ (..., K) → the per-recording θ (..., k)."""
        return [theta[..., row] for row in self.index()]

    def combine(self, thetas) -> np.ndarray:
        """Per-recording θ (n_recordings, k) → global θ (shared entries from recording 0)."""
        thetas = np.asarray(thetas, dtype=float)
        return np.concatenate([thetas[0, list(self.shared)]]
                              + [thetas[r, list(self.own)] for r in range(self.n_recordings)])


# ----------------------------------------------------------------------------- profile
def _masked_columns(model, theta, tau, mask):
    xo = model.columns(theta, tau)
    return xo if mask is None else xo * mask[:, None]


def profile(model, theta, tau, y, drift, mask=None) -> Profile:
    r"""Exact linear least squares (P2) of ``y`` [m/s²] on the model's columns and the drift at θ.

    The m×m system is formed from Gram products (QᵀX, Qᵀy, XᵀX, Xᵀy): O(n·d·m) per
    evaluation, column-scaled and solved by Cholesky. The RSS comes from the explicit
    residual, not from ‖y⊥‖² − β̂ᵀX⊥ᵀy⊥, which would lose digits when the fit is nearly exact.
    ``mask`` [1] (0 or 1 per sample) switches padded rows off (they carry y = 0 and zero drift
    rows; the mask zeroes their columns).
    """
    xo = _masked_columns(model, theta, tau, mask)
    qx = drift.T @ xo
    qy = drift.T @ y
    gram = xo.T @ xo - qx.T @ qx
    rhs = xo.T @ y - qx.T @ qy
    scale = jnp.sqrt(jnp.diag(gram))
    chol = jnp.linalg.cholesky(gram / jnp.outer(scale, scale))
    beta_osc = jsl.cho_solve((chol, True), rhs / scale) / scale
    logdet = 2.0 * jnp.sum(jnp.log(jnp.diag(chol))) + 2.0 * jnp.sum(jnp.log(scale))
    beta_drift = qy - qx @ beta_osc
    resid = y - xo @ beta_osc - drift @ beta_drift
    return Profile(jnp.concatenate([beta_osc, beta_drift]), jnp.sum(resid * resid), logdet,
                   chol, scale, resid)


def conditional_covariance(prof: Profile) -> jnp.ndarray:
    """(X⊥ᵀX⊥)⁻¹ [1/column²] from a :class:`Profile`; times s² it is the covariance of β | θ."""
    m = prof.scale.shape[0]
    return jsl.cho_solve((prof.chol, True), jnp.eye(m)) / jnp.outer(prof.scale, prof.scale)


def predict(model, phi, tau, drift, mask=None):
    """Model values X(θ)·β + Q·d [m/s²] for φ = (θ, β, d) (the full nonlinear model)."""
    k, m = model.n_params, model.n_columns
    xo = _masked_columns(model, phi[:k], tau, mask)
    return xo @ phi[k:k + m] + drift @ phi[k + m:]


def _dof(model, samples: Samples):
    return samples.n - (samples.n_drift + model.n_columns)


def log_marginal(model, theta, samples: Samples, temper=1.0):
    """temper·ℓ(θ) of (P3) [1]; −inf where the profile is undefined (singular, RSS ≤ 0)."""
    return marginal_and_amplitudes(model, theta, samples, temper)[0]


def marginal_and_amplitudes(model, theta, samples: Samples, temper=1.0):
    r"""temper·ℓ(θ) of (P3) and the conditional posterior of the amplitudes β given θ:

        β | θ, y ~ N(β̂, s²/temper·(X⊥ᵀX⊥)⁻¹),   s² = RSS/(n − q)

    (a Student-t with n − q degrees of freedom; Gaussian for n − q ≫ 1). Returns
    ``(ll, beta_hat (m,), cov (m, m))``; ll is −inf where undefined.
    """
    prof = profile(model, theta, samples.tau, samples.y, samples.drift, samples.mask)
    dof = _dof(model, samples)
    ll = temper * (-0.5 * prof.logdet - 0.5 * dof * jnp.log(prof.rss))
    ll = jnp.where(jnp.isfinite(ll), ll, -jnp.inf)
    cov = (prof.rss / dof / temper) * conditional_covariance(prof)
    return ll, prof.beta[:model.n_columns], cov


def joint_log_marginal(joint: Joint, theta, samples: Sequence[Samples], temper=1.0):
    """Σ_r temper_r·ℓ_r(θ_r) over the recordings of ``joint`` (each (P3), own β, d, σ) [1];
    ``temper`` a scalar or one per recording."""
    if len(samples) != joint.n_recordings:
        raise ValueError(f"{len(samples)} recordings for a joint model of {joint.n_recordings}")
    tempers = (list(temper) if isinstance(temper, (list, tuple, np.ndarray))
               else [temper] * joint.n_recordings)
    return sum(log_marginal(joint.model, th, s, t)
               for th, s, t in zip(joint.split(theta), samples, tempers))
