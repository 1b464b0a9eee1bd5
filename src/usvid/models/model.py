"""A complete vessel model: dynamics + steering servo + vessel particulars (+ provenance).

:class:`VesselModel` is what a model file holds (:mod:`usvid.io.modelfile`) and what the
simulator (:func:`usvid.sim.simulate`) runs. ``dynamics`` is the parameter set of any registered
kind (:mod:`usvid.models.registry`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from usvid.errors import UsvidError
from usvid.models.kind import Dynamics
from usvid.models.registry import kind_of
from usvid.models.servo import FirstOrderServo, IdealServo, SecondOrderServo
from usvid.trial import Vessel

Servo = IdealServo | FirstOrderServo | SecondOrderServo


@dataclass
class VesselModel:
    """Dynamics + servo + vessel (length [m], nominal speed [m/s], ...) + identification record.

    ``identification`` is the provenance dict of the model file (data, method, std errors, fit
    metrics) or ``None``.
    """

    dynamics: Dynamics
    servo: Servo = field(default_factory=IdealServo)
    vessel: Vessel = field(default_factory=Vessel)
    identification: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        kind_of(self.dynamics)  # raises naming the known kinds
        if not isinstance(self.servo, (IdealServo, FirstOrderServo, SecondOrderServo)):
            raise UsvidError(f"VesselModel.servo must be a servo model "
                             f"(got {type(self.servo).__name__})")

    @property
    def kind(self) -> str:
        """The kind name ("nomoto1", "norrbin", "threedof", ...)."""
        return self.dynamics.kind
