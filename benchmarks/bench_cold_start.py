"""Cold start: ``usvid simulate zigzag`` in a fresh process with an empty numba cache, against
the same with the cache written by it (warm), and where the compile time goes.

For each model kind given (default ``nomoto1 threedof mmg``, the example models of
``examples/``), the command runs twice in fresh processes with ``NUMBA_CACHE_DIR`` set to a new
empty folder: the first compiles every function it runs (the cold start), the second loads them
(warm). Inside the cold process every compilation is timed (numba's ``numba:compile`` events
for jitted functions, the compile of each C callback): per function its own time (nested
compilations of the functions it calls subtracted) and CPU, and the cache loads are counted.
Printed: wall and CPU of both runs, the number of functions compiled, and the compile time by
function, largest first, grouped by kind of function (the chunk driver, the per-lane step, the
vector-step variants, the helpers), so that the floor of a cold start can be read off.
``python benchmarks/bench_cold_start.py [KIND ...]``.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"nomoto1": "lanxin.json", "norrbin": "lanxin_norrbin.json",
          "threedof": "lanxin_threedof.json", "mmg": "usv_twin_mmg.json",
          "catamaran": "catamaran.json"}

#: Run in the measured process: hooks on numba's compiler, then the command in process.
PROBE = r"""
import json, sys, time
t_start = time.perf_counter(); c_start = time.process_time()
import numba.core.event as ev
from numba.core import caching, ccallback
records, stack = [], []

def begin(name):
    stack.append([name, time.perf_counter(), time.process_time(), 0.0, 0.0])

def end():
    name, t0, c0, child_t, child_c = stack.pop()
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    records.append({"name": name, "wall": dt - child_t, "cpu": dc - child_c, "incl": dt})
    if stack:
        stack[-1][3] += dt
        stack[-1][4] += dc

class Timer(ev.Listener):
    def on_start(self, event):
        d = event.data["dispatcher"]
        begin(getattr(d, "__qualname__", None) or d.py_func.__qualname__)
    def on_end(self, event):
        end()

ev.register("numba:compile", Timer())
uncached = ccallback.CFunc._compile_uncached
def timed(self):
    begin(self._pyfunc.__qualname__)
    try:
        return uncached(self)
    finally:
        end()
ccallback.CFunc._compile_uncached = timed
loads = {"hit": 0, "miss": 0}
load = caching.Cache.load_overload
def counted(self, *a, **k):
    r = load(self, *a, **k)
    loads["hit" if r is not None else "miss"] += 1
    return r
caching.Cache.load_overload = counted
from usvid.cli import main
t_imp = time.perf_counter() - t_start
try:
    code = main(sys.argv[2:])
finally:
    out = {"records": records, "loads": loads, "wall": time.perf_counter() - t_start,
           "cpu": time.process_time() - c_start, "import_cli_wall": t_imp}
    with open(sys.argv[1], "w") as f:
        json.dump(out, f)
sys.exit(code)
"""


def _group(name: str) -> str:
    base = name.split("__")[0]
    if base.startswith("_vstep") or base.startswith(("_vrk4", "_vderiv", "_steer")):
        return "vector step (per kind and variant)"
    if base.startswith(("_lstep", "_rk4", "_deriv", "_inputs", "_substeps")):
        return "per-lane step (per kind)"
    if "core_" in name:
        return "chunk driver (once)"
    return "other (helpers, rhs, scalar, estimation)"


def _run(kind: str, cache: str, probe: str | None) -> tuple[float, float, dict | None]:
    model = ROOT / "examples" / MODELS[kind]
    argv = ["simulate", "zigzag", str(model), "--json"]
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    if probe:
        cmd = [sys.executable, "-c", PROBE, probe, *argv]
    else:
        cmd = [str(Path(sys.executable).with_name("usvid")), *argv]
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    data = json.loads(Path(probe).read_text()) if probe else None
    return wall, cpu, data


def main() -> int:
    kinds = sys.argv[1:] or ["nomoto1", "threedof", "mmg"]
    print(f"bench_cold_start: usvid simulate zigzag, {len(os.sched_getaffinity(0))} cores, "
          f"load average {os.getloadavg()[0]:.1f}")
    for kind in kinds:
        with tempfile.TemporaryDirectory() as tmp:
            cache = str(Path(tmp) / "numba")
            probe = str(Path(tmp) / "probe.json")
            cw, cc, data = _run(kind, cache, probe)
            ww, wc, _ = _run(kind, cache, None)
            wp, cp, data_w = _run(kind, cache, str(Path(tmp) / "warm.json"))
        assert data is not None and data_w is not None
        recs = data["records"]
        comp_wall = sum(r["wall"] for r in recs)
        comp_cpu = sum(r["cpu"] for r in recs)
        print(f"{kind}: empty cache {cw:5.1f} s wall {cc:5.1f} s CPU (with the timing hooks); "
              f"warm {ww:5.2f} s wall {wc:5.2f} s CPU; {len(recs)} compilations, "
              f"{comp_wall:5.1f} s wall {comp_cpu:5.1f} s CPU in numba's compiler; cache loads "
              f"cold {data['loads']}, warm {data_w['loads']}")
        groups: dict[str, list[float]] = {}
        for r in recs:
            g = groups.setdefault(_group(r["name"]), [0, 0.0, 0.0])
            g[0] += 1
            g[1] += r["wall"]
            g[2] += r["cpu"]
        for name, (n, w, c) in sorted(groups.items(), key=lambda kv: -kv[1][2]):
            print(f"    {name:42s} {n:3d} functions {w:6.2f} s wall {c:6.2f} s CPU")
        wrec = data_w["records"]
        print(f"    warm: {len(wrec)} compilations, {sum(r['cpu'] for r in wrec):.2f} s CPU in "
              f"numba's compiler ({', '.join(sorted({r['name'][:40] for r in wrec})[:8])})")
        for r in sorted(recs, key=lambda r: -r["cpu"])[:12]:
            print(f"      {r['cpu']:6.2f} s CPU {r['wall']:6.2f} s wall (incl. callees "
                  f"{r['incl']:6.2f} s)  {r['name'][:90]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
