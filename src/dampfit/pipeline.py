"""The main job: :func:`analyze` a free-decay recording into c, k, u₀ with a posterior.

Fixed pipeline (each stage its own module):
``preprocess`` → ``baselines`` (initial guess, reported) → ``fit`` (least squares) →
``noise`` (calibration) → ``posterior`` (emcee) → :class:`Analysis` (plain-data summary).
"""

from __future__ import annotations

import json
import os
import platform
import time
from datetime import datetime, timezone
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from dampfit import physics
from dampfit.damping.quantities import summarise
from dampfit.estimators import baselines
from dampfit.inference import least_squares as fit
from dampfit.inference import noise
from dampfit.inference import posterior
from dampfit.signal import prepare as preprocess
from dampfit._json import jsonable
from dampfit._files import atomic_write, atomic_write_text
from dampfit.errors import InputError
from dampfit.io.recording import Recording
from dampfit.result.views import ResultViews

__all__ = ["Analysis", "analyze", "PARAMETER_UNITS"]

#: Unit of every reported parameter.
PARAMETER_UNITS = {name: physics.UNITS[name] for name in (
    "c", "k", "u0", "zeta", "f_n", "p", "f_d", "delta", "Q", "c_crit")}
#: A PSD ratio r above this many times its white-noise value signals residual structure.
R_WARN = noise.R_WARN
#: A free decay must explain at least this fraction of the window's variance beyond the drift
#: (a real decay explains ≈ 1 − 1/SNR; random hand motion or noise far less).
MIN_EXPLAINED = 0.5


def _version() -> str:
    try:
        return metadata.version("dampfit")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def _check_mass(mass: float | None, mass_sd: float | None) -> tuple[float | None, float]:
    """Mass [kg] and its standard deviation [kg] checked (:func:`dampfit.physics.check_mass`)."""
    return physics.check_mass(mass, mass_sd)


