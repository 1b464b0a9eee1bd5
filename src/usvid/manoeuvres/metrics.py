"""Standard manoeuvre metrics (zig-zag, turning circle) from time histories.

Pure array functions: the simulator (:mod:`usvid.sim`) and the measured-trial metrics use the same
definitions, so a simulated and a measured manoeuvre are compared on equal terms. Inputs are 1-D
arrays in SI units and radians (heading ``psi`` NED, clockwise positive; ``delta`` positive makes
the yaw rate positive, i.e. turns to starboard). The execute, side, amplitude, reversals and steady
turn are those of :mod:`usvid.manoeuvres.detect` (one definition each).

Definitions (IMO MSC.137(76) with its explanatory notes MSC/Circ.1053, and ITTC Recommended
Procedure 7.5-04-02-01 "Full scale manoeuvring trials"):

Zig-zag ``delta_amp / psi_switch``
    *first execute* ``t_e``: the rudder is put over (first rudder order; given, or
    :func:`~usvid.manoeuvres.detect.find_execute` on ``delta``). ``psi0`` is the heading at
    ``t_e``. The *k-th reversal* (k = 1, 2, ...) happens when the heading deviation reaches
    ``+psi_switch, -psi_switch, +psi_switch, ...`` (sign of the first turn first;
    :func:`~usvid.manoeuvres.detect.zigzag_crossings`). Crossing instants are interpolated
    linearly between samples.

    * ``initial_turning_time_s``: first execute to the first reversal (heading change reaches
      ``psi_switch``).
    * ``overshoot_deg[k]``: after reversal k, the largest excursion of the heading deviation beyond
      the switching heading, ``|psi_ext - psi0| - psi_switch`` [deg]; all of them, first first.
    * ``time_to_check_yaw_s``: reversal to the following heading extremum (yaw rate zero) for the
      first reversal; ``time_to_check_yaw_all_s`` all of them.
    * ``period_s``: the ITTC period is the time of one full cycle; usvid takes the time between two
      successive reversals *in the same direction* (reversal k to k + 2), averaged over all complete
      cycles in the record (``period_all_s`` lists them). With a single cycle only, NaN.

    Heading extrema lie between samples: a parabola through the three samples around the discrete
    extremum gives the peak value and time.

Turning circle
    From the rudder execute (position ``(x0, y0)``, heading ``psi0``):

    * ``advance_m``: distance travelled along the original course when the heading has changed by
      90 deg; ``transfer_m``: distance perpendicular to it, towards the turning side, at 90 deg;
    * ``tactical_diameter_m``: distance perpendicular to the original course at 180 deg change.

    The 90/180 deg instants are interpolated between samples (linear in heading), positions too.
    Magnitudes are positive; ``side`` says ``"starboard"`` or ``"port"``.

    * steady turn (:func:`~usvid.manoeuvres.detect.steady_turn`): the last 360 deg of heading
      change (or, when the record turns less than 360 deg past the 180 deg instant, the part
      after the 180 deg instant). ``steady_diameter_m`` is the diameter of a least-squares circle
      fitted to the positions in that window (algebraic Kasa fit refined by Gauss-Newton on the
      geometric distance); when that window covers less than 90 deg of arc it is ``2 U / |r|``
      from the steady speed and yaw rate. ``steady_yaw_rate_rad_s`` is the magnitude of the mean
      ``r`` (or of the slope of a line fitted to ``psi(t)``) and ``steady_speed_m_s`` the mean
      ``U`` (or the path speed from the positions) over the window.
"""

from __future__ import annotations

import html
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.manoeuvres.detect import (
    as_1d,
    clean,
    crossing_time,
    find_execute,
    rudder_amplitude,
    steady_turn,
    zigzag_crossings,
)

