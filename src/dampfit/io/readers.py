"""File readers: an accelerometer recording on disk → :class:`~dampfit.io.recording.Recording`.

This module holds the entry points, the options, the dispatch on the file's content and the
final step from a parsed table to a ``Recording``; the work is done by
:mod:`~dampfit.io.bounded` (limits, bounded reading, decoding), :mod:`~dampfit.io.text`
(delimited text), :mod:`~dampfit.io.containers` (ZIP, Excel, NumPy),
:mod:`~dampfit.io.matlab` (.mat), :mod:`~dampfit.io.columns` (which column is what) and
:mod:`~dampfit.io.units` (units of time [s] and acceleration [m/s²]).

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
``"logger-pro-txt"``
    Vernier Logger Pro text export (``Vernier Format 2``, title, data set name, long names,
    short names, units, then tab-separated data; :mod:`dampfit.io.labexports`).
``"graphical-analysis-csv"`` / ``"capstone-csv"``
    Vernier Graphical Analysis (``"Run 1: Time (s)"``) and PASCO Capstone (``"Time (s) Run
    #1"``) CSV exports. With several runs side by side the first is read, or the one named by
    ``run=`` (a note names the others).
``"matlab"``
    MATLAB ``.mat`` files, v4–v7 and v7.3 (HDF5): one numeric variable, found through structs
    or named by ``variable="Fe.Out.Acc"``, with a time row, a sibling time vector or sample
    rate; ``row=`` picks the acceleration row, which is required when the variable has
    several data rows (:mod:`dampfit.io.matlab`).
``"lvm"`` / ``"tdms"`` / ``"uff58"``
    LabVIEW Measurement ``.lvm``, NI ``.tdms`` (``group=``, ``channel=``) and UFF data set 58
    ``.uff``/``.unv`` (``row=`` picks the record) through lvm-read, npTDMS and pyuff, optional
    extras (:mod:`dampfit.io.daq`).
``"npy"`` / ``"npz"``
    NumPy arrays: ``.npy`` of shape (2, N) / (N, 2) = time, acceleration or (4, N) / (N, 4)
    = time, x, y, z; ``.npz`` with arrays named like ``t``/``time`` and ``a``/``acc``/``x``…
    (else the first array is time and the others acceleration).

No time column, and a logger's preamble
---------------------------------------
``rate=`` [Hz] gives the time of a table without a time column (``i / rate``); ``channel=``
names its acceleration column. A data logger's settings lines before the table (CONTEC,
Graphtec …) are skipped with a note (:mod:`dampfit.io.preamble`). Time stamps that repeat
split the recording into segments (the longest is analysed); time that goes backwards keeps
its longest run (:func:`dampfit.io.recording.untangle`).

Empty cells
-----------
Rows at the start or end of the table with an empty (or NaN) time or acceleration cell — a
run shorter than the others, a logger that wrote its first values late — are dropped with a
note. Empty cells inside the data are an error naming the first one, unless ``window=`` (the
analysis window [s]) leaves them out: rows with empty cells outside it are then dropped with
a note. Position- or velocity-only files (a motion detector) are refused with that reason.

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
neither block nor read forever. The limits live in :mod:`dampfit.io.bounded`: files larger
than :data:`~dampfit.io.bounded.MAX_INPUT_BYTES` are refused. ZIP members (phyphox ZIP,
``.xlsx``, ``.npz``) are checked from the archive directory *before* anything is
decompressed: at most :data:`~dampfit.io.bounded.MAX_UNPACKED_BYTES` in total and a
compression ratio of at most :data:`~dampfit.io.bounded.MAX_ZIP_RATIO` for members over 1 MiB
(a zip bomb); ``.npy`` headers are checked (declared shape × item size against the data
present and the limit, no object arrays or pickles) before an array is allocated. Text lines
may be at most :data:`~dampfit.io.bounded.MAX_LINE_BYTES` long and tables at most
:data:`~dampfit.io.bounded.MAX_COLUMNS` wide and :data:`~dampfit.io.bounded.MAX_ROWS` long,
checked before parsing. Line endings ``\r\n`` and lone ``\r`` (old Mac) are read as ``\n``;
UTF-16 text with a byte-order mark is decoded.

Every unusable input raises :class:`~dampfit.errors.InputError` with a one-line message
that starts with the file name.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from dampfit.errors import InputError
from dampfit.io import bounded
from dampfit.io import matlab as matfile
from dampfit.io.bounded import TEXT_EXTS, decode, read_bytes
from dampfit.io.columns import axis_names, identify, lookup, role, select
from dampfit.io.containers import container_table, npy_table, xls_table
from dampfit.io.daq import daq_kind, daq_table
from dampfit.io.preamble import strip_preamble
from dampfit.io.labexports import is_logger_pro, logger_pro_table, native_file_hint, split_runs
from dampfit.io.recording import Recording, gap_summary, untangle
from dampfit.io.text import PEEK_ROWS, Column, Table, text_table
from dampfit.io.units import ACCEL_ALIASES, TIME_ALIASES, accel_block, canonical_unit, time_axis

#: The reading options of :func:`read`, as recorded in ``Recording.read_options`` and
#: ``provenance.options`` (each is also a ``dampfit analyze`` option, ``_`` → ``-``).
READ_OPTIONS = ("time_column", "accel_columns", "time_unit", "accel_unit", "sheet", "variable",
                "row", "run", "rate", "group", "channel")
#: Largest --rate [Hz] (beyond any accelerometer DAQ).
MAX_RATE_HZ = 1e7

#: Magic bytes: NumPy .npy, ZIP (also .xlsx and .npz) and OLE2 (legacy .xls).
_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")
_OLE_MAGIC = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"  # legacy .xls


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
    run: str | int | None = None,
    window: tuple[float, float] | None = None,
    rate: float | None = None,
    group: str | None = None,
    channel: str | None = None,
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
        MATLAB file: 0-based row (variable) of that array holding the acceleration; UFF file:
        the 0-based data-set number of the UFF 58 record to read.
    run
        Lab export with several runs: the run to read, by label (``"Run #2"``, ``"Latest"``)
        or number (``2``); default: the first.
    window
        (start, end) [s] of the analysis window, if one will be given: rows with empty cells
        outside it are dropped instead of refused (module docstring, "Empty cells"). Not a
        reading option (it is recorded with the analysis options).
    rate
        Sample rate [Hz] of a table without a time column (a data logger's channels, a TDMS
        channel without waveform properties): time is ``i / rate``.
    group
        TDMS file: the group to read (default: the only one).
    channel
        The acceleration channel by name: of a TDMS group, an LVM file, or a table's column
        (as ``accel_columns=[channel]``); default: detected.

    Returns
    -------
    Recording
        Time [s], acceleration [m/s²], axes, format, ``gravity_removed``, notes, SHA-256,
        ``read_options`` (the options given, for provenance).

    Raises
    ------
    InputError
        One line naming the file and the problem, for every file that cannot be used.
    """
    p = Path(path)
    try:
        opts = _Options(time_column, accel_columns, time_unit, accel_unit, sheet, variable,
                        row, run, rate, group, channel)
        data = _read_input(p)
        table = _load_table(p, data, opts, nrows=None)
        return _to_recording(table, opts, p, hashlib.sha256(data).hexdigest(), _window(window))
    except InputError as exc:
        raise _located(p, exc) from None


