"""The damping report (:mod:`dampfit.output.report`): ``report.html`` and ``report.md`` of a result folder.

One analysed short recording of the seed paper's set-up (conftest's ``analysed``) is written as
a result folder once per module; synthetic variants of its summary test the optional sections
(CRLB, model checks, amplitude curve, verification), missing/None fields and bad input. The
HTML is opened in headless Chromium (skipped only if the binary is absent), and one real
recording is analysed and reported. The "for a reader" tests hold what a colleague relies on:
human labels instead of summary keys, each warning once, one defined noise level, absolute
paths in the reproduce command, "sd not given", digits that show the interval and the
embedded ζ(A)/f(A) figure.
"""

from __future__ import annotations

import ast
import base64
import copy
import json
import re
import shlex
import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

import dampfit
from dampfit.output import document as _document
from dampfit import cli
from dampfit.files.folder import DEMO_MARKER, MARKER
from dampfit.output import figures as plots
from dampfit.output import report
from dampfit.output import text as render
from dampfit.output.format import interval, own_spread, point
from dampfit.output.report import single, values
from dampfit.errors import InputError

from tests._support.requirements import REAL

FIGS = ("signal", "spectrum", "fit", "displacement", "posterior", "trace", "amplitude")
CHROMIUM = shutil.which("chromium") or next(
    (p for p in ("/usr/bin/chromium", "/usr/bin/chromium-browser") if Path(p).is_file()), None)
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="Debian chromium (/usr/bin/chromium) "
                                    "is not installed; the browser rendering check needs it")
PENDULUM = REAL / "phone-pendulum-harinlee83" / "l2LongTheta5.csv"


# ----------------------------------------------------------------------------- fixtures
def _write_folder(an, d: Path, dpi: int = 60) -> Path:
    d.mkdir(parents=True, exist_ok=True)
    an.to_json(d / "summary.json")
    plots.save_figures(an, d, dpi=dpi)
    return d


@pytest.fixture(scope="module")
def folder(analysed, tmp_path_factory):
    """A result folder (summary.json + the six figures) with its report written by the CLI."""
    an, _ = analysed
    d = _write_folder(an, tmp_path_factory.mktemp("result") / "run")
    assert cli.main(["report", str(d)]) == 0
    return d


@pytest.fixture(scope="module")
def summary(folder):
    return json.loads((folder / "summary.json").read_text())


def _render(s: dict, d: Path | None = None, **files) -> tuple[str, str]:
    """(html, md) of summary ``s``, built in memory (no files needed) for folder ``d``."""
    d = d or Path("/nonexistent-folder")
    data = {"summary": s, "verification": files.get("verification"), "verification_error": None}
    title, blocks = report.build(data, d, now="2025-01-01T00:00:00+00:00")
    return report.render_html(title, blocks, d), report.render_markdown(title, blocks, d)


def _img_srcs(html: str) -> list[str]:
    return re.findall(r'<img src="([^"]*)"', html)


def _check_balanced(page: str) -> None:
    """Every element the report opens is closed, in order (a well-formed page)."""
    from html.parser import HTMLParser

    void = {"meta", "img", "br", "hr", "link", "input"}

    class Check(HTMLParser):
        def __init__(self):
            super().__init__()
            self.stack: list[str] = []

        def handle_starttag(self, tag, attrs):
            if tag not in void:
                self.stack.append(tag)

        def handle_endtag(self, tag):
            assert self.stack and self.stack[-1] == tag, (tag, self.stack[-3:])
            self.stack.pop()

    c = Check()
    c.feed(page)
    assert c.stack == [], c.stack


def _section(text: str, heading: str) -> str:
    """The Markdown of one ``## heading`` section."""
    start = text.index(f"## {heading}")
    end = text.find("\n## ", start + 3)
    return text[start:end if end > 0 else None]


# ----------------------------------------------------------------------------- the folder
def test_cli_writes_both_files_and_nothing_else(folder, capsys):
    names = {p.name for p in folder.iterdir()}
    assert names == {"summary.json", "report.html", "report.md"} | {f"{n}.png" for n in FIGS}
    # regenerating our own report needs no --force and prints where it went
    assert cli.main(["report", str(folder)]) == 0
    assert "report.html" in capsys.readouterr().out


def test_html_is_self_contained(folder):
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>") and "<style>" in html
    assert "default-src 'none'" in html  # the CSP forbids loading anything else
    assert not re.search(r"<(script|link|iframe|object)\b", html)
    assert not re.search(r'\b(src|href)\s*=\s*"(?!data:)', html)
    assert "url(" not in html and "@import" not in html and "http://" not in html
    _check_balanced(html)
    srcs = _img_srcs(html)
    assert len(srcs) == len(FIGS)
    embedded = {base64.b64decode(s.split(",", 1)[1]) for s in srcs}
    assert embedded == {(folder / f"{n}.png").read_bytes() for n in FIGS}


