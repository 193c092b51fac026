r"""Posterior of every mode's frequency and damping (emcee over the 2K nonlinear parameters).

Model and priors
----------------
The K-mode model (MK1) of :mod:`dampfit.model.modes` for the K chosen by
:func:`dampfit.inference.modes_select.select`, with the one profile likelihood of
:mod:`dampfit.model.profile` (P3: amplitudes, drift and σ marginalised) tempered by 1/r, r the
largest per-mode Whittle factor of the chosen fit's residuals (each floored at its
white-noise value, :mod:`dampfit.inference.noise`) — as the one-mode posterior
(:mod:`dampfit.inference.posterior`), which this is for K = 1. The prior is the ordered prior
(MK3–MK4): ln p_i log-uniform on [10⁻⁶·ω_i, 0.2·ω_i], and ln ω_i uniform over **its basin**
(:func:`basins`): the part of the modal band nearer (in ln ω) to the selection's i-th mode
than to its neighbours, so ω_1 < … < ω_K and the modes are numbered by frequency in every
draw (no label switching), and each mode stays the component the selection found. Without
the basins a walker could leave a well-separated mode for a better optimum elsewhere: on a
real phone on a spring (amplitude-dependent damping) the 2.85 Hz component's walkers moved
to 0.716 Hz, beside the 0.714 Hz mode, splitting it — a different model, not the
posterior of the modes found. For separated modes the basins lie hundreds of posterior sd
away and change nothing.

Per mode, from every draw of (p_i, ω_i) (:func:`dampfit.physics.quantities`):
f_n = ω_n/2π and f_d [Hz], ζ = p/ω_n, p [1/s], the loss factor η = 2ζ, the logarithmic
decrement Λ = 2π·p/ω_d and Q = 1/(2ζ) [1]; the acceleration amplitude √(A_i² + B_i²) [m/s²]
at the window start from the conditional Gaussian of (A_i, B_i) given θ (the decimation
filter's gain removed). c = 2·m·p [N·s/m], k = m·ω_n² [N/m], c_crit [N·s/m] and
u₀ = √(A² + B²)/ω_n² [m] (eq. M2) only for the mode the mass belongs to: the mode given, or
by default (:func:`mode_of_mass_default`, used only when no one-mode analysis names the
fundamental) the mode with the largest *displacement* energy ½·(a_i/ω_i²)²·Σ_τ e^{−2p_iτ}
in the window — never the largest acceleration, which grows with ω² and would favour a
higher mode (issue 34: a 0.23 kg cantilever's 50 Hz second mode was named the mass's, with
c 6.5× the 7.85 Hz fundamental's); the other modes have no modal mass in a free decay.

Sampling
--------
emcee's ensemble with dampfit's moves (:func:`dampfit.inference.posterior.ensemble`; 64
walkers, or 32·K if more), started in a ball from the Laplace covariance of the selection,
run by :func:`dampfit.inference.posterior.run_adaptive` (≥ 50 autocorrelation times, R-hat
< 1.01, bulk ESS ≥ ``min_ess`` over the 2K dimensions). R-hat and bulk ESS of every reported
quantity of every mode come from arviz (walkers as chains).

Bounded work
------------
In an analysis the run gets a :class:`~dampfit.inference.law_sampler.Budget`
(:func:`budget`) counted in **steps**: at most :data:`STEPS_PER_MODE` × K steps. Steps, not
seconds: the same command with the same seed then gives the same numbers on any machine and
under any load (issue 34: a wall-time budget stopped the same run of a lab cantilever after
342 steps once and 630 the next, R-hat 1.040 against 1.018). A wall-time limit is opt-in
(``max_seconds``); a run it stops says so — ``converged`` False, ``stop_reason`` "wall-time
budget reached … after N steps; ``max_steps`` N reproduces this stop on any machine" — and
so does a run stopped by its step budget ("step budget reached …"), with a warning that the
modes' intervals are not reliable. A run that converges inside the budget is unchanged (the
budget only stops a run between two blocks). What it stops: the 40 cm cantilever run
11-41-04 (paper/modes.md), whose first mode the selection splits into a weak pair — the
least squares put the weak component at 9.14 Hz, the walkers drift to ≈ 9.36 Hz with ζ down
to its prior bound, a posterior with more than one mode: after 3000 steps τ ≈ 37 steps and
ESS 1335 passed, but R-hat stayed 1.05, so the run went on in 50-step blocks towards
``max_steps`` (776 s). Without a budget (``budget=None``, the default of :func:`sample`) only
``max_steps`` bounds the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from dampfit import physics
from dampfit._options import DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, DEFAULT_SEED
from dampfit._progress import stage_bar
from dampfit.inference import posterior as _post
from dampfit.inference.executables import kernel
from dampfit.inference.law_sampler import Budget
from dampfit.inference.least_squares import amplitude_gain
from dampfit.inference.modes import check_mode_of_mass, padded_arrays
from dampfit.inference.modes_select import psd_ratios
from dampfit.inference.sampler_run import ReadsRun, SamplerRun, to_idata
from dampfit.model import modes as mm
from dampfit.model import profile

#: Step budget of the modal posterior per mode [steps] (K modes: K × this).
STEPS_PER_MODE = 4000
#: Quantities reported for every mode, and for the mode of the mass only.
PER_MODE = ("f_n", "f_d", "zeta", "p", "eta", "delta", "Q", "accel_amplitude")
MASS_MODE = ("c", "k", "c_crit", "u0", "mass")
#: Blob fields per mode: conditional mean and covariance of (A_i, B_i).
_BLOB = 5


@dataclass(frozen=True)
class ModalPosterior(ReadsRun):
    """Posterior of K modes: ``run`` the emcee run
    (:class:`~dampfit.inference.sampler_run.SamplerRun`; its ``idata`` has per-mode variables
    with a ``mode`` dimension 1 … K, mass-mode variables none, and its ``diagnostics`` name →
    list (per mode) or dict of {"r_hat", "ess_bulk"}; read through: ``converged``,
    ``n_steps``, ``warnings`` …), ``n_modes`` K, ``mode_of_mass`` (0-based) and ``temper``
    = 1/r."""

    run: SamplerRun
    n_modes: int
    mode_of_mass: int
    temper: float

    def sampling(self) -> dict:
        """JSON-safe facts about the run (:meth:`SamplerRun.sampling`)."""
        return self.run.sampling()

    def draws(self, name: str) -> np.ndarray:
        """Flattened draws of ``name``: (n, K) for a per-mode quantity, (n,) otherwise."""
        v = np.asarray(self.idata.posterior[name])
        return v.reshape((-1,) + v.shape[2:])

    def summary(self) -> list[dict]:
        """One plain dict per mode (by frequency): ``index`` (1-based), ``mass_mode``, and
        for each quantity ``{"mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk"}`` with
        its ``unit``."""
        out = []
        for i in range(self.n_modes):
            row: dict = {"index": i + 1, "mass_mode": i == self.mode_of_mass}
            for name in PER_MODE:
                row[name] = _stats(self.draws(name)[:, i], self.diagnostics[name][i], name)
            if i == self.mode_of_mass:
                for name in MASS_MODE:
                    if name in self.idata.posterior:
                        row[name] = _stats(self.draws(name), self.diagnostics[name], name)
            out.append(row)
        return out


_UNITS = dict(physics.UNITS, eta="1", accel_amplitude="m/s^2")


def _stats(x, diag, name) -> dict:
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
            "q50": float(q50), "q95": float(q95), "r_hat": diag["r_hat"],
            "ess_bulk": diag["ess_bulk"], "unit": _UNITS.get(name, "1")}


@kernel(static_argnums=(0,))
def _batched_log_prob(n, thetas, samples, temper, bounds):
    """(tempered ln posterior, per-mode conditional moments of (A_i, B_i)) for a batch of θ;
    ``samples`` a :class:`~dampfit.model.profile.Samples`."""
    mdl = mm.model(n)

    def one(theta):
        inside = jnp.isfinite(mm.log_prior(theta, bounds[0], bounds[1], xp=jnp))
        ll, ab, cov = profile.marginal_and_amplitudes(mdl, theta, samples, temper)
        blobs = jnp.stack([jnp.stack([ab[2 * i], ab[2 * i + 1], cov[2 * i, 2 * i],
                                      cov[2 * i, 2 * i + 1], cov[2 * i + 1, 2 * i + 1]])
                           for i in range(n)]).reshape(-1)
        return jnp.where(inside & jnp.isfinite(ll), ll, -jnp.inf), blobs

    return jax.vmap(one)(thetas)


def walkers(k: int) -> int:
    """Walkers of the K = ``k`` posterior's ensemble: 64, or 32 per mode if more."""
    return max(_post.N_WALKERS, 32 * k)


