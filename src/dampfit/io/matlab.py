"""MATLAB ``.mat`` files: one variable of a MAT-file → named time and acceleration columns.

Laboratory data acquisition (MATLAB, LabVIEW exports, dSPACE) stores recordings as MAT-files,
often inside structs (``Fe.Out.Acc``, 2 × N) rather than as flat tables. :func:`load` finds the
numeric arrays in a file — through structs, at any depth — picks one and splits it into time
and acceleration:

* **Versions.** v4, v5 and v6/v7 (zlib-compressed) through :func:`scipy.io.loadmat`; v7.3 (an
  HDF5 file behind a 512-byte MATLAB header) through h5py. h5py sees MATLAB's column-major
  arrays transposed (a 2 × N variable is stored N × 2); :func:`load` transposes them back, so
  both versions give the shape MATLAB shows.
* **Variable.** ``variable="Fe.Out.Acc"`` (a dotted struct path) picks one; without it the only
  numeric array with enough samples is used, or the one whose name says acceleration
  (``acc…``); several candidates and no hint is an error that lists them.
* **Orientation and rows.** The longer dimension counts samples, the shorter one variables
  ("rows" in MATLAB's 2 × N sense, whichever way they are stored). A row that is finite and
  strictly increasing is time; ``row=N`` (0-based) picks the acceleration row, the other rows
  are ignored. An array with several data rows besides the time needs ``row``: a MAT-file
  does not say whether they are the axes of one accelerometer or separate sensors (two
  sensors on a cantilever are not the axes of one vector), so the error names the rows and
  their rms. Without a time row, a sibling time vector in the same struct (``t``, ``time``,
  ``Time``…, the same length) or a sibling sample rate (``fs``, ``Fs``, ``SampleRate``… [Hz])
  gives the time axis.

**Bounded memory.** A MAT-file can declare or compress far more data than it holds. Before any
array is loaded, the declared sizes are checked against ``max_bytes``: v5 compressed elements
are inflated in a streaming pass that stops at the limit (a "zip bomb" costs at most one
chunk), v7.3 datasets are checked by their declared shape. Pickled or object data are never
loaded (MATLAB objects and cell arrays are skipped).
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from dampfit.errors import InputError

#: The HDF5 signature; a v7.3 MAT-file has it at byte 512, after MATLAB's text header.
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_V5_COMPRESSED = 15  # miCOMPRESSED
_TIME_NAMES = {"t", "time", "times", "tt", "timestamp", "timestamps", "time_s", "tvec"}
_RATE_NAMES = {"fs", "samplerate", "sample_rate", "srate", "samplingrate", "sampling_rate",
               "samplingfrequency", "sampling_frequency", "sr"}
#: Fewest samples along the long dimension for an array to count as a recording.
_MIN_SAMPLES = 16


@dataclass
class MatTable:
    """Named columns (``time`` first, then acceleration) from one MAT-file variable."""

    columns: dict[str, np.ndarray]
    version: str
    notes: list[str] = field(default_factory=list)


def is_mat(data: bytes) -> bool:
    """Whether ``data`` starts like a MAT-file of version 5 or later (v4 has no signature)."""
    return data[:6] == b"MATLAB" or data[512:520] == HDF5_MAGIC


def load(data: bytes, *, variable: str | None = None, row: int | None = None,
         max_bytes: int = 2**30) -> MatTable:
    """Time and acceleration columns from a MAT-file's bytes (module docstring).

    Parameters
    ----------
    data
        The file's bytes.
    variable
        Dotted struct path of the array to use, e.g. ``"Fe.Out.Acc"``; default: detected.
    row
        0-based row (variable) of the acceleration within that array; required when the
        array has more than one row besides the time.
    max_bytes
        Largest total decompressed size [bytes] the file may declare.

    Raises
    ------
    InputError
        One line: not a MAT-file, too large, no (or an ambiguous) numeric variable, no time.
    """
    if data[512:520] == HDF5_MAGIC:
        arrays, version = _read_v73(data, max_bytes), "v7.3"
    else:
        arrays, version = _read_v5(data, max_bytes), "v5" if data[:6] == b"MATLAB" else "v4"
    if not arrays:
        raise InputError(f"MATLAB {version} file without numeric arrays")
    path = _choose(arrays, variable)
    rows = _rows(arrays[path], path)
    time, accel, how = _split(rows, path, arrays, row)
    columns = {"time": time, "a": accel[0]}
    shape = " × ".join(str(s) for s in arrays[path].shape)
    return MatTable(columns, version, [f"MATLAB {version} file: variable {path!r} ({shape}): {how}"])


# ---------------------------------------------------------------------------- reading
def _read_v5(data: bytes, max_bytes: int) -> dict[str, np.ndarray]:
    """Every numeric array of a v4/v5/v7 MAT-file by dotted path (structs flattened)."""
    from scipy import io as sio

    if data[:6] == b"MATLAB":
        _check_v5_size(data, max_bytes)
    elif len(data) > max_bytes:
        raise InputError(f"is larger than the {max_bytes / 2**20:.0f} MiB limit")
    try:
        content = sio.loadmat(io.BytesIO(data), simplify_cells=True, mat_dtype=False,
                              verify_compressed_data_integrity=True)
    except (ValueError, TypeError, OSError, EOFError, NotImplementedError, zlib.error,
            struct.error, IndexError, KeyError, AttributeError) as exc:
        raise InputError(f"is not a readable MAT-file ({' '.join(str(exc).split())[:200]})") from None
    arrays: dict[str, np.ndarray] = {}
    for key, value in content.items():
        if not key.startswith("__"):
            _collect(value, key, arrays, depth=0)
    return arrays


def _check_v5_size(data: bytes, max_bytes: int) -> None:
    """Walk the top-level data elements; inflate compressed ones in bounded chunks."""
    endian = "<" if data[126:128] == b"IM" else ">"
    pos, total = 128, 0
    while pos + 8 <= len(data):
        dtype, nbytes = struct.unpack(endian + "II", data[pos:pos + 8])
        if dtype >> 16:  # small data element: type and size share the first word
            pos += 8
            continue
        body = data[pos + 8:pos + 8 + nbytes]
        if dtype == _V5_COMPRESSED:
            inflate = zlib.decompressobj()
            chunk = body
            while chunk:
                total += len(inflate.decompress(chunk, 2**20))
                if total > max_bytes:
                    break
                chunk = inflate.unconsumed_tail
        else:
            total += nbytes
        if total > max_bytes:
            raise InputError(f"declares more than {max_bytes / 2**20:.0f} MiB of data once "
                             "decompressed; refusing to load it")
        pos += 8 + nbytes + (-nbytes % 8 if dtype != _V5_COMPRESSED else 0)


def _collect(value, path: str, out: dict[str, np.ndarray], depth: int) -> None:
    """Numeric arrays and scalars under ``value`` (a loadmat object) into ``out``."""
    if depth > 16:
        return
    if isinstance(value, dict):
        for key, sub in value.items():
            _collect(sub, f"{path}.{key}", out, depth + 1)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        out[path] = np.asarray(float(value))
    elif isinstance(value, np.ndarray) and value.dtype.kind in "iuf":
        out[path] = value
    # cell arrays (lists / object arrays), strings, logicals, objects: not recordings


def _read_v73(data: bytes, max_bytes: int) -> dict[str, np.ndarray]:
    """Every numeric dataset of a v7.3 (HDF5) MAT-file, in MATLAB's orientation."""
    try:
        import h5py
    except ImportError:  # pragma: no cover - h5py comes with h5netcdf
        raise InputError("is a MATLAB v7.3 file, which needs the h5py package") from None
    try:
        with h5py.File(io.BytesIO(data), "r") as h5:
            found: list = []
            h5.visititems(lambda name, obj: found.append((name, obj))
                          if isinstance(obj, h5py.Dataset) else None)
            numeric = [(name, ds) for name, ds in found
                       if not name.startswith("#") and ds.dtype.kind in "iuf"
                       and ds.attrs.get("MATLAB_class", b"double") not in (b"logical", b"char")]
            declared = sum(int(np.prod(ds.shape, dtype=np.float64)) * ds.dtype.itemsize
                           for _, ds in numeric)
            if declared > max_bytes:
                raise InputError(f"declares {declared / 2**20:.0f} MiB of arrays, more than the "
                                 f"{max_bytes / 2**20:.0f} MiB limit; refusing to load it")
            return {name.replace("/", "."): np.asarray(ds[()]).T for name, ds in numeric}
    except InputError:
        raise
    except (OSError, ValueError, TypeError, KeyError) as exc:
        raise InputError(f"is not a readable MATLAB v7.3 (HDF5) file ({' '.join(str(exc).split())[:200]})") from None