def test_markdown_refers_to_the_pngs(folder):
    md = (folder / "report.md").read_text(encoding="utf-8")
    links = re.findall(r"!\[(?:\\.|[^\]\\])*\]\(([^)]+)\)", md)
    assert sorted(links) == sorted(f"{n}.png" for n in FIGS)
    assert all((folder / link).is_file() for link in links)


def test_numbers_come_from_summary(folder, summary):
    html = (folder / "report.html").read_text(encoding="utf-8")
    md = (folder / "report.md").read_text(encoding="utf-8")
    p = summary["parameters"]
    for text in (html, md):
        for name in values.MAIN:  # the median with the digits its interval supports
            assert interval(p[name]["q50"], p[name]["q05"], p[name]["q95"])[0] in text, name
            assert values.bracket(p[name]).replace("[", "").split(",")[0] in text
        # least squares with the posterior's digits, a baseline with those of its own spread
        assert values.estimate(summary, "c", summary["least_squares"]["c"]) in text
        for b in summary["baselines"].values():
            assert own_spread(b.get("c"), b.get("expected_rel_sd")) in text
        assert values.number(summary["noise_model"]["psd_ratio_at_f0"]) in text
        assert summary["input"]["format"] in text and summary["dampfit_version"] in text
        for unit in ("N s/m", "N/m", "Hz", "1/s", "m/s^2", "kg"):
            assert unit in text, unit
    # the table lists the five parameters in order, with R-hat and ESS columns
    table = _section(md, "Result")
    assert "| R-hat | bulk ESS |" in table
    rows = [r for r in table.splitlines() if r.startswith("| ") and "---" not in r][1:6]
    assert [r.split(" | ")[0][2:] for r in rows] == [_document._md(values.NAMES[n]) for n in values.MAIN]
    assert f"{p['c']['r_hat']:.4f}" in rows[0] and f"{p['c']['ess_bulk']:.0f}" in rows[0]
    assert "| sha256 | — |" in md  # an in-memory recording has no file hash
    # the Cramér–Rao bound, when the analysis computed it, beside each posterior sd
    if isinstance(summary.get("crlb"), dict):
        assert "| CRLB sd | sd / CRLB sd |" in table
        for row, name in zip(rows, values.MAIN):
            bound = p[name].get("crlb_sd") or single.crlb_sd(summary["crlb"], name)
            assert f"| {values.number(bound, 3)} | {p[name]['sd'] / bound:.2f} |" in row


def test_absent_optional_sections_say_not_computed(summary, tmp_path):
    s = {k: v for k, v in summary.items()
         if k not in ("crlb", "model_checks", "amplitude_curve", "verification")}
    for p in s["parameters"].values():
        if isinstance(p, dict):
            p.pop("crlb_sd", None)
    (tmp_path / "summary.json").write_text(json.dumps(s))
    md = report.write_report(tmp_path)["md"].read_text(encoding="utf-8")
    for heading in ("Model checks", "Amplitude dependence", "Verification in OpenSees"):
        assert "Not computed" in _section(md, heading), heading
    assert "Not computed" in _section(md, "Result") and "CRLB sd" not in md
    assert f"dampfit verify {tmp_path.resolve()}" in md
    assert "--model auto" in _section(md, "Model checks")


def test_reproduce_command_parses_back_to_the_options(folder, summary):
    s = copy.deepcopy(summary)
    s["input"]["path"] = "/data/my run/Raw Data.csv"
    s["provenance"]["options"].update({"axis": "y", "window": [1.5, 18.25], "band": [1.2, 2.4],
                                       "max_steps": 5000})
    s["provenance"]["seed"] = 7
    cmd = report.reproduce_command(s, "/tmp/out dir")
    args = cli.get_parser().parse_args(shlex.split(cmd)[1:])
    assert args.command == "analyze" and args.file == "/data/my run/Raw Data.csv"
    assert (args.mass, args.mass_sd) == (s["mass"]["value"], s["mass"]["sd"])
    assert args.axis == "y" and args.window == [1.5, 18.25] and args.band == [1.2, 2.4]
    assert (args.seed, args.max_steps, args.out) == (7, 5000, "/tmp/out dir")
    s["mass"] = {"value": None, "sd": None, "unit": "kg"}
    assert "--mass" not in report.reproduce_command(s, "x")
    # several modes come back as they were asked for; edited values are left out
    s["provenance"]["options"].update({"max_modes": 4, "mode_of_mass": 2})
    args = cli.get_parser().parse_args(shlex.split(report.reproduce_command(s, "x"))[1:])
    assert (args.max_modes, args.mode_of_mass) == (4, 2)
    s["provenance"]["options"].update({"max_modes": "4; rm -rf ~", "mode_of_mass": True})
    cmd = report.reproduce_command(s, "x")
    assert "--max-modes" not in cmd and "--mode-of-mass" not in cmd
    s["provenance"]["options"].update({"max_modes": 1, "mode_of_mass": None})
    assert "--max-modes" not in report.reproduce_command(s, "x")


