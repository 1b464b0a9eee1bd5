"""Identification outdoors, virtual acceptance: an MMG vessel (the 7 m KVLCC2 model) in a known
gusty wind, logged by a noisy, offset anemometer, and a known current, runs zig-zags and turns
from rest; ``usvid identify --model mmg --disturbance current`` with otherwise default options
(the library call the CLI makes, ``ModelEstimator("mmg", disturbance="current")``) gives hull
coefficients that predict the calm-water 35 deg turning and 20/20 zig-zag, the current of each
run and the scale of the wind loads.

The campaign: four runs from rest (shaft at its service rps), the first ``T_APPROACH`` s under
a PD course-keeping autopilot (as the trials' helmsman or autopilot holds the course while the
ship gathers way: the KVLCC2 is course-unstable and swings off with its rudder amidships), then
a 20/20 zig-zag to starboard, one to port, a 35 deg turn to starboard, one to port, each until
``T_END``. All seeded.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest

from usvid.identify.estimator import ModelEstimator
from usvid.models.environment import gust_series
from usvid.models.environment.wind import true_to_apparent
from usvid.models.kinds.mmg import equilibrium_rps, from_physics, kvlcc2
from usvid.models.model import VesselModel
from usvid.models.servo import IdealServo
from usvid.sim import (
    PID,
    CourseChange,
    Environment,
    Turning,
    ZigZag,
    run_turning,
    run_zigzag,
    simulate,
)
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Trial, Vessel

P = kvlcc2("hsva").replace(R_0=0.016)  # the HSVA runs' resistance (kvlcc2's docstring)
FULL = {"x_g": P.x_G, "yaw_inertia": P.I_zG, "propeller_diameter": P.D_p,
        "rudder_area": P.A_R, "rudder_span": P.H_R, "water_density": P.rho,
        "volume": P.m / P.rho, "gamma_R_plus": P.gamma_R_plus,
        "gamma_R_minus": P.gamma_R_minus, "C_2_plus": P.C_2_plus, "C_2_minus": P.C_2_minus}
#: Windage of the 7 m model (1:45.7): A_L = 2.0 m^2 is the full-scale tanker's ~4200 m^2 of
#: hull above water and accommodation, A_T = 0.5 m^2 its ~1000 m^2 front (Blendermann 1994's
#: form; no Fujiwara particulars).
WINDAGE = {"frontal_area": 0.5, "lateral_area": 2.0}
#: GNSS/INS-class sensors of a model-scale free-running test (2 cm positions, 0.1 deg heading).
SENSORS = SensorModel(heading_sigma_deg=0.1, gyro_sigma_deg_s=0.05, rudder_sigma_deg=0.1,
                      speed_sigma_m_s=0.005, gps_sigma_m=0.02)
U0 = 1.18  # [m/s] the service speed the propeller's rps holds in calm water (HSVA runs)
#: The truth's environment: a current of 0.15 m/s towards 060 deg; a NORSOK gusty wind of
#: WIND_MEAN m/s from 200 deg (at model scale: a strong breeze at 1:45.7), its loads
#: WIND_SCALE times the Blendermann model's (so that a scale held at 1 fails the test).
CURRENT, TOWARDS = 0.15, math.radians(60.0)
WIND_MEAN, WIND_FROM = 5.0, math.radians(200.0)
WIND_SCALE = 1.25
#: The anemometer on board logs the apparent wind with 0.2 m/s and 2 deg of noise and a
#: realistic calibration: +0.1 m/s on the speed (a cup anemometer's offset), its vane 3 deg off
#: the centreline. The offset alone biases the fitted scale by (5 / 5.1)^2 - 1 = -4 %.
ANEMO_NOISE, ANEMO_DIR_NOISE = 0.2, math.radians(2.0)
ANEMO_OFFSET, ANEMO_VANE = 0.1, math.radians(3.0)
T_APPROACH, T_END, DT = 80.0, 200.0, 0.05  # [s]: ~1.0 m/s (85 % of U0) at the execute

#: One output-error fit of four 200 s runs (17 hull coefficients, f_alpha, wind_scale, a
#: current per run, multiple shooting): minutes on two cores, the smallest campaign that has
#: runs from rest, turns through every heading and zig-zags to both sides.
pytestmark = pytest.mark.slow


def _vessel(**extra: float) -> Vessel:
    return Vessel(length=P.L, beam=P.B, draft=P.d, mass=P.m, block_coefficient=0.81,
                  speed=U0, extra={**FULL, **extra}, **WINDAGE)


def _truth(wind_scale: float = WIND_SCALE) -> VesselModel:
    return VesselModel(from_physics(P, n=equilibrium_rps(P, U0)),
                       IdealServo(max_rate=math.radians(15.0)), _vessel(wind_scale=wind_scale))


def _campaign(seed: int = 1) -> list[Trial]:
    """The four runs (module docstring), each a :class:`Trial` with the logged apparent wind."""
    truth = _truth()
    t = np.arange(0.0, T_END + 0.05, 0.1)
    ws = gust_series(t, WIND_MEAN, spectrum="norsok", seed=seed, n_batch=4)
    wd = np.full_like(ws, WIND_FROM)
    cur = {"current_speed": CURRENT, "current_dir": TOWARDS}
    app = simulate(truth, CourseChange(np.zeros(4), PID(kp=2.0, kd=8.0)), t_end=T_APPROACH,
                   dt=DT, u0=0.0, environment=Environment(t=t, wind_speed=ws, wind_dir=wd, **cur))
    k = app.t.size - 1
    cn, ce = CURRENT * math.cos(TOWARDS), CURRENT * math.sin(TOWARDS)
    psi = app["psi"][:, k]
    # the runs go on from the approach's end: the kind's states are through the water
    u_r = app["u"][:, k] - (cn * np.cos(psi) + ce * np.sin(psi))
    v_r = app["v"][:, k] - (-cn * np.sin(psi) + ce * np.cos(psi))
    later = t >= T_APPROACH - 1e-9
    logics = (ZigZag(math.radians(20.0), math.radians(20.0), first=1),
              ZigZag(math.radians(20.0), math.radians(20.0), first=-1),
              Turning(math.radians(35.0)), Turning(math.radians(-35.0)))
    rng = np.random.default_rng(seed)
    out = []
    for i, logic in enumerate(logics):
        env = Environment(t=t[later] - T_APPROACH, wind_speed=ws[i, later],
                          wind_dir=wd[i, later], **cur)
        man = simulate(truth, logic, t_end=T_END - T_APPROACH, dt=DT, u0=float(u_r[i]),
                       psi0=float(psi[i]), environment=env,
                       initial={"x": float(app["x"][i, k]), "y": float(app["y"][i, k]),
                                "v": float(v_r[i]), "r": float(app["r"][i, k]),
                                "delta": float(app["delta"][i, k])})
        a = virtual_trial_uniform(app, SENSORS, seed=20 + i, i=i, rate_hz=10.0).data
        b = virtual_trial_uniform(man, SENSORS, seed=40 + i, rate_hz=10.0).data.iloc[1:]
        d = pd.concat([a, b.assign(t=b["t"] + T_APPROACH)], ignore_index=True)
        tt = d["t"].to_numpy()
        tg = np.concatenate([app.t, man.t[1:] + T_APPROACH])
        u, v, ps = (np.interp(tt, tg, np.concatenate([app[c][i], man[c][0, 1:]]))
                    for c in ("u", "v", "psi"))
        c, s = np.cos(ps), np.sin(ps)
        va, ga = true_to_apparent(np.interp(tt, t, ws[i]), np.interp(tt, t, wd[i]),
                                  u * c - v * s, u * s + v * c, ps)
        d["wind_speed"] = np.maximum(va + ANEMO_OFFSET + rng.normal(0, ANEMO_NOISE, tt.size), 0)
        d["wind_angle"] = ga + ANEMO_VANE + rng.normal(0, ANEMO_DIR_NOISE, tt.size)
        out.append(Trial(data=d, vessel=_vessel(), name=f"run{i + 1}"))
    return out


@pytest.fixture(scope="module")
def identified():
    """The campaign identified as ``usvid identify RUNS --model mmg --disturbance current``:
    the same fit, its failed checks recorded instead of raised (``--accept-failed-checks``)
    so that one fit serves every criterion; :func:`test_passes_its_checks` asks for none."""
    trials = _campaign()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = ModelEstimator("mmg", disturbance="current", checks="record").fit(trials)
    return est


def test_passes_its_checks(identified):
    """With default options the identified model must pass its checks (else the CLI exits 2).
    The checks replay each run in the current estimated for it, from its velocities through
    the water (measured: windowed heading RMSE 0.004 rad, R^2 1.000; the free run finite,
    heading RMSE 0.38 rad over 200 s), and it stays finite when started from rest in calm
    water (rudder amidships and at +-35 deg). Replayed in calm water from the velocities over
    ground, the first window of every run (at rest: the current's 0.15 m/s alone, mostly
    sideways) diverges after 7-8 s, and the fit would be refused."""
    from usvid.identify.checks import failed

    print([c.message for c in failed(identified.checks_)])
    assert not failed(identified.checks_)
    # the runs start from rest: the checks start the model from rest too (amidships and
    # +-35 deg; it stays finite, as the truth does)
    assert "start from rest" in [c.name for c in identified.checks_]


def test_runs_start_from_rest_and_turn(identified):
    """The data are what the acceptance asks: every run from rest, the turns through more
    than a full circle of headings (what separates a current from the hull)."""
    for s in identified.series_:
        assert abs(s["u"][0]) < 0.2  # [m/s] over ground: the current alone
    spans = [np.degrees(np.ptp(s["psi_s"])) for s in identified.series_]
    assert min(spans[2:]) > 300.0


def test_calm_water_turning_diameter_within_3_percent(identified):
    """The identified hull predicts the calm-water 35 deg turning's tactical diameter within
    3 % of the truth's, to both sides (measured: -0.02 % and +0.15 %)."""
    calm = _truth(1.0)
    for side in (1, -1):
        _, want = run_turning(calm, 35.0 * side, u0=U0)
        _, got = run_turning(identified.model_, 35.0 * side, u0=U0)
        err = got.tactical_diameter_m / want.tactical_diameter_m - 1.0
        print(f"TD {side:+d}: truth {want.tactical_diameter_m:.2f} m, identified "
              f"{got.tactical_diameter_m:.2f} m ({100 * err:+.1f} %)")
        assert abs(err) < 0.03


