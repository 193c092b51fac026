"""The rules of the analysis and reading options, once: the command line's argparse types
(:mod:`dampfit.cli.options`) and the Python face's checks (:class:`AnalysisOptions`, which
:func:`dampfit.analyze` and :func:`dampfit.batch.runner.analyze_many` build) refuse the same
values with the same reasons.

A rule (:data:`RULES`) is the kind of number (``int`` or ``real``), what it must be (the
message's words) and the test; :func:`convert` applies one to a value or a command-line text
(``ValueError`` with "not an integer: 'x'", "not a number: 'x'" or "must be WHAT, got V");
:func:`check_relations` checks the options against each other (window and band order,
``mode_of_mass`` ≤ ``max_modes``), with the messages of ``dampfit analyze``.

The options of one run are one frozen object, :class:`AnalysisOptions` (axis, window, band,
damping law, amplitude, modes) holding its :class:`SamplerSettings` (seed, step limit,
effective sample size, progress), each checked once, in its constructor, under the rules
above. The defaults live here only (:data:`DEFAULT_SEED`, :data:`DEFAULT_MAX_STEPS`,
:data:`DEFAULT_MIN_ESS`, :data:`DEFAULT_MAX_MODES`); :meth:`AnalysisOptions.to_dict` is what
summary.json records as ``options`` and :meth:`AnalysisOptions.from_dict` rebuilds the run
from it (with the summary's ``seed``).
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field, replace
from typing import Any, Callable, NamedTuple

from dampfit.errors import InputError

#: Largest seed + 1 (numpy and the sampler take 32-bit seeds).
SEED_LIMIT = 2**32
#: Largest max_steps: the stored chain grows with it (10⁶ steps × 64 walkers ≈ 2 GB).
MAX_STEPS = 10**6
#: Default and largest max_modes (here only: :mod:`dampfit.inference.modes` imports them).
DEFAULT_MAX_MODES, MAX_MODES_LIMIT = 4, 8
#: max_modes when not given, for one recording (paper/modes.md) and for a campaign's tests
#: (their own modes are opt-in).
ANALYSIS_MAX_MODES, CAMPAIGN_MAX_MODES = DEFAULT_MAX_MODES, 1
#: The sampler's defaults: seed, step limit (emcee steps per walker) and the bulk effective
#: sample size [draws] it stops at (:func:`dampfit.inference.posterior.run_adaptive`).
DEFAULT_SEED, DEFAULT_MAX_STEPS, DEFAULT_MIN_ESS = 0, 20000, 1000.0
#: The damping laws ``model`` may name.
MODELS = ("auto", "viscous", "coulomb", "quadratic", "power")


class Rule(NamedTuple):
    """One option's values: ``kind`` "int" or "real" (finite), ``what`` it must be, ``ok``."""

    kind: str
    what: str
    ok: Callable[[float], bool] | None = None


RULES: dict[str, Rule] = {
    "seed": Rule("int", f"an integer from 0 to {SEED_LIMIT - 1}", lambda v: 0 <= v < SEED_LIMIT),
    "max_steps": Rule("int", f"an integer from 1 to {MAX_STEPS}", lambda v: 1 <= v <= MAX_STEPS),
    "max_modes": Rule("int", f"an integer from 1 to {MAX_MODES_LIMIT}",
                      lambda v: 1 <= v <= MAX_MODES_LIMIT),
    "mode_of_mass": Rule("int", f"an integer from 1 to {MAX_MODES_LIMIT}",
                         lambda v: 1 <= v <= MAX_MODES_LIMIT),
    "row": Rule("int", "an integer from 0 to 1023", lambda v: 0 <= v <= 1023),
    "rate": Rule("real", "a sample rate in Hz, above 0 and at most 1e7", lambda v: 0 < v <= 1e7),
    "window": Rule("real", "a finite time [s]"),
    "band": Rule("real", "a positive frequency [Hz]", lambda v: v > 0),
    "amplitude": Rule("real", "a positive displacement amplitude in metres", lambda v: v > 0),
}


def convert(name: str, value: Any) -> int | float:
    """``value`` (a number, or the text given on the command line) under the rule of
    option ``name``; ``ValueError`` with the reason otherwise."""
    rule = RULES[name]
    text = value if isinstance(value, str) else repr(value)
    if rule.kind == "int":
        try:
            v = int(value, 10) if isinstance(value, str) else operator.index(value)
            if isinstance(value, bool):
                raise TypeError
        except (TypeError, ValueError):
            raise ValueError(f"not an integer: {text!r}") from None
        if not rule.ok(v):
            raise ValueError(f"must be {rule.what}, got {v}")
        return v
    try:
        if isinstance(value, bool):
            raise TypeError
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or (rule.ok is not None and not rule.ok(v)):
        raise ValueError(f"must be {rule.what}, got {value if isinstance(value, str) else f'{v:g}'}")
    return v


