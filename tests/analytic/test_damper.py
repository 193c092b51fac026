"""The recommended damper (summary.json's ``damper``, :mod:`dampfit.damping.damper`) from
draws with a known truth, the verdict texts it leads with, and the outputs that lead with it.

The draws are built from the closed forms (K2) of :mod:`dampfit.model.laws`, so every number
the section gives has an exact value to compare with.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dampfit.damping import checks
from dampfit.damping.damper import MAX_DRAWS, LawDraws, recommend
from dampfit.model.laws import LAWS, lam
from dampfit.output import text as render
from tests._support.summaries import summary

M, W, A0 = 0.5, 2 * math.pi * 3.0, 0.02  # [kg], [rad/s], [m]
C_ALPHA, ALPHA = 0.02, 0.5  # [N (s/m)^alpha], [1]
MEASURED = (0.0025, 0.019)  # [m]


def power_draws(n: int = 6000, spread: float = 0.01, mass=M, seed: int = 0) -> LawDraws:
    """Draws of the power law around the truth: θ = (ln p₀, α, ln ω), p₀ = ρ(a₀) (K2)."""
    rng = np.random.default_rng(seed)
    alpha = ALPHA + spread * rng.standard_normal(n)
    c_alpha = C_ALPHA * (1 + spread * rng.standard_normal(n))
    p0 = c_alpha * (W * A0) ** (alpha - 1) * lam(alpha) / (2 * math.pi * M)
    theta = np.column_stack([np.log(p0), alpha, np.full(n, math.log(W))])
    return LawDraws("power", theta, np.full(n, A0), None if mass is None else np.full(n, M))


def viscous_draws(c: float = 0.06, n: int = 3000) -> LawDraws:
    rng = np.random.default_rng(1)
    p = c / (2 * M) * (1 + 0.01 * rng.standard_normal(n))
    theta = np.column_stack([np.log(p), np.full(n, math.log(W))])
    return LawDraws("viscous", theta, np.full(n, A0), np.full(n, M))


def damper(**kw):
    args = dict(verdict="amplitude-dependent", reasons=["windowed slope decisive"], law="power",
                draws=power_draws(), measured=MEASURED, amplitude=None, mass=M, mass_sd=0.0)
    args.update(kw)
    args["amplitudes"] = (args.pop("measured"), args.pop("amplitude"))
    args["mass"] = (args["mass"], args.pop("mass_sd"))
    return recommend(**args)


def test_the_power_law_is_recommended_with_its_own_coefficients():
    d = damper()
    s = d.section
    assert s["status"] == "recommended" and s["law"] == "power"
    assert set(s["coefficients"]) == {"c_alpha", "alpha"}
    assert s["coefficients"]["c_alpha"]["q50"] == pytest.approx(C_ALPHA, rel=0.01)
    assert s["coefficients"]["c_alpha"]["unit"] == "N (s/m)^alpha"
    assert s["coefficients"]["alpha"]["q05"] < ALPHA < s["coefficients"]["alpha"]["q95"]
    assert s["k"]["q50"] == pytest.approx(M * W * W)
    assert s["measured_range"]["velocity_m_s"] == pytest.approx([W * a for a in MEASURED])
    # design amplitude: the middle of the measured range, said so
    a_d = math.sqrt(MEASURED[0] * MEASURED[1])
    assert s["design_amplitude"]["source"] == "middle of the measured range"
    assert s["design_amplitude"]["displacement_m"] == pytest.approx(a_d)
    assert s["design_amplitude"]["velocity_m_s"] == pytest.approx(W * a_d)
    # c_eq = λ·c_α·(ω·A)^(α−1)/π (FEMA 274)
    c_eq = lam(ALPHA) * C_ALPHA * (W * a_d) ** (ALPHA - 1) / math.pi
    assert s["c_linear"]["q50"] == pytest.approx(c_eq, rel=0.01)
    assert s["zeta_linear"]["q50"] == pytest.approx(c_eq / (2 * M * W), rel=0.01)
    # ±10 %: c_eq ∝ A^(α−1), so A_d·1.1^(1/(α−1)) … A_d·0.9^(1/(α−1))
    lo, hi = s["linear_within_10pct_m"]
    assert lo == pytest.approx(a_d * 1.1 ** (1 / (ALPHA - 1)), rel=0.03)
    assert hi == pytest.approx(a_d * 0.9 ** (1 / (ALPHA - 1)), rel=0.03)
    assert s["draws"] == {"group": "damper", "n": MAX_DRAWS}
    assert set(d.draws) >= {"mass", "k", "f_n", "c_alpha", "alpha", "c_linear", "zeta_linear"}
    assert all(len(v) == MAX_DRAWS for v in d.draws.values())
    assert d.attrs == {"law": "power", "design_amplitude_m": pytest.approx(a_d)}


def test_a_given_design_amplitude_is_used_and_named():
    s = damper(amplitude=0.01).section
    assert s["design_amplitude"]["displacement_m"] == 0.01
    assert s["design_amplitude"]["source"] == "--amplitude"
    c_eq = lam(ALPHA) * C_ALPHA * (W * 0.01) ** (ALPHA - 1) / math.pi
    assert s["c_linear"]["q50"] == pytest.approx(c_eq, rel=0.01)


def test_the_draws_are_thinned_reproducibly():
    a, b = damper(seed=3), damper(seed=3)
    assert np.array_equal(a.draws["c_alpha"], b.draws["c_alpha"])
    assert not np.array_equal(a.draws["c_alpha"], damper(seed=4).draws["c_alpha"])
    small = damper(draws=power_draws(n=500))
    assert small.section["draws"]["n"] == 500


def test_adequate_recommends_the_viscous_c_over_every_amplitude():
    s = damper(verdict="adequate", law=None, reasons=["no amplitude dependence: …"],
               draws=viscous_draws()).section
    assert s["status"] == "recommended" and s["law"] == "viscous"
    assert list(s["coefficients"]) == ["c"]
    assert s["coefficients"]["c"]["q50"] == pytest.approx(0.06, rel=0.01)
    assert s["c_linear"]["q50"] == pytest.approx(s["coefficients"]["c"]["q50"])
    a_d = s["design_amplitude"]["displacement_m"]
    lo, hi = s["linear_within_10pct_m"]  # a linear law: the whole search range
    assert lo == pytest.approx(MEASURED[0] / 10) and hi == pytest.approx(MEASURED[1] * 10)
    assert lo < a_d < hi and s["not_ruled_out"] is None and s["try"] is None


def test_inconclusive_keeps_the_viscous_c_and_says_what_is_not_ruled_out():
    ctx = {"bound": 2.5, "bound_source": "windowed slope", "white_at_f0": True,
           "best_nonlinear": "coulomb", "best_weight": 0.3}
    s = damper(verdict="inconclusive", law=None, draws=viscous_draws(), context=ctx,
               reasons=["the amplitudes span too little to tell"]).section
    assert s["status"] == "viscous-stands" and s["law"] == "viscous"
    nro = s["not_ruled_out"]
    assert "up to 2.5x" in nro and "0.0025 and 0.019 m" in nro and "coulomb law (P = 0.3)" in nro
    assert nro.endswith("cannot be ruled out")
    # a dependence the data bound is said to be bounded, not "not ruled out"
    ctx = {"bound": 1.004, "white_at_f0": False, "ljung_box_p": 0.0014}
    nro = damper(verdict="inconclusive", law=None, draws=viscous_draws(), context=ctx,
                 reasons=["structured"]).section["not_ruled_out"]
    assert nro.startswith("structure at f0") and "bounded: ζ changes by at most 0.4 %" in nro


def test_a_misfit_recommends_nothing_and_says_what_to_try():
    d = damper(verdict="misfit", law=None, reasons=["viscous residual rms 12 % of the signal"],
               context={"criteria": {"frequency_drift": True}})
    s = d.section
    assert s["status"] == "none" and s["law"] is None and s["coefficients"] == {}
    assert s["reason"] == "viscous residual rms 12 % of the signal"
    assert "--window" in s["try"] and d.draws is None
    assert s["c_linear"] is None and s["draws"] is None
    # an amplitude dependence no law describes: no damper either
    s = damper(law=None).section
    assert s["status"] == "none" and "no damping law describes it" in s["reason"]


def test_without_a_mass_only_mass_free_coefficients_and_rates_are_given():
    s = damper(draws=power_draws(mass=None), mass=None).section
    assert list(s["coefficients"]) == ["alpha"]
    per = s["per_unit_mass"]["c_alpha_per_kg"]
    assert per["q50"] == pytest.approx(C_ALPHA / M, rel=0.01) and per["unit"].endswith("/kg")
    assert s["c_linear"] is None and s["k"] is None and s["mass"]["value"] is None
    assert s["zeta_linear"]["q50"] > 0 and s["linear_within_10pct_m"] is not None
    assert "no mass given" in s["missing"]


def test_every_law_names_its_coefficients_in_si():
    names = {law: [c.name for c in LAWS[law].coefficients] for law in LAWS}
    assert names == {"viscous": ["c"], "coulomb": ["c", "F_c"], "quadratic": ["c", "c2"],
                     "power": ["c_alpha", "alpha"]}
    v = np.array([-0.2, 0.1])
    assert LAWS["coulomb"].force(v, {"c": 1.0, "F_c": 0.5}) == pytest.approx([-0.7, 0.6])
    assert LAWS["power"].force(v, {"c_alpha": 2.0, "alpha": 0.5}) == pytest.approx(
        [-2 * 0.2**0.5, 2 * 0.1**0.5])


# -- the verdict texts: no sentence speaks of a c not computed or contradicts its numbers -----

def _inconclusive():
    return checks.adequacy(n_cycles=60.0, slope={"s": 0.0, "s_sd": 0.5, "s_q05": -0.8,
                                                 "s_q95": 0.8, "n_windows": 8,
                                                 "chi2_per_dof": 1.0},
                           amplitude_span=1.5, freq=None,
                           laws=checks.LawEvidence(p_viscous=0.9, best_nonlinear="power"),
                           fits=checks.FitChecks(viscous={"ljung_box_p": 0.5, "r_excess": 1.0,
                                                          "resid_fraction": 0.01,
                                                          "noise_excess": 1.0}, best=None))


def test_without_a_mass_the_warnings_speak_of_zeta_not_c():
    res = _inconclusive()
    assert res["verdict"] == "inconclusive"
    assert "treat c as an estimate" in checks.verdict_warning(res)
    text = checks.verdict_warning(res, has_mass=False)
    assert "treat zeta as an estimate" in text and "treat c" not in text
    assert text.startswith("inconclusive: the recording cannot tell whether one viscous zeta")
    misfit = dict(res, verdict="misfit")
    assert "c and its interval" not in checks.verdict_warning(misfit, has_mass=False)
    assert "zeta and its interval are not trustworthy" in checks.verdict_warning(
        misfit, has_mass=False)
    gone = dict(res, criteria={"no_decay": True}, reasons=["no decay measured"])
    assert "zeta, p and delta are reported" in checks.verdict_warning(gone, has_mass=False)


def _inconclusive_summary(p_viscous: float, weights: dict) -> dict:
    s = summary()
    s["model_checks"] = {"verdict": "inconclusive", "preferred_model": "viscous",
                         "verdict_reasons": ["weak evidence either way"],
                         "amplitude_dependence": {"p_viscous": p_viscous}}
    s["damping_models"] = {"comparison": [{"model": m, "weight": w} for m, w in weights.items()]}
    return s


@pytest.mark.parametrize("p_viscous, weights", [
    (1.0, {"viscous": 1.0, "quadratic": 0.0017}),
    (0.47, {"viscous": 0.47, "power": 0.31, "coulomb": 0.22}),
])
def test_an_inconclusive_line_does_not_contradict_its_probability(p_viscous, weights):
    """The demo (simulated viscous) printed "inconclusive … (P(one viscous c) = 1, viscous
    fits best)", and P = 0.47 printed "below 0.5 … viscous fits best"."""
    line = render._damping_law_line(_inconclusive_summary(p_viscous, weights))
    assert "fits best" not in line and "not enough for a verdict" in line
    other = max((m for m in weights if m != "viscous"), key=weights.get)
    assert f"most probable other law {other}" in line
    assert ("leans to one viscous c" in line) == (p_viscous >= 0.5)


