"""CLI: ``usvid identify LOG... --format SPEC --model KIND [--method ls|rls|oe|oe-zigzag]
[--validate LOG...] [--report DIR] [--accept-failed-checks] --out MODEL.json [--json]``.

Reads the logs with the format spec and prepares each once (:func:`usvid.prep.logs.
prepare_logs`: uniform grid, repaired and unwrapped heading, missing channels derived); the
estimator, the validation and the report use those prepared trials. Identifies the model
(:mod:`usvid.identify`; without ``--method`` the kind's best method,
:data:`usvid.identify.defaults.DEFAULT_METHODS`), checks it (:mod:`usvid.identify.checks`:
refused with exit 2 when it fails, unless ``--accept-failed-checks``) and writes the model file
atomically (ARCHITECTURE.md schema; ``identification`` holds the data files with their sha256,
the method, standard errors, covariance, 95 % intervals, fit metrics and the checks). Prints a
fit summary; with ``--json`` one JSON object: ``model_file``, ``kind``, ``method``, ``params``,
``std_errors``, ``ci95``, ``held``, ``fit`` (training metrics per output channel: rmse, nrmse,
r2, max_error), ``validation`` (the rows of ``usvid validate``, one per held-out log:
:class:`usvid.identify.validation.TrialValidation`), ``report`` and ``data``.
"""

from __future__ import annotations

import json
import math
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
    emit_json,
    print_validation,
    psi_switch_option,
    report_files,
    say_format,
)
from usvid.errors import UsvidError


def kind_names() -> list[str]:
    """The model kinds for the help text (the registry's list; it names them without importing
    them, so the help stays fast)."""
    from usvid.models.registry import names

    return list(names())


LogsArg = Annotated[list[Path], typer.Argument(help="Log file(s) to identify from.",
                                               show_default=False)]
ModelOpt = Annotated[str, typer.Option(
    "--model", "-m", help="Model kind: " + " | ".join(kind_names()) + ".")]
def _method_help() -> str:
    from usvid.identify.defaults import DEFAULT_METHODS

    defaults = "; ".join(f"{k} {', then '.join(m)}" for k, m in sorted(DEFAULT_METHODS.items()))
    return ("ls (least squares) | rls (recursive, --lam) | oe (LS + output error) | oe-zigzag "
            "(LS + closed-loop zig-zag replay output error). Default: the kind's method that "
            f"predicts held-out zig-zags best, the next one when its model fails the checks "
            f"(oe-zigzag only for logs with zig-zags): {defaults}; others ls.")


MethodOpt = Annotated[str | None, typer.Option("--method", help=_method_help())]
AcceptOpt = Annotated[bool, typer.Option(
    "--accept-failed-checks", help="Write the model even when it fails its checks (a standard "
    "manoeuvre inside the training envelope diverges or turns the wrong way, the training free "
    "run diverges, it explains too little of the heading); the failures are kept in the model "
    "file's identification.checks. Without it such a model is refused (exit 2).")]
ValidateOpt = Annotated[list[Path] | None, typer.Option(
    "--validate", help="Held-out log(s) to validate on (repeat the option for several).")]
OutOpt = Annotated[Path, typer.Option("--out", "-o", help="Model file to write (JSON).")]
WindowOpt = Annotated[float, typer.Option(
    "--window-s", help="Output-error / metric window [s] (multiple shooting).")]
OverlapOpt = Annotated[float, typer.Option(
    "--overlap", help="Overlap of output-error windows, 0 <= overlap < 1.")]
LamOpt = Annotated[float, typer.Option("--lam", help="RLS forgetting factor (0, 1].")]
NorrbinOpt = Annotated[str, typer.Option(
    "--norrbin", help="Norrbin fit: joint (n1 free) | two_step (Mu et al. 2018, with --turning "
    "logs).")]
TurningOpt = Annotated[list[Path] | None, typer.Option(
    "--turning", help="Turning-test log(s) for --norrbin two_step (repeat for several).")]
XlOpt = Annotated[float | None, typer.Option(
    "--x-l", help="Thruster arm behind the pivot [m] (threedof; else vessel.extra.x_l).")]
DisturbanceOpt = Annotated[str | None, typer.Option(
    "--disturbance", help="Estimate what was not logged, with the hull (kinds with surge and "
    "sway): current (a constant current per trial, north and east [m/s]), bias (a constant "
    "sway force [N] and yaw moment [N m] per trial), or current,bias; by the output error "
    "(--method oe, the default with this option) or, current only, by the regression "
    "(--method ls/rls); reported per trial with 95 % intervals (JSON and model file: "
    "identification.disturbance), with a warning when the manoeuvres cannot separate them "
    "from the hull.")]
VesselOpt = Annotated[list[str] | None, typer.Option(
    "--vessel", help="A vessel particular NAME=VALUE in SI units, overriding the format spec's "
    "vessel block (e.g. propeller_diameter=0.46); repeat for several.")]


