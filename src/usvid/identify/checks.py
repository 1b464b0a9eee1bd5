"""Honest identification: the data are checked before a fit, the model after it.

Before fitting (:func:`check_data`), a trial is refused (:class:`IdentificationError` naming the
trial, the channel and the statistic) when

* it was not under way: the median speed over the trial is below :data:`MIN_SPEED` [m/s], and
  the vessel was above it for less than :data:`~usvid.prep.under_way.MIN_MOVING_S` or a
  quarter of the trial (:attr:`usvid.prep.under_way.UnderWay.made_way`: a run from rest whose
  turns are slower than MIN_SPEED is under way)
  (:func:`usvid.prep.under_way.under_way`, the one definition: a logged ``U``, ``sog`` or
  ``u``, ``v``; a speed derived from the positions only when none is logged: GNSS noise at rest
  makes a derived speed of a moored boat look like motion);
* it tells no speed at all (no speed channel, no positions) and the format spec declares none
  (``vessel.speed``): a bench or dock record with a moving rudder looks the same as a basin's
  rudder and heading record; the user who knows it was under way says so by its speed;
* the heading does not respond: it stays within :data:`MIN_HEADING_RANGE` [rad] over the whole
  trial (a constant heading, a compass stuck at one value);
* the heading is noise: its lag-1 circular autocorrelation (:func:`heading_autocorrelation`)
  is below :data:`MIN_HEADING_AUTOCORR` (successive samples of a measured heading follow the
  vessel's inertia; white noise, a random compass, or another quantity mapped as the heading
  do not).

The needed channels missing or without a finite sample, and a constant rudder (no excitation),
are refused where the series are built (:mod:`usvid.identify.series`) and by the estimator.

After fitting (:func:`check_model`), the model identification returns must

* explain its own training data: the windowed replays reproduce at least :data:`MIN_R2` of the
  heading's variance (R^2; a fit to noise explains nothing);
* replay the training trials as a free run without diverging (both replays run each trial
  in the conditions it was fitted in: its logged wind and the current and force biases
  estimated for it, the estimator's ``fit_``);
* simulate the standard manoeuvres inside the training envelope (:func:`envelope`): turning
  circles to both sides at the largest steering angle of the training data, and the standard
  zig-zags (10/10, 20/20) whose amplitude the training data reached (else one at the largest
  angle), from the training approach speed: no divergence, the turn to the side of the rudder
  (a positive rudder angle makes r positive: K > 0 for an ordinary vessel) and, for kinds with
  a surge equation, a positive speed; and, when the training trials start from (or come to)
  rest and the kind has a surge equation, starts from rest with the rudder amidships and at
  the largest angle to each side (:func:`_rest_check`): the envelope's lowest speed is 0
  there, and a model that diverges as it gathers way is confident and wrong about a part of
  its own training data.

A failed check is a :class:`Check` with the reason and what to do; the estimator refuses such a
model (``checks="error"``, the default) or keeps the failures in the model file's
``identification.checks`` (``checks="record"``: ``usvid identify --accept-failed-checks``).

Units: SI and radians inside; messages in degrees and m/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.manoeuvres.logic import ZigZag
from usvid.models.model import VesselModel
from usvid.models.registry import kind_of
from usvid.prep.under_way import MIN_SPEED, speed, under_way
from usvid.sim.physics import turn_probe
from usvid.sim.runs import default_t_end
from usvid.sim.simulate import approach_speed, simulate
from usvid.trial import Trial

__all__ = ["Check", "ChecksFailed", "Envelope", "MIN_HEADING_RANGE", "MIN_R2", "MIN_SPEED",
           "MIN_HEADING_AUTOCORR", "check_data", "check_model", "envelope", "failed",
           "heading_autocorrelation", "mass_checks", "refusal", "trial_speed"]

#: Smallest range of the heading [rad] over a trial that responds to its steering (0.5 deg).
MIN_HEADING_RANGE = math.radians(0.5)
#: Smallest lag-1 circular autocorrelation of a heading that is a measurement, not noise [-]
#: (white noise: 0 +- 2/sqrt(N); a zig-zag's heading at 1-50 Hz with a compass's 1 deg noise:
#: above 0.9; below 0.3 most of the heading's variance changes from one sample to the next).
MIN_HEADING_AUTOCORR = 0.3
#: Smallest share of the heading's variance the windowed replays of the training data must
#: explain (R^2 of the heading).
MIN_R2 = 0.5
#: Largest steering angle of the standard manoeuvres [rad] (the rudder's usual limit, 35 deg).
MAX_CHECK_ANGLE = math.radians(35.0)


class ChecksFailed(IdentificationError):
    """The identified model fails its checks; ``reason`` the failures alone (one line)."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(message)
        self.reason = reason or message


