"""The conditions of a held-out run, for predicting its manoeuvre in them: the run's logged wind
and the current estimated from its approach before the execute.

* **Wind**: the true wind of the log, ``wind_speed_true`` [m/s] and ``wind_dir_true`` [rad, from
  north, clockwise, coming from], when logged; else the apparent wind ``wind_speed``,
  ``wind_angle`` converted with :func:`usvid.models.environment.wind.apparent_to_true` and the
  vessel's ground velocity (the derivative of the positions, a 2-s Savitzky-Golay window; the
  body velocities u, v rotated by the heading when the log has no positions, taken to be over
  ground). The wind is an input, like the rudder: its series from the execute on drives the
  prediction (held at its last value beyond the log).
* **Current** (Fossen 2021, ch. 10.3: the velocity over ground is the velocity through the water
  plus the current): over the approach before the execute only
  (:func:`usvid.manoeuvres.detect.approach_window`, nothing after the execute), the mean velocity
  over ground from the positions (their change over the window divided by its duration) less the
  mean velocity through the water, ``U_w (cos psi, sin psi)`` (no drift angle on a straight
  approach; the log carries no speed through the water). ``U_w`` is the model's: with a
  constant current the acceleration over ground is the acceleration through the water, so
  ``U_w`` is the speed at which the model's straight run at the approach's shaft speed
  accelerates as the vessel does along its heading (:func:`water_speed`; a quadratic fit of
  the positions over the window gives the acceleration). On a steady approach that is the
  model's straight-line speed; a run still accelerating from rest (the Esso Osaka pond
  zig-zags, executed at 40 % of their steady speed) is slower through the water than that, and
  taking the steady speed would make its speed deficit a head current (0.3-0.4 m/s there,
  against the 0.03 m/s the turning circles drift). Refused, with the reason, when the log has
  no positions or heading, when the model gives no speed through the water (a response kind:
  constant speed, no propulsion), when the heading turns by more than
  :data:`STEADY_HEADING_DEG` over the window (not a straight approach), when the vessel
  accelerates more than the model can at that shaft speed, or when the acceleration's
  standard error leaves the speed through the water uncertain by more than
  :data:`WATER_SPEED_RESOLUTION` (a sluggish boat near its straight-line speed).

Units: SI and radians inside; the dictionaries carry degrees in their key names.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.manoeuvres.detect import approach, approach_window
from usvid.manoeuvres.logic import Turning
from usvid.models.environment.wind import apparent_to_true
from usvid.models.registry import kind_of
from usvid.prep.filters import savgol_derivative
from usvid.prep.kinematics import body_to_earth
from usvid.sim.simulate import Environment, simulate

__all__ = ["RunConditions", "approach_current", "logged_wind", "run_conditions"]

#: Largest heading change [deg] over the approach window for a straight approach.
STEADY_HEADING_DEG = 10.0
#: Savitzky-Golay window [s] of the ground velocity for the wind conversion.
GROUND_VELOCITY_WINDOW_S = 2.0


@dataclass
class RunConditions:
    """The wind series (``t`` [s] from the execute, ``wind_speed`` [m/s], ``wind_dir`` [rad,
    from]; None when not logged) and the current (``current_speed`` [m/s], ``current_dir``
    [rad, towards]; None when not estimated) of one run, what each came from (``wind``,
    ``current``: JSON-ready) and the reasons of what is missing (``messages``)."""

    t: np.ndarray | None = None
    wind_speed: np.ndarray | None = None
    wind_dir: np.ndarray | None = None
    current_speed: float | None = None
    current_dir: float | None = None
    wind: dict[str, Any] | None = None
    current: dict[str, Any] | None = None
    messages: list[str] = field(default_factory=list)

    @property
    def known(self) -> bool:
        """A logged wind or an estimated current."""
        return self.wind_speed is not None or self.current_speed is not None

    def environment(self, psi0: float) -> Environment | None:
        """The :class:`usvid.sim.Environment` of a prediction that starts on heading 0 where
        the run's execute was on ``psi0`` [rad]: every direction turned by -psi0 (the metrics
        are relative to the heading at the execute). None when nothing is known."""
        if not self.known:
            return None
        kw: dict[str, Any] = {}
        if self.current_speed is not None:
            kw.update(current_speed=self.current_speed,
                      current_dir=float(self.current_dir) - psi0)  # type: ignore[arg-type]
        if self.wind_speed is not None:
            kw.update(t=self.t, wind_speed=self.wind_speed, wind_dir=self.wind_dir - psi0)
            if self.current_speed is not None:
                n = np.size(self.t)
                kw.update(current_speed=np.full(n, self.current_speed),
                          current_dir=np.full(n, kw["current_dir"]))
        return Environment(**kw)

    def to_dict(self) -> dict[str, Any]:
        return {"wind": self.wind, "current": self.current, "messages": list(self.messages)}


def _ground_velocity(trial: Any) -> tuple[np.ndarray, np.ndarray, str] | None:
    """(north, east) velocity over ground [m/s] on the trial's grid and where it came from."""
    t = trial.t
    if trial.has("x") and trial.has("y") and t.size > 8:
        dt = float(np.median(np.diff(t)))
        x, y = trial["x"], trial["y"]
        if np.all(np.isfinite(x)) and np.all(np.isfinite(y)):
            return (savgol_derivative(x, dt, GROUND_VELOCITY_WINDOW_S),
                    savgol_derivative(y, dt, GROUND_VELOCITY_WINDOW_S),
                    f"the derivative of the positions ({GROUND_VELOCITY_WINDOW_S:g}-s "
                    "Savitzky-Golay)")
    if trial.has("u") and trial.has("psi"):
        v = trial["v"] if trial.has("v") else np.zeros_like(trial["u"])
        vn, ve = body_to_earth(trial["u"], v, trial["psi"])
        return vn, ve, "the body velocities u, v rotated by the heading (taken as over ground)"
    return None


