"""Geodetic (WGS84 latitude/longitude) to local north-east-down positions.

The conversion is pymap3d's ``geodetic2ned`` (exact ellipsoidal geodetic -> ECEF -> local
tangent plane at the origin), vectorised over whole arrays. The origin is the first valid fix
unless given. Height is taken as 0 m (sea surface) for both fix and origin: a surface vessel's
height changes by centimetres, and the horizontal error this causes over a few kilometres is below
a millimetre.
"""

from __future__ import annotations

import numpy as np

from usvid.errors import UsvidError
from usvid.trial import Trial


def geodetic_to_ned(
    lat_deg: np.ndarray,
    lon_deg: np.ndarray,
    origin: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """North and east [m] of WGS84 fixes relative to ``origin`` = (lat0, lon0) [deg].

    Returns ``(north, east, origin)``; NaN fixes stay NaN. With ``origin=None`` the first fix
    where both coordinates are finite is the origin.
    """
    lat = np.asarray(lat_deg, dtype=float)
    lon = np.asarray(lon_deg, dtype=float)
    if lat.shape != lon.shape:
        raise UsvidError(f"latitude and longitude differ in shape ({lat.shape} vs {lon.shape})")
    if lat.ndim == 0:  # one fix given as scalars: same rules, scalar-shaped results
        n1, e1, org = geodetic_to_ned(lat.reshape(1), lon.reshape(1), origin)
        return n1.reshape(()), e1.reshape(()), org
    ok = np.isfinite(lat) & np.isfinite(lon)
    if origin is None:
        if not ok.any():
            raise UsvidError("no valid position fix (latitude/longitude all missing)")
        i0 = int(np.argmax(ok))
        origin = (float(lat[i0]), float(lon[i0]))
    lat0, lon0 = float(origin[0]), float(origin[1])
    if not (-90.0 <= lat0 <= 90.0 and -180.0 <= lon0 <= 360.0):
        raise UsvidError(f"origin ({lat0}, {lon0}) is not a latitude/longitude in degrees")
    bad_range = ok & ((np.abs(lat) > 90.0) | (np.abs(lon) > 360.0))
    if bad_range.any():
        i = int(np.argmax(bad_range))
        raise UsvidError(
            f"position fix {i} ({lat[i]}, {lon[i]}) is not a latitude/longitude in degrees"
        )
    north = np.full(lat.shape, np.nan)
    east = np.full(lat.shape, np.nan)
    if ok.any():
        import pymap3d  # (on first use: `import usvid.sim` spares it)

        n, e, _ = pymap3d.geodetic2ned(lat[ok], lon[ok], 0.0, lat0, lon0, 0.0)
        north[ok] = n
        east[ok] = e
    return north, east, (lat0, lon0)


def to_ned(
    trial: Trial,
    origin: tuple[float, float] | None = None,
    *,
    overwrite: bool = False,
) -> Trial:
    """A copy of ``trial`` with ``x``, ``y`` [m, north, east] computed from ``lat``, ``lon`` [deg].

    ``origin`` (lat0, lon0) [deg] defaults to the first valid fix and is stored in
    ``meta["ned_origin"]``. Existing ``x``/``y`` are kept unless ``overwrite`` (a reader keeps a
    file's own plane coordinates under other names, e.g. ``x_src``). A trial without
    ``lat``/``lon`` is returned unchanged.
    """
    if not (trial.has("lat") and trial.has("lon")):
        return trial
    if (trial.has("x") or trial.has("y")) and not overwrite:
        return trial
    north, east, org = geodetic_to_ned(trial["lat"], trial["lon"], origin)
    data = trial.data.copy()
    data["x"] = north
    data["y"] = east
    meta = dict(trial.meta)
    meta["ned_origin"] = {"lat_deg": org[0], "lon_deg": org[1]}
    return trial.with_data(data, meta=meta)
