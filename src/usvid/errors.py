"""One exception family for usvid.

Every error caused by the user's input (a bad log, a bad format spec, a bad model file, data that
cannot support an estimate) is a :class:`UsvidError`; the CLI maps it to exit code 2 with its
message on one line of stderr. Anything else escaping is a bug (exit code 1).
"""

from __future__ import annotations


class UsvidError(Exception):
    """Base class of every error usvid raises on bad input or bad usage."""


class FormatSpecError(UsvidError):
    """A trial format spec (YAML) is malformed or names something unknown."""


class LogReadError(UsvidError):
    """A log file cannot be read at all (wholly bad, empty, unreadable)."""


class ModelFileError(UsvidError):
    """A model file (JSON, ``usvid_model: 1``) fails validation."""


class IdentificationError(UsvidError):
    """The data cannot support the requested estimate (too short, no excitation, collinear)."""


class SimulationError(UsvidError):
    """A simulation request is inconsistent (bad step, bad manoeuvre definition)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C (temporary files removed, clean-up run): the CLI raises it
    from its SIGTERM handler and exits with 143 (128 + 15) instead of 130."""


def interrupt_exit_code(exc: BaseException) -> int | None:
    """143 when ``exc`` is, or was raised while handling, a :class:`Terminated` (SIGTERM); 130
    for a KeyboardInterrupt (Ctrl-C); None otherwise (see :func:`raised_by_interrupt`)."""
    seen = set()
    e: BaseException | None = exc
    code = None
    while e is not None and id(e) not in seen:
        if isinstance(e, Terminated):
            return 143
        if isinstance(e, KeyboardInterrupt):
            code = 130
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return code


def raised_by_interrupt(exc: BaseException) -> bool:
    """True when ``exc`` is, or was raised while handling, a KeyboardInterrupt (Ctrl-C): an
    interrupt inside compiled code or inside a library's clean-up can surface as another
    exception (an ``OSError``, a ``RuntimeError``) whose cause or context is the interrupt."""
    seen = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False