__all__ = [
    "ZigZagMetrics",
    "TurningMetrics",
    "zigzag_metrics",
    "turning_metrics",
    "parabolic_peak",
    "fit_circle",
]


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------
def parabolic_peak(t: np.ndarray, y: np.ndarray, i: int) -> tuple[float, float]:
    """Time and value of the extremum of the parabola through samples ``i-1, i, i+1``.

    Works on non-uniform times. At the ends of the record (or on a flat triple) the sample itself
    is returned. Units are those of ``t`` and ``y``.
    """
    if i <= 0 or i >= len(y) - 1:
        return float(t[i]), float(y[i])
    t0, t1, t2 = t[i - 1], t[i], t[i + 1]
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    # y = a (t - t1)^2 + b (t - t1) + y1 through the three points
    h0, h2 = t0 - t1, t2 - t1
    den = h0 * h2 * (h0 - h2)
    if den == 0:
        return float(t1), float(y1)
    a = (h2 * (y0 - y1) - h0 * (y2 - y1)) / den
    b = (h0 * h0 * (y2 - y1) - h2 * h2 * (y0 - y1)) / den
    if a == 0:
        return float(t1), float(y1)
    dt = -b / (2 * a)
    # the vertex belongs to this sample's neighbourhood; clip against a degenerate fit
    dt = float(np.clip(dt, h0, h2))
    return float(t1 + dt), float(a * dt * dt + b * dt + y1)


def _html_table(title: str, d: dict[str, Any]) -> str:
    def cell(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.4g}"
        if isinstance(v, list):
            return ", ".join(cell(x) for x in v[:6]) + (" ..." if len(v) > 6 else "")
        return html.escape(str(v))

    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{cell(v)}</td></tr>" for k, v in d.items())
    return f"<table><caption>{html.escape(title)}</caption>{rows}</table>"


#: Metrics present only where the run has what they measure (None: left out of ``to_dict``):
#: the roll metrics, for runs with a roll angle ``phi``.
_WHEN_MEASURED = ("max_heel_deg", "steady_heel_deg")


class _Metrics:
    """``to_dict()``: the CLI keys first (the leading fields), then the extras; NaN stays NaN
    (the JSON writer maps it to null); the roll metrics only for runs with a roll angle.
    ``_repr_html_``: a two-column table (Jupyter)."""

    def _repr_html_(self) -> str:
        return _html_table(type(self).__name__, self.to_dict())

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)  # type: ignore[call-overload]
        for k in _WHEN_MEASURED:
            if k in d and d[k] is None:
                del d[k]
        return d


def max_heel(t: np.ndarray, phi: Any, t_execute: float) -> float:
    """Largest heel [deg]: max |phi| from the execute on (phi [rad], positive heel to starboard;
    NaN samples left out; NaN when none is left)."""
    ph = as_1d("phi", phi, len(t))
    ok = np.isfinite(ph) & (t >= t_execute)
    return math.degrees(float(np.max(np.abs(ph[ok])))) if ok.any() else math.nan


# --------------------------------------------------------------------------------------------
# zig-zag
# --------------------------------------------------------------------------------------------
@dataclass
class ZigZagMetrics(_Metrics):
    """Zig-zag metrics (definitions in the module docstring). Times [s], angles [deg].

    NaN (``None`` in JSON) marks a quantity the record is too short to show.
    """

    overshoot_deg: list[float]
    period_s: float
    initial_turning_time_s: float
    time_to_check_yaw_s: float
    time_to_check_yaw_all_s: list[float] = field(default_factory=list)
    period_all_s: list[float] = field(default_factory=list)
    reversal_times_s: list[float] = field(default_factory=list)
    execute_time_s: float = 0.0
    first_side: str = "starboard"
    delta_amp_deg: float = math.nan
    psi_switch_deg: float = math.nan
    initial_turning_distance_m: float = math.nan
    max_heel_deg: float | None = None


