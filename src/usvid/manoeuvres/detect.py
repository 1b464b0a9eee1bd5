"""Find standard manoeuvres (zig-zags, turning circles) inside a log, and measure them.

The rudder (or, without a rudder, the thruster differential port - starboard, seed 002:
tau_r = (T_port - T_stbd) b/2) is cut into *pulses*: runs where the smoothed command keeps one sign
beyond ``min_level``. Then

* a **zig-zag** is a chain of at least two pulses of alternating sign and similar level, joined by
  short transitions, whose reversals all happen at about the same heading deviation from the
  heading at the first execute (that deviation is the switching angle ``psi_switch``; it is rounded
  to whole degrees when above 0.75 deg, as zig-zag tests are specified);
* a **turning circle** is a single pulse during which the heading changes by at least
  ``min_turn_deg`` (180 deg by default, enough for the tactical diameter);
* where no command explains it, a run of one-signed yaw rate turning at least 360 deg is a
  turning circle found from the heading alone (closed-loop circles of a thruster-driven USV);
  its "execute" is the start of the run (``execute_from="heading"``).

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
from usvid.prep.prepare import prepare
from usvid.trial import Trial

#: Thruster command pairs (port, starboard) used as a turning command when there is no rudder.
THRUSTER_PAIRS: tuple[tuple[str, str], ...] = (
    ("n_port", "n_stbd"),
    ("pwm_port", "pwm_stbd"),
    ("thrust_port", "thrust_stbd"),
)


@dataclass
class Segment:
    """One manoeuvre found in a log.

    ``kind`` "zigzag" | "turning"; times [s]; ``side`` +1 when the first command turns to
    starboard; ``level`` the command's plateau (rudder [rad] or thruster-differential units);
    ``psi_switch`` [rad] (zig-zag); ``heading_change`` [rad] over the segment; ``command`` the
    channel(s) used; ``execute_from`` "command" or "heading".
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
        out.update(self.extra)
        return out


@dataclass
class _Pulse:
    i0: int
    i1: int  # exclusive
    sign: int
    level: float


def turning_command(trial: Trial) -> tuple[str, np.ndarray, bool] | None:
    """``(name, command, is_rudder)``: ``delta``, else ``delta_cmd``, else port - stbd thrust."""
    for ch in ("delta", "delta_cmd"):
        if trial.has(ch):
            d = trial[ch]
            if np.nanmax(np.abs(d)) > 0:
                return ch, d, True
    for port, stbd in THRUSTER_PAIRS:
        if trial.has(port) and trial.has(stbd):
            return f"{port}-{stbd}", trial[port] - trial[stbd], False
    return None


def _runs(mask: np.ndarray) -> np.ndarray:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return np.column_stack([np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)])


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
        seg = np.abs(c[p.i0:p.i1])
        p.level = float(np.nanmedian(seg))
        out.append(p)
    return out


def _execute_index(t: np.ndarray, c: np.ndarray, p: _Pulse, floor: int) -> int:
    """Sample where the command starts to move towards pulse ``p`` (the rudder execute).

    The last sample before the pulse within 10 % of its level of zero, moved back along the
    rising edge (a straight line through the 10 % and 50 % points, extrapolated to zero): a
    rate-limited rudder reaches 10 % of 20 deg 0.4 s after the order at 5 deg/s.
    """
    mag = p.sign * c
    idx = np.flatnonzero(mag[floor:p.i0 + 1] <= 0.1 * p.level)
    if not idx.size:
        return floor
    i10 = floor + int(idx[-1])
    after = np.flatnonzero(mag[i10:p.i1] >= 0.5 * p.level)
    if not after.size:
        return i10
    i50 = i10 + int(after[0])
    rise = (mag[i50] - mag[i10]) / max(t[i50] - t[i10], 1e-12)
    if not (np.isfinite(rise) and rise > 0):
        return i10
    t0 = t[i10] - max(float(mag[i10]), 0.0) / rise
    return max(floor, int(np.searchsorted(t, t0 - 1e-9)))


def _reversal_index(c: np.ndarray, p: _Pulse) -> int:
    """Last sample of pulse ``p`` still on its plateau (within 10 % of its level)."""
    on = np.flatnonzero(np.abs(p.sign * c[p.i0:p.i1] - p.level) <= 0.1 * p.level)
    return p.i0 + int(on[-1]) if on.size else p.i1 - 1


#: Switching angles [deg] zig-zag tests are specified with (IMO MSC.137(76): 10 and 20 deg;
#: ITTC 7.5-04-02-01 and SIMMAN: also 1, 5, 15 deg; larger ones occur in research).
STANDARD_SWITCH_DEG: tuple[float, ...] = (1.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)


