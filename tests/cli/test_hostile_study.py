"""Hostile study files and study folders (``dampfit study``): exit 2 with one stderr line, no
traceback, nothing outside the output changed, nothing written on a refusal, ``--force`` replacing
only a dampfit study, no ``.lock`` left behind, what ``dampfit simulate`` refuses refused up front,
absurd or malformed values in the TOML, and a study name or source that carries no raw markup
into ``summary.md`` or the figures."""

from __future__ import annotations

import json
import re
import time
import warnings

import pandas as pd
import pytest

from dampfit import simulate as sim
from dampfit.errors import InputError
from dampfit.study import config as sconfig
from dampfit.study import runner
from dampfit.study.store import Store
from tests._support.hostile import assert_one_line_error, assert_unchanged, run, snapshot
from tests._support.hostile import fails
from tests._support.study import AVAILABLE, SMALL, base
from tests._support.hostile import no_compile_cache as _no_compile_cache  # noqa: F401 (autouse)


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


# -- study files with absurd or malformed values --------------------------------------------


_STUDY = ('[study]\nreplicates = {rep}\nestimators = ["hilbert"]\nmass = 1.0\n{study}\n'
          "[grid]\n{grid}\n[fixed]\nf_n = 2.0\n{fixed}\n")

@pytest.mark.parametrize("fields,match", [
    ({"rep": "1000000000000000000000"}, "more than the limit of 100,000"),
    ({"rep": "-1"}, "replicates must be an integer ≥ 1"),
    ({"rep": '"3"'}, "replicates must be an integer ≥ 1"),
    ({"grid": "zeta = [nan]"}, "must be a finite number"),
    ({"grid": "zeta = [[0.01]]"}, "must be a finite number"),
    ({"grid": "zeta = [1.0]"}, "damping ratio zeta must be in [0, 1)"),
    ({"fixed": 'main_axis = "../../etc"'}, "main_axis must be one of x, y, z"),
    ({"fixed": "gaps = -5"}, "gaps must be a non-negative integer"),
    ({"study": "replicates = 2"}, "is not valid TOML"),
    ({"study": "seed = -1"}, "seed must be an integer ≥ 0"),
], ids=["replicates-huge", "replicates-negative", "replicates-string", "zeta-nan", "zeta-nested",
        "zeta-1", "main-axis-path", "gaps-negative", "duplicate-key", "seed-negative"])
def test_study_file_with_absurd_values(tmp_path, capsys, fields, match):
    values = {"rep": "2", "study": "", "grid": "zeta = [0.01]", "fixed": "", **fields}
    cfg = tmp_path / "bad.toml"
    cfg.write_text(_STUDY.format(**values))
    before = snapshot(tmp_path)
    code, _, err = run(["study", cfg, "--out", tmp_path / "bad.study"], capsys)
    assert_one_line_error(code, err, 2, match)
    assert_unchanged(before, snapshot(tmp_path))


# -- study grid ---------------------------------------------------------------------------------


def test_study_grid_of_1e10_scenarios_is_refused_at_once(tmp_path, capsys):
    axes = ["zeta", "u0", "duration", "sample_rate", "jitter", "noise_density", "drift",
            "quantization", "tilt_deg", "azimuth_deg"]
    grid = "\n".join(f"{a} = [{', '.join(str(0.01 * (i + 1)) for i in range(10))}]" for a in axes)
    cfg = tmp_path / "huge.toml"
    cfg.write_text('[study]\nreplicates = 3\nestimators = ["hilbert"]\nmass = 1.0\n'
                   f"[grid]\n{grid}\n[fixed]\nf_n = 2.0\n")
    before = snapshot(tmp_path)
    t0 = time.perf_counter()
    code, _, err = run(["study", cfg, "--out", tmp_path / "huge.study"], capsys)
    assert time.perf_counter() - t0 < 10
    line = assert_one_line_error(code, err, 2, "30,000,000,000 runs")
    assert "10,000,000,000 scenarios × 3 replicates" in line and "100,000" in line
    assert_unchanged(before, snapshot(tmp_path))


def test_a_huge_study_config_built_in_python_is_refused_too():
    from dampfit.errors import InputError
    from dampfit.study.config import StudyConfig

    cfg = StudyConfig("big", 1, 0, ("hilbert",), 1.0, {},
                      {f"a{i}": list(range(100)) for i in range(5)}, {"f_n": 2.0, "zeta": 0.01})
    assert cfg.n_runs == 10**10
    with pytest.raises(InputError, match="10,000,000,000 runs"):
        cfg.tasks()
