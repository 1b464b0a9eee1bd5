"""Measured manoeuvre metrics of a log: the segments of :mod:`usvid.manoeuvres.detect` measured
with the definitions of :mod:`usvid.manoeuvres.metrics` (the keys of ``usvid simulate``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.manoeuvres.detect import Segment, find_manoeuvres
from usvid.manoeuvres.drift import current_corrected_turning
from usvid.manoeuvres.metrics import turning_metrics, zigzag_metrics
from usvid.prep.filters import savgol_smooth, unwrap_angle
from usvid.prep.prepare import as_prepared
from usvid.trial import Trial


def manoeuvre_metrics(trial: Trial, segment: Segment, *, smooth_s: float = 2.0) -> dict[str, Any]:
    """Measured metrics of one segment, with the same keys as ``usvid simulate``.

    The trial is prepared (:func:`usvid.prep.prepare`, once: a prepared trial is used as it is),
    which repairs its heading glitches at the sensor's own samples (their count is
    ``heading_glitches``); then the heading is smoothed (zero-phase cubic
    Savitzky-Golay over ``smooth_s`` [s]; 0 turns it off): the maximum of noisy samples
    around a flat heading peak is biased upwards by about two noise standard deviations, which
    a cubic fit over 2 s removes without flattening the peak (a zig-zag heading peak is tens
    of seconds wide).

    Zig-zag: :func:`usvid.manoeuvres.metrics.zigzag_metrics` (overshoot_deg, period_s,
    initial_turning_time_s, time_to_check_yaw_s, ...); turning: :func:`turning_metrics`
    (advance_m, transfer_m, tactical_diameter_m, steady_diameter_m, ...), and for a turn of 540
    deg or more the current of :func:`usvid.manoeuvres.drift.imo_current` (key ``current``) and
    the metrics corrected for it (key ``corrected``, the same keys as the raw ones); both None
    for a shorter turn. Returns the segment's description merged with its metrics.
    """
    trial = as_prepared(trial, derivatives=False)
    n_glitch = trial.heading_glitches
    # 5 s of approach before the execute: the heading there is smoothed in the interior of the
    # filter window, so psi0 (the reference of every overshoot) carries the least noise
    part = trial.slice_time(segment.t_start - 5.0, segment.t_end)
    t = part.t
    if smooth_s and len(t) > 3:
        data = part.data.copy()
        data["psi"] = savgol_smooth(unwrap_angle(part["psi"]), float(np.median(np.diff(t))),
                                    smooth_s)
        part = part.with_data(data)
    out = segment.to_dict()
    out["heading_glitches"] = n_glitch  # repaired before the metrics (log's count)
    drift = None
    if segment.kind == "zigzag":
        rudder = segment.command.startswith("delta")
        m = zigzag_metrics(
            t, part["psi"], part[segment.command] if rudder else None,
            delta_amp=segment.level if rudder else None,
            psi_switch=segment.psi_switch, t_execute=segment.t_execute, first=segment.side,
            x=part["x"] if part.has("x") else None, y=part["y"] if part.has("y") else None,
        )
    elif segment.kind == "turning":
        if not (part.has("x") and part.has("y")):
            raise UsvidError(f"trial {trial.name or '?'}: a turning circle needs positions x, y")
        meas_r = "r" in part.channels and "r" not in trial.derived
        r = part["r"] if meas_r else None
        m = turning_metrics(
            t, part["x"], part["y"], part["psi"],
            U=part["U"] if part.has("U") else None, r=r, t_execute=segment.t_execute,
        )
        drift = current_corrected_turning(t, part["x"], part["y"], part["psi"], r=r,
                                          t_execute=segment.t_execute)
    else:  # pragma: no cover - kinds are ours
        raise UsvidError(f"unknown manoeuvre kind {segment.kind!r}")
    metrics = m.to_dict()
    metrics.pop("first_side", None)
    out.update(metrics)
    if segment.kind == "turning":
        # IMO MSC/Circ.1053 3.4.2.5: the current from a turn of 540 deg or more, and the
        # metrics of the track corrected for it (None for a shorter turn)
        out["current"] = drift[0].to_dict() if drift else None
        out["corrected"] = drift[1].to_dict() if drift else None
    return out


def measured_metrics(trial: Trial, **find_kw: Any) -> list[dict[str, Any]]:
    """Find every manoeuvre in ``trial`` and measure it: one dict per manoeuvre (time order)."""
    prepared = as_prepared(trial, derivatives=False)
    return [manoeuvre_metrics(prepared, s) for s in find_manoeuvres(prepared, **find_kw)]
