r"""The number of modes in one recording: Laplace evidence of each K and its rejection rules.

For K = 1 … K_max modes (:mod:`dampfit.model.modes`) fitted by
:func:`dampfit.inference.modes.fit_modes` — K = 1 from the matrix pencil's poles and the
spectrum peaks of the window (:mod:`dampfit.signal.subspace`), K + 1 from the K-mode optimum
plus one candidate mode (each pencil pole and each peak of the K-mode residual's spectrum
more than one resolution cell 1/T from the fitted modes) — the evidence decides.

Evidence
--------
With the amplitudes (A_i, B_i) uniform on the disc of radius a_max = 2·max|y⊥| [m/s²]
(V = π·a_max² per mode: no mode can have much more acceleration than the record shows; y⊥
is y with the drift projected out), a flat prior on the drift, a Jeffreys prior on σ, and the
likelihood tempered by the Whittle factor r (:mod:`dampfit.inference.noise`; L^{1/r}), the
linear parameters and σ integrate out exactly:

    ln p(y | θ, K) = (q/2)·ln(2πr) − ½·ln det X⊥ᵀX⊥ − K·ln V
                     + ln Γ(a/2) − (a/2)·ln(RSS(θ)/2r),     a = n/r − q,  q = 2K + d,      (MS2)

(constants common to every K dropped; d drift columns, n samples). The nonlinear θ are then
integrated by Laplace's method around the least-squares optimum θ̂ with the ordered prior
π_K of (MK4):

    ln Z_K = ln p(y | θ̂, K) + ln π_K(θ̂) + K·ln 2π − ½·ln det H,   H = a·J_rᵀJ_r/RSS,        (MS3)

J_r the Jacobian of the projected residual (Gauss–Newton; Golub & Pereyra 2003) — the same
Laplace machinery as the damping-law evidence (:mod:`dampfit.inference.law_fit`, L2), with
the amplitudes' prior made proper because here their number changes with K. The prior
volumes — (Δ_ω·Δ_p)^K/K! for the frequencies and rates, V^K for the amplitudes — are the
Occam factor every extra mode pays.

*Which r.* The Whittle factor r(f) is a property of the noise *at a frequency*: an
amplitude-dependent decay leaves misfit — a large r — at its own mode only, and tempering a
far, clean mode with it would hide that mode. The fits are nested (K from K − 1 plus one
mode), so the evidence is built as a chain of Bayes factors, each tempered at the frequency
f_new of the mode that step adds:

    ln Z_K = ln Z_1(r(f_1)) + Σ_{k=2}^{K} [ln Z_k(r(f_new,k)) − ln Z_{k−1}(r(f_new,k))],     (MS5)

r(f) measured on the residuals of the largest converged fit (which has absorbed every real
mode) over ±¼f and floored at its white-noise value (:func:`local_ratio`). A step starts from
the last converged K below (usually K − 1; if that one did not converge, the one before), and
the first converged fit starts the chain at the r of its strongest mode. With white noise
r ≡ 1 and (MS5) is (MS3). With equal prior probabilities for the admissible K,
P(K | y) = Z_K / Σ_K' Z_K'. Modes at 2…5× a stronger mode's frequency are flagged as possible
harmonics of a nonlinear oscillation (:func:`harmonics`).

Rejection
---------
A K is **rejected** (with the reason, :attr:`KResult.reason`; P(K) = 0) when its least
squares fails; a mode leaves the band; two modes lie within one resolution cell
(|f_i − f_j|·T < 1: not separable in this record — the number of modes is never overstated);
a mode has fewer than :data:`~dampfit.inference.modes.MIN_SAMPLES_PER_CYCLE` samples per
cycle; or a mode's amplitude is not distinguishable from the noise,

    z_i² = β_iᵀC_i⁻¹β_i < 2·ln(N_cells/α),   N_cells = (f_hi − f_lo)·T,                       (MS4)

C_i = s²·r·(X⊥ᵀX⊥)⁻¹ its conditional covariance — the level-α (:data:`AMPLITUDE_ALPHA`)
threshold of the largest of N_cells 2-dof χ² variables, i.e. of the best noise peak of the
band. The chosen K is the admissible one of largest P(K); every other K gets its reason
(:meth:`ModeSelection.reasons`). Only a recording with no admissible K at all, or a fixed K it
cannot support, raises :class:`~dampfit.errors.InputError`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import gammaln

from dampfit import physics
from dampfit._progress import stage_bar
from dampfit.errors import InputError
from dampfit.inference import noise as _noise
from dampfit.inference.modes import (
    DEFAULT_MAX_MODES, MIN_SAMPLES_PER_CYCLE, ModeFit, check_max_modes, fit_modes, modal_band,
    modal_fit_data, modal_prepared, support,
)
from dampfit.model import modes as mm
from dampfit.signal import subspace
from dampfit.signal.prepare import FitData, Prepared

#: Amplitude prior radius in units of the largest |y⊥| (MS2).
AMP_PRIOR_FACTOR = 2.0
#: False-alarm level of the amplitude check (MS4).
AMPLITUDE_ALPHA = 0.01
#: Candidate new modes tried per K.
MAX_CANDIDATES = 6
#: A mode within this relative distance of m × a stronger mode's frequency (m = 2…5) is
#: flagged as a possible harmonic.
HARMONIC_TOLERANCE = 0.02
#: A flagged component within this many resolution cells 1/T of the multiple [1] *is* a
#: harmonic, not a mode (a genuine mode lands that close to a multiple only by chance).
HARMONIC_CELLS = 1.0
#: A harmonic m·f of a decaying nonlinear oscillation decays at m·p or faster (its amplitude
#: goes as A^m or a higher power of the fundamental's amplitude A ∝ e^{−p t}); a component at
#: the multiple whose rate is below this share of m·p [1] decays too slowly to be one: it is a
#: mode of its own that happens to lie at the multiple (issue 34).
HARMONIC_DECAY = 0.5


#: Two-sided 90 % standard normal quantile (the 95 % point), for the Laplace intervals.
Z90 = 1.6448536269514722


@dataclass(frozen=True)
class Tried:
    """One K of the greedy fits: its ``fit``, or None and ``why`` it was not tried."""

    fit: ModeFit | None
    why: str = ""


@dataclass(frozen=True)
class KResult:
    """One K of the order selection: its ``fit``, ``ln_evidence`` (MS5; NaN if not computed),
    the amplitude significance ``z`` [1] of every mode (MS4, each at its own Whittle factor),
    the tempered Laplace covariance ``cov`` (2K, 2K) of θ, ``reason`` why it was rejected (""
    if admissible) and ``psd_ratio``, the r of its evidence step and ``cov``."""

    n_modes: int
    fit: ModeFit | None
    ln_evidence: float
    z: np.ndarray
    cov: np.ndarray
    reason: str = ""
    psd_ratio: float = float("nan")

    def laplace_intervals(self, z: float = Z90) -> list[dict]:
        r"""The K-mode least squares' own intervals, mode by mode in order of frequency: per
        mode ``p`` [1/s], ``f_n`` [Hz] and ``zeta`` [1] as (optimum, lower, upper), the normal
        interval ±``z``·sd in the logs (``z`` = 1.645: 90 %) from the tempered Laplace
        covariance ``cov`` of θ = (ln p_i, ln ω_d,i) (eq. MS3) by the delta method. With
        ζ = p/ω_n and ω_n² = p² + ω_d² (:func:`dampfit.physics.quantities`),

        .. math::  \frac{∂\ln ζ}{∂(\ln p, \ln ω_d)} = (1 − ζ^2, −(1 − ζ^2)),\quad
                   \frac{∂\ln f_n}{∂(\ln p, \ln ω_d)} = (ζ^2, 1 − ζ^2),\quad
                   \frac{∂\ln p}{∂(\ln p, \ln ω_d)} = (1, 0).

        The baseline beside the posterior in studies and in the calibration
        (``paper/modes_calibration.py``). Each mode also carries its optimum ``omega_d``
        [rad/s] (a float). Raises ValueError when this K has no fit."""
        if self.fit is None:
            raise ValueError(f"no {self.n_modes}-mode least-squares fit: {self.reason}")
        fit, cov = self.fit, np.asarray(self.cov, dtype=float)
        out = []
        for i in np.argsort(fit.omega_d):
            p, w = float(fit.p[i]), float(fit.omega_d[i])
            d = physics.quantities(p, w)
            z2 = float(d["zeta"]) ** 2
            block = cov[2 * i:2 * i + 2, 2 * i:2 * i + 2]
            mode: dict = {"omega_d": w}
            for q, grad in (("p", (1.0, 0.0)), ("f_n", (z2, 1.0 - z2)),
                            ("zeta", (1.0 - z2, -(1.0 - z2)))):
                g = np.asarray(grad)
                sd_ln = math.sqrt(max(float(g @ block @ g), 0.0))
                v = float(d[q])
                mode[q] = (v, v * math.exp(-z * sd_ln), v * math.exp(z * sd_ln))
            out.append(mode)
        return out


def amplitude_prior_radius(fd: FitData) -> float:
    """a_max = 2·max|y⊥| [m/s²] of (MS2): y with the drift projected out."""
    y = np.asarray(fd.y, dtype=float)
    q = fd.drift
    return float(AMP_PRIOR_FACTOR * np.max(np.abs(y - q @ (q.T @ y))))


def evidence(fit: ModeFit, n: int, *, temper: float, band: tuple[float, float],
             a_max: float) -> tuple[float, np.ndarray]:
    """ln Z_K of (MS3) [1] and the tempered Laplace covariance of θ for a converged ``fit``
    of ``n`` samples; ``temper`` = 1/r, ``band`` [Hz], ``a_max`` [m/s²]."""
    k, r = fit.n_modes, 1.0 / temper
    a = n / r - fit.q
    if not (fit.converged and a > 0 and fit.rss > 0):
        return float("nan"), np.full((2 * k, 2 * k), np.nan)
    lnp = (0.5 * fit.q * math.log(2 * math.pi * r) - 0.5 * fit.logdet
           - k * math.log(math.pi * a_max**2) + float(gammaln(a / 2))
           - 0.5 * a * math.log(fit.rss / (2 * r)))
    h = a * fit.jac.T @ fit.jac / fit.rss
    lw = np.log(2 * np.pi * np.asarray(band, dtype=float))
    lprior = float(mm.log_prior(fit.theta, lw[0], lw[1]))
    try:
        sign, logdet_h = np.linalg.slogdet(h)
        cov = np.linalg.inv(h)
    except np.linalg.LinAlgError:
        return float("nan"), np.full((2 * k, 2 * k), np.nan)
    if sign <= 0 or not np.isfinite(lprior):
        return float("nan"), cov
    return float(lnp + lprior + k * math.log(2 * math.pi) - 0.5 * logdet_h), cov


def amplitude_z(fit: ModeFit, n: int, temper) -> np.ndarray:
    """z_i = √(β_iᵀC_i⁻¹β_i) [1] of every mode, C_i = s²/temper_i·(X⊥ᵀX⊥)⁻¹ block,
    s² = RSS/(n − q): the amplitude in units of its own uncertainty (``temper`` one value or
    one per mode)."""
    tempers = np.broadcast_to(np.asarray(temper, dtype=float), (fit.n_modes,))
    s2 = fit.rss / max(n - fit.q, 1)
    out = np.zeros(fit.n_modes)
    for i in range(fit.n_modes):
        b = fit.beta[2 * i:2 * i + 2]
        c = s2 / tempers[i] * fit.minv[2 * i:2 * i + 2, 2 * i:2 * i + 2]
        try:
            out[i] = math.sqrt(max(float(b @ np.linalg.solve(c, b)), 0.0))
        except np.linalg.LinAlgError:
            out[i] = 0.0
    return out


def z_threshold(band: tuple[float, float], span: float) -> float:
    """z below which a mode is noise: √(2·ln(N_cells/α)), N_cells = (f_hi − f_lo)·T."""
    cells = max((band[1] - band[0]) * span, 1.0)
    return math.sqrt(2.0 * math.log(cells / AMPLITUDE_ALPHA))


def reject_reason(fit: ModeFit, z: np.ndarray, band, span: float, fs: float,
                   z_min: float) -> str:
    """Why a converged K-mode optimum is not admissible ("" if it is)."""
    f = fit.f_d
    out = [i for i in range(fit.n_modes) if not band[0] <= f[i] <= band[1]]
    if out:
        return f"mode at {f[out[0]]:.4g} Hz lies outside the band {band[0]:.4g}–{band[1]:.4g} Hz"
    d = np.diff(f)
    if d.size and d.min() * span < 1.0:
        i = int(np.argmin(d))
        return (f"modes at {f[i]:.4g} and {f[i + 1]:.4g} Hz lie within one resolution cell "
                f"(Δf·T = {d[i] * span:.2f} < 1): not separable as two modes in this record")
    if fs / f.max() < MIN_SAMPLES_PER_CYCLE:
        return (f"too few samples per cycle of the mode at {f.max():.4g} Hz "
                f"({fs / f.max():.2g} < {MIN_SAMPLES_PER_CYCLE:g})")
    weak = [i for i in range(fit.n_modes) if z[i] < z_min]
    if weak:
        i = weak[0]
        return (f"the mode at {f[i]:.4g} Hz is not distinguishable from the noise (amplitude "
                f"{z[i]:.2g} sd, needs {z_min:.2g} for this band and record)")
    return ""


# ----------------------------------------------------------------------------- selection
@dataclass(frozen=True)
class ModeSelection:
    """Order selection of one recording (module docstring).

    ``fit_data`` the modal fit samples, ``band`` [Hz] (MS1), ``span`` T [s]; ``results`` one
    :class:`KResult` per K = 1 … max_modes; ``probabilities`` P(K) [1] (0 for rejected or
    untried K); ``n_modes`` the chosen K; ``psd_ratio`` the r of the chosen K's evidence step
    (MS5) and ``psd_ratios`` the per-mode r (:func:`local_ratio`) of its modes; ``pencil`` the
    subspace estimate and ``peaks`` the spectrum peaks [(Hz, m/s²)] of the window; ``a_max``
    [m/s²] (MS2); ``warnings`` (an uncertain K, possible harmonics) and ``notes`` (how the
    modal window was set).
    """

    fit_data: FitData
    band: tuple[float, float]
    span: float
    results: tuple[KResult, ...]
    probabilities: np.ndarray
    n_modes: int
    psd_ratio: float
    psd_ratios: np.ndarray
    pencil: subspace.PencilResult | None
    peaks: tuple[tuple[float, float], ...]
    a_max: float
    warnings: tuple[str, ...] = field(default_factory=tuple)
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def chosen(self) -> KResult:
        """The :class:`KResult` of the chosen K."""
        return self.results[self.n_modes - 1]

    def reasons(self) -> dict[int, str]:
        """K → why it was not chosen (every K but the chosen one)."""
        best = self.chosen.ln_evidence
        out = {}
        for res in self.results:
            k = res.n_modes
            if k == self.n_modes:
                continue
            if res.reason:
                out[k] = res.reason
            else:
                out[k] = (f"P(K = {k}) = {self.probabilities[k - 1]:.2g}: ln Z lower by "
                          f"{best - res.ln_evidence:.3g} than K = {self.n_modes}")
        return out

    def summary(self) -> dict:
        """Plain-data description: ``n_modes``, ``band_hz``, ``psd_ratio`` and per K
        ``{"n_modes", "ln_evidence", "probability", "admissible", "reason", "f_d_hz",
        "amplitude_z"}``."""
        reasons = self.reasons()
        rows = []
        for res in self.results:
            fit = res.fit
            rows.append({
                "n_modes": res.n_modes,
                "ln_evidence": _num(res.ln_evidence),
                "probability": float(self.probabilities[res.n_modes - 1]),
                "admissible": not res.reason and fit is not None,
                "reason": reasons.get(res.n_modes, ""),
                "f_d_hz": [] if fit is None else [_num(v) for v in fit.f_d],
                "amplitude_z": [_num(v) for v in res.z],
            })
        return {"n_modes": self.n_modes, "band_hz": list(self.band), "window_s": self.span,
                "psd_ratio": float(self.psd_ratio),
                "psd_ratios": [float(v) for v in self.psd_ratios], "evidence": rows,
                "subspace_order_mdl": None if self.pencil is None else self.pencil.order_mdl,
                "subspace_order_floor": None if self.pencil is None else self.pencil.order_floor,
                "spectrum_peaks_hz": [float(f) for f, _ in self.peaks]}


def _num(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _zeta_guess(pencil) -> float:
    if pencil is None or not pencil.poles:
        return 0.01
    z = [q.p / math.hypot(q.p, q.omega_d) for q in pencil.poles if q.p > 0]
    return float(np.clip(np.median(z), 1e-3, 0.1)) if z else 0.01


def _candidates(fd: FitData, theta, resid, pencil, band, span: float, zeta: float):
    """New-mode candidates (ln p, ln ω) for K + 1 modes: pencil poles and residual-spectrum
    peaks more than one resolution cell from the modes of ``theta``."""
    have = mm.rates(theta)[1] / (2 * np.pi) if theta is not None else np.empty(0)
    tu = np.arange(fd.tau[0], fd.tau[-1], 1.0 / fd.fs)
    peaks = subspace.spectrum_peaks(np.interp(tu, fd.tau, resid), fd.fs, band, MAX_CANDIDATES)
    cands = [(q.p, q.omega_d) for q in (pencil.poles if pencil else ()) if q.p > 0]
    cands += [(zeta * 2 * np.pi * f, 2 * np.pi * f) for f, _ in peaks]
    out = []
    for p, w in cands:
        f = w / (2 * np.pi)
        if np.all(np.abs(have - f) * span >= 1.0) and all(
                abs(f - g) * span >= 1.0 for _, g in out):
            p = min(max(p, 1e-6 * w), 0.5 * mm.P_MAX * w)  # inside the prior's rates (MK3)
            out.append(((math.log(p), math.log(w)), f))
    return [c for c, _ in out]


def _starts(theta, cands) -> np.ndarray:
    """Start rows: the K-mode optimum plus one candidate each (the candidate last)."""
    base = [] if theta is None else list(np.asarray(theta, dtype=float))
    return np.array([base + list(c) for c in cands[:MAX_CANDIDATES]])


def local_ratio(resid: np.ndarray, fd: FitData, f: float, n_params: int) -> float:
    """Whittle factor r [1] of the residuals ``resid`` [m/s²] at ``f`` [Hz] (±¼f), floored at
    its white-noise value on this path (:func:`dampfit.inference.noise.estimate`)."""
    white = _noise.white_ratio(fd.lowpass_sos, fd.fs_filter, fd.fs, f)
    return float(_noise.estimate(resid, fd.fs, f, 0.25 * f, n_params, white=white).psd_ratio)


def psd_ratios(fit: ModeFit, fd: FitData) -> np.ndarray:
    """Per-mode Whittle factor r_i [1] of ``fit``'s own residuals (:func:`local_ratio`)."""
    return np.array([local_ratio(fit.residuals, fd, float(f), fit.q + 2 * fit.n_modes)
                     for f in fit.f_d])


