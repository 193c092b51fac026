"""Tests of the figures (:mod:`dampfit.output.figures`): every PNG is written, valid and not blank.

One short simulated recording of the seed paper's spring (20 s, 500 Hz) is analysed once
with a mass and once without; the figures of both are written to a temporary directory.
"""

from __future__ import annotations

import ast
import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dampfit import simulate
from dampfit import pipeline as analysis
from dampfit.output import figures as plots
from dampfit.output.figures.data import FigureData
from dampfit.output.figures.posterior import variables
from dampfit.signal.display import keep_extremes

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
ALL = {"signal", "spectrum", "fit", "displacement", "posterior", "trace", "amplitude"}


@pytest.fixture(scope="module")
def recording():
    rec, _ = simulate.recording(simulate.preset("paper", duration=20.0))
    return rec


# a short chain is enough for figures (and keeps the file fast); it need not converge
FAST = dict(seed=1, max_steps=500, min_ess=100)


@pytest.fixture(scope="module")
def with_mass(recording):
    return analysis.analyze(recording, mass=5.3, mass_sd=0.05, **FAST)


@pytest.fixture(scope="module")
def without_mass(recording):
    return analysis.analyze(recording, **FAST)


def _check_png(path: Path) -> None:
    import matplotlib.image as mpimg

    assert path.is_file(), path
    data = path.read_bytes()
    assert len(data) > 5_000, f"{path.name} is suspiciously small ({len(data)} bytes)"
    assert data[:8] == PNG_MAGIC, f"{path.name} is not a PNG"
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 300 and img.shape[1] > 300
    assert float(np.std(img[..., :3])) > 0.02, f"{path.name} looks blank"


@pytest.mark.heavy
@pytest.mark.parametrize("case", ["with_mass", "without_mass"])
def test_save_figures_writes_every_png(case, request, tmp_path):
    an = request.getfixturevalue(case)
    out = plots.save_figures(an, tmp_path / "figs", dpi=80)
    assert set(out) == ALL
    for name, path in out.items():
        assert path == tmp_path / "figs" / f"{name}.png"
        _check_png(path)
    # nothing else (no leftover temporary files)
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == sorted(f"{n}.png" for n in ALL)


def test_figure_functions_return_figures(with_mass, without_mass):
    from matplotlib.figure import Figure

    for an, names in ((with_mass, ["c", "k", "u0"]), (without_mass, ["zeta", "f_n", "u0"])):
        assert variables(an.posterior.posterior) == names
        for name, make in plots.FIGURES.items():
            fig = make(an)
            if name == "modes":  # one mode: not drawn (tests/cli/test_report_modes.py)
                assert fig is None
                continue
            assert isinstance(fig, Figure), name
            assert fig.get_suptitle(), f"{name} has no title"
            for ax in fig.axes:
                if ax.get_visible() and ax.has_data() and ax.get_xlabel():
                    assert "[" in ax.get_xlabel(), f"{name}: x label without unit"
    # corner plot: marginals carry the 90 % interval in their titles
    fig = plots.posterior_figure(with_mass)
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible() and ax.get_title()]
    assert any(t.startswith("c = ") for t in titles) and any(t.startswith("k = ") for t in titles)


def test_displacement_skipped_without_baseline(with_mass, tmp_path):
    an = dataclasses.replace(with_mass, baselines={**with_mass.baselines, "envelope_pipeline": None})
    assert plots.displacement_figure(an) is None
    (tmp_path / "displacement.png").write_bytes(PNG_MAGIC)  # stale file of an earlier run
    out = plots.save_figures(an, tmp_path)
    assert "displacement" not in out and not (tmp_path / "displacement.png").exists()
    assert set(out) == ALL - {"displacement"}


def test_reduce_keeps_extremes():
    t = np.linspace(0, 100, 200_001)
    y = np.sin(2 * np.pi * 1.7 * t) * np.exp(-0.01 * t)
    tr, yr = keep_extremes(t, y, 5_000)
    assert tr.size <= 5_002 and np.all(np.diff(tr) > 0)
    assert yr.max() == y.max() and yr.min() == y.min()
    assert keep_extremes(t[:10], y[:10])[0].size == 10


@pytest.mark.parametrize("module", sorted(p.name for p in Path(plots.__file__).parent.glob("*.py")))
def test_plots_module_imports_matplotlib_lazily(module):
    tree = ast.parse((Path(plots.__file__).parent / module).read_text(encoding="utf-8"))
    for node in tree.body:  # module level only; TYPE_CHECKING blocks never run
        if isinstance(node, ast.If):
            continue
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        for n in names:
            assert not n.startswith(("matplotlib", "arviz")), f"{module} imports {n} at import time"


def test_numeric_core_does_not_import_matplotlib():
    code = "import dampfit.pipeline, sys; print('matplotlib' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "False"


