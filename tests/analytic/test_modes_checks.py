"""Is each component a mode (issue 34)? The checks of :mod:`dampfit.inference.modes_checks` on
constructed components, and the mass's mode: the fundamental, never the largest acceleration."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

from dampfit.inference import modes_checks as MC
from dampfit.inference import modes_posterior as MP

SPAN = 60.0  # [s]: a resolution cell is 1/60 Hz


def _row(f, zeta, *, f_width=None, z_lo=None, z_hi=None, r_hat=1.001):
    """A per-mode posterior summary: f_n and ζ medians with their 90 % intervals."""
    fw = f * 1e-4 if f_width is None else f_width
    lo, hi = (0.9 * zeta if z_lo is None else z_lo), (1.1 * zeta if z_hi is None else z_hi)
    return {"f_n": {"q05": f - fw / 2, "q50": f, "q95": f + fw / 2, "r_hat": r_hat},
            "zeta": {"q05": lo, "q50": zeta, "q95": hi, "r_hat": r_hat}}


def _check(f, zeta, amp, rows=None, **kw):
    f, zeta = np.asarray(f, float), np.asarray(zeta, float)
    p = 2 * np.pi * f * zeta
    rows = rows or [_row(a, b) for a, b in zip(f, zeta)]
    lnw = np.log(2 * np.pi * f)
    band = (0.5 * f.min(), 2.0 * f.max())
    basins = np.exp(MP.basins(np.exp(lnw), band)) / (2 * np.pi)
    return MC.check_components(rows, f_d=f, p=p, amplitudes=amp, span=SPAN, basins_hz=basins,
                               **kw)


def test_a_harmonic_decaying_at_n_sigma_is_not_a_mode():
    """A clipped or dragged decay at 5 Hz puts a component at exactly 10 Hz decaying at 2 p
    (its amplitude goes as A²): not a mode, with the reason."""
    got = _check([5.0, 10.0], [0.004, 0.004], [1.0, 0.05])
    assert list(got) == [1] and got[1][0] == "harmonic" and "2 x 5 Hz" in got[1][1]


def test_a_real_mode_at_twice_the_fundamental_with_its_own_slower_decay_is_a_mode():
    """The same 10 Hz component decaying 5x slower than any harmonic could (p₂ = 0.4 p₁ < 2 p₁)
    is a mode of its own, at the multiple by chance."""
    assert _check([5.0, 10.0], [0.004, 0.0004], [1.0, 0.05]) == {}


def test_a_component_one_cell_off_the_multiple_is_not_a_harmonic():
    assert _check([5.0, 10.0 + 3 / SPAN], [0.004, 0.004], [1.0, 0.05]) == {}


def test_sidebands_of_two_modulating_modes_are_not_modes():
    """A real second mode at 50.4 Hz modulated by the 7.85 Hz fundamental: components at
    f₂ ∓ f₁ decaying at p₁ + p₂ are sidebands; the two modes stay."""
    f1, f2 = 7.85, 50.4
    p1, p2 = 2 * math.pi * f1 * 0.002, 2 * math.pi * f2 * 0.003
    f = [f1, f2 - f1, f2, f2 + f1]
    p = [p1, p1 + p2, p2, p1 + p2]
    zeta = [pi / (2 * math.pi * fi) for pi, fi in zip(p, f)]
    got = _check(f, zeta, [1.0, 0.05, 0.3, 0.05])
    assert sorted(got) == [1, 3] and {v[0] for v in got.values()} == {"sideband"}
    assert "50.4 Hz - 1 x 7.85 Hz" in got[1][1]


def test_a_third_mode_at_a_sum_frequency_that_decays_slowly_is_a_mode():
    f1, f2 = 7.85, 50.4
    f = [f1, f2, f2 + f1]
    zeta = [0.002, 0.003, 0.0002]
    assert _check(f, zeta, [1.0, 0.3, 0.05]) == {}


@pytest.mark.parametrize("row, kind", [
    (dict(f_width=3.8), "basin"),                       # 2.8 [1.5, 5.3] Hz: fills its basin
    (dict(f_width=1.2), "basin"),                       # over a quarter of it
    (dict(z_lo=1e-5, z_hi=0.15), "zeta"),               # ζ 0.00 [0.00, 0.15]: reaches 0
    (dict(z_lo=0.05, z_hi=0.195), "zeta"),              # at the prior's edge
    (dict(r_hat=1.2), "not converged"),
])
def test_a_component_the_posterior_does_not_identify_is_not_a_mode(row, kind):
    rows = [_row(0.714, 0.003), _row(2.8, 0.01, **row)]
    got = _check([0.714, 2.8], [0.003, 0.01], [1.0, 0.1], rows=rows)
    assert list(got) == [1] and got[1][0] == kind


def test_the_fundamental_is_kept_and_a_split_partner_is_not_a_mode():
    """Under an amplitude-dependent verdict a partner beside the fundamental is its split
    (or an unresolved pair); the fundamental itself is never dropped, even with a poor
    posterior: the one-mode analysis identified it."""
    rows = [_row(4.15, 0.01, f_width=5.0), _row(4.248, 0.004)]
    got = _check([4.15, 4.248], [0.01, 0.004], [0.5, 1.0], rows=rows, keep=1, split=[0])
    assert list(got) == [0] and got[0][0] == "split" and "unresolved pair" in got[0][1]
    assert 1 not in _check([4.15, 4.248], [0.01, 0.004], [0.5, 1.0],
                           rows=[_row(4.15, 0.01), _row(4.248, 0.004, f_width=5.0)], keep=1)


def test_the_mass_s_default_mode_is_the_largest_displacement_not_acceleration():
    """A second mode at 8.91 Hz with 3x the fundamental's acceleration (a cantilever's
    second bending mode under a phone) has 0.4x its displacement: the mass belongs to the
    3.3 Hz fundamental. Chosen by acceleration energy it would be the 8.91 Hz one."""
    f = np.array([3.3, 8.91])
    zeta = np.array([0.006, 0.012])
    w = 2 * np.pi * f
    p = zeta * w
    fit = types.SimpleNamespace(amplitudes=np.array([1.0, 3.0]), p=p,
                                omega_d=w * np.sqrt(1 - zeta**2))
    fd = types.SimpleNamespace(tau=np.arange(0.0, 40.0, 0.01), lowpass_sos=None)
    accel = [a**2 * np.sum(np.exp(-2 * r * fd.tau)) for a, r in zip(fit.amplitudes, p)]
    assert int(np.argmax(accel)) == 1  # the acceleration would pick the higher mode
    assert MP.mode_of_mass_default(fit, fd) == 0


def test_only_a_close_pair_is_flagged_not_one_hundreds_of_cells_apart():
    """Three modes in 60 s: 5.00 and 5.02 Hz (2 half-power bandwidths, 1.2 cells) and 27.6 Hz,
    over a thousand cells away: only the close pair is flagged, whatever the third does."""
    from dampfit.inference import modes_close

    t = np.arange(0.0, SPAN, 0.005)
    f = np.array([5.0, 5.02, 27.6])
    zeta = np.array([0.001, 0.001, 0.002])
    w = 2 * np.pi * f
    rows, warns = modes_close.pairs(zeta * w, w * np.sqrt(1 - zeta**2),
                                    [1.0, 0.0, 0.8, 0.3, 0.2, 0.1], t)
    flagged = {tuple(r["modes"]): r["flagged"] for r in rows}
    assert flagged == {(1, 2): True, (1, 3): False, (2, 3): False}
    assert len(warns) == 1 and "modes 1 and 2" in warns[0]
    far = [r for r in rows if r["modes"] == [1, 3]][0]
    assert far["separation_resolution"] > 100 and far["inflation_f_n"] < 1.25


def test_a_disagreement_on_the_fundamental_is_stated_and_the_mass_row_is_the_headline():
    """The modal ζ of the fundamental excludes the one-mode value: stated (never resolved
    silently); the mass's row carries the one-mode c and k, the modal ones as *_modal."""
    from dampfit import stages

    w = 2 * math.pi * 7.85
    ls = types.SimpleNamespace(p=0.004 * w, omega_d=w * math.sqrt(1 - 0.004**2))
    row = {"index": 2, "mass_mode": True, "fundamental": True,
           "f_n": {"q05": 7.849, "q50": 7.85, "q95": 7.851},
           "zeta": {"q05": 0.005, "q50": 0.006, "q95": 0.007},
           "c": {"q50": 1.39}, "k": {"q50": 23077.0}}
    (said,) = stages.modes_disagreement([{"index": 1}, row], 1, ls)
    assert "disagree on the fundamental (mode 2)" in said and "zeta 0.004" in said
    assert "modes[1].c_modal" in said
    agree = dict(row, zeta={"q05": 0.0035, "q50": 0.004, "q95": 0.0045})
    assert stages.modes_disagreement([agree], 1, ls) == []
    params = {"c": {"q50": 0.212}, "k": {"q50": 570.0}, "u0": None}
    (out,) = stages.one_mode_values([row], params)
    assert out["c"] == {"q50": 0.212} and out["c_modal"] == {"q50": 1.39}
    assert out["k"] == {"q50": 570.0} and out["mass_values"].startswith("one-mode")
    other = dict(row, fundamental=False)
    assert stages.one_mode_values([other], params)[0]["c"] == {"q50": 1.39}


