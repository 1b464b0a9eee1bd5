"""Fuzzing of the ros1 reader, in a file of its own so that ``--dist loadfile`` spreads the
formats over the workers (tests/test_fuzz_messages.py, which skips without the extras)."""

from test_fuzz_messages import fuzz_message_log, pytestmark  # noqa: F401 - the fuzz marker


def test_ros1_reader(tmp_path):
    fuzz_message_log("ros1", tmp_path)
