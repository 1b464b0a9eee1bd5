"""The vectorised (SIMD) path of the integration core equals its per-lane reference path.

``usvid.sim.core`` integrates the quiet steps of a chunk of lanes with one vectorised RK4 step
and every other step lane by lane; ``core.SIMD = False`` integrates every step lane by lane (the
reference). Both must give the same runs, for every model kind, with a second-order servo with
dead time, a disturbance (noise), a thrust law, measured input series and more lanes than one
chunk (:data:`usvid.sim.core.CH`), so that a partial chunk is covered too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.models import (
    FirstOrderServo,
    IdealServo,
    SecondOrderServo,
    VesselModel,
    mu2018_threedof,
    registry,
)
from usvid.models.environment import SeaState, wind_load_model
from usvid.models.thrust import Propeller
from usvid.sim import (
    Commanded,
    Disturbance,
    Environment,
    Turning,
    ZigZag,
    core,
    simulate,
    specialise,
)
from usvid.trial import Vessel

B = core.CH + 8  # one full chunk and a partial one
#: The two paths run the same arithmetic, but the vector one inlines the right-hand side (FMA
#: contraction may then differ in the last bit): rounding differences of 1e-16 relative per step
#: grow over a few hundred steps to well below 1e-12 of a channel's scale.
RTOL = 1e-12


def _both(model: VesselModel, logic, generic: bool = False, **kw):
    """The same batch on the SIMD path (``generic``: with the generic vector step) and on the
    per-lane path."""
    try:
        core.SIMD = True
        core.FORCE_GENERIC = generic
        a = simulate(model, logic, **kw)
        core.SIMD = False
        b = simulate(model, logic, **kw)
    finally:
        core.SIMD = True
        core.FORCE_GENERIC = False
    return a, b


def _assert_same(a, b) -> None:
    assert a.channels.keys() == b.channels.keys()
    for name, x in a.channels.items():
        y = b.channels[name]
        scale = max(float(np.nanmax(np.abs(y))), 1e-3)
        np.testing.assert_allclose(x, y, rtol=0.0, atol=RTOL * scale, err_msg=name)
    for name, x in a.course.items():  # itae, iae, max |delta|
        np.testing.assert_allclose(x, b.course[name], rtol=RTOL, err_msg=name)
    for name, x in a.zigzag_online.items():  # overshoots [rad], reversal instants [s]
        np.testing.assert_allclose(x, b.zigzag_online[name], rtol=0.0, atol=1e-10,
                                   equal_nan=True, err_msg=name)
    assert (a.success, a.message) == (b.success, b.message)


@pytest.mark.parametrize("kind", registry.names())
def test_simd_path_equals_per_lane_path_zigzag_with_noise(kind):
    dyn = registry.get(kind).dynamics.example()
    servo = SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5, max_rate=math.radians(20.0))
    model = VesselModel(dyn, servo=servo, vessel=Vessel(length=7.0, speed=2.0))
    amp = np.radians(np.linspace(8.0, 25.0, B))
    dist = Disturbance(intensity=np.where(np.arange(B) % 3 == 0, 0.0, math.radians(1.0)), seed=4)
    a, b = _both(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                 t_end=30.0, dt=0.05, disturbance=dist, psi0=np.linspace(-0.2, 0.2, B))
    _assert_same(a, b)


def test_simd_path_equals_per_lane_path_thrust_law_and_series():
    prop = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)
    dyn = mu2018_threedof(x_l=3.5, thrust=prop, n=52.88)
    model = VesselModel(dyn, servo=FirstOrderServo(T=0.4, max_rate=math.radians(15.0)),
                        vessel=Vessel(length=7.02, speed=5.14))
    # turning circles: the quiet vector steps with the propeller law
    a, b = _both(model, Turning(np.radians(np.linspace(-30.0, 30.0, B)),
                                t_start=np.linspace(0.0, 3.0, B)), t_end=20.0, dt=0.02)
    _assert_same(a, b)
    # a commanded run with a measured shaft speed (first-order-hold series)
    t = np.arange(0.0, 20.5, 0.1)
    n = 52.88 * np.interp(t, [0.0, 8.0, 10.0, 20.5], [1.0, 1.0, 0.8, 0.8])
    a, b = _both(model, Commanded(t, delta_cmd=np.radians(5.0) * np.sin(t / 3.0), n=n),
                 t_end=20.0, dt=0.02)
    _assert_same(a, b)


@pytest.mark.parametrize("servo", [
    IdealServo(max_rate=math.radians(20.0)),
    FirstOrderServo(T=0.4, max_rate=math.radians(15.0)),
    SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5, max_rate=math.radians(20.0)),
], ids=["ideal", "first_order", "second_order"])
@pytest.mark.parametrize("kind", ["threedof", "nomoto1"])
def test_simd_variants_equal_per_lane_path(kind, servo):
    """Every variant of the vector step (core.vector_step: per servo kind, without disturbance
    and series, with and without x and y recorded, and the generic one) gives the per-lane
    path's runs."""
    dyn = mu2018_threedof(x_l=3.5) if kind == "threedof" else registry.get(kind).dynamics.example()
    model = VesselModel(dyn, servo=servo, vessel=Vessel(length=7.02, speed=5.14))
    amp = np.radians(np.linspace(8.0, 25.0, B))
    logic = ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1))
    for channels in (None, ("psi", "r", "delta")):
        for generic in (False, True):
            a, b = _both(model, logic, generic=generic, t_end=30.0, dt=0.05, channels=channels,
                         psi0=np.linspace(-0.2, 0.2, B))
            _assert_same(a, b)