def select(prep: Prepared, *, max_modes: int = DEFAULT_MAX_MODES,
           band: tuple[float, float] | None = None, n_modes: int | None = None) -> ModeSelection:
    """Fit K = 1 … ``max_modes`` modes to the window of ``prep`` and choose K by evidence
    (module docstring). ``band`` [Hz] overrides (MS1); ``n_modes`` fixes K (the fits below it
    only give starting values) and raises :class:`InputError` if the recording cannot support
    it."""
    max_modes = check_max_modes(max_modes if n_modes is None else n_modes)
    band = modal_band(prep, band)
    prep, note = modal_prepared(prep, band)
    fd = modal_fit_data(prep, band)
    span = float(fd.tau[-1] - fd.tau[0])
    if n_modes is not None and support(fd, max_modes):
        raise InputError(support(fd, max_modes))
    x, fsx = subspace.uniform_window(prep.grid, prep.grid_signal, prep.fs, prep.window, band)
    try:
        pencil = subspace.matrix_pencil(x, fsx, max_order=max(2 * max_modes + 4, 8), band=band)
    except InputError:
        pencil = None
    peaks = tuple(subspace.spectrum_peaks(x, fsx, band))
    fits = _greedy_fits(fd, band, span, pencil, max_modes)
    sel = _decide(fd, band, span, fits, pencil, peaks, max_modes, n_modes is not None)
    return dataclasses.replace(sel, notes=(note,) if note else ())


