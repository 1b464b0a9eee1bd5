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
* a constant scale factor between two position sources (lat/lon vs a file's own x/y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    heading_glitches,
    repair_trial_heading,
)
from usvid.prep.kinematics import earth_to_body
from usvid.prep.prepare import prepare
from usvid.prep.stale import POSITION_GROUPS, detect_stale
from usvid.trial import Finding, Trial

RAD = 180.0 / np.pi
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
        gap = dt > max(3.0 * med, med + 0.5)
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


# --- physics checks ----------------------------------------------------------------------------
def _check_yaw_rate(prep: Trial, measured: set[str], dt: float, window_s: float) -> list[Finding]:
    if not prep.has("psi"):
        return [Finding("info", "no_heading", "no heading channel 'psi': yaw rate not checked")]
    t = prep.t
    out: list[Finding] = []
    # glitches of a few tenths of a degree to a few degrees: repaired before the derivative (a
    # 1-deg glitch is 1 deg/s in a 1-s derivative, which would hide a good gyro's agreement)
    w = max(window_s, 2.0)
    psi = unwrap_angle(prep["psi"])
    spikes = heading_jumps(psi, window_samples(w, dt))
    # glitches were found and repaired at the compass's own samples, before resampling
    n_glitch = int(prep.meta.get("heading_glitches", 0))
    if n_glitch:
        a, b = prep.meta.get("heading_glitch_span", (None, None))
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
        out.append(Finding(
            "warning", "heading_jump",
            f"the heading jumps within one sample (glitches, or records of different runs "
            f"joined); the {int(spikes.sum())} samples around the jumps are left out of the "
            f"yaw-rate and rudder checks",
            count=int(spikes.sum()), t_start=a, t_end=b, channel="psi"))
        ref = np.where(spikes, np.nan, ref)
    if np.nanstd(ref) < np.deg2rad(0.05):
        return [Finding("info", "no_turning",
                        "heading hardly changes: yaw rate and rudder sign cannot be checked")]
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
                fix = "give it sign: -1 in the format spec"
            elif ex is not None:
                fix = "fix the angle unit of r (or psi) in the format spec"
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
        if best is not None:
            msg = (f"channel 'r' is not the yaw rate: it does not follow d(psi)/dt (correlation "
                   f"{corr_r:+.2f}); channel {describe(best)}, so '{best.name}' is the yaw rate "
                   f"- map that column to r in the format spec")
        else:
            msg = (f"channel 'r' does not follow d(psi)/dt (correlation {corr_r:+.2f}) and no "
                   f"other channel does either: the yaw rate is not in this log")
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


def heading_jumps(psi: np.ndarray, dilate: int = 0, k: float = 10.0) -> np.ndarray:
    """Bool (N,): samples where the heading [rad] steps as a glitch, widened by ``dilate``.

    A step is a glitch when its one-sample change is more than ``k`` times the median change of
    its ten neighbours and of the whole log: a real turn, however fast, builds up over several
    samples, a glitch (or two records joined) happens in one.
    """
    from scipy.ndimage import median_filter

    psi = np.asarray(psi, dtype=float)
    out = np.zeros(psi.shape, dtype=bool)
    ok = np.isfinite(psi)
    if ok.sum() < 20:
        return out
    idx = np.flatnonzero(ok)
    d = np.abs(np.diff(psi[idx]))
    local = median_filter(d, size=11, mode="nearest")
    glob = float(np.median(d))
    floor = 1e-6  # rad: a heading resolution no sensor beats
    jump = (d > k * np.maximum(local, floor)) & (d > k * max(glob, floor))
    out[idx[1:][jump]] = True
    if out.any() and dilate > 0:
        out = np.convolve(out.astype(float), np.ones(2 * dilate + 1), mode="same") > 0
    return out


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
        g = float(a @ b / (a @ a))
        rel = float(np.sqrt(np.mean((b - g * a) ** 2)) / np.sqrt(np.mean(b**2)))
        if abs(g - 1.0) <= 0.03 or rel > 0.3:
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


