r"""Campaign studies: simulate a test campaign with known truth, analyse it jointly, score it.

One run of a campaign study (a ``[campaign]`` table, :mod:`dampfit.study.config`) simulates
``tests`` recordings of one damper with :func:`dampfit.simulate.campaign` (between-test
spread ``c_spread`` of ln c, known added masses Δm_i [kg], release amplitudes u0_i [m]),
analyses them with :func:`dampfit.campaign.analyze_campaign` and compares the result with
the truth. ``paper/campaign_calibration.py`` scores its replicates with the same functions.

Design
------
The added masses are either listed (``added_mass``, one per test) or a fraction f [1] of
the simulated bare mass m₀ [kg], evenly spaced over the n tests:
Δm_i = f·m₀·i/(n − 1), i = 0 … n − 1 (the first test is the bare system). These are the
masses the analysis is told; with ``added_mass_sd`` s [kg] the simulated masses are
Δm_i + s·e_i, e_i ~ N(0, 1) (a stated 0 stays exact): the error the analysis assumes.

Scoring (:func:`score`), each a flag that is None where it is not defined
------------------------------------------------------------------------
* ``covers_c``, ``covers_k``, ``covers_zeta`` — the 90 % interval [q05, q95] of the
  population damper (the median c [N·s/m] of the log-normal population, the fixed k [N/m],
  the bare system's ζ = c/(2√(k·m₀)) [1]) holds the truth; c and k need a mass or added
  masses;
* ``covers_m0`` — the interval of the effective mass m₀ [kg] holds it (added-mass design);
* ``covers_predictive_c`` (``covers_predictive_zeta``) — the predictive 90 % interval of a
  new test holds one new test drawn from the true population,
  c_new = c·exp(s·z), ζ_new = ζ·exp(s·z), z ~ N(0, 1) (ζ_new only without added masses,
  where k and m are those of every test);
* ``covers_spread`` — the interval of τ_p (the between-test sd of ln p [1]; the true value
  is ``c_spread`` = s) holds s; only for s > 0 (an interval of a positive quantity cannot
  hold 0);
* ``spread_zero_ok`` — with s = 0, the analysis calls the spread consistent with zero.

A calibrated analysis covers about 90 % of the runs for each interval; ``spread_zero_ok``
should be close to 1 (its test has a 1 % false-alarm rate). A campaign that the simulator or
the analysis refuses (an overdamped draw, tests it cannot tell apart …) is a result with
``refused`` set, not an error. Nothing here writes files.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, NamedTuple

import numpy as np

from dampfit.errors import InputError
from dampfit._json import finite
from dampfit._options import SamplerSettings

#: The coverage flags of a row (``covers_<name>``), in table order.
CHECKS = ("c", "k", "m0", "zeta", "predictive_c", "predictive_zeta", "spread")
#: Spawn key of the run's second stream (analysis seed and the new test's z): far beyond the
#: children 0 … n_tests that :func:`dampfit.simulate.campaign` spawns from the same seed.
_STREAM = 2**31


def added_masses(n: int, fraction: float, mass: float) -> list[float]:
    """Evenly spaced added masses [kg]: Δm_i = fraction·mass·i/(n − 1), i = 0 … n − 1."""
    return [float(fraction * mass * i / (n - 1)) for i in range(n)]


def per_test(params: dict[str, Any], mass: float) -> tuple[int, float, list[float] | None,
                                                           list[float] | None]:
    """The campaign design of a scenario: (n_tests, c_spread [1], added masses [kg] or None,
    amplitudes [m] or None), from its ``tests``, ``c_spread``, ``added_mass`` or
    ``added_mass_fraction`` (of the simulated bare ``mass`` [kg]) and ``amplitudes``."""
    n = int(params["tests"])
    dm = params.get("added_mass")
    if dm is None and params.get("added_mass_fraction") is not None:
        dm = added_masses(n, float(params["added_mass_fraction"]), mass)
    u0 = params.get("amplitudes")
    return (n, float(params.get("c_spread", 0.0)),
            None if dm is None else [float(x) for x in dm],
            None if u0 is None else [float(x) for x in u0])


def check_scenario(base, params: dict[str, Any]) -> None:
    """Refuse a campaign scenario the simulator would refuse, before any run (InputError):
    the samples of all tests together, and every test's mass and amplitude (the simulator's
    limits, :func:`dampfit.simulate.check_limits`)."""
    from dampfit import simulate as sim

    n, _, dm, u0 = per_test(params, base.mass)
    total = n * base.duration * base.sample_rate
    if total > sim.MAX_SIM_SAMPLES:
        raise InputError(f"{n} tests of {base.duration:g} s at {base.sample_rate:g} Hz would be "
                         f"{total:.3g} samples; at most {sim.MAX_SIM_SAMPLES:g} are simulated")
    for i in range(n):
        try:
            test = dataclasses.replace(base, mass=base.mass + (dm[i] if dm else 0.0),
                                       u0=u0[i] if u0 else base.u0)
            sim.check_limits(test)
        except InputError as exc:
            raise InputError(f"test {i + 1}: {exc}") from None


def streams(seed: int) -> tuple[int, float]:
    """The analysis seed and the new test's standard-normal draw z of a run ``seed``: a stream
    of ``SeedSequence(seed)`` that the simulated recordings do not use."""
    ss = np.random.SeedSequence(seed, spawn_key=(_STREAM,))
    analysis_seed = int(ss.generate_state(1, dtype=np.uint32)[0])
    z_new = float(np.random.default_rng(ss.spawn(1)[0]).standard_normal())
    return analysis_seed, z_new


def _inside(entry: dict | None, x: float | None) -> bool | None:
    """Whether the [q05, q95] interval of a summary ``entry`` holds ``x`` (None: undefined)."""
    if not entry or x is None:
        return None
    lo, hi = finite(entry.get("q05")), finite(entry.get("q95"))
    if lo is None or hi is None:
        return None
    return bool(lo <= x <= hi)


def truth(base, mass_known: bool, added: bool) -> dict[str, float | None]:
    """The population truth of a campaign around ``base``: c [N·s/m] and k [N/m] (None when
    the analysis can report neither: no mass, no added masses), m₀ [kg] (added-mass design
    only) and the bare system's ζ = c/(2√(k·m₀)) [1]."""
    known = mass_known or added
    return {"c": float(base.c) if known else None, "k": float(base.k) if known else None,
            "m0": float(base.mass) if added else None,
            "zeta": float(base.c / (2.0 * math.sqrt(base.k * base.mass)))}


