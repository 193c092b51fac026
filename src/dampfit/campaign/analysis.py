r"""Joint analysis of several free-decay recordings of one damper: :func:`analyze_campaign`.

Stages
------
1. **Per test** (each recording on its own, as :func:`dampfit.pipeline.analyze` does it):
   preparation (window, band, axis: :func:`dampfit.signal.prepare.prepare`), the baselines'
   initial decay rate, least squares (:func:`dampfit.inference.least_squares.least_squares`),
   the single-recording refusals (no free decay; noise-free), the noise calibration r_i
   (:func:`dampfit.inference.noise.estimate`), and the Laplace expansion of the tempered
   profiled likelihood ℓ_i (eqs. C1, C2 of :mod:`dampfit.campaign.model`).
2. **Refusals** before any sampling (:mod:`dampfit.campaign.checks`).
3. **Hyper-posterior** of φ (eqs. C3–C5) sampled with emcee (differential-evolution moves,
   see :func:`_ensemble`, and the stopping rule of
   :func:`dampfit.inference.posterior.run_adaptive`: ≥ 50 autocorrelation times, R-hat < 1.01,
   bulk ESS ≥ ``min_ess``, or ``max_steps``), once for each frequency model (M₁: τ_ω free;
   M₀: τ_ω = 0, the tests share one frequency law); their posterior probabilities come from
   the Savage–Dickey ratio (C7) and the result is their mixture (:func:`_sample`).
4. **Per-test values and the exact likelihood**: for every draw of φ, each test's
   ψ_i = (ln p_i, ln ω_n,i) is drawn from its Gaussian conditional, and the joint draw gets
   the importance weight

       w = Π_i exp[ℓ_i(θ_i) − ℓ_i(θ̂_i) − (ℓ̃_i(ψ_i) − ℓ̃_i(ψ̂_i))],                     (C6)

   the ratio of the exact tempered likelihood (C1) to its Laplace form (C2) (everything else
   in the joint density is common to both, so (C6) is exact); each walker's draws are
   resampled by w (systematic resampling). The importance ESS fraction is reported; below
   :data:`MIN_IMPORTANCE_FRACTION` the result is flagged not converged.
5. **Quantities** per draw (:func:`dampfit.physics.quantities` from p and ω_n): the population damper from
   the location parameters (mass mode: c = 2·m·e^{μ_p} [N·s/m], k = m·e^{2μ_ω} [N/m] with m
   drawn normal(m, sd) truncated at 0 as in :func:`dampfit.inference.posterior.mass_draws`;
   added-mass mode: c, k, m₀ directly, p = c/(2m₀), ω_n² = k/m₀ for the bare system), the
   **predictive** damper of a new test (ln p_new = μ_p + τ_p·z, ln ω_new = μ_ω + τ_ω·z'), each
   test's **pooled** values from its ψ_i (mass m, or m₀ + Δm_i), and each test's **own**
   values from its Laplace expansion alone (mass m, or the posterior m₀ + Δm_i).
6. **Checks** (:mod:`dampfit.campaign.checks`): spread consistent with zero, outliers,
   amplitude explains the scatter, and a one-sentence verdict.

The summary's schema is ``summary.json`` of kind "campaign" (schema_version 1).
"""

from __future__ import annotations

import copy
import json
import os
import time
import warnings as _warnings
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from dampfit.files.atomic import atomic_write, atomic_write_text
from dampfit import physics
from dampfit._arviz import arviz
from dampfit._json import jsonable
from dampfit._progress import progress_bar
from dampfit._meta import __version__
from dampfit.errors import DampfitError, InputError
from dampfit.result.views import ResultViews

__all__ = ["CampaignAnalysis", "TestFit", "analyze_campaign", "SUMMARY_KEYS",
           "MIN_IMPORTANCE_FRACTION"]

#: Top-level keys of :meth:`CampaignAnalysis.summary` (schema_version 1, kind "campaign").
SUMMARY_KEYS = ("schema_version", "kind", "dampfit_version", "design", "parameters", "mass",
                "population", "tests", "checks", "added_mass", "diagnostics", "warnings")
#: Least importance ESS of (C6) as a fraction of the draws [1] for a converged result.
MIN_IMPORTANCE_FRACTION = 0.1
#: emcee walkers over the 4–5 hyper-parameters.
N_WALKERS = 64
#: Draws [1] of each test's own (Laplace) estimate.
OWN_DRAWS = 4000
#: Population quantities reported under "parameters" and their units.
POPULATION_UNITS = {"c": "N s/m", "k": "N/m", "zeta": "1", "f_n": "Hz", "p": "1/s",
                    "c_crit": "N s/m", "m0": "kg"}


# ----------------------------------------------------------------------------- results
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

    @property
    def name(self) -> str:
        path = self.recording.path
        return os.path.basename(str(path)) if path else f"recording {self.index + 1}"

    def samples(self):
        """:class:`dampfit.model.profile.Samples` of the padded fit data (inside x64)."""
        from dampfit.model.profile import Samples

        return Samples.from_padded(self.fit_data.padded)


@dataclass(frozen=True)
class CampaignSampling:
    """The joint posterior (arviz InferenceData) and the sampler's facts."""

    idata: Any
    converged: bool
    n_steps: int
    burn_in: int
    thin: int
    autocorr_time: np.ndarray
    acceptance: float
    importance_ess_fraction: float
    diagnostics: dict[str, dict[str, float]]
    warnings: tuple[str, ...] = ()
    seconds: float = float("nan")
    #: posterior probability [1] that the tests share one frequency law (τ_ω = 0), eq. (C7)
    p_shared_frequency: float = float("nan")
    #: ln B₀₁ [1] of (C7) with the exact-likelihood correction
    log_bayes_factor_shared: float = float("nan")


