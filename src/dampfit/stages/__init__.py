"""The single-recording stages: what :func:`dampfit.pipeline.analyze`, each test of a campaign
(:mod:`dampfit.campaign`) and the study's estimators (:mod:`dampfit.study.registry`) share.

In order, for one :class:`~dampfit.io.recording.Recording`:

1. :func:`refuse_impossible_time` — a time base no accelerometer can have is refused up front;
   :func:`unit_plausibility` — warnings naming a likely unit mix-up;
2. (:func:`dampfit.signal.prepare.prepare` — axis, band, window; not repeated here);
3. :func:`fit_stages` — the seed paper's baselines (initial guess, reported), the
   variable-projection least squares (:mod:`dampfit.inference.least_squares`) and the noise
   calibration (:mod:`dampfit.inference.noise`); refuses a window with no free decay;
4. :func:`viscous_stages` — the same plus the viscous posterior (:mod:`dampfit.inference.posterior`);
5. :func:`crlb_stage` — the Cramér–Rao bound of this recording's design;
6. :func:`assess_damping` — damping laws, ζ(amplitude) and the adequacy verdict
   (:mod:`dampfit.damping`);
7. :func:`modes_stage` (:mod:`dampfit.stages.modes`) — several modes: a screen of the one-mode
   residual, the number of modes by evidence and every mode's posterior, bound, close pairs
   and Rayleigh α, β, as plain data; one function for a single recording, each test of a
   campaign and the study's modal estimators.

:func:`ls_summary` is the one least-squares summary (values, 1-σ from the calibrated Jacobian
covariance): summary.json's ``least_squares`` and the study's ``least_squares`` estimator both
report it. :func:`window_signals` are the measured and modelled signals of the window;
:func:`figure_signals` adds the bounded arrays every figure of the result is drawn from
(:mod:`dampfit.output.figures`), kept in signals.npz. :func:`fit_summary` and
:func:`sampling_summary` are the summary.json sections known once the fit and the posterior
stage have run (the figure process draws from them meanwhile).

Nothing here reads or writes files; every refusal is a one-line
:class:`~dampfit.errors.InputError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from dampfit import physics
from dampfit._json import jsonable
from dampfit._options import AnalysisOptions, SamplerSettings
from dampfit.errors import InputError
from dampfit.estimators import baselines
from dampfit.inference import least_squares
from dampfit.inference import noise
from dampfit.inference import posterior
from dampfit.io.recording import Recording
from dampfit.signal import display
from dampfit.signal import prepare

#: A PSD ratio r above this many times its white-noise value signals residual structure.
R_WARN = noise.R_WARN

#: A free decay must explain at least this fraction of the window's variance beyond the drift
#: (a real decay explains ≈ 1 − 1/SNR; random hand motion or noise far less).
MIN_EXPLAINED = 0.5

#: Dominant frequencies [Hz] and stiffnesses [N/m] a free-decay test plausibly has; outside
#: them a unit mix-up (time in ms read as s, or the reverse) is the likely cause.
PLAUSIBLE_F0_HZ = (0.05, 2000.0)
PLAUSIBLE_K_N_PER_M = (1e-3, 1e8)
#: Formats a phone app writes, and the masses [kg] a phone (with a light holder) has: above
#: PHONE_MASS_KG[1] or below [0] a phone's mass was likely given in grams, or as a tiny part.
PHONE_FORMATS = ("phyphox-csv", "phyphox-zip", "phyphox-xlsx", "sensor-logger")
PHONE_MASS_KG = (0.05, 20.0)

#: Residual power relative to the signal's below which a record is noise-free (rounding
#: only: residual rms < 1e-8 of the signal, 40 dB below a 24-bit converter's resolution).
NOISE_FREE_POWER = 1e-16

#: Sample rates [Hz] no accelerometer recording can have: outside this range the time
#: column is in the wrong unit or corrupt, and the analysis is refused up front.
POSSIBLE_RATE_HZ = (1e-3, 1e8)


@dataclass(frozen=True)
class FitStages:
    """The stages before the posterior of one prepared signal (:func:`fit_stages`)."""

    baselines: dict[str, Any]  # name → baselines.BaselineResult | None
    fit_data: prepare.FitData
    least_squares: least_squares.LeastSquaresResult
    noise: noise.NoiseModel
    warnings: list[str]


@dataclass(frozen=True)
class ViscousStages(FitStages):
    """The stages of the viscous analysis of one prepared signal (:func:`viscous_stages`)."""

    sampling: posterior.PosteriorResult = None
    posterior_seconds: float = float("nan")  # wall time [s] of the posterior stage


def refuse_impossible_time(rec: Recording) -> None:
    """InputError naming the time-unit mix-up when the median sample rate is impossible
    (:data:`POSSIBLE_RATE_HZ`); merely implausible rates only warn (:func:`unit_plausibility`)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        rate = float(1.0 / np.median(np.diff(rec.time)))
    lo, hi = POSSIBLE_RATE_HZ
    if not lo <= rate <= hi:
        raise InputError(rec.time_unit_verdict or f"the median sample rate {rate:.3g} Hz is "
                         "impossible for an accelerometer; check the time column and --time-unit")


