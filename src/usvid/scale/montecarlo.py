"""Monte-Carlo simulation of a standard manoeuvre over the uncertainty of a model's parameters.

The parameters of run i are drawn from the model file's uncertainty (the covariance of the
fitted parameters when the file holds one, else independent normals from its standard errors)
and/or from given distributions (``NAME=normal:MEAN,SD``, ``NAME=uniform:LO,HI``, SI units), by
the one sampler of :mod:`usvid.models.uncertainty`: runs are drawn in fixed blocks of
:data:`BLOCK` runs, block k from the generator seeded with ``(seed, k)``, so run i's parameters,
hence its results, are the same whatever the number of workers or the chunk size; a draw
outside the model's parameter bounds is drawn again (column ``redraws``), a run with no draw
within them, or whose parameters are no valid model, is kept as a failed row (``valid_draw``
false), never an error that stops its chunk. Chunks of runs are simulated as batches of lanes
of the integration core (:func:`usvid.sim.simulate`) and measured with the kernel's online
trackers:

* ``zigzag``: ``overshoot_1_deg``, ``overshoot_2_deg``, ``overshoot_3_deg`` [deg],
  ``initial_turning_time_s`` (execute to first reversal) and ``reversal_2_s`` [s];
* ``turning``: ``advance_m``, ``transfer_m``, ``tactical_diameter_m`` [m]
  (:func:`usvid.manoeuvres.metrics.turning_metrics` per run);
* ``course-keeping``: ``itae`` [rad s^2], ``iae`` [rad s], ``max_rudder_deg`` [deg].

Option ``disturbance_deg`` [deg] (default 0: calm water) adds the rudder-equivalent coloured-noise
disturbance of Mu et al. (2018) (:class:`usvid.manoeuvres.logic.Disturbance`, as ``usvid
autopilot`` and ``usvid sim`` use it) to every manoeuvre; run i draws its noise from the stream
``(seed, i)``, so its realisation, like its parameters, does not depend on the chunking.

A run that diverges, or whose draw failed, keeps its row with ``success`` false and NaN
metrics.

Where the runs go (:func:`use_dask`): on a small machine (up to :data:`SMALL_MACHINE_CORES`
cores) with no scheduler given and no more workers than cores, in this process, chunk after
chunk, each chunk's lanes spread over the kernel's threads (no cluster to start, no process to
import the kernel again, no port opened); otherwise as Dask tasks (a remote scheduler, or
``--workers`` above the cores). The results are identical either way. Sizes are bounded
(:func:`check_size`): at most :data:`MAX_RUNS` runs and :data:`MAX_TASKS` chunks, the results
within the available memory, and a chunk within :data:`CHUNK_BYTES` of recorded trajectories
(a turning chunk is made smaller when its trajectories would not fit).
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
import pandas as pd

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import SimulationError, UsvidError
from usvid.io.modelfile import model_from_dict
from usvid.manoeuvres.logic import PID, CourseChange, Disturbance, Turning, ZigZag
from usvid.manoeuvres.metrics import turning_metrics
from usvid.models.uncertainty import BLOCK, Distribution, Sample, Uncertainty, lane_errors
from usvid.scale.cluster import available_memory, map_ordered
from usvid.sim.runs import default_t_end
from usvid.sim.simulate import approach_speed, simulate

__all__ = ["BLOCK", "MANOEUVRES", "MAX_RUNS", "MonteCarlo", "Vary", "check_size", "parse_vary",
           "quantiles", "run_chunk", "run_montecarlo", "run_timing", "use_dask"]

MANOEUVRES = ("zigzag", "turning", "course-keeping")
METRICS = {
    "zigzag": ("overshoot_1_deg", "overshoot_2_deg", "overshoot_3_deg",
               "initial_turning_time_s", "reversal_2_s"),
    "turning": ("advance_m", "transfer_m", "tactical_diameter_m"),
    "course-keeping": ("itae", "iae", "max_rudder_deg"),
}
#: Most runs of one Monte-Carlo command: their results take about 100 bytes a run in memory,
#: three times over while the Parquet file is made (10 million: ~3 GB), and 10 million 3-DOF
#: zig-zags of 60 s take about 15 minutes of CPU on this 2-core machine (100,000 in 8 s).
MAX_RUNS = 10_000_000
#: Most chunks (tasks) of one command: each is a Dask future and a result frame to concatenate.
MAX_TASKS = 10_000
#: Memory budget of the trajectories one chunk records [bytes] (turning: x, y, psi, delta
#: every 5 steps of every lane).
CHUNK_BYTES = 256 * 2**20
#: Most cores of a "small" machine, on which the runs stay in this process (:func:`use_dask`).
SMALL_MACHINE_CORES = 8
_VARY = re.compile(r"^\s*([A-Za-z_]\w*)\s*=\s*(normal|uniform)\s*:\s*([^,]+),([^,]+)$")


#: A parameter drawn from ``normal`` (a = mean, b = standard deviation) or ``uniform``
#: (a = low, b = high), SI units (:class:`usvid.models.uncertainty.Distribution`).
Vary = Distribution


def parse_vary(text: str) -> Vary:
    """``NAME=normal:MEAN,SD`` or ``NAME=uniform:LO,HI`` (SI units) -> :class:`Vary`."""
    m = _VARY.match(text)
    try:
        if not m:
            raise ValueError
        a, b = float(m.group(3)), float(m.group(4))
    except ValueError:
        raise UsvidError(f"--vary {text!r}: expected NAME=normal:MEAN,SD or "
                         "NAME=uniform:LO,HI (numbers in SI units)") from None
    if not (math.isfinite(a) and math.isfinite(b)) or (m.group(2) == "normal" and b < 0) \
            or (m.group(2) == "uniform" and b < a):
        raise UsvidError(f"--vary {text!r}: need finite numbers, SD >= 0, LO <= HI")
    return Distribution(m.group(1), m.group(2), a, b)


@dataclass
class MonteCarlo:
    """What to run: the model file dict, the manoeuvre and its options, the distributions.

    ``options``: ``delta_deg``, ``psi_deg`` [deg] (zig-zag, turning), ``target_deg`` [deg],
    ``kp`` [rad/rad], ``ki`` [1/s], ``kd`` [s] (course-keeping), ``t_end`` [s], ``dt`` [s],
    ``speed`` [m/s], ``disturbance_deg`` [deg] (standard deviation of the rudder-equivalent
    disturbance; 0 = calm). ``names``/``mean``/``cov``: the jointly normal parameters (SI), may be
    empty; ``vary``: further independent distributions (they override a jointly drawn name).
    """

    model: dict[str, Any]
    manoeuvre: str
    options: dict[str, Any] = field(default_factory=dict)
    names: tuple[str, ...] = ()
    mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cov: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    vary: tuple[Vary, ...] = ()
    seed: int = 0

    def __post_init__(self) -> None:
        if self.manoeuvre not in MANOEUVRES:
            raise UsvidError(f"--manoeuvre {self.manoeuvre!r}: expected one of "
                             f"{', '.join(MANOEUVRES)}")
        d = self.options.get("disturbance_deg", 0.0)
        if not (isinstance(d, (int, float)) and math.isfinite(d) and d >= 0):
            raise UsvidError(f"--disturbance-deg must be >= 0 deg (got {d!r})")
        if not 0 <= int(self.seed) < 2**53:  # (the kernel's noise streams: whole floats)
            raise UsvidError(f"--seed must be in 0..2^53-1 (got {self.seed})")
        vm = model_from_dict(self.model)
        # the kind's numeric parameters (not its options such as sway_force, nor a thrust law)
        known = {p.name for p in type(vm.dynamics).param_specs() if p.submodel is None}
        for name in (*self.names, *(v.name for v in self.vary)):
            if name not in known:
                raise UsvidError(f"--vary {name}: not a parameter of model kind "
                                 f"'{vm.kind}' (parameters: {', '.join(sorted(known))})")
        self._uncertainty = Uncertainty(
            tuple(self.names), np.asarray(self.mean, float), np.asarray(self.cov, float),
            "given" if self.names else "none", tuple(self.vary), (),
            {p.name: p for p in type(vm.dynamics).param_specs()})

    @property
    def parameters(self) -> tuple[str, ...]:
        """The sampled parameter names, in column order."""
        return self._uncertainty.parameters

    @property
    def metrics(self) -> tuple[str, ...]:
        return METRICS[self.manoeuvre]

    def sample(self, lo: int, hi: int) -> Sample:
        """The parameters [SI] of runs lo..hi-1 (independent of how runs are chunked; the
        bounds policy of :mod:`usvid.models.uncertainty`)."""
        return self._uncertainty.sample(lo, hi, int(self.seed))


def run_timing(mc: MonteCarlo, vm: Any) -> tuple[float, float, float]:
    """(approach speed [m/s], step [s], run length [s]) of the runs: the options when given
    (0 is a value, not "the default"), else the model's approach speed
    (:func:`usvid.sim.simulate.approach_speed`) and
    :func:`usvid.sim.runs.default_t_end`."""
    o = mc.options
    try:
        u0 = approach_speed(vm, o.get("speed"))
    except SimulationError as e:
        raise UsvidError(f"the model file has no vessel.speed: give --speed [m/s] ({e})") from None
    if not (math.isfinite(u0) and u0 > 0):
        raise UsvidError(f"--speed must be > 0 m/s (got {u0!r})")
    dt = float(o.get("dt", 0.02))
    t_end = o.get("t_end")
    if t_end is None:
        t_end = default_t_end(vm, u0)
    if not (math.isfinite(dt) and dt > 0 and math.isfinite(t_end) and t_end > 0):
        raise UsvidError(f"--dt and --t-end must be > 0 s (got {dt!r}, {t_end!r})")
    return float(u0), dt, float(t_end)


def chunk_bytes(mc: MonteCarlo) -> int:
    """Trajectory memory one run of a chunk records [bytes] (turning: 4 channels every 5
    steps; the other manoeuvres keep only their online metrics)."""
    if mc.manoeuvre != "turning":
        return 0
    _, dt, t_end = run_timing(mc, model_from_dict(mc.model))
    return 8 * 4 * (int(t_end / dt) // 5 + 2)


def check_size(mc: MonteCarlo, runs: int, chunk: int) -> int:
    """Check ``--runs`` and ``--chunk`` (one-line :class:`UsvidError` naming the option and the
    bound) and return the chunk to use: ``chunk``, made smaller when one chunk's trajectories
    would exceed :data:`CHUNK_BYTES` (the results do not depend on the chunking)."""
    if not 1 <= runs <= MAX_RUNS:
        raise UsvidError(f"--runs must be in 1..{MAX_RUNS} (got {runs}): the results take "
                         "about 100 bytes a run in memory, three times over while written; "
                         "split a larger study over several --seed values")
    if chunk < 1:
        raise UsvidError(f"--chunk must be >= 1 (got {chunk})")
    tasks = -(-runs // chunk)
    if tasks > MAX_TASKS:
        raise UsvidError(f"--chunk {chunk} cuts --runs {runs} into {tasks} tasks; at most "
                         f"{MAX_TASKS}: give --chunk {-(-runs // MAX_TASKS)} or more")
    row = 8 * (2 + len(mc.parameters) + len(mc.metrics)) + 1
    mem = available_memory()
    if mem is not None and 3 * row * runs > mem:
        raise UsvidError(f"--runs {runs}: the results need about {3 * row * runs / 2**30:.1f} "
                         f"GB of memory and {mem / 2**30:.1f} GB are available")
    per_run = chunk_bytes(mc)
    if per_run and chunk * per_run > CHUNK_BYTES:
        chunk = max(1, CHUNK_BYTES // per_run)
    return min(chunk, runs)


def use_dask(scheduler: str | None, workers: int | None, cores: int) -> bool:
    """True when the runs go to Dask: a scheduler is given, ``workers`` exceeds ``cores``, or
    the machine has more than :data:`SMALL_MACHINE_CORES` cores. Else they run in this
    process: on a small machine a local cluster only adds worker processes that import and
    load the kernel again (~1 s of CPU each) and results to serialise, for the same cores."""
    if scheduler:
        return True
    if workers is not None and workers > cores:
        return True
    return cores > SMALL_MACHINE_CORES


def run_chunk(mc: MonteCarlo, lo: int, hi: int, threads: int | None = None) -> pd.DataFrame:
    """Simulate runs lo..hi-1: one row per run (``run``, the sampled parameters [SI],
    ``success``, the metrics). ``threads``: numba threads for this call (1 on Dask workers)."""
    if threads is not None:
        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    B = hi - lo
    vm = model_from_dict(mc.model)
    drawn = mc.sample(lo, hi)
    nominal = {n: float(getattr(vm.dynamics, n)) for n in drawn.values}  # a valid set
    params = drawn.usable(nominal)  # failed runs simulate the nominal model, marked failed
    valid = ~drawn.failed
    # a check across parameters that the bounds do not cover: those runs fail, not the chunk
    for i in lane_errors(vm.dynamics, params):
        valid[i] = False
        for n, v in params.items():
            v[i] = nominal[n]
    model = dataclasses.replace(vm, dynamics=vm.dynamics.replace(**params))
    o = mc.options
    u0, dt, t_end = run_timing(mc, vm)
    rows: dict[str, Any] = {"run": np.arange(lo, hi)}
    rows.update(drawn.values)
    rows["redraws"] = drawn.redraws
    rows["valid_draw"] = valid
    sd = math.radians(float(o.get("disturbance_deg", 0.0)))
    dist = (Disturbance(intensity=sd, seed=int(mc.seed), stream=np.arange(lo, hi, dtype=float))
            if sd > 0 else None)  # run i: noise stream (seed, i), whatever the chunk
    delta = math.radians(o.get("delta_deg", 10.0 if mc.manoeuvre == "zigzag" else 35.0))
    with np.errstate(all="ignore"):
        if mc.manoeuvre == "zigzag":
            psi = o.get("psi_deg")
            psi_sw = delta if psi is None else math.radians(psi)
            logic = ZigZag(np.full(B, delta), psi_sw)
            nsteps = max(1, round(t_end / dt))
            res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, record_every=nsteps,
                           channels=("psi",), disturbance=dist)
            ov = np.degrees(res.zigzag_online["overshoot"])
            rt = res.zigzag_online["reversal_t"]
            metrics = {"overshoot_1_deg": ov[:, 0], "overshoot_2_deg": ov[:, 1],
                       "overshoot_3_deg": ov[:, 2], "initial_turning_time_s": rt[:, 1] - rt[:, 0],
                       "reversal_2_s": rt[:, 2]}
        elif mc.manoeuvre == "turning":
            logic = Turning(np.full(B, delta))
            res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, record_every=5,
                           channels=("x", "y", "psi", "delta"), disturbance=dist)
            tm = []
            for i in range(B):  # metrics per run (fits of the steady circle)
                try:
                    tm.append(turning_metrics(res.t, res["x"][i], res["y"][i], res["psi"][i],
                                              t_execute=0.0))
                except (UsvidError, ValueError, IndexError, np.linalg.LinAlgError):
                    tm.append(None)
            metrics = {k: np.array([np.nan if m is None else float(getattr(m, k))
                                    for m in tm]) for k in METRICS["turning"]}
        else:
            ki = float(o.get("ki", 0.0))
            logic = CourseChange(target=math.radians(o.get("target_deg", 100.0)),
                                 controller=PID(kp=float(o.get("kp", 0.7)), ki=ki,
                                                kd=float(o.get("kd", 1.0))),
                                 disturbance=dist)
            res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0,
                           psi0=np.zeros(B), record_every=max(1, round(t_end / dt)),
                           channels=("psi",))
            metrics = {"itae": res.course["itae"], "iae": res.course["iae"],
                       "max_rudder_deg": np.degrees(res.course["max_rudder"])}
    ok = np.ones(B, bool) if res.status is None else np.asarray(res.status) == 0
    ok &= valid
    rows["success"] = ok
    for k, v in metrics.items():
        rows[k] = np.where(ok, np.asarray(v, float), np.nan)
    return pd.DataFrame(rows)


def run_montecarlo(mc: MonteCarlo, runs: int, *, chunk: int = 4096, client: Any = None,
                   progress: bool = True, threads: int | None = None) -> pd.DataFrame:
    """All ``runs`` runs, in chunks of ``chunk`` runs (:func:`check_size`): as Dask tasks on
    ``client``, else in this process on ``threads`` kernel threads (default numba's). One row
    per run, ordered by run (identical either way)."""
    chunk = check_size(mc, runs, chunk)
    bounds = [(mc, lo, min(runs, lo + chunk)) for lo in range(0, runs, chunk)]
    if client is None:
        parts = [run_chunk(*b, threads) for b in bounds]
    else:
        parts = map_ordered(client, run_chunk, [(*b, 1) for b in bounds], progress=progress,
                            label="montecarlo")
    return pd.concat(parts, ignore_index=True)


def quantiles(df: pd.DataFrame, metrics: tuple[str, ...],
              qs: tuple[float, ...] = (0.05, 0.5, 0.95)) -> dict[str, dict[str, float]]:
    """Per metric: its quantiles (keys ``q05``, ``q50``, ``q95``), mean and the number of
    finite values ``n``, over the successful runs."""
    out = {}
    for m in metrics:
        x = df[m].to_numpy(float)
        x = x[np.isfinite(x)]
        d = {f"q{round(q * 100):02d}": (float(np.quantile(x, q)) if x.size else None)
             for q in qs}
        d["mean"] = float(x.mean()) if x.size else None
        d["n"] = int(x.size)
        out[m] = d
    return out
