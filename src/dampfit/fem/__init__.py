"""FEM hand-off: decks for LS-DYNA, OpenSees, CalculiX and verification in OpenSeesPy.

Modules (nothing is imported here, so building the CLI stays fast):

* :mod:`~dampfit.fem.sdof` — the identified system (m, k, c, u0, gravity) from a result folder;
* :mod:`~dampfit.fem.units` — consistent unit systems (SI, mm-ms-kg, mm-s-t), derived factors;
* :mod:`~dampfit.fem.timestep` — fixed steps with negligible period and phase error;
* :mod:`~dampfit.fem.keyword` — fixed-width LS-DYNA cards and their reader;
* :mod:`~dampfit.fem.lsdyna`, :mod:`~dampfit.fem.opensees`, :mod:`~dampfit.fem.calculix` —
  the decks (and, for OpenSees, the run of that very script in an isolated child process);
* :mod:`~dampfit.fem.damper` — the damper a deck writes (the recommended law, checked) and its
  engine elements; :mod:`~dampfit.fem.draws` — posterior draws as decks (export/verify --draws);
* :mod:`~dampfit.fem.response` — pure numerics of the verification;
* :mod:`~dampfit.fem.export`, :mod:`~dampfit.fem.verify` — ``dampfit export`` and ``dampfit verify``.
"""
