"""The study file itself: ``[study]``, ``[grid]`` and ``[fixed]`` validated into a
:class:`StudyConfig`, its scenarios, tasks and their seeds (the layout, limits and determinism
are described in :mod:`dampfit.study.config`; the ``[campaign]`` table in
:mod:`dampfit.study.config.campaign`, the simulator fields in :mod:`dampfit.study.config.fields`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import InputError
from dampfit.study.config.campaign import (CAMPAIGN_AXES, CAMPAIGN_KEYS, CAMPAIGN_SETTINGS,
                                           campaign_table, campaign_value)
from dampfit.study.config.fields import check_field, field_value

_STUDY_KEYS = {"name", "replicates", "seed", "estimators", "mass", "max_replicates", "max_modes"}
_DEFAULT_MASS = 5.3  # [kg] simulated mass when [study] mass is omitted (the seed paper's)
#: Largest number of modes the several-mode estimators try when [study] max_modes is omitted.
DEFAULT_MAX_MODES = 3
#: Most runs (scenarios × replicates) one study may have; see the module docstring.
MAX_RUNS = 100_000
#: Largest study file [bytes] read (a real one is a few hundred bytes).
MAX_CONFIG_BYTES = 1 << 20
#: Longest [study] name [characters]; it must be one printable line (it titles summary.md).
MAX_NAME = 200
#: Names of the several-mode estimators (:mod:`dampfit.study.modal`) start with this.
MODE_ESTIMATOR_PREFIX = "modes_"


@dataclass(frozen=True)
class Task:
    """One unit of work: simulate scenario ``scenario`` once (replicate ``replicate``) and run
    ``estimators`` on that recording. ``params`` are the simulator fields; ``mass`` [kg] is
    simulated and, if ``mass_known``, given to the estimators. With ``campaign`` the run
    simulates a campaign (``params`` then hold its design too) and analyses it jointly."""

    scenario: str
    replicate: int
    seed: int
    params: dict[str, Any]
    estimators: tuple[str, ...]
    mass: float
    mass_known: bool
    #: a campaign study's analysis settings (:data:`CAMPAIGN_SETTINGS`), else None
    campaign: dict[str, Any] | None = None
    #: the largest K the several-mode estimators (:mod:`dampfit.study.modal`) try
    max_modes: int = DEFAULT_MAX_MODES

    @property
    def key(self) -> tuple[str, int]:
        return (self.scenario, self.replicate)


@dataclass(frozen=True)
class StudyConfig:
    """A validated study (see the module docstring)."""

    name: str
    replicates: int
    seed: int
    estimators: tuple[str, ...]
    mass: float | None
    max_replicates: dict[str, int]
    grid: dict[str, list]
    fixed: dict[str, Any]
    source: str = ""
    #: a campaign study: its design constants and analysis settings (validated), else None
    campaign: dict[str, Any] | None = None
    #: the largest number of modes K the several-mode estimators try ([study] max_modes)
    max_modes: int = DEFAULT_MAX_MODES

    @property
    def is_campaign(self) -> bool:
        """Whether the runs are campaigns analysed jointly (a [campaign] table)."""
        return self.campaign is not None

    @property
    def added_mass_design(self) -> bool:
        """A campaign study with added masses (the analysis estimates m₀)."""
        return self.campaign is not None and (
            "added_mass" in self.campaign or "added_mass_fraction" in self.campaign
            or "added_mass_fraction" in self.grid)

    @property
    def n_recordings(self) -> int:
        """Recordings simulated: runs × tests for a campaign study (exact: every value of a
        tests axis is in the same number of scenarios), else the runs."""
        if self.campaign is None:
            return self.n_runs
        tests = self.grid.get("tests", [self.campaign.get("tests", 1)])
        return self.n_runs // len(tests) * sum(tests)

    @property
    def n_scenarios(self) -> int:
        """Number of scenarios: the product of the grid's list lengths (nothing is built)."""
        return math.prod(len(v) for v in self.grid.values())

    @property
    def n_runs(self) -> int:
        """Number of runs (tasks): scenarios × replicates."""
        return self.n_scenarios * self.replicates

    @property
    def varying(self) -> list[str]:
        """Grid fields with more than one value (they label the scenarios)."""
        return [k for k, v in self.grid.items() if len(v) > 1]

    @property
    def sim_mass(self) -> float:
        """Simulated mass [kg]: ``mass``, or the seed paper's 5.3 kg when the study has none."""
        return self.mass if self.mass is not None else _DEFAULT_MASS

    @property
    def has_modes(self) -> bool:
        """Whether some scenario simulates extra modes (a ``modes`` field that is not empty)."""
        return bool(self.fixed.get("modes")) or any(self.grid.get("modes", []))

    @property
    def target(self) -> str:
        """The quantity the ranking is about: ``"c"`` with a mass (or added masses), else
        ``"zeta"``; ``"zeta"`` too when a scenario has several modes (c belongs to the mass's
        mode only, ζ to every mode)."""
        if self.has_modes:
            return "zeta"
        return "c" if self.mass is not None or self.added_mass_design else "zeta"

    @property
    def mass_known(self) -> bool:
        """Whether the estimators (the joint analysis) are given the mass."""
        return self.mass is not None and not self.added_mass_design

    def _design(self) -> dict[str, Any]:
        """A campaign study's design constants (scenario fields set in [campaign])."""
        if self.campaign is None:
            return {}
        return {k: v for k, v in self.campaign.items() if k not in CAMPAIGN_SETTINGS}

    def settings(self) -> dict[str, Any] | None:
        """A campaign study's analysis settings (:data:`CAMPAIGN_SETTINGS`), else None."""
        if self.campaign is None:
            return None
        return {k: self.campaign[k] for k in CAMPAIGN_SETTINGS}

    def scenarios(self) -> list[tuple[str, dict[str, Any]]]:
        """``(scenario id, parameters)`` of the cartesian product of the grid, in grid order
        (refused beyond :data:`MAX_RUNS` runs before anything is built)."""
        _check_size(self)
        keys = list(self.grid)
        out = []
        design = self._design()
        for values in itertools.product(*(self.grid[k] for k in keys)):
            params = {**self.fixed, **design, **dict(zip(keys, values))}
            if params.get("modes") == []:  # no extra mode: the one-mode scenario and its id
                del params["modes"]
            out.append((scenario_id(params), params))
        return out

    def tasks(self) -> list[Task]:
        """All tasks, replicate-major (every scenario gets its first replicates first)."""
        scen = self.scenarios()
        out = []
        for rep in range(self.replicates):
            names = tuple(e for e in self.estimators if rep < self.max_replicates.get(e, rep + 1))
            for sid, params in scen:
                out.append(Task(sid, rep, run_seed(self.seed, sid, rep), params, names,
                                self.sim_mass, self.mass_known, self.settings(), self.max_modes))
        return out

    def fingerprint(self) -> str:
        """Hash of what determines the runs' numbers: seed, estimators, mass and the set of
        scenarios (not their order, nor name, replicates or max_replicates, which only add or
        drop runs), a campaign study's analysis settings and ``max_modes`` when a several-mode
        estimator uses it. A stored study with another fingerprint is not resumed with this one."""
        core = {"seed": self.seed, "estimators": list(self.estimators), "mass": self.mass,
                "scenarios": sorted(sid for sid, _ in self.scenarios())}
        if self.campaign is not None:  # (absent otherwise: older studies keep their fingerprint)
            core["campaign"] = self.settings()
        if any(e.startswith(MODE_ESTIMATOR_PREFIX) for e in self.estimators):
            core["max_modes"] = self.max_modes
        return hashlib.sha256(_canonical(core).encode()).hexdigest()[:16]

    def as_dict(self) -> dict[str, Any]:
        """JSON-safe description (stored in study.json)."""
        d = dataclasses.asdict(self)
        d.pop("source")
        d["estimators"] = list(self.estimators)
        return d


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def scenario_id(params: dict[str, Any]) -> str:
    """Stable id of a scenario: ``s`` + 12 hex digits of the SHA-256 of its canonical parameters."""
    return "s" + hashlib.sha256(_canonical(params).encode()).hexdigest()[:12]


