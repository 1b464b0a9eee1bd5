"""Channel audit: check every channel of a raw trial against the physics, in plain words.

:func:`audit` returns a list of :class:`~usvid.trial.Finding` (severity, stable code, message,
count, time span). Only problems (and a few facts worth knowing, as ``info``) become findings.
The checks:

* time: reversals, repeated stamps, gaps (> 3 median steps and > the median step + 0.5 s);
* duplicated rows (every channel equal to the previous row) and stale GNSS fixes (rate reported);
* NaN runs per channel, saturation (an actuator or other non-motion channel pinned at its
  extreme, the rudder at hard-over); heading jumps (left out of the physics checks);
* yaw rate: every numeric channel (whatever its name, e.g. ``p``) is compared with d(psi)/dt by
  correlation and least-squares gain; says which channel is the yaw rate, a wrong sign, or an
  angle-unit factor 57.3 (deg vs rad);
* u, v against d(x, y)/dt rotated into the body frame (kinematics of Mu et al. 2018, eq. 13), and a
  measured speed (U, SOG) against |d(x, y)/dt| (a constant factor: wrong time base or scale);
* rudder sign against the turning direction: the first-order Nomoto equation
  T r' + r = K delta (Mu et al. 2018, Nomoto model) gives r' = (K/T) delta - r/T; the least-squares
  sign of K/T must be positive (usvid convention: positive delta makes r positive);
* a thruster differential (port minus starboard) the same way (the catamaran paper:
  tau_r ~ T_port - T_stbd);
* a constant scale factor between two position sources (lat/lon vs a file's own x/y);
* degenerate data: a position jump implying a speed no vessel makes (:data:`MAX_SPEED`), an
  actuator channel constant over the whole log, time running backwards (errors), a rudder angle
  beyond any rudder's travel.

Verdicts only where the data support them: the channels are compared on the prepared trial's
grid (:func:`usvid.prep.prepare`, the one road: the rate of the fastest *message stream*,
:func:`usvid.prep.resample.stream_rate`, not the spacing of the merged records, which a gateway
stamping in bursts makes a millisecond);
the physics checks need :data:`MIN_PHYSICS_S` of log, the yaw-rate check a nearly level
vehicle and some turning, the rudder-sign check a vessel under way (:mod:`usvid.prep.under_way`,
the one definition: speed at least :data:`MIN_SPEED` on :data:`MIN_MOVING_S` of the log). Every
error says what to do, with the format-spec line that does it for the log's reader
(:func:`spec_hint`). Heading glitches and steps are those of :mod:`usvid.prep.glitches` (the
one definition the manoeuvre metrics use too).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy.signal import savgol_coeffs

from usvid.errors import UsvidError
from usvid.prep.filters import (
    nan_runs,
    savgol_derivative,
    savgol_smooth,
    unwrap_angle,
    window_samples,
)
from usvid.prep.geodesy import geodetic_to_ned
from usvid.prep.glitches import (
    GLITCH_MIN,
    MAX_TURN_RATE,
    STEP_MIN,
)
from usvid.prep.kinematics import earth_to_body
from usvid.prep.prepare import PreparedTrial, prepare
from usvid.prep.stale import POSITION_GROUPS, detect_stale
from usvid.prep.under_way import MIN_MOVING_S, MIN_SPEED
from usvid.prep.under_way import moving as moving_samples
from usvid.trial import Finding, Trial

RAD = 180.0 / np.pi
#: Physics checks need at least this much log [s].
MIN_PHYSICS_S = 10.0
#: The rudder sign is judged only on samples where the vessel makes way (a boat at the dock
#: turns with wind and lines, not with its rudder), on at least MIN_MOVING_S [s] of them:
#: :mod:`usvid.prep.under_way`, the one definition (MIN_SPEED [m/s]).
#: The yaw-rate check compares a body-axis rate with d(psi)/dt: only for a nearly level vehicle
#: (roll and pitch within this [rad] on 90 % of the samples; a banked aircraft's body rate is no
#: heading rate).
MAX_LEVEL = math.radians(10.0)
#: Fastest speed over ground of a surface vessel [m/s] (90 knots; racing boats stay below);
#: a position jump implying more is no motion. For aircraft, MAX_SPEED_AIR (Mach 0.9).
MAX_SPEED, MAX_SPEED_AIR = 46.0, 300.0
#: A rudder angle beyond this [rad] is beyond any rudder's travel (35-45 deg; high-lift
#: rudders 65-70 deg; an azimuth drive turns all round and is logged as a thrust angle).
MAX_RUDDER = math.radians(70.0)
#: Gains between a candidate channel and d(psi)/dt that have a plain explanation.
_GAINS: tuple[tuple[float, str], ...] = (
    (1.0, "matches"),
    (-1.0, "has the opposite sign"),
    (RAD, "is 57.3 times too small (an angle unit: rad read as deg?)"),
    (-RAD, "has the opposite sign and is 57.3 times too small (rad read as deg?)"),
    (1.0 / RAD, "is 57.3 times too large (an angle unit: deg read as rad?)"),
    (-1.0 / RAD, "has the opposite sign and is 57.3 times too large (deg read as rad?)"),
)
#: Channels never candidates for a rate: time, positions, headings (derived channels are not
#: candidates either: only what the log measured is tested).
_NOT_RATE = {"t", "x", "y", "lat", "lon", "x_src", "y_src", "psi", "cog"}
#: Input channels (commands and actuator states): never a yaw rate, however well they follow it.
_INPUTS = {"delta", "delta_cmd", "n", "n_port", "n_stbd", "thrust", "tau_u", "tau_r"}
_INPUT_PREFIXES = ("delta", "pwm", "n_", "thrust", "T_", "rudder", "throttle")
#: Motion channels: outputs of the physics, whose steady values are not saturation.
_KINEMATIC = {"u", "v", "r", "p", "q", "U", "sog", "psi_cmd", "psi_set"}
#: Thruster differential pairs (port, starboard), first present wins.
THRUSTER_PAIRS: tuple[tuple[str, str], ...] = (
    ("n_port", "n_stbd"),
    ("pwm_port", "pwm_stbd"),
    ("thrust_port", "thrust_stbd"),
    ("PWM_L", "PWM_R"),
)


@dataclass
class Match:
    """How well channel ``name`` explains a reference: ``ref ~ gain * channel``."""

    name: str
    corr: float
    gain: float
    r2: float
    n: int

    def explanation(self, tol: float = 0.1) -> tuple[float, str] | None:
        """The nearest plain gain (±1, ±57.3, ±1/57.3) within ``tol`` relative, else None."""
        for g, words in _GAINS:
            if abs(self.gain - g) <= tol * abs(g):
                return g, words
        return None


def _ls_match(name: str, y: np.ndarray, ref: np.ndarray) -> Match | None:
    ok = np.isfinite(y) & np.isfinite(ref)
    n = int(ok.sum())
    if n < 20:
        return None
    a, b = y[ok], ref[ok]
    if np.std(a) <= 1e-12 * (1 + np.abs(a).max()) or np.std(b) == 0:
        return None
    corr = float(np.corrcoef(a, b)[0, 1])
    gain = float(np.dot(a, b) / np.dot(a, a))
    res = b - gain * a
    r2 = 1.0 - float(np.dot(res, res) / np.dot(b - b.mean(), b - b.mean()))
    return Match(name, corr, gain, r2, n)


def _span(t: np.ndarray, mask: np.ndarray) -> tuple[float | None, float | None]:
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return None, None
    return float(t[idx[0]]), float(t[idx[-1]])


def _numeric_channels(trial: Trial) -> list[str]:
    return [
        c for c in trial.channels
        if pd.api.types.is_numeric_dtype(trial.data[c]) and not pd.api.types.is_bool_dtype(
            trial.data[c])
    ]


# --- time, duplicates, NaN, saturation ---------------------------------------------------------
def _check_time(trial: Trial) -> list[Finding]:
    out: list[Finding] = []
    t = trial.t
    if len(t) < 3:
        return out
    dt = np.diff(t)
    rev = dt < 0
    if rev.any():
        a, b = _span(t[1:], rev)
        out.append(Finding("error", "time_reversal",
                           f"time runs backwards at {int(rev.sum())} row(s) "
                           f"(first at t = {a:.3f} s)",
                           count=int(rev.sum()), t_start=a, t_end=b, channel="t"))
    rep = dt == 0
    if rep.any():
        a, b = _span(t[1:], rep)
        out.append(Finding("warning", "time_repeated",
                           f"{int(rep.sum())} row(s) repeat the previous time stamp",
                           count=int(rep.sum()), t_start=a, t_end=b, channel="t"))
    pos = dt[dt > 0]
    if len(pos):
        med = float(np.median(pos))
        # in a multi-rate log no record may arrive for a while between the samples of the
        # slowest regular channel: a gap is longer than twice its own typical spacing too
        slow = 0.0
        for c in _numeric_channels(trial):
            y = trial[c]
            ts = t[np.isfinite(y)]
            if 2 < len(ts) < len(t):
                slow = max(slow, float(np.median(np.diff(ts))))
        gap = dt > max(3.0 * med, med + 0.5, 2.0 * slow)
        if gap.any():
            i = np.flatnonzero(gap)
            longest = int(i[np.argmax(dt[i])])
            out.append(Finding(
                "warning", "time_gap",
                f"{len(i)} gap(s) in time longer than 3 sample intervals (median {med:.3g} s); "
                f"longest {dt[longest]:.2f} s after t = {t[longest]:.2f} s",
                count=len(i), t_start=float(t[i[0]]), t_end=float(t[i[-1] + 1]), channel="t",
                data={"longest_s": float(dt[longest])}))
    return out


def _check_duplicates(trial: Trial, chans: list[str]) -> list[Finding]:
    if len(trial) < 2 or not chans:
        return []
    vals = trial.data[chans].to_numpy(dtype=float)
    # A repeat is a complete row (every channel present, at least two) equal to the previous
    # complete row. In a multi-rate trial (union of sensor time stamps, NaN elsewhere) rows hold
    # one sensor's sample each, and a rudder sentence repeating a saturated angle is no
    # duplicate; such trials have no complete rows and are not checked here (their readers
    # count repeated time stamps).
    full = np.isfinite(vals).all(axis=1)
    same = np.zeros(len(vals) - 1, dtype=bool)
    if vals.shape[1] >= 2:
        same = full[1:] & full[:-1] & np.all(vals[1:] == vals[:-1], axis=1)
    if not same.any():
        return []
    a, b = _span(trial.t[1:], same)
    return [Finding("warning", "duplicate_rows",
                    f"{int(same.sum())} row(s) repeat every channel of the previous row exactly "
                    f"(a logger writing faster than its sources?)",
                    count=int(same.sum()), t_start=a, t_end=b)]


def _check_nan(trial: Trial, chans: list[str]) -> list[Finding]:
    out = []
    t = trial.t
    n = len(t)
    for ch in chans:
        y = trial[ch]
        runs = nan_runs(y)
        if not len(runs):
            continue
        nn = int(np.sum(runs[:, 1] - runs[:, 0]))
        if nn == n:
            out.append(Finding("warning", "channel_empty", f"channel '{ch}' has no valid sample",
                               count=n, channel=ch))
            continue
        ts = t[np.isfinite(y)]
        own = float(np.median(np.diff(ts))) if len(ts) > 2 else 0.0
        lo = np.clip(runs[:, 0] - 1, 0, n - 1)
        hi = np.clip(runs[:, 1], 0, n - 1)
        dur = t[hi] - t[lo]
        long_ = dur > max(1.0, 5.0 * own)
        if long_.any():
            k = int(np.argmax(dur))
            out.append(Finding(
                "warning", "nan_run",
                f"channel '{ch}' is missing over {int(long_.sum())} stretch(es) longer than "
                f"{max(1.0, 5.0 * own):.2g} s; longest {dur[k]:.2f} s from t = {t[lo[k]]:.2f} s",
                count=int(np.sum((runs[:, 1] - runs[:, 0])[long_])),
                t_start=float(t[runs[long_][0, 0]]), t_end=float(t[runs[long_][-1, 1] - 1]),
                channel=ch))
        elif nn > 0.5 * n and own > 0:
            continue  # a slower channel in a multi-rate trial: NaN between its samples is normal
        else:
            out.append(Finding("info", "nan_samples",
                               f"channel '{ch}' has {nn} missing sample(s) in {len(runs)} run(s)",
                               count=nn, t_start=float(t[runs[0, 0]]),
                               t_end=float(t[runs[-1, 1] - 1]), channel=ch))
    return out


def _check_saturation(trial: Trial, chans: list[str], hard_over_deg: float = 34.5) -> list[Finding]:
    out = []
    t = trial.t
    for ch in chans:
        if ch in _NOT_RATE or ch in _KINEMATIC or ch.endswith("_dot"):
            continue
        y = trial[ch]
        ok = np.isfinite(y)
        if ok.sum() < 20:
            continue
        if ch in ("delta", "delta_cmd"):
            if np.nanmedian(np.abs(y)) > MAX_RUDDER:
                continue  # no rudder angle at all (rudder_out_of_range says so)
            pinned = ok & (np.abs(y) >= np.deg2rad(hard_over_deg))
            frac = pinned.sum() / ok.sum()
            if frac > 0.01:
                a, b = _span(t, pinned)
                out.append(Finding(
                    "info", "saturation",
                    f"rudder '{ch}' is at hard-over (|delta| >= {hard_over_deg} deg) on "
                    f"{100 * frac:.1f} % of the samples: the response there is rudder-limited",
                    count=int(pinned.sum()), t_start=a, t_end=b, channel=ch))
            continue
        lo, hi = np.nanmin(y), np.nanmax(y)
        rng = hi - lo
        if rng <= 0:
            continue
        for level, side in ((hi, "maximum"), (lo, "minimum")):
            at = ok & (np.abs(y - level) <= 1e-9 * max(1.0, abs(level)))
            # pinned: at the extreme on >= 2 % of samples in runs of >= 3 samples
            runs = nan_runs(np.where(at, np.nan, 0.0))
            long_runs = runs[(runs[:, 1] - runs[:, 0]) >= 3] if len(runs) else runs
            cnt = int(np.sum(long_runs[:, 1] - long_runs[:, 0])) if len(long_runs) else 0
            if cnt >= 0.02 * ok.sum() and len(np.unique(y[ok])) > 3:
                out.append(Finding(
                    "info", "saturation",
                    f"channel '{ch}' sits at its {side} {level:.6g} on {cnt} samples "
                    f"({100 * cnt / ok.sum():.1f} %): saturated or clipped there",
                    count=cnt, t_start=float(t[long_runs[0, 0]]),
                    t_end=float(t[long_runs[-1, 1] - 1]), channel=ch))
    return out



# --- what to do: the format-spec line for the log's reader --------------------------------------
def spec_hint(trial: Trial, channel: str, *, sign: bool = False, take: str | None = None,
              unit: str | None = None, rename: str | None = None) -> str:
    """The format-spec change that fixes ``channel`` for this log's reader, as words with the
    YAML line: flip its sign (``sign``), read it from the column / decoded channel / message
    field of channel ``take`` instead, give it another ``unit``, or ``rename`` it (a channel
    renamed away is not used as that channel: ``r`` renamed ``r_logged`` lets usvid derive the
    yaw rate from the heading). The line is the user's own
    column (``meta["spec_columns"]``) changed; for a shipped preset read without ``--format``,
    a copy of the preset; for the NMEA readers without a column, a spec naming the decoded
    channel."""
    meta = trial.meta
    cols = meta.get("spec_columns") or {}
    reader = meta.get("reader")
    src_name = meta.get("spec") or ""
    shipped = meta.get("spec_shipped")
    base = dict(cols.get(take or channel) or {})
    if not base and reader in ("nmea0183", "nmea2000"):
        base = {"col": take or channel}
    if not base:
        return (f"map '{channel}' in the format spec (columns: {channel}: ...) to the right "
                "source column with its unit and sign")
    base.pop("optional", None)
    if sign:
        if base.get("sign") == -1:
            base.pop("sign")
        else:
            base["sign"] = -1
    if unit is not None:
        base["unit"] = unit
    if rename is not None:
        entry = f"{rename}: {flow_yaml(base)}"
        if reader in ("nmea0183", "nmea2000") and not cols:
            return (f"give a format spec with `reader: {reader}` and `columns: {{{entry}}}` "
                    f"(--format): '{channel}' is then kept as '{rename}', not used as "
                    f"'{channel}'")
        return f"rename its `{channel}:` line in the format spec to `{entry}`" + (
            f" (a copy of the shipped spec '{shipped}', given with --format)" if shipped else "")
    line = f"columns: {{{channel}: {flow_yaml(base)}}}"
    if shipped:
        name = shipped
        part = (f" (its {src_name.split('(')[1].rstrip(')')} columns)" if "(" in src_name
                else "")
        return (f"copy the shipped spec '{name}' (usvid.io.shipped_spec_path('{name}')), change "
                f"the line{part} to `{channel}: {flow_yaml(base)}` and give the copy with "
                "--format")
    if not cols and reader in ("nmea0183", "nmea2000"):
        return (f"give a format spec with `reader: {reader}` and `{line}` (--format; the other "
                "channels are decoded as before)")
    where = f" {src_name}" if src_name and not src_name.startswith("<") else ""
    return f"in the format spec{where} write `{line}`"


def flow_yaml(d: dict[str, Any]) -> str:
    """A mapping as one line of YAML flow style (``{col: 8, unit: deg}``; strings quoted when
    YAML would read them otherwise)."""
    def val(v: Any) -> str:
        if isinstance(v, dict):
            return flow_yaml(v)
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str) and not re.fullmatch(r"[A-Za-z_/][A-Za-z0-9_./]*", v):
            return '"' + v.replace('"', '\\"') + '"'
        return str(v)
    return "{" + ", ".join(f"{k}: {val(v)}" for k, v in d.items()) + "}"



# --- degenerate data: errors ----------------------------------------------------------------------
#: Steering channels: constant over a whole log, no steering response can be identified (a
#: propeller rate held constant is the usual trial; a rudder or a thruster differential held
#: constant steers nothing).
STEERING = ("delta", "delta_cmd")


def _constant(y: np.ndarray) -> bool:
    v = y[np.isfinite(y)]
    return bool(len(v)) and float(np.ptp(v)) <= 1e-9 * max(1.0, float(np.max(np.abs(v))))


def _check_actuators(trial: Trial) -> list[Finding]:
    """A steering channel (rudder, or the differential of a thruster pair) that holds one value
    over the whole log (at least 20 samples and :data:`MIN_PHYSICS_S`) is an error when no other
    steering channel moves (a warning otherwise); a rudder angle beyond :data:`MAX_RUDDER` is
    explained."""
    out: list[Finding] = []
    t = trial.t
    cands: list[tuple[str, np.ndarray, str]] = [(c, trial[c], c) for c in STEERING
                                                if trial.has(c)]
    pair = next(((a, b) for a, b in THRUSTER_PAIRS if trial.has(a) and trial.has(b)), None)
    if pair is not None:
        a, b = pair
        cands.append((f"'{a}' - '{b}'", trial[a] - trial[b], a))
    moved = [c for _, y, c in cands if np.isfinite(y).any() and not _constant(y)]
    for what, y, ch in cands:
        ok = np.isfinite(y)
        if not ok.any():
            continue
        span = float(t[ok][-1] - t[ok][0]) if ok.sum() > 1 else 0.0
        if ch.startswith("delta") and np.nanmedian(np.abs(y)) > MAX_RUDDER:
            out.append(Finding(
                "warning", "rudder_out_of_range",
                f"rudder channel '{ch}' reads {math.degrees(float(np.nanmedian(y))):.1f} deg "
                f"(median): beyond any rudder's travel (at most about "
                f"{math.degrees(MAX_RUDDER):.0f} deg); the sensor is not calibrated or not "
                "connected, or the field holds another quantity - it is no rudder angle",
                count=int(ok.sum()), t_start=float(t[ok][0]), t_end=float(t[ok][-1]),
                channel=ch, data={"median_deg": math.degrees(float(np.nanmedian(y)))}))
        if ok.sum() < 20 or span < MIN_PHYSICS_S or not _constant(y):
            continue
        v0 = float(y[ok][0])
        value = f"{math.degrees(v0):.2f} deg" if ch.startswith("delta") else f"{v0:.6g}"
        if ch.startswith("delta"):
            other = next((c for c in ("delta_port", "delta_cmd", "delta") if c != ch
                          and trial.has(c) and not _constant(trial[c])), None)
            fix = (f"if it did move, this is not the channel: {spec_hint(trial, ch, take=other)}"
                   if other else f"if it did move, map the right one: {spec_hint(trial, ch)}")
            name = f"rudder channel '{ch}'"
        else:
            fix = ("if they did differ, map the thruster channels: "
                   + spec_hint(trial, pair[0]) + f"; the same for '{pair[1]}'")
            name = f"the thruster differential {what}"
        alone = not moved  # (another steering channel that moves: only this one is stuck)
        out.append(Finding(
            "error" if alone else "warning", "actuator_constant",
            f"{name} holds {value} on all {int(ok.sum())} samples over {span:.1f} s"
            + (": nothing steered in this log, so no steering response can be identified"
               if alone else f", while {', '.join(repr(c) for c in moved)} moves: it is not "
               "used for steering, or logged from another device") + f"; {fix}",
            count=int(ok.sum()), t_start=float(t[ok][0]), t_end=float(t[ok][-1]), channel=ch,
            data={"value": v0}))
    return out


def _check_position_jumps(trial: Trial, stale_rows: np.ndarray | None) -> list[Finding]:
    """Consecutive valid fixes (lat/lon, or x/y without them) further apart than
    :data:`MAX_SPEED` times their time difference: an error (no vessel moves so)."""
    t = trial.t
    if trial.has("lat") and trial.has("lon"):
        lat, lon = trial["lat"].copy(), trial["lon"].copy()
        if stale_rows is not None:
            lat[stale_rows] = np.nan
        ok = np.isfinite(lat) & np.isfinite(lon)
        if ok.sum() < 2:
            return []
        la, lo = np.radians(lat[ok]), np.radians(lon[ok])
        # great-circle distance (haversine, mean Earth radius 6371.0 km)
        h = (np.sin(np.diff(la) / 2) ** 2
             + np.cos(la[1:]) * np.cos(la[:-1]) * np.sin(np.diff(lo) / 2) ** 2)
        dist = 2 * 6_371_000.0 * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))
        which = "lat/lon"
    elif trial.has("x") and trial.has("y"):
        x, y = trial["x"], trial["y"]
        ok = np.isfinite(x) & np.isfinite(y)
        if ok.sum() < 2:
            return []
        dist = np.hypot(np.diff(x[ok]), np.diff(y[ok]))
        which = "x/y"
    else:
        return []
    tt = t[ok]
    dt = np.diff(tt)
    air = (trial.meta.get("vehicle") or {}).get("kind", "") in (
        "fixed-wing aircraft", "VTOL aircraft", "helicopter", "multicopter")
    vmax = MAX_SPEED_AIR if air else MAX_SPEED
    with np.errstate(divide="ignore", invalid="ignore"):
        jump = (dist > 10.0) & (dist > vmax * np.maximum(dt, 0.0))
    if not jump.any():
        return []
    i = np.flatnonzero(jump)
    k = int(i[np.argmax(dist[i])])
    big = float(dist[k])
    reader = trial.meta.get("reader")
    who = {"nmea2000": "source address", "nmea0183": "talker"}.get(reader or "")
    fix = (f"if two receivers alternate, take one: a format spec with `reader: {reader}` and "
           "`columns: {lat: {col: lat, source: S}, lon: {col: lon, source: S}}` (S: the "
           f"receiver's {who}, as the several_sources finding lists them)" if who else
           "check the position columns (their unit: degrees, not radians or 1e-7 degrees) "
           "and the receiver's fix quality")
    return [Finding(
        "error", "position_jump",
        f"the positions ({which}) jump {len(i)} time(s) by more than a vessel can move "
        f"(largest {big / 1000:.3g} km in {float(dt[k]):.3g} s at t = {float(tt[k + 1]):.2f} s, "
        f"more than {vmax:g} m/s): these are no motion (a bad fix, or two sources); use only "
        f"the part of the log on one side of them (LOG:T0:T1), or {fix}",
        count=len(i), t_start=float(tt[i[0] + 1]), t_end=float(tt[i[-1] + 1]), channel="lat"
        if which == "lat/lon" else "x", data={"largest_m": big, "max_speed_m_s": vmax})]


def _check_time_backwards(trial: Trial) -> list[Finding]:
    """Time running backwards, as the reader found it (it sorted or re-timed the records): an
    error when a clock reset was found or more than 1 % of the records (at least 3) went
    backwards; records slightly out of order (jitter) stay the reader's warning."""
    n = max(len(trial), 1)
    back = [f for f in trial.findings if f.code == "non_monotonic_time"]
    resets = [b for b in trial.meta.get("time_breaks", []) if b.get("kind") == "clock_reset"]
    repaired = [f for f in trial.findings if f.code == "clock_reset_repaired"]
    n_back = sum(f.count for f in back)
    if not resets and not repaired and not (n_back >= 3 and n_back > 0.01 * n):
        return []
    what = []
    if n_back:
        what.append(f"{n_back} record(s) earlier than the one before (sorted into place)")
    if resets or repaired:
        k = len(resets) + sum(f.count for f in repaired)
        what.append(f"{k} clock reset(s) (the clock continued one step later)")
    return [Finding(
        "error", "time_backwards",
        f"time runs backwards in this log: {'; '.join(what)}: a clock that was reset, or "
        "records of two runs joined; usvid put the records in order, which is right only for "
        "jitter - give each run as its own log (LOG:T0:T1), or drop the late records with "
        "`non_monotonic: reject` in the format spec", count=n_back + len(resets),
        channel="t")]


