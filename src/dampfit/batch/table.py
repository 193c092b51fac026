"""The batch's outputs from its rows: ``results.csv`` (and ``results.parquet`` with pyarrow),
``summary.md`` and ``comparison.png`` — :func:`frame`, :func:`write_outputs`.

``results.csv`` has one row per recording of the command, in the order given: ``file`` (as
given), ``name`` (its folder under ``runs/``), ``sha256``, ``status`` (ok: a damper
recommended / inconclusive / misfit / refused / failed: :func:`dampfit.batch.task.status_of`)
and ``message`` (the verdict's own reason, the refusal, or the analysis's first warning),
``mass_kg``, f_n [Hz], ζ [1], c [N·s/m] and k [N/m] each as ``q05``, ``q50``, ``q95`` (the
90 % interval and the median; c and k empty without a mass), the damping-law ``verdict``,
``converged``, ``n_modes`` and ``modes_f_n_hz`` (the modes' median f_n [Hz] when
``--max-modes`` found several; the quantities above are then the mass's mode), the damper
(summary.json ``damper``; empty for a summary without it): ``damper_status``,
``damper_law``, each coefficient's ``damper_NAME_q05/q50/q95`` (NAME c [N s/m], F_c [N], c2
[N s²/m²], c_alpha [N (s/m)^α], alpha [1]; only the law's own filled),
``design_amplitude_m`` [m], ``c_linear_q05/q50/q95`` [N s/m] (the equivalent linear c at
that amplitude) and ``law_follows_decay`` (whether a nonlinear law's own free decay follows
the recording, ``damper.decay_check``; false: ``dampfit export`` writes the measured curve
where it comes closer; empty when not checked), ``seconds`` (wall time of that recording's analysis and outputs) and
``folder``.

Every text cell of results.csv is quoted, and one starting with ``=``, ``+``, ``-``, ``@``,
a tab or a carriage return gets a leading ``'`` (OWASP's CSV-injection advice): a file name
or message cannot run as a spreadsheet formula; numbers are written as numbers.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Sequence

from dampfit.batch.task import DAMPER_COLUMNS, QUANTITIES
from dampfit.files.atomic import atomic_write, atomic_write_text

COLUMNS = ("file", "name", "sha256", "status", "message", "mass_kg",
           *(f"{q}_{lv}" for q in QUANTITIES for lv in ("q05", "q50", "q95")),
           "verdict", "converged", "n_modes", "modes_f_n_hz", *DAMPER_COLUMNS, "seconds", "folder")
#: Statuses of a recording that was analysed (a row with numbers).
ANALYSED = ("ok", "inconclusive", "misfit")
_UNITS = {"c": "N s/m", "zeta": "1", "f_n": "Hz", "k": "N/m"}


def frame(rows: Sequence[dict[str, Any]]):
    """The results table (module docstring) of ``rows`` in their order."""
    import pandas as pd

    df = pd.DataFrame([{c: r.get(c) for c in COLUMNS} for r in rows], columns=list(COLUMNS))
    df["converged"] = df["converged"].astype("boolean")
    df["law_follows_decay"] = df["law_follows_decay"].astype("boolean")
    df["n_modes"] = pd.to_numeric(df["n_modes"], errors="coerce").astype("Int64")
    return df


#: First characters that make a spreadsheet read a cell as a formula (OWASP "CSV Injection":
#: ``=``, ``+``, ``-``, ``@``, tab, carriage return).
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def neutralised(value: Any) -> Any:
    """A text cell made inert for a spreadsheet as the OWASP CSV-injection advice says: one
    starting with a :data:`FORMULA_START` character gets a leading ``'`` (shown as text,
    never run); the CSV writer quotes the cell and doubles its quotes. Numbers, booleans and
    empty cells are returned unchanged (a negative number stays a number)."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


def spreadsheet_safe(df):
    """``df`` with every text cell :func:`neutralised` (the columns of numbers untouched)."""
    import pandas as pd

    out = df.copy()
    for col in out.columns:
        if out[col].dtype == object or pd.api.types.is_string_dtype(out[col].dtype):
            out[col] = out[col].map(neutralised).astype(object)
    return out


def _md(text: Any) -> str:
    """A table cell: Markdown and HTML specials escaped, one line."""
    import html

    s = " ".join(str(text).split())
    s = html.escape(s, quote=False)
    for ch in "\\`*_[]|#<>":
        s = s.replace(ch, "\\" + ch)
    return s


def _shown_quantity(df) -> str:
    """c when any analysed recording has it, else ζ."""
    ok = df[df["status"].isin(ANALYSED)]
    return "c" if len(ok) and ok["c_q50"].notna().any() else "zeta"


def _num(v: Any) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.4g}"