def _load(paths: list[Path], fmt: str, t_start: float | None = None,
          t_end: float | None = None) -> list[Any]:
    """Read, trim and prepare each log once (:func:`usvid.prep.logs.prepare_logs`)."""
    from usvid.prep.logs import prepare_logs

    trials = prepare_logs(paths, fmt, t_start, t_end)
    say_format(trials, paths)
    return trials


def _spec_files(fmt: str) -> list[Path]:
    """The format spec's file when ``fmt`` names one (an input the output must not overwrite)."""
    p = Path(fmt) if fmt else None
    return [p] if p is not None and p.is_file() else []


def check_options(kind: str, method: str | None, *, window_s: float, overlap: float, lam: float,
                  norrbin: str) -> None:
    """The options of ``usvid identify`` at the edge, each error naming its option."""
    from usvid.commands._common import check_number
    from usvid.identify.estimator import METHODS

    kinds = kind_names()
    if kind not in kinds:
        raise UsvidError(f"--model {kind!r}: not a model kind (choose one of: "
                         f"{', '.join(kinds)})")
    if method is not None and method not in METHODS:
        raise UsvidError(f"--method {method!r}: not a method (choose one of: "
                         f"{', '.join(METHODS)})")
    if norrbin not in ("joint", "two_step"):
        raise UsvidError(f"--norrbin {norrbin!r}: choose joint or two_step")
    check_number(window_s, "--window-s", lo=0.0, hi=MAX_WINDOW_S, lo_open=True, unit="s")
    check_number(overlap, "--overlap", lo=0.0, hi=1.0, hi_open=True)
    check_number(lam, "--lam", lo=0.0, hi=1.0, lo_open=True)


#: Longest output-error / metric window [s] (a log of an hour; longer is one whole log).
MAX_WINDOW_S = 3600.0


