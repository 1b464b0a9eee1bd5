"""Hypothesis fuzzing of every untrusted-input loader: nothing but a UsvidError escapes.

Marked ``fuzz`` (run by ``make test``; ``-m "not fuzz"`` leaves them out); in-process calls
only. Hypothesis draws one 32-bit seed per example and a seeded generator builds BATCH hostile
inputs from it (values of every JSON type, huge and non-finite numbers, deep nesting, alias
bombs, byte mutations of valid logs). Measured on the 2-core development machine under load:
drawing structured data through Hypothesis cost 10-20 ms per example, and even a bare seed
costs about 2.5 ms of engine overhead per example, against 0.05-0.7 ms per input for the
schema loaders; so each Hypothesis example runs a batch of inputs (a failure names the seed,
which regenerates the batch).

Inputs per loader, sized to the suite's time budget:
- 10,000 each (500 examples x 20): the bounded JSON loader (0.2 ms per input), the run-file
  schema check (0.1 ms), the format-spec schema on generated mappings (0.05 ms), the model-file
  schema on mutated model files (0.7 ms);
- 1,000 (100 x 10): the bounded YAML loader (1-3 ms per document, PyYAML is pure Python; 30-50
  ms to refuse an alias bomb after 100,000 expanded nodes);
- 300 each (30 x 10): the text log readers (table, NMEA 0183, NMEA 2000 candump; 5-10 ms per
  input: the Trial and pandas), on top of tests/test_io_fuzz.py's random-byte and mutation
  cases.
"""

from __future__ import annotations

import json
import random
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from usvid.errors import UsvidError
from usvid.files import load_json_text, load_yaml_text
from usvid.io import read_candump, read_nmea0183, read_trial
from usvid.io.modelfile import model_from_dict
from usvid.io.spec import parse_spec
from usvid.report.run import check_run

sys.path.insert(0, str(Path(__file__).parent))
from test_io_fuzz import CANDUMP, NMEA, TABLE_CSV, TABLE_SPECS, TABLE_WS  # noqa: E402

pytestmark = pytest.mark.fuzz
REPO = Path(__file__).resolve().parents[1]
BATCH = 20
MANY, YAML_N, FEW = 10_000 // BATCH, 1_000 // 10, 300 // 10
seeds = st.integers(0, 2**32 - 1)


def _settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


SCALARS = [None, True, False, 0, -1, 1, 2**63, -(2**70), 10**308, 1e308, -1e308, 1e-320,
           float("nan"), float("inf"), -float("inf"), 0.5, "", "x", "nan", "1e308", "kind",
           "\u00e9\u2603", "a" * 300, "\x00", [], {}]


def value(rng: random.Random, depth: int = 0):
    """A random JSON-like value: hostile scalars, lists and mappings nested up to 4 levels."""
    r = rng.random()
    if depth >= 4 or r < 0.55:
        if rng.random() < 0.5:
            return rng.choice(SCALARS)
        return rng.choice([rng.uniform(-1e3, 1e3), rng.randint(-10**6, 10**6),
                           "".join(chr(rng.randint(1, 0x2FF)) for _ in range(rng.randint(0, 8)))])
    if r < 0.8:
        return [value(rng, depth + 1) for _ in range(rng.randint(0, 4))]
    return {rng.choice(["kind", "a", "", "T", "K", "col", "unit", str(rng.random())]):
            value(rng, depth + 1) for _ in range(rng.randint(0, 4))}


def _safe(fn, *args):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn(*args)
    except UsvidError as exc:
        assert len(str(exc)) < 5000
        return None


def json_text(rng: random.Random) -> str:
    k = rng.randint(0, 5)
    if k == 0:
        return "[" * (n := rng.randint(0, 3000)) + "]" * n
    if k == 1:
        return '{"a": ' + "9" * rng.randint(1, 6000) + "}"
    text = json.dumps(value(rng), allow_nan=True)
    if k == 2 and text:  # a byte-level mutation
        i = rng.randrange(len(text))
        text = text[:i] + rng.choice(['"', "[", "}", ",", "\\", "NaN", "\x00", ""]) + text[i + 1:]
    return text


@_settings(MANY)
@given(seeds)
def test_bounded_json_loader(seed):
    rng = random.Random(seed)
    for _ in range(BATCH):
        _safe(load_json_text, json_text(rng), "f.json")


def yaml_text(rng: random.Random) -> str:
    k = rng.randint(0, 11)  # alias bombs (k = 1) cost 30-50 ms each to refuse: 1 in 12
    if k == 0:
        return "a: " + "[" * (n := rng.randint(0, 200)) + "]" * n
    if k == 1:
        levels = rng.randint(1, 9)
        return "a0: &a0 [1,1,1,1,1,1,1,1,1]\n" + "".join(
            f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]\n" for i in range(1, levels))
    if k == 2:
        return rng.choice(["!!python/object/apply:os.system [x]", "&a [*a]", "a: *b",
                           "%YAML 9\n", "a: !!binary x", "\x07", "a:\n\t- b", "? [a]\n: b"])
    text = json.dumps(value(rng), allow_nan=True)
    if k == 3 and text:
        i = rng.randrange(len(text))
        text = text[:i] + rng.choice([":", "&x ", "*x", "- ", "\n  ", "!!", "|", "\x00"]) + text[i:]
    return text


