"""The study configuration (TOML): validation, scenarios, tasks and their seeds.

Three modules: :mod:`~dampfit.study.config.study` (the file, ``[study]``, ``[grid]``,
``[fixed]``, scenarios and tasks), :mod:`~dampfit.study.config.fields` (the simulator fields)
and :mod:`~dampfit.study.config.campaign` (the ``[campaign]`` table of a campaign study).


A study file has three tables (and an optional fourth, ``[campaign]``, below)::

    [study]
    name = "ranking"            # title of the summary (optional; default: the file's stem)
    replicates = 40             # simulated recordings per scenario (≥ 1)
    seed = 0                    # study seed (≥ 0)
    estimators = ["bayes", "least_squares", "log_decrement"]   # see dampfit.study.registry
    mass = 5.3                  # [kg]; known exactly to the estimators. Omit it to study ζ (no c)
    max_replicates = { bayes = 5 }   # optional: an expensive estimator on the first 5 only
    max_modes = 3               # optional: largest K the several-mode estimators try (default 3)

    [grid]                      # lists; the scenarios are their cartesian product
    f_n = [2.0]                 # natural frequency [Hz]
    zeta = [0.002, 0.01]        # damping ratio [1]
    duration = [30, 60]         # and any other field of dampfit.simulate.SimulationConfig

    [fixed]                     # single values shared by every scenario
    noise_density = 150         # [µg/√Hz]
    modes = [[8.91, 0.012, 0.25, 0.5]]   # optional extra modes [f_n Hz, zeta, amplitude ratio, phase rad]

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
    # max_steps = N             # sampler bounds of analyze_campaign (default: its own,
    # min_ess = N               # dampfit._options.DEFAULT_MAX_STEPS and DEFAULT_MIN_ESS)

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

Several modes: ``modes`` adds extra modes to the simulated decay besides the mass's (f_n, zeta)
one (:mod:`dampfit.study.config.fields`; in [grid] a list of such lists, ``[]`` the one-mode
scenario, whose id is that of a study without the field). Every run then gives one row per
estimator and true mode (:mod:`dampfit.study.task`); the several-mode estimators
(``modes_bayes``, ``modes_least_squares``, ``modes_pencil``, :mod:`dampfit.study.modal`) try
K = 1 … ``max_modes``; the ranking compares ζ (c is the mass's mode's only). A campaign study
has no extra modes.

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

from dampfit.study.config.campaign import CAMPAIGN_AXES as CAMPAIGN_AXES
from dampfit.study.config.campaign import CAMPAIGN_KEYS as CAMPAIGN_KEYS
from dampfit.study.config.fields import FIELDS as FIELDS
from dampfit.study.config.study import MAX_RUNS as MAX_RUNS
from dampfit.study.config.study import StudyConfig as StudyConfig
from dampfit.study.config.study import Task as Task
from dampfit.study.config.study import load as load
from dampfit.study.config.study import parse as parse
from dampfit.study.config.study import run_seed as run_seed
from dampfit.study.config.study import scenario_id as scenario_id
from dampfit.study.config.study import sim_config as sim_config