# --- physics checks ----------------------------------------------------------------------------
def step_mask(prep: Trial, dt: float, window_s: float) -> np.ndarray:
    """Grid samples within a derivative window of a heading step (:mod:`usvid.prep.glitches`,
    found at the compass's own samples; times in ``meta["heading_steps"]``)."""
    t = prep.t
    out = np.zeros(len(t), dtype=bool)
    half = window_samples(window_s, dt) * dt
    for ts in prep.meta.get("heading_steps", []):
        out |= np.abs(t - ts) <= half + 1e-9
    return out


def _level(prep: Trial) -> bool:
    """True unless the roll or pitch channel exceeds :data:`MAX_LEVEL` on more than 10 % of
    its samples."""
    for ch in ("phi", "theta"):
        if prep.has(ch):
            a = np.abs(prep[ch])
            a = a[np.isfinite(a)]
            if len(a) and np.mean(a > MAX_LEVEL) > 0.1:
                return False
    return True


def _check_yaw_rate(prep: Trial, measured: set[str], dt: float, window_s: float) -> list[Finding]:
    if not prep.has("psi"):
        return [Finding("info", "no_heading", "no heading channel 'psi': yaw rate not checked")]
    t = prep.t
    out: list[Finding] = []
    # glitches of a few tenths of a degree to a few degrees: repaired before the derivative (a
    # 1-deg glitch is 1 deg/s in a 1-s derivative, which would hide a good gyro's agreement)
    w = max(window_s, 2.0)
    psi = unwrap_angle(prep["psi"])
    spikes = step_mask(prep, dt, w)
    # glitches were found and repaired at the compass's own samples, before resampling
    n_glitch = int(prep.meta.get("heading_glitches", 0))
    if n_glitch:
        gt = prep.meta.get("heading_glitch_times") or [None]
        a, b = gt[0], gt[-1]
        out.append(Finding(
            "warning", "heading_glitch",
            f"{n_glitch} heading sample(s) leave the heading's course (glitches of more than "
            f"{math.degrees(GLITCH_MIN):.1f} deg and 6 noise standard deviations off its course, "
            "a running median); repaired by interpolation for the checks and the manoeuvre "
            "metrics", count=n_glitch, t_start=a, t_end=b, channel="psi",
            data={"count": n_glitch}))
    # derivative and candidates smoothed over at least 2 s alike: the heading's noise
    # differentiated over 1 s would decorrelate a good gyro on a straight run
    ref = savgol_derivative(psi, dt, w)
    if spikes.any():
        a, b = _span(t, spikes)
        n_steps = len(prep.meta.get("heading_steps", []))
        out.append(Finding(
            "warning", "heading_jump",
            f"the heading jumps {n_steps} time(s) by more than {math.degrees(STEP_MIN):.0f} deg "
            f"faster than any vessel turns ({math.degrees(MAX_TURN_RATE):.0f} deg/s: records of "
            f"different runs or sensors joined, a compass re-aligned); the "
            f"{int(spikes.sum())} samples around the jumps are left out of the yaw-rate and "
            "rudder checks", count=int(spikes.sum()), t_start=a, t_end=b, channel="psi",
            data={"steps": n_steps}))
        ref = np.where(spikes, np.nan, ref)
    turned = np.nanmax(psi) - np.nanmin(psi) if np.isfinite(psi).any() else 0.0
    if not np.isfinite(ref).any() or np.nanstd(ref) < np.deg2rad(0.05) or turned < MIN_TURN:
        return out + [Finding("info", "no_turning",
                              f"heading hardly changes ({math.degrees(turned):.1f} deg over the "
                              "log): yaw rate and rudder sign cannot be checked")]
    vehicle = prep.meta.get("vehicle") or {}
    if vehicle.get("surface_vessel") is False:
        return out + [Finding(
            "info", "not_checked_vehicle",
            f"the yaw rate is not checked against the heading: the log is from a "
            f"{vehicle.get('kind')}, whose body-axis rate is no heading rate when it banks or "
            "pitches")]
    if not _level(prep):
        return out + [Finding(
            "info", "not_level",
            f"the vehicle rolls or pitches beyond {math.degrees(MAX_LEVEL):.0f} deg on more "
            "than 10 % of the log: a body-axis yaw rate is not d(psi)/dt there, so the yaw "
            "rate is not checked against the heading")]
    matches = []
    for ch in prep.channels:
        if ch in _NOT_RATE or ch not in measured:
            continue
        m = _ls_match(ch, savgol_smooth(prep[ch], dt, w), ref)
        if m is not None:
            matches.append(m)
    # a yaw rate only when its gain is a unit conversion and it is no input: a rudder or
    # thruster command follows the yaw rate too (through the hull's response, with its gain)
    good = [m for m in matches if abs(m.corr) >= 0.95 and m.r2 >= 0.85
            and m.name not in _INPUTS and not m.name.startswith(_INPUT_PREFIXES)
            and (m.name == "r" or m.explanation() is not None)]
    good.sort(key=lambda m: -abs(m.corr))
    best = good[0] if good else None
    span = (float(t[0]), float(t[-1]))

    def describe(m: Match) -> str:
        ex = m.explanation()
        words = ex[1] if ex else f"is proportional with gain {m.gain:.3g}"
        return (f"'{m.name}' {words} (correlation {m.corr:+.3f}, d(psi)/dt = {m.gain:.3g} x "
                f"'{m.name}')")

    r_match = next((m for m in matches if m.name == "r"), None)
    if "r" in measured and prep.has("r"):
        if r_match is not None and abs(r_match.corr) >= 0.95:
            ex = r_match.explanation()
            if ex is not None and ex[0] == 1.0:
                return out
            code = "yaw_rate_sign" if ex is not None and ex[0] < 0 else "yaw_rate_scale"
            if ex is not None and abs(ex[0]) == 1.0 and ex[0] < 0:
                fix = "flip its sign: " + spec_hint(prep, "r", sign=True)
            elif ex is not None and prep.meta.get("reader") in ("nmea0183", "nmea2000"):
                fix = "the reader delivers r in rad/s: check the sender's unit"
            elif ex is not None:
                to = "deg/s" if abs(ex[0]) > 1 else "rad/s"
                fix = "fix its angle unit: " + spec_hint(prep, "r", unit=to, sign=ex[0] < 0)
            else:
                fix = "check its unit"
            out.append(Finding(
                "error", code,
                f"yaw rate channel {describe(r_match)} compared with the time derivative of the "
                f"heading; {fix}",
                count=r_match.n, t_start=span[0], t_end=span[1], channel="r",
                data={"corr": r_match.corr, "gain": r_match.gain}))
            return out
        corr_r = r_match.corr if r_match is not None else float("nan")
        lag = _lag_match(savgol_smooth(prep["r"], dt, w), ref, dt) if best is None else None
        if (lag is not None and lag["corr"] >= 0.7 and lag["corr"] >= corr_r + 0.2
                and 0.7 <= lag["gain"] <= 1.3 and lag["lag_s"] > 0):
            out.append(Finding(
                "warning", "yaw_rate_lag",
                f"channel 'r' follows d(psi)/dt {lag['lag_s']:.1f} s late (correlation "
                f"{lag['corr']:+.2f} at that delay, {corr_r:+.2f} without; gain "
                f"{lag['gain']:.2f}): a filtered or delayed rate of turn. A fit would take the "
                "delay for the vessel's response; to derive the yaw rate from the heading "
                "instead, " + spec_hint(prep, "r", rename="r_logged"),
                count=r_match.n if r_match else 0, t_start=span[0], t_end=span[1],
                channel="r", data={"corr_r": corr_r, **lag}))
            return out
        if best is None and r_match is not None and r_match.corr >= 0.3 \
                and 0.7 <= r_match.gain <= 1.3:
            # same sign and unit, but loose: little yaw motion against heading/gyro noise (a
            # straight run) lowers the correlation, not the regression gain of d(psi)/dt on r,
            # which is ~0 for a channel unrelated to the yaw rate; no other channel fits better,
            # so this is no wrong column
            out.append(Finding(
                "warning", "yaw_rate_weak",
                f"channel 'r' follows d(psi)/dt with the right sign and unit (gain "
                f"{r_match.gain:.3g}) but only loosely (correlation {r_match.corr:+.3f}): "
                f"little yaw motion against the noise of heading and gyro; it is kept as the "
                f"yaw rate", count=r_match.n, t_start=span[0], t_end=span[1], channel="r",
                data={"corr": r_match.corr, "gain": r_match.gain}))
            return out
        shown = f"{corr_r:+.2f}" if math.isfinite(corr_r) else "none"
        if best is not None:
            msg = (f"channel 'r' is not the yaw rate: it does not follow d(psi)/dt (correlation "
                   f"{shown}); channel {describe(best)}, so '{best.name}' is the yaw rate - "
                   + spec_hint(prep, "r", take=best.name))
        else:
            msg = (f"channel 'r' does not follow d(psi)/dt (correlation {shown}) and no "
                   "other channel does either: the yaw rate is not in this log - to derive it "
                   "from the heading, " + spec_hint(prep, "r", rename="r_logged"))
        out.append(Finding(
            "error", "yaw_rate_column", msg, count=r_match.n if r_match else 0,
            t_start=span[0], t_end=span[1], channel="r",
            data={"corr_r": corr_r, "yaw_rate_channel": best.name if best else None,
                  "corr": best.corr if best else None, "gain": best.gain if best else None}))
    elif best is not None:
        out.append(Finding(
            "info", "yaw_rate_found",
            f"no channel 'r', but channel {describe(best)}: '{best.name}' is a yaw rate",
            count=best.n, t_start=span[0], t_end=span[1], channel=best.name,
            data={"yaw_rate_channel": best.name, "corr": best.corr, "gain": best.gain}))
    return out