def nominal_switch(measured: float, delta_amp: float | None = None) -> float:
    """Nominal switching angle [rad] from the heading deviation [rad] at the rudder reversals.

    The rudder can only start to reverse after the heading has passed the switching angle (the
    helm or autopilot reacts with some delay, the heading keeps turning meanwhile), so the
    deviation measured where the rudder leaves its plateau is an upper bound: HSVA's 10/10
    zig-zags reverse at 10.7-10.9 deg, their 20/5 at 6.3 deg. The nominal value is the largest
    standard angle (:data:`STANDARD_SWITCH_DEG`, plus the rudder amplitude for n/n tests) not
    above the measured deviation + 0.1 deg (sampling); below 1 deg the measured value to 0.1 deg.
    """
    deg = math.degrees(measured) + 0.1
    cands = list(STANDARD_SWITCH_DEG)
    if delta_amp is not None:
        cands.append(float(round(math.degrees(delta_amp))))
    below = [c for c in cands if c <= deg]
    if not below:
        return math.radians(round(math.degrees(measured), 1))
    return math.radians(max(below))


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
        a non-uniform trial is prepared first (:func:`usvid.prep.prepare`).
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
    if not trial.is_uniform or trial.data[["t", "psi"]].isna().any().any():
        trial = prepare(trial, derivatives=False)
    t = trial.t
    dt = float(np.median(np.diff(t)))
    psi = unwrap_angle(trial["psi"])
    segs: list[Segment] = []
    used = np.zeros(len(t), dtype=bool)
    cmd = turning_command(trial)
    if cmd is not None:
        name, c, rudder = cmd
        cs = savgol_smooth(c, dt, smooth_s or (0.5 if rudder else 5.0))
        if min_level is None:
            min_level = (math.radians(1.0) if rudder
                         else 0.2 * float(np.nanpercentile(np.abs(cs), 95)))
        pulses = _pulses(c if rudder else cs, cs, dt, min_level, min_pulse_s, merge_gap_s=1.0)
        # chains of alternating pulses of similar level
        chains: list[list[_Pulse]] = []
        for p in pulses:
            if chains:
                q = chains[-1][-1]
                if (q.sign != p.sign and (p.i0 - q.i1) * dt <= max_transition_s
                        and 0.7 <= p.level / q.level <= 1 / 0.7):
                    chains[-1].append(p)
                    continue
            chains.append([p])
        floor = 0
        for chain in chains:
            seg = _zigzag(chain, t, c, cs, psi, floor, name, rudder, psi_switch)
            if seg is None:
                for p in chain:
                    s = _turning_from_pulse(p, t, c if rudder else cs, psi, floor, name,
                                            min_turn_deg)
                    if s is not None:
                        segs.append(s)
                        used[(t >= s.t_start) & (t <= s.t_end)] = True
                    floor = p.i1
            else:
                segs.append(seg)
                used[(t >= seg.t_start) & (t <= seg.t_end)] = True
            floor = chain[-1].i1
    segs += _turning_from_heading(t, psi, dt, used)
    segs.sort(key=lambda s: s.t_start)
    return segs


def _zigzag(chain: list[_Pulse], t, c, cs, psi, floor, name, rudder, psi_switch
            ) -> Segment | None:
    if len(chain) < 2:
        return None
    level = float(np.median([p.level for p in chain]))
    ie = _execute_index(t, c if rudder else cs, chain[0], floor)
    psi0 = psi[ie]
    rev = [_reversal_index(c if rudder else cs, p) for p in chain[:-1]]
    dev = np.array([p.sign * (psi[i] - psi0) for p, i in zip(chain[:-1], rev, strict=True)])
    if not np.all(np.isfinite(dev)) or np.any(dev <= 0):
        return None
    est = float(np.median(dev))
    # every reversal at the same heading deviation (within 50 % or 1 deg): a real zig-zag
    if np.any(np.abs(dev - est) > max(0.5 * est, math.radians(1.0))):
        return None
    sw = psi_switch if psi_switch is not None else nominal_switch(est, level if rudder else None)
    i_end = chain[-1].i1 - 1
    if not _steady_before(psi, ie, i_end, float(t[1] - t[0])):
        return None
    return Segment(
        kind="zigzag",
        t_start=float(t[ie]),
        t_end=float(t[i_end]),
        t_execute=float(t[ie]),
        side=chain[0].sign,
        command=name,
        level=level,
        psi_switch=sw,
        n_pulses=len(chain),
        heading_change=float(np.nanmax(psi[ie:i_end + 1]) - np.nanmin(psi[ie:i_end + 1])),
        extra={"psi_switch_measured_deg": math.degrees(est),
               "psi_switch_from": "given" if psi_switch is not None else "nominal"},
    )


def _turning_from_pulse(p, t, c, psi, floor, name, min_turn_deg) -> Segment | None:
    ie = _execute_index(t, c, p, floor)
    i_end = p.i1 - 1
    change = p.sign * (psi[i_end] - psi[ie])
    if not np.isfinite(change) or change < math.radians(min_turn_deg):
        return None
    if not _steady_before(psi, ie, i_end, float(t[1] - t[0])):
        return None
    return Segment(kind="turning", t_start=float(t[ie]), t_end=float(t[i_end]),
                   t_execute=float(t[ie]), side=p.sign, command=name, level=p.level,
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
