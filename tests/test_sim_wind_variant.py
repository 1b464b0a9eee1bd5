"""The vector step's wind variants without x and y: the heading's trig bases rotated at the
load evaluations only, and a steady batch without an external force series (its rows not
read), against the per-lane path (the reference).

Tolerances: 1e-12 of each channel's scale and 1e-10 rad for the zig-zag overshoots, as the
other vector-against-per-lane tests (FMA contraction may differ in the last bits; the bases are
rotated over a load interval instead of step by step, the same series to 1e-16).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.models import SecondOrderServo, VesselModel, mu2018_threedof, registry
from usvid.sim import Environment, Turning, ZigZag, core, simulate, specialise
from usvid.trial import Vessel

#: A 7 m USV's windage (Blendermann's speed boat): the benchmark's.
VESSEL = Vessel(length=7.02, speed=5.144, frontal_area=2.0, lateral_area=5.0)


def _model() -> VesselModel:
    return VesselModel(mu2018_threedof(x_l=3.5),
                       servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5,
                                              max_rate=math.radians(20.0)),
                       vessel=VESSEL)


def _both(logic, **kw):
    try:
        a = simulate(_model(), logic, **kw)
        core.SIMD = False
        b = simulate(_model(), logic, **kw)
    finally:
        core.SIMD = True
    return a, b


def _same(a, b) -> None:
    for name, x in a.channels.items():
        scale = max(float(np.max(np.abs(b[name]))), 1e-3)
        np.testing.assert_allclose(x, b[name], rtol=0.0, atol=1e-12 * scale, err_msg=name)
    for name, x in a.zigzag_online.items():
        np.testing.assert_allclose(x, b.zigzag_online[name], rtol=0.0, atol=1e-10,
                                   equal_nan=True, err_msg=name)


def _variants(key: str) -> list[tuple]:
    return [k for k in specialise._VSTEPS if k[0] == key and k[5]]


@pytest.mark.parametrize("force", [None, (40.0, -25.0, 0.0, 30.0)])
def test_steady_wind_without_a_force_series_skips_its_rows(force):
    """A constant wind and current, heading recorded: without an external force the variant
    that does not read the force rows (key position 10 False), with one the variant that adds
    it; both give the per-lane path's zig-zags (both signs, wind from every side)."""
    B = 12
    amp = np.radians(np.linspace(8.0, 25.0, B))
    logic = ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1))
    env = Environment(wind_speed=8.0, wind_dir=math.radians(45.0), current_speed=0.5,
                      current_dir=math.radians(90.0), force=force)
    a, b = _both(logic, t_end=30.0, dt=0.05, environment=env, channels=("psi", "r", "v"))
    key = specialise.kernel_key(registry.get("threedof"))
    # shared, steady, and the force rows read only with a force series
    assert any(k[8] and k[9] and k[10] == (force is not None) and not k[4]
               for k in _variants(key))
    _same(a, b)
    calm = simulate(_model(), logic, t_end=30.0, dt=0.05, channels=("psi",))
    assert np.max(np.abs(a["psi"] - calm["psi"])) > 1e-3  # the wind acts


def test_heading_base_rotated_over_the_load_interval_falls_back_when_too_far():
    """Without x and y the vector step rotates the heading's base only at the evaluations of
    the loads, over the whole interval: a turn at about 0.2 rad/s with the loads every 0.5 s
    (ten steps of 0.05 s) moves the heading more than 0.05 rad between evaluations (the
    series' reach), so the evaluation cannot rotate the base; those lanes take the per-lane
    step, which evaluates their loads, and the runs equal the per-lane path's."""
    B = 6
    env = Environment(wind_speed=8.0, wind_dir=np.linspace(0.0, 5.0, B), current_speed=0.5,
                      current_dir=1.2, load_interval=0.5)
    a, b = _both(Turning(np.radians(np.linspace(20.0, 35.0, B)), 1.0), t_end=40.0, dt=0.05,
                 environment=env, channels=("psi", "r", "u", "v"))
    assert a.meta["environment"]["load_hold"]["load_every_steps"] == 10
    # more than 0.05 rad of heading between evaluations (half a second) on every lane
    assert np.min(np.max(np.abs(b["r"]), axis=1)) * 0.5 > 0.05
    key = specialise.kernel_key(registry.get("threedof"))
    assert any(not k[4] for k in _variants(key))
    _same(a, b)
