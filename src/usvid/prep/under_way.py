"""Under way: whether a vessel made way through the water, the one definition every stage uses.

A vessel is *under way* over a stretch of a log when its median speed there is at least
:data:`MIN_SPEED`. Identification refuses a log that was not (:mod:`usvid.identify.checks`), a
turning circle needs it at its execute (:mod:`usvid.manoeuvres.detect`), and the audit judges
the rudder's sign only on the samples above it, on at least :data:`MIN_MOVING_S` of them
(:mod:`usvid.prep.channel_audit`): at the dock, at anchor or on the bench the heading follows
the wind, the lines or a hand, not the rudder.

The speed [m/s] is read from what the log measured, in this order (:func:`speed`): the speed
``U``, the speed over ground ``sog``, the body velocities ``hypot(u, v)`` (``|u|`` without
``v``); only when none is logged, the speed derived from the positions (GNSS noise at rest
makes a derived speed of a moored boat look like motion, so a logged speed wins).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvid.prep.filters import savgol_derivative
from usvid.prep.prepare import PreparedTrial, as_prepared
from usvid.trial import Trial

__all__ = ["MIN_MOVING_FRACTION", "MIN_MOVING_S", "MIN_SPEED", "UnderWay", "moving", "speed",
           "under_way"]

#: Lowest median speed [m/s] of a vessel under way (0.2 m/s = 0.4 kn): a moored or drifting
#: boat's speed over ground stays below it (GNSS noise at rest: 0.02-0.1 m/s); a model in a basin
#: or pond runs faster (the Esso Osaka 3 m model approaches its manoeuvres at 0.22-0.41 m/s).
MIN_SPEED = 0.2
#: Least time [s] above :data:`MIN_SPEED` for a verdict that needs the vessel moving (the
#: audit's rudder sign: a few manoeuvres' worth of samples).
MIN_MOVING_S = 20.0
#: Least share of a log's time above :data:`MIN_SPEED` for a log whose median speed is below
#: it to count as under way for identification (:attr:`UnderWay.made_way`): a run that starts
#: from rest and loses speed in its turns (the Esso Osaka 3 m model's turning tests at 10 rps:
#: median 0.16-0.18 m/s, above 0.2 m/s for 27-32 % of the run, 100-120 s); a moored boat's GNSS
#: noise (0.02-0.1 m/s) is above it for a fraction of a per cent of the time.
MIN_MOVING_FRACTION = 0.25
#: Savitzky-Golay window [s] of the speed derived from positions when no state is derived.
POSITION_WINDOW_S = 2.0


def speed(trial: Trial) -> tuple[np.ndarray | None, str]:
    """The speed [m/s] per sample of ``trial`` (prepared first when it is not: the grid of the
    one road) and the channel it is read from (module docstring); ``(None, "")`` when the log
    tells no speed. The source names a derived speed "U from the positions"."""
    tr = as_prepared(trial, derivatives=False)
    derived = set(tr.derived)
    for ch in ("U", "sog"):
        if tr.has(ch) and ch not in derived:
            return np.abs(tr[ch]), ch
    if tr.has("u") and "u" not in derived:
        if tr.has("v") and "v" not in derived:
            return np.hypot(tr["u"], tr["v"]), "hypot(u, v)"
        return np.abs(tr["u"]), "u"
    if tr.has("U"):
        return np.abs(tr["U"]), "U from the positions"
    if tr.has("x") and tr.has("y") and len(tr) > 3:
        dt = 1.0 / tr.sample_rate if tr.sample_rate else float(np.median(np.diff(tr.t)))
        return (np.hypot(savgol_derivative(tr["x"], dt, POSITION_WINDOW_S),
                         savgol_derivative(tr["y"], dt, POSITION_WINDOW_S)),
                "U from the positions")
    return None, ""


@dataclass(frozen=True)
class UnderWay:
    """The verdict of :func:`under_way`: ``median_speed`` [m/s] over the stretch and the channel
    ``source`` it is read from (None and "" when the log tells no speed there), ``moving_s`` [s]
    the time above :data:`MIN_SPEED`."""

    median_speed: float | None
    source: str
    moving_s: float
    duration_s: float = 0.0

    @property
    def known(self) -> bool:
        """Whether the log tells the speed over the stretch."""
        return self.median_speed is not None

    @property
    def is_under_way(self) -> bool | None:
        """True when the median speed is at least :data:`MIN_SPEED`; None when unknown."""
        return None if self.median_speed is None else self.median_speed >= MIN_SPEED

    @property
    def made_way(self) -> bool | None:
        """Under way for identification: :attr:`is_under_way`, or above :data:`MIN_SPEED` for at
        least :data:`MIN_MOVING_S` and :data:`MIN_MOVING_FRACTION` of the stretch (a run from
        rest with slow turns); None when unknown."""
        if self.median_speed is None:
            return None
        return bool(self.is_under_way or (
            self.moving_s >= MIN_MOVING_S
            and self.moving_s >= MIN_MOVING_FRACTION * self.duration_s))

    def reason(self) -> str:
        """Why it is not under way, or why that cannot be told, in words (units in the text)."""
        if self.median_speed is None:
            return ("no speed (U, sog, u) and no positions: usvid cannot tell that the vessel "
                    "was under way")
        text = (f"its median speed is {self.median_speed:.3g} m/s ({self.source}), "
                f"{'at least' if self.is_under_way else 'below'} {MIN_SPEED:g} m/s")
        if not self.is_under_way and self.duration_s > 0:
            text += (f", above it for {self.moving_s:.3g} s of {self.duration_s:.3g} s (under "
                     f"way needs {MIN_MOVING_S:g} s and {100 * MIN_MOVING_FRACTION:g} %)")
        return text


def under_way(trial: Trial, where: np.ndarray | None = None) -> UnderWay:
    """Whether ``trial`` was under way (module docstring): over the samples ``where`` (a boolean
    mask on the prepared trial's grid; default all)."""
    tr = as_prepared(trial, derivatives=False)
    sp, src = speed(tr)
    if sp is None:
        return UnderWay(None, "", 0.0)
    sel = np.isfinite(sp) if where is None else (np.isfinite(sp) & where)
    if not sel.any():
        return UnderWay(None, src, 0.0)
    dt = 1.0 / tr.sample_rate if tr.sample_rate else float(np.median(np.diff(tr.t)))
    return UnderWay(float(np.median(sp[sel])), src, float(np.sum(sp[sel] >= MIN_SPEED) * dt),
                    float(np.sum(sel) * dt))


def moving(trial: PreparedTrial) -> np.ndarray | None:
    """The samples where the vessel makes way (speed at least :data:`MIN_SPEED`; a sample
    without a speed counts as not moving); None when the log tells no speed."""
    sp, _ = speed(trial)
    if sp is None:
        return None
    return np.nan_to_num(sp) >= MIN_SPEED