# -- every output leads with the damper ------------------------------------------------------

def with_damper() -> dict:
    s = summary()
    s["damper"] = damper().section
    return s


def test_the_terminal_leads_with_the_damper_and_names_the_viscous_c():
    lines = render.text(with_damper()).splitlines()
    first = next(i for i, x in enumerate(lines) if x.startswith("  ") and x.strip()
                 and not x.startswith(("  phyphox", "  free-decay", "  window", "  mass")))
    assert lines[first].startswith("  RECOMMENDED DAMPER: the power law")
    block = "\n".join(lines[first:first + 9])
    assert "c_α" in block and "N (s/m)^alpha" in block and "measured over" in block
    assert "middle of the measured range" in block and "within ±10 %" in block
    post = lines.index("  viscous posterior (one c; not adequate here)")
    assert post > first
    assert any(x.startswith("  least squares (viscous)") for x in lines)
    assert any(x.startswith("  log decrement (seed paper baseline)") for x in lines)
    assert render.headline(with_damper()).startswith("power damper c_α = ")


def test_the_notebook_table_leads_with_the_damper():
    html = render.html_table(with_damper())
    assert html.startswith("<p><b>RECOMMENDED DAMPER: the power law")
    assert html.index("c_α") < html.index("viscous posterior (one c; not adequate here)")
    s = with_damper()
    s["damper"]["reason"] = "<script>x</script>"
    assert "<script>" not in render.html_table(s)


