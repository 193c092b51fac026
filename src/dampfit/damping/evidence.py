r"""Which damping law? Evidence comparison with one calibrated noise model.

**Criterion.** Each law's log evidence ln Z (:func:`dampfit.inference.law_fit.laplace`: Laplace for
the viscous law; for the others the shape parameter integrated numerically and the rest by
Laplace, eq. L3) with the likelihood tempered by the *same* Whittle factor r for every law. r is measured on the
residuals of the best-fitting law (smallest RSS), the best available estimate of the noise
alone; a viscous fit to amplitude-dependent data leaves misfit at f₀ that would otherwise
inflate r and mute the evidence. Tempering by 1/r makes the likelihood-ratio statistic of
nested laws ≈ χ² under the null even for coloured or decimated noise (the information about
the envelope sits at f₀, where r rescales it), so ln Z is comparable across laws.

**Why not pointwise LOO/WAIC.** PSIS-LOO treats samples as conditionally independent; these
residuals are correlated (coloured phone noise, low-pass and decimation, misfit at f₀), and the
envelope parameters are informed by the whole decay, so leaving out one sample changes
nothing and LOO reduces to AIC with a too-small standard error. The evidence with
proper priors on the shape parameter (friction or drag fraction f ∈ [0, 1], exponent α ∈ [0, 3])
charges the Occam factor that an extra nonlinear parameter deserves, is exact for a Gaussian
posterior in the other parameters, and costs a few dozen least-squares fits, so many
replicates can check its false-alarm rate (``tests/recovery/test_damping_checks.py``: 0 of 60
realistic viscous phone recordings flagged).

**Standard error.** ``dse`` is the LOO-style standard error of a law's difference in tempered
log likelihood from the best law, from one-cycle blocks: dse = √(B·var_b(ℓ_b − ℓ_b^best)).
Blocks of a cycle keep the correlated residuals of one cycle together.

**Model prior and verdict.** Prior odds 1 : 1 between "one viscous c" and "amplitude-dependent"
(1/2 for viscous, 1/6 for each nonlinear law: each law's ``prior_weight``,
:func:`dampfit.model.registry.prior_weights`). Posterior model probabilities are the
``weight`` column. Amplitude dependence is *detected* when P(viscous | data) <
:data:`P_VISCOUS_MAX`; the preferred law is then the most probable nonlinear one, else viscous.
"""

from __future__ import annotations

import numpy as np

from dampfit.inference import law_fit
from dampfit.model import laws, registry


def model_prior() -> dict[str, float]:
    """Prior model probabilities of the registered laws (1 : 1 between viscous and
    amplitude-dependent for the four built-in ones): :func:`dampfit.model.registry.prior_weights`."""
    return registry.prior_weights()

#: Amplitude dependence is reported when P(viscous | data) falls below this.
P_VISCOUS_MAX = 0.05


def _block_loglik(mf: law_fit.ModelFit, data: law_fit.Data, blocks: np.ndarray, n_blocks: int):
    s2 = mf.rss / max(data.n - data.q - mf.k, 1)
    point = mf.temper * (-0.5 * np.log(2 * np.pi * s2) - 0.5 * mf.residuals**2 / s2)
    return np.bincount(blocks, weights=point, minlength=n_blocks)


def compare(fits: dict[str, law_fit.ModelFit], data: law_fit.Data, f0: float) -> tuple[list[dict], dict]:
    """The comparison table (best first) and the verdict, from Laplace-evaluated ``fits``.

    ``f0`` [Hz] sets the one-cycle blocks of ``dse``. Table rows: ``model``, ``k`` (nonlinear
    parameters), ``ln_evidence``, ``d_ln_evidence`` (≤ 0, from the best), ``dse``, ``weight``
    (posterior probability), ``loglik_tempered``, ``rss`` [(m/s²)²], ``converged``. The verdict:
    ``{"preferred", "amplitude_dependent", "p_viscous", "best_nonlinear", "bayes_factor_ln"}``.
    """
    names = [m for m in laws.names() if m in fits]
    lnz = np.array([fits[m].ln_evidence for m in names])
    weights = model_prior()
    prior = np.array([weights[m] for m in names])
    ok = np.isfinite(lnz)
    logw = np.where(ok, lnz + np.log(prior), -np.inf)
    weight = np.zeros(len(names))
    if ok.any():
        weight = np.exp(logw - np.max(logw[ok]))
        weight /= weight.sum()
    best = names[int(np.argmax(np.where(ok, lnz, -np.inf)))] if ok.any() else "viscous"
    blocks = np.floor(data.tau * f0).astype(int)
    blocks -= blocks.min()
    nb = int(blocks.max()) + 1
    ll_best = _block_loglik(fits[best], data, blocks, nb) if ok.any() else None
    rows = []
    for i, m in enumerate(names):
        mf = fits[m]
        dse = float("nan")
        if ll_best is not None and np.isfinite(mf.ln_evidence):
            d = _block_loglik(mf, data, blocks, nb) - ll_best
            dse = float(np.sqrt(nb * np.var(d, ddof=1))) if nb > 1 else float("nan")
        rows.append({
            "model": m, "k": mf.k, "ln_evidence": mf.ln_evidence,
            "d_ln_evidence": (mf.ln_evidence - fits[best].ln_evidence) if ok[i] else None,
            "dse": dse, "weight": float(weight[i]),
            "loglik_tempered": mf.temper * mf.loglik, "rss": mf.rss, "converged": mf.converged,
        })
    rows.sort(key=lambda r: -np.inf if r["ln_evidence"] is None or not np.isfinite(
        r["ln_evidence"]) else -r["ln_evidence"])
    p_visc = float(weight[names.index("viscous")]) if "viscous" in names else 0.0
    nonlin = [(weight[i], m) for i, m in enumerate(names) if m != "viscous" and ok[i]]
    best_nl = max(nonlin)[1] if nonlin else None
    detected = bool(ok[names.index("viscous")] and p_visc < P_VISCOUS_MAX and best_nl) \
        if "viscous" in names else bool(best_nl)
    bf = float("nan")
    if nonlin and "viscous" in names and ok[names.index("viscous")]:
        lz_nl = np.logaddexp.reduce([fits[m].ln_evidence for _, m in nonlin]) - np.log(len(nonlin))
        bf = float(lz_nl - fits["viscous"].ln_evidence)
    verdict = {"preferred": best_nl if detected else "viscous", "amplitude_dependent": detected,
               "p_viscous": p_visc, "best_nonlinear": best_nl, "bayes_factor_ln": bf}
    return rows, verdict
