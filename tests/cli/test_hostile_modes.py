"""Bad several-modes options of ``dampfit analyze`` (issue 21): ``--max-modes`` 0, 100, not a
number; ``--mode-of-mass`` out of range or beyond ``--max-modes``; ``--mode-of-mass`` or a bad
``--max-modes`` with a campaign (which pools the mode its band isolates);
``--mode-of-mass 2`` on a one-mode recording. Each: exit 2, one line, nothing written. And
the validating reader refuses an edited ``modes`` section in one line."""

from __future__ import annotations

import json

import pytest

from dampfit.cli import options
from dampfit.errors import InputError
from dampfit.inference import modes as inference_modes
from dampfit.result.schema import read_summary
from tests._support.hostile import (assert_one_line_error, assert_unchanged, decay, decay_csv,
                                    run, snapshot)


@pytest.mark.parametrize("argv, match", [
    (["--max-modes", "0"], "--max-modes"),
    (["--max-modes", "100"], "--max-modes"),
    (["--max-modes", "two"], "not an integer"),
    (["--max-modes", "2.5"], "not an integer"),
    (["--max-modes", ""], "not an integer"),
    (["--mode-of-mass", "0"], "--mode-of-mass"),
    (["--mode-of-mass", "9"], "--mode-of-mass"),
    (["--mode-of-mass", "x"], "not an integer"),
    (["--mode-of-mass", "3", "--max-modes", "2"], "beyond --max-modes 2"),
])
def test_bad_modes_options_are_one_line(tmp_path, capsys, argv, match):
    csv = decay_csv(tmp_path / "d.csv", *decay())
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", csv, "--out", tmp_path / "out", *argv], capsys)
    assert_one_line_error(code, err, match=match)
    assert_unchanged(before, snapshot(tmp_path))


@pytest.mark.parametrize("argv", [["--mode-of-mass", "1"], ["--max-modes", "0"],
                                  ["--max-modes", "100"]])
def test_modes_options_are_refused_for_a_campaign(tmp_path, capsys, argv):
    a = decay_csv(tmp_path / "a.csv", *decay())
    b = decay_csv(tmp_path / "b.csv", *decay(fs=120.0))
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", a, b, "--out", tmp_path / "out", *argv], capsys)
    assert_one_line_error(code, err, match=argv[0])
    assert_unchanged(before, snapshot(tmp_path))


def test_mode_of_mass_beyond_the_modes_found(tmp_path, capsys):
    csv = decay_csv(tmp_path / "d.csv", *decay())
    before = snapshot(tmp_path)
    code, _, err = run(["analyze", csv, "--out", tmp_path / "out", "--mass", "1",
                        "--mode-of-mass", "2", "--max-modes", "4", "--max-steps", "2000",
                        "--no-figures",
                        "--quiet"], capsys)
    assert_one_line_error(code, err, match="the recording has 1 mode")
    assert_unchanged(before, snapshot(tmp_path))


def test_max_modes_one_runs_without_the_modal_stage(tmp_path, capsys):
    csv = decay_csv(tmp_path / "d.csv", *decay())
    code, _, err = run(["analyze", csv, "--out", tmp_path / "out", "--max-modes", "1",
                        "--max-steps", "2000", "--no-figures", "--quiet"], capsys)
    assert code == 0, err
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["n_modes"] == 1 and s["modes_evidence"]["screen"] is None
    assert s["provenance"]["options"]["max_modes"] == 1


def test_the_cli_limits_are_the_library_s():
    assert options.DEFAULT_MAX_MODES == inference_modes.DEFAULT_MAX_MODES
    assert options.MAX_MODES_LIMIT == inference_modes.MAX_MODES_LIMIT


@pytest.mark.parametrize("edit, match", [
    ({"modes": "x"}, "'modes' must be a list"),
    ({"modes": [3]}, "modes[0] must be an object"),
    ({"modes": [{"index": 1, "zeta": 0.01}]}, "modes[0].zeta must be an object"),
    ({"modes": [{"index": 1}], "n_modes": 5}, "'n_modes' must be a whole number"),
    ({"modes": [{"index": 1}], "n_modes": True}, "'n_modes' must be a whole number"),
    ({"modes_evidence": [1]}, "'modes_evidence' must be an object"),
    ({"rayleigh": "fast"}, "'rayleigh' must be an object"),
])
def test_an_edited_modes_section_is_refused(tmp_path, edit, match):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps({"parameters": {}, **edit}))
    with pytest.raises(InputError, match=__import__("re").escape(match)):
        read_summary(folder)


def test_a_summary_without_modes_is_still_read(tmp_path):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps({"parameters": {}}))
    assert "modes" not in read_summary(folder).data


@pytest.mark.heavy
def test_the_cli_runs_in_a_process_that_used_xarray_before(tmp_path):
    """xarray caches "is Dask installed?" on first use; a process that used it before calling
    the CLI in-process (a script, a notebook, a test session) must not see the CLI's
    Dask-absent shortcut clash with that cached answer (it raised "No module named
    'dask.base'")."""
    import subprocess
    import sys

    csv = decay_csv(tmp_path / "d.csv", *decay())
    code = ("import sys, xarray\n"  # xarray's import asks about Dask (and caches "yes")
            "from dampfit.cli import main\n"
            f"sys.exit(main(['analyze', {str(csv)!r}, '--out', {str(tmp_path / 'out')!r}, "
            "'--mass', '1', '--max-steps', '2000', '--no-figures', '--quiet']))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert read_summary(tmp_path / "out").data["n_modes"] == 1