def unit_plausibility(rec: Recording, prep: prepare.Prepared, mass: float | None) -> list[str]:
    """Warnings naming a likely unit mix-up: the time unit (``Recording.time_unit_verdict``:
    a sample rate outside 1 Hz–100 kHz, or seconds under a ``(ms)`` header), a dominant
    frequency outside :data:`PLAUSIBLE_F0_HZ`, or an implied k = m·(2π·f₀)² outside
    :data:`PLAUSIBLE_K_N_PER_M` for the given mass [kg]."""
    out = []
    hint = rec.time_unit_verdict
    if hint:
        out.append(hint)
    lo, hi = PLAUSIBLE_F0_HZ
    if not lo <= prep.f0 <= hi:
        out.append(f"the dominant frequency {prep.f0:.4g} Hz is outside {lo:g}–{hi:g} Hz, unusual "
                   "for a free-decay test; check the time unit (--time-unit)")
    if mass is not None:
        with np.errstate(over="ignore"):
            k = float(physics.stiffness(mass, 2 * np.pi * np.float64(prep.f0)))
        k_lo, k_hi = PLAUSIBLE_K_N_PER_M
        if not k_lo <= k <= k_hi:
            out.append(f"the implied stiffness k ≈ {k:.3g} N/m for {mass:g} kg is outside "
                       f"{k_lo:g}–{k_hi:g} N/m; check the time unit (--time-unit: a time "
                       "1000× too small makes k 10⁶× too large) and the mass")
        out += _phone_mass(rec.format, mass, k)
    return out


def _phone_mass(fmt: str, mass: float, k: float) -> list[str]:
    """A note naming the likely mistake when ``mass`` [kg] cannot be a phone's, for a
    recording a phone app wrote (``fmt`` in :data:`PHONE_FORMATS`; k [N/m] as implied)."""
    if fmt not in PHONE_FORMATS:
        return []
    lo, hi = PHONE_MASS_KG
    if mass > hi:
        return [f"mass {mass:g} kg for a phone recording ({fmt}): a phone weighs about 0.2 kg; "
                f"if you weighed it in grams, give --mass {mass / 1000:g} (k = {k:.4g} N/m "
                f"would then be {k / 1000:.4g} N/m)"]
    if mass < lo:
        return [f"mass {mass:g} kg for a phone recording ({fmt}) makes k = {k:.3g} N/m the "
                f"stiffness of a phone weighing {mass * 1000:.3g} g; give the mass in kg of what "
                "oscillates (the phone with its holder, about 0.2 kg)"]
    return []