@dataclass
class Analysis(ResultViews):
    """Everything :func:`analyze` computed. ``summary()`` is the plain-data view of it.

    The same class is what :func:`dampfit.load` returns for a result folder: then
    :meth:`summary` is the folder's summary.json as written (not recomputed), ``posterior`` is
    read from posterior.nc and :meth:`signals` from signals.npz when first used, ``folder`` is
    the folder, and the live pipeline objects (``recording``, ``prepared``, ``fit_data``,
    ``least_squares``, ``noise``, ``sampling``, ``baselines``, ``damping``) raise a
    :class:`~dampfit.errors.DampfitError` saying the result was loaded from that folder.
    """

    recording: Recording
    prepared: preprocess.Prepared
    fit_data: preprocess.FitData
    least_squares: fit.LeastSquaresResult
    noise: noise.NoiseModel
    sampling: posterior.PosteriorResult
    baselines: dict[str, baselines.BaselineResult | None]
    crlb: dict[str, Any] | None
    mass: float | None
    mass_sd: float
    seed: int
    options: dict[str, Any]
    warnings: list[str] = field(default_factory=list)
    damping: Any = None  # dampfit.damping.DampingAssessment (None when not assessed)
    date: str = field(default_factory=lambda: datetime.now(timezone.utc).isoformat(timespec="seconds"))
    #: Result folder this analysis was loaded from (:func:`dampfit.load`); None when live.
    folder: Path | None = None
    #: What :func:`dampfit.result.folder.load` read (summary, lazily posterior and signals).
    _loaded: Any = field(default=None, repr=False, compare=False)
    _summary: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)

    # --------------------------------------------------------------- views
    # posterior, converged: dampfit.result.views.ResultViews
    def _live_converged(self) -> bool:
        """Least squares and posterior both converged."""
        return bool(self.least_squares.converged and self.sampling.converged)

    def draws(self, name: str) -> np.ndarray:
        """All posterior draws of one quantity, flattened."""
        return np.asarray(self.posterior.posterior[name]).ravel()

    def summary(self) -> dict[str, Any]:
        """The JSON-safe summary (schema in the README; ``schema_version``
        :data:`dampfit.result.schema.SCHEMA_VERSION`), a fresh copy on every call.

        Computed once per analysis and cached; of a loaded result it is the summary.json read.
        """
        import copy

        if self._summary is None:
            if self._loaded is not None:
                self._summary = self._loaded.summary
            else:
                from dampfit.result.schema import SCHEMA_VERSION

                self._summary = {"schema_version": SCHEMA_VERSION, **self._compute_summary()}
        return copy.deepcopy(self._summary)

    def _compute_summary(self) -> dict[str, Any]:
        """The summary of the live pipeline objects (see :meth:`summary`)."""
        rec, prep, fd = self.recording, self.prepared, self.fit_data
        post = self.posterior.posterior
        params: dict[str, Any] = {}
        for name in PARAMETER_UNITS:
            params[name] = (_param_summary(self.posterior, name, self.sampling.diagnostics)
                            if name in post else None)
            bound = (self.crlb or {}).get(name)
            if params[name] is not None and isinstance(bound, dict):
                params[name]["crlb_sd"] = bound.get("sd_with_mass", bound["sd"])
        missing = {}
        if self.mass is None:
            why = ("no mass given: a free decay identifies only the decay rate p and the "
                   "frequency f_n; c = 2·m·p and k = m·(2π·f_n)² need the mass (--mass KG)")
            missing = {"c": why, "k": why, "c_crit": why}
        ls = self.least_squares
        lsd = _ls_physical(ls, self.mass, self.noise.psd_ratio)
        lsd.update({"converged": ls.converged, "message": ls.message, "n_steps": ls.n_steps})
        s = self.sampling
        return jsonable({
            "dampfit_version": _version(),
            "input": {
                "path": os.path.abspath(rec.path) if rec.path else rec.path, "format": rec.format, "sha256": rec.sha256,
                "n_samples": rec.n_samples, "sample_rate_hz": prep.fs,
                "duration_s": rec.duration, "timing_jitter": prep.jitter,
                "axis": prep.axis, "axis_direction": prep.direction,
                "gravity_removed": rec.gravity_removed, "notes": list(rec.notes),
            },
            "window": {"start_s": prep.window[0], "end_s": prep.window[1],
                       "auto": prep.window_auto,
                       "n_cycles": (prep.window[1] - prep.window[0]) * prep.f0},
            "band": {"low_hz": prep.band[0], "high_hz": prep.band[1], "auto": prep.band_auto},
            "dominant_frequency_hz": prep.f0,
            "mass": {"value": self.mass, "sd": self.mass_sd if self.mass is not None else None,
                     "unit": "kg"},
            "parameters": params,
            "missing": missing,
            "least_squares": lsd,
            "baselines": _baselines_summary(self.baselines, params.get("p")),
            "noise_model": self.noise.summary(),
            "crlb": self.crlb,
            **self._damping_summary(),
            "fit": {"path": fd.path, "n_samples": int(fd.y.size), "sample_rate_hz": fd.fs,
                    "drift_degree": fd.drift_degree, "n_excluded": fd.n_excluded,
                    "t0_s": fd.t0},
            "preprocessing": {"n_stale_dropped": prep.n_stale, "n_clipped": prep.n_clipped,
                              "n_spikes": prep.n_spikes,
                              "noise_density": prep.noise_density,
                              "noise_density_unit": "m/s^2/sqrt(Hz)",
                              "notes": list(prep.notes)},
            "diagnostics": {
                "converged": self.converged,
                "posterior_converged": s.converged,
                "max_r_hat": s.max_r_hat, "min_ess_bulk": s.min_ess_bulk,
                "n_steps": s.n_steps, "burn_in": s.burn_in, "thin": s.thin,
                "n_walkers": posterior.N_WALKERS,
                "autocorr_time_steps": [float(x) for x in s.autocorr_time],
                "acceptance_fraction": s.acceptance,
                "warnings": list(self.warnings),
            },
            "provenance": {"seed": self.seed, "options": self.options, "date": self.date,
                           "python": platform.python_version(), "versions": _versions()},
        })

    def _damping_summary(self) -> dict[str, Any]:
        """model_checks, damping_models, amplitude_curve and c_equivalent (the chosen
        non-viscous law's energy-equivalent viscous c at a stated amplitude, else None)."""
        if self.damping is None:
            return {"model_checks": None, "damping_models": None, "amplitude_curve": None,
                    "c_equivalent": None}
        out = dict(self.damping.summary())
        out["c_equivalent"] = (self.damping.c_report() if self.damping.chosen != "viscous"
                               else None)
        # each law's sampling facts: budget, stop reason, ill-conditioning (damping.sample)
        for name, entry in ((out.get("damping_models") or {}).get("models") or {}).items():
            post = self.damping.posteriors.get(name)
            if post is not None and isinstance(entry.get("posterior"), dict):
                entry["posterior"].update(jsonable(post.diagnostics()))
        return out

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`summary` as JSON to ``path`` (atomically)."""
        return atomic_write_text(path, json.dumps(self.summary(), indent=2) + "\n")

    def true_quadratures(self) -> tuple[float, float]:
        """Least-squares acceleration quadratures (A, B) [m/s²] at the window start, filter
        gain removed (:meth:`dampfit.inference.least_squares.LeastSquaresResult.true_quadratures`)."""
        if self._loaded is not None:
            raise self._loaded.live_only("true_quadratures()")
        return self.least_squares.true_quadratures()

    def signals(self) -> dict[str, np.ndarray]:
        """Measured and modelled signals on the analysis window (plain arrays, SI units).

        ``t`` [s] uniform grid of the window (recording time base), ``accel`` [m/s²]
        band-passed measured acceleration of the analysed axis, ``accel_model`` [m/s²] the
        least-squares decay (drift excluded, filter gain removed), ``displacement`` [m] the
        measured displacement of the paper's pipeline (band-pass, ∫∫, band-pass; NaN when that
        baseline failed), ``displacement_model`` [m]; scalars ``fs`` [Hz], ``p`` [1/s],
        ``omega_d`` [rad/s], ``t0`` [s] (window start, τ = t − t0).

        Of a loaded result: the arrays of its signals.npz (a copy).
        """
        if self._loaded is not None:
            return self._loaded.signals()
        from dampfit.model import viscous as model

        prep, ls = self.prepared, self.least_squares
        sel = (prep.grid >= prep.window[0]) & (prep.grid <= prep.window[1])
        t = prep.grid[sel]
        tau = t - self.fit_data.t0
        a_cos, a_sin = self.true_quadratures()
        args = (np.asarray(tau, float), ls.p, ls.omega_d, a_cos, a_sin)
        accel_model = np.asarray(model.acceleration(*args, xp=np), dtype=float)
        disp_model = np.asarray(model.displacement(*args, xp=np), dtype=float)
        env = self.baselines.get("envelope_pipeline")
        disp = np.full(t.size, np.nan)
        if env is not None and np.size(env.details.get("displacement", [])) == t.size:
            disp = np.asarray(env.details["displacement"], float)
        return {"t": t, "accel": prep.bandpassed[sel], "accel_model": accel_model,
                "displacement": disp, "displacement_model": disp_model,
                "fs": np.float64(prep.fs), "p": np.float64(ls.p),
                "omega_d": np.float64(ls.omega_d), "t0": np.float64(self.fit_data.t0)}

    def to_signals(self, path: str | os.PathLike) -> Path:
        """Write :meth:`signals` to an ``.npz`` file (atomically)."""
        arrays = self.signals()
        return atomic_write(path, lambda tmp: np.savez_compressed(tmp, **arrays), suffix=".npz")

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write the posterior (arviz InferenceData) to a NetCDF file."""
        return atomic_write(path, lambda tmp: self.posterior.to_netcdf(tmp, engine="h5netcdf"),
                            suffix=".nc")


