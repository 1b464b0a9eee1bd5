"""The CLI shell: help works, unknown commands are usage errors (exit 2)."""

from usvid.cli import main


def test_help_exits_zero(capsys):
    assert main(["--help"]) == 0
    assert "usvid" in capsys.readouterr().out.lower()


def test_unknown_command_is_usage_error():
    assert main(["no-such-command"]) == 2

