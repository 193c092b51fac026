"""FEM verification (``dampfit verify``): OpenSees against the closed form, the integrator's
period error, the start from the fitted model, and the comparison on simulated results."""

from __future__ import annotations

import hashlib
import json
import math
import os
import shlex
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.fem import units
from dampfit.fem.export import export
from dampfit.fem import opensees, response, sdof, timestep, verify
from dampfit.physics import to_decay
from dampfit.simulate import free_decay
from tests._support.fem import C, K, M, SPAN, U0, write_result

# -- the engine and the integrator -----------------------------------------------------------


@pytest.mark.usefixtures("requires_opensees")
def test_opensees_free_decay_matches_the_closed_form():
    """Known (m, k, c, u0), Δt = T/2000 over 5 periods: OpenSees within 1e-4 (relative)."""
    period = 2 * math.pi / math.sqrt(K / M)
    dt = period / 2000
    res = opensees.free_decay(M, K, C, U0, 0.0, dt, 5 * 2000)
    u, v, a = free_decay(res["t"], M, C, K, U0)
    assert np.max(np.abs(res["u"] - u)) / U0 < 1e-4
    assert np.max(np.abs(res["v"] - v)) / np.max(np.abs(v)) < 1e-4
    assert np.max(np.abs(res["a"] - a)) / np.max(np.abs(a)) < 1e-4
    # with a constant force (gravity) the decay is about the static equilibrium −m·g/k
    g = opensees.free_decay(M, K, C, -M * 9.81 / K + U0, 0.0, dt, 2000, force=-M * 9.81)
    assert np.max(np.abs(g["u"] + M * 9.81 / K - u[:2001])) / U0 < 1e-4


@pytest.mark.usefixtures("requires_opensees")
def test_newmark_period_error_formula_is_what_opensees_does():
    """Coarse step T/16, undamped: the measured period elongation equals (ωΔt/2)/atan(ωΔt/2) − 1."""
    wn = math.sqrt(K / M)
    period = 2 * math.pi / wn
    dt = period / 16
    res = opensees.free_decay(M, K, 0.0, U0, 0.0, dt, 16 * 60)
    u, t = res["u"], res["t"]
    up = np.flatnonzero((u[:-1] < 0) & (u[1:] >= 0))
    crossings = t[up] - u[up] * dt / (u[up + 1] - u[up])
    measured = np.mean(np.diff(crossings)) / period - 1
    predicted = timestep.newmark_period_error(wn, dt)
    assert predicted == pytest.approx((wn * dt) ** 2 / 12, rel=0.05)
    assert measured == pytest.approx(predicted, rel=0.02)
    assert np.ptp(u[-32:]) == pytest.approx(2 * U0, rel=1e-3)   # no numerical damping
    assert timestep.newmark_period_error(wn, period / 200) < 1e-4


def test_time_step_choice():
    wn = 10.8
    dt = timestep.choose(wn, 60.0, 0.002)
    assert 0.002 / dt == pytest.approx(round(0.002 / dt), abs=1e-9)       # divides the output
    assert dt <= 2 * math.pi / wn / 200
    assert wn * 60.0 * timestep.newmark_period_error(wn, dt) <= timestep.PHASE_BUDGET
    assert timestep.central_difference_period_error(wn, dt) == pytest.approx(-(wn * dt) ** 2 / 24, rel=1e-3)


# -- pure comparison pieces ------------------------------------------------------------------


def test_initial_state_is_the_fitted_models_state():
    p, wd = (float(x) for x in to_decay(C, K, M))
    tau = np.arange(0, 10, 0.01)
    _, _, a = free_decay(tau + 1.234, M, C, K, U0)   # window starts 1.234 s after release
    st = response.initial_state(tau, a, p, wd, tau0=0.37)
    u_ref, v_ref, _ = free_decay(np.array([0.37 + 1.234]), M, C, K, U0)
    assert st["u"] == pytest.approx(u_ref[0], rel=1e-9, abs=1e-12)
    assert st["v"] == pytest.approx(v_ref[0], rel=1e-9, abs=1e-12)
    assert st["fit_rms"] < 1e-10


def test_peak_decay_rate_and_errors():
    p, _ = to_decay(C, K, M)
    t = np.arange(0, 30, 0.005)
    u, _, _ = free_decay(t, M, C, K, U0)
    d = response.peak_decay_rate(t, u)
    assert d["p"] == pytest.approx(float(p), rel=1e-5) and d["n_peaks"] > 90
    assert response.peak_decay_rate(t[:50], u[:50])["p"] is None
    e = response.errors(u, 1.01 * u)
    assert e["nmse"] == pytest.approx(1e-4 * np.mean(u**2) / np.var(u), rel=1e-9)
    assert e["slope"] == pytest.approx(1.01) and e["r2"] == pytest.approx(1.0)
    assert response.errors([np.nan] * 5, [1.0] * 5)["mse"] is None


