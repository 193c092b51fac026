"""``dampfit simulate --out FILE.csv``: a synthetic phyphox CSV with known truth (FILE.truth.json).

With ``--tests N`` (or ``--added-mass``/``--amplitudes`` with one value per test) a campaign
of N recordings of one damper (:func:`dampfit.simulate.campaign`): FILE-1.csv … FILE-N.csv
and one FILE.truth.json, all or none.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from dampfit.physics import MAX_MASS
from dampfit.simulate import MAX_SIM_SAMPLES
from dampfit.cli.options import (integer_arg, mass_arg, non_negative_arg,
                                 positive_arg, real_arg, seed_arg)
from dampfit.errors import InputError

#: Most tests of one campaign and largest --c-spread (the library's limits).
MAX_TESTS = 100
MAX_C_SPREAD = 2.0


def add_arguments(s: argparse.ArgumentParser) -> None:
    """Options of ``dampfit simulate``."""
    s.add_argument("--preset", default="paper", help="starting configuration: paper | phone")
    s.add_argument("--mass", type=mass_arg, metavar="KG", help="oscillating mass [kg]")
    s.add_argument("--f-n", type=positive_arg, metavar="HZ", help="natural frequency [Hz]")
    s.add_argument("--zeta", type=real_arg("a damping ratio in [0, 1)", lambda v: 0 <= v < 1),
                   metavar="Z", help="damping ratio [1], 0 ≤ ZETA < 1")
    s.add_argument("--u0", type=real_arg("a displacement in [0, 100] m", lambda v: 0 <= v <= 100),
                   metavar="M", help="initial displacement [m]")
    s.add_argument("--duration", type=positive_arg, metavar="S", help="record length [s]")
    s.add_argument("--sample-rate", type=positive_arg, metavar="HZ",
                   help=f"sample rate [Hz]; duration × sample rate ≤ {MAX_SIM_SAMPLES:g} samples")
    s.add_argument("--jitter", type=real_arg("a coefficient of variation in [0, 1]",
                                          lambda v: 0 <= v <= 1), metavar="CV")
    s.add_argument("--noise-density", type=non_negative_arg, metavar="UG", help="µg/√Hz")
    s.add_argument("--drift", type=non_negative_arg, metavar="MS2", help="bias drift rms [m/s²]")
    s.add_argument("--tilt", type=real_arg("an angle in [-90, 90] degrees", lambda v: abs(v) <= 90),
                   metavar="DEG")
    s.add_argument("--handheld", type=non_negative_arg, metavar="S")
    s.add_argument("--gravity", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--catch", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--dialect", default="comma", choices=["comma", "tab", "semicolon"])
    s.add_argument("--seed", type=seed_arg, default=0)
    s.add_argument("--out", required=True, metavar="FILE.csv")
    s.add_argument("--force", action="store_true",
                   help="overwrite existing files FILE.csv and FILE.truth.json")
    g = s.add_argument_group("campaign (several recordings of one damper)")
    g.add_argument("--tests", type=integer_arg(2, MAX_TESTS, f"an integer from 2 to {MAX_TESTS}"),
                   metavar="N", help="write N recordings FILE-1.csv … FILE-N.csv of the same "
                   "system and one FILE.truth.json")
    g.add_argument("--c-spread", type=real_arg(f"a spread in [0, {MAX_C_SPREAD:g}] (sd of ln c)",
                                            lambda v: 0 <= v <= MAX_C_SPREAD),
                   metavar="F", help="between-test sd of ln c [1] (≈ relative sd; default 0)")
    g.add_argument("--added-mass", type=real_arg(f"a mass in [0, {MAX_MASS:g}] kg",
                                              lambda v: 0 <= v <= MAX_MASS),
                   nargs="+", metavar="KG", help="known added mass of each test [kg] (0 for the "
                   "bare system); sets N when --tests is not given")
    g.add_argument("--added-mass-sd", type=real_arg(f"a standard deviation in [0, {MAX_MASS:g}] kg",
                                                 lambda v: 0 <= v <= MAX_MASS),
                   metavar="KG", help="scale error of each added mass [kg]: the mass simulated "
                   "is the stated one plus a normal error of this sd (0 stays exact; default 0)")
    g.add_argument("--amplitudes", type=real_arg("a displacement in [0, 100] m",
                                              lambda v: 0 <= v <= 100),
                   nargs="+", metavar="M", help="release displacement u0 of each test [m]")


_SIM_FIELDS = {"mass": "mass", "u0": "u0", "duration": "duration", "sample_rate": "sample_rate",
               "jitter": "jitter", "noise_density": "noise_density", "drift": "drift",
               "tilt": "tilt_deg", "handheld": "handheld", "gravity": "gravity", "catch": "catch"}


def _sim_config(args):
    from dampfit import simulate as sim

    over = {field: getattr(args, name) for name, field in _SIM_FIELDS.items()
            if getattr(args, name) is not None}
    cfg = sim.preset(args.preset, seed=args.seed, **over)
    if args.f_n is not None or args.zeta is not None:
        from dampfit.physics import critical_damping

        f_n = args.f_n if args.f_n is not None else (cfg.k / cfg.mass) ** 0.5 / (2 * 3.141592653589793)
        zeta = args.zeta if args.zeta is not None else cfg.c / float(critical_damping(cfg.k, cfg.mass))
        fields = {k: getattr(cfg, k) for k in cfg.__dataclass_fields__ if k not in ("k", "c", "mass")}
        cfg = sim.from_modal(cfg.mass, f_n, zeta, **fields)
    n = cfg.duration * cfg.sample_rate
    if n > MAX_SIM_SAMPLES:
        raise InputError(f"--duration {cfg.duration:g} s at --sample-rate {cfg.sample_rate:g} Hz "
                         f"would be {n:.3g} samples; at most {MAX_SIM_SAMPLES:g} are simulated")
    f_n = (cfg.k / cfg.mass) ** 0.5 / (2 * math.pi)
    if not f_n < cfg.sample_rate / 2:
        raise InputError(f"natural frequency {f_n:g} Hz is not below the Nyquist frequency "
                         f"{cfg.sample_rate / 2:g} Hz of --sample-rate {cfg.sample_rate:g} Hz")
    return cfg


def _write_failure(out, exc: Exception) -> InputError:
    """One line for a failed write of ``out`` (an OSError, or a WriteError raised while writing
    into the staging folder): nothing was written."""
    from dampfit.files.atomic import error_text

    if isinstance(exc, OSError):
        reason = error_text(exc)
    else:
        cause = exc.__cause__
        reason = error_text(cause) if isinstance(cause, OSError) else str(exc)
    return InputError(f"cannot write {out}: {reason}; nothing was written")


def command(args) -> int:
    """``dampfit simulate``: FILE.csv and FILE.truth.json, both or neither (a campaign:
    :func:`_campaign_command`).

    Before any work: both names are checked (:func:`dampfit.files.folder.check_output_file`: an
    existing file or link only with --force, never a directory; a name too long or a missing
    folder is one line) and the configuration against :func:`dampfit.simulate.check_limits`.
    Both files are written into a private staging folder beside them and renamed into place
    (:func:`_write_all`), so a failed write (full disk, read-only folder) leaves nothing
    behind. Every file-system failure is an :class:`InputError` (exit 2, one line).
    """
    from dampfit import simulate as sim

    if _campaign_size(args) is not None:
        return _campaign_command(args)
    out = _checked_out(args, lambda out: [out, out.with_suffix(".truth.json")])
    truth_path = out.with_suffix(".truth.json")
    cfg = _sim_config(args)
    sim.check_limits(cfg)
    rec, truth = sim.recording(cfg)
    _write_all(out, [(lambda f: sim.write_phyphox_csv(rec, f, dialect=args.dialect), out),
                     (lambda f: sim.write_truth(truth, f), truth_path)])
    print(f"wrote {out} ({rec.n_samples} samples, {rec.duration:.4g} s) and {truth_path}: "
          f"c = {truth['c']:.6g} N s/m, k = {truth['k']:.6g} N/m, m = {truth['mass']:.6g} kg, "
          f"f_n = {truth['f_n']:.6g} Hz, zeta = {truth['zeta']:.4g}")
    return 0


def _checked_out(args, targets) -> Path:
    """``--out`` as a Path, once every file ``targets(out)`` names is checked writable
    (:func:`dampfit.files.atomic.check_output_file`) and its folder enterable and writable."""
    from dampfit.files.atomic import check_output_file

    out = Path(args.out)
    if not out.name or out.name in (".", ".."):
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv")
    try:
        paths = targets(out)
    except ValueError:
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv") from None
    for f in paths:
        check_output_file(f, args.force)
    if not os.access(out.parent, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into {os.path.abspath(out.parent)}: permission denied")
    return out


def _write_all(out: Path, writes) -> None:
    """Each ``(write, path)`` of ``writes``: ``write(file)`` into a private staging folder
    beside ``out``, then every file renamed onto its ``path``, all or none (:func:`_publish`);
    a failure is one :class:`InputError` line and nothing is written."""
    import shutil
    import tempfile

    from dampfit.files.atomic import error_text

    try:
        stage = Path(tempfile.mkdtemp(prefix=".dampfit-simulate-", dir=out.parent))
    except OSError as exc:
        raise InputError(f"cannot write {out}: {error_text(exc)}; nothing was written") from None
    try:
        for write, path in writes:
            write(stage / path.name)
        _publish(stage, [path for _, path in writes])
    except (OSError, InputError) as exc:
        raise _write_failure(out, exc) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)


# -- campaigns ------------------------------------------------------------------------------


def _campaign_size(args) -> int | None:
    """Number of tests asked for, or None for one recording (today's behaviour).

    ``--tests`` gives it; else the count of ``--added-mass`` or ``--amplitudes`` values. A
    list whose length differs from it, or ``--c-spread`` without a campaign, is one line.
    """
    lists = [(opt, getattr(args, name, None)) for opt, name in
             (("--added-mass", "added_mass"), ("--amplitudes", "amplitudes"))]
    given = [(opt, v) for opt, v in lists if v is not None]
    if getattr(args, "added_mass_sd", None) is not None and getattr(args, "added_mass", None) is None:
        raise InputError("--added-mass-sd needs --added-mass (one value per test)")
    n = getattr(args, "tests", None)
    if n is None and given:
        n = len(given[0][1])
        if n < 2:
            raise InputError(f"{given[0][0]} gives 1 value: a campaign needs at least 2 tests "
                             "(one value per test)")
    if n is None:
        if getattr(args, "c_spread", None) is not None:
            raise InputError("--c-spread needs a campaign: give --tests N (or --added-mass "
                             "with one value per test)")
        return None
    for opt, values in given:
        if len(values) != n:
            raise InputError(f"{opt} gives {len(values)} value(s) for {n} tests; give one per test")
    return n


def campaign_paths(out: Path, n: int) -> tuple[list[Path], Path]:
    """FILE-1.csv … FILE-N.csv and FILE.truth.json for ``--out FILE.csv``."""
    return ([out.with_name(f"{out.stem}-{i}{out.suffix}") for i in range(1, n + 1)],
            out.with_suffix(".truth.json"))


def _campaign_command(args) -> int:
    """``dampfit simulate --tests N``: N CSVs and one truth file, all or none.

    The same checks as one recording, before any work, for every name; all files are
    written into a private staging folder beside them and renamed into place; if a rename
    fails, the files already renamed are removed (or, with --force, the old ones put back).
    """
    from dampfit import simulate as sim

    n = _campaign_size(args)
    out = _checked_out(args, lambda o: [*campaign_paths(o, n)[0], o.with_suffix(".truth.json")])
    csvs, truth_path = campaign_paths(out, n)
    base = _sim_config(args)
    sim.check_limits(base)
    recs, truth = sim.campaign(base, n_tests=n, c_spread=args.c_spread or 0.0,
                               added_mass=args.added_mass, amplitudes=args.amplitudes,
                               added_mass_sd=args.added_mass_sd or 0.0, seed=args.seed)
    writes = [(lambda f, rec=rec: sim.write_phyphox_csv(rec, f, dialect=args.dialect), path)
              for rec, path in zip(recs, csvs)]
    _write_all(out, [*writes, (lambda f: sim.write_truth(truth, f), truth_path)])
    print(f"wrote {csvs[0]} … {csvs[-1]} ({n} tests, {recs[0].duration:.4g} s each) and "
          f"{truth_path}: c = {truth['c']:.6g} N s/m (median; spread {truth['c_spread']:g} in "
          f"ln c), k = {truth['k']:.6g} N/m, m0 = {truth['mass']:.6g} kg")
    for i, (c, m, f, u0) in enumerate(zip(truth["c_tests"], truth["mass_tests"],
                                          truth["f_n_tests"], truth["u0_tests"]), 1):
        print(f"  test {i}: c = {c:.6g} N s/m, m = {m:.6g} kg, f_n = {f:.6g} Hz, u0 = {u0:.4g} m")
    return 0


def _publish(stage: Path, targets: list[Path]) -> None:
    """Rename ``stage/<name>`` onto each target, all or none.

    An existing target (allowed by --force) is first moved into ``stage`` so it can be put
    back; on an OSError every target already renamed is removed or restored, then the error
    propagates.
    """
    done: list[tuple[Path, Path | None]] = []
    try:
        for i, dest in enumerate(targets):
            backup = None
            if os.path.lexists(dest):
                backup = stage / f".previous-{i}"
                os.replace(dest, backup)
            try:
                os.replace(stage / dest.name, dest)
            except OSError:
                if backup is not None:
                    os.replace(backup, dest)
                raise
            done.append((dest, backup))
    except OSError:
        for dest, backup in reversed(done):
            try:
                if backup is None:
                    os.unlink(dest)
                else:
                    os.replace(backup, dest)
            except OSError:
                pass
        raise