@dataclass
class CampaignAnalysis(ResultViews):
    """Everything :func:`analyze_campaign` computed; :meth:`summary` is its plain-data view.

    Loaded back from a result folder (:func:`dampfit.load`), ``summary()`` is the stored
    summary.json, ``posterior`` is read from posterior.nc, and ``tests`` is empty."""

    tests: list = field(default_factory=list)
    sampling: Any = None
    warnings: list[str] = field(default_factory=list)
    folder: Path | None = None
    _loaded: Any = field(default=None, repr=False, compare=False)
    mass: float | None = None
    mass_sd: float = 0.0
    added_mass: np.ndarray | None = None
    added_mass_sd: float = 0.0
    seed: int = 0
    options: dict[str, Any] = field(default_factory=dict)
    date: str = field(default_factory=lambda: datetime.now(timezone.utc).isoformat(timespec="seconds"))
    _summary: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)

    @classmethod
    def from_loaded(cls, loaded) -> "CampaignAnalysis":
        """The campaign of a result folder read by :func:`dampfit.result.folder.open_result`
        (what :func:`dampfit.load` returns for it): its summary as stored, the joint posterior
        read from posterior.nc on first use; the per-test analyses are not stored (``tests``
        is empty)."""
        d = loaded.summary
        diag = d.get("diagnostics") if isinstance(d.get("diagnostics"), dict) else {}
        warns = [w for items in (diag.get("warnings"), d.get("warnings"))
                 if isinstance(items, list) for w in items if isinstance(w, str)]
        return cls(tests=[], sampling=None, warnings=list(dict.fromkeys(warns)),
                   folder=loaded.folder, _loaded=loaded)

    @property
    def model(self) -> str:
        """"hierarchical" (known or no mass) or "added-mass"."""
        return "added-mass" if self.added_mass is not None else "hierarchical"

    # posterior (variables named as in the summary), converged: result.views.ResultViews
    def _live_converged(self) -> bool:
        """The hyper-posterior met its stopping rule and the importance weights are healthy."""
        return bool(self.sampling.converged)

    def draws(self, name: str) -> np.ndarray:
        """All posterior draws of one quantity (per-test ones: (draws, tests))."""
        x = np.asarray(self.posterior.posterior[name])
        return x.reshape((-1,) + x.shape[2:])

    def signals(self) -> list[dict[str, np.ndarray]]:
        """Each test's measured and modelled signals on its analysis window, in the order of
        ``tests``: the arrays and scalars of :meth:`dampfit.analysis.Analysis.signals` (``t``
        [s], ``accel``, ``accel_model`` [m/s²], ``displacement``, ``displacement_model`` [m]
        — the measured displacement is NaN: a campaign keeps no envelope-pipeline baseline —
        ``fs`` [Hz], ``p`` [1/s], ``omega_d`` [rad/s], ``t0`` [s]) from the test's own least
        squares. A campaign loaded from its folder (:func:`dampfit.load`) has none: the folder
        stores no signals.npz; that raises a :class:`~dampfit.errors.DampfitError`."""
        if self._loaded is not None:
            from dampfit.errors import shown

            raise DampfitError(f"signals() is not available: this campaign was loaded from "
                               f"{shown(self.folder)}, which stores summary.json and "
                               "posterior.nc only (no per-test signals); run "
                               "dampfit.analyze([rec1, rec2, …]) on the recordings for them")
        from dampfit.stages import window_signals

        return [window_signals(t.prepared, t.fit_data, t.least_squares) for t in self.tests]

    def summary(self) -> dict[str, Any]:
        """The JSON-safe summary (kind "campaign", schema_version 1), a fresh copy; computed
        once and cached (of a loaded result: the summary.json read)."""
        if self._summary is None:
            if self._loaded is not None:
                self._summary = self._loaded.summary
            else:
                self._summary = _summarise(self)
        return copy.deepcopy(self._summary)

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`summary` as JSON to ``path`` (atomically)."""
        return atomic_write_text(path, json.dumps(self.summary(), indent=2) + "\n")

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write the joint posterior (arviz InferenceData) to a NetCDF file."""
        return atomic_write(path, lambda tmp: self.posterior.to_netcdf(tmp, engine="h5netcdf"),
                            suffix=".nc")

    # --------------------------------------------------------------- renderings
    def report(self) -> str:
        """The text table the CLI prints (:func:`dampfit.output.text_campaign.text`)."""
        from dampfit.output import text_campaign

        return text_campaign.text(self.summary())

    def _repr_html_(self) -> str:
        """A short HTML table of the population's headline numbers, for notebooks."""
        from dampfit.output import text

        return text.html_table(self.summary())

    def save(self, folder, *, force: bool = False, figures: bool = True,
             report: bool = False) -> Path:
        """Write the campaign folder ``dampfit analyze FILE FILE…`` writes (summary.json,
        posterior.nc, ``forest.png`` and, of the added-mass design, ``added_mass.png``; with
        ``report`` report.html/.md) and return its path — written whole as
        :meth:`dampfit.analysis.Analysis.save` does. ``folder`` may be an open
        :class:`dampfit.files.folder.ResultFolder` (the CLI's): the files go into its staging folder
        and the caller publishes it."""
        from dampfit.files.folder import ResultFolder, result_folder

        if isinstance(folder, ResultFolder):
            self._write(folder, figures)
            return folder.stage
        inputs = [t.recording.path for t in self.tests if t.recording.path]
        with result_folder(folder, "campaign", force, inputs=inputs) as target:
            self._write(target, figures)
            out = target.publish()
        if report:
            from dampfit.output.report import write_report

            write_report(out)
        return out

    def _write(self, folder, figures: bool) -> None:
        stage = folder.stage
        with folder.writing():
            self.to_json(stage / "summary.json")
            self.to_netcdf(stage / "posterior.nc")
            if figures:
                from dampfit.output.figures.campaign import save_figures

                save_figures(self.summary(), stage)