def _greedy_fits(fd: FitData, band, span: float, pencil, max_modes: int) -> list[Tried]:
    """K = 1 … ``max_modes`` fitted greedily (module docstring): K from the K − 1 optimum
    plus each candidate mode; a K is not tried (with the reason) when the samples cannot
    support it, no candidate is left, or K − 1 found no optimum to build on."""
    zeta = _zeta_guess(pencil)
    out: list[Tried] = []
    theta, resid = None, fd.y - fd.drift @ (fd.drift.T @ fd.y)
    with stage_bar(max_modes, f"modes: K = 1 … {max_modes} by evidence", unit="K") as bar:
        for k in range(1, max_modes + 1):
            theta, resid = _greedy_step(fd, band, span, pencil, zeta, k, (theta, resid), out)
            bar.update(1)
    return out


def _greedy_step(fd, band, span, pencil, zeta, k, state, out: list[Tried]):
    """The K = ``k`` step of :func:`_greedy_fits` from ``state`` = (θ, residuals) of the step
    before: its :class:`Tried` appended to ``out``; returns the (θ, residuals) the next K
    builds on."""
    theta, resid = state
    why = support(fd, k)
    if not why and k > 1 and not (out[-1].fit is not None and out[-1].fit.found):
        why = f"not tried: {k - 1} mode{'s' if k > 2 else ''} could not be fitted"
    cands = [] if why else _candidates(fd, theta, resid, pencil, band, span, zeta)
    if not why and not cands:
        why = "no candidate left for another mode"
    if why:
        out.append(Tried(None, why))
        return theta, resid
    fit = fit_modes(fd, _starts(theta, cands), band=band)
    out.append(Tried(fit, ""))
    return (fit.theta, fit.residuals) if fit.found else (theta, resid)