def fit_stages(prep: prepare.Prepared, mass: physics.Mass | float | None) -> FitStages:
    """Baselines, least squares and noise calibration of one prepared signal: the stages
    :func:`dampfit.pipeline.analyze`, the ``bayes`` estimator and each test of a campaign
    (:mod:`dampfit.campaign`) share (``mass`` a checked :class:`dampfit.physics.Mass`, taken as
    it is, or a number [kg] or None, checked by the baselines, for their c). Refuses
    (one-line :class:`~dampfit.errors.InputError`) a window with no free decay and a
    noise-free record."""
    warns: list[str] = []
    # baselines on the uniform grid inside the window (also the initial guess)
    sel = prep.grid_in_window
    base: dict[str, baselines.BaselineResult | None] = {}
    for name, fn in (("log_decrement", baselines.log_decrement),
                     ("envelope_pipeline", baselines.envelope_pipeline)):
        try:
            base[name] = fn(prep.grid[sel], prep.grid_signal[sel], prep.fs, prep.band, mass=mass)
        except InputError as exc:
            base[name] = None
            warns.append(f"baseline {name} not computed: {exc}")
    p0 = initial_decay_rate(base)

    fd = prepare.fit_data(prep)
    ls = least_squares.least_squares(fd, p0, prep.f0)
    if ls.explained < MIN_EXPLAINED:
        raise InputError(
            f"no free decay found: a damped oscillation explains only {100 * ls.explained:.0f} % "
            f"of the signal in {prep.window[0]:.3g}–{prep.window[1]:.3g} s (random motion or "
            "noise?); check the axis or give --window START END"
        )
    if ls.rss_drift > 0 and ls.rss < NOISE_FREE_POWER * ls.rss_drift:
        raise InputError(
            "the recording is free of noise to numerical precision (residual "
            f"{np.sqrt(ls.rss / ls.rss_drift):.1g} of the signal): a simulation or FEM output? A "
            "posterior needs measurement noise; add the sensor's noise (dampfit simulate does) "
            "or read the least-squares values of dampfit.inference.least_squares"
        )
    if not ls.converged:
        warns.append(f"least squares did not converge ({ls.message})")
    # r calibrated at f0: corrected for the fit's own projection, floored at the white level of
    # the residual above f0/2 (dampfit.inference.noise)
    nm = noise.estimate(ls.residuals, fd.fs, prep.f0, 0.25 * prep.f0, ls.n_params,
                        white=noise.white_ratio(fd.lowpass_sos, fd.fs_filter, fd.fs, prep.f0),
                        jacobian=ls.jacobian, lowpass=(fd.lowpass_sos, fd.fs_filter))
    return FitStages(baselines=base, fit_data=fd, least_squares=ls, noise=nm, warnings=warns)


def viscous_stages(prep: prepare.Prepared, mass: physics.Mass, *,
                   sampler: SamplerSettings | None = None, on_fit=None) -> ViscousStages:
    """:func:`fit_stages` and the viscous posterior of one prepared signal: the stages
    :func:`dampfit.pipeline.analyze` and the ``bayes`` estimator share (``mass`` the
    checked :class:`dampfit.physics.Mass` [kg] with its sd; ``sampler`` the
    :class:`~dampfit._options.SamplerSettings`, default ones if None). ``on_fit(stages)`` is
    called with the :class:`FitStages` before the posterior is sampled."""
    s = SamplerSettings() if sampler is None else sampler
    st = fit_stages(prep, mass)
    if on_fit is not None:
        on_fit(st)
    started = time.monotonic()
    post = posterior.sample(
        posterior.Target(st.fit_data, prep.band, 1.0 / st.noise.psd_ratio), st.least_squares,
        mass=mass.value, mass_sd=mass.sd, seed=s.seed, progress=s.progress, max_steps=s.max_steps,
        min_ess=s.min_ess,
    )
    return ViscousStages(baselines=st.baselines, fit_data=st.fit_data,
                         least_squares=st.least_squares, noise=st.noise,
                         warnings=st.warnings + list(post.warnings), sampling=post,
                         posterior_seconds=time.monotonic() - started)


def initial_decay_rate(base: dict) -> float:
    """The least-squares starting decay rate p [1/s]: the log decrement's regression p, else
    the envelope pipeline's; NaN when neither gave a positive finite p."""
    for name in ("log_decrement", "envelope_pipeline"):
        b = base.get(name)
        if b is not None:
            p = b.details.get("p_regression", b.p) if name == "log_decrement" else b.p
            if p is not None and np.isfinite(p) and p > 0:
                return float(p)
    return float("nan")


def assess_damping(prep: prepare.Prepared, run: ViscousStages, mass: physics.Mass,
                   options: AnalysisOptions):
    """Damping-law comparison, ζ(amplitude) and model checks (:mod:`dampfit.damping`) after
    the viscous stages ``run``, under ``options`` (its model, amplitude and sampler); the
    warnings are the result's ``warnings``.

    The comparison uses each law's Laplace approximation; emcee runs for the chosen law only
    when it is not the viscous one (whose emcee posterior is ``parameters``), within a step
    budget tied to the viscous sampler's (:class:`dampfit.inference.law_sampler.Budget`)."""
    from dampfit import damping
    from dampfit.inference.law_sampler import Budget

    budget = Budget.from_viscous(run.sampling.n_steps, run.posterior_seconds)
    return damping.assess(prep, run.fit_data, run.least_squares, run.noise, mass,
                          model=options.model, amplitude=options.amplitude,
                          settings=damping.Settings("chosen-nonviscous",
                                                    sampler=options.sampler, budget=budget))


