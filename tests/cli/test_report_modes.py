"""The report and figure of several modes (issue 21): ``dampfit report DIR`` of a simulated
2-mode decay has a "Modes" section — one row per mode with f_n, ζ, η, Λ and Q⁻¹ and their
90 % intervals printed by the one formatter, each mode's CRLB sd of ζ, P(K) with reasons,
close pairs and the Rayleigh α, β — and modes.png, the spectrum with each mode marked, which
``dampfit report`` redraws byte for byte after it was deleted. A one-mode report is the report
of a summary without the modes (nothing added), with no modes.png. Hostile strings and types
in the modes sections of an edited summary.json render inert."""

from __future__ import annotations

import copy
import json
import re
import shutil
from pathlib import Path

import pytest

from dampfit import cli
from dampfit import simulate as sim
from dampfit.output import figures, report
from dampfit.output.figures import NEEDS, FigureData, MissingData, render
from dampfit.output.figures.modes import modes_figure
from dampfit.output.format import interval
from dampfit.output.report import modes as report_modes
from dampfit.pipeline import analyze

EVIL = '<script>alert(1)</script><img src=x onerror=alert(2)> | `tick` *star* $x$'


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    """A 2-mode decay (3.3 Hz, ζ 0.006 with the mass; 8.91 Hz, ζ 0.012 at 1/4 the amplitude:
    the wiring test's recording) analysed and saved with its figures and report."""
    cfg = sim.from_modal(0.8, 3.3, 0.006, u0=0.004, duration=40.0, sample_rate=100.0,
                         noise_density=300.0, modes=[(8.91, 0.012, 0.25, 0.5)], seed=21)
    rec, _ = sim.recording(cfg)
    an = analyze(rec, mass=0.8, mass_sd=0.01, max_modes=2, min_ess=400, seed=3)
    out = tmp_path_factory.mktemp("modes") / "res"
    an.save(out)
    assert cli.main(["report", str(out)]) == 0
    return an, out


def _section(md: str, heading: str = "Modes") -> str:
    start = md.index(f"## {heading}\n")
    end = md.find("\n## ", start + 3)
    return md[start:end if end > 0 else None]


def _cells(md: str) -> list[list[str]]:
    """The cells of every Markdown table row of ``md`` (escapes undone)."""
    rows = []
    for line in md.splitlines():
        if line.startswith("| ") and not line.startswith("| ---"):
            cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
            rows.append([re.sub(r"\\(.)", r"\1", c.strip()) for c in cells])
    return rows


def _shown(q: dict) -> str:
    med, lo, hi = interval(q["q50"], q["q05"], q["q95"])
    return f"{med} [{lo}, {hi}]"


def _render(s: dict, d: Path = Path("/nonexistent-folder")) -> tuple[str, str]:
    data = {"summary": s, "verification": None, "verification_error": None}
    title, blocks = report.build(data, d, now="2025-01-01T00:00:00+00:00")
    return report.render_html(title, blocks, d), report.render_markdown(title, blocks, d)


# ----------------------------------------------------------------------------- the table
@pytest.mark.heavy
def test_the_modes_table_prints_every_convention_from_the_summary(two):
    an, out = two
    s = an.summary()
    md = (out / "report.md").read_text(encoding="utf-8")
    rows = _cells(_section(md))
    head = rows[0]
    assert head[:6] == ["mode", "f_n, natural frequency [Hz]", "ζ, damping ratio [1]",
                        "η = 2ζ, loss factor [1]", "Λ, log decrement [1]",
                        "Q⁻¹ = 1/Q, inverse quality factor [1]"]
    assert head[6] == "CRLB sd of ζ [1]"
    body = {r[0]: r for r in rows[1:len(s["modes"]) + 1]}
    assert list(body) == ["1 (the mass's mode)", "2"]
    for row, mode in zip(body.values(), s["modes"]):
        assert row[1] == _shown(mode["f_n"])
        assert row[2] == _shown(mode["zeta"])
        assert row[3] == _shown(mode["eta"])
        assert row[4] == _shown(mode["delta"])
        q = mode["Q"]  # 1/Q reverses the order of the quantiles
        assert row[5] == _shown({"q50": 1 / q["q50"], "q05": 1 / q["q95"], "q95": 1 / q["q05"]})
        assert 1 / q["q50"] == pytest.approx(mode["eta"]["q50"], rel=1e-6)  # Q⁻¹ = 2ζ = η
        assert float(row[6]) == pytest.approx(mode["crlb_sd"]["zeta"], rel=5e-3)
    # the truth of the simulation lies in the printed intervals
    lo, hi = (float(x) for x in re.findall(r"[\d.]+", body["2"][2])[1:3])
    assert lo <= 0.012 <= hi
    html = (out / "report.html").read_text(encoding="utf-8")
    text = re.sub(r"<[^>]+>", "", html)  # a numeric cell's value and interval are two spans
    assert "<h2>Modes</h2>" in html and _shown(s["modes"][1]["delta"]) in text


