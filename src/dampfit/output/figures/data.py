"""The plain data a figure is drawn from: :class:`FigureData` (summary, signals, posterior).

* ``summary`` — the summary dict (summary.json; schema in :mod:`dampfit.result.schema`), or
  only the sections a stage has produced so far (:func:`dampfit.stages.fit_summary`,
  :func:`dampfit.stages.sampling_summary`);
* ``signals`` — the arrays of signals.npz (:mod:`dampfit.result.signals`);
* ``posterior`` — the posterior as arviz ``InferenceData`` (posterior.nc).

A live :class:`~dampfit.analysis.Analysis`, one loaded from its folder and the figure process
all hand figures the same plain data, so the PNGs are the same bytes. Whatever is read from a
folder may have been edited: every value is read through :meth:`FigureData.number` /
:meth:`FigureData.text` (a wrong type reads as missing), and a figure whose data are absent
raises :class:`MissingData` (one line) instead of drawing something else.
"""

from __future__ import annotations

import math
from pathlib import PurePath
from typing import Any
from collections.abc import Callable

import numpy as np

from dampfit import physics
from dampfit.errors import InputError
from dampfit.result.signals import FIGURE_GROUPS

#: Symbol and unit (:data:`dampfit.physics.UNITS`, "N s/m" drawn as "N·s/m") of each quantity.
LABELS = {
    name: (sym, physics.UNITS[name].replace(" ", "·"))
    for name, sym in (("c", "c"), ("k", "k"), ("u0", "u₀"), ("zeta", "ζ"), ("f_n", "f_n"),
                      ("p", "p"), ("f_d", "f_d"), ("delta", "δ"), ("mass", "m"),
                      ("omega_d", "ω_d"))
}
#: The summary sections a stage delivers before the whole summary exists.
_STAGE_SECTIONS = ("input", "window", "band", "dominant_frequency_hz", "mass", "least_squares",
                   "noise_model", "fit", "preprocessing", "diagnostics")
#: Every data key a figure may need (:data:`dampfit.output.figures.NEEDS`): the signals, the
#: posterior and ``summary.<section>`` for each summary section.
DATA_KEYS = frozenset({"signals", "posterior", "summary.amplitude_curve", "summary.n_modes",
                       "summary.modes",
                       *(f"summary.{s}" for s in _STAGE_SECTIONS)})


class MissingData(InputError):
    """A figure cannot be drawn: the data it is drawn from are not there (one line)."""


class Draws:
    """A posterior group as plain NumPy arrays: what the posterior and trace figures read of
    it (``name in draws``, ``draws[name]`` of shape (walker, draw), ``draws.sizes``) without
    arviz or xarray. The figure process (:mod:`dampfit.output.figure_process`) is sent this
    instead of the InferenceData, so it never imports them (≈ 1 s of CPU on the core the
    analysis shares with it)."""

    def __init__(self, arrays: dict[str, np.ndarray], sizes: dict[str, int]):
        self._arrays = {str(k): np.asarray(v) for k, v in arrays.items()}
        self.sizes = {str(k): int(v) for k, v in sizes.items()}

    @classmethod
    def of(cls, idata: Any) -> "Draws | None":
        """The posterior group of the InferenceData ``idata`` as plain arrays (None without
        one; a ``Draws`` is returned as it is)."""
        if idata is None or isinstance(idata, cls):
            return idata
        post = getattr(idata, "posterior", None)
        if post is None:
            return None
        return cls({k: v.values for k, v in post.data_vars.items()}, dict(post.sizes))

    def __contains__(self, name: object) -> bool:
        return name in self._arrays

    def __getitem__(self, name: str) -> np.ndarray:
        return self._arrays[name]


