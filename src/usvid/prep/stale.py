"""Duplicated (stale) GNSS fixes: detect them and treat them as missing, not as zero speed.

A logger that writes rows faster than the receiver updates repeats the last fix. Differentiating
such a staircase gives zero speed on the repeated rows and a spike on the next true fix. A stale row
is one where every coordinate of a position group (``lat``/``lon``, else ``x``/``y``) is finite and
exactly equal to its previous finite value. Exact repetition of a real fix to the logged precision
(1e-7 deg is about 1 cm) by a moving vessel does not happen, so the rule has no threshold; a vessel
lying still is the one case it misjudges, and then interpolating over the "missing" fixes gives the
same (constant) position anyway.

Channels written by the same receiver at the same instant (speed over ground, course, and a GNSS
heading) repeat on the same rows; such a channel is treated the same way when at least
``follow_fraction`` of the stale rows repeat it exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvid.trial import Trial

#: Position groups checked, in order of preference; every present group is checked.
POSITION_GROUPS: tuple[tuple[str, str], ...] = (("lat", "lon"), ("x", "y"), ("x_src", "y_src"))
#: Channels that may come from the same receiver and repeat with the fix.
GNSS_FOLLOWERS: tuple[str, ...] = ("sog", "cog", "U", "psi")


@dataclass
class StaleReport:
    """Result of stale-fix detection.

    ``mask`` (N,) bool marks stale rows of the primary group; ``n_fixes`` counts rows with a fix;
    ``rate`` = stale / fixes; ``channels`` the channels set to NaN on stale rows.
    """

    mask: np.ndarray
    n_stale: int
    n_fixes: int
    group: tuple[str, ...]
    channels: list[str] = field(default_factory=list)

    @property
    def rate(self) -> float:
        return self.n_stale / self.n_fixes if self.n_fixes else 0.0


def repeats_previous(y: np.ndarray) -> np.ndarray:
    """Bool (N,): sample is finite and exactly equal to the previous finite sample."""
    y = np.asarray(y, dtype=float)
    out = np.zeros(y.shape, dtype=bool)
    ok = np.flatnonzero(np.isfinite(y))
    if len(ok) > 1:
        vals = y[ok]
        out[ok[1:]] = vals[1:] == vals[:-1]
    return out


def stale_mask(trial: Trial, group: tuple[str, ...]) -> np.ndarray:
    """Bool (N,): rows where every channel of ``group`` repeats its previous finite value."""
    mask = np.ones(len(trial), dtype=bool)
    for ch in group:
        mask &= repeats_previous(trial[ch])
    return mask


def _primary_group(trial: Trial) -> tuple[str, ...] | None:
    for g in POSITION_GROUPS:
        if all(trial.has(c) for c in g):
            return g
    return None


def detect_stale(trial: Trial, follow_fraction: float = 0.9) -> StaleReport | None:
    """Detect stale fixes; ``None`` when the trial has no position channels.

    Returns which channels to blank: every present position group (its own stale rows) and each
    GNSS follower channel that repeats on at least ``follow_fraction`` of the stale rows.
    """
    group = _primary_group(trial)
    if group is None:
        return None
    mask = stale_mask(trial, group)
    fixes = np.ones(len(trial), dtype=bool)
    for ch in group:
        fixes &= np.isfinite(trial[ch])
    n_stale = int(mask.sum())
    channels = list(group)
    for g in POSITION_GROUPS:
        if g != group and all(trial.has(c) for c in g):
            channels.extend(g)
    if n_stale:
        for ch in GNSS_FOLLOWERS:
            if trial.has(ch) and ch not in channels:
                rep = repeats_previous(trial[ch])
                if rep[mask].mean() >= follow_fraction:
                    channels.append(ch)
    return StaleReport(mask=mask, n_stale=n_stale, n_fixes=int(fixes.sum()), group=group,
                       channels=channels)


def drop_stale(trial: Trial, report: StaleReport | None = None) -> tuple[Trial, StaleReport | None]:
    """A copy of ``trial`` with stale samples set to NaN (to be interpolated by resampling).

    Position groups are blanked on their own stale rows; follower channels on the rows where they
    repeat. Returns ``(trial, report)``; the report is also stored in ``meta["stale_fixes"]``.
    """
    if report is None:
        report = detect_stale(trial)
    if report is None or report.n_stale == 0:
        return trial, report
    data = trial.data.copy()
    blanked = set()
    for g in POSITION_GROUPS:
        if all(c in report.channels for c in g):
            m = stale_mask(trial, g)
            for c in g:
                data.loc[m, c] = np.nan
            blanked.update(g)
    for ch in report.channels:
        if ch not in blanked:
            m = repeats_previous(trial[ch]) & report.mask
            data.loc[m, ch] = np.nan
    meta = dict(trial.meta)
    meta["stale_fixes"] = {
        "count": report.n_stale,
        "fixes": report.n_fixes,
        "rate": report.rate,
        "group": list(report.group),
        "channels": list(report.channels),
    }
    return trial.with_data(data, meta=meta), report
