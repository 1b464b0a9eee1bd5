"""The papers' headline numbers that ``usvid demo`` recomputes (docs/papers.md, rows marked
"demo"): each row the paper's value, usvid's value on the shipped example models, the command
that prints it and its status, as the page states them. The page and the report come from this
one computation (a test checks the page against it).

Rows: Mu et al. 2018 Table 3 (PID and PD ITAE under the documented reading, one realisation),
the Lanxin turning radius at 10 deg; Mu et al. 2016 turning radius (eq. 25 as printed) and
15/15 zig-zag period; the catamaran paper's measured turn predicted by the paper's model; Ma et
al.'s objective of eq. 3, the bounded optimum and the extrapolation interval. About 5 s.
"""

from __future__ import annotations

import math
from importlib import resources
from typing import Any

import numpy as np

from usvid.identify.turning_diameter import load_turning_table
from usvid.identify.turning_diameter_interval import prediction_interval
from usvid.io.modelfile import model_from_dict
from usvid.models.turning_diameter import (
    MA_BOUNDS,
    MA_EQ3,
    relative_turning_diameter,
    rms_objective,
)
from usvid.sim import Commanded, run_course, run_turning, run_zigzag, simulate

#: The documented reading of Mu et al. 2018 Table 3 (docs/papers.md): rudder-equivalent
#: disturbance std [deg], horizon [s], realisation.
TABLE3_READING = {"noise_deg": 0.75, "t_end": 50.0, "seed": 12}
#: Ma et al. extrapolation point: Froude number, rudder angle [deg].
MA_POINT = (0.3, 10.0)


def example_model(name: str) -> Any:
    """A shipped example model (package data ``usvid/data/examples/NAME.json``)."""
    import json

    text = resources.files("usvid").joinpath("data", "examples", f"{name}.json").read_text(
        encoding="utf-8")
    return model_from_dict(json.loads(text), source=f"examples/{name}.json")


def _row(paper: str, quantity: str, paper_value: str, usvid_value: str, command: str,
         status: str) -> dict[str, str]:
    return {"paper": paper, "quantity": quantity, "paper_value": paper_value,
            "usvid_value": usvid_value, "command": command, "status": status}


def _table3() -> list[dict[str, str]]:
    m = example_model("lanxin")
    r = TABLE3_READING
    itae = {c: run_course(m, controller=c, **r)[1]["itae"] for c in ("pid", "pd")}
    cmd = ("usvid simulate course-keeping examples/lanxin.json --controller {c} --noise "
           f"{r['noise_deg']:g} --t-end {r['t_end']:g} --seed {r['seed']}")
    order = "PID < PD" if itae["pid"] < itae["pd"] else "PID >= PD"
    return [
        _row("Mu et al. 2018", "Table 3, ITAE of the PID course change", "37.98",
             f"{itae['pid']:.2f}", cmd.format(c="pid"),
             f"{100 * (itae['pid'] / 37.98 - 1):+.1f} % under the documented reading "
             "(one realisation)"),
        _row("Mu et al. 2018", "Table 3, ITAE of the PD course change", "38.6",
             f"{itae['pd']:.2f}", cmd.format(c="pd"),
             f"{100 * (itae['pd'] / 38.6 - 1):+.1f} %, {order} in this realisation"),
    ]


def _lanxin_turning() -> dict[str, str]:
    R = {k: run_turning(example_model(k), 10.0)[1].steady_diameter_m / 2
         for k in ("lanxin_threedof", "lanxin", "lanxin_norrbin")}
    return _row("Mu et al. 2018", "turning radius at 10 deg (Fig. 8: 1.5 m = 3.8 % of it)",
                "about 39.5 m measured",
                f"{R['lanxin_threedof']:.2f} m (3-DOF), {R['lanxin']:.2f} m (Nomoto), "
                f"{R['lanxin_norrbin']:.2f} m (Norrbin)",
                "usvid simulate turning examples/lanxin_threedof.json --delta-deg 10",
                f"3-DOF {100 * (R['lanxin_threedof'] / 39.47 - 1):+.1f} % of 1.5/0.038 m")


