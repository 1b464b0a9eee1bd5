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
- ``papers``: ``{"description", "rows": [{"paper", "quantity", "paper_value", "usvid_value",
  "command", "status"}]}`` (the papers' headline numbers, :mod:`usvid.demo.papers`);
- ``timing``: ``{"total_s", ...}``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from usvid.errors import UsvidError
from usvid.files import InputLimitError, load_json_text, to_json, write_atomic
from usvid.report.html import build_html, external_urls
from usvid.report.validation_html import build_validation_html

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
        raise UsvidError(f"{path}: no run file (expected the run.json written by `usvid demo` "
                         "or by --report DIR of `usvid identify` / `usvid validate`)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UsvidError(f"{path}: not a readable JSON run file ({exc})") from None
    if len(text) > MAX_RUN_CHARS:
        raise UsvidError(f"{path}: {len(text)} characters; a run file has at most "
                         f"{MAX_RUN_CHARS}")
    try:
        run = load_json_text(text, str(path), max_depth=MAX_RUN_DEPTH)  # bounded nesting, numbers
    except InputLimitError:
        raise
    except UsvidError as exc:
        raise UsvidError(f"not a readable JSON run file: {exc}") from None
    if not isinstance(run, dict) or run.get("usvid_run") != RUN_FORMAT:
        raise UsvidError(
            f"{path}: field usvid_run must be {RUN_FORMAT} (got {_short(run.get('usvid_run'))})"
            if isinstance(run, dict)
            else f"{path}: expected a JSON object"
        )
    check_run(run, str(path))
    return run


#: Largest run file accepted [characters] (a full demo writes about 10 MB).
MAX_RUN_CHARS = 500_000_000
#: Deepest nesting of a run file (the demo writes 6 levels).
MAX_RUN_DEPTH = 32
#: Expected JSON type of each top-level field of a run file, and of the items of list fields.
RUN_FIELDS: dict[str, tuple[type, type | None]] = {
    "title": (str, None), "created_by": (str, None), "usvid_version": (str, None),
    "settings": (dict, None), "vessel": (dict, None), "steps": (list, dict),
    "campaign": (dict, None), "audit": (list, dict), "models": (list, dict),
    "truth_definition": (str, None), "norrbin_fit": (dict, None), "validation": (list, dict),
    "course_keeping": (dict, None), "turning_diameter": (dict, None), "papers": (dict, None),
    "timing": (dict, None),
    "acceptance": (dict, None), "summary_text": (str, None),
}
_JSON_NAMES = {str: "text", dict: "an object", list: "a list", float: "a number"}


def _short(v: Any) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:60] + "..."


def check_run(run: dict[str, Any], source: str = "run.json") -> None:
    """Check the types of a run file's top-level fields (and of the items of its lists).

    Raises :class:`UsvidError` naming the field: ``"run.json: field models[2] must be an
    object (got 'x')"``. Unknown fields are allowed (later versions add some).
    """
    for key, (typ, item) in RUN_FIELDS.items():
        if key not in run or run[key] is None:
            continue
        v = run[key]
        if not isinstance(v, typ):
            raise UsvidError(f"{source}: field {key} must be {_JSON_NAMES[typ]} "
                             f"(got {_short(v)})")
        if item is not None:
            for i, x in enumerate(v):
                if not isinstance(x, item):
                    raise UsvidError(f"{source}: field {key}[{i}] must be "
                                     f"{_JSON_NAMES[item]} (got {_short(x)})")


def write_report(run: dict[str, Any], run_dir: str | Path, *, inputs: Any = ()) -> Path:
    """Build the HTML from ``run`` and write ``RUN_DIR/report.html`` atomically; returns the path.

    Raises :class:`UsvidError` if the HTML would name an external URL (it must open offline).
    """
    try:
        if run.get("run_kind") == "validation":  # identify/validate --report
            text = build_validation_html(run)
        else:
            text = build_html(run)
    except (TypeError, ValueError, KeyError, AttributeError, IndexError, OverflowError,
            ZeroDivisionError, RecursionError) as exc:
        # a field of a valid type holds a value the report cannot show: name the section
        raise UsvidError(f"run file: {_section(exc)} holds a malformed value "
                         f"({type(exc).__name__}: {_short(str(exc))[1:-1]})") from None
    # the embedded plotly.js names URLs in strings it never fetches offline; the rest of the
    # page must name none
    urls = external_urls(re.sub(r'<script id="plotly-js">.*?</script>', "", text, count=1,
                                flags=re.S))
    if urls:  # defensive: esc() neutralises text, so only a bug gets here
        raise UsvidError(f"report would reference external URLs: {sorted(set(urls))[:3]}")
    return write_atomic(Path(run_dir) / REPORT_FILE, text, inputs=inputs)


def _section(exc: BaseException) -> str:
    """The report section (its run-file field) whose rendering raised ``exc``."""
    import traceback

    names = [f.name for f in traceback.extract_tb(exc.__traceback__)
             if f.filename.endswith(("html.py", "figures.py"))]
    for n in reversed(names):
        if n.startswith("_") and n.strip("_") in RUN_FIELDS | {"header": 0, "steps": 0}:
            return f"field {n.strip('_')}"
    return "a field"


def regenerate(run_dir: str | Path) -> Path:
    """``usvid report RUN_DIR``: read ``run.json`` and (re)write ``report.html`` next to it."""
    run_dir = Path(run_dir)
    run = load_run(run_dir)
    src = run_dir / RUN_FILE if run_dir.is_dir() else run_dir
    return write_report(run, run_dir if run_dir.is_dir() else run_dir.parent, inputs=[src])
