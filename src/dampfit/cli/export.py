"""``dampfit export DIR --format lsdyna|opensees|calculix``: an FEM deck of the identified system
(:func:`dampfit.fem.export.export`)."""

from __future__ import annotations

import argparse
import math

from dampfit.cli.options import float_arg, progress_reporting
from dampfit.fem import units as units_mod
from dampfit.fem.export import FORMATS


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
    parser.add_argument("--out", metavar="FILE", help="output file (default: DIR/sdof_FORMAT.EXT; "
                        "with --draws a folder, default DIR/sdof_FORMAT_draws)")
    parser.add_argument("--force", action="store_true", help="replace an existing output file")
    parser.add_argument("--law", metavar="LAW",
                        help="'viscous': a linear dashpot (under a non-viscous verdict the "
                             "equivalent linear c at the design amplitude, with a warning); "
                             "'measured': the force-velocity curve fitted to the measured "
                             "envelope (a table F(v): LS-DYNA *DEFINE_CURVE, OpenSees Damper "
                             "of an ElasticMultiLinear); the recommended law's name: that law "
                             "even where its run misses the measured decay; default: the "
                             "recommended damper of summary.json, or the measured curve where "
                             "that law misses the decay (said on stderr and in the deck)")
    parser.add_argument("--draws", type=int, metavar="N",
                        help="write N posterior draws of the system and damper: a folder "
                             "(default DIR/sdof_FORMAT_draws) of draws.csv and N decks "
                             "(1 <= N <= 1000)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the choice of draws (default 0)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress lines (the measured curve's bootstrap, ~10-50 s)")
    parser.add_argument("--force-law", metavar="LAW",
                        help="write LAW (viscous, coulomb, quadratic, power) whatever the "
                             "verdict; needed when no damper is recommended (a misfit)")


def command(args: argparse.Namespace) -> int:
    """Write the deck and print what it holds; exit code 0."""
    import numpy as np

    from dampfit.cli import messages
    from dampfit.fem.export import Deck, export

    deck = Deck(units=args.units, quantile=args.quantile, gravity=args.gravity,
                duration=args.duration, law=getattr(args, "law", None),
                force_law=getattr(args, "force_law", None))
    with progress_reporting(args):
        out, info = export(args.folder, args.format, args.out, deck=deck, force=args.force,
                           draws=getattr(args, "draws", None), seed=getattr(args, "seed", 0))
    dmp = info["damper"]
    for warning in dmp.warnings:  # also in the deck; printed once the command has succeeded
        messages.defer(f"dampfit: warning: {warning}")
    if "rows" in info:  # --draws
        z = np.array([r["zeta_eq_at_design"] for r in info["rows"]])
        print(f"wrote {out}: draws.csv and {info['n']} {FORMATS[args.format][0]}s of the "
              f"{info['law']} damper (posterior draws, seed {info['seed']}, units {info['units']})")
        print(f"  zeta_eq at the design amplitude over the draws: median {np.median(z):.4g}, "
              f"5-95 % [{np.quantile(z, 0.05):.4g}, {np.quantile(z, 0.95):.4g}]")
        return 0
    s, u = info["sdof"], units_mod.get(info["units"])
    print(f"wrote {out} ({FORMATS[args.format][0]}, units {u.name}, posterior quantile "
          f"{info['quantile']:g}{', gravity' if info['gravity'] else ''})")
    print(f"  damper: {damper_words(dmp)}, verdict {dmp.verdict or 'not recorded'}")
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



def damper_words(dmp) -> str:
    """The damper of the deck in one phrase: a law with its coefficients (SI), or the
    measured curve summarised (its points are in the deck, not on the terminal)."""
    from dampfit.fem import damper as damper_mod

    if dmp.law != damper_mod.MEASURED:
        coeffs = ", ".join(f"{k} = {v:.6g}" for k, v in dmp.coefficients.items())
        return f"{dmp.law} law ({coeffs}; SI)"
    v, F = damper_mod.points(dmp.coefficients)
    return (f"the measured force-velocity curve ({v.size} points, v {v[0]:.3g} to "
            f"{v[-1]:.3g} m/s, F up to {F[-1]:.3g} N; listed in the deck)")
