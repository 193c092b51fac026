"""``dampfit analyze FILE FILE…`` (several recordings of one damper, issue 12) and the outputs of
a campaign folder: the text table, ``forest.png`` / ``added_mass.png``, the report, FEM export
and :func:`dampfit.load`.

Most tests run against a hand-made campaign summary that follows the contract of
:mod:`dampfit.campaign` (a fake ``analyze_campaign`` returns it), so the CLI, staging and
outputs are checked without sampling; ``test_end_to_end_*`` run the real joint analysis on
short simulated recordings (20 s at 100 Hz).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import dampfit
from dampfit import simulate as sim
from dampfit.files.folder import MARKER
from tests._support.hostile import run
from tests._support.summaries import hand_summary


class FakeCampaign:
    """Stands for :class:`dampfit.campaign.result.CampaignAnalysis` (writing path only)."""

    def __init__(self, summary: dict):
        self._s = summary
        self.converged = summary["diagnostics"]["converged"]
        self.warnings: list[str] = []

    def summary(self) -> dict:
        return json.loads(json.dumps(self._s))

    def to_json(self, path):
        Path(path).write_text(json.dumps(self._s, indent=2) + "\n")

    def save(self, folder, **kw):  # the real writing path
        from dampfit.campaign.result import CampaignAnalysis

        return CampaignAnalysis.save(self, folder, **kw)

    def _record_files(self, stage):  # the real path amends the summary with posterior.nc's digest
        from dampfit.result.files import file_digests

        self._s["files"] = file_digests(stage, ("posterior.nc",))

    def _write(self, folder, figures):
        from dampfit.campaign.result import CampaignAnalysis

        return CampaignAnalysis._write(self, folder, figures)

    def to_netcdf(self, path):
        import arviz as az
        import numpy as np

        rng = np.random.default_rng(0)
        az.from_dict(posterior={"c": 0.2 + 0.01 * rng.standard_normal((2, 50)),
                                "k": 619 + 3 * rng.standard_normal((2, 50))}
                     ).to_netcdf(str(path), engine="h5netcdf")


@pytest.fixture
def fake_campaign(monkeypatch):
    """``analyze_campaign`` returns the hand-made summary (with the given paths); the list
    records each call's (recordings, keyword arguments)."""
    calls: list = []

    def fake(recordings, mass=None, mass_sd=None, **kw):
        calls.append((recordings, {"mass": mass, "mass_sd": mass_sd, **kw}))
        added = kw.get("added_mass") is not None
        return FakeCampaign(hand_summary(added, len(recordings),
                                         paths=[r.path for r in recordings]))

    monkeypatch.setattr("dampfit.campaign.analyze_campaign", fake)
    return calls


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Three short simulated recordings of one damper (20 s at 100 Hz) and one of a system
    twice as fast (a different system)."""
    d = tmp_path_factory.mktemp("campaign")
    paths = []
    for i, u0 in enumerate((0.04, 0.03, 0.02)):
        cfg = sim.from_modal(1.0, 2.0, 0.01, duration=20.0, sample_rate=100.0, u0=u0, seed=i + 1)
        rec, _ = sim.recording(cfg)
        paths.append(sim.write_phyphox_csv(rec, d / f"rec-{i + 1}.csv"))
    cfg = sim.from_modal(1.0, 6.0, 0.01, duration=20.0, sample_rate=100.0, seed=9)
    other = sim.write_phyphox_csv(sim.recording(cfg)[0], d / "other.csv")
    return [Path(p) for p in paths], Path(other)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("dampfit: error:")
    return lines[0]


def write_folder(tmp_path: Path, summary: dict, name: str = "camp") -> Path:
    folder = tmp_path / name
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps(summary))
    (folder / MARKER).write_text(json.dumps({"kind": "campaign", "dampfit": "0.test"}))
    FakeCampaign(summary).to_netcdf(folder / "posterior.nc")
    return folder


# ----------------------------------------------------------------------------- text, figures
def test_text_table_names_population_predictive_spread_tests_and_verdict():
    from dampfit.output.text_campaign import text

    t = text(hand_summary())
    for words in ("campaign of 3 tests", "c      [N s/m]", "new test (predictive)",
                  "0.200 [0.170, 0.230]", "spread τ of p", "rec-3.csv", "OUTLIER",
                  "verdict         outlier", "converged       yes"):
        assert words in t, words
    t = text(hand_summary(added_mass=True))
    assert "m0     [kg]" in t and "added masses 0, 2, 4 kg" in t and "m0 = 5.30 [5.14, 5.46] kg" in t


def test_figures_from_the_summary(tmp_path):
    from dampfit.output.figures.campaign import save_figures

    written = save_figures(hand_summary(added_mass=True), tmp_path)
    assert set(written) == {"forest", "added_mass"}
    for p in written.values():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # without the added-mass design the old added_mass.png is removed, forest.png rewritten
    assert set(save_figures(hand_summary(), tmp_path)) == {"forest"}
    assert not (tmp_path / "added_mass.png").exists()


def test_missing_campaign_figures_are_redrawn_from_the_summary(tmp_path):
    from dampfit.output.figures import redraw_missing
    from dampfit.output.figures.campaign import save_figures

    folder = write_folder(tmp_path, hand_summary(added_mass=True))
    (tmp_path / "drawn").mkdir()
    expected = save_figures(hand_summary(added_mass=True), tmp_path / "drawn")
    (folder / "forest.png").write_bytes(b"mine")  # present: left alone
    done = redraw_missing(folder)
    assert done.drawn == ["added_mass"] and done.notes == []
    assert (folder / "added_mass.png").read_bytes() == expected["added_mass"].read_bytes()
    assert (folder / "forest.png").read_bytes() == b"mine"


def test_tests_of_the_same_file_name_are_told_apart():
    from dampfit.output.text_campaign import labels, text

    paths = [f"/data/40cm/08-12_11-4{i}-04_adxl6cmfromtip/accelerometer_data.npy" for i in range(3)]
    names = labels(hand_summary(paths=paths)["tests"])
    assert len(set(names)) == 3 and all(n.endswith("/accelerometer_data.npy") for n in names)
    assert "08-12_11-41-04_" in names[1]
    assert all(n in text(hand_summary(paths=paths)) for n in names)


# ----------------------------------------------------------------------------- CLI, writing
def test_campaign_cli_writes_the_folder(recordings, fake_campaign, tmp_path, capsys):
    paths, _ = recordings
    out = tmp_path / "camp"
    code, text, err = run(["analyze", *paths, "--mass", "1.0", "--mass-sd", "0.01", "--out", out,
                           "--quiet", "--report"], capsys)
    assert code == 0, err
    assert "campaign of 3 tests" in text and "written to" in text and "forest.png" in text
    recs, kw = fake_campaign[-1]
    assert [r.path for r in recs] == [str(p) for p in paths]
    assert kw["mass"] == 1.0 and kw["mass_sd"] == 0.01 and "added_mass" not in kw
    names = {p.name for p in out.iterdir()}
    assert {"summary.json", "posterior.nc", "forest.png", "report.html", "report.md",
            MARKER} <= names
    assert "added_mass.png" not in names and "signals.npz" not in names
    assert json.loads((out / MARKER).read_text())["kind"] == "campaign"
    assert not list(tmp_path.glob(".camp*")), "staging or lock left behind"
    # an existing folder is replaced only with --force
    code, _, err = run(["analyze", *paths, "--mass", "1", "--out", out, "--quiet"], capsys)
    assert code == 2 and "use --force" in one_line(err)
    code, text, err = run(["analyze", *paths, "--added-mass", "0", "0.5", "1", "--out", out,
                           "--quiet", "--force", "--json"], capsys)
    assert code == 0, err
    assert json.loads(text)["design"]["model"] == "added-mass"
    assert fake_campaign[-1][1]["added_mass"] == [0.0, 0.5, 1.0]
    assert {"forest.png", "added_mass.png"} <= {p.name for p in out.iterdir()}
    assert "report.html" not in {p.name for p in out.iterdir()}


def test_default_out_is_named_after_the_first_file(recordings, fake_campaign, tmp_path,
                                                   monkeypatch, capsys):
    paths, _ = recordings
    monkeypatch.chdir(tmp_path)
    code, _, err = run(["analyze", *paths[:2], "--mass", "1", "--quiet", "--no-figures"], capsys)
    assert code == 0, err
    out = tmp_path / (paths[0].name + ".campaign.dampfit")
    assert (out / "summary.json").is_file() and not (out / "forest.png").exists()


@pytest.mark.parametrize("extra,match", [
    (["--added-mass", "0", "1"], "one added mass per FILE, got 2 for 3 files"),
    (["--added-mass", "0", "1", "2", "--mass", "1"], "not with --added-mass"),
    (["--added-mass-sd", "0.01", "--mass", "1"], "without --added-mass"),
    (["--mass-sd", "0.01"], "without --mass"),
    (["--mass", "1", "--model", "coulomb"], "applies to one recording"),
    (["--added-mass", "0", "-1", "2"], "an added mass in kg"),
])
def test_bad_campaign_options_one_line_nothing_written(recordings, fake_campaign, tmp_path,
                                                       capsys, extra, match):
    paths, _ = recordings
    out = tmp_path / "o"
    code, _, err = run(["analyze", *paths, "--out", out, "--quiet", *extra], capsys)
    assert code == 2
    assert match in one_line(err)
    assert not out.exists() and not list(tmp_path.glob(".o*"))
    assert fake_campaign == []


def test_missing_or_repeated_file_is_named(recordings, fake_campaign, tmp_path, capsys):
    paths, _ = recordings
    out = tmp_path / "o"
    missing = tmp_path / "nope.csv"
    code, _, err = run(["analyze", paths[0], missing, "--mass", "1", "--out", out, "--quiet"],
                       capsys)
    assert code == 2 and str(missing) in one_line(err)
    code, _, err = run(["analyze", paths[0], paths[1], paths[0], "--mass", "1", "--out", out,
                        "--quiet"], capsys)
    assert code == 2 and "given twice" in one_line(err)
    assert not out.exists() and not list(tmp_path.glob(".o*")) and fake_campaign == []


def test_added_mass_needs_several_files(recordings, tmp_path, capsys):
    paths, _ = recordings
    code, _, err = run(["analyze", paths[0], "--added-mass", "0", "--out", tmp_path / "o"], capsys)
    assert code == 2 and "needs several recordings" in one_line(err)
    assert not (tmp_path / "o").exists()


def test_every_input_folder_is_protected(recordings, fake_campaign, tmp_path, capsys):
    paths, _ = recordings
    code, _, err = run(["analyze", *paths, "--mass", "1", "--out", paths[1].parent, "--force",
                        "--quiet"], capsys)
    assert code == 2 and "holds the input" in one_line(err)


# ----------------------------------------------------------------------------- read back
def test_campaign_folder_round_trips_through_load(tmp_path):
    from dampfit.campaign.result import CampaignAnalysis

    s = hand_summary(added_mass=True)
    folder = write_folder(tmp_path, s)
    an = dampfit.load(folder)
    assert isinstance(an, CampaignAnalysis)
    assert an.summary() == s and an.folder == folder and an.converged is True
    assert "c" in an.posterior.posterior
    # the loaded result renders and exports like its folder
    from dampfit.fem.export import export
    from dampfit.output.report import write_report

    assert write_report(an)["md"].is_file()
    path, info = export(an, "calculix")
    assert path.is_file() and info["mass"] == pytest.approx(5.3)


@pytest.mark.parametrize("edit,match", [
    (lambda s: s.update(tests="x"), "'tests' of a campaign"),
    (lambda s: s.update(tests=[s["tests"][0]]), "at least 2"),
    (lambda s: s["tests"].__setitem__(1, 3), "tests[1] must be an object"),
    (lambda s: s.update(population=[1]), "'population' must be an object"),
    (lambda s: s.update(kind="zoo"), "'kind' must be"),
])
def test_broken_campaign_summary_is_one_line(tmp_path, capsys, edit, match):
    s = hand_summary()
    edit(s)
    folder = write_folder(tmp_path, s)
    code, _, err = run(["report", folder], capsys)
    assert code == 2 and match in one_line(err)


def test_report_of_a_campaign_folder(tmp_path, capsys):
    from dampfit.output.figures.campaign import save_figures

    folder = write_folder(tmp_path, hand_summary(added_mass=True))
    save_figures(hand_summary(added_mass=True), folder)
    code, text, err = run(["report", folder], capsys)
    assert code == 0, err
    html = (folder / "report.html").read_text()
    md = (folder / "report.md").read_text()
    for words in ("campaign of 3 tests", "90 % predictive interval", "Between-test spread",
                  "Added-mass method", "OUTLIER", "--added-mass 0.0 2.0 4.0"):
        assert words in md, words
    assert "forest.png" in md and "added_mass.png" in md
    assert html.count("data:image/png;base64") == 2


@pytest.mark.parametrize("fmt,comment", [("lsdyna", "$ "), ("opensees", "# "),
                                         ("calculix", "** ")])
def test_export_of_a_campaign_is_the_population_damper(tmp_path, capsys, fmt, comment):
    folder = write_folder(tmp_path, hand_summary())
    code, text, err = run(["export", folder, "--format", fmt], capsys)
    assert code == 0, err
    assert "c = 0.2 N s/m" in text and "m = 5.3 kg" in text and "u0 = 0.03 m" in text
    deck = next(p for p in folder.iterdir() if p.name.startswith("sdof_")).read_text()
    assert f"{comment}Population damper of a campaign of 3 tests" in deck
    assert "[0.17, 0.23]" in deck.replace("\n" + comment, " ")
    if fmt == "lsdyna":
        assert deck.startswith("*KEYWORD\n")
    if fmt == "opensees":
        compile(deck, "deck.py", "exec")


# ----------------------------------------------------------------------------- end to end
@pytest.mark.heavy
def test_end_to_end_campaign_round_trip_report_export(recordings, tmp_path, capsys):
    """The real joint analysis (short chain: not converged, exit 0 with the warning)."""
    from dampfit.campaign.result import CampaignAnalysis

    paths, _ = recordings
    out = tmp_path / "camp"
    code, text, err = run(["analyze", *paths, "--mass", "1.0", "--mass-sd", "0.01", "--out", out,
                           "--quiet", "--max-steps", "300", "--report"], capsys)
    assert code == 0, err
    assert "campaign of 3 tests" in text and "verdict" in text
    assert {"summary.json", "posterior.nc", "forest.png", "report.html"} <= {
        p.name for p in out.iterdir()}
    an = dampfit.load(out)
    assert isinstance(an, CampaignAnalysis)
    assert an.summary() == json.loads((out / "summary.json").read_text())
    assert an.summary()["kind"] == "campaign" and len(an.summary()["tests"]) == 3
    assert "c" in an.posterior.posterior
    code, text, err = run(["export", out, "--format", "lsdyna"], capsys)
    assert code == 0, err
    assert "Population damper of a campaign of 3 tests" in (out / "sdof_lsdyna.k").read_text()
    code, _, err = run(["report", out], capsys)
    assert code == 0, err
    assert "Each test" in (out / "report.md").read_text()
    # its posterior.nc is recorded in summary.files, and one of another analysis is refused
    import arviz as az

    files = json.loads((out / "summary.json").read_text())["files"]
    assert set(files) == {"posterior.nc"}
    assert files["posterior.nc"]["bytes"] == (out / "posterior.nc").stat().st_size
    with az.rc_context({"data.load": "eager"}):
        idata = az.from_netcdf(out / "posterior.nc")
    idata.posterior["c"] = idata.posterior["c"] * (1 + 1e-9)
    idata.to_netcdf(str(out / "posterior.nc"))
    code, _, err = run(["report", out], capsys)
    assert code == 2 and "posterior.nc does not belong to" in one_line(err), err


@pytest.mark.heavy
def test_end_to_end_added_mass(tmp_path, capsys):
    paths = []
    for i, dm in enumerate((0.0, 0.5, 1.0)):
        cfg = sim.from_modal(1.0 + dm, 2.0 / (1.0 + dm) ** 0.5, 0.01, duration=20.0,
                             sample_rate=100.0, seed=20 + i)
        paths.append(sim.write_phyphox_csv(sim.recording(cfg)[0], tmp_path / f"m{i}.csv"))
    out = tmp_path / "am"
    code, text, err = run(["analyze", *paths, "--added-mass", "0", "0.5", "1.0", "--out", out,
                           "--quiet", "--max-steps", "300"], capsys)
    assert code == 0, err
    assert "m0     [kg]" in text
    s = json.loads((out / "summary.json").read_text())
    assert s["design"]["model"] == "added-mass" and isinstance(s["added_mass"], dict)
    assert (out / "added_mass.png").is_file() and (out / "forest.png").is_file()


def test_files_of_different_systems_one_line_nothing_written(recordings, tmp_path, capsys):
    paths, other = recordings
    out = tmp_path / "o"
    code, _, err = run(["analyze", paths[0], paths[1], other, "--mass", "1", "--out", out,
                        "--quiet"], capsys)
    assert code == 2 and "not of one system" in one_line(err)
    assert not out.exists() and not list(tmp_path.glob(".o*"))


def test_unidentifiable_added_mass_design_one_line_nothing_written(recordings, tmp_path, capsys):
    """One distinct added mass cannot separate m0 from k: refused before any sampling."""
    paths, _ = recordings
    out = tmp_path / "o"
    code, _, err = run(["analyze", paths[0], paths[1], "--added-mass", "0.1", "0.1", "--out",
                        out, "--quiet"], capsys)
    line = one_line(err)
    assert code == 2 and "m0" in line
    assert not out.exists() and not list(tmp_path.glob(".o*"))


def test_a_test_without_decay_is_named_one_line_nothing_written(recordings, tmp_path, capsys):
    """A file of pure noise among the tests: one line naming that test, nothing written."""
    import numpy as np

    paths, _ = recordings
    t = np.arange(0, 20, 0.01)
    noise = np.random.default_rng(3).normal(0, 0.05, (t.size, 3))
    rec = dampfit.Recording(t, noise, axes=("x", "y", "z"))
    flat = sim.write_phyphox_csv(rec, tmp_path / "noise.csv")
    out = tmp_path / "o"
    code, _, err = run(["analyze", paths[0], paths[1], flat, "--mass", "1", "--out", out,
                        "--quiet"], capsys)
    line = one_line(err)
    assert code == 2 and "test 3" in line and "noise.csv" in line
    assert not out.exists() and not list(tmp_path.glob(".o*"))


@pytest.mark.usefixtures("requires_opensees")  # without OpenSees, verify stops before reading
def test_verify_of_a_campaign_folder_says_what_to_do(tmp_path, capsys):
    """verify compares one recording with its FEM model: a campaign folder gets one line
    saying so, not a missing-file message."""
    out = tmp_path / "camp"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps(hand_summary()))
    code, _, err = run(["verify", out], capsys)
    line = one_line(err)
    assert code == 2 and "campaign of 3 tests" in line and "single-recording" in line


# ----------------------------------------------------------------------------- issue 19
@pytest.mark.parametrize("edit,match", [
    (lambda s: s["population"].update(predictive=1e308), "'population.predictive' must be an object"),
    (lambda s: s["population"].update(spread="x"), "'population.spread' must be an object"),
    (lambda s: s["population"]["predictive"].update(c=[1]), "'population.predictive.c' must be"),
])
@pytest.mark.parametrize("command", [["export", "--format", "lsdyna"], ["report"]])
def test_an_edited_population_is_one_line_in_export_and_report(tmp_path, capsys, edit, match,
                                                                command):
    s = hand_summary()
    edit(s)
    folder = write_folder(tmp_path, s)
    code, _, err = run([command[0], folder, *command[1:]], capsys)
    assert code == 2 and match in one_line(err)
    assert not any(p.name.startswith(("sdof_", "report.")) for p in folder.iterdir())


@pytest.mark.heavy
def test_identical_recordings_are_named_and_campaign_signals_are_per_test(recordings, tmp_path,
                                                                          capsys, monkeypatch):
    """The same file under two names is warned about (both names, same SHA-256) in the table
    and the summary; a live campaign's signals() gives each test's window signals, a loaded
    one says its folder has none (a DampfitError, not an AttributeError)."""
    import shutil

    import dampfit.campaign as campaign
    from dampfit.errors import DampfitError

    paths, _ = recordings
    copy = tmp_path / "copy-of-rec-1.csv"
    shutil.copy(paths[0], copy)
    live = []
    real = campaign.analyze_campaign
    monkeypatch.setattr(campaign, "analyze_campaign",
                        lambda *a, **k: live.append(real(*a, **k)) or live[-1])
    out = tmp_path / "camp"
    code, text, err = run(["analyze", paths[0], paths[1], copy, "--mass", "1.0", "--out", out,
                           "--quiet", "--max-steps", "300", "--no-figures"], capsys)
    assert code == 0, err
    warning = next(line for line in text.splitlines() if "byte-identical" in line)
    assert "test 1 (rec-1.csv) and test 3 (copy-of-rec-1.csv)" in warning
    assert "same SHA-256" in warning
    assert any("byte-identical" in w for w in json.loads((out / "summary.json").read_text())
               ["warnings"])
    sig = live[0].signals()
    assert len(sig) == 3
    for test, s in zip(live[0].tests, sig):
        assert s["t"].shape == s["accel"].shape == s["accel_model"].shape
        assert s["t"][0] >= test.prepared.window[0] and float(s["p"]) == test.least_squares.p
    with pytest.raises(DampfitError, match="stores summary.json and posterior.nc only"):
        dampfit.load(out).signals()
