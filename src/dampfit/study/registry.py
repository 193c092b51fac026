r"""One interface for every damping estimator, for comparison studies.

Each estimator is a function ``(prep, mass, *, seed) -> Estimate`` of a
:class:`~dampfit.signal.prepare.Prepared` recording; all of them see the same free-decay window
(``prep.window`` [s]) of the same analysed axis on the uniform grid (``prep.grid_signal``
[m/s²] at ``prep.fs`` [Hz]) and the same pass band ``prep.band`` [Hz]. :func:`run` prepares a
recording once and runs the named estimators, turning a numerical failure of one of them
into ``ok=False`` and a message.

Every estimator reports the decay rate p [1/s] and the natural frequency f_n [Hz]; then
ζ = p/ω_n and, with the mass m [kg], c = 2·m·p (seed paper eq. 3). The estimators
(:data:`ESTIMATORS`):

``bayes``              dampfit's posterior (:func:`dampfit.pipeline.analyze`), median and
                       90 % credible interval;
``least_squares``      variable-projection least squares (:func:`dampfit.inference.least_squares.least_squares`),
                       90 % normal interval from the calibrated Jacobian covariance;
``log_decrement``      the seed paper's logarithmic decrement (eqs. 9, 13);
``envelope_pipeline``  the seed paper's band-pass → integrate twice → Hilbert envelope →
                       log-linear fit (eqs. 2–4);
``hilbert``            Hilbert envelope and phase of the band-passed *acceleration*;
``half_power``         half-power bandwidth of the power spectrum;
``matrix_pencil``      Hua & Sarkar's total-least-squares matrix pencil on the
                       low-passed, decimated window.

The estimators that report every mode they find (several modes) are in
:mod:`dampfit.study.modal`.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import asdict, dataclass, replace
from typing import Callable, Iterable

import numpy as np
from scipy import signal

from dampfit.estimators import baselines
from dampfit.signal import filters
from dampfit.signal import prepare
from dampfit.errors import InputError
from dampfit import physics
from dampfit.signal.prepare import Prepared
from dampfit.io.recording import Recording

#: Bulk ESS the "bayes" estimator asks for (below the CLI's DEFAULT_MIN_ESS; 400 keeps studies fast).
BAYES_MIN_ESS = 400.0
#: Two-sided 90 % normal quantile.
Z90 = 1.6448536269514722
#: Envelope fits stop where the smoothed envelope falls below this multiple of the in-band
#: noise envelope ``prep.noise_floor`` (below it ln|envelope| is biased by the noise).
ENVELOPE_NOISE_MULTIPLE = 3.0
#: Matrix pencil: extra poles beyond the signal's pair, and the most samples it decomposes.
PENCIL_EXTRA_ORDER, PENCIL_MAX_SAMPLES = 4, 1500


@dataclass(frozen=True)
class Estimate:
    """One estimator's result. p [1/s], f_n [Hz], ζ [1], c and its interval [N·s/m]."""

    estimator: str
    p: float  # decay rate [1/s]
    f_n: float  # natural frequency [Hz]
    zeta: float  # damping ratio [1]
    c: float | None  # damping coefficient [N s/m] (None without mass)
    c_lo: float | None  # 90 % interval where the estimator has one, else None
    c_hi: float | None
    zeta_lo: float | None
    zeta_hi: float | None
    ok: bool
    message: str  # "" or why it failed
    runtime_s: float  # wall time [s]

    def as_dict(self) -> dict:
        """Flat JSON/CSV-safe dict: Python floats, non-finite numbers as None."""
        out = {}
        for k, v in asdict(self).items():
            if isinstance(v, (float, np.floating)):
                v = float(v) if math.isfinite(v) else None
            elif isinstance(v, np.bool_):
                v = bool(v)
            out[k] = v
        return out


def failed_estimate(name: str, message: str, runtime: float = 0.0) -> Estimate:
    """An ``ok=False`` estimate of ``name`` with no numbers, ``message`` saying why, and the
    wall time ``runtime`` [s] it took to fail."""
    nan = float("nan")
    return Estimate(name, nan, nan, nan, None, None, None, None, None, False, message, runtime)