@dataclass(frozen=True)
class Check:
    """One check of an identified model: ``name``, ``passed``, ``message`` (the reason and
    what to do when it failed)."""

    name: str
    passed: bool
    message: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def failed(checks: Sequence[Check]) -> list[Check]:
    """The checks that failed."""
    return [c for c in checks if not c.passed]


# -- before the fit ------------------------------------------------------------------------------
def trial_speed(trial: Trial) -> tuple[float | None, str]:
    """The median speed [m/s] of a trial and the channel it is read from
    (:func:`usvid.prep.under_way.under_way`, the one definition); (None, "") when the trial
    has no speed."""
    uw = under_way(trial)
    return uw.median_speed, uw.source if uw.known else ""


def heading_autocorrelation(psi: np.ndarray) -> float:
    """Lag-1 autocorrelation [-] of a heading ``psi`` [rad] as the unit vector
    ``z_k = (cos psi_k, sin psi_k)`` (free of wrapping: a compass that jumps at random is no
    smooth unwrapped walk):
    ``rho = sum_k (z_k - zbar).(z_{k+1} - zbar) / sum_k |z_k - zbar|^2`` (the sample
    autocorrelation at lag 1, Box and Jenkins 1976, of a vector series). NaN samples are
    dropped; NaN when fewer than three remain or the heading is constant."""
    psi = np.asarray(psi, dtype=float)
    psi = psi[np.isfinite(psi)]
    if psi.size < 3:
        return math.nan
    z = np.stack([np.cos(psi), np.sin(psi)])
    z -= z.mean(axis=1, keepdims=True)
    den = float(np.sum(z * z))
    if den <= 1e-24 * psi.size:  # deviations below 1e-12: rounding of a constant heading
        return math.nan
    return float(np.sum(z[:, 1:] * z[:, :-1]) / den)


def check_data(trials: Sequence[Trial], kind_name: str) -> None:
    """Refuse trials that cannot be identified from (module docstring): not under way, or a
    heading that does not respond. Raises :class:`IdentificationError` naming the trial, the
    channel and the statistic."""
    for tr in trials:
        name = tr.name or (tr.sources[0] if tr.sources else "?")
        uw = under_way(tr)
        if uw.made_way is False:
            raise IdentificationError(
                f"trial {name} was not under way: {uw.reason()}; a {kind_name} model needs "
                "manoeuvres at speed (a boat at the dock or drifting says nothing about its "
                "manoeuvring)")
        if not uw.known and (tr.vessel is None or tr.vessel.speed is None):
            raise IdentificationError(
                f"trial {name}: {uw.reason()} (a bench or dock record with a moving rudder "
                f"looks the same), and the format spec gives no vessel.speed; a {kind_name} "
                "model needs manoeuvres at speed. If the vessel was under way, give its "
                "approach speed as vessel.speed [m/s] in the format spec's vessel block (or "
                "log a speed or positions)")
        if tr.has("psi"):
            psi = tr["psi"]
            psi = psi[np.isfinite(psi)]
            rng = float(np.max(psi) - np.min(psi))
            if rng < MIN_HEADING_RANGE:
                raise IdentificationError(
                    f"trial {name}: channel 'psi' is constant (range {math.degrees(rng):.3g} "
                    f"deg over {len(psi)} samples): the heading does not respond to the "
                    "steering, nothing to identify (check the heading's column and sign in the "
                    "format spec)")
            rho = heading_autocorrelation(psi)
            if rho < MIN_HEADING_AUTOCORR:
                raise IdentificationError(
                    f"trial {name}: channel 'psi' is noise (lag-1 autocorrelation {rho:.2f} "
                    f"over {len(psi)} samples, below {MIN_HEADING_AUTOCORR:g}): successive "
                    "headings are unrelated, as no vessel's heading is; nothing to identify "
                    "(check the heading's column and unit in the format spec)")


# -- after the fit -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Envelope:
    """What the training data covered: the largest steering angle ``delta_max`` [rad] (a
    rudder, or the thrusters' rudder-equivalent steering), the approach speed ``speed``
    [m/s]."""

    delta_max: float
    speed: float
    #: the training trials start from (or come to) rest: a speed below MIN_SPEED [m/s]
    from_rest: bool = False


