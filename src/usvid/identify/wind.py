"""The logged wind in identification: its loads along the measured track, its model and scale.

Where the training trials log the wind (the true wind ``wind_speed_true``, ``wind_dir_true``;
or the apparent wind ``wind_speed``, ``wind_angle`` with the heading and the body velocities,
turned into the true wind by the wind triangle,
:func:`usvid.models.environment.wind.apparent_to_true`), identification fits the hull through
it instead of taking the wind's forces for hull forces:

* the series carry the air's velocity over ground ``wind_x``, ``wind_y`` [m/s, north, east]
  (:func:`air_velocity`; linear between samples, like the simulator's wind series, so that a
  direction through north is not turned the long way);
* the least-squares regression subtracts the wind loads computed along the measured track
  (:func:`track_wind_loads`) from the measured forces before regressing;
* the output error and every replay simulate the windows in the logged wind, the loads computed
  inside the integration step (:class:`usvid.sim.Environment`'s wind).

The loads are those of the apparent wind less those of the still air the vessel moves through
(ISO 15016:2015, ITTC 7.5-04-01-01.1: the identified calm-water terms hold the still-air
load), from the vessel's wind-load model (:func:`usvid.models.environment.wind_load_model`:
Fujiwara et al. 1998 with the windage particulars, Blendermann 1994 otherwise) times one
``wind_scale`` [-]. Units: SI, radians.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.environment import WindLoadModel, wind_load_model, wind_loads
from usvid.models.environment.wind import apparent_to_true, true_to_apparent
from usvid.models.registry import get as get_kind
from usvid.models.registry import names as kind_names
from usvid.trial import Vessel

__all__ = ["WindFit", "air_velocity", "track_wind_loads", "wind_fit",
           "wind_kinds"]


def wind_kinds() -> tuple[str, ...]:
    """The kinds whose fit takes the logged wind: a regression that takes known loads
    (``Regression.external``, the series :data:`usvid.models.kind.EXTERNAL`) and a force
    balance the integration core adds them to (every kind with surge and sway)."""
    return tuple(k for k in kind_names() if (reg := get_kind(k).regression) is not None
                 and reg.external is not None)


def __getattr__(name: str) -> Any:
    """``WIND_KINDS``: :func:`wind_kinds` (the registry's kinds are imported on first use)."""
    if name == "WIND_KINDS":
        return wind_kinds()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def air_velocity(trial: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The air's velocity over ground ``(north, east)`` [m/s] of the logged wind on the times
    ``t`` [s] (a wind from ``dir_true`` moves the air towards ``dir_true + pi``), or None when
    the trial logs no wind. The true wind when logged; else the apparent wind with the heading
    and the body velocities u, v (the ground velocity without a current)."""
    def ch(name: str) -> np.ndarray | None:
        if not trial.has(name):
            return None
        x = np.asarray(trial[name], dtype=float)
        ok = np.isfinite(x)
        if ok.sum() < 2:
            return None
        tt = np.asarray(trial.t, dtype=float)
        return np.interp(t, tt[ok], x[ok])

    ws, wd = ch("wind_speed_true"), ch("wind_dir_true")
    if ws is None or wd is None:
        va, ga, psi, u, v = (ch(n) for n in ("wind_speed", "wind_angle", "psi", "u", "v"))
        if va is None or ga is None or psi is None or u is None:
            return None
        v = np.zeros_like(u) if v is None else v
        c, s = np.cos(psi), np.sin(psi)
        ws, wd = apparent_to_true(va, ga, u * c - v * s, u * s + v * c, psi)
    # a direction unwrapped before interpolation would not matter: the components interpolate
    return -ws * np.cos(wd), -ws * np.sin(wd)


def track_wind_loads(model: WindLoadModel, wind_x: np.ndarray, wind_y: np.ndarray,
                     u: np.ndarray, v: np.ndarray, psi: np.ndarray,
                     wind_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wind loads (X, Y [N], N [N m], body axes) along a measured track: the apparent wind of
    the air velocity ``wind_x``, ``wind_y`` [m/s, north, east] seen from the ground velocity of
    the body velocities ``u``, ``v`` [m/s] at heading ``psi`` [rad], less the still air's load
    at the same ground velocity (module docstring; the same loads as the simulator's
    :func:`usvid.sim.lane._envload`), times ``wind_scale``."""
    c, s = np.cos(psi), np.sin(psi)
    vn, ve = u * c - v * s, u * s + v * c
    ws = np.hypot(wind_x, wind_y)
    wd = np.arctan2(-wind_y, -wind_x)
    p = model.packed(wind_scale)
    va, ga = true_to_apparent(ws, wd, vn, ve, psi)
    a = wind_loads(p, va, ga)
    v0, g0 = true_to_apparent(0.0, 0.0, vn, ve, psi)
    b = wind_loads(p, v0, g0)
    return a.X - b.X, a.Y - b.Y, a.N - b.N


@dataclass
class WindFit:
    """How identification took the logged wind: the wind-load ``model`` (None: no wind in the
    fit), why (``reason``), ``wind_scale`` [-] with its 95 % interval ``ci95`` and standard
    error (0 and the value itself when held), ``held`` with why, the trials that logged it."""

    model: WindLoadModel | None
    reason: str
    wind_scale: float = 1.0
    std_error: float = 0.0
    ci95: list[float] = field(default_factory=lambda: [1.0, 1.0])
    held: str = ""
    trials: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """The model file's ``identification.wind`` entry (JSON-ready)."""
        out: dict[str, Any] = {"model": self.model.name if self.model else None,
                               "reason": self.reason, "wind_scale": self.wind_scale,
                               "std_error": self.std_error, "ci95": list(self.ci95),
                               "held": self.held or None, "trials": list(self.trials)}
        if self.model is not None:
            out["model_reason"] = self.model.reason
        return out


def wind_fit(series: Sequence[Mapping[str, np.ndarray]], names: Sequence[str],
             vessel: Vessel | None, units: str | None = None) -> WindFit:
    """The wind of the fit: the vessel's wind-load model when some trial logs the wind (series
    with ``wind_x``) and the vessel has the windage particulars it needs; else no wind, with
    the reason (a logged wind without windage particulars is said, never ignored silently).
    ``units``: why the kind's forces are not in newtons (``Regression.external``): no wind
    either, saying so."""
    logged = [n for s, n in zip(series, names, strict=True) if "wind_x" in s]
    if not logged:
        return WindFit(None, "no trial logs the wind: fitted as calm water")
    try:
        if vessel is None:
            raise UsvidError("no vessel particulars")
        if units:
            raise UsvidError(units)
        wm = wind_load_model(vessel, wind_scale=1.0)
    except UsvidError as exc:
        return WindFit(None, f"the wind is logged in {len(logged)} trial(s) but its loads "
                             f"cannot be modelled ({exc}): fitted as calm water, the wind's "
                             "forces taken for hull forces", trials=logged)
    mean = float(np.mean(np.concatenate([np.hypot(s["wind_x"], s["wind_y"]) for s in series
                                         if "wind_x" in s])))
    return WindFit(wm, f"wind logged in {len(logged)} of {len(series)} trial(s) (mean true "
                       f"wind {mean:.3g} m/s): loads of {wm.name} subtracted in the regression "
                       "and simulated in the output error", trials=logged)


def interval(value: float, se: float, q: float) -> list[float]:
    """The 95 % interval ``value +- q se``."""
    return [value - q * se, value + q * se] if math.isfinite(se) else [-math.inf, math.inf]
