"""Scale-out on Dask: ``usvid montecarlo`` and ``usvid batch`` on a local 2-worker cluster give
the results of the in-process run (same seed), whatever the chunking; the local cluster opens no
HTTP port and its errors are one line; montecarlo's in-process path on a small machine."""

from __future__ import annotations

import dataclasses
import json
import operator
import os

import numpy as np
import pandas as pd
import pytest
import yaml

from usvid.cli import main
from usvid.commands.batch import batch
from usvid.commands.montecarlo import montecarlo
from usvid.errors import UsvidError
from usvid.io.modelfile import model_to_dict
from usvid.models import Nomoto1, VesselModel, mu2018_servo
from usvid.scale.batch import run_batch
from usvid.scale.cluster import (
    TaskFailed,
    check_scheduler_address,
    connect,
    map_ordered,
    max_workers,
)
from usvid.scale.montecarlo import (
    CHUNK_BYTES,
    MAX_RUNS,
    MAX_TASKS,
    MonteCarlo,
    Vary,
    check_size,
    run_montecarlo,
    use_dask,
)
from usvid.trial import Vessel

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    """One local cluster of 2 single-threaded worker processes for the module, as the commands
    make it (:func:`usvid.scale.cluster.connect`; start-up ~2 s idle, ~8 s under load)."""
    with connect(workers=2) as cl:
        yield cl


def _model_file(tmp_path):
    vm = VesselModel(Nomoto1(K=0.2, T=5.0), servo=mu2018_servo(),
                     vessel=Vessel(length=7.0, speed=3.0))
    d = model_to_dict(vm)
    # an identified model's record: std errors and the covariance of (K, T)
    d["identification"] = {"method": "ls", "std_errors": {"K": 0.01, "T": 0.3},
                           "covariance": {"names": ["K", "T"],
                                          "matrix": [[1e-4, 1e-3], [1e-3, 0.09]]}}
    path = tmp_path / "model.json"
    path.write_text(json.dumps(d))
    return path, d


def test_montecarlo_on_dask_equals_in_process(client, tmp_path):
    path, d = _model_file(tmp_path)
    out = tmp_path / "mc.parquet"
    s = montecarlo(path, "zigzag", 700, out, from_uncertainty=True,
                   vary=["delta0=normal:0,0.001"], seed=5, options={"t_end": 60.0},
                   chunk=256, client=client, progress=False)
    assert s["workers"] == 2 and s["chunks"] == 3 and s["uncertainty"] == "covariance"
    # the bounds policy's counts (T = 5 +- 0.3 s, K = 0.2 +- 0.01: never out of bounds)
    assert s["redrawn"] == 0 and s["failed_draws"] == 0 and s["diverged"] == 0
    got = pd.read_parquet(out)
    mc = MonteCarlo(d, "zigzag", {"t_end": 60.0}, ("K", "T"), np.array([0.2, 5.0]),
                    np.array([[1e-4, 1e-3], [1e-3, 0.09]]), (Vary("delta0", "normal", 0, 0.001),),
                    seed=5)
    ref = run_montecarlo(mc, 700, chunk=300)  # in process, another chunking
    pd.testing.assert_frame_equal(got, ref)  # identical, not merely close
    assert list(got["run"]) == list(range(700))
    # the draws follow the covariance: sample correlation of K, T near 1e-3 / (0.01 * 0.3)
    # = 0.333 (700 samples: standard error ~0.034; 0.12 is > 3 sigma)
    assert np.corrcoef(got["K"], got["T"])[0, 1] == pytest.approx(1 / 3, abs=0.12)
    q = s["quantiles"]["overshoot_1_deg"]
    assert q["q05"] < q["q50"] < q["q95"] and q["n"] == 700
    assert q["q50"] == pytest.approx(float(np.median(ref["overshoot_1_deg"])))


def test_montecarlo_cli_errors(tmp_path, capsys):
    path, _ = _model_file(tmp_path)
    out = tmp_path / "x.parquet"
    assert main(["montecarlo", str(path), "--manoeuvre", "zigzag", "--out", str(out),
                 "--vary", "K=gauss:1,2"]) == 2
    assert "--vary 'K=gauss:1,2': expected NAME=normal:MEAN,SD" in capsys.readouterr().err
    assert main(["montecarlo", str(path), "--manoeuvre", "zigzag", "--out", str(out),
                 "--vary", "Q=normal:1,2"]) == 2
    assert "--vary Q: not a parameter of model kind 'nomoto1'" in capsys.readouterr().err
    assert main(["montecarlo", str(path), "--manoeuvre", "circle", "--out", str(out),
                 "--vary", "K=normal:1,0.1"]) == 2
    assert not out.exists()


