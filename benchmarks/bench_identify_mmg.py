"""MMG identification benchmark: the 13 HSVA KVLCC2 zig-zags (SIMMAN 2008, 20 Hz), output error
against least squares, CPU side by side in one run.

Reads the 13 runs of ``../shared/data/kvlcc2_hsva`` with the shipped ``hsva_kvlcc2`` spec
(skipped with a message where the data are not present), then times, in this process,
``ModelEstimator("mmg", "ls")`` (state estimation by EKF + RTS smoother of every run, the
regularised regression of the 17 hull coefficients, the replay fit metrics) and
``ModelEstimator("mmg", "oe")`` (the same, then output error by multiple shooting over 20 s
windows, each Jacobian's perturbed parameter sets the lanes of one core call), and the same
output error with one core call per perturbed set (the former Jacobian, for the record and to
show the same fitted parameters). Printed: wall and CPU time of each fit (after a warm-up fit
of one run, so numba compilation or cache loading is excluded), peak memory of Python/numpy
allocations (tracemalloc), the 35 deg turning circles (advance/L, tactical diameter/L) the
identified models predict, the ratio oe / ls of CPU (each fit from the same prepared trials
with nothing an earlier fit derived from them kept: every fit estimates the states again),
and the largest relative difference of the fitted parameters between the two Jacobians; the
finite-difference Jacobians and the simulations of all windows (a Jacobian's sets counted one by
one) of every output-error fit (the fit again with a held parameter included); and the output
error with the plain Levenberg-Marquardt iteration (no secant tail, no structured step:
``SECANT_SE = 0``, ``STRUCTURED = False``) with its fitted parameters' largest difference in
their standard errors.
Then the commands ``usvid identify ... --model mmg --method ls|oe`` in fresh processes (CPU
of the process, start-up included). The acceptance: oe at most 1.5x the CPU of ls, the same
fitted parameters to the optimizer's tolerance.
``USVID_BENCH_SKIP_CLI=1`` skips the commands.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np

import usvid.identify.output_error as oe_mod
import usvid.io
import usvid.prep
from usvid.errors import UsvidError
from usvid.identify import ModelEstimator
from usvid.identify.output_error import OEProblem
from usvid.sim import run_turning

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "kvlcc2_hsva"


def _one_set_per_call(self, xs, inits):
    """The former Jacobian: one core call per perturbed set (the reference)."""
    K = len(xs)
    ok = np.ones(K, dtype=bool)
    outs = []
    for k, (x, init) in enumerate(zip(xs, inits, strict=True)):
        try:
            outs.append(self.simulate(x, init))
        except (UsvidError, ValueError, ZeroDivisionError):
            ok[k] = False
            outs.append(None)
    good = next(o for o in outs if o is not None)
    sims = {c: np.stack([(o if o is not None else good)[c] for o in outs]) for c in good}
    return sims, ok


COUNT = {"jac": 0, "sims": 0}


def _counting():
    """Count the finite-difference Jacobians and the simulations of all windows."""
    fd, one, sets = oe_mod.fd_jacobian, OEProblem.simulate, OEProblem.simulate_sets

    def fd_jacobian(*a, **k):
        COUNT["jac"] += 1
        return fd(*a, **k)

    def simulate(self, *a, **k):
        COUNT["sims"] += 1
        return one(self, *a, **k)

    def simulate_sets(self, xs, *a, **k):
        COUNT["sims"] += len(xs)
        return sets(self, xs, *a, **k)

    oe_mod.fd_jacobian, OEProblem.simulate, OEProblem.simulate_sets = (
        fd_jacobian, simulate, simulate_sets)


def _fit(trials, method: str):
    for tr in trials:  # the same preparation for every fit: what an earlier fit derived from the
        tr.memo.clear()  # trials (state estimates, segments) is derived again, not reused
    tracemalloc.start()
    t0, c0 = time.perf_counter(), time.process_time()
    est = ModelEstimator("mmg", method, checks="record").fit(trials)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return est, wall, cpu, peak


def _turns(est) -> str:
    L = est.model_.vessel.length
    turns = []
    for d in (35.0, -35.0):
        side = "stbd" if d > 0 else "port"
        try:
            _, m = run_turning(est.model_, d)
        except UsvidError as exc:  # a model that extrapolates badly to 35 deg
            turns.append(f"{side} {exc}")
            continue
        turns.append(f"{side} advance/L {m.advance_m / L:.3f} "
                     f"tactical/L {m.tactical_diameter_m / L:.3f}")
    return "; ".join(turns)


def _command_cpu(argv: list[str]) -> tuple[float, float]:
    """(CPU [s] of the process and its children, wall [s]) of ``argv`` run to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime), wall


