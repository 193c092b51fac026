"""The main job: :func:`analyze` one free-decay recording into c, k, u₀ with a posterior.

Fixed pipeline, each stage in :mod:`dampfit.stages`: ``prepare`` (axis, band, window) →
``baselines`` (initial guess, reported) → ``least squares`` → ``noise`` (calibration) →
``posterior`` (emcee) → ``CRLB`` → ``damping`` (laws, verdict) → ``modes`` (several modes,
:func:`dampfit.stages.modes_stage`) → :class:`~dampfit.analysis.Analysis`.
Several recordings of one damper: :func:`dampfit.campaign.analyze_campaign` (both through
:func:`dampfit.analyze`).
"""

from __future__ import annotations

import copy
import math

from threadpoolctl import threadpool_limits

from dampfit import physics
from dampfit import stages
from dampfit._options import AnalysisOptions
from dampfit.analysis import Analysis, Modes
from dampfit.errors import InputError
from dampfit.io.recording import Recording
from dampfit.signal import prepare


def analyze(recording: Recording, mass: float | None = None, mass_sd: float | None = None, *,
            options: AnalysisOptions | None = None, on_stage=None, **keywords) -> Analysis:
    """Estimate c [N·s/m], k [N/m], u₀ [m], ζ and f_n [Hz] from a free-decay recording.

    The analysis options are one :class:`~dampfit._options.AnalysisOptions` (``options``),
    or its fields as keywords — ``axis``, ``window``, ``band``, ``model``, ``amplitude``,
    ``max_modes``, ``mode_of_mass`` and the sampler's ``seed``, ``max_steps``, ``min_ess``
    and ``progress`` (defaults: :data:`~dampfit._options.DEFAULT_SEED`,
    :data:`~dampfit._options.DEFAULT_MAX_STEPS`, :data:`~dampfit._options.DEFAULT_MIN_ESS`)
    — checked once, before any work.

    ``mass`` [kg] (with standard deviation ``mass_sd`` [kg]) is needed for c and k; without it
    the identifiable quantities (ζ, f_n, p, δ, u₀) are still estimated. ``axis``, ``window``
    (start, end) [s] and ``band`` (low, high) [Hz] override the automatic choices. ``seed``
    makes the posterior reproducible; ``progress`` shows the progress of every long stage
    (:mod:`dampfit._progress`).

    ``model`` (``auto``, ``viscous``, ``coulomb``, ``quadratic``, ``power``) chooses the damping
    law reported as ``c_equivalent`` (:mod:`dampfit.damping`): ``auto`` compares them all and
    takes the one the evidence prefers; every law is checked either way (``model_checks``).
    The viscous posterior under ``parameters`` is always computed. ``amplitude`` [m] is the
    displacement amplitude at which a non-viscous law's equivalent viscous c is reported
    (default: the middle of the recorded displacement amplitudes, their geometric mean) and
    the design amplitude of the recommended damper (``Analysis.damper``).

    ``on_stage(name, data)``, when given, is called as stages finish with the plain data they
    produced (what the figures are drawn from, :class:`dampfit.output.figures.FigureData`):
    ``"fit"`` before the posterior is sampled with ``{"signals": …, "summary": …}`` — the
    arrays of :meth:`Analysis.signals` (computed once, here) and the summary sections the fit
    stage knows (:func:`dampfit.stages.fit_summary`) — and ``"posterior"`` before the damping
    laws are assessed with ``{"posterior": InferenceData, "summary": {"diagnostics": …}}``
    (:func:`dampfit.stages.sampling_summary`) — the CLI draws figures from them in a second
    process meanwhile (:mod:`dampfit.output.figure_process`). Not used for several
    recordings.

    ``max_modes`` (1 … :data:`~dampfit.inference.modes.MAX_MODES_LIMIT`) is the most modes
    looked for in the recording (:func:`dampfit.stages.modes_stage`; by default
    :data:`~dampfit._options.DEFAULT_MAX_MODES`: a one-mode recording pays only the
    screen, one with a second mode its selection and posterior — seconds to minutes on a
    real record, paper/modes.md; 1 skips the stage) and
    ``mode_of_mass`` (1-based, by frequency; default the dominant mode) the mode the mass
    belongs to: only that mode gets c and k in ``modes``. ``parameters`` stay the one-mode
    analysis of the dominant mode.
    """
    if not isinstance(recording, Recording):
        raise InputError("analyze() takes a Recording; use dampfit.read(path) first")
    opts = AnalysisOptions.of(options, **keywords).resolved()
    checked = physics.Mass(mass, mass_sd)
    # BLAS on one thread (threadpoolctl): every matrix here is thin (n × a few columns), and
    # OpenBLAS's spinning worker threads only compete with the CLI's figure process or a
    # batch's other worker for the cores (measured: 0.3 s of a 4 s CLI run on 2 cores)
    with threadpool_limits(limits=1, user_api="blas"), _reporting(opts.sampler.progress):
        return _analyze(recording, checked, opts, on_stage)


def _reporting(progress: bool):
    """With ``progress`` and no caller's :func:`dampfit._progress.reporting`: tqdm bars of
    every long stage (the CLI chooses bars or lines itself)."""
    import contextlib

    from dampfit import _progress

    if progress and not _progress.active():
        return _progress.reporting(bars=True)
    return contextlib.nullcontext()


