"""Option converters of the command line: every number is checked by the parser, one line each.

A converter raises :class:`argparse.ArgumentTypeError` with the reason (``must be WHAT, got
TEXT``); the parser (:class:`Parser`) turns it into one :class:`~dampfit.errors.InputError`
line, exit code 2. The limits are the library's (:data:`dampfit.physics.MAX_MASS`,
:data:`dampfit.simulate.MAX_SIM_SAMPLES`), so the CLI and the library refuse the same values.
"""

from __future__ import annotations

import argparse
import math

from dampfit._options import (ANALYSIS_MAX_MODES, CAMPAIGN_MAX_MODES, DEFAULT_MAX_MODES,  # noqa: F401
                              DEFAULT_MAX_STEPS, DEFAULT_SEED, MAX_MODES_LIMIT, MAX_STEPS,
                              SEED_LIMIT, convert)
from dampfit.errors import InputError
from dampfit.physics import MAX_MASS

# The limits and defaults are those of :mod:`dampfit._options` (the rules the Python face
# checks too); --max-modes when not given: CAMPAIGN_MAX_MODES (1) for a campaign, its tests'
# own modes are opt-in (each test would pay the modal analysis; the pooling is of one mode).


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(f"{message} (see '{self.prog} --help')")


def real_arg(what: str = "a finite number", ok=None):
    """argparse type: a finite float for which ``ok(value)`` holds, else 'must be WHAT'."""

    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not math.isfinite(v) or (ok is not None and not ok(v)):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text}")
        return v

    return conv


def integer_arg(lo: int, hi: int, what: str | None = None):
    """argparse type: an integer in [lo, hi]."""

    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(
                f"must be {what or f'an integer from {lo} to {hi}'}, got {v}")
        return v

    return conv