def _pod() -> list[dict[str, str]]:
    R = run_turning(example_model("pod_usv_eq25"), 5.0)[1].steady_diameter_m / 2
    P = run_zigzag(example_model("pod_usv"), 15.0, 15.0)[1].period_s
    return [
        _row("Mu et al. 2016", "turning radius at 5 deg", "85.76 m simulated (84.97 m measured)",
             f"{R:.2f} m", "usvid simulate turning examples/pod_usv_eq25.json --delta-deg 5",
             f"{100 * (R / 85.76 - 1):+.2f} %, K of eq. 25 as printed at 9.1 kn"),
        _row("Mu et al. 2016", "15/15 zig-zag period", "11.3 s simulated (12.9 s measured)",
             f"{P:.2f} s",
             "usvid simulate zigzag examples/pod_usv.json --delta-deg 15 --psi-deg 15",
             "not reproduced by any printed parameter set"),
    ]


def _catamaran() -> dict[str, str]:
    m = example_model("catamaran")
    t = np.array([0.0, 1.0])
    res = simulate(m, Commanded(t, n_port=np.array([20.0, 20.0]),
                                n_stbd=np.array([15.0, 15.0])), t_end=600.0, dt=0.05, u0=0.0)
    tm = res.turning_metrics()[0]
    D, U = tm.steady_diameter_m, tm.steady_speed_m_s
    return _row("catamaran paper", "the measured turn", "about 8 m at 0.246 m/s",
                f"{D:.2f} m at {U:.3f} m/s", "python examples/catamaran_turn.py",
                f"predicted: {D - 8.0:+.2f} m ({100 * (D / 8.0 - 1):+.1f} %), speed "
                f"{100 * (U / 0.246 - 1):+.0f} %")


def _ma() -> list[dict[str, str]]:
    Fr, delta, DL = load_turning_table(None)
    pub = float(rms_objective(MA_EQ3, Fr, delta, DL))
    fr0, d0 = MA_POINT
    # the interval's own search finds the bounded least-squares optimum (a_opt, ssr_min)
    pi = prediction_interval(Fr, delta, DL, fr0, math.radians(d0), {"published_eq3": MA_EQ3})
    F = math.sqrt(pi.ssr_min / Fr.size)
    lo, hi = np.asarray(MA_BOUNDS).T
    on = [f"a{k + 1} = {pi.a_opt[k]:.4g}" for k in range(5)
          if min(abs(pi.a_opt[k] - lo[k]), abs(pi.a_opt[k] - hi[k])) <= 1e-6 * (hi[k] - lo[k])]
    opt = float(relative_turning_diameter(fr0, math.radians(d0), pi.a_opt))
    return [
        _row("Ma et al.", "RMS objective F of eq. 3 on Table 2", "0.4665", f"{pub:.4f}",
             "usvid fit-turning-diameter", f"reproduced ({pub:.6f})"),
        _row("Ma et al.", "the optimum of eq. 2 within the paper's bounds", "eq. 3, F 0.4665",
             f"F {F:.4f}, {' and '.join(on)} on their bounds", "usvid fit-turning-diameter",
             "the chaotic GA reaches it too"),
        _row("Ma et al.", f"D/L at Fr {fr0:g}, delta {d0:g} deg (outside the tests)",
             f"{pi.by_fit['published_eq3']:.2f} (eq. 3)",
             f"{opt:.2f} (optimum), 95 % interval {pi.low:.2f} .. {pi.high:.2f}",
             f"usvid fit-turning-diameter --predict-fr {fr0:g} --predict-delta-deg {d0:g}",
             "not determined by the data"),
    ]


def paper_rows() -> list[dict[str, str]]:
    """The rows (module docstring), each ``paper``, ``quantity``, ``paper_value``,
    ``usvid_value``, ``command``, ``status`` as docs/papers.md states them."""
    return [*_table3(), _lanxin_turning(), *_pod(), _catamaran(), *_ma()]


def papers_entry() -> dict[str, Any]:
    """The ``run.json`` entry of the report's "Papers" section."""
    return {"description": (
        "Headline numbers of the papers usvid implements, recomputed on the shipped example "
        "models (not on this campaign): the paper's value, usvid's, the command that prints "
        "it. docs/papers.md has every row with its arithmetic."), "rows": paper_rows()}
