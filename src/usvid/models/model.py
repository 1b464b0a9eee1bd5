"""A complete vessel model: dynamics + steering servo + vessel particulars (+ provenance).

:class:`VesselModel` is what a model file holds (``usvid.modelfile``) and what the simulator
(``usvid.sim.simulate``) runs. ``dynamics`` is one of :class:`~usvid.models.response.Nomoto1`,
:class:`~usvid.models.response.Nomoto2`, :class:`~usvid.models.response.Norrbin`,
:class:`~usvid.models.threedof.ThreeDOF`, :class:`~usvid.models.catamaran.Catamaran`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from usvid.errors import UsvidError
from usvid.models.catamaran import Catamaran
from usvid.models.response import Nomoto1, Nomoto2, Norrbin
from usvid.models.servo import FirstOrderServo, IdealServo, SecondOrderServo
from usvid.models.threedof import ThreeDOF
from usvid.trial import Vessel

Dynamics = Nomoto1 | Nomoto2 | Norrbin | ThreeDOF | Catamaran
Servo = IdealServo | FirstOrderServo | SecondOrderServo

KINDS = ("nomoto1", "nomoto2", "norrbin", "threedof", "catamaran")


@dataclass
class VesselModel:
    """Dynamics + servo + vessel (length [m], nominal speed [m/s]) + identification record.

    ``identification`` is the free-form provenance dict of the model file (data, method, std
    errors, fit metrics) or ``None``.
    """

    dynamics: Dynamics
    servo: Servo = field(default_factory=IdealServo)
    vessel: Vessel = field(default_factory=Vessel)
    identification: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if getattr(self.dynamics, "kind", None) not in KINDS:
            raise UsvidError(f"VesselModel.dynamics must be one of {', '.join(KINDS)} "
                             f"(got {type(self.dynamics).__name__})")
        if getattr(self.servo, "kind", None) not in ("ideal", "first_order", "second_order"):
            raise UsvidError(f"VesselModel.servo must be a servo model "
                             f"(got {type(self.servo).__name__})")

    @property
    def kind(self) -> str:
        """"nomoto1" | "nomoto2" | "norrbin" | "threedof" | "catamaran"."""
        return self.dynamics.kind

    @property
    def is_response(self) -> bool:
        """True for the constant-speed yaw response models (Nomoto, Norrbin)."""
        return self.kind in ("nomoto1", "nomoto2", "norrbin")
