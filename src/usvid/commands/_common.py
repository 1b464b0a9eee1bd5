"""Helpers shared by the CLI commands (not a command: every command may import it, no command
imports another): JSON on stdout, option declarations and checks, the validation table.

Every numeric option is checked here, at the edge, before any work: finite, in its range, and a
one-line :class:`UsvidError` naming the option, the range and the value otherwise
(:func:`check_number` and the checks of the options several commands share: rudder angles,
switching angles, speeds, steps, run lengths, shaft speeds, disturbances).
"""

from __future__ import annotations

import math
import sys
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.errors import UsvidError

#: Seeds are 32-bit (numpy's SeedSequence accepts more, the CGA's legacy generator does not).
SEED_MAX = 2**32 - 1


def check_seed(seed: int, option: str = "--seed") -> int:
    """``seed`` when 0 <= seed <= 2**32 - 1, else a one-line :class:`UsvidError`."""
    if not 0 <= seed <= SEED_MAX:
        raise UsvidError(f"{option} must be an integer in 0 .. {SEED_MAX} (got {seed})")
    return seed


def _bound(x: float) -> str:
    return f"{x:g}"


def check_number(value: float | int | None, option: str, *, lo: float | None = None,
                 hi: float | None = None, lo_open: bool = False, hi_open: bool = False,
                 unit: str = "", nonzero: bool = False) -> float | None:
    """``value`` when it is a finite number in the range (``lo``/``hi``, open or closed; with
    ``nonzero``, 0 excluded), else a :class:`UsvidError` naming ``option``:
    ``"--t-end must be in (0, 3600] s (got nan)"``. ``None`` (an option not given) passes."""
    if value is None:
        return None
    v = float(value)
    ok = math.isfinite(v) and (lo is None or (v > lo if lo_open else v >= lo)) \
        and (hi is None or (v < hi if hi_open else v <= hi)) and not (nonzero and v == 0)
    if ok:
        return value
    if lo is not None and hi is not None:
        rng = (f"{'(' if lo_open else '['}{_bound(lo)}, {_bound(hi)}{')' if hi_open else ']'}")
        what = f"in {rng}"
    elif lo is not None:
        what = f"{'>' if lo_open else '>='} {_bound(lo)}"
    elif hi is not None:
        what = f"{'<' if hi_open else '<='} {_bound(hi)}"
    else:
        what = "a finite number"
    if nonzero:
        what = f"non-zero and {what}" if what != "a finite number" else "non-zero and finite"
    raise UsvidError(f"{option} must be {what}{' ' + unit if unit else ''} (got {value!r})")


#: Smallest rudder angle [deg] of a manoeuvre (a smaller one steers nothing measurable).
MIN_RUDDER_DEG = 0.1
#: Approach speeds [m/s] of a manoeuvre: from a model basin's slowest carriage runs to the
#: fastest planing craft.
SPEED_RANGE = (0.01, 100.0)
#: Largest disturbance or noise standard deviation [deg] (a rudder-equivalent disturbance
#: beyond the largest rudder angle is not a disturbance).
MAX_DISTURBANCE_DEG = 90.0
#: Shaft speeds [rps]: below 0.01 rps (0.6 rpm) a propeller gives no thrust (its advance
#: ratio overflows); small high-speed propellers turn at up to ~100 rps.
RPS_RANGE = (0.01, 1000.0)
#: Course changes [deg] of the course-keeping manoeuvre and autopilot design.
MAX_TARGET_DEG = 360.0
#: Largest absolute autopilot gain (kp [rad/rad], ki [1/s], kd [s]).
MAX_GAIN = 1e6


