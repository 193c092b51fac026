"""The result of one recording: :class:`Analysis`, live (from :func:`dampfit.pipeline.analyze`)
or loaded from its folder (:func:`dampfit.load`).

An :class:`Analysis` renders and saves itself: :meth:`Analysis.summary` is the plain-data
summary (summary.json, schema in :mod:`dampfit.result.schema`), :meth:`Analysis.report` the
text table, :meth:`Analysis._repr_html_` a short HTML table for notebooks,
:meth:`Analysis.save` the whole result folder ``dampfit analyze`` writes (summary.json,
posterior.nc, signals.npz, figures, optionally report.html/.md).
"""

from __future__ import annotations

import copy
import json
import os
import platform
import warnings
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from dampfit import physics
from dampfit import stages
from dampfit._json import jsonable
from dampfit.files.atomic import atomic_write, atomic_write_text
from dampfit._meta import __version__, versions
from dampfit.damping.quantities import summarise
from dampfit.estimators import baselines
from dampfit.inference import least_squares
from dampfit.inference import noise
from dampfit.inference import posterior
from dampfit.io.recording import Recording
from dampfit.result.folder import real
from dampfit.result.views import ResultViews
from dampfit.signal import prepare
from dampfit._arviz import write_netcdf

#: Unit of every reported parameter.
PARAMETER_UNITS = {name: physics.UNITS[name] for name in (
    "c", "k", "u0", "zeta", "f_n", "p", "f_d", "delta", "Q", "c_crit")}


@dataclass(frozen=True)
class Modes:
    """The several-modes stage's result for one recording (:func:`dampfit.pipeline.modes_stage`
    of :func:`dampfit.stages.modes_stage`): ``n_modes``;
    ``modes`` one plain dict per mode (by frequency; None for one mode: then the one mode is
    ``parameters``, :meth:`Analysis.summary` fills it in); ``evidence`` summary.json's
    ``modes_evidence``; ``rayleigh`` α [1/s], β [s] (None below two modes); ``idata`` the
    per-mode posterior (arviz, dimension ``mode``: every component; None for one mode);
    ``warnings``; ``seen`` summary.json's ``modes_seen`` (components that are not modes)."""

    n_modes: int = 1
    modes: list | None = None
    evidence: dict = field(default_factory=dict)
    rayleigh: dict | None = None
    idata: Any = None
    warnings: tuple[str, ...] = ()
    seen: list = field(default_factory=list)


#: Quantities of each entry of summary.json's ``modes`` (and of the modes group of
#: posterior.nc); c, k, c_crit, u0, mass only for the mass's mode.
MODE_QUANTITIES = ("f_n", "f_d", "zeta", "p", "eta", "delta", "Q", "c", "k", "c_crit", "u0")


def modes_of_summary(params: dict[str, Any], crlb: dict | None) -> list[dict[str, Any]]:
    """summary.json's ``modes`` of a one-mode result: the one mode is ``parameters`` (each
    quantity as there, η = 2ζ added), marked as the mass's mode, with the bounds' sd."""
    row: dict[str, Any] = {"index": 1, "mass_mode": True, "identified": True,
                           "fundamental": True}
    for name in MODE_QUANTITIES:
        if name == "eta":
            z = params.get("zeta")
            row["eta"] = None if z is None else {
                key: (2 * v if key in ("mean", "sd", "q05", "q50", "q95", "crlb_sd")
                      and isinstance(v, (int, float)) else v) for key, v in z.items()}
            if row["eta"] is not None:
                row["eta"]["unit"] = "1"
        elif params.get(name) is not None:
            row[name] = copy.deepcopy(params[name])
    crlb = crlb or {}
    row["crlb_sd"] = {q: (crlb.get(q) or {}).get("sd") for q in ("f_n", "zeta", "p", "omega_d")}
    return [row]