def logged_wind(trial: Any, t_execute: float) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                        dict[str, Any]] | str:
    """(t [s] from ``t_execute``, true wind speed [m/s], direction [rad, from], description) of
    the log from its execute on (module docstring), or the reason there is none."""
    t = trial.t
    sel = t >= t_execute
    if trial.has("wind_speed_true") and trial.has("wind_dir_true"):
        s, d = trial["wind_speed_true"], trial["wind_dir_true"]
        source = "logged true wind (wind_speed_true, wind_dir_true)"
    elif trial.has("wind_speed") and trial.has("wind_angle"):
        if not trial.has("psi"):
            return "the apparent wind needs the heading psi to be converted to the true wind"
        g = _ground_velocity(trial)
        if g is None:
            return ("the apparent wind needs the ground velocity (positions x, y or velocities "
                    "u, v) to be converted to the true wind")
        s, d = apparent_to_true(trial["wind_speed"], trial["wind_angle"], g[0], g[1],
                                trial["psi"])
        source = ("logged apparent wind (wind_speed, wind_angle) converted to the true wind "
                  f"with the ground velocity from {g[2]}")
    else:
        return "no wind logged (wind_speed_true/wind_dir_true or wind_speed/wind_angle)"
    ok = sel & np.isfinite(s) & np.isfinite(d)
    if ok.sum() < 1:
        return "no finite wind sample from the execute on"
    tt, s, d = t[ok] - t_execute, np.asarray(s[ok], float), np.asarray(d[ok], float)
    d = np.unwrap(d)  # (the series is interpolated: through north the short way)
    vn, ve = -np.mean(s * np.cos(d)), -np.mean(s * np.sin(d))  # the mean air velocity
    desc = {"source": source, "samples": int(ok.sum()),
            "speed_m_s": {"mean": float(np.mean(s)), "min": float(np.min(s)),
                          "max": float(np.max(s))},
            "mean_direction_from_deg": float(np.degrees(np.arctan2(-ve, -vn)) % 360.0),
            "t_s": [float(tt[0]), float(tt[-1])]}
    return tt, s, d, desc


