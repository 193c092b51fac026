"""Several modes, the exact parts: Rayleigh α, β (exact for two modes, the misfit stated
for more), the simulator's extra modes (added exactly; one-mode truth unchanged), the matrix
pencil on noise-free modes, the rejection reasons of a K-mode fit, and every validation path of
the options (``max_modes``, ``mode_of_mass``, a recording that cannot support K modes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit import physics_modal as pm
from dampfit import simulate as sim
from dampfit.errors import InputError
from dampfit.inference import modes as M
from dampfit.inference import modes_select as MS
from dampfit.signal import subspace
from tests._support.modes import modal_prep

MASS = 0.8


def test_rayleigh_is_exact_for_two_modes_and_states_its_misfit_for_more():
    w = 2 * np.pi * np.array([3.0, 9.0, 20.0])
    alpha, beta = 0.12, 4e-4
    z = pm.rayleigh_zeta(alpha, beta, w)
    two = pm.rayleigh(w[:2], z[:2])
    assert two["alpha"] == pytest.approx(alpha, rel=1e-12)
    assert two["beta"] == pytest.approx(beta, rel=1e-12) and two["dof"] == 0
    three = pm.rayleigh(w, z * np.array([1.0, 1.3, 1.0]), weights=[1.0, 1.0, 1.0])
    assert three["dof"] == 1 and three["chi2"] > 0 and three["max_relative_misfit"] > 0.05
    rng = np.random.default_rng(0)
    W = w + 1e-3 * rng.standard_normal((2000, 3))
    good = pm.rayleigh_summary(W, z * (1 + 0.05 * rng.standard_normal((2000, 3))))
    assert good["p_value"] > 0.05 and "reproduces all 3" in good["statement"]
    assert good["alpha"]["q05"] < alpha < good["alpha"]["q95"]
    bad = pm.rayleigh_summary(W, z * np.array([1.0, 1.5, 1.0])
                              * (1 + 0.02 * rng.standard_normal((2000, 3))))
    assert bad["p_value"] < 0.01 and "does NOT reproduce" in bad["statement"]
    neg = pm.rayleigh_summary(W[:, :2], np.column_stack([np.full(2000, 0.05),
                                                         np.full(2000, 0.001)])
                              * (1 + 0.01 * rng.standard_normal((2000, 2))))
    assert any("beta is negative" in x for x in neg["warnings"])


@pytest.mark.parametrize("omega, zeta, match", [
    ([10.0], [0.01], "at least two modes"),
    ([10.0, 20.0], [0.01], "same shape"),
    ([10.0, 10.0], [0.01, 0.02], "same frequency"),
    ([10.0, -20.0], [0.01, 0.02], "positive"),
    ([10.0, 20.0], [0.01, float("nan")], "finite"),
])
def test_rayleigh_inputs_are_validated(omega, zeta, match):
    with pytest.raises(InputError, match=match):
        pm.rayleigh(omega, zeta)


def test_rayleigh_weights_are_validated():
    with pytest.raises(InputError, match="2 positive finite numbers"):
        pm.rayleigh([10.0, 20.0], [0.01, 0.02], weights=[1.0, -1.0])
    with pytest.raises(InputError, match=r"shape \(draws ≥ 2, modes\)"):
        pm.rayleigh_summary([10.0, 20.0], [0.01, 0.02])


def test_simulator_adds_modes_exactly_and_one_mode_truth_is_unchanged():
    clean = dict(noise_density=0.0, drift=0.0, quantization=0.0, bias=0.0, duration=6.0,
                 sample_rate=200.0)
    base = sim.from_modal(MASS, 3.0, 0.01, u0=0.01, **clean)
    rec1, truth1 = sim.recording(base)
    assert "modes" not in truth1 and "modes" not in truth1["config"]
    two = sim.from_modal(MASS, 3.0, 0.01, u0=0.01, modes=[(11.0, 0.02, 0.3, 0.7)], **clean)
    rec2, truth2 = sim.recording(two)
    extra = truth2["modes"][1]
    a1 = truth2["modes"][0]["accel_amplitude"]
    assert a1 == pytest.approx(0.01 * truth1["omega_n"] ** 3 / truth1["omega_d"], rel=1e-12)
    assert extra["accel_amplitude"] == pytest.approx(0.3 * a1) and extra["zeta"] == 0.02
    t = rec2.time
    want = 0.3 * a1 * np.exp(-extra["p"] * t) * np.cos(extra["omega_d"] * t + 0.7)
    along = (rec2.accel - rec1.accel) @ np.asarray(truth2["direction"])
    np.testing.assert_allclose(along, want, atol=1e-12)
    assert truth2["config"]["modes"] == [[11.0, 0.02, 0.3, 0.7]]


@pytest.mark.parametrize("modes, match", [
    (3, "list of"), ([(1.0, 0.01, 0.5)], "list of"), ([(200.0, 0.01, 0.5, 0.0)], "Nyquist"),
    ([(5.0, 1.0, 0.5, 0.0)], "0 <= zeta < 1"), ([(5.0, 0.1, -0.5, 0.0)], "ratio >= 0"),
    ([(5.0, 0.1, 0.5, math.inf)], "finite"),
])
def test_simulator_modes_are_validated(modes, match):
    with pytest.raises(InputError, match=match):
        sim.from_modal(MASS, 3.0, 0.01, sample_rate=100.0, modes=modes)


def test_modes_within_one_resolution_cell_are_refused():
    fit = M.ModeFit(2, np.log([0.1, 2 * np.pi * 3.0, 0.1, 2 * np.pi * 3.02]), np.ones(6), 1.0,
                    0.0, np.zeros(5), np.zeros((5, 4)), np.eye(4), 2, True, "converged")
    why = MS.reject_reason(fit, np.array([50.0, 50.0]), (1.0, 10.0), 20.0, 100.0, 4.0)
    assert "within one resolution cell" in why and "0.4" in why
    why = MS.reject_reason(fit, np.array([50.0, 50.0]), (1.0, 10.0), 60.0, 100.0, 4.0)
    assert why == ""
    why = MS.reject_reason(fit, np.array([50.0, 2.0]), (1.0, 10.0), 60.0, 100.0, 4.0)
    assert "not distinguishable from the noise" in why
    why = MS.reject_reason(fit, np.array([50.0, 50.0]), (3.01, 10.0), 60.0, 100.0, 4.0)
    assert "outside the band" in why


def test_matrix_pencil_finds_the_poles_of_noise_free_modes():
    fs = 50.0
    t = np.arange(600) / fs
    x = (1.2 * np.exp(-0.2 * t) * np.cos(2 * np.pi * 2.0 * t + 0.3)
         + 0.4 * np.exp(-0.7 * t) * np.cos(2 * np.pi * 7.5 * t - 1.0))
    res = subspace.matrix_pencil(x, fs, max_order=8, order=4)
    got = sorted((q.f_d, q.p, q.amplitude) for q in res.poles)
    np.testing.assert_allclose([g[0] for g in got], [2.0, 7.5], rtol=1e-8)
    np.testing.assert_allclose([g[1] for g in got], [0.2, 0.7], rtol=1e-6)
    np.testing.assert_allclose([g[2] for g in got], [1.2, 0.4], rtol=1e-6)
    noisy = x + 1e-3 * np.random.default_rng(0).standard_normal(t.size)
    res = subspace.matrix_pencil(noisy, fs, max_order=8)
    assert res.order_mdl >= 4 and res.order_gap == 4 and res.order_floor == 4
    peaks = subspace.spectrum_peaks(noisy, fs, (0.5, 20.0), 2)
    np.testing.assert_allclose(sorted(f for f, _ in peaks), [2.0, 7.5], atol=0.03)
    with pytest.raises(InputError, match="cannot hold a pencil of order 8"):
        subspace.matrix_pencil(x[:20], fs, max_order=8)


@pytest.mark.parametrize("value, match", [
    (0, "from 1 to 8, got 0"), (100, "from 1 to 8, got 100"), (2.5, "whole number"),
    ("3", "whole number"), (True, "whole number"), (None, "whole number"),
    (float("nan"), "whole number")])
def test_max_modes_is_validated(value, match):
    with pytest.raises(InputError, match=match):
        M.check_max_modes(value)


def test_max_modes_accepts_whole_numbers():
    assert M.check_max_modes(4) == 4 and M.check_max_modes(np.int64(2)) == 2
    assert M.check_max_modes(3.0) == 3


@pytest.mark.parametrize("value, match", [
    (0, "out of range: the recording has 2 modes"), (3, "out of range"),
    (1.5, "mode number 1 … 2"), ("1", "mode number"), (True, "mode number")])
def test_mode_of_mass_is_validated(value, match):
    with pytest.raises(InputError, match=match):
        M.check_mode_of_mass(value, 2)


def test_mode_of_mass_maps_to_an_index():
    assert M.check_mode_of_mass(None, 3) is None
    assert M.check_mode_of_mass(2, 3) == 1 and M.check_mode_of_mass(1.0, 1) == 0


def test_a_recording_that_cannot_support_the_modes_says_so():
    prep, _ = modal_prep([], duration=3.0, zeta=0.006, sample_rate=50.0)  # ≈ 85 samples
    with pytest.raises(InputError, match="too few samples per cycle of the highest mode"):
        M.modal_band(prep, (2.0, 48.0))
    with pytest.raises(InputError, match=r"holds only .* cycles of the band's lower edge"):
        M.modal_band(prep, (0.5, 10.0))
    with pytest.raises(InputError, match="not a valid band"):
        M.modal_band(prep, (5.0, 2.0))
    fd = M.modal_fit_data(prep, (2.0, 10.0))
    many = np.log(np.tile([0.1, 2 * np.pi * 3.3], 8))[None]
    with pytest.raises(InputError, match=r"cannot support 8 modes .* too short"):
        M.fit_modes(fd, many)
    with pytest.raises(InputError, match="cannot support 8 modes"):
        MS.select(prep, n_modes=8, band=(2.0, 10.0))


def test_start_grid_varies_the_last_mode_by_rate_factors_and_frequency_cells():
    """Every start row gives GRID_PER_START rows, start by start: the earlier modes as given,
    the last mode's rate × each factor and its frequency shifted by each fraction of 1/T."""
    starts = np.log([[0.1, 2 * np.pi * 3.0, 0.3, 2 * np.pi * 8.0],
                     [0.1, 2 * np.pi * 3.0, 0.2, 2 * np.pi * 12.0]])
    span = 20.0
    grid = M.start_grid(starts, span)
    assert grid.shape == (2 * M.GRID_PER_START, 4)
    for s, block in zip(starts, grid.reshape(2, M.GRID_PER_START, 4)):
        np.testing.assert_array_equal(block[:, :2], np.repeat(s[None, :2], M.GRID_PER_START, 0))
        rates = sorted(set(np.round(np.exp(block[:, 2]) / np.exp(s[2]), 12)))
        np.testing.assert_allclose(rates, sorted(M.GRID_RATE_FACTORS), rtol=1e-12)
        cells = sorted(set(np.round((np.exp(block[:, 3]) - np.exp(s[3])) * span / (2 * np.pi), 9)))
        np.testing.assert_allclose(cells, sorted(M.GRID_CELL_SHIFTS), atol=1e-9)


