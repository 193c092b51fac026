"""Why a separation threshold alone cannot tell an unresolved close pair from friction (issue 34).

For each replicate of the false-mode study's ``close_pair``, ``coulomb``, ``quadratic`` and
``drifting`` cases (:func:`modes_false_rate.simulate`, the same seeds), the one-mode analysis
and its damping-law verdict are run as :func:`modes_false_rate._modes_path` runs them, and
then the pair fit of :func:`dampfit.inference.modes_checks.unresolved_pair` *before* its two
thresholds (:func:`dampfit.inference.modes_checks.pair_fit`): the BIC score of two viscous
modes against the preferred law (< 0: the pair fits better) and the pair's separation in
resolution cells Δf·T. ``unresolved_pair`` flags score < 0 and Δf·T ≥ ``PAIR_MIN_CELLS``.

Usage::

    nice -n 10 python paper/modes_pair_separation.py --replicates 25 \\
        --out paper/results/modes_pair_separation.csv
    python paper/modes_pair_separation.py --summary paper/results/modes_pair_separation.csv

Rows are appended as they finish; a rerun skips the (case, seed) already there.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import modes_false_rate as M  # noqa: E402

CASES = ("close_pair", "coulomb", "quadratic", "drifting")
FIELDS = ("case", "seed", "verdict", "law", "score", "cells", "span_s", "seconds")


def row(case: str, seed: int) -> dict:
    from dampfit import damping, stages
    from dampfit._options import SamplerSettings
    from dampfit.inference import modes_checks
    from dampfit.signal import prepare

    t0 = time.perf_counter()
    rec, _ = M.simulate(case, seed)
    prep = prepare.prepare(rec, axis="auto")
    st = stages.fit_stages(prep, M.MASS)
    ls = st.least_squares
    a = damping.assess(prep, st.fit_data, ls, st.noise, M.MASS, 0.0, posterior="laplace",
                       sampler=SamplerSettings(seed=seed, min_ess=M.MIN_ESS))
    fd, fit = st.fit_data, a.fits[a.verdict["preferred"]]
    res = np.asarray(fit.residuals, float)
    got = modes_checks.pair_fit(fd.tau, fd.y, fd.drift, float(ls.p), float(ls.omega_d),
                                float(res @ res), fit.k)
    span = float(fd.tau[-1] - fd.tau[0])
    score, f = got if got else (math.nan, [math.nan, math.nan])
    return {"case": case, "seed": seed, "verdict": a.verdict_name, "law": fit.model,
            "score": round(score, 2), "cells": round((f[1] - f[0]) * span, 4),
            "span_s": round(span, 2), "seconds": round(time.perf_counter() - t0, 1)}


def summary(path: Path) -> str:
    from dampfit.inference.modes_checks import PAIR_MIN_CELLS

    rows = list(csv.DictReader(path.open()))
    lines = ["| case | replicates | pair preferred (score < 0) | their separation [cells] | "
             f"flagged (≥ {PAIR_MIN_CELLS} cells) |", "|---|---|---|---|---|"]
    for case in CASES:
        r = [x for x in rows if x["case"] == case]
        neg = sorted(float(x["cells"]) for x in r if float(x["score"]) < 0)
        flagged = sum(c >= PAIR_MIN_CELLS for c in neg)
        span = f"{neg[0]:.3g}–{neg[-1]:.3g}" if neg else "–"
        lines.append(f"| {case} | {len(r)} | {len(neg)} | {span} | {flagged} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=25)
    ap.add_argument("--out", type=Path, default=Path("paper/results/modes_pair_separation.csv"))
    ap.add_argument("--summary", type=Path)
    a = ap.parse_args(argv)
    if a.summary:
        print(summary(a.summary))
        return 0
    done = set()
    if a.out.exists():
        done = {(r["case"], int(r["seed"])) for r in csv.DictReader(a.out.open())}
    new = not a.out.exists()
    with a.out.open("a", newline="") as fh:
        w = csv.DictWriter(fh, FIELDS)
        if new:
            w.writeheader()
        for seed in range(a.replicates):
            for case in CASES:
                if (case, seed) not in done:
                    w.writerow(row(case, seed))
                    fh.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