# ----------------------------------------------------------------------------- synthetic
def test_optional_sections_present(folder, summary, tmp_path):
    s = copy.deepcopy(summary)
    for q in s["parameters"].values():
        if isinstance(q, dict):
            q.pop("crlb_sd", None)
    s["crlb"] = {"c": 0.5 * s["parameters"]["c"]["sd"], "k": {"sd": 1.25, "unit": "N/m"},
                 "u0": None, "zeta": "n/a", "method": "Fisher information at the optimum"}
    s["model_checks"] = {
        "verdict": "viscous damping is adequate", "warning": "decay rate falls with amplitude",
        "residual_whiteness": {"ljung_box_p": 0.31, "lag1": 0.05},
        "amplitude_dependence": {"slope": -0.25, "p_value": None},
        "preferred_model": "quadratic",
        "models": [{"model": "viscous", "aic": 10.5, "c": 0.2},
                   {"model": "quadratic", "aic": 4.25, "c2_unit": "N s^2/m^2", "c2": 1.5}],
        "future_key": {"nested": {"deeper": [1, 2, 3]}},
    }
    s["amplitude_curve"] = {"amplitude_m": [0.04, 0.03, 0.02], "p_per_s": [0.0211, 0.0197, 0.0188],
                            "method": "sliding windows of 5 cycles"}
    ver = {"mae": 1.5e-4, "mae_unit": "m", "mse": 3.25e-8, "nmse": 0.0125,
           "envelope_decay_rate_per_s": 0.01887, "identified_p_per_s": 0.018868}
    d = tmp_path / "r"
    d.mkdir()
    (d / "summary.json").write_text(json.dumps(s))
    (d / "verification.json").write_text(json.dumps(ver))
    shutil.copy(folder / "signal.png", d / "verify.png")
    (d / "amplitude.png").write_text("not a PNG")
    paths = report.write_report(d)
    html, md = paths["html"].read_text(), paths["md"].read_text()
    for text in (html, md):
        assert "CRLB sd" in text and "sd / CRLB sd" in text
        assert "1.25" in text and "Fisher information at the optimum" in text
        assert "viscous damping is adequate" in text and "quadratic" in text and "4.25" in text
        assert "0.31" in text and "-0.25" in text and "deeper" in text
        assert "sliding windows of 5 cycles" in text and "0.0197" in text
        assert "0.00015" in text and "0.0125" in text and "0.01887" in text
        assert "Not computed" not in text
    c_row = next(r for r in md.splitlines() if r.startswith(f"| {values.NAMES['c']}"))
    assert f"| {values.number(s['crlb']['c'], 3)} | 2.00 |" in c_row  # posterior sd / bound
    k_row = next(r for r in md.splitlines() if r.startswith(f"| {values.NAMES['k']}"))
    assert "| 1.25 |" in k_row
    assert "amplitude [m]" in html and "p [1/s]" in html  # units from the key suffixes
    assert "c2 [N s^2/m^2]" in html
    assert "MAE" in html and re.search(r"<td>MAE</td><td class=n>0.00015</td><td>m</td>", html)
    # the model-check warning is in the red box at the top, before the result table
    top = html[:html.index("<h2>")]
    assert 'class="box bad"' in top and "decay rate falls with amplitude" in top
    # a file that is not a PNG is reported as missing, never embedded as a broken image
    assert "amplitude.png</strong>: amplitude.png is not in this folder" in html
    assert "](verify.png)" in md and "](amplitude.png)" not in md
    assert [base64.b64decode(u.split(",", 1)[1]) for u in _img_srcs(html)] == \
        [(d / "verify.png").read_bytes()]


