"""Validation: simulated zig-zag against usvid.sim, cross-validation, comparison of kinds, and the
real-data result on the HSVA KVLCC2 zig-zags (Mu et al. 2018 section 5.2 style: simulated versus
measured overshoots), all through the one validation of a held-out trial
(:func:`usvid.identify.validation.validate_trial`)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from usvid.identify.estimator import ModelEstimator, compare_kinds
from usvid.identify.validate import cross_validate, zigzag_response
from usvid.identify.validation import validate_trial
from usvid.manoeuvres.metrics import zigzag_metrics
from usvid.models import Nomoto1, Norrbin
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo
from usvid.sim import ZigZag
from usvid.sim.simulate import simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel

DEG = math.pi / 180


def test_zigzag_response_is_usvid_sim_with_the_rudder_rate():
    # zigzag_response is usvid.sim's ZigZag on the model, with ``rate`` replacing an ideal
    # servo's rate limit (was: a second simulator, agreeing within one step's 0.25 deg)
    dyn = Norrbin(K=0.5, T=3.0, n1=1.0, n3=2.0)
    rate = 5 * DEG
    mine = zigzag_response(VesselModel(dyn, vessel=Vessel(speed=3.0)), 20 * DEG, 20 * DEG,
                           rate=rate, t_end=120.0, h=0.02)
    model = VesselModel(dyn, servo=IdealServo(max_rate=rate), vessel=Vessel(speed=3.0))
    res = simulate(model, ZigZag(delta_amp=20 * DEG, psi_switch=20 * DEG), t_end=120.0, dt=0.02)
    for ch in ("psi", "r", "delta"):
        np.testing.assert_array_equal(mine[ch], res[ch][0])
    a = zigzag_metrics(mine["t"], mine["psi"], mine["delta"], psi_switch=20 * DEG,
                       t_execute=0.0)
    b = res.zigzag_metrics()[0]
    assert a.overshoot_deg[:3] == pytest.approx(b.overshoot_deg[:3], abs=1e-9)
    assert np.max(np.diff(mine["delta"])) == pytest.approx(rate * 0.02)  # the rate limit


@pytest.fixture(scope="module")
def virtual_set():
    dyn = Nomoto1(K=0.5, T=3.0)
    model = VesselModel(dyn, servo=IdealServo(max_rate=10 * DEG), vessel=Vessel(speed=3.0))
    amps = np.radians([10.0, 20.0, 15.0])
    res = simulate(model, ZigZag(delta_amp=amps, psi_switch=amps), t_end=150.0, dt=0.02)
    trials = [virtual_trial_uniform(res, SensorModel(), seed=4, i=i, rate_hz=10.0,
                                    name=f"zz{i}") for i in range(3)]
    truth = res.zigzag_metrics()
    for i, tr in enumerate(trials):
        tr.meta["truth_overshoot_deg"] = truth[i].overshoot_deg
    # a rudder angle and no command logged: the identified model gets an ideal servo at the
    # measured rudder rate (the truth's servo; a logged command would be fitted by a
    # second-order servo, which a rate-limited rudder is not)
    return [tr.with_data(tr.data.drop(columns=["delta_cmd"])) for tr in trials]


def test_cross_validation_leave_one_out(virtual_set):
    cv = cross_validate(virtual_set, "nomoto1", "ls")
    assert [f["held_out"] for f in cv["folds"]] == ["zz0", "zz1", "zz2"]
    for f in cv["folds"]:
        assert f["params"]["K"] == pytest.approx(0.5, rel=0.05)
    # held-out heading R^2 in 20 s windows: the model explains the unseen zig-zags
    assert cv["mean"]["psi"]["r2"] > 0.99


def test_compare_kinds_and_validation_of_a_held_out_trial(virtual_set):
    rows = compare_kinds(virtual_set[:2], ("nomoto1", "norrbin"), method="ls",
                         validate=virtual_set[2])
    assert [r["kind"] for r in rows] == ["nomoto1", "norrbin"]
    assert all(r["validation"]["psi"]["r2"] > 0.99 for r in rows)
    est = ModelEstimator("nomoto1", "ls").fit(virtual_set[:2])
    row = validate_trial(est.model_, virtual_set[2], psi_switch=15 * DEG, window_s=est.window_s)
    assert row.manoeuvre == "zigzag"
    # the identified model's zig-zag (its servo at the measured rudder rate, 9.9 deg/s; the
    # measured approach speed) reproduces the truth's first overshoot (13.40 deg) ...
    truth = virtual_set[2].meta["truth_overshoot_deg"]
    assert row.predicted["overshoot_deg"][0] == pytest.approx(truth[0], abs=0.2)
    # ... and the measured one within the compass noise (0.5 deg, smoothed over 2 s)
    assert abs(row.error["overshoot_deg"][0]) < 0.5
    # the windowed fit metrics of the held-out trial are the estimator's score of it
    sc = est.score(virtual_set[2])
    assert row.metrics["psi"]["rmse"] == pytest.approx(sc["psi"]["rmse"], rel=1e-9)


# --- real data: HSVA KVLCC2 (model scale 1:45.7, 1.18 m/s) --------------------------------------
TRAIN = ("10_05", "15_05", "20_05")
VALID = {"10_10_P": 9.7, "10_10_S": 9.7, "20_10_P": 12.0, "20_10_S": 11.7}


def _hsva(hsva_dir, name):
    from usvid.io import read_trial

    return read_trial(hsva_dir / f"HSVA_CPMC_KVLCC2_Z_{name}.dat", "hsva_kvlcc2")


@pytest.fixture(scope="module")
def kvlcc2(hsva_dir):
    train = [_hsva(hsva_dir, n) for n in TRAIN]
    valid = {n: _hsva(hsva_dir, n) for n in VALID}
    return train, valid


# Output error with 35 s windows, 50 % overlap (windows of about 1-2 yaw time constants; the fit
# is sensitive to the window length on this near-critically stable ship, see the report)
KV_OPTS = {"window_s": 35.0, "overlap": 0.5}


def test_kvlcc2_measured_overshoots_match_published(kvlcc2):
    est = ModelEstimator("nomoto1", "ls").fit(kvlcc2[0])
    for name, want in VALID.items():
        row = validate_trial(est.model_, kvlcc2[1][name], replay=False)
        # published first overshoots (SIMMAN 2008): 9.7 deg for 10/10, 12.0 / 11.7 for 20/10 P/S
        assert row.measured["overshoot_deg"][0] == pytest.approx(want, abs=0.1)


@pytest.fixture(scope="module")
def kvlcc2_norrbin(kvlcc2):
    """The norrbin output-error fit on the training zig-zags and the warnings it gave (fitted
    once for the two tests that read it)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est = ModelEstimator("norrbin", "oe", **KV_OPTS).fit(kvlcc2[0])
    return est, caught