def check_relations(window, band, max_modes: int | None, mode_of_mass: int | None) -> None:
    """The options against each other (each already under its rule): START < END, LO < HI,
    ``mode_of_mass`` at most ``max_modes`` (default :data:`ANALYSIS_MAX_MODES`)."""
    if window is not None and not window[0] < window[1]:
        raise InputError(f"argument --window: END must come after its start, got "
                         f"{window[0]:g} {window[1]:g}")
    if mode_of_mass is not None and mode_of_mass > (max_modes or ANALYSIS_MAX_MODES):
        raise InputError(f"argument --mode-of-mass: mode {mode_of_mass} is beyond "
                         f"--max-modes {max_modes or ANALYSIS_MAX_MODES}")
    if band is not None and not band[0] < band[1]:
        raise InputError(f"argument --band: the pass band needs LO < HI, got "
                         f"{band[0]:g} {band[1]:g}")


def _pair(name: str, value) -> tuple[float, float]:
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != 2:
        raise InputError(f"argument --{name}: expected two numbers, got {value!r}")
    return tuple(_one(name, v) for v in items)


def _one(name: str, value):
    try:
        return convert(name, value)
    except ValueError as exc:
        raise InputError(f"argument --{name.replace('_', '-')}: {exc}") from None


def _models() -> tuple[str, ...]:
    """The values ``model`` may take: ``auto`` and every registered damping law's name."""
    from dampfit.model.laws import names  # light: JAX is imported on first use

    return ("auto",) + names()


