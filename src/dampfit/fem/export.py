"""An FEM deck of the identified system (``dampfit export DIR --format lsdyna|opensees|calculix``,
:mod:`dampfit.cli.export`).

The system (m, k, c, u0 at a posterior quantile; see :mod:`dampfit.fem.sdof`) is written as

* ``lsdyna``  — an LS-DYNA keyword deck (.k), the seed paper's discrete-element model
  (:mod:`dampfit.fem.lsdyna`);
* ``opensees`` — a runnable OpenSeesPy script (.py) that writes the displacement history
  (:mod:`dampfit.fem.opensees`); ``dampfit verify`` runs exactly this script (the defaults'
  text, SHA-256 in verification.json; :mod:`dampfit.fem.verify`);
* ``calculix`` — a CalculiX input deck (.inp) (:mod:`dampfit.fem.calculix`; CalculiX is not
  installed here, the deck is verified by reading it back).

Units: ``--units SI`` (m, s, kg, N), ``mm-ms-kg`` (mm, ms, kg, kN) or ``mm-s-t`` (mm, s,
tonne, N), converted with :mod:`dampfit.fem.units`. The run lasts ``--duration`` [s]
(default: the analysed window), the output interval is the recording's sample interval (at
most T/50) and the fixed time step comes from :func:`dampfit.fem.timestep.choose`
(≥ 200 steps per period, phase error ≤ 1e-3 rad at the end). With ``--gravity`` the mass
hangs under g = 9.80665 m/s² and is released from static equilibrium + u0.

**The damper** (issue 32; :mod:`dampfit.fem.damper`) is summary.json's recommendation
(``damper``): the law with its coefficients' medians — LS-DYNA *MAT_DAMPER_NONLINEAR_VISCOUS
with its force–velocity *DEFINE_CURVE (symmetric, through 0, to 5× the fastest measured
velocity; the deck says where it is extrapolated), OpenSees ``Viscous c_alpha alpha`` or a
``Parallel`` material (quadratic: Viscous α = 1 + Viscous α = 2; Coulomb: Viscous + an
ElasticPP friction element, its stick stiffness stated), CalculiX (linear *DASHPOT only) the
linear c at the design amplitude with that limitation stated. Every deck's header gives the
verdict, the law and its coefficients, the measured amplitude range, the notes and the
command that writes it (:func:`canonical_command`). Where the recording shows that the law's
two coefficients miss its decay — the law's run (:func:`dampfit.fem.response.free_run`) lies
farther from the measured envelope's trend than the measurement scatters about it, and the
measured curve's run comes closer (:func:`dampfit.fem.measured.default_damper`) — the deck is
that curve instead, said in the deck and on stderr with the numbers; ``law=LAW`` (``--law
LAW``, the recommended law's name) writes the law regardless, and so does every posterior draw
(``--draws``: the law's posterior). ``law="measured"`` (``--law measured``) always writes the
force–velocity curve fitted to the measured envelope (:mod:`dampfit.fem.measured`: a table
F(v) piecewise linear in |v| with slopes ≥ 0; LS-DYNA its *DEFINE_CURVE, OpenSees a Damper
material wrapping an ElasticMultiLinear of its points, CalculiX its c_eq at the design
amplitude), said in the deck; ``law="viscous"`` (``--law viscous``)
writes a linear dashpot: under a non-viscous verdict the equivalent linear c at the design
amplitude (``damper.c_linear``), with a warning (stderr and deck); ``force_law``
(``--force-law LAW``) any law, and is needed when no damper is recommended (a misfit). A
summary without a ``damper`` section (written before it existed) gives the viscous posterior
c as before, with a note in the deck. ``--draws N`` writes N posterior draws instead
(:mod:`dampfit.fem.draws`: a folder of ``draws.csv`` and N decks). Modes that are seen but
not identified (``modes_seen``, ``"identified": false``) never reach a deck; the deck names
them (:func:`dampfit.fem.modal.modal_note`).

A campaign folder (several recordings of one damper) gives the population damper
(:func:`dampfit.fem.sdof.load`); the deck says so in a comment line near its top, with the
number of tests and the predictive interval of c for a new test. Its duration is the longest
test window, its output interval from the highest test sample rate.

The file is written atomically and an existing one (a symbolic link too, even a dangling one:
the link is replaced, never its target) is replaced only with ``--force``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dampfit.files.atomic import atomic_write_text, check_output_file
from dampfit.errors import InputError
from dampfit.fem import damper as damper_mod
from dampfit.fem import sdof as sdof_mod
from dampfit.result.schema import number
from dampfit.fem import timestep
from dampfit.fem import units as units_mod
from dampfit.errors import shown
from dampfit.result.schema import folder_of

#: format → (description, default file name)
FORMATS: dict[str, tuple[str, str]] = {
    "lsdyna": ("LS-DYNA keyword deck", "sdof_lsdyna.k"),
    "opensees": ("OpenSeesPy script", "sdof_opensees.py"),
    "calculix": ("CalculiX input deck", "sdof_calculix.inp"),
}


@dataclass(frozen=True)
class Deck:
    """What a deck is of, beside its format: ``units`` (:mod:`dampfit.fem.units`), the
    posterior ``quantile``, ``gravity`` (the mass hangs under g), ``duration`` [s] (None: the
    analysed window), ``law`` (``"viscous"``, ``"measured"`` or the recommended law's name) and
    ``force_law`` (any law):
    ``dampfit export``'s options, which travel together from the command line to the deck and
    back into its header (:func:`canonical_command`)."""

    units: str = "SI"
    quantile: float = 0.5
    gravity: bool = False
    duration: float | None = None
    law: str | None = None
    force_law: str | None = None


def output_interval(period: float, sample_rate: float | None) -> float:
    """Output interval [s]: the sample interval 1/``sample_rate`` [Hz], at most ``period``/50 [s],
    rounded to the nearest 1-2-5 number (not above period/50), so the decks read well."""
    target = period / 50.0
    if isinstance(sample_rate, (int, float)) and math.isfinite(sample_rate) and sample_rate > 0:
        target = min(target, 1.0 / sample_rate)
    nice = [m * 10.0**e for e in range(math.floor(math.log10(target)) - 1,
                                       math.floor(math.log10(target)) + 2) for m in (1, 2, 5)]
    allowed = [x for x in nice if x <= period / 50.0 * (1 + 1e-12)]
    return min(allowed, key=lambda x: abs(math.log(x / target)))


def run_duration(summary: dict[str, Any], duration: float | None, path: Path) -> float:
    """Simulated time [s]: ``duration``, else the analysed window of summary.json ``path``
    (of a campaign the longest test window); :class:`InputError` if there is none."""
    if duration is None and summary.get("kind") == "campaign":
        duration = _campaign_duration(summary, path)
    if duration is None:
        w = summary.get("window") or {}
        if w.get("start_s") is None or w.get("end_s") is None:
            raise InputError(f"{shown(path)} has no analysis window; give --duration S")
        start = number(w["start_s"], "window.start_s", path)
        end = number(w["end_s"], "window.end_s", path)
        if not end > start:
            raise InputError(f"{shown(path)}: window.end_s ({end:g}) must be after window.start_s "
                             f"({start:g}); give --duration S")
        duration = end - start
    if isinstance(duration, bool) or not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {duration!r}")
    return float(duration)


def _campaign_duration(summary: dict[str, Any], path: Path) -> float:
    """Longest analysed window [s] of the tests of a campaign summary."""
    spans = []
    for i, t in enumerate(summary.get("tests") or []):
        w = t.get("window") if isinstance(t, dict) else None
        if isinstance(w, dict) and w.get("start_s") is not None and w.get("end_s") is not None:
            start = number(w["start_s"], f"tests[{i}].window.start_s", path)
            end = number(w["end_s"], f"tests[{i}].window.end_s", path)
            if end > start:
                spans.append(end - start)
    if not spans:
        raise InputError(f"{shown(path)} has no analysis window in its tests; give --duration S")
    return max(spans)


def _sample_rate(summary: dict[str, Any], path: Path) -> float | None:
    """``input.sample_rate_hz`` [Hz] of the summary (``None`` if absent), checked; of a
    campaign the highest of its tests'."""
    if summary.get("kind") == "campaign":
        rates = [number(t["input"]["sample_rate_hz"], f"tests[{i}].input.sample_rate_hz",
                                 path, positive=True)
                 for i, t in enumerate(summary.get("tests") or []) if isinstance(t, dict)
                 and isinstance(t.get("input"), dict) and t["input"].get("sample_rate_hz") is not None]
        return max(rates) if rates else None
    fs = (summary.get("input") or {}).get("sample_rate_hz")
    return None if fs is None else number(fs, "input.sample_rate_hz", path, positive=True)


def build(folder: str | Path | Any, fmt: str, deck: Deck = Deck(), *, name: str | None = None,
          command: str | None = None, variant=None) -> tuple[str, dict[str, Any]]:
    """Text of the ``fmt`` deck for result ``folder`` (or an analysis :func:`dampfit.load` read
    from one) and a plain-data description of it, under the options ``deck`` (:class:`Deck`).

    ``deck.duration`` [s] (default: the analysed window); ``name`` is the script's file name
    (OpenSees only, used in its help text). Raises :class:`InputError` for bad input: every
    summary.json field the deck uses is checked first (type, finite, range; see
    :func:`dampfit.result.schema.number`), so a bad value is one error line and no deck.

    The damper is the summary's recommendation, ``deck.law="viscous"`` a linear dashpot,
    ``deck.force_law`` any law (:func:`dampfit.fem.damper.choose`); ``command`` (the command line
    that asked for the deck) is written into its header with the damper's sentences.
    ``variant(sdof, damper) -> (sdof, damper, header lines)`` replaces the system and damper
    before the deck is written (one posterior draw: :mod:`dampfit.fem.draws`).
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    units, quantile, gravity, duration = deck.units, deck.quantile, deck.gravity, deck.duration
    system = units_mod.get(units)
    sdof = sdof_mod.load(folder, quantile, gravity)
    folder, summary = sdof_mod.read_summary(folder)
    path = folder / "summary.json"
    dmp, sdof = _damper(summary, path, sdof, deck, auto=variant is None)
    header = damper_mod.describe(dmp, command or canonical_command(folder, fmt, deck))
    if variant is not None:
        sdof, dmp, extra = variant(sdof, dmp)
        header = list(extra) + header
    dur = run_duration(summary, duration, path)
    fs = _sample_rate(summary, path)
    output_dt = output_interval(sdof.period, fs)
    dt = timestep.choose(sdof.omega_n, dur, output_dt)
    if dur / dt > 5e7:
        raise InputError(f"{dur:g} s at a step of {dt:.3g} s is over 5e7 steps; give a shorter --duration")
    from dampfit.fem.modal import modal_damping

    modal = None if summary.get("kind") == "campaign" else modal_damping(summary, path)
    if fmt == "lsdyna":
        from dampfit.fem.lsdyna import deck

        text = deck(sdof, system, (dur, dt, output_dt), damper=dmp, header=header)
    elif fmt == "opensees":
        from dampfit.fem.opensees import script

        text = script(sdof, system, (dur, dt, output_dt), name=name or FORMATS[fmt][1],
                      modal=modal, damper=dmp, header=header)
    else:
        from dampfit.fem.calculix import deck

        text = deck(sdof, system, (dur, dt, output_dt), damper=dmp, header=header)
    if modal is not None and fmt != "opensees":
        text = _with_modal(text, fmt, modal, system)
    note = sdof.source.get("campaign")
    if note:
        text = _with_note(text, fmt, note)
    from dampfit.fem.modal import modal_note

    seen = None if summary.get("kind") == "campaign" else modal_note(summary)
    if seen:
        text = _with_note(text, fmt, seen)
    info = {"format": fmt, "units": system.name, "quantile": quantile, "gravity": gravity,
            "mass": sdof.mass, "k": sdof.k, "c": sdof.c, "u0": sdof.u0,
            "duration": dur, "dt": dt, "output_dt": output_dt, "sdof": sdof, "modal": modal,
            "damper": dmp}
    return text, info


def canonical_command(folder: Path, fmt: str, deck: Deck = Deck(),
                      extra: tuple[str, ...] = ()) -> str:
    """The ``dampfit export`` command that writes this deck, as a shell runs it: the resolved
    folder and every option of ``deck`` that differs from its default (``--out`` aside: the file name is
    not part of the deck), the same whether the deck was asked for on the command line or
    from Python. ``dampfit verify`` records the same string (``script.export_command``)."""
    import shlex

    words = ["dampfit", "export", str(Path(folder).resolve()), "--format", fmt]
    for option, value, default in (("--units", deck.units, "SI"),
                                   ("--quantile", deck.quantile, 0.5),
                                   ("--duration", deck.duration, None), ("--law", deck.law, None),
                                   ("--force-law", deck.force_law, None)):
        if value != default:
            words += [option, repr(value) if isinstance(value, float) else str(value)]
    if deck.gravity:
        words.append("--gravity")
    return shlex.join(words + list(extra))


def _damper(summary: dict[str, Any], path: Path, sdof, deck: Deck, auto: bool = True):
    """(damper, system): the damper the deck writes and the system with its linear c — the
    dashpot itself, or for a nonlinear law the equivalent linear c at the design amplitude
    (``damper.c_linear``, else c_eq at u0), which the decks only report.

    With ``auto`` (not for a posterior draw's deck, which is the law's draw), no ``--law`` and
    no ``--force-law``, a recommended nonlinear law is checked against the measured envelope
    and replaced by the measured curve when it misses it
    (:func:`dampfit.fem.measured.default_damper`).

    Whenever the deck carries a law other than the viscous posterior's (a nonlinear law, or
    ``--law viscous``'s c_linear of one), its spring is that law's k (``damper.k``: the
    damper section's, of the law's own posterior), not ``parameters.k`` of the viscous
    posterior (on the phone spring 6.5687 against 6.5618 N/m): one k in the deck, the damper
    section and the report."""
    import dataclasses

    law, force_law, quantile = deck.law, deck.force_law, deck.quantile
    curve = law == damper_mod.MEASURED
    if curve and force_law is not None:
        raise InputError("give --law measured or --force-law, not both")
    dmp = damper_mod.choose(summary, path, None if curve else law, force_law,
                            viscous_c=sdof.c)
    if dmp.k is not None and (dmp.nonlinear or dmp.recommended not in (None, "viscous")):
        sdof = dataclasses.replace(sdof, k=dmp.k)
    if curve:  # the curve fitted to the measured envelope (fem/measured.py)
        from dampfit.fem.measured import measured_damper

        dmp = measured_damper(path.parent, summary, dmp, sdof)
    elif (auto and law is None and force_law is None and dmp.nonlinear
          and dmp.status == "recommended"):  # the law, or the curve where the law misses
        from dampfit.fem.measured import default_damper

        dmp = default_damper(path.parent, summary, dmp, sdof)
    if dmp.nonlinear:
        if abs(quantile - 0.5) > 1e-12:
            raise InputError(f"--quantile {quantile:g}: the {dmp.law} damper is written at its "
                             "coefficients' medians (quantiles of correlated coefficients are no "
                             "damper); use --draws N for its uncertainty")
        c = (dmp.c_linear or {}).get("q50")
        if c is None:
            a = (dmp.design or {}).get("displacement_m", abs(sdof.u0))
            c = damper_mod.c_equivalent(dmp.law, dmp.coefficients, sdof.omega_n, a)
        return dmp, dataclasses.replace(sdof, c=c)
    if dmp.coefficients["c"] != sdof.c:
        return dmp, dataclasses.replace(sdof, c=dmp.coefficients["c"])
    return dmp, sdof


def _with_modal(text: str, fmt: str, modal: dict[str, Any], system) -> str:
    """``text`` of an LS-DYNA or CalculiX deck with the comment block of the modal damping
    (:mod:`dampfit.fem.modal`): before LS-DYNA's closing ``*END``, at the end of CalculiX's."""
    from dampfit.fem import modal as modal_mod

    if fmt == "lsdyna":
        body = text.rstrip("\n")
        if not body.endswith("\n*END"):
            raise ValueError("an LS-DYNA deck ends with *END")
        lines = modal_mod.lsdyna_lines(modal, system)
        return body[:-len("*END")] + "\n".join(lines) + "\n*END\n"
    return text + "\n".join(modal_mod.calculix_lines(modal, system)) + "\n"


def _with_note(text: str, fmt: str, note: str) -> str:
    """``text`` of a deck with the comment ``note`` (a campaign's population damper) near its
    top, in the comment syntax of ``fmt`` (sanitised: it can never start a card or code)."""
    from dampfit.fem.sanitize import calculix_comment, lsdyna_comment, python_comment

    lines = text.split("\n")
    if fmt == "lsdyna":  # after *KEYWORD, which must stay the first line
        return "\n".join(lines[:1] + lsdyna_comment(note, limit=None) + lines[1:])
    if fmt == "calculix":
        return "\n".join(calculix_comment(note, limit=None) + lines)
    return "\n".join([f"# {python_comment(note, None)}"] + lines)  # before the docstring


def export(result: str | Path | Any, fmt: str, out: str | Path | None = None, *,
           deck: Deck = Deck(), force: bool = False, command: str | None = None,
           draws: int | None = None, seed: int = 0) -> tuple[Path, dict[str, Any]]:
    """Write the ``fmt`` deck of ``result`` (a result folder, or an analysis :func:`dampfit.load`
    read from one) under the options ``deck`` (:class:`Deck`) to ``out`` (default:
    ``FOLDER/sdof_FORMAT.EXT``); return (path, description). ``draws`` N writes N posterior
    draws' decks instead (:mod:`dampfit.fem.draws`, seeded by ``seed``).

    Before anything is written: an existing ``out`` (a dangling link too) is replaced only with
    ``force`` (a link is then replaced itself, never its target); a directory, a special file
    or a name too long never. A given ``out`` is checked first, the default one inside the
    folder once the folder is read. The file is written atomically.
    """
    if fmt not in FORMATS:
        raise InputError(f"unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    folder = folder_of(result)
    if draws is not None:  # N posterior draws: a folder of decks and draws.csv
        from dampfit.fem import draws as draws_mod

        if deck.law == damper_mod.MEASURED:
            raise InputError("--law measured has no posterior draws (its interval is a "
                             "bootstrap, stated in the deck); drop --draws or --law measured")

        draws_mod.check_count(draws)
        command = command or canonical_command(folder, fmt, deck, ("--draws", str(draws),
                                                                   "--seed", str(seed)))

        def one_deck(name: str, variant=None):
            return build(folder, fmt, deck, name=name, command=command, variant=variant)

        return draws_mod.write(one_deck, folder, fmt, FORMATS[fmt][1].rsplit(".", 1)[1],
                               (draws, seed), out, force)
    path = Path(out) if out else folder / FORMATS[fmt][1]
    if out:
        check_output_file(path, force)
    text, info = build(folder, fmt, deck, name=path.name, command=command)
    if not out:
        check_output_file(path, force)
    atomic_write_text(path, text)
    return path, info
