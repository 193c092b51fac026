"""Laboratory DAQ files: LabVIEW ``.lvm``, NI ``.tdms`` and UFF 58 (``.uff``/``.unv``) → one table.

Each format is read through its maintained library, an optional extra (``pip install
'dampfit[lvm]'``, ``[tdms]``, ``[uff]``; a missing one is a one-line error naming it):

* **LabVIEW Measurement** (``lvm-read``; NI's text format, "LabVIEW Measurement File (.lvm)
  Specification"): a header, then per segment ``Channels``, ``Samples``, ``X0``, ``Delta_X``,
  ``Y_Unit_Label`` and a table whose first column is the X (time) value when ``X_Columns`` is
  ``One`` or ``Multi``. With ``X_Columns No`` time is ``X0 + i·Delta_X``. The first data
  segment is read (a note names the others). The text is parsed with ``lvm_read.read_str``
  from the bytes :mod:`dampfit.io.bounded` read (never ``lvm_read.read``, which would unpickle
  a ``.pkl`` file lying next to the recording).
* **NI TDMS** (``npTDMS``): groups of channels; ``group=`` and ``channel=`` pick them (default:
  the only group, the acceleration channels by unit or name). Time is the channel's waveform
  properties ``wf_start_offset + i·wf_increment`` [s], else a time channel of the group, else
  ``rate=`` [Hz]. The metadata are read first (``TdmsFile.open`` on the bytes in memory) and
  every channel's declared length × item size is checked against
  :data:`~dampfit.io.bounded.MAX_UNPACKED_BYTES` before its data are read. npTDMS's own log
  lines (a truncated last segment) become notes, never extra lines on stderr.
* **UFF data set 58** (``pyuff``; function at nodal DOF): each record is one function with its
  abscissa. Time-response records (function type 1) are candidates; ``row=`` picks one by its
  0-based data-set number in the file (as pyuff numbers them), which is required when there
  are several. pyuff reads from a path only: the checked bytes are written to a private
  temporary file it reads, so the file read is the file checked.

The table has the time column ``"time"`` [s] first, then one column per acceleration channel
named as in the file, and carries its :class:`~dampfit.io.columns.Layout` (units from the
file's metadata where it writes one: ``g``, ``m/s^2``), so :mod:`dampfit.io.columns` does not
guess from the names. A channel whose unit is not an acceleration (``N``, ``V``) is left out
of the automatic choice and refused when named, unless ``accel_unit=`` says what it is.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pandas as pd

from dampfit.errors import InputError
from dampfit.io import bounded
from dampfit.io.columns import Layout, role
from dampfit.io.text import Table
from dampfit.io.units import ACCEL_ALIASES

#: Extensions of the DAQ formats and the format each is.
DAQ_EXTS = {".lvm": "lvm", ".tdms": "tdms", ".uff": "uff58", ".unv": "uff58"}
#: The pip extra of each format's library.
_EXTRA = {"lvm": ("lvm_read", "lvm-read", "lvm"), "tdms": ("nptdms", "npTDMS", "tdms"),
          "uff58": ("pyuff", "pyuff", "uff")}


@dataclass
class _Channel:
    name: str
    values: np.ndarray
    unit: str  # as written in the file ('' when none)


def daq_kind(data: bytes, ext: str) -> str | None:
    """``"lvm"``, ``"tdms"``, ``"uff58"`` from the content (magic) or the extension; None."""
    if data.startswith((b"TDSm", b"TDSh")):
        return "tdms"
    if data.lstrip(b"\xef\xbb\xbf").startswith(b"LabVIEW Measurement"):
        return "lvm"
    return DAQ_EXTS.get(ext)


def _library(kind: str):
    module, package, extra = _EXTRA[kind]
    try:
        return __import__(module)
    except ImportError:
        raise InputError(f"reading this file needs the {package} package: pip install "
                         f"'dampfit[{extra}]'") from None


def daq_table(data: bytes, kind: str, name: str, *, group=None, channel=None, row=None,
              rate=None, accel_unit=None) -> Table:
    """The table of a DAQ file's ``data`` (module docstring); ``kind`` from :func:`daq_kind`."""
    lib = _library(kind)
    if kind != "tdms" and group is not None:
        raise InputError("--group applies to TDMS files only")
    if kind != "uff58" and row is not None:
        raise InputError("--row applies to MATLAB and UFF files only")
    if kind == "lvm":
        time, channels, notes = _lvm(lib, data)
    elif kind == "tdms":
        time, channels, notes = _tdms(lib, data, group, rate)
    else:
        time, channels, notes = _uff(lib, data, row)
    if time is not None and rate is not None:
        raise InputError("--rate is for tables without a time base; this file has its own "
                         "(leave --rate out)")
    chosen = _choose(channels, channel, accel_unit)
    if time is None:
        time = np.arange(chosen[0].values.size) / rate
        notes.append(f"time from --rate {rate:g} Hz")
    n = min([time.size, *(c.values.size for c in chosen)])
    if any(c.values.size != n for c in chosen) or time.size != n:
        notes.append(f"channels of different lengths: the first {n} samples of each are read")
    frame = pd.DataFrame({"time": time[:n], **{c.name: c.values[:n] for c in chosen}})
    units = {"time": "s", **{c.name: u for c in chosen if (u := _accel_unit(c.unit))}}
    names = ", ".join(repr(c.name) for c in chosen)
    notes.append(f"acceleration from channel{'s' if len(chosen) > 1 else ''} {names}")
    layout = Layout("generic", "time", [c.name for c in chosen], units)
    return Table(frame, True, kind, name, notes, layout=layout)


