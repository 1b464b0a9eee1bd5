"""Helpers shared by the CLI commands: JSON on stdout."""

from __future__ import annotations

from typing import Any


def emit_json(obj: Any) -> None:
    """Print exactly one JSON object on stdout."""
    from usvid.files import to_json  # numpy: loaded when a command runs, not for --help

    print(to_json(obj))
