"""Every real recording in ../shared/data/real is read and analysed without error.

The recordings are third-party files with no licence to redistribute: they are read in place
and never copied. Skipped when the folder is absent. The reported natural frequency must
match the decay's own dominant frequency (of the analysed window,
computed here independently of dampfit's fit from the zero crossings) within 0.5 %.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import dampfit

from tests._support.requirements import REAL

FILES = sorted(
    [p for p in REAL.rglob("*") if p.suffix in {".csv", ".npy"}] if REAL.is_dir() else []
)
pytestmark = pytest.mark.skipif(not FILES, reason="../shared/data/real is not present")

# rough reference numbers from SOURCES.md: (path fragment, f0 [Hz], tolerance [Hz])
REFERENCE_F0 = [("phone-spring", 0.715, 0.01), ("l2LongTheta5.", 0.980, 0.01),
                ("l2LongTheta60", 0.937, 0.01), ("30cm_adxl", 16.35, 0.1),
                ("40cm_adxl", 9.39, 0.05), ("50cm_adxl", 6.055, 0.03),
                ("emptybox5cm", 3.915, 0.03), ("Cantilever-Data", 21.0, 0.8)]


def window_frequency(an) -> float:
    """Dominant damped frequency [Hz] of the analysed window, from its upward zero crossings.

    The zero crossings of e^{−pt}·cos(ω_d·t + φ) are exactly periodic at T_d, so cycle
    lengths measure f_d even in a few-cycle window where an FFT peak cannot (its resolution
    is 1/T). Each cycle's frequency is weighted by its energy (peak amplitude²): "dominant"
    is where the decay's energy is, which matters when the frequency drifts with amplitude.
    Crossings are located by linear interpolation on the band-passed signal.
    """
    prep = an.prepared
    sel = (prep.grid >= prep.window[0]) & (prep.grid <= prep.window[1])
    t, y = prep.grid[sel], prep.bandpassed[sel]
    up = np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))
    tz = t[up] - y[up] * (t[up + 1] - t[up]) / (y[up + 1] - y[up])
    f_cycle = 1.0 / np.diff(tz)
    energy = np.array([np.max(y[a:b]) ** 2 for a, b in zip(up[:-1], up[1:] + 1)])
    return float(np.sum(energy * f_cycle) / np.sum(energy))


def _by_default(files):
    """One recording of each source runs by default; the others are marked heavy (CI runs them)."""
    seen = set()
    for p in files:
        source = p.relative_to(REAL).parts[0]
        yield pytest.param(p, id=str(p.relative_to(REAL)),
                           marks=[] if source not in seen else [pytest.mark.heavy])
        seen.add(source)


@pytest.mark.parametrize("path", list(_by_default(FILES)))
def test_real_recording_is_analysed(path):
    rec = dampfit.read(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # no emcee for other laws; one mode: the parameters are what this test checks (the
        # same with max_modes 4), and the modes of these files are test_modes_real's (slow)
        an = dampfit.analyze(rec, seed=0, min_ess=400, model="viscous", max_modes=1)
    s = an.summary()
    f_n = s["parameters"]["f_n"]["q50"]
    zeta = s["parameters"]["zeta"]["q50"]
    f_d = s["parameters"]["f_d"]["q50"]
    # 0.5 %, or 3 posterior sd where the data cannot give that (a 4-cycle, clipped, ζ ≈ 0.1
    # ring: SOURCES.md lists the ADXL345 file "for robustness, not for accuracy")
    tol = max(0.005 * f_d, 3 * s["parameters"]["f_d"]["sd"])
    assert abs(f_d - window_frequency(an)) < tol, (f_d, window_frequency(an), tol)
    assert abs(f_n / f_d - 1) < 0.005  # f_n = f_d/√(1−ζ²): true for ζ < 0.1
    assert 0 < zeta < 0.2
    for frag, f0, tol in REFERENCE_F0:
        if frag in str(path):
            assert abs(f_n - f0) < tol, (f_n, f0)