def run_seed(study_seed: int, scenario: str, replicate: int) -> int:
    """Seed (63 bit) of one run, a pure function of (study seed, scenario id, replicate)."""
    ss = np.random.SeedSequence(study_seed, spawn_key=(int(scenario[1:], 16), replicate))
    return int(ss.generate_state(1, dtype=np.uint64)[0]) & (2**63 - 1)


# -- loading and validation ---------------------------------------------------------------


def load(path: str | Path, available: list[str] | None = None) -> StudyConfig:
    """Read and validate the TOML study file ``path``; ``available`` estimator names."""
    path = Path(path)
    from dampfit.io.bounded import read_regular

    def refuse(message: str) -> InputError:
        if "larger than" in message:
            return InputError(f"study file {path} is more than the limit of "
                              f"{MAX_CONFIG_BYTES // 2**10} KiB for a study configuration")
        return InputError("study file " + message.replace(" is ", " is not a regular file: it is ", 1)
                          if not message.startswith("cannot") else message)

    try:
        text = read_regular(path, MAX_CONFIG_BYTES, follow_links=True, refuse=refuse,
                            missing=InputError(f"study file {path} does not exist")
                            ).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"cannot read study file {path}: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path.name} is not valid TOML: {exc}") from None
    except (RecursionError, ValueError, MemoryError):  # e.g. arrays nested 5000 deep
        raise InputError(f"{path.name} is not a usable study file: its tables or arrays are "
                         "nested too deeply") from None
    return parse(data, available, default_name=path.stem, source=text)


