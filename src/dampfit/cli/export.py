"""``dampfit export DIR --format lsdyna|opensees|calculix``: an FEM deck of the identified system
(:func:`dampfit.fem.export.export`)."""

from __future__ import annotations

import argparse
import math

from dampfit.cli.options import float_arg
from dampfit.fem import units as units_mod
from dampfit.fem.export import FORMATS

__all__ = ["add_arguments", "command"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``dampfit export``."""
    parser.add_argument("folder", metavar="DIR", help="dampfit result folder (with summary.json)")
    parser.add_argument("--format", required=True, choices=list(FORMATS),
                        help="lsdyna (.k), opensees (OpenSeesPy .py) or calculix (.inp)")
    parser.add_argument("--units", default="SI", choices=list(units_mod.UNIT_SYSTEMS),
                        help="SI (m, s, kg, N), mm-ms-kg (mm, ms, kg, kN) or mm-s-t (mm, s, t, N)")
    parser.add_argument("--quantile", type=float_arg, default=0.5, metavar="Q",
                        help="posterior quantile of k, c, u0 (0.05/0.5/0.95 from summary.json, "
                             "others from posterior.nc); default 0.5")
    parser.add_argument("--gravity", action=argparse.BooleanOptionalAction, default=False,
                        help="hang the mass under gravity, released from static equilibrium + u0")
    parser.add_argument("--duration", type=float_arg, metavar="S",
                        help="simulated time [s] (default: the analysed window)")
    parser.add_argument("--out", metavar="FILE", help="output file (default: DIR/sdof_FORMAT.EXT)")
    parser.add_argument("--force", action="store_true", help="replace an existing output file")
    parser.add_argument("--law", metavar="LAW",
                        help="'viscous': a linear dashpot (under a non-viscous verdict the "
                             "equivalent linear c at the design amplitude, with a warning); "
                             "default: the recommended damper of summary.json")
    parser.add_argument("--force-law", metavar="LAW",
                        help="write LAW (viscous, coulomb, quadratic, power) whatever the "
                             "verdict; needed when no damper is recommended (a misfit)")


def command(args: argparse.Namespace) -> int:
    """Write the deck and print what it holds; exit code 0."""
    import sys

    from dampfit.fem.export import export

    command = _command(args)
    out, info = export(args.folder, args.format, args.out, units=args.units,
                       quantile=args.quantile, gravity=args.gravity, duration=args.duration,
                       force=args.force, law=getattr(args, "law", None),
                       force_law=getattr(args, "force_law", None), command=command)
    dmp = info["damper"]
    for warning in dmp.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    s, u = info["sdof"], units_mod.get(info["units"])
    print(f"wrote {out} ({FORMATS[args.format][0]}, units {u.name}, posterior quantile "
          f"{info['quantile']:g}{', gravity' if info['gravity'] else ''})")
    coeffs = ", ".join(f"{k} = {v:.6g}" for k, v in dmp.coefficients.items())
    print(f"  damper: {dmp.law} law ({coeffs}; SI), verdict {dmp.verdict or 'not recorded'}")
    cname = "c_eq at the design amplitude" if dmp.nonlinear else "c"
    print(f"  m = {s.mass:.6g} kg, k = {s.k:.6g} N/m, {cname} = {s.c:.6g} N s/m, u0 = "
          f"{s.u0:.6g} m (zeta = {s.zeta:.4g}, f_n = {s.omega_n / (2 * math.pi):.6g} Hz)")
    print(f"  {info['duration']:g} s, step {info['dt']:.4g} s (T/{s.period / info['dt']:.0f}), "
          f"output every {info['output_dt']:.4g} s")
    md = info.get("modal")
    if md:
        print(f"  modal damping of {md['n_modes']} modes: Rayleigh alpha = "
              f"{md['alpha']['q50']:.4g} 1/s, beta = {md['beta']['q50']:.4g} s (zeta "
              + ", ".join(f"{r['zeta']['q50']:.3g} at {r['f_n']['q50']:.4g} Hz"
                          for r in md["modes"]) + ")")
    return 0


def _command(args: argparse.Namespace) -> str:
    """The export command line of ``args`` (every option that differs from its default), as a
    shell would run it: what the deck's header records (sanitised by each writer)."""
    import shlex

    words = ["dampfit", "export", str(args.folder), "--format", args.format]
    for option, value, default in (("--units", args.units, "SI"),
                                   ("--quantile", args.quantile, 0.5),
                                   ("--duration", args.duration, None),
                                   ("--law", getattr(args, "law", None), None),
                                   ("--force-law", getattr(args, "force_law", None), None),
                                   ("--draws", getattr(args, "draws", None), None),
                                   ("--seed", getattr(args, "seed", None), None)):
        if value != default:
            words += [option, f"{value:g}" if isinstance(value, float) else str(value)]
    if args.gravity:
        words.append("--gravity")
    if args.out:
        words += ["--out", str(args.out)]
    return shlex.join(words)
