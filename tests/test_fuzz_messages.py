"""Fuzzing (``fuzz`` marker): the message-log readers (ROS 2 bags in MCAP and SQLite storage,
ROS 1 bags, PX4 ULog, ArduPilot DataFlash and MAVLink tlog) on binary mutations of small valid
logs (flipped bits, overwritten lengths and counters, deleted, duplicated and inserted ranges,
truncation), read with their preset spec, only return a Trial honouring the contract or raise
a UsvidError. See tests/fuzzing.py.

Fewer examples than the other loaders (``N_MESSAGE``): a read costs 2-20 ms (measured without
Hypothesis, 2026-11-23: ROS 2 MCAP 18 ms and SQLite 20 ms, of which ~10 ms is rosbags parsing
the unchanged metadata.yaml with pure-Python ruamel.yaml; ROS 1 6, DataFlash 4.7, tlog 4.5,
ULog 2.4 ms), so 10,000 examples of each would cost ~620 s of CPU, more than the whole suite's
budget; ``USVID_FUZZ_EXAMPLES`` sets every count (``make fuzz``: 10,000 each).
"""

from __future__ import annotations

import os
import random
import shutil

import pytest

from fuzzing import binary_mutate, check_trial, fuzz, put, safe
from usvid.io import read_trial, shipped_spec

pytest.importorskip("rosbags")
pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

from test_io_message_logs import PRESET, WRITERS, small_trial  # noqa: E402

pytestmark = pytest.mark.fuzz
N_MESSAGE = int(os.environ.get("USVID_FUZZ_EXAMPLES", "0")) or {
    "ros2_mcap": 100, "ros2_sqlite3": 100, "ros1": 200, "ulog": 500, "dataflash": 500,
    "tlog": 500}


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_message_log_reader(fmt, tmp_path):
    n = N_MESSAGE if isinstance(N_MESSAGE, int) else N_MESSAGE[fmt]
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
        for p in src.parent.rglob("*"):  # sqlite may leave a journal beside a corrupt db3
            if p.name.endswith(("-journal", "-wal", "-shm")):
                p.unlink()

    fuzz(check, n, f"messages:{fmt}")
    assert sorted(p.name for p in src.parent.rglob("*")) == before  # nothing written
    shutil.rmtree(tmp_path, ignore_errors=True)