@pytest.mark.heavy
def test_evidence_pairs_rayleigh_and_the_mass_mode_are_reported(two):
    an, out = two
    s = an.summary()
    sec = _section((out / "report.md").read_text(encoding="utf-8"))
    text = re.sub(r"\\(.)", r"\1", sec)
    evidence = sec[sec.index("### Number of modes"):sec.index("### Close modes")]
    rows = {r[0]: r for r in _cells(evidence)}
    # P(K) for K = 1 and 2 with the reason K = 1 was rejected
    ev = s["modes_evidence"]["evidence"]
    assert rows["1"][1] == format(ev[0]["probability"], ".3g") and ev[0]["reason"] in rows["1"][5]
    assert rows["2"][1] == format(ev[1]["probability"], ".3g")
    assert "kept" in rows["2"][5]
    pairs = {r[0]: r for r in _cells(sec[sec.index("### Close modes"):])}
    assert pairs["1 and 2"][-1] == "no"
    ray = s["rayleigh"]
    assert f"α = {_shown(ray['alpha'])} 1/s" in text and f"β = {_shown(ray['beta'])} s" in text
    assert ray["statement"] in text
    c = s["modes"][0]["c"]
    assert f"c = {_shown(c)} N·s/m" in text and "Mode 1 is the mode of the mass" in text
    assert "](modes.png)" in sec


# ----------------------------------------------------------------------------- the figure
@pytest.mark.heavy
def test_modes_png_is_drawn_and_redrawn_byte_for_byte(two, tmp_path):
    _, out = two
    copy_ = tmp_path / "copy"
    shutil.copytree(out, copy_)
    before = (copy_ / "modes.png").read_bytes()
    (copy_ / "modes.png").unlink()
    assert cli.main(["report", str(copy_)]) == 0  # dampfit report redraws missing figures
    assert (copy_ / "modes.png").read_bytes() == before
    html = (copy_ / "report.html").read_text(encoding="utf-8")
    assert re.search(r'<img src="data:image/png;base64,[^"]+"[^>]*alt="Amplitude spectrum of '
                     r'the selected signal in dB re its peak with each identified mode', html)


@pytest.mark.heavy
def test_the_modes_figure_needs_only_what_needs_names(two, tmp_path):
    an, _ = two
    full = an.summary()
    part = FigureData({k: v for k, v in full.items() if f"summary.{k}" in NEEDS["modes"]},
                      an.signals())
    assert render(part, ["modes"], tmp_path)["modes"] is not None
    assert (tmp_path / "modes.png").read_bytes() == (two[1] / "modes.png").read_bytes()


def test_one_mode_has_no_modes_figure_and_no_section(analysed, tmp_path):
    """One mode: modes.png is not drawn (an older one is removed), and the report is exactly
    the report of the same summary without its modes sections (as before they existed)."""
    an = analysed[0]
    s = an.summary()
    assert s["n_modes"] == 1 and modes_figure(an) is None
    (tmp_path / "modes.png").write_bytes(b"stale")
    assert render(an, ["modes"], tmp_path) == {"modes": None}
    assert not (tmp_path / "modes.png").exists()
    old = {k: v for k, v in s.items() if k not in ("n_modes", "modes", "modes_evidence",
                                                   "rayleigh")}
    assert _render(s) == _render(old)
    assert "Modes" not in _render(s)[1] and "modes.png" not in _render(s)[1]