def zigzag_metrics(
    t: Any,
    psi: Any,
    delta: Any | None = None,
    *,
    delta_amp: float | None = None,
    psi_switch: float | None = None,
    t_execute: float | None = None,
    first: int | None = None,
    x: Any | None = None,
    y: Any | None = None,
    psi_ref: float | None = None,
    phi: Any | None = None,
) -> ZigZagMetrics:
    """Zig-zag metrics of one run (IMO MSC.137(76) / ITTC 7.5-04-02-01; see module docstring).

    Parameters
    ----------
    t : array (N,)
        Time [s], increasing.
    psi : array (N,)
        Heading [rad] (unwrapped here).
    delta : array (N,), optional
        Rudder angle [rad]; used to find the first execute and its side, and the amplitude.
    delta_amp : float, optional
        Rudder amplitude [rad] (reported only; default from ``delta``).
    psi_switch : float, optional
        Switching heading deviation [rad]; default ``delta_amp`` (the usual n/n zig-zag).
    t_execute : float, optional
        Time of the first execute [s]; default from ``delta`` or ``t[0]``.
    first : {+1, -1}, optional
        Side of the first rudder (+1 starboard); default from ``delta`` or the heading.
    x, y : array (N,), optional
        North/east positions [m]; give ``initial_turning_distance_m`` (track length to the first
        reversal, for the IMO initial-turning criterion).
    psi_ref : float, optional
        Reference heading [rad] of the deviation (default: the heading at the execute, as
        :class:`usvid.manoeuvres.logic.ZigZag` without ``psi_ref``).
    phi : array (N,), optional
        Roll angle [rad, positive heel to starboard]: gives ``max_heel_deg`` (:func:`max_heel`).
    """
    t = as_1d("t", t)
    n = len(t)
    psi = as_1d("psi", psi, n)
    d = None if delta is None else as_1d("delta", delta, n)
    if n < 3:
        raise UsvidError("metrics: a zig-zag needs at least 3 samples")
    if np.any(np.diff(t[np.isfinite(t)]) <= 0):
        raise UsvidError("metrics: `t` must be strictly increasing")

    side = first
    if d is not None and np.isfinite(d).sum() >= 2 and (t_execute is None or side is None
                                                         or delta_amp is None):
        te_d, side_d = find_execute(t, d)  # (not needed when all three are given)
        if t_execute is None:
            t_execute = te_d
        if side is None:
            side = int(side_d)
        if delta_amp is None:
            delta_amp = rudder_amplitude(t, d, t_execute)
    if psi_switch is None:
        if delta_amp is None:
            raise UsvidError("metrics: give `psi_switch` (or `delta`/`delta_amp`) for a zig-zag")
        psi_switch = float(delta_amp)
    if not psi_switch > 0:
        raise UsvidError(f"metrics: `psi_switch` must be > 0 (got {psi_switch!r})")

    tt, pp = clean(t, psi)
    if len(tt) < 3:
        raise UsvidError(f"metrics: a zig-zag needs at least 3 samples with a heading "
                         f"(got {len(tt)} of {n})")
    pp = np.unwrap(pp)
    if t_execute is None:
        t_execute = float(tt[0])
    psi0 = float(np.interp(t_execute, tt, pp)) if psi_ref is None else float(psi_ref)
    if psi_ref is not None:  # the reference on the branch of the unwrapped heading at execute
        psi0 += 2 * math.pi * round((float(np.interp(t_execute, tt, pp)) - psi0) / (2 * math.pi))
    if side is None:
        dev = pp - psi0
        k = int(np.argmax(np.abs(dev) >= 0.5 * psi_switch)) if np.any(
            np.abs(dev) >= 0.5 * psi_switch) else int(np.argmax(np.abs(dev)))
        side = 1 if dev[k] >= 0 else -1
    side = 1 if side >= 0 else -1
    z = side * (pp - psi0)

    # reversals: alternate crossings of +psi_switch (up) and -psi_switch (down), after t_execute
    rev, rev_idx = zigzag_crossings(tt, z, psi_switch, int(np.searchsorted(tt, t_execute)))

    overshoots: list[float] = []
    checks: list[float] = []
    for k, (tc, j) in enumerate(zip(rev, rev_idx, strict=True)):
        stop = rev_idx[k + 1] if k + 1 < len(rev) else len(tt)
        if stop - j < 1:
            break
        w = z[j:stop] if k % 2 == 0 else -z[j:stop]
        i = int(np.argmax(w))
        if i == len(w) - 1 and k + 1 >= len(rev):
            break  # still turning at the end of the record: no extremum yet
        tpk, vpk = parabolic_peak(tt, z if k % 2 == 0 else -z, j + i)
        overshoots.append(math.degrees(vpk - psi_switch))
        checks.append(tpk - tc)

    periods = [rev[k + 2] - rev[k] for k in range(len(rev) - 2)]
    dist = math.nan
    if x is not None and y is not None and rev:
        xx = as_1d("x", x, n)
        yy = as_1d("y", y, n)
        tx, xx, yy = clean(t, xx, yy)
        if len(tx) >= 2:
            s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xx), np.diff(yy)))])
            dist = float(np.interp(rev[0], tx, s) - np.interp(t_execute, tx, s))
    return ZigZagMetrics(
        overshoot_deg=overshoots,
        period_s=float(np.mean(periods)) if periods else math.nan,
        initial_turning_time_s=(rev[0] - t_execute) if rev else math.nan,
        time_to_check_yaw_s=checks[0] if checks else math.nan,
        time_to_check_yaw_all_s=checks,
        period_all_s=periods,
        reversal_times_s=rev,
        execute_time_s=float(t_execute),
        first_side="starboard" if side > 0 else "port",
        delta_amp_deg=math.degrees(delta_amp) if delta_amp is not None else math.nan,
        psi_switch_deg=math.degrees(psi_switch),
        initial_turning_distance_m=dist,
        max_heel_deg=None if phi is None else max_heel(t, phi, float(t_execute)),
    )


