r"""The entry point: :func:`assess` — is one viscous c enough, and if not, which damper?

Pipeline, after the viscous least-squares fit and noise model of :func:`dampfit.analyze`:

1. least squares of every law (:mod:`~dampfit.inference.law_fit`, the variable projection of
   :mod:`~dampfit.model.profile`), with J = 0…3 frequency-drift phase terms (K4) chosen by BIC
   on the viscous law and shared;
2. one Whittle factor r from the best law's residuals (:mod:`~dampfit.damping.evidence`);
3. evidence of every law, the comparison table and the verdict (amplitude dependence,
   preferred law);
4. posterior draws of every law (emcee for the chosen law by default, the nested Laplace
   approximation for the others; :data:`POSTERIORS`);
5. ζ(amplitude) from windowed viscous fits (:mod:`~dampfit.damping.curve`);
6. model checks, the adequacy verdict (:func:`~dampfit.damping.checks.adequacy`: adequate,
   amplitude-dependent, misfit or inconclusive) and its one warning
   (:mod:`~dampfit.damping.checks`).

What to report as *the* c when the chosen law is not viscous: the energy-equivalent viscous
c_eq at the reference amplitude a_ref [m] (the user's ``amplitude``, else the geometric mean of
the largest and smallest recorded displacement amplitudes), with the amplitude stated —
:meth:`DampingAssessment.c_report`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from dampfit.inference import noise
from dampfit._json import jsonable
from dampfit.errors import InputError
from dampfit.damping import checks, curve, quantities
from dampfit.damping import evidence
from dampfit._options import SamplerSettings
from dampfit.physics import Mass
from dampfit.model import laws
from dampfit.damping.summary import summary as _summary
from dampfit.inference import law_fit
from dampfit.inference import law_sampler as dsample


class Settings(NamedTuple):
    """How :func:`assess` runs: ``posterior`` (:data:`POSTERIORS`), ``window_cycles``
    [cycles] of the ζ(amplitude) windows (None: automatic), ``sampler`` the
    :class:`~dampfit._options.SamplerSettings` of the emcee runs (None: default ones) and
    ``budget`` their step budget (:class:`dampfit.inference.law_sampler.Budget`, None: none)."""

    posterior: str = "chosen"
    window_cycles: float | None = None
    sampler: SamplerSettings | None = None
    budget: Any = None


def choices() -> tuple[str, ...]:
    """Accepted values of ``model``: ``auto`` and the registered laws' names."""
    return ("auto",) + laws.names()

#: Accepted values of ``posterior``: emcee for every law, for the chosen law only, or none.
POSTERIORS = ("chosen", "chosen-nonviscous", "emcee", "laplace")


