"""The structured decays of :mod:`dampfit.simulate.structure` hold the structure they are
named for (issue 34): a friction decay loses 4F_c/k per cycle, a clipped one saturates, the
modulation puts peaks at f₂ ± f₁, the drift moves the frequency."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from dampfit.errors import InputError
from dampfit.simulate import structure as S


def _peak_near(rec, f, width=0.3):
    fs = 1.0 / np.median(np.diff(rec.time))
    freqs, pxx = signal.periodogram(rec.accel[:, 0], fs, window="boxcar")
    near = (freqs > f - width) & (freqs < f + width)
    off = (freqs > f + 3 * width) & (freqs < f + 6 * width)
    return pxx[near].max() / np.median(pxx[off])


def test_coulomb_friction_loses_four_fc_over_k_per_cycle_and_sticks():
    rec, truth = S.nonlinear(2.0, F_c=0.02, mass=0.5, u0=0.03, noise_density=1e-3)
    k = 0.5 * (2 * np.pi * 2.0) ** 2
    a, t = rec.accel[:, 0], rec.time - 0.5
    peaks = [np.abs(a[(t >= n / 2.0) & (t < (n + 1) / 2.0)]).max() for n in range(4)]
    # acceleration amplitude ω²·(A − F_c/k) + F_c/m falls by ω²·4F_c/k per cycle
    assert np.diff(peaks) == pytest.approx([-(2 * np.pi * 2.0) ** 2 * 4 * 0.02 / k] * 3, rel=0.02)
    assert np.abs(a[t > 20]).max() < 1e-3 and truth["kind"] == "coulomb"


def test_clipping_saturates_and_modulation_makes_sidebands():
    rec, _ = S.clipped(level=0.5, noise_density=1e-3)
    a = rec.accel[:, 0]
    assert np.sum(np.isclose(np.abs(a), np.abs(a).max(), rtol=1e-6)) > 50
    mod, truth = S.modulated()
    assert [n["kind"] for n in truth["not_modes"]] == ["sideband", "sideband"]
    for f in (50.4 - 7.85, 50.4 + 7.85):
        assert _peak_near(mod, f) > 20


def test_the_drift_moves_the_frequency_and_bad_options_are_one_line():
    rec, _ = S.drifting(drift=-0.05, duration=40.0, noise_density=1e-3)
    a, t = rec.accel[:, 0], rec.time - 0.5
    crossings = t[1:][np.diff(np.sign(a)) != 0]
    early = 1 / (2 * np.median(np.diff(crossings[(crossings > 0.5) & (crossings < 5)])))
    late = 1 / (2 * np.median(np.diff(crossings[(crossings > 35) & (crossings < 40)])))
    assert late / early == pytest.approx(1 - 0.05 * 37.5 / 40 + 0.05 * 2.5 / 40, abs=0.005)
    with pytest.raises(InputError, match="exactly one"):
        S.nonlinear(F_c=0.1, c2=0.1)