#: Longest delay searched between a yaw rate and d(psi)/dt [s].
MAX_LAG_S = 5.0
#: Least heading change over the log [rad] for the yaw-rate check (a straight run weaving by
#: a degree or two against a compass's noise says nothing about the yaw-rate channel).
MIN_TURN = math.radians(2.0)


def _lag_match(r: np.ndarray, ref: np.ndarray, dt: float) -> dict | None:
    """The delay [s] (positive: ``r`` late) within +-:data:`MAX_LAG_S` at which ``r`` best
    correlates with ``ref``, with that correlation and the gain of ``ref`` on ``r`` there."""
    best = None
    for k in range(-int(MAX_LAG_S / dt), int(MAX_LAG_S / dt) + 1, max(1, int(0.1 / dt))):
        a = r[k:] if k >= 0 else r[:k]
        b = ref[:len(ref) - k] if k >= 0 else ref[-k:]
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < 20 or np.std(a[ok]) == 0 or np.std(b[ok]) == 0:
            continue
        c = float(np.corrcoef(a[ok], b[ok])[0, 1])
        if best is None or c > best["corr"]:
            best = {"lag_s": k * dt, "corr": c,
                    "gain": float(a[ok] @ b[ok] / (a[ok] @ a[ok]))}
    return best


def _check_body_velocity(prep: Trial, measured: set[str], dt: float, window_s: float
                         ) -> list[Finding]:
    if not (prep.has("x") and prep.has("y")):
        return []
    w = max(window_s, 2.0)  # velocities from positions need a longer window than rates
    xd = savgol_derivative(prep["x"], dt, w)
    yd = savgol_derivative(prep["y"], dt, w)
    has_psi = prep.has("psi")
    uk, vk = earth_to_body(xd, yd, prep["psi"]) if has_psi else (None, None)
    # expected noise of the kinematic velocity: position noise (residual about a smooth fit)
    # times the noise gain of the SG derivative (root of the sum of its squared coefficients)
    n_w = window_samples(w, dt)
    gain = float(np.sqrt(np.sum(savgol_coeffs(n_w, 3, deriv=1, delta=dt) ** 2)))
    pos_noise = float(np.nanstd(prep["x"] - savgol_derivative(prep["x"], dt, w, deriv=0)))
    noise = gain * pos_noise
    t = prep.t
    out = _check_speed(prep, measured, np.hypot(xd, yd), noise)
    for ch, ref in (("u", uk), ("v", vk)):
        if ref is None or ch not in measured or not prep.has(ch):
            continue
        y = prep[ch]
        ok = np.isfinite(y) & np.isfinite(ref)
        if ok.sum() < 20:
            continue
        err = float(np.sqrt(np.mean((y[ok] - ref[ok]) ** 2)))
        scale = float(np.sqrt(np.mean(ref[ok] ** 2)))
        # agreement: within 30 % of the signal plus 2 cm/s plus 3 sigma of differentiation noise
        if err <= 0.3 * scale + 0.02 + 3.0 * noise:
            continue
        m = _ls_match(ch, y, ref)
        a, b = y[ok], ref[ok]
        g = float(a @ b / (a @ a)) if a @ a > 0 else float("nan")
        rel = float(np.sqrt(np.mean((b - g * a) ** 2))) / max(scale, 1e-12)
        sign_words = ""
        if rel <= 0.2 + 3.0 * noise / max(scale, 1e-12):  # proportional: a sign or a scale
            if abs(g + 1.0) <= 0.1:
                sign_words = " It follows the kinematic value with the opposite sign."
            else:
                sign_words = (f" It is proportional to it: kinematic = {g:.3g} x '{ch}' "
                              f"(gain {g:.3g}).")
        corr = m.corr if m is not None else float("nan")
        out.append(Finding(
            "warning", f"{ch}_mismatch",
            f"channel '{ch}' disagrees with the body-frame velocity from d(x, y)/dt rotated by "
            f"psi: RMS difference {err:.3f} m/s against an RMS of {scale:.3f} m/s (correlation "
            f"{corr:+.2f}).{sign_words} Either it is measured elsewhere or it is another "
            f"quantity; it is not used as '{ch}'",
            count=int(ok.sum()), t_start=float(t[0]), t_end=float(t[-1]), channel=ch,
            data={"rms_diff": err, "rms_kinematic": scale, "corr": corr}))
    return out


