"""Batch simulation: a model and a manoeuvre logic packed into lanes of the integration core.

:func:`simulate` is the public entry (a batch of runs of one model kind under one logic);
:class:`Lanes` is the lower-level form used by identification (output-error windows, replays),
where every lane may have its own parameters, initial state, inputs and length. Both run
:func:`usvid.sim.core.kernel` -- the same equations, servo, limits and input hold.

Integration: classical RK4 with a fixed step over the joint state (vessel, servo, disturbance
filter); see :mod:`usvid.sim.core` for the timing of commands, events and inputs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import SimulationError, UsvidError
from usvid.manoeuvres.logic import PID, Commanded, CourseChange, Disturbance, Turning, ZigZag
from usvid.models.environment import (
    drift_coefficients,
    rudder_equivalent,
    wave_components,
    wave_motion,
)
from usvid.models.environment.wind_loads import WIND_PACK, wind_load_model
from usvid.models.kind import S0, ModelKind, batch_size
from usvid.models.model import VesselModel
from usvid.models.registry import kind_of
from usvid.sim import core
from usvid.sim.layout import NENV, NWIND
from usvid.sim.result import SimResult

#: Channels recorded by default (a kind's unused inputs are left out).
_BASE_CHANNELS = ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd")
#: Largest number of (lanes x recorded samples) one call may allocate (about 4 GB of float64
#: per recorded channel set would be far beyond a useful run).
MAX_RECORD = 5e8
#: Most integration steps of one run (t_end / dt): 2e7 steps are 4.6 days at 0.02 s.
MAX_STEPS = 2e7


def _arr(v: Any) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim > 1:
        raise SimulationError(
            f"batch parameters must be scalars or 1-D arrays (got shape {a.shape})")
    return a


def _col(v: Any, B: int) -> np.ndarray:
    return np.broadcast_to(_arr(v), (B,)).astype(float)


def servo_rows(servo: Any, B: int) -> tuple[int, np.ndarray]:
    """(servo code, (SERVO_ROWS, B) rows): 0 ideal, 1 first order, 2 second order.

    Rows: max_angle [rad], max_rate [rad/s], T [s] or omega_n [rad/s], zeta, gain, delay [s],
    1/T."""
    S = np.zeros((core.SERVO_ROWS, B))
    S[0] = _col(servo.max_angle, B)
    S[1] = _col(servo.max_rate, B)
    S[4] = 1.0
    kind = servo.kind
    if kind == "ideal":
        return 0, S
    if kind == "first_order":
        T = _col(servo.T, B)
        if np.all(T == 0):
            return 0, S
        if np.any(T == 0):
            raise SimulationError("FirstOrderServo.T: a batch cannot mix T = 0 and T > 0")
        S[2] = T
        S[6] = 1.0 / T
        return 1, S
    S[2] = _col(servo.omega_n, B)
    S[3] = _col(servo.zeta, B)
    S[4] = _col(servo.gain, B)
    S[5] = _col(servo.delay, B)
    return 2, S


def approach_speed(model: VesselModel, u0: Any) -> Any:
    """The approach speed [m/s]: ``u0``, else ``vessel.speed``, else the kind's straight-line
    speed under its nominal inputs; SimulationError when none is known."""
    if u0 is not None:
        return u0
    if model.vessel is not None and model.vessel.speed is not None:
        return model.vessel.speed
    kind = kind_of(model.dynamics)
    speed = kind.speed(model.dynamics) if kind.speed is not None else None
    if speed is None:
        raise SimulationError(f"a {kind.name} model needs a speed: give u0 (--speed) or "
                              "vessel.speed [m/s]")
    return speed


def _series(t_grid: np.ndarray, t: np.ndarray, values: Any) -> np.ndarray:
    """Linear interpolation of (N,) or (B, N) values onto t_grid -> (1 or B, len(t_grid))."""
    v = np.atleast_2d(np.asarray(values, dtype=float))
    if t.size == 1:
        return np.repeat(v[:, :1], t_grid.size, axis=1)
    idx = np.clip(np.searchsorted(t, t_grid, side="right") - 1, 0, t.size - 2)
    w = np.clip((t_grid - t[idx]) / (t[idx + 1] - t[idx]), 0.0, 1.0)
    return v[:, idx] * (1.0 - w) + v[:, idx + 1] * w


#: Default interval [s] of the multirate hold of the state-dependent environment loads (wind,
#: mean wave drift): evaluated every :func:`load_every` steps, linearly extrapolated from the
#: last two evaluations to each step's midpoint (:func:`usvid.sim.lane._holdget`).
LOAD_INTERVAL = 0.1


def load_every(interval: float, dt: float) -> int:
    """The steps between two evaluations of the state-dependent environment loads for a load
    interval ``interval`` [s] (0: every step) at the step ``dt`` [s]: max(1, round(interval /
    dt)), so that the interval, not dt's choice, fixes the hold's accuracy."""
    if not (math.isfinite(interval) and interval >= 0.0):
        raise SimulationError(f"Environment.load_interval must be >= 0 [s] and finite (got "
                              f"{interval!r})")
    return max(1, round(interval / dt))


def load_hold(interval: float, dt: float) -> dict[str, Any]:
    """How the state-dependent loads are held (the ``load_hold`` entry of a simulation's
    environment meta): the interval asked for and used [s], the steps per evaluation and the
    scheme."""
    m = load_every(interval, dt)
    return {"load_interval_s": float(interval), "load_every_steps": m,
            "load_interval_used_s": m * float(dt),
            "scheme": "evaluated at the start of every load interval; linearly extrapolated "
                      "from the last two evaluations to each step's midpoint, held over the "
                      "step (second order)"}


@dataclass
class Environment:
    """The environment of a simulation besides the rudder-equivalent noise: a current, a true
    wind, a sea state and an external force on the hull, each (but the sea state) a constant,
    one value per run ((B,)), or a time series over ``t`` ((M,) or (B, M) values), linear
    between samples like the measured inputs.

    ``current_speed`` [m/s] and ``current_dir`` [rad]: the current's speed and the direction it
    flows towards, from north, clockwise (constant over the area; the kinematics integrate the
    velocity over ground, the kind's states are its velocities through the water: Fossen 2021
    ch. 10.3, exact for a constant irrotational current).

    ``wind_speed`` [m/s] and ``wind_dir`` [rad]: the true wind's speed and the direction it
    comes FROM, from north, clockwise (a series: e.g. :func:`usvid.models.environment.gust_series`
    on ``t``; interpolated as the air's velocity, so that a direction through north is not
    turned the long way). Its loads are computed inside the integration from the apparent wind
    of the velocity over ground and heading (:func:`usvid.sim.lane._envload`: the load of the
    apparent wind less that of the still air, so zero wind is calm water), at the start of
    every ``load_interval`` [s] (default :data:`LOAD_INTERVAL` = 0.1 s; 0: every step; the
    steps between evaluations :func:`load_every`), linearly extrapolated from the last two
    evaluations to each RK4 step's midpoint and held over the step (the multirate hold,
    :func:`usvid.sim.lane._heldload`: second order in the interval; at 0.1 s and dt 0.02 s a
    turning's metrics within 3e-5 of the continuous model's), through ``wind_model`` (a
    :class:`~usvid.models.environment.WindLoadModel`; None: ``wind_load_model(model.vessel)``,
    Fujiwara et al. 1998 or Blendermann 1994 from the vessel's windage particulars).

    ``sea``: a :class:`~usvid.models.environment.SeaState` (constant in time; one for all runs,
    or one per run: H_s, T_p, direction (B,) arrays, each run its own drift coefficients,
    direction and realisation; a batch whose runs are all equal is that one sea state, the same
    numbers): its mean wave drift force
    (:func:`~usvid.models.environment.drift_coefficients` from the vessel's length, beam and
    draft; :func:`~usvid.models.environment.mean_drift_scalar` at the heading, held as the
    wind's loads are), and, with ``wave_motion``, the first-order wave-induced motion
    (:func:`~usvid.models.environment.wave_motion`, ``wave_components`` components drawn with
    ``wave_seed``, run b from the stream (wave_seed, b), or (wave_seed, ``wave_stream[b]``) when
    ``wave_stream`` gives each run its stream) added to the recorded x, y, psi after the run
    (Fossen 2021 ch. 10.2: eta = eta_LF + eta_WF; it does not feed back).

    ``force``: (X, Y [N], K, N [N m]) in body axes (x forward, y starboard, z down; K heels to
    starboard, N turns to starboard), a precomputed external load. The force kinds add the
    loads to their force balance; the response kinds take N as the rudder-equivalent angle
    N / N_delta (their ``N_delta`` [N m/rad]; for the wind, when not given, from
    :func:`~usvid.models.environment.rudder_equivalent` of the kind and the vessel) and have no
    use for X, Y, K. ``t`` [s]: the sample times of the series (None: constants). Zero current,
    wind and force and no sea state are calm water: the same runs as without an environment.
    """

    current_speed: Any = 0.0
    current_dir: Any = 0.0
    force: Sequence[Any] | None = None
    t: Any = None
    wind_speed: Any = 0.0
    wind_dir: Any = 0.0
    wind_model: Any = None
    sea: Any = None
    wave_motion: bool = True
    wave_seed: int = 0
    wave_components: int = 128
    wave_stream: Any = None
    load_interval: float = LOAD_INTERVAL

    @property
    def has_wind(self) -> bool:
        """A true wind other than zero."""
        a = np.asarray(self.wind_speed, dtype=float)
        return bool(np.any(a != 0.0))

    @property
    def stateful(self) -> bool:
        """Loads that depend on the state inside the step (wind, wave drift)."""
        return self.has_wind or self.sea is not None

    def series(self, t_grid: np.ndarray, B: int) -> dict[str, np.ndarray]:
        """The core's series (:data:`usvid.sim.core.SERIES` names) on the step grid t_grid
        [s]: name -> (1 or B, len(t_grid))."""
        tt = None if self.t is None else np.asarray(self.t, dtype=float)

        def on_grid(v: Any, name: str) -> np.ndarray:
            a = np.asarray(v, dtype=float)
            if not np.all(np.isfinite(a)):
                raise SimulationError(f"Environment.{name} must be finite")
            if tt is None or a.ndim == 0:  # a constant (also beside series on t)
                if a.ndim > 1:
                    raise SimulationError(f"Environment.{name}: a constant or one value per "
                                          f"run (got shape {a.shape}); give t for a series")
                return np.repeat(a.reshape(-1, 1), t_grid.size, axis=1)
            if a.shape[-1] != tt.size or a.ndim > 2:
                raise SimulationError(f"Environment.{name}: {tt.size} samples (as t) for each "
                                      f"run (got shape {a.shape})")
            return _series(t_grid, tt, a)

        speed = on_grid(self.current_speed, "current_speed")
        direction = on_grid(self.current_dir, "current_dir")
        out = {"current_x": speed * np.cos(direction), "current_y": speed * np.sin(direction)}
        if self.force is not None:
            if len(self.force) != 4:
                raise SimulationError("Environment.force must be (X, Y, K, N) [N, N, N m, N m]")
            for name, v in zip(("force_X", "force_Y", "force_K", "force_N"), self.force,
                               strict=True):
                out[name] = on_grid(v, "force")
        if self.stateful:
            ws = np.asarray(self.wind_speed, dtype=float)
            wd = np.asarray(self.wind_dir, dtype=float)
            for name, a in (("wind_speed", ws), ("wind_dir", wd)):
                if not np.all(np.isfinite(a)):
                    raise SimulationError(f"Environment.{name} must be finite")
            if np.any(ws < 0.0):
                raise SimulationError("Environment.wind_speed must be >= 0 [m/s]")
            try:
                ws, wd = np.broadcast_arrays(ws, wd)
            except ValueError:
                raise SimulationError(f"Environment.wind_speed and wind_dir: shapes {ws.shape} "
                                      f"and {wd.shape} do not match") from None
            # the air's velocity over ground (north, east): a wind from wd moves it towards
            # wd + pi (usvid.models.environment.wind)
            out["wind_x"] = on_grid(-ws * np.cos(wd), "wind_speed")
            out["wind_y"] = on_grid(-ws * np.sin(wd), "wind_speed")
        for a in out.values():
            if a.shape[0] not in (1, B):
                raise SimulationError(f"Environment: {a.shape[0]} runs' values for a batch of "
                                      f"{B}")
        return out

    def block(self, model: VesselModel, kind: ModelKind) -> tuple[np.ndarray, Any, dict]:
        """The environment block of the core (:data:`usvid.sim.layout.ENVBLOCK`, (NENV, 1)),
        the model's dynamics to simulate (a response kind's ``N_delta`` filled in from
        :func:`~usvid.models.environment.rudder_equivalent` for the wind when not given) and
        what was chosen and assumed (:meth:`describe`'s ``wind`` and ``waves`` entries).
        SimulationError naming the missing particular when the vessel lacks one."""
        assert NWIND == WIND_PACK
        sea = None if self.sea is None else self.sea.collapsed()
        blk = np.zeros((NENV, 1 if sea is None or sea.batch is None else sea.batch))
        info: dict[str, Any] = {}
        dyn = model.dynamics
        vessel = model.vessel
        if self.has_wind:
            wm = self.wind_model
            try:
                if wm is None:
                    if vessel is None:
                        raise UsvidError("wind loads need the vessel's windage particulars: the "
                                         "model has no vessel block")
                    wm = wind_load_model(vessel)
                blk[:NWIND, :] = np.asarray(wm.packed(), dtype=float)[:, None]
            except UsvidError as exc:
                raise SimulationError(f"simulate: {exc}") from None
            w: dict[str, Any] = {"model": wm.name, "reason": wm.reason,
                                 "assumed": list(wm.assumed), "wind_scale": wm.wind_scale,
                                 "air_density_kg_m3": wm.air_density,
                                 "particulars": dict(wm.particulars),
                                 "loads": "apparent wind less still air (ISO 15016)"}
            if wm.name == "fujiwara1998":
                w["assumed"].append("roll moment K = 0 (Fujiwara et al. 1998 gives none here)")
            if kind.constant_speed:
                if getattr(dyn, "N_delta", None) is None:
                    try:
                        if vessel is None:
                            raise UsvidError("the model has no vessel block (mass, length)")
                        re, n_delta = _rudder_equivalents(kind.name, dyn.values(), vessel)
                    except UsvidError as exc:
                        raise SimulationError(
                            f"simulate: a {kind.name} model takes the wind's yaw moment as a "
                            f"rudder-equivalent angle N / N_delta and N_delta cannot be had: "
                            f"{exc}; give its parameter N_delta [N m/rad]") from None
                    dyn = dyn.replace(N_delta=n_delta)
                    w["rudder_equivalent"] = re.to_dict()
                else:
                    w["rudder_equivalent"] = {"N_delta_N_m_per_rad": float(np.mean(
                        np.asarray(dyn.N_delta, dtype=float))), "assumed": ["given"]}
                w["assumed"].append(f"a {kind.name} model has no sway and constant speed: the "
                                    "wind's X, Y and K are not represented, only N (as a "
                                    "rudder angle)")
            info["wind"] = w
        if sea is not None:
            missing = [f"vessel.{k}" for k in ("length", "beam", "draft")
                       if vessel is None or getattr(vessel, k, None) is None]
            if missing:
                raise SimulationError(f"simulate: the mean wave drift needs {', '.join(missing)} "
                                      "[m]")
            try:
                fx0, fy0 = drift_coefficients(sea, float(vessel.length),
                                              float(vessel.beam), float(vessel.draft))
            except UsvidError as exc:
                raise SimulationError(f"simulate: {exc}") from None
            if sea.batch is None:
                blk[NWIND:, 0] = (fx0, fy0, math.cos(sea.chi), math.sin(sea.chi))
            else:  # one sea state per run: its own drift coefficients and direction
                blk[NWIND:, :] = [np.broadcast_to(v, (sea.batch,)) for v in (
                    fx0, fy0, np.cos(sea.chi), np.sin(sea.chi))]
            info["waves"] = {**sea.to_dict(), "drift_fx0_N": _number(fx0),
                             "drift_fy0_N": _number(fy0),
                             "first_order_motion": bool(self.wave_motion),
                             "wave_seed": int(self.wave_seed),
                             "wave_components": int(self.wave_components)}
            if kind.constant_speed:
                info["waves"]["assumed"] = [f"a {kind.name} model has no sway: the drift force "
                                            "(no yaw moment) does not act on it"]
        return blk, dyn, info

    def describe_for(self, model: VesselModel) -> dict[str, Any]:
        """:meth:`describe` with what :meth:`block` chose and assumed for ``model`` (the wind
        load model, its reason and particulars, the rudder equivalent, the drift coefficients):
        the ``environment`` that ``usvid simulate --json`` echoes. SimulationError naming the
        missing particular when the vessel lacks one."""
        info = self.block(model, kind_of(model.dynamics))[2] if self.stateful else {}
        return _merged(self.describe(), info)

    def describe(self) -> dict[str, Any]:
        """The inputs, JSON-ready (angles in degrees, as named): ``current`` (speed [m/s],
        direction towards [deg]), ``wind`` (speed [m/s], direction from [deg]), ``waves`` (the
        sea state), ``force`` given or not; a series is described by its mean."""
        def num(v: Any) -> Any:
            a = np.asarray(v, dtype=float)
            return float(a) if a.ndim == 0 else {"mean": float(np.mean(a)), "min":
                                                 float(np.min(a)), "max": float(np.max(a))}

        def deg(v: Any) -> Any:
            a = np.degrees(np.asarray(v, dtype=float))
            return num(a)

        out: dict[str, Any] = {
            "current": {"speed_m_s": num(self.current_speed),
                        "direction_towards_deg": deg(self.current_dir)},
            "wind": {"speed_m_s": num(self.wind_speed),
                     "direction_from_deg": deg(self.wind_dir)},
            "waves": None if self.sea is None else self.sea.to_dict(),
            "external_force": self.force is not None, "series": self.t is not None}
        return out


def _number(v: Any) -> Any:
    """A number, or a per-run array described by its mean, min and max (JSON-ready)."""
    a = np.asarray(v, dtype=float)
    return v if a.ndim == 0 else {"mean": float(np.mean(a)), "min": float(np.min(a)),
                                  "max": float(np.max(a))}


def _rudder_equivalents(kind: str, params: dict[str, Any], vessel: Any) -> tuple[Any, Any]:
    """(the :func:`~usvid.models.environment.rudder_equivalent` of the first run, N_delta
    [N m/rad]: a number, or one per run when the kind's parameters are (B,) arrays, each run's
    from its own parameters)."""
    arrays = {k: np.asarray(v, dtype=float) for k, v in params.items()
              if isinstance(v, (int, float, np.ndarray, np.number)) and not isinstance(v, bool)}
    B = max([a.size for a in arrays.values() if a.ndim], default=0)
    if B == 0:
        re = rudder_equivalent(kind, params, vessel)
        return re, re.N_delta

    def run(b: int) -> dict[str, Any]:
        return {**params, **{k: float(a if a.ndim == 0 else np.broadcast_to(a, (B,))[b])
                             for k, a in arrays.items()}}

    each = [rudder_equivalent(kind, run(b), vessel) for b in range(B)]
    return each[0], np.array([r.N_delta for r in each])


def _merged(described: dict[str, Any], info: dict[str, Any]) -> dict[str, Any]:
    """:meth:`Environment.describe` with :meth:`Environment.block`'s entries merged in."""
    for key, value in info.items():
        described[key] = {**(described.get(key) or {}), **value}
    return described


@dataclass
class LaneResult:
    """Raw output of :meth:`Lanes.run`: recorded channels (name -> (B, N)), course accumulators
    (3, B): ITAE, IAE, max |delta|; zig-zag overshoots (N_ZZ, B) and reversal times
    (N_ZZ + 1, B); status (2, B): code (0 ok, 1 diverged) and the time [s] it happened."""

    t: np.ndarray
    channels: dict[str, np.ndarray]
    acc: np.ndarray
    zz: np.ndarray
    zzt: np.ndarray
    status: np.ndarray


@dataclass
class Lanes:
    """A batch of lanes for the integration core (SI units; B lanes).

    ``P`` (n_params, B) the kind's packed parameter rows; ``servo``/``S`` the servo code and
    rows (:func:`servo_rows`); ``logic`` a :mod:`usvid.sim.core` logic code with its rows ``L``
    (6, B); ``Z0`` (n_states, B) initial joint states; ``nsteps`` (B,) steps per lane;
    ``series`` name -> (1 or B, max(nsteps) + 1) input samples at the step instants
    (``delta`` measured rudder angle [rad], ``n`` [rps], ``n_port``, ``n_stbd``, ``delta_cmd``
    [rad]; the environment: ``force_X``, ``force_Y`` [N], ``force_K``, ``force_N`` [N m] the
    external force in body axes, ``current_x``, ``current_y`` [m/s] the current's velocity
    north and east, :class:`Environment`); ``Dq`` (2 or 3, B) disturbance spectral density
    [1/s], seed and (optional) noise stream index (default: the lane index; lanes with equal
    seed and stream see the same noise); ``env_block`` (NENV, 1 or B) the state-dependent
    environment (:data:`usvid.sim.layout.ENVBLOCK`: the packed wind-load model and the mean
    wave drift, :meth:`Environment.block`; None: none), with the series ``wind_x``, ``wind_y``;
    ``load_interval`` [s] that environment's (:attr:`Environment.load_interval`).
    """

    kind: ModelKind
    P: np.ndarray
    servo: int
    S: np.ndarray
    Z0: np.ndarray
    nsteps: np.ndarray
    dt: float
    logic: int = core.COMMANDED
    L: np.ndarray | None = None
    series: Mapping[str, np.ndarray] = field(default_factory=dict)
    Dq: np.ndarray | None = None
    channels: Sequence[str] = ("psi", "r")
    record_every: int = 1
    env_block: np.ndarray | None = None
    load_interval: float = LOAD_INTERVAL

    @property
    def size(self) -> int:
        return int(self.Z0.shape[1])

    def run(self) -> LaneResult:
        """Integrate every lane; returns the recorded channels and accumulators."""
        B = self.size
        nmax = int(np.max(self.nsteps)) if B else 0
        for name in self.channels:
            if name not in core.CHANNELS:
                raise SimulationError(f"unknown channel '{name}' (known: "
                                      f"{', '.join(core.CHANNELS)})")
            if name in core.STATE_CHANNELS and name not in self.kind.states:
                raise SimulationError(
                    f"channel '{name}' needs a kind with the state '{name}' (a "
                    f"{self.kind.name} model has {', '.join(self.kind.states)})")
        slots = np.full(len(core.CHANNELS), -1, dtype=np.int64)
        for j, name in enumerate(self.channels):
            slots[core.CHANNELS.index(name)] = j
        nrec = nmax // self.record_every + 1
        if B * nrec * len(self.channels) > MAX_RECORD:
            raise SimulationError(
                f"the simulation would record {B} runs x {nrec} samples x "
                f"{len(self.channels)} channels ({B * nrec * len(self.channels) * 8 / 1e9:.1f} "
                "GB); use a larger step, a shorter run, record_every or fewer runs")
        rec = np.full((len(self.channels), B, nrec), np.nan)
        names = (*core.SERIES, "delta_cmd")
        given = [n for n in names if n in self.series]
        rows_ = max([np.asarray(self.series[n]).shape[0] for n in given], default=1)
        SER = np.full((max(len(given), 1), rows_, nmax + 1), np.nan)
        sidx = np.full(len(names), -1, dtype=np.int64)
        for j, n in enumerate(given):
            a = np.asarray(self.series[n], dtype=float)
            if a.ndim != 2 or a.shape[1] < nmax + 1:
                raise SimulationError(f"input series '{n}' must have shape (1 or B, "
                                      f">= {nmax + 1}) (got {a.shape})")
            SER[j] = np.broadcast_to(a[:, :nmax + 1], (rows_, nmax + 1))
            sidx[names.index(n)] = j
        if rows_ not in (1, B):
            raise SimulationError(f"input series have {rows_} rows for {B} lanes")
        L = np.zeros((6, B)) if self.L is None else self.L
        Dq = np.zeros((2, B)) if self.Dq is None else np.asarray(self.Dq, dtype=float)
        if Dq.shape[0] == 2:
            Dq = np.vstack([Dq, np.arange(B, dtype=float)[None, :]])
        qlen = float(np.max(self.S[5], initial=0.0)) / self.dt
        if not qlen <= MAX_STEPS:
            raise SimulationError(
                f"the servo dead time {float(np.max(self.S[5])):.4g} s at dt = {self.dt:.4g} s "
                f"needs a queue of {qlen:.4g} samples per run ({B * qlen * 16 / 1e9:.3g} GB); "
                "use a larger dt")
        qcap = int(np.ceil(qlen)) + 3
        acc = np.zeros((B, 3))
        zz = np.empty((B, core.N_ZZ))
        zzt = np.empty((B, core.N_ZZ + 1))
        status = np.zeros((B, 2))
        Z = np.array(np.asarray(self.Z0, dtype=float).T, order="C")

        def c(a: Any, dtype: Any = float) -> np.ndarray:  # lane-major, C, writable
            return np.array(np.asarray(a, dtype=dtype).T, dtype=dtype, order="C")

        P = np.asarray(self.P, dtype=float)
        wind = self.env_block is not None
        if wind:
            eb = np.asarray(self.env_block, dtype=float)
            P = np.vstack([np.broadcast_to(P, (P.shape[0], B)), np.broadcast_to(eb, (eb.shape[0],
                                                                                     B))])
        core.run(self.kind, c(P), c(self.S), int(self.servo), int(self.logic), c(L),
                 c(Dq), SER, sidx, Z, np.require(self.nsteps, np.int64, ("C", "W")),
                 float(self.dt), int(self.record_every), slots, rec, acc, zz, zzt, status, qcap,
                 wind=wind, load_every=load_every(self.load_interval, self.dt))
        acc, zz, zzt, status = acc.T, zz.T, zzt.T, status.T
        return LaneResult(t=np.arange(nrec) * self.record_every * self.dt,
                          channels={n: rec[j] for j, n in enumerate(self.channels)},
                          acc=acc, zz=zz, zzt=zzt, status=status)


def initial_state(kind: ModelKind, dynamics: Any, B: int, *, psi0: Any = 0.0,
                  values: Mapping[str, Any] | None = None) -> np.ndarray:
    """The (n_states, B) joint initial state: x, y [m], psi [rad], the kind's states from
    ``values`` (``u``, ``v``, ``r``, ``rdot``, ``delta``), servo angle ``delta`` [rad] and rate
    ``delta_dot`` [rad/s]; disturbance filter at rest."""
    values = dict(values or {})
    nz = S0 + kind.n_states + 4
    Z0 = np.zeros((nz, B))
    Z0[0] = _col(values.get("x", 0.0), B)
    Z0[1] = _col(values.get("y", 0.0), B)
    Z0[2] = _col(psi0, B)
    Z0[S0:S0 + kind.n_states] = np.broadcast_to(kind.initial(dynamics, values),
                                                (kind.n_states, B))
    Z0[S0 + kind.n_states] = _col(values.get("delta", 0.0), B)
    Z0[S0 + kind.n_states + 1] = _col(values.get("delta_dot", 0.0), B)
    return Z0


#: Initial values by name (besides the kind's own states, e.g. a roll angle phi).
_INITIAL = ("x", "y", "v", "r", "delta", "delta_dot")


def simulate(model: VesselModel, logic: Any, *, t_end: float, dt: float = 0.02,
             u0: Any = None, record_every: int = 1, seed: int = 0, psi0: Any = 0.0,
             disturbance: Disturbance | None = None, environment: Environment | None = None,
             channels: tuple[str, ...] | list[str] | None = None,
             initial: dict[str, Any] | None = None) -> SimResult:
    """Simulate a batch of runs of ``model`` under ``logic`` with fixed-step RK4 (numba).

    Parameters
    ----------
    model : VesselModel
        Dynamics + servo + vessel. Any numeric parameter may be an array of shape (B,);
        scalars are shared by all runs.
    logic : Turning | ZigZag | CourseChange | Commanded
        The manoeuvre (its parameters may be (B,) arrays too).
    t_end : float
        Duration [s] (rounded to a whole number of steps).
    dt : float
        Integration step [s] (default 0.02 s).
    u0 : float or (B,) array, optional
        Approach speed [m/s]: the constant U of response models, the initial surge speed of
        the others (default ``vessel.speed``, else the straight-line speed of the model).
    record_every : int
        Keep every k-th step (so large batches fit in memory).
    seed : int
        Offset added to the disturbance's own seed(s); run i draws from the stream
        (seed sum, i), or (seed sum, ``disturbance.stream[i]``) when the disturbance gives its
        streams. No effect without a disturbance.
    psi0 : float or (B,) array
        Initial heading [rad].
    disturbance : Disturbance, optional
        Rudder-equivalent disturbance for any logic (a CourseChange's own takes precedence).
    environment : Environment, optional
        A current, a wind, a sea state (one, or one per run) and an external force on the hull
        (:class:`Environment`); recorded u, v, U are then over ground.
    channels : sequence of str, optional
        Channels to record (default: all relevant to the model kind).
    initial : dict, optional
        Initial values by name: ``x``, ``y`` [m], ``v`` [m/s], ``r`` [rad/s], ``delta`` [rad]
        (servo angle; also the command in force before t = 0), ``delta_dot`` [rad/s], or any
        other state of the kind by its name (e.g. a roll angle ``phi`` [rad]).

    Returns
    -------
    SimResult
        ``t`` (N,), ``channels`` name -> (B, N), accumulators, ``success``/``message``.
    """
    if not isinstance(model, VesselModel):
        raise SimulationError(f"simulate: model must be a VesselModel (got {type(model).__name__})")
    try:
        dt, t_end = float(dt), float(t_end)
    except (TypeError, ValueError):
        raise SimulationError(f"simulate: dt and t_end must be numbers [s] "
                              f"(got dt={dt!r}, t_end={t_end!r})") from None
    if not (dt > 0 and math.isfinite(dt)):
        raise SimulationError(f"simulate: dt must be > 0 (got {dt!r})")
    if not (t_end > 0 and math.isfinite(t_end)):
        raise SimulationError(f"simulate: t_end must be > 0 (got {t_end!r})")
    if isinstance(record_every, bool) or int(record_every) != record_every or record_every < 1:
        raise SimulationError(f"simulate: record_every must be an integer >= 1 "
                              f"(got {record_every!r})")
    record_every = int(record_every)
    steps = t_end / dt
    if steps > MAX_STEPS:
        raise SimulationError(
            f"simulate: t_end / dt = {steps:.4g} steps (at most {MAX_STEPS:.0f}); the step grid "
            f"and input series alone would need {steps * 8 * 8 / 1e9:.3g} GB; use a larger dt "
            "or a shorter t_end")
    nsteps = int(round(steps))
    if nsteps < 1:
        raise SimulationError(f"simulate: t_end={t_end} is shorter than one step dt={dt}")
    kind = kind_of(model.dynamics)
    initial = dict(initial or {})
    for name, value in (("u0", u0), ("psi0", psi0), *((f"initial['{k}']", v) for k, v in
                                                      initial.items())):
        if value is not None and not np.all(np.isfinite(_arr(value))):
            raise SimulationError(f"simulate: {name} must be finite (got {value!r})")
    for name in initial:
        if name not in _INITIAL and (name not in kind.states or name == "u"):
            raise SimulationError(f"simulate: initial['{name}'] is not an initial state "
                                  f"(use {', '.join(_INITIAL)} or a state of the kind: "
                                  f"{', '.join(kind.states)}; u0= and psi0= for u, psi)")
        if name == "v" and kind.constant_speed:
            raise SimulationError("simulate: initial['v'] needs a 3-DOF model with sway (not a "
                                  "constant-speed response model)")
    speed = approach_speed(model, u0)
    dist = disturbance
    env_block = None
    env_info: dict[str, Any] = {}
    if environment is not None and environment.stateful:
        env_block, dyn, env_info = environment.block(model, kind)
        if dyn is not model.dynamics:
            model = VesselModel(dyn, servo=model.servo, vessel=model.vessel)
    lrows: list[Any] = [0.0] * 6
    lk = core.COMMANDED
    series: dict[str, Any] = {}
    t_grid = np.arange(nsteps + 1) * dt
    if isinstance(logic, Commanded):
        tc = np.asarray(logic.t, dtype=float)
        for name, value in (("delta", logic.delta), ("delta_cmd", logic.delta_cmd),
                            ("n", logic.n), ("n_port", logic.n_port),
                            ("n_stbd", logic.n_stbd)):
            if value is None:
                continue
            if name in ("n", "n_port", "n_stbd") and name not in kind.inputs:
                raise SimulationError(f"Commanded.{name}: a {kind.name} model has no input "
                                      f"'{name}' (its inputs: {', '.join(kind.inputs)})")
            series[name] = _series(t_grid, tc, value)
    elif isinstance(logic, Turning):
        lk, lrows = core.TURNING, [logic.delta, logic.t_start, 0.0, 0.0, 0.0, 0.0]
    elif isinstance(logic, ZigZag):
        lk = core.ZIGZAG
        lrows = [logic.delta_amp, logic.psi_switch, logic.first, logic.t_start,
                 np.nan if logic.psi_ref is None else logic.psi_ref, logic.command]
    elif isinstance(logic, CourseChange):
        c: PID = logic.controller
        lk = core.COURSE
        lrows = [logic.target, c.kp, c.ki, c.kd, 1.0 if c.anti_windup else 0.0, 0.0]
        if logic.disturbance is not None:
            dist = logic.disturbance
    else:
        raise SimulationError(f"simulate: unknown logic {type(logic).__name__} (use Turning, "
                              "ZigZag, CourseChange or Commanded)")
    values: dict[str, Any] = {"speed": speed, "psi0": psi0, **initial}
    for i, v in enumerate(lrows):
        values[f"logic{i}"] = v
    for k, v in series.items():
        values[f"series_{k}"] = np.zeros(np.asarray(v).shape[0]) if np.asarray(v).shape[0] > 1 \
            else 0.0
    if environment is not None and environment.sea is not None:
        for k in ("hs", "tp", "direction"):  # a batch of sea states: one per run
            values[f"sea_{k}"] = getattr(environment.sea, k)
    if dist is not None:
        values.update(dist_q=dist.intensity, dist_seed=dist.seed)
        if dist.stream is not None:
            values["dist_stream"] = dist.stream
    try:
        B = batch_size({**values, **{k: v for k, v in model.dynamics.values().items()
                                     if not hasattr(v, "thrust")},
                        **{k: getattr(model.servo, k) for k in ("max_angle", "max_rate")}})
        P = kind.pack(model.dynamics, speed)
    except UsvidError as exc:
        raise SimulationError(f"simulate: {exc}") from None
    if P.shape[1] not in (1, B):
        B = max(B, P.shape[1])
    P = np.broadcast_to(P, (P.shape[0], B))
    if environment is not None:
        env = environment.series(t_grid, B)
        if kind.constant_speed and np.any(env.get("force_N", 0.0) != 0.0) and getattr(
                model.dynamics, "N_delta", None) is None:
            raise SimulationError(
                f"simulate: a {kind.name} model takes an external yaw moment as a "
                "rudder-equivalent angle N / N_delta: give its parameter N_delta [N m/rad] "
                "(the yaw moment of one radian of rudder)")
        series.update(env)
    skind, S = servo_rows(model.servo, B)
    L = np.vstack([_col(v, B) for v in lrows])
    Dq = np.zeros((3, B))
    Dq[2] = np.arange(B)
    if dist is not None:
        Dq[0] = _col(dist.spectral_density(), B)
        Dq[1] = _col(dist.seed, B) + seed
        if dist.stream is not None:
            Dq[2] = _col(dist.stream, B)
    init_vals = dict(initial)
    if not kind.constant_speed:
        init_vals["u"] = speed
    if "delta" in series and "delta" not in init_vals:
        init_vals["delta"] = series["delta"][:, 0]
    Z0 = initial_state(kind, model.dynamics, B, psi0=psi0, values=init_vals)
    if channels is None:
        wanted = (list(_BASE_CHANNELS) + [n for n in ("n", "n_port", "n_stbd")
                                          if n in kind.inputs]
                  + [n for n in core.STATE_CHANNELS if n in kind.states])
        if dist is not None:
            wanted.append("dist")
    else:
        wanted = list(channels)
    if not wanted:
        raise SimulationError("simulate: channels must name at least one channel")
    lanes = Lanes(kind=kind, P=P, servo=skind, S=S, Z0=Z0, nsteps=np.full(B, nsteps),
                  dt=dt, logic=lk, L=L, series=series, Dq=Dq, channels=tuple(wanted),
                  record_every=record_every, env_block=env_block,
                  load_interval=LOAD_INTERVAL if environment is None
                  else environment.load_interval)
    out = lanes.run()
    chans = out.channels
    _fill_inputs(kind, model.dynamics, chans, B)
    meta: dict[str, Any] = {"nsteps": nsteps, "integrator": "rk4", "u0": speed,
                            "kind": kind.name}
    if environment is not None:
        if env_block is not None:
            env_info["load_hold"] = load_hold(environment.load_interval, dt)
        meta["environment"] = _merged(environment.describe(), env_info)
        if environment.sea is not None and environment.wave_motion:
            _add_wave_motion(environment, model, out.t, chans, B)
    return SimResult(
        t=out.t, channels=chans,
        course={"itae": out.acc[0], "iae": out.acc[1], "max_rudder": out.acc[2]},
        zigzag_online={"overshoot": out.zz.T.copy(), "reversal_t": out.zzt.T.copy()},
        model=model, logic=logic, dt=float(dt), record_every=record_every,
        status=out.status[0].astype(int), t_fail=out.status[1],
        meta=meta,
    )


def _add_wave_motion(env: Environment, model: VesselModel, t: np.ndarray,
                     chans: dict[str, np.ndarray], B: int) -> None:
    """The first-order wave-induced motion of ``env.sea`` added to the recorded x, y, psi
    (:func:`usvid.models.environment.wave_motion` along the recorded track; run b draws its
    components from (wave_seed, b), or (wave_seed, wave_stream[b])); needs x, y and psi
    recorded (the phases follow the position, the response the heading)."""
    if not all(k in chans for k in ("x", "y", "psi")):
        raise SimulationError("simulate: the first-order wave motion needs the channels x, y "
                              "and psi recorded (or Environment(wave_motion=False))")
    L = float(model.vessel.length)
    sea = env.sea.collapsed()
    if sea.batch is not None and sea.batch != B:
        raise SimulationError(f"simulate: {sea.batch} sea states for a batch of {B} runs")
    comps = wave_components(sea, n_components=int(env.wave_components),
                            seed=int(env.wave_seed), n_batch=B, length=L,
                            streams=None if env.wave_stream is None else
                            np.broadcast_to(np.asarray(env.wave_stream, float), (B,)))
    wm = wave_motion(comps, sea, L, t, chans["x"], chans["y"], chans["psi"])
    chans["x"] = chans["x"] + wm.north
    chans["y"] = chans["y"] + wm.east
    chans["psi"] = chans["psi"] + wm.psi


def _fill_inputs(kind: ModelKind, dyn: Any, chans: dict[str, np.ndarray], B: int) -> None:
    """Recorded inputs the kind takes from its nominal values when not commanded."""
    if "n" in chans and "n" in kind.inputs and getattr(dyn, "n", None) is not None:
        n0 = np.broadcast_to(np.asarray(dyn.n, float), (B,))[:, None]
        chans["n"] = np.where(np.isnan(chans["n"]), n0, chans["n"])
    if kind.channels is not None:
        kind.channels(dyn, chans)