def test_a_fit_that_finds_no_optimum_is_data_not_an_error():
    failed = M.ModeFit.failed(2, 50, 3, M.NO_OPTIMUM)
    assert not failed.found and not failed.converged and failed.q == 7
    assert failed.residuals.shape == (50,) and np.isnan(failed.theta).all()
    assert "resolution cell" in failed.message


@pytest.mark.parametrize("kw, match", [
    (dict(max_modes=0), "from 1 to 8, got 0"), (dict(max_modes=100), "from 1 to 8, got 100"),
    (dict(max_modes="4"), "whole number"), (dict(n_modes=9), "from 1 to 8, got 9"),
    (dict(max_modes=2, mode_of_mass=3), "out of range: the recording has 2 modes"),
    (dict(mode_of_mass="1"), "mode number"), (dict(mass=-1.0), "mass"),
    (dict(mass_sd=0.1), "mass_sd was given without mass")])
def test_the_modes_stage_refuses_bad_options_before_fitting(kw, match):
    from dampfit import stages
    from dampfit.physics import Mass

    prep, _ = modal_prep(duration=6.0)
    with pytest.raises(InputError, match=match):
        if "mass" in kw or "mass_sd" in kw:  # a mass is checked where it is made: Mass(…)
            kw = {**kw, "mass": Mass(kw.get("mass"), kw.pop("mass_sd", None))}
        stages.modes_stage(prep, **kw)


