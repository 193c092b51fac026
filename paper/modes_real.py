"""How many modes are in the real cantilever recordings? (issue 21, item "Real data")

Runs the real pipeline, ``dampfit.analyze(dampfit.read(path), max_modes=4)``, on every
recording under ``../shared/data/real/cantilever-*`` (read as the reference tests read them:
:func:`dampfit.read` with its automatic format detection; the files are never copied). The
damping-law comparison is restricted to ``model="viscous"``: it does not touch the modes stage.
Writes one CSV row per recording — the screen, P(K) for K = 1 … 4, the reasons the other K were
refused, each mode's f_n [Hz] (q05/q50/q95) and ζ [1] (q05/q50/q95), the pipeline's warnings —
and, for every recording where the order selection ran (the screen fired: a second mode found
or rejected), a spectrum figure: the amplitude spectrum of the modal window over 0 … Nyquist
with the modal band, the modes found, and the Euler–Bernoulli prediction of the second bending
mode, f₂ ≈ 6.27·f₁ (uniform clamped–free beam, (β₂L/β₁L)² = (4.694/1.875)²).

Usage (from the checkout root)::

    nice -n 19 python paper/modes_real.py --out paper/results/modes_real.csv
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                                   "intra_op_parallelism_threads=1")
os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
#: Second/first bending frequency of a uniform clamped–free beam (Euler–Bernoulli) [1].
RATIO_2_1 = (4.694091 / 1.875104) ** 2
K_MAX = 4


def files() -> list[Path]:
    """Every cantilever recording under :data:`REAL` (sorted)."""
    return sorted(p for p in REAL.glob("cantilever-*/**/*") if p.suffix in (".npy", ".csv"))


def short_name(path: Path) -> str:
    """A file-system-safe short label of a recording (for the figure's file name)."""
    rel = path.relative_to(REAL)
    parts = [p for p in rel.parts if p not in ("accelerometer_data.npy",)]
    label = "_".join(parts[-2:]) if len(parts) > 1 else parts[0]
    return re.sub(r"[^A-Za-z0-9_.-]", "_", label.replace(".csv", ""))[:60]


def run(path: Path) -> tuple[dict, object]:
    """Analyse one recording; the CSV row and the :class:`dampfit.Analysis`."""
    import dampfit

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(dampfit.read(path), max_modes=K_MAX, seed=0, model="viscous")
    s = an.summary()
    ev = s.get("modes_evidence") or {}
    screen = ev.get("screen") or {}
    p_k = {r["n_modes"]: r["probability"] for r in ev.get("evidence", [])}
    f1 = s["parameters"]["f_n"]["q50"]
    row = {
        "recording": str(path.relative_to(REAL)),
        "fs_hz": an.prepared.fs, "f1_one_mode_hz": f1,
        "f2_euler_bernoulli_hz": RATIO_2_1 * f1, "nyquist_hz": an.prepared.fs / 2,
        "modal_band_hz": " ".join(f"{v:.4g}" for v in ev.get("band_hz", [])),
        "screen_passed": screen.get("passed"),
        "screen_z2": screen.get("max_z2"), "screen_at_hz": screen.get("at_hz"),
        "screen_threshold_z2": screen.get("threshold_z2"),
        "n_modes": s.get("n_modes", 1),
    }
    for k in range(1, K_MAX + 1):
        row[f"P_K{k}"] = p_k.get(k, "")
    modes = s.get("modes") or []
    for i in range(K_MAX):
        m = modes[i] if i < len(modes) else None
        for q in ("q05", "q50", "q95"):
            row[f"f{i + 1}_{q}_hz"] = m["f_n"][q] if m else ""
        for q in ("q05", "q50", "q95"):
            row[f"zeta{i + 1}_{q}"] = m["zeta"][q] if m else ""
    if len(modes) >= 2:
        row["f2_over_f1"] = modes[1]["f_n"]["q50"] / modes[0]["f_n"]["q50"]
    row["reasons"] = " | ".join(f"K={r['n_modes']}: {r['reason']}"
                                for r in ev.get("evidence", []) if r.get("reason"))
    row["modes_reason"] = ev.get("reason", "")
    row["screen_reason"] = screen.get("reason", "")
    row["spectrum_peaks_hz"] = " ".join(f"{f:.4g}" for f in ev.get("spectrum_peaks_hz", []))
    row["warnings"] = " | ".join((s.get("diagnostics") or {}).get("warnings") or [])
    run = ev.get("sampling") or {}
    row["modes_posterior"] = (f"{run['stop_reason']}, {run['n_steps']} steps, "
                              f"{run['wall_time_s']:.1f} s" if run.get("stop_reason") else "")
    row["runtime_s"] = time.perf_counter() - t0
    return row, an


def spectrum(an) -> dict:
    """Amplitude spectrum [m/s²] of the modal window of ``an`` (Hann window, 0 … Nyquist),
    with the modal band [Hz], window [s], f₀ and sample rate [Hz]."""
    from dampfit.inference.modes import modal_band, modal_window

    prep = an.prepared
    band = modal_band(prep)
    (w0, w1), _ = modal_window(prep, band)
    sel = (prep.grid >= w0) & (prep.grid <= w1)
    x = prep.grid_signal[sel] - np.mean(prep.grid_signal[sel])
    hann = np.hanning(x.size)
    return {"f": np.fft.rfftfreq(x.size, 1 / prep.fs),
            "amp": 2 * np.abs(np.fft.rfft(x * hann)) / np.sum(hann),
            "band": np.array(band), "window": np.array([w0, w1]),
            "f0": prep.f0, "fs": prep.fs}


def figure(sp: dict, row: dict, out: Path) -> None:
    """The spectrum ``sp`` (:func:`spectrum`) on log axes from f₀/10 to Nyquist, with the
    modal band, the modes found, the screen's peak and the Euler–Bernoulli f₂ marked; saved as
    a small PNG."""
    import matplotlib.pyplot as plt

    f, amp, band, (w0, w1) = sp["f"], sp["amp"], sp["band"], sp["window"]
    keep = f >= sp["f0"] / 10
    fig, ax = plt.subplots(figsize=(6.4, 3.4), dpi=90)
    ax.loglog(f[keep], amp[keep], lw=0.5, color="0.25")
    ax.axvspan(*band, color="tab:blue", alpha=0.08,
               label=f"modal band {band[0]:.3g}–{band[1]:.3g} Hz")
    n = int(row["n_modes"] or 1)
    for i in range(n):
        fi = float(row[f"f{i + 1}_q50_hz"]) if n > 1 else float(row["f1_one_mode_hz"])
        ax.axvline(fi, color="tab:green", lw=1.2,
                   label=f"modes found (dampfit, K = {n})" if i == 0 else None)
    f2 = float(row["f2_euler_bernoulli_hz"])
    ax.axvline(f2, color="tab:red", ls="--", lw=1,
               label=f"Euler–Bernoulli f₂ = 6.27·f₁ = {f2:.3g} Hz")
    if row.get("screen_at_hz") not in (None, ""):
        at = float(row["screen_at_hz"])
        ax.axvline(at, color="tab:orange", ls=":", lw=1.2,
                   label=f"screen's strongest residual peak {at:.3g} Hz")
    ax.set_xlim(sp["f0"] / 10, sp["fs"] / 2)
    ax.set_ylim(max(amp[keep].min(), amp.max() * 1e-7), amp.max() * 30)
    ax.set_xlabel(f"frequency [Hz] (axis ends at Nyquist, {sp['fs'] / 2:.4g} Hz)")
    ax.set_ylabel("amplitude [m/s²]")
    ax.set_title(f"{short_name(REAL / row['recording'])}: modal window "
                 f"{w0:.3g}–{w1:.3g} s, Hann", fontsize=8)
    ax.legend(fontsize=6, loc="upper right", ncol=2)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def replot(out: Path, cache: Path, folder: Path) -> int:
    """Redraw the figures named in the CSV ``out`` from the spectra kept in ``cache``."""
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row in rows:
        if row.get("figure"):
            with np.load(cache / f"{short_name(REAL / row['recording'])}.npz") as z:
                sp = {k: z[k] for k in z.files}
            sp["f0"], sp["fs"] = float(sp["f0"]), float(sp["fs"])
            figure(sp, row, folder / row["figure"])
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="paper/results/modes_real.csv")
    ap.add_argument("--figures", default="paper/results",
                    help="folder for the spectrum figures (modes_real_<recording>.png)")
    ap.add_argument("--only", action="append", default=[],
                    help="analyse only paths containing this text (repeatable); the rows of "
                         "the other recordings already in --out are kept")
    ap.add_argument("--cache", default="",
                    help="folder to keep each spectrum in (npz), so --replot can redraw")
    ap.add_argument("--replot", action="store_true",
                    help="redraw the figures from --out and --cache without analysing")
    a = ap.parse_args(argv)
    if a.replot:
        return replot(Path(a.out), Path(a.cache), Path(a.figures))
    paths = [p for p in files() if not a.only or any(o in str(p) for o in a.only)]
    if not paths:
        print(f"no cantilever recordings under {REAL}", file=sys.stderr)
        return 1
    rows = []
    if a.only and Path(a.out).is_file():
        names = {str(p.relative_to(REAL)) for p in paths}
        with open(a.out, newline="") as fh:
            rows = [r for r in csv.DictReader(fh) if r["recording"] not in names]
    for path in paths:
        try:
            row, an = run(path)
            sp = spectrum(an)
            if a.cache:
                np.savez(Path(a.cache) / f"{short_name(path)}.npz", **sp)
            if row["screen_passed"]:
                name = Path(a.figures) / f"modes_real_{short_name(path)}.png"
                figure(sp, row, name)
                row["figure"] = name.name
        except Exception as exc:  # noqa: BLE001 - report and go on
            row = {"recording": str(path.relative_to(REAL)),
                   "warnings": f"{type(exc).__name__}: {exc}"}
        rows.append(row)
        print({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()},
              flush=True)
        rows.sort(key=lambda r: r["recording"])
        write(rows, Path(a.out))  # after every recording: a long run keeps what it has
    return 0


def write(rows: list[dict], out: Path) -> None:
    """The CSV of ``rows`` (columns: the union of their keys, in first-seen order)."""
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    tmp = out.with_suffix(".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    tmp.replace(out)


if __name__ == "__main__":
    sys.exit(main())