def crlb_stage(prep, fd, ls, nm, mass: physics.Mass) -> tuple[dict[str, Any] | None, list[str]]:
    """Cramér–Rao bound of this recording's design (:mod:`dampfit.inference.crlb`) and the
    stage's warnings (the bound, None and why when it cannot be computed).

    Design: the raw usable sample times of the window; white noise at the level the residuals
    show at f₀ — one-sided density S(f₀) = r·σ²·2/f_fit from the noise model (σ per fitted
    sample, r the Whittle factor), i.e. σ_raw = √(S(f₀)·f_s/2) per raw sample — since by the
    Whittle argument only the noise near f₀ limits the estimate; the least-squares parameters
    (amplitude with the decimation filter's gain removed); the fitted drift as nuisance."""
    from dampfit.inference import crlb

    sel = prep.time_in_window & prep.usable
    density = float(np.sqrt(nm.psd_ratio * nm.sigma**2 * 2.0 / nm.fs))
    sigma = crlb.from_noise_density(density, prep.fs)
    a_cos, a_sin = ls.true_quadratures()
    try:
        out = crlb.bound(prep.time[sel] - fd.t0, sigma, p=ls.p, omega_d=ls.omega_d,
                         a_cos=a_cos, a_sin=a_sin, mass=mass,
                         drift_degree=fd.drift_degree)
    except (InputError, np.linalg.LinAlgError, ValueError) as exc:
        return None, [f"Cramér–Rao bound not computed: {exc}"]
    out["noise_sigma"] = sigma
    out["noise_density"] = density
    out["noise_density_unit"] = "m/s^2/sqrt(Hz)"
    return out, []


def ls_summary(ls: least_squares.LeastSquaresResult, mass: float | None,
               r: float = 1.0) -> dict[str, Any]:
    """The one least-squares summary: p [1/s], ζ, f_n [Hz], u₀ [m] and (with ``mass`` [kg]) c
    [N·s/m], k [N/m] (:func:`dampfit.physics.quantities`), with the 1-σ ``p_sd``, ``zeta_sd``
    and ``c_sd`` — summary.json's ``least_squares`` and the study's ``least_squares``
    estimator (:mod:`dampfit.study.registry`) both report it.

    The 1-σ come from the Jacobian covariance C of θ = (ln p, ln ω_d) times the noise
    calibration factor ``r`` (as the posterior's temper), by the delta method:
    sd(ln p) = √C₁₁, and with ln ζ = ln p − ½·ln(p² + ω_d²),
    sd(ln ζ) = (1 − ζ²)·√(C₁₁ − 2C₁₂ + C₂₂); sd(ln c) = sd(ln p) (the mass is exact here).
    """
    q = ls_quantities(ls, mass)
    out = {name: (float(q[name]) if name in q else None)
           for name in ("p", "zeta", "f_n", "u0", "c", "k")}
    cov = np.asarray(ls.cov[:2, :2], float) * r
    if np.all(np.isfinite(cov)):
        sd_lnp = float(np.sqrt(max(cov[0, 0], 0.0)))
        zeta = out["zeta"]
        sd_lnz = (1 - zeta**2) * float(np.sqrt(max(cov[0, 0] - 2 * cov[0, 1] + cov[1, 1], 0.0)))
        out["p_sd"] = out["p"] * sd_lnp
        out["c_sd"] = out["c"] * sd_lnp if mass is not None else None
        out["zeta_sd"] = zeta * sd_lnz
    return out


def ls_quantities(ls: least_squares.LeastSquaresResult, mass: float | None = None) -> dict[str, np.ndarray]:
    """:func:`dampfit.physics.quantities` of the least-squares optimum: p, ω_d and the
    acceleration amplitude with the decimation filter's gain removed
    (:meth:`~dampfit.inference.least_squares.LeastSquaresResult.true_quadratures`)."""
    return physics.quantities(ls.p, ls.omega_d, mass,
                              accel_amplitude=np.hypot(*ls.true_quadratures()))


