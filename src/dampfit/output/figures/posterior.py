"""Figures of the posterior: the corner plot and the sampler's traces.

* :func:`posterior_figure` (``posterior.png``) — corner plot of (c, k, u₀), or (ζ, f_n, u₀)
  without a mass;
* :func:`trace_figure` (``trace.png``) — walker traces and marginal densities.

Drawn from the posterior (posterior.nc) and the summary's ``least_squares``, ``mass`` and
``diagnostics`` sections (:class:`~dampfit.output.figures.data.FigureData`). Posterior
densities are evaluated by binning (:func:`contours`, :func:`density`); medians and 90 %
intervals in titles are written by the one interval formatter
(:func:`dampfit.output.text.interval`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from dampfit.output.figures import layout as L
from dampfit.output.figures.data import LABELS, MissingData, as_data, label
from dampfit.output.format import interval

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: Most points drawn in one scatter (random subsample).
MAX_SCATTER_POINTS = 4_000
#: Seed of the scatter's subsample: the same draws give the same figure.
SCATTER_SEED = 0
#: Draws that set the kernel bandwidth of the posterior densities (Scott's rule): emcee draws
#: are autocorrelated, so the effective sample is a few thousand whatever their number.
KDE_DRAWS = 2_000


def variables(post) -> list[str]:
    """The corner variables of the posterior group ``post``: (c, k, u₀) with a mass, else
    (ζ, f_n, u₀), those present; :class:`MissingData` unless each is numbers of shape
    (walker, draw)."""
    names = ["c", "k", "u0"] if ("c" in post and "k" in post) else ["zeta", "f_n", "u0"]
    names = [v for v in names if v in post]
    for v in names:
        x = post[v]
        if x.ndim != 2 or x.size == 0 or x.dtype.kind not in "iuf":
            raise MissingData(f"the posterior's {v} is not a (walker, draw) array of numbers")
    if not names:
        raise MissingData("the posterior holds none of c, k, u0, zeta, f_n")
    return names


def quantiles(x: np.ndarray) -> tuple[float, float, float]:
    """(q05, q50, q95) of the finite values of ``x`` (NaN when none)."""
    x = x[np.isfinite(x)]
    if x.size == 0:
        return (np.nan, np.nan, np.nan)
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return float(q05), float(q50), float(q95)


def _interval_text(q05: float, q50: float, q95: float) -> str:
    """``median  [q05, q95]`` with the digits :func:`dampfit.output.text.interval` gives."""
    m, lo, hi = interval(q50, q05, q95)
    return f"{m}  [{lo}, {hi}]"


def _bins(n: int) -> int:
    """Histogram bins for ``n`` draws (Rice rule, 15–50)."""
    return int(np.clip(2.0 * max(n, 1) ** (1 / 3), 15, 50))


def _subsample(n: int, max_points: int, seed: int = SCATTER_SEED) -> np.ndarray:
    if n <= max_points:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, max_points, replace=False))


def posterior_figure(an: Any) -> "Figure":
    """Corner plot of (c, k, u₀) with a mass, else (ζ, f_n, u₀): pairs and marginals, with
    the least-squares point. ``an``: an analysis or its
    :class:`~dampfit.output.figures.data.FigureData`."""
    d = as_data(an)
    post = d.draws("posterior")
    names = variables(post)
    draws = {v: np.asarray(post[v], float).ravel() for v in names}
    ok = np.all([np.isfinite(draws[v]) for v in names], axis=0)
    draws = {v: x[ok] for v, x in draws.items()}
    n = len(names)
    idx = _subsample(int(ok.sum()), MAX_SCATTER_POINTS)
    ls_vals = d.ls_values()

    fig = L.new_figure(3.0 * n + 1.0, 3.0 * n + 0.6)
    gs = fig.add_gridspec(n, n)
    axes = np.empty((n, n), dtype=object)  # lower triangle only: no hidden axes to build
    for i in range(n):
        for j in range(i + 1):
            axes[i, j] = fig.add_subplot(gs[i, j])
    lims = {}
    for v in names:
        x = draws[v]
        if x.size:
            a, b = np.quantile(x, [0.001, 0.999])
            pad = 0.08 * (b - a) if b > a else 0.5 * abs(a) + 1e-12
            lims[v] = (a - pad, b + pad)
    for i, vy in enumerate(names):
        for j, vx in enumerate(names[:i + 1]):
            ax = axes[i, j]
            if i == j:
                _marginal(ax, draws[vx], lims.get(vx), ls_vals.get(vx),
                          LABELS.get(vx, (vx, ""))[0], legend=i == 0)
            else:
                _pair(ax, draws[vx], draws[vy], idx, lims.get(vx), lims.get(vy),
                      (ls_vals.get(vx), ls_vals.get(vy)))
            ax.set_xlim(lims.get(vx))
            L.compact_ticks(ax, "both" if i != j else "x", 4)
            ax.tick_params(labelsize=8)
            for lab in ax.get_xticklabels():
                lab.set_rotation(30)
                lab.set_ha("right")
            if i == n - 1:  # left-aligned: the tick offset text (×10⁻⁴ + …) sits on the right
                ax.set_xlabel(label(vx), loc="left")
            else:
                ax.tick_params(labelbottom=False)
            if j == 0 and i != j:
                ax.set_ylabel(label(vy))
            elif i != j:
                ax.tick_params(labelleft=False)
            ax.grid(alpha=0.25)
    m, sd = d.number("mass", "value"), d.number("mass", "sd", 0.0)
    mass = f", m = {m:g} ± {sd:g} kg" if np.isfinite(m) else \
        " (no mass: c and k not identifiable)"
    L.suptitle(fig, f"Posterior ({ok.sum()} draws, median and 90 % interval){mass}")
    place_corner(axes)
    return fig


def _marginal(ax, x, lim, ls_value, symbol: str, legend: bool) -> None:
    """A corner plot's marginal: histogram, median, 90 % interval (in the title),
    least-squares value."""
    q05, q50, q95 = quantiles(x)
    ax.hist(x, bins=_bins(x.size), range=lim, histtype="step", color="tab:blue", density=True,
            lw=1.2)
    ax.axvspan(q05, q95, color="tab:orange", alpha=0.15, lw=0, label="90 % interval")
    ax.axvline(q50, color="tab:orange", lw=1.5, label="median")
    for q in (q05, q95):
        ax.axvline(q, color="tab:orange", lw=0.8, ls="--")
    if ls_value is not None:
        ax.axvline(ls_value, color="tab:red", lw=1.0, ls=":", label="least squares")
    ax.set_yticks([])
    L.title(ax, f"{symbol} = {_interval_text(q05, q50, q95)}", size=9)
    if legend:
        ax.legend(loc="upper left", fontsize=7, framealpha=0.8)


def _pair(ax, x, y, idx, xlim, ylim, ls_point) -> None:
    """A corner plot's pair panel: subsampled draws, HDR contours, least-squares point."""
    ax.plot(x[idx], y[idx], ".", ms=1.5, color="tab:blue", alpha=0.35, rasterized=True)
    try:
        contours(ax, x, y, xlim, ylim)
    except (ValueError, np.linalg.LinAlgError):  # degenerate draws: scatter only
        pass
    if None not in ls_point:
        ax.plot(*ls_point, "+", color="tab:red", ms=10, mew=1.5)
    ax.set_ylim(ylim)


