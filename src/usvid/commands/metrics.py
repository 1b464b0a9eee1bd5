"""CLI: ``usvid metrics LOG --format SPEC [--json]`` - measured manoeuvre metrics of a log.

Finds the zig-zags and turning circles in the log (:func:`usvid.manoeuvres.find_manoeuvres`)
and measures them with the definitions the simulator uses (:mod:`usvid.manoeuvres.metrics`), so
the keys are those of ``usvid simulate``: ``overshoot_deg`` (list, first first), ``period_s``,
``initial_turning_time_s``, ``time_to_check_yaw_s`` for a zig-zag; ``advance_m``, ``transfer_m``,
``tactical_diameter_m``, ``steady_diameter_m``, ``steady_yaw_rate_rad_s``, ``steady_speed_m_s`` for
a turning circle. JSON: ``file``, ``format``, ``rejected`` (per reason), ``count`` and
``manoeuvres`` (one object each: kind, times, command, delta_amp_deg, psi_switch_deg, and the
metric keys); when the log holds exactly one manoeuvre its keys are also at the top level. A
turning circle also has ``current`` (the current measured from positions 360 deg of heading
apart, IMO MSC/Circ.1053 3.4.2.5: ``speed_m_s``, ``dir_deg`` towards, ``spread_m_s``, ...) and
``corrected`` (its metrics with the current's drift removed, the same keys as the raw ones),
both null for a turn of less than 540 deg. ``findings``: what the detection left out and why
(``turn_not_under_way``: a turn of the heading while the vessel was not under way is no turning
circle), as the audit's findings.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import FormatOpt, JsonOpt, say_format

LogArg = Annotated[Path, typer.Argument(help="Log file to measure.", show_default=False)]

PsiOpt = Annotated[float | None, typer.Option(
    "--psi-deg", help="Zig-zag switching angle [deg] when known (default: from the heading at "
                      "the rudder reversals; see psi_switch_from).")]
TurnOpt = Annotated[float, typer.Option(
    "--min-turn-deg", help="Heading change [deg] that makes a single rudder pulse a turning "
                           "circle.")]


def metrics_log(log: Path, fmt: str, psi_deg: float | None = None,
                min_turn_deg: float = 180.0) -> dict[str, Any]:
    """The JSON object of ``usvid metrics`` for one log."""
    from usvid.commands._common import check_number, check_psi_deg
    from usvid.manoeuvres import manoeuvre_findings, measured_metrics
    from usvid.prep import as_prepared
    from usvid.prep.logs import read_log

    check_psi_deg(psi_deg)
    check_number(min_turn_deg, "--min-turn-deg", lo=0.0, hi=3600.0, lo_open=True, unit="deg")
    trial = as_prepared(read_log(log, fmt), derivatives=False)
    say_format([trial], [log])
    options = {"psi_switch": math.radians(psi_deg) if psi_deg is not None else None,
               "min_turn_deg": min_turn_deg}
    ms = measured_metrics(trial, **options)
    out: dict[str, Any] = {
        "file": str(log),
        "format": fmt,
        "rejected": dict(trial.rejected),
        "count": len(ms),
        "manoeuvres": ms,
        "findings": [f.to_dict() for f in manoeuvre_findings(trial, **options)],
    }
    if len(ms) == 1:
        for k, v in ms[0].items():
            out.setdefault(k, v)
    if not ms:
        out["message"] = "no zig-zag or turning circle found in the log"
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "-" if not math.isfinite(v) else f"{v:.4g}"
    if isinstance(v, list):
        return ", ".join(_fmt(x) for x in v[:6]) + (" ..." if len(v) > 6 else "")
    return str(v)


def register(app: typer.Typer) -> None:
    """Register ``usvid metrics``."""

    @app.command("metrics")
    def metrics_cmd(log: LogArg, fmt: FormatOpt = "auto", json_out: JsonOpt = False,
                    psi_deg: PsiOpt = None, min_turn_deg: TurnOpt = 180.0) -> None:
        """Find zig-zags and turning circles in a log and print their measured metrics."""
        from usvid.commands._common import emit_json

        out = metrics_log(log, fmt, psi_deg, min_turn_deg)
        if json_out:
            emit_json(out)
            return
        from rich.console import Console
        from rich.table import Table

        con = Console()
        for f in out["findings"]:
            con.print(f"{log.name}: {f['message']}")
        if not out["manoeuvres"]:
            con.print(f"{log.name}: {out['message']}")
            return
        keys = {
            "zigzag": ("delta_amp_deg", "psi_switch_deg", "psi_switch_from", "rudder_lag_s",
                       "first_side", "overshoot_deg", "period_s", "initial_turning_time_s",
                       "time_to_check_yaw_s", "heading_glitches"),
            "turning": ("first_side", "advance_m", "transfer_m", "tactical_diameter_m",
                        "steady_diameter_m", "steady_yaw_rate_rad_s", "steady_speed_m_s"),
        }
        for i, m in enumerate(out["manoeuvres"], 1):
            table = Table("metric", "value",
                          title=f"{log.name} #{i}: {m['kind']} from t = {m['t_start']:.1f} s")
            for k in keys[m["kind"]]:
                if k in m:
                    table.add_row(k, _fmt(m[k]))
            cur, corr = m.get("current"), m.get("corrected")
            if cur:  # IMO MSC/Circ.1053 3.4.2.5 (turns of 540 deg or more)
                table.add_row("current_speed_m_s", _fmt(cur["speed_m_s"]))
                table.add_row("current_dir_deg (towards)", _fmt(cur["dir_deg"]))
                table.add_row("current_spread_m_s", _fmt(cur["spread_m_s"]))
                for k in ("advance_m", "transfer_m", "tactical_diameter_m",
                          "steady_diameter_m"):
                    table.add_row(f"{k} (current-corrected)", _fmt(corr[k]))
            con.print(table)
