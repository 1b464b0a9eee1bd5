"""The virtual Lanxin sea-trial campaign (Mu et al. 2018): the bundled default data of
``usvid demo``.

The Lanxin USV (Mu et al. 2018 Table 1: 7.02 m x 2.6 m, one vector thruster +-35 deg, about 10 kn)
is simulated with the full 3-DOF model of Mu et al. 2018 eq. 37 (:func:`usvid.models.threedof.
mu2018_threedof`, thruster arm x_l = 3.5 m, not printed in the seed), the propeller thrust of
Mu et al. 2018 eq. 1 (D = 0.46 m, P/D = 0.3, disk ratio 0.516, t_P = 0.05, w_P = 0.04 as the seed
states) at the shaft speed that holds 10 kn (about 48 rps = 2880 rpm; the seed says the engine
ran at about 2800 rpm), the identified second-order servo with 1 s dead time (Mu et al. 2018 section
5.1.3), and a calm-sea disturbance. It runs the Mu et al. 2018 test programme -- turning tests at
10, 15, 25, 35 deg and a 10/10 zig-zag -- plus a 15/15 zig-zag, and writes each trial as real log
files: NMEA 0183 (GNSS position/speed/course, heading, rate of turn, rudder), candump (NMEA 2000
engine speed and heading/rate), and the logger's CSV export; seeded and deterministic.

The "truth" the identification is judged against (see :func:`response_truth`):

- 3-DOF: the eq. 37 coefficients themselves (the simulator runs exactly that model).
- Nomoto K, T: the first-order Nomoto model whose yaw rate, driven by the *actual* propulsion
  angle of the noise-free, disturbance-free 3-DOF 10/10 zig-zag, matches the 3-DOF yaw rate best
  in the least-squares sense (output error). The 3-DOF model is not exactly first order, so this
  is the best first-order description of it on that manoeuvre. The small-signal linearisation at
  10 kn (a Nomoto 2nd-order transfer function, Mu et al. 2018 eq. 29) is reported next to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pymap3d
import yaml
from scipy.optimize import brentq

from usvid.files import write_atomic
from usvid.identify.estimator import identify
from usvid.io.n2k import read_candump, write_candump
from usvid.io.nmea0183 import read_nmea0183, write_nmea0183
from usvid.io.rosbag import write_rosbag
from usvid.io.spec import load_spec
from usvid.io.table import read_table
from usvid.manoeuvres.detect import steady_turn
from usvid.models import mu2018_threedof
from usvid.models.model import VesselModel
from usvid.models.servo import SecondOrderServo
from usvid.models.thrust import Propeller
from usvid.prep.merge import merge_trials
from usvid.sim import Commanded, Disturbance, Turning, ZigZag, simulate
from usvid.sim.virtual import SensorModel, run_channels, virtual_trial
from usvid.trial import Trial, Vessel

KNOT = 1852.0 / 3600.0  # [m/s]

#: Lanxin particulars (Mu et al. 2018 Table 1), SI.
LANXIN = {
    "length": 7.02, "beam": 2.6, "draft": 0.32, "block_coefficient": 0.6976,
    "displacement": 2.73, "speed": 10.0 * KNOT,
}
#: Propeller (Mu et al. 2018 Table 1 and section 3.1: t_P ~ 0.05, w_P ~ 0.04).
LANXIN_PROPELLER = {"D": 0.46, "pitch_ratio": 0.3, "disk_ratio": 0.516, "t_P": 0.05, "w_P": 0.04}
#: Thruster arm behind the pivot [m] (not printed in Mu et al. 2018; about half the length).
LANXIN_X_L = 3.5
#: The particulars a 3-DOF model needs besides the data, as the format specs carry them
#: (``vessel.extra``; see :mod:`usvid.models.kinds.threedof`).
LANXIN_PARTICULARS = {
    "x_l": LANXIN_X_L, "propeller_diameter": LANXIN_PROPELLER["D"],
    "propeller_pitch_ratio": LANXIN_PROPELLER["pitch_ratio"],
    "propeller_disk_ratio": LANXIN_PROPELLER["disk_ratio"],
    "thrust_deduction": LANXIN_PROPELLER["t_P"], "wake_fraction": LANXIN_PROPELLER["w_P"],
}
#: Identified servo of Mu et al. 2018 section 5.1.3: 1.95 / (s^2 + 2.38125 s + 1.95), 1 s dead time.
LANXIN_SERVO = {"omega_n": math.sqrt(1.95), "zeta": 2.38125 / (2.0 * math.sqrt(1.95)),
                "gain": 1.0, "delay": 1.0}
#: Origin of the local NED frame: the Mu et al. 2018 trial area (lat 38.8612 N, lon 121.5548 E).
ORIGIN_LAT_DEG, ORIGIN_LON_DEG = 38.8612, 121.5548


@dataclass(frozen=True)
class Manoeuvre:
    """One trial of the programme: ``kind`` "turning" or "zigzag", angles in degrees (edges)."""

    name: str
    kind: str
    delta_deg: float
    psi_deg: float | None = None
    duration_s: float = 60.0


def programme(quick: bool = False) -> list[Manoeuvre]:
    """The Mu et al. 2018 test programme (section 2.4): turning 10/15/25/35 deg, zig-zag 10/10, plus
    a 15/15 zig-zag, a straight run with propeller-speed steps (``speed_steps``) and a 20/20
    zig-zag that no model is identified from (the held-out validation trial).

    The speed steps are an addition to Mu et al. 2018's programme: at one constant shaft speed the
    surge equation's ``a_u u`` and ``a_tau tau_u`` terms are collinear (thrust and resistance
    balance at the one speed), so eq. 37's a_u and a_tau cannot be separated without a change
    of propeller speed. During the speed steps the helmsman weaves gently
    (:data:`WEAVE_DEG`). ``quick`` shortens every run (for tests); durations in seconds.
    """
    turn_s, zz_s, sp_s = (45.0, 45.0, 60.0) if quick else (90.0, 120.0, 120.0)
    return [
        Manoeuvre("turning_10", "turning", 10.0, None, turn_s),
        Manoeuvre("turning_15", "turning", 15.0, None, turn_s),
        Manoeuvre("turning_25", "turning", 25.0, None, turn_s),
        Manoeuvre("turning_35", "turning", 35.0, None, turn_s),
        Manoeuvre("zigzag_10_10", "zigzag", 10.0, 10.0, zz_s),
        Manoeuvre("zigzag_15_15", "zigzag", 15.0, 15.0, zz_s),
        Manoeuvre("speed_steps", "speed", 0.0, None, sp_s),
        Manoeuvre("zigzag_20_20", "zigzag", 20.0, 20.0, zz_s),
    ]


#: Helm of the speed-steps run: a gentle weave (amplitude [deg], period [s]) as a helmsman
#: holding a course by hand, so that the run also carries some yaw excitation.
WEAVE_DEG, WEAVE_PERIOD_S = 5.0, 20.0


def weave_command(t: np.ndarray) -> np.ndarray:
    """Propulsion-angle command [rad] of the speed-steps run at times ``t`` [s]."""
    return math.radians(WEAVE_DEG) * np.sin(2.0 * math.pi * np.asarray(t) / WEAVE_PERIOD_S)


def speed_step_schedule(n0: float, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Shaft-speed command [rps] of the ``speed_steps`` run: n0, then 75 %, 100 %, 85 %, 100 %
    of n0 in equal stages with 3 s linear ramps (throttle moved by hand); times [s]."""
    stage = duration_s / 5.0
    levels = [1.0, 0.75, 1.0, 0.85, 1.0]
    t, n = [0.0], [n0]
    for k in range(1, 5):
        ts = k * stage
        t += [ts, ts + 3.0]
        n += [levels[k - 1] * n0, levels[k] * n0]
    t.append(duration_s + 1.0)
    n.append(n0)
    return np.array(t), np.array(n)