def _new_mode(fit: ModeFit, prev: ModeFit) -> float:
    """Frequency [Hz] of the mode of ``fit`` farthest from every mode of ``prev`` (the mode
    the K-th greedy step added)."""
    d = np.min(np.abs(fit.f_d[:, None] - prev.f_d[None, :]), axis=1)
    return float(fit.f_d[int(np.argmax(d))])


def _decide(fd, band, span, fits, pencil, peaks, max_modes, fixed) -> ModeSelection:
    """Evidence of every fit (MS5), rejection reasons and the chosen K (module docstring)."""
    conv = [t.fit for t in fits if t.fit is not None and t.fit.converged]
    if not conv:
        raise InputError("no mode could be fitted to the free-decay window (least squares "
                         "failed for every number of modes); check the window and band")
    ref = conv[-1]  # the largest converged fit: its residuals are the noise

    def r_at(f):
        return local_ratio(ref.residuals, fd, float(f), ref.q + 2 * ref.n_modes)

    results = _evidence_chain(fd, band, span, fits, r_at)
    ok = np.array([not res.reason for res in results])
    if fixed:
        ok[:-1] = False
        if results[-1].reason:
            raise InputError(f"{max_modes} modes cannot be fitted: {results[-1].reason}")
    if not ok.any():
        raise InputError(f"no mode found: {results[0].reason}")
    lnz = np.array([res.ln_evidence if good else -np.inf for res, good in zip(results, ok)])
    prob = np.exp(lnz - lnz.max())
    prob /= prob.sum()
    chosen = int(np.argmax(prob)) + 1
    warns = []
    if not fixed and prob[chosen - 1] < 0.9:
        alt = ", ".join(f"P(K = {k + 1}) = {p:.2g}" for k, p in enumerate(prob) if p >= 0.01)
        warns.append(f"the number of modes is uncertain: {alt}"
                     + harmonic_alternatives(results, prob, chosen, span))
    best = results[chosen - 1]
    warns += harmonics(best.fit)
    return ModeSelection(fit_data=fd, band=band, span=span, results=tuple(results),
                         probabilities=prob, n_modes=chosen, psd_ratio=best.psd_ratio,
                         psd_ratios=np.array([r_at(f) for f in best.fit.f_d]),
                         pencil=pencil, peaks=peaks, a_max=amplitude_prior_radius(fd),
                         warnings=tuple(warns))


