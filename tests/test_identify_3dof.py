"""3-DOF (Mu et al. 2018 eq. 37) and twin-thruster catamaran (the catamaran paper) identification:
recovery of the Fossen masses and dampings and of their regression coefficients on noisy virtual
trials (servo
dead time, disturbance, seeded)."""

from __future__ import annotations

import numpy as np
import pytest

from usvid.identify.estimator import ModelEstimator
from usvid.models import Catamaran, ThreeDOF
from usvid.models.kinds._fossen import regression_coefficients
from usvid.models.model import VesselModel
from usvid.models.servo import SecondOrderServo
from usvid.models.thrust import PodThrust
from usvid.sim import Commanded, Disturbance, ZigZag
from usvid.sim.simulate import simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel

# speed sensor noise 0.02 m/s (GNSS Doppler class), other sensors at SensorModel defaults
SENSORS = SensorModel(speed_sigma_m_s=0.02)
FOSSEN = ("m11", "m22", "m33", "d11", "d22", "d33")


def _check_recovery(est: ModelEstimator, dyn, rel: float) -> None:
    """The identified Fossen parameters (the model file's) and the regression coefficients they
    imply (Mu et al. 2018 eq. 37), each within ``rel`` of the truth."""
    truth = {k: getattr(dyn, k) for k in FOSSEN}
    assert set(est.params_) == set(FOSSEN)
    for k, v in truth.items():
        assert est.params_[k] == pytest.approx(v, rel=rel), k
    implied = regression_coefficients(est.params_)
    for k, v in regression_coefficients(truth).items():
        assert implied[k] == pytest.approx(v, rel=rel), k


@pytest.fixture(scope="module")
def threedof_case():
    # a small vector-thruster USV with a sway motion large enough to be measured (|v| ~ 0.7 m/s);
    # the Lanxin model of Mu et al. 2018 has |v| < 1 cm/s, below any speed sensor's noise
    dyn = ThreeDOF(m11=120.0, m22=180.0, m33=60.0, d11=30.0, d22=90.0, d33=50.0, x_l=1.0,
                   thrust=60.0)
    model = VesselModel(dyn, servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5),
                        vessel=Vessel(length=2.0))
    # two zig-zags started below the steady speed so the surge equation is excited too
    res = simulate(model, ZigZag(delta_amp=np.radians([30, 20]), psi_switch=np.radians([10, 20])),
                   t_end=200.0, dt=0.02, u0=np.array([0.5, 1.0]),
                   disturbance=Disturbance(0.0005, seed=np.arange(2)))
    trials = []
    for i in range(2):
        tr = virtual_trial_uniform(res, SENSORS, seed=1, i=i, rate_hz=10.0)
        tr.data["thrust"] = 60.0  # the logged thrust [N] (constant here)
        trials.append(tr)
    return dyn, trials


@pytest.mark.parametrize("method", ["ls", "oe"])
def test_threedof_recovery_within_10_percent(threedof_case, method):
    dyn, trials = threedof_case
    # the logged thrust gives the forces; the model file needs the thrust law (a constant 60 N)
    est = ModelEstimator("threedof", method, x_l=1.0, thrust=60.0).fit(trials)
    _check_recovery(est, dyn, 0.10)  # task: within 10 %
    # the model file holds the Fossen parameters of Mu et al. 2018 eq. 13-17 and the thrust law
    p = est.to_dict()["parameters"]
    assert p["m11"] == pytest.approx(120.0, rel=0.10)
    assert p["d33"] == pytest.approx(50.0, rel=0.10)
    assert p["thrust"] == 60.0 and p["x_l"] == 1.0


def test_threedof_from_shaft_speed_and_thrust_model(threedof_case):
    dyn, trials = threedof_case
    tr = trials[0]
    data = tr.data.drop(columns=["thrust"]).copy()
    data["n"] = 10.0  # [rps]; a pod thrust law T = 0.6 |n| n gives the same 60 N
    est = ModelEstimator("threedof", "ls", x_l=1.0,
                         thrust=PodThrust(c=0.0, d=0.6)).fit(tr.with_data(data))
    assert est.params_["m33"] == pytest.approx(dyn.m33, rel=0.10)  # 1 / c_tau
    assert est.model_.dynamics.n == pytest.approx(10.0)  # the nominal shaft speed: the log's


@pytest.fixture(scope="module")
def catamaran_case():
    cat = Catamaran(m11=80.0, m22=120.0, m33=30.0, d11=25.0, d22=70.0, d33=40.0, b=0.8,
                    thrust=0.5)
    t = np.arange(0.0, 300.01, 0.1)
    rng = np.random.default_rng(0)
    seg = (t // 15).astype(int)  # commands held 15 s: steady runs and differential turns
    lev = rng.uniform(20, 100, seg.max() + 1)
    dif = rng.uniform(-40, 40, seg.max() + 1)
    dif[::3] = 0.0  # every third segment a straight run (the catamaran paper: speed/thrust runs)
    res = simulate(VesselModel(cat, vessel=Vessel(length=1.5)),
                   Commanded(t=t, n_port=lev[seg] + dif[seg], n_stbd=lev[seg] - dif[seg]),
                   t_end=300.0, dt=0.02, u0=0.0)
    trial = virtual_trial_uniform(res, SENSORS, seed=2, rate_hz=10.0)
    return cat, trial, (lev, dif)


@pytest.mark.parametrize("method", ["ls", "oe"])
def test_catamaran_recovery_within_10_percent(catamaran_case, method):
    cat, trial, _ = catamaran_case
    est = ModelEstimator("catamaran", method, thrust=0.5,
                         particulars={"thruster_spacing": 0.8}).fit(trial)
    _check_recovery(est, cat, 0.10)  # task: within 10 %
    p = est.to_dict()["parameters"]
    assert p["m11"] == pytest.approx(80.0, rel=0.10)
    assert p["d11"] == pytest.approx(25.0, rel=0.10)
    assert p["b"] == pytest.approx(0.8)
    assert p["thrust"] == 0.5


def test_catamaran_steady_runs_give_d11(catamaran_case):
    # the catamaran paper: on steady straight runs d11 u = tau_u; the commands are held 15 s,
    # the surge time constant m11/d11 = 3.2 s, so the last 5 s after a 10 s settling are steady
    # within ~4 %. (This model keeps turning on some runs of equal thrust: straight runs are those
    # with
    # |r| < 3 deg/s.) The identified d11 agrees with the steady runs' (was: a "steady_runs"
    # diagnostic of the estimator, no longer computed, compared with -a_u/a_tau)
    _, trial, (lev, dif) = catamaran_case
    est = ModelEstimator("catamaran", "ls", thrust=0.5,
                         particulars={"thruster_spacing": 0.8}).fit(trial)
    t, u, r = trial.t, trial["u"], trial["r"]
    us, taus = [], []
    for k in range(len(lev)):
        sel = (t >= 15 * k + 10) & (t < 15 * k + 15)
        if dif[k] == 0.0 and sel.sum() > 40 and abs(np.nanmean(r[sel])) < np.radians(3.0):
            us.append(np.nanmean(u[sel]))
            taus.append(2 * 0.5 * lev[k])  # tau_u = T_port + T_stbd [N]
    us, taus = np.array(us), np.array(taus)
    assert len(us) >= 2
    d11_runs = float(us @ taus / (us @ us))  # slope of tau_u over u through the origin
    assert d11_runs == pytest.approx(25.0, rel=0.10)
    assert est.params_["d11"] == pytest.approx(d11_runs, rel=0.10)