# ----------------------------------------------------------------------------- the job
def analyze_campaign(recordings: Sequence, mass: float | None = None,
                     mass_sd: float | None = None, *, added_mass: Sequence[float] | None = None,
                     added_mass_sd: float = 0.0, seed: int = 0, progress: bool = False,
                     max_steps: int = 20000, min_ess: float = 1000.0,
                     window: tuple[float, float] | Sequence | None = None,
                     band: tuple[float, float] | Sequence | None = None,
                     axis: str = "auto") -> CampaignAnalysis:
    """Joint hierarchical analysis of several recordings of one damper.

    ``recordings`` (≥ 2 :class:`~dampfit.io.recording.Recording`). Either ``mass`` [kg] (sd
    ``mass_sd`` [kg]; both optional: without a mass only p, ζ, f_n are reported) — the
    "hierarchical" design — or ``added_mass`` [kg] per recording (0 for the bare system) with
    sd ``added_mass_sd`` [kg] — the "added-mass" design, which estimates m₀ and k itself.
    ``window`` (start, end) [s] and ``band`` (low, high) [Hz] apply to every recording, or
    give one per recording (a list of pairs or None). ``seed`` makes the run reproducible;
    ``max_steps`` and ``min_ess`` bound the sampler. Bad inputs raise a one-line
    :class:`~dampfit.errors.InputError` before any sampling.
    """
    from dampfit.campaign import checks

    recs, m, sd, dm, dm_sd = checks.check_design(recordings, mass, mass_sd, added_mass,
                                                 added_mass_sd)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    windows = _per_test_option("window", window, len(recs))
    bands = _per_test_option("band", band, len(recs))
    tests = [_fit_test(i, r, axis, windows[i], bands[i], m, None if dm is None else dm[i])
             for i, r in enumerate(recs)]
    names = [t.name for t in tests]
    warns = checks.duplicate_recordings(recs)
    warns += [f"test {t.index + 1} ({t.name}): {w}" for t in tests for w in t.warnings]
    if dm is None:
        checks.check_same_system([t.prepared.f0 for t in tests], names)
    data, centre = _campaign_data(tests, dm, dm_sd)
    started = time.monotonic()
    sampling = _sample(tests, data, dm is not None, m, sd, dm, seed, progress, max_steps,
                       min_ess)
    sampling = _with_seconds(sampling, time.monotonic() - started)
    warns.extend(sampling.warnings)
    options = {"axis": axis, "window": _jsonable_option(window), "band": _jsonable_option(band),
               "max_steps": max_steps, "min_ess": min_ess, **_reading_options(recs)}
    return CampaignAnalysis(tests=tests, sampling=sampling, warnings=warns, mass=m,
                            mass_sd=sd, added_mass=dm, added_mass_sd=dm_sd, seed=int(seed),
                            options=options)


def _with_seconds(s: CampaignSampling, seconds: float) -> CampaignSampling:
    from dataclasses import replace

    return replace(s, seconds=float(seconds))


def _reading_options(recs) -> dict:
    """The recordings' reading options (``Recording.read_options``) for the provenance: as
    one set when every recording was read alike (as the CLI reads them), else per test."""
    opts = [dict(getattr(r, "read_options", None) or {}) for r in recs]
    if all(o == opts[0] for o in opts):
        return opts[0]
    return {"read_options_per_test": opts}


def _jsonable_option(x):
    if x is None:
        return None
    return [list(v) if isinstance(v, (list, tuple)) else v for v in x] if _is_per_test(x) else list(x)


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


def _fit_test(i: int, rec, axis, window, band, mass, dm) -> TestFit:
    """Stage 1 for recording ``i`` (as :func:`dampfit.pipeline.analyze`), every refusal
    prefixed with the test it concerns."""
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
    warns.extend(stages.unit_plausibility(rec, prep, mass))
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
    verdict = _damping_verdict(prep, fd, ls, nm, mass, warns)
    return TestFit(index=i, recording=rec, prepared=prep, fit_data=fd, least_squares=ls,
                   noise=nm, temper=temper, theta_hat=theta, cov_theta=cov, ll_max=ll_max,
                   psi_hat=psi, sigma_psi=sigma, amplitude_m=amp,
                   added_mass_kg=None if dm is None else float(dm), warnings=warns,
                   damping_verdict=verdict)


#: Damping-law verdicts that say one viscous c does not describe a test's decay
#: ("inconclusive" says nothing either way and is only reported per test).
INADEQUATE = ("amplitude-dependent", "misfit")


def _damping_verdict(prep, fd, ls, nm, mass, warns: list[str]) -> str | None:
    """This test's damping-law verdict (:func:`dampfit.damping.assess`, Laplace evidence only:
    no sampling), and a warning when one viscous c does not describe its decay: the hierarchy
    pools one decay rate per test, so within-test amplitude dependence (ζ falling with the
    amplitude, as in most real dampers) is averaged, not modelled."""
    from dampfit import damping

    try:
        res = damping.assess(prep, fd, ls, nm, mass, 0.0, posterior="laplace")
    except InputError as exc:
        warns.append(f"damping-law check not made: {exc}")
        return None
    verdict = res.verdict_name
    if verdict in INADEQUATE:
        warns.append(f"one viscous c does not describe this test's decay (damping-law check: "
                     f"{verdict}); its pooled c averages over its amplitudes — analyse the "
                     "file alone for ζ(amplitude) and the damping laws")
    return verdict


