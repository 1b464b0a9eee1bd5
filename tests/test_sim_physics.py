"""The one probe of a model's physics under a rudder step (usvid.sim.physics), read by both
identification's model checks and the commands' physics check."""

from __future__ import annotations

import math

import pytest

from usvid.models import IdealServo, Nomoto1, Norrbin, VesselModel, mu2018_threedof
from usvid.sim.physics import TURN_DEG, turn_probe
from usvid.trial import Vessel

DELTA = math.radians(20.0)


def _nomoto(K: float, T: float = 5.0) -> VesselModel:
    return VesselModel(Nomoto1(K=K, T=T), IdealServo(), Vessel(length=6.0, speed=2.0))


def test_an_ordinary_vessel_turns_to_the_side_of_its_rudder():
    p = turn_probe(_nomoto(0.3), DELTA, 2.0, t_end=60.0, dt=0.05)
    assert not (p.wrong_side or p.astern or p.diverged)
    # hand value (ideal servo: the rudder steps at t = 0): psi(t) = K delta (t - T (1 -
    # exp(-t/T))); RK4 at dt/T = 0.01 is exact to ~1e-8 relative, so 1e-6
    k_d = 0.3 * DELTA
    assert p.turn == pytest.approx(k_d * (60.0 - 5.0 * (1.0 - math.exp(-12.0))), rel=1e-6)
    # the side is read when psi first exceeds TURN_DEG: psi ~ K delta t^2 / (2 T) = 1 deg at
    # t = 1.29 s, the next sample of the 0.05 s grid is 1.35 s
    assert p.side_turn > math.radians(TURN_DEG) and p.side_at == pytest.approx(1.35)


def test_a_negative_gain_turns_to_the_wrong_side_and_port_rudder_mirrors_it():
    p = turn_probe(_nomoto(-0.3), DELTA, 2.0, t_end=30.0, dt=0.05)
    assert p.wrong_side and p.side_turn < 0
    q = turn_probe(_nomoto(0.3), -DELTA, 2.0, t_end=30.0, dt=0.05)
    assert not q.wrong_side and q.side_turn < 0


def test_a_runaway_cubic_damping_diverges():
    bad = VesselModel(Norrbin(K=0.3, T=5.0, n1=1.0, n3=-500.0), IdealServo(),
                      Vessel(length=6.0, speed=2.0))
    p = turn_probe(bad, DELTA, 2.0, t_end=120.0, dt=0.05)
    assert p.diverged and p.diverged_at is not None and 0.0 < p.diverged_at < 120.0


def test_negative_thrust_goes_astern():
    m = VesselModel(mu2018_threedof(x_l=3.5, thrust=-2000.0), IdealServo(),
                    Vessel(length=7.02, speed=5.144))
    p = turn_probe(m, DELTA, 5.144, t_end=120.0, dt=0.05)
    # the speed falls from 5.144 m/s through zero to the astern balance -T/d11 (about -2.4 m/s;
    # the turn's sway and yaw coupling take some of it): astern, and backing reverses the turn
    assert p.astern and -2.4 < p.u_end < 0.0 and p.wrong_side
