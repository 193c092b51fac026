"""A newcomer's frictions, through the CLI: each test failed before its change.

* a mass implausible for a phone recording names the likely mistake (grams, or a part only);
* every assumption that changes a number is on screen (the unit guessed, the mass sd
  missing, the axis chosen), in an "assumptions" block at the end of the table;
* a handheld start (the hand's motion first, cut short where the real release makes the
  envelope rise again) is not refused: the longest free decay after it is analysed.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests._support.hostile import run

FAST = ["--no-figures", "--quiet", "--model", "viscous", "--max-modes", "1"]
F = 5.0  # [Hz]


def _phyphox(path, t, z, x=None):
    """A phyphox CSV export (Linear Acceleration, m/s²) of axis z (and x) over t [s]."""
    x = np.full(t.size, 0.002) if x is None else x
    head = ('"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)",'
            '"Linear Acceleration z (m/s^2)"\n')
    path.write_text(head + "".join(f"{ti:.4f},{xi:.6f},0.001,{zi:.6f}\n"
                                   for ti, xi, zi in zip(t, x, z)))
    return path


def _decay(n_sec=20.0, fs=100.0):
    t = np.arange(0, n_sec, 1 / fs)
    z = 3 * np.exp(-0.25 * t) * np.cos(2 * np.pi * F * t)
    return t, z + 0.01 * np.random.default_rng(0).standard_normal(t.size)


@pytest.mark.parametrize("mass, words", [
    ("200", "if you weighed it in grams, give --mass 0.2"),
    ("0.002", "the stiffness of a phone weighing 2 g"),
], ids=["grams-as-kg", "a-few-grams"])
def test_a_phone_mass_that_cannot_be_names_the_mistake(tmp_path, capsys, mass, words):
    t, z = _decay()
    path = _phyphox(tmp_path / "Raw Data.csv", t, z)
    code, out, err = run(["analyze", path, *FAST, "--mass", mass, "--out", tmp_path / "o"], capsys)
    assert code == 0, err
    assert words in out
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert any(words in w for w in s["diagnostics"]["warnings"])


@pytest.mark.heavy
def test_a_plausible_phone_mass_gets_no_note(tmp_path, capsys):
    t, z = _decay()
    path = _phyphox(tmp_path / "Raw Data.csv", t, z)
    code, out, err = run(["analyze", path, *FAST, "--mass", "0.2", "--mass-sd", "0.005",
                          "--out", tmp_path / "o"], capsys)
    assert code == 0, err
    assert "a phone weighs" not in out and "phone weighing" not in out
    assert "mass sd not given" not in out


def test_assumptions_that_change_a_number_are_on_screen(tmp_path, capsys):
    t, z = _decay()
    path = tmp_path / "plain.csv"  # no units written: the acceleration unit is guessed
    path.write_text("time,ax,az\n" + "".join(f"{ti:.4f},{0.3 * zi:.6f},{zi:.6f}\n"
                                             for ti, zi in zip(t, z)))
    code, out, err = run(["analyze", path, *FAST, "--mass", "0.2", "--out", tmp_path / "o"],
                         capsys)
    assert code == 0, err
    block = out[out.index("\n  assumptions\n"):]
    assert "acceleration unit not given" in block  # the unit guessed
    assert "mass sd not given" in block  # the mass taken as exact
    assert "axis auto: projected on the oscillation direction" in block  # the axis chosen


def test_a_handheld_start_analyses_the_longest_decay_after_it(tmp_path, capsys):
    fs = 100.0
    t = np.arange(0, 25, 1 / fs)
    hand = np.where(t < 2.0, 6 * np.exp(-3.0 * t) * np.cos(2 * np.pi * F * t), 0.0)
    free = np.where(t >= 2.0, 3 * np.exp(-0.25 * (t - 2)) * np.sin(2 * np.pi * F * (t - 2)), 0.0)
    z = hand + free + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    path = _phyphox(tmp_path / "Raw Data.csv", t, z)
    code, out, err = run(["analyze", path, *FAST, "--mass", "0.2", "--out", tmp_path / "o"],
                         capsys)
    assert code == 0, err  # refused before: "4.6 cycles after the release …"
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert 2.0 <= s["window"]["start_s"] < 3.0 and s["window"]["end_s"] > 20
    assert "cut short after 4.6 cycles (a handheld start?)" in out
    zeta = s["parameters"]["zeta"]["q50"]
    assert abs(zeta / (0.25 / (2 * np.pi * F)) - 1) < 0.05


_WIDTH = """<script>window.addEventListener('load', () => {
  const d = document.createElement('div'); d.id = 'width';
  d.textContent = 'scroll=' + document.documentElement.scrollWidth + ' client=' +
    document.documentElement.clientWidth; document.body.appendChild(d);
});</script>"""


@pytest.mark.skipif(not __import__("os").path.isfile("/usr/bin/chromium"),
                    reason="Debian chromium (/usr/bin/chromium) is not installed")
def test_report_with_a_modes_table_reads_at_1300_px_without_sideways_scrolling(tmp_path):
    import re
    import subprocess

    from dampfit.output.document import render_html

    head = ["mode", "f_n, natural frequency [Hz]", "ζ, damping ratio [1]", "η = 2ζ, loss factor [1]",
            "Λ, log decrement [1]", "Q⁻¹ = 1/Q, inverse quality factor [1]", "CRLB sd of ζ [1]",
            "sd / CRLB sd", "max R-hat"]
    rows = [["1 (the mass's mode)", "12.000595 [12.000570, 12.000620]",
             "0.0099998 [0.0099977, 0.0100019]", "0.0199996 [0.0199955, 0.0200039]",
             "0.062834 [0.062821, 0.062847]", "0.0199996 [0.0199955, 0.0200039]", "1.26e-06",
             "1.01", "1.0085"]] * 3
    page = render_html("wide", [("h1", "wide"), ("table", head, rows),
                                ("code", "dampfit export folder --format lsdyna " + "x" * 300)],
                       tmp_path)
    page = page.replace("style-src 'unsafe-inline'", "style-src 'unsafe-inline'; "
                        "script-src 'unsafe-inline'").replace("</body>", _WIDTH + "</body>")
    html = tmp_path / "wide.html"
    html.write_text(page, encoding="utf-8")
    res = subprocess.run(["/usr/bin/chromium", "--headless", "--no-sandbox", "--disable-gpu",
                          f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1300,2000",
                          "--virtual-time-budget=3000", "--dump-dom", html.as_uri()],
                         capture_output=True, text=True, timeout=120)
    m = re.search(r'id="width">scroll=(\d+) client=(\d+)<', res.stdout)
    assert m, res.stderr[-500:]
    assert int(m.group(1)) <= int(m.group(2))  # no sideways scrolling
    assert '<span>12.000595</span> <span>[12.000570, 12.000620]</span>' in page
