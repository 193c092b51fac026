"""``python -m dampfit …`` runs the command-line interface.

Like every ``python -m``, this puts the working folder first on *this* process's import path
(Python's own rule), so a module file lying there (``numpy.py``) would be imported in place of
the real one: in a folder you do not trust, run the ``dampfit`` command instead. dampfit's
child processes (figures, OpenSees, Dask workers) never import from the working folder either
way (:mod:`dampfit._child`).
"""

from dampfit.cli import run

if __name__ == "__main__":  # not when a spawned worker process imports this module
    run()
