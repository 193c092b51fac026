"""FEM hand-off (``dampfit export``): unit conversion, fixed-width cards, decks read back, CLI.

CalculiX and LS-DYNA are not installed here: their decks are checked by reading them back and
evaluating what they imply (the static equilibrium and the release position) with each
solver's documented conventions. The OpenSeesPy script is run and compared with the closed
form of the free decay.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.fem import calculix, keyword, lsdyna, opensees, sdof, timestep, units
from dampfit.fem.export import Deck, build, output_interval
from dampfit.simulate import free_decay
from tests._support.fem import C, K, M, U0, write_summary

@pytest.fixture
def result(tmp_path):
    return write_summary(tmp_path / "result")


# -- units -----------------------------------------------------------------------------------


def test_unit_factors_are_the_hand_derived_ones():
    f = units.factor
    # mm-ms-kg: force kg·mm/ms² = 1e3 N = kN; c: 1 N·s/m = 1 kg/s = 1e-3 kg/ms = 1e-3 kN·ms/mm
    assert f("force", "mm-ms-kg") == pytest.approx(1e-3, rel=1e-15)
    assert f("damping", "mm-ms-kg") == pytest.approx(1e-3, rel=1e-15)
    assert f("stiffness", "mm-ms-kg") == pytest.approx(1e-6, rel=1e-15)
    assert f("mass", "mm-ms-kg") == 1.0
    assert f("acceleration", "mm-ms-kg") * units.STANDARD_GRAVITY == pytest.approx(9.80665e-3)
    # mm-s-t: force t·mm/s² = 1 N; k: 1 N/m = 1e-3 N/mm; c: 1e-3 N·s/mm; m: 1 kg = 1e-3 t
    assert f("force", "mm-s-t") == pytest.approx(1.0, rel=1e-15)
    assert f("stiffness", "mm-s-t") == pytest.approx(1e-3, rel=1e-15)
    assert f("damping", "mm-s-t") == pytest.approx(1e-3, rel=1e-15)
    assert f("mass", "mm-s-t") == pytest.approx(1e-3, rel=1e-15)
    assert f("acceleration", "mm-s-t") * units.STANDARD_GRAVITY == pytest.approx(9806.65)
    assert all(f(q, "SI") == 1.0 for q in units.DIMENSIONS)
    assert units.get("mm-ms-kg").label("damping") == "kN*ms/mm"
    assert units.get("mm-s-t").label("stiffness") == "N/mm"


@pytest.mark.parametrize("name", list(units.UNIT_SYSTEMS))
def test_converted_system_has_the_same_physics(name):
    """ω_n and ζ from converted (m, k, c) are the SI ones (ω_n in the system's 1/time)."""
    m, k, c = (units.to_system(v, q, name) for v, q in ((M, "mass"), (K, "stiffness"), (C, "damping")))
    wn_si, zeta_si = math.sqrt(K / M), C / (2 * math.sqrt(K * M))
    assert math.sqrt(k / m) == pytest.approx(units.to_system(wn_si, "frequency", name), rel=1e-13)
    assert c / (2 * math.sqrt(k * m)) == pytest.approx(zeta_si, rel=1e-13)
    # the force unit is mass·length/time² of the system: k·u is a force in it
    u = units.to_system(U0, "length", name)
    assert k * u == pytest.approx(units.to_system(K * U0, "force", name), rel=1e-13)


def test_unknown_unit_system_is_an_input_error():
    with pytest.raises(InputError, match="unknown unit system 'inch'"):
        units.get("inch")


# -- fixed-width numbers ---------------------------------------------------------------------


@pytest.mark.parametrize("width,rel_small,rel_any", [(10, 5e-6, 5e-4), (16, 5e-11, 5e-9),
                                                     (20, 5e-15, 5e-13)])
def test_format_real_fits_with_the_best_precision(width, rel_small, rel_any):
    """Every value fits its field and keeps at least as many digits as d.ddddE-e allows."""
    rng = np.random.default_rng(3)
    moderate = rng.uniform(1, 10, 300) * 10.0 ** rng.integers(-9, 9, 300)        # |exponent| < 10
    anything = rng.uniform(-10, 10, 300) * 10.0 ** rng.integers(-99, 99, 300)
    for values, rel in ((moderate, rel_small), (anything, rel_any)):
        for x in values:
            text = keyword.format_real(x, width)
            assert len(text) == width and (("." in text) or ("E" in text))
            assert abs(keyword.read_real(text) / x - 1) <= rel, (x, text)
    for x in (0.2, 5.3, 618.98599, 0.0002, -2.5e-4, 123456.0):   # repr fits: exact
        assert float(keyword.format_real(x)) == x
    assert keyword.format_real(618.985996).strip() == "618.985996"   # 9 digits, not 6.19E2
    assert keyword.format_real(0.000123456789).strip() == "1.23457E-4"
    assert keyword.card([1, 0.000618998]) == "         16.18998E-4"  # LS-PrePost style
    with pytest.raises(ValueError, match="non-finite"):
        keyword.format_real(float("nan"))


# -- LS-DYNA ---------------------------------------------------------------------------------


def _system(gravity=False, u0=U0):
    return sdof.Sdof(M, K, C, u0, g=units.STANDARD_GRAVITY if gravity else 0.0)


@pytest.mark.parametrize("gravity", [False, True])
@pytest.mark.parametrize("name", list(units.UNIT_SYSTEMS))
def test_lsdyna_deck_round_trip(name, gravity):
    s, u = _system(gravity), units.get(name)
    out = output_interval(s.period, 500.0)
    dt = timestep.choose(s.omega_n, 60.0, out)
    text = lsdyna.deck(s, u, (60.0, dt, out))
    lines = text.splitlines()
    assert lines[0] == "*KEYWORD" and lines[-1] == "*END"
    assert all(len(line) <= 80 for line in lines)
    names = {line.split()[0] for line in lines if line.startswith("*")}
    assert {"*ELEMENT_DISCRETE", "*ELEMENT_MASS", "*SECTION_DISCRETE", "*MAT_SPRING_ELASTIC",
            "*MAT_DAMPER_VISCOUS", "*PART", "*NODE", "*CONTROL_TERMINATION", "*CONTROL_TIMESTEP",
            "*DATABASE_NODOUT", "*DATABASE_HISTORY_NODE", "*BOUNDARY_SPC_NODE"} <= names
    assert ("*LOAD_BODY_Y" in names) == gravity
    r = lsdyna.read_deck(text)
    f = units.factor
    assert r["mass"] / f("mass", u) == pytest.approx(M, rel=1e-6)
    assert r["k"] / f("stiffness", u) == pytest.approx(K, rel=1e-5)
    assert r["c"] / f("damping", u) == pytest.approx(C, rel=1e-5)
    assert r["duration"] / f("time", u) == pytest.approx(60.0, rel=1e-6)
    assert r["dt"] / f("time", u) == pytest.approx(dt, rel=1e-5)
    assert r["output_dt"] / f("time", u) == pytest.approx(out, rel=1e-6)
    assert r["g"] / f("acceleration", u) == pytest.approx(s.g, rel=1e-6)
    # what LS-DYNA would do: released at rest u0 above the static equilibrium
    assert r["u0"] / f("length", u) == pytest.approx(U0, rel=1e-5)
    assert r["v0"] == 0.0 and r["axis_y"] == pytest.approx(-1.0)
    assert r["spc"][1] == [1] * 6 and r["spc"][2] == [1, 0, 1, 1, 1, 1]


def test_lsdyna_offset_carries_the_initial_force():
    """The spring's OFFSET is its elongation at t = 0: the net force on the mass is −k·u0."""
    s = _system(gravity=True, u0=-0.03)
    r = lsdyna.read_deck(lsdyna.deck(s, units.get("SI"), (10.0, 1e-3, 2e-3)))
    spring_up = r["k"] * r["offset"]          # tension pulls the hanging mass up
    assert spring_up - r["mass"] * r["g"] == pytest.approx(-K * -0.03, rel=1e-6)


# -- CalculiX --------------------------------------------------------------------------------


@pytest.mark.parametrize("gravity", [False, True])
@pytest.mark.parametrize("name", list(units.UNIT_SYSTEMS))
def test_calculix_deck_round_trip(name, gravity):
    s, u = _system(gravity), units.get(name)
    out = output_interval(s.period, 500.0)
    dt = timestep.choose(s.omega_n, 20.0, out)
    text = calculix.deck(s, u, (20.0, dt, out))
    r = calculix.read_deck(text)
    f = units.factor
    assert r["mass"] / f("mass", u) == pytest.approx(M, rel=1e-12)
    assert r["k"] / f("stiffness", u) == pytest.approx(K, rel=1e-12)
    assert r["c"] / f("damping", u) == pytest.approx(C, rel=1e-12)
    assert r["u0"] / f("length", u) == pytest.approx(U0, rel=1e-9)
    assert -r["cload"] / f("force", u) == pytest.approx(M * s.g, rel=1e-12)
    assert r["dt"] / f("time", u) == pytest.approx(dt, rel=1e-12)
    assert r["duration"] / f("time", u) == pytest.approx(20.0, rel=1e-3)
    assert r["alpha"] == 0.0 and r["direct"]
    assert r["output_every"] * dt == pytest.approx(out, rel=1e-9)
    inc = int(next(x for x in text.splitlines() if x.startswith("*STEP, INC=")).split("=")[1])
    assert inc >= round(20.0 / dt)
    # *SPRING/*DASHPOT: blank first line (SPRINGA/DASHPOTA), constant as a real with a point
    lines = text.splitlines()
    for card in ("*SPRING, ELSET=ESPRING", "*DASHPOT, ELSET=EDASHPOT"):
        i = lines.index(card)
        assert lines[i + 1] == "" and "." in lines[i + 2]


def test_calculix_real_always_has_a_point():
    assert calculix.real(1e-05) == "1.0e-05" and calculix.real(619.0) == "619.0"
    assert float(calculix.real(0.1 + 0.2)) == 0.1 + 0.2


# -- OpenSees script -------------------------------------------------------------------------


@pytest.mark.usefixtures("requires_opensees")
@pytest.mark.parametrize("name,gravity", [("SI", False), ("mm-ms-kg", True)])
def test_exported_opensees_script_runs_and_matches_the_closed_form(tmp_path, name, gravity):
    s, u = _system(gravity), units.get(name)
    duration = 3 * s.period
    out = output_interval(s.period, 500.0)
    dt = timestep.choose(s.omega_n, duration, out)
    path = tmp_path / "model.py"
    path.write_text(opensees.script(s, u, (duration, dt, out), name=path.name))
    run = subprocess.run([sys.executable, str(path), str(tmp_path / "h.csv")], capture_output=True,
                         text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    data = np.loadtxt(tmp_path / "h.csv", delimiter=",", skiprows=1)
    t = data[:, 0] / units.factor("time", u)
    disp = data[:, 1] / units.factor("length", u) + s.sag       # from static equilibrium
    exact, _, _ = free_decay(t, M, C, K, U0)
    assert t[-1] == pytest.approx(duration, rel=1e-3)
    # phase budget 1e-3 rad at the end (timestep.choose) → relative error about 1e-3
    assert np.max(np.abs(disp - exact)) / U0 < 2e-3


# -- export: the system and the command ----------------------------------------------------


def test_build_reads_the_requested_quantile(result):
    _, lo = build(result, "lsdyna", Deck(quantile=0.05))
    _, hi = build(result, "lsdyna", Deck(quantile=0.95))
    assert lo["c"] == pytest.approx(0.99 * C) and hi["k"] == pytest.approx(1.01 * K)
    assert lo["duration"] == pytest.approx(10.0)   # the analysed window
    assert lo["output_dt"] == pytest.approx(0.002)


def test_other_quantiles_come_from_the_posterior(result):
    import arviz as az

    rng = np.random.default_rng(0)
    draws = {n: v * (1 + 0.01 * rng.standard_normal((4, 200))) for n, v in (("c", C), ("k", K), ("u0", U0))}
    az.from_dict(posterior=draws).to_netcdf(str(result / "posterior.nc"), engine="h5netcdf")
    _, info = build(result, "calculix", Deck(quantile=0.3))
    for name in ("c", "k", "u0"):
        assert info[name] == pytest.approx(np.quantile(draws[name], 0.3), rel=1e-12)


def test_export_cli_writes_refuses_overwrite_and_forces(result, capsys):
    assert main(["export", str(result), "--format", "lsdyna", "--units", "mm-ms-kg"]) == 0
    deck = result / "sdof_lsdyna.k"
    text = deck.read_text()
    r = lsdyna.read_deck(text)
    assert r["k"] == pytest.approx(K * 1e-6, rel=1e-5) and r["g"] == 0.0
    assert "wrote" in capsys.readouterr().out
    assert main(["export", str(result), "--format", "lsdyna"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists; use --force" in err[0]
    assert deck.read_text() == text
    assert main(["export", str(result), "--format", "lsdyna", "--gravity", "--force"]) == 0
    assert lsdyna.read_deck(deck.read_text())["g"] == pytest.approx(units.STANDARD_GRAVITY)
    assert not list(result.glob(".sdof_lsdyna.k.*")), "temporary file left behind"
    out = result / "deck.inp"
    assert main(["export", str(result), "--format", "calculix", "--out", str(out),
                 "--duration", "5"]) == 0
    assert calculix.read_deck(out.read_text())["duration"] == pytest.approx(5.0, rel=1e-3)


@pytest.mark.parametrize("args,message", [
    (["--format", "ansys"], "invalid choice: 'ansys'"),
    (["--format", "lsdyna", "--quantile", "1.0"], "strictly between 0 and 1"),
    (["--format", "lsdyna", "--quantile", "0"], "strictly between 0 and 1"),
    (["--format", "lsdyna", "--quantile", "x"], "not a number"),
    (["--format", "lsdyna", "--quantile", "0.3"], "posterior.nc, which is missing"),
    (["--format", "lsdyna", "--duration", "-2"], "--duration must be a positive"),
    (["--format", "lsdyna", "--units", "inch"], "invalid choice: 'inch'"),
    (["--format", "opensees", "--out", "/nonexistent/dir/x.py"], "does not exist"),
])
def test_export_cli_bad_input_is_one_line(result, capsys, args, message):
    assert main(["export", str(result), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dampfit: error:") and message in err[0]
    assert not list(result.glob("sdof_*"))


def test_export_input_errors(tmp_path):
    with pytest.raises(InputError, match="is not a directory"):
        build(tmp_path / "missing", "lsdyna")
    with pytest.raises(InputError, match="summary.json not found"):
        build(tmp_path, "lsdyna")
    with pytest.raises(InputError, match="no mass, so c and k are not identified"):
        build(write_summary(tmp_path / "nomass", mass=None), "opensees")
    with pytest.raises(InputError, match="unknown format 'abaqus'"):
        build(write_summary(tmp_path / "ok"), "abaqus")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "summary.json").write_text("{not json")
    with pytest.raises(InputError, match="not readable JSON"):
        build(tmp_path / "bad", "lsdyna")
    with pytest.raises(InputError, match="does not oscillate"):
        sdof.Sdof(M, K, 2 * math.sqrt(K * M), U0)
