"""What a batch analyses: the recordings named on the command line, in a list file or in
folders, each with its mass and reading options (:class:`Job`): :func:`jobs`.

Rules (each refusal is one :class:`~dampfit.errors.InputError` line, before any work):

* a FILE is a recording; a folder stands for the recordings directly in it (files with a
  suffix dampfit reads, :data:`SUFFIXES`, hidden files and the ``--masses``/``--list`` files
  left out; not recursive, so a batch's own output folder inside it is never read back); a
  folder with none is refused;
* ``--list FILE``: one path per line (blank lines and lines starting with ``#`` skipped;
  relative paths are relative to the list's folder);
* every recording must exist (the first missing one is named) and appear once: the same file
  twice (after resolving links and relative paths) is refused, naming it;
* the mass: ``--mass`` [kg] for all, or per file from ``--masses masses.csv`` (columns ``file``,
  ``mass``, optional ``mass_sd`` and any reading option of :data:`dampfit.io.readers.READ_OPTIONS`,
  e.g. ``time_column``; ``accel_columns`` holds names separated by ``;``). A row's ``file`` is
  matched to a recording by its path relative to the CSV's folder, or by its name when that
  is unique. A row naming no recording of the batch, a recording named twice, or a recording
  without a row when ``--mass`` gives no default is refused; every mass passes the one mass
  check (:func:`dampfit.physics.check_mass`: finite, positive, at most 10⁶ kg, sd ≤ mass/2).
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import math
import os
from pathlib import Path
from typing import Any, Sequence

from dampfit.errors import InputError, shown
from dampfit.io.bounded import read_regular
from dampfit.io.readers import READ_OPTIONS
from dampfit.physics import check_mass

#: File suffixes a folder is searched for (the formats :func:`dampfit.io.readers.read` knows).
SUFFIXES = (".csv", ".txt", ".tsv", ".dat", ".zip", ".xlsx", ".xlsm", ".xls", ".npy", ".npz",
            ".mat")
#: Largest ``--list`` or ``--masses`` file [bytes] (a path per line: a million recordings).
MAX_LIST_BYTES = 256 * 2**20


@dataclasses.dataclass(frozen=True)
class Job:
    """One recording of a batch: its path as given (``file``), the real path read
    (``path``), its run folder name (``name``, unique in the batch), the SHA-256 of its bytes,
    mass [kg] and mass sd [kg] (None: no mass, ζ only) and reading options."""

    file: str
    path: str
    name: str
    sha256: str
    mass: float | None
    mass_sd: float
    read_options: dict[str, Any]

    def key(self, options: dict[str, Any]) -> str:
        """The identity of this job's result: its path (the real path and its run folder's
        name: two files of identical bytes are two rows), its bytes, mass, reading and
        analysis options (a rerun with all of them the same is not redone)."""
        import json

        text = json.dumps([self.path, self.name, self.sha256, self.mass, self.mass_sd,
                           self.read_options, options], sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()


def _lines(path: Path) -> list[str]:
    data = read_regular(path, MAX_LIST_BYTES, missing=InputError(f"{shown(path)} does not exist"),
                        what="a list of recordings")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{shown(path)} is not UTF-8 text") from None
    return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def expand(paths: Sequence[str], list_file: str | None = None,
           skip: Sequence[str] = ()) -> list[str]:
    """The recordings of a batch in order (module docstring): FILEs, the lines of
    ``list_file``, folders expanded; ``skip`` (the masses file) is never a recording."""
    given = [str(p) for p in paths]
    if list_file is not None:
        base = Path(list_file).parent
        given += [ln if os.path.isabs(ln) else str(base / ln) for ln in _lines(Path(list_file))]
    if not given:
        raise InputError("no recordings given: name FILEs or folders, or --list FILE")
    skipped = {os.path.realpath(p) for p in (*skip, *([list_file] if list_file else []))}
    out: list[str] = []
    for p in given:
        _no_loop(p)
        if os.path.isdir(p):
            found = sorted(str(Path(p) / e.name) for e in _entries(p)
                           if not e.name.startswith(".")
                           and Path(e.name).suffix.lower() in SUFFIXES
                           and _no_loop(e.path) and e.is_file()
                           and os.path.realpath(Path(p) / e.name) not in skipped)
            if not found:
                raise InputError(f"folder {shown(p)} holds no recordings (files ending in "
                                 f"{', '.join(SUFFIXES)})")
            out += found
        elif not os.path.lexists(p):
            raise InputError(f"recording {shown(p)} does not exist")
        else:
            out.append(p)
    return out


def _no_loop(path: str) -> bool:
    """True, or a one-line refusal of a path whose symbolic links loop (``ELOOP``: a link to
    itself, two links to each other) or that cannot be looked at."""
    import errno

    try:
        os.stat(path)
    except FileNotFoundError:
        return True  # dangling or missing: named by the caller's own check
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError(f"{shown(path)} is a symbolic link loop (a link that leads back "
                             "to itself); remove it or name the recordings") from None
        raise InputError(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    return True


def _entries(folder: str) -> list:
    try:
        with os.scandir(folder) as it:
            return list(it)
    except OSError as exc:
        raise InputError(f"cannot read folder {shown(folder)}: "
                         f"{exc.strerror or type(exc).__name__}") from None


def _float(value: Any, what: str) -> float | None:
    if value is None or (isinstance(value, float) and math.isnan(value)) or value == "":
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} is not a number: {shown(value)!r}") from None


def read_masses(path: str) -> list[dict[str, Any]]:
    """The rows of ``masses.csv`` (module docstring): ``file``, ``mass`` [kg], ``mass_sd``
    [kg] and reading options, each as given (checked by :func:`jobs`)."""
    import pandas as pd

    data = read_regular(path, MAX_LIST_BYTES, missing=InputError(f"{shown(path)} does not exist"),
                        what="a masses table")
    try:
        frame = pd.read_csv(io.BytesIO(data), dtype=str, keep_default_na=False,
                            skipinitialspace=True, comment=None)
    except (ValueError, UnicodeDecodeError, pd.errors.ParserError) as exc:
        raise InputError(f"{shown(path)} is not a CSV table: {shown(exc)}") from None
    frame.columns = [str(c).strip().lower() for c in frame.columns]
    for need in ("file", "mass"):
        if need not in frame.columns:
            raise InputError(f"{shown(path)} has no '{need}' column (needs file, mass; optional "
                             f"mass_sd, {', '.join(READ_OPTIONS)})")
    unknown = [c for c in frame.columns if c not in ("file", "mass", "mass_sd", *READ_OPTIONS)]
    if unknown:
        raise InputError(f"{shown(path)}: unknown column {shown(unknown[0])!r} (known: file, "
                         f"mass, mass_sd, {', '.join(READ_OPTIONS)})")
    rows = []
    for i, rec in enumerate(frame.to_dict("records"), start=2):
        where = f"{shown(path)} line {i}"
        if not rec["file"].strip():
            raise InputError(f"{where}: empty file name")
        row = {"file": rec["file"].strip(), "line": i,
               "mass": _float(rec["mass"], f"{where}: mass"),
               "mass_sd": _float(rec.get("mass_sd"), f"{where}: mass_sd")}
        if row["mass"] is None:
            raise InputError(f"{where}: no mass for {shown(row['file'])}")
        opts = {k: rec[k].strip() for k in READ_OPTIONS if k in rec and rec[k].strip()}
        if "accel_columns" in opts:
            opts["accel_columns"] = [c.strip() for c in opts["accel_columns"].split(";") if c.strip()]
        if "row" in opts:
            row_value = _float(opts["row"], f"{where}: row")
            if row_value is None or row_value != int(row_value) or not 0 <= row_value < 1024:
                raise InputError(f"{where}: row must be an integer from 0 to 1023")
            opts["row"] = int(row_value)
        row["read_options"] = opts
        rows.append(row)
    return rows


def _match(rows: list[dict[str, Any]], files: list[str], base: Path, masses: str) -> dict[int, dict]:
    """Each recording's index → its masses row (module docstring's matching rule)."""
    real = [os.path.realpath(f) for f in files]
    by_real = {r: i for i, r in enumerate(real)}
    names: dict[str, list[int]] = {}
    for i, f in enumerate(files):
        names.setdefault(Path(f).name, []).append(i)
    out: dict[int, dict] = {}
    for row in rows:
        cand = os.path.realpath(row["file"] if os.path.isabs(row["file"]) else base / row["file"])
        i = by_real.get(cand)
        if i is None and len(names.get(row["file"], [])) == 1:
            i = names[row["file"]][0]
        if i is None:
            raise InputError(f"{shown(masses)} line {row['line']}: {shown(row['file'])} is not "
                             "a recording of this batch")
        if i in out:
            raise InputError(f"{shown(masses)} names {shown(files[i])} twice (lines "
                             f"{out[i]['line']} and {row['line']})")
        out[i] = row
    return out


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
    except OSError as exc:
        raise InputError(f"cannot read {shown(path)}: {exc.strerror or type(exc).__name__}") from None
    return h.hexdigest()


def labels(files: Sequence[str], deepest: int = 4) -> list[str]:
    """Each file's shortest path suffix (its name, then with as many parent folders as it
    takes, at most ``deepest`` parts) that no other file of the batch shares: recordings that
    all have one name (``run1/accelerometer_data.npy``, ``run2/accelerometer_data.npy``) get
    folders that tell them apart."""
    from collections import Counter

    parts = [Path(f).parts or (f,) for f in files]
    suffix = lambda p, d: "/".join(p[-d:]).lower()  # noqa: E731
    counts = [Counter(suffix(p, d) for p in parts) for d in range(1, deepest + 1)]
    out = []
    for p in parts:  # one pass per depth: linear in the number of files
        depth = 1
        while depth < min(len(p), deepest) and counts[depth - 1][suffix(p, depth)] > 1:
            depth += 1
        out.append("/".join(p[-depth:]))
    return out


def run_name(label: str, taken: set[str]) -> str:
    """A folder name for a recording's results from its :func:`labels` entry: anything but
    letters, digits, ``.``, ``-`` and ``_`` replaced by ``_`` (a hostile name cannot leave
    ``runs/`` or hide), at most 80 characters (the end kept: the file name), made unique in
    the batch with a number."""
    import re

    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", label).strip("._") or "recording"
    stem = stem[-80:].lstrip("._") or "recording"
    name, n = stem, 2
    while name.lower() in taken:
        name, n = f"{stem}-{n}", n + 1
    taken.add(name.lower())
    return name


def jobs(paths: Sequence[str], *, list_file: str | None = None, mass: float | None = None,
         mass_sd: float | None = None, masses: str | None = None,
         read_options: dict[str, Any] | None = None) -> list[Job]:
    """The :class:`Job` of every recording of a batch (module docstring); one-line
    :class:`InputError` for anything a batch cannot run with."""
    files = expand(paths, list_file, skip=[masses] if masses else [])
    seen: dict[str, str] = {}
    for f in files:
        r = os.path.realpath(f)
        if r in seen:
            raise InputError(f"recording {shown(f)} is given twice (also as {shown(seen[r])})")
        seen[r] = f
        if not os.path.isfile(f):
            raise InputError(f"recording {shown(f)} is not a regular file")
    default = check_mass(mass, mass_sd) if mass is not None or mass_sd is not None else None
    rows = _match(read_masses(masses), files, Path(masses).parent, masses) if masses else {}
    taken: set[str] = set()
    names = labels(files)
    out = []
    for i, f in enumerate(files):
        row = rows.get(i)
        if row is not None:
            try:
                m, sd = check_mass(row["mass"], row["mass_sd"])
            except InputError as exc:
                raise InputError(f"{shown(masses)} line {row['line']}: {exc}") from None
            opts = {**(read_options or {}), **row["read_options"]}
        elif masses and default is None:
            raise InputError(f"{shown(masses)} has no row for {shown(f)} (add one, or give "
                             "--mass as the default)")
        else:
            m, sd = default if default is not None else (None, 0.0)
            opts = dict(read_options or {})
        out.append(Job(file=f, path=os.path.realpath(f), name=run_name(names[i], taken),
                       sha256=_sha256(f), mass=m, mass_sd=sd, read_options=opts))
    return out
