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

import dataclasses
import math
from dataclasses import dataclass
from collections.abc import Sequence
from typing import Any

import numpy as np

from dampfit._meta import __version__
from dampfit.physics import MAX_MASS
from dampfit.errors import InputError
from dampfit.physics import check_mass, critical_damping, quantities, stiffness, to_decay
from dampfit.io.recording import STANDARD_GRAVITY, Recording
from dampfit.io.writers import DIALECTS, write_phyphox_csv, write_truth  # re-exported

__all__ = [
    "SimulationConfig",
    "check_limits",
    "PRESETS",
    "preset",
    "from_modal",
    "free_decay",
    "recording",
    "campaign",
    "MAX_TESTS",
    "envelope_at",
    "write_phyphox_csv",
    "write_truth",
    "DIALECTS",
]

TWO_PI = 2.0 * math.pi
_AXES = ("x", "y", "z")
#: Hand-tremor band [Hz] and rms per axis [m/s²].
_TREMOR_BAND = (3.0, 12.0)
_TREMOR_RMS = 0.1
_TREMOR_COMPONENTS = 64
#: Longest pull from equilibrium to u0 [s]; the pull takes at most 60 % of the hand-held time.
_PULL_TIME = 2.0
#: Catch: time before the end [s], pulse peak [m/s²] and shortest pulse width [s].
_CATCH_BEFORE_END = 1.5
_CATCH_PEAK = 8.0
_CATCH_WIDTH = 0.015
#: Drift content: highest frequency as a fraction of f_n, number of components.
_DRIFT_FRACTION = 0.1
_DRIFT_COMPONENTS = 8
#: Missing samples per gap (inclusive range).
_GAP_LENGTH = (2, 10)
_PAPER_K = 5.3 * (TWO_PI * 1.72) ** 2


