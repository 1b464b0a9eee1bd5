"""Logged thruster commands that did not drive the boat: a twin-thruster boat moving astern while
both its thrusters are commanded ahead.

A boat whose two thrusters both push it ahead cannot make way astern for long: the surge
balance ``m11 u' = -d11 u + T_port + T_stbd`` (Fossen form; any hull with positive surge
damping) drives u towards a positive value, and at u < 0 the damping and the thrust both
accelerate it ahead. A stretch of at least :data:`MIN_ASTERN_S` with ``u < -``:data:`ASTERN_U`
while both commands give thrust ahead therefore says that the logged commands are not what drove
the boat there (a manual override, a thruster reversed by its controller, commands logged but not
sent). Fitting through it teaches the model a thrust that pushes the boat astern (on the VTec S3
zig-zag runs: a surge mass of 3.4 times the boat's and a negative surge R^2). The estimator keeps
the part of such a log before the first stretch and says so; validation replays the whole log
and notes the stretch.

Units: time [s], speed [m/s].
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Speed astern [m/s] beyond which a boat is making way astern (above GNSS/INS velocity noise).
ASTERN_U = 0.15
#: Shortest stretch [s] of way astern under thrust ahead that counts (a brief overshoot of a
#: stop is not one).
MIN_ASTERN_S = 1.0
#: Seconds before such a stretch also left out of a fit: the deceleration into it (on the VTec
#: runs from 1.1 m/s ahead to astern within about 1 s) is as little driven by the commands.
MARGIN_S = 2.0


def astern_under_thrust_ahead(trial: Any, thrust_of: Any) -> list[tuple[float, float, float]]:
    """The stretches ``(t0, t1, u_min)`` [s from the trial's first sample, s, m/s] where the
    trial's surge ``u`` is below ``-ASTERN_U`` for at least :data:`MIN_ASTERN_S` while the thrust
    of both commands ``n_port``, ``n_stbd`` (``thrust_of(command)`` [N or command units]) is
    ahead (> 0). Empty when the trial lacks a channel."""
    if not all(trial.has(c) for c in ("u", "n_port", "n_stbd")):
        return []
    t = np.asarray(trial.t, dtype=float)
    u = np.asarray(trial["u"], dtype=float)
    tp = np.asarray(thrust_of(np.asarray(trial["n_port"], float)), dtype=float)
    ts = np.asarray(thrust_of(np.asarray(trial["n_stbd"], float)), dtype=float)
    with np.errstate(invalid="ignore"):
        bad = (u < -ASTERN_U) & (tp > 0) & (ts > 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if t[b - 1] - t[a] >= MIN_ASTERN_S:
            out.append((float(t[a] - t[0]), float(t[b - 1] - t[0]), float(np.min(u[a:b]))))
    return out


def describe(stretches: list[tuple[float, float, float]]) -> str:
    """The stretches as text: ``8.6-12.0 s (u down to -0.32 m/s)``."""
    return ", ".join(f"{a:.1f}-{b:.1f} s (u down to {m:.2f} m/s)" for a, b, m in stretches)


__all__ = ["ASTERN_U", "MARGIN_S", "MIN_ASTERN_S", "astern_under_thrust_ahead", "describe"]