def _analyze(recording: Recording, mass: physics.Mass, opts: AnalysisOptions,
             on_stage) -> Analysis:
    """The stages of :func:`analyze` (mass and options checked); every stage's warnings
    are returned with its result and collected here, in the order of the stages."""
    m, sd = mass.value, mass.sd
    warns: list[str] = []
    stages.refuse_impossible_time(recording)
    prep = prepare.prepare(recording, axis=opts.axis, window=opts.window, band=opts.band)
    warns.extend(prep.warnings)
    warns.extend(stages.unit_plausibility(recording, prep, m))

    fitted: list[dict] = []  # the figure signals and fit summary, once, at the fit stage
    run = stages.viscous_stages(prep, mass, sampler=opts.sampler,
                                on_fit=_on_fit(on_stage, recording, prep, m, sd, fitted))
    if on_stage is not None:
        on_stage("posterior", {"posterior": run.sampling.idata,
                               "summary": {"diagnostics": stages.sampling_summary(run.sampling)}})
    warns.extend(run.warnings)
    bound, said = stages.crlb_stage(prep, run.fit_data, run.least_squares, run.noise, mass)
    warns.extend(said)
    assessment = stages.assess_damping(prep, run, mass, opts)
    warns.extend(assessment.warnings)
    warns.extend(_noise_warning(run.noise, assessment))
    law = (run.fit_data, assessment.fits[assessment.verdict["preferred"]])
    st = stages.modes_stage(prep, max_modes=opts.max_modes, mass=mass,
                            mode_of_mass=opts.mode_of_mass, sampler=opts.sampler,
                            one_mode=stages.OneMode(run.least_squares.p,
                                                    run.least_squares.omega_d,
                                                    assessment.verdict_name, law))
    modes = modes_result(st, run.least_squares)
    warns.extend(modes.warnings)
    an = Analysis(
        recording=recording, prepared=prep, fit_data=run.fit_data,
        least_squares=run.least_squares, noise=run.noise, sampling=run.sampling,
        baselines=run.baselines, crlb=bound, damping=assessment, mass=m, mass_sd=sd,
        seed=opts.seed, options=opts.to_dict(reading=recording.read_options), warnings=warns,
        modes=modes,
    )
    if fitted:
        an.keep_fit_stage(fitted[0]["signals"], fitted[0]["summary"])
    return an


def _on_fit(on_stage, recording: Recording, prep, m: float | None, sd: float,
            fitted: list[dict]):
    """The fit stage's callback: with ``on_stage``, the figure signals and the fit's summary
    sections (kept in ``fitted``, for the result) are handed to ``on_stage("fit", …)``."""
    def fitted_stage(st: stages.FitStages) -> None:
        if on_stage is not None:
            fitted.append({
                "signals": stages.figure_signals(prep, st.fit_data, st.least_squares,
                                                 st.baselines),
                "summary": stages.fit_summary(recording, prep, st.fit_data, st.least_squares,
                                              st.noise, m, sd)})
            # the caller's copy of the summary: the result keeps its own
            on_stage("fit", {"signals": fitted[0]["signals"],
                             "summary": copy.deepcopy(fitted[0]["summary"])})

    return fitted_stage


def _noise_warning(nm, assessment) -> list[str]:
    """The r warning (residuals near f₀ far above white noise), unless the adequacy
    verdict's warning already explains the structure."""
    if nm.excess > stages.R_WARN and assessment.verdict_name not in ("misfit", "amplitude-dependent"):
        return [f"residuals near f0 are {nm.excess:.1f}x what white noise alone would leave on "
                "this path (coloured noise, amplitude-dependent damping or a second mode?); "
                "intervals were widened to match"]
    return []


def modes_result(st: stages.ModesStage, ls) -> Modes:
    """The modes stage's result ``st`` (:func:`dampfit.stages.modes_stage`, run after the
    one-mode least squares ``ls``) as the result's :class:`~dampfit.analysis.Modes`, with the
    warnings that compare it with the one-mode analysis: a recording the modal analysis
    cannot handle gives one mode with the reason as a warning."""
    evidence = dict(st.evidence)
    seen = list(st.seen)
    if st.n_modes is None or st.n_modes == 1 or st.posterior is None:
        return Modes(evidence=evidence, warnings=st.warnings, seen=seen)
    out = st.summary
    warns = list(st.warnings) + stages.modes_disagreement(out["modes"], st.dominant, ls)
    nearest, f1 = st.dominant, ls.omega_d / (2 * math.pi)
    if nearest is not None and nearest != st.posterior.mode_of_mass:
        at = [i for i, r in enumerate(out["modes"]) if r.get("mass_mode")]
        where = f"modes[{at[0]}]" if at else "no entry of modes (not identified)"
        warns.append(f"'parameters' describe the one-mode analysis of the mode at {f1:.4g} Hz "
                     f"(mode {nearest + 1}); the mass belongs to mode "
                     f"{st.posterior.mode_of_mass + 1} (--mode-of-mass), whose c and k are "
                     f"in {where}")
    return Modes(n_modes=st.n_modes, modes=out["modes"], evidence=evidence, seen=seen,
                 rayleigh=out["rayleigh"], idata=st.posterior.idata, warnings=tuple(warns))
