"""Running a study on Dask ``distributed`` and writing its tables, summary and figures.

One Dask task is one (scenario, replicate): :func:`dampfit.study.task.run_task`. Tasks are
pure; the client appends each finished record to ``runs.jsonl`` as it arrives
(:class:`~dampfit.study.store.Store`), so an interrupted study loses at most the runs in
flight and the same command resumes it. Runs whose record is already stored are not
submitted again. The tables are written once every run of the configuration is stored.

By default the client starts a local cluster of N worker processes with one thread each
(:func:`dampfit.cluster.local_cluster`: like ``LocalCluster``, but its workers import
nothing from the working folder), N capped at the number of runs still to do; with a scheduler
address (``tcp://``, or ``tls://`` with Dask's TLS settings) it connects to an existing cluster,
after the scheduler has answered a first request within :data:`SCHEDULER_WAIT_S`. Workers must
be able to import the same dampfit version (same environment, e.g. ``pip install`` on every
node); this is checked before anything is submitted.
"""

from __future__ import annotations

import html
import importlib.util
import sys
import uuid
from pathlib import Path
from typing import Any, TextIO

from dampfit.files.atomic import atomic_write_text
from dampfit.errors import InputError
from dampfit.study import tables
from dampfit.study.config import StudyConfig, Task
from dampfit.cluster import check_workers, client as dask_client
from dampfit.study.store import Store
from dampfit.study.task import run_task

class StudyIncomplete(Exception):
    """Some runs did not finish (a worker died); the finished ones are stored."""


def _execute(client, todo: list[Task], store: Store, total: int, done: int, cfg: StudyConfig,
             quiet: bool, err: TextIO) -> list[str]:
    """Submit ``todo``, store each record as it completes; return failures (one line each)."""
    from distributed import as_completed

    from dampfit._progress import progress_bar

    tag = uuid.uuid4().hex[:8]
    keys = [f"dampfit-study-{t.scenario}-{t.replicate}-{tag}" for t in todo]
    futures = client.map(run_task, todo, key=keys, pure=False)
    failures = []
    with progress_bar(total, cfg.name, unit="run", initial=done, file=err,
                      enabled=not quiet and err.isatty(), leave=True) as bar:
        for fut in as_completed(futures):
            try:
                record = fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: report, keep going
                failures.append(f"{fut.key}: {type(exc).__name__}: {exc}")
            else:
                store.append(record)
                bar.update(1)
            fut.release()
    return failures


def _finished(store: Store, tasks: list[Task]) -> dict[tuple[str, int], dict[str, Any]]:
    """Stored records that match a task of this configuration (seed and estimators; a
    several-mode estimator has one row per mode)."""
    want = {t.key: t for t in tasks}
    out = {}
    for rec in store.records():
        t = want.get((rec["scenario"], rec["replicate"]))
        if t is not None and rec.get("seed") == t.seed and \
                list(dict.fromkeys(r.get("estimator") for r in rec["rows"])) == list(t.estimators):
            out[t.key] = rec
    return out


def run_study(cfg: StudyConfig, out: str | Path, *, workers: int = 1, scheduler: str | None = None,
              force: bool = False, quiet: bool = False, figures: bool = True,
              streams: tuple[TextIO, TextIO] | None = None) -> dict[str, Any]:
    """Run (or resume) the study ``cfg`` into folder ``out``; return what was done.
    ``streams`` = (stdout, stderr) to print to (default: the process's).

    Raises :class:`InputError` for a folder holding another study (unless ``force``), an
    unreachable scheduler or unusable workers, and :class:`StudyIncomplete` if some runs did
    not finish (the finished ones are kept: run again to complete the study).
    """
    from dampfit._meta import __version__

    stdout, stderr = streams or (sys.stdout, sys.stderr)
    if importlib.util.find_spec("distributed") is None:
        raise InputError("dampfit study runs on Dask: install it with "
                         "pip install 'dask[distributed]'")
    store = Store(out)
    try:
        store.open(cfg, force=force, version=__version__, start=False)  # nothing written yet
        tasks = cfg.tasks()
        done = _finished(store, tasks)
        todo = [t for t in tasks if t.key not in done]
        workers = max(1, min(workers, len(todo)))  # no idle worker processes to start
        if not quiet:
            where = scheduler or f"a local cluster of {workers} worker process(es)"
            print(f"dampfit study: {len(tasks)} runs ({cfg.n_scenarios} scenarios × "
                  f"{cfg.replicates} replicates) of {cfg.name!r}, {len(done)} already stored in "
                  f"{store.root}; {len(todo)} to run on {where}", file=stderr)
        failures: list[str] = []
        if todo:
            with dask_client(workers, scheduler) as client:
                check_workers(client, scheduler, __version__, stderr)
                store.start()  # the first write: study.json (and --force's clean-up)
                failures = _execute(client, todo, store, len(tasks), len(done), cfg, quiet, stderr)
        if failures:
            raise StudyIncomplete(f"{len(failures)} of {len(tasks)} runs did not finish (first: "
                                  f"{failures[0]}); the others are stored in {store.runs_path}: "
                                  "run the same command again to complete the study")
        store.start()
        records = list(_finished(store, tasks).values())
        result = write_outputs(cfg, records, store.root, figures=figures, version=__version__)
    finally:
        store.close()
    head = tables.coverage_view(result["ranking"]) if cfg.is_campaign else result["ranking"]
    print(tables.text(head), file=stdout, end="")
    print(f"\n  {len(records)} runs ({len(todo)} new); tables, summary.md"
          f"{' and figures' if figures else ''} in {store.root}/", file=stdout)
    return {**result, "n_new": len(todo), "n_stored": len(done)}


