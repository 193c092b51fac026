"""Simulated test campaigns: several recordings of one damper with known truth
(:func:`campaign`): between-test spread of c, added masses with a scale error, amplitudes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dampfit._meta import __version__
from dampfit.errors import InputError
from dampfit.io.recording import Recording
from dampfit.physics import MAX_MASS, critical_damping, quantities, to_decay
from dampfit.simulate.config import (MAX_SIM_SAMPLES, MAX_U0, SimulationConfig,
                                     check_limits)
from dampfit.simulate.synthesis import recording

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

    Test ``i`` (1-based) is :func:`~dampfit.simulate.synthesis.recording` of ``base`` with

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
    :func:`~dampfit.simulate.synthesis.recording` truth) and ``design`` (``"hierarchical"`` or ``"added-mass"``).
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

    configs, dm_true = _test_configs(base, spread, seed, dm, dm_sd, u0)

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


def _test_configs(base: SimulationConfig, spread: float, seed: int, dm: list[float],
                  dm_sd: float, u0: list[float]) -> tuple[list[SimulationConfig], list[float]]:
    """Each test's config and the added masses [kg] actually simulated, drawn as
    :func:`campaign` says (the ``z_i``, the tests' seeds and the ``e_i`` from the children of
    ``SeedSequence(seed)``); each config within :func:`check_limits`."""
    n = len(dm)
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
    return configs, dm_true


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
