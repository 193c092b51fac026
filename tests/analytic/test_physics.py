"""dampfit.physics: the one conversion of (p, ω_d) into physical quantities, the one mass
check and the one units table, and that the pipeline, posterior, estimators, bound and
output use them."""

from __future__ import annotations

import inspect
import math
import warnings

import numpy as np
import pytest

from dampfit import physics
from dampfit.errors import InputError

P, WD, M, ACC = 0.0923, 10.8, 5.3, 2.4  # [1/s], [rad/s], [kg], [m/s²]


def test_quantities_follow_the_sdof_relations():
    q = physics.quantities(P, WD, M, accel_amplitude=ACC)
    wn2 = P**2 + WD**2
    wn = math.sqrt(wn2)
    expect = {"p": P, "omega_d": WD, "omega_n": wn, "f_n": wn / (2 * math.pi),
              "f_d": WD / (2 * math.pi), "zeta": P / wn, "delta": 2 * math.pi * P / WD,
              "Q": wn / (2 * P), "c": 2 * M * P, "k": M * wn2, "c_crit": 2 * M * wn,
              "u0": ACC / wn2}
    assert set(q) == set(expect)
    for name, value in expect.items():
        assert float(q[name]) == pytest.approx(value, rel=1e-14), name
    # the mass-dependent ones round-trip through to_decay and critical_damping
    p2, wd2 = physics.to_decay(q["c"], q["k"], M)
    assert (float(p2), float(wd2)) == pytest.approx((P, WD), rel=1e-12)
    assert float(q["c_crit"]) == pytest.approx(float(physics.critical_damping(q["k"], M)), rel=1e-12)
    assert float(q["zeta"]) == pytest.approx(float(q["c"] / q["c_crit"]), rel=1e-12)


def test_quantities_from_the_natural_frequency_are_the_same():
    """A campaign's population draws come as (p, ω_n): the same quantities, and an overdamped
    draw (p ≥ ω_n) keeps finite c, k, ζ, f_n where ω_d, f_d and δ are NaN."""
    wn = math.hypot(P, WD)
    a, b = physics.quantities(P, WD, M), physics.quantities(P, mass=M, omega_n=wn)
    assert set(a) == set(b)
    for name in a:
        assert float(b[name]) == pytest.approx(float(a[name]), rel=1e-12), name
    over = physics.quantities(np.array([2.0]), mass=M, omega_n=np.array([1.0]))
    assert all(np.isfinite(over[n]).all() for n in ("c", "k", "zeta", "f_n", "Q", "c_crit"))
    assert np.isnan(over["omega_d"]).all() and np.isnan(over["delta"]).all()
    with pytest.raises(TypeError, match="exactly one"):
        physics.quantities(P, WD, omega_n=wn)


def test_quantities_without_mass_or_amplitude_are_mass_free():
    q = physics.quantities(P, WD)
    assert not {"c", "k", "c_crit", "u0"} & set(q)


def test_quantities_broadcast_draws():
    p = np.array([0.1, 0.2, 0.3])
    m = np.array([[5.0], [6.0]])  # mass draws along another axis
    q = physics.quantities(p, 10.0, m, accel_amplitude=np.ones(3))
    assert q["c"].shape == (2, 3) and q["zeta"].shape == (3,) and q["u0"].shape == (3,)
    np.testing.assert_allclose(q["c"], 2 * m * p)


def test_quantities_are_differentiable_by_jax():
    import jax
    import jax.numpy as jnp

    with jax.enable_x64(True):
        grad = jax.grad(lambda x: physics.quantities(x[0], x[1], M)["c"])(jnp.array([P, WD]))
    assert np.asarray(grad) == pytest.approx([2 * M, 0.0])


