"""Adding a damping law at run time: :func:`register`, :func:`unregister`, and the prior model
probabilities of the registered laws (:func:`prior_weights`).

A law is one :class:`dampfit.model.laws.Law` subclass (its numerics and everything dampfit
reads about it: prior weight, coefficients, force text, FEM hint, colour). Registered, it is
fitted, sampled, compared, offered by ``--model``, reported and can be the recommended damper
like the four built-in ones (``tests/recovery/test_new_law.py``).
"""

from __future__ import annotations

from dampfit.model import laws

#: The four laws of :mod:`dampfit.model.laws` (never removed).
BUILT_IN = frozenset(("viscous", "coulomb", "quadratic", "power"))


def prior_weights() -> dict[str, float]:
    """Prior model probabilities [1]: each registered law's ``prior_weight``, normalised to
    sum 1 (the four built-in laws: 1/2, 1/6, 1/6, 1/6 — prior odds 1 : 1 between "one
    viscous c" and "amplitude-dependent")."""
    total = sum(law.prior_weight for law in laws.LAWS.values())
    if abs(total - 1.0) < 1e-12:  # already normalised: the weights as written
        return {m: law.prior_weight for m, law in laws.LAWS.items()}
    return {m: law.prior_weight / total for m, law in laws.LAWS.items()}


def register(law: laws.Law) -> laws.Law:
    """Add a damping law (an instance of a :class:`~dampfit.model.laws.Law` subclass with a
    new ``name`` and its ``coefficients``); returns it. A name already registered, a law
    without a name or coefficients is a ``ValueError``; :func:`unregister` removes it."""
    if not isinstance(law, laws.Law) or not law.name or law.name == "auto":
        raise ValueError("register() takes an instance of a Law subclass with a name")
    if law.name in laws.LAWS:
        raise ValueError(f"damping law {law.name!r} is already registered")
    if not law.coefficients:
        raise ValueError(f"damping law {law.name!r} declares no coefficients")
    laws.LAWS[law.name] = law.with_phase(0)
    laws.refresh()
    return law


def unregister(name: str) -> None:
    """Remove a law added by :func:`register` (the built-in ones stay)."""
    if name in BUILT_IN:
        raise ValueError(f"the built-in damping law {name!r} cannot be removed")
    laws.LAWS.pop(name, None)
    laws.refresh()