# --------------------------------------------------------------------- the job
@dataclass(frozen=True)
class FitStages:
    """The stages before the posterior of one prepared signal (:func:`fit_stages`)."""

    baselines: dict[str, Any]  # name → baselines.BaselineResult | None
    fit_data: preprocess.FitData
    least_squares: fit.LeastSquaresResult
    noise: noise.NoiseModel
    warnings: list[str]


@dataclass(frozen=True)
class ViscousStages(FitStages):
    """The stages of the viscous analysis of one prepared signal (:func:`viscous_stages`)."""

    sampling: posterior.PosteriorResult = None
    posterior_seconds: float = float("nan")  # wall time [s] of the posterior stage


def fit_stages(prep: preprocess.Prepared, mass: float | None) -> FitStages:
    """Baselines, least squares and noise calibration of one prepared signal: the stages
    :func:`analyze`, the ``bayes`` estimator and each test of a campaign
    (:mod:`dampfit.campaign`) share (``mass`` [kg] or None, for the baselines' c). Refuses
    (one-line :class:`~dampfit.errors.InputError`) a window with no free decay and a
    noise-free record."""
    warns: list[str] = []
    # baselines on the uniform grid inside the window (also the initial guess)
    sel = (prep.grid >= prep.window[0]) & (prep.grid <= prep.window[1])
    base: dict[str, baselines.BaselineResult | None] = {}
    for name, fn in (("log_decrement", baselines.log_decrement),
                     ("envelope_pipeline", baselines.envelope_pipeline)):
        try:
            base[name] = fn(prep.grid[sel], prep.grid_signal[sel], prep.fs, prep.band, mass=mass)
        except InputError as exc:
            base[name] = None
            warns.append(f"baseline {name} not computed: {exc}")
    p0 = _initial_decay_rate(base)

    fd = preprocess.fit_data(prep)
    ls = fit.least_squares(fd, p0, prep.f0)
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
                        jacobian=ls.jacobian, sos=fd.lowpass_sos, fs_filter=fd.fs_filter)
    return FitStages(baselines=base, fit_data=fd, least_squares=ls, noise=nm, warnings=warns)


