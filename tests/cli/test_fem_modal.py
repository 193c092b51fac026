"""FEM hand-off of several modes (issue 21, item 5): Rayleigh α, β and per-mode ζ in the
OpenSees, LS-DYNA and CalculiX decks, read back; one-mode decks unchanged to the byte; the
OpenSees ``--modal`` run decays at the rates the exported α, β give; ``dampfit verify``
reports it; hostile summaries refused in one line with nothing written."""

from __future__ import annotations

import ast
import hashlib
import json
import math

import numpy as np
import pytest

from dampfit.cli import main
from dampfit.errors import InputError
from dampfit.fem import (
    calculix,
    lsdyna,
    modal,
    opensees,
    response,
    sdof,
    timestep,
    units,
    verify,
)
from dampfit.fem.export import Deck, build, output_interval
from tests._support.fem import (
    MODES,
    U0,
    C,
    K,
    M,
    modal_entries,
    write_modal_summary,
    write_result,
    write_summary,
)

FORMATS = ("lsdyna", "opensees", "calculix")


def _summary(folder):
    return json.loads((folder / "summary.json").read_text())


def _edit(folder, change):
    s = _summary(folder)
    change(s)
    (folder / "summary.json").write_text(json.dumps(s))
    return folder


# -- one mode: nothing changes ---------------------------------------------------------------

#: SHA-256 of the one-mode decks of :func:`_fixed_system` as main wrote them before issue 21
#: (commit ac6b4c9): the modal damping must not change a byte of them.
BEFORE = {
    ("lsdyna", "SI"): "8a642a5547380ebe5be857c8d122c9ed6b80a5a07a1231a34ff7227a25aeac74",
    ("lsdyna", "mm-ms-kg"): "3d2a039cad750dfb7b334fdfe713d8aae472ccce9db08558a3cc6cc68f8937d3",
    ("calculix", "SI"): "147a1e412863585635e485351f1164a34f5994493e5783691a373e148336b1d3",
    ("calculix", "mm-ms-kg"): "e7b318dbd3cdd1c98aee1242a3934db30560a0967286231c8307b192cef1cdab",
    ("opensees", "SI"): "73251d8dac7a7736fc43ee69eaea86c270c1e38047c13a5d4c2bf2c312167729",
    ("opensees", "mm-ms-kg"): "0d76b841e8d0e36074d21a94bcc9b01c900b63a01488357f5bcdb6f5bb046a36",
}


@pytest.mark.parametrize("fmt,unit", list(BEFORE))
def test_one_mode_decks_are_byte_identical_to_before(fmt, unit):
    s = sdof.Sdof(M, K, C, U0, source={"folder": "/data/result", "quantile": 0.5,
                                       "summary_sha256": "ab" * 32, "dampfit_version": "test"})
    out = output_interval(s.period, 500.0)
    dt = timestep.choose(s.omega_n, 10.0, out)
    write = {"lsdyna": lsdyna.deck, "calculix": calculix.deck, "opensees": opensees.script}[fmt]
    text = write(s, units.get(unit), (10.0, dt, out))
    assert hashlib.sha256(text.encode()).hexdigest() == BEFORE[fmt, unit]


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_one_mode_summary_with_modes_keys_gives_the_one_mode_deck(tmp_path, fmt):
    """A summary of the modes stage with one mode (any layout) exports exactly the deck of
    the summary without modes: same bytes, no modal block."""
    plain = write_summary(tmp_path / "r")
    text, info = build(plain, fmt)
    assert info["modal"] is None
    rows, _ = modal_entries(MODES[:1])
    for layout in ({"n_modes": 1, "modes": rows, "rayleigh": None},):  # summary.json's layout
        _edit(plain, lambda s, layout=layout: s.update(layout))
        again, info = build(plain, fmt)
        # the summary's hash is in the deck: compare with it put back
        digest = hashlib.sha256((plain / "summary.json").read_bytes()).hexdigest()
        assert info["modal"] is None
        _edit(plain, lambda s: [s.pop(k, None) for k in ("n_modes", "modes", "rayleigh")])
        original = hashlib.sha256((plain / "summary.json").read_bytes()).hexdigest()
        assert again.replace(digest[:16], original[:16]) == text


# -- reading the modes from a summary --------------------------------------------------------


