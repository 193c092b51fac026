"""Hostile inputs to the FEM hand-off (``export``, ``verify``): nothing injected, nothing written,
one error line.

* Injection: a result folder, a ``dampfit_version`` or an output file name holding Python,
  quotes, newlines, ``*KEYWORD`` cards or ``$`` must stay inert data in every generated file:
  the OpenSees script's module body is exactly the clean script's, and the LS-DYNA and
  CalculiX decks read back to exactly the clean card list and values.
* Bad summary.json values (booleans, strings, NaN, 1e400, negative, missing, not an object,
  truncated, huge, a device, a FIFO, a directory): ``dampfit export`` exits 2 with one line
  naming the field and the file, and writes nothing.
* ``dampfit verify`` without a usable OpenSeesPy: exit 2, one line, before any work.
* ``export``/``verify`` with hostile options and files: bad ``--quantile``/``--duration``/
  ``--dt``, junk ``posterior.nc``/``signals.npz`` (including a zip bomb and an ``.npy`` header
  declaring more than the file holds), an ``--out`` that exists, is a link, is too long or lies
  below a regular file; ``--force`` replaces a link, never its target.

Cases that would need OpenSeesPy only to get past ``verify``'s availability check pretend it
is there (``opensees.unavailable`` → None): they must fail before OpenSees would run.
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
import zipfile
from pathlib import Path

import pytest

from dampfit.fem import calculix, keyword, lsdyna, opensees, sanitize, sdof, units
from dampfit.errors import shown
from dampfit.fem.export import Deck, build
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, run_subprocess, snapshot
from tests._support.hostile import LONG, fails
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
    clean, _ = build(write_summary(tmp_path / "clean"), "opensees", Deck(duration=2.0), name="m.py")
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
    code, _, err = run(["verify", folder, "--quiet"], capsys)
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
    text, _ = build(hostile_result, "lsdyna", Deck(units=units, gravity=True))
    clean, _ = build(write_summary(tmp_path / "clean"), "lsdyna", Deck(units=units, gravity=True))
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
    text, _ = build(hostile_result, "calculix", Deck(units=units, gravity=True))
    clean, _ = build(write_summary(tmp_path / "clean"), "calculix", Deck(units=units, gravity=True))
    cards = lambda t: [x for x in t.splitlines() if not x.startswith("**")]  # noqa: E731
    assert cards(text) == cards(clean)  # every keyword and data line identical
    assert calculix.read_deck(text) == calculix.read_deck(clean)
    comments = [x for x in text.splitlines() if x.startswith("**")]
    assert any("PWNED" in x for x in comments)
    assert all(len(x) <= 80 and x.isascii() and x.isprintable() for x in text.splitlines())


def test_lsdyna_title_cannot_start_a_card():
    text = lsdyna.deck(sdof.Sdof(5.3, 619.0, 0.2, 0.04), units.get("SI"), (5.0, 1e-3, 2e-3),
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
    # dampfit's own verdicts reach deck headers: their symbols are spelled, not turned into "?"
    assert (sanitize.ascii_line("ζ changes by at most 0.35 % — F = c·|v|^α, ≤ 2 µm")
            == "zeta changes by at most 0.35 % - F = c*|v|^alpha, <= 2 um")


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


# -- export / verify: hostile values, --out, junk or oversized signals, names too long ------


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


@pytest.fixture
def no_opensees_needed(monkeypatch):
    """verify's availability check passes; OpenSees itself must not be reached."""
    monkeypatch.setattr(opensees, "unavailable", lambda: None)

    def boom(*a, **k):
        raise AssertionError("OpenSees ran although the case must fail before it")

    monkeypatch.setattr(opensees, "free_decay", boom)

def test_verify_refuses_an_existing_out_file_without_force(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (tmp_path / "thesis.png").write_bytes(b"my figure")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "thesis.png"],
          "exists; use --force")

