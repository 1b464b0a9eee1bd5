"""Several devices on one bus: channels are built per source, one source is chosen per channel,
the others are reported, and sources are never interleaved.

A *source* is what the log says sent a record: the NMEA 2000 source address (0-253), the NMEA
0183 talker (``GP``, ``HE``, ``II``...), the MAVLink system/component (``1/1``). Two devices
that give the same quantity (two compasses, a GNSS receiver and a chart plotter repeating its
position) alternate record by record in one channel when read naively: a heading that jumps
between two values 115 deg apart, and a yaw rate that "does not follow" it. Here every decoded
channel keeps the records of one source:

- the source named in the format spec (``columns: {psi: {col: psi, source: 128}}``; for the
  ``tlog`` reader ``source: "1/1"``), else
- the source with the most samples of the channel (ties: the one heard first).

Every channel that more than one source gives gets a finding (``several_sources``) listing the
sources, their sample counts, how far each lies from the chosen one (median difference where
their samples are within 2 s of each other) and the spec line that chooses another; a warning
when they disagree by more than the channel's tolerance, else info. A spec column may also
take another source's samples under a name of its own (``psi_b: {col: psi, source: 23}``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvid.errors import LogReadError
from usvid.io.spec import ColumnSpec, FormatSpec
from usvid.trial import CHANNEL_UNITS, Finding

#: Channels that are angles [rad] (differences wrapped, shown in degrees).
ANGLES = frozenset({"psi", "psi_mag", "cog", "wind_angle", "wind_dir_true", "wind_angle_true",
                    "phi", "theta", "delta", "delta_cmd", "delta_port", "_yaw",
                    "_wind_dir_mag", "_wind_angle_water", "_variation"})
#: Rates [rad/s] (shown in deg/s).
RATES = frozenset({"r", "p"})
#: Disagreement above which two sources of a channel get a warning (SI units; angles [rad]):
#: beyond the noise of one instrument.
TOLERANCE = {"angle": math.radians(2.0), "rate": math.radians(0.5), "lat": 10.0,
             "lon": 10.0, "default_rel": 0.05, "default_abs": 0.1}
#: Samples of two sources are compared when they lie within this time [s] of each other.
PAIR_WINDOW_S = 2.0
#: Metres per degree of latitude (mean Earth radius 6371.0 km).
M_PER_DEG = 6_371_000.0 * math.pi / 180.0


@dataclass(frozen=True)
class Sources:
    """The source of each record: ``codes`` (N,) int (-1: unknown), and per code its label for
    messages (``"0x17"``, ``"talker HE"``, ``"1/1"``) and its value in a spec (``23``, ``"HE"``,
    ``"1/1"``)."""

    codes: np.ndarray
    labels: dict[int, str]
    spec_values: dict[int, int | str]
    kind: str  # "address", "talker", "system/component"
    plural: str  # "addresses", "talkers", "systems/components"

    def code_of(self, value: int | str) -> int | None:
        """The code of a spec's ``source:`` value (None: not in the log)."""
        for c, v in self.spec_values.items():
            if v == value or (isinstance(value, str) and str(v).upper() == value.upper()):
                return c
        if isinstance(value, str) and "/" not in value:  # a MAVLink system id alone
            for c, v in self.spec_values.items():
                if str(v).split("/")[0] == value:
                    return c
        return None


def _display(name: str, d: float) -> str:
    if name in ANGLES:
        return f"{math.degrees(d):.3g} deg"
    if name in RATES:
        return f"{math.degrees(d):.3g} deg/s"
    if name in ("lat", "lon"):
        return f"{d:.3g} m"
    unit = CHANNEL_UNITS.get(name, "")
    return f"{d:.3g} {unit}" if unit and unit != "1" else f"{d:.3g}"


def _median_difference(name: str, t: np.ndarray, a: np.ndarray, ma: np.ndarray,
                       mb: np.ndarray) -> float | None:
    """Median |difference| [SI; lat/lon in m] between the samples of source b (mask ``mb``)
    and source a (``ma``) of channel values ``a`` at times ``t``, a interpolated at b's times
    where a has samples within :data:`PAIR_WINDOW_S`; None when no pair."""
    ta, va = t[ma], a[ma]
    tb, vb = t[mb], a[mb]
    ok = np.isfinite(ta)
    ta, va = ta[ok], va[ok]
    ok = np.isfinite(tb)
    tb, vb = tb[ok], vb[ok]
    if len(ta) < 1 or len(tb) < 1:
        return None
    o = np.argsort(ta, kind="stable")
    ta, va = ta[o], va[o]
    if name in ANGLES:
        va = np.unwrap(va)
    j = np.searchsorted(ta, tb)
    near = np.minimum(np.abs(ta[np.clip(j - 1, 0, len(ta) - 1)] - tb),
                      np.abs(ta[np.clip(j, 0, len(ta) - 1)] - tb))
    sel = near <= PAIR_WINDOW_S
    if not sel.any():
        return None
    ref = np.interp(tb[sel], ta, va) if len(ta) > 1 else np.full(int(sel.sum()), va[0])
    d = vb[sel] - ref
    if name in ANGLES:
        d = np.remainder(d + math.pi, 2 * math.pi) - math.pi
    d = np.abs(d)
    if name == "lat":
        d = d * M_PER_DEG
    elif name == "lon":
        d = d * M_PER_DEG  # (an upper bound: times cos(latitude))
    return float(np.median(d))


