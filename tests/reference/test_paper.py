"""The seed paper's worked example (Flis et al. 2025) recomputed by paper/reproduce_seed.py."""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "paper" / "reproduce_seed.py"


def _load():
    spec = importlib.util.spec_from_file_location("reproduce_seed", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def table():
    return {r["name"]: r for r in _load().rows()}


def _find(table, prefix):
    hits = [r for name, r in table.items() if name.startswith(prefix)]
    assert len(hits) == 1, (prefix, list(table))
    return hits[0]


def test_rows_have_the_documented_keys(table):
    keys = {"name", "equation", "paper_value", "dampfit_value", "digits", "agrees", "note"}
    for r in table.values():
        assert keys <= set(r)
        assert isinstance(r["agrees"], bool)


@pytest.mark.parametrize(
    "prefix, printed",
    [
        ("c = 2·m·p", 0.1897),
        ("δ = (1/97)", 0.0182827682),
        ("γ = δ/", 0.0029097806),
        ("ln(3.3/2.9)", 0.1292),
        ("c_kr = 2√(k·m)", 119.73),
    ],
)
def test_values_the_paper_gets_right_agree_when_rounded(table, prefix, printed):
    r = _find(table, prefix)
    assert r["paper_value"] == printed
    assert r["agrees"], r


@pytest.mark.parametrize(
    "prefix, printed, exact",
    [
        ("2m/t", 2.128, 2.1285140562),
        ("c = (2m/t)·ln", 0.27, 0.2750289867),
        ("0.6·c_kr", 71.83, 71.8384186908),
    ],
)
def test_truncated_values_agree_only_when_truncated(table, prefix, printed, exact):
    # The paper truncates these three (2.1285 -> 2.128, 0.2750 -> 0.27, 71.838 -> 71.83);
    # rounding to the printed digits would give 2.129, 0.28 and 71.84.
    r = _find(table, prefix)
    assert r["paper_value"] == printed
    assert math.isclose(r["dampfit_value"], exact, rel_tol=1e-9)
    assert r["agrees_truncated"] and not r["agrees"]
    # Off by at most one unit in the last printed digit.
    unit = 10.0 ** (math.floor(math.log10(printed)) - r["digits"] + 1)
    assert abs(r["dampfit_value"] - printed) < unit


def test_slow_motion_result_is_the_product_of_the_printed_factors(table):
    assert round(2.128 * 0.1292, 2) == _find(table, "c = (2m/t)·ln")["paper_value"]


def test_typeset_eq3_expression_drops_the_factor_two(table):
    r = _find(table, "c as typeset")
    assert not r["agrees"]
    assert math.isclose(2 * r["dampfit_value"], _find(table, "c = 2·m·p")["dampfit_value"])


def test_eq15_is_flagged_and_explained_by_m_6_3(table):
    r = _find(table, "c = γ·2√(k·m)")
    assert r["paper_value"] == 0.3798290195
    assert not r["agrees"]
    assert math.isclose(r["dampfit_value"], 0.0029097806 * 2 * math.sqrt(676.169 * 5.3),
                        rel_tol=1e-8)
    assert "6.3" in r["note"]
    slip = _find(table, "  same with m = 6.3")
    assert slip["agrees"]
    assert math.isclose(slip["dampfit_value"], 0.3798290195, rel_tol=1e-9)


def test_internal_inconsistencies_are_reported(table):
    assert _find(table, "(a) eq. 2 radicand")["dampfit_value"] < 0  # q imaginary
    fn = _find(table, "(b) f_n")
    assert not fn["agrees"] and math.isclose(fn["dampfit_value"], 1.798, abs_tol=5e-4)
    k = _find(table, "(b) k = m")
    assert not k["agrees"] and math.isclose(k["dampfit_value"], 619.0, abs_tol=0.1)
    d = _find(table, "(c) δ = p·T")
    assert not d["agrees"] and math.isclose(d["dampfit_value"], 0.0104, abs_tol=5e-5)
    spread = _find(table, "(c) spread")
    assert math.isclose(spread["dampfit_value"], 2.0, abs_tol=0.01)


def test_script_runs_and_prints_the_table():
    proc = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True,
                          timeout=60, cwd=SCRIPT.parents[1])
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    for text in ("quantity", "paper", "dampfit", "agree", "0.3798290195", "119.73", "Notes:"):
        assert text in out
    assert out.count("yes") >= 6 and "NO" in out
