"""Posterior draws of the damper carried into the FEM model (``dampfit export --draws N``,
``dampfit verify --draws N``; issue 32).

Design: **N decks and one table.** ``export --draws N`` writes a folder (default
``DIR/sdof_FORMAT_draws/``) holding ``draws.csv`` — one row per draw: its number, the index of
the posterior draw it is, m [kg], k [N/m], the law's coefficients (SI), c_linear [N·s/m],
ζ_linear [1] as stored and ζ_eq at the design amplitude recomputed from the coefficients
(K2 of :mod:`dampfit.model.laws`) — and ``draw_0001.EXT`` … ``draw_N.EXT``, each the deck
``dampfit export`` writes with that draw's m, k and coefficients (same units, duration, start
amplitude; its own time step; its header names the draw). N decks rather than one
parametrised deck: every engine reads them as they are (LS-DYNA and CalculiX have no loop over
a table), and each is a complete, checked deck a batch run of the solver can take.

The draws are a seeded subset (``--seed``, default 0: ``numpy.random.default_rng(seed)``,
chosen without replacement, sorted) of the ``damper`` group of posterior.nc (a thinned joint
sample of the law's posterior: m, k and the coefficients of one draw belong together), so the
same command gives the same decks on any machine. N is bounded: 1 ≤ N ≤ :data:`MAX_DRAWS`
and at most the draws stored.

``verify --draws N`` runs each draw's OpenSees script from the measured start state and draws
the band (5–95 % at every measured peak) of the N simulated envelopes against the measurement
(:func:`verify_band`).
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import InputError, shown
from dampfit.fem import damper as damper_mod

#: Most draws one export or verify writes or runs.
MAX_DRAWS = 1000


def check_count(n: Any) -> int:
    """``n`` as a number of draws: an integer in [1, :data:`MAX_DRAWS`], else one error line."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_DRAWS:
        raise InputError(f"--draws must be a whole number from 1 to {MAX_DRAWS}, got {n!r}")
    return int(n)


