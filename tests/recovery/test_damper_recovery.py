"""End to end: a simulated power-law (α = 0.5), Coulomb and quadratic free decay through
:func:`dampfit.analyze` — the recommended damper (summary.json's ``damper``) is the law that
was simulated, and its coefficients' 90 % intervals cover the truth.

The decays are solved exactly (``tests/_support/reference_sim``: DOP853 half-cycle by
half-cycle; :mod:`dampfit.simulate` has only the viscous law) and short (20–40 s at 100 Hz,
2 % white noise); one mode is looked for.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import dampfit
from tests._support.reference_sim import noisy_recording, reference_decay

M, F, U0, FS = 0.5, 3.0, 0.02, 100.0  # [kg], [Hz], [m], [Hz]
K = M * (2 * math.pi * F) ** 2
CASES = {  # law → (duration [s], coefficients of the reference ODE)
    "power": (40.0, dict(c_alpha=0.02, alpha=0.5)),
    "coulomb": (20.0, dict(c=0.01, F_c=0.02)),
    "quadratic": (40.0, dict(c=0.06, c2=0.3)),
}


@pytest.mark.slow
@pytest.mark.parametrize("law", list(CASES))
def test_the_recommended_damper_is_the_simulated_law(law, tmp_path):
    duration, truth = CASES[law]
    t = np.arange(0, duration, 1 / FS)
    accel = reference_decay(t, M, K, U0, **truth)[2]
    rec = noisy_recording(t, accel, 0.02 * np.max(np.abs(accel)), seed=1, lead=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(rec, mass=M, max_modes=1, seed=2)
    d = an.damper
    assert d["status"] == "recommended" and d["verdict"] == "amplitude-dependent"
    assert d["law"] == law and d["posterior"]["method"] == "emcee"
    assert set(d["coefficients"]) == set(truth)
    for name, value in truth.items():
        q = d["coefficients"][name]
        assert q["q05"] <= value <= q["q95"], (name, q, value)
    assert d["k"]["q05"] <= K <= d["k"]["q95"] or d["k"]["q50"] == pytest.approx(K, rel=1e-3)
    # the damper and its draws come back from the folder as they were
    back = dampfit.load(an.save(tmp_path / law, figures=False))
    assert back.damper == d
    draws = back.damper_draws
    assert draws.attrs["law"] == law and draws.sizes["draw"] == d["draws"]["n"]
    for name in truth:
        assert float(np.median(draws[name])) == pytest.approx(d["coefficients"][name]["q50"],
                                                              rel=0.02)  # a thinned subset
