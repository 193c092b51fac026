"""Estimator comparison on one simulated recording, against the Cramér–Rao bound.

Run:  python examples/02_estimator_comparison.py   (about 15 s)

Every estimator of ``dampfit.study.registry`` sees the same recording, window and band. For a
study over many replicates and scenarios (bias, RMSE/CRLB, coverage) use
``dampfit study examples/study_ranking.toml``.
"""

import numpy as np

from dampfit import simulate
from dampfit.inference import crlb
from dampfit.study import registry
from dampfit.io.recording import STANDARD_GRAVITY

MASS = 5.3  # [kg]
cfg = simulate.from_modal(MASS, 2.0, 0.01, u0=0.02, duration=60.0, sample_rate=200.0,
                          noise_density=2000.0, seed=3)
rec, truth = simulate.recording(cfg)

results = registry.run(list(registry.ESTIMATORS), rec, mass=MASS, seed=0)

# the bound for this design: the samples after release, the simulated white-noise level
sigma = crlb.from_noise_density(cfg.noise_density * 1e-6 * STANDARD_GRAVITY, cfg.sample_rate)
omega_d = 2 * np.pi * truth["f_d"]
t = rec.time - cfg.handheld
amp = cfg.u0 * truth["k"] / MASS  # acceleration amplitude at release [m/s²]
bound = crlb.bound(t[t >= 0], sigma, p=truth["p"], omega_d=omega_d, a_cos=-amp, a_sin=0.0,
                   mass=MASS)["c"]["sd"]

print(f"truth c = {truth['c']:.5f} N s/m, CRLB sd(c) = {bound:.2e} N s/m "
      "(whole decay, mass known)\n")
print(f"{'estimator':18s}{'c [N s/m]':>12s}{'error/CRLB':>12s}{'90 % interval':>26s}{'time [s]':>10s}")
for e in results:
    if not e.ok:
        print(f"{e.estimator:18s}  failed: {e.message}")
        continue
    interval = f"[{e.c_lo:.5f}, {e.c_hi:.5f}]" if e.c_lo is not None else "—"
    print(f"{e.estimator:18s}{e.c:12.5f}{(e.c - truth['c']) / bound:12.1f}{interval:>26s}"
          f"{e.runtime_s:10.2f}")