def approach_current(trial: Any, t_execute: float, model: Any
                     ) -> tuple[float, float, dict[str, Any]] | str:
    """(speed [m/s], direction towards [rad], description) of the current over the approach
    before ``t_execute`` [s] (module docstring), or the reason it cannot be estimated."""
    if not (trial.has("x") and trial.has("y") and trial.has("psi")):
        return "no current estimated: the log has no positions x, y or heading psi"
    kind = kind_of(model.dynamics)
    if kind.constant_speed or kind.speed is None:
        return (f"no current estimated: a {kind.name} model gives no speed through the water "
                "(the log carries none)")
    sel = approach_window(trial.t, t_execute) & (trial.t <= t_execute)
    t, x, y, psi = trial.t[sel], trial["x"][sel], trial["y"][sel], trial["psi"][sel]
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(psi)
    t, x, y, psi = t[ok], x[ok], y[ok], psi[ok]
    if t.size < 4 or t[-1] - t[0] <= 0:
        return "no current estimated: too few positions before the execute"
    dur = float(t[-1] - t[0])
    turn = math.degrees(float(np.max(psi) - np.min(psi)))
    if turn > STEADY_HEADING_DEG:
        return (f"no current estimated: the approach is not steady (heading range {turn:.3g} "
                f"deg over {dur:.3g} s)")
    ap = approach(trial, t_execute)
    dyn = model.dynamics
    if ap.shaft_speed is not None and hasattr(dyn, "n") and math.isfinite(ap.shaft_speed) \
            and ap.shaft_speed > 0:
        dyn = dyn.replace(n=float(ap.shaft_speed))
    try:
        u_ss = float(np.asarray(kind.speed(dyn), dtype=float).ravel()[0])
    except Exception as exc:  # noqa: BLE001 - a model without a steady speed: say so
        return f"no current estimated: the model's straight-line speed: {exc}"
    if not (math.isfinite(u_ss) and u_ss > 0):
        return "no current estimated: the model has no straight-line speed through the water"
    # the acceleration over ground along the heading, with its standard error: a quadratic
    # fit of the positions (the difference of two half-window speeds carries their noise twice)
    tc = t - 0.5 * (t[0] + t[-1])
    basis = np.column_stack([np.ones_like(tc), tc, 0.5 * tc * tc])
    heading = math.atan2(float(np.mean(np.sin(psi))), float(np.mean(np.cos(psi))))
    along = x * math.cos(heading) + y * math.sin(heading)
    coef, rss, *_ = np.linalg.lstsq(basis, along, rcond=None)
    accel = float(coef[2])
    dof = max(t.size - 3, 1)
    var = float(rss[0]) / dof if np.size(rss) else 0.0
    sigma = max(math.sqrt(var * float(np.linalg.inv(basis.T @ basis)[2, 2])),
                ACCELERATION_FLOOR)
    got = water_speed(dataclasses.replace(model, dynamics=dyn), u_ss, accel, sigma)
    if isinstance(got, str):
        return got
    uw, uw_err = got
    if uw_err > WATER_SPEED_RESOLUTION:
        return (f"no current estimated: the speed through the water is not told by the "
                f"approach: {uw:.3g} +- {uw_err:.2g} m/s (the model's straight-line speed "
                f"{u_ss:.3g} m/s; the vessel accelerates at {accel:.2g} +- {sigma:.2g} m/s^2, "
                f"and near its straight-line speed the model's surge barely accelerates), more "
                f"than the {WATER_SPEED_RESOLUTION} m/s a current needs")
    gn, ge = (x[-1] - x[0]) / dur, (y[-1] - y[0]) / dur
    wn, we = uw * float(np.mean(np.cos(psi))), uw * float(np.mean(np.sin(psi)))
    cn, ce = gn - wn, ge - we
    speed = math.hypot(cn, ce)
    direction = math.atan2(ce, cn) % (2 * math.pi)
    desc = {"speed_m_s": speed, "direction_towards_deg": math.degrees(direction),
            "north_m_s": cn, "east_m_s": ce, "window_s": [float(t[0] - t_execute), 0.0],
            "ground_speed_m_s": math.hypot(gn, ge), "water_speed_m_s": uw,
            "acceleration_m_s2": accel, "acceleration_std_m_s2": sigma,
            "water_speed_uncertainty_m_s": uw_err, "straight_line_speed_m_s": u_ss,
            "method": "mean velocity over ground from the positions less the model's "
                      "speed through the water along the heading (the speed at which its "
                      "straight run accelerates as the vessel did), over the approach "
                      "before the execute",
            "assumed": ["no drift angle on the straight approach",
                        "the model's calm-water surge at the approach's shaft speed",
                        "a constant current over the approach"]}
    return speed, direction, desc


