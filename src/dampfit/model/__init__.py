"""Forward models of the free decay (JAX).

* :mod:`~dampfit.model.laws` — the four damping laws (viscous, +Coulomb, +quadratic, power), one
  small class each (:class:`~dampfit.model.laws.Law`: parameter names, units, priors, averaged
  envelope, model columns, physical coefficients), registered by name in
  :data:`~dampfit.model.laws.LAWS`;
* :mod:`~dampfit.model.profile` — the one variable-projection profile and σ-marginal likelihood
  (with the Whittle factor) for any law, for sums of laws (``Sum``: several modes) and for
  several recordings sharing parameters (``Joint``); used by least squares, the posterior and
  the law fits, evidence and sampler;
* :mod:`~dampfit.model.viscous` — the viscous decay (M1): acceleration, velocity, displacement,
  the drift basis and the profile with the (M1) columns.
"""
