"""simulate(): argument checking, batching, decimation, SimResult conversions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.errors import SimulationError, UsvidError
from usvid.models import Nomoto1, SecondOrderServo, VesselModel
from usvid.sim import PID, Commanded, SimResult, Turning, ZigZag, run_turning, simulate
from usvid.trial import Trial, Vessel

M = VesselModel(Nomoto1(K=0.707, T=0.332), vessel=Vessel(length=7.02, speed=5.144))


def test_result_shape_and_channels():
    res = simulate(M, Turning(0.1), t_end=10.0, dt=0.02)
    assert isinstance(res, SimResult)
    assert res.t.shape == (501,)
    assert res.t[-1] == pytest.approx(10.0)
    assert set(res.channels) == {"x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd"}
    assert all(v.shape == (1, 501) for v in res.channels.values())
    assert res.batch_size == 1
    np.testing.assert_allclose(res["U"], 5.144)
    with pytest.raises(SimulationError, match="no channel 'n'"):
        res["n"]


def test_record_every_is_exact_decimation():
    full = simulate(M, ZigZag(0.17, 0.17), t_end=20.0)
    dec = simulate(M, ZigZag(0.17, 0.17), t_end=20.0, record_every=10, channels=["psi", "r"])
    assert set(dec.channels) == {"psi", "r"}
    np.testing.assert_array_equal(dec.t, full.t[::10])
    np.testing.assert_array_equal(dec["psi"], full["psi"][:, ::10])


def test_batch_equals_individual_runs():
    K = np.array([0.4, 0.707, 1.0])
    servo = SecondOrderServo(omega_n=np.array([1.0, 1.4, 2.0]), zeta=0.6, delay=0.2)
    batch = simulate(VesselModel(Nomoto1(K=K, T=0.5), servo=servo, vessel=M.vessel),
                     ZigZag(np.radians([10, 20, 15]), np.radians(10)), t_end=30.0)
    for i in range(3):
        one = simulate(VesselModel(Nomoto1(K=K[i], T=0.5),
                                   servo=SecondOrderServo(omega_n=[1.0, 1.4, 2.0][i], zeta=0.6,
                                                          delay=0.2), vessel=M.vessel),
                       ZigZag(math.radians([10, 20, 15][i]), math.radians(10)), t_end=30.0)
        np.testing.assert_array_equal(batch["psi"][i], one["psi"][0])


def test_commanded_per_run_series():
    t = np.array([0.0, 10.0])
    cmd = np.array([[0.1, 0.1], [-0.1, -0.1]])
    res = simulate(M, Commanded(t, delta_cmd=cmd), t_end=5.0)
    assert res.batch_size == 2
    np.testing.assert_allclose(res["psi"][0], -res["psi"][1], atol=1e-15)


def test_to_trial():
    res = simulate(M, Turning(0.1), t_end=5.0, psi0=np.array([0.0, 1.0]))
    tr = res.to_trial(1)
    assert isinstance(tr, Trial)
    assert tr.is_uniform and tr.sample_rate == pytest.approx(50.0)
    assert tr["psi"][0] == pytest.approx(1.0)
    assert tr.vessel.length == 7.02
    assert tr.meta["truth"] is M
    assert "delta" in tr.channels
    with pytest.raises(SimulationError, match="out of range"):
        res.to_trial(5)


def test_bad_arguments():
    with pytest.raises(SimulationError, match="dt"):
        simulate(M, Turning(0.1), t_end=5.0, dt=0.0)
    with pytest.raises(SimulationError, match="t_end"):
        simulate(M, Turning(0.1), t_end=-1.0)
    with pytest.raises(SimulationError, match="record_every"):
        simulate(M, Turning(0.1), t_end=5.0, record_every=0)
    with pytest.raises(SimulationError, match="unknown logic"):
        simulate(M, "zigzag", t_end=5.0)
    with pytest.raises(SimulationError, match="unknown channel"):
        simulate(M, Turning(0.1), t_end=5.0, channels=["psi", "heading"])
    with pytest.raises(SimulationError, match="incompatible"):
        simulate(VesselModel(Nomoto1(K=np.array([1.0, 2.0]), T=1.0), vessel=M.vessel),
                 Turning(np.array([0.1, 0.2, 0.3])), t_end=1.0)
    with pytest.raises(SimulationError, match="speed"):
        simulate(VesselModel(Nomoto1(K=1.0, T=1.0)), Turning(0.1), t_end=1.0)
    with pytest.raises(SimulationError, match="VesselModel"):
        simulate(Nomoto1(K=1.0, T=1.0), Turning(0.1), t_end=1.0)
    with pytest.raises(SimulationError, match="psi_switch"):
        ZigZag(0.1, 0.0)
    with pytest.raises(SimulationError, match="first"):
        ZigZag(0.1, 0.1, first=0)
    with pytest.raises(SimulationError, match="strictly increasing"):
        Commanded(np.array([0.0, 0.0]), delta_cmd=np.array([0.0, 1.0]))
    with pytest.raises(SimulationError, match="shape"):
        Commanded(np.array([0.0, 1.0]), delta_cmd=np.array([0.0, 1.0, 2.0]))
    with pytest.raises(SimulationError, match="controller"):
        from usvid.sim import CourseChange

        CourseChange(0.1, controller=(0.7, 0, 1))
    with pytest.raises(UsvidError):
        VesselModel("nomoto")
    assert isinstance(PID(0.7), PID)


def test_run_turning_default_duration_covers_a_whole_steady_circle():
    res, _ = run_turning(M, 35.0)
    turned = res["psi"][0, -1]
    assert turned >= 3 * math.pi


def test_initial_state():
    from usvid.models import Nomoto2, mu2018_threedof

    # steady turn from the start: r stays at K delta
    res = simulate(M, Turning(0.1), t_end=5.0, initial={"r": 0.0707, "delta": 0.1})
    np.testing.assert_allclose(res["r"][0], 0.0707, rtol=1e-12)
    m2 = VesselModel(Nomoto2(K=0.5, T1=3.0, T2=0.5), vessel=M.vessel)
    res = simulate(m2, Turning(0.1), t_end=5.0, initial={"r": 0.05, "delta": 0.1})
    np.testing.assert_allclose(res["r"][0], 0.05, rtol=1e-12)
    m3 = VesselModel(mu2018_threedof(thrust=3000.0))
    res = simulate(m3, Turning(0.0), t_end=1.0, initial={"v": np.array([0.1, -0.1])})
    assert res["v"][0, 0] == 0.1 and res["v"][1, 0] == -0.1
    with pytest.raises(SimulationError, match="initial"):
        simulate(M, Turning(0.1), t_end=1.0, initial={"u": 3.0})
    with pytest.raises(SimulationError, match="3-DOF"):
        simulate(M, Turning(0.1), t_end=1.0, initial={"v": 0.1})


@pytest.mark.parametrize("kw", [{"u0": math.nan}, {"psi0": math.inf},
                                {"initial": {"r": math.nan}}, {"channels": []}])
def test_simulate_rejects_non_finite_state_and_empty_channels(kw):
    m = VesselModel(Nomoto1(K=0.5, T=2.0), vessel=Vessel(speed=2.0))
    with pytest.raises(SimulationError):
        simulate(m, Turning(0.2), t_end=1.0, **kw)