def _accel_unit(unit: str) -> str | None:
    """The canonical acceleration unit of a unit label (``g``, ``m/s^2``), else None."""
    return ACCEL_ALIASES.get(unit.strip().lower().replace(" ", "").replace("μ", "µ")) if unit \
        else None


def _choose(channels: list[_Channel], wanted, accel_unit) -> list[_Channel]:
    """The named channel(s) ``wanted``, else the acceleration channels (by unit, then name),
    else the only one; a choice that cannot be made is an :class:`InputError` listing them."""
    if not channels:
        raise InputError("holds no data channels")
    listing = ", ".join(f"{c.name!r}" + (f" [{c.unit}]" if c.unit else "") for c in channels[:12])
    listing += ", …" if len(channels) > 12 else ""
    if wanted is not None:
        names = [wanted] if isinstance(wanted, (str, int)) else list(wanted)
        picked = []
        for w in names:
            hit = [c for c in channels if c.name == str(w)] or \
                  [c for c in channels if c.name.lower() == str(w).strip().lower()]
            if not hit:
                raise InputError(f"has no channel {str(w)!r}; its channels: {listing}")
            c = hit[0]
            if c.unit and _accel_unit(c.unit) is None and accel_unit is None:
                raise InputError(f"channel {c.name!r} is in {c.unit}, not an acceleration; name "
                                 "an acceleration channel, or give --accel-unit if it is one")
            picked.append(c)
        return picked
    accel = [c for c in channels if _accel_unit(c.unit)] or \
            [c for c in channels if not c.unit and role(c.name) == "accel"]
    if accel:
        return accel
    free = [c for c in channels if not c.unit or accel_unit is not None]
    if len(free) == 1:
        return free
    raise InputError(f"has {len(channels)} channels and none says it is an acceleration: "
                     f"{listing}; choose one with --channel NAME")


def _check_size(n: int, itemsize: int, what: str) -> None:
    if n * itemsize > bounded.MAX_UNPACKED_BYTES:
        raise InputError(f"{what} declares {n} values ({bounded.size_text(n * itemsize)}), more "
                         f"than the limit of {bounded.size_text(bounded.MAX_UNPACKED_BYTES)}; "
                         "the file is corrupt or too large")


