"""File readers: an accelerometer recording on disk → :class:`~dampfit.io.recording.Recording`.

:func:`read` detects the format from the file's extension *and* its content (magic bytes,
header line, column names), never from the file name alone, and returns a validated
:class:`~dampfit.io.recording.Recording` with time [s], acceleration [m/s²], the axis names,
``gravity_removed`` and human-readable ``notes`` of every assumption and conversion.
:func:`detect_format` returns the format name only.

Formats (``Recording.format``)
------------------------------
``"phyphox-csv"``
    phyphox CSV export (``Raw Data.csv``, ``Accelerometer.csv``, ``Linear Acceleration.csv``):
    quoted header ``"Time (s)","Acceleration x (m/s^2)",…`` (or ``Linear Acceleration x``,
    ``(m/s²)``), in all three phyphox dialects: comma + decimal point, tab + decimal point,
    semicolon + decimal comma. The ``Absolute acceleration`` column is dropped. Also the
    renamed header ``"time","linear_acceleration_x",…,"absolute_acceleration"``.
``"phyphox-zip"``
    phyphox ZIP export (CSV files plus ``meta/``). The member used is, in this order,
    ``Linear Acceleration.csv``, ``Accelerometer.csv``, ``Raw Data.csv``, else the only CSV
    with acceleration columns.
``"phyphox-xlsx"``
    phyphox Excel export, one sheet per data set; ``sheet=`` picks one (other workbooks
    read as ``"generic-xlsx"``). Old ``.xls`` needs the optional ``xlrd`` package.
``"sensor-logger"``
    Sensor Logger CSV (``time`` [ns since epoch], ``seconds_elapsed`` [s], ``z``, ``y``,
    ``x`` [m/s²]); time is ``seconds_elapsed``.
``"generic-csv"``
    Any delimited text (comma, semicolon, tab, ``|`` or whitespace; decimal comma; optional
    header; ``#`` comment lines). Columns and units come from the header where written
    (``Time (ms)``, ``acc [g]``, ``micros`` …), else from the data (see below), or from the
    options ``time_column``, ``accel_columns``, ``time_unit``, ``accel_unit``.
``"matlab"``
    MATLAB ``.mat`` files, v4–v7 and v7.3 (HDF5): one numeric variable, found through structs
    or named by ``variable="Fe.Out.Acc"``, with a time row, a sibling time vector or sample
    rate; ``row=`` picks the acceleration row (:mod:`dampfit.io.matlab`).
``"npy"`` / ``"npz"``
    NumPy arrays: ``.npy`` of shape (2, N) / (N, 2) = time, acceleration or (4, N) / (N, 4)
    = time, x, y, z; ``.npz`` with arrays named like ``t``/``time`` and ``a``/``acc``/``x``…
    (else the first array is time and the others acceleration).

Unit inference when a unit is neither written nor given
-------------------------------------------------------
* Time: the unit (s, ms, µs, ns) whose median step gives a plausible sample rate
  (1 Hz–100 kHz); non-integer stamps prefer s, integer stamps (``millis()``, ``micros()``,
  epoch ns) the unit nearest a few hundred Hz.
* Acceleration: g if the data clearly look like g (mean vector of three axes of magnitude
  ≈ 1, or a single axis with a static mean ≈ ±1, and peak |a| < 20); m/s² if they cannot be g
  (peak > 20 or |mean| > 2); otherwise the format's default: m/s² for text tables, g for
  NumPy arrays (raw arrays come from MEMS logging scripts, which report g).

Limits on hostile input
-----------------------
Only regular files are read (symlinks are resolved first); FIFOs, devices, sockets and
directories are refused before they are opened, so a ``/dev/zero`` link or a named pipe can
neither block nor read forever. Files larger than :data:`MAX_INPUT_BYTES` are refused. ZIP
members (phyphox ZIP, ``.xlsx``, ``.npz``) are checked from the archive directory *before*
anything is decompressed: at most :data:`MAX_UNPACKED_BYTES` in total and a compression ratio of
at most :data:`MAX_ZIP_RATIO` for members over 1 MiB (a zip bomb); ``.npy`` headers are checked
(declared shape × item size against the data present and the limit, no object arrays or
pickles) before an array is allocated. Text lines may be at most :data:`MAX_LINE_BYTES` long
and tables at most :data:`MAX_COLUMNS` wide and :data:`MAX_ROWS` long, checked before parsing. Line endings ``\r\n`` and
lone ``\r`` (old Mac) are read as ``\n``; UTF-16 text with a byte-order mark is decoded.

Every unusable input raises :class:`~dampfit.errors.InputError` with a one-line message
that starts with the file name.
"""

from __future__ import annotations

import csv
import hashlib
import io
import math
import os
import re
import stat
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dampfit.io import matlab as matfile
from dampfit._files import read_bounded
from dampfit.errors import InputError
from dampfit.io.recording import STANDARD_GRAVITY, Recording, gap_summary, time_segments

__all__ = ["read", "detect_format", "MAX_INPUT_BYTES", "MAX_UNPACKED_BYTES", "MAX_ZIP_RATIO",
           "MAX_LINE_BYTES", "MAX_COLUMNS", "MAX_ROWS"]

Column = str | int

# -- units -----------------------------------------------------------------------------

#: Seconds per unit of time.
_TIME_FACTORS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Integer ticks per second, for exact conversion of integer stamps.
_TICKS: dict[str, int] = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}
_TIME_LABELS = {"s": "s", "ms": "ms", "us": "µs", "ns": "ns"}
_TIME_ALIASES: dict[str, str] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millis", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "usec", "micros", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanos", "nanosecond", "nanoseconds"), "ns"),
}
#: m/s² per unit of acceleration.
_ACCEL_FACTORS: dict[str, float] = {"m/s2": 1.0, "g": STANDARD_GRAVITY, "mg": STANDARD_GRAVITY / 1000}
_ACCEL_LABELS = {"m/s2": "m/s²", "g": "g", "mg": "mg"}
_ACCEL_ALIASES: dict[str, str] = {
    **dict.fromkeys(
        ("m/s2", "m/s^2", "m/s²", "m/s/s", "ms^-2", "ms-2", "m s^-2", "m*s^-2", "mps2", "ms2"),
        "m/s2",
    ),
    **dict.fromkeys(("g", "g0", "gee"), "g"),
    **dict.fromkeys(("mg", "milli-g"), "mg"),
}

#: Plausible sample rates [Hz] for time-unit inference, and the typical rate for ties.
_RATE_RANGE = (1.0, 1e5)
_TYPICAL_RATE = 300.0
#: Largest |a| that can still be g from a MEMS sensor (full scale ≤ ±16 g) [g].
_MAX_G = 20.0