# --- the truth model ---------------------------------------------------------------------------
def lanxin_propeller() -> Any:
    """The Lanxin propeller as a :class:`usvid.models.thrust.Propeller`."""

    return Propeller(**LANXIN_PROPELLER)


def shaft_speed_for(speed: float = LANXIN["speed"], x_l: float = LANXIN_X_L) -> float:
    """Shaft speed n [rps] at which the eq. 37 model holds ``speed`` [m/s] straight ahead:
    solves ``d11 u = T(n, u)`` (Mu et al. 2018 eq. 1 and eq. 17 with u' = 0, v = r = 0)."""


    d11 = float(mu2018_threedof(x_l=x_l).d11)
    prop = lanxin_propeller()
    return float(brentq(lambda n: float(prop.thrust(n, speed)) - d11 * speed, 5.0, 200.0,
                        xtol=1e-10))


def lanxin_model(x_l: float = LANXIN_X_L, speed: float = LANXIN["speed"]) -> Any:
    """The truth :class:`~usvid.models.model.VesselModel`: eq. 37 3-DOF + propeller at the
    10 kn shaft speed + the Mu et al. 2018 servo (second order, 1 s dead time, +-35 deg)."""

    n0 = shaft_speed_for(speed, x_l)
    dyn = mu2018_threedof(x_l=x_l, thrust=lanxin_propeller(), n=n0)
    vessel = Vessel(length=LANXIN["length"], speed=speed, beam=LANXIN["beam"],
                    draft=LANXIN["draft"], displacement=LANXIN["displacement"],
                    block_coefficient=LANXIN["block_coefficient"])
    return VesselModel(dynamics=dyn, servo=SecondOrderServo(**LANXIN_SERVO), vessel=vessel)


