"""``dampfit warm-up`` (issue 36, item 1): after it, a first analysis of a new recording in a
warmed sample bucket compiles no kernel — counted (dampfit's compile announcements and JAX's
compilation log), never timed."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from dampfit.signal import prepare
from dampfit.warmup import recording_in_bucket, sample_buckets
from tests._support.hostile import assert_one_line_error, run

XLA = re.compile(r"Finished XLA compilation of jit\((?!convert_element_type)")


def test_buckets_are_the_padded_lengths_up_to_the_limit():
    assert sample_buckets(1024, 256) == (256, 384, 512, 768, 1024)
    assert sample_buckets(1000, 256)[-1] == 1024  # 1000 samples fall in the bucket of 1024


@pytest.mark.parametrize("bucket", [256, 768, 4096])
def test_each_simulated_recording_falls_in_its_bucket(bucket):
    rec, n = recording_in_bucket(bucket)
    fd = prepare.fit_data(prepare.prepare(rec))
    assert fd.tau.size == n and prepare.padded_length(n) == bucket


def test_bad_max_samples_is_one_line(capsys):
    code, _, err = run(["warm-up", "--max-samples", "100"], capsys)
    assert_one_line_error(code, err, match="--max-samples")


def test_warm_up_refuses_when_the_store_is_off(capsys, monkeypatch):
    from dampfit.inference import executables

    monkeypatch.setenv(executables.ENV, "")  # restored after the test, whatever the CLI sets
    monkeypatch.setenv("DAMPFIT_JAX_CACHE", "off")
    code, _, err = run(["warm-up", "--max-samples", "256", "--quiet"], capsys)
    assert_one_line_error(code, err, match="switched off")


def _dampfit(argv, env):
    return subprocess.run([sys.executable, "-m", "dampfit", *map(str, argv)], env=env,
                          capture_output=True, text=True, timeout=900)


@pytest.mark.slow
def test_after_warm_up_a_new_recording_compiles_no_kernel(tmp_path):
    from dampfit import simulate as sim

    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = {k: v for k, v in os.environ.items()
           if k not in ("JAX_COMPILATION_CACHE_DIR", "DAMPFIT_EXECUTABLE_CACHE")}
    env.update(DAMPFIT_JAX_CACHE=str(cache), JAX_LOG_COMPILES="1")
    rec, _ = sim.recording(sim.preset("paper", duration=9.0, sample_rate=60.0, seed=11))
    new = sim.write_phyphox_csv(rec, tmp_path / "new.csv")
    assert prepare.padded_length(prepare.fit_data(prepare.prepare(rec)).tau.size) <= 512
    warm = _dampfit(["warm-up", "--max-samples", "512"], env)
    assert warm.returncode == 0, warm.stderr
    assert re.search(r"3 sample buckets \(256 … 512 samples\) warm; [1-9]\d* kernels",
                     warm.stdout), warm.stdout
    assert "warm-up: sample buckets: done in" in warm.stderr
    first = _dampfit(["analyze", new, "--mass", "5.3", "--no-figures", "--out",
                      tmp_path / "o"], env)
    assert first.returncode == 0, first.stderr
    assert "compiling kernel" not in first.stderr, first.stderr
    assert not XLA.findall(first.stderr), XLA.findall(first.stderr)
