"""CLI: ``usvid simulate zigzag|turning|course-keeping MODEL.json ...``.

Runs a standard manoeuvre on a model file and prints its metrics (a table, or with ``--json`` one
JSON object whose keys are the ``ARCHITECTURE.md`` contract, followed by extras):

- ``zigzag``: ``overshoot_deg`` (list, first first), ``period_s``, ``initial_turning_time_s``,
  ``time_to_check_yaw_s`` (+ ``imo`` for a 10/10 or 20/20 test when L and U are known);
- ``turning``: ``advance_m``, ``transfer_m``, ``tactical_diameter_m``, ``steady_diameter_m``,
  ``steady_yaw_rate_rad_s``, ``steady_speed_m_s`` (+ ``imo`` when L is known and the rudder is
  the maximum angle, 35 deg or the servo limit: MSC.137(76) 5.2.1);
- ``course-keeping``: ``itae`` [rad s^2], ``iae`` [rad s], ``max_rudder_deg``.

Metric definitions: :mod:`usvid.manoeuvres.metrics`; IMO criteria: :mod:`usvid.manoeuvres.imo`.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.errors import SimulationError, UsvidError

#: Largest simulated time [s] when the run is extended automatically.
MAX_T_END = 3600.0


class Side(StrEnum):
    starboard = "starboard"
    port = "port"


class ControllerKind(StrEnum):
    pd = "pd"
    pid = "pid"


JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
ModelArg = Annotated[Path, typer.Argument(help="Model file (JSON, usvid_model: 1).",
                                          show_default=False)]
DtOpt = Annotated[float, typer.Option("--dt", help="Integration step [s].")]
SpeedOpt = Annotated[float | None, typer.Option(
    "--speed", help="Approach speed [m/s] (default: the model's vessel.speed).")]


def _load(path: Path) -> Any:
    from usvid.modelfile import load_model

    return load_model(path)


def _speed(model: Any, speed: float | None, path: Path) -> float:
    u0 = speed if speed is not None else getattr(model.vessel, "speed", None)
    if u0 is None:
        raise UsvidError(f"{path.name}: vessel.speed is not given; pass --speed [m/s]")
    if not (math.isfinite(u0) and u0 > 0):
        raise UsvidError(f"--speed must be > 0 m/s (got {u0!r})")
    return float(u0)


def _check_dt(dt: float) -> None:
    if not (math.isfinite(dt) and 0 < dt <= 1.0):
        raise SimulationError(f"--dt must be in (0, 1] s (got {dt!r})")


def _setup(model_path: Path, dt: float, speed: float | None, *, t_end: float | None = None
           ) -> tuple[Any, float]:
    """Check ``--dt`` (and a given ``--t-end``), load the model file; returns (model, u0 [m/s])."""
    _check_dt(dt)
    if t_end is not None and not (math.isfinite(t_end) and 0 < t_end <= MAX_T_END):
        raise SimulationError(f"--t-end must be in (0, {MAX_T_END:g}] s (got {t_end!r})")
    model = _load(model_path)
    return model, _speed(model, speed, model_path)


def _output(out: dict[str, Any], as_json: bool, title: str, rows: list[tuple[str, Any, str]],
            check: Any = None) -> None:
    """Print the command's result: ``out`` as one JSON object, or ``rows`` (plus the IMO
    criteria of ``check``) as a table."""
    from usvid.commands._common import emit_json

    if as_json:
        emit_json(out)
        return
    _print_table(title, rows + (_imo_rows(check) if check else []))


def _default_ki(controller: str) -> float:
    """Integral gain [1/s] when none is given: seed 000's 0.00095 for PID, 0 for PD."""
    return 0.00095 if controller == "pid" else 0.0


def _default_t_end(model: Any, u0: float) -> float:
    """A first guess of the run length [s]: a few yaw time constants and L/U, at least 60 s."""
    dyn = model.dynamics
    T = 0.0
    for k in ("T", "T1"):
        if hasattr(dyn, k):
            T = float(abs(getattr(dyn, k)))
            break
    delay = float(getattr(model.servo, "delay", 0.0))
    L = getattr(model.vessel, "length", None) or 0.0
    # capped: a slow vessel (tiny --speed) would otherwise ask for days of simulated time
    return min(MAX_T_END, max(60.0, 20.0 * T + 10.0 * delay + 40.0 * L / u0))


