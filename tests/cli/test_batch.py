"""``dampfit batch`` and ``dampfit.analyze_many`` (issue 23): one row per recording, the same
analysis as ``dampfit analyze``, refused recordings as rows, resumable, locked, bad input
refused in one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests._support.hostile import (assert_one_line_error, decay, decay_csv, fails, run,
                                    run_subprocess, snapshot, assert_unchanged)
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401

pytestmark = pytest.mark.filterwarnings("ignore")


def _recording(path: Path, seed: int, n_sec: float = 10.0, fs: float = 100.0) -> Path:
    t, a = decay(n_sec, fs)
    a = a + 0.01 * np.random.default_rng(seed).standard_normal(t.size)
    return decay_csv(path, t, a)


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    """Three decays (one at another rate and length) and a corrupt file in one folder."""
    root = tmp_path_factory.mktemp("batch-data")
    _recording(root / "a.csv", 1)
    _recording(root / "b.csv", 2, n_sec=8.0, fs=80.0)
    _recording(root / "c.csv", 3)
    (root / "broken.csv").write_text("time,acc\n0,1\n")
    (root / "notes.md").write_text("not a recording\n")
    return root


@pytest.fixture(scope="module")
def done(data, tmp_path_factory) -> Path:
    """The batch of ``data`` (a folder argument), in this process, without figures."""
    from dampfit.cli import main

    out = tmp_path_factory.mktemp("batch-out") / "B"
    os.environ["DAMPFIT_JAX_CACHE"] = "off"
    try:
        assert main(["batch", str(data), "--out", str(out), "--workers", "1", "--quiet",
                     "--no-figures", "--mass", "0.5"]) == 0
    finally:
        os.environ.pop("DAMPFIT_JAX_CACHE", None)
    return out


def _table(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / "results.csv", keep_default_na=False)


@pytest.mark.heavy
def test_a_batch_has_one_row_per_recording_and_refused_ones_are_rows(done):
    table = _table(done)
    assert list(table["name"]) == ["a.csv", "b.csv", "broken.csv", "c.csv"]  # notes.md is no recording
    status = dict(zip(table["name"], table["status"]))
    assert status == {"a.csv": "ok", "b.csv": "ok", "broken.csv": "refused", "c.csv": "ok"}
    broken = table[table["name"] == "broken.csv"].iloc[0]
    assert "samples" in broken["message"] and broken["c_q50"] == ""
    ok = table[table["status"] == "ok"]
    f_n = np.hypot(2 * np.pi * 5.0, 0.3) / (2 * np.pi)  # [Hz] of decay(): p = 0.3 1/s, f_d = 5 Hz
    assert np.allclose(ok["f_n_q50"].astype(float), f_n, rtol=1e-4)
    assert np.allclose(ok["c_q50"].astype(float), 2 * 0.5 * 0.3, rtol=0.01)  # c = 2 m p
    assert (ok["c_q05"].astype(float) < ok["c_q50"].astype(float)).all()
    assert set(ok["converged"]) == {"True"} and all(len(h) == 64 for h in table["sha256"])
    assert set(ok["n_modes"]) == {"1"} and set(ok["modes_f_n_hz"]) == {""}  # one mode each
    md = (done / "summary.md").read_text()
    assert ("3 analysed (3 with a damper recommended, 0 inconclusive, 0 misfit), 1 refused, "
            "0 failed") in md and "broken.csv" in md
    import dampfit

    loaded = dampfit.load(done / "runs" / "a.csv")  # each run folder is a result folder
    assert loaded.summary()["parameters"]["c"]["q50"] == pytest.approx(
        float(ok.iloc[0]["c_q50"]), rel=1e-12)


@pytest.mark.heavy
def test_a_row_is_the_summary_dampfit_analyze_gives(done, data, tmp_path, capsys):
    """The analysis is the same: the row and run folder of b.csv equal `dampfit analyze`'s
    summary of that file with the same (default) seed, to the last digit."""
    code, _, err = run(["analyze", data / "b.csv", "--mass", "0.5", "--out", tmp_path / "b",
                        "--quiet", "--no-figures"], capsys)
    assert code == 0, err
    single = json.loads((tmp_path / "b" / "summary.json").read_text())
    batch = json.loads((done / "runs" / "b.csv" / "summary.json").read_text())
    assert batch["parameters"] == single["parameters"]
    assert batch["model_checks"] == single["model_checks"]
    row = _table(done).set_index("name").loc["b.csv"]
    assert float(row["zeta_q50"]) == single["parameters"]["zeta"]["q50"]


@pytest.mark.heavy
def test_the_same_command_resumes_without_redoing_finished_rows(done, data, capsys):
    before = (done / "rows.jsonl").read_text()
    code, _, err = run(["batch", data, "--out", done, "--workers", "1", "--no-figures",
                        "--mass", "0.5"], capsys)
    assert code == 0, err
    assert "4 already done" in err and "0 to analyse" in err
    assert (done / "rows.jsonl").read_text() == before  # nothing analysed again
    # other analysis options (another seed) are another batch: refused without --force
    fails(done.parent, capsys, ["batch", data, "--out", done, "--workers", "1", "--no-figures",
                                "--mass", "0.5", "--seed", "1"], "different configuration")


@pytest.mark.heavy
def test_a_second_batch_on_the_same_folder_stops_at_once(data, tmp_path, capsys):
    from dampfit.files.lock import FileLock

    out = tmp_path / "B"
    out.mkdir()
    lock = FileLock(out / ".lock", busy=lambda pid: "busy")
    lock.acquire()
    try:
        line = fails(tmp_path, capsys, ["batch", data / "a.csv", "--out", out, "--workers", "1"],
                     "another dampfit batch is running")
    finally:
        lock.release()
    assert str(out) in line


@pytest.mark.heavy
@pytest.mark.parametrize("case,match", [
    ("empty", "no recordings given"),
    ("missing", "does-not-exist.csv does not exist"),
    ("twice", "is given twice"),
    ("empty-folder", "holds no recordings"),
    ("unknown-in-masses", "is not a recording of this batch"),
    ("negative-mass", "mass must be positive"),
    ("nan-mass", "mass must be positive"),
    ("no-row", "has no row for"),
    ("masses-twice", "names"),
    ("bad-column", "unknown column"),
    ("empty-list", "no recordings given"),
])
def test_bad_batch_input_is_one_line_and_writes_nothing(data, tmp_path, capsys, case, match):
    a, b = data / "a.csv", data / "b.csv"
    masses = tmp_path / "masses.csv"
    (tmp_path / "empty").mkdir()
    lst = tmp_path / "list.txt"
    lst.write_text("# nothing here\n\n")
    table = {"unknown-in-masses": f"file,mass\n{a},0.5\nelsewhere.csv,0.5\n",
             "negative-mass": f"file,mass\n{a},-1\n",
             "nan-mass": f"file,mass\n{a},nan\n",
             "no-row": f"file,mass\n{a},0.5\n",
             "masses-twice": f"file,mass\n{a},0.5\na.csv,0.6\n",
             "bad-column": f"file,mass,colour\n{a},0.5,red\n"}
    if case in table:
        masses.write_text(table[case])
    paths = {"empty": [], "missing": [a, data / "does-not-exist.csv"], "twice": [a, str(a)],
             "empty-folder": [tmp_path / "empty"], "no-row": [a, b],
             "empty-list": []}.get(case, [a])
    extra = ["--masses", masses] if case in table else []
    extra += ["--list", lst] if case == "empty-list" else []
    fails(tmp_path, capsys, ["batch", *paths, *extra, "--out", tmp_path / "B", "--workers", "1"],
          match, exclude=("B",))
    assert not (tmp_path / "B").exists()


@pytest.mark.heavy
def test_masses_csv_gives_each_recording_its_mass_and_reading_options(data, tmp_path):
    from dampfit.batch.inputs import jobs

    masses = tmp_path / "masses.csv"
    masses.write_text(f"file,mass,mass_sd,time_column\n{data / 'a.csv'},0.5,0.01,Time (s)\n"
                      "b.csv,0.7,,\n")
    got = jobs([data / "a.csv", data / "b.csv", data / "c.csv"], masses=str(masses), mass=0.4)
    assert [(j.mass, j.mass_sd) for j in got] == [(0.5, 0.01), (0.7, 0.0), (0.4, 0.0)]
    assert got[0].read_options == {"time_column": "Time (s)"} and got[1].read_options == {}
    assert len({j.key({}) for j in got}) == 3
    # a row is identified by the bytes, the mass and the options: any change is a new analysis
    import dataclasses

    a = got[0]
    assert a.key({"seed": 0}) == dataclasses.replace(a, file="elsewhere").key({"seed": 0})
    assert a.key({"seed": 0}) != dataclasses.replace(a, mass=0.6).key({"seed": 0})
    assert a.key({"seed": 0}) != a.key({"seed": 1})
    assert a.key({"seed": 0}) != dataclasses.replace(a, sha256="0" * 64).key({"seed": 0})


@pytest.mark.heavy
def test_a_hostile_file_name_becomes_a_safe_folder_and_an_escaped_row(tmp_path, capsys):
    evil = tmp_path / "in" / "x\n| <script>alert(1)<\\script> $\\frac{1}{0}$ ..csv"
    evil.parent.mkdir()
    _recording(evil, 4, n_sec=8.0)
    code, _, err = run(["batch", evil.parent, "--out", tmp_path / "B", "--workers", "1",
                        "--quiet"], capsys)
    assert code == 0, err
    (run_dir,) = (tmp_path / "B" / "runs").iterdir()
    assert all(ch.isalnum() or ch in "._-" for ch in run_dir.name)
    table = _table(tmp_path / "B")
    assert table.loc[0, "file"] == str(evil) and table.loc[0, "status"] == "ok"
    md = (tmp_path / "B" / "summary.md").read_text()
    assert "<script>" not in md and "\nx\n" not in md
    assert (tmp_path / "B" / "comparison.png").stat().st_size > 1000


@pytest.mark.heavy
def test_summaries_only_writes_summary_json_alone(data, tmp_path, capsys):
    import dampfit

    code, _, err = run(["batch", data / "a.csv", "--out", tmp_path / "B", "--workers", "1",
                        "--summaries-only", "--quiet"], capsys)
    assert code == 0, err
    folder = tmp_path / "B" / "runs" / "a.csv"
    assert sorted(p.name for p in folder.iterdir()) == [".dampfit-result", "summary.json"]
    assert dampfit.load(folder).summary()["parameters"]["zeta"]["q50"] > 0


@pytest.mark.heavy
def test_analyze_many_returns_the_same_table_without_writing(done, data):
    import dampfit

    table = dampfit.analyze_many([data / "b.csv", data / "broken.csv"], mass=0.5, figures=False)
    assert list(table["status"]) == ["ok", "refused"]
    ref = _table(done).set_index("name")
    assert table.loc[0, "c_q50"] == float(ref.loc["b.csv", "c_q50"])
    assert table.loc[0, "folder"] is None


@pytest.mark.heavy
def test_a_killed_batch_keeps_its_rows_and_resumes(data, tmp_path):
    """SIGTERM while the batch runs: exit 143, every finished row kept (rows.jsonl and
    results.csv), and the same command analyses only what is left."""
    out = tmp_path / "B"
    files = [str(data / n) for n in ("a.csv", "b.csv", "c.csv")]
    env = {**os.environ, "MPLBACKEND": "Agg", "DAMPFIT_JAX_CACHE": "off"}
    proc = subprocess.Popen([sys.executable, "-m", "dampfit", "batch", *files, "--out", str(out),
                             "--workers", "1", "--no-figures", "--quiet"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rows = out / "rows.jsonl"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        if rows.exists() and rows.read_text().count("\n") >= 1:
            break
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "finished rows are kept" in err
    kept = [json.loads(line) for line in rows.read_text().splitlines()]
    assert 1 <= len(kept) < 3 and all(r["status"] == "ok" for r in kept)
    assert len(_table(out)) == len(kept)
    assert not [p for p in (out / "runs").iterdir() if p.name.startswith(".")]  # no staging left
    code, _, err = run_subprocess(["batch", *files, "--out", out, "--workers", "1",
                                   "--no-figures"], env={"DAMPFIT_JAX_CACHE": "off"}, timeout=300)
    assert code == 0, err
    assert f"{len(kept)} already done" in err
    again = [json.loads(line) for line in rows.read_text().splitlines()]
    assert again[:len(kept)] == kept and len(again) == 3  # the finished ones not redone
    assert list(_table(out)["status"]) == ["ok", "ok", "ok"]


@pytest.mark.slow  # a Dask cluster started and a batch run on it (≈ 45 s)
def test_a_dask_batch_gives_the_rows_of_an_in_process_one(done, data, tmp_path, capsys):
    """Two local Dask workers (isolated processes): the same numbers as in this process."""
    pytest.importorskip("distributed")
    code, _, err = run(["batch", data / "a.csv", data / "c.csv", "--out", tmp_path / "B",
                        "--workers", "2", "--no-figures", "--mass", "0.5", "--quiet"], capsys)
    assert code == 0, err
    got = _table(tmp_path / "B").set_index("name")
    ref = _table(done).set_index("name")
    for name in ("a.csv", "c.csv"):
        assert float(got.loc[name, "c_q50"]) == float(ref.loc[name, "c_q50"])
        assert float(got.loc[name, "zeta_q95"]) == float(ref.loc[name, "zeta_q95"])


@pytest.mark.heavy
def test_output_refusals_leave_other_folders_alone(data, tmp_path, capsys):
    """--out that holds other files is refused (dampfit never writes into a folder it did not
    make), and so is a file."""
    other = tmp_path / "mine"
    other.mkdir()
    (other / "thesis.tex").write_text("keep me")
    before = snapshot(tmp_path)
    code, _, err = run(["batch", data / "a.csv", "--out", other, "--workers", "1"], capsys)
    assert_one_line_error(code, err, 2, "holds no dampfit batch")
    assert_unchanged(before, snapshot(tmp_path))


def test_local_workers_run_xla_on_one_thread_each(monkeypatch):
    """Several local workers share the processors: each gets one XLA compute thread (unless
    the user set XLA_FLAGS), so their small kernels do not fight over the cores; and glibc's
    mmap threshold at 32 MiB and trim threshold at 1 MiB (Dask's 64 KiB trim threshold froze
    the mmap threshold at 128 KiB: every array mapped and unmapped at each use, ~0.5 s of
    page faults per analysis), unless the user set them."""
    pytest.importorskip("distributed")
    from dampfit import cluster

    monkeypatch.delenv("XLA_FLAGS", raising=False)
    for name in cluster.MALLOC_THRESHOLDS:
        monkeypatch.delenv(name, raising=False)
    assert "XLA_FLAGS" not in cluster.worker_env(1)
    env = lambda: {k: __import__("os").environ.get(k)  # noqa: E731 - read in the worker
                   for k in ("XLA_FLAGS", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")}
    with cluster.client(2, None) as c:
        seen = c.run(env)
    assert len(seen) == 2
    for got in seen.values():
        assert got["XLA_FLAGS"] == cluster.ONE_THREAD_XLA
        assert got["MALLOC_MMAP_THRESHOLD_"] == "33554432"  # 32 MiB
        assert got["MALLOC_TRIM_THRESHOLD_"] == "1048576"  # not Dask's 65536
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "1048576")  # the user's own: theirs
    monkeypatch.setenv("XLA_FLAGS", "--mine")
    assert cluster.worker_env(2) == {"MALLOC_TRIM_THRESHOLD_": "1048576"}
    with cluster.client(1, None) as c:
        seen = c.run(env)
    assert [got["MALLOC_MMAP_THRESHOLD_"] for got in seen.values()] == ["1048576"]


def test_a_row_names_the_modes_of_a_several_mode_summary():
    from dampfit.batch.task import row_of

    mode = lambda f: {"f_n": {"q50": f}}  # noqa: E731
    row = row_of({"n_modes": 2, "modes": [mode(3.3), mode(8.91)],
                  "parameters": {"c": {"q05": 1, "q50": 2, "q95": 3}}})
    assert (row["n_modes"], row["modes_f_n_hz"], row["c_q50"]) == (2, "3.3 8.91", 2.0)
    # an edited summary: wrong types give empty cells, never an error
    row = row_of({"n_modes": True, "modes": [mode("x"), 5, None]})
    assert row["n_modes"] is None and row["modes_f_n_hz"] is None


def test_recordings_of_one_name_get_folders_that_tell_them_apart(tmp_path):
    from dampfit.batch.inputs import jobs, labels

    for folder in ("run1", "run2", "deep/run1"):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "accelerometer_data.npy").write_bytes(folder.encode())
    (tmp_path / "solo.csv").write_text("t,a\n")
    files = [str(tmp_path / r / "accelerometer_data.npy") for r in ("run1", "run2", "deep/run1")]
    names = [j.name for j in jobs([*files, str(tmp_path / "solo.csv")])]
    assert names == [f"{tmp_path.name}_run1_accelerometer_data.npy",
                     "run2_accelerometer_data.npy", "deep_run1_accelerometer_data.npy",
                     "solo.csv"]
    # at most four path parts, and still unique when those are shared
    assert labels(["/a/b/c/d/e/f.csv", "/z/b/c/d/e/f.csv"]) == ["c/d/e/f.csv"] * 2
    assert [j.name for j in jobs([str(tmp_path / "solo.csv")])] == ["solo.csv"]


@pytest.mark.parametrize("mmap, noted", [(None, True), ("33554432", False)])
def test_workers_of_an_external_cluster_mapping_every_array_are_pointed_out(monkeypatch, mmap,
                                                                            noted):
    """Workers of the user's own cluster with Dask's trim threshold and glibc's mmap threshold
    left at 128 KiB make each analysis 1.2-1.5x slower: one note names the setting that avoids
    it (not a refusal)."""
    pytest.importorskip("distributed")
    import io

    from distributed import Client, LocalCluster

    from dampfit import cluster
    from dampfit._meta import __version__

    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")  # the in-process worker's, as Dask's
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    if mmap is not None:
        monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", mmap)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as lc, Client(lc) as c:
        err = io.StringIO()
        cluster.check_workers(c, lc.scheduler_address, __version__, err)
    lines = [x for x in err.getvalue().splitlines() if "MALLOC" in x]
    assert len(lines) == (1 if noted else 0)
    if noted:
        assert "MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=1048576" in lines[0]


# ------------------------------------------------------- outputs (issues 35, 36)
@pytest.mark.heavy
def test_per_recording_figures_only_on_request_and_report_draws_them_later(done, tmp_path,
                                                                          capsys):
    """By default a run folder has no figures; the batch's comparison.png is written all
    the same; `dampfit report DIR/runs/NAME` draws the figures from the saved files."""
    run_dir = done / "runs" / "a.csv"
    assert not list(run_dir.glob("*.png"))
    assert (done / "comparison.png").stat().st_size > 1000  # written despite --no-figures
    code, out, err = run(["report", run_dir], capsys)
    assert code == 0, err
    assert "redrew" in out and (run_dir / "fit.png").stat().st_size > 1000
    assert (run_dir / "report.html").is_file()


def _summary(verdict, damper=None, reasons=("the decay rate stays within its interval",)):
    s = {"parameters": {"c": {"q05": 0.2, "q50": 0.3, "q95": 0.4}},
         "model_checks": {"verdict": verdict, "verdict_reasons": list(reasons)}}
    if damper is not None:
        s["damper"] = damper
    return s


@pytest.mark.parametrize("verdict,damper,status", [
    ("adequate", None, "ok"), ("amplitude-dependent", None, "ok"),
    ("inconclusive", None, "inconclusive"), ("misfit", None, "misfit"), (None, None, "inconclusive"),
    ("adequate", {"status": "recommended", "reason": "viscous: ζ(A) flat"}, "ok"),
    ("inconclusive", {"status": "viscous-stands", "reason": "too short to tell",
                      "not_ruled_out": "a Coulomb share below 20 %"}, "inconclusive"),
    ("misfit", {"status": "none", "reason": "no law fits the residuals",
                "try": "a longer window"}, "misfit"),
    (None, {"status": "none", "reason": "no verdict could be made"}, "inconclusive"),
])
def test_a_rows_status_is_its_verdict_with_the_verdicts_reason(verdict, damper, status):
    from dampfit.batch.task import status_of

    reasons = () if verdict is None else ("the decay rate stays within its interval",)
    got, reason = status_of(_summary(verdict, damper, reasons))
    assert got == status
    if damper is not None:
        assert damper["reason"] in reason
        assert all(damper[k] in reason for k in ("not_ruled_out", "try") if k in damper)
    elif verdict is not None:
        assert reason == "the decay rate stays within its interval"
    else:
        assert reason == "no damping verdict could be made"


def test_damper_columns_from_the_contract_and_empty_without_it():
    from dampfit.batch.table import COLUMNS, frame
    from dampfit.batch.task import DAMPER_COLUMNS, row_of

    damper = {"status": "recommended", "law": "coulomb",
              "coefficients": {"c": {"q05": 0.1, "q50": 0.2, "q95": 0.3, "unit": "N s/m"},
                               "F_c": {"q05": 0.01, "q50": 0.02, "q95": 0.03, "unit": "N"}},
              "design_amplitude": {"displacement_m": 0.004, "velocity_m_s": 0.1,
                                   "source": "--amplitude"},
              "c_linear": {"unit": "N s/m", "q05": 0.5, "q50": 0.6, "q95": 0.7},
              "decay_check": {"checked": True, "follows": False, "rms": 0.04, "scatter": 0.001}}
    row = row_of(_summary("amplitude-dependent", damper))
    assert row["law_follows_decay"] is False
    edited = row_of(_summary("amplitude-dependent", {**damper, "decay_check": {
        "checked": True, "follows": "no"}}))
    assert edited["law_follows_decay"] is None
    assert row["damper_law"] == "coulomb" and row["damper_F_c_q50"] == 0.02
    assert row["damper_c_q95"] == 0.3 and row["damper_c2_q50"] is None
    assert row["design_amplitude_m"] == 0.004 and row["c_linear_q05"] == 0.5
    old = row_of(_summary("adequate"))
    assert all(old[c] is None for c in DAMPER_COLUMNS)
    assert set(DAMPER_COLUMNS) <= set(COLUMNS)
    assert list(frame([row]).columns) == list(COLUMNS)


def test_comparison_figure_uses_a_log_axis_where_values_span_decades(tmp_path):
    from dampfit.batch.table import comparison_figure, frame, log_scale

    assert log_scale([0.01, 0.5], [0.02, 2.0]) and not log_scale([1.0, 2.0], [1.5, 3.0])
    assert not log_scale([-1.0, 5.0], [1.0, 60.0])  # not all positive: linear
    rows = [{"name": f"r{i}", "status": st, "verdict": v, "c_q05": lo, "c_q50": mid,
             "c_q95": hi} for i, (st, v, lo, mid, hi) in enumerate(
                 [("ok", "adequate", 0.01, 0.012, 0.015), ("misfit", "misfit", 1.0, 2.0, 3.0),
                  ("inconclusive", "inconclusive", 0.1, 0.2, 0.3), ("refused", None, None, None, None)])]
    assert comparison_figure(frame(rows), tmp_path / "c.png").stat().st_size > 1000