def _particulars(x_l: float | None, vessel: list[str] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in vessel or []:
        key, sep, val = item.partition("=")
        try:
            if not sep or not key.strip():
                raise ValueError
            out[key.strip()] = float(val)
        except ValueError:
            raise UsvidError(f"--vessel {item!r}: expected NAME=NUMBER (SI units)") from None
        if not math.isfinite(out[key.strip()]):
            raise UsvidError(f"--vessel {item!r}: the value must be finite")
    if x_l is not None:
        from usvid.commands._common import check_number

        check_number(x_l, "--x-l", lo=-1000.0, hi=1000.0, unit="m")
        out["x_l"] = x_l
    return out


def identify_logs(logs: list[Path], fmt: str, kind: str, method: str | None = None, *,
                  validate: list[Path] | None = None, out: Path | None = None,
                  window_s: float = 20.0, overlap: float = 0.0, lam: float = 1.0,
                  norrbin: str = "joint", turning: list[Path] | None = None,
                  x_l: float | None = None, vessel: list[str] | None = None,
                  t_start: float | None = None, t_end: float | None = None,
                  psi_deg: float | None = None, report: Path | None = None,
                  accept_failed_checks: bool = False,
                  disturbance: str | None = None) -> dict[str, Any]:
    """Everything ``usvid identify`` does; returns its JSON object (and writes ``out``).
    Logs are ``LOG`` or ``LOG:T0:T1`` (:func:`usvid.prep.logs.parse_log_arg`), each read and
    prepared once: the estimator, the validation and the report use the same prepared trials."""
    from usvid.files import check_outputs
    from usvid.identify.estimator import ModelEstimator
    from usvid.identify.validation import validate_model
    from usvid.io.modelfile import save_model
    from usvid.prep.logs import input_paths

    if not logs:
        raise UsvidError("identify: give at least one LOG")
    check_options(kind, method, window_s=window_s, overlap=overlap, lam=lam, norrbin=norrbin)
    psi_switch_option(psi_deg)
    # the files read (LOG:T0:T1 trims resolved to their files), checked against every output
    # before any work: never overwrite an input
    inputs = [*input_paths([*logs, *(validate or []), *(turning or [])], t_start, t_end),
              *_spec_files(fmt)]
    check_outputs([out, *report_files(report)], inputs)
    est = ModelEstimator(kind, method, window_s=window_s, overlap=overlap, lam=lam,
                         norrbin=norrbin, particulars=_particulars(x_l, vessel),
                         checks="record" if accept_failed_checks else "error",
                         disturbance=disturbance)
    psi_switch = psi_switch_option(psi_deg)  # the zig-zag switching angle of every log, as given
    trials = _load(logs, fmt, t_start, t_end)
    est.fit(trials, turning=_load(turning, fmt, t_start, t_end) if turning else None,
            psi_switch=psi_switch)
    res = est.result_
    summary: dict[str, Any] = {
        "model_file": str(out) if out is not None else None,
        **res.summary(),
        "data": res.data,
    }
    held_res, held = None, []
    if validate:
        held = _load(validate, fmt, t_start, t_end)
        held_res = validate_model(est.model_, held, psi_switch=psi_switch,
                                  window_s=est.window_s, water=est.water_of)
        summary["validation"] = held_res.to_dict()["validation"]
    if report is not None:
        from usvid.report.validation_run import write_identify_report

        training = validate_model(est.model_, trials, psi_switch=psi_switch,
                                  window_s=est.window_s, water=est.water_of)
        summary["report"] = str(write_identify_report(
            report, est, training, trials, held_res, held,
            model_file=str(out) if out is not None else None))
    if out is not None:
        from usvid.files import to_json

        if "validation" in summary:
            est.model_.identification["validation"] = json.loads(to_json(summary["validation"]))
        save_model(est.model_, out, inputs=inputs)
    return summary


def _print_summary(s: dict[str, Any]) -> None:
    print(f"model {s['kind']} ({s['method']}) -> {s['model_file'] or '(not written)'}")
    for k, v in s["params"].items():
        lo, hi = s["ci95"].get(k, (math.nan, math.nan))
        # the interval's own half-width: Student-t for the cluster-robust OE covariance
        if k in s.get("held", ()):
            print(f"  {k:8s} = {v: .6g}  (held at its prior: not identified by {s['method']})")
            continue
        print(f"  {k:8s} = {v: .6g}  +- {(hi - lo) / 2:.3g} (95 %)")
    w = s.get("wind")
    if w and w.get("model"):
        lo, hi = w["ci95"]
        scale = (f"{w['wind_scale']: .6g}  (held: {w['held']})" if w.get("held") else
                 f"{w['wind_scale']: .6g}  +- {(hi - lo) / 2:.3g} (95 %)")
        print(f"  wind_scale = {scale}; wind loads {w['model']} from the logged wind")
    elif w and w.get("trials"):
        print(f"  wind: {w['reason']}")
    _print_disturbance(s.get("disturbance"))
    for label, fit in (("fit", s["fit"]), ("free run", s["fit"].get("free_run", {}))):
        for ch, m in fit.items():
            if isinstance(m, dict) and "rmse" in m:
                print(f"  {label} {ch:4s} rmse {m['rmse']:.4g}  nrmse {m['nrmse']:.3g}  "
                      f"r2 {m['r2']:.4f}")
    if s.get("validation"):
        print_validation(s["validation"])
    if s.get("report"):
        print(f"report: {s['report']}")


def _print_disturbance(d: dict[str, Any] | None) -> None:
    """The per-trial current / biases of ``--disturbance`` with their 95 % half-widths."""
    if not d:
        return
    for row in d["trials"]:
        parts = []
        for q in ("current_north", "current_east", "bias_Y", "bias_N"):
            if q in row:
                lo, hi = row[q]["ci95"]
                parts.append(f"{q} {row[q]['value']: .3g} +- {(hi - lo) / 2:.2g} "
                             f"{row[q]['unit']}")
        if "current_speed_m_s" in row:
            parts.append(f"(current {row['current_speed_m_s']:.3g} m/s towards "
                         f"{row['current_towards_deg']:.0f} deg)")
        print(f"  disturbance {row['trial']}: " + ", ".join(parts))
    if d.get("warning"):
        print(f"  disturbance: {d['warning']}")


def register(app: typer.Typer) -> None:
    """Register ``usvid identify``."""

    @app.command("identify")
    def identify_cmd(logs: LogsArg, model: ModelOpt, out: OutOpt, fmt: FormatOpt = "auto",
                     method: MethodOpt = None, validate: ValidateOpt = None,
                     json_out: JsonOpt = False, window_s: WindowOpt = 20.0,
                     overlap: OverlapOpt = 0.0, lam: LamOpt = 1.0,
                     norrbin: NorrbinOpt = "joint", turning: TurningOpt = None,
                     x_l: XlOpt = None, vessel: VesselOpt = None,
                     t_start: TStartOpt = None, t_end: TEndOpt = None,
                     psi_deg: PsiOpt = None, report: ReportOpt = None,
                     accept_failed_checks: AcceptOpt = False,
                     disturbance: DisturbanceOpt = None) -> None:
        """Identify a manoeuvring model from trial logs and write the model file."""
        s = identify_logs(logs, fmt, model, method, validate=validate, out=out,
                          window_s=window_s, overlap=overlap, lam=lam, norrbin=norrbin,
                          turning=turning, x_l=x_l, vessel=vessel, t_start=t_start,
                          t_end=t_end, psi_deg=psi_deg, report=report,
                          accept_failed_checks=accept_failed_checks,
                          disturbance=disturbance)
        if json_out:
            emit_json(s)
        else:
            _print_summary(s)
