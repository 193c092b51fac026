"""Estimators of the decay rate and c, ranked by :mod:`dampfit.study`.

* :mod:`~dampfit.estimators.registry` — the common interface ``(prep, mass, *, seed) ->
  Estimate``, the registered estimators (bayes, least squares, log decrement, envelope
  pipeline, Hilbert, half-power, matrix pencil) and :func:`run`;
* :mod:`~dampfit.estimators.baselines` — the seed paper's classical pipeline (band-pass, double
  integration, envelope, log-linear fit; log decrement over n cycles).
"""

from dampfit.estimators.registry import BAYES_MIN_ESS as BAYES_MIN_ESS
from dampfit.estimators.registry import ESTIMATORS as ESTIMATORS
from dampfit.estimators.registry import Z90 as Z90
from dampfit.estimators.registry import Estimate as Estimate
from dampfit.estimators.registry import run as run

__all__ = ["BAYES_MIN_ESS", "ESTIMATORS", "Estimate", "Z90", "run"]