def test_kvlcc2_norrbin_first_overshoot_within_1p5_deg(kvlcc2, kvlcc2_norrbin):
    train, valid = kvlcc2
    from usvid.identify.series import IdentificationWarning

    # K, T and n3 are correlated on these three zig-zags (K 0.56 +- 0.45, T 39 +- 31 s): the fit
    # says so rather than reporting them as sharp
    est, caught = kvlcc2_norrbin
    assert any(issubclass(w.category, IdentificationWarning)
               and "poorly determined" in str(w.message) for w in caught), \
        [str(w.message) for w in caught]
    # course-unstable: n1 = -1 (the linear yaw damping is negative), held by the cubic
    assert est.params_["n1"] == -1.0 and est.params_["n3"] > 0
    for name in VALID:
        err = validate_trial(est.model_, valid[name], replay=False).error["overshoot_deg"]
        # task acceptance: first overshoot within 1.5 deg of the measured one
        assert abs(err[0]) < 1.5, (name, err)


def test_kvlcc2_norrbin_is_best_kind(kvlcc2, kvlcc2_norrbin):
    train, valid = kvlcc2
    err = {}
    for kind in ("nomoto1", "nomoto2", "norrbin"):
        est = (kvlcc2_norrbin[0] if kind == "norrbin"  # the same fit: shared
               else ModelEstimator(kind, "oe", **KV_OPTS).fit(train))
        err[kind] = np.mean([abs(validate_trial(est.model_, v, replay=False)
                                 .error["overshoot_deg"][0]) for v in valid.values()])
    assert err["norrbin"] < err["nomoto1"] and err["norrbin"] < err["nomoto2"]
