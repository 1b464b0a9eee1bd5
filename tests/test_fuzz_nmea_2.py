"""Fuzzing (``fuzz`` marker): the second half of the nmea reader's examples (other salt), in a
file of its own so that ``--dist loadfile`` can run the halves side by side. See
tests/test_fuzz_nmea.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import halves
from test_fuzz_nmea import fuzz_nmea

pytestmark = pytest.mark.fuzz


def test_nmea0183_reader_second_half(tmp_path):
    fuzz_nmea(tmp_path, halves()[1], "nmea0183:2")
