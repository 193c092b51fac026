"""Hand-built summaries: a single-recording summary.json to vary field by field
(:func:`summary`), and a campaign summary following the campaign contract (:func:`hand_summary`)."""

from __future__ import annotations

import copy

BASE = {
    "dampfit_version": "0.1.0",
    "input": {"path": "rec.csv", "format": "phyphox-csv", "n_samples": 6000,
              "sample_rate_hz": 100.0, "duration_s": 60.0, "axis": "z"},
    "window": {"start_s": 1.0, "end_s": 8.0, "auto": True, "n_cycles": 12.0},
    "band": {"low_hz": 1.15, "high_hz": 2.58}, "dominant_frequency_hz": 1.72,
    "mass": {"value": 0.23, "sd": 0.0, "unit": "kg"},
    "parameters": {
        "c": {"q05": 0.0195, "q50": 0.0201, "q95": 0.0207, "sd": 0.00036, "r_hat": 1.001,
              "ess_bulk": 5000.0},
        "f_n": {"q05": 1.71992, "q50": 1.72031, "q95": 1.72068, "sd": 0.00023, "r_hat": 1.001,
                "ess_bulk": 5000.0},
        "p": {"q05": 0.0424, "q50": 0.0437, "q95": 0.0450, "sd": 0.0008, "r_hat": 1.001,
              "ess_bulk": 5000.0},
    },
    "least_squares": {"c": 0.0201, "zeta": 0.004, "converged": True},
    "baselines": {
        "log_decrement": {"c": 0.18, "zeta": 0.036, "p": 0.39, "n_cycles": 2,
                          "n_cycles_used": 2.0, "n_cycles_window": 12.0, "supported": False,
                          "support_reason": "rests on only 2 cycles (fewer than 5)",
                          "expected_rel_sd": 0.3, "agrees_with_posterior": False,
                          "note": "log decrement gives p = 0.39 1/s, 8.9x the posterior"},
        "envelope_pipeline": {"c": 0.0203, "zeta": 0.004, "p": 0.044, "n_cycles": None,
                              "n_cycles_used": 9.1, "n_cycles_window": 12.0,
                              "supported": True, "support_reason": None,
                              "expected_rel_sd": 0.05, "agrees_with_posterior": True,
                              "note": None},
    },
    "noise_model": {"sigma": 0.05, "sample_rate_hz": 100.0, "psd_ratio_at_f0": 1.1},
    "model_checks": None,
    "c_equivalent": None,
    "diagnostics": {"converged": True, "max_r_hat": 1.001, "min_ess_bulk": 5000.0,
                    "n_steps": 300, "n_walkers": 64, "warnings": []},
}


def summary(**changes):
    s = copy.deepcopy(BASE)
    s.update(changes)
    return s


# ----------------------------------------------------------------------------- fixtures
def _q(m, sd, unit=None):
    d = {"mean": m, "sd": sd, "q05": m - 1.645 * sd, "q50": m, "q95": m + 1.645 * sd,
         "r_hat": 1.002, "ess_bulk": 2400.0}
    if unit is not None:
        d["unit"] = unit
    return d


def _qi(m, sd):
    return {"q05": m - 1.645 * sd, "q50": m, "q95": m + 1.645 * sd, "sd": sd}


def hand_summary(added_mass: bool = False, n: int = 3, paths=None) -> dict:
    """A campaign summary as /tmp/campaign_contract.md specifies it (schema_version 1)."""
    m, k = 5.3, 619.0
    dms = [0.0, 2.0, 4.0, 6.0][:n] if added_mass else [None] * n
    paths = paths or [f"/data/rec-{i + 1}.csv" for i in range(n)]
    tests = []
    for i in range(n):
        c = 0.2 * (1 + 0.05 * (i - 1))
        tests.append({
            "index": i + 1,
            "input": {"path": str(paths[i]), "sha256": "ab" * 32, "n_samples": 2000,
                      "sample_rate_hz": 100.0, "duration_s": 20.0},
            "window": {"start_s": 0.5, "end_s": 19.5}, "added_mass_kg": dms[i],
            "amplitude_m": 0.04 - 0.01 * i,
            "own": {"c": _qi(c, 0.01), "zeta": _qi(c / 114.6, 1e-4), "f_n": _qi(1.72, 1e-3),
                    "p": _qi(c / 2 / m, 1e-3)},
            "pooled": {"c": _qi(0.2, 0.008), "zeta": _qi(0.2 / 114.6, 8e-5),
                       "f_n": _qi(1.72, 1e-3), "p": _qi(0.2 / 2 / m, 8e-4)},
            "outlier": i == n - 1})
    params = {"c": _q(0.2, 0.01, "N s/m"), "k": _q(k, 3.0, "N/m"), "zeta": _q(0.00175, 1e-4, "1"),
              "f_n": _q(1.72, 0.002, "Hz"), "p": _q(0.0189, 0.001, "1/s"),
              "c_crit": _q(114.6, 0.5, "N s/m")}
    s = {"schema_version": 1, "kind": "campaign", "dampfit_version": "0.test",
         "design": {"n_tests": n, "model": "added-mass" if added_mass else "hierarchical",
                    "mass": None if added_mass else {"value": m, "sd": 0.02, "unit": "kg"},
                    "added_mass": ({"values": dms, "sd": 0.001, "unit": "kg"} if added_mass
                                   else None)},
         "parameters": params,
         "mass": {"value": m, "sd": 0.1 if added_mass else 0.02, "unit": "kg"},
         "population": {
             "spread": {"p": {"unit": "1", "q05": 0.01, "q50": 0.04, "q95": 0.12},
                        "omega": {"unit": "1", "q05": 0.0001, "q50": 0.001, "q95": 0.003}},
             "predictive": {"c": {"unit": "N s/m", "q05": 0.17, "q50": 0.2, "q95": 0.23},
                            "zeta": {"unit": "1", "q05": 0.0015, "q50": 0.00175, "q95": 0.002},
                            "f_n": {"unit": "Hz", "q05": 1.71, "q50": 1.72, "q95": 1.73},
                            "k": {"unit": "N/m", "q05": 612.0, "q50": 619.0, "q95": 626.0}},
             "spread_consistent_with_zero": True},
         "tests": tests,
         "checks": {"verdict": "outlier",
                    "text": f"Test {n} disagrees with the others beyond its own uncertainty.",
                    "tau_over_within": 1.3, "outliers": [n],
                    "amplitude": {"slope": 0.1, "q05": -0.2, "q95": 0.4,
                                  "explains_scatter": False}},
         "added_mass": None,
         "diagnostics": {"converged": True, "max_r_hat": 1.004, "min_ess_bulk": 1800.0,
                         "n_steps": 3000, "warnings": []},
         "warnings": []}
    if added_mass:
        params["m0"] = _q(m, 0.1, "kg")
        s["added_mass"] = {"m0": _q(m, 0.1, "kg"), "k": _q(k, 3.0, "N/m"),
                           "points": [{"added_mass_kg": dm, "omega_n2": k / (m + dm),
                                       "omega_n2_sd": 0.05} for dm in dms],
                           "line": {"intercept": m / k, "slope": 1 / k}}
    return s
