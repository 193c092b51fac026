"""What the several-modes default costs and finds on every real recording (issue 21).

For each recording under ``../shared/data/real`` (read in place with :func:`dampfit.read`,
never copied), the whole single-recording analysis runs twice in one warmed-up process, seed 0: with
``max_modes=1`` (the modal stage skipped) and with the default (up to 4 modes). One CSV row
per recording: both wall times [s] and their ratio, the modes reported, what decided it (the
screen, the evidence, harmonics), whether the modal posterior converged, the one-mode damping
verdict, and whether the one-mode ``parameters`` are the same both ways (they must be: the
modal stage runs after them). A Markdown table is written beside the CSV.

Usage (from the checkout root; ≈ 15 min on two cores)::

    python paper/modes_default.py --out paper/results/modes_default.csv
"""

from __future__ import annotations

import argparse
import csv
import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
FIELDS = ["recording", "seconds_one_mode", "seconds_default", "ratio", "n_modes", "f_n_hz",
          "decided_by", "modal_converged", "verdict", "parameters_identical"]


def _row(path: Path) -> dict:
    import dampfit

    rec = dampfit.read(path)
    out = {"recording": str(path.relative_to(REAL))}
    runs = {}
    for label, kw in (("one_mode", {"max_modes": 1}), ("default", {})):
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[label] = dampfit.analyze(rec, seed=0, **kw).summary()
        out[f"seconds_{label}"] = round(time.perf_counter() - start, 2)
    s = runs["default"]
    ev = s["modes_evidence"]
    out["ratio"] = round(out["seconds_default"] / out["seconds_one_mode"], 2)
    out["n_modes"] = s["n_modes"]
    out["f_n_hz"] = " / ".join(f"{m['f_n']['q50']:.4g}" for m in s["modes"])
    if ev.get("harmonics"):
        out["decided_by"] = "harmonics: " + ", ".join(
            f"{h['f_d_hz']:.4g} Hz = {h['multiple']} x {h['of_hz']:.4g} Hz"
            for h in ev["harmonics"])
    elif ev.get("split"):
        out["decided_by"] = "split of the one mode: " + ", ".join(
            f"{e['f_d_hz']:.4g} Hz" for e in ev["split"])
    elif ev.get("screen") and ev["screen"].get("passed") is False:
        out["decided_by"] = "screen"
    else:
        best = max((r["probability"] for r in ev.get("evidence") or []), default=None)
        out["decided_by"] = "evidence" + (f" (P(K) = {best:.2g})" if best is not None else "")
    sampling = ev.get("sampling") or {}
    out["modal_converged"] = sampling.get("converged") if s["n_modes"] > 1 else ""
    out["verdict"] = s["model_checks"]["verdict"]
    out["parameters_identical"] = runs["one_mode"]["parameters"] == s["parameters"]
    return out


def _markdown(rows: list[dict]) -> str:
    lines = ["| " + " | ".join(FIELDS) + " |", "|" + "---|" * len(FIELDS)]
    lines += ["| " + " | ".join(str(r[k]) for k in FIELDS) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="CSV to write (and .md beside it)")
    args = ap.parse_args(argv)
    if not REAL.is_dir():
        raise SystemExit(f"no real recordings at {REAL}")
    files = sorted(p for p in REAL.rglob("*") if p.suffix in (".csv", ".npy"))
    _row(files[0])  # warm-up: the first analysis of a process compiles or loads the kernels
    rows = []
    for path in files:
        rows.append(_row(path))
        print(rows[-1], flush=True)
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
    args.out.with_suffix(".md").write_text(
        "<!-- written by paper/modes_default.py -->\n\n" + _markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
