"""Shared engine and input generators of the ``fuzz`` tests (tests/test_fuzz_*.py).

Every loader is fuzzed with :func:`fuzz`: N Hypothesis examples, each one input built by a
seeded generator from the example's 32-bit seed and given to the loader in process; the
example passes when the loader returns (and what it returns honours its contract) or raises a
:class:`usvid.errors.UsvidError` subclass, and fails on any other exception. :func:`fuzz`
counts the examples actually executed and asserts that all N ran.

Why a seed per example rather than Hypothesis strategies for the structure: drawing structured
data through Hypothesis cost 10-20 ms per example on the 2-core development machine, a bare
32-bit seed 0.45-0.65 ms (the engine's own overhead, with shrinking, the example database and
the deadline switched off, numpy's global generator left alone: see :func:`fuzz`), against
0.1-4 ms for the loaders themselves. A failure is reported with its seed;
``random.Random(f"{salt}:{seed}")`` regenerates the input.

The costliest loaders run their examples in two test files of half the examples each, with
different salts (``test_fuzz_X.py`` and ``test_fuzz_X_2.py``): ``pytest --dist loadfile`` keeps
a file on one worker, and halves balance the two workers of ``make test``.
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import warnings
from collections.abc import Callable

import numpy as np
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from usvid.errors import UsvidError

#: Hypothesis examples per loader in ``make test`` (at least 10,000 each), the
#: costliest loaders' split over two files (:func:`halves`), the message-log formats one file
#: each (tests/test_fuzz_messages.py). ``USVID_FUZZ_EXAMPLES`` sets the count for all.
N_EXAMPLES = int(os.environ.get("USVID_FUZZ_EXAMPLES", "10000"))


def halves(n: int = N_EXAMPLES) -> tuple[int, int]:
    """``n`` examples as the counts of a loader's two test files (together exactly ``n``)."""
    return n - n // 2, n // 2


@contextlib.contextmanager
def _numpy_random_left_alone():
    """Hypothesis saves, seeds and restores numpy's global generator around every example
    (0.13-0.15 ms of its 0.6 ms per example here, measured): needless for the loaders, which
    draw no random numbers, and for the inputs, drawn from the example's own ``Random``. The
    generator is taken off Hypothesis's list for the run and put back; a Hypothesis without
    that (private) list leaves it managed, which changes only the speed."""
    try:
        from hypothesis.internal import entropy

        entropy.get_seeder_and_restorer(0)  # registers numpy's generator when not yet done
        rng = entropy.NP_RANDOM
        keys = [k for k, r in list(entropy.RANDOMS_TO_MANAGE.items()) if r is rng]
        for k in keys:
            del entropy.RANDOMS_TO_MANAGE[k]
    except Exception:  # noqa: BLE001 - another Hypothesis: leave its bookkeeping as it is
        keys = []
    try:
        yield
    finally:
        for k in keys:
            entropy.RANDOMS_TO_MANAGE[k] = rng


def fuzz(check: Callable[[random.Random], None], n: int, salt: str) -> int:
    """Run ``check(rng)`` on ``n`` Hypothesis examples (generation phase only, derandomised:
    the same inputs on every run); ``rng`` is seeded from the example's seed and ``salt`` (so
    two tests of one loader draw different inputs). Returns the number of examples run, which
    is asserted to be ``n``."""
    count = 0

    @settings(max_examples=n, deadline=None, derandomize=True, database=None,
              phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(st.integers(0, 2**32 - 1))
    def run(seed: int) -> None:
        nonlocal count
        count += 1
        check(random.Random(f"{salt}:{seed}"))

    with _numpy_random_left_alone():
        run()
    assert count == n, f"{salt}: {count} examples run, {n} asked"
    return count


def safe(fn: Callable, *args, **kwargs):
    """``fn(*args)``; a :class:`UsvidError` (one bounded message) gives ``None``; any other
    exception propagates (and fails the example)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn(*args, **kwargs)
    except UsvidError as exc:
        msg = str(exc)
        assert msg and len(msg) < 5000, msg[:200]
        return None


def put(path, data: bytes) -> None:
    """Overwrite ``path`` with ``data`` in place. Not ``Path.write_bytes``: on ext4 (default
    ``auto_da_alloc``) opening an existing file with O_TRUNC and rewriting it forces a flush,
    6-7 ms per example on the development machine against 0.1 ms for this."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        os.write(fd, data)
        os.ftruncate(fd, len(data))
    finally:
        os.close(fd)


def check_trial(tr) -> None:
    """The Trial contract: finite, strictly increasing time; positive integer reject counts."""
    if tr is None:
        return
    t = tr.t
    assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
    assert all(isinstance(v, int) and v > 0 for v in tr.rejected.values())


# -- structured values ---------------------------------------------------------------------------
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


def yaml_text(rng: random.Random) -> str:
    """A hostile YAML document. Alias bombs cost 30-50 ms each to refuse (100,000 expanded
    nodes), 25-35 times the other documents: 1 in 160 documents (~60 of 10,000), the deep ones
    (refused at the node bound) 1 in 4 of those; the other kinds in proportions 3:3:14:19."""
    k = 0 if rng.random() < 1 / 160 else rng.randint(1, 39)
    if k == 0:
        levels = rng.randint(1, 9) if rng.random() < 0.25 else rng.randint(1, 5)
        return "a0: &a0 [1,1,1,1,1,1,1,1,1]\n" + "".join(
            f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]\n" for i in range(1, levels))
    if k <= 3:
        return "a: " + "[" * (n := rng.randint(0, 200)) + "]" * n
    if k <= 6:
        return rng.choice(["!!python/object/apply:os.system [x]", "&a [*a]", "a: *b",
                           "%YAML 9\n", "a: !!binary x", "\x07", "a:\n\t- b", "? [a]\n: b",
                           "a: !!float 1e999", "a: !!int 0x" + "f" * 400, "--- a\n--- b",
                           "a: &x 1\nb: *x\nc: <<: *x"])
    text = json.dumps(value(rng), allow_nan=True)
    if k <= 20 and text:
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(text) + 1)
            text = text[:i] + rng.choice([":", "&x ", "*x", "- ", "\n  ", "!!", "|", "\x00",
                                          "? ", "<<: ", "\t", "#", "'", '"']) + text[i:]
    return text


