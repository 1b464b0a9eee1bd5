"""Fuzzing (``fuzz`` marker): the second half of the excel reader's examples (other salt), in a
file of its own so that ``--dist loadfile`` can run the halves side by side. See
tests/test_fuzz_excel.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import halves
from test_fuzz_excel import fuzz_excel

pytestmark = pytest.mark.fuzz


def test_excel_reader_second_half(tmp_path):
    fuzz_excel(tmp_path, halves()[1], "excel:2")