def rule_arg(name: str):
    """argparse type of the option ``name`` under its rule in :data:`dampfit._options.RULES`
    (the one the Python face checks too)."""

    def conv(text: str):
        try:
            return convert(name, text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return conv


def scheduler_arg(text: str) -> str:
    """argparse type of ``--scheduler``: a non-empty address (an empty one is not ignored)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must be a Dask scheduler address such as "
                                         "tcp://host:8786, got an empty string")
    return text


#: argparse type for a float option with a one-line error: a finite number (NaN and ±inf are
#: refused).
float_arg = real_arg()
#: argparse type of every ``--seed``: an integer in [0, 2³²).
seed_arg = rule_arg("seed")

positive_arg = real_arg("a positive finite number", lambda v: v > 0)
non_negative_arg = real_arg("a finite number ≥ 0", lambda v: v >= 0)
mass_arg = real_arg("a positive mass in kg (at most 1e6)", lambda v: 0 < v <= MAX_MASS)


def add_analysis_options(a: argparse.ArgumentParser, quiet_help: str = "no progress bar") -> None:
    """The analysis options of ``dampfit analyze`` (and of ``dampfit record``, which analyses
    its recording the same way): mass, axis, window, band, sampler, outputs."""
    a.add_argument("--mass", type=mass_arg, metavar="KG", help="oscillating mass [kg]")
    a.add_argument("--mass-sd", type=real_arg("a standard deviation ≥ 0 kg", lambda v: v >= 0),
                   metavar="KG", default=None, help="standard deviation of the mass [kg]")
    a.add_argument("--axis", default="auto", help="x, y, z, another column name, or auto")
    a.add_argument("--window", nargs=2, type=rule_arg("window"), metavar=("START", "END"),
                   help="free-decay window [s] in the recording's time base, START < END")
    a.add_argument("--band", nargs=2, type=rule_arg("band"),
                   metavar=("LO", "HI"), help="pass band [Hz] around the oscillation, 0 < LO < HI")
    a.add_argument("--seed", type=seed_arg, default=DEFAULT_SEED,
                   help=f"random seed of the sampler, 0 to {SEED_LIMIT - 1}")
    a.add_argument("--max-steps", type=rule_arg("max_steps"), default=DEFAULT_MAX_STEPS,
                   help=f"sampler step limit, 1 to {MAX_STEPS}")
    a.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    a.add_argument("--json", action="store_true", help="print summary.json instead of the table")
    a.add_argument("--quiet", action="store_true", help=quiet_help)
    a.add_argument("--report", action="store_true", help="also write report.html and report.md")
    from dampfit.model.laws import names as law_names  # light: JAX is imported on first use

    a.add_argument("--model", default="auto", choices=("auto",) + law_names(),
                   help="damping law reported as c_equivalent (auto: the one the evidence "
                        "prefers); all are compared in model_checks either way")
    a.add_argument("--amplitude", type=rule_arg("amplitude"), metavar="M",
                   help="displacement amplitude [m] at which a non-viscous law's equivalent "
                        "viscous c is reported (the amplitude your FEM model will see)")
    a.add_argument("--max-modes", type=rule_arg("max_modes"), metavar="N",
                   default=None,
                   help=f"most modes looked for in the recording, 1 to {MAX_MODES_LIMIT} "
                        f"(default {ANALYSIS_MAX_MODES} for one recording, {CAMPAIGN_MAX_MODES} "
                        "for a campaign's tests; 1 skips the modal analysis; paper/modes.md)")
    a.add_argument("--mode-of-mass", type=rule_arg("mode_of_mass"), metavar="N",
                   default=None,
                   help="the mode (1 = lowest frequency) the --mass belongs to: only it gets "
                        "c and k (default: the dominant mode)")


def analysis_options(args):
    """The analysis options of ``args`` as the one :class:`~dampfit._options.AnalysisOptions`
    of the run, built (and so checked: the relations between options, single values being
    checked by the parser already) before any work, as the Python face builds it."""
    from dampfit._options import AnalysisOptions, SamplerSettings

    return AnalysisOptions(
        axis=args.axis, window=tuple(args.window) if args.window else None,
        band=tuple(args.band) if args.band else None, model=getattr(args, "model", "auto"),
        amplitude=getattr(args, "amplitude", None), max_modes=getattr(args, "max_modes", None),
        mode_of_mass=getattr(args, "mode_of_mass", None),
        sampler=SamplerSettings(seed=args.seed, max_steps=args.max_steps,
                                progress=not args.quiet))


def add_reading_options(a: argparse.ArgumentParser) -> None:
    """The reading options of ``dampfit analyze`` and ``dampfit batch``
    (:data:`dampfit.io.readers.READ_OPTIONS`)."""
    g = a.add_argument_group("reading (generic CSV/NPY, lab exports, Excel, MATLAB, LVM, TDMS, UFF)")
    g.add_argument("--time-column", metavar="COL", help="time column name or 0-based index")
    g.add_argument("--accel-columns", metavar="COL", nargs="+", help="acceleration column(s)")
    g.add_argument("--time-unit", choices=["s", "ms", "us", "ns"], help="unit of the time column")
    g.add_argument("--accel-unit", choices=["m/s2", "g", "mg"], help="unit of the acceleration")
    g.add_argument("--sheet", help="Excel sheet name")
    g.add_argument("--run", metavar="RUN",
                   help="lab export with several runs (Logger Pro, Graphical Analysis, "
                        "Capstone): the run to read, e.g. 'Run #2' or 2 (default: the first)")
    g.add_argument("--variable", metavar="PATH",
                   help="MATLAB .mat: the array to read, e.g. Fe.Out.Acc (default: detected)")
    g.add_argument("--row", type=rule_arg("row"), metavar="N",
                   help="MATLAB .mat: 0-based row of that array holding the acceleration; "
                        "UFF: the 0-based number of the data set 58 record to read")
    g.add_argument("--rate", type=rule_arg("rate"), metavar="HZ",
                   help="sample rate [Hz] of a table without a time column (a data logger's "
                        "channels): time = sample number / HZ")
    g.add_argument("--group", metavar="NAME", help="TDMS: the group to read (default: the only one)")
    g.add_argument("--channel", metavar="NAME",
                   help="the acceleration channel by name (TDMS, LVM, a logger's column; "
                        "default: the channels whose unit or name says acceleration)")


#: Most local worker processes ``--workers`` may start (each is a Python process with JAX).
MAX_WORKERS = 256


def positive_int(text: str) -> int:
    """A worker count: an integer from 1 to :data:`MAX_WORKERS` (argparse type)."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {v}")
    if v > MAX_WORKERS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_WORKERS}, got {v}")
    return v


def add_cluster_options(parser, *, workers_note: str, force_help: str) -> None:
    """``--workers N``, ``--scheduler ADDRESS`` and ``--force`` of the commands that run on
    Dask (``study``, ``batch``; :mod:`dampfit.cluster`): ``workers_note`` ends the help of
    ``--workers``, ``force_help`` is the help of ``--force``."""
    parser.add_argument("--workers", type=positive_int, metavar="N", default=None,
                        help=f"local Dask worker processes, 1 to {MAX_WORKERS} (default: the "
                             f"number of CPUs; {workers_note})")
    parser.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_arg,
                        help="use an existing Dask scheduler, e.g. tcp://host:8786 (tls:// with "
                             "Dask's TLS settings; the workers must see the output folder at "
                             "the same path; ignores --workers)")
    parser.add_argument("--force", action="store_true", help=force_help)


def progress_reporting(args):
    """The long stages' progress on stderr (:mod:`dampfit._progress`): a tqdm bar with its ETA
    on a terminal, a few lines a stage with their ETAs anywhere else; none with ``--quiet``."""
    import contextlib
    import sys

    from dampfit._progress import reporting

    return contextlib.nullcontext() if getattr(args, "quiet", False) else reporting(sys.stderr)
