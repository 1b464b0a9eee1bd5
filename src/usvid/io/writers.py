"""Writers for Trials as tables: CSV and Parquet (SI units, radians, one column per channel).

Both are written atomically. A table written here reads back with ``read_trial(path, None)``
(header names are Trial channel names in SI) or with the spec :func:`table_spec` returns.
"""

from __future__ import annotations

import io
import json
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from usvid.files import write_atomic
from usvid.trial import CHANNEL_UNITS, VESSEL_FIELDS, Trial

#: Start time of a written log when neither the caller nor ``trial.meta["t0_utc"]`` gives one.
DEFAULT_T0_UTC = "2025-01-01T00:00:00+00:00"


def log_start_epoch(trial: Trial, t0_utc: str | datetime | None = None) -> float:
    """Epoch seconds [s] of the trial's t = 0 for the log writers: ``t0_utc`` (ISO string or
    datetime; naive means UTC), else ``trial.meta["t0_utc"]``, else :data:`DEFAULT_T0_UTC`."""
    if t0_utc is None:
        t0_utc = trial.meta.get("t0_utc", DEFAULT_T0_UTC)
    t0 = pd.Timestamp(t0_utc)
    t0 = t0.tz_localize("UTC") if t0.tzinfo is None else t0.tz_convert("UTC")
    return t0.timestamp()


def channel_or_none(trial: Trial, name: str) -> np.ndarray | None:
    """Channel ``name`` of ``trial`` as a float array, ``None`` when the trial lacks it."""
    return trial.data[name].to_numpy(dtype=float) if name in trial.data.columns else None


def _si_unit(name: str) -> str:
    return CHANNEL_UNITS.get(name, "1")


def table_spec(trial: Trial, reader: str = "table") -> dict:
    """A format spec (as a mapping) that reads back a table written by this module."""
    spec: dict = {"reader": reader}
    if reader == "table":
        spec.update({"delimiter": ",", "header": True})
    spec["columns"] = {c: {"col": c, "unit": _si_unit(c)} for c in trial.data.columns}
    v = trial.vessel.to_dict()
    extra = {k: v.pop(k) for k in list(v) if k not in VESSEL_FIELDS}
    if extra:
        v["extra"] = extra
    if v:
        spec["vessel"] = v
    return spec


def write_csv(trial: Trial, path: str | Path, *, spec_path: str | Path | None = None) -> Path:
    """Write the channel table as CSV (comma, header row of channel names, SI units, radians).

    Full float precision (``repr``), NaN as empty fields. With ``spec_path`` also writes the YAML
    format spec that reads it back.
    """
    buf = io.StringIO()
    trial.data.to_csv(buf, index=False, float_format="%.17g", na_rep="")
    out = write_atomic(path, buf.getvalue())
    if spec_path is not None:
        write_atomic(spec_path, yaml.safe_dump(table_spec(trial), sort_keys=False))
    return out


def write_parquet(trial: Trial, path: str | Path) -> Path:
    """Write the channel table as Parquet (SI units, radians; trial summary in the metadata)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(pd.DataFrame(trial.data), preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[b"usvid"] = json.dumps(
        {"name": trial.name, "vessel": trial.vessel.to_dict(), "sources": trial.sources},
        default=str,
    ).encode()
    table = table.replace_schema_metadata(meta)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return write_atomic(path, sink.getvalue().to_pybytes())
