"""Free-decay window: it stops at a catch, rattle or contact (an abrupt envelope drop)."""

from __future__ import annotations

import numpy as np
import pytest

from dampfit.signal import prepare as pp
from dampfit.io.recording import Recording

FS, F, ZETA = 400.0, 5.0, 0.005


def decay(drop_at: float | None = None, factor: float = 3.0, zeta: float = ZETA, seed: int = 0,
          noise: float = 0.01) -> Recording:
    """A 20 s, 5 Hz free decay released at 1 s whose amplitude falls ``factor``× at ``drop_at``."""
    t = np.arange(0.0, 20.0, 1 / FS)
    w = 2 * np.pi * F
    tau = np.clip(t - 1.0, 0.0, None)
    a = 5.0 * np.exp(-zeta * w * tau) * np.cos(w * np.sqrt(1 - zeta**2) * tau)
    a[t < 1.0] = 0.0
    if drop_at is not None:
        a[t > drop_at] /= factor
    a += np.random.default_rng(seed).normal(0.0, noise, t.size)
    return Recording(time=t, accel=a[:, None], axes=("z",))


def test_window_ends_before_a_rattle():
    prep = pp.prepare(decay(drop_at=7.7))
    assert 6.5 < prep.window[1] < 7.7
    note = next(n for n in prep.notes if "abrupt envelope drop" in n)
    assert "7.7" in note and "catch, rattle or contact" in note


def test_a_users_window_across_the_drop_is_kept_and_warned():
    prep = pp.prepare(decay(drop_at=7.7), window=(2.0, 15.0))
    assert prep.window == (2.0, 15.0)
    assert any("abrupt envelope drop at 7.7" in w for w in prep.warnings)


@pytest.mark.parametrize("zeta", [0.001, 0.01, 0.05, 0.1])
def test_smooth_decays_are_not_cut(zeta):
    """Heavy damping loses 3× in well under two cycles at ζ = 0.1: the trend, not a catch."""
    for seed in range(2):
        prep = pp.prepare(decay(zeta=zeta, seed=seed))
        assert not any("abrupt" in n for n in prep.notes), prep.notes


def test_amplitude_dependent_decay_is_not_a_catch():
    """Quadratic drag: ζ falls ≈ 5× along the decay, smoothly; no drop is reported."""
    from tests.reference_sim import noisy_recording, reference_decay

    t = np.arange(0.0, 30.0, 1 / 200.0)
    m, k = 1.0, (2 * np.pi * 3.0) ** 2
    _, _, acc = reference_decay(t, m, k, 0.05, c=0.05, c2=8.0)
    rec = noisy_recording(t, acc, 0.005, seed=1, lead=1.0)
    assert not any("abrupt" in n for n in pp.prepare(rec).notes)
