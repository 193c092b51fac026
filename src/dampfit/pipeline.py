"""The main job: :func:`analyze` one free-decay recording into c, k, u₀ with a posterior.

Fixed pipeline, each stage in :mod:`dampfit.stages`: ``prepare`` (axis, band, window) →
``baselines`` (initial guess, reported) → ``least squares`` → ``noise`` (calibration) →
``posterior`` (emcee) → ``CRLB`` → ``damping`` (laws, verdict) → :class:`~dampfit.analysis.Analysis`.
Several recordings of one damper: :func:`dampfit.campaign.analyze_campaign` (both through
:func:`dampfit.analyze`).
"""

from __future__ import annotations

from dampfit import physics
from dampfit._arviz import preload as preload_arviz
from dampfit import stages
from dampfit.analysis import Analysis
from dampfit.errors import InputError
from dampfit.io.recording import Recording
from dampfit.signal import prepare

__all__ = ["analyze"]


def analyze(
    recording: Recording,
    mass: float | None = None,
    mass_sd: float | None = None,
    *,
    axis: str = "auto",
    window: tuple[float, float] | None = None,
    band: tuple[float, float] | None = None,
    seed: int = 0,
    progress: bool = False,
    max_steps: int = 20000,
    min_ess: float = 1000.0,
    model: str = "auto",
    amplitude: float | None = None,
    on_stage=None,
) -> Analysis:
    """Estimate c [N·s/m], k [N/m], u₀ [m], ζ and f_n [Hz] from a free-decay recording.

    ``mass`` [kg] (with standard deviation ``mass_sd`` [kg]) is needed for c and k; without it
    the identifiable quantities (ζ, f_n, p, δ, u₀) are still estimated. ``axis``, ``window``
    (start, end) [s] and ``band`` (low, high) [Hz] override the automatic choices. ``seed``
    makes the posterior reproducible; ``progress`` shows a progress bar.

    ``model`` (``auto``, ``viscous``, ``coulomb``, ``quadratic``, ``power``) chooses the damping
    law reported as ``c_equivalent`` (:mod:`dampfit.damping`): ``auto`` compares them all and
    takes the one the evidence prefers; every law is checked either way (``model_checks``).
    The viscous posterior under ``parameters`` is always computed. ``amplitude`` [m] is the
    displacement amplitude at which a non-viscous law's equivalent viscous c is reported
    (default: the geometric mean of the first and last amplitudes of the window).

    ``on_stage(name, data)``, when given, is called as stages finish with the plain data they
    produced (what the figures are drawn from, :class:`dampfit.output.figures.FigureData`):
    ``"fit"`` before the posterior is sampled with ``{"signals": …, "summary": …}`` — the
    arrays of :meth:`Analysis.signals` (computed once, here) and the summary sections the fit
    stage knows (:func:`dampfit.stages.fit_summary`) — and ``"posterior"`` before the damping
    laws are assessed with ``{"posterior": InferenceData, "summary": {"diagnostics": …}}``
    (:func:`dampfit.stages.sampling_summary`) — the CLI draws figures from them in a second
    process meanwhile (:mod:`dampfit.output.figure_process`). Not used for several
    recordings.
    """
    if not isinstance(recording, Recording):
        raise InputError("analyze() takes a Recording; use dampfit.read(path) first")
    preload_arviz()  # needed by the posterior stage; imported meanwhile
    m, sd = physics.check_mass(mass, mass_sd)
    stages.check_damping_options(model, amplitude)
    warns: list[str] = []
    stages.refuse_impossible_time(recording)
    prep = prepare.prepare(recording, axis=axis, window=window, band=band)
    warns.extend(prep.warnings)
    warns.extend(stages.unit_plausibility(recording, prep, m))

    signals: list[dict] = []  # the figure signals, computed once at the fit stage if wanted
    run = stages.viscous_stages(prep, m, sd, seed=seed, progress=progress, max_steps=max_steps,
                                min_ess=min_ess,
                                on_fit=_on_fit(on_stage, recording, prep, m, sd, signals))
    base, fd, ls, nm, post = (run.baselines, run.fit_data, run.least_squares, run.noise,
                              run.sampling)
    if on_stage is not None:
        on_stage("posterior", {"posterior": post.idata,
                               "summary": {"diagnostics": stages.sampling_summary(post)}})
    warns.extend(run.warnings)
    bound = stages.crlb_stage(prep, fd, ls, nm, m, sd, warns)
    viscous_seconds = run.posterior_seconds
    assessment = stages.assess_damping(prep, fd, ls, nm, m, sd, model, amplitude, seed, progress,
                                       max_steps, min_ess, warns, post.n_steps, viscous_seconds)
    warns.extend(_noise_warning(nm, assessment))
    options = {"axis": axis, "window": list(window) if window else None,
               "band": list(band) if band else None, "max_steps": max_steps,
               "min_ess": min_ess, "model": model, "amplitude": amplitude,
               **recording.read_options}
    an = Analysis(
        recording=recording, prepared=prep, fit_data=fd, least_squares=ls, noise=nm,
        sampling=post, baselines=base, crlb=bound, damping=assessment, mass=m, mass_sd=sd,
        seed=int(seed), options=options, warnings=warns,
    )
    if signals:
        an.keep_signals(signals[0])
    return an


def _on_fit(on_stage, recording: Recording, prep, m: float | None, sd: float,
            signals: list[dict]):
    """The fit stage's callback: with ``on_stage``, the figure signals (kept in ``signals``)
    and the fit's summary sections are handed to ``on_stage("fit", …)``."""
    def fitted(st: stages.FitStages) -> None:
        if on_stage is not None:
            signals.append(stages.figure_signals(prep, st.fit_data, st.least_squares,
                                                 st.baselines))
            on_stage("fit", {"signals": signals[0], "summary": stages.fit_summary(
                recording, prep, st.fit_data, st.least_squares, st.noise, m, sd)})

    return fitted


def _noise_warning(nm, assessment) -> list[str]:
    """The r warning (residuals near f₀ far above white noise), unless the adequacy
    verdict's warning already explains the structure."""
    if nm.excess > stages.R_WARN and assessment.verdict_name not in ("misfit", "amplitude-dependent"):
        return [f"residuals near f0 are {nm.excess:.1f}x what white noise alone would leave on "
                "this path (coloured noise, amplitude-dependent damping or a second mode?); "
                "intervals were widened to match"]
    return []
