"""The PNG harness: one Agg draw per figure, written atomically as an RGB PNG.

* :func:`write_png` — draw a figure once at a resolution and write it (atomically) as an
  8-bit RGB PNG with its resolution and matplotlib's software tag;
* :func:`save_png` — the same, then release the figure's axes;
* :func:`drawing` — the settings the figures are drawn in (garbage collector paused, BLAS on
  one thread).

Drawing is the larger part of ``dampfit analyze --report`` after the analysis, so the figures
are drawn cheaply with the same content: fixed layouts (:mod:`dampfit.output.figures.layout`),
tick labels without mathtext, long lines reduced, one Agg draw per figure written without the
alpha channel at zlib level :data:`PNG_COMPRESSION`. ``paper/figure_benchmark.py`` times them.
"""

from __future__ import annotations

import contextlib
import gc
import os
from pathlib import Path
from typing import TYPE_CHECKING

from dampfit.files.atomic import atomic_write

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: zlib level of the PNG files: 1 encodes about twice as fast as Pillow's default 6; without
#: the alpha channel the seven figures are then no larger than matplotlib's RGBA files at 6.
PNG_COMPRESSION = 1

_DRAWING = False  # inside drawing()


@contextlib.contextmanager
def drawing():
    """Settings for drawing figures: Python's cyclic garbage collector paused (the youngest
    generation, what the figures left, is collected at the end) and BLAS held to one thread.

    Drawing allocates about a million short-lived objects in reference cycles (artists,
    transforms, canvases); with the collector on, they trigger full collections that walk the
    whole heap — the analysis, JAX, arviz — about 0.2 s each, for garbage that one
    young-generation pass afterwards frees in a fraction of that. The figures' linear algebra
    is tiny (2 × 2 Cholesky factors, a few small histograms), where waking BLAS threads costs a
    hundred times the work. Nested use changes nothing."""
    from threadpoolctl import threadpool_limits

    global _DRAWING
    if _DRAWING:  # nested: the outer call has set everything
        yield
        return
    pause = gc.isenabled()  # the caller may have switched it off: leave it so
    _DRAWING = True
    if pause:
        gc.disable()
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
    finally:
        _DRAWING = False
        if pause:
            gc.enable()
            gc.collect(0)


def save_png(fig: "Figure", path: str | os.PathLike, dpi: int = 110) -> Path:
    """Write ``fig`` as PNG to ``path`` atomically (:func:`write_png`), then release its axes
    (:func:`release`)."""
    try:
        return write_png(fig, path, dpi)
    finally:
        release(fig)


def release(fig: "Figure") -> None:
    """Detach every axes of ``fig`` (its artists are freed with the axes; cheaper than
    :meth:`~matplotlib.figure.Figure.clear`, which rebuilds every axes it empties)."""
    for ax in list(fig.axes):
        fig.delaxes(ax)


def write_png(fig: "Figure", path: str | os.PathLike, dpi: int = 110) -> Path:
    """Draw ``fig`` once on an Agg canvas at ``dpi`` [pixels per inch] and write it to ``path``
    atomically (:func:`dampfit.files.atomic.atomic_write`) as an 8-bit RGB PNG with its resolution
    and matplotlib's software tag (what ``savefig`` writes, less the alpha channel: every
    figure here is opaque, and the channel costs a quarter more to compress)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin

    old_dpi = fig.dpi
    try:
        fig.set_dpi(dpi)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        size = canvas.get_width_height()
        image = Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        image = image.convert("RGB")
    finally:
        fig.set_dpi(old_dpi)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, "
                              "https://matplotlib.org/")
    return atomic_write(path, lambda tmp: image.save(tmp, format="png", dpi=(dpi, dpi),
                                                     pnginfo=info,
                                                     compress_level=PNG_COMPRESSION),
                        suffix=".png")