def _line(ax, label_start: str):
    lines = [ln for ln in ax.get_lines() if ln.get_label().startswith(label_start)]
    assert len(lines) == 1, (label_start, [ln.get_label() for ln in ax.get_lines()])
    return np.asarray(lines[0].get_xdata(), float), np.asarray(lines[0].get_ydata(), float)


def test_spectrum_figure_linear_db_band_and_filter_response(with_mass):
    """The paper's Figs 15–17 and 19: linear and dB spectra, pass band, |H|², filtered spectrum."""
    prep = with_mass.prepared
    lo, hi = prep.band
    fig = plots.spectrum_figure(with_mass)
    by_ylabel = {ax.get_ylabel(): ax for ax in fig.axes}
    ax_lin = by_ylabel["amplitude [m/s²]"]
    ax_h = by_ylabel["filter gain |H|² [1]"]
    ax_db = by_ylabel["level re peak [dB]"]
    assert ax_db.get_xlabel() == "frequency [Hz]"

    # pass band shaded and f0 marked in both panels
    for ax in (ax_lin, ax_db):
        spans = [(p.get_x(), p.get_x() + p.get_width()) for p in ax.patches]
        assert any(np.allclose(s, (lo, hi)) for s in spans), spans
        assert any(len(ln.get_xdata()) == 2 and np.allclose(ln.get_xdata(), prep.f0)
                   for ln in ax.get_lines())

    # zero-phase Butterworth: |H|² = 1/2 at the band edges (−3 dB of |H|), ≈ 1 inside, ≈ 0 far out
    fh, gain = _line(ax_h, "band-pass |H|²")
    assert abs(np.interp(lo, fh, gain) - 0.5) < 0.02 and abs(np.interp(hi, fh, gain) - 0.5) < 0.02
    assert abs(gain.max() - 1.0) < 1e-3 and np.all(gain[fh < 0.5 * lo] < 0.01)
    fh_db, gdb = _line(ax_db, "band-pass |H|² [dB]")
    assert np.allclose(gdb, 20 * np.log10(np.maximum(gain, 1e-12)))

    # dB spectrum: 0 dB at the peak, which is at f0; the filtered spectrum is that times |H|²
    f, db = _line(ax_db, "amplitude re peak")
    f_lin, amp = _line(ax_lin, "amplitude spectrum")
    assert np.allclose(f, f_lin)
    assert abs(db.max()) < 1e-9 and abs(f[np.argmax(db)] - prep.f0) < 0.05 * prep.f0
    assert np.allclose(db, 20 * np.log10(np.maximum(amp, 1e-12 * amp.max()) / amp.max()))
    ff, db_filt = _line(ax_db, "after band-pass")
    assert np.allclose(ff, f) and np.all(db_filt <= db + 1e-9)
    ok = (db_filt > -200) & (f > fh[0]) & (f < fh[-1])
    assert np.allclose(db_filt[ok] - db[ok], np.interp(f[ok], fh, 20 * np.log10(gain)), atol=0.5)
    far = f > 2.0 * hi
    if far.any():
        assert np.all(db_filt[far] < db[far] - 20)


def _errorbar(ax, label_start: str):
    """(x, y, half-length of each error bar or None) of the errorbar labelled ``label_start``."""
    cont = [c for c in ax.containers if c.get_label().startswith(label_start)]
    assert len(cont) == 1, [c.get_label() for c in ax.containers]
    line, _, bars = cont[0].lines
    x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
    if not cont[0].has_yerr:
        return x, y, None
    segs = bars[0].get_segments()
    return x, y, np.array([0.5 * (sg[1][1] - sg[0][1]) for sg in segs])


def test_amplitude_figure_draws_zeta_and_backbone(with_mass):
    """ζ(A) on top (windows with their 90 % band, each law's ζ_eq) and the f(A) backbone below."""
    curve = with_mass.summary()["amplitude_curve"]
    wins = curve["windows"]
    f_ls = FigureData.of(with_mass).ls_values()["f_d"]
    fig = plots.amplitude_figure(curve, f_d_hz=f_ls)
    ax_z = fig.axes[0]
    ax_f = next(ax for ax in fig.axes if ax.get_ylabel() == "damped frequency f_d [Hz]")
    assert ax_z.get_xscale() == "log" and ax_z.get_ylabel() == "damping ratio ζ [1]"
    assert ax_f.get_xlabel() == "displacement amplitude a [m]" and ax_f.get_xscale() == "log"
    assert ax_z.get_title(loc="left").startswith("ζ(A)")
    assert ax_f.get_title(loc="left").startswith("f(A)")
    a = [w["amplitude_m"] for w in wins]
    x, y, half = _errorbar(ax_z, "windowed viscous fits")
    assert np.allclose(x, a) and np.allclose(y, [w["zeta"] for w in wins])
    assert np.allclose(half, [1.645 * w["zeta_sd"] for w in wins])
    x, y, half = _errorbar(ax_f, "windowed damped frequency (90 %)")
    assert np.allclose(x, a) and np.allclose(y, [w["f_d_hz"] for w in wins])
    assert np.all(np.isfinite(half)) and np.allclose(half, [1.645 * w["f_d_sd_hz"] for w in wins])
    const = [ln for ln in ax_f.get_lines() if ln.get_label().startswith("constant f_d")]
    assert len(const) == 1 and np.allclose(const[0].get_ydata(), f_ls)
    laws = {ln.get_label().split(":")[0].replace(" (chosen)", "") for ln in ax_z.get_lines()
            if "ζ_eq(a)" in ln.get_label()}
    assert laws == set(curve["models"])
    # a summary without the frequency sd: points without bars, and the legend says so
    bare = {**curve, "windows": [{k: v for k, v in w.items() if k != "f_d_sd_hz"} for w in wins]}
    fig = plots.amplitude_figure(bare)
    ax_f = next(ax for ax in fig.axes if ax.get_ylabel() == "damped frequency f_d [Hz]")
    assert _errorbar(ax_f, "windowed damped frequency (sd not in the summary)")[2] is None
    # no windows at all (a very short recording) still gives a figure, saying why it is empty
    fig = plots.amplitude_figure({"windows": [], "models": {}})
    assert any("no amplitude windows" in t.get_text() for t in fig.axes[0].texts)