def write_outputs(cfg: StudyConfig, records: list[dict], out: Path, *, figures: bool,
                  version: str) -> dict[str, Any]:
    """Write runs.csv (+ runs.parquet if pyarrow is present), aggregate.csv, ranking.csv,
    summary.md and the figures into ``out``; return the three tables. For a campaign study
    aggregate.csv holds the coverage per scenario and ranking.csv pooled over all scenarios
    (:func:`dampfit.study.tables.campaign_aggregate`); its one figure is coverage.png."""
    runs = tables.runs_frame(cfg, records)
    if cfg.is_campaign:
        agg = tables.campaign_aggregate(runs, cfg.target, keys=cfg.varying)
        rank = tables.campaign_aggregate(runs, cfg.target, pooled=True)
    else:
        agg = tables.aggregate(runs, cfg.target, keys=cfg.varying)
        rank = tables.ranking(agg)
    atomic_write_text(out / "runs.csv", runs.to_csv(index=False))
    if importlib.util.find_spec("pyarrow") is None:
        (out / "runs.parquet").unlink(missing_ok=True)
    else:
        _atomic_parquet(runs, out / "runs.parquet")
    atomic_write_text(out / "aggregate.csv", agg.to_csv(index=False))
    atomic_write_text(out / "ranking.csv", rank.to_csv(index=False))
    summary = (_campaign_summary_md if cfg.is_campaign else _summary_md)(cfg, runs, agg, rank,
                                                                          version, figures)
    atomic_write_text(out / "summary.md", summary)
    if figures and cfg.is_campaign:
        from dampfit.study.figures import save_campaign_figures

        save_campaign_figures(agg, out, cfg.name)
    elif figures:
        from dampfit.study.figures import save_figures

        save_figures(agg, rank, out, cfg.name)
    return {"runs": runs, "aggregate": agg, "ranking": rank}


def _atomic_parquet(df, path: Path) -> None:
    from dampfit.files.atomic import atomic_write

    frame = df.copy()
    for col in frame.columns:  # mixed None/bool columns → pandas nullable booleans
        if frame[col].dtype == object and frame[col].dropna().map(type).eq(bool).all():
            frame[col] = frame[col].astype("boolean")
    atomic_write(path, lambda tmp: frame.to_parquet(tmp, index=False))


_UNITS = {"c": "N s/m", "zeta": "1", "p": "1/s", "f_n": "Hz"}


def _summary_md(cfg: StudyConfig, runs, agg, rank, version: str, figures: bool) -> str:
    q = cfg.target
    mass = (f"the mass m = {cfg.mass:g} kg is known exactly to the estimators" if cfg.mass
            else "no mass is given, so the estimators report ζ (not c)")
    scen_cols = ["label", "estimator", "mode", "n", "n_failed", "true", "bias", "rel_bias", "rmse", "crlb",
                 "rmse_crlb", "coverage", "median_runtime_s"]
    parts = [
        f"# Simulation study: {tables.md_escape(cfg.name)}\n",
        (f"dampfit {version}; {len(cfg.scenarios())} scenario(s) × {cfg.replicates} replicate(s), "
         f"{len(runs)} estimates; study seed {cfg.seed}; {mass}. Quantity compared: "
         f"**{q}** [{_UNITS[q]}].\n"),
        "## Ranking\n",
        ("Sorted by the geometric mean over scenarios of RMSE/CRLB (1 = as good as any unbiased "
         "estimator can be). `coverage` is the pooled fraction of 90 % intervals that hold the "
         "truth (– when the estimator reports none); `failed` the fraction of runs without an "
         "estimate.\n"),
        tables.markdown(rank),
        *_modes_md(cfg),
        "## Per scenario\n",
        tables.markdown(agg[[c for c in scen_cols if c in agg.columns]]),
        "## Definitions\n",
        ("Each run simulates one recording (`dampfit.simulate`) and runs every estimator on that "
         "same recording. bias = mean(estimate − truth); RMSE = √mean((estimate − truth)²); "
         "failed runs are left out of both. CRLB = Cramér–Rao bound sd (`dampfit.inference.crlb.bound`) "
         "for the whole simulated free decay with white noise of the simulated σ (quantization "
         "included), an unknown offset and the exact mass; it omits drift and coloured noise, "
         "whose cost shows as RMSE/CRLB > 1. With n runs, RMSE/CRLB has a sampling scatter of "
         "about 1/√(2n) and coverage one of about √(0.09/n).\n"),
    ]
    return _closing_md(parts, figures and
                       "![RMSE/CRLB per estimator](ranking.png)\n\n![coverage](coverage.png)\n",
                       cfg)


