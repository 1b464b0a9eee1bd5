"""usvid: sea-trial logs of unmanned surface vehicles -> identified, validated manoeuvring models.

Stages (one sub-package each, data flowing one way): ``usvid.io`` -> ``usvid.prep`` ->
``usvid.identify`` -> ``usvid.models`` / ``usvid.sim`` -> ``usvid.report``; ``usvid.cli`` is a thin
typer layer over them. SI units and radians everywhere inside.
"""

from usvid.errors import UsvidError
from usvid.trial import Finding, Trial, Vessel

__version__ = "0.1.0"

__all__ = ["Finding", "Trial", "UsvidError", "Vessel", "__version__"]