def summary_md(df, version: str, figure: bool) -> str:
    """summary.md: counts, the table of analysed recordings (median and 90 % interval of c
    or ζ, status, damper law, verdict), the refused and failed ones with their reasons."""
    q = _shown_quantity(df)
    counts = df["status"].value_counts()
    n = {k: int(counts.get(k, 0)) for k in (*ANALYSED, "refused", "failed")}
    parts = [
        "# dampfit batch\n",
        (f"dampfit {version}; {len(df)} recording(s): {sum(n[k] for k in ANALYSED)} analysed "
         f"({n['ok']} with a damper recommended, {n['inconclusive']} inconclusive, "
         f"{n['misfit']} misfit), {n['refused']} refused, {n['failed']} failed. "
         f"Full numbers: results.csv; each recording's result folder: runs/NAME "
         f"(`dampfit.load`; `dampfit report DIR/runs/NAME` draws its figures).\n"),
        f"## {q} [{_UNITS[q]}] per recording (median, 90 % interval)\n",
        f"| recording | {q} | q05 | q95 | status | damper law | verdict | converged |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for _, r in df[df["status"].isin(ANALYSED)].iterrows():
        parts.append(f"| {_md(r['file'])} | {_num(r[f'{q}_q50'])} | {_num(r[f'{q}_q05'])} | "
                     f"{_num(r[f'{q}_q95'])} | {r['status']} | {_md(r['damper_law'] or '')} | "
                     f"{_md(r['verdict'] or '')} | {_md(r['converged'])} |")
    why = df[df["status"].isin(("inconclusive", "misfit"))]
    if len(why):
        parts += ["", "## No damper recommended\n", "| recording | status | reason |",
                  "|---|---|---|"]
        parts += [f"| {_md(r['file'])} | {r['status']} | {_md(r['message'])} |"
                  for _, r in why.iterrows()]
    bad = df[~df["status"].isin(ANALYSED)]
    if len(bad):
        parts += ["", "## Not analysed\n", "| recording | status | reason |", "|---|---|---|"]
        parts += [f"| {_md(r['file'])} | {r['status']} | {_md(r['message'])} |"
                  for _, r in bad.iterrows()]
    if figure:
        parts += ["", f"![{q} per recording](comparison.png)"]
    return "\n".join(parts) + "\n"


#: Marker of each status in comparison.png: filled circle (a damper recommended), open
#: circle (inconclusive), cross (misfit).
_MARKERS = {"ok": dict(marker="o", facecolors="C0", edgecolors="C0", label="damper recommended"),
            "inconclusive": dict(marker="o", facecolors="none", edgecolors="C0",
                                 label="inconclusive"),
            "misfit": dict(marker="x", facecolors="C3", label="misfit")}


def log_scale(lo, hi) -> bool:
    """Whether intervals [lo, hi] (arrays, > 0) are drawn on a log axis: when all are
    positive and they span at least a decade (max / min ≥ 10)."""
    import numpy as np

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    ok = np.isfinite(lo) & np.isfinite(hi)
    return bool(ok.any() and (lo[ok] > 0).all() and hi[ok].max() / lo[ok].min() >= 10)


def comparison_figure(df, path: str | os.PathLike) -> Path | None:
    """comparison.png: the median and 90 % interval of c (or ζ) of every analysed recording,
    sorted by the median, its status as the marker (:data:`_MARKERS`), on a log axis where
    the values span a decade or more (:func:`log_scale`); None when no recording was analysed."""
    from dampfit.output.figures.layout import new_figure
    from dampfit.output.figures.png import drawing, save_png

    q = _shown_quantity(df)
    ok = df[df["status"].isin(ANALYSED) & df[f"{q}_q50"].notna()].sort_values(f"{q}_q50")
    if not len(ok):
        return None
    with drawing():
        bottom, top, row = 0.5, 0.35, 0.22  # [in]
        height = bottom + top + row * (len(ok) + 0.6)
        fig = new_figure(6.4, height)
        ax = fig.add_axes((0.3, bottom / height, 0.66, row * (len(ok) + 0.6) / height))
        y = list(range(len(ok)))
        med = ok[f"{q}_q50"].to_numpy(float)
        q05 = ok[f"{q}_q05"].fillna(ok[f"{q}_q50"]).to_numpy(float)
        q95 = ok[f"{q}_q95"].fillna(ok[f"{q}_q50"]).to_numpy(float)
        ax.errorbar(med, y, xerr=[med - q05, q95 - med], fmt="none", ecolor="0.4", lw=1)
        status = ok["status"].to_numpy()
        for name, kw in _MARKERS.items():
            sel = status == name
            if sel.any():
                ax.scatter(med[sel], [i for i, s in zip(y, sel) if s], zorder=3, **kw)
        log = log_scale(q05, q95)
        if log:
            ax.set_xscale("log")
        ax.set_yticks(y)
        ax.set_yticklabels([str(n)[:40] for n in ok["name"]], fontsize=7)  # names are [A-Za-z0-9._-]
        ax.set_ylim(-0.7, len(ok) - 0.3)
        ax.set_xlabel(f"{q} [{_UNITS[q]}] (median, 90 % interval{'; log axis' if log else ''})")
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=3,
                  frameon=False, borderaxespad=0.1, handletextpad=0.2)
        return save_png(fig, path)


def write_outputs(rows: Sequence[dict[str, Any]], out: Path, *, version: str):
    """results.csv (+ results.parquet with pyarrow; its text cells as they are, CSV's made
    inert: :func:`spreadsheet_safe`), summary.md and comparison.png in ``out``, each written
    atomically (the batch's own figure always, whatever ``--figures`` says of the
    recordings'); returns the table."""
    import importlib.util

    import csv

    df = frame(rows)
    atomic_write_text(out / "results.csv",
                      spreadsheet_safe(df).to_csv(index=False, quoting=csv.QUOTE_NONNUMERIC))
    if importlib.util.find_spec("pyarrow") is not None:
        atomic_write(out / "results.parquet", lambda tmp: df.to_parquet(tmp, index=False))
    else:  # an older batch's table would no longer match results.csv
        (out / "results.parquet").unlink(missing_ok=True)
    drawn = comparison_figure(df, out / "comparison.png")
    if drawn is None:  # an older batch's figure would no longer match results.csv
        (out / "comparison.png").unlink(missing_ok=True)
    atomic_write_text(out / "summary.md", summary_md(df, version, drawn is not None))
    return df
