"""Campaigns of many logs: each group of logs is read, audited, identified and validated as one
task (``usvid batch CAMPAIGN.yaml --out DIR``).

A campaign file (YAML)::

    groups:
      - name: boat1-day1            # unique; names the group's rows and state file
        logs: ["day1/*.csv"]        # globs, relative to the campaign file
        spec: specs/boat1.yaml      # format spec: a file (relative) or a shipped spec name
        kinds: [nomoto1, norrbin]   # model kinds to identify
        holdout: ["day1/run7.csv"]  # globs of the held-out logs (validation only)
        method: oe                  # optional: ls, rls, oe, oe-zigzag (default: each kind's
                                    # best, as usvid identify)

A log that cannot be read (or has fewer than three valid records) is reported with its error and
the group goes on without it; a kind that cannot be identified is reported likewise. Results in
``DIR``: ``logs.parquet`` (one row per log: role, ok, samples, audit counts, error),
``parameters.parquet`` (group, kind, parameter, value [SI], std_error), ``validation.parquet``
(group, kind, log, channel, metric, value), ``summary.json``; each group's result is kept in
``DIR/groups/NAME.json`` with a fingerprint of its inputs (configuration, spec, and path, size and
modification time of every log): a re-run skips groups whose fingerprint is unchanged.
"""

from __future__ import annotations

import glob
import hashlib
import io
import json
import math
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from usvid.errors import UsvidError
from usvid.files import check_outputs, load_yaml_text, read_input_text, to_json, write_atomic
from usvid.identify.estimator import ModelEstimator
from usvid.identify.validation import validate_model
from usvid.io import read_trial
from usvid.io.spec import MAX_SPEC_BYTES
from usvid.models.registry import names as kind_names
from usvid.prep import audit, prepare
from usvid.scale.cluster import map_ordered

__all__ = ["Group", "load_campaign", "run_batch", "run_group", "stale_groups"]

METHODS = ("ls", "rls", "oe")


@dataclass
class Group:
    """One group of a campaign: resolved log paths (training and held out), format spec (a path
    or a shipped spec name), kinds, method."""

    name: str
    train: list[str]
    holdout: list[str]
    spec: str
    kinds: list[str]
    method: str | None = None
    fingerprint: str = ""
    #: The group's log and hold-out globs (absolute): what a run reads its logs from.
    patterns: list[str] = field(default_factory=list)


@dataclass
class GroupResult:
    group: str
    fingerprint: str
    logs: list[dict[str, Any]] = field(default_factory=list)
    parameters: list[dict[str, Any]] = field(default_factory=list)
    validation: list[dict[str, Any]] = field(default_factory=list)
    errors: list[dict[str, Any]] = field(default_factory=list)


def _short(v: Any) -> str:
    r = repr(v)
    return r if len(r) <= 60 else r[:60] + "..."


def _text(v: Any, where: str) -> str:
    """A campaign string: text without control characters (a NUL cannot be in a path)."""
    if not isinstance(v, str) or not v or len(v) > 4096 \
            or any(ord(ch) < 32 or ord(ch) == 127 for ch in v):
        raise UsvidError(f"{where}: expected a non-empty text without control characters "
                         f"(got {_short(v)})")
    return v


def _globs(patterns: Any, base: Path, where: str) -> list[str]:
    """The globs of a campaign entry, made absolute (relative ones to the campaign's folder)."""
    if isinstance(patterns, str):
        patterns = [patterns]
    if not isinstance(patterns, list):
        raise UsvidError(f"{where}: expected a glob or a list of globs (got {_short(patterns)})")
    return [p if Path(p).is_absolute() else str(base / p)
            for p in (_text(x, where) for x in patterns)]


def _expand(patterns: list[str]) -> list[str]:
    out: list[str] = []
    for full in patterns:
        out.extend(sorted(glob.glob(full, recursive=True)))
    return list(dict.fromkeys(out))