# -- limits on hostile input -------------------------------------------------------------

#: Largest input file [bytes] read at all (1 GiB: ~25 million rows of phone CSV).
MAX_INPUT_BYTES = 1 << 30
#: Largest total decompressed size [bytes] of the ZIP members read (ZIP, xlsx, npz) and of an
#: array declared in an .npy header.
MAX_UNPACKED_BYTES = 1 << 30
#: Largest compression ratio (uncompressed / compressed) of a ZIP member over 1 MiB; text and
#: float arrays compress ≤ 20:1, a zip bomb of zeros ≈ 1000:1.
MAX_ZIP_RATIO = 200.0
_RATIO_MIN_BYTES = 1 << 20
#: Longest line [bytes] of a text table (a real row is < 1 KiB).
MAX_LINE_BYTES = 64 * 1024
#: Most columns of a text table.
MAX_COLUMNS = 1000
#: Most lines of a text table (11 hours at 500 Hz); bounds the parsed table's memory.
MAX_ROWS = 20_000_000
_LINE_CHUNK = 1 << 24

# -- file types ------------------------------------------------------------------------

_TEXT_EXTS = {".csv", ".txt", ".tsv", ".dat", ""}
_SUPPORTED_EXTS = _TEXT_EXTS | {".zip", ".xlsx", ".xlsm", ".xls", ".npy", ".npz", ".mat"}
_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")
_OLE_MAGIC = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"  # legacy .xls
#: Preferred acceleration data sets in a phyphox/Sensor Logger ZIP or workbook, best first.
_PREFERRED_SETS = ("linear acceleration", "accelerometer", "raw data")
#: Rows read to detect a format or choose a ZIP member.
_PEEK_ROWS = 5
_SNIFF_LINES = 50

# -- column names ----------------------------------------------------------------------

_PHYPHOX_TIME = re.compile(r"^time \(s\)$", re.I)
_PHYPHOX_ACCEL = re.compile(r"^(linear )?acceleration ([xyz]) \((?:m/s\^2|m/s²)\)$", re.I)
_PHYPHOX_ABS = re.compile(r"^absolute acceleration \((?:m/s\^2|m/s²)\)$", re.I)
_RENAMED_ACCEL = re.compile(r"^(linear_)?acceleration_([xyz])$", re.I)
_BRACKET_UNIT = re.compile(r"^(?P<base>.*?)\s*[(\[{]\s*(?P<unit>[^)\]}]*?)\s*[)\]}]\s*$")
_SUFFIX_UNIT = re.compile(r"^(?P<base>.+?)[\s_\-]+(?P<unit>[^\s_\-]+)$")
_DECIMAL_COMMA = re.compile(r"^[-+]?\d*,\d+(?:[eE][-+]?\d+)?$")
_TIME_WORDS = {"time", "timestamp", "timestamps", "t", "seconds", "sec", "secs", "elapsed",
               "millis", "micros", "nanos", "ms", "us", "ns", "zeit"}
_MAGNITUDE_WORDS = {"abs", "absolute", "norm", "magnitude", "mag", "resultant", "total"}
_ACCEL_NAMES = {"a", "ax", "ay", "az", "x", "y", "z"}
_ACCEL_PREFIXES = ("acc", "linearacc", "linacc", "useracc")


# =====================================================================================
# public API
# =====================================================================================


def read(
    path: str | Path,
    *,
    time_column: Column | None = None,
    accel_columns: Column | Sequence[Column] | None = None,
    time_unit: str | None = None,
    accel_unit: str | None = None,
    sheet: str | int | None = None,
    variable: str | None = None,
    row: int | None = None,
) -> Recording:
    """Read an accelerometer recording.

    Parameters
    ----------
    path
        The file (see the module docstring for the formats).
    time_column
        Time column by name or 0-based position; default: detected.
    accel_columns
        Acceleration column(s) by name or 0-based position; default: detected.
    time_unit
        Unit of the time column, one of ``s``, ``ms``, ``us``, ``µs``, ``ns``; default: from
        the header, else inferred from the step size.
    accel_unit
        Unit of the acceleration columns, one of ``m/s2``, ``m/s^2``, ``m/s²``, ``g``
        (or ``mg``); default: from the header, else inferred.
    sheet
        Worksheet of an Excel workbook by name or 0-based position.
    variable
        MATLAB file: the array to read, a dotted struct path such as ``"Fe.Out.Acc"``;
        default: detected (:mod:`dampfit.io.matlab`).
    row
        MATLAB file: 0-based row (variable) of that array holding the acceleration.

    Returns
    -------
    Recording
        Time [s], acceleration [m/s²], axes, format, ``gravity_removed``, notes, SHA-256.

    Raises
    ------
    InputError
        One line naming the file and the problem, for every file that cannot be used.
    """
    opts = _Options.make(time_column, accel_columns, time_unit, accel_unit, sheet, variable, row)
    p = Path(path)
    try:
        data = _read_bytes(p)
        table = _load_table(p, data, opts, nrows=None)
        return _to_recording(table, opts, p, hashlib.sha256(data).hexdigest())
    except InputError as exc:
        raise _located(p, exc) from None


def detect_format(path: str | Path) -> str:
    """The format :func:`read` would report for ``path``, e.g. ``"phyphox-csv"``.

    Only the first rows are parsed. Raises :class:`InputError` for unreadable files.
    """
    p = Path(path)
    try:
        table = _load_table(p, _read_bytes(p), _Options(), nrows=_PEEK_ROWS)
        return _format_name(table.source, _identify(table).kind)
    except InputError as exc:
        raise _located(p, exc) from None


# =====================================================================================
# internal data
# =====================================================================================


@dataclass(frozen=True)
class _Options:
    """Validated user options of :func:`read` (units canonical: s/ms/us/ns, m/s2/g/mg)."""

    time_column: Column | None = None
    accel_columns: tuple[Column, ...] | None = None
    time_unit: str | None = None
    accel_unit: str | None = None
    sheet: str | int | None = None
    variable: str | None = None
    row: int | None = None

    @classmethod
    def make(cls, time_column, accel_columns, time_unit, accel_unit, sheet, variable=None,
             row=None) -> _Options:
        if row is not None and (isinstance(row, bool) or not isinstance(row, int) or row < 0):
            raise InputError(f"row must be a 0-based row number, got {row!r}")
        if accel_columns is not None and isinstance(accel_columns, (str, int)):
            accel_columns = (accel_columns,)
        elif accel_columns is not None:
            accel_columns = tuple(accel_columns)
            if not accel_columns:
                raise InputError("accel_columns is empty; give at least one acceleration column")
        return cls(
            time_column=time_column,
            accel_columns=accel_columns,
            time_unit=None if time_unit is None else _canonical_unit(time_unit, _TIME_ALIASES, "time"),
            accel_unit=None if accel_unit is None else _canonical_unit(accel_unit, _ACCEL_ALIASES, "acceleration"),
            sheet=sheet,
            variable=variable,
            row=row,
        )


