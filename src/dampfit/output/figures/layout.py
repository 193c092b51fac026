"""The layout engine of every dampfit figure: fixed layouts computed from what fills the margins.

Every figure has a fixed layout: the margins and gaps [in] are computed from what occupies
them (the suptitle, axes titles, legends drawn above an axes, tick labels, axis labels; tick
labels measured from the formatted strings) and set as gridspec parameters before drawing.
matplotlib's constrained layout would find them by measuring every artist of every axes in
two extra passes per savefig, about half of the figure stage's time. Titles sit at a fixed
height (``y=1``: matplotlib's automatic title placement measures the y axis once more per
titled axes and draw) and are lifted where a y-axis offset text (×10ⁿ) takes their place.

A figure is built in three steps: :func:`new_figure`; axes drawn with :func:`title`,
:func:`legend_above`, :func:`compact_ticks`, :func:`log_ticks`; then :func:`place` of each
gridspec with margins from :func:`y_room`, :func:`x_room`, :func:`top` and :func:`above`
(or :func:`spans` for cells of different sizes). Sizes are in inches [in] unless in points
[pt] (:data:`PT` inches each).

Tick labels are written without mathtext (:func:`unicode_formatter`): the same text, but no
mathtext parse per label. matplotlib is imported inside the functions only.
"""

from __future__ import annotations

import functools
import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

PT = 1.0 / 72.0  #: [in] per typographic point
EDGE = 5 * PT  #: free border of the figure [in]
TICK = 7 * PT  #: tick length + tick-label pad [in] (matplotlib's 3.5 + 3.5 pt)
LABEL_PAD = 4 * PT  #: axis label pad [in] (rcParams["axes.labelpad"])
TITLE_PAD = 6.0  #: title above the axes [pt] (rcParams["axes.titlepad"])
SIZE = 10.0  #: tick labels, axis labels and titles [pt] unless set
SUPTITLE = 12.0  #: suptitle [pt] ("large")


def new_figure(width: float, height: float) -> "Figure":
    """An empty ``width`` × ``height`` [in] figure without a layout engine (see above)."""
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def line(size: float = SIZE) -> float:
    """Height [in] of one line of text of ``size`` [pt]."""
    return 1.25 * size * PT