@_settings(YAML_N)
@given(seeds)
def test_bounded_yaml_loader(seed):
    rng = random.Random(seed)
    for _ in range(10):
        _safe(load_yaml_text, yaml_text(rng), "f.yaml")


SPEC_KEYS = ["reader", "delimiter", "skip_rows", "header", "comment", "encoding", "sheet",
             "non_monotonic", "time_source", "n2k_format", "vessel", "description"]
COLUMN_KEYS = ["col", "unit", "sign", "scale", "offset", "optional", "topic", "field",
               "convert", "frame", "pwm", "instance"]
READER_NAMES = ["table", "excel", "parquet", "nmea0183", "nmea2000", "rosbag", "ulog",
                "dataflash", "tlog"]


def spec_dict(rng: random.Random) -> dict:
    d: dict = {"reader": rng.choice(READER_NAMES) if rng.random() < 0.9 else value(rng)}
    for k in rng.sample(SPEC_KEYS, rng.randint(0, 4)):
        d[k] = value(rng)
    if rng.random() < 0.8:
        d["columns"] = {rng.choice(["t", "psi", "r", "delta", "lat", "n", "?"]):
                        ({k: value(rng) for k in rng.sample(COLUMN_KEYS, rng.randint(0, 5))}
                         if rng.random() < 0.8 else value(rng))
                        for _ in range(rng.randint(0, 4))}
    return d


@_settings(MANY)
@given(seeds)
def test_spec_schema(seed):
    rng = random.Random(seed)
    for _ in range(BATCH):
        _safe(parse_spec, spec_dict(rng), "s.yaml")


MODELS = [json.loads((REPO / "examples" / n).read_text())
          for n in ("lanxin.json", "lanxin_norrbin.json", "lanxin_threedof.json",
                    "pod_usv.json")]


def _paths(d, prefix=()):
    yield prefix
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, (*prefix, k))


def mutated_model(rng: random.Random) -> dict:
    d = json.loads(json.dumps(rng.choice(MODELS)))
    for _ in range(rng.randint(1, 3)):
        path = rng.choice([p for p in _paths(d) if p])
        node = d
        for k in path[:-1]:
            node = node[k]
        if not isinstance(node, dict):
            continue
        if rng.random() < 0.3:
            node.pop(path[-1], None)
        else:
            node[path[-1]] = value(rng)
    return d


@_settings(MANY)
@given(seeds)
def test_model_file_schema(seed):
    rng = random.Random(seed)
    for _ in range(BATCH):
        _safe(model_from_dict, mutated_model(rng), "m.json")


RUN_KEYS = ["title", "steps", "models", "validation", "audit", "campaign", "course_keeping",
            "turning_diameter", "timing", "settings", "vessel", "norrbin_fit", "acceptance",
            "summary_text", "truth_definition", "usvid_run"]


@_settings(MANY)
@given(seeds)
def test_run_file_check(seed):
    rng = random.Random(seed)
    for _ in range(BATCH):
        run = {"usvid_run": 1, **{k: value(rng) for k in rng.sample(RUN_KEYS, rng.randint(0, 6))}}
        d = _safe(load_json_text, json.dumps(run, allow_nan=True), "run.json")
        if isinstance(d, dict):
            _safe(check_run, d, "run.json")


READERS = {
    "nmea0183": (NMEA, read_nmea0183),
    "candump": (CANDUMP, read_candump),
    "table_csv": (TABLE_CSV, lambda p: read_trial(p, TABLE_SPECS[1])),
    "table_ws": (TABLE_WS, lambda p: read_trial(p, TABLE_SPECS[0])),
}


def mutate(base: bytes, rng: random.Random) -> bytes:
    b = bytearray(base)
    for _ in range(rng.randint(1, 6)):
        if not b:
            b = bytearray(rng.randbytes(4))
        i = rng.randrange(len(b))
        op = rng.randint(0, 6)
        if op == 0:
            b[i] ^= rng.randint(1, 255)
        elif op == 1:
            del b[i:i + rng.randint(1, 8)]
        elif op == 2:
            b[i:i] = rng.choice([b"\n", b",", b"*", b"$", b"1e308", b"-", b"nan", b"inf",
                                 b"\r", b"\x00", b'"', rng.randbytes(4)])
        elif op == 3:
            del b[i:]
        else:  # duplicate, swap or re-time a line
            lines = bytes(b).split(b"\n")
            j, k = rng.randrange(len(lines)), rng.randrange(len(lines))
            if op == 4:
                lines.insert(k, lines[j])
            elif op == 5:
                lines[j], lines[k] = lines[k], lines[j]
            else:
                lines[j] = rng.choice([b"1e15 ", b"-5 ", b"0 ", b"(1e300) "]) + lines[j]
            b = bytearray(b"\n".join(lines))
    return bytes(b)


@pytest.mark.parametrize("name", sorted(READERS))
def test_text_readers(name, tmp_path):
    base, read = READERS[name]
    p = tmp_path / "log"

    @_settings(FEW)
    @given(seeds)
    def check(seed):
        rng = random.Random(seed)
        for _ in range(10):
            p.write_bytes(mutate(base, rng))
            tr = _safe(read, p)
            if tr is not None:  # what is returned honours the Trial contract
                assert np.all(np.isfinite(tr.t)) and np.all(np.diff(tr.t) > 0)

    check()
    assert [q.name for q in tmp_path.iterdir()] == ["log"]  # nothing written beside the log
