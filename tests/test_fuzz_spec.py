"""Fuzzing (``fuzz`` marker): the format-spec loader on generated specs (every reader, known
and unknown keys, hostile values, bad encodings and units), as mappings and as YAML text, only
returns a FormatSpec or raises a UsvidError. See tests/fuzzing.py."""

from __future__ import annotations

import random

import pytest
import yaml

from fuzzing import N_EXAMPLES, fuzz, mutate, safe, spec_dict
from usvid.files import load_yaml_text
from usvid.io.spec import FormatSpec, parse_spec

pytestmark = pytest.mark.fuzz


def _check(rng: random.Random) -> None:
    d = spec_dict(rng)
    if rng.random() < 0.2:  # through the YAML loader, as `--format SPEC` reads it
        text = mutate(yaml.safe_dump(d, allow_unicode=True).encode(), rng, 2).decode(
            "utf-8", "replace")
        d = safe(load_yaml_text, text, "s.yaml")
    fs = safe(parse_spec, d, "s.yaml")
    assert fs is None or isinstance(fs, FormatSpec)


def test_spec_loader():
    fuzz(_check, N_EXAMPLES, "spec")