def linearised_response(model: Any, speed: float | None = None) -> dict[str, float]:
    """Small-signal r/delta of the 3-DOF model at straight running ``speed`` [m/s].

    Linearising Mu et al. 2018 eq. 17 at (u0, v = r = delta = 0) with T0 = d11 u0:
    ``[v', r'] = A [v, r] + b delta`` with ``A = [[-d22/m22, -(m11/m22) u0], [((m11 - m22)/m33)
    u0, -d33/m33]]``, ``b = [0, x_l T0 /
    m33]``, giving the Nomoto 2nd-order form (Mu et al. 2018 eq. 29) ``K (1 + T3 s) / ((1 + T1
    s)(1 + T2 s))``. Returns K [1/s], T1, T2, T3 [s] and the equivalent first-order ``T = T1 + T2 -
    T3`` [s].
    """
    dyn = getattr(model, "dynamics", model)
    u0 = float(speed if speed is not None else model.vessel.speed)
    m11, m22, m33 = float(dyn.m11), float(dyn.m22), float(dyn.m33)
    d11, d22, d33, x_l = float(dyn.d11), float(dyn.d22), float(dyn.d33), float(dyn.x_l)
    a11, a12 = -d22 / m22, -(m11 / m22) * u0
    a21, a22 = ((m11 - m22) / m33) * u0, -d33 / m33
    b2 = x_l * d11 * u0 / m33
    # r/delta = b2 (s - a11) / (s^2 - (a11 + a22) s + (a11 a22 - a12 a21))
    det = a11 * a22 - a12 * a21
    K = b2 * (-a11) / det
    # (1 + T1 s)(1 + T2 s) = 1 + (-(a11 + a22)/det) s + (1/det) s^2
    s1, p = -(a11 + a22) / det, 1.0 / det
    disc = math.sqrt(max(s1 * s1 - 4.0 * p, 0.0))
    T1, T2 = (s1 + disc) / 2.0, (s1 - disc) / 2.0
    T3 = 1.0 / (-a11)
    return {"K": K, "T1": T1, "T2": T2, "T3": T3, "T": T1 + T2 - T3, "u0": u0}


@dataclass
class CampaignTrial:
    """One generated trial: its manoeuvre, the log files written, and the noise-free truth."""

    manoeuvre: Manoeuvre
    files: dict[str, str] = field(default_factory=dict)
    truth: dict[str, Any] = field(default_factory=dict)


