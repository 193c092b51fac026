"""FEM hand-off: analyse a recording, write an LS-DYNA deck, verify the damper in OpenSeesPy.

Run:  python examples/03_fem_export_verify.py [OUT_DIR]   (about 20 s)

The recording is simulated (the seed paper's set-up: 5.3 kg on a spring, 1.72 Hz,
c = 0.2 N·s/m). The same three steps on the command line::

    dampfit analyze rec.csv --mass 5.3 --mass-sd 0.02 --out result --report
    dampfit export result --format lsdyna --units mm-s-t
    dampfit verify result

``dampfit verify`` needs OpenSeesPy (``pip install 'dampfit[fem]'``) and, on Debian, its
BLAS/LAPACK (``sudo apt-get install libblas3 liblapack3``). Without them the example says so
and stops after the exports — or fails if ``DAMPFIT_REQUIRE_ALL=1`` (as in CI).
"""

import json
import os
import sys
import tempfile
from pathlib import Path

from dampfit import simulate
from dampfit.cli import main
from dampfit.fem.opensees import unavailable

missing = unavailable()  # checked first: None, or why OpenSeesPy cannot run and the fix
if missing and os.environ.get("DAMPFIT_REQUIRE_ALL", "").strip() not in ("", "0"):
    sys.exit(f"DAMPFIT_REQUIRE_ALL=1: {missing}")

out_root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
out_root.mkdir(parents=True, exist_ok=True)
csv = out_root / "paper.csv"
rec, truth = simulate.recording(simulate.preset("paper", seed=7))
simulate.write_phyphox_csv(rec, csv)

result = out_root / "result"
steps = [
    ["analyze", str(csv), "--mass", "5.3", "--mass-sd", "0.02", "--out", str(result),
     "--quiet", "--no-figures", "--force"],
    ["export", str(result), "--format", "lsdyna", "--units", "mm-s-t", "--force"],
    ["export", str(result), "--format", "opensees", "--force"],
]
if missing:
    print(f"(dampfit verify is left out: {missing})")
else:
    steps.append(["verify", str(result)])
for argv in steps:
    print("$ dampfit", " ".join(argv))
    code = main(argv)
    if code != 0:
        sys.exit(code)

print("\nfiles:", ", ".join(sorted(p.name for p in result.iterdir())))
if not missing:
    ver = json.loads((result / "verification.json").read_text())
    print("truth c =", truth["c"], "N s/m; verification keys:", ", ".join(sorted(ver)))