# ----------------------------------------------------------------------------- hostile
@pytest.mark.heavy
def test_markup_in_the_modes_sections_is_escaped(two):
    s = copy.deepcopy(two[0].summary())
    ev = s["modes_evidence"]
    ev.update(reason=EVIL, max_modes=EVIL, notes=[EVIL, 3], screen={"reason": EVIL})
    ev["evidence"][0]["reason"] = EVIL
    ev["evidence"].append(EVIL)
    ev["pairs"][0]["modes"] = [EVIL, 2]
    ev["pairs"][0]["flagged"] = EVIL
    s["rayleigh"].update(statement=EVIL, warnings=[EVIL], chi2=EVIL, dof=2)
    s["rayleigh"]["alpha"]["q50"] = EVIL
    s["modes"][1]["zeta"]["q05"] = EVIL
    s["modes"][1]["mass_mode"] = EVIL
    s["modes"][0]["c"]["unit"] = EVIL
    html, md = _render(s)
    assert not re.search(r"<(script|img src=x)", html, re.I) and "&lt;script&gt;" in html
    prose = re.sub(r"```bash\n.*?\n```", "", md, flags=re.S)
    assert "<script" not in prose.replace("\\<script", "") and "\\<script\\>" in prose
    for line in _section(md).splitlines():  # a pipe in the data never adds a column
        if line.startswith("| ") and "script" in line:
            assert len(re.findall(r"(?<!\\)\|", line)) in (4, 6, 7, 8)


@pytest.mark.heavy
@pytest.mark.parametrize("edit", [
    lambda s: s.update(n_modes=True),
    lambda s: s.update(n_modes=1),
    lambda s: s.update(n_modes="2"),
    lambda s: s.update(modes=s["modes"][:1]),
    lambda s: s.update(modes={"a": 1}),
])
def test_an_edited_mode_count_means_no_section_and_no_figure(two, edit):
    an, _ = two
    s = copy.deepcopy(an.summary())
    edit(s)
    assert "## Modes" not in _render(s)[1]
    assert modes_figure(FigureData(s, an.signals())) is None


@pytest.mark.heavy
def test_odd_mode_entries_render_and_unusable_modes_are_one_line(two, tmp_path):
    an, _ = two
    s = copy.deepcopy(an.summary())
    s["modes"] = [7, {"f_n": {"q50": "x"}}, {}, *s["modes"]]
    s["n_modes"] = 5
    s["modes_evidence"] = {"evidence": "x", "pairs": [1, None], "notes": "x"}
    s["rayleigh"] = ["x"]
    html, md = _render(s)
    assert "## Modes" in md and "mode 4" not in md
    assert render(FigureData(s, an.signals()), ["modes"], tmp_path)["modes"] is not None
    s["modes"] = s["modes"][:3]
    s["n_modes"] = 3
    with pytest.raises(MissingData, match=r"^modes\.png cannot be drawn: .* no mode with a "
                                          r"usable f_n"):
        figures.FIGURES["modes"](FigureData(s, an.signals()))


def test_the_flag_threshold_is_the_analysis_own():
    from dampfit.inference.modes_close import CLOSE_CELLS, CLOSE_HALF_POWER, FLAG_INFLATION

    assert report_modes.FLAG_INFLATION == FLAG_INFLATION
    assert (report_modes.CLOSE_HALF_POWER, report_modes.CLOSE_CELLS) == (CLOSE_HALF_POWER,
                                                                         CLOSE_CELLS)
    assert json.dumps(report_modes.CONVENTIONS, ensure_ascii=False).count("[1]") == 4


@pytest.mark.heavy
def test_components_seen_but_not_modes_are_listed_without_a_damping_row(two):
    """A component without the evidence of a mode (modes_seen) is listed in the text table and
    the report with its kind and reason — no ζ row, no Rayleigh — also beside one mode, and a
    hostile reason renders inert."""
    from dampfit.output import text as render_text

    s = copy.deepcopy(two[0].summary())
    seen = {"index": 3, "f_n": {"q05": 1.51, "q50": 2.77, "q95": 5.29, "unit": "Hz"},
            "zeta": {"q05": 1e-5, "q50": 0.004, "q95": 0.15, "unit": "1"}, "kind": "basin",
            "reason": "its f_n interval spans 88% of its basin " + EVIL}
    s["modes_seen"] = [seen]
    text = render_text.text(s)
    assert "seen, not modes" in text and "2.77 Hz  basin: its f_n interval spans 88%" in text
    html, md = _render(s)
    sec = _section(md)
    assert "### Seen, not modes" in sec and "basin" in sec and "<script>" not in html
    one = copy.deepcopy(s)
    one.update(n_modes=1, modes=one["modes"][:1], rayleigh=None)
    html1, md1 = _render(one)
    assert "### Seen, not modes" in _section(md1) and "### Rayleigh" not in _section(md1)
    assert "seen, not modes" in render_text.text(one)
