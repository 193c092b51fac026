"""The study configuration (TOML): validation, scenarios, tasks and their seeds.

A study file has three tables (and an optional fourth, ``[campaign]``, below)::

    [study]
    name = "ranking"            # title of the summary (optional; default: the file's stem)
    replicates = 40             # simulated recordings per scenario (≥ 1)
    seed = 0                    # study seed (≥ 0)
    estimators = ["bayes", "least_squares", "log_decrement"]   # see dampfit.estimators.registry
    mass = 5.3                  # [kg]; known exactly to the estimators. Omit it to study ζ (no c)
    max_replicates = { bayes = 5 }   # optional: an expensive estimator on the first 5 only

    [grid]                      # lists; the scenarios are their cartesian product
    f_n = [2.0]                 # natural frequency [Hz]
    zeta = [0.002, 0.01]        # damping ratio [1]
    duration = [30, 60]         # and any other field of dampfit.simulate.SimulationConfig

    [fixed]                     # single values shared by every scenario
    noise_density = 150         # [µg/√Hz]

A fourth, optional table makes it a *campaign study*: each run simulates a test campaign
(several recordings of one damper, :func:`dampfit.simulate.campaign`) and analyses it jointly
(:func:`dampfit.campaign.analyze_campaign`) instead of running single-recording estimators;
the tables then hold the coverage of its intervals (:mod:`dampfit.study.campaign`)::

    [campaign]
    tests = 4                   # recordings per campaign, 2 … 100 (may be a [grid] axis)
    c_spread = 0.1              # between-test sd of ln c [1], 0 … 2 (default 0; may be an axis)
    added_mass_fraction = 1.0   # added masses 0 … 1.0·m0 evenly over the tests (may be an axis)
    # added_mass = [0, 0.5, 1, 1.5]   # or one added mass per test [kg]
    # amplitudes = [0.02, 0.04, 0.06, 0.08]   # release displacement u0 of each test [m]
    added_mass_sd = 0.002       # sd [kg] of the added masses given to the analysis (default 0)
    # mass_sd = 0.05            # sd [kg] of the [study] mass given to it (no added masses)
    max_steps = 20000           # sampler bounds of analyze_campaign (its defaults)
    min_ess = 1000

A campaign study has no ``estimators`` or ``max_replicates`` in [study] (its one "estimator"
is ``campaign``, the joint analysis). Without added masses the analysis gets ``[study] mass``
(sd ``mass_sd``; without a mass it reports ζ, not c); with added masses (``added_mass`` or
``added_mass_fraction``, not both) ``[study] mass`` is the simulated bare mass m₀ (default
5.3 kg) that the analysis estimates. ``tests``, ``c_spread`` and ``added_mass_fraction``
are single values in [campaign] or lists in [grid], like simulator fields in [fixed] and
[grid]; per-test lists (``added_mass``, ``amplitudes``) fix ``tests`` (their length) and
cannot be combined with a ``tests`` axis, nor ``amplitudes`` with ``u0``. Besides the run
limit, the recordings simulated (runs × tests) are at most :data:`MAX_RUNS`.

Allowed fields in ``[grid]`` and ``[fixed]``: ``f_n`` [Hz] and ``zeta`` [1] (both required,
the simulator's k and c follow from them and the mass, see
:func:`dampfit.simulate.from_modal`) and the :class:`~dampfit.simulate.SimulationConfig`
options except ``mass`` (set in ``[study]``), ``k``, ``c`` and ``seed`` (set per run). Fields
not given keep the simulator's defaults (60 s at 500 Hz, 150 µg/√Hz, u0 = 4 cm, no drift…).

Size: a study may have at most :data:`MAX_RUNS` = 100,000 runs (scenarios × replicates).
The count is the product of the [grid] list lengths times ``replicates``, computed before any
scenario is built, so a grid of 10¹⁰ scenarios is refused at once (one error line saying how
many runs it would be) instead of hanging. At ≈ 900 cheap fits per minute and core, 100,000
runs are already a day on a workstation; larger studies should be split (e.g. by estimator or
by a grid axis) into separate study files.

Determinism: a scenario's id is a hash of its canonical parameters (numbers normalised to
float, keys sorted), and the seed of a run is drawn from
``numpy.random.SeedSequence(study_seed, spawn_key=(scenario hash, replicate))``. A run
therefore gets the same numbers on any worker, in any order, whatever else is in the grid.
Everything here is pure and cheap (no simulation, no estimator imports).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import stat
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.errors import InputError

__all__ = ["CAMPAIGN_AXES", "CAMPAIGN_KEYS", "FIELDS", "MAX_RUNS", "StudyConfig", "Task", "load",
           "parse"]

#: Simulator fields a study may set, with their kind: float, int, bool, str or bias.
FIELDS: dict[str, str] = {
    "f_n": "float", "zeta": "float", "u0": "float", "duration": "float", "sample_rate": "float",
    "jitter": "float", "timestamp_jitter": "float", "gaps": "int", "noise_density": "float", "bias": "bias", "drift": "float",
    "quantization": "float", "tilt_deg": "float", "azimuth_deg": "float", "main_axis": "str",
    "gravity": "bool", "handheld": "float", "catch": "bool",
}
_SET_ELSEWHERE = {"mass": "set it as [study] mass", "k": "give f_n and the mass instead",
                  "c": "give zeta instead", "seed": "each run's seed is derived from [study] seed"}
_STUDY_KEYS = {"name", "replicates", "seed", "estimators", "mass", "max_replicates"}
_DEFAULT_MASS = 5.3  # [kg] simulated mass when [study] mass is omitted (the seed paper's)
#: Most runs (scenarios × replicates) one study may have; see the module docstring.
MAX_RUNS = 100_000
#: [campaign] settings that may also be [grid] axes (scenario fields), with their kind.
CAMPAIGN_AXES: dict[str, str] = {"tests": "int", "c_spread": "float", "added_mass_fraction": "float"}
#: Per-test lists of [campaign] (scenario fields, one value per test).
CAMPAIGN_LISTS = ("added_mass", "amplitudes")
#: Settings of the joint analysis (not scenario fields), with their defaults.
CAMPAIGN_SETTINGS: dict[str, Any] = {"mass_sd": 0.0, "added_mass_sd": 0.0, "max_steps": 20000,
                                     "min_ess": 1000.0}
#: Every key a [campaign] table may hold.
CAMPAIGN_KEYS = (*CAMPAIGN_AXES, *CAMPAIGN_LISTS, *CAMPAIGN_SETTINGS)
#: Largest added_mass_fraction [1] (added masses up to 100 × the bare mass).
MAX_ADDED_FRACTION = 100.0
#: Bounds of the campaign sampler's max_steps [steps] and min_ess [draws].
MIN_STEPS, MAX_STEPS, MAX_MIN_ESS = 100, 1_000_000, 1e6
#: Largest study file [bytes] read (a real one is a few hundred bytes).
MAX_CONFIG_BYTES = 1 << 20
#: Longest [study] name [characters]; it must be one printable line (it titles summary.md).
MAX_NAME = 200


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
    def target(self) -> str:
        """The quantity the ranking is about: ``"c"`` with a mass (or added masses), else
        ``"zeta"``."""
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
                                self.sim_mass, self.mass_known, self.settings()))
        return out

    def fingerprint(self) -> str:
        """Hash of what determines the runs' numbers: seed, estimators, mass and the set of
        scenarios (not their order, nor name, replicates or max_replicates, which only add or
        drop runs), and a campaign study's analysis settings. A stored study with another
        fingerprint is not resumed with this one."""
        core = {"seed": self.seed, "estimators": list(self.estimators), "mass": self.mass,
                "scenarios": sorted(sid for sid, _ in self.scenarios())}
        if self.campaign is not None:  # (absent otherwise: older studies keep their fingerprint)
            core["campaign"] = self.settings()
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
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"study file {path} is not a regular file")
        if st.st_size > MAX_CONFIG_BYTES:
            raise InputError(f"study file {path} is {st.st_size / 2**20:.1f} MiB, more than the "
                             f"limit of {MAX_CONFIG_BYTES // 2**10} KiB for a study configuration")
        with open(path, "rb") as fh:
            text = fh.read(MAX_CONFIG_BYTES + 1).decode("utf-8")
    except FileNotFoundError:
        raise InputError(f"study file {path} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise InputError(f"cannot read study file {path}: {reason}") from None
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
    from dampfit.simulate import MAX_MASS  # the limit of 'analyze --mass'

    if mass is not None and (isinstance(mass, bool) or not isinstance(mass, (int, float))
                             or not math.isfinite(mass) or mass <= 0 or mass > MAX_MASS):
        raise InputError(f"[study] mass must be a positive number of kilograms (at most "
                         f"{MAX_MASS:g}), got {mass!r}")
    max_rep = _max_replicates(study.get("max_replicates", {}), estimators)

    if not grid:
        raise InputError("[grid] is empty; give at least one field as a list, e.g. zeta = [0.01]")
    norm_grid: dict[str, list] = {}
    for key, values in grid.items():
        axis = key in CAMPAIGN_AXES
        if key in CAMPAIGN_KEYS and not axis:
            raise InputError(f"[grid] {key} cannot be a [grid] axis; set it in [campaign] "
                             f"(axes: {', '.join(CAMPAIGN_AXES)})")
        if not axis:
            _check_field(key, "grid")
        if not isinstance(values, list):
            home = "[campaign]" if axis else "[fixed]"
            raise InputError(f"[grid] {key} must be a list of values, e.g. {key} = [{values!r}]; "
                             f"put single values in {home}")
        if not values:
            raise InputError(f"[grid] {key} is an empty list; give at least one value")
        norm = [_campaign_value(key, v, "grid") if axis else _value(key, v, "grid") for v in values]
        if len({_canonical(v) for v in norm}) != len(norm):
            raise InputError(f"[grid] {key} lists a value twice")
        norm_grid[key] = norm
    norm_fixed = {}
    for key, value in fixed.items():
        if key in CAMPAIGN_KEYS:
            raise InputError(f"[fixed] {key} is a campaign setting; put it in [campaign]")
        _check_field(key, "fixed")
        if key in norm_grid:
            raise InputError(f"{key} is in both [grid] and [fixed]; keep one")
        norm_fixed[key] = _value(key, value, "fixed")
    for key in ("f_n", "zeta"):
        if key not in norm_grid and key not in norm_fixed:
            raise InputError(f"{key} is missing; give it in [grid] (a list) or [fixed]")

    mass = None if mass is None else float(mass)
    norm_campaign = _campaign(campaign, norm_grid, norm_fixed, mass) if is_campaign else None
    cfg = StudyConfig(name.strip(), replicates, seed, estimators, mass, max_rep, norm_grid,
                      norm_fixed, source, norm_campaign)
    _check_size(cfg)
    _check_scenarios(cfg)
    return cfg


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


def _check_field(key: str, table: str) -> None:
    if key in _SET_ELSEWHERE:
        raise InputError(f"[{table}] {key} cannot be set here: {_SET_ELSEWHERE[key]}")
    if key not in FIELDS:
        raise InputError(f"unknown field [{table}] {key}; known: {', '.join(sorted(FIELDS))}")


def _value(key: str, value: Any, table: str) -> Any:
    """A field value normalised to its kind (so 2 and 2.0 give the same scenario id)."""
    kind = FIELDS[key]
    where = f"[{table}] {key}"
    if kind == "bool":
        if not isinstance(value, bool):
            raise InputError(f"{where} must be true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise InputError(f"{where} must be a string, got {value!r}")
        return value
    if kind == "bias" and isinstance(value, list):
        return [_number(where, v) for v in value]
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{where} must be an integer, got {value!r}")
        return value
    return _number(where, value)


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{where} must be a finite number, got {value!r}")
    return float(value)


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
    the bare system; :func:`dampfit.simulate.campaign` varies mass, c and u0 per test)."""
    from dampfit import simulate as sim

    fields = {k: v for k, v in params.items() if k not in CAMPAIGN_KEYS}  # a campaign's design
    f_n, zeta = fields.pop("f_n"), fields.pop("zeta")
    if isinstance(fields.get("bias"), list):
        fields["bias"] = tuple(fields["bias"])
    return sim.from_modal(mass, f_n, zeta, seed=seed, **fields)


