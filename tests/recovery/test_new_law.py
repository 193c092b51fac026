"""A new damping law is one class: a fifth law defined only here, registered with
:func:`dampfit.model.registry.register`, is fitted, sampled, compared, reported, offered by
``--model`` and can be the recommended damper — with no edit anywhere else.

The law is the power law with its exponent fixed at 1/2, F = c_h·|v|^½·sgn(v): its averaged
envelope is (K3) of :mod:`dampfit.model.laws` with α = ½, e = (1 − p₀τ/2)², and the recording
is a power-law decay with α = 0.5 solved exactly (``tests/_support/reference_sim``), so its
c_h is the simulated c_α.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from dampfit.damping import assess, damper
from dampfit.damping import Settings
from dampfit.model import laws, registry
from dampfit.model.laws import Coefficient, lam
from dampfit.output.report.checks import model_checks
from dampfit.signal import prepare
from tests._support.reference_sim import noisy_recording, reference_decay

M, F, U0, FS = 0.5, 3.0, 0.02, 100.0  # [kg], [Hz], [m], [Hz]
K = M * (2 * math.pi * F) ** 2
C_H = 0.02  # [N (s/m)^0.5]


@dataclass(frozen=True)
class HalfPower(laws.Law):
    """f_d = c_h·|u̇|^½·sgn(u̇): θ = (ln p₀, ln ω, phase…), e = (1 − p₀τ/2)²."""

    name: ClassVar[str] = "half-power"
    own: ClassVar[tuple[str, ...]] = ("ln_p0",)
    own_units: ClassVar[tuple[str, ...]] = ("ln(1/s)",)
    prior_weight: ClassVar[float] = 1 / 6
    coefficients: ClassVar[tuple[Coefficient, ...]] = (
        Coefficient("c_h", "N (s/m)^0.5", "c_h"),)
    force_text: ClassVar[str] = "F = c_h·|v|^0.5·sgn(v)"
    fem_hint: ClassVar[str] = "a nonlinear viscous damper with alpha = 0.5"
    colour: ClassVar[str] = "tab:red"

    def envelope(self, theta, tau, xp=laws.jnp):
        p0 = xp.exp(theta[..., 0])[..., None]
        arg = 1.0 - 0.5 * p0 * tau
        ok = arg > 1e-9
        safe = xp.where(ok, arg, 1.0)
        e = xp.where(ok, safe * safe, 0.0)
        return e, xp.where(ok, p0 * safe, 0.0), xp.where(ok, 0.5 * p0 / safe, 0.0)

    def local_rate(self, theta, ratio):
        p0 = np.exp(np.asarray(theta, dtype=float)[..., 0])
        return p0 * np.asarray(ratio, dtype=float) ** -0.5

    def _coefficients(self, p0, s, w, a0):
        return {"c_h/m": 2.0 * math.pi * p0 * np.sqrt(w * a0) / lam(0.5)}

    def force(self, velocity, coefficients):
        v = np.asarray(velocity, dtype=float)
        return coefficients["c_h"] * np.sqrt(np.abs(v)) * np.sign(v)


@pytest.fixture()
def half_power():
    law = registry.register(HalfPower())
    try:
        yield law
    finally:
        registry.unregister(law.name)


@pytest.fixture(scope="module")
def recording():
    t = np.arange(0, 40.0, 1 / FS)
    accel = reference_decay(t, M, K, U0, c_alpha=C_H, alpha=0.5)[2]
    prep = prepare.prepare(noisy_recording(t, accel, 0.02 * np.max(np.abs(accel)), seed=1,
                                           lead=1.0))
    return prep, prepare.fit_data(prep)


def test_registration_is_checked_and_undone():
    before = laws.names()
    law = registry.register(HalfPower())
    assert laws.names() == before + ("half-power",) and "half-power" in laws.MODELS
    assert sum(registry.prior_weights().values()) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="already registered"):
        registry.register(HalfPower())
    registry.unregister(law.name)
    assert laws.names() == before and registry.prior_weights()["viscous"] == 0.5
    with pytest.raises(ValueError, match="cannot be removed"):
        registry.unregister("viscous")


def test_the_command_line_offers_a_registered_law(half_power):
    from dampfit.cli import get_parser

    args = get_parser().parse_args(["analyze", "x.csv", "--model", "half-power"])
    assert args.model == "half-power"


def test_a_registered_law_is_fitted_compared_reported_and_recommended(half_power, recording):
    prep, fd = recording
    res = assess(prep, fd, None, None, mass=M, settings=Settings("laplace"))
    assert "half-power" in res.fits and res.fits["half-power"].converged
    s = res.summary()
    table = {r["model"]: r for r in s["damping_models"]["comparison"]}
    assert set(table) == {"viscous", "coulomb", "quadratic", "power", "half-power"}
    assert s["damping_models"]["model_prior"]["half-power"] == pytest.approx(1 / 7)
    entry = s["damping_models"]["models"]["half-power"]
    c_h = entry["parameters"]["c_h"]
    assert c_h["unit"] == "N (s/m)^0.5" and c_h["q05"] <= C_H <= c_h["q95"], c_h
    assert entry["force"] == HalfPower.force_text and entry["style"] == {"colour": "tab:red"}
    assert s["amplitude_curve"]["models"]["half-power"]["colour"] == "tab:red"
    # the report's laws table names its coefficient
    blocks = model_checks(s, Path("."))
    rows = [r for b in blocks if b[0] == "table" for r in b[2] if r and r[0] == "half-power"]
    assert rows and "c_h = " in rows[0][2]
    # the simpler of the two laws that fit (power, half-power) wins the evidence, and the
    # verdict names it: it is the recommended damper
    assert res.adequacy["verdict"] == "amplitude-dependent"
    assert res.adequacy["law"] == "half-power" and table["half-power"]["weight"] > 0.9
    sec = damper.from_assessment(res, None, amplitude=None).section
    assert sec["status"] == "recommended" and sec["law"] == "half-power"
    assert sec["force"] == HalfPower.force_text
    assert sec["coefficients"]["c_h"]["q05"] <= C_H <= sec["coefficients"]["c_h"]["q95"]