#: The calm-sea sensor suite (Mu et al. 2018 section 2.3): 10 Hz GNSS with metre-level noise,
# heading
#: and gyro at 50 Hz, rudder feedback at 50 Hz, the logger's body velocities at the GNSS rate,
#: propeller speed over NMEA 2000 (10 rpm noise), 2 ms time-stamp jitter.
SENSORS = {
    "gps_rate_hz": 10.0, "gps_sigma_m": 0.05, "speed_sigma_m_s": 0.05,
    "heading_rate_hz": 50.0, "heading_sigma_deg": 0.3,
    "gyro_rate_hz": 50.0, "gyro_sigma_deg_s": 0.2, "gyro_bias_deg_s": 0.0,
    "rudder_rate_hz": 50.0, "rudder_sigma_deg": 0.2, "rpm_sigma": 10.0, "jitter_s": 0.002,
}
#: GNSS position error besides the receiver's white noise: a second-order Gauss-Markov wander
#: per axis (std [m], correlation time [s], :func:`smooth_wander`); metre-level like a
#: standalone receiver, but smooth from fix to fix as real receivers are (white metre noise at
#: 10 Hz, or a first-order process with its white derivative, is not realistic).
GNSS_WANDER_M, GNSS_WANDER_TAU_S = 1.0, 60.0
#: Course-over-ground noise [deg] (receiver Doppler course).
COG_SIGMA_DEG = 0.5
#: Calm sea (Mu et al. 2018 section 2.4: sea state 1, waves 0-0.1 m): rudder-equivalent disturbance
#: std [deg] through the Mu et al. 2018 filter 0.42 s/(s^2 + 0.36 s + 0.37).
CALM_SEA_DIST_DEG = 0.15
#: Straight run before the rudder is put over [s].
APPROACH_S = 5.0
#: UTC time of the first trial (trials follow each other every 10 minutes).
T0_UTC = "2018-04-10T02:00:00+00:00"
#: How the simulation truth of the identified models is defined (shown in the report).
TRUTH_DEFINITION = (
    "3-DOF: the Mu et al. 2018 eq. 37 coefficients the campaign was simulated with (x_l = 3.5 m, "
    "propeller of eq. 1 at the 10 kn shaft speed). Servo: the Mu et al. 2018 servo (omega_n = "
    "sqrt(1.95) rad/s, zeta = 0.853, gain 1, 1 s dead time). Nomoto K, T: the 3-DOF model is "
    "not first order, so its Nomoto 'truth' is the best first-order fit: the output-error "
    "estimator of usvid.identify (the same criterion and manoeuvres as the identification) "
    "applied to noise-free, disturbance-free simulations of the 10/10 and 15/15 zig-zags on "
    "the 3-DOF truth with perfect 50 Hz sensors; the deviation of the identified K, T from it "
    "is what sensor noise, disturbance and logging cost. The yaw-rate-only output-error fit "
    "(10/10 zig-zag) and the small-signal "
    "linearisation at 10 kn (Nomoto 2nd order) are listed with it in run.json. Norrbin: K, T "
    "as Nomoto, n1 = 1, n3 = alpha fitted by least squares to r + alpha r^3 = K delta over "
    "the steady part of noise-free turning tests (Mu et al. 2018 eq. 36)."
)

SPEC_FILES = {
    "nmea0183": ("lanxin_nmea0183.yaml", {
        "reader": "nmea0183", "time_source": "prefix",
        "description": "Lanxin USV NMEA 0183 log: GNSS (GGA/RMC/VTG, 10 Hz), heading HDT, "
                       "rate of turn ROT and propulsion angle RSA (50 Hz)"}),
    "nmea2000": ("lanxin_nmea2000.yaml", {
        "reader": "nmea2000",
        "description": "Lanxin USV NMEA 2000 bus (candump -L): engine rapid update 127488 "
                       "(propeller speed) and rudder order 127245 (commanded propulsion angle)"}),
    "csv": ("lanxin_logger_csv.yaml", {
        "reader": "table", "delimiter": ",", "header": True,
        "description": "Lanxin logger database export (MFC terminal): body velocities u, v",
        "columns": {"t": {"col": "time_s", "unit": "s"}, "u": {"col": "u_m_s", "unit": "m/s"},
                    "v": {"col": "v_m_s", "unit": "m/s"}}}),
}


