"""Container files: phyphox/Sensor Logger ZIP exports, Excel workbooks, NumPy arrays.

* ZIP export: the member read is ``Linear Acceleration.csv``, ``Accelerometer.csv``,
  ``Raw Data.csv`` (in this order), else the only CSV with acceleration columns; it is parsed
  as text (:mod:`dampfit.io.text`).
* ``.xlsx`` (openpyxl) and legacy ``.xls`` (optional ``xlrd``): the worksheet named by
  ``sheet``, else a preferred phyphox data set, else the only acceleration sheet.
* ``.npy`` of shape (k, N) or (N, k), k = 2…4 (time, then acceleration), and ``.npz`` with
  named arrays (``t``/``time``, ``a``/``acc``/``x``…) or arrays read by position.

Hostile input is refused before anything is unpacked or allocated: :func:`check_zip` reads
the archive directory (total unpacked size at most
:data:`~dampfit.io.bounded.MAX_UNPACKED_BYTES` [bytes], compression ratio at most
:data:`~dampfit.io.bounded.MAX_ZIP_RATIO` for members over 1 MiB), :func:`check_npy_header`
reads an array header (no object arrays or pickles; declared shape × item size [bytes] within
the data present and the limit). Both also guard :mod:`dampfit.fem.verify`.
"""

from __future__ import annotations

import io
import math
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd

from dampfit.errors import InputError
from dampfit.io import bounded
from dampfit.io.bounded import decode
from dampfit.io.columns import looks_like_acceleration, role
from dampfit.io.text import PEEK_ROWS, Table, drop_empty_unnamed, is_number, text_table

#: Preferred acceleration data sets in a phyphox/Sensor Logger ZIP or workbook, best first.
_PREFERRED_SETS = ("linear acceleration", "accelerometer", "raw data")


