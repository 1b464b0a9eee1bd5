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

The environment (``environment``: ``wind_speed`` [m/s], ``wind_dir_deg`` [deg, from],
``current_speed`` [m/s], ``current_dir_deg`` [deg, towards], ``hs`` [m], ``tp`` [s],
``wave_dir_deg`` [deg, from]; :class:`usvid.sim.Environment`) is, each of them, a constant or a
:class:`Distribution` drawn per run (block k of :data:`BLOCK` runs from the generator seeded
with ``(seed, k, 1)``, so run i's environment does not depend on the chunking either; a speed
drawn below 0 is 0, calm; a significant height or peak period drawn at or below 0 is no sea
state and is drawn again, as a parameter outside its bounds is: both of that run, at most
:data:`usvid.models.uncertainty.MAX_REDRAWS` times, column ``sea_redraws``; a run with no valid
draw is a failed row). With a sea state drawn per run each run has its own drift force and
realisation (:class:`usvid.sim.Environment` with a batch of sea states). In a sea state run i's
first-order wave motion is the realisation of stream ``(seed, i)``, and a zig-zag is then
measured on the recorded heading (manoeuvring plus first-order wave motion, as ``usvid simulate
zigzag`` measures it, every :func:`sea_record_every` steps) instead of the kernel's online
trackers (which see the manoeuvring heading only).

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
from usvid.manoeuvres.metrics import turning_metrics, zigzag_metrics
from usvid.models.environment import SeaState
from usvid.models.uncertainty import (
    BLOCK,
    Distribution,
    Sample,
    Uncertainty,
    lane_errors,
    redraw_invalid,
)
from usvid.scale.cluster import available_memory, map_ordered
from usvid.sim.runs import default_t_end
from usvid.sim.simulate import Environment, approach_speed, simulate

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
#: The environment of the runs (names as :func:`usvid.commands._common.environment_of`'s
#: arguments: speeds [m/s], ``hs`` [m], ``tp`` [s], directions [deg]); each may be a
#: distribution.
ENVIRONMENT = ("wind_speed", "wind_dir_deg", "current_speed", "current_dir_deg", "hs", "tp",
               "wave_dir_deg")
ENV_VARIABLE = ENVIRONMENT
#: The sea state's quantities that must be > 0 (a draw at or below 0 is drawn again).
SEA_POSITIVE = ("hs", "tp")


#: A parameter drawn from ``normal`` (a = mean, b = standard deviation) or ``uniform``
#: (a = low, b = high), SI units (:class:`usvid.models.uncertainty.Distribution`).
Vary = Distribution


def parse_vary(text: str) -> Vary:
    """``NAME=normal:MEAN,SD`` or ``NAME=uniform:LO,HI`` (SI units) -> :class:`Vary`."""
    return _parse_distribution(text, "--vary", "NAME=")


def parse_environment(text: str, name: str) -> float | Vary:
    """An environment option of ``usvid montecarlo`` (``name`` one of :data:`ENVIRONMENT`): a
    number, or ``normal:MEAN,SD`` / ``uniform:LO,HI`` in the option's units (the form of
    ``--vary`` without the name) -> a float or a :class:`Vary` named ``name``."""
    option = "--" + name.replace("_", "-")
    try:
        return float(text)
    except ValueError:
        pass
    if name not in ENV_VARIABLE:
        raise UsvidError(f"{option} {text!r}: expected a number")
    return _parse_distribution(f"{name}={text}", option, "")


def _parse_distribution(text: str, option: str, prefix: str) -> Vary:
    m = _VARY.match(text)
    try:
        if not m:
            raise ValueError
        a, b = float(m.group(3)), float(m.group(4))
    except ValueError:
        shown = text if prefix else text.split("=", 1)[-1]
        units = "SI units" if prefix else "the option's units"
        raise UsvidError(f"{option} {shown!r}: expected {prefix}normal:MEAN,SD or "
                         f"{prefix}uniform:LO,HI (numbers in {units})") from None
    if not (math.isfinite(a) and math.isfinite(b)) or (m.group(2) == "normal" and b < 0) \
            or (m.group(2) == "uniform" and b < a):
        shown = text if prefix else text.split("=", 1)[-1]
        raise UsvidError(f"{option} {shown!r}: need finite numbers, SD >= 0, LO <= HI")
    return Distribution(m.group(1), m.group(2), a, b)


