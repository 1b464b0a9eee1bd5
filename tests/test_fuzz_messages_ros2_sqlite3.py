"""Fuzzing (``fuzz`` marker): the ROS 2 bag (SQLite storage) reader, in a file of its own so that
``--dist loadfile`` spreads the message-log formats over the workers. See
tests/test_fuzz_messages.py and tests/fuzzing.py."""

from __future__ import annotations

import pytest

pytest.importorskip("rosbags")
pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

from test_fuzz_messages import fuzz_message_log  # noqa: E402

pytestmark = pytest.mark.fuzz


def test_ros2_sqlite3_reader(tmp_path):
    fuzz_message_log("ros2_sqlite3", tmp_path)
