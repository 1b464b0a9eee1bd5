"""One entry point from a raw trial to a prepared one: :func:`prepare` -> :class:`PreparedTrial`.

Every command, estimator, validation and report consumes a :class:`PreparedTrial`, prepared once
per log and per command (:func:`as_prepared` passes a prepared trial through untouched). What
later stages derive from it once - its manoeuvre segments (:func:`usvid.manoeuvres.
find_manoeuvres`) and its identification series (:func:`usvid.identify.series.trial_series`) -
is remembered on the prepared trial (:meth:`PreparedTrial.remember`), so that no stage builds
them a second time.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.prep.filters import savgol_derivative, unwrap_angle
from usvid.prep.geodesy import to_ned
from usvid.prep.glitches import repair_trial_heading
from usvid.prep.kinematics import body_velocity_from_cog, body_velocity_from_positions
from usvid.prep.resample import resample
from usvid.prep.stale import drop_stale
from usvid.trial import Finding, Trial, merge_shared_stamp_rows

__all__ = ["PreparedTrial", "as_prepared", "prepare", "sort_time"]


@dataclass(eq=False)
class PreparedTrial(Trial):
    """A trial ready for every stage (made by :func:`prepare` only): one uniform time grid,
    time stamps sorted and unique, stale GNSS fixes dropped, positions in NED [m], the heading
    unwrapped with its glitches repaired at the compass's own samples, thruster commands from
    PWM pulse widths, the missing states derived (``r``, ``u``, ``v``, ``U``).

    ``heading_glitches``: heading samples repaired; ``filled``: channel -> samples of a
    single-rate log's gaps filled by interpolation (NaN in the log, bridged on the grid);
    ``derived``: channels computed here, not measured; ``window_s`` [s]: the Savitzky-Golay
    window of the derived states; ``resampled_hz`` [Hz]: the grid a log that was not on one
    uniform grid was resampled to (None when it was on one). ``memo`` holds what later stages
    derived from this trial once (segments, series): a copy made with :meth:`with_data` or
    :meth:`slice_time` starts with an empty one.
    """

    heading_glitches: int = 0
    filled: dict[str, int] = field(default_factory=dict)
    derived: tuple[str, ...] = ()
    window_s: float = 1.0
    resampled_hz: float | None = None
    memo: dict[Hashable, Any] = field(default_factory=dict, init=False, repr=False)

    def remember(self, key: Hashable, build: Callable[[], Any]) -> Any:
        """``build()`` the first time ``key`` is asked for, the same object afterwards."""
        if key not in self.memo:
            self.memo[key] = build()
        return self.memo[key]


def as_prepared(trial: Trial, **options: Any) -> PreparedTrial:
    """``trial`` itself when it is prepared already, else :func:`prepare` (``options``) of it:
    the one road of every stage into the prepared form."""
    if isinstance(trial, PreparedTrial):
        return trial
    if not isinstance(trial, Trial):
        raise UsvidError(f"expected a usvid.Trial (got {type(trial).__name__})")
    return prepare(trial, **options)


def pwm_commands(trial: Trial) -> tuple[Trial, bool]:
    """Thruster commands ``n_port``/``n_stbd`` from logged PWM pulse widths ``pwm_port``/
    ``pwm_stbd`` [us] where the log has no other commands (the kinds' thrust map then reads the
    pulse width: ``twin_thrust`` with ``command: pwm``); returns (trial, derived or not)."""
    if trial.has("pwm_port") and trial.has("pwm_stbd") and not (trial.has("n_port")
                                                                or trial.has("n_stbd")):
        data = trial.data.copy()
        data["n_port"] = data["pwm_port"]
        data["n_stbd"] = data["pwm_stbd"]
        return trial.with_data(data), True
    return trial, False


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
) -> PreparedTrial:
    """The :class:`PreparedTrial` of a raw trial: uniform grid, NED, repaired and unwrapped
    heading, derived states.

    Steps: sort time (reversed stamps sorted, repeated ones dropped, both reported; rows without
    a time dropped and counted in ``rejected["nan_time"]``); stale GNSS fixes set missing
    (:mod:`usvid.prep.stale`, rate in ``meta["stale_fixes"]``); lat/lon [deg] -> x, y [m NED]
    (pymap3d, origin = first fix or ``origin``); thruster commands from PWM pulse widths;
    heading glitches repaired at the compass's own samples, before resampling blurs them into
    their neighbours (:func:`usvid.prep.glitches.repair_trial_heading`); resampling onto a
    uniform grid of ``rate_hz`` [Hz] (default: the fastest channel; gaps longer than
    ``max_gap_s`` [s] stay NaN, never a whole channel invented); heading unwrapped; missing
    channels derived: ``r`` = d(psi)/dt, ``u``, ``v`` from d(x, y)/dt rotated by psi (or from
    SOG/COG), ``U`` = hypot(u, v); with ``derivatives`` also ``u_dot``, ``v_dot``, ``r_dot``
    [m/s^2, rad/s^2]. All derivatives are zero-phase Savitzky-Golay over ``window_s`` [s].

    A trial prepared already is returned as it is (resampled when another ``rate_hz`` is
    asked for, its derivatives added when asked for and missing).
    """
    prior = trial if isinstance(trial, PreparedTrial) else None
    if prior is not None:
        rate = prior.sample_rate
        rerate = rate_hz is not None and (rate is None or abs(rate - rate_hz) > 1e-6 * rate_hz)
        if not rerate and (not derivatives or all(f"{c}_dot" in prior.channels or not
                                                  prior.has(c) for c in ("u", "v", "r"))):
            return prior
        trial = Trial(**{f: getattr(prior, f) for f in ("data", "vessel", "sources", "rejected",
                                                        "findings", "name", "meta")})
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
    trial, from_pwm = pwm_commands(trial)
    derived: list[str] = list(prior.derived) if prior is not None else []
    if from_pwm:
        derived += ["n_port", "n_stbd"]
    trial, n_glitch = repair_trial_heading(trial)
    trial = trial.with_data(trial.data, findings=findings)
    uniform = trial.is_uniform and not trial.data.isna().any().any()
    filled: dict[str, int] = dict(prior.filled) if prior is not None else {}
    resampled = prior.resampled_hz if prior is not None else None
    if rate_hz is not None or not uniform:
        before = trial.data.isna().sum() if trial.is_uniform else None
        trial = resample(trial, rate_hz, max_gap_s=max_gap_s)
        if before is None:
            resampled = trial.sample_rate
        if before is not None:  # a single-rate log's gaps: what the grid bridged
            after = trial.data.isna().sum()
            for ch, n in before.items():
                k = int(n - after.get(ch, n))
                if k > 0:
                    filled[str(ch)] = filled.get(str(ch), 0) + k
    data = trial.data.copy()
    dt = 1.0 / trial.sample_rate if trial.sample_rate else float(np.median(np.diff(trial.t)))

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
    import pandas as pd  # (here, not at import: `import usvid.sim` spares pandas)

    return PreparedTrial(
        data=pd.DataFrame(data).reset_index(drop=True), vessel=trial.vessel,
        sources=list(trial.sources), rejected=dict(trial.rejected),
        findings=list(trial.findings), name=trial.name, meta=dict(trial.meta),
        heading_glitches=int(n_glitch), filled=filled, derived=tuple(sorted(set(derived))),
        window_s=float(window_s), resampled_hz=resampled)