class FigureData:
    """The plain data figures are drawn from (module docstring). Each of ``summary``,
    ``signals`` and ``posterior`` is the value or a function returning it, called on first use
    (a loaded result reads posterior.nc only when a figure needs it); ``where`` names the
    source in messages (e.g. the result folder)."""

    def __init__(self, summary: dict | Callable[[], dict] | None = None,
                 signals: dict | Callable[[], dict] | None = None,
                 posterior: Any = None, where: str = "this result"):
        self._parts = {"summary": summary, "signals": signals, "posterior": posterior}
        self._errors: dict[str, InputError] = {}
        self.where = where

    @classmethod
    def of(cls, result: Any) -> "FigureData":
        """The data of an :class:`~dampfit.analysis.Analysis`, live or loaded (each part read
        on first use)."""
        where = f"the result in {result.folder}" if getattr(result, "folder", None) else \
            "this result"
        return cls(result.summary, result.signals, lambda: result.posterior, where)

    # ------------------------------------------------------------------ parts
    def _part(self, name: str) -> Any:
        value = self._parts[name]
        if callable(value):
            try:
                value = value()
            except InputError as exc:  # an unusable file of a loaded result
                self._errors[name] = exc
                value = None
            self._parts[name] = value
        return value

    @property
    def summary(self) -> dict:
        s = self._part("summary")
        return s if isinstance(s, dict) else {}

    @property
    def signals(self) -> dict | None:
        return self._part("signals")

    @property
    def posterior(self) -> Any:
        return self._part("posterior")

    def add(self, parts: dict[str, Any]) -> None:
        """Merge what a stage delivered: ``signals``, ``posterior`` and ``summary`` sections
        (a later section replaces an earlier one of its name)."""
        for name in ("signals", "posterior"):
            if parts.get(name) is not None:
                self._parts[name] = parts[name]
        if isinstance(parts.get("summary"), dict):
            self._parts["summary"] = {**self.summary, **parts["summary"]}

    def keys(self) -> frozenset[str]:
        """The data keys present (:data:`DATA_KEYS`; ``signals`` and ``posterior`` without
        reading them)."""
        out = {f"summary.{k}" for k in self.summary}
        out.update(name for name in ("signals", "posterior") if self._parts[name] is not None)
        return frozenset(out)

    # ------------------------------------------------------------------ access
    def section(self, name: str) -> dict:
        """Summary section ``name`` (a dict; empty when absent or not a dict)."""
        s = self.summary.get(name)
        return s if isinstance(s, dict) else {}

    def number(self, section: str, key: str | None = None, default: float = math.nan) -> float:
        """A number of the summary (``summary[section][key]``, or ``summary[section]``), as a
        float; ``default`` when absent, not a number or not finite."""
        v = self.summary.get(section) if key is None else self.section(section).get(key)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            return float(v)
        return default

    def text(self, section: str, key: str, default: str = "") -> str:
        """A string of the summary, mathtext dollars escaped (a title never parses it)."""
        v = self.section(section).get(key)
        return plain(v) if isinstance(v, str) else default

    def flag(self, section: str, key: str) -> bool | None:
        """A boolean of the summary, or None."""
        v = self.section(section).get(key)
        return v if isinstance(v, bool) else None

    def require(self, figure: str, *numbers: tuple[str, str | None]) -> list[float]:
        """The summary numbers ``(section, key)`` a figure cannot do without, as floats;
        :class:`MissingData` naming the first one absent."""
        out = []
        for section, key in numbers:
            v = self.number(section, key)
            if not math.isfinite(v):
                name = section if key is None else f"{section}.{key}"
                raise MissingData(f"{figure}.png cannot be drawn: {self.where} has no usable "
                                  f"{name} in its summary")
            out.append(v)
        return out

    def need_signals(self, figure: str) -> dict:
        """The signals; :class:`MissingData` naming why they are not there."""
        sig = self.signals
        if sig is None:
            why = self._errors.get("signals")
            raise MissingData(f"{figure}.png cannot be drawn: "
                              + (str(why) if why else f"{self.where} has no signals"))
        return sig

    def arrays(self, figure: str, group: str, optional: bool = False) -> dict | None:
        """The figure arrays of ``group`` (:data:`dampfit.result.signals.FIGURE_GROUPS`).
        An absent group is :class:`MissingData` naming the reason, or — if ``optional`` and
        the signals hold other figure arrays (the stage had nothing to keep: the figure does
        not apply) — None."""
        sig = self.need_signals(figure)
        keys = FIGURE_GROUPS[group]
        if all(k in sig for k in keys):
            return {k: sig[k] for k in keys}
        if optional and any(k in sig for keys in FIGURE_GROUPS.values() for k in keys):
            return None
        raise MissingData(f"{figure}.png cannot be drawn: the signals.npz of {self.where} holds "
                          f"no {group} figure arrays (written by an older dampfit); re-run "
                          "'dampfit analyze' to draw it")

    def scalar(self, key: str) -> float:
        """Scalar ``key`` of the signals (NaN when absent)."""
        sig = self.signals or {}
        return float(np.asarray(sig[key], float).reshape(())) if key in sig else math.nan

    def draws(self, figure: str):
        """The posterior group of the InferenceData (or the :class:`Draws` sent in its
        place); :class:`MissingData` without one."""
        idata = self.posterior
        post = idata if isinstance(idata, Draws) else \
            getattr(idata, "posterior", None) if idata is not None else None
        if post is None:
            why = self._errors.get("posterior")
            raise MissingData(f"{figure}.png cannot be drawn: "
                              + (str(why) if why else f"{self.where} has no posterior"))
        return post

    # ------------------------------------------------------------------ derived
    def ls_values(self) -> dict[str, float]:
        """Least-squares physical values (summary ``least_squares``: p, ζ, f_n, u₀, with a
        mass c and k) with the damped frequency f_d [Hz] and ω_d [rad/s] of the signals and
        the mass [kg]; only the finite ones."""
        out = {k: self.number("least_squares", k) for k in ("p", "zeta", "f_n", "u0", "c", "k")}
        p, w = self.scalar("p"), self.scalar("omega_d")
        if math.isfinite(w):
            q = physics.quantities(p, w)
            out["f_d"], out["omega_d"] = float(q["f_d"]), float(q["omega_d"])
        out["mass"] = self.number("mass", "value")
        return {k: v for k, v in out.items() if math.isfinite(v)}

    def recording_name(self) -> str:
        """The recording's file name, or ``<format> recording``."""
        path = self.text("input", "path")
        return PurePath(path).name if path else f"{self.text('input', 'format')} recording"


def plain(s: str) -> str:
    """``s`` with its dollar signs escaped: drawn as written, never parsed as mathtext."""
    return s.replace("$", r"\$")


def as_data(x: Any) -> FigureData:
    """``x`` if it is :class:`FigureData`, else the data of the analysis ``x``."""
    return x if isinstance(x, FigureData) else FigureData.of(x)


def unit(name: str) -> str:
    """Unit of ``name`` as drawn (:data:`LABELS`)."""
    return LABELS[name][1]


def label(name: str) -> str:
    """``symbol [unit]`` of ``name``."""
    sym, u = LABELS.get(name, (name, "1"))
    return f"{sym} [{u}]"


def fmt(x: float | None, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits, ``–`` when missing or not finite."""
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.{digits}g}"