def place_corner(axes) -> None:
    """Layout of the corner plot: y tick labels [8 pt] in the first column, x tick labels
    (rotated 30°, right-aligned at their tick) in the last row — a column's gap on its left
    holds its first label where that reaches out of the axes — marginal titles [9 pt] and y
    offset texts between rows."""
    fig = axes[0, 0].figure
    n = axes.shape[0]
    sin, cos = np.sin(np.radians(30.0)), np.cos(np.radians(30.0))
    labels = [L.tick_texts(ax.xaxis)[0] for ax in axes[-1]]
    rotated = max((L.text_width(t, 8) * sin + L.line(8) * cos for row in labels for t in row),
                  default=0.0)
    x_offset = L.line(9) if any(L.offset(ax.xaxis) for ax in axes[-1]) else 0.0
    bottom = L.EDGE + L.TICK + rotated + max(L.LABEL_PAD + L.line(), x_offset)
    left = L.y_room(axes[1:, 0], 8) if n > 1 else L.EDGE + L.TICK
    right = 0.15
    gap = max([L.above(axes[i, i], 9) for i in range(n)]
              + [L.above(axes[i, 0], None, offset_size=9) for i in range(1, n)])
    width = (fig.get_figwidth() - left - right - 0.12 * (n - 1)) / n  # [in], about
    wgaps = []
    for j in range(1, n):
        ax = axes[-1, j]
        a, b = ax.get_xlim()
        first = min((v for v in ax.xaxis.get_major_locator().tick_values(a, b)
                     if min(a, b) <= v <= max(a, b)), default=None, key=lambda v: abs(v - a))
        reach = (L.text_width(labels[j][0], 8) * cos + L.line(8) * sin) if labels[j] else 0.0
        room = abs(first - a) / abs(b - a) * width if first is not None and b != a else 0.0
        wgaps.append(max(0.12, reach - room + 0.05))
    cols = L.spans(fig.get_figwidth(), left, right, [1.0] * n, wgaps)
    rows = L.spans(fig.get_figheight(), L.top(L.above(axes[0, 0], 9)), bottom, [1.0] * n,
                   [gap + 3 * L.PT] * (n - 1))
    W, H = fig.get_size_inches()
    for i, (t, bot) in enumerate(rows):
        for j, (lft, r) in enumerate(cols[:i + 1]):
            axes[i, j].set_position([lft / W, bot / H, (W - lft - r) / W, (H - t - bot) / H])