def _pair_fit(tau, y, drift, w1, w2, p0):
    """The two-component least squares (scipy, variable projection) from ω₁, ω₂ [rad/s]."""
    from scipy.optimize import least_squares

    def resid(th):
        cols = []
        for k in range(2):
            e = np.exp(-math.exp(min(th[2 * k], 5.0)) * tau)
            cols += [e * np.cos(th[2 * k + 1] * tau), e * np.sin(th[2 * k + 1] * tau)]
        x = np.column_stack(cols + list(drift.T))
        return y - x @ np.linalg.lstsq(x, y, rcond=None)[0]

    th = least_squares(resid, [math.log(p0), w1, math.log(p0), w2], method="lm").x
    return np.exp(th[[0, 2]]), th[[1, 3]]


def _decay(kind, seed=1):
    """20 s at 50 Hz of a 3 Hz decay (ζ 0.004): drifting −2 % over the record, or a real
    pair 1 % apart (3.3 resolution cells, beating) at amplitude ratio 0.8; SNR ≈ 100."""
    from dampfit.model.viscous import drift_basis

    T, w = 20.0, 2 * math.pi * 3.0
    tau = np.arange(0.0, T, 1 / 50.0)
    p = 0.004 * w
    if kind == "drift":
        y, w1, w2 = np.exp(-p * tau) * np.cos(w * (tau - 0.02 * tau**2 / (2 * T))), \
            0.995 * w, 0.985 * w
    else:
        y, w1, w2 = np.exp(-p * tau) * (np.cos(w * tau) + 0.8 * np.cos(1.01 * w * tau + 0.4)), \
            w, 1.01 * w
    y = y + 0.01 * np.random.default_rng(seed).standard_normal(tau.size)
    drift = drift_basis(tau, 2)
    return tau, y, drift, *_pair_fit(tau, y, drift, w1, w2, p)