@dataclass
class _Table:
    """A parsed table before column selection.

    ``header`` tells whether the columns are names from the file (else positions).
    ``source`` is the container: ``text``, ``zip``, ``xlsx``, ``npy`` or ``npz``.
    ``name`` is the file, ZIP member or sheet name (Sensor Logger's sensor is in it).
    """

    frame: pd.DataFrame
    header: bool
    source: str
    name: str
    notes: list[str] = field(default_factory=list)
    positional_fallback: bool = False


@dataclass
class _Layout:
    """Which columns hold what, as recognised from the header (before user options)."""

    kind: str  # "phyphox", "sensor-logger" or "generic"
    time_col: Column | None
    accel_cols: list[Column]
    units: dict[Column, str] = field(default_factory=dict)  # units implied by the format
    gravity_removed: bool | None = None
    notes: list[str] = field(default_factory=list)


# =====================================================================================
# loading: bytes → _Table
# =====================================================================================


def _located(path: Path, exc: InputError) -> InputError:
    """``exc`` as a one-line message prefixed with the file name."""
    msg = " ".join(str(exc).split("\n"))
    return InputError(f"{path}: {msg}")


def _file_kind(mode: int) -> str | None:
    """What a non-regular file is, e.g. ``"a named pipe (FIFO)"``; None for a regular file."""
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return None if stat.S_ISREG(mode) else "not a regular file"


def _read_bytes(path: Path) -> bytes:
    """The file's bytes, after checking it exists, is a regular file (links resolved), has a
    supported type, is not empty and not larger than :data:`MAX_INPUT_BYTES`.

    The type is checked with ``stat`` before opening, and again on the open descriptor (opened
    non-blocking, so a FIFO swapped in between cannot block), and at most
    ``MAX_INPUT_BYTES + 1`` bytes are ever read.
    """
    try:
        info = os.stat(path)  # follows symlinks: the target is what would be read
    except FileNotFoundError:
        raise InputError("file not found" + (" (broken link)" if path.is_symlink() else "")) from None
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror or exc})") from None
    kind = _file_kind(info.st_mode)
    if kind == "a directory":
        raise InputError("is a directory, not a recording file")
    if kind is not None:
        via = " (via a symbolic link)" if path.is_symlink() else ""
        raise InputError(f"is {kind}{via}, not a regular file; only regular files are read")
    ext = path.suffix.lower()
    if ext not in _SUPPORTED_EXTS:
        supported = " ".join(sorted(e for e in _SUPPORTED_EXTS if e))
        raise InputError(f"unsupported file type {ext!r}; supported: {supported}")
    if info.st_size > MAX_INPUT_BYTES:
        raise InputError(f"is {info.st_size / 2**20:.0f} MiB, larger than the limit of "
                         f"{MAX_INPUT_BYTES / 2**20:.0f} MiB; split or decimate the recording")
    def still_regular(st: os.stat_result) -> None:  # replaced since the stat above?
        if _file_kind(st.st_mode) is not None:
            raise InputError("is not a regular file; only regular files are read")

    try:
        data = read_bounded(path, MAX_INPUT_BYTES, still_regular)
    except OSError as exc:
        raise InputError(f"cannot be read ({exc.strerror or exc})") from None
    if len(data) > MAX_INPUT_BYTES:
        raise InputError(f"is larger than the limit of {MAX_INPUT_BYTES / 2**20:.0f} MiB; "
                         "split or decimate the recording")
    if not data:
        raise InputError("is empty (0 bytes)")
    return data


def _load_table(path: Path, data: bytes, opts: _Options, nrows: int | None) -> _Table:
    """Dispatch on the content (magic bytes), checked against the extension."""
    ext = path.suffix.lower()
    if ext == ".mat" or matfile.is_mat(data):
        return _mat_table(data, path.name, opts)
    if opts.variable is not None or opts.row is not None:
        raise InputError("--variable and --row apply to MATLAB .mat files only")
    if data.startswith(_NPY_MAGIC):
        return _npy_table(data, path.name)
    if data.startswith(_ZIP_MAGICS):
        return _container_table(data, path.name, ext, opts, nrows)
    if data.startswith(_OLE_MAGIC) or ext == ".xls":
        return _xls_table(data, opts, nrows)
    if ext not in _TEXT_EXTS:
        raise InputError(f"is not a valid {ext} file (corrupt, truncated or wrongly named)")
    return _text_table(_decode(data), path.name, "text", nrows)


def _mat_table(data: bytes, name: str, opts: _Options) -> _Table:
    """One variable of a MATLAB file (:mod:`dampfit.io.matlab`) as a time + acceleration table."""
    mat = matfile.load(data, variable=opts.variable, row=opts.row, max_bytes=MAX_UNPACKED_BYTES)
    return _Table(pd.DataFrame(mat.columns), True, "matlab", name, list(mat.notes))


def _longest_line(data: bytes) -> int:
    """Length [bytes] of the longest line (``\n`` or ``\r`` ends a line), scanned in chunks;
    stops early once a line exceeds :data:`MAX_LINE_BYTES`."""
    longest, run = 0, 0  # run: the open line carried over from the previous chunk
    for start in range(0, len(data), _LINE_CHUNK):
        chunk = np.frombuffer(data, np.uint8, count=min(_LINE_CHUNK, len(data) - start), offset=start)
        ends = np.flatnonzero((chunk == 10) | (chunk == 13))
        if ends.size == 0:
            run += chunk.size
        else:
            inner = int(np.diff(ends).max()) - 1 if ends.size > 1 else 0
            longest = max(longest, run + int(ends[0]), inner)
            run = chunk.size - int(ends[-1]) - 1
        longest = max(longest, run)
        if longest > MAX_LINE_BYTES:
            break
    return longest

# -- text ------------------------------------------------------------------------------