def _min_ess(value):
    """``min_ess``: a finite number above 0 (kept as given: summary.json records it so)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) and not hasattr(
            value, "__float__"):
        raise InputError(f"argument --min-ess: not a number: {value!r}")
    if not (math.isfinite(float(value)) and float(value) > 0):
        raise InputError(f"argument --min-ess: must be a finite number above 0, got {value!r}")
    return value


#: The keywords of :func:`dampfit.analyze` that are :class:`SamplerSettings`.
SAMPLER_KEYS = ("seed", "max_steps", "min_ess", "progress")


@dataclass(frozen=True)
class SamplerSettings:
    """How every sampler of a run is driven: ``seed`` (0 … 2³²−1), ``max_steps`` (emcee steps
    per walker, 1 … :data:`MAX_STEPS`), ``min_ess`` (the bulk effective sample size [draws]
    a chain stops at) and ``progress`` (show the long stages). Checked on construction
    (one-line :class:`InputError` naming the option as the command line does)."""

    seed: int = DEFAULT_SEED
    max_steps: int = DEFAULT_MAX_STEPS
    min_ess: float = DEFAULT_MIN_ESS
    progress: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "seed", _one("seed", self.seed))
        object.__setattr__(self, "max_steps", _one("max_steps", self.max_steps))
        object.__setattr__(self, "min_ess", _min_ess(self.min_ess))
        object.__setattr__(self, "progress", bool(self.progress))


def _range(name: str, value):
    """``window``/``band``: None, one (lo, hi) pair, or (a campaign) one pair or None per
    recording; each number under its rule, kept as given."""
    if value is None:
        return None
    if isinstance(value, (list, tuple)) and value and all(
            v is None or (isinstance(v, (list, tuple)) and len(v) == 2) for v in value):
        return tuple(None if v is None else _checked_pair(name, v) for v in value)
    return _checked_pair(name, value)


def _checked_pair(name: str, value) -> tuple:
    pair = _pair(name, value)
    check_relations(pair if name == "window" else None, pair if name == "band" else None,
                    None, None)
    return tuple(value)


@dataclass(frozen=True)
class AnalysisOptions:
    """The options of one analysis, checked once (here) and carried whole through the stages.

    ``axis`` (x, y, z, a column or auto), ``window`` (start, end) [s] and ``band`` (low, high)
    [Hz] (a campaign: one pair for all or one per recording), ``model`` (:data:`MODELS`),
    ``amplitude`` [m] (the design displacement amplitude of a non-viscous law's c), ``max_modes``
    (1 … :data:`MAX_MODES_LIMIT`; None: :data:`ANALYSIS_MAX_MODES` for one recording,
    :data:`CAMPAIGN_MAX_MODES` for a campaign, :meth:`resolved`), ``mode_of_mass`` (1-based)
    and the :class:`SamplerSettings`. Values are kept as given (summary.json records them)."""

    axis: str = "auto"
    window: tuple | None = None
    band: tuple | None = None
    model: str = "auto"
    amplitude: float | None = None
    max_modes: int | None = None
    mode_of_mass: int | None = None
    sampler: SamplerSettings = field(default_factory=SamplerSettings)

    def __post_init__(self) -> None:
        if not (isinstance(self.axis, str) and self.axis.strip()):
            raise InputError(f"argument --axis: must be x, y, z, a column name or auto, got "
                             f"{self.axis!r}")
        models = _models()
        if self.model not in models:
            raise InputError(f"argument --model: unknown damping model {self.model!r}; choose "
                             f"one of {', '.join(models)}")
        if not isinstance(self.sampler, SamplerSettings):
            raise InputError(f"sampler must be SamplerSettings, got {self.sampler!r}")
        for name in ("max_modes", "mode_of_mass"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, _one(name, getattr(self, name)))
        if self.amplitude is not None:
            _one("amplitude", self.amplitude)
        for name in ("window", "band"):
            object.__setattr__(self, name, _range(name, getattr(self, name)))
        check_relations(None, None, self.max_modes, self.mode_of_mass)

    @classmethod
    def of(cls, options: "AnalysisOptions | None" = None, **keywords) -> "AnalysisOptions":
        """``options`` as given, or built from the keywords of :func:`dampfit.analyze`
        (``seed``, ``max_steps``, ``min_ess``, ``progress`` go to the :class:`SamplerSettings`);
        both at once is a one-line :class:`InputError`."""
        if options is not None:
            if keywords:
                raise InputError(f"give options or the keywords {', '.join(keywords)}, not both")
            if not isinstance(options, cls):
                raise InputError(f"options must be AnalysisOptions, got {options!r}")
            return options
        sampler = SamplerSettings(**{k: keywords.pop(k) for k in SAMPLER_KEYS if k in keywords})
        return cls(**keywords, sampler=sampler)

    def resolved(self, campaign: bool = False) -> "AnalysisOptions":
        """These options with ``max_modes`` set: the given one, else the default of one
        recording or of a campaign's tests."""
        if self.max_modes is not None:
            return self
        return replace(self, max_modes=CAMPAIGN_MAX_MODES if campaign else ANALYSIS_MAX_MODES)

    @property
    def seed(self) -> int:
        return self.sampler.seed

    def to_dict(self, campaign: bool = False, reading: dict | None = None) -> dict[str, Any]:
        """The plain-data form summary.json records as ``options``, with the recording's
        ``reading`` options (:attr:`~dampfit.io.recording.Recording.read_options`): one
        recording's, or a campaign's (no model, amplitude or mode of mass; ``max_modes``
        last and only above 1)."""
        opts = self.resolved(campaign)
        out: dict[str, Any] = {"axis": opts.axis, "window": _plain(opts.window),
                               "band": _plain(opts.band), "max_steps": opts.sampler.max_steps,
                               "min_ess": opts.sampler.min_ess}
        if not campaign:
            out.update(model=opts.model, amplitude=opts.amplitude, max_modes=opts.max_modes,
                       mode_of_mass=opts.mode_of_mass)
        out.update(reading or {})
        if campaign and opts.max_modes > 1:  # absent for one mode: one-mode summaries unchanged
            out["max_modes"] = opts.max_modes
        return out

    def to_keywords(self) -> dict[str, Any]:
        """The keywords of :func:`dampfit.analyze` that rebuild these options (``progress``
        aside; ``min_ess`` only when not the default): what a batch passes to, and keys,
        every recording's analysis (:mod:`dampfit.batch`)."""
        opts, s = self.resolved(), self.sampler
        out = {"axis": opts.axis, "window": opts.window, "band": opts.band, "seed": s.seed,
               "max_steps": s.max_steps, "model": opts.model, "amplitude": opts.amplitude,
               "max_modes": opts.max_modes, "mode_of_mass": opts.mode_of_mass}
        if s.min_ess != DEFAULT_MIN_ESS:  # absent by default: earlier batches' keys unchanged
            out["min_ess"] = s.min_ess
        return out

    @classmethod
    def from_dict(cls, options: dict[str, Any], seed: int = DEFAULT_SEED,
                  progress: bool = False) -> "AnalysisOptions":
        """The options of the run whose summary.json recorded ``options`` (and ``seed``):
        ``to_dict`` read back (reading options and unknown keys ignored)."""
        known = ("axis", "window", "band", "model", "amplitude", "max_modes", "mode_of_mass")
        given = {k: options[k] for k in known if options.get(k) is not None}
        return cls(**given, sampler=SamplerSettings(
            seed=seed, max_steps=options.get("max_steps", DEFAULT_MAX_STEPS),
            min_ess=options.get("min_ess", DEFAULT_MIN_ESS), progress=progress))


def _plain(value):
    """A window or band as summary.json records it: lists (per recording: a list of them)."""
    if value is None:
        return None
    return [None if v is None else list(v) if isinstance(v, tuple) else v for v in value]
