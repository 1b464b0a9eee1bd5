"""Heading glitches: single samples (or a few) of a compass or GNSS heading that leave the
heading's course by more than its noise, found against a running median (Hampel 1974) and
repaired by linear interpolation. Used by the channel audit and by the manoeuvre metrics.
Units: time [s], heading [rad]."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.ndimage import median_filter

from usvid.prep.filters import savgol_smooth, unwrap_angle
from usvid.trial import Trial

__all__ = ["GLITCH_MIN", "GLITCH_WINDOW_S", "heading_glitches", "repair_heading",
           "repair_trial_heading"]


#: Half-width [s] of the running median that heading glitches are judged against.
GLITCH_WINDOW_S = 0.1
#: Smallest heading glitch [rad] (0.5 deg; and at least 6 robust noise standard deviations).
GLITCH_MIN = math.radians(0.5)


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
    ``meta["heading_glitches"]``; a trial repaired before is returned as it is. Inputs are not
    modified."""
    if "heading_glitches" in trial.meta:
        return trial, int(trial.meta["heading_glitches"])
    if not trial.has("psi"):
        return trial, 0
    psi = trial["psi"]
    ok = np.isfinite(psi) & np.isfinite(trial.t)
    fixed, n = repair_heading(trial.t[ok], psi[ok])
    data = trial.data
    if n:
        data = data.copy()
        col = data["psi"].to_numpy(dtype=float).copy()
        # back onto the original branch of each sample (repair_heading unwraps)
        col[ok] = fixed - 2 * np.pi * np.round((fixed - psi[ok]) / (2 * np.pi))
        data["psi"] = col
    out = replace(trial, data=data, meta={**trial.meta, "heading_glitches": n})
    return out, n
