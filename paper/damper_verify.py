"""Is the exported nonlinear damper the measured one? (issue 32, "Done when": the real
amplitude-dependent recordings)

For each amplitude-dependent real recording in ``../shared/data/real`` — the phone on a spring
(``phone-spring-metalcupcake5/raw_data.csv``, m = 0.3255 kg) and the three ADXL357 50 cm
cantilevers (``cantilever-adxl357-demirkaya/tests_for_comparing_1st_nfreq/50cm_adxl/*``,
m_eff ≈ 0.037 kg: 0.236·m_beam + 5 g tip, SOURCES.md) — it

1. analyses the recording with the defaults (``dampfit analyze FILE --mass KG --out DIR``;
   ``--reuse`` keeps a folder that already holds a summary.json);
2. exports the default deck for LS-DYNA and OpenSees (``dampfit export DIR --format
   lsdyna|opensees``: the recommended law, or the measured curve where the law misses the
   measured envelope, :func:`dampfit.fem.measured.default_damper`) and the other one beside
   it (``--law LAW`` of the recommended law, or ``--law measured``);
3. verifies (``dampfit verify DIR``): the exported OpenSees deck and, beside it, the linear
   dashpot at the design amplitude and the other deck, each released at rest at the first
   measured peak after the three periods where the filters settle, on the measured
   envelope's trend (as export's own check runs each law), their displacement envelopes
   (|a|/ω_n² at every half period) against the measured one over the interior of the window;
4. writes one markdown table (default ``paper/results/damper_verify.md``): the law, the
   default deck, the log-envelope rms error of the law's run, of the measured curve's and of
   the linear dashpot's against the trend of the measured envelope, the measurement's own
   scatter about that trend, and how many ζ(A) windows of ``amplitude_curve`` each run falls
   inside of.

The result folders need summary.json's ``damper`` section (dampfit ≥ the version that
recommends a damper): the script says so and stops for a folder without one. Runs each
command as a child process of this checkout (``python -m dampfit``), so it measures what a
user runs. Not part of CI (several minutes a recording).

Usage (from the checkout root)::

    nice -n 19 python paper/damper_verify.py --work /tmp/damper-verify [--reuse]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
ADXL50 = "cantilever-adxl357-demirkaya/tests_for_comparing_1st_nfreq/50cm_adxl"
#: (label, recording relative to REAL, mass [kg]) — masses from REAL/SOURCES.md.
RECORDINGS = [("phone spring", "phone-spring-metalcupcake5/raw_data.csv", 0.3255)] + [
    (f"ADXL357 50 cm {run}", f"{ADXL50}/{run}_adxl6cmfromtip2cmID/accelerometer_data.npy", 0.037)
    for run in ("08-12_11-46-55", "08-12_11-47-32", "08-12_11-49-09")]


def dampfit(*args: str) -> subprocess.CompletedProcess:
    """``python -m dampfit ARGS`` with this checkout's source first; raises on failure."""
    src = Path(__file__).resolve().parents[1] / "src"
    env = {**os.environ, "PYTHONPATH": f"{src}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
           "MPLBACKEND": "Agg"}
    proc = subprocess.run([sys.executable, "-m", "dampfit", *args], capture_output=True,
                          text=True, env=env)
    if proc.returncode != 0:
        raise RuntimeError(f"dampfit {' '.join(args[:2])} failed: {proc.stderr.strip()[-400:]}")
    return proc


def one(label: str, path: Path, mass: float, folder: Path, reuse: bool) -> dict:
    """Analyse, export and verify one recording; its row of the table."""
    if not (reuse and (folder / "summary.json").is_file()):
        dampfit("analyze", str(path), "--mass", repr(mass), "--out", str(folder), "--force")
    summary = json.loads((folder / "summary.json").read_text())
    if "damper" not in summary:
        raise SystemExit(f"{folder}/summary.json has no damper section: re-run with a dampfit "
                         "that recommends a damper (without --reuse)")
    rec = summary["damper"]["law"]
    for fmt in ("lsdyna", "opensees"):
        ext = "k" if fmt == "lsdyna" else "py"
        dampfit("export", str(folder), "--format", fmt, "--force")
        other = "measured" if rec in (None, "viscous") else rec  # the deck the default is not
        dampfit("export", str(folder), "--format", fmt, "--law", other, "--force",
                "--out", str(folder / f"sdof_{fmt}_{other}.{ext}"))
    dampfit("verify", str(folder), "--force")
    rep = json.loads((folder / "verification.json").read_text())
    d = rep["damper"]
    row = {"recording": label, "mass_kg": mass, "verdict": summary["damper"]["verdict"],
           "law": rec, "default_deck": d["law"],
           "coefficients": {k: v["q50"] if isinstance(v, dict) else v for k, v in
                            (summary["damper"].get("coefficients") or {}).items()}}
    curve = "exported" if d["law"] == "measured" else "measured"
    row["measured_coefficients"] = (d["coefficients"] if curve == "exported" else
                                    (rep.get("measured_script") or {}).get("coefficients", {}))
    runs = {"law_run": "recommended_law" if d["law"] == "measured" else "exported",
            "measured": curve, "linear": "linear"}
    for name, key in runs.items():
        if key in d:
            env, z = d[key]["envelope"], d[key]["zeta_amplitude"]
            row[name] = {"rms_vs_trend": env["rms_vs_trend"], "rms_vs_peaks": env["rms_vs_peaks"],
                         "zeta_inside": f"{z['n_inside']}/{z['n']}"}
            row["scatter"] = env["scatter"]
    row["exported"] = row.get("measured" if d["law"] == "measured" else "law_run")
    return row


