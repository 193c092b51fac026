"""dampfit's kernel-density proposal is emcee's KDEMove: same draws, same Metropolis–Hastings
correction (scipy's gaussian_kde), same chains — only cheaper."""

import emcee
import numpy as np
import pytest
from scipy.stats import gaussian_kde

from dampfit.inference.moves import KDEMove


@pytest.mark.parametrize("n, d", [(32, 2), (32, 6), (17, 3)])
def test_the_proposal_and_its_correction_are_emcee_s(n, d):
    rng = np.random.default_rng(n * 10 + d)
    mix = rng.normal(size=(d, d))
    c = [rng.normal(size=(n // 2, d)) @ mix, rng.normal(size=(n - n // 2, d)) @ mix]
    s = rng.normal(size=(20, d)) @ mix
    q, f = KDEMove().get_proposal(s, c, np.random.RandomState(7))
    q_ref, f_ref = emcee.moves.KDEMove().get_proposal(s, c, np.random.RandomState(7))
    assert q.shape == (20, d) and f.shape == (20,)
    np.testing.assert_allclose(q, q_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-10)
    kde = gaussian_kde(np.concatenate(c).T)  # the density itself, not only the ratio
    np.testing.assert_allclose(f, kde.logpdf(s.T) - kde.logpdf(q.T), rtol=0, atol=1e-10)


def test_a_sampler_with_it_runs_emcee_s_chain():
    cov = np.array([[1.0, 0.8], [0.8, 2.0]])
    prec = np.linalg.inv(cov)

    def log_prob(x):
        return -0.5 * np.einsum("wi,ij,wj->w", x, prec, x)

    start = np.random.default_rng(3).normal(size=(32, 2))

    def chain(move):
        sampler = emcee.EnsembleSampler(32, 2, log_prob, vectorize=True, moves=[move])
        sampler._random.seed(11)
        sampler.run_mcmc(start, 400, progress=False)
        return sampler.get_chain()

    ours = chain(KDEMove())
    np.testing.assert_allclose(ours, chain(emcee.moves.KDEMove()), rtol=0, atol=1e-9)
    draws = ours[100:].reshape(-1, 2)  # and it samples the target
    np.testing.assert_allclose(np.cov(draws.T), cov, atol=0.15)
    np.testing.assert_allclose(draws.mean(axis=0), 0.0, atol=0.1)
