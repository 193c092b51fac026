"""The identified single-degree-of-freedom system a deck describes, read from a result folder.

``m·ü + c·u̇ + k·u = 0`` (seed paper eq. 22 with F = 0), released at rest from ``u(0) = u0``.
u is measured from the static equilibrium along the vertical, positive *up*. With gravity g the
spring already carries the weight at equilibrium: it is stretched by the static sag
``s = m·g/k`` [m], so the mass is released from ``−s + u0`` relative to the unstretched spring
and oscillates about ``−s``; without gravity ``s = 0``. The dynamics of u are the same either
way (the system is linear).

Values come from ``DIR/summary.json`` at a posterior quantile q: q = 0.05, 0.5, 0.95 are
read from the summary's ``q05``/``q50``/``q95``; any other q ∈ (0, 1) from the draws in
``DIR/posterior.nc`` (arviz/xarray ``quantile`` over chain and draw, linear interpolation).
The quantiles are *marginal* (c at q and k at q are not one joint draw). The mass is the
weighed mass ``mass.value`` of the summary (the value a FEM model is built with).

u0 in the summary is the displacement envelope amplitude at the start of the analysed
window; a release from rest at u0 has envelope u0·ω_n/ω_d = u0/√(1 − ζ²), which differs from
u0 by ζ²/2 (≤ 5e-5 for ζ ≤ 0.01).
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dampfit._files import read_bounded
from dampfit.errors import InputError
from dampfit.fem.sanitize import shown
from dampfit.fem.units import STANDARD_GRAVITY

__all__ = ["MAX_MAGNITUDE", "MAX_SUMMARY_BYTES", "MIN_POSITIVE", "Sdof", "load", "number",
           "read_summary", "summary_quantile"]

#: Quantiles the summary stores, by key.
_SUMMARY_QUANTILES = {0.05: "q05", 0.5: "q50", 0.95: "q95"}
#: Largest summary.json read [bytes]; a real one is a few kB.
MAX_SUMMARY_BYTES = 50 * 2**20
#: Largest magnitude of any number read from a summary (SI units): beyond it a value is a
#: typo or an edit, not a measured spring–damper (and decks in mm or ms would overflow fields).
MAX_MAGNITUDE = 1e15
#: Smallest value of a quantity that must be positive (mass [kg], k [N/m]): below it unit
#: conversion (e.g. k × 1e-6 in mm-ms-kg) approaches underflow.
MIN_POSITIVE = 1e-15


@dataclass(frozen=True)
class Sdof:
    """Mass [kg], stiffness k [N/m], damping c [N·s/m], release displacement u0 [m], gravity g [m/s²].

    ``g = 0`` means no gravity. ``source`` carries provenance (folder, quantile, hashes).
    """

    mass: float
    k: float
    c: float
    u0: float
    g: float = 0.0
    source: dict[str, Any] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        for name in ("mass", "k", "c", "u0", "g"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, numbers.Real):
                raise InputError(f"{name} must be a real number, got {v!r}")
            try:
                object.__setattr__(self, name, float(v))  # NumPy scalars too: decks write repr()
            except OverflowError:
                raise InputError(f"{name} must be finite, got an integer of {len(str(v))} digits") from None
        for name in ("mass", "k"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be positive and finite, got {v!r}")
        if not (math.isfinite(self.c) and self.c >= 0):
            raise InputError(f"c must be non-negative and finite, got {self.c!r}")
        if not math.isfinite(self.u0):
            raise InputError(f"u0 must be finite, got {self.u0!r}")
        if not (math.isfinite(self.g) and self.g >= 0):
            raise InputError(f"g must be non-negative and finite, got {self.g!r}")
        if self.c >= 2.0 * math.sqrt(self.k * self.mass):
            raise InputError("c >= 2*sqrt(k*m): the identified system does not oscillate")

    @property
    def omega_n(self) -> float:
        """Natural angular frequency √(k/m) [rad/s]."""
        return math.sqrt(self.k / self.mass)

    @property
    def p(self) -> float:
        """Decay rate c/(2m) [1/s] (paper eq. 3)."""
        return self.c / (2.0 * self.mass)

    @property
    def omega_d(self) -> float:
        """Damped angular frequency √(ω_n² − p²) [rad/s]."""
        return math.sqrt(self.omega_n**2 - self.p**2)

    @property
    def zeta(self) -> float:
        """Damping ratio c/(2√(k·m)) [1]."""
        return self.c / (2.0 * math.sqrt(self.k * self.mass))

    @property
    def period(self) -> float:
        """Natural period 2π/ω_n [s]."""
        return 2.0 * math.pi / self.omega_n

    @property
    def sag(self) -> float:
        """Static sag m·g/k [m] of the spring under the weight (0 without gravity)."""
        return self.mass * self.g / self.k


def read_summary(folder: str | Path) -> tuple[Path, dict[str, Any]]:
    """``(folder, summary)`` of a dampfit result folder; :class:`InputError` if unusable.

    summary.json must be a regular file (a FIFO or device is refused before it is opened, so
    nothing blocks) of at most :data:`MAX_SUMMARY_BYTES`, hold one JSON object with a
    ``parameters`` object, and its sections ``mass``, ``input``, ``window`` must be objects
    (or absent). Numbers are checked where they are used (:func:`number`).
    """
    folder, summary, _ = _read(folder)
    return folder, summary


def _read(folder: str | Path) -> tuple[Path, dict[str, Any], str]:
    """``(folder, summary, SHA-256 of the bytes read)``; see :func:`read_summary`."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{shown(folder)} is not a directory; give a dampfit result folder "
                         "(the --out of 'dampfit analyze')")
    path = folder / "summary.json"
    data = _read_regular(path, MAX_SUMMARY_BYTES, missing=(
        f"{shown(path)} not found; run 'dampfit analyze FILE --mass KG --out {shown(folder)}' first"))
    try:
        summary = json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise InputError(f"{shown(path)} is not UTF-8 text; is it a dampfit summary.json?") from None
    except RecursionError:
        raise InputError(f"{shown(path)} is nested too deeply to be a dampfit summary.json") from None
    except ValueError as exc:  # json.JSONDecodeError, or an integer with too many digits
        raise InputError(f"{shown(path)} is not readable JSON ({shown(exc, 120)}); "
                         "re-run 'dampfit analyze'") from None
    if not isinstance(summary, dict):
        raise InputError(f"{shown(path)} holds a JSON {_kind(summary)}, not an object; "
                         "is it a dampfit summary.json?")
    if not isinstance(summary.get("parameters"), dict):
        raise InputError(f"{shown(path)} has no 'parameters'; is it a dampfit summary.json?")
    for section in ("mass", "input", "window"):
        if summary.get(section) is not None and not isinstance(summary[section], dict):
            raise InputError(f"{shown(path)}: '{section}' must be an object, "
                             f"got {_brief(summary[section])}")
    version = summary.get("dampfit_version")
    if version is not None and not isinstance(version, str):
        raise InputError(f"{shown(path)}: 'dampfit_version' must be a string, got {_brief(version)}")
    return folder, summary, hashlib.sha256(data).hexdigest()


