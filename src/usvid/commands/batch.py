"""CLI: ``usvid batch CAMPAIGN.yaml --out DIR [--scheduler ADDRESS] [--workers N] [--json]``.

Each group of the campaign file (:mod:`usvid.scale.batch`: log globs, format spec, model kinds,
held-out logs) is read, audited, identified and validated as one Dask task (a local cluster by
default, or the scheduler at ``--scheduler``). Results as Parquet in ``DIR`` plus
``summary.json``; a failing log is reported with its error and the rest go on; a re-run skips the
groups whose inputs are unchanged. With ``--json`` one object: ``out``, ``groups``, ``ran``,
``skipped``, ``logs``, ``logs_ok``, ``errors`` (group, log, kind, error), ``parameters``,
``validation`` (row counts).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import SchedulerOpt, WorkersOpt, emit_json


def batch(campaign: Path, out: Path, *, scheduler: str | None = None,
          workers: int | None = None, progress: bool = True) -> dict[str, Any]:
    """Everything ``usvid batch`` does; returns its JSON object."""
    from usvid.scale.batch import run_batch, stale_groups
    from usvid.scale.cluster import check_scheduler_address, check_workers, connect

    if scheduler:
        check_scheduler_address(scheduler)
    check_workers(workers)
    # (a bad campaign file, or an --out over its inputs, fails before a cluster is started;
    # nothing to run: none is started)
    if not stale_groups(campaign, out):
        return run_batch(campaign, out, progress=progress)
    with connect(scheduler, workers) as client:
        return run_batch(campaign, out, client=client, progress=progress)


def register(app: typer.Typer) -> None:
    @app.command("batch")
    def batch_cmd(
        campaign: Annotated[Path, typer.Argument(help="Campaign file (YAML).",
                                                 show_default=False)],
        out: Annotated[Path, typer.Option("--out", help="Results folder.")],
        scheduler: SchedulerOpt = None,
        workers: WorkersOpt = None,
        as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    ) -> None:
        """Identify and validate groups of logs of a campaign, one Dask task per group."""
        s = batch(campaign, out, scheduler=scheduler, workers=workers, progress=not as_json)
        if as_json:
            emit_json(s)
            return
        print(f"batch: {s['groups']} group(s), ran {len(s['ran'])}, skipped "
              f"{len(s['skipped'])} unchanged; {s['logs_ok']} of {s['logs']} log(s) read; "
              f"{s['parameters']} parameter rows, {s['validation']} validation rows -> "
              f"{s['out']}")
        for e in s["errors"]:
            what = e["log"] or f"kind {e['kind']}"
            msg = e["error"] if e["error"].startswith(what) else f"{what}: {e['error']}"
            print(f"  error: {e['group']}: {msg}")