@dataclass
class DampingAssessment:
    """Everything :func:`assess` computed; :meth:`summary` is its plain-data view."""

    fits: dict[str, law_fit.ModelFit]
    posteriors: dict[str, dsample.ModelPosterior]
    table: list[dict]
    verdict: dict
    requested: str
    chosen: str
    psd_ratio: float
    psd_ratios: dict[str, float]
    whiteness: dict[str, dict]
    windows: list[curve.Window]
    slope: dict | None
    window_cycles: float
    amplitudes: dict[str, float]  # ref, start, end [m]
    mass: float | None
    quantities: dict[str, dict[str, np.ndarray]]
    t0: float
    pipeline_psd_ratio: float | None = None  # r of the viscous pipeline's NoiseModel
    warnings: list[str] = field(default_factory=list)
    adequacy: dict | None = None  # checks.adequacy(...) plus "fit_checks", "frequency_trend"
    warning: str | None = None  # the verdict's warning (also in warnings)
    decay: dict | None = None  # law_fit.decay_test of the viscous fit: is a decay measured?
    mass_draws: dict[str, np.ndarray | None] = field(default_factory=dict)  # [kg] per law
    mass_sd: float = 0.0  # [kg]
    span_s: float | None = None  # [s] τ₁ − τ₀ of the fitted window (the phase terms' scale)

    @property
    def preferred(self) -> str:
        """The law the evidence prefers (viscous unless amplitude dependence is detected)."""
        return self.verdict["preferred"]

    @property
    def amplitude_dependent(self) -> bool:
        return bool(self.verdict["amplitude_dependent"])

    def c_report(self) -> dict[str, Any]:
        """What to report as c: the chosen law's c (viscous) or c_eq at a_ref [N·s/m]."""
        q = self.quantities[self.chosen]
        name = "c" if self.chosen == "viscous" else "c_eq_ref"
        zname = "zeta" if self.chosen == "viscous" else "zeta_eq_ref"
        return {
            "model": self.chosen,
            "c": quantities.summarise(q[name], "N s/m") if name in q else None,
            "zeta": quantities.summarise(q[zname], "1") if zname in q else None,
            "amplitude_m": self.amplitudes["ref"],
            "recorded_amplitude_range_m": list(self.recorded_amplitudes),
            "extrapolated": self.extrapolated,
            "note": ("viscous c" if self.chosen == "viscous" else
                     f"energy-equivalent viscous c of the {self.chosen} law at "
                     f"{self.amplitudes['ref']:.3g} m displacement amplitude"
                     + (" (extrapolated: outside the recorded amplitudes)"
                        if self.extrapolated else "")),
        }

    def c_missing(self) -> str | None:
        """Why the chosen non-viscous law's c_eq means nothing, or None: the verdict is
        "misfit" (no law describes the waveform), or the law's posterior did not converge or
        is ill-conditioned (its interval is not a posterior)."""
        if self.chosen == "viscous":
            return None
        if self.verdict_name == "misfit":
            return (f"the verdict is misfit: no damping law describes this waveform, so the "
                    f"{self.chosen} law's equivalent viscous c means nothing")
        post = self.posteriors.get(self.chosen)
        if post is None or not len(post.a0):
            return f"the {self.chosen} law has no posterior draws"
        if post.ill_conditioned:
            return (f"the {self.chosen} law is ill-conditioned "
                    f"({post.ill_conditioned_reason or 'see the warnings'}): its equivalent "
                    "viscous c has no trustworthy interval")
        if not post.converged:
            return (f"the {self.chosen} law's posterior did not converge "
                    f"({post.stop_reason or 'see the warnings'}): its equivalent viscous c "
                    "has no trustworthy interval")
        return None

    @property
    def recorded_amplitudes(self) -> tuple[float, float]:
        """Smallest and largest displacement amplitude [m] the window recorded (the windows'
        amplitudes and the chosen law's start and end)."""
        amps = [w.amplitude for w in self.windows if w.amplitude > 0]
        amps += [a for a in (self.amplitudes["start"], self.amplitudes["end"])
                 if np.isfinite(a) and a > 0]
        return (float(min(amps)), float(max(amps))) if amps else (float("nan"),) * 2

    @property
    def extrapolated(self) -> bool:
        """Is the reference amplitude outside :attr:`recorded_amplitudes`?"""
        lo, hi = self.recorded_amplitudes
        ref = self.amplitudes["ref"]
        return bool(np.isfinite(lo) and not lo * (1 - 1e-9) <= ref <= hi * (1 + 1e-9))

    @property
    def verdict_name(self) -> str:
        """The adequacy verdict: adequate, amplitude-dependent, misfit or inconclusive."""
        return self.adequacy["verdict"] if self.adequacy else "inconclusive"

    def summary(self) -> dict[str, Any]:
        """JSON-safe dict with keys ``model_checks``, ``damping_models``, ``amplitude_curve``.

        ``model_checks`` carries the adequacy ``verdict`` and ``verdict_reasons``;
        ``single_viscous_c_adequate`` is true exactly when the verdict is "adequate", and
        ``warning`` is the verdict's warning.
        """
        out = _summary(self)
        mc = out["model_checks"]
        ad = self.adequacy or {}
        mc["verdict"] = self.verdict_name
        mc["verdict_reasons"] = list(ad.get("reasons", []))
        mc["verdict_law"] = ad.get("law")
        mc["single_viscous_c_adequate"] = self.verdict_name == "adequate"
        mc["warning"] = self.warning
        amp = mc["amplitude_dependence"]
        amp["evidence_detected"] = amp["detected"]
        amp["detected"] = self.verdict_name == "amplitude-dependent"
        amp["criterion"] = ("adequacy verdict (dampfit.damping.checks.adequacy): windowed slope "
                            "decisive or " + amp["criterion"] + "; evidence_detected is the "
                            "evidence criterion alone")
        mc["adequacy"] = jsonable({k: ad.get(k) for k in ("criteria", "fit_checks",
                                                          "frequency_trend", "laws")})
        mc["decay"] = jsonable(self.decay) if self.decay is not None else None
        return out


