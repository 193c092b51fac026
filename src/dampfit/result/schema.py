"""The one validating reader of a result folder's ``summary.json`` (and its checked numbers).

Every reader of a result folder — :func:`dampfit.load`, ``dampfit report``, ``export`` and
``verify`` — goes through :func:`read_summary`, so they accept and refuse the same folders with
the same words. This module imports only the standard library.

What a usable ``summary.json`` is:

* a regular file, not a symbolic link (a FIFO, device or link is refused from the descriptor
  opened without blocking or following: :mod:`dampfit.result.files`), of at most
  :data:`MAX_SUMMARY_BYTES`, UTF-8 (a byte-order mark is allowed);
* one JSON object nested at most :data:`MAX_DEPTH` levels, with a ``parameters`` object;
  sections ``mass``, ``input``, ``window`` are objects (or absent/null), ``dampfit_version`` a
  string (or absent);
* ``"kind": "campaign"`` (several recordings of one damper, :mod:`dampfit.campaign`): then
  ``tests`` is a list of at least two objects and ``design``, ``population``, ``checks``,
  ``added_mass``, ``diagnostics`` are objects (or null); a summary of one recording has no
  ``kind``, any other ``kind`` is refused;
* ``schema_version`` a non-negative integer of at most :data:`SCHEMA_VERSION`; a summary
  without it was written by dampfit before the schema was versioned and is read as version 0
  with the same checks. A newer version is refused with one line naming both versions.

Integers beyond float precision are read as floats (±inf beyond range), strings with lone
surrogates get U+FFFD: the result is plain, renderable data. Numbers are checked where they
are used (:func:`number`: type, finite, range). A folder that is not usable — not a
directory, no summary.json, or a summary.json that is not one of the above — is refused
with one error text, ``DIR is not a dampfit result folder: WHY; run 'dampfit analyze …'``.
The marker file ``.dampfit-result`` (:data:`dampfit.files.folder.MARKER`) is not required: folders
of older dampfit versions and hand-made folders with a valid summary.json are read too.

The layout of summary.json (schema_version 1)
---------------------------------------------
Plain JSON: non-finite numbers become ``null``; every physical quantity is in SI units, named
in a ``unit`` field or in the key (``_s`` [s], ``_hz`` [Hz], ``_m`` [m], ``_kg`` [kg]). A
new field may be added within a version; an incompatible change bumps
:data:`SCHEMA_VERSION`. Keys scripts can rely on, top level exactly as listed (tested:
``tests/invariants/test_schema_doc.py``), sections abridged with ``…``.

Top-level keys of one recording's summary (:meth:`dampfit.analysis.Analysis.summary`)::

    {"schema_version": 1,                          # SCHEMA_VERSION
     "dampfit_version": str,
     "input": {"path", "format", "sha256", "n_samples", "sample_rate_hz", "duration_s",
             "timing_jitter", "axis", "axis_direction", "gravity_removed", "notes",
             "decimated": null | {"factor", "from_hz", "to_hz", "n_samples_read",
                   "n_samples_analysed", "band_top_hz", "n_clipped_dropped",
                   "n_stale_dropped", "method"}},  # more than 1 M samples: decimated to
                   # 16x the band's top first (dampfit.signal.decimate); n_samples is
                   # the file's, sample_rate_hz and timing_jitter the analysed samples'
                   # (from_hz the file's rate; null, or absent in older summaries:
                   # analysed as read)
     "window": {"start_s", "end_s", "auto", "n_cycles",      # recording's own time base
             "end_reason"},                      # why it ends: noise floor, catch, impact…
     "band": {"low_hz", "high_hz", "auto"},
     "dominant_frequency_hz": float,
     "mass": {"value", "sd", "unit"},              # kg; value null if not given
     "damper": null | {                            # THE recommendation (dampfit.damping.damper)
             "status": "recommended" | "viscous-stands" | "none",
                   # recommended: verdict adequate (law viscous) or amplitude-dependent
                   # (the law the verdict names); viscous-stands: inconclusive (law
                   # viscous, not_ruled_out says what); none: misfit, no verdict, or a
                   # dependence no law describes (law null; reason and try)
             "verdict", "law": "viscous" | "coulomb" | "quadratic" | "power" | null,
             "force": str,                       # e.g. "F = c_alpha·|v|^alpha·sgn(v)"
             "coefficients": {NAME: {"unit", "symbol", "mean", "sd", "q05", "q50",
                   "q95"}},   # the law's own posterior, SI: c [N s/m], F_c [N],
                   # c2 [N s^2/m^2], c_alpha [N (s/m)^alpha], alpha [1]; viscous: c;
                   # coulomb: c, F_c; quadratic: c, c2; power: c_alpha, alpha.
                   # Without mass only the mass-free ones (alpha), the others per kg:
             "per_unit_mass": {NAME_per_kg: {…}},  # only without mass
             "mass": {"value", "sd", "unit"}, "k": {"unit": "N/m", …} | null,
             "f_n": {"unit": "Hz", …},
             "measured_range": {"displacement_m": [lo, hi],  # the analysed window's
                   "velocity_m_s": [lo, hi]},    # amplitudes, v = omega_n·A
             "design_amplitude": {"displacement_m", "velocity_m_s",
                   "source": "--amplitude" | "middle of the measured range"},
                   # middle: sqrt(lo·hi)
             "c_linear": {"unit": "N s/m", …} | null,  # equivalent linear c = 2·m·rho(A)
             "zeta_linear": {"unit": "1", …},    #   and zeta at the design amplitude
             "linear_within_10pct_m": [lo, hi] | null,  # where the law's median c_eq(A)
                   # stays within ±10 % of c_linear's median, searched over
                   # [lo/10, 10·hi] of the measured range
             "decay_check": {"checked": true, "follows": bool, "rms", "scatter",
                   "n_peaks", "what"} | {"checked": false, "reason"} | null,
                   # a recommended nonlinear law's own free decay against the measured
                   # envelope (rms of ln|u| about its trend [1], against the measurement's
                   # scatter): where it does not follow, export writes the measured
                   # force-velocity curve if closer; null: viscous, no recommendation or
                   # no mass
             "reason": str, "not_ruled_out": str | null, "try": str | null,
             "missing": str | null,              # without mass: what needs it
             "posterior": {"method", "converged", "note"},  # how the draws were made
             "draws": {"group": "damper", "n"} | null},   # posterior.nc's group
     "parameters": {                               # posterior summaries
             "c": {"unit": "N s/m", "mean", "sd", "q05", "q50", "q95", "r_hat",
                   "ess_bulk", "crlb_sd"},
             "k": {"unit": "N/m", …}, "u0": {"unit": "m", …}, "zeta": {"unit": "1", …},
             "f_n": {"unit": "Hz", …}, "p": {"unit": "1/s", …}, "f_d", "delta", "Q",
             "c_crit": {"unit": "N s/m", …}},   # c, k, c_crit null without mass;
                                                 # no decay measured: p, zeta, c, delta
                                                 # q05 = 0, Q q95 null, "reaches_zero": true
     "missing": {"c": why, "k": why, "c_crit": why,  # only without mass
             "c_equivalent": why},               # under misfit / an unconverged law
     "least_squares": {"c", "k", "u0", "zeta", "f_n", "p", "p_sd", "c_sd", "zeta_sd",
             "converged", "message", "n_steps"},
     "baselines": {"log_decrement": {"method", "c", "zeta", "p", "delta", "f_d", "k",
                   "n_cycles", "n_cycles_used", "supported", "agrees_with_posterior",
                   "note", …},
             "envelope_pipeline": {…the same keys}},
     "noise_model": {"kind", "sigma", "sigma_unit", "psd_ratio_at_f0",
             "residual_lag1_autocorrelation", "psd_ratio_expected_for_white_noise", …},
     "crlb": {"c": {"value", "sd", "sd_with_mass"}, "k", "u0", "zeta", "f_n", "p",
             "omega_d": {"value", "sd"}, "units", "n_samples", "drift_degree", "mass",
             "mass_sd", "noise_sigma", "noise_density", …},  # Cramér–Rao bound
     "model_checks": {"verdict", "verdict_reasons", "verdict_law", "decay": {"z",
             "resolved", …}, "requested_model", "preferred_model", "chosen_model",
             "single_viscous_c_adequate", "amplitude_dependence": {"detected",
             "p_viscous", "slope_ln_p_vs_ln_amplitude", …}, "residual_whiteness": {…},
             "adequacy", "warning"},             # verdict: dampfit.damping.checks
     "damping_models": {"comparison": [...], "models": {law: {"parameters",
                   "least_squares", "posterior", "ln_evidence", "fem", "force",
                   "coefficients": [{"name", "unit", "symbol", "needs_mass"}],
                   "style": {"colour"}}}, "preferred_model", "model_prior",
             "chosen_model", …},               # each law's parameters and weight
     "amplitude_curve": {"windows": [{"amplitude_m", "zeta", "zeta_sd", "f_d_hz",
             "f_d_sd_hz", …}], "slope", "backbone",      # ζ(A) and f(A)
             "models": {law: {"zeta_eq", "c_eq", "colour"}}, …},
     "c_equivalent": null | {"model", "c", "zeta", "amplitude_m", "note",
             "recorded_amplitude_range_m", "extrapolated"},
     "n_modes": int,                               # identified modes (1 … max modes)
     "modes": [{"index", "mass_mode",              # one per identified mode, by frequency;
             "identified": true,                   # index: the component's number (1-based,
             "fundamental": bool,                  # as --mode-of-mass); fundamental: the
                                                   # one-mode analysis's (released) mode
             "f_n": {"unit": "Hz", "mean", "sd", "q05", "q50", "q95", "r_hat",
                   "ess_bulk"}, "f_d", "zeta", "p", "eta", "delta", "Q",
             "accel_amplitude",                  # K ≥ 2 only
             "c", "k", "c_crit", "u0",             # the mass's mode only (c, k with mass):
             "c_modal", "k_modal", "mass_values",  # the one-mode analysis's when it is the
                                                   # fundamental; the modal posterior's: *_modal
             "crlb_sd": {"f_n", "zeta", "p", "omega_d"},
             "least_squares": {"f_n": {"value", "q05", "q95", "unit"}, "zeta",
                   "p"}}],                        # K ≥ 2: least squares, Laplace 90 %
             # one mode: modes[0] is parameters (eta = 2 zeta added)
     "modes_seen": [{"index", "f_n": {"q05", "q50", "q95", "unit", …}, "zeta": {…} | null,
             "kind": "harmonic" | "sideband" | "split" | "not converged" | "basin" | "zeta",
             "reason"}],       # components that are not modes (inference.modes_checks):
             # no zeta row, no Rayleigh, no deck; [] when none (absent: older summaries)
     "modes_evidence": {"max_modes", "reason", "seconds", "n_components",
             "screen": null | {"passed", "max_z2", "at_hz", "rate_per_s",
                   "threshold_z2", "reason"},  # the cheap one-mode screen
             "harmonics": [{"index", "f_d_hz", "multiple", "of_hz", "cells"}],  # only when
             "split": [{"index", "f_d_hz"}],  # the evidence's other components are harmonics of the one
                   # mode or its split (amplitude-dependent verdict; a drift, any): K = 1
             "unresolved_pair": {"f_hz", "separation_hz", "separation_cells",
                   "delta_bic", "law"},  # only when K = 1 under an amplitude-dependent or
                   # misfit verdict and two modes in one resolution cell fit better (BIC)
             "evidence": [{"n_modes", "ln_evidence", "probability", "admissible",
                   "reason", "f_d_hz", "amplitude_z"}],   # every K tried, P(K)
             "band_hz", "window_s", "psd_ratio", "pairs": [{…, "flagged"}],
             "sampling": {"converged", "max_r_hat", "min_ess_bulk", "n_steps",
                   "burn_in", "thin", "n_walkers", "acceptance_fraction",
                   "wall_time_s", "stop_reason", "budget": null | {"max_steps",
                   "max_seconds", "basis"}}, …},  # only when more modes were fitted
     "rayleigh": null | {"alpha": {"unit": "1/s", …}, "beta": {"unit": "s", …},
             "zeta_fitted", "zeta_measured", "chi2", "dof", "p_value",
             "max_relative_misfit", "statement", "warnings"},  # K ≥ 2
     "fit": {"path": "raw" | "decimated", "n_samples", "sample_rate_hz", "drift_degree",
             "n_excluded", "t0_s"},
     "preprocessing": {"n_stale_dropped", "n_clipped", "n_spikes", "noise_density",
             "noise_density_unit", "notes"},
     "diagnostics": {"converged", "posterior_converged", "max_r_hat", "min_ess_bulk",
             "n_steps", "burn_in", "thin", "n_walkers", "autocorr_time_steps",
             "acceptance_fraction", "warnings": [str]},
     "provenance": {"seed", "options", "date", "python", "versions"},
     "files": null | {"posterior.nc": {"sha256", "bytes"},       # the files written with
             "signals.npz": {"sha256", "bytes"}}}    # it (null until saved); a reader refuses
                                                     # one whose SHA-256 differs

``model_checks``, ``damping_models``, ``amplitude_curve`` and ``damper`` are null when the
damping-law assessment could not run. Of status "none" every number of ``damper`` is null and
``coefficients`` is empty. posterior.nc holds, besides the arviz groups (and ``modes`` with
several modes), the group ``damper`` when its status is not "none": one dimension ``draw``
(a seeded, thinned subset of the law's posterior, at most 4000), variables in SI — ``mass``
[kg], ``k`` [N/m] (with a mass), ``f_n`` [Hz], each coefficient NAME (or NAME_per_kg),
``c_linear`` [N s/m] (with a mass) and ``zeta_linear`` [1] at the design amplitude — and
attributes ``law``, ``design_amplitude_m``.

Top-level keys of a campaign's summary (several recordings of one damper,
:mod:`dampfit.campaign`)::

    {"schema_version": 1,
     "kind": "campaign",
     "dampfit_version": str,
     "design": {"n_tests", "model", "mass", "added_mass", "priors"},
     "parameters": {"c", "k", "zeta", "f_n", "p", "m0" (added-mass method only), …},
             # the population, each {"unit", "mean", "sd", "q05", "q50", "q95", …}
     "mass": {"value", "sd", "unit"},              # m0's posterior with added masses
     "population": {"spread": {"p", "omega"}, "predictive": {"c", "zeta", "f_n", "k"},
             "spread_consistent_with_zero"},   # predictive: a new test of this damper
     "tests": [{"index", "input", "window", "band", "dominant_frequency_hz",
             "added_mass_kg", "amplitude_m", "noise_psd_ratio", "damping_verdict",
             "own", "pooled", "outlier",
             "modes"}],   # only with max_modes > 1 (dampfit.campaign.modes):
             # {"max_modes", "n_modes", "pooled_mode", "modes": [{"index", "f_n", "f_d",
             #  "zeta", "eta", "delta", "Q", "p", "crlb_sd", "pooled"}], "modes_evidence",
             #  "rayleigh", "converged", "warnings", "reason"}
     "checks": {"verdict", "text", "tau_over_within", "heterogeneity_p_value",
             "outliers", "amplitude", "within_test_inadequate", …},
     "added_mass": null | {"m0", "k", "points", "line"},
     "diagnostics": {"converged", "max_r_hat", "min_ess_bulk", "n_steps",
             "importance_ess_fraction", "log_bayes_factor_shared_frequency",
             "warnings", …},
     "warnings": [str],
     "provenance": {"seed", "options", "date"},
     "files": null | {"posterior.nc": {"sha256", "bytes"}}}  # as one recording's (no
             # signals.npz); absent in campaign summaries written before it was recorded
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dampfit.files.folder import MARKER
from dampfit.errors import InputError
from dampfit.errors import shown
from dampfit.result import files

#: Version of the summary.json layout :meth:`dampfit.analysis.Analysis.summary` writes (its
#: ``schema_version``). 0: written before the field existed (same layout as 1).
SCHEMA_VERSION = 1
#: Largest summary.json read [bytes]; a real one is a few kB.
MAX_SUMMARY_BYTES = 50 * 2**20
#: Deepest nesting of lists and objects a summary.json may have (dampfit writes ≤ 6).
MAX_DEPTH = 32
#: Largest magnitude of any number read from a summary (SI units): beyond it a value is a
#: typo or an edit, not a measured spring–damper (and decks in mm or ms would overflow fields).
MAX_MAGNITUDE = 1e15
#: Smallest value of a quantity that must be positive (mass [kg], k [N/m]): below it unit
#: conversion (e.g. k × 1e-6 in mm-ms-kg) approaches underflow.
MIN_POSITIVE = 1e-15


@dataclass(frozen=True)
class Summary:
    """A validated summary.json: ``data`` (plain JSON), its ``folder`` and ``path``, the
    SHA-256 of the bytes read, the ``schema_version`` (0 if absent) and whether the folder
    holds the ``.dampfit-result`` marker."""

    folder: Path
    path: Path
    data: dict[str, Any]
    sha256: str
    schema_version: int
    marked: bool


def folder_of(result: Any) -> Path:
    """The folder of ``result``: a path, or an analysis :func:`dampfit.load` read from a folder."""
    folder = getattr(result, "folder", None) if not isinstance(result, (str, os.PathLike)) else result
    if folder is None:
        raise InputError("this analysis was not loaded from a result folder; write it with "
                         "'dampfit analyze' (or its to_json/to_netcdf/to_signals) and "
                         "dampfit.load() that folder")
    return Path(folder)


def not_a_result(folder: str | Path, why: str, again: bool = False) -> InputError:
    """The one error of a folder that is not a usable result folder: ``why`` it is not."""
    when = "again" if again else "first"
    return InputError(f"{shown(folder)} is not a dampfit result folder: {why}; run 'dampfit "
                      f"analyze FILE --mass KG --out {shown(folder)}' {when}")


def read_summary(folder: str | os.PathLike | Any) -> Summary:
    """The validated summary.json of result ``folder`` (see the module); :class:`InputError`
    (one line) if the folder is not a usable result folder."""
    folder = folder_of(folder)
    if not folder.is_dir():
        raise not_a_result(folder, _hidden_previous(folder) or "it is not a directory")
    path = folder / "summary.json"
    data = read_regular(path, MAX_SUMMARY_BYTES, missing=not_a_result(
        folder, f"{shown(path)} not found, the folder has no summary.json"), folder=folder)
    try:
        summary = parse_json(data)
    except ValueError as exc:
        raise not_a_result(folder, f"cannot read {shown(path)}: {exc}", again=True) from None
    if not isinstance(summary, dict):
        raise not_a_result(folder, f"{shown(path)} holds a JSON {_kind(summary)}, not an "
                           "object: not a dampfit summary", again=True)
    if not isinstance(summary.get("parameters"), dict):
        raise not_a_result(folder, f"{shown(path)} has no 'parameters' object: not a dampfit "
                           "summary", again=True)
    _check_fields(summary, path)
    return Summary(folder=folder, path=path, data=summary,
                   sha256=hashlib.sha256(data).hexdigest(),
                   schema_version=_schema_version(summary, path),
                   marked=os.path.isfile(folder / MARKER))


def _hidden_previous(folder: Path) -> str | None:
    """Why ``folder`` is missing when a dampfit run killed between the two renames of its
    swap left the previous result beside it (``.NAME.dampfit-old-PID-XXXX``), else None."""
    if os.path.lexists(folder):
        return None
    try:
        hidden = sorted(p.name for p in folder.parent.iterdir()
                        if p.name.startswith(f".{folder.name}.dampfit-old-"))
    except OSError:
        return None
    if not hidden:
        return None
    return (f"it does not exist, but a dampfit run killed while replacing it left its previous "
            f"result as {shown(hidden[0], 80)} beside it; the next 'dampfit analyze … --out "
            f"{shown(folder)}' restores it (or rename it back yourself)")


def parse_json(data: bytes) -> Any:
    """JSON bytes of a result folder (UTF-8, a byte-order mark allowed) as plain data
    (:func:`_plain`); ValueError with a short reason: not UTF-8, not JSON, nested deeper than
    :data:`MAX_DEPTH`."""
    try:
        return _plain(json.loads(data.decode("utf-8-sig")))
    except UnicodeDecodeError:
        raise ValueError("not UTF-8 text") from None
    except RecursionError:
        raise ValueError("nested too deeply") from None
    except _TooDeep:
        raise ValueError(f"nested too deeply (more than {MAX_DEPTH} levels)") from None
    except ValueError as exc:  # json.JSONDecodeError, or an integer with too many digits
        raise ValueError(f"not readable JSON ({shown(exc, 120)})") from None


def _check_fields(summary: dict[str, Any], path: Path) -> None:
    """Field-level checks of the sections every reader relies on (one line naming the field)."""
    for section in ("mass", "input", "window", "modes_evidence", "rayleigh"):
        if summary.get(section) is not None and not isinstance(summary[section], dict):
            raise InputError(f"{shown(path)}: '{section}' must be an object, "
                             f"got {brief(summary[section])}")
    _check_modes(summary, path)
    version = summary.get("dampfit_version")
    if version is not None and not isinstance(version, str):
        raise InputError(f"{shown(path)}: 'dampfit_version' must be a string, got {brief(version)}")
    if "kind" in summary:
        if summary["kind"] != "campaign":
            raise InputError(f"{shown(path)}: 'kind' must be \"campaign\" (or absent for one "
                             f"recording), got {brief(summary['kind'])}")
        _check_campaign(summary, path)


#: Entries of a ``modes`` row that are not quantity objects.
MODE_FLAGS = ("index", "mass_mode", "identified", "fundamental", "mass_values")


def _check_modes(summary: dict[str, Any], path: Path) -> None:
    """``modes`` a list of objects (or absent/null: a summary older than the modes), each
    quantity an object (or null), and ``n_modes`` a whole number 1 … len(modes) when given."""
    seen = summary.get("modes_seen")
    if seen is not None and not (isinstance(seen, list)
                                 and all(isinstance(e, dict) for e in seen)):
        raise InputError(f"{shown(path)}: 'modes_seen' must be a list of objects, got "
                         f"{brief(seen)}")
    modes = summary.get("modes")
    if modes is None:
        return
    if not isinstance(modes, list):
        raise InputError(f"{shown(path)}: 'modes' must be a list, got {brief(modes)}")
    for i, mode in enumerate(modes):
        if not isinstance(mode, dict):
            raise InputError(f"{shown(path)}: modes[{i}] must be an object, got {brief(mode)}")
        for name, entry in mode.items():
            if name not in MODE_FLAGS and entry is not None \
                    and not isinstance(entry, dict):
                raise InputError(f"{shown(path)}: modes[{i}].{shown(name, 40)} must be an "
                                 f"object, got {brief(entry)}")
    n = summary.get("n_modes")
    if n is not None and (isinstance(n, bool) or not isinstance(n, int)
                          or not 1 <= n <= max(len(modes), 1)):
        raise InputError(f"{shown(path)}: 'n_modes' must be a whole number from 1 to the "
                         f"{len(modes)} entries of 'modes', got {brief(n)}")


#: Sections of a campaign summary (``"kind": "campaign"``) that are objects (or null/absent).
CAMPAIGN_SECTIONS = ("design", "population", "checks", "added_mass", "diagnostics")
#: Sections of each test of a campaign that are objects (or null/absent).
CAMPAIGN_TEST_SECTIONS = ("input", "window", "own", "pooled", "modes")


def _check_campaign(summary: dict[str, Any], path: Path) -> None:
    """Field-level checks of a campaign summary (several recordings of one damper): ``tests``
    a list of at least two objects, the sections objects (one line naming the field)."""
    for section in CAMPAIGN_SECTIONS:
        if summary.get(section) is not None and not isinstance(summary[section], dict):
            raise InputError(f"{shown(path)}: '{section}' must be an object, "
                             f"got {brief(summary[section])}")
    population = summary.get("population") or {}
    for section in ("spread", "predictive"):
        entries = population.get(section)
        if entries is not None and not isinstance(entries, dict):
            raise InputError(f"{shown(path)}: 'population.{section}' must be an object, "
                             f"got {brief(entries)}")
        for name, entry in (entries or {}).items():
            if entry is not None and not isinstance(entry, dict):
                raise InputError(f"{shown(path)}: 'population.{section}.{shown(name, 40)}' must "
                                 f"be an object with q05/q50/q95, got {brief(entry)}")
    tests = summary.get("tests")
    if not isinstance(tests, list) or len(tests) < 2:
        raise InputError(f"{shown(path)}: 'tests' of a campaign must be a list of at least 2 "
                         f"tests, got {brief(tests) if not isinstance(tests, list) else len(tests)}")
    for i, test in enumerate(tests):
        if not isinstance(test, dict):
            raise InputError(f"{shown(path)}: tests[{i}] must be an object, got {brief(test)}")
        for section in CAMPAIGN_TEST_SECTIONS:
            if test.get(section) is not None and not isinstance(test[section], dict):
                raise InputError(f"{shown(path)}: tests[{i}].{section} must be an object, "
                                 f"got {brief(test[section])}")
    for key in ("warnings",):
        if summary.get(key) is not None and not isinstance(summary[key], list):
            raise InputError(f"{shown(path)}: '{key}' must be a list, got {brief(summary[key])}")


#: Most warnings a report or table shows (the others are counted): an analysis has a handful.
MAX_WARNINGS_SHOWN = 100
#: Longest warning shown [characters]; a longer one (an edited summary) is cut.
MAX_WARNING_CHARS = 2000


def unique_warnings(*lists: Any, text=str, limit: int = MAX_WARNINGS_SHOWN
                    ) -> tuple[list[str], int]:
    """The distinct non-empty warnings of ``lists`` (each a list; anything else is skipped)
    as ``text(item)``, stripped, in order of first appearance: at most ``limit`` of them,
    each cut at :data:`MAX_WARNING_CHARS`, and the number of further distinct ones. One pass
    with a set: linear in the number of warnings (an edited summary can hold millions)."""
    seen: set[str] = set()
    out: list[str] = []
    more = 0
    for items in lists:
        if not isinstance(items, list):
            continue
        for item in items:
            t = text(item).strip()
            if not t or t in seen:
                continue
            seen.add(t)
            if len(out) < limit:
                out.append(t if len(t) <= MAX_WARNING_CHARS else t[:MAX_WARNING_CHARS - 1] + "…")
            else:
                more += 1
    return out, more


def is_campaign(summary: dict[str, Any]) -> bool:
    """True for the summary of a campaign (several recordings of one damper)."""
    return isinstance(summary, dict) and summary.get("kind") == "campaign"


def _schema_version(summary: dict[str, Any], path: Path) -> int:
    """``schema_version`` of the summary: 0 if absent; refused if not an integer or newer."""
    if "schema_version" not in summary:
        return 0
    v = summary["schema_version"]
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise InputError(f"{shown(path)}: 'schema_version' must be a non-negative integer, "
                         f"got {brief(v)}")
    if v > SCHEMA_VERSION:
        writer = summary.get("dampfit_version") or "a newer dampfit"
        raise InputError(f"{shown(path)} has result schema version {v} (written by dampfit "
                         f"{shown(writer, 40)}); this dampfit reads versions up to "
                         f"{SCHEMA_VERSION}: upgrade dampfit to read it")
    return v


def read_regular(path: Path, limit: int, missing: InputError | str, folder: Path | None = None,
                 what: str = "a dampfit summary.json is a few kB") -> bytes:
    """Bytes of the regular file ``path`` of a result folder, at most ``limit`` bytes
    (:func:`dampfit.result.files.read_regular`: not a link, FIFO, socket, device or directory,
    checked on the descriptor opened without blocking). A missing file raises ``missing``;
    with ``folder`` every refusal is :func:`not_a_result`."""
    def refuse(why: str) -> InputError:
        return not_a_result(folder, why, again=True) if folder is not None else InputError(why)

    return files.read_regular(path, limit, missing, refuse=refuse, what=what)


class _TooDeep(ValueError):
    """Parsed JSON nested deeper than :data:`MAX_DEPTH`."""


def _plain(obj: Any, depth: int = 0) -> Any:
    """``obj`` (parsed JSON) made plain: integers beyond float precision as floats (±inf
    beyond range), strings as valid UTF-8 (lone surrogates replaced); :class:`_TooDeep` past
    :data:`MAX_DEPTH` levels of nesting."""
    if depth > MAX_DEPTH:
        raise _TooDeep(f"nested deeper than {MAX_DEPTH} levels")
    if isinstance(obj, dict):
        return {_plain(k, depth + 1): _plain(v, depth + 1) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_plain(v, depth + 1) for v in obj]
    if isinstance(obj, int) and not isinstance(obj, bool) and abs(obj) > 2**53:
        try:
            return float(obj)
        except OverflowError:
            return math.inf if obj > 0 else -math.inf
    if isinstance(obj, str):
        return obj.encode("utf-8", "replace").decode("utf-8")
    return obj


def _kind(value: Any) -> str:
    return {dict: "object", list: "array", str: "string", bool: "boolean"}.get(
        type(value), "null" if value is None else "number")


def brief(value: Any) -> str:
    """A JSON value as the user wrote it, shortened: ``true``, ``"0.2"``, ``an array``…"""
    if isinstance(value, (dict, list)):
        return f"an {_kind(value)}"
    try:
        text = json.dumps(value, ensure_ascii=True)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def number(value: Any, field: str, where: str | Path, *, positive: bool = False,
           nonnegative: bool = False, maximum: float = MAX_MAGNITUDE) -> float:
    """``value`` of ``field`` in file ``where`` as a float, or :class:`InputError` naming both.

    It must be a real number (not a boolean, string, array, object or null), finite, of
    magnitude at most ``maximum``, and ``> 0`` (``positive``, then also at least
    :data:`MIN_POSITIVE`) or ``≥ 0`` (``nonnegative``) if asked.
    """
    head = f"{shown(where)}: {field}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{head} must be a number, got {brief(value)}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise InputError(f"{head} must be finite, got {brief(value) if isinstance(value, int) else x}")
    if positive and not x >= MIN_POSITIVE:
        raise InputError(f"{head} must be positive (at least {MIN_POSITIVE:g}), got {x!r}")
    if nonnegative and x < 0:
        raise InputError(f"{head} must not be negative, got {x!r}")
    if abs(x) > maximum:
        raise InputError(f"{head} = {x:g} is beyond {maximum:g}: not a plausible value")
    return x
