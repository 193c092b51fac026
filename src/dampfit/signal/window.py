"""Free-decay window: where the decay starts (after the release) and where it ends.

From the Hilbert envelope [m/s²] of the band-passed signal on a uniform grid [s]:

* start — just after the release: the maximum of the envelope (averaged over a period); an
  envelope flat within its own ripple (a very light decay, ζ ~ 1e-5) has its maximum
  anywhere, and the release is then where it first comes near it (:func:`_release_index`);
* end — the first of: the envelope reaching 3× the in-band noise floor
  (:func:`noise_floor`, [m/s²]) or rising again (a catch or a new excitation), an abrupt
  envelope drop (a catch, rattle or contact: :func:`envelope_drops`), or an impact spike more
  than :data:`IMPACT_RATIO` times the oscillation before it (:func:`impacts`) — unless the
  oscillation runs on through that spike unchanged (:func:`passes_through`: an isolated
  glitch, masked like any spike, not a catch or knock).

:func:`detect_window` returns the window [s], notes saying why it ends there and the reason
in a few words (``end_reason``: what the CLI table and ``summary.json`` ``window.end_reason``
show; one of :data:`END_REASONS`, with the time of a drop or impact).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from dampfit.signal.spectrum import noise_density

#: A spike this many times the oscillation's envelope ends the free decay (catch or knock).
IMPACT_RATIO = 10.0
#: An envelope flat within this many noise floors or this fraction of its maximum (the
#: Hilbert envelope's own ripple near the ends of a record) has no clear maximum; its release
#: is where it first comes that near (:func:`_release_index`).
PEAK_NOISE, PEAK_RIPPLE = 3.0, 0.1
#: An impact the oscillation passes through: the log-envelope slopes [1/period] over
#: ``THROUGH_PERIODS`` periods before and after the spike agree within ln(``THROUGH_FACTOR``)
#: over that span, and the oscillation after it stands ≥ 3× the noise floor.
THROUGH_PERIODS, THROUGH_FACTOR = 2.0, 1.5
#: Abrupt envelope drops (catch, rattle, contact; :func:`envelope_drops`): the span [periods]
#: over which a drop is measured, the running-median span of the decay trend [periods], the
#: excess loss factor that ends the window, and the envelope-to-noise-floor ratio needed.
DROP_PERIODS, DROP_TREND_PERIODS, DROP_FACTOR, DROP_MIN_SNR = 2.0, 15.0, 2.0, 20.0
#: Why an automatic window ends (``end_reason`` of :func:`detect_window`; a drop or an impact
#: adds its time): the decay reached the noise floor, the envelope rose again, an abrupt drop,
#: an impact spike, or the recording ended first.
END_REASONS = ("the decay reaches 3x the noise floor",
               "the envelope rises again (catch or new excitation)",
               "abrupt envelope drop (catch, rattle or contact)", "impact (catch or knock)",
               "end of the recording")
#: Mean and 10th percentile of a Rayleigh envelope, in units of the in-band noise σ.
RAYLEIGH_MEAN, RAYLEIGH_P10 = float(np.sqrt(np.pi / 2)), float(np.sqrt(-2 * np.log(0.9)))


def noise_floor(env: np.ndarray, y: np.ndarray, fs: float, f0: float, band) -> float:
    """Mean envelope [m/s²] of the in-band noise alone.

    Two estimates, the smaller wins: (a) spectral — white density off the peak times the band
    width (a Rayleigh envelope has mean 1.25·σ); it is accurate for long records but overstated
    when a short, strongly damped line leaks into every bin; (b) temporal — the 10th
    percentile of the envelope, scaled to the Rayleigh mean (×2.7); it is accurate when part of
    the record is quiet (before release, after the decay) and overstated otherwise.
    """
    spectral = RAYLEIGH_MEAN * noise_density(y, fs, f0, band) * np.sqrt(band[1] - band[0])
    edge = min(len(env) // 10, int(fs / f0))
    inner = env[edge : len(env) - edge] if len(env) > 2 * edge + 10 else env
    temporal = RAYLEIGH_MEAN / RAYLEIGH_P10 * float(np.percentile(inner, 10))
    return float(min(spectral, temporal)) if temporal > 0 else float(spectral)


def impacts(t, y, usable, hits, f0) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] of spike samples and their size relative to the usable signal before them.

    The reference is the largest usable |y| [m/s²] between 1.5 and 0.25 periods before the
    spike: the oscillation's own amplitude, unaffected by masking or filtering.
    """
    times = t[hits]
    ratios = np.empty(times.size)
    tu, au = t[usable], np.abs(y[usable])
    for j, (tc, a) in enumerate(zip(times, np.abs(y[hits]))):
        lo, hi = np.searchsorted(tu, [tc - 1.5 / f0, tc - 0.25 / f0])
        ref = au[lo:hi].max() if hi > lo else 0.0
        ratios[j] = a / ref if ref > 0 else np.inf
    return times, ratios