def _check_finite(res: Any, dt: float) -> None:
    """Raise :class:`SimulationError` when the trajectory is not finite (an unstable model or an
    RK4 step too large for the model's fastest mode), instead of reporting null metrics."""
    import numpy as np

    for name in ("x", "y", "psi"):
        if name in res.channels and not np.all(np.isfinite(res.channels[name])):
            raise SimulationError(f"the simulation diverged ({name} is not finite) with "
                                  f"--dt {dt:g} s; reduce --dt or check the model parameters")


def _imo_turning_applies(model: Any, delta_deg: float) -> bool:
    """MSC.137(76) 5.2.1 judges the turning circle at the maximum rudder angle (35 deg, or the
    servo's limit when that is smaller); a circle at a smaller angle gets no IMO verdict."""
    max_deg = math.degrees(float(model.servo.max_angle))
    return min(abs(delta_deg), max_deg) >= min(35.0, max_deg) - 1e-9


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
# library-level runners (used by the CLI and by the demo)
# ---------------------------------------------------------------------------------------------
def run_zigzag(model: Any, delta_deg: float, psi_deg: float, *, first: int = 1,
               t_end: float | None = None, dt: float = 0.02, u0: float) -> tuple[Any, Any]:
    """Simulate a zig-zag ``delta_deg/psi_deg`` [deg] and return (SimResult, ZigZagMetrics).

    Without ``t_end`` the run is doubled until it shows the second overshoot and one full
    period (four reversals), up to :data:`MAX_T_END`.
    """
    from usvid.sim import ZigZag, simulate

    if not (0 < delta_deg <= 90):
        raise SimulationError(f"--delta-deg must be in (0, 90] (got {delta_deg!r})")
    if not (0 < psi_deg <= 180):
        raise SimulationError(f"--psi-deg must be in (0, 180] (got {psi_deg!r})")
    logic = ZigZag(delta_amp=math.radians(delta_deg), psi_switch=math.radians(psi_deg),
                   first=first)
    auto = t_end is None
    te = _default_t_end(model, u0) if auto else float(t_end)
    while True:
        res = simulate(model, logic, t_end=te, dt=dt, u0=u0)
        _check_finite(res, dt)
        m = res.zigzag_metrics()[0]
        if not auto or (len(m.reversal_times_s) >= 4 and len(m.overshoot_deg) >= 3) \
                or te >= MAX_T_END:
            return res, m
        te = min(2 * te, MAX_T_END)


def run_turning(model: Any, delta_deg: float, *, t_end: float | None = None, dt: float = 0.02,
                u0: float) -> tuple[Any, Any]:
    """Simulate a turning circle with ``delta_deg`` [deg] (negative: to port); returns
    (SimResult, TurningMetrics). Without ``t_end`` the run is doubled until the heading has
    changed by 540 deg (180 deg for the tactical diameter plus a full steady circle), up to
    :data:`MAX_T_END`."""
    from usvid.sim import Turning, simulate

    if not (0 < abs(delta_deg) <= 90):
        raise SimulationError(f"--delta-deg must be non-zero and within +-90 (got {delta_deg!r})")
    logic = Turning(delta=math.radians(delta_deg))
    auto = t_end is None
    te = _default_t_end(model, u0) if auto else float(t_end)
    while True:
        res = simulate(model, logic, t_end=te, dt=dt, u0=u0)
        _check_finite(res, dt)
        psi = res["psi"][0]
        turned = abs(float(psi[-1] - psi[0]))
        if not auto or turned >= 3 * math.pi or te >= MAX_T_END:
            return res, res.turning_metrics()[0]
        te = min(2 * te, MAX_T_END)