def test_u0_convention_matches_least_squares_and_bound():
    from dampfit.inference import crlb

    a, b = 1.5, -0.7
    q = physics.quantities(P, WD, accel_amplitude=math.hypot(a, b))
    t = np.linspace(0.0, 20.0, 400)
    bound = crlb.bound(t, 0.1, p=P, omega_d=WD, a_cos=a, a_sin=b, mass=M)
    assert bound["u0"]["value"] == pytest.approx(float(q["u0"]), rel=1e-12)
    assert bound["c"]["value"] == pytest.approx(2 * M * P, rel=1e-12)


# -- one mass check ----------------------------------------------------------------------------
@pytest.mark.parametrize(("mass", "sd", "substrings"), [
    (-1.0, None, ("mass must be positive", "mass must be a positive",
                  "positive number of kilograms")),
    (0.0, None, ("mass must be positive",)),
    (float("nan"), None, ("mass must be positive",)),
    ("heavy", None, ("mass must be a positive",)),
    (None, 0.1, ("without --mass", "without mass")),
    (1.0, -0.1, ("mass_sd", "standard deviation")),
    (1.0, float("nan"), ("mass_sd", "standard deviation")),
    (1.0, 0.6, ("more than half the mass",)),
])
def test_check_mass_has_one_message_set(mass, sd, substrings):
    with pytest.raises(InputError) as err:
        physics.check_mass(mass, sd)
    msg = str(err.value)
    assert "\n" not in msg
    for s in substrings:
        assert s in msg


def test_check_mass_returns_floats():
    assert physics.check_mass(None) == (None, 0.0)
    assert physics.check_mass(None, 0.0) == (None, 0.0)
    assert physics.check_mass(np.float32(2.0), 0.1) == (2.0, pytest.approx(0.1))
    assert physics.check_mass(5, None) == (5.0, 0.0)


def test_every_mass_check_is_the_physics_one():
    from dampfit import pipeline
    from dampfit.estimators import baselines
    from dampfit.inference import crlb
    from dampfit.simulate import config as simulate_config
    from dampfit.study import registry

    for mod in (pipeline, simulate_config, baselines, registry, crlb):
        src = inspect.getsource(mod)
        # physics.Mass is the check (issue 37: built once and carried); check_mass wraps it
        assert "check_mass(" in src or "Mass(" in src or "as_mass(" in src, mod.__name__
        assert "positive number of kilograms" not in src, mod.__name__


# -- one units table ---------------------------------------------------------------------------
def test_units_come_from_one_table():
    from dampfit import analysis
    from dampfit.damping import quantities
    from dampfit.inference import crlb
    from dampfit.output import text

    for table in (analysis.PARAMETER_UNITS, crlb.UNITS):
        assert all(unit == physics.UNITS[name] for name, unit in table.items())
    assert all(quantities.UNITS[name] == physics.UNITS[name] for name in physics.UNITS
               if name in quantities.UNITS)
    assert text._LABELS["c"] == "c      [N s/m]"


# -- one summariser, diagnostics computed once --------------------------------------------------
def _idata(rng):
    import arviz as az

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return az.from_dict(posterior={"p": rng.normal(1.0, 0.1, (8, 50)),
                                       "mass": np.full((8, 50), M)})


def test_posterior_diagnostics_are_arviz_rhat_and_bulk_ess():
    import arviz as az

    from dampfit.inference.posterior import quantity_diagnostics

    idata = _idata(np.random.default_rng(1))
    diag = quantity_diagnostics(idata)
    x = np.asarray(idata.posterior["p"])
    assert diag["p"]["r_hat"] == pytest.approx(float(az.rhat(x)), rel=1e-12)
    assert diag["p"]["ess_bulk"] == pytest.approx(float(az.ess(x, method="bulk")), rel=1e-12)
    assert math.isnan(diag["mass"]["r_hat"])  # constant draws