def _check_inputs(model: str, amplitude, posterior: str, window_cycles) -> None:
    if model not in choices():
        raise InputError(f"unknown damping model {model!r}; choose one of "
                         f"{', '.join(choices())}")
    if amplitude is not None and not (np.isfinite(amplitude) and amplitude > 0):
        raise InputError("the reference amplitude must be a positive displacement in m, "
                         f"got {amplitude!r}")
    if posterior not in POSTERIORS:
        raise InputError(f"posterior must be one of {', '.join(POSTERIORS)}, got {posterior!r}")
    if window_cycles is not None and not (np.isfinite(window_cycles) and window_cycles >= 2):
        raise InputError(f"amplitude windows must span at least 2 cycles, got {window_cycles!r}")


def assess(prep, fd, ls, noise_model, mass: Mass | float | None = None, *,
           model: str = "auto", amplitude: float | None = None,
           settings: Settings = Settings()) -> DampingAssessment:
    """Compare damping laws on a prepared recording (see the module docstring).

    ``prep`` :class:`~dampfit.signal.prepare.Prepared`, ``fd`` :class:`~dampfit.signal.prepare.FitData`,
    ``ls`` the viscous :class:`~dampfit.inference.least_squares.LeastSquaresResult` (start values; None: from the
    envelope), ``noise_model`` its :class:`~dampfit.inference.noise.NoiseModel` or None (its r is
    reported; the comparison re-measures r on the best law's residuals). ``mass`` the
    :class:`~dampfit.physics.Mass` (value and sd [kg], checked when it was made; a bare number
    [kg] is ``Mass(number)``); ``model`` one of :func:`choices` (``auto`` = the preferred law); ``amplitude`` [m]
    the reference displacement amplitude for c_eq; ``settings`` (:class:`Settings`): its
    ``posterior`` (:data:`POSTERIORS`):
    ``"chosen"`` = emcee for the chosen law and the Laplace approximation for the others,
    ``"chosen-nonviscous"`` the same except when the chosen law is viscous (whose emcee
    posterior :func:`dampfit.analyze` has already), ``"emcee"`` for all, ``"laplace"`` for
    none (fast; what the false-alarm study uses); ``window_cycles`` [cycles] of the
    ζ(amplitude) windows (automatic if None); ``sampler`` the
    :class:`~dampfit._options.SamplerSettings` of the emcee runs (default ones if None) and
    their ``budget``.
    """
    posterior, window_cycles, sampler, budget = settings
    _check_inputs(model, amplitude, posterior, window_cycles)
    checked = mass if isinstance(mass, Mass) else Mass(mass)
    mass, mass_sd = checked.value, checked.sd
    sampler = SamplerSettings() if sampler is None else sampler
    data = law_fit.Data.from_fit_data(fd)
    f0 = float(prep.f0)
    p_start, w_start = (ls.p, ls.omega_d) if ls is not None else _initial_guess(prep)
    r_white = noise.white_ratio(fd.lowpass_sos, fd.fs_filter, fd.fs, f0)

    def noise_of(mf):
        return noise.estimate(mf.residuals, fd.fs, f0, 0.25 * f0, data.q + mf.k,
                               white=r_white)

    def ratio(mf):  # floored at r_white: the likelihood is never sharper than for white noise
        return noise_of(mf).psd_ratio

    fits, best, p_start, warns = _fit_laws(fd, data, p_start, w_start, ratio)
    r = ratio(best)
    fits = {m: law_fit.laplace(mf, data, 1.0 / r, prep.band) for m, mf in fits.items()}
    table, verdict = evidence.compare(fits, data, f0)
    decay = law_fit.decay_test(fits["viscous"], data, 1.0 / r)
    chosen = verdict["preferred"] if model == "auto" else model
    posts = _posteriors(fits, data, prep.band, chosen, posterior, sampler=sampler,
                        budget=budget, warns=warns)

    # ζ(amplitude) windows on the drift-free signal of the best law
    ref = fits[verdict["preferred"]] if fits[verdict["preferred"]].converged else best
    n_cyc = float((fd.tau[-1] - fd.tau[0]) * f0)
    cyc = window_cycles or curve.auto_cycles(n_cyc, fd.fs / f0)
    wins = curve.windows(fd.tau, fd.y - fd.drift @ ref.beta[2:], ref.omega, p_start, cycles=cyc,
                         psd_ratio=r, gain=ref.gain)

    amps = _amplitudes(fits[chosen], wins, fd, amplitude)
    rng = np.random.default_rng(sampler.seed + 101)
    qts, mds = {}, {}
    for m, post in posts.items():
        mds[m] = quantities.mass_draws(mass, mass_sd, len(post.a0), rng)
        qts[m] = quantities.draws(m, post.theta, post.a0, mds[m], amps) if len(post.a0) else {}

    ratios = {m: float(ratio(mf)) for m, mf in fits.items() if mf.converged}
    best_nl = verdict.get("best_nonlinear")
    white = {m: checks.envelope_whiteness(fd.tau, fits[m].residuals, fits[m].omega)
             for m in dict.fromkeys(("viscous", verdict["preferred"], chosen, best_nl))
             if m is not None}
    out = DampingAssessment(
        fits=fits, posteriors=posts, table=table, verdict=verdict, requested=model,
        chosen=chosen, psd_ratio=float(r), psd_ratios=ratios, whiteness=white, windows=wins,
        slope=curve.slope(wins), window_cycles=float(cyc), amplitudes=amps, mass=mass,
        quantities=qts, t0=float(fd.t0), warnings=warns,
        pipeline_psd_ratio=(float(noise_model.psd_ratio) if noise_model is not None else None),
        decay=decay, mass_draws=mds, mass_sd=mass_sd, span_s=float(fd.tau[-1] - fd.tau[0]),
    )
    out.adequacy = _adequacy(out, prep, fd, data, n_cyc, noise_of, white_r=r_white, ls=ls)
    law = out.adequacy.get("law")
    if law and law != chosen and posterior != "laplace":  # the named law's own posterior
        _resample(out, law, data, prep.band, seed=sampler.seed + laws.names().index(law),
                  sampler=sampler, budget=budget)
    out.warning = checks.verdict_warning(out.adequacy, _warning(out, law) if law else None,
                                         has_mass=mass is not None)
    if out.warning:
        out.warnings.append(out.warning)
    out.warnings.extend(_request_warnings(out, model, amplitude))
    return out


