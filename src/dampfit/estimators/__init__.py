"""Estimators of the decay rate and c beside dampfit's own fit.

* :mod:`~dampfit.estimators.baselines` — the seed paper's classical pipeline (band-pass, double
  integration, envelope, log-linear fit; log decrement over n cycles), computed on every
  analysis and reported beside the posterior.

The common interface that ranks every estimator in a study is :mod:`dampfit.study.registry`.
"""
