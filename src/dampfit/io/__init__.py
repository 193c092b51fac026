"""Reading recordings: every supported file format becomes one validated :class:`Recording`.

* :mod:`~dampfit.io.readers` — :func:`read` and :func:`detect_format`: options, dispatch on the
  file's content, and the final table → :class:`Recording` step;
* :mod:`~dampfit.io.bounded` — limits on hostile input (sizes in bytes), file-kind checks,
  bounded byte reading and text decoding;
* :mod:`~dampfit.io.text` — delimited text tables (CSV/TSV/semicolon/whitespace, decimal comma):
  dialect sniffing and parsing;
* :mod:`~dampfit.io.containers` — phyphox/Sensor Logger ZIP exports, xlsx/xls workbooks,
  npy/npz arrays, with zip-bomb and array-header checks before unpacking;
* :mod:`~dampfit.io.columns` — column roles and the phyphox/Sensor Logger/generic layouts;
* :mod:`~dampfit.io.units` — time [s] and acceleration [m/s²] units: from the header, the
  format or inferred from the values, and the conversion;
* :mod:`~dampfit.io.matlab` — MATLAB .mat files (v4/v5 via SciPy, v7.3 via h5py);
* :mod:`~dampfit.io.daq` — LabVIEW .lvm, NI .tdms and UFF 58 files (optional extras);
* :mod:`~dampfit.io.preamble` — a data logger's settings lines before its table;
* :mod:`~dampfit.io.recording` — the :class:`Recording` type (time [s], acceleration [m/s²])
  and its validation: monotone time, gap splitting, unit notes.
"""

from typing import TYPE_CHECKING

from dampfit.io.recording import Recording as Recording

if TYPE_CHECKING:  # pragma: no cover
    from dampfit.io.readers import detect_format as detect_format
    from dampfit.io.readers import read as read


def __getattr__(name: str):
    """:func:`read` and :func:`detect_format` on first use (PEP 562): the readers import
    pandas, and code that needs only :mod:`~dampfit.io.bounded` (the result files, the
    figure process) should not pay for that."""
    if name in ("read", "detect_format"):
        from dampfit.io import readers

        return getattr(readers, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
