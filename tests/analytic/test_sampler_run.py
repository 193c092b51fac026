"""The one sampler result (dampfit.inference.sampler_run): the emcee → arviz reshape, the
diagnostics, the stop reasons."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit.inference.sampler_run import SamplerRun, Stop, diagnostics, to_idata, worst


def test_to_idata_puts_each_walker_in_its_own_chain():
    """emcee's flat (draw, walker) order: draw i of walker j is row i·W + j."""
    n_draw, n_walk = 5, 3
    flat = np.array([100 * i + j for i in range(n_draw) for j in range(n_walk)], dtype=float)
    per_mode = np.column_stack([flat, -flat])  # a quantity with a further axis (2 modes)
    idata = to_idata({"x": flat, "y": per_mode}, n_walk, dims={"y": ["mode"]},
                     coords={"mode": [1, 2]}, log_prob=flat.reshape(n_draw, n_walk))
    x = idata.posterior["x"].values
    assert x.shape == (n_walk, n_draw)
    assert x[2, 4] == 402.0  # walker 2, draw 4
    assert idata.posterior["y"].sel(mode=2).values[1, 3] == -301.0
    np.testing.assert_array_equal(idata.sample_stats["lp"].values, x)


def test_diagnostics_list_every_mode_and_worst_skips_nan():
    rng = np.random.default_rng(0)
    n_draw, n_walk = 200, 8
    idata = to_idata({"a": rng.standard_normal(n_draw * n_walk),
                      "m": np.full(n_draw * n_walk, 2.0),  # constant: R-hat NaN
                      "z": rng.standard_normal((n_draw * n_walk, 3))}, n_walk,
                     dims={"z": ["mode"]}, coords={"mode": [1, 2, 3]})
    diag = diagnostics(idata)
    assert isinstance(diag["a"], dict) and len(diag["z"]) == 3
    assert math.isnan(diag["m"]["r_hat"])
    rh, ess = worst(diag)
    assert 0.99 < rh < 1.05 and 200 < ess <= 2000
    assert math.isnan(worst(diag, names=("m",))[0])  # no finite R-hat among the names
    only = diagnostics(idata, scalars_only=True)
    assert set(only) == {"a", "m"}


def _run(stop: Stop) -> SamplerRun:
    return SamplerRun(draws=np.zeros((4, 2, 1)), log_prob=np.zeros((4, 2)), blobs=None,
                      n_steps=10, n_walkers=2, burn_in=2, thin=1, autocorr_time=np.ones(1),
                      acceptance=0.5, stop=stop, stop_reason=stop.value)


@pytest.mark.parametrize("stop", list(Stop))
def test_only_a_converged_run_has_no_remedy(stop):
    run = _run(stop)
    assert run.converged is (stop is Stop.CONVERGED)
    assert bool(run.remedy) is not run.converged
    facts = run.sampling()
    assert facts["converged"] is run.converged and facts["n_walkers"] == 2
    assert facts["wall_time_s"] is None and facts["budget"] is None
