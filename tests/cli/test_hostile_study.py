"""More hostile cases for ``verify``, ``export``, ``simulate`` and ``study``: exit 2 with one
stderr line, no traceback, nothing outside the output changed, nothing written on a refusal,
``--force`` replacing only what dampfit wrote, memory bounded by the data, and Markdown that
carries no raw markup from a user's string.

Cases that would need OpenSeesPy only to get past ``verify``'s availability check pretend it
is there (``opensees.unavailable`` → None): they must fail before OpenSees would run.
"""

from __future__ import annotations

import json
import re
import time
import warnings
import zipfile
from pathlib import Path

import pandas as pd
import pytest

from dampfit import simulate as sim
from dampfit.files.atomic import WriteError, atomic_write_text
from dampfit.errors import InputError
from dampfit.fem import opensees
from dampfit.study import config as sconfig
from dampfit.study import runner
from dampfit.study.store import Store
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, run_subprocess, snapshot
from tests._support.fem import write_summary
from tests._support.fem import write_result
from tests._support.study import AVAILABLE, SMALL, base
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401 (autouse)

LONG = "x" * 300  # longer than NAME_MAX (255 bytes) of every common file system


@pytest.fixture
def no_opensees_needed(monkeypatch):
    """verify's availability check passes; OpenSees itself must not be reached."""
    monkeypatch.setattr(opensees, "unavailable", lambda: None)

    def boom(*a, **k):
        raise AssertionError("OpenSees ran although the case must fail before it")

    monkeypatch.setattr(opensees, "free_decay", boom)


def fails(tmp_path, capsys, argv, match, exclude=()):
    """``dampfit ARGV``: exit 2, one line containing ``match``, nothing under tmp_path changed."""
    before = snapshot(tmp_path, exclude=exclude)
    code, out, err = run(argv, capsys)
    line = assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path, exclude=exclude))
    return line


# -- B4/B7: verify --out ------------------------------------------------------------------------


def test_verify_refuses_an_existing_out_file_without_force(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (tmp_path / "thesis.png").write_bytes(b"my figure")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "thesis.png"],
          "exists; use --force")


def test_verify_refuses_a_symlinked_out_without_force(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (tmp_path / "precious.png").write_bytes(b"keep")
    (tmp_path / "fig.png").symlink_to(tmp_path / "precious.png")
    (tmp_path / "dangling.png").symlink_to(tmp_path / "nowhere" / "x.png")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "fig.png"], "symbolic link")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "dangling.png"], "symbolic link")


@pytest.mark.parametrize("name", ["fig.txt", "fig.docx", "fig.exe"])
def test_verify_refuses_an_unknown_figure_format_before_any_work(tmp_path, capsys,
                                                                  no_opensees_needed, name):
    folder = write_result(tmp_path / "r")
    line = fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / name], "unknown format")
    assert ".png" in line and ".pdf" in line


def test_verify_refuses_a_name_too_long(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / f"{LONG}.png"], "too long")


