"""The physics check of a model before its manoeuvres are simulated and judged.

A model outside the physics of a surface vessel gives numbers that look like results (a "turning
circle" to port under starboard rudder, negative tactical diameters of a vessel backing, IMO
"passed"; autopilot gains of 1e-13): ``usvid simulate`` and ``usvid autopilot`` refuse it with
the reason instead. The check is a probe, the same for every kind: a step of the rudder to
starboard at the manoeuvre's rudder angle (a turning test's or zig-zag's ``--delta-deg``; else
the largest angle, 35 deg or the steering gear's limit when smaller: a model is judged where it
is used, not where it is extrapolated) from the approach speed, :data:`PROBE_S` long, and it
refuses a model

* whose shaft speed ``n`` is not positive (the propeller runs astern: no turning test);
* that turns to port (e.g. K < 0 with a course-stable T > 0);
* whose surge speed ends negative (it goes astern: negative thrust);
* (``strict``, for the autopilot design) that diverges within the probe (e.g. K = 1e12, or a
  cubic damping n3 < 0 that lets the turn run away).

The probe and what counts as turning to the wrong side, going astern and diverging are defined
once, in :mod:`usvid.sim.physics` (identification's model checks read the same probe).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from usvid.errors import UsvidError

#: Length of the probe [s].
PROBE_S = 60.0
#: Parameters named in the hint when negative (gains, shaft speed, cubic damping).
_SIGNED = ("K", "n", "n3")


class PhysicsError(UsvidError):
    """A model is outside the physics of a surface vessel (the message says how)."""


def _hint(model: Any, setting: str = "") -> str:
    neg = [setting] if setting else []
    for name in _SIGNED:
        v = getattr(model.dynamics, name, None)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and v < 0:
            neg.append(f"{name} = {v:g}")
    return f" (check {', '.join(neg)})" if neg else ""


def check_physics(model: Any, path: str | Path, u0: float, dt: float, *,
                  strict: bool = False, setting: str = "", duration: float = PROBE_S,
                  angle: float | None = None) -> None:
    """Refuse ``model`` (loaded from ``path``) with a :class:`PhysicsError` when the probe (the
    module docstring) shows it outside the physics of a surface vessel at ``u0`` [m/s], step
    ``dt`` [s]; ``strict`` also refuses a probe that diverges. ``setting``: an option that
    changed the model (``"--rps 1e-06"``), named in the message. ``duration`` [s]: the run the
    model is wanted for; the probe is no longer (at most :data:`PROBE_S`). ``angle`` [rad]: the
    probe's rudder angle (default: 35 deg or the steering gear's limit)."""
    from usvid.sim.physics import turn_probe

    name = Path(path).name
    hint = _hint(model, setting)
    kind = getattr(model, "kind", "?")
    where = f"{name}: outside the physics of a {kind} model"
    n = getattr(model.dynamics, "n", None)
    if isinstance(n, (int, float)) and not isinstance(n, bool) and n <= 0:
        raise PhysicsError(f"{where}: the shaft speed n = {n:g} rps is not positive (the "
                           f"propeller runs astern; give n > 0 or --rps){hint}")
    limit = min(math.radians(35.0), float(model.servo.max_angle))
    angle = limit if angle is None else min(abs(angle), float(model.servo.max_angle))
    probe = turn_probe(model, angle, u0, t_end=min(PROBE_S, duration), dt=dt)
    step = f"under a {math.degrees(angle):g} deg rudder step to starboard"
    if probe.wrong_side:
        raise PhysicsError(f"{where}: {step} it turns to port (heading "
                           f"{math.degrees(probe.side_turn):+.1f} deg at t = "
                           f"{probe.side_at:.1f} s; a positive rudder angle must make the yaw "
                           f"rate positive){hint}")
    if probe.astern:
        raise PhysicsError(f"{where}: {step} it goes astern (surge speed {probe.u_end:.3g} m/s "
                           f"after {probe.t[-1]:g} s: negative thrust?){hint}")
    if strict and probe.diverged:
        when = f" at t = {probe.diverged_at:.2f} s" if probe.diverged_at is not None else ""
        raise PhysicsError(f"{where}: {step} it diverges{when} (yaw rate beyond 100 rad/s, "
                           f"which no vessel reaches){hint}")