def detect_format(path: str | Path) -> str:
    """The format :func:`read` would report for ``path``, e.g. ``"phyphox-csv"``.

    Only the first rows are parsed. Raises :class:`InputError` for unreadable files.
    """
    p = Path(path)
    try:
        table = _load_table(p, _read_input(p), _Options(), nrows=PEEK_ROWS)
        return _format_name(table, identify(table).kind)
    except InputError as exc:
        raise _located(p, exc) from None


@dataclass(frozen=True)
class _Options:
    """Validated user options of :func:`read` (units canonical: s/ms/us/ns, m/s2/g/mg),
    checked and normalised once, on construction."""

    time_column: Column | None = None
    accel_columns: tuple[Column, ...] | None = None
    time_unit: str | None = None
    accel_unit: str | None = None
    sheet: str | int | None = None
    variable: str | None = None
    row: int | None = None
    run: str | int | None = None
    rate: float | None = None
    group: str | None = None
    channel: str | None = None

    def __post_init__(self) -> None:
        row, run, accel_columns = self.row, self.run, self.accel_columns
        time_unit, accel_unit, group, channel = (self.time_unit, self.accel_unit, self.group,
                                                 self.channel)
        if row is not None and (isinstance(row, bool) or not isinstance(row, int) or row < 0):
            raise InputError(f"row must be a 0-based row number, got {row!r}")
        if run is not None and (isinstance(run, bool) or not isinstance(run, (str, int))
                                or not str(run).strip()):
            raise InputError(f"run must be a run label such as 'Run #2' or a run number, "
                             f"got {run!r}")
        if accel_columns is not None and isinstance(accel_columns, (str, int)):
            accel_columns = (accel_columns,)
        elif accel_columns is not None:
            accel_columns = tuple(accel_columns)
            if not accel_columns:
                raise InputError("accel_columns is empty; give at least one acceleration column")
        normal = {
            "accel_columns": accel_columns,
            "time_unit": None if time_unit is None else canonical_unit(time_unit, TIME_ALIASES,
                                                                       "time"),
            "accel_unit": None if accel_unit is None else canonical_unit(accel_unit, ACCEL_ALIASES,
                                                                         "acceleration"),
            "rate": _rate(self.rate),
            "group": None if group is None else str(group),
            "channel": None if channel is None else str(channel),
        }
        for name, value in normal.items():
            object.__setattr__(self, name, value)

    def recorded(self) -> dict:
        """Every reading option (:data:`READ_OPTIONS`) as JSON-safe data, None where not given."""
        out = {k: getattr(self, k) for k in READ_OPTIONS}
        if out["accel_columns"] is not None:
            out["accel_columns"] = list(out["accel_columns"])
        return out