SPEC = """reader: table
delimiter: ","
skip_rows: 1
columns:
  t:     {col: 0, unit: s}
  psi:   {col: 1, unit: deg}
  r:     {col: 2, unit: deg/s}
  delta: {col: 3, unit: deg}
vessel: {length: 7.0, speed: 3.0}
"""


def _write_log(path, K, amp, seed):
    """A small virtual zig-zag log (Nomoto K [1/s], T = 3 s, 10 Hz, 60 s, Euler, small noise)."""
    rng = np.random.default_rng(seed)
    h, n = 0.1, 600
    t = np.arange(n) * h
    d = np.radians(amp) * np.sign(np.sin(2 * np.pi * t / 20.0) + 1e-9)
    r = np.zeros(n)
    psi = np.zeros(n)
    for k in range(n - 1):
        r[k + 1] = r[k] + h * (K * d[k] - r[k]) / 3.0
        psi[k + 1] = psi[k] + h * r[k]
    pd.DataFrame({"t": t, "psi": np.degrees(psi) + rng.normal(0, 0.05, n),
                  "r": np.degrees(r) + rng.normal(0, 0.02, n),
                  "delta": np.degrees(d)}).round(5).to_csv(path, index=False)


def test_batch_on_dask_one_corrupt_log_then_nothing_to_do(client, tmp_path):
    (tmp_path / "spec.yaml").write_text(SPEC)
    groups = []
    for g in range(5):  # 5 boats x 10 logs = 50 virtual logs, 2 held out per boat
        folder = tmp_path / f"boat{g}"
        folder.mkdir()
        for i in range(10):
            _write_log(folder / f"run{i}.csv", 0.3 + 0.05 * g, 10 + i, seed=10 * g + i)
        groups.append({"name": f"boat{g}", "logs": [f"boat{g}/*.csv"], "spec": "spec.yaml",
                       "kinds": ["nomoto1"], "holdout": [f"boat{g}/run8.csv",
                                                         f"boat{g}/run9.csv"]})
    (tmp_path / "boat3" / "run4.csv").write_text("t,psi,r,delta\n0,1,2\nnot,a,log,at\nall\n")
    camp = tmp_path / "campaign.yaml"
    camp.write_text(yaml.safe_dump({"groups": groups}))
    out = tmp_path / "out"
    s = run_batch(camp, out, client=client, progress=False)
    assert s["logs"] == 50 and s["logs_ok"] == 49
    assert len(s["errors"]) == 1 and s["errors"][0]["log"].endswith("boat3/run4.csv")
    logs = pd.read_parquet(out / "logs.parquet")
    assert logs["ok"].sum() == 49 and logs.loc[~logs["ok"], "error"].str.len().iloc[0] > 0
    par = pd.read_parquet(out / "parameters.parquet")
    K = par[par["parameter"] == "K"].set_index("group")["value"]
    # Euler truth K = 0.3 + 0.05 g; low-noise logs: 5 % covers the Euler and noise bias
    np.testing.assert_allclose(K.to_numpy(), 0.3 + 0.05 * np.arange(5), rtol=0.05)
    val = pd.read_parquet(out / "validation.parquet")
    assert set(val["log"].map(lambda p: p.rsplit("/", 1)[-1])) == {"run8.csv", "run9.csv"}
    # the same campaign in this process gives the same parameters
    ref = run_batch(camp, tmp_path / "ref")
    assert ref["ran"] == s["ran"]
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "ref" / "parameters.parquet"), par)
    # nothing changed: a second run does nothing
    again = run_batch(camp, out, client=client, progress=False)
    assert again["ran"] == [] and len(again["skipped"]) == 5
    assert again["logs_ok"] == 49 and again["parameters"] == s["parameters"]
    # one log changed: only its group runs again
    _write_log(tmp_path / "boat1" / "run0.csv", 0.35, 12, seed=99)
    assert run_batch(camp, out, client=client, progress=False)["ran"] == ["boat1"]


def test_batch_campaign_errors(tmp_path, capsys):
    camp = tmp_path / "c.yaml"
    camp.write_text("groups:\n  - name: a\n    logs: ['*.csv']\n    spec: s.yaml\n"
                    "    kinds: [nomoto9]\n")
    assert main(["batch", str(camp), "--out", str(tmp_path / "o")]) == 2
    assert "groups[0].kinds: unknown kind 'nomoto9'" in capsys.readouterr().err
    camp.write_text("groups:\n  - name: a\n    logs: ['*.csv']\n    kinds: [nomoto1]\n")
    assert main(["batch", str(camp), "--out", str(tmp_path / "o")]) == 2
    assert "groups[0] (a): 'spec' is missing" in capsys.readouterr().err