def _decode(data: bytes) -> str:
    """Bytes → text (UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1) with ``\n`` line
    endings; reject binary junk and lines longer than :data:`MAX_LINE_BYTES` before parsing."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            data = data.decode("utf-16").encode("utf-8")
        except UnicodeDecodeError:
            raise InputError("is neither valid UTF-16 text (despite its byte-order mark) nor a table") from None
    if b"\x00" in data[:65536]:
        raise InputError("is binary, not a text table of time and acceleration")
    longest = _longest_line(data)
    if longest > MAX_LINE_BYTES:
        what = "has no line breaks" if len(data) == longest else "has a line"
        raise InputError(
            f"{what} over {MAX_LINE_BYTES // 1024} KiB long ({len(data) / 2**20:.3g} MiB file); "
            "a table of time and acceleration has one short row per sample"
        )
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    head = text[:65536]
    control = sum(1 for ch in head if (ch < " " and ch not in "\t\r\n") or "\x7f" <= ch <= "\x9f")
    if control > 0.01 * len(head):
        raise InputError("is binary, not a text table of time and acceleration")
    if "\r" in text:  # Windows \r\n and old-Mac lone \r line endings
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    rows = text.count("\n")
    if rows > MAX_ROWS:
        raise InputError(f"has {rows} lines, more than the limit of {MAX_ROWS}; split or decimate "
                         "the recording")
    return text


def _strip_comments(text: str) -> str:
    """Drop lines starting with ``#``."""
    if "#" not in text:
        return text
    return "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))


def _count_outside_quotes(line: str, char: str) -> int:
    """How often ``char`` occurs in ``line`` outside double quotes."""
    count, quoted = 0, False
    for ch in line:
        if ch == '"':
            quoted = not quoted
        elif ch == char and not quoted:
            count += 1
    return count


def _split(line: str, sep: str | None) -> list[str]:
    """Fields of one line under the separator ``sep`` (None: one field; ``\\s+``: whitespace)."""
    if sep is None:
        return [line]
    if sep == r"\s+":
        return line.split()
    return next(csv.reader([line], delimiter=sep, skipinitialspace=True), [])


def _is_number(token: str, decimal: str) -> bool:
    """True for a numeric or empty field."""
    token = token.strip().strip("\"'").strip()
    if not token:
        return True
    if decimal == ",":
        token = token.replace(",", ".")
    try:
        float(token)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class _Dialect:
    sep: str | None
    decimal: str
    header: bool


def _sniff(text: str) -> _Dialect:
    """Separator, decimal mark and header presence from the first lines."""
    lines: list[str] = []
    for line in io.StringIO(text):
        if line.strip():
            lines.append(line.rstrip("\r\n"))
            if len(lines) >= _SNIFF_LINES:
                break
    if not lines:
        raise InputError("contains no data (only blank or comment lines)")
    data_lines = lines[1:] or lines
    sep: str | None = None
    for candidate in ("\t", ";", ",", "|"):
        counts = {_count_outside_quotes(line, candidate) for line in data_lines}
        if len(counts) == 1 and counts.pop() > 0:
            sep = candidate
            break
    if sep is None:
        widths = {len(line.split()) for line in data_lines}
        if len(widths) == 1 and widths.pop() > 1:
            sep = r"\s+"
    decimal = "."
    if sep != ",":
        tokens = (tok.strip().strip('"') for line in data_lines for tok in _split(line, sep))
        if any(_DECIMAL_COMMA.match(tok) for tok in tokens):
            decimal = ","
    width = max(len(_split(line, sep)) for line in lines)
    if width > MAX_COLUMNS:
        raise InputError(f"has {width} columns (more than {MAX_COLUMNS}); expected a table of "
                         "time and acceleration")
    header = not all(_is_number(tok, decimal) for tok in _split(lines[0], sep))
    numeric_rows = [all(_is_number(t, decimal) for t in _split(line, sep)) for line in lines[header:]]
    if not any(numeric_rows):
        if header and len(lines) == 1:
            raise InputError("has a header but no data rows")
        raise InputError("contains no numeric data rows; expected a table of time and acceleration")
    return _Dialect(sep, decimal, header)


