"""Amplitude-dependent and nonlinear damping: which damper, and c as a function of amplitude.

One viscous c assumes the decay rate is the same at every amplitude. Real recordings often
show it falling as the amplitude falls (air drag, friction, material damping). This package
fits four damping laws to the same free decay with the same calibrated noise model —
``viscous`` c·u̇, ``coulomb`` c·u̇ + F_c·sgn(u̇), ``quadratic`` c·u̇ + c₂·u̇|u̇| and ``power``
c_α·|u̇|^α·sgn(u̇) — compares them by their evidence, estimates ζ(amplitude) from windowed
fits, and says which damper an FEM model needs:

    from dampfit import damping
    res = damping.assess(prep, fd, ls, noise_model, mass=0.3255, model="auto")
    res = damping.from_analysis(dampfit.analyze(rec, mass=0.3255))   # the same, from an Analysis
    res.summary()          # {"model_checks", "damping_models", "amplitude_curve"}
    res.warnings           # the text a user sees when one viscous c is not adequate
    res.c_report()         # c (viscous) or c_eq at a stated amplitude

Modules: :mod:`~dampfit.model.laws` (laws, averaged envelopes, c_eq),
:mod:`~dampfit.inference.law_fit` (least squares, evidence), :mod:`~dampfit.damping.evidence`,
:mod:`~dampfit.inference.law_sampler` (emcee / Laplace draws), :mod:`~dampfit.damping.curve`
(ζ(amplitude)), :mod:`~dampfit.damping.checks`, :mod:`~dampfit.damping.quantities`,
:mod:`~dampfit.damping.summary`, :mod:`~dampfit.damping.damper` (the one recommended damper:
``Analysis.damper``);
:mod:`~dampfit.damping.assessment` holds :func:`assess`.
"""

from dampfit.damping.assessment import choices as choices
from dampfit.damping.assessment import POSTERIORS as POSTERIORS
from dampfit.damping.assessment import DampingAssessment as DampingAssessment
from dampfit.damping.assessment import assess as assess
from dampfit.damping.assessment import Settings as Settings
from dampfit.damping.assessment import from_analysis as from_analysis
from dampfit.model.laws import names as names
from dampfit.model.laws import c_equivalent as c_equivalent

