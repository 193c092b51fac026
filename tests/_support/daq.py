"""Small DAQ files made by the tests: LabVIEW LVM (text, written per NI's LVM specification),
NI TDMS (npTDMS's ``TdmsWriter``), UFF 58 (pyuff's ``prepare_58`` and ``write_sets``), and a
CONTEC-style data-logger CSV (a settings preamble, raw counts, no time column)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["FS", "F1", "F2", "cantilever", "write_lvm", "write_tdms", "write_uff", "write_logger_csv"]

FS = 1653.0  # [Hz] the hammer test's sample rate
F1, F2 = 12.0, 75.0  # [Hz] the first two bending modes of the simulated cantilever


def cantilever(n_sec: float = 4.0, fs: float = FS) -> tuple[np.ndarray, np.ndarray]:
    """Time [s] and a two-mode hammer-test response [g] (ζ₁ = 1 %, ζ₂ = 0.5 %), a little noise."""
    t = np.arange(int(n_sec * fs)) / fs
    a = (0.8 * np.exp(-2 * np.pi * F1 * 0.01 * t) * np.sin(2 * np.pi * F1 * t)
         + 0.3 * np.exp(-2 * np.pi * F2 * 0.005 * t) * np.sin(2 * np.pi * F2 * t))
    return t, a + 1e-3 * np.random.default_rng(1).standard_normal(t.size)


def write_lvm(path: Path, t, channels: dict[str, np.ndarray], units: dict[str, str] | None = None,
              x_columns: str = "One", declared: int | None = None) -> Path:
    """An LVM file (Writer_Version 2, tab-separated, one segment) of ``channels`` over ``t`` [s]."""
    names = list(channels)
    units = units or {}
    n = len(names)
    tab = "\t"
    head = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab",
            "Decimal_Separator\t.", "Multi_Headings\tNo", f"X_Columns\t{x_columns}",
            "Time_Pref\tRelative", "Operator\tdampfit tests", "Date\t2026/12/01",
            "Time\t10:00:00.000", "***End_of_Header***", ""]
    dx = float(t[1] - t[0])
    seg = [f"Channels\t{n}", "Samples\t" + tab.join([str(declared or len(t))] * n),
           "Date\t" + tab.join(["2026/12/01"] * n), "Time\t" + tab.join(["10:00:00"] * n),
           "Y_Unit_Label\t" + tab.join(units.get(c, "") for c in names),
           "X_Dimension\t" + tab.join(["Time"] * n), "X0\t" + tab.join(["0.0000000000000000E+0"] * n),
           "Delta_X\t" + tab.join([f"{dx:.16E}"] * n), "***End_of_Header***",
           "X_Value\t" + tab.join(names) + "\tComment"]
    rows = []
    for i in range(len(t)):
        vals = tab.join(f"{channels[c][i]:.9f}" for c in names)
        rows.append((f"{t[i]:.9f}\t" if x_columns != "No" else "\t") + vals)
    path.write_text("\n".join(head + seg + rows) + "\n")
    return path


def write_tdms(path: Path, channels: dict[str, np.ndarray], *, group: str = "Accel",
               dt: float | None = 1 / FS, units: dict[str, str] | None = None,
               more_groups: dict[str, dict[str, np.ndarray]] | None = None) -> Path:
    """A TDMS file through npTDMS's own writer: ``channels`` in ``group`` with waveform
    properties (``wf_increment = dt``; none when ``dt`` is None) and ``unit_string``."""
    from nptdms import ChannelObject, TdmsWriter

    units = units or {}
    objs = []
    for g, chans in {group: channels, **(more_groups or {})}.items():
        for name, values in chans.items():
            props = {"unit_string": units.get(name, "")} if units.get(name) else {}
            if dt is not None:
                props.update(wf_increment=dt, wf_start_offset=0.0)
            objs.append(ChannelObject(g, name, np.asarray(values, dtype=np.float64), properties=props))
    with TdmsWriter(str(path)) as w:
        w.write_segment(objs)
    return path


def write_uff(path: Path, records: list[dict]) -> Path:
    """A UFF file of data set 58 records through pyuff: each ``{"t", "a", "name", "func_type"
    (1: time response), "unit"}``."""
    import pyuff

    sets = []
    for k, r in enumerate(records):
        t = np.asarray(r["t"], dtype=np.float64)
        sets.append(pyuff.prepare_58(
            binary=0, id1=r.get("name", f"accel {k}"), id2="dampfit test", id3="01-Dec-26",
            func_type=r.get("func_type", 1), rsp_node=k + 1, rsp_dir=3, ref_node=0, ref_dir=0,
            ord_data_type=4, num_pts=t.size, abscissa_spacing=1, abscissa_min=float(t[0]),
            abscissa_inc=float(t[1] - t[0]), abscissa_spec_data_type=17,
            ordinate_spec_data_type=12, ordinate_axis_units_lab=r.get("unit", "g"),
            abscissa_axis_units_lab="s", orddenom_spec_data_type=0, z_axis_spec_data_type=0,
            x=t, data=np.asarray(r["a"], dtype=np.float64)))
    uff = pyuff.UFF(str(path))
    uff.write_sets(sets, mode="overwrite")
    return path


def write_logger_csv(path: Path, counts: np.ndarray, fs: float) -> Path:
    """A CONTEC-style logger CSV: a 14-line settings preamble, a row of channel names
    CH1…CHn, then raw ADC counts (integers), no time column."""
    n_ch = counts.shape[1]
    pre = ["[Header]", "Model,C-LGR-DEMO", "Version,1.02", "Device Name,LOGGER1",
           "Start Date,2026/12/01", "Start Time,10:00:00", f"Sampling Clock,{1000 / fs:g}ms",
           f"Sampling Rate,{fs:g}Hz", f"Channel Count,{n_ch}", "Range,+/-10V",
           "Resolution,16bit", "Trigger,Manual", "Data Type,Raw", "[Data]"]
    rows = [",".join(f"CH{i + 1}" for i in range(n_ch))]
    rows += [",".join(str(int(v)) for v in row) for row in counts]
    path.write_text("\n".join(pre + rows) + "\n")
    return path
