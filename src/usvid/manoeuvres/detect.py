"""Manoeuvre detection: the one definition in usvid of every manoeuvre quantity read from a
record, and the standard manoeuvres (zig-zags, turning circles) found inside a log.

Definitions (used by the metrics of measured and simulated manoeuvres, ``usvid metrics``,
identification, validation and the report). Time [s], angles [rad], rates [rad/s]; a command
other than a rudder angle (a thruster differential) in its own unit. IMO MSC.137(76) and ITTC
7.5-04-02-01 measure a manoeuvre from the *execute*, the instant the rudder order is given: a
log's manoeuvres are read from the rudder order when it is logged, else from the rudder angle
(:func:`turning_command`); a simulation's execute is its logic's start. Each quantity is
defined once, in the docstring of its function:

* **rudder execute and side** (from ``delta_0``, the rudder over the :data:`APPROACH_S` before
  the execute): :func:`find_execute`;
* **approach** (speed, shaft speed and rudder offset over the :data:`APPROACH_S` before the
  execute): :func:`approach`, carried by every segment;
* **plateau level and rudder amplitude**: :func:`plateau_level`, :func:`rudder_amplitude`;
* **rudder rate**: :func:`rudder_rate`;
* **switching angle**: the median deviation of the heading (smoothed over 2 s) from the heading
  at the execute where the rudder (order) leaves its plateaux (:func:`find_manoeuvres`), taken
  to a nominal angle by :func:`nominal_switch`;
* **zig-zag reversals**: :func:`zigzag_crossings`;
* **steady turn**: :func:`steady_turn`.

Finding manoeuvres (:func:`find_manoeuvres`). The rudder (or, without a rudder, the thruster
differential port - starboard, the catamaran paper: tau_r = (T_port - T_stbd) b/2) is cut into
*pulses*: runs where the smoothed command keeps one sign beyond ``min_level``. Then

* a **zig-zag** is a chain of at least three pulses of alternating sign and similar level, joined
  by short transitions, whose reversals all happen at about the same heading deviation from the
  heading at the first execute (within 30 % or 0.5 deg: steering corrections held for a few
  seconds each are not a zig-zag); that deviation, read at the starts of the reversing rudder
  ramps, gives the switching angle ``psi_switch`` (:func:`nominal_switch`). A chain that fails
  this as a whole is searched for a zig-zag inside it (:func:`_zigzag_in_steering`): a run
  started from rest is steered onto its course by rudder corrections of the zig-zag's own size
  before the execute (the Esso Osaka pond runs), and a helm may reverse late once the
  overshoots have been read; the zig-zag is then the pulses after the corrections, up to the
  first reversal out of line, with at least two reversals and one rudder amplitude (within
  :data:`ZIGZAG_LEVEL_TOL` of the pulses' median: a zig-zag's rudder is set to one angle,
  corrections are not);
* a **turning circle** is a single pulse during which the heading changes by at least
  ``min_turn_deg`` (180 deg by default, enough for the tactical diameter);
* where no command explains it, a run of one-signed yaw rate turning at least 360 deg is a
  turning circle found from the heading alone (closed-loop circles of a thruster-driven USV);
  its "execute" is the start of the run (``execute_from="heading"``);
* a turning circle needs the vessel under way at its execute (:func:`turn_under_way`: over its
  approach, :mod:`usvid.prep.under_way`); a turn of the heading on the spot or at the dock is
  left out and said (:func:`manoeuvre_findings`), never measured as a circle of no diameter.

The segments are measured by :mod:`usvid.manoeuvres.measure` with the definitions of
:mod:`usvid.manoeuvres.metrics` (the simulator uses the same functions), so a measured and a
simulated manoeuvre are compared on equal terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.prep.filters import savgol_derivative, savgol_smooth, unwrap_angle
from usvid.prep.prepare import PreparedTrial, as_prepared
from usvid.prep.under_way import UnderWay, under_way
from usvid.trial import Finding, Trial

#: The approach before a manoeuvre [s]: the rudder over it is the reference ``delta_0``.
APPROACH_S = 5.0

#: Largest interquartile range [rad] of the rudder over the approach for it to count as held
#: steady (0.5 deg): its median is then a zero offset.
STEADY_RUDDER = math.radians(0.5)

#: Thruster command pairs (port, starboard) used as a turning command when there is no rudder.
THRUSTER_PAIRS: tuple[tuple[str, str], ...] = (
    ("n_port", "n_stbd"),
    ("pwm_port", "pwm_stbd"),
    ("thrust_port", "thrust_stbd"),
)


@dataclass(frozen=True)
class Approach:
    """The approach of a manoeuvre: the state before its execute, over the :data:`APPROACH_S`
    before it (:func:`approach`). ``speed`` [m/s] the mean speed ``U`` (else ``u``),
    ``shaft_speed`` [rps] the mean shaft speed ``n``, both None when not logged there;
    ``rudder_offset`` [rad] ``delta_0``, the median rudder (None without a rudder)."""

    t_execute: float
    speed: float | None = None
    shaft_speed: float | None = None
    rudder_offset: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"speed_m_s": self.speed, "shaft_speed_rps": self.shaft_speed,
                "rudder_offset_deg": None if self.rudder_offset is None
                else math.degrees(self.rudder_offset)}


def approach_window(t: np.ndarray, t_execute: float) -> np.ndarray:
    """The samples of the approach before ``t_execute`` [s] (times ``t`` [s]): ``t_execute -
    APPROACH_S .. t_execute``; the samples up to the execute's when none lies in that window;
    the first :data:`APPROACH_S` of a record that starts at its execute."""
    sel = (t >= t_execute - APPROACH_S) & (t <= t_execute)
    if sel.sum() < 2:
        i = int(np.searchsorted(t, t_execute, side="right"))
        sel = np.zeros(len(t), dtype=bool)
        sel[:max(i, 1)] = True
        if i <= 1:  # the record starts at the execute: its first APPROACH_S
            sel = t <= t[0] + APPROACH_S
    return sel


def approach(trial: Trial, t_execute: float) -> Approach:
    """The :class:`Approach` before ``t_execute`` [s]: means over :func:`approach_window`; the
    one definition of a manoeuvre's approach speed, shaft speed and rudder offset
    ``delta_0``."""
    sel = approach_window(trial.t, t_execute)

    def mean(ch: str) -> float | None:
        if not trial.has(ch):
            return None
        v = trial[ch][sel]
        v = v[np.isfinite(v)]
        return float(np.mean(v)) if v.size else None

    speed = mean("U")
    if speed is None:
        speed = mean("u")
    offset = None
    if trial.has("delta"):
        d = trial["delta"][sel]
        d = d[np.isfinite(d)]
        offset = float(np.median(d)) if d.size else None
    return Approach(float(t_execute), speed, mean("n"), offset)


@dataclass
class Segment:
    """One manoeuvre found in a log.

    ``kind`` "zigzag" | "turning"; times [s]; ``t_execute`` and ``side`` (+1 when the first
    command turns to starboard) by :func:`find_execute`; ``level`` the amplitude by
    :func:`rudder_amplitude` (rudder [rad] or thruster-differential units);
    ``psi_switch`` [rad] (zig-zag); ``heading_change`` [rad] over the segment; ``command`` the
    channel(s) used; ``execute_from`` "command" or "heading"; ``approach`` the state before
    the execute (:func:`approach`).
    """

    kind: str
    t_start: float
    t_end: float
    t_execute: float
    side: int
    command: str
    level: float | None = None
    psi_switch: float | None = None
    n_pulses: int = 1
    heading_change: float = 0.0
    execute_from: str = "command"
    extra: dict[str, Any] = field(default_factory=dict)
    approach: Approach | None = None

    @property
    def delta_amp_deg(self) -> float | None:
        """Rudder amplitude [deg] (None for a thruster command)."""
        if self.level is None or not self.command.startswith("delta"):
            return None
        return math.degrees(self.level)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.kind,
            "t_start": self.t_start,
            "t_end": self.t_end,
            "t_execute": self.t_execute,
            "first_side": "starboard" if self.side > 0 else "port",
            "command": self.command,
            "execute_from": self.execute_from,
            "heading_change_deg": math.degrees(self.heading_change),
        }
        if self.delta_amp_deg is not None:
            out["delta_amp_deg"] = self.delta_amp_deg
        elif self.level is not None:
            out["command_level"] = self.level
        if self.psi_switch is not None:
            out["psi_switch_deg"] = math.degrees(self.psi_switch)
        if self.kind == "zigzag":
            out["n_pulses"] = self.n_pulses
        if self.approach is not None:
            out["approach"] = self.approach.to_dict()
        out.update(self.extra)
        return out


@dataclass
class _Pulse:
    i0: int
    i1: int  # exclusive
    sign: int
    level: float


def turning_command(trial: Trial) -> tuple[str, np.ndarray, bool] | None:
    """``(name, command, is_rudder)``: the channel a log's manoeuvres are read from.

    The rudder order ``delta_cmd`` [rad] when the log has one (IMO MSC.137(76) and ITTC
    7.5-04-02-01 time a manoeuvre from the order, the *execute*, and the helm's reversals are
    the order's; a simulation's logic does the same), else the rudder angle ``delta`` [rad], else
    the thruster differential port - starboard (command units)."""
    for ch in ("delta_cmd", "delta"):
        if trial.has(ch):
            d = trial[ch]
            if np.nanmax(np.abs(d)) > 0:
                return ch, d, True
    derived = getattr(trial, "derived", ())  # (n_port, n_stbd from PWM: read the PWM itself)
    for port, stbd in THRUSTER_PAIRS:
        if trial.has(port) and trial.has(stbd) and port not in derived:
            return f"{port}-{stbd}", trial[port] - trial[stbd], False
    return None


def _runs(mask: np.ndarray) -> np.ndarray:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return np.column_stack([np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)])


# --------------------------------------------------------------------------------------------
# array helpers
# --------------------------------------------------------------------------------------------
def as_1d(name: str, a: Any, n: int | None = None) -> np.ndarray:
    """``a`` as a 1-D float array of ``n`` samples (:class:`UsvidError` naming ``name``)."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != 1:
        raise UsvidError(f"metrics: `{name}` must be a 1-D array (got shape {arr.shape})")
    if n is not None and arr.shape[0] != n:
        raise UsvidError(f"metrics: `{name}` has {arr.shape[0]} samples, `t` has {n}")
    return arr


