"""Fuzzing (``fuzz`` marker): the bounded JSON loader (model files, run files) on hostile text
(values of every JSON type, huge and non-finite numbers, 3,000-deep nesting, 6,000-digit
integers, byte mutations) only returns or raises a UsvidError. See tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import N_EXAMPLES, fuzz, json_text, safe
from usvid.files import load_json_text

pytestmark = pytest.mark.fuzz


def test_bounded_json_loader():
    fuzz(lambda rng: safe(load_json_text, json_text(rng), "f.json"), N_EXAMPLES, "json")
