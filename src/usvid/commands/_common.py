"""Helpers shared by the CLI commands (not a command: every command may import it, no command
imports another): JSON on stdout, option declarations and checks, the validation table."""

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
    "--workers", help="Workers of the local cluster (default: one per core).")]


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
    if not (math.isfinite(psi_deg) and 0 < psi_deg <= 180):
        raise UsvidError(f"--psi-deg must be in (0, 180] deg (got {psi_deg!r})")
    return math.radians(psi_deg)


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
        for m in r.get("messages", []):
            con.print(f"  note: {m}")
