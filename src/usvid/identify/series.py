"""A trial as the arrays identification needs: one uniform grid, smoothed states, derivatives.

:func:`trial_series` takes a :class:`usvid.Trial` (SI channels; prepared first when it is not,
:func:`usvid.prep.as_prepared`) and returns a :class:`Series` with the measured channels the
model kind needs (its inputs and outputs), the Savitzky-Golay smoothed states ``<name>_s`` and
derivatives ``<name>dot_s`` (cubic, window ``smooth_s``), the unwrapped heading, and the kind's
own regressors (e.g. forces from the thrust law: ``ModelKind.series``). Missing samples are
interpolated linearly with a warning; more than 20 % missing, or a channel the kind needs
absent, is an :class:`IdentificationError` naming the trial and the channel. The series of a
prepared trial is built once per kind and smoothing (remembered by the trial: the estimator,
the validation and the report share it); the kind's regressors are added to a copy per call.

Why the rudder is smoothed too: the regression sees both sides of each equation through one
linear filter (smoothing r alone biases T by about +3 % on a noise-free zig-zag).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import IdentificationError
from usvid.identify.wind import air_velocity
from usvid.models.kind import ModelKind
from usvid.prep.filters import savgol_derivative, unwrap_angle, window_samples
from usvid.prep.prepare import PreparedTrial, as_prepared
from usvid.prep.state_estimation import MEASUREMENT_CHANNELS, estimate_states
from usvid.sim.layout import STATE_CHANNELS

#: Fewest samples of a trial for identification.
MIN_SAMPLES = 20


class IdentificationWarning(UserWarning):
    """The data were repaired or the estimate is weak (interpolated gaps, resampled grid,
    poorly determined parameters)."""


@dataclass
class Series:
    """One trial on a uniform grid of step ``h`` [s]: name -> 1-D array (SI units).

    Measured ``t`` [s], ``psi`` [rad, unwrapped], ``r`` [rad/s], ``delta`` [rad], ``u``, ``v``
    [m/s], ``n`` [rps], ``n_port``, ``n_stbd`` (as present); smoothed ``*_s`` and derivatives
    ``*dot_s``; kind regressors (``tau_u`` [N], ``tau_r`` [N m], ...).
    """

    name: str
    h: float
    data: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, k: str) -> np.ndarray:
        return self.data[k]

    def __contains__(self, k: str) -> bool:
        return k in self.data

    def __len__(self) -> int:
        return len(self.data["t"])

    def decimated(self, m: int) -> Series:
        """Every m-th sample (step m h)."""
        return Series(self.name, self.h * m, {k: v[::m] for k, v in self.data.items()})


def _channel(trial: Any, ch: str, name: str, t: np.ndarray) -> np.ndarray:
    x = trial[ch]
    bad = ~np.isfinite(x)
    nbad = int(bad.sum())
    if nbad:
        frac = nbad / len(x)
        if frac > 0.2 or nbad > len(x) - 2:
            raise IdentificationError(
                f"trial {name}: channel '{ch}' has {nbad} of {len(x)} samples NaN/inf "
                f"({100 * frac:.0f} %); repair or cut the log before identification")
        warnings.warn(f"trial {name}: channel '{ch}' has {nbad} NaN/inf samples; interpolated "
                      "linearly", IdentificationWarning, stacklevel=4)
        x = np.interp(t, t[~bad], x[~bad])
    return x


def _has_positions(trial: Any) -> bool:
    return trial.has("psi") and ((trial.has("x") and trial.has("y"))
                                 or (trial.has("lat") and trial.has("lon")))


def trial_series(trial: Any, kind: ModelKind, *, smooth_s: float = 1.0,
                 fixed: Mapping[str, Any] | None = None, states: str = "auto") -> Series:
    """The arrays of ``kind`` from a :class:`usvid.Trial` on a uniform grid (module docstring).

    ``fixed``: the kind's particulars (thrust law, lever arm, ...) for its own regressors.
    ``states``: ``"smooth"`` Savitzky-Golay states and derivatives; ``"ekf"`` u, v, r and their
    derivatives from the EKF + RTS smoother (:func:`usvid.prep.estimate_states`, Alexandersson
    et al. 2022) on the positions, heading and what else is logged; ``"auto"`` (default) the
    smoother for kinds that declare ``state_estimation`` when the trial has positions.
    """
    if states not in ("auto", "smooth", "ekf"):
        raise IdentificationError(f"`states` must be 'auto', 'smooth' or 'ekf' (got {states!r})")
    prepared = as_prepared(trial, derivatives=False)
    key = ("series", kind.name, float(smooth_s), states)
    base = prepared.remember(key, lambda: build_series(prepared, kind, smooth_s=smooth_s,
                                                        states=states))
    d = dict(base.data)
    if kind.series is not None:
        kind.series(d, fixed or {})
    return Series(name=base.name, h=base.h, data=d)


def build_series(trial: PreparedTrial, kind: ModelKind, *, smooth_s: float = 1.0,
                 states: str = "auto") -> Series:
    """The series of ``kind`` from a prepared trial, without the kind's own regressors: what
    :func:`trial_series` builds once per prepared trial (call :func:`trial_series`)."""
    name = trial.name or (trial.sources[0] if trial.sources else "?")
    if len(trial) < MIN_SAMPLES:
        raise IdentificationError(f"trial {name}: too short for identification ({len(trial)} "
                                  f"samples, need >= {MIN_SAMPLES})")
    t = np.asarray(trial.t, dtype=float)
    if not np.all(np.diff(t) > 0):
        raise IdentificationError(f"trial {name}: time stamps must be strictly increasing")
    h = float(np.median(np.diff(t)))
    win = window_samples(smooth_s, h)
    if t[-1] - t[0] < 3 * smooth_s or len(t) < 2 * win:
        raise IdentificationError(
            f"trial {name}: too short for identification ({t[-1] - t[0]:.1f} s; need at "
            f"least {max(3 * smooth_s, 2 * win * h):.1f} s with smoothing window {smooth_s} s)")
    d: dict[str, np.ndarray] = {"t": t}

    def need(ch: str) -> np.ndarray:
        if ch in trial.channels and not trial.has(ch):
            raise IdentificationError(
                f"trial {name}: channel '{ch}' (needed by model '{kind.name}') has no finite "
                f"sample (all {len(trial)} NaN/inf); check its column in the format spec")
        if not trial.has(ch):
            raise IdentificationError(
                f"trial {name}: model '{kind.name}' needs channel '{ch}' (present: "
                f"{', '.join(trial.channels) or 'none'})")
        return _channel(trial, ch, name, t)

    def sg(x: np.ndarray, deriv: int = 0) -> np.ndarray:
        return savgol_derivative(x, h, smooth_s, 3, deriv=deriv)

    needs = set(kind.regression.needs if kind.regression else ()) | set(kind.outputs)
    if kind.constant_speed or "delta" in needs:
        needs.add("delta")
    use_ekf = states == "ekf" or (states == "auto" and kind.state_estimation
                                  and _has_positions(trial))
    for ch in ("delta", "n", "n_port", "n_stbd", "u", "v", "thrust", "tau_u", "tau_r",
               "T_port", "T_stbd"):
        if use_ekf and ch in ("u", "v") and (not trial.has(ch) or ch in trial.derived):
            continue  # from the state estimate (not differentiated positions)
        if ch in needs or (ch in kind.inputs and trial.has(ch)) or (
                ch in ("thrust", "tau_u", "tau_r", "T_port", "T_stbd") and trial.has(ch)):
            d[ch] = need(ch)
    if "delta" in d:
        d["delta_s"] = sg(d["delta"])
    if "psi" in trial.channels and not trial.has("psi"):
        raise IdentificationError(
            f"trial {name}: channel 'psi' has no finite sample (all {len(trial)} NaN/inf): "
            "no heading to identify from; check its column in the format spec")
    if trial.has("psi"):
        d["psi"] = unwrap_angle(need("psi"))
    if trial.has("r") and "r" not in trial.derived:
        d["r"] = need("r")
    elif "psi" in d:
        d["r"] = sg(d["psi"], 1)
    else:
        raise IdentificationError(f"trial {name}: needs channel 'r' or 'psi' (present: "
                                  f"{', '.join(trial.channels) or 'none'})")
    if "psi" not in d:
        d["psi"] = np.concatenate([[0.0], np.cumsum(0.5 * h * (d["r"][1:] + d["r"][:-1]))])
    d["r_s"] = sg(d["r"])
    d["rdot_s"] = sg(d["r"], 1)
    d["psi_s"] = sg(d["psi"])
    if use_ekf:
        _ekf_states(trial, name, t, d)
    for ch in ("u", "v"):
        if ch in d and ch + "_s" not in d:
            d[ch + "_s"] = sg(d[ch])
            d[ch + "dot_s"] = sg(d[ch], 1)
    # roll (kinds with the states phi, p): the logged roll angle and rate, smoothed; a roll rate
    # the log lacks is the roll angle's derivative
    for ch in STATE_CHANNELS:
        if ch in kind.states and (ch in needs or trial.has(ch)):
            if ch == "p" and not trial.has("p") and "phi" in d:
                d["p"] = sg(d["phi"], 1)
            else:
                d[ch] = need(ch)
            d[ch + "_s"] = sg(d[ch])
            d[ch + "dot_s"] = sg(d[ch], 1)
    # the logged wind as the air's velocity over ground (usvid.identify.wind): the fit and the
    # replays take its loads
    air = air_velocity(trial, t)
    if air is not None:
        d["wind_x"], d["wind_y"] = air
    return Series(name=name, h=h, data=d)


def _ekf_states(trial: Any, name: str, tg: np.ndarray, d: dict[str, np.ndarray]) -> None:
    """u, v, r and their derivatives (``*_s``, ``*dot_s``) from the EKF + RTS smoother; a
    velocity the log lacks (u, v) becomes its estimate (the output output error compares)."""
    if not _has_positions(trial):
        raise IdentificationError(f"trial {name}: state estimation needs positions (x, y or "
                                  "lat, lon) and heading psi")
    # the measurements only: channels prepare() derived (U from u, v; u, v from the positions)
    # would count the positions twice
    derived = getattr(trial, "derived", ())
    est = estimate_states(trial, exclude=[c for c in MEASUREMENT_CHANNELS
                                          if c in derived and c not in ("x", "y", "psi")])
    t = np.asarray(est.t, float)
    for ch in ("u", "v", "r"):
        d[ch + "_s"] = np.interp(tg, t, est[ch])
        d[ch + "dot_s"] = np.interp(tg, t, est[ch + "dot"])
    for ch in ("u", "v"):
        if ch not in d or not np.all(np.isfinite(d[ch])):
            d[ch] = d[ch + "_s"].copy()
