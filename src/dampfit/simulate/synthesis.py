"""Simulated free-decay accelerometer recordings with known truth.

The mass–spring–damper ``m·ü + c·u̇ + k·u = 0`` is released at ``t_r`` from ``u(t_r) = u0``,
``u̇(t_r) = 0``. With ``τ = t − t_r``, ``p = c/(2m)``, ``ω_n = √(k/m)`` and
``ω_d = √(ω_n² − p²)`` (underdamped, c < 2√(k·m)) the exact solution is

    u(τ) = u0·e^{−pτ}·(cos ω_d τ + (p/ω_d)·sin ω_d τ) = U·e^{−pτ}·cos(ω_d τ − φ),
    u̇(τ) = −u0·(ω_n²/ω_d)·e^{−pτ}·sin ω_d τ,
    ü(τ) = −(c·u̇ + k·u)/m,

with envelope amplitude ``U = u0·ω_n/ω_d`` and phase ``φ = atan(p/ω_d)``. (Derivation: the
ansatz ``u = e^{−pτ}(A cos ω_d τ + B sin ω_d τ)`` solves the ODE; ``u(0) = u0`` gives
``A = u0`` and ``u̇(0) = −pA + ω_d B = 0`` gives ``B = p·u0/ω_d``.) It is evaluated exactly at
the irregular sample times, so jitter and gaps are in the time stamps, not in the physics.
With ``timestamp_jitter`` the recording's time stamps are *not* the sample times: each stamp is
the sample time plus an independent error — a phone stamps a sample when the operating system
receives it, while the sensor samples on its own steady clock — and an analysis that reads the
stamps as given sees every sample at a slightly wrong time.

A phone/MEMS recording adds, in the phone frame (axes x, y, z):

* **direction** — the motion runs along the unit vector ``d`` that makes the angle
  ``tilt_deg`` with ``main_axis``, tilted towards ``azimuth_deg`` (measured from the next
  axis in cyclic order x→y→z→x towards the one after: for main axis z from x towards y,
  for y from z towards x, for x from y towards z); ``d`` points vertically *up* and ``u``
  is positive along ``d``;
* **hand-held segment** ``0 ≤ t < t_r`` (``t_r = handheld``): the hand slowly pulls the
  mass from equilibrium to ``u0`` (a cycloidal ramp with zero velocity and acceleration at
  both ends) and holds it there; hand tremor is a band-limited random acceleration
  (3–12 Hz, 0.1 m/s² rms per axis);
* **catch** at ``t_c = t_end − 1.5 s``: a half-sine impact pulse (8 m/s², ~15 ms) opposing
  the velocity, then the held state (tremor only);
* **gravity** (phyphox "with g"): the specific force ``+g·d`` [m/s²];
* **bias** per axis, slow random **drift** (content below f_n/10, zero mean, given rms),
  white **noise** with σ = noise_density·1e-6·g·√(fs/2) per sample, and finally
  **quantization** to multiples of the LSB.

Each random ingredient has its own stream spawned from ``seed``, so switching one on or
off does not change the others.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dampfit.errors import InputError
from dampfit.io.recording import STANDARD_GRAVITY, Recording
from dampfit.physics import to_decay
from dampfit.simulate.artefacts import recording_truth
from dampfit.simulate.config import (AXES, GAP_LENGTH, TWO_PI, SimulationConfig, catch_time,
                                     noise_sigma)

#: Hand-tremor band [Hz] and rms per axis [m/s²].
_TREMOR_BAND = (3.0, 12.0)
_TREMOR_RMS = 0.1
_TREMOR_COMPONENTS = 64
#: Longest pull from equilibrium to u0 [s]; the pull takes at most 60 % of the hand-held time.
_PULL_TIME = 2.0
#: Catch: pulse peak [m/s²] and shortest pulse width [s] (its time: config.catch_time).
_CATCH_PEAK = 8.0
_CATCH_WIDTH = 0.015
#: Drift content: highest frequency as a fraction of f_n, number of components.
_DRIFT_FRACTION = 0.1
_DRIFT_COMPONENTS = 8


# -- physics ----------------------------------------------------------------------------


def free_decay(
    tau, mass: float, c: float, k: float, u0: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacement [m], velocity [m/s] and acceleration [m/s²] of the free decay.

    ``tau`` [s] is the time since release from ``u0`` [m] at rest; ``mass`` [kg], ``c`` [N·s/m],
    ``k`` [N/m]. Closed form of the module docstring.
    """
    p, omega_d = (float(x) for x in to_decay(c, k, mass))
    tau = np.asarray(tau, dtype=float)
    decay = np.exp(-p * tau)
    cos, sin = np.cos(omega_d * tau), np.sin(omega_d * tau)
    u = u0 * decay * (cos + (p / omega_d) * sin)
    v = -u0 * ((p**2 + omega_d**2) / omega_d) * decay * sin
    return u, v, -(c * v + k * u) / mass