def _short_span_curve(span: float = 5.0) -> dict:
    """An amplitude curve over ``span``× in amplitude: windows, a viscous and a Coulomb law
    (ζ_eq = ζ_v + ζ_c·a_ref/a, falling with amplitude) and a Coulomb fit left flat."""
    a = np.geomspace(1e-4, span * 1e-4, 8)
    grid = np.geomspace(a[0], a[-1], 40)
    wins = [{"amplitude_m": float(x), "zeta": 0.01, "zeta_sd": 0.0005, "f_d_hz": 5.0,
             "f_d_sd_hz": 0.01} for x in a]
    return {"windows": wins, "amplitude_grid_m": grid.tolist(), "chosen_model": "coulomb",
            "models": {"viscous": {"zeta_eq": np.full(grid.size, 0.01).tolist()},
                       "coulomb": {"zeta_eq": (0.006 + 0.004 * a[0] / grid).tolist()},
                       "quadratic": {"zeta_eq": np.full(grid.size, 0.01).tolist()}}}


@pytest.mark.parametrize("span", [1.5, 4.0, 9.0])
def test_amplitude_tick_labels_do_not_overlap(span):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plots.amplitude_figure(_short_span_curve(span))
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    ax_f = next(ax for ax in fig.axes if ax.get_ylabel() == "damped frequency f_d [Hz]")
    renderer = canvas.get_renderer()
    lo, hi = ax_f.get_xlim()
    boxes = sorted((t.get_window_extent(renderer) for t in
                    ax_f.xaxis.get_majorticklabels() + ax_f.xaxis.get_minorticklabels()
                    if t.get_text() and t.get_visible() and lo <= t.get_position()[0] <= hi),
                   key=lambda b: b.x0)
    assert len(boxes) >= (2 if span > 2 else 1)
    assert all(b.x1 < c.x0 for b, c in zip(boxes, boxes[1:])), [(b.x0, b.x1) for b in boxes]


def test_every_law_is_drawn_as_it_says():
    """The Coulomb ζ_eq(a) falls with amplitude as drawn; a law whose fit found no extra
    term says so beside its flat line."""
    curve = _short_span_curve()
    fig = plots.amplitude_figure(curve)
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines() if "ζ_eq(a)" in ln.get_label()}
    coulomb = lines["coulomb (chosen): ζ_eq(a)"]
    x, y = np.asarray(coulomb.get_xdata(), float), np.asarray(coulomb.get_ydata(), float)
    assert np.all(np.diff(y) < 0) and np.all(np.diff(x) > 0)
    assert "quadratic: ζ_eq(a) (no drag at its fit: flat)" in lines
    assert "viscous: ζ_eq(a)" in lines  # viscous is flat by law: no note


def test_last_cycles_panel_comments_a_model_out_of_phase():
    import matplotlib.pyplot as plt

    from dampfit.output.figures.fit import PHASE_COMMENT_DEG, _phase_comment, phase_offset

    f0 = 5.0
    t = np.arange(0, 1, 0.002)
    model = np.cos(2 * np.pi * f0 * t)
    assert abs(phase_offset(t, np.cos(2 * np.pi * f0 * t + 0.9), t, model, f0)
               - np.degrees(0.9)) < 0.5
    assert abs(phase_offset(t, 2 * model, t, model, f0)) < 0.1
    fig, (ok, bad) = plt.subplots(1, 2)
    _phase_comment(ok, t, np.cos(2 * np.pi * f0 * t + np.radians(PHASE_COMMENT_DEG / 2)),
                   t, model, f0)
    _phase_comment(bad, t, np.cos(2 * np.pi * f0 * t + 1.2), t, model, f0)
    assert not ok.texts
    assert "model 69° behind the data here" in bad.texts[0].get_text()
    plt.close(fig)
