"""One entry point from a raw trial to an identification-ready one: :func:`prepare`."""

from __future__ import annotations

import numpy as np
import pandas as pd

from usvid.errors import UsvidError
from usvid.prep.filters import savgol_derivative, unwrap_angle
from usvid.prep.geodesy import to_ned
from usvid.prep.kinematics import body_velocity_from_cog, body_velocity_from_positions
from usvid.prep.resample import resample
from usvid.prep.stale import drop_stale
from usvid.trial import Finding, Trial, merge_shared_stamp_rows


def sort_time(trial: Trial) -> tuple[Trial, int, int]:
    """Sort rows by time and merge rows sharing a time stamp (per channel the last finite
    value in row order: :func:`usvid.trial.merge_shared_stamps`, the readers' rule).

    Returns ``(trial, n_reversals, n_duplicates)``; a reversal is a row whose stamp is earlier
    than its predecessor's (among the rows with a finite time). Rows with a NaN time are dropped
    and counted in the returned trial's ``rejected["nan_time"]`` (the readers' reason).
    """
    t = trial.data["t"].to_numpy(dtype=float)
    ok = np.isfinite(t)
    n_nan = int((~ok).sum())
    n_rev = int(np.sum(np.diff(t[ok]) < 0))
    data = trial.data.loc[ok]
    if n_rev:
        data = data.sort_values("t", kind="stable")
    data, n_dup = merge_shared_stamp_rows(data)  # the readers' rule for shared stamps
    if n_nan or n_rev or n_dup:
        changes = {}
        if n_nan:
            changes["rejected"] = {**trial.rejected,
                                   "nan_time": trial.rejected.get("nan_time", 0) + n_nan}
        trial = trial.with_data(data.reset_index(drop=True), **changes)
    return trial, n_rev, n_dup


def prepare(
    trial: Trial,
    rate_hz: float | None = None,
    *,
    origin: tuple[float, float] | None = None,
    window_s: float = 1.0,
    max_gap_s: float | None = None,
    drop_stale_fixes: bool = True,
    derivatives: bool = True,
) -> Trial:
    """Uniform-grid, NED, unwrapped, differentiated trial from a raw one.

    Steps: sort time (reversed stamps sorted, repeated ones dropped, both reported; rows without
    a time dropped and counted in ``rejected["nan_time"]``); stale GNSS fixes set missing
    (:mod:`usvid.prep.stale`, rate in ``meta["stale_fixes"]``); lat/lon [deg] -> x, y [m NED]
    (pymap3d, origin = first fix or ``origin``); resampling onto a uniform grid of ``rate_hz`` [Hz]
    (default: the fastest channel; gaps longer than ``max_gap_s`` [s] stay NaN); heading unwrapped;
    missing channels derived: ``r`` = d(psi)/dt, ``u``, ``v`` from d(x, y)/dt rotated by psi (or
    from SOG/COG), ``U`` = hypot(u, v); with ``derivatives`` also ``u_dot``, ``v_dot``, ``r_dot``
    [m/s^2, rad/s^2]. All derivatives are zero-phase Savitzky-Golay over ``window_s`` [s].

    Channels computed here (not measured) are listed in ``meta["derived"]``.
    """
    if len(trial) < 3:
        raise UsvidError(f"trial {trial.name or '?'}: fewer than three samples, cannot prepare")
    findings = list(trial.findings)
    trial, n_rev, n_dup = sort_time(trial)
    if n_rev:
        findings.append(Finding("warning", "time_reversal",
                                f"{n_rev} time stamp(s) earlier than their predecessor; "
                                f"rows sorted",
                                count=n_rev, channel="t"))
    if n_dup:
        findings.append(Finding("info", "time_duplicate",
                                f"{n_dup} repeated time stamp(s); rows merged, the last "
                                "value of each channel kept",
                                count=n_dup, channel="t"))
    if drop_stale_fixes:
        trial, rep = drop_stale(trial)
        if rep is not None and rep.n_stale:
            findings.append(Finding(
                "info" if rep.rate < 0.5 else "warning", "stale_gnss_fix",
                f"{rep.n_stale} of {rep.n_fixes} position fixes ({100 * rep.rate:.1f} %) repeat "
                f"the previous fix exactly (stale); treated as missing and interpolated "
                f"({', '.join(rep.channels)})",
                count=rep.n_stale, data={"rate": rep.rate, "channels": rep.channels}))
    trial = to_ned(trial, origin)
    trial = trial.with_data(trial.data, findings=findings)
    uniform = trial.is_uniform and not trial.data.isna().any().any()
    if rate_hz is not None or not uniform:
        trial = resample(trial, rate_hz, max_gap_s=max_gap_s)
    data = trial.data.copy()
    dt = 1.0 / trial.sample_rate if trial.sample_rate else float(np.median(np.diff(trial.t)))
    derived: list[str] = list(trial.meta.get("derived", []))

    def have(c: str) -> bool:
        return c in data.columns and bool(np.isfinite(data[c].to_numpy(dtype=float)).any())

    if have("psi"):
        data["psi"] = unwrap_angle(data["psi"].to_numpy(dtype=float))
        if not have("r"):
            data["r"] = savgol_derivative(data["psi"].to_numpy(), dt, window_s)
            derived.append("r")
    if have("cog"):
        data["cog"] = unwrap_angle(data["cog"].to_numpy(dtype=float))
    if have("psi") and not (have("u") and have("v")):
        psi = data["psi"].to_numpy(dtype=float)
        if have("x") and have("y"):
            u, v = body_velocity_from_positions(
                data["x"].to_numpy(dtype=float), data["y"].to_numpy(dtype=float), psi, dt, window_s
            )
        elif have("sog") and have("cog"):
            u, v = body_velocity_from_cog(data["sog"].to_numpy(dtype=float),
                                          data["cog"].to_numpy(dtype=float), psi)
        else:
            u = v = None
        if u is not None:
            for name, val in (("u", u), ("v", v)):
                if not have(name):
                    data[name] = val
                    derived.append(name)
    if not have("U") and have("u") and have("v"):
        data["U"] = np.hypot(data["u"].to_numpy(dtype=float), data["v"].to_numpy(dtype=float))
        derived.append("U")
    if derivatives:
        for name in ("u", "v", "r"):
            if have(name):
                data[f"{name}_dot"] = savgol_derivative(data[name].to_numpy(dtype=float), dt,
                                                        window_s)
                derived.append(f"{name}_dot")
    meta = dict(trial.meta)
    meta["derived"] = sorted(set(derived))
    meta["prepared"] = {"window_s": window_s, "rate_hz": 1.0 / dt}
    return trial.with_data(pd.DataFrame(data).reset_index(drop=True), meta=meta)