def clean(t: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Drop samples where any array is not finite (a multi-rate trial has NaN gaps)."""
    ok = np.isfinite(t)
    for a in arrays:
        ok &= np.isfinite(a)
    return (t[ok],) + tuple(a[ok] for a in arrays)


def crossing_time(t: np.ndarray, z: np.ndarray, level: float, start: int, upward: bool
                  ) -> float:
    """First time [s] at or after sample ``start`` where ``z`` crosses ``level`` upwards
    (``upward``) or downwards: linear interpolation between the two samples that bracket the
    crossing (a sample already beyond ``level`` at ``start`` gives its own time); NaN when none.
    """
    seg = z[start:]
    hit = np.flatnonzero(seg >= level) if upward else np.flatnonzero(seg <= level)
    if hit.size == 0:
        return math.nan
    j = start + int(hit[0])
    if j == 0:
        return float(t[0])
    z0, z1 = z[j - 1], z[j]
    already = (z0 >= level) if upward else (z0 <= level)
    if already or z1 == z0:
        return float(t[j])
    f = (level - z0) / (z1 - z0)
    return float(t[j - 1] + f * (t[j] - t[j - 1]))


# --------------------------------------------------------------------------------------------
# the one definition of each manoeuvre quantity
# --------------------------------------------------------------------------------------------
def plateau_level(deflection: Any) -> float:
    """Plateau level of a deflection (a rudder [rad] or command pulse, positive towards its
    side): the median of its samples beyond half the largest one, so the ramps and the upward
    bias of the largest noisy sample are left out. 0 when nothing is positive, NaN when no
    sample is finite."""
    d = np.asarray(deflection, dtype=float)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return math.nan
    peak = float(d.max())
    if peak <= 0:
        return 0.0
    return float(np.median(d[d >= 0.5 * peak]))


def _approach(t: np.ndarray, delta: np.ndarray, t_ref: float, i_ref: int, lo: int = 0) -> float:
    """``delta_0``: median rudder over the :data:`APPROACH_S` before ``t_ref`` [s] (samples
    ``lo`` <= i < ``i_ref``); the rudder at ``t_ref`` when no sample precedes it."""
    a = max(int(np.searchsorted(t, t_ref - APPROACH_S)), lo)
    before = delta[a:i_ref]
    before = before[np.isfinite(before)]
    if before.size:
        return float(np.median(before))
    return float(np.interp(t_ref, t, delta))


def find_execute(t: Any, delta: Any, *, start: int = 0,
                 pulse: tuple[int, int] | None = None) -> tuple[float, int]:
    """The rudder execute: time [s] and side (+1 starboard, -1 port) of the first rudder order.

    The first deflection is ``pulse`` (sample range ``[i0, i1)`` of ``delta``, as found by
    :func:`find_manoeuvres`) or, by default, the run of samples from the first whose deviation
    from ``delta[start]`` reaches 25 % of the largest deviation (a zig-zag's largest deviation
    is up to twice its amplitude, so 25 % finds its first order), as long as it keeps that sign
    and size. With ``delta_0`` the median rudder over the :data:`APPROACH_S` (5 s) before the
    execute (found iteratively, starting from the 5 s before the deflection), the side is the
    sign of the deflection from ``delta_0`` and its level ``A`` the :func:`plateau_level` of
    ``side (delta - delta_0)`` over it. The execute is where the rising edge leaves
    ``delta_0``: the straight line through the first sample of the deflection beyond ``0.5 A``
    and the last sample before it within ``0.1 A`` of ``delta_0``, extended back to ``delta_0``
    (a rate-limited ramp gives its start, a sampled step its last sample before the step), not
    before sample ``start``. A record whose sample ``start`` is already beyond half
    the largest ``|delta|`` starts at the execute. ``delta`` in [rad] (or any command unit);
    non-finite samples are left out.
    """
    t = as_1d("t", t)
    delta = as_1d("delta", delta, len(t))
    ok = np.isfinite(t) & np.isfinite(delta)
    idx = np.flatnonzero(ok)
    t, delta = t[ok], delta[ok]
    s = int(np.searchsorted(idx, start))
    if len(t) - s < 2:
        raise UsvidError("metrics: too few samples to find the rudder execute")
    if pulse is None:
        big_abs = float(np.max(np.abs(delta[s:])))
        if abs(delta[s]) >= 0.5 * big_abs > 0:
            # the record starts with the rudder already over (e.g. a simulation from the execute)
            return float(t[s]), (1 if delta[s] > 0 else -1)
        dev = delta[s:] - delta[s]
        amp = float(np.max(np.abs(dev)))
        if amp <= 0:
            raise UsvidError("metrics: the rudder never moves; no manoeuvre to measure")
        i0 = s + int(np.flatnonzero(np.abs(dev) >= 0.25 * amp)[0])
        sgn = 1.0 if dev[i0 - s] > 0 else -1.0
        off = np.flatnonzero(sgn * dev[i0 - s:] < 0.25 * amp)
        i1 = i0 + (int(off[0]) if off.size else len(t) - i0)
    else:
        i0, i1 = (int(np.searchsorted(idx, i)) for i in pulse)
        if i0 <= s:
            return float(t[s]), (1 if np.median(delta[s:max(i1, s + 1)]) > 0 else -1)
    # delta_0 over the approach before the deflection, then (once the edge is known) over the
    # approach before the execute, so that no sample of the edge biases it
    t_e, side, t_ref, i_ref = float(t[s]), 1, float(t[i0]), i0
    for _ in range(3):
        d0 = _approach(t, delta, t_ref, i_ref, s)
        side, t_prev = (1 if float(np.median(delta[i0:i1])) - d0 > 0 else -1), t_e
        t_e = _edge_start(t, side * (delta - d0), s, i0, i1)
        t_ref, i_ref = t_e, int(np.searchsorted(t, t_e, side="right"))
        if t_e == t_prev:
            break
    return t_e, side


def _edge_start(t: np.ndarray, mag: np.ndarray, s: int, i0: int, i1: int) -> float:
    """Start [s] of the rising edge of the deflection ``mag[i0:i1]`` (towards its side, from
    ``delta_0``), not before sample ``s``: see :func:`find_execute`."""
    level = plateau_level(mag[i0:i1])
    rising = np.flatnonzero(mag[i0:i1] >= 0.5 * level)
    if not rising.size:
        return float(t[i0])
    return ramp_start(t, mag, i0 + int(rising[0]), s, level)


def ramp_start(t: np.ndarray, mag: np.ndarray, i_mid: int, lo: int, level: float) -> float:
    """Start [s] of the ramp of ``mag`` that passes sample ``i_mid`` on its way up to
    ``level`` (a rudder order, the helm putting the rudder over or reversing it).

    The ramp is the run of samples around ``i_mid`` where the slope of ``mag`` (0.5 s
    Savitzky-Golay) is at least a quarter of its slope at ``i_mid``; its foot is where that run
    begins. The baseline ``b`` is the median of ``mag`` over the second before the foot (the
    rudder held before the order, which may be a small steering correction rather than the
    approach rudder), and the start is the straight line through the first sample beyond
    ``b + 0.5 (level - b)`` and the last one before it within ``0.1 (level - b)`` of ``b``,
    extended back to ``b`` (a rate-limited ramp gives its start, a sampled step its last
    sample before the step). Not before sample ``lo``. Units of ``mag``: any (rad)."""
    dt = float(t[min(i_mid + 1, len(t) - 1)] - t[max(i_mid - 1, 0)]) / 2 or 1.0
    a = max(lo, i_mid - int(round(30.0 / dt)))
    seg = mag[a:i_mid + 1]
    if seg.size >= 5:
        slope = savgol_derivative(seg, dt, 0.5, order=2)
        ref = slope[-1] if np.isfinite(slope[-1]) else np.nan
        steep = (slope >= 0.25 * ref) if ref > 0 else np.ones(seg.size, dtype=bool)
        flat = np.flatnonzero(~steep)
        foot = a + (int(flat[-1]) + 1 if flat.size else 0)
    else:
        foot = a
    b0 = max(lo, foot - int(round(1.0 / dt)))
    base = mag[b0:foot + 1]
    base = base[np.isfinite(base)]
    b = float(np.median(base)) if base.size else 0.0
    b = min(b, 0.5 * level)
    rel = mag - b
    lev = level - b
    up = np.flatnonzero(rel[foot:i_mid + 1] >= 0.5 * lev)
    i50 = foot + int(up[0]) if up.size else i_mid
    quiet = np.flatnonzero(rel[b0:i50] <= 0.1 * lev)
    if not quiet.size:
        return float(t[max(b0, lo)])
    i10 = b0 + int(quiet[-1])
    rise = (rel[i50] - rel[i10]) / (t[i50] - t[i10]) if t[i50] > t[i10] else 0.0
    t0 = float(t[i10]) - max(float(rel[i10]), 0.0) / rise if rise > 0 else float(t[i10])
    return max(t0, float(t[lo]))


def rudder_amplitude(t: Any, delta: Any, t_execute: float, t_end: float | None = None) -> float:
    """Rudder amplitude [rad] (or command units) of the manoeuvre from ``t_execute`` to
    ``t_end`` [s] (default: the end of the record).

    Deflections are measured from ``delta_0``, the median rudder over the :data:`APPROACH_S`
    (5 s) before the execute (the rudder at the execute when no sample precedes it). A zig-zag
    (deflections to both sides, the smaller side at least 25 % of the larger) has the mean of
    its starboard and port :func:`plateau_level` (half the distance between the median
    starboard and the median port plateau: a rudder zero offset cancels); a one-sided
    manoeuvre (turning circle) the plateau level of its side, from ``delta_0`` when the rudder
    was steady before the execute (interquartile range within :data:`STEADY_RUDDER`), else
    from zero (the rudder before was a helmsman's steering corrections, not a zero offset).
    NaN without finite samples.
    """
    t = as_1d("t", t)
    t, delta = clean(t, as_1d("delta", delta, len(t)))
    if len(t) == 0:
        return math.nan
    i_e = int(np.searchsorted(t, t_execute))
    d0 = _approach(t, delta, float(t_execute), i_e)
    sel = t >= t_execute
    if t_end is not None:
        sel &= t <= t_end
    dev = delta[sel] - d0
    if dev.size == 0:
        return math.nan
    stbd, port = plateau_level(dev), plateau_level(-dev)
    hi, lo = float(dev.max()), float(-dev.min())
    if stbd > 0 and port > 0 and min(hi, lo) > 0.25 * max(hi, lo):
        return 0.5 * (stbd + port)
    # one side only (a turning circle): from delta_0 when the rudder was held steady before
    # the execute (a zero offset), else from zero (the rudder before was steering corrections:
    # their median is no offset)
    a = int(np.searchsorted(t, t_execute - APPROACH_S))
    before = delta[a:i_e]
    if before.size >= 3 and float(np.subtract(*np.percentile(before, [75, 25]))) > STEADY_RUDDER:
        dev = delta[sel]
        hi, lo = float(dev.max()), float(-dev.min())
    return plateau_level(dev) if hi >= lo else plateau_level(-dev)


def rudder_rate(t: Any, delta: Any) -> float:
    """Rudder rate [rad/s] on the ramps: |d delta/dt| of a 0.5 s quadratic Savitzky-Golay fit
    (:func:`usvid.prep.savgol_derivative`), median over the samples where it exceeds half its
    maximum; ``inf`` when the rudder does not move (an ideal servo)."""
    t = as_1d("t", t)
    delta = as_1d("delta", delta, len(t))
    tf = t[np.isfinite(t)]
    if tf.size < 2:
        return math.inf
    dd = np.abs(savgol_derivative(delta, float(np.median(np.diff(tf))), 0.5, order=2))
    peak = float(np.nanmax(dd)) if np.isfinite(dd).any() else 0.0
    if not peak > 0:
        return math.inf
    return float(np.median(dd[dd > 0.5 * peak]))


def zigzag_crossings(t: Any, z: Any, psi_switch: float, start: int = 0
                     ) -> tuple[list[float], list[int]]:
    """The reversal instants of a zig-zag (IMO MSC.137(76), ITTC 7.5-04-02-01).

    ``z`` [rad] is the heading deviation from the heading at the execute, signed so that the
    first turn is positive (``side (psi - psi0)``). Reversal k (k = 0, 1, ...) is where ``z``
    reaches ``+psi_switch`` (k even) or ``-psi_switch`` (k odd) [rad], searched alternately from
    sample ``start`` on. Returns the times [s], interpolated linearly between the two samples
    around each crossing, and the index of the first sample at or after each.
    """
    t = as_1d("t", t)
    z = as_1d("z", z, len(t))
    times: list[float] = []
    index: list[int] = []
    k = 0
    while start < len(t):
        up = k % 2 == 0
        tc = crossing_time(t, z, psi_switch if up else -psi_switch, start, up)
        if math.isnan(tc):
            break
        j = int(np.searchsorted(t, tc))
        times.append(tc)
        index.append(j)
        start = max(j, start + 1)
        k += 1
    return times, index


@dataclass
class SteadyTurn:
    """The steady part of a turning circle (:func:`steady_turn`): the window ``t_start`` ..
    ``t_end`` [s], the heading change ``arc`` [rad] inside it, the turn's ``side`` (+1
    starboard) and the means over the window of the yaw rate ``yaw_rate`` [rad/s, signed], the
    speed ``speed`` [m/s] and the rudder ``delta`` [rad] (NaN when not given)."""

    t_start: float
    t_end: float
    arc: float
    side: int
    yaw_rate: float
    speed: float
    delta: float


def steady_turn(t: Any, psi: Any, t_execute: float | None = None, *, r: Any = None,
                U: Any = None, x: Any = None, y: Any = None, delta: Any = None) -> SteadyTurn:
    """The steady part of a turning circle and its mean yaw rate, speed and rudder.

    From the execute ``t_execute`` [s] (default the first sample), heading ``psi`` [rad]: the
    side is the sign of the largest heading change after the execute. The steady window is the
    last 360 deg of heading change when the record turns at least 540 deg (180 deg for the
    tactical diameter, then a whole circle, which also averages out a current); else the part
    after the 180 deg instant; else (a turn of less than 180 deg) the part after half the final
    heading change. Over that window: ``yaw_rate`` the mean ``r`` [rad/s] (else the slope of a
    line fitted to ``psi(t)``), ``speed`` the mean ``U`` [m/s] (else the path length of ``x``,
    ``y`` [m] over the window's duration), ``delta`` the mean rudder [rad]. All arrays on ``t``;
    each channel's non-finite samples are left out.
    """
    t = as_1d("t", t)
    n = len(t)
    tt, pp = clean(t, as_1d("psi", psi, n))
    if len(tt) < 2:
        raise UsvidError("metrics: a steady turn needs at least 2 samples with a heading")
    pp = np.unwrap(pp)
    t_e = float(tt[0]) if t_execute is None else float(t_execute)
    after = tt >= t_e
    if not after.any():
        raise UsvidError(f"metrics: no heading sample after the execute at {t_e:g} s")
    dev = pp - float(np.interp(t_e, tt, pp))
    kmax = int(np.argmax(np.abs(np.where(after, dev, 0.0))))
    side = 1 if dev[kmax] >= 0 else -1
    z = side * dev
    z_end = float(z[-1])
    if z_end - 2 * math.pi >= math.pi:
        w = z >= z_end - 2 * math.pi
    else:
        t180 = crossing_time(tt, z, math.pi, int(np.searchsorted(tt, t_e)), True)
        w = tt >= t180 if not math.isnan(t180) else z >= 0.5 * z_end
    w &= after
    if not w.any():
        w = after
    ta, tb = float(tt[w][0]), float(tt[w][-1])

    def mean(name: str, a: Any) -> float:
        if a is None:
            return math.nan
        a = as_1d(name, a, n)
        sel = np.isfinite(a) & (t >= ta) & (t <= tb)
        return float(np.mean(a[sel])) if sel.any() else math.nan

    if r is not None:
        yaw = mean("r", r)
    else:
        yaw = float(np.polyfit(tt[w], pp[w], 1)[0]) if w.sum() >= 2 else math.nan
    if U is not None:
        speed = mean("U", U)
    elif x is not None and y is not None:
        tx, xx, yy = clean(t, as_1d("x", x, n), as_1d("y", y, n))
        sel = (tx >= ta) & (tx <= tb)
        speed = (float(np.sum(np.hypot(np.diff(xx[sel]), np.diff(yy[sel]))))
                 / float(tx[sel][-1] - tx[sel][0])) if sel.sum() >= 2 else math.nan
    else:
        speed = math.nan
    return SteadyTurn(t_start=ta, t_end=tb, arc=float(z[w].max() - z[w].min()), side=side,
                      yaw_rate=yaw, speed=speed, delta=mean("delta", delta))


def _pulses(c: np.ndarray, cs: np.ndarray, dt: float, min_level: float, min_pulse_s: float,
            merge_gap_s: float) -> list[_Pulse]:
    pulses: list[_Pulse] = []
    for sgn in (1, -1):
        for a, b in _runs(np.isfinite(cs) & (sgn * cs >= min_level)):
            pulses.append(_Pulse(int(a), int(b), sgn, 0.0))
    pulses.sort(key=lambda p: p.i0)
    merged: list[_Pulse] = []
    for p in pulses:
        if merged and merged[-1].sign == p.sign and (p.i0 - merged[-1].i1) * dt <= merge_gap_s:
            merged[-1].i1 = p.i1
        else:
            merged.append(p)
    out = []
    for p in merged:
        if (p.i1 - p.i0) * dt < min_pulse_s:
            continue
        p.level = plateau_level(p.sign * c[p.i0:p.i1])
        out.append(p)
    return out


def _plateau_end(c: np.ndarray, p: _Pulse) -> int:
    """Index of the last sample of pulse ``p`` within 10 % of its plateau level."""
    on = np.flatnonzero(np.abs(p.sign * c[p.i0:p.i1] - p.level) <= 0.1 * p.level)
    return p.i0 + int(on[-1]) if on.size else p.i1 - 1


def reversal_time(t: np.ndarray, c: np.ndarray, p: _Pulse) -> float:
    """The instant [s] the command of pulse ``p`` leaves its plateau to reverse: the start of
    the ramp away from the plateau (:func:`ramp_start` on ``level - sign c``), so that a
    rate-limited rudder gives the reversal order, not the end of the plateau."""
    mag = p.level - p.sign * c
    last = _plateau_end(c, p)
    away = np.flatnonzero(mag[last:] >= 0.5 * p.level)
    if not away.size:
        return float(t[min(p.i1, len(t) - 1)])
    return ramp_start(t, mag, last + int(away[0]), max(p.i0, last - int(2.0 / (t[1] - t[0]))),
                      p.level)


#: Switching angles [deg] zig-zag tests are specified with (IMO MSC.137(76): 10 and 20 deg;
#: ITTC 7.5-04-02-01 and SIMMAN: also 1, 5, 15 deg; larger ones occur in research).
STANDARD_SWITCH_DEG: tuple[float, ...] = (1.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)


#: Longest delay [s] between a rudder reversal order and the logged rudder angle leaving its
#: plateau that is taken as steering-gear lag of an n/n zig-zag (servo dead time and lag of a
#: small craft's steering: about 1 s).
MAX_HELM_LAG_S = 1.5
#: Longest such delay [s] for a switching angle other than the amplitude (a helm reacting
#: to the heading crossing; the HSVA KVLCC2 model tests: 0.2-0.4 s).
MAX_HELM_LAG_STANDARD_S = 0.45


def nominal_switch(measured: float, delta_amp: float | None = None, yaw_rate: float = 0.0,
                   *, order: bool = False) -> tuple[float, str]:
    """Switching angle [rad] of a zig-zag and how it was found.

    ``measured`` [rad] is the median heading deviation at the reversals (the starts of the
    rudder ramps, :func:`reversal_time`). Read from a logged rudder order (``order``) it is the
    switching angle itself (any value; to the whole degree when within 0.2 deg of one, the
    heading noise, as orders are given in whole degrees). Read from the rudder angle it is late by
    the steering lag tau (servo dead time and lag, helm reaction): measured = psi_s + |r| tau,
    ``yaw_rate`` |r| [rad/s] the median yaw rate at the reversals. So the amplitude
    ``delta_amp`` (an n/n zig-zag; to the whole degree when within 0.25 deg of one, as helm
    orders are given) is taken when its lag (measured - amplitude) / |r| lies in
    -0.3 deg/|r| .. :data:`MAX_HELM_LAG_S`, else a standard angle (:data:`STANDARD_SWITCH_DEG`)
    whose lag lies within :data:`MAX_HELM_LAG_STANDARD_S` and 1.5 deg, else the measured value
    (so a 13 deg switch of a fast-turning craft is not taken for 10 deg). Returns
    (angle [rad], "order" | "amplitude" | "standard" | "measured").
    """
    tol = math.radians(0.3)
    if order:  # orders are given in whole degrees: within 0.2 deg (heading noise) of one, it
        whole = math.radians(round(math.degrees(measured)))
        return (whole if abs(measured - whole) <= math.radians(0.2) else float(measured)), "order"
    r = abs(float(yaw_rate))

    def lag_ok(c: float, tmax: float, cap: float = math.inf) -> bool:
        return -tol <= measured - c <= min(r * tmax, cap) + tol

    if delta_amp is not None and math.isfinite(delta_amp) and lag_ok(delta_amp, MAX_HELM_LAG_S):
        # helm orders are whole degrees: a measured amplitude within 0.25 deg of one is that
        whole = math.radians(round(math.degrees(delta_amp)))
        near = abs(delta_amp - whole) <= math.radians(0.25)
        return (whole if near else float(delta_amp)), "amplitude"
    ok = [math.radians(c) for c in STANDARD_SWITCH_DEG
          if lag_ok(math.radians(c), MAX_HELM_LAG_STANDARD_S, math.radians(1.5))]
    if ok:
        return max(ok), "standard"
    return float(measured), "measured"


def _steady_before(psi: np.ndarray, i_exec: int, i_end: int, dt: float) -> bool:
    """True when the heading was steady over the 3 s before the execute (a standard manoeuvre
    starts from a straight approach): the mean yaw rate there (net heading change / 3 s) is at
    most 10 % of the manoeuvre's peak yaw rate (2-s Savitzky-Golay slope), or below 0.3 deg/s."""
    a = max(0, i_exec - int(round(3.0 / dt)))
    if i_exec - a < 2:
        return True
    r_before = abs(float(psi[i_exec] - psi[a])) / ((i_exec - a) * dt)
    r = savgol_derivative(psi[i_exec:i_end + 1], dt, 2.0)
    r_peak = float(np.nanmax(np.abs(r))) if np.isfinite(r).any() else 0.0
    return r_before <= max(0.1 * r_peak, math.radians(0.3))


def find_manoeuvres(
    trial: Trial,
    *,
    min_level: float | None = None,
    min_pulse_s: float = 2.0,
    max_transition_s: float = 10.0,
    min_turn_deg: float = 180.0,
    psi_switch: float | None = None,
    smooth_s: float | None = None,
) -> list[Segment]:
    """Zig-zags and turning circles inside ``trial`` (see the module docstring for the rules).

    Parameters
    ----------
    trial : Trial
        Needs ``psi`` [rad] and a command (``delta`` [rad], ``delta_cmd``, or a thruster pair);
        a raw trial is prepared first (:func:`usvid.prep.prepare`). On a prepared trial the
        segments are found once (remembered by the trial) and returned again on a second call
        with the same options.
    min_level : float, optional
        Smallest command counted as a deflection: rudder [rad] default 1 deg; thruster
        differential default 20 % of the 95th percentile of its magnitude.
    min_pulse_s, max_transition_s : float
        Shortest pulse [s]; longest time [s] between two pulses of one zig-zag.
    min_turn_deg : float
        Heading change [deg] that makes a single pulse a turning circle.
    psi_switch : float, optional
        Switching angle [rad] of zig-zags when known (default: measured, see module docstring).
    smooth_s : float, optional
        Smoothing window of the command [s] (default 0.5 s rudder, 5 s thrusters).

    Returns
    -------
    list of Segment, in time order.
    """
    if not trial.has("psi"):
        raise UsvidError(f"trial {trial.name or '?'}: no heading 'psi', cannot find manoeuvres")
    options = _options(min_level=min_level, min_pulse_s=min_pulse_s,
                       max_transition_s=max_transition_s, min_turn_deg=min_turn_deg,
                       psi_switch=psi_switch, smooth_s=smooth_s)
    prepared = as_prepared(trial, derivatives=False)
    if not prepared.has("psi"):
        raise UsvidError(f"trial {trial.name or '?'}: no heading 'psi', cannot find manoeuvres")
    return list(_segmentation(prepared, options)[0])


def manoeuvre_findings(trial: Trial, **options: Any) -> list[Finding]:
    """What :func:`find_manoeuvres` (with the same ``options``) found and did not return, and
    why: a turn of the heading while the vessel was not under way (code
    ``turn_not_under_way``). From the same segmentation (no second one)."""
    if not trial.has("psi"):
        return []
    prepared = as_prepared(trial, derivatives=False)
    if not prepared.has("psi"):
        return []
    return list(_segmentation(prepared, _options(**options))[1])


def _options(*, min_level: float | None = None, min_pulse_s: float = 2.0,
             max_transition_s: float = 10.0, min_turn_deg: float = 180.0,
             psi_switch: float | None = None, smooth_s: float | None = None) -> dict[str, Any]:
    return dict(min_level=min_level, min_pulse_s=min_pulse_s,
                max_transition_s=max_transition_s, min_turn_deg=min_turn_deg,
                psi_switch=psi_switch, smooth_s=smooth_s)


def _segmentation(prepared: PreparedTrial, options: dict[str, Any]
                  ) -> tuple[list[Segment], list[Finding]]:
    key = ("segments", *sorted(options.items()))
    return prepared.remember(key, lambda: segment_trial(prepared, **options))


def turn_under_way(trial: PreparedTrial, seg: Segment) -> UnderWay:
    """Whether the vessel was under way at the execute of a turn ``seg``
    (:func:`usvid.prep.under_way.under_way`, the one definition): over its approach
    (:func:`approach_window`), else, when the log tells no speed there, over the turn."""
    t = trial.t
    uw = under_way(trial, approach_window(t, seg.t_execute))
    if not uw.known:
        uw = under_way(trial, (t >= seg.t_execute) & (t <= seg.t_end))
    return uw


def segment_trial(trial: PreparedTrial, *, min_level: float | None, min_pulse_s: float,
                  max_transition_s: float, min_turn_deg: float, psi_switch: float | None,
                  smooth_s: float | None) -> tuple[list[Segment], list[Finding]]:
    """The segmentation behind :func:`find_manoeuvres` (run once per prepared trial and
    options; call :func:`find_manoeuvres`): the segments, and the findings of the turns left
    out because the vessel was not under way (:func:`manoeuvre_findings`)."""
    t = trial.t
    dt = float(np.median(np.diff(t)))
    psi = unwrap_angle(trial["psi"])
    psi_s = savgol_smooth(psi, dt, 2.0)  # zero-phase cubic over 2 s (as the metrics)
    segs: list[Segment] = []
    used = np.zeros(len(t), dtype=bool)
    cmd = turning_command(trial)
    if cmd is not None:
        name, c, rudder = cmd
        cs = savgol_smooth(c, dt, smooth_s or (0.5 if rudder else 5.0))
        if min_level is None:
            min_level = (math.radians(1.0) if rudder
                         else 0.2 * float(np.nanpercentile(np.abs(cs), 95)))
        cc = c if rudder else cs  # the command the execute and the level are read from
        # a command that never leaves zero (e.g. equal thrusters throughout: a differential of
        # zero, whose 95th percentile is 0) has no pulses, whatever the threshold
        pulses = (_pulses(cc, cs, dt, min_level, min_pulse_s, merge_gap_s=1.0)
                  if min_level > 0 else [])
        # chains of alternating pulses of similar level
        chains: list[list[_Pulse]] = []
        for p in pulses:
            if chains:
                q = chains[-1][-1]
                if (q.sign != p.sign and (p.i0 - q.i1) * dt <= max_transition_s
                        and 0.7 * q.level <= p.level <= q.level / 0.7):
                    chains[-1].append(p)
                    continue
            chains.append([p])
        floor = 0
        for chain in chains:
            seg = _zigzag(chain, t, cc, psi, psi_s, floor, name, rudder, psi_switch)
            rest: list[_Pulse] = list(chain) if seg is None else []
            if seg is None:
                seg, rest = _zigzag_in_steering(chain, t, cc, psi, psi_s, floor, name, rudder,
                                                psi_switch)
            if seg is not None:
                segs.append(seg)
                used[(t >= seg.t_start) & (t <= seg.t_end)] = True
            if rest:
                for p in rest:
                    s = _turning_from_pulse(p, t, cc, psi, floor, name, min_turn_deg)
                    if s is not None:
                        segs.append(s)
                        used[(t >= s.t_start) & (t <= s.t_end)] = True
                    floor = _plateau_end(cc, p)
            # the next order's ramp may start before this pulse has ended (a correction reversed
            # straight into the order): the next search starts at this pulse's last plateau
            floor = _plateau_end(cc, chain[-1])
    segs += _turning_from_heading(t, psi, dt, used)
    segs.sort(key=lambda s: s.t_start)
    kept: list[Segment] = []
    findings: list[Finding] = []
    for seg in segs:
        seg.approach = approach(trial, seg.t_execute)
        if seg.kind == "turning":  # a turning circle is sailed: the vessel under way
            uw = turn_under_way(trial, seg)
            if uw.is_under_way is False:
                findings.append(Finding(
                    "info", "turn_not_under_way",
                    f"the heading turns {math.degrees(seg.heading_change):.0f} deg from t = "
                    f"{seg.t_start:.1f} s to {seg.t_end:.1f} s, but the vessel was not under "
                    f"way: {uw.reason()}; not a turning circle (on the spot or at the dock the "
                    "heading turns without a track to measure)",
                    t_start=seg.t_start, t_end=seg.t_end, channel="psi",
                    data={"heading_change_deg": math.degrees(seg.heading_change),
                          "median_speed_m_s": uw.median_speed, "speed_from": uw.source}))
                continue
        kept.append(seg)
    return kept, findings


#: Largest relative difference of a pulse's rudder level from the pulses' median for a zig-zag
#: found inside a longer chain of steering (:func:`_zigzag_in_steering`): 10 %, the spread of a
#: helm set to one angle (the Esso Osaka runs: 14.8/15.1 and 19.5/20.2 deg), well inside the
#: 0.7-1/0.7 that chains pulses.
ZIGZAG_LEVEL_TOL = 0.10


def _consistent(dev: np.ndarray) -> bool:
    """Every reversal at the same heading deviation ``dev`` [rad] (within 30 % of their median
    or 0.5 deg): a real zig-zag, not a helmsman's steering corrections (held for a few seconds
    each, whatever the heading)."""
    est = float(np.median(dev))
    return not np.any(np.abs(dev - est) > max(0.3 * est, math.radians(0.5)))


def _final_rise(c: np.ndarray, p: _Pulse) -> _Pulse:
    """Pulse ``p`` from its last rise onto its plateau.

    A run started from rest is steered onto its course with the rudder to the execute's side
    before the execute: the pulse then holds a shelf (e.g. 5-8 deg of steering, then the
    15 deg order). The rise starts after the last sample below 60 % of the plateau level before
    the plateau is first reached (within 10 %); without such a sample (a clean step from the
    approach) the pulse is returned unchanged."""
    mag = p.sign * c[p.i0:p.i1]
    on = np.flatnonzero(np.abs(mag - p.level) <= 0.1 * p.level)
    if not on.size:
        return p
    below = np.flatnonzero(mag[:on[0]] < 0.6 * p.level)
    if not below.size:
        return p
    return _Pulse(p.i0 + int(below[-1]) + 1, p.i1, p.sign, p.level)


def _zigzag_in_steering(chain: list[_Pulse], t, c, psi, psi_s, floor, name, rudder, psi_switch
                        ) -> tuple[Segment | None, list[_Pulse]]:
    """A zig-zag inside a chain of pulses that is not one as a whole (see the module
    docstring): after up to two leading steering corrections, from the last rise onto the
    first pulse's plateau (:func:`_final_rise`), up to the first reversal out of line
    (:func:`_consistent`), with at least two reversals and every pulse's level within
    :data:`ZIGZAG_LEVEL_TOL` of their median. Returns (the segment or None, the chain's pulses
    it leaves, to be tried as turning circles)."""
    for k in range(min(3, len(chain) - 2)):
        sub = list(chain[k:])
        # the execute is searched from the previous pulse's plateau (not from the shelf): the
        # foot of the final rise may lie below the shelf's level (:func:`ramp_start`)
        first = _final_rise(c, sub[0])
        start = floor if k == 0 else _plateau_end(c, chain[k - 1])
        seg, n = _zigzag([first, *sub[1:]], t, c, psi, psi_s, start, name, rudder, psi_switch,
                         in_steering=True)
        if seg is not None:
            return seg, list(chain[:k]) + list(chain[k + n:])
    return None, list(chain)


def _zigzag(chain: list[_Pulse], t, c, psi, psi_s, floor, name, rudder, psi_switch, *,
            in_steering: bool = False):
    """The zig-zag of a chain of pulses, else None (see the module docstring). With
    ``in_steering`` (:func:`_zigzag_in_steering`): (the zig-zag of the chain's first pulses, up
    to the first reversal out of line, or None; the number of pulses it takes)."""
    def fail() -> Any:
        return (None, 0) if in_steering else None

    if len(chain) < 3:  # two reversals at least (IMO's first and second overshoot need them)
        return fail()
    t_e, side = find_execute(t, c, start=floor, pulse=(chain[0].i0, chain[0].i1))
    ie = int(np.searchsorted(t, t_e))
    # the switching angle from the smoothed heading (psi_s): a noisy sample at the execute or at
    # a reversal would shift it by the heading noise
    psi0 = float(np.interp(t_e, t, psi_s))
    rev = [reversal_time(t, c, p) for p in chain[:-1]]
    dev = np.array([p.sign * (float(np.interp(tr, t, psi_s)) - psi0)
                    for p, tr in zip(chain[:-1], rev, strict=True)])
    if in_steering:  # up to the first reversal out of line (two at least)
        m = len(dev)
        while m >= 2 and not (np.all(np.isfinite(dev[:m])) and np.all(dev[:m] > 0)
                              and _consistent(dev[:m])):
            m -= 1
        levels = np.array([p.level for p in chain[:m + 1]])
        if m < 2 or np.any(np.abs(levels - np.median(levels))
                           > ZIGZAG_LEVEL_TOL * np.median(levels)):
            return fail()
        chain, rev, dev = chain[:m + 1], rev[:m], dev[:m]
    if not np.all(np.isfinite(dev)) or np.any(dev <= 0) or not _consistent(dev):
        return fail()
    est = float(np.median(dev))
    i_end = chain[-1].i1 - 1
    level = rudder_amplitude(t, c, t_e, float(t[i_end]))
    r_s = np.gradient(psi_s, t)
    yaw = float(np.median([abs(np.interp(tr, t, r_s)) for tr in rev]))
    if psi_switch is not None:
        sw, how = psi_switch, "given"
    elif not rudder:
        sw, how = nominal_switch(est, None, yaw)
    else:
        sw, how = nominal_switch(est, level, yaw, order=name == "delta_cmd")
    # the smoothed heading: the 3-s heading change of two raw samples carries the compass noise
    # (0.5 deg: 0.24 deg/s, near the 0.3 deg/s limit)
    if not _steady_before(psi_s, ie, i_end, float(t[1] - t[0])):
        return fail()
    seg = Segment(
        kind="zigzag",
        t_start=t_e,
        t_end=float(t[i_end]),
        t_execute=t_e,
        side=side,
        command=name,
        level=level,
        psi_switch=sw,
        n_pulses=len(chain),
        heading_change=float(np.nanmax(psi[ie:i_end + 1]) - np.nanmin(psi[ie:i_end + 1])),
        extra={"psi_switch_measured_deg": math.degrees(est), "psi_switch_from": how,
               "rudder_lag_s": (est - sw) / yaw if yaw > 0 else math.nan},
    )
    return (seg, len(chain)) if in_steering else seg


def _turning_from_pulse(p, t, c, psi, floor, name, min_turn_deg) -> Segment | None:
    t_e, side = find_execute(t, c, start=floor, pulse=(p.i0, p.i1))
    ie = int(np.searchsorted(t, t_e))
    i_end = p.i1 - 1
    change = side * (psi[i_end] - float(np.interp(t_e, t, psi)))
    if not np.isfinite(change) or change < math.radians(min_turn_deg):
        return None
    if not _steady_before(psi, ie, i_end, float(t[1] - t[0])):
        return None
    return Segment(kind="turning", t_start=t_e, t_end=float(t[i_end]), t_execute=t_e,
                   side=side, command=name, level=rudder_amplitude(t, c, t_e, float(t[i_end])),
                   heading_change=float(change))


def _turning_from_heading(t, psi, dt, used, min_rate_deg_s: float = 0.2,
                          min_change_deg: float = 360.0, window_s: float = 20.0) -> list[Segment]:
    # the mean yaw rate over window_s (straight-line fit): a path-following controller's yaw
    # oscillations (periods of a few seconds) do not break the run
    r = savgol_derivative(psi, dt, window_s, order=1)
    out = []
    for sgn in (1, -1):
        for a, b in _runs(np.isfinite(r) & (sgn * r >= math.radians(min_rate_deg_s)) & ~used):
            change = sgn * (psi[b - 1] - psi[a])
            if change >= math.radians(min_change_deg):
                out.append(Segment(kind="turning", t_start=float(t[a]), t_end=float(t[b - 1]),
                                   t_execute=float(t[a]), side=sgn, command="heading",
                                   heading_change=float(change), execute_from="heading"))
    return out