#: Smallest standard error [m/s^2] of the approach's acceleration over ground: 1 mm/s per
#: second, what a 5-s window resolves of a boat surging in gusts with positions to a few
#: centimetres (the fit's own standard error when larger).
ACCELERATION_FLOOR = 1e-3
#: Largest uncertainty [m/s] of the speed through the water (from the acceleration's standard
#: error, :func:`water_speed`) for a current to be estimated: 0.05 m/s, a tenth of a small
#: boat's speed. A sluggish boat (surge time constant ~100 s) cannot tell over 5 s whether it is
#: still accelerating: its current is refused rather than guessed.
WATER_SPEED_RESOLUTION = 0.05


def water_speed(model: Any, u_ss: float, accel: float, sigma: float
                ) -> tuple[float, float] | str:
    """(speed through the water [m/s], its uncertainty [m/s]): the speed at which ``model``'s
    straight run (rudder amidships, its shaft speed) accelerates at ``accel`` [m/s^2], the
    vessel's acceleration over ground along its heading (a constant current: the same through
    the water), whose standard error is ``sigma`` [m/s^2]; ``u_ss`` [m/s] the model's
    straight-line speed, the answer for a steady approach (``accel`` within ``sigma`` of 0).

    Read off the model's own run from 5 % of ``u_ss`` to its straight-line speed (the surge
    acceleration falls monotonically as the resistance grows towards the thrust), so it holds
    for any kind with a surge equation; the uncertainty is the spread of that curve over
    ``accel +- sigma`` (near the straight-line speed the curve is flat in acceleration: a
    sluggish boat's speed is poorly told by it). The reason (a string) when the vessel
    accelerates (within ``sigma``) as much as the model can at that shaft speed, or more."""
    length = float(getattr(model.vessel, "length", None) or 1.0)
    t_end = 200.0 * length / u_ss  # 200 ship lengths: past 99 % of the straight-line speed
    dt = min(0.1, 0.05 * length / u_ss)
    res = simulate(model, Turning(0.0), t_end=t_end, dt=dt, u0=0.05 * u_ss, channels=("u",))
    u = np.asarray(res.channels["u"][0], dtype=float)
    a = np.gradient(u, np.asarray(res.t, dtype=float))
    ok = np.isfinite(u) & np.isfinite(a)
    u, a = u[ok], a[ok]
    # within one standard error of the model's largest acceleration (from rest) the curve is
    # steep in u: the speed through the water is anything below the ground speed
    if u.size < 3 or accel + sigma > float(a.max()):
        return (f"no current estimated: the vessel accelerates at {accel:.3g} +- {sigma:.2g} "
                f"m/s^2 over the approach, more than the model can at its shaft speed "
                f"({float(a.max()) if a.size else float('nan'):.3g} m/s^2 from rest)")
    i = int(np.argmax(a))  # past the start's transient: a falls as u grows
    u, a = np.append(u[i:], u_ss), np.append(a[i:], 0.0)
    order = np.argsort(a, kind="stable")

    def at(acc: float) -> float:
        return u_ss if acc <= 0.0 else float(np.interp(acc, a[order], u[order]))

    lo, mid, hi = at(accel + sigma), at(accel), at(accel - sigma)
    return mid, 0.5 * (hi - lo)


def run_conditions(trial: Any, t_execute: float, model: Any) -> RunConditions:
    """The :class:`RunConditions` of the run whose manoeuvre starts at ``t_execute`` [s]."""
    out = RunConditions()
    w = logged_wind(trial, t_execute)
    if isinstance(w, str):
        out.messages.append(w)
    else:
        out.t, out.wind_speed, out.wind_dir, out.wind = w
    c = approach_current(trial, t_execute, model)
    if isinstance(c, str):
        out.messages.append(c)
    else:
        out.current_speed, out.current_dir, out.current = c
    return out