def envelope(model: VesselModel, trials: Sequence[Trial]) -> Envelope | None:
    """The training envelope (:class:`Envelope`): the 99.5th percentile of |delta| over the
    training trials (thrusters: |n_port - n_stbd| / (2 steer_gain) with the model's steering
    gain), at most 35 deg and at least 1 deg, the model's approach speed, and whether a trial
    is at rest somewhere (its speed, :func:`usvid.prep.under_way.speed`, below
    :data:`MIN_SPEED`); None when the trials have no steering the model can be driven with."""
    devs = []
    gain = getattr(model.dynamics, "steer_gain", None)
    for tr in trials:
        if tr.has("delta"):
            d = tr["delta"]
            devs.append(np.abs(d[np.isfinite(d)]))
        elif tr.has("n_port") and tr.has("n_stbd") and isinstance(gain, int | float) \
                and gain > 0:
            c = tr["n_port"] - tr["n_stbd"]
            devs.append(np.abs(c[np.isfinite(c)]) / (2.0 * gain))
    if not devs:
        return None
    dmax = float(np.percentile(np.concatenate(devs), 99.5))
    dmax = min(max(dmax, math.radians(1.0)), MAX_CHECK_ANGLE)
    try:
        speed_ = float(approach_speed(model, None))
    except UsvidError:
        return None
    rest = False
    for tr in trials:
        U, _ = speed(tr)
        if U is not None and np.any(U[np.isfinite(U)] < MIN_SPEED):
            rest = True
            break
    return Envelope(round(math.degrees(dmax), 1) * math.pi / 180.0, speed_, rest)


def _run(model: VesselModel, logic: Any, u0: float) -> Any:
    t_end = default_t_end(model, u0)
    with np.errstate(all="ignore"):
        return simulate(model, logic, t_end=t_end, dt=0.02, u0=u0,
                        channels=("psi", "r", "u", "v", "delta"))


def _rest_check(model: VesselModel, env: Envelope) -> Check:
    """Starts from rest (u = v = r = 0) at the model's nominal propulsion with the rudder
    amidships and at the envelope's largest angle to each side, each for the turning test's
    duration at the approach speed: the model must stay finite (it may swing off: a
    course-unstable hull does). At low speed v' = v/U and r' = r L/U are large, where the
    hull's cubic terms decide: a wrong sign there diverges as the vessel gathers way."""
    name = "start from rest"
    t_end = default_t_end(model, env.speed)
    a_deg = math.degrees(env.delta_max)
    for delta in (0.0, env.delta_max, -env.delta_max):
        how = ("with the rudder amidships" if delta == 0.0 else
               f"with the rudder at {math.copysign(a_deg, delta):+.1f} deg")
        try:
            probe = turn_probe(model, delta, 0.0, t_end=t_end, dt=0.02)
        except UsvidError as exc:
            return Check(name, False, f"a start from rest {how} cannot be simulated ({exc})")
        if probe.diverged:
            t_bad = probe.diverged_at if probe.diverged_at is not None else math.nan
            return Check(name, False, (
                f"the model diverges {t_bad:.0f} s after a start from rest {how} (inside the "
                "training envelope: the training runs start from or come to rest): its hull "
                "forces at low speed are not physical"))
    return Check(name, True)


def _manoeuvre_checks(model: VesselModel, env: Envelope) -> list[Check]:
    kind = kind_of(model.dynamics)
    out = []
    if env.from_rest and not kind.constant_speed:
        out.append(_rest_check(model, env))
    a_deg = math.degrees(env.delta_max)
    for side in (1, -1):
        name = f"turning circle {side * a_deg:+.1f} deg"
        where = (f"the turning circle at {side * a_deg:+.1f} deg rudder (inside the training "
                 f"envelope: up to {a_deg:.1f} deg at {env.speed:.3g} m/s)")
        try:
            probe = turn_probe(model, side * env.delta_max, env.speed,
                               t_end=default_t_end(model, env.speed), dt=0.02)
        except UsvidError as exc:
            out.append(Check(name, False, f"{where} cannot be simulated ({exc})"))
            continue
        if probe.diverged:
            t_bad = probe.diverged_at if probe.diverged_at is not None else math.nan
            out.append(Check(name, False, f"the model diverges in {where} after {t_bad:.0f} s"))
            continue
        if probe.wrong_side or (probe.side_turn is None and side * probe.turn <= 0):
            out.append(Check(name, False, (
                f"with the rudder at {side * a_deg:+.1f} deg the model turns to the other side "
                f"({math.degrees(probe.turn):+.0f} deg): a positive rudder angle makes r "
                "positive")))
            continue
        if not kind.constant_speed and probe.astern:
            out.append(Check(name, False, f"the surge speed in {where} falls to "
                                          f"{probe.u_end:.3g} m/s: the model stops or runs "
                                          "astern"))
            continue
        out.append(Check(name, True))
    amps = [a for a in (10.0, 20.0) if a <= a_deg + 1e-9] or [a_deg]
    for a in amps:
        name = f"zig-zag {a:g}/{a:g}"
        try:
            res = _run(model, ZigZag(math.radians(a), math.radians(a)), env.speed)
            ok = res.success and bool(np.all(np.isfinite(res["psi"][0])))
        except UsvidError as exc:
            out.append(Check(name, False, f"the {name} cannot be simulated ({exc})"))
            continue
        out.append(Check(name, ok, "" if ok else f"the model diverges in the {name} zig-zag "
                                                 f"(inside the training envelope: up to "
                                                 f"{a_deg:.1f} deg at {env.speed:.3g} m/s)"))
    return out


