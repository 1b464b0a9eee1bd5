"""CLI command: ``usvid report RUN_DIR`` regenerates ``report.html`` from a run's ``run.json``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from usvid.commands._common import emit_json


def register(app: typer.Typer) -> None:
    """Register ``usvid report`` on the CLI app."""

    @app.command("report")
    def report(
        run_dir: Annotated[Path, typer.Argument(help="Run directory (holding run.json) written "
                                                     "by `usvid demo`.")],
        json_out: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    ) -> None:
        """Regenerate the self-contained HTML report (report.html) from RUN_DIR/run.json."""
        from usvid.report.run import regenerate

        path = regenerate(run_dir)
        if json_out:
            emit_json({"report": str(path), "bytes": path.stat().st_size})
        else:
            print(f"report written: {path}")
