r"""Refusals of unusable campaigns and the verdicts of a campaign analysis (NumPy/SciPy).

Refusals (one-line :class:`~dampfit.errors.InputError`, raised before any sampling)
-----------------------------------------------------------------------------------
* fewer than 2 recordings, or an entry that is not a :class:`~dampfit.io.recording.Recording`;
* ``mass`` together with ``added_mass`` (the added-mass method estimates the effective mass
  m₀ itself); an added-mass count different from the number of recordings; a negative or
  non-finite added mass or sd;
* files of different systems: without added masses, dominant frequencies f₀ [Hz] more than
  :data:`MAX_FREQUENCY_RATIO` − 1 = 30 % apart;
* a test with no free decay (the single-recording refusals, naming the test);
* an added-mass design that cannot identify m₀: one distinct Δm; frequencies that do not fall
  as ω² = k/(m₀ + Δm) (line 1/ω² = (m₀ + Δm)/k with non-positive slope or intercept); or a
  spread of Δm whose predicted change of ln ω_n, ½·ln((m₀ + Δm_max)/(m₀ + Δm_min)), is below
  :data:`MIN_FREQUENCY_CHANGE_SD` = 3 standard deviations of a test's ln ω_n (its own
  uncertainty combined with the added-mass sd's effect ½·s_Δm/(m₀ + Δm)).

A warning, not a refusal (:func:`duplicate_recordings`): byte-identical recordings (same
SHA-256) given as different tests.

Verdicts (on the tests' own estimates y_i = ln p̂_i with sds s_i, or ln ĉ_i in added-mass mode)
-----------------------------------------------------------------------------------------------
* **spread consistent with zero** — Cochran's heterogeneity statistic
  Q = Σ (y_i − ȳ_w)²/s_i², ȳ_w the inverse-variance mean, is χ²(n − 1) when the tests share
  one value; consistent when P(χ² ≥ Q) ≥ :data:`ALPHA` = 0.01.
* **outliers** — leave-one-out: the posterior of (μ, τ) from the other tests (the Gaussian
  marginal y_j ~ N(μ, τ² + s_j²), flat μ, half-normal τ as in :mod:`dampfit.campaign.model`,
  on a grid) gives the predictive distribution of test i's own estimate,
  N(μ, τ² + s_i²) mixed over the grid; test i is an outlier when y_i lies outside its
  99 % interval.
* **amplitude explains the scatter** — the weighted regression y_i = a + b·ln A_i + ε_i,
  ε_i ~ N(0, s_i² + τ_r²), A_i [m] the test's initial displacement amplitude, τ_r the residual
  spread (maximum likelihood): b [1] with its 90 % interval (Student t, n − 2 degrees of
  freedom) and the two-sided P of b = 0; "explains" when P < :data:`ALPHA` (the level of the
  other claims: with the 90 % interval's 10 %, 3.3 % of simulated campaigns of tests that
  merely scatter, their amplitudes differing by chance — windows starting at different
  times — were called amplitude-dependent; now 0.5 %, tests/recovery/test_campaign.py) and the
  residuals are consistent with no
  spread (Cochran's Q of the residuals with n − 2 degrees of freedom, P ≥ 0.01) or their
  spread τ_r is at most :data:`EXPLAINED_SPREAD` = ⅓ of the spread about the mean (the
  amplitude accounts for ≥ 89 % of the between-test variance: a smooth but not log-linear
  dependence, as a pendulum's period). Needs ≥ 3 tests and amplitudes spanning ≥ 10 %
  (ln A range ≥ 0.1).
* **frequencies** — the same Cochran test on ln ω̂_n,i (in added-mass mode on the bare-system
  values ln ω̂_n,i + ½·ln(1 + Δm_i/m₀)); a spread counts as disagreement only when it is also
  relevant, a between-test sd above :data:`FREQUENCY_RELEVANT` = 0.5 %, and the amplitude
  must explain it too for the verdict "amplitude-dependent".
"""

