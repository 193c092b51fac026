"""arviz, imported once and quietly (its import announces a refactor with a FutureWarning);
the one NetCDF writer of posteriors (:func:`write_netcdf`); and :func:`dask_absent`."""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import warnings

__all__ = ["arviz", "dask_absent", "write_netcdf"]


#: arviz's import-time notice of its refactor (a FutureWarning meant for its developers' users).
_NOTICE = r"\s*ArviZ is undergoing a major refactor"
_preloading: threading.Thread | None = None


def _quiet_import() -> None:
    warnings.filterwarnings("ignore", message=_NOTICE, category=FutureWarning)
    try:
        import arviz  # noqa: F401
    except Exception:  # noqa: BLE001 - imported again (and its error raised) on first use
        pass


def preload() -> None:
    """Start importing arviz (with xarray and matplotlib ≈ 0.4 s of a warm ``dampfit
    analyze``) in a background thread, once, so that it overlaps the least squares and the
    sampler's compiled steps, which run without the interpreter lock; :func:`arviz` waits
    for it. The pipeline calls this as an analysis starts, after every module it imports at
    the top has been imported, so the two threads do not import the same modules."""
    global _preloading
    if "arviz" in sys.modules or _preloading is not None:
        return
    _preloading = threading.Thread(target=_quiet_import, name="dampfit-import-arviz",
                                   daemon=True)
    _preloading.start()


def arviz():
    """The arviz module (imported on first use: it pulls in xarray and takes a moment)."""
    if _preloading is not None:
        _preloading.join()
    warnings.filterwarnings("ignore", message=_NOTICE, category=FutureWarning)
    import arviz as az

    return az


@contextlib.contextmanager
def dask_absent():
    """Within this context Dask counts as not installed, unless it is already imported.

    xarray (under arviz) asks for Dask on every array it wraps (is it a Dask array?) and on
    every file it writes (which Dask scheduler holds the lock?), and answering imports
    ``dask.array`` and ``dask.distributed``: ≈ 0.3 s, a tenth of a warm ``dampfit analyze``,
    in a process that never makes a Dask array. The commands that analyse or render one result
    run inside this context (:mod:`dampfit.cli`), so xarray takes the path it takes where Dask
    is not installed; a process that has imported Dask (a study or batch, a user's script) is
    left alone, and so is everything after the context."""
    if "dask" in sys.modules:
        yield
        return
    sys.modules["dask"] = None  # type: ignore[assignment] - "import dask" raises ImportError
    try:
        yield
    finally:
        if "dask" in sys.modules and sys.modules["dask"] is None:
            del sys.modules["dask"]


def write_netcdf(idata, path: str | os.PathLike, groups=None) -> None:
    """Write the arviz InferenceData ``idata`` to ``path`` (NetCDF 4 through h5netcdf), and
    each xarray Dataset of ``groups`` (name → Dataset) as a further group."""
    idata.to_netcdf(str(path), engine="h5netcdf")
    for name, data in (groups or {}).items():
        data.to_netcdf(str(path), mode="a", group=name, engine="h5netcdf")
