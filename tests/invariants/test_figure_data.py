"""Every figure is drawn from plain data (issue 20): summary.json + signals.npz + posterior.nc.

A live analysis, the same result loaded from its folder, the data the stages deliver as they
finish (what the figure process draws from) and :func:`dampfit.output.figures.redraw_missing`
of a folder whose PNGs were deleted all write the same bytes. A folder written before the
figure arrays existed loads, verifies and redraws what it can, with one note per figure it
cannot; hostile figure arrays in signals.npz are one line.
"""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

import dampfit
from dampfit import simulate as sim
from dampfit.errors import InputError
from dampfit.output import figures
from dampfit.output.figures import FIGURES, NEEDS, FigureData, redraw_missing, render
from dampfit.pipeline import analyze
from dampfit.result.folder import load_signals
from dampfit.result.signals import FIGURE_GROUPS, MAX_LINE, SIGNAL_KEYS
from tests._support.figures import pngs as _pngs

#: The figures of a one-mode result: all but ``modes``, which only a recording with several
#: modes has (tests/cli/test_report_modes.py draws and redraws it).
ALL = set(FIGURES) - {"modes"}


@pytest.fixture(scope="module")
def staged():
    """A short analysis with a mass and the plain data each stage delivered, in order."""
    rec = sim.recording(sim.preset("paper", duration=20.0, sample_rate=100.0, seed=4))[0]
    stages = []
    an = analyze(rec, mass=5.3, max_steps=2000, on_stage=lambda name, data: stages.append(
        (name, data)))
    return an, stages


@pytest.fixture(scope="module")
def folder(staged, tmp_path_factory):
    out = tmp_path_factory.mktemp("res") / "res"
    staged[0].save(out)
    return out


def test_save_then_load_round_trips(staged, folder):
    """``Analysis.save(dir)`` then ``dampfit.load(dir)``: the same summary, the same signals
    and the same posterior draws as the live analysis."""
    live, loaded = staged[0], dampfit.load(folder)
    assert loaded.summary() == live.summary()
    for key, value in live.signals().items():
        np.testing.assert_array_equal(loaded.signals()[key], value)
    np.testing.assert_array_equal(loaded.draws("c"), live.draws("c"))


@pytest.mark.heavy
def test_live_and_loaded_figures_are_the_same_bytes(staged, folder, tmp_path):
    an, _ = staged
    assert {p.stem for p in folder.glob("*.png")} == ALL
    loaded = dampfit.load(folder)
    again = tmp_path / "again"
    written = figures.save_figures(loaded, again)
    assert set(written) == ALL
    assert _pngs(again) == _pngs(folder)
    live = tmp_path / "live"  # and the live analysis drawn now, outside save()
    figures.save_figures(an, live)
    assert _pngs(live) == _pngs(folder)


@pytest.mark.heavy
def test_the_stage_data_draw_the_same_bytes_as_the_finished_analysis(staged, tmp_path):
    """What the figure process does, here: each figure drawn as soon as the data NEEDS names
    have arrived from the stages, the rest once the summary is there."""
    an, stages = staged
    assert [name for name, _ in stages] == ["fit", "posterior"]
    data, drawn = FigureData(), {}
    early = tmp_path / "early"
    early.mkdir()
    for _, delivered in stages:
        data.add(delivered)
        ready = [n for n in FIGURES if n not in drawn and NEEDS[n] <= data.keys()]
        drawn.update(render(data, ready, early))
    assert {"signal", "spectrum", "fit", "displacement", "posterior", "trace"} <= set(drawn)
    data.add({"summary": an.summary()})
    render(data, [n for n in FIGURES if n not in drawn], early)
    figures.save_figures(an, tmp_path / "final")
    assert _pngs(early) == _pngs(tmp_path / "final")


@pytest.mark.heavy
def test_each_figure_needs_only_what_needs_names(staged, tmp_path):
    an, _ = staged
    full = an.summary()
    (tmp_path / "part").mkdir()
    (tmp_path / "full").mkdir()
    for name, need in NEEDS.items():
        part = FigureData({k: v for k, v in full.items() if f"summary.{k}" in need},
                          an.signals() if "signals" in need else None,
                          an.posterior if "posterior" in need else None)
        drawn = render(part, [name], tmp_path / "part")[name]
        assert (drawn is None) == (render(an, [name], tmp_path / "full")[name] is None), name
        if drawn is None:  # does not apply to this result (modes: one mode) either way
            assert name not in ALL
            continue
        assert (tmp_path / "part" / f"{name}.png").read_bytes() == \
            (tmp_path / "full" / f"{name}.png").read_bytes(), name


def test_signals_are_computed_once_and_saved_as_computed(staged, folder):
    an, stages = staged
    sent = stages[0][1]["signals"]
    kept = an.signals()
    assert set(kept) == set(sent) and all(np.array_equal(kept[k], sent[k]) for k in kept)
    kept["t"][:] = 0.0  # a copy: the analysis keeps its own
    assert not np.array_equal(an.signals()["t"], kept["t"])
    loaded = load_signals(folder)
    assert set(loaded) == set(sent)
    for key, value in sent.items():
        np.testing.assert_array_equal(np.asarray(loaded[key]), value)


