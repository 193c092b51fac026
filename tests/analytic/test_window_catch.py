"""The window and the several-mode model (issue 34): a catch ends the window even where a
second mode rings on and the fundamental's decay after the catch is short; a one-sample spike
is masked, never a window end."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit.io.recording import Recording
from dampfit.signal import prepare as pp

FS, T, TC = 500.0, 20.0, 7.7  # [Hz], [s], the catch [s]


def caught(hold1: float, hold2: float, seed: int = 0) -> Recording:
    """A cantilever-like decay: 4.27 Hz (ζ 0.004) and its second bending mode at 6.45 f₁
    (ζ 0.006, half the acceleration), caught at 7.7 s: after it each mode decays at
    ``hold1``, ``hold2`` [1/s]; mostly along z."""
    t = np.arange(0.0, T, 1 / FS)

    def mode(f, z, a, held):
        w = 2 * np.pi * f
        env = np.where(t < TC, np.exp(-z * w * t), np.exp(-z * w * TC - held * (t - TC)))
        return a * env * np.cos(w * np.sqrt(1 - z * z) * t)

    y = mode(4.27, 0.004, 2.0, hold1) + mode(6.45 * 4.27, 0.006, 1.0, hold2)
    y += 0.002 * np.random.default_rng(seed).standard_normal(t.size)
    return Recording(time=t, accel=np.column_stack([0.05 * y, 0.02 * y, y]), axes=("x", "y", "z"),
                     format="simulated")


@pytest.mark.parametrize("hold1, hold2", [(20.0, 0.0), (5.0, 0.0), (3.0, 1.0)])
def test_a_catch_ends_the_window_before_it(hold1, hold2):
    """A hand that stops the mass within a few cycles (5/s, 3/s) while the second mode rings
    on: the fundamental reaches its noise floor soon after, and a drop measured only against
    a centred trend (half of it after the catch) was missed — the window ran to 8.9–9.9 s."""
    prep = pp.prepare(caught(hold1, hold2))
    assert prep.f0 == pytest.approx(4.27, rel=1e-3)
    assert 6.5 < prep.window[1] < TC + 0.05  # within a few samples of the smoothed catch
    assert "abrupt envelope drop" in prep.window_end_reason


@pytest.mark.parametrize("fs, f, size", [(20.0, 1.0, 20.0), (20.0, 1.0, 100.0),
                                         (50.0, 1.2, 100.0)])
def test_a_one_sample_spike_is_masked_not_a_window_end(fs, f, size):
    """A logger's one-sample glitch (``size`` × the oscillation) 20 s into a 100 s decay of
    ≈ 100 cycles: masked, and the window runs on through it."""
    cfg = sim.from_modal(0.5, f, 0.003, u0=0.05, duration=100.0, sample_rate=fs,
                         noise_density=200.0, seed=1)
    rec = sim.recording(cfg)[0]
    a = np.array(rec.accel, dtype=float)
    i = int(np.searchsorted(rec.time, 20.0))
    a[i] += size * np.abs(a[i - 50:i]).max() * np.sign(a[i] + 1e-12)
    prep = pp.prepare(dataclasses.replace(rec, accel=a))
    assert prep.window[1] > 90.0 and "impact" not in prep.window_end_reason
    assert any("do not end the window" in n for n in prep.notes)
