"""Delimited text tables: dialect sniffing and parsing into a :class:`Table`.

:func:`text_table` reads CSV, TSV, semicolon-, pipe- or whitespace-separated text, with a
decimal point or a decimal comma, with or without a header row and with ``#`` comment lines.
The dialect (separator, decimal mark, header) is sniffed from the first lines
(:func:`sniff_dialect`); pandas' C engine then parses the table. Tables wider than
:data:`~dampfit.io.bounded.MAX_COLUMNS` are refused before parsing. Values stay as written
(no units are applied here; see :mod:`dampfit.io.units`).

:class:`Table` is the parsed form every reader produces (text, ZIP member, worksheet, NumPy
array, MATLAB variable) before the columns are identified (:mod:`dampfit.io.columns`).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field

import pandas as pd

from dampfit.errors import InputError
from dampfit.io import bounded

#: A column by name or by 0-based position.
Column = str | int

#: Rows read to detect a format or choose a ZIP member or worksheet.
PEEK_ROWS = 5
#: Non-blank lines looked at to sniff the dialect.
_SNIFF_LINES = 50
#: A number with a decimal comma, e.g. ``-1,25e-3``.
DECIMAL_COMMA = re.compile(r"^[-+]?\d*,\d+(?:[eE][-+]?\d+)?$")


@dataclass
class Table:
    """A parsed table before column selection.

    ``header`` tells whether the columns are names from the file (else positions).
    ``source`` is the container: ``text``, ``zip``, ``xlsx``, ``npy`` or ``npz``.
    ``name`` is the file, ZIP member or sheet name (Sensor Logger's sensor is in it).
    ``origin`` names the lab software that wrote it when the layout tells (``"logger-pro"``,
    ``"graphical-analysis"``, ``"capstone"``; :mod:`dampfit.io.labexports`), and ``runs``
    maps a column to its (run label, column name) where a parser read the runs itself.
    ``layout`` is a :class:`~dampfit.io.columns.Layout` fixed by a reader that knows the
    columns from the file's metadata (:mod:`dampfit.io.daq`); None: judged from the header.
    """

    frame: pd.DataFrame
    header: bool
    source: str
    name: str
    notes: list[str] = field(default_factory=list)
    positional_fallback: bool = False
    origin: str | None = None
    runs: dict[str, tuple[str, str]] | None = None
    layout: object | None = None


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


def is_number(token: str, decimal: str) -> bool:
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
    """Separator (None: one column; ``\\s+``: whitespace), decimal mark and header presence."""

    sep: str | None
    decimal: str
    header: bool


def _lines(text: str):
    """The lines of ``text`` (each with its ``\n``) one by one, as iterating
    ``io.StringIO(text)`` gives them but without its copy of the whole text at 4 bytes a
    character (850 MB for a 213 MB CSV, only to read its first lines)."""
    start = 0
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end + 1
        yield text[start:end]
        start = end


def sniff_dialect(text: str) -> _Dialect:
    """Separator, decimal mark and header presence from the first lines."""
    lines: list[str] = []
    for line in _lines(text):
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
        if any(DECIMAL_COMMA.match(tok) for tok in tokens):
            decimal = ","
    width = max(len(_split(line, sep)) for line in lines)
    if width > bounded.MAX_COLUMNS:
        raise InputError(f"has {width} columns (more than {bounded.MAX_COLUMNS}); expected a table of "
                         "time and acceleration")
    header = not all(is_number(tok, decimal) for tok in _split(lines[0], sep))
    numeric_rows = [all(is_number(t, decimal) for t in _split(line, sep)) for line in lines[header:]]
    if not any(numeric_rows):
        if header and len(lines) == 1:
            raise InputError("has a header but no data rows")
        raise InputError("contains no numeric data rows; expected a table of time and acceleration")
    return _Dialect(sep, decimal, header)


def text_table(text: str, name: str, source: str, nrows: int | None) -> Table:
    """Parse delimited text with pandas' C engine after sniffing the dialect ourselves."""
    text = _strip_comments(text)
    dialect = sniff_dialect(text)
    _check_cells(text, dialect)
    notes = []
    if dialect.decimal == ",":
        sep_name = {"\t": "tab", ";": "semicolon", "|": "pipe", r"\s+": "whitespace"}.get(dialect.sep, "")
        notes.append(f"read as {sep_name}-separated text with decimal comma")
    try:
        # bytes, not io.StringIO: pandas reads a StringIO through a 4-byte-a-character
        # buffer (measured: 10 M rows, 213 MB, peak 1.39 GiB from StringIO, 0.78 GiB as bytes)
        frame = pd.read_csv(
            io.BytesIO(text.encode("utf-8")),
            encoding="utf-8",
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
        frame = drop_empty_unnamed(frame)
    if frame.shape[0] == 0:
        raise InputError("has a header but no data rows")
    return Table(frame, dialect.header, source, name, notes)


def _check_cells(text: str, dialect: _Dialect) -> None:
    """Refuse, before parsing, a table of more than :data:`~dampfit.io.bounded.MAX_CELLS`
    values (data lines × the columns of the first data line): the parse's memory grows
    with them (about 60 bytes a value at its peak)."""
    rows = text.count("\n") + (not text.endswith("\n")) - dialect.header
    lines = (ln for ln in io.StringIO(text[:1 << 20]) if ln.strip())
    if dialect.header:
        next(lines, "")
    width = max(len(_split(next(lines, "").rstrip("\n"), dialect.sep)), 1)
    if rows * width > bounded.MAX_CELLS:
        raise InputError(f"has {rows} rows of {width} column(s), {rows * width} values, more "
                         f"than the limit of {bounded.MAX_CELLS} (about 2 GB to read); keep "
                         "fewer columns, split or decimate the recording")


def drop_empty_unnamed(frame: pd.DataFrame) -> pd.DataFrame:
    """Remove all-empty ``Unnamed: k`` columns left by trailing separators."""
    empty = [c for c in frame.columns if str(c).startswith("Unnamed: ") and frame[c].isna().all()]
    return frame.drop(columns=empty) if empty else frame