def text_width(s: str, size: float = SIZE) -> float:
    """Width [in] of ``s`` at ``size`` [pt] in the default font; mathtext is measured as its
    characters at full size (an upper bound: superscripts are smaller)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import text_to_path

    if "$" in s:
        for a, b in (("\\mathdefault", ""), ("\\times", "×"), ("\\cdot", "·"), ("$", ""),
                     ("{", ""), ("}", ""), ("^", ""), ("\\", "")):
            s = s.replace(a, b)
    if not s:
        return 0.0
    w, _, _ = text_to_path.get_text_width_height_descent(s, FontProperties(size=size), False)
    return w * PT


def tick_texts(axis, minor: bool = False, interval=None) -> tuple[list[str], str]:
    """The tick labels ``axis`` will draw in its current view (or ``interval``), and its offset
    text (×10ⁿ)."""
    lo, hi = sorted(axis.get_view_interval() if interval is None else interval)
    loc = axis.get_minor_locator() if minor else axis.get_major_locator()
    fmt = axis.get_minor_formatter() if minor else axis.get_major_formatter()
    tol = 1e-9 * (hi - lo) if hi > lo else 0.0
    locs = [v for v in loc.tick_values(lo, hi) if lo - tol <= v <= hi + tol]
    labels = fmt.format_ticks(locs) if locs else []
    off = fmt.get_offset() if hasattr(fmt, "get_offset") and locs else ""
    return [t for t in labels if t], off


def ticks_width(axis, size: float = SIZE) -> float:
    """Width [in] of the widest tick label of ``axis`` (major and, on a log axis, minor)."""
    texts = tick_texts(axis)[0]
    if axis.get_scale() == "log":
        texts += tick_texts(axis, minor=True)[0]
    return max((text_width(t, size) for t in texts), default=0.0)


def y_room(axes, size: float = SIZE, label: bool = True, labels=()) -> float:
    """Room [in] beside the y axes ``axes`` for their tick labels (and ``labels``; ``size``
    [pt]) and an axis label."""
    width = max([ticks_width(ax.yaxis, size) for ax in axes]
                + [text_width(t, size) for t in labels] + [0.0])
    return EDGE + TICK + width + (LABEL_PAD + line() if label else 0.0)


def x_room(size: float = SIZE, label: bool = True) -> float:
    """Room [in] below an x axis for one line of tick labels (``size`` [pt]) and a label."""
    return EDGE + TICK + line(size) + (LABEL_PAD + line() if label else 0.0)


def offset(axis) -> str:
    """The offset text (×10ⁿ, +c) ``axis`` will draw, or ``""``."""
    return tick_texts(axis)[1]


def above(ax, title_size: float | None = SIZE, legend_rows: int = 0, legend_size=8.0,
          offset_size: float = SIZE) -> float:
    """Height [in] of the strip above ``ax``: its title (``title_size`` [pt], None: none), a
    legend of ``legend_rows`` rows placed above it (:func:`legend_above`) and the y-axis offset
    text; a title is lifted over an offset text (:func:`lift_titles`)."""
    head = TITLE_PAD * PT + line(title_size) if title_size else 0.0
    off = line(offset_size) + 3 * PT if offset(ax.yaxis) else 0.0
    if off and head:
        lift_titles(ax, off, title_size)
    legend = (legend_rows * line(legend_size) + (legend_rows - 1) * 0.5 * legend_size * PT
              + 1.0 * legend_size * PT) if legend_rows else 0.0
    return max(head + off, legend, off)


def title(ax, text: str, loc: str = "center", size: float = SIZE):
    """Axes title at a fixed height (no automatic placement; see the module)."""
    return ax.set_title(text, loc=loc, fontsize=size, y=1.0, pad=TITLE_PAD)


def lift_titles(ax, lift: float, size: float = SIZE) -> None:
    """Raise the titles of ``ax`` (set by :func:`title` at ``size`` [pt]) by ``lift`` [in],
    over the y-axis offset text."""
    for loc in ("left", "center", "right"):
        text = ax.get_title(loc)
        if text:
            ax.set_title(text, loc=loc, fontsize=size, y=1.0, pad=TITLE_PAD + lift / PT)


def suptitle(fig, text: str) -> None:
    """Figure title at the top edge (:data:`EDGE`)."""
    fig.suptitle(text, y=1.0 - EDGE / fig.get_figheight(), va="top", fontsize=SUPTITLE)


def top(extra: float = 0.0) -> float:
    """Top margin [in]: the suptitle and a strip of ``extra`` [in] above the first axes."""
    return EDGE + line(SUPTITLE) + 3 * PT + extra


def place(gs, *, left: float, right: float, top: float, bottom: float, hgap: float = 0.0,
          wgap: float = 0.0) -> None:
    """Put gridspec ``gs`` at ``left``, ``right``, ``top``, ``bottom`` [in] from the figure's
    edges, with ``hgap`` [in] between rows and ``wgap`` [in] between columns."""
    width, height = gs.figure.get_size_inches()
    nrows, ncols = gs.get_geometry()
    w, h = width - left - right, height - top - bottom
    gs.update(left=left / width, right=1.0 - right / width, bottom=bottom / height,
              top=1.0 - top / height,
              hspace=hgap * nrows / max(h - hgap * (nrows - 1), 1e-6) if nrows > 1 else 0.0,
              wspace=wgap * ncols / max(w - wgap * (ncols - 1), 1e-6) if ncols > 1 else 0.0)
    fig = gs.figure  # GridSpec.update moves the axes of pyplot's figures only
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        if spec is not None and spec.get_topmost_subplotspec().get_gridspec() is gs:
            ax.set_position(spec.get_position(fig))


def gridspec(ax):
    """The gridspec ``ax`` was made in (for :func:`place`)."""
    return ax.get_subplotspec().get_gridspec()


def spans(size: float, start: float, end: float, ratios, gaps) -> list[tuple[float, float]]:
    """Margins (from the start, from the end) [in] of cells laid out along a figure side of
    ``size`` [in] inside margins ``start`` and ``end`` [in], with sizes in ``ratios`` and
    ``gaps`` [in] between consecutive cells (rows from the top, columns from the left)."""
    unit = (size - start - end - sum(gaps)) / sum(ratios)
    out, y = [], start
    for i, r in enumerate(ratios):
        out.append((y, size - y - r * unit))
        y += r * unit + (gaps[i] if i < len(gaps) else 0.0)
    return out


def legend_above(ax, ncols: int, *args, **kw) -> int:
    """Legend in the strip above the axes (right-aligned), so it never hides data; returns its
    number of rows (for :func:`above`)."""
    leg = ax.legend(*args, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=ncols,
                    fontsize=8, frameon=False, borderaxespad=0.2, **kw)
    return -(-len(leg.texts) // max(ncols, 1))


# ----------------------------------------------------------------------------- ticks
def compact_ticks(ax, which: str = "both", n: int = 4) -> None:
    """At most ``n`` ticks; scientific notation with an offset (×10ⁿ + c) beyond 10⁻³–10⁴."""
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    axes = {"x": [ax.xaxis], "y": [ax.yaxis], "both": [ax.xaxis, ax.yaxis]}[which]
    for axis in axes:
        axis.set_major_locator(MaxNLocator(n))
        fmt = unicode_formatter(ScalarFormatter)(useOffset=True, useMathText=True)
        fmt.set_powerlimits((-3, 4))
        axis.set_major_formatter(fmt)


def log_ticks(axis) -> None:
    """Decade labels of a log ``axis`` (10⁻², 6×10⁻²) without mathtext
    (:func:`unicode_formatter`)."""
    from matplotlib.ticker import LogFormatterSciNotation

    cls = unicode_formatter(LogFormatterSciNotation)
    axis.set_major_formatter(cls(10.0))
    axis.set_minor_formatter(cls(10.0, labelOnlyBase=False))  # as matplotlib's log scale


_SUPERSCRIPT = str.maketrans("0123456789-−+", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁻⁺")


def unmath(s: str) -> str:
    """Tick-label mathtext (``$\\mathdefault{6\\times10^{-2}}$``) as plain text with Unicode
    superscripts (``6×10⁻²``); anything else unchanged."""
    if "$" not in s:
        return s
    body = s.strip()
    if body.count("$") != 2 or body[0] != "$" or body[-1] != "$":
        return s
    body = body[1:-1].replace("\\mathdefault", "").replace("\\times", "×")
    body = re.sub(r"\^\{([0-9−+-]*)\}", lambda m: m.group(1).translate(_SUPERSCRIPT), body)
    body = body.replace("{", "").replace("}", "").replace(" × ", "×")
    return s if any(c in body for c in "\\^_$") else body


@functools.lru_cache(maxsize=None)
def unicode_formatter(cls):
    """The matplotlib formatter class ``cls`` with its tick labels and offset text written
    without mathtext (:func:`unmath`): the same text, but no mathtext parse per label (about
    10 ms each, and the parser's construction on first use)."""

    class Unicode(cls):
        def __call__(self, x, pos=None):
            return unmath(super().__call__(x, pos))

        def get_offset(self):
            return unmath(super().get_offset())

    Unicode.__name__ = Unicode.__qualname__ = f"Unicode{cls.__name__}"
    return Unicode
