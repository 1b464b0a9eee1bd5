"""``usvid montecarlo`` in wind, current and waves: the environment options of ``usvid
simulate``, the wind and current also as distributions drawn per run; run i's environment and
wave realisation do not depend on the chunking, so Dask and the in-process path give identical
rows; calm water is today's runs."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from usvid.cli import main
from usvid.commands.montecarlo import montecarlo
from usvid.io.modelfile import model_from_dict
from usvid.manoeuvres.logic import ZigZag
from usvid.scale.montecarlo import MonteCarlo, Vary, run_montecarlo, sea_record_every
from usvid.sim.simulate import simulate

distributed = pytest.importorskip("distributed")

MODEL = {"usvid_model": 1, "kind": "nomoto1", "parameters": {"K": 0.5, "T": 2.0},
         "servo": {"kind": "ideal", "max_angle_deg": 35},
         "vessel": {"length": 5.0, "speed": 2.0, "mass": 800.0, "beam": 1.8, "draft": 0.3,
                    "frontal_area": 1.2, "lateral_area": 3.0}}
OPTS = {"t_end": 40.0}
SEA = {"hs": 0.3, "tp": 3.0, "wave_dir_deg": 30.0}


@pytest.fixture(scope="module")
def client():
    from usvid.scale.cluster import connect

    with connect(workers=2) as cl:
        yield cl


@pytest.fixture()
def model_file(tmp_path):
    p = tmp_path / "n.json"
    p.write_text(json.dumps(MODEL))
    return p


def test_zigzag_in_a_sea_on_dask_equals_in_process(client, model_file, tmp_path):
    env = {"wind_speed": "uniform:2,6", "wind_dir_deg": "normal:90,20", **SEA}
    s = montecarlo(model_file, "zigzag", 300, tmp_path / "d.parquet", vary=["K=normal:0.5,0.02"],
                   seed=7, options=OPTS, chunk=100, client=client, progress=False,
                   environment=env)
    assert s["backend"] == "dask" and s["chunks"] == 3
    a = montecarlo(model_file, "zigzag", 300, tmp_path / "a.parquet",
                   vary=["K=normal:0.5,0.02"], seed=7, options=OPTS, chunk=300, progress=False,
                   environment=env)
    assert a["backend"] == "in-process"
    got, ref = pd.read_parquet(tmp_path / "d.parquet"), pd.read_parquet(tmp_path / "a.parquet")
    pd.testing.assert_frame_equal(got, ref)  # identical, not merely close
    assert a["quantiles"] == s["quantiles"]
    # the drawn wind is a column, within its distribution; a constant is none
    assert {"wind_speed", "wind_dir_deg"} <= set(got) and "hs" not in got
    assert got["wind_speed"].between(2.0, 6.0).all()
    # 300 draws of N(90, 20): the mean within 4 standard errors (4 * 20 / sqrt(300) = 4.6 deg)
    assert abs(got["wind_dir_deg"].mean() - 90.0) < 4.6
    # nearly every run shows its first overshoot in 40 s (a run whose first reversal comes late
    # in a strong wind may not: its metric is NaN and out of n)
    assert s["quantiles"]["overshoot_1_deg"]["n"] >= 285
    e = s["environment"]
    assert e["wind_speed"] == {"dist": "uniform", "a": 2.0, "b": 6.0} and e["hs"] == 0.3
    assert e["run0"]["wind"]["model"] == "blendermann1994"
    assert e["run0"]["waves"]["first_order_motion"] is True
    assert e["run0"]["wind"]["speed_m_s"] == pytest.approx(got["wind_speed"][0])


def test_run_i_is_the_single_run_with_wave_stream_i(model_file):
    """Run i of a study is the simulation of run i alone: its wind as drawn, its wave
    realisation from the stream (seed, i), measured on the recorded heading."""
    d = dict(MODEL)
    env = {"wind_speed": Vary("wind_speed", "uniform", 2.0, 6.0), "wind_dir_deg": 90.0, **SEA}
    mc = MonteCarlo(d, "zigzag", OPTS, vary=(Vary("K", "normal", 0.5, 0.02),), seed=3,
                    environment=env)
    df = run_montecarlo(mc, 12, chunk=5)
    i = 7
    one = mc.environment_of(i, i + 1)
    assert one.wave_stream[0] == i and one.wind_speed[0] == df["wind_speed"][i]
    vm = model_from_dict(d)
    vm = type(vm)(vm.dynamics.replace(K=float(df["K"][i])), servo=vm.servo, vessel=vm.vessel)
    res = simulate(vm, ZigZag(math.radians(10.0), math.radians(10.0)), t_end=40.0, dt=0.02,
                   record_every=sea_record_every(mc, 0.02), environment=one,
                   channels=("x", "y", "psi", "delta"))
    m = res.zigzag_metrics()[0]
    assert df["overshoot_1_deg"][i] == pytest.approx(m.overshoot_deg[0], rel=1e-12)
    # the sea acts: another wave stream gives another overshoot
    assert df["overshoot_1_deg"][i] != df["overshoot_1_deg"][i - 1]


def test_calm_and_zero_environment_are_todays_runs(model_file, tmp_path):
    calm = run_montecarlo(MonteCarlo(dict(MODEL), "zigzag", OPTS,
                                     vary=(Vary("K", "normal", 0.5, 0.02),), seed=1), 50)
    zero = run_montecarlo(MonteCarlo(dict(MODEL), "zigzag", OPTS,
                                     vary=(Vary("K", "normal", 0.5, 0.02),), seed=1,
                                     environment={"wind_speed": 0.0, "current_speed": 0.0}),
                          50)
    # zero wind and current: the core's environment-series variant (FMA contraction may differ
    # in the last bits)
    for k in ("overshoot_1_deg", "overshoot_2_deg", "initial_turning_time_s"):
        np.testing.assert_allclose(zero[k], calm[k], rtol=1e-12)
    assert "wind_speed" not in calm


@pytest.mark.parametrize("args, message", [
    (["--wind-speed", "normal:5"], "--wind-speed 'normal:5': expected normal:MEAN,SD"),
    (["--wind-speed", "uniform:6,2"], "LO <= HI"),
    (["--hs", "uniform:0,0.3", "--tp", "3"], "--hs must be in (0, 30] m (got 0.0)"),
    (["--hs", "normal:-0.1,0.3", "--tp", "3"], "--hs must be in (0, 30] m (got -0.1)"),
    (["--hs", "0.3", "--tp", "normal:3"], "--tp 'normal:3': expected normal:MEAN,SD"),
    (["--wave-dir-deg", "uniform:0,90"], "--wave-dir-deg needs --hs and --tp"),
    (["--wind-speed", "-1"], "--wind-speed must be in [0, 100] m/s"),
    (["--wind-speed", "uniform:-1,3"], "--wind-speed must be in [0, 100] m/s"),
    (["--wind-dir-deg", "90"], "--wind-dir-deg needs --wind-speed"),
    (["--hs", "0.3"], "--hs and --tp go together"),
])
def test_environment_option_errors(model_file, tmp_path, capsys, args, message):
    code = main(["montecarlo", str(model_file), "--manoeuvre", "zigzag", "--runs", "10",
                 "--vary", "K=normal:0.5,0.01", "--out", str(tmp_path / "o.parquet"), *args])
    err = capsys.readouterr().err
    assert code == 2 and message in err, err
    assert not (tmp_path / "o.parquet").exists()


def test_windage_missing_is_refused_before_any_run(tmp_path, capsys):
    d = json.loads(json.dumps(MODEL))
    del d["vessel"]["frontal_area"]
    p = tmp_path / "m.json"
    p.write_text(json.dumps(d))
    code = main(["montecarlo", str(p), "--manoeuvre", "turning", "--runs", "10", "--vary",
                 "K=normal:0.5,0.01", "--out", str(tmp_path / "o.parquet"), "--wind-speed", "4"])
    assert code == 2 and "frontal_area" in capsys.readouterr().err


def test_wave_streams_are_the_lanes_of_a_larger_batch():
    """Lane b with stream s draws what lane s of one batch draws (run i of a study from
    (seed, i) whatever its chunk); bad streams are refused."""
    from usvid.errors import UsvidError
    from usvid.models.environment import SeaState, wave_components

    sea = SeaState(hs=0.3, tp=3.0, direction=0.0)
    whole = wave_components(sea, n_components=16, seed=4, n_batch=8, length=5.0)
    part = wave_components(sea, n_components=16, seed=4, n_batch=3, length=5.0,
                           streams=[5, 6, 7])
    np.testing.assert_array_equal(part, whole[5:])
    with pytest.raises(UsvidError, match="streams must be 2 whole numbers"):
        wave_components(sea, n_components=16, seed=4, n_batch=2, streams=[0.5, 1])
