"""Stage 1 of a campaign: each recording on its own (:func:`fit_test`), as
:func:`dampfit.pipeline.analyze` does it — preparation, least squares, the single-recording
refusals, the noise calibration r_i, the Laplace expansion of the tempered profiled
likelihood ℓ_i (eqs. C1, C2 of :mod:`dampfit.campaign.model`) and the test's damping-law
verdict — and the tests' expansions gathered into the model's data (:func:`campaign_data`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dampfit.campaign.checks import INADEQUATE
from dampfit.errors import InputError


@dataclass(eq=False)
class TestFit:
    """One recording's single-test stage: preparation, least squares, noise calibration and
    the Laplace expansion of its tempered likelihood.

    ``theta_hat`` (ln p, ln ω_d) at the maximum of ℓ_i, ``cov_theta`` its Laplace covariance,
    ``ll_max`` ℓ_i(θ̂) [1], ``psi_hat`` (ln p, ln ω_n) and ``sigma_psi`` Σ_i (C2),
    ``temper`` 1/r_i, ``amplitude_m`` the displacement amplitude at the release [m] (the least-squares
    amplitude at the window start carried back to :func:`dampfit.signal.window.release_time`)."""

    index: int
    recording: Any
    prepared: Any
    fit_data: Any
    least_squares: Any
    noise: Any
    temper: float
    theta_hat: np.ndarray
    cov_theta: np.ndarray
    ll_max: float
    psi_hat: np.ndarray
    sigma_psi: np.ndarray
    amplitude_m: float
    added_mass_kg: float | None
    warnings: list[str] = field(default_factory=list)
    #: this test's damping-law verdict (:mod:`dampfit.damping`: "adequate" when one viscous c
    #: describes its decay; "amplitude-dependent", "misfit", …), None if it could not be made
    damping_verdict: str | None = None
    #: several modes of this test (:mod:`dampfit.campaign.modes`), None unless the campaign
    #: asked for them (``max_modes`` > 1)
    modes: dict | None = None

    @property
    def name(self) -> str:
        path = self.recording.path
        return os.path.basename(str(path)) if path else f"recording {self.index + 1}"

    def samples(self):
        """:class:`dampfit.model.profile.Samples` of the padded fit data (inside x64)."""
        from dampfit.model.profile import Samples

        return Samples.from_padded(self.fit_data.padded)


def fit_test(i: int, rec, axis, window, band, mass, dm) -> TestFit:
    """Stage 1 for recording ``i`` (as :func:`dampfit.pipeline.analyze`; ``mass`` the
    campaign's checked :class:`~dampfit.physics.Mass`), every refusal prefixed with the test
    it concerns."""
    try:
        return _fit_test_inner(i, rec, axis, window, band, mass, dm)
    except InputError as exc:
        name = os.path.basename(str(rec.path)) if rec.path else f"recording {i + 1}"
        raise InputError(f"test {i + 1} ({name}): {exc}") from None


def _fit_test_inner(i, rec, axis, window, band, mass, dm) -> TestFit:
    import jax

    from dampfit import stages
    from dampfit.campaign import model
    from dampfit.signal import prepare

    warns: list[str] = []
    stages.refuse_impossible_time(rec)
    prep = prepare.prepare(rec, axis=axis, window=window, band=band)
    warns.extend(prep.warnings)
    warns.extend(stages.unit_plausibility(rec, prep, mass.value))
    st = stages.fit_stages(prep, mass)
    warns.extend(st.warnings)
    fd, ls, nm = st.fit_data, st.least_squares, st.noise
    temper = 1.0 / nm.psd_ratio
    with jax.enable_x64(True):
        from dampfit.model.profile import Samples

        samples = Samples.from_padded(fd.padded)
        theta, cov, ll_max = model.laplace(np.asarray(ls.theta[:2], float), samples, temper,
                                           np.asarray(ls.cov[:2, :2]) / temper)
    if not (np.all(np.isfinite(theta)) and np.isfinite(ll_max)):
        raise InputError("its likelihood could not be evaluated at the least-squares decay")
    psi, sigma = model.to_population(theta, cov)
    # the displacement amplitude at the release: the least-squares u₀ at the window start
    # carried back over the decay the window skipped (window.release_time), so that it does
    # not depend on the test's own decay rate (it did: tests that merely scatter were called
    # "amplitude-dependent" in 23 of 100 simulated campaigns)
    from dampfit.signal.window import release_time

    skipped = max(fd.t0 - release_time(prep.grid, prep.envelope, prep.window[0], prep.f0), 0.0)
    amp = float(stages.ls_quantities(ls)["u0"] * np.exp(ls.p * skipped))
    verdict = _damping_verdict(prep, fd, ls, nm, mass.value, warns)
    return TestFit(index=i, recording=rec, prepared=prep, fit_data=fd, least_squares=ls,
                   noise=nm, temper=temper, theta_hat=theta, cov_theta=cov, ll_max=ll_max,
                   psi_hat=psi, sigma_psi=sigma, amplitude_m=amp,
                   added_mass_kg=None if dm is None else float(dm), warnings=warns,
                   damping_verdict=verdict)



def _damping_verdict(prep, fd, ls, nm, mass, warns: list[str]) -> str | None:
    """This test's damping-law verdict (:func:`dampfit.damping.assess`, Laplace evidence only:
    no sampling), and a warning when one viscous c does not describe its decay: the hierarchy
    pools one decay rate per test, so within-test amplitude dependence (ζ falling with the
    amplitude, as in most real dampers) is averaged, not modelled."""
    from dampfit import damping

    try:
        res = damping.assess(prep, fd, ls, nm, mass, settings=damping.Settings("laplace"))
    except InputError as exc:
        warns.append(f"damping-law check not made: {exc}")
        return None
    verdict = res.verdict_name
    if verdict in INADEQUATE:
        warns.append(f"one viscous c does not describe this test's decay (damping-law check: "
                     f"{verdict}); its pooled c averages over its amplitudes — analyse the "
                     "file alone for ζ(amplitude) and the damping laws")
    return verdict


def campaign_data(tests: list[TestFit], dm, dm_sd):
    """(:class:`~dampfit.campaign.model.CampaignData`, prior centres) and the added-mass
    design's refusals (:func:`dampfit.campaign.checks.check_added_mass_design`)."""
    import jax
    import jax.numpy as jnp

    from dampfit.campaign import checks, model

    psi = np.array([t.psi_hat for t in tests])
    sigma = np.array([t.sigma_psi for t in tests])
    if dm is None:
        centre = np.array([psi[:, 0].mean(), psi[:, 1].mean()])
        dm_arr = np.zeros(len(tests))
    else:
        dm_arr = np.asarray(dm, float)
    sd_arr = np.where(dm_arr > 0, dm_sd, 0.0)  # the bare system's Δm = 0 is exact
    if dm is not None:
        centre = np.array(checks.check_added_mass_design(psi, sigma, dm_arr, sd_arr))
    with jax.enable_x64(True):
        data = model.CampaignData(jnp.asarray(psi), jnp.asarray(sigma), jnp.asarray(dm_arr),
                                  jnp.asarray(sd_arr), jnp.asarray(centre),
                                  jnp.float64(1.0 if dm is not None else 0.0))
    return data, centre