# --------------------------------------------------------------------------------------------
# turning circle
# --------------------------------------------------------------------------------------------
@dataclass
class TurningMetrics(_Metrics):
    """Turning-circle metrics (definitions in the module docstring). Lengths [m], positive."""

    advance_m: float
    transfer_m: float
    tactical_diameter_m: float
    steady_diameter_m: float
    steady_yaw_rate_rad_s: float
    steady_speed_m_s: float
    side: str = "starboard"
    execute_time_s: float = 0.0
    time_to_90_s: float = math.nan
    time_to_180_s: float = math.nan
    steady_window_deg: float = math.nan
    steady_diameter_method: str = "circle_fit"
    max_heel_deg: float | None = None
    steady_heel_deg: float | None = None


def fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle through points: centre ``(xc, yc)`` and radius [m].

    Algebraic (Kasa) fit ``x^2 + y^2 + a x + b y + c = 0`` solved by linear least squares, then a
    few Gauss-Newton steps on the geometric distances ``|p - c| - R``. Points with a NaN
    coordinate are left out; fewer than 3 finite points raise :class:`UsvidError`.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3:
        raise UsvidError(f"metrics: a circle fit needs 3 finite points (got {int(ok.sum())})")
    x, y = x[ok], y[ok]
    A = np.column_stack([x, y, np.ones_like(x)])
    rhs = -(x * x + y * y)
    (a, b, c), *_ = np.linalg.lstsq(A, rhs, rcond=None)
    xc, yc = -a / 2, -b / 2
    R = math.sqrt(max(xc * xc + yc * yc - c, 0.0))
    for _ in range(10):
        dx, dy = x - xc, y - yc
        rho = np.hypot(dx, dy)
        rho = np.where(rho == 0, 1e-12, rho)
        res = rho - R
        J = np.column_stack([-dx / rho, -dy / rho, -np.ones_like(rho)])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        xc, yc, R = xc + step[0], yc + step[1], R + step[2]
        if np.max(np.abs(step)) < 1e-10 * max(R, 1.0):
            break
    return float(xc), float(yc), float(abs(R))


