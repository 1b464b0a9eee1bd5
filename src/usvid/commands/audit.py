"""CLI: ``usvid audit LOG --format SPEC [--json]`` - check a log's channels against the physics.

Reads the log with its trial format spec (a YAML path or a shipped spec name), runs
:func:`usvid.prep.audit` and prints the findings (the reader's and the audit's, errors first,
then warnings, then infos). With ``--json`` one
object: ``file``, ``format``, ``samples``, ``duration_s``, ``channels``, ``rejected`` (record counts
per reason from the reader), ``findings`` (list of {severity, code, message, count, t_start, t_end,
channel, data}) and ``counts`` per severity. Exit code 3 when error-severity findings exist
(the output is complete; a script can test for it). A log that cannot be read at all, or holds
fewer than three valid records, exits with code 2 and a one-line reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import FormatOpt, JsonOpt

LogArg = Annotated[Path, typer.Argument(help="Log file to check.", show_default=False)]


def load_log(log: Path, fmt: str) -> Any:
    """Read ``log`` with spec ``fmt`` (:func:`usvid.prep.logs.read_log`), saying on stderr
    what ``--format auto`` chose."""
    from usvid.commands._common import say_format
    from usvid.prep.logs import read_log

    trial = read_log(log, fmt)
    say_format([trial], [log])
    return trial


def audit_log(log: Path, fmt: str) -> dict[str, Any]:
    """The JSON object of ``usvid audit`` for one log."""
    from usvid.prep import audit
    from usvid.prep.channel_audit import sort_findings

    trial = load_log(log, fmt)
    findings = sort_findings(list(trial.findings) + audit(trial))  # errors first
    counts = {s: sum(1 for f in findings if f.severity == s) for s in ("error", "warning", "info")}
    return {
        "file": str(log),
        "format": fmt,
        "samples": len(trial),
        "duration_s": trial.duration,
        "channels": trial.channels,
        "rejected": dict(trial.rejected),
        "findings": [f.to_dict() for f in findings],
        "counts": counts,
    }


def register(app: typer.Typer) -> None:
    """Register ``usvid audit``."""

    @app.command("audit")
    def audit_cmd(log: LogArg, fmt: FormatOpt = "auto", json_out: JsonOpt = False) -> None:
        """Check each channel of a log against the physics and report what is wrong."""
        from usvid.commands._common import emit_json

        out = audit_log(log, fmt)
        if json_out:
            emit_json(out)
            _exit_on_errors(out)
            return
        from rich.console import Console
        from rich.table import Table

        con = Console()
        rej = ", ".join(f"{k} {v}" for k, v in out["rejected"].items()) or "none"
        con.print(f"{log.name}: {out['samples']} samples, {out['duration_s']:.1f} s, "
                  f"rejected records: {rej}")
        if not out["findings"]:
            con.print("no problems found")
            return
        table = Table("severity", "code", "channel", "count", "message")
        for f in out["findings"]:
            table.add_row(f["severity"], f["code"], f["channel"] or "", str(f["count"]),
                          f["message"])
        con.print(table)
        _exit_on_errors(out)


#: Exit code of ``usvid audit`` when error-severity findings exist (the log was read).
EXIT_FINDINGS = 3


def _exit_on_errors(out: dict[str, Any]) -> None:
    if out["counts"].get("error", 0):
        raise typer.Exit(EXIT_FINDINGS)