def test_calm_water_first_overshoot_within_half_a_degree(identified):
    """The 20/20 zig-zag's first overshoot in calm water within 0.5 deg of the truth's, to
    both sides (measured: 11.55 deg against 11.21 to starboard, 15.33 against 14.99 to port).

    The helm is the truth's rate-limited one (15 deg/s). Identified as a linear second-order
    servo (omega_n 1.73 rad/s, fitted mostly to the approach's small autopilot orders) the
    same hull overshot 0.99 and 1.25 deg too little; behind the rate limit measured on the
    rudder's ramps it is within 0.02 deg of the truth's helm (the truth's hull with the
    identified helm: 11.23 and 15.02 deg). What is left (+0.33 deg) is the hull's: the yaw
    equation's cubic terms are poorly determined by these runs (N_rrr +0.028 against -0.013,
    Y_vvv -0.58 against -1.61, N_r +9 %), mostly through the anemometer's errors (with a
    perfect anemometer N_r is within 1 %)."""
    calm = _truth(1.0)
    for side in (1, -1):
        _, want = run_zigzag(calm, 20.0, 20.0, first=side, u0=U0)
        _, got = run_zigzag(identified.model_, 20.0, 20.0, first=side, u0=U0)
        print(f"20/20 first overshoot {side:+d}: truth {want.overshoot_deg[0]:.2f} deg, "
              f"identified {got.overshoot_deg[0]:.2f} deg")
        assert got.overshoot_deg[0] == pytest.approx(want.overshoot_deg[0], abs=0.5)


