"""The CLI shell: help works, unknown commands are usage errors (exit 2)."""

from usvid.cli import main


def test_help_exits_zero(capsys):
    assert main(["--help"]) == 0
    assert "usvid" in capsys.readouterr().out.lower()


def test_unknown_command_is_usage_error():
    assert main(["no-such-command"]) == 2


def test_write_atomic_replaces_whole_file_with_ordinary_mode(tmp_path):
    import os

    from usvid.commands._common import write_atomic

    old = os.umask(0o022)
    try:
        p = write_atomic(tmp_path / "sub" / "a.txt", "one")
        write_atomic(p, "two")
    finally:
        os.umask(old)
    assert p.read_text() == "two"
    assert (p.stat().st_mode & 0o777) == 0o644  # as open() would create it under umask 022
    assert [q.name for q in p.parent.iterdir()] == ["a.txt"]  # no temporary file left behind
