"""``dampfit warm-up``: compile the analysis kernels once per machine (:mod:`dampfit.warmup`).

Analyses one simulated recording per sample bucket up to ``--max-samples`` fitted samples, then
compiles the several-mode kernels (K = 1 … 4) of every modal shape up to the same size, so that
a first real analysis of a recording in those buckets — one in which a second mode is found
included — loads its compiled kernels from the store instead of compiling them. Progress on stderr (a bar on a terminal, lines elsewhere,
none with ``--quiet``); at the end one line says how many buckets were warmed and how many
kernels had to be compiled (0: the store was already warm). Run it again after upgrading
dampfit (the store is keyed by the package's source). Exit 0; a store that is switched off or
unusable: one error line, exit 2.
"""

from __future__ import annotations

import argparse
import sys

from dampfit.cli.options import integer_arg, seed_arg

#: The largest --max-samples accepted (the bucket of a 5e7-sample raw fit).
MAX_SAMPLES = 50_331_648


def add_arguments(w: argparse.ArgumentParser) -> None:
    """Options of ``dampfit warm-up``."""
    from dampfit.warmup import DEFAULT_MAX_SAMPLES

    w.add_argument("--max-samples", type=integer_arg(256, MAX_SAMPLES), metavar="N",
                   default=DEFAULT_MAX_SAMPLES,
                   help=f"warm every sample bucket (one and several modes) up to N fitted samples (default "
                        f"{DEFAULT_MAX_SAMPLES}; larger buckets compile on first use)")
    w.add_argument("--seed", type=seed_arg, default=0, help="seed of the simulated recordings")
    w.add_argument("--quiet", action="store_true", help="no progress bar or lines")


def command(args) -> int:
    """Fill the compiled-kernel store; one summary line on stdout; exit code 0."""
    import contextlib

    from dampfit._progress import reporting
    from dampfit.warmup import warm_up

    with contextlib.nullcontext() if args.quiet else reporting(sys.stderr):
        done = warm_up(args.max_samples, seed=args.seed)
    n = len(done.buckets)
    print(f"dampfit warm-up: {n} sample bucket{'s' if n != 1 else ''} "
          f"({done.buckets[0]} … {done.buckets[-1]} samples) warm; {done.compiled} kernel"
          f"{'s' if done.compiled != 1 else ''} compiled now"
          + (" (the store was already warm)" if done.compiled == 0 else ""))
    return 0