def check_seed(seed: Any) -> int:
    """``seed`` as a non-negative integer seed (below 2**63), else one error line."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise InputError(f"--seed must be a whole number from 0 to 2**63-1, got {seed!r}")
    return int(seed)


def sample(folder: Path, law: str, n: int, seed: int) -> dict[str, Any]:
    """``n`` draws (seeded, without replacement, sorted) of the ``damper`` group of
    ``folder``/posterior.nc: ``{"index", "mass", "k", NAME…, "c_linear", "zeta_linear"}``
    (arrays, SI) for ``law``'s coefficients; :class:`InputError` if the group is missing, of
    another law, short of draws, or holds a non-finite or out-of-range value."""
    from dampfit.result.folder import read_posterior

    n, path = check_count(n), folder / "posterior.nc"
    idata = read_posterior(folder)
    if "damper" not in idata.groups():
        raise InputError(f"{shown(path)} has no damper group (written before dampfit kept the "
                         "damper's draws, or no damper recommended); re-run 'dampfit analyze'")
    ds = idata["damper"]
    stored = ds.attrs.get("law")
    if law == "viscous" and "c" not in ds and "c_linear" in ds:  # --law viscous: c_linear
        ds = ds.assign(c=ds["c_linear"])
    elif stored is not None and str(stored) != law:
        raise InputError(f"{shown(path)}: the damper draws are of the {shown(stored, 40)} law, "
                         f"the deck's is {law}; export --draws writes the recommended law only")
    names = ["mass", "k", *damper_mod.COEFFICIENTS[law]]
    out: dict[str, Any] = {}
    for name in names + ["c_linear", "zeta_linear"]:
        if name not in ds:
            if name in ("c_linear", "zeta_linear"):
                continue
            raise InputError(f"{shown(path)}: the damper group has no {name!r}")
        x = np.asarray(ds[name].values, dtype=float).ravel()
        out[name] = x
    total = min(x.size for x in out.values())
    if n > total:
        raise InputError(f"--draws {n}: {shown(path)} holds {total} damper draws")
    rng = np.random.default_rng(check_seed(seed))
    idx = np.sort(rng.choice(total, size=n, replace=False))
    out = {k: v[idx] for k, v in out.items()}
    for name in names:
        bad = ~np.isfinite(out[name]) | (out[name] < 0) | ((out[name] <= 0) if name in (
            "mass", "k", "c_alpha", "alpha") else False)
        if bad.any():
            raise InputError(f"{shown(path)}: damper draw {int(idx[bad][0])} has {name} = "
                             f"{out[name][bad][0]!r}, not a usable value")
    out["index"] = idx
    return out


def _variant(draws: dict[str, Any], i: int, n: int, seed: int, design_m: float | None):
    """The ``variant`` of :func:`dampfit.fem.export.build` for draw ``i`` (0-based)."""
    def apply(sdof, dmp):
        coeffs = {k: float(draws[k][i]) for k in damper_mod.COEFFICIENTS[dmp.law]}
        mass, k = float(draws["mass"][i]), float(draws["k"][i])
        w = math.sqrt(k / mass)
        c = (float(draws["c_linear"][i]) if dmp.nonlinear and "c_linear" in draws else
             damper_mod.c_equivalent(dmp.law, coeffs, w, design_m or abs(sdof.u0)))
        lines = (f"Posterior draw {i + 1} of {n} (seed {seed}, draw {int(draws['index'][i])} of "
                 f"posterior.nc's damper group): m = {mass:.6g} kg, k = {k:.6g} N/m.",)
        if dmp.nonlinear:
            lines += (f"A draw of the {dmp.law} law's own posterior. Where that law's free "
                      "decay misses the measured one, the plain 'dampfit export' writes the "
                      "measured force-velocity curve instead, its uncertainty a bootstrap "
                      "interval stated in that deck.",)
        return (replace(sdof, mass=mass, k=k, c=c), replace(dmp, coefficients=coeffs), lines)
    return apply


def law_itself(sdof, dmp):
    """The ``variant`` of :func:`dampfit.fem.export.build` that keeps the system and the
    summary's damper as they are: the draws are of the recommended law's posterior, so their
    base deck is that law, not the measured curve a plain export may put in its place
    (:func:`dampfit.fem.measured.default_damper`, run only without a variant)."""
    return sdof, dmp, ()


def write(one_deck, folder: Path, fmt: str, ext: str, n_seed: tuple[int, int],
          out: str | Path | None, force: bool) -> tuple[Path, dict[str, Any]]:
    """Write the draws' table and decks (module docstring) into the folder ``out`` (default
    ``folder/sdof_FORMAT_draws``): staged in a hidden sibling folder and moved in at the end;
    an existing folder is replaced only with ``force`` and only if it holds nothing but a
    previous draws export (draws.csv, draw_*). ``n_seed`` = (N, seed); ``one_deck(name,
    variant=None)`` is :func:`dampfit.fem.export.build` of the export's folder, format and
    options (handed in: export calls this module). Returns (folder, description)."""
    n, seed = check_count(n_seed[0]), check_seed(n_seed[1])
    target = Path(out) if out else folder / f"sdof_{fmt}_draws"
    _check_target(target, force)
    text, info = one_deck(f"draw_0001.{ext}", law_itself)
    dmp = info["damper"]
    draws = sample(folder, dmp.law, n, seed)
    design = (dmp.design or {}).get("displacement_m")
    texts, rows = {}, []
    for i in range(n):
        name = f"draw_{i + 1:04d}.{ext}"
        t, inf = one_deck(name, _variant(draws, i, n, seed, design))
        texts[name] = t
        rows.append(_row(i, draws, inf, design, name))
    texts["draws.csv"] = _csv(rows)
    _publish(target, texts, force)
    return target, {"n": n, "seed": seed, "law": dmp.law, "rows": rows, "damper": dmp,
                    "units": info["units"], "format": fmt}


def _row(i: int, draws: dict[str, Any], info: dict[str, Any], design: float | None,
         name: str) -> dict[str, Any]:
    s, dmp = info["sdof"], info["damper"]
    a = design or abs(s.u0)
    c_eq = damper_mod.c_equivalent(dmp.law, dmp.coefficients, s.omega_n, a)
    row = {"draw": i + 1, "posterior_index": int(draws["index"][i]), "mass_kg": s.mass,
           "k_N_per_m": s.k}
    row.update({f"{k} [{damper_mod.COEFFICIENTS[dmp.law][k]}]": v
                for k, v in dmp.coefficients.items()})
    row.update({"c_linear [N s/m]": float(draws["c_linear"][i]) if "c_linear" in draws else None,
                "zeta_linear": float(draws["zeta_linear"][i]) if "zeta_linear" in draws else None,
                "design_amplitude_m": a,
                "zeta_eq_at_design": c_eq / (2 * math.sqrt(s.k * s.mass)), "file": name})
    return row


def _csv(rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (repr(float(v)) if isinstance(v, float) else ("" if v is None else v))
                    for k, v in r.items()})
    return buf.getvalue()


def _own(path: Path) -> bool:
    """Whether folder ``path`` holds only a previous draws export."""
    return all(p.is_file() and not p.is_symlink() and (p.name == "draws.csv"
                                                      or p.name.startswith("draw_"))
               for p in path.iterdir())


def _check_target(target: Path, force: bool) -> None:
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise InputError(f"refusing to write the draws into {shown(target)}: not a folder")
    if target.exists():
        if not force:
            raise InputError(f"{shown(target)} exists; use --force to replace it")
        if not _own(target):
            raise InputError(f"refusing to replace {shown(target)}: it holds files that are "
                             "not a dampfit draws export")
    if not target.parent.is_dir():
        raise InputError(f"cannot write {shown(target)}: {shown(target.parent)} is not a folder")


def _publish(target: Path, texts: dict[str, str], force: bool) -> None:
    """Write ``texts`` into a hidden sibling of ``target`` and move it in (the old folder,
    if replaced, is moved aside first and removed last)."""
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name[:40]}-", dir=target.parent))
    try:
        for name, text in texts.items():
            (stage / name).write_text(text, encoding="utf-8")
        old = None
        if target.exists():
            _check_target(target, force)
            old = Path(tempfile.mkdtemp(prefix=f".{target.name[:40]}-old-", dir=target.parent))
            os.rename(target, old / "x")
        os.rename(stage, target)
        if old is not None:
            shutil.rmtree(old)
    except OSError as exc:
        shutil.rmtree(stage, ignore_errors=True)
        raise InputError(f"cannot write {shown(target)}: {exc.strerror or exc}") from None


def verify_band(one_deck, folder: Path, n_seed: tuple[int, int], run, measured,
                interior: tuple[float, float], omega_n: float) -> dict[str, Any]:
    """Run the OpenSees script of each of N draws (``n_seed`` = (N, seed), seeded as
    export's) from the start state of ``run`` = (start, dt, n_steps) for ``n_steps`` of ``dt``
    and compare the band of their envelopes with the measured envelope's trend over
    ``interior``: the 5 % and 95 % quantiles of the draws' |a|/ω_n² at each measured peak
    time (ln-interpolated between each run's own peaks; ``measured`` = (t, u_meas) with
    u_meas |a|/ω_n² as well, :func:`dampfit.fem.verify_damper.damper_runs`);
    ``one_deck(name=None, variant=None)`` is :func:`dampfit.fem.export.build` of ``folder``'s
    OpenSees script (SI, the medians, no gravity, ``n_steps × dt`` long)."""
    from scipy.signal import savgol_filter

    from dampfit._progress import stage_bar
    from dampfit.fem import opensees, response

    (n, seed), (start, dt, n_steps), (t, u_meas) = n_seed, run, measured
    _, info = one_deck(None, law_itself)
    dmp = info["damper"]
    draws = sample(folder, dmp.law, n, seed)
    design = (dmp.design or {}).get("displacement_m")
    tm, am = response.envelope(t, u_meas, *interior)
    curves = []
    with stage_bar(n, "verify: draws", unit="run") as bar:
        for i in range(n):
            text, _ = one_deck(opensees.SCRIPT_NAME, _variant(draws, i, n, seed, design))
            res = opensees.run_steps(text, start["u"], start["v"], dt, n_steps)
            ts, as_ = response.envelope(t[0] + start.get("offset_s", 0.0) + res["t"],
                                        res["a"] / omega_n ** 2)
            curves.append(np.exp(np.interp(tm, ts, np.log(as_))) if ts.size >= 2 else
                          np.full(tm.size, np.nan))
            bar.update(1)
    c = np.array(curves)
    lo, hi = np.nanquantile(c, 0.05, axis=0), np.nanquantile(c, 0.95, axis=0)
    frac = None
    if tm.size >= 8:
        trend = np.exp(savgol_filter(np.log(am), min(response.TREND_PEAKS,
                                                     tm.size - (1 - tm.size % 2)), 2))
        frac = float(np.mean((trend >= lo) & (trend <= hi)))
    return {"report": {"n": n, "seed": seed, "law": dmp.law, "n_peaks": int(tm.size),
                       "fraction_trend_inside": frac,
                       "median_relative_width": float(np.median((hi - lo) / np.maximum(
                           0.5 * (hi + lo), 1e-300))) if tm.size else None,
                       "what": "5-95 % band of the draws' |u| at the measured peaks; the "
                               "measured envelope trend (Savitzky-Golay) inside it"},
            "arrays": {"t": tm, "lo": lo, "hi": hi, "n": n}}
