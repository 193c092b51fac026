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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from .units import STANDARD_GRAVITY

__all__ = ["Sdof", "load", "read_summary", "summary_quantile"]

#: Quantiles the summary stores, by key.
_SUMMARY_QUANTILES = {0.05: "q05", 0.5: "q50", 0.95: "q95"}


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
    """``(folder, summary)`` of a dampfit result folder; :class:`InputError` if unusable."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder} is not a directory; give a dampfit result folder "
                         "(the --out of 'dampfit analyze')")
    path = folder / "summary.json"
    if not path.is_file():
        raise InputError(f"{path} not found; run 'dampfit analyze FILE --mass KG --out {folder}' first")
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path} is not readable JSON ({exc}); re-run 'dampfit analyze'") from None
    if not isinstance(summary, dict) or not isinstance(summary.get("parameters"), dict):
        raise InputError(f"{path} has no 'parameters'; is it a dampfit summary.json?")
    return folder, summary


def _mass(summary: dict[str, Any], path: Path) -> float:
    mass = (summary.get("mass") or {}).get("value")
    params = summary["parameters"]
    if mass is None or params.get("c") is None or params.get("k") is None:
        raise InputError(f"{path} has no mass, so c and k are not identified; re-run "
                         "'dampfit analyze FILE --mass KG' with the weighed mass")
    return float(mass)


def summary_quantile(summary: dict[str, Any], name: str, q: float, folder: Path) -> float:
    """Posterior quantile ``q`` of parameter ``name`` (summary keys, else posterior.nc)."""
    entry = summary["parameters"].get(name)
    if not isinstance(entry, dict):
        raise InputError(f"{folder / 'summary.json'} has no parameter {name!r}")
    for level, key in _SUMMARY_QUANTILES.items():
        if abs(q - level) < 1e-12 and entry.get(key) is not None:
            return float(entry[key])
    return _posterior_quantile(folder, name, q)


def _posterior_quantile(folder: Path, name: str, q: float) -> float:
    path = folder / "posterior.nc"
    if not path.is_file():
        raise InputError(f"quantile {q:g} needs the posterior draws in {path}, which is missing; "
                         "use --quantile 0.05, 0.5 or 0.95 (stored in summary.json)")
    import arviz as az  # lazy: heavy

    try:
        post = az.from_netcdf(str(path)).posterior
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file for the user
        raise InputError(f"{path} is not a readable posterior ({type(exc).__name__}); "
                         "re-run 'dampfit analyze'") from None
    if name not in post:
        raise InputError(f"{path} has no draws of {name!r}; re-run 'dampfit analyze --mass KG'")
    return float(post[name].quantile(q, dim=("chain", "draw")).values)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load(folder: str | Path, quantile: float = 0.5, gravity: bool = False) -> Sdof:
    """The identified system of result ``folder`` at posterior ``quantile`` ∈ (0, 1).

    ``gravity`` adds g = 9.80665 m/s² (the deck then starts from static equilibrium + u0).
    """
    if not (math.isfinite(quantile) and 0.0 < quantile < 1.0):
        raise InputError(f"--quantile must be strictly between 0 and 1, got {quantile!r}")
    folder, summary = read_summary(folder)
    mass = _mass(summary, folder / "summary.json")
    values = {name: summary_quantile(summary, name, quantile, folder) for name in ("k", "c", "u0")}
    source = {
        "folder": str(folder.resolve()),
        "quantile": quantile,
        "summary_sha256": _sha256(folder / "summary.json"),
        "recording_sha256": (summary.get("input") or {}).get("sha256"),
        "dampfit_version": summary.get("dampfit_version"),
        "mass_sd": (summary.get("mass") or {}).get("sd"),
    }
    return Sdof(mass=mass, k=values["k"], c=values["c"], u0=values["u0"],
                g=STANDARD_GRAVITY if gravity else 0.0, source=source)