def running_median(x: np.ndarray, width: int, mode: str = "nearest") -> np.ndarray:
    """Centred running median over ``width`` samples, computed on a thinned copy (fast);
    ``mode`` extends the ends as :func:`scipy.ndimage.median_filter` does (``"mirror"`` keeps
    an outlier in the first sample from filling the window)."""
    step = max(1, width // 20)
    thin = x[::step]
    med = ndimage.median_filter(thin, size=max(1, width // step) | 1, mode=mode)
    return np.interp(np.arange(x.size), np.arange(thin.size) * step, med)


def envelope_drops(grid: np.ndarray, env: np.ndarray, f0: float, floor: float,
                   i0: int, i1: int) -> list[tuple[float, float]]:
    """Abrupt envelope drops between grid indices ``i0`` and ``i1``: [(time [s], factor [1])].

    A free decay loses amplitude smoothly: over ``DROP_PERIODS`` periods the log envelope
    falls by 2π·ζ·``DROP_PERIODS`` (viscous) or by a slowly varying amount (any other smooth
    law). A catch, rattle or contact takes energy out within a cycle. The drop over
    ``DROP_PERIODS`` periods, d(t) = ln ē(t + D/2) − ln ē(t − D/2) (ē: the Hilbert envelope
    averaged over one period), is compared with its running median over ``DROP_TREND_PERIODS``
    periods (the decay trend, whatever the law); an excess loss of more than ``DROP_FACTOR``
    (a factor, not a difference) where the envelope stands ≥ ``DROP_MIN_SNR`` × the noise
    floor before the drop (and ≥ 3× after it, so that the trend is measured on the decay,
    not on the noise floor) is reported, at the time of the steepest excess.
    """
    fs = 1.0 / (grid[1] - grid[0])
    per = max(1, int(round(fs / f0)))
    half = max(1, int(round(DROP_PERIODS * per / 2)))
    # not within two periods of the record's end, where the band-pass and Hilbert edges
    # bend the envelope down (against the trend before it, that edge would look abrupt)
    lo, hi = max(i0, half), min(i1, len(env) - half - 2 * per - 1)
    if hi - lo < 4 * per:
        return []
    sm = np.log(np.maximum(ndimage.uniform_filter1d(env, per), 1e-300))
    idx = np.arange(lo, hi)
    # measured where the envelope stands clear of the noise on both sides: the flat floor
    # after a decay must not enter the trend (it would make the decay itself look abrupt)
    clear = (sm[idx - half] > np.log(DROP_MIN_SNR * floor)) & (sm[idx + half] > np.log(3.0 * floor))
    idx = idx[clear]
    if idx.size < 4 * per:
        return []
    d = sm[idx + half] - sm[idx - half]
    width = int(DROP_TREND_PERIODS * per)
    trend = running_median(d, width)
    # the trend before the drop too: a catch within a trend span of the range's end (where
    # the decay after it reaches the floor) would otherwise pull the centred median down
    # with it (issue 34: a cantilever caught at 7.7 s was analysed on to 19.4 s)
    lag = width // 2 + 2 * half
    past = trend.copy()
    if idx.size > lag:
        past[lag:] = trend[:-lag]
    centred = trend - d
    excess = np.maximum(trend, past) - d  # > 0: more loss than the trend
    # against the past trend only where the amplitude lost (not only its log) also exceeds
    # the past trend's: friction loses a constant amplitude per cycle, so its log rate grows
    # towards its stop but its linear loss does not; a catch exceeds both
    lin = np.exp(sm)
    dl = lin[idx + half] - lin[idx - half]  # [m/s²] < 0 while decaying
    past_lin = running_median(dl, width)
    if idx.size > lag:
        past_lin[lag:] = past_lin[:-lag].copy()
    sudden = (past_lin < 0) & (dl < DROP_FACTOR * past_lin)
    hits = (centred > np.log(DROP_FACTOR)) | ((past - d > np.log(DROP_FACTOR)) & sudden)
    out = []
    j = 0
    while j < idx.size:
        if hits[j]:
            k = j
            while k < idx.size and hits[k]:
                k += 1
            # at the steepest excess over the centred trend; found against the past trend
            # alone (which stays exceeded after a catch): at the run's onset
            m = j + int(np.argmax(centred[j:k])) if centred[j:k].max() > np.log(DROP_FACTOR) \
                else j
            out.append((float(grid[idx[m]]), float(np.exp(excess[m]))))
            j = k + 2 * half
        else:
            j += 1
    return out


def _release_index(sm: np.ndarray, per: int, floor: float) -> int:
    """Index of the release in the period-averaged envelope ``sm`` [m/s²] (``per`` samples a
    period, ``floor`` the noise floor [m/s²]): its maximum — unless the envelope first came
    within its own ripple (:data:`PEAK_RIPPLE` of the maximum, or :data:`PEAK_NOISE` noise
    floors) more than two periods earlier and stayed above half the maximum since: then the
    envelope is flat (a very light decay, whose maximum is anywhere) and the release is where
    it first got there. A dip below half between the two is a new excitation: the maximum."""
    i_max = int(np.argmax(sm))
    top = float(sm[i_max])
    i_first = int(np.argmax(sm >= top - max(PEAK_NOISE * floor, PEAK_RIPPLE * top)))
    flat = i_max - i_first > 2 * per and float(sm[i_first:i_max + 1].min()) >= 0.5 * top
    return i_first if flat else i_max


def passes_through(sm: np.ndarray, i: int, per: int, floor: float, i_pk: int) -> bool:
    """Whether the oscillation runs on unchanged through a spike at grid index ``i``.

    ``sm`` is the period-averaged envelope [m/s²] (spikes masked and bridged before the
    band-pass, so it shows the oscillation, not the spike), ``per`` the period [samples],
    ``floor`` the noise floor [m/s²], ``i_pk`` the release. A free decay is locally
    exponential: the log-envelope slope from ``THROUGH_PERIODS`` periods before the spike (or
    a period after the release, if nearer) to as many after it equals the slope over the next
    2·``THROUGH_PERIODS`` periods (or up to a period before the end of the recording, if
    nearer), whatever the damping law. A catch (the oscillation stops), a knock (it jumps) or
    a contact (it loses energy at once) breaks that; so does an oscillation already at the
    noise after the spike, where nothing can be told (then False).
    """
    d = max(1, int(round(THROUGH_PERIODS * per)))
    a, b, c = max(i - d, i_pk + per), i + d, min(i + 3 * d, sm.size - 1 - per)
    if b - a < per or c - b < per or min(sm[a], sm[b]) <= 0 or sm[c] < 3.0 * floor:
        return False
    before = (np.log(sm[b]) - np.log(sm[a])) / (b - a)
    after = (np.log(sm[c]) - np.log(sm[b])) / (c - b)
    return abs(before - after) * (c - a) / 2 < np.log(THROUGH_FACTOR)


def detect_window(
    grid: np.ndarray, env: np.ndarray, f0: float, floor: float, events: np.ndarray
) -> tuple[float, float, list[str], str]:
    """Free-decay window [s] from the smoothed envelope; see the module docstring.

    Returns (start [s], end [s], notes, end_reason): ``end_reason`` is the one cause that set
    the end (:data:`END_REASONS`), the last of the notes.

    ``events`` = (times [s], size ratios [1]) of masked impact spikes (:func:`impacts`). A
    spike ends the free decay (a catch, or a knock that resets the oscillator) if it is more
    than ``IMPACT_RATIO`` times the oscillation just before it, unless the oscillation passes
    through it unchanged (:func:`passes_through`). (Whether the oscillation "dies" after a
    spike alone is no test: a heavily damped decay dies by itself within a few periods; the
    test compares the decay rates before and after the spike.) The last note says why the
    window ends where it does.
    """
    fs = 1.0 / (grid[1] - grid[0])
    per = max(1, int(round(fs / f0)))
    sm = ndimage.uniform_filter1d(env, per)
    edge = min(per, len(sm) // 10)
    inner = sm[edge : len(sm) - edge] if len(sm) > 2 * edge + 1 else sm
    i_pk = _release_index(inner, per, floor) + (edge if len(sm) > 2 * edge + 1 else 0)
    notes = []
    # the end: envelope below 3× the noise floor, or rising again (a catch or a new pluck),
    # judged on a median over five periods so that short dropouts (gaps) do not end it
    robust = running_median(env, 5 * per)
    run_min = np.minimum.accumulate(robust[i_pk:])
    low = np.flatnonzero(robust[i_pk:] < 3.0 * floor)
    rise = np.flatnonzero((robust[i_pk:] > 1.5 * run_min) & (robust[i_pk:] > 5.0 * floor))
    i_end = len(sm) - 1 - edge
    reason = END_REASONS[4]
    if low.size and i_pk + int(low[0]) < i_end:
        i_end = i_pk + int(low[0])
        notes.append("window ends where the decay reaches 3x the noise floor")
        reason = END_REASONS[0]
    if rise.size:
        i_rise = i_pk + int(rise[0]) - per
        if i_rise < i_end:
            i_end = i_rise
            notes.append("window ends before the envelope rises again (catch or new excitation)")
            reason = END_REASONS[1]
    ev_t, ev_a = events
    after = ev_t > grid[min(i_pk + per, len(grid) - 1)]  # not the excitation itself
    through: list[float] = []
    for tc, ratio in zip(ev_t[after], ev_a[after]):
        i = int(np.searchsorted(grid, tc))
        if i >= i_end:
            break
        if ratio > IMPACT_RATIO:
            if passes_through(sm, i, per, floor, i_pk):
                if not through or tc - through[-1] > 0.5 / f0:  # one spike, not its samples
                    through.append(float(tc))
                continue
            i_end = max(i - per // 2, i_pk)
            notes.append(f"window ends before an impact at {tc:.2f} s (catch or knock)")
            reason = f"impact at {tc:.2f} s (catch or knock)"
            break
    # an abrupt drop before that end (after an impact's end the drop is the impact's own)
    drops = envelope_drops(grid, env, f0, floor, i_pk + per, i_end)
    if drops:
        tc, factor = drops[0]
        i_end = max(int(np.searchsorted(grid, tc)) - per, i_pk)
        notes.append(f"window ends before an abrupt envelope drop at {tc:.2f} s (the envelope fell "
                     f"{factor:.1f}x more than the decay trend within {DROP_PERIODS:g} cycles: a "
                     "catch, rattle or contact)")
        reason = f"abrupt envelope drop at {tc:.2f} s (catch, rattle or contact)"
    if through:
        shown = ", ".join(f"{x:.2f}" for x in through[:3]) + (", …" if len(through) > 3 else "")
        notes.insert(0, f"{len(through)} spike(s) over {IMPACT_RATIO:g}x the oscillation (at "
                        f"{shown} s) are masked but do not end the window: the decay runs on "
                        "through them unchanged (glitches, not a catch or knock)")
    return float(grid[i_pk]), float(grid[max(i_end, i_pk)]), notes, reason


#: How many later windows :func:`later_decay` tries.
LATER_TRIES = 8


def later_decay(grid: np.ndarray, env: np.ndarray, f0: float, floor: float, events,
                after: float, guard: float, min_cycles: float):
    """The longest free decay that starts after ``after`` [s] (a handheld start: the first
    "release" was the hand's motion, cut short where the real release made the envelope rise
    again): :func:`detect_window` on the rest of the recording, again after each window it
    finds, up to :data:`LATER_TRIES` times. Returns ``(start, end, notes, end_reason)`` of the window with
    the most cycles of ``f0`` [Hz] past ``guard`` [s], if it has at least ``min_cycles``;
    else None."""
    ev_t, ev_a = events
    best, best_cycles = None, min_cycles
    per_s = 1.0 / f0
    for _ in range(LATER_TRIES):
        i = int(np.searchsorted(grid, after))
        if grid.size - i < 8 * max(1, int(round(1.0 / (f0 * (grid[1] - grid[0]))))):
            break
        keep = ev_t >= grid[i]
        w0, w1, notes, reason = detect_window(grid[i:], env[i:], f0, floor,
                                              (ev_t[keep], ev_a[keep]))
        cycles = (w1 - min(w0 + guard, w1)) * f0
        if cycles >= best_cycles:
            best, best_cycles = (w0, w1, notes, reason), cycles
        after = max(w1, after + per_s)
    return best


def release_time(grid: np.ndarray, env: np.ndarray, start: float, f0: float) -> float:
    """Time [s] the oscillation was released, for a decay window starting at ``start`` [s].

    An automatic window starts after the envelope maximum plus a guard (half a period at
    least), so the decay between the release and ``start`` depends on the decay rate: two
    tests released alike start their windows at amplitudes that differ by e^{−Δp·(start −
    release)}. The release is taken where the envelope ``env`` [m/s²] (on ``grid`` [s]) last
    rose through half its maximum before ``start``; when the envelope is below half only in
    the first period of the recording (1/``f0``, ``f0`` [Hz]) — the band-pass filter's edge,
    a recording that starts at the release, as a simulation does — the release is the first
    grid time."""
    grid, env = np.asarray(grid, float), np.asarray(env, float)
    i_start = int(np.searchsorted(grid, start, side="right"))
    before = env[:max(i_start, 1)]
    i_peak = int(np.argmax(before))
    low = np.flatnonzero(before[:i_peak + 1] < 0.5 * before[i_peak])
    if not low.size or grid[low[-1]] - grid[0] < 1.0 / f0 and low.size == low[-1] + 1:
        return float(grid[0])
    return float(grid[low[-1] + 1])