def test_verify_refuses_a_symlinked_out_without_force(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (tmp_path / "precious.png").write_bytes(b"keep")
    (tmp_path / "fig.png").symlink_to(tmp_path / "precious.png")
    (tmp_path / "dangling.png").symlink_to(tmp_path / "nowhere" / "x.png")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "fig.png"], "symbolic link")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "dangling.png"], "symbolic link")

@pytest.mark.parametrize("name", ["fig.txt", "fig.docx", "fig.exe"])
def test_verify_refuses_an_unknown_figure_format_before_any_work(tmp_path, capsys,
                                                                  no_opensees_needed, name):
    folder = write_result(tmp_path / "r")
    line = fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / name], "unknown format")
    assert ".png" in line and ".pdf" in line

def test_verify_refuses_a_name_too_long(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / f"{LONG}.png"], "too long")

@pytest.mark.usefixtures("requires_opensees")
def test_verify_force_replaces_a_link_not_its_target(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    (tmp_path / "precious.png").write_bytes(b"keep")
    link = tmp_path / "fig.png"
    link.symlink_to(tmp_path / "precious.png")
    code, _, err = run(["verify", folder, "--out", link, "--force", "--quiet"], capsys)
    assert code == 0 and err == "", err
    assert (tmp_path / "precious.png").read_bytes() == b"keep"
    assert not link.is_symlink() and link.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

def test_verify_bad_out_with_a_foreign_report_writes_nothing(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (folder / "report.html").write_text("<p>my own report</p>")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "f.txt"], "unknown format")

@pytest.mark.usefixtures("requires_opensees")
def test_verify_leaves_a_foreign_report_alone_and_says_so(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    (folder / "report.html").write_text("<p>my own report</p>")
    (folder / "report.md").write_text("# mine\n")
    before = snapshot(tmp_path, exclude=[folder / "verification.json", folder / "verify.png"])
    code, out, err = run(["verify", folder, "--quiet"], capsys)
    assert code == 0 and err == "", err
    assert_unchanged(before, snapshot(tmp_path, exclude=[folder / "verification.json",
                                                         folder / "verify.png"]))
    assert "report not updated" in out and "not written by dampfit" in out
    assert (folder / "verification.json").is_file()

def test_verify_on_a_bad_folder_prints_exactly_one_line_in_a_real_process(tmp_path):
    before = snapshot(tmp_path)
    code, out, err = run_subprocess(["verify", tmp_path / "missing"], timeout=300)
    assert_one_line_error(code, err, 2)
    assert "Terminating" not in err and out == ""
    assert_unchanged(before, snapshot(tmp_path))

@pytest.mark.usefixtures("requires_opensees")
def test_a_successful_verify_prints_nothing_on_stderr_in_a_real_process(tmp_path):
    folder = write_result(tmp_path / "r")
    code, out, err = run_subprocess(["verify", folder], timeout=300)
    assert code == 0, err
    # only verify's own progress lines: not even OpenSees' "Process 0 Terminating"
    assert all(line.startswith("verify: ") for line in err.splitlines()), err
    code, out, err = run_subprocess(["verify", folder, "--quiet", "--force"], timeout=300)
    assert code == 0 and err == "", err  # --quiet: nothing at all
    assert "decay rate p" in out

def _npz_with_member(path: Path, name: str, header_shape: tuple, n_bytes: int,
                     compress: bool) -> None:
    """An .npz whose member ``name`` has a float64 header of ``header_shape`` followed by
    ``n_bytes`` zero bytes, streamed (never held in memory)."""
    import io

    from numpy.lib import format as npformat

    head = io.BytesIO()
    npformat.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                           "shape": header_shape})
    chunk = bytes(2**20)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED) as zf:
        with zf.open(name, "w", force_zip64=True) as fp:
            fp.write(head.getvalue())
            for start in range(0, n_bytes, len(chunk)):
                fp.write(chunk[:n_bytes - start])