def _check_speed(prep: Trial, measured: set[str], speed: np.ndarray, noise: float
                 ) -> list[Finding]:
    """Measured speed (``U`` or ``sog``) against |d(x, y)/dt|: a constant factor means a wrong
    time base (the clock of ``t`` runs fast or slow) or scaled positions."""
    out = []
    for ch in ("U", "sog"):
        if ch not in measured or not prep.has(ch):
            continue
        y = prep[ch]
        ok = np.isfinite(y) & np.isfinite(speed) & (speed > 0.1)  # moving: > 0.1 m/s
        if ok.sum() < 20:
            continue
        a, b = y[ok], speed[ok]
        if not a @ a > 0:
            continue  # the measured speed is zero throughout: no factor to speak of
        g = float(a @ b / (a @ a))
        rel = float(np.sqrt(np.mean((b - g * a) ** 2)) / np.sqrt(np.mean(b**2)))
        if not (math.isfinite(g) and math.isfinite(rel)) or abs(g - 1.0) <= 0.03 or rel > 0.3:
            continue  # agrees within 3 %, or no proportional relation to speak of
        t = prep.t
        out.append(Finding(
            "warning", "speed_scale",
            f"the speed from the positions, |d(x, y)/dt|, is {100 * (g - 1):+.1f} % off the "
            f"measured speed '{ch}' (factor {g:.4f}, RMS scatter {100 * rel:.0f} %): either "
            f"the time stamps run {'slow' if g > 1 else 'fast'} against the clock of the speed "
            f"sensor (they advance {1 / g:.3f} s per second of it) or the positions are scaled; "
            f"check the time column first",
            count=int(ok.sum()), t_start=float(t[0]), t_end=float(t[-1]), channel=ch,
            data={"factor": g, "rel_scatter": rel}))
    return out


