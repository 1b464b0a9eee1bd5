"""The result of a batch simulation: named channels on a uniform time grid, plus metrics."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from usvid import manoeuvres  # its metrics load on first use (PEP 562), not with the simulation
from usvid.errors import SimulationError
from usvid.manoeuvres.logic import Turning, ZigZag
from usvid.trial import CHANNEL_UNITS, Trial, Vessel

if TYPE_CHECKING:
    import pandas as pd


@dataclass
class SimResult:
    """Batch simulation result.

    Attributes
    ----------
    t : (N,) time [s] of the recorded samples (every ``record_every`` steps of ``dt``).
    channels : dict name -> (B, N) array, SI units (:data:`CHANNEL_UNITS`): x, y [m, NED],
        psi [rad], u, v [m/s], r [rad/s], U [m/s], delta (servo angle) and delta_cmd (logic
        command) [rad]; n [rps] (threedof), n_port/n_stbd (catamaran commands), dist [rad]
        (rudder-equivalent disturbance), roll angle phi [rad, positive heel to starboard] and
        roll rate p [rad/s] (kinds with those states) where relevant.
    course : dict with ``itae`` [rad s^2], ``iae`` [rad s], ``max_rudder`` [rad], each (B,),
        accumulated at every integration step (not the recorded grid). ITAE/IAE are 0 unless
        the logic is a :class:`~usvid.manoeuvres.logic.CourseChange`.
    zigzag_online : dict with ``overshoot`` (B, 8) [rad] and ``reversal_t`` (B, 9) [s]
        (execute time then reversal times) tracked at every step by a ZigZag logic; NaN where
        not reached / not completed. :meth:`zigzag_metrics` is the full (interpolated) version.
    model, logic, dt, record_every, meta : what was simulated.
    """

    t: np.ndarray
    channels: dict[str, np.ndarray]
    course: dict[str, np.ndarray]
    zigzag_online: dict[str, np.ndarray]
    model: Any
    logic: Any
    dt: float
    record_every: int = 1
    status: np.ndarray | None = None
    t_fail: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """True when every run was integrated to its end (none diverged)."""
        return self.status is None or not bool(np.any(self.status))

    @property
    def message(self) -> str:
        """What happened: "ok", or which runs diverged (state not finite or |r| beyond
        100 rad/s) and when."""
        if self.success:
            return "ok"
        bad = np.flatnonzero(self.status)
        first = int(bad[0])
        tf = float(self.t_fail[first]) if self.t_fail is not None else float("nan")
        return (f"{bad.size} of {self.batch_size} run(s) diverged (state not finite or |r| > "
                f"100 rad/s), the first (run {first}) at t = {tf:.3g} s; the step dt = "
                f"{self.dt:g} s may be too large for the model, or the model unstable")

    def units(self) -> dict[str, str]:
        """SI unit of every recorded channel."""
        return {k: CHANNEL_UNITS.get(k, "") for k in self.channels}

    @property
    def batch_size(self) -> int:
        """Number of runs B."""
        return int(next(iter(self.channels.values())).shape[0])

    def __len__(self) -> int:
        return self.batch_size

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.channels:
            raise SimulationError(f"SimResult has no channel '{name}' "
                                  f"(recorded: {', '.join(self.channels)})")
        return self.channels[name]

    def _run(self, i: int) -> int:
        if not -self.batch_size <= i < self.batch_size:
            raise SimulationError(f"run index {i} out of range (batch size {self.batch_size})")
        return i % self.batch_size

    def _logic_value(self, name: str, i: int) -> float:
        v = np.asarray(getattr(self.logic, name), dtype=float)
        return float(v if v.ndim == 0 else v[i])

    # --- metrics --------------------------------------------------------------------------
    def zigzag_metrics(self, **kw: Any) -> list[Any]:
        """One :class:`usvid.manoeuvres.metrics.ZigZagMetrics` per run (needs psi, delta
        recorded)."""
        out = []
        for i in range(self.batch_size):
            args: dict[str, Any] = {}
            if isinstance(self.logic, ZigZag):
                args = {"delta_amp": abs(self._logic_value("delta_amp", i)),
                        "psi_switch": self._logic_value("psi_switch", i),
                        "t_execute": self._logic_value("t_start", i),
                        "first": int(self._logic_value("first", i))}
                if self.logic.psi_ref is not None:
                    args["psi_ref"] = self._logic_value("psi_ref", i)
            if "x" in self.channels and "y" in self.channels:
                args.update(x=self.channels["x"][i], y=self.channels["y"][i])
            if "phi" in self.channels:
                args["phi"] = self.channels["phi"][i]
            args.update(kw)
            delta = self.channels["delta"][i] if "delta" in self.channels else None
            out.append(manoeuvres.zigzag_metrics(self.t, self["psi"][i], delta, **args))
        return out

    def turning_metrics(self, **kw: Any) -> list[Any]:
        """One :class:`usvid.manoeuvres.metrics.TurningMetrics` per run (needs x, y, psi)."""
        out = []
        for i in range(self.batch_size):
            args: dict[str, Any] = {}
            if isinstance(self.logic, Turning):
                args["t_execute"] = self._logic_value("t_start", i)
            for name in ("U", "r", "phi"):
                if name in self.channels:
                    args[name] = self.channels[name][i]
            args.update(kw)
            out.append(manoeuvres.turning_metrics(self.t, self["x"][i], self["y"][i],
                                                  self["psi"][i], **args))
        return out

    def course_metrics(self) -> list[dict[str, float]]:
        """Per run: ``itae`` [rad s^2] = int t |psi_d - psi| dt, ``iae`` [rad s] = int |e| dt
        (trapezoid at the integration step, from t = 0), ``max_rudder_deg`` [deg] (max |delta|)."""
        return [{"itae": float(self.course["itae"][i]), "iae": float(self.course["iae"][i]),
                 "max_rudder_deg": math.degrees(float(self.course["max_rudder"][i]))}
                for i in range(self.batch_size)]

    # --- conversion -----------------------------------------------------------------------
    def to_trial(self, i: int = 0, name: str | None = None) -> Trial:
        """Run i as a :class:`usvid.Trial` (perfect sensors, uniform grid, SI channels).

        ``meta["truth"]`` holds the model; ``meta["dt"]`` the integration step.
        """
        i = self._run(i)
        cols: dict[str, np.ndarray] = {"t": self.t.copy()}
        for k, v in self.channels.items():
            row = v[i]
            if np.all(np.isnan(row)):
                continue
            cols[k] = row.copy()
        vessel = getattr(self.model, "vessel", None) or Vessel()
        import pandas as pd  # (on first use: `import usvid.sim` spares pandas)

        return Trial(data=pd.DataFrame(cols), vessel=vessel, sources=[],
                     name=name or f"sim-{type(self.logic).__name__.lower()}-{i}",
                     meta={"truth": self.model, "dt": self.dt, "simulated": True, "run": i})

    def to_pandas(self, i: int = 0) -> pd.DataFrame:
        """Run i as a table (t + channels)."""
        return self.to_trial(i).to_pandas()
