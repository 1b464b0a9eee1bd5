"""Compile the integration core for the named model kinds (``python tests/precompile.py KIND...``):
run by ``conftest.py`` before the test workers start, two processes side by side, so that each
kind's core is compiled once into the on-disk cache instead of once per worker: the per-lane
core and the variants of its vector step the suite uses most (``usvid.sim.core.vector_step``:
ideal and second-order servo, with and without a disturbance, x and y recorded or not)."""

from __future__ import annotations

import math
import sys
import warnings

from usvid.models import registry
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo, SecondOrderServo
from usvid.sim import Disturbance, ZigZag, simulate
from usvid.trial import Vessel


def main(names: list[str]) -> None:
    warnings.simplefilter("ignore")
    for name in names:
        dyn = registry.get(name).dynamics.example()
        runs = [(IdealServo(), None, None), (IdealServo(), 0.01, None),
                (IdealServo(), 0.01, ("psi", "r")),
                (SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.1), None, None),
                (SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.1), 0.01, None)]
        for servo, dist, channels in runs:
            model = VesselModel(dyn, servo=servo, vessel=Vessel(length=7.0, speed=1.0))
            try:  # an example parameter set may diverge: compiling is what counts
                simulate(model, ZigZag(math.radians(10), math.radians(10)), t_end=0.2, dt=0.05,
                         disturbance=None if dist is None else Disturbance(intensity=dist),
                         channels=channels)
            except Exception:  # noqa: BLE001 - the tests report real errors, not this warm-up
                pass


if __name__ == "__main__":
    main(sys.argv[1:])
