"""Hostile inputs to the FEM hand-off and the study grid: nothing injected, nothing written,
one error line.

* Injection: a result folder, a ``dampfit_version`` or an output file name holding Python,
  quotes, newlines, ``*KEYWORD`` cards or ``$`` must stay inert data in every generated file:
  the OpenSees script's module body is exactly the clean script's, and the LS-DYNA and
  CalculiX decks read back to exactly the clean card list and values.
* Bad summary.json values (booleans, strings, NaN, 1e400, negative, missing, not an object,
  truncated, huge, a device, a FIFO, a directory): ``dampfit export`` exits 2 with one line
  naming the field and the file, and writes nothing.
* ``dampfit verify`` without a usable OpenSeesPy: exit 2, one line, before any work.
* A study grid of 10¹⁰ scenarios: exit 2, one line, at once.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dampfit.fem import calculix, keyword, lsdyna, opensees, sanitize, sdof, units
from dampfit.errors import shown
from dampfit.fem.export import build
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, run_subprocess, snapshot
from tests._support.fem import write_summary
from tests._support.fem import write_result

PAYLOAD = '"""\nimport os; os.system("touch PWNED")\n"""'
HOSTILE_FOLDER = f"r{PAYLOAD}\r*INCLUDE\n$ x\n** y\u202e \u00e9 '"
HOSTILE_VERSION = f"0.1{PAYLOAD}\n*KEYWORD\n*END\n**HEADING\n$\\ '"

#: Text a sanitiser must neutralise.
HOSTILE_TEXTS = {
    "single quote": "it's",
    "double quote": 'say "hi"',
    "triple quote": 'a"""b',
    "trailing quote": 'end"',
    "backslash": "C:\\dir\\x",
    "trailing backslash": "dir\\",
    "newline": "one\ntwo",
    "carriage return": "one\rtwo",
    "keyword after newline": "x\n*INCLUDE\nevil.k",
    "keyword first": "*KEYWORD",
    "dollar": "$ not a comment\n$x",
    "calculix comment and card": "** c\n*STEP",
    "unicode": "Dämpfer—Prüfstand ✓ 振動",
    "bidi override and NUL": "abc\u202edef\x00ghi\u2028jkl",
    "lone surrogate": "bad\udcffname",
    "braces": "{os.system('x')}",
    "very long": "x" * 5000 + "\n*END",
}


def set_raw(folder: Path, dotted: str, raw: str | None) -> Path:
    """Replace the value at ``dotted`` (e.g. ``parameters.c.q50``) of folder/summary.json by the
    raw JSON text ``raw`` (so ``1e400`` or ``NaN`` is literally in the file); ``None`` deletes it."""
    path = folder / "summary.json"
    data = json.loads(path.read_text())
    *parents, last = dotted.split(".")
    node = data
    for key in parents:
        node = node[key]
    if raw is None:
        del node[last]
    else:
        node[last] = "@@RAW@@"
    path.write_text(json.dumps(data).replace('"@@RAW@@"', raw or ""))
    return folder


def export_fails(tmp_path, capsys, folder, match, fmt="lsdyna", extra=()):
    """``dampfit export`` on ``folder``: exit 2, one line containing ``match``, nothing changed."""
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", fmt, *extra], capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))
    return line


# -- injection into generated files ------------------------------------------------------------


@pytest.fixture
def hostile_result(tmp_path):
    """A result folder with a hostile name and a hostile dampfit_version in its summary."""
    folder = write_summary(tmp_path / HOSTILE_FOLDER)
    set_raw(folder, "dampfit_version", json.dumps(HOSTILE_VERSION))
    return folder


def _module_shape(text: str) -> list[str]:
    """Top-level statements of a script, string constants blanked (what the code *does*)."""
    tree = ast.parse(text)

    class Blank(ast.NodeTransformer):
        def visit_Constant(self, node):
            return ast.Constant("" if isinstance(node.value, str) else node.value)

    return [ast.dump(Blank().visit(stmt)) for stmt in tree.body]


