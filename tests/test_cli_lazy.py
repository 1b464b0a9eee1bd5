"""The CLI imports what its command needs: ``usvid --help`` lists every command from
``usvid.commands.COMMANDS`` without importing a command module, a command imports its own
module only, and the listing is the one click makes from the commands themselves (checked in
fresh interpreters, by the modules loaded; the CPU times are in benchmarks/bench_imports.py)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from usvid.commands import COMMAND_MODULES, COMMANDS


def _run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout


_HELP = ("import io, sys, contextlib\n"
         "import usvid.cli as cli\n"
         "{before}\n"
         "buf = io.StringIO()\n"
         "with contextlib.redirect_stdout(buf):\n"
         "    cli.main({argv!r})\n"
         "print(buf.getvalue())\n"
         "print('LOADED', sorted(m for m in sys.modules if m.startswith('usvid.commands.')))\n")


def test_help_imports_no_command_and_lists_them_as_click_does():
    lazy = _run(_HELP.format(before="", argv=["--help"]))
    text, loaded = lazy.rsplit("LOADED", 1)
    assert loaded.strip() == "[]"
    for name in COMMANDS:
        assert f"\n  {name} " in text
    eager = _run(_HELP.format(before="from usvid.commands import COMMAND_MODULES\n"
                                     "[cli._load(m) for m in COMMAND_MODULES]", argv=["--help"]))
    assert eager.rsplit("LOADED", 1)[0] == text  # every command imported: the same listing


@pytest.mark.parametrize("name", ["simulate", "fit-turning-diameter", "example"])
def test_a_command_imports_its_own_module_only(name):
    out = _run(_HELP.format(before="", argv=[name, "--help"]))
    loaded = eval(out.rsplit("LOADED", 1)[1])
    assert f"usvid.commands.{COMMANDS[name][0]}" in loaded
    others = {f"usvid.commands.{m}" for m in COMMAND_MODULES} - {
        f"usvid.commands.{COMMANDS[name][0]}"}
    assert not others & set(loaded)


def test_each_summary_is_the_first_sentence_of_its_commands_help():
    import typer

    import usvid.cli as cli

    for module in COMMAND_MODULES:
        cli._load(module)
    group = typer.main.get_command(cli.app)
    for name, (_, summary) in COMMANDS.items():
        cmd = group.commands[name]
        for limit in (45, 60, 1000):
            assert (cmd.get_short_help_str(limit)
                    == typer.core.TyperCommand(name, help=summary).get_short_help_str(limit))
    assert set(group.commands) == {"version", *COMMANDS}


def test_a_mistyped_command_is_still_matched_against_every_name(capsys):
    import usvid.cli as cli

    assert cli.main(["fit-turning-diamter"]) == 2
    assert "Did you mean 'fit-turning-diameter'" in capsys.readouterr().err
