"""The installed version of dampfit and of the libraries its numbers depend on (provenance)."""

from __future__ import annotations

from importlib import metadata

#: Libraries whose versions every summary records (``provenance.versions``).
NUMERIC_LIBRARIES = ("numpy", "scipy", "jax", "optimistix", "emcee", "arviz")


def version(package: str = "dampfit") -> str:
    """The installed version of ``package`` (``"unknown"`` for dampfit run from a source tree
    without an install, ``"missing"`` for another package that is not installed)."""
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:  # pragma: no cover - depends on the installation
        return "unknown" if package == "dampfit" else "missing"


def versions() -> dict[str, str]:
    """``{library: version}`` of :data:`NUMERIC_LIBRARIES`."""
    return {pkg: version(pkg) for pkg in NUMERIC_LIBRARIES}


__version__ = version()
