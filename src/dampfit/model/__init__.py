"""Forward models of the free decay (JAX).

* :mod:`~dampfit.model.viscous` — the viscous law's variable-projection profile: for decay rate p
  and damped frequency ω_d the amplitudes (A, B) and the drift are linear and solved exactly;
* :mod:`~dampfit.model.laws` — the four damping laws (viscous, +Coulomb, +quadratic, power):
  averaged envelopes, model columns, physical coefficients and equivalent viscous damping.
"""