def _evidence_chain(fd, band, span, fits, r_at) -> list[KResult]:
    """One :class:`KResult` per tried K: ln Z_K by the chain of Bayes factors (MS5), each
    step from the last converged fit below K (``base``) tempered at the Whittle factor
    ``r_at(f)`` of the mode K added farthest from ``base``'s modes; the first converged fit
    starts the chain at its strongest mode's r (its first mode's for K = 1). Amplitude
    significance (MS4) of each mode at its own r; the rejection reason."""
    n = fd.tau.size
    a_max = amplitude_prior_radius(fd)
    z_min = z_threshold(band, span)
    results: list[KResult] = []
    base, base_lnz = None, float("nan")
    for k, tried in enumerate(fits, start=1):
        fit = tried.fit
        if fit is None or not fit.found:
            why = tried.why or f"least squares found no optimum ({fit.message})"
            results.append(KResult(k, fit, float("nan"), np.zeros(0), np.zeros((0, 0)), why))
            continue
        ratios = np.array([r_at(f) for f in fit.f_d])
        z = amplitude_z(fit, n, 1.0 / ratios)
        f_step = fit.f_d[int(np.argmax(fit.amplitudes))] if base is None \
            else _new_mode(fit, base)
        r = r_at(f_step)
        lnz_k, cov = evidence(fit, n, temper=1.0 / r, band=band, a_max=a_max)
        ln_z = lnz_k if base is None else (
            base_lnz + lnz_k - evidence(base, n, temper=1.0 / r, band=band, a_max=a_max)[0])
        if not fit.converged:
            why = f"least squares did not converge ({fit.message})"
            if np.isfinite(z).all():
                why += (f"; its weakest mode ({fit.f_d[int(np.argmin(z))]:.4g} Hz) has an "
                        f"amplitude of {z.min():.2g} sd (noise: below {z_min:.2g})")
        else:
            why = reject_reason(fit, z, band, span, fd.fs, z_min)
            if not why and not np.isfinite(ln_z):
                why = "the evidence is not defined (singular curvature at the optimum)"
        results.append(KResult(k, fit, float(ln_z), z, cov, why, float(r)))
        if fit.converged and np.isfinite(ln_z):
            base, base_lnz = fit, float(ln_z)
    return results


