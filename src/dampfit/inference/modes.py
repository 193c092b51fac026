r"""Several modes in one recording: the modal band, fit samples and K-mode least squares.

Data
----
The modes of a structure lie far apart (a cantilever's second bending mode at 6.3× the
first), so the one-mode pass band [f₀/1.5, 1.5·f₀] would cut them off. The modal analysis
keeps the one-mode window (starting it earlier and running it through beats:
:func:`modal_window`) but widens the band (:func:`modal_band`) to

    [max(f₀/8, 3/T), min(8·f₀, 0.45·f_s)]   [Hz]                                           (MS1)

(T [s] the window length: at least three cycles of the lowest mode), low-passes and decimates
to ≥ 2.5× its upper edge as the one-mode path does (:func:`dampfit.signal.prepare.fit_data`),
and sets the drift basis from the *lowest* frequency of the band (one Legendre degree per four
of its cycles), so that the drift terms cannot absorb a low mode.

Least squares
-------------
The model is (MK1) of :mod:`dampfit.model.modes`: K viscous modes plus drift, amplitudes
projected out (variable projection, :func:`dampfit.model.profile.profile`). Starts
(:func:`fit_modes`): every start row θ₀ is expanded into a small grid (its last mode — the
new candidate — with rate × {⅓, 1, 3} and frequency ± ¼ resolution cell 1/T), the RSS is
evaluated on the whole grid at once, and optimistix's Levenberg–Marquardt minimises the
projected residual over the 2K parameters θ = (ln p_i, ln ω_i) from the best grid point of
each of the :data:`N_LM` best starts at once (one ``jax.vmap``-ed
:class:`~dampfit.inference.executables.Kernel` per K and shape bucket; its Jacobian is
Kaufman's, :func:`vp_residual`). The best optimum inside the prior support (MK3: every mode
in the band — on uniform samples a mode and its alias above the Nyquist frequency fit
equally well — and ζ ≲ 0.2) with no two modes within one resolution cell 1/T (refused as
separate modes) wins; if none of the batch qualifies — typically a new mode that slid into an
old one's cell to absorb the misfit of an amplitude-dependent decay — the next starts are run.
An optimum that has not converged within ``max_steps`` is restarted from where it stopped
(:data:`RESTARTS` times: a heavily damped mode has a long, flat valley). Modes are numbered by
frequency. The drift basis is padded to the next of 4, 8, 16 or 25 columns (not always 25),
which keeps the kernels cheap.

The evidence of each K, the rejection rules and the choice of K are in
:mod:`dampfit.inference.modes_select`.

Failure inside is data (``converged=False``, reasons); only unusable options raise
:class:`~dampfit.errors.InputError`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from scipy import ndimage

from dampfit._options import DEFAULT_MAX_MODES, MAX_MODES_LIMIT  # modes tried by default, the most accepted
from dampfit.errors import InputError
from dampfit.inference.executables import kernel
from dampfit.model import modes as mm
from dampfit.model import profile
from dampfit.signal.prepare import MAX_DRIFT_DEGREE, MIN_CYCLES, FitData, Prepared, fit_data
from dampfit.signal.window import END_REASONS, IMPACT_RATIO, impacts, running_median

#: Band (MS1): a factor below and above the dominant frequency.
BAND_RATIO = 8.0
#: A rise of the one-period envelope mean by more than this factor within one period is a new
#: excitation, not a beat (:func:`modal_window`).
ABRUPT_RISE = 2.0
#: Fewest samples per cycle of the highest mode (0.45·f_s: the one-mode band's cap).
MIN_SAMPLES_PER_CYCLE = 2.2
#: Fewest fitted samples per linear or nonlinear parameter for K modes to be tried.
MIN_SAMPLES_PER_PARAMETER = 4
#: Levenberg–Marquardt runs per K (one vmapped batch), rows per grid evaluation, and restarts
#: of an optimum that has not converged within ``max_steps``.
N_LM, GRID_BATCH, RESTARTS = 3, 64, 2
#: Levenberg–Marquardt steps per run (a static argument of the compiled fit).
LM_STEPS = 100
#: The start grid around each start's last mode (:func:`start_grid`): rate factors and
#: frequency shifts in resolution cells 1/T.
GRID_RATE_FACTORS, GRID_CELL_SHIFTS = (1 / 3, 1.0, 3.0), (-0.25, 0.0, 0.25)
#: Rows of the start grid per start row.
GRID_PER_START = len(GRID_RATE_FACTORS) * len(GRID_CELL_SHIFTS)
#: Levenberg–Marquardt tolerances (relative, absolute) of the K-mode least squares.
TOLERANCES = (1e-8, 1e-10)


# ----------------------------------------------------------------------------- options
def check_max_modes(value) -> int:
    """``max_modes`` as an int in [1, :data:`MAX_MODES_LIMIT`]; :class:`InputError` otherwise."""
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if not ok and isinstance(value, (float, np.floating)) and float(value).is_integer():
        ok, value = True, int(value)
    if not ok:
        raise InputError(f"max modes must be a whole number from 1 to {MAX_MODES_LIMIT}, "
                         f"got {value!r}")
    if not 1 <= int(value) <= MAX_MODES_LIMIT:
        raise InputError(f"max modes must be from 1 to {MAX_MODES_LIMIT}, got {int(value)}")
    return int(value)


def check_mode_of_mass(value, n_modes: int) -> int | None:
    """The 1-based index of the mode the mass belongs to, as a 0-based int (None: the dominant
    mode); :class:`InputError` unless a whole number in [1, ``n_modes``]."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer, float, np.floating)) \
            or not float(value).is_integer():
        raise InputError(f"mode of mass must be a mode number 1 … {n_modes}, got {value!r}")
    if not 1 <= int(value) <= n_modes:
        raise InputError(f"mode of mass {int(value)} is out of range: the recording has "
                         f"{n_modes} mode{'s' if n_modes > 1 else ''} (1 … {n_modes})")
    return int(value) - 1


