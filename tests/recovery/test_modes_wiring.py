"""Several modes through the whole pipeline (issue 21): ``dampfit.analyze`` on a simulated
2-mode decay reports both modes in summary.json (each with f_n, ζ, η, Λ, Q and intervals;
c, k only for the mass's mode), P(K), the Rayleigh α, β, the text table's block per mode,
and posterior.nc's ``modes`` group read back by ``dampfit.load``; on a one-mode recording the
cheap screen stops the modal analysis and ``modes[0]`` is ``parameters``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dampfit
from dampfit import simulate as sim
from dampfit.pipeline import analyze
from dampfit.inference import modes_gate
from dampfit.signal import prepare as pp
from dampfit import stages
from dampfit._options import SamplerSettings

from tests._support.modes import two_mode_recording

MASS = 0.8


@pytest.fixture(scope="module")
def two_modes():
    rec, truth = two_mode_recording(MASS)
    return analyze(rec, mass=MASS, mass_sd=0.01, max_modes=2, min_ess=400, seed=3), truth


@pytest.mark.heavy
def test_both_modes_in_the_summary_with_intervals(two_modes):
    an, truth = two_modes
    s = an.summary()
    assert s["n_modes"] == 2 and len(s["modes"]) == 2
    low, high = s["modes"]
    assert low["f_n"]["q05"] <= 3.3 <= low["f_n"]["q95"]
    assert high["f_n"]["q05"] <= 8.91 <= high["f_n"]["q95"]
    for mode in (low, high):
        for name in ("f_n", "zeta", "eta", "delta", "Q"):
            assert set(mode[name]) >= {"mean", "sd", "q05", "q50", "q95"}
        assert mode["eta"]["q50"] == pytest.approx(2 * mode["zeta"]["q50"], rel=1e-9)
    assert low["mass_mode"] is True and "c" in low and "k" in low
    assert high["mass_mode"] is False and "c" not in high and "k" not in high
    ev = s["modes_evidence"]
    assert ev["screen"]["passed"] is True
    assert [r["n_modes"] for r in ev["evidence"]] == [1, 2]
    assert ev["evidence"][1]["probability"] > 0.9 and ev["evidence"][0]["reason"]
    assert s["rayleigh"]["alpha"]["unit"] == "1/s" and s["rayleigh"]["dof"] == 0
    # the modal posterior ran within its budget, counted in steps only (issue 34)
    run = ev["sampling"]
    assert run["converged"] is True and run["stop_reason"] == "converged"
    assert run["n_steps"] <= run["budget"]["max_steps"] and run["budget"]["max_seconds"] is None
    # the one-mode parameters stay, for the damper's (dominant) mode
    assert s["parameters"]["f_n"]["q50"] == pytest.approx(low["f_n"]["q50"], rel=1e-3)
    # both identified; the mass's mode is the fundamental and carries the headline c, k
    assert low["identified"] is True and high["identified"] is True and s["modes_seen"] == []
    assert low["fundamental"] is True and low["c"] == s["parameters"]["c"]
    assert low["k"] == s["parameters"]["k"] and "c_modal" in low
    # beside each mode's posterior, its least-squares optimum with the Laplace interval
    for mode in (low, high):
        for name in ("f_n", "zeta", "p"):
            ls = mode["least_squares"][name]
            assert ls["q05"] < ls["value"] < ls["q95"]
            assert ls["value"] == pytest.approx(mode[name]["q50"], rel=0.05)
    assert low["least_squares"]["f_n"]["unit"] == "Hz"
    json.dumps(s, allow_nan=False)


def test_a_modal_posterior_that_did_not_converge_points_to_the_least_squares():
    """Stopped long before convergence (60 steps), the modal posterior's quantiles are not to
    be read: the warnings list each mode's least-squares optimum and Laplace interval."""
    rec, _ = two_mode_recording(MASS)
    st = stages.modes_stage(pp.prepare(rec), max_modes=2, n_modes=2,
                            sampler=SamplerSettings(max_steps=60, seed=1))
    out = st.summary
    assert out["sampling"]["posterior_converged"] is False
    (note,) = [w for w in out["warnings"] if "least-squares optima" in w]
    for mode in out["modes"]:
        assert f"f_n {mode['least_squares']['f_n']['value']:.5g} Hz" in note


@pytest.mark.heavy
def test_the_table_has_one_block_per_mode(two_modes):
    an, _ = two_modes
    table = an.report()
    assert "2 modes" in table and "mode 1  (the mass's mode)" in table and "mode 2" in table
    block2 = table[table.index("  mode 2"):]
    assert "Lambda" in block2 and "eta" in block2 and "this mode's viscous c" not in block2
    assert "this mode's viscous c" in table[:table.index("  mode 2")]