def harmonic_components(fit: ModeFit, span: float | None = None) -> list[dict]:
    """Modes of ``fit`` at an integer multiple m = 2…5 of a stronger mode's damped frequency,
    within :data:`HARMONIC_TOLERANCE` of it: ``[{"index", "of", "multiple", "cells"}]``
    (0-based mode and its fundamental; ``cells`` = |f_j − m·f_i|·T, the mismatch in
    resolution cells of the window ``span`` T [s], NaN without it). The harmonics of a
    nonlinear oscillation (a pendulum's large swing, friction, drag, a stiffening spring)
    decay like modes and sit at exactly m·f_i — within a resolution cell — but are not
    structural modes. Its decay is tested too: a harmonic's rate p_j is at least
    :data:`HARMONIC_DECAY` × m·p_i; a component at the multiple that decays slower (a real
    mode at 2 f₁ with its own, lighter damping) is not listed."""
    out = []
    amp, f, p = fit.amplitudes, fit.f_d, fit.p
    for j in range(fit.n_modes):
        for i in range(fit.n_modes):
            ratio = f[j] / f[i]
            m = round(ratio)
            if i != j and 2 <= m <= 5 and abs(ratio / m - 1) < HARMONIC_TOLERANCE \
                    and amp[i] > amp[j] and p[j] >= HARMONIC_DECAY * m * p[i]:
                cells = abs(f[j] - m * f[i]) * span if span else math.nan
                out.append({"index": j, "of": i, "multiple": m, "cells": float(cells)})
                break
    return out


