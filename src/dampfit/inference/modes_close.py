r"""Close modes: how far apart each pair is, and how much each one's uncertainty suffers.

Two modes i, j with natural frequencies f_i < f_j [Hz] and damping ratios ζ_i, ζ_j are
separated by

    Δf = f_j − f_i [Hz],   s_hp = Δf / ((B_i + B_j)/2),   s_T = Δf·T,                        (C1)

B = 2ζ·f_n [Hz] the half-power bandwidth of a mode (the width of its resonance peak) and T
[s] the analysed window: s_hp counts half-power bandwidths, s_T frequency resolution cells
1/T. A pair with s_T < 1 is not separable in this record (its least squares is refused as
two modes by :mod:`dampfit.inference.modes_select`).

How much a neighbour costs is measured, not guessed: the Cramér–Rao bound of each mode's f_n
and ζ in the K-mode design (:func:`dampfit.inference.crlb.bound_modes`, the modes' columns
overlapping) divided by the bound of the same mode fitted alone on the same samples,

    g = sd_CRLB(with the other modes) / sd_CRLB(alone)   [1].                               (C2)

For well-separated modes g ≈ 1; as the separation falls below a few bandwidths the errors
grow as 1/gap to 1/gap³ (the columns become collinear). g of a pair is that of the pair's own
two-mode design (not of all K modes: a third mode, or the drift, inflating one member says
nothing about this pair). "Close" means close: a pair is **flagged** only when it lies within
:data:`CLOSE_HALF_POWER` half-power bandwidths or :data:`CLOSE_CELLS` resolution cells (C1)
*and* g of f_n or ζ of either member exceeds :data:`FLAG_INFLATION` (issue 34: six warnings
on one recording for pairs 100–600 cells apart). g is a ratio of bounds on the same samples,
so the noise level cancels (σ = 1 is used).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from dampfit import physics
from dampfit.errors import InputError
from dampfit.inference import crlb

#: CRLB inflation (C2) above which a pair is flagged in the warnings …
FLAG_INFLATION = 1.25
#: … when it is also within this many half-power bandwidths [1] …
CLOSE_HALF_POWER = 5.0
#: … or this many resolution cells 1/T [1] (C1).
CLOSE_CELLS = 5.0
#: A pair at the one-mode frequency closer than this many half-power bandwidths (C1) …
SPLIT_HALF_POWER = 3.0
#: … whose damping ratios differ by at least this factor is read as a possibly split mode.
SPLIT_DAMPING_RATIO = 3.0


def inflation(times, modes, drift_degree: int | None = 0) -> list[dict[str, float]]:
    """g of (C2) for f_n and ζ of every mode: ``[{"f_n": g, "zeta": g}, …]``.

    ``times`` [s] the fitted sample times, ``modes`` the (p [1/s], ω_d [rad/s], A, B [m/s²])
    of each mode (as in :func:`dampfit.inference.crlb.fisher_modes`)."""
    modes = [tuple(float(v) for v in m) for m in modes]
    together = crlb.bound_modes(times, 1.0, modes, drift_degree=drift_degree)
    out = []
    for i, mode in enumerate(modes):
        alone = crlb.bound_modes(times, 1.0, [mode], drift_degree=drift_degree)[0]
        out.append({q: together[i][q]["sd"] / alone[q]["sd"] for q in ("f_n", "zeta")})
    return out


def pairs(p, omega_d, amplitudes, times, drift_degree: int | None = 0) -> tuple[list[dict],
                                                                                 list[str]]:
    """Every pair of modes (C1) with the inflation (C2) of its members, and the warnings.

    ``p`` [1/s], ``omega_d`` [rad/s] and ``amplitudes`` (A_i, B_i) [m/s²] of each mode (the
    least-squares values), ``times`` [s] the fitted samples. Rows: ``{"modes": [i, j]``
    (1-based)``, "separation_hz", "separation_half_power", "separation_resolution",
    "inflation_f_n", "inflation_zeta", "flagged"}`` (inflation: the larger of the two modes').
    """
    p, wd = np.asarray(p, dtype=float), np.asarray(omega_d, dtype=float)
    amp = np.asarray(amplitudes, dtype=float).reshape(-1, 2)
    q = physics.quantities(p, wd)
    f, zeta = np.asarray(q["f_n"]), np.asarray(q["zeta"])
    t = np.asarray(times, dtype=float)
    span = float(t[-1] - t[0])
    rows, warns = [], []
    for i, j in itertools.combinations(range(p.size), 2):
        try:  # the pair's own two-mode design (module docstring)
            g = inflation(t, [(p[k], wd[k], *amp[k]) for k in (i, j)], drift_degree)
        except InputError:  # a singular design: the two are not separable at all
            g = [{"f_n": math.inf, "zeta": math.inf}] * 2
        df = abs(f[j] - f[i])
        half_power = 0.5 * (2 * zeta[i] * f[i] + 2 * zeta[j] * f[j])
        s_hp = float(df / half_power) if half_power > 0 else math.inf
        gf, gz = max(g[0]["f_n"], g[1]["f_n"]), max(g[0]["zeta"], g[1]["zeta"])
        near = s_hp < CLOSE_HALF_POWER or df * span < CLOSE_CELLS
        flagged = bool(near and (gf > FLAG_INFLATION or gz > FLAG_INFLATION))
        rows.append({"modes": [i + 1, j + 1], "separation_hz": float(df),
                     "separation_half_power": s_hp,
                     "separation_resolution": float(df * span),
                     "inflation_f_n": float(gf), "inflation_zeta": float(gz),
                     "flagged": flagged})
        if flagged:
            warns.append(
                f"modes {i + 1} and {j + 1} ({f[i]:.4g} and {f[j]:.4g} Hz) are close: "
                f"{rows[-1]['separation_half_power']:.2g} half-power bandwidths, "
                f"{df * span:.2g} resolution cells apart; their uncertainty is {gf:.2g}x (f) "
                f"and {gz:.2g}x (ζ) that of a lone mode")
    return rows, warns


def selection_pairs(sel) -> tuple[list[dict], list[str]]:
    """:func:`pairs` of the chosen fit of a
    :class:`~dampfit.inference.modes_select.ModeSelection` on its fit samples."""
    fit, fd = sel.chosen.fit, sel.fit_data
    return pairs(fit.p, fit.omega_d, fit.beta[:2 * fit.n_modes], fd.tau, fd.drift_degree)


def selection_bounds(sel) -> list[dict]:
    """Cramér–Rao bound of every mode of the chosen fit of ``sel`` on its own design: the fit
    samples' times, white noise at the level the residuals show near each mode —
    σ_i = √(r_i·RSS/(n − q)) per fitted sample, r_i the Whittle factor at mode i — and the
    fitted (p, ω_d, A, B) of every mode (:func:`dampfit.inference.crlb.bound_modes`; f_n, ζ,
    p, ω_d per mode; u₀ of the filtered samples)."""
    fit, fd = sel.chosen.fit, sel.fit_data
    s2 = fit.rss / max(fd.tau.size - fit.q, 1)
    amp = np.asarray(fit.beta[:2 * fit.n_modes]).reshape(-1, 2)
    modes = [(fit.p[i], fit.omega_d[i], *amp[i]) for i in range(fit.n_modes)]
    return [crlb.bound_modes(fd.tau, math.sqrt(r * s2), modes, drift_degree=fd.drift_degree)[i]
            for i, r in enumerate(sel.psd_ratios)]


def split_pair(modes: list[dict], pair_rows: list[dict], dominant: int, *,
               amplitude_dependent: bool = False) -> list[str]:
    """Warnings for a close pair that may be one mode split in two.

    A sum of viscous modes fitted to one mode whose damping depends on amplitude (friction,
    drag: ζ changes over the record) can absorb the non-exponential envelope into a second,
    close "mode": two modes beat, and a beat can mimic an envelope that is not exponential.
    The signature is a pair around the one-mode frequency, closer than
    :data:`SPLIT_HALF_POWER` half-power bandwidths (C1), whose damping ratios differ by
    :data:`SPLIT_DAMPING_RATIO` or more (seen in a real cantilever recording whose ζ falls by
    a third over the record: 9.358 / 9.405 Hz, ζ 0.0008 / 0.0055). Such a pair is not refused
    — two genuine close modes can look the same — but explained: compare the damping-law
    verdict, and take that mode's damping from the one-mode analysis.

    When the one-mode analysis has itself found the damping to depend on amplitude (or the
    viscous model to misfit: ``amplitude_dependent``), every such close pair is explained,
    whatever its damping ratios: the split is then the expected artefact (seen in a real 30 cm
    cantilever run, ζ falling 2× over the record, where three "modes" within 3 bandwidths of
    16.4 Hz had ζ only 2.5–2.8× apart).

    ``modes`` the summary entries (``f_n``, ``zeta`` with ``q50``), ``pair_rows`` those of
    :func:`pairs` (``modes`` 1-based), ``dominant`` the 0-based index of the mode at the
    one-mode frequency.
    """
    out = []
    for row in pair_rows:
        i, j = (int(k) - 1 for k in row["modes"])
        if dominant not in (i, j) or not row["separation_half_power"] < SPLIT_HALF_POWER:
            continue
        zi, zj = (float(modes[k]["zeta"]["q50"]) for k in (i, j))
        lo, hi = sorted((zi, zj))
        differ = lo > 0 and hi / lo >= SPLIT_DAMPING_RATIO
        if not (differ or amplitude_dependent):
            continue
        fi, fj = (float(modes[k]["f_n"]["q50"]) for k in (i, j))
        why = (f"differ {hi / lo:.2g}x in damping (zeta {zi:.2g} and {zj:.2g})" if differ else
               "lie beside a mode whose damping the one-mode analysis found not to be one "
               "viscous c")
        out.append(f"modes {i + 1} and {j + 1} ({fi:.4g} and {fj:.4g} Hz, "
                   f"{row['separation_half_power']:.2g} half-power bandwidths apart) {why}: "
                   "they may be one mode whose damping depends on amplitude, split in two by "
                   "the sum of viscous modes; see the damping-law verdict, and read this "
                   "mode's damping from the one-mode analysis ('parameters', c_equivalent)")
    return out
