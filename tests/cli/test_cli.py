"""The command line through ``main([...])``: outputs, overwrite safety, exit codes, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dampfit import cli
from dampfit import simulate as sim
from dampfit.cli import main
from tests._support.hostile import one_error_line


@pytest.fixture(scope="module")
def csv_file(tmp_path_factory):
    """A short simulated phyphox CSV of the paper's set-up and its truth."""
    d = tmp_path_factory.mktemp("rec")
    rec, truth = sim.recording(sim.preset("paper", duration=20.0, seed=5))
    path = d / "Raw Data.csv"
    sim.write_phyphox_csv(rec, path)
    return path, truth


def test_analyze_writes_outputs_and_prints_table(csv_file, tmp_path, capsys):
    path, truth = csv_file
    out = tmp_path / "result"
    assert main(["analyze", str(path), "--mass", "5.3", "--mass-sd", "0.02", "--out", str(out),
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "c      [N s/m]" in text and "log decrement" in text and "converged       yes" in text
    # a viscous simulation: the damping-law check runs and finds no amplitude dependence
    assert "damping law" in text and "no amplitude dependence" in text
    names = {p.name for p in out.iterdir()}
    assert {"summary.json", "posterior.nc", "signal.png", "spectrum.png", "fit.png",
            "posterior.png", "trace.png"} <= names
    s = json.loads((out / "summary.json").read_text())
    assert s["input"]["format"] == "phyphox-csv"
    assert s["mass"] == {"value": 5.3, "sd": 0.02, "unit": "kg"}
    c = s["parameters"]["c"]
    assert c["q05"] - 2 * c["sd"] <= truth["c"] <= c["q95"] + 2 * c["sd"]

    # refuses to overwrite without --force, and leaves the old result alone
    before = (out / "summary.json").read_bytes()
    assert main(["analyze", str(path), "--mass", "5.3", "--out", str(out), "--quiet"]) == 2
    assert "exists; use --force" in one_error_line(capsys)
    assert (out / "summary.json").read_bytes() == before

    # --force replaces it completely
    assert main(["analyze", str(path), "--mass", "5.0", "--out", str(out), "--quiet",
                 "--no-figures", "--force"]) == 0
    s2 = json.loads((out / "summary.json").read_text())
    assert s2["mass"]["value"] == 5.0
    assert not (out / "fit.png").exists()
    assert not list(tmp_path.glob(".result*")), "staging directories left behind"


def test_analyze_without_mass_says_why(csv_file, tmp_path, capsys):
    path, _ = csv_file
    out = tmp_path / "nomass"
    assert main(["analyze", str(path), "--out", str(out), "--quiet", "--no-figures", "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["parameters"]["c"] is None and "mass" in s["missing"]["c"]
    assert s["parameters"]["zeta"]["q50"] > 0


def test_non_converged_result_exits_zero_but_warns_loudly(csv_file, tmp_path, capsys):
    path, _ = csv_file
    code = main(["analyze", str(path), "--mass", "5.3", "--out", str(tmp_path / "nc"),
                 "--quiet", "--no-figures", "--max-steps", "40"])
    assert code == 0
    err = capsys.readouterr().err
    assert "did NOT converge" in err


def test_simulate_writes_csv_and_truth_and_refuses_overwrite(tmp_path, capsys):
    out = tmp_path / "sim.csv"
    assert main(["simulate", "--preset", "phone", "--f-n", "2.5", "--zeta", "0.02",
                 "--dialect", "semicolon", "--out", str(out)]) == 0
    truth = json.loads((tmp_path / "sim.truth.json").read_text())
    assert truth["f_n"] == pytest.approx(2.5) and truth["zeta"] == pytest.approx(0.02)
    assert out.read_text().splitlines()[0].startswith('"Time (s)";')
    capsys.readouterr()
    assert main(["simulate", "--out", str(out)]) == 2
    assert "exists" in one_error_line(capsys)


def test_demo_recovers_c_inside_its_interval(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet", "--no-figures"]) == 0
    text = capsys.readouterr().out
    assert "is inside the 90 % interval" in text
    # the last line is the next step: the same analysis of the user's own recording
    assert text.rstrip().splitlines()[-1].strip() == (
        "next: dampfit analyze YOUR.csv --mass KG --report   (README: \"Your own recording\")")
    assert (out / "paper-preset.csv").exists() and (out / "summary.json").exists()
    s = json.loads((out / "summary.json").read_text())
    assert s["input"]["path"] == str((out / "paper-preset.csv").resolve())


# ------------------------------------------------------------------------ bad input
def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


HEADER = '"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)","Linear Acceleration z (m/s^2)"\n'


def rows(t, a):
    return "".join(f"{ti:.6E},{ai:.6E},0.0,0.0\n" for ti, ai in zip(t, a))


def _bad_files(tmp_path):
    t = np.arange(2000) / 100.0
    a = np.sin(2 * np.pi * 2 * t) * np.exp(-0.1 * t)
    # a NaN inside the data (issue 19: one in the first or last row is an empty edge row,
    # dropped with a note, so the refused case sits in the middle)
    lines = rows(t, a).splitlines(keepends=True)
    nan = "".join(lines[:1000]) + lines[1000].replace("0.0,0.0\n", "NaN,0.0\n") + "".join(lines[1001:])
    back = t.copy()
    back[500] = back[100]
    dup = t.copy()
    dup[501] = dup[500]
    rng = np.random.default_rng(0)
    return {
        "empty": write(tmp_path, "empty.csv", ""),
        "header only": write(tmp_path, "header.csv", HEADER),
        "NaN": write(tmp_path, "nan.csv", HEADER + nan),
        "non-monotonic": write(tmp_path, "back.csv", HEADER + rows(back, a)),
        "duplicated time": write(tmp_path, "dup.csv", HEADER + rows(dup, a)),
        "text junk": write(tmp_path, "junk.csv", "hello world\nthis is not a recording\n"),
        "unknown columns": write(tmp_path, "cols.csv", "foo,bar,baz\n" + "1,2,3\n" * 50),
        "no oscillation": write(tmp_path, "noise.csv", HEADER + rows(t, 0.01 * rng.standard_normal(t.size))),
        "too short": write(tmp_path, "short.csv", HEADER + rows(t[:8], a[:8])),
        "missing": tmp_path / "does-not-exist.csv",
    }


# "non-monotonic" and "duplicated time" are analysed since issue 35 (the longest run or
# segment, named in a note): tests/cli/test_daq_formats.py, tests/analytic/test_io.py
@pytest.mark.parametrize("case", ["empty", "header only", "NaN", "text junk", "unknown columns",
                                  "no oscillation", "too short", "missing"])
def test_malformed_input_gives_exit_2_and_one_line(tmp_path, capsys, case):
    path = _bad_files(tmp_path)[case]
    out = tmp_path / "out"
    code = main(["analyze", str(path), "--mass", "1.0", "--out", str(out), "--quiet"])
    assert code == 2
    one_error_line(capsys)
    assert not out.exists()
    assert not list(tmp_path.glob(".out*"))


@pytest.mark.parametrize("argv,match", [
    ([], "no command"),
    (["analyze"], "required"),
    (["frobnicate"], "invalid choice"),
    (["analyze", "x.csv", "--mass", "heavy"], "not a number"),
    (["analyze", "x.csv", "--window", "1"], "expected 2"),
    (["simulate"], "required"),
    (["simulate", "--preset", "nope", "--out", "x.csv"], "preset"),
])
def test_usage_errors(tmp_path, monkeypatch, capsys, argv, match):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert match in one_error_line(capsys)


@pytest.mark.parametrize("extra,match", [
    (["--mass", "-2"], "positive"),
    (["--mass", "1", "--mass-sd", "-0.1"], "standard deviation"),
    (["--mass-sd", "0.1"], "without --mass"),
    (["--mass", "1", "--axis", "q"], "axis 'q'"),
    (["--mass", "1", "--band", "3", "1"], "pass band"),
    (["--mass", "1", "--window", "9", "2"], "after its start"),
    (["--mass", "1", "--amplitude", "-0.01"], "positive displacement amplitude"),
    (["--mass", "1", "--model", "linear"], "invalid choice: 'linear'"),
])
def test_bad_options_exit_2(csv_file, tmp_path, capsys, extra, match):
    path, _ = csv_file
    out = tmp_path / "o"
    assert main(["analyze", str(path), "--out", str(out), "--quiet", *extra]) == 2
    assert match in one_error_line(capsys)
    assert not out.exists()


def test_output_parent_must_exist(csv_file, tmp_path, capsys):
    path, _ = csv_file
    assert main(["analyze", str(path), "--mass", "1", "--out", str(tmp_path / "a" / "b"),
                 "--quiet"]) == 2
    assert "does not exist" in one_error_line(capsys)


def test_internal_error_exits_1_without_traceback(csv_file, tmp_path, capsys, monkeypatch):
    path, _ = csv_file

    def boom(*a, **k):
        raise RuntimeError("kaput")

    monkeypatch.setattr("dampfit.pipeline.analyze", boom)
    out = tmp_path / "o"
    assert main(["analyze", str(path), "--mass", "1", "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "internal error: RuntimeError: kaput" in err and "Traceback" not in err
    assert not out.exists()


def test_parser_is_documented():
    text = cli.get_parser().format_help()
    assert "analyze" in text and "simulate" in text and "demo" in text


def test_compile_cache_is_private_optional_and_used(tmp_path, monkeypatch):
    """CLI runs keep compiled kernels in a private folder (a second run loads instead of
    compiling); DAMPFIT_JAX_CACHE=off and a user's own JAX_COMPILATION_CACHE_DIR win."""
    import stat
    import subprocess
    import sys

    from dampfit import cli

    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", "off")
    assert cli._compile_cache() is None
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "users"))
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", str(tmp_path / "ours"))
    assert cli._compile_cache() is None and not (tmp_path / "ours").exists()
    # a fresh process, as the CLI runs: the cache folder is created private and filled
    code = ("import os; os.environ.pop('JAX_COMPILATION_CACHE_DIR', None); "
            f"os.environ['DAMPFIT_JAX_CACHE'] = {str(tmp_path / 'fresh')!r}; "
            "from dampfit import cli; cli._compile_cache(); "
            "import jax.numpy as jnp; from dampfit.inference.executables import Kernel; "
            "Kernel(lambda x: jnp.sin(x) * 2)(jnp.ones(3))")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    folder = tmp_path / "fresh"
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert any(folder.iterdir())


# -- provenance that reproduces (issue 19) ----------------------------------------------------
def _strip_volatile(s: dict) -> dict:
    """A summary without what differs between two runs of one command: the date, wall times
    [s] wherever they are recorded, and the digests of the files (posterior.nc records the time
    it was written)."""
    s = json.loads(json.dumps(s))
    s["provenance"].pop("date", None)
    s.pop("files", None)

    def walk(x):
        if isinstance(x, dict):
            return {k: walk(v) for k, v in x.items() if "seconds" not in k and k != "wall_time"}
        if isinstance(x, list):
            return [walk(v) for v in x]
        return x
    return walk(s)


@pytest.mark.heavy
def test_the_printed_recreate_command_reproduces_the_summary(tmp_path, capsys):
    """Every reading option is in provenance.options and in the report's "re-create this
    folder" command, shell-quoted (a path with a space, column names with spaces, brackets,
    '²' and '#'); running that command gives the same summary with the same seed."""
    import re
    import shlex

    t = np.arange(0.0, 12.0, 0.01)
    runs = [1.0 * np.exp(-0.25 * t) * np.cos(2 * np.pi * 2.5 * t),
            3.0 * np.exp(-0.15 * t) * np.cos(2 * np.pi * 2.5 * t)]
    runs[1] += np.random.default_rng(4).normal(0.0, 0.003, t.size)
    header = ",".join(f'"{n} Run #{k}"' for k in (1, 2) for n in ("Time (s)", "Acceleration (m/s²)"))
    rows = [",".join(f"{t[i]:.3f},{r[i]:.5f}" if i < n else "," for r, n in zip(runs, (700, t.size)))
            for i in range(t.size)]
    folder = tmp_path / "lab data"
    folder.mkdir()
    path = write(folder, "cart run.csv", header + "\n" + "\n".join(rows) + "\n")
    out = tmp_path / "result"
    argv = ["analyze", str(path), "--run", "Run #2", "--time-column", "Time (s)",
            "--accel-columns", "Acceleration (m/s²)", "--time-unit", "s", "--accel-unit", "m/s2",
            "--window", "0.5", "11.0", "--mass", "0.25", "--seed", "3", "--max-steps", "3000",
            "--model", "viscous", "--out", str(out), "--no-figures", "--quiet", "--report"]
    assert main(argv) == 0, capsys.readouterr().err
    first = json.loads((out / "summary.json").read_text())
    opts = first["provenance"]["options"]
    assert {k: opts[k] for k in ("run", "time_column", "accel_columns", "time_unit", "accel_unit",
                                 "sheet", "variable", "row")} == {
        "run": "Run #2", "time_column": "Time (s)", "accel_columns": ["Acceleration (m/s²)"],
        "time_unit": "s", "accel_unit": "m/s2", "sheet": None, "variable": None, "row": None}
    md = (out / "report.md").read_text(encoding="utf-8")
    command = re.search(r"```bash\n(dampfit analyze .*?)\n```", md).group(1)
    words = shlex.split(command)
    assert words[:3] == ["dampfit", "analyze", str(path)]
    for flag, value in (("--run", "Run #2"), ("--time-column", "Time (s)"),
                        ("--accel-columns", "Acceleration (m/s²)"), ("--time-unit", "s"),
                        ("--accel-unit", "m/s2"), ("--seed", "3"), ("--max-steps", "3000"),
                        ("--model", "viscous")):
        assert words[words.index(flag) + 1] == value, (flag, command)
    capsys.readouterr()
    assert main(words[1:] + ["--force", "--no-figures", "--quiet"]) == 0, capsys.readouterr().err
    again = json.loads((out / "summary.json").read_text())
    assert _strip_volatile(again) == _strip_volatile(first)
    assert again["input"]["n_samples"] == t.size and again["input"]["format"] == "capstone-csv"


def test_mat_and_sheet_options_reach_the_recreate_command(tmp_path, capsys):
    """--variable, --row and --sheet are recorded and come back in the command (parsed here,
    not run: the run above covers that the command reproduces)."""
    import shlex

    from dampfit.output import report

    s = {"input": {"path": "/data/-lab.mat"}, "mass": {"value": 0.5, "sd": None},
         "provenance": {"seed": 1, "options": {
             "variable": "Fe.Out.Acc", "row": 2, "sheet": "Linear Acceleration",
             "time_column": "-t", "accel_columns": ["a 1", "a'2"], "time_unit": "ms",
             "accel_unit": "g", "run": "Latest"}}}
    args = cli.get_parser().parse_args(shlex.split(report.reproduce_command(s, tmp_path))[1:])
    assert (args.variable, args.row, args.sheet, args.time_column) == (
        "Fe.Out.Acc", 2, "Linear Acceleration", "-t")
    assert (args.accel_columns, args.time_unit, args.accel_unit, args.run) == (
        ["a 1", "a'2"], "ms", "g", "Latest")
    # values of the wrong type (an edited summary) are left out, never passed to the shell
    s["provenance"]["options"].update({"row": "2; rm -rf ~", "accel_columns": [{"x": 1}]})
    cmd = report.reproduce_command(s, tmp_path)
    assert "--row" not in cmd and "--accel-columns" not in cmd and "rm -rf" not in cmd
    # a campaign's command carries them too
    c = {"tests": [{"input": {"path": "/d/a.csv"}}, {"input": {"path": "/d/b c.csv"}}],
         "design": {"mass": {"value": 0.5}},
         "provenance": {"seed": 2, "options": {"run": "Run #1", "time_unit": "ms"}}}
    args = cli.get_parser().parse_args(
        shlex.split(report.campaign_reproduce_command(c, tmp_path))[1:])
    assert (args.file, args.more_files, args.run, args.time_unit) == (
        "/d/a.csv", ["/d/b c.csv"], "Run #1", "ms")
    c["provenance"]["options"]["max_modes"] = 3  # a campaign listing each test's modes
    args = cli.get_parser().parse_args(
        shlex.split(report.campaign_reproduce_command(c, tmp_path))[1:])
    assert args.max_modes == 3 and args.mode_of_mass is None