def test_batch_on_real_hsva_logs_with_a_corrupt_copy(hsva_dir, tmp_path):
    # six shared HSVA KVLCC2 zig-zags (one held out) and, beside them in tmp_path, a corrupt
    # copy of one (its header lines, then binary junk: a transfer cut short); in this process,
    # the Dask path being the same run_group (test above)
    src = hsva_dir / "HSVA_CPMC_KVLCC2_Z_10_05.dat"
    head = b"".join(src.read_bytes().splitlines(keepends=True)[:4])
    bad = tmp_path / "HSVA_CPMC_KVLCC2_Z_10_05_copy.dat"
    bad.write_bytes(head + bytes(range(256)) * 8)
    camp = tmp_path / "campaign.yaml"
    camp.write_text(yaml.safe_dump({"groups": [{
        "name": "kvlcc2", "logs": [str(hsva_dir / "HSVA_CPMC_KVLCC2_Z_1*.dat"), bad.name],
        "spec": "hsva_kvlcc2", "kinds": ["nomoto1"],
        "holdout": [str(hsva_dir / "HSVA_CPMC_KVLCC2_Z_10_10_S.dat")]}]}))
    s = run_batch(camp, tmp_path / "out", progress=False)
    assert s["logs"] == 7 and s["logs_ok"] == 6
    assert [e["log"] for e in s["errors"]] == [str(bad)]
    par = pd.read_parquet(tmp_path / "out" / "parameters.parquet").set_index("parameter")
    # KVLCC2 model (Lpp 7 m, 1.18 m/s): K ~ 0.19 1/s and T ~ 11 s from all 11 training logs;
    # these 5 give the same within 25 % (a broad check that real logs are read and fitted)
    # K and T of a Nomoto fit depend on the rudder amplitude of the runs (these 10-15 deg
    # zig-zags: K 0.30 1/s, T 18 s; all 11 training logs of the set: K 0.19 1/s, T 11.4 s), but
    # K/T, the initial yaw acceleration per radian of rudder (N_delta / (I_z - N_rdot)), is a
    # linear-range constant: 0.0165 1/s^2 from all 11; 15 % is ~5 of its standard errors here
    K, T = par.loc["K", "value"], par.loc["T", "value"]
    assert K / T == pytest.approx(0.0165, rel=0.15)
    val = pd.read_parquet(tmp_path / "out" / "validation.parquet")
    r2 = val[(val["channel"] == "psi") & (val["metric"] == "r2")]["value"]
    assert len(r2) == 1 and r2.iloc[0] > 0.9  # the held-out zig-zag is predicted (0.95)
    # nothing changed: the command does nothing, and starts or reaches no cluster for it (no
    # scheduler listens at port 9)
    again = batch(camp, tmp_path / "out", scheduler="tcp://127.0.0.1:9", progress=False)
    assert again["ran"] == [] and again["logs_ok"] == 6 and len(again["errors"]) == 1


def test_course_keeping_with_disturbance_on_dask_equals_in_process(client, tmp_path):
    # run i's disturbance is drawn from the stream (seed, i): the same noise, hence the same
    # results, on 2 workers in chunks of 64 as in this process in one chunk
    path, d = _model_file(tmp_path)
    opts = {"t_end": 60.0, "target_deg": 0.0, "disturbance_deg": 2.0}  # keep the course
    out = tmp_path / "ck.parquet"
    s = montecarlo(path, "course-keeping", 200, out, vary=["K=normal:0.2,0.01"], seed=3,
                   options=opts, chunk=64, client=client, progress=False)
    assert s["chunks"] == 4 and s["disturbance_deg"] == 2.0
    got = pd.read_parquet(out)
    mc = MonteCarlo(d, "course-keeping", opts, vary=(Vary("K", "normal", 0.2, 0.01),), seed=3)
    pd.testing.assert_frame_equal(got, run_montecarlo(mc, 200, chunk=200))  # identical
    # the disturbance acts: in calm water the ship starting on course stays on it (IAE 0), in
    # the disturbance it wanders off and is steered back (IAE > 0) in every run
    calm = run_montecarlo(MonteCarlo(d, "course-keeping", {**opts, "disturbance_deg": 0.0},
                                     vary=mc.vary, seed=3), 200, chunk=200)
    assert (calm["K"] == got["K"]).all() and (calm["iae"] == 0).all()
    assert (got["iae"] > 0).all() and (got["max_rudder_deg"] > 0).all()
    # another seed: other noise, other results (the same parameters would need the same seed)
    other = run_montecarlo(dataclasses.replace(mc, seed=4), 8, chunk=8)
    assert not np.allclose(other["iae"], got["iae"][:8])