@pytest.mark.parametrize("coupled", [False, True], ids=["uncoupled", "coupled"])
def test_simd_path_equals_per_lane_path_threedof_coupling(coupled):
    """A 3-DOF model with the coupling terms (m23, m32, d23, d32, sway force: the generic
    vector step) or without them (the uncoupled equations of its switch value), propeller
    law, turning circles: the per-lane path's runs."""
    prop = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)
    kw = dict(m23=20.0, m32=15.0, d23=10.0, d32=5.0, sway_force=True) if coupled else {}
    dyn = mu2018_threedof(x_l=3.5, thrust=prop, n=52.88).replace(**kw)
    model = VesselModel(dyn, servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.3),
                        vessel=Vessel(length=7.02, speed=5.14))
    a, b = _both(model, Turning(np.radians(np.linspace(-30.0, 30.0, B)),
                                t_start=np.linspace(0.0, 3.0, B)), t_end=20.0, dt=0.02)
    _assert_same(a, b)


#: A 7 m USV's windage: Blendermann's form needs A_T, A_L [m^2] and L; Fujiwara et al. (1998)
#: also the superstructure's and the lateral centroid's (the Esso Osaka model's particulars
#: scaled by 7.02 / 3: lengths by the ratio, areas by its square).
_S = 7.02 / 3.0
WINDAGE = dict(length=7.02, speed=5.14, beam=0.489 * _S, draft=0.32, mass=1500.0,
               frontal_area=0.13544 * _S**2, lateral_area=0.52038 * _S**2,
               extra=dict(superstructure_area=0.14230 * _S**2, lateral_centroid_x=-0.01299 * _S,
                          lateral_centroid_height=0.10359 * _S, superstructure_x=-1.23339 * _S,
                          superstructure_height=0.2940 * _S))


@pytest.mark.parametrize(("kind", "wind_model"), [
    ("threedof", "blendermann1994"), ("threedof", "fujiwara1998"), ("nomoto1", "blendermann1994"),
])
def test_simd_path_equals_per_lane_path_in_wind_current_and_waves(kind, wind_model):
    """The wind loads and the mean wave drift, computed at each RK4 step's start from the
    velocity over ground and heading there and held over the step, on the vector step (its
    wind variant, which the batch must take) give the per-lane path's runs: a gusty wind
    series per run (every direction of the apparent wind within the batch), a current, a sea
    state (mean drift), noise on some lanes, zig-zags of both signs; a force kind and a
    response kind (the wind's yaw moment as a rudder-equivalent angle), both published
    wind-load models."""
    dyn = mu2018_threedof(x_l=3.5) if kind == "threedof" else registry.get(kind).dynamics.example()
    vessel = Vessel(**WINDAGE)
    model = VesselModel(dyn, servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5,
                                                    max_rate=math.radians(20.0)), vessel=vessel)
    t = np.linspace(0.0, 30.0, 61)
    lanes = np.arange(B)[:, None]
    env = Environment(t=t, wind_speed=6.0 + 2.0 * np.sin(0.4 * t + lanes),
                      wind_dir=2.0 * math.pi * lanes / B + 0.1 * np.cos(0.2 * t),
                      current_speed=np.full(t.size, 0.5), current_dir=np.full(t.size, 1.2),
                      sea=SeaState(hs=1.0, tp=5.0, direction=2.0), wave_motion=False,
                      wind_model=wind_load_model(vessel, model=wind_model))
    amp = np.radians(np.linspace(8.0, 25.0, B))
    dist = Disturbance(intensity=np.where(np.arange(B) % 3 == 0, 0.0, math.radians(1.0)), seed=4)
    a, b = _both(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                 t_end=30.0, dt=0.05, disturbance=dist, environment=env,
                 psi0=np.linspace(-0.2, 0.2, B))
    assert a.meta["environment"]["wind"]["model"] == wind_model
    key = specialise.kernel_key(registry.get(kind))  # the batch took the wind variant
    assert any(k[0] == key and k[5] for k in specialise._VSTEPS)
    _assert_same(a, b)
    calm = simulate(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                    t_end=30.0, dt=0.05, disturbance=dist, psi0=np.linspace(-0.2, 0.2, B))
    assert np.max(np.abs(a["psi"] - calm["psi"])) > 1e-3  # the environment acts


