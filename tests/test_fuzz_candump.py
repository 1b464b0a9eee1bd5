"""Fuzzing (``fuzz`` marker): the NMEA 2000 candump reader on byte- and line-level mutations of
a valid log only returns a Trial honouring the contract or raises a UsvidError, and writes
nothing. See tests/fuzzing.py."""

from __future__ import annotations

import random

import pytest

from fuzzing import check_trial, fuzz, halves, mutate, put, safe
from test_io_fuzz import CANDUMP
from usvid.io import read_candump

pytestmark = pytest.mark.fuzz


def fuzz_candump(tmp_path, n: int, salt: str) -> None:
    """``n`` examples of the candump fuzzing (its two test files: different salts)."""
    p = tmp_path / "log.candump"

    def check(rng: random.Random) -> None:
        put(p, mutate(CANDUMP, rng))
        check_trial(safe(read_candump, p))

    fuzz(check, n, salt)
    assert [q.name for q in tmp_path.iterdir()] == ["log.candump"]


def test_candump_reader(tmp_path):
    fuzz_candump(tmp_path, halves()[0], "candump")