from __future__ import annotations

import os
from typing import Any, Sequence

import numpy as np
from scipy import optimize, stats

from dampfit import physics
from dampfit.errors import InputError
from dampfit.errors import shown

#: Largest ratio of the tests' dominant frequencies [1] of one system without added masses.
MAX_FREQUENCY_RATIO = 1.3
#: Predicted change of ln ω_n across the added masses must exceed this many sds of a test's
#: ln ω_n for m₀ to be identified.
MIN_FREQUENCY_CHANGE_SD = 3.0
#: Damping-law verdicts that say one viscous c does not describe a test's decay
#: ("inconclusive" says nothing either way and is only reported per test).
INADEQUATE = ("amplitude-dependent", "misfit")
#: Significance level of the heterogeneity tests [1].
ALPHA = 0.01
#: The amplitude "explains" a spread when the residual spread about the regression line is at
#: most this fraction of the spread about the mean (≥ 89 % of the between-test variance).
EXPLAINED_SPREAD = 1.0 / 3.0
#: Between-test relative sd of ω_n [1] above which a significant frequency spread counts as a
#: disagreement (smaller ones — temperature, remounting — do not matter for the damper).
FREQUENCY_RELEVANT = 0.005
#: Level of the leave-one-out predictive interval for outliers [1].
OUTLIER_LEVEL = 0.99


def check_design(recordings: Any, mass, mass_sd, added_mass, added_mass_sd):
    """Validate the campaign's inputs. Returns (recordings list, the checked
    :class:`~dampfit.physics.Mass` [kg] (no value under the added-mass method), Δm array [kg]
    | None, s_Δm [kg])."""
    from dampfit.io.recording import Recording

    recs = list(recordings) if isinstance(recordings, (list, tuple)) else None
    if recs is None or len(recs) < 2:
        raise InputError("a campaign needs at least 2 recordings of the same system; "
                         "analyse a single file on its own")
    for i, r in enumerate(recs):
        if not isinstance(r, Recording):
            raise InputError(f"campaign entry {i + 1} is not a Recording "
                             f"({type(r).__name__}); use dampfit.read(path) first")
    if added_mass is None:
        if added_mass_sd not in (None, 0, 0.0):
            raise InputError("--added-mass-sd was given without --added-mass")
        return recs, physics.Mass(mass, mass_sd), None, 0.0
    if mass is not None or mass_sd not in (None, 0, 0.0):
        raise InputError("--mass cannot be combined with --added-mass: the added-mass method "
                         "estimates the effective mass m0 itself")
    if isinstance(added_mass, (str, bytes)) or not hasattr(added_mass, "__len__"):
        raise InputError(f"--added-mass needs one mass [kg] per recording, got {added_mass!r}")
    if len(added_mass) != len(recs):
        raise InputError(f"--added-mass gives {len(added_mass)} mass(es) for {len(recs)} "
                         "recordings; give one per recording (0 for the bare system)")
    dm = np.array([physics.as_float(x) for x in added_mass])
    if not np.all(np.isfinite(dm)) or np.any(dm < 0):
        raise InputError(f"added masses must be finite numbers ≥ 0 kg, got {list(added_mass)!r}")
    dm_sd = physics.as_float(0.0 if added_mass_sd is None else added_mass_sd)
    if not (np.isfinite(dm_sd) and dm_sd >= 0):
        raise InputError(f"--added-mass-sd must be ≥ 0 kg, got {added_mass_sd!r}")
    if np.unique(np.round(dm, 12)).size < 2:
        raise InputError("the added-mass method needs at least 2 different added masses "
                         f"(all recordings have {dm[0]:g} kg): m0 cannot be identified")
    return recs, physics.Mass(), dm, dm_sd


