"""Reading recordings: every supported file format becomes one validated :class:`Recording`.

* :mod:`~dampfit.io.readers` — format detection, bounded reads, table readers (CSV/TSV/text,
  phyphox, Sensor Logger, xlsx/xls, ZIP exports, npy/npz) and column/unit identification;
* :mod:`~dampfit.io.matlab` — MATLAB .mat files (v4/v5 via SciPy, v7.3 via h5py);
* :mod:`~dampfit.io.recording` — the :class:`Recording` type (time [s], acceleration [m/s²])
  and its validation: monotone time, gap splitting, unit notes.
"""

from dampfit.io.readers import detect_format as detect_format
from dampfit.io.readers import read as read
from dampfit.io.recording import Recording as Recording

__all__ = ["Recording", "detect_format", "read"]
