"""usvid command-line interface: a thin typer layer over the library.

Each command lives in ``usvid.commands.<name>`` and registers itself on :data:`app` when it is
run or asked for its help (``usvid.commands.COMMANDS`` names its module and summary, from which
``usvid --help`` lists the commands without importing one). Every command
takes ``--json`` and then prints exactly one JSON object on stdout. Exit codes: 0 success,
2 bad usage or bad input (one-line reason on stderr), 3 ``usvid audit`` found error-severity
problems, 130 Ctrl-C (SIGINT) and 143 SIGTERM (both: temporary files removed, clusters shut
down, one line ``usvid: interrupted`` / ``usvid: terminated``), 1 internal error. Warnings are
printed as one line each (``usvid: warning: ...``).

Signals at every moment: while this module is imported (before any work) a SIGINT or SIGTERM
exits at once, quietly, with 130 / 143; during a command both raise into it (SIGTERM as
:class:`usvid.errors.Terminated`, a KeyboardInterrupt) so that its clean-up runs; once the exit
code is known, further signals are ignored while the interpreter shuts down (a late Ctrl-C
would otherwise kill it by the signal, exit status -2).
"""

from __future__ import annotations

import gc
import os
import signal
import sys
import threading
from typing import Any


def _exit_at_start_up(signum: int, frame: object) -> None:
    """SIGINT / SIGTERM while the CLI is imported: nothing to clean up yet; exit quietly."""
    os.write(2, b"usvid: interrupted\n" if signum == signal.SIGINT else b"usvid: terminated\n")
    os._exit(130 if signum == signal.SIGINT else 143)


_IN_MAIN_THREAD = threading.current_thread() is threading.main_thread()
_START_UP = ({s: signal.signal(s, _exit_at_start_up) for s in (signal.SIGINT, signal.SIGTERM)}
             if _IN_MAIN_THREAD else {})

import traceback  # noqa: E402 - the start-up handlers above come first

import typer  # noqa: E402

from usvid.errors import (  # noqa: E402
    Terminated,
    UsvidError,
    interrupt_exit_code,
    raised_by_interrupt,
)


class _LazyGroup(typer.core.TyperGroup):
    """usvid's command group: a command's module is imported when the command is run or asked
    for its help, not before (``usvid --help`` lists the commands from
    :data:`usvid.commands.COMMANDS` and imports none of them)."""

    def list_commands(self, ctx: typer.Context) -> list[str]:
        from usvid.commands import COMMANDS

        return [*(n for n in self.commands if n not in COMMANDS), *COMMANDS]

    def get_command(self, ctx: typer.Context, cmd_name: str) -> Any:
        from usvid.commands import COMMANDS

        if cmd_name not in self.commands and cmd_name in COMMANDS:
            _load(COMMANDS[cmd_name][0])
            self.commands.update(typer.main.get_command(app).commands)
        return self.commands.get(cmd_name)

    def resolve_command(self, ctx: typer.Context, args: list[str]) -> Any:
        from usvid.commands import COMMANDS

        if args and args[0] not in COMMANDS and args[0] not in self.commands:
            for name in COMMANDS:  # an unknown command: typer's suggestions see every name
                self.get_command(ctx, name)
        return super().resolve_command(ctx, args)

    def format_commands(self, ctx: typer.Context, formatter: Any) -> None:
        """The commands and their summaries, as click lists them (the summary of a command not
        imported made from its sentence in :data:`usvid.commands.COMMANDS`)."""
        from usvid.commands import COMMANDS

        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = []
        for name in names:
            cmd = self.commands.get(name) or typer.core.TyperCommand(name, help=COMMANDS[name][1])
            if not cmd.hidden:
                rows.append((name, cmd.get_short_help_str(limit)))
        with formatter.section("Commands"):
            formatter.write_dl(rows)


app = typer.Typer(
    name="usvid",
    cls=_LazyGroup,
    help="Identify, validate and simulate USV manoeuvring models from sea-trial logs.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    rich_markup_mode=None,  # help texts carry units in brackets ("[deg]"): no markup parsing
)


def _load(module_name: str) -> None:
    """Import the command module ``usvid.commands.<module_name>`` and register its command."""
    import importlib

    module = importlib.import_module(f"usvid.commands.{module_name}")
    if module_name not in _LOADED:
        _LOADED.add(module_name)
        module.register(app)


#: Command modules registered on :data:`app`.
_LOADED: set[str] = set()


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


for _sig, _handler in _START_UP.items():  # the CLI is imported: back to the usual handlers
    if _handler is None:  # (a handler not set from Python: Python's own defaults)
        _handler = signal.default_int_handler if _sig == signal.SIGINT else signal.SIG_DFL
    signal.signal(_sig, _handler)

#: The line printed for each interrupt exit code.
_INTERRUPTED = {130: "usvid: interrupted", 143: "usvid: terminated"}


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


#: Set when SIGTERM arrived during the command (typer reports any interrupt as exit code 130).
_TERMINATED = threading.Event()