# ------------------------------------------------------------------ LabVIEW LVM
def _lvm(lib, data: bytes):
    text = bounded.decode(data)
    try:
        lvm = lib.read_str(text)
    except (ValueError, SyntaxError, TypeError, KeyError, IndexError, RecursionError,
            MemoryError):
        raise InputError("is not a readable LabVIEW Measurement file (no data segment: "
                         "truncated, or a wrong separator)") from None
    segments = [lvm[i] for i in range(int(lvm.get("Segments", 0))) if "data" in lvm.get(i, {})]
    if not segments:
        raise InputError("is a LabVIEW Measurement file without a data segment")
    seg = segments[0]
    block = np.asarray(seg["data"], dtype=np.float64)
    names = [str(n).strip() for n in seg.get("Channel names", [])]
    if block.ndim != 2 or block.shape[0] == 0:
        raise InputError("is a LabVIEW Measurement file whose data segment has no rows")
    notes = [f"LabVIEW Measurement file: {len(segments)} data segments, the first is read"] \
        if len(segments) > 1 else []
    x_cols = str(lvm.get("X_Columns", "One")).strip()
    units = [str(u).strip() for u in seg.get("Y_Unit_Label", [])]
    cols = [i for i, n in enumerate(names[:block.shape[1]]) if n not in ("X_Value", "Comment")]
    time = None
    if x_cols != "No" and names[:1] == ["X_Value"]:
        time = block[:, 0]
    else:
        x0, dx = _first(seg.get("X0")), _first(seg.get("Delta_X"))
        if dx is not None and np.isfinite(dx) and dx > 0:
            time = (0.0 if x0 is None or not np.isfinite(x0) else x0) + np.arange(block.shape[0]) * dx
    channels = [_Channel(names[i], block[:, i], units[k] if k < len(units) else "")
                for k, i in enumerate(cols)]
    return time, channels, notes


def _first(values):
    try:
        return float(values[0])
    except (TypeError, ValueError, IndexError):
        return None


# ------------------------------------------------------------------ NI TDMS
@contextlib.contextmanager
def _quiet_nptdms(notes: list[str]):
    """npTDMS's log lines (its own stderr handler) collected into ``notes`` instead."""
    from nptdms.log import log_manager

    class _Collect(logging.Handler):
        def emit(self, record):
            notes.append(f"npTDMS: {record.getMessage()}")

    handler, level = _Collect(logging.WARNING), log_manager.console_handler.level
    parent = logging.getLogger("nptdms")
    parent.addHandler(handler)
    log_manager.console_handler.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        log_manager.console_handler.setLevel(level)
        parent.removeHandler(handler)


def _tdms(lib, data: bytes, group, rate):
    notes: list[str] = []
    try:
        with _quiet_nptdms(notes):
            f = lib.TdmsFile.open(io.BytesIO(data))
            groups = [g for g in f.groups() if g.channels()]
            g = _tdms_group(groups, group)
            channels, time = [], None
            for ch in g.channels():
                _check_size(len(ch), max(int(getattr(ch.dtype, "itemsize", 8) or 8), 1),
                            f"channel {ch.name!r}")
                if ch.dtype is None or np.dtype(ch.dtype).kind not in "iuf":
                    continue  # strings, timestamps, complex: not a signal
                values = np.asarray(ch[:], dtype=np.float64)
                if role(ch.name) == "time":
                    time = values if time is None else time
                    continue
                unit = str(ch.properties.get("unit_string", "") or "").strip()
                channels.append(_Channel(str(ch.name), values, unit))
                wf = ch.properties
                if "wf_increment" in wf and time is None and rate is None:
                    dt = float(wf["wf_increment"])
                    if not (np.isfinite(dt) and dt > 0):
                        raise InputError(f"channel {ch.name!r} has a wf_increment of {dt:g} s; "
                                         "give --rate HZ")
                    time = float(wf.get("wf_start_offset", 0.0) or 0.0) + np.arange(len(ch)) * dt
    except InputError:
        raise
    except Exception as exc:  # npTDMS raises ValueError, KeyError, struct.error, … on junk
        raise InputError(f"is not a readable TDMS file ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:120]}): corrupt or truncated") from None
    if time is None and rate is None:
        raise InputError("has no time base (no wf_increment property, no time channel); give "
                         "the sample rate with --rate HZ")
    notes = [n for n in dict.fromkeys(notes)][:3]
    return time, channels, [f"TDMS group {g.name!r}", *notes]