def _resample(a: DampingAssessment, law: str, data, band, *, seed: int,
              sampler: SamplerSettings, budget) -> None:
    """emcee draws of ``law`` — the law the verdict names when it is not the chosen one (the
    windows carried the verdict), whose Laplace draws served the comparison — so the damper's
    coefficients come from the law's own posterior; its quantities are recomputed."""
    mf = a.fits[law]
    if not (mf.converged and mf.cov is not None and np.all(np.isfinite(mf.cov))):
        return
    post = dsample.sample_emcee(mf, data, band, seed=seed, min_ess=sampler.min_ess,
                                max_steps=sampler.max_steps, budget=budget,
                                progress=sampler.progress)
    if not len(post.a0):
        return
    a.posteriors[law] = post
    a.warnings.extend(post.warnings)
    rng = np.random.default_rng(seed + 101)
    a.mass_draws[law] = quantities.mass_draws(a.mass, a.mass_sd, len(post.a0), rng)
    a.quantities[law] = quantities.draws(law, post.theta, post.a0, a.mass_draws[law],
                                         a.amplitudes)


def _fit_laws(fd, data, p_start: float, w_start: float, ratio):
    """Least squares of every damping law, started from the viscous fit with drift:
    (fits by law, the one with the least residual sum of squares among the converged, the
    decay rate p [1/s] the others start from, warnings of the laws that did not converge)."""
    visc = _viscous_with_drift(fd, data, p_start, w_start, ratio)
    p_start, w_start = (visc.p0, visc.omega) if visc.converged else (p_start, w_start)
    phase0 = visc.theta[2:]
    fits = {"viscous": visc}
    fits.update({m: law_fit.fit_model(m, fd, data, p_start, w_start, phase0=phase0)
                 for m in laws.names()[1:]})
    warns = [f"{m} damping law: least squares did not converge ({mf.message})"
             for m, mf in fits.items() if not mf.converged]
    ok = [mf for mf in fits.values() if mf.converged] or [fits["viscous"]]
    return fits, min(ok, key=lambda mf: mf.rss), p_start, warns