def _nomoto_sign(prep: Trial, cmd: np.ndarray, dt: float, window_s: float,
                 use: np.ndarray | None = None) -> dict | None:
    """Least-squares ``r' = a cmd + b r + c`` with r = d(psi)/dt (on the samples ``use``, away
    from heading steps); returns a, its t-value, R^2."""
    psi = unwrap_angle(prep["psi"])
    r = savgol_derivative(psi, dt, 2 * window_s)
    rd = savgol_derivative(psi, dt, 2 * window_s, order=3, deriv=2)
    ok = np.isfinite(r) & np.isfinite(rd) & np.isfinite(cmd)
    ok &= ~step_mask(prep, dt, 2 * window_s)
    if use is not None:
        ok &= use
    if ok.sum() < 50 or np.std(cmd[ok]) == 0:
        return None
    A = np.column_stack([cmd[ok], r[ok], np.ones(ok.sum())])
    A[:, 0] /= np.std(cmd[ok])
    coef, *_ = np.linalg.lstsq(A, rd[ok], rcond=None)
    res = rd[ok] - A @ coef
    dof = max(1, ok.sum() - 3)
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.pinv(A.T @ A)
    tval = float(coef[0] / np.sqrt(max(cov[0, 0], 1e-300)))
    return {"a": float(coef[0] / np.std(cmd[ok])), "t_value": tval, "n": int(ok.sum())}


