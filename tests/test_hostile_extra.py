"""More hostile and careless input that dampfit already handles: one error line or a clean result.

Extra cases beyond ``test_hostile_input``/``_output``/``_fem`` (found by a hostile review):
odd recordings (reversed time, a million identical time stamps, constant or zero signal, a pure
Nyquist-rate alternation, formulas without cached values and 1000 sheets in an .xlsx, a ZIP
whose member names climb out of the folder), odd output names (a name too long for the lock
file, a symbolic link as ``export --out`` or ``simulate --out``), hostile values in
``summary.json`` rendered by ``dampfit report`` (markup in every kind of field), bad
``--quantile``/``--duration``/``--dt`` values and junk ``posterior.nc``/``signals.npz`` for
``export``/``verify``, and study files with absurd or malformed values. Every case is fast
(no full analysis): it fails before the work starts, or uses only the reader or the report.
"""

from __future__ import annotations

import json
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit.fem import opensees

from tests._support.hostile import assert_one_line_error, assert_unchanged, run, snapshot
from tests._support.fem import write_summary
from tests._support.fem import write_result

FAST = ["--no-figures", "--quiet", "--model", "viscous", "--mass", "5.3"]
EVIL = '<script>alert(1)</script><img src=x onerror=alert(2)>'


def _csv(path: Path, t, a, header='"Time (s)","acc z (m/s^2)"') -> Path:
    path.write_text(header + "\n" + "".join(f"{float(x)!r},{float(y)!r}\n" for x, y in zip(t, a)))
    return path


def _decay(n: int = 1000, fs: float = 100.0):
    t = np.arange(n) / fs
    a = 3.0 * np.exp(-0.3 * t) * np.cos(2 * np.pi * 5.0 * t)
    return t, a + 0.01 * np.random.default_rng(0).standard_normal(n)


def _analyze_fails(tmp_path, capsys, path, match, *extra):
    """``analyze PATH``: exit 2, one line containing ``match``, nothing in tmp_path changed."""
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", path, *FAST, "--out", tmp_path / "out", *extra], capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))
    return line


# -- odd recordings -----------------------------------------------------------------------------


def test_time_column_in_descending_order(tmp_path, capsys):
    t, a = _decay()
    path = _csv(tmp_path / "desc.csv", t[::-1], a[::-1])
    _analyze_fails(tmp_path, capsys, path, "time goes backwards at sample 1")


def test_a_million_identical_time_stamps(tmp_path, capsys):
    path = tmp_path / "same_t.csv"
    path.write_text('"Time (s)","acc z (m/s^2)"\n' + "1.0,0.5\n" * 1_000_000)
    _analyze_fails(tmp_path, capsys, path, "time is duplicated at sample 1")


@pytest.mark.parametrize("value", [9.81, 0.0], ids=["constant", "zero"])
def test_constant_signal(tmp_path, capsys, value):
    t, _ = _decay()
    path = _csv(tmp_path / "flat.csv", t, np.full(t.size, value))
    _analyze_fails(tmp_path, capsys, path, "too few distinct samples")


def test_alternating_values_at_the_nyquist_frequency(tmp_path, capsys):
    t, _ = _decay()
    path = _csv(tmp_path / "nyquist.csv", t, np.where(np.arange(t.size) % 2 == 0, 1e6, -1e6))
    _analyze_fails(tmp_path, capsys, path, "no resolvable oscillation")


def test_alternating_huge_and_tiny_values(tmp_path, capsys):
    t, _ = _decay()
    path = _csv(tmp_path / "alt.csv", t, np.where(np.arange(t.size) % 2 == 0, 1e300, 1e-300))
    _analyze_fails(tmp_path, capsys, path, "is not physical")


@pytest.mark.parametrize("n", [2, 3])
def test_two_or_three_samples(tmp_path, capsys, n):
    t, a = _decay()
    path = _csv(tmp_path / "short.csv", t[:n], a[:n])
    _analyze_fails(tmp_path, capsys, path, f"only {n} samples")


def _xlsx_header():
    return ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"]


def test_xlsx_with_formulas_and_no_cached_values(tmp_path, capsys):
    openpyxl = pytest.importorskip("openpyxl")
    t, _ = _decay()
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Accelerometer"
    ws.append(_xlsx_header())
    for i, x in enumerate(t):
        ws.append([float(x), 0.0, 0.0, f"=3*EXP(-0.3*A{i + 2})*COS(2*PI()*5*A{i + 2})"])
    wb.save(tmp_path / "formula.xlsx")
    _analyze_fails(tmp_path, capsys, tmp_path / "formula.xlsx", "missing or non-finite values")


