r"""One-mode decays with the structure that is *not* a second mode (issue 34), and the cases a
several-mode analysis must tell from it: the recordings on which ``paper/modes_false_rate.py``
measures the false-mode rate.

Each function returns ``(Recording, truth)``: one axis ``z`` [m/s²] of a mass released at rest
from ``u0`` [m] at t = 0 (a quiet 0.5 s before it), white noise of density ``noise_density``
[µg/√Hz], and a truth dict naming the true modes (``modes``: [{"f_n" [Hz], "zeta" [1]}]) and
the components that are not modes (``not_modes``: [{"f_hz", "kind"}]).

* :func:`clipped` — a viscous decay whose acceleration saturates at ``level`` × its first
  peak (a sensor's range): odd harmonics 3f, 5f … while the swing exceeds the range, none
  after (they decay faster than any harmonic's n·p);
* :func:`nonlinear` — Coulomb friction (F_c [N], closed form: each half cycle a sinusoid
  about ±F_c/k, the amplitude falling by 2F_c/k, until static friction holds) or quadratic
  drag (c₂ [N·s²/m²], ODE m·ü + c·u̇ + c₂·u̇|u̇| + k·u = 0 by scipy's DOP853): the
  acceleration's harmonics come from the force's sgn(v) or v|v|;
* :func:`modulated` — a fundamental and a real second mode whose amplitude the first
  modulates, a₂(t)·(1 + μ·e^{−p₁t}·cos ω₁t): sidebands at f₂ ± f₁ decaying at p₁ + p₂;
* :func:`drifting` — a viscous decay whose frequency drifts linearly by ``drift`` (relative)
  over the record (temperature, a slowly settling clamp), phase φ(t) = ω₀(t + drift·t²/2T);
* :func:`two_modes` — a fundamental and a real mode at ``ratio`` × f₁ with its own ζ₂ (at
  2 f₁ with a slow decay: a mode, not a harmonic; 1.001 f₁: a close pair).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from dampfit.errors import InputError
from dampfit.io.recording import Recording

#: The structured cases by name (``paper/modes_false_rate.py``).
KINDS = ("clipped", "coulomb", "quadratic", "modulated", "drifting", "mode_at_2f", "close_pair")

_G = 9.80665
_LEAD = 0.5  # [s] of quiet before the release


def _times(duration: float, fs: float) -> np.ndarray:
    if not (math.isfinite(duration) and duration > 0 and math.isfinite(fs) and fs > 0):
        raise InputError(f"duration and sample rate must be positive, got {duration!r}, {fs!r}")
    return np.arange(0.0, duration + _LEAD, 1.0 / fs) - _LEAD


def _finish(t: np.ndarray, a: np.ndarray, noise_density: float, fs: float, seed: int,
            truth: dict[str, Any]) -> tuple[Recording, dict[str, Any]]:
    """Quiet before the release, white noise [µg/√Hz → m/s² per sample], one axis z."""
    a = np.where(t < 0, 0.0, a)
    sigma = noise_density * 1e-6 * _G * math.sqrt(fs / 2.0)
    a = a + sigma * np.random.default_rng(seed).standard_normal(t.size)
    rec = Recording(time=t + _LEAD, accel=a[:, None], axes=("z",), format="simulated",
                    notes=(f"simulated structured decay: {truth['kind']}, seed {seed}",))
    return rec, truth


def _viscous(t, f_n: float, zeta: float, u0: float):
    """(u [m], v [m/s], a [m/s²]) of a viscous decay released at rest (t ≥ 0)."""
    wn = 2 * math.pi * f_n
    p, wd = zeta * wn, wn * math.sqrt(1 - zeta**2)
    tau = np.clip(t, 0.0, None)
    e = np.exp(-p * tau)
    u = u0 * e * (np.cos(wd * tau) + p / wd * np.sin(wd * tau))
    v = -u0 * wn**2 / wd * e * np.sin(wd * tau)
    return u, v, -(2 * p * v + wn**2 * u)


def clipped(f_n: float = 3.3, zeta: float = 0.004, *, level: float = 0.6, u0: float = 0.02,
            duration: float = 40.0, fs: float = 200.0, noise_density: float = 300.0,
            seed: int = 0):
    """A viscous decay clipped at ``level`` × its first acceleration peak (module docstring)."""
    t = _times(duration, fs)
    a = _viscous(t, f_n, zeta, u0)[2]
    top = level * float(np.max(np.abs(a)))
    return _finish(t, np.clip(a, -top, top), noise_density, fs, seed,
                   {"kind": "clipped", "modes": [{"f_n": f_n, "zeta": zeta}],
                    "not_modes": [{"f_hz": n * f_n, "kind": "harmonic"} for n in (3, 5)]})


def nonlinear(f_n: float = 2.0, zeta: float = 0.002, *, F_c: float = 0.0, c2: float = 0.0,
              mass: float = 0.5, u0: float = 0.03, duration: float = 40.0, fs: float = 200.0,
              noise_density: float = 300.0, seed: int = 0):
    """Coulomb friction ``F_c`` [N] (closed form, ``zeta`` ignored) or quadratic drag ``c2``
    [N·s²/m²] with viscous ``zeta`` (ODE): module docstring."""
    t = _times(duration, fs)
    k = mass * (2 * math.pi * f_n) ** 2
    if F_c > 0 and c2 == 0:
        u, v, stuck = _coulomb(np.clip(t, 0, None), k, mass, F_c, u0)
        a = np.where(t >= stuck, 0.0, -(k * u + F_c * np.sign(v)) / mass)  # held by friction
        kind = "coulomb"
    elif c2 > 0 and F_c == 0:
        a = _drag(t, k, mass, 2 * zeta * math.sqrt(k * mass), c2, u0)
        kind = "quadratic"
    else:
        raise InputError("nonlinear() needs exactly one of F_c > 0 (Coulomb) or c2 > 0 (drag)")
    return _finish(t, a, noise_density, fs, seed,
                   {"kind": kind, "modes": [{"f_n": f_n, "zeta": zeta}],
                    "not_modes": [{"f_hz": n * f_n, "kind": "harmonic"} for n in (2, 3, 5)]})


def _coulomb(t, k: float, mass: float, F_c: float, u0: float):
    """Displacement and velocity of a Coulomb decay: half cycle n about offset s·F_c/k with
    amplitude |u_n| − F_c/k, the next turning point |u_n| − 2F_c/k, stuck once k|u| ≤ F_c
    (returned: u [m], v [m/s] and the time it sticks [s])."""
    w = math.sqrt(k / mass)
    half, d = math.pi / w, F_c / k
    u, v = np.full(t.size, float(u0)), np.zeros(t.size)
    start, turn = 0.0, float(u0)
    while abs(turn) > d:
        sign = -math.copysign(1.0, turn)  # direction of motion
        centre = -sign * d  # friction opposes the motion: the offset is on the far side
        amp = turn - centre
        sel = (t >= start) & (t < start + half)
        tau = t[sel] - start
        u[sel] = centre + amp * np.cos(w * tau)
        v[sel] = -amp * w * np.sin(w * tau)
        start, turn = start + half, centre - amp
        u[t >= start], v[t >= start] = turn, 0.0
    return u, v, start


def _drag(t, k: float, mass: float, c: float, c2: float, u0: float) -> np.ndarray:
    from scipy.integrate import solve_ivp

    def rhs(_, y):
        return [y[1], -(k * y[0] + c * y[1] + c2 * y[1] * abs(y[1])) / mass]

    tau = np.clip(t, 0.0, None)
    grid = np.unique(tau)
    sol = solve_ivp(rhs, (0.0, float(grid[-1])), [u0, 0.0], t_eval=grid, method="DOP853",
                    rtol=1e-10, atol=1e-12 * max(abs(u0), 1e-12))
    u, v = (np.interp(tau, grid, s) for s in sol.y)
    return -(k * u + c * v + c2 * v * np.abs(v)) / mass


def modulated(f1: float = 7.85, zeta1: float = 0.003, f2: float = 50.4, zeta2: float = 0.002,
              *, ratio: float = 0.3, depth: float = 0.3, u0: float = 0.002,
              duration: float = 30.0, fs: float = 500.0, noise_density: float = 300.0,
              seed: int = 0):
    """A fundamental and a real second mode (acceleration ``ratio`` × the first's) modulated
    by the first at ``depth`` μ: sidebands at f₂ ± f₁ (module docstring)."""
    t = _times(duration, fs)
    a1 = _viscous(t, f1, zeta1, u0)[2]
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
    tau = np.clip(t, 0.0, None)
    peak = float(np.max(np.abs(a1)))
    env1 = np.exp(-zeta1 * w1 * tau)
    a2 = ratio * peak * np.exp(-zeta2 * w2 * tau) * np.cos(w2 * tau) \
        * (1.0 + depth * env1 * np.cos(w1 * tau))
    return _finish(t, a1 + a2, noise_density, fs, seed,
                   {"kind": "modulated", "modes": [{"f_n": f1, "zeta": zeta1},
                                                   {"f_n": f2, "zeta": zeta2}],
                    "not_modes": [{"f_hz": f2 - f1, "kind": "sideband"},
                                  {"f_hz": f2 + f1, "kind": "sideband"}]})


def drifting(f_n: float = 4.25, zeta: float = 0.003, *, drift: float = -0.02, u0: float = 0.01,
             duration: float = 40.0, fs: float = 200.0, noise_density: float = 300.0,
             seed: int = 0):
    """A viscous decay whose frequency drifts by ``drift`` (relative) over ``duration``."""
    t = _times(duration, fs)
    tau = np.clip(t, 0.0, None)
    w = 2 * math.pi * f_n
    phase = w * (tau + drift * tau**2 / (2 * duration))
    a = -u0 * w**2 * np.exp(-zeta * w * tau) * np.cos(phase)
    return _finish(t, a, noise_density, fs, seed,
                   {"kind": "drifting", "modes": [{"f_n": f_n, "zeta": zeta}],
                    "not_modes": [{"f_hz": f_n * (1 + drift), "kind": "split"}]})


def two_modes(f1: float = 3.3, zeta1: float = 0.004, *, ratio: float = 2.0,
              zeta2: float = 0.0004, amplitude: float = 0.2, u0: float = 0.01,
              duration: float = 40.0, fs: float = 200.0, noise_density: float = 300.0,
              seed: int = 0, kind: str = "mode_at_2f"):
    """A fundamental and a real mode at ``ratio`` × f₁ with damping ``zeta2`` and
    ``amplitude`` × the first's acceleration (module docstring)."""
    t = _times(duration, fs)
    a1 = _viscous(t, f1, zeta1, u0)[2]
    f2 = ratio * f1
    w2 = 2 * math.pi * f2
    tau = np.clip(t, 0.0, None)
    a2 = amplitude * float(np.max(np.abs(a1))) * np.exp(-zeta2 * w2 * tau) * np.cos(
        w2 * math.sqrt(1 - zeta2**2) * tau + 0.4)
    return _finish(t, a1 + a2, noise_density, fs, seed,
                   {"kind": kind, "modes": [{"f_n": f1, "zeta": zeta1},
                                            {"f_n": f2, "zeta": zeta2}], "not_modes": []})