def _campaign_data(tests: list[TestFit], dm, dm_sd):
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


# ----------------------------------------------------------------------------- sampling
def _start(data, added: bool, rng, n_walkers: int) -> np.ndarray:
    """Walkers about the moment estimates: locations at the prior centres (± their spread
    over the tests), τ from the tests' scatter (a small positive value at least)."""
    psi = np.asarray(data.psi_hat)
    centre = np.asarray(data.centre)
    tau0 = np.maximum(np.std(psi, axis=0, ddof=1), [1e-3, 1e-4])
    loc_sd = np.maximum(tau0 / np.sqrt(psi.shape[0]), 1e-4)
    if added:
        loc_sd = np.array([loc_sd[0], loc_sd[1], 0.05])
    loc = centre[None] + rng.standard_normal((n_walkers, centre.size)) * loc_sd[None]
    ln_tau = np.log(tau0)[None] + 0.3 * rng.standard_normal((n_walkers, 2))
    return np.concatenate([loc, ln_tau], axis=1)


def _to_hyper(x: np.ndarray, data, shared: bool) -> np.ndarray:
    """φ rows (N, k) from sampler coordinates x (N, k or k − 1 under M₀ ``shared``) of
    (C8); ln τ_ω = −inf under M₀."""
    import jax
    import jax.numpy as jnp

    from dampfit.campaign import model

    x = np.asarray(x, dtype=float)
    if shared:
        x = np.concatenate([x, np.full((x.shape[0], 1), -np.inf)], axis=1)
    with jax.enable_x64(True):
        phi = jax.vmap(lambda row: model.to_hyper(row, data)[0])(jnp.asarray(x))
    out = np.array(phi)
    if shared:
        out[:, -1] = -np.inf
    return out


def _to_sampler(phi: np.ndarray, data, shared: bool) -> np.ndarray:
    """Sampler coordinates (C8) of φ rows (N, k); under M₀ (``shared``) without ln τ_ω,
    whatever φ's last entry (M₁'s walkers seed M₀)."""
    from dampfit.campaign import model

    phi = np.array(phi, dtype=float)
    if shared:
        phi[:, -1] = -np.inf
    x = model.from_hyper(phi, data)
    return x[:, :-1] if shared else x


def _laplace_start(target, data, candidates: np.ndarray, rng) -> np.ndarray:
    """Walkers (len(candidates), k) drawn from the Laplace approximation N(φ*, −H⁻¹) of the
    log posterior ``target`` (a batched model function of :mod:`dampfit.campaign.model`),
    φ* its mode found by a trust-region Newton search (exact JAX gradient and Hessian) from
    the best of ``candidates`` (walkers, k). If the search fails or the Hessian at its end is
    not negative definite, ``candidates`` themselves are returned."""
    import jax
    import jax.numpy as jnp
    from scipy import optimize

    lp = np.asarray(target(jnp.asarray(candidates), data))
    if not np.any(np.isfinite(lp)):
        return candidates
    x0 = candidates[int(np.nanargmax(np.where(np.isfinite(lp), lp, -np.inf)))]

    def neg(x):
        return -target(x[None], data)[0]

    value_grad = jax.jit(jax.value_and_grad(neg))
    hess = jax.jit(jax.hessian(neg))

    def fun(x):
        v, g = value_grad(jnp.asarray(x))
        return float(v), np.asarray(g, dtype=float)

    try:
        res = optimize.minimize(fun, x0, jac=True, hess=lambda x: np.asarray(hess(jnp.asarray(x))),
                                method="trust-exact", options={"maxiter": 200})
        h = np.asarray(hess(jnp.asarray(res.x)), dtype=float)
        chol = np.linalg.cholesky(np.linalg.inv(0.5 * (h + h.T)))
    except (ValueError, np.linalg.LinAlgError):
        return candidates
    if not (np.all(np.isfinite(res.x)) and np.isfinite(res.fun) and res.fun <= -np.max(lp)
            and np.all(np.isfinite(chol))):
        return candidates
    return res.x[None] + rng.standard_normal(candidates.shape) @ chol.T


@dataclass(frozen=True)
class _ModelRun:
    """One model's sampled, importance-resampled draws: φ (N, k) with ln τ_ω = −inf under M₀,
    ψ (N, n, 2), the chain layout, ln of the mean importance weight (C6) and the run facts."""

    phi: np.ndarray
    psi: np.ndarray
    n_draw: int
    n_walk: int
    log_mean_weight: float
    ess_fraction: float
    run: Any
    burn: int
    thin: int
    acceptance: float
    m1_draws: np.ndarray | None = None
    last: np.ndarray | None = None