def test_xlsx_with_a_thousand_sheets_and_a_bad_sheet_name(tmp_path, capsys):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    wb.active.title = "S0"
    wb.active.append(_xlsx_header())
    for k in range(1, 1000):
        wb.create_sheet(f"S{k}").append(_xlsx_header())
    wb.save(tmp_path / "many.xlsx")
    _analyze_fails(tmp_path, capsys, tmp_path / "many.xlsx", "has no single acceleration sheet")
    _analyze_fails(tmp_path, capsys, tmp_path / "many.xlsx", "has no sheet '../S5'", "--sheet", "../S5")


def test_zip_member_names_that_climb_out_are_only_read(tmp_path):
    """A phyphox ZIP whose members are named ``../../Accelerometer.csv`` and
    ``/tmp/…``: read from inside the archive, nothing is extracted anywhere."""
    t, a = _decay()
    body = ('"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)","Acceleration z (m/s^2)"\n'
            + "".join(f"{float(x)!r},0,0,{float(y)!r}\n" for x, y in zip(t, a)))
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    with zipfile.ZipFile(work / "trav.zip", "w") as z:
        z.writestr("../../Accelerometer.csv", body)
        z.writestr("meta/../../../etc/device.csv", "x\n")
    before = snapshot(tmp_path)
    rec = dampfit.read(work / "trav.zip")
    assert rec.n_samples == t.size
    assert np.allclose(rec.time, t)
    assert_unchanged(before, snapshot(tmp_path))


# -- odd output names ---------------------------------------------------------------------------


def test_out_name_too_long_for_the_lock_file_is_one_line(tmp_path, capsys, monkeypatch):
    t, a = _decay()
    _csv(tmp_path / "rec.csv", t, a)
    monkeypatch.chdir(tmp_path)
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", "rec.csv", *FAST, "--out", "y" * 250], capsys)
    assert_one_line_error(code, err, 2, "lock file")
    assert_unchanged(before, snapshot(tmp_path))


def test_export_out_link_to_a_foreign_file(tmp_path, capsys):
    """Without --force a link to an existing file is refused; with --force the link is
    replaced by the deck and the file it pointed to is untouched."""
    folder = write_summary(tmp_path / "r")
    (tmp_path / "mine.txt").write_text("precious")
    (tmp_path / "deck.k").symlink_to(tmp_path / "mine.txt")
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", "lsdyna", "--out", tmp_path / "deck.k"], capsys)
    assert_one_line_error(code, err, 2, "exists; use --force")
    assert_unchanged(before, snapshot(tmp_path))
    code, _, err = run(["export", folder, "--format", "lsdyna", "--out", tmp_path / "deck.k",
                        "--force"], capsys)
    assert code == 0, err
    assert (tmp_path / "mine.txt").read_text() == "precious"
    assert not (tmp_path / "deck.k").is_symlink()
    assert "*KEYWORD" in (tmp_path / "deck.k").read_text()


def test_simulate_force_over_links_keeps_their_targets(tmp_path, capsys):
    (tmp_path / "mine.txt").write_text("precious")
    (tmp_path / "sim.csv").symlink_to(tmp_path / "mine.txt")
    (tmp_path / "sim.truth.json").symlink_to(tmp_path / "mine.txt")
    code, _, err = run(["simulate", "--duration", "2", "--handheld", "0",
                        "--out", tmp_path / "sim.csv", "--force"], capsys)
    assert code == 0, err
    assert (tmp_path / "mine.txt").read_text() == "precious"
    assert not (tmp_path / "sim.csv").is_symlink() and not (tmp_path / "sim.truth.json").is_symlink()


def test_simulate_unknown_preset_path_is_one_line(tmp_path, capsys):
    before = snapshot(tmp_path)
    code, _, err = run(["simulate", "--preset", "../../etc/passwd", "--out", tmp_path / "x.csv"], capsys)
    assert_one_line_error(code, err, 2, "unknown preset")
    assert_unchanged(before, snapshot(tmp_path))


# -- export / verify with hostile values ------------------------------------------------------


@pytest.mark.parametrize("extra,match", [
    (["--quantile", "0"], "strictly between 0 and 1"),
    (["--quantile", "2"], "strictly between 0 and 1"),
    (["--duration", "-1"], "positive number of seconds"),
    (["--duration", "1e300"], "over 5e7 steps"),
    (["--quantile", "0.3"], "needs the posterior draws"),
], ids=["q0", "q2", "dur-neg", "dur-huge", "q-no-posterior"])
def test_export_bad_options(tmp_path, capsys, extra, match):
    folder = write_summary(tmp_path / "r")
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", "lsdyna", *extra], capsys)
    assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))


