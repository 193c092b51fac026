"""The deck is the recommended damper (issue 32): each law in each format, read back or run.

* OpenSees: the exported script of a power (α = 0.5), Coulomb and quadratic damper, run from
  the start amplitude, follows the law's closed-form averaged envelope (model/laws.py K3)
  within 2 % of the amplitude at every peak of the window.
* LS-DYNA: the *DEFINE_CURVE of *MAT_DAMPER_NONLINEAR_VISCOUS read back from the deck is the
  law (symmetric, through 0, beyond the measured velocities, its steepest segment a damping
  the explicit step carries), in every unit system.
* CalculiX: the linear c at the design amplitude and the stated limitation.
* The choices: ``--law viscous`` (c_linear, warned on stderr and in the deck), a misfit
  (nothing without ``--force-law``), an old summary (viscous with a note), ``--quantile``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.fem import calculix, damper, lsdyna, opensees, response, units
from dampfit.fem.export import build
from tests._support.fem import C, K, LAW_CASES, M, U0, write_damper_summary, write_summary
from tests._support.hostile import assert_one_line_error, run

NONLINEAR = ("power", "coulomb", "quadratic")


@pytest.mark.usefixtures("requires_opensees")
@pytest.mark.parametrize("law", NONLINEAR)
def test_opensees_deck_of_each_law_follows_its_closed_form_envelope(tmp_path, law):
    """The exported script, run 10 s from rest at U0: |u| at every peak within 2 % of
    U0·e(t) of (K3) for the known coefficients, and the decay is the law's (it fails for
    the viscous dashpot of the same c_eq)."""
    from dampfit.model import laws

    folder = write_damper_summary(tmp_path / law, law)
    text, info = build(folder, "opensees")
    assert info["damper"].law == law
    dt = info["dt"]
    res = opensees.run_steps(text, U0, 0.0, dt, int(round(10.0 / dt)))
    tp, yp = response._extrema(res["t"], res["u"])
    w = math.sqrt(K / M)
    env = U0 * laws.get(law).envelope(damper.theta(law, LAW_CASES[law], M, w, U0), tp, xp=np)[0]
    assert env[-1] < 0.8 * U0  # the damper did work
    assert np.max(np.abs(np.abs(yp) - env) / env) < 0.02
    linear = U0 * np.exp(-info["sdof"].p * tp)  # the dashpot of c_eq at the design amplitude
    assert np.max(np.abs(np.abs(yp) - linear) / linear) > 0.02


@pytest.mark.parametrize("law", NONLINEAR)
@pytest.mark.parametrize("unit", ["SI", "mm-ms-kg", "mm-s-t"])
def test_lsdyna_curve_read_back_is_the_law(tmp_path, law, unit):
    folder = write_damper_summary(tmp_path / law, law)
    text, info = build(folder, "lsdyna", units=unit)
    assert "*MAT_DAMPER_NONLINEAR_VISCOUS" in text and "*MAT_DAMPER_VISCOUS\n" not in text
    back = lsdyna.read_deck(text)
    sysu = units.get(unit)
    V, F = units.factor("velocity", sysu), units.factor("force", sysu)
    v = np.array([p[0] for p in back["damper_curve"]]) / V
    f = np.array([p[1] for p in back["damper_curve"]]) / F
    dmp = info["damper"]
    np.testing.assert_allclose(f, dmp.force(v), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(f[::-1], -f, rtol=1e-9, atol=1e-15)  # symmetric
    assert 0.0 in v and np.all(np.diff(v) > 0) and np.all(np.diff(f) >= 0)
    lo, hi = dmp.velocity_range
    assert v.max() >= damper.TABLE_REACH * hi * (1 - 1e-9) and v[v > 0].min() < lo
    slope = np.max(np.diff(f) / np.diff(v))  # the steepest segment, through 0
    assert slope <= M / info["dt"] * (1 + 1e-9)
    head = "\n".join(line for line in text.splitlines() if line.startswith("$"))
    for words in (f"{law} law", "verdict amplitude-dependent", "extrapolated", "Written by"):
        assert words in head.replace("\n$ ", " ")
    assert back["k"] == pytest.approx(K * units.factor("stiffness", sysu), rel=1e-6)


def test_calculix_has_no_nonlinear_dashpot_and_says_so(tmp_path):
    folder = write_damper_summary(tmp_path / "p", "power")
    text, info = build(folder, "calculix")
    back = calculix.read_deck(text)
    c_lin = json.loads((folder / "summary.json").read_text())["damper"]["c_linear"]["q50"]
    assert back["c"] == pytest.approx(c_lin, rel=1e-12)
    flat = " ".join(line[3:] for line in text.splitlines() if line.startswith("**"))
    assert "no nonlinear dashpot" in flat and "power law" in flat


def test_viscous_verdict_writes_the_viscous_dashpot_as_before(tmp_path):
    folder = write_damper_summary(tmp_path / "v", "viscous")
    text, info = build(folder, "lsdyna")
    assert lsdyna.read_deck(text)["c"] == pytest.approx(C, rel=1e-6)
    assert "*MAT_DAMPER_VISCOUS" in text and "Recommended damper: linear viscous" in text


def test_law_viscous_writes_c_linear_and_warns(tmp_path, capsys):
    folder = write_damper_summary(tmp_path / "p", "power")
    out = tmp_path / "deck.k"
    code, stdout, err = run(["export", folder, "--format", "lsdyna", "--law", "viscous",
                             "--out", out], capsys)
    assert code == 0
    c_lin = json.loads((folder / "summary.json").read_text())["damper"]["c_linear"]["q50"]
    text = out.read_text()
    assert lsdyna.read_deck(text)["c"] == pytest.approx(c_lin, rel=1e-6)
    assert "warning: --law viscous" in err and "power law" in err
    assert "--law viscous: a linear dashpot" in " ".join(
        line[2:] for line in text.splitlines() if line.startswith("$"))
    assert "dampfit export" in text and "--law viscous" in text  # the command in the header


def test_a_misfit_exports_nothing_without_force_law(tmp_path, capsys):
    folder = write_damper_summary(tmp_path / "m", None, coeffs={}, status="none",
                                  verdict="misfit")
    out = tmp_path / "deck.py"
    code, _, err = run(["export", folder, "--format", "opensees", "--out", out], capsys)
    assert_one_line_error(code, err, match="no damper is recommended")
    assert "--force-law" in err and not out.exists()
    code, _, err = run(["export", folder, "--format", "opensees", "--out", out,
                        "--force-law", "power"], capsys)
    assert_one_line_error(code, err, match="no fitted power law")
    summary = json.loads((folder / "summary.json").read_text())
    summary["damping_models"] = {"models": {"power": {"parameters": {
        "c_alpha": {"q50": 0.5}, "alpha": {"q50": 0.6}}}}}
    (folder / "summary.json").write_text(json.dumps(summary))
    code, _, err = run(["export", folder, "--format", "opensees", "--out", out,
                        "--force-law", "power"], capsys)
    assert code == 0 and "warning: --force-law power" in err
    assert "law_alpha = 0.6" in out.read_text()


def test_a_summary_without_a_damper_section_writes_the_viscous_c_with_a_note(tmp_path):
    folder = write_summary(tmp_path / "old")
    text, info = build(folder, "lsdyna")
    assert lsdyna.read_deck(text)["c"] == pytest.approx(C, rel=1e-6)
    assert "has no damper section" in text
    with pytest.raises(InputError, match="no damper section"):
        build(folder, "lsdyna", force_law="power")


def test_nonlinear_law_refuses_a_quantile_and_a_foreign_law(tmp_path):
    folder = write_damper_summary(tmp_path / "p", "power")
    with pytest.raises(InputError, match="--draws N"):
        build(folder, "opensees", quantile=0.95)
    with pytest.raises(InputError, match="--force-law coulomb"):
        build(folder, "opensees", law="coulomb")
    with pytest.raises(InputError, match="choose one of"):
        build(folder, "opensees", law="rubber")
    with pytest.raises(InputError, match="not both"):
        build(folder, "opensees", law="viscous", force_law="power")


@pytest.mark.parametrize("law", NONLINEAR)
def test_opensees_script_constants_are_the_coefficients_in_deck_units(tmp_path, law):
    folder = write_damper_summary(tmp_path / law, law)
    text, _ = build(folder, "opensees", units="mm-ms-kg")
    ns: dict = {}
    body = text.split("\ncli = argparse")[0].split('"""', 2)[2]
    exec(compile(body, "script", "exec"), ns)  # the constants block only (no OpenSees)
    F, V = units.factor("force", "mm-ms-kg"), units.factor("velocity", "mm-ms-kg")
    coeffs = LAW_CASES[law]
    if law == "power":
        assert ns["law_c_alpha"] == pytest.approx(coeffs["c_alpha"] * F / V ** 0.5, rel=1e-12)
    else:
        assert ns["law_c"] == pytest.approx(coeffs["c"] * F / V, rel=1e-12)
