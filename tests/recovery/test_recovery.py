"""Recovery on simulated phone recordings with known truth, through the CLI and the CSV files.

Each scenario is written as a phyphox CSV (cycling through the three dialects) with jitter,
bias drift, quantisation, tilt, a hand-held start and noise, then analysed by
``dampfit analyze``. The acceptance rule is the core issue's: the posterior median of c within
5 % and of k within 1 % of the truth where the noise allows, otherwise the truth inside
``[q05 − 2·sd, q95 + 2·sd]``. The default run covers a few scenarios; ``-m slow`` runs the grid.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit.cli import main

DIALECTS = ("comma", "tab", "semicolon")
ACCEL_AMPLITUDE = 4.0  # [m/s²] initial acceleration amplitude, typical of a phone on a spring


def scenario(f_n: float, zeta: float, fs: float, noise: float, seed: int) -> sim.SimulationConfig:
    """A phone-like free decay at ``f_n`` [Hz], ``zeta``, ``fs`` [Hz], ``noise`` [µg/√Hz]."""
    rng = np.random.default_rng(seed)
    p = zeta * 2 * np.pi * f_n
    decay = min(120.0, max(12.0 / f_n, 4.0 / p))
    handheld = float(rng.uniform(1.5, 4.0))
    return sim.from_modal(
        mass=float(rng.uniform(0.2, 6.0)), f_n=f_n, zeta=zeta,
        u0=ACCEL_AMPLITUDE / (2 * np.pi * f_n) ** 2,
        duration=handheld + decay + 1.0, sample_rate=fs, jitter=0.07, gaps=2,
        noise_density=noise, bias=tuple(rng.normal(0, 0.05, 3)), drift=0.01,
        quantization=0.0012, tilt_deg=float(rng.uniform(0, 25)),
        azimuth_deg=float(rng.uniform(0, 360)), main_axis=str(rng.choice(["x", "y", "z"])),
        gravity=bool(rng.integers(2)), handheld=handheld, seed=seed,
    )


def check(tmp_path, cfg: sim.SimulationConfig, dialect: str) -> dict:
    """Simulate, write, analyse through the CLI; return the verdict per parameter."""
    rec, truth = sim.recording(cfg)
    csv = tmp_path / f"rec-{dialect}.csv"
    sim.write_phyphox_csv(rec, csv, dialect=dialect)
    out = tmp_path / "out"
    code = main(["analyze", str(csv), "--mass", repr(truth["mass"]), "--out", str(out),
                 "--no-figures", "--quiet", "--seed", "3"])
    assert code == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["diagnostics"]["converged"], s["diagnostics"]["warnings"]
    verdict = {}
    for name, tol in (("c", 0.05), ("k", 0.01)):
        q = s["parameters"][name]
        rel = q["q50"] / truth[name] - 1
        within = abs(rel) <= tol
        noisy = q["sd"] / truth[name] > tol / 2  # the noise does not allow tol
        inside = q["q05"] - 2 * q["sd"] <= truth[name] <= q["q95"] + 2 * q["sd"]
        verdict[name] = (within or (noisy and inside), rel, q["sd"] / truth[name])
    return verdict


FAST = [  # (f_n, zeta, fs, noise)
    (1.72, 0.002, 500, 150),
    (0.7, 0.01, 60, 400),
    (20.0, 0.08, 100, 70),
]


@pytest.mark.parametrize("i,case", list(enumerate(FAST)))
def test_recovery_fast(tmp_path, i, case):
    verdict = check(tmp_path, scenario(*case, seed=100 + i), DIALECTS[i % 3])
    for name, (ok, rel, sd) in verdict.items():
        assert ok, f"{name}: relative error {rel:+.3%}, relative sd {sd:.3%}"


GRID = list(itertools.product((0.7, 2.0, 6.0, 20.0), (0.001, 0.01, 0.08), (60, 200, 500)))


@pytest.mark.slow
@pytest.mark.parametrize("i,case", list(enumerate(GRID)))
def test_recovery_grid(tmp_path, i, case):
    f_n, zeta, fs = case
    noise = (70, 150, 400)[i % 3]
    verdict = check(tmp_path, scenario(f_n, zeta, fs, noise, seed=1000 + i), DIALECTS[i % 3])
    for name, (ok, rel, sd) in verdict.items():
        assert ok, f"{name}: relative error {rel:+.3%}, relative sd {sd:.3%}"