def _assigned(text: str, name: str):
    for stmt in ast.parse(text).body:
        if isinstance(stmt, ast.Assign) and [getattr(t, "id", None) for t in stmt.targets] == [name]:
            return ast.literal_eval(stmt.value)
    raise AssertionError(f"{name} not assigned")


def test_opensees_script_from_a_hostile_folder_runs_no_injected_code(hostile_result, tmp_path,
                                                                       capsys):
    out = tmp_path / "deck" / 'model"""\nimport os\n""".py'
    out.parent.mkdir()
    before = snapshot(tmp_path, exclude=[out.parent])
    code, _, err = run(["export", hostile_result, "--format", "opensees", "--out", out,
                        "--duration", "2"], capsys)
    assert code == 0, err
    assert_unchanged(before, snapshot(tmp_path, exclude=[out.parent]))
    text = out.read_text(encoding="utf-8")
    clean, _ = build(write_summary(tmp_path / "clean"), "opensees", duration=2.0, name="m.py")
    # the module does exactly what the clean script does; the hostile text is only in strings
    assert _module_shape(text) == _module_shape(clean)
    assert _assigned(text, "SOURCE_FOLDER") == str(hostile_result.resolve())
    assert _assigned(text, "DAMPFIT_VERSION") == HOSTILE_VERSION
    doc = ast.get_docstring(ast.parse(text))
    assert "import os" in doc and '"' not in doc and "\\" not in doc
    # and running it creates no PWNED file (the payload would run before the OpenSees import)
    work = tmp_path / "work"
    work.mkdir()
    proc = subprocess.run([sys.executable, str(out), str(work / "h.csv")], cwd=work,
                          capture_output=True, text=True, timeout=120, check=False)
    assert not list(tmp_path.rglob("PWNED")) and not Path("PWNED").exists()
    if opensees.unavailable() is None:
        assert proc.returncode == 0, proc.stderr
        assert (work / "h.csv").stat().st_size > 1000
    else:  # it got as far as importing OpenSeesPy, i.e. past the docstring
        assert "openseespy" in proc.stderr.lower(), proc.stderr


@pytest.mark.usefixtures("requires_opensees")
def test_verify_of_a_hostile_folder_runs_the_exported_script(tmp_path, capsys):
    """verify runs the script export writes from a hostile folder (same SHA-256; that script's
    module is the clean one, above), and records the folder exactly in its export command."""
    folder = set_raw(write_result(tmp_path / HOSTILE_FOLDER), "dampfit_version",
                     json.dumps(HOSTILE_VERSION))
    code, _, err = run(["verify", folder], capsys)
    assert code == 0 and err == "", err
    code, _, err = run(["export", folder, "--format", "opensees"], capsys)
    assert code == 0, err
    script = folder / "sdof_opensees.py"
    rep = json.loads((folder / "verification.json").read_text())
    assert rep["script_sha256"] == hashlib.sha256(script.read_bytes()).hexdigest()
    clean, _ = build(write_result(tmp_path / "clean"), "opensees")
    assert _module_shape(script.read_text(encoding="utf-8")) == _module_shape(clean)
    assert shlex.split(rep["script"]["export_command"])[2] == str(folder.resolve())
    assert not list(tmp_path.rglob("PWNED")) and not Path("PWNED").exists()


@pytest.mark.parametrize("units", ["SI", "mm-ms-kg"])
def test_lsdyna_deck_from_a_hostile_folder_has_exactly_the_clean_cards(hostile_result, tmp_path,
                                                                        units):
    text, _ = build(hostile_result, "lsdyna", units=units, gravity=True)
    clean, _ = build(write_summary(tmp_path / "clean"), "lsdyna", units=units, gravity=True)
    assert [(name, len(data)) for name, data in keyword.parse_deck(text)] == \
           [(name, len(data)) for name, data in keyword.parse_deck(clean)]
    lines = text.splitlines()
    assert [x for x in lines if x.startswith("*")] == [x for x in clean.splitlines() if x.startswith("*")]
    assert all(len(x) <= 80 and x.isascii() and x.isprintable() for x in lines)
    got, want = lsdyna.read_deck(text), lsdyna.read_deck(clean)
    for key in ("mass", "k", "c", "g", "u0", "dt", "duration", "output_dt"):
        assert got[key] == want[key]
    assert "touch PWNED" in text  # still recorded, as comment text only
    assert all(x.startswith("$ ") for x in lines if "PWNED" in x or "INCLUDE" in x)


