"""The kind of vehicle a robot log comes from (ArduPilot, PX4 and MAVLink logs say it), named in
the output: usvid's models are ship models, and a multicopter's or a fixed-wing aircraft's log
read as a boat's gives headings and positions but no meaningful manoeuvring model.

The MAVLink ``MAV_TYPE`` enumeration (common.xml) gives the kind for MAVLink HEARTBEATs and the
PX4 parameter ``MAV_TYPE``; ArduPilot DataFlash logs name their firmware in a ``MSG`` message
and, for Rover, the frame in the parameter ``FRAME_CLASS`` (2 = boat).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from usvid.trial import Finding

#: MAVLink MAV_TYPE -> (kind, surface vessel?).
MAV_TYPES: dict[int, tuple[str, bool]] = {
    1: ("fixed-wing aircraft", False), 2: ("multicopter", False),
    3: ("multicopter", False), 4: ("helicopter", False), 7: ("airship", False),
    8: ("free balloon", False), 9: ("rocket", False), 10: ("ground rover", False),
    11: ("surface boat", True), 12: ("submarine", False), 13: ("multicopter", False),
    14: ("multicopter", False), 15: ("multicopter", False), 16: ("flapping wing", False),
    19: ("VTOL aircraft", False), 20: ("VTOL aircraft", False), 21: ("VTOL aircraft", False),
    22: ("VTOL aircraft", False), 23: ("VTOL aircraft", False), 24: ("VTOL aircraft", False),
    25: ("VTOL aircraft", False), 29: ("multicopter", False), 35: ("helicopter", False),
}


def mav_type_kind(mav_type: int, where: str) -> dict[str, Any] | None:
    """``{"kind", "surface_vessel", "detail"}`` of a MAVLink MAV_TYPE (None: unknown)."""
    k = MAV_TYPES.get(int(mav_type))
    if k is None:
        return None
    return {"kind": k[0], "surface_vessel": k[1], "detail": f"{where} {int(mav_type)}"}


def vehicle_finding(path: Path, vehicle: dict[str, Any] | None) -> Finding | None:
    """A warning naming a vehicle that is not a surface vessel (``not_a_vessel``); an info
    finding ``vehicle`` for a boat or a rover-or-boat log; None when the kind is unknown."""
    if vehicle is None:
        return None
    kind, detail = vehicle["kind"], vehicle.get("detail") or ""
    if vehicle.get("surface_vessel") is False:
        return Finding(
            "warning", "not_a_vessel",
            f"{path.name}: the log is from a {kind} ({detail}), not a surface vessel: usvid "
            "reads its heading, positions and outputs, but its manoeuvring models are ship "
            "models - identified parameters and manoeuvre metrics say nothing about this "
            "vehicle", data=dict(vehicle))
    return Finding("info", "vehicle", f"{path.name}: the log is from a {kind} ({detail})",
                   data=dict(vehicle))
