"""The amplitude figure (``amplitude.png``): ζ(A) and the f(A) backbone of the damping laws.

Drawn from the summary's ``amplitude_curve`` (:func:`dampfit.damping.assess`; written when the
analysis assessed the damping laws, always with :func:`dampfit.analyze`) and the damped
frequency of the least-squares fit (the signals' ω_d). Every value of the curve is read as a
number or skipped, so an edited summary draws what it holds or nothing.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from dampfit import physics
from dampfit.output.figures import layout as L
from dampfit.output.figures.data import as_data, plain, unit

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

#: Colour of a law whose curve names none (an older summary.json: the four laws' own colours,
#: which every law now carries itself, :attr:`dampfit.model.laws.Law.colour`).
_OLD_COLOURS = {"viscous": "0.45", "coulomb": "tab:orange", "quadratic": "tab:green",
                "power": "tab:blue"}


def _colour(name: str, entry: dict) -> str:
    """The law's plot colour from its curve (``amplitude_curve.models.<law>.colour``)."""
    from matplotlib.colors import is_color_like

    c = entry.get("colour")  # an edited summary may hold anything: only a real colour is used
    return c if isinstance(c, str) and is_color_like(c) else _OLD_COLOURS.get(name, "k")


def _num(v: Any) -> float:
    """``v`` as a float; NaN when it is not a number."""
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def _series(v: Any, n: int) -> np.ndarray | None:
    """``v`` as ``n`` floats (None as NaN), or None when it is not such a list or tuple."""
    if not isinstance(v, (list, tuple, np.ndarray)) or len(v) != n:
        return None
    return np.array([_num(x) for x in v], dtype=float)


def _window_f_sd(w: dict) -> float:
    """1-σ [Hz] of a window's damped frequency (``f_d_sd_hz``, or ``omega_sd`` [rad/s]); NaN."""
    for key, scale in (("f_d_sd_hz", 1.0), ("omega_sd", 1.0 / (2 * np.pi))):
        v = w.get(key)
        if isinstance(v, (int, float)) and np.isfinite(v) and v > 0:
            return float(v) * scale
    return float("nan")


def amplitude_of(an: Any) -> "Figure | None":
    """:func:`amplitude_figure` of an analysis or its
    :class:`~dampfit.output.figures.data.FigureData`: its summary's ``amplitude_curve`` with
    the least-squares damped frequency f_d [Hz] (from the signals' ω_d); None without an
    amplitude curve (the damping laws were not assessed)."""
    d = as_data(an)
    curve = d.section("amplitude_curve")
    if not curve:
        return None
    d.need_signals("amplitude")
    return amplitude_figure(curve, f_d_hz=d.ls_values().get("f_d"))