def extra_modes(tau, cfg: SimulationConfig) -> np.ndarray:
    """Acceleration [m/s²] of the extra ``cfg.modes`` at ``tau`` [s] after the release:
    Σ R·A₁·e^{−ζω_nτ}·cos(ω_n√(1−ζ²)·τ + φ), A₁ = u0·ω_n³/ω_d [m/s²] of the primary mode
    (its acceleration envelope at release)."""
    tau = np.asarray(tau, dtype=float)
    out = np.zeros_like(tau)
    if not cfg.modes:
        return out
    p1, wd1 = (float(x) for x in to_decay(cfg.c, cfg.k, cfg.mass))
    a1 = cfg.u0 * (p1**2 + wd1**2) ** 1.5 / wd1
    for f_n, zeta, ratio, phase in cfg.modes:
        wn = TWO_PI * f_n
        out += ratio * a1 * np.exp(-zeta * wn * tau) * np.cos(wn * math.sqrt(1 - zeta**2) * tau
                                                              + phase)
    return out


def _direction(cfg: SimulationConfig) -> np.ndarray:
    """Unit vector (x, y, z) of the motion in the phone frame."""
    i = AXES.index(cfg.main_axis)
    tilt, az = math.radians(cfg.tilt_deg), math.radians(cfg.azimuth_deg)
    d = np.zeros(3)
    d[i] = math.cos(tilt)
    d[(i + 1) % 3] = math.sin(tilt) * math.cos(az)
    d[(i + 2) % 3] = math.sin(tilt) * math.sin(az)
    return d




# -- random ingredients -------------------------------------------------------------------


def _sample_times(rng: np.random.Generator, cfg: SimulationConfig) -> np.ndarray:
    """Sample times [s] from 0 to before ``duration`` with jittered intervals."""
    dt0 = 1.0 / cfg.sample_rate
    n = int(math.ceil(cfg.duration * cfg.sample_rate)) + 1
    if cfg.jitter == 0:
        t = np.arange(n) * dt0
    else:
        chunks, total = [], 0.0
        while total < cfg.duration:
            dt = np.maximum(dt0 * (1.0 + cfg.jitter * rng.standard_normal(n)), 0.2 * dt0)
            chunks.append(dt)
            total += float(dt.sum())
        t = np.concatenate([[0.0], np.cumsum(np.concatenate(chunks))])
    return t[t < cfg.duration - 1e-6 * dt0]


def _stamps(rng: np.random.Generator, t: np.ndarray, cfg: SimulationConfig) -> np.ndarray:
    """Time stamps [s] of samples taken at ``t`` [s]: ``t`` plus independent normal errors of
    sd ``timestamp_jitter``/sample_rate, each truncated at ±0.45 of the shorter neighbouring
    interval (so the stamps stay strictly increasing); ``t`` itself without timestamp jitter."""
    if cfg.timestamp_jitter == 0 or t.size < 2:
        return t
    err = cfg.timestamp_jitter / cfg.sample_rate * rng.standard_normal(t.size)
    step = np.diff(t)
    room = 0.45 * np.minimum(np.concatenate([[step[0]], step]), np.concatenate([step, [step[-1]]]))
    return t + np.clip(err, -room, room)


def _remove_gaps(rng: np.random.Generator, t: np.ndarray, gaps: int) -> np.ndarray:
    """``t`` [s] with ``gaps`` runs of a few samples removed (never the first or last ones)."""
    if gaps == 0:
        return t
    lo, hi = GAP_LENGTH
    if gaps * (hi + 1) > t.size // 2:
        raise InputError(f"{gaps} gaps do not fit into a recording of {t.size} samples")
    starts = rng.choice(np.arange(1, t.size - hi - 1), size=gaps, replace=False)
    keep = np.ones(t.size, dtype=bool)
    for start, length in zip(starts, rng.integers(lo, hi + 1, size=gaps)):
        keep[start : start + length] = False
    return t[keep]


def _band_limited(
    rng: np.random.Generator, t: np.ndarray, band: tuple[float, float], rms: float, n_components: int
) -> np.ndarray:
    """Random zero-mean signal of shape (len(t), 3) with content in ``band`` [Hz] and exact ``rms`` per column.

    A sum of sinusoids at random frequencies in ``band`` with Gaussian amplitudes, evaluated at
    the (irregular) times ``t`` [s].
    """
    if t.size == 0 or rms == 0:
        return np.zeros((t.size, 3))
    freq = rng.uniform(band[0], band[1], size=(n_components, 3))
    phase = rng.uniform(0.0, TWO_PI, size=(n_components, 3))
    amp = rng.standard_normal((n_components, 3))
    x = np.einsum("kj,nkj->nj", amp, np.cos(TWO_PI * freq[None] * t[:, None, None] + phase[None]))
    x -= x.mean(axis=0)
    scale = np.sqrt(np.mean(x**2, axis=0))
    return x * np.where(scale > 0, rms / np.where(scale > 0, scale, 1.0), 0.0)


