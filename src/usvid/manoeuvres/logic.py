"""Manoeuvre logics (what the helmsman / autopilot commands), radians and seconds.

Every numeric field may be a scalar or an array of shape (B,) (one value per run of a batch).
The simulator evaluates a logic at the start of every integration step (the command is held
constant over the step, as a digital controller at the step rate would).

- :class:`Turning`: delta_cmd = 0 before ``t_start``, ``delta`` after.
- :class:`ZigZag`: ``first * delta_amp`` at ``t_start`` (heading psi0 then noted); the command
  flips to ``-delta_amp`` when ``psi - psi0 >= +psi_switch`` and back to ``+delta_amp`` when
  ``psi - psi0 <= -psi_switch`` (any delta/psi pair, e.g. 10/10, 20/20, 20/10; ``first=-1``
  starts to port). Positive delta turns to starboard (r > 0, ARCHITECTURE.md).
- :class:`CourseChange`: a heading autopilot with :class:`PID` (Mu et al. 2018 eq. 41) towards
  ``target``, optionally with a :class:`Disturbance`.
- :class:`Commanded`: time series of commands (rudder and/or thruster commands).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvid.errors import SimulationError

ArrayLike = float | np.ndarray

#: Mu et al. 2018 section 6.1: disturbance filter 0.42 s / (s^2 + 0.36 s + 0.37).
DISTURBANCE_TF = (0.42, 0.36, 0.37)


def _finite(owner: str, **values: ArrayLike) -> None:
    for k, v in values.items():
        a = np.asarray(v, dtype=float)
        if a.ndim > 1 or not np.all(np.isfinite(a)):
            raise SimulationError(f"{owner}.{k} must be a finite scalar or 1-D array (got {v!r})")


@dataclass
class Turning:
    """Turning circle: rudder step to ``delta`` [rad] at ``t_start`` [s] (0 before)."""

    delta: ArrayLike
    t_start: ArrayLike = 0.0

    def __post_init__(self) -> None:
        _finite("Turning", delta=self.delta, t_start=self.t_start)


@dataclass
class ZigZag:
    """Zig-zag ``delta_amp``/``psi_switch`` [rad] (IMO/ITTC), first rudder side ``first`` (+1
    starboard, -1 port), starting at ``t_start`` [s] (rudder 0 before).

    The reference heading of the deviation is the heading at ``t_start`` unless ``psi_ref``
    [rad] is given. ``command`` (+1/-1, default 0) starts the run in the middle of a zig-zag
    with that side's command in force (closed-loop replays of measured zig-zags): the logic
    then reverses at the next crossing of the switching angle on that side.
    """

    delta_amp: ArrayLike
    psi_switch: ArrayLike
    first: ArrayLike = 1
    t_start: ArrayLike = 0.0
    psi_ref: ArrayLike | None = None
    command: ArrayLike = 0.0

    def __post_init__(self) -> None:
        _finite("ZigZag", delta_amp=self.delta_amp, psi_switch=self.psi_switch,
                first=self.first, t_start=self.t_start, command=self.command)
        if self.psi_ref is not None:
            _finite("ZigZag", psi_ref=self.psi_ref)
        if not np.all(np.isin(np.asarray(self.command, dtype=float), (-1.0, 0.0, 1.0))):
            raise SimulationError(f"ZigZag.command must be -1, 0 or +1 (got {self.command!r})")
        if not np.all(np.asarray(self.delta_amp, dtype=float) >= 0):
            # the side is ``first``; a negative amplitude would steer against the switching
            # logic (heading never reaches +psi_switch: a silent endless turn)
            raise SimulationError(f"ZigZag.delta_amp must be >= 0, the side is given by first "
                                  f"(got {self.delta_amp!r})")
        if not np.all(np.asarray(self.psi_switch, dtype=float) > 0):
            raise SimulationError(f"ZigZag.psi_switch must be > 0 (got {self.psi_switch!r})")
        if not np.all(np.abs(np.asarray(self.first, dtype=float)) == 1):
            raise SimulationError(f"ZigZag.first must be +1 or -1 (got {self.first!r})")


@dataclass
class PID:
    """Heading controller (Mu et al. 2018 eq. 41, signs for our convention), gains may be arrays.

    ``delta_cmd = kp e + ki int(e dt) - kd r`` with ``e = wrap(target - psi)`` [rad] and r [rad/s]
    (the derivative of -e for a constant target). Mu et al. 2018 prints
    ``delta = -Kp (psi - psi_d) - Ki int(psi - psi_d) - Kd d(psi - psi_d)/dt`` with three positive
    gains; with positive delta giving positive r this is the stable sign (negative feedback).
    kp [-], ki [1/s], kd [s]; PD when ki = 0. Mu et al. 2018: PID kp = 0.7, ki = 0.00095, kd = 1;
    PD kp = 0.7, kd = 1. ``anti_windup``: the integrator stops while the command is saturated at
    the servo angle limit and the error would drive it further (conditional integration).
    """

    kp: ArrayLike
    ki: ArrayLike = 0.0
    kd: ArrayLike = 0.0
    anti_windup: bool = True

    def __post_init__(self) -> None:
        _finite("PID", kp=self.kp, ki=self.ki, kd=self.kd)


@dataclass
class Disturbance:
    """Rudder-equivalent disturbance: white noise through ``0.42 s / (s^2 + 0.36 s + 0.37)``
    (Mu et al. 2018 section 6.1), added to the servo angle seen by the hull (delta_eff = delta + d).

    ``intensity`` [rad]: the stationary standard deviation of d. For this filter driven by white
    noise of two-sided spectral density q, var(d) = 0.42^2 q / (2 * 0.36); the simulator uses
    q = 2 * 0.36 * intensity^2 / 0.42^2 and a piecewise-constant noise of variance q/dt per step.
    ``seed``: the generator seed, a whole number below 2^53 (run i of a batch uses the stream
    (seed, i); reproducible, independent of threads). May be arrays over the batch.
    ``stream``: the stream index of each run (default ``None``: the run's index i in the
    batch); runs with equal seed and stream see the same noise realisation (common random
    numbers: candidate autopilot gains compared under one disturbance).
    """

    intensity: ArrayLike
    seed: ArrayLike = 0
    stream: ArrayLike | None = None

    def __post_init__(self) -> None:
        _finite("Disturbance", intensity=self.intensity, seed=self.seed)
        if self.stream is not None:
            _finite("Disturbance", stream=self.stream)
            st = np.asarray(self.stream, dtype=float)
            if not np.all((st == np.round(st)) & (st >= 0) & (st < 2.0**53)):
                raise SimulationError(f"Disturbance.stream must be whole numbers in [0, 2^53) "
                                      f"(got {self.stream!r})")
        if not np.all(np.asarray(self.intensity, dtype=float) >= 0):
            raise SimulationError(f"Disturbance.intensity must be >= 0 (got {self.intensity!r})")
        # the kernel carries seeds as float64: whole numbers below 2^53 are exact, others would
        # be truncated or rounded onto another seed's stream
        sd = np.asarray(self.seed, dtype=float)
        if not np.all((sd == np.round(sd)) & (np.abs(sd) < 2.0**53)):
            raise SimulationError(f"Disturbance.seed must be whole numbers below 2^53 "
                                  f"(got {self.seed!r})")

    def spectral_density(self) -> np.ndarray:
        """Two-sided white-noise spectral density q [1/s] giving the requested std."""
        b, a1, _ = DISTURBANCE_TF
        return 2.0 * a1 * np.asarray(self.intensity, dtype=float) ** 2 / b**2


@dataclass
class CourseChange:
    """Course change / course keeping to ``target`` [rad] with a :class:`PID` autopilot.

    Mu et al. 2018 section 6.1: initial course 0, target 100 deg, with the disturbance. The heading
    error metrics (ITAE = int t |e| dt [rad s^2], IAE = int |e| dt [rad s], max |delta|) are
    accumulated by the simulator at every step.
    """

    target: ArrayLike
    controller: PID
    disturbance: Disturbance | None = None

    def __post_init__(self) -> None:
        _finite("CourseChange", target=self.target)
        if not isinstance(self.controller, PID):
            raise SimulationError("CourseChange.controller must be a PID")


@dataclass
class Commanded:
    """Time series of inputs on times ``t`` [s], interpolated linearly onto the step grid (held
    at the end values outside). Arrays (N,) or (B, N).

    ``delta`` [rad]: a measured steering angle, fed to the hull directly (the servo is bypassed)
    and linear between the step instants (first-order hold: a replay of a measured rudder);
    ``delta_cmd`` [rad]: a command through the servo, held over each step; ``n`` [rps] shaft
    speed; ``n_port``/``n_stbd`` thruster commands (both linear between step instants).
    """

    t: np.ndarray
    delta_cmd: np.ndarray | None = None
    n: np.ndarray | None = None
    n_port: np.ndarray | None = None
    n_stbd: np.ndarray | None = None
    delta: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
            raise SimulationError("Commanded.t must be a finite 1-D array")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise SimulationError("Commanded.t must be strictly increasing")
        if self.delta is not None and self.delta_cmd is not None:
            raise SimulationError("Commanded: give delta (measured angle) or delta_cmd "
                                  "(command through the servo), not both")
        for name in ("delta_cmd", "n", "n_port", "n_stbd", "delta"):
            v = getattr(self, name)
            if v is None:
                continue
            a = np.asarray(v, dtype=float)
            if a.ndim not in (1, 2) or a.shape[-1] != t.size:
                raise SimulationError(
                    f"Commanded.{name} must have shape (N,) or (B, N) with N = len(t) = "
                    f"{t.size} (got {a.shape})")
            if not np.all(np.isfinite(a)):
                raise SimulationError(f"Commanded.{name} has non-finite values")
        if (self.n_port is None) != (self.n_stbd is None):
            raise SimulationError("Commanded: give both n_port and n_stbd, or neither")
