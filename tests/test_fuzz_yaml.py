"""Fuzzing (``fuzz`` marker): the bounded YAML loader (format specs) on hostile documents
(alias bombs, deep nesting, Python tags, bad directives, mutated flow text) only returns or
raises a UsvidError. See tests/fuzzing.py."""

from __future__ import annotations

import pytest

from fuzzing import N_EXAMPLES, fuzz, safe, yaml_text
from usvid.files import load_yaml_text

pytestmark = pytest.mark.fuzz


def test_bounded_yaml_loader():
    fuzz(lambda rng: safe(load_yaml_text, yaml_text(rng), "f.yaml"), N_EXAMPLES, "yaml")
