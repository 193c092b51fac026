"""Simulated free-decay accelerometer recordings with known truth: the package's own
simulator (demo data, study scenarios and campaigns).

* :mod:`dampfit.simulate.config` — :class:`SimulationConfig` (fields checked on
  construction), :func:`check_limits`, :data:`PRESETS`, :func:`preset`, :func:`from_modal`;
* :mod:`dampfit.simulate.synthesis` — the recording itself: the exact free decay
  (:func:`free_decay`, its closed form in that module's docstring), the hand-held segment,
  the catch, gravity, tilt, bias, drift, noise, timing jitter, gaps and quantization
  (:func:`recording`);
* :mod:`dampfit.simulate.artefacts` — the truth of a recording, :func:`envelope_at`, and the
  CSV and truth writers (:func:`write_phyphox_csv`, :func:`write_truth`);
* :mod:`dampfit.simulate.campaigns` — several recordings of one damper (:func:`campaign`).

Every public name is re-exported here: ``dampfit.simulate.recording(dampfit.simulate.preset("paper"))``.
"""

from dampfit.simulate.artefacts import DIALECTS, envelope_at, write_phyphox_csv, write_truth
from dampfit.simulate.campaigns import MAX_C_SPREAD, MAX_TESTS, campaign
from dampfit.simulate.config import (MAX_ACCEL, MAX_NOISE_DENSITY, MAX_SAMPLE_RATE,
                                     MAX_SIM_SAMPLES, MAX_TIMESTAMP_JITTER, MAX_U0,
                                     MIN_SAMPLES, PRESETS, TWO_PI, SimulationConfig,
                                     check_limits, from_modal, preset)
from dampfit.simulate.synthesis import free_decay, recording

__all__ = [
    "SimulationConfig",
    "check_limits",
    "PRESETS",
    "preset",
    "from_modal",
    "free_decay",
    "recording",
    "campaign",
    "MAX_TESTS",
    "envelope_at",
    "write_phyphox_csv",
    "write_truth",
    "DIALECTS",
    "MAX_C_SPREAD",
    "MAX_SIM_SAMPLES",
    "MAX_SAMPLE_RATE",
    "MIN_SAMPLES",
    "MAX_U0",
    "MAX_NOISE_DENSITY",
    "MAX_ACCEL",
    "MAX_TIMESTAMP_JITTER",
    "TWO_PI",
]
