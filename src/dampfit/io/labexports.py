"""School- and university-lab exports: Vernier Logger Pro text, Graphical Analysis and PASCO
Capstone CSVs, and their runs.

Lab data-logging software exports tables that a generic CSV reader misreads:

* **Logger Pro text** (File ▸ Export As ▸ Text, and the "Vernier Format 2" that Vernier's
  Arduino sketches print): a preamble (``Vernier Format 2``, the file name and date, the data
  set name — one for all columns or one per column), then tab-separated rows of long names
  (``Time``, ``Acceleration``), short names (``t``, ``a``) and units (``s``, ``m/s²``), then the
  data. :func:`logger_pro_table` reads it (with a decimal point or a decimal comma) into columns
  named ``Time (s)``, ``Acceleration (m/s²)`` so that units come from the header as for any
  other table; with several data sets the columns become runs (below).
* **Graphical Analysis CSV**: one header row whose names carry the run as a prefix,
  ``"Run 1: Time (s)"``, ``"Latest: Acceleration (m/s²)"`` or ``"Data Set 1:Time(s)"``.
* **PASCO Capstone CSV**: the run as a suffix, ``"Time (s) Run #1"``, ``"Acceleration (m/s²)
  Run #1"``.

**Runs.** Several runs (releases) side by side have different lengths: the shorter runs end
in empty cells. :func:`split_runs` reads one run: the one named by ``run`` (its label, e.g.
``"Run #2"`` or ``"Latest"``, or its number, ``2``), else the **first run in column order**,
with a note saying which run was read and which others the file holds. The run's trailing
rows that are empty in all of its columns (the longer runs' rows) are dropped. Columns
without a run label (one time column shared by all runs) belong to every run.

A native Logger Pro (``.cmbl``), Graphical Analysis (``.gambl``) or Capstone (``.cap``) file
is refused with the menu command that exports text (:func:`native_file_hint`).
"""

from __future__ import annotations

import io
import re

import numpy as np
import pandas as pd

from dampfit.errors import InputError
from dampfit.io import bounded
from dampfit.io.text import DECIMAL_COMMA, Table, is_number

#: A run label as Graphical Analysis writes it in front of a column name: ``Run 1:``,
#: ``Latest:``, ``Data Set 2:`` (also ``Trial 3:``), and as Capstone writes it after the
#: name: ``… Run #1`` (also ``… Run 1``).
_PREFIX_RUN = re.compile(
    r"^\s*(?P<run>latest|(?:run|data\s*set|trial)\s*#?\s*\d+)\s*:\s*(?P<base>\S.*)$", re.I)
_SUFFIX_RUN = re.compile(
    r"^(?P<base>.*?\S)\s*[,;:\-]?\s+(?P<run>run\s*#\s*\d+|run\s+\d+)\s*$", re.I)
#: Native files of lab software that dampfit does not read, and how to export text from them.
_NATIVE = {
    ".cmbl": "a Logger Pro file; export the data as text (File ▸ Export As ▸ Text) and "
             "read that",
    ".gambl": "a Graphical Analysis file; export the data as CSV (Export ▸ CSV) and read that",
    ".cap": "a PASCO Capstone file; export the data as CSV (File ▸ Export Data) and "
            "read that",
}
#: Most preamble and header lines a Logger Pro export has before its data.
_MAX_HEADER_LINES = 12


def native_file_hint(ext: str) -> str | None:
    """One sentence for a native lab-software file (``.cmbl``, ``.gambl``, ``.cap``), else None."""
    return _NATIVE.get(ext.lower())


# ----------------------------------------------------------------------------- Logger Pro
def is_logger_pro(text: str) -> bool:
    """Whether the first non-blank line of ``text`` is Vernier's ``Vernier Format N`` marker."""
    head = text.lstrip()[:64].lower()
    return head.startswith("vernier format")


def _fields(line: str) -> list[str]:
    """Tab-separated fields of a line, trailing empty fields dropped."""
    out = [f.strip().strip('"').strip() for f in line.split("\t")]
    while out and not out[-1]:
        out.pop()
    return out