@dataclass
class Campaign:
    """A generated campaign: trials (with their files), vessel, truth, the sim model."""

    trials: list[CampaignTrial]
    vessel: dict[str, Any]
    truth: dict[str, dict[str, float]]
    truth_extra: dict[str, Any]
    model: Any
    specs: dict[str, str]
    seed: int
    quick: bool
    truth_definition: str = TRUTH_DEFINITION

    @property
    def x_l(self) -> float:
        return float(self.model.dynamics.x_l)

    def manoeuvre(self, name: str) -> Manoeuvre:
        for ct in self.trials:
            if ct.manoeuvre.name == name:
                return ct.manoeuvre
        raise KeyError(name)

    def relocate(self, old: Any, new: Any) -> None:
        """Re-point file paths after the log folder was moved from ``old`` to ``new``."""
        from pathlib import Path

        old, new = str(Path(old)), str(Path(new))
        for ct in self.trials:
            ct.files = {k: v.replace(old, new, 1) for k, v in ct.files.items()}
        self.specs = {k: v.replace(old, new, 1) for k, v in self.specs.items()}

    def summary(self, relative_to: Any = None) -> dict[str, Any]:
        """JSON-able description for ``run.json`` (file paths relative to ``relative_to``)."""
        from pathlib import Path

        def rel(p: str) -> str:
            if relative_to is None:
                return p
            try:
                return str(Path(p).relative_to(Path(relative_to)))
            except ValueError:
                return p

        return {
            "description": (
                "Virtual sea trials of the Lanxin USV (Mu et al. 2018): 3-DOF model of eq. 37, "
                "propeller thrust of eq. 1, second-order servo with 1 s dead time, calm-sea "
                f"disturbance ({CALM_SEA_DIST_DEG} deg rudder-equivalent), sensors: GNSS "
                f"{SENSORS['gps_rate_hz']:g} Hz with {GNSS_WANDER_M:g} m 2nd-order "
                f"Gauss-Markov wander "
                f"({GNSS_WANDER_TAU_S:g} s) + {SENSORS['gps_sigma_m']:g} m white, heading and "
                f"gyro {SENSORS['gyro_rate_hz']:g} Hz, rudder {SENSORS['rudder_rate_hz']:g} Hz, "
                f"propeller speed over NMEA 2000. Seed {self.seed}."),
            "trials": [{"name": ct.manoeuvre.name, "kind": ct.manoeuvre.kind,
                        "delta_deg": ct.manoeuvre.delta_deg, "psi_deg": ct.manoeuvre.psi_deg,
                        "duration_s": ct.manoeuvre.duration_s,
                        "files": [rel(f) for f in ct.files.values()]} for ct in self.trials],
            "truth": self.truth,
            "truth_extra": self.truth_extra,
        }