@pytest.mark.usefixtures("requires_opensees")
def test_verify_force_replaces_a_link_not_its_target(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    (tmp_path / "precious.png").write_bytes(b"keep")
    link = tmp_path / "fig.png"
    link.symlink_to(tmp_path / "precious.png")
    code, _, err = run(["verify", folder, "--out", link, "--force"], capsys)
    assert code == 0 and err == "", err
    assert (tmp_path / "precious.png").read_bytes() == b"keep"
    assert not link.is_symlink() and link.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# -- B5: a foreign report is never touched, and nothing is written on exit 2 -------------------


def test_verify_bad_out_with_a_foreign_report_writes_nothing(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    (folder / "report.html").write_text("<p>my own report</p>")
    fails(tmp_path, capsys, ["verify", folder, "--out", tmp_path / "f.txt"], "unknown format")


@pytest.mark.usefixtures("requires_opensees")
def test_verify_leaves_a_foreign_report_alone_and_says_so(tmp_path, capsys):
    folder = write_result(tmp_path / "r")
    (folder / "report.html").write_text("<p>my own report</p>")
    (folder / "report.md").write_text("# mine\n")
    before = snapshot(tmp_path, exclude=[folder / "verification.json", folder / "verify.png"])
    code, out, err = run(["verify", folder], capsys)
    assert code == 0 and err == "", err
    assert_unchanged(before, snapshot(tmp_path, exclude=[folder / "verification.json",
                                                         folder / "verify.png"]))
    assert "report not updated" in out and "not written by dampfit" in out
    assert (folder / "verification.json").is_file()


# -- B6: no stray 'Process 0 Terminating' from OpenSees' native exit code ----------------------


def test_verify_on_a_bad_folder_prints_exactly_one_line_in_a_real_process(tmp_path):
    before = snapshot(tmp_path)
    code, out, err = run_subprocess(["verify", tmp_path / "missing"], timeout=300)
    assert_one_line_error(code, err, 2)
    assert "Terminating" not in err and out == ""
    assert_unchanged(before, snapshot(tmp_path))


@pytest.mark.usefixtures("requires_opensees")
def test_a_successful_verify_prints_nothing_on_stderr_in_a_real_process(tmp_path):
    folder = write_result(tmp_path / "r")
    code, out, err = run_subprocess(["verify", folder], timeout=300)
    assert code == 0, err
    assert err == "", err  # not even OpenSees' "Process 0 Terminating"
    assert "decay rate p" in out


# -- B14 (verify): signals.npz cannot make verify allocate more than the file holds -----------


def _npz_with_member(path: Path, name: str, header_shape: tuple, n_bytes: int,
                     compress: bool) -> None:
    """An .npz whose member ``name`` has a float64 header of ``header_shape`` followed by
    ``n_bytes`` zero bytes, streamed (never held in memory)."""
    import io

    from numpy.lib import format as npformat

    head = io.BytesIO()
    npformat.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                           "shape": header_shape})
    chunk = bytes(2**20)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED) as zf:
        with zf.open(name, "w", force_zip64=True) as fp:
            fp.write(head.getvalue())
            for start in range(0, n_bytes, len(chunk)):
                fp.write(chunk[:n_bytes - start])


def test_verify_refuses_a_zip_bomb_signals_npz_before_loading(tmp_path, capsys, no_opensees_needed):
    folder = write_result(tmp_path / "r")
    path = folder / "signals.npz"
    # 160 MB of zeros in a < 1 MB file: np.load would allocate all of it
    _npz_with_member(path, "t.npy", (20_000_000,), 160_000_000, compress=True)
    assert path.stat().st_size < 2**20
    t0 = time.perf_counter()
    line = fails(tmp_path, capsys, ["verify", folder], "zip bomb")
    assert "signals.npz" in line and time.perf_counter() - t0 < 10


def test_verify_refuses_an_npy_header_declaring_more_than_the_file_holds(tmp_path, capsys,
                                                                          no_opensees_needed):
    folder = write_result(tmp_path / "r")
    _npz_with_member(folder / "signals.npz", "t.npy", (10**8,), 800, compress=False)
    line = fails(tmp_path, capsys, ["verify", folder], "declares shape (100000000,)")
    assert "signals.npz" in line


# -- B11: names too long, dangling links ------------------------------------------------------