def _is_data(line: str) -> bool:
    """A row of numbers (decimal point or comma) or empty cells, with at least one number."""
    fields = _fields(line)
    return bool(fields) and all(is_number(f, ",") for f in fields)


def _decimal(lines: list[str]) -> str:
    """``","`` if the data rows write numbers with a decimal comma, else ``"."``."""
    tokens = (f for ln in lines[:200] for f in _fields(ln))
    return "," if any(DECIMAL_COMMA.match(f) for f in tokens) else "."


def logger_pro_table(text: str, name: str, nrows: int | None) -> Table:
    """A Logger Pro / Vernier Format text export (module docstring) as a :class:`Table`."""
    lines = text.split("\n")
    start = next((i for i, ln in enumerate(lines) if ln.strip()), 0)
    stop = min(len(lines), start + 2 + _MAX_HEADER_LINES)
    first_data = next((i for i in range(start + 1, stop) if _is_data(lines[i])), None)
    if first_data is None:
        raise InputError("is a Vernier (Logger Pro) text export without numeric data rows "
                         f"in its first {_MAX_HEADER_LINES} lines")
    header = [_fields(ln) for ln in lines[start + 1:first_data] if ln.strip()]
    width = len(_fields(lines[first_data]))
    names, runs, notes = _logger_pro_names(header, width)
    if len(names) > bounded.MAX_COLUMNS:
        raise InputError(f"has {len(names)} columns (more than {bounded.MAX_COLUMNS})")
    decimal = _decimal(lines[first_data:])
    if decimal == ",":
        notes.append("read with decimal comma")
    try:
        frame = pd.read_csv(io.StringIO("\n".join(lines[first_data:])), sep="\t", header=None,
                            names=names, decimal=decimal, index_col=False, nrows=nrows,
                            skip_blank_lines=True, engine="c")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        detail = " ".join(str(exc).split())
        raise InputError(f"cannot be parsed as a Vernier text export ({detail})") from None
    if frame.shape[0] == 0:
        raise InputError("is a Vernier (Logger Pro) text export without data rows")
    return Table(frame, True, "text", name, notes, origin="logger-pro", runs=runs or None)


def _looks_like_run(field: str) -> bool:
    """A data set name as Logger Pro names them: ``Run 1``, ``Latest``, ``Data Set 2``."""
    return bool(re.fullmatch(r"(latest|data\s*set|(run|data\s*set|trial)\s*#?\s*\d+)",
                             field.strip(), re.I))


def _header_rows(header: list[list[str]]):
    """(data set names, long names, units) rows of a Logger Pro header, each a list or None:
    ``[sets,] long, [short,] units`` from the bottom; three rows are sets/long/units only
    when the first names runs (``Run 1``, ``Latest``…), else long/short/units."""
    rows = [h for h in header if len(h) > 1]
    if not rows:
        rows = [h for h in header[-1:] if h]
    if not rows:
        raise InputError("is a Vernier (Logger Pro) text export without a row of column names; "
                         "export it again with the column names")
    if len(rows) >= 4:
        return rows[-4], rows[-3], rows[-1]
    if len(rows) == 3:
        if all(_looks_like_run(f) for f in rows[0] if f):
            return rows[0], rows[1], rows[2]
        return None, rows[0], rows[2]
    if len(rows) == 2:
        return None, rows[0], rows[1]
    return None, rows[0], None


def _logger_pro_names(header: list[list[str]], width: int):
    """Column names ``Long (unit)`` of a Logger Pro header, the runs ({column: (data set,
    name)} when the columns belong to several data sets) and notes. ``header`` = the fields
    of the non-blank lines between the format line and the data."""
    sets, longs, units = _header_rows(header)
    n = max(width, len(longs))
    bases = []
    for j in range(n):
        long = longs[j] if j < len(longs) and longs[j] else f"column {j + 1}"
        unit = units[j] if units is not None and j < len(units) else ""
        bases.append(f"{long} ({unit})" if unit else long)
    labels = [sets[j] if sets is not None and j < len(sets) and sets[j] else "" for j in range(n)]
    titles = [h[0] for h in header if len(h) == 1]  # the file name and date, the data set
    notes = [f"Vernier (Logger Pro) text export ({titles[0] if titles else 'no title'})"]
    several = len(set(labels) - {""}) > 1
    if not several and (set(labels) - {""} or len(titles) > 1):
        notes.append(f"data set {next((r for r in labels if r), titles[-1])!r}")
    seen: dict[tuple[str, str], int] = {}
    for j, key in enumerate(zip(labels if several else [""] * n, bases)):
        seen[key] = seen.get(key, 0) + 1  # repeated names (two "Acceleration") made unique
        if seen[key] > 1:
            bases[j] = f"{bases[j]} [{seen[key]}]"
    if not several:
        return bases, {}, notes
    names = [f"{r}: {b}" if r else b for r, b in zip(labels, bases)]
    return names, {c: (r, b) for c, r, b in zip(names, labels, bases) if r}, notes