@pytest.mark.parametrize("layout", ["list", "rayleigh", "stage"])
def test_modal_damping_reads_every_layout(tmp_path, layout):
    folder = write_modal_summary(tmp_path / layout, layout=layout)
    md = modal.modal_damping(_summary(folder))
    rows, ray = modal_entries()
    assert md["n_modes"] == 2 and md["mass_mode"] == 1 and not md["computed"]
    for got, want in zip(md["modes"], rows):
        assert got["f_n"] == {q: want["f_n"][q] for q in ("q05", "q50", "q95", "sd")}
    assert md["alpha"]["q50"] == ray["alpha"]["q50"] and md["beta"]["q95"] == ray["beta"]["q95"]
    assert md["statement"].startswith("exact")
    # ζ(ω_i) of the exported medians reproduces each measured ζ_i
    for z, row in zip(md["zeta_fitted"], md["modes"]):
        assert z == pytest.approx(row["zeta"]["q50"], rel=0.02)
    assert md["zeta_fitted"] == pytest.approx(
        [a["q50"] for a in ray["zeta_fitted"]], rel=0.02)


def test_modal_damping_is_none_for_one_mode_and_solves_a_missing_rayleigh(tmp_path):
    assert modal.modal_damping({"parameters": {}}) is None
    rows, _ = modal_entries()
    assert modal.modal_damping({"n_modes": 1, "modes": rows[:1]}) is None
    md = modal.modal_damping({"n_modes": 2, "modes": rows})  # no Rayleigh entry
    assert md["computed"] and "no interval" in modal.describe(md)[-2]
    w = [2 * math.pi * r["f_n"]["q50"] for r in rows]
    z = [r["zeta"]["q50"] for r in rows]
    assert md["zeta_fitted"] == pytest.approx(z, rel=1e-12)  # exact through both medians
    assert modal.decay_rates(md) == pytest.approx([zi * wi for zi, wi in zip(z, w)], rel=1e-12)


# -- the decks, read back --------------------------------------------------------------------


@pytest.mark.parametrize("unit", list(units.UNIT_SYSTEMS))
def test_lsdyna_and_calculix_decks_carry_the_modal_cards(tmp_path, unit):
    folder = write_modal_summary(tmp_path / "r")
    md = modal.modal_damping(_summary(folder))
    ff, ft = units.factor("frequency", unit), units.factor("time", unit)
    text, _ = build(folder, "lsdyna", Deck(units=unit))
    assert all(len(line) <= 80 for line in text.splitlines()) and text.endswith("\n*END\n")
    got = modal.read_lsdyna(text)
    assert got["alpha"] == pytest.approx(md["alpha"]["q50"] * ff, rel=1e-15)
    assert got["beta"] == pytest.approx(md["beta"]["q50"] * ft, rel=1e-15) and got["coef"] < 0
    assert lsdyna.read_deck(text)["c"] == pytest.approx(C * units.factor("damping", unit),
                                                        rel=1e-5)  # the SDOF is unchanged
    # the block is comments only: pasted without its prefix it is the cards
    assert not any(line.startswith("*DAMPING") for line in text.splitlines())
    for needle in ("*DAMPING_PART_MASS", "*DAMPING_PART_STIFFNESS", "zeta = 0.004",
                   "Misfit: exact: two modes determine alpha and beta"):
        assert needle in text
    text, _ = build(folder, "calculix", Deck(units=unit))
    got = modal.read_calculix(text)
    assert got["alpha"] == pytest.approx(md["alpha"]["q50"] * ff, rel=1e-15)
    assert got["beta"] == pytest.approx(md["beta"]["q50"] * ft, rel=1e-15)
    assert got["zeta"] == {i + 1: r["zeta"]["q50"] for i, r in enumerate(md["modes"])}
    assert calculix.read_deck(text)["c"] == pytest.approx(C * units.factor("damping", unit),
                                                          rel=1e-12)
    assert "*MODAL DAMPING, RAYLEIGH" in text and not any(
        line.startswith("*MODAL") for line in text.splitlines())
    # the Rayleigh ζ of the read-back α, β at each measured frequency (deck units)
    for row, z in zip(md["modes"], md["zeta_fitted"]):
        w = 2 * math.pi * row["f_n"]["q50"] * ff
        assert modal.zeta_of(got["alpha"], got["beta"], w) == pytest.approx(z, rel=1e-12)


