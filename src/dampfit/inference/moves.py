r"""emcee's kernel-density proposal without scipy's general-purpose KDE object: :class:`KDEMove`.

The proposal is emcee's :class:`emcee.moves.KDEMove` exactly — an independence proposal
drawn from a Gaussian kernel density estimate of the complementary half-ensemble
:math:`\{c_j\}_{j=1}^{n}` with equal weights and Scott's bandwidth,

.. math::

    \hat q(x) = \frac1n \sum_{j=1}^{n} \mathcal N\!\left(x;\; c_j,\; h^2 \hat\Sigma\right),
    \qquad h = n^{-1/(d+4)},

(:math:`\hat\Sigma` the unbiased sample covariance of the :math:`c_j`, :math:`d` the
dimension; Scott 1992, eq. 6.42), with the Metropolis–Hastings correction
:math:`\ln\hat q(x) - \ln\hat q(x')` for a walker at :math:`x` proposed to move to
:math:`x'`. emcee builds a :class:`scipy.stats.gaussian_kde` for this at every step and asks
it for draws and two log densities; for the 32 walkers of a half-ensemble in 2–8 dimensions
that object's set-up and checks cost ≈ 0.44 ms a step, four times the arithmetic. Here the
same quantities are computed directly:

* the draws use the walkers' random state in the same order and the same way as
  ``gaussian_kde.resample`` (one ``multivariate_normal`` of the kernel covariance, then one
  ``choice`` of the centres), so a sampler's chain is emcee's to rounding;
* the log density is a log-sum-exp over the centres of the whitened squared distances
  :math:`\lVert L^{-1}(x - c_j)\rVert^2` (:math:`L` the Cholesky factor of
  :math:`h^2\hat\Sigma`), equal to scipy's to ~1e-14 (``tests/analytic/test_moves.py``).

Measured on the paper recording: ≈ 0.1 s less per posterior (0.15 → 0.05 s for the proposal
of a 200-step run), the draws and their statistics unchanged.
"""

from __future__ import annotations

import emcee
import numpy as np

__all__ = ["KDEMove"]


class KDEMove(emcee.moves.RedBlueMove):
    """emcee's :class:`emcee.moves.KDEMove` (Scott's bandwidth, equal weights) computed
    directly (module docstring)."""

    def get_proposal(self, s, c, random):
        """Proposals for the walkers ``s`` (m, d) from the KDE of the complementary ensemble
        ``c`` (a list of (n_i, d) arrays); returns (proposals (m, d), log q(s) − log q(proposal))
        as emcee's :meth:`emcee.moves.RedBlueMove.get_proposal`."""
        centres = np.concatenate(c, axis=0)
        n, d = centres.shape
        weights = np.full(n, 1.0 / n)
        deviation = centres - centres.mean(axis=0)
        cov = np.atleast_2d(deviation.T @ deviation / (n - 1)) * n ** (-2.0 / (d + 4))
        chol = np.linalg.cholesky(cov)  # LinAlgError on a degenerate ensemble, as scipy's
        m = len(s)
        jitter = random.multivariate_normal(np.zeros(d), cov, size=m)
        proposal = centres[random.choice(n, size=m, p=weights)] + jitter
        whiten = np.linalg.inv(chol)
        log_norm = -0.5 * d * np.log(2.0 * np.pi) - np.log(np.diag(chol)).sum() - np.log(n)
        z = (np.concatenate([s, proposal])[:, None, :] - centres[None, :, :]) @ whiten.T
        a = -0.5 * np.einsum("mnd,mnd->mn", z, z)
        peak = a.max(axis=1)
        log_q = peak + np.log(np.exp(a - peak[:, None]).sum(axis=1)) + log_norm
        return proposal, log_q[:m] - log_q[m:]
