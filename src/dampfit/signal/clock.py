r"""Sample clock: are the samples where their time stamps say, or on a steady clock?

A phone stamps each accelerometer sample when the operating system receives it, while the
sensor samples on its own steady clock: the stamps then scatter around the true sample times
(consecutive intervals anti-correlated). Read as given, every sample sits at a slightly wrong
time, t_i = c_i + δ_i (c_i the true time, δ_i the stamp error), and the recorded value is

    y_i = s(c_i) + ε_i ≈ s(t_i) − ṡ(t_i)·δ_i + ε_i,                                  (K1)

a noise proportional to the signal's slope: at f₀ it lies entirely in the phase quadrature and
it decays with the envelope, which the stationary noise model (:mod:`dampfit.inference.noise`)
does not describe — the frequency (k) is then less certain and the decay rate (c) more
certain than the intervals say (measured with 8 % stamp jitter at 100 Hz: 90 % intervals of k
covered 0.81–0.87, of c 0.94–0.95). A polled logger that stamps each read when it happens has
equally irregular stamps but no such error; the data tell the two apart:

1. **Steady clock.** Each interval is rounded to a whole number of median steps (dropped
   samples count) and the stamps are fitted by a line in that sample count: c_i. The
   candidate stamp errors are δ_i = t_i − c_i. The clock is kept stiff on purpose: any
   wander it were allowed to follow (a running mean over M samples) would put the stamp
   errors' own content below f_s/M back into the sample times, as a phase wander right at f₀
   (measured: a 64-sample running mean left 1/8 of the rms error, at the full spectral density
   near f₀). A sensor clock keeps its rate to ≈ 1e-4 over a recording.
2. **Test.** With s the band-passed signal at the stamps and ṡ = −ω₀·H[s] its slope (H the
   Hilbert transform; s is narrow-band at ω₀ = 2πf₀ [rad/s]), the regression of the
   out-of-band residual y_i − s(t_i) on −ṡ(t_i)·δ_i over the usable samples of the free-decay
   window (the filter is settled there; its edge transients would swamp the test) gives κ̂
   (0: the samples are at their stamps; 1: on the steady clock) and its standard error. Only
   the fast part of δ (δ minus its running mean over :data:`TEST_SPAN` samples) enters the
   regressor: stamp errors are fast, while a slow deviation — irregular sampling that
   accumulates, as in the simulator's ``jitter`` — times ṡ is a signal at f₀ that correlates
   with the band-pass filter's own in-band error on a decay (it gave κ̂ = 0.51 ± 0.07 on exact
   stamps at 500 Hz). The fast part is independent of the signal, so nothing but a timing
   error correlates with the regressor (drift is slow, harmonics and sensor noise are
   uncorrelated with δ).
3. **Correction.** Only if κ̂ exceeds :data:`KAPPA_Z` standard errors *and* lies between
   :data:`KAPPA_MIN` and :data:`KAPPA_MAX` are the samples moved to t_i − κ·δ_i,
   κ = min(κ̂, 1): stamps that are right (κ̂ ≈ 0), or too regular for the test to see anything
   (δ ≈ 0, as in most phone exports, whose jitter is dropped samples), are left as they are.
   (A very clean lab recording can make a κ̂ of 0.001 "significant": with the whole δ as
   regressor the real ADXL357 cantilever files gave κ̂ from −0.007 to +0.0014 with standard
   errors of 0.0002 — a slightly wandering logger clock, not stamp errors.)

The band-pass keeps the in-band part of the timing noise in s, which biases κ̂ low by about
the band's share of the Nyquist range (≈ 5 % at 100 Hz for a 3.3 Hz decay): negligible for the
correction (the timing-noise power left is (1 − κ)² of what it was).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import interpolate, ndimage, signal

#: κ̂ must exceed this many standard errors before the samples are moved (a false move costs
#: little — δ is small — but results on regular stamps must not change).
KAPPA_Z = 4.0
#: … and this fraction of the stamp deviation [1] must be timing error, and at most
#: KAPPA_MAX: (K1) allows only κ ∈ [0, 1], and a κ̂ far above 1 is something else (the ADXL345
#: cantilever file, a few clipped cycles polled faster than the sensor's rate, gave 11 ± 1.7).
KAPPA_MIN, KAPPA_MAX = 0.5, 1.5
#: Stamps within this fraction of a step [1] of the clock are regular (rounding, not timing
#: error): nothing to test.
REGULAR = 1e-4
#: Running-mean span [samples] whose residual, the fast part of δ, is the test's regressor.
TEST_SPAN = 9
#: Fewest usable samples [1] for the test.
MIN_SAMPLES = 64


@dataclass(frozen=True)
class ClockCheck:
    """Outcome of :func:`check`: κ̂ [1] and its standard error [1], the rms stamp deviation
    from the steady clock [s], whether the samples were moved, and their times [s]."""

    kappa: float
    kappa_se: float
    deviation_rms: float
    moved: bool
    time: np.ndarray

    def note(self) -> str:
        """One line for the preparation notes."""
        if self.moved:
            return (f"the time stamps scatter around a steady sample clock (rms "
                    f"{1e3 * self.deviation_rms:.3g} ms) and the signal follows the clock, not the "
                    f"stamps (timing-error fit κ = {self.kappa:.2f} ± {self.kappa_se:.2f}): the "
                    "samples are placed on the clock")
        return ""

    def summary(self) -> dict:
        """JSON-safe facts of the test."""
        return {"kappa": self.kappa, "kappa_se": self.kappa_se,
                "deviation_rms_s": self.deviation_rms, "moved": self.moved}


def steady_clock(t: np.ndarray) -> np.ndarray:
    """Times [s] of a steady clock fitted to the stamps ``t`` [s] (step 1 of the module
    docstring): a line in the sample count, each interval rounded to whole median steps."""
    t = np.asarray(t, dtype=float)
    step = float(np.median(np.diff(t)))
    count = np.concatenate([[0.0], np.cumsum(np.maximum(1.0, np.round(np.diff(t) / step)))])
    design = np.column_stack([np.ones_like(count), count - count.mean()])
    coef, *_ = np.linalg.lstsq(design, t, rcond=None)
    return design @ coef


def check(t: np.ndarray, y: np.ndarray, usable: np.ndarray, grid: np.ndarray,
          bandpassed: np.ndarray, f0: float) -> ClockCheck:
    """Steps 1–3 of the module docstring for samples ``y`` [m/s²] at stamps ``t`` [s]
    (``usable`` bool mask: the usable samples of the free-decay window), the band-passed signal ``bandpassed`` [m/s²] on the uniform
    ``grid`` [s] and the dominant frequency ``f0`` [Hz]."""
    t = np.asarray(t, dtype=float)
    unchanged = ClockCheck(0.0, float("inf"), 0.0, False, t)
    if t.size < MIN_SAMPLES or grid.size < 4:
        return unchanged
    delta = t - steady_clock(t)
    rms = float(np.sqrt(np.mean(delta**2)))
    sel = usable & (t >= grid[0]) & (t <= grid[-1])
    if rms < REGULAR * float(np.median(np.diff(t))) or sel.sum() < MIN_SAMPLES:
        return ClockCheck(0.0, float("inf"), rms, False, t)
    s = interpolate.make_interp_spline(grid, bandpassed, k=3)(t[sel])
    quadrature = np.imag(signal.hilbert(bandpassed))
    slope = -2.0 * np.pi * f0 * interpolate.make_interp_spline(grid, quadrature, k=3)(t[sel])
    # the fast part of δ only: a slow deviation (a wandering clock, or irregular sampling that
    # accumulates) times the slope is a signal at f₀, which correlates with the band-pass
    # filter's own in-band error y − s on a decay; stamp errors are fast
    fast = delta - ndimage.uniform_filter1d(delta, TEST_SPAN, mode="nearest")
    x = -slope * fast[sel]
    e = y[sel] - s
    xx = float(x @ x)
    if not xx > 0:
        return ClockCheck(0.0, float("inf"), rms, False, t)
    kappa = float(x @ e) / xx
    res = e - kappa * x
    se = float(np.sqrt(max(float(res @ res), 0.0) / max(x.size - 1, 1) / xx))
    moved = bool(se > 0 and kappa > KAPPA_Z * se and KAPPA_MIN < kappa < KAPPA_MAX)
    placed = t - min(kappa, 1.0) * delta
    if moved and not np.all(np.diff(placed) > 0):  # a clock that does not keep the order
        moved = False
    return ClockCheck(kappa, se, rms, moved, placed if moved else t)
