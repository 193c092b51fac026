"""``python -m dampfit …`` runs the command-line interface."""

from .cli import run

run()
