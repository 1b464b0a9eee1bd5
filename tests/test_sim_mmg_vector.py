"""The MMG kind on the core's vector step (its right-hand side inlined, one vector step per
variant: rudder, pod, twin) equals the per-lane reference path, for a batch of more lanes than a
chunk and for a single run (a chunk of one lane: the vector step computes one vector of lanes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from test_sim_simd import _both  # the SIMD vs per-lane pair of runs, one definition
from usvid.models import SecondOrderServo, VesselModel
from usvid.models import mmg as _mmg
from usvid.models.kinds.mmg import equilibrium_rps, from_physics
from usvid.sim import Disturbance, ZigZag, core
from usvid.trial import Vessel

#: As tests/test_sim_simd.py: the two paths run the same arithmetic; the vector one inlines the
#: right-hand side (FMA contraction may differ in the last bit), 1e-16 per step growing over a
#: few hundred steps stays well below 1e-12 of a channel's scale.
RTOL = 1e-12
U0 = 1.179


def _model(variant: str) -> VesselModel:
    p = _mmg.kvlcc2("paper")
    if variant == "pod":
        p = p.replace(variant="pod", thrust_law="pod", pod_c=-2.0, pod_d=0.5)
    elif variant == "twin":
        p = p.replace(variant="twin", y_P=0.1)
    n = 10.0 if variant == "twin" else equilibrium_rps(p, U0)
    dyn = from_physics(p, n=n, **({"steer_gain": 8.0} if variant == "twin" else {}))
    servo = SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5, max_rate=math.radians(20.0))
    return VesselModel(dyn, servo=servo, vessel=Vessel(length=p.L, speed=U0))




def _assert_same(a, b) -> None:
    for name, x in a.channels.items():
        y = b.channels[name]
        scale = max(float(np.nanmax(np.abs(y))), 1e-3)
        np.testing.assert_allclose(x, y, rtol=0.0, atol=RTOL * scale, err_msg=name)
    for name, x in a.zigzag_online.items():
        np.testing.assert_allclose(x, b.zigzag_online[name], rtol=0.0, atol=1e-10,
                                   equal_nan=True, err_msg=name)
    assert (a.success, a.message) == (b.success, b.message)


@pytest.mark.parametrize("variant", ["rudder", "pod", "twin"])
def test_mmg_vector_step_equals_per_lane_path(variant):
    model = _model(variant)
    B = core.CH + 5  # a full chunk and a partial one (5 lanes: not a whole vector)
    amp = np.radians(np.linspace(10.0, 25.0, B))
    dist = Disturbance(intensity=np.where(np.arange(B) % 3 == 0, 0.0, math.radians(1.0)), seed=2)
    a, b = _both(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                 t_end=40.0, dt=0.05, disturbance=dist, psi0=np.linspace(-0.2, 0.2, B))
    _assert_same(a, b)
    # one run, calm water (the quiet steps on the vector step of one vector of lanes)
    a, b = _both(model, ZigZag(math.radians(20.0), math.radians(20.0)), t_end=60.0, dt=0.05)
    assert np.ptp(a["psi"][0]) > 0.05  # the run turned (not a trivial straight line)
    _assert_same(a, b)
