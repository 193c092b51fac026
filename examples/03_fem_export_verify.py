"""FEM hand-off: analyse a recording, write an LS-DYNA deck, verify the damper in OpenSeesPy.

Run:  python examples/03_fem_export_verify.py [OUT_DIR]   (about 20 s)

The recording is simulated (the seed paper's set-up: 5.3 kg on a spring, 1.72 Hz,
c = 0.2 N·s/m). The same three steps on the command line::

    dampfit analyze rec.csv --mass 5.3 --mass-sd 0.02 --out result --report
    dampfit export result --format lsdyna --units mm-s-t
    dampfit verify result
"""

import json
import sys
import tempfile
from pathlib import Path

from dampfit import simulate
from dampfit.cli import main

out_root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
out_root.mkdir(parents=True, exist_ok=True)
csv = out_root / "paper.csv"
rec, truth = simulate.simulate(simulate.preset("paper", seed=7))
simulate.write_phyphox_csv(rec, csv)

result = out_root / "result"
steps = [
    ["analyze", str(csv), "--mass", "5.3", "--mass-sd", "0.02", "--out", str(result),
     "--quiet", "--no-figures", "--force"],
    ["export", str(result), "--format", "lsdyna", "--units", "mm-s-t", "--force"],
    ["export", str(result), "--format", "opensees", "--force"],
    ["verify", str(result)],
]
for argv in steps:
    print("$ dampfit", " ".join(argv))
    code = main(argv)
    if code != 0:
        sys.exit(code)

ver = json.loads((result / "verification.json").read_text())
print("\nfiles:", ", ".join(sorted(p.name for p in result.iterdir())))
print("truth c =", truth["c"], "N s/m; verification keys:", ", ".join(sorted(ver)))
