"""Virtual sea trials: a simulated run seen through imperfect sensors, as a :class:`usvid.Trial`.

The identification and preprocessing code is tested against known truth by simulating a model,
then sampling the run the way a real USV logs it:

* each sensor group has its own sample rate (GNSS position/speed e.g. 5 Hz, compass heading
  10 Hz, gyro yaw rate and rudder feedback 50 Hz) and optional time-stamp jitter (Gaussian, std
  ``jitter_s``, clipped to +-0.4 sample intervals so samples stay in order);
* Gaussian white noise on every measured channel, a constant gyro bias, and an optional fraction
  of lost samples (``dropout``);
* the output follows the Trial contract for multi-rate sources (``ARCHITECTURE.md``): the union
  of all time stamps (rounded to 1 us) with NaN where a channel has no sample at that instant.

Channels and groups (SI units, radians; a channel absent from the run is skipped):

================  =====================  ======================================
group             channels               noise
================  =====================  ======================================
gnss              x, y, U                ``gps_sigma_m`` per axis, ``speed_sigma_m_s``
heading           psi                    ``heading_sigma_deg`` (wrapped to (-pi, pi] when
                                         ``wrap_heading``)
gyro              r                      ``gyro_sigma_deg_s`` + ``gyro_bias_deg_s``
velocity          u, v                   ``speed_sigma_m_s`` (at the gnss rate)
rudder            delta, delta_cmd       ``rudder_sigma_deg`` (delta_cmd exact)
engine            n, n_port, n_stbd      ``rpm_sigma`` [rpm] (at the rudder rate)
attitude          phi, p                 ``roll_sigma_deg``, ``roll_rate_sigma_deg_s`` (an
                                         IMU's roll angle and rate; kinds with roll)
================  =====================  ======================================

Values between simulation samples are linearly interpolated (headings unwrapped first). The
noise of each group comes from its own generator spawned from ``numpy.random.SeedSequence(
[seed, i])`` so a run is reproducible and adding a channel does not change the others' noise.
The true model (a ``VesselModel``, the run's member of a batch) is stored in
``trial.meta["truth"]`` (as :meth:`SimResult.to_trial` does), its model-file dict in
``trial.meta["truth_file"]`` and the sensor settings in ``trial.meta["sensors"]``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from usvid.errors import SimulationError
from usvid.io.modelfile import model_to_dict
from usvid.trial import Trial, Vessel

__all__ = ["SensorModel", "virtual_trial", "virtual_trial_uniform", "run_channels"]

#: Sensor group -> (rate field, channels).
_GROUPS: dict[str, tuple[str, tuple[str, ...]]] = {
    "gnss": ("gps_rate_hz", ("x", "y", "U")),
    "heading": ("heading_rate_hz", ("psi",)),
    "gyro": ("gyro_rate_hz", ("r",)),
    "velocity": ("gps_rate_hz", ("u", "v")),
    "rudder": ("rudder_rate_hz", ("delta", "delta_cmd")),
    "engine": ("rudder_rate_hz", ("n", "n_port", "n_stbd")),
    "attitude": ("attitude_rate_hz", ("phi", "p")),
}


@dataclass
class SensorModel:
    """Sensor rates [Hz], noise standard deviations (units in the names), bias, jitter [s].

    The defaults are a typical small-USV installation: 5 Hz GNSS with 0.5 m position noise,
    10 Hz compass with 0.5 deg noise, 50 Hz gyro with 0.2 deg/s noise and no bias, 50 Hz rudder
    feedback with 0.2 deg noise, 50 Hz IMU attitude with 0.2 deg roll and 0.2 deg/s roll-rate
    noise, 2 ms time-stamp jitter. :meth:`perfect` gives noise-free, jitter-free sensors.
    """

    gps_rate_hz: float = 5.0
    gps_sigma_m: float = 0.5
    speed_sigma_m_s: float = 0.05
    heading_rate_hz: float = 10.0
    heading_sigma_deg: float = 0.5
    gyro_rate_hz: float = 50.0
    gyro_sigma_deg_s: float = 0.2
    gyro_bias_deg_s: float = 0.0
    rudder_rate_hz: float = 50.0
    rudder_sigma_deg: float = 0.2
    rpm_sigma: float = 0.0
    attitude_rate_hz: float = 50.0
    roll_sigma_deg: float = 0.2
    roll_rate_sigma_deg_s: float = 0.2
    jitter_s: float = 0.002
    dropout: float = 0.0
    wrap_heading: bool = True

    def __post_init__(self) -> None:
        for name in ("gps_rate_hz", "heading_rate_hz", "gyro_rate_hz", "rudder_rate_hz",
                     "attitude_rate_hz"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise SimulationError(f"SensorModel.{name} must be > 0 (got {v!r})")
        for name in ("gps_sigma_m", "speed_sigma_m_s", "heading_sigma_deg", "gyro_sigma_deg_s",
                     "rudder_sigma_deg", "rpm_sigma", "roll_sigma_deg", "roll_rate_sigma_deg_s",
                     "jitter_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise SimulationError(f"SensorModel.{name} must be >= 0 (got {v!r})")
        if not math.isfinite(self.gyro_bias_deg_s):
            raise SimulationError("SensorModel.gyro_bias_deg_s must be finite")
        if not 0 <= self.dropout < 1:
            raise SimulationError(f"SensorModel.dropout must be in [0, 1) (got {self.dropout!r})")

    @classmethod
    def perfect(cls, rate_hz: float = 50.0) -> SensorModel:
        """Noise-free, jitter-free sensors, every channel at ``rate_hz``."""
        return cls(gps_rate_hz=rate_hz, gps_sigma_m=0.0, speed_sigma_m_s=0.0,
                   heading_rate_hz=rate_hz, heading_sigma_deg=0.0, gyro_rate_hz=rate_hz,
                   gyro_sigma_deg_s=0.0, rudder_rate_hz=rate_hz, rudder_sigma_deg=0.0,
                   attitude_rate_hz=rate_hz, roll_sigma_deg=0.0, roll_rate_sigma_deg_s=0.0,
                   jitter_s=0.0, wrap_heading=False)

    def uniform(self, rate_hz: float) -> SensorModel:
        """The same noise levels, but every channel at ``rate_hz`` with no jitter and no dropout
        (one uniform grid)."""
        return replace(self, gps_rate_hz=rate_hz, heading_rate_hz=rate_hz, gyro_rate_hz=rate_hz,
                       rudder_rate_hz=rate_hz, attitude_rate_hz=rate_hz, jitter_s=0.0,
                       dropout=0.0)

    def sigma(self, channel: str) -> float:
        """Noise std of ``channel`` in SI units (m, m/s, rad, rad/s, rps)."""
        return {
            "x": self.gps_sigma_m, "y": self.gps_sigma_m, "U": self.speed_sigma_m_s,
            "u": self.speed_sigma_m_s, "v": self.speed_sigma_m_s,
            "psi": math.radians(self.heading_sigma_deg),
            "r": math.radians(self.gyro_sigma_deg_s),
            "delta": math.radians(self.rudder_sigma_deg), "delta_cmd": 0.0,
            "n": self.rpm_sigma / 60.0, "n_port": self.rpm_sigma / 60.0,
            "n_stbd": self.rpm_sigma / 60.0, "phi": math.radians(self.roll_sigma_deg),
            "p": math.radians(self.roll_rate_sigma_deg_s),
        }.get(channel, 0.0)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_channels(source: Any, i: int = 0) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Time [s] and true channels of run ``i`` of a simulation result (or of a Trial).

    ``source`` is a ``usvid.sim.SimResult`` (``.t`` (N,), ``.channels`` name -> (B, N)) or a
    :class:`usvid.Trial`. Returns 1-D float arrays.
    """
    if isinstance(source, Trial):
        t = source.t
        return t, {c: source[c] for c in source.channels}
    t = np.asarray(source.t, dtype=float)
    chans = {}
    for name, arr in source.channels.items():
        a = np.asarray(arr, dtype=float)
        if a.ndim == 2:
            if not 0 <= i < a.shape[0]:
                raise SimulationError(f"run index i={i} out of range (batch of {a.shape[0]})")
            a = a[i]
        if a.ndim != 1 or a.shape[0] != t.shape[0]:
            continue
        chans[name] = a
    return t, chans


