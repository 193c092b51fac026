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

__all__ = ["DIALECTS", "write_phyphox_csv", "write_truth"]

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
    label = "Linear Acceleration" if recording.gravity_removed else "Acceleration"
    names = ["Time (s)", *(f"{label} {a} (m/s^2)" for a in _AXES), "Absolute acceleration (m/s^2)"]
    header = sep.join(f'"{n}"' for n in names) + "\n"
    table = np.column_stack([recording.time, xyz, np.sqrt(np.sum(xyz**2, axis=1))])
    return atomic_write_text(path, header + _phyphox_numbers(table, sep, decimal))


def write_truth(truth: dict[str, Any], path: str | os.PathLike) -> Path:
    """Write the truth dict of :func:`dampfit.simulate.recording` as JSON (indent 2); returns
    the path."""
    return atomic_write_text(path, json.dumps(truth, indent=2, allow_nan=False) + "\n")