@dataclass
class MonteCarlo:
    """What to run: the model file dict, the manoeuvre and its options, the distributions.

    ``options``: ``delta_deg``, ``psi_deg`` [deg] (zig-zag, turning), ``target_deg`` [deg],
    ``kp`` [rad/rad], ``ki`` [1/s], ``kd`` [s] (course-keeping), ``t_end`` [s], ``dt`` [s],
    ``speed`` [m/s], ``disturbance_deg`` [deg] (standard deviation of the rudder-equivalent
    disturbance; 0 = calm). ``names``/``mean``/``cov``: the jointly normal parameters (SI), may be
    empty; ``vary``: further independent distributions (they override a jointly drawn name);
    ``environment``: name (:data:`ENVIRONMENT`) -> a number or a :class:`Vary` (module
    docstring; empty: calm water).
    """

    model: dict[str, Any]
    manoeuvre: str
    options: dict[str, Any] = field(default_factory=dict)
    names: tuple[str, ...] = ()
    mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cov: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    vary: tuple[Vary, ...] = ()
    seed: int = 0
    environment: dict[str, Any] = field(default_factory=dict)

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
        for name, v in self.environment.items():
            if name not in ENVIRONMENT:
                raise UsvidError(f"environment {name!r}: expected one of "
                                 f"{', '.join(ENVIRONMENT)}")
            if isinstance(v, Distribution) and name not in ENV_VARIABLE:
                raise UsvidError(f"--{name.replace('_', '-')}: one value per study")
            if name in SEA_POSITIVE and not _centre(v) > 0:
                raise UsvidError(f"--{name.replace('_', '-')}: must be > 0 (a distribution: "
                                 f"its mean, or the middle of its range; got {_centre(v):g})")

    @property
    def varied_environment(self) -> tuple[str, ...]:
        """The environment drawn per run, in column order."""
        return tuple(n for n in ENVIRONMENT if isinstance(self.environment.get(n),
                                                          Distribution))

    def environment_sample(self, lo: int, hi: int) -> dict[str, np.ndarray]:
        """The environment of runs lo..hi-1: name -> (hi - lo,) values (options' units; module
        docstring: block k from (seed, k, 1), speeds drawn below 0 are 0, a sea state's height
        or period at or below 0 drawn again), independent of the chunking."""
        return self.environment_draws(lo, hi)[0]

    def environment_draws(self, lo: int, hi: int
                          ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
        """(:meth:`environment_sample`, (n,) how often each run's sea state was drawn again,
        (n,) runs with no valid sea state in
        :data:`usvid.models.uncertainty.MAX_REDRAWS` redraws: their values are the
        distribution's centre, the run a failed row)."""
        out: dict[str, list[np.ndarray]] = {n: [] for n in self.environment}
        red: list[np.ndarray] = []
        fail: list[np.ndarray] = []
        varied = self.varied_environment
        sea = [n for n in SEA_POSITIVE if n in varied]
        for blk in range(lo // BLOCK, (hi - 1) // BLOCK + 1):
            rng = np.random.default_rng([int(self.seed), blk, 1])
            draws = {n: self.environment[n].draw(rng, BLOCK) for n in varied}

            def again(bad: np.ndarray, draws: dict = draws, rng: Any = rng) -> None:
                for n in sea:
                    draws[n][bad] = self.environment[n].draw(rng, bad.size)

            # the bounds policy of the parameters
            redraws, failed = redraw_invalid(
                BLOCK, lambda rows, d=draws: self._no_sea(d, sea, rows), again)
            for n in sea:
                draws[n][failed] = _centre(self.environment[n])
            a = max(lo, blk * BLOCK) - blk * BLOCK
            b = min(hi, (blk + 1) * BLOCK) - blk * BLOCK
            for n, v in self.environment.items():
                x = draws[n][a:b] if n in varied else np.full(b - a, float(v))
                out[n].append(np.maximum(x, 0.0) if n.endswith("speed") else x)
            red.append(redraws[a:b])
            fail.append(failed[a:b])
        return ({n: np.concatenate(v) for n, v in out.items()}, np.concatenate(red),
                np.concatenate(fail))

    @staticmethod
    def _no_sea(draws: dict[str, np.ndarray], names: list[str], rows: np.ndarray) -> np.ndarray:
        """Of ``rows``, those whose drawn height or period is no sea state (<= 0 or not
        finite)."""
        bad = np.zeros(rows.size, dtype=bool)
        for n in names:
            x = draws[n][rows]
            bad |= ~(np.isfinite(x) & (x > 0))
        return bad

    def environment_of(self, lo: int, hi: int) -> Any:
        """The :class:`usvid.sim.Environment` of runs lo..hi-1 (None in calm water): per-run
        wind and current, the sea state (one, or one per run when any of its quantities is
        drawn) with run i's wave stream (seed, i)."""
        if not self.environment:
            return None
        e = self.environment_sample(lo, hi)
        sea = None
        if "hs" in e:
            varied = self.varied_environment

            def value(n: str, scale: float = 1.0) -> Any:
                x = e.get(n, np.zeros(hi - lo)) * scale
                return x if n in varied else float(x[0])
            sea = SeaState(hs=value("hs"), tp=value("tp"),
                           direction=value("wave_dir_deg", math.pi / 180.0)
                           if "wave_dir_deg" in varied else
                           math.radians(float(e.get("wave_dir_deg", [0.0])[0])))
        z = np.zeros(hi - lo)
        return Environment(current_speed=e.get("current_speed", z),
                           current_dir=np.radians(e.get("current_dir_deg", z)),
                           wind_speed=e.get("wind_speed", z),
                           wind_dir=np.radians(e.get("wind_dir_deg", z)), sea=sea,
                           wave_seed=int(self.seed), wave_stream=np.arange(lo, hi, dtype=float))

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


def sea_record_every(mc: MonteCarlo, dt: float) -> int:
    """Steps between recorded samples of a zig-zag in a sea state: 20 samples per peak period
    (the largest heading of a wave-period oscillation then sampled within 1 - cos(pi / 20) =
    1.2 % of its amplitude), at least every step. One for the study (its rows must not depend
    on the chunking): a peak period drawn per run counts with the shortest it may draw, the low
    end of a uniform and the mean less 4 standard deviations of a normal (a normal draws
    shorter periods in 3 of 100,000 runs: those are sampled a little more coarsely)."""
    tp = mc.environment.get("tp", math.inf)
    if isinstance(tp, Distribution):
        tp = tp.a if tp.dist == "uniform" else tp.a - 4.0 * tp.b
    return max(1, int(float(tp) / 20.0 / dt))


def _centre(v: Any) -> float:
    """A number, or the centre of a distribution (its mean, the middle of its range): the value
    of a run with no valid draw."""
    if isinstance(v, Distribution):
        return float(v.a if v.dist == "normal" else 0.5 * (v.a + v.b))
    return float(v)


def _zigzag_in_sea(mc: MonteCarlo) -> bool:
    return mc.manoeuvre == "zigzag" and "hs" in mc.environment


def chunk_bytes(mc: MonteCarlo) -> int:
    """Trajectory memory one run of a chunk records [bytes] (turning: 4 channels every 5
    steps; a zig-zag in a sea state: 4 channels every :func:`sea_record_every` steps; the other
    manoeuvres keep only their online metrics)."""
    if mc.manoeuvre != "turning" and not _zigzag_in_sea(mc):
        return 0
    _, dt, t_end = run_timing(mc, model_from_dict(mc.model))
    every = 5 if mc.manoeuvre == "turning" else sea_record_every(mc, dt)
    return 8 * 4 * (int(t_end / dt) // every + 2)


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
    row = 8 * (2 + len(mc.parameters) + len(mc.varied_environment) + len(mc.metrics)) + 1
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
    """Simulate runs lo..hi-1: one row per run (``run``, the sampled parameters [SI], the
    environment drawn per run (its options' units), ``success``, the metrics). ``threads``:
    numba threads for this call (1 on Dask workers)."""
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
    env = mc.environment_of(lo, hi)
    if mc.varied_environment:
        e, sea_redraws, sea_failed = mc.environment_draws(lo, hi)
        rows.update({n: e[n] for n in mc.varied_environment})
        valid &= ~sea_failed
    rows["redraws"] = drawn.redraws
    if any(n in mc.varied_environment for n in SEA_POSITIVE):
        rows["sea_redraws"] = sea_redraws
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
            if _zigzag_in_sea(mc):
                res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0,
                               record_every=sea_record_every(mc, dt),
                               channels=("x", "y", "psi", "delta"), disturbance=dist,
                               environment=env)
                metrics = _zigzag_recorded(res, logic, B)
            else:
                nsteps = max(1, round(t_end / dt))
                res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, record_every=nsteps,
                               channels=("psi",), disturbance=dist, environment=env)
                ov = np.degrees(res.zigzag_online["overshoot"])
                rt = res.zigzag_online["reversal_t"]
                metrics = {"overshoot_1_deg": ov[:, 0], "overshoot_2_deg": ov[:, 1],
                           "overshoot_3_deg": ov[:, 2],
                           "initial_turning_time_s": rt[:, 1] - rt[:, 0],
                           "reversal_2_s": rt[:, 2]}
        elif mc.manoeuvre == "turning":
            logic = Turning(np.full(B, delta))
            res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0, record_every=5,
                           channels=("x", "y", "psi", "delta"), disturbance=dist,
                           environment=env)
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
                           channels=("psi",), environment=_no_wave_motion(env))
            metrics = {"itae": res.course["itae"], "iae": res.course["iae"],
                       "max_rudder_deg": np.degrees(res.course["max_rudder"])}
    ok = np.ones(B, bool) if res.status is None else np.asarray(res.status) == 0
    ok &= valid
    rows["success"] = ok
    for k, v in metrics.items():
        rows[k] = np.where(ok, np.asarray(v, float), np.nan)
    return pd.DataFrame(rows)


