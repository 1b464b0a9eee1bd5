"""``usvid montecarlo`` with the sea state drawn per run: ``--hs``, ``--tp`` and
``--wave-dir-deg`` take the distributions of the wind and current options, each run's sea
state is a column and is the run's own (its single run with that sea state and its wave
stream), a height drawn at or below 0 is drawn again, and a sea state counts as variation."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from usvid.cli import main
from usvid.io.modelfile import model_from_dict
from usvid.manoeuvres.logic import ZigZag
from usvid.models.environment import SeaState
from usvid.scale.montecarlo import MonteCarlo, Vary, run_montecarlo, sea_record_every
from usvid.sim.simulate import Environment, simulate

MODEL = {"usvid_model": 1, "kind": "nomoto1", "parameters": {"K": 0.5, "T": 2.0},
         "servo": {"kind": "ideal", "max_angle_deg": 35},
         "vessel": {"length": 5.0, "speed": 2.0, "mass": 800.0, "beam": 1.8, "draft": 0.3}}
OPTS = {"t_end": 30.0}


@pytest.fixture()
def model_file(tmp_path):
    p = tmp_path / "n.json"
    p.write_text(json.dumps(MODEL))
    return p


def test_cli_sea_state_distributions_are_columns(model_file, tmp_path, capsys):
    """No --vary: the sea state alone varies the runs; each drawn quantity is a column within
    its distribution; --json echoes the distributions and run 0's sea state."""
    out = tmp_path / "o.parquet"
    code = main(["montecarlo", str(model_file), "--manoeuvre", "zigzag", "--runs", "40",
                 "--t-end", "30", "--seed", "4", "--hs", "normal:0.3,0.05", "--tp",
                 "uniform:2.5,4", "--wave-dir-deg", "uniform:0,360", "--out", str(out),
                 "--json"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0
    df = pd.read_parquet(out)
    assert {"hs", "tp", "wave_dir_deg", "sea_redraws"} <= set(df.columns)
    assert df["tp"].between(2.5, 4.0).all() and df["wave_dir_deg"].between(0, 360).all()
    assert df["hs"].std() > 0.02 and df["hs"].min() > 0
    e = s["environment"]
    assert e["hs"] == {"dist": "normal", "a": 0.3, "b": 0.05}
    assert e["run0"]["waves"]["hs_m"] == pytest.approx(df["hs"][0], rel=1e-12)
    assert e["run0"]["waves"]["tp_s"] == pytest.approx(df["tp"][0], rel=1e-12)
    assert s["parameters"] == [] and s["failed"] == 0 and s["sea_redrawn"] == 0
    assert s["quantiles"]["overshoot_1_deg"]["n"] == 40
    # a constant sea state alone (each run its own wave realisation) is variation too
    code = main(["montecarlo", str(model_file), "--manoeuvre", "zigzag", "--runs", "8",
                 "--t-end", "30", "--hs", "0.3", "--tp", "3", "--out", str(out), "--json"])
    assert code == 0
    assert pd.read_parquet(out)["overshoot_1_deg"].std() > 0
    capsys.readouterr()
    code = main(["montecarlo", str(model_file), "--manoeuvre", "zigzag", "--runs", "8",
                 "--out", str(tmp_path / "calm.parquet")])
    assert code == 2 and "nothing to vary" in capsys.readouterr().err


def test_run_i_is_its_own_sea_state_and_independent_of_the_chunking():
    """Run i is the single run of its drawn sea state with its wave stream (seed, i) (to the
    rounding of the batch's band, 1e-9 deg); chunks of 5 and one chunk give identical rows."""
    env = {"hs": Vary("hs", "uniform", 0.1, 0.5), "tp": Vary("tp", "normal", 3.0, 0.3),
           "wave_dir_deg": Vary("wave_dir_deg", "uniform", 0.0, 360.0)}
    mc = MonteCarlo(dict(MODEL), "zigzag", OPTS, seed=3, environment=env)
    df = run_montecarlo(mc, 12, chunk=5)
    pd.testing.assert_frame_equal(df, run_montecarlo(mc, 12, chunk=12))
    assert df["success"].all() and df["hs"].nunique() == 12
    i = 7
    sea = SeaState(float(df["hs"][i]), float(df["tp"][i]), math.radians(df["wave_dir_deg"][i]))
    res = simulate(model_from_dict(MODEL), ZigZag(math.radians(10.0), math.radians(10.0)),
                   t_end=30.0, record_every=sea_record_every(mc, 0.02),
                   environment=Environment(sea=sea, wave_seed=3, wave_stream=[i]),
                   channels=("x", "y", "psi", "delta"))
    m = res.zigzag_metrics()[0]
    assert df["overshoot_1_deg"][i] == pytest.approx(m.overshoot_deg[0], rel=0, abs=1e-9)
    # record every step of 20 per shortest peak period: a normal's mean less 4 SD (1.8 s)
    assert sea_record_every(mc, 0.02) == int(1.8 / 20 / 0.02)


def test_heights_at_or_below_zero_are_drawn_again():
    """H_s normal(0.1, 0.1): 16 % of first draws are no sea state and are drawn again (column
    sea_redraws, as the parameters outside their bounds), never clipped; run i's draw does not
    depend on the chunk; a height whose centre is not > 0 is refused."""
    env = {"hs": Vary("hs", "normal", 0.1, 0.1), "tp": 3.0}
    mc = MonteCarlo(dict(MODEL), "course-keeping", {"t_end": 5.0}, seed=1, environment=env)
    e, redraws, failed = mc.environment_draws(0, 2000)
    assert np.all(e["hs"] > 0) and not failed.any()
    # P(x <= 0) = 0.159 of a normal at one SD: 2000 runs give 318 +- 16 (binomial SD)
    assert 250 < np.sum(redraws > 0) < 390
    e2, r2, _ = mc.environment_draws(1500, 1600)
    np.testing.assert_array_equal(e2["hs"], e["hs"][1500:1600])
    np.testing.assert_array_equal(r2, redraws[1500:1600])
    df = run_montecarlo(mc, 30)
    assert df["sea_redraws"].sum() == redraws[:30].sum() and df["valid_draw"].all()
    from usvid.errors import UsvidError
    with pytest.raises(UsvidError, match="--hs: must be > 0"):
        MonteCarlo(dict(MODEL), "zigzag", OPTS,
                   environment={"hs": Vary("hs", "normal", -0.1, 0.1), "tp": 3.0})