def main() -> int:
    files = sorted(DATA.glob("HSVA_CPMC_KVLCC2_Z_*.dat"))
    if not files:
        print(f"HSVA data not found in {DATA}: benchmark skipped")
        return 0
    warnings.simplefilter("ignore")
    trials = [usvid.prep.prepare(usvid.io.read_trial(f, "hsva_kvlcc2")) for f in files]
    for method in ("ls", "oe"):  # warm-up: compilation / cache loading
        try:
            ModelEstimator("mmg", method, checks="record").fit(trials[:1])
        except UsvidError:  # (one run: a model that may fail its checks; compiled all the same)
            pass
    print(f"bench_identify_mmg: {len(trials)} HSVA runs ({sum(len(t) for t in trials)} rows), "
          f"{len(os.sched_getaffinity(0))} cores, load average {os.getloadavg()[0]:.1f}")
    cpu, params, ses = {}, {}, {}
    plain = (oe_mod.SECANT_SE, oe_mod.STRUCTURED)
    _counting()
    for label, method in (("ls", "ls"), ("oe", "oe"), ("oe, plain LM", "oe"),
                          ("oe, one call per set", "oe")):
        if label == "oe, one call per set":
            batched, OEProblem.simulate_sets = OEProblem.simulate_sets, _one_set_per_call
        if label == "oe, plain LM":
            oe_mod.SECANT_SE, oe_mod.STRUCTURED = 0.0, False
        COUNT.update(jac=0, sims=0)
        try:
            est, wall, cpu[label], peak = _fit(trials, method)
        finally:
            if label == "oe, one call per set":
                OEProblem.simulate_sets = batched
            oe_mod.SECANT_SE, oe_mod.STRUCTURED = plain
        params[label], ses[label] = est.params_, est.std_errors_
        sims = (f", {COUNT['jac']} Jacobians, {COUNT['sims']} simulations of all windows"
                if label != "ls" and COUNT["sims"] else "")
        print(f"  mmg {label:22s} {wall:6.1f} s wall {cpu[label]:6.1f} s CPU, peak traced "
              f"memory {peak:.0f} MiB{sims}; 35 deg turn {_turns(est)}")
    rel = max(abs(params["oe"][k] - v) / max(abs(v), 1e-12)
              for k, v in params["oe, one call per set"].items())
    print(f"  oe / ls CPU in process: {cpu['oe'] / cpu['ls']:.2f} (acceptance <= 1.5); "
          f"the former Jacobian {cpu['oe, one call per set'] / cpu['ls']:.2f}; fitted "
          f"parameters of the two Jacobians differ by {rel:.2e} relative at most")
    dse = max(abs(params["oe"][k] - v) / ses["oe, plain LM"][k]
              for k, v in params["oe, plain LM"].items() if ses["oe, plain LM"][k] > 0)
    print(f"  oe / ls CPU with the plain Levenberg-Marquardt iteration: "
          f"{cpu['oe, plain LM'] / cpu['ls']:.2f}; fitted parameters differ from it by "
          f"{dse:.4f} of their standard errors at most (tolerance 0.01 each: ~0.03)")
    if os.environ.get("USVID_BENCH_SKIP_CLI") != "1":
        exe = str(Path(sys.executable).with_name("usvid"))
        cli = {}
        with tempfile.TemporaryDirectory() as tmp:
            for method in ("ls", "oe"):
                argv = [exe, "identify", *map(str, files), "--format", "hsva_kvlcc2",
                        "--model", "mmg", "--method", method, "--accept-failed-checks", "--out",
                        str(Path(tmp) / f"{method}.json")]
                cli[method] = _command_cpu(argv)
                print(f"  usvid identify --method {method}: {cli[method][0]:6.1f} s CPU "
                      f"{cli[method][1]:6.1f} s wall (fresh process, start-up included)")
        print(f"  usvid identify oe / ls CPU: {cli['oe'][0] / cli['ls'][0]:.2f} "
              f"(acceptance <= 1.5); load average {os.getloadavg()[0]:.1f}")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  process max RSS {rss:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
