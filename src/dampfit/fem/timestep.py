"""Time steps whose integration error is negligible, and the period errors they imply.

A free decay of ω_n [rad/s] integrated with a fixed step Δt is, for the two integrators the
decks use, an exactly undamped-numerically oscillation whose period is slightly wrong
(Hughes 1987, *The Finite Element Method*, §9.3; Chopra, *Dynamics of Structures*, §5.5):

* Newmark average acceleration (γ = 1/2, β = 1/4; OpenSees, CalculiX with α = 0): no
  numerical damping and a period *elongation*
  ``ω̄Δt = 2·atan(ωΔt/2)``, i.e. ``T̄/T − 1 = (ωΔt/2)/atan(ωΔt/2) − 1 ≈ (ωΔt)²/12``;
* central difference (LS-DYNA explicit): no numerical damping and a period *shortening*
  ``ω̄Δt = 2·asin(ωΔt/2)``, i.e. ``T̄/T − 1 ≈ −(ωΔt)²/24``.

The phase error grows linearly with time, ``Δφ(D) ≈ ω·D·|T̄/T − 1|`` after a duration D, so a
step fine enough for one period is not fine enough for a hundred. :func:`choose` takes the
larger of two demands: at least 200 steps per period (period error < 1e-4) and a phase error
below ``phase_budget`` [rad] at the end of the run; it then rounds Δt down so that an output
interval holds a whole number of steps.
"""

from __future__ import annotations

import math

#: Largest phase error [rad] a run may accumulate by its end.
PHASE_BUDGET = 1e-3
#: Fewest steps per natural period.
MIN_STEPS_PER_PERIOD = 200


def newmark_period_error(omega: float, dt: float) -> float:
    """Relative period elongation ``T̄/T − 1`` [1] of Newmark average acceleration.

    ``omega`` [rad/s], ``dt`` [s]: ``(ωΔt/2)/atan(ωΔt/2) − 1`` (≈ (ωΔt)²/12).
    """
    x = 0.5 * omega * dt
    return x / math.atan(x) - 1.0 if x > 0 else 0.0


def central_difference_period_error(omega: float, dt: float) -> float:
    """Relative period error ``T̄/T − 1`` [1] (negative) of the central difference method.

    ``(ωΔt/2)/asin(ωΔt/2) − 1`` (≈ −(ωΔt)²/24); stable only for ωΔt < 2.
    """
    x = 0.5 * omega * dt
    if x >= 1.0:
        raise ValueError("central difference is unstable for omega*dt >= 2")
    return x / math.asin(x) - 1.0 if x > 0 else 0.0


def choose(omega: float, duration: float, output_dt: float,
           phase_budget: float = PHASE_BUDGET) -> float:
    """Fixed time step [s] for a free decay of ``omega`` [rad/s] over ``duration`` [s].

    ``Δt_max = min(T/200, √(12·φ/(ω³·D)))`` keeps the period error below (2π/200)²/12 ≈ 8e-5
    and the phase error at the end below ``phase_budget`` φ [rad]; the result is
    ``output_dt/n`` with the smallest integer n that makes it ≤ Δt_max.
    """
    period = 2.0 * math.pi / omega
    dt_max = min(period / MIN_STEPS_PER_PERIOD,
                 math.sqrt(12.0 * phase_budget / (omega**3 * duration)))
    return output_dt / math.ceil(output_dt / dt_max * (1.0 - 1e-12))
