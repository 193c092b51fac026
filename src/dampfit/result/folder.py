"""A result folder read back as plain data: :func:`open_result` gives a :class:`Loaded`, from
which :func:`dampfit.load` builds the :class:`dampfit.analysis.Analysis` the folder was written
from — or, for a campaign folder (summary.json with ``"kind": "campaign"``, several recordings
of one damper), the :class:`dampfit.campaign.result.CampaignAnalysis` (its stored summary; the
joint posterior from posterior.nc on first use; no per-test analyses). Nothing here imports
those classes: this module sits below them.

What :meth:`dampfit.analysis.Analysis.save` writes and how it is read:

* ``summary.json`` — :func:`dampfit.result.schema.read_summary` (the one validating reader),
  eagerly: ``Analysis.summary()`` returns it as written, nothing is recomputed;
* ``posterior.nc`` — :func:`read_posterior` (arviz ``from_netcdf``, loaded eagerly into memory
  so no file stays open), on first use of ``Analysis.posterior``; at most
  :data:`MAX_POSTERIOR_BYTES`, and the sizes its datasets declare are checked against the file
  before anything is allocated;
* ``signals.npz`` — :func:`load_signals` (the ZIP directory and array headers are checked
  before anything is allocated, as :mod:`dampfit.io.readers` does for recordings; the arrays
  then as :mod:`dampfit.result.signals` says), on first use of ``Analysis.signals()``; at most
  :data:`MAX_SIGNALS_BYTES`.

Every file is opened through :mod:`dampfit.result.files` (a regular file of the folder, not a
link, FIFO or device; size-limited).

The live pipeline objects (recording, prepared signal, least-squares and sampler results,
baselines, damping assessment) are not stored; using one raises a
:class:`~dampfit.errors.DampfitError` that names the folder.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from dampfit.errors import DampfitError, InputError
from dampfit.errors import shown
from dampfit.result.files import Unusable, check_digest, open_regular
from dampfit.result.schema import Summary, folder_of, is_campaign, read_summary
from dampfit.result.signals import KNOWN_KEYS, SIGNAL_KEYS, check_signals

#: Largest posterior.nc read [bytes]: the longest chain ``--max-steps`` allows is ≈ 2 GB.
MAX_POSTERIOR_BYTES = 4 * 2**30
#: Largest signals.npz read [bytes]: the analysed window of a recording, a few MB.
MAX_SIGNALS_BYTES = 2 * 2**30
#: Most bytes of data posterior.nc may declare per byte of file [1]: deflate, the compression
#: arviz writes with, cannot exceed about 1032:1 (draws of a real posterior compress < 2:1).
MAX_DECLARED_RATIO = 1100
#: Declared bytes allowed beyond that ratio (HDF5 headers of a tiny file) [bytes].
DECLARED_SLACK_BYTES = 64 * 2**20
#: Fields of :class:`dampfit.analysis.Analysis` that exist only in a live analysis.
LIVE_FIELDS = ("recording", "prepared", "fit_data", "least_squares", "noise", "sampling",
               "baselines", "damping")


def open_result(folder: str | os.PathLike) -> "Loaded":
    """What result ``folder`` holds, read lazily (see the module): its checked summary.json
    now, posterior.nc and signals.npz on first use. :func:`dampfit.load` turns it into the
    :class:`~dampfit.analysis.Analysis` (or, for a campaign folder, the
    :class:`~dampfit.campaign.result.CampaignAnalysis`) the folder was written from.
    :class:`~dampfit.errors.InputError` (one line) if ``folder`` is not a usable result folder.
    """
    return Loaded(read_summary(folder))


def real(x: Any) -> bool:
    """``x`` is a finite int or float (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


class Loaded:
    """What a result folder holds: the summary (checked), and posterior and signals read on
    first use; ``folder`` the folder, ``is_campaign`` whether it holds a campaign."""

    def __init__(self, summary: Summary):
        self.source = summary
        self.summary = summary.data
        self.folder = summary.folder
        self.is_campaign = is_campaign(summary.data)
        self._posterior = None
        self._signals: dict[str, Any] | None = None

    def posterior(self):
        if self._posterior is None:
            self._posterior = read_posterior(self.source.folder, summary=self.summary)
        return self._posterior

    def signals(self) -> dict[str, Any]:
        import numpy as np

        if self._signals is None:
            self._signals = load_signals(self.source.folder, checked=False, summary=self.summary)
        return {k: np.copy(v) for k, v in self._signals.items()}

    def converged(self) -> bool:
        diag = self.summary.get("diagnostics")
        return isinstance(diag, dict) and diag.get("converged") is True

    def live_only(self, what: str) -> DampfitError:
        """The error for ``what``, a live-only object, of this loaded result."""
        return _live_error(what, self.source.folder)

    def unavailable(self, names=LIVE_FIELDS) -> dict[str, "Unavailable"]:
        """``{name: Unavailable}`` for the live-only fields ``names`` of this loaded result."""
        return {name: Unavailable(name, self.source.folder) for name in names}


def _live_error(what: str, folder: Path) -> DampfitError:
    return DampfitError(f"{what} is not available: this result was loaded from {shown(folder)}, "
                        "which stores summary.json, posterior.nc and signals.npz only; run "
                        "dampfit.analyze() on the recording for the live pipeline objects")


class Unavailable:
    """Stands for a live pipeline object of a loaded analysis: any use of it raises
    :class:`~dampfit.errors.DampfitError` naming the result folder."""

    __slots__ = ("_name", "_folder")

    def __init__(self, name: str, folder: Path):
        object.__setattr__(self, "_name", name)
        object.__setattr__(self, "_folder", folder)

    def __getattr__(self, attr: str):
        if attr.startswith("__") and attr.endswith("__"):
            raise AttributeError(attr)  # copy, pickle and friends probe dunders
        raise _live_error(f"{self._name}.{attr}", self._folder)

    def _fail(self, *args, **kw):
        raise _live_error(self._name, self._folder)

    __getitem__ = __iter__ = __len__ = __call__ = __contains__ = _fail

    def __bool__(self) -> bool:
        raise _live_error(self._name, self._folder)

    def __repr__(self) -> str:
        return f"<{self._name}: not stored in the result folder {self._folder}>"


# ------------------------------------------------------------------------- posterior.nc
def _summary_of(folder: Any) -> dict | None:
    """The summary.json that ``folder`` (a path or a loaded result) was written with, for
    :func:`dampfit.result.files.check_digest`; None when it cannot be read (then nothing is
    checked: the caller's own reading of the summary reports it)."""
    data = getattr(folder, "summary", None)
    if isinstance(data, dict):
        return data
    source = getattr(folder, "source", None)
    if isinstance(getattr(source, "data", None), dict):
        return source.data
    try:
        return read_summary(folder_of(folder)).data
    except InputError:
        return None


def check_files(folder: str | os.PathLike) -> None:
    """Refuse result ``folder`` when its posterior.nc or signals.npz is a readable file of
    another analysis, not the one its summary.json records
    (:func:`dampfit.result.files.check_digest`; one line): ``dampfit report`` checks it
    before drawing anything. A missing or unreadable file is left to its reader (the
    figures it feeds are then not drawn, with a note)."""
    from dampfit.result.files import DIGESTED, ForeignFile

    folder = folder_of(folder)
    summary = read_summary(folder).data
    for name in DIGESTED:
        path = folder / name
        try:
            fd = open_regular(path, 2**40, missing=FileNotFoundError())
        except (FileNotFoundError, InputError):
            continue
        try:
            check_digest(fd, path, summary)
        except ForeignFile:
            reader = read_posterior if name == "posterior.nc" else load_signals
            try:
                reader(folder, summary=summary)  # raises ForeignFile only if it is readable
            except ForeignFile:
                raise
            except InputError:
                continue
        finally:
            os.close(fd)


def read_posterior(folder: str | os.PathLike | Any, summary: dict | None = None):
    """The posterior of result ``folder`` as arviz ``InferenceData`` (read into memory).

    :class:`InputError` if posterior.nc is missing, not a regular file of the folder (a link,
    FIFO or device: :mod:`dampfit.result.files`), larger than :data:`MAX_POSTERIOR_BYTES`,
    declares more data than it could hold (:func:`_check_declared`, before anything is
    allocated), is not the file the folder's summary.json (or ``summary``) records
    (:func:`dampfit.result.files.check_digest`) or is not a readable NetCDF file of arviz
    groups. The file checked is the file read (the open descriptor is handed to the reader).
    """
    expected = summary if summary is not None else _summary_of(folder)
    folder = folder_of(folder)
    path = folder / "posterior.nc"
    fd = open_regular(path, MAX_POSTERIOR_BYTES, missing=InputError(
        f"{shown(path)} not found; re-run 'dampfit analyze' (it writes posterior.nc)"),
        what="a posterior of the longest allowed chain is about 2 GB")
    try:
        size = os.fstat(fd).st_size
        name = _fd_path(fd, path)
        _check_declared(name, size, path)
        idata = _read_idata(name, path)
        check_digest(fd, path, expected)  # readable, but is it this summary's?
    finally:
        os.close(fd)
    if "posterior" not in idata.groups():
        raise InputError(f"{shown(path)} holds no posterior group; re-run 'dampfit analyze'")
    return idata


def _fd_path(fd: int, path: Path) -> str:
    """A name that opens the very file behind ``fd`` (``/proc/self/fd/N`` on Linux,
    ``/dev/fd/N`` elsewhere), or ``path`` where neither exists."""
    for base in ("/proc/self/fd", "/dev/fd"):
        if os.path.isdir(base):
            return f"{base}/{fd}"
    return str(path)  # pragma: no cover - no descriptor file system


def _read_idata(name: str, path: Path):
    import warnings

    import arviz as az  # lazy: heavy

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with az.rc_context({"data.load": "eager"}):
                return az.from_netcdf(name)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file for the user
        raise InputError(f"{shown(path)} is not a readable posterior ({type(exc).__name__}); "
                         "re-run 'dampfit analyze'") from None


def _check_declared(name: str, size: int, path: Path) -> None:
    """Refuse a posterior.nc whose datasets declare more bytes than its ``size`` [bytes] could
    hold compressed (:data:`MAX_DECLARED_RATIO`, plus :data:`DECLARED_SLACK_BYTES`) or than
    :data:`MAX_POSTERIOR_BYTES`, and one whose data lie outside it (external storage,
    external links, virtual datasets): read with h5py from the headers, nothing allocated."""
    import h5py

    declared = 0
    foreign: list[str] = []

    def visit(obj_name: str, obj) -> None:
        nonlocal declared
        if isinstance(obj, h5py.Dataset):
            declared += int(obj.size) * int(obj.dtype.itemsize)
            if obj.is_virtual or obj.id.get_create_plist().get_external_count() > 0:
                foreign.append(obj_name)

    def visit_link(obj_name: str, link) -> None:
        if isinstance(link, h5py.ExternalLink):
            foreign.append(obj_name)

    try:
        with h5py.File(name, "r", locking=False) as f:
            f.visititems_links(visit_link)
            f.visititems(visit)
    except Exception as exc:  # noqa: BLE001 - not HDF5 (NetCDF-4 is), truncated, corrupt
        raise InputError(f"{shown(path)} is not a readable posterior ({type(exc).__name__}); "
                         "re-run 'dampfit analyze'") from None
    if foreign:
        raise InputError(f"{shown(path)}: {shown(foreign[0], 60)} keeps its data outside the "
                         "file (external storage, link or virtual dataset): not a posterior "
                         "dampfit writes; re-run 'dampfit analyze'")
    limit = min(MAX_POSTERIOR_BYTES, MAX_DECLARED_RATIO * size + DECLARED_SLACK_BYTES)
    if declared > limit:
        raise InputError(f"{shown(path)} declares {declared / 2**20:.0f} MB of draws in a "
                         f"{size / 2**20:.1f} MB file (at most {limit / 2**20:.0f} MB can be "
                         "read): not a posterior dampfit writes; re-run 'dampfit analyze'")


# ------------------------------------------------------------------------- signals.npz
def load_signals(folder: str | os.PathLike | Any, checked: bool = True,
                 summary: dict | None = None) -> dict[str, Any]:
    """Arrays of ``folder/signals.npz`` as float64 NumPy arrays (with ``checked``, the scalars
    ``p``, ``omega_d``, ``t0`` as floats); :class:`InputError` if unusable.

    The file must be a regular file of the folder (not a link, FIFO or device) of at most
    :data:`MAX_SIGNALS_BYTES` holding :data:`SIGNAL_KEYS` and optionally the figure arrays,
    as :func:`dampfit.result.signals.check_signals` checks them (shapes, bounds, finite
    values); other arrays are ignored. It must be the file the folder's summary.json (or
    ``summary``) records (:func:`dampfit.result.files.check_digest`). The ZIP directory and
    array headers are checked before anything is allocated, on the descriptor that is then
    read; only numeric arrays are converted.
    """
    import numpy as np

    expected = summary if summary is not None else _summary_of(folder)
    path = folder_of(folder) / "signals.npz"
    again = "re-run 'dampfit analyze' (it writes signals.npz)"
    try:
        fd = open_regular(path, MAX_SIGNALS_BYTES, missing=InputError(
            f"{shown(path)} not found; {again}"), what="signals.npz of an analysis is a few MB")
    except Unusable as exc:
        raise InputError(f"{shown(path)} not found as a regular file: it is {exc.reason}; "
                         f"{again}") from None
    with os.fdopen(fd, "rb") as fh:
        _check_npz(fh, path)
        fh.seek(0)
        try:
            with np.load(fh, allow_pickle=False) as data:
                sig = {}
                for key in (k for k in data.files if k in KNOWN_KEYS):
                    array = data[key]
                    if array.dtype.kind not in "biuf":
                        raise InputError(f"{shown(path)}: '{key}' holds {array.dtype} values, "
                                         "not numbers; re-run 'dampfit analyze'")
                    sig[key] = np.asarray(array, dtype=float)
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001 - a corrupt file is the user's input
            raise InputError(f"{shown(path)} is not a readable .npz ({type(exc).__name__})") from None
        check_digest(fh.fileno(), path, expected)  # readable, but is it this summary's?
    sig = check_signals(sig, path)
    if checked:
        for key in ("p", "omega_d", "t0"):
            sig[key] = float(sig[key].reshape(()))
    return sig


def _check_npz(fh, path: Path) -> None:
    """Refuse a zip bomb or an array header declaring more bytes than the file holds before
    ``np.load`` allocates anything (the checks :mod:`dampfit.io.readers` applies to
    recordings), so the memory used is bounded by the data present."""
    import zipfile

    from dampfit.io.containers import check_npy_header, check_zip

    try:
        with zipfile.ZipFile(fh) as zf:
            check_zip(zf)
            for info in zf.infolist():
                if info.filename.endswith(".npy"):
                    with zf.open(info) as fp:
                        check_npy_header(fp, info.file_size, f"array {info.filename[:-4]!r}")
    except InputError as exc:
        raise InputError(f"{shown(path)}: {exc}") from None
    except (OSError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError,
            RuntimeError, ValueError) as exc:
        raise InputError(f"{shown(path)} is not a readable .npz ({type(exc).__name__})") from None