def test_figure_arrays_are_bounded(staged):
    """Lines over the whole recording are reduced for display; the masked samples and runs
    are bounded too (the 20 s recording has 2000 samples per axis; the bound is the same
    whatever the length)."""
    sig = staged[0].signals()
    for key in ("rec_signal_t", "rec_envelope_t", "spectrum_f"):
        assert 0 < sig[key].size <= MAX_LINE, key
    assert sig["rec_axes_n"].sum() == sig["rec_axes_t"].size
    assert np.all(sig["rec_axes_n"] <= MAX_LINE)


# ----------------------------------------------------------------------------- redraw
def test_redraw_missing_restores_every_figure_byte_for_byte(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    before = _pngs(copy)
    for png in copy.glob("*.png"):
        png.unlink()
    (copy / "report.html").write_text("x")  # other files are left alone
    done = redraw_missing(copy)
    assert sorted(done.drawn) == sorted(ALL) and done.notes == []
    assert _pngs(copy) == before
    assert (copy / "report.html").read_text() == "x"
    again = redraw_missing(copy)  # nothing missing: nothing drawn
    assert again.drawn == [] and again.notes == []
    assert _pngs(copy) == before


def test_dampfit_report_redraws_deleted_figures_into_the_report(folder, tmp_path, capsys):
    """``rm DIR/*.png; dampfit report DIR``: every figure is back, byte for byte, and shown in
    report.html; ``--no-redraw`` writes the report without them."""
    import shutil

    from dampfit import cli

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    before = _pngs(copy)
    bare = tmp_path / "bare"
    shutil.copytree(folder, bare)
    for d in (copy, bare):
        for png in d.glob("*.png"):
            png.unlink()
    assert cli.main(["report", str(copy)]) == 0
    assert "redrew" in capsys.readouterr().out
    assert _pngs(copy) == before
    assert (copy / "report.html").read_text().count("data:image/png") == len(ALL)
    assert cli.main(["report", str(bare), "--no-redraw"]) == 0
    assert _pngs(bare) == {}
    assert "data:image/png" not in (bare / "report.html").read_text()


def test_redraw_missing_draws_only_what_is_missing_and_never_follows_a_link(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    outside = tmp_path / "outside.txt"
    outside.write_text("not a figure")
    (copy / "fit.png").unlink()
    (copy / "fit.png").symlink_to(outside)
    (copy / "trace.png").unlink()
    (copy / "signal.png").write_bytes(b"mine")
    done = redraw_missing(copy)
    assert done.drawn == ["trace"]
    assert outside.read_text() == "not a figure" and (copy / "fit.png").is_symlink()
    assert (copy / "signal.png").read_bytes() == b"mine"
    assert (copy / "trace.png").read_bytes() == (folder / "trace.png").read_bytes()


def test_redraw_missing_writes_only_into_a_folder_dampfit_wrote(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    (copy / ".dampfit-result").unlink()
    (copy / "fit.png").unlink()
    with pytest.raises(InputError, match="not written by dampfit"):
        redraw_missing(copy)
    assert not (copy / "fit.png").exists()
    with pytest.raises(InputError, match="not a dampfit result folder"):
        redraw_missing(tmp_path / "nowhere")


def _rewrite_signals(path, edit):
    """Edit signals.npz and record its new SHA-256 in summary.json, as one who edits both
    would: the arrays are then checked on their own (a file whose digest does not match is
    refused before, as another analysis's: tests/cli/test_hostile_batch.py)."""
    from dampfit.result.files import file_digests

    with np.load(path) as data:
        sig = {k: data[k] for k in data.files}
    edit(sig)
    np.savez(path, **sig)
    summary_path = path.parent / "summary.json"
    s = json.loads(summary_path.read_text())
    if isinstance(s.get("files"), dict):
        s["files"].update(file_digests(path.parent, (path.name,)))
        summary_path.write_text(json.dumps(s))


def test_an_older_folder_loads_verifies_and_redraws_what_it_can(folder, tmp_path):
    """signals.npz written before the figure arrays existed: the result loads, its required
    signals read (verify, export), and the figures drawn from the summary and posterior are
    redrawn; the others get one note each, naming why."""
    import shutil

    old = tmp_path / "old"
    shutil.copytree(folder, old)
    _rewrite_signals(old / "signals.npz", lambda s: [s.pop(k) for k in list(s)
                                                     if k not in (*SIGNAL_KEYS, "fs")])
    assert set(load_signals(old)) == {*SIGNAL_KEYS, "fs"}
    loaded = dampfit.load(old)
    without_files = lambda d: {k: v for k, v in d.items() if k != "files"}  # noqa: E731
    assert without_files(loaded.summary()) == without_files(dampfit.load(folder).summary())
    for png in old.glob("*.png"):
        png.unlink()
    done = redraw_missing(old)
    assert sorted(done.drawn) == ["amplitude", "posterior", "trace"]
    assert len(done.notes) == 4
    for name, note in zip(("signal", "spectrum", "fit", "displacement"), done.notes):
        assert note.startswith(f"{name}.png cannot be drawn") and "older dampfit" in note
        assert "\n" not in note
    for name in done.drawn:
        assert (old / f"{name}.png").read_bytes() == (folder / f"{name}.png").read_bytes()
    with pytest.warns(UserWarning, match="signal.png cannot be drawn"):
        loaded.save(tmp_path / "resaved")
    assert {p.stem for p in (tmp_path / "resaved").glob("*.png")} == {"amplitude", "posterior",
                                                                      "trace"}


def test_redraw_missing_of_a_broken_signals_file_notes_and_draws_the_rest(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    (copy / "signals.npz").write_bytes(b"junk")
    for png in copy.glob("*.png"):
        png.unlink()
    done = redraw_missing(copy)
    assert sorted(done.drawn) == ["posterior", "trace"]  # the amplitude figure needs ω_d
    assert len(done.notes) == 5 and all("signals.npz" in n for n in done.notes)


def test_an_edited_summary_draws_what_it_can(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    s = json.loads((copy / "summary.json").read_text())
    s["band"]["low_hz"] = "low"
    s["input"]["axis_direction"] = ["x"]
    s["input"]["path"] = "/tmp/$\\frac{a}{$b.csv"  # never parsed as mathtext
    s["amplitude_curve"]["models"] = "none"
    s["amplitude_curve"]["windows"] = [{"amplitude_m": "big", "zeta": None}, 7]
    s["diagnostics"]["burn_in"] = None
    (copy / "summary.json").write_text(json.dumps(s))
    for png in copy.glob("*.png"):
        png.unlink()
    done = redraw_missing(copy)
    assert sorted(done.drawn) == ["amplitude", "displacement", "fit", "posterior", "signal"]
    assert len(done.notes) == 2
    assert any("spectrum.png cannot be drawn" in n and "band.low_hz" in n for n in done.notes)
    assert any("trace.png cannot be drawn" in n and "diagnostics.burn_in" in n
               for n in done.notes)


# ----------------------------------------------------------------------------- hostile arrays
@pytest.mark.parametrize("edit, match", [
    (lambda s: s.pop("fit_y"), "fit figure arrays are incomplete"),
    (lambda s: s.update(rec_signal_y=np.full_like(s["rec_signal_t"], np.inf)),
     "'rec_signal_y' must be finite"),
    (lambda s: s.update(spectrum_amp=s["spectrum_amp"][:-1]),
     "'spectrum_amp' must be one line as long as 'spectrum_f'"),
    (lambda s: s.update(rec_signal_t=np.arange(10_000.0), rec_signal_y=np.zeros(10_000)),
     "'rec_signal_t' holds 10000 points"),
    (lambda s: s.update(rec_masked_runs=np.zeros((5000, 2))), "'rec_masked_runs' must be at most"),
    (lambda s: s.update(rec_axes_n=s["rec_axes_n"] + 1), "exactly the points 'rec_axes_n'"),
    (lambda s: s.update(rec_axes_n=np.ones(40)), "1 to 16 axes"),
    (lambda s: s.update(disp_envelope=s["disp_envelope"][:5]), "'disp_envelope' has shape"),
    (lambda s: s.update(disp_p=np.array([1.0, 2.0])), "'disp_p' must be one finite number"),
    (lambda s: s.update(fit_t=np.array(["a", "b"])), "'fit_t' holds <U1 values, not numbers"),
    (lambda s: s.update(rec_ylim=np.zeros(3)), "'rec_ylim' must be two"),
])
def test_hostile_figure_arrays_are_one_line(folder, tmp_path, edit, match):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    _rewrite_signals(copy / "signals.npz", edit)
    with pytest.raises(InputError, match=match) as info:
        load_signals(copy)
    assert "\n" not in str(info.value)


def test_unknown_arrays_in_signals_are_not_read(folder, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    _rewrite_signals(copy / "signals.npz", lambda s: s.update(extra=np.array(["text"])))
    assert "extra" not in load_signals(copy)
    with zipfile.ZipFile(copy / "signals.npz") as zf:
        assert "extra.npy" in zf.namelist()


def test_every_figure_group_is_documented_with_its_keys():
    import dampfit.result.signals as doc

    for group, keys in FIGURE_GROUPS.items():
        assert f"``{group}``" in doc.__doc__, group
        for key in keys:
            stem = key.rsplit("_", 1)[0] if key.endswith(("_t", "_y")) else key
            assert f"``{key}``" in doc.__doc__ or f"``{stem}_t``" in doc.__doc__, key