def test_the_modal_posterior_budget_is_counted_in_steps():
    """modes_posterior.budget: K × STEPS_PER_MODE steps and no wall-time limit unless asked
    for (the same seed gives the same numbers under any load); the basis says so."""
    from dampfit.inference import modes_posterior as MP

    b = MP.budget(3)
    assert b.max_steps == 3 * MP.STEPS_PER_MODE and b.max_seconds is None
    assert b.basis == f"{MP.STEPS_PER_MODE} steps per mode x 3 modes"
    b = MP.budget(2, 90.0)
    assert b.max_steps == 2 * MP.STEPS_PER_MODE and b.max_seconds == 90.0
    assert b.basis == f"{MP.STEPS_PER_MODE} steps per mode x 2 modes; a wall-time limit of 90 s"
    for unknown in (None, float("nan"), -1.0):
        assert MP.budget(2, unknown).max_seconds is None


def _entry(f, zeta):
    return {"f_n": {"q50": f}, "zeta": {"q50": zeta}}


def test_a_close_pair_with_very_different_damping_at_the_dominant_mode_is_explained():
    """The real 40 cm cantilever case (9.358 / 9.405 Hz, ζ 0.0008 / 0.0055, a third mode at
    61.7 Hz): the pair at the one-mode frequency is explained as a possibly split
    amplitude-dependent mode; a genuine close pair of equal damping, a pair away from the
    one-mode frequency, or a pair far apart is not."""
    from dampfit.inference.modes_close import split_pair

    modes = [_entry(9.358, 0.0008), _entry(9.405, 0.0055), _entry(61.7, 0.018)]
    rows = [{"modes": [1, 2], "separation_half_power": 0.8},
            {"modes": [1, 3], "separation_half_power": 200.0},
            {"modes": [2, 3], "separation_half_power": 200.0}]
    (warning,) = split_pair(modes, rows, dominant=1)
    assert warning.startswith("modes 1 and 2 (9.358 and 9.405 Hz, 0.8 half-power")
    assert "6.9x in damping" in warning and "depends on amplitude" in warning
    assert split_pair(modes, rows, dominant=2) == []  # the pair is not at the one-mode f
    equal = [_entry(3.3, 0.006), _entry(3.42, 0.006)]
    assert split_pair(equal, [{"modes": [1, 2], "separation_half_power": 3.0 * 0.99}], 0) == []
    far = [{"modes": [1, 2], "separation_half_power": 3.5}]
    assert split_pair(modes[:2], far, 0) == []
    # the real 30 cm run: damping amplitude-dependent by the one-mode verdict, three "modes"
    # within 3 bandwidths of 16.4 Hz whose zeta are only 2.5x apart
    near = [_entry(16.36, 0.0038), _entry(16.39, 0.0015)]
    rows = [{"modes": [1, 2], "separation_half_power": 2.7}]
    assert split_pair(near, rows, 0) == []
    (warning,) = split_pair(near, rows, 0, amplitude_dependent=True)
    assert "not to be one viscous c" in warning and "split in two" in warning
    assert split_pair(near, far, 0, amplitude_dependent=True) == []