def _rate(rate) -> float | None:
    """``rate`` [Hz] checked: a finite number in (0, :data:`MAX_RATE_HZ`] (text from a
    masses.csv too)."""
    if rate is None:
        return None
    try:
        value = float(rate)
    except (TypeError, ValueError):
        raise InputError(f"rate must be a sample rate in Hz, got {rate!r}") from None
    if isinstance(rate, bool) or not (np.isfinite(value) and 0 < value <= MAX_RATE_HZ):
        raise InputError(f"rate must be a sample rate in Hz, above 0 and at most "
                         f"{MAX_RATE_HZ:g}, got {rate!r}")
    return value


def _window(window) -> tuple[float, float] | None:
    """``window`` = (start, end) [s] checked: two finite numbers, start < end."""
    if window is None:
        return None
    try:
        w0, w1 = (float(w) for w in window)
    except (TypeError, ValueError):
        raise InputError(f"window must be (start, end) in seconds, got {window!r}") from None
    if not (np.isfinite(w0) and np.isfinite(w1) and w0 < w1):
        raise InputError(f"window must be two finite times with start < end, got {window!r}")
    return w0, w1


def _read_input(path: Path) -> bytes:
    """:func:`~dampfit.io.bounded.read_bytes`; a native lab-software file (``.cmbl``,
    ``.gambl``, ``.cap``) that exists is refused with the export to use instead."""
    hint = native_file_hint(path.suffix)
    if hint is None:
        return read_bytes(path)
    try:
        read_bytes(path)
    except InputError as exc:
        if "unsupported file type" not in str(exc):
            raise  # missing, a FIFO or device, too large: that reason first
    raise InputError(f"is {hint}")


def _located(path: Path, exc: InputError) -> InputError:
    """``exc`` as a one-line message prefixed with the file name."""
    msg = " ".join(str(exc).split("\n"))
    return InputError(f"{path}: {msg}")


def _load_table(path: Path, data: bytes, opts: _Options, nrows: int | None) -> Table:
    """Dispatch on the content (magic bytes), checked against the extension."""
    ext = path.suffix.lower()
    kind = daq_kind(data, ext)
    if kind is not None:
        if opts.variable is not None or opts.sheet is not None or opts.run is not None:
            raise InputError("--variable, --sheet and --run do not apply to LVM, TDMS or UFF "
                             "files; choose with --group, --channel or --row")
        return daq_table(data, kind, path.name, group=opts.group, channel=opts.channel,
                         row=opts.row, rate=opts.rate, accel_unit=opts.accel_unit)
    if opts.group is not None:
        raise InputError("--group applies to TDMS files only")
    if ext == ".mat" or matfile.is_mat(data):
        if opts.run is not None:
            raise InputError("--run applies to lab exports with runs, not to MATLAB files; "
                             "choose the variable with --variable")
        return _mat_table(data, path.name, opts)
    if opts.variable is not None or opts.row is not None:
        raise InputError("--variable and --row apply to MATLAB .mat files only")
    if data.startswith(_NPY_MAGIC):
        table = npy_table(data, path.name)
    elif data.startswith(_ZIP_MAGICS):
        table = container_table(data, path.name, ext, opts.sheet, nrows)
    elif data.startswith(_OLE_MAGIC) or ext == ".xls":
        table = xls_table(data, opts.sheet, nrows)
    elif ext not in TEXT_EXTS:
        raise InputError(f"is not a valid {ext} file (corrupt, truncated or wrongly named)")
    else:
        text = decode(data)
        table = logger_pro_table(text, path.name, nrows) if is_logger_pro(text) else \
            _text_table(text, path.name, nrows)
    return split_runs(table, opts.run)


