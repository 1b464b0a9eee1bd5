"""Multi-rate alignment: put every channel of a trial on one uniform time grid.

A trial read from a multi-rate source carries the union of all time stamps with NaN where a channel
has no sample. Each channel is interpolated linearly over *its own* samples; angle channels are
unwrapped first (so 359 deg -> 1 deg interpolates through 0, not 180). Nothing is extrapolated:
grid points before a channel's first or after its last sample, or inside a gap between two of its
samples longer than ``max_gap_s``, stay NaN and are reported as a :class:`~usvid.trial.Finding`.
"""

from __future__ import annotations

import numpy as np

from usvid.errors import UsvidError
from usvid.prep.filters import nan_runs
from usvid.trial import Finding, Trial

#: Channels that are headings/courses: unwrapped before interpolation.
ANGLE_CHANNELS: frozenset[str] = frozenset({"psi", "cog", "heading", "psi_cmd", "psi_set"})


def stream_rate(t: np.ndarray, y: np.ndarray) -> float | None:
    """Samples per second [Hz] of channel ``y`` (times ``t`` [s], NaN where it has no sample):
    the rate of its message stream, the one definition of a channel's rate (the grid of
    :func:`resample`, the audit's physics checks).

    A regular stream (most of its time spent in spacings near the median spacing: the spacing
    that holds the middle of its flowing time at most twice the median spacing) has the rate
    1 / median spacing, its nominal rate: a regular log keeps its own samples on the grid,
    dropped samples and jitter do not move it. A bursty stream (a gateway stamping ten frames
    within a few milliseconds every 0.3 s: a median spacing of a millisecond) has its samples
    over the time it flows: the span less the gaps longer than max(1 s, 5 x its mean spacing).
    None with fewer than two distinct stamps.
    """
    ts = np.unique(t[np.isfinite(y) & np.isfinite(t)])
    if len(ts) < 2:
        return None
    d = np.diff(ts)
    span = float(ts[-1] - ts[0])
    flows = d <= max(1.0, 5.0 * span / len(d))
    df = np.sort(d[flows])
    if not len(df):
        return None
    med = float(np.median(df))
    # the spacing holding the middle of the flowing time (the time-weighted median spacing)
    held = float(df[np.searchsorted(np.cumsum(df), 0.5 * df.sum())])
    if held <= 2.0 * med:
        return 1.0 / med
    return len(df) / float(df.sum())


def infer_rate(trial: Trial) -> float:
    """The grid rate [Hz]: the fastest channel's :func:`stream_rate` (else the time stamps')."""
    import pandas as pd  # (on first use: `import usvid.sim` spares pandas)

    t = trial.t
    rates = []
    for ch in trial.channels:
        col = trial.data[ch]
        if not pd.api.types.is_numeric_dtype(col):
            continue
        r = stream_rate(t, col.to_numpy(dtype=float))
        if r:
            rates.append(r)
    if not rates:
        r = stream_rate(t, t)
        if not r:
            raise UsvidError(f"trial {trial.name or '?'}: fewer than two distinct time stamps")
        return r
    return max(rates)


def interp_channel(
    t: np.ndarray, y: np.ndarray, grid: np.ndarray, max_gap_s: float, angle: bool = False
) -> np.ndarray:
    """Linear interpolation of ``y(t)`` onto ``grid`` over ``y``'s own finite samples.

    NaN outside the sample span and inside gaps longer than ``max_gap_s`` [s]; angles [rad] are
    unwrapped over the samples first (the result stays unwrapped).
    """
    ok = np.isfinite(y) & np.isfinite(t)
    ts, ys = t[ok], y[ok]
    out = np.full(grid.shape, np.nan)
    if len(ts) == 0:
        return out
    order = np.argsort(ts, kind="stable")
    ts, ys = ts[order], ys[order]
    keep = np.concatenate(([True], np.diff(ts) > 0))  # duplicate stamps: keep the first
    ts, ys = ts[keep], ys[keep]
    if angle:
        ys = np.unwrap(ys)
    if len(ts) == 1:
        out[np.abs(grid - ts[0]) <= 1e-9] = ys[0]
        return out
    inside = (grid >= ts[0] - 1e-9) & (grid <= ts[-1] + 1e-9)
    g = grid[inside]
    vals = np.interp(g, ts, ys)
    idx = np.clip(np.searchsorted(ts, g, side="right"), 1, len(ts) - 1)
    gap = (ts[idx] - ts[idx - 1]) > max_gap_s
    on_sample = np.isclose(g, ts[idx - 1], rtol=0, atol=1e-9) | np.isclose(
        g, ts[idx], rtol=0, atol=1e-9
    )
    vals[gap & ~on_sample] = np.nan
    out[inside] = vals
    return out


