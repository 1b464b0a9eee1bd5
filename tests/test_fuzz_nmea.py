"""Fuzzing (``fuzz`` marker): the NMEA 0183 reader (default engine) on byte- and line-level
mutations of a valid log, with and without time prefixes, only returns a Trial honouring the
contract or raises a UsvidError, and writes nothing. See tests/fuzzing.py."""

from __future__ import annotations

import random

import pytest

from fuzzing import check_trial, fuzz, halves, mutate, put, safe
from test_io_fuzz import NMEA, NMEA_NOPREFIX
from usvid.io import read_nmea0183

pytestmark = pytest.mark.fuzz


def fuzz_nmea(tmp_path, n: int, salt: str) -> None:
    """``n`` examples of the nmea fuzzing (its two test files: different salts)."""
    p = tmp_path / "log.nmea"

    def check(rng: random.Random) -> None:
        put(p, mutate(rng.choice([NMEA, NMEA_NOPREFIX]), rng))
        check_trial(safe(read_nmea0183, p))

    fuzz(check, n, salt)
    assert [q.name for q in tmp_path.iterdir()] == ["log.nmea"]  # nothing written beside it


def test_nmea0183_reader(tmp_path):
    fuzz_nmea(tmp_path, halves()[0], "nmea0183")
