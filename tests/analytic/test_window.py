"""Free-decay window: it stops at a catch, rattle or contact (an abrupt envelope drop)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from dampfit.signal import prepare as pp
from dampfit.errors import InputError
from dampfit.io.recording import Recording

FS, F, ZETA = 400.0, 5.0, 0.005


def decay(drop_at: float | None = None, factor: float = 3.0, zeta: float = ZETA, seed: int = 0,
          noise: float = 0.01) -> Recording:
    """A 20 s, 5 Hz free decay released at 1 s whose amplitude falls ``factor``× at ``drop_at``."""
    t = np.arange(0.0, 20.0, 1 / FS)
    w = 2 * np.pi * F
    tau = np.clip(t - 1.0, 0.0, None)
    a = 5.0 * np.exp(-zeta * w * tau) * np.cos(w * np.sqrt(1 - zeta**2) * tau)
    a[t < 1.0] = 0.0
    if drop_at is not None:
        a[t > drop_at] /= factor
    a += np.random.default_rng(seed).normal(0.0, noise, t.size)
    return Recording(time=t, accel=a[:, None], axes=("z",))


def test_window_ends_before_a_rattle():
    prep = pp.prepare(decay(drop_at=7.7))
    assert 6.5 < prep.window[1] < 7.7
    note = next(n for n in prep.notes if "abrupt envelope drop" in n)
    assert "7.7" in note and "catch, rattle or contact" in note


def test_the_reason_the_window_ends_is_carried_to_the_table():
    """Prepared, summary.json (window.end_reason) and the CLI table say why the window ends:
    the rattle, an impact, the noise floor — or that the user gave it."""
    from dampfit.output import text as render
    from tests._support.summaries import summary

    rattle = pp.prepare(decay(drop_at=7.7)).window_end_reason
    assert rattle.startswith("abrupt envelope drop at 7.7") and "catch" in rattle
    assert pp.prepare(decay(zeta=0.05)).window_end_reason == "the decay reaches 3x the noise floor"
    knock = decay(zeta=0.002)
    i = int(9.0 * FS)  # a catch: a knock 80x the oscillation that stops it (a glitch the
    knock.accel[i, 0] += 400.0  # decay runs through unchanged does not end the window)
    knock.accel[i + 1:, 0] *= np.exp(-3.0 * (knock.time[i + 1:] - 9.0))
    assert pp.prepare(knock).window_end_reason == "impact at 9.00 s (catch or knock)"
    assert pp.prepare(decay(drop_at=7.7), window=(2.0, 15.0)).window_end_reason == "given"
    s = summary()
    s["window"]["end_reason"] = rattle
    assert f"window ends     {rattle}" in render.text(s)
    s["window"].update(auto=False, end_reason="given")
    assert "window ends" not in render.text(s)


def test_a_users_window_across_the_drop_is_kept_and_warned():
    prep = pp.prepare(decay(drop_at=7.7), window=(2.0, 15.0))
    assert prep.window == (2.0, 15.0)
    assert any("abrupt envelope drop at 7.7" in w for w in prep.warnings)


@pytest.mark.parametrize("zeta", [0.001, 0.01, 0.05, 0.1])
def test_smooth_decays_are_not_cut(zeta):
    """Heavy damping loses 3× in well under two cycles at ζ = 0.1: the trend, not a catch."""
    for seed in range(2):
        prep = pp.prepare(decay(zeta=zeta, seed=seed))
        assert not any("abrupt" in n for n in prep.notes), prep.notes


def test_amplitude_dependent_decay_is_not_a_catch():
    """Quadratic drag: ζ falls ≈ 5× along the decay, smoothly; no drop is reported."""
    from tests._support.reference_sim import noisy_recording, reference_decay

    t = np.arange(0.0, 30.0, 1 / 200.0)
    m, k = 1.0, (2 * np.pi * 3.0) ** 2
    _, _, acc = reference_decay(t, m, k, 0.05, c=0.05, c2=8.0)
    rec = noisy_recording(t, acc, 0.005, seed=1, lead=1.0)
    assert not any("abrupt" in n for n in pp.prepare(rec).notes)


@pytest.mark.parametrize("held", [0.0, 2.0])
def test_release_time_is_where_the_decay_starts(held):
    """The release (signal.window.release_time) is found within a period of the true one,
    whether the recording starts at the release or holds still before it, and the campaign
    amplitude carried back to it does not depend on the decay rate."""
    from dampfit import simulate as sim
    from dampfit.inference import least_squares as ls_mod
    from dampfit.signal.window import release_time

    amps = []
    for zeta in (0.01, 0.03):
        cfg = sim.from_modal(1.0, 4.0, zeta, duration=15.0, sample_rate=200.0, handheld=held,
                             noise_density=100.0, u0=0.02)
        prep = pp.prepare(sim.recording(cfg)[0])
        t_rel = release_time(prep.grid, prep.envelope, prep.window[0], prep.f0)
        assert abs(t_rel - held) < 1.0 / 4.0, (t_rel, held)
        assert prep.window[0] > t_rel  # the window skips part of the decay
        fd = pp.fit_data(prep)
        ls = ls_mod.least_squares(fd, float("nan"), prep.f0)
        a, b = ls.true_quadratures()
        u0 = np.hypot(a, b) / (ls.p**2 + ls.omega_d**2)
        amps.append(u0 * np.exp(ls.p * (fd.t0 - t_rel)))
    # at the window start the two differ by e^(−Δp·skip) (≈ 40 %); at the release by < 2 %
    assert abs(np.log(amps[0] / amps[1])) < 0.02, amps


# -- issue 19: a very light decay, a train of spikes, and the real reason for a refusal ------
def _light(zeta: float, **kw) -> Recording:
    """A 30 s, 3 Hz simulated decay (0.5 kg, 200 Hz) released at t = 0."""
    from dampfit import simulate as sim

    return sim.recording(sim.from_modal(0.5, 3.0, zeta, duration=30.0, sample_rate=200.0,
                                        seed=1, **kw))[0]


def _zeta(prep) -> float:
    from dampfit.stages import fit_stages

    ls = fit_stages(prep, 0.5).least_squares
    return ls.p / np.hypot(ls.p, ls.omega_d)


def test_a_very_light_decay_is_analysed():
    """ζ = 1e-5: the envelope falls 0.6 % in 30 s, less than its own ripple, so its maximum can
    sit anywhere (it sat 0.4 s before the end: "0.0 cycles … too short?"). The release is
    where the flat envelope is first reached; the whole decay is fitted."""
    prep = pp.prepare(_light(1e-5))
    assert prep.window[0] < 1.5 and prep.window[1] > 25.0
    assert _zeta(prep) == pytest.approx(1e-5, rel=0.05)


def _spiked(rec: Recording, size: float, every: float = 1.0, first: float = 0.5) -> Recording:
    """``rec`` with a one-sample glitch of ``size`` [m/s²] on y once every ``every`` [s]."""
    import dataclasses

    a = rec.accel.copy()
    idx = np.searchsorted(rec.time, np.arange(first, rec.time[-1], every))
    a[idx, rec.axes.index("y")] += size
    return dataclasses.replace(rec, accel=a)


@pytest.mark.heavy
@pytest.mark.parametrize("size,first", [(500.0, 0.5), (500.0, 0.0), (50.0, 0.37)])
def test_a_train_of_glitches_neither_poses_as_the_oscillation_nor_ends_the_decay(size, first):
    """A one-sample spike once a second, up to 35× the release amplitude (14 m/s²): its comb
    of harmonics once won the spectrum (f0 = 50 Hz) or its first spike ended the window
    (0.7 cycles); now the spikes are masked, f0 is the oscillation's and the window runs on
    through them, with a note."""
    prep = pp.prepare(_spiked(_light(0.005), size, first=first))
    assert prep.f0 == pytest.approx(3.0, rel=1e-3)
    assert prep.window[0] < 1.5 and prep.window[1] > 25.0
    assert prep.n_spikes >= 25
    assert any("do not end the window: the decay runs on through them" in n for n in prep.notes)
    assert _zeta(prep) == pytest.approx(0.005, rel=0.02)


def test_too_few_samples_per_period_still_mask_gross_glitches():
    """At 30 Hz (10 samples a period) the local-cubic spike test cannot run; spikes 35× the
    oscillation are still masked (they need no f0 to be found)."""
    from dampfit import simulate as sim

    rec = sim.recording(sim.from_modal(0.5, 3.0, 0.005, duration=30.0, sample_rate=30.0,
                                       seed=1))[0]
    prep = pp.prepare(_spiked(rec, 500.0))
    assert prep.n_spikes >= 25 and prep.f0 == pytest.approx(3.0, rel=1e-3)
    assert prep.window[1] - prep.window[0] > 20.0


def test_the_release_of_a_fast_heavy_decay_is_not_a_gross_spike():
    """20 Hz, ζ = 0.08 at 60 Hz with 7 % jitter after ≈ 3.6 s of hand motion (the recovery
    grid's case 33): three samples a period, so the first peak alone stands 20× above both
    scales. It was masked as a gross spike, and the spectrum then found 8 Hz ("no free decay
    found"); the samples after it stay loud, so it is an onset, not a spike."""
    from dampfit import simulate as sim

    rng = np.random.default_rng(1033)
    handheld = float(rng.uniform(1.5, 4.0))
    cfg = sim.from_modal(
        mass=float(rng.uniform(0.2, 6.0)), f_n=20.0, zeta=0.08, u0=4.0 / (2 * np.pi * 20.0) ** 2,
        duration=handheld + 2.0, sample_rate=60.0, jitter=0.07, gaps=2, noise_density=400.0,
        bias=tuple(rng.normal(0, 0.05, 3)), drift=0.01, quantization=0.0012,
        tilt_deg=float(rng.uniform(0, 25)), azimuth_deg=float(rng.uniform(0, 360)),
        main_axis=str(rng.choice(["x", "y", "z"])), gravity=bool(rng.integers(2)),
        handheld=handheld, seed=1033)
    prep = pp.prepare(sim.recording(cfg)[0])
    assert prep.f0 == pytest.approx(20.0, rel=0.02)
    assert (prep.window[1] - prep.window[0]) * prep.f0 >= 3.0


def test_a_catch_still_ends_the_window_among_glitches():
    """The spike test compares the decay before and after a spike: a real catch (the
    oscillation stops) still ends the window, glitches before it do not."""
    rec = _spiked(_light(0.005, catch=True), 500.0)  # the catch 1.5 s before the end
    prep = pp.prepare(rec)
    assert 26.0 < prep.window[1] < 28.6
    assert any("do not end the window" in n for n in prep.notes)


def test_a_knock_early_in_the_decay_is_named_and_the_decay_after_it_analysed():
    """A knock 1.5 s after the release: a spike 35× the oscillation, after which it rings on
    at a fifth of its amplitude. The 2.7 cycles before it are too few; the free decay after it
    is analysed (issue 35: the longest free decay after a cut-short start), and the note names
    the impact, not "0.0 cycles … too short?"."""
    import dataclasses

    rec = _light(0.005)
    a = rec.accel.copy()
    i = int(np.searchsorted(rec.time, 1.5))
    a[i, 1] += 500.0
    a[i + 1:, :] *= 0.2
    prep = pp.prepare(dataclasses.replace(rec, accel=a))
    assert 1.5 < prep.window[0] < 3.0 and prep.window[1] > 25.0
    assert prep.f0 == pytest.approx(3.0, rel=1e-3)
    note = next(n for n in prep.notes if "cut short" in n)
    assert re.search(r"cut short after \d\.\d cycles by an impact at 1\.5\d s", note), note
    assert "longest free decay after it" in note and "too short" not in note


def test_a_growing_oscillation_says_so():
    """An oscillation that builds up to the end of the recording: no free decay after its
    maximum, and the message says it grows (forced or self-sustained?)."""
    t = np.arange(0.0, 20.0, 1 / FS)
    a = 0.2 * np.exp(0.2 * t) * np.sin(2 * np.pi * F * t)
    a += np.random.default_rng(0).normal(0.0, 0.01, t.size)
    with pytest.raises(InputError, match=r"grows rather than decays \(forced or self-sustained"):
        pp.prepare(Recording(time=t, accel=a[:, None], axes=("z",)))