def turning_metrics(
    t: Any,
    x: Any,
    y: Any,
    psi: Any,
    *,
    U: Any | None = None,
    r: Any | None = None,
    delta: Any | None = None,
    t_execute: float | None = None,
    phi: Any | None = None,
) -> TurningMetrics:
    """Turning-circle metrics of one run (IMO MSC.137(76) definitions; see module docstring).

    Parameters
    ----------
    t : array (N,)
        Time [s], increasing.
    x, y : array (N,)
        North and east position [m].
    psi : array (N,)
        Heading [rad] (unwrapped here).
    U : array (N,), optional
        Speed over ground [m/s]; default from the positions.
    r : array (N,), optional
        Yaw rate [rad/s]; default the slope of ``psi``.
    delta : array (N,), optional
        Rudder angle [rad]; used to find the execute.
    t_execute : float, optional
        Rudder execute time [s]; default from ``delta``, else ``t[0]``.
    phi : array (N,), optional
        Roll angle [rad, positive heel to starboard]: gives ``max_heel_deg`` (:func:`max_heel`)
        and ``steady_heel_deg``, the mean roll angle over the steady turn [deg, signed].
    """
    t = as_1d("t", t)
    n = len(t)
    x = as_1d("x", x, n)
    y = as_1d("y", y, n)
    psi = as_1d("psi", psi, n)
    if n < 3:
        raise UsvidError("metrics: a turning circle needs at least 3 samples")
    if t_execute is None and delta is not None:
        t_execute, _ = find_execute(t, as_1d("delta", delta, n))
    tt, xx, yy, pp = clean(t, x, y, psi)
    if len(tt) < 3:
        raise UsvidError("metrics: fewer than 3 samples with position and heading")
    if np.any(np.diff(tt) <= 0):
        raise UsvidError("metrics: `t` must be strictly increasing")
    pp = np.unwrap(pp)
    if t_execute is None:
        t_execute = float(tt[0])
    psi0 = float(np.interp(t_execute, tt, pp))
    x0 = float(np.interp(t_execute, tt, xx))
    y0 = float(np.interp(t_execute, tt, yy))
    st = steady_turn(t, psi, t_execute, r=r, U=U, x=x, y=y)
    side = float(st.side)
    z = side * (pp - psi0)
    start = int(np.searchsorted(tt, t_execute))
    # along the original course and towards the turning side
    ex, ey = math.cos(psi0), math.sin(psi0)
    nx, ny = -side * ey, side * ex  # starboard of north is east: rotate +90 deg for side = +1
    along = (xx - x0) * ex + (yy - y0) * ey
    across = (xx - x0) * nx + (yy - y0) * ny

    t90 = crossing_time(tt, z, math.pi / 2, start, True)
    t180 = crossing_time(tt, z, math.pi, start, True)
    advance = float(np.interp(t90, tt, along)) if not math.isnan(t90) else math.nan
    transfer = float(np.interp(t90, tt, across)) if not math.isnan(t90) else math.nan
    tactical = float(np.interp(t180, tt, across)) if not math.isnan(t180) else math.nan

    w = (tt >= st.t_start) & (tt <= st.t_end)
    yaw, speed = abs(st.yaw_rate), st.speed
    method = "circle_fit"
    if st.arc >= math.pi / 2 and w.sum() >= 5:
        _, _, R = fit_circle(xx[w], yy[w])
        diam = 2 * R
    else:
        method = "2U/r"
        diam = 2 * speed / yaw if yaw and yaw > 0 else math.nan
    heel = steady = None
    if phi is not None:
        heel = max_heel(t, phi, float(t_execute))
        ph = as_1d("phi", phi, n)
        ws = (t >= st.t_start) & (t <= st.t_end) & np.isfinite(ph)
        steady = math.degrees(float(np.mean(ph[ws]))) if ws.any() else math.nan
    return TurningMetrics(
        advance_m=advance,
        transfer_m=transfer,
        tactical_diameter_m=tactical,
        steady_diameter_m=float(diam),
        steady_yaw_rate_rad_s=yaw,
        steady_speed_m_s=speed,
        side="starboard" if side > 0 else "port",
        execute_time_s=float(t_execute),
        time_to_90_s=t90 - t_execute if not math.isnan(t90) else math.nan,
        time_to_180_s=t180 - t_execute if not math.isnan(t180) else math.nan,
        steady_window_deg=math.degrees(st.arc),
        steady_diameter_method=method,
        max_heel_deg=heel,
        steady_heel_deg=steady,
    )
