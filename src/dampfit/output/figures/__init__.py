"""Figures of a result (PNG files for the report), drawn from its plain data only.

Every figure of one recording is drawn from :class:`~dampfit.output.figures.data.FigureData`:
the summary dict (summary.json), the signals dict (signals.npz, with the figure arrays of
:mod:`dampfit.result.signals`) and the posterior (posterior.nc) — never from live pipeline
objects — so a live :class:`~dampfit.analysis.Analysis`, the same result loaded from its
folder (:func:`dampfit.load`) and the figure process (:mod:`dampfit.output.figure_process`)
write the same bytes, and :func:`redraw_missing` draws the figures a result folder lacks.

=================  ===============================  ==========================================
name (PNG stem)    function                         what
=================  ===============================  ==========================================
``signal``         :func:`signal_figure`            raw axes, selected signal, window, masked
``spectrum``       :func:`spectrum_figure`          amplitude spectrum (linear, dB), band, |H|²
``fit``            :func:`fit_figure`               fitted samples, model, zooms, residuals
``displacement``   :func:`displacement_figure`      the paper's envelope pipeline (Fig. 20)
``posterior``      :func:`posterior_figure`         corner plot of (c, k, u₀) or (ζ, f_n, u₀)
``trace``          :func:`trace_figure`             walker traces and marginal densities
``amplitude``      :func:`amplitude_of`             ζ(A) and the f(A) backbone (damping laws)
``modes``          :func:`modes_figure`             spectrum with each mode's f_n and ζ marked
=================  ===============================  ==========================================

Each function takes an analysis or its ``FigureData`` and returns a
:class:`matplotlib.figure.Figure` built with the object API (no pyplot, no global state), or
None where the figure does not apply (no envelope-pipeline baseline; no damping-law
assessment; one mode). :data:`NEEDS` names the data each figure is drawn from, so the figure process
draws each one as soon as its stage has delivered them. The modules: ``layout`` (the layout
engine), ``data``, one per figure family (``recording``, ``fit``, ``posterior``,
``amplitude``, ``modes``, ``campaign``: the forest and added-mass figures of a campaign) and ``png`` (the
PNG harness). matplotlib is imported inside the functions only: the numeric core never needs
it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

from dampfit.output.figures.amplitude import amplitude_figure, amplitude_of
from dampfit.output.figures.data import FigureData, MissingData, as_data
from dampfit.output.figures.fit import displacement_figure, fit_figure
from dampfit.output.figures.modes import modes_figure
from dampfit.output.figures.png import drawing, save_png, write_png
from dampfit.output.figures.posterior import posterior_figure, trace_figure
from dampfit.output.figures.recording import signal_figure, spectrum_figure

#: name → figure function; the name is also the PNG file stem.
FIGURES: dict[str, Callable[[Any], Any]] = {
    "signal": signal_figure,
    "spectrum": spectrum_figure,
    "fit": fit_figure,
    "displacement": displacement_figure,
    "posterior": posterior_figure,
    "trace": trace_figure,
    "amplitude": amplitude_of,
    "modes": modes_figure,
}

#: The data keys (:data:`~dampfit.output.figures.data.DATA_KEYS`: ``signals``, ``posterior``,
#: ``summary.<section>``) each figure is drawn from: a figure can be drawn as soon as its
#: stage has delivered them — the signals and the fit's summary sections after the fit
#: (:func:`dampfit.stages.fit_summary`), the posterior and the sampler's diagnostics after
#: sampling (:func:`dampfit.stages.sampling_summary`), the amplitude curve and the modes with the
#: summary.
NEEDS: dict[str, frozenset[str]] = {
    "signal": frozenset({"signals", "summary.input", "summary.window",
                         "summary.dominant_frequency_hz", "summary.preprocessing"}),
    "spectrum": frozenset({"signals", "summary.input", "summary.band",
                           "summary.dominant_frequency_hz"}),
    "fit": frozenset({"signals", "summary.least_squares", "summary.noise_model",
                      "summary.fit"}),
    "displacement": frozenset({"signals", "summary.least_squares"}),
    "posterior": frozenset({"posterior", "summary.least_squares", "summary.mass"}),
    "trace": frozenset({"posterior", "summary.diagnostics"}),
    "amplitude": frozenset({"signals", "summary.amplitude_curve"}),
    "modes": frozenset({"signals", "summary.input", "summary.n_modes", "summary.modes"}),
}


def render(an: Any, names, outdir: str | os.PathLike, dpi: int = 110,
           on_missing: Callable[[str, str], object] | None = None,
           claim: Callable[[str], bool] | None = None) -> dict[str, Path | None]:
    """Draw the figures ``names`` of :data:`FIGURES` of ``an`` (an analysis or its
    :class:`FigureData`) and write each as ``<name>.png`` into ``outdir`` (atomically).
    Returns ``{name: path}``; ``None`` for a figure that does not apply, whose older file in
    ``outdir`` is removed. A figure whose data are absent raises :class:`MissingData`, or with
    ``on_missing`` is reported as ``on_missing(name, message)`` and left out (its file left
    as it is). With ``claim``, a figure is drawn only if ``claim(name)`` is true (another
    process drawing into the same folder took the others: :func:`claim_in`)."""
    data = as_data(an)
    outdir = Path(outdir)
    written: dict[str, Path | None] = {}
    with drawing():
        for name in names:
            if claim is not None and not claim(name):
                continue
            try:
                fig = FIGURES[name](data)
            except MissingData as exc:
                if on_missing is None:
                    raise
                on_missing(name, str(exc))
                continue
            path = outdir / f"{name}.png"
            if fig is None:
                path.unlink(missing_ok=True)  # never leave a stale figure of an earlier run
                written[name] = None
                continue
            save_png(fig, path, dpi)
            written[name] = path
    return written


#: Suffix of the claim files two processes drawing into one folder share (:func:`claim_in`).
CLAIM_SUFFIX = ".figure-claim"


def claim_in(outdir: str | os.PathLike) -> Callable[[str], bool]:
    """A ``claim`` for :func:`render`: figure ``name`` is this process's to draw if it is the
    first to create the empty file ``.<name>.figure-claim`` in ``outdir`` (``O_EXCL``: the
    file system decides, atomically, between the figure process and the analysis process,
    which share the last figures this way). :func:`release_claims` removes the files."""
    folder = Path(outdir)

    def claim(name: str) -> bool:
        try:
            os.close(os.open(folder / f".{name}{CLAIM_SUFFIX}",
                             os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600))
        except FileExistsError:
            return False
        return True

    return claim


def release_claims(outdir: str | os.PathLike) -> None:
    """Remove the claim files of :func:`claim_in` from ``outdir``."""
    for name in FIGURES:
        (Path(outdir) / f".{name}{CLAIM_SUFFIX}").unlink(missing_ok=True)


def save_figures(an: Any, outdir: str | os.PathLike, *, dpi: int = 110, skip=(),
                 on_missing: Callable[[str, str], object] | None = None) -> dict[str, Path]:
    """Write every figure of :data:`FIGURES` (but ``skip``) of ``an`` (an analysis or its
    :class:`FigureData`) as ``<name>.png`` into ``outdir`` (:func:`render`).

    Returns ``{name: path}`` of the files written. A figure that does not apply (the
    displacement figure without the envelope-pipeline baseline; the amplitude figure without a
    damping assessment) is skipped, and an older file of that name in ``outdir`` is removed.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    done = render(an, [name for name in FIGURES if name not in skip], outdir, dpi, on_missing)
    return {name: path for name, path in done.items() if path is not None}


