"""Single-degree-of-freedom relations between the physical and the decay parametrisations.

The viscous free decay of ``m·ü + c·u̇ + k·u = 0`` (seed paper, eq. 22 with F = 0) is,
for ζ < 1,

    u(t) = U·exp(−p·t)·cos(ω_d·t + φ),

with decay rate ``p = c/(2m)`` [1/s] (paper eq. 3), natural angular frequency
``ω_n = √(k/m)`` [rad/s] and damped angular frequency ``ω_d = √(ω_n² − p²)``. (The paper's
eq. 2 writes ``q = √((c/2m)² − k/m)``, which is imaginary for an underdamped system; the
real damped frequency is ``√(k/m − (c/2m)²)``.) Derived quantities:

* damping ratio ζ = p/ω_n = c/c_crit, with critical damping c_crit = 2√(k·m) (paper eq. 14);
* logarithmic decrement δ = p·T_d = 2π·p/ω_d = 2πζ/√(1−ζ²) (paper eq. 11);
* quality factor Q = 1/(2ζ).

:func:`quantities` is the one place where the physical quantities of an analysis are
computed from (p, ω_d) — least-squares values, posterior draws, baselines, estimators, the
Cramér–Rao bound and the simulator's truth all call it; :func:`check_mass` is the one check
of a mass [kg] and its standard uncertainty [kg], and :data:`UNITS` the one table of units.

All functions are plain NumPy and broadcast over arrays, so they convert posterior draws
as well as point estimates; :func:`quantities` also accepts JAX arrays (it uses arithmetic
operators only), so the Cramér–Rao bound differentiates it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dampfit.errors import InputError

#: Unit of every quantity dampfit reports (ASCII, as written to ``summary.json``).
UNITS = {
    "p": "1/s", "omega_d": "rad/s", "omega_n": "rad/s", "f_n": "Hz", "f_d": "Hz",
    "zeta": "1", "delta": "1", "Q": "1", "c": "N s/m", "k": "N/m", "c_crit": "N s/m",
    "u0": "m", "mass": "kg",
}

TWO_PI = 2.0 * np.pi


def _real(x):
    """``x`` as a float array, leaving JAX arrays (and tracers) to JAX."""
    if isinstance(x, (np.ndarray, np.generic)) or not hasattr(x, "shape"):
        return np.asarray(x, dtype=float)
    return x


def _sqrt(x):
    return np.sqrt(x) if isinstance(x, (np.ndarray, np.generic)) else x ** 0.5


def damping_coefficient(mass, p):
    """Viscous damping coefficient ``c = 2·m·p`` [N·s/m] from the mass [kg] and the decay
    rate (or a local decay rate ρ(a) of a nonlinear law) ``p`` [1/s] (paper eq. 3)."""
    return 2.0 * mass * p


def stiffness(mass, omega_n):
    """Stiffness ``k = m·ω_n²`` [N/m] from the mass [kg] and ``ω_n`` [rad/s]."""
    return mass * omega_n**2


def quantities(p, omega_d=None, mass=None, *, omega_n=None,
               accel_amplitude=None) -> dict[str, np.ndarray]:
    """Every reported physical quantity from decay rate ``p`` [1/s] and damped angular
    frequency ``omega_d`` [rad/s] — point values or arrays of draws (broadcast together).

    Or from ``p`` and the natural angular frequency ``omega_n`` [rad/s] instead of ``omega_d``
    (a campaign's population draws, :mod:`dampfit.campaign`): then ω_d = √(ω_n² − p²), NaN
    where p ≥ ω_n (and with it f_d and δ), while p, ζ, f_n, Q, c, k and c_crit stay finite.

    Mass-free (identified by the recording alone):

    * ``omega_n`` [rad/s]: ω_n² = p² + ω_d² (the decay's pole is −p ± i·ω_d, |pole| = ω_n);
    * ``f_n``, ``f_d`` [Hz]: ω_n/2π, ω_d/2π;
    * ``zeta`` [1]: ζ = p/ω_n (from p = ζ·ω_n);
    * ``delta`` [1]: logarithmic decrement δ = 2π·p/ω_d (paper eq. 11);
    * ``Q`` [1]: quality factor 1/(2ζ).

    With ``mass`` m [kg] (a value or draws): ``c`` = 2·m·p [N·s/m] (paper eq. 3),
    ``k`` = m·ω_n² [N/m] (ω_n² = k/m) and ``c_crit`` = 2·m·ω_n = 2√(k·m) [N·s/m] (paper
    eq. 14).

    With ``accel_amplitude`` [m/s²], the acceleration envelope amplitude √(A² + B²) at the
    window start (quadratures of the model's acceleration e^{−pτ}(A·cos ω_dτ + B·sin ω_dτ),
    filter gain removed): ``u0`` = √(A² + B²)/ω_n² [m] (eq. M2 of
    :mod:`dampfit.model.viscous`: the displacement is the acceleration divided by
    −(−p + iω_d)², of modulus ω_n²).

    ``p`` and ``omega_d`` are returned as given (as float arrays). Q is infinite for p = 0.
    """
    if (omega_d is None) == (omega_n is None):
        raise TypeError("quantities() takes exactly one of omega_d and omega_n")
    p = _real(p)
    if omega_d is not None:
        omega_d = _real(omega_d)
        wn2 = p**2 + omega_d**2
        omega_n = _sqrt(wn2)
    else:
        omega_n = _real(omega_n)
        wn2 = omega_n**2
        with np.errstate(invalid="ignore"):
            omega_d = np.sqrt(np.where(wn2 > p**2, wn2 - p**2, np.nan))
    zeta = p / omega_n
    out = {
        "p": p,
        "omega_d": omega_d,
        "omega_n": omega_n,
        "f_n": omega_n / TWO_PI,
        "f_d": omega_d / TWO_PI,
        "zeta": zeta,
        "delta": TWO_PI * p / omega_d,
        "Q": 0.5 / zeta,
    }
    if mass is not None:
        m = _real(mass)
        out["c"] = damping_coefficient(m, p)
        out["k"] = m * wn2
        out["c_crit"] = 2.0 * m * omega_n
    if accel_amplitude is not None:
        out["u0"] = _real(accel_amplitude) / wn2
    return out



def to_decay(c, k, mass) -> tuple[np.ndarray, np.ndarray]:
    """Decay rate ``p`` [1/s] and damped frequency ``ω_d`` [rad/s] from ``c`` [N·s/m], ``k`` [N/m], ``m`` [kg].

    Raises ``ValueError`` if the system is not underdamped (c ≥ c_crit has no oscillation).
    """
    c, k, m = (np.asarray(x, dtype=float) for x in (c, k, mass))
    p = c / (2.0 * m)
    wn2 = k / m
    if np.any(p**2 >= wn2):
        raise ValueError("the system is critically damped or overdamped (c >= 2*sqrt(k*m))")
    return p, np.sqrt(wn2 - p**2)


def zeta_from_log_decrement(delta):
    """Damping ratio from the logarithmic decrement, ζ = δ/√(4π² + δ²) (paper eq. 13)."""
    delta = np.asarray(delta, dtype=float)
    return delta / np.sqrt(4.0 * np.pi**2 + delta**2)


def log_decrement_from_zeta(zeta):
    """Logarithmic decrement from the damping ratio, δ = 2πζ/√(1−ζ²) (paper eq. 11)."""
    zeta = np.asarray(zeta, dtype=float)
    return TWO_PI * zeta / np.sqrt(1.0 - zeta**2)


def critical_damping(k, mass):
    """Critical damping ``c_crit = 2√(k·m)`` [N·s/m] (paper, after eq. 14)."""
    return 2.0 * np.sqrt(np.asarray(k, dtype=float) * np.asarray(mass, dtype=float))


#: Largest oscillating or added mass dampfit accepts [kg] (simulated, analysed, studied; the
#: library and the CLI alike): far above any spring–mass test, far below overflow.
MAX_MASS = 1e6


@dataclass(frozen=True)
class Mass:
    """An oscillating mass ``value`` [kg] (None: not given) and its standard uncertainty
    ``sd`` [kg] (None = 0), checked once, on construction, and kept as floats.

    A mass must be a finite number > 0 and at most :data:`MAX_MASS`; ``sd`` a finite number
    ≥ 0 and at most half the mass (the mass prior is a normal truncated at 0: a wider one is
    no longer a measured mass); a non-zero ``sd`` needs a mass. Raises :class:`InputError`
    with one line otherwise.
    """

    value: float | None = None
    sd: float | None = 0.0

    def __post_init__(self) -> None:
        mass, mass_sd = self.value, self.sd
        sd = 0.0 if mass_sd is None else as_float(mass_sd)
        if mass is None:
            if sd != 0.0:  # NaN too
                raise InputError("mass_sd was given without mass (--mass-sd without --mass)")
            object.__setattr__(self, "sd", 0.0)
            return
        m = as_float(mass)
        if not (math.isfinite(m) and m > 0.0):
            raise InputError("mass must be positive: the oscillating mass must be a positive "
                             f"number of kilograms, got {mass!r}")
        if m > MAX_MASS:
            raise InputError(f"mass = {m:g} kg is beyond the limit of {MAX_MASS:g} kg")
        if not (math.isfinite(sd) and sd >= 0.0):
            raise InputError(f"mass_sd, the mass standard deviation, must be ≥ 0 kg, got "
                             f"{mass_sd!r}")
        if sd > 0.5 * m:
            raise InputError(f"mass standard deviation {sd:g} kg is more than half the mass "
                             f"{m:g} kg")
        object.__setattr__(self, "value", m)
        object.__setattr__(self, "sd", sd)


def as_mass(mass, mass_sd=None) -> Mass:
    """``mass`` itself when it is a :class:`Mass` (checked when it was made, so not again;
    ``mass_sd`` is then ignored), else ``Mass(mass, mass_sd)``, checked now."""
    return mass if isinstance(mass, Mass) else Mass(mass, mass_sd)


def check_mass(mass, mass_sd=None) -> tuple[float | None, float]:
    """The one check of an oscillating mass ``mass`` [kg] and its standard uncertainty
    ``mass_sd`` [kg] (:class:`Mass`); returns ``(mass, mass_sd)`` as floats (``(None, 0.0)``
    without a mass)."""
    checked = Mass(mass, mass_sd)
    return checked.value, checked.sd


def as_float(x) -> float:
    """``float(x)`` for a real number, NaN for anything else (a string, a bool, an array)."""
    if isinstance(x, bool):
        return float("nan")
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")