def _nomoto_sign(prep: Trial, cmd: np.ndarray, dt: float, window_s: float) -> dict | None:
    """Least-squares ``r' = a cmd + b r + c`` with r = d(psi)/dt; returns a, its t-value, R^2."""
    psi = prep["psi"]
    r = savgol_derivative(psi, dt, 2 * window_s)
    rd = savgol_derivative(psi, dt, 2 * window_s, order=3, deriv=2)
    ok = np.isfinite(r) & np.isfinite(rd) & np.isfinite(cmd)
    ok &= ~heading_jumps(psi, window_samples(2 * window_s, dt))
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
    for ch in ("delta", "delta_cmd"):
        if not prep.has(ch):
            continue
        d = prep[ch]
        if np.nanstd(d) < np.deg2rad(0.5):
            continue
        fit = _nomoto_sign(prep, d, dt, window_s)
        if fit is None or abs(fit["t_value"]) < 5:  # weaker evidence than 5 sigma: no verdict
            continue
        if fit["a"] < 0:
            out.append(Finding(
                "error", "rudder_sign",
                f"rudder channel '{ch}' has the wrong sign: a positive '{ch}' turns the vessel to "
                f"port (r decreasing; Nomoto fit r' = a {ch} + b r + c gives a = {fit['a']:.3g} "
                f"1/s^2, t = {fit['t_value']:.1f}). usvid wants positive delta to make r positive: "
                f"give '{ch}' sign: -1 in the format spec",
                count=fit["n"], t_start=float(t[0]), t_end=float(t[-1]), channel=ch,
                data=fit))
    for port, stbd in THRUSTER_PAIRS:
        if not (prep.has(port) and prep.has(stbd)):
            continue
        diff = prep[port] - prep[stbd]
        if np.nanstd(diff) == 0:
            break
        fit = _nomoto_sign(prep, diff, dt, window_s)
        if fit is not None and abs(fit["t_value"]) >= 5 and fit["a"] < 0:
            out.append(Finding(
                "error", "thruster_sign",
                f"thruster differential '{port}' - '{stbd}' turns the vessel to port (fit "
                f"r' = a ({port} - {stbd}) + b r + c gives a = {fit['a']:.3g}, t = "
                f"{fit['t_value']:.1f}); more port thrust should turn it to starboard "
                f"(tau_r = (T_port - T_stbd) b/2): port and starboard are probably swapped",
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


def audit(trial: Trial, *, window_s: float = 1.0) -> list[Finding]:
    """Check each channel of a raw trial against the physics; returns the problems found.

    Parameters
    ----------
    trial : Trial
        As read (SI units, possibly multi-rate with NaN, stale fixes, lat/lon).
    window_s : float
        Savitzky-Golay window [s] for the derivatives compared (d(psi)/dt, d(x, y)/dt).

    Returns
    -------
    list of Finding, most severe first (errors, warnings, infos), each with a stable ``code``:
    ``time_reversal``, ``time_repeated``, ``time_gap``, ``duplicate_rows``, ``stale_gnss_fix``,
    ``nan_run``, ``nan_samples``, ``channel_empty``, ``saturation``, ``heading_jump``,
    ``heading_glitch``, ``yaw_rate_column``, ``yaw_rate_sign``, ``yaw_rate_scale``,
    ``yaw_rate_weak``, ``yaw_rate_found``,
    ``u_mismatch``, ``v_mismatch``, ``speed_scale``, ``rudder_sign``, ``thruster_sign``,
    ``position_scale``, ``position_axes``, ``no_heading``, ``no_turning``, ``not_prepared``.
    """
    measured = set(trial.channels)
    chans = _numeric_channels(trial)
    findings: list[Finding] = []
    findings += _check_time(trial)
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
    findings += _check_position_sources(trial, stale_rows)
    try:
        fixed, n_glitch = repair_trial_heading(trial)
        if n_glitch:
            ok = np.isfinite(trial["psi"])
            bad = heading_glitches(trial.t[ok], unwrap_angle(trial["psi"][ok]))
            fixed.meta["heading_glitch_span"] = _span(trial.t[ok], bad)
        prep = prepare(fixed, derivatives=False, window_s=window_s)
    except UsvidError as exc:  # the audit reports, it does not die on odd data
        findings.append(Finding("warning", "not_prepared",
                                f"physics checks skipped: the trial cannot be prepared ({exc})"))
        return _sorted(findings)
    dt = 1.0 / (prep.sample_rate or 1.0)
    findings += _check_yaw_rate(prep, measured, dt, window_s)
    findings += _check_body_velocity(prep, measured, dt, window_s)
    findings += _check_rudder_sign(prep, dt, window_s)
    return _sorted(findings)


def _sorted(findings: list[Finding]) -> list[Finding]:
    rank = {"error": 0, "warning": 1, "info": 2}
    return sorted(findings, key=lambda f: rank.get(f.severity, 3))
