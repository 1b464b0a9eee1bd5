"""Helpers of the binary test-log writers (ULog, DataFlash): fixed-size records of several types
interleaved in time order without a Python loop per record."""

from __future__ import annotations

import numpy as np


def records(dtype: np.dtype, columns: dict[str, np.ndarray], n: int) -> np.ndarray:
    """``n`` packed records of ``dtype`` (little-endian, no padding) filled from ``columns``;
    fields not in ``columns`` are zero. Returns the records as an (n, itemsize) uint8 array."""
    rec = np.zeros(n, dtype=dtype)
    for k, v in columns.items():
        rec[k] = v
    return rec.view(np.uint8).reshape(n, dtype.itemsize)


def interleave(parts: list[tuple[np.ndarray, np.ndarray]]) -> bytes:
    """Concatenate records of several types in time order (stable: earlier parts first at equal
    times). ``parts``: (times (N,), records (N, L) uint8) per type, L may differ between types."""
    parts = [(np.asarray(t), r) for t, r in parts if len(t)]
    if not parts:
        return b""
    t = np.concatenate([p[0] for p in parts])
    lens = np.concatenate([np.full(len(p[0]), p[1].shape[1], dtype=np.int64) for p in parts])
    order = np.argsort(t, kind="stable")
    start = np.empty(len(t), dtype=np.int64)
    ends = np.cumsum(lens[order])
    start[order] = ends - lens[order]
    out = np.empty(int(ends[-1]), dtype=np.uint8)
    k = 0
    for tp, rows in parts:
        s = start[k:k + len(tp)]
        out[s[:, None] + np.arange(rows.shape[1])] = rows
        k += len(tp)
    return out.tobytes()
