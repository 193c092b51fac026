"""The main job: :func:`analyze` one free-decay recording into c, k, u₀ with a posterior.

Fixed pipeline, each stage in :mod:`dampfit.stages`: ``prepare`` (axis, band, window) →
``baselines`` (initial guess, reported) → ``least squares`` → ``noise`` (calibration) →
``posterior`` (emcee) → ``CRLB`` → ``damping`` (laws, verdict) → ``modes`` (several modes,
:func:`modes_stage`) → :class:`~dampfit.analysis.Analysis`.
Several recordings of one damper: :func:`dampfit.campaign.analyze_campaign` (both through
:func:`dampfit.analyze`).
"""

from __future__ import annotations

import math

from threadpoolctl import threadpool_limits

from dampfit import physics
from dampfit import stages
from dampfit.analysis import Analysis, Modes
from dampfit.errors import InputError
from dampfit.inference.modes import DEFAULT_MAX_MODES
from dampfit.io.recording import Recording
from dampfit.signal import prepare

__all__ = ["analyze", "modes_stage"]


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
    max_modes: int = DEFAULT_MAX_MODES,
    mode_of_mass: int | None = None,
) -> Analysis:
    """Estimate c [N·s/m], k [N/m], u₀ [m], ζ and f_n [Hz] from a free-decay recording.

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
    looked for in the recording (:func:`modes_stage`; by default
    :data:`~dampfit.inference.modes.DEFAULT_MAX_MODES`, 4: a one-mode recording pays only the
    screen, one with a second mode its selection and posterior — seconds to minutes on a
    real record, paper/modes.md; 1 skips the stage) and
    ``mode_of_mass`` (1-based, by frequency; default the dominant mode) the mode the mass
    belongs to: only that mode gets c and k in ``modes``. ``parameters`` stay the one-mode
    analysis of the dominant mode.
    """
    if not isinstance(recording, Recording):
        raise InputError("analyze() takes a Recording; use dampfit.read(path) first")
    # BLAS on one thread (threadpoolctl): every matrix here is thin (n × a few columns), and
    # OpenBLAS's spinning worker threads only compete with the CLI's figure process or a
    # batch's other worker for the cores (measured: 0.3 s of a 4 s CLI run on 2 cores)
    with threadpool_limits(limits=1, user_api="blas"), _reporting(progress):
        return _analyze(recording, mass, mass_sd, axis=axis, window=window, band=band,
                        seed=seed, progress=progress, max_steps=max_steps, min_ess=min_ess,
                        model=model, amplitude=amplitude, on_stage=on_stage,
                        max_modes=max_modes, mode_of_mass=mode_of_mass)


def _reporting(progress: bool):
    """With ``progress`` and no caller's :func:`dampfit._progress.reporting`: tqdm bars of
    every long stage (the CLI chooses bars or lines itself)."""
    import contextlib

    from dampfit import _progress

    if progress and not _progress.active():
        return _progress.reporting(bars=True)
    return contextlib.nullcontext()


def _analyze(recording, mass, mass_sd, *, axis, window, band, seed, progress, max_steps,
             min_ess, model, amplitude, on_stage, max_modes, mode_of_mass) -> Analysis:
    m, sd = physics.check_mass(mass, mass_sd)
    stages.check_damping_options(model, amplitude)
    max_modes, mode_of_mass = _check_modes_options(max_modes, mode_of_mass)
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
    modes = modes_stage(prep, ls, m, sd, max_modes=max_modes, mode_of_mass=mode_of_mass,
                        seed=seed, min_ess=min_ess, max_steps=max_steps,
                        viscous_seconds=viscous_seconds,
                        verdict=assessment.verdict_name,
                        law=(fd, assessment.fits[assessment.verdict["preferred"]]))
    warns.extend(modes.warnings)
    options = {"axis": axis, "window": list(window) if window else None,
               "band": list(band) if band else None, "max_steps": max_steps,
               "min_ess": min_ess, "model": model, "amplitude": amplitude,
               "max_modes": max_modes, "mode_of_mass": mode_of_mass,
               **recording.read_options}
    an = Analysis(
        recording=recording, prepared=prep, fit_data=fd, least_squares=ls, noise=nm,
        sampling=post, baselines=base, crlb=bound, damping=assessment, mass=m, mass_sd=sd,
        seed=int(seed), options=options, warnings=warns, modes=modes,
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


def _check_modes_options(max_modes, mode_of_mass) -> tuple[int, int | None]:
    """``max_modes`` and ``mode_of_mass`` checked before any work (one-line InputError)."""
    from dampfit.inference.modes import check_max_modes, check_mode_of_mass

    max_modes = check_max_modes(max_modes)
    index = check_mode_of_mass(mode_of_mass, max_modes)
    return max_modes, None if index is None else index + 1


def modes_stage(prep, ls, mass: float | None, mass_sd: float, *, max_modes: int,
                mode_of_mass: int | None, seed: int, min_ess: float,
                max_steps: int, viscous_seconds: float | None = None,
                verdict: str | None = None, law=None) -> Modes:
    """Several modes in the recording (issue 21), after the one-mode analysis: the stage
    :func:`dampfit.stages.modes_stage` with the one-mode least squares ``ls`` (its screen
    first; K = 1 is the one-mode posterior of ``parameters``, so no second sampler runs) and
    the damping-law ``verdict`` (a close pair at the one-mode frequency explained; ``law``
    its preferred law's fit, an unresolved pair flagged), as the
    result's :class:`~dampfit.analysis.Modes`. A recording the modal analysis cannot handle
    gives one mode with the reason as a warning; ``mode_of_mass`` beyond the modes found is
    a one-line :class:`~dampfit.errors.InputError`."""
    st = stages.modes_stage(prep, max_modes=max_modes, mass=mass, mass_sd=mass_sd,
                            mode_of_mass=mode_of_mass, seed=seed, min_ess=min_ess,
                            max_steps=max_steps, viscous_seconds=viscous_seconds,
                            one_mode=(ls.p, ls.omega_d), verdict=verdict, law=law)
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