def test_local_cluster_has_no_http_server(client):
    """Dask's scheduler serves HTTP on port 8787 even without a dashboard: usvid's local cluster
    serves none (scheduler and workers), and everything it listens on is 127.0.0.1."""
    psutil = pytest.importorskip("psutil")
    assert client.cluster.scheduler.services == {}
    assert set(client.run(lambda dask_worker: len(dask_worker.services)).values()) == {0}
    me = psutil.Process()
    listening = [c.laddr for p in [me, *me.children(recursive=True)]
                 for c in p.net_connections(kind="inet") if c.status == psutil.CONN_LISTEN]
    assert listening and all(a.ip == "127.0.0.1" and a.port != 8787 for a in listening)


def test_worker_error_is_one_line(client, capfd):
    # a task's own error comes back as one line naming the task; Dask prints nothing
    with pytest.raises(TaskFailed, match=r"^mc task 2 of 2 failed on a worker: "
                                         r"ZeroDivisionError: division by zero$"):
        map_ordered(client, operator.truediv, [(1, 2), (1, 0)], progress=False, label="mc")
    assert "distributed" not in capfd.readouterr().err


def test_montecarlo_in_process_path_equals_dask(client, tmp_path):
    """On this small machine (<= 8 cores) with no scheduler and no more workers than cores,
    montecarlo runs in process on the kernel's threads: the same rows as on the cluster."""
    path, _ = _model_file(tmp_path)
    opts = {"t_end": 60.0}
    a = montecarlo(path, "turning", 300, tmp_path / "a.parquet", vary=["K=normal:0.2,0.01"],
                   seed=2, options=opts, chunk=128, progress=False)
    b = montecarlo(path, "turning", 300, tmp_path / "b.parquet", vary=["K=normal:0.2,0.01"],
                   seed=2, options=opts, chunk=100, client=client, progress=False)
    assert a["backend"] == "in-process" and b["backend"] == "dask"
    assert a["workers"] == len(os.sched_getaffinity(0))
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "a.parquet"),
                                  pd.read_parquet(tmp_path / "b.parquet"))
    assert a["quantiles"] == b["quantiles"]


def test_which_path_montecarlo_takes():
    assert not use_dask(None, None, 2) and not use_dask(None, 2, 2) and not use_dask(None, 1, 8)
    assert use_dask("tcp://head:8786", None, 2)  # a remote scheduler
    assert use_dask(None, 3, 2)  # more workers than cores
    assert use_dask(None, None, 64)  # a large machine: one process per core


def test_scheduler_addresses():
    assert check_scheduler_address("tcp://head:8786") == "tcp://head:8786"
    assert check_scheduler_address("10.0.0.2:8786") == "tcp://10.0.0.2:8786"
    assert check_scheduler_address("tcp://[::1]:8786") == "tcp://[::1]:8786"
    for bad in ("garbage", "inproc://x", "tls://h:1", "ucx://h:1", "http://h:1", "ws://h:1",
                "tcp://h:0", "tcp://h:65536", "tcp://:8786", "tcp://h", "tcp://h:1/x",
                "tcp://-h:1", "tcp://[zz]:1", "tcp://h_h:1", "tcp://h:1:2", "x" * 10000):
        with pytest.raises(UsvidError, match="--scheduler"):
            check_scheduler_address(bad)


def test_sizes_are_bounded():
    vm = VesselModel(Nomoto1(K=0.2, T=5.0), servo=mu2018_servo(),
                     vessel=Vessel(length=7.0, speed=3.0))
    zz = MonteCarlo(model_to_dict(vm), "zigzag", {"t_end": 60.0},
                    vary=(Vary("K", "normal", 0.2, 0.01),))
    assert check_size(zz, 100, 4096) == 100 and check_size(zz, 10**6, 4096) == 4096
    with pytest.raises(UsvidError, match=f"--runs must be in 1..{MAX_RUNS}"):
        check_size(zz, 10**12, 4096)
    with pytest.raises(UsvidError, match=f"at most {MAX_TASKS}: give --chunk 1000 or more"):
        check_size(zz, 10**7, 1)
    # a turning chunk records x, y, psi, delta every 5 steps: 3600 s at 0.02 s is 36,001
    # records of 32 bytes a run, so CHUNK_BYTES (256 MiB) holds 233 runs of a chunk
    tc = dataclasses.replace(zz, manoeuvre="turning", options={"t_end": 3600.0})
    assert check_size(tc, 10**4, 4096) == CHUNK_BYTES // (32 * 36_002) == 233
    n, why = max_workers()
    assert 1 <= n <= 4 * len(os.sched_getaffinity(0)) and ("core" in why or "memory" in why)
