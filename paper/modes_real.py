"""How many modes are in the real cantilever recordings? (issue 21, item "Real data")

Reads every recording under ``../shared/data/real/cantilever-*`` with :func:`dampfit.read`,
prepares it as the pipeline does (:func:`dampfit.signal.prepare.prepare`, automatic axis, band
and window) and runs the order selection (:func:`dampfit.inference.modes_select.select`,
max_modes = 4) on the modal band. Prints, per recording: the one-mode f₀, the modal band and
window, P(K) for K = 1 … 4 with the reasons, the chosen modes (f_d, ζ, amplitude z), the
spectrum peaks of the window (the evidence a reader can check), and the Euler–Bernoulli
prediction of the second bending mode, f₂ ≈ 6.27·f₁ (clamped–free beam; (β₂L/β₁L)² =
(4.694/1.875)²). Writes one CSV row per recording.

Usage::

    python paper/modes_real.py --out paper/results/modes_real.csv
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                                   "intra_op_parallelism_threads=1")

import numpy as np  # noqa: E402

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
#: Second/first bending frequency of a uniform clamped–free beam (Euler–Bernoulli).
RATIO_2_1 = (4.694091 / 1.875104) ** 2


def analyse(path: Path) -> dict:
    import dampfit
    from dampfit.inference import modes_select as MS
    from dampfit.signal import prepare as pp

    rec = dampfit.read(path)
    prep = pp.prepare(rec)
    t0 = time.perf_counter()
    sel = MS.select(prep, max_modes=4)
    fit = sel.chosen.fit
    zeta = fit.p / np.hypot(fit.p, fit.omega_d)
    s = sel.summary()
    return {
        "recording": str(path.relative_to(REAL)), "f0_hz": prep.f0,
        "band_hz": f"{sel.band[0]:.4g}-{sel.band[1]:.4g}", "window_s": sel.span,
        "fit_rate_hz": sel.fit_data.fs, "n_samples": sel.fit_data.tau.size,
        "n_modes": sel.n_modes,
        "p_k": " ".join(f"{r['probability']:.3g}" for r in s["evidence"]),
        "ln_z": " ".join("nan" if r["ln_evidence"] is None else f"{r['ln_evidence']:.6g}"
                         for r in s["evidence"]),
        "f_d_hz": " ".join(f"{f:.5g}" for f in fit.f_d),
        "zeta": " ".join(f"{z:.3g}" for z in zeta),
        "amplitude_z": " ".join(f"{z:.3g}" for z in sel.chosen.z),
        "psd_ratio": sel.psd_ratio,
        "peaks_hz": " ".join(f"{f:.4g}({a:.2g})" for f, a in sel.peaks),
        "pencil_poles_hz": " ".join(f"{q.f_d:.4g}" for q in (sel.pencil.poles[:6]
                                                             if sel.pencil else ())),
        "f2_euler_bernoulli_hz": RATIO_2_1 * prep.f0,
        "reasons": " | ".join(f"K={k}: {v}" for k, v in sel.reasons().items()),
        "notes": " | ".join(sel.notes + sel.warnings),
        "runtime_s": time.perf_counter() - t0,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="paper/results/modes_real.csv")
    a = ap.parse_args(argv)
    files = sorted(p for p in REAL.glob("cantilever-*/**/*") if p.suffix in (".npy", ".csv"))
    if not files:
        print(f"no cantilever recordings under {REAL}", file=sys.stderr)
        return 1
    rows = []
    for path in files:
        try:
            row = analyse(path)
        except Exception as exc:  # noqa: BLE001 - report and go on
            row = {"recording": str(path.relative_to(REAL)),
                   "notes": f"{type(exc).__name__}: {exc}"}
        rows.append(row)
        print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()},
              flush=True)
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(a.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