def viscous_stages(prep: preprocess.Prepared, mass: float | None, mass_sd: float, *,
                   seed: int = 0, progress: bool = False, max_steps: int = 20000,
                   min_ess: float = 1000.0, on_fit=None) -> ViscousStages:
    """:func:`fit_stages` and the viscous posterior of one prepared signal: the stages
    :func:`analyze` and the ``bayes`` estimator share (``mass`` [kg] and ``mass_sd`` [kg] as
    checked by :func:`dampfit.physics.check_mass`). ``on_fit(stages)`` is called with the
    :class:`FitStages` before the posterior is sampled."""
    st = fit_stages(prep, mass)
    if on_fit is not None:
        on_fit(st)
    started = time.monotonic()
    post = posterior.sample(
        st.fit_data, st.least_squares, band=prep.band, temper=1.0 / st.noise.psd_ratio,
        mass=mass, mass_sd=mass_sd, seed=seed, progress=progress, max_steps=max_steps,
        min_ess=min_ess,
    )
    return ViscousStages(baselines=st.baselines, fit_data=st.fit_data,
                         least_squares=st.least_squares, noise=st.noise,
                         warnings=st.warnings + list(post.warnings), sampling=post,
                         posterior_seconds=time.monotonic() - started)


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

    ``on_stage(name, fields)``, when given, is called as stages finish with the
    :class:`Analysis` fields they produced: ``"fit"`` (recording, prepared, fit_data,
    least_squares, noise, baselines, mass, mass_sd, seed) before the posterior is sampled and
    ``"posterior"`` (sampling) before the damping laws are assessed — the CLI draws figures
    from them in a second process meanwhile (:mod:`dampfit.output.figure_process`). Not used
    for several recordings.
    """
    if isinstance(recording, (list, tuple)):  # several recordings of one damper (issue 12)
        from dampfit.campaign import analyze_campaign

        return analyze_campaign(recording, mass, mass_sd, axis=axis, window=window, band=band,
                                seed=seed, progress=progress, max_steps=max_steps,
                                min_ess=min_ess)
    if not isinstance(recording, Recording):
        raise InputError("analyze() takes a Recording; use dampfit.read(path) first")
    m, sd = _check_mass(mass, mass_sd)
    _check_damping_options(model, amplitude)
    warns: list[str] = []
    _refuse_impossible_time(recording)
    prep = preprocess.prepare(recording, axis=axis, window=window, band=band)
    warns.extend(prep.warnings)
    warns.extend(unit_plausibility(recording, prep, m))

    def fitted(st: FitStages) -> None:
        if on_stage is not None:
            on_stage("fit", {"recording": recording, "prepared": prep, "fit_data": st.fit_data,
                             "least_squares": st.least_squares, "noise": st.noise,
                             "baselines": st.baselines, "mass": m, "mass_sd": sd,
                             "seed": int(seed)})

    stages = viscous_stages(prep, m, sd, seed=seed, progress=progress, max_steps=max_steps,
                            min_ess=min_ess, on_fit=fitted)
    base, fd, ls, nm, post = (stages.baselines, stages.fit_data, stages.least_squares,
                              stages.noise, stages.sampling)
    if on_stage is not None:
        on_stage("posterior", {"sampling": post})
    warns.extend(stages.warnings)
    bound = _crlb(prep, fd, ls, nm, m, sd, warns)
    viscous_seconds = stages.posterior_seconds
    assessment = _assess_damping(prep, fd, ls, nm, m, sd, model, amplitude, seed, progress,
                                 max_steps, min_ess, warns, post.n_steps, viscous_seconds)
    # the r warning, unless the adequacy verdict's warning already explains the structure
    if nm.excess > R_WARN and assessment.verdict_name not in ("misfit", "amplitude-dependent"):
        warns.append(
            f"residuals near f0 are {nm.excess:.1f}x what white noise alone would leave on this "
            "path (coloured noise, amplitude-dependent damping or a second mode?); intervals "
            "were widened to match"
        )
    options = {"axis": axis, "window": list(window) if window else None,
               "band": list(band) if band else None, "max_steps": max_steps,
               "min_ess": min_ess, "model": model, "amplitude": amplitude}
    return Analysis(
        recording=recording, prepared=prep, fit_data=fd, least_squares=ls, noise=nm,
        sampling=post, baselines=base, crlb=bound, damping=assessment, mass=m, mass_sd=sd, seed=int(seed), options=options,
        warnings=warns,
    )


# --------------------------------------------------------------------- unit plausibility
#: Dominant frequencies [Hz] and stiffnesses [N/m] a free-decay test plausibly has; outside
#: them a unit mix-up (time in ms read as s, or the reverse) is the likely cause.
PLAUSIBLE_F0_HZ = (0.05, 2000.0)
PLAUSIBLE_K_N_PER_M = (1e-3, 1e8)


#: Residual power relative to the signal's below which a record is noise-free (rounding
#: only: residual rms < 1e-8 of the signal, 40 dB below a 24-bit converter's resolution).
NOISE_FREE_POWER = 1e-16
#: Sample rates [Hz] no accelerometer recording can have: outside this range the time
#: column is in the wrong unit or corrupt, and the analysis is refused up front.
POSSIBLE_RATE_HZ = (1e-3, 1e8)


def _refuse_impossible_time(rec: Recording) -> None:
    """InputError naming the time-unit mix-up when the median sample rate is impossible
    (:data:`POSSIBLE_RATE_HZ`); merely implausible rates only warn (:func:`unit_plausibility`)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        rate = float(1.0 / np.median(np.diff(rec.time)))
    lo, hi = POSSIBLE_RATE_HZ
    if not lo <= rate <= hi:
        raise InputError(rec.time_unit_hint() or f"the median sample rate {rate:.3g} Hz is "
                         "impossible for an accelerometer; check the time column and --time-unit")


