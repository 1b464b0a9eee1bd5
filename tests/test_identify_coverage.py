"""Statistical acceptance: the reported 95 % intervals of the output-error fit cover the truth in at
least 90 of 100 seeded virtual repetitions (sensor noise, servo dead time, disturbance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.identify.estimator import ModelEstimator
from usvid.models import Nomoto1
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo, SecondOrderServo
from usvid.sim import Disturbance, ZigZag
from usvid.sim.simulate import simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel

B = 100


@pytest.mark.slow
def test_oe_ci95_coverage_100_repetitions():
    K, T = 0.5, 3.0
    model = VesselModel(Nomoto1(K=K, T=T, delta0=math.radians(0.5)),
                        servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5),
                        vessel=Vessel(length=7.0, speed=3.0))
    res = simulate(model, ZigZag(delta_amp=math.radians(20), psi_switch=math.radians(20)),
                   t_end=300.0, dt=0.02,
                   disturbance=Disturbance(intensity=0.001, seed=1000 + np.arange(B)))
    cover = np.zeros(2, int)
    for i in range(B):
        tr = virtual_trial_uniform(res, SensorModel(), seed=17, i=i, rate_hz=10.0)
        # the servo is not under test: "auto" would fit a second-order servo to every
        # repetition's logged order (through the core: 1.1 s of the 1.2 s of each fit)
        est = ModelEstimator("nomoto1", "oe", servo=IdealServo()).fit(tr)
        for j, (name, truth) in enumerate((("K", K), ("T", T))):
            lo, hi = est.ci95_[name]
            cover[j] += lo <= truth <= hi
        assert est.params_["K"] == pytest.approx(K, rel=0.05)
        assert est.params_["T"] == pytest.approx(T, rel=0.05)
    # task acceptance: at least 90 of 100 (a true 95 % interval fails this with p ~ 2 %)
    assert cover[0] >= 90, cover
    assert cover[1] >= 90, cover
