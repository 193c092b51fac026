"""dampfit: the viscous damping coefficient c [N·s/m], stiffness k [N/m] and initial amplitude
u0 [m] of a single-degree-of-freedom oscillator from a free-decay accelerometer recording,
with a Bayesian posterior and the seed paper's classical estimators beside it.

Typical use::

    import dampfit
    rec = dampfit.read("Raw Data.csv")
    result = dampfit.analyze(rec, mass=5.3, mass_sd=0.02, seed=1)
    result.summary()["parameters"]["c"]      # posterior summary of c [N·s/m]
    print(result.report())                   # the table the CLI prints
    result.save("decay.dampfit")             # the folder `dampfit analyze` writes
    again = dampfit.load("decay.dampfit")    # read back: the same class
    table = dampfit.analyze_many(["a.csv", "b.csv"], mass=5.3)  # one row per recording

    rec, truth = dampfit.simulate.recording(dampfit.simulate.preset("paper"))

The names are imported on first use (PEP 562) from :mod:`dampfit.api` and the modules below,
so ``import dampfit`` — and every CLI command that needs no analysis — does not pay for JAX,
SciPy and arviz.
"""

from importlib import import_module as _import_module

from dampfit._meta import __version__ as __version__
from dampfit.errors import DampfitError as DampfitError
from dampfit.errors import InputError as InputError

#: Public names and the module each comes from (None: the module itself).
_LAZY = {
    "Analysis": ("dampfit.api", "Analysis"),
    "CampaignAnalysis": ("dampfit.api", "CampaignAnalysis"),
    "analyze": ("dampfit.api", "analyze"),
    "analyze_campaign": ("dampfit.api", "analyze_campaign"),
    "analyze_many": ("dampfit.api", "analyze_many"),
    "load": ("dampfit.api", "load"),
    "read": ("dampfit.api", "read"),
    "Recording": ("dampfit.io.recording", "Recording"),
    "crlb": ("dampfit.inference.crlb", None),
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


__all__ = ["__version__", "DampfitError", "InputError", *_LAZY]
