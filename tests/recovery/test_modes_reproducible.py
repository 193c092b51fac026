"""The same analysis with the same seed gives the same numbers under any load (issue 34): the
modal posterior's budget is counted in steps, not seconds, so a CPU-bound neighbour changes
how long the run takes, never what it finds."""

from __future__ import annotations

import subprocess
import sys

import pytest

from dampfit import analyze

from tests._support.modes import two_mode_recording

#: Fields that are times of this run, not results.
_TIMES = ("seconds", "wall_time", "date", "elapsed", "python", "versions")


def _numbers(x, path=""):
    """Every number of a summary (with its path), times of the run left out."""
    if isinstance(x, dict):
        return {k: v for key, val in x.items() if not any(t in key for t in _TIMES)
                for k, v in _numbers(val, f"{path}.{key}").items()}
    if isinstance(x, list):
        return {k: v for i, val in enumerate(x) for k, v in _numbers(val, f"{path}[{i}]").items()}
    if isinstance(x, (int, float)) and not isinstance(x, bool):
        return {path: x}
    return {}


@pytest.mark.slow
def test_the_same_seed_gives_the_same_numbers_beside_a_cpu_hog():
    rec, _ = two_mode_recording(duration=20.0)
    first = analyze(rec, mass=0.8, seed=0, min_ess=200).summary()
    assert first["n_modes"] == 2 and first["modes_evidence"]["sampling"]["n_steps"] > 0
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        second = analyze(rec, mass=0.8, seed=0, min_ess=200).summary()
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    a, b = _numbers(first), _numbers(second)
    assert a.keys() == b.keys()
    assert {k: (a[k], b[k]) for k in a if a[k] != b[k]} == {}
