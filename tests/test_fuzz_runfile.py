"""Fuzzing (``fuzz`` marker): the run-file check of ``usvid report`` on run files with hostile
values in every field (after the bounded JSON loader) only passes or raises a UsvidError. See
tests/fuzzing.py."""

from __future__ import annotations

import json
import random

import pytest

from fuzzing import N_EXAMPLES, fuzz, safe, value
from usvid.files import load_json_text
from usvid.report.run import check_run

pytestmark = pytest.mark.fuzz
RUN_KEYS = ["title", "steps", "models", "validation", "audit", "campaign", "course_keeping",
            "turning_diameter", "timing", "settings", "vessel", "norrbin_fit", "acceptance",
            "summary_text", "truth_definition", "usvid_run"]


def _check(rng: random.Random) -> None:
    run = {"usvid_run": 1, **{k: value(rng) for k in rng.sample(RUN_KEYS, rng.randint(0, 6))}}
    d = safe(load_json_text, json.dumps(run, allow_nan=True), "run.json")
    if isinstance(d, dict):
        safe(check_run, d, "run.json")


def test_run_file_check():
    fuzz(_check, N_EXAMPLES, "run")
