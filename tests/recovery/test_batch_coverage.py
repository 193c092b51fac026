"""Issue 23's acceptance batch: 50 simulated recordings (mixed presets, rates and lengths,
3 of them corrupt) through ``dampfit batch`` on two local Dask workers, killed (SIGKILL) half
way and resumed: 47 ok rows whose 90 % intervals of c and ζ cover the truths at the calibrated
rate, 3 refused rows with their messages, no finished row analysed twice."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore")]

N_GOOD = 47


def _recordings(folder: Path) -> dict[str, dict]:
    """47 simulated recordings (the two presets at several rates, lengths and seeds) and 3
    corrupt files; returns each good file's truth."""
    from dampfit import simulate as sim

    truths = {}
    for i in range(N_GOOD):
        name = "paper" if i % 3 == 0 else "phone"
        rate = {"paper": (200.0, 500.0), "phone": (50.0, 100.0, 200.0)}[name][i % (2 if name == "paper" else 3)]
        duration = {"paper": (30.0, 60.0), "phone": (35.0, 45.0)}[name][i % 2]
        cfg = sim.preset(name, seed=1000 + i, sample_rate=rate, duration=duration)
        rec, truth = sim.recording(cfg)
        path = folder / f"rec{i:02d}.csv"
        sim.write_phyphox_csv(rec, path)
        truths[path.name] = truth
    (folder / "header_only.csv").write_text('"Time (s)","Acceleration z (m/s^2)"\n')
    (folder / "binary.csv").write_bytes(bytes(range(256)) * 40)
    (folder / "truncated.zip").write_bytes(b"PK\x03\x04" + b"\x00" * 50)
    return truths


def _batch(data: Path, masses: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "dampfit", "batch", str(data), "--masses", str(masses),
            "--out", str(out), "--workers", "2", "--no-figures", "--quiet"]


def test_fifty_recordings_killed_and_resumed(tmp_path):
    pytest.importorskip("distributed")
    data = tmp_path / "data"
    data.mkdir()
    truths = _recordings(data)
    masses = tmp_path / "masses.csv"
    masses.write_text("file,mass\n" + "".join(f"{n},{t['mass']!r}\n" for n, t in truths.items())
                      + "header_only.csv,1\nbinary.csv,1\ntruncated.zip,1\n")
    out = tmp_path / "out"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.Popen(_batch(data, masses, out), env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    rows = out / "rows.jsonl"
    deadline = time.monotonic() + 900
    while time.monotonic() < deadline and proc.poll() is None:
        if rows.exists() and rows.read_text().count("\n") >= 12:
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.communicate()[1]
    os.killpg(proc.pid, signal.SIGKILL)  # the client and, with it, its workers' watchdogs
    proc.wait(60)
    kept = [json.loads(line) for line in rows.read_text().splitlines() if line.endswith("}")]
    assert 12 <= len(kept) < 50

    again = [a for a in _batch(data, masses, out) if a != "--quiet"]  # with the status line
    done = subprocess.run(again, env=env, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"{len(kept)} already done" in done.stderr
    final = [json.loads(line) for line in rows.read_text().splitlines()]
    assert final[:len(kept)] == kept  # the rows stored before the kill are kept as they were
    assert len(final) == 50 and len({r["key"] for r in final}) == 50  # none analysed twice

    table = pd.read_csv(out / "results.csv")
    assert len(table) == 50
    analysed = table["status"].isin(("ok", "inconclusive", "misfit"))  # a damper or not
    bad = table[~analysed]
    assert sorted(bad["name"]) == ["binary.csv", "header_only.csv", "truncated.zip"]
    assert set(bad["status"]) == {"refused"} and bad["message"].str.len().gt(10).all()
    ok = table[analysed].set_index("name")
    assert ok.loc[ok["status"] != "ok", "message"].str.len().gt(10).all()  # the verdict's why
    assert len(ok) == N_GOOD and ok["converged"].all()
    cover = {q: int(sum(ok.loc[n, f"{q}_q05"] <= truths[n][q] <= ok.loc[n, f"{q}_q95"]
                        for n in ok.index)) for q in ("c", "zeta")}
    # 90 % intervals over 47 recordings: 42.3 expected, binomial sd 2.1
    assert all(N_GOOD * 0.9 - 4.5 <= k <= N_GOOD for k in cover.values()), cover
    leftover = [p.name for p in (out / "runs").iterdir() if p.name.startswith(".")]
    assert not leftover  # the killed run's staging folders were cleaned up by the rerun
    print(f"coverage of 47: {cover}; rows before the kill: {len(kept)}")
    np.testing.assert_array_less(0, ok["seconds"].to_numpy())
