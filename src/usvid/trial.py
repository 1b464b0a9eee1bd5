"""The :class:`Trial`: one sea-trial record in SI units, the hand-over between all stages.

Contract (``../shared/ARCHITECTURE.md``): a table whose column ``t`` [s] is the time and whose other
columns are channels in SI units and radians:

``x``, ``y`` [m, north, east], ``psi`` [rad, NED, clockwise positive], ``u``, ``v`` [m/s, body],
``r`` [rad/s], ``U`` [m/s], ``delta`` [rad, positive makes r positive], ``delta_cmd`` [rad],
``n`` [rps], ``n_port``, ``n_stbd`` [rps] or thruster commands, ``tau_u`` [N], ``tau_r`` [N m],
plus ``lat``, ``lon`` [deg, only as read from a receiver, before conversion to NED].

Environment and attitude: apparent wind ``wind_speed`` [m/s] and ``wind_angle`` [rad, from the
bow, clockwise, the direction the wind comes from, in (-pi, pi]]; true wind ``wind_speed_true``
[m/s] and ``wind_dir_true`` [rad, from north, clockwise, the direction it comes from, in
[0, 2 pi)]; roll ``phi`` [rad, positive heel to starboard], roll rate ``p`` [rad/s], pitch
``theta`` [rad, bow up positive]. A current is a speed and the direction it flows towards.

A reader of a multi-rate source (NMEA) returns the union of all time stamps with NaN where a channel
has no sample at that instant; :func:`usvid.prep.resample` puts such a trial on one uniform grid.
Absent channels are simply absent columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from usvid.errors import UsvidError

if TYPE_CHECKING:  # pandas is imported where a table is built: `import usvid.sim` spares it
    import pandas as pd

#: Channels of the Trial contract (and of simulation results) and their SI units; extensions
#: may add more columns. ``dist`` is a simulated rudder-equivalent disturbance.
CHANNEL_UNITS: dict[str, str] = {
    "t": "s",
    "x": "m",
    "y": "m",
    "psi": "rad",
    "u": "m/s",
    "v": "m/s",
    "r": "rad/s",
    "U": "m/s",
    "delta": "rad",
    "delta_cmd": "rad",
    "n": "rps",
    "n_port": "rps",
    "n_stbd": "rps",
    "tau_u": "N",
    "tau_r": "N*m",
    "lat": "deg",
    "lon": "deg",
    "cog": "rad",
    "sog": "m/s",
    "dist": "rad",
    # environment (usvid.models.environment.wind): apparent wind, from the bow, clockwise, the
    # direction it comes from (NMEA 0183 MWV "R"); true wind, from north, clockwise, coming from
    # (NMEA 0183 MWD)
    "wind_speed": "m/s",
    "wind_angle": "rad",
    "wind_speed_true": "m/s",
    "wind_dir_true": "rad",
    # attitude: roll (positive = heel to starboard, starboard side down), roll rate, pitch (bow up)
    "phi": "rad",
    "p": "rad/s",
    "theta": "rad",
}


#: The numeric particulars of :class:`Vessel` (every field but ``extra``), in field order.
VESSEL_FIELDS = (
    "length",
    "speed",
    "beam",
    "draft",
    "mass",
    "displacement",
    "block_coefficient",
    "frontal_area",
    "lateral_area",
)


@dataclass
class Vessel:
    """Vessel particulars carried with a trial or a model (SI units).

    ``length`` [m] and ``speed`` [m/s, nominal approach speed] are the ones most code needs; the
    others are optional and ``None`` when unknown.
    """

    length: float | None = None
    speed: float | None = None
    beam: float | None = None
    draft: float | None = None
    mass: float | None = None
    displacement: float | None = None
    block_coefficient: float | None = None
    #: windage: transverse (frontal) and lateral projected areas above the waterline [m^2]
    frontal_area: float | None = None
    lateral_area: float | None = None
    extra: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        out = {k: getattr(self, k) for k in VESSEL_FIELDS if getattr(self, k) is not None}
        out.update(self.extra)
        return out


@dataclass
class Finding:
    """One observation of the channel audit (or of a reader) about the data.

    ``severity`` is ``"info"``, ``"warning"`` or ``"error"``; ``code`` a stable machine key
    (``"yaw_rate_column"``, ``"stale_gnss_fix"``, ...); ``message`` the plain-words sentence;
    ``count`` how many samples/records it concerns; ``t_start``/``t_end`` [s] its time span.
    """

    severity: str
    code: str
    message: str
    count: int = 0
    t_start: float | None = None
    t_end: float | None = None
    channel: str | None = None
    data: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "severity": self.severity,
            "code": self.code,
            "message": self.message,
            "count": int(self.count),
            "t_start": self.t_start,
            "t_end": self.t_end,
            "channel": self.channel,
            **({"data": self.data} if self.data else {}),
        }


@dataclass
class Trial:
    """One trial: a time-indexed table of SI channels plus where it came from.

    Parameters
    ----------
    data : pandas.DataFrame
        Column ``t`` [s] strictly increasing, other columns SI channels (see module docstring).
    vessel : Vessel
        Particulars (length [m], nominal speed [m/s], ...).
    sources : list of str
        Files the trial was read from.
    rejected : dict
        Records rejected by the reader, ``reason -> count`` (never silently dropped).
    findings : list of Finding
        Audit and reader findings.
    name : str
        A short label (file stem or manoeuvre name).
    meta : dict
        Anything else a reader or a simulator wants to carry (e.g. the true parameters of a
        virtual trial under ``meta["truth"]``).
    """

    data: pd.DataFrame
    vessel: Vessel = field(default_factory=Vessel)
    sources: list[str] = field(default_factory=list)
    rejected: dict[str, int] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)
    name: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if "t" not in self.data.columns:
            raise UsvidError(f"trial {self.name or '?'}: no time column 't'")

    # --- access -------------------------------------------------------------------------------
    @property
    def t(self) -> np.ndarray:
        """Time [s] as a float array."""
        return self.data["t"].to_numpy(dtype=float)

    @property
    def channels(self) -> list[str]:
        """Names of the channels present (all columns except ``t``)."""
        return [c for c in self.data.columns if c != "t"]

    def has(self, name: str) -> bool:
        """True when channel ``name`` is present and has at least one finite sample."""
        return name in self.data.columns and bool(np.isfinite(self.data[name].to_numpy()).any())

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.data.columns:
            raise UsvidError(
                f"trial {self.name or '?'}: channel '{name}' is absent "
                f"(present: {', '.join(self.channels) or 'none'})"
            )
        return self.data[name].to_numpy(dtype=float)

    def __len__(self) -> int:
        return len(self.data)

    @property
    def duration(self) -> float:
        """Duration [s]."""
        t = self.t
        return float(t[-1] - t[0]) if len(t) > 1 else 0.0

    @property
    def sample_rate(self) -> float | None:
        """Sample rate [Hz] when the grid is uniform (within 1 %), else ``None``."""
        t = self.t
        if len(t) < 3:
            return None
        dt = np.diff(t)
        med = float(np.median(dt))
        if med <= 0 or np.max(np.abs(dt - med)) > 0.01 * med:
            return None
        return 1.0 / med

    @property
    def is_uniform(self) -> bool:
        return self.sample_rate is not None

    def with_data(self, data: pd.DataFrame, **changes: Any) -> Trial:
        """A copy of this trial with another table (and other fields changed as given)."""
        return replace(self, data=data, **changes)

    def slice_time(self, t0: float, t1: float, name: str | None = None) -> Trial:
        """The part of the trial with ``t0 <= t <= t1`` [s]."""
        t = self.t
        sel = (t >= t0) & (t <= t1)
        return replace(
            self, data=self.data.loc[sel].reset_index(drop=True), name=name or self.name
        )

    def to_pandas(self) -> pd.DataFrame:
        """The channel table (a copy)."""
        return self.data.copy()

    def summary(self) -> dict[str, Any]:
        """A JSON-able summary: name, samples, duration, rate, channels, rejected records."""
        return {
            "name": self.name,
            "samples": len(self),
            "duration_s": self.duration,
            "sample_rate_hz": self.sample_rate,
            "channels": self.channels,
            "sources": list(self.sources),
            "rejected": dict(self.rejected),
            "vessel": self.vessel.to_dict(),
        }


def merge_shared_stamps(t: np.ndarray, chans: dict[str, np.ndarray],
                        streams: np.ndarray | None = None,
                        ) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, int]]:
    """Records that share a time stamp merged into one row: the one rule of usvid for equal
    stamps (readers and :func:`usvid.prep.prepare`).

    ``t`` [s] in time order (stably sorted: the records of one stamp in log order), ``chans``
    arrays of the same length. Per channel the last finite value of each stamp (in log order)
    is kept. Returns the distinct stamps, the merged channels and, per channel, the number of
    samples superseded by a later sample of the same stamp *with another value* (an equal
    value repeated loses nothing and is not counted); with ``streams`` (the message stream
    of each record) only a sample superseded by one of its own stream is counted (GGA and RMC
    of one fix rounding a position differently report one instant twice); channels with none
    are left out.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2 or not (t[1:] == t[:-1]).any():
        return t, chans, {}
    uniq, inv = np.unique(t, return_inverse=True)
    merged: dict[str, np.ndarray] = {}
    superseded: dict[str, int] = {}
    for k, v in chans.items():
        out = np.full(len(uniq), np.nan)
        idx = np.flatnonzero(np.isfinite(v))
        if len(idx):
            g = inv[idx]  # non-decreasing: t is sorted
            last = np.r_[g[1:] != g[:-1], True]
            out[g[last]] = v[idx[last]]
            lost = ~last & (v[idx] != out[g])
            if streams is not None and lost.any():
                kept = np.full(len(uniq), np.nan)
                kept[g[last]] = streams[idx[last]]
                lost &= streams[idx] == kept[g]
            if lost.any():
                superseded[k] = int(lost.sum())
        merged[k] = out
    return uniq, merged, superseded



def merge_shared_stamp_rows(data: pd.DataFrame) -> tuple[pd.DataFrame, int]:
    """:func:`merge_shared_stamps` on a table whose column ``t`` [s] is in time order (stably
    sorted); the numeric columns are merged, the table keeps its column order. Returns the
    table and the number of rows merged away."""
    import pandas as pd

    t = data["t"].to_numpy(dtype=float)
    if len(t) < 2 or not (t[1:] == t[:-1]).any():
        return data, 0
    cols = {c: data[c].to_numpy(dtype=float) for c in data.columns
            if c != "t" and pd.api.types.is_numeric_dtype(data[c])}
    tu, merged, _ = merge_shared_stamps(t, cols)
    out = pd.DataFrame({"t": tu, **merged})
    first = np.r_[True, t[1:] != t[:-1]]  # other columns: the first row of each stamp
    for c in data.columns:
        if c not in out.columns:
            out[c] = data[c].to_numpy()[first]
    return out[list(data.columns)], len(t) - len(tu)


