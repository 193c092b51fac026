"""MATLAB MAT-files (v5 through scipy.io, v7.3 through h5py): variables, rows, time, limits."""

from __future__ import annotations

import io

import numpy as np
import pytest
import scipy.io as sio

from dampfit.io import matlab as matfile
from dampfit.errors import InputError

FS = 200.0
T = np.arange(2000) / FS
A = np.exp(-0.2 * T) * np.cos(2 * np.pi * 4.0 * T)


def v5(content: dict, compress: bool = True) -> bytes:
    buf = io.BytesIO()
    sio.savemat(buf, content, do_compression=compress)
    return buf.getvalue()


def v73(path, build) -> bytes:
    """A v7.3 MAT-file as MATLAB writes it: HDF5 behind a 512-byte text header, arrays transposed."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as h5:
        build(h5)
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 2026".ljust(116)
                 + b"\0" * 8 + b"\x00\x02IM")
    return path.read_bytes()


def test_struct_path_two_by_n_time_first():
    data = v5({"Fe": {"Out": {"Acc": np.vstack([T, A]), "Label": "run 1"}}})
    table = matfile.load(data, variable="Fe.Out.Acc")
    np.testing.assert_array_equal(table.columns["time"], T)
    np.testing.assert_array_equal(table.columns["a"], A)
    assert "Fe.Out.Acc" in table.notes[0] and table.version == "v5"


def test_detected_without_variable_and_transposed_storage():
    """Found without --variable, stored N × 4 (transposed); its three data rows need --row
    (issue 19: they used to be read as x, y, z of one vector, which two sensors are not)."""
    data = v5({"rec": np.column_stack([T, A, 2 * A, 3 * A])}, compress=False)
    table = matfile.load(data, row=2)
    assert list(table.columns) == ["time", "a"]
    np.testing.assert_array_equal(table.columns["a"], 2 * A)
    with pytest.raises(InputError, match=r"3 data rows: row 1 \(rms .*\), row 2 .*, row 3 .*--row"):
        matfile.load(data)


def test_several_rows_without_row_are_refused_naming_them():
    """Two sensors on one cantilever (tip and middle) in one 3 × N variable: not the axes of one
    vector, so --variable alone is refused with the rows named; --row picks one."""
    data = v5({"Fe": {"Out": {"Acc": np.vstack([T, A, 0.4 * A])}}})
    with pytest.raises(InputError, match=r"'Fe.Out.Acc' has 2 data rows: row 1 \(rms 0.\d+\), "
                                         r"row 2 \(rms 0.\d+\); row 0 is time;.*separate sensors.*"
                                         r"--row \(e.g. --row 1\)"):
        matfile.load(data, variable="Fe.Out.Acc")
    np.testing.assert_array_equal(matfile.load(data, variable="Fe.Out.Acc", row=2).columns["a"],
                                  0.4 * A)
    # two rows and a sibling sample rate (no time row): the same refusal, before the time
    with pytest.raises(InputError, match="2 data rows: row 0 .*row 1 .*--row"):
        matfile.load(v5({"S": {"acc": np.vstack([A, -A]), "fs": FS}}))


def test_row_picks_the_acceleration_and_the_time_row_is_refused():
    data = v5({"D": np.vstack([T, A, -A])})
    np.testing.assert_array_equal(matfile.load(data, row=2).columns["a"], -A)
    with pytest.raises(InputError, match="time row"):
        matfile.load(data, row=0)
    with pytest.raises(InputError, match="--row 5"):
        matfile.load(data, row=5)


def test_time_from_a_sibling_vector_or_sample_rate():
    table = matfile.load(v5({"S": {"acc": A, "fs": FS}}))
    np.testing.assert_allclose(table.columns["time"], T)
    table = matfile.load(v5({"S": {"acc": A, "time": T + 5.0}}))
    np.testing.assert_allclose(table.columns["time"], T + 5.0)
    with pytest.raises(InputError, match="no time"):
        matfile.load(v5({"S": {"acc": A}}))


def test_ambiguous_and_missing_variables_are_named():
    data = v5({"run1": np.vstack([T, A]), "run2": np.vstack([T, -A])})
    with pytest.raises(InputError, match="--variable") as exc:
        matfile.load(data)
    assert "run1" in str(exc.value) and "run2" in str(exc.value)
    with pytest.raises(InputError, match="no numeric variable 'Fe.Nope'"):
        matfile.load(data, variable="Fe.Nope")
    with pytest.raises(InputError, match="without numeric arrays"):
        matfile.load(v5({"note": "text only"}))


def test_v73_struct_in_matlab_orientation(tmp_path):
    def build(h5):
        h5.create_group("Fe").create_group("Out")["Acc"] = np.vstack([T, A]).T  # column-major
    table = matfile.load(v73(tmp_path / "r.mat", build), variable="Fe.Out.Acc")
    assert table.version == "v7.3"
    np.testing.assert_array_equal(table.columns["a"], A)


def test_compressed_bomb_is_refused_before_inflating():
    bomb = v5({"z": np.zeros((2, 5_000_000))})  # 80 MB of zeros in ≈ 80 kB
    assert len(bomb) < 1_000_000
    with pytest.raises(InputError, match="MiB"):
        matfile.load(bomb, max_bytes=2**24)


def test_v73_declared_size_is_refused(tmp_path):
    def build(h5):
        h5.create_dataset("big", shape=(2, 10**9), dtype="f8", chunks=(2, 1024),
                          compression="gzip")  # declared 16 GB, stored as nothing
    with pytest.raises(InputError, match="limit"):
        matfile.load(v73(tmp_path / "big.mat", build))


def test_garbage_after_a_matlab_header_is_one_error():
    with pytest.raises(InputError, match="MAT"):
        matfile.load(b"MATLAB 5.0 MAT-file".ljust(128, b" ") + b"\x00" * 7 + b"\xff" * 64)


def test_cli_reads_a_lab_struct_and_recovers_the_frequency(tmp_path, capsys):
    """A 2 kHz lab recording stored as Fe.Out.Acc (2 × N, g) analysed through the CLI."""
    import json

    from dampfit.cli import main

    fs, f, zeta = 2000.0, 12.0, 0.004
    t = np.arange(0.0, 6.0, 1 / fs)
    w = 2 * np.pi * f
    tau = np.clip(t - 0.5, 0.0, None)
    a = 2.0 * np.exp(-zeta * w * tau) * np.cos(w * np.sqrt(1 - zeta**2) * tau) * (t >= 0.5)
    a += np.random.default_rng(0).normal(0.0, 0.002, t.size)
    path = tmp_path / "lab.mat"
    sio.savemat(path, {"Fe": {"Out": {"Acc": np.vstack([t, a / 9.80665]), "Unit": "g"}}})
    out = tmp_path / "lab.dampfit"
    code = main(["analyze", str(path), "--variable", "Fe.Out.Acc", "--row", "1", "--accel-unit", "g",
                 "--mass", "0.5", "--out", str(out), "--quiet", "--no-figures", "--json"])
    assert code == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["input"]["format"] == "matlab"
    assert summary["parameters"]["f_n"]["q50"] == pytest.approx(f, rel=2e-3)
    assert summary["parameters"]["zeta"]["q50"] == pytest.approx(zeta, rel=0.1)


def test_cli_refuses_several_rows_without_row(tmp_path, capsys):
    from dampfit.cli import main

    mat = tmp_path / "two.mat"
    sio.savemat(mat, {"Fe": {"Out": {"Acc": np.vstack([T, A, -A])}}})
    code = main(["analyze", str(mat), "--variable", "Fe.Out.Acc", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and not (tmp_path / "o").exists()
    assert "row 1 (rms" in err and "row 2 (rms" in err and "--row" in err


def test_cli_mat_options_on_other_files_and_bad_variables(tmp_path, capsys):
    from dampfit.cli import main

    csv = tmp_path / "r.csv"
    csv.write_text("time,a\n" + "\n".join(f"{x},{np.sin(x * 20)}" for x in T[:400]))
    assert main(["analyze", str(csv), "--variable", "x", "--out", str(tmp_path / "o")]) == 2
    assert "MATLAB .mat files only" in capsys.readouterr().err
    mat = tmp_path / "r.mat"
    sio.savemat(mat, {"run1": np.vstack([T, A]), "run2": np.vstack([T, -A])})
    assert main(["analyze", str(mat), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--variable" in err and not (tmp_path / "o").exists()