def contours(ax, x, y, xlim, ylim, n_grid: int = 64) -> None:
    """Highest-density-region (HDR) contours holding ≈ 50 % and 90 % of the draws.

    The density is a Gaussian kernel density estimate whose kernel has the draws' own
    covariance (as :class:`scipy.stats.gaussian_kde`; Scott's factor n^(−1/6) with
    n = min(draws, :data:`KDE_DRAWS`)), evaluated by binning: the draws are whitened,
    w = L⁻¹·(p − mean) with L the Cholesky factor of their covariance (so a strongly
    correlated pair such as c–k becomes round and keeps its narrow ridge; standardised first,
    so L is that of the correlation matrix whatever the parameters' scales), counted on an
    ``n_grid`` × ``n_grid`` histogram and smoothed with an isotropic Gaussian filter of that
    bandwidth (:func:`scipy.ndimage.gaussian_filter`). The level of the q-HDR contour is the
    density that a fraction q of the draws exceed (the density at each draw read off the grid),
    so the contour encloses ≈ q of the draws (q = 50 %, 90 %). The grid is mapped back to the
    parameters' units for drawing. ``xlim``/``ylim`` None (no draws) or fewer than 10 draws:
    nothing is drawn; degenerate draws raise :class:`numpy.linalg.LinAlgError`.
    """
    from scipy import ndimage

    if xlim is None or ylim is None or x.size < 10:
        return
    if np.ptp(x) <= 0 or np.ptp(y) <= 0:
        return
    mean, sd = np.array([x.mean(), y.mean()]), np.array([x.std(), y.std()])
    z = (np.vstack([x, y]) - mean[:, None]) / sd[:, None]  # standardised draws (2, n)
    chol = np.linalg.cholesky(np.corrcoef(z))
    w = np.linalg.solve(chol, z)  # whitened draws
    bw = min(x.size, KDE_DRAWS) ** (-1.0 / 6.0)  # kernel sd in whitened units
    lo = np.quantile(w, 0.0005, axis=1) - 3 * bw
    hi = np.quantile(w, 0.9995, axis=1) + 3 * bw
    counts, eu, ev = np.histogram2d(w[0], w[1], bins=n_grid, range=[(lo[0], hi[0]),
                                                                    (lo[1], hi[1])])
    du, dv = eu[1] - eu[0], ev[1] - ev[0]
    dens = ndimage.gaussian_filter(counts, (bw / du, bw / dv), mode="constant")
    # density at each draw (bilinear between bin centres); the HDR levels are its quantiles
    at = ndimage.map_coordinates(dens, [(w[0] - lo[0]) / du - 0.5, (w[1] - lo[1]) / dv - 0.5],
                                 order=1, mode="constant", cval=0.0)
    levels = sorted({float(np.quantile(at, 1.0 - q)) for q in (0.9, 0.5)})
    if dens.max() <= levels[0] or levels[0] <= 0:
        return
    cu, cv = np.meshgrid(0.5 * (eu[1:] + eu[:-1]), 0.5 * (ev[1:] + ev[:-1]), indexing="ij")
    gx = mean[0] + sd[0] * (chol[0, 0] * cu)
    gy = mean[1] + sd[1] * (chol[1, 0] * cu + chol[1, 1] * cv)
    ax.contour(gx, gy, dens, levels=levels, colors="navy", linewidths=0.9)