def estimate_from(name, p, f_d, mass, *, p_int=None, zeta_int=None, ok=True, message="") -> Estimate:
    """Estimate from p [1/s] and the damped frequency f_d [Hz] (mass [kg] or None for c);
    ``p_int`` a 90 % interval of p [1/s], ``zeta_int`` one of ζ [1]. A non-positive or
    non-finite p is ``ok=False`` ("no decay found")."""
    d = physics.quantities(p, 2 * np.pi * f_d, mass)
    p, f_n, zeta = float(p), float(d["f_n"]), float(d["zeta"])
    if ok and not (math.isfinite(p) and math.isfinite(f_n) and p > 0):
        ok, message = False, f"no decay found (p = {p:.3g} 1/s)"
    c = c_lo = c_hi = None
    if mass is not None:
        c = float(d["c"])
        if p_int is not None:
            c_lo, c_hi = (float(physics.damping_coefficient(mass, float(x))) for x in p_int)
    z_lo, z_hi = (None, None) if zeta_int is None else (float(zeta_int[0]), float(zeta_int[1]))
    return Estimate(name, p, f_n, zeta, c, c_lo, c_hi, z_lo, z_hi, bool(ok), message, 0.0)


def _window(prep: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """Grid times [s] and acceleration [m/s²] inside the free-decay window."""
    sel = prep.grid_in_window
    return prep.grid[sel], prep.grid_signal[sel]


#: name -> estimator(prep, mass, *, seed) -> Estimate
ESTIMATORS: dict[str, Callable[..., Estimate]] = {}


def _estimator(name: str):
    """Register ``fn`` under ``name`` and time it (``runtime_s``); ``fn`` receives the mass
    as a checked :class:`dampfit.physics.Mass` (a plain number is checked by the wrapper)."""

    def wrap(fn):
        @functools.wraps(fn)
        def timed(prep: Prepared, mass: float | physics.Mass | None = None, *,
                  seed: int = 0) -> Estimate:
            t0 = time.perf_counter()
            est = fn(prep, physics.as_mass(mass), seed=seed)  # a Mass is not checked again
            return replace(est, runtime_s=time.perf_counter() - t0)

        ESTIMATORS[name] = timed
        return timed

    return wrap


# --------------------------------------------------------------------------- estimators
@_estimator("bayes")
def bayes(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """dampfit's viscous posterior (:func:`dampfit.stages.viscous_stages`, the stages of
    :func:`dampfit.pipeline.analyze` after the preparation): medians, 90 % credible intervals.

    It runs on ``prep`` itself — the samples every other estimator sees — with
    ``min_ess`` = :data:`BAYES_MIN_ESS` (400, below the CLI's DEFAULT_MIN_ESS); the mass is taken as exact
    (``mass_sd`` = 0). No damping-law comparison is made. ``ok`` is False when the least
    squares or the chain did not converge (the numbers are still reported).
    """
    from dampfit._options import SamplerSettings
    from dampfit.stages import viscous_stages

    st = viscous_stages(prep, mass, sampler=SamplerSettings(seed=seed, min_ess=BAYES_MIN_ESS))
    post = st.sampling.idata.posterior

    def q(name: str) -> tuple[float, float, float]:
        x = np.asarray(post[name], dtype=float).ravel()
        return tuple(float(v) for v in np.quantile(x, (0.05, 0.5, 0.95)))

    p, f_n, z = q("p"), q("f_n"), q("zeta")
    c = q("c") if mass.value is not None else None
    ok = bool(st.least_squares.converged and st.sampling.converged)
    msg = "" if ok else "; ".join(st.warnings) or "did not converge"
    return Estimate(
        "bayes", p[1], f_n[1], z[1], c[1] if c else None, c[0] if c else None,
        c[2] if c else None, z[0], z[2], ok, msg, 0.0,
    )


@_estimator("least_squares")
def least_squares(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """The least squares every analysis reports (summary.json's ``least_squares``): the same
    stage (:func:`dampfit.stages.fit_stages`: started from the log decrement, noise
    calibrated with the Whittle factor r floored at its white-noise value) and the same
    1-σ (:func:`dampfit.stages.ls_summary`); the 90 % intervals are normal in the logs,
    p·(1 ± 1.645·sd(ln p)) and ζ·(1 ± 1.645·sd(ln ζ)).

    A window the stage refuses (no free decay) is ``ok=False`` with its reason.
    """
    from dampfit import stages

    try:
        st = stages.fit_stages(prep, mass)
    except InputError as exc:
        return failed_estimate("least_squares", str(exc))
    ls = st.least_squares
    s = stages.ls_summary(ls, mass.value, st.noise.psd_ratio)
    p, zeta = s["p"], s["zeta"]
    nan = float("nan")
    sd_lnp = s["p_sd"] / p if "p_sd" in s and p > 0 else nan
    sd_lnz = s["zeta_sd"] / zeta if "zeta_sd" in s and zeta > 0 else nan
    ok, msg = ls.converged, ("" if ls.converged else ls.message)
    return estimate_from(
        "least_squares", p, ls.omega_d / (2 * np.pi), mass.value, ok=ok, message=msg,
        p_int=(p * (1 - Z90 * sd_lnp), p * (1 + Z90 * sd_lnp)),
        zeta_int=(zeta * (1 - Z90 * sd_lnz), zeta * (1 + Z90 * sd_lnz)),
    )


@_estimator("log_decrement")
def log_decrement(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """Seed paper's logarithmic decrement over all cycles, δ = (1/n)·ln(a₀/aₙ) (eq. 9), ζ (eq. 13).

    Wraps :func:`dampfit.estimators.baselines.log_decrement` (first to last usable peak); no interval.
    """
    t, y = _window(prep)
    b = baselines.log_decrement(t, y, prep.fs, prep.band)
    return estimate_from("log_decrement", b.p, b.f_d, mass.value)


@_estimator("envelope_pipeline")
def envelope_pipeline(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """Seed paper's pipeline: band-pass, integrate twice, Hilbert envelope, ln fit (eqs. 2–4).

    Wraps :func:`dampfit.estimators.baselines.envelope_pipeline` (env²-weighted); no interval.
    """
    t, y = _window(prep)
    b = baselines.envelope_pipeline(t, y, prep.fs, prep.band)
    return estimate_from("envelope_pipeline", b.p, b.f_d, mass.value)


def _hilbert_fit(prep: Prepared) -> tuple[float, float]:
    """(p [1/s], f_d [Hz]) from the analytic signal of the band-passed window acceleration."""
    t, y = _window(prep)
    lo, hi = prep.band
    z = signal.hilbert(filters.bandpass(y, prep.fs, prep.band))
    env = np.abs(z)
    # filter/Hilbert end effects: two periods or three band-pass time constants 1/(hi − lo)
    trim = min(max(2.0 / prep.f0, 3.0 / (hi - lo)), 0.2 * (t[-1] - t[0]))
    inner = np.flatnonzero((t >= t[0] + trim) & (t <= t[-1] - trim))
    per = max(1, int(round(prep.fs / prep.f0)))
    smooth = signal.convolve(env, np.ones(per) / per, mode="same")
    low = np.flatnonzero(smooth[inner] < ENVELOPE_NOISE_MULTIPLE * prep.noise_floor)
    if low.size:
        inner = inner[: low[0]]
    if inner.size < 2 * per:
        raise InputError("fewer than two cycles lie above the noise between the trimmed ends")
    tt, w = t[inner] - t[inner[0]], env[inner]
    slope = np.polyfit(tt, np.log(w), 1, w=w)[0]  # weights env² (polyfit squares w)
    omega = np.polyfit(tt, np.unwrap(np.angle(z[inner])), 1, w=w)[0]
    return float(-slope), float(omega / (2 * np.pi))


@_estimator("hilbert")
def hilbert(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """Hilbert-transform envelope and phase of the band-passed acceleration (Feldman 1994).

    The window is band-passed (zero-phase Butterworth, ``prep.band``), its analytic signal
    z = y + i·H[y] gives ln|z| = ln K − p·t and arg z = ω_d·t + φ, both fitted by least
    squares weighted by |z|² (var ln|z| ≈ σ²/|z|²). The ends (filter and Hilbert transients,
    max(two periods, 3/(band width))) are trimmed, and the fit stops where the envelope,
    smoothed over one period, falls below 3× the in-band noise envelope. Unlike the paper's
    pipeline it does not integrate to displacement. No interval.
    Ref.: M. Feldman, "Non-linear system vibration analysis using Hilbert transform — I.
    Free vibration analysis method 'FREEVIB'", Mech. Syst. Signal Process. 8(2), 1994.
    """
    p, f_d = _hilbert_fit(prep)
    return estimate_from("hilbert", p, f_d, mass.value)


def _half_power_width(f: np.ndarray, pw: np.ndarray) -> tuple[float, float]:
    """Peak frequency [Hz] and full width [Hz] at half the peak of the power ``pw`` on grid ``f``."""
    i = int(np.argmax(pw))
    half = 0.5 * pw[i]
    left = np.flatnonzero(pw[:i] < half)
    right = np.flatnonzero(pw[i:] < half)
    if not left.size or not right.size:
        raise InputError("the spectral peak's half-power points lie outside the pass band")
    a, b = left[-1], i + right[0]
    f_l = np.interp(half, [pw[a], pw[a + 1]], [f[a], f[a + 1]])
    f_r = np.interp(half, [pw[b], pw[b - 1]], [f[b], f[b - 1]])
    return float(f[i]), float(f_r - f_l)


@_estimator("half_power")
def half_power(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """Half-power bandwidth of the power spectrum: ζ ≈ Δf/(2·f_n) (e.g. Ewins, *Modal Testing*).

    The window's acceleration (linear trend removed, no taper: the decay is its own window)
    is transformed by a zoom FFT (:func:`scipy.signal.zoom_fft`) over ``prep.band`` at 1/32
    of the Fourier resolution 1/T, so the peak and the half-power points are resolved
    without parabolic fitting; the crossings are linearly interpolated. For a decay
    e^{−pt} the spectrum is a Lorentzian of full width Δf = p/π, so p = π·Δf and
    f_n = √(f_peak² + (Δf/2)²). Bias: the record of length T convolves the line with the
    rectangular window, widening it. For |X(f)|² ∝ |1 − e^{−(p+2πiΔf)T}|²/|p + 2πiΔf|² the
    half-power width overestimates p by +190 % at p·T = 1, +56 % at 2, +19 % at 3, +5 % at
    4, +1 % at 5 and < 0.1 % from 7 on; for T ≪ 1/p, Δf tends to the window's own width
    0.886/T and ζ to 0.443/(f_n·T) whatever the true damping. The free-decay window ends
    where the decay meets the noise, so typically p·T ≈ 3–5. White noise lifts the whole
    spectrum, widening the peak further. No interval.
    """
    t, y = _window(prep)
    y = signal.detrend(y)
    lo, hi = prep.band
    m = int(np.clip(32 * (hi - lo) * (t[-1] - t[0]), 256, 2**18))
    spec = signal.zoom_fft(y, [lo, hi], m=m, fs=prep.fs, endpoint=True)
    f = np.linspace(lo, hi, m)
    f_pk, width = _half_power_width(f, np.abs(spec) ** 2)
    return estimate_from("half_power", np.pi * width, f_pk, mass.value)


def _pencil_poles(x: np.ndarray, order: int) -> np.ndarray:
    """Signal poles z_i of ``x`` (n,) by the TLS matrix pencil with pencil parameter L = n/3."""
    n = x.size
    ell = n // 3
    hank = np.lib.stride_tricks.sliding_window_view(x, ell + 1)  # (n − L) × (L + 1)
    _, _, vh = np.linalg.svd(hank, full_matrices=False)
    v = vh[:order].conj().T  # right singular vectors of the signal subspace, (L + 1) × M
    return np.linalg.eigvals(np.linalg.pinv(v[:-1]) @ v[1:])


@_estimator("matrix_pencil")
def matrix_pencil(prep: Prepared, mass: physics.Mass, *, seed: int = 0) -> Estimate:
    """Total-least-squares matrix pencil (Hua & Sarkar 1990; Sarkar & Pereira 1995).

    The window (linear trend removed) is low-passed at the band's upper edge (zero-phase
    Butterworth, :func:`dampfit.signal.filters.lowpass`) and decimated to ≈ 4× that edge (fewer
    samples if there would be more than 1500: the SVD is O(n·L²)). A low-pass, not the
    band-pass: the band-pass rings for ≈ 1/(hi − lo) at both window ends and those
    transients biased p (white noise, f_n = 2 Hz, ζ = 0.01: RMSE(p) ≈ 1.6× the CRLB
    untrimmed, 1.0–1.25× with the ends trimmed, 0.9–1.15× low-passed). A real damped
    sinusoid is two complex exponentials; model order M = 2 + 4 extra poles absorb noise
    and what is left of the drift. With pencil parameter L = n/3 the Hankel matrix
    Y ((n − L) × (L + 1)) = UΣVᴴ is truncated to its M leading right singular vectors V_M;
    the poles are the eigenvalues of V₁⁺V₂ (V₁, V₂: V_M without its last / first row). The
    pole with positive frequency nearest f₀ gives p = −f_s·ln|z| and ω_d = f_s·arg z.
    (The matrix pencil, not ESPRIT, though with this truncation the two coincide in form.)
    No interval. Ref.: Y. Hua and T. K. Sarkar, IEEE Trans. ASSP 38(5), 814–824, 1990.
    """
    _, y = _window(prep)
    hi = prep.band[1]
    yl = filters.lowpass(signal.detrend(y), prep.fs, hi)
    q = max(1, int(prep.fs / (4.0 * hi)), math.ceil(yl.size / PENCIL_MAX_SAMPLES))
    x, fs = yl[::q], prep.fs / q
    order = 2 + PENCIL_EXTRA_ORDER
    if x.size < 3 * order:
        raise InputError(f"the decimated window has only {x.size} samples for a pencil of order {order}")
    s = np.log(_pencil_poles(x, order).astype(complex)) * fs  # continuous-time poles −p + iω_d
    s = s[s.imag > 0]
    if not s.size:
        raise InputError("the matrix pencil found no oscillating pole")
    best = s[np.argmin(np.abs(s.imag - 2 * np.pi * prep.f0))]
    return estimate_from("matrix_pencil", -best.real, best.imag / (2 * np.pi), mass.value)


# --------------------------------------------------------------------------- runner
def run(names: Iterable[str] | str, recording: Recording, mass: float | None = None, *,
        seed: int = 0) -> list[Estimate]:
    """Prepare ``recording`` once (:func:`dampfit.signal.prepare.prepare`) and run each named estimator.

    ``names`` — names from :data:`ESTIMATORS` (or one name); ``mass`` [kg] for c; ``seed``
    for the stochastic ones. Returns one :class:`Estimate` per name, in order. Any exception
    inside an estimator becomes ``ok=False`` with the reason in ``message``; an unknown name,
    a bad mass, or an :class:`InputError` of ``prepare`` (an unusable recording) is raised.
    """
    names = [names] if isinstance(names, str) else list(names)
    unknown = [n for n in names if n not in ESTIMATORS]
    if unknown:
        raise InputError(
            f"unknown estimator(s) {', '.join(map(repr, unknown))}; valid: {', '.join(ESTIMATORS)}"
        )
    mass = physics.Mass(mass)  # checked once; the estimators take it as it is
    prep = prepare.prepare(recording)
    out = []
    for name in names:
        t0 = time.perf_counter()
        try:
            out.append(ESTIMATORS[name](prep, mass, seed=seed))
        except Exception as exc:  # noqa: BLE001 - failure is data in a comparison study
            msg = f"{type(exc).__name__}: {exc}".strip()
            out.append(failed_estimate(name, msg, time.perf_counter() - t0))
    return out