def warm_log_prob(fd, theta, band) -> None:
    """Compile (or load from the store) the batched log-probability :func:`sample` runs for
    K = len(θ)/2 modes on ``fd``'s padded shapes, at every batch size it evaluates (the whole
    ensemble at the start; a half ensemble per KDE or DE move, a quarter per DE-snooker move:
    emcee's ``nsplits``); ``theta`` (2K,) and ``band`` [Hz] need only be finite
    (:mod:`dampfit.inference.modes_warm`)."""
    theta = np.asarray(theta, dtype=np.float64)
    k = mm.n_modes(theta)
    with jax.enable_x64(True):
        log_prob = _make_log_prob(k, fd, basins(np.exp(theta[1::2]), band), 1.0)
        for size in (walkers(k), walkers(k) // 2, walkers(k) // 4):
            log_prob(np.tile(theta, (size, 1)))


def _make_log_prob(n, fd, lw, temper):
    """ln posterior of θ batches (and the amplitude blobs); ``lw`` (2, K) the basins."""
    with jax.enable_x64(True):
        samples = profile.Samples(*padded_arrays(fd), *jax.device_put(
            (np.float64(fd.tau.size), np.float64(fd.drift_degree + 1))))
        rest = jax.device_put((np.float64(temper), np.asarray(lw, dtype=np.float64)))

    def log_prob(thetas):  # called inside jax.enable_x64(True)
        lp, blobs = _batched_log_prob(n, np.asarray(thetas, dtype=np.float64), samples, *rest)
        return np.column_stack([np.asarray(lp), np.asarray(blobs)])

    return log_prob


def mode_of_mass_default(fit, fd) -> int:
    """Index (0-based) of the mode of a :class:`~dampfit.inference.modes.ModeFit` with the
    largest displacement energy ½·(a_i/ω_i²)²·Σ_τ e^{−2p_iτ} (a_i its gain-corrected
    acceleration amplitude [m/s²], ω_i² = p_i² + ω_d,i² [rad²/s²]): the mode the recording
    was released in, not the largest acceleration (∝ ω² × displacement)."""
    tau = np.asarray(fd.tau, dtype=float)
    energy = [0.5 * (a / abs(amplitude_gain(fd, p, w)) / (p * p + w * w)) ** 2
              * np.sum(np.exp(-2 * p * tau))
              for a, p, w in zip(fit.amplitudes, fit.p, fit.omega_d)]
    return int(np.argmax(energy))


def basins(omega_d, band) -> np.ndarray:
    """(2, K) ln ω bounds [ln(rad/s)] of each mode's basin: from the geometric midpoint to
    the mode below (the band's lower edge for the first) to the midpoint to the mode above
    (the upper edge for the last); ``omega_d`` [rad/s] the selection's modes by frequency,
    ``band`` [Hz] the modal band."""
    lnw = np.log(np.asarray(omega_d, dtype=float))
    edges = np.log(2 * np.pi * np.asarray(band, dtype=float))
    mids = 0.5 * (lnw[1:] + lnw[:-1])
    return np.stack([np.concatenate([[edges[0]], mids]), np.concatenate([mids, [edges[1]]])])


def _start(theta, cov, lw, rng, n_walkers) -> np.ndarray:
    """Walkers in a ball around θ̂ from ``cov``, all inside the ordered support."""
    k = theta.size
    cov = np.asarray(cov, dtype=float)
    if not np.all(np.isfinite(cov)) or np.linalg.eigvalsh(cov).min() <= 0:
        cov = np.diag((1e-3 * np.abs(theta) + 1e-6) ** 2)
    cov = cov + np.diag(np.full(k, _post.START_SPREAD_FLOOR**2))
    out = np.empty((0, k))
    for scale in (0.25, 0.05, 0.01, 0.0):
        draw = rng.multivariate_normal(theta, scale * cov, size=4 * n_walkers) if scale else \
            np.repeat(theta[None], n_walkers, 0)
        ok = np.isfinite(mm.log_prior(draw, lw[0], lw[1]))
        out = np.concatenate([out, draw[ok]])
        if len(out) >= n_walkers:
            break
    return out[:n_walkers]


def budget(n_modes: int, max_seconds: float | None = None) -> Budget:
    """The modal posterior's budget of the module docstring for ``n_modes`` modes:
    :data:`STEPS_PER_MODE` × K steps; ``max_seconds`` [s] an opt-in wall-time limit (None:
    none — the default of an analysis, so that its numbers do not depend on the machine)."""
    k = int(n_modes)
    basis = f"{STEPS_PER_MODE} steps per mode x {k} modes"
    sec = None
    if max_seconds is not None and math.isfinite(max_seconds) and max_seconds > 0:
        sec = float(max_seconds)
        basis += f"; a wall-time limit of {sec:.3g} s"
    return Budget(max_steps=STEPS_PER_MODE * k, max_seconds=sec, basis=basis)


def sample(sel, *, mass: float | None = None, mass_sd: float = 0.0,
           mode_of_mass: int | None = None, seed: int = DEFAULT_SEED, min_ess: float = DEFAULT_MIN_ESS,
           max_steps: int = DEFAULT_MAX_STEPS, budget: Budget | None = None) -> ModalPosterior:
    """Sample the posterior of the chosen K of ``sel`` (a
    :class:`~dampfit.inference.modes_select.ModeSelection`); see the module docstring.

    ``mass``, ``mass_sd`` [kg] (checked where they were given: :class:`dampfit.physics.Mass`);
    ``mode_of_mass`` the 1-based mode the mass belongs to (None: the dominant one;
    :class:`~dampfit.errors.InputError` if out of range); ``seed`` makes the run reproducible.
    ``budget`` (:func:`budget`; None: none) bounds the run together with ``max_steps``
    [steps]; a run it stops has ``converged`` False, its ``stop_reason`` and a warning.
    """
    res, fd = sel.chosen, sel.fit_data
    k = res.n_modes
    i_mass = check_mode_of_mass(mode_of_mass, k)
    if i_mass is None:
        i_mass = mode_of_mass_default(res.fit, fd)
    temper = 1.0 / float(np.max(psd_ratios(res.fit, fd)))
    rng = np.random.default_rng(seed)
    n_walkers = walkers(k)
    lw = basins(res.fit.omega_d, sel.band)
    cov = res.cov / (res.psd_ratio * temper)  # the Laplace covariance (∝ r) at this r
    start = _start(res.fit.theta, cov, lw, rng, n_walkers)
    steps_allowed = int(max_steps if budget is None else min(max_steps, budget.max_steps))
    sampler = _post.ensemble(2 * k, _make_log_prob(k, fd, lw, temper), rng, n_walkers)
    with stage_bar(steps_allowed, f"modes: K = {k}, posterior") as bar:
        run = _post.run_adaptive(sampler, start, min_ess=min_ess, max_steps=max_steps,
                                 x64=True, bar=bar, budget=budget)
    warns = [] if run.converged else [run.not_converged(
        "modal posterior", f"the intervals of the {k} modes are not reliable")]
    idata = _to_idata(run, fd, res.fit, i_mass, (mass, mass_sd), temper, rng)
    return ModalPosterior(run=run.finish(idata, warns), n_modes=k, mode_of_mass=i_mass,
                          temper=temper)


def _to_idata(run: SamplerRun, fd, fit, i_mass: int, mass: tuple, temper: float, rng):
    """Every mode's quantities, and the mass's mode's c, k, u₀, of each kept draw of ``run``
    (``mass`` = (value, sd) [kg])."""
    dim = run.draws.shape[-1]
    k = dim // 2
    flat = run.draws.reshape(-1, dim)
    p, wd = mm.rates(flat)
    mom = np.asarray(run.blobs).reshape(-1, k, _BLOB)
    gains = np.array([abs(amplitude_gain(fd, float(a), float(b)))
                      for a, b in zip(fit.p, fit.omega_d)])
    amp = np.column_stack([np.hypot(*_post.conditional_amplitudes(mom[:, i], rng).T)
                           for i in range(k)]) / gains
    q = physics.quantities(p, wd, accel_amplitude=amp)
    post = {name: q[name] for name in ("f_n", "f_d", "zeta", "p", "delta", "Q")}
    post["eta"] = 2.0 * q["zeta"]
    post["accel_amplitude"] = amp
    m = _post.mass_draws(mass[0], mass[1], p.shape[0], rng)
    qm = physics.quantities(p[:, i_mass], wd[:, i_mass], m, accel_amplitude=amp[:, i_mass])
    post["u0"] = qm["u0"]
    if m is not None:
        post.update({"mass": m, "c": qm["c"], "k": qm["k"], "c_crit": qm["c_crit"]})
    return to_idata(post, run.n_walkers, log_prob=run.log_prob,
                    dims={name: ["mode"] for name in PER_MODE},
                    coords={"mode": np.arange(1, k + 1)},
                    attrs={"n_walkers": run.n_walkers, "likelihood_temper": float(temper)})


def modal_summary(sel, post: ModalPosterior, *, keep: int | None = None,
                  split=()) -> dict:
    """Plain data of a multi-mode analysis (for the outputs): ``n_modes`` (the identified
    modes); ``n_components`` K; ``modes_evidence``
    (:meth:`~dampfit.inference.modes_select.ModeSelection.summary`: P(K), the reasons);
    ``modes`` the components that pass :func:`dampfit.inference.modes_checks.check_components`
    (``keep`` the fundamental, always kept; ``split`` its split partners, 0-based), each
    ``"identified": True``, :meth:`ModalPosterior.summary` with ``crlb_sd`` of f_n, ζ, p, ω_d
    from :func:`dampfit.inference.modes_close.selection_bounds` and ``least_squares``: the
    K-mode least-squares f_n [Hz], ζ, p [1/s] with their Laplace 90 % intervals,
    :meth:`~dampfit.inference.modes_select.KResult.laplace_intervals` — listed in a warning
    when the posterior did not converge); ``modes_seen`` the others (``index``, ``f_n``,
    ``zeta``, ``kind``, ``reason``); ``pairs`` (separation and CRLB inflation of every pair
    of components); ``rayleigh`` (:func:`dampfit.physics_modal.rayleigh_summary` of the
    identified modes' draws, None below two); ``mode_of_mass`` (1-based component);
    ``psd_ratio`` r; ``warnings`` and ``notes``."""
    from dampfit import physics_modal
    from dampfit.inference import modes_checks, modes_close

    rows = post.summary()
    for row, bound in zip(rows, modes_close.selection_bounds(sel)):
        row["crlb_sd"] = {q: bound[q]["sd"] for q in ("f_n", "zeta", "p", "omega_d")}
    laplace = sel.chosen.laplace_intervals()
    for row, est in zip(rows, laplace):
        row["least_squares"] = {q: {"value": est[q][0], "q05": est[q][1], "q95": est[q][2],
                                    "unit": _UNITS.get(q, "1")} for q in ("f_n", "zeta", "p")}
    fit = sel.chosen.fit
    failed = modes_checks.check_components(
        rows, f_d=fit.f_d, p=fit.p, amplitudes=fit.amplitudes, span=sel.span,
        basins_hz=np.exp(basins(fit.omega_d, sel.band)) / (2 * np.pi), keep=keep, split=split)
    modes = [dict(row, identified=True, fundamental=i == keep) for i, row in enumerate(rows)
             if i not in failed]
    seen = [{"index": i + 1, "f_n": rows[i]["f_n"], "zeta": rows[i]["zeta"], "kind": kind,
             "reason": why} for i, (kind, why) in sorted(failed.items())]
    pairs, pair_warnings = modes_close.selection_pairs(sel)
    warns = list(sel.warnings) + pair_warnings + list(post.warnings)
    if not post.converged:
        listed = "; ".join(f"mode {i} f_n {m['f_n'][0]:.5g} Hz [{m['f_n'][1]:.5g}, "
                           f"{m['f_n'][2]:.5g}], zeta {m['zeta'][0]:.3g} [{m['zeta'][1]:.3g}, "
                           f"{m['zeta'][2]:.3g}]" for i, m in enumerate(laplace, start=1))
        warns.append("the modes' least-squares optima with their Laplace 90 % intervals "
                     f"(modes[i].least_squares), to read instead: {listed}")
    if seen:
        warns.append("seen, not modes (no zeta row, no Rayleigh, no deck; modes_seen): " + "; ".join(
            f"{e['f_n']['q50']:.5g} Hz ({e['kind']}: {e['reason']})" for e in seen))
    if post.mode_of_mass in failed:
        warns.append(f"the mass's mode (component {post.mode_of_mass + 1}) is not identified "
                     f"({failed[post.mode_of_mass][0]}): its c and k are not reported")
    rayleigh = None
    ident = [i for i in range(post.n_modes) if i not in failed]
    if len(ident) >= 2:
        rayleigh = physics_modal.rayleigh_summary(2 * np.pi * post.draws("f_n")[:, ident],
                                                  post.draws("zeta")[:, ident])
        warns += rayleigh["warnings"]
    return {"n_modes": len(ident), "n_components": post.n_modes,
            "modes_evidence": sel.summary(), "modes": modes, "modes_seen": seen,
            "pairs": pairs, "rayleigh": rayleigh, "mode_of_mass": post.mode_of_mass + 1,
            "psd_ratio": 1.0 / post.temper, "warnings": warns, "notes": list(sel.notes)}
