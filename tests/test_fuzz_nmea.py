"""Fuzzing (``fuzz`` marker): the NMEA 0183 reader (default engine) on byte- and line-level
mutations of a valid log, with and without time prefixes, only returns a Trial honouring the
contract or raises a UsvidError, and writes nothing. See tests/fuzzing.py."""

from __future__ import annotations

import random

import pytest

from fuzzing import N_EXAMPLES, check_trial, fuzz, mutate, put, safe
from test_io_fuzz import NMEA, NMEA_NOPREFIX
from usvid.io import read_nmea0183

pytestmark = pytest.mark.fuzz


def test_nmea0183_reader(tmp_path):
    p = tmp_path / "log.nmea"

    def check(rng: random.Random) -> None:
        put(p, mutate(rng.choice([NMEA, NMEA_NOPREFIX]), rng))
        check_trial(safe(read_nmea0183, p))

    fuzz(check, N_EXAMPLES, "nmea0183")
    assert [q.name for q in tmp_path.iterdir()] == ["log.nmea"]  # nothing written beside it
