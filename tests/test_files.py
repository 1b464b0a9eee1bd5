"""Bottom-layer file helpers (usvid.files): atomic writes and JSON."""

import os

from usvid.files import write_atomic


def test_write_atomic_replaces_whole_file_with_ordinary_mode(tmp_path):
    old = os.umask(0o022)
    try:
        p = write_atomic(tmp_path / "sub" / "a.txt", "one")
        write_atomic(p, "two")
    finally:
        os.umask(old)
    assert p.read_text() == "two"
    assert (p.stat().st_mode & 0o777) == 0o644  # as open() would create it under umask 022
    assert [q.name for q in p.parent.iterdir()] == ["a.txt"]  # no temporary file left behind