def test_export_junk_posterior_is_one_line(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    (folder / "posterior.nc").write_bytes(b"CDF\x01junk" * 10)
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", "calculix", "--quantile", "0.3"], capsys)
    assert_one_line_error(code, err, 2, "not a readable posterior")
    assert_unchanged(before, snapshot(tmp_path))


def test_export_out_below_a_regular_file(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    (tmp_path / "rec.csv").write_text("precious")
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", "lsdyna", "--out", tmp_path / "rec.csv" / "x.k"],
                       capsys)
    assert_one_line_error(code, err, 2, "does not exist")
    assert_unchanged(before, snapshot(tmp_path))


@pytest.mark.parametrize("setup,extra,match", [
    ("junk", [], "is not a readable .npz"),
    ("devzero", [], "signals.npz not found"),
    ("dir", [], "signals.npz not found"),
    (None, ["--dt", "1e300"], "Newmark period error"),
    (None, ["--dt", "1e-12"], "too many"),
], ids=["npz-junk", "npz-devzero", "npz-dir", "dt-huge", "dt-tiny"])
def test_verify_hostile_signals_and_steps(tmp_path, capsys, monkeypatch, setup, extra, match):
    monkeypatch.setattr(opensees, "unavailable", lambda: None)  # checks come before OpenSees runs
    folder = write_result(tmp_path / "r")
    sig = folder / "signals.npz"
    if setup == "junk":
        sig.write_bytes(b"PK\x03\x04junk")
    elif setup == "devzero":
        sig.unlink()
        sig.symlink_to("/dev/zero")
    elif setup == "dir":
        sig.unlink()
        sig.mkdir()
    before = snapshot(tmp_path)
    code, _, err = run(["verify", folder, *extra], capsys)
    assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))


# -- report: hostile strings in summary.json are inert ------------------------------------------


def test_markup_in_every_kind_of_summary_field_is_escaped(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    s = json.loads((folder / "summary.json").read_text())
    s["dampfit_version"] = EVIL
    s["input"].update({"path": f"/data/{EVIL}.csv", "format": EVIL, "notes": [EVIL]})
    s["diagnostics"] = {"converged": False, "warnings": [EVIL]}
    s["model_checks"] = {"warning": EVIL, "verdict": EVIL, "preferred_model": EVIL, EVIL: EVIL}
    s["provenance"] = {"options": {"axis": EVIL, "model": EVIL}, "python": EVIL,
                       "versions": {EVIL: EVIL}, "date": EVIL}
    s["noise_model"] = {EVIL: EVIL, "kind": [EVIL, {EVIL: EVIL}]}
    s["parameters"]["c"]["unit"] = EVIL
    s["baselines"] = {EVIL: {"c": EVIL, "note": EVIL, "agrees_with_posterior": False}}
    s["missing"] = {"c": EVIL}
    (folder / "summary.json").write_text(json.dumps(s))
    before = snapshot(tmp_path, exclude=[folder / "report.html", folder / "report.md"])
    code, _, err = run(["report", folder], capsys)
    assert code == 0, err
    assert_unchanged(before, snapshot(tmp_path, exclude=[folder / "report.html", folder / "report.md"]))
    html = (folder / "report.html").read_text()
    assert not re.search(r"<(script|img src=x)", html, re.I)
    assert "&lt;script&gt;" in html
    md = (folder / "report.md").read_text()
    fenced = re.sub(r"```bash\n.*?\n```", "", md, flags=re.S)  # shell commands are code blocks
    assert "<script" not in fenced.replace("\\<script", "")


def test_report_force_replaces_a_linked_report_not_its_target(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    (tmp_path / "page.html").write_text("<html>my page</html>")
    (folder / "report.html").symlink_to(tmp_path / "page.html")
    before = snapshot(tmp_path)
    code, _, err = run(["report", folder], capsys)
    assert_one_line_error(code, err, 2, "was not written by dampfit")
    assert_unchanged(before, snapshot(tmp_path))
    code, _, err = run(["report", folder, "--force"], capsys)
    assert code == 0, err
    assert (tmp_path / "page.html").read_text() == "<html>my page</html>"
    assert not (folder / "report.html").is_symlink()


@pytest.mark.parametrize("content,match", [
    (b"\xff\xfe{}", "cannot read"),
    (b"[1]", "not a dampfit summary"),
    (b'"just a string"', "not a dampfit summary"),
], ids=["not-utf8", "array", "string"])
def test_report_refuses_a_summary_that_is_not_an_object(tmp_path, capsys, content, match):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").write_bytes(content)
    before = snapshot(tmp_path)
    code, _, err = run(["report", folder], capsys)
    assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))