def test_verdict_c_equivalent_and_zero_reaching_intervals_are_explained(summary):
    """Issue 19: the verdict words state the rule; a c_equivalent that means nothing is
    absent with its reason; an extrapolated one says so; r / r_white below 1 is explained,
    not shown as evidence; a decay not told from 0 is one-sided with Q unbounded."""
    s = copy.deepcopy(summary)
    mc = s["model_checks"]
    mc.update(verdict="inconclusive", verdict_law=None, verdict_reasons=[
        "the amplitudes span too little to tell (zeta could change up to 2.1x over the "
        "recorded 1.3x amplitude range; one viscous c needs the data to rule out 1.25x)"])
    mc["adequacy"]["fit_checks"]["viscous"]["r_excess"] = 0.42
    s["missing"]["c_equivalent"] = ("the verdict is misfit: no damping law describes this "
                                    "waveform, so the coulomb law's equivalent viscous c means "
                                    "nothing")
    s["c_equivalent"] = None
    html, md = _render(s)
    for text in (html, md):
        assert "could not have seen a dependence" in text and "span too little to tell" in text
        assert "Equivalent viscous damping not given:" in text and "means nothing" in text
        assert "&lt; 1 (no excess)" in text or "< 1 (no excess)" in text
        assert "0.42" not in text and "no evidence either way" in text
    mc["verdict"] = "adequate"
    assert "rule out a change of ζ by 1.25× or more" in _render(s)[1]
    s["missing"].pop("c_equivalent")
    s["c_equivalent"] = {"model": "coulomb", "amplitude_m": 1.0, "extrapolated": True,
                         "recorded_amplitude_range_m": [0.002, 0.02],
                         "zeta": {"q05": 0.01, "q50": 0.02, "q95": 0.03, "unit": "1"}}
    md = _render(s)[1]
    assert "Extrapolated:" in md and "0.002–0.02 m" in md
    for name in ("p", "zeta", "delta"):
        s["parameters"][name].update(q05=0.0, reaches_zero=True)
    s["parameters"]["Q"].update(q95=None, mean=None, sd=None, reaches_zero=True)
    md = _render(s)[1]
    assert "No decay measured:" in md and "intervals reach 0" in md
    q_row = next(r for r in md.splitlines() if r.startswith(f"| {values.NAMES['Q']}"))
    assert ", ∞)" in q_row
    # the new fields of an edited summary, of any type: rendered, never a crash
    for odd in (5, "x", [1], [None, "a"], {"a": 1}, None, True, float("nan")):
        t = copy.deepcopy(s)
        t["c_equivalent"]["recorded_amplitude_range_m"] = odd
        t["missing"]["c_equivalent"] = odd
        t["model_checks"].update(decay=odd, verdict_law=odd)
        t["parameters"]["Q"]["reaches_zero"] = odd
        t["window"]["end_reason"] = odd
        assert _render(t)[0].endswith("</html>\n")


def test_not_converged_and_warnings_give_a_red_box(summary):
    s = copy.deepcopy(summary)
    s["diagnostics"].update(converged=False, posterior_converged=False,
                            warnings=["R-hat 1.2 > 1.01: run longer", "second <b>mode</b>?"])
    html, md = _render(s)
    top = html[:html.index("<h2>")]
    assert 'class="box bad"' in top and "NOT CONVERGED" in top
    assert "R-hat 1.2 &gt; 1.01: run longer" in top and "&lt;b&gt;mode&lt;/b&gt;" in top
    assert "> **⚠ NOT CONVERGED" in md and "second \\<b\\>mode\\</b\\>?" in md
    s["diagnostics"].update(converged=True, posterior_converged=True, warnings=[])
    ok_html, _ = _render(s)
    assert 'class="box ok"' in ok_html and 'class="box bad"' not in ok_html


def test_data_strings_are_escaped(summary):
    s = copy.deepcopy(summary)
    evil = '<script>alert("x")</script> & | `tick` *star*'
    s["input"]["path"] = f"/tmp/{evil}.csv"
    s["input"]["notes"] = [evil]
    s["model_checks"] = {"verdict": evil, "models": {evil: {"aic": 1.0}, "b": {"aic": 2.0}}}
    html, md = _render(s)
    assert "<script>" not in html and "&lt;script&gt;" in html and "&amp; |" in html
    prose = re.sub(r"```bash\n.*?\n```", "", md, flags=re.S)  # code blocks show text verbatim
    assert "<script>" not in prose and "\\<script\\>" in prose and "\\|" in prose
    assert shlex.split(report.reproduce_command(s, "d"))[2] == s["input"]["path"]
    # table rows keep their column count despite the pipe in the data
    for line in md.splitlines():
        if line.startswith("| ") and "script" in line:
            assert len(re.findall(r"(?<!\\)\|", line)) in (3, 4, 7)


def test_demo_folder_shows_truth_and_demo_command(summary, tmp_path):
    s = copy.deepcopy(summary)
    s["input"]["path"] = str(tmp_path / "paper-preset.csv")
    (tmp_path / DEMO_MARKER).write_text(json.dumps({"c": 0.2, "zeta": 0.00175, "f_n": 1.72,
                                                        "p": 0.0189}))
    html, md = _render(s, tmp_path)
    assert "truth (simulated input)" in md and f"dampfit demo --seed {s['provenance']['seed']}" in md


