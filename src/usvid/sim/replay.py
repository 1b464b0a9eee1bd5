"""Replays of measured inputs on a model: the windows of output error, fit metrics and
free runs, integrated by the same core as every simulation (:mod:`usvid.sim.core`).

A measured record is cut into windows (multiple shooting); each window is a lane of the core,
started from the (smoothed) measured state at its first sample and driven by the measured
steering angle (fed to the hull directly, the servo bypassed) and the measured shaft speed or
thruster commands, all linear between samples (first-order hold). ``window_s=None`` gives one
window per record: a free run from the measured initial state.

Units: time [s], angles [rad], rates [rad/s], speeds [m/s].
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import SimulationError, UsvidError
from usvid.models.environment import wind_load_model
from usvid.models.kind import ModelKind
from usvid.models.model import VesselModel
from usvid.models.registry import kind_of
from usvid.models.servo import IdealServo
from usvid.sim.layout import NENV, NWIND
from usvid.sim.simulate import Lanes, approach_speed, initial_state, servo_rows

#: Output channels a replay can compare (roll angle and rate for kinds with roll), and the
#: series holding their smoothed start values.
OUTPUTS = ("psi", "r", "u", "v", "phi", "p")
_START = {"psi": "psi_s", "r": "r_s", "u": "u_s", "v": "v_s", "rdot": "rdot_s", "phi": "phi_s",
          "p": "p_s"}
#: Inputs replayed when present in the series (the names of the core's series; ``wind_x``,
#: ``wind_y`` the logged true wind as the air's velocity over ground [m/s, north, east]).
INPUTS = ("delta", "n", "n_port", "n_stbd", "wind_x", "wind_y")
#: The wind's series among the inputs.
WIND_SERIES = ("wind_x", "wind_y")


@dataclass
class Windows:
    """Measured records cut into equal windows (batch first, time next), at step ``h`` [s].

    ``inputs`` name -> (B, W) measured inputs; ``outputs`` name -> (B, W) measured outputs;
    ``init`` name -> (B,) smoothed values at each window's first sample (``psi``, ``r``,
    ``u``, ``v``, ``rdot``, ``delta``); ``trial_index`` (B,) the record of each window;
    ``start`` (B,) the first sample's index in its (decimated) record.
    """

    h: float
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    init: dict[str, np.ndarray]
    trial_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    start: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def batch_size(self) -> int:
        return int(next(iter(self.outputs.values())).shape[0])

    @property
    def width(self) -> int:
        return int(next(iter(self.outputs.values())).shape[1])


def make_windows(series: Sequence[Mapping[str, np.ndarray]], h: float,
                 window_s: float | None, overlap: float = 0.0) -> Windows:
    """Cut uniformly sampled records into windows of ``window_s`` seconds (``None``: one window
    per record, as long as the shortest record).

    ``series``: one dict per record with 1-D arrays on one grid of step ``h`` [s]: inputs
    (``delta``, ``n``, ``n_port``, ``n_stbd``), measured outputs (``psi``, ``r``, ``u``, ``v``)
    and smoothed states (``psi_s``, ``r_s``, ``u_s``, ``v_s``, ``rdot_s``). Windows start every
    ``(1 - overlap) W`` samples; a last window is aligned with the record's end, so the whole
    record is used; a record shorter than one window is one window.
    """
    if not 0 <= overlap < 1:
        raise SimulationError(f"`overlap` must be in [0, 1) (got {overlap!r})")
    if not series:
        raise SimulationError("no records to cut into windows")
    nmin = min(len(s["psi"]) for s in series)
    if window_s is None:
        W = nmin
        if len({len(s["psi"]) for s in series}) > 1:
            return _concat([make_windows([s], h, None) for s in series])
    else:
        W = min(max(int(round(window_s / h)) + 1, 3), nmin)
    starts: list[tuple[int, int]] = []
    for i, s in enumerate(series):
        n = len(s["psi"])
        stride = max(int(round((W - 1) * (1 - overlap))), 1)
        ks = list(range(0, n - W + 1, stride))
        if ks[-1] + W < n:
            ks.append(n - W)
        starts += [(i, k) for k in ks]
    in_names = [k for k in INPUTS if k in series[0]]
    out_names = [k for k in OUTPUTS if k in series[0]]

    def stack(name: str) -> np.ndarray:
        return np.stack([np.asarray(series[i][name][k:k + W], float) for i, k in starts])

    init: dict[str, np.ndarray] = {}
    for name, src in _START.items():
        if src in series[0]:
            init[name] = np.array([series[i][src][k] for i, k in starts], dtype=float)
    if "delta" in series[0]:
        init["delta"] = np.array([series[i]["delta"][k] for i, k in starts], dtype=float)
    return Windows(h=h, inputs={k: stack(k) for k in in_names},
                   outputs={k: stack(k) for k in out_names}, init=init,
                   trial_index=np.array([i for i, _ in starts], dtype=int),
                   start=np.array([k for _, k in starts], dtype=int))


def _concat(ws: list[Windows]) -> Windows:
    """Windows of different widths cannot be stacked: free runs of records of different
    lengths are padded with NaN to the longest (the core runs each lane its own length)."""
    W = max(w.width for w in ws)

    def pad(a: np.ndarray) -> np.ndarray:
        out = np.full((a.shape[0], W), np.nan)
        out[:, :a.shape[1]] = a
        return out

    first = ws[0]
    return Windows(
        h=first.h,
        inputs={k: np.vstack([pad(w.inputs[k]) for w in ws]) for k in first.inputs},
        outputs={k: np.vstack([pad(w.outputs[k]) for w in ws]) for k in first.outputs},
        init={k: np.concatenate([w.init[k] for w in ws]) for k in first.init},
        trial_index=np.arange(len(ws)), start=np.zeros(len(ws), dtype=int))


def window_initial_state(kind: ModelKind, dynamics: Any, win: Windows,
                         init: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """The joint initial state (rows of the core, one column per window) of the windows of
    ``win``: their measured initial values, overridden by ``init``, through the kind's
    initial-state map of ``dynamics``."""
    values = dict(win.init)
    values.update(init or {})
    if not kind.constant_speed and "u" not in values:
        raise SimulationError(f"a {kind.name} replay needs the measured surge speed u")
    return initial_state(kind, dynamics, win.batch_size, psi0=values.get("psi", 0.0),
                         values={k: v for k, v in values.items() if k != "psi"})


def window_lanes(kind: ModelKind, P: np.ndarray, dynamics: Any, win: Windows,
                 init: Mapping[str, np.ndarray] | None = None,
                 channels: Sequence[str] = ("psi", "r"),
                 env_block: np.ndarray | None = None,
                 environment: Mapping[str, np.ndarray] | None = None) -> Lanes:
    """The core lanes of ``win`` for parameter rows ``P`` ((n_params, 1 or B)); ``init``
    overrides the windows' initial values (output error estimates them); ``dynamics`` gives
    the kind's initial-state map; ``env_block`` (NENV, 1) the packed wind-load model of the
    windows' wind series (:meth:`usvid.sim.Environment.block`; None: calm water, the wind
    series unused); ``environment`` further core series of the windows (:func:`replay_windows`:
    a current, force biases)."""
    B, W = win.batch_size, win.width
    Z0 = window_initial_state(kind, dynamics, win, init)
    nsteps = np.full(B, W - 1, dtype=np.int64)
    ref = win.outputs[next(iter(win.outputs))]
    nan_tail = np.isnan(ref)
    if nan_tail.any():  # padded free runs: each lane its own length
        nsteps = (W - 1 - np.argmax(nan_tail[:, ::-1] == 0, axis=1)).astype(np.int64)
    skind, S = servo_rows(IdealServo(max_angle=np.pi), B)
    series = {k: np.nan_to_num(v, nan=0.0) for k, v in win.inputs.items()
              if k in kind.inputs or k == "delta"
              or (k in WIND_SERIES and env_block is not None)}
    series.update(environment or {})
    return Lanes(kind=kind, P=np.broadcast_to(P, (P.shape[0], B)), servo=skind, S=S, Z0=Z0,
                 nsteps=nsteps, dt=win.h, series=series, channels=tuple(channels),
                 env_block=env_block)


def replay_windows(model: VesselModel, win: Windows,
                   channels: Sequence[str] | None = None,
                   wind: bool = True,
                   environment: Mapping[str, np.ndarray] | None = None
                   ) -> dict[str, np.ndarray]:
    """Simulate every window of ``win`` with ``model`` (measured inputs, measured smoothed
    initial state); returns name -> (B, W) simulated outputs (NaN after a divergence).
    Windows with a logged wind (``wind_x``, ``wind_y``) are replayed in it (``wind``; False:
    calm water), its loads from the model's vessel (:func:`wind_block`). ``environment``:
    further core series (B, W) of the windows (:data:`usvid.sim.layout.SERIES` names: an
    estimated current ``current_x``, ``current_y`` [m/s, north, east], a force bias
    ``force_Y`` [N], ``force_N`` [N m]); with a current the windows' initial velocities must be
    those through the water (the kind's states; the recorded ``u``, ``v`` are over ground)."""
    kind = kind_of(model.dynamics)
    chans = tuple(channels) if channels is not None else tuple(
        c for c in OUTPUTS if c in win.outputs and (c not in ("phi", "p") or c in kind.states))
    if kind.constant_speed:
        # the measured speed of each window; without one the replay stays put (x, y): the
        # heading and yaw rate of a constant-speed kind, all it compares, do not depend on it
        speed = win.init.get("u")
        speed = 0.0 if speed is None else speed
    else:  # the model's own approach speed (an error when it has none, never an assumed one)
        speed = approach_speed(model, None)
    P = kind.pack(model.dynamics, speed)
    env = logged_wind(model, win)[0] if wind else None
    out = window_lanes(kind, P, model.dynamics, win, channels=chans, env_block=env,
                       environment=environment).run()
    return {c: out.channels[c] for c in chans}


def logged_wind(model: VesselModel, win: Windows) -> tuple[np.ndarray | None, str]:
    """How ``win`` is replayed with ``model`` in its logged wind: (the environment block of the
    model's wind loads, :func:`wind_block`, or None for calm air; what was done and why, the
    text a replay's row states). The windows carry the logged true wind as the air's velocity
    over ground (``wind_x``, ``wind_y``) when the log has it; a model without wind loads (a
    response kind, a vessel without windage particulars) replays them in calm air."""
    if "wind_x" not in win.inputs:
        return None, "calm air: no wind logged"
    env = wind_block(model)
    if env is None:
        return None, ("calm air: wind logged, but the model has no wind loads (a response kind, "
                      "or its vessel lacks the windage particulars)")
    return env, "the logged wind"


def wind_block(model: VesselModel) -> np.ndarray | None:
    """The environment block of ``model``'s wind loads (its vessel's wind-load model with the
    vessel's ``wind_scale``: :func:`usvid.models.environment.wind_load_model`); None when the
    model is not a force kind or its vessel lacks the windage particulars (replayed calm)."""
    if kind_of(model.dynamics).constant_speed or model.vessel is None:
        return None
    try:
        wm = wind_load_model(model.vessel)
    except UsvidError:
        return None
    blk = np.zeros((NENV, 1))
    blk[:NWIND, 0] = wm.packed()
    return blk


__all__ = ["WIND_SERIES", "Windows", "logged_wind", "make_windows", "replay_windows",
           "wind_block", "window_initial_state", "window_lanes"]