@pytest.mark.parametrize("units", ["SI", "mm-s-t"])
def test_calculix_deck_from_a_hostile_folder_has_exactly_the_clean_cards(hostile_result, tmp_path,
                                                                          units):
    text, _ = build(hostile_result, "calculix", units=units, gravity=True)
    clean, _ = build(write_summary(tmp_path / "clean"), "calculix", units=units, gravity=True)
    cards = lambda t: [x for x in t.splitlines() if not x.startswith("**")]  # noqa: E731
    assert cards(text) == cards(clean)  # every keyword and data line identical
    assert calculix.read_deck(text) == calculix.read_deck(clean)
    comments = [x for x in text.splitlines() if x.startswith("**")]
    assert any("PWNED" in x for x in comments)
    assert all(len(x) <= 80 and x.isascii() and x.isprintable() for x in text.splitlines())


def test_lsdyna_title_cannot_start_a_card():
    text = lsdyna.deck(sdof.Sdof(5.3, 619.0, 0.2, 0.04), units.get("SI"), 5.0, 1e-3, 2e-3,
                       title="*END\n*INCLUDE\nx" + "y" * 200)
    title = text.splitlines()[text.splitlines().index("*TITLE") + 1]
    assert not title.startswith(("*", "$")) and len(title) <= 80
    assert [n for n, _ in keyword.parse_deck(text)].count("END") == 1


@pytest.mark.parametrize("text", list(HOSTILE_TEXTS.values()), ids=list(HOSTILE_TEXTS))
def test_each_sanitiser_neutralises_hostile_text(text):
    py = sanitize.python_comment(text)
    assert py.isascii() and py.isprintable() and not any(c in py for c in "\"\\\n\r")
    assert len(py) <= sanitize.COMMENT_LIMIT
    ast.parse(f'"""{py}"""\n# {py}\n')  # inert in a docstring and in a comment
    lit = sanitize.python_literal(text)
    assert "\n" not in lit and "\r" not in lit and ast.literal_eval(lit) == text
    for lines, prefix in ((sanitize.lsdyna_comment(text), "$"),
                          (sanitize.calculix_comment(text), "**")):
        assert lines and all(x.startswith(prefix) and len(x) <= 80 for x in lines)
        assert all(x.isascii() and x.isprintable() for x in lines)
    title = sanitize.lsdyna_title(text)
    assert 0 < len(title) <= 80 and title.isascii() and not title.startswith(("*", "$"))
    one = shown(text)
    assert "\n" not in one and "\r" not in one and len(one) <= 200


def test_sanitisers_keep_ordinary_text_readable():
    assert sanitize.ascii_line("Messungen/Dämpfer 1") == "Messungen/Dampfer 1"
    assert sanitize.python_comment("/data/run 3") == "/data/run 3"
    assert shown("/data/run 3") == "/data/run 3"
    assert sanitize.lsdyna_comment("") == ["$"]


# -- bad summary.json values: exit 2, one line naming field and file, nothing written --------

