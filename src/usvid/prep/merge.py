"""Merge the logs of one trial recorded by several loggers into one multi-rate Trial.

A USV typically records the same run in several files: NMEA 0183 from the GNSS and compass,
NMEA 2000 (candump) from the engine and rudder network, and a CSV export of the control
computer (Mu et al. 2018 section 2.3). Each reader returns seconds since its own first record and,
where the format carries absolute time, ``meta["t0_utc"]`` (ISO 8601). :func:`merge_trials`
puts them on one clock and returns the union of their time stamps with NaN where a channel has
no sample (the Trial contract for multi-rate data); :func:`usvid.prep.resample` then makes it
uniform.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from usvid.errors import UsvidError
from usvid.trial import Finding, Trial


def _utc(value: str, what: str) -> pd.Timestamp:
    """``value`` (ISO 8601) as a UTC time stamp; a time without zone is taken as UTC."""
    try:
        ts = pd.Timestamp(value)
    except (ValueError, TypeError):
        raise UsvidError(f"merge_trials: {what} = {value!r} is not an ISO 8601 time") from None
    if ts is pd.NaT:
        raise UsvidError(f"merge_trials: {what} = {value!r} is not an ISO 8601 time")
    return ts.tz_localize("UTC") if ts.tzinfo is None else ts.tz_convert("UTC")


def merge_trials(trials: list[Trial], *, t0_utc: str | None = None, name: str | None = None,
                 time_resolution_s: float = 1e-6) -> Trial:
    """One Trial from several logs of the same run, on a common clock.

    Parameters
    ----------
    trials : list of Trial
        The logs. Those with ``meta["t0_utc"]`` are shifted to the common epoch; those without
        are taken to count seconds from it already (e.g. a CSV export relative to the run start).
        A ``t0_utc`` without a time zone (an Excel date-time) is taken as UTC.
    t0_utc : str, optional
        The common epoch (ISO 8601); default the earliest ``t0_utc`` of the inputs.
    name : str, optional
        Name of the merged trial (default: the first input's).
    time_resolution_s : float
        Time stamps are rounded to this [s] before matching, so samples of two loggers taken at
        the same instant share one row.

    Returns
    -------
    Trial
        Union of the time stamps, every channel of every log; rejected records summed per
        reason; findings concatenated. A channel present in several logs is taken from the
        first log that has it; the others are reported in a finding (``channel_in_several_logs``).
        Two samples of one log at one time stamp keep the first and are counted under
        ``rejected["duplicate_time"]`` (never silently dropped).
    """
    if not trials:
        raise UsvidError("merge_trials: no trials given")
    epochs = [
        _utc(tr.meta["t0_utc"], f"meta['t0_utc'] of trial {tr.name or i}")
        if tr.meta.get("t0_utc") else None
        for i, tr in enumerate(trials)
    ]
    known = [e for e in epochs if e is not None]
    t0 = _utc(t0_utc, "t0_utc") if t0_utc else (min(known) if known else None)
    rejected: dict[str, int] = {}
    findings: list[Finding] = []
    merged: pd.DataFrame | None = None
    owner: dict[str, str] = {}
    for tr, epoch in zip(trials, epochs, strict=True):
        for k, v in tr.rejected.items():
            rejected[k] = rejected.get(k, 0) + int(v)
        findings.extend(tr.findings)
        off = (epoch - t0).total_seconds() if (epoch is not None and t0 is not None) else 0.0
        df = tr.data.copy()
        df["t"] = np.round((df["t"].to_numpy(dtype=float) + off) / time_resolution_s) \
            * time_resolution_s
        dup = df["t"].duplicated(keep="first")
        if dup.any():
            rejected["duplicate_time"] = rejected.get("duplicate_time", 0) + int(dup.sum())
            df = df.loc[~dup]
        label = tr.name or (tr.sources[0] if tr.sources else "?")
        clash = [c for c in df.columns if c != "t" and c in owner]
        if clash:
            findings.append(Finding(
                "info", "channel_in_several_logs",
                f"channel(s) {', '.join(clash)} of {label} are also in {owner[clash[0]]}; the "
                f"first log's samples are used", count=len(clash), data={"channels": clash}))
            df = df.drop(columns=clash)
        for c in df.columns:
            owner.setdefault(c, label)
        merged = df if merged is None else merged.merge(df, on="t", how="outer")
    assert merged is not None
    merged = merged.sort_values("t").reset_index(drop=True)
    first = trials[0]
    sources = [s for tr in trials for s in tr.sources]
    meta = {"t0_utc": t0.isoformat() if t0 is not None else None,
            "merged_from": [tr.name for tr in trials]}
    return Trial(data=merged, vessel=first.vessel, sources=sources, rejected=rejected,
                 findings=findings, name=name or first.name, meta=meta)
