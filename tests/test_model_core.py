"""The identified model is the model file is the model that is simulated (one model core).

For every registered kind: virtual trials are simulated from a known model, seen through noisy
sensors, written as CSV logs with their format spec; ``usvid identify`` (the CLI) writes a model
file; ``usvid simulate turning/zigzag`` on that file is compared with the same commands on the
truth model file. Then the model file is loaded and the training data replayed through
``usvid.sim.replay``: the fit metrics the identification wrote are reproduced (same equations).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from usvid.cli import main
from usvid.identify.estimator import ModelEstimator, _replay_metrics, one_grid
from usvid.io import read_trial
from usvid.io.modelfile import load_model, save_model
from usvid.io.writers import write_csv
from usvid.models import (
    Catamaran,
    IdealServo,
    Nomoto1,
    Nomoto2,
    Norrbin,
    VesselModel,
    mu2018_threedof,
    registry,
)
from usvid.models.kinds.nomoto2_nonlinear import Nomoto2Nonlinear
from usvid.models.thrust import Propeller
from usvid.sim import Commanded, ZigZag, simulate
from usvid.sim.virtual import SensorModel, virtual_trial_uniform
from usvid.trial import Vessel

RATE = math.radians(10.0)  # helm rate [rad/s] of the truth models
# realistic sensors: compass 0.3 deg, gyro 0.1 deg/s, rudder feedback 0.1 deg, GNSS speed
# 0.02 m/s, all logged at 10 Hz (identification needs no position)
SENSORS = SensorModel(heading_sigma_deg=0.3, gyro_sigma_deg_s=0.1, rudder_sigma_deg=0.1,
                      speed_sigma_m_s=0.02, gps_sigma_m=0.3)


def _prop() -> Propeller:
    return Propeller(D=0.46, pitch_ratio=0.3, disk_ratio=0.516, t_P=0.05, w_P=0.04)


def _truth(kind: str) -> tuple[VesselModel, dict[str, float]]:
    """The truth model of each kind and the vessel particulars its format spec carries."""
    servo = IdealServo(max_rate=RATE)
    if kind == "nomoto1":
        return VesselModel(Nomoto1(K=0.25, T=6.0), servo, Vessel(length=20.0, speed=3.0)), {}
    if kind == "nomoto2":
        return VesselModel(Nomoto2(K=0.25, T1=8.0, T2=1.2, T3=2.0), servo,
                           Vessel(length=20.0, speed=3.0)), {}
    if kind == "norrbin":
        return VesselModel(Norrbin(K=0.2, T=10.0, n1=1.0, n3=400.0), servo,
                           Vessel(length=20.0, speed=3.0)), {}
    if kind == "nomoto2_nonlinear":
        # Mu et al. 2018 eq. 34: the nomoto2 truth with the Norrbin truth's cubic (strong enough
        # to show in the 15-20 deg zig-zags the identification sees)
        return VesselModel(Nomoto2Nonlinear(K=0.25, T1=8.0, T2=1.2, T3=2.0, alpha=400.0), servo,
                           Vessel(length=20.0, speed=3.0)), {}
    if kind == "threedof":
        n0 = 52.88  # [rps] holds about 10 kn with this propeller (Lanxin USV)
        dyn = mu2018_threedof(x_l=3.5, thrust=_prop(), n=n0)
        extra = {"x_l": 3.5, "propeller_diameter": 0.46, "propeller_pitch_ratio": 0.3,
                 "propeller_disk_ratio": 0.516, "thrust_deduction": 0.05,
                 "wake_fraction": 0.04}
        return VesselModel(dyn, servo, Vessel(length=7.02, speed=5.14)), extra
    if kind == "mmg":
        # the published KVLCC2 MMG model (Yasukawa & Yoshimura 2015) at the HSVA model scale,
        # R_0 = 0.016 (the HSVA runs' resistance) and the shaft speed holding 1.18 m/s
        from usvid.models.kinds.mmg import equilibrium_rps, from_physics, kvlcc2

        p = kvlcc2("hsva").replace(R_0=0.016)
        n0 = equilibrium_rps(p, 1.18)
        extra = {"x_g": p.x_G, "yaw_inertia": p.I_zG, "propeller_diameter": p.D_p,
                 "rudder_area": p.A_R, "rudder_span": p.H_R, "water_density": p.rho,
                 "volume": p.m / p.rho, "gamma_R_plus": p.gamma_R_plus,
                 "gamma_R_minus": p.gamma_R_minus, "C_2_plus": p.C_2_plus,
                 "C_2_minus": p.C_2_minus}
        return VesselModel(from_physics(p, n=n0), servo, Vessel(length=p.L, speed=1.18, beam=p.B,
                                                          draft=p.d, mass=p.m)), extra
    if kind == "fourdof":
        # a 2.4 m USV with roll (period ~2 s, GM 0.17 m, centre of gravity 10 cm above the roll
        # axis) driven by a pod thruster, T = 0.8 |n| n = 80 N at 10 rps (2 m/s)
        from usvid.models.kinds.fourdof import FourDOF
        from usvid.models.thrust import PodThrust

        held = {"x_l": 0.5, "z_l": 0.15, "m24": 8.5, "mzg": -7.0, "d42": -15.0}
        dyn = FourDOF(m11=80.0, m22=130.0, m44=12.0, m66=30.0, d11=40.0, d22=150.0, d44=15.0,
                      d66=200.0, w_gm=120.0, thrust=PodThrust(c=0.0, d=0.8), n=10.0, **held)
        return (VesselModel(dyn, servo, Vessel(length=2.4, speed=2.0)),
                {**held, "pod_c": 0.0, "pod_d": 0.8})
    # a 2 m catamaran: 35 deg of rudder-equivalent steering turns it at about 15 deg/s, a 20/20
    # zig-zag overshoots by about 15 deg
    dyn = Catamaran(m11=60.0, m22=70.0, m33=20.0, d11=20.0, d22=300.0, d33=45.0, b=0.8,
                    thrust=1.5, cmd=20.0, steer_gain=10.0)
    extra = {"thruster_spacing": 0.8, "thrust_per_command": 1.5, "steer_gain": 10.0,
             "nominal_command": 20.0}
    return VesselModel(dyn, servo, Vessel(length=2.0, speed=3.0)), extra


def _runs(model: VesselModel, kind: str) -> list:
    """Simulated training runs: zig-zags to both sides (and for the kinds with surge, runs at
    several shaft speeds / commands so that the surge damping separates from the thrust)."""
    if kind == "catamaran":
        t = np.arange(0.0, 150.0, 0.5)
        rng = np.random.default_rng(3)
        diff = 6.0 * np.sign(np.sin(2 * np.pi * t / 30.0))
        mean = 20.0 + np.repeat(rng.uniform(-6, 6, len(t) // 60 + 1), 60)[:len(t)]
        res = simulate(model, Commanded(t, n_port=mean + diff, n_stbd=mean - diff), t_end=150.0,
                       dt=0.02)
        zz = simulate(model, ZigZag(np.radians([20.0, 15.0]), np.radians([20.0, 15.0]),
                                    first=np.array([1, -1])), t_end=150.0, dt=0.02)
        return [(res, 0), (zz, 0), (zz, 1)]
    amp = np.radians([20.0, 15.0])
    zz = simulate(model, ZigZag(amp, amp, first=np.array([1, -1])), t_end=150.0, dt=0.02)
    runs = [(zz, 0), (zz, 1)]
    if kind in ("threedof", "fourdof"):
        t = np.arange(0.0, 121.0, 0.1)
        n = model.dynamics.n * np.interp(t, [0, 30, 33, 60, 63, 90, 93, 121],
                                         [1, 1, .75, .75, 1, 1, .85, .85])
        res = simulate(model, Commanded(t, delta_cmd=np.radians(5) * np.sin(2 * np.pi * t / 20),
                                        n=n), t_end=120.0, dt=0.02)
        runs.append((res, 0))
    return runs


@pytest.fixture(scope="module", params=registry.names())
def identified(request, tmp_path_factory):
    kind = request.param
    tmp = tmp_path_factory.mktemp(kind)
    truth, extra = _truth(kind)
    vessel = Vessel(length=truth.vessel.length, speed=truth.vessel.speed,
                    beam=truth.vessel.beam, draft=truth.vessel.draft, mass=truth.vessel.mass,
                    extra=extra)
    logs = []
    for j, (res, i) in enumerate(_runs(truth, kind)):
        tr = virtual_trial_uniform(res, SENSORS, seed=10 + j, i=i, rate_hz=10.0)
        tr = tr.with_data(tr.data.drop(columns=[c for c in ("x", "y", "delta_cmd")
                                                 if c in tr.data.columns]), vessel=vessel)
        logs.append(write_csv(tr, tmp / f"run{j}.csv", spec_path=tmp / "spec.yaml"))
    out = tmp / "model.json"
    code = main(["identify", *map(str, logs), "--format", str(tmp / "spec.yaml"),
                 "--model", kind, "--method", "oe", "--out", str(out), "--json"])
    assert code == 0
    truth_file = save_model(truth, tmp / "truth.json")
    return kind, truth_file, out, logs, tmp


def _cli(capsys, *args: str) -> dict:
    assert main([*args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_identified_file_predicts_the_truth_manoeuvres(identified, capsys):
    kind, truth_file, model_file, _, _ = identified
    capsys.readouterr()
    t_turn = _cli(capsys, "simulate", "turning", str(truth_file), "--delta-deg", "35")
    m_turn = _cli(capsys, "simulate", "turning", str(model_file), "--delta-deg", "35")
    t_zz = _cli(capsys, "simulate", "zigzag", str(truth_file), "--delta-deg", "20")
    m_zz = _cli(capsys, "simulate", "zigzag", str(model_file), "--delta-deg", "20")
    # the acceptance: tactical diameter and steady speed within 2 %, first overshoot
    # within 0.3 deg of the truth model's (identification from noisy virtual trials). MMG
    # (from zig-zags only): advance and tactical diameter within 3 %, the 20/20 first
    # overshoot within 0.5 deg; the steady speed of a 35 deg turn extrapolates the surge terms
    # (X_vv, X_vr, X_rr; identified 0.10, 0.22, 0.08 against the truth's -0.040, 0.002, 0.011)
    # far beyond the drift of a 20 deg zig-zag: within 8 % (measured +7.4 %; +4.2 % when
    # f_alpha was held at Fujii's 3.04, a 10 % rudder-force error that happened to offset it)
    tol = ({"advance_m": 0.03, "tactical_diameter_m": 0.03, "steady_speed_m_s": 0.08}
           if kind == "mmg" else {"tactical_diameter_m": 0.02, "steady_speed_m_s": 0.02})
    if kind == "mmg":
        # output error refines the rudder lift gradient from its Fujii estimate (3.04): the
        # truth's published 2.747 within 3 % (measured 2.788, +1.5 %)
        f_alpha = json.loads(model_file.read_text())["parameters"]["f_alpha"]
        truth = json.loads(truth_file.read_text())["parameters"]["f_alpha"]
        assert f_alpha == pytest.approx(truth, rel=0.03)
    for key, rel in tol.items():
        print(f"{kind} {key}: identified {m_turn[key]:.4g}, truth {t_turn[key]:.4g}")
        assert m_turn[key] == pytest.approx(t_turn[key], rel=rel), (kind, key)
    print(f"{kind} 20/20 first overshoot: identified {m_zz['overshoot_deg'][0]:.3f} deg, truth "
          f"{t_zz['overshoot_deg'][0]:.3f} deg")
    assert abs(m_zz["overshoot_deg"][0] - t_zz["overshoot_deg"][0]) < (
        0.5 if kind == "mmg" else 0.3), kind


def test_model_file_replays_the_fit_residuals(identified):
    kind, _, model_file, logs, tmp = identified
    model = load_model(model_file)
    ident = model.identification
    opts = ident["options"]
    # the training data, replayed through usvid.sim with the file's model and options
    est = ModelEstimator(kind, ident["method"], window_s=opts["window_s"],
                         overlap=opts["overlap"], step=opts["step_s"], smooth_s=opts["smooth_s"])
    trials = one_grid([read_trial(p, str(tmp / "spec.yaml")) for p in logs])
    fixed = {p.name: getattr(model.dynamics, p.name)
             for p in registry.get(kind).dynamics.param_specs() if not p.fit}
    series = est._series(trials, fixed)
    got = _replay_metrics(model, est._windows(series, opts["window_s"]))
    free = _replay_metrics(model, est._windows(series, None))
    for ch, m in got.items():
        # same equations, same data, same input hold: the reported residual to rounding
        assert m["rmse"] == pytest.approx(ident["fit"][ch]["rmse"], rel=1e-9), (kind, ch)
        assert free[ch]["rmse"] == pytest.approx(ident["fit"]["free_run"][ch]["rmse"],
                                                 rel=1e-9), (kind, ch)
    # uncertainties are keyed by the file's parameter names
    assert set(ident["std_errors"]) <= set(json.loads(model_file.read_text())["parameters"])