BAD_VALUES = [
    ("parameters.c.q50", "true", "parameters.c.q50 must be a number, got true"),
    ("parameters.c.q50", '"0.2"', 'parameters.c.q50 must be a number, got "0.2"'),
    ("parameters.c.q50", "NaN", "parameters.c.q50 must be finite"),
    ("parameters.c.q50", "1e400", "parameters.c.q50 must be finite, got inf"),
    ("parameters.c.q50", "-1", "parameters.c.q50 must not be negative"),
    ("parameters.c.q50", "[0.2]", "parameters.c.q50 must be a number, got an array"),
    ("parameters.c.q50", "1" + "0" * 5000, "not readable JSON"),
    ("parameters.c.q50", "200.0", "critical damping"),
    ("parameters.k.q50", "0", "parameters.k.q50 must be positive"),
    ("parameters.k.q50", "Infinity", "parameters.k.q50 must be finite"),
    ("parameters.k.q50", "1e300", "parameters.k.q50 = 1e+300 is beyond"),
    ("parameters.u0.q50", "{}", "parameters.u0.q50 must be a number, got an object"),
    ("mass.value", "true", "mass.value must be a number, got true"),
    ("mass.value", "-5.3", "mass.value must be positive"),
    ("mass.sd", '"small"', "mass.sd must be a number"),
    ("window.end_s", "false", "window.end_s must be a number, got false"),
    ("window.end_s", "1.0", "window.end_s (1) must be after window.start_s"),
    ("input.sample_rate_hz", "true", "input.sample_rate_hz must be a number"),
    ("dampfit_version", "5", "'dampfit_version' must be a string"),
    ("parameters.c", None, "has a mass but no parameters.c"),
    ("parameters.u0", '"4 cm"', 'parameters.u0 must be an object with q05/q50/q95, got "4 cm"'),
    ("window", '"0-10 s"', "'window' must be an object"),
]


@pytest.mark.parametrize("dotted,raw,match", BAD_VALUES, ids=[f"{d}={r if r is None else r[:12]}"
                                                             for d, r, _ in BAD_VALUES])
def test_export_refuses_a_bad_summary_value(tmp_path, capsys, dotted, raw, match):
    folder = set_raw(write_summary(tmp_path / "r"), dotted, raw)
    line = export_fails(tmp_path, capsys, folder, match)
    if "must" in match:
        assert "summary.json" in line  # names the file


@pytest.mark.parametrize("fmt", ["opensees", "calculix"])
def test_every_format_validates_before_writing(tmp_path, capsys, fmt):
    folder = set_raw(write_summary(tmp_path / "r"), "parameters.c.q50", "true")
    export_fails(tmp_path, capsys, folder, "parameters.c.q50 must be a number", fmt=fmt)


@pytest.mark.parametrize("content,match", [
    (b"[1, 2, 3]", "holds a JSON array, not an object"),
    (b'"summary"', "holds a JSON string, not an object"),
    (b'{"parameters": {"c": {"q50": 0.2', "not readable JSON"),
    (b"", "not readable JSON"),
    (b"\xff\xfe{}", "not UTF-8"),
    (b"[" * 100_000 + b"]" * 100_000, "nested too deeply"),
    (b'{"parameters": 3}', "has no 'parameters'"),
], ids=["list", "string", "truncated", "empty", "not-utf8", "deep", "parameters-number"])
def test_export_refuses_a_summary_that_is_not_an_object(tmp_path, capsys, content, match):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").write_bytes(content)
    export_fails(tmp_path, capsys, folder, match)


def test_export_refuses_a_60_mb_summary_without_reading_it(tmp_path, capsys):
    folder = tmp_path / "r"
    folder.mkdir()
    with open(folder / "summary.json", "wb") as fh:
        fh.truncate(60 * 2**20)  # sparse
    t0 = time.perf_counter()
    export_fails(tmp_path, capsys, folder, "larger than 50 MB")
    assert time.perf_counter() - t0 < 10


def test_export_refuses_a_summary_linked_to_dev_zero(tmp_path, capsys):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").symlink_to("/dev/zero")
    export_fails(tmp_path, capsys, folder, "not a regular file")


def test_export_refuses_a_summary_that_is_a_directory(tmp_path, capsys):
    folder = tmp_path / "r"
    (folder / "summary.json").mkdir(parents=True)
    export_fails(tmp_path, capsys, folder, "is a directory, not a file")


