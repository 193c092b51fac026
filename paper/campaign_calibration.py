"""Interval calibration of the campaign analysis (issue 12) on simulated test campaigns.

Each replicate draws a campaign design at random (seeded by the replicate number):
3–8 tests, between-test spread of ln c uniform on 0–30 % (a quarter of the replicates exactly
0), f_n 2–10 Hz, ζ 0.005–0.03, sensor noise 100–3000 µg/√Hz (log-uniform), 20 s at 100 Hz per
test; half the replicates have a known mass (design "hierarchical", mass exact), the other
half the added-mass design (evenly spaced added masses from 0 to 20–100 % of m₀, known to
0.2 % of m₀). It simulates the tests with :func:`dampfit.simulate.campaign`, runs
:func:`dampfit.campaign.analyze_campaign` and records whether the 90 % intervals contain
the truth (the scoring of :mod:`dampfit.study.campaign`, which campaign studies —
``dampfit study`` with a [campaign] table — share):

* ``c``, ``k`` — the population damper (median of the log-normal population, fixed k);
* ``m0`` — the effective mass (added-mass design);
* ``predictive_c`` — a new test's c drawn from the true population, c·exp(spread·z);
* ``spread_zero_ok`` — with zero true spread, the reported spread is consistent with zero.

A calibrated analysis covers 85–95 % for each (binomial sd ≈ 3 % at 100 replicates). Usage::

    python paper/campaign_calibration.py --replicates 100 --workers 2 --out campaign_calibration.csv

``--design added-mass --start 101 --replicates 100`` runs the 50 added-mass replicates 101,
103, … 199 (with the first 100: 100 added-mass replicates for m₀; the committed CSV holds both
runs).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import math
import os
import sys
import time

import numpy as np
import pandas as pd

ROOT_SEED = 20261123
M0 = 1.0  # [kg]


def design(rep: int) -> dict:
    """The random campaign design of replicate ``rep`` (plain data)."""
    rng = np.random.default_rng(np.random.SeedSequence([ROOT_SEED, rep]))
    n = int(rng.integers(3, 9))
    spread = 0.0 if rng.random() < 0.25 else float(rng.uniform(0.0, 0.3))
    added = rep % 2 == 1
    top = float(rng.uniform(0.2, 1.0)) * M0
    return {
        "rep": rep, "n_tests": n, "c_spread": spread, "added": added,
        "added_mass": [float(x) for x in np.linspace(0.0, top, n)] if added else None,
        "f_n": float(rng.uniform(2.0, 10.0)), "zeta": float(rng.uniform(0.005, 0.03)),
        "noise_density": float(np.exp(rng.uniform(np.log(100.0), np.log(3000.0)))),
        "z_new": float(rng.standard_normal()), "seed": int(rng.integers(2**31)),
    }


def one(rep: int, max_steps: int, min_ess: float) -> dict:
    """Simulate, analyse and score replicate ``rep`` (:func:`dampfit.study.campaign.run`, the
    scoring shared with campaign studies); one CSV row."""
    from dampfit import simulate as sim
    from dampfit.study import campaign

    d = design(rep)
    base = sim.from_modal(M0, d["f_n"], d["zeta"], duration=20.0, sample_rate=100.0,
                          noise_density=d["noise_density"])
    from dampfit._options import SamplerSettings

    design = campaign.Design(d["n_tests"], d["c_spread"], d["added_mass"],
                             added_mass_sd=0.002 * M0)
    r = campaign.run(base, design, mass_known=True, sim_seed=d["seed"], z_new=d["z_new"],
                     sampler=SamplerSettings(seed=rep, max_steps=max_steps, min_ess=min_ess))
    row = {k: v for k, v in d.items() if k not in ("added_mass", "z_new", "seed")}
    row["max_added_mass_kg"] = max(d["added_mass"]) if d["added"] else 0.0
    row.update(refused=r["refused"], seconds=r["runtime_s"])
    if r["refused"]:
        return row

    def flag(x):  # a coverage flag as 1.0/0.0, NaN where it is not defined
        return math.nan if x is None else float(x)

    row.update(
        converged=r["converged"], n_steps=r["n_steps"],
        importance_ess=r["importance_ess_fraction"],
        c_true=r["true_c"], c_q50=r["est_c"], cover_c=flag(r["covers_c"]),
        cover_k=flag(r["covers_k"]), cover_m0=flag(r["covers_m0"]),
        cover_predictive_c=flag(r["covers_predictive_c"]), spread_q50=r["spread_q50"],
        spread_zero_ok=flag(r["spread_zero_ok"]), verdict=r["verdict"],
    )
    return row


def table(df: pd.DataFrame) -> pd.DataFrame:
    """Coverage [%] of each check with its binomial sd, overall and by design."""
    rows = []
    for label, part in (("all", df), ("known mass", df[~df["added"]]),
                        ("added mass", df[df["added"]])):
        for col in ("cover_c", "cover_k", "cover_m0", "cover_predictive_c", "spread_zero_ok"):
            if col not in part:
                continue
            x = part[col].dropna().astype(float)
            if x.empty:
                continue
            cov = x.mean()
            rows.append({"design": label, "check": col.replace("cover_", ""), "n": len(x),
                         "coverage_%": 100 * cov,
                         "binomial_sd_%": 100 * math.sqrt(max(cov * (1 - cov), 1e-12) / len(x))})
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=100)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--start", type=int, default=0, help="first replicate number")
    ap.add_argument("--max-steps", type=int, default=10000)
    ap.add_argument("--min-ess", type=float, default=400.0)
    ap.add_argument("--design", choices=["both", "added-mass", "hierarchical"], default="both",
                    help="only the replicates of one design (the added-mass ones are the odd "
                    "replicate numbers)")
    ap.add_argument("--out", default="campaign_calibration.csv")
    a = ap.parse_args(argv)
    reps = [r for r in range(a.start, a.start + a.replicates)
            if a.design == "both" or (r % 2 == 1) == (a.design == "added-mass")]
    t0 = time.perf_counter()
    rows = []
    if a.workers <= 1:
        for r in reps:
            rows.append(one(r, a.max_steps, a.min_ess))
            print(f"replicate {r}: {rows[-1].get('seconds', float('nan')):.1f} s", file=sys.stderr)
    else:
        with cf.ProcessPoolExecutor(a.workers) as ex:
            futs = [ex.submit(one, r, a.max_steps, a.min_ess) for r in reps]
            for f in cf.as_completed(futs):
                rows.append(f.result())
    df = pd.DataFrame(rows).sort_values("rep")
    df.to_csv(a.out, index=False)
    wall = time.perf_counter() - t0
    pd.set_option("display.width", 120)
    print(table(df[df["refused"] == ""]).to_string(index=False, float_format="%.1f"))
    print(f"\n{len(df)} replicates, {int((df['refused'] != '').sum())} refused, "
          f"{int(df.get('converged', pd.Series(dtype=bool)).fillna(False).astype(bool).sum())} "
          f"converged; analysis {df['seconds'].mean():.1f} s per replicate (mean), "
          f"wall {wall:.0f} s with {a.workers} worker(s); CSV: {os.path.abspath(a.out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
