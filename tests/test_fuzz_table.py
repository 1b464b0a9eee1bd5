"""Fuzzing (``fuzz`` marker): the table reader (CSV, whitespace, semicolon tables; header or
numbered columns; unit conversions; other encodings) on byte- and line-level mutations of valid
tables only returns a Trial honouring the contract or raises a UsvidError, and writes nothing.
See tests/fuzzing.py."""

from __future__ import annotations

import random

import pytest

from fuzzing import check_trial, fuzz, halves, mutate, put, safe
from test_io_fuzz import TABLE_CSV, TABLE_SPECS, TABLE_WS
from usvid.io import read_table
from usvid.io.spec import parse_spec

pytestmark = pytest.mark.fuzz
TABLE_SEMI = "# a comment\nzeit;kurs;fahrt\n0,0;10;5\n0,5;11;5,1\n1,0;12;5,2\n".encode("latin-1")
CASES = [
    (TABLE_WS, parse_spec(TABLE_SPECS[0])),
    (TABLE_CSV, parse_spec(TABLE_SPECS[1])),
    (TABLE_SEMI, parse_spec({
        "reader": "table", "delimiter": ";", "header": True, "comment": "#",
        "encoding": "latin-1", "columns": {"t": {"col": "zeit", "unit": "s"},
                                           "psi": {"col": "kurs", "unit": "deg"},
                                           "sog": {"col": "fahrt", "unit": "kn"}}})),
]


def fuzz_table(tmp_path, n: int, salt: str) -> None:
    """``n`` examples of the table fuzzing (its two test files: different salts)."""
    p = tmp_path / "log.txt"

    def check(rng: random.Random) -> None:
        base, spec = rng.choice(CASES)
        put(p, mutate(base, rng))
        check_trial(safe(read_table, p, spec))

    fuzz(check, n, salt)
    assert [q.name for q in tmp_path.iterdir()] == ["log.txt"]


def test_table_reader(tmp_path):
    fuzz_table(tmp_path, halves()[0], "table")