def _run_model(tests, data, added, shared, rng, progress, max_steps, min_ess,
               start=None) -> _ModelRun:
    """Sample one model's hyper-posterior (M₀ ``shared``: τ_ω = 0; else M₁) from ``start``
    (walkers, k) or :func:`_start`, draw each test's ψ given φ and resample by the
    exact-likelihood weights (C6)."""
    import jax.numpy as jnp

    from dampfit.campaign import model
    from dampfit.inference import posterior

    ndim = len(model.hyper_names(added)) - (1 if shared else 0)
    target = model.sampler_log_posterior(shared)  # non-centred levels (C8)

    def log_prob(xs: np.ndarray) -> np.ndarray:  # inside jax.enable_x64(True)
        return np.asarray(target(jnp.asarray(xs, dtype=jnp.float64), data))

    sampler = _ensemble(ndim, log_prob, rng)
    if start is None:
        start = _to_sampler(_start(data, added, rng, sampler.nwalkers), data, shared)
    start = start[:, :ndim]
    bar = progress_bar(max_steps, "campaign posterior (emcee steps)", enabled=progress)
    try:
        run = posterior.run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps,
                                     bar=bar, x64=True)
    finally:
        bar.close()
    burn, thin = posterior.burn_thin(run.tau)
    chain = sampler.get_chain(discard=burn, thin=thin)  # (draw, walker, k), coordinates (C8)
    n_draw, n_walk, _ = chain.shape
    phi = _to_hyper(chain.reshape(-1, ndim), data, shared)  # with ln τ_ω = −inf under M₀
    psi = model.conditional(phi, data, rng)  # (N, n, 2)
    logw = _importance_log_weights(tests, psi, data)
    finite = logw[np.isfinite(logw)]
    log_mean = (float(finite.max() + np.log(np.sum(np.exp(finite - finite.max())) / logw.size))
                if finite.size else -np.inf)
    ess_frac, idx = _resample(logw, n_draw, n_walk, rng)
    return _ModelRun(phi=phi[idx], psi=psi[idx], n_draw=n_draw, n_walk=n_walk,
                     log_mean_weight=log_mean, ess_fraction=ess_frac, run=run, burn=burn,
                     thin=thin, acceptance=float(np.mean(sampler.acceptance_fraction)),
                     m1_draws=None if shared else phi,
                     last=_to_hyper(sampler.get_last_sample().coords, data, shared))


#: A model whose posterior probability is below this [1] need not have converged (its draws
#: are at most this fraction of the result).
NEGLIGIBLE_MODEL = 0.01


def _sample(tests, data, added, mass, mass_sd, dm, seed, progress, max_steps,
            min_ess) -> CampaignSampling:
    """Both frequency models (M₁: τ_ω free; M₀: τ_ω = 0, :mod:`dampfit.campaign.model`),
    their posterior probabilities by (C7) with the exact-likelihood correction, and the
    model-averaged draws: each (draw, walker) slot of the more probable model's layout holds
    a draw of the other model with that model's probability."""
    import jax

    from dampfit.campaign import model

    rng = np.random.default_rng(seed)
    names = model.hyper_names(added)
    with jax.enable_x64(True):
        m1 = _run_model(tests, data, added, False, rng, progress, max_steps, min_ess)
        # M₀ starts from its own Laplace approximation, found from M₁'s last walkers (ln τ_ω
        # dropped): M₀ can be far narrower than M₁ — with an exact bare mass, the bare test
        # pins ω₀ to its own 1e-5 — and a walker left 100 posterior sd out stays there under
        # the DE moves and spoils the importance weights (measured: importance ESS 0.006 %)
        m0 = _run_model(tests, data, added, True, rng, progress, max_steps, min_ess,
                        start=_laplace_start(model.sampler_log_posterior(True), data,
                                             _to_sampler(m1.last, data, True), rng))
        log_bf = model.log_bayes_factor_shared(m1.m1_draws, data, rng)
    log_bf += m0.log_mean_weight - m1.log_mean_weight
    prior_odds = np.log(model.P_SHARED_FREQUENCY / (1 - model.P_SHARED_FREQUENCY))
    p_shared = (float(1.0 / (1.0 + np.exp(-(log_bf + prior_odds))))
                if np.isfinite(log_bf) else 0.0)
    warns: list[str] = []
    converged = True
    for label, r, weight in (("scatter", m1, 1 - p_shared), ("shared-frequency", m0, p_shared)):
        if weight < NEGLIGIBLE_MODEL:
            continue
        if not r.run.converged:
            converged = False
            warns.append(f"campaign posterior ({label} model) NOT converged after "
                         f"{r.run.steps} steps: {r.run.reason}")
        if r.ess_fraction < MIN_IMPORTANCE_FRACTION:
            converged = False
            warns.append(f"the exact per-test likelihoods differ from their Laplace forms "
                         f"({label} model): importance ESS only {100 * r.ess_fraction:.1f} % "
                         "of the draws")
    base, other, p_other = (m0, m1, 1 - p_shared) if p_shared >= 0.5 else (m1, m0, p_shared)
    phi, psi = base.phi.copy(), base.psi.copy()
    swap = rng.random(phi.shape[0]) < p_other
    pick = rng.integers(other.phi.shape[0], size=int(swap.sum()))
    phi[swap], psi[swap] = other.phi[pick], other.psi[pick]
    idata = _to_idata(phi, psi, names, added, mass, mass_sd, dm, base.n_draw, base.n_walk, rng)
    idata.posterior.attrs["p_shared_frequency"] = p_shared
    diag = _diagnostics(idata)
    ess_frac = min(r.ess_fraction for r, w in ((m1, 1 - p_shared), (m0, p_shared))
                   if w >= NEGLIGIBLE_MODEL)
    return CampaignSampling(
        idata=idata, converged=converged, n_steps=m1.run.steps + m0.run.steps,
        burn_in=base.burn, thin=base.thin, autocorr_time=np.asarray(base.run.tau),
        acceptance=base.acceptance, importance_ess_fraction=float(ess_frac),
        diagnostics=diag, warnings=tuple(warns), p_shared_frequency=p_shared,
        log_bayes_factor_shared=float(log_bf))


