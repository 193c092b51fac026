"""Wall time and sampler steps of campaigns with 2, 3 and 5 tests of one simulated damper.

For each seed it simulates one damper (known mass, a between-test spread of ln c) with
:func:`dampfit.simulate.campaign` and analyses its first 2, 3 and 5 tests with
:func:`dampfit.campaign.analyze_campaign` (warm: one untimed campaign of each size compiles
first). It prints, per campaign: the sampling wall time [s], the emcee steps of both
frequency models, the integrated autocorrelation times [steps] and the posterior probability
of a shared frequency; then the median ratio of the 2-test to the 3-test time. Usage::

    python paper/campaign_timing.py --seeds 0 1 2 3 4 [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

SIZES = (2, 3, 5)


def run(seed: int, n_tests: int, recordings: list, mass: float) -> dict:
    """Analyse the first ``n_tests`` of ``recordings``; timing and sampler facts."""
    from dampfit.campaign import analyze_campaign

    t0 = time.perf_counter()
    an = analyze_campaign(recordings[:n_tests], mass=mass, seed=seed)
    total = time.perf_counter() - t0
    s = an.sampling
    return {"seed": seed, "n_tests": n_tests, "total_s": total, "sampling_s": s.seconds,
            "n_steps": int(s.n_steps), "autocorr_time": [float(x) for x in s.autocorr_time],
            "p_shared_frequency": float(s.p_shared_frequency), "converged": bool(s.converged)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--c-spread", type=float, default=0.1)
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    from dampfit import simulate as sim

    mass = 0.8
    base = sim.from_modal(mass, 3.0, 0.01, u0=0.005, duration=20.0, sample_rate=100.0,
                          noise_density=300.0)
    rows = []
    warm, _ = sim.campaign(base, n_tests=max(SIZES), c_spread=a.c_spread, seed=10**6)
    for n in SIZES:  # compile every kernel once, untimed
        run(0, n, warm, mass)
    for seed in a.seeds:
        recs, _ = sim.campaign(base, n_tests=max(SIZES), c_spread=a.c_spread, seed=seed)
        for n in SIZES:
            row = run(seed, n, recs, mass)
            rows.append(row)
            print(f"seed {seed} tests {n}: sampling {row['sampling_s']:6.2f} s, total "
                  f"{row['total_s']:6.2f} s, steps {row['n_steps']:6d}, tau "
                  f"{np.round(row['autocorr_time'], 1)}, P(shared f) "
                  f"{row['p_shared_frequency']:.2f}, converged {row['converged']}", flush=True)
    ratio = {n: float(np.median([r["sampling_s"] for r in rows if r["n_tests"] == n]
                                ) / np.median([r["sampling_s"] for r in rows if r["n_tests"] == 3]))
             for n in SIZES}
    steps = {n: float(np.median([r["n_steps"] for r in rows if r["n_tests"] == n])) for n in SIZES}
    print("median sampling time relative to 3 tests:", {n: round(v, 2) for n, v in ratio.items()})
    print("median steps:", steps)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"rows": rows, "time_ratio_to_3": ratio, "median_steps": steps}, fh,
                      indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