def test_current_of_every_run(identified):
    """The current estimated per run: within 0.02 m/s and 10 deg of the truth's (measured:
    0.150-0.153 m/s towards 59.4-60.5 deg: the turns through every heading and the starts from
    rest, where the ground velocity is the current's, separate it from the hull)."""
    rows = identified.result_.summary()["disturbance"]["trials"]
    assert len(rows) == 4
    for row in rows:
        print(f"{row['trial']}: {row['current_speed_m_s']:.3f} m/s towards "
              f"{row['current_towards_deg']:.1f} deg")
        assert row["current_speed_m_s"] == pytest.approx(CURRENT, abs=0.02)
        assert abs((row["current_towards_deg"] - 60.0 + 180.0) % 360.0 - 180.0) < 10.0


def test_wind_scale_within_10_percent(identified):
    """wind_scale estimated (not held) within 10 % of the truth's 1.25 (measured 1.139, -8.9 %:
    the anemometer's +0.1 m/s offset alone accounts for -4 %, its vane offset and the ridge
    of the hull's surge terms for the rest)."""
    w = identified.model_.identification["wind"]
    print(f"wind_scale {w['wind_scale']:.3f} (95 % {w['ci95']})")
    assert not w["held"] and w["model"] == "blendermann1994"
    assert w["wind_scale"] == pytest.approx(WIND_SCALE, rel=0.10)
