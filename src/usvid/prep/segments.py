"""Split a log at its time discontinuities (clock resets, forward jumps).

The readers (:func:`usvid.io._assemble.assemble`) locate clock resets and forward jumps of the
time stamps and list them in ``trial.meta["time_breaks"]`` (``{"t" [s], "t_before" [s], "kind",
"step_s", "record"}``; a reset's later records continue the clock one median step after the last
record before it). Nothing that differentiates, filters or integrates may run across such a break:
:func:`split_at_breaks` cuts the trial there so that each segment is fitted on its own.
"""

from __future__ import annotations

import numpy as np

from usvid.trial import Trial

#: Segments shorter than this [s] are dropped by :func:`split_at_breaks` (too short to
#: identify anything from).
MIN_SEGMENT_S = 5.0


def time_breaks(trial: Trial) -> list[dict]:
    """The time breaks the reader recorded (``meta["time_breaks"]``), or ``[]``."""
    tb = trial.meta.get("time_breaks") or []
    return [b for b in tb if isinstance(b, dict) and np.isfinite(b.get("t", np.nan))]


def split_at_breaks(trial: Trial, min_duration_s: float = MIN_SEGMENT_S
                    ) -> tuple[list[Trial], list[Trial]]:
    """Cut ``trial`` at its time breaks; returns ``(segments, dropped)``: the segments of at
    least ``min_duration_s`` [s] (named ``NAME[1]``, ``NAME[2]``, ...; no break left in them)
    and the shorter ones. A trial without breaks is returned as ``([trial], [])``."""
    tb = time_breaks(trial)
    if not tb:
        return [trial], []
    t = trial.t
    tb = sorted(tb, key=lambda b: float(b["t"]))
    starts = [-np.inf, *(float(b["t"]) for b in tb)]
    # a segment ends at the last time before its break (a forward jump's gap, resampled,
    # belongs to no segment)
    ends = [*(float(b.get("t_before", np.nextafter(b["t"], -np.inf))) for b in tb), np.inf]
    keep, dropped = [], []
    for i, (a, b) in enumerate(zip(starts, ends, strict=True)):
        sel = (t >= a) & (t <= b)
        if not sel.any():
            continue
        meta = {**trial.meta, "time_breaks": [], "segment": {"index": i + 1,
                                                             "of": len(starts)}}
        seg = trial.with_data(trial.data.loc[sel].reset_index(drop=True),
                              name=f"{trial.name or 'trial'}[{i + 1}]", meta=meta)
        ts = seg.t
        (keep if ts[-1] - ts[0] >= min_duration_s else dropped).append(seg)
    return keep, dropped
