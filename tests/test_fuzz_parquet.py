"""Fuzzing (``fuzz`` marker): the Parquet reader on tables with hostile columns (every Arrow
type the writer accepts, non-finite and huge values, nulls, strings, duplicated or reversed
time) and on byte mutations of a valid file, with the usvid-table spec and with a unit spec,
only returns a Trial honouring the contract or raises a UsvidError. See tests/fuzzing.py."""

from __future__ import annotations

import io
import random

import numpy as np
import pandas as pd
import pytest

from fuzzing import binary_mutate, check_trial, fuzz, halves, put, safe
from usvid.io import read_trial
from usvid.io.spec import parse_spec

pq = pytest.importorskip("pyarrow.parquet")
pa = pytest.importorskip("pyarrow")
pytestmark = pytest.mark.fuzz
SPEC = parse_spec({"reader": "parquet", "columns": {"t": {"col": "t", "unit": "s"},
                                                    "psi": {"col": "psi", "unit": "deg"},
                                                    "n": {"col": 2, "unit": "rpm"}}})
NAMES = ["t", "psi", "r", "n", "delta", "x", "", "t"]


def _column(rng: random.Random, n: int):
    k = rng.randint(0, 7)
    if k == 0:
        return pa.array([rng.choice([0.0, -1.0, 1e308, -1e308, float("nan"), float("inf"),
                                     -float("inf"), 5e-324, None]) for _ in range(n)],
                        type=pa.float64())
    if k == 1:
        return pa.array([rng.choice([0, -1, 2**63 - 1, -(2**63), None]) for _ in range(n)],
                        type=pa.int64())
    if k == 2:
        return pa.array([rng.choice(["", "1.5", "nan", "x", "1e999", None]) for _ in range(n)])
    if k == 3:
        return pa.array([rng.choice([True, False, None]) for _ in range(n)])
    if k == 4:
        return pa.array(np.cumsum([rng.choice([0.1, 0.0, -0.1, 1e9]) for _ in range(n)]))
    if k == 5:
        return pa.array([rng.randrange(2**62) for _ in range(n)], type=pa.timestamp("ns"))
    return pa.array([rng.uniform(-10, 10) for _ in range(n)], type=rng.choice(
        [pa.float32(), pa.float64(), pa.float16()]) if k == 6 else pa.float64())


def _table(rng: random.Random) -> bytes:
    n = rng.randint(0, 6)
    names = ["t"] + [rng.choice(NAMES) for _ in range(rng.randint(0, 4))]
    table = pa.table([_column(rng, n) for _ in names], names=names)
    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


def _valid() -> bytes:
    buf = io.BytesIO()
    t = np.arange(5) * 0.1
    pd.DataFrame({"t": t, "psi": 10 * t, "n": 0 * t + 600.0}).to_parquet(buf)
    return buf.getvalue()


VALID = _valid()


def fuzz_parquet(tmp_path, n: int, salt: str) -> None:
    """``n`` examples of the parquet fuzzing (its two test files: different salts)."""
    p = tmp_path / "log.parquet"

    def check(rng: random.Random) -> None:
        put(p, _table(rng) if rng.random() < 0.5 else binary_mutate(VALID, rng))
        check_trial(safe(read_trial, p, rng.choice([None, SPEC])))

    fuzz(check, n, salt)
    assert [q.name for q in tmp_path.iterdir()] == ["log.parquet"]


def test_parquet_reader(tmp_path):
    fuzz_parquet(tmp_path, halves()[0], "parquet")
