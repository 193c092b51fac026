"""``dampfit simulate --out FILE.csv``: a synthetic phyphox CSV with known truth (FILE.truth.json)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from dampfit.cli.options import (MAX_SIM_SAMPLES, _mass, _non_negative, _positive, _real,
                                 seed_arg)
from dampfit.errors import InputError

__all__ = ["add_arguments", "command"]


def add_arguments(s: argparse.ArgumentParser) -> None:
    """Options of ``dampfit simulate``."""
    s.add_argument("--preset", default="paper", help="starting configuration: paper | phone")
    s.add_argument("--mass", type=_mass, metavar="KG", help="oscillating mass [kg]")
    s.add_argument("--f-n", type=_positive, metavar="HZ", help="natural frequency [Hz]")
    s.add_argument("--zeta", type=_real("a damping ratio in [0, 1)", lambda v: 0 <= v < 1),
                   metavar="Z", help="damping ratio [1], 0 ≤ ZETA < 1")
    s.add_argument("--u0", type=_real("a displacement in [0, 100] m", lambda v: 0 <= v <= 100),
                   metavar="M", help="initial displacement [m]")
    s.add_argument("--duration", type=_positive, metavar="S", help="record length [s]")
    s.add_argument("--sample-rate", type=_positive, metavar="HZ",
                   help=f"sample rate [Hz]; duration × sample rate ≤ {MAX_SIM_SAMPLES:g} samples")
    s.add_argument("--jitter", type=_real("a coefficient of variation in [0, 1]",
                                          lambda v: 0 <= v <= 1), metavar="CV")
    s.add_argument("--noise-density", type=_non_negative, metavar="UG", help="µg/√Hz")
    s.add_argument("--drift", type=_non_negative, metavar="MS2", help="bias drift rms [m/s²]")
    s.add_argument("--tilt", type=_real("an angle in [-90, 90] degrees", lambda v: abs(v) <= 90),
                   metavar="DEG")
    s.add_argument("--handheld", type=_non_negative, metavar="S")
    s.add_argument("--gravity", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--catch", action=argparse.BooleanOptionalAction, default=None)
    s.add_argument("--dialect", default="comma", choices=["comma", "tab", "semicolon"])
    s.add_argument("--seed", type=seed_arg, default=0)
    s.add_argument("--out", required=True, metavar="FILE.csv")
    s.add_argument("--force", action="store_true",
                   help="overwrite existing files FILE.csv and FILE.truth.json")


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


def command(args) -> int:
    """``dampfit simulate``: FILE.csv and FILE.truth.json, both or neither.

    Before any work: both names are checked (:func:`dampfit._files.check_output_file`: an
    existing file or link only with --force, never a directory; a name too long or a missing
    folder is one line) and the configuration against :func:`dampfit.simulate.check_limits`.
    Both files are written into a private staging folder beside them and renamed into place,
    so a failed write (full disk, read-only folder) leaves nothing behind. Every file-system
    failure is an :class:`InputError` (exit 2, one line).
    """
    import shutil
    import tempfile

    from dampfit import simulate as sim
    from dampfit._files import _reason, check_output_file

    out = Path(args.out)
    if not out.name or out.name in (".", ".."):
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv")
    try:
        truth_path = out.with_suffix(".truth.json")
    except ValueError:
        raise InputError(f"--out {args.out} names no file; give a file name such as rec.csv") from None
    for f in (out, truth_path):
        check_output_file(f, args.force)
    if not os.access(out.parent, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into {os.path.abspath(out.parent)}: permission denied")
    cfg = _sim_config(args)
    sim.check_limits(cfg)
    rec, truth = sim.simulate(cfg)
    try:
        stage = Path(tempfile.mkdtemp(prefix=".dampfit-simulate-", dir=out.parent))
    except OSError as exc:
        raise InputError(f"cannot write {out}: {_reason(exc)}; nothing was written") from None
    existed = os.path.lexists(out)
    try:
        sim.write_phyphox_csv(rec, stage / out.name, dialect=args.dialect)
        sim.write_truth(truth, stage / truth_path.name)
        os.replace(stage / out.name, out)
        try:
            os.replace(stage / truth_path.name, truth_path)
        except OSError:
            if not existed:  # both or neither
                out.unlink(missing_ok=True)
            raise
    except OSError as exc:
        raise InputError(f"cannot write {out}: {_reason(exc)}; nothing was written") from None
    except InputError as exc:  # a failed write in the staging folder
        cause = exc.__cause__
        reason = _reason(cause) if isinstance(cause, OSError) else str(exc)
        raise InputError(f"cannot write {out}: {reason}; nothing was written") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    print(f"wrote {out} ({rec.n_samples} samples, {rec.duration:.4g} s) and {truth_path}: "
          f"c = {truth['c']:.6g} N s/m, k = {truth['k']:.6g} N/m, m = {truth['mass']:.6g} kg, "
          f"f_n = {truth['f_n']:.6g} Hz, zeta = {truth['zeta']:.4g}")
    return 0