# -- format specs ---------------------------------------------------------------------------------
SPEC_KEYS = ["reader", "delimiter", "skip_rows", "header", "comment", "encoding", "sheet",
             "non_monotonic", "time_source", "n2k_format", "vessel", "description", "variants"]
COLUMN_KEYS = ["col", "unit", "sign", "scale", "offset", "optional", "topic", "field",
               "convert", "frame", "pwm", "instance"]
READER_NAMES = ["table", "excel", "parquet", "nmea0183", "nmea2000", "rosbag", "ulog",
                "dataflash", "tlog"]
GOOD = {"delimiter": [",", ";", "\t", " ", None], "skip_rows": [0, 1, 3], "header": [True, False],
        "encoding": ["utf-8", "latin-1", "utf-16", "base64", "rot13", "zlib", "nope"],
        "unit": ["s", "deg", "rad", "deg/s", "kn", "rpm", "m", "1", "furlong"],
        "non_monotonic": ["sort", "reject", "error", "x"]}


def _field(rng: random.Random, key: str):
    if key in GOOD and rng.random() < 0.6:
        return rng.choice(GOOD[key])
    return value(rng)


def spec_dict(rng: random.Random) -> dict:
    d: dict = {"reader": rng.choice(READER_NAMES) if rng.random() < 0.9 else value(rng)}
    for k in rng.sample(SPEC_KEYS, rng.randint(0, 4)):
        d[k] = _field(rng, k)
    if rng.random() < 0.8:
        d["columns"] = {rng.choice(["t", "psi", "r", "delta", "lat", "n", "?"]):
                        ({k: _field(rng, k) for k in rng.sample(COLUMN_KEYS, rng.randint(0, 5))}
                         if rng.random() < 0.8 else value(rng))
                        for _ in range(rng.randint(0, 4))}
    return d


# -- model files ----------------------------------------------------------------------------------
def _paths(d, prefix=()):
    yield prefix
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, (*prefix, k))


def mutated_model(base: dict, rng: random.Random) -> dict:
    """``base`` (a valid model file) with 1-3 fields replaced by hostile values or removed."""
    d = json.loads(json.dumps(base))
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


# -- bytes ---------------------------------------------------------------------------------------
def mutate(base: bytes, rng: random.Random, max_ops: int = 6) -> bytes:
    """1..max_ops byte- and line-level mutations of ``base``: bit flips, deletions, hostile
    insertions (huge and non-finite numbers, separators, NUL, quotes), truncation, duplicated,
    swapped or re-timed lines."""
    b = bytearray(base)
    for _ in range(rng.randint(1, max_ops)):
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
                                 b"\r", b"\x00", b'"', b"\xff\xfe", rng.randbytes(4)])
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


def binary_mutate(base: bytes, rng: random.Random) -> bytes:
    """Mutations of a binary log: flipped bytes, overwritten little-endian integers (0, -1,
    2**31 - 1, huge lengths), deleted, duplicated or inserted ranges, truncation."""
    b = bytearray(base)
    for _ in range(rng.randint(1, 4)):
        if not b:
            b = bytearray(rng.randbytes(8))
        i = rng.randrange(len(b))
        op = rng.randint(0, 5)
        if op == 0:
            b[i] ^= 1 << rng.randrange(8)
        elif op == 1:
            b[i:i + 4] = rng.choice([b"\0\0\0\0", b"\xff\xff\xff\xff", b"\xff\xff\xff\x7f",
                                     b"\x00\x00\x00\x80", rng.randbytes(4)])
        elif op == 2:
            del b[i:i + rng.randint(1, 64)]
        elif op == 3:
            j = rng.randrange(len(b))
            b[i:i] = b[j:j + rng.randint(1, 64)]
        elif op == 4:
            b[i:i] = rng.randbytes(rng.randint(1, 16))
        else:
            del b[max(i, len(b) // 2):]
    return bytes(b)