# -- the [campaign] table ----------------------------------------------------------------------


def _campaign_value(key: str, value: Any, table: str) -> Any:
    """A campaign axis value (:data:`CAMPAIGN_AXES`) checked against the simulator's limits."""
    from dampfit.simulate import MAX_C_SPREAD, MAX_TESTS

    where = f"[{table}] {key}"
    if key == "tests":
        if isinstance(value, bool) or not isinstance(value, int) or not 2 <= value <= MAX_TESTS:
            raise InputError(f"{where} must be an integer from 2 to {MAX_TESTS} (recordings per "
                             f"campaign), got {value!r}")
        return value
    x = _number(where, value)
    if key == "c_spread" and not 0 <= x <= MAX_C_SPREAD:
        raise InputError(f"{where} must be in [0, {MAX_C_SPREAD:g}] (the between-test sd of "
                         f"ln c), got {value!r}")
    if key == "added_mass_fraction" and not 0 < x <= MAX_ADDED_FRACTION:
        raise InputError(f"{where} must be in (0, {MAX_ADDED_FRACTION:g}] (the largest added "
                         f"mass as a fraction of the mass), got {value!r}")
    return x


def _per_test_list(key: str, value: Any, lo: float, hi: float, unit: str) -> list[float]:
    """A per-test list of [campaign] (:data:`CAMPAIGN_LISTS`): numbers in [lo, hi] [unit]."""
    from dampfit.simulate import MAX_TESTS

    where = f"[campaign] {key}"
    if not isinstance(value, list) or not value:
        raise InputError(f"{where} must be a list of numbers [{unit}], one per test")
    if len(value) > MAX_TESTS:
        raise InputError(f"{where} gives {len(value)} values; a campaign has at most "
                         f"{MAX_TESTS} tests")
    out = [_number(where, v) for v in value]
    bad = [v for v in out if not lo <= v <= hi]
    if bad:
        raise InputError(f"{where} values must be in [{lo:g}, {hi:g}] {unit}, got {bad[0]:g}")
    return out


