"""usvid: sea-trial logs of unmanned surface vehicles -> identified, validated manoeuvring models.

Stages (one sub-package each, data flowing one way): ``usvid.io`` -> ``usvid.prep`` ->
``usvid.identify`` -> ``usvid.models`` / ``usvid.sim`` -> ``usvid.report``; ``usvid.cli`` is a thin
typer layer over them. SI units and radians everywhere inside.
"""

from typing import Any

from usvid.errors import UsvidError

__version__ = "0.1.0"

__all__ = ["Finding", "Trial", "UsvidError", "Vessel", "__version__"]


def __getattr__(name: str) -> Any:
    """``usvid.Trial``, ``usvid.Vessel``, ``usvid.Finding`` on first use (PEP 562): importing
    usvid (and starting the CLI) does not load pandas."""
    if name in ("Finding", "Trial", "Vessel"):
        from usvid import trial

        return getattr(trial, name)
    raise AttributeError(f"module 'usvid' has no attribute {name!r}")
