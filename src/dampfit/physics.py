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

All functions are plain NumPy and broadcast over arrays, so they convert posterior draws
as well as point estimates.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "from_decay",
    "to_decay",
    "zeta_from_log_decrement",
    "log_decrement_from_zeta",
    "critical_damping",
]

TWO_PI = 2.0 * np.pi


def from_decay(p, omega_d, mass=None) -> dict[str, np.ndarray]:
    """Derived quantities from decay rate ``p`` [1/s] and damped frequency ``ω_d`` [rad/s].

    Returns a dict with ``p`` [1/s], ``omega_n`` [rad/s], ``f_n`` and ``f_d`` [Hz], ``zeta`` [1],
    ``delta`` (log decrement) [1], ``Q`` [1] and, if ``mass`` [kg] is given, ``c`` [N·s/m],
    ``k`` [N/m] and ``c_crit`` [N·s/m].
    """
    p = np.asarray(p, dtype=float)
    omega_d = np.asarray(omega_d, dtype=float)
    omega_n = np.sqrt(omega_d**2 + p**2)
    zeta = p / omega_n
    out = {
        "p": p,
        "omega_n": omega_n,
        "f_n": omega_n / TWO_PI,
        "f_d": omega_d / TWO_PI,
        "zeta": zeta,
        "delta": TWO_PI * p / omega_d,
        "Q": 0.5 / zeta,
    }
    if mass is not None:
        m = np.asarray(mass, dtype=float)
        out["c"] = 2.0 * m * p
        out["k"] = m * omega_n**2
        out["c_crit"] = 2.0 * m * omega_n
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