def empty_row(n_tests: int, added: bool, true: dict[str, float | None], c_spread: float,
              z_new: float) -> dict[str, Any]:
    """A row with the truth and every estimate column None (JSON-safe); see :func:`score`."""
    new = math.exp(c_spread * z_new)
    row: dict[str, Any] = {"estimator": "campaign",
                           "design": "added-mass" if added else "hierarchical",
                           "n_tests": int(n_tests)}
    for q in ("c", "k", "m0", "zeta"):
        row.update({f"true_{q}": true.get(q), f"est_{q}": None, f"{q}_lo": None,
                    f"{q}_hi": None, f"err_{q}": None})
    for q in ("c", "zeta"):
        t = true.get(q)
        row[f"true_new_{q}"] = None if t is None or (q == "zeta" and added) else t * new
        row.update({f"predictive_{q}_lo": None, f"predictive_{q}_hi": None})
    row.update({"true_spread": float(c_spread), "spread_q05": None, "spread_q50": None,
                "spread_q95": None, "spread_zero_consistent": None})
    row.update({f"covers_{c}": None for c in CHECKS})
    row.update({"spread_zero_ok": None, "verdict": None, "converged": None, "n_steps": None,
                "max_r_hat": None, "min_ess_bulk": None, "importance_ess_fraction": None,
                "runtime_s": None, "ok": False, "refused": "", "message": ""})
    return row


