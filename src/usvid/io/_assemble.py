"""Turn decoded records (time + channel arrays) into a :class:`usvid.Trial`.

Shared by every reader, so that all of them treat bad records the same way:

- records without a finite time are rejected (``rejected["nan_time"]``);
- records with no finite channel value are rejected (``rejected["nan_row"]``);
- time going backwards: with ``non_monotonic: sort`` (the default) the records are sorted by time
  (stable) and a warning finding ``non_monotonic_time`` counts the records that were out of order;
  with ``non_monotonic: reject`` every record earlier than the latest time seen before it is
  dropped and counted as ``rejected["non_monotonic"]``;
- records with the same time are merged into one row (per channel the last finite value wins).
  For tables that is counted as ``rejected["duplicate_time"]`` (one row per time is expected);
  for multi-rate logs (NMEA) it is the normal union of time stamps and not counted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from usvid.errors import LogReadError
from usvid.io.spec import FormatSpec
from usvid.trial import Finding, Trial, Vessel


def read_log_bytes(path: Path, limit: int = -1) -> bytes:
    """The bytes of the log ``path`` (opened read-only; at most ``limit`` bytes, -1 = all).

    Shared by every text reader. Raises :class:`LogReadError` naming the file when it cannot be
    read or holds only white space.
    """
    try:
        with open(path, "rb") as fh:  # read-only
            blob = fh.read(limit)
    except OSError as exc:
        raise LogReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not blob.strip():
        raise LogReadError(f"{path}: empty file")
    return blob


def check_log_file(path: Path) -> None:
    """For the binary readers (Excel, Parquet): :class:`LogReadError` when ``path`` is not a file
    or is empty."""
    if not path.is_file():
        raise LogReadError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise LogReadError(f"{path}: empty file")


def ignored_finding(path: Path, code: str, what: str, ignored: dict, *,
                    data: dict | None = None) -> Finding:
    """The info finding of records a reader skipped on purpose (types it does not use):
    ``"<file>: ignored N <what> not used: k1 (n1), k2 (n2)"``, ``count`` N."""
    n = sum(ignored.values())
    return Finding("info", code,
                   f"{path.name}: ignored {n} {what} not used: "
                   + ", ".join(f"{k} ({v})" for k, v in sorted(ignored.items())),
                   count=n, data=dict(data or {}))


def _add(rejected: dict[str, int], reason: str, n: int) -> None:
    if n:
        rejected[reason] = rejected.get(reason, 0) + int(n)


def assemble(
    path: str | Path,
    t: np.ndarray,
    channels: dict[str, np.ndarray],
    *,
    spec: FormatSpec | None,
    rejected: dict[str, int] | None = None,
    findings: list[Finding] | None = None,
    count_duplicates: bool = True,
    meta: dict | None = None,
    non_monotonic: str | None = None,
) -> Trial:
    """Build a Trial from records ``t`` [s] and ``channels`` (arrays of the same length, SI).

    Raises :class:`LogReadError` when no usable record remains.
    """
    path = Path(path)
    rejected = dict(rejected or {})
    findings = list(findings or [])
    t = np.asarray(t, dtype=float)
    chans = {k: np.asarray(v, dtype=float) for k, v in channels.items()}
    nm = non_monotonic or (spec.non_monotonic if spec is not None else "sort")

    keep = np.isfinite(t)
    _add(rejected, "nan_time", int((~keep).sum()))
    if chans:
        anyval = np.zeros(len(t), dtype=bool)
        for v in chans.values():
            anyval |= np.isfinite(v)
        bad = keep & ~anyval
        _add(rejected, "nan_row", int(bad.sum()))
        keep &= anyval
    t = t[keep]
    chans = {k: v[keep] for k, v in chans.items()}
    if len(t) == 0:
        detail = ", ".join(f"{k}: {n}" for k, n in rejected.items()) or "no data records"
        raise LogReadError(f"{path}: no usable records ({detail})")

    # time going backwards
    if len(t) > 1:
        runmax = np.maximum.accumulate(t)
        late = np.r_[False, t[1:] < runmax[:-1]]
        n_back = int(late.sum())
        if n_back:
            i0 = int(np.argmax(late))
            if nm == "reject":
                _add(rejected, "non_monotonic", n_back)
                t = t[~late]
                chans = {k: v[~late] for k, v in chans.items()}
                what = "rejected"
            else:
                order = np.argsort(t, kind="stable")
                t = t[order]
                chans = {k: v[order] for k, v in chans.items()}
                what = "sorted into place"
            findings.append(
                Finding(
                    "warning",
                    "non_monotonic_time",
                    f"{path.name}: time goes backwards at {n_back} record(s) (first at record "
                    f"{i0}, t = {float(runmax[i0 - 1] if i0 else 0.0):.3f} s); they were {what}",
                    count=n_back,
                )
            )

    # identical times -> one row
    uniq, inv = np.unique(t, return_inverse=True)
    if len(uniq) < len(t):
        if count_duplicates:
            _add(rejected, "duplicate_time", len(t) - len(uniq))
        merged = {}
        for k, v in chans.items():
            out = np.full(len(uniq), np.nan)
            m = np.isfinite(v)
            out[inv[m]] = v[m]
            merged[k] = out
        chans = merged
        t = uniq

    data = pd.DataFrame({"t": t, **chans})
    vessel = spec.vessel if spec is not None else Vessel()
    return Trial(
        data=data,
        vessel=Vessel(**{**vessel.__dict__, "extra": dict(vessel.extra)}),
        sources=[str(path)],
        rejected=rejected,
        findings=findings,
        name=path.stem,
        meta={"reader": spec.reader if spec else None, "spec": spec.source if spec else None,
              **(meta or {})},
    )


def apply_renames(chans: dict[str, np.ndarray], spec: FormatSpec | None) -> dict[str, np.ndarray]:
    """For the NMEA readers: apply ``columns`` entries (rename / sign / offset / scale).

    An entry ``name: {col: decoded, sign: -1}`` produces channel ``name`` from decoded channel
    ``decoded``; the decoded channel is dropped when renamed. A missing decoded channel is an error
    unless the entry is ``optional``.
    """
    if spec is None or not spec.columns:
        return chans
    out = dict(chans)
    for c in spec.columns.values():
        src = str(c.col)
        if src not in chans:
            if c.optional:
                continue
            raise LogReadError(
                f"{spec.source}: columns.{c.name}.col: the log has no decoded channel '{src}' "
                f"(decoded: {', '.join(sorted(chans)) or 'none'})"
            )
        if src != c.name and src in out:
            del out[src]
        out[c.name] = c.sign * (c.scale * chans[src] + c.offset)
    return out