# -- verify on results -----------------------------------------------------------------------


@pytest.mark.usefixtures("requires_opensees")
def test_verify_reproduces_a_clean_simulated_decay(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    assert main(["verify", str(folder)]) == 0
    rep = json.loads((folder / "verification.json").read_text())
    assert (folder / "verify.png").stat().st_size > 10_000
    d = rep["decay_rate"]
    assert abs(d["relative_difference"]) < 0.01
    assert d["fem_peaks"] == pytest.approx(C / (2 * M), rel=1e-4)
    for key in ("displacement", "acceleration"):
        assert rep[key]["vs_measured"]["nmse"] < 1e-5
        assert rep[key]["vs_model"]["nmse"] < 1e-5
    e = rep["engine"]
    assert e["gamma"] == 0.5 and e["beta"] == 0.25 and e["period_error"] < 1e-4
    assert e["phase_error_at_end_rad"] <= timestep.PHASE_BUDGET
    assert e["version"] != "unknown"
    out = capsys.readouterr().out
    assert "decay rate p" in out and "NMSE" in out and "verification.json" in out


@pytest.mark.usefixtures("requires_opensees")
def test_verify_with_noise_and_custom_figure(tmp_path):
    folder = write_result(tmp_path / "r", noise=0.3)
    fig = tmp_path / "fig.png"
    assert main(["verify", str(folder), "--out", str(fig), "--dt", "0.001"]) == 0
    rep = json.loads((folder / "verification.json").read_text())
    assert fig.is_file() and rep["engine"]["dt_s"] == 0.001 and rep["figure"] == str(fig)
    acc = rep["acceleration"]["vs_measured"]
    measured = np.load(folder / "signals.npz")["accel"]
    assert acc["nmse"] == pytest.approx(0.3**2 / np.var(measured), rel=0.1)  # noise var / var
    assert rep["acceleration"]["vs_model"]["nmse"] < 1e-5


@pytest.mark.slow  # ~2 s itself, but the shared 'analysed' fixture costs ~40 s when run alone
@pytest.mark.usefixtures("requires_opensees")
def test_verify_on_an_analysed_recording(analysed, tmp_path):
    """The full pipeline: a simulated phone recording analysed by dampfit, then verified."""
    an, _ = analysed
    folder = tmp_path / "r"
    folder.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an.to_json(folder / "summary.json")
        an.to_signals(folder / "signals.npz")
    rep = verify.run(folder)["report"]
    assert abs(rep["decay_rate"]["relative_difference"]) < 0.01
    assert rep["acceleration"]["vs_measured_interior"]["nmse"] < 0.01
    assert rep["acceleration"]["vs_model"]["nmse"] < 1e-3


@pytest.mark.usefixtures("requires_opensees")
def test_verify_without_measured_displacement(tmp_path):
    """The paper's displacement pipeline may fail (NaN): acceleration is still compared."""
    folder = write_result(tmp_path / "r")
    with np.load(folder / "signals.npz") as data:
        sig = dict(data)
    sig["displacement"] = np.full(sig["t"].size, np.nan)
    np.savez(folder / "signals.npz", **sig)
    result = verify.run(folder)
    rep = result["report"]
    assert rep["displacement"]["vs_measured"]["nmse"] is None
    assert rep["decay_rate"]["measured_displacement_peaks"] is None
    assert rep["acceleration"]["vs_measured"]["nmse"] < 1e-5
    assert verify.plot(result, tmp_path / "v.png").is_file()


# -- verify runs the exported script ------------------------------------------------------------


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.usefixtures("requires_opensees")
def test_verify_runs_exactly_the_script_export_writes(tmp_path, capsys):
    """verification.json's script_sha256 is the SHA-256 of 'dampfit export DIR --format
    opensees' (the defaults); --dt is an option of the run, not of the script; another unit
    system is another script."""
    folder = write_result(tmp_path / "r")
    assert main(["export", str(folder), "--format", "opensees"]) == 0
    exported = _sha256(folder / "sdof_opensees.py")
    assert main(["verify", str(folder)]) == 0
    rep = json.loads((folder / "verification.json").read_text())
    assert rep["script_sha256"] == exported == rep["script"]["sha256"]
    s = rep["script"]
    assert (s["name"], s["format"], s["units"], s["quantile"], s["gravity"]) == \
        ("sdof_opensees.py", "opensees", "SI", 0.5, False)
    assert s["duration_s"] == pytest.approx(SPAN)  # the analysed window of summary.json
    assert shlex.split(s["export_command"]) == ["dampfit", "export", str(folder.resolve()),
                                                "--format", "opensees"]
    assert f"sha256 {exported[:16]}" in capsys.readouterr().out
    assert main(["verify", str(folder), "--dt", "0.001"]) == 0
    again = json.loads((folder / "verification.json").read_text())
    assert again["script_sha256"] == exported and "--dt=0.001" in again["script"]["run_options"]
    assert main(["export", str(folder), "--format", "opensees", "--units", "mm-ms-kg",
                 "--out", str(tmp_path / "sdof_opensees.py")]) == 0
    assert _sha256(tmp_path / "sdof_opensees.py") != exported


@pytest.mark.usefixtures("requires_opensees")
def test_the_exported_file_with_the_recorded_options_reproduces_verifys_run(tmp_path):
    """Run the exported file by hand with script.run_options: its response, on the sample
    times, is exactly the FEM response verify compared."""
    folder = write_result(tmp_path / "r", noise=0.1)
    path, _ = export(folder, "opensees")
    result = verify.run(folder)
    rep = result["report"]
    assert rep["script_sha256"] == _sha256(path)
    out = tmp_path / "again.csv"
    proc = subprocess.run([sys.executable, str(path), str(out), *rep["script"]["run_options"]],
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (rep["engine"]["n_steps"] + 1, 4)
    t = result["arrays"]["t"]
    t_fem = t[0] + rep["engine"]["dt_s"] * np.arange(data.shape[0])
    assert np.array_equal(np.interp(t, t_fem, data[:, 1]), result["arrays"]["u_fem"])
    assert np.array_equal(np.interp(t, t_fem, data[:, 3]), result["arrays"]["a_fem"])
    assert data[0, 1] == rep["initial_state"]["u"]["value"]
    assert data[0, 2] == rep["initial_state"]["v"]["value"]


@pytest.mark.usefixtures("requires_opensees")
def test_without_a_window_the_export_command_names_the_duration(tmp_path):
    """A summary.json without a window: export needs --duration, verify uses the signals'
    span and records the export command that writes its script."""
    folder = write_result(tmp_path / "r")
    summary = json.loads((folder / "summary.json").read_text())
    del summary["window"]
    (folder / "summary.json").write_text(json.dumps(summary))
    with pytest.raises(InputError, match="no analysis window; give --duration S"):
        export(folder, "opensees")
    rep = verify.run(folder)["report"]
    argv = shlex.split(rep["script"]["export_command"])
    assert argv[:5] == ["dampfit", "export", str(folder.resolve()), "--format", "opensees"]
    assert argv[5] == "--duration" and float(argv[6]) == pytest.approx(SPAN)
    assert main(argv[1:]) == 0
    assert _sha256(folder / "sdof_opensees.py") == rep["script_sha256"]


@pytest.mark.usefixtures("requires_opensees")
def test_verify_refreshes_the_report_dampfit_wrote(tmp_path, capsys):
    from dampfit.output.report import write_report
    from dampfit.result.files import REPORT_MARKERS, written_by_dampfit

    folder = write_result(tmp_path / "r")
    paths = write_report(folder)
    for name, marker in REPORT_MARKERS.items():  # the markers the report really carries
        assert written_by_dampfit(folder / name, marker)
    assert not written_by_dampfit(folder / "report.html", REPORT_MARKERS["report.md"])
    assert not written_by_dampfit(folder / "missing.html", REPORT_MARKERS["report.html"])
    assert "OpenSees verification" not in paths["md"].read_text()
    assert main(["verify", str(folder)]) == 0
    assert "report updated" in capsys.readouterr().out
    assert "OpenSees verification" in paths["md"].read_text()


def test_run_script_reports_a_failed_run_in_one_bounded_line(tmp_path, monkeypatch):
    """The child's exit message (sys.exit text or exception) is the error; 1 MB of noise on
    its standard error before it is not read."""
    monkeypatch.setattr(opensees, "unavailable", lambda: None)  # these scripts need no OpenSees
    noise = "import sys\nsys.stderr.write('Process 0 Terminating\\n' * 50000)\n"
    with pytest.raises(RuntimeError, match=r"exit 1\): OpenSees failed before t = 1.5$"):
        opensees.run_script(noise + "sys.exit('OpenSees failed before t = 1.5')", [], 3)
    with pytest.raises(RuntimeError, match=r"exit 1\): ZeroDivisionError: division by zero$"):
        opensees.run_script("1 / 0", [], 3)
    with pytest.raises(RuntimeError, match=r"exit 7\): no message$"):
        opensees.run_script("import sys\nsys.exit(7)", [], 3)
    with pytest.raises(RuntimeError, match="wrote no output"):
        opensees.run_script("pass", [], 3)


def test_run_script_reads_only_what_the_script_writes(tmp_path, monkeypatch):
    """The CSV must be the header and exactly the expected rows; a larger file is refused
    from its size, before it is read."""
    monkeypatch.setattr(opensees, "unavailable", lambda: None)
    write = "import sys\nopen(sys.argv[1], 'w').write({!r})\n"
    good = "time,u,v,a\n0.0,1.0,2.0,3.0\n0.5,4.0,5.0,6.0\n"
    res = opensees.run_script(write.format(good), [], 2, name="model.py")
    assert res["t"].tolist() == [0.0, 0.5] and res["a"].tolist() == [3.0, 6.0]
    with pytest.raises(RuntimeError, match="more than 2 rows hold"):
        opensees.run_script(write.format(good + "1.0,0,0,0\n" * 100), [], 2)
    with pytest.raises(RuntimeError, match="wrote 3 rows of 4 numbers, not 2 of 4"):
        opensees.run_script(write.format(good + "1.0,0,0,0\n"), [], 2)
    with pytest.raises(RuntimeError, match="does not start with 'time,u,v,a'"):
        opensees.run_script(write.format(good.replace("time", "t")), [], 2)
    with pytest.raises(ValueError, match="plain file name"):
        opensees.run_script("pass", [], 2, name="../x.py")
    # the arguments reach the script after OUT.csv, as on a command line
    echo = "import sys\nopen(sys.argv[1], 'w').write('time,u,v,a\\n' + ','.join(sys.argv[2:]) + '\\n')"
    assert opensees.run_script(echo, ["1.5", "2", "-3", "4e-3"], 1)["a"].tolist() == [4e-3]


def test_the_scripts_options_are_checked(tmp_path):
    """The exported script's own command line: a bad option is argparse's exit 2 with the
    reason on the last line, decided before OpenSees is imported (no exit noise after it)."""
    s = sdof.Sdof(M, K, C, U0)
    path = tmp_path / "model.py"
    path.write_text(opensees.script(s, units.get("SI"), (1.0, 0.001, 0.002), name=path.name))
    for args, message in ((["--steps", "5", "--every", "2"], "non-negative multiple of --every"),
                          (["--dt", "0"], "--dt must be positive"),
                          (["--u-start", "nan"], "all numbers finite"),
                          (["--steps", "x"], "invalid int value")):
        proc = subprocess.run([sys.executable, str(path), str(tmp_path / "o.csv"), *args],
                              capture_output=True, text=True, timeout=300, check=False)
        assert proc.returncode == 2 and message in proc.stderr.splitlines()[-1], proc.stderr
        assert "Process 0" not in proc.stderr
    assert not (tmp_path / "o.csv").exists()
    usage = subprocess.run([sys.executable, str(path), "--help"], capture_output=True, text=True,
                           timeout=300, check=False)
    assert usage.returncode == 0 and "--u-start" in usage.stdout and "--steps" in usage.stdout


def test_verify_input_errors(tmp_path):
    """Bad result folders are input errors before OpenSees runs (so OpenSees is not needed)."""
    with pytest.raises(InputError, match="summary.json not found"):
        verify.run(tmp_path)
    folder = write_result(tmp_path / "a")
    (folder / "signals.npz").unlink()
    with pytest.raises(InputError, match="signals.npz not found"):
        verify.run(folder)
    with pytest.raises(InputError, match="no mass, so c and k are not identified"):
        verify.run(write_result(tmp_path / "b", mass=None))
    with pytest.raises(InputError, match="lacks accel_model"):
        verify.run(write_result(tmp_path / "c", drop=("accel_model",)))
    with pytest.raises(InputError, match="period error .* > 0.0001"):
        verify.run(write_result(tmp_path / "d"), dt=0.02)
    write_result(tmp_path / "f")
    (tmp_path / "f" / "signals.npz").write_bytes(b"junk")
    with pytest.raises(InputError, match="not a readable .npz"):
        verify.run(tmp_path / "f")
    with pytest.raises(InputError, match="force must be a finite weight <= 0"):
        opensees.free_decay(M, K, C, U0, 0.0, 1e-3, 10, force=1.0)  # the script's load is a weight


@pytest.mark.usefixtures("requires_opensees")
def test_verify_cli_input_errors_are_one_line(tmp_path, capsys):
    assert main(["verify", str(tmp_path / "missing")]) == 2
    assert main(["verify", str(write_result(tmp_path / "g")), "--out", str(tmp_path / "no" / "f.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "is not a directory" in err[0] and "does not exist" in err[1]
    assert not (tmp_path / "g" / "verification.json").exists()


# -- is OpenSeesPy usable, and what CI does when it is not -----------------------------------


def _import_failure(message: str) -> BaseException:
    """The exception chain OpenSeesPy's Linux wrapper raises when its binary cannot load."""
    try:
        try:
            raise ImportError(message)
        except ImportError:
            raise RuntimeError("Failed to import openseespy on Linux.")  # noqa: B904 - as it does
    except RuntimeError as exc:
        return exc


def test_unavailable_names_the_fix(monkeypatch):
    import importlib.util

    err = "libblas.so.3: cannot open shared object file: No such file or directory"
    assert opensees._reason(_import_failure(err)) == opensees.BLAS_REASON
    assert "sudo apt-get install libblas3 liblapack3" in opensees.BLAS_REASON
    other = opensees._reason(_import_failure("libfoo.so.7: cannot open shared object file: x"))
    assert "libfoo.so.7" in other and "\n" not in other
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "openseespy" else real(name, *a))
    assert opensees.unavailable() == opensees.NOT_INSTALLED_REASON
    assert "pip install 'dampfit[fem]'" in opensees.NOT_INSTALLED_REASON


def test_unavailable_agrees_with_a_real_import():
    reason = opensees.unavailable()
    if reason is None:  # imported in a child: this process stays free of OpenSees' exit line
        proc = subprocess.run([sys.executable, "-c", "import openseespy.opensees as o; o.wipe()"],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
    else:
        assert "\n" not in reason
        with pytest.raises(InputError, match="OpenSeesPy"):
            opensees.free_decay(M, K, C, U0, 0.0, 1e-3, 10)


def test_require_skips_or_fails_under_require_all(monkeypatch, request):
    from tests._support.requirements import require

    monkeypatch.delenv("DAMPFIT_REQUIRE_ALL", raising=False)
    require(True, "present")  # no-op
    with pytest.raises(pytest.skip.Exception, match="libfoo missing"):
        require(False, "libfoo missing")
    monkeypatch.setenv("DAMPFIT_REQUIRE_ALL", "1")
    require(True, "present")
    with pytest.raises(pytest.fail.Exception, match="DAMPFIT_REQUIRE_ALL=1.*libfoo missing"):
        require(False, "libfoo missing")
    # the OpenSees fixture follows it: a missing OpenSees fails the test in CI
    monkeypatch.setattr(opensees, "unavailable", lambda: opensees.BLAS_REASON)
    with pytest.raises(pytest.fail.Exception, match="libblas3 liblapack3"):
        request.getfixturevalue("requires_opensees")


def test_require_all_turns_every_other_skip_into_a_failure(tmp_path):
    """The conftest hook: under DAMPFIT_REQUIRE_ALL=1 a skipif/pytest.skip fails, except a
    skip_optional (what CI does not install either); without it all three skip."""
    (tmp_path / "test_deps.py").write_text(
        "import pytest\n"
        "from tests._support.requirements import require, skip_optional\n"
        "def test_required():\n    require(False, 'thing A missing')\n"
        "@pytest.mark.skipif(True, reason='thing B missing')\n"
        "def test_marked():\n    pass\n"
        "def test_optional():\n    skip_optional('pyarrow missing')\n")
    root = Path(__file__).resolve().parents[2]
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "tests.conftest",
           "--rootdir", str(tmp_path), str(tmp_path / "test_deps.py")]
    env = {k: v for k, v in os.environ.items() if k != "DAMPFIT_REQUIRE_ALL"}
    loose = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, timeout=120)
    assert "3 skipped" in loose.stdout and loose.returncode == 0, loose.stdout
    strict = subprocess.run(cmd, cwd=root, env={**env, "DAMPFIT_REQUIRE_ALL": "1"},
                            capture_output=True, text=True, timeout=120)
    # a skipif mark skips in setup, so its failure is reported as an error: both fail the run
    assert "1 failed, 1 skipped, 1 error" in strict.stdout and strict.returncode == 1, strict.stdout
    assert "thing A missing" in strict.stdout and "thing B missing" in strict.stdout