def _text_table(text: str, name: str, nrows: int | None) -> Table:
    """:func:`~dampfit.io.text.text_table`; text that is no table as it stands is tried once
    more without a data logger's preamble (:mod:`dampfit.io.preamble`)."""
    try:
        return text_table(text, name, "text", nrows)
    except InputError:
        stripped, note = strip_preamble(text)
        if note is None:
            raise
    table = text_table(stripped, name, "text", nrows)
    table.notes.insert(0, note)
    return table


def _mat_table(data: bytes, name: str, opts: _Options) -> Table:
    """One variable of a MATLAB file (:mod:`dampfit.io.matlab`) as a time + acceleration table."""
    mat = matfile.load(data, variable=opts.variable, row=opts.row, max_bytes=bounded.MAX_UNPACKED_BYTES)
    return Table(pd.DataFrame(mat.columns), True, "matlab", name, list(mat.notes))


def _format_name(table: Table, kind: str) -> str:
    """``Recording.format`` from the table's container (``text``, ``zip``, ``xlsx``, ``npy``,
    ``npz``, ``matlab``), the software that wrote it (``table.origin``) and the layout kind
    (``phyphox``, ``sensor-logger``, ``generic``)."""
    source = table.source
    if source in ("npy", "npz", "matlab", "lvm", "tdms", "uff58"):
        return source
    if table.origin == "logger-pro":
        return "logger-pro-txt"
    if table.origin is not None and source == "text":
        return f"{table.origin}-csv"
    if kind == "phyphox":
        return {"text": "phyphox-csv", "zip": "phyphox-zip", "xlsx": "phyphox-xlsx"}[source]
    if kind == "sensor-logger":
        return "sensor-logger"
    return "generic-xlsx" if source == "xlsx" else "generic-csv"


def _to_recording(table: Table, opts: _Options, path: Path, sha256: str,
                  window: tuple[float, float] | None = None) -> Recording:
    """Select, convert and validate: the final step of every reader."""
    layout = identify(table)
    wanted = opts.accel_columns
    if wanted is None and opts.channel is not None and table.layout is None:
        wanted = (opts.channel,)
    if opts.rate is not None and table.layout is None:
        time_col, accel_cols = _rate_columns(table, layout, opts.time_column, wanted)
    else:
        time_col, accel_cols = select(table, layout, opts.time_column, wanted)
    axes = axis_names(table, accel_cols)
    if set(axes) <= {"x", "y", "z"}:
        order = sorted(range(len(axes)), key=lambda i: axes[i])
        axes, accel_cols = [axes[i] for i in order], [accel_cols[i] for i in order]
    if time_col is None:  # --rate: time from the sample number
        time = np.arange(len(table.frame), dtype=np.float64) / opts.rate
        time_notes, time_unit, time_source = \
            [f"time from --rate {opts.rate:g} Hz (the table has no time column)"], "s", "given"
    else:
        time, time_notes, time_unit, time_source = time_axis(table, time_col, opts.time_unit,
                                                             layout.units)
    accel, accel_notes = accel_block(table, accel_cols, opts.accel_unit, layout.units)
    notes = list(table.notes) + list(layout.notes)
    if layout.kind == "generic" and table.header and table.layout is None and time_col is not None:
        notes.append(f"time from column {str(time_col)!r}; acceleration from {', '.join(repr(str(c)) for c in accel_cols)}")
    keep, empty_notes = _rows_to_keep(time, accel, window)
    if keep is not None:
        time, accel = time[keep], accel[keep]
    notes += empty_notes
    order, breaks, order_note = untangle(time)
    if order is not None:
        time, accel = time[order], accel[order]
        notes.append(order_note)
    rec = Recording(
        time=time,
        accel=accel,
        axes=tuple(axes),
        path=str(path),
        format=_format_name(table, layout.kind),
        gravity_removed=layout.gravity_removed,
        notes=tuple(notes + time_notes + accel_notes),
        sha256=sha256,
        time_unit=time_unit,
        time_unit_source=time_source,
        read_options=opts.recorded(),
        breaks=breaks,
    )
    return rec.with_notes(gap_summary(rec.time, rec.segments)) \
        if len(rec.segments) > 1 and not breaks else rec