def _tdms_group(groups, wanted):
    listing = ", ".join(repr(g.name) for g in groups[:12])
    if not groups:
        raise InputError("is a TDMS file without channels")
    if wanted is not None:
        hit = [g for g in groups if g.name == wanted] or \
              [g for g in groups if g.name.lower() == str(wanted).strip().lower()]
        if not hit:
            raise InputError(f"has no TDMS group {wanted!r}; its groups: {listing}")
        return hit[0]
    if len(groups) > 1:
        raise InputError(f"has {len(groups)} TDMS groups ({listing}); choose one with --group NAME")
    return groups[0]


# ------------------------------------------------------------------ UFF 58
#: UFF 58 function types (field 1 of record 6) and ordinate data types (record 9).
_FUNC = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum",
         4: "frequency response", 6: "coherence"}


def _uff(lib, data: bytes, row):
    with tempfile.TemporaryDirectory(prefix="dampfit-uff-") as folder:
        path = os.path.join(folder, "input.uff")
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        try:
            uff = lib.UFF(path)
            types = [int(t) for t in uff.get_set_types()]
            heads = {i: uff.read_sets(i, header_only=True) for i, t in enumerate(types) if t == 58}
            if not heads:
                raise InputError("is not a UFF file with a data set 58 (function at nodal DOF)"
                                 if not types else f"holds UFF data sets {sorted(set(types))} "
                                 "but no data set 58 (function at nodal DOF)")
            pick = _uff_record(heads, row)
            _check_size(int(heads[pick].get("num_pts", 0) or 0), 8, f"UFF record {pick}")
            rec = uff.read_sets(pick)
        except InputError:
            raise
        except Exception as exc:  # pyuff raises bare Exception on every fault
            raise InputError(f"is not a readable UFF file ({' '.join(str(exc).split())[:120]}): "
                             "corrupt or truncated") from None
    x, y = np.asarray(rec.get("x"), dtype=np.float64), np.asarray(rec.get("data"))
    if np.iscomplexobj(y):
        raise InputError(f"UFF record {pick} holds complex values (a spectrum), not a time "
                         "response")
    name = str(rec.get("id1", "") or f"record {pick}").strip() or f"record {pick}"
    unit = str(rec.get("ordinate_axis_units_lab", "") or "").strip()
    notes = [f"UFF data set 58 record {pick} ({name!r})"]
    return x, [_Channel(name, y.astype(np.float64), unit)], notes


def _uff_record(heads: dict, row) -> int:
    """The data-set number to read: ``row`` (checked), else the only time response."""
    def label(i):
        h = heads[i]
        return f"{i}: {str(h.get('id1', '')).strip()!r} ({_FUNC.get(h.get('func_type'), 'type ' + str(h.get('func_type')))})"
    listing = ", ".join(label(i) for i in list(heads)[:12])
    if row is not None:
        if row not in heads:
            raise InputError(f"has no UFF data set 58 numbered {row}; its records: {listing}")
        if heads[row].get("func_type") not in (0, 1):
            raise InputError(f"UFF record {label(row)} is not a time response; choose a time "
                             f"response with --row N; its records: {listing}")
        return row
    times = [i for i, h in heads.items() if h.get("func_type") == 1]
    if len(times) == 1:
        return times[0]
    if not times:
        raise InputError(f"holds no time-response record (UFF 58 function type 1); its records: "
                         f"{listing}; choose one with --row N")
    raise InputError(f"holds {len(times)} time-response records ({listing}); choose one with "
                     "--row N")