def _on_sigterm(signum: int, frame: object) -> None:
    """SIGTERM during a command: raised into it as Ctrl-C is (its clean-up runs); a second one
    while it cleans up is ignored."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _TERMINATED.set()
    raise Terminated()


#: Collections of the youngest generation between two full collections (generation 2) in a
#: process of its own (Python's default: 10): see :func:`_short_lived_gc`.
GC_FULL_EVERY = 100


def _short_lived_gc() -> None:
    """The cyclic garbage collector set for a CLI process, which is short-lived and whose heap
    is mostly the libraries it imports (after numba's and the kernels' loading ~130,000 objects
    that live until exit): full collections, each a pass over all of them, are made ten times
    rarer (young garbage is collected as before, and a full collection still runs when the
    objects that survived the younger generations grow by a quarter). Measured on
    ``usvid simulate zigzag`` (KVLCC2, warm numba cache): the collector took 0.25 s of its
    1.4 s of CPU, 0.15 s of them in three full collections."""
    gen0, gen1, _ = gc.get_threshold()
    gc.set_threshold(gen0, gen1, GC_FULL_EVERY)


def _ignore_signals() -> None:
    """The exit code is known: SIGINT and SIGTERM can no longer change it (nor kill the
    interpreter while it shuts down worker threads and pools)."""
    if threading.current_thread() is threading.main_thread():
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns (and exits with) the process exit code. ``argv`` given: run in
    process (tests), the signal handlers and warning format restored on return."""
    import warnings

    previous = warnings.formatwarning
    warnings.formatwarning = _one_line_warning  # restored on return (main() called in-process)
    handlers = {}
    _TERMINATED.clear()
    if argv is None:  # a process of its own (not a test calling main in process)
        _short_lived_gc()
    if threading.current_thread() is threading.main_thread():
        handlers[signal.SIGTERM] = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        code = _main(argv)
    finally:
        warnings.formatwarning = previous
        if argv is not None:
            for s, h in handlers.items():
                if h is not None:
                    signal.signal(s, h)
    if argv is not None:
        return code
    sys.exit(code)  # (signals are ignored from here: _main's done())


def _main(argv: list[str] | None) -> int:
    """Run the command; its exit code, the one line of an error or interrupt printed."""

    def done(code: int, message: str | None = None) -> int:
        if code == 130 and _TERMINATED.is_set():  # (typer's 130 for any interrupt)
            code, message = 143, _INTERRUPTED[143]
        if message is not None:
            print(message, file=sys.stderr)
        if argv is None:  # a process of its own: the code is final
            _ignore_signals()
            # the interpreter's shut-down need not search the heap for garbage cycles (its full
            # collections over every object cost ~0.2 s of CPU after numba's imports): what
            # must be released at exit is released by the command and the atexit handlers,
            # which still run; the standard streams are still flushed
            gc.freeze()
        return code

    try:
        # not standalone: click's usage errors come here (one line below), not as a usage box
        rv = _command()(args=argv, prog_name="usvid", standalone_mode=False)
        code = rv if isinstance(rv, int) and not isinstance(rv, bool) else 0  # typer.Exit(code)
        if code in _INTERRUPTED:  # typer turns Ctrl-C into exit code 130, silently
            return done(code, _INTERRUPTED[code])
        return done(code)
    except SystemExit as exc:  # sys.exit in a command or library
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        if code == 130 and _TERMINATED.is_set():
            code = 143
        text = exc.code if isinstance(exc.code, str) else None
        return done(code, _INTERRUPTED.get(code) or (text and "usvid: error: " + text))
    except _CLICK_ERROR as exc:  # wrong option type, missing argument, unknown option
        if type(exc).__name__ == "NoArgsIsHelpError":  # plain `usvid`: the help, as before
            return done(exc.exit_code, exc.format_message())
        where = f" (see '{exc.ctx.command_path} --help')" if getattr(exc, "ctx", None) else ""
        return done(exc.exit_code if exc.exit_code else 2,
                    "usvid: error: " + " ".join(exc.format_message().split()) + where)
    except typer.Abort as exc:  # click's Ctrl-C (from the KeyboardInterrupt or Terminated)
        code = interrupt_exit_code(exc) or 130
        return done(code, _INTERRUPTED[code])
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (Terminated)
        code = interrupt_exit_code(exc) or 130
        return done(code, _INTERRUPTED[code])
    except UsvidError as exc:
        if raised_by_interrupt(exc):  # (an error of the clean-up under an interrupt)
            code = interrupt_exit_code(exc) or 130
            return done(code, _INTERRUPTED[code])
        return done(2, "usvid: error: " + " ".join(str(exc).split()))
    except OSError as exc:  # the environment (a file vanished, permissions, disk): not a bug
        if raised_by_interrupt(exc):
            code = interrupt_exit_code(exc) or 130
            return done(code, _INTERRUPTED[code])
        if exc.filename is not None:
            from usvid.files import os_reason  # (here: `usvid --help` does not import files)

            return done(2, f"usvid: error: {exc.filename}: {os_reason(exc)}")
        traceback.print_exc()
        return done(1, "usvid: internal error (please report with the traceback above)")
    except Exception as exc:  # a bug: say so, with the traceback
        if raised_by_interrupt(exc):
            code = interrupt_exit_code(exc) or 130
            return done(code, _INTERRUPTED[code])
        traceback.print_exc()
        return done(1, "usvid: internal error (please report with the traceback above)")
    return 0


if __name__ == "__main__":
    main()
