"""Hostile result folders (issue 19, item 9): reading a result folder is bounded.

A result folder is read by ``report``, ``export``, ``verify`` and :func:`dampfit.load`; whatever
someone put into it — a FIFO or a link to ``/dev/zero`` under a file's name, a link to a file
outside the folder, a sparse multi-GB file, a posterior.nc that declares 40 GB, a summary of
millions of warnings, any edited field — the command ends promptly with exit 0 (an optional
file is reported as unusable) or exit 2 and one line, and embeds nothing from outside the
folder. Cases that would hang or exhaust memory if they regressed run in a child process with
a timeout and an address-space limit, so a regression fails the test instead of the machine.

``dampfit report`` of a hostile summary.json: markup in every kind of field, a folder name with
blank lines and HTML, 100,000 nested lists, a 5000-digit integer, broken Unicode, a summary that
is not an object, a linked report: escaped, rendered, or one line.
"""

from __future__ import annotations

import base64
import json
import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit.errors import InputError
from dampfit.output.document import PNG_MAGIC
from dampfit.result.folder import load_signals
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, snapshot
from tests._support.fem import write_summary
from tests._support.fem import write_result
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401 (autouse)

#: Address space [bytes] of a bounded child: far below what the hostile files would claim.
CHILD_MEMORY = 3 * 2**30


#: Prologue of a bounded child: its own address-space limit, set before anything else.
_LIMIT = ("import resource, sys\n"
          f"resource.setrlimit(resource.RLIMIT_AS, ({CHILD_MEMORY}, {CHILD_MEMORY}))\n")


def run_bounded(argv, timeout: float = 120, code: str | None = None) -> tuple[int, str, str]:
    """``dampfit ARGV`` (or the Python ``code``) in a child with a timeout and a memory limit."""
    if code is None:
        code = ("import runpy\nsys.argv = ['dampfit', *sys.argv[1:]]\n"
                "runpy.run_module('dampfit', run_name='__main__', alter_sys=True)\n")
    env = {**os.environ, "MPLBACKEND": "Agg", "DAMPFIT_JAX_CACHE": "off",
           "PYTHONPATH": os.pathsep.join(sys.path)}
    proc = subprocess.run([sys.executable, "-c", _LIMIT + code, *map(str, argv or [])],
                          capture_output=True, text=True, timeout=timeout, env=env,
                          stdin=subprocess.DEVNULL)
    return proc.returncode, proc.stdout, proc.stderr


def _png(tag: bytes) -> bytes:
    """A file that passes the report's PNG check (magic, IHDR, size), ending in ``tag``."""
    return PNG_MAGIC + b"\x00\x00\x00\rIHDR" + struct.pack(">II", 8, 8) + b"\x08\x02\x00\x00\x00" + tag


def _posterior(path: Path) -> None:
    import arviz as az

    rng = np.random.default_rng(0)
    az.from_dict(posterior={"c": 0.2 + 0.01 * rng.standard_normal((2, 50)),
                            "k": 619 + 3 * rng.standard_normal((2, 50))}
                 ).to_netcdf(str(path), engine="h5netcdf")


# ----------------------------------------------------------------------- figures and reports
@pytest.mark.parametrize("kind", ["fifo", "link-to-dev-zero", "directory"])
def test_a_figure_that_is_not_a_regular_file_never_blocks_the_report(tmp_path, kind):
    folder = write_summary(tmp_path / "r")
    fig = folder / "fit.png"
    if kind == "fifo":
        os.mkfifo(fig)
    elif kind == "directory":
        fig.mkdir()
    else:
        fig.symlink_to("/dev/zero")
    code, out, err = run_bounded(["report", folder], timeout=120)
    assert code == 0, err
    html = (folder / "report.html").read_text()
    assert "fit.png is not in this folder" in html and "data:image/png" not in html