def test_export_refuses_a_file_name_too_long(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    fails(tmp_path, capsys, ["export", folder, "--format", "lsdyna", "--out", tmp_path / f"{LONG}.k"],
          "File name too long")


def test_simulate_refuses_a_file_name_too_long_before_simulating(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sim, "recording", lambda *a, **k: pytest.fail("simulated anyway"))
    fails(tmp_path, capsys, ["simulate", "--out", tmp_path / f"{LONG}.csv"], "File name too long")
    # the CSV name fits, the truth file's (longer) name does not: refused before either is written
    fails(tmp_path, capsys, ["simulate", "--out", tmp_path / ("y" * 245 + ".csv")],
          "File name too long")


def test_simulate_writes_both_files_or_neither(tmp_path, capsys, monkeypatch):
    def full_disk(truth, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(sim, "write_truth", full_disk)
    line = fails(tmp_path, capsys, ["simulate", "--out", tmp_path / "rec.csv", "--duration", "5"],
                 "No space left on device")
    assert "nothing was written" in line
    assert not list(tmp_path.iterdir())  # no staging debris either


def test_atomic_write_text_fits_long_names_and_turns_os_errors_into_one_line(tmp_path):
    name = "z" * 250  # fits, but ".NAME.XXXXXXXX.tmp" would not
    atomic_write_text(tmp_path / name, "ok")
    assert (tmp_path / name).read_text() == "ok"
    with pytest.raises(WriteError, match="File name too long"):
        atomic_write_text(tmp_path / LONG, "no")
    assert isinstance(WriteError("x"), InputError)
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_export_onto_a_dangling_link_needs_force_and_replaces_the_link(tmp_path, capsys):
    folder = write_summary(tmp_path / "r")
    link = tmp_path / "deck.k"
    target = tmp_path / "elsewhere" / "deck.k"
    link.symlink_to(target)
    fails(tmp_path, capsys, ["export", folder, "--format", "lsdyna", "--out", link],
          "exists; use --force to replace it (it is a symbolic link")
    code, _, err = run(["export", folder, "--format", "lsdyna", "--out", link, "--force"], capsys)
    assert code == 0, err
    assert not link.is_symlink() and link.read_text().startswith("*KEYWORD")
    assert not (tmp_path / "elsewhere").exists()


# -- B3: the study name and source carry no markup into summary.md ----------------------------


@pytest.mark.parametrize("name", ["two\nlines", "cr\rname", "tab\tname", "nul\x00", "x" * 201])
def test_study_name_must_be_one_printable_line(name):
    with pytest.raises(InputError, match=r"\[study\] name must be one line"):
        sconfig.parse(base(study__name=name), AVAILABLE)


def test_study_name_with_newline_in_a_file_is_one_error_line(tmp_path, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text(SMALL.replace('name = "tiny"', 'name = "a\\n# <script>alert(1)</script>"'))
    fails(tmp_path, capsys, ["study", cfg, "--out", tmp_path / "o", "--quiet"], "[study] name")


def _pre_block(md: str, heading: str) -> tuple[str, str]:
    """(raw text, text as a browser shows it) of the ``<pre>`` block after ``heading``."""
    import html

    after = md.split(heading, 1)[1]
    m = re.search(r'<pre><code class="language-toml">(.*?)</code></pre>', after, re.S)
    assert m, after
    return m.group(1), html.unescape(m.group(1))


def test_summary_md_escapes_the_name_and_fences_the_source(tmp_path):
    """The name is escaped for Markdown and HTML; the TOML source is shown verbatim as a
    preformatted block whose ``& < >`` are entities: no tag of the source reaches the file raw
    (issue 19: a raw ``<script>`` inside a fenced code block was flagged), and nothing in it can
    end the block early."""
    name = "# <script>alert(1)</script> & `rm -rf` *bold* [x](javascript:y) | ~z~"
    source = ('[study]\nname = "<script>alert(1)</script>"\n# ```\n# <img src=x onerror=alert(1)>\n'
              '# ````\n# </code></pre> <b>\nreplicates = 1\n')
    cfg = sconfig.parse(base(study__name=name), AVAILABLE, source=source)
    rank = pd.DataFrame({"rank": [1], "estimator": ["<b>hilbert</b>"], "rmse_crlb": [1.5]})
    agg = pd.DataFrame({"label": ["zeta=0.01 | <i>"], "estimator": ["hilbert"], "n": [2]})
    md = runner._summary_md(cfg, [], agg, rank, "test", figures=False)
    title = md.splitlines()[0]
    assert title.startswith("# Simulation study: ")
    shown = title.removeprefix("# Simulation study: ")
    assert "<" not in shown and ">" not in shown and "&lt;script&gt;" in shown
    assert re.search(r"(?<!\\)[`*\[\]|~#]", shown) is None  # every special is escaped
    assert "&amp;" in shown
    # the whole source is shown verbatim inside one block
    raw, text = _pre_block(md, "## Configuration")
    assert text == source.rstrip()
    # no raw tag anywhere but the block's own <pre><code>…</code></pre>
    outside = md.replace(f'<pre><code class="language-toml">{raw}</code></pre>', "")
    assert "<" not in outside.replace("<=", "") and "<" not in raw
    assert "&lt;b&gt;hilbert&lt;/b&gt;" in md and "zeta=0.01 \\| &lt;i&gt;" in md


def test_study_figures_take_a_name_with_dollar_signs_as_text(tmp_path):
    from dampfit.study.figures import save_figures

    agg = pd.DataFrame({"estimator": ["a", "b"], "label": ["s", "s"], "quantity": ["c", "c"],
                        "rmse_crlb": [1.2, 2.0], "coverage": [0.9, 0.8], "n": [4, 4],
                        "n_intervals": [4, 4]})
    rank = pd.DataFrame({"estimator": ["a", "b"]})
    paths = save_figures(agg, rank, tmp_path, r"cost $\frac{$ of $x")  # bad mathtext
    assert all(p.stat().st_size > 1000 for p in paths)


# -- B12/B13: --force writes only into a dampfit study; a refusal leaves no .lock -------------


@pytest.fixture
def study_file(tmp_path):
    cfg = tmp_path / "s.toml"
    cfg.write_text(SMALL)
    return cfg


@pytest.mark.parametrize("content", [
    {"summary.md": "# my notes\n", "runs.csv": "a,b\n1,2\n"},
    {"study.json": '{"name": "not a study"}', "ranking.png": "mine"},
    {"study.json": "not json at all", "runs.jsonl": "mine\n"},
], ids=["user-files", "foreign-study-json", "corrupt-study-json"])
@pytest.mark.parametrize("force", [False, True], ids=["plain", "force"])
def test_study_never_writes_into_a_folder_that_is_not_a_dampfit_study(tmp_path, capsys,
                                                                      study_file, content, force):
    folder = tmp_path / "mine"
    folder.mkdir()
    for name, text in content.items():
        (folder / name).write_text(text)
    line = fails(tmp_path, capsys, ["study", study_file, "--out", folder, "--quiet",
                                    *(["--force"] if force else [])], str(folder))
    assert "study" in line
    assert not (folder / ".lock").exists()


def test_study_force_replaces_only_a_dampfit_study(tmp_path):
    cfg = sconfig.parse(base(), AVAILABLE)
    store = Store(tmp_path / "s")
    store.open(cfg, force=False, version="x")
    store.append({"scenario": "s1", "replicate": 0, "rows": []})
    store.close()
    (tmp_path / "s" / "notes.txt").write_text("mine")
    other = sconfig.parse(base(study__seed=9), AVAILABLE)
    forced = Store(tmp_path / "s")
    forced.open(other, force=True, version="x")
    assert forced.records() == [] and not forced.runs_path.exists()
    forced.close()
    assert (tmp_path / "s" / "notes.txt").read_text() == "mine"  # not a study file: kept
    assert json.loads((tmp_path / "s" / "study.json").read_text())["fingerprint"] == other.fingerprint()
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["notes.txt", "study.json"]


def test_a_refused_study_leaves_no_lock_file(tmp_path, capsys, study_file):
    cfg = sconfig.parse(base(), AVAILABLE)
    store = Store(tmp_path / "s")
    store.open(cfg, force=False, version="x")
    store.close()
    assert not (tmp_path / "s" / ".lock").exists()  # removed by the store that created it
    fails(tmp_path, capsys, ["study", study_file, "--out", tmp_path / "s", "--quiet"],
          "different configuration")


def test_a_study_refused_later_leaves_no_folder(tmp_path, capsys, study_file):
    """An unreachable scheduler is found after the folder checks: nothing may remain."""
    fails(tmp_path, capsys, ["study", study_file, "--out", tmp_path / "new", "--quiet",
                             "--scheduler", "nonsense://"], "cannot reach the Dask scheduler")
    assert not (tmp_path / "new").exists()


def test_a_second_store_is_refused_while_the_first_holds_the_lock(tmp_path):
    cfg = sconfig.parse(base(), AVAILABLE)
    first = Store(tmp_path / "s")
    first.open(cfg, force=False, version="x")
    with pytest.raises(InputError, match="another dampfit study is running"):
        Store(tmp_path / "s").open(cfg, force=False, version="x")
    assert (tmp_path / "s" / ".lock").exists()  # the loser does not remove the holder's lock
    first.close()
    assert not (tmp_path / "s" / ".lock").exists()


# -- B14 (study): what 'dampfit simulate' refuses, the study refuses up front ----------------


@pytest.mark.parametrize("over, match", [
    ({"fixed__duration": 1e6, "fixed__sample_rate": 1000.0}, r"1e\+09 samples; at most 5e\+07"),
    ({"fixed__sample_rate": 1e9, "fixed__duration": 0.01}, r"sample_rate = 1e\+09 Hz is beyond"),
    ({"fixed__sample_rate": 0.0}, r"sample_rate must be positive"),
    ({"fixed__sample_rate": 3.0}, r"natural frequency 2 Hz is not below the Nyquist"),
    ({"fixed__duration": 1e-300}, r"at least 16 are needed"),
    ({"fixed__jitter": 1.5}, r"jitter must be a coefficient of variation in \[0, 1\]"),
    ({"fixed__tilt_deg": 120.0}, r"tilt_deg must be an angle in \[-90, 90\]"),
    ({"fixed__gaps": 10**9}, r"gaps = 1000000000 gaps .* do not fit"),
    ({"fixed__u0": 1e6}, r"u0 must be a displacement in \[0, 100\] m"),
    ({"fixed__noise_density": 1e300}, r"noise_density = 1e\+300 µg/√Hz is beyond"),
    ({"fixed__drift": 1e300}, r"drift = 1e\+300 m/s² is beyond"),
    ({"study__mass": 1e300}, r"\[study\] mass must be a positive number of kilograms \(at most 1e\+06\)"),
    ({"study__mass": 2e6}, r"at most 1e\+06"),
])
def test_study_refuses_scenarios_simulate_refuses(over, match):
    with pytest.raises(InputError, match=match):
        sconfig.parse(base(**over), AVAILABLE)


def test_check_limits_uses_the_cli_limit():
    cfg = sim.from_modal(1.0, 2.0, 0.01, duration=sim.MAX_SIM_SAMPLES / 100.0, sample_rate=100.0)
    sim.check_limits(cfg)  # exactly at the limit: fine
    with pytest.raises(InputError, match="samples; at most"):
        sim.check_limits(sim.from_modal(1.0, 2.0, 0.01, duration=sim.MAX_SIM_SAMPLES / 99.0,
                                        sample_rate=100.0))


def test_absurd_study_mass_is_one_line_without_a_runtime_warning(tmp_path, capsys, study_file):
    study_file.write_text(SMALL.replace("mass = 0.5", "mass = 1e300"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fails(tmp_path, capsys, ["study", study_file, "--out", tmp_path / "o", "--quiet"],
              "[study] mass")
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)]


def test_study_scenario_error_via_the_cli_is_one_line(tmp_path, capsys, study_file):
    study_file.write_text(SMALL.replace("duration = 8", "duration = 1e7"))
    fails(tmp_path, capsys, ["study", study_file, "--out", tmp_path / "o", "--quiet"],
          "samples; at most")


def test_study_toml_nested_5000_deep_is_one_line(tmp_path, capsys):
    cfg = tmp_path / "deep.toml"
    cfg.write_text("[fixed]\nbias = " + "[" * 5000 + "]" * 5000 + "\n")
    fails(tmp_path, capsys, ["study", cfg, "--out", tmp_path / "o"], "nested too deeply")


def test_study_file_too_large_is_refused_without_reading_it(tmp_path, capsys):
    cfg = tmp_path / "big.toml"
    with open(cfg, "wb") as fh:
        fh.truncate(50 * 2**20)
    fails(tmp_path, capsys, ["study", cfg, "--out", tmp_path / "o"], "more than the limit")
