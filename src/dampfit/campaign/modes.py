r"""Several modes in the tests of a campaign: the pooled mode and the others, listed per test.

A campaign pools **one** mode of the damper: the one every test's window and band isolate
(the one-mode path of :func:`dampfit.signal.prepare.prepare`: the dominant mode by default; a
``band`` pools another). With ``max_modes`` > 1 each test is also analysed for several modes
on its own, as a single recording is (:func:`dampfit.stages.modes_stage` on the test's
prepared signal with its one-mode least squares and damping verdict: the screen, K chosen by
evidence, the posterior of every mode, a split pair explained). A test whose screen or
evidence finds one mode lists none beside the pooled one (``n_modes`` 1, the evidence's
``reason``). No modal mass is invented for the other modes: they
report f_n [Hz] and ζ [1] in every damping convention (η, Λ, Q), with their intervals, and the
test's Rayleigh α [1/s], β [s] where it has two modes or more. The pooled mode of a test is the
one whose posterior median f_n is nearest the test's own natural frequency ω̂_n/2π of the
pooling (ψ̂ = (ln p, ln ω_n) of :class:`~dampfit.campaign.tests.TestFit`).

A test that cannot support several modes (too short, too few samples per cycle) keeps its
place in the pooling; its entry says why (``reason``) and a warning names it.
"""

from __future__ import annotations

import math
from typing import Any

#: Fields of a mode row kept per test (no c, k, u₀: no modal mass for a campaign's modes).
MODE_FIELDS = ("index", "f_n", "f_d", "zeta", "eta", "delta", "Q", "p", "crlb_sd",
               "least_squares")


def pooled_index(modes: list[dict[str, Any]], f_pooled: float) -> int | None:
    """1-based index of the mode whose median f_n [Hz] is nearest ``f_pooled`` [Hz]."""
    best, index = math.inf, None
    for i, row in enumerate(modes, start=1):
        f = (row.get("f_n") or {}).get("q50")
        if isinstance(f, (int, float)) and math.isfinite(f) and abs(f - f_pooled) < best:
            best, index = abs(f - f_pooled), i
    return index


def _entry(st, f_pooled: float, max_modes: int) -> dict[str, Any]:
    """The plain-data entry of one test from its :class:`~dampfit.stages.modes.ModesStage`."""
    summary = st.summary or {"modes": [], "n_modes": st.n_modes}
    modes = [{k: row[k] for k in MODE_FIELDS if k in row} for row in summary["modes"]]
    pooled = pooled_index(modes, f_pooled) if modes else 1
    for i, row in enumerate(modes, start=1):
        row["pooled"] = i == pooled
    sampling = summary.get("sampling") or {}
    return {"max_modes": max_modes, "n_modes": st.n_modes, "pooled_mode": pooled,
            "modes": modes, "modes_evidence": st.evidence,
            "rayleigh": summary.get("rayleigh"),
            "converged": sampling.get("posterior_converged"),
            "warnings": list(st.warnings), "reason": None}


def per_test_modes(fits, max_modes: int, sampler) -> list[str]:
    """Run the modes stage on every test of ``fits`` (:class:`~dampfit.campaign.tests.TestFit`,
    their ``modes`` set in place to the plain-data entry of this module) and return the
    campaign warnings it raises (a test that cannot support several modes, a modal
    posterior that did not converge, a close pair that may be the pooled mode split);
    ``sampler`` the run's :class:`~dampfit._options.SamplerSettings`."""
    import numpy as np

    from dampfit import stages
    from dampfit._progress import progress_bar

    warns: list[str] = []
    with progress_bar(len(fits), "modes per test", unit="test",
                      enabled=sampler.progress) as bar:
        for t in fits:
            label = f"test {t.index + 1} ({t.name})"
            st = stages.modes_stage(t.prepared, max_modes=max_modes, sampler=sampler,
                                    one_mode=stages.OneMode(t.least_squares.p,
                                                            t.least_squares.omega_d,
                                                            t.damping_verdict))
            if st.n_modes is None:
                reason = str(st.evidence.get("reason"))
                t.modes = {"max_modes": max_modes, "n_modes": None, "pooled_mode": None,
                           "modes": [], "reason": reason}
                warns.append(f"{label}: {reason}")
            else:
                f_pooled = float(np.exp(t.psi_hat[1]) / (2 * np.pi))
                t.modes = _entry(st, f_pooled, max_modes)
                if t.modes["converged"] is False:
                    warns.append(f"{label}: the posterior of its {t.modes['n_modes']} modes "
                                 "did not converge; their intervals are not reliable (each "
                                 "mode's least_squares is)")
                warns.extend(f"{label}: {w}" for w in st.split)
            bar.update(1)
    return warns