# ---------------------------------------------------------------------------- choosing
def _long(arr: np.ndarray) -> int:
    return max(arr.shape) if arr.ndim else 0


def _is_signal(arr: np.ndarray) -> bool:
    return arr.ndim in (1, 2) and _long(arr) >= _MIN_SAMPLES and (arr.ndim == 1 or min(arr.shape) <= 16)


def _listing(paths) -> str:
    paths = sorted(paths)
    shown = ", ".join(paths[:8])
    return shown + (f" and {len(paths) - 8} more" if len(paths) > 8 else "")


def _choose(arrays: dict[str, np.ndarray], variable: str | None) -> str:
    """The dotted path of the array to read."""
    if variable is not None:
        wanted = variable.strip().replace("/", ".")
        match = {p.lower(): p for p in arrays}.get(wanted.lower())
        if match is None:
            raise InputError(f"has no numeric variable {variable!r}; numeric arrays: "
                             f"{_listing(p for p, a in arrays.items() if a.ndim)}")
        if not _is_signal(arrays[match]):
            raise InputError(f"variable {match!r} has shape {arrays[match].shape}; expected a "
                             f"vector or a k × N array (k ≤ 16) of ≥ {_MIN_SAMPLES} samples")
        return match
    signals = [p for p, a in arrays.items() if _is_signal(a)]
    leaves = {p: p.rsplit(".", 1)[-1].lower() for p in signals}
    candidates = [p for p in signals if leaves[p] not in _TIME_NAMES]
    if not candidates:
        raise InputError("has no numeric array of at least 16 samples; arrays: "
                         f"{_listing(arrays)}")
    if len(candidates) > 1:
        acc = [p for p in candidates if leaves[p].startswith("acc")]
        if len(acc) == 1:
            return acc[0]
        raise InputError(f"has several arrays that could be the recording ({_listing(candidates)}); "
                         "choose one with --variable (a dotted struct path such as Fe.Out.Acc)")
    return candidates[0]


