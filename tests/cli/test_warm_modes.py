"""The several-mode kernels warmed without an analysis (issue 36): the shapes ``dampfit warm-up``
compiles are those a recording's modal stage looks up — counted (JAX's compilation log and
dampfit's compile announcements), never timed."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from dampfit.inference import modes
from dampfit.inference.modes_warm import drift_buckets, modal_pairs
from dampfit.signal import prepare
from dampfit.warmup import DEFAULT_MAX_SAMPLES, sample_buckets
from tests._support.modes import two_mode_recording

XLA = re.compile(r"Finished XLA compilation of jit\((?!convert_element_type|stage\))")


def _modal_shape(rec) -> tuple[int, int]:
    """(modal sample bucket, drift columns) of ``rec``'s modal fit."""
    prep = prepare.prepare(rec)
    band = modes.modal_band(prep)
    fd = modes.modal_fit_data(modes.modal_prepared(prep, band)[0], band)
    return prepare.padded_length(fd.tau.size), modes.drift_columns(fd.drift_degree)


def test_every_sample_bucket_has_a_drift_bucket_and_the_pairs_are_distinct():
    pairs = modal_pairs(DEFAULT_MAX_SAMPLES)
    assert len(set(pairs)) == len(pairs)
    assert {b for b, _ in pairs} == set(sample_buckets(DEFAULT_MAX_SAMPLES))
    assert all(drift_buckets(b) for b, _ in pairs)


@pytest.mark.parametrize("duration, rate", [(10.0, 30.0), (10.0, 100.0), (23.0, 50.0),
                                            (120.0, 1000.0)])
def test_the_modal_shapes_of_recordings_of_several_lengths_and_rates_are_warmed(duration, rate):
    from dampfit import simulate as sim

    rec, _ = sim.recording(sim.preset("paper", duration=duration, sample_rate=rate, seed=1))
    assert _modal_shape(rec) in modal_pairs(DEFAULT_MAX_SAMPLES)


def _dampfit(argv, env):
    return subprocess.run([sys.executable, *map(str, argv)], env=env, capture_output=True,
                          text=True, timeout=1200, check=False)


@pytest.mark.slow
def test_after_warm_modal_a_two_mode_recording_compiles_no_modal_kernel(tmp_path):
    from dampfit import simulate as sim

    rec, _ = two_mode_recording()
    path = sim.write_phyphox_csv(rec, tmp_path / "two.csv")
    bucket, drift = _modal_shape(rec)
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"}
    env.update(DAMPFIT_JAX_CACHE=str(cache), JAX_LOG_COMPILES="1")
    code = ("from dampfit.inference.modes_warm import warm_modal; "
            f"warm_modal({bucket}, {drift}, (1, 2))")
    warm = _dampfit(["-c", code], env)
    assert warm.returncode == 0, warm.stderr
    analyze = ["-m", "dampfit", "analyze", path, "--mass", "0.8", "--no-figures", "--force"]
    one = _dampfit(analyze + ["--max-modes", "1", "--out", tmp_path / "one"], env)
    assert one.returncode == 0, one.stderr  # the one-mode kernels of this recording
    two = _dampfit(analyze + ["--max-modes", "2", "--out", tmp_path / "two"], env)
    assert two.returncode == 0, two.stderr
    assert '"n_modes": 2' in (tmp_path / "two" / "summary.json").read_text()
    assert "compiling kernel" not in two.stderr, two.stderr
    assert not XLA.findall(two.stderr), XLA.findall(two.stderr)