def _leaves(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(obj, list) and obj:
        for i, v in enumerate(obj):
            yield from _leaves(v, path + (i,))
    yield path


@pytest.mark.heavy
def test_any_missing_none_or_odd_field_renders(summary):
    """Each field of the summary removed, None, a string or an empty dict: never a crash."""
    s0 = copy.deepcopy(summary)
    s0.update(crlb={"c": 1e-3}, model_checks={"verdict": "ok", "models": []},
              amplitude_curve={"a": [1.0]})
    n = 0
    for path in {p for p in _leaves(s0) if p}:
        for value in (None, "<odd>", {}, float("nan")):
            s = copy.deepcopy(s0)
            parent = s
            for k in path[:-1]:
                parent = parent[k]
            parent[path[-1]] = value
            html, md = _render(s)
            assert html.endswith("</html>\n") and md.count("\n## ") >= 10
            if n % 37 == 0:
                _check_balanced(html)
            n += 1
        s = copy.deepcopy(s0)
        parent = s
        for k in path[:-1]:
            parent = parent[k]
        if isinstance(parent, dict):
            del parent[path[-1]]
            _render(s)
    assert n > 300
    html, md = _render({})
    assert "No diagnostics" in html and "Not computed" in md


def test_missing_figures_are_announced(folder, tmp_path):
    d = tmp_path / "r"
    shutil.copytree(folder, d)
    (d / "fit.png").unlink()
    (d / "trace.png").write_bytes(b"\x89PNG\r\n\x1a\n broken")  # truncated PNG
    s = json.loads((d / "summary.json").read_text())
    s["baselines"]["envelope_pipeline"] = None
    (d / "summary.json").write_text(json.dumps(s))
    paths = report.write_report(d)
    html, md = paths["html"].read_text(), paths["md"].read_text()
    assert len(_img_srcs(html)) == len(FIGS) - 3
    assert "fit.png is not in this folder" in html and "trace.png is not in this folder" in md
    assert "envelope-pipeline baseline was not computed" in md
    assert "](fit.png)" not in md and "](trace.png)" not in md


def test_report_module_imports_only_the_standard_library():
    import sys

    files = sorted(Path(report.__file__).parent.glob("*.py")) + [Path(_document.__file__)]
    assert len(files) >= 6  # the package's modules, not only its face
    tree = ast.parse("\n".join(f.read_text(encoding="utf-8") for f in files))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""] if node.level == 0 else []
        else:
            continue
        for name in names:
            # dampfit's own modules are imported absolutely; no third-party package
            assert name.split(".")[0] in sys.stdlib_module_names | {"__future__", "dampfit"}, name


# ----------------------------------------------------------------------------- for a reader
#: Keys that are also the report's symbols (f_n is printed as the quantity's symbol).
SYMBOLS = {"f_n", "f_d", "c_crit", "u0", "F_c", "mu_c", "c_alpha"}


def _keys(obj) -> set[str]:
    if isinstance(obj, dict):
        return {str(k) for k in obj} | {k for v in obj.values() for k in _keys(v)}
    if isinstance(obj, list):
        return {k for v in obj for k in _keys(v)}
    return set()


def _lower_half(md: str) -> str:
    """From "Inputs and provenance" to "How to reproduce", without list items (the analysis'
    own sentences: notes, verdict reasons) and code blocks."""
    text = md[md.index("## Inputs and provenance"):md.index("## How to reproduce")]
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return "\n".join(line for line in text.splitlines() if not line.startswith("- "))


def test_lower_half_has_human_labels_and_no_dumps(folder, summary):
    md = (folder / "report.md").read_text(encoding="utf-8")
    lower = _lower_half(md)
    snake = {k for k in _keys(summary) if "_" in k and k not in SYMBOLS}
    assert len(snake) > 50  # the summary has plenty of them
    shown = sorted(k for k in snake if _document._md(k) in lower or k in lower)
    assert shown == [], shown
    # nor keys with their underscores merely replaced by spaces (the old dump's "labels")
    for raw in ("ljung box at f0", "psd ratio", "zeta q05", "slope ln p vs ln amplitude",
                "window slope", "s q05", "amplitude grid", "zeta eq"):
        assert raw not in lower.lower(), raw
    # short tables: no table longer than the windows would be, none printed twice
    tables = re.findall(r"(?:^\|.*\|\n?)+", lower, flags=re.M)
    assert tables and max(t.count("\n") for t in tables) < 25
    assert len(tables) == len(set(tables))
    # the verdict once, in plain words, at the top of the model checks, its reasons as a list
    mc = summary["model_checks"]
    checks = _section(md, "Model checks")
    first = checks.split("\n\n")[1]
    assert first.startswith(f"**Verdict: {mc['verdict']}** — ")
    assert first.count("Verdict") == 1 and md.count("**Verdict:") == 1
    for reason in mc["verdict_reasons"]:
        assert f"- {_document._md(reason)}" in checks
    # one table of the laws: law, weight, parameters with units
    laws = [r for r in checks.splitlines() if r.startswith("| ") and "---" not in r]
    head = next(r for r in laws if r.startswith("| law |"))
    assert "weight" in head and "parameters" in head
    for law, entry in summary["damping_models"]["models"].items():
        row = next(r for r in laws if r.startswith(f"| {law} |"))
        if "c" in entry["parameters"]:
            assert "N s/m" in row, row