def _read_regular(path: Path, limit: int, missing: str) -> bytes:
    """Bytes of the regular file ``path`` (symbolic links followed), at most ``limit`` bytes.

    A directory, FIFO, socket or device is refused from its ``stat`` and again after a
    non-blocking ``open`` (so a file swapped in between cannot make the read block).
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(missing) from None
    except OSError as exc:
        raise InputError(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    _check_regular(path, st, limit)
    try:
        data = read_bounded(path, limit, lambda st: _check_regular(path, st, limit))
    except OSError as exc:
        raise InputError(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    if len(data) > limit:
        raise InputError(f"{shown(path)} is larger than {limit // 2**20} MB; a dampfit summary.json "
                         "is a few kB — is it the right file?")
    return data


def _check_regular(path: Path, st: os.stat_result, limit: int) -> None:
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{shown(path)} is a directory, not a file; give a dampfit result folder")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{shown(path)} is not a regular file (a FIFO, socket or device); "
                         "give a dampfit result folder")
    if st.st_size > limit:
        raise InputError(f"{shown(path)} is {st.st_size / 2**20:.0f} MB, larger than "
                         f"{limit // 2**20} MB; a dampfit summary.json is a few kB — is it the right file?")


def _kind(value: Any) -> str:
    return {dict: "object", list: "array", str: "string", bool: "boolean"}.get(
        type(value), "null" if value is None else "number")


def _brief(value: Any) -> str:
    """A JSON value as the user wrote it, shortened: ``true``, ``"0.2"``, ``an array``…"""
    if isinstance(value, (dict, list)):
        return f"an {_kind(value)}"
    try:
        text = json.dumps(value, ensure_ascii=True)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def number(value: Any, field: str, where: str | Path, *, positive: bool = False,
           nonnegative: bool = False, maximum: float = MAX_MAGNITUDE) -> float:
    """``value`` of ``field`` in file ``where`` as a float, or :class:`InputError` naming both.

    It must be a real number (not a boolean, string, array, object or null), finite, of
    magnitude at most ``maximum``, and ``> 0`` (``positive``, then also at least
    :data:`MIN_POSITIVE`) or ``≥ 0`` (``nonnegative``) if asked.
    """
    head = f"{shown(where)}: {field}"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{head} must be a number, got {_brief(value)}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise InputError(f"{head} must be finite, got {_brief(value) if isinstance(value, int) else x}")
    if positive and not x >= MIN_POSITIVE:
        raise InputError(f"{head} must be positive (at least {MIN_POSITIVE:g}), got {x!r}")
    if nonnegative and x < 0:
        raise InputError(f"{head} must not be negative, got {x!r}")
    if abs(x) > maximum:
        raise InputError(f"{head} = {x:g} is beyond {maximum:g}: not a plausible value")
    return x


#: What each parameter the decks use must be.
_PARAMETER_RULES = {"k": {"positive": True}, "c": {"nonnegative": True}, "u0": {},
                    "p": {"nonnegative": True}}


def _mass(summary: dict[str, Any], path: Path) -> float:
    mass = (summary.get("mass") or {}).get("value")
    params = summary["parameters"]
    if mass is None:
        raise InputError(f"{shown(path)} has no mass, so c and k are not identified; re-run "
                         "'dampfit analyze FILE --mass KG' with the weighed mass")
    for name in ("c", "k"):
        if params.get(name) is None:
            raise InputError(f"{shown(path)} has a mass but no parameters.{name}; is it a complete "
                             "dampfit summary.json? re-run 'dampfit analyze FILE --mass KG'")
    return number(mass, "mass.value", path, positive=True)


def summary_quantile(summary: dict[str, Any], name: str, q: float, folder: Path) -> float:
    """Posterior quantile ``q`` of parameter ``name`` (summary keys, else posterior.nc).

    The value is checked (:func:`number`): finite, ``k > 0``, ``c ≥ 0``, ``p ≥ 0``.
    """
    path = Path(folder) / "summary.json"
    entry = summary["parameters"].get(name)
    if entry is None:
        raise InputError(f"{shown(path)} has no parameter {name!r}")
    if not isinstance(entry, dict):
        raise InputError(f"{shown(path)}: parameters.{name} must be an object with q05/q50/q95, "
                         f"got {_brief(entry)}")
    rules = _PARAMETER_RULES.get(name, {})
    for level, key in _SUMMARY_QUANTILES.items():
        if abs(q - level) < 1e-12 and entry.get(key) is not None:
            return number(entry[key], f"parameters.{name}.{key}", path, **rules)
    value = _posterior_quantile(Path(folder), name, q)
    return number(value, f"quantile {q:g} of the draws of {name}", Path(folder) / "posterior.nc",
                  **rules)


def _posterior_quantile(folder: Path, name: str, q: float) -> float:
    path = folder / "posterior.nc"
    if not path.is_file():
        raise InputError(f"quantile {q:g} needs the posterior draws in {shown(path)}, which is "
                         "missing; use --quantile 0.05, 0.5 or 0.95 (stored in summary.json)")
    import arviz as az  # lazy: heavy

    try:
        post = az.from_netcdf(str(path)).posterior
        if name not in post:
            raise InputError(f"{shown(path)} has no draws of {name!r}; re-run 'dampfit analyze --mass KG'")
        return float(post[name].quantile(q, dim=("chain", "draw")).values)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file for the user
        raise InputError(f"{shown(path)} is not a readable posterior ({type(exc).__name__}); "
                         "re-run 'dampfit analyze'") from None


def load(folder: str | Path, quantile: float = 0.5, gravity: bool = False) -> Sdof:
    """The identified system of result ``folder`` at posterior ``quantile`` ∈ (0, 1).

    ``gravity`` adds g = 9.80665 m/s² (the deck then starts from static equilibrium + u0).
    """
    if not (math.isfinite(quantile) and 0.0 < quantile < 1.0):
        raise InputError(f"--quantile must be strictly between 0 and 1, got {quantile!r}")
    folder, summary, digest = _read(folder)
    path = folder / "summary.json"
    mass = _mass(summary, path)
    values = {name: summary_quantile(summary, name, quantile, folder) for name in ("k", "c", "u0")}
    critical = 2.0 * math.sqrt(values["k"] * mass)
    if values["c"] >= critical:
        raise InputError(f"{shown(path)}: c = {values['c']:g} N s/m is at or above the critical "
                         f"damping 2*sqrt(k*m) = {critical:g} (zeta >= 1): the system does not oscillate")
    sd = (summary.get("mass") or {}).get("sd")
    recording = (summary.get("input") or {}).get("sha256")
    source = {
        "folder": str(folder.resolve()),
        "quantile": quantile,
        "summary_sha256": digest,
        "recording_sha256": recording if isinstance(recording, str) else None,
        "dampfit_version": summary.get("dampfit_version"),
        "mass_sd": None if sd is None else number(sd, "mass.sd", path, nonnegative=True),
    }
    return Sdof(mass=mass, k=values["k"], c=values["c"], u0=values["u0"],
                g=STANDARD_GRAVITY if gravity else 0.0, source=source)
