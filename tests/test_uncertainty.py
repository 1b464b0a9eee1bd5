"""The one reader and sampler of a model's stored uncertainty (:mod:`usvid.models.uncertainty`):
block-seeded draws independent of the chunking, the bounds policy (redrawn, else failed, never an
error that stops the other runs), the model file's covariance and std_errors blocks validated
(a list, a string, ragged, the wrong shape, an unknown parameter, a negative standard error:
one line naming the entry), and ``usvid montecarlo`` on them."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from usvid.cli import main
from usvid.errors import ModelFileError, UsvidError
from usvid.io.modelfile import model_from_dict, model_to_dict
from usvid.models import IdealServo, Nomoto1, Norrbin, VesselModel
from usvid.models.uncertainty import BLOCK, MAX_REDRAWS, Distribution, Uncertainty, lane_errors
from usvid.trial import Vessel


def _model(ident=None, **params):
    p = {"K": 0.3, "T": 20.0, "n1": 1.0, "n3": 10.0, **params}
    return VesselModel(Norrbin(**p), IdealServo(max_rate=math.radians(10)),
                       Vessel(length=7.0, speed=1.2), identification=ident)


COV = {"names": ["K", "T"], "matrix": [[1e-4, 0.027], [0.027, 100.0]]}


def test_draws_do_not_depend_on_the_range_asked_for():
    unc = Uncertainty.from_model(_model({"covariance": COV}))
    assert unc.source == "covariance" and unc.names == ("K", "T")
    whole = unc.sample(0, 3000, seed=7)
    parts = [unc.sample(lo, min(lo + 700, 3000), seed=7) for lo in range(0, 3000, 700)]
    for n in ("K", "T"):
        np.testing.assert_array_equal(whole.values[n],
                                      np.concatenate([p.values[n] for p in parts]))
    np.testing.assert_array_equal(whole.redraws, np.concatenate([p.redraws for p in parts]))
    # the covariance: correlation 0.027 / (0.01 * 10) = 0.27 (3000 draws, std error ~0.017;
    # the draws redrawn inside T > 0 (T = 20 +- 10: 2.3 %) shift it a little)
    assert np.corrcoef(whole.values["K"], whole.values["T"])[0, 1] == pytest.approx(0.27,
                                                                                  abs=0.06)
    assert unc.sample(0, 5, seed=8).values["K"][0] != whole.values["K"][0]


def test_bounds_policy_redraws_then_fails_a_run_never_the_batch():
    # T = 20 +- 10 s: P(T <= 0) = Phi(-2) = 2.28 %; every such draw is drawn again
    unc = Uncertainty.from_model(_model({"std_errors": {"T": 10.0}}))
    s = unc.sample(0, 4 * BLOCK, seed=1)
    assert np.all(s.values["T"] > 0) and s.n_failed == 0
    frac = s.redrawn / (4 * BLOCK)
    assert frac == pytest.approx(0.0228, abs=0.008)  # binomial std 0.0023: 3.5 sigma
    # T = 1 +- 1000 s: half the draws are out of bounds; after MAX_REDRAWS the chance a run is
    # still out is 0.5^(MAX_REDRAWS + 1): none fails. T = -5 +- 1e-3 can never be drawn in
    # bounds: every run fails, none raises, and usable() gives the nominal set
    dyn = _model().dynamics
    bad = Uncertainty(("T",), np.array([-5.0]), np.array([[1e-6]]), "given",
                      specs={p.name: p for p in type(dyn).param_specs()})
    s = bad.sample(0, 10, seed=0)
    assert s.n_failed == 10 and np.all(s.redraws == MAX_REDRAWS)
    assert np.all(s.usable()["T"] == -5.0)  # the means; the caller gives valid ones
    assert np.all(s.usable({"T": 20.0})["T"] == 20.0)


def test_independent_distributions_and_their_checks():
    unc = Uncertainty.from_model(_model()).with_vary([Distribution("K", "uniform", 0.1, 0.2)])
    s = unc.sample(0, 1000, seed=2)
    assert unc.parameters == ("K",) and 0.1 <= s.values["K"].min() < s.values["K"].max() <= 0.2
    with pytest.raises(UsvidError, match="--vary Q: not a parameter"):
        Uncertainty.from_model(_model()).with_vary([Distribution("Q", "normal", 0, 1)])
    with pytest.raises(UsvidError, match="SD >= 0"):
        Distribution("K", "normal", 0.0, -1.0)


def test_assumed_relative_uncertainty_completes_the_stored_one():
    unc = Uncertainty.from_model(_model({"std_errors": {"K": 0.01}}), rel=0.1)
    d = unc.to_dict()["parameters"]
    assert d["K"] == {"value": 0.3, "std": pytest.approx(0.01), "source": "std_errors"}
    assert d["T"]["source"] == "assumed" and d["T"]["std"] == pytest.approx(2.0)


def test_lane_errors_name_the_lane():
    dyn = Nomoto1(K=0.3, T=5.0)
    assert lane_errors(dyn, {"T": np.array([5.0, 6.0])}) == {}
    errs = lane_errors(dyn, {"T": np.array([5.0, -1.0, 6.0])})
    assert list(errs) == [1] and "T must be > 0 (got -1.0)" in errs[1]
    # a batch's own check names the first offending lane, not the first three values
    with pytest.raises(UsvidError, match=r"T must be > 0 \(got -1.0 in lane 3 of 4\)"):
        dyn.replace(T=np.array([5.0, 6.0, 7.0, -1.0]))


BASE = model_to_dict(_model({"std_errors": {"K": 0.01, "T": 1.0}, "covariance": COV}))


@pytest.mark.parametrize("block,value,needle", [
    ("covariance", [1, 2], "identification.covariance must be an object (got [1, 2])"),
    ("covariance", "abc", 'identification.covariance must be an object (got "abc")'),
    ("covariance", {"names": ["K", "T"], "matrix": [[1e-4, 0.0], [0.0]]},
     "identification.covariance.matrix[1] must be a row of 2 numbers (got 1 number)"),
    ("covariance", {"names": ["K", "T"], "matrix": [[1e-4]]},
     "identification.covariance.matrix must be a list of 2 rows, one per name (got 1 rows)"),
    ("covariance", {"names": ["K", "Q"], "matrix": [[1e-4, 0.0], [0.0, 1.0]]},
     "identification.covariance.names[1] = 'Q' is not a parameter of the model"),
    ("covariance", {"names": ["K", "T"], "matrix": [[1e-4, 0.1], [0.0, 1.0]]},
     "identification.covariance.matrix is not symmetric: [0][1] = 0.1 but [1][0] = 0"),
    ("covariance", {"names": ["K", "T"], "matrix": [[1.0, 2.0], [2.0, 1.0]]},
     "is not positive semi-definite"),
    ("std_errors", [0.1], "identification.std_errors must be an object (got [0.1])"),
    ("std_errors", "x", 'identification.std_errors must be an object (got "x")'),
    ("std_errors", {"K": -0.1}, "identification.std_errors.K must be >= 0 (got -0.1)"),
    ("std_errors", {"Q": 0.1}, "identification.std_errors.Q: not a parameter of kind 'norrbin'"),
])
def test_model_file_uncertainty_blocks_are_validated(block, value, needle):
    d = copy.deepcopy(BASE)
    d["identification"][block] = value
    if block == "std_errors":
        del d["identification"]["covariance"]
    with pytest.raises(ModelFileError) as err:
        model_from_dict(d, "m.json")
    assert str(err.value).startswith("m.json: ") and needle in str(err.value)
    assert "\n" not in str(err.value)


def test_montecarlo_on_bad_uncertainty_blocks_is_one_line(tmp_path, capsys):
    for block, value in (("covariance", {"names": ["K"], "matrix": [[1e-4, 0], [0, 1]]}),
                         ("std_errors", {"T": -1.0})):
        d = copy.deepcopy(BASE)
        d["identification"][block] = value
        if block == "std_errors":
            del d["identification"]["covariance"]
        path = tmp_path / "m.json"
        path.write_text(json.dumps(d))
        code = main(["montecarlo", str(path), "--manoeuvre", "zigzag", "--runs", "10",
                     "--from-uncertainty", "--out", str(tmp_path / "o.parquet")])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and err.startswith("usvid: error: m.json:")
    assert not (tmp_path / "o.parquet").exists()


def test_montecarlo_redraws_out_of_bounds_draws_and_reports_them():
    # T = 20 +- 10 s: 2.3 % of the draws fall at T <= 0 (the issue: one such draw aborted its
    # whole 4096-run chunk with "parameters.T must be > 0 (got [29.01 29.65 38.36])")
    from usvid.scale.montecarlo import MonteCarlo, run_montecarlo

    unc = Uncertainty.from_model(_model({"std_errors": {"T": 10.0}}))
    mc = MonteCarlo(model_to_dict(_model()), "zigzag", {"t_end": 60.0}, unc.names, unc.mean,
                    unc.cov, seed=4)
    df = run_montecarlo(mc, 2000, chunk=700)
    assert list(df["run"]) == list(range(2000)) and df["valid_draw"].all()
    assert 20 < int((df["redraws"] > 0).sum()) < 80 and (df["T"] > 0).all()
    assert df["success"].all()
    # a draw that is no valid model at all is a failed run, not a failed chunk
    bad = MonteCarlo(model_to_dict(_model()), "zigzag", {"t_end": 20.0}, ("T",),
                     np.array([-5.0]), np.array([[1e-6]]), seed=4)
    df = run_montecarlo(bad, 10, chunk=10)
    assert not df["valid_draw"].any() and not df["success"].any()
    assert df["overshoot_1_deg"].isna().all()
