"""CLI: ``usvid validate MODEL LOG... --format SPEC [--psi-deg S] [--t-start/--t-end]
[--report DIR] [--json]`` - validate a model file on measured logs.

For each log (``LOG`` or ``LOG:T0:T1``, times in seconds from its first record): the manoeuvre
found in it, its measured metrics, the model's closed-loop prediction of the same manoeuvre (the
detected amplitude, switching angle and first side, the measured approach speed and shaft
speed) and a free-run replay of the measured inputs (:mod:`usvid.identify.validation`). JSON:
``{"model_file", "validation": [{"trial", "file", "manoeuvre": "zigzag"|"turning"|"other",
"measured", "predicted", "error", "replay", "settings", "messages"}]}``; the metric keys are
those of ``usvid metrics``. ``identify --validate LOG`` gives the same rows.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import (
    FormatOpt,
    JsonOpt,
    PsiOpt,
    ReportOpt,
    TEndOpt,
    TStartOpt,
    print_validation,
    psi_switch_option,
    report_files,
)

ModelArg = Annotated[Path, typer.Argument(help="Model file (JSON) to validate.",
                                          show_default=False)]
LogsArg = Annotated[list[str], typer.Argument(
    help="Log file(s) to validate on; LOG:T0:T1 uses the part T0..T1 [s] of a log.",
    show_default=False)]


def validate_logs(model_path: Path, logs: list[str], fmt: str = "auto", *,
                  psi_deg: float | None = None, t_start: float | None = None,
                  t_end: float | None = None) -> tuple[dict[str, Any], Any]:
    """Everything ``usvid validate`` does; returns its JSON object and
    ``(ValidationResult, trials, model)`` for the report. Each log is read and prepared once
    (:func:`usvid.prep.logs.prepare_logs`); the validation and the report use that trial."""
    from usvid.commands._common import say_format
    from usvid.errors import UsvidError
    from usvid.identify.validation import validate_model
    from usvid.io.modelfile import load_model
    from usvid.prep.logs import prepare_logs

    if not logs:
        raise UsvidError("validate: give at least one LOG")
    psi_switch_option(psi_deg)
    model = load_model(model_path)
    trials = prepare_logs(logs, fmt, t_start, t_end)
    say_format(trials, logs)
    res = validate_model(model, trials, psi_switch=psi_switch_option(psi_deg))
    return {"model_file": str(model_path), **res.to_dict()}, (res, trials, model)


def register(app: typer.Typer) -> None:
    """Register ``usvid validate``."""

    @app.command("validate")
    def validate_cmd(model_path: ModelArg, logs: LogsArg, fmt: FormatOpt = "auto",
                     json_out: JsonOpt = False, psi_deg: PsiOpt = None,
                     t_start: TStartOpt = None, t_end: TEndOpt = None,
                     report: ReportOpt = None) -> None:
        """Validate a model file on logs: predicted vs measured manoeuvres, free-run replay."""
        from usvid.commands._common import emit_json
        from usvid.files import check_outputs
        from usvid.prep.logs import input_paths

        # before any work: the report's files never overwrite an input (a run.json given as
        # the model file or a log, LOG:T0:T1 trims resolved to their files)
        spec = [Path(fmt)] if Path(fmt).is_file() else []
        check_outputs(report_files(report),
                      [model_path, *input_paths(logs, t_start, t_end), *spec])
        out, res = validate_logs(model_path, logs, fmt, psi_deg=psi_deg, t_start=t_start,
                                 t_end=t_end)
        if report is not None:
            from usvid.report.validation_run import write_validation_report

            vres, trials, model = res
            out["report"] = str(write_validation_report(report, vres, trials, model=model,
                                                        model_path=model_path))
        if json_out:
            emit_json(out)
        else:
            print_validation(out["validation"])
            if "report" in out:
                print(f"report: {out['report']}")
