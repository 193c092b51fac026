"""Quick start in Python: simulate a phone recording, analyse it, compare with the truth.

Run:  python examples/01_quickstart.py  (about 15 s; writes nothing)
"""

import dampfit
from dampfit import simulate

# A phone on a soft spring (0.33 kg, 0.9 Hz, ζ = 1 %), recorded at 100 Hz with 7 % timing
# jitter, bias drift, tilt, a hand-held start and a catch at the end.
rec, truth = simulate.recording(simulate.preset("phone", seed=42))

result = dampfit.analyze(rec, mass=truth["mass"], mass_sd=0.005, seed=1)
s = result.summary()

print(f"{'':6s} {'truth':>10s} {'median':>10s} {'90 % interval':>25s}")
for name in ("c", "k", "zeta", "f_n"):
    q = s["parameters"][name]
    print(f"{name:6s} {truth[name]:10.5g} {q['q50']:10.5g}   [{q['q05']:10.5g}, {q['q95']:10.5g}]")
print("baselines:", {k: round(v["c"], 5) for k, v in s["baselines"].items() if v})
print("converged:", s["diagnostics"]["converged"], "| warnings:", s["diagnostics"]["warnings"])