def parse(data: dict, available: list[str] | None = None, *, default_name: str = "study",
          source: str = "") -> StudyConfig:
    """Validate a parsed study table (see the module docstring); raise :class:`InputError`."""
    unknown = sorted(set(data) - {"study", "grid", "fixed", "campaign"})
    if unknown:
        raise InputError(f"unknown table(s) [{'], ['.join(unknown)}]; "
                         "a study has [study], [grid], [fixed] and optionally [campaign]")
    study = _table(data, "study", required=True)
    grid = _table(data, "grid", required=True)
    fixed = _table(data, "fixed", required=False)
    is_campaign = "campaign" in data
    campaign = _table(data, "campaign", required=False)
    bad = sorted(set(study) - _STUDY_KEYS)
    if bad:
        raise InputError(f"unknown key [study] {bad[0]}; known: {', '.join(sorted(_STUDY_KEYS))}")
    axes = [k for k in grid if k in CAMPAIGN_AXES]
    if axes and not is_campaign:  # before "estimators is missing": the likely slip
        raise InputError(f"[grid] {axes[0]} is a campaign setting; it needs a [campaign] table")
    if is_campaign:
        for key in ("estimators", "max_replicates"):
            if key in study:
                raise InputError(f"[study] {key} is not used by a campaign study (it runs the joint "
                                 "analysis, estimator 'campaign', on every campaign); remove it")

    name = study.get("name", default_name)
    if not isinstance(name, str) or not name.strip():
        raise InputError("[study] name must be a non-empty string")
    if not name.isprintable() or len(name) > MAX_NAME:
        raise InputError(f"[study] name must be one line of at most {MAX_NAME} printable "
                         "characters (no newlines or control characters)")
    replicates = _integer(study, "replicates", minimum=1, default=None)
    seed = _integer(study, "seed", minimum=0, default=0)
    estimators = ("campaign",) if is_campaign else _estimators(study.get("estimators"), available)
    mass = study.get("mass")
    from dampfit.physics import MAX_MASS  # the limit of 'analyze --mass'

    if mass is not None and (isinstance(mass, bool) or not isinstance(mass, (int, float))
                             or not math.isfinite(mass) or mass <= 0 or mass > MAX_MASS):
        raise InputError(f"[study] mass must be a positive number of kilograms (at most "
                         f"{MAX_MASS:g}), got {mass!r}")
    max_rep = _max_replicates(study.get("max_replicates", {}), estimators)
    max_modes = _max_modes(study, estimators)

    norm_grid = _grid(grid)
    norm_fixed = _fixed(fixed, norm_grid)
    for key in ("f_n", "zeta"):
        if key not in norm_grid and key not in norm_fixed:
            raise InputError(f"{key} is missing; give it in [grid] (a list) or [fixed]")

    mass = None if mass is None else float(mass)
    if is_campaign and ("modes" in norm_grid or "modes" in norm_fixed):
        raise InputError("modes (extra modes) cannot be simulated in a campaign study; remove it")
    norm_campaign = campaign_table(campaign, norm_grid, norm_fixed, mass) if is_campaign else None
    cfg = StudyConfig(name.strip(), replicates, seed, estimators, mass, max_rep, norm_grid,
                      norm_fixed, source, norm_campaign, max_modes)
    _check_size(cfg)
    _check_scenarios(cfg)
    return cfg