def _posteriors(fits, data, band, chosen: str, posterior: str, *, sampler: SamplerSettings,
                budget, warns: list[str]):
    """Each law's posterior: emcee where ``posterior`` (:data:`POSTERIORS`) asks for it and
    the fit has a finite covariance, the Laplace approximation otherwise; their warnings are
    appended to ``warns``."""
    posts: dict[str, dsample.ModelPosterior] = {}
    for i, (m, mf) in enumerate(fits.items()):
        use_emcee = posterior == "emcee" or (posterior == "chosen" and m == chosen) or (
            posterior == "chosen-nonviscous" and m == chosen and m != "viscous")
        if use_emcee and mf.converged and np.all(np.isfinite(mf.cov)):
            posts[m] = dsample.sample_emcee(mf, data, band, seed=sampler.seed + i,
                                            min_ess=sampler.min_ess,
                                            max_steps=sampler.max_steps, budget=budget,
                                            progress=sampler.progress)
        else:
            posts[m] = dsample.sample_laplace(mf, data, seed=sampler.seed + i)
        warns.extend(posts[m].warnings)
    return posts


def _request_warnings(out: DampingAssessment, model: str, amplitude: float | None) -> list[str]:
    """Warnings about what the user asked for: a reference ``amplitude`` [m] outside the
    recorded ones (an extrapolation of a nonlinear law), a ``model`` the evidence does not
    prefer."""
    warns = []
    if amplitude is not None and out.chosen != "viscous" and out.extrapolated:
        lo, hi = out.recorded_amplitudes
        warns.append(
            f"--amplitude {amplitude:.3g} m is outside the recorded displacement amplitudes "
            f"{lo:.3g}–{hi:.3g} m: the {out.chosen} law's c_equivalent there is an extrapolation "
            "of the law beyond the data")
    preferred = out.verdict["preferred"]
    if model != "auto" and model != preferred:
        warns.append(
            f"the {model} damping law was requested, but the evidence prefers "
            f"{preferred} (P = {_weight(out.table, preferred):.2g})")
    return warns


def from_analysis(an, posterior: str = "chosen", **kw) -> DampingAssessment:
    """:func:`assess` on the stages of a :class:`dampfit.analysis.Analysis` (same mass, seed),
    with ``posterior`` (:class:`Settings`) and :func:`assess`'s ``model`` and ``amplitude``."""
    kw["settings"] = Settings(posterior, sampler=SamplerSettings(seed=an.seed))
    return assess(an.prepared, an.fit_data, an.least_squares, an.noise, Mass(an.mass, an.mass_sd),
                  **kw)


def _viscous_with_drift(fd, data, p_start, w_start, ratio) -> law_fit.ModelFit:
    """The viscous fit with J = 0…MAX_PHASE frequency-drift terms (K4), J chosen by BIC.

    The score is ℓ/r − ½·J·ln(n/r), with one r (that of the richest fit) for every J: the
    tempered likelihood and an effective sample size n/r. The chosen J is then shared by
    every law, so the laws are compared with the same nuisance model.
    """
    base = law_fit.fit_model("viscous", fd, data, p_start, w_start)
    if not base.converged:
        return base
    cands = [base] + [law_fit.fit_model("viscous", fd, data, base.p0, base.omega,
                                     phase0=np.zeros(j)) for j in range(1, laws.MAX_PHASE + 1)]
    cands = [c for c in cands if c.converged]
    r = ratio(min(cands, key=lambda c: c.rss))
    n_eff = max(data.n / r, 2.0)
    return max(cands, key=lambda c: c.loglik / r - 0.5 * (c.k - 2) * np.log(n_eff))


def _initial_guess(prep) -> tuple[float, float]:
    """Decay rate [1/s] from a log-linear fit of the band-passed envelope, and 2π·f₀ [rad/s]."""
    sel = prep.grid_in_window & (prep.envelope > 0)
    w = 2 * np.pi * prep.f0
    if sel.sum() < 4:
        return 1e-3 * w, w
    slope = np.polyfit(prep.grid[sel] - prep.window[0], np.log(prep.envelope[sel]), 1)[0]
    return (float(-slope) if slope < 0 else 1e-3 * w), w