def test_each_mode_s_posterior_stays_in_its_basin():
    """The modal posterior's prior confines mode i to the ln ω nearer its selected frequency
    than its neighbours' (a real phone-spring record's 2.85 Hz walkers otherwise left for
    0.716 Hz, splitting the 0.714 Hz mode): the basins tile the band in order, and a draw
    with a mode outside its own basin has zero prior even though it is ordered."""
    import numpy as np

    from dampfit.inference.modes_posterior import basins
    from dampfit.model import modes as mm

    w = 2 * np.pi * np.array([0.7145, 2.8465])
    lw = basins(w, (0.2, 6.0))
    assert lw.shape == (2, 2)
    assert lw[0, 0] == pytest.approx(np.log(2 * np.pi * 0.2))
    assert lw[1, 1] == pytest.approx(np.log(2 * np.pi * 6.0))
    assert lw[1, 0] == lw[0, 1] == pytest.approx(np.log(np.sqrt(w[0] * w[1])))
    lnp = np.log(0.01)
    at_fit = np.array([lnp, np.log(w[0]), lnp, np.log(w[1])])
    split = np.array([lnp, np.log(w[0]), lnp, np.log(2 * np.pi * 0.716)])  # ordered, but mode 2 left
    assert np.isfinite(mm.log_prior(at_fit, lw[0], lw[1]))
    assert mm.log_prior(split, lw[0], lw[1]) == -np.inf
    assert np.isfinite(mm.log_prior(split, lw[0, 0], lw[1, 1]))  # the band alone allows it


