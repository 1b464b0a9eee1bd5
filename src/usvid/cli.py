"""usvid command-line interface: a thin typer layer over the library.

Each command lives in ``usvid.commands.<name>`` and registers itself on :data:`app`. Every command
takes ``--json`` and then prints exactly one JSON object on stdout. Exit codes: 0 success,
2 bad usage or bad input (one-line reason on stderr), 3 ``usvid audit`` found error-severity
problems, 1 internal error. Warnings are printed as one line each (``usvid: warning: ...``).
"""

from __future__ import annotations

import sys
import traceback

import typer

from usvid.errors import UsvidError, raised_by_interrupt
from usvid.files import os_reason

app = typer.Typer(
    name="usvid",
    help="Identify, validate and simulate USV manoeuvring models from sea-trial logs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    rich_markup_mode=None,  # help texts carry units in brackets ("[deg]"): no markup parsing
)


def _register_all() -> None:
    import importlib

    from usvid.commands import COMMAND_MODULES

    for name in COMMAND_MODULES:
        module = importlib.import_module(f"usvid.commands.{name}")
        module.register(app)


@app.command("version")
def version() -> None:
    """Print the usvid version."""
    from usvid import __version__

    print(__version__)


def _version_flag(value: bool) -> None:
    if value:
        from usvid import __version__

        print(f"usvid {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(version: bool = typer.Option(  # noqa: B008 - typer's option declaration
        False, "--version", help="Print the usvid version and exit.", is_eager=True,
        callback=_version_flag)) -> None:
    """Identify, validate and simulate USV manoeuvring models from sea-trial logs."""


def _one_line_warning(message: Warning | str, category: type[Warning], filename: str,
                      lineno: int, line: str | None = None) -> str:
    """Warnings on the command line: one clean line, no source location."""
    return f"usvid: warning: {' '.join(str(message).split())}\n"


_register_all()


#: click's base exception as typer uses it (its own copy of click in recent versions)
_CLICK_ERROR = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


_COMMAND: tuple[tuple[int, int], typer.core.TyperGroup] | None = None


def _command() -> typer.core.TyperGroup:
    """The click command tree of :data:`app`, built once (typer rebuilds it from the commands'
    signatures at every ``app(...)`` call: ~20 ms, which every in-process :func:`main` paid),
    and again only when a command or group is registered after the build."""
    global _COMMAND
    key = (len(app.registered_commands), len(app.registered_groups))
    if _COMMAND is None or _COMMAND[0] != key:
        _COMMAND = (key, typer.main.get_command(app))
    return _COMMAND[1]


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns (and exits with) the process exit code."""
    import warnings

    previous = warnings.formatwarning
    warnings.formatwarning = _one_line_warning  # restored on return (main() called in-process)
    try:
        return _main(argv)
    finally:
        warnings.formatwarning = previous


def _main(argv: list[str] | None) -> int:

    def done(code: int, message: str | None = None) -> int:
        if message is not None:
            print(message, file=sys.stderr)
        if argv is not None:
            return code
        sys.exit(code)

    try:
        # not standalone: click's usage errors come here (one line below), not as a usage box
        rv = _command()(args=argv, prog_name="usvid", standalone_mode=False)
        code = rv if isinstance(rv, int) and not isinstance(rv, bool) else 0  # typer.Exit(code)
        if code == 130:  # typer turns Ctrl-C into exit code 130, silently
            return done(130, "usvid: interrupted")
        return done(code)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        if code == 130:
            print("usvid: interrupted", file=sys.stderr)
        if argv is not None:
            return code
        raise
    except _CLICK_ERROR as exc:  # wrong option type, missing argument, unknown option
        if type(exc).__name__ == "NoArgsIsHelpError":  # plain `usvid`: the help, as before
            return done(exc.exit_code, exc.format_message())
        where = f" (see '{exc.ctx.command_path} --help')" if getattr(exc, "ctx", None) else ""
        return done(exc.exit_code if exc.exit_code else 2,
                    "usvid: error: " + " ".join(exc.format_message().split()) + where)
    except typer.Abort:
        return done(130, "usvid: interrupted")
    except UsvidError as exc:
        return done(2, "usvid: error: " + " ".join(str(exc).split()))
    except KeyboardInterrupt:
        return done(130, "usvid: interrupted")
    except OSError as exc:  # the environment (a file vanished, permissions, disk): not a bug
        if exc.filename is not None and not raised_by_interrupt(exc):
            return done(2, f"usvid: error: {exc.filename}: {os_reason(exc)}")
        if raised_by_interrupt(exc):
            return done(130, "usvid: interrupted")
        traceback.print_exc()
        return done(1, "usvid: internal error (please report with the traceback above)")
    except Exception as exc:  # a bug: say so, with the traceback
        if raised_by_interrupt(exc):
            return done(130, "usvid: interrupted")
        traceback.print_exc()
        return done(1, "usvid: internal error (please report with the traceback above)")
    return 0


if __name__ == "__main__":
    main()
