"""The 4-DOF surge-sway-roll-yaw kind (Fossen 2021 ch. 6-7; Blanke & Christensen 1993).

* roll decay at rest against the oscillator formula, with Blanke & Christensen's published roll
  inertia, added inertia, restoring and damping (uncoupled, and with the sway free);
* the steady heel of a turn against the roll row of the force balance (and its sign: a vessel
  whose centre of gravity is above the roll axis heels outward), reported by the standard run;
* the kinematics (psi' = r cos phi);
* recovery: least squares and output error on noisy virtual trials (zig-zags and a turn seen
  through GNSS, compass, gyro, IMU roll and roll rate, speed log and rudder feedback).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.identify import identify
from usvid.models import IdealServo, VesselModel, registry
from usvid.models.kinds.fourdof import FITTED, FourDOF, steady_heel
from usvid.sim import Commanded, Turning, ZigZag, run_turning, simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel

KIND = registry.get("fourdof")

# Blanke & Christensen (1993) naval vessel, published (MSS navalvessel.m): I_x, K_p', rho,
# nabla, GM_T, K_p
IXX, KPDOT, RHO, NABLA, GM, KP = 2.3763e6, -774000.0, 1014.0, 357.0, 1.1, -500000.0
M44 = IXX - KPDOT
W_GM = RHO * 9.81 * NABLA * GM


def _at_rest(**kw) -> FourDOF:
    base = dict(m11=4e5, m22=7.55e5, m44=M44, m66=8.66e7, d11=0.0, d22=0.0, d44=-KP,
                d66=0.0, w_gm=W_GM, x_l=20.0, thrust=None)
    return FourDOF(**{**base, **kw})


def _decay(dyn: FourDOF, phi0: float = 0.05, t_end: float = 40.0, dt: float = 0.01):
    """Roll decay from phi0 [rad] at rest (u = 0, no thrust, rudder 0): (t, phi)."""
    model = VesselModel(dyn, servo=IdealServo())
    res = simulate(model, Commanded(np.array([0.0, t_end]), delta=np.zeros(2)), t_end=t_end,
                   dt=dt, u0=0.0, initial={"phi": phi0}, channels=("phi",))
    return res.t, res["phi"][0]


def _period_and_damping(t: np.ndarray, phi: np.ndarray) -> tuple[float, float]:
    """Damped period [s] from the downward zero crossings (linear interpolation) and damping
    ratio from the logarithmic decrement of successive maxima."""
    i = np.flatnonzero((phi[:-1] > 0) & (phi[1:] <= 0))
    tc = t[i] + phi[i] / (phi[i] - phi[i + 1]) * (t[i + 1] - t[i])
    Td = float(np.mean(np.diff(tc)))
    k = np.flatnonzero((phi[1:-1] > phi[:-2]) & (phi[1:-1] >= phi[2:])) + 1
    dlt = float(np.mean(np.log(phi[k[:-1]] / phi[k[1:]])))
    return Td, dlt / math.sqrt(4 * math.pi ** 2 + dlt ** 2)


@pytest.mark.parametrize("coupled", [False, True], ids=["roll_alone", "sway_free"])
def test_roll_decay_matches_the_oscillator_formula(coupled):
    """m44 phi'' + d44 phi' + w_gm phi = 0: damped period 2 pi / (w_n sqrt(1 - zeta^2)),
    w_n = sqrt(w_gm / m44), zeta = d44 / (2 sqrt(w_gm m44)); with the sway free (the B&C
    sway-roll coupling m24 = -m z_G - Y_p' = 680,000 kg m, m22 = m - Y_v' = 755,000 kg, no
    sway damping at rest) the roll inertia is m44 - m24^2/m22. From the published numbers:
    natural roll period 5.64 s alone (damped 5.66 s), 5.06 s with the sway free (damped
    5.08 s); damping ratio 0.071 and 0.079."""
    m24 = -(RHO * NABLA * -(3.36 - 2.3) - 296000.0) if coupled else 0.0
    dyn = _at_rest(m24=m24)
    inertia = M44 - m24 ** 2 / dyn.m22
    wn = math.sqrt(W_GM / inertia)
    zeta = -KP / (2.0 * math.sqrt(W_GM * inertia))
    Td_want = 2 * math.pi / (wn * math.sqrt(1 - zeta ** 2))
    t, phi = _decay(dyn)
    Td, z = _period_and_damping(t, phi)
    # the restoring is w_gm sin(phi): at 0.05 rad the period is longer by ~phi0^2/16 = 1.6e-4
    # (decaying); RK4 at dt = T/500 and the crossings' linear interpolation err < 1e-5
    assert Td == pytest.approx(Td_want, rel=3e-4)
    assert 2 * math.pi / wn == pytest.approx(5.06 if coupled else 5.64, abs=0.005)
    assert Td_want == pytest.approx(5.08 if coupled else 5.66, abs=0.005)
    assert zeta == pytest.approx(0.079 if coupled else 0.071, abs=5e-4)
    # log decrement of sampled maxima (dt = 0.01 s at 1.2 rad/s: peak error ~(w dt)^2 / 8)
    assert z == pytest.approx(zeta, rel=2e-3)


# a 2.4 m USV: 70 kg, roll period ~2 s, GM 0.17 m, CG 10 cm above the roll axis; a 20/20 zig-zag
# overshoots by 15 deg, a 35 deg turn has a tactical diameter of 4 L
USV = dict(m11=80.0, m22=130.0, m44=12.0, m66=30.0, d11=40.0, d22=150.0, d44=15.0,
           d66=200.0, w_gm=120.0, x_l=0.5, z_l=0.15, m24=8.5, mzg=-7.0, d42=-15.0)
THRUST = 80.0  # N: 2 m/s straight


def test_steady_heel_in_a_turn_and_the_standard_run():
    dyn = FourDOF(**USV, thrust=THRUST)
    model = VesselModel(dyn, servo=IdealServo(max_rate=math.radians(20.0)),
                        vessel=Vessel(length=2.4, speed=2.0))
    res, m = run_turning(model, 25.0, dt=0.01)
    u, v, r, phi = (res[k][0, -1] for k in ("u", "v", "r", "phi"))
    want = steady_heel(dyn, u, v, r, math.radians(25.0), THRUST)
    assert abs(res["p"][0, -1]) < 1e-9  # steady
    assert phi == pytest.approx(float(want), abs=1e-9)
    # centrifugal heel outward (to port in a turn to starboard) outweighs the thruster's side
    # force below the roll axis here
    assert r > 0 and phi < 0
    assert m.steady_heel_deg == pytest.approx(math.degrees(phi), abs=1e-3)
    assert m.max_heel_deg >= abs(m.steady_heel_deg)
    assert {"max_heel_deg", "steady_heel_deg"} <= set(m.to_dict())


def test_kinematics_with_heel():
    """x' = u cos psi - v cos phi sin psi, psi' = r cos phi (Fossen 2021, theta = 0): the
    velocities the core integrates are u, v cos phi, r cos phi."""
    dyn = FourDOF(**USV, thrust=THRUST)
    u, v, r, _ = KIND.derivatives(dyn, np.array([1.5, 0.2, 0.3, 0.0, 0.4]), delta=0.1)
    assert (u, v, r) == pytest.approx((1.5, 0.2 * math.cos(0.4), 0.3 * math.cos(0.4)), rel=1e-15)


def _trials(dyn: FourDOF, seed: int = 3):
    """Zig-zags 20/20 and 10/10 (to port) and a 30 deg turn, 60 s each at 2 m/s, seen through
    the default small-USV sensors at 20 Hz (GNSS 0.5 m, speed 0.05 m/s, compass 0.5 deg, gyro
    0.2 deg/s, rudder 0.2 deg, IMU roll 0.2 deg and roll rate 0.2 deg/s)."""
    model = VesselModel(dyn, servo=IdealServo(max_rate=math.radians(30.0)),
                        vessel=Vessel(length=2.4, speed=2.0))
    runs = [ZigZag(math.radians(20.0), math.radians(20.0)),
            ZigZag(math.radians(10.0), math.radians(10.0), first=-1),
            Turning(math.radians(30.0))]
    out = []
    for k, logic in enumerate(runs):
        res = simulate(model, logic, t_end=60.0, dt=0.01, u0=2.0)
        out.append(virtual_trial_uniform(res, SensorModel(), seed=seed + k, rate_hz=20.0,
                                         vessel=Vessel(length=2.4, speed=2.0)))
    return out


HELD = {k: v for k, v in USV.items() if k not in FITTED}


#: Relative tolerances. Output error: noise alone moves the parameters by up to ~2 % (3 x 60 s at
#: 20 Hz; two noise seeds: at most 1.9 %), so 4 %. Equation error on Savitzky-Golay derivatives
#: is only output error's start: its roll row (roll angle and rate from the IMU) is well
#: determined (observed within 7.5 %), while the surge, sway and yaw rows regress on the sway
#: velocity, whose speed-log noise (0.05 m/s) is of the size of the sway itself (errors in
#: variables: m11 -82 %, m22 -57 %, m66 +22 % for both seeds), so they are not checked.
TOL = {"oe": dict.fromkeys(FITTED, 0.04), "ls": {"m44": 0.1, "d44": 0.1, "w_gm": 0.05}}


@pytest.mark.parametrize("method", ["ls", "oe"])
def test_recovery_from_noisy_virtual_trials(method):
    truth = FourDOF(**USV, thrust=THRUST)
    trials = _trials(truth)
    assert all("phi" in tr.channels and "p" in tr.channels for tr in trials)
    fit = identify(trials, "fourdof", method, particulars=HELD, thrust=THRUST)
    got = fit.model.dynamics
    err = {k: abs(float(getattr(got, k)) / USV[k] - 1.0) for k in FITTED}
    bad = {k: round(err[k], 4) for k in TOL[method] if err[k] > TOL[method][k]}
    assert not bad, f"{method}: relative errors {bad} (all: {err})"
    if method == "oe":  # the identified model predicts the turn: heel and diameter
        servo = IdealServo(max_rate=math.radians(20.0))
        vessel = Vessel(length=2.4, speed=2.0)
        _, m0 = run_turning(VesselModel(truth, servo=servo, vessel=vessel), 25.0)
        _, m1 = run_turning(VesselModel(got, servo=servo, vessel=vessel), 25.0)
        assert m1.steady_heel_deg == pytest.approx(m0.steady_heel_deg, rel=0.03)
        assert m1.steady_diameter_m == pytest.approx(m0.steady_diameter_m, rel=0.03)