def _ensemble(ndim: int, log_prob, rng):
    """emcee's vectorised ensemble over φ with differential-evolution moves (80 % DE, 20 % DE
    snooker), seeded from ``rng``. Not :func:`dampfit.inference.posterior.default_moves`: its
    KDE proposal costs ≈ 50 ms a step in 4–5 dimensions (measured: 2000 steps 114 s against
    4.5 s for DE at integrated autocorrelation ≈ 20–40 steps either way on a 5-test
    campaign). The log-probability is called directly (no emcee wrapper), as in
    :func:`dampfit.inference.posterior.ensemble`."""
    import emcee

    from dampfit.inference import posterior

    sampler = emcee.EnsembleSampler(N_WALKERS, ndim, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.8),
                                           (emcee.moves.DESnookerMove(), 0.2)])
    sampler.log_prob_fn = log_prob
    posterior.seed_sampler(sampler, rng)
    return sampler


def _importance_log_weights(tests, psi: np.ndarray, data) -> np.ndarray:
    """log w of (C6) per joint draw (N,)."""
    import jax

    from dampfit.campaign import model

    approx = model.gaussian_log_likelihood(psi, data)  # (N, n), 0 at ψ̂
    theta = model.to_decay(psi)
    logw = np.zeros(psi.shape[0])
    with jax.enable_x64(True):
        for i, t in enumerate(tests):
            th = theta[:, i]
            ok = np.all(np.isfinite(th), axis=1)
            ll = np.full(th.shape[0], -np.inf)
            if ok.any():
                ll[ok] = model.exact_log_likelihood(th[ok], t.samples(), t.temper)
            logw += ll - t.ll_max - approx[:, i]
    return logw


def _resample(logw: np.ndarray, n_draw: int, n_walk: int, rng) -> tuple[float, np.ndarray]:
    """Importance ESS fraction [1] and indices (into the flat (draw, walker) order) of each
    walker's draws resampled systematically by its weights."""
    finite = np.isfinite(logw)
    if not finite.any():
        raise DampfitError("no posterior draw has a finite likelihood in every test")
    w = np.where(finite, np.exp(logw - logw[finite].max()), 0.0)
    frac = float(w.sum() ** 2 / np.sum(w**2) / w.size)
    w2 = w.reshape(n_draw, n_walk)
    idx = np.empty((n_draw, n_walk), dtype=int)
    for j in range(n_walk):
        wj = w2[:, j]
        if wj.sum() <= 0:  # this walker's draws all impossible: borrow the pooled weights
            wj = w2.sum(axis=1)
        cdf = np.cumsum(wj / wj.sum())
        u = (rng.random() + np.arange(n_draw)) / n_draw
        rows = np.minimum(np.searchsorted(cdf, u), n_draw - 1)
        idx[:, j] = rows * n_walk + j
    return frac, idx.ravel()


def _to_idata(phi, psi, names, added, mass, mass_sd, dm, n_draw, n_walk, rng):
    """arviz InferenceData of the hyper-parameters, population, predictive and per-test
    quantities (walkers as chains)."""
    from dampfit.inference import posterior

    n_total, n_tests = psi.shape[0], psi.shape[1]
    post: dict[str, np.ndarray] = {name: phi[:, j] for j, name in enumerate(names)}
    tau_p, tau_w = np.exp(phi[:, -2]), np.exp(phi[:, -1])
    post["tau_p"], post["tau_omega"] = tau_p, tau_w
    if added:
        p, wn, m0 = np.exp(phi[:, 0]), np.exp(phi[:, 1]), np.exp(phi[:, 2])
        m = m0
        post["m0"] = m0
        test_mass = m0[:, None] + np.asarray(dm)[None, :]
    else:
        m = posterior.mass_draws(mass, mass_sd, n_total, rng)
        p, wn = np.exp(phi[:, 0]), np.exp(phi[:, 1])
        if m is not None:
            post["mass"] = m
        test_mass = None if m is None else np.broadcast_to(m[:, None], (n_total, n_tests))
    q = physics.quantities(p, mass=m, omega_n=wn)
    for name in ("c", "k", "zeta", "f_n", "p", "c_crit"):
        if name in q:
            post[name] = q[name]
    z = rng.standard_normal((n_total, 2))
    p_new, wn_new = p * np.exp(tau_p * z[:, 0]), wn * np.exp(tau_w * z[:, 1])
    qn = physics.quantities(p_new, mass=m, omega_n=wn_new)
    for name in ("c", "k", "zeta", "f_n", "p"):
        if name in qn:
            post[f"predictive_{name}"] = qn[name]
    p_i, wn_i = np.exp(psi[..., 0]), np.exp(psi[..., 1])
    qi = physics.quantities(p_i, mass=test_mass, omega_n=wn_i)
    for name in ("c", "k", "zeta", "f_n", "p"):
        if name in qi:
            post[f"{name}_test"] = qi[name]

    def shape(v):  # flat (draw·walker) → arviz (chain = walker, draw, …)
        v = np.asarray(v, dtype=float).reshape((n_draw, n_walk) + np.shape(v)[1:])
        return np.swapaxes(v, 0, 1)

    import emcee

    dims = {k_: ["test"] for k_ in post if k_.endswith("_test")}
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        return arviz().from_dict(
            posterior={k_: shape(v) for k_, v in post.items()},
            coords={"test": np.arange(1, n_tests + 1)}, dims=dims,
            attrs={"sampler": f"emcee {emcee.__version__}", "n_walkers": n_walk,
                   "model": "added-mass" if added else "hierarchical",
                   "per_test_likelihood": "exact tempered profile (importance-resampled)"},
        )