@dataclass(frozen=True)
class SimulationConfig:
    """Parameters of one simulated recording; validated on construction (:class:`InputError`).

    Attributes
    ----------
    mass : float
        Oscillating mass [kg].
    k : float
        Spring stiffness [N/m] (default: the seed paper's 5.3 kg at 1.72 Hz, ≈ 619 N/m).
    c : float
        Viscous damping coefficient [N·s/m]; underdamped, ``0 ≤ c < 2√(k·m)``.
    u0 : float
        Displacement at release [m]; the velocity is 0 there.
    duration : float
        Total record length [s], hand-held segment included.
    sample_rate : float
        Nominal sample rate [Hz].
    jitter : float
        Coefficient of variation of the sample interval [1] (the samples are taken at these
        irregular times, and stamped with them).
    timestamp_jitter : float
        Standard deviation of each time stamp's error, as a fraction of the nominal interval
        1/sample_rate [1] (independent errors, truncated at ±0.45 of the neighbouring
        intervals so the stamps stay in order): the samples are taken at their true times and
        the recording carries the true times plus these errors (8 % gives an interval CV of
        ≈ 11 %). 0 for exact stamps.
    gaps : int
        Number of gaps of a few (2–10) missing samples each.
    noise_density : float
        White noise density [µg/√Hz], one-sided, independent per axis.
    flicker : float
        Coloured (1/f, "flicker") noise: one-sided amplitude density at 1 Hz [µg/√Hz], so
        the power density is flicker²/f; added to the white noise, independent per axis.
    bias : float or (float, float, float)
        Constant offset [m/s²], one for all axes or one per axis (x, y, z); stored as a 3-tuple.
    drift : float
        Rms [m/s²] of a slow zero-mean random bias drift per axis (content below f_n/10).
    quantization : float
        LSB step [m/s²]; 0 for none.
    tilt_deg, azimuth_deg : float
        Angle [deg] between the motion and ``main_axis``, and direction [deg] of that tilt.
    main_axis : str
        Phone axis ``"x"``, ``"y"`` or ``"z"`` the motion mostly runs along.
    gravity : bool
        Add g along the vertical (phyphox "Acceleration with g" instead of "Linear Acceleration").
    handheld : float
        Duration [s] of the hand-held segment before release; the release is at ``t = handheld``.
    catch : bool
        End with a catch (impact, then held) 1.5 s before the end.
    seed : int
        Seed of all random ingredients.
    """

    mass: float = 5.3
    k: float = _PAPER_K
    c: float = 0.2
    u0: float = 0.04
    duration: float = 60.0
    sample_rate: float = 500.0
    jitter: float = 0.0
    timestamp_jitter: float = 0.0
    gaps: int = 0
    noise_density: float = 150.0
    flicker: float = 0.0
    bias: tuple[float, float, float] | float = 0.0
    drift: float = 0.0
    quantization: float = 0.0
    tilt_deg: float = 0.0
    azimuth_deg: float = 0.0
    main_axis: str = "y"
    gravity: bool = False
    handheld: float = 0.0
    catch: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        _require_number(self, "mass", positive=None)
        check_mass(self.mass)
        for name in ("k", "sample_rate", "duration"):
            _require_number(self, name, positive=True)
        for name in ("c", "u0", "jitter", "timestamp_jitter", "noise_density", "flicker", "drift",
                     "quantization", "handheld"):
            _require_number(self, name, positive=False)
        for name in ("tilt_deg", "azimuth_deg"):
            _require_number(self, name, positive=None)
        for name in ("gaps", "seed"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 0:
                raise InputError(
                    f"simulation option {name} must be a non-negative integer, got {value!r}"
                )
        c_crit = float(critical_damping(self.k, self.mass))
        if self.c >= c_crit:
            raise InputError(
                f"c = {self.c:g} N·s/m is critically damped or overdamped (c >= 2*sqrt(k*m) = {c_crit:g} N·s/m); "
                "a free decay needs c < 2*sqrt(k*m)"
            )
        if self.handheld >= self.duration:
            raise InputError(
                f"handheld = {self.handheld:g} s leaves no free decay in a {self.duration:g} s recording"
            )
        if self.main_axis not in _AXES:
            raise InputError(f"main_axis must be one of x, y, z, got {self.main_axis!r}")
        object.__setattr__(self, "bias", _bias_tuple(self.bias))
        if self.catch and _catch_time(self) <= self.handheld:
            raise InputError(
                f"a catch {_CATCH_BEFORE_END:g} s before the end of a {self.duration:g} s recording "
                f"comes before the release at {self.handheld:g} s; lengthen duration or shorten handheld"
            )


def _require_number(cfg: SimulationConfig, name: str, positive: bool | None) -> None:
    """Raise unless option ``name`` is a finite real; ``positive`` True → > 0, False → ≥ 0."""
    value = getattr(cfg, name)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"simulation option {name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"simulation option {name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise InputError(f"simulation option {name} must be positive, got {value:g}")
    if positive is False and value < 0:
        raise InputError(f"simulation option {name} must not be negative, got {value:g}")


def _bias_tuple(bias: Any) -> tuple[float, float, float]:
    """Bias [m/s²] as one float per axis (x, y, z)."""
    try:
        values = np.asarray(bias, dtype=float)
    except (TypeError, ValueError):
        values = np.array([np.nan])
    if values.ndim == 0:
        values = np.full(3, float(values))
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        raise InputError(f"bias must be one finite number or three (x, y, z) [m/s²], got {bias!r}")
    return tuple(float(v) for v in values)


def _catch_time(cfg: SimulationConfig) -> float:
    """Time of the catch [s]."""
    return cfg.duration - _CATCH_BEFORE_END


def _build(**fields: Any) -> SimulationConfig:
    """A :class:`SimulationConfig`, turning an unknown option into an :class:`InputError`."""
    known = {f.name for f in dataclasses.fields(SimulationConfig)}
    unknown = sorted(set(fields) - known)
    if unknown:
        raise InputError(
            f"unknown simulation option(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}"
        )
    return SimulationConfig(**fields)


def from_modal(mass: float, f_n: float, zeta: float, **kw: Any) -> SimulationConfig:
    """Config from mass [kg], natural frequency ``f_n`` [Hz] and damping ratio ``zeta`` [1].

    ``k = m·(2π·f_n)²`` [N/m] and ``c = 2·ζ·√(k·m)`` [N·s/m]; ``kw`` sets the other options.
    """
    check_mass(mass)
    if not (math.isfinite(f_n) and f_n > 0):
        raise InputError(f"f_n must be positive, got {f_n!r}")
    if not (math.isfinite(zeta) and 0 <= zeta < 1):
        raise InputError(f"damping ratio zeta must be in [0, 1) for a free decay, got {zeta!r}")
    if {"k", "c"} & set(kw):
        raise InputError("from_modal sets k and c itself; pass f_n and zeta instead")
    k = float(stiffness(mass, TWO_PI * f_n))
    return _build(mass=mass, k=k, c=zeta * float(critical_damping(k, mass)), **kw)


#: Largest simulated recording [samples] (duration × sample rate): ≈ 2 GB of arrays.
MAX_SIM_SAMPLES = 5e7
#: Highest sample rate [Hz] simulated (MEMS accelerometers sample at ≤ 32 kHz).
MAX_SAMPLE_RATE = 1e6
#: Fewest samples [1] a simulated recording may have.
MIN_SAMPLES = 16
#: Largest displacement at release [m], noise densities [µg/√Hz] and offsets, drift rms and
#: LSB step [m/s²] simulated: far beyond any test rig, far below floating-point overflow.
MAX_U0 = 100.0
MAX_NOISE_DENSITY = 1e6
MAX_ACCEL = 1e4
#: Largest time-stamp error sd [1 = one nominal interval] simulated: beyond it most errors would
#: be truncated to keep the stamps in order.
MAX_TIMESTAMP_JITTER = 0.3


def check_limits(cfg: SimulationConfig) -> None:
    """Refuse a configuration the simulator must not run, before it allocates anything.

    The one check shared by ``dampfit simulate`` and ``dampfit study`` (each scenario):
    mass ≤ :data:`MAX_MASS` [kg]; duration × sample rate between
    :data:`MIN_SAMPLES` and :data:`MAX_SIM_SAMPLES` samples (memory); sample rate
    ≤ :data:`MAX_SAMPLE_RATE` [Hz]; natural frequency below Nyquist; jitter in [0, 1];
    timestamp_jitter in [0, :data:`MAX_TIMESTAMP_JITTER`]; tilt
    in [−90°, 90°]; u0 ≤ :data:`MAX_U0` [m]; noise densities ≤ :data:`MAX_NOISE_DENSITY`
    [µg/√Hz]; |bias|, drift and quantization ≤ :data:`MAX_ACCEL` [m/s²]; the gaps must fit
    into the recording. Raises :class:`InputError` (one line naming the option).
    """
    if cfg.mass > MAX_MASS:
        raise InputError(f"mass = {cfg.mass:g} kg is beyond the limit of {MAX_MASS:g} kg")
    if cfg.sample_rate > MAX_SAMPLE_RATE:
        raise InputError(f"sample_rate = {cfg.sample_rate:g} Hz is beyond the limit of "
                         f"{MAX_SAMPLE_RATE:g} Hz")
    n = cfg.duration * cfg.sample_rate
    if n > MAX_SIM_SAMPLES:
        raise InputError(f"duration {cfg.duration:g} s at sample_rate {cfg.sample_rate:g} Hz "
                         f"would be {n:.3g} samples; at most {MAX_SIM_SAMPLES:g} are simulated")
    if n < MIN_SAMPLES:
        raise InputError(f"duration {cfg.duration:g} s at sample_rate {cfg.sample_rate:g} Hz "
                         f"would be {n:.3g} samples; at least {MIN_SAMPLES} are needed")
    f_n = math.sqrt(cfg.k / cfg.mass) / TWO_PI
    if not f_n < cfg.sample_rate / 2:
        raise InputError(f"natural frequency {f_n:g} Hz is not below the Nyquist frequency "
                         f"{cfg.sample_rate / 2:g} Hz of sample_rate {cfg.sample_rate:g} Hz")
    if not 0 <= cfg.jitter <= 1:
        raise InputError(f"jitter must be a coefficient of variation in [0, 1], got {cfg.jitter:g}")
    if not 0 <= cfg.timestamp_jitter <= MAX_TIMESTAMP_JITTER:
        raise InputError(f"timestamp_jitter must be a fraction of the sample interval in "
                         f"[0, {MAX_TIMESTAMP_JITTER:g}], got {cfg.timestamp_jitter:g}")
    if abs(cfg.tilt_deg) > 90:
        raise InputError(f"tilt_deg must be an angle in [-90, 90] degrees, got {cfg.tilt_deg:g}")
    if abs(cfg.azimuth_deg) > 360:
        raise InputError(f"azimuth_deg must be an angle in [-360, 360] degrees, "
                         f"got {cfg.azimuth_deg:g}")
    if abs(cfg.u0) > MAX_U0:
        raise InputError(f"u0 must be a displacement in [0, {MAX_U0:g}] m, got {cfg.u0:g}")
    for name in ("noise_density", "flicker"):
        if getattr(cfg, name) > MAX_NOISE_DENSITY:
            raise InputError(f"{name} = {getattr(cfg, name):g} µg/√Hz is beyond the limit of "
                             f"{MAX_NOISE_DENSITY:g}")
    for name, value in (("bias", max(abs(b) for b in cfg.bias)), ("drift", cfg.drift),
                        ("quantization", cfg.quantization)):
        if value > MAX_ACCEL:
            raise InputError(f"{name} = {value:g} m/s² is beyond the limit of {MAX_ACCEL:g} m/s²")
    hi = _GAP_LENGTH[1]
    if cfg.gaps * (hi + 1) > int(n) // 2:
        raise InputError(f"gaps = {cfg.gaps} gaps of up to {hi} samples do not fit into a "
                         f"recording of about {int(n)} samples")


#: Named realistic configurations (see :func:`preset`).
PRESETS: dict[str, SimulationConfig] = {
    # Seed paper: 5.3 kg on a spring at 1.72 Hz, u0 = 4 cm, c ≈ 0.2 N·s/m, phone at 500 Hz, 60 s.
    "paper": SimulationConfig(
        mass=5.3, k=_PAPER_K, c=0.2, u0=0.04, duration=60.0, sample_rate=500.0,
        jitter=0.01, gaps=0, noise_density=150.0, bias=(0.012, -0.021, 0.034), drift=0.005,
        quantization=0.0012, tilt_deg=5.0, azimuth_deg=30.0, main_axis="y", gravity=False,
        handheld=3.0, catch=False, seed=0,
    ),
    # A phone lying on a light plate on a soft spring, phyphox "with g" at 100 Hz.
    "phone": from_modal(
        0.33, 0.9, 0.01, u0=0.03, duration=45.0, sample_rate=100.0, jitter=0.07, gaps=4,
        noise_density=250.0, bias=(0.08, -0.12, 0.15), drift=0.02, quantization=0.0024,
        tilt_deg=12.0, azimuth_deg=60.0, main_axis="z", gravity=True, handheld=4.0,
        catch=True, seed=0,
    ),
}


def preset(name: str, **overrides: Any) -> SimulationConfig:
    """The preset ``name`` from :data:`PRESETS` with ``overrides`` applied (physical k, c stay as set)."""
    try:
        base = PRESETS[name]
    except KeyError:
        choices = ", ".join(sorted(PRESETS))
        raise InputError(f"unknown preset {name!r}; choose one of {choices}") from None
    return _build(**{**dataclasses.asdict(base), **overrides})


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


def _direction(cfg: SimulationConfig) -> np.ndarray:
    """Unit vector (x, y, z) of the motion in the phone frame."""
    i = _AXES.index(cfg.main_axis)
    tilt, az = math.radians(cfg.tilt_deg), math.radians(cfg.azimuth_deg)
    d = np.zeros(3)
    d[i] = math.cos(tilt)
    d[(i + 1) % 3] = math.sin(tilt) * math.cos(az)
    d[(i + 2) % 3] = math.sin(tilt) * math.sin(az)
    return d


def _noise_sigma(cfg: SimulationConfig) -> float:
    """White-noise standard deviation per sample [m/s²]."""
    return cfg.noise_density * 1e-6 * STANDARD_GRAVITY * math.sqrt(cfg.sample_rate / 2.0)


def _truth(cfg: SimulationConfig, t_catch: float | None, direction: np.ndarray) -> dict[str, Any]:
    """JSON-safe truth of ``cfg``."""
    p, omega_d = to_decay(cfg.c, cfg.k, cfg.mass)
    with np.errstate(divide="ignore"):  # Q = 1/(2ζ) is infinite for c = 0; it is not reported
        derived = {name: float(v) for name, v in quantities(p, omega_d, cfg.mass).items()}
    config = {k: v.item() if isinstance(v, np.generic) else v for k, v in dataclasses.asdict(cfg).items()}
    config["bias"] = list(cfg.bias)
    return {
        "mass": float(cfg.mass),
        "c": float(cfg.c),
        "k": float(cfg.k),
        "u0": float(cfg.u0),
        "zeta": derived["zeta"],
        "f_n": derived["f_n"],
        "f_d": derived["f_d"],
        "p": derived["p"],
        "omega_n": derived["omega_n"],
        "omega_d": float(omega_d),
        "delta": derived["delta"],
        "envelope_amplitude": float(cfg.u0 * derived["omega_n"] / omega_d),
        "phase": float(math.atan2(derived["p"], omega_d)),
        "t_release": float(cfg.handheld),
        "t_catch": t_catch,
        "direction": [float(x) for x in direction],
        "noise_sigma": _noise_sigma(cfg),
        "config": config,
        "dampfit_version": __version__,
    }



def envelope_at(truth: dict[str, Any], t) -> float | np.ndarray:
    """Displacement envelope ``U·e^{−p(t − t_release)}`` [m] at time ``t`` [s] (valid between release and catch)."""
    elapsed = np.asarray(t, dtype=float) - truth["t_release"]
    env = truth["envelope_amplitude"] * np.exp(-truth["p"] * elapsed)
    return float(env) if np.ndim(env) == 0 else env


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
    lo, hi = _GAP_LENGTH
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
    t_catch = _catch_time(cfg) if cfg.catch else None
    end_free = t_catch if t_catch is not None else math.inf
    free = (t >= t_release) & (t < end_free)
    held = ~free

    # acceleration along the motion direction
    along = np.zeros(t.size)
    along[free] = free_decay(t[free] - t_release, cfg.mass, cfg.c, cfg.k, cfg.u0)[2]
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
    accel += _noise_sigma(cfg) * rng_noise.standard_normal(accel.shape)
    accel += _flicker_noise(rng_flicker, t.size, cfg)
    if cfg.quantization > 0:
        accel = np.round(accel / cfg.quantization) * cfg.quantization

    recording = Recording(
        time=_stamps(rng_stamp, t, cfg),
        accel=accel,
        axes=_AXES,
        format="simulated",
        gravity_removed=not cfg.gravity,
        notes=(
            f"simulated free decay: m = {cfg.mass:g} kg, c = {cfg.c:g} N·s/m, k = {cfg.k:g} N/m, "
            f"u0 = {cfg.u0:g} m, seed {cfg.seed}",
        ),
    )
    return recording, _truth(cfg, t_catch, direction)


# -- campaigns: several recordings of one system ----------------------------------------

#: Most tests in one simulated campaign (the recordings are all held in memory).
MAX_TESTS = 100
#: Standard normal 95 % quantile: the 90 % predictive interval is median·e^{±1.645·σ}.
_Z95 = 1.6448536269514722
#: Largest between-test spread [1] of ln c: a relative sd far beyond any repeated test.
MAX_C_SPREAD = 2.0


def campaign(
    base: SimulationConfig,
    *,
    n_tests: int,
    c_spread: float = 0.0,
    added_mass: Sequence[float] | None = None,
    amplitudes: Sequence[float] | None = None,
    added_mass_sd: float = 0.0,
    seed: int = 0,
) -> tuple[list[Recording], dict[str, Any]]:
    """A simulated test campaign: ``n_tests`` recordings of one damper, and its truth.

    Test ``i`` (1-based) is :func:`simulate` of ``base`` with

    * the same stiffness ``k = base.k`` [N/m];
    * mass ``m_i = base.mass + Δm_i`` [kg], ``Δm_i = added_mass[i-1]`` (0 when not given):
      the added-mass method, ``ω_i² = k/(m0 + Δm_i)`` with ``m0 = base.mass``; with
      ``added_mass_sd`` = s [kg] > 0 the stated masses are what a scale read: the mass
      actually added is ``Δm_i + s·e_i``, ``e_i`` standard normal (a stated 0, the bare
      system, stays exactly 0) — the error model the campaign analysis assumes;
    * damping ``c_i = base.c·exp(c_spread·z_i)`` [N·s/m], ``z_i`` standard normal: log-normal
      with median ``base.c`` and between-test sd ``c_spread`` of ``ln c`` (≈ the relative sd
      for small spreads); k and m_i are fixed, so ``c_spread`` is also the sd of ``ln p``;
    * release displacement ``u0_i = amplitudes[i-1]`` [m] (``base.u0`` when not given);
    * its own noise seed.

    All randomness comes from ``numpy.random.SeedSequence(seed)`` (``base.seed`` is ignored):
    its first child draws the ``z_i``, the next ``n_tests`` children seed the tests and the
    last draws the ``e_i``, so changing ``c_spread``, the masses, their sd or the amplitudes
    changes neither the noise nor the standardised draws.

    Returns the recordings and a JSON-safe truth dict: the population ``c`` (median) [N·s/m],
    ``k`` [N/m], ``mass`` (m0) [kg], ``zeta`` and ``f_n`` [Hz] of the bare system, the
    per-test lists ``c_tests``, ``added_mass``, ``mass_tests``, ``u0_tests``, ``zeta_tests``,
    ``f_n_tests``, ``p_tests``, ``seeds`` (``added_mass`` the stated masses,
    ``added_mass_true`` those simulated, ``added_mass_sd`` s), the spread ``c_spread``
    (= ``tau_p``, the true between-test sd of ln p; ``tau_omega`` = 0: k and the masses are fixed), ``line``: the
    added-mass line ``1/ω_n² = (m0 + Δm)/k`` as ``intercept`` = m0/k [s²] and ``slope`` = 1/k
    [s²/kg], ``predictive_c`` = [q05, q95] of the true population of c [N·s/m] (and
    ``predictive_zeta`` without added masses, else None), ``tests`` (each test's
    :func:`simulate` truth) and ``design`` (``"hierarchical"`` or ``"added-mass"``).
    Bad input raises :class:`InputError` (one line).
    """
    if not isinstance(base, SimulationConfig):
        raise InputError(f"campaign needs a SimulationConfig, got {type(base).__name__}")
    n = _check_count(n_tests)
    spread = _check_spread(c_spread)
    seed = _check_seed(seed)
    dm = _per_test("added_mass", added_mass, n, 0.0, lo=0.0, hi=MAX_MASS, unit="kg")
    u0 = _per_test("amplitudes", amplitudes, n, base.u0, lo=0.0, hi=MAX_U0, unit="m")
    dm_sd = _check_added_mass_sd(added_mass_sd, added_mass is not None)
    total = n * base.duration * base.sample_rate
    if total > MAX_SIM_SAMPLES:
        raise InputError(f"{n} tests of {base.duration:g} s at {base.sample_rate:g} Hz would be "
                         f"{total:.3g} samples; at most {MAX_SIM_SAMPLES:g} are simulated")

    children = np.random.SeedSequence(seed).spawn(n + 2)
    z = np.random.default_rng(children[0]).standard_normal(n)
    c_tests = [float(base.c * math.exp(spread * zi)) for zi in z]
    seeds = [int(child.generate_state(1, dtype=np.uint32)[0]) for child in children[1:n + 1]]
    e = np.random.default_rng(children[n + 1]).standard_normal(n)
    dm_true = [x + dm_sd * ei if x > 0 else 0.0 for x, ei in zip(dm, e)]
    for i, x in enumerate(dm_true):
        if x < 0:
            raise InputError(f"test {i + 1}: the simulated added mass {dm[i]:g} kg "
                             f"{dm_sd * e[i]:+.3g} kg is negative; give a smaller added_mass_sd")
    configs = [_test_config(base, i, c_tests[i], dm_true[i], u0[i], seeds[i], spread)
               for i in range(n)]
    for cfg in configs:
        check_limits(cfg)

    recordings, truths = [], []
    for i, cfg in enumerate(configs):
        rec, truth = recording(cfg)
        note = (f"simulated campaign test {i + 1} of {n}: added mass {dm[i]:g} kg, "
                f"c_spread {spread:g}, campaign seed {seed}")
        recordings.append(dataclasses.replace(rec, notes=rec.notes + (note,)))
        truths.append(truth)
    out = _campaign_truth(base, spread, seed, dm, added_mass is not None, truths)
    return recordings, {**out, "added_mass_true": [float(x) for x in dm_true],
                        "added_mass_sd": dm_sd}


def _check_added_mass_sd(sd: Any, added: bool) -> float:
    """``added_mass_sd`` [kg] as a finite float in [0, MAX_MASS]; > 0 needs added masses."""
    if (isinstance(sd, bool) or not isinstance(sd, (int, float, np.integer, np.floating))
            or not math.isfinite(sd) or not 0 <= sd <= MAX_MASS):
        raise InputError(f"added_mass_sd must be a number in [0, {MAX_MASS:g}] kg, got {sd!r}")
    if sd > 0 and not added:
        raise InputError("added_mass_sd needs added masses (added_mass)")
    return float(sd)


def _check_count(n_tests: Any) -> int:
    """``n_tests`` as an int in [1, MAX_TESTS]."""
    if (isinstance(n_tests, bool) or not isinstance(n_tests, (int, np.integer))
            or not 1 <= n_tests <= MAX_TESTS):
        raise InputError(f"n_tests must be an integer from 1 to {MAX_TESTS}, got {n_tests!r}")
    return int(n_tests)


def _check_spread(c_spread: Any) -> float:
    """``c_spread`` [1] as a finite float in [0, MAX_C_SPREAD]."""
    if (isinstance(c_spread, bool) or not isinstance(c_spread, (int, float, np.integer, np.floating))
            or not math.isfinite(c_spread) or not 0 <= c_spread <= MAX_C_SPREAD):
        raise InputError(f"c_spread must be a number in [0, {MAX_C_SPREAD:g}] (the sd of ln c "
                         f"between tests), got {c_spread!r}")
    return float(c_spread)


def _check_seed(seed: Any) -> int:
    """``seed`` as a non-negative int."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _per_test(name: str, values: Any, n: int, default: float, *, lo: float, hi: float,
              unit: str) -> list[float]:
    """One float per test [unit] in [lo, hi]: ``values`` checked, or ``default`` n times."""
    if values is None:
        return [float(default)] * n
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
        raise InputError(f"{name} must be a sequence of {n} numbers [{unit}], got {values!r}")
    if len(values) != n:
        raise InputError(f"{name} gives {len(values)} value(s) for {n} test(s); give one per test")
    out = []
    for i, v in enumerate(values):
        if (isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating))
                or not math.isfinite(v) or not lo <= v <= hi):
            raise InputError(f"{name}[{i}] must be a number in [{lo:g}, {hi:g}] {unit}, got {v!r}")
        out.append(float(v))
    return out


def _test_config(base: SimulationConfig, i: int, c: float, dm: float, u0: float, seed: int,
                 spread: float) -> SimulationConfig:
    """Config of test ``i`` (0-based); an overdamped draw is one line naming the test."""
    mass = base.mass + dm
    if mass > MAX_MASS:
        raise InputError(f"test {i + 1}: mass {base.mass:g} + {dm:g} kg is beyond the limit of "
                         f"{MAX_MASS:g} kg")
    c_crit = float(critical_damping(base.k, mass))
    if c >= c_crit:
        raise InputError(f"test {i + 1}: c = {c:g} N·s/m drawn with c_spread {spread:g} is "
                         f"overdamped (c >= 2*sqrt(k*m) = {c_crit:g} N·s/m); lower c or c_spread")
    return dataclasses.replace(base, mass=mass, c=c, u0=u0, seed=seed)


def _campaign_truth(base: SimulationConfig, spread: float, seed: int, dm: list[float],
                    added: bool, truths: list[dict[str, Any]]) -> dict[str, Any]:
    """JSON-safe truth of a campaign (see :func:`campaign`)."""
    p, omega_d = to_decay(base.c, base.k, base.mass)
    with np.errstate(divide="ignore"):
        bare = {name: float(v) for name, v in quantities(p, omega_d, base.mass).items()}
    wide = math.exp(_Z95 * spread)
    return {
        "kind": "campaign",
        "design": "added-mass" if added else "hierarchical",
        "n_tests": len(truths),
        "c": float(base.c),
        "k": float(base.k),
        "mass": float(base.mass),
        "zeta": bare["zeta"],
        "f_n": bare["f_n"],
        "p": bare["p"],
        "c_spread": spread,
        "tau_p": spread,
        "tau_omega": 0.0,
        "line": {"intercept": float(base.mass / base.k), "slope": float(1.0 / base.k)},
        "predictive_c": [float(base.c / wide), float(base.c * wide)],
        "predictive_zeta": [bare["zeta"] / wide, bare["zeta"] * wide] if not added else None,
        "c_tests": [t["c"] for t in truths],
        "added_mass": list(dm),
        "mass_tests": [t["mass"] for t in truths],
        "u0_tests": [t["u0"] for t in truths],
        "zeta_tests": [t["zeta"] for t in truths],
        "f_n_tests": [t["f_n"] for t in truths],
        "p_tests": [t["p"] for t in truths],
        "seed": seed,
        "seeds": [t["config"]["seed"] for t in truths],
        "tests": truths,
        "dampfit_version": __version__,
    }