@pytest.mark.heavy
def test_save_and_load_give_back_every_mode(two_modes, tmp_path):
    an, _ = two_modes
    out = an.save(tmp_path / "r", figures=False)
    back = dampfit.load(out)
    assert back.summary()["modes"] == an.summary()["modes"]
    assert back.summary()["modes_evidence"] == an.summary()["modes_evidence"]
    assert dict(back.modes_posterior.sizes) == dict(an.modes_posterior.sizes)
    np.testing.assert_array_equal(back.mode_draws("zeta"), an.mode_draws("zeta"))
    np.testing.assert_array_equal(back.mode_draws("c"), an.mode_draws("c"))
    assert back.mode_draws("f_n").shape[1] == 2


def test_several_modes_are_looked_for_by_default(analysed):
    """The default looks for up to 4 modes (issue 21); on a one-mode recording the screen
    settles it: one mode, no selection, and ``modes[0]`` is ``parameters``."""
    s = analysed[0].summary()
    assert s["provenance"]["options"]["max_modes"] == 4
    assert s["n_modes"] == 1 and s["modes_evidence"]["screen"]["passed"] is False
    assert "evidence" not in s["modes_evidence"]
    assert s["modes"][0]["zeta"] == s["parameters"]["zeta"]


@pytest.mark.heavy
def test_a_harmonic_of_the_one_mode_is_not_a_second_mode():
    """A large swing puts whole-multiple harmonics in the acceleration (a real phone pendulum
    at 25 degrees: a component at 3.000 x f1). A damped component at exactly 3 f_d decaying
    at 3 p (the same zeta) is the 3rd harmonic of a nonlinear mode: the evidence may prefer
    two components, but the analysis reports one mode and names the harmonic."""
    cfg = sim.from_modal(MASS, 3.3, 0.006, modes=[(3 * 3.3, 0.006, 0.08, 0.3)], seed=5,
                         u0=0.004, duration=40.0, sample_rate=100.0, noise_density=300.0)
    rec, _ = sim.recording(cfg)
    an = analyze(rec, mass=MASS, mass_sd=0.01, min_ess=300, seed=2)
    s = an.summary()
    ev = s["modes_evidence"]
    assert ev["screen"]["passed"] is True and ev["n_modes"] == 2  # the evidence saw it
    assert s["n_modes"] == 1 and an.modes_posterior is None  # no modal posterior ran
    (h,) = ev["harmonics"]
    assert h["multiple"] == 3 and h["cells"] < 1 and h["f_d_hz"] == pytest.approx(9.9, rel=0.01)
    assert ev["reason"].startswith("one mode") and "harmonic" in ev["reason"]
    assert any("harmonics of a nonlinear oscillation" in w for w in s["diagnostics"]["warnings"])


def test_a_one_mode_recording_is_screened_out(short_paper):
    rec, truth = short_paper
    analysed = analyze(rec, mass=truth["mass"], mass_sd=0.05, seed=1, max_modes=4)
    s = analysed.summary()
    assert s["n_modes"] == 1 and len(s["modes"]) == 1 and s["rayleigh"] is None
    ev = s["modes_evidence"]
    assert ev["screen"]["passed"] is False and ev["reason"].startswith("one mode")
    assert "evidence" not in ev  # no K > 1 was fitted
    mode = s["modes"][0]
    for name in ("f_n", "zeta", "c", "k", "Q", "delta"):
        assert mode[name] == s["parameters"][name]
    assert mode["eta"]["q50"] == pytest.approx(2 * s["parameters"]["zeta"]["q50"])
    assert analysed.modes_posterior is None
    assert analysed.mode_draws("zeta").shape == (analysed.draws("zeta").size, 1)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("preset", ["paper", "phone"])
def test_the_screen_passes_one_mode_presets_and_catches_a_second_mode(preset, seed):
    rec, _ = sim.recording(sim.preset(preset, seed=seed, duration=30.0))
    prep = pp.prepare(rec)
    ls = stages.fit_stages(prep, None).least_squares
    one = modes_gate.screen(prep, ls.p, ls.omega_d)
    assert not one.passed and one.z2 < one.threshold, one.reason
    f0 = ls.omega_d / (2 * np.pi)
    rec, _ = sim.recording(sim.preset(preset, seed=seed, duration=30.0,
                                      modes=[(4.1 * f0, 0.01, 0.03, 0.4)]))
    prep = pp.prepare(rec)
    ls = stages.fit_stages(prep, None).least_squares
    two = modes_gate.screen(prep, ls.p, ls.omega_d)
    assert two.passed and abs(two.f_hz - 4.1 * f0) < 0.05 * f0, two.reason


def test_max_modes_one_skips_the_stage(short_paper):
    rec, _ = short_paper
    an = analyze(rec, max_modes=1, min_ess=200, max_steps=2000)
    s = an.summary()
    assert s["n_modes"] == 1 and s["modes_evidence"]["screen"] is None
    assert "not looked for" in s["modes_evidence"]["reason"]
    assert s["provenance"]["options"]["max_modes"] == 1
