"""Benchmark: dampfit's posterior against an lmfit + emcee reference on the same recording.

Runs, in one process and on one recording (the seed paper's set-up simulated: 60 s at
500 Hz, m = 5.3 kg known exactly so that c = 2·m·p and the effective sample size of c is that
of the decay rate):

1. **reference** — what an engineer would write by hand: the band-passed full-rate
   acceleration of dampfit's analysis window fitted with an lmfit ``Model``
   (A·e^{−p·t}·cos(ω·t + φ) + offset) by least squares, then lmfit's emcee wrapper
   (``method="emcee"``, ``is_weighted=False`` so the noise level is sampled too, 32 walkers,
   ``--ref-steps`` steps). Effective samples of c per second = bulk ESS of p (arviz, walkers as
   chains, first third discarded) / wall time of the emcee run.
2. **dampfit** — :func:`dampfit.analyze` (``model="viscous"``: no extra damping laws) on the
   same recording (cold: including JAX compilation; warm: a second recording of the same
   shape). ESS of c per second = bulk ESS of c / wall time, both of the posterior stage alone
   (emcee, amplitude draws, arviz — the counterpart of the reference's emcee run) and of the
   whole ``analyze`` call (preprocessing, least squares, CRLB, baselines and all).
3. **whole CLI** — ``dampfit analyze FILE --mass 5.3 --report`` in a fresh process (start-up,
   compile, fit, posterior, figures, NetCDF, report), wall time with a fresh persistent
   compilation cache: the first run compiles and fills it, the median of three later runs
   loads the kernels (every later run of a user). Against the time the reference needs for
   1,000 effective samples of c, and against the *import floor* (median of three): a fresh
   Python importing the stack the CLI is built on (:data:`STACK`: numpy, scipy, pandas, JAX,
   optimistix, emcee, arviz, matplotlib) — the start-up every CLI built on these libraries pays
   before any work. Goal: warm CLI ≤ 2 × the floor.
4. **study throughput** — least-squares fits per minute (prepare + fit, warm) over
   ``--fits`` recordings with different seeds.
5. **a script's first analysis** (issue 23) — a fresh Python with the compiled-kernel store
   filled by an earlier process (the store a script now gets by default,
   :mod:`dampfit.inference.executables`): the first ``dampfit.analyze()`` of the recording
   (after ``from dampfit import analyze``) against a second one of the same shape in the same
   process, in three fresh processes (the median ratio: one varied by ±20 % between runs);
   and the same first call with the store switched off (the 35 s a script used to pay on a
   loaded machine). Goal: first ≤ 1.5 × warm.
6. **batch throughput** (issue 23) — ``dampfit batch`` of ``--batch`` recordings of the same
   kind (seeds of the paper preset) on 2 local workers, wall time per recording, against one
   warm single ``dampfit analyze FILE --mass 5.3`` (same outputs: figures, no report; median of
   three runs before the batches and three after, against the machine's drift) in the same
   run, after a first batch of the same recordings that filled the compiled-kernel store (as
   the single runs are warm: a recording whose fit window falls in a new shape bucket compiles
   once per machine). Goal: ≤ 0.35 ×.

The CLI is also compared with the narrower floor of issue 23 (:data:`STACK_ISSUE`: numpy,
scipy.signal, JAX, emcee, matplotlib, arviz; best of two, and the median ratio of five
interleaved floor/CLI pairs: single ratios varied 1.48–1.76 between runs on the shared 2-core
machine): goal ≤ 1.5 ×.

Usage: ``python paper/benchmark.py [--ref-steps 2000] [--fits 20] [--batch 20] [--json FILE]``. Timings
are ratios measured in the same run, so they transfer between machines; the absolute numbers
are this machine's.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

MASS = 5.3  # [kg]


def _ess(chain: np.ndarray) -> float:
    """Bulk ESS of a (chain, draw) array."""
    import arviz as az

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return float(az.ess(np.asarray(chain), method="bulk"))


def reference(rec, prep, steps: int, seed: int) -> dict:
    """lmfit least squares + lmfit's emcee wrapper on the full-rate band-passed window."""
    import lmfit

    sel = (prep.grid >= prep.window[0]) & (prep.grid <= prep.window[1])
    t = prep.grid[sel] - prep.window[0]
    y = prep.bandpassed[sel]

    def decay(t, amp, p, omega, phi, offset):
        return amp * np.exp(-p * t) * np.cos(omega * t + phi) + offset

    model = lmfit.Model(decay)
    params = model.make_params(amp=float(np.max(np.abs(y[: int(prep.fs)]))), p=0.02,
                               omega=2 * np.pi * prep.f0, phi=0.0, offset=0.0)
    params["p"].set(min=0.0)
    params["amp"].set(min=0.0)
    params["phi"].set(min=-np.pi, max=np.pi)
    t0 = time.perf_counter()
    ls = model.fit(y, params, t=t)
    t_ls = time.perf_counter() - t0
    t0 = time.perf_counter()
    mc = model.fit(y, ls.params, t=t, method="emcee",
                   fit_kws=dict(steps=steps, nwalkers=32, burn=0, is_weighted=False,
                                progress=False, seed=seed))
    t_mc = time.perf_counter() - t0
    names = list(mc.var_names)
    chain = np.asarray(mc.chain)  # (steps, walkers, nvarys)
    chain = chain[chain.shape[0] // 3 :]
    p_chain = chain[:, :, names.index("p")].T
    ess = _ess(p_chain)
    return {"n_samples": int(y.size), "steps": steps, "walkers": 32, "ls_time_s": t_ls,
            "emcee_time_s": t_mc, "ess_c": ess, "ess_c_per_s": ess / t_mc,
            "c_median": float(2 * MASS * np.median(p_chain)),
            "time_per_1000_ess_s": 1000.0 * t_mc / ess}


def dampfit_run(rec) -> dict:
    """The whole analyze() call, and its posterior stage alone (emcee + draws + arviz), timed.

    The posterior stage also computes every quantity's R-hat and bulk ESS once
    (:func:`dampfit.inference.sampler_run.diagnostics`, which the summary reuses); the
    reference's timing holds no ESS computation, so the sampler-vs-sampler ratio takes that
    time out (``posterior_time_s``) and reports it separately (``diagnostics_time_s``)."""
    import dampfit
    from dampfit.inference import posterior, sampler_run

    calls, diag = [], []
    original, original_diag = posterior.sample, sampler_run.diagnostics

    def timed(*args, **kw):
        t = time.perf_counter()
        out = original(*args, **kw)
        calls.append(time.perf_counter() - t)
        return out

    def timed_diag(*args, **kw):
        t = time.perf_counter()
        out = original_diag(*args, **kw)
        diag.append(time.perf_counter() - t)
        return out

    posterior.sample, sampler_run.diagnostics = timed, timed_diag
    try:
        t0 = time.perf_counter()
        an = dampfit.analyze(rec, mass=MASS, model="viscous")
        dt = time.perf_counter() - t0
    finally:
        posterior.sample, sampler_run.diagnostics = original, original_diag
    ess = _ess(np.asarray(an.posterior.posterior["c"]))
    diag_s = sum(diag)  # inside the posterior stage
    stage = calls[0] - diag_s
    return {"time_s": dt, "posterior_time_s": stage, "diagnostics_time_s": diag_s,
            "ess_c": ess, "ess_c_per_s": ess / dt, "posterior_ess_c_per_s": ess / stage,
            "posterior_with_diagnostics_ess_c_per_s": ess / calls[0],
            "c_median": float(np.median(an.draws("c"))), "n_fit_samples": int(an.fit_data.y.size)}


def _env(cache: Path | str) -> dict:
    """The environment of a benchmark child: the compiled-kernel store in ``cache`` ("off"
    for none), no JAX cache of the user's."""
    import os

    env = dict(os.environ, DAMPFIT_JAX_CACHE=str(cache))
    for name in ("JAX_COMPILATION_CACHE_DIR", "DAMPFIT_EXECUTABLE_CACHE"):
        env.pop(name, None)
    return env


def _timed(argv: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, env=env)
    return time.perf_counter() - t0


def cli_times(csv: Path, cache: Path, warm_runs: int = 3, report: bool = True,
              extra: tuple[str, ...] = ()) -> list[float]:
    """Wall times [s] of ``dampfit analyze FILE --mass 5.3 [--report] [extra…]`` in fresh
    processes using the store in ``cache`` (the first run fills it when it is empty)."""
    out = cache.parent / "cli-out"
    return [_timed([sys.executable, "-m", "dampfit", "analyze", str(csv), "--mass", str(MASS),
                    "--out", str(out), "--force", "--quiet", *(["--report"] if report else []),
                    *extra], _env(cache)) for _ in range(warm_runs)]


#: A fresh process's first and second analyze() (issue 23 item 6): prints one JSON line.
FIRST_CALL = """
import json, sys, time
t_import = time.perf_counter()
from dampfit import analyze
t_import = time.perf_counter() - t_import
from dampfit import simulate as sim
recs = [sim.recording(sim.preset("paper", seed=s))[0] for s in (0, 1, 2)]
t = []
for rec in recs:
    t0 = time.perf_counter(); analyze(rec, mass=float(sys.argv[1])); t.append(time.perf_counter() - t0)
print(json.dumps({"import_s": t_import, "first_s": t[0], "warm_s": min(t[1:])}))
"""


def first_call(cache: Path | str) -> dict:
    """``from dampfit import analyze`` (the imports), the first ``analyze()`` and the faster of
    two later ones [s] in a fresh Python (:data:`FIRST_CALL`)."""
    out = subprocess.run([sys.executable, "-c", FIRST_CALL, str(MASS)], check=True,
                         capture_output=True, text=True, env=_env(cache))
    return json.loads(out.stdout.strip().splitlines()[-1])


def batch_times(folder: Path, n: int, cache: Path) -> dict[str, float]:
    """Wall times [s] of ``dampfit batch`` of ``n`` paper-preset recordings on 2 workers:
    with the outputs of ``dampfit analyze`` (``all``: folder with figures per recording) and
    with ``--summaries-only`` (``summaries``: the table and each summary.json), both after a
    first ``--summaries-only`` batch (``first``) that filled the compiled-kernel store, and
    both again on :data:`SMALL` of the recordings (``all_small``, ``summaries_small``: the
    fixed cost of a batch)."""
    from dampfit import simulate as sim

    data = folder / "batch-data"
    data.mkdir()
    for i in range(n):
        sim.write_phyphox_csv(sim.recording(sim.preset("paper", seed=100 + i))[0],
                              data / f"rec{i:03d}.csv")
    def command(recordings: Path) -> list[str]:
        return [sys.executable, "-m", "dampfit", "batch", str(recordings), "--mass", str(MASS),
                "--workers", "2", "--quiet"]

    base = command(data)
    # first a batch that fills the compiled-kernel store with every shape bucket these
    # recordings need (the single CLI runs it is compared with are warm too: a recording whose
    # fit window falls in another bucket compiles ≈ 14 s once per machine, which is the cold
    # start, not the throughput)
    first = _timed([*base, "--out", str(folder / "batch-first"), "--summaries-only"],
                   _env(cache))
    # the same command on the first SMALL recordings (one per worker) is the batch's fixed
    # cost (the cluster's start, every worker's imports, the table): T(N) ≈ F + N·t, so
    # (T(n) − T(SMALL))/(n − SMALL) is the throughput of a long batch, the marginal
    # wall time per recording
    small = folder / "batch-data-small"
    small.mkdir()
    for i in range(SMALL):
        (small / f"rec{i:03d}.csv").write_bytes((data / f"rec{i:03d}.csv").read_bytes())
    base_small = command(small)
    return {"first": first,
            "all": _timed([*base, "--out", str(folder / "batch-all")], _env(cache)),
            "summaries": _timed([*base, "--out", str(folder / "batch-summaries"),
                                 "--summaries-only"], _env(cache)),
            "all_small": _timed([*base_small, "--out", str(folder / "batch-all-small")],
                                _env(cache)),
            "summaries_small": _timed([*base_small, "--out",
                                       str(folder / "batch-summaries-small"),
                                       "--summaries-only"], _env(cache))}


def batch_only(n: int, json_path: str | None) -> int:
    """Item 6 alone: ``dampfit batch`` of ``n`` recordings with its default outputs (the table,
    the comparison figure and each recording's summary, posterior and FEM deck; no
    per-recording figures, issue 36) and ``--summaries-only``, against the median of three warm
    single ``dampfit analyze FILE --mass 5.3`` (default outputs, figures included) before the
    batches and three after, all on one compiled-kernel store filled by a first run."""
    from dampfit import simulate as sim

    rec, _ = sim.recording(sim.preset("paper", seed=0))
    with tempfile.TemporaryDirectory() as tmp:
        csv, cache = Path(tmp) / "paper.csv", Path(tmp) / "jax-cache"
        sim.write_phyphox_csv(rec, csv)
        cli_times(csv, cache, 1, report=False)  # fills the store
        single_runs = cli_times(csv, cache, report=False)
        batch = batch_times(Path(tmp), n, cache)
        single_runs += cli_times(csv, cache, report=False)
    single = float(np.median(single_runs))
    marginal = {kind: (batch[kind] - batch[f"{kind}_small"]) / (n - SMALL)
                for kind in ("all", "summaries")}
    out = {"batch_recordings": n, "single_cli_s": single, "single_cli_runs_s": single_runs,
           "batch_times_s": batch,
           "batch_per_recording_over_single": batch["all"] / n / single,
           "batch_summaries_per_recording_over_single": batch["summaries"] / n / single,
           "batch_marginal_over_single": marginal["all"] / single,
           "batch_summaries_marginal_over_single": marginal["summaries"] / single}
    print(f"batch of {n} on 2 workers, default outputs: {batch['all'] / n:.2f} s per recording "
          f"= {out['batch_per_recording_over_single']:.2f} x one warm dampfit analyze "
          f"({single:.2f} s, median of {len(single_runs)}; goal <= 0.35x); marginal "
          f"{out['batch_marginal_over_single']:.2f} x; --summaries-only "
          f"{out['batch_summaries_per_recording_over_single']:.2f} x (marginal "
          f"{out['batch_summaries_marginal_over_single']:.2f} x)")
    if json_path:
        Path(json_path).write_text(json.dumps(out, indent=2) + "\n")
    return 0


#: Recordings of the small batch that measures a batch's fixed cost (one per worker).
SMALL = 2


#: The scientific stack the CLI is built on: every library ``dampfit analyze`` needs to do its
#: work (signal processing, the JAX model and its least squares, the sampler, diagnostics and
#: NetCDF, figures). Importing them and touching the JAX backend is the *import floor*: no CLI
#: built on these libraries can start faster.
STACK = ("import numpy, scipy.signal, scipy.optimize, pandas, jax, jax.numpy as jnp, optimistix, "
         "emcee, arviz, matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot; "
         "jnp.zeros(1).block_until_ready()")
#: The floor of issue 23: numpy, scipy.signal, JAX, emcee, matplotlib, arviz (best of two).
STACK_ISSUE = ("import numpy, scipy.signal, jax, jax.numpy as jnp, emcee, arviz, matplotlib; "
               "matplotlib.use('Agg'); import matplotlib.pyplot; jnp.zeros(1).block_until_ready()")
#: The narrower floor of earlier benchmark runs (no pandas, optimistix, arviz), for comparison.
STACK_NARROW = ("import numpy, scipy.signal, jax, jax.numpy as jnp, emcee, matplotlib; "
                "matplotlib.use('Agg'); import matplotlib.pyplot; jnp.zeros(1).block_until_ready()")


def import_floor(code: str = STACK, runs: int = 3, best: bool = False) -> float:
    """Median (``best``: minimum) wall time [s] of a fresh Python importing the libraries the
    CLI is built on."""
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        times.append(time.perf_counter() - t0)
    return float(np.min(times) if best else np.median(times))


def throughput(n: int) -> float:
    from dampfit.inference import least_squares as fit
    from dampfit.signal import prepare as preprocess
    from dampfit import simulate as sim

    recs = [sim.recording(sim.preset("paper", seed=1000 + i))[0] for i in range(n + 1)]
    prep = preprocess.prepare(recs[0])  # warm-up (compilation) not counted
    fit.least_squares(preprocess.fit_data(prep), float("nan"), prep.f0)
    t0 = time.perf_counter()
    for rec in recs[1:]:
        prep = preprocess.prepare(rec)
        fit.least_squares(preprocess.fit_data(prep), float("nan"), prep.f0)
    return 60.0 * n / (time.perf_counter() - t0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="dampfit vs lmfit + emcee benchmark")
    ap.add_argument("--ref-steps", type=int, default=2000, help="emcee steps of the reference")
    ap.add_argument("--fits", type=int, default=20, help="recordings for the throughput test")
    ap.add_argument("--batch", type=int, default=20, help="recordings of the batch throughput")
    ap.add_argument("--json", help="also write the numbers to this JSON file")
    ap.add_argument("--batch-only", action="store_true",
                    help="measure only the batch against warm single runs (item 6)")
    a = ap.parse_args(argv)
    if a.batch_only:
        return batch_only(a.batch, a.json)

    import os

    from dampfit.signal import prepare as preprocess
    from dampfit import simulate as sim

    rec, truth = sim.recording(sim.preset("paper", seed=0))
    with tempfile.TemporaryDirectory() as tmp:
        csv, cache = Path(tmp) / "paper.csv", Path(tmp) / "jax-cache"
        sim.write_phyphox_csv(rec, csv)
        (cli_first,) = cli_times(csv, cache, 1)  # fills the store: compiling
        cli_runs = cli_times(csv, cache)
        floor_issue = import_floor(STACK_ISSUE, runs=2, best=True)
        # the same ratio from 5 interleaved pairs (floor, then CLI), whose median does not
        # move with the machine's speed between the two measurements above
        pairs = []
        for _ in range(5):
            f = import_floor(STACK_ISSUE, runs=1)
            pairs.append(cli_times(csv, cache, 1)[0] / f)
        single_runs = cli_times(csv, cache, report=False)
        # issue 21 "no regression": on this one-mode recording the default (several modes
        # looked for: the screen runs, finds one mode, so no selection or modal posterior)
        # against --max-modes 1 (the modal stage skipped: the one-mode analysis alone)
        cli_first_modes = cli_times(csv, cache, 1, extra=("--max-modes", "1"))[0]
        modes_runs, modes_pairs = [], []
        for _ in range(5):  # interleaved with the default, as the floor pairs
            modes_runs += cli_times(csv, cache, 1, extra=("--max-modes", "1"))
            modes_pairs.append(cli_times(csv, cache, 1)[0] / modes_runs[-1])
        # three fresh processes: one first call varies by ±20 % on a shared 2-core machine
        firsts = [first_call(cache) for _ in range(3)]
        first = sorted(firsts, key=lambda f: f["first_s"] / f["warm_s"])[1]  # median ratio
        first_off = first_call("off")
        batch = batch_times(Path(tmp), a.batch, cache)
        single_runs += cli_times(csv, cache, report=False)  # again after the batch: drift
    cli = float(np.median(cli_runs))
    single = float(np.median(single_runs))
    marginal = {kind: (batch[kind] - batch[f"{kind}_small"]) / (a.batch - SMALL)
                for kind in ("all", "summaries")}
    floor = import_floor()
    floor_narrow = import_floor(STACK_NARROW)
    os.environ["DAMPFIT_JAX_CACHE"] = "off"  # the in-process runs below: cold means compiling
    d_cold = dampfit_run(rec)
    # warm: three further recordings of the same shape, the median one (by sampler ESS/s)
    warm_runs = [dampfit_run(sim.recording(sim.preset("paper", seed=s))[0]) for s in (1, 2, 3)]
    d_warm = sorted(warm_runs, key=lambda d: d["posterior_ess_c_per_s"])[1]
    ref = reference(rec, preprocess.prepare(rec), a.ref_steps, seed=0)
    tput = throughput(a.fits)

    ratio_cold = d_cold["ess_c_per_s"] / ref["ess_c_per_s"]
    ratio_warm = d_warm["ess_c_per_s"] / ref["ess_c_per_s"]
    ratio_sampler = d_warm["posterior_ess_c_per_s"] / ref["ess_c_per_s"]
    cli_ratio = ref["time_per_1000_ess_s"] / cli
    out = {"truth_c": truth["c"], "reference": ref, "dampfit_cold": d_cold,
           "dampfit_warm": d_warm, "dampfit_warm_runs": warm_runs,
           "cli_time_s": cli, "cli_time_first_run_s": cli_first, "import_floor_s": floor,
           "import_floor_narrow_s": floor_narrow, "cli_over_import_floor": cli / floor,
           "ess_ratio_cold": ratio_cold, "ess_ratio_warm": ratio_warm,
           "ess_ratio_sampler": ratio_sampler, "reference_time_over_cli_time": cli_ratio,
           "reference_time_over_cli_time_first_run": ref["time_per_1000_ess_s"] / cli_first,
           "reference_time_over_import_floor": ref["time_per_1000_ess_s"] / floor,
           "least_squares_fits_per_minute": tput,
           "cli_runs_s": cli_runs, "import_floor_issue_s": floor_issue,
           "cli_over_import_floor_issue": cli / floor_issue,
           "cli_over_import_floor_issue_pairs": pairs,
           "cli_over_import_floor_issue_paired": float(np.median(pairs)),
           "analyze_import_s": first["import_s"],
           "first_analyze_s": first["first_s"], "warm_analyze_s": first["warm_s"],
           "first_over_warm": first["first_s"] / first["warm_s"],
           "first_over_warm_runs": [f["first_s"] / f["warm_s"] for f in firsts],
           "first_analyze_store_off_s": first_off["first_s"],
           "batch_recordings": a.batch, "batch_time_s": batch["all"],
           "batch_time_per_recording_s": batch["all"] / a.batch, "single_cli_s": single,
           "single_cli_runs_s": single_runs,
           "batch_per_recording_over_single": batch["all"] / a.batch / single,
           "batch_summaries_time_s": batch["summaries"],
           "batch_summaries_per_recording_over_single": batch["summaries"] / a.batch / single,
           "batch_first_time_s": batch["first"],
           "batch_small_recordings": SMALL, "batch_small_time_s": batch["all_small"],
           "batch_summaries_small_time_s": batch["summaries_small"],
           "batch_marginal_per_recording_s": marginal["all"],
           "batch_marginal_over_single": marginal["all"] / single,
           "batch_summaries_marginal_per_recording_s": marginal["summaries"],
           "batch_summaries_marginal_over_single": marginal["summaries"] / single,
           "cli_max_modes_1_runs_s": modes_runs, "cli_max_modes_1_first_run_s": cli_first_modes,
           "cli_default_over_max_modes_1": cli / float(np.median(modes_runs)),
           "cli_default_over_max_modes_1_pairs": modes_pairs,
           "cli_default_over_max_modes_1_paired": float(np.median(modes_pairs))}
    print(f"recording: paper preset, 60 s at 500 Hz, truth c = {truth['c']} N s/m (mass known)")
    print(f"{'':28s}{'time [s]':>10s}{'ESS(c)':>10s}{'ESS/s':>10s}{'c median':>12s}")
    print(f"{'lmfit + emcee (reference)':28s}{ref['emcee_time_s']:10.1f}{ref['ess_c']:10.0f}"
          f"{ref['ess_c_per_s']:10.2f}{ref['c_median']:12.5f}")
    for name, d in (("dampfit.analyze (cold)", d_cold), ("dampfit.analyze (warm)", d_warm)):
        print(f"{name:28s}{d['time_s']:10.1f}{d['ess_c']:10.0f}{d['ess_c_per_s']:10.1f}"
              f"{d['c_median']:12.5f}")
    print(f"{'dampfit posterior stage (warm)':28s}{d_warm['posterior_time_s']:10.1f}"
          f"{d_warm['ess_c']:10.0f}{d_warm['posterior_ess_c_per_s']:10.1f}")
    print(f"\nESS/s ratio dampfit / reference: sampler vs sampler {ratio_sampler:.0f}x; whole "
          f"analyze() cold {ratio_cold:.0f}x, warm {ratio_warm:.0f}x (goal >= 100x)")
    print(f"whole warm CLI `dampfit analyze --report` {cli:.2f} s = {cli / floor:.2f} x the import "
          f"floor of the stack ({floor:.2f} s; goal <= 2x; numpy+scipy+jax+emcee+matplotlib only: "
          f"{floor_narrow:.2f} s, {cli / floor_narrow:.2f} x)")
    print(f"posterior stage ESS/s vs lmfit + emcee: {ratio_sampler:.0f}x (goal >= 250x); with "
          f"the diagnostics computed there ({d_warm['diagnostics_time_s']:.2f} s): "
          f"{d_warm['posterior_with_diagnostics_ess_c_per_s'] / ref['ess_c_per_s']:.0f}x")
    print(f"whole CLI `dampfit analyze` {cli:.1f} s (first run, compiling: {cli_first:.1f} s) vs "
          f"reference {ref['time_per_1000_ess_s']:.0f} s per 1,000 ESS: 1/{cli_ratio:.1f} "
          f"(goal <= 1/20); importing numpy+scipy+jax+emcee+matplotlib alone: {floor:.1f} s "
          f"= 1/{ref['time_per_1000_ess_s'] / floor:.0f}")
    print(f"study throughput: {tput:.0f} least-squares fits per minute")
    print(f"issue 23: warm CLI {cli:.2f} s = {cli / floor_issue:.2f} x the floor of numpy, "
          f"scipy.signal, jax, emcee, matplotlib, arviz ({floor_issue:.2f} s, best of two; goal "
          f"<= 1.5x; in 5 interleaved pairs: median {np.median(pairs):.2f} x, "
          f"{min(pairs):.2f}-{max(pairs):.2f}); a script's first analyze() {first['first_s']:.2f} s = "
          f"{first['first_s'] / first['warm_s']:.2f} x a warm one ({first['warm_s']:.2f} s; goal "
          f"<= 1.5x; after {first['import_s']:.2f} s of 'from dampfit import analyze'; "
          f"{first_off['first_s']:.1f} s with the store off); batch of {a.batch} on 2 "
          f"workers {batch['all'] / a.batch:.2f} s per recording = "
          f"{batch['all'] / a.batch / single:.2f} x one warm dampfit analyze ({single:.2f} s; goal "
          f"<= 0.35x); --summaries-only {batch['summaries'] / a.batch:.2f} s = "
          f"{batch['summaries'] / a.batch / single:.2f} x (after a first batch filling the "
          f"store: {batch['first'] / a.batch:.2f} s per recording, summaries-only); a long "
          f"batch's throughput (the {a.batch}-recording batch minus a {SMALL}-recording one): "
          f"{marginal['all']:.2f} s per recording = {marginal['all'] / single:.2f} x with every "
          f"output, {marginal['summaries']:.2f} s = {marginal['summaries'] / single:.2f} x "
          f"summaries-only (fixed cost {batch['all_small']:.1f} s and "
          f"{batch['summaries_small']:.1f} s)")
    print(f"issue 21: on the one-mode recording the default (up to 4 modes: the screen finds "
          f"one) takes {cli / float(np.median(modes_runs)):.3f} x --max-modes 1 "
          f"({float(np.median(modes_runs)):.2f} s), paired median {np.median(modes_pairs):.3f} x "
          f"({min(modes_pairs):.3f}-{max(modes_pairs):.3f}; goal <= 1.10x)")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