def run_course(model: Any, *, controller: str = "pd", kp: float = 0.7, ki: float | None = None,
               kd: float = 1.0, target_deg: float = 100.0, noise_deg: float = 1.0,
               seed: int = 1, t_end: float = 100.0, dt: float = 0.02, u0: float
               ) -> tuple[Any, dict[str, float]]:
    """Course change 0 -> ``target_deg`` with a PD or PID autopilot (seed 000 section 6.1).

    Gains are dimensionless kp [rad/rad], ki [1/s], kd [s] (seed 000: kp = 0.7, ki = 0.00095,
    kd = 1; PD: ki = 0). ``noise_deg``: std [deg] of the seed 000 rudder-equivalent disturbance
    (0 = calm). Returns (SimResult, {"itae", "iae", "max_rudder_deg"}).
    """
    from usvid.sim import PID, CourseChange, Disturbance, simulate

    if ki is None:
        ki = _default_ki(controller)
    if controller == "pd" and ki != 0:
        raise UsvidError("--controller pd takes no integral gain (give --controller pid)")
    if not (math.isfinite(noise_deg) and noise_deg >= 0):
        raise UsvidError(f"--noise must be >= 0 deg (got {noise_deg!r})")
    dist = Disturbance(intensity=math.radians(noise_deg), seed=seed) if noise_deg > 0 else None
    logic = CourseChange(target=math.radians(target_deg), controller=PID(kp=kp, ki=ki, kd=kd),
                         disturbance=dist)
    res = simulate(model, logic, t_end=t_end, dt=dt, u0=u0)
    _check_finite(res, dt)
    return res, res.course_metrics()[0]


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
    as_json: JsonOpt = False,
) -> None:
    """Zig-zag test: overshoot angles, period, initial turning time, time to check yaw."""
    from usvid.manoeuvres.imo import imo_zigzag_check, zigzag_kind

    model, u0 = _setup(model_path, dt, speed, t_end=t_end)
    psi_deg = delta_deg if psi_deg is None else psi_deg
    _, m = run_zigzag(model, delta_deg, psi_deg, first=1 if first == Side.starboard else -1,
                      t_end=t_end, dt=dt, u0=u0)
    out: dict[str, Any] = m.to_dict()
    kind = zigzag_kind(delta_deg, psi_deg)
    L = model.vessel.length
    check = imo_zigzag_check(m, L, u0, kind) if kind and L else None
    out.update(manoeuvre="zigzag", model=str(model_path), model_kind=model.kind,
               delta_deg=delta_deg, psi_deg=psi_deg, speed_m_s=u0,
               imo=check.to_dict() if check else None)
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
    as_json: JsonOpt = False,
) -> None:
    """Turning circle: advance, transfer, tactical and steady diameters, steady yaw rate/speed."""
    from usvid.manoeuvres.imo import imo_turning_check

    model, u0 = _setup(model_path, dt, speed, t_end=t_end)
    _, m = run_turning(model, delta_deg, t_end=t_end, dt=dt, u0=u0)
    out: dict[str, Any] = m.to_dict()
    L = model.vessel.length
    check = imo_turning_check(m, L) if L and _imo_turning_applies(model, delta_deg) else None
    out.update(manoeuvre="turning", model=str(model_path), model_kind=model.kind,
               delta_deg=delta_deg, speed_m_s=u0, imo=check.to_dict() if check else None)
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
    controller: Annotated[ControllerKind, typer.Option(
        "--controller", help="pd or pid autopilot.")] = ControllerKind.pd,
    kp: Annotated[float, typer.Option("--kp", help="Proportional gain [rad/rad].")] = 0.7,
    ki: Annotated[float | None, typer.Option(
        "--ki", help="Integral gain [1/s] (pid; default 0.00095, seed 000).")] = None,
    kd: Annotated[float, typer.Option("--kd", help="Derivative gain [s].")] = 1.0,
    target_deg: Annotated[float, typer.Option("--target-deg", help="Target course [deg].")] =
        100.0,
    seed: Annotated[int, typer.Option("--seed", help="Disturbance seed.")] = 1,
    noise: Annotated[float, typer.Option(
        "--noise", help="Disturbance std [deg] (seed 000 filter); 0 = calm.")] = 1.0,
    t_end: Annotated[float, typer.Option("--t-end", help="Simulated time [s].")] = 100.0,
    dt: DtOpt = 0.02,
    speed: SpeedOpt = None,
    as_json: JsonOpt = False,
) -> None:
    """Course change 0 -> target with a PD/PID autopilot: ITAE, IAE, largest rudder angle."""
    model, u0 = _setup(model_path, dt, speed, t_end=t_end)
    _, m = run_course(model, controller=controller.value, kp=kp, ki=ki, kd=kd,
                      target_deg=target_deg, noise_deg=noise, seed=seed, t_end=t_end, dt=dt,
                      u0=u0)
    out: dict[str, Any] = dict(m)
    out.update(manoeuvre="course-keeping", model=str(model_path), model_kind=model.kind,
               controller=controller.value, kp=kp,
               ki=ki if ki is not None else _default_ki(controller.value),
               kd=kd, target_deg=target_deg, noise_deg=noise, seed=seed, t_end_s=t_end,
               speed_m_s=u0)
    _output(out, as_json, f"course change 0 -> {target_deg:g} deg, {controller.value.upper()}, "
            f"{model_path.name}",
            [("ITAE", m["itae"], "rad s^2"), ("IAE", m["iae"], "rad s"),
             ("max rudder", m["max_rudder_deg"], "deg")])


def register(app: typer.Typer) -> None:
    """Register ``usvid simulate ...`` on the CLI app."""
    app.add_typer(sim_app, name="simulate")