def test_a_drifting_fundamental_split_in_two_is_one_mode_with_its_drift():
    """A 3 Hz mode drifting −2 % over 20 s is fitted by two viscous components 0.03 Hz apart;
    one mode with a linear chirp fits as well (BIC), and the chirp found is the drift put in:
    −0.06 Hz over the record, from 3.00 Hz."""
    tau, y, drift, p, w = _decay("drift")
    got = MC.drift_split(tau, y, drift, p, w, 0, 1)
    assert got is not None and got["delta_bic"] < 0
    assert got["chirp_hz_per_s"] * 20.0 == pytest.approx(-0.06, rel=0.05)
    assert got["f_start_hz"] == pytest.approx(3.0, abs=0.003)


def test_a_beating_pair_of_real_modes_is_not_a_drift():
    """Two real modes 1 % apart beat: no single decay with a drifting frequency follows that
    envelope, so the pair stays two components."""
    tau, y, drift, p, w = _decay("pair")
    assert MC.drift_split(tau, y, drift, p, w, 0, 1) is None


def _one_mode_rss(tau, y, drift, w, p):
    """RSS [(m/s²)²] of the best single viscous decay (scipy, from ω [rad/s], p [1/s])."""
    from scipy.optimize import least_squares

    def resid(th):
        e = np.exp(-math.exp(min(th[0], 5.0)) * tau)
        x = np.column_stack([e * np.cos(th[1] * tau), e * np.sin(th[1] * tau)] + list(drift.T))
        return y - x @ np.linalg.lstsq(x, y, rcond=None)[0]

    sol = least_squares(resid, [math.log(p), w], method="lm")
    return float(sol.fun @ sol.fun), math.exp(sol.x[0]), float(sol.x[1])


def _close(kind, seed=2):
    """16 s at 100 Hz of a 20 Hz decay (ζ 0.002, SNR ≈ 200): two modes 0.1 % apart at
    amplitude ratio 0.8 (0.32 resolution cells), or one mode whose envelope is the sum of a
    fast and a slow exponential at one frequency (what amplitude-dependent damping looks
    like), each with its noise RSS (what an exact damping law leaves)."""
    from dampfit.model.viscous import drift_basis

    tau = np.arange(0.0, 16.0, 0.01)
    w, p = 2 * math.pi * 20.0, 0.002 * 2 * math.pi * 20.0
    if kind == "pair":
        clean = np.exp(-p * tau) * (np.cos(w * tau) + 0.8 * np.cos(1.001 * w * tau + 0.4))
    else:
        clean = (np.exp(-3 * p * tau) + 0.8 * np.exp(-p * tau)) * np.cos(w * tau)
    noise = 0.005 * np.random.default_rng(seed).standard_normal(tau.size)
    return tau, clean + noise, drift_basis(tau, 2), float(noise @ noise), w, p


def test_a_pair_the_record_does_not_resolve_is_flagged_not_called_amplitude_dependent():
    """Two modes 0.1 % apart beat over a third of a resolution cell: two viscous modes fit
    better than a damping law that does no better than one viscous decay (+1 parameter),
    and the pair found is the one put in (20.000 and 20.020 Hz)."""
    tau, y, drift, _, w, p = _close("pair")
    rss, p1, w1 = _one_mode_rss(tau, y, drift, w, p)
    got = MC.unresolved_pair(tau, y, drift, p1, w1, rss, 3)
    assert got is not None and got["delta_bic"] < 0
    assert got["f_hz"] == pytest.approx([20.0, 20.02], abs=0.004)
    assert got["separation_cells"] >= MC.PAIR_MIN_CELLS


def test_an_amplitude_dependent_envelope_that_a_law_fits_is_not_a_pair():
    """A non-exponential envelope at one frequency that the damping law fits to the noise:
    the law stays, no pair is flagged."""
    tau, y, drift, noise_rss, w, p = _close("envelope")
    _, p1, w1 = _one_mode_rss(tau, y, drift, w, p)
    assert MC.unresolved_pair(tau, y, drift, p1, w1, noise_rss, 3) is None
