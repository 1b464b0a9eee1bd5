r"""The current measured by a turning test, and the turning metrics corrected for it
(IMO MSC/Circ.1053, Explanatory Notes to the Standards for Ship Manoeuvrability, 3.4.2.5).

MSC/Circ.1053 3.4.2.5: "The turning circle test results may be used to measure the magnitude and
direction of current. The ship's track, heading and the elapsed time should be recorded until at
least a 720 deg change of heading has been completed. The data obtained after ship's heading
change 180 deg are used to estimate magnitude and direction of the current." Positions
:math:`(x_{1i}, y_{1i}, t_{1i})` and :math:`(x_{2i}, y_{2i}, t_{2i})` a heading rotation of 360
deg apart give a local current estimate, and the current is their mean:

.. math::

    v_{c,i} = \frac{(x_{2i} - x_{1i},\ y_{2i} - y_{1i})}{t_{2i} - t_{1i}}, \qquad
    \bar v_c = \frac1n \sum_i v_{c,i}.

Why it works: in a uniform, constant current a vessel whose hydrodynamics see the
water-relative velocity moves on its calm-water track plus :math:`v_c t`
(:mod:`usvid.models.environment.current`); once the turn is steady (after 180 deg), the
calm-water track repeats every 360 deg of heading, so the displacement between two such
positions is the current's drift over the time between them. A turn that is not steady, or a
wind that pushes the vessel differently on each heading, shows as ``spread``.

usvid takes every sample after the 180 deg instant whose heading 360 deg later is still in the
record (the heading crossing interpolated linearly between samples, positions too), so that a
turn of 540 deg is the least that gives an estimate (one circle after the 180 deg instant). The
corrected track is :math:`(x, y) - \bar v_c (t - t_e)` from the execute :math:`t_e`, and the
turning metrics of :func:`usvid.manoeuvres.metrics.turning_metrics` on it are the metrics
corrected for the current.

Directions: the current is given by the direction it flows TOWARDS [rad or deg, from north,
clockwise] (the Trial contract); speed [m/s].
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.manoeuvres.detect import as_1d, clean, crossing_time, steady_turn
from usvid.manoeuvres.metrics import TurningMetrics, turning_metrics

__all__ = ["CurrentEstimate", "imo_current", "current_corrected_track",
           "current_corrected_turning", "MIN_TURN_FOR_CURRENT"]

#: Least heading change [rad] after the execute that gives an estimate: 180 deg, then a circle.
MIN_TURN_FOR_CURRENT = 3.0 * math.pi


@dataclass
class CurrentEstimate:
    """The current estimated from a turning test (module docstring).

    ``speed_m_s`` [m/s] and ``dir_deg`` [deg, from north, clockwise, the direction it flows
    towards, in [0, 360)] of the mean vector ``v_north_m_s``, ``v_east_m_s`` [m/s];
    ``spread_m_s`` [m/s] the RMS distance of the local estimates from the mean (how much the
    phases of the turn disagree); ``speed_min_m_s``, ``speed_max_m_s`` the range of the local
    speeds; ``pairs`` the number of position pairs; ``heading_change_deg`` the heading change
    after the execute that the estimate used up to; ``method`` the source.
    """

    speed_m_s: float
    dir_deg: float
    v_north_m_s: float
    v_east_m_s: float
    spread_m_s: float
    speed_min_m_s: float
    speed_max_m_s: float
    pairs: int
    heading_change_deg: float
    method: str = "IMO MSC/Circ.1053 3.4.2.5"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def imo_current(t: Any, x: Any, y: Any, psi: Any, *, t_execute: float | None = None
                ) -> CurrentEstimate | None:
    """The current from a turning test's positions 360 deg of heading apart (module
    docstring); ``None`` when the heading changes by less than 540 deg after the execute.

    ``t`` [s] increasing, ``x``, ``y`` [m, north, east], ``psi`` [rad] (unwrapped here),
    ``t_execute`` [s] the rudder execute (default the first sample). The turn's side is that of
    :func:`usvid.manoeuvres.detect.steady_turn` (the one definition of the turn).
    """
    t = as_1d("t", t)
    n = len(t)
    tt, xx, yy, pp = clean(t, as_1d("x", x, n), as_1d("y", y, n), as_1d("psi", psi, n))
    if len(tt) < 3:
        raise UsvidError("current estimate: fewer than 3 samples with position and heading")
    if np.any(np.diff(tt) <= 0):
        raise UsvidError("current estimate: `t` must be strictly increasing")
    pp = np.unwrap(pp)
    t_e = float(tt[0]) if t_execute is None else float(t_execute)
    st = steady_turn(tt, pp, t_e)
    z = st.side * (pp - float(np.interp(t_e, tt, pp)))
    start = int(np.searchsorted(tt, t_e))
    z_end = float(np.max(z[start:])) if start < len(z) else -math.inf
    if z_end < MIN_TURN_FOR_CURRENT:
        return None
    t180 = crossing_time(tt, z, math.pi, start, True)
    # heading as a monotone function of time after the 180 deg instant (its running maximum:
    # a noisy heading that dips back does not make a second crossing)
    after = tt >= t180
    ta, za = tt[after], np.maximum.accumulate(z[after])
    xa, ya = xx[after], yy[after]
    usable = za + 2.0 * math.pi <= za[-1]
    if usable.sum() < 1:
        return None
    t1, x1, y1 = ta[usable], xa[usable], ya[usable]
    # first instant the heading reaches z1 + 360 deg (linear between samples); za is
    # non-decreasing, so searchsorted finds the bracketing samples
    target = za[usable] + 2.0 * math.pi
    j = np.clip(np.searchsorted(za, target, side="left"), 1, len(za) - 1)
    dz = za[j] - za[j - 1]
    w = np.where(dz > 0, (target - za[j - 1]) / np.where(dz > 0, dz, 1.0), 1.0)
    t2 = ta[j - 1] + w * (ta[j] - ta[j - 1])
    x2 = xa[j - 1] + w * (xa[j] - xa[j - 1])
    y2 = ya[j - 1] + w * (ya[j] - ya[j - 1])
    dt = t2 - t1
    ok = dt > 0
    if not ok.any():
        return None
    vn = (x2[ok] - x1[ok]) / dt[ok]
    ve = (y2[ok] - y1[ok]) / dt[ok]
    mn, me = float(np.mean(vn)), float(np.mean(ve))
    local = np.hypot(vn, ve)
    return CurrentEstimate(
        speed_m_s=math.hypot(mn, me),
        dir_deg=math.degrees(math.atan2(me, mn)) % 360.0,
        v_north_m_s=mn,
        v_east_m_s=me,
        spread_m_s=float(np.sqrt(np.mean((vn - mn) ** 2 + (ve - me) ** 2))),
        speed_min_m_s=float(local.min()),
        speed_max_m_s=float(local.max()),
        pairs=int(ok.sum()),
        heading_change_deg=math.degrees(z_end),
    )


def current_corrected_track(t: Any, x: Any, y: Any, current: CurrentEstimate,
                            t_execute: float) -> tuple[np.ndarray, np.ndarray]:
    """The track with the current's drift removed: ``(x - v_N (t - t_e), y - v_E (t - t_e))``
    [m] (``t`` [s], ``x``, ``y`` [m, north, east], ``t_execute`` [s])."""
    t = as_1d("t", t)
    n = len(t)
    x, y = as_1d("x", x, n), as_1d("y", y, n)
    return (x - current.v_north_m_s * (t - t_execute),
            y - current.v_east_m_s * (t - t_execute))


def current_corrected_turning(t: Any, x: Any, y: Any, psi: Any, *, r: Any | None = None,
                              t_execute: float | None = None
                              ) -> tuple[CurrentEstimate, TurningMetrics] | None:
    """The current of :func:`imo_current` and the turning metrics of the track corrected for
    it (:func:`turning_metrics` on :func:`current_corrected_track`, yaw rate ``r`` [rad/s] when
    measured); ``None`` for a turn of less than 540 deg. The speed over ground is not passed on:
    the corrected steady speed is the path speed of the corrected track (through the water)."""
    t = as_1d("t", t)
    t_e = float(t[np.isfinite(t)][0]) if t_execute is None else float(t_execute)
    est = imo_current(t, x, y, psi, t_execute=t_e)
    if est is None:
        return None
    xc, yc = current_corrected_track(t, x, y, est, t_e)
    return est, turning_metrics(t, xc, yc, psi, r=r, t_execute=t_e)
