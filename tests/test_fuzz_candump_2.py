"""Fuzzing (``fuzz`` marker): the second half of the candump reader's examples (other salt), in a
file of its own so that ``--dist loadfile`` can run the halves side by side. See
tests/test_fuzz_candump.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import halves
from test_fuzz_candump import fuzz_candump

pytestmark = pytest.mark.fuzz


def test_candump_reader_second_half(tmp_path):
    fuzz_candump(tmp_path, halves()[1], "candump:2")