def test_export_does_not_block_on_a_fifo(tmp_path):
    """A FIFO named summary.json (nobody writes to it) must not hang the process."""
    folder = tmp_path / "r"
    folder.mkdir()
    os.mkfifo(folder / "summary.json")
    os.mkfifo(tmp_path / "fifo_folder")
    before = snapshot(tmp_path)
    code, _, err = run_subprocess(["export", folder, "--format", "lsdyna"], timeout=60)
    assert_one_line_error(code, err, 2, "not a regular file")
    code, _, err = run_subprocess(["export", tmp_path / "fifo_folder", "--format", "lsdyna"], timeout=60)
    assert_one_line_error(code, err, 2, "is not a directory")
    assert_unchanged(before, snapshot(tmp_path))


def test_hostile_folder_name_in_an_error_stays_one_line(tmp_path, capsys):
    folder = set_raw(write_summary(tmp_path / "a\nb\rc"), "parameters.c.q50", "true")
    line = export_fails(tmp_path, capsys, folder, "parameters.c.q50")
    assert "a\\nb\\rc" in line


# -- verify without OpenSees, and on hostile summaries -----------------------------------------


def test_verify_without_opensees_is_one_line_before_any_work(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(opensees, "unavailable", lambda: opensees.BLAS_REASON)
    folder = write_result(tmp_path / "r")
    before = snapshot(tmp_path)
    code, out, err = run(["verify", folder], capsys)
    assert_one_line_error(code, err, 2, "sudo apt-get install libblas3 liblapack3")
    assert out == ""
    assert_unchanged(before, snapshot(tmp_path))


def test_verify_without_openseespy_installed_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(opensees, "unavailable", lambda: opensees.NOT_INSTALLED_REASON)
    before = snapshot(tmp_path)
    code, _, err = run(["verify", tmp_path], capsys)
    assert_one_line_error(code, err, 2, "pip install 'dampfit[fem]'")
    assert_unchanged(before, snapshot(tmp_path))


def test_verify_refuses_a_bad_summary_value(tmp_path, capsys, monkeypatch):
    """With OpenSees (pretended) available, a bad summary is still one line, nothing written."""
    monkeypatch.setattr(opensees, "unavailable", lambda: None)
    folder = set_raw(write_result(tmp_path / "r"), "parameters.p.q50", '"fast"')
    before = snapshot(tmp_path)
    code, _, err = run(["verify", folder], capsys)
    assert_one_line_error(code, err, 2, 'parameters.p.q50 must be a number, got "fast"')
    assert_unchanged(before, snapshot(tmp_path))


# -- study grid ---------------------------------------------------------------------------------


def test_study_grid_of_1e10_scenarios_is_refused_at_once(tmp_path, capsys):
    axes = ["zeta", "u0", "duration", "sample_rate", "jitter", "noise_density", "drift",
            "quantization", "tilt_deg", "azimuth_deg"]
    grid = "\n".join(f"{a} = [{', '.join(str(0.01 * (i + 1)) for i in range(10))}]" for a in axes)
    cfg = tmp_path / "huge.toml"
    cfg.write_text('[study]\nreplicates = 3\nestimators = ["hilbert"]\nmass = 1.0\n'
                   f"[grid]\n{grid}\n[fixed]\nf_n = 2.0\n")
    before = snapshot(tmp_path)
    t0 = time.perf_counter()
    code, _, err = run(["study", cfg, "--out", tmp_path / "huge.study"], capsys)
    assert time.perf_counter() - t0 < 10
    line = assert_one_line_error(code, err, 2, "30,000,000,000 runs")
    assert "10,000,000,000 scenarios × 3 replicates" in line and "100,000" in line
    assert_unchanged(before, snapshot(tmp_path))


def test_a_huge_study_config_built_in_python_is_refused_too():
    from dampfit.errors import InputError
    from dampfit.study.config import StudyConfig

    cfg = StudyConfig("big", 1, 0, ("hilbert",), 1.0, {},
                      {f"a{i}": list(range(100)) for i in range(5)}, {"f_n": 2.0, "zeta": 0.01})
    assert cfg.n_runs == 10**10
    with pytest.raises(InputError, match="10,000,000,000 runs"):
        cfg.tasks()