@dataclass
class Analysis(ResultViews):
    """Everything :func:`analyze` computed. ``summary()`` is the plain-data view of it.

    The same class is what :func:`dampfit.load` returns for a result folder: then
    :meth:`summary` is the folder's summary.json as written (not recomputed), ``posterior`` is
    read from posterior.nc and :meth:`signals` from signals.npz when first used, ``folder`` is
    the folder, and the live pipeline objects (``recording``, ``prepared``, ``fit_data``,
    ``least_squares``, ``noise``, ``sampling``, ``baselines``, ``damping``) raise a
    :class:`~dampfit.errors.DampfitError` saying the result was loaded from that folder.
    """

    recording: Recording
    prepared: prepare.Prepared
    fit_data: prepare.FitData
    least_squares: least_squares.LeastSquaresResult
    noise: noise.NoiseModel
    sampling: posterior.PosteriorResult
    baselines: dict[str, baselines.BaselineResult | None]
    crlb: dict[str, Any] | None
    mass: float | None
    mass_sd: float
    seed: int
    options: dict[str, Any]
    warnings: list[str] = field(default_factory=list)
    damping: Any = None  # dampfit.damping.DampingAssessment (None when not assessed)
    modes: Modes | None = None  # the several-modes stage (None: not run, as max modes 1)
    date: str = field(default_factory=lambda: datetime.now(timezone.utc).isoformat(timespec="seconds"))
    #: Result folder this analysis was loaded from (:func:`dampfit.load`); None when live.
    folder: Path | None = None
    #: What :func:`dampfit.result.folder.load` read (summary, lazily posterior and signals).
    _loaded: Any = field(default=None, repr=False, compare=False)
    _summary: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)
    _signals: dict[str, np.ndarray] | None = field(default=None, init=False, repr=False,
                                                   compare=False)
    _fit: dict[str, Any] | None = field(default=None, init=False, repr=False, compare=False)
    _damper_cache: Any = field(default=None, init=False, repr=False, compare=False)

    @classmethod
    def from_loaded(cls, loaded) -> "Analysis":
        """The analysis of a result folder read by :func:`dampfit.result.folder.open_result`
        (what :func:`dampfit.load` returns): its summary as written, the live-only fields
        standing for objects that raise an error naming the folder."""
        d = loaded.summary
        mass = d.get("mass") if isinstance(d.get("mass"), dict) else {}
        prov = d.get("provenance") if isinstance(d.get("provenance"), dict) else {}
        diag = d.get("diagnostics") if isinstance(d.get("diagnostics"), dict) else {}
        warns = diag.get("warnings")
        return cls(
            **loaded.unavailable(), crlb=d.get("crlb") if isinstance(d.get("crlb"), dict) else None,
            mass=mass.get("value") if real(mass.get("value")) else None,
            mass_sd=mass.get("sd") if real(mass.get("sd")) else 0.0,
            seed=prov.get("seed") if isinstance(prov.get("seed"), int) else None,
            options=prov.get("options") if isinstance(prov.get("options"), dict) else {},
            warnings=[w for w in warns if isinstance(w, str)] if isinstance(warns, list) else [],
            date=prov.get("date") if isinstance(prov.get("date"), str) else None,
            folder=loaded.folder, _loaded=loaded)

    # --------------------------------------------------------------- views
    # posterior, converged: dampfit.result.views.ResultViews
    def _live_converged(self) -> bool:
        """Least squares and posterior both converged."""
        return bool(self.least_squares.converged and self.sampling.converged)

    def draws(self, name: str) -> np.ndarray:
        """All posterior draws of one quantity, flattened."""
        return np.asarray(self.posterior.posterior[name]).ravel()

    def summary(self) -> dict[str, Any]:
        """The JSON-safe summary (schema in :mod:`dampfit.result.schema`; ``schema_version``
        :data:`dampfit.result.schema.SCHEMA_VERSION`), a fresh copy on every call.

        Computed once per analysis and cached; of a loaded result it is the summary.json read.
        """
        if self._summary is None:
            if self._loaded is not None:
                self._summary = self._loaded.summary
            else:
                from dampfit.result.schema import SCHEMA_VERSION

                self._summary = {"schema_version": SCHEMA_VERSION, **self._compute_summary(),
                                 "files": None}  # set by save(): the files written with it
        return copy.deepcopy(self._summary)

    def _compute_summary(self) -> dict[str, Any]:
        """The summary of the live pipeline objects (see :meth:`summary`): the sections the
        fit stage knows (:func:`dampfit.stages.fit_summary`), the posterior, baselines, CRLB,
        damping laws and diagnostics (the sampler's: :func:`dampfit.stages.sampling_summary`)."""
        post = self.posterior.posterior
        params: dict[str, Any] = {}
        for name in PARAMETER_UNITS:
            params[name] = (_param_summary(self.posterior, name, self.sampling.diagnostics)
                            if name in post else None)
            bound = (self.crlb or {}).get(name)
            if params[name] is not None and isinstance(bound, dict):
                params[name]["crlb_sd"] = bound.get("sd_with_mass", bound["sd"])
        self._reach_zero(params)
        missing = {}
        if self.mass is None:
            why = ("no mass given: a free decay identifies only the decay rate p and the "
                   "frequency f_n; c = 2·m·p and k = m·(2π·f_n)² need the mass (--mass KG)")
            missing = {"c": why, "k": why, "c_crit": why}
        damping = self._damping_summary()
        missing.update(damping.pop("missing", {}))
        if self._fit is None:  # computed once (kept from the fit stage: keep_fit_stage)
            self._fit = stages.fit_summary(self.recording, self.prepared, self.fit_data,
                                           self.least_squares, self.noise, self.mass,
                                           self.mass_sd)
        fit = self._fit
        return jsonable({
            "dampfit_version": __version__,
            **{key: fit[key] for key in ("input", "window", "band", "dominant_frequency_hz",
                                         "mass")},
            "damper": self._damper().section if self._damper() is not None else None,
            "parameters": params,
            "missing": missing,
            "least_squares": fit["least_squares"],
            "baselines": _baselines_summary(self.baselines, params.get("p")),
            "noise_model": fit["noise_model"],
            "crlb": self.crlb,
            **damping,
            **self._modes_summary(params),
            "fit": fit["fit"],
            "preprocessing": fit["preprocessing"],
            "diagnostics": {"converged": self.converged,
                            **stages.sampling_summary(self.sampling),
                            "warnings": list(self.warnings)},
            "provenance": {"seed": self.seed, "options": self.options, "date": self.date,
                           "python": platform.python_version(), "versions": versions()},
        })

    @property
    def damper(self) -> dict[str, Any] | None:
        """The recommended damper: summary.json's ``damper`` section (a fresh plain dict;
        :mod:`dampfit.damping.damper`, layout in :mod:`dampfit.result.schema`) — the law, its
        coefficients with 90 % intervals, the measured range, the equivalent linear c at the
        design amplitude — or None when the damping laws were not assessed (an older
        folder)."""
        d = self.summary().get("damper")
        return d if isinstance(d, dict) else None

    @property
    def damper_draws(self):
        """The damper's posterior draws (an ``xarray.Dataset`` over ``draw``: mass, k, f_n, the
        law's coefficients, c_linear, zeta_linear; attributes law and design_amplitude_m), or
        None (status none, or not assessed). Of a loaded result: the ``damper`` group of
        posterior.nc."""
        if self._loaded is not None:
            post = self._loaded.posterior()
            return post["damper"] if "damper" in post.groups() else None
        dm = self._damper()
        if dm is None or dm.draws is None:
            return None
        import xarray as xr

        return xr.Dataset({k: ("draw", np.asarray(v, float)) for k, v in dm.draws.items()},
                          coords={"draw": np.arange(len(next(iter(dm.draws.values()))))},
                          attrs=dm.attrs)

    def _damper(self):
        """The :class:`dampfit.damping.damper.Damper` of the live analysis (computed once),
        None without a damping assessment."""
        if self.damping is None or self.damping.adequacy is None:
            return None
        if self._damper_cache is None:
            from dampfit.damping import damper

            dm = damper.from_assessment(
                self.damping, self._viscous_draws(), amplitude=self.options.get("amplitude"),
                seed=self.seed)
            sig = self.signals()  # the recommended law's own decay against the recording's
            dm.section["decay_check"] = damper.decay_check(dm.section, sig["t"], sig["accel"])
            self._damper_cache = dm
        return self._damper_cache

    def _viscous_draws(self):
        """The pipeline's viscous posterior (``parameters``) as damper draws: θ = (ln p,
        ln ω_n), a₀ = u0, the posterior's mass draws."""
        from dampfit.damping.damper import LawDraws

        post = self.posterior.posterior
        p = self.draws("p")
        theta = np.column_stack([np.log(p), np.log(2 * np.pi * self.draws("f_n"))])
        mass = self.draws("mass") if "mass" in post and self.mass is not None else None
        return LawDraws("viscous", theta, self.draws("u0"), mass, "emcee",
                        bool(self.sampling.converged),
                        "" if self.sampling.converged else "posterior NOT converged")

    def _modes_summary(self, params: dict[str, Any]) -> dict[str, Any]:
        """``n_modes``, ``modes`` (the mass's mode, when the fundamental, with the one-mode
        c and k), ``modes_seen``, ``modes_evidence`` and ``rayleigh`` (schema docstring)."""
        modes = self.modes or Modes(evidence={"max_modes": 1, "screen": None,
                                              "reason": "several modes not looked for"})
        rows = stages.one_mode_values(modes.modes, params) if modes.modes is not None \
            else modes_of_summary(params, self.crlb)
        return {"n_modes": modes.n_modes, "modes": rows, "modes_seen": list(modes.seen),
                "modes_evidence": modes.evidence, "rayleigh": modes.rayleigh}

    @property
    def modes_posterior(self):
        """The per-mode posterior (an ``xarray.Dataset``, dimensions chain, draw and ``mode``
        1 … K by frequency; c, k, u0 of the mass's mode without ``mode``), or None when the
        recording has one mode (then it is :attr:`posterior`). Of a loaded result: the
        ``modes`` group of posterior.nc."""
        if self._loaded is not None:
            post = self._loaded.posterior()
            return post["modes"] if "modes" in post.groups() else None
        if self.modes is None or self.modes.idata is None:
            return None
        return self.modes.idata.posterior

    def mode_draws(self, name: str) -> np.ndarray:
        """Flattened draws of ``name`` from :attr:`modes_posterior`: (draws, K) for a per-mode
        quantity, (draws,) for the mass's mode's c, k, u0; for one mode the one-mode
        posterior's draws as (draws, 1) (η = 2ζ)."""
        post = self.modes_posterior
        if post is None:
            x = 2 * self.draws("zeta") if name == "eta" else self.draws(name)
            return x[:, None] if name in ("f_n", "f_d", "zeta", "p", "eta", "delta", "Q") else x
        v = np.asarray(post[name])
        return v.reshape((-1,) + v.shape[2:])

    def _reach_zero(self, params: dict[str, Any]) -> None:
        """p, ζ, c, δ (and Q) of a decay that cannot be told from 0 as one-sided intervals
        reaching 0, under a prior uniform in p (:mod:`dampfit.inference.posterior`, "No
        measured decay"); each gets ``"reaches_zero": true``. Resolved decays are untouched."""
        decay = getattr(self.damping, "decay", None)
        if not (isinstance(decay, dict) and decay.get("resolved") is False):
            return
        weights = self.draws("p")  # uniform over log-uniform prior density: ∝ p
        for name in ("p", "zeta", "c", "delta", "Q"):
            if params.get(name) is None:
                continue
            q = summarise(self.draws(name), PARAMETER_UNITS[name],
                          self.sampling.diagnostics.get(name) or {}, weights=weights)
            if "crlb_sd" in params[name]:
                q["crlb_sd"] = params[name]["crlb_sd"]
            if name == "Q":  # Q = 1/(2ζ) → ∞ as p → 0: a lower bound only
                q.update(mean=None, sd=None, q95=None)
            else:
                q["q05"] = 0.0
            q["reaches_zero"] = True
            params[name] = q

    def _damping_summary(self) -> dict[str, Any]:
        """model_checks, damping_models, amplitude_curve and c_equivalent (the chosen
        non-viscous law's energy-equivalent viscous c at a stated amplitude, else None; None
        with the reason under ``"missing"`` when it means nothing:
        :meth:`dampfit.damping.DampingAssessment.c_missing`)."""
        if self.damping is None:
            return {"model_checks": None, "damping_models": None, "amplitude_curve": None,
                    "c_equivalent": None}
        out = dict(self.damping.summary())
        out["c_equivalent"], why = None, None
        if self.damping.chosen != "viscous":
            out["c_equivalent"], why = self.damping.c_report(), self.damping.c_missing()
        if why:  # under "misfit" or from a posterior that did not converge it means nothing
            out["c_equivalent"], out["missing"] = None, {"c_equivalent": why}
        # each law's sampling facts: budget, stop reason, ill-conditioning (damping.sample)
        for name, entry in ((out.get("damping_models") or {}).get("models") or {}).items():
            post = self.damping.posteriors.get(name)
            if post is not None and isinstance(entry.get("posterior"), dict):
                entry["posterior"].update(jsonable(post.diagnostics()))
        return out

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`summary` as JSON to ``path`` (atomically)."""
        return atomic_write_text(path, json.dumps(self.summary(), indent=2) + "\n")

    def true_quadratures(self) -> tuple[float, float]:
        """Least-squares acceleration quadratures (A, B) [m/s²] at the window start, filter
        gain removed (:meth:`dampfit.inference.least_squares.LeastSquaresResult.true_quadratures`)."""
        if self._loaded is not None:
            raise self._loaded.live_only("true_quadratures()")
        return self.least_squares.true_quadratures()

    def signals(self) -> dict[str, np.ndarray]:
        """Measured and modelled signals (plain arrays, SI units), a fresh copy on every call.

        On the analysis window: ``t`` [s] uniform grid of the window (recording time base),
        ``accel`` [m/s²] band-passed measured acceleration of the analysed axis,
        ``accel_model`` [m/s²] the least-squares decay (drift excluded, filter gain removed),
        ``displacement`` [m] the measured displacement of the paper's pipeline (band-pass, ∫∫,
        band-pass; NaN when that baseline failed), ``displacement_model`` [m]; scalars ``fs``
        [Hz], ``p`` [1/s], ``omega_d`` [rad/s], ``t0`` [s] (window start, τ = t − t0). And the
        arrays every figure is drawn from (:func:`dampfit.stages.figure_signals`, each key in
        :mod:`dampfit.result.signals`): the whole recording reduced for display, its
        spectrum, the fitted samples and least-squares curve, the envelope pipeline's
        displacement envelopes — bounded in size whatever the recording's length.

        Computed once (:meth:`keep_fit_stage`: the pipeline computes them at the fit stage);
        of a loaded result: the arrays of its signals.npz (an older folder has no figure
        arrays).
        """
        if self._loaded is not None:
            return self._loaded.signals()
        if self._signals is None:
            self._signals = stages.figure_signals(self.prepared, self.fit_data,
                                                  self.least_squares, self.baselines)
        return {key: np.copy(value) for key, value in self._signals.items()}

    def keep_fit_stage(self, signals: dict[str, np.ndarray], fit: dict[str, Any]) -> None:
        """Use ``signals`` — :func:`dampfit.stages.figure_signals` of this analysis's own
        prepared signal, fit data, least squares and baselines, computed at the fit stage — as
        :meth:`signals`, and ``fit`` (:func:`dampfit.stages.fit_summary` of the same) in
        :meth:`summary`, so neither is computed twice."""
        self._signals, self._fit = signals, fit

    def to_signals(self, path: str | os.PathLike) -> Path:
        """Write :meth:`signals` to an ``.npz`` file (atomically;
        :func:`dampfit.result.signals.write_npz`)."""
        from dampfit.result.signals import write_npz

        return write_npz(path, self.signals())

    # --------------------------------------------------------------- renderings
    def report(self) -> str:
        """The text table the CLI prints (:func:`dampfit.output.text.text` of :meth:`summary`)."""
        from dampfit.output import text

        return text.text(self.summary())

    def _repr_html_(self) -> str:
        """A short HTML table of the headline numbers, for notebooks."""
        from dampfit.output import text

        return text.html_table(self.summary())

    def __repr__(self) -> str:
        where = f" loaded from {self.folder}" if self.folder is not None else ""
        return f"<dampfit Analysis{where}: {self._headline()}>"

    def _headline(self) -> str:
        from dampfit.output import text

        return text.headline(self.summary())

    def save(self, folder, *, force: bool = False, figures: bool = True, report: bool = False,
             figure_process=None) -> Path:
        """Write the result folder ``dampfit analyze`` writes and return its path.

        ``folder`` is a path: the folder is written whole (staged beside the target, locked,
        swapped in at the end; an existing folder is replaced only with ``force`` and only if
        dampfit wrote it) with summary.json, posterior.nc, signals.npz, the figures unless
        ``figures`` is False, and with ``report`` report.html and report.md. Or ``folder`` is
        an open :class:`dampfit.files.folder.ResultFolder` (the CLI opens it before the analysis, so
        that a folder that cannot be written is refused before the work): the files go into
        its staging folder and the caller publishes it. ``figure_process`` (the CLI's
        :class:`dampfit.output.figure_process.FigureProcess`) draws the figures when given.
        """
        from dampfit.files.folder import ResultFolder, result_folder

        if isinstance(folder, ResultFolder):
            self._write(folder, figures, figure_process)
            return folder.stage
        inputs = [] if self._loaded is not None or not self.recording.path else [
            self.recording.path]
        with result_folder(folder, "analyze", force, inputs=inputs) as target:
            self._write(target, figures, figure_process)
            out = target.publish()
        if report:
            from dampfit.output.report import write_report

            write_report(out)
        return out

    def _write(self, folder, figures: bool, figure_process) -> None:
        """summary.json, posterior.nc, signals.npz and the figures into ``folder.stage``."""
        stage = folder.stage
        with folder.writing():
            if figures and figure_process is not None:  # it draws while the files are written
                figure_process.deliver(self, stage)
            self.to_netcdf(stage / "posterior.nc")
            self.to_signals(stage / "signals.npz")
            self._record_files(stage)
            self.to_json(stage / "summary.json")
            if figures and figure_process is not None:
                figure_process.finish(self, stage)
            elif figures:
                from dampfit.output.figures import save_figures

                # a result loaded from an older folder lacks the figure arrays: say so, once
                notes: list[str] = []
                save_figures(self, stage, on_missing=None if self._loaded is None else
                             lambda name, why: notes.append(why))
                if notes:
                    warnings.warn("; ".join(notes), stacklevel=4)

    def _record_files(self, stage: Path) -> None:
        """summary.json's ``files``: the SHA-256 and size of the posterior.nc and signals.npz
        just written into ``stage``, so a reader refuses either swapped in from another
        analysis (:func:`dampfit.result.files.check_digest`)."""
        from dampfit.result.files import file_digests

        self.summary()  # computed (or loaded) before it is amended
        self._summary["files"] = file_digests(stage)

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write the posterior (arviz InferenceData) to a NetCDF file, with the per-mode
        posterior (:attr:`modes_posterior`, when there are several modes) as its group
        ``modes`` and the damper's draws (:attr:`damper_draws`, unless no damper is
        recommended) as its group ``damper``."""
        modal, damper = self.modes_posterior, self.damper_draws
        groups = {**({} if modal is None else {"modes": modal}),
                  **({} if damper is None else {"damper": damper})}
        return atomic_write(path, lambda tmp: write_netcdf(self.posterior, tmp, groups=groups),
                            suffix=".nc")


def _baselines_summary(base: dict, p_post: dict | None) -> dict[str, Any]:
    """Each baseline's summary with its support (:mod:`dampfit.estimators.baselines`) and whether it
    agrees with the posterior of p within its expected spread (``agrees_with_posterior``,
    ``note``; :func:`dampfit.estimators.baselines.agreement`)."""
    out: dict[str, Any] = {}
    for name, b in base.items():
        if b is None:
            out[name] = None
            continue
        d = b.summary()
        d.update(baselines.agreement(d, (p_post or {}).get("q50"), (p_post or {}).get("sd")))
        out[name] = d
    return out


def _param_summary(idata, name: str, diagnostics: dict[str, dict[str, float]]) -> dict[str, Any]:
    """Quantiles of one posterior quantity (:func:`dampfit.damping.quantities.summarise`) with
    the R-hat and bulk ESS the posterior stage computed
    (:attr:`dampfit.inference.posterior.PosteriorResult.diagnostics`; NaN for ≤ 4 draws)."""
    x = np.asarray(idata.posterior[name])
    return summarise(x, PARAMETER_UNITS[name],
                     (diagnostics.get(name) or {}) if x.shape[1] > 4 else {})
