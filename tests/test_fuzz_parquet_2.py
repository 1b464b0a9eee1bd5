"""Fuzzing (``fuzz`` marker): the second half of the parquet reader's examples (other salt), in a
file of its own so that ``--dist loadfile`` can run the halves side by side. See
tests/test_fuzz_parquet.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import halves
from test_fuzz_parquet import fuzz_parquet

pytestmark = pytest.mark.fuzz


def test_parquet_reader_second_half(tmp_path):
    fuzz_parquet(tmp_path, halves()[1], "parquet:2")
