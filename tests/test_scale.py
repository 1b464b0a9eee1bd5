"""Scale-out on Dask: ``usvid montecarlo`` and ``usvid batch`` on a local 2-worker cluster give
the results of the in-process run (same seed), whatever the chunking."""

from __future__ import annotations

import json
import logging

import numpy as np
import pandas as pd
import pytest

from usvid.cli import main
from usvid.commands.montecarlo import montecarlo
from usvid.io.modelfile import model_to_dict
from usvid.models import Nomoto1, VesselModel, seed000_servo
from usvid.scale.montecarlo import MonteCarlo, Vary, run_montecarlo
from usvid.trial import Vessel

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    """One local cluster of 2 single-threaded worker processes for the module (start-up ~2 s)."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    cl = distributed.Client(cluster)
    yield cl
    cl.close()
    cluster.close()


def _model_file(tmp_path):
    vm = VesselModel(Nomoto1(K=0.2, T=5.0), servo=seed000_servo(),
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
