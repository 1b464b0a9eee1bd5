"""A run directory: ``run.json`` (everything the report needs) and ``report.html`` made from it.

``run.json`` (written by ``usvid demo``; JSON, SI units unless a key names another unit) holds:

- ``usvid_run``: 1 (format version); ``title``; ``created_by``; ``usvid_version``;
  ``settings`` (seed, quick, ...); ``vessel`` (particulars);
- ``steps``: ``[{"name", "status": "ok"|"unavailable"|"failed"|"skipped", "seconds", "message"}]``;
- ``campaign``: ``{"description", "trials": [{"name", "kind", "delta_deg", "psi_deg",
  "duration_s", "files"}]}``;
- ``audit``: ``[{"trial", "findings": [Finding.to_dict()], "rejected": {reason: count}}]``;
- ``models``: ``[{"kind", "label", "equation", "file", "method", "params", "ci95": {name: [lo,
  hi]}, "truth", "units", "fit"}]``; ``truth_definition`` (how the truth was obtained);
  ``norrbin_fit``: steady turns and the fitted curve;
- ``validation``: ``[{"trial", "model", "t", "xy": {"measured": {"x", "y"}, "simulated": {...}},
  "channels": [{"name", "ylabel", "lines": {"measured": [...], "simulated": [...]}}],
  "metrics": {"measured": {...}, "simulated": {...}}, "imo": [...], "fit": {...}}]``;
- ``course_keeping``: ``{"t", "target_deg", "disturbance", "runs": [{"label", "kp", "ki", "kd",
  "psi_deg", "delta_deg", "itae", "iae", "max_rudder_deg"}], "paper_itae"}``;
- ``turning_diameter``: ``{"points_delta_deg", "points_D_over_L", "curve_delta_deg",
  "curve_D_over_L", "coeffs", "rms"}``;
- ``timing``: ``{"total_s", ...}``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from usvid.errors import UsvidError
from usvid.files import to_json, write_atomic
from usvid.report.html import build_html, external_urls

RUN_FILE = "run.json"
REPORT_FILE = "report.html"
RUN_FORMAT = 1


def save_run(run: dict[str, Any], run_dir: str | Path) -> Path:
    """Write ``run`` as ``RUN_DIR/run.json`` atomically; returns the path."""
    return write_atomic(Path(run_dir) / RUN_FILE, to_json(run) + "\n")


def load_run(run_dir: str | Path) -> dict[str, Any]:
    """Read ``RUN_DIR/run.json`` (or the file itself when given one).

    Raises :class:`UsvidError` naming the file when it is missing, not JSON, or not a run.
    """
    path = Path(run_dir)
    if path.is_dir():
        path = path / RUN_FILE
    if not path.is_file():
        raise UsvidError(f"{path}: no run file (expected the run.json written by `usvid demo`)")
    try:
        run = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UsvidError(f"{path}: not a readable JSON run file ({exc})") from exc
    if not isinstance(run, dict) or run.get("usvid_run") != RUN_FORMAT:
        raise UsvidError(
            f"{path}: field usvid_run must be {RUN_FORMAT} (got {run.get('usvid_run')!r})"
            if isinstance(run, dict)
            else f"{path}: expected a JSON object"
        )
    return run


def write_report(run: dict[str, Any], run_dir: str | Path, *, inputs: Any = ()) -> Path:
    """Build the HTML from ``run`` and write ``RUN_DIR/report.html`` atomically; returns the path.

    Raises :class:`UsvidError` if the HTML would name an external URL (it must open offline).
    """
    text = build_html(run)
    urls = external_urls(text)
    if urls:  # defensive: esc() neutralises text, so only a bug gets here
        raise UsvidError(f"report would reference external URLs: {sorted(set(urls))[:3]}")
    return write_atomic(Path(run_dir) / REPORT_FILE, text, inputs=inputs)


def regenerate(run_dir: str | Path) -> Path:
    """``usvid report RUN_DIR``: read ``run.json`` and (re)write ``report.html`` next to it."""
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    src = run_dir / RUN_FILE if run_dir.is_dir() else run_dir
    return write_report(run, run_dir if run_dir.is_dir() else run_dir.parent, inputs=[src])