def _text_table(text: str, name: str, source: str, nrows: int | None) -> _Table:
    """Parse delimited text with pandas' C engine after sniffing the dialect ourselves."""
    text = _strip_comments(text)
    dialect = _sniff(text)
    notes = []
    if dialect.decimal == ",":
        sep_name = {"\t": "tab", ";": "semicolon", "|": "pipe", r"\s+": "whitespace"}.get(dialect.sep, "")
        notes.append(f"read as {sep_name}-separated text with decimal comma")
    try:
        frame = pd.read_csv(
            io.StringIO(text),
            sep=dialect.sep if dialect.sep is not None else ",",
            decimal=dialect.decimal,
            header=0 if dialect.header else None,
            skipinitialspace=True,
            index_col=False,
            nrows=nrows,
            engine="c",
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        detail = " ".join(str(exc).split())
        raise InputError(f"cannot be parsed as a table ({detail})") from None
    if dialect.header:
        frame.columns = [str(c).strip() for c in frame.columns]
        frame = _drop_empty_unnamed(frame)
    if frame.shape[0] == 0:
        raise InputError("has a header but no data rows")
    return _Table(frame, dialect.header, source, name, notes)


def _drop_empty_unnamed(frame: pd.DataFrame) -> pd.DataFrame:
    """Remove all-empty ``Unnamed: k`` columns left by trailing separators."""
    empty = [c for c in frame.columns if str(c).startswith("Unnamed: ") and frame[c].isna().all()]
    return frame.drop(columns=empty) if empty else frame


# -- ZIP / xlsx / npz containers -------------------------------------------------------


def _container_table(data: bytes, name: str, ext: str, opts: _Options, nrows: int | None) -> _Table:
    """A ZIP-based file: an xlsx workbook, an .npz archive or a phyphox/Sensor Logger ZIP."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            _check_zip(zf)
            members = zf.namelist()
            if "[Content_Types].xml" in members and any(m.startswith("xl/") for m in members):
                return _xlsx_table(data, opts, nrows)
            if ext == ".npz" or (members and all(m.endswith(".npy") for m in members)):
                return _npz_table(data, name, zf)
            return _zip_table(zf, nrows)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError):
        raise InputError(f"is not a valid {ext or 'zip'} archive (corrupt or truncated); export it again") from None
    except (NotImplementedError, RuntimeError) as exc:  # unsupported compression, encryption
        raise InputError(f"cannot be unpacked ({' '.join(str(exc).split())}); export it again without a password") from None


def _check_zip(zf: zipfile.ZipFile) -> None:
    """Refuse a zip bomb from the archive directory, before anything is decompressed: more
    than :data:`MAX_UNPACKED_BYTES` in total, or a member over 1 MiB compressed more than
    :data:`MAX_ZIP_RATIO`:1. (``zipfile`` never returns more than a member's declared size.)"""
    infos = zf.infolist()
    total = sum(i.file_size for i in infos)
    if total > MAX_UNPACKED_BYTES:
        raise InputError(
            f"would unpack to {total / 2**20:.0f} MiB, more than the limit of "
            f"{MAX_UNPACKED_BYTES / 2**20:.0f} MiB (a zip bomb?); refused before unpacking"
        )
    for info in infos:
        ratio = info.file_size / max(info.compress_size, 1)
        if info.file_size > _RATIO_MIN_BYTES and ratio > MAX_ZIP_RATIO:
            raise InputError(
                f"member {info.filename!r} would unpack {ratio:.0f}:1 to {info.file_size / 2**20:.0f} MiB "
                f"(more than {MAX_ZIP_RATIO:.0f}:1: a zip bomb?); refused before unpacking"
            )


def _zip_table(zf: zipfile.ZipFile, nrows: int | None) -> _Table:
    """The acceleration CSV of a phyphox (or Sensor Logger) ZIP export."""
    candidates = [
        m for m in zf.namelist()
        if m.lower().endswith((".csv", ".txt"))
        and "meta/" not in m.lower()
        and not m.startswith("__MACOSX")
    ]
    if not candidates:
        raise InputError("is a zip without CSV files; expected a phyphox or Sensor Logger export")

    def load(member: str, rows: int | None) -> _Table:
        try:
            text = _decode(zf.read(member))
        except InputError as exc:
            raise InputError(f"member {member!r} {exc}") from None
        return _text_table(text, Path(member).name, "zip", rows)

    by_name = {Path(m).stem.lower(): m for m in candidates}
    member = next((by_name[s] for s in _PREFERRED_SETS if s in by_name), None)
    if member is None:
        usable = []
        for m in candidates:
            try:
                if _looks_like_acceleration(load(m, _PEEK_ROWS)):
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


def _looks_like_acceleration(table: _Table) -> bool:
    """True if a table has a time and acceleration columns named as such (not just x/y/z)."""
    layout = _identify(table)
    if layout.time_col is None or not layout.accel_cols:
        return False
    if layout.kind == "phyphox":
        return True
    return "acc" in table.name.lower() or any("acc" in str(c).lower() for c in layout.accel_cols)


def _choose_sheet(names: list[str], opts: _Options, parse) -> str:
    """The worksheet to read: ``opts.sheet``, a preferred phyphox set, else the only acceleration sheet."""
    if opts.sheet is not None:
        if isinstance(opts.sheet, int) and not isinstance(opts.sheet, bool):
            if 0 <= opts.sheet < len(names):
                return names[opts.sheet]
        elif str(opts.sheet) in names:
            return str(opts.sheet)
        elif str(opts.sheet).strip().isdigit() and int(opts.sheet) < len(names):
            return names[int(opts.sheet)]
        listing = ", ".join(repr(n) for n in names)
        raise InputError(f"has no sheet {opts.sheet!r}; sheets: {listing}")
    by_name = {n.strip().lower(): n for n in names}
    for preferred in _PREFERRED_SETS:
        if preferred in by_name:
            return by_name[preferred]
    usable = [n for n in names if _looks_like_acceleration(parse(n, _PEEK_ROWS))]
    if len(usable) == 1 or (usable and len(names) == 1):
        return usable[0]
    if not usable and len(names) == 1:
        return names[0]
    listing = ", ".join(repr(n) for n in (usable or names))
    raise InputError(f"has no single acceleration sheet (sheets: {listing}); choose one with --sheet")


def _excel_table(data: bytes, opts: _Options, nrows: int | None, engine: str) -> _Table:
    """A worksheet of an Excel workbook as a table (header row = column names)."""
    book = pd.ExcelFile(io.BytesIO(data), engine=engine)

    def parse(sheet: str, rows: int | None) -> _Table:
        frame = pd.read_excel(book, sheet_name=sheet, header=0, nrows=rows)
        header = any(isinstance(c, str) and not _is_number(c, ".") for c in frame.columns)
        if header:
            frame.columns = [str(c).strip() for c in frame.columns]
            frame = _drop_empty_unnamed(frame)
        else:
            frame = pd.read_excel(book, sheet_name=sheet, header=None, nrows=rows)
        return _Table(frame, header, "xlsx", sheet)

    sheet = _choose_sheet(book.sheet_names, opts, parse)
    table = parse(sheet, nrows)
    if table.frame.shape[0] == 0:
        raise InputError(f"sheet {sheet!r} has a header but no data rows")
    table.notes.append(f"read sheet {sheet!r}")
    return table


def _xlsx_table(data: bytes, opts: _Options, nrows: int | None) -> _Table:
    """An .xlsx workbook via openpyxl."""
    from openpyxl.utils.exceptions import InvalidFileException

    try:
        return _excel_table(data, opts, nrows, "openpyxl")
    except InputError:
        raise
    except (zipfile.BadZipFile, InvalidFileException, KeyError, ValueError, OSError, EOFError) as exc:
        raise InputError(f"is not a readable xlsx workbook ({type(exc).__name__}); export it again") from None


def _xls_table(data: bytes, opts: _Options, nrows: int | None) -> _Table:
    """A legacy .xls workbook; needs the optional xlrd package."""
    try:
        import xlrd  # noqa: F401
    except ImportError:
        raise InputError(
            "is a legacy .xls workbook, which needs the xlrd package; export as .xlsx or CSV instead"
        ) from None
    try:
        return _excel_table(data, opts, nrows, "xlrd")
    except InputError:
        raise
    except (ValueError, KeyError, OSError, EOFError) as exc:
        raise InputError(f"is not a readable .xls workbook ({type(exc).__name__})") from None


# -- NumPy -----------------------------------------------------------------------------


def _load_numpy(data: bytes, what: str):
    """``np.load`` of bytes without pickles."""
    try:
        return np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"is not a readable {what} file ({' '.join(str(exc).split())})") from None


def _check_npy_header(fp, size: int, what: str) -> None:
    """Check an .npy header at ``fp`` before any array is allocated.

    ``size`` [bytes] is the whole .npy (header + data). Refuses object arrays (pickles) and a
    declared shape × item size beyond the bytes present or :data:`MAX_UNPACKED_BYTES`.
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
    if declared > MAX_UNPACKED_BYTES:
        raise InputError(f"{what} declares shape {tuple(shape)} = {declared / 2**20:.3g} MiB, more than "
                         f"the limit of {MAX_UNPACKED_BYTES / 2**20:.0f} MiB; refused before loading")
    if declared > present:
        raise InputError(f"{what} declares shape {tuple(shape)} ({declared} bytes) but holds only "
                         f"{max(present, 0)} bytes of data (corrupt or truncated)")


def _numeric_array(arr: np.ndarray, what: str) -> np.ndarray:
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


def _npy_table(data: bytes, name: str) -> _Table:
    """An .npy array of shape (k, N) or (N, k): time, then acceleration."""
    _check_npy_header(io.BytesIO(data), len(data), "the array")
    arr = _numeric_array(_load_numpy(data, ".npy"), "the array")
    rows = _variables_first(arr, "the array")
    columns = _array_columns(rows)
    frame = pd.DataFrame(dict(zip(columns, rows)))
    notes = [f"array of shape {arr.shape}: {', '.join(columns)} (time first)"]
    return _Table(frame, True, "npy", name, notes)


def _npz_table(data: bytes, name: str, zf: zipfile.ZipFile) -> _Table:
    """An .npz archive: named arrays (t/time, a/acc/x/y/z…) or the first two arrays."""
    for info in zf.infolist():  # every header checked before np.load allocates an array
        if info.filename.endswith(".npy"):
            with zf.open(info) as fp:
                _check_npy_header(fp, info.file_size, f"array {info.filename[:-4]!r}")
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
        return _Table(frame, True, "npz", name, [f"array {key!r} of shape {arr.shape}: {', '.join(columns)}"])
    time_key = next((k for k in arrays if _role(k) == "time"), next(iter(arrays)))
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
    return _Table(frame, True, "npz", name, notes, positional_fallback=True)


# =====================================================================================
# column recognition
# =====================================================================================


def _canonical_unit(unit: str, aliases: dict[str, str], what: str) -> str:
    key = str(unit).strip().lower().replace("μ", "µ")
    if key in aliases:
        return aliases[key]
    allowed = "s, ms, us, µs, ns" if what == "time" else "m/s2, m/s^2, m/s², g, mg"
    raise InputError(f"unknown {what} unit {unit!r}; use one of {allowed}")


def _split_name(name: Column) -> tuple[str, str | None]:
    """Column name → (base name, unit written in it or None): ``Time (ms)``, ``acc_g``…"""
    text = str(name).strip().strip('"').strip()
    match = _BRACKET_UNIT.match(text)
    if match:
        return match["base"], match["unit"]
    match = _SUFFIX_UNIT.match(text)
    if match:
        unit = match["unit"].lower().replace("μ", "µ")
        if unit in _TIME_ALIASES or unit in _ACCEL_ALIASES:
            return match["base"], match["unit"]
    return text, None


def _words(base: str) -> list[str]:
    return re.findall(r"[a-z]+", base.lower())


def _role(name: Column) -> str | None:
    """``"time"``, ``"accel"``, ``"magnitude"`` or None, judged from a column name."""
    words = _words(_split_name(name)[0])
    joined = "".join(words)
    if not words:
        return None
    if _TIME_WORDS.intersection(words) or "time" in joined:
        return "time"
    is_accel = joined in _ACCEL_NAMES or joined.startswith(_ACCEL_PREFIXES) or "acceleration" in joined
    if not is_accel:
        return None
    return "magnitude" if _MAGNITUDE_WORDS.intersection(words) else "accel"


def _header_unit(name: Column, aliases: dict[str, str]) -> str | None:
    """The unit (canonical) written in a column name, e.g. ``Time (ms)`` → ``ms``, ``micros`` → ``us``."""
    base, unit = _split_name(name)
    if unit is not None:
        return aliases.get(unit.strip().lower().replace("μ", "µ"))
    if aliases is _TIME_ALIASES:
        for word in _words(base):
            if word in _TIME_ALIASES and word != "s":
                return _TIME_ALIASES[word]
    return None


def _axis_from_name(name: Column) -> str | None:
    """``x``/``y``/``z`` if the column name says so (``Acceleration x``, ``ax``, ``accY``…)."""
    words = _words(_split_name(name)[0])
    if words and words[-1] in ("x", "y", "z"):
        return words[-1]
    match = re.fullmatch(r"(?:a|acc|accel|acceleration|linearacceleration)([xyz])", "".join(words))
    return match.group(1) if match else None


def _identify(table: _Table) -> _Layout:
    """Recognise the layout from the header (or positions when there is none)."""
    cols = list(table.frame.columns)
    if not table.header:
        n_acc = len(cols) - 1
        note = "no header: column 0 read as time" + (f", columns 1–{n_acc} as acceleration" if n_acc > 1 else ", column 1 as acceleration" if n_acc == 1 else "")
        return _Layout("generic", cols[0] if cols else None, cols[1:], notes=[note])
    return _phyphox_layout(cols) or _sensor_logger_layout(cols, table.name) or _generic_layout(cols, table)


def _phyphox_layout(cols: list) -> _Layout | None:
    """phyphox header, original (``Time (s)``, ``Acceleration x (m/s^2)``) or renamed (``time``, ``linear_acceleration_x``)."""
    notes: list[str] = []
    units: dict[Column, str] = {}
    time = [c for c in cols if _PHYPHOX_TIME.match(str(c))]
    accel = {c: m for c in cols if (m := _PHYPHOX_ACCEL.match(str(c)))}
    magnitude = [c for c in cols if _PHYPHOX_ABS.match(str(c))]
    if not (time and accel):
        time = [c for c in cols if str(c).lower() == "time"]
        accel = {c: m for c in cols if (m := _RENAMED_ACCEL.match(str(c)))}
        magnitude = [c for c in cols if str(c).lower() == "absolute_acceleration"]
        if not (time and accel):
            return None
        units = {time[0]: "s", **dict.fromkeys(accel, "m/s2")}
        notes.append("renamed phyphox header without units; read as s and m/s² like phyphox exports")
    linear = [bool(m.group(1)) for m in accel.values()]
    gravity = True if all(linear) else False if not any(linear) else None
    if gravity is False:
        notes.append(
            "gravity_removed=False presumed from the header 'Acceleration' (with g); "
            "phyphox's Spring experiment labels linear acceleration the same way"
        )
    if magnitude:
        notes.append(f"dropped column {magnitude[0]!r} (magnitude, not an axis)")
    return _Layout("phyphox", time[0], list(accel), units, gravity, notes)


def _sensor_logger_layout(cols: list, name: str) -> _Layout | None:
    """Sensor Logger CSV: ``time`` [ns], ``seconds_elapsed`` [s], ``z``, ``y``, ``x`` [m/s²]."""
    lower = {str(c).strip().lower(): c for c in cols}
    if "seconds_elapsed" not in lower or not {"x", "y", "z"} <= lower.keys():
        return None
    time = lower["seconds_elapsed"]
    accel = [lower[a] for a in ("x", "y", "z")]
    notes = ["time from 'seconds_elapsed' (the epoch 'time' column is ignored)"]
    sensor = Path(name).stem.lower().replace(" ", "")
    if sensor.startswith("totalacceleration") or sensor.startswith("accelerometeruncalibrated"):
        gravity = False
    elif sensor.startswith("accelerometer"):
        gravity = True
        notes.append("Sensor Logger's Accelerometer is without gravity (gravity_removed=True)")
    elif sensor.startswith("gravity"):
        gravity = False
        notes.append("this is Sensor Logger's gravity estimate, not the motion; use Accelerometer.csv")
    else:
        gravity = None
        notes.append(f"Sensor Logger sensor unknown from the name {name!r}; gravity_removed unknown")
    return _Layout("sensor-logger", time, accel, {time: "s", **dict.fromkeys(accel, "m/s2")}, gravity, notes)


def _generic_layout(cols: list, table: _Table) -> _Layout:
    """Any header: time- and acceleration-like names; npz falls back to positions."""
    roles = {c: _role(c) for c in cols}
    times = [c for c in cols if roles[c] == "time"]
    time = next((c for c in times if "elapsed" in str(c).lower()), times[0] if times else None)
    accel = [c for c in cols if roles[c] == "accel"]
    notes = []
    if (time is None or not accel) and table.positional_fallback and len(cols) >= 2:
        time, accel = cols[0], cols[1:]
        notes.append(f"array names not recognised; {time!r} read as time, the rest as acceleration")
    magnitude = [c for c in cols if roles[c] == "magnitude" and c not in accel]
    if magnitude:
        notes.append(f"dropped {', '.join(repr(c) for c in magnitude)} (magnitude, not an axis)")
    ignored = [c for c in cols if c != time and c not in accel and c not in magnitude]
    if ignored and time is not None and accel:
        notes.append(f"ignored columns {', '.join(repr(str(c)) for c in ignored)}")
    gravity = True if accel and all("linear" in str(c).lower() for c in accel) else None
    return _Layout("generic", time, accel, gravity_removed=gravity, notes=notes)


# =====================================================================================
# table → Recording
# =====================================================================================


def _format_name(source: str, kind: str) -> str:
    if source in ("npy", "npz", "matlab"):
        return source
    if kind == "phyphox":
        return {"text": "phyphox-csv", "zip": "phyphox-zip", "xlsx": "phyphox-xlsx"}[source]
    if kind == "sensor-logger":
        return "sensor-logger"
    return "generic-xlsx" if source == "xlsx" else "generic-csv"


def _column_listing(table: _Table) -> str:
    cols = list(table.frame.columns)
    if not table.header:
        return f"0–{len(cols) - 1} (by position; the file has no header)"
    return ", ".join(repr(str(c)) for c in cols)


def _lookup(table: _Table, key: Column) -> Column:
    """A column by name (exact, then case-insensitive) or 0-based position."""
    cols = list(table.frame.columns)
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if 0 <= key < len(cols):
            return cols[int(key)]
        raise InputError(f"column index {key} is out of range; available columns: {_column_listing(table)}")
    wanted = str(key).strip()
    for match in (lambda c: str(c).strip() == wanted, lambda c: str(c).strip().lower() == wanted.lower()):
        found = [c for c in cols if match(c)]
        if found:
            return found[0]
    if wanted.isdigit():
        return _lookup(table, int(wanted))
    raise InputError(f"column {str(key)!r} not found; available columns: {_column_listing(table)}")


def _select(table: _Table, layout: _Layout, opts: _Options) -> tuple[Column, list[Column]]:
    """Time and acceleration columns: user options, else the recognised layout."""
    time = _lookup(table, opts.time_column) if opts.time_column is not None else layout.time_col
    if opts.accel_columns is not None:
        accel = [_lookup(table, c) for c in opts.accel_columns]
    elif opts.time_column is not None and layout.kind == "generic" and not table.header:
        accel = [c for c in table.frame.columns if c != time]
    else:
        accel = [c for c in layout.accel_cols if c != time]
    if len(table.frame.columns) < 2:
        raise InputError("has only one column; need a time column and at least one acceleration column")
    if time is None or not accel:
        missing = " or ".join(w for w, bad in (("time", time is None), ("acceleration", not accel)) if bad)
        raise InputError(
            f"no {missing} column recognised among columns {_column_listing(table)}; "
            "name them with --time-column/--accel-columns"
        )
    if time in accel:
        raise InputError(f"column {str(time)!r} cannot be both time and acceleration")
    return time, accel


def _axis_names(table: _Table, accel: list[Column]) -> list[str]:
    """``x``/``y``/``z`` where the columns say so, else the column names (``a`` for one unnamed)."""
    if not table.header:
        return ["a"] if len(accel) == 1 else ["x", "y", "z"] if len(accel) == 3 else [f"a{i + 1}" for i in range(len(accel))]
    names = [_axis_from_name(c) or str(c).strip() for c in accel]
    if len(set(names)) < len(names):
        names = [str(c).strip() for c in accel]
    return names


def _values(table: _Table, col: Column) -> np.ndarray:
    """A column as a numeric array (integers kept for exact time conversion)."""
    series = table.frame[col]
    if pd.api.types.is_numeric_dtype(series) and not pd.api.types.is_bool_dtype(series):
        return series.to_numpy()
    converted = pd.to_numeric(series, errors="coerce")
    text = series.astype("string").str.strip()
    bad = converted.isna() & series.notna() & (text != "")
    if bad.any():
        row = int(np.argmax(bad.to_numpy()))
        raise InputError(f"column {str(col)!r} has a non-numeric value {str(series.iloc[row])!r} in data row {row + 1}")
    return converted.to_numpy(dtype=np.float64, na_value=np.nan)


def _infer_time_unit(raw: np.ndarray) -> tuple[str, str]:
    """(unit, note) from the median time step: a plausible sample rate (1 Hz–100 kHz)."""
    steps = np.diff(raw.astype(np.float64))
    steps = steps[steps > 0]
    if steps.size == 0:
        return "s", "time unit not given; assumed s"
    step = float(np.median(steps))
    rate = {u: 1.0 / (step * f) for u, f in _TIME_FACTORS.items()}
    plausible = [u for u in _TIME_FACTORS if _RATE_RANGE[0] <= rate[u] <= _RATE_RANGE[1]]
    if not plausible:
        raise InputError(
            f"cannot infer the time unit: a median step of {step:g} gives no sample rate between "
            "1 Hz and 100 kHz in s, ms, µs or ns; pass --time-unit"
        )
    integer = bool(np.all(raw == np.round(raw)))
    if "s" in plausible and not integer:
        unit = "s"
    else:
        unit = min(plausible, key=lambda u: abs(np.log10(rate[u] / _TYPICAL_RATE)))
    return unit, (
        f"time unit not given; assumed {_TIME_LABELS[unit]} from the median step {step:g} "
        f"({rate[unit]:.4g} Hz){'' if unit == 's' else ', converted to s'}; pass --time-unit to override"
    )


def _to_seconds(raw: np.ndarray, unit: str) -> np.ndarray:
    """Time [s]; integer stamps (epoch ns, micros()) are split exactly before the float conversion."""
    if raw.dtype.kind in "iu" and unit != "s":
        whole, rest = np.divmod(raw.astype(np.int64), _TICKS[unit])
        return whole.astype(np.float64) + rest.astype(np.float64) / _TICKS[unit]
    return raw.astype(np.float64) * _TIME_FACTORS[unit]


def _infer_accel_unit(block: np.ndarray, default: str) -> tuple[str, str]:
    """(unit, note) for acceleration [n, k] without a written unit."""
    finite = block[np.isfinite(block).all(axis=1)]
    if finite.size == 0:
        return default, f"acceleration unit not given; assumed {_ACCEL_LABELS[default]}"
    mean = finite.mean(axis=0)
    peak = float(np.abs(finite).max())
    override = "; pass --accel-unit to override"
    if peak > _MAX_G or float(np.abs(mean).max()) > 2.0:
        return "m/s2", (
            f"acceleration unit not given; assumed m/s² (mean {float(np.abs(mean).max()):.3g}, "
            f"peak {peak:.3g}: too large for g){override}"
        )
    if finite.shape[1] >= 3 and 0.7 <= float(np.linalg.norm(mean)) <= 1.3:
        return "g", f"acceleration unit not given; assumed g (the mean vector has magnitude {np.linalg.norm(mean):.3g}, gravity in g){override}"
    if finite.shape[1] < 3 and np.any((np.abs(mean) >= 0.5) & (np.abs(mean) <= 1.5)):
        return "g", f"acceleration unit not given; assumed g (static mean {mean[np.argmax(np.abs(mean))]:.3g} ≈ ±1, gravity in g){override}"
    return default, (
        f"acceleration unit not given and ambiguous (mean {float(np.abs(mean).max()):.3g}, peak {peak:.3g}); "
        f"assumed {_ACCEL_LABELS[default]}{override}"
    )


def _time_axis(table: _Table, layout: _Layout, col: Column, opts: _Options) -> tuple[np.ndarray, list[str], str, str]:
    """Time [s] of column ``col``, notes on its unit, the unit and where it came from
    (``given``, ``header``, ``format`` or ``inferred``)."""
    raw = _values(table, col)
    if opts.time_unit is not None:
        unit, source = opts.time_unit, "as given"
    elif (unit := _header_unit(col, _TIME_ALIASES) if table.header else None) is not None:
        source = "from the header"
    elif col in layout.units:
        unit, source = layout.units[col], "format default"
    else:
        unit, note = _infer_time_unit(raw[np.isfinite(raw)] if raw.dtype.kind == "f" else raw)
        return _to_seconds(raw, unit), [note], unit, "inferred"
    notes = [f"time converted from {_TIME_LABELS[unit]} to s ({source})"] if unit != "s" else []
    origin = {"as given": "given", "from the header": "header", "format default": "format"}[source]
    return _to_seconds(raw, unit), notes, unit, origin


def _accel_block(table: _Table, layout: _Layout, cols: list[Column], opts: _Options) -> tuple[np.ndarray, list[str]]:
    """Acceleration [m/s²] of columns ``cols`` and notes on their units."""
    block = np.column_stack([_values(table, c).astype(np.float64) for c in cols])
    units: list[tuple[str, str]] = []
    for col in cols:
        if opts.accel_unit is not None:
            units.append((opts.accel_unit, "as given"))
        elif table.header and (unit := _header_unit(col, _ACCEL_ALIASES)) is not None:
            units.append((unit, "from the header"))
        elif col in layout.units:
            units.append((layout.units[col], "format default"))
        else:
            units.append(("", ""))
    notes = []
    unknown = [i for i, (u, _) in enumerate(units) if not u]
    if unknown:
        default = "g" if table.source in ("npy", "npz") else "m/s2"
        unit, note = _infer_accel_unit(block[:, unknown], default)
        notes.append(note)
        for i in unknown:
            units[i] = (unit, "inferred")
    for unit, source in dict.fromkeys(units):
        if unit != "m/s2":
            which = [str(c) for c, u in zip(cols, units) if u == (unit, source)]
            scope = f" ({', '.join(which)})" if len(set(units)) > 1 else ""
            notes.append(
                f"acceleration{scope} converted from {_ACCEL_LABELS[unit]} to m/s² "
                f"(× {_ACCEL_FACTORS[unit]:g}, unit {source})"
            )
    factors = np.array([_ACCEL_FACTORS[u] for u, _ in units])
    return block * factors, notes


def _to_recording(table: _Table, opts: _Options, path: Path, sha256: str) -> Recording:
    """Select, convert and validate: the final step of every reader."""
    layout = _identify(table)
    time_col, accel_cols = _select(table, layout, opts)
    axes = _axis_names(table, accel_cols)
    if set(axes) <= {"x", "y", "z"}:
        order = sorted(range(len(axes)), key=lambda i: axes[i])
        axes, accel_cols = [axes[i] for i in order], [accel_cols[i] for i in order]
    time, time_notes, time_unit, time_source = _time_axis(table, layout, time_col, opts)
    accel, accel_notes = _accel_block(table, layout, accel_cols, opts)
    notes = list(table.notes) + list(layout.notes)
    if layout.kind == "generic" and table.header:
        notes.append(f"time from column {str(time_col)!r}; acceleration from {', '.join(repr(str(c)) for c in accel_cols)}")
    segments = time_segments(time)
    if len(segments) > 1:
        time_notes.append(gap_summary(time, segments))
    return Recording(
        time=time,
        accel=accel,
        axes=tuple(axes),
        path=str(path),
        format=_format_name(table.source, layout.kind),
        gravity_removed=layout.gravity_removed,
        notes=tuple(notes + time_notes + accel_notes),
        sha256=sha256,
        time_unit=time_unit,
        time_unit_source=time_source,
    )
