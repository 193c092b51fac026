"""arviz, imported once and quietly (its import announces a refactor with a FutureWarning)."""

from __future__ import annotations

import warnings

__all__ = ["arviz"]


def arviz():
    """The arviz module (imported on first use: it pulls in xarray and takes a moment)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az

    return az
