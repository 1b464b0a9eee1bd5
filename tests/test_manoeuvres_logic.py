"""usvid.manoeuvres.logic: validation of the manoeuvre descriptions the simulator runs."""

from __future__ import annotations

import numpy as np
import pytest

from usvid.errors import SimulationError
from usvid.manoeuvres.logic import Disturbance, ZigZag


@pytest.mark.parametrize("seed", [1.5, 2.0**53 + 2, np.array([1, 2.5])])
def test_disturbance_seed_must_be_exact_whole_number(seed):
    # seeds travel to the kernel as float64: 1.5 was truncated onto seed 1's stream, and seeds
    # beyond 2^53 rounded onto their neighbours'
    with pytest.raises(SimulationError, match="seed"):
        Disturbance(0.01, seed=seed)


def test_zigzag_negative_amplitude_rejected():
    # ZigZag(-0.17, 0.17) put the rudder to port while waiting for the heading to reach
    # +psi_switch: it never reversed (an endless turn reported as a zig-zag)
    with pytest.raises(SimulationError, match="delta_amp"):
        ZigZag(-0.17, 0.17)
    ZigZag(0.17, 0.17, first=-1)  # port first is the documented way


def test_zigzag_command_and_reference_heading_validated():
    ZigZag(0.17, 0.17, psi_ref=0.3, command=-1)  # a replay started mid-zig-zag
    with pytest.raises(SimulationError, match="command"):
        ZigZag(0.17, 0.17, command=0.5)
    with pytest.raises(SimulationError, match="psi_ref"):
        ZigZag(0.17, 0.17, psi_ref=float("nan"))