def amplitude_figure(curve: dict, path: str | os.PathLike | None = None, *, dpi: int = 110,
                     f_d_hz: float | None = None, frequency_trend: dict | None = None) -> "Figure":
    """ζ(A) and the f(A) backbone against displacement amplitude, in two panels.

    ``curve`` is ``summary()["amplitude_curve"]`` of :func:`dampfit.damping.assess`.

    * Top (``fig.axes[0]``), ζ(A): window estimates ζ ± 1.645·sd (90 %) [1] at their
      amplitude [m] (log axis), every law's ζ_eq(a) = ρ(a)/ω from its least-squares fit, the
      90 % posterior band of the chosen law and the reference amplitude of c_eq. With a mass,
      a second axis gives c_eq [N·s/m] = 2·m·ω·ζ (ω from the windows).
    * Bottom, f(A) backbone: each window's damped frequency f_d [Hz] ± 1.645·sd (90 %; sd
      from ``f_d_sd_hz`` [Hz] or ``omega_sd`` [rad/s] of the window, error bars omitted when
      absent) against the same amplitude axis, with the constant frequency ``f_d_hz`` [Hz] the
      free-decay model assumes (dashed, when given); ``frequency_trend``
      (:func:`dampfit.damping.curve.frequency_trend`; default ``curve["backbone"]
      ["frequency_trend"]``) adds its relative change to the title.

    With ``path``, the PNG is written atomically as well.
    """
    fig = L.new_figure(8.0, 7.5)
    ax, ax_f = fig.subplots(2, 1, sharex=True, height_ratios=[1.5, 1.0])
    wins = [w for w in (curve.get("windows") or []) if isinstance(w, dict)]
    a = np.array([_num(w.get("amplitude_m", np.nan)) for w in wins], dtype=float)
    fd = np.array([_num(w.get("f_d_hz", np.nan)) for w in wins], dtype=float)
    grid = _zeta_panel(ax, curve, wins, a)
    ref = _num(curve.get("reference_amplitude_m"))
    for axis in (ax, ax_f):
        if np.isfinite(ref) and ref:
            axis.axvline(ref, color="tab:red", lw=0.9, ls=":",
                         label=f"reference amplitude {ref:.3g} m" if axis is ax else None)
        axis.grid(alpha=0.3, which="both")
    if (a > 0).any() or grid.size > 1:
        _log_amplitudes(ax, ax_f, np.concatenate([a[a > 0], grid[grid > 0]]))
    ax.set_ylabel("damping ratio ζ [1]")
    mass = _num(curve.get("mass_kg"))
    sec = c_per_zeta = None
    if np.isfinite(mass) and mass and np.isfinite(fd).any():
        w = float(2 * np.pi * np.nanmedian(fd))
        c_per_zeta = float(physics.damping_coefficient(mass, w))  # c = 2·m·ω·ζ [N·s/m]
        sec = ax.secondary_yaxis("right", functions=(lambda zz: c_per_zeta * zz,
                                                     lambda cc: cc / c_per_zeta))
        sec.set_ylabel(f"c_eq [{unit('c')}]")
    _zeta_title(ax, curve.get("slope"))
    if not a.size and grid.size < 2:
        ax.text(0.5, 0.5, "no amplitude windows (too few cycles)", ha="center", va="center",
                transform=ax.transAxes, color="0.4")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="best", ncols=2, framealpha=0.7)
    if frequency_trend is None and isinstance(curve.get("backbone"), dict):
        frequency_trend = curve["backbone"].get("frequency_trend")
    _backbone_panel(ax_f, wins, a, fd, f_d_hz, frequency_trend)
    L.suptitle(fig, "Amplitude dependence: damping ζ(A) and frequency f(A)")
    right = 0.2
    if sec is not None:  # c_eq axis: its ticks follow ζ's limits through c = c_per_zeta·ζ
        labels = L.tick_texts(sec.yaxis, interval=[c_per_zeta * v for v in ax.get_ylim()])[0]
        right = L.y_room([], labels=labels)
    L.place(L.gridspec(ax), left=L.y_room([ax, ax_f]), right=right, bottom=L.x_room(),
            top=L.top(L.above(ax)), hgap=L.above(ax_f) + 4 * L.PT)
    if path is not None:
        from dampfit.output.figures.png import write_png

        write_png(fig, path, dpi)
    return fig


def _zeta_panel(ax, curve: dict, wins: list[dict], a: np.ndarray) -> np.ndarray:
    """ζ(A): the windows' ζ ± 90 %, the chosen law's posterior band and every law's
    ζ_eq(a); returns the amplitude grid [m] of the laws' curves."""
    z = np.array([_num(w.get("zeta", np.nan)) for w in wins], dtype=float)
    zs = np.array([_num(w.get("zeta_sd", np.nan)) for w in wins], dtype=float)
    cyc = _num(curve.get("window_cycles") or 0)
    if a.size:
        ax.errorbar(a, z, yerr=1.645 * np.nan_to_num(zs), fmt="o", ms=4, color="0.25",
                    ecolor="0.6", capsize=2,
                    label=f"windowed viscous fits ({cyc:.0f} cycles, 90 %)")
    raw = curve.get("amplitude_grid_m")
    grid = _series(raw, len(raw)) if isinstance(raw, (list, tuple)) else None
    grid = grid if grid is not None else np.zeros(0)
    band = curve.get("band") if isinstance(curve.get("band"), dict) else None
    lo, hi = ((_series(band.get(k), grid.size) for k in ("zeta_q05", "zeta_q95"))
              if band else (None, None))
    if band and grid.size > 1 and lo is not None and hi is not None:
        ax.fill_between(grid, lo, hi, color="tab:blue", alpha=0.18, lw=0,
                        label=f"{plain(str(band.get('model')))}: 90 % posterior band")
    chosen = curve.get("chosen_model")
    models = curve.get("models") if isinstance(curve.get("models"), dict) else {}
    for name, entry in models.items():
        zeta_eq = _series(entry.get("zeta_eq"), grid.size) if isinstance(entry, dict) else None
        if grid.size > 1 and zeta_eq is not None:
            ax.plot(grid, zeta_eq, color=_colour(name, entry),
                    lw=2.0 if name == chosen else 1.0, ls="-" if name == chosen else "--",
                    label=f"{plain(name)}{' (chosen)' if name == chosen else ''}: ζ_eq(a)"
                          + _flat_note(name, zeta_eq))
    return grid


#: The note on a non-viscous law's curve that its fit left flat (no extra term found).
_FLAT_NOTE = {"coulomb": " (no friction at its fit: flat)", "quadratic": " (no drag at its fit: flat)",
              "power": " (exponent 1 at its fit: flat)"}


