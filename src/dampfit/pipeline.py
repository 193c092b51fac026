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
import time

from threadpoolctl import threadpool_limits

from dampfit import physics
from dampfit import stages
from dampfit.analysis import Analysis, Modes
from dampfit.errors import InputError
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
    max_modes: int = 1,
    mode_of_mass: int | None = None,
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

    ``max_modes`` (1 … :data:`~dampfit.inference.modes.MAX_MODES_LIMIT`) is the most modes
    looked for in the recording (:func:`modes_stage`; 1, the default: the stage is skipped —
    several modes are opt-in, e.g. ``max_modes=4``: they can add minutes to a real
    recording, paper/modes.md) and
    ``mode_of_mass`` (1-based, by frequency; default the dominant mode) the mode the mass
    belongs to: only that mode gets c and k in ``modes``. ``parameters`` stay the one-mode
    analysis of the dominant mode.
    """
    if not isinstance(recording, Recording):
        raise InputError("analyze() takes a Recording; use dampfit.read(path) first")
    # BLAS on one thread (threadpoolctl): every matrix here is thin (n × a few columns), and
    # OpenBLAS's spinning worker threads only compete with the CLI's figure process or a
    # batch's other worker for the cores (measured: 0.3 s of a 4 s CLI run on 2 cores)
    with threadpool_limits(limits=1, user_api="blas"):
        return _analyze(recording, mass, mass_sd, axis=axis, window=window, band=band,
                        seed=seed, progress=progress, max_steps=max_steps, min_ess=min_ess,
                        model=model, amplitude=amplitude, on_stage=on_stage,
                        max_modes=max_modes, mode_of_mass=mode_of_mass)


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
                        amplitude_dependent=assessment.verdict_name in ("amplitude-dependent",
                                                                        "misfit"))
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
                amplitude_dependent: bool = False) -> Modes:
    """Several modes in the recording (issue 21), after the one-mode analysis.

    ``max_modes`` 1: nothing is done (``n_modes`` 1, "not looked for"). Otherwise the cheap
    screen :func:`dampfit.inference.modes_gate.screen` (≈ 0.01–0.05 s) looks at the one-mode
    least squares ``ls``'s residual in the modal band: if nothing stands out of the noise the
    recording is one mode, and neither the order selection nor the modal posterior is run
    (the screen's false-negative risk is in its module docstring: it errs towards running the
    selection). Else the number of modes is chosen by evidence
    (:func:`dampfit.inference.modes_select.select`); for K ≥ 2 every mode's posterior is
    sampled (:func:`dampfit.inference.modes_posterior.sample`, ``mass``, ``mass_sd`` [kg] for
    the mode ``mode_of_mass``; within the work budget
    :func:`dampfit.inference.modes_posterior.budget` of K and ``viscous_seconds``, the
    one-mode posterior's wall time [s]: a run it stops is reported not converged, with a
    warning, in ``modes_evidence["sampling"]``) and summarised with its bound, close pairs
    and Rayleigh α, β (:func:`~dampfit.inference.modes_posterior.modal_summary`); a close
    pair at the one-mode frequency with very different damping, or any close pair there when
    ``amplitude_dependent`` (the one-mode damping verdict: amplitude-dependent or misfit), is
    explained in a warning (:func:`~dampfit.inference.modes_close.split_pair`). K = 1 —
    by the screen or the evidence — is the one-mode posterior of ``parameters`` (the same
    model, so no second sampler runs). A recording the modal analysis cannot handle (too short, no mode fitted)
    gives one mode with the reason as a warning. ``mode_of_mass`` beyond the modes found is
    a one-line :class:`~dampfit.errors.InputError`.
    """
    from dampfit.errors import InputError
    from dampfit.inference import modes_close, modes_gate, modes_posterior, modes_select

    start = time.perf_counter()
    if max_modes == 1:
        return Modes(evidence={"max_modes": 1, "screen": None, "reason":
                               "several modes not looked for (max modes 1)"})

    def one(evidence: dict, warnings: tuple[str, ...] = ()) -> Modes:
        if mode_of_mass is not None and mode_of_mass > 1:
            raise InputError(f"mode of mass {mode_of_mass} is out of range: the recording has "
                             "1 mode (1 … 1)")
        evidence.update(max_modes=max_modes, seconds=time.perf_counter() - start)
        return Modes(evidence=evidence, warnings=warnings)

    try:
        gate = modes_gate.screen(prep, ls.p, ls.omega_d)
        if not gate.passed:
            return one({"screen": gate.summary(), "reason": gate.reason})
        sel = modes_select.select(prep, max_modes=max_modes)
    except InputError as exc:
        why = f"several modes not analysed: {exc}"
        return one({"screen": None, "reason": why}, (why,))
    evidence = {"screen": gate.summary(), **sel.summary()}
    if sel.n_modes == 1:
        evidence["reason"] = "one mode by evidence"
        return one(evidence, tuple(sel.warnings))
    post = modes_posterior.sample(sel, mass=mass, mass_sd=mass_sd, mode_of_mass=mode_of_mass,
                                  seed=seed, min_ess=min_ess, max_steps=max_steps,
                                  budget=modes_posterior.budget(sel.n_modes, viscous_seconds))
    out = modes_posterior.modal_summary(sel, post)
    evidence.update(reason=f"{sel.n_modes} modes by evidence", pairs=out["pairs"],
                    notes=out["notes"], max_modes=max_modes, sampling=post.sampling(),
                    seconds=time.perf_counter() - start)
    warns = list(out["warnings"])
    f1 = ls.omega_d / (2 * math.pi)
    nearest = min(range(len(out["modes"])),
                  key=lambda i: abs(out["modes"][i]["f_d"]["q50"] - f1))
    warns.extend(modes_close.split_pair(out["modes"], out["pairs"], nearest,
                                        amplitude_dependent=amplitude_dependent))
    if nearest != post.mode_of_mass:
        warns.append(f"'parameters' describe the one-mode analysis of the mode at {f1:.4g} Hz "
                     f"(mode {nearest + 1}); the mass belongs to mode {post.mode_of_mass + 1}, "
                     f"whose c and k are in modes[{post.mode_of_mass}]")
    return Modes(n_modes=sel.n_modes, modes=out["modes"], evidence=evidence,
                 rayleigh=out["rayleigh"], idata=post.idata, warnings=tuple(warns))