def score(summary: dict[str, Any], row: dict[str, Any]) -> dict[str, Any]:
    """``row`` (:func:`empty_row`, holding the truth) completed from a campaign ``summary``
    (:meth:`dampfit.campaign.CampaignAnalysis.summary`): medians ``est_*``, 90 % intervals,
    errors, the coverage flags of the module docstring, the spread and the diagnostics."""
    row = dict(row)
    params, pop, diag = summary["parameters"], summary["population"], summary["diagnostics"]
    for q in ("c", "k", "m0", "zeta"):
        entry, true = params.get(q), row[f"true_{q}"]
        if not entry:
            continue
        est = finite(entry.get("q50"))
        row.update({f"est_{q}": est, f"{q}_lo": finite(entry.get("q05")),
                    f"{q}_hi": finite(entry.get("q95")),
                    f"err_{q}": None if est is None or true is None else est - true,
                    f"covers_{q}": _inside(entry, true)})
    for q in ("c", "zeta"):
        entry = (pop.get("predictive") or {}).get(q)
        if entry:
            row[f"predictive_{q}_lo"] = finite(entry.get("q05"))
            row[f"predictive_{q}_hi"] = finite(entry.get("q95"))
            row[f"covers_predictive_{q}"] = _inside(entry, row[f"true_new_{q}"])
    spread = pop["spread"]["p"]
    s = row["true_spread"]
    zero = pop.get("spread_consistent_with_zero")
    row.update({"spread_q05": finite(spread.get("q05")), "spread_q50": finite(spread.get("q50")),
                "spread_q95": finite(spread.get("q95")),
                "spread_zero_consistent": None if zero is None else bool(zero),
                "covers_spread": _inside(spread, s) if s > 0 else None,
                "spread_zero_ok": None if s > 0 or zero is None else bool(zero)})
    row.update({"verdict": summary["checks"]["verdict"], "converged": bool(diag["converged"]),
                "n_steps": diag.get("n_steps"), "max_r_hat": finite(diag.get("max_r_hat")),
                "min_ess_bulk": finite(diag.get("min_ess_bulk")),
                "importance_ess_fraction": finite(diag.get("importance_ess_fraction")),
                "ok": True})
    if not row["converged"]:
        warn = [w for w in diag.get("warnings", []) if "converged" in w]
        row["message"] = warn[0] if warn else "the campaign posterior did not converge"
    return row


class Design(NamedTuple):
    """The campaign one study run simulates (:func:`dampfit.simulate.campaign`): ``n_tests``
    recordings, the between-test sd ``c_spread`` of ln c [1], the ``added_mass`` of each test
    [kg] (None: none) with the scale error ``added_mass_sd`` [kg] (also the sd the analysis
    is given), and each test's release ``amplitudes`` u0 [m] (None: the base's)."""

    n_tests: int
    c_spread: float = 0.0
    added_mass: list[float] | None = None
    amplitudes: list[float] | None = None
    added_mass_sd: float = 0.0


def run(base, design: Design, *, mass_known: bool = True, mass_sd: float = 0.0,
        sim_seed: int = 0, z_new: float = 0.0,
        sampler: SamplerSettings = SamplerSettings()) -> dict[str, Any]:
    """Simulate one campaign ``design`` (:class:`Design`) around ``base``
    (:class:`~dampfit.simulate.SimulationConfig`, its mass the bare m₀ [kg]), analyse it
    jointly and score it: one JSON-safe row.

    Without added masses the analysis gets the mass (``mass_known``; sd ``mass_sd`` [kg]),
    with them the added masses [kg] (sd ``design.added_mass_sd`` [kg]) and estimates m₀
    itself; the masses simulated are the stated ones plus a normal error of that sd (the bare
    system's 0 exact), as the analysis assumes.
    ``sim_seed`` seeds the recordings, ``sampler`` (its seed: the analysis seed) the joint
    analysis, ``z_new`` is the new test's draw (:func:`streams`). A refusal
    (:class:`InputError` of the simulator or the analysis) is a row with ``refused`` set and
    ``ok`` False; other exceptions propagate.
    """
    from dampfit import simulate as sim
    from dampfit.campaign import analyze_campaign

    n_tests, c_spread, added_mass, amplitudes, added_mass_sd = design
    analysis_seed, max_steps, min_ess = sampler.seed, sampler.max_steps, sampler.min_ess
    added = added_mass is not None
    row = empty_row(n_tests, added, truth(base, mass_known, added), c_spread, z_new)
    try:
        recs, _ = sim.campaign(base, n_tests=n_tests, c_spread=c_spread, added_mass=added_mass,
                               amplitudes=amplitudes, seed=sim_seed,
                               added_mass_sd=added_mass_sd if added else 0.0)
    except InputError as exc:
        return {**row, "refused": f"simulation refused: {exc}", "message": str(exc)}
    started = time.perf_counter()
    try:
        if added:
            an = analyze_campaign(recs, added_mass=added_mass, added_mass_sd=added_mass_sd,
                                  seed=analysis_seed, max_steps=max_steps, min_ess=min_ess)
        else:
            an = analyze_campaign(recs, mass=base.mass if mass_known else None,
                                  mass_sd=mass_sd if mass_known else None,
                                  seed=analysis_seed, max_steps=max_steps, min_ess=min_ess)
        summary = an.summary()
    except InputError as exc:
        return {**row, "refused": str(exc), "message": str(exc),
                "runtime_s": time.perf_counter() - started}
    return {**score(summary, row), "runtime_s": time.perf_counter() - started}