def _stamps(t0: float, t1: float, rate: float, jitter: float, rng: np.random.Generator
            ) -> np.ndarray:
    dt = 1.0 / rate
    ts = t0 + dt * np.arange(int(math.floor((t1 - t0) / dt + 1e-9)) + 1)
    if jitter > 0:
        ts = ts + np.clip(rng.normal(0.0, jitter, ts.size), -0.4 * dt, 0.4 * dt)
        ts = np.clip(ts, t0, t1)
    return np.round(ts, 6)


def virtual_trial(source: Any, sensors: SensorModel | None = None, seed: int = 0, i: int = 0,
                  *, name: str | None = None, vessel: Vessel | None = None) -> Trial:
    """Run ``i`` of a simulation seen through ``sensors``: a multi-rate, noisy :class:`Trial`.

    Parameters
    ----------
    source : SimResult or Trial
        The true run (perfect, uniform samples).
    sensors : SensorModel, optional
        Rates, noise and jitter (default :class:`SensorModel()`).
    seed : int
        Seed of the sensor noise (with ``i``: ``SeedSequence([seed, i])``).
    i : int
        Run of a batch.
    name, vessel : optional
        Trial label and particulars (default from the result's model when it carries one).

    Returns a Trial whose rows are the union of the sensors' time stamps; a channel is NaN at the
    stamps of other sensors. ``meta["truth"]`` holds the simulated model (run ``i``),
    ``meta["truth_file"]`` its model-file dict, ``meta["sensors"]`` the sensor settings,
    ``meta["virtual"] = True``.
    """
    sensors = sensors if sensors is not None else SensorModel()
    t, chans = run_channels(source, i)
    if t.size < 2:
        raise SimulationError("virtual trial: the run has fewer than 2 samples")
    t0, t1 = float(t[0]), float(t[-1])
    root = np.random.SeedSequence([int(seed), int(i)])
    gens = dict(zip(_GROUPS, (np.random.default_rng(s) for s in root.spawn(len(_GROUPS))),
                    strict=True))
    bias = math.radians(sensors.gyro_bias_deg_s)
    pieces: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for group, (rate_field, names) in _GROUPS.items():
        present = [c for c in names if c in chans]
        if not present:
            continue
        rng = gens[group]
        ts = _stamps(t0, t1, getattr(sensors, rate_field), sensors.jitter_s, rng)
        keep = np.ones(ts.size, bool)
        if sensors.dropout > 0:
            keep = rng.random(ts.size) >= sensors.dropout
        for c in present:
            truth = chans[c]
            if c == "psi":
                ok = np.isfinite(truth)
                truth = truth.copy()
                truth[ok] = np.unwrap(truth[ok])
            val = np.interp(ts, t, truth)
            s = sensors.sigma(c)
            if s > 0:
                val = val + rng.normal(0.0, s, ts.size)
            if c == "r":
                val = val + bias
            if c == "psi" and sensors.wrap_heading:
                val = np.angle(np.exp(1j * val))
            pieces[c] = (ts[keep], val[keep])
    # channels no sensor measures (tau_u, tau_r, dist, ...) stay out of the trial
    all_t = np.unique(np.concatenate([p[0] for p in pieces.values()]))
    data = {"t": all_t}
    for c, (ts, val) in pieces.items():
        col = np.full(all_t.size, np.nan)
        col[np.searchsorted(all_t, ts)] = val
        data[c] = col
    model = getattr(source, "model", None)
    if model is None and isinstance(source, Trial):
        model = source.meta.get("truth")
    member = _member(model, i) if model is not None else None
    truth_file: dict[str, Any] | None = None
    if member is not None:
        try:
            truth_file = model_to_dict(member)
        except Exception:  # not a VesselModel, or not writable as one file: keep the object only
            truth_file = None
    if vessel is None:
        vessel = getattr(member, "vessel", None)
        if vessel is None and isinstance(source, Trial):
            vessel = source.vessel
    meta: dict[str, Any] = {"virtual": True, "sensors": sensors.to_dict(), "seed": int(seed),
                            "run": int(i)}
    if member is not None:
        meta["truth"] = member
    if truth_file is not None:
        meta["truth_file"] = truth_file
    label = name or (source.name if isinstance(source, Trial) and source.name else "virtual")
    return Trial(data=pd.DataFrame(data), vessel=vessel or Vessel(), sources=[f"<{label}>"],
                 name=label, meta=meta)


def _member(model: Any, i: int) -> Any:
    """Run ``i`` of a batch model (array parameters indexed), or the model itself."""
    import dataclasses

    def pick(obj: Any) -> Any:
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            changes = {}
            for f in dataclasses.fields(obj):
                if not f.init:
                    continue
                v = getattr(obj, f.name)
                if isinstance(v, np.ndarray) and v.ndim == 1:
                    changes[f.name] = float(v[i])
                elif dataclasses.is_dataclass(v) and not isinstance(v, type):
                    changes[f.name] = pick(v)
            return dataclasses.replace(obj, **changes) if changes else obj
        return obj

    return pick(model)


def virtual_trial_uniform(source: Any, sensors: SensorModel | None = None, seed: int = 0,
                          i: int = 0, *, rate_hz: float = 10.0, **kw: Any) -> Trial:
    """Like :func:`virtual_trial` but every channel on one uniform grid at ``rate_hz`` [Hz]
    (same noise levels, no jitter, no dropout): ready for estimators without resampling."""
    sensors = sensors if sensors is not None else SensorModel()
    return virtual_trial(source, sensors.uniform(rate_hz), seed, i, **kw)