def test_each_warning_appears_once(summary):
    s = copy.deepcopy(summary)
    mc_warn = "damping depends on amplitude: ζ falls from 0.0021 to 0.0015 (P < 0.05)"
    s["diagnostics"]["warnings"] = ["R-hat 1.2 > 1.01: run longer", mc_warn]
    s["model_checks"]["warning"] = mc_warn  # the analysis repeats it in the model checks
    html, md = _render(s)
    for w in s["diagnostics"]["warnings"]:
        esc = _document._h(w)
        assert html.count(esc) == 1, w
        assert html[:html.index("<h2>")].count(esc) == 1  # in the red box at the top
    assert html.count('class="box bad"') == 1 and md.count("⚠") == 1
    # a model-check warning of its own is in the same box, once
    s["model_checks"]["warning"] = "decay rate falls with amplitude"
    html, _ = _render(s)
    assert html.count("decay rate falls with amplitude") == 1
    assert "decay rate falls with amplitude" in html[:html.index("<h2>")]


def _count_number(text: str, number: str) -> int:
    return len(re.findall(rf"(?<![\d.]){re.escape(number)}(?![\d])", text))


def test_noise_level_is_defined_once(folder, summary):
    md = (folder / "report.md").read_text(encoding="utf-8")
    nm, crlb = summary["noise_model"], summary["crlb"]
    noise = _section(md, "Noise model")
    sigma, dens = values.number(nm["sigma"], 3), values.number(crlb["noise_density"], 3)
    assert _count_number(md, sigma) == 1 and _count_number(noise, sigma) == 1
    assert _count_number(md, dens) == 1 and _count_number(noise, dens) == 1
    rows = {r.split(" | ")[0][2:]: r for r in noise.splitlines() if r.startswith("| ")}
    assert "per fitted sample" in rows["σ, residual noise level"]
    assert "m/s^2 |" in rows["σ, residual noise level"]
    assert "Cramér–Rao" in rows["noise density at f₀"]
    assert "m/s^2/sqrt(Hz)" in rows["noise density at f₀"]
    # the CRLB's own per-raw-sample σ is not a second, unlabelled "noise" number
    for digits in (3, 4, 6):
        assert _count_number(md, values.number(crlb["noise_sigma"], digits)) == 0
    # the bound refers to the definition instead of repeating a number
    result = _section(md, "Result")
    assert "noise density at f₀ defined in the section “Noise model”" in result
    assert "noise" not in "".join(r for r in result.splitlines() if r.startswith("| "))


def test_reproduce_command_is_absolute_and_quoted(folder, summary, tmp_path, monkeypatch):
    md = (folder / "report.md").read_text(encoding="utf-8")
    code = re.search(r"```bash\n(dampfit analyze .*?)\n```", md).group(1)
    args = shlex.split(code)
    assert args[args.index("--out") + 1] == str(folder.resolve())
    # a relative folder becomes absolute (quoted where needed)
    monkeypatch.chdir(tmp_path)
    s = copy.deepcopy(summary)
    s["input"]["path"] = "/data/my run/Raw Data.csv"
    args = shlex.split(report.reproduce_command(s, "out dir"))
    assert args[args.index("--out") + 1] == str(tmp_path / "out dir")
    assert args[2] == "/data/my run/Raw Data.csv"
    # a relative input path (as recorded) is flagged: the command must run from that folder
    s["input"]["path"] = "rel/data.csv"
    _, md = _render(s)
    assert "rel/data.csv was recorded relative to the folder the analysis ran in" in md


def test_a_folder_holding_its_input_is_recreated_beside_it(summary, tmp_path):
    """analyze refuses an --out that holds its input: a folder holding its own input (moved
    there, or a record folder, wherever it was moved since) gets a command writing beside it."""
    d = tmp_path / "run"
    d.mkdir()
    s = copy.deepcopy(summary)
    s["input"]["path"] = str(d / "sub" / "rec.csv")  # inside the folder, not a record folder
    args = shlex.split(report.reproduce_command(s, d))
    assert args[2] == str(d / "sub" / "rec.csv")
    assert args[args.index("--out") + 1] == str(tmp_path / "run.reanalysed")
    _, md = _render(s, d)
    assert "This folder holds its own input file" in md and "record anew" not in md
    # a record folder moved away from where it was recorded: its own recording.csv
    (d / MARKER).write_text(json.dumps({"kind": "record", "dampfit": "0"}))
    for recorded in ("/elsewhere/decay/recording.csv", "..", None):
        s["input"]["path"] = recorded
        args = shlex.split(report.reproduce_command(s, d))
        assert args[2] == str(d / "recording.csv"), recorded
        assert args[args.index("--out") + 1] == str(tmp_path / "run.reanalysed")
    _, md = _render(s, d)
    assert "This folder holds its own recording (dampfit record wrote it)" in md
    # any other folder: re-created in place, as before
    (d / MARKER).write_text(json.dumps({"kind": "analyze", "dampfit": "0"}))
    s["input"]["path"] = "/data/rec.csv"
    args = shlex.split(report.reproduce_command(s, d))
    assert args[2] == "/data/rec.csv" and args[args.index("--out") + 1] == str(d)
    # a campaign whose inputs lie in its folder
    from tests._support.summaries import hand_summary

    c = hand_summary(paths=[d / "a.csv", "/data/b.csv", "/data/c.csv"])
    args = shlex.split(report.campaign_reproduce_command(c, d))
    assert args[args.index("--out") + 1] == str(tmp_path / "run.reanalysed")
    c = hand_summary()
    args = shlex.split(report.campaign_reproduce_command(c, d))
    assert args[args.index("--out") + 1] == str(d)


