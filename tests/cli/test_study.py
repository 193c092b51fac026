"""``dampfit study``: config validation, seeds, the CRLB design, aggregate math, resumable
storage, and studies on a local Dask cluster, on an external scheduler and after a SIGKILL."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dampfit.study import registry
from dampfit import simulate as sim
from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.study import config as sconfig
from dampfit.study import tables
from dampfit.study.store import Store
from dampfit.study.task import crlb_design, run_task
from tests._support.hostile import one_error_line
from tests._support.study import _DELETE, AVAILABLE, SMALL, base

N_SMALL = 4 * 4  # runs
RUN_CMD = [sys.executable, "-c", "import sys; from dampfit.cli import main; sys.exit(main(sys.argv[1:]))"]
#: columns that legitimately differ between two executions of the same run
TIMING = ["runtime_s"]


# -- configuration ------------------------------------------------------------------------

@pytest.mark.parametrize("over, match", [
    ({"study__replicates": 0}, r"\[study\] replicates must be an integer ≥ 1"),
    ({"study__replicates": _DELETE}, r"\[study\] replicates is missing"),
    ({"study__replicates": 2.5}, r"\[study\] replicates must be an integer"),
    ({"study__seed": -1}, r"\[study\] seed must be an integer ≥ 0"),
    ({"study__estimators": ["hilbert", "magic"]}, r"unknown estimator 'magic'.*available: .*least_squares"),
    ({"study__estimators": []}, r"\[study\] estimators must be a non-empty list"),
    ({"study__estimators": ["hilbert", "hilbert"]}, r"lists a name twice"),
    ({"study__estimators": _DELETE}, r"\[study\] estimators is missing"),
    ({"study__mass": -1.0}, r"\[study\] mass must be a positive number"),
    ({"study__colour": "red"}, r"unknown key \[study\] colour"),
    ({"study__max_replicates": {"bayes": 2}}, r"max_replicates names 'bayes'"),
    ({"study__max_replicates": {"hilbert": 0}}, r"max_replicates.hilbert must be an integer ≥ 1"),
    ({"grid__zeta": 0.01}, r"\[grid\] zeta must be a list of values.*\[fixed\]"),
    ({"grid__zeta": []}, r"\[grid\] zeta is an empty list"),
    ({"grid__zeta": [0.01, 0.01]}, r"\[grid\] zeta lists a value twice"),
    ({"grid__wobble": [1.0]}, r"unknown field \[grid\] wobble; known: .*noise_density"),
    ({"grid__k": [100.0]}, r"\[grid\] k cannot be set here"),
    ({"fixed__seed": 3}, r"\[fixed\] seed cannot be set here"),
    ({"fixed__mass": 3.0}, r"\[fixed\] mass cannot be set here: set it as \[study\] mass"),
    ({"fixed__zeta": 0.02}, r"zeta is in both \[grid\] and \[fixed\]"),
    ({"fixed__f_n": _DELETE}, r"f_n is missing"),
    ({"fixed__duration": "long"}, r"\[fixed\] duration must be a finite number"),
    ({"fixed__gravity": 1}, r"\[fixed\] gravity must be true or false"),
    ({"grid__zeta": [0.01, 1.5]}, r"scenario zeta=1.5: damping ratio zeta must be in \[0, 1\)"),
    ({"fixed__noise_density": -5.0}, r"noise_density must not be negative"),
])
def test_config_errors_name_the_key(over, match):
    with pytest.raises(InputError, match=match):
        sconfig.parse(base(**over), AVAILABLE)


def test_config_structure_errors(tmp_path):
    with pytest.raises(InputError, match=r"unknown table\(s\) \[extra\]"):
        sconfig.parse({**base(), "extra": {}}, AVAILABLE)
    with pytest.raises(InputError, match=r"\[grid\] is empty"):
        sconfig.parse({**base(), "grid": {}}, AVAILABLE)
    with pytest.raises(InputError, match=r"no \[grid\] table"):
        sconfig.parse({"study": base()["study"]}, AVAILABLE)
    bad = tmp_path / "bad.toml"
    bad.write_text("[study\nreplicates = 1\n")
    with pytest.raises(InputError, match="bad.toml is not valid TOML"):
        sconfig.load(bad, AVAILABLE)
    with pytest.raises(InputError, match="does not exist"):
        sconfig.load(tmp_path / "missing.toml", AVAILABLE)


def test_bad_config_exits_2_and_writes_nothing(tmp_path, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text(SMALL.replace("replicates = 4", "replicates = 0"))
    out = tmp_path / "out"
    assert main(["study", str(cfg), "--out", str(out), "--quiet"]) == 2
    assert "[study] replicates must be an integer ≥ 1" in one_error_line(capsys)
    assert not out.exists()
    assert main(["study", str(cfg), "--workers", "0"]) == 2
    assert "--workers: must be at least 1" in one_error_line(capsys)


def test_scenarios_tasks_and_seeds_are_deterministic():
    two = {"grid__zeta": [0.01, 0.02], "grid__duration": [10, 20], "fixed__duration": _DELETE}
    a = sconfig.parse(base(**two), AVAILABLE)
    b = sconfig.parse(base(grid__duration=[20.0, 10.0], grid__zeta=[0.02, 0.01],
                           fixed__duration=_DELETE), AVAILABLE)
    # 10 and 10.0, and the order of grid keys and values, do not change a scenario's id or seeds
    seeds_a = {t.key: t.seed for t in a.tasks()}
    seeds_b = {t.key: t.seed for t in b.tasks()}
    assert seeds_a == seeds_b and len(seeds_a) == 4 * 2
    assert len(set(seeds_a.values())) == len(seeds_a)  # every run its own seed
    assert a.fingerprint() == b.fingerprint()
    # another study seed changes every run's seed and the fingerprint
    c = sconfig.parse(base(study__seed=1, **two), AVAILABLE)
    assert not set(seeds_a.values()) & {t.seed for t in c.tasks()}
    assert c.fingerprint() != a.fingerprint()
    # more replicates keep the existing runs' seeds (a study can be extended)
    d = sconfig.parse(base(study__replicates=5, **two), AVAILABLE)
    assert {t.key: t.seed for t in d.tasks()}.items() >= seeds_a.items()
    assert d.fingerprint() == a.fingerprint()


def test_max_replicates_limits_one_estimator():
    cfg = sconfig.parse(base(study__estimators=["hilbert", "log_decrement"], study__replicates=3,
                             study__max_replicates={"log_decrement": 1}), AVAILABLE)
    assert [t.estimators for t in cfg.tasks()] == [("hilbert", "log_decrement"), ("hilbert",),
                                                   ("hilbert",)]


# -- one run -------------------------------------------------------------------------------

def test_crlb_design_is_the_noise_free_simulated_acceleration():
    """The bound's (p, ω_d, a_cos, a_sin) reproduce the simulator's free decay sample by sample,
    also with jitter, a hand-held start (window not at the release) and quantization σ."""
    cfg = sim.from_modal(2.0, 1.5, 0.03, u0=0.05, duration=12.0, sample_rate=80.0, jitter=0.05,
                         noise_density=0.0, handheld=1.234, seed=3)
    rec, truth = sim.recording(cfg)
    d = crlb_design(rec, truth)
    free = rec.time >= truth["t_release"]
    want = rec.axis("y")[free]
    tau, wd = d["times"], d["omega_d"]
    got = np.exp(-d["p"] * tau) * (d["a_cos"] * np.cos(wd * tau) + d["a_sin"] * np.sin(wd * tau))
    assert d["times"][0] == 0.0 and d["times"].size == free.sum()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())
    q = dict(truth, noise_sigma=0.3, config={**truth["config"], "quantization": 0.6})
    assert crlb_design(rec, q)["sigma"] == pytest.approx(math.sqrt(0.09 + 0.03))


def test_run_task_rows_and_failures_are_data(monkeypatch):
    cfg = sconfig.parse(base(study__estimators=["hilbert", "least_squares"]), AVAILABLE)
    task = cfg.tasks()[0]
    fake = registry.Estimate("hilbert", 0.2, 2.0, 0.0159, 0.4, 0.2, 0.5, None, None, True, "", 0.01)
    broken = registry.Estimate("least_squares", math.nan, math.nan, math.nan, None, None, None,
                                 None, None, False, "LinAlgError: singular", 0.02)
    monkeypatch.setattr(registry, "run", lambda names, rec, mass, seed: [fake, broken])
    rec = run_task(task)
    assert json.loads(json.dumps(rec, allow_nan=False)) == rec  # JSON-safe
    good, bad = rec["rows"]
    p_true = 2.0 * math.pi * 2.0 * 0.01
    assert good["true_p"] == pytest.approx(p_true) and good["true_c"] == pytest.approx(2 * p_true)
    assert good["err_c"] == pytest.approx(0.4 - 2 * p_true)
    assert good["covers_c"] is True and good["covers_zeta"] is None
    assert good["crlb_c"] == pytest.approx(2.0 * good["crlb_p"]) and good["crlb_c"] > 0
    assert bad["ok"] is False and bad["est_c"] is None and bad["message"] == "LinAlgError: singular"

    def explode(*a, **k):
        raise RuntimeError("boom")

    monkeypatch.setattr(registry, "run", explode)
    rec = run_task(task)
    assert [r["ok"] for r in rec["rows"]] == [False, False]
    assert rec["rows"][0]["message"] == "run failed: RuntimeError: boom"


def test_run_task_without_mass_compares_zeta():
    """Real estimator, no mass: ζ is the target, c and its bound are absent, not invented."""
    cfg = sconfig.parse(base(study__mass=_DELETE), AVAILABLE)
    assert cfg.target == "zeta"
    task = cfg.tasks()[0]
    assert not task.mass_known
    (row,) = run_task(task)["rows"]
    assert row["ok"], row["message"]
    assert row["est_c"] is None and row["true_c"] is None and row["crlb_c"] is None
    assert row["true_zeta"] == pytest.approx(0.01)
    assert row["err_zeta"] == pytest.approx(row["est_zeta"] - 0.01)
    assert 0 < row["crlb_zeta"] < 1e-3 and abs(row["err_zeta"]) < 1e-3


# -- tables ----------------------------------------------------------------------------------

def test_aggregate_and_ranking_math():
    rows = []
    # scenario A, truth c = 1, bound 0.1: "good" errors ±0.1 → RMSE 0.1, ratio 1;
    # "biased" errors 0.3, 0.5 → bias 0.4, RMSE √0.17; one failed run left out
    for est, errs, cov in [("good", [0.1, -0.1], [True, False]), ("biased", [0.3, 0.5], [None, None])]:
        for i, e in enumerate(errs):
            rows.append({"scenario": "A", "label": "zeta=0.01", "estimator": est, "ok": True,
                         "est_c": 1 + e, "true_c": 1.0, "crlb_c": 0.1, "err_c": e,
                         "covers_c": cov[i], "runtime_s": 0.1 * (i + 1)})
    rows.append({"scenario": "A", "label": "zeta=0.01", "estimator": "biased", "ok": False,
                 "est_c": None, "true_c": 1.0, "crlb_c": 0.1, "err_c": None, "covers_c": None,
                 "runtime_s": 5.0})
    # scenario B: bound sds 0.1 and 0.3 → CRLB √mean(σ²) = √0.05; "good" RMSE = 0.2
    for est, errs in [("good", [0.2, -0.2]), ("biased", [2.0, 2.0])]:
        for e, s in zip(errs, [0.1, 0.3]):
            rows.append({"scenario": "B", "label": "zeta=0.02", "estimator": est, "ok": True,
                         "est_c": 2 + e, "true_c": 2.0, "crlb_c": s, "err_c": e, "covers_c": True,
                         "runtime_s": 1.0})
    agg = tables.aggregate(pd.DataFrame(rows), "c").set_index(["scenario", "estimator"])
    g, b = agg.loc[("A", "good")], agg.loc[("A", "biased")]
    assert (g["n"], g["n_failed"], b["n"], b["n_failed"]) == (2, 0, 3, 1)
    assert g["bias"] == pytest.approx(0.0) and g["rmse"] == pytest.approx(0.1)
    assert g["rmse_crlb"] == pytest.approx(1.0)
    assert g["coverage"] == pytest.approx(0.5) and g["n_intervals"] == 2
    assert g["median_runtime_s"] == pytest.approx(0.15)
    assert b["bias"] == pytest.approx(0.4) and b["rel_bias"] == pytest.approx(0.4)
    assert b["rmse"] == pytest.approx(math.sqrt(0.17)) and b["rmse_crlb"] == pytest.approx(math.sqrt(17))
    assert math.isnan(b["coverage"]) and b["n_intervals"] == 0
    assert b["median_runtime_s"] == pytest.approx(0.2)  # the failed run's 5 s counts too
    gb = agg.loc[("B", "good")]
    assert gb["crlb"] == pytest.approx(math.sqrt(0.05))
    assert gb["rmse_crlb"] == pytest.approx(0.2 / math.sqrt(0.05))

    rank = tables.ranking(agg.reset_index())
    assert list(rank["estimator"]) == ["good", "biased"] and list(rank["rank"]) == [1, 2]
    r = rank.set_index("estimator")
    assert r.loc["good", "rmse_crlb_gmean"] == pytest.approx(math.sqrt(1.0 * 0.2 / math.sqrt(0.05)))
    assert r.loc["biased", "rmse_crlb_worst"] == pytest.approx(2.0 / math.sqrt(0.05))
    assert r.loc["good", "coverage"] == pytest.approx(3 / 4)  # pooled: (1 + 2) of (2 + 2)
    assert r.loc["biased", "coverage"] == pytest.approx(1.0)  # only B has intervals
    assert r.loc["biased", "failed"] == pytest.approx(1 / 5)
    md = tables.markdown(rank)
    assert md.splitlines()[0].startswith("| rank | estimator |") and "| 1 | good |" in md


# -- storage ---------------------------------------------------------------------------------

def test_store_tolerates_torn_line_refuses_other_config_and_locks(tmp_path):
    cfg = sconfig.parse(base(), AVAILABLE)
    store = Store(tmp_path / "s")
    store.open(cfg, force=False, version="x")
    store.append({"scenario": "s1", "replicate": 0, "rows": []})
    store.append({"scenario": "s1", "replicate": 1, "rows": [{"a": 1}]})
    with open(store.runs_path, "ab") as fh:
        fh.write(b'{"scenario": "s1", "replicate": 2, "ro')  # killed mid-write
    assert [r["replicate"] for r in store.records()] == [0, 1]
    # a second study process on the same folder is refused while the first holds it
    with pytest.raises(InputError, match="another dampfit study is running"):
        Store(tmp_path / "s").open(cfg, force=False, version="x")
    store.close()

    again = Store(tmp_path / "s")
    again.open(cfg, force=False, version="x")  # reopening cuts the torn line
    again.append({"scenario": "s1", "replicate": 2, "rows": []})
    assert [r["replicate"] for r in again.records()] == [0, 1, 2]
    assert store.runs_path.read_bytes().endswith(b"\n")
    again.close()

    other = sconfig.parse(base(study__seed=9), AVAILABLE)
    with pytest.raises(InputError, match="holds a study with a different configuration.*--force"):
        Store(tmp_path / "s").open(other, force=False, version="x")
    forced = Store(tmp_path / "s")
    forced.open(other, force=True, version="x")
    assert forced.records() == []
    forced.close()

    (tmp_path / "unrelated").mkdir()
    (tmp_path / "unrelated" / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="holds no dampfit study"):
        Store(tmp_path / "unrelated").open(cfg, force=False, version="x")


# -- whole studies ---------------------------------------------------------------------------

def frame(folder: Path) -> pd.DataFrame:
    return pd.read_csv(folder / "runs.csv").drop(columns=TIMING)


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    """The SMALL study run once on a local cluster of 2 worker processes."""
    d = tmp_path_factory.mktemp("study")
    cfg = d / "tiny.toml"
    cfg.write_text(SMALL)
    out = d / "ref"
    rc = main(["study", str(cfg), "--out", str(out), "--workers", "2", "--quiet"])
    return cfg, out, rc


def test_local_cluster_study_writes_tables_and_figures(small_study):
    _, out, rc = small_study
    assert rc == 0
    names = {p.name for p in out.iterdir()}
    assert {"study.json", "runs.jsonl", "runs.csv", "aggregate.csv", "ranking.csv",
            "summary.md", "ranking.png", "coverage.png"} <= names
    # Parquet is written exactly when pyarrow is installed (an optional dependency)
    assert ("runs.parquet" in names) == (importlib.util.find_spec("pyarrow") is not None)
    runs = pd.read_csv(out / "runs.csv")
    assert len(runs) == N_SMALL * 3
    assert runs.groupby(["scenario", "replicate"]).size().eq(3).all()
    assert runs["ok"].all(), runs.loc[~runs["ok"], "message"].tolist()
    assert np.allclose(runs["err_c"], runs["est_c"] - runs["true_c"])
    assert (runs["crlb_c"] > 0).all()
    # the two records of a scenario's replicate were simulated with the same seed
    assert runs.groupby(["scenario", "replicate"])["seed"].nunique().eq(1).all()
    if importlib.util.find_spec("pyarrow"):
        pq = pd.read_parquet(out / "runs.parquet")
        assert list(pq.columns) == list(runs.columns)
        assert np.array_equal(pq["est_c"], runs["est_c"]) and pq["ok"].all()
    else:
        assert not (out / "runs.parquet").exists()
    agg = pd.read_csv(out / "aggregate.csv")
    assert len(agg) == 4 * 3 and (agg["n"] == 4).all() and set(agg["quantity"]) == {"c"}
    # every estimator is at or above the bound, up to sampling scatter of 4 runs
    assert (agg["rmse_crlb"] > 0.4).all()
    summary = (out / "summary.md").read_text()
    assert "# Simulation study: tiny" in summary and "| rank | estimator |" in summary
    # runs were spread over both workers
    pids = {json.loads(line)["pid"] for line in (out / "runs.jsonl").read_text().splitlines()}
    assert len(pids) == 2


def test_rerun_of_a_finished_study_is_a_no_op_and_another_config_is_refused(small_study, tmp_path,
                                                                            capsys):
    cfg, ref, _ = small_study
    out = tmp_path / "copy"
    shutil.copytree(ref, out)
    before = (out / "runs.jsonl").read_bytes()
    capsys.readouterr()
    assert main(["study", str(cfg), "--out", str(out), "--workers", "1"]) == 0
    captured = capsys.readouterr()
    assert "16 already stored" in captured.err and "(0 new)" in captured.out
    assert "dampfit study: 16 runs (4 scenarios × 4 replicates)" in captured.err
    assert (out / "runs.jsonl").read_bytes() == before
    pd.testing.assert_frame_equal(frame(out), frame(ref))
    # another configuration in the same folder is refused unless --force
    other = tmp_path / "other.toml"
    other.write_text(SMALL.replace("seed = 7", "seed = 8"))
    assert main(["study", str(other), "--out", str(out), "--quiet"]) == 2
    assert "different configuration" in one_error_line(capsys)
    assert (out / "runs.jsonl").read_bytes() == before


def _start(args, log):
    return subprocess.Popen([sys.executable, "-m", *args], stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """An external Dask scheduler and one worker (1 thread), started as ``dask scheduler`` and
    ``dask worker`` would be; yields the scheduler's address and the worker's pid."""
    d = tmp_path_factory.mktemp("dask")
    sched_file = d / "scheduler.json"
    log = (d / "dask.log").open("wb")  # open for the fixture's lifetime
    procs = [_start(["distributed.cli.dask_scheduler", "--scheduler-file", str(sched_file),
                     "--port", "0", "--no-dashboard"], log)]
    try:
        procs.append(_start(["distributed.cli.dask_worker", "--scheduler-file", str(sched_file),
                             "--nworkers", "1", "--nthreads", "1", "--no-dashboard"], log))
        deadline = time.monotonic() + 60
        while not sched_file.is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        yield json.loads(sched_file.read_text())["address"]
    finally:  # the worker (and its nanny's child) first, then the scheduler
        for p in reversed(procs):
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
        log.close()


@pytest.mark.heavy
def test_external_scheduler(small_study, dask_cluster, tmp_path):
    cfg, ref, _ = small_study
    out = tmp_path / "remote"
    assert main(["study", str(cfg), "--out", str(out), "--scheduler", dask_cluster, "--quiet"]) == 0
    # the same numbers as on the local cluster of 2 workers
    pd.testing.assert_frame_equal(frame(out), frame(ref))
    pids = {json.loads(line)["pid"] for line in (out / "runs.jsonl").read_text().splitlines()}
    assert len(pids) == 1 and os.getpid() not in pids  # all on the external worker


def test_unreachable_scheduler_is_an_input_error(small_study, tmp_path, capsys):
    cfg, _, _ = small_study
    assert main(["study", str(cfg), "--out", str(tmp_path / "x"), "--scheduler", "nonsense://",
                 "--quiet"]) == 2
    assert "cannot reach the Dask scheduler at nonsense://" in one_error_line(capsys)


@pytest.mark.heavy
def test_resume_after_sigkill_recomputes_nothing_finished(small_study, dask_cluster, tmp_path):
    """SIGKILL a running ``dampfit study`` process; the same command then runs only the rest,
    and the final table equals the uninterrupted run's. (Both runs use the external cluster
    to skip a second cluster start-up; the store does not depend on where runs execute.)"""
    cfg, ref, _ = small_study
    out = tmp_path / "killed"
    runs = out / "runs.jsonl"
    args = ["study", str(cfg), "--out", str(out), "--scheduler", dask_cluster, "--quiet"]
    proc = subprocess.Popen([*RUN_CMD, *args], start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if runs.is_file() and runs.read_bytes().count(b"\n") >= 2:
                break
            time.sleep(0.01)
        assert proc.poll() is None, proc.stderr.read().decode()
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    first = [json.loads(line) for line in runs.read_text().splitlines() if line.endswith("}")]
    assert 2 <= len(first) < N_SMALL
    assert not (out / "runs.csv").exists()

    assert main(args) == 0
    final = [json.loads(line) for line in runs.read_text().splitlines()]
    keys = [(r["scenario"], r["replicate"]) for r in final]
    assert len(keys) == len(set(keys)) == N_SMALL  # nothing computed twice
    by_key = {(r["scenario"], r["replicate"]): r for r in final}
    for r in first:  # finished runs were kept as they were
        assert by_key[(r["scenario"], r["replicate"])]["started"] == r["started"]
    pd.testing.assert_frame_equal(frame(out), frame(ref))


# -- hostile options and files (issue 19, item 10): exit 2, one line, nothing written -------

TINY = SMALL.replace("replicates = 4", "replicates = 1").replace(
    'estimators = ["log_decrement", "hilbert", "matrix_pencil"]', 'estimators = ["log_decrement"]'
).replace("jitter = [0, 0.02]", "")


@pytest.fixture
def tiny(tmp_path):
    cfg = tmp_path / "tiny.toml"
    cfg.write_text(TINY)
    return cfg


def _refused(capsys, argv, match, out: Path) -> None:
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    line = one_error_line(capsys)
    assert match in line, line
    assert not (out / "study.json").exists() and not (out / ".lock").exists()


@pytest.mark.parametrize("address,match", [
    ("ucx://127.0.0.1:9", "the ucx:// transport is not supported"),
    ("ws://127.0.0.1:9", "the ws:// transport is not supported"),
    ("tls://127.0.0.1:9", "tls:// needs Dask's TLS settings"),
])
def test_a_scheduler_scheme_dampfit_cannot_use_is_one_line(tiny, tmp_path, capsys, address, match):
    out = tmp_path / "s"
    _refused(capsys, ["study", tiny, "--out", out, "--scheduler", address, "--quiet"], match, out)
    assert not out.exists()


def test_a_silent_server_is_one_line_within_the_wait(tiny, tmp_path, capsys, monkeypatch):
    """A TCP port that accepts connections but never speaks (the kernel's backlog accepts
    them): refused once the scheduler has not answered within the wait, not a hang."""
    import socket

    from dampfit import cluster

    monkeypatch.setattr(cluster, "SCHEDULER_WAIT_S", 1.0)
    out = tmp_path / "s"
    with socket.create_server(("127.0.0.1", 0)) as srv:
        port = srv.getsockname()[1]
        _refused(capsys, ["study", tiny, "--out", out, "--scheduler", f"tcp://127.0.0.1:{port}",
                          "--quiet"], "no answer within 1 s", out)


def test_a_lock_file_that_is_a_fifo_is_one_line(tiny, tmp_path, capsys):
    out = tmp_path / "s"
    out.mkdir()
    os.mkfifo(out / ".lock")
    capsys.readouterr()
    assert main(["study", str(tiny), "--out", str(out), "--quiet"]) == 2
    line = one_error_line(capsys)
    assert "lock file" in line and "not a regular file" in line, line
    assert sorted(p.name for p in out.iterdir()) == [".lock"]


@pytest.mark.parametrize("line,why", [
    ("[1, 2, 3]", "not a JSON object"),
    ('{"scenario": ["s1"], "replicate": 0, "seed": 1, "rows": []}', "'scenario' must be a string"),
    ('{"scenario": "s1", "replicate": true, "rows": []}', "'replicate' must be"),
    ('{"scenario": "s1", "replicate": 0, "rows": {"a": 1}}', "'rows' must be a list"),
    ('{"scenario": "s1", "replicate": 0, "rows": [1, 2]}', "rows[0] must be an object"),
    ('{"scenario": "s1", "replicate": 0, "rows": [{"estimator": ["x"]}]}', "estimator must be"),
    ('{"scenario": "s1", "replicate": 0, "rows": [{"estimator": "x", "est_c": [1]}]}', "nested"),
])
def test_a_tampered_runs_jsonl_is_one_line_and_kept(tiny, tmp_path, capsys, line, why):
    cfg = sconfig.load(tiny, AVAILABLE)
    out = tmp_path / "s"
    store = Store(out)
    store.open(cfg, force=False, version="x")
    store.append({"scenario": "s1", "replicate": 0, "rows": []})
    store.close()
    with open(out / "runs.jsonl", "a") as fh:
        fh.write(line + "\n")
    before = (out / "runs.jsonl").read_bytes()
    capsys.readouterr()
    assert main(["study", str(tiny), "--out", str(out), "--quiet"]) == 2
    err = one_error_line(capsys)
    assert "runs.jsonl line 2 is not a run record dampfit wrote" in err and why in err, err
    assert (out / "runs.jsonl").read_bytes() == before and not (out / ".lock").exists()


def test_a_runs_jsonl_that_is_a_fifo_or_link_is_refused_before_anything(tiny, tmp_path, capsys):
    cfg = sconfig.load(tiny, AVAILABLE)
    for kind in ("fifo", "link"):
        out = tmp_path / kind
        store = Store(out)
        store.open(cfg, force=False, version="x")
        store.close()
        if kind == "fifo":
            os.mkfifo(out / "runs.jsonl")
        else:
            (tmp_path / "elsewhere.jsonl").write_text("")
            (out / "runs.jsonl").symlink_to(tmp_path / "elsewhere.jsonl")
        capsys.readouterr()
        assert main(["study", str(tiny), "--out", str(out), "--quiet"]) == 2
        assert "runs.jsonl is not a regular file" in one_error_line(capsys)


def test_local_workers_are_capped_at_the_runs_to_do(tiny, tmp_path, capsys, monkeypatch):
    """--workers 4 for a study of 2 runs starts 2 worker processes, not 4."""
    from dampfit import cluster as local

    started = []

    def cluster(n_workers, **kw):
        started.append(n_workers)
        raise InputError("stopped before starting workers")

    monkeypatch.setattr(local, "local_cluster", cluster)
    out = tmp_path / "s"
    capsys.readouterr()
    assert main(["study", str(tiny), "--out", str(out), "--workers", "4"]) == 2
    assert started == [2]
    assert "2 runs" in capsys.readouterr().err