def _rows(arr: np.ndarray, path: str) -> np.ndarray:
    """The array as (k, N) float64: k variables of N samples."""
    arr = np.asarray(arr, dtype=np.float64)
    if arr.ndim == 1:
        return arr[None, :]
    return arr if arr.shape[1] >= arr.shape[0] else arr.T


def _increasing(x: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(x)) and np.all(np.diff(x) > 0))


def _split(rows: np.ndarray, path: str, arrays: dict, row: int | None):
    """(time, list of acceleration rows, description) of a (k, N) array."""
    k, n = rows.shape
    time_rows = [i for i in range(k) if _increasing(rows[i])] if k > 1 else []
    if row is not None:
        if not 0 <= row < k:
            raise InputError(f"variable {path!r} has {k} row(s) (0…{k - 1}); --row {row} is not one of them")
        if row in time_rows and len(time_rows) == 1 and k > 1:
            raise InputError(f"row {row} of {path!r} is the time row (strictly increasing); "
                             "choose the acceleration row")
        accel_idx = [row]
    else:
        accel_idx = [i for i in range(k) if i not in time_rows[:1]]
    time_idx = next((i for i in time_rows if i not in accel_idx), None)
    if len(accel_idx) > 1:
        rms = ", ".join(f"row {i} (rms {np.sqrt(np.mean(np.square(rows[i]))):.3g})"
                        for i in accel_idx[:8]) + (", …" if len(accel_idx) > 8 else "")
        timed = f"row {time_idx} is time; " if time_idx is not None else ""
        raise InputError(
            f"variable {path!r} has {len(accel_idx)} data rows: {rms}; {timed}a MAT-file does "
            "not say whether they are the axes of one accelerometer or separate sensors, so "
            f"choose the acceleration row with --row (e.g. --row {accel_idx[0]})")
    if time_idx is not None:
        time, how_t = rows[time_idx], f"row {time_idx} time"
    else:
        time, how_t = _sibling_time(path, arrays, n)
    return time, [rows[accel_idx[0]]], f"{how_t}, acceleration from row {accel_idx[0]}"


def _sibling_time(path: str, arrays: dict, n: int) -> tuple[np.ndarray, str]:
    """A time vector or sample rate stored beside ``path`` in the same struct."""
    parent = path.rsplit(".", 1)[0] + "." if "." in path else ""
    siblings = {p[len(parent):].lower(): p for p in arrays
                if p.startswith(parent) and "." not in p[len(parent):]}
    for name, p in siblings.items():
        arr = np.asarray(arrays[p], dtype=np.float64).ravel()
        if name in _TIME_NAMES and arr.size == n and _increasing(arr):
            return arr, f"time from {p!r}"
    for name, p in siblings.items():
        arr = np.asarray(arrays[p], dtype=np.float64)
        if name in _RATE_NAMES and arr.size == 1 and np.isfinite(arr).all() and float(arr.ravel()[0]) > 0:
            fs = float(arr.ravel()[0])
            return np.arange(n) / fs, f"time from the sample rate {p!r} = {fs:g} Hz"
    raise InputError(f"variable {path!r} has no time row (strictly increasing) and no time "
                     "vector or sample rate (t, time, fs, SampleRate…) beside it in the same struct")
