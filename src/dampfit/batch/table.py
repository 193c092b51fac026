"""The batch's outputs from its rows: ``results.csv`` (and ``results.parquet`` with pyarrow),
``summary.md`` and ``comparison.png`` — :func:`frame`, :func:`write_outputs`.

``results.csv`` has one row per recording of the command, in the order given: ``file`` (as
given), ``name`` (its folder under ``runs/``), ``sha256``, ``status`` (ok / refused / failed)
and ``message`` (the one-line reason, or the analysis's first warning), ``mass_kg``, f_n [Hz],
ζ [1], c [N·s/m] and k [N/m] each as ``q05``, ``q50``, ``q95`` (the 90 % interval and the
median; c and k empty without a mass), the damping-law ``verdict``, ``converged``,
``n_modes`` and ``modes_f_n_hz`` (the modes' median f_n [Hz] when ``--max-modes`` found
several; the quantities above are then the mass's mode), ``seconds`` (wall time of that recording's analysis and outputs) and ``folder``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Sequence

from dampfit.batch.task import QUANTITIES
from dampfit.files.atomic import atomic_write, atomic_write_text

__all__ = ["COLUMNS", "comparison_figure", "frame", "summary_md", "write_outputs"]

COLUMNS = ("file", "name", "sha256", "status", "message", "mass_kg",
           *(f"{q}_{lv}" for q in QUANTITIES for lv in ("q05", "q50", "q95")),
           "verdict", "converged", "n_modes", "modes_f_n_hz", "seconds", "folder")
_UNITS = {"c": "N s/m", "zeta": "1", "f_n": "Hz", "k": "N/m"}


def frame(rows: Sequence[dict[str, Any]]):
    """The results table (module docstring) of ``rows`` in their order."""
    import pandas as pd

    df = pd.DataFrame([{c: r.get(c) for c in COLUMNS} for r in rows], columns=list(COLUMNS))
    df["converged"] = df["converged"].astype("boolean")
    df["n_modes"] = pd.to_numeric(df["n_modes"], errors="coerce").astype("Int64")
    return df


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
    ok = df[df["status"] == "ok"]
    return "c" if len(ok) and ok["c_q50"].notna().any() else "zeta"


def _num(v: Any) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.4g}"


def summary_md(df, version: str, figure: bool) -> str:
    """summary.md: counts, the table of recordings (median and 90 % interval of c or ζ,
    verdict), the refused and failed ones with their reasons."""
    q = _shown_quantity(df)
    counts = df["status"].value_counts()
    parts = [
        "# dampfit batch\n",
        (f"dampfit {version}; {len(df)} recording(s): {int(counts.get('ok', 0))} analysed, "
         f"{int(counts.get('refused', 0))} refused, {int(counts.get('failed', 0))} failed. "
         f"Full numbers: results.csv; each recording's result folder: runs/NAME "
         f"(`dampfit.load`).\n"),
        f"## {q} [{_UNITS[q]}] per recording (median, 90 % interval)\n",
        f"| recording | {q} | q05 | q95 | verdict | converged |",
        "|---|---|---|---|---|---|",
    ]
    ok = df[df["status"] == "ok"]
    for _, r in ok.iterrows():
        parts.append(f"| {_md(r['file'])} | {_num(r[f'{q}_q50'])} | {_num(r[f'{q}_q05'])} | "
                     f"{_num(r[f'{q}_q95'])} | {_md(r['verdict'] or '')} | "
                     f"{_md(r['converged'])} |")
    bad = df[df["status"] != "ok"]
    if len(bad):
        parts += ["", "## Not analysed\n", "| recording | status | reason |", "|---|---|---|"]
        parts += [f"| {_md(r['file'])} | {r['status']} | {_md(r['message'])} |"
                  for _, r in bad.iterrows()]
    if figure:
        parts += ["", f"![{q} per recording](comparison.png)"]
    return "\n".join(parts) + "\n"


def comparison_figure(df, path: str | os.PathLike) -> Path | None:
    """comparison.png: the median and 90 % interval of c (or ζ) of every analysed recording,
    sorted, the verdict as the marker (filled: adequate, open: inconclusive, cross: not
    adequate or none); None when no recording was analysed."""
    from dampfit.output.figures.layout import new_figure
    from dampfit.output.figures.png import drawing, save_png

    q = _shown_quantity(df)
    ok = df[(df["status"] == "ok") & df[f"{q}_q50"].notna()].sort_values(f"{q}_q50")
    if not len(ok):
        return None
    with drawing():
        bottom, top, row = 0.5, 0.35, 0.22  # [in]
        height = bottom + top + row * (len(ok) + 0.6)
        fig = new_figure(6.4, height)
        ax = fig.add_axes((0.3, bottom / height, 0.66, row * (len(ok) + 0.6) / height))
        y = range(len(ok))
        med = ok[f"{q}_q50"].to_numpy(float)
        lo = med - ok[f"{q}_q05"].to_numpy(float)
        hi = ok[f"{q}_q95"].to_numpy(float) - med
        ax.errorbar(med, list(y), xerr=[lo, hi], fmt="none", ecolor="0.4", lw=1)
        style = {"adequate": dict(marker="o", facecolors="C0"),
                 "inconclusive": dict(marker="o", facecolors="none")}
        for name, kw in (("adequate", style["adequate"]), ("inconclusive", style["inconclusive"]),
                         ("other", dict(marker="x", facecolors="C3"))):
            sel = ok["verdict"].eq(name).to_numpy() if name != "other" else \
                ~ok["verdict"].isin(["adequate", "inconclusive"]).to_numpy()
            if sel.any():
                ax.scatter(med[sel], [i for i, s in zip(y, sel) if s], edgecolors="C0" if name != "other"
                           else None, label=name if name != "other" else "not adequate / none",
                           zorder=3, **kw)
        ax.set_yticks(list(y))
        ax.set_yticklabels([str(n)[:40] for n in ok["name"]], fontsize=7)  # names are [A-Za-z0-9._-]
        ax.set_ylim(-0.7, len(ok) - 0.3)
        ax.set_xlabel(f"{q} [{_UNITS[q]}] (median, 90 % interval)")
        ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=3,
                  frameon=False, borderaxespad=0.1, handletextpad=0.2)
        return save_png(fig, path)


def write_outputs(rows: Sequence[dict[str, Any]], out: Path, *, figure: bool, version: str):
    """results.csv (+ results.parquet with pyarrow), summary.md and comparison.png in ``out``,
    each written atomically; returns the table."""
    import importlib.util

    df = frame(rows)
    atomic_write_text(out / "results.csv", df.to_csv(index=False))
    if importlib.util.find_spec("pyarrow") is not None:
        atomic_write(out / "results.parquet", lambda tmp: df.to_parquet(tmp, index=False))
    else:  # an older batch's table would no longer match results.csv
        (out / "results.parquet").unlink(missing_ok=True)
    drawn = comparison_figure(df, out / "comparison.png") if figure else None
    atomic_write_text(out / "summary.md", summary_md(df, version, drawn is not None))
    return df
