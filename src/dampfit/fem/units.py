"""Consistent unit systems of FEM solvers and the conversion of SI values into them.

FEM codes have no units: the user picks base units for length, time and mass and every other
quantity follows from them (force = mass·length/time²). A unit system is therefore fully
defined by the size of its three base units in SI; the factor that turns an SI value into the
system is derived from the quantity's dimension L^a·T^b·M^c as

    value_system = value_SI / (ℓ^a · τ^b · μ^c),

with ℓ [m], τ [s], μ [kg] the sizes of the system's length, time and mass units. Worked
examples (what :func:`factor` returns):

=================  ==========  ========================  ======================  ====================
quantity           dimension   SI (m, s, kg, N)          mm-ms-kg (kN)           mm-s-t (N)
=================  ==========  ========================  ======================  ====================
mass m             M           1 kg                      1 kg                    1e-3 t
stiffness k        M·T⁻²       1 N/m                     1e-6 kN/mm              1e-3 N/mm
damping c          M·T⁻¹       1 N·s/m                   1e-3 kN·ms/mm           1e-3 N·s/mm
length u           L           1 m                       1e3 mm                  1e3 mm
time t             T           1 s                       1e3 ms                  1 s
force F            M·L·T⁻²     1 N                       1e-3 kN                 1 N
acceleration g     L·T⁻²       9.80665 m/s²              9.80665e-3 mm/ms²       9806.65 mm/s²
=================  ==========  ========================  ======================  ====================

For example c in mm-ms-kg: 1 N·s/m = 1 kg/s = 1 kg / (10³ ms) = 10⁻³ kg/ms, and the system's
c unit kN·ms/mm = (kg·mm/ms²)·ms/mm = kg/ms, so 1 N·s/m = 10⁻³ kN·ms/mm. Because every
factor comes from the same (ℓ, τ, μ), ω_n = √(k/m) and ζ = c/(2√(k·m)) computed in any system
are the same physical quantities (ω_n scaled by τ, ζ unchanged); the tests check this.
"""

from __future__ import annotations

from dataclasses import dataclass

from dampfit.errors import InputError

#: Standard acceleration of gravity [m/s²] (CGPM 1901).
STANDARD_GRAVITY = 9.80665

#: Dimension exponents (length, time, mass) of the quantities the decks use.
DIMENSIONS: dict[str, tuple[int, int, int]] = {
    "length": (1, 0, 0),
    "time": (0, 1, 0),
    "mass": (0, 0, 1),
    "force": (1, -2, 1),
    "stiffness": (0, -2, 1),
    "damping": (0, -1, 1),
    "velocity": (1, -1, 0),
    "acceleration": (1, -2, 0),
    "frequency": (0, -1, 0),
}


@dataclass(frozen=True)
class UnitSystem:
    """A consistent unit system: sizes of its base units in SI and their names.

    Attributes
    ----------
    name : str
        Name used on the command line (``SI``, ``mm-ms-kg``, ``mm-s-t``).
    length, time, mass : float
        Size of the length [m], time [s] and mass [kg] unit.
    length_label, time_label, mass_label, force_label : str
        Unit names; ``force_label`` names mass·length/time² (checked by the tests).
    """

    name: str
    length: float
    time: float
    mass: float
    length_label: str
    time_label: str
    mass_label: str
    force_label: str

    def label(self, quantity: str) -> str:
        """Unit name of ``quantity`` (a key of :data:`DIMENSIONS`) in this system."""
        L, T, M, F = self.length_label, self.time_label, self.mass_label, self.force_label
        return {
            "length": L, "time": T, "mass": M, "force": F,
            "stiffness": f"{F}/{L}", "damping": f"{F}*{T}/{L}", "velocity": f"{L}/{T}",
            "acceleration": f"{L}/{T}^2", "frequency": f"1/{T}",
        }[quantity]


#: The unit systems ``dampfit export --units`` offers.
UNIT_SYSTEMS: dict[str, UnitSystem] = {
    "SI": UnitSystem("SI", 1.0, 1.0, 1.0, "m", "s", "kg", "N"),
    "mm-ms-kg": UnitSystem("mm-ms-kg", 1e-3, 1e-3, 1.0, "mm", "ms", "kg", "kN"),
    "mm-s-t": UnitSystem("mm-s-t", 1e-3, 1.0, 1e3, "mm", "s", "t", "N"),
}


def get(name: str) -> UnitSystem:
    """The unit system called ``name``; :class:`InputError` names the choices otherwise."""
    try:
        return UNIT_SYSTEMS[name]
    except KeyError:
        raise InputError(f"unknown unit system {name!r}; choose one of "
                         f"{', '.join(UNIT_SYSTEMS)}") from None


def factor(quantity: str, system: UnitSystem | str) -> float:
    """Factor that turns an SI value of ``quantity`` into ``system``: 1/(ℓ^a·τ^b·μ^c)."""
    system = get(system) if isinstance(system, str) else system
    a, b, c = DIMENSIONS[quantity]
    return 1.0 / (system.length**a * system.time**b * system.mass**c)


def to_system(value: float, quantity: str, system: UnitSystem | str) -> float:
    """``value`` (SI) of ``quantity`` expressed in ``system``."""
    return float(value) * factor(quantity, system)
