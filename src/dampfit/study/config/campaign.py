"""The ``[campaign]`` table of a campaign study: its design axes, per-test lists and the joint
analysis' settings (see :mod:`dampfit.study.config` for the file layout).
"""

from __future__ import annotations

from typing import Any

from dampfit._options import DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS
from dampfit.errors import InputError
from dampfit.study.config.fields import number

#: [campaign] settings that may also be [grid] axes (scenario fields), with their kind.
CAMPAIGN_AXES: dict[str, str] = {"tests": "int", "c_spread": "float", "added_mass_fraction": "float"}
#: Per-test lists of [campaign] (scenario fields, one value per test).
CAMPAIGN_LISTS = ("added_mass", "amplitudes")
#: Settings of the joint analysis (not scenario fields), with their defaults.
CAMPAIGN_SETTINGS: dict[str, Any] = {"mass_sd": 0.0, "added_mass_sd": 0.0,
                                     "max_steps": DEFAULT_MAX_STEPS, "min_ess": DEFAULT_MIN_ESS}
#: Every key a [campaign] table may hold.
CAMPAIGN_KEYS = (*CAMPAIGN_AXES, *CAMPAIGN_LISTS, *CAMPAIGN_SETTINGS)
#: Largest added_mass_fraction [1] (added masses up to 100 × the bare mass).
MAX_ADDED_FRACTION = 100.0
#: Bounds of the campaign sampler's max_steps [steps] and min_ess [draws].
MIN_STEPS, MAX_STEPS, MAX_MIN_ESS = 100, 1_000_000, 1e6


def campaign_value(key: str, value: Any, table: str) -> Any:
    """A campaign axis value (:data:`CAMPAIGN_AXES`) checked against the simulator's limits."""
    from dampfit.simulate import MAX_C_SPREAD, MAX_TESTS

    where = f"[{table}] {key}"
    if key == "tests":
        if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= MAX_TESTS:
            raise InputError(f"{where} must be an integer from 2 to {MAX_TESTS} (recordings per "
                             f"campaign), got {value!r}")
        return value
    x = number(where, value)
    if key == "c_spread" and not 0 <= x <= MAX_C_SPREAD:
        raise InputError(f"{where} must be in [0, {MAX_C_SPREAD:g}] (the between-test sd of "
                         f"ln c), got {value!r}")
    if key == "added_mass_fraction" and not 0 < x <= MAX_ADDED_FRACTION:
        raise InputError(f"{where} must be in (0, {MAX_ADDED_FRACTION:g}] (the largest added "
                         f"mass as a fraction of the mass), got {value!r}")
    return x


def per_test_list(key: str, value: Any, lo: float, hi: float, unit: str) -> list[float]:
    """A per-test list of [campaign] (:data:`CAMPAIGN_LISTS`): numbers in [lo, hi] [unit]."""
    from dampfit.simulate import MAX_TESTS

    where = f"[campaign] {key}"
    if not isinstance(value, list) or not value:
        raise InputError(f"{where} must be a list of numbers [{unit}], one per test")
    if len(value) > MAX_TESTS:
        raise InputError(f"{where} gives {len(value)} values; a campaign has at most "
                         f"{MAX_TESTS} tests")
    out = [number(where, v) for v in value]
    bad = [v for v in out if not lo <= v <= hi]
    if bad:
        raise InputError(f"{where} values must be in [{lo:g}, {hi:g}] {unit}, got {bad[0]:g}")
    return out


def setting(table: dict, key: str) -> Any:
    """An analysis setting of [campaign] (:data:`CAMPAIGN_SETTINGS`), checked, or its default."""
    from dampfit.physics import MAX_MASS

    if key not in table:
        return CAMPAIGN_SETTINGS[key]
    value, where = table[key], f"[campaign] {key}"
    if key == "max_steps":
        if isinstance(value, bool) or not isinstance(value, int) or \
                not MIN_STEPS <= value <= MAX_STEPS:
            raise InputError(f"{where} must be an integer from {MIN_STEPS} to {MAX_STEPS:,}, "
                             f"got {value!r}")
        return value
    x = number(where, value)
    if key == "min_ess" and not 1 <= x <= MAX_MIN_ESS:
        raise InputError(f"{where} must be a number from 1 to {MAX_MIN_ESS:g}, got {value!r}")
    if key in ("mass_sd", "added_mass_sd") and not 0 <= x <= MAX_MASS:
        raise InputError(f"{where} must be a number of kilograms in [0, {MAX_MASS:g}], "
                         f"got {value!r}")
    return x