def duplicate_recordings(recordings: Sequence[Any]) -> list[str]:
    """One warning per group of byte-identical recordings: the same SHA-256 of the file (of
    the time and acceleration arrays for a recording not read from a file). The same release
    given twice is one test, not two: the between-test spread and the predictive interval
    would come out too narrow. Each warning names the tests and files and the digest."""
    import hashlib

    groups: dict[str, list[int]] = {}
    for i, rec in enumerate(recordings):
        digest = rec.sha256 if isinstance(rec.sha256, str) and rec.sha256 else \
            hashlib.sha256(np.ascontiguousarray(rec.time).tobytes()
                           + np.ascontiguousarray(rec.accel).tobytes()).hexdigest()
        groups.setdefault(digest, []).append(i)
    out = []
    for digest, idx in groups.items():
        if len(idx) < 2:
            continue
        named = " and ".join(
            f"test {i + 1} ({shown(os.path.basename(str(recordings[i].path)), 80)})"
            if recordings[i].path else f"test {i + 1}" for i in idx)
        out.append(f"{named} are byte-identical (same SHA-256 {digest[:16]}…): the same "
                   "recording given more than once is not several independent tests; the "
                   "between-test spread and the predictive interval are too narrow — give each "
                   "release once")
    return out


def check_same_system(f0: Sequence[float], names: Sequence[str]) -> None:
    """Refuse tests whose dominant frequencies [Hz] differ by more than 30 % (no added mass)."""
    f0 = np.asarray(f0, dtype=float)
    lo, hi = int(np.argmin(f0)), int(np.argmax(f0))
    if f0[hi] > MAX_FREQUENCY_RATIO * f0[lo]:
        raise InputError(
            f"the recordings are not of one system: {names[lo]} oscillates at {f0[lo]:.4g} Hz "
            f"and {names[hi]} at {f0[hi]:.4g} Hz (more than {100 * (MAX_FREQUENCY_RATIO - 1):.0f}"
            " % apart); analyse them separately, or give --added-mass if masses were added")


def check_added_mass_design(psi_hat: np.ndarray, sigma: np.ndarray, dm: np.ndarray,
                            dm_sd: float | np.ndarray) -> tuple[float, float, float]:
    """Refuse designs that cannot identify m₀ (module docstring); return least-squares
    starting values (ln p₀, ln ω₀, ln m₀) of :mod:`dampfit.campaign.model` from the line 1/ω_n² = (m₀ + Δm)/k and c = 2·M·p."""
    w2 = np.exp(2 * psi_hat[:, 1])
    slope, intercept = np.polyfit(dm, 1.0 / w2, 1)
    if not (slope > 0 and intercept > 0):
        raise InputError(
            "the added-mass design does not identify m0: the frequencies do not fall as "
            "ω² = k/(m0 + Δm) with the added masses (masses too close, or mislabelled?)")
    k, m0 = 1.0 / slope, intercept / slope
    change = 0.5 * np.log((m0 + dm.max()) / (m0 + dm.min()))
    sd = np.sqrt(np.max(sigma[:, 1, 1] + (0.5 * dm_sd / (m0 + dm)) ** 2))
    if change < MIN_FREQUENCY_CHANGE_SD * sd:
        raise InputError(
            f"the added masses are too close to identify m0: they change the frequency by "
            f"{100 * change:.2g} %, less than {MIN_FREQUENCY_CHANGE_SD:g}× the tests' frequency "
            f"uncertainty ({100 * sd:.2g} %); add masses that differ more")
    ln_p0 = float(np.mean(psi_hat[:, 0] + np.log1p(dm / m0)))
    return ln_p0, float(0.5 * np.log(k / m0)), float(np.log(m0))


# ----------------------------------------------------------------------------- verdicts
def heterogeneity(y: np.ndarray, s: np.ndarray, dof: int | None = None) -> tuple[float, float]:
    """Cochran's Q [1] of estimates ``y`` with sds ``s`` about their inverse-variance mean, and
    P(χ²(dof) ≥ Q) (dof = n − 1 by default)."""
    y, s = np.asarray(y, float), np.asarray(s, float)
    w = 1.0 / s**2
    mean = np.sum(w * y) / np.sum(w)
    q = float(np.sum(w * (y - mean) ** 2))
    dof = y.size - 1 if dof is None else dof
    return q, float(stats.chi2.sf(q, max(dof, 1)))