def _flicker_noise(rng: np.random.Generator, n: int, cfg: SimulationConfig) -> np.ndarray:
    """1/f noise [m/s²] of shape (n, 3), one-sided density ``cfg.flicker``/√f [µg/√Hz].

    Unit white noise (one-sided density √(2/f_s)) shaped in the frequency domain by
    H(f) = flicker·f^(−1/2)/√(2/f_s), on the nominal sample grid (jitter is ignored here).
    """
    if n == 0 or cfg.flicker == 0:
        return np.zeros((n, 3))
    fs = cfg.sample_rate
    f = np.fft.rfftfreq(n, 1.0 / fs)
    gain = np.zeros_like(f)
    gain[1:] = cfg.flicker * 1e-6 * STANDARD_GRAVITY / np.sqrt(f[1:]) / math.sqrt(2.0 / fs)
    white = rng.standard_normal((n, 3))
    return np.fft.irfft(np.fft.rfft(white, axis=0) * gain[:, None], n=n, axis=0)


def _pull(t: np.ndarray, cfg: SimulationConfig) -> np.ndarray:
    """Acceleration [m/s²] of the slow cycloidal pull from 0 to ``u0`` during the hand-held segment.

    ``u = u0·(x − sin(2πx)/(2π))``, ``x = (t − t0)/T`` on [0, 1], so ``ü = 2π·u0/T²·sin(2πx)``.
    """
    duration = min(_PULL_TIME, 0.6 * cfg.handheld)
    start = 0.2 * cfg.handheld
    x = (t - start) / duration
    inside = (x >= 0) & (x <= 1)
    return np.where(inside, TWO_PI * cfg.u0 / duration**2 * np.sin(TWO_PI * x), 0.0)


def _catch_pulse(t: np.ndarray, t_catch: float, cfg: SimulationConfig, sign: float) -> np.ndarray:
    """Half-sine impact acceleration [m/s²] starting at ``t_catch`` [s]."""
    width = max(_CATCH_WIDTH, 3.5 / cfg.sample_rate)
    x = (t - t_catch) / width
    return np.where((x >= 0) & (x <= 1), sign * _CATCH_PEAK * np.sin(math.pi * x), 0.0)


# -- simulator -----------------------------------------------------------------------------


def recording(config: SimulationConfig) -> tuple[Recording, dict[str, Any]]:
    """A simulated recording (axes x, y, z [m/s²]) and its JSON-safe truth dict for ``config``."""
    if not isinstance(config, SimulationConfig):
        raise InputError(f"recording() needs a SimulationConfig, got {type(config).__name__}")
    cfg = config
    # a seventh stream for the stamp errors: spawn(7)'s first six children are spawn(6)'s
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(cfg.seed).spawn(7)]
    rng_time, rng_gaps, rng_tremor, rng_drift, rng_noise, rng_flicker, rng_stamp = streams

    t = _remove_gaps(rng_gaps, _sample_times(rng_time, cfg), cfg.gaps)
    t_release = cfg.handheld
    t_catch = catch_time(cfg) if cfg.catch else None
    end_free = t_catch if t_catch is not None else math.inf
    free = (t >= t_release) & (t < end_free)
    held = ~free

    # acceleration along the motion direction
    along = np.zeros(t.size)
    along[free] = free_decay(t[free] - t_release, cfg.mass, cfg.c, cfg.k, cfg.u0)[2]
    if cfg.modes:  # one-mode recordings stay byte-identical
        along[free] += extra_modes(t[free] - t_release, cfg)
    if t_release > 0:
        before = t < t_release
        along[before] = _pull(t[before], cfg)
    if t_catch is not None:
        v_catch = free_decay(t_catch - t_release, cfg.mass, cfg.c, cfg.k, cfg.u0)[1]
        along += _catch_pulse(t, t_catch, cfg, sign=-1.0 if v_catch >= 0 else 1.0)

    direction = _direction(cfg)
    accel = along[:, None] * direction[None, :]
    accel[held] += _band_limited(rng_tremor, t[held], _TREMOR_BAND, _TREMOR_RMS, _TREMOR_COMPONENTS)
    if cfg.gravity:
        accel += STANDARD_GRAVITY * direction
    accel += np.asarray(cfg.bias)
    f_n = math.sqrt(cfg.k / cfg.mass) / TWO_PI
    f_drift = _DRIFT_FRACTION * f_n
    accel += _band_limited(rng_drift, t, (f_drift / 50.0, f_drift), cfg.drift, _DRIFT_COMPONENTS)
    accel += noise_sigma(cfg) * rng_noise.standard_normal(accel.shape)
    accel += _flicker_noise(rng_flicker, t.size, cfg)
    if cfg.quantization > 0:
        accel = np.round(accel / cfg.quantization) * cfg.quantization

    recording = Recording(
        time=_stamps(rng_stamp, t, cfg),
        accel=accel,
        axes=AXES,
        format="simulated",
        gravity_removed=not cfg.gravity,
        notes=(
            f"simulated free decay: m = {cfg.mass:g} kg, c = {cfg.c:g} N·s/m, k = {cfg.k:g} N/m, "
            f"u0 = {cfg.u0:g} m, seed {cfg.seed}",
        ),
    )
    return recording, recording_truth(cfg, t_catch, direction)
