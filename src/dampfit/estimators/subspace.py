r"""Subspace baseline for several modes: matrix pencil frequencies and damping, no Bayes.

The baseline a multi-mode study ranks the posterior (:mod:`dampfit.inference.modes_posterior`)
and the K-mode least squares (:mod:`dampfit.inference.modes`) against. On the same window and
modal band as those (:func:`dampfit.inference.modes.modal_band`, eq. MS1) the analysed signal
is low-passed at the band's upper edge and decimated to ≥ 2.5× it
(:func:`dampfit.signal.subspace.uniform_window`), and the TLS matrix pencil
(:func:`dampfit.signal.subspace.matrix_pencil`, eq. S1; order 2·max_modes + 4 complex
exponentials, the extra ones absorbing noise and drift) gives the poles s = −p + iω_d [1/s].
The number of modes is its own rule: half the noise-floor order of
:func:`dampfit.signal.subspace.floor_order` (singular values clear of the noise; a real mode is
a conjugate pair), clipped to [1, ``max_modes``]; the strongest in-band poles (signal energy) are kept and
numbered by frequency. Per mode: f_n = |s|/2π [Hz], ζ = p/|s| [1] (:func:`dampfit.physics.quantities`).
No interval (the pencil has no noise model); ``sd`` fields are None.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from dampfit import physics
from dampfit._options import DEFAULT_MAX_MODES
from dampfit.errors import InputError
from dampfit.signal import subspace
from dampfit.signal.prepare import Prepared


@dataclass(frozen=True)
class ModeEstimate:
    """One mode of the subspace baseline: ``f_n``, ``f_d`` [Hz], ``zeta`` [1], ``p`` [1/s],
    acceleration ``amplitude`` [m/s²] at the window start; ``zeta_sd``/``f_n_sd`` None (no
    interval)."""

    f_n: float
    f_d: float
    zeta: float
    p: float
    amplitude: float
    f_n_sd: float | None = None
    zeta_sd: float | None = None

    def as_dict(self) -> dict:
        return asdict(self)


def subspace_modes(prep: Prepared, *, max_modes: int = DEFAULT_MAX_MODES,
                   band: tuple[float, float] | None = None) -> list[ModeEstimate]:
    """The subspace baseline's modes of ``prep`` (module docstring), by frequency.

    ``max_modes`` as :func:`dampfit.inference.modes.check_max_modes`; ``band`` [Hz] overrides
    the modal band. Raises :class:`InputError` if the window is too short for the pencil or
    no decaying in-band pole is found."""
    from dampfit.inference.modes import check_max_modes, modal_band

    max_modes = check_max_modes(max_modes)
    band = modal_band(prep, band)
    x, fs = subspace.uniform_window(prep.grid, prep.grid_signal, prep.fs, prep.window, band)
    res = subspace.matrix_pencil(x, fs, max_order=2 * max_modes + 4,
                                 order=2 * max_modes + 4, band=band)
    poles = [q for q in res.poles if q.p > 0]
    if not poles:
        raise InputError("the matrix pencil found no decaying mode in the band")
    k = int(np.clip(res.order_floor // 2, 1, max_modes))
    chosen = sorted(poles[:k], key=lambda q: q.omega_d)
    out = []
    for q in chosen:
        d = physics.quantities(q.p, q.omega_d)
        out.append(ModeEstimate(f_n=float(d["f_n"]), f_d=float(d["f_d"]),
                                zeta=float(d["zeta"]), p=float(q.p),
                                amplitude=float(q.amplitude)))
    return out
