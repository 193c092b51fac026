r"""Study tables with pandas: tidy runs, per-scenario aggregates, the estimator ranking.

For a scenario s and an estimator, with the target quantity θ (c [N·s/m] when the study has a
mass, else ζ [1]), the n_ok successful runs' errors e_i = θ̂_i − θ and bound sds σ_i:

    bias = mean(e_i),   RMSE = √mean(e_i²),   CRLB = √mean(σ_i²),   efficiency ratio = RMSE/CRLB,

(RMSE/CRLB ≥ 1 for an unbiased estimator up to sampling noise, ≈ 1 for an efficient one), the
coverage of the reported 90 % intervals = fraction of runs with an interval whose interval
holds θ, and the median runtime [s]. Failed runs (``ok`` false or no estimate) are counted
in ``n_failed`` and left out of the error statistics. The ranking pools the scenarios per
estimator: geometric mean and worst RMSE/CRLB, median relative bias, pooled coverage,
failure fraction and median runtime, sorted by the geometric mean.

Several modes: every statistic is per scenario × estimator × true ``mode`` (1-based by
frequency; a true mode an estimator did not find counts as a failed run of that mode), and the
ranking per estimator × mode, ranked within each mode (mode 1 first). A one-mode study has
``mode`` = 1 throughout and otherwise the same tables.

A campaign study (:mod:`dampfit.study.campaign`) has no bound and one "estimator", the joint
analysis: :func:`campaign_aggregate` gives per scenario (and pooled over all of them, in the
place of the ranking) the number of runs ``n``, refused (``n_refused``), crashed
(``n_failed``) and not converged (``n_not_converged``) runs, the bias, relative bias and
RMSE of the population median of the target over the analysed runs, and for each check of
:data:`dampfit.study.campaign.CHECKS` the fraction ``cover_<check>`` of the analysed runs
where it is defined whose 90 % interval holds the truth, with that number of runs
``n_cover_<check>`` (so covered = fraction × n), and the same for ``zero_spread_ok`` (zero
true spread recognised). Runs that did not converge are counted in the coverages (and in
``n_not_converged``). :func:`coverage_view` shows them as "covered/n (fraction)".
"""

from __future__ import annotations

import html
import math
import re
from typing import Any

import numpy as np
import pandas as pd

from dampfit.study.config import StudyConfig


def scenario_labels(cfg: StudyConfig) -> dict[str, str]:
    """Short label of each scenario from its varying grid fields, e.g. ``zeta=0.002 duration=30``."""
    out = {}
    for sid, params in cfg.scenarios():
        out[sid] = " ".join(f"{k}={_short(params[k])}" for k in cfg.varying) or "all"
    return out


def _short(v: Any) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def runs_frame(cfg: StudyConfig, records: list[dict[str, Any]]) -> pd.DataFrame:
    """Tidy table: one row per scenario × replicate × estimator, in config order.

    Columns: ``scenario``, ``label``, the scenario's fields, ``mass`` (simulated) [kg], ``replicate``,
    ``seed``, ``estimator``, ``mode``, then the record rows' columns (see
    :func:`dampfit.study.task.run_task`; a stored row without ``mode``, from before several
    modes, is mode 1). Sorted by scenario (config order), replicate, estimator, mode.
    """
    scen = dict(cfg.scenarios())
    order = {sid: i for i, sid in enumerate(scen)}
    est_order = {e: i for i, e in enumerate(cfg.estimators)}
    labels = scenario_labels(cfg)
    mass = cfg.sim_mass  # given to the estimators only if cfg.mass is set
    rows = []
    for rec in records:
        sid = rec["scenario"]
        if sid not in scen or rec["replicate"] >= cfg.replicates:
            continue
        params = {k: (str(v) if isinstance(v, list) else v) for k, v in scen[sid].items()}
        head = {"scenario": sid, "label": labels[sid], **params, "mass": mass,
                "replicate": rec["replicate"], "seed": rec["seed"]}
        rows.extend({**head, **row} for row in rec["rows"])
    df = pd.DataFrame(rows)
    if df.empty:
        return df
    if not cfg.is_campaign:
        df["mode"] = (df["mode"] if "mode" in df else pd.Series(1, index=df.index)) \
            .fillna(1).astype(int)
    keys = pd.DataFrame({"s": df["scenario"].map(order), "r": df["replicate"],
                         "e": df["estimator"].map(lambda e: est_order.get(e, len(est_order))),
                         "m": df["mode"] if "mode" in df else 1})
    df = df.loc[keys.sort_values(["s", "r", "e", "m"], kind="stable").index].reset_index(drop=True)
    for col in df.columns:  # None → NaN in numeric columns; booleans with gaps stay objects
        if col.startswith(("est_", "true_", "crlb_", "err_", "spread_q")) \
                or col.endswith(("_lo", "_hi")) or col in ("runtime_s", "n_modes"):
            df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
    return df


