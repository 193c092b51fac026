"""Tests of the simulator :mod:`dampfit.simulate` and its writers."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from dampfit.errors import InputError
from dampfit.io.recording import STANDARD_GRAVITY, Recording
from dampfit.simulate import (
    PRESETS,
    SimulationConfig,
    envelope_at,
    free_decay,
    from_modal,
    preset,
    recording as simulate_recording,
    write_phyphox_csv,
    write_truth,
)

#: Noise-free, untilted, short: the pure physics plus irregular sampling.
CLEAN = dict(noise_density=0.0, drift=0.0, quantization=0.0, bias=0.0, duration=10.0)


def _axis_along(rec: Recording, truth: dict) -> np.ndarray:
    """Acceleration [m/s²] projected on the true direction of motion."""
    return rec.accel @ np.asarray(truth["direction"])


# -- physics ------------------------------------------------------------------------------


def test_acceleration_after_release_solves_the_ode():
    cfg = SimulationConfig(**CLEAN, jitter=0.05, gaps=3, handheld=1.0, seed=3)
    rec, truth = simulate_recording(cfg)
    m, c, k, u0 = cfg.mass, cfg.c, cfg.k, cfg.u0
    after = rec.time >= truth["t_release"]
    tau = rec.time[after] - truth["t_release"]
    sol = solve_ivp(
        lambda _t, y: [y[1], -(c * y[1] + k * y[0]) / m],
        (0.0, tau[-1]), [u0, 0.0], method="DOP853", t_eval=tau, rtol=1e-10, atol=1e-14,
    )
    assert sol.success
    accel_ref = -(c * sol.y[1] + k * sol.y[0]) / m
    scale = k / m * u0
    np.testing.assert_allclose(rec.axis("y")[after], accel_ref, rtol=0, atol=1e-6 * scale)
    np.testing.assert_array_equal(rec.axis("x")[after], 0.0)
    np.testing.assert_array_equal(rec.axis("z")[after], 0.0)
    assert rec.format == "simulated" and rec.axes == ("x", "y", "z") and rec.gravity_removed is True


def test_free_decay_starts_at_rest_at_u0():
    u, v, a = free_decay(0.0, 5.3, 0.2, 619.0, 0.04)
    assert u == pytest.approx(0.04) and v == 0.0 and a == pytest.approx(-619.0 / 5.3 * 0.04)


def test_truth_is_consistent_and_json_safe(tmp_path):
    cfg = preset("paper")
    _, truth = simulate_recording(cfg)
    assert truth["zeta"] == pytest.approx(cfg.c / (2 * math.sqrt(cfg.k * cfg.mass)), rel=1e-12)
    assert truth["f_n"] == pytest.approx(1.72, rel=1e-9)
    assert truth["omega_n"] == pytest.approx(2 * math.pi * truth["f_n"], rel=1e-12)
    assert truth["f_d"] == pytest.approx(truth["omega_d"] / (2 * math.pi), rel=1e-12)
    assert truth["p"] == pytest.approx(cfg.c / (2 * cfg.mass), rel=1e-12)
    assert truth["envelope_amplitude"] == pytest.approx(cfg.u0 * truth["omega_n"] / truth["omega_d"])
    assert envelope_at(truth, truth["t_release"]) == pytest.approx(truth["envelope_amplitude"], rel=1e-15)
    assert envelope_at(truth, truth["t_release"] + 10) == pytest.approx(
        truth["envelope_amplitude"] * math.exp(-10 * truth["p"])
    )
    assert truth["t_release"] == 3.0 and truth["t_catch"] is None
    assert np.linalg.norm(truth["direction"]) == pytest.approx(1.0)
    assert truth["config"]["c"] == 0.2 and isinstance(truth["dampfit_version"], str)
    path = write_truth(truth, tmp_path / "truth.json")
    assert json.loads(path.read_text()) == truth
    assert path.read_text().startswith('{\n  "mass": 5.3')


def test_from_modal_gives_physical_c_and_k():
    cfg = from_modal(0.33, 0.9, 0.01, u0=0.03)
    assert cfg.k == pytest.approx(0.33 * (2 * math.pi * 0.9) ** 2)
    assert cfg.c == pytest.approx(2 * 0.01 * math.sqrt(cfg.k * 0.33))
    _, truth = simulate_recording(dataclasses.replace(cfg, duration=5.0))
    assert truth["zeta"] == pytest.approx(0.01) and truth["f_n"] == pytest.approx(0.9)


def test_presets():
    paper, phone = preset("paper"), preset("phone")
    assert (paper.mass, paper.c, paper.u0, paper.sample_rate, paper.duration) == (5.3, 0.2, 0.04, 500.0, 60.0)
    assert paper.k == pytest.approx(5.3 * (2 * math.pi * 1.72) ** 2)
    assert phone.catch and phone.gaps > 0 and phone.jitter == 0.07 and phone.handheld > 0
    assert preset("paper", seed=7, duration=20.0).seed == 7
    assert set(PRESETS) >= {"paper", "phone"}
    for name in PRESETS:
        rec, truth = simulate_recording(preset(name))
        assert rec.time[0] == 0.0 and rec.time[-1] < PRESETS[name].duration


# -- measurement effects -----------------------------------------------------------------


def test_noise_level_matches_noise_sigma():
    cfg = SimulationConfig(u0=0.0, duration=20.0, noise_density=150.0, seed=1)
    rec, truth = simulate_recording(cfg)
    assert truth["noise_sigma"] == pytest.approx(150e-6 * STANDARD_GRAVITY * math.sqrt(250.0))
    np.testing.assert_allclose(rec.accel.std(axis=0), truth["noise_sigma"], rtol=0.03)
    np.testing.assert_allclose(rec.accel.mean(axis=0), 0.0, atol=4 * truth["noise_sigma"] / math.sqrt(rec.n_samples))


def test_jitter_cv_matches_config():
    rec, _ = simulate_recording(SimulationConfig(**CLEAN, jitter=0.05, seed=2))
    assert rec.jitter == pytest.approx(0.05, rel=0.05)
    assert rec.sample_rate == pytest.approx(500.0, rel=0.01)
    regular, _ = simulate_recording(SimulationConfig(**CLEAN))
    np.testing.assert_allclose(np.diff(regular.time), 1 / 500.0, rtol=1e-9)
    assert regular.n_samples == 5000


def test_timestamp_jitter_moves_the_stamps_not_the_samples():
    """With timestamp_jitter the recording carries stamps off their samples' true times by
    independent errors (sd = the fraction of the interval), still strictly increasing; the
    acceleration is that of the true, regular times."""
    cfg = SimulationConfig(**CLEAN, timestamp_jitter=0.08, seed=5)
    rec, truth = simulate_recording(cfg)
    exact, truth0 = simulate_recording(dataclasses.replace(cfg, timestamp_jitter=0.0))
    np.testing.assert_array_equal(rec.accel, exact.accel)
    err = rec.time - exact.time
    assert np.std(err) * cfg.sample_rate == pytest.approx(0.08, rel=0.05)
    assert np.all(np.abs(err) <= 0.45 / cfg.sample_rate + 1e-12)
    assert np.all(np.diff(rec.time) > 0)
    # consecutive intervals anti-correlated, as stamp errors make them
    d = np.diff(rec.time)
    assert np.corrcoef(d[:-1], d[1:])[0, 1] == pytest.approx(-0.5, abs=0.05)
    assert truth["config"]["timestamp_jitter"] == 0.08 and truth["c"] == truth0["c"]


def test_timestamp_jitter_limits():
    from dampfit.simulate import check_limits

    with pytest.raises(InputError, match="timestamp_jitter must not be negative"):
        SimulationConfig(timestamp_jitter=-0.01)
    with pytest.raises(InputError, match=r"timestamp_jitter must be a fraction of the sample "
                                          r"interval in \[0, 0.3\], got 0.5"):
        check_limits(SimulationConfig(timestamp_jitter=0.5))


def test_gaps_remove_samples():
    rec, _ = simulate_recording(SimulationConfig(**CLEAN, gaps=5, seed=4))
    big = np.diff(rec.time) > 1.5 / 500.0
    assert 1 <= big.sum() <= 5 and rec.n_samples < 5000


@pytest.mark.parametrize("main_axis, tilt, azimuth", [("y", 10.0, 30.0), ("z", 25.0, 200.0), ("x", 5.0, 90.0)])
def test_tilt_projects_along_direction(main_axis, tilt, azimuth):
    cfg = SimulationConfig(**CLEAN, main_axis=main_axis, tilt_deg=tilt, azimuth_deg=azimuth)
    rec, truth = simulate_recording(cfg)
    d = np.asarray(truth["direction"])
    i = "xyz".index(main_axis)
    assert d[i] == pytest.approx(math.cos(math.radians(tilt)))
    a = rec.axis(main_axis)
    peak = np.argmax(np.abs(a))
    for j, name in enumerate("xyz"):
        assert rec.axis(name)[peak] / a[peak] == pytest.approx(d[j] / d[i], abs=1e-12)
    # the amplitude along the direction is the untilted one
    untilted, _ = simulate_recording(SimulationConfig(**CLEAN))
    np.testing.assert_allclose(_axis_along(rec, truth), untilted.axis("y"), atol=1e-12)


def test_gravity_adds_g_along_direction():
    kw = dict(CLEAN, tilt_deg=20.0, azimuth_deg=45.0, noise_density=150.0, seed=5)
    with_g, truth = simulate_recording(SimulationConfig(**kw, gravity=True))
    without, _ = simulate_recording(SimulationConfig(**kw, gravity=False))
    g_vec = STANDARD_GRAVITY * np.asarray(truth["direction"])
    np.testing.assert_allclose(with_g.accel - without.accel, np.broadcast_to(g_vec, with_g.accel.shape), atol=1e-12)
    assert with_g.gravity_removed is False and without.gravity_removed is True


def test_bias_and_drift():
    cfg = SimulationConfig(u0=0.0, noise_density=0.0, bias=(0.1, -0.2, 0.3), drift=0.02, duration=30.0)
    rec, truth = simulate_recording(cfg)
    np.testing.assert_allclose(rec.accel.mean(axis=0), [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(rec.accel.std(axis=0), 0.02, rtol=1e-9)
    # slow: almost no power above f_n/5
    x = rec.axis("x") - 0.1
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size))) ** 2
    f = np.fft.rfftfreq(x.size, 1 / 500.0)
    assert spec[f > truth["f_n"] / 5].sum() < 0.01 * spec.sum()


def test_quantization_gives_multiples_of_the_step():
    q = 0.0012
    rec, _ = simulate_recording(SimulationConfig(quantization=q, bias=(0.01, 0.02, 0.03), drift=0.01, duration=5.0))
    steps = rec.accel / q
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert len(np.unique(rec.axis("x"))) > 10


def test_handheld_segment_precedes_the_decay():
    cfg = SimulationConfig(**CLEAN, handheld=3.0)
    rec, truth = simulate_recording(cfg)
    t_r = truth["t_release"]
    assert t_r == 3.0
    before = rec.time < t_r
    assert before.sum() == 1500
    rms = np.sqrt(np.mean(rec.accel[before] ** 2, axis=0))
    assert np.all((rms > 0.05) & (rms < 0.3))  # tremor (+ the slow pull along y)
    after = ~before
    expected = free_decay(rec.time[after] - t_r, cfg.mass, cfg.c, cfg.k, cfg.u0)[2]
    np.testing.assert_allclose(rec.axis("y")[after], expected, atol=1e-12)
    assert rec.axis("y")[after][0] == pytest.approx(-cfg.k / cfg.mass * cfg.u0, rel=1e-6)
    # the slow pull (below ~1.5 Hz) runs along y only; tremor (3–12 Hz) is on all axes
    held = rec.accel[before] * np.hanning(before.sum())[:, None]
    spectrum = np.abs(np.fft.rfft(held, axis=0)) ** 2
    slow = np.sqrt(spectrum[np.fft.rfftfreq(before.sum(), 1 / 500.0) < 1.5].sum(axis=0))
    assert slow[1] > 5 * max(slow[0], slow[2])


def test_catch_spike_then_held():
    cfg = SimulationConfig(**CLEAN, catch=True)
    rec, truth = simulate_recording(cfg)
    t_c = truth["t_catch"]
    assert t_c == pytest.approx(cfg.duration - 1.5)
    a = _axis_along(rec, truth)
    spike = (rec.time >= t_c) & (rec.time < t_c + 0.03)
    assert 3 <= spike.sum() <= 20
    assert np.max(np.abs(a[spike])) > 5.0
    late = rec.time > t_c + 0.1
    rms = np.sqrt(np.mean(rec.accel[late] ** 2, axis=0))
    assert np.all(rms < 0.3)
    free = (rec.time >= truth["t_release"]) & (rec.time < t_c)
    assert np.max(np.abs(a[free])) > 3.0  # the decay ran until the catch


def test_seeds_are_deterministic():
    cfg = preset("phone", duration=15.0)
    a, ta = simulate_recording(cfg)
    b, tb = simulate_recording(cfg)
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.accel, b.accel)
    assert ta == tb
    c, _ = simulate_recording(preset("phone", duration=15.0, seed=1))
    assert a.time.size != c.time.size or not np.array_equal(a.time, c.time)
    assert a.accel.shape != c.accel.shape or not np.array_equal(a.accel, c.accel)


# -- CSV writer ----------------------------------------------------------------------------

_HEADERS = {
    True: '"Time (s)"{s}"Linear Acceleration x (m/s^2)"{s}"Linear Acceleration y (m/s^2)"'
    '{s}"Linear Acceleration z (m/s^2)"{s}"Absolute acceleration (m/s^2)"',
    False: '"Time (s)"{s}"Acceleration x (m/s^2)"{s}"Acceleration y (m/s^2)"'
    '{s}"Acceleration z (m/s^2)"{s}"Absolute acceleration (m/s^2)"',
}
_DIALECTS = {"comma": (",", "."), "tab": ("\t", "."), "semicolon": (";", ",")}


def _known_recording(gravity_removed: bool) -> Recording:
    t = np.arange(16) * 0.002
    accel = np.zeros((16, 3))
    accel[0] = [8.152291659e-3, 1.027333016, -5.420560837e-1]
    accel[1] = [123456.78901, -1e-12, 0.0]
    accel[2] = [-0.0, 9.80665, 1e-300]
    return Recording(time=t, accel=accel, gravity_removed=gravity_removed)


@pytest.mark.parametrize("dialect", list(_DIALECTS))
@pytest.mark.parametrize("gravity_removed", [True, False])
def test_csv_header_and_number_format(tmp_path, dialect, gravity_removed):
    sep, dec = _DIALECTS[dialect]
    path = write_phyphox_csv(_known_recording(gravity_removed), tmp_path / "a.csv", dialect=dialect)
    lines = path.read_text(encoding="utf-8").split("\n")
    assert lines[0] == _HEADERS[gravity_removed].format(s=sep)
    absolute = math.sqrt(8.152291659e-3**2 + 1.027333016**2 + 5.420560837e-1**2)
    expected = [
        ["0.000000000E0", "8.152291659E-3", "1.027333016E0", "-5.420560837E-1", f"{absolute:.9E}".replace("E+00", "E0")],
        ["2.000000000E-3", "1.234567890E5", "-1.000000000E-12", "0.000000000E0", "1.234567890E5"],
        ["4.000000000E-3", "0.000000000E0", "9.806650000E0", "1.000000000E-300", "9.806650000E0"],
    ]
    for line, row in zip(lines[1:4], expected):
        assert line == sep.join(v.replace(".", dec) for v in row)
    assert lines[-1] == "" and len(lines) == 18
    assert all(re.fullmatch(r"-?\d[.,]\d{9}E(0|-?[1-9]\d*)", v) for v in lines[5].split(sep))


@pytest.mark.parametrize("dialect", list(_DIALECTS))
def test_csv_round_trip_with_pandas(tmp_path, dialect):
    rec, _ = simulate_recording(preset("phone", duration=10.0))
    path = write_phyphox_csv(rec, tmp_path / "phone.csv", dialect=dialect)
    kw = {"comma": {}, "tab": {"sep": "\t"}, "semicolon": {"sep": ";", "decimal": ","}}[dialect]
    df = pd.read_csv(path, **kw)
    assert list(df.columns)[1] == "Acceleration x (m/s^2)"
    np.testing.assert_allclose(df.iloc[:, 0].to_numpy(), rec.time, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(df.iloc[:, 1:4].to_numpy(), rec.accel, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(df.iloc[:, 4].to_numpy(), np.linalg.norm(rec.accel, axis=1), rtol=1e-9)


def test_csv_writer_writes_every_row_of_a_long_recording(tmp_path):
    """30k rows: one line each plus the header (its speed: paper/bench_csv.py)."""
    rec, _ = simulate_recording(preset("paper"))
    path = write_phyphox_csv(rec, tmp_path / "paper.csv")
    assert path.read_text().count("\n") == rec.n_samples + 1


def test_writers_leave_no_half_written_file(tmp_path, monkeypatch):
    target = tmp_path / "a.csv"
    target.write_text("old")

    def fail(*_args):
        raise OSError("disk full")

    monkeypatch.setattr("dampfit.files.writers.os.replace", fail)
    with pytest.raises(InputError, match="disk full") as info:
        write_phyphox_csv(_known_recording(True), target)
    assert isinstance(info.value.__cause__, OSError)
    with pytest.raises(InputError, match="disk full"):
        write_truth({"a": 1}, tmp_path / "t.json")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


def test_writer_errors(tmp_path):
    with pytest.raises(InputError, match="unknown CSV dialect 'excel'"):
        write_phyphox_csv(_known_recording(True), tmp_path / "a.csv", dialect="excel")
    with pytest.raises(InputError, match="does not exist"):
        write_phyphox_csv(_known_recording(True), tmp_path / "missing" / "a.csv")
    two_axes = Recording(time=np.arange(16.0), accel=np.zeros((16, 2)), axes=("x", "y"))
    with pytest.raises(InputError, match="axis 'z'"):
        write_phyphox_csv(two_axes, tmp_path / "a.csv")
    assert list(tmp_path.iterdir()) == []


# -- invalid configurations ---------------------------------------------------------------


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(c=200.0), r"overdamped.*c < 2\*sqrt\(k\*m\)"),
        (dict(c=2 * math.sqrt(619.0 * 5.3), k=619.0), "critically damped or overdamped"),
        (dict(mass=0.0), "mass must be positive"),
        (dict(mass=-1.0), "mass must be positive"),
        (dict(k=0.0), "k must be positive"),
        (dict(sample_rate=0.0), "sample_rate must be positive"),
        (dict(duration=-5.0), "duration must be positive"),
        (dict(u0=-0.01), "u0 must not be negative"),
        (dict(noise_density=-1.0), "noise_density must not be negative"),
        (dict(c=-0.1), "c must not be negative"),
        (dict(jitter=float("nan")), "jitter must be finite"),
        (dict(gaps=1.5), "gaps must be a non-negative integer"),
        (dict(bias=(1.0, 2.0)), "bias must be one finite number or three"),
        (dict(main_axis="w"), "main_axis must be one of x, y, z"),
        (dict(handheld=70.0), "leaves no free decay"),
        (dict(duration=3.0, handheld=2.0, catch=True), "catch .* comes before the release"),
    ],
)
def test_invalid_config_raises(kw, match):
    with pytest.raises(InputError, match=match):
        SimulationConfig(**kw)


def test_invalid_helpers_raise():
    with pytest.raises(InputError, match="unknown preset 'lab'; choose one of paper, phone"):
        preset("lab")
    with pytest.raises(InputError, match="unknown simulation option"):
        preset("paper", massa=3.0)
    with pytest.raises(InputError, match="damping ratio zeta must be in"):
        from_modal(1.0, 1.0, 1.2)
    with pytest.raises(InputError, match="f_n must be positive"):
        from_modal(1.0, -1.0, 0.1)
    with pytest.raises(InputError, match="gaps do not fit"):
        simulate_recording(SimulationConfig(duration=0.1, gaps=10))