def container_table(data: bytes, name: str, ext: str, sheet: str | int | None,
                    nrows: int | None) -> Table:
    """A ZIP-based file: an xlsx workbook, an .npz archive or a phyphox/Sensor Logger ZIP."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            check_zip(zf)
            members = zf.namelist()
            if "[Content_Types].xml" in members and any(m.startswith("xl/") for m in members):
                return _xlsx_table(data, sheet, nrows)
            if ext == ".npz" or (members and all(m.endswith(".npy") for m in members)):
                return _npz_table(data, name, zf)
            return _zip_table(zf, nrows)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError):
        raise InputError(f"is not a valid {ext or 'zip'} archive (corrupt or truncated); export it again") from None
    except (NotImplementedError, RuntimeError) as exc:  # unsupported compression, encryption
        raise InputError(f"cannot be unpacked ({' '.join(str(exc).split())}); export it again without a password") from None


def check_zip(zf: zipfile.ZipFile) -> None:
    """Refuse a zip bomb from the archive directory, before anything is decompressed: more
    than :data:`~dampfit.io.bounded.MAX_UNPACKED_BYTES` [bytes] in total, or a member over
    1 MiB compressed more than :data:`~dampfit.io.bounded.MAX_ZIP_RATIO`:1. (``zipfile``
    never returns more than a member's declared size.)"""
    infos = zf.infolist()
    total = sum(i.file_size for i in infos)
    if total > bounded.MAX_UNPACKED_BYTES:
        raise InputError(
            f"would unpack to {total / 2**20:.0f} MiB, more than the limit of "
            f"{bounded.MAX_UNPACKED_BYTES / 2**20:.0f} MiB (a zip bomb?); refused before unpacking"
        )
    for info in infos:
        ratio = info.file_size / max(info.compress_size, 1)
        if info.file_size > bounded.RATIO_MIN_BYTES and ratio > bounded.MAX_ZIP_RATIO:
            raise InputError(
                f"member {info.filename!r} would unpack {ratio:.0f}:1 to {info.file_size / 2**20:.0f} MiB "
                f"(more than {bounded.MAX_ZIP_RATIO:.0f}:1: a zip bomb?); refused before unpacking"
            )


def _zip_table(zf: zipfile.ZipFile, nrows: int | None) -> Table:
    """The acceleration CSV of a phyphox (or Sensor Logger) ZIP export."""
    candidates = [
        m for m in zf.namelist()
        if m.lower().endswith((".csv", ".txt"))
        and "meta/" not in m.lower()
        and not m.startswith("__MACOSX")
    ]
    if not candidates:
        raise InputError("is a zip without CSV files; expected a phyphox or Sensor Logger export")

    def load(member: str, rows: int | None) -> Table:
        try:
            text = decode(zf.read(member))
        except InputError as exc:
            raise InputError(f"member {member!r} {exc}") from None
        return text_table(text, Path(member).name, "zip", rows)

    by_name = {Path(m).stem.lower(): m for m in candidates}
    member = next((by_name[s] for s in _PREFERRED_SETS if s in by_name), None)
    if member is None:
        usable = []
        for m in candidates:
            try:
                if looks_like_acceleration(load(m, PEEK_ROWS)):
                    usable.append(m)
            except InputError:
                continue
        if not usable:
            found = ", ".join(repr(Path(m).name) for m in candidates)
            raise InputError(f"is a zip without an acceleration CSV (found {found}); export the accelerometer data")
        if len(usable) > 1:
            found = ", ".join(repr(m) for m in usable)
            raise InputError(f"is a zip with several acceleration CSVs ({found}); extract the one to analyse and read it directly")
        member = usable[0]
    table = load(member, nrows)
    table.notes.insert(0, f"read zip member {member!r}")
    return table


def _choose_sheet(names: list[str], sheet: str | int | None, parse) -> str:
    """The worksheet to read: ``sheet`` (name or 0-based position), a preferred phyphox set,
    else the only acceleration sheet. ``parse(name, rows)`` reads a sheet as a table."""
    if sheet is not None:
        if isinstance(sheet, int) and not isinstance(sheet, bool):
            if 0 <= sheet < len(names):
                return names[sheet]
        elif str(sheet) in names:
            return str(sheet)
        elif str(sheet).strip().isdigit() and int(sheet) < len(names):
            return names[int(sheet)]
        listing = ", ".join(repr(n) for n in names)
        raise InputError(f"has no sheet {sheet!r}; sheets: {listing}")
    by_name = {n.strip().lower(): n for n in names}
    for preferred in _PREFERRED_SETS:
        if preferred in by_name:
            return by_name[preferred]
    usable = [n for n in names if looks_like_acceleration(parse(n, PEEK_ROWS))]
    if len(usable) == 1 or (usable and len(names) == 1):
        return usable[0]
    if not usable and len(names) == 1:
        return names[0]
    listing = ", ".join(repr(n) for n in (usable or names))
    raise InputError(f"has no single acceleration sheet (sheets: {listing}); choose one with --sheet")


def _excel_table(data: bytes, sheet: str | int | None, nrows: int | None, engine: str) -> Table:
    """A worksheet of an Excel workbook as a table (header row = column names)."""
    book = pd.ExcelFile(io.BytesIO(data), engine=engine)

    def parse(sheet: str, rows: int | None) -> Table:
        frame = pd.read_excel(book, sheet_name=sheet, header=0, nrows=rows)
        header = any(isinstance(c, str) and not is_number(c, ".") for c in frame.columns)
        if header:
            frame.columns = [str(c).strip() for c in frame.columns]
            frame = drop_empty_unnamed(frame)
        else:
            frame = pd.read_excel(book, sheet_name=sheet, header=None, nrows=rows)
        return Table(frame, header, "xlsx", sheet)

    sheet = _choose_sheet(book.sheet_names, sheet, parse)
    table = parse(sheet, nrows)
    if table.frame.shape[0] == 0:
        raise InputError(f"sheet {sheet!r} has a header but no data rows")
    table.notes.append(f"read sheet {sheet!r}")
    return table


def _xlsx_table(data: bytes, sheet: str | int | None, nrows: int | None) -> Table:
    """An .xlsx workbook via openpyxl."""
    from xml.etree.ElementTree import ParseError
    from xml.parsers.expat import ExpatError

    from openpyxl.utils.exceptions import InvalidFileException

    try:
        return _excel_table(data, sheet, nrows, "openpyxl")
    except InputError:
        raise
    except (ParseError, ExpatError) as exc:  # expat refuses entity bombs: one line, exit 2
        why = ("its XML declares entities that expand without bound, an entity bomb"
               if "amplification" in str(exc) or "entit" in str(exc).lower()
               else "its XML is malformed")
        raise InputError(f"is not a readable xlsx workbook: {why}; export it again") from None
    except (zipfile.BadZipFile, InvalidFileException, KeyError, ValueError, OSError, EOFError) as exc:
        raise InputError(f"is not a readable xlsx workbook ({type(exc).__name__}); export it again") from None


def xls_table(data: bytes, sheet: str | int | None, nrows: int | None) -> Table:
    """A legacy .xls workbook; needs the optional xlrd package."""
    try:
        import xlrd  # noqa: F401
    except ImportError:
        raise InputError(
            "is a legacy .xls workbook, which needs the xlrd package; export as .xlsx or CSV instead"
        ) from None
    try:
        return _excel_table(data, sheet, nrows, "xlrd")
    except InputError:
        raise
    except (ValueError, KeyError, OSError, EOFError) as exc:
        raise InputError(f"is not a readable .xls workbook ({type(exc).__name__})") from None


def _load_numpy(data: bytes, what: str):
    """``np.load`` of bytes without pickles."""
    try:
        return np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"is not a readable {what} file ({' '.join(str(exc).split())})") from None


