"""Simulated several-mode decays shared by the modes tests (analytic and recovery tiers)."""

from __future__ import annotations

#: A light phone-like oscillator: 40 s at 100 Hz, 300 µg/√Hz.
BASE = dict(u0=0.004, duration=40.0, sample_rate=100.0, noise_density=300.0)


def modal_prep(modes=(), zeta=0.006, seed=3, **kw):
    """(Prepared, truth) of a 0.8 kg, 3.3 Hz decay of damping ratio ``zeta`` [1] with the extra
    ``modes`` [(f_n [Hz], ζ [1], amplitude ratio [1], phase [rad])]; ``kw`` overrides
    :data:`BASE` and the other simulator options."""
    from dampfit import simulate as sim
    from dampfit.signal import prepare as pp

    cfg = sim.from_modal(0.8, 3.3, zeta, modes=list(modes), seed=seed, **{**BASE, **kw})
    rec, truth = sim.recording(cfg)
    return pp.prepare(rec), truth
