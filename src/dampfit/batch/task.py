"""One recording of a batch, analysed where it runs (a Dask worker or this process):
:func:`run_job` → one row of the results table (plain JSON data).

The analysis is the one ``dampfit analyze FILE`` runs, with the same options and seed — read
(:func:`dampfit.io.readers.read` with the reading options and the window), analyse
(:func:`dampfit.pipeline.analyze`), write the result folder ``runs/NAME`` as ``dampfit
analyze --out`` writes it (:meth:`dampfit.analysis.Analysis.save`: staged, locked, swapped in
whole; ``summaries_only``: summary.json alone) — so a row's numbers are that summary's. A
worker process keeps its imports and compiled kernels from one recording to the next.

A recording the analysis refuses (:class:`~dampfit.errors.DampfitError`: unreadable, no free
decay, too short…) is a row with status ``refused`` and the one-line reason; any other
exception is a row with status ``failed`` and its type and message; neither ends the batch.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from dampfit.errors import DampfitError, shown

__all__ = ["QUANTITIES", "STATUSES", "row_of", "run_job"]

#: Quantities of a row, each with q05, q50 and q95 (c and k only with a mass).
QUANTITIES = ("f_n", "zeta", "c", "k")
#: A row's status: analysed, refused by the analysis (a bad recording), or failed (a bug, a
#: worker that died: tried again when the batch is run again).
STATUSES = ("ok", "refused", "failed")


def row_of(summary: dict[str, Any]) -> dict[str, Any]:
    """The quantities, verdict and convergence of a summary.json, as a row's columns
    (``c_q50`` …; None where the summary has no value), its number of modes ``n_modes`` and,
    for several, their median natural frequencies [Hz] ``modes_f_n_hz`` ("3.3 8.91")."""
    params = summary.get("parameters") or {}
    out: dict[str, Any] = {}
    for q in QUANTITIES:
        entry = params.get(q) if isinstance(params.get(q), dict) else {}
        for level in ("q05", "q50", "q95"):
            v = entry.get(level)
            out[f"{q}_{level}"] = float(v) if isinstance(v, (int, float)) else None
    checks = summary.get("model_checks") or {}
    diag = summary.get("diagnostics") or {}
    out["verdict"] = checks.get("verdict") if isinstance(checks.get("verdict"), str) else None
    out["converged"] = diag.get("converged") if isinstance(diag.get("converged"), bool) else None
    n = summary.get("n_modes")
    out["n_modes"] = n if isinstance(n, int) and not isinstance(n, bool) else None
    modes = summary.get("modes") if isinstance(summary.get("modes"), list) else []
    f = [m["f_n"]["q50"] for m in modes if isinstance(m, dict) and isinstance(m.get("f_n"), dict)
         and isinstance(m["f_n"].get("q50"), (int, float))]
    out["modes_f_n_hz"] = " ".join(f"{v:.6g}" for v in f) if len(f) >= 2 else None
    return out


_FROZEN = False


def _settle() -> None:
    """Once per process: import the stack, then move its objects out of the garbage
    collector's reach (``gc.freeze``), as the CLI does — JAX, SciPy, arviz and matplotlib are
    hundreds of thousands of long-lived objects that every full collection would walk again,
    recording after recording. The recordings' own objects stay collectable."""
    global _FROZEN
    if _FROZEN:
        return
    import gc

    import dampfit.output.figures  # noqa: F401 - the whole stack a recording needs
    import dampfit.pipeline  # noqa: F401
    from dampfit._arviz import arviz

    arviz()
    gc.collect()
    gc.freeze()
    _FROZEN = True


def _analyse(job, options: dict[str, Any]):
    from dampfit.io.readers import read
    from dampfit.pipeline import analyze

    _settle()

    reading = dict(job.read_options)
    if options.get("window") is not None:
        reading["window"] = tuple(options["window"])
    rec = read(job.path, **reading)
    return analyze(rec, mass=job.mass, mass_sd=job.mass_sd or None, progress=False, **options)


def _write(an, folder: Path, job, outputs: dict[str, bool]) -> None:
    if outputs.get("summaries_only"):
        from dampfit.files.folder import result_folder

        with result_folder(folder, "analyze", True, inputs=[job.path]) as target:
            an.to_json(target.stage / "summary.json")
            target.publish()
        return
    an.save(folder, force=True, figures=outputs.get("figures", True),
            report=outputs.get("report", False))


def run_job(job, key: str, options: dict[str, Any], outputs: dict[str, bool],
            runs: str | None) -> dict[str, Any]:
    """Analyse ``job`` (a :class:`dampfit.batch.inputs.Job`) with the analysis ``options``
    (keyword arguments of :func:`dampfit.pipeline.analyze`: axis, window, band, seed,
    max_steps, model, amplitude, max_modes, mode_of_mass); write its folder into ``runs`` (None: nothing written) with
    ``outputs`` (figures, report, summaries_only); return its row (module docstring)."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"key": key, "file": job.file, "name": job.name,
                           "sha256": job.sha256, "mass_kg": job.mass, "status": "ok",
                           "message": "", "folder": None}
    row.update(row_of({}))
    try:
        an = _analyse(job, options)
        summary = an.summary()
        row.update(row_of(summary))
        warnings = (summary.get("diagnostics") or {}).get("warnings") or []
        row["message"] = shown(warnings[0], 300) if warnings else ""
        if runs is not None:
            _write(an, Path(runs) / job.name, job, outputs)
            row["folder"] = f"runs/{job.name}"
    except DampfitError as exc:
        row.update(status="refused", message=shown(exc, 500))
    except Exception as exc:  # noqa: BLE001 - one recording's bug is a row, not the batch's end
        row.update(status="failed", message=shown(f"{type(exc).__name__}: {exc}", 500))
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row
