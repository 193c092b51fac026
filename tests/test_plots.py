"""Tests of the figures (:mod:`dampfit.plots`): every PNG is written, valid and not blank.

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

from dampfit import analysis, plots, simulate

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
ALL = {"signal", "spectrum", "fit", "displacement", "posterior", "trace"}


@pytest.fixture(scope="module")
def recording():
    rec, _ = simulate.simulate(simulate.preset("paper", duration=20.0))
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
        assert plots._variables(an) == names
        for name, make in plots.FIGURES.items():
            fig = make(an)
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
    tr, yr = plots._reduce(t, y, 5_000)
    assert tr.size <= 5_002 and np.all(np.diff(tr) > 0)
    assert yr.max() == y.max() and yr.min() == y.min()
    assert plots._reduce(t[:10], y[:10])[0].size == 10


def test_plots_module_imports_matplotlib_lazily():
    tree = ast.parse(Path(plots.__file__).read_text(encoding="utf-8"))
    for node in tree.body:  # module level only; TYPE_CHECKING blocks never run
        if isinstance(node, ast.If):
            continue
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""]
        for n in names:
            assert not n.startswith(("matplotlib", "arviz")), f"plots imports {n} at import time"


def test_numeric_core_does_not_import_matplotlib():
    code = "import dampfit.analysis, sys; print('matplotlib' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "False"
