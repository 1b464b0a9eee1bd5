"""CLI command(s): simulate (not yet implemented)."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Register this module's command(s) on the CLI app (placeholder until implemented)."""
    return None
