"""Batch simulation entry point: pack dataclasses into flat rows and run the numba RK4 kernel.

Integration: classical 4th-order Runge-Kutta with a fixed step dt over the joint state (vessel,
servo, disturbance filter). The logic (rudder/autopilot command) and the servo dead time are
evaluated at the start of each step and held over it; an ideal servo's angle is set at the step
start (so a rudder step is exact at the step boundary). Angle limits: the hull never sees more
than +-max_angle (plus the disturbance); rates are limited inside the derivative.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from usvid.errors import SimulationError
from usvid.models.model import VesselModel
from usvid.sim import _kernel as K
from usvid.sim.logic import PID, Commanded, CourseChange, Disturbance, Turning, ZigZag
from usvid.sim.result import SimResult

_NP = 34  # 0..29 parameters by kind, 30..33 derived constants (see _kernel)

_DEFAULT_CHANNELS = {
    "nomoto1": ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd"),
    "threedof": ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n"),
    "catamaran": ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n_port", "n_stbd"),
}
_DEFAULT_CHANNELS["nomoto2"] = _DEFAULT_CHANNELS["nomoto1"]
_DEFAULT_CHANNELS["norrbin"] = _DEFAULT_CHANNELS["nomoto1"]
_KIND_CODE = {"nomoto1": 0, "nomoto2": 1, "norrbin": 2, "threedof": 3, "catamaran": 4}


def _arr(v: Any) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim > 1:
        raise SimulationError(
            f"batch parameters must be scalars or 1-D arrays (got shape {a.shape})")
    return a


class _Batch:
    """Collects per-run values and their common batch size."""

    def __init__(self) -> None:
        self.shapes: list[tuple[int, ...]] = []

    def add(self, *values: Any) -> None:
        for v in values:
            if v is not None:
                self.shapes.append(_arr(v).shape)

    def size(self) -> int:
        try:
            shape = np.broadcast_shapes(*self.shapes) if self.shapes else ()
        except ValueError as exc:
            raise SimulationError(f"batch parameters have incompatible lengths: {exc}") from None
        return int(shape[0]) if shape else 1


def _col(v: Any, B: int) -> np.ndarray:
    return np.broadcast_to(_arr(v), (B,)).astype(float)


def _initial_speed(model: VesselModel, u0: Any) -> Any:
    if u0 is not None:
        return u0
    return model.vessel.speed


def _model_values(model: VesselModel, u0: Any) -> tuple[list[Any], Any]:
    """Flat parameter list (scalars/arrays) for the kernel row and the initial surge speed."""
    d = model.dynamics
    kind = model.kind
    speed = _initial_speed(model, u0)
    if kind in ("nomoto1", "nomoto2", "norrbin"):
        if speed is None:
            raise SimulationError(f"a {kind} model needs a speed: give u0 or vessel.speed [m/s]")
        if kind == "nomoto1":
            vals = [d.K, d.T, d.delta0, speed]
        elif kind == "nomoto2":
            vals = [d.K, d.T1, d.T2, d.T3, d.delta0, speed]
        else:
            vals = [d.K, d.T, d.n1, d.n3, d.delta0, speed]
        return vals, speed
    if kind == "threedof":
        tname = type(d.thrust).__name__
        T0, n0, prop, pod = 0.0, (0.0 if d.n is None else d.n), [1.0, 1.0, 1.0, 0.0, 0.0, 1025.0],\
            [0.0, 0.0]
        if d.thrust is None:
            if speed is None:
                raise SimulationError("ThreeDOF with thrust=None needs u0 or vessel.speed (the "
                                      "thrust is then the one holding that speed, T = d11 u0)")
            tmode, T0 = 0.0, _arr(d.d11) * _arr(speed)
        elif tname == "Propeller":
            tmode = 1.0
            t = d.thrust
            prop = [t.D, t.pitch_ratio, t.disk_ratio, t.t_P, t.w_P, t.rho]
        elif tname == "PodThrust":
            tmode = 2.0
            pod = [d.thrust.c, d.thrust.d]
        elif hasattr(d.thrust, "thrust"):
            raise SimulationError(f"ThreeDOF.thrust of type {tname} is not supported by the "
                                  "simulator (use a number, Propeller or PodThrust)")
        else:
            tmode, T0 = 0.0, d.thrust
        vals = [d.m11, d.m22, d.m33, d.d11, d.d22, d.d33, d.m23, d.m32, d.d23, d.d32, d.x_l,
                1.0 if d.sway_force else 0.0, tmode, T0, n0, *prop, *pod]
        if speed is None:
            speed = _steady_speed_3dof(d, tmode, T0, n0)
        return vals, speed
    # catamaran
    tw = d.thrust
    if hasattr(tw, "nb_args"):
        fwd, rev, off, sc, lo, hi, db = tw.nb_args()
        if fwd.size > 6 or rev.size > 6:
            raise SimulationError("catamaran thrust polynomials above degree 5 are not supported")
        f6 = np.zeros(6)
        r6 = np.zeros(6)
        f6[:fwd.size] = fwd
        r6[:rev.size] = rev
        vals = [d.m11, d.m22, d.m33, d.d11, d.d22, d.d33, d.b, d.cmd, d.steer_gain, 1.0, 0.0,
                float(fwd.size), float(rev.size), off, sc, lo, hi, db, *f6, *r6]
    elif hasattr(tw, "thrust"):
        raise SimulationError(f"Catamaran.thrust of type {type(tw).__name__} is not supported "
                              "by the simulator (use TwinThrust or a number)")
    else:
        vals = [d.m11, d.m22, d.m33, d.d11, d.d22, d.d33, d.b, d.cmd, d.steer_gain, 0.0, tw,
                *([0.0] * 19)]
    if speed is None:
        speed = 2.0 * np.asarray(d.thruster_thrust(d.cmd), float) / np.asarray(d.d11, float)
    return vals, speed


def _derived(kind: str, P: np.ndarray) -> None:
    """Fill the derived-constant columns 30..33 of the kernel rows (saves divisions)."""
    if kind in ("nomoto1", "norrbin"):
        P[:, 30] = 1.0 / P[:, 1]
    elif kind == "nomoto2":
        a0 = 1.0 / (P[:, 1] * P[:, 2])
        P[:, 30] = a0
        P[:, 31] = (P[:, 1] + P[:, 2]) * a0
        P[:, 32] = P[:, 0] * a0
    elif kind == "threedof":
        P[:, 30] = 1.0 / P[:, 0]
        P[:, 31] = 1.0 / (P[:, 1] * P[:, 2] - P[:, 6] * P[:, 7])
    else:
        P[:, 30] = 1.0 / P[:, 0]
        P[:, 31] = 1.0 / P[:, 1]
        P[:, 32] = 1.0 / P[:, 2]


def _steady_speed_3dof(d: Any, tmode: float, T0: Any, n0: Any) -> Any:
    """Straight-line speed with the thrust model: root of T(u) = d11 u (bisection, vectorised)."""
    if tmode == 0.0:
        return _arr(T0) / _arr(d.d11)
    lo = np.zeros(np.broadcast_shapes(np.shape(d.d11), np.shape(n0)))
    hi = lo + 100.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        g = np.asarray(d.thrust_at(mid, n0)) - np.asarray(d.d11) * mid
        lo = np.where(g > 0, mid, lo)
        hi = np.where(g > 0, hi, mid)
    return 0.5 * (lo + hi)


def _servo_values(servo: Any, dt: float) -> tuple[int, list[Any]]:
    kind = servo.kind
    if kind == "ideal":
        return 0, [servo.max_angle, servo.max_rate, 1.0, 0.0, 1.0, 0.0]
    if kind == "first_order":
        T = _arr(servo.T)
        if np.all(T == 0):
            return 0, [servo.max_angle, servo.max_rate, 1.0, 0.0, 1.0, 0.0]
        if np.any(T == 0):
            raise SimulationError("FirstOrderServo.T: a batch cannot mix T = 0 and T > 0")
        return 1, [servo.max_angle, servo.max_rate, T, 0.0, 1.0, 0.0]
    delay_steps = np.round(_arr(servo.delay) / dt)
    return 2, [servo.max_angle, servo.max_rate, servo.omega_n, servo.zeta, servo.gain,
               delay_steps]


def _series(t_grid: np.ndarray, t: np.ndarray, values: np.ndarray | None) -> np.ndarray | None:
    """Linear interpolation of (N,) or (B, N) values onto t_grid -> (1 or B, len(t_grid))."""
    if values is None:
        return None
    v = np.atleast_2d(np.asarray(values, dtype=float))
    if t.size == 1:
        return np.repeat(v[:, :1], t_grid.size, axis=1)
    idx = np.clip(np.searchsorted(t, t_grid, side="right") - 1, 0, t.size - 2)
    w = np.clip((t_grid - t[idx]) / (t[idx + 1] - t[idx]), 0.0, 1.0)
    return v[:, idx] * (1.0 - w) + v[:, idx + 1] * w


def simulate(model: VesselModel, logic: Any, *, t_end: float, dt: float = 0.02,
             u0: Any = None, record_every: int = 1, seed: int = 0, psi0: Any = 0.0,
             disturbance: Disturbance | None = None,
             channels: tuple[str, ...] | list[str] | None = None,
             initial: dict[str, Any] | None = None) -> SimResult:
    """Simulate a batch of runs of ``model`` under ``logic`` with fixed-step RK4 (numba).

    Parameters
    ----------
    model : VesselModel
        Dynamics + servo + vessel. Any numeric parameter of its dataclasses may be an array of
        shape (B,); scalars are shared by all runs.
    logic : Turning | ZigZag | CourseChange | Commanded
        The manoeuvre (its parameters may be (B,) arrays too).
    t_end : float
        Duration [s] (rounded to a whole number of steps).
    dt : float
        Integration step [s] (default 0.02 s, the seed 000 sampling time).
    u0 : float or (B,) array, optional
        Initial/constant speed [m/s]: the constant U of response models; the initial surge speed
        of 3-DOF/catamaran models (default ``vessel.speed``, else the straight-line speed under
        the model's thrust).
    record_every : int
        Keep every k-th step (decimation) so large batches fit in memory.
    seed : int
        Offset added to the disturbance's own seed(s) (``Disturbance.seed + seed``; run i of
        the batch then draws from the stream (that sum, i)). No effect without a disturbance.
    psi0 : float or (B,) array
        Initial heading [rad].
    disturbance : Disturbance, optional
        Rudder-equivalent disturbance for any logic (a CourseChange's own takes precedence).
    channels : sequence of str, optional
        Channels to record (default: all relevant to the model kind).
    initial : dict, optional
        Initial state values (scalars or (B,) arrays) by name: ``x``, ``y`` [m], ``v`` [m/s],
        ``r`` [rad/s], ``delta`` [rad] (servo angle; also the command "before t = 0" seen through
        a dead time), ``delta_dot`` [rad/s]. ``u`` and ``psi`` are ``u0`` and ``psi0``. For
        Nomoto 2 an initial r is realised as the steady state (z = r T1 T2 / K, z' = 0).

    Returns
    -------
    SimResult
        ``t`` (N,), ``channels`` name -> (B, N), course-keeping accumulators, online zig-zag data.
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
    if int(record_every) != record_every or record_every < 1:
        raise SimulationError(f"simulate: record_every must be an integer >= 1 "
                              f"(got {record_every!r})")
    record_every = int(record_every)
    nsteps = int(round(t_end / dt))
    if nsteps < 1:
        raise SimulationError(f"simulate: t_end={t_end} is shorter than one step dt={dt}")
    kind = model.kind
    batch = _Batch()

    for name, value in (("u0", u0), ("psi0", psi0), *((f"initial['{k}']", v) for k, v in
                                                      (initial or {}).items())):
        if value is not None and not np.all(np.isfinite(_arr(value))):
            raise SimulationError(f"simulate: {name} must be finite (got {value!r})")
    mvals, speed = _model_values(model, u0)
    skind, svals = _servo_values(model.servo, dt)
    batch.add(*mvals, *svals, speed, psi0)
    initial = dict(initial or {})
    state_index = {"x": K.IX, "y": K.IY, "v": K.IV, "r": K.IR, "delta": K.IDL,
                "delta_dot": K.IDLD}
    for name, value in initial.items():
        if name not in state_index:
            raise SimulationError(f"simulate: initial['{name}'] is not an initial state "
                                  f"(use {', '.join(state_index)}; u0= and psi0= for u, psi)")
        if name == "v" and model.is_response:
            raise SimulationError("simulate: initial['v'] needs a 3-DOF or catamaran model")
        batch.add(value)

    # --- logic ---
    t_grid = np.arange(nsteps + 1) * dt
    cmd_series = np.zeros((1, nsteps + 1))
    thr_series = np.full((1, nsteps + 1, 2), np.nan)
    dist = disturbance
    if isinstance(logic, Commanded):
        lkind, lvals = 0, [0.0] * 5
        tc = np.asarray(logic.t, dtype=float)
        c = _series(t_grid, tc, logic.delta_cmd)
        if c is not None:
            cmd_series = c
        if kind == "threedof" and logic.n is not None:
            n = _series(t_grid, tc, logic.n)
            thr_series = np.full((n.shape[0], nsteps + 1, 2), np.nan)
            thr_series[:, :, 0] = n
        if kind == "catamaran" and logic.n_port is not None:
            npo = _series(t_grid, tc, logic.n_port)
            nst = _series(t_grid, tc, logic.n_stbd)
            rows = max(npo.shape[0], nst.shape[0])
            thr_series = np.empty((rows, nsteps + 1, 2))
            thr_series[:, :, 0] = npo
            thr_series[:, :, 1] = nst
        for arr in (cmd_series, thr_series):
            if arr.shape[0] > 1:
                batch.add(np.zeros(arr.shape[0]))
    elif isinstance(logic, Turning):
        lkind, lvals = 1, [logic.delta, logic.t_start, 0.0, 0.0, 0.0]
    elif isinstance(logic, ZigZag):
        lkind, lvals = 2, [logic.delta_amp, logic.psi_switch, logic.first, logic.t_start, 0.0]
    elif isinstance(logic, CourseChange):
        c: PID = logic.controller
        lkind, lvals = 3, [logic.target, c.kp, c.ki, c.kd, 1.0 if c.anti_windup else 0.0]
        if logic.disturbance is not None:
            dist = logic.disturbance
    else:
        raise SimulationError(f"simulate: unknown logic {type(logic).__name__} (use Turning, "
                              "ZigZag, CourseChange or Commanded)")
    batch.add(*lvals)
    if dist is not None:
        batch.add(dist.intensity, dist.seed)
    B = batch.size()

    P = np.zeros((B, _NP))
    for j, v in enumerate(mvals):
        P[:, j] = _col(v, B)
    _derived(kind, P)
    S = np.column_stack([_col(v, B) for v in svals] + [np.zeros(B)])
    if skind == 1:
        S[:, 6] = 1.0 / S[:, 2]
    L = np.column_stack([_col(v, B) for v in lvals])
    Dq = np.zeros((B, 2))
    if dist is not None:
        Dq[:, 0] = _col(dist.spectral_density(), B)
        Dq[:, 1] = _col(dist.seed, B) + seed
    Z0 = np.zeros((B, K.NZ))
    Z0[:, K.IPSI] = _col(psi0, B)
    if kind in ("threedof", "catamaran"):
        Z0[:, K.IU] = _col(speed, B)
    for name, value in initial.items():
        Z0[:, state_index[name]] = _col(value, B)
    if kind == "nomoto2" and "r" in initial:
        Z0[:, K.IZ1] = Z0[:, K.IR] / P[:, 32]  # z = r / (K a0), steady

    # --- channels ---
    wanted = list(channels) if channels is not None else list(_DEFAULT_CHANNELS[kind])
    if channels is None and dist is not None:
        wanted.append("dist")
    if not wanted:
        raise SimulationError("simulate: channels must name at least one channel")
    for name in wanted:
        if name not in K.CHANNELS:
            raise SimulationError(f"simulate: unknown channel '{name}' "
                                  f"(known: {', '.join(K.CHANNELS)})")
    slots = np.full(K.NCH, -1, dtype=np.int64)
    for j, name in enumerate(wanted):
        slots[K.CHANNELS.index(name)] = j
    nrec = nsteps // record_every + 1
    rec = np.empty((len(wanted), B, nrec))
    course = np.zeros((B, 3))
    zz = np.empty((B, K.N_ZZ))
    zz_t = np.empty((B, K.N_ZZ + 1))
    c = np.ascontiguousarray  # one compiled signature: C-contiguous float64 everywhere
    # small dynamic chunks: threads that get more CPU (a shared machine) take more runs
    with numba.parallel_chunksize(max(1, min(64, B // (8 * numba.get_num_threads()) or 1))):
        K.run_batch(_KIND_CODE[kind], c(P), int(skind), c(S), int(lkind), c(L), c(Dq),
                    c(cmd_series, dtype=float), c(thr_series, dtype=float), c(Z0), float(dt),
                    int(nsteps), record_every, slots, rec, course, zz, zz_t)
    return SimResult(
        t=(np.arange(nrec) * record_every) * dt,
        channels={name: rec[j] for j, name in enumerate(wanted)},
        course={"itae": course[:, 0], "iae": course[:, 1], "max_rudder": course[:, 2]},
        zigzag_online={"overshoot": zz, "reversal_t": zz_t},
        model=model, logic=logic, dt=float(dt), record_every=record_every,
        meta={"nsteps": nsteps, "integrator": "rk4", "u0": speed},
    )


# --- convenience ------------------------------------------------------------------------------
def simulate_zigzag(model: VesselModel, delta_amp: Any, psi_switch: Any | None = None, *,
                    first: Any = 1, t_start: Any = 0.0, t_end: float = 100.0,
                    **kw: Any) -> SimResult:
    """Zig-zag delta_amp/psi_switch [rad] (psi_switch defaults to delta_amp)."""
    sw = delta_amp if psi_switch is None else psi_switch
    return simulate(model, ZigZag(delta_amp, sw, first=first, t_start=t_start), t_end=t_end,
                    **kw)


def simulate_turning(model: VesselModel, delta: Any, *, t_start: Any = 0.0,
                     t_end: float | None = None, **kw: Any) -> SimResult:
    """Turning circle with rudder delta [rad] from t_start [s]. Default t_end: long enough for
    about two full circles of the Nomoto-estimated yaw rate (at least 60 s)."""
    if t_end is None:
        t_end = 60.0
        d = model.dynamics
        K_ = getattr(d, "K", None)
        if K_ is not None:
            r = np.max(np.abs(_arr(K_) * _arr(delta)))
            if r > 0:
                t_end = max(60.0, float(np.max(_arr(t_start))) + 2.5 * 2 * math.pi / r)
    return simulate(model, Turning(delta, t_start=t_start), t_end=t_end, **kw)


def simulate_course_change(model: VesselModel, target: Any, controller: PID,
                           disturbance: Disturbance | None = None, *, t_end: float = 100.0,
                           **kw: Any) -> SimResult:
    """Course change to target [rad] with a PID autopilot (seed 000 section 6.1)."""
    return simulate(model, CourseChange(target, controller, disturbance), t_end=t_end, **kw)