@dataclass
class Redrawn:
    """What :func:`redraw_missing` did: ``drawn`` the figures written (PNG stems), ``notes``
    one line per missing figure it could not draw (why)."""

    drawn: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def redraw_missing(folder: str | os.PathLike | Any, *, dpi: int = 110) -> Redrawn:
    """Draw the figures result ``folder`` lacks from its own summary.json, signals.npz and
    posterior.nc (what :func:`dampfit.load` reads), each written atomically into the folder.

    Only a folder dampfit wrote (its ``.dampfit-result`` marker) is written into; a figure
    whose file exists — even as a link, which is never followed — is left alone, as is a
    figure that does not apply. A figure whose data the folder lacks (a signals.npz written
    before the figure arrays existed, an unreadable posterior.nc) is not drawn: ``notes``
    says why, one line each. For a campaign folder, its forest and added-mass figures.
    :class:`~dampfit.errors.InputError` (one line) for a folder that is not a dampfit result.
    """
    from dampfit.files.folder import MARKER, read_marker
    from dampfit.errors import InputError, shown
    from dampfit.result.folder import open_result
    from dampfit.result.schema import folder_of

    d = folder_of(folder)
    loaded = open_result(d)  # refuses what is not a result folder, one line
    if read_marker(d) is None:
        raise InputError(f"refusing to draw figures into {shown(d)}: it was not written by "
                         f"dampfit (no {MARKER} marker)")
    out = Redrawn()
    if loaded.is_campaign:
        from dampfit.output.figures import campaign

        present = [n for n in campaign.DRAW if os.path.lexists(d / f"{n}.png")]
        with drawing():
            out.drawn = list(campaign.save_figures(loaded.summary, d, dpi=dpi, skip=present))
        return out
    missing = [n for n in FIGURES if not os.path.lexists(d / f"{n}.png")]
    data = FigureData(loaded.summary, loaded.signals, loaded.posterior,
                      where=f"the result in {shown(d)}")
    with drawing():
        for name in missing:
            try:
                fig = FIGURES[name](data)
            except MissingData as exc:
                out.notes.append(str(exc))
                continue
            if fig is not None:  # a figure that does not apply stays absent
                save_png(fig, d / f"{name}.png", dpi)
                out.drawn.append(name)
    return out