def test_one_number_is_printed_alike_by_the_tables_and_the_reports(summary):
    """The one formatter (dampfit.output.format): the text table, the notebook table, the
    report and a caller of the public functions print a value with the same digits."""
    s = copy.deepcopy(summary)
    q = {"q05": 0.1912345, "q50": 0.2001234, "q95": 0.2098765}
    s["parameters"]["c"].update(q)
    s["least_squares"]["c"] = 0.20031234
    med, lo, hi = interval(q["q50"], q["q05"], q["q95"])
    assert (med, lo, hi) == ("0.200", "0.191", "0.210")  # not six digits: the width's
    ls = point(0.20031234, q["q05"], q["q95"])
    assert ls == "0.200" and point(q["q50"], q["q05"], q["q95"]) == med
    table = render.text(s)
    row = next(x for x in table.splitlines() if x.lstrip().startswith("c      [N s/m]"))
    assert re.search(rf" {re.escape(med)} +\[ *{re.escape(lo)}, +{re.escape(hi)}\]", row), row
    assert f"c = {ls}," in next(x for x in table.splitlines() if "least squares" in x)
    assert f"<td>{med}</td><td>[{lo}, {hi}]</td>" in render.html_table(s)
    html, md = _render(s)
    assert f"c = {med} N s/m</strong> (90 % interval [{lo}, {hi}])" in html
    assert f"c = {med} N s/m** (90 % interval \\[{lo}, {hi}\\])" in md
    methods = _section(md, "Result")
    ls_row = next(x for x in methods.splitlines() if x.startswith("| least squares"))
    assert ls_row.split(" | ")[1].startswith(f"{ls} ± ")
    for b in s["baselines"].values():  # a baseline: the digits of its own spread
        if isinstance(b, dict) and b.get("c") is not None:
            digits = own_spread(b["c"], b.get("expected_rel_sd"))
            assert digits in table and digits in md
    # a campaign: the table and its report
    from tests._support.summaries import hand_summary
    from dampfit.output.text_campaign import text as campaign_text

    c = hand_summary()
    pop = c["parameters"]["c"]
    shown = "{} [{}, {}]".format(*interval(pop["q50"], pop["q05"], pop["q95"]))
    _, cmd = _render(c)
    assert shown in campaign_text(c) and shown in cmd.replace("\\[", "[").replace("\\]", "]")


def test_mass_without_sd_says_so(summary):
    s = copy.deepcopy(summary)
    for sd in (None, 0.0):
        s["mass"] = {"value": 0.23, "sd": sd, "unit": "kg"}
        _, md = _render(s)
        assert "| mass | 0.23 kg (sd not given) |" in md and "± 0 kg" not in md
    s["mass"]["sd"] = 0.01
    assert "| mass | 0.23 ± 0.01 kg |" in _render(s)[1]


def test_digits_show_the_interval(summary):
    s = copy.deepcopy(summary)
    s["parameters"]["f_n"].update(q05=1.71992, q50=1.72031, q95=1.72068, mean=1.720305)
    html, md = _render(s)
    assert "**f\\_n = 1.72031 Hz** (90 % interval \\[1.71992, 1.72068\\])" in md
    row = next(r for r in md.splitlines() if r.startswith(f"| {_document._md(values.NAMES['f_n'])}"))
    assert "| 1.72031 | 1.72030 |" in row and "\\[1.71992, 1.72068\\]" in row
    # every posterior row: median and both ends distinct as printed
    for name in values.MAIN + values.DERIVED:
        q = s["parameters"][name]
        if q["q05"] < q["q50"] < q["q95"]:
            lo, hi = values.bracket(q)[1:-1].split(", ")
            assert len({values.median(q), lo, hi}) == 3, name


def test_amplitude_figures_are_embedded(folder, summary):
    html = (folder / "report.html").read_text(encoding="utf-8")
    fig = re.search(r'<figure><img src="data:image/png;base64,([^"]+)"[^>]*alt="([^"]*)"'
                    r"><figcaption><strong>amplitude.png</strong>", html)
    assert fig, "amplitude.png is not embedded"
    assert base64.b64decode(fig.group(1)) == (folder / "amplitude.png").read_bytes()
    assert "ζ(A)" in fig.group(2) and "f(A)" in fig.group(2) and "backbone" in fig.group(2)
    section = html[html.index("<h2>Amplitude dependence</h2>"):]
    assert section.index("amplitude.png") < section.index("<h2>", 5)