def _steady_turns(res: Any, t_execute: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean delta [rad] and r [rad/s] over the steady turn of each run of a turning batch
    (:func:`usvid.manoeuvres.detect.steady_turn`, from the execute ``t_execute`` [s])."""
    ch = res.channels
    st = [steady_turn(res.t, ch["psi"][i], t_execute, r=ch["r"][i], delta=ch["delta"][i])
          for i in range(res.batch_size)]
    return np.array([s.delta for s in st]), np.array([s.yaw_rate for s in st])


def norrbin_alpha(K: float, delta: np.ndarray, r: np.ndarray) -> float:
    """Least-squares alpha of ``r + alpha r^3 = K delta`` (Mu et al. 2018 eq. 36) [s^2/rad^2]."""
    r = np.asarray(r, float)
    y = K * np.asarray(delta, float) - r
    return float(np.sum(y * r ** 3) / np.sum(r ** 6))


def campaign_truth(model: Any, quick: bool = False) -> tuple[dict[str, dict[str, float]],
                                                              dict[str, Any]]:
    """Truth parameters of every identified model kind (see :data:`TRUTH_DEFINITION`)."""

    dyn = model.dynamics
    speed = float(model.vessel.speed)
    # the two zig-zags of the programme (10/10 and 15/15), one batch, noise-free: the Nomoto
    # truth is the estimator's own output-error fit to them (perfect sensors)
    amps = np.radians([10.0, 15.0])
    zz = simulate(model, ZigZag(amps, amps, t_start=APPROACH_S),
                  t_end=45.0 if quick else 120.0, dt=0.02, u0=speed)
    est = identify([zz.to_trial(0, name="zigzag_10_10_truth"),
                    zz.to_trial(1, name="zigzag_15_15_truth")], "nomoto1", "oe")
    nom = {"K": float(est.params["K"]), "T": float(est.params["T"]),
           "criterion": "usvid.identify oe"}
    turns = simulate(model, Turning(np.radians([10.0, 15.0, 25.0, 35.0]), t_start=APPROACH_S),
                     t_end=60.0, dt=0.02, u0=speed)
    d_ss, r_ss = _steady_turns(turns, APPROACH_S)
    alpha = norrbin_alpha(nom["K"], d_ss, r_ss)
    lin = linearised_response(model, speed)
    servo = model.servo
    truth = {
        "threedof": {k: float(getattr(dyn, k)) for k in ("m11", "m22", "m33", "d11", "d22",
                                                          "d33")},
        "nomoto1": {"K": nom["K"], "T": nom["T"], "delta0": 0.0},
        "norrbin": {"K": nom["K"], "T": nom["T"], "n1": 1.0, "n3": alpha, "delta0": 0.0},
        "servo": {"omega_n": float(servo.omega_n), "zeta": float(servo.zeta),
                  "gain": float(servo.gain), "delay": float(servo.delay)},
    }
    extra = {"nomoto_linearised": lin, "nomoto_truth_criterion": nom["criterion"],
             "threedof_regression": {k: float(v) for k, v in
                                     dyn.regression_coefficients().items()},
             "steady_turns": {"delta_deg": np.degrees(d_ss).tolist(),
                              "r_deg_s": np.degrees(r_ss).tolist()},
             "shaft_speed_rps": float(dyn.n), "x_l": float(dyn.x_l)}
    return truth, extra


def gauss_markov(t: np.ndarray, sigma: float, tau: float, rng: np.random.Generator
                 ) -> np.ndarray:
    """First-order Gauss-Markov samples at times ``t`` [s]: stationary std ``sigma``,
    correlation time ``tau`` [s] (exact discretisation for uneven steps)."""
    out = np.empty(len(t))
    if len(t) == 0:
        return out
    out[0] = rng.normal(0.0, sigma)
    phi = np.exp(-np.diff(t) / tau)
    w = rng.normal(0.0, 1.0, len(t) - 1) * sigma * np.sqrt(1.0 - phi ** 2)
    for k in range(1, len(t)):  # O(N) recursion over ~1e3 fixes per trial
        out[k] = phi[k - 1] * out[k - 1] + w[k - 1]
    return out


def smooth_wander(t: np.ndarray, sigma: float, tau: float, rng: np.random.Generator
                  ) -> np.ndarray:
    """Second-order Gauss-Markov position wander at times ``t`` [s]: std ``sigma`` [m].

    A first-order Gauss-Markov process has a white-noise derivative: differentiated fix to fix at
    10 Hz, a 1 m / 60 s wander gives about 0.6 m/s of velocity noise, which no receiver shows
    (and which makes body velocities from d(x, y)/dt meaningless). Real GNSS errors drift
    smoothly, so the first-order process is passed once more through the same first-order lag
    ``tau`` (output variance sigma^2 / 2 for equal time constants, hence the factor sqrt(2));
    its derivative is then of order sigma / tau (0.02 m/s for 1 m / 60 s). A burn-in of 5 tau
    starts both stages from their stationary state.
    """
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return np.empty(0)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    burn = t[0] - step * np.arange(int(np.ceil(5.0 * tau / step)), 0, -1)
    tt = np.concatenate([burn, t])
    x = gauss_markov(tt, sigma * math.sqrt(2.0), tau, rng)
    phi = np.exp(-np.diff(tt) / tau)
    y = np.empty_like(x)
    y[0] = 0.0
    for k in range(1, len(tt)):  # the same O(N) recursion as gauss_markov
        y[k] = phi[k - 1] * y[k - 1] + (1.0 - phi[k - 1]) * x[k]
    return y[len(burn):]


def _to_logs(trial: Any, t0_utc: str, truth: tuple[np.ndarray, dict[str, np.ndarray]],
             seed: int) -> tuple[Any, Any, Any, Any]:
    """Split a virtual trial into what each logger records: (NMEA 0183, NMEA 2000, CSV, ROS:
    every channel, as a ROS robot records them).

    Adds the GNSS wander (:data:`GNSS_WANDER_M`) to the positions and a Doppler course over
    ground (true course ``psi + atan2(v, u)`` plus :data:`COG_SIGMA_DEG` noise) at the fixes.
    """


    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    d = trial.data
    t = d["t"].to_numpy()
    lat = np.full(len(t), np.nan)
    lon = np.full(len(t), np.nan)
    cog = np.full(len(t), np.nan)
    ok = np.isfinite(d["x"].to_numpy()) & np.isfinite(d["y"].to_numpy())
    tf = t[ok]
    xn = d["x"].to_numpy()[ok] + smooth_wander(tf, GNSS_WANDER_M, GNSS_WANDER_TAU_S, rng)
    ye = d["y"].to_numpy()[ok] + smooth_wander(tf, GNSS_WANDER_M, GNSS_WANDER_TAU_S, rng)
    la, lo, _ = pymap3d.ned2geodetic(xn, ye, 0.0, ORIGIN_LAT_DEG, ORIGIN_LON_DEG, 0.0)
    lat[ok], lon[ok] = la, lo
    tt, ch = truth
    course = np.unwrap(ch["psi"] + np.arctan2(ch["v"], ch["u"]))
    cog[ok] = (np.interp(tf, tt, course)
               + rng.normal(0.0, math.radians(COG_SIGMA_DEG), tf.size)) % (2.0 * math.pi)
    meta = {"t0_utc": t0_utc}

    def sub(cols: dict[str, np.ndarray]) -> Any:
        df = pd.DataFrame({"t": t, **cols})
        keep = np.zeros(len(t), bool)
        for c in cols:
            keep |= np.isfinite(df[c].to_numpy(dtype=float))
        return Trial(data=df.loc[keep].reset_index(drop=True), name=trial.name, meta=meta)

    col = {c: d[c].to_numpy(dtype=float) for c in d.columns}
    nav = {"lat": lat, "lon": lon, "U": col["U"], "cog": cog, "psi": col["psi"], "r": col["r"],
           "delta": col["delta"]}
    n0183 = sub(nav)
    n2k = sub({"n": col["n"], "delta_cmd": col["delta_cmd"]})
    csv = sub({"u": col["u"], "v": col["v"]})
    # a ROS robot records the same sensors on its topics (no NMEA quantisation)
    ros = sub({**nav, "n": col["n"], "delta_cmd": col["delta_cmd"], "u": col["u"],
               "v": col["v"]})
    return n0183, n2k, csv, ros


def _csv_text(trial: Any) -> str:
    d = trial.data
    lines = ["time_s,u_m_s,v_m_s"]
    for t, u, v in zip(d["t"].to_numpy(), d["u"].to_numpy(), d["v"].to_numpy(), strict=True):
        if np.isfinite(u) and np.isfinite(v):
            lines.append(f"{t:.6f},{u:.4f},{v:.4f}")
    return "\n".join(lines) + "\n"


def generate_campaign(out_dir: Any, seed: int = 1, quick: bool = False,
                      ros2_bag: bool = False) -> Campaign:
    """Simulate the programme and write its log files into ``out_dir`` (created).

    Per trial ``NAME.nmea`` (NMEA 0183), ``NAME.candump`` (NMEA 2000, ``candump -L``) and
    ``NAME.csv`` (logger export), plus the three format specs ``lanxin_*.yaml``. With
    ``ros2_bag`` (needs the ``usvid[ros]`` extra) the first zig-zag is also recorded as a ROS 2
    bag ``NAME_ros2/`` (MCAP storage, topics of the ``ros2_usv`` preset, every sensor channel;
    ``files["ros2"]``). Deterministic for a given ``seed`` (disturbance and sensor noise are
    seeded; file times are fixed).
    """



    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model = lanxin_model()
    speed = float(model.vessel.speed)
    prog = programme(quick)
    specs = {}
    for key, (fname, spec) in SPEC_FILES.items():
        spec = dict(spec)
        spec["vessel"] = {"length": LANXIN["length"], "speed": speed, "beam": LANXIN["beam"],
                          "draft": LANXIN["draft"], "extra": LANXIN_PARTICULARS}
        specs[key] = str(write_atomic(out / fname, yaml.safe_dump(spec, sort_keys=False)))
    sensors = SensorModel(**SENSORS)
    results = {}
    turns = [m for m in prog if m.kind == "turning"]
    zigs = [m for m in prog if m.kind == "zigzag"]
    dist = Disturbance(math.radians(CALM_SEA_DIST_DEG), seed=seed)
    if turns:
        res = simulate(model, Turning(np.radians([m.delta_deg for m in turns]),
                                      t_start=APPROACH_S),
                       t_end=max(m.duration_s for m in turns), dt=0.02, u0=speed, seed=seed,
                       disturbance=dist)
        for i, m in enumerate(turns):
            results[m.name] = (res, i)
    if zigs:
        res = simulate(model, ZigZag(np.radians([m.delta_deg for m in zigs]),
                                     np.radians([m.psi_deg for m in zigs]), t_start=APPROACH_S),
                       t_end=max(m.duration_s for m in zigs), dt=0.02, u0=speed,
                       seed=seed + 1000, disturbance=dist)
        for i, m in enumerate(zigs):
            results[m.name] = (res, i)
    for m in (m for m in prog if m.kind == "speed"):
        ts, ns = speed_step_schedule(float(model.dynamics.n), m.duration_s)
        tg = np.arange(0.0, m.duration_s + 1.0, 0.1)  # 10 Hz command table (linear interp.)
        res = simulate(model, Commanded(tg, delta_cmd=weave_command(tg), n=np.interp(tg, ts, ns)),
                       t_end=m.duration_s, dt=0.02, u0=speed, seed=seed + 2000,
                       disturbance=dist)
        results[m.name] = (res, 0)
    t0 = datetime.fromisoformat(T0_UTC)
    trials = []
    for k, m in enumerate(prog):
        res, i = results[m.name]
        vt = virtual_trial(res, sensors, seed=seed * 100 + k, i=i, name=m.name)
        vt = vt.slice_time(0.0, m.duration_s, name=m.name)
        t0_utc = (t0 + timedelta(minutes=10 * k)).isoformat()
        n0183, n2k, csv, ros = _to_logs(vt, t0_utc, run_channels(res, i), seed * 100 + k)
        files = {
            "nmea0183": str(write_nmea0183(n0183, out / f"{m.name}.nmea", t0_utc=t0_utc)),
            "nmea2000": str(write_candump(n2k, out / f"{m.name}.candump", t0_utc=t0_utc)),
            "csv": str(write_atomic(out / f"{m.name}.csv", _csv_text(csv))),
        }
        if ros2_bag and m.kind == "zigzag" and not any("ros2" in t.files for t in trials):
            files["ros2"] = str(write_rosbag(ros, out / f"{m.name}_ros2", storage="mcap",
                                             t0_utc=t0_utc))
        trials.append(CampaignTrial(m, files, {"t0_utc": t0_utc}))
    truth, extra = campaign_truth(model, quick)
    vessel = {"length": LANXIN["length"], "speed": speed, "beam": LANXIN["beam"],
              "draft": LANXIN["draft"], "displacement": LANXIN["displacement"],
              "block_coefficient": LANXIN["block_coefficient"], "x_l": LANXIN_X_L,
              "propeller_D": LANXIN_PROPELLER["D"]}
    return Campaign(trials, vessel, truth, extra, model, specs, seed, quick)


def read_campaign_trial(ct: CampaignTrial, specs: dict[str, str] | None = None) -> Any:
    """Read one trial's three log files with :mod:`usvid.io` and merge them on absolute time.

    Each reader returns seconds since its own first record and ``meta["t0_utc"]``; the CSV
    export's time is seconds since the trial's t0. The merged trial has the union of time
    stamps (NaN where a channel has no sample), the readers' rejected counts summed, and their
    findings concatenated (:func:`usvid.prep.merge_trials`).
    """


    files = ct.files
    folder = Path(files["nmea0183"]).parent
    spec_paths = specs or {k: str(folder / v[0]) for k, v in SPEC_FILES.items()}
    a = read_nmea0183(files["nmea0183"], load_spec(spec_paths["nmea0183"]))
    b = read_candump(files["nmea2000"], load_spec(spec_paths["nmea2000"]))
    c = read_table(files["csv"], load_spec(spec_paths["csv"]))
    # the CSV export counts seconds from the trial's t0; the NMEA readers carry their own epoch
    return merge_trials([a, b, c], t0_utc=ct.truth["t0_utc"], name=ct.manoeuvre.name)