def _stats(g: pd.DataFrame, q: str) -> pd.Series:
    est = g[f"est_{q}"].astype(float)
    ok = g["ok"].astype(bool) & est.notna()
    err = g.loc[ok, f"err_{q}"].astype(float)
    true = float(g[f"true_{q}"].astype(float).mean())
    crlb_sd = g[f"crlb_{q}"].astype(float).dropna()
    crlb = math.sqrt(float((crlb_sd**2).mean())) if len(crlb_sd) else math.nan
    bias = float(err.mean()) if len(err) else math.nan
    rmse = math.sqrt(float((err**2).mean())) if len(err) else math.nan
    cov = g.loc[ok, f"covers_{q}"].dropna().astype(bool) if f"covers_{q}" in g else pd.Series([], dtype=bool)
    runtime = g["runtime_s"].astype(float).dropna()
    return pd.Series({
        "n": len(g),
        "n_failed": int((~ok).sum()),
        "true": true,
        "bias": bias,
        "rel_bias": bias / true if true else math.nan,
        "rmse": rmse,
        "crlb": crlb,
        "rmse_crlb": rmse / crlb if crlb > 0 else math.nan,
        "coverage": float(cov.mean()) if len(cov) else math.nan,
        "n_intervals": len(cov),
        "median_runtime_s": float(runtime.median()) if len(runtime) else math.nan,
    })


def aggregate(runs: pd.DataFrame, target: str, keys: list[str] | None = None) -> pd.DataFrame:
    """Per scenario × estimator (× mode) statistics of ``target`` (``"c"``, ``"zeta"``, ``"p"``
    or ``"f_n"``).

    ``keys`` are extra per-scenario columns to carry along (e.g. the varying grid fields).
    Columns: ``scenario``, ``label``, keys…, ``estimator``, ``mode`` (when the runs have it),
    ``quantity``, ``n``, ``n_failed``,
    ``true``, ``bias``, ``rel_bias``, ``rmse``, ``crlb``, ``rmse_crlb``, ``coverage``,
    ``n_intervals``, ``median_runtime_s`` (module docstring).
    """
    keys = [k for k in (keys or []) if k in runs.columns and k not in ("scenario", "label", "mode")]
    group = ["scenario", "label", *keys, "estimator", *(["mode"] if "mode" in runs else [])]
    parts = []
    for name, g in runs.groupby(group, sort=False, dropna=False):
        s = _stats(g, target)
        parts.append({**dict(zip(group, name)), "quantity": target, **s.to_dict()})
    out = pd.DataFrame(parts)
    for col in ("mode", "n", "n_failed", "n_intervals"):
        if col in out:
            out[col] = out[col].astype(int)
    return out


def ranking(agg: pd.DataFrame) -> pd.DataFrame:
    """Per estimator (× mode) over all scenarios, best first (within each mode; module
    docstring). Columns: ``rank``, ``estimator``, ``mode`` (when ``agg`` has it),
    ``scenarios``, ``rmse_crlb_gmean``, ``rmse_crlb_worst``, ``rel_bias_median``,
    ``coverage``, ``failed``, ``median_runtime_s``."""
    rows = []
    by = ["estimator", *(["mode"] if "mode" in agg else [])]
    for key, g in agg.groupby(by, sort=False):
        ratio = g["rmse_crlb"].astype(float)
        ratio = ratio[np.isfinite(ratio) & (ratio > 0)]
        n_int = int(g["n_intervals"].sum())
        covered = float((g["coverage"].fillna(0) * g["n_intervals"]).sum())
        rows.append({
            **dict(zip(by, key)),
            "scenarios": len(g),
            "rmse_crlb_gmean": float(np.exp(np.log(ratio).mean())) if len(ratio) else math.nan,
            "rmse_crlb_worst": float(ratio.max()) if len(ratio) else math.nan,
            "rel_bias_median": float(g["rel_bias"].median()),
            "coverage": covered / n_int if n_int else math.nan,
            "failed": float(g["n_failed"].sum() / g["n"].sum()) if g["n"].sum() else math.nan,
            "median_runtime_s": float(g["median_runtime_s"].median()),
        })
    out = pd.DataFrame(rows)
    if out.empty:
        return out
    if "mode" not in out:
        out = out.sort_values("rmse_crlb_gmean", na_position="last", kind="stable")
        out.insert(0, "rank", np.arange(1, len(out) + 1))
        return out.reset_index(drop=True)
    out["mode"] = out["mode"].astype(int)
    out = out.sort_values(["mode", "rmse_crlb_gmean"], na_position="last",
                          kind="stable").reset_index(drop=True)
    out.insert(0, "rank", out.groupby("mode").cumcount() + 1)
    return out


# -- campaign studies ----------------------------------------------------------------------

def _campaign_checks() -> list[tuple[str, str]]:
    """(run flag, table column) of each campaign check: ``covers_<c>`` → ``cover_<c>``, and
    ``spread_zero_ok`` → ``zero_spread_ok``."""
    from dampfit.study.campaign import CHECKS

    return [(f"covers_{c}", f"cover_{c}") for c in CHECKS] + [("spread_zero_ok", "zero_spread_ok")]