def campaign_table(table: dict, grid: dict, fixed: dict, mass: float | None) -> dict[str, Any]:
    """The validated [campaign] table: design constants (scenario fields) and every analysis
    setting (see the module docstring); one :class:`InputError` line otherwise."""
    from dampfit.physics import MAX_MASS
    from dampfit.simulate import MAX_U0

    bad = sorted(set(table) - set(CAMPAIGN_KEYS))
    if bad:
        raise InputError(f"unknown key [campaign] {bad[0]}; known: {', '.join(CAMPAIGN_KEYS)}")
    both = [k for k in CAMPAIGN_AXES if k in table and k in grid]
    if both:
        raise InputError(f"{both[0]} is in both [grid] and [campaign]; keep one")
    out: dict[str, Any] = {k: campaign_value(k, table[k], "campaign")
                           for k in CAMPAIGN_AXES if k in table}
    limits = {"added_mass": (0.0, MAX_MASS, "kg"), "amplitudes": (0.0, MAX_U0, "m")}
    for key in CAMPAIGN_LISTS:
        if key in table:
            out[key] = per_test_list(key, table[key], *limits[key])
    lists = [k for k in CAMPAIGN_LISTS if k in out]
    if lists and "tests" in grid:
        raise InputError(f"[campaign] {lists[0]} gives one value per test, so tests cannot be a "
                         "[grid] axis" + (" (use added_mass_fraction for added masses that follow "
                                          "the number of tests)" if lists[0] == "added_mass" else ""))
    if "tests" not in out and "tests" not in grid:
        if not lists:
            raise InputError("tests is missing; give [campaign] tests (recordings per campaign, "
                             "e.g. tests = 4) or a [grid] tests list")
        if len(out[lists[0]]) < 2:
            raise InputError(f"[campaign] {lists[0]} gives 1 value: a campaign needs at least "
                             "2 tests")
        out["tests"] = len(out[lists[0]])
    for key in lists:
        if len(out[key]) != out["tests"]:
            raise InputError(f"[campaign] {key} gives {len(out[key])} value(s) for "
                             f"{out['tests']} tests; give one per test")
    if "c_spread" not in out and "c_spread" not in grid:
        out["c_spread"] = 0.0
    added = "added_mass" in out or "added_mass_fraction" in out or "added_mass_fraction" in grid
    if "added_mass" in out and ("added_mass_fraction" in out or "added_mass_fraction" in grid):
        raise InputError("give [campaign] added_mass (one mass per test [kg]) or "
                         "added_mass_fraction, not both")
    if "added_mass" in out and len(set(out["added_mass"])) < 2:
        raise InputError("[campaign] added_mass needs at least 2 different masses: the "
                         "added-mass method cannot identify the mass otherwise")
    if "amplitudes" in out and ("u0" in grid or "u0" in fixed):
        raise InputError("u0 is set in [grid] or [fixed] and [campaign] amplitudes sets each "
                         "test's u0; keep one")
    settings = {k: setting(table, k) for k in CAMPAIGN_SETTINGS}
    if "mass_sd" in table and (added or mass is None):
        why = ("the added-mass design estimates the mass itself" if added
               else "it is the sd of [study] mass, which is not given")
        raise InputError(f"[campaign] mass_sd cannot be used: {why}")
    if "added_mass_sd" in table and not added:
        raise InputError("[campaign] added_mass_sd needs added masses (added_mass or "
                         "added_mass_fraction)")
    if mass is not None and settings["mass_sd"] > 0.5 * mass:
        raise InputError(f"[campaign] mass_sd {settings['mass_sd']:g} kg is more than half the "
                         f"mass {mass:g} kg")
    return {**out, **settings}
