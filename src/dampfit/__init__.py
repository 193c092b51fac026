"""dampfit: the viscous damping coefficient c [N·s/m], stiffness k [N/m] and initial amplitude
u0 [m] of a single-degree-of-freedom oscillator from a free-decay accelerometer recording,
with a Bayesian posterior and the seed paper's classical estimators beside it.

Typical use::

    import dampfit
    rec = dampfit.read("Raw Data.csv")
    result = dampfit.analyze(rec, mass=5.3, mass_sd=0.02, seed=1)
    result.summary()["parameters"]["c"]      # posterior summary of c [N·s/m]
    result.posterior                         # arviz InferenceData
    result.to_json("summary.json")
    again = dampfit.load("Raw Data.csv.dampfit")   # a result folder read back: same class

    rec, truth = dampfit.simulate.recording(dampfit.simulate.preset("paper"))
"""

from importlib import import_module as _import_module
from importlib import metadata as _metadata

from dampfit.errors import DampfitError as DampfitError
from dampfit.errors import InputError as InputError

try:
    __version__ = _metadata.version("dampfit")
except _metadata.PackageNotFoundError:  # pragma: no cover - source tree without install
    __version__ = "unknown"

#: Public names and the module each comes from. They are imported on first use (PEP 562), so
#: ``import dampfit`` — and every CLI command that needs no analysis, such as ``dampfit report``
#: or ``dampfit --help`` — does not pay for JAX, SciPy and arviz.
_LAZY = {
    "Analysis": ("dampfit.pipeline", "Analysis"),
    "analyze": ("dampfit.pipeline", "analyze"),
    "load": ("dampfit.result", "load"),
    "read": ("dampfit.io.readers", "read"),
    "Recording": ("dampfit.io.recording", "Recording"),
    "crlb": ("dampfit.inference.crlb", None),
    "estimators": ("dampfit.estimators", None),
    "simulate": ("dampfit.simulate", None),
}


def __getattr__(name: str):
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'dampfit' has no attribute {name!r}") from None
    value = _import_module(module)
    if attr is not None:
        value = getattr(value, attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "Analysis", "DampfitError", "InputError", "Recording", "__version__", "analyze", "load",
    "read", "crlb", "estimators", "simulate",
]