def test_a_linked_figure_from_outside_the_folder_is_not_embedded(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    secret = _png(b"private-holiday-photo")
    (tmp_path / "elsewhere.png").write_bytes(secret)
    (folder / "fit.png").symlink_to(tmp_path / "elsewhere.png")
    (folder / "signal.png").write_bytes(_png(b"a figure of the folder"))
    code, _, err = run(["report", folder], capsys)
    assert code == 0, err
    html = (folder / "report.html").read_text()
    assert base64.b64encode(secret).decode() not in html
    assert base64.b64encode(_png(b"a figure of the folder")).decode() in html  # its own: shown
    assert "**fit.png**: fit.png is not in this folder" in (folder / "report.md").read_text()


@pytest.mark.parametrize("kind", ["fifo", "link-to-dev-zero"])
def test_a_report_html_that_is_not_a_regular_file_never_blocks_report_or_verify(tmp_path, kind):
    folder = write_summary(tmp_path / "r")
    html = folder / "report.html"
    if kind == "fifo":
        os.mkfifo(html)
    else:
        html.symlink_to("/dev/zero")
    code, _, err = run_bounded(["report", folder], timeout=120)
    assert_one_line_error(code, err, 2, "was not written by dampfit")
    assert not html.is_file()  # left alone
    # verify's "did dampfit write it" check (run after the OpenSees step) decides at once
    code, out, err = run_bounded(None, timeout=120, code=(
        "from pathlib import Path; from dampfit.fem.verify import _report_refresh; "
        f"print(_report_refresh(Path({str(folder)!r})))"))
    assert code == 0 and "was not written by dampfit" in out, err
    code, _, err = run_bounded(["report", folder, "--force"], timeout=120)
    assert code == 0, err
    assert html.is_file() and not html.is_symlink()


def test_a_sparse_6_gb_verification_json_is_not_read(tmp_path):
    folder = write_summary(tmp_path / "r")
    with open(folder / "verification.json", "wb") as fh:
        fh.truncate(6 * 2**30)  # sparse: no disk used
    code, _, err = run_bounded(["report", folder], timeout=120)
    assert code == 0, err
    html = (folder / "report.html").read_text()
    assert "verification.json could not be read" in html and "larger than 16 MB" in html


@pytest.mark.parametrize("kind", ["fifo", "link", "deep"])
def test_an_unusable_verification_json_is_reported_not_followed(tmp_path, capsys, kind):
    folder = write_summary(tmp_path / "r")
    ver = folder / "verification.json"
    if kind == "fifo":
        os.mkfifo(ver)
    elif kind == "link":
        (tmp_path / "mine.json").write_text('{"secret": "do not show"}')
        ver.symlink_to(tmp_path / "mine.json")
    else:
        ver.write_text("[" * 100000 + "]" * 100000)
    code, _, err = run(["report", folder], capsys)
    assert code == 0, err
    html = (folder / "report.html").read_text()
    assert "verification.json could not be read" in html and "do not show" not in html


# ----------------------------------------------------------------------- summary.json
def test_a_summary_linked_from_outside_is_refused(tmp_path, capsys):
    outside = write_summary(tmp_path / "real")
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").symlink_to(outside / "summary.json")
    before = snapshot(tmp_path)
    code, _, err = run(["report", folder], capsys)
    assert_one_line_error(code, err, 2, "summary.json is a symbolic link")
    assert_unchanged(before, snapshot(tmp_path))


@pytest.mark.heavy
def test_two_million_warnings_are_shown_once_each_and_bounded(tmp_path):
    """A 22 MB summary of 2,000,000 short warnings (half of them repeated): the report ends
    well within the timeout (the de-duplication was quadratic: > 300 s) and shows at most
    100 warnings and how many more there are."""
    folder = write_summary(tmp_path / "r")
    s = json.loads((folder / "summary.json").read_text())
    s["diagnostics"] = {"converged": True, "warnings": [f"w{i % 1_000_000}" for i in range(2_000_000)]}
    (folder / "summary.json").write_text(json.dumps(s))
    assert (folder / "summary.json").stat().st_size > 20 * 2**20
    code, _, err = run_bounded(["report", folder], timeout=240)
    assert code == 0, err
    md = (folder / "report.md").read_text()
    assert "… and 999900 more distinct warnings (see summary.json)" in md
    assert md.count("Warning: ") <= 101


def _edits():
    """(section, value) pairs: each top-level section of a real summary replaced."""
    values = [1e308, -1, "x</script>", [1, [2]], {"a": {"b": None}}, None, True]
    sections = ["input", "window", "band", "mass", "parameters", "missing", "least_squares",
                "baselines", "noise_model", "crlb", "model_checks", "damping_models",
                "amplitude_curve", "c_equivalent", "fit", "preprocessing", "diagnostics",
                "provenance", "dominant_frequency_hz", "schema_version", "dampfit_version"]
    return [(s, v) for s in sections for v in values]


@pytest.mark.heavy
def test_every_edited_section_is_exit_0_or_one_line_exit_2(tmp_path, capsys, analysed):
    """Report and export of a real summary with any top-level section replaced by a value of
    another type: never a traceback or an internal error (exit 1)."""
    an, _ = analysed
    base = an.summary()
    folder = tmp_path / "r"
    folder.mkdir()
    for section, value in _edits():
        s = json.loads(json.dumps(base))
        s[section] = value
        (folder / "summary.json").write_text(json.dumps(s))
        for argv in (["report", folder, "--force"], ["export", folder, "--format", "opensees",
                                                     "--force"]):
            code, _, err = run(argv, capsys)
            assert code in (0, 2), (section, value, argv[0], err)
            if code == 2:
                assert_one_line_error(code, err, 2)


# ----------------------------------------------------------------------- posterior and signals
def test_a_posterior_declaring_40_gb_is_refused_before_allocation(tmp_path):
    import h5py

    folder = write_summary(tmp_path / "r")
    _posterior(folder / "posterior.nc")
    with h5py.File(folder / "posterior.nc", "a") as f:
        f["posterior"].create_dataset("c_huge", shape=(5_000_000_000,), dtype="f8",
                                      chunks=(1_000_000,), compression="gzip")
    assert (folder / "posterior.nc").stat().st_size < 4 * 2**20
    code, _, err = run_bounded(["export", folder, "--format", "opensees", "--quantile", "0.3"],
                               timeout=120)
    line = assert_one_line_error(code, err, 2, "declares")
    assert "MB of draws in a" in line


@pytest.mark.parametrize("kind", ["external-storage", "external-link"])
def test_a_posterior_whose_data_lie_outside_the_file_is_refused(tmp_path, kind):
    import h5py

    folder = write_summary(tmp_path / "r")
    _posterior(folder / "posterior.nc")
    (tmp_path / "private.bin").write_bytes(np.arange(100, dtype="f8").tobytes())
    with h5py.File(folder / "posterior.nc", "a") as f:
        if kind == "external-storage":
            f["posterior"].create_dataset("c2", shape=(100,), dtype="f8",
                                          external=[(str(tmp_path / "private.bin"), 0, 800)])
        else:
            f["posterior"]["c2"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "/x")
    with pytest.raises(InputError, match="keeps its data outside the file"):
        dampfit.load(folder).posterior


@pytest.mark.heavy
@pytest.mark.parametrize("kind", ["fifo", "link-to-dev-zero", "link-outside"])
def test_a_posterior_that_is_not_a_regular_file_of_the_folder_is_refused(tmp_path, kind):
    folder = write_summary(tmp_path / "r")
    post = folder / "posterior.nc"
    if kind == "fifo":
        os.mkfifo(post)
    elif kind == "link-to-dev-zero":
        post.symlink_to("/dev/zero")
    else:
        _posterior(tmp_path / "outside.nc")
        post.symlink_to(tmp_path / "outside.nc")
    code, out, err = run_bounded(None, timeout=120, code=(
        "import dampfit\nfrom dampfit.errors import InputError\ntry:\n"
        "    dampfit.load(%r).posterior\nexcept InputError as e:\n"
        "    print('refused:', e)\n" % str(folder)))
    assert code == 0 and "refused:" in out, err
    assert ("symbolic link" in out) if kind.startswith("link") else ("not a regular file" in out)


def test_signals_linked_from_outside_are_refused(tmp_path):
    real = write_result(tmp_path / "real")
    folder = write_result(tmp_path / "r")
    (folder / "signals.npz").unlink()
    (folder / "signals.npz").symlink_to(real / "signals.npz")
    with pytest.raises(InputError, match="signals.npz not found as a regular file: it is a "
                                         "symbolic link"):
        load_signals(folder)


# ----------------------------------------------------------------------- input: xlsx
def test_an_xlsx_entity_bomb_is_one_line_exit_2(tmp_path, capsys):
    """expat refuses the expansion; the refusal is a bad input (exit 2), not a crash."""
    import io
    import zipfile

    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["Time (s)", "Acceleration z (m/s^2)"])
    for i in range(100):
        ws.append([i * 0.01, float(np.sin(i))])
    buf = io.BytesIO()
    wb.save(buf)
    lol = "".join(f'<!ENTITY l{i + 1} "{("&l%d;" % i) * 10}">' for i in range(9))
    bomb = f'<?xml version="1.0"?><!DOCTYPE w [<!ENTITY l0 "lol">{lol}]>'
    out = tmp_path / "bomb.xlsx"
    with zipfile.ZipFile(buf) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == "xl/worksheets/sheet1.xml":
                text = data.decode()
                text = text.split("?>", 1)[1] if text.startswith("<?xml") else text
                cut = text.index(">") + 1
                data = (bomb + text[:cut] + "&l9;" + text[cut:]).encode()
            dst.writestr(info, data)
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", out, "--mass", "1", "--out", tmp_path / "res", "--quiet",
                        "--no-figures"], capsys)
    assert_one_line_error(code, err, 2, "entity bomb")
    assert_unchanged(before, snapshot(tmp_path))


# -- report: hostile strings and structures in summary.json are inert -----------------------


EVIL = '<script>alert(1)</script><img src=x onerror=alert(2)>'

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
