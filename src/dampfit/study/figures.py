"""Study figures: RMSE/CRLB and interval coverage per estimator; for a campaign study the
coverage of each check of the joint analysis (matplotlib, imported lazily)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from dampfit.files.atomic import atomic_write


def _save(fig, path: Path) -> None:
    """Save atomically (:func:`dampfit.files.folder.atomic_write`)."""
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"), suffix=".png")


def _wilson(k: np.ndarray, n: np.ndarray, z: float = 1.96) -> tuple[np.ndarray, np.ndarray]:
    """Wilson score interval (95 %) of a binomial proportion k/n: (lower, upper), widened by
    rounding error so it always holds k/n (at k = n the upper end is 1 − ε in floating point)."""
    n = np.maximum(n, 1)
    p = k / n
    centre = (p + z**2 / (2 * n)) / (1 + z**2 / n)
    half = z / (1 + z**2 / n) * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    return np.minimum(centre - half, p), np.maximum(centre + half, p)


def _strip(ax, agg: pd.DataFrame, order: list[str], column: str, wilson: bool = False):
    """One column of points per estimator (one point per scenario, jittered), scenario colours;
    ``wilson`` adds the 95 % Wilson interval of a coverage from its ``n_intervals``."""
    labels = list(dict.fromkeys(agg["label"]))
    colours = {lab: f"C{i % 10}" for i, lab in enumerate(labels)}
    width = 0.5
    for j, lab in enumerate(labels):
        sub = agg[agg["label"] == lab].set_index("estimator")
        x = np.array([order.index(e) for e in sub.index if e in order], dtype=float)
        sel = sub.loc[[e for e in sub.index if e in order]]
        y = sel[column].to_numpy(float)
        offset = (j - (len(labels) - 1) / 2) * width / max(len(labels), 1)
        if wilson:
            n = sel["n_intervals"].to_numpy(float)
            lo, hi = _wilson(np.round(y * n), n)
            ax.errorbar(x + offset, y, yerr=[y - lo, hi - y], fmt="o", color=colours[lab],
                        label=lab, ms=6, alpha=0.85, capsize=3)
        else:
            ax.plot(x + offset, y, "o", color=colours[lab], label=lab, ms=6, alpha=0.85)
    ax.set_xticks(range(len(order)), order, rotation=25, ha="right")
    ax.set_xlim(-0.6, len(order) - 0.4)


def _legend(ax) -> None:
    if len(ax.get_legend_handles_labels()[1]) > 1:
        ax.legend(fontsize=8, title="scenario", title_fontsize=8, loc="best")


def _per_mode(agg: pd.DataFrame, rank: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """``agg`` and the x order of the estimators; with several modes each estimator × mode is
    one column of points, labelled "estimator · mode k", in the ranking's order."""
    if "mode" not in agg or agg["mode"].nunique() < 2:
        return agg, list(dict.fromkeys(rank["estimator"]))

    def label(est, mode) -> str:
        return f"{est} · mode {int(mode)}"

    agg = agg.assign(estimator=[label(e, m) for e, m in zip(agg["estimator"], agg["mode"])])
    return agg, [label(e, m) for e, m in zip(rank["estimator"], rank["mode"])]