def test_param_summary_takes_the_posterior_diagnostics():
    from dampfit.analysis import _param_summary

    idata = _idata(np.random.default_rng(2))
    diag = {"p": {"r_hat": 1.234, "ess_bulk": 56.0}}
    s = _param_summary(idata, "p", diag)  # given values are reported, not recomputed
    assert (s["r_hat"], s["ess_bulk"]) == (1.234, 56.0)
    x = np.asarray(idata.posterior["p"]).ravel()
    assert s["unit"] == "1/s" and s["mean"] == pytest.approx(x.mean())
    assert s["sd"] == pytest.approx(x.std(ddof=1))
    assert [s["q05"], s["q50"], s["q95"]] == pytest.approx(np.quantile(x, [0.05, 0.5, 0.95]))
    assert list(s) == ["unit", "mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk"]
    assert math.isnan(_param_summary(idata, "p", {})["r_hat"])


# -- figures draw, they do not compute ---------------------------------------------------------
def test_figures_neither_compute_physics_nor_evaluate_the_model():
    from dampfit.output import figures

    src = inspect.getsource(figures)
    assert "jax" not in src and "design_matrix" not in src
    assert "np.hypot(p" not in src and "2 * an.mass" not in src


def test_mass_is_checked_once_on_construction_and_kept_as_floats():
    """physics.Mass (issue 37): the one mass check; check_mass is its tuple form."""
    import dataclasses

    from dampfit.errors import InputError
    from dampfit.physics import Mass, check_mass

    m = Mass(2, None)
    assert (m.value, m.sd) == (2.0, 0.0) and isinstance(m.value, float)
    assert Mass() == Mass(None, None) == Mass(None, 0.0)
    assert check_mass(0.5, 0.01) == (Mass(0.5, 0.01).value, Mass(0.5, 0.01).sd) == (0.5, 0.01)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.value = 3.0
    for args, match in (((0.0,), "mass must be positive"), ((1.0, 0.6), "more than half"),
                        ((None, 0.1), "without mass"), ((1.0, float("nan")), "must be ≥ 0 kg")):
        with pytest.raises(InputError, match=match):
            Mass(*args)


@pytest.mark.heavy
def test_a_checked_mass_is_carried_not_checked_again(monkeypatch):
    """Issue 37: the analysis builds its Mass once; the stages it passes it to (the baselines,
    the least squares, both CRLBs) take it as it is, and a plain number is still checked at
    those public functions' edge."""
    from dampfit import physics, simulate as sim, stages
    from dampfit.errors import InputError
    from dampfit.estimators import baselines
    from dampfit.inference import crlb
    from dampfit.signal import prepare

    rec, _ = sim.recording(sim.from_modal(0.8, 3.3, 0.006, duration=10.0, sample_rate=100.0,
                                          noise_density=150.0, u0=0.004, seed=3))
    prep = prepare.prepare(rec)
    checked = physics.Mass(0.8, 0.01)
    built = []
    original = physics.Mass.__post_init__
    monkeypatch.setattr(physics.Mass, "__post_init__",
                        lambda self: (built.append(self.value), original(self))[1])
    st = stages.fit_stages(prep, checked)
    ls = st.least_squares
    bound = crlb.bound(st.fit_data.tau, st.noise.sigma, p=ls.p, omega_d=ls.omega_d, a_cos=1.0,
                       a_sin=0.0, mass=checked)
    modes = crlb.bound_modes(st.fit_data.tau, st.noise.sigma, [[ls.p, ls.omega_d, 1.0, 0.0]],
                             mass=checked, mode_of_mass=0)
    assert built == []  # nothing along the path made (checked) a mass again
    assert bound["mass"] == 0.8 and bound["mass_sd"] == 0.01 and "c" in modes[0]
    grid = prep.grid[prep.grid_in_window], prep.grid_signal[prep.grid_in_window]
    by_object = baselines.log_decrement(*grid, prep.fs, prep.band, mass=checked)
    by_number = baselines.log_decrement(*grid, prep.fs, prep.band, mass=0.8)
    assert by_object.c == by_number.c and built == [0.8]  # the number was checked, once
    with pytest.raises(InputError, match="mass must be positive"):
        baselines.envelope_pipeline(*grid, prep.fs, prep.band, mass=-1.0)