def resample(
    trial: Trial,
    rate_hz: float | None = None,
    *,
    max_gap_s: float | None = None,
    t_start: float | None = None,
    t_end: float | None = None,
) -> Trial:
    """The trial on one uniform grid of ``rate_hz`` [Hz] (default: the fastest channel's
    :func:`stream_rate`).

    Parameters
    ----------
    trial : Trial
        Any trial (union of time stamps with NaN where a channel has no sample is fine).
    rate_hz : float, optional
        Grid rate [Hz].
    max_gap_s : float, optional
        Longest gap [s] between two samples of a channel that is bridged by interpolation;
        default ``max(1 s, 5 x`` that channel's sample interval, 1 / :func:`stream_rate`).
    t_start, t_end : float, optional
        Grid span [s]; default the trial's first and last time stamp.

    Returns
    -------
    Trial with column ``t`` uniform and every numeric channel interpolated; non-numeric columns
    are dropped. Grid points left NaN by a gap are reported as findings (``code="resample_gap"``)
    appended to ``trial.findings``; ``meta["resample"]`` holds the rate and per-channel NaN counts.
    """
    import pandas as pd  # (on first use, as in infer_rate)

    t = trial.t
    if len(t) < 2:
        raise UsvidError(f"trial {trial.name or '?'}: fewer than two samples, cannot resample")
    rate = float(rate_hz) if rate_hz is not None else infer_rate(trial)
    if not (rate > 0 and np.isfinite(rate)):
        raise UsvidError(f"resample rate must be > 0 Hz (got {rate_hz})")
    t0 = float(np.nanmin(t)) if t_start is None else float(t_start)
    t1 = float(np.nanmax(t)) if t_end is None else float(t_end)
    if not t1 > t0:
        raise UsvidError(f"trial {trial.name or '?'}: empty time span [{t0}, {t1}] s")
    n = int(np.floor((t1 - t0) * rate + 1e-6)) + 1
    grid = t0 + np.arange(n) / rate
    cols: dict[str, np.ndarray] = {"t": grid}
    findings = list(trial.findings)
    nan_counts: dict[str, int] = {}
    for ch in trial.channels:
        col = trial.data[ch]
        if not (pd.api.types.is_numeric_dtype(col) or pd.api.types.is_bool_dtype(col)):
            continue
        y = col.to_numpy(dtype=float)
        r = stream_rate(t, y)
        gap = max_gap_s if max_gap_s is not None else max(1.0, 5.0 / r if r else 1.0)
        v = interp_channel(t, y, grid, gap, angle=ch in ANGLE_CHANNELS)
        cols[ch] = v
        runs = nan_runs(v)
        nn = int(np.sum(runs[:, 1] - runs[:, 0])) if len(runs) else 0
        nan_counts[ch] = nn
        if nn and np.isfinite(y).any():
            a, b = runs[np.argmax(runs[:, 1] - runs[:, 0])]
            findings.append(
                Finding(
                    severity="warning" if nn > 0.05 * n else "info",
                    code="resample_gap",
                    message=(
                        f"channel '{ch}' has no sample within {gap:g} s on {nn} of {n} grid points "
                        f"({len(runs)} stretch(es), longest {grid[b - 1] - grid[a]:.2f} s "
                        f"from t = {grid[a]:.2f} s); left as missing, not extrapolated"
                    ),
                    count=nn,
                    t_start=float(grid[a]),
                    t_end=float(grid[b - 1]),
                    channel=ch,
                )
            )
    meta = dict(trial.meta)
    meta["resample"] = {"rate_hz": rate, "nan_counts": nan_counts}
    return trial.with_data(pd.DataFrame(cols), findings=findings, meta=meta)
