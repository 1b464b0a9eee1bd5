"""The command line against shipmmg, end to end: ``usvid simulate zigzag`` in a fresh process
(warm numba cache) against a small script that imports shipmmg and simulates the same zig-zag
(target: at most 1.5x its CPU time).

Both simulate the published KVLCC2 MMG model (Yasukawa & Yoshimura 2015, the paper's
particulars, with the wake and x_G that shipmmg implements: ``wake_model='gaussian'``, C_w = 4,
x_G = 0; the one mapping is ``tests/shipmmg_map.py``, as in :mod:`bench_mmg`), approach
1.179 m/s at the shaft speed holding it, a 20/20 zig-zag with the rudder at 15.8 deg/s, 100 s
on a 0.01 s grid:

- usvid: ``usvid simulate zigzag MODEL --delta-deg 20 --t-end 100 --dt 0.01 --json`` (RK4, an
  ideal servo; the model file written here), the metrics printed as JSON;
- the peer: a script that imports ``shipmmg.mmg_3dof``, sets the same parameters, runs
  ``zigzag_test_mmg_3dof`` (its defaults: RK45, rtol 1e-3) and prints the two overshoots.

Each command runs ``--repeat`` times (default 7) in fresh processes, the two interleaved so that
the load of the shared machine weighs on both alike, after one warm-up run each (it fills
numba's cache when empty: minutes of CPU in a fresh checkout). The figure is the child's CPU
time (user + system, ``os.wait4``), interpreter start-up included for both. Python's bytecode
is written as for any installed package (``PYTHONDONTWRITEBYTECODE`` is dropped for the
children; pip compiles the peer's at install). Prints the fastest and the median of each,
their ratios and the load average.

Run: ``.venv/bin/python benchmarks/bench_cli_zigzag.py [--repeat N]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import statistics
import sys
import tempfile
from pathlib import Path

from bench_imports import cpu_seconds, run_child

ROOT = Path(__file__).resolve().parents[1]
U0 = 1.179  # approach speed of Y&Y 2015's KVLCC2 model [m/s]
AMP_DEG, RATE_DEG_S, T_END, DT = 20.0, 15.8, 100.0, 0.01

PEER = """import json, math
import numpy as np
from shipmmg.mmg_3dof import (Mmg3DofBasicParams, Mmg3DofManeuveringParams,
                              zigzag_test_mmg_3dof)
basic = Mmg3DofBasicParams(**{basic!r})
man = Mmg3DofManeuveringParams(**{man!r})
t = np.arange(0.0, {t_end!r} + 1e-9, {dt!r})
amp = math.radians({amp!r})
out = zigzag_test_mmg_3dof(basic, man, amp, amp, list(t), list(np.full(t.size, {n!r})),
                           δ_rad_rate=math.radians({rate!r}), u0={u0!r}, ρ={rho!r})
psi = np.degrees(np.asarray(out[6]))
i1 = int(np.argmax(psi >= {amp!r}))
i2 = i1 + int(np.argmax(psi[i1:] <= -{amp!r}))
i3 = i2 + int(np.argmax(psi[i2:] >= {amp!r}))
print(json.dumps({{"overshoot_1_deg": float(psi[i1:i2].max() - {amp!r}),
                  "overshoot_2_deg": float(-psi[i2:i3].min() - {amp!r})}}))
"""


def write_inputs(tmp: Path) -> tuple[Path, Path]:
    """(the usvid model file, the peer script) of the KVLCC2 zig-zag, written into ``tmp``."""
    import shipmmg.mmg_3dof as sm

    from usvid.io.modelfile import save_model
    from usvid.models import VesselModel
    from usvid.models import mmg as _mmg
    from usvid.models.kinds.mmg import equilibrium_rps, from_physics
    from usvid.models.servo import IdealServo
    from usvid.trial import Vessel

    sys.path.insert(0, str(ROOT / "tests"))
    from shipmmg_map import shipmmg_params

    p = _mmg.kvlcc2("paper").replace(wake_model="gaussian", C_w=4.0, x_G=0.0)
    n = equilibrium_rps(p, U0)
    model = VesselModel(from_physics(p, n=n), vessel=Vessel(length=p.L, speed=U0),
                        servo=IdealServo(max_angle=math.radians(35.0),
                                         max_rate=math.radians(RATE_DEG_S)))
    model_path = save_model(model, tmp / "kvlcc2_mmg.json")
    basic, man = shipmmg_params(sm, p)
    peer = tmp / "shipmmg_zigzag.py"
    peer.write_text(PEER.format(basic=dataclasses.asdict(basic), man=dataclasses.asdict(man),
                                t_end=T_END, dt=DT, amp=AMP_DEG, n=float(n), rate=RATE_DEG_S,
                                u0=U0, rho=float(p.rho)), encoding="utf-8")
    return Path(model_path), peer


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    try:
        import shipmmg  # noqa: F401
    except ImportError:
        print("bench_cli_zigzag: shipmmg not installed (pip install -e '.[test]'): skipped")
        return
    usvid = str(Path(sys.executable).with_name("usvid"))
    with tempfile.TemporaryDirectory() as tmp:
        model, peer = write_inputs(Path(tmp))
        mine = [usvid, "simulate", "zigzag", str(model), "--delta-deg", str(AMP_DEG),
                "--t-end", str(T_END), "--dt", str(DT), "--json"]
        theirs = [sys.executable, str(peer)]
        out_m = run_child(mine)[1]  # warm-up: bytecode, numba's cache
        out_p = run_child(theirs)[1]
        load0 = os.getloadavg()[0]
        tm, tp = [], []
        for _ in range(args.repeat):
            tm.append(cpu_seconds(mine))
            tp.append(cpu_seconds(theirs))
        load1 = os.getloadavg()[0]
    zz = json.loads(out_m)
    os_m = (list(zz.get("overshoot_deg") or []) + [None, None])[:2]
    os_p = [json.loads(out_p)[k] for k in ("overshoot_1_deg", "overshoot_2_deg")]
    print(f"bench_cli_zigzag: KVLCC2 MMG 20/20 zig-zag, {T_END:.0f} s on a {DT} s grid, CPU time "
          f"of a fresh process, {args.repeat} runs each, interleaved (load average {load0:.1f} "
          f"at the start, {load1:.1f} at the end)")
    print(f"  usvid simulate zigzag (warm numba cache): fastest {min(tm):.3f} s, median "
          f"{statistics.median(tm):.3f} s; shipmmg script: fastest {min(tp):.3f} s, median "
          f"{statistics.median(tp):.3f} s; ratio {min(tm) / min(tp):.2f}x fastest, "
          f"{statistics.median(tm) / statistics.median(tp):.2f}x median [target <= 1.5x]")
    print(f"  overshoots [deg]: usvid {_fmt(os_m)}, shipmmg {_fmt(os_p)}")


def _fmt(v: list) -> str:
    return ", ".join("n/a" if x is None else f"{x:.3f}" for x in v)


if __name__ == "__main__":
    main()
