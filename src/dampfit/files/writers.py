"""Writers beside the readers: a recording as a phyphox-style CSV, a truth dict as JSON.

* :func:`write_phyphox_csv` — time [s], x, y, z and absolute acceleration [m/s²] in phyphox's
  accelerometer export format (quoted header, numbers as ``0.000000000E0``) in one of its three
  dialects (:data:`DIALECTS`); :func:`dampfit.io.readers.read` reads it back as
  ``"phyphox-csv"``.
* :func:`write_truth` — the known parameters of a simulated recording
  (:func:`dampfit.simulate.recording`) as indented JSON, strict (no NaN or infinity).

Both write atomically (:func:`dampfit.files.folder.atomic_write_text`): a file is complete or absent.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from dampfit.files.atomic import atomic_write_text
from dampfit.errors import InputError
from dampfit.io.recording import Recording

#: Axis columns written, in order.
_AXES = ("x", "y", "z")
#: CSV dialects of phyphox's export: separator and decimal mark.
DIALECTS: dict[str, tuple[str, str]] = {"comma": (",", "."), "tab": ("\t", "."), "semicolon": (";", ",")}
#: Java-style exponent as phyphox writes it: ``E+05`` → ``E5``, ``E-05`` → ``E-5``.
_EXPONENT = re.compile(r"E\+?(-?)0*(\d)")


def _phyphox_numbers(values: np.ndarray, sep: str, decimal: str) -> str:
    """Rows of ``values`` in phyphox's number format (``0.000000000E0``), one line per row."""
    values = np.asarray(values, dtype=float) + 0.0  # turns −0.0 into 0.0
    row = sep.join(["%.9E"] * values.shape[1]) + "\n"
    text = _EXPONENT.sub(r"E\1\2", (row * values.shape[0]) % tuple(values.ravel().tolist()))
    return text.replace(".", decimal) if decimal != "." else text


def write_phyphox_csv(recording: Recording, path: str | os.PathLike, dialect: str = "comma") -> Path:
    """Write ``recording`` like phyphox's CSV export of the accelerometer; returns the path.

    ``dialect``: ``"comma"`` (comma, decimal point), ``"tab"`` (tab, decimal point) or
    ``"semicolon"`` (semicolon, decimal comma). Columns: time [s], x, y, z and absolute
    acceleration [m/s²]; "Linear Acceleration" when ``recording.gravity_removed`` is True.
    """
    try:
        sep, decimal = DIALECTS[dialect]
    except KeyError:
        choices = ", ".join(DIALECTS)
        raise InputError(f"unknown CSV dialect {dialect!r}; choose one of {choices}") from None
    xyz = np.column_stack([recording.axis(name) for name in _AXES])
    return atomic_write_text(path, phyphox_csv_text(recording.time, xyz,
                                                    recording.gravity_removed, dialect=dialect))


def phyphox_csv_text(time: np.ndarray, xyz: np.ndarray, gravity_removed: bool, *,
                     header: bool = True, dialect: str = "comma") -> str:
    """The text of :func:`write_phyphox_csv` for time [s] and x, y, z [m/s²] (shape (n, 3)):
    the header line (``header``) and one line per sample; ``header=False`` gives lines to
    append to such a file (``dampfit record`` streams its samples so)."""
    sep, decimal = DIALECTS[dialect]
    text = ""
    if header:
        label = "Linear Acceleration" if gravity_removed else "Acceleration"
        names = ["Time (s)", *(f"{label} {a} (m/s^2)" for a in _AXES),
                 "Absolute acceleration (m/s^2)"]
        text = sep.join(f'"{n}"' for n in names) + "\n"
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    if not xyz.shape[0]:
        return text
    table = np.column_stack([time, xyz, np.sqrt(np.sum(xyz**2, axis=1))])
    return text + _phyphox_numbers(table, sep, decimal)


def write_truth(truth: dict[str, Any], path: str | os.PathLike) -> Path:
    """Write the truth dict of :func:`dampfit.simulate.recording` as JSON (indent 2); returns
    the path."""
    return atomic_write_text(path, json.dumps(truth, indent=2, allow_nan=False) + "\n")