def check_rudder_deg(value: float | None, option: str = "--delta-deg", *,
                     signed: bool = False) -> float | None:
    """A rudder angle [deg]: in [MIN_RUDDER_DEG, 90] (``signed``: its magnitude; negative is
    to port)."""
    if value is None:
        return None
    check_number(value, option, lo=-90.0 if signed else MIN_RUDDER_DEG, hi=90.0, unit="deg")
    if abs(value) < MIN_RUDDER_DEG:
        raise UsvidError(f"{option} must be {'non-zero and ' if signed else ''}at least "
                         f"{MIN_RUDDER_DEG:g} deg in magnitude (got {value!r})")
    return value


def check_psi_deg(value: float | None, option: str = "--psi-deg") -> float | None:
    """A zig-zag switching heading deviation [deg]: in [MIN_RUDDER_DEG, 180]."""
    return check_number(value, option, lo=MIN_RUDDER_DEG, hi=180.0, unit="deg")


def check_speed(value: float | None, option: str = "--speed") -> float | None:
    """An approach speed [m/s]: in :data:`SPEED_RANGE`."""
    return check_number(value, option, lo=SPEED_RANGE[0], hi=SPEED_RANGE[1], unit="m/s")


def check_dt(value: float, option: str = "--dt") -> float:
    """An integration step [s]: in (0, 1]."""
    check_number(value, option, lo=0.0, hi=1.0, lo_open=True, unit="s")
    return value


def check_t_end(value: float | None, option: str = "--t-end") -> float | None:
    """A simulated time [s]: in (0, ``usvid.sim.runs.MAX_T_END``] (the longest run)."""
    from usvid.sim.runs import MAX_T_END  # (the kernel: loaded by the commands that simulate)

    return check_number(value, option, lo=0.0, hi=MAX_T_END, lo_open=True, unit="s")


def check_rps(value: float | None, option: str = "--rps") -> float | None:
    """A shaft speed [rps]: in :data:`RPS_RANGE`."""
    return check_number(value, option, lo=RPS_RANGE[0], hi=RPS_RANGE[1], unit="rps")


def check_steps(t_end: float, dt: float, t_option: str = "--t-end") -> None:
    """The run ``t_end`` [s] in steps ``dt`` [s] (both checked already): at least one step and
    at most the kernel's ``MAX_STEPS`` (its grid and input series alone would need gigabytes);
    the message names both options."""
    from usvid.sim.simulate import MAX_STEPS  # (the kernel: loaded by the commands that run it)

    steps = t_end / dt
    if steps < 1:
        raise UsvidError(f"{t_option} {t_end:g} s is shorter than one step --dt {dt:g} s")
    if steps > MAX_STEPS:
        raise UsvidError(f"{t_option} {t_end:g} s / --dt {dt:g} s = {steps:.4g} steps (at most "
                         f"{MAX_STEPS:.0f}; the step grid alone would need "
                         f"{steps * 64 / 1e9:.3g} GB): give a larger --dt or a shorter "
                         f"{t_option}")


def check_disturbance_deg(value: float | None, option: str) -> float | None:
    """A disturbance standard deviation [deg]: in [0, MAX_DISTURBANCE_DEG]."""
    return check_number(value, option, lo=0.0, hi=MAX_DISTURBANCE_DEG, unit="deg")


def check_target_deg(value: float | None, option: str = "--target-deg") -> float | None:
    """A course change [deg]: within +-MAX_TARGET_DEG."""
    return check_number(value, option, lo=-MAX_TARGET_DEG, hi=MAX_TARGET_DEG, unit="deg")


def check_gain(value: float | None, option: str) -> float | None:
    """An autopilot gain: finite, within +-MAX_GAIN."""
    return check_number(value, option, lo=-MAX_GAIN, hi=MAX_GAIN)


#: Ranges of the environment options: wind [m/s] up to hurricane force (Beaufort 12 starts at
#: 32.7 m/s), currents [m/s] up to the fastest tidal races (~8 m/s), significant wave height
#: [m] and peak period [s] beyond the largest sea states recorded, directions [deg] one turn
#: either way.
WIND_RANGE = (0.0, 100.0)
CURRENT_RANGE = (0.0, 20.0)
HS_RANGE = (0.0, 30.0)
TP_RANGE = (0.0, 60.0)
DIR_RANGE_DEG = (-360.0, 360.0)


