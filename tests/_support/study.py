"""Study configurations for the ``dampfit study`` tests: the estimators available, a small fast
study file, and a base table with ``table__key=value`` overrides."""

from __future__ import annotations

from dampfit.study import modal, registry

AVAILABLE = list(registry.ESTIMATORS) + list(modal.MODE_ESTIMATORS)

# A small, fast study: 4 scenarios x 4 replicates x 3 cheap estimators on 8 s records.
SMALL = """
[study]
name = "tiny"
replicates = 4
seed = 7
estimators = ["log_decrement", "hilbert", "matrix_pencil"]
mass = 0.5

[grid]
zeta = [0.01, 0.03]
jitter = [0, 0.02]

[fixed]
f_n = 3.0
duration = 8
sample_rate = 60
noise_density = 300
"""


def with_overrides(d: dict, over: dict) -> dict:
    """``d`` (a study table) with ``table__key=value`` overrides; ``_DELETE`` removes a key."""
    for dotted, value in over.items():
        table, key = dotted.split("__")
        if value is _DELETE:
            d[table].pop(key, None)
        else:
            d.setdefault(table, {})[key] = value
    return d


def base(**over) -> dict:
    return with_overrides({"study": {"replicates": 2, "estimators": ["hilbert"], "mass": 1.0},
                           "grid": {"zeta": [0.01]}, "fixed": {"f_n": 2.0, "duration": 10.0}},
                          over)


_DELETE = object()