def _check_rudder_sign(prep: Trial, dt: float, window_s: float) -> list[Finding]:
    out: list[Finding] = []
    if not prep.has("psi"):
        return out
    t = prep.t
    moving = moving_samples(prep)
    cmds = [ch for ch in ("delta", "delta_cmd") if prep.has(ch)]
    pair = next(((a, b) for a, b in THRUSTER_PAIRS if prep.has(a) and prep.has(b)), None)
    if moving is not None and (cmds or pair) and moving.sum() * dt < MIN_MOVING_S:
        return [Finding(
            "info", "not_under_way",
            f"the vessel makes way (speed above {MIN_SPEED:g} m/s) on only "
            f"{moving.sum() * dt:.1f} s of the log (at least {MIN_MOVING_S:g} s needed): the "
            "sign of its rudder or thrusters is not judged (at the dock or at anchor the "
            "heading follows wind and lines, not the rudder)",
            data={"moving_s": float(moving.sum() * dt)})]
    wrong: dict[str, dict] = {}
    for ch in cmds:
        d = prep[ch]
        if np.nanstd(d) < np.deg2rad(0.5):
            continue
        fit = _nomoto_sign(prep, d, dt, window_s, moving)
        if fit is None or abs(fit["t_value"]) < 5:  # weaker evidence than 5 sigma: no verdict
            continue
        if fit["a"] < 0:
            wrong[ch] = fit
    for ch, fit in wrong.items():
        # the angle and its command share the convention: flip both
        both = [c for c in cmds if c == ch or c not in wrong]
        fixes = " and ".join(f"'{c}': {spec_hint(prep, c, sign=True)}" for c in both)
        out.append(Finding(
            "error", "rudder_sign",
            f"rudder channel '{ch}' has the wrong sign: a positive '{ch}' turns the vessel to "
            f"port (r decreasing; Nomoto fit r' = a {ch} + b r + c gives a = {fit['a']:.3g} "
            f"1/s^2, t = {fit['t_value']:.1f}). usvid wants positive delta to make r positive: "
            f"give it sign: -1 - {fixes}",
            count=fit["n"], t_start=float(t[0]), t_end=float(t[-1]), channel=ch,
            data=fit))
    for port, stbd in THRUSTER_PAIRS:
        if not (prep.has(port) and prep.has(stbd)):
            continue
        diff = prep[port] - prep[stbd]
        if not np.isfinite(diff).any() or np.nanstd(diff) == 0:
            break
        fit = _nomoto_sign(prep, diff, dt, window_s, moving)
        if fit is not None and abs(fit["t_value"]) >= 5 and fit["a"] < 0:
            out.append(Finding(
                "error", "thruster_sign",
                f"thruster differential '{port}' - '{stbd}' turns the vessel to port (fit "
                f"r' = a ({port} - {stbd}) + b r + c gives a = {fit['a']:.3g}, t = "
                f"{fit['t_value']:.1f}); more port thrust should turn it to starboard "
                f"(tau_r = (T_port - T_stbd) b/2): port and starboard are probably swapped - "
                f"swap them: '{port}': {spec_hint(prep, port, take=stbd)} and '{stbd}': "
                f"{spec_hint(prep, stbd, take=port)}",
                count=fit["n"], t_start=float(t[0]), t_end=float(t[-1]), channel=port,
                data=fit))
        break
    return out


