"""Shared fixtures: short simulated recordings and one analysed result per session."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from dampfit import analysis
from dampfit import simulate as sim

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"


@pytest.fixture(scope="session")
def short_paper():
    """A 20 s version of the paper preset: (recording, truth)."""
    return sim.simulate(sim.preset("paper", duration=20.0, seed=7))


@pytest.fixture(scope="session")
def analysed(short_paper):
    """The short paper recording analysed with a known mass ± 0.05 kg."""
    rec, truth = short_paper
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return analysis.analyze(rec, mass=truth["mass"], mass_sd=0.05, seed=1), truth
