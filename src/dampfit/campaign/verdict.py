"""Stage 6 of a campaign: the checks and the one-sentence verdict (:func:`assess`), computed
once after the sampling and stored on the result, so the summary only renders them.

The tests' own estimates (:func:`own_estimates`) feed the statistics of
:mod:`dampfit.campaign.checks`: Cochran's heterogeneity of the decay rates and of the
frequencies, the leave-one-out outliers, the regressions on the release amplitude, and the
between-test verdict; each test's within-test damping-law verdict
(:data:`~dampfit.campaign.checks.INADEQUATE`) is added to the sentence.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from dampfit.campaign import checks


@dataclass(frozen=True)
class CampaignChecks:
    """The checks of a campaign (the "checks" section of its summary).

    ``verdict`` and ``text`` (:func:`dampfit.campaign.checks.verdict`, with the within-test
    clause), ``tau_over_within`` [1] the median between-test spread of ln p over the median
    own sd, ``heterogeneity_p_value`` and ``frequency_heterogeneity_p_value`` (Cochran),
    ``frequency_spread`` [1] the between-test sd of ln ω_n, ``frequency_disagrees``,
    ``outliers`` (0-based test indices), ``amplitude`` (the regression of the decay rates on
    the release amplitude, its ``"frequency"`` entry that of the frequencies),
    ``within_test_inadequate`` (1-based tests whose own damping-law check found one viscous c
    inadequate) and ``consistent`` (the decay rates agree by Cochran's test)."""

    verdict: str
    text: str
    tau_over_within: float
    heterogeneity_p_value: float
    frequency_heterogeneity_p_value: float
    frequency_spread: float
    frequency_disagrees: bool
    outliers: list[int]
    amplitude: dict[str, Any]
    within_test_inadequate: list[int] = field(default_factory=list)
    consistent: bool = True

    @property
    def spread_consistent_with_zero(self) -> bool:
        """The tests agree in decay rate and frequency (no relevant disagreement)."""
        return bool(self.consistent and not self.frequency_disagrees)

    def summary(self) -> dict[str, Any]:
        """The "checks" section of the campaign summary (outliers 1-based)."""
        return {"verdict": self.verdict, "text": self.text,
                "tau_over_within": self.tau_over_within,
                "heterogeneity_p_value": self.heterogeneity_p_value,
                "frequency_heterogeneity_p_value": self.frequency_heterogeneity_p_value,
                "frequency_spread": self.frequency_spread,
                "frequency_disagrees": self.frequency_disagrees,
                "outliers": [i + 1 for i in self.outliers],
                "amplitude": self.amplitude,
                "within_test_inadequate": self.within_test_inadequate}


def own_estimates(tests: Sequence, m0: float | None, added_mass_sd: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The tests' own estimates the verdicts compare: (y, s) the decay, (y_ω, s_ω) the
    frequency, each with its sd [1].

    y_i is the own ln p̂_i; in added-mass mode (``m0`` [kg], the posterior median of m₀, not
    None) ln ĉ_i = ln p̂_i + ln(2·(m₀ + Δm_i)). An added mass known to ± ``added_mass_sd`` [kg]
    (the bare system's 0 exactly) moves ln M_i by sd/M_i: ln c by as much, the bare system's
    ln ω_n by half (model eq. C4). y_ω,i is the own ln ω̂_n,i (in added-mass mode of the bare
    system: + ½·ln(1 + Δm_i/m₀))."""
    added = m0 is not None
    y, s, yw, sw = [], [], [], []
    for t in tests:
        dm_sd = added_mass_sd if added and t.added_mass_kg > 0 else 0.0
        rel = dm_sd / (m0 + t.added_mass_kg) if added else 0.0
        y.append(t.psi_hat[0] + (np.log(2 * (m0 + t.added_mass_kg)) if added else 0.0))
        s.append(np.sqrt(t.sigma_psi[0, 0] + rel**2))
        yw.append(t.psi_hat[1] + (0.5 * np.log1p(t.added_mass_kg / m0) if added else 0.0))
        sw.append(np.sqrt(t.sigma_psi[1, 1] + (0.5 * rel) ** 2))
    return np.array(y), np.array(s), np.array(yw), np.array(sw)


def assess(tests: Sequence, tau_p: np.ndarray, m0: float | None, added_mass_sd: float,
           tau_scale: float) -> CampaignChecks:
    """The checks and the verdict of the campaign of ``tests`` (:class:`~dampfit.campaign.
    tests.TestFit`): ``tau_p`` the posterior draws of the between-test sd of ln p [1], ``m0``
    [kg] the posterior median of m₀ in added-mass mode (None otherwise), ``added_mass_sd``
    [kg] the scale's sd, ``tau_scale`` the half-normal prior scale of τ_p [1]
    (:data:`dampfit.campaign.model.TAU_P_SCALE`) the outlier check uses too."""
    y, s, yw, sw = own_estimates(tests, m0, added_mass_sd)
    _, p_het = checks.heterogeneity(y, s)
    consistent = bool(p_het >= checks.ALPHA)
    _, p_het_w = checks.heterogeneity(yw, sw)
    spread_w = checks.spread(yw, sw)
    freq_off = bool(p_het_w < checks.ALPHA and spread_w > checks.FREQUENCY_RELEVANT)
    ratio = float(np.median(np.asarray(tau_p).ravel()) / np.median(s))
    outliers = checks.loo_outliers(y, s, tau_scale)
    amps = [t.amplitude_m for t in tests]
    amplitude = checks.amplitude_regression(y, s, amps)
    amplitude_w = checks.amplitude_regression(yw, sw, amps)
    amplitude["frequency"] = amplitude_w
    names = [t.name for t in tests]
    verdict, text = checks.verdict(consistent, freq_off, outliers, amplitude, amplitude_w,
                                   ratio, names)
    within, text = _within_tests(tests, text)
    return CampaignChecks(verdict=verdict, text=text, tau_over_within=ratio,
                          heterogeneity_p_value=p_het, frequency_heterogeneity_p_value=p_het_w,
                          frequency_spread=spread_w, frequency_disagrees=freq_off,
                          outliers=list(outliers), amplitude=amplitude,
                          within_test_inadequate=within, consistent=consistent)


def _within_tests(tests: Sequence, text: str) -> tuple[list[int], str]:
    """The tests (1-based) whose own damping-law check found one viscous c inadequate, and
    the verdict sentence with a clause saying so: the between-test verdict alone would let
    tests that agree with each other but are each not one viscous decay pass as "consistent"
    without a word; the verdict name stays the between-test one."""
    within = [t.index + 1 for t in tests if t.damping_verdict in checks.INADEQUATE]
    if within:
        kinds = sorted({t.damping_verdict for t in tests
                        if t.damping_verdict in checks.INADEQUATE})
        text += (f"; within the tests, one viscous c is not adequate (test "
                 f"{', '.join(map(str, within))}: {', '.join(kinds)}), so the population c is "
                 "an average over the tested amplitudes, valid near them only")
    return within, text


def assess_sampled(tests: Sequence, posterior, added: bool, added_mass_sd: float
                   ) -> CampaignChecks:
    """:func:`assess` from the joint ``posterior`` (the arviz posterior group of
    :func:`dampfit.campaign.sampling.sample`): τ_p's draws, m₀'s median of the added-mass
    design (``added``) and the model's prior scale of τ_p."""
    from dampfit.campaign import model

    m0 = float(np.median(np.asarray(posterior["m0"]).ravel())) if added else None
    return assess(tests, np.asarray(posterior["tau_p"]).ravel(), m0,
                  added_mass_sd if added else 0.0, model.TAU_P_SCALE)
