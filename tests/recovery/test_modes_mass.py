"""The mass belongs to the fundamental the recording was released in (issue 34): the
component at the one-mode analysis's frequency, never the one with the largest acceleration
(∝ ω² × displacement, which favours a higher mode)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit import stages
from dampfit.inference import modes_posterior as MP

from tests._support.modes import modal_prep


class _Stop(Exception):
    pass


@pytest.mark.heavy
def test_the_mass_s_mode_is_the_fundamental_not_the_largest_acceleration(monkeypatch):
    """A 3.3 Hz release with an 8.91 Hz second mode at 3x its acceleration (0.4x its
    displacement; a cantilever's second bending mode): the modal posterior is asked for the
    mass on the 3.3 Hz component."""
    prep, truth = modal_prep(modes=[(8.91, 0.012, 3.0, 0.5)])
    w = 2 * math.pi * 3.3
    one_mode = (0.006 * w, w * math.sqrt(1 - 0.006**2))
    asked = {}

    def sample(sel, **kw):
        asked.update(kw, sel=sel)
        raise _Stop

    monkeypatch.setattr(MP, "sample", sample)
    with pytest.raises(_Stop):
        stages.modes_stage(prep, max_modes=2, mass=0.8, one_mode=one_mode)
    fit = asked["sel"].chosen.fit
    assert fit.n_modes == 2
    accel = np.asarray(fit.amplitudes)
    assert float(fit.f_d[int(np.argmax(accel))]) == pytest.approx(8.91, rel=0.01)  # the trap
    i = asked["mode_of_mass"] - 1
    assert float(fit.f_d[i]) == pytest.approx(3.3, rel=0.01)