def fitted_curve(fd: prepare.FitData, ls: least_squares.LeastSquaresResult,
                 n: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares model of the fitted samples (decay and drift, as fitted: filter gain
    included) on ``n`` uniform times over the fitted span: (t [s], a [m/s²])."""
    from dampfit.model import viscous

    # same end points as fd.tau, so the drift basis maps onto the same [-1, 1]
    tau = np.linspace(fd.tau[0], fd.tau[-1], int(n))
    drift = viscous.drift_basis(fd.tau, fd.drift_degree, at=tau)
    # NumPy columns: a figure needs no JAX trace
    x = np.concatenate([viscous.M1.columns(np.asarray(ls.theta), tau, xp=np), drift], axis=1)
    return fd.t0 + tau, x @ np.asarray(ls.beta)


def window_signals(prep: prepare.Prepared, fd, ls, envelope=None) -> dict[str, np.ndarray]:
    """The signals of :meth:`dampfit.analysis.Analysis.signals` from a prepared recording, its fit data, its
    least-squares result and (optionally) its envelope-pipeline baseline (else the measured
    displacement is NaN); also each test of a campaign (:meth:`CampaignAnalysis.signals`)."""
    from dampfit.model import viscous

    sel = prep.grid_in_window
    t = prep.grid[sel]
    tau = t - fd.t0
    a_cos, a_sin = ls.true_quadratures()
    args = (np.asarray(tau, float), ls.p, ls.omega_d, a_cos, a_sin)
    accel_model = np.asarray(viscous.acceleration(*args, xp=np), dtype=float)
    disp_model = np.asarray(viscous.displacement(*args, xp=np), dtype=float)
    disp = np.full(t.size, np.nan)
    if envelope is not None and np.size(envelope.details.get("displacement", [])) == t.size:
        disp = np.asarray(envelope.details["displacement"], float)
    return {"t": t, "accel": prep.bandpassed[sel], "accel_model": accel_model,
            "displacement": disp, "displacement_model": disp_model,
            "fs": np.float64(prep.fs), "p": np.float64(ls.p),
            "omega_d": np.float64(ls.omega_d), "t0": np.float64(fd.t0)}


# ----------------------------------------------------------------------------- plain data
def fit_summary(rec: Recording, prep: prepare.Prepared, fd: prepare.FitData,
                ls: least_squares.LeastSquaresResult, nm: noise.NoiseModel,
                mass: float | None, mass_sd: float) -> dict[str, Any]:
    """The summary.json sections known once :func:`fit_stages` has run (JSON-safe): ``input``,
    ``window``, ``band``, ``dominant_frequency_hz``, ``mass`` (``mass`` and ``mass_sd`` [kg]),
    ``least_squares`` (:func:`ls_summary` with the solver's state), ``noise_model``, ``fit``
    and ``preprocessing`` — :meth:`dampfit.analysis.Analysis.summary` holds them unchanged."""
    import os

    lsd = ls_summary(ls, mass, nm.psd_ratio)
    lsd.update({"converged": ls.converged, "message": ls.message, "n_steps": ls.n_steps})
    return jsonable({
        "input": {
            "path": os.path.abspath(rec.path) if rec.path else rec.path, "format": rec.format,
            "sha256": rec.sha256, "n_samples": rec.n_samples, "sample_rate_hz": prep.fs,
            "duration_s": rec.duration, "timing_jitter": prep.jitter,
            "axis": prep.axis, "axis_direction": prep.direction,
            "gravity_removed": rec.gravity_removed, "notes": list(rec.notes),
            "decimated": prep.decimation,
        },
        "window": {"start_s": prep.window[0], "end_s": prep.window[1],
                   "auto": prep.window_auto,
                   "n_cycles": (prep.window[1] - prep.window[0]) * prep.f0,
                   "end_reason": prep.window_end_reason},
        "band": {"low_hz": prep.band[0], "high_hz": prep.band[1], "auto": prep.band_auto},
        "dominant_frequency_hz": prep.f0,
        "mass": {"value": mass, "sd": mass_sd if mass is not None else None, "unit": "kg"},
        "least_squares": lsd,
        "noise_model": nm.summary(),
        "fit": {"path": fd.path, "n_samples": int(fd.y.size), "sample_rate_hz": fd.fs,
                "drift_degree": fd.drift_degree, "n_excluded": fd.n_excluded, "t0_s": fd.t0},
        "preprocessing": {"n_stale_dropped": prep.n_stale, "n_clipped": prep.n_clipped,
                          "n_spikes": prep.n_spikes, "noise_density": prep.noise_density,
                          "noise_density_unit": "m/s^2/sqrt(Hz)", "notes": list(prep.notes)},
    })


def sampling_summary(post: posterior.PosteriorResult) -> dict[str, Any]:
    """The sampler's part of summary.json's ``diagnostics`` (JSON-safe), known once the
    posterior stage has run: its convergence, max R-hat [1], min bulk ESS [draws], steps,
    burn-in and thinning [steps], walkers, autocorrelation times [steps], acceptance [1]."""
    return jsonable({
        "posterior_converged": post.converged,
        "max_r_hat": post.max_r_hat, "min_ess_bulk": post.min_ess_bulk,
        "n_steps": post.n_steps, "burn_in": post.burn_in, "thin": post.thin,
        "n_walkers": posterior.N_WALKERS,
        "autocorr_time_steps": [float(x) for x in post.autocorr_time],
        "acceptance_fraction": post.acceptance,
    })


def figure_signals(prep: prepare.Prepared, fd: prepare.FitData,
                   ls: least_squares.LeastSquaresResult, base: dict) -> dict[str, np.ndarray]:
    """:func:`window_signals` plus the arrays the figures are drawn from (float64, SI units;
    every key documented in :mod:`dampfit.result.signals`): the whole recording reduced for
    display (:func:`recording_arrays`), its amplitude spectrum (:func:`spectrum_arrays`), the
    fitted samples with the least-squares curve (:func:`fit_arrays`) and the envelope
    pipeline's displacement envelopes and log-decrement peaks (:func:`displacement_arrays`;
    absent when that baseline failed). Lines over the whole recording are reduced to at most
    :data:`dampfit.signal.display.MAX_LINE_POINTS` points, dots to
    :data:`~dampfit.signal.display.MAX_DOTS`; window-long arrays are as long as ``t``."""
    out = window_signals(prep, fd, ls, base.get("envelope_pipeline"))
    out.update(recording_arrays(prep))
    out.update(spectrum_arrays(prep))
    out.update(fit_arrays(prep, fd, ls))
    out.update(displacement_arrays(prep, base))
    return out


def recording_arrays(prep: prepare.Prepared) -> dict[str, np.ndarray]:
    """The whole recording for the signal figure: each axis on the grid (``rec_axes_t``,
    ``rec_axes_y`` concatenated, ``rec_axes_n`` points per axis), the selected signal
    (``rec_signal_*``) and its band-pass envelope (``rec_envelope_*``) reduced
    (:func:`dampfit.signal.display.keep_extremes`); the masked samples (``rec_masked_*``) and
    their runs (``rec_masked_runs``, (start, end) [s] split at gaps over 5 samples); the
    y limits of the axes and of the signal (``rec_ylim`` rows; NaN: none) from the samples
    away from masked ones."""
    bad = ~np.asarray(prep.usable, bool)
    t_bad, y_bad = prep.time[bad], prep.signal[bad]
    dt = 1.0 / prep.fs
    grid_ok = display.distance_to(t_bad, prep.grid) > 1.5 * dt  # not beside a masked sample
    axes = [display.keep_extremes(prep.grid, prep.grid_raw[:, j])
            for j in range(prep.grid_raw.shape[1])]
    lims = [display.robust_limits(prep.grid_raw[grid_ok] if grid_ok.any() else prep.grid_raw),
            display.robust_limits(prep.signal[~bad] if (~bad).any() else prep.signal)]
    t_sig, y_sig = display.keep_extremes(prep.time, prep.signal)
    t_env, y_env = display.keep_extremes(prep.grid, prep.envelope)
    t_mask, y_mask = display.keep_extremes(t_bad, y_bad, display.MAX_DOTS)
    return {"rec_axes_t": np.concatenate([t for t, _ in axes]),
            "rec_axes_y": np.concatenate([y for _, y in axes]),
            "rec_axes_n": np.array([t.size for t, _ in axes], float),
            "rec_signal_t": t_sig, "rec_signal_y": y_sig,
            "rec_envelope_t": t_env, "rec_envelope_y": y_env,
            "rec_masked_t": t_mask, "rec_masked_y": y_mask,
            "rec_masked_runs": np.array(display.bounded_runs(t_bad, 5 * dt), float).reshape(-1, 2),
            "rec_ylim": np.array([lim if lim is not None else (np.nan, np.nan) for lim in lims])}


def spectrum_arrays(prep: prepare.Prepared) -> dict[str, np.ndarray]:
    """The single-sided amplitude spectrum [m/s²] of the selected signal up to
    max(4·f₀, 2·band high) (at most the Nyquist frequency), reduced: ``spectrum_f`` [Hz],
    ``spectrum_amp``."""
    fmax = display.spectrum_limit(prep.f0, prep.band[1], prep.fs)
    sel = (prep.freqs > 0) & (prep.freqs <= fmax)
    f, amp = display.keep_extremes(prep.freqs[sel], prep.amplitude[sel])
    return {"spectrum_f": f, "spectrum_amp": amp}


def fit_arrays(prep: prepare.Prepared, fd: prepare.FitData,
               ls: least_squares.LeastSquaresResult) -> dict[str, np.ndarray]:
    """The fitted samples ``fit_t`` [s], ``fit_y`` [m/s²] and residuals ``fit_residual``, the
    least-squares model on a grid of 40 points per cycle (2 000 to
    :data:`~dampfit.signal.display.MAX_DOTS`) over the fitted span (``fit_model_t``,
    ``fit_model_y``; :func:`fitted_curve`), and, when the fitted samples are filtered (not the
    raw path), the recorded signal in the first and last
    :data:`~dampfit.signal.display.ZOOM_CYCLES` cycles of that span
    (:func:`dampfit.signal.display.zoom_ranges`; ``fit_raw_t``, ``fit_raw_y``; empty on the
    raw path)."""
    t_fit = np.asarray(fd.t0 + fd.tau, float)
    f_d = float(ls_quantities(ls)["f_d"])
    n_curve = int(np.clip(40 * f_d * float(fd.tau[-1] - fd.tau[0]), 2000, display.MAX_DOTS))
    t_mod, y_mod = fitted_curve(fd, ls, n_curve)
    keep = np.zeros(prep.time.size, bool)
    if fd.path != "raw":
        t_start, t_end = float(t_fit[0]), float(t_fit[-1])
        for lo, hi in display.zoom_ranges(t_start, t_end, f_d):
            keep |= (prep.time >= t_start) & (prep.time <= t_end) & (prep.time >= lo) & (
                prep.time <= hi)
    return {"fit_t": t_fit, "fit_y": np.asarray(fd.y, float),
            "fit_residual": np.asarray(ls.residuals, float),
            "fit_model_t": t_mod, "fit_model_y": y_mod,
            "fit_raw_t": np.asarray(prep.time[keep], float),
            "fit_raw_y": np.asarray(prep.signal[keep], float)}


def displacement_arrays(prep: prepare.Prepared, base: dict) -> dict[str, np.ndarray]:
    """The envelope pipeline's Hilbert envelope ``disp_envelope`` [m], its fit K·e^(−pt)
    ``disp_envelope_fit`` [m] and the samples that fit used ``disp_fit_mask`` (1/0) on the
    window's ``t``, with its ``disp_p`` [1/s], ``disp_c`` [N·s/m] (NaN without a mass) and
    ``disp_zeta``; the log decrement's peaks ``logdec_peak_t`` [s], ``logdec_peak_a`` [m/s²]
    and ``logdec_p`` [1/s] when it found them. Empty when the envelope pipeline failed."""
    env = base.get("envelope_pipeline")
    n = int(np.count_nonzero(prep.grid_in_window))
    det = env.details if env is not None else {}
    if env is None or np.size(det.get("displacement", [])) != n or n < 2:
        return {}
    out = {"disp_envelope": np.asarray(det["envelope"], float),
           "disp_envelope_fit": np.asarray(det["envelope_fit"], float),
           "disp_fit_mask": np.asarray(det.get("fit_mask", np.ones(n, bool)), bool).astype(float),
           "disp_p": _number(env.p), "disp_c": _number(env.c), "disp_zeta": _number(env.zeta)}
    ld = base.get("log_decrement")
    if ld is not None and "peak_times" in ld.details:
        out.update({"logdec_peak_t": np.asarray(ld.details["peak_times"], float),
                    "logdec_peak_a": np.asarray(ld.details["peak_amplitudes"], float),
                    "logdec_p": _number(ld.p)})
    return out


def _number(x) -> np.float64:
    """``x`` as a float64 scalar, NaN for None."""
    return np.float64(np.nan if x is None else x)


from dampfit.stages.modes import (  # noqa: E402 (the modes stage)
    ModesStage, OneMode, modes_disagreement, modes_stage, one_mode_values)