@pytest.mark.parametrize(("channels", "noise"), [(("psi",), False), (("x", "y", "psi", "u"), False),
                                                  (("x", "y", "psi"), True)])
def test_simd_path_equals_per_lane_path_in_a_constant_environment(channels, noise):
    """A constant wind, current, sea state and external force, the same for every lane: the
    wind variant that reads the lanes' shared environment block once and adds the constant
    force to the held loads once per step (``shared``, ``steady``: the variant the batch must
    take) gives the per-lane path's runs, recording the heading only or x and y too, with and
    without a disturbance (its filter on the vector step)."""
    model = VesselModel(mu2018_threedof(x_l=3.5),
                        servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5,
                                               max_rate=math.radians(20.0)),
                        vessel=Vessel(**WINDAGE))
    env = Environment(wind_speed=8.0, wind_dir=math.radians(45.0), current_speed=0.5,
                      current_dir=math.radians(90.0), sea=SeaState(hs=1.0, tp=5.0, direction=2.0),
                      wave_motion=False, force=(40.0, -25.0, 0.0, 30.0))
    amp = np.radians(np.linspace(8.0, 25.0, B))
    dist = Disturbance(intensity=math.radians(1.0) if noise else 0.0, seed=2)
    a, b = _both(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                 t_end=30.0, dt=0.05, disturbance=dist, environment=env, channels=channels,
                 psi0=np.linspace(-0.2, 0.2, B))
    key = specialise.kernel_key(registry.get("threedof"))
    assert any(k[0] == key and k[5] and k[8] and k[9] for k in specialise._VSTEPS)
    _assert_same(a, b)


def test_simd_path_flags_a_lane_whose_heading_base_moved_too_far():
    """A USV turning at up to 0.06-0.12 rad a step (the 2 m vector-thruster 3-DOF USV's
    zig-zags and turning circles at dt 0.05-0.1 s), x and y recorded, in calm water and in a
    current: where the heading moved more than 0.05 rad over a step, the next step's heading
    base is NaN and the vector step's x, y with it; the lane must be flagged for the per-lane
    step. With numba's ``np.isfinite`` under the kernels' fast-math flags the NaN tested finite
    (``usvid.sim.scalar._fin``): on the vectorised path alone 44,508 of the zig-zags' x, y, psi
    samples were NaN at dt 0.05 (measured)."""
    from usvid.models import ThreeDOF

    dyn = ThreeDOF(m11=120.0, m22=180.0, m33=60.0, d11=30.0, d22=90.0, d33=50.0, x_l=1.0,
                   thrust=60.0)
    model = VesselModel(dyn, servo=SecondOrderServo(omega_n=1.4, zeta=0.85, delay=0.5),
                        vessel=Vessel(length=2.0))
    amp = np.radians(np.linspace(10.0, 35.0, B))
    current = Environment(current_speed=0.3, current_dir=math.radians(120.0))
    for logic, dt, env in ((ZigZag(amp, np.radians(10.0)), 0.05, None),
                           (Turning(amp), 0.1, current)):
        a, b = _both(model, logic, t_end=40.0, dt=dt, channels=("x", "y", "psi", "r"),
                     environment=env)
        assert np.nanmax(np.abs(b.channels["r"])) * dt > 0.05  # the case (measured 0.058, 0.13)
        for k in ("x", "y", "psi"):
            assert np.all(np.isfinite(a.channels[k])), k
        _assert_same(a, b)