def _pct(x) -> str:
    return "n/a" if x is None else f"{100 * x:.3g} %"


def _shortfall(r: dict) -> str:
    """The sentence of a recording whose measured curve is not within its scatter ('' else)."""
    m, sc = (r.get("measured") or {}).get("rms_vs_trend"), r.get("scatter")
    if m is None or sc is None or m <= sc:
        return ""
    return (f"- {r['recording']}: the measured curve misses the scatter by "
            f"{100 * (m - sc):.3f} percentage points ({_pct(m)} against {_pct(sc)}, "
            f"{m / sc:.2f}x).")


def table(rows: list[dict]) -> str:
    """The markdown table of the rows (log-envelope rms errors in percent)."""
    out = ["# The exported damper vs the recommended law vs the linear dashpot vs the "
           "measurement (issue 32)", "",
           "Log-envelope rms error against the trend of the measured envelope (Savitzky-Golay "
           "over 15 peaks), over the interior of the analysed window (three periods left out "
           "at each end); the measured scatter is the rms of the measured peaks about that "
           "trend. zeta(A): windows of amplitude_curve whose 90 % band holds the run's zeta. "
           "Every run is released at rest at the first measured peak after the three periods "
           "where the filters settle, its displacement scaled so that the run's first peak "
           "lies on the trend (as export's own check runs each law); the comparison starts a "
           "quarter period after the release. default deck: what `dampfit "
           "export DIR` writes (the recommended law, or the measured curve where the law's "
           "run misses the measured envelope by more than its scatter and the curve's comes "
           "closer: fem/measured.py default_damper); law: the recommended law (the headline, "
           "`--law LAW`); measured curve: the force-velocity table F(v) fitted to the measured "
           "envelope (piecewise linear in |v| through 0, slopes >= 0 on knots at the "
           "quantiles of the measured velocity amplitudes, last slope continued; OpenSees runs "
           "it as a Damper material wrapping an ElasticMultiLinear of its points).", "",
           "| recording | verdict | law | default deck | law run | measured curve | linear "
           "dashpot | measured scatter | zeta(A) law / curve / linear | default below linear | "
           "law within scatter | default within scatter |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ex, lin, cur = r.get("law_run", {}), r.get("linear", {}), r.get("measured", {})
        a, b, m = ex.get("rms_vs_trend"), lin.get("rms_vs_trend"), cur.get("rms_vs_trend")
        de = (r.get("exported") or {}).get("rms_vs_trend")
        better = "n/a" if None in (de, b) else ("yes" if de < b else "no")
        within = ["n/a" if x is None else ("yes" if x <= r["scatter"] else "no") for x in (a, de)]
        zs = " / ".join(x.get("zeta_inside", "n/a") for x in (ex, cur, lin))
        deck = r.get("default_deck", r.get("law"))
        deck = "measured curve" if deck == "measured" else f"{deck} law"
        out.append(f"| {r['recording']} | {r['verdict']} | {r['law']} | {deck} | {_pct(a)} | "
                   f"{_pct(m)} | {_pct(b)} | {_pct(r.get('scatter'))} | {zs} | {better} | "
                   f"{within[0]} | {within[1]} |")
    out += [""] + [_shortfall(r) for r in rows if _shortfall(r)] + ["",
            "Coefficients (SI, posterior medians):", ""]
    out += [f"- {r['recording']}: " + ", ".join(f"{k} = {v:.5g}" for k, v in
                                                r["coefficients"].items()) for r in rows]
    out += ["", "Measured curves (SI: points v_j [m/s], F_j [N], through (0, 0)):", ""]
    for r in rows:
        c = r.get("measured_coefficients", {})
        pts = [f"({c[f'v_{j}']:.4g}, {c[f'F_{j}']:.4g})" for j in range(1, len(c) // 2 + 1)]
        out.append(f"- {r['recording']}: " + " ".join(pts))
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/damper-verify"),
                    help="folder of the result folders (default /tmp/damper-verify)")
    ap.add_argument("--reuse", action="store_true",
                    help="keep result folders that already hold a summary.json")
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results" /
                    "damper_verify.md")
    ap.add_argument("--table-only", action="store_true",
                    help="rewrite the markdown table from the .json beside --out (no runs)")
    args = ap.parse_args(argv)
    if args.table_only:
        args.out.write_text(table(json.loads(args.out.with_suffix(".json").read_text())))
        return 0
    args.work.mkdir(parents=True, exist_ok=True)
    rows = []
    for i, (label, rel, mass) in enumerate(RECORDINGS):
        path = REAL / rel
        if not path.is_file():
            print(f"missing {path}; skipped", file=sys.stderr)
            continue
        print(f"{label} …", file=sys.stderr, flush=True)
        rows.append(one(label, path, mass, args.work / f"r{i}", args.reuse))
    (args.out.with_suffix(".json")).write_text(json.dumps(rows, indent=2) + "\n")
    args.out.write_text(table(rows))
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
