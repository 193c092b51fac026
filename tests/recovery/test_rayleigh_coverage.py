"""Rayleigh α, β of simulated 2-mode decays reproduce the true damping ratios (issue 21, "Done
when: Rayleigh"): on each replicate the 90 % interval of ζ(ω_i) = α/(2ω_i) + β·ω_i/2 from the
posterior draws covers the simulated ζ_i, and α, β lie near the α, β that reproduce the truth.

The default run takes two replicates of the calibration's "two_modes" scenario (ratio 2.7,
ζ 0.002 and 0.05, phone-like noise); the calibration itself (≥ 100 replicates, every scenario,
the columns alpha_covered, beta_covered and rayleigh_zeta_covered) is
``python paper/modes_calibration.py --replicates 100 --scenarios two_modes two_modes_weak
three_modes close_pair`` (paper/modes.md).
"""

from __future__ import annotations

import numpy as np
import pytest

from dampfit import physics_modal as pm
from dampfit import simulate as sim
from dampfit import stages
from dampfit._options import SamplerSettings
from dampfit.signal import prepare as pp

MASS, F1 = 0.8, 3.3  # [kg], [Hz]


def _replicate(rep: int, zetas=(0.006, 0.03), ratio=2.7, amp=0.5, max_modes=3, min_ess=400):
    rng = np.random.default_rng([21, rep])
    cfg = sim.from_modal(MASS, F1, zetas[0], u0=0.004, duration=40.0, sample_rate=100.0,
                         noise_density=300.0, jitter=0.05, seed=int(rng.integers(2**31)),
                         modes=[(ratio * F1, zetas[1], amp, float(rng.uniform(0, 2 * np.pi)))])
    rec, truth = sim.recording(cfg)
    stage = stages.modes_stage(pp.prepare(rec), max_modes=max_modes, mass=MASS,
                               sampler=SamplerSettings(seed=rep, min_ess=min_ess))
    return truth, stage.summary


def _covers(truth, summary):
    modes = sorted(truth["modes"], key=lambda m: m["f_n"])
    w = np.array([m["omega_n"] for m in modes])
    z = np.array([m["zeta"] for m in modes])
    ray = summary["rayleigh"]
    fitted = [q["q05"] <= zt <= q["q95"] for q, zt in zip(ray["zeta_fitted"], z)]
    exact = pm.rayleigh(w, z)
    near = [abs(ray[k]["q50"] - exact[k]) < 4 * ray[k]["sd"] for k in ("alpha", "beta")]
    return fitted, near


@pytest.mark.heavy
def test_rayleigh_intervals_reproduce_the_simulated_zetas():
    """Two replicates (K ≤ 2, ESS 200: the quick version of the slow test below)."""
    covered, total = 0, 0
    for rep in range(2):
        truth, summary = _replicate(rep, max_modes=2, min_ess=200)
        assert summary["n_modes"] == 2, summary["modes_evidence"]
        assert summary["rayleigh"]["dof"] == 0  # two modes: exact
        fitted, near = _covers(truth, summary)
        assert all(near), (rep, summary["rayleigh"])
        covered += sum(fitted)
        total += len(fitted)
    # 90 % intervals: at most one of the 4 (mode, replicate) pairs may miss
    assert covered >= total - 1, (covered, total)


@pytest.mark.slow
def test_rayleigh_coverage_over_twenty_replicates():
    """20 replicates: the ζ(ω_i) intervals cover the truth in ≥ 75 % of (mode, replicate)
    pairs (nominal 90 %; the binomial 1 % lower bound for 40 pairs is about 75 %)."""
    hits = []
    for rep in range(3, 23):
        truth, summary = _replicate(rep)
        if summary["n_modes"] == 2:
            hits += _covers(truth, summary)[0]
    assert len(hits) >= 36 and np.mean(hits) >= 0.75, (np.mean(hits), len(hits))
