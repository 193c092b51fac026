r"""Reference solution of the nonlinear free decay, and simulated recordings built from it.

Solves, from rest at u₀ [m],

    m·ü + c·u̇ + F_c·sgn(u̇) + c₂·u̇·|u̇| + c_α·|u̇|^α·sgn(u̇) + k·u = 0            (R1)

with scipy's DOP853 one half-cycle at a time: between two velocity zeros sgn(u̇) = s is
constant, so the right-hand side is smooth there, and an event stops the integration where
u̇ = 0. At each stop the mass sticks for good if the spring force cannot beat static friction
(k·|u| ≤ F_c); otherwise the next half-cycle starts with s = −sgn(u). This is exact up to the
integrator's tolerance (no smoothed sign), which is what the averaged envelopes of
:mod:`dampfit.model.laws` are tested against. NumPy/SciPy only; used by tests and examples.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from dampfit.errors import InputError
from dampfit.io.recording import Recording

__all__ = ["reference_decay", "noisy_recording"]


def reference_decay(
    t, mass: float, k: float, u0: float, *, c: float = 0.0, F_c: float = 0.0,
    c2: float = 0.0, c_alpha: float = 0.0, alpha: float = 1.0, rtol: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacement [m], velocity [m/s] and acceleration [m/s²] of (R1) at times ``t`` [s] ≥ 0.

    ``mass`` [kg], ``k`` [N/m], ``u0`` [m] (released at rest at t = 0), ``c`` [N·s/m],
    ``F_c`` [N], ``c2`` [N·s²/m²], ``c_alpha`` [N·(s/m)^α], ``alpha`` [1].
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) <= 0) or t[0] < 0:
        raise InputError("reference_decay needs increasing times t ≥ 0 [s]")
    if mass <= 0 or k <= 0 or min(c, F_c, c2, c_alpha) < 0 or alpha < 0:
        raise InputError("reference_decay needs m, k > 0 and non-negative damping coefficients")
    u_out, v_out, a_out = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    scale_v = abs(u0) * np.sqrt(k / mass)

    def force(v, s):
        av = np.abs(v)
        return c * v + s * F_c + c2 * v * av + s * c_alpha * av**alpha

    t_now, u_now, t_end = 0.0, float(u0), float(t[-1])
    while t_now < t_end:
        if abs(k * u_now) <= F_c or u_now == 0.0:  # stuck (static friction holds)
            rest = t >= t_now
            u_out[rest], v_out[rest], a_out[rest] = u_now, 0.0, 0.0
            break
        s = -np.sign(u_now)

        def rhs(_, y, s=s):
            return [y[1], -(k * y[0] + force(y[1], s)) / mass]

        def stop(_, y, s=s):
            return y[1] * s  # > 0 while moving in direction s

        stop.terminal, stop.direction = True, -1
        # the first few steps see u̇ ≈ 0, where the event is not armed: start just after
        sol = solve_ivp(rhs, (t_now, t_end), [u_now, 0.0], method="DOP853", events=stop,
                        dense_output=True, rtol=rtol, atol=1e-13 * max(scale_v, 1e-300),
                        first_step=1e-6 * np.pi * np.sqrt(mass / k))
        t_stop = float(sol.t_events[0][0]) if sol.t_events[0].size else t_end
        seg = (t >= t_now) & (t <= t_stop)
        if seg.any():
            y = sol.sol(t[seg])
            u_out[seg], v_out[seg] = y[0], y[1]
            a_out[seg] = -(k * y[0] + force(y[1], s)) / mass
        if t_stop >= t_end:
            break
        t_now, u_now = t_stop, float(sol.y_events[0][0][0])
    return u_out, v_out, a_out


def noisy_recording(t, accel, noise_sd: float, *, seed: int = 0, lead: float = 0.0) -> Recording:
    """A one-axis :class:`~dampfit.io.recording.Recording` of ``accel`` [m/s²] plus white noise.

    ``noise_sd`` [m/s²] per sample; ``lead`` [s] of noise-only samples at rest before the release
    (same spacing as the first two samples of ``t`` [s]).
    """
    rng = np.random.default_rng(seed)
    t = np.asarray(t, dtype=float)
    a = np.asarray(accel, dtype=float)
    if lead > 0:
        dt = t[1] - t[0]
        pre = np.arange(-np.floor(lead / dt), 0) * dt + t[0]
        t, a = np.concatenate([pre, t]), np.concatenate([np.zeros(pre.size), a])
    y = a + noise_sd * rng.standard_normal(a.size)
    return Recording(time=t, accel=y[:, None], axes=("z",), format="array",
                     gravity_removed=True, notes=("simulated: damping.reference",))