WindSpeedOpt = Annotated[float | None, typer.Option(
    "--wind-speed", help="True wind speed [m/s] (loads from the vessel's windage: "
    "vessel.frontal_area, lateral_area; default: calm).")]
WindDirOpt = Annotated[float | None, typer.Option(
    "--wind-dir-deg", help="Direction the true wind comes FROM [deg, clockwise from north].")]
CurrentSpeedOpt = Annotated[float | None, typer.Option(
    "--current-speed", help="Current speed [m/s] (default: none).")]
CurrentDirOpt = Annotated[float | None, typer.Option(
    "--current-dir-deg", help="Direction the current flows TOWARDS [deg, clockwise from north].")]
HsOpt = Annotated[float | None, typer.Option(
    "--hs", help="Significant wave height [m] of a JONSWAP sea (with --tp; default: none).")]
TpOpt = Annotated[float | None, typer.Option("--tp", help="Peak wave period [s] (with --hs).")]
WaveDirOpt = Annotated[float | None, typer.Option(
    "--wave-dir-deg", help="Direction the waves come FROM [deg, clockwise from north].")]


def environment_of(wind_speed: float | None = None, wind_dir_deg: float | None = None,
                   current_speed: float | None = None, current_dir_deg: float | None = None,
                   hs: float | None = None, tp: float | None = None,
                   wave_dir_deg: float | None = None) -> Any:
    """The :class:`usvid.sim.Environment` of the options ``--wind-speed`` [m/s],
    ``--wind-dir-deg`` (true, from, clockwise from north), ``--current-speed`` [m/s],
    ``--current-dir-deg`` (towards), ``--hs`` [m], ``--tp`` [s], ``--wave-dir-deg`` (from),
    each checked (:func:`check_number`, the option named); None when none is given (calm water:
    the runs of today). A direction needs its speed, ``--hs`` and ``--tp`` go together."""
    check_number(wind_speed, "--wind-speed", lo=WIND_RANGE[0], hi=WIND_RANGE[1], unit="m/s")
    check_number(current_speed, "--current-speed", lo=CURRENT_RANGE[0], hi=CURRENT_RANGE[1],
                 unit="m/s")
    check_number(hs, "--hs", lo=HS_RANGE[0], hi=HS_RANGE[1], lo_open=True, unit="m")
    check_number(tp, "--tp", lo=TP_RANGE[0], hi=TP_RANGE[1], lo_open=True, unit="s")
    for opt, v in (("--wind-dir-deg", wind_dir_deg), ("--current-dir-deg", current_dir_deg),
                   ("--wave-dir-deg", wave_dir_deg)):
        check_number(v, opt, lo=DIR_RANGE_DEG[0], hi=DIR_RANGE_DEG[1], unit="deg")
    for opt, v, need, given in (("--wind-dir-deg", wind_dir_deg, "--wind-speed", wind_speed),
                                ("--current-dir-deg", current_dir_deg, "--current-speed",
                                 current_speed), ("--wave-dir-deg", wave_dir_deg, "--hs and --tp",
                                                  hs)):
        if v is not None and given is None:
            raise UsvidError(f"{opt} needs {need}")
    if (hs is None) != (tp is None):
        raise UsvidError("--hs and --tp go together (the sea state's significant wave height "
                         "[m] and peak period [s])")
    if all(v is None for v in (wind_speed, current_speed, hs)):
        return None
    from usvid.models.environment import SeaState
    from usvid.sim.simulate import Environment

    sea = None
    if hs is not None:
        sea = SeaState(hs=float(hs), tp=float(tp),  # type: ignore[arg-type]
                       direction=math.radians(wave_dir_deg or 0.0))
    return Environment(current_speed=float(current_speed or 0.0),
                       current_dir=math.radians(current_dir_deg or 0.0),
                       wind_speed=float(wind_speed or 0.0),
                       wind_dir=math.radians(wind_dir_deg or 0.0), sea=sea)


