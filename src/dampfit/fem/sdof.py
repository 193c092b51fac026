"""The identified single-degree-of-freedom system a deck describes, read from a result folder.

``m·ü + c·u̇ + k·u = 0`` (seed paper eq. 22 with F = 0), released at rest from ``u(0) = u0``.
u is measured from the static equilibrium along the vertical, positive *up*. With gravity g the
spring already carries the weight at equilibrium: it is stretched by the static sag
``s = m·g/k`` [m], so the mass is released from ``−s + u0`` relative to the unstretched spring
and oscillates about ``−s``; without gravity ``s = 0``. The dynamics of u are the same either
way (the system is linear).

Values come from ``DIR/summary.json`` (read by :func:`dampfit.result.schema.read_summary`) at a posterior quantile q: q = 0.05, 0.5, 0.95 are
read from the summary's ``q05``/``q50``/``q95``; any other q ∈ (0, 1) from the draws in
``DIR/posterior.nc`` (arviz/xarray ``quantile`` over chain and draw, linear interpolation).
The quantiles are *marginal* (c at q and k at q are not one joint draw). The mass is the
weighed mass ``mass.value`` of the summary (the value a FEM model is built with).

A campaign folder (several recordings of one damper, ``"kind": "campaign"``) gives the
population damper: c and k from its ``parameters`` (the population), the mass from ``mass``
(the effective mass m₀ in added-mass mode), u0 the median of the tests' ``amplitude_m``; its
``source`` carries a ``campaign`` sentence the decks print as a comment.

u0 in the summary is the displacement envelope amplitude at the start of the analysed
window; a release from rest at u0 has envelope u0·ω_n/ω_d = u0/√(1 − ζ²), which differs from
u0 by ζ²/2 (≤ 5e-5 for ζ ≤ 0.01).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dampfit.errors import InputError
from dampfit.errors import shown
from dampfit.fem.units import STANDARD_GRAVITY
from dampfit.result.schema import brief as _brief
from dampfit.result.schema import number
from dampfit.result.schema import read_summary as read_checked

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
    """``(folder, summary)`` of a dampfit result folder (or of an analysis
    :func:`dampfit.load` read from one), read and checked by the one reader of result folders,
    :func:`dampfit.result.schema.read_summary`; :class:`InputError` if unusable. Numbers are
    checked where they are used (:func:`number`)."""
    s = read_checked(folder)
    return s.folder, s.data


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
    from dampfit.result.folder import read_posterior

    post = read_posterior(folder).posterior
    try:
        if name not in post:
            raise InputError(f"{shown(path)} has no draws of {name!r}; re-run 'dampfit analyze --mass KG'")
        return float(post[name].quantile(q, dim=("chain", "draw")).values)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file for the user
        raise InputError(f"{shown(path)} is not a readable posterior ({type(exc).__name__}); "
                         "re-run 'dampfit analyze'") from None


def _campaign_tests(summary: dict[str, Any]) -> list[dict[str, Any]]:
    tests = summary.get("tests")
    return [t for t in tests if isinstance(t, dict)] if isinstance(tests, list) else []


def campaign_u0(summary: dict[str, Any], path: Path) -> float:
    """Release displacement [m] of a campaign's population damper: the median of the tests'
    initial displacement amplitudes ``tests[i].amplitude_m`` (each checked, > 0)."""
    amps = sorted(number(t.get("amplitude_m"), f"tests[{i}].amplitude_m", path, positive=True)
                  for i, t in enumerate(_campaign_tests(summary)))
    if not amps:
        raise InputError(f"{shown(path)}: a campaign summary without tests: no release "
                         "amplitude for the deck")
    n = len(amps)
    return amps[n // 2] if n % 2 else 0.5 * (amps[n // 2 - 1] + amps[n // 2])


def campaign_note(summary: dict[str, Any]) -> str:
    """One sentence for a deck written from a campaign: it is the population damper of N tests
    (its predictive interval for a new test, when stored)."""
    design = summary.get("design") if isinstance(summary.get("design"), dict) else {}
    n = design.get("n_tests")
    n = n if isinstance(n, int) and not isinstance(n, bool) else len(_campaign_tests(summary))
    model = design.get("model") if design.get("model") in ("hierarchical", "added-mass") \
        else "hierarchical"
    note = (f"Population damper of a campaign of {n} tests ({model} model): c, k and m are the "
            "population values (the centre of the tests), u0 the median release amplitude")
    pred = summary
    for key in ("population", "predictive", "c"):  # any of them may be an edited non-object
        pred = pred.get(key) if isinstance(pred, dict) else None
    if isinstance(pred, dict) and all(isinstance(pred.get(k), (int, float))
                                      and not isinstance(pred.get(k), bool)
                                      and math.isfinite(pred[k]) for k in ("q05", "q95")):
        note += (f"; a new test's c is predicted in [{pred['q05']:.4g}, {pred['q95']:.4g}] "
                 "N*s/m (90 % predictive interval)")
    return note + "."


def load(folder: str | Path, quantile: float = 0.5, gravity: bool = False) -> Sdof:
    """The identified system of result ``folder`` at posterior ``quantile`` ∈ (0, 1).

    ``gravity`` adds g = 9.80665 m/s² (the deck then starts from static equilibrium + u0).
    """
    if not (math.isfinite(quantile) and 0.0 < quantile < 1.0):
        raise InputError(f"--quantile must be strictly between 0 and 1, got {quantile!r}")
    checked = read_checked(folder)
    folder, summary, digest = checked.folder, checked.data, checked.sha256
    path = checked.path
    mass = _mass(summary, path)
    campaign = summary.get("kind") == "campaign"
    values = {name: summary_quantile(summary, name, quantile, folder)
              for name in (("k", "c") if campaign else ("k", "c", "u0"))}
    if campaign:
        values["u0"] = campaign_u0(summary, path)
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
    if campaign:
        source["campaign"] = campaign_note(summary)
    return Sdof(mass=mass, k=values["k"], c=values["c"], u0=values["u0"],
                g=STANDARD_GRAVITY if gravity else 0.0, source=source)