def _flat_note(name: str, zeta_eq: np.ndarray) -> str:
    """`` (no friction at its fit: flat)`` for a non-viscous law whose least-squares fit put
    its amplitude-dependent term at zero (ζ_eq constant to 0.1 %): the law's own shape (a
    Coulomb ζ_eq falling as 1/a) is then absent from the data, not from the drawing."""
    z = zeta_eq[np.isfinite(zeta_eq)]
    if name not in _FLAT_NOTE or z.size < 2 or not np.all(z > 0):
        return ""
    return _FLAT_NOTE[name] if z.max() < 1.001 * z.min() else ""


def _mantissa_formatter(span: float):
    """Plain tick labels (``0.0002``) of a log axis spanning less than a decade (``span`` =
    largest / smallest amplitude shown): every minor tick below a 3× span, else only the
    mantissas 2 and 5 (and the decades), so that labels never overlap."""
    from matplotlib.ticker import FuncFormatter

    keep = range(1, 10) if span < 3 else (1, 2, 5)

    def label(v, _):
        if not (np.isfinite(v) and v > 0):
            return ""
        m = v / 10 ** math.floor(math.log10(v) + 1e-9)
        return f"{v:.3g}" if abs(m - round(m)) < 1e-6 and round(m) in keep else ""

    return FuncFormatter(label)


def _log_amplitudes(ax, ax_f, span: np.ndarray) -> None:
    """The shared amplitude axis on a log scale; plain numbers on a span of less than a
    decade (``span``: the amplitudes [m] shown)."""
    ax.set_xscale("log")
    L.log_ticks(ax.xaxis)
    if span.size and span.max() < 10 * span.min():  # not 2.2×10⁻¹ on a short log span
        ratio = float(span.max() / span.min())
        ax_f.xaxis.set_major_formatter(_mantissa_formatter(ratio))
        ax_f.xaxis.set_minor_formatter(_mantissa_formatter(ratio))


def _zeta_title(ax, slope: Any) -> None:
    """ζ(A) and, when the summary has it, the slope d ln p/d ln a with its interval."""
    text = "ζ(A)"
    if isinstance(slope, dict) and all(np.isfinite(_num(slope.get(k)))
                                       for k in ("s", "s_q05", "s_q95")):
        text += (f": d ln p/d ln a = {slope['s']:.2f} [{slope['s_q05']:.2f}, "
                 f"{slope['s_q95']:.2f}] (0 for one viscous c)")
    L.title(ax, text, loc="left")


def _backbone_panel(ax_f, wins: list[dict], a: np.ndarray, fd: np.ndarray,
                    f_d_hz: float | None, trend: Any) -> None:
    """f(A): each window's damped frequency f_d [Hz] ± 90 % against its amplitude, the fit's
    constant f_d, and the relative change of ``trend`` in the title."""
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    fs = np.array([_window_f_sd(w) for w in wins], dtype=float)
    ok = np.isfinite(a) & np.isfinite(fd)
    if ok.any():
        has_sd = np.isfinite(fs[ok]).all()
        ax_f.errorbar(a[ok], fd[ok], yerr=1.645 * fs[ok] if has_sd else None, fmt="s", ms=4,
                      color="tab:purple", ecolor="plum", capsize=2,
                      label="windowed damped frequency" + (" (90 %)" if has_sd else
                                                           " (sd not in the summary)"))
    else:
        ax_f.text(0.5, 0.5, "no windowed frequencies", ha="center", va="center",
                  transform=ax_f.transAxes, color="0.4")
    if f_d_hz is not None and np.isfinite(f_d_hz):
        ax_f.axhline(f_d_hz, color="0.3", lw=1.0, ls="--",
                     label=f"constant f_d of the fit = {f_d_hz:.6g} Hz")
    ax_f.set_ylabel("damped frequency f_d [Hz]")
    ax_f.set_xlabel("displacement amplitude a [m]")
    ax_f.yaxis.set_major_locator(MaxNLocator(4))
    ax_f.yaxis.set_major_formatter(ScalarFormatter(useOffset=False))  # 1.72008, not ×10⁻⁴+1.72
    text = "f(A) backbone"
    if isinstance(trend, dict) and all(np.isfinite(_num(trend.get(k)))
                                       for k in ("rel_change", "rel_change_sd")):
        text += (f": f_d changes {100 * trend['rel_change']:+.2g} % "
                 f"(± {100 * trend['rel_change_sd']:.2g} %) over the amplitudes (0 if linear)")
    L.title(ax_f, text, loc="left")
    if ax_f.get_legend_handles_labels()[0]:
        ax_f.legend(fontsize=8, loc="best")
