"""A wrong axis is said (issue 34): when the chosen axis carries under 20 % of the
oscillation's energy at f₀, the warning names the axis that carries it and suggests
--axis auto; a fair axis or auto says nothing."""

from __future__ import annotations

import pytest

from dampfit import simulate as sim
from dampfit.signal import prepare as pp


@pytest.fixture(scope="module")
def tilted():
    cfg = sim.from_modal(0.3, 2.0, 0.01, u0=0.02, duration=30.0, sample_rate=100.0,
                         noise_density=100.0, main_axis="z", tilt_deg=15.0, seed=4)
    return sim.recording(cfg)[0]


def test_a_cross_axis_is_said_with_the_axis_that_carries_the_oscillation(tilted):
    prep = pp.prepare(tilted, axis="x")
    (w,) = [w for w in prep.warnings if "of the oscillation's energy" in w]
    assert w.startswith("axis x carries only") and "axis z carries" in w
    assert "--axis auto" in w


@pytest.mark.parametrize("axis", ["z", "auto"])
def test_the_right_axis_or_auto_is_not_warned(tilted, axis):
    prep = pp.prepare(tilted, axis=axis)
    assert not [w for w in prep.warnings if "of the oscillation's energy" in w]