# -- study files with absurd or malformed values ------------------------------------------------

_STUDY = ('[study]\nreplicates = {rep}\nestimators = ["hilbert"]\nmass = 1.0\n{study}\n'
          "[grid]\n{grid}\n[fixed]\nf_n = 2.0\n{fixed}\n")


@pytest.mark.parametrize("fields,match", [
    ({"rep": "1000000000000000000000"}, "more than the limit of 100,000"),
    ({"rep": "-1"}, "replicates must be an integer ≥ 1"),
    ({"rep": '"3"'}, "replicates must be an integer ≥ 1"),
    ({"grid": "zeta = [nan]"}, "must be a finite number"),
    ({"grid": "zeta = [[0.01]]"}, "must be a finite number"),
    ({"grid": "zeta = [1.0]"}, "damping ratio zeta must be in [0, 1)"),
    ({"fixed": 'main_axis = "../../etc"'}, "main_axis must be one of x, y, z"),
    ({"fixed": "gaps = -5"}, "gaps must be a non-negative integer"),
    ({"study": "replicates = 2"}, "is not valid TOML"),
    ({"study": "seed = -1"}, "seed must be an integer ≥ 0"),
], ids=["replicates-huge", "replicates-negative", "replicates-string", "zeta-nan", "zeta-nested",
        "zeta-1", "main-axis-path", "gaps-negative", "duplicate-key", "seed-negative"])
def test_study_file_with_absurd_values(tmp_path, capsys, fields, match):
    values = {"rep": "2", "study": "", "grid": "zeta = [0.01]", "fixed": "", **fields}
    cfg = tmp_path / "bad.toml"
    cfg.write_text(_STUDY.format(**values))
    before = snapshot(tmp_path)
    code, _, err = run(["study", cfg, "--out", tmp_path / "bad.study"], capsys)
    assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))



# ----------------------------------------------------- report: what the probe broke, now held
def _minimal_result(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(text, encoding="utf-8", errors="surrogatepass")
    return folder


@pytest.mark.parametrize("case, text", [
    ("100,000 nested lists", '{"mass":{"value":5.3},"x":' + "[" * 100_000 + "]" * 100_000 + "}"),
    ("900 nested objects", '{"mass":{"value":5.3},"x":' + '{"a":' * 900 + "1" + "}" * 900 + "}"),
    ("an integer of 5000 digits", '{"parameters":{"c":{"q50":' + "9" * 5000 + "}}}"),
])
def test_report_of_a_hostile_summary_is_one_line(tmp_path, capsys, case, text):
    folder = _minimal_result(tmp_path / "r", text)
    before = snapshot(tmp_path)
    code, _, err = run(["report", folder], capsys)
    assert_one_line_error(code, err, match="cannot read")
    assert_unchanged(before, snapshot(tmp_path))


def test_report_renders_huge_numbers_and_broken_unicode(tmp_path, capsys):
    big = "1" + "0" * 400
    text = ('{"mass":{"value":' + big + '},"parameters":{"c":{"q05":' + big + ',"q50":' + big
            + ',"q95":' + big + '1,"sd":' + big + ',"r_hat":' + big + '}},'
            '"diagnostics":{"warnings":["\\udcff broken"]}}')
    folder = _minimal_result(tmp_path / "r", text)
    code, _, err = run(["report", folder], capsys)
    assert code == 0, err
    assert (folder / "report.html").read_text(encoding="utf-8")


def test_a_folder_name_with_blank_lines_cannot_inject_markdown_html(tmp_path, capsys):
    folder = _minimal_result(tmp_path / "r\n\n<img src=x onerror=alert(1)>\n\nz",
                             '{"mass":{"value":5.3},"parameters":{}}')
    code, _, err = run(["report", folder], capsys)
    assert code == 0, err
    fenced, raw = False, []
    for line in (folder / "report.md").read_text().splitlines():
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and line.lstrip().startswith("<img"):
            raw.append(line)  # outside a code block: rendered as HTML by Markdown viewers
    assert raw == []
    assert "<img src=x" not in (folder / "report.html").read_text()