def _grid(grid: dict) -> dict[str, list]:
    """The [grid] table checked and normalised: every key a simulation field or a campaign
    axis, every value a non-empty list of distinct valid values."""
    if not grid:
        raise InputError("[grid] is empty; give at least one field as a list, e.g. zeta = [0.01]")
    norm_grid: dict[str, list] = {}
    for key, values in grid.items():
        axis = key in CAMPAIGN_AXES
        if key in CAMPAIGN_KEYS and not axis:
            raise InputError(f"[grid] {key} cannot be a [grid] axis; set it in [campaign] "
                             f"(axes: {', '.join(CAMPAIGN_AXES)})")
        if not axis:
            check_field(key, "grid")
        if not isinstance(values, list):
            home = "[campaign]" if axis else "[fixed]"
            raise InputError(f"[grid] {key} must be a list of values, e.g. {key} = [{values!r}]; "
                             f"put single values in {home}")
        if not values:
            raise InputError(f"[grid] {key} is an empty list; give at least one value")
        norm = [campaign_value(key, v, "grid") if axis else field_value(key, v, "grid") for v in values]
        if len({_canonical(v) for v in norm}) != len(norm):
            raise InputError(f"[grid] {key} lists a value twice")
        norm_grid[key] = norm
    return norm_grid


def _fixed(fixed: dict, norm_grid: dict[str, list]) -> dict[str, Any]:
    """The [fixed] table checked and normalised: simulation fields only, none also in [grid]."""
    norm_fixed = {}
    for key, value in fixed.items():
        if key in CAMPAIGN_KEYS:
            raise InputError(f"[fixed] {key} is a campaign setting; put it in [campaign]")
        check_field(key, "fixed")
        if key in norm_grid:
            raise InputError(f"{key} is in both [grid] and [fixed]; keep one")
        norm_fixed[key] = field_value(key, value, "fixed")
    return norm_fixed


def _table(data: dict, name: str, required: bool) -> dict:
    table = data.get(name)
    if table is None:
        if required:
            raise InputError(f"the study file has no [{name}] table")
        return {}
    if not isinstance(table, dict):
        raise InputError(f"{name} must be a table ([{name}])")
    return table


def _integer(study: dict, key: str, minimum: int, default: int | None) -> int:
    value = study.get(key, default)
    if value is None:
        raise InputError(f"[study] {key} is missing; give an integer ≥ {minimum}")
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise InputError(f"[study] {key} must be an integer ≥ {minimum}, got {value!r}")
    return value