def check_npy_header(fp, size: int, what: str) -> None:
    """Check an .npy header at ``fp`` before any array is allocated.

    ``size`` [bytes] is the whole .npy (header + data). Refuses object arrays (pickles) and a
    declared shape × item size beyond the bytes present or :data:`~dampfit.io.bounded.MAX_UNPACKED_BYTES`.
    """
    from numpy.lib import format as npformat

    try:
        version = npformat.read_magic(fp)
        if version == (1, 0):
            shape, _, dtype = npformat.read_array_header_1_0(fp)
        elif version == (2, 0):
            shape, _, dtype = npformat.read_array_header_2_0(fp)
        else:
            shape, _, dtype = npformat._read_array_header(fp, version)
    except (ValueError, TypeError, SyntaxError, OSError, EOFError) as exc:
        raise InputError(f"{what} has an unreadable .npy header ({' '.join(str(exc).split())})") from None
    if dtype.hasobject:
        raise InputError(f"is not a readable {'.npz' if what.startswith('array ') else '.npy'} file: "
                         f"{what} holds Python objects (pickled data), which are never loaded; "
                         "save plain numeric arrays")
    declared = math.prod(int(d) for d in shape) * dtype.itemsize
    present = size - fp.tell()
    if declared > bounded.MAX_UNPACKED_BYTES:
        raise InputError(f"{what} declares shape {tuple(shape)} = {declared / 2**20:.3g} MiB, more than "
                         f"the limit of {bounded.MAX_UNPACKED_BYTES / 2**20:.0f} MiB; refused before loading")
    if declared > present:
        raise InputError(f"{what} declares shape {tuple(shape)} ({declared} bytes) but holds only "
                         f"{max(present, 0)} bytes of data (corrupt or truncated)")


def _numeric_array(arr: np.ndarray, what: str) -> np.ndarray:
    """``arr`` if it holds integers or floats, else an :class:`InputError` naming ``what``."""
    if arr.dtype.kind not in "iuf":
        raise InputError(f"{what} has dtype {arr.dtype}; expected numbers")
    return arr


def _variables_first(arr: np.ndarray, what: str) -> np.ndarray:
    """A 2-D array as (k, N) with k = 2…4 variables (time first)."""
    if arr.ndim == 2 and arr.shape[0] in (2, 3, 4) and arr.shape[1] not in (2, 3, 4):
        return arr
    if arr.ndim == 2 and arr.shape[1] in (2, 3, 4):
        return arr.T
    raise InputError(
        f"{what} has shape {arr.shape}; expected (2, N) time + acceleration or (4, N) time + x, y, z (or transposed)"
    )


def _array_columns(rows: np.ndarray) -> list[str]:
    """Column names for a (k, N) array: time then a / x, y, z / a1, a2."""
    n_acc = rows.shape[0] - 1
    return ["time"] + (["a"] if n_acc == 1 else ["x", "y", "z"] if n_acc == 3 else [f"a{i + 1}" for i in range(n_acc)])


def npy_table(data: bytes, name: str) -> Table:
    """An .npy array of shape (k, N) or (N, k): time, then acceleration."""
    check_npy_header(io.BytesIO(data), len(data), "the array")
    arr = _numeric_array(_load_numpy(data, ".npy"), "the array")
    rows = _variables_first(arr, "the array")
    columns = _array_columns(rows)
    frame = pd.DataFrame(dict(zip(columns, rows)))
    notes = [f"array of shape {arr.shape}: {', '.join(columns)} (time first)"]
    return Table(frame, True, "npy", name, notes)


def _npz_table(data: bytes, name: str, zf: zipfile.ZipFile) -> Table:
    """An .npz archive: named arrays (t/time, a/acc/x/y/z…) or the first two arrays."""
    for info in zf.infolist():  # every header checked before np.load allocates an array
        if info.filename.endswith(".npy"):
            with zf.open(info) as fp:
                check_npy_header(fp, info.file_size, f"array {info.filename[:-4]!r}")
    with _load_numpy(data, ".npz") as npz:
        try:
            loaded = {key: npz[key] for key in npz.files}
        except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
            raise InputError(f"has an unreadable array ({' '.join(str(exc).split())})") from None
    arrays = {key: _numeric_array(arr, f"array {key!r}") for key, arr in loaded.items()}
    if not arrays:
        raise InputError("is an .npz archive without arrays")
    if len(arrays) == 1:
        key, arr = next(iter(arrays.items()))
        rows = _variables_first(arr, f"array {key!r}")
        columns = _array_columns(rows)
        frame = pd.DataFrame(dict(zip(columns, rows)))
        return Table(frame, True, "npz", name, [f"array {key!r} of shape {arr.shape}: {', '.join(columns)}"])
    time_key = next((k for k in arrays if role(k) == "time"), next(iter(arrays)))
    n = arrays[time_key].size
    columns: dict[str, np.ndarray] = {}
    ignored = []
    for key, arr in arrays.items():
        if arr.ndim == 1 and arr.size == n:
            columns[key] = arr
        elif arr.ndim == 2 and n in arr.shape:
            block = arr if arr.shape[0] == n else arr.T
            suffixes = "xyz" if block.shape[1] == 3 else [str(i + 1) for i in range(block.shape[1])]
            for suffix, col in zip(suffixes, block.T):
                columns[f"{key}_{suffix}"] = col
        else:
            ignored.append(f"{key!r} {arr.shape}")
    notes = [f"ignored arrays not matching {n} time stamps: {', '.join(ignored)}"] if ignored else []
    frame = pd.DataFrame(columns)
    return Table(frame, True, "npz", name, notes, positional_fallback=True)