def _grid_posterior(y, s, tau_scale, n_mu=161, n_tau=120):
    """Posterior weights on a (μ, τ) grid of y_j ~ N(μ, τ² + s_j²), flat μ, half-normal τ."""
    spread = max(np.ptp(y), 6 * np.max(s), 1e-12)
    mu = np.linspace(y.min() - spread, y.max() + spread, n_mu)
    tau = np.linspace(0.0, max(4 * tau_scale, 3 * np.ptp(y) + 3 * np.max(s)), n_tau)
    var = tau[None, :, None] ** 2 + s[None, None, :] ** 2
    ll = -0.5 * np.sum((y[None, None, :] - mu[:, None, None]) ** 2 / var + np.log(var), -1)
    ll = ll - 0.5 * (tau[None, :] / tau_scale) ** 2
    w = np.exp(ll - ll.max())
    return mu, tau, w / w.sum()


def loo_outliers(y: np.ndarray, s: np.ndarray, tau_scale: float,
                 level: float = OUTLIER_LEVEL) -> list[int]:
    """Indices (0-based) of tests whose estimate lies outside the leave-one-out predictive
    interval at ``level`` (module docstring). Needs ≥ 3 tests (else none)."""
    y, s = np.asarray(y, float), np.asarray(s, float)
    if y.size < 3:
        return []
    out = []
    for i in range(y.size):
        keep = np.arange(y.size) != i
        mu, tau, w = _grid_posterior(y[keep], s[keep], tau_scale)
        sd = np.sqrt(tau[None, :] ** 2 + s[i] ** 2)
        cdf = float(np.sum(w * stats.norm.cdf((y[i] - mu[:, None]) / sd)))
        tail = (1.0 - level) / 2
        if cdf < tail or cdf > 1 - tail:
            out.append(i)
    return out


def _ml_fit(y: np.ndarray, s: np.ndarray, x: np.ndarray | None):
    """Weighted fit of y on [1] or [1, x] with y_i ~ N(·, s_i² + τ²), τ by maximum likelihood
    (0 when the data prefer none): (coefficients, their covariance, τ, residuals, weights)."""
    cols = [np.ones_like(y)] + ([] if x is None else [x])
    design = np.stack(cols, axis=1)

    def fit(tau):
        w = 1.0 / (s**2 + tau**2)
        xtw = design.T * w
        cov = np.linalg.inv(xtw @ design)
        coef = cov @ (xtw @ y)
        return coef, cov, y - design @ coef, w

    def nll(tau):
        _, _, r, w = fit(tau)
        return 0.5 * np.sum(r**2 * w - np.log(w))

    best = optimize.minimize_scalar(lambda u: nll(np.exp(u)), method="bounded",
                                    bounds=(np.log(1e-3 * np.min(s)), np.log(10.0 + np.ptp(y))))
    tau = float(np.exp(best.x)) if best.fun < nll(0.0) else 0.0
    coef, cov, r, w = fit(tau)
    return coef, cov, tau, r, w


def spread(y: np.ndarray, s: np.ndarray) -> float:
    """Maximum-likelihood between-test sd τ [units of y] of y_i ~ N(μ, s_i² + τ²)."""
    return _ml_fit(np.asarray(y, float), np.asarray(s, float), None)[2]


