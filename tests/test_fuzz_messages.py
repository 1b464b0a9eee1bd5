"""Fuzzing (``fuzz`` marker): the message-log readers (ROS 2 bags in MCAP and SQLite storage,
ROS 1 bags, PX4 ULog, ArduPilot DataFlash and MAVLink tlog) on binary mutations of small valid
logs (flipped bits, overwritten lengths and counters, deleted, duplicated and inserted ranges,
truncation), read with their preset spec, only return a Trial honouring the contract or raise
a UsvidError, and write nothing beside the log. See tests/fuzzing.py.

As many examples per format as the other loaders (``N_MESSAGE``: 10,000 in ``make fuzz``, the
first 2,000 of them in ``make test``), one test file per format
(this one: ROS 2 MCAP; test_fuzz_messages_<format>.py: the others) so that ``--dist loadfile``
spreads them over the workers. CPU of 10,000 examples (user + sys of the test file less
pytest's start, 2-core development machine shared with other jobs, load 2-3, 2026-11-24):
ROS 2 MCAP 20 s, ROS 2 SQLite 31 s, ROS 1 14 s, ULog 21 s, DataFlash 36 s, tlog 42 s (164 s;
0.4 ms of each example was Hypothesis's own, gone since the engine is a plain seeded loop:
tests/fuzzing.py). Before 2026-11-24 they would have been 166, 176,
65, 19, 30 and 42 s (1,000 examples measured, times 10), when ``make test`` ran 100-500:

- a successful read of a small bag (1 in 10 examples) took 65-90 ms, rosbags re-parsing the
  bag's message definitions and recompiling its deserialisers on every open: the typestore
  is now kept across reads (io.rosbag._reader_class);
- a ROS 2 bag's metadata.yaml, unchanged here, is parsed by rosbags with ruamel.yaml, 8.6 ms
  in pure Python, 1.8 ms with ruamel.yaml.clib (now in the ``ros`` extra; without it the two
  ROS 2 files cost 28 and 43 s): a damaged storage file is now refused before that (86% of
  the MCAP, 67% of the SQLite examples) by rosbags' own first checks, done first
  (io.rosbag._check_storage);
- the DataFlash count was too small to meet a mutated FMT message declaring a message shorter
  than its header, on which pymavlink looped forever (example 2,835 of 10,000; fixed in
  io.ardupilot).
"""

from __future__ import annotations

import random
import shutil

import pytest

from fuzzing import N_EXAMPLES, binary_mutate, check_trial, fuzz, put, safe
from usvid.io import read_trial, shipped_spec

pytest.importorskip("rosbags")
pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

from test_io_message_logs import PRESET, WRITERS, small_trial  # noqa: E402

pytestmark = pytest.mark.fuzz
#: Examples per message-log format (``USVID_FUZZ_EXAMPLES`` sets it, as for every loader).
N_MESSAGE = N_EXAMPLES


def fuzz_message_log(fmt: str, tmp_path, n: int = N_MESSAGE) -> None:
    """``n`` examples of the fuzzing of format ``fmt`` (a key of ``WRITERS``): a 1 s log of
    the small test trial written by the format's writer, the storage file of a ROS 2 bag
    folder mutated (its metadata.yaml kept), read by ``read_trial`` with the preset spec."""
    src = WRITERS[fmt](small_trial(T=1.0), tmp_path)
    if src.is_dir():  # a ROS 2 bag folder: the storage file is mutated, metadata.yaml kept
        (f,) = [x for x in src.iterdir() if x.suffix in (".mcap", ".db3")]
    else:
        f = src
    base = f.read_bytes()
    spec = shipped_spec(PRESET[fmt])
    before = sorted(p.name for p in src.parent.rglob("*"))

    def check(rng: random.Random) -> None:
        put(f, binary_mutate(base, rng))
        check_trial(safe(read_trial, src, spec))

    fuzz(check, n, f"messages:{fmt}")
    # nothing written (rosbags and the storage check open sqlite3 files immutable: no journal)
    assert sorted(p.name for p in src.parent.rglob("*")) == before
    shutil.rmtree(tmp_path, ignore_errors=True)


def test_ros2_mcap_reader(tmp_path):
    fuzz_message_log("ros2_mcap", tmp_path)
