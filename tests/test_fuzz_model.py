"""Fuzzing (``fuzz`` marker): the model-file loader on mutated model files (fields replaced by
hostile values or removed; byte-mutated JSON text) only returns a model or raises a UsvidError.
See tests/fuzzing.py."""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from fuzzing import N_EXAMPLES, fuzz, mutate, mutated_model, safe
from usvid.files import load_json_text
from usvid.io.modelfile import model_from_dict

pytestmark = pytest.mark.fuzz
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
MODELS = [json.loads((EXAMPLES / n).read_text())
          for n in ("lanxin.json", "lanxin_norrbin.json", "lanxin_threedof.json",
                    "pod_usv.json")]


def _check(rng: random.Random) -> None:
    d = mutated_model(rng.choice(MODELS), rng)
    if rng.random() < 0.2:  # through the bounded JSON loader, as `usvid ... MODEL` reads it
        text = mutate(json.dumps(d, allow_nan=True).encode(), rng, 2).decode("utf-8", "replace")
        d = safe(load_json_text, text, "m.json")
    safe(model_from_dict, d, "m.json")


def test_model_file_loader():
    fuzz(_check, N_EXAMPLES, "model")
