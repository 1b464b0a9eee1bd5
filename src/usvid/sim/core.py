"""The integration core: fixed-step RK4 over a batch of lanes, for every model kind.

One kernel integrates simulations (a batch of runs), output-error windows, closed-loop zig-zag
replays and servo fits: the same right-hand side (the kind's ``rhs``, :mod:`usvid.models.kind`),
the same servo and limits, the same input hold. It is specialised per kind at first use (numba)
and cached on disk; chunks of lanes run in parallel on the process's thread pool.

Joint state of a lane (a row of ``Z``, lanes along the first axis): x, y [m, NED], psi [rad],
the kind's states, the servo angle delta [rad] and rate [rad/s], the disturbance filter (w1, w2).
Inside a chunk its rows and the helpers that load, store and combine it are generated from the
kind's state names (:mod:`usvid.sim.layout`): a kind has any number of states.

The core's parts, each in its module:

* :mod:`usvid.sim.layout`: the named rows of a chunk's work array, the core's constants, and the
  code generated from a kind's state names;
* :mod:`usvid.sim.chunk`: the chunk driver (time loop, logic, dead-time queues, events, zig-zag
  switching, limits, records, divergence), compiled once for every kind;
* :mod:`usvid.sim.lane`: the per-lane path (the reference: a lane's step split at its events,
  RK4 of the kind's right-hand side), compiled per kind;
* :mod:`usvid.sim.vector`: the vector path (one step of all lanes of a chunk, vectorised across
  lanes), compiled per kind and variant;
* :mod:`usvid.sim.specialise`: how and when each is compiled (and cached on disk);
* :mod:`usvid.sim.scalar`: the scalar helpers they share;
* this module: :func:`run`, the entry of :mod:`usvid.sim.simulate`.

Time stepping (step ``dt`` [s], lane ``b`` runs ``nsteps[b]`` steps):

* **Logic** at the start of each step: ``0`` commanded series, ``1`` turning, ``2`` zig-zag,
  ``3`` PID course change. A logic issues command *events* (time, value) into the lane's
  dead-time queue; an event takes effect on the servo input ``delay`` seconds later (servo dead
  time). Turning and zig-zag start at their exact ``t_start``; the PID and commanded series issue
  one event per step (a digital controller at the step rate, zero-order hold).
* **Events inside a step split it**: when a queued command takes effect, or an ideal servo's
  rate-limited ramp reaches its target, inside a step, that lane's step is integrated as
  sub-steps ending at those instants. An ideal servo is a rate-limited ramp (its angle has the
  piecewise-constant derivative 0 or +-max_rate, so RK4 integrates it exactly); first- and
  second-order servos are integrated with the vessel (Mu et al. 2018, eq. 11-12).
* **Zig-zag switching is event-located**: after a step in which the heading deviation crossed
  the switching angle, the crossing instant is interpolated linearly within the step, the
  command reverses there, and (without dead time) the step is integrated again with the
  reversal at that instant. Simulated manoeuvres are then continuous in the model parameters
  (output-error fits of zig-zags need that) and their metrics do not jump with dt.
* **Measured inputs** (rudder angle ``delta``, shaft speed ``n``, thruster commands) are linear
  between samples (first-order hold) inside the step; a measured rudder angle bypasses the
  servo. A commanded ``delta_cmd`` series goes through the servo (zero-order hold).
* **Divergence**: a lane whose state stops being finite, or whose yaw rate exceeds
  :data:`R_MAX`, stops; its status says when (``SimResult.success``/``message``).

Records (every ``record_every`` steps, at the step start): :data:`CHANNELS`. Accumulators per
lane: ITAE [rad s^2] and IAE [rad s] of the heading error (course logic, trapezoid at the step
points), max |delta| [rad]; zig-zag reversal instants and overshoots (:data:`N_ZZ`).

The cos/sin of the heading and of the steering angle are rotated from the step start's values by
the angle-sum formula (:func:`usvid.sim.scalar._rot`) instead of library calls.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from usvid.models.kind import S0, ModelKind
from usvid.sim import specialise
from usvid.sim.layout import (
    CH,
    CHANNELS,
    COMMANDED,
    COURSE,
    DIST_A0,
    DIST_A1,
    DIST_B,
    KNPK,
    N_ZZ,
    NCH,
    NSER,
    R_MAX,
    SERIES,
    SERVO_ROWS,
    SFORCE,
    STATE_CHANNELS,
    TURNING,
    ZIGZAG,
)
from usvid.sim.specialise import INLINE_MAX_PARAMS, KindCode
from usvid.sim.vector import VW

__all__ = ["CH", "CHANNELS", "COMMANDED", "COURSE", "DIST_A0", "DIST_A1", "DIST_B",
           "FORCE_GENERIC", "INLINE_MAX_PARAMS", "N_ZZ", "NCH", "NSER", "R_MAX", "SERIES",
           "SERVO_ROWS", "SIMD", "STATE_CHANNELS", "TURNING", "ZIGZAG", "kernel", "run",
           "vector_step"]

#: Set to False to integrate every step on the per-lane path (the reference for the benchmark).
SIMD = True
#: Set to True to use the generic variant of the vector step (any servo kind, disturbance,
#: series, with x and y; see :func:`vector_step`) for every batch.
FORCE_GENERIC = False
#: The multirate hold of the state-dependent environment loads (:func:`run`): linearly
#: extrapolated from the last two evaluations (second order), else a zero-order hold of the
#: last evaluation (first order; kept for the accuracy comparison of the tests).
LOAD_EXTRAPOLATE = True


def kernel(kind: ModelKind) -> KindCode:
    """The compiled code of ``kind`` (:func:`usvid.sim.specialise.kernel`)."""
    return specialise.kernel(kind)


def vector_step(kind: ModelKind, swi: int, sk: int, nod: bool, xy: bool,
                wind: bool = False, wcode: int = -1, narrow: bool = False,
                shared: bool = False, steady: bool = False, force: bool = True) -> int:
    """Address of a vector-step variant of ``kind`` (:func:`usvid.sim.specialise.vector_step`;
    the generic one for every batch when :data:`FORCE_GENERIC`)."""
    return specialise.vector_step(kind, swi, sk, nod, xy, generic=bool(FORCE_GENERIC),
                                  wind=wind, wcode=wcode, narrow=narrow, shared=shared,
                                  steady=steady, force=force)


def run(kind: ModelKind, P: np.ndarray, S: np.ndarray, skind: int, lk: int, L: np.ndarray,
        Dq: np.ndarray, SER: np.ndarray, sidx: np.ndarray, Z: np.ndarray, nsteps: np.ndarray,
        dt: float, rec_every: int, slots: np.ndarray, rec: np.ndarray, acc: np.ndarray,
        zz: np.ndarray, zzt: np.ndarray, status: np.ndarray, qcap: int,
        chunk: int = CH, wind: bool = False, load_every: int = 1,
        load_extrapolate: bool | None = None) -> None:
    """Integrate all lanes of ``Z`` (in place) and fill the outputs.

    Arrays are lane-major (a lane's parameters, state and work values contiguous): ``P``
    (B, n_params), ``S`` (B, SERVO_ROWS), ``L`` (B, 6), ``Dq`` (B, 2 or 3) (spectral density,
    seed, optional noise stream index), ``Z`` (B, n_states),
    ``acc`` (B, 3), ``zz`` (B, N_ZZ), ``zzt`` (B, N_ZZ + 1), ``status`` (B, 2); ``SER``
    (n_series, 1 or B, N) and ``rec`` (n_channels, B, N_rec). Lanes are integrated in chunks of
    ``chunk`` lanes that step together (:func:`usvid.sim.chunk._chunk`, vectorised across the
    chunk's lanes); chunks run in parallel on the process's thread pool (:func:`_pool`; the
    driver is compiled ``nogil``), as many threads as numba's thread count. The vector step's
    variant (:func:`vector_step`) follows from the batch: the servo kind, whether it has a
    disturbance or input series, whether x or y is recorded, and each chunk's switch value.
    ``wind``: ``P`` carries the environment block (:data:`usvid.sim.layout.ENVBLOCK`) after the
    kind's parameters: the per-lane step of :func:`usvid.sim.specialise.wind_step` and the
    vector step's wind variant (its loads vectorised across the lanes like the rest of the
    step), with the multirate hold (:func:`usvid.sim.lane._heldload`): the loads
    evaluated at the start of every ``load_every``-th step and, with ``load_extrapolate``,
    linearly extrapolated from the last two evaluations to each step's midpoint, else held
    (:func:`usvid.sim.lane._holdget`).
    """
    B, nz = Z.shape
    chunk = max(1, min(chunk, CH))
    if B == 0:
        return
    drive = specialise.driver()
    code = kernel(kind)
    env = bool(np.any(sidx[SFORCE:NSER] >= 0))  # force or current series
    kinfo = code.kinfo
    simd = bool(SIMD)
    if wind:  # wind loads, wave drift: the per-lane step with the environment block in P
        lstep, kinfo = specialise.wind_step(kind)
        if P.shape[1] != kinfo[KNPK]:
            raise ValueError(f"run: {P.shape[1]} parameter rows, the kind's and the environment "
                             f"block need {int(kinfo[KNPK])}")
    else:
        lstep = specialise.lane_step(kind, env)
    qt, qv = np.empty((B, qcap)), np.empty((B, qcap))
    sstride = 1 if SER.shape[1] > 1 else 0
    # the environment's series constant in time (and no other series): loaded once by the driver
    used = [i for i in range(NSER) if sidx[i] >= 0]
    sconst = bool(used) and min(used) >= SFORCE and all(
        bool(np.all(SER[sidx[i]] == SER[sidx[i], :, :1])) for i in used)
    hold_m = max(1, int(load_every)) if wind else 0
    if load_extrapolate is None:
        load_extrapolate = bool(LOAD_EXTRAPOLATE)
    hold_w = 1.0 if (wind and load_extrapolate) else 0.0
    starts = list(range(0, B, chunk))
    vaddr = dict.fromkeys(starts, 0)
    if simd:
        ID = S0 + kind.n_states
        # no disturbance and no series (with wind: none but the environment's, which the wind
        # variant reads in any case)
        nod = (not bool(np.any(sidx[:SFORCE if wind else NSER] >= 0))
               and not bool(np.any(Dq[:, 0] > 0.0))
               and not bool(np.any(Z[:, ID + 2:ID + 4] != 0.0)))
        xy = bool(slots[0] >= 0 or slots[1] >= 0)
        wcode = -1  # the wind-load model's code of every lane: a literal in the variant
        shared = steady = False
        force = True
        if wind:
            codes = P[:, kind.n_params]
            wcode = int(codes[0]) if bool(np.all(codes == codes[0])) else -1
            # one environment block for every lane; the series the environment's only and
            # constant in time, or none (their rows then hold constant zeros)
            shared = bool(np.all(P[:, kind.n_params:] == P[:1, kind.n_params:]))
            steady = sconst or not used
            # an external force series in some lane (else its rows, zeros, are not read)
            force = bool(np.any(sidx[SFORCE:SFORCE + 4] >= 0))
        steps: dict[tuple[int, bool], int] = {}
        for lo in starts:
            hi = min(B, lo + chunk)
            swi = code.chunk_switch(P, lo, hi)
            narrow = hi - lo <= VW  # a single run: the vector step of one vector of lanes
            if (swi, narrow) not in steps:
                steps[swi, narrow] = vector_step(kind, swi, skind, nod, xy, wind, wcode, narrow,
                                                 shared, steady, force)
            vaddr[lo] = steps[swi, narrow]

    def task(lo: int) -> None:
        drive(lo, min(B, lo + chunk), P, S, skind, lk, L, Dq, SER, sidx, sstride, Z, nsteps,
              dt, rec_every, slots, rec, acc, zz, zzt, status, qt, qv, simd, vaddr[lo],
              lstep, kinfo, sconst, hold_m, hold_w)

    threads = min(numba.get_num_threads(), len(starts))
    if threads <= 1:
        for lo in starts:
            task(lo)
        return
    todo = iter(starts)
    lock = threading.Lock()
    stop = threading.Event()  # the caller was interrupted: no further chunk

    def worker() -> None:  # takes the next chunk until none is left (chunks may differ in cost)
        while not stop.is_set():
            with lock:
                lo = next(todo, None)
            if lo is None:
                return
            task(lo)

    pool = _pool()
    futs = [pool.submit(worker) for _ in range(threads)]
    try:
        for fut in futs:
            fut.result()
    except BaseException:
        stop.set()
        raise


_POOL: dict[int, ThreadPoolExecutor] = {}  # process id -> the process's pool
_POOL_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    """The process's thread pool for the chunks of :func:`run` (started once, its threads kept
    between calls; output error runs hundreds of batches). Up to numba's thread count of workers
    (:data:`numba.config.NUMBA_NUM_THREADS`); each call occupies ``numba.get_num_threads()`` of
    them. A forked child (Dask's workers, the tests' forks) has none of its parent's threads: it
    starts its own pool, keyed by process id."""
    pid = os.getpid()
    pool = _POOL.get(pid)
    if pool is None:
        with _POOL_LOCK:
            pool = _POOL.get(pid)
            if pool is None:
                _POOL.clear()  # (a parent's pool object: its threads do not exist here)
                pool = _POOL[pid] = ThreadPoolExecutor(
                    max_workers=max(1, int(numba.config.NUMBA_NUM_THREADS)),
                    thread_name_prefix="usvid-core")
    return pool