def unit_plausibility(rec: Recording, prep: preprocess.Prepared, mass: float | None) -> list[str]:
    """Warnings naming a likely unit mix-up: the time unit (:meth:`Recording.time_unit_hint`:
    a sample rate outside 1 Hz–100 kHz, or seconds under a ``(ms)`` header), a dominant
    frequency outside :data:`PLAUSIBLE_F0_HZ`, or an implied k = m·(2π·f₀)² outside
    :data:`PLAUSIBLE_K_N_PER_M` for the given mass [kg]."""
    out = []
    hint = rec.time_unit_hint()
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
    return out


# --------------------------------------------------------------------- helpers
def _baselines_summary(base: dict, p_post: dict | None) -> dict[str, Any]:
    """Each baseline's summary with its support (:mod:`dampfit.estimators.baselines`) and whether it
    agrees with the posterior of p within its expected spread (``agrees_with_posterior``,
    ``note``; :func:`dampfit.estimators.baselines.agreement`)."""
    out: dict[str, Any] = {}
    for name, b in base.items():
        if b is None:
            out[name] = None
            continue
        d = b.summary()
        d.update(baselines.agreement(d, (p_post or {}).get("q50"), (p_post or {}).get("sd")))
        out[name] = d
    return out


def _initial_decay_rate(base: dict) -> float:
    for name in ("log_decrement", "envelope_pipeline"):
        b = base.get(name)
        if b is not None:
            p = b.details.get("p_regression", b.p) if name == "log_decrement" else b.p
            if p is not None and np.isfinite(p) and p > 0:
                return float(p)
    return float("nan")


