r"""Joint analysis of several free-decay recordings of one damper: :func:`analyze_campaign`.

Stages
------
1. **Per test** (:mod:`dampfit.campaign.tests`; each recording on its own, as
   :func:`dampfit.pipeline.analyze` does it):
   preparation (window, band, axis: :func:`dampfit.signal.prepare.prepare`), the baselines'
   initial decay rate, least squares (:func:`dampfit.inference.least_squares.least_squares`),
   the single-recording refusals (no free decay; noise-free), the noise calibration r_i
   (:func:`dampfit.inference.noise.estimate`), and the Laplace expansion of the tempered
   profiled likelihood ℓ_i (eqs. C1, C2 of :mod:`dampfit.campaign.model`).
2. **Refusals** before any sampling (:mod:`dampfit.campaign.checks`).
3. **Hyper-posterior** of φ (eqs. C3–C5) sampled with emcee (differential-evolution moves,
   see :func:`dampfit.campaign.sampling.ensemble`, and the stopping rule of
   :func:`dampfit.inference.posterior.run_adaptive`: ≥ 50 autocorrelation times, R-hat < 1.01,
   bulk ESS ≥ ``min_ess``, or ``max_steps``), once for each frequency model (M₁: τ_ω free;
   M₀: τ_ω = 0, the tests share one frequency law); their posterior probabilities come from
   the Savage–Dickey ratio (C7) and the result is their mixture
   (:func:`dampfit.campaign.sampling.sample`).
4. **Per-test values and the exact likelihood**: for every draw of φ, each test's
   ψ_i = (ln p_i, ln ω_n,i) is drawn from its Gaussian conditional, and the joint draw gets
   the importance weight

       w = Π_i exp[ℓ_i(θ_i) − ℓ_i(θ̂_i) − (ℓ̃_i(ψ_i) − ℓ̃_i(ψ̂_i))],                     (C6)

   the ratio of the exact tempered likelihood (C1) to its Laplace form (C2) (everything else
   in the joint density is common to both, so (C6) is exact); each walker's draws are
   resampled by w (systematic resampling). The importance ESS fraction is reported; below
   :data:`~dampfit.campaign.sampling.MIN_IMPORTANCE_FRACTION` the result is flagged not converged.
5. **Quantities** per draw (:func:`dampfit.physics.quantities` from p and ω_n): the population
   damper from the location parameters (mass mode: c = 2·m·e^{μ_p} [N·s/m], k = m·e^{2μ_ω} [N/m] with m
   drawn normal(m, sd) truncated at 0 as in :func:`dampfit.inference.posterior.mass_draws`;
   added-mass mode: c, k, m₀ directly, p = c/(2m₀), ω_n² = k/m₀ for the bare system), the
   **predictive** damper of a new test (ln p_new = μ_p + τ_p·z, ln ω_new = μ_ω + τ_ω·z'), each
   test's **pooled** values from its ψ_i (mass m, or m₀ + Δm_i), and each test's **own**
   values from its Laplace expansion alone (mass m, or the posterior m₀ + Δm_i).
6. **Checks** (:mod:`dampfit.campaign.verdict`, the statistics of
   :mod:`dampfit.campaign.checks`): spread consistent with zero, outliers, amplitude explains
   the scatter, and a one-sentence verdict — made once here, stored on the result.
7. **Several modes per test** (only with ``max_modes`` > 1, :mod:`dampfit.campaign.modes`):
   each test on its own through :func:`dampfit.stages.modes_stage` (its screen, evidence,
   posterior and split-pair check, as for one recording); its modes are listed with the
   pooled one marked, the pooling above unchanged.

The summary's schema is ``summary.json`` of kind "campaign" (schema_version 1).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Sequence

from dampfit._options import AnalysisOptions
from dampfit.campaign.result import CampaignAnalysis
from dampfit.errors import InputError


def analyze_campaign(recordings: Sequence, mass: float | None = None,
                     mass_sd: float | None = None, *, added_mass: Sequence[float] | None = None,
                     added_mass_sd: float = 0.0, options: AnalysisOptions | None = None,
                     **keywords) -> CampaignAnalysis:
    """Joint hierarchical analysis of several recordings of one damper.

    ``recordings`` (≥ 2 :class:`~dampfit.io.recording.Recording`). Either ``mass`` [kg] (sd
    ``mass_sd`` [kg]; both optional: without a mass only p, ζ, f_n are reported) — the
    "hierarchical" design — or ``added_mass`` [kg] per recording (0 for the bare system) with
    sd ``added_mass_sd`` [kg] — the "added-mass" design, which estimates m₀ and k itself.
    The options are one :class:`~dampfit._options.AnalysisOptions` (``options``) or its
    fields as keywords: ``window`` (start, end) [s] and ``band`` (low, high) [Hz] apply to
    every recording, or give one per recording (a list of pairs or None); ``axis``; ``seed``
    makes the run reproducible; ``max_steps`` and ``min_ess`` bound the sampler;
    ``max_modes`` > 1 (default 1) also analyses every test for up to that many modes and
    lists them per test; the campaign pools the mode each test's band isolates
    (:mod:`dampfit.campaign.modes`). Bad inputs raise a one-line
    :class:`~dampfit.errors.InputError` before any sampling.
    """
    from dampfit.campaign import checks, modes, sampling, tests, verdict

    opts = AnalysisOptions.of(options, **keywords).resolved(campaign=True)
    single = [n for n, v in (("model", opts.model != "auto"), ("amplitude", opts.amplitude),
                             ("mode_of_mass", opts.mode_of_mass)) if v is not None and v]
    if single:
        raise InputError(f"{', '.join(single)} apply to a single recording, not to a "
                         f"campaign of {len(recordings)}; analyse one recording for them")
    recs, checked, dm, dm_sd = checks.check_design(recordings, mass, mass_sd, added_mass,
                                                   added_mass_sd)
    m, sd = checked.value, checked.sd
    s = opts.sampler
    windows = _per_test_option("window", opts.window, len(recs))
    bands = _per_test_option("band", opts.band, len(recs))
    fits = [tests.fit_test(i, r, opts.axis, windows[i], bands[i], checked,
                           None if dm is None else dm[i]) for i, r in enumerate(recs)]
    names = [t.name for t in fits]
    warns = checks.duplicate_recordings(recs)
    warns += [f"test {t.index + 1} ({t.name}): {w}" for t in fits for w in t.warnings]
    if dm is None:
        checks.check_same_system([t.prepared.f0 for t in fits], names)
    data, _ = tests.campaign_data(fits, dm, dm_sd)
    started = time.monotonic()
    sampled = sampling.sample(sampling.Problem(fits, data, dm, m, sd), s.seed, s.progress,
                              s.max_steps, s.min_ess)
    sampled = replace(sampled, seconds=float(time.monotonic() - started))
    warns.extend(sampled.warnings)
    found = verdict.assess_sampled(fits, sampled.idata.posterior, dm is not None, dm_sd)
    if opts.max_modes > 1:
        warns.extend(modes.per_test_modes(fits, opts.max_modes, s))
    return CampaignAnalysis(tests=fits, sampling=sampled, checks=found, warnings=warns, mass=m,
                            mass_sd=sd, added_mass=dm, added_mass_sd=dm_sd, seed=s.seed,
                            options=opts.to_dict(campaign=True, reading=_reading_options(recs)))


def _reading_options(recs) -> dict:
    """The recordings' reading options (``Recording.read_options``) for the provenance: as
    one set when every recording was read alike (as the CLI reads them), else per test."""
    opts = [dict(getattr(r, "read_options", None) or {}) for r in recs]
    if all(o == opts[0] for o in opts):
        return opts[0]
    return {"read_options_per_test": opts}


def _is_per_test(x) -> bool:
    return isinstance(x, (list, tuple)) and len(x) > 0 and all(
        v is None or (isinstance(v, (list, tuple)) and len(v) == 2) for v in x)


def _per_test_option(name: str, value, n: int) -> list:
    """``value`` (one (lo, hi) pair or None for all, or one per recording) as n entries."""
    if value is None:
        return [None] * n
    if _is_per_test(value):
        if len(value) != n:
            raise InputError(f"{name} gives {len(value)} ranges for {n} recordings; give one "
                             "range for all or one per recording")
        return [None if v is None else tuple(v) for v in value]
    return [tuple(value)] * n