def position_scale(
    a_x: np.ndarray, a_y: np.ndarray, b_x: np.ndarray, b_y: np.ndarray
) -> dict[str, float] | None:
    """Least-squares scale ``k`` with ``b - mean(b) = k (a - mean(a))`` over both axes.

    Returns ``{"factor", "residual_m", "n"}`` or ``None`` with fewer than 10 common samples or no
    motion. The residual is the RMS [m] of what the scaled fit leaves.
    """
    ok = np.isfinite(a_x) & np.isfinite(a_y) & np.isfinite(b_x) & np.isfinite(b_y)
    if ok.sum() < 10:
        return None
    ax, ay = a_x[ok] - a_x[ok].mean(), a_y[ok] - a_y[ok].mean()
    bx, by = b_x[ok] - b_x[ok].mean(), b_y[ok] - b_y[ok].mean()
    den = float(ax @ ax + ay @ ay)
    if den <= 1e-6:
        return None
    k = float((ax @ bx + ay @ by) / den)
    res = np.concatenate([bx - k * ax, by - k * ay])
    return {"factor": k, "residual_m": float(np.sqrt(np.mean(res**2))), "n": int(ok.sum())}


def _check_position_sources(trial: Trial, stale_rows: np.ndarray | None) -> list[Finding]:
    out: list[Finding] = []
    if not (trial.has("lat") and trial.has("lon")):
        return out
    lat, lon = trial["lat"].copy(), trial["lon"].copy()
    if stale_rows is not None:
        lat[stale_rows] = np.nan
        lon[stale_rows] = np.nan
    n, e, _ = geodetic_to_ned(lat, lon)
    t = trial.t
    for gx, gy in POSITION_GROUPS[1:]:
        if not (trial.has(gx) and trial.has(gy)):
            continue
        fit = position_scale(n, e, trial[gx], trial[gy])
        if fit is None:
            continue
        swapped = position_scale(n, e, trial[gy], trial[gx])
        if swapped is not None and swapped["residual_m"] < 0.5 * fit["residual_m"]:
            out.append(Finding(
                "warning", "position_axes",
                f"'{gx}'/'{gy}' match east/north from lat/lon, not north/east: the axes are "
                f"swapped (factor {swapped['factor']:.4f}, residual {swapped['residual_m']:.2f} m)",
                count=swapped["n"], t_start=float(t[0]), t_end=float(t[-1]), channel=gx,
                data=swapped))
            continue
        k = fit["factor"]
        if abs(k - 1.0) > 0.01:
            out.append(Finding(
                "warning", "position_scale",
                f"positions '{gx}'/'{gy}' are {100 * (k - 1):+.1f} % larger than the positions "
                f"computed from lat/lon (scale factor {k:.4f}, residual {fit['residual_m']:.3f} m "
                f"after scaling): the two position sources disagree by a constant factor; "
                f"usvid uses the geodetic positions",
                count=fit["n"], t_start=float(t[0]), t_end=float(t[-1]), channel=gx,
                data=fit))
    return out