def _diagnostics(idata) -> dict[str, dict[str, float]]:
    """R-hat and bulk ESS of every scalar quantity (walkers as chains)."""

    az = arviz()
    out = {}
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        scalars = [v for v, x in idata.posterior.data_vars.items()
                   if x.ndim == 2 and np.all(np.isfinite(x.values))]  # ln τ_ω = −inf under M₀
        rhat = az.rhat(idata.posterior[scalars])
        ess = az.ess(idata.posterior[scalars], method="bulk")
    for v in scalars:
        out[str(v)] = {"r_hat": float(rhat[v]), "ess_bulk": float(ess[v])}
    return out


# ----------------------------------------------------------------------------- summary
def _p_shared(a: CampaignAnalysis) -> float:
    """P(τ_ω = 0 | data) [1]: the tests share one frequency law (eq. C7)."""
    return float(a.sampling.p_shared_frequency)


def _summarise(a: CampaignAnalysis) -> dict[str, Any]:
    from dampfit.campaign import checks, model
    from dampfit.damping.quantities import summarise
    from dampfit.result.schema import SCHEMA_VERSION

    post = a.posterior.posterior
    diag = a.sampling.diagnostics
    added = a.added_mass is not None

    def par(name, unit):
        if name not in post:
            return None
        return summarise(np.asarray(post[name]), unit, diag.get(name, {}))

    def q3(x, unit=None):
        x = np.asarray(x, float).ravel()
        x = x[np.isfinite(x)]
        if x.size == 0:
            return {"q05": None, "q50": None, "q95": None, "sd": None,
                    **({"unit": unit} if unit else {})}
        out = {"q05": float(np.quantile(x, 0.05)), "q50": float(np.median(x)),
               "q95": float(np.quantile(x, 0.95)), "sd": float(x.std(ddof=1))}
        if unit:
            out["unit"] = unit
        return out

    params = {n: par(n, u) for n, u in POPULATION_UNITS.items() if n != "m0" or added}
    if added:
        m0 = np.asarray(post["m0"]).ravel()
        mass_entry = {"value": float(np.median(m0)), "sd": float(m0.std(ddof=1)), "unit": "kg"}
    else:
        mass_entry = {"value": a.mass, "sd": a.mass_sd if a.mass is not None else None,
                      "unit": "kg"}
    spread = {"p": {k_: v for k_, v in q3(post["tau_p"], "1").items() if k_ != "sd"},
              "omega": {**{k_: v for k_, v in q3(post["tau_omega"], "1").items() if k_ != "sd"},
                        "p_zero": _p_shared(a)}}
    predictive = {}
    for name in ("c", "zeta", "f_n", "k"):
        key = f"predictive_{name}"
        unit = POPULATION_UNITS[name]
        predictive[name] = ({k_: v for k_, v in q3(post[key], unit).items() if k_ != "sd"}
                            if key in post else None)

    # each test's own (Laplace) and pooled values
    rng = np.random.default_rng(a.seed + 1)
    n = len(a.tests)
    from dampfit.inference import posterior as post_mod

    if added:
        m0_draws = rng.choice(np.asarray(post["m0"]).ravel(), OWN_DRAWS)
    else:
        m_own = post_mod.mass_draws(a.mass, a.mass_sd, OWN_DRAWS, rng)
    tests_out, y_own, s_own, yw_own, sw_own = [], [], [], [], []
    m0_med = mass_entry["value"] if added else None
    for t in a.tests:
        z = rng.multivariate_normal(t.psi_hat, t.sigma_psi, OWN_DRAWS)
        p, wn = np.exp(z[:, 0]), np.exp(z[:, 1])
        mass_i = (m0_draws + t.added_mass_kg) if added else m_own
        q = physics.quantities(p, mass=mass_i, omega_n=wn)
        own = {name: (q3(q[name]) if name in q else None) for name in ("c", "zeta", "f_n", "p")}
        pooled = {}
        for name in ("c", "zeta", "f_n", "p"):
            key = f"{name}_test"
            pooled[name] = (q3(np.asarray(post[key])[..., t.index]) if key in post else None)
        rec, prep = t.recording, t.prepared
        tests_out.append({
            "index": t.index + 1,
            "input": {"path": os.path.abspath(rec.path) if rec.path else rec.path,
                      "sha256": rec.sha256, "n_samples": rec.n_samples,
                      "sample_rate_hz": prep.fs, "duration_s": rec.duration},
            "window": {"start_s": prep.window[0], "end_s": prep.window[1]},
            "band": {"low_hz": prep.band[0], "high_hz": prep.band[1]},
            "dominant_frequency_hz": prep.f0,
            "added_mass_kg": t.added_mass_kg,
            "amplitude_m": t.amplitude_m,
            "noise_psd_ratio": t.noise.psd_ratio,
            "damping_verdict": t.damping_verdict,
            "own": own, "pooled": pooled, "outlier": False})
        # the verdicts' y: own ln p (ln c in added-mass mode, at the posterior m0); an added
        # mass known to ± sd [kg] (the bare system's 0 exactly) moves ln M_i by sd/M_i: ln c
        # by as much, the bare system's ln ω_n by half (model eq. C4)
        dm_sd = a.added_mass_sd if added and t.added_mass_kg > 0 else 0.0
        rel = dm_sd / (m0_med + t.added_mass_kg) if added else 0.0
        y = t.psi_hat[0] + (np.log(2 * (m0_med + t.added_mass_kg)) if added else 0.0)
        y_own.append(y)
        s_own.append(np.sqrt(t.sigma_psi[0, 0] + rel**2))
        # frequencies: own ln ω_n (of the bare system in added-mass mode)
        yw_own.append(t.psi_hat[1] + (0.5 * np.log1p(t.added_mass_kg / m0_med) if added else 0.0))
        sw_own.append(np.sqrt(t.sigma_psi[1, 1] + (0.5 * rel) ** 2))
    y_own, s_own = np.array(y_own), np.array(s_own)
    yw_own, sw_own = np.array(yw_own), np.array(sw_own)
    _, p_het = checks.heterogeneity(y_own, s_own)
    consistent = bool(p_het >= checks.ALPHA)
    _, p_het_w = checks.heterogeneity(yw_own, sw_own)
    spread_w = checks.spread(yw_own, sw_own)
    freq_off = bool(p_het_w < checks.ALPHA and spread_w > checks.FREQUENCY_RELEVANT)
    tau_p = np.asarray(post["tau_p"]).ravel()
    ratio = float(np.median(tau_p) / np.median(s_own))
    outliers = checks.loo_outliers(y_own, s_own, model.TAU_P_SCALE)
    for i in outliers:
        tests_out[i]["outlier"] = True
    amps = [t.amplitude_m for t in a.tests]
    amplitude = checks.amplitude_regression(y_own, s_own, amps)
    amplitude_w = checks.amplitude_regression(yw_own, sw_own, amps)
    amplitude["frequency"] = amplitude_w
    names = [t.name for t in a.tests]
    verdict, text = checks.verdict(consistent, freq_off, outliers, amplitude, amplitude_w,
                                   ratio, names)
    # within-test amplitude dependence (each test's damping-law check): the between-test
    # verdict alone would let tests that agree with each other but are each not one viscous
    # decay pass as "consistent" without a word; the verdict name stays the between-test one
    within = [t.index + 1 for t in a.tests if t.damping_verdict in INADEQUATE]
    if within:
        kinds = sorted({t.damping_verdict for t in a.tests if t.damping_verdict in INADEQUATE})
        text += (f"; within the tests, one viscous c is not adequate (test "
                 f"{', '.join(map(str, within))}: {', '.join(kinds)}), so the population c is "
                 "an average over the tested amplitudes, valid near them only")

    added_section = None
    if added:
        k = np.asarray(post["k"]).ravel()
        m0 = np.asarray(post["m0"]).ravel()
        points = []
        for t in a.tests:
            w2 = float(np.exp(2 * t.psi_hat[1]))
            points.append({"added_mass_kg": t.added_mass_kg, "omega_n2": w2,
                           "omega_n2_sd": float(2 * w2 * np.sqrt(t.sigma_psi[1, 1]))})
        added_section = {"m0": params["m0"], "k": params["k"], "points": points,
                         "line": {"intercept": float(np.median(m0 / k)),
                                  "slope": float(np.median(1.0 / k)),
                                  "unit_intercept": "s^2", "unit_slope": "s^2/kg"}}
    s = a.sampling
    reported = [diag[v] for v in ("c", "k", "zeta", "f_n", "p", "m0", "tau_p", "tau_omega")
                if v in diag]
    max_rhat = max((d["r_hat"] for d in reported if np.isfinite(d["r_hat"])), default=np.nan)
    min_ess = min((d["ess_bulk"] for d in reported if np.isfinite(d["ess_bulk"])),
                  default=np.nan)
    return jsonable({
        "schema_version": SCHEMA_VERSION,
        "kind": "campaign",
        "dampfit_version": __version__,
        "design": {"n_tests": n, "model": a.model,
                   "mass": ({"value": a.mass, "sd": a.mass_sd, "unit": "kg"}
                            if a.mass is not None else None),
                   "added_mass": ({"values": [float(x) for x in a.added_mass],
                                   "sd": a.added_mass_sd, "unit": "kg"} if added else None),
                   "priors": {"tau_p": f"half-normal, scale {model.TAU_P_SCALE}",
                              "tau_omega": f"0 with probability {model.P_SHARED_FREQUENCY}, "
                                           f"else half-normal, scale {model.TAU_OMEGA_SCALE}",
                              "locations": f"normal, sd {model.LOCATION_SD} about the "
                                           "least-squares values (log scale)"}},
        "parameters": params,
        "mass": mass_entry,
        "population": {"spread": spread, "predictive": predictive,
                       "spread_consistent_with_zero": bool(consistent and not freq_off)},
        "tests": tests_out,
        "checks": {"verdict": verdict, "text": text, "tau_over_within": ratio,
                   "heterogeneity_p_value": p_het,
                   "frequency_heterogeneity_p_value": p_het_w,
                   "frequency_spread": spread_w, "frequency_disagrees": freq_off,
                   "outliers": [i + 1 for i in outliers],
                   "amplitude": amplitude,
                   "within_test_inadequate": within},
        "added_mass": added_section,
        "diagnostics": {"converged": a.converged, "max_r_hat": max_rhat,
                        "min_ess_bulk": min_ess, "n_steps": s.n_steps, "burn_in": s.burn_in,
                        "thin": s.thin, "acceptance_fraction": s.acceptance,
                        "importance_ess_fraction": s.importance_ess_fraction,
                        "log_bayes_factor_shared_frequency": s.log_bayes_factor_shared,
                        "seconds": s.seconds, "warnings": list(s.warnings)},
        "warnings": list(a.warnings),
        "provenance": {"seed": a.seed, "options": a.options, "date": a.date},
    })