def _estimators(value: Any, available: list[str] | None) -> tuple[str, ...]:
    hint = f" (available: {', '.join(available)})" if available else ""
    if value is None:
        raise InputError(f"[study] estimators is missing; give a list of names{hint}")
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise InputError(f"[study] estimators must be a non-empty list of names{hint}")
    if len(set(value)) != len(value):
        raise InputError("[study] estimators lists a name twice")
    if available is not None:
        unknown = [v for v in value if v not in available]
        if unknown:
            raise InputError(f"[study] estimators: unknown estimator {unknown[0]!r}{hint}")
    return tuple(value)


def _max_replicates(value: Any, estimators: tuple[str, ...]) -> dict[str, int]:
    if not isinstance(value, dict):
        raise InputError("[study] max_replicates must be a table, e.g. max_replicates = { bayes = 5 }")
    for name, n in value.items():
        if name not in estimators:
            raise InputError(f"[study] max_replicates names {name!r}, which is not in [study] estimators")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise InputError(f"[study] max_replicates.{name} must be an integer ≥ 1, got {n!r}")
    return dict(value)


def _max_modes(study: dict, estimators: tuple[str, ...]) -> int:
    """[study] max_modes: an integer from 1 to the modes analysis' limit, only with a several-mode
    estimator (``modes_…``) that uses it; :data:`DEFAULT_MAX_MODES` when omitted."""
    if "max_modes" not in study:
        return DEFAULT_MAX_MODES
    if not any(e.startswith(MODE_ESTIMATOR_PREFIX) for e in estimators):
        raise InputError("[study] max_modes is used only by the several-mode estimators "
                         "(modes_bayes, modes_least_squares, modes_pencil); remove it or add one")
    from dampfit.inference.modes import MAX_MODES_LIMIT

    value = study["max_modes"]
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_MODES_LIMIT:
        raise InputError(f"[study] max_modes must be an integer from 1 to {MAX_MODES_LIMIT}, "
                         f"got {value!r}")
    return value


def _check_size(cfg: StudyConfig) -> None:
    """Refuse a study of more than :data:`MAX_RUNS` runs (or, for a campaign study, simulated
    recordings), from the list lengths alone."""
    n = cfg.n_runs
    if n > MAX_RUNS:
        raise InputError(f"the study would be {n:,} runs ({cfg.n_scenarios:,} scenarios × "
                         f"{cfg.replicates:,} replicates), more than the limit of {MAX_RUNS:,}; "
                         "shorten the [grid] lists or replicates, or split the study")
    if cfg.is_campaign and cfg.n_recordings > MAX_RUNS:
        raise InputError(f"the campaign study would simulate {cfg.n_recordings:,} recordings "
                         f"({n:,} campaigns of their tests), more than the limit of {MAX_RUNS:,}; "
                         "lower tests, the [grid] lists or replicates, or split the study")


def _check_scenarios(cfg: StudyConfig) -> None:
    """Build every scenario's simulator configuration once, so bad values fail before any work."""
    from dampfit import simulate as sim

    from dampfit.study import campaign

    for sid, params in cfg.scenarios():
        try:
            base = sim_config(params, cfg.sim_mass, seed=0)
            sim.check_limits(base)
            if cfg.is_campaign:
                campaign.check_scenario(base, params)
        except InputError as exc:
            label = ", ".join(f"{k}={params[k]}" for k in cfg.varying) or "the fixed scenario"
            raise InputError(f"scenario {label}: {exc}") from None


def sim_config(params: dict[str, Any], mass: float, seed: int):
    """The :class:`~dampfit.simulate.SimulationConfig` of one run (of a campaign: its base,
    the bare system; :func:`dampfit.simulate.campaign` varies mass, c and u0 per test); a
    ``modes`` field becomes the simulator's extra modes."""
    from dampfit import simulate as sim

    fields = {k: v for k, v in params.items() if k not in CAMPAIGN_KEYS}  # a campaign's design
    f_n, zeta = fields.pop("f_n"), fields.pop("zeta")
    if isinstance(fields.get("bias"), list):
        fields["bias"] = tuple(fields["bias"])
    return sim.from_modal(mass, f_n, zeta, seed=seed, **fields)


# -- the [campaign] table ----------------------------------------------------------------------


