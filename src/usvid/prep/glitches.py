"""Heading defects, the one definition used by the channel audit and by the manoeuvre metrics
(both read the heading through :func:`repair_trial_heading`, at the sensor's own samples):

* *glitches*: single samples (or a few) of a compass or GNSS heading that leave the heading's
  course by more than its noise, found against a running median (Hampel 1974) and repaired by
  linear interpolation;
* *held samples*: a heading that repeats its previous value exactly while the yaw rate says the
  vessel turns by more than :data:`HELD_TURN` (a compass logged faster than it updates, which
  then catches up in a jump): treated as missing;
* *steps*: the heading changing by more than :data:`STEP_MIN` faster than any vessel turns
  (:data:`MAX_TURN_RATE`): records of two runs or two compasses joined, a sensor re-aligned. A
  step is not repaired (the heading after it may be the right one); the checks leave its
  neighbourhood out.

Units: time [s], heading [rad]."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from usvid.prep.filters import savgol_smooth, unwrap_angle
from usvid.trial import Trial

__all__ = ["GLITCH_MIN", "GLITCH_WINDOW_S", "HELD_TURN", "MAX_TURN_RATE", "STEP_MIN",
           "heading_glitches", "heading_held", "heading_steps", "repair_heading",
           "repair_trial_heading"]


#: Half-width [s] of the running median that heading glitches are judged against.
GLITCH_WINDOW_S = 0.1
#: Smallest heading glitch [rad] (0.5 deg; and at least 6 robust noise standard deviations).
GLITCH_MIN = math.radians(0.5)
#: A heading step: a change of more than STEP_MIN [rad] between two samples at a rate above
#: MAX_TURN_RATE [rad/s] (small fast USVs turn at up to 30-40 deg/s; 90 deg/s is beyond any
#: vessel, while a 10 Hz compass in a 40 deg/s turn moves 4 deg a sample).
STEP_MIN = math.radians(5.0)
MAX_TURN_RATE = math.radians(90.0)


#: A run of equal heading samples is held (stale) when the yaw rate turns the vessel by more
#: than this [rad] over it (1 deg: well above a gyro's drift over a few seconds).
HELD_TURN = math.radians(1.0)


def heading_held(t: Any, psi: Any, r: Any) -> np.ndarray:
    """Mask of held heading samples: repeats of the previous heading sample (times ``t`` [s],
    heading ``psi`` [rad], NaN where none) inside a run of equal samples over which the yaw
    rate ``r`` [rad/s] (on the same times, NaN where none) integrates to more than
    :data:`HELD_TURN`. The first sample of each run is kept (it was fresh)."""
    t = np.asarray(t, dtype=float)
    psi = np.asarray(psi, dtype=float)
    r = np.asarray(r, dtype=float)
    out = np.zeros(len(t), dtype=bool)
    ok = np.flatnonzero(np.isfinite(psi) & np.isfinite(t))
    rk = np.isfinite(r) & np.isfinite(t)
    if len(ok) < 3 or rk.sum() < 3:
        return out
    tr_, rr = t[rk], r[rk]
    turned = np.concatenate(([0.0], np.cumsum(0.5 * (rr[1:] + rr[:-1]) * np.diff(tr_))))
    p = psi[ok]
    same = np.r_[False, p[1:] == p[:-1]]
    edges = np.diff(np.r_[0, same.astype(np.int8), 0])
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        t0, t1 = t[ok[a - 1]], t[ok[b - 1]]  # the run: its first (fresh) sample to its last
        turn = abs(float(np.interp(t1, tr_, turned) - np.interp(t0, tr_, turned)))
        if turn > HELD_TURN and t0 >= tr_[0] and t1 <= tr_[-1]:
            out[ok[a:b]] = True
    return out


def heading_steps(t: Any, psi: Any) -> np.ndarray:
    """Mask of heading steps: samples whose (unwrapped) heading ``psi`` [rad] differs from the
    previous finite sample by more than :data:`STEP_MIN` at a rate [rad/s] above
    :data:`MAX_TURN_RATE` (times ``t`` [s]). Time-aware, so a gateway stamping its records in
    bursts (milliseconds apart, small changes) shows none."""
    t = np.asarray(t, dtype=float)
    psi = np.asarray(psi, dtype=float)
    out = np.zeros(len(t), dtype=bool)
    ok = np.flatnonzero(np.isfinite(psi) & np.isfinite(t))
    if len(ok) < 2:
        return out
    d = np.abs(np.diff(psi[ok]))
    dt = np.diff(t[ok])
    with np.errstate(divide="ignore", invalid="ignore"):
        fast = (d > STEP_MIN) & ((dt <= 0) | (d > MAX_TURN_RATE * dt))
    out[ok[1:][fast]] = True
    return out


def heading_glitches(t: Any, psi: Any, *, passes: int = 4) -> np.ndarray:
    """Mask of heading glitches: samples of the (unwrapped) heading ``psi`` [rad] on times
    ``t`` [s] farther than max(:data:`GLITCH_MIN`, 6 sigma) from the heading's course.

    The course is a running median over +-:data:`GLITCH_WINDOW_S` (at least +-2 samples;
    Hampel 1974) followed by a cubic Savitzky-Golay fit over 0.3 s or more (it follows the
    heading's curvature, so a fast turn's entry is no glitch); sigma is the robust noise level,
    1.4826 x the median absolute deviation of the heading from its course. In each run of
    samples off the course the farthest one is a glitch when it lies off its two neighbours'
    midpoint by 3/4 of the threshold or more and by more than 2/3 of their own difference (it
    leaves the course and comes back: a step of two joined records, or a held heading catching
    up in a turn, lies between its neighbours); it is replaced by interpolation and the
    search repeated (``passes`` times: glitches of a few samples). Non-finite samples are not
    glitches."""
    t = np.asarray(t, dtype=float)
    psi = np.asarray(psi, dtype=float)
    ok = np.isfinite(psi) & np.isfinite(t)
    out = np.zeros(len(t), dtype=bool)
    if ok.sum() < 7:
        return out
    tt, pp = t[ok], psi[ok].copy()
    n = len(pp)
    dt = float(np.median(np.diff(tt)))
    k = max(int(round(GLITCH_WINDOW_S / dt)), 2)
    found = np.zeros(n, dtype=bool)
    sigma = None
    from scipy.ndimage import median_filter  # (on first use: importing usvid.prep spares it)

    for _ in range(passes):
        med = median_filter(pp, size=2 * k + 1, mode="nearest")
        res = pp - savgol_smooth(med, dt, max(0.3, (2 * k + 3) * dt))
        if sigma is None:  # the noise of the record as logged
            sigma = 1.4826 * float(np.median(np.abs(res)))
        thr = max(GLITCH_MIN, 6.0 * sigma)
        flag = np.abs(res) > thr
        edges = np.diff(np.concatenate(([0], flag.astype(np.int8), [0])))
        new = []
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
            i = a + int(np.argmax(np.abs(res[a:b])))
            if not 0 < i < n - 1:
                continue
            off = abs(pp[i] - 0.5 * (pp[i - 1] + pp[i + 1]))  # from its neighbours' midpoint
            if off > 0.75 * thr and abs(pp[i + 1] - pp[i - 1]) < 1.5 * off:
                new.append(i)
        if not new:
            break
        found[new] = True
        good = ~found
        pp[found] = np.interp(tt[found], tt[good], pp[good])
    out[np.flatnonzero(ok)] = found
    return out


def repair_heading(t: Any, psi: Any) -> tuple[np.ndarray, int]:
    """The heading ``psi`` [rad] (unwrapped) with its glitches (:func:`heading_glitches`)
    replaced by linear interpolation between the good samples around them, and the number of
    glitch samples."""
    t = np.asarray(t, dtype=float)
    p = unwrap_angle(np.asarray(psi, dtype=float))
    bad = heading_glitches(t, p)
    n = int(bad.sum())
    if n:
        good = ~bad & np.isfinite(p)
        p = p.copy()
        p[bad] = np.interp(t[bad], t[good], p[good])
    return p, n


def repair_trial_heading(trial: Trial) -> tuple[Trial, int]:
    """``trial`` with its heading glitches repaired (:func:`repair_heading` on the finite
    heading samples at their own time stamps, before any resampling blurs a glitch into its
    neighbours and the noise), and the number of glitch samples. The count is kept in
    ``meta["heading_glitches"]``, the times [s] of the glitches in
    ``meta["heading_glitch_times"]`` and of the heading steps (:func:`heading_steps`, on the
    repaired heading) in ``meta["heading_steps"]``; held samples (:func:`heading_held`) are set
    missing first and counted in ``meta["heading_held"]``. A trial repaired before is returned
    as it is. Inputs are not modified."""
    if "heading_glitches" in trial.meta:
        return trial, int(trial.meta["heading_glitches"])
    if not trial.has("psi"):
        return trial, 0
    psi = trial["psi"]
    held = heading_held(trial.t, psi, trial["r"]) if trial.has("r") else np.zeros(len(psi), bool)
    if held.any():
        psi = np.where(held, np.nan, psi)
    ok = np.isfinite(psi) & np.isfinite(trial.t)
    tt = trial.t[ok]
    fixed = unwrap_angle(psi[ok])
    bad = heading_glitches(tt, fixed)  # (repair_heading's steps, the mask kept)
    n = int(bad.sum())
    if n:
        fixed = fixed.copy()
        fixed[bad] = np.interp(tt[bad], tt[~bad], fixed[~bad])
    glitch_t = tt[bad]
    steps_t = tt[heading_steps(tt, fixed)]
    data = trial.data
    if n or held.any():
        data = data.copy()
        col = psi.copy()  # (held samples NaN: missing)
        # back onto the original branch of each sample (repair_heading unwraps)
        col[ok] = fixed - 2 * np.pi * np.round((fixed - psi[ok]) / (2 * np.pi))
        data["psi"] = col
    out = replace(trial, data=data, meta={**trial.meta, "heading_glitches": n,
                                          "heading_held": int(held.sum()),
                                          "heading_glitch_times": [float(x) for x in glitch_t],
                                          "heading_steps": [float(x) for x in steps_t]})
    return out, n