def _flag_fraction(g: pd.DataFrame, col: str) -> tuple[float, int]:
    """(fraction true, number defined) of a column of flags with gaps."""
    if col not in g:
        return math.nan, 0
    x = g[col].dropna().astype(bool)
    return (float(x.mean()) if len(x) else math.nan), len(x)


def _campaign_stats(g: pd.DataFrame, q: str) -> dict[str, Any]:
    ok = g["ok"].astype(bool)
    refused = g["refused"].fillna("").astype(str).ne("")
    ran = g.loc[ok]
    conv = ran["converged"].fillna(False).astype(bool)
    err = ran[f"err_{q}"].astype(float).dropna()
    true = float(g[f"true_{q}"].astype(float).mean())
    bias = float(err.mean()) if len(err) else math.nan
    runtime = g["runtime_s"].astype(float).dropna()
    out: dict[str, Any] = {
        "n": len(g),
        "n_refused": int(refused.sum()),
        "n_failed": int((~ok & ~refused).sum()),
        "n_not_converged": int((~conv).sum()),
        "true": true,
        "bias": bias,
        "rel_bias": bias / true if true else math.nan,
        "rmse": math.sqrt(float((err**2).mean())) if len(err) else math.nan,
    }
    for flag, col in _campaign_checks():
        out[col], out[f"n_{col}"] = _flag_fraction(ran, flag)
    out["median_runtime_s"] = float(runtime.median()) if len(runtime) else math.nan
    return out


def campaign_aggregate(runs: pd.DataFrame, target: str, keys: list[str] | None = None, *,
                       pooled: bool = False) -> pd.DataFrame:
    """Coverage table of a campaign study (module docstring): per scenario (``keys``: extra
    per-scenario columns to carry along), or with ``pooled`` one row over all scenarios
    (label "all"). Columns: ``scenario``, ``label``, keys…, ``estimator``, ``quantity``,
    ``n``, ``n_refused``, ``n_failed``, ``n_not_converged``, ``true``, ``bias``,
    ``rel_bias``, ``rmse``, ``cover_<check>`` and ``n_cover_<check>`` for each check,
    ``zero_spread_ok``, ``n_zero_spread_ok``, ``median_runtime_s``."""
    if pooled:
        runs = runs.assign(scenario="all", label="all")
        keys = []
    keys = [k for k in (keys or []) if k in runs.columns and k not in ("scenario", "label")]
    group = ["scenario", "label", *keys, "estimator"]
    parts = [{**dict(zip(group, name)), "quantity": target, **_campaign_stats(g, target)}
             for name, g in runs.groupby(group, sort=False, dropna=False)]
    out = pd.DataFrame(parts)
    for col in out.columns:
        if col == "n" or col.startswith("n_"):
            out[col] = out[col].astype(int)
    return out


def coverage_view(agg: pd.DataFrame) -> pd.DataFrame:
    """A campaign aggregate for reading: label, runs, refused/failed/not converged, bias of
    the target's median, and "covered/n (fraction)" for each check any run defines."""
    cols = ["label", "n", "n_refused", "n_failed", "n_not_converged", "rel_bias"]
    view = agg[[c for c in cols if c in agg.columns]].copy()
    for _, col in _campaign_checks():
        if col not in agg or not (agg[f"n_{col}"] > 0).any():
            continue
        view[col.removeprefix("cover_")] = [
            f"{round(f * n)}/{n} ({f:.2f})" if n else "–"
            for f, n in zip(agg[col].astype(float), agg[f"n_{col}"].astype(int))]
    return view.rename(columns={"n_refused": "refused", "n_failed": "failed",
                                "n_not_converged": "not_converged"})


def _fmt(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return "–" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def md_escape(text: str) -> str:
    """``text`` as inert Markdown/HTML: one line, Markdown's special characters
    (`` ` * [ ] # | ~ ! \\ ``; ``_`` is inert inside words) backslash-escaped and ``< > &``
    as HTML entities."""
    text = " ".join(str(text).split())
    text = re.sub(r"([\\`*\[\]#|~!])", r"\\\1", text)
    return html.escape(text, quote=False)


def markdown(df: pd.DataFrame) -> str:
    """A GitHub-flavoured Markdown table of ``df`` (numbers to 4 significant digits; every
    cell through :func:`md_escape`)."""
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |",
             "|" + "|".join("---:" if pd.api.types.is_numeric_dtype(df[c]) else "---"
                            for c in df.columns) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(md_escape(_fmt(v)) for v in row) + " |")
    return "\n".join(lines) + "\n"


def text(df: pd.DataFrame) -> str:
    """A plain fixed-width rendering of ``df`` (numbers to 4 significant digits)."""
    if df.empty:
        return "(no runs)\n"
    left = [not pd.api.types.is_numeric_dtype(df[c]) for c in df.columns]
    cells = [[str(c) for c in df.columns]] + [[_fmt(v) for v in row] for row in df.itertuples(index=False)]
    widths = [max(len(r[i]) for r in cells) for i in range(len(cells[0]))]
    return "\n".join("  ".join(c.ljust(w) if lf else c.rjust(w) for c, w, lf in zip(r, widths, left))
                     .rstrip() for r in cells) + "\n"
