"""Simulated several-mode decays shared by the modes tests (analytic and recovery tiers)."""

from __future__ import annotations

#: A light phone-like oscillator: 40 s at 100 Hz, 300 µg/√Hz.
BASE = dict(u0=0.004, duration=40.0, sample_rate=100.0, noise_density=300.0)


#: The two-mode decay of the posterior and wiring tests: 3.3 Hz, ζ 0.006 (the mass's mode) and
#: 8.91 Hz, ζ 0.012 at a quarter of its amplitude [(f_n [Hz], ζ [1], amplitude ratio, phase)].
SECOND_MODE = (8.91, 0.012, 0.25, 0.5)


def two_mode_recording(mass: float = 0.8, seed: int = 21, **kw):
    """(Recording, truth) of the shared two-mode decay (:data:`SECOND_MODE` above a
    ``mass`` [kg], 3.3 Hz, ζ 0.006 decay, :data:`BASE` with ``kw`` overriding)."""
    from dampfit import simulate as sim

    cfg = sim.from_modal(mass, 3.3, 0.006, modes=[SECOND_MODE], seed=seed, **{**BASE, **kw})
    return sim.recording(cfg)


def modal_prep(modes=(), zeta=0.006, seed=3, **kw):
    """(Prepared, truth) of a 0.8 kg, 3.3 Hz decay of damping ratio ``zeta`` [1] with the extra
    ``modes`` [(f_n [Hz], ζ [1], amplitude ratio [1], phase [rad])]; ``kw`` overrides
    :data:`BASE` and the other simulator options."""
    from dampfit import simulate as sim
    from dampfit.signal import prepare as pp

    cfg = sim.from_modal(0.8, 3.3, zeta, modes=list(modes), seed=seed, **{**BASE, **kw})
    rec, truth = sim.recording(cfg)
    return pp.prepare(rec), truth
