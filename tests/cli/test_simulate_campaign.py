"""Simulated campaigns (issue 12): :func:`dampfit.simulate.campaign` and
``dampfit simulate --tests N``."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from dampfit import simulate as sim
from dampfit.cli import main
from dampfit.errors import InputError
from tests._support.hostile import one_error_line

#: Short and quick: 4 s at 100 Hz of the paper's system.
SHORT = dict(duration=4.0, sample_rate=100.0, handheld=0.0)


def base(**kw):
    return sim.preset("paper", **{**SHORT, **kw})


# -- library ---------------------------------------------------------------------------------


def test_each_test_is_the_base_system_with_its_own_mass_c_and_u0():
    cfg = base()
    dm, u0 = [0.0, 1.3, 5.3], [0.01, 0.02, 0.04]
    recs, truth = sim.campaign(cfg, n_tests=3, c_spread=0.2, added_mass=dm, amplitudes=u0,
                               seed=11)
    assert len(recs) == 3 and truth["n_tests"] == 3 and truth["design"] == "added-mass"
    assert (truth["c"], truth["k"], truth["mass"], truth["c_spread"]) == (cfg.c, cfg.k, cfg.mass, 0.2)
    assert truth["added_mass"] == dm and truth["u0_tests"] == u0
    assert truth["mass_tests"] == pytest.approx([cfg.mass + d for d in dm])
    for i, (rec, t) in enumerate(zip(recs, truth["tests"])):
        assert t["k"] == cfg.k and t["mass"] == pytest.approx(cfg.mass + dm[i])
        assert t["c"] == truth["c_tests"][i] and t["u0"] == u0[i]
        # the added-mass line: 1/ω_n² = (m0 + Δm)/k
        assert 1 / t["omega_n"] ** 2 == pytest.approx((cfg.mass + dm[i]) / cfg.k, rel=1e-12)
        assert truth["f_n_tests"][i] == t["f_n"] and truth["zeta_tests"][i] == t["zeta"]
        line = truth["line"]
        assert 1 / t["omega_n"] ** 2 == pytest.approx(line["intercept"] + line["slope"] * dm[i])
        # a test is exactly simulate() of its own config
        again, _ = sim.recording(sim.SimulationConfig(**t["config"]))
        np.testing.assert_array_equal(rec.accel, again.accel)
        np.testing.assert_array_equal(rec.time, again.time)
        assert f"test {i + 1} of 3" in rec.notes[-1]
    # independent noise per test
    assert len(set(truth["seeds"])) == 3
    assert not np.allclose(recs[0].accel[:50] - recs[0].accel[:50].mean(),
                           recs[1].accel[:50] - recs[1].accel[:50].mean())


def test_truth_is_json_safe_and_round_trips(tmp_path):
    _, truth = sim.campaign(base(), n_tests=2, c_spread=0.1, seed=1)
    path = sim.write_truth(truth, tmp_path / "t.json")
    assert json.loads(path.read_text()) == truth
    assert truth["design"] == "hierarchical" and truth["added_mass"] == [0.0, 0.0]
    assert truth["tau_p"] == 0.1 and truth["tau_omega"] == 0.0
    lo, hi = truth["predictive_c"]
    assert lo == pytest.approx(truth["c"] * math.exp(-1.6448536 * 0.1))
    assert hi == pytest.approx(truth["c"] * math.exp(1.6448536 * 0.1))
    assert truth["predictive_zeta"][0] == pytest.approx(truth["zeta"] * lo / truth["c"])


def test_zero_spread_gives_identical_c_and_default_u0():
    cfg = base()
    _, truth = sim.campaign(cfg, n_tests=4, seed=2)
    assert truth["c_tests"] == [cfg.c] * 4 and truth["u0_tests"] == [cfg.u0] * 4
    assert truth["predictive_c"] == [cfg.c, cfg.c]


def test_c_is_log_normal_around_base_c_with_the_given_spread():
    cfg = sim.preset("paper", duration=0.5, sample_rate=50.0, handheld=0.0)
    _, truth = sim.campaign(cfg, n_tests=100, c_spread=0.3, seed=5)
    ln = np.log(np.asarray(truth["c_tests"]) / cfg.c)
    assert abs(ln.mean()) < 3 * 0.3 / 10  # median base.c: 3 standard errors
    assert ln.std(ddof=1) == pytest.approx(0.3, rel=0.21)
    lo, hi = truth["predictive_c"]
    inside = np.mean((np.asarray(truth["c_tests"]) >= lo) & (np.asarray(truth["c_tests"]) <= hi))
    assert 0.8 <= inside <= 0.97


def test_seeds_are_deterministic_and_spread_only_scales_the_draws():
    a, ta = sim.campaign(base(), n_tests=3, c_spread=0.1, seed=7)
    b, tb = sim.campaign(base(), n_tests=3, c_spread=0.1, seed=7)
    assert ta == tb
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.accel, y.accel)
    _, tc = sim.campaign(base(), n_tests=3, c_spread=0.2, seed=7)
    assert tc["seeds"] == ta["seeds"]  # the noise does not depend on the spread
    np.testing.assert_allclose(np.log(np.asarray(tc["c_tests"]) / 0.2),
                               2 * np.log(np.asarray(ta["c_tests"]) / 0.2), rtol=1e-12)
    _, td = sim.campaign(base(), n_tests=3, c_spread=0.1, seed=8)
    assert td["seeds"] != ta["seeds"] and td["c_tests"] != ta["c_tests"]
    _, te = sim.campaign(base(seed=99), n_tests=3, c_spread=0.1, seed=7)
    assert te["seeds"] == ta["seeds"]  # base.seed is ignored


def test_added_mass_sd_perturbs_the_simulated_masses_but_not_the_bare_one_or_the_noise():
    dm = [0.0, 1.0, 3.0, 5.0]
    a, ta = sim.campaign(base(), n_tests=4, added_mass=dm, seed=5)
    b, tb = sim.campaign(base(), n_tests=4, added_mass=dm, added_mass_sd=0.05, seed=5)
    assert ta["added_mass_true"] == dm and ta["added_mass_sd"] == 0.0
    assert tb["added_mass"] == dm and tb["added_mass_sd"] == 0.05
    err = np.asarray(tb["added_mass_true"]) - dm
    assert err[0] == 0.0 and np.all(err[1:] != 0.0) and np.all(np.abs(err[1:]) < 5 * 0.05)
    m0 = base().mass
    np.testing.assert_allclose(tb["mass_tests"], m0 + np.asarray(tb["added_mass_true"]))
    assert tb["seeds"] == ta["seeds"] and tb["c_tests"] == ta["c_tests"]
    _, tc = sim.campaign(base(), n_tests=4, added_mass=dm, added_mass_sd=0.10, seed=5)
    np.testing.assert_allclose(np.asarray(tc["added_mass_true"]) - dm, 2 * err, rtol=1e-12)
    with pytest.raises(InputError, match="added_mass_sd needs added masses"):
        sim.campaign(base(), n_tests=2, added_mass_sd=0.1, seed=5)
    with pytest.raises(InputError, match="is negative; give a smaller added_mass_sd"):
        sim.campaign(base(), n_tests=4, added_mass=[0.0, 1e-6, 2e-6, 3e-6], added_mass_sd=1.0,
                     seed=5)


def test_amplitudes_set_the_release_displacement():
    cfg = base(noise_density=0.0, drift=0.0, quantization=0.0, bias=0.0, tilt_deg=0.0, jitter=0.0)
    recs, truth = sim.campaign(cfg, n_tests=2, amplitudes=[0.01, 0.05], seed=3)
    for rec, u0, m in zip(recs, [0.01, 0.05], truth["mass_tests"]):
        assert rec.axis("y")[0] == pytest.approx(-cfg.k / m * u0, rel=1e-9)


@pytest.mark.parametrize("kw, match", [
    (dict(n_tests=0), "n_tests must be an integer from 1 to 100"),
    (dict(n_tests=2.0), "n_tests must be an integer"),
    (dict(n_tests=True), "n_tests must be an integer"),
    (dict(n_tests=101), "n_tests must be an integer from 1 to 100"),
    (dict(n_tests=2, c_spread=-0.1), "c_spread must be a number in"),
    (dict(n_tests=2, c_spread=float("nan")), "c_spread must be a number in"),
    (dict(n_tests=2, c_spread=2.5), "c_spread must be a number in"),
    (dict(n_tests=2, c_spread="0.1"), "c_spread must be a number in"),
    (dict(n_tests=3, added_mass=[0.0, 1.0]), "added_mass gives 2 value.s. for 3 test"),
    (dict(n_tests=2, added_mass=[0.0, -1.0]), r"added_mass\[1\] must be a number in \[0"),
    (dict(n_tests=2, added_mass=[0.0, float("inf")]), r"added_mass\[1\] must be a number"),
    (dict(n_tests=2, added_mass=[0.0, 2e6]), r"added_mass\[1\] must be a number"),
    (dict(n_tests=2, added_mass="01"), "added_mass must be a sequence"),
    (dict(n_tests=2, added_mass=1.0), "added_mass must be a sequence"),
    (dict(n_tests=2, amplitudes=[0.01]), "amplitudes gives 1 value.s. for 2 test"),
    (dict(n_tests=2, amplitudes=[0.01, 200.0]), r"amplitudes\[1\] must be a number in \[0, 100\] m"),
    (dict(n_tests=2, amplitudes=[0.01, None]), r"amplitudes\[1\] must be a number"),
    (dict(n_tests=2, added_mass=[0.0, 1.0], added_mass_sd=-0.1), "added_mass_sd must be a"),
    (dict(n_tests=2, added_mass=[0.0, 1.0], added_mass_sd=float("nan")), "added_mass_sd must"),
    (dict(n_tests=2, seed=-1), "seed must be a non-negative integer"),
    (dict(n_tests=2, seed=1.5), "seed must be a non-negative integer"),
])
def test_bad_input_is_one_line(kw, match):
    with pytest.raises(InputError, match=match) as info:
        sim.campaign(base(), **kw)
    assert "\n" not in str(info.value)


def test_refusals_of_the_system():
    with pytest.raises(InputError, match="campaign needs a SimulationConfig"):
        sim.campaign({"mass": 1.0}, n_tests=2)
    crit = 2 * math.sqrt(base().k * base().mass)
    with pytest.raises(InputError, match="test [0-9]+: c = .* drawn with c_spread 2 is overdamped"):
        sim.campaign(base(c=0.9 * crit), n_tests=10, c_spread=2.0, seed=0)
    with pytest.raises(InputError, match="at most 5e.07 are simulated"):
        sim.campaign(sim.preset("paper", duration=1000.0, sample_rate=1000.0), n_tests=60)
    with pytest.raises(InputError, match="beyond the limit of 1e.06 kg"):
        sim.campaign(base(), n_tests=2, added_mass=[0.0, 1e6])
    # limits are those of one recording (here: Nyquist)
    with pytest.raises(InputError, match="Nyquist"):
        sim.campaign(sim.from_modal(1.0, 60.0, 0.01, duration=4.0, sample_rate=100.0), n_tests=2)


# -- command line ------------------------------------------------------------------------------


SHORT_ARGS = ["--duration", "4", "--sample-rate", "100", "--handheld", "0"]


def test_cli_writes_n_recordings_and_one_truth(tmp_path, capsys):
    out = tmp_path / "rec.csv"
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), "--tests", "3", "--c-spread", "0.2",
                 "--added-mass", "0", "1", "2", "--seed", "4"]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["rec-1.csv", "rec-2.csv", "rec-3.csv", "rec.truth.json"]
    truth = json.loads((tmp_path / "rec.truth.json").read_text())
    _, expected = sim.campaign(sim.preset("paper", duration=4.0, sample_rate=100.0, handheld=0.0),
                               n_tests=3, c_spread=0.2, added_mass=[0.0, 1.0, 2.0], seed=4)
    assert truth == json.loads(json.dumps(expected))
    text = capsys.readouterr().out
    assert "rec-1.csv" in text and "3 tests" in text and text.count("  test ") == 3
    from dampfit import read

    rec = read(tmp_path / "rec-2.csv")
    assert rec.n_samples == 400


def test_cli_added_mass_alone_sets_the_number_of_tests(tmp_path):
    out = tmp_path / "m.csv"
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), "--added-mass", "0", "2.65",
                 "--amplitudes", "0.02", "0.03"]) == 0
    truth = json.loads((tmp_path / "m.truth.json").read_text())
    assert truth["n_tests"] == 2 and truth["added_mass"] == [0.0, 2.65]
    assert truth["u0_tests"] == [0.02, 0.03] and truth["c_spread"] == 0.0


def test_cli_without_tests_is_one_recording_as_before(tmp_path):
    out = tmp_path / "one.csv"
    assert main(["simulate", *SHORT_ARGS, "--out", str(out)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.csv", "one.truth.json"]
    truth = json.loads((tmp_path / "one.truth.json").read_text())
    _, expected = sim.recording(sim.preset("paper", duration=4.0, sample_rate=100.0, handheld=0.0))
    assert truth == json.loads(json.dumps(expected))


@pytest.mark.parametrize("extra, match", [
    (["--tests", "1"], "--tests: must be an integer from 2 to 100"),
    (["--tests", "101"], "--tests: must be an integer from 2 to 100"),
    (["--tests", "3", "--added-mass", "0", "1"], "--added-mass gives 2 value.s. for 3 tests"),
    (["--tests", "2", "--amplitudes", "0.01"], "--amplitudes gives 1 value.s. for 2 tests"),
    (["--added-mass", "0"], "--added-mass gives 1 value: a campaign needs at least 2 tests"),
    (["--c-spread", "0.1"], "--c-spread needs a campaign"),
    (["--tests", "2", "--added-mass-sd", "0.1"], "--added-mass-sd needs --added-mass"),
    (["--added-mass", "0", "1", "--added-mass-sd", "-1"], "--added-mass-sd: must be a standard"),
    (["--tests", "2", "--c-spread", "-1"], "--c-spread: must be a spread in"),
    (["--tests", "2", "--c-spread", "nan"], "--c-spread: must be a spread in"),
    (["--tests", "2", "--added-mass", "0", "-1"], "--added-mass: must be a mass in"),
    (["--tests", "2", "--amplitudes", "0.01", "1e3"], "--amplitudes: must be a displacement"),
    (["--tests", "2", "--zeta", "0.9", "--c-spread", "2"], "overdamped"),
])
def test_cli_errors_are_one_line_and_write_nothing(tmp_path, capsys, extra, match):
    out = tmp_path / "rec.csv"
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), *extra]) == 2
    assert re.search(match, one_error_line(capsys))
    assert list(tmp_path.iterdir()) == []


def test_cli_refuses_to_overwrite_any_file_of_the_campaign(tmp_path, capsys):
    (tmp_path / "rec-2.csv").write_text("mine")
    out = tmp_path / "rec.csv"
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), "--tests", "3"]) == 2
    assert "rec-2.csv exists; use --force" in one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec-2.csv"]
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), "--tests", "3", "--force"]) == 0
    assert (tmp_path / "rec-2.csv").read_text().startswith('"Time (s)"')


def test_cli_failed_rename_leaves_nothing_and_restores_old_files(tmp_path, capsys, monkeypatch):
    import os

    out = tmp_path / "rec.csv"
    (tmp_path / "rec-1.csv").write_text("old 1")
    real_replace = os.replace
    published = []

    def flaky(src, dst):  # the staged files are written; publishing the third one fails
        if Path(dst) == tmp_path / "rec-3.csv":
            raise OSError(28, "No space left on device")
        if Path(dst).parent == tmp_path:
            published.append(Path(dst).name)
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    assert main(["simulate", *SHORT_ARGS, "--out", str(out), "--tests", "3", "--force"]) == 2
    assert published == ["rec-1.csv", "rec-2.csv", "rec-1.csv"]  # rec-1 put back
    assert "No space left on device; nothing was written" in one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec-1.csv"]
    assert (tmp_path / "rec-1.csv").read_text() == "old 1"


def test_cli_campaign_then_truth_matches_the_files(tmp_path):
    """The truth's per-test masses give each file's dominant frequency (what an analysis sees)."""
    out = tmp_path / "r.csv"
    assert main(["simulate", "--duration", "30", "--sample-rate", "100", "--handheld", "0",
                 "--out", str(out), "--added-mass", "0", "5.3", "--seed", "1"]) == 0
    truth = json.loads((tmp_path / "r.truth.json").read_text())
    from dampfit import read

    for i, f_n in enumerate(truth["f_n_tests"], 1):
        rec = read(tmp_path / f"r-{i}.csv")
        y = rec.axis("y") - rec.axis("y").mean()
        spec = np.abs(np.fft.rfft(y * np.hanning(y.size)))
        f = np.fft.rfftfreq(y.size, 1 / 100.0)
        assert f[np.argmax(spec)] == pytest.approx(f_n, abs=2 / 30)
    assert truth["f_n_tests"][1] == pytest.approx(truth["f_n_tests"][0] / math.sqrt(2))

