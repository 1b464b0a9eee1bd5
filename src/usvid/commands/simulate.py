"""CLI: ``usvid simulate zigzag|turning|course-keeping MODEL.json ...``.

Runs a standard manoeuvre on a model file and prints its metrics (a table, or with ``--json`` one
JSON object whose keys are the ``ARCHITECTURE.md`` contract, followed by extras):

- ``zigzag``: ``overshoot_deg`` (list, first first), ``period_s``, ``initial_turning_time_s``,
  ``time_to_check_yaw_s`` (+ ``imo`` for a 10/10 or 20/20 test when L and U are known);
- ``turning``: ``advance_m``, ``transfer_m``, ``tactical_diameter_m``, ``steady_diameter_m``,
  ``steady_yaw_rate_rad_s``, ``steady_speed_m_s`` (+ ``imo`` when L is known and the rudder is
  the maximum angle, 35 deg or the servo limit: MSC.137(76) 5.2.1);
- ``course-keeping``: ``itae`` [rad s^2], ``iae`` [rad s] over the horizon ``horizon_s``
  (= ``--t-end``, the run is 0 .. t_end), ``max_rudder_deg``.

Every manoeuvre takes the environment (:func:`usvid.commands._common.environment_of`):
``--wind-speed`` [m/s], ``--wind-dir-deg`` (from), ``--current-speed`` [m/s],
``--current-dir-deg`` (towards), ``--hs`` [m], ``--tp`` [s], ``--wave-dir-deg`` (from); ``--json``
echoes it as ``environment`` (null in calm water).

The runs are :mod:`usvid.sim.runs`; metric definitions :mod:`usvid.manoeuvres.metrics`; IMO
criteria :mod:`usvid.manoeuvres.imo`.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import (
    Controller,
    CurrentDirOpt,
    CurrentSpeedOpt,
    HsOpt,
    TpOpt,
    WaveDirOpt,
    WindDirOpt,
    WindSpeedOpt,
    check_disturbance_deg,
    check_dt,
    check_gain,
    check_psi_deg,
    check_rps,
    check_rudder_deg,
    check_seed,
    check_speed,
    check_steps,
    check_t_end,
    check_target_deg,
    environment_of,
)
from usvid.errors import SimulationError, UsvidError


class Side(StrEnum):
    starboard = "starboard"
    port = "port"


JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
ModelArg = Annotated[Path, typer.Argument(help="Model file (JSON, usvid_model: 1).",
                                          show_default=False)]
DtOpt = Annotated[float, typer.Option("--dt", help="Integration step [s].")]
SpeedOpt = Annotated[float | None, typer.Option(
    "--speed", help="Approach speed [m/s] (default: the model's vessel.speed).")]
RpsOpt = Annotated[float | None, typer.Option(
    "--rps", help="Shaft speed [rps] during the manoeuvre, for kinds with a propeller (mmg, "
    "threedof; default: the model's nominal n).")]


def _load(path: Path) -> Any:
    from usvid.io.modelfile import load_model

    return load_model(path)


def _speed(model: Any, speed: float | None, path: Path) -> float:
    """The approach speed [m/s] (:func:`usvid.sim.simulate.approach_speed`: ``--speed``, else
    the model's vessel.speed, else its kind's straight-line speed), checked."""
    from usvid.sim.simulate import approach_speed

    if speed is not None:
        return float(check_speed(speed))
    try:
        u0 = approach_speed(model, None)
    except SimulationError:
        raise UsvidError(f"{path.name}: vessel.speed is not given; pass --speed [m/s]") from None
    check_speed(u0, f"{path.name}: vessel.speed (or --speed)")
    return float(u0)


def _with_rps(model: Any, rps: float | None, path: Path) -> Any:
    """The model with its nominal shaft speed ``n`` set to ``--rps`` [rps] (checked already)."""
    if rps is None:
        return model
    if "n" not in {p.name for p in model.dynamics.param_specs()}:
        raise UsvidError(f"--rps: {path.name} is a {model.kind} model, which has no shaft speed "
                         "input (kinds with one: mmg, threedof)")
    model.dynamics = model.dynamics.replace(n=float(rps))
    return model


def _rps_of(model: Any) -> float | None:
    """The nominal shaft speed [rps] of a model with one (None otherwise)."""
    n = getattr(model.dynamics, "n", None)
    return None if n is None or hasattr(n, "__len__") else float(n)


def _setup(model_path: Path, dt: float, speed: float | None, *, t_end: float | None = None,
           rps: float | None = None, delta_deg: float | None = None) -> tuple[Any, float]:
    """Check ``--dt``, ``--speed`` (and a given ``--t-end``), load the model file, set its shaft
    speed to ``--rps`` and check its physics (:func:`usvid.commands._physics.check_physics`,
    probed at the manoeuvre's rudder angle ``delta_deg`` when it has one); returns
    (model, u0 [m/s])."""
    from usvid.commands._physics import check_physics
    from usvid.sim.runs import default_t_end

    check_dt(dt)
    check_t_end(t_end)
    check_speed(speed)
    check_rps(rps)
    model = _with_rps(_load(model_path), rps, model_path)
    u0 = _speed(model, speed, model_path)
    run = t_end if t_end is not None else default_t_end(model, u0)
    check_steps(run, dt, "--t-end" if t_end is not None else f"the run ({run:g} s, from the "
                "model; --t-end)")
    check_physics(model, model_path, u0, dt, duration=run,
                  setting=f"--rps {rps:g}" if rps is not None else "",
                  angle=None if delta_deg is None else math.radians(abs(delta_deg)))
    return model, u0


def _no_metrics(model_path: Path, what: str, t_end: float | None, te: float) -> SimulationError:
    """The error of a manoeuvre whose metrics cannot be computed from the run."""
    fix = (f"give a longer --t-end (the run was {te:g} s)" if t_end is not None else
           f"the run was extended to {te:g} s; check the model and --speed")
    return SimulationError(f"{model_path.name}: {what}; {fix}")


def _env_json(res: Any) -> dict[str, Any] | None:
    """The ``environment`` key of ``--json``: the environment the run had (its inputs, the wind
    model chosen with its reason and assumptions, the rudder equivalent of a response kind, the
    sea state's drift coefficients), None in calm water."""
    return res.meta.get("environment")


def _env_rows(env: dict[str, Any] | None) -> list[tuple[str, Any, str]]:
    """Table rows of the environment (none in calm water)."""
    if not env:
        return []
    w, c, s = env.get("wind") or {}, env.get("current") or {}, env.get("waves")
    rows: list[tuple[str, Any, str]] = [
        ("wind speed (from)", f"{_fmt(w.get('speed_m_s'))} ({_fmt(w.get('direction_from_deg'))}"
         " deg)", "m/s"),
        ("current speed (towards)", f"{_fmt(c.get('speed_m_s'))} "
         f"({_fmt(c.get('direction_towards_deg'))} deg)", "m/s")]
    if w.get("model"):
        rows.append(("wind-load model", f"{w['model']}: {w['reason']}", ""))
        rows += [("assumed", a, "") for a in w.get("assumed", [])]
    if s:
        rows.append(("waves Hs, Tp (from)", f"{_fmt(s['hs_m'])} m, {_fmt(s['tp_s'])} s "
                     f"({_fmt(s['direction_from_deg'])} deg)", ""))
    return rows


def _output(out: dict[str, Any], as_json: bool, title: str, rows: list[tuple[str, Any, str]],
            check: Any = None) -> None:
    """Print the command's result: ``out`` as one JSON object, or ``rows`` (plus the IMO
    criteria of ``check`` and the environment) as a table."""
    from usvid.commands._common import emit_json

    if as_json:
        emit_json(out)
        return
    _print_table(title, rows + (_imo_rows(check) if check else [])
                 + _env_rows(out.get("environment")))


def _print_table(title: str, rows: list[tuple[str, Any, str]]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    table.add_column("unit")
    for name, value, unit in rows:
        table.add_row(name, _fmt(value), unit)
    Console().print(table)


def _fmt(v: Any) -> str:
    if isinstance(v, (list, tuple)):
        return ", ".join(_fmt(x) for x in v) if v else "-"
    if isinstance(v, bool) or v is None:
        return "-" if v is None else ("pass" if v else "FAIL")
    if isinstance(v, float):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    return str(v)


def _imo_rows(check: Any) -> list[tuple[str, Any, str]]:
    rows = []
    for c in check.criteria:
        verdict = "-" if c.passed is None else ("pass" if c.passed else "FAIL")
        rows.append((f"IMO {c.name}", f"{_fmt(c.value)} <= {_fmt(c.limit)}: {verdict}", c.unit))
    return rows


# ---------------------------------------------------------------------------------------------
# typer commands
# ---------------------------------------------------------------------------------------------
sim_app = typer.Typer(name="simulate", no_args_is_help=True, add_completion=False,
                      rich_markup_mode=None,
                      help="Simulate a standard manoeuvre on a model file and print its metrics.")


@sim_app.command("zigzag")
def zigzag_cmd(
    model_path: ModelArg,
    delta_deg: Annotated[float, typer.Option("--delta-deg", help="Rudder amplitude [deg].")] = 10.0,
    psi_deg: Annotated[float | None, typer.Option(
        "--psi-deg", help="Switching heading deviation [deg] (default: --delta-deg).")] = None,
    first: Annotated[Side, typer.Option("--first", help="Side of the first rudder.")] =
        Side.starboard,
    t_end: Annotated[float | None, typer.Option(
        "--t-end", help="Simulated time [s] (default: long enough for 4 reversals).")] = None,
    dt: DtOpt = 0.02,
    speed: SpeedOpt = None,
    rps: RpsOpt = None,
    wind_speed: WindSpeedOpt = None,
    wind_dir_deg: WindDirOpt = None,
    current_speed: CurrentSpeedOpt = None,
    current_dir_deg: CurrentDirOpt = None,
    hs: HsOpt = None,
    tp: TpOpt = None,
    wave_dir_deg: WaveDirOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Zig-zag test: overshoot angles, period, initial turning time, time to check yaw."""
    from usvid.manoeuvres.imo import imo_zigzag_check, zigzag_kind
    from usvid.sim.runs import run_zigzag

    check_rudder_deg(delta_deg)
    check_psi_deg(psi_deg)
    env = environment_of(wind_speed, wind_dir_deg, current_speed, current_dir_deg, hs, tp,
                         wave_dir_deg)
    psi_deg = delta_deg if psi_deg is None else psi_deg
    model, u0 = _setup(model_path, dt, speed, t_end=t_end, rps=rps, delta_deg=delta_deg)
    res, m = run_zigzag(model, delta_deg, psi_deg, first=1 if first == Side.starboard else -1,
                        t_end=t_end, dt=dt, u0=u0, environment=env)
    if not m.overshoot_deg:
        n = len(m.reversal_times_s or [])
        raise _no_metrics(model_path, f"no overshoot within the run: the zig-zag made {n} "
                          f"rudder reversal(s), the first overshoot needs one and the heading's "
                          "turn back", t_end, float(res.t[-1]))
    out: dict[str, Any] = m.to_dict()
    kind = zigzag_kind(delta_deg, psi_deg)
    L = model.vessel.length
    check = imo_zigzag_check(m, L, u0, kind) if kind and L else None
    out.update(manoeuvre="zigzag", model=str(model_path), model_kind=model.kind,
               delta_deg=delta_deg, psi_deg=psi_deg, speed_m_s=u0,
               shaft_speed_rps=_rps_of(model),
               imo=check.to_dict() if check else None, environment=_env_json(res))
    rows = [("overshoot angles (first 4)", m.overshoot_deg[:4], "deg"),
            ("period", m.period_s, "s"),
            ("initial turning time", m.initial_turning_time_s, "s"),
            ("time to check yaw", m.time_to_check_yaw_s, "s")]
    _output(out, as_json, f"zig-zag {delta_deg:g}/{psi_deg:g} ({first.value} first), "
            f"{model_path.name} ({model.kind})", rows, check)


@sim_app.command("turning")
def turning_cmd(
    model_path: ModelArg,
    delta_deg: Annotated[float, typer.Option(
        "--delta-deg", help="Rudder angle [deg], negative to port.")] = 35.0,
    t_end: Annotated[float | None, typer.Option(
        "--t-end", help="Simulated time [s] (default: until 540 deg of heading change).")] = None,
    dt: DtOpt = 0.02,
    speed: SpeedOpt = None,
    rps: RpsOpt = None,
    wind_speed: WindSpeedOpt = None,
    wind_dir_deg: WindDirOpt = None,
    current_speed: CurrentSpeedOpt = None,
    current_dir_deg: CurrentDirOpt = None,
    hs: HsOpt = None,
    tp: TpOpt = None,
    wave_dir_deg: WaveDirOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Turning circle: advance, transfer, tactical and steady diameters, steady yaw rate/speed."""
    from usvid.manoeuvres.imo import imo_turning_applies, imo_turning_check
    from usvid.sim.runs import run_turning

    check_rudder_deg(delta_deg, signed=True)
    env = environment_of(wind_speed, wind_dir_deg, current_speed, current_dir_deg, hs, tp,
                         wave_dir_deg)
    model, u0 = _setup(model_path, dt, speed, t_end=t_end, rps=rps, delta_deg=delta_deg)
    res, m = run_turning(model, delta_deg, t_end=t_end, dt=dt, u0=u0, environment=env)
    missing = [k for k in ("advance_m", "transfer_m", "tactical_diameter_m")
               if not math.isfinite(getattr(m, k))]
    if missing:
        psi = res["psi"][0]
        turn = abs(math.degrees(float(psi[-1] - psi[0])))
        raise _no_metrics(model_path, f"no turning circle: the heading changed {turn:.3g} deg "
                          f"({', '.join(missing)} need 90 and 180 deg)", t_end, float(res.t[-1]))
    out: dict[str, Any] = m.to_dict()
    L = model.vessel.length
    applies = imo_turning_applies(math.radians(delta_deg), float(model.servo.max_angle))
    check = imo_turning_check(m, L) if L and applies else None
    out.update(manoeuvre="turning", model=str(model_path), model_kind=model.kind,
               delta_deg=delta_deg, speed_m_s=u0, shaft_speed_rps=_rps_of(model),
               imo=check.to_dict() if check else None, environment=_env_json(res))
    rows = [("advance", m.advance_m, "m"), ("transfer", m.transfer_m, "m"),
            ("tactical diameter", m.tactical_diameter_m, "m"),
            ("steady diameter", m.steady_diameter_m, "m"),
            ("steady yaw rate", m.steady_yaw_rate_rad_s, "rad/s"),
            ("steady speed", m.steady_speed_m_s, "m/s"), ("side", m.side, "")]
    _output(out, as_json, f"turning circle {delta_deg:g} deg, {model_path.name} ({model.kind})",
            rows, check)


@sim_app.command("course-keeping")
def course_cmd(
    model_path: ModelArg,
    controller: Annotated[Controller, typer.Option(
        "--controller", help="pd or pid autopilot.")] = Controller.pd,
    kp: Annotated[float, typer.Option("--kp", help="Proportional gain [rad/rad].")] = 0.7,
    ki: Annotated[float | None, typer.Option(
        "--ki", help="Integral gain [1/s] (pid; default 0.00095, Mu et al. 2018).")] = None,
    kd: Annotated[float, typer.Option("--kd", help="Derivative gain [s].")] = 1.0,
    target_deg: Annotated[float, typer.Option("--target-deg", help="Target course [deg].")] =
        100.0,
    seed: Annotated[int, typer.Option("--seed", help="Disturbance seed.")] = 1,
    noise: Annotated[float, typer.Option(
        "--noise", help="Disturbance std [deg] (filter of Mu et al. 2018); 0 = calm.")] = 1.0,
    t_end: Annotated[float, typer.Option(
        "--t-end", help="Simulated time [s]: the horizon of ITAE and IAE.")] = 100.0,
    dt: DtOpt = 0.02,
    speed: SpeedOpt = None,
    wind_speed: WindSpeedOpt = None,
    wind_dir_deg: WindDirOpt = None,
    current_speed: CurrentSpeedOpt = None,
    current_dir_deg: CurrentDirOpt = None,
    hs: HsOpt = None,
    tp: TpOpt = None,
    wave_dir_deg: WaveDirOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Course change 0 -> target with a PD/PID autopilot: ITAE, IAE, largest rudder angle."""
    from usvid.sim.runs import default_ki, run_course

    check_seed(seed)
    check_disturbance_deg(noise, "--noise")
    check_target_deg(target_deg)
    env = environment_of(wind_speed, wind_dir_deg, current_speed, current_dir_deg, hs, tp,
                         wave_dir_deg)
    for opt, v in (("--kp", kp), ("--ki", ki), ("--kd", kd)):
        check_gain(v, opt)
    model, u0 = _setup(model_path, dt, speed, t_end=t_end)
    res, m = run_course(model, controller=controller.value, kp=kp, ki=ki, kd=kd,
                      target_deg=target_deg, noise_deg=noise, seed=seed, t_end=t_end, dt=dt,
                      u0=u0, environment=env)
    out: dict[str, Any] = dict(m)
    out.update(manoeuvre="course-keeping", model=str(model_path), model_kind=model.kind,
               controller=controller.value, kp=kp,
               ki=ki if ki is not None else default_ki(controller.value),
               kd=kd, target_deg=target_deg, noise_deg=noise, seed=seed, t_end_s=t_end,
               horizon_s=t_end, speed_m_s=u0, environment=_env_json(res))
    _output(out, as_json, f"course change 0 -> {target_deg:g} deg, {controller.value.upper()}, "
            f"{model_path.name}",
            [(f"ITAE over 0 .. {t_end:g} s", m["itae"], "rad s^2"),
             (f"IAE over 0 .. {t_end:g} s", m["iae"], "rad s"),
             ("max rudder", m["max_rudder_deg"], "deg")])


def register(app: typer.Typer) -> None:
    """Register ``usvid simulate ...`` on the CLI app."""
    app.add_typer(sim_app, name="simulate")