def trace_figure(an: Any) -> "Figure":
    """Per-walker traces (thinned, after burn-in) and marginal densities of the corner
    variables, with the sampler's state (summary ``diagnostics``) in the title."""
    d = as_data(an)
    post = d.draws("trace")
    names = variables(post)
    burn_in, thin, n_steps = (int(v) for v in d.require(
        "trace", ("diagnostics", "burn_in"), ("diagnostics", "thin"), ("diagnostics", "n_steps")))
    n = len(names)
    fig = L.new_figure(11.0, 2.3 * n + 0.8)
    axes = fig.subplots(n, 2, squeeze=False, width_ratios=[2.6, 1.0])
    for i, v in enumerate(names):
        _trace_row(axes[i], np.asarray(post[v], float), burn_in, thin, v, legend=i == 0)
        if i < n - 1:
            axes[i, 0].tick_params(labelbottom=False)
    axes[-1, 0].set_xlabel(f"emcee step [1] (after burn-in {burn_in}, thinned by {thin}; "
                           f"{post.sizes.get('chain', 0)} walkers)")
    conv = {True: "converged", False: "NOT converged"}.get(
        d.flag("diagnostics", "posterior_converged"), "convergence unknown")
    r_hat = d.number("diagnostics", "max_r_hat")
    ess = d.number("diagnostics", "min_ess_bulk")
    acc = d.number("diagnostics", "acceptance_fraction")
    L.suptitle(fig, f"Posterior traces — {conv}: max R-hat {r_hat:.3f}, "
                    f"min bulk ESS {ess:.0f}, acceptance {acc:.2f}, {n_steps} steps")
    # between rows: the density's x tick labels [8 pt] and offset text, then the next row's
    # density title [9 pt] or trace offset text
    below_d = L.TICK + L.line(8) + max((L.line(8) + 3 * L.PT for ax in axes[:, 1]
                                        if L.offset(ax.xaxis)), default=0.0)
    above = [max(L.above(ax_d, 9), L.above(ax_t, None)) for ax_t, ax_d in axes]
    L.place(L.gridspec(axes[0, 0]), left=L.y_room(axes[:, 0]), right=0.2,
            bottom=max(L.x_room(), L.EDGE + below_d), top=L.top(above[0]),
            hgap=below_d + max(above[1:], default=0.0) + 3 * L.PT, wgap=0.2)
    return fig