def _rate_columns(table: Table, layout, time_column, wanted) -> tuple[None, list]:
    """Acceleration columns of a table read with ``rate=`` (time from the sample number): the
    named ones, else those named as acceleration, else the only column; a table with a time
    column, or several columns none of which says acceleration, is refused naming them."""
    if time_column is not None:
        raise InputError("--rate is for tables without a time column; give --time-column or "
                         "--rate, not both")
    if table.header and layout.time_col is not None and role(layout.time_col) == "time":
        raise InputError(f"has a time column {str(layout.time_col)!r}; --rate is for tables "
                         "without one (leave --rate out)")
    cols = list(table.frame.columns)
    if wanted is not None:
        return None, [lookup(table, c) for c in wanted]
    named = [c for c in cols if table.header and role(c) == "accel"]
    if named or len(cols) == 1:
        return None, named or cols
    listing = ", ".join(repr(str(c)) for c in cols[:12]) + (", …" if len(cols) > 12 else "")
    raise InputError(f"has {len(cols)} columns and none is named as acceleration ({listing}); "
                     "choose the channel with --channel NAME (or --accel-columns)")


def _rows_to_keep(time: np.ndarray, accel: np.ndarray, window: tuple[float, float] | None):
    """(row mask or None, notes): rows with an empty (NaN) time or acceleration cell are
    dropped at the start and end of the table, and outside ``window`` [s]; one inside the
    data (and the window) is an :class:`InputError` that names it and the fix. A table with
    no complete row is left to :class:`Recording`'s own check."""
    empty = np.isnan(time) | np.isnan(accel).any(axis=1)
    full = np.flatnonzero(~empty)
    if not empty.any() or full.size == 0:
        return None, []
    keep = np.zeros(time.size, dtype=bool)
    keep[full[0]:full[-1] + 1] = True
    notes = []
    lead, trail = int(full[0]), int(time.size - 1 - full[-1])
    if lead or trail:
        ends = " and ".join(_count(n, f"{where} row") for n, where in
                            ((lead, "leading"), (trail, "trailing")) if n)
        notes.append(f"dropped {ends} with empty cells (at the edges of the table)")
    inner = np.flatnonzero(empty & keep)
    if inner.size and window is not None:
        # a row's time, or for an empty time the times of the complete rows around it
        prev_t = time[full[np.searchsorted(full, inner) - 1]]
        next_t = time[full[np.searchsorted(full, inner)]]
        t_row = time[inner]
        outside = np.where(np.isnan(t_row), (next_t <= window[0]) | (prev_t >= window[1]),
                           (t_row < window[0]) | (t_row > window[1]))
        if outside.any():
            keep[inner[outside]] = False
            notes.append(f"dropped {_count(int(outside.sum()), 'row')} with empty cells outside "
                         f"the window {window[0]:g}–{window[1]:g} s")
        inner = inner[~outside]
    if inner.size:
        first = int(inner[0])
        which = "time" if np.isnan(time[first]) else "acceleration"
        count = int(np.isnan(time[inner]).sum() if which == "time"
                    else np.isnan(accel[inner]).sum())
        near = time[full[full < first][-1]]
        raise InputError(
            f"{which} has {_count(count, 'missing or non-finite value')} inside the data (first "
            f"at data row {first + 1}, after t = {near:g} s); fill or delete those rows, or "
            "give --window START END that leaves them out (rows with empty cells at the start "
            "or end are dropped by themselves)")
    return keep, notes


def _count(n: int, noun: str) -> str:
    """``"1 row"``, ``"3 rows"``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"