def test_fin_is_false_for_a_computed_nan_under_fast_math():
    """``_fin`` in a function compiled with the kernels' fast-math flags: a NaN or an infinity
    computed in the function (a rotation's NaN marker times a speed plus a position, as in the
    vector step's x) is not finite; finite values are. (numba's ``np.isfinite`` gave True for
    the NaN here: ``x - x`` folded to 0 under ``reassoc`` and ``nsz``.)"""
    import numba

    from usvid.sim.scalar import _FM, _fin

    @numba.njit(fastmath=_FM, error_model="numpy")
    def fin_of(h, u, z, out):
        for j in range(h.shape[0]):
            bad = np.nan if abs(h[j]) > 0.05 else 0.0
            out[j] = 1.0 if _fin(z[j] + 0.1 * u[j] * ((1.0 - 0.5 * h[j] * h[j]) + bad)) else 0.0

    h = np.array([0.06, 0.01, 0.01, 0.01, 0.07, 0.0, 0.02, 0.01])
    u = np.array([1.0, 1.0, np.inf, 1.0, 2.0, 1.0, -np.inf, 1e300])
    z = np.array([1.0, 1.0, 1.0, np.nan, 1.0, 1e308, 1.0, 1e300])
    out = np.zeros(8)
    fin_of(h, u, z, out)
    np.testing.assert_array_equal(out, [0, 1, 0, 0, 0, 1, 0, 1])


def test_simd_path_equals_per_lane_path_measured_series():
    """Measured input series (a per-lane measured steering angle, the shaft speed) without a
    command: the lanes take the quiet path, the series loaded for the quiet lanes and the
    measured angle in their record and max |delta| (the output-error windows); with a zig-zag
    and a measured shaft speed too. Some lanes' angle jumps by more than 0.05 rad within a
    step (their steering base then comes from the library, on the per-lane path)."""
    prop = Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)
    dyn = mu2018_threedof(x_l=3.5, thrust=prop, n=52.88)
    model = VesselModel(dyn, servo=IdealServo(max_rate=math.radians(20.0)),
                        vessel=Vessel(length=7.02, speed=5.14))
    t = np.arange(0.0, 20.5, 0.1)
    lane = np.arange(B)[:, None]
    delta = np.radians(5.0 + 0.5 * lane) * np.sin(t / (2.0 + 0.1 * lane))
    delta[::5, 100:] += np.radians(8.0)  # a jump of 0.14 rad in some lanes
    n = 52.88 * (1.0 - 0.005 * lane * np.clip((t - 8.0) / 2.0, 0.0, 1.0))
    channels = ("psi", "r", "u", "v", "U", "delta", "n")
    a, b = _both(model, Commanded(t, delta=delta, n=n), t_end=20.0, dt=0.1, channels=channels)
    _assert_same(a, b)
    np.testing.assert_array_equal(a.channels["delta"], delta[:, :201])  # the samples, exactly
    amp = np.radians(np.linspace(8.0, 25.0, B))
    # a zig-zag in a current and an external force that vary in time (series, quiet lanes)
    env = Environment(t=t, current_speed=0.3 + 0.02 * t, current_dir=math.radians(60.0),
                      force=(0.0, 20.0 * np.sin(t), 0.0, 10.0 * np.cos(t / 2.0)))
    a, b = _both(model, ZigZag(amp, amp, first=np.where(np.arange(B) % 2 == 0, 1, -1)),
                 t_end=20.0, dt=0.05, environment=env, channels=("x", "y") + channels)
    _assert_same(a, b)


def test_no_isfinite_in_code_compiled_with_fast_math():
    """No ``np.isfinite`` / ``math.isfinite`` in code compiled into the kernels (the core's
    templates, which :mod:`usvid.sim.specialise` compiles with fast math, and every numba
    function of :mod:`usvid.models`, inlined into them), nor in the code :mod:`usvid.sim.layout`
    generates: under ``reassoc`` and ``nsz`` it tests a NaN finite (see the test above); use
    :func:`usvid.sim.scalar._fin`."""
    import ast
    from pathlib import Path

    import usvid

    root = Path(usvid.__file__).parent
    templates = [root / "sim" / f"{m}.py" for m in ("chunk", "vector", "lane", "scalar")]
    bad = []
    for path in [*templates, *sorted((root / "models").rglob("*.py")), root / "sim" / "layout.py"]:
        tree = ast.parse(path.read_text())
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef):
                continue
            jitted = path in templates or any("njit" in ast.unparse(d) for d in fn.decorator_list)
            for node in ast.walk(fn):
                called = (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                          and node.func.attr == "isfinite")
                generated = isinstance(node, ast.Constant) and "isfinite(" in str(node.value)
                if (jitted and called) or generated:
                    bad.append(f"{path.relative_to(root)}:{node.lineno} in {fn.name}")
    assert not bad, bad
