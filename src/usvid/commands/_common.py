"""Helpers shared by the CLI commands: JSON on stdout."""

from __future__ import annotations

from typing import Any

from usvid.files import to_json


def emit_json(obj: Any) -> None:
    """Print exactly one JSON object on stdout."""
    print(to_json(obj))
