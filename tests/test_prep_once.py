"""One road through the chain: every command prepares each log once and every later stage
(estimator, validation, report) uses that prepared trial.

Counted here: the series builds (:func:`usvid.identify.series.build_series`), the heading-glitch
repairs of a trial (:func:`usvid.prep.glitches.repair_trial_heading`) and the manoeuvre
segmentations (:func:`usvid.manoeuvres.detect.segment_trial`) of one command. Before the
prepared trial, one ``identify --validate --report`` of 3 training and 2 held-out HSVA logs built
15 series, repaired 12 headings and segmented 7 times (5 logs); now 5 of each.
"""

from __future__ import annotations

import collections
import math
import sys

import numpy as np
import pandas as pd
import pytest

import usvid.identify.series as series_mod
import usvid.manoeuvres.detect as detect_mod
import usvid.prep.glitches as glitches_mod
from usvid.cli import main
from usvid.io.modelfile import save_model
from usvid.io.writers import write_csv
from usvid.models import IdealServo, Nomoto1, VesselModel
from usvid.prep import PreparedTrial, as_prepared, prepare
from usvid.sim import Turning, ZigZag, simulate
from usvid.trial import Trial, Vessel

K, T, U, L = 0.3, 5.0, 2.0, 6.0  # Nomoto gain [1/s], time constant [s], speed [m/s], length [m]


def _model() -> VesselModel:
    return VesselModel(Nomoto1(K=K, T=T), servo=IdealServo(math.radians(35), math.radians(10)),
                       vessel=Vessel(length=L, speed=U))


def _log(path, logic, t_end, seed):
    res = simulate(_model(), logic, t_end=t_end, dt=0.01, u0=U,
                   channels=("x", "y", "psi", "r", "delta", "U"))
    tr = res.to_trial(0, name=path.stem)
    data = tr.data.iloc[::10].reset_index(drop=True)
    rng = np.random.default_rng(seed)
    data["psi"] += rng.normal(0, math.radians(0.05), len(data))
    tr = tr.with_data(data)
    spec = path.with_suffix(".yaml")
    write_csv(tr, path, spec_path=spec)
    return spec


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("once")
    model = d / "truth.json"
    save_model(_model(), model)
    zz, tc = d / "zz.csv", d / "tc.csv"
    spec = _log(zz, ZigZag(math.radians(20), math.radians(20), t_start=5.0), 100.0, 0)
    _log(tc, Turning(math.radians(-25), t_start=5.0), 80.0, 1)
    return {"model": model, "zz": zz, "tc": tc, "spec": spec, "dir": d}


@pytest.fixture
def counts(monkeypatch):
    """Calls of the series builder, the heading repair and the segmentation, wherever a module
    imported them."""
    n: collections.Counter = collections.Counter()
    for mod, name in ((series_mod, "build_series"), (glitches_mod, "repair_trial_heading"),
                      (detect_mod, "segment_trial")):
        f = getattr(mod, name)

        def counted(*a, _f=f, _name=name, **k):
            n[_name] += 1
            return _f(*a, **k)

        for m in list(sys.modules.values()):
            if getattr(m, "__name__", "").startswith("usvid") and getattr(m, name, None) is f:
                monkeypatch.setattr(m, name, counted)
    return n


def test_identify_validate_report_prepares_each_log_once(logs, counts, tmp_path, capsys):
    code = main([str(a) for a in ("identify", logs["zz"], "--format", logs["spec"], "--model",
                                  "nomoto1", "--method", "ls", "--validate", logs["tc"],
                                  "--out", tmp_path / "m.json", "--report", tmp_path / "rep",
                                  "--json")])
    assert code == 0, capsys.readouterr().err
    # two logs (one training, one held out): one of each per log, for the fit, the validation
    # of both (identify --validate, the report's training section) and the prediction bands
    assert counts == {"build_series": 2, "repair_trial_heading": 2, "segment_trial": 2}


def test_validate_report_prepares_each_log_once(logs, counts, tmp_path, capsys):
    code = main([str(a) for a in ("validate", logs["model"], logs["zz"], logs["tc"],
                                  "--format", logs["spec"], "--report", tmp_path / "rep",
                                  "--json")])
    assert code == 0, capsys.readouterr().err
    assert counts == {"build_series": 2, "repair_trial_heading": 2, "segment_trial": 2}


def test_prepared_trial_passes_through_and_remembers():
    t = np.arange(0.0, 60.0, 0.1)
    psi = 0.01 * t
    psi[100] += math.radians(5.0)  # one compass glitch
    tr = Trial(pd.DataFrame({"t": t, "psi": psi, "delta": np.zeros_like(t)}), name="g")
    p = prepare(tr, derivatives=False)
    assert isinstance(p, PreparedTrial) and p.heading_glitches == 1
    # repaired at the compass's own sample: the heading there is its neighbours' midpoint
    assert p["psi"][100] == pytest.approx(0.01 * t[100], abs=1e-12)
    assert as_prepared(p) is p and prepare(p, derivatives=False) is p
    assert p.remember("k", lambda: [1]) is p.remember("k", lambda: [2])
    # a part of a prepared trial is prepared, with nothing remembered from the whole
    part = p.slice_time(10.0, 20.0)
    assert isinstance(part, PreparedTrial) and part.memo == {}
    assert "r" in p.derived  # the yaw rate differentiated from the heading, said so


def test_gaps_of_a_single_rate_log_are_counted():
    t = np.arange(0.0, 30.0, 0.1)
    r = np.sin(t)
    r[[50, 51, 200]] = np.nan
    p = prepare(Trial(pd.DataFrame({"t": t, "r": r})), derivatives=False)
    assert p.filled == {"r": 3} and p.resampled_hz is None
    assert np.isfinite(p["r"]).all()