def _fingerprint(group: Group, spec_text: str) -> str:
    h = hashlib.sha256()
    cfg = {k: v for k, v in asdict(group).items() if k not in ("fingerprint", "patterns")}
    h.update(json.dumps(cfg, sort_keys=True).encode())
    h.update(spec_text.encode())
    for p in (*group.train, *group.holdout):
        st = Path(p).stat()
        h.update(f"{p}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


#: Largest campaign file [bytes] (a campaign of a thousand groups is about 200 kB).
MAX_CAMPAIGN_BYTES = 10_000_000
#: Longest group name [characters] (it names a state file, ``groups/NAME.json``).
MAX_NAME = 100


def load_campaign(path: str | Path) -> list[Group]:
    """The groups of the campaign file ``path``; UsvidError naming the file, group and key.

    The file is read as any untrusted input (:func:`usvid.files.read_input_text`: a regular
    UTF-8 file of at most :data:`MAX_CAMPAIGN_BYTES`; :func:`usvid.files.load_yaml_text`: plain
    YAML with bounded nesting and alias expansion). Every group names at least one kind, and
    each of its log and hold-out globs matches at least one file."""
    path = Path(path)
    text = read_input_text(path, "campaign file", MAX_CAMPAIGN_BYTES)
    doc = load_yaml_text(text, str(path))
    if not isinstance(doc, dict) or not isinstance(doc.get("groups"), list) or not doc["groups"]:
        raise UsvidError(f"{path}: expected a mapping with a non-empty list 'groups'")
    base = path.parent
    groups, seen = [], set()
    for i, g in enumerate(doc["groups"]):
        where = f"{path}: groups[{i}]"
        if not isinstance(g, dict):
            raise UsvidError(f"{where}: expected a mapping")
        unknown = set(map(str, g)) - {"name", "logs", "spec", "kinds", "holdout", "method"}
        if unknown:
            raise UsvidError(f"{where}: unknown key(s) {_short(', '.join(sorted(unknown)))} "
                             "(expected name, logs, spec, kinds, holdout, method)")
        name = g.get("name")
        if not isinstance(name, str) or not name or len(name) > MAX_NAME or name in seen \
                or name in (".", "..") or any(ch in name for ch in "/\\") \
                or any(ord(ch) < 32 or ord(ch) == 127 for ch in name):
            raise UsvidError(f"{where}.name: expected a unique name of at most {MAX_NAME} "
                             "characters without '/', '\\' or control characters "
                             f"(got {_short(name)})")
        seen.add(name)
        for key in ("logs", "spec", "kinds"):
            if key not in g:
                raise UsvidError(f"{where} ({name}): '{key}' is missing")
        kinds = g["kinds"] if isinstance(g["kinds"], list) else [g["kinds"]]
        if not kinds:
            raise UsvidError(f"{where}.kinds: empty; name at least one model kind (known: "
                             f"{', '.join(kind_names())})")
        for k in kinds:
            if not isinstance(k, str) or k not in kind_names():
                raise UsvidError(f"{where}.kinds: unknown kind {_short(k)} (known: "
                                 f"{', '.join(kind_names())})")
        method = g.get("method")
        if method is not None and (not isinstance(method, str) or method not in METHODS):
            raise UsvidError(f"{where}.method: expected one of {', '.join(METHODS)} "
                             f"(got {_short(method)})")
        log_globs = _globs(g["logs"], base, f"{where}.logs")
        hold_globs = _globs(g.get("holdout", []), base, f"{where}.holdout")
        logs = _expand(log_globs)
        if not logs:
            raise UsvidError(f"{where}.logs: no file matches {_short(g['logs'])}")
        hold = set()
        for pat in hold_globs:
            found = _expand([pat])
            if not found:
                raise UsvidError(f"{where}.holdout: no file matches {_short(pat)}")
            hold.update(found)
        spec = _text(g["spec"], f"{where}.spec")
        spec_path = base / spec
        spec_text = ""
        if spec_path.exists():  # a spec file (else a shipped spec's name)
            spec = str(spec_path)
            spec_text = read_input_text(spec_path, "format spec", MAX_SPEC_BYTES)
        group = Group(name, [p for p in logs if p not in hold], sorted(hold), spec,
                      [str(k) for k in kinds], method, patterns=log_globs + hold_globs)
        group.fingerprint = _fingerprint(group, spec_text)
        groups.append(group)
    return groups


def output_files(groups: list[Group], out: str | Path) -> list[Path]:
    """Every file :func:`run_batch` writes into ``out`` for ``groups``."""
    out = Path(out)
    return [out / "logs.parquet", out / "parameters.parquet", out / "validation.parquet",
            out / "summary.json", *(out / "groups" / f"{g.name}.json" for g in groups)]


def check_batch_outputs(campaign: str | Path, groups: list[Group], out: str | Path) -> None:
    """Refuse (:class:`usvid.files.OutputError`, before any work) an ``out`` folder where a
    result would overwrite an input of the campaign (the campaign file, a spec, a log) or would
    be matched by one of its globs (the next run would read it as a log)."""
    inputs = [campaign, *(g.spec for g in groups if Path(g.spec).exists()),
              *(p for g in groups for p in (*g.train, *g.holdout))]
    check_outputs(output_files(groups, out), inputs,
                  patterns=[p for g in groups for p in g.patterns])


def _read(path: str, spec: str, role: str, res: GroupResult) -> Any:
    row: dict[str, Any] = {"group": res.group, "log": path, "role": role, "ok": False,
                           "samples": 0, "audit_errors": 0, "audit_warnings": 0, "error": None}
    res.logs.append(row)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tr = read_trial(path, spec)
            if len(tr) < 3:
                raise UsvidError(f"{path}: only {len(tr)} valid record(s)")
            findings = list(tr.findings) + audit(tr)
            tr = prepare(tr, derivatives=False)  # once: the fit and the validation share it
    except Exception as exc:  # noqa: BLE001 - a failing log is reported, the rest go on
        row["error"] = _one_line(exc)
        res.errors.append({"group": res.group, "log": path, "kind": None, "error": row["error"]})
        return None
    row.update(ok=True, samples=len(tr),
               audit_errors=sum(f.severity == "error" for f in findings),
               audit_warnings=sum(f.severity == "warning" for f in findings))
    return tr


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if isinstance(exc, UsvidError) else f"{type(exc).__name__}: {text}"


def run_group(group: Group) -> GroupResult:
    """Read, audit, identify and validate one group (one Dask task)."""
    res = GroupResult(group.name, group.fingerprint)
    train = [t for p in group.train if (t := _read(p, group.spec, "train", res)) is not None]
    hold = [t for p in group.holdout if (t := _read(p, group.spec, "holdout", res)) is not None]
    for kind in group.kinds:
        if not train:
            res.errors.append({"group": group.name, "log": None, "kind": kind,
                               "error": "no readable training log"})
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                est = ModelEstimator(kind, group.method).fit(train)
                table = [r.to_dict() for r in validate_model(
                    est.model_, hold, window_s=est.window_s).rows] if hold else []
        except Exception as exc:  # noqa: BLE001 - reported, the other kinds go on
            res.errors.append({"group": group.name, "log": None, "kind": kind,
                               "error": _one_line(exc)})
            continue
        r = est.result_
        for p, v in r.params.items():
            se = r.std_errors.get(p)
            res.parameters.append({"group": group.name, "kind": kind, "parameter": p,
                                   "value": float(v), "std_error": _num(se)})
        for row in table:
            for ch, ms in row.get("metrics", {}).items():
                if not isinstance(ms, dict):
                    continue
                for m, v in ms.items():
                    if isinstance(v, (int, float)):
                        res.validation.append({"group": group.name, "kind": kind,
                                               "log": row["file"], "channel": ch, "metric": m,
                                               "value": _num(v)})
    return res


def _num(v: Any) -> float:
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan


def _parquet(rows: list[dict[str, Any]], columns: list[str]) -> bytes:
    buf = io.BytesIO()
    pd.DataFrame(rows, columns=columns).to_parquet(buf, index=False)
    return buf.getvalue()


def _plan(groups: list[Group], state: Path) -> tuple[dict[str, GroupResult], list[Group]]:
    """The kept results of the groups whose fingerprint is unchanged (by name), and the groups
    to run (new, changed, or with an unreadable state file in ``state``)."""
    done: dict[str, GroupResult] = {}
    todo = []
    for g in groups:
        f = state / f"{g.name}.json"
        if f.is_file():
            try:
                old = json.loads(f.read_text(encoding="utf-8"))
                if old.get("fingerprint") == g.fingerprint:
                    done[g.name] = GroupResult(**old)
                    continue
            except (OSError, ValueError, TypeError):
                pass  # unreadable state: run the group again
        todo.append(g)
    return done, todo


def stale_groups(campaign: str | Path, out: str | Path) -> list[str]:
    """Names of the campaign's groups that :func:`run_batch` into ``out`` would run (new or
    changed inputs); empty when a re-run has nothing to do (no cluster is then needed). Refuses
    an ``out`` that would overwrite an input, before any work (:func:`check_batch_outputs`)."""
    groups = load_campaign(campaign)
    check_batch_outputs(campaign, groups, out)
    return [g.name for g in _plan(groups, Path(out) / "groups")[1]]


def run_batch(campaign: str | Path, out: str | Path, *, client: Any = None,
              progress: bool = True) -> dict[str, Any]:
    """Run the campaign's changed groups (as Dask tasks on ``client``, else in this process),
    write the results into ``out`` and return the summary (the ``--json`` object)."""
    groups = load_campaign(campaign)
    check_batch_outputs(campaign, groups, out)
    out = Path(out)
    state = out / "groups"
    done, todo = _plan(groups, state)
    if client is None:
        results = [run_group(g) for g in todo]
    else:
        results = map_ordered(client, run_group, [(g,) for g in todo], progress=progress,
                              label="batch")
    for r in results:
        write_atomic(state / f"{r.group}.json", to_json(asdict(r)))
        done[r.group] = r
    ordered = [done[g.name] for g in groups]
    logs = [row for r in ordered for row in r.logs]
    write_atomic(out / "logs.parquet", _parquet(logs, ["group", "log", "role", "ok", "samples",
                                                       "audit_errors", "audit_warnings",
                                                       "error"]))
    write_atomic(out / "parameters.parquet", _parquet(
        [row for r in ordered for row in r.parameters],
        ["group", "kind", "parameter", "value", "std_error"]))
    write_atomic(out / "validation.parquet", _parquet(
        [row for r in ordered for row in r.validation],
        ["group", "kind", "log", "channel", "metric", "value"]))
    summary = {
        "out": str(out), "groups": len(groups), "ran": [r.group for r in results],
        "skipped": [g.name for g in groups if g.name not in {r.group for r in results}],
        "logs": len(logs), "logs_ok": sum(bool(row["ok"]) for row in logs),
        "errors": [e for r in ordered for e in r.errors],
        "parameters": sum(len(r.parameters) for r in ordered),
        "validation": sum(len(r.validation) for r in ordered),
    }
    write_atomic(out / "summary.json", to_json(summary))
    return summary
