"""The result of a campaign: :class:`CampaignAnalysis` — live (what
:func:`dampfit.campaign.analyze_campaign` computed) or loaded back from its folder
(:func:`dampfit.load`) — with its plain-data :meth:`~CampaignAnalysis.summary`, and the
renderings and writers of it (:meth:`~CampaignAnalysis.report`, ``_repr_html_``,
:meth:`~CampaignAnalysis.save`).
"""

from __future__ import annotations

import copy
import json
import os
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import DampfitError
from dampfit.files.atomic import atomic_write, atomic_write_text
from dampfit.result.views import ResultViews
from dampfit._arviz import write_netcdf

#: Top-level keys of :meth:`CampaignAnalysis.summary` (schema_version 1, kind "campaign").
SUMMARY_KEYS = ("schema_version", "kind", "dampfit_version", "design", "parameters", "mass",
                "population", "tests", "checks", "added_mass", "diagnostics", "warnings")


@dataclass
class CampaignAnalysis(ResultViews):
    """Everything :func:`dampfit.campaign.analyze_campaign` computed; :meth:`summary` is its
    plain-data view.

    Loaded back from a result folder (:func:`dampfit.load`), ``summary()`` is the stored
    summary.json, ``posterior`` is read from posterior.nc, and ``tests`` is empty."""

    tests: list = field(default_factory=list)
    sampling: Any = None
    #: the checks and the verdict (:class:`dampfit.campaign.verdict.CampaignChecks`), made
    #: once after the sampling
    checks: Any = None
    warnings: list[str] = field(default_factory=list)
    folder: Path | None = None
    _loaded: Any = field(default=None, repr=False, compare=False)
    mass: float | None = None
    mass_sd: float = 0.0
    added_mass: np.ndarray | None = None
    added_mass_sd: float = 0.0
    seed: int = 0
    options: dict[str, Any] = field(default_factory=dict)
    date: str = field(default_factory=lambda: datetime.now(timezone.utc).isoformat(timespec="seconds"))
    _summary: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)

    @classmethod
    def from_loaded(cls, loaded) -> "CampaignAnalysis":
        """The campaign of a result folder read by :func:`dampfit.result.folder.open_result`
        (what :func:`dampfit.load` returns for it): its summary as stored, the joint posterior
        read from posterior.nc on first use; the per-test analyses are not stored (``tests``
        is empty)."""
        d = loaded.summary
        diag = d.get("diagnostics") if isinstance(d.get("diagnostics"), dict) else {}
        warns = [w for items in (diag.get("warnings"), d.get("warnings"))
                 if isinstance(items, list) for w in items if isinstance(w, str)]
        return cls(tests=[], sampling=None, warnings=list(dict.fromkeys(warns)),
                   folder=loaded.folder, _loaded=loaded)

    @property
    def model(self) -> str:
        """"hierarchical" (known or no mass) or "added-mass"."""
        return "added-mass" if self.added_mass is not None else "hierarchical"

    # posterior (variables named as in the summary), converged: result.views.ResultViews
    def _live_converged(self) -> bool:
        """The hyper-posterior met its stopping rule and the importance weights are healthy."""
        return bool(self.sampling.converged)

    def draws(self, name: str) -> np.ndarray:
        """All posterior draws of one quantity (per-test ones: (draws, tests))."""
        x = np.asarray(self.posterior.posterior[name])
        return x.reshape((-1,) + x.shape[2:])

    def signals(self) -> list[dict[str, np.ndarray]]:
        """Each test's measured and modelled signals on its analysis window, in the order of
        ``tests``: the arrays and scalars of :meth:`dampfit.analysis.Analysis.signals` (``t``
        [s], ``accel``, ``accel_model`` [m/s²], ``displacement``, ``displacement_model`` [m]
        — the measured displacement is NaN: a campaign keeps no envelope-pipeline baseline —
        ``fs`` [Hz], ``p`` [1/s], ``omega_d`` [rad/s], ``t0`` [s]) from the test's own least
        squares. A campaign loaded from its folder (:func:`dampfit.load`) has none: the folder
        stores no signals.npz; that raises a :class:`~dampfit.errors.DampfitError`."""
        if self._loaded is not None:
            from dampfit.errors import shown

            raise DampfitError(f"signals() is not available: this campaign was loaded from "
                               f"{shown(self.folder)}, which stores summary.json and "
                               "posterior.nc only (no per-test signals); run "
                               "dampfit.analyze([rec1, rec2, …]) on the recordings for them")
        from dampfit.stages import window_signals

        return [window_signals(t.prepared, t.fit_data, t.least_squares) for t in self.tests]

    def summary(self) -> dict[str, Any]:
        """The JSON-safe summary (kind "campaign", schema_version 1), a fresh copy; computed
        once and cached (of a loaded result: the summary.json read)."""
        if self._summary is None:
            if self._loaded is not None:
                self._summary = self._loaded.summary
            else:
                from dampfit.campaign import summary, verdict

                if self.checks is None:  # a live result built without the checks stage
                    self.checks = verdict.assess_sampled(self.tests, self.posterior.posterior,
                                                         self.added_mass is not None,
                                                         self.added_mass_sd)
                # files: set by save(), the posterior.nc written with it (as one recording's)
                self._summary = {**summary.summarise(self), "files": None}
        return copy.deepcopy(self._summary)

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`summary` as JSON to ``path`` (atomically)."""
        return atomic_write_text(path, json.dumps(self.summary(), indent=2) + "\n")

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write the joint posterior (arviz InferenceData) to a NetCDF file."""
        return atomic_write(path, lambda tmp: write_netcdf(self.posterior, tmp),
                            suffix=".nc")

    # --------------------------------------------------------------- renderings
    def report(self) -> str:
        """The text table the CLI prints (:func:`dampfit.output.text_campaign.text`)."""
        from dampfit.output import text_campaign

        return text_campaign.text(self.summary())

    def _repr_html_(self) -> str:
        """A short HTML table of the population's headline numbers, for notebooks."""
        from dampfit.output import text

        return text.html_table(self.summary())

    def save(self, folder, *, force: bool = False, figures: bool = True,
             report: bool = False) -> Path:
        """Write the campaign folder ``dampfit analyze FILE FILE…`` writes (summary.json,
        posterior.nc, ``forest.png`` and, of the added-mass design, ``added_mass.png``; with
        ``report`` report.html/.md) and return its path — written whole as
        :meth:`dampfit.analysis.Analysis.save` does. ``folder`` may be an open
        :class:`dampfit.files.folder.ResultFolder` (the CLI's): the files go into its staging folder
        and the caller publishes it."""
        from dampfit.files.folder import ResultFolder, result_folder

        if isinstance(folder, ResultFolder):
            self._write(folder, figures)
            return folder.stage
        inputs = [t.recording.path for t in self.tests if t.recording.path]
        with result_folder(folder, "campaign", force, inputs=inputs) as target:
            self._write(target, figures)
            out = target.publish()
        if report:
            from dampfit.output.report import write_report

            write_report(out)
        return out

    def _record_files(self, stage: Path) -> None:
        """summary.json's ``files``: the SHA-256 and size of the posterior.nc just written into
        ``stage`` (a campaign writes no signals.npz), so ``dampfit report`` and
        :func:`dampfit.load` refuse one swapped in from another analysis
        (:func:`dampfit.result.files.check_digest`), as for one recording."""
        from dampfit.result.files import file_digests

        self.summary()  # computed (or loaded) before it is amended
        self._summary["files"] = file_digests(stage, ("posterior.nc",))

    def _write(self, folder, figures: bool) -> None:
        stage = folder.stage
        with folder.writing():
            self.to_netcdf(stage / "posterior.nc")
            self._record_files(stage)
            self.to_json(stage / "summary.json")
            if figures:
                from dampfit.output.figures.campaign import save_figures

                save_figures(self.summary(), stage)
