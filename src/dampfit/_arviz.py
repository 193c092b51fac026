"""arviz, imported once and quietly (its import announces a refactor with a FutureWarning);
the one NetCDF writer of posteriors (:func:`write_netcdf`); and :func:`dask_absent`."""

from __future__ import annotations

import contextlib
import os
import sys
import warnings


def arviz():
    """The arviz module (imported on first use: it pulls in xarray and takes a moment)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
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
    left alone, and so is everything after the context. So is a process that imported xarray
    before the context: xarray caches its answer to "is Dask installed?" (``lru_cache``), and
    a "yes" cached outside would make it import ``dask.base`` inside, which fails here."""
    if "dask" in sys.modules or "xarray" in sys.modules:
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