def harmonic_alternatives(results, prob, chosen: int, span: float) -> str:
    """What the uncertain number of modes hinges on when another K counts harmonics
    (:func:`harmonic_components` within :data:`HARMONIC_CELLS`): "; K = k counts f Hz = m x
    f' Hz, …" for every other K with P(K) ≥ 0.01 whose fit has them, "" if none. A pendulum's
    large swing puts its 3rd harmonic in the acceleration, and the evidence may then rate
    K = 2 as likely as K = 1 (the real 15° pendulum: P = 0.5 each) although the second
    component is no mode of its own."""
    notes = []
    for k, (res, p) in enumerate(zip(results, prob), start=1):
        fit = res.fit
        if k == chosen or p < 0.01 or fit is None:
            continue
        harm = [h for h in harmonic_components(fit, span) if h["cells"] < HARMONIC_CELLS]
        if harm:
            notes.append(f"K = {k} counts " + ", ".join(
                f"{fit.f_d[h['index']]:.4g} Hz = {h['multiple']} x {fit.f_d[h['of']]:.4g} Hz"
                for h in harm))
    if not notes:
        return ""
    return ("; " + "; ".join(notes) + " (a whole multiple of a stronger component within a "
            "resolution cell: a harmonic of a nonlinear oscillation, not a mode)")


def harmonics(fit: ModeFit) -> list[str]:
    """Warnings for the :func:`harmonic_components` of ``fit``: they may be harmonics of a
    nonlinear oscillation rather than structural modes."""
    f = fit.f_d
    return [f"the mode at {f[h['index']]:.4g} Hz lies at {h['multiple']}x the mode at "
            f"{f[h['of']]:.4g} Hz: it may be a harmonic of a nonlinear oscillation rather "
            "than a structural mode" for h in harmonic_components(fit)]