def _constants(text):
    """The ``name = literal`` lines of an exported OpenSees script, evaluated."""
    out = {}
    for node in ast.parse(text).body:
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name):
            try:
                out[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                pass
    return out


@pytest.mark.parametrize("unit", ["SI", "mm-ms-kg"])
def test_opensees_script_carries_the_rayleigh_coefficients(tmp_path, unit):
    folder = write_modal_summary(tmp_path / "r")
    md = modal.modal_damping(_summary(folder))
    text, _ = build(folder, "opensees", Deck(units=unit))
    v = _constants(text)
    ff, ft = units.factor("frequency", unit), units.factor("time", unit)
    assert v["alphaM"] == md["alpha"]["q50"] * ff and v["betaK"] == md["beta"]["q50"] * ft
    assert v["modal_f"] == [r["f_n"]["q50"] * ff for r in md["modes"]]
    assert v["modal_zeta"] == [r["zeta"]["q50"] for r in md["modes"]]
    assert v["c"] == pytest.approx(C * units.factor("damping", unit))  # SDOF unchanged
    assert "ops.rayleigh(alphaM, betaK, 0.0, 0.0)" in text and "modalDamping" in text


# -- the OpenSees run ------------------------------------------------------------------------


@pytest.mark.usefixtures("requires_opensees")
def test_the_modal_run_decays_at_the_rayleigh_rates(tmp_path):
    """The exported script's --modal run: each mode's peaks fall at α/2 + β·ω_i²/2 (Newmark,
    T/200 of the highest mode: within 1e-3) and its ζ = p/ω_i is the measured ζ_i."""
    folder = write_modal_summary(tmp_path / "r", modes=((1.72, 0.0017), (10.0, 0.004),
                                                        (23.0, 0.0085)))
    md = modal.modal_damping(_summary(folder))
    assert md["dof"] == 1
    text, _ = build(folder, "opensees")
    step = opensees.modal_step(2 * math.pi * 23.0, 1 / (50 * 23.0))
    n = 4 * math.ceil(8.0 / (4 * step))
    res = opensees.run_modal(text, 3, step, n, 4)
    assert res["u"].shape == (n // 4 + 1, 3) and np.all(res["u"][0] == 1.0)
    for i, (row, p) in enumerate(zip(md["modes"], modal.decay_rates(md))):
        fem = response.peak_decay_rate(res["t"], res["u"][:, i])
        assert fem["p"] == pytest.approx(p, rel=1e-3), i
        zeta = fem["p"] / (2 * math.pi * row["f_n"]["q50"])
        assert zeta == pytest.approx(md["zeta_fitted"][i], rel=1e-3)
        assert abs(zeta / row["zeta"]["q50"] - 1) <= md["max_relative_misfit"] + 1e-3


@pytest.mark.usefixtures("requires_opensees")
def test_verify_reports_the_modal_run(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    rows, ray = modal_entries()
    _edit(folder, lambda s: s.update(n_modes=2, modes=rows, modes_rayleigh=ray))
    result = verify.run(folder)
    rep = result["report"]["modal_damping"]
    assert rep["run_options"][0] == "--modal" and len(rep["modes"]) == 2
    for m in rep["modes"]:
        assert m["fem_matches_rayleigh"] and m["zeta_in_measured_interval"], m
        assert m["within_misfit"] and abs(m["fem_vs_rayleigh"]) < 1e-3
    assert result["report"]["decay_rate"]["relative_difference"] == pytest.approx(0, abs=1e-3)
    table = verify.table(result["report"])
    assert "mode 2 (9.9997 Hz)" in table and "alpha/2 + beta*w^2/2" in table
    json.dumps(result["report"], allow_nan=False)


# -- the command and hostile summaries --------------------------------------------------------


def test_export_cli_prints_the_modal_damping(tmp_path, capsys):
    folder = write_modal_summary(tmp_path / "r")
    assert main(["export", str(folder), "--format", "calculix"]) == 0
    out = capsys.readouterr().out
    assert "modal damping of 2 modes: Rayleigh alpha = " in out
    assert modal.read_calculix((folder / "sdof_calculix.inp").read_text()) is not None


def test_hostile_statement_cannot_become_a_card_or_code(tmp_path):
    bad = 'x"""\n*INCLUDE\nevil.k\n**> *MODAL\nimport os; os.system("rm -rf /")\n$> *END\u2028\u03b1'
    folder = write_modal_summary(tmp_path / "r")
    _edit(folder, lambda s: s["modes_rayleigh"].update(statement=bad))
    for fmt in FORMATS:
        text, _ = build(folder, fmt)
        lines = text.splitlines()
        assert not any(line.startswith(("*INCLUDE", "evil", "import os;")) for line in lines)
        assert sum(line.startswith(("$>", "**>")) for line in lines) == \
            {"lsdyna": 8, "calculix": 5, "opensees": 0}[fmt]
        if fmt == "opensees":
            tree = ast.parse(text)  # one docstring, no injected statement
            assert not any(isinstance(n, ast.Expr) and isinstance(n.value, ast.Call)
                           for n in tree.body[:8])  # the docstring, then the imports
            assert text.count('"""') == 2 and "os.system" not in text.split('"""')[2]
        assert "Misfit: x'''" in text.replace('"', "'") or "Misfit: x" in text
    assert modal.read_lsdyna(build(folder, "lsdyna")[0])["beta"] > 0


@pytest.mark.parametrize("change,message", [
    # refused by the one summary reader (result.schema) before the decks read them
    (lambda s: s.update(modes="two"), "'modes' must be a list"),
    (lambda s: s.update(n_modes=3), "'n_modes' must be a whole number from 1 to the 2 entries"),
    (lambda s: s["modes"][1]["f_n"].update(q50="10"), r"modes\[1\].f_n.q50 must be a number"),
    (lambda s: s["modes"][1]["f_n"].update(q50=float("nan")), r"modes\[1\].f_n.q50 must be"),
    (lambda s: s["modes"][0]["f_n"].update(q50=-1.0), r"modes\[0\].f_n.q50 must be positive"),
    (lambda s: s["modes"][1]["zeta"].update(q50=1.5), "not below 1: the mode does not oscillate"),
    (lambda s: s["modes"][1].update(f_n=s["modes"][0]["f_n"]), "must increase strictly"),
    (lambda s: s["modes_rayleigh"]["alpha"].update(q50=True), "rayleigh.alpha.q50 must be a number"),
    (lambda s: s["modes_rayleigh"].update(beta=[1]), "rayleigh.beta must be an object"),
    (lambda s: s.update(modes_rayleigh="exact"), "the Rayleigh entry must be an object"),
    (lambda s: s["modes_rayleigh"]["alpha"].update(q50=-1e3), "damping ratio <= 0"),
])
@pytest.mark.parametrize("fmt", FORMATS)
def test_hostile_modal_summary_is_one_line_and_nothing_written(tmp_path, capsys, change,
                                                               message, fmt):
    folder = _edit(write_modal_summary(tmp_path / "r"), change)
    assert main(["export", str(folder), "--format", fmt]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dampfit: error:"), err
    assert __import__("re").search(message, err[0]), err[0]
    assert not list(folder.glob("sdof_*")) and not list(folder.glob(".sdof_*"))
    with pytest.raises(InputError):
        modal.modal_damping(_summary(folder))


# -- seen, not identified (issue 32): never in a deck or a Rayleigh fit -------------------------


def _seen_summary(folder):
    """Two modes in ``modes``, the second (10 Hz) also listed in ``modes_seen`` (a harmonic),
    plus a ``modes_seen`` component at 2.847 Hz; ``rayleigh`` null (fewer than two identified).
    (The ``"identified"`` flag itself is checked on the plain dict below: the result reader
    of this branch does not know the flag yet; the modes branch adds it to MODE_FLAGS.)"""
    from tests._support.fem import write_modal_summary

    write_modal_summary(folder, layout="rayleigh")
    path = folder / "summary.json"
    s = json.loads(path.read_text())
    s["rayleigh"] = None
    s["modes_seen"] = [{"f_n": {"q50": 2.847, "q05": 1.5, "q95": 5.3}, "zeta": None,
                        "kind": "harmonic", "reason": "4x the mode at 0.7145 Hz"},
                       {"f_n": dict(s["modes"][1]["f_n"]), "zeta": None, "kind": "basin-filling",
                        "reason": "the posterior fills its basin"}]
    path.write_text(json.dumps(s))
    return folder


@pytest.mark.parametrize("fmt", ["lsdyna", "opensees", "calculix"])
def test_modes_seen_not_identified_reach_no_deck_and_no_rayleigh(tmp_path, fmt):
    folder = _seen_summary(tmp_path / "r")
    text, info = build(folder, fmt)
    assert info["modal"] is None
    for card in ("DAMPING_PART_MASS", "--modal", "MODAL DAMPING", "alphaM"):
        assert card not in text
    flat = " ".join(text.split()).replace("$ ", "").replace("** ", "").replace("# ", "")
    assert "Seen, not identified as modes" in flat and "2.847 Hz (harmonic)" in flat
    assert "(basin-filling)" in flat and "No Rayleigh damping: 1 identified mode" in flat


def test_a_mode_flagged_not_identified_is_left_out_even_with_a_rayleigh_entry():
    """Three modes, the 10 Hz one ``"identified": false``: the Rayleigh block holds the two
    identified ones only, the note names the one left out; with ``rayleigh`` null and one
    identified mode there is no block at all; an old summary (no flag) keeps every mode."""
    modes = (MODES[0], (10.0, 0.004), (17.0, 0.006))
    rows, ray = modal_entries(modes)
    old = modal.modal_damping({"modes": rows, "rayleigh": ray})
    assert old["n_modes"] == 3
    rows[1]["identified"] = False
    md = modal.modal_damping({"modes": rows, "rayleigh": ray})
    assert [round(r["f_n"]["q50"]) for r in md["modes"]] == [round(MODES[0][0]), 17]
    assert "10 Hz (not identified)" in modal.modal_note({"modes": rows, "rayleigh": ray})
    rows[2]["identified"] = False
    assert modal.modal_damping({"modes": rows, "rayleigh": None}) is None
    assert "No Rayleigh damping: 1 identified mode" in modal.modal_note({"modes": rows,
                                                                          "rayleigh": None})
