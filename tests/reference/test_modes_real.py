"""Several modes in the real cantilever recordings of ../shared/data/real (issue 21).

What a user relies on when running ``dampfit analyze --max-modes 4`` on a cantilever free
decay (numbers from ``paper/modes_real.py`` → ``paper/results/modes_real.csv``, discussed in
paper/modes.md, "Real data"):

* the 50 cm Al cantilever (ADXL357 at 4 kHz) clearly rings in its second bending mode — a
  narrow spectrum peak at ≈39.05 Hz, hundreds of times the local noise, present in all three
  runs: dampfit reports two modes, the second at f₂/f₁ = 6.45 (the measured ratio; a uniform
  Euler–Bernoulli beam gives 6.27, the tip mass raises it) with a plausible small ζ;
* a recording whose spectrum shows nothing beside the first mode (the second LSM run of the
  50 cm beam with the empty box, 14-36-57) is not given a false second mode: one mode, and
  the one-mode ``parameters`` are its frequency.

The recordings are third-party files with no licence to redistribute: read in place, never
copied. A missing ../shared/data/real skips with that reason (fails under
DAMPFIT_REQUIRE_ALL=1, as in CI). Each analysis takes 20–60 s: marked slow (``-m slow``).
"""

from __future__ import annotations

import re
import warnings

import pytest

import dampfit
from tests._support.requirements import REAL, require

pytestmark = pytest.mark.slow

ADXL = REAL / "cantilever-adxl357-demirkaya"
TWO_MODES = ADXL / ("tests_for_comparing_1st_nfreq/50cm_adxl/08-12_11-47-32_adxl6cmfromtip2cmID/"
                    "accelerometer_data.npy")
ONE_MODE = ADXL / ("LSM_accelerometer/emptybox5cm/08-05_14-36-57_50cm_acc_7cm_ID2cm/"
                   "accelerometer_data.npy")
#: f₂/f₁ measured on the three 50 cm runs (paper/results/modes_real.csv) [1].
RATIO_50CM = 6.45


def analysed(path):
    """summary() of ``dampfit.analyze(read(path), max_modes=4)``; skips (fails under
    DAMPFIT_REQUIRE_ALL=1) when the recording is absent."""
    require(path.is_file(), f"the real cantilever recording {path.relative_to(REAL.parent.parent)}"
            " is not there (../shared/data/real; see SOURCES.md there)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        an = dampfit.analyze(dampfit.read(path), max_modes=4, seed=0, model="viscous",
                             min_ess=400)
    return an.summary()


def test_50cm_cantilever_second_bending_mode_is_found():
    s = analysed(TWO_MODES)
    assert s["n_modes"] >= 2, s["modes_evidence"].get("reason")
    f = [m["f_n"]["q50"] for m in s["modes"]]
    assert f == sorted(f)
    assert abs(f[0] - 6.055) < 0.03  # SOURCES.md: f0 = 6.055 Hz
    ratio = f[1] / f[0]
    assert abs(ratio - RATIO_50CM) < 0.05, ratio
    assert abs(ratio - 6.27) / 6.27 < 0.05  # beam theory within 5 %
    mode2 = s["modes"][1]
    assert mode2["f_n"]["q05"] < mode2["f_n"]["q50"] < mode2["f_n"]["q95"]
    assert 5e-4 < mode2["zeta"]["q05"] < mode2["zeta"]["q50"] < mode2["zeta"]["q95"] < 0.02
    p = {r["n_modes"]: r["probability"] for r in s["modes_evidence"]["evidence"]}
    assert p[2] > 0.99 and p[1] < 1e-6


def test_one_mode_recording_gets_no_false_second_mode():
    s = analysed(ONE_MODE)
    assert s["n_modes"] == 1, s["modes"]
    assert abs(s["parameters"]["f_n"]["q50"] - 3.915) < 0.03  # SOURCES.md: f0 = 3.915 Hz
    assert s["modes_evidence"]["reason"]


PENDULUM_25 = REAL / "phone-pendulum-harinlee83" / "l2LongTheta25.csv"


def test_a_pendulum_s_harmonic_is_not_a_second_mode():
    """The phone pendulum released at 25 degrees: its acceleration holds the 3rd harmonic of
    the swing (2.907 Hz = 3.000 x 0.969 Hz, hundreds of times the noise), which the evidence
    prefers as a second component. It is a harmonic of one nonlinear mode, not a mode: the
    analysis reports one mode at the pendulum's frequency and names the harmonic."""
    s = analysed(PENDULUM_25)
    ev = s["modes_evidence"]
    assert s["n_modes"] == 1 and ev["n_modes"] == 2, ev["reason"]
    (h,) = ev["harmonics"]
    assert h["multiple"] == 3 and abs(h["of_hz"] - 0.969) < 0.005
    assert abs(s["parameters"]["f_n"]["q50"] - 0.969) < 0.01


PENDULUM_15 = REAL / "phone-pendulum-harinlee83" / "l2LongTheta15.csv"


def test_a_pendulum_s_harmonic_is_named_when_the_number_of_modes_is_uncertain():
    """Released at 15 degrees, the pendulum's evidence rates K = 1 and K = 2 alike (P ≈ 0.5
    each), and K = 2's second component is the swing's 3rd harmonic (2.928 Hz = 3 x 0.976 Hz).
    Whichever K the evidence picks, one mode is reported and the harmonic named: in the
    warning on the uncertain number of modes (K = 1) or in ``modes_evidence.harmonics``."""
    s = analysed(PENDULUM_15)
    ev = s["modes_evidence"]
    assert s["n_modes"] == 1, ev["reason"]
    if ev["n_modes"] == 2:
        assert [h["multiple"] for h in ev["harmonics"]] == [3]
        return
    (w,) = [w for w in s["diagnostics"]["warnings"] if "number of modes is uncertain" in w]
    assert re.search(r"K = 2 counts 2\.9\d* Hz = 3 x 0\.97\d* Hz", w), w


SPLIT_30CM = ADXL / ("tests_for_comparing_1st_nfreq/30cm_adxl/08-12_21-08-55_2cmIDadxlAt6cm/"
                     "accelerometer_data.npy")


def test_an_amplitude_dependent_mode_split_by_the_evidence_is_one_mode():
    """The 30 cm run 21-08-55, whose damping falls as the ring decays: the sum of viscous
    modes reproduces its envelope with extra components overlapping the 16.34 Hz mode (within
    3 half-power bandwidths: close ones, or broad ones with ζ > 0.1 a cantilever does not
    have), which the evidence prefers. They are one amplitude-dependent mode: one mode is
    reported, the split is named, and no modal posterior runs (it took 2 min and reported
    three "modes")."""
    s = analysed(SPLIT_30CM)
    ev = s["modes_evidence"]
    assert s["model_checks"]["verdict"] in ("amplitude-dependent", "misfit")
    assert s["n_modes"] == 1 and ev["n_modes"] >= 2 and ev.get("split"), ev["reason"]
    assert abs(s["parameters"]["f_n"]["q50"] - 16.35) < 0.1  # SOURCES.md
    assert "sampling" not in ev