def _weight(table, name) -> float:
    return next((r["weight"] for r in table if r["model"] == name), float("nan"))


def _amplitudes(mf: law_fit.ModelFit, wins, fd, amplitude) -> dict[str, float]:
    """Displacement amplitudes [m] at the window start and end and the reference one: the
    user's ``amplitude``, else the middle (geometric mean) of the recorded range — the
    windows' amplitudes with the start and end (:attr:`DampingAssessment.recorded_amplitudes`),
    the damper's design amplitude (:mod:`dampfit.damping.damper`)."""
    start = mf.a0
    e_end = float(laws.envelope(mf.model, mf.theta, np.array([fd.tau[-1] - fd.tau[0]]),
                                  xp=np)[0][..., 0])
    end = start * e_end
    measured = [w.amplitude for w in wins if w.amplitude > 0]
    if measured:  # the smallest amplitude a window measured, if the model decays below it
        end = max(end, min(measured))
    if not (np.isfinite(end) and end > 0):
        end = 0.5 * start
    rec = [a for a in measured + [start, end] if np.isfinite(a) and a > 0]
    middle = float(np.sqrt(min(rec) * max(rec))) if rec else float("nan")
    ref = float(amplitude) if amplitude is not None else middle
    return {"ref": ref, "start": float(start), "end": float(end)}


def _q50(q: dict, name: str) -> float:
    x = q.get(name)
    return float(np.nanmedian(x)) if x is not None and len(x) else float("nan")


def _fit_check(mf: law_fit.ModelFit, fd, data, noise_of, white_r: float, sigma_exp: float,
               lb: dict | None) -> dict:
    """Residual checks of one fit: Ljung–Box p at f₀ and :func:`dampfit.inference.noise.misfit_check`."""
    nm = noise_of(mf)
    osc = mf.fitted - data.drift @ mf.beta[2:]
    resid_rms = float(np.sqrt(np.mean(mf.residuals**2)))
    chk = noise.misfit_check(nm.psd_ratio_raw, white_r, resid_rms,
                              float(np.sqrt(np.mean(osc**2))), sigma_exp)
    return {"ljung_box_p": (lb or {}).get("p_value"), "r_raw": nm.psd_ratio_raw,
            "r_white": white_r, "r_excess": chk["r_excess"], "resid_rms": resid_rms,
            "resid_fraction": chk["resid_fraction"], "noise_excess": chk["noise_excess"],
            "sigma_expected": sigma_exp, "lag1": nm.lag1}


def _pipeline_check(ls, fd, f0: float, white_r: float, sigma_exp: float) -> dict | None:
    """The same checks on the viscous pipeline's least squares (constant frequency, no phase
    terms) — the fit whose c :func:`dampfit.analyze` reports under ``parameters``."""
    if ls is None or not hasattr(ls, "residuals") or np.size(ls.residuals) != fd.y.size:
        return None
    res = np.asarray(ls.residuals, float)
    nm = noise.estimate(res, fd.fs, f0, 0.25 * f0, len(ls.theta) + len(ls.beta), white=white_r)
    resid_rms = float(np.sqrt(np.mean(res**2)))
    sig = float(np.sqrt(max(ls.rss_drift - ls.rss, 0.0) / res.size))
    chk = noise.misfit_check(nm.psd_ratio_raw, white_r, resid_rms, sig, sigma_exp)
    lb = checks.envelope_whiteness(fd.tau, res, float(ls.omega_d))
    return {"ljung_box_p": lb.get("p_value"), "r_raw": nm.psd_ratio_raw, "r_white": white_r,
            "r_excess": chk["r_excess"], "resid_rms": resid_rms,
            "resid_fraction": chk["resid_fraction"], "noise_excess": chk["noise_excess"],
            "sigma_expected": sigma_exp, "lag1": nm.lag1}


