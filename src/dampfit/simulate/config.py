"""The configuration of a simulated recording: :class:`SimulationConfig` (its fields checked on
construction), the limits every simulation is held to (:func:`check_limits`), the named
:data:`PRESETS` and the modal constructor :func:`from_modal`.

What each field does to the recording is :mod:`dampfit.simulate.synthesis`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from dampfit.errors import InputError
from dampfit.io.recording import STANDARD_GRAVITY
from dampfit.physics import MAX_MASS, check_mass, critical_damping, stiffness

TWO_PI = 2.0 * math.pi
#: The phone axes, in the cyclic order the tilt's azimuth is measured in.
AXES = ("x", "y", "z")
#: Catch: time before the end [s].
_CATCH_BEFORE_END = 1.5
#: Missing samples per gap (inclusive range).
GAP_LENGTH = (2, 10)
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
    modes : sequence of (f_n, zeta, ratio, phase)
        Further modes of the structure after the release (a second bending mode, a pendulum
        swing): natural frequency f_n [Hz], damping ratio ζ [1], acceleration envelope
        amplitude at release relative to the primary (m, k, c) mode's u0·ω_n³/ω_d [1], and
        phase [rad]; each adds R·A₁·e^{−ζω_nτ}·cos(ω_n√(1−ζ²)·τ + φ) along the motion
        (:func:`dampfit.simulate.synthesis.extra_modes`). Empty (the default): one mode, and
        the recording and its truth are exactly those of a one-mode configuration.
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
    modes: tuple = ()

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
        if self.main_axis not in AXES:
            raise InputError(f"main_axis must be one of x, y, z, got {self.main_axis!r}")
        object.__setattr__(self, "bias", _bias_tuple(self.bias))
        object.__setattr__(self, "modes", _modes_tuple(self.modes, self.sample_rate))
        if self.catch and catch_time(self) <= self.handheld:
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


def _modes_tuple(modes: Any, sample_rate: float) -> tuple[tuple[float, float, float, float], ...]:
    """Extra modes as a tuple of (f_n [Hz], ζ [1], ratio [1], phase [rad]) float tuples."""
    try:
        rows = np.asarray(modes, dtype=float) if len(modes) else np.empty((0, 4))
    except (TypeError, ValueError):
        rows = np.empty(0)
    if rows.ndim != 2 or rows.shape[1] != 4:
        raise InputError("modes must be a list of (f_n, zeta, amplitude ratio, phase) "
                         f"tuples, got {modes!r}")
    for f_n, zeta, ratio, phase in rows:
        if not np.all(np.isfinite([f_n, zeta, ratio, phase])):
            raise InputError(f"modes: every value must be finite, got {modes!r}")
        if not 0 < f_n < sample_rate / 2:
            raise InputError(f"modes: f_n = {f_n:g} Hz must be positive and below the Nyquist "
                             f"frequency {sample_rate / 2:g} Hz")
        if not 0 <= zeta < 1 or ratio < 0:
            raise InputError(f"modes: need 0 <= zeta < 1 and amplitude ratio >= 0, "
                             f"got zeta = {zeta:g}, ratio = {ratio:g}")
    return tuple(tuple(float(v) for v in row) for row in rows)


def catch_time(cfg: SimulationConfig) -> float:
    """Time of the catch [s]."""
    return cfg.duration - _CATCH_BEFORE_END


def noise_sigma(cfg: SimulationConfig) -> float:
    """White-noise standard deviation per sample [m/s²]."""
    return cfg.noise_density * 1e-6 * STANDARD_GRAVITY * math.sqrt(cfg.sample_rate / 2.0)


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
    hi = GAP_LENGTH[1]
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