# ----------------------------------------------------------------------------- data
def modal_band(prep: Prepared, band: tuple[float, float] | None = None) -> tuple[float, float]:
    """The modal pass band (MS1) [Hz], or ``band`` [Hz] checked against the window (≥ 3
    cycles of its lower edge) and the sample rate (≥ :data:`MIN_SAMPLES_PER_CYCLE` samples
    per cycle of its upper edge); one-line :class:`InputError` otherwise."""
    span = prep.window[1] - prep.window[0]
    if band is None:
        lo = max(prep.f0 / BAND_RATIO, MIN_CYCLES / span)
        hi = min(BAND_RATIO * prep.f0, prep.fs / MIN_SAMPLES_PER_CYCLE * 0.99)
        return float(lo), float(hi)
    lo, hi = float(band[0]), float(band[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError(f"modal band {lo:g}–{hi:g} Hz is not a valid band (need 0 < low < high)")
    if span * lo < MIN_CYCLES:
        raise InputError(f"the window ({span:.3g} s) holds only {span * lo:.2g} cycles of the "
                         f"band's lower edge {lo:g} Hz; at least {MIN_CYCLES:g} are needed")
    if prep.fs / hi < MIN_SAMPLES_PER_CYCLE:
        raise InputError(f"too few samples per cycle of the highest mode: {prep.fs:.4g} Hz "
                         f"sampling gives {prep.fs / hi:.2g} per cycle at {hi:g} Hz "
                         f"(need {MIN_SAMPLES_PER_CYCLE:g})")
    return lo, hi


def modal_window(prep: Prepared, band: tuple[float, float]) -> tuple[tuple[float, float], str]:
    """The modal window [s] for the modal ``band`` [Hz], and a note ("" if unchanged).

    *Start.* The one-mode window starts max(½/f₀, 3/f_hi) after the envelope maximum (the
    release), f_hi the one-mode band's upper edge; the modal one max(½/f₀, 3/f_hi') after it,
    f_hi' the modal band's edge — earlier, because a higher mode decays faster (at constant ζ
    the rate grows with the frequency) and its information sits right after the release.
    *End.* The one-mode window ends where the envelope rises again or drops abruptly (a catch
    or a new excitation, :func:`dampfit.signal.window.detect_window`) — but two close modes
    beat, and a beat's null and rise would cut the record after one beat period. When one of
    those rules ended an automatic window, the modal window runs on until the envelope
    (running median over five periods) falls below 3× the noise floor, or rises *abruptly* —
    the one-period mean more than :data:`ABRUPT_RISE` × what it was one period before, at
    > 5× the floor: a new excitation; a beat rises over many periods — or an impact spike
    > ``IMPACT_RATIO`` × the signal comes. A window the user gave is kept as it is.
    (Two nearly equal modes have deep beat nulls whose recovery can look abrupt: their modal
    window may still end at a null.)
    """
    w0, w1 = prep.window
    if not prep.window_auto:
        return prep.window, ""
    guard = max(0.5 / prep.f0, 3.0 / prep.band[1])
    start = max(float(prep.grid[0]), w0 - guard + max(0.5 / prep.f0, 3.0 / band[1]))
    notes = []
    if start < w0:
        notes.append(f"modal window starts at {start:.4g} s ({w0 - start:.2g} s before the "
                     "one-mode window: higher modes decay faster)")
    reason = prep.window_end_reason
    if not (reason == END_REASONS[1] or reason.startswith("abrupt envelope drop")):
        return (start, w1), "; ".join(notes)
    end = _beat_end(prep)
    if end <= w1:
        return (start, w1), "; ".join(notes)
    notes.append(f"modal window extended to {end:.4g} s past the one-mode window's end "
                 f"at {w1:.4g} s: the envelope dips and rises again gradually (the beating of "
                 "close modes), not abruptly (a new excitation)")
    return (start, end), "; ".join(notes)


def _beat_end(prep: Prepared) -> float:
    """Where a decay that beats ends [s] (:func:`modal_window`): the five-period running
    median of the envelope below 3× the noise floor, an abrupt rise, or an impact spike —
    whichever comes first after the one-mode window's start (at most the grid's end)."""
    grid, env, w0 = prep.grid, prep.envelope, prep.window[0]
    per = max(1, int(round(prep.fs / prep.f0)))
    robust = running_median(env, 5 * per)
    smooth = ndimage.uniform_filter1d(env, per)
    i0 = int(np.searchsorted(grid, w0))
    end = len(grid) - 1 - per
    low = np.flatnonzero(robust[i0:] < 3.0 * prep.noise_floor)
    if low.size:
        end = min(end, i0 + int(low[0]))
    rise = np.flatnonzero((smooth[i0 + per:] > ABRUPT_RISE * smooth[i0:-per])
                          & (smooth[i0 + per:] > 5.0 * prep.noise_floor))
    if rise.size:
        end = min(end, i0 + int(rise[0]))
    ev_t, ev_r = impacts(prep.time, prep.signal, prep.usable, ~prep.usable, prep.f0)
    for tc, ratio in zip(ev_t, ev_r):
        if tc > w0 + 1.0 / prep.f0 and ratio > IMPACT_RATIO:
            end = min(end, int(np.searchsorted(grid, tc)) - per // 2)
            break
    return float(grid[max(end, i0)])


def modal_prepared(prep: Prepared, band: tuple[float, float]) -> tuple[Prepared, str]:
    """``prep`` with the modal band ``band`` [Hz] and the :func:`modal_window`, and its note."""
    window, note = modal_window(prep, band)
    return dataclasses.replace(prep, band=(float(band[0]), float(band[1])), window=window), note


def modal_fit_data(prep: Prepared, band: tuple[float, float]) -> FitData:
    """Fit samples of ``prep``'s window in the modal band ``band`` [Hz] (module docstring:
    decimation to ≥ 2.5× its upper edge, drift basis from its lower edge); give ``prep``
    from :func:`modal_prepared` for the modal window."""
    fd = fit_data(dataclasses.replace(prep, band=(float(band[0]), float(band[1]))))
    span = float(fd.tau[-1] - fd.tau[0])
    degree = int(np.clip(span * band[0] / 4.0, 1, MAX_DRIFT_DEGREE))
    return dataclasses.replace(fd, drift_degree=degree)


def support(fd: FitData, n: int) -> str:
    """Why ``fd`` cannot support ``n`` modes ("" if it can): fewer than
    :data:`MIN_SAMPLES_PER_PARAMETER` samples per parameter (4K + drift terms)."""
    need = MIN_SAMPLES_PER_PARAMETER * (4 * n + fd.drift_degree + 1)
    if fd.tau.size < need:
        return (f"{fd.tau.size} fitted samples cannot support {n} modes (need "
                f"{MIN_SAMPLES_PER_PARAMETER} per parameter: {need}; the recording is too short)")
    return ""


# ----------------------------------------------------------------------------- kernels
@kernel(static_argnums=(0,))
def _rss_batch(n, thetas, tau, y, drift, mask):
    """Projected RSS [(m/s²)²] at every row of ``thetas`` (the start grid)."""
    mdl = mm.model(n)
    return jax.vmap(lambda th: profile.profile(mdl, th, tau, y, drift, mask).rss)(thetas)


def vp_residual(n: int, tau, y, drift, mask):
    """The projected residual r(θ) = P⊥·y [m/s²] of ``n`` modes as a function of θ alone, with
    Kaufman's Jacobian −P⊥·(∂X/∂θ)·β̂ as its JVP (``jax.custom_jvp``).

    Kaufman (1975) drops the term (X⁺)ᵀ(∂X/∂θ)ᵀr of the exact variable-projection Jacobian
    (Golub & Pereyra 1973); it lies in the column space of X, orthogonal to r, so Jᵀr — the
    gradient of the RSS — is exact and Levenberg–Marquardt converges to the same optimum,
    while each Jacobian costs a few matrix products instead of differentiating the Cholesky
    factorisation (≈ 10× cheaper per step at K = 3). ∂X/∂ln p_i = −p_i·τ·X_i and
    ∂X/∂ln ω_i = ω_i·τ·X_i·[[0, 1], [−1, 0]] for the (M1) columns X_i = e^{−p_iτ}[cos, sin].
    """
    mdl = mm.model(n)

    @jax.custom_jvp
    def resid(theta):
        return profile.profile(mdl, theta, tau, y, drift, mask).residual

    @resid.defjvp
    def _jvp(primals, tangents):
        (theta,), (dtheta,) = primals, tangents
        pr = profile.profile(mdl, theta, tau, y, drift, mask)
        xo = mdl.columns(theta, tau) * mask[:, None]  # (n, 2K): [c_1, s_1, c_2, s_2, …]
        c, s = xo[:, 0::2], xo[:, 1::2]
        a, b = pr.beta[0:2 * n:2], pr.beta[1:2 * n:2]
        p, w = jnp.exp(theta[0::2]), jnp.exp(theta[1::2])
        d_lnp = -(p * tau[:, None]) * (a * c + b * s)
        d_lnw = (w * tau[:, None]) * (b * c - a * s)
        v = d_lnp @ dtheta[0::2] + d_lnw @ dtheta[1::2]
        qv, qx = drift.T @ v, drift.T @ xo
        coef = jsl.cho_solve((pr.chol, True), (xo.T @ v - qx.T @ qv) / pr.scale) / pr.scale
        return pr.residual, -(v - drift @ qv - (xo - drift @ qx) @ coef)

    return resid


@kernel(static_argnums=(0, 1))
def _fit_batch(n, max_steps, starts, tau, y, drift, mask):
    """Levenberg–Marquardt from every row of ``starts``: (θ̂, RSS, result code, steps)."""
    mdl = mm.model(n)
    resid = vp_residual(n, tau, y, drift, mask)

    def one(th0):
        import optimistix as optx  # only where traced: a loaded kernel needs no optimistix

        solver = optx.LevenbergMarquardt(rtol=TOLERANCES[0], atol=TOLERANCES[1])
        sol = optx.least_squares(lambda th, _: resid(th), solver, th0, max_steps=max_steps,
                                 throw=False)
        rss = profile.profile(mdl, sol.value, tau, y, drift, mask).rss
        return sol.value, rss, sol.result._value, sol.stats.get("num_steps", -1)

    return jax.vmap(one)(starts)


@kernel(static_argnums=(0,))
def _details(n, theta, tau, y, drift, mask):
    """(β̂, RSS, ln det X⊥ᵀX⊥, residual, J_r = ∂residual/∂θ, (X⊥ᵀX⊥)⁻¹) at θ."""
    mdl = mm.model(n)

    def resid(th):
        return profile.profile(mdl, th, tau, y, drift, mask).residual

    pr = profile.profile(mdl, theta, tau, y, drift, mask)
    return (pr.beta, pr.rss, pr.logdet, pr.residual, jax.jacfwd(resid)(theta),
            profile.conditional_covariance(pr))


#: Why a fit found no optimum (:meth:`ModeFit.failed`).
NO_OPTIMUM = ("none inside the band (ζ < 0.2) with every pair of modes more than one "
              "resolution cell apart, from any start")
#: Drift-column buckets of the padded arrays.
_DRIFT_BUCKETS = (4, 8, 16, MAX_DRIFT_DEGREE + 1)


def padded_arrays(fd: FitData) -> tuple:
    """(τ [s], y [m/s²], drift, mask) of ``fd`` padded to its sample bucket and the next drift
    bucket (:data:`_DRIFT_BUCKETS`), as float64 device arrays (call inside x64)."""
    pad = fd.padded
    d = drift_columns(fd.drift_degree)
    return jax.device_put((np.asarray(pad.tau, np.float64), np.asarray(pad.y, np.float64),
                           np.asarray(pad.drift[:, :d], np.float64),
                           np.asarray(pad.mask, np.float64)))


def drift_columns(degree: int) -> int:
    """Drift columns of the padded arrays of a fit whose drift has ``degree``: the smallest
    of :data:`_DRIFT_BUCKETS` that holds its ``degree + 1`` terms."""
    return next(b for b in _DRIFT_BUCKETS if b >= degree + 1)


def drift_column_buckets() -> tuple[int, ...]:
    """Every drift-column bucket (:func:`drift_columns`), smallest first."""
    return _DRIFT_BUCKETS


def warm_kernels(fd: FitData, theta) -> None:
    """Compile (or load from the store) the kernels :func:`fit_modes` runs for K = len(θ)/2
    modes on ``fd``'s padded shapes, each called once with rows of ``theta`` (2K,), which only
    needs finite values (:mod:`dampfit.inference.modes_warm`)."""
    theta = np.asarray(theta, dtype=np.float64)
    n = mm.n_modes(theta)
    with jax.enable_x64(True):
        args = padded_arrays(fd)
        _rss_batch(n, np.tile(theta, (GRID_BATCH, 1)), *args)
        _fit_batch(n, LM_STEPS, np.tile(theta, (N_LM, 1)), *args)
        _details(n, theta, *args)


# ----------------------------------------------------------------------------- fits
@dataclass(frozen=True)
class ModeFit:
    """Least-squares optimum of K modes (numbered by frequency).

    ``theta`` (2K,) of (MK2); ``beta`` = (A_1, B_1, …, A_K, B_K [m/s²], drift…); ``rss``
    [(m/s²)²]; ``logdet`` = ln det X⊥ᵀX⊥; ``residuals`` [m/s²]; ``jac`` (n, 2K) the Jacobian
    of the projected residual; ``minv`` (2K, 2K) = (X⊥ᵀX⊥)⁻¹ [1]; ``n_drift`` drift columns.
    """

    n_modes: int
    theta: np.ndarray
    beta: np.ndarray
    rss: float
    logdet: float
    residuals: np.ndarray
    jac: np.ndarray
    minv: np.ndarray
    n_drift: int
    converged: bool
    message: str

    @property
    def p(self) -> np.ndarray:
        """Decay rates [1/s] (K,)."""
        return mm.rates(self.theta)[0]

    @property
    def omega_d(self) -> np.ndarray:
        """Damped angular frequencies [rad/s] (K,)."""
        return mm.rates(self.theta)[1]

    @property
    def f_d(self) -> np.ndarray:
        """Damped frequencies [Hz] (K,)."""
        return self.omega_d / (2 * np.pi)

    @property
    def amplitudes(self) -> np.ndarray:
        """Acceleration envelope amplitudes √(A_i² + B_i²) at the window start [m/s²] (K,),
        as fitted (the decimation filter's gain not removed)."""
        b = np.asarray(self.beta[:2 * self.n_modes]).reshape(-1, 2)
        return np.hypot(b[:, 0], b[:, 1])

    @property
    def q(self) -> int:
        """Linear coefficients: 2K amplitudes and the drift terms."""
        return 2 * self.n_modes + self.n_drift

    @property
    def found(self) -> bool:
        """Whether the least squares found an optimum at all (finite θ; it may still not
        have converged)."""
        return bool(np.all(np.isfinite(self.theta)))

    @classmethod
    def failed(cls, n: int, m: int, n_drift: int, message: str) -> "ModeFit":
        """A fit of ``n`` modes to ``m`` samples that found no optimum (NaN everywhere)."""
        return cls(n, np.full(2 * n, np.nan), np.full(2 * n + n_drift, np.nan), np.inf,
                   np.nan, np.full(m, np.nan), np.full((m, 2 * n), np.nan),
                   np.full((2 * n, 2 * n), np.nan), n_drift, False, message)


def start_grid(starts: np.ndarray, span: float) -> np.ndarray:
    """:data:`GRID_PER_START` rows per start row of θ, start by start: its last mode's rate ×
    :data:`GRID_RATE_FACTORS` and its frequency shifted by :data:`GRID_CELL_SHIFTS`
    resolution cells 1/``span`` (``span`` T [s])."""
    rows = []
    for th in starts:
        w = math.exp(th[-1])
        for factor in GRID_RATE_FACTORS:
            for cells in GRID_CELL_SHIFTS:
                row = th.copy()
                row[-2] += math.log(factor)
                row[-1] = math.log(max(w + 2 * math.pi * cells / span, 0.5 * w))
                rows.append(row)
    return np.array(rows)


def _admissible(theta: np.ndarray, band: tuple[float, float] | None, span: float) -> bool:
    """θ in the prior support (MK3) and no two modes within one resolution cell 1/``span``
    (``band`` [Hz] None: every θ)."""
    if band is None:
        return True
    th = mm.order(theta)[0]
    lw = np.log(2 * np.pi * np.asarray(band, dtype=float))
    f = mm.rates(th)[1] / (2 * np.pi)
    return bool(np.isfinite(mm.log_prior(th, lw[0], lw[1]))
                and (f.size < 2 or np.min(np.diff(f)) * span >= 1.0))


def _ranked_starts(n: int, grid: np.ndarray, args) -> np.ndarray:
    """The best row of each start's block of :data:`GRID_PER_START` rows in ``grid`` (by
    projected RSS, evaluated :data:`GRID_BATCH` rows at a time), the starts ordered by it."""
    rss0 = np.concatenate([np.asarray(_rss_batch(n, _pad_rows(grid[i:i + GRID_BATCH],
                                                               GRID_BATCH), *args))
                           for i in range(0, len(grid), GRID_BATCH)])[:len(grid)]
    rss0 = np.where(np.isfinite(rss0), rss0, np.inf).reshape(-1, GRID_PER_START)
    best_row = np.argmin(rss0, axis=1) + GRID_PER_START * np.arange(len(rss0))
    return grid[best_row[np.argsort(rss0.min(axis=1), kind="stable")]]


def _run_lm(n, rows, args, max_steps, band, span):
    """Levenberg–Marquardt from ``rows`` of θ in order, :data:`N_LM` at a time (one vmapped
    batch), until a batch yields an optimum inside the prior support with its modes more than
    one resolution cell apart (:func:`_admissible`): (rss, θ, result code, steps) of that
    batch's best such optimum, None if no row gives one."""
    for i in range(0, len(rows), N_LM):
        batch = rows[i:i + N_LM]
        th, rss, code, steps = (np.asarray(v) for v in _fit_batch(
            n, int(max_steps), _pad_rows(batch, N_LM), *args))
        best = None
        for j in range(len(batch)):
            if not (np.isfinite(rss[j]) and np.all(np.isfinite(th[j]))):
                continue
            if _admissible(th[j], band, span) and (best is None or rss[j] < best[0]):
                best = (float(rss[j]), th[j], int(code[j]), int(steps[j]))
        if best is not None:
            return best
    return None


def _pad_rows(rows: np.ndarray, size: int) -> np.ndarray:
    return np.concatenate([rows, np.repeat(rows[-1:], size - len(rows), 0)])


def fit_modes(fd: FitData, starts, *, band: tuple[float, float] | None = None,
              max_steps: int = LM_STEPS) -> ModeFit:
    """K-mode least squares of ``fd`` from the start rows ``starts`` (b, 2K) of θ (MK2), the
    last mode of each row being the one to search around (module docstring); with ``band``
    [Hz] only optima inside the prior support (MK3) with no two modes within one resolution
    cell count. Modes are numbered by frequency.
    Raises :class:`InputError` if ``fd`` cannot support K modes; failure to converge is data
    (``converged=False``)."""
    starts = np.atleast_2d(np.asarray(starts, dtype=float))
    n = mm.n_modes(starts)
    why = support(fd, n)
    if why:
        raise InputError(why)
    m, n_drift = fd.tau.size, fd.drift_degree + 1
    with jax.enable_x64(True):
        args = padded_arrays(fd)
        span = float(fd.tau[-1] - fd.tau[0])
        rows = _ranked_starts(n, start_grid(starts, span), args)
        best = _run_lm(n, rows, args, max_steps, band, span)
        for _ in range(RESTARTS):  # a slow valley (a heavily damped mode): go on from there
            if best is None or best[2] == 0:
                break
            again = _run_lm(n, best[1][None], args, max_steps, band, span)
            if again is None or again[0] > best[0] * (1 + 1e-12):
                break
            best = again
        if best is None:
            return ModeFit.failed(n, m, n_drift, NO_OPTIMUM)
        theta = mm.order(best[1])[0]
        beta, rss, logdet, resid, jac, minv = (np.asarray(v) for v in
                                               _details(n, theta, *args))
    q = 2 * n + n_drift
    finite = bool(np.isfinite(rss) and np.all(np.isfinite(jac[:m])))
    ok = best[2] == 0 and finite
    msg = "converged" if ok else (f"optimistix result code {best[2]} after {best[3]} steps"
                                  if finite else "non-finite profile at the optimum")
    return ModeFit(n_modes=n, theta=theta, beta=beta[:q], rss=float(rss), logdet=float(logdet),
                   residuals=resid[:m], jac=jac[:m], minv=minv[:2 * n, :2 * n],
                   n_drift=n_drift, converged=ok, message=msg)