def _adequacy(a: DampingAssessment, prep, fd, data, n_cyc: float, noise_of,
              white_r: float, ls=None) -> dict:
    """:func:`checks.adequacy` on this assessment, with the per-fit checks and the
    frequency trend it used (``fit_checks``, ``frequency_trend``)."""
    best_nl = a.verdict.get("best_nonlinear")
    ok = [mf for mf in a.fits.values() if mf.converged] or [a.fits["viscous"]]
    f0 = float(prep.f0)
    f_max = 0.9 * fd.fs / 2 if fd.lowpass_sos is None else min(0.8 * prep.band[1], 0.9 * fd.fs / 2)
    dens = noise.sensor_density(min(ok, key=lambda mf: mf.rss).residuals, fd.fs, f0, f_max)
    if not np.isfinite(dens):  # too short for the residual spectrum: the recording's own level
        dens = float(prep.noise_density)
    sigma_exp = noise.expected_sigma(dens, fd.fs, white_r)
    names = ["viscous"] + ([best_nl] if best_nl and a.fits[best_nl].converged else [])
    fc = {m: _fit_check(a.fits[m], fd, data, noise_of, white_r, sigma_exp, a.whiteness.get(m))
          for m in names if a.fits[m].converged}
    amps = [w.amplitude for w in a.windows if w.amplitude > 0]
    span = max(amps) / min(amps) if len(amps) >= 2 else 1.0
    freq = curve.frequency_trend(a.windows)
    pipe = _pipeline_check(ls, fd, float(prep.f0), white_r, sigma_exp)
    if pipe is not None:
        fc["viscous_pipeline"] = pipe
    best_model = names[-1] if names[-1] in fc else "viscous"
    usability = _law_usability(a, amps)
    q = a.quantities.get("power", {}).get("alpha")
    power = None
    if not usability.get("power", {}).get("issue") and q is not None and len(q):
        q05, q50, q95 = np.quantile(np.asarray(q) - 1.0, [0.05, 0.5, 0.95])
        power = {"q05": float(q05), "q50": float(q50), "q95": float(q95)}
    out = checks.adequacy(
        n_cycles=n_cyc, slope=a.slope, amplitude_span=span, freq=freq,
        laws=checks.LawEvidence(a.verdict["p_viscous"], best_nl, usability, power),
        fits=checks.FitChecks(fc.get("viscous"), fc.get(best_model), best_model, pipe),
        decay=a.decay)
    out["fit_checks"] = fc
    out["frequency_trend"] = freq
    out["laws"] = usability
    return out


def _law_usability(a: DampingAssessment, amps: list[float]) -> dict[str, dict]:
    """Per non-viscous law: its weight, why it cannot carry a verdict (not converged, shape on
    its prior bound, ill-conditioned: :func:`dampfit.inference.law_sampler.conditioning`) or
    None, and ζ(a_max)/ζ(a_min) [1] of its least-squares optimum over the windows' amplitudes."""
    out = {}
    for m, mf in a.fits.items():
        if m == "viscous":
            continue
        issue = None if mf.converged else f"least squares did not converge ({mf.message})"
        if issue is None:
            issue = dsample.conditioning(mf)
        post = a.posteriors.get(m)
        if issue is None and post is not None and post.ill_conditioned:
            issue = post.ill_conditioned_reason or "ill-conditioned"
        ratio = None
        if mf.converged and len(amps) >= 2 and mf.a0 > 0:
            rho = laws.local_rate(m, mf.theta, np.array([max(amps), min(amps)]) / mf.a0)
            ratio = float(rho[0] / rho[1]) if rho[1] > 0 and np.all(np.isfinite(rho)) else None
        out[m] = {"weight": _weight(a.table, m), "issue": issue, "zeta_ratio": ratio}
    return out


def _warning(a: DampingAssessment, law: str | None = None) -> str | None:
    """The amplitude-dependence warning for ``law`` (default: the preferred one); ζ from the
    first and last windows, else from the law."""
    m = law or a.preferred
    if m == "viscous":
        return None
    q = a.quantities.get(m, {})
    c_ref = _q50(q, "c_eq_ref") if a.mass is not None else None
    if len(a.windows) >= 4:
        first, last = a.windows[0], a.windows[-1]
        zeta_hi, zeta_lo, a_hi, a_lo = first.zeta, last.zeta, first.amplitude, last.amplitude
        source = "windowed fits"
    else:
        zeta_hi, zeta_lo = _q50(q, "zeta_eq_start"), _q50(q, "zeta_eq_end")
        a_hi, a_lo = a.amplitudes["start"], a.amplitudes["end"]
        source = f"{m} law"
    return checks.warning_text(m, a.verdict["p_viscous"], (zeta_hi, a_hi), (zeta_lo, a_lo),
                               c_ref, a.amplitudes["ref"], source)