def check_model(model: VesselModel, trials: Sequence[Trial], fit: dict[str, Any]
                ) -> list[Check]:
    """The checks of an identified model (module docstring) on its training ``trials`` and
    fit metrics ``fit`` (the estimator's ``fit_``: windowed metrics per output and
    ``free_run``)."""
    out = []
    psi = fit.get("psi") if isinstance(fit.get("psi"), dict) else None
    if psi is not None:
        r2 = psi.get("r2")
        ok = isinstance(r2, int | float) and math.isfinite(r2) and r2 >= MIN_R2
        out.append(Check("explains the heading", ok, "" if ok else (
            f"the model explains R^2 = {r2:.3g} of the heading's variation in its own training "
            f"data (windowed replays, {fit.get('window_s', 0):g} s; at least {MIN_R2:g} "
            "needed): the steering does not explain the yaw (noise, no response, or the wrong "
            "channels)")))
    free = fit.get("free_run") or {}
    bad = [ch for ch, m in free.items() if isinstance(m, dict)
           and not math.isfinite(float(m.get("rmse", math.nan)))]
    out.append(Check("free run", not bad, "" if not bad else (
        f"the free run of the training data diverges ({', '.join(bad)} not finite): the model "
        "cannot replay the data it was fitted to")))
    out += mass_checks(model)
    env = envelope(model, trials)
    if env is not None:
        out += _manoeuvre_checks(model, env)
    return out


#: Plausible ranges of the rigid-body-plus-added masses of a Fossen-form model relative to the
#: vessel's own mass (yaw: its yaw inertia): (parameter, particular, lowest, highest ratio).
#: Added mass is positive, so each is at least the rigid body's (0.8: a declared mass 20 % off);
#: in surge it is a small fraction of the mass, in sway and yaw up to about the rigid body's
#: (Fossen 2021, ch. 6.4: e.g. a surge added mass of 5-10 %), so the highest ratios (2, 4, 5)
#: leave room for a thrust map a factor 2 off and refuse only what no hull has.
MASS_RATIOS = (("m11", "mass", 0.8, 2.0), ("m22", "mass", 0.8, 4.0),
               ("m33", "yaw_inertia", 0.5, 5.0))
#: Particulars (format spec ``vessel.extra``) that declare the thrust in newtons: with them
#: the identified masses are in kg and comparable with the vessel's.
THRUST_IN_NEWTONS = ("thrust_per_command", "thrust_full")


def mass_checks(model: VesselModel) -> list[Check]:
    """The identified masses (``m11``, ``m22`` [kg], ``m33`` [kg m^2]) against the vessel's
    mass and yaw inertia (:data:`MASS_RATIOS`), for a model whose thrust is declared in newtons
    (:data:`THRUST_IN_NEWTONS`; in command units the masses are in those units too). A surge
    mass many times the boat's says the logged commands overstate the thrust that drove it, or
    the surge was not identified (e.g. the least-squares inverse mass 1/m11 at its lower
    bound): refused, with the reason, rather than simulated."""
    v = model.vessel
    dyn = model.dynamics
    if v is None or not hasattr(dyn, "m11"):
        return []
    extra = dict(v.extra or {})
    if not any(extra.get(k) is not None for k in THRUST_IN_NEWTONS):
        return []
    out = []
    for name, part, lo, hi in MASS_RATIOS:
        ref = v.mass if part == "mass" else extra.get(part)
        val = getattr(dyn, name, None)
        if ref is None or val is None or not float(ref) > 0:
            continue
        ratio = float(val) / float(ref)
        ok = math.isfinite(ratio) and lo <= ratio <= hi
        unit = "kg" if part == "mass" else "kg m^2"
        out.append(Check(f"{name} against the vessel's {part}", ok, "" if ok else (
            f"{name} = {float(val):.4g} {unit} is {ratio:.3g} times the vessel's {part} "
            f"({float(ref):.4g} {unit}; a hull's is {lo:g}-{hi:g} times): the thrust the logged "
            "commands declare (N) is not the thrust that drove the boat, or the data do not "
            f"determine {name}; check the thrust map (vessel.extra.{THRUST_IN_NEWTONS[0]}) and "
            "the logs (commands that do not move the boat)")))
    return out


def refusal(kind: str, method: str, checks: Sequence[Check]) -> str:
    """The one-line reason a model is not returned, and what to do."""
    bad = failed(checks)
    return (f"the identified {kind} model ({method}) fails its checks: "
            + "; ".join(c.message for c in bad)
            + ". It is not written: try another --method or --model, more or richer training "
            "data (turns to both sides, the angles you will simulate), or give "
            "--accept-failed-checks to write it anyway (the failures are kept in its "
            "identification.checks)")
