"""Logs as the commands take them: a file, a trial format spec and the part of the log to use
(``LOG:T0:T1`` [s from the log's first record], or ``--t-start`` / ``--t-end`` for every log),
read and prepared once (:func:`prepare_logs` -> :class:`usvid.prep.PreparedTrial`).

The shared road of ``usvid identify``, ``validate``, ``metrics`` and ``audit``: a log read here
is prepared once, and every later stage of the command (estimator, validation, report) uses
that prepared trial.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from usvid.errors import LogReadError, UsvidError
from usvid.io import read_trial
from usvid.prep.prepare import PreparedTrial, prepare
from usvid.trial import Trial

__all__ = ["LogArg", "input_paths", "parse_log_arg", "prepare_logs", "read_log", "read_trimmed"]

#: Latest trim time [s from a log's first record]: a year of logging.
MAX_TRIM_S = 3.2e7

_TRIM = re.compile(r"^(?P<path>.+?):(?P<t0>[^:]*):(?P<t1>[^:]*)$")


@dataclass
class LogArg:
    """A log file and the part of it to use: ``t0`` .. ``t1`` [s from its first record] (None:
    from the start / to the end)."""

    path: Path
    t0: float | None = None
    t1: float | None = None


def _number(text: str, arg: str, what: str) -> float | None:
    if not text.strip():
        return None
    try:
        v = float(text)
    except ValueError:
        raise UsvidError(f"log argument {arg!r}: {what} {text!r} is not a number of seconds "
                         "(expected LOG:T0:T1)") from None
    if not math.isfinite(v):
        raise UsvidError(f"log argument {arg!r}: {what} must be finite")
    return v


def parse_log_arg(arg: str | Path, t_start: float | None = None,
                  t_end: float | None = None) -> LogArg:
    """``LOG`` or ``LOG:T0:T1`` (either time may be empty) -> :class:`LogArg`; an existing file
    whose name contains colons is taken as it is. ``t_start``/``t_end`` [s] (``--t-start``,
    ``--t-end``) apply when the argument gives no time of its own."""
    text = str(arg)
    m = _TRIM.match(text)
    if m is None or Path(text).exists():
        out = LogArg(Path(text))
    else:
        out = LogArg(Path(m["path"]), _number(m["t0"], text, "T0"), _number(m["t1"], text, "T1"))
    for opt, v in (("--t-start", t_start), ("--t-end", t_end)):
        if v is not None and not (math.isfinite(v) and 0 <= v <= MAX_TRIM_S):
            raise UsvidError(f"{opt} must be in [0, {MAX_TRIM_S:g}] s from the log's first "
                             f"record (got {v!r})")
    if out.t0 is None:
        out.t0 = t_start
    if out.t1 is None:
        out.t1 = t_end
    if out.t0 is not None and out.t1 is not None and out.t1 <= out.t0:
        raise UsvidError(f"log argument {text!r}: the end {out.t1:g} s must be after the start "
                         f"{out.t0:g} s (LOG:T0:T1, --t-start/--t-end)")
    return out


def read_log(path: str | Path, fmt: str) -> Trial:
    """Read ``path`` with the trial format spec ``fmt`` (a YAML path, a shipped spec name or
    ``auto``); a log without three valid records is a :class:`LogReadError` naming the reasons
    its records were rejected. ``--format auto``'s choice is in ``meta["format_detected"]``."""
    trial = read_trial(path, fmt)
    if len(trial) < 3:
        rej = ", ".join(f"{k}: {v}" for k, v in trial.rejected.items()) or "none"
        raise LogReadError(
            f"{path}: only {len(trial)} valid record(s), nothing to work on (rejected: {rej})")
    return trial


def input_paths(args: Sequence[str | Path], t_start: float | None = None,
                t_end: float | None = None) -> list[Path]:
    """The files of log arguments (``LOG`` or ``LOG:T0:T1``, :func:`parse_log_arg`): what the
    command reads, for the check of its outputs against its inputs
    (:func:`usvid.files.check_outputs`). Refuses a bad trim or ``--t-start``/``--t-end``."""
    return [parse_log_arg(a, t_start, t_end).path for a in args]


def read_trimmed(arg: str | Path, fmt: str, t_start: float | None = None,
                 t_end: float | None = None) -> Trial:
    """Read a log argument (:func:`parse_log_arg`) and keep its part ``T0 <= t <= T1``; the
    trial keeps its file as ``sources[0]``."""
    la = parse_log_arg(arg, t_start, t_end)
    trial = read_log(la.path, fmt)
    if la.t0 is None and la.t1 is None:
        return trial
    t = trial.t
    lo = float(t[0]) if la.t0 is None else float(t[0]) + la.t0
    hi = float(t[-1]) if la.t1 is None else float(t[0]) + la.t1
    part = trial.slice_time(lo, hi)
    if len(part) < 3:
        raise UsvidError(f"{la.path}: the part {la.t0 or 0:g} .. "
                         f"{'end' if la.t1 is None else f'{la.t1:g}'} s holds {len(part)} "
                         f"record(s) (the log spans {t[-1] - t[0]:.1f} s); check LOG:T0:T1 / "
                         "--t-start / --t-end")
    return part


def prepare_logs(args: Sequence[str | Path], fmt: str, t_start: float | None = None,
                 t_end: float | None = None) -> list[PreparedTrial]:
    """Read, trim and prepare each log argument once (:func:`read_trimmed`,
    :func:`usvid.prep.prepare` without the accelerations): the trials every later stage of a
    command uses."""
    return [prepare(read_trimmed(a, fmt, t_start, t_end), derivatives=False) for a in args]