def _setting(table: dict, key: str) -> Any:
    """An analysis setting of [campaign] (:data:`CAMPAIGN_SETTINGS`), checked, or its default."""
    from dampfit.simulate import MAX_MASS

    if key not in table:
        return CAMPAIGN_SETTINGS[key]
    value, where = table[key], f"[campaign] {key}"
    if key == "max_steps":
        if isinstance(value, bool) or not isinstance(value, int) or \
                not MIN_STEPS <= value <= MAX_STEPS:
            raise InputError(f"{where} must be an integer from {MIN_STEPS} to {MAX_STEPS:,}, "
                             f"got {value!r}")
        return value
    x = _number(where, value)
    if key == "min_ess" and not 1 <= x <= MAX_MIN_ESS:
        raise InputError(f"{where} must be a number from 1 to {MAX_MIN_ESS:g}, got {value!r}")
    if key in ("mass_sd", "added_mass_sd") and not 0 <= x <= MAX_MASS:
        raise InputError(f"{where} must be a number of kilograms in [0, {MAX_MASS:g}], "
                         f"got {value!r}")
    return x


def _campaign(table: dict, grid: dict, fixed: dict, mass: float | None) -> dict[str, Any]:
    """The validated [campaign] table: design constants (scenario fields) and every analysis
    setting (see the module docstring); one :class:`InputError` line otherwise."""
    from dampfit.simulate import MAX_MASS, MAX_U0

    bad = sorted(set(table) - set(CAMPAIGN_KEYS))
    if bad:
        raise InputError(f"unknown key [campaign] {bad[0]}; known: {', '.join(CAMPAIGN_KEYS)}")
    both = [k for k in CAMPAIGN_AXES if k in table and k in grid]
    if both:
        raise InputError(f"{both[0]} is in both [grid] and [campaign]; keep one")
    out: dict[str, Any] = {k: _campaign_value(k, table[k], "campaign")
                           for k in CAMPAIGN_AXES if k in table}
    limits = {"added_mass": (0.0, MAX_MASS, "kg"), "amplitudes": (0.0, MAX_U0, "m")}
    for key in CAMPAIGN_LISTS:
        if key in table:
            out[key] = _per_test_list(key, table[key], *limits[key])
    lists = [k for k in CAMPAIGN_LISTS if k in out]
    if lists and "tests" in grid:
        raise InputError(f"[campaign] {lists[0]} gives one value per test, so tests cannot be a "
                         "[grid] axis" + (" (use added_mass_fraction for added masses that follow "
                                          "the number of tests)" if lists[0] == "added_mass" else ""))
    if "tests" not in out and "tests" not in grid:
        if not lists:
            raise InputError("tests is missing; give [campaign] tests (recordings per campaign, "
                             "e.g. tests = 4) or a [grid] tests list")
        if len(out[lists[0]]) < 2:
            raise InputError(f"[campaign] {lists[0]} gives 1 value: a campaign needs at least "
                             "2 tests")
        out["tests"] = len(out[lists[0]])
    for key in lists:
        if len(out[key]) != out["tests"]:
            raise InputError(f"[campaign] {key} gives {len(out[key])} value(s) for "
                             f"{out['tests']} tests; give one per test")
    if "c_spread" not in out and "c_spread" not in grid:
        out["c_spread"] = 0.0
    added = "added_mass" in out or "added_mass_fraction" in out or "added_mass_fraction" in grid
    if "added_mass" in out and ("added_mass_fraction" in out or "added_mass_fraction" in grid):
        raise InputError("give [campaign] added_mass (one mass per test [kg]) or "
                         "added_mass_fraction, not both")
    if "added_mass" in out and len(set(out["added_mass"])) < 2:
        raise InputError("[campaign] added_mass needs at least 2 different masses: the "
                         "added-mass method cannot identify the mass otherwise")
    if "amplitudes" in out and ("u0" in grid or "u0" in fixed):
        raise InputError("u0 is set in [grid] or [fixed] and [campaign] amplitudes sets each "
                         "test's u0; keep one")
    settings = {k: _setting(table, k) for k in CAMPAIGN_SETTINGS}
    if "mass_sd" in table and (added or mass is None):
        why = ("the added-mass design estimates the mass itself" if added
               else "it is the sd of [study] mass, which is not given")
        raise InputError(f"[campaign] mass_sd cannot be used: {why}")
    if "added_mass_sd" in table and not added:
        raise InputError("[campaign] added_mass_sd needs added masses (added_mass or "
                         "added_mass_fraction)")
    if mass is not None and settings["mass_sd"] > 0.5 * mass:
        raise InputError(f"[campaign] mass_sd {settings['mass_sd']:g} kg is more than half the "
                         f"mass {mass:g} kg")
    return {**out, **settings}