def _disagree(name: str, diff: float, scale: float) -> bool:
    if name in ANGLES:
        return diff > TOLERANCE["angle"]
    if name in RATES:
        return diff > TOLERANCE["rate"]
    if name in ("lat", "lon"):
        return diff > TOLERANCE[name]
    return diff > TOLERANCE["default_rel"] * scale + TOLERANCE["default_abs"] * 0.1


def spec_source_line(reader: str, name: str, value: int | str) -> str:
    """The format-spec line that takes channel ``name`` from source ``value``."""
    v = f'"{value}"' if isinstance(value, str) else str(value)
    return f"columns: {{{name}: {{col: {name}, source: {v}}}}}" if reader != "tlog" else \
        f"columns: {{{name}: {{message: ..., field: ..., source: {v}}}}}"


def select_sources(path: Path, t: np.ndarray, chans: dict[str, np.ndarray], src: Sources,
                   spec: FormatSpec | None, *, reader: str,
                   public_name: Callable[[str], str] = lambda k: k,
                   ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], list[Finding], dict]:
    """Keep one source per channel (see the module docstring).

    ``t`` [s] and ``chans`` are per record (the same length as ``src.codes``; NaN where a
    record does not carry a channel). Returns the channels with one source each, the columns
    of the spec that name a source (column name -> its samples, for
    :func:`usvid.io._assemble.apply_renames`), the findings and ``meta["sources"]``
    (channel -> {"chosen": label, "samples": {label: count}}). Raises :class:`LogReadError`
    when the spec names a source that does not give the channel.
    """
    codes = src.codes
    named: dict[str, int] = {}
    sourced: dict[str, np.ndarray] = {}
    cols: list[ColumnSpec] = [c for c in (spec.columns.values() if spec else [])
                              if c.source is not None]
    for c in cols:
        dec = str(c.col)
        if dec not in chans:
            if c.optional:
                continue
            raise LogReadError(
                f"{spec.source}: columns.{c.name}.col: the log has no decoded channel '{dec}' "
                f"(decoded: {', '.join(sorted(k for k in chans if not k.startswith('_')))})")
        code = src.code_of(c.source)
        have = np.isfinite(chans[dec])
        givers = sorted({int(x) for x in np.unique(codes[have])})
        if code is None or code not in givers:
            listed = ", ".join(f"{src.spec_values[g]!r}" for g in givers if g in src.spec_values)
            raise LogReadError(
                f"{path}: {spec.source}: columns.{c.name}.source: no {src.kind} {c.source!r} "
                f"gives '{dec}' in this log (sources of '{dec}': {listed or 'none'})")
        named.setdefault(dec, code)
        sourced[c.name] = np.where(codes == code, chans[dec], np.nan)
    out: dict[str, np.ndarray] = {}
    findings: list[Finding] = []
    meta: dict = {}
    for k, v in chans.items():
        have = np.isfinite(v)
        if not have.any():
            out[k] = v
            continue
        present, first, counts = np.unique(codes[have], return_index=True, return_counts=True)
        if len(present) <= 1:
            out[k] = v
            continue
        if k in named:
            chosen, why = named[k], "named in the format spec"
        else:
            # the most samples; ties: the source heard first
            order = sorted(range(len(present)), key=lambda i: (-counts[i], first[i]))
            chosen, why = int(present[order[0]]), "the most samples"
        mine = codes == chosen
        out[k] = np.where(mine, v, np.nan)
        if k.startswith("_"):
            continue  # an internal channel: reported through the channel it becomes
        name = public_name(k)
        n_of = {int(p): int(n) for p, n in zip(present, counts, strict=True)}
        scale = float(np.nanmedian(np.abs(v[mine & have]))) if (mine & have).any() else 0.0
        parts = []
        warn = False
        diffs: dict[str, float | None] = {}
        for p in sorted(n_of, key=lambda x: -n_of[x]):
            if p == chosen:
                continue
            d = _median_difference(k, t, v, mine & have, (codes == p) & have)
            diffs[src.labels.get(p, str(p))] = d
            far = "" if d is None else f", {_display(k, d)} from the chosen (median)"
            if d is not None and _disagree(k, d, scale):
                warn = True
            parts.append(f"{src.labels.get(p, str(p))} ({n_of[p]} samples{far})")
        other = next(p for p in sorted(n_of, key=lambda x: -n_of[x]) if p != chosen)
        line = spec_source_line(reader, name, src.spec_values.get(other, other))
        findings.append(Finding(
            "warning" if warn else "info", "several_sources",
            f"{path.name}: '{name}' comes from {len(present)} {src.plural} "
            f"{'(they disagree) ' if warn else ''}- used: {src.labels.get(chosen, chosen)} "
            f"({n_of[chosen]} samples, {why}); not used: {'; '.join(parts)}. To use another, "
            f"name it in the format spec: {line}",
            count=sum(n for p, n in n_of.items() if p != chosen), channel=name,
            data={"chosen": src.labels.get(chosen, str(chosen)),
                  "samples": {src.labels.get(p, str(p)): n for p, n in n_of.items()},
                  "median_difference": diffs}))
        meta[name] = {"chosen": src.labels.get(chosen, str(chosen)),
                      "samples": {src.labels.get(p, str(p)): n for p, n in n_of.items()}}
    return out, sourced, findings, {"sources": meta} if meta else {}