class Controller(StrEnum):
    """``--controller`` of the course-keeping autopilot (autopilot, simulate course-keeping)."""
    pd = "pd"
    pid = "pid"


def emit_json(obj: Any) -> None:
    """Print exactly one JSON object on stdout."""
    from usvid.files import to_json  # numpy: loaded when a command runs, not for --help

    print(to_json(obj))


#: ``--scheduler`` and ``--workers`` of the commands that run on Dask (montecarlo, batch).
SchedulerOpt = Annotated[str | None, typer.Option(
    "--scheduler", help="Address of an existing Dask scheduler (tcp://host:8786); "
    "default: a local cluster.")]
WorkersOpt = Annotated[int | None, typer.Option(
    "--workers", help="Workers of the local cluster (default: one per core; at most 4 per "
    "core and what the memory holds).")]


# -- options and output shared by the commands that read logs (identify, validate, metrics,
#    audit); the logs themselves are read and prepared by usvid.prep.logs
FormatOpt = Annotated[str, typer.Option(
    "--format", "-f", help="Trial format spec: a YAML path, a shipped spec name, or auto "
    "(detect the format by content and pick the shipped preset).")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
TStartOpt = Annotated[float | None, typer.Option(
    "--t-start", help="Use every log from this time on [s from its first record]; a "
    "LOG:T0:T1 argument trims one log.")]
TEndOpt = Annotated[float | None, typer.Option(
    "--t-end", help="Use every log up to this time [s from its first record].")]
PsiOpt = Annotated[float | None, typer.Option(
    "--psi-deg", help="Zig-zag switching angle [deg] when known (default: detected).")]
ReportOpt = Annotated[Path | None, typer.Option(
    "--report", help="Write run.json and report.html into this directory.")]


def psi_switch_option(psi_deg: float | None) -> float | None:
    """``--psi-deg`` [deg] -> radians, checked."""
    if psi_deg is None:
        return None
    return math.radians(check_psi_deg(psi_deg))


def say_format(trials: Any, paths: Any) -> None:
    """Print on stderr what ``--format auto`` chose for each log (one line each)."""
    for tr, p in zip(trials, paths, strict=False):
        note = tr.meta.get("format_detected")
        if note:
            print(f"usvid: {p}: {note}", file=sys.stderr)


def print_validation(rows: list[dict[str, Any]]) -> None:
    """The human-readable table of validation rows (measured, predicted, error)."""
    from rich.console import Console
    from rich.table import Table

    from usvid.identify.validation import short_value as f

    con = Console()
    for r in rows:
        table = Table("metric", "measured", "predicted", "error",
                      title=f"{Path(str(r.get('file') or r['trial'])).name}: {r['manoeuvre']}")
        for k in r.get("error", {}):
            table.add_row(k, f(r["measured"].get(k)), f(r["predicted"].get(k)), f(r["error"][k]))
        for k, v in r.get("replay", {}).items():
            table.add_row(f"free-run replay {k}", f(v), "", "")
        con.print(table)
        w = r.get("replay_water")
        if w:  # a model identified with a disturbance: the water the replay ran in
            vals = ", ".join(f"{k} {v:.4g}" for k, v in w.items()
                             if isinstance(v, float))
            con.print(f"  replay water: {w['water']}" + (f" ({vals})" if vals else "")
                      + f": {w['why']}", highlight=False)
        for m in r.get("messages", []):
            con.print(f"  note: {m}")


def report_files(report: Path | None) -> list[Path]:
    """The files ``--report DIR`` writes (``DIR/run.json``, ``DIR/report.html``): checked
    against the command's inputs before any work (a run.json given as a log, a log named
    report.html in DIR)."""
    from usvid.report.run import REPORT_FILE, RUN_FILE

    return [] if report is None else [Path(report) / RUN_FILE, Path(report) / REPORT_FILE]
