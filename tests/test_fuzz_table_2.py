"""Fuzzing (``fuzz`` marker): the second half of the table reader's examples (other salt), in a
file of its own so that ``--dist loadfile`` can run the halves side by side. See
tests/test_fuzz_table.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import halves
from test_fuzz_table import fuzz_table

pytestmark = pytest.mark.fuzz


def test_table_reader_second_half(tmp_path):
    fuzz_table(tmp_path, halves()[1], "table:2")