def _no_wave_motion(env: Any) -> Any:
    """``env`` without the first-order wave motion added after the run (the course-keeping
    metrics are the kernel's accumulators: the motion could not change them, and it needs
    x, y recorded)."""
    return env if env is None or env.sea is None else dataclasses.replace(env,
                                                                           wave_motion=False)


def _zigzag_recorded(res: Any, logic: ZigZag, B: int) -> dict[str, np.ndarray]:
    """The zig-zag metrics of each run from its recorded heading, rudder and track
    (:func:`usvid.manoeuvres.metrics.zigzag_metrics`, as ``usvid simulate zigzag``); NaN where
    the record shows none."""
    out = {k: np.full(B, np.nan) for k in METRICS["zigzag"]}
    amp = np.broadcast_to(np.abs(np.asarray(logic.delta_amp, float)), (B,))
    for i in range(B):
        try:
            m = zigzag_metrics(res.t, res["psi"][i], res["delta"][i], delta_amp=float(amp[i]),
                               psi_switch=float(logic.psi_switch), t_execute=float(logic.t_start),
                               first=int(logic.first), x=res["x"][i], y=res["y"][i])
        except (UsvidError, ValueError, IndexError):
            continue
        ov = [*m.overshoot_deg, math.nan, math.nan, math.nan]
        for j in range(3):
            out[f"overshoot_{j + 1}_deg"][i] = ov[j]
        out["initial_turning_time_s"][i] = m.initial_turning_time_s
        out["reversal_2_s"][i] = [*m.reversal_times_s, math.nan, math.nan][1]
    return out


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
