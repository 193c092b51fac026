"""``python -m dampfit …`` runs the command-line interface."""

from dampfit.cli import run

run()