def test_the_damper_frequency_is_the_mean_over_the_window_of_the_drifting_phase():
    """ω̄ = (ψ(τ₁) − ψ(τ₀))/T of (K4) — not ω alone when an odd Legendre term is fitted."""
    from dampfit.damping.damper import mean_omega

    law = LAWS["power"].with_phase(3)
    tau = np.linspace(0.0, 40.0, 4001)
    theta = np.array([[math.log(0.05), 0.5, math.log(W), 0.8, -1.3, 0.4]])
    psi = law.phase(theta, tau, xp=np)[0][0]
    assert mean_omega(law, theta, 40.0)[0] == pytest.approx((psi[-1] - psi[0]) / 40.0)
    assert mean_omega(law, theta, 40.0)[0] != pytest.approx(W, rel=1e-4)


def _paths(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, path + (i,))
    yield path


def test_an_edited_damper_section_renders_everywhere_without_a_crash():
    """Every field of summary.json's damper (a user may edit it) replaced by an odd value: the
    terminal, the notebook table, the headline and the report's first box still render."""
    from dampfit.output.report.single import build_single

    import copy

    base = with_damper()
    for path in [p for p in _paths(base["damper"]) if p] + [()]:
        for odd in (None, "<odd>", {}, [1, "a"], float("nan"), True):
            s = copy.deepcopy(base)
            if path:
                parent = s["damper"]
                for k in path[:-1]:
                    parent = parent[k]
                parent[path[-1]] = odd
            else:
                s["damper"] = odd
            render.text(s), render.html_table(s), render.headline(s)
            title, blocks = build_single({"summary": s}, __import__("pathlib").Path("."), "now")
            assert blocks[0][0] == "h1"


@pytest.mark.parametrize("verdict", ["misfit", "inconclusive", "adequate"])
def test_the_report_verdict_words_speak_of_zeta_without_a_mass(verdict):
    from pathlib import Path

    from dampfit.output.report.checks import model_checks

    s = summary(mass={"value": None, "sd": None, "unit": "kg"})
    s["model_checks"] = {"verdict": verdict, "verdict_reasons": ["why"], "verdict_law": None}
    words = str(model_checks(s, Path(".")))
    assert "viscous c" not in words and "c and its interval" not in words
    assert "ζ" in words
    s["mass"]["value"] = 0.2
    with_mass = str(model_checks(s, Path(".")))
    assert any(w in with_mass for w in ("viscous c", "(c)", "so c and"))