def amplitude_regression(y: np.ndarray, s: np.ndarray, amplitude: np.ndarray) -> dict[str, Any]:
    """Slope of y on ln amplitude with its 90 % interval and whether it explains the scatter
    (module docstring). Slope and interval None when the design cannot tell."""
    y, s = np.asarray(y, float), np.asarray(s, float)
    x = np.log(np.asarray(amplitude, float))
    none = {"slope": None, "q05": None, "q95": None, "explains_scatter": False}
    if y.size < 3 or not np.all(np.isfinite(x)) or np.ptp(x) < 0.1:
        return none
    coef, cov, tau_r, r, w = _ml_fit(y, s, x)
    tau_0 = spread(y, s)
    dof = y.size - 2
    # sd of the slope from the weighted fit with the fitted spread, inflated by the reduced
    # chi² when > 1 (Student t with n − 2 degrees of freedom)
    chi2 = float(np.sum(w * r**2))
    se = float(np.sqrt(max(1.0, chi2 / dof) * cov[1, 1]))
    b = float(coef[1])
    tq = stats.t.ppf(0.95, dof)
    q05, q95 = b - tq * se, b + tq * se
    p_slope = float(2.0 * stats.t.sf(abs(b) / se, dof)) if se > 0 else 0.0
    _, p_res = heterogeneity(r, s, dof=dof)  # residual spread about the line, no τ
    explains = p_slope < ALPHA and (p_res >= ALPHA or tau_r <= EXPLAINED_SPREAD * tau_0)
    return {"slope": b, "q05": float(q05), "q95": float(q95), "p_slope_zero": p_slope,
            "explains_scatter": bool(explains), "spread": tau_0, "residual_spread": tau_r}


def verdict(damping_consistent: bool, frequency_disagrees: bool, outliers: Sequence[int],
            amplitude: dict[str, Any], amplitude_frequency: dict[str, Any],
            tau_over_within: float, names: Sequence[str]) -> tuple[str, str]:
    """(verdict, one sentence): "amplitude-dependent", "outlier", "consistent" or "scatter".

    The tests disagree when their decay rates do (Cochran) or their frequencies do by a
    relevant amount (:data:`FREQUENCY_RELEVANT`); "amplitude-dependent" when the amplitude
    explains every quantity that disagrees."""
    damping_off = not damping_consistent
    if (damping_off or frequency_disagrees) and \
            (not damping_off or amplitude.get("explains_scatter")) and \
            (not frequency_disagrees or amplitude_frequency.get("explains_scatter")):
        parts = []
        if damping_off:
            parts.append(f"the decay rate scales as amplitude^{amplitude['slope']:.2g}")
        if frequency_disagrees:
            parts.append("the frequency as amplitude^"
                         f"{amplitude_frequency['slope']:.2g}")
        return ("amplitude-dependent",
                "the tests disagree beyond their own uncertainty, but the release amplitude "
                f"explains it: {' and '.join(parts)} (a nonlinear damper or spring; see the "
                "damping-law assessment of each test)")
    if len(names) < 3:  # amplitude_regression needs a residual degree of freedom
        clause = ("two tests cannot show an amplitude trend (a slope against the release "
                  "amplitude needs at least 3 tests)")
    elif amplitude.get("slope") is None:
        clause = "the release amplitudes are too alike to tell whether the amplitude matters"
    else:
        clause = ("no effect of the release amplitude is resolved over the tested amplitudes"
                  if not (damping_off or frequency_disagrees)
                  else "the release amplitude does not explain it")
    if outliers:
        which = ", ".join(f"test {i + 1} ({names[i]})" for i in outliers)
        return ("outlier",
                f"{which} lies outside the 99 % interval the other tests predict; check that "
                f"recording (mounting, release, window) before pooling it; {clause}")
    if not (damping_off or frequency_disagrees):
        return ("consistent",
                "the tests agree within their own uncertainty: the between-test spread is "
                f"consistent with zero; {clause}")
    what = (f"by {tau_over_within:.1f}× their own uncertainty in the decay rate"
            if damping_off else "in frequency beyond their own uncertainty")
    why = ("beyond what the amplitude explains" if amplitude.get("slope") is not None
           else f"and {clause}")
    return ("scatter",
            f"the tests disagree {what}, {why}: carry the predictive interval, not one test's")
