"""Helpers shared by the CLI commands: JSON on stdout, option checks."""

from __future__ import annotations

from enum import StrEnum
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