def _check_damping_options(model: str, amplitude: float | None) -> None:
    """Validate ``model`` and ``amplitude`` before any work is done."""
    from dampfit.damping import CHOICES

    if model not in CHOICES:
        raise InputError(f"unknown damping model {model!r}; choose one of {', '.join(CHOICES)}")
    if amplitude is not None and not (np.isfinite(amplitude) and amplitude > 0):
        raise InputError("--amplitude must be a positive displacement amplitude in metres, "
                         f"got {amplitude!r}")


def _assess_damping(prep, fd, ls, nm, mass, mass_sd, model, amplitude, seed, progress,
                    max_steps, min_ess, warns: list[str], viscous_steps: int | None = None,
                    viscous_seconds: float | None = None):
    """Damping-law comparison, ζ(amplitude) and model checks (:mod:`dampfit.damping`).

    The comparison uses each law's Laplace approximation; emcee runs for the chosen law only
    when it is not the viscous one (whose emcee posterior is ``parameters``), within a step
    and time budget tied to the viscous sampler's (:class:`dampfit.inference.law_sampler.Budget`)."""
    from dampfit import damping
    from dampfit.inference.law_sampler import Budget

    budget = Budget.from_viscous(viscous_steps, viscous_seconds)
    common = dict(model=model, amplitude=amplitude, seed=seed, max_steps=max_steps,
                  min_ess=min_ess, progress=progress, budget=budget)
    res = damping.assess(prep, fd, ls, nm, mass, mass_sd, posterior="chosen-nonviscous",
                         **common)
    warns.extend(res.warnings)
    return res


