"""Fuzzing of the ros2_sqlite3 reader, in a file of its own so that ``--dist loadfile`` spreads the
formats over the workers (tests/test_fuzz_messages.py, which skips without the extras)."""

from test_fuzz_messages import fuzz_message_log, pytestmark  # noqa: F401 - the fuzz marker


def test_ros2_sqlite3_reader(tmp_path):
    fuzz_message_log("ros2_sqlite3", tmp_path)
