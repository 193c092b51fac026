"""Result folders read back: :func:`dampfit.load` and the one reader of summary.json.

Every result folder the CLI writes (``analyze`` plain, with ``--report``, with
``--no-figures``; ``demo``) loads into the :class:`~dampfit.analysis.Analysis` that wrote it:
the same summary (as written, and as the live analysis computes it), posterior and signals;
report, export and verify work from the loaded result; a foreign or broken folder is one error
line (exit 2) that says it is not a dampfit result folder, the same through every command.
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit import simulate as sim
from dampfit.cli import main
from dampfit.errors import DampfitError, InputError
from dampfit.analysis import Analysis
from dampfit.result import SCHEMA_VERSION, read_summary

FOREIGN = "is not a dampfit result folder"


@pytest.fixture
def live(monkeypatch, analysed):
    """``analyze`` returns a fresh copy of the session's analysis (the writing path stays
    real); the list holds each analysis returned, and ``computed`` counts summary computations."""
    an, _ = analysed
    made: list[Analysis] = []
    computed: list[int] = []
    real = Analysis._compute_summary

    def counting(self):
        computed.append(1)
        return real(self)

    def fake(*args, **kwargs):
        made.append(dataclasses.replace(an))  # a new object: no cached summary
        return made[-1]

    monkeypatch.setattr("dampfit.pipeline.analyze", fake)
    monkeypatch.setattr(Analysis, "_compute_summary", counting)
    return made, computed


@pytest.fixture(scope="module")
def csv_file(tmp_path_factory):
    rec, _ = sim.recording(sim.preset("paper", duration=20.0, seed=3))
    path = tmp_path_factory.mktemp("rec") / "rec.csv"
    sim.write_phyphox_csv(rec, path)
    return path


def _written(folder: Path) -> dict:
    return json.loads((folder / "summary.json").read_text(encoding="utf-8"))


def _round_trip(folder: Path, an: Analysis) -> Analysis:
    loaded = dampfit.load(folder)
    assert type(loaded) is Analysis and loaded.folder == folder
    written = _written(folder)
    assert written["schema_version"] == SCHEMA_VERSION == 1
    assert loaded.summary() == written == an.summary()
    assert loaded.converged == an.converged
    # posterior.nc: the same draws
    for name in ("c", "k", "zeta"):
        np.testing.assert_array_equal(loaded.draws(name), an.draws(name))
    # signals.npz: the same arrays
    live_sig, sig = an.signals(), loaded.signals()
    assert set(sig) == set(live_sig)
    for key in live_sig:
        np.testing.assert_array_equal(np.asarray(sig[key]), np.asarray(live_sig[key]))
    return loaded


# ----------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("extra", [[], ["--report"], ["--no-figures"]],
                         ids=["plain", "report", "no-figures"])
def test_load_round_trips_analyze(csv_file, tmp_path, capsys, live, extra):
    made, computed = live
    out = tmp_path / "res"
    assert main(["analyze", str(csv_file), "--mass", "5.3", "--out", str(out), "--quiet",
                 *extra]) == 0
    capsys.readouterr()
    assert len(made) == 1
    assert len(computed) == 1  # computed once per run, then cached
    assert (out / "report.html").exists() == ("--report" in extra)
    assert (out / "fit.png").exists() == ("--no-figures" not in extra)
    _round_trip(out, made[0])


def test_load_round_trips_demo(tmp_path, capsys, live, monkeypatch):
    made, computed = live
    real_preset = sim.preset
    monkeypatch.setattr(sim, "preset", lambda name, **kw: real_preset(name, **{"duration": 10.0, **kw}))
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--quiet", "--no-figures", "--report"]) == 0
    capsys.readouterr()
    assert len(computed) == 1
    _round_trip(out, made[0])
    assert (out / "report.html").is_file() and (out / "paper-preset.truth.json").is_file()


def test_a_loaded_result_does_not_recompute_and_names_its_folder(tmp_path, analysed):
    an, _ = analysed
    folder = tmp_path / "r"
    folder.mkdir()
    an.to_json(folder / "summary.json")
    an.to_netcdf(folder / "posterior.nc")
    an.to_signals(folder / "signals.npz")
    loaded = dampfit.load(folder)
    s = loaded.summary()
    s["parameters"]["c"]["q50"] = -1.0  # a copy: the loaded summary is unchanged
    assert loaded.summary() == an.summary()
    assert loaded.posterior.posterior["c"].shape == an.posterior.posterior["c"].shape
    for use in (lambda: loaded.recording.path, lambda: loaded.prepared.grid,
                lambda: loaded.least_squares.p, lambda: loaded.true_quadratures(),
                lambda: loaded.baselines["log_decrement"]):
        with pytest.raises(DampfitError, match=f"loaded from {re.escape(str(folder))}"):
            use()
    # what a loaded result holds can be written again, unchanged
    again = tmp_path / "again"
    again.mkdir()
    loaded.to_json(again / "summary.json")
    loaded.to_netcdf(again / "posterior.nc")
    loaded.to_signals(again / "signals.npz")
    assert _written(again) == _written(folder)
    assert dampfit.load(again).summary() == an.summary()


def test_a_live_summary_is_computed_once(analysed, monkeypatch):
    an = dataclasses.replace(analysed[0])
    calls = []
    real = Analysis._compute_summary
    monkeypatch.setattr(Analysis, "_compute_summary", lambda self: calls.append(1) or real(self))
    first = an.summary()
    first["mass"]["value"] = 0.0  # the caller's copy
    assert an.summary()["mass"]["value"] == analysed[0].mass
    an.summary()
    assert len(calls) == 1


# ----------------------------------------------------------------------------- from a loaded result
@pytest.fixture
def folder(csv_file, tmp_path, capsys, live) -> Path:
    out = tmp_path / "res"
    assert main(["analyze", str(csv_file), "--mass", "5.3", "--out", str(out), "--quiet",
                 "--no-figures"]) == 0
    capsys.readouterr()
    return out


def test_report_and_export_work_from_a_loaded_result(folder, tmp_path):
    from dampfit.fem.export import build, export
    from dampfit.output.report import write_report

    loaded = dampfit.load(folder)
    paths = write_report(loaded)
    assert paths["html"] == folder / "report.html" and paths["html"].is_file()
    text, info = build(loaded, "lsdyna")
    assert info["sdof"].mass == pytest.approx(5.3) and "*KEYWORD" in text
    path, _ = export(loaded, "opensees", tmp_path / "deck.py")
    assert path.is_file() and text != path.read_text()
    assert build(folder, "lsdyna")[0] == text  # same deck from the folder itself


@pytest.mark.usefixtures("requires_opensees")
def test_verify_works_from_a_loaded_result(folder):
    from dampfit.fem import verify

    res = verify.verify(dampfit.load(folder))
    assert res["json"] == folder / "verification.json" and res["json"].is_file()
    assert res["figure"] == folder / "verify.png" and res["figure"].is_file()
    assert np.isfinite(res["report"]["acceleration"]["vs_model"]["nmse"])


def test_a_live_analysis_without_folder_is_refused_by_report(analysed):
    from dampfit.output.report import write_report

    with pytest.raises(InputError, match="not loaded from a result folder"):
        write_report(analysed[0])


# ----------------------------------------------------------------------------- schema versions
def test_a_summary_without_schema_version_is_version_0(folder):
    s = _written(folder)
    del s["schema_version"]
    (folder / "summary.json").write_text(json.dumps(s))
    assert read_summary(folder).schema_version == 0
    assert dampfit.load(folder).summary() == s
    assert main(["report", str(folder)]) == 0


def test_a_newer_schema_version_is_one_clear_line(folder, capsys):
    s = _written(folder)
    s["schema_version"] = SCHEMA_VERSION + 1
    (folder / "summary.json").write_text(json.dumps(s))
    with pytest.raises(InputError, match="schema version 2 .*reads versions up to 1: upgrade dampfit"):
        dampfit.load(folder)
    for argv in (["report", folder], ["export", folder, "--format", "lsdyna"]):
        assert main([str(a) for a in argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "upgrade dampfit" in err[0]


@pytest.mark.parametrize("bad", ["-1", "true", '"1"', "1.0"])
def test_a_malformed_schema_version_is_refused(folder, bad):
    text = (folder / "summary.json").read_text().replace('"schema_version": 1', f'"schema_version": {bad}', 1)
    (folder / "summary.json").write_text(text)
    with pytest.raises(InputError, match="'schema_version' must be a non-negative integer"):
        read_summary(folder)


# ----------------------------------------------------------------------------- foreign folders
def _foreign(tmp_path: Path, case: str) -> Path:
    d = tmp_path / case
    if case == "missing":
        return d
    d.mkdir()
    if case == "empty":
        (d / "notes.txt").write_text("my own folder\n")
    elif case == "broken-json":
        (d / "summary.json").write_text("{not json")
    elif case == "not-an-object":
        (d / "summary.json").write_text("[1, 2]")
    elif case == "no-parameters":
        (d / "summary.json").write_text('{"mass": {"value": 5.3}}')
    elif case == "marker-only":
        (d / ".dampfit-result").write_text('{"kind": "analyze"}')
    return d


CASES = ["missing", "empty", "broken-json", "not-an-object", "no-parameters", "marker-only"]


@pytest.mark.parametrize("case", CASES)
def test_foreign_folders_are_one_line_exit_2_through_every_command(tmp_path, capsys, monkeypatch,
                                                                   case):
    from dampfit.fem import opensees

    monkeypatch.setattr(opensees, "unavailable", lambda: None)  # the folder is read first
    d = _foreign(tmp_path, case)
    lines = []
    for argv in (["report", d], ["export", d, "--format", "lsdyna"], ["verify", d]):
        assert main([str(a) for a in argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("dampfit: error:") and FOREIGN in err[0], err
        lines.append(err[0])
    assert len(set(lines)) == 1  # one text, whatever the command
    with pytest.raises(InputError, match=FOREIGN) as info:
        dampfit.load(d)
    assert f"dampfit: error: {info.value}" == lines[0]
    if d.exists():
        assert not list(d.glob("report.*")) and not list(d.glob("sdof_*"))


def test_posterior_and_signals_are_read_only_when_used(folder):
    shutil.copyfile(folder / "summary.json", folder / "summary.bak")
    (folder / "posterior.nc").write_bytes(b"not netcdf")
    (folder / "signals.npz").unlink()
    loaded = dampfit.load(folder)  # the summary alone is enough to load
    assert loaded.summary() == _written(folder)
    with pytest.raises(InputError, match="posterior.nc is not a readable posterior"):
        loaded.posterior
    with pytest.raises(InputError, match="signals.npz not found"):
        loaded.signals()