def audit(trial: Trial, *, window_s: float = 1.0,
          prepared: PreparedTrial | None = None) -> list[Finding]:
    """Check each channel of a raw trial against the physics; returns the problems found.

    Parameters
    ----------
    trial : Trial
        As read (SI units, possibly multi-rate with NaN, stale fixes, lat/lon): the time,
        record and sensor checks read its own stamps and samples.
    window_s : float
        Savitzky-Golay window [s] for the derivatives compared (d(psi)/dt, d(x, y)/dt).
    prepared : PreparedTrial, optional
        ``trial`` prepared by the one road (:func:`usvid.prep.prepare`, as the command that
        audits it also fits or measures it): the physics checks run on it, so the log is
        prepared once. Default: :func:`usvid.prep.prepare` of ``trial`` (its grid, the fastest
        message stream's rate; its heading repaired at the compass's own samples).

    Returns
    -------
    list of Finding, most severe first (errors, warnings, infos), each with a stable ``code``:
    ``time_reversal``, ``time_backwards``, ``time_repeated``, ``time_gap``,
    ``duplicate_rows``, ``stale_gnss_fix``, ``nan_run``, ``nan_samples``, ``channel_empty``,
    ``saturation``, ``actuator_constant``, ``rudder_out_of_range``, ``position_jump``,
    ``heading_jump``, ``heading_glitch``, ``yaw_rate_column``, ``yaw_rate_sign``,
    ``yaw_rate_scale``, ``yaw_rate_weak``, ``yaw_rate_found``, ``u_mismatch``,
    ``v_mismatch``, ``speed_scale``, ``rudder_sign``, ``thruster_sign``, ``position_scale``,
    ``position_axes``, ``no_heading``, ``no_turning``, ``not_level``, ``not_under_way``,
    ``too_short``, ``not_prepared``. Numerical warnings of the checks' statistics (empty
    slices, NaN) are no output: the checks test their results themselves.
    """
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        return sort_findings(_audit(trial, window_s, prepared))


def _audit(trial: Trial, window_s: float, prepared: PreparedTrial | None) -> list[Finding]:
    measured = set(trial.channels)
    chans = _numeric_channels(trial)
    findings: list[Finding] = []
    findings += _check_time(trial)
    findings += _check_time_backwards(trial)
    findings += _check_duplicates(trial, chans)
    rep = detect_stale(trial)
    stale_rows = None
    if rep is not None and rep.n_fixes:
        stale_rows = rep.mask
    if rep is not None and rep.n_fixes and (rep.n_stale or rep.group == ("lat", "lon")):
        a, b = _span(trial.t, rep.mask)
        why = ("the receiver updates slower than the log; they are treated as missing, not as "
               "zero speed" if rep.n_stale else "no stale fixes")
        findings.append(Finding(
            "warning" if rep.rate > 0.2 else "info", "stale_gnss_fix",
            f"{rep.n_stale} of {rep.n_fixes} position fixes ({100 * rep.rate:.1f} %) repeat the "
            f"previous fix exactly ({'/'.join(rep.group)}): {why}",
            count=rep.n_stale, t_start=a, t_end=b, channel=rep.group[0],
            data={"rate": rep.rate, "fixes": rep.n_fixes}))
    findings += _check_nan(trial, chans)
    findings += _check_saturation(trial, chans)
    findings += _check_actuators(trial)
    findings += _check_position_jumps(trial, stale_rows)
    findings += _check_position_sources(trial, stale_rows)
    if any(f.code == "time_stamps_collapsed" for f in trial.findings) or \
            trial.duration < MIN_PHYSICS_S:
        findings.append(Finding(
            "info", "too_short",
            f"the log spans {trial.duration:.3g} s of its time stamps (at least "
            f"{MIN_PHYSICS_S:g} s of trustworthy time are needed): the yaw rate, velocities and "
            "rudder sign are not checked"))
        return findings
    prep = prepared
    if prep is None:
        try:
            prep = prepare(trial, derivatives=False, window_s=window_s)
        except UsvidError as exc:  # the audit reports, it does not die on odd data
            findings.append(Finding(
                "warning", "not_prepared",
                f"physics checks skipped: the trial cannot be prepared ({exc})"))
            return findings
    dt = 1.0 / (prep.sample_rate or 1.0)
    findings += _check_yaw_rate(prep, measured, dt, window_s)
    findings += _check_body_velocity(prep, measured, dt, window_s)
    findings += _check_rudder_sign(prep, dt, window_s)
    return findings


#: Order of the severities in every list of findings usvid prints.
SEVERITY_RANK = {"error": 0, "warning": 1, "info": 2}


def sort_findings(findings: list[Finding]) -> list[Finding]:
    """Findings most severe first (errors, warnings, infos), in their order otherwise."""
    return sorted(findings, key=lambda f: SEVERITY_RANK.get(f.severity, 3))