def _trace_row(row, x: np.ndarray, burn_in: int, thin: int, v: str, legend: bool) -> None:
    """One variable's trace (``x`` (walker, draw), thinned steps after burn-in) and density."""
    from matplotlib.collections import LineCollection

    ax_t, ax_d = row
    n_walk, n_draw = x.shape
    step = burn_in + thin * np.arange(n_draw)
    stride = max(1, int(np.ceil(n_draw * n_walk / 40_000)))
    # one LineCollection per panel instead of one Line2D per walker (64 artists)
    segs = np.stack(np.broadcast_arrays(step[::stride][None, :], x[:, ::stride]), axis=-1)
    ax_t.add_collection(LineCollection(segs, linewidths=0.4, alpha=0.5, rasterized=True,
                                       colors=[f"C{w % 10}" for w in range(n_walk)]))
    ax_t.autoscale_view()
    q05, q50, q95 = quantiles(x.ravel())
    ax_t.axhline(q50, color="black", lw=0.9)
    ax_t.set_ylabel(label(v))
    ax_t.set_xlim(step[0], step[-1] if n_draw > 1 else step[0] + 1)
    ax_t.grid(alpha=0.3)
    L.compact_ticks(ax_t, "y", 4)

    flat = x.ravel()
    flat = flat[np.isfinite(flat)]
    lo, hi = np.quantile(flat, [0.001, 0.999]) if flat.size else (0.0, 1.0)
    pad = 0.1 * (hi - lo) if hi > lo else 1e-12 + 0.1 * abs(lo)
    grid = np.linspace(lo - pad, hi + pad, 300)
    ax_d.hist(flat, bins=_bins(flat.size), range=(grid[0], grid[-1]), density=True,
              color="0.85", histtype="stepfilled")  # one polygon, not one bar per bin
    dens = density(flat, grid)
    if dens is not None:
        ax_d.plot(grid, dens, color="tab:blue", lw=1.2, label="density (KDE)")
        inside = (grid >= q05) & (grid <= q95)
        ax_d.fill_between(grid[inside], dens[inside], color="tab:orange", alpha=0.3, lw=0,
                          label="90 % interval")
    ax_d.axvline(q50, color="tab:orange", lw=1.5, label="median")
    ax_d.set_ylim(bottom=0)
    if legend:
        ax_d.legend(loc="upper right", fontsize=7, framealpha=0.8)
    ax_d.set_xlim(grid[0], grid[-1])
    ax_d.set_yticks([])  # no x label: the trace's y label names it, and the tick
    L.title(ax_d, _interval_text(q05, q50, q95), size=9)  # offset text needs the room
    L.compact_ticks(ax_d, "x", 3)
    ax_d.tick_params(labelsize=8)


def density(x: np.ndarray, grid: np.ndarray) -> np.ndarray | None:
    """Gaussian kernel density [1/unit of x] of the draws ``x`` on the evenly spaced ``grid``.

    Scott's bandwidth h = sd · n^(−1/5), n = min(draws, :data:`MAX_SCATTER_POINTS`) (as
    :class:`scipy.stats.gaussian_kde`), evaluated by binning: the draws are counted in bins
    centred on the grid points and the counts smoothed with a Gaussian of sd h
    (:func:`scipy.ndimage.gaussian_filter1d`), normalised by all draws. None for fewer than
    3 draws or no spread.
    """
    from scipy import ndimage

    if x.size < 3 or np.ptp(x) <= 0 or grid.size < 2:
        return None
    dx = float(grid[1] - grid[0])
    counts, _ = np.histogram(x, bins=grid.size, range=(grid[0] - dx / 2, grid[-1] + dx / 2))
    h = float(np.std(x, ddof=1)) * min(x.size, MAX_SCATTER_POINTS) ** (-0.2)
    return ndimage.gaussian_filter1d(counts.astype(float), h / dx, mode="constant") / (x.size * dx)
