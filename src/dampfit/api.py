"""The package face: read a recording, analyse one or several, load a result folder back.

* :func:`read` — a recording file → :class:`~dampfit.io.recording.Recording`;
* :func:`analyze` — one recording → :class:`~dampfit.analysis.Analysis`; several recordings
  of one damper → :class:`~dampfit.campaign.CampaignAnalysis` (every campaign option passed
  through; options that only apply to one recording are refused, never dropped);
* :func:`analyze_campaign` — several recordings, explicitly;
* :func:`analyze_many` — many independent recordings → one results table (a
  ``pandas.DataFrame``; in this process or on a Dask client; with ``out`` the resumable
  folder ``dampfit batch`` writes): :func:`dampfit.batch.analyze_many`;
* :func:`load` — a result folder → the :class:`~dampfit.analysis.Analysis` or
  :class:`~dampfit.campaign.CampaignAnalysis` it was written from.

Each result renders and saves itself (``summary()``, ``report()``, ``save(dir)``).
"""

from __future__ import annotations

import os
from typing import Sequence

from dampfit._arviz import arviz
from dampfit._options import (DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS, DEFAULT_SEED, AnalysisOptions,
                              SamplerSettings)
from dampfit.analysis import Analysis
from dampfit.batch import analyze_many
from dampfit.campaign import CampaignAnalysis, analyze_campaign
from dampfit.errors import InputError
from dampfit.io.readers import read
from dampfit.io.recording import Recording
from dampfit.pipeline import analyze as analyze_one
from dampfit.result.folder import open_result

# arviz (diagnostics, InferenceData; with xarray ≈ 0.4 s) is imported with the face rather than
# inside the first analysis: a script pays its imports at ``from dampfit import analyze`` and its
# first analyze() then costs a later one's time plus loading the compiled kernels
# (paper/benchmark.py). The pipeline itself still imports neither arviz nor matplotlib.
arviz()

__all__ = ["Analysis", "CampaignAnalysis", "analyze", "analyze_campaign", "analyze_many", "load",
           "read"]

#: Options of :func:`analyze` that only apply to one recording.
SINGLE_ONLY = ("model", "amplitude", "on_stage", "mode_of_mass")


def analyze(recording: Recording | Sequence[Recording], mass: float | None = None,
            mass_sd: float | None = None, *, axis: str = "auto",
            window: tuple[float, float] | Sequence | None = None,
            band: tuple[float, float] | Sequence | None = None, seed: int = DEFAULT_SEED,
            progress: bool = False, max_steps: int = DEFAULT_MAX_STEPS,
            min_ess: float = DEFAULT_MIN_ESS,
            model: str = "auto", amplitude: float | None = None, on_stage=None,
            added_mass: Sequence[float] | None = None,
            added_mass_sd: float | None = None, max_modes: int | None = None,
            mode_of_mass: int | None = None) -> Analysis | CampaignAnalysis:
    """Estimate c [N·s/m], k [N/m], u₀ [m], ζ and f_n [Hz] from a free-decay recording
    (:func:`dampfit.pipeline.analyze`, which documents every option), or jointly from several
    recordings of one damper (a list or tuple: :func:`dampfit.campaign.analyze_campaign`,
    which documents ``added_mass`` [kg] per recording and ``added_mass_sd`` [kg]; ``window``
    and ``band`` may then be one per recording).

    ``model``, ``amplitude``, ``on_stage`` and ``mode_of_mass`` apply to one recording
    (a campaign pools the mode its ``band`` isolates; ``max_modes`` > 1 lists every test's
    other modes, :mod:`dampfit.campaign.modes`) and ``added_mass``,
    ``added_mass_sd`` to several: giving one where it does not apply is a one-line
    :class:`~dampfit.errors.InputError`, never silently ignored. ``max_modes`` by default:
    :data:`~dampfit._options.DEFAULT_MAX_MODES` (4) for one recording — a one-mode recording pays only a cheap
    screen, ``max_modes=1`` skips the modal analysis — and 1 for a campaign (its tests' own
    modes are opt-in). The options are checked once, as one
    :class:`~dampfit._options.AnalysisOptions` (the defaults are its own).
    """
    options = AnalysisOptions(
        axis=axis, window=window, band=band, model=model, amplitude=amplitude,
        max_modes=max_modes, mode_of_mass=mode_of_mass,
        sampler=SamplerSettings(seed=seed, max_steps=max_steps, min_ess=min_ess,
                                progress=progress))
    if isinstance(recording, (list, tuple)):
        given = {"model": model != "auto", "amplitude": amplitude is not None,
                 "on_stage": on_stage is not None,
                 "mode_of_mass": mode_of_mass is not None}
        wrong = [name for name in SINGLE_ONLY if given[name]]
        if wrong:
            raise InputError(f"{', '.join(wrong)} apply to a single recording, not to a "
                             f"campaign of {len(recording)}; analyse one recording for them")
        return analyze_campaign(recording, mass, mass_sd, added_mass=added_mass,
                                added_mass_sd=0.0 if added_mass_sd is None else added_mass_sd,
                                options=options)
    if added_mass is not None or added_mass_sd is not None:
        raise InputError("added_mass applies to several recordings (one per added mass), got "
                         "one recording")
    return analyze_one(recording, mass, mass_sd, options=options, on_stage=on_stage)


def load(folder: str | os.PathLike) -> Analysis | CampaignAnalysis:
    """The result of ``folder`` (written by ``dampfit analyze`` or ``save``): an
    :class:`~dampfit.analysis.Analysis`, or for a campaign folder a
    :class:`~dampfit.campaign.CampaignAnalysis`. ``summary()`` is the folder's summary.json as
    written; the posterior and signals are read on first use; live-only pipeline objects raise
    a :class:`~dampfit.errors.DampfitError` naming the folder. One-line
    :class:`~dampfit.errors.InputError` if ``folder`` is not a usable result folder."""
    loaded = open_result(folder)
    return (CampaignAnalysis if loaded.is_campaign else Analysis).from_loaded(loaded)
