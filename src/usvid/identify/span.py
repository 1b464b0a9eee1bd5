"""The part of a log where every channel a model needs is logged.

Logs whose sensors start (or stop) at different times - a ROS bag recorded before the INS
publishes, thrust commands logged before the positions - hold leading or trailing stretches
where a channel is NaN throughout. Interpolation cannot fill them (nothing to interpolate
from) and a fit cannot use them; they are cut off before identification and validation, and
the output says which part was left out and why. Gaps inside the span are not touched here
(the prepared grid and the series interpolate short ones, refuse long ones).

Units: time [s].
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import Any

import numpy as np

from usvid.identify.series import IdentificationWarning

#: Leading or trailing stretches shorter than this [s] are left to the interpolation.
MIN_CUT_S = 0.5
#: Smallest share of a log the logged span must keep: a channel missing for most of a log is a
#: broken channel, refused as such where the series are built (its NaN count named), not cut.
MIN_KEPT = 0.5


def logged_span(trial: Any, channels: Iterable[str]) -> tuple[float, float, list[str]] | None:
    """``(t0, t1, late)``: the times [s] of the first and last sample at which every channel of
    ``channels`` the trial has is logged (finite), and the channels that start late or stop
    early; None when it is the whole trial (within :data:`MIN_CUT_S`), shorter than
    :data:`MIN_KEPT` of it, or no channel is finite."""
    t = np.asarray(trial.t, dtype=float)
    if t.size < 2:
        return None
    firsts, lasts = {}, {}
    for ch in channels:
        if ch not in trial.channels:
            continue
        ok = np.flatnonzero(np.isfinite(np.asarray(trial[ch], dtype=float)))
        if ok.size == 0:
            return None  # nothing logged: the series say so with the channel's name
        firsts[ch], lasts[ch] = t[ok[0]], t[ok[-1]]
    if not firsts:
        return None
    t0, t1 = max(firsts.values()), min(lasts.values())
    if t0 - t[0] < MIN_CUT_S and t[-1] - t1 < MIN_CUT_S:
        return None
    if t1 - t0 < MIN_KEPT * (t[-1] - t[0]):
        return None  # mostly missing: the series refuse the channel with its NaN count
    late = sorted(c for c in firsts if firsts[c] - t[0] >= MIN_CUT_S
                  or t[-1] - lasts[c] >= MIN_CUT_S)
    return float(t0), float(t1), late


def trim_to_logged(trial: Any, channels: Iterable[str], stacklevel: int = 3) -> Any:
    """``trial`` cut to :func:`logged_span` of ``channels`` (the same trial when nothing is
    cut), with an :class:`IdentificationWarning` naming the part left out and the channels
    that are not logged there."""
    span = logged_span(trial, channels)
    if span is None:
        return trial
    t0, t1, late = span
    t = np.asarray(trial.t, dtype=float)
    parts = []
    if t0 - t[0] >= MIN_CUT_S:
        parts.append(f"{t[0] - t[0]:.1f}-{t0 - t[0]:.1f} s")
    if t[-1] - t1 >= MIN_CUT_S:
        parts.append(f"{t1 - t[0]:.1f}-{t[-1] - t[0]:.1f} s")
    warnings.warn(f"trial {trial.name or '?'}: {' and '.join(parts)} (from its start) left out: "
                  f"{', '.join(repr(c) for c in late)} not logged there (the log's channels "
                  "start or stop at different times)", IdentificationWarning,
                  stacklevel=stacklevel)
    return trial.slice_time(t0, t1)


def kind_channels(kind: Any) -> tuple[str, ...]:
    """The logged channels a fit or replay of ``kind`` reads: its outputs, inputs and the
    heading."""
    needs = tuple(kind.regression.needs) if kind.regression is not None else ()
    return tuple(dict.fromkeys(("psi", *kind.outputs, *kind.inputs, *needs)))


__all__ = ["MIN_CUT_S", "MIN_KEPT", "kind_channels", "logged_span", "trim_to_logged"]
