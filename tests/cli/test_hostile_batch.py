"""Hostile batches (``dampfit batch``, ``dampfit.analyze_many``) and swapped result files:
file names that a spreadsheet would run as formulas, identical bytes under two names, a
tampered rows.jsonl, symbolic link loops, options the command line refuses given from Python,
an empty ``--scheduler``, and a posterior.nc or signals.npz swapped in from another analysis.
Each is exit 2 with one line (or the correct behaviour), nothing outside ``--out`` written."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit.errors import InputError
from tests._support.hostile import assert_one_line_error, run, snapshot, assert_unchanged
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401

pytestmark = pytest.mark.filterwarnings("ignore")

FORMULAS = ["=HYPERLINK(\"http:x\",\"y\").csv", "+cmd|' calc'!A0.csv", "@SUM(1).csv",
            "-2+3.csv"]


def _broken(folder: Path, names) -> Path:
    """Recordings the analysis refuses at once (one sample): rows with text, no numbers."""
    folder.mkdir(exist_ok=True)
    for name in names:
        (folder / name).write_text("time,acc\n0,1\n")
    return folder


def _cells(path: Path) -> list[list[str]]:
    return list(csv.reader(io.StringIO(path.read_text())))


# ------------------------------------------------------------------ CSV injection
def test_no_results_csv_cell_can_run_as_a_formula(tmp_path, capsys, monkeypatch):
    data = _broken(tmp_path / "in", FORMULAS)
    (data / "list.txt").write_text("\n".join(FORMULAS) + "\n")
    monkeypatch.chdir(data)  # the names as given: the file cells start with = + - @ tab
    code, _, err = run(["batch", "--list", "list.txt", "--out", tmp_path / "B", "--workers",
                        "1", "--quiet"], capsys)
    assert code == 0, err
    rows = _cells(tmp_path / "B" / "results.csv")
    cells = [c for row in rows[1:] for c in row]
    assert not [c for c in cells if c[:1] in ("=", "+", "-", "@", "\t", "\r")], cells
    assert [row[0] for row in rows[1:]] == ["'" + n for n in FORMULAS]
    assert all(row[3] == "refused" for row in rows[1:])


def test_text_cells_neutralised_numbers_stay_numbers():
    from dampfit.batch.table import frame, spreadsheet_safe

    df = frame([{"file": "=1+1", "name": "a", "status": "ok", "message": "@SUM(1)",
                 "c_q50": -1.5, "converged": True, "n_modes": 1},
                {"file": "\rx", "name": "b", "status": "refused", "message": "-bad"}])
    safe = spreadsheet_safe(df)
    assert list(safe["file"]) == ["'=1+1", "'\rx"] and list(safe["message"]) == ["'@SUM(1)", "'-bad"]
    assert safe.loc[0, "c_q50"] == -1.5 and safe["c_q50"].dtype == float
    assert list(df["file"]) == ["=1+1", "\rx"]  # the table returned is unchanged


# ------------------------------------------------------------ identical bytes, rows.jsonl
def test_identical_bytes_under_two_names_give_two_rows(tmp_path, capsys):
    data = _broken(tmp_path / "in", ["one.csv", "two.csv"])
    code, _, err = run(["batch", data, "--out", tmp_path / "B", "--workers", "1", "--quiet"],
                       capsys)
    assert code == 0, err
    rows = _cells(tmp_path / "B" / "results.csv")[1:]
    assert sorted(Path(r[0]).name for r in rows) == ["one.csv", "two.csv"]
    assert rows[0][2] == rows[1][2]  # the same SHA-256, two rows
    lines = (tmp_path / "B" / "rows.jsonl").read_text().splitlines()
    assert len({json.loads(x)["key"] for x in lines}) == 2


@pytest.mark.parametrize("field,value,match", [
    ("folder", "../../../../etc", "'folder' must be runs/"),
    ("name", "../x", "'name' holds"),
    ("c_q50", "=1+1", "'c_q50' holds"),
    ("sha256", "zz", "'sha256' holds"),
    ("evil", 1, "unknown column"),
])
def test_a_tampered_row_is_refused_before_anything_is_written(tmp_path, capsys, field, value,
                                                              match):
    data = _broken(tmp_path / "in", ["one.csv"])
    argv = ["batch", data, "--out", tmp_path / "B", "--workers", "1", "--quiet"]
    assert run(argv, capsys)[0] == 0
    log = tmp_path / "B" / "rows.jsonl"
    row = json.loads(log.read_text())
    row[field] = value
    log.write_text(json.dumps(row) + "\n")
    before = snapshot(tmp_path)
    code, _, err = run(argv, capsys)
    assert_one_line_error(code, err, match=match)
    assert "is not a run record dampfit wrote" in err
    assert_unchanged(before, snapshot(tmp_path))


# ------------------------------------------------------------------ symbolic link loops
@pytest.mark.parametrize("make", ["self", "pair"])
def test_a_symbolic_link_loop_is_refused(tmp_path, capsys, make):
    data = _broken(tmp_path / "in", ["one.csv"])
    if make == "self":
        os.symlink("loop.csv", data / "loop.csv")
    else:
        os.symlink("b.csv", data / "a.csv")
        os.symlink("a.csv", data / "b.csv")
    for target in (data, data / ("loop.csv" if make == "self" else "a.csv")):
        before = snapshot(tmp_path)
        code, _, err = run(["batch", target, "--out", tmp_path / "B", "--workers", "1"], capsys)
        assert_one_line_error(code, err, match="is a symbolic link loop")
        assert_unchanged(before, snapshot(tmp_path))


# ---------------------------------------------------------- options checked as the CLI does
@pytest.mark.parametrize("kw,flag", [
    ({"max_steps": 0}, ["--max-steps", "0"]), ({"seed": -1}, ["--seed", "-1"]),
    ({"seed": 1.5}, None), ({"max_modes": 9}, ["--max-modes", "9"]),
    ({"window": (5.0, 1.0)}, ["--window", "5", "1"]), ({"band": (0.0, 3.0)}, ["--band", "0", "3"]),
    ({"amplitude": float("nan")}, ["--amplitude", "nan"]), ({"model": "linear"}, None),
    ({"mode_of_mass": 5, "max_modes": 2}, ["--mode-of-mass", "5", "--max-modes", "2"]),
])
def test_analyze_many_refuses_what_the_cli_refuses(tmp_path, capsys, kw, flag):
    data = _broken(tmp_path / "in", ["one.csv"])
    with pytest.raises(InputError) as exc:
        dampfit.analyze_many(data, **kw)
    assert str(exc.value).startswith("argument --")
    if flag is not None:
        code, _, err = run(["batch", data, "--out", tmp_path / "B", "--workers", "1", *flag],
                           capsys)
        line = assert_one_line_error(code, err)
        assert line.startswith(f"dampfit: error: {exc.value}"), (line, str(exc.value))
    assert not (tmp_path / "B").exists()


@pytest.mark.parametrize("read_options,match", [
    ({"bogus": 1}, "unknown option 'bogus'"), ({"row": -1}, "row must be an integer"),
    ("time_column", "must be a dict"),
])
def test_analyze_many_refuses_unknown_reading_options(tmp_path, read_options, match):
    data = _broken(tmp_path / "in", ["one.csv"])
    with pytest.raises(InputError, match=match):
        dampfit.analyze_many(data, read_options=read_options)


def test_an_empty_scheduler_is_refused_and_batch_refusals_name_no_other_command(tmp_path,
                                                                                capsys):
    data = _broken(tmp_path / "in", ["one.csv"])
    code, _, err = run(["batch", data, "--out", tmp_path / "B", "--scheduler", ""], capsys)
    assert_one_line_error(code, err, match="argument --scheduler: must be a Dask scheduler")
    code, _, err = run(["batch", data, "--out", tmp_path / "B", "--scheduler", "ucx://h:1", "--quiet"],
                       capsys)
    assert "dampfit study" not in assert_one_line_error(code, err)
    assert not (tmp_path / "B").exists()


# -------------------------------------------------- files swapped in from another analysis
@pytest.fixture(scope="module")
def two_folders(tmp_path_factory):
    from dampfit import simulate as sim

    root = tmp_path_factory.mktemp("swap")
    rec, truth = sim.recording(sim.preset("paper", duration=12.0, seed=3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(rec, mass=truth["mass"], seed=1, max_steps=400, max_modes=1)
    an.save(root / "A", figures=False)
    an.save(root / "B", figures=False)
    return root / "A", root / "B"


@pytest.mark.heavy
@pytest.mark.parametrize("name", ["posterior.nc", "signals.npz"])
def test_report_refuses_a_file_of_another_analysis(two_folders, tmp_path, capsys, name):
    a, b = two_folders
    target = tmp_path / "B"
    shutil.copytree(b, target)
    summary = json.loads((target / "summary.json").read_text())
    assert summary["files"][name]["bytes"] == (target / name).stat().st_size
    # a valid file of another analysis: the same arrays, one changed in its 9th digit
    if name == "signals.npz":
        with np.load(a / name) as z:
            arrays = {k: z[k] for k in z.files}
        arrays["accel"] = arrays["accel"] * (1 + 1e-9)
        np.savez(target / name, **arrays)
    else:
        import arviz as az

        with az.rc_context({"data.load": "eager"}):
            idata = az.from_netcdf(a / name)
        idata.posterior["c"] = idata.posterior["c"] * (1 + 1e-9)
        idata.to_netcdf(str(target / name))
    code, _, err = run(["report", target], capsys)
    assert_one_line_error(code, err, match=f"{name} does not belong to")
    with pytest.raises(InputError, match="does not belong"):
        loaded = dampfit.load(target)
        loaded.posterior if name == "posterior.nc" else loaded.signals()
    # the folder as written is read as before
    code, _, err = run(["report", b], capsys)
    assert code == 0, err