# ----------------------------------------------------------------------------- runs
def _run_key(label: str) -> str:
    """``"Run #2"``, ``"run 2"``, ``"RUN2"`` → ``"run 2"``; ``"Latest"`` → ``"latest"``."""
    words = re.findall(r"[a-z]+|\d+", label.lower())
    return " ".join(str(int(w)) if w.isdigit() else w for w in words)


def _labels(table: Table) -> tuple[dict, str | None]:
    """{column: (run label, name without it)} and the software the labels point to."""
    if table.runs:
        return dict(table.runs), table.origin
    prefix = {c: (m["run"].strip(), m["base"].strip()) for c in table.frame.columns
              if (m := _PREFIX_RUN.match(str(c)))}
    suffix = {c: (m["run"].strip(), m["base"].strip()) for c in table.frame.columns
              if (m := _SUFFIX_RUN.match(str(c)))}
    if len(prefix) >= len(suffix) and prefix:
        return prefix, table.origin or "graphical-analysis"
    if suffix:
        return suffix, table.origin or "capstone"
    return {}, table.origin


def _choose(order: list[str], run: str | int) -> str:
    """The run label matching ``run`` (a label or a run number)."""
    want = str(run).strip()
    key = _run_key(want)
    for label in order:
        if _run_key(label) == key:
            return label
    if want.isdigit():
        numbered = [lb for lb in order
                    if (nums := re.findall(r"\d+", lb)) and int(nums[-1]) == int(want)]
        if len(numbered) == 1:
            return numbered[0]
    raise InputError(f"has no run {want!r}; runs: {', '.join(repr(r) for r in order)}")


def split_runs(table: Table, run: str | int | None) -> Table:
    """The columns of one run (module docstring); the table itself when it has no run labels."""
    if not table.header:
        if run is not None:
            raise InputError("--run: this file has no header, so no runs to choose from")
        return table
    labels, origin = _labels(table)
    if not labels:
        if run is not None:
            raise InputError("--run: this file has no runs (no 'Run 1:' or 'Run #1' column names); "
                             "leave --run out")
        return table
    order = list(dict.fromkeys(label for label, _ in labels.values()))
    chosen = order[0] if run is None else _choose(order, run)
    own = {c: base for c, (label, base) in labels.items() if label == chosen}
    shared = [c for c in table.frame.columns if c not in labels and str(c) not in own.values()]
    cols = [c for c in table.frame.columns if c in own or c in shared]
    frame = table.frame[cols].rename(columns={c: own[c] for c in own})
    filled = np.flatnonzero(frame[[own_c for own_c in own.values()]].notna().any(axis=1).to_numpy())
    frame = frame.iloc[: int(filled[-1]) + 1] if filled.size else frame.iloc[:0]
    others = [r for r in order if r != chosen]
    listing = ", ".join(repr(r) for r in others)
    if frame.shape[0] == 0:
        raise InputError(f"run {chosen!r} has no data"
                         + (f"; choose another with --run ({listing})" if others else ""))
    how = "the first run" if run is None else "as chosen with --run"
    note = f"read run {chosen!r} ({frame.shape[0]} rows, {how})"
    if others:
        note += (f"; the file has {len(order)} runs ({', '.join(repr(r) for r in order)}): "
                 "choose another with --run")
    return Table(frame, True, table.source, table.name, list(table.notes) + [note],
                 table.positional_fallback, origin, None)