class _Fit:
    """The few fields of a ModeFit that the one-mode check reads."""

    def __init__(self, f, zeta, amp):
        import numpy as np

        fn, z = np.asarray(f, float), np.asarray(zeta, float)
        wn = 2 * np.pi * fn
        self.p, self.omega_d = z * wn, wn * np.sqrt(1 - z**2)
        self.f_d, self.amplitudes, self.n_modes = self.omega_d / (2 * np.pi), np.asarray(amp), fn.size
        self.beta = np.ravel([[a, 0.0] for a in amp])


class _Sel:
    """A ModeSelection's chosen fit on ``span`` [s] of 100 Hz samples: the samples are the
    sum of its components (cosines of the given amplitudes [m/s²]) and white noise of
    0.001 m/s², with a constant drift column."""

    def __init__(self, fit, span):
        import types

        import numpy as np

        from dampfit.model.viscous import drift_basis

        self.chosen, self.n_modes, self.span = types.SimpleNamespace(fit=fit), fit.n_modes, span
        tau = np.arange(0.0, span, 0.01)
        y = sum(a * np.exp(-p * tau) * np.cos(w * tau)
                for a, p, w in zip(fit.amplitudes, fit.p, fit.omega_d))
        y = y + 0.001 * np.random.default_rng(0).standard_normal(tau.size)
        self.fit_data = types.SimpleNamespace(tau=tau, drift_degree=0, y=y,
                                              drift=drift_basis(tau, 0))


@pytest.mark.parametrize("verdict, expect", [("amplitude-dependent", 1), ("misfit", 1),
                                             ("adequate", None), (None, None)])
def test_a_split_one_mode_is_one_mode_only_when_its_damping_changes_with_amplitude(verdict,
                                                                                   expect):
    """The real 30 cm cantilever run 21-08-55 (ζ falls over the record): the evidence's three
    components at 16.356 / 16.388 / 16.394 Hz (ζ 0.0038 / 0.0015 / 0.011) are one mode split
    by the sum of viscous modes — when the one-mode verdict says the damping is amplitude-
    dependent. With a viscous-adequate verdict the same numbers stay three modes (three
    viscous components are not one mode with a drifting frequency)."""
    from dampfit.stages.modes import one_mode_after_all

    sel = _Sel(_Fit([16.3555, 16.3880, 16.3937], [0.00379, 0.00148, 0.01068], [1, 3, 0.5]), 60.0)
    got = one_mode_after_all(sel, 16.388, verdict)
    if expect is None:
        assert got is None
    else:
        reason, entries = got
        assert reason.startswith("one mode") and f"({verdict})" in reason
        assert [round(e["f_d_hz"], 2) for e in entries["split"]] == [16.36, 16.39]