# ----------------------------------------------------------------------------- bad input
def test_bad_folders_are_input_errors(tmp_path, capsys):
    with pytest.raises(InputError, match="is not a directory"):
        report.write_report(tmp_path / "nope")
    with pytest.raises(InputError, match="has no summary.json; run 'dampfit analyze"):
        report.write_report(tmp_path)
    (tmp_path / "summary.json").write_text("{not json")
    with pytest.raises(InputError, match="cannot read .*summary.json"):
        report.write_report(tmp_path)
    (tmp_path / "summary.json").write_text("[1, 2]")
    with pytest.raises(InputError, match="not a dampfit summary"):
        report.write_report(tmp_path)
    assert cli.main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a dampfit summary" in err[0]
    assert cli.main(["report"]) == 2 and "DIR" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["summary.json"]  # nothing written


def test_unreadable_verification_is_shown_not_fatal(summary, tmp_path):
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "verification.json").write_text("{oops")
    html = report.write_report(tmp_path)["html"].read_text()
    assert "verification.json could not be read" in html


def test_foreign_report_needs_force(summary, tmp_path, capsys):
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "report.md").write_text("my own notes\n")
    with pytest.raises(InputError, match="report.md exists and was not written by dampfit"):
        report.write_report(tmp_path)
    assert cli.main(["report", str(tmp_path)]) == 2
    assert "use --force" in capsys.readouterr().err
    assert (tmp_path / "report.md").read_text() == "my own notes\n"
    assert not (tmp_path / "report.html").exists()
    assert cli.main(["report", str(tmp_path), "--force"]) == 0
    assert (tmp_path / "report.md").read_text().startswith("<!-- generated by dampfit report")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.html", "report.md", "summary.json"]


# ----------------------------------------------------------------------------- in a browser
def _chromium(tmp: Path, *args: str) -> subprocess.CompletedProcess:
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", f"--user-data-dir={tmp / 'profile'}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180)


_CHECK = """<script>window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  const bad = imgs.filter(i => !(i.complete && i.naturalWidth > 0)).length;
  const d = document.createElement('div'); d.id = 'imgcheck';
  d.textContent = 'images=' + imgs.length + ' broken=' + bad; document.body.appendChild(d);
});</script>"""


def _image_check(html_path: Path, tmp: Path, extra_html: str = "") -> tuple[int, int]:
    """(images, broken images) of the page after load, counted by a script in a copy of it."""
    page = html_path.read_text(encoding="utf-8")
    page = page.replace("style-src 'unsafe-inline'", "style-src 'unsafe-inline'; "
                        "script-src 'unsafe-inline'").replace("</body>", extra_html + _CHECK + "</body>")
    copy_ = tmp / "check.html"
    copy_.write_text(page, encoding="utf-8")
    res = _chromium(tmp, "--run-all-compositor-stages-before-draw", "--virtual-time-budget=5000",
                    "--dump-dom", copy_.as_uri())
    m = re.search(r'id="imgcheck">images=(\d+) broken=(\d+)<', res.stdout)
    assert m, f"chromium gave no result (exit {res.returncode}): {res.stderr[-500:]}"
    return int(m.group(1)), int(m.group(2))


@needs_chromium
def test_report_renders_in_chromium(folder, tmp_path):
    shot = tmp_path / "shot.png"
    res = _chromium(tmp_path, f"--screenshot={shot}", "--window-size=1200,4000",
                    (folder / "report.html").as_uri())
    assert shot.is_file(), res.stderr[-500:]
    import matplotlib.image as mpimg

    img = mpimg.imread(shot)[..., :3]
    assert img.shape[:2] == (4000, 1200)
    non_white = np.mean(img.min(axis=2) < 0.9)
    colour = np.mean(img.max(axis=2) - img.min(axis=2) > 0.3)  # figure lines, not text
    assert non_white > 0.05 and float(img.std()) > 0.05, (non_white, img.std())
    assert colour > 0.002, colour
    # every figure decodes; the check itself sees a broken image when there is one
    assert _image_check(folder / "report.html", tmp_path) == (len(FIGS), 0)
    assert _image_check(folder / "report.html", tmp_path,
                        '<img src="data:image/png;base64,AAAA">') == (len(FIGS) + 1, 1)


@pytest.mark.heavy
@needs_chromium
@pytest.mark.skipif(not PENDULUM.is_file(), reason="../shared/data/real is not present")
def test_real_recording_report(tmp_path):
    """A phone pendulum (phyphox, 100 Hz, 42 s, no mass): c and k are reported as missing."""
    rec = dampfit.read(PENDULUM)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(rec, seed=0, min_ess=400)
    d = _write_folder(an, tmp_path / "pendulum", dpi=50)
    assert cli.main(["report", str(d)]) == 0
    md = (d / "report.md").read_text(encoding="utf-8")
    assert "c and k not identified" in md and "not identified" in _section(md, "Result")
    assert "l2LongTheta5.csv" in md and rec.sha256 in md
    f_n = an.summary()["parameters"]["f_n"]  # with the digits its interval supports
    assert interval(f_n["q50"], f_n["q05"], f_n["q95"])[0] in md
    assert _image_check(d / "report.html", tmp_path) == (len(FIGS), 0)
