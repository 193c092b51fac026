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

    rec, truth = dampfit.simulate.simulate(dampfit.simulate.preset("paper"))
"""

from importlib import metadata as _metadata

from dampfit.pipeline import Analysis as Analysis
from dampfit.pipeline import analyze as analyze
from dampfit.result import load as load
from dampfit.errors import DampfitError as DampfitError
from dampfit.errors import InputError as InputError
from dampfit.io.readers import read as read
from dampfit.io.recording import Recording as Recording
from dampfit.inference import crlb
from dampfit import estimators
from dampfit import simulate as simulate

try:
    __version__ = _metadata.version("dampfit")
except _metadata.PackageNotFoundError:  # pragma: no cover - source tree without install
    __version__ = "unknown"

__all__ = [
    "Analysis", "DampfitError", "InputError", "Recording", "__version__", "analyze", "load",
    "read",
    "crlb", "estimators", "simulate",
]
