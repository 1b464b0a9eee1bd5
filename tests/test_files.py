"""Bottom-layer file helpers (usvid.files): atomic writes, JSON, the input/output guard."""

import os
import stat

import pytest

from usvid.errors import ModelFileError, UsvidError
from usvid.files import (
    InputLimitError,
    OutputError,
    check_input,
    check_outputs,
    read_input_bytes,
    read_input_text,
    special_file,
    write_atomic,
)


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


# ----------------------------------------------------------------------------------------------
# the input/output guard
# ----------------------------------------------------------------------------------------------
def test_special_files_are_never_outputs(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    link = tmp_path / "null-link"
    link.symlink_to("/dev/null")
    for out in (fifo, link, "/dev/null", "/dev/full"):  # (refused before anything is written)
        with pytest.raises(OutputError, match="never replaces a device node"):
            check_outputs([out])
        with pytest.raises(OutputError, match="never replaces a device node"):
            write_atomic(out, "x")
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert special_file(fifo) == "a FIFO (named pipe)" and special_file(link) == \
        "a character device" and special_file(tmp_path / "none") is None


def test_outputs_against_inputs_and_globs(tmp_path):
    log = tmp_path / "logs" / "a.csv"
    log.parent.mkdir()
    log.write_text("x")
    os.link(log, tmp_path / "hard.csv")
    for out in (tmp_path / "hard.csv", tmp_path / "logs" / "." / "a.csv"):
        with pytest.raises(OutputError, match="overwrite the input"):
            check_outputs([out], [log])
    pats = [str(tmp_path / "logs" / "*.csv"), str(tmp_path / "**" / "*.json")]
    check_outputs([tmp_path / "logs" / "out.parquet", tmp_path / "logs" / "sub" / "b.csv"],
                  [log], patterns=pats)  # no glob reads them: fine
    for out in (tmp_path / "logs" / "b.csv", tmp_path / "summary.json",
                tmp_path / "x" / "y" / "groups" / "g.json"):
        with pytest.raises(OutputError, match="read back as an input"):
            check_outputs([out], [log], patterns=pats)


def test_inputs_are_regular_files_read_with_a_bound(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)  # opened for reading it would block: refused by its type
    for p, what in ((fifo, "FIFO"), ("/dev/zero", "character device"), (tmp_path, "folder")):
        with pytest.raises(ModelFileError, match=f"is a {what}"):
            read_input_text(p, "model file", 100, error=ModelFileError)
    with pytest.raises(UsvidError, match="not found"):
        check_input(tmp_path / "none.json", "model file")
    assert check_input(tmp_path, "log", folder=True).st_mode  # a ROS 2 bag is a folder
    big = tmp_path / "big.txt"
    big.write_bytes(b"x" * 101)
    with pytest.raises(InputLimitError, match="101 bytes; a spec has at most 100 bytes"):
        read_input_bytes(big, "spec", 100)
    assert read_input_bytes(big, "spec", 101) == b"x" * 101
    (tmp_path / "u16.yaml").write_bytes("a: 1\n".encode("utf-16"))
    with pytest.raises(UsvidError, match="is UTF-16 text; save the spec as UTF-8"):
        read_input_text(tmp_path / "u16.yaml", "spec", 100)
    (tmp_path / "latin.yaml").write_bytes(b"a: \xe9\n")
    with pytest.raises(UsvidError, match=r"not UTF-8 text \(byte 0xe9 at offset 3\)"):
        read_input_text(tmp_path / "latin.yaml", "spec", 100)
    (tmp_path / "bom.yaml").write_bytes(b"\xef\xbb\xbfa: 1\n")
    assert read_input_text(tmp_path / "bom.yaml", "spec", 100) == "a: 1\n"