def test_verify_refuses_a_zip_bomb_signals_npz_before_loading(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    path = folder / "signals.npz"
    # 160 MB of zeros in a < 1 MB file: np.load would allocate all of it
    _npz_with_member(path, "t.npy", (20_000_000,), 160_000_000, compress=True)
    assert path.stat().st_size < 2**20
    t0 = time.perf_counter()
    line = fails(tmp_path, capsys, ["verify", folder], "zip bomb")
    assert "signals.npz" in line and time.perf_counter() - t0 < 10

def test_verify_refuses_an_npy_header_declaring_more_than_the_file_holds(tmp_path, capsys,
                                                                          no_opensees_needed):
    folder = write_result(tmp_path / "r")
    _npz_with_member(folder / "signals.npz", "t.npy", (10**8,), 800, compress=False)
    line = fails(tmp_path, capsys, ["verify", folder], "declares shape (100000000,)")
    assert "signals.npz" in line

def test_export_refuses_a_file_name_too_long(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    fails(tmp_path, capsys, ["export", folder, "--format", "lsdyna", "--out", tmp_path / f"{LONG}.k"],
          "File name too long")

def test_export_onto_a_dangling_link_needs_force_and_replaces_the_link(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    link = tmp_path / "deck.k"
    target = tmp_path / "elsewhere" / "deck.k"
    link.symlink_to(target)
    fails(tmp_path, capsys, ["export", folder, "--format", "lsdyna", "--out", link],
          "exists; use --force to replace it (it is a symbolic link")
    code, _, err = run(["export", folder, "--format", "lsdyna", "--out", link, "--force"], capsys)
    assert code == 0, err
    assert not link.is_symlink() and link.read_text().startswith("*KEYWORD")
    assert not (tmp_path / "elsewhere").exists()


# -- the damper section (issue 32) ----------------------------------------------------------

HOSTILE_TEXT = f"amplitude-dependent{PAYLOAD}\n*INCLUDE\nevil.k\n** x\n$ y {{os.system('x')}}"


def _damper_folder(tmp_path, name, law="power", **sec):
    from tests._support.fem import write_damper_summary

    folder = write_damper_summary(tmp_path / name, law)
    path = folder / "summary.json"
    data = json.loads(path.read_text())
    data["damper"].update(sec)
    path.write_text(json.dumps(data))
    return folder


@pytest.mark.parametrize("law", ["power", "coulomb", "quadratic"])
@pytest.mark.parametrize("fmt", ["lsdyna", "opensees", "calculix"])
def test_hostile_damper_texts_stay_inert_in_every_deck(tmp_path, law, fmt):
    """Verdict, design-amplitude source and the command line hold code, quotes and cards: the
    deck is the clean deck's cards (LS-DYNA, CalculiX) or statements (OpenSees), ASCII, finite."""
    clean = _damper_folder(tmp_path, "clean", law)
    evil = _damper_folder(tmp_path, "evil", law, verdict=HOSTILE_TEXT, design_amplitude={
        "displacement_m": 0.026, "source": HOSTILE_TEXT})
    a, _ = build(clean, fmt, command="dampfit export clean")
    b, _ = build(evil, fmt, command=f"dampfit export {HOSTILE_FOLDER}")
    assert b.isascii() and "nan" not in b.lower().replace("nonlinear", "")
    if fmt == "opensees":
        assert _module_shape(a) == _module_shape(b)
    elif fmt == "lsdyna":
        assert keyword.parse_deck(a) == keyword.parse_deck(b)
        assert all(len(line) <= 80 for line in b.splitlines())
        assert lsdyna.read_deck(a)["damper_curve"] == lsdyna.read_deck(b)["damper_curve"]
    else:
        cards = lambda t: [x for x in t.splitlines() if not x.startswith("**")]  # noqa: E731
        assert cards(a) == cards(b)


BAD_DAMPER = [
    ("damper", '"power"', "damper must be an object"),
    ("damper.status", '"maybe"', "damper.status must be one of"),
    ("damper.law", '"rubber"', "damper.law must be one of"),
    ("damper.coefficients.alpha.q50", "NaN", "damper.coefficients.alpha.q50 must be finite"),
    ("damper.coefficients.alpha.q50", "7.5", "outside (0, 3]"),
    ("damper.coefficients.alpha.q50", "-0.5", "must be positive"),
    ("damper.coefficients.c_alpha.q50", "1e400", "must be finite"),
    ("damper.coefficients.c_alpha.q50", "true", "must be a number, got true"),
    ("damper.coefficients.c_alpha", None, "has no 'c_alpha'"),
    ("damper.measured_range.velocity_m_s", "[2, 1]", "is not [low, high]"),
    ("damper.measured_range.velocity_m_s", "[0, 1]", "must be positive"),
    ("damper.measured_range.velocity_m_s", '"fast"', "must be [low, high]"),
    ("damper.c_linear.q50", '"0.4"', "damper.c_linear.q50 must be a number"),
    ("damper.design_amplitude.displacement_m", "-1", "must be positive"),
]


@pytest.mark.parametrize("dotted,raw,match", BAD_DAMPER,
                         ids=[f"{d}={r}" for d, r, _ in BAD_DAMPER])
@pytest.mark.parametrize("fmt", ["lsdyna", "opensees"])
def test_export_refuses_a_bad_damper_value(tmp_path, capsys, dotted, raw, match, fmt):
    folder = set_raw(_damper_folder(tmp_path, "r"), dotted, raw)
    export_fails(tmp_path, capsys, folder, match, fmt=fmt)


@pytest.mark.parametrize("extra,match", [
    (["--law", "x\n*INCLUDE"], "--law"),
    (["--force-law", '"""'], "--force-law"),
    (["--law", "viscous", "--force-law", "power"], "not both"),
])
def test_export_bad_law_options_are_one_line(tmp_path, capsys, extra, match):
    export_fails(tmp_path, capsys, _damper_folder(tmp_path, "r"), match, extra=extra)


def test_hostile_huge_coefficients_give_finite_cards_or_one_line(tmp_path, capsys):
    """A damper at 1e300: a card that cannot hold it is one error line, never inf or nan."""
    folder = set_raw(_damper_folder(tmp_path, "r"), "damper.coefficients.c_alpha.q50", "1e300")
    before = snapshot(tmp_path)
    code, _, err = run(["export", folder, "--format", "lsdyna"], capsys)
    if code == 0:
        text = (folder / "sdof_lsdyna.k").read_text()
        assert "inf" not in text.lower() and "nan" not in text.lower().replace("nonlinear", "")
    else:
        assert_one_line_error(code, err, 2)
        assert_unchanged(before, snapshot(tmp_path))


@pytest.mark.parametrize("extra,match", [
    (["--draws", "0"], "from 1 to 1000"), (["--draws", "1001"], "from 1 to 1000"),
    (["--draws", "-5"], "from 1 to 1000"), (["--draws", "1e3"], "invalid int value"),
    (["--draws", "10**9"], "invalid int value"),
])
def test_hostile_draw_counts_are_one_line_before_any_work(tmp_path, capsys, extra, match,
                                                          no_opensees_needed):
    folder = _damper_folder(tmp_path, "r")
    for command in (["export", folder, "--format", "lsdyna"], ["verify", folder]):
        before = snapshot(tmp_path)
        code, _, err = run([*command, *extra], capsys)
        assert_one_line_error(code, err, 2, match)
        assert_unchanged(before, snapshot(tmp_path))


def test_export_draws_out_that_is_a_file_or_foreign_folder_is_refused(tmp_path, capsys):
    folder = _damper_folder(tmp_path, "r")
    (tmp_path / "afile").write_text("keep")
    export_fails(tmp_path, capsys, folder, "not a folder",
                 extra=["--draws", "2", "--out", str(tmp_path / "afile"), "--force"])
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    export_fails(tmp_path, capsys, folder, "not a dampfit draws export",
                 extra=["--draws", "2", "--out", str(foreign), "--force"])