def _crlb(prep, fd, ls, nm, mass, mass_sd, warns: list[str]) -> dict[str, Any] | None:
    """Cramér–Rao bound of this recording's design (:mod:`dampfit.inference.crlb`).

    Design: the raw usable sample times of the window; white noise at the level the residuals
    show at f₀ — one-sided density S(f₀) = r·σ²·2/f_fit from the noise model (σ per fitted
    sample, r the Whittle factor), i.e. σ_raw = √(S(f₀)·f_s/2) per raw sample — since by the
    Whittle argument only the noise near f₀ limits the estimate; the least-squares parameters
    (amplitude with the decimation filter's gain removed); the fitted drift as nuisance."""
    from dampfit.inference import crlb

    sel = (prep.time >= prep.window[0]) & (prep.time <= prep.window[1]) & prep.usable
    density = float(np.sqrt(nm.psd_ratio * nm.sigma**2 * 2.0 / nm.fs))
    sigma = crlb.from_noise_density(density, prep.fs)
    a_cos, a_sin = ls.true_quadratures()
    try:
        out = crlb.bound(prep.time[sel] - fd.t0, sigma, p=ls.p, omega_d=ls.omega_d,
                         a_cos=a_cos, a_sin=a_sin, mass=mass, mass_sd=mass_sd,
                         drift_degree=fd.drift_degree)
    except (InputError, np.linalg.LinAlgError, ValueError) as exc:
        warns.append(f"Cramér–Rao bound not computed: {exc}")
        return None
    out["noise_sigma"] = sigma
    out["noise_density"] = density
    out["noise_density_unit"] = "m/s^2/sqrt(Hz)"
    return out


def _param_summary(idata, name: str, diagnostics: dict[str, dict[str, float]]) -> dict[str, Any]:
    """Quantiles of one posterior quantity (:func:`dampfit.damping.quantities.summarise`) with
    the R-hat and bulk ESS the posterior stage computed
    (:attr:`dampfit.inference.posterior.PosteriorResult.diagnostics`; NaN for ≤ 4 draws)."""
    x = np.asarray(idata.posterior[name])
    return summarise(x, PARAMETER_UNITS[name],
                     (diagnostics.get(name) or {}) if x.shape[1] > 4 else {})


def _ls_physical(ls: fit.LeastSquaresResult, mass: float | None, r: float = 1.0) -> dict[str, Any]:
    """Least-squares p, ζ, f_n, u₀ and (with ``mass`` [kg]) c, k (:func:`dampfit.physics.quantities`),
    with 1-σ of c and ζ."""
    q = ls_quantities(ls, mass)
    out = {name: (float(q[name]) if name in q else None)
           for name in ("p", "zeta", "f_n", "u0", "c", "k")}
    # 1-σ from the Jacobian covariance × the noise calibration factor r (as the posterior),
    # by the delta method in (ln p, ln ω_d)
    cov = ls.cov[:2, :2] * r
    if np.all(np.isfinite(cov)):
        sd_lnp = float(np.sqrt(cov[0, 0]))
        out["c_sd"] = out["c"] * sd_lnp if mass is not None else None
        out["zeta_sd"] = out["zeta"] * sd_lnp
    return out


def ls_quantities(ls: fit.LeastSquaresResult, mass: float | None = None) -> dict[str, np.ndarray]:
    """:func:`dampfit.physics.quantities` of the least-squares optimum: p, ω_d and the
    acceleration amplitude with the decimation filter's gain removed
    (:meth:`~dampfit.inference.least_squares.LeastSquaresResult.true_quadratures`)."""
    return physics.quantities(ls.p, ls.omega_d, mass,
                              accel_amplitude=np.hypot(*ls.true_quadratures()))


def fitted_curve(fd: preprocess.FitData, ls: fit.LeastSquaresResult,
                 n: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares model of the fitted samples (decay and drift, as fitted: filter gain
    included) on ``n`` uniform times over the fitted span: (t [s], a [m/s²])."""
    from dampfit.model import viscous as model

    # same end points as fd.tau, so the drift basis maps onto the same [-1, 1]
    tau = np.linspace(fd.tau[0], fd.tau[-1], int(n))
    drift = model.drift_basis(fd.tau, fd.drift_degree, at=tau)
    # NumPy columns: a figure needs no JAX trace
    x = np.concatenate([model.M1.columns(np.asarray(ls.theta), tau, xp=np), drift], axis=1)
    return fd.t0 + tau, x @ np.asarray(ls.beta)


def _versions() -> dict[str, str]:
    out = {}
    for pkg in ("numpy", "scipy", "jax", "optimistix", "emcee", "arviz"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "missing"
    return out