def test_a_split_pair_beside_a_genuine_mode_stays_modes():
    """The 40 cm run 11-41-04: a split pair at 9.36 / 9.41 Hz and the 2nd bending mode at
    61.7 Hz — two genuine modes remain, so nothing is folded (the split pair is a warning)."""
    from dampfit.stages.modes import one_mode_after_all

    sel = _Sel(_Fit([9.3585, 9.4052, 61.715], [0.00078, 0.00555, 0.0176], [0.3, 1, 0.2]), 60.0)
    assert one_mode_after_all(sel, 9.405, "amplitude-dependent") is None


def test_a_component_near_but_not_at_a_multiple_is_not_a_harmonic():
    """Harmonics sit at a whole multiple within a resolution cell: 2.907 Hz beside 0.969 Hz
    (3.000 x) in a 60 s window is one; 2.85 Hz (2.94 x) is not."""
    from dampfit.stages.modes import one_mode_after_all

    harm = _Sel(_Fit([0.96910, 2.90677], [0.0005, 0.0005], [1, 0.05]), 60.0)
    reason, entries = one_mode_after_all(harm, 0.969, None)
    assert entries["harmonics"][0]["multiple"] == 3 and "harmonics" in reason
    other = _Sel(_Fit([0.96910, 2.85], [0.0005, 0.0005], [1, 0.05]), 60.0)
    assert one_mode_after_all(other, 0.969, None) is None


def test_an_uncertain_number_of_modes_says_when_the_other_k_counts_a_harmonic():
    """The real 15° pendulum: the evidence rates K = 2 as likely as K = 1, and K = 2's second
    component is the swing's 3rd harmonic; the warning names it. An alternative whose extra
    component is off the multiple, or too unlikely to be listed, adds nothing."""
    import types

    from dampfit.inference.modes_select import harmonic_alternatives

    one = _Fit([0.97578], [0.0005], [1])
    two = _Fit([0.97578, 2.92782], [0.0005, 0.0005], [1, 0.01])
    results = [types.SimpleNamespace(fit=one), types.SimpleNamespace(fit=two)]
    note = harmonic_alternatives(results, [0.5, 0.5], 1, 39.9)
    assert "K = 2 counts 2.928 Hz = 3 x 0.9758 Hz" in note and "not a mode" in note
    assert harmonic_alternatives(results, [0.995, 0.005], 1, 39.9) == ""
    off = [results[0], types.SimpleNamespace(fit=_Fit([0.97578, 2.85], [0.0005] * 2, [1, 0.01]))]
    assert harmonic_alternatives(off, [0.5, 0.5], 1, 39.9) == ""


@pytest.mark.parametrize("mode_of_mass, warned", [(1, True), (0, False)])
def test_parameters_say_which_mode_they_describe_when_the_mass_is_another_s(
        monkeypatch, mode_of_mass, warned):
    """With the mass given to another mode (``--mode-of-mass``) than the one the one-mode
    analysis found, ``parameters`` (whose c and k use the mass) describe the one-mode
    analysis's mode: the result says so and points to the mass's mode in ``modes``."""
    import math
    import types

    from dampfit import pipeline
    from dampfit.stages.modes import ModesStage

    stage = ModesStage(n_modes=2, evidence={"reason": "2 modes by evidence"},
                       summary={"modes": [{"f_n": 2.0, "mass_mode": mode_of_mass == 0},
                                          {"f_n": 7.0, "mass_mode": mode_of_mass == 1}],
                                "rayleigh": None},
                       posterior=types.SimpleNamespace(mode_of_mass=mode_of_mass, idata=None),
                       dominant=0)
    one_mode = types.SimpleNamespace(p=0.1, omega_d=2 * math.pi * 2.0)
    modes = pipeline.modes_result(stage, one_mode)
    said = [w for w in modes.warnings if "'parameters' describe" in w]
    assert modes.n_modes == 2 and len(modes.modes) == 2
    if warned:
        assert said == ["'parameters' describe the one-mode analysis of the mode at 2 Hz "
                        "(mode 1); the mass belongs to mode 2 (--mode-of-mass), whose c and k are "
                        "in modes[1]"]
    else:
        assert said == []