def _modes_md(cfg: StudyConfig) -> list[str]:
    """The paragraph on several modes (nothing for a one-mode study)."""
    if not cfg.has_modes:
        return []
    return [("Several modes: `mode` numbers the simulated modes by frequency (1 = lowest). The "
             "several-mode estimators (`modes_*`, K = 1 … "
             f"{cfg.max_modes} tried) are compared on every mode, their modes paired one to one "
             "with the true ones by nearest frequency; a true mode not found counts as a failed "
             "run of that mode (`failed`). A one-mode estimator is compared on the mass's mode "
             "only. Each mode's CRLB is the several-mode bound (`dampfit.inference.crlb."
             "bound_modes`), the other modes unknown; ζ is compared because c belongs to the "
             "mass's mode only. Ranks are within each mode.\n")]


def _configuration_md(cfg: StudyConfig) -> list[str]:
    """The configuration's TOML source as a preformatted HTML block with every ``& < >``
    escaped: Markdown viewers show it verbatim, and no tag of the source (a study named
    ``<script>…``) reaches the file raw, as it would inside a fenced code block. (The source
    itself is also in study.json.)"""
    text = html.escape(cfg.source.rstrip(), quote=False)
    return ["## Configuration\n", f'<pre><code class="language-toml">{text}</code></pre>\n']


def _campaign_summary_md(cfg: StudyConfig, runs, agg, pooled, version: str, figures: bool) -> str:
    q = cfg.target
    if cfg.added_mass_design:
        design = (f"added-mass design: the analysis gets the added masses and estimates the "
                  f"simulated bare mass m0 = {cfg.sim_mass:g} kg")
    elif cfg.mass is not None:
        design = f"known-mass design: the analysis gets m = {cfg.mass:g} kg"
    else:
        design = "no mass is given, so the analysis reports ζ (not c)"
    parts = [
        f"# Campaign study: {tables.md_escape(cfg.name)}\n",
        (f"dampfit {version}; {len(cfg.scenarios())} scenario(s) × {cfg.replicates} simulated "
         f"campaign(s), {len(runs)} runs; study seed {cfg.seed}; {design}. Each campaign is "
         "analysed jointly (`dampfit.campaign.analyze_campaign`); population median compared: "
         f"**{q}** [{_UNITS[q]}].\n"),
        "## Coverage, all scenarios\n",
        ("Each cell: runs whose 90 % interval holds the truth / runs where the check is defined "
         "(fraction); a calibrated analysis covers about 0.9 (binomial sd √(0.09/n)). "
         "`zero_spread_ok`: campaigns simulated without spread whose spread the analysis calls "
         "consistent with zero (should be near 1). Refused campaigns (an overdamped draw, a "
         "design the analysis refuses) are results, counted apart; runs that did not converge "
         "are counted in the coverage and in `not_converged`.\n"),
        tables.markdown(tables.coverage_view(pooled)),
        "## Per scenario\n",
        tables.markdown(tables.coverage_view(agg)),
        "## Definitions\n",
        ("c, k: the population damper (median c of the log-normal population of tests, the "
         "fixed k); m0: the effective mass (added-mass design); zeta: the bare system's ζ; "
         "predictive_c (predictive_zeta): the predictive interval of a new test against one "
         "new test drawn from the true population; spread: the interval of τ_p, the between-"
         "test sd of ln p, against the simulated c_spread (only when it is > 0). rel_bias: "
         f"mean(median − truth)/truth of {q} over the analysed runs. Full numbers: "
         "aggregate.csv (per scenario), ranking.csv (pooled), runs.csv (one row per "
         "campaign).\n"),
    ]
    return _closing_md(parts, figures and "![coverage](coverage.png)\n", cfg)


def _closing_md(parts: list[str], images: str | bool, cfg) -> str:
    """The Markdown of ``parts``, the ``images`` line (none when False) and the study's
    configuration (:func:`_configuration_md`)."""
    if images:
        parts.append(images)
    parts += _configuration_md(cfg)
    return "\n".join(parts)
