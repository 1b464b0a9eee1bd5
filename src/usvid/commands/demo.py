"""CLI: ``usvid demo [--out DIR] [--seed N] [--quick] [--json]``: the main job end to end.

Generates the virtual Lanxin sea-trial campaign (Mu et al. 2018) as NMEA 0183 / candump / CSV logs,
reads them back, audits them, identifies the servo, Nomoto, Norrbin (two-step) and 3-DOF models,
validates them against the trials, compares PD and PID course keeping (ITAE), fits the Ma et al.
turning-diameter model, and writes ``DIR/models/*.json``, ``DIR/run.json`` and the
self-contained ``DIR/report.html`` (all atomically). A non-empty ``--out`` folder that usvid
did not create is refused (exit 2) unless ``--force``; the demo never deletes a file it did not
create. The pipeline is
:mod:`usvid.demo.pipeline`; ``usvid report DIR`` regenerates the report from ``run.json``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer


def register(app: typer.Typer) -> None:
    """Register ``usvid demo`` on the CLI app."""

    @app.command("demo")
    def demo(
        out: Annotated[Path, typer.Option(
            "--out", help="Run folder: logs/, models/, run.json, report.html.")] = Path(
                "demo-out"),
        seed: Annotated[int, typer.Option(
            "--seed", help="Seed of the disturbance and sensor noise (same seed, same "
                           "files).")] = 1,
        quick: Annotated[bool, typer.Option(
            "--quick", help="Shorter trials and GA (for tests; the acceptance numbers are for "
                            "the full demo).")] = False,
        as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
        force: Annotated[bool, typer.Option(
            "--force", help="Write into a non-empty folder that usvid did not create (usvid "
                            "overwrites only its own file names there and deletes nothing).")
        ] = False,
    ) -> None:
        """Virtual Lanxin sea trials -> identified, validated models -> report.html."""
        import warnings

        from usvid.commands._common import emit_json
        from usvid.demo.pipeline import print_summary, run_demo, summary_rows

        progress = (not as_json) or sys.stderr.isatty()
        with warnings.catch_warnings():
            # the estimators warn per trial about interpolated NaN samples of the multi-rate
            # logs; the audit table of the report lists the data issues instead
            warnings.simplefilter("ignore")
            result = run_demo(out, seed=seed, quick=quick, progress=progress, force=force)
        if as_json:
            run = result.run
            emit_json({
                "out": str(result.out), "report": str(result.report),
                "run": str(result.out / "run.json"),
                "models": {m["kind"]: {"params": m["params"], "truth": m["truth"],
                                       "rel_error": m["rel_error"], "ci95": m["ci95"],
                                       "file": m["file"]} for m in run.get("models", [])},
                "course_keeping": [{k: r.get(k) for k in ("label", "kp", "ki", "kd", "itae",
                                                          "iae", "max_rudder_deg")}
                                   for r in run.get("course_keeping", {}).get("runs", [])],
                "steps": run["steps"], "acceptance": run.get("acceptance", {}),
                "timing": run.get("timing", {}),
                "summary": [list(r) for r in summary_rows(run)],
            })
        else:
            print_summary(result)
        if result.exit_code:
            raise typer.Exit(result.exit_code)
