"""Several modes, recovered from simulated decays: the number of modes by evidence (a 2-mode
phone-like decay, the false-mode check on a one-mode decay) and a close pair at three
half-power bandwidths."""

from __future__ import annotations

import numpy as np
import pytest

from dampfit.inference import modes_close
from dampfit.inference import modes_select as MS
from tests._support.modes import modal_prep


@pytest.fixture(scope="module")
def two_modes():
    prep, truth = modal_prep([(3.3 * 2.7, 0.012, 0.2, 0.5)], jitter=0.05, quantization=0.0024)
    return prep, truth, MS.select(prep, max_modes=3)


def test_two_mode_decay_is_recovered(two_modes):
    """A 2-mode phone-like decay (jitter, quantisation): K = 2 by a clear margin, both modes'
    frequencies and damping ratios near the truth, ordered by frequency, every other K with
    its reason."""
    prep, truth, sel = two_modes
    assert sel.n_modes == 2
    assert sel.probabilities[1] > 0.99
    fit = sel.chosen.fit
    for i, mode in enumerate(truth["modes"]):
        assert fit.f_d[i] == pytest.approx(mode["f_d"], rel=2e-3)
        zeta = fit.p[i] / np.hypot(fit.p[i], fit.omega_d[i])
        assert zeta == pytest.approx(mode["zeta"], rel=0.15)
    reasons = sel.reasons()
    assert set(reasons) == {1, 3} and all(reasons.values())
    assert "ln Z lower" in reasons[1]
    s = sel.summary()
    assert s["n_modes"] == 2 and [r["n_modes"] for r in s["evidence"]] == [1, 2, 3]
    assert sum(r["probability"] for r in s["evidence"]) == pytest.approx(1.0)
    # the subspace estimate saw both modes among its poles
    fs = sorted(q.f_d for q in sel.pencil.poles[:4])
    assert any(abs(f - truth["modes"][1]["f_d"]) < 0.05 for f in fs)


def test_one_mode_decay_is_called_one_mode():
    prep, _ = modal_prep([], jitter=0.05, quantization=0.0024, drift=0.01, seed=11)
    sel = MS.select(prep, max_modes=3)
    assert sel.n_modes == 1
    assert sel.probabilities[0] > 0.9
    assert set(sel.reasons()) == {2, 3}


def test_close_pair_at_three_half_power_bandwidths_is_resolved_and_reported():
    """Two modes 3 half-power bandwidths apart beat; the modal window runs on through the beats
    and both modes are found; the pair's separation is reported in bandwidths and cells."""
    bw = 2 * 0.006 * 3.3
    prep, truth = modal_prep([(3.3 + 3 * bw, 0.006, 0.5, 1.0)], seed=5)
    sel = MS.select(prep, max_modes=2)
    assert sel.n_modes == 2
    assert any("beating" in n for n in sel.notes)
    fit = sel.chosen.fit
    rows, _ = modes_close.pairs(fit.p, fit.omega_d, fit.beta[:4], sel.fit_data.tau,
                                sel.fit_data.drift_degree)
    assert rows[0]["separation_half_power"] == pytest.approx(3.0, rel=0.25)
    assert rows[0]["separation_resolution"] > 2


def test_evidence_is_the_chain_of_bayes_factors_at_each_new_modes_noise(two_modes):
    """(MS5): ln Z_2 = ln Z_1(r(f_1)) + ln Z_2(r(f_new)) − ln Z_1(r(f_new)), r measured on the
    residuals of the largest converged fit; P(K) follows from the ln Z of the admissible K."""
    _, _, sel = two_modes
    fd, n = sel.fit_data, sel.fit_data.tau.size
    fit1, fit2 = sel.results[0].fit, sel.results[1].fit
    ref = [r.fit for r in sel.results if r.fit is not None and r.fit.converged][-1]

    def r_at(f):
        return MS.local_ratio(ref.residuals, fd, float(f), ref.q + 2 * ref.n_modes)

    def lnz(fit, r):
        return MS.evidence(fit, n, temper=1 / r, band=sel.band, a_max=sel.a_max)[0]

    new = fit2.f_d[int(np.argmax(np.min(np.abs(fit2.f_d[:, None] - fit1.f_d[None]), axis=1)))]
    want1 = lnz(fit1, r_at(fit1.f_d[0]))
    want2 = want1 + lnz(fit2, r_at(new)) - lnz(fit1, r_at(new))
    assert sel.results[0].ln_evidence == pytest.approx(want1, rel=1e-12)
    assert sel.results[1].ln_evidence == pytest.approx(want2, rel=1e-12)
    assert sel.results[1].psd_ratio == pytest.approx(r_at(new), rel=1e-12)
    ok = [not r.reason for r in sel.results]
    lz = np.array([r.ln_evidence if good else -np.inf for r, good in zip(sel.results, ok)])
    np.testing.assert_allclose(sel.probabilities, np.exp(lz - lz.max()) / np.exp(lz - lz.max()).sum())


def test_least_squares_intervals_are_the_delta_method_of_the_laplace_covariance(two_modes):
    """The K-mode least squares' 90 % intervals (studies' ``modes_least_squares`` and the
    calibration's baseline): by frequency, centred in the logs on the optimum, their half-width
    1.645·sd from the Laplace covariance carried through ln p, ln f_n, ln ζ (θ) by numerical
    derivatives here (their coverage is measured in paper/modes_calibration.py)."""
    from dampfit import physics

    _, _, sel = two_modes
    res = sel.chosen
    got = res.laplace_intervals()
    fit = res.fit
    order = np.argsort(fit.omega_d)
    assert [m["omega_d"] for m in got] == list(fit.omega_d[order])
    for m, i in zip(got, order):
        theta = np.log([fit.p[i], fit.omega_d[i]])
        cov = res.cov[2 * i:2 * i + 2, 2 * i:2 * i + 2]
        for q in ("p", "f_n", "zeta"):
            def ln_q(t):
                return np.log(float(physics.quantities(np.exp(t[0]), np.exp(t[1]))[q]))
            h = 1e-6
            grad = np.array([(ln_q(theta + h * e) - ln_q(theta - h * e)) / (2 * h)
                             for e in np.eye(2)])
            sd = np.sqrt(grad @ cov @ grad)
            v, lo, hi = m[q]
            assert v == pytest.approx(float(physics.quantities(fit.p[i], fit.omega_d[i])[q]))
            assert np.log(hi / v) == pytest.approx(1.6448536269514722 * sd, rel=1e-5)
            assert np.log(v / lo) == pytest.approx(np.log(hi / v), rel=1e-9)
    empty = MS.KResult(3, None, float("nan"), np.array([]), np.empty((0, 0)), "not tried")
    with pytest.raises(ValueError, match="no 3-mode least-squares fit: not tried"):
        empty.laplace_intervals()