def save_figures(agg: pd.DataFrame, rank: pd.DataFrame, out: str | os.PathLike, title: str) -> list[Path]:
    """Write ``ranking.png`` (RMSE/CRLB, log scale) and ``coverage.png`` into ``out`` (with
    several modes one column per estimator and mode)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    out = Path(out)
    agg, order = _per_mode(agg, rank)
    quantity = str(agg["quantity"].iloc[0]) if len(agg) else "c"
    paths = []

    fig, ax = plt.subplots(figsize=(7.5, 4.5), layout="constrained")
    _strip(ax, agg, order, "rmse_crlb")
    ax.set_yscale("log")
    ax.axhline(1.0, color="k", lw=1, ls="--")
    ax.text(len(order) - 0.45, 1.0, "CRLB", va="bottom", ha="right", fontsize=8)
    ax.set_ylabel(f"RMSE / CRLB of {quantity} [1]")
    ax.set_title(f"{title}: efficiency (1 = the Cramér–Rao bound)", fontsize=10, parse_math=False)  # a '$' in the name is text
    ax.grid(True, which="both", axis="y", alpha=0.3)
    _legend(ax)
    _save(fig, out / "ranking.png")
    plt.close(fig)
    paths.append(out / "ranking.png")

    fig, ax = plt.subplots(figsize=(7.5, 4.5), layout="constrained")
    has = agg[agg["n_intervals"] > 0]
    order_cov = [e for e in order if e in set(has["estimator"])]
    if order_cov:
        _strip(ax, has, order_cov, "coverage", wilson=True)
    without = [e for e in order if e not in order_cov]
    if without:
        ax.text(0.01, 0.01, "no intervals: " + ", ".join(without), fontsize=8, va="bottom",
                ha="left", transform=ax.transAxes, color="0.3")
    ax.axhline(0.9, color="k", lw=1, ls="--")
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel(f"coverage of the 90 % interval of {quantity} [1]")
    ax.set_title(f"{title}: interval coverage (bars: 95 % Wilson interval)", fontsize=10, parse_math=False)  # a '$' in the name is text
    ax.grid(True, axis="y", alpha=0.3)
    _legend(ax)
    _save(fig, out / "coverage.png")
    plt.close(fig)
    paths.append(out / "coverage.png")
    return paths


def save_campaign_figures(agg: pd.DataFrame, out: str | os.PathLike, title: str) -> list[Path]:
    """Write ``coverage.png`` of a campaign study into ``out``: per check (x) and scenario
    (colour) the fraction of 90 % intervals holding the truth, with its 95 % Wilson interval
    (:func:`dampfit.study.tables.campaign_aggregate`'s ``cover_*``/``n_cover_*``). A campaign
    study has no bound, so there is no ranking.png."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    out = Path(out)
    checks = [c for c in agg.columns if c.startswith(("cover_", "zero_spread_ok"))
              and f"n_{c}" in agg and (agg[f"n_{c}"] > 0).any()]
    names = [c.removeprefix("cover_") for c in checks]
    labels = list(dict.fromkeys(agg["label"])) if len(agg) else []
    fig, ax = plt.subplots(figsize=(7.5, 4.5), layout="constrained")
    width = 0.5
    for j, lab in enumerate(labels):
        row = agg[agg["label"] == lab].iloc[0]
        n = np.array([float(row[f"n_{c}"]) for c in checks])
        y = np.array([float(row[c]) for c in checks])
        keep = n > 0
        x = np.arange(len(checks), dtype=float) + (j - (len(labels) - 1) / 2) * width / len(labels)
        lo, hi = _wilson(np.round(y * n), n)
        ax.errorbar(x[keep], y[keep], yerr=[(y - lo)[keep], (hi - y)[keep]], fmt="o",
                    color=f"C{j % 10}", label=lab, ms=6, alpha=0.85, capsize=3)
    ax.set_xticks(range(len(names)), names, rotation=25, ha="right")
    ax.set_xlim(-0.6, max(len(names), 1) - 0.4)
    if not checks:
        ax.text(0.5, 0.5, "no campaign was analysed", ha="center", va="center",
                transform=ax.transAxes, color="0.3")
    if "zero_spread_ok" in checks:
        ax.text(0.01, 0.01, "zero_spread_ok: zero spread called consistent with zero (ideal 1)",
                fontsize=8, va="bottom", ha="left", transform=ax.transAxes, color="0.3")
    ax.axhline(0.9, color="k", lw=1, ls="--")
    ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel("fraction of 90 % intervals holding the truth [1]")
    ax.set_title(f"{title}: campaign coverage (bars: 95 % Wilson interval)", fontsize=10,
                 parse_math=False)  # a '$' in the name is text
    ax.grid(True, axis="y", alpha=0.3)
    _legend(ax)
    _save(fig, out / "coverage.png")
    plt.close(fig)
    return [out / "coverage.png"]
