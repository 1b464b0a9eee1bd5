"""Channels the NMEA readers derive from others when a log carries a quantity only in another
reference: a heading from a magnetic heading and the magnetic variation, a true wind direction
from north from the true wind angle from the bow and the heading.

Conventions (the Trial contract): headings and wind directions [rad] clockwise from north; the
magnetic variation [rad] positive east (true = magnetic + variation); the true wind angle
``wind_angle_true`` [rad] from the bow, clockwise, the direction the wind comes from (NMEA 0183
MWV with reference "T", NMEA 2000 PGN 130306 "True (boat referenced)"), so that
``wind_dir_true = wind_angle_true + psi`` (wrapped into [0, 2 pi)).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from usvid.trial import Finding

#: A heading is interpolated at another channel's time only between samples at most this far
#: apart [s] (a compass logs at 1-20 Hz; beyond this the ship may have turned unseen).
HEADING_GAP_S = 2.0


def heading_at(t: np.ndarray, psi: np.ndarray, at: np.ndarray,
               max_gap_s: float = HEADING_GAP_S) -> np.ndarray:
    """The heading ``psi`` [rad] (samples at times ``t`` [s], NaN where none) interpolated at
    the times ``at`` [s] along the shorter way round (unwrapped), NaN where the nearest samples
    on either side are more than ``max_gap_s`` apart or ``at`` lies outside them."""
    ok = np.isfinite(psi) & np.isfinite(t)
    out = np.full(len(at), np.nan)
    if ok.sum() < 1:
        return out
    ts, ps = t[ok], psi[ok]
    o = np.argsort(ts, kind="stable")
    ts, ps = ts[o], np.unwrap(ps[o])
    if len(ts) == 1:
        hit = np.abs(at - ts[0]) <= 1e-9
        out[hit] = ps[0]
        return np.remainder(out, 2 * math.pi)
    j = np.clip(np.searchsorted(ts, at), 1, len(ts) - 1)
    inside = (at >= ts[0]) & (at <= ts[-1]) & ((ts[j] - ts[j - 1]) <= max_gap_s)
    out[inside] = np.interp(at[inside], ts, ps)
    return np.remainder(out, 2 * math.pi)


def variation_of(chans: dict[str, np.ndarray]) -> float | None:
    """The magnetic variation [rad, east positive] the log gives (``_variation``: the median
    of its samples; it changes by less than a degree a day at sea), None when it gives none."""
    v = chans.get("_variation")
    if v is None or not np.isfinite(v).any():
        return None
    return float(np.nanmedian(v))


def heading_from_magnetic(path: Path, chans: dict[str, np.ndarray], findings: list[Finding],
                          what: str) -> None:
    """``psi`` from ``psi_mag`` (a magnetic heading [rad]) when the log has no true heading:
    plus the logged variation, or as it is (with a warning) when no variation is logged.
    ``what`` names the source in the finding (``"HDM/HDG"``, ``"PGN 127250"``). In place."""
    if "psi" in chans and np.isfinite(chans["psi"]).any():
        return
    mag = chans.get("psi_mag")
    if mag is None or not np.isfinite(mag).any():
        return
    var = variation_of(chans)
    n = int(np.isfinite(mag).sum())
    if var is None:
        chans["psi"] = np.remainder(chans.pop("psi_mag"), 2 * math.pi)
        findings.append(Finding(
            "warning", "heading_magnetic",
            f"{path.name}: the heading is magnetic ({what}) and the log gives no magnetic "
            "variation: psi is the magnetic heading, off the true heading by the local "
            "variation (a constant: harmless for yaw rates and manoeuvres, not for a current "
            "or a wind direction from north)", count=n, channel="psi"))
        return
    chans["psi"] = np.remainder(chans.pop("psi_mag") + var, 2 * math.pi)
    findings.append(Finding(
        "info", "heading_from_magnetic",
        f"{path.name}: no true heading in the log: psi is the magnetic heading ({what}) plus "
        f"the logged magnetic variation {math.degrees(var):+.1f} deg", count=n, channel="psi",
        data={"variation_deg": math.degrees(var)}))


def wind_from_magnetic(path: Path, chans: dict[str, np.ndarray], findings: list[Finding],
                       what: str) -> None:
    """``wind_dir_true`` [rad, from north] from ``_wind_dir_mag`` (a true wind direction from
    magnetic north) when the log gives none from true north: plus the logged variation (a
    warning when there is none). ``_wind_speed_mag`` becomes ``wind_speed_true`` when that is
    missing. In place."""
    if "wind_dir_true" in chans and np.isfinite(chans["wind_dir_true"]).any():
        return
    mag = chans.get("_wind_dir_mag")
    if mag is None or not np.isfinite(mag).any():
        return
    var = variation_of(chans)
    chans["wind_dir_true"] = np.remainder(mag + (var or 0.0), 2 * math.pi)
    sp = chans.get("_wind_speed_mag")
    if sp is not None and not ("wind_speed_true" in chans
                               and np.isfinite(chans["wind_speed_true"]).any()):
        chans["wind_speed_true"] = sp
    findings.append(Finding(
        "info" if var is not None else "warning", "wind_direction_magnetic",
        f"{path.name}: the true wind direction is logged from magnetic north ({what}): "
        + (f"wind_dir_true adds the logged magnetic variation {math.degrees(var):+.1f} deg"
           if var is not None else "the log gives no magnetic variation, so wind_dir_true is "
           "from magnetic north"), count=int(np.isfinite(mag).sum()), channel="wind_dir_true"))


def true_wind_direction(path: Path, t: np.ndarray, chans: dict[str, np.ndarray],
                        findings: list[Finding], what: str) -> None:
    """``wind_dir_true`` [rad, from north] from ``wind_angle_true`` (the true wind angle from
    the bow) and the heading ``psi`` when the log gives no true wind direction from north:
    ``wind_dir_true = wind_angle_true + psi`` with the heading interpolated at the wind's time
    (:func:`heading_at`); NaN where no heading sample lies within 2 s. In place."""
    if "wind_dir_true" in chans and np.isfinite(chans["wind_dir_true"]).any():
        return
    twa = chans.get("wind_angle_true")
    if twa is None or not np.isfinite(twa).any():
        return
    has = np.isfinite(twa)
    psi = chans.get("psi")
    if psi is None or not np.isfinite(psi).any():
        findings.append(Finding(
            "info", "wind_direction_unknown",
            f"{path.name}: the true wind is logged as an angle from the bow ({what}) and the log "
            "has no heading: its direction from north (wind_dir_true) is not known; "
            "wind_angle_true is kept", count=int(has.sum()), channel="wind_angle_true"))
        return
    h = heading_at(t, psi, t[has])
    d = np.full(len(t), np.nan)
    d[has] = np.remainder(twa[has] + h, 2 * math.pi)
    chans["wind_dir_true"] = d
    n_ok = int(np.isfinite(d).sum())
    findings.append(Finding(
        "info", "wind_direction_from_heading",
        f"{path.name}: the true wind is logged as an angle from the bow ({what}): "
        f"wind_dir_true = wind_angle_true + psi, the heading interpolated at the wind's time "
        f"({n_ok} of {int(has.sum())} samples; none where no heading lies within "
        f"{HEADING_GAP_S:g} s)", count=n_ok, channel="wind_dir_true"))
