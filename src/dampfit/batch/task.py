"""One recording of a batch, analysed where it runs (a Dask worker or this process):
:func:`run_job` → one row of the results table (plain JSON data).

The analysis is the one ``dampfit analyze FILE`` runs, with the same options and seed — read
(:func:`dampfit.io.readers.read` with the reading options and the window), analyse
(:func:`dampfit.pipeline.analyze`), write the result folder ``runs/NAME`` as ``dampfit
analyze --out`` writes it (:meth:`dampfit.analysis.Analysis.save`: staged, locked, swapped in
whole; ``summaries_only``: summary.json alone) — so a row's numbers are that summary's. A
worker process keeps its imports and compiled kernels from one recording to the next.

A row's status follows its damping verdict (:func:`status_of`): ``ok`` only when a damper is
recommended, ``inconclusive`` or ``misfit`` otherwise, with the verdict's own reason as the
message (an analysis warning when the verdict gives none). A recording the analysis refuses
(:class:`~dampfit.errors.DampfitError`: unreadable, no free decay, too short…) is a row with
status ``refused`` and the one-line reason; any other
exception is a row with status ``failed`` and its type and message; neither ends the batch.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from dampfit.errors import DampfitError, shown

#: Quantities of a row, each with q05, q50 and q95 (c and k only with a mass).
QUANTITIES = ("f_n", "zeta", "c", "k")
#: A row's status: a damper recommended (``ok``), the recording analysed but no damper
#: recommended (``inconclusive``: viscous stands, not proven; ``misfit``: no law fits),
#: refused by the analysis (a bad recording), or failed (a bug, a worker that died: tried
#: again when the batch is run again).
STATUSES = ("ok", "inconclusive", "misfit", "refused", "failed")
#: Coefficients of the damper's law (summary.json ``damper.coefficients``), in SI units.
DAMPER_COEFFICIENTS = ("c", "F_c", "c2", "c_alpha", "alpha")
#: The damper columns of a row: status, law, each coefficient's q05/q50/q95, the design
#: amplitude [m] and the equivalent linear c [N s/m] there.
DAMPER_COLUMNS = ("damper_status", "damper_law",
                  *(f"damper_{n}_{lv}" for n in DAMPER_COEFFICIENTS for lv in ("q05", "q50", "q95")),
                  "design_amplitude_m", *(f"c_linear_{lv}" for lv in ("q05", "q50", "q95")),
                  "law_follows_decay")
#: Verdicts (model_checks.verdict) that recommend a damper when a summary has no ``damper``
#: section (written before it existed).
_RECOMMENDING = ("adequate", "amplitude-dependent")


def _number(v: Any) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def _levels(entry: Any, prefix: str) -> dict[str, float | None]:
    entry = entry if isinstance(entry, dict) else {}
    return {f"{prefix}_{lv}": _number(entry.get(lv)) for lv in ("q05", "q50", "q95")}


def damper_of(summary: dict[str, Any]) -> dict[str, Any]:
    """The damper columns (:data:`DAMPER_COLUMNS`) of a summary.json's ``damper`` section;
    all None for a summary without one."""
    d = summary.get("damper") if isinstance(summary.get("damper"), dict) else {}
    out: dict[str, Any] = {
        "damper_status": d.get("status") if isinstance(d.get("status"), str) else None,
        "damper_law": d.get("law") if isinstance(d.get("law"), str) else None}
    coefs = d.get("coefficients") if isinstance(d.get("coefficients"), dict) else {}
    for name in DAMPER_COEFFICIENTS:
        out.update(_levels(coefs.get(name), f"damper_{name}"))
    design = d.get("design_amplitude") if isinstance(d.get("design_amplitude"), dict) else {}
    out["design_amplitude_m"] = _number(design.get("displacement_m"))
    out.update(_levels(d.get("c_linear"), "c_linear"))
    chk = d.get("decay_check") if isinstance(d.get("decay_check"), dict) else {}
    follows = chk.get("follows") if chk.get("checked") is True else None
    out["law_follows_decay"] = follows if isinstance(follows, bool) else None
    return out


def status_of(summary: dict[str, Any]) -> tuple[str, str]:
    """A row's status from its verdict, and the verdict's own reason: ``ok`` only when a
    damper is recommended (``damper.status`` "recommended"; a summary without the section:
    ``model_checks.verdict`` adequate or amplitude-dependent); ``misfit`` when no law fits
    (verdict misfit); else ``inconclusive`` (viscous stands unproven, or no verdict could be
    made)."""
    d = summary.get("damper") if isinstance(summary.get("damper"), dict) else None
    checks = summary.get("model_checks") if isinstance(summary.get("model_checks"), dict) else {}
    verdict = checks.get("verdict")
    if d is not None and isinstance(d.get("status"), str):
        status = ("ok" if d["status"] == "recommended" else
                  "misfit" if d["status"] == "none" and verdict == "misfit" else "inconclusive")
        reason = " ".join(x for x in (d.get("reason"), d.get("not_ruled_out"), d.get("try"))
                          if isinstance(x, str) and x)
    else:
        status = ("ok" if verdict in _RECOMMENDING else "misfit" if verdict == "misfit"
                  else "inconclusive")
        reasons = checks.get("verdict_reasons")
        reason = "; ".join(r for r in reasons if isinstance(r, str)) \
            if isinstance(reasons, list) else ""
    if not reason and status != "ok":
        reason = (f"damping verdict {verdict}" if isinstance(verdict, str)
                  else "no damping verdict could be made")
    return status, reason


def row_of(summary: dict[str, Any]) -> dict[str, Any]:
    """The quantities, verdict and convergence of a summary.json, as a row's columns
    (``c_q50`` …; None where the summary has no value), its number of modes ``n_modes`` and,
    for several, their median natural frequencies [Hz] ``modes_f_n_hz`` ("3.3 8.91"), and
    the damper columns (:func:`damper_of`)."""
    params = summary.get("parameters") or {}
    out: dict[str, Any] = {}
    for q in QUANTITIES:
        out.update(_levels(params.get(q), q))
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
    out.update(damper_of(summary))
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
    an.save(folder, force=True, figures=outputs.get("figures", False),
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
        row["status"], reason = status_of(summary)
        warnings = (summary.get("diagnostics") or {}).get("warnings") or []
        row["message"] = shown(reason or (warnings[0] if warnings else ""), 500)
        if runs is not None:
            _write(an, Path(runs) / job.name, job, outputs)
            row["folder"] = f"runs/{job.name}"
    except DampfitError as exc:
        row.update(status="refused", message=shown(exc, 500))
    except Exception as exc:  # noqa: BLE001 - one recording's bug is a row, not the batch's end
        row.update(status="failed", message=shown(f"{type(exc).__name__}: {exc}", 500))
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row
